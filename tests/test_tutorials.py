"""The tutorials (docs/tutorials/): each one's scene runs, and the numbers the tutorial quotes are
the numbers the run gives."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import warpsph
from warpsph.cli import main

TUTORIALS = Path(__file__).resolve().parent.parent / "docs" / "tutorials"
G = 9.81


def quoted(tutorial: str, *texts: str) -> None:
    page = (TUTORIALS / tutorial).read_text()
    for text in texts:
        assert text in page, text


def test_first_model(tmp_path, capsys):
    scene_path = TUTORIALS / "first_model.toml"
    assert main(["validate", str(scene_path), "--no-estimate"]) == 0
    validated = capsys.readouterr().out
    assert "1369 particles, 1280 virtual points, dt = 0.001077 s" in validated
    quoted("first_model.md", "1369 particles, 1280 virtual points, dt = 0.001077 s")
    wrong_side = scene_path.read_text().replace('position = 0.0\nside = "min"', 'position = 0.0\nside = "max"', 1)
    (tmp_path / "wrong.toml").write_text(wrong_side)
    assert main(["validate", str(tmp_path / "wrong.toml")]) == 2
    assert "bodies.slope: 1288 particles lie beyond boundaries.base" in capsys.readouterr().err
    quoted("first_model.md", "bodies.slope: 1288 particles lie beyond boundaries.base")

    scene = warpsph.load_scene(scene_path)
    scene.output.usd = False
    summary = warpsph.run_scene(scene, tmp_path / "run", device="cpu")
    phase = summary.phases[0]
    assert phase["outcome"] == "converged" and phase["criterion"] < 1e-5
    assert abs(phase["steps"] - 1340) <= 40  # quoted: 1340
    quoted("first_model.md", "converged after 1340 steps")
    results = warpsph.load_results(tmp_path / "run" / "results.h5")
    settlement = results.series("crest_settlement")[1][-1]
    reaction = results.series("base_reaction")[1][-1]
    assert 1e3 * settlement == pytest.approx(12.36, abs=0.01)
    assert reaction / 1e6 == pytest.approx(1.5755, abs=1e-4)
    quoted("first_model.md", "crest settlement 12.36 mm, base reaction 1.5755 MN/m")
    weight = 80.0 * 2000.0 * G  # the polygon's area is 80 m2
    assert reaction / weight - 1 == pytest.approx(0.004, abs=5e-4)
    frame = results.frame(-1)
    i = np.argmin(np.sum((frame["position"][:, :2] - [17.0, 1.0]) ** 2, axis=1))
    assert frame["stress"][i, 1] / 1e3 == pytest.approx(-97.0, abs=0.05)
    quoted("first_model.md", "σ_yy = −97.0 kPa against ρ g z = −98.1 kPa")
    oedometric = 20e6 * 0.7 / (1.3 * 0.4)
    assert 1e3 * 2000.0 * G * 36.0 / (2 * oedometric) == pytest.approx(13.1, abs=0.05)
    quoted("first_model.md", "ρ g H² / (2 M) = 13.1 mm", "26.9 MPa")
