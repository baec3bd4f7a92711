"""Rigid plates as boundaries (loads of kind "plate", ``stages/plates.py``): a plate on a face, driven by a
total force, passes that force into the soil, a smooth one lets the soil spread under it, and an
impermeable one on saturated soil draws no suction.

Closed forms (no gravity, E_oed = λ + 2G):

- a 1D column of height H on a fixed base under a plate's force P [N/m²]: settlement P H / E_oed and a
  base reaction P;
- a plane-strain block on a slip base and a symmetry plane, its far side free, under a smooth plate over
  its whole top: uniaxial stress σ_yy = −P in plane strain, settlement P H (1 − ν²)/E and the free side's
  displacement P ν (1 + ν) A / E at every height.
"""

import math

import numpy as np
import pytest

from warpsph.errors import SceneError
from warpsph.io import load_results
from warpsph.runner import Run
from warpsph.scene import (Body, Boundary, Drainage, Effects, Load, Material, Output, Phase, PressureSolver, Probe,
                           Region, Scene, Simulation, TimeFunction)

H, E, NU, DENSITY, P = 1.0, 10e6, 0.3, 2000.0, 50e3
E_OED = E * (1 - NU) / ((1 + NU) * (1 - 2 * NU))
TRANSIT = H / math.sqrt(E_OED / DENSITY)
SOIL = Material(name="soil", density=DENSITY, youngs_modulus=E, poisson_ratio=NU)


def series(scene: Scene, out, extra=()) -> dict:
    """The probes' series of a run of ``scene``, and the ``extra`` series named."""
    Run(scene, out).run()
    results = load_results(out / "results.h5")
    return {name: results.series(name) for name in [*(p.name for p in scene.probes), *extra]}


def saturated(hydraulic_conductivity: float) -> Material:
    """A saturated soil (Terzaghi's set A but for its permeability)."""
    return Material("soil", density=1700.0, youngs_modulus=30e6, poisson_ratio=0.2, porosity=0.3, grain_density=2000.0,
                    water_bulk_modulus=100e6, hydraulic_conductivity=hydraulic_conductivity)  # fmt: skip


def plate(**kw) -> Load:
    return Load(name="plate", kind="plate", axis="y", side="max", position=H, **kw)


def test_force_driven_plate_on_a_column_passes_its_force(tmp_path):
    """1D: the base reaction and the settlement, means over the hold after a ramp of 20 transits."""
    end = 60 * TRANSIT
    scene = Scene(
        simulation=Simulation(dim=1, dx=0.05, end_time=end), materials={"soil": SOIL},
        bodies=[Body(name="column", material="soil", min=(0.0, 0.0, 0.0), max=(0.0, H, 0.0))],
        boundaries=[Boundary(name="base", kind="fixed", axis="y", position=0.0, side="min")],
        loads=[plate(force=(0.0, -P, 0.0), time_function=TimeFunction(kind="ramp", duration=20 * TRANSIT))],
        probes=[Probe(name="base", kind="reaction", field="y", boundary="base"),
                Probe(name="top", kind="point", field="displacement_y", point=(0.0, H, 0.0))],
        output=Output(frame_interval=end, probe_every=10, usd=False),
    ).validate()  # fmt: skip
    out = series(scene, tmp_path, ["plate_force_y", "plate_displacement_y"])
    hold = {name: float(np.mean(v[t > end / 2])) for name, (t, v) in out.items()}
    print(f"\nbase {hold['base']:.1f} N/m² for {P:.0f}; settlement {-hold['top'] * 1e3:.4f} mm for "
          f"{P * H / E_OED * 1e3:.4f}; the plate's series: force {hold['plate_force_y']:.1f}, displacement "
          f"{hold['plate_displacement_y'] * 1e3:.4f} mm")  # fmt: skip
    assert hold["base"] == pytest.approx(P, rel=0.01)
    assert -hold["top"] == pytest.approx(P * H / E_OED, rel=0.01)
    assert hold["plate_force_y"] == pytest.approx(-P, rel=0.01)
    assert hold["plate_displacement_y"] == pytest.approx(hold["top"], rel=1e-6)


