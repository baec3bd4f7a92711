"""A layered c′–φ′ slope (a problem no scene ships): Griffiths & Lane's 2:1 slope of scenes/slope_fos.toml,
10 m high on 2 m of foundation, whose lower 6 m (foundation included) have half the cohesion of the upper
6 m; strength reduction against limit equilibrium on the same particles (docs/scenes.md, *Limit
equilibrium*)."""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

import warpsph
from warpsph.scene_toml import parse_scene

SHIPPED = (Path(__file__).resolve().parent.parent / "scenes" / "slope_fos.toml").read_text()
UPPER_LAYER = """
[[bodies]]                       # the slope above y = 6 m, in the shipped soil
name = "upper"
material = "soil"
shape = "polygon"
vertices = [[20, 6], [44, 6], [44, 12], [32, 12]]
"""


def layered_slope():
    """The shipped slope up to its safety phase (no run-out, no probes), its body below y = 6 m in the
    shipped soil with c′ = 5 kPa."""
    text = SHIPPED.split('[[phases]]\nname = "runout"')[0] + UPPER_LAYER
    soil = tomllib.loads(SHIPPED)["materials"]["soil"]
    return parse_scene(text, "layered_slope", {
        "materials.weak": {**soil, "cohesion": 5e3},
        "bodies.slope.material": "weak",
        "bodies.slope.vertices": [[0, 0], [44, 0], [44, 6], [20, 6], [12, 2], [0, 2]],
        "output.usd": False, "output.xdmf": False, "output.fields": ["displacement"],
    })  # fmt: skip


@pytest.mark.slow
def test_layered_slope_against_limit_equilibrium(tmp_path):
    """Δx = 1 m: strength reduction 1.133 ± 0.008 against Bishop's 1.184 and Spencer's 1.183 on the same
    particles (−4.3 %; the homogeneous slope at this spacing reads −2.2 %), the critical circle through
    both layers (centre (14.80, 26.54) m, radius 24.08 m), in 93 970 steps (about 15 min on one core)."""
    safety = warpsph.run_scene(layered_slope(), tmp_path, device="cpu").phases[-1]
    print(f"\nfactor of safety {safety['criterion']:.4f}, limit equilibrium {safety['limit_equilibrium']}")
    assert safety["outcome"] == "converged"
    assert safety["criterion"] == pytest.approx(safety["limit_equilibrium"][0], rel=0.05)
    assert not safety["warnings"]
