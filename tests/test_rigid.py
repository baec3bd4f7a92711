"""Rigid regions (``stages/rigid.py``): a cap on an elastic column, driven by a force or a velocity.

Closed forms (1D column of height H on a fixed base, E_oed = λ + 2G, no gravity):

- a force P [N/m² in 1D] on a rigid cap, applied over 40 wave transits and held: the column's top
  settles u = P H / E_oed and the contact force on the column equals P (means over the hold, where
  the cap rings about its equilibrium);
- the cap driven down at a slow velocity v: the column's stress is σ_yy = −E_oed ε (small strains) and
  the contact force equals the base reaction (quasi-static: the column's inertia is negligible).
"""

import math

import numpy as np
import pytest

from warpsph.errors import SceneError
from warpsph.runner import Run
from warpsph.scene import Body, Boundary, Load, Material, Output, Probe, Region, Scene, Simulation, TimeFunction

H, CAP, E, NU, DENSITY = 1.0, 0.3, 10e6, 0.3, 2000.0
E_OED = E * (1 - NU) / ((1 + NU) * (1 - 2 * NU))
WAVE = math.sqrt(E_OED / DENSITY)
CAP_REGION = Region(min=(-1.0, H + 0.04, -1.0), max=(1.0, H + CAP + 0.01, 1.0))


def capped_column(load: Load, end_time: float, dx: float = 0.05) -> Scene:
    return Scene(
        name="capped_column",
        simulation=Simulation(dim=1, dx=dx, end_time=end_time, artificial_viscosity=0.1),
        materials={"soil": Material(name="soil", density=DENSITY, youngs_modulus=E, poisson_ratio=NU)},
        bodies=[Body(name="column", material="soil", min=(0.0, 0.0, 0.0), max=(0.0, H, 0.0)),
                Body(name="cap", material="soil", min=(0.0, H, 0.0), max=(0.0, H + CAP, 0.0))],  # fmt: skip
        boundaries=[Boundary(name="base", kind="fixed", axis="y", position=0.0, side="min")],
        loads=[load],
        probes=[Probe(name="contact", kind="reaction", field="y", boundary="cap"),
                Probe(name="base", kind="reaction", field="y", boundary="base"),
                Probe(name="top_displacement", kind="point", field="displacement_y", point=(0.0, H, 0.0))],
        output=Output(frame_interval=end_time, probe_every=10, usd=False),
    ).validate()


def probe_series(scene: Scene, tmp_path) -> dict:
    run = Run(scene, tmp_path)
    run.run()
    from warpsph.io import load_results

    results = load_results(tmp_path / "results.h5")
    return {name: results.series(name) for name in ("contact", "base", "top_displacement")}


def held_mean(series, start: float) -> float:
    """Mean of a probe series (time, value) from ``start`` [s] on: the cap rings about equilibrium."""
    t, value = series
    return float(np.mean(value[t >= start]))


def test_force_driven_cap_settles_to_the_elastic_solution(tmp_path):
    pressure = 50e3
    transit = H / WAVE
    load = Load(name="cap", kind="force", region=CAP_REGION, force=(0.0, -pressure, 0.0),
                time_function=TimeFunction(kind="ramp", duration=40 * transit))  # fmt: skip
    series = probe_series(capped_column(load, 80 * transit), tmp_path)
    hold = 40 * transit
    settlement = -held_mean(series["top_displacement"], hold)
    contact, base = -held_mean(series["contact"], hold), held_mean(series["base"], hold)
    exact = pressure * H / E_OED
    print(f"\nsettlement {settlement * 1e3:.4f} mm (closed form {exact * 1e3:.4f}), contact {contact:.1f} N/m², "
          f"base {base:.1f} (means over the hold)")  # fmt: skip
    assert settlement == pytest.approx(exact, rel=0.02)
    assert contact == pytest.approx(pressure, rel=0.01)
    assert base == pytest.approx(pressure, rel=0.01)


def test_velocity_driven_cap_contact_force_balances_the_base(tmp_path):
    speed, transit = 0.01, H / WAVE
    load = Load(name="cap", kind="velocity", region=CAP_REGION, velocity=(0.0, -speed, 0.0),
                time_function=TimeFunction(kind="ramp", duration=10 * transit))  # fmt: skip
    series = probe_series(capped_column(load, 40 * transit), tmp_path)
    contact, base = -series["contact"][1][-1], series["base"][1][-1]
    strain = -series["top_displacement"][1][-1] / H
    print(f"\ncontact {contact:.1f} N/m², base {base:.1f}, E_oed ε = {E_OED * strain:.1f}")
    assert contact == pytest.approx(base, rel=0.02)
    assert contact == pytest.approx(E_OED * strain, rel=0.03)


def test_a_force_load_needs_a_region():
    with pytest.raises(SceneError, match=r"loads\.cap\.region"):
        capped_column(Load(name="cap", kind="force", force=(0.0, -1.0, 0.0)), 1.0)


@pytest.mark.parametrize("contact", ["rough", "smooth"])
def test_smooth_contact_constrains_only_the_drive_direction(contact):
    """A footing on a quarter of a block's top, driven down for 200 steps: rough, its points move as
    one; smooth, their velocities along the drive are the footing's and across it their own. (Run on,
    the soil particle at the footing's edge grows an upward mode, 0.8 m/s after 1 800 steps of a
    0.01 m/s drive, rough or smooth: the footing-edge limit of docs/method.md.)"""
    from warpsph.builder import build
    from warpsph.solver import Solver

    region = Region(min=(-1.0, 0.5 + 0.04, -1.0), max=(0.26, 1.0, 1.0))
    scene = Scene(
        name="footing_contact",
        simulation=Simulation(dim=2, dx=0.05, end_time=1.0, artificial_viscosity=0.3),
        materials={"soil": Material(name="soil", density=DENSITY, youngs_modulus=E, poisson_ratio=NU)},
        bodies=[Body(name="soil", material="soil", min=(0.0, 0.0, 0.0), max=(1.0, 0.5, 0.0)),
                Body(name="footing", material="soil", min=(0.0, 0.5, 0.0), max=(0.25, 0.7, 0.0))],  # fmt: skip
        boundaries=[Boundary(name="base", kind="fixed", axis="y", position=0.0, side="min"),
                    Boundary(name="centre", kind="symmetry", axis="x", position=0.0, side="min")],  # fmt: skip
        loads=[Load(name="footing", kind="velocity", region=region, velocity=(0.0, -0.01, 0.0), contact=contact,
                    time_function=TimeFunction(kind="ramp", duration=0.01))],  # fmt: skip
    ).validate()
    model, state = build(scene)
    scratch = model.state()
    scratch.assign(state)
    solver, dt = Solver(model), scene.time_step
    for k in range(200):
        solver.step(state, scratch, k * dt, dt)
        state, scratch = scratch, state
    v = state.particle_v.numpy()[model.region_particle.numpy()]
    np.testing.assert_allclose(v[:, 1], -0.01, rtol=1e-12)  # 200 steps: past the ramp
    spread = np.ptp(v[:, 0])
    print(f"\n{contact}: spread of the footing's horizontal velocities {spread:.2e} m/s")
    assert spread == 0.0 if contact == "rough" else spread > 1e-4