def test_impermeable_plate_on_a_saturated_column_passes_its_force_to_the_water_and_the_skeleton(tmp_path):
    """1D, saturated and sealed (an impermeable plate over an impermeable base), 50 kPa ramped over 0.05 s:
    the base takes the plate's force within 1 % (its mean over 0.1–0.3 s), the water carries P Q/(Q + E_oed)
    and the column settles P H/(E_oed + Q), the undrained closed forms, within 1 %."""
    soil = saturated(1e-3)
    end = 0.3
    scene = Scene(
        simulation=Simulation(dim=1, dx=0.05, end_time=end), effects=Effects(pore_water=True), materials={"soil": soil},
        bodies=[Body("column", "soil", min=(0, 0, 0), max=(0, H, 0))],
        boundaries=[Boundary("base", "fixed", "y", 0.0, "min")],
        loads=[plate(force=(0, -P, 0), time_function=TimeFunction("ramp", duration=0.05))],
        probes=[Probe(name="base", kind="reaction", field="y", boundary="base"),
                Probe(name="water", kind="point", field="pore_pressure", point=(0, H / 2, 0))],
        output=Output(frame_interval=end, probe_every=10, usd=False),
    ).validate()  # fmt: skip
    out = series(scene, tmp_path, ["plate_displacement_y"])
    hold = {name: float(np.mean(v[t > 0.1])) for name, (t, v) in out.items()}
    q, e_oed = soil.biot_modulus, soil.oedometric_modulus
    print(f"\nbase {hold['base']:.1f} N/m² for {P:.0f}; water {hold['water']:.1f} Pa for {P * q / (q + e_oed):.1f}; "
          f"settlement {-hold['plate_displacement_y'] * 1e3:.5f} mm for {P * H / (e_oed + q) * 1e3:.5f}")  # fmt: skip
    assert hold["base"] == pytest.approx(P, rel=0.01)
    assert hold["water"] == pytest.approx(P * q / (q + e_oed), rel=0.01)
    assert -hold["plate_displacement_y"] == pytest.approx(P * H / (e_oed + q), rel=0.01)


def test_smooth_plate_lets_the_block_spread_under_it(tmp_path):
    """2D equilibrium: the base takes the plate's force within 1 %; the top row moves sideways as the
    mid-plane does (within 2 %), both as the closed form; the settlement within 1 %."""
    scene = Scene(
        simulation=Simulation(dim=2, dx=0.1, end_time=1.0), materials={"soil": SOIL},
        bodies=[Body(name="block", material="soil", min=(0.0, 0.0, 0.0), max=(1.0, H, 0.0))],
        boundaries=[Boundary(name="base", kind="slip", axis="y", position=0.0, side="min"),
                    Boundary(name="axis", kind="symmetry", axis="x", position=0.0, side="min")],
        loads=[plate(force=(0.0, -P, 0.0), contact="smooth")],
        phases=[Phase(name="load", kind="equilibrium", tolerance=1e-6)],
        probes=[Probe(name="base", kind="reaction", field="y", boundary="base"),
                Probe(name="top_x", kind="point", field="displacement_x", point=(1.0, H, 0.0)),
                Probe(name="mid_x", kind="point", field="displacement_x", point=(1.0, H / 2, 0.0)),
                Probe(name="top_y", kind="point", field="displacement_y", point=(0.0, H, 0.0))],
        output=Output(probe_every=50, usd=False),
    ).validate()  # fmt: skip
    last = {name: float(v[-1]) for name, (t, v) in series(scene, tmp_path).items()}
    side = P * NU * (1 + NU) / E
    settlement = P * H * (1 - NU**2) / E
    print(f"\nbase {last['base']:.1f} N/m; side top {last['top_x'] * 1e3:.5f}, mid {last['mid_x'] * 1e3:.5f}, closed "
          f"form {side * 1e3:.5f} mm; settlement {-last['top_y'] * 1e3:.5f} for {settlement * 1e3:.5f} mm")  # fmt: skip
    assert last["base"] == pytest.approx(P, rel=0.01)
    assert last["top_x"] == pytest.approx(last["mid_x"], rel=0.02)
    assert last["mid_x"] == pytest.approx(side, rel=0.01)
    assert -last["top_y"] == pytest.approx(settlement, rel=0.01)


