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
    assert len(phase["energy_warnings"]) == 1
    quoted("first_model.md", f"warpsph: warning: phase gravity: {phase['energy_warnings'][0]}")
    results = warpsph.load_results(tmp_path / "run" / "results.h5")
    t, error = results.series("energy_error")
    peak = int(np.argmax(error))
    assert t[peak] == pytest.approx(0.15, abs=0.005) and error[peak] == pytest.approx(546, abs=1)
    assert error[peak:].min() == pytest.approx(447, abs=1) and error[-1] == pytest.approx(479.2, abs=0.1)
    quoted("first_model.md", "546 J/m at t = 0.15 s, then between 447 and 479 J/m")
    settlement = results.series("crest_settlement")[1][-1]
    reaction = results.series("base_reaction")[1][-1]
    assert 1e3 * settlement == pytest.approx(12.36, abs=0.01)
    assert reaction / 1e6 == pytest.approx(1.5808, abs=1e-4)
    quoted("first_model.md", "crest settlement 12.36 mm, base reaction 1.5808 MN/m")
    weight = 80.0 * 2000.0 * G  # the polygon's area is 80 m2
    assert reaction / weight - 1 == pytest.approx(0.007, abs=5e-4)
    quoted("first_model.md", "the base reaction is 1.5808 MN/m, 0.7 % more")
    frame = results.frame(-1)
    i = np.argmin(np.sum((frame["position"][:, :2] - [17.0, 1.0]) ** 2, axis=1))
    assert frame["stress"][i, 1] / 1e3 == pytest.approx(-97.0, abs=0.05)
    quoted("first_model.md", "σ_yy = −97.0 kPa against ρ g z = −98.1 kPa")
    oedometric = 20e6 * 0.7 / (1.3 * 0.4)
    assert 1e3 * 2000.0 * G * 36.0 / (2 * oedometric) == pytest.approx(13.1, abs=0.05)
    quoted("first_model.md", "ρ g H² / (2 M) = 13.1 mm", "26.9 MPa")


@pytest.mark.slow
def test_slope_factor_of_safety(tmp_path):
    """docs/tutorials/slope_factor_of_safety.md: the shipped scenes/slope_fos.toml (about 10 min)."""
    page = "slope_factor_of_safety.md"
    scene = warpsph.load_scene(TUTORIALS.parent.parent / "scenes" / "slope_fos.toml")
    summary = warpsph.run_scene(scene, tmp_path, device="cpu")
    gravity, safety, runout = summary.phases[1:]
    assert gravity["outcome"] == "converged" and abs(gravity["steps"] - 670) <= 20
    quoted(page, "converged after 670 steps")
    for phase in (gravity, runout):
        quoted(page, *(f"warpsph: warning: phase {phase['name']}: {line}" for line in phase["energy_warnings"]))
    assert safety["criterion"] == pytest.approx(1.32, abs=0.01)
    trials = {round(factor, 3): outcome == 1 for factor, outcome, *_ in safety["trials"]}
    assert trials[1.312] and not trials[1.328]
    quoted(page, "factor of safety is **1.32 ± 0.01**", "trial F = 1.312: stands", "trial F = 1.328: fails")
    assert safety["limit_equilibrium"][0] == pytest.approx(1.350, abs=5e-4)
    quoted(page, "Bishop 1.350, Spencer 1.348")
    results = warpsph.load_results(tmp_path / "results.h5")
    names = [phase["name"] for phase in results.phases]
    failed = [i for i in range(len(results.times))
              if results.frame_phases[i] == names.index("safety") and results.frame_attrs(i).get("outcome") == 0]
    frame = results.frame(failed[0])
    moved = np.linalg.norm(frame["displacement"], axis=1)
    sliding = frame["position"][moved > 0.5 * moved.max()]
    assert sliding[:, 0].min() == pytest.approx(12.9, abs=0.05) and sliding[:, 0].max() == pytest.approx(35.9, abs=0.05)
    quoted(page, "sliding mass from x = 12.9 to 35.9 m")
    front, crest = results.series("front")[1], results.series("crest_settlement")[1]
    assert front[-1] == pytest.approx(10.04, abs=0.005) and crest[-1] == pytest.approx(2.21, abs=0.005)
    assert runout["criterion"] == pytest.approx(0.029, abs=0.001)
    quoted(page, "from 12.00 to 10.04 m", "settles 2.21 m", "2.9 % of its peak")


def test_the_tutorials_say_how_warpsph_gets_on_the_path():
    """The tutorials type plain ``warpsph``; the README's install leaves it in .venv/bin, so the README
    and the first tutorial say how to put it on the PATH."""
    root = Path(__file__).resolve().parents[1]
    readme = (root / "README.md").read_text()
    first = (root / "docs" / "tutorials" / "first_model.md").read_text()
    assert "`source .venv/bin/activate` then puts `warpsph` on the shell's PATH" in readme
    assert "source .venv/bin/activate" in first and first.index("activate") < first.index("warpsph validate")


def test_the_first_tutorials_blocks_are_the_whole_scene():
    """The TOML blocks of first_model.md, one after the other, parse to the scene of first_model.toml
    (a scene typed from the page is the one the page runs)."""
    import dataclasses
    import re

    from warpsph.scene_toml import load_scene, parse_scene

    page = (TUTORIALS / "first_model.md").read_text()
    typed = parse_scene("\n".join(re.findall(r"```toml\n(.*?)```", page, re.S)), "first_model")
    shipped = load_scene(TUTORIALS / "first_model.toml")
    assert typed.boundaries == shipped.boundaries and typed.output == shipped.output
    assert dataclasses.replace(typed, source_text="") == dataclasses.replace(shipped, source_text="")
