"""The factor of safety of Griffiths & Lane's 2:1 slope (scenes/slope_fos.toml, example 1 of
Griffiths & Lane 1999: H = 10 m, φ′ = 20°, c′/(γH) = 0.05; FoS 1.4 by finite elements, 1.38 by
Bishop and Morgenstern's charts), by the scene's own equilibrium and safety phases.

Measured at Δx = 0.5 m: 1.352 ± 0.008 in 58 120 steps (about 20 min on the 2-core CPU), 0.8 % below Bishop's method on
the phase's own particles (1.363) and 2.0 % below the charts' 1.38; at the scene's 1 m 1.320.
"""

from __future__ import annotations

from pathlib import Path

import pytest

import warpsph

SCENE = Path(__file__).resolve().parent.parent / "scenes" / "slope_fos.toml"


@pytest.mark.slow
def test_griffiths_lane_slope_factor_of_safety(tmp_path):
    scene = warpsph.load_scene(SCENE)
    scene.simulation.dx = 0.5
    scene.phases = [p for p in scene.phases if p.kind != "dynamic"]
    summary = warpsph.run_scene(scene.validate(), tmp_path, device="cpu")
    safety = summary.phases[-1]
    print(f"\nfactor of safety {safety['criterion']:.4f}; trials {safety['trials']}")
    assert safety["kind"] == "safety" and safety["outcome"] == "converged"
    assert safety["criterion"] == pytest.approx(safety["limit_equilibrium"][0], rel=0.05)
    assert safety["criterion"] == pytest.approx(1.38, rel=0.05)


@pytest.mark.slow
def test_doubling_the_step_cap_leaves_the_factor(tmp_path):
    """The shipped scene at its Δx = 1 m with every trial's cap doubled (48 000 steps): 1.320 ± 0.008 as
    at 24 000, the trial at 1.328 failing at the failure displacement after 55 380 steps where it was
    collapsing at its cap; 123 800 steps in all (about 8 min)."""
    scene = warpsph.load_scene(SCENE)
    scene.phases = [p for p in scene.phases if p.kind != "dynamic"]
    scene.phases[-1].max_steps *= 2
    safety = warpsph.run_scene(scene.validate(), tmp_path, device="cpu").phases[-1]
    assert safety["criterion"] == pytest.approx(1.3203125, abs=1e-6) and safety["resolution"] < 0.01