def test_smooth_rectangular_plate_on_a_3d_block(tmp_path):
    """3D equilibrium of a quarter block 0.5 m a side (Δx = 0.1 m) under a smooth plate over its top: the base
    takes the plate's force within 1 %, the free sides move as the closed form ν P L/E within 1 %."""
    side = 0.5
    scene = Scene(
        simulation=Simulation(dim=3, dx=0.1, end_time=1.0), materials={"soil": SOIL},
        bodies=[Body(name="block", material="soil", min=(0.0, 0.0, 0.0), max=(side, side, side))],
        boundaries=[Boundary(name="base", kind="slip", axis="y", position=0.0, side="min"),
                    Boundary(name="x0", kind="symmetry", axis="x", position=0.0, side="min"),
                    Boundary(name="z0", kind="symmetry", axis="z", position=0.0, side="min")],
        loads=[Load(name="plate", kind="plate", axis="y", side="max", position=side, contact="smooth",
                    force=(0.0, -P * side**2, 0.0))],
        phases=[Phase(name="load", kind="equilibrium", tolerance=1e-6)],
        probes=[Probe(name="base", kind="reaction", field="y", boundary="base"),
                Probe(name="side_x", kind="point", field="displacement_x", point=(side, side, 0.0))],
        output=Output(probe_every=50, usd=False),
    ).validate()  # fmt: skip
    last = {name: float(v[-1]) for name, (t, v) in series(scene, tmp_path, ["plate_displacement_y"]).items()}
    print(f"\nbase {last['base']:.1f} N for {P * side**2:.0f}; side {last['side_x'] * 1e3:.5f} mm for "
          f"{NU * P * side / E * 1e3:.5f}; settlement {-last['plate_displacement_y'] * 1e3:.5f} for "
          f"{P * side / E * 1e3:.5f}")  # fmt: skip
    assert last["base"] == pytest.approx(P * side**2, rel=0.01)
    assert last["side_x"] == pytest.approx(NU * P * side / E, rel=0.01)
    assert -last["plate_displacement_y"] == pytest.approx(P * side / E, rel=0.01)


def test_plate_free_to_rotate_tilts_under_a_moment_as_in_pure_bending(tmp_path):
    """A plane-strain block 2a × H on a slip base, its sides free, under a smooth plate free to rotate that
    carries a moment M alone: pure bending, σ_yy = 3M x/(2a³), so the plate turns by θ = 3MH/(2E′a³)
    (E′ = E/(1 − ν²)). Within 5 % at Δx = 0.1 m (+3.4 %) after 4 000 damped steps, by which the rotation has
    settled (the block's horizontal translation is unrestrained and keeps the ratio at 2e-4)."""
    a, moment = 0.5, 1000.0
    scene = Scene(
        simulation=Simulation(dim=2, dx=0.1, end_time=1.0), materials={"soil": SOIL},
        bodies=[Body(name="block", material="soil", min=(-a, 0.0, 0.0), max=(a, H, 0.0))],
        boundaries=[Boundary(name="base", kind="slip", axis="y", position=0.0, side="min")],
        loads=[plate(contact="smooth", rotation="free", moment=(0.0, 0.0, moment))],
        phases=[Phase(name="turn", kind="equilibrium", tolerance=1e-6, max_steps=4000)],
        output=Output(probe_every=50, usd=False),
    ).validate()  # fmt: skip
    out = series(scene, tmp_path, ["plate_rotation_z", "plate_force_y"])
    rotation, force = float(out["plate_rotation_z"][1][-1]), float(out["plate_force_y"][1][-1])
    exact = 3 * moment * H / (2 * E / (1 - NU**2) * a**3)
    print(f"\nrotation {rotation * 1e3:.5f} mrad for {exact * 1e3:.5f}; vertical force {force:.2e} N/m")
    assert rotation == pytest.approx(exact, rel=0.05)
    assert abs(force) < 1e-3 * moment / a


