"""scenes/strip_footing.toml: it validates, a short run writes pore pressure to the results and the USD
cache, the ramped footing load raises the pore pressure under the footing above hydrostatic, and the
sealed footing holds its pore pressure while the ground beside it is drained."""

from pathlib import Path

import numpy as np
import pytest

from warpsph.io import load_results
from warpsph.runner import Run
from warpsph.scene_toml import load_scene

STEPS = 60
"""Steps of the short run: t = 0.054 s, about half-way up the 0.1 s load ramp."""
WATER_WEIGHT = 1000.0 * 9.81
"""ρ_w g [N/m³] (scene gravity 9.81 m/s², water table at the ground surface y = 5 m)."""


SCENE = Path(__file__).resolve().parent.parent / "scenes" / "strip_footing.toml"


@pytest.fixture(scope="module")
def scene():
    return load_scene(SCENE)


@pytest.fixture(scope="module")
def short_run(scene, tmp_path_factory):
    """Output directory of a STEPS-step run of the scene."""
    out = tmp_path_factory.mktemp("strip_footing")
    Run(scene, out, end_time=STEPS * scene.time_step).run()
    return out


def test_scene_validates(scene):
    assert scene.effects.pore_water and scene.simulation.dim == 2
    (footing,) = scene.loads
    assert footing.extent.min[0] < 0.0 and footing.extent.max[0] == 1.125  # edge on the virtual column
    assert footing.drainage.kind == "drained" and footing.time_function.kind == "ramp"
    assert footing.drainage.extent.min[0] == footing.extent.max[0]  # impermeable under the footing only
    kinds = {b.name: (b.kind, b.drainage.kind) for b in scene.boundaries}
    assert kinds == {"base": ("slip", "impermeable"), "centre": ("symmetry", "impermeable"),
                     "far_side": ("slip", "impermeable")}  # fmt: skip
    assert scene.bodies[0].geostatic and scene.pressure.water_table == 5.0
    assert {p.name for p in scene.probes} >= {"settlement", "pore_pressure_centre", "base_reaction"}
    assert "pore_pressure" in scene.output.fields and scene.output.usd


def test_short_run_writes_pore_pressure(scene, short_run):
    results = load_results(short_run / "results.h5")
    assert results.steps[-1] == STEPS
    last = results.frame(len(results) - 1)
    assert last["pore_pressure"].shape == (last["position"].shape[0],)
    assert np.all(np.isfinite(last["pore_pressure"]))


def test_usd_cache_has_the_pore_pressure_primvar(short_run):
    from pxr import Usd

    stage = Usd.Stage.Open(str(short_run / "particles.usdc"))
    prim = stage.GetPrimAtPath("/Particles")
    attr = prim.GetAttribute("primvars:pore_pressure")
    assert attr.IsValid()
    value = attr.Get(stage.GetEndTimeCode())
    assert stage.GetEndTimeCode() >= 1 and value is not None and len(value) == len(prim.GetAttribute("points").Get(0))
    ids = prim.GetAttribute("ids").Get(stage.GetEndTimeCode())  # the particles' ids, as in results.h5
    assert list(ids) == list(load_results(short_run / "results.h5").particle_ids)


def test_load_raises_the_pore_pressure_under_the_footing(scene, short_run):
    """Once the ramp has started, the water carries part of the load: the total pore pressure 1.5 m
    under the footing centre exceeds the hydrostatic ρ_w g depth, and the footing area settles."""
    results = load_results(short_run / "results.h5")
    times, pressure = results.series("pore_pressure_centre")
    hydrostatic = WATER_WEIGHT * 1.5
    assert pressure[0] == pytest.approx(hydrostatic, rel=1e-9)  # geostatic start: at rest
    assert pressure[-1] > hydrostatic + 2.0e3  # > 2 kPa excess
    frame, x0 = results.frame(len(results) - 1), results.frame(0)["position"]
    below = (x0[:, 0] <= 1.0) & (x0[:, 1] >= 3.0) & (x0[:, 1] <= 4.0)  # 1–2 m under the footing
    excess = frame["pore_pressure"][below] - WATER_WEIGHT * (5.0 - x0[below, 1])
    assert np.all(excess > 0.0)
    _, settlement = results.series("settlement")
    assert settlement[-1] < 0.0


def test_footing_is_sealed_and_the_ground_beside_it_drained(short_run):
    """Surface particles under the footing (x <= 1 m) carry an excess pore pressure; beside it the
    drained surface holds the hydrostatic pressure, zero at the water table (to within ρ_w g times
    the surface's settlement: the total pressure is reported at the current position)."""
    results = load_results(short_run / "results.h5")
    frame, x0 = results.frame(len(results) - 1), results.frame(0)["position"]
    surface = np.isclose(x0[:, 1], 5.0)
    under, beside = surface & (x0[:, 0] <= 1.0), surface & (x0[:, 0] >= 1.25)
    assert np.all(frame["pore_pressure"][under] > 2.0e3)
    assert np.all(np.abs(frame["pore_pressure"][beside]) < WATER_WEIGHT * 1e-3)  # 1 mm of water
