"""Prandtl's strip footing on weightless von Mises soil (scenes/footing_prandtl.toml).

The issue's criterion: the plateau of footing_pressure within 5 % of (2 + π) c_u = 51.4 kPa at the
default resolution (Δx = 1/24 m, B/2 = 0.521 m). Measured (smooth footing, stress filter β = 0.02,
plateau at 25–40 mm settlement): 4.98 c_u at Δx = 1/24 m (3.1 % low); under refinement 4.04 (to 25 mm),
4.90 and 5.06 c_u at Δx = 0.1, 0.05 and 0.025 m, converging from below. Under the footing centre the soil
carries Prandtl's stress (σ_yy = 5.2–5.3 c_u, σ_xx = 3.1 c_u at Δx = 0.05 m); the force is short
where the pressure falls off over the last two to three particles before the edge (scene comments,
docs/method.md "Known limits"). Each Δx runs the scene with its geometry following Δx as the accuracy
study sets it (warpsph.study.metrics.footing_scene: B/2 = last footing particle + Δx/2).
"""

import math
from pathlib import Path

import pytest

from warpsph.io import load_results
from warpsph.runner import Run
from warpsph.scene_toml import load_scene
from warpsph.study.metrics import FOOTING_PRESSURE, FOOTING_SETTLEMENT, FOOTING_WINDOW, footing_plateau, footing_scene

COHESION = 10e3
SCENE = Path(__file__).resolve().parent.parent / "scenes" / "footing_prandtl.toml"
PRANDTL = (2.0 + math.pi) * COHESION

END_TIME = {0.1: 1.5, 0.025: 1.55}
"""Shorter runs [s]: the footing edge's corner mode (its edge particles and the free surface beside
them) blows the run up at 1.66 s (31 mm) at Δx = 0.025 m; at Δx = 0.1 m the footing's pressure breaks
down from 1.55 s (27 mm; 40.5 kPa at 1.48 s, 14 at 1.66 s, then the run blows up at 1.77 s), with the
share's floor at 0.45 and at 0.625 alike; docs/method.md, "Known limits"."""


@pytest.fixture(scope="module")
def plateaus(tmp_path_factory):
    """Run the scene once per Δx on demand (None: the shipped one); {Δx: plateau footing_pressure [Pa]}."""
    found = {}

    def get(dx=None):
        if dx not in found:
            scene = load_scene(SCENE)
            scene.output.usd = False
            if dx is not None:
                scene.simulation.dx = dx
            scene = footing_scene(scene)
            out = tmp_path_factory.mktemp(f"footing_{dx}")
            Run(scene, out, end_time=END_TIME.get(dx)).run()
            results = load_results(out / "results.h5")
            _, pressure = results.series(FOOTING_PRESSURE)
            _, settlement = results.series(FOOTING_SETTLEMENT)
            # the 0.025 m run stops at 28.6 mm
            found[dx], spread, _ = footing_plateau(settlement, pressure, FOOTING_WINDOW)
            print(f"\ndx = {scene.simulation.dx} m: footing plateau {found[dx] / 1e3:.2f} ± {spread / 1e3:.2f} kPa = "
                  f"{found[dx] / COHESION:.3f} c_u ({100 * (found[dx] / PRANDTL - 1):+.1f} % against (2 + pi) c_u)")
        return found[dx]

    return get


@pytest.mark.slow
def test_footing_plateau_is_prandtl(plateaus):
    """The shipped scene (Δx = 1/24 m): 4.983 c_u measured, about 5 min on one core."""
    assert plateaus() == pytest.approx(PRANDTL, rel=0.05)


@pytest.mark.slow
def test_footing_plateau_under_refinement(plateaus):
    """Halving Δx twice moves the plateau toward (2 + π) c_u from below, to within 5 % at Δx = 0.025 m
    (measured: 4.04, 4.90 and 5.06 c_u at Δx = 0.1, 0.05 and 0.025 m, the shipped 1/24 m
    between with 4.98; about 10 min on 2 cores)."""
    coarse, fine, finest = plateaus(0.1), plateaus(0.05), plateaus(0.025)
    assert coarse < fine < plateaus() < finest < PRANDTL
    assert finest == pytest.approx(PRANDTL, rel=0.05)