def test_impermeable_plate_on_saturated_soil_draws_no_suction(tmp_path):
    """Mandel's geometry (a smooth impermeable plate over the top of a saturated block, its far side
    free and drained), loaded over 0.05 s and held to 0.3 s: no pore pressure below −1 % of the
    plate's stress, and the base takes its force (mean over the hold, where the block rings) within 1 %."""
    soil = saturated(1e-5)
    end = 0.3
    scene = Scene(
        simulation=Simulation(dim=2, dx=0.1, end_time=end), effects=Effects(pore_water=True), materials={"soil": soil},
        bodies=[Body("block", "soil", min=(0, 0, 0), max=(1.0, H, 0))],
        boundaries=[Boundary("base", "slip", "y", 0.0, "min"), Boundary("axis", "symmetry", "x", 0.0, "min"),
                    Boundary("side", "free", "x", 1.0, "max", drainage=Drainage("drained"))],
        loads=[plate(force=(0, -P, 0), contact="smooth", time_function=TimeFunction("ramp", duration=0.05))],
        probes=[Probe(name="base", kind="reaction", field="y", boundary="base"),
                Probe(name="lowest", kind="minimum", field="pore_pressure")],
        output=Output(frame_interval=end, probe_every=20, usd=False),
    ).validate()  # fmt: skip
    out = series(scene, tmp_path)
    t, base = out["base"]
    lowest = float(np.min(out["lowest"][1]))
    held = float(np.mean(base[t > 0.15]))
    print(f"\nlowest pore pressure {lowest:.1f} Pa; base {held:.1f} N/m for {P:.0f}")
    assert lowest >= -0.01 * P
    assert held == pytest.approx(P, rel=0.01)


def column_with(load: Load, effects: Effects = Effects()) -> Scene:
    return Scene(simulation=Simulation(dim=2, dx=0.1, end_time=0.01), effects=effects, materials={"soil": SOIL},
                 bodies=[Body(name="block", material="soil", min=(0.0, 0.0, 0.0), max=(1.0, H, 0.0))],
                 boundaries=[Boundary(name="base", kind="fixed", axis="y", position=0.0, side="min")],
                 loads=[load]).validate()  # fmt: skip


@pytest.mark.parametrize("load, key", [
    (plate(drive="force", velocity=(0, -0.01, 0)), "loads.plate.velocity"),
    (plate(drive="push"), "loads.plate.drive"),
    (plate(base_drainage="drained"), "loads.plate.base_drainage"),
    (plate(region=Region(min=(0, 0, 0), max=(1, 1, 0))), "loads.plate.region"),
    (plate(rotation="tilted"), "loads.plate.rotation"),
    (plate(moment=(0, 0, 1000.0)), "loads.plate.moment"),
])  # fmt: skip
def test_bad_plates_are_refused_at_their_key(load, key):
    with pytest.raises(SceneError) as error:
        column_with(load)
    assert error.value.key == key


def test_a_plate_under_which_no_particle_lies_is_refused(tmp_path):
    scene = column_with(plate(force=(0, -P, 0), extent=Region(min=(2.0, H, 0), max=(3.0, H, 0))))
    with pytest.raises(SceneError) as error:
        Run(scene, tmp_path).run()
    assert error.value.key == "loads.plate.extent"


def test_a_plate_with_a_drained_base_drains_a_consolidation_phase():
    """A consolidation phase needs somewhere for the water to go: a plate's drained base is such a place."""
    soil = saturated(1e-3)

    def scene(base_drainage: str) -> Scene:
        return Scene(simulation=Simulation(dim=1, dx=0.1), effects=Effects(pore_water=True), materials={"soil": soil},
                     bodies=[Body("column", "soil", min=(0, 0, 0), max=(0, H, 0))],
                     boundaries=[Boundary("base", "fixed", "y", 0.0, "min")],
                     loads=[plate(force=(0, -P, 0), base_drainage=base_drainage)],
                     phases=[Phase("settle", "consolidation", duration=1.0)],
                     pressure=PressureSolver(free_surface="impermeable")).validate()  # fmt: skip

    scene("drained")
    with pytest.raises(SceneError) as error:
        scene("impermeable")
    assert error.value.key == "phases.settle.kind" and "plate" in error.value.message
