"""The factor of safety of Griffiths & Lane's 2:1 slope (scenes/slope_fos.toml, example 1 of
Griffiths & Lane 1999: H = 10 m, φ′ = 20°, c′/(γH) = 0.05; FoS 1.4 by finite elements, 1.38 by
Bishop and Morgenstern's charts), by the scene's own equilibrium and safety phases.

Measured: 1.430 ± 0.008 at Δx = 0.5 m (about 7 min on the 2-core CPU) and at the scene's 1 m: 2.1 %
above the finite elements' 1.4 (the check), 3.6 % above Bishop's 1.38.
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
    assert safety["criterion"] == pytest.approx(1.4, rel=0.03)
