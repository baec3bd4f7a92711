"""Prescribed velocities (planes and regions), load time functions and reaction probes.

A velocity v₀ imposed on the top of a resting 1D column sends a front with −σ_yy = ρ c v₀ down
(impedance relation of the 1D wave); a reaction probe on the base of a column loaded slowly on its
top measures the applied force.
"""

import numpy as np
import pytest

from warpsph.builder import build
from warpsph.probes import Probes
from warpsph.runner import host_fields
from warpsph.scene import Body, Boundary, Load, Material, Probe, Region, Scene, Simulation, TimeFunction
from warpsph.solver import Solver
from warpsph.verification import sample_column_stress, step_wave_metrics

SOIL = {"soil": Material("soil", density=1700.0, youngs_modulus=30e6, poisson_ratio=0.2)}
V0 = -0.01  # m/s, downward: compression


def column_1d(**parts):
    return Scene(simulation=Simulation(dim=1, dx=0.1), materials=SOIL,
                 bodies=[Body("column", "soil", min=(0, 0, 0), max=(0, 10, 0))],
                 **parts).validate()  # fmt: skip


def test_prescribed_velocity_plane_sends_the_impedance_stress():
    scene = column_1d(boundaries=[Boundary("base", "fixed", "y", 0.0, "min"),
                                  Boundary("piston", "velocity", "y", 10.0, "max", velocity=(0, V0, 0))])  # fmt: skip
    check_impedance(scene, 10.0)


def test_prescribed_velocity_region_sends_the_impedance_stress():
    """A region 0.6 m thick (more than the support 2h) in the middle of a 20 m column, driven
    downward: a compression front runs down from its lower face (and a tension front up); the
    lower part is compared. Thinner pistons excite odd-even modes at their faces (docs/method.md)."""
    scene = column_1d(boundaries=[Boundary("base", "fixed", "y", 0.0, "min"),
                                  Boundary("top", "free", "y", 20.0, "max")],
                      loads=[Load("piston", "velocity", region=Region((-1, 9.95, -1), (1, 10.55, 1)),
                                  velocity=(0, V0, 0))])  # fmt: skip
    scene.bodies[0].max = (0, 20, 0)
    check_impedance(scene, 9.95, cut=9.9)  # the piston's face is its lowest virtual point


def check_impedance(scene, loaded_at, cut=None):
    """Front speed and plateau of the wave below ``loaded_at`` [m], from the stress at y ≤ ``cut``."""
    cut = loaded_at if cut is None else cut
    soil = SOIL["soil"]
    sigma0 = -soil.density * soil.p_wave_speed * V0  # magnitude of the compressive stress behind the front
    times, profiles = sample_column_stress(scene, 0.05)
    below = [(y[y <= cut], s[y <= cut]) for y, s in profiles]
    m = step_wave_metrics(times, below, height=loaded_at, speed=soil.p_wave_speed, sigma0=sigma0, dx=0.1)
    print(f"\nplateau {m.plateau_mean:.4f} of ρ c v₀, front speed error {m.front_speed / soil.p_wave_speed - 1:+.4f}")
    assert abs(m.plateau_mean - 1.0) < 0.03
    assert abs(m.front_speed / soil.p_wave_speed - 1.0) < 0.01


def test_time_functions():
    assert TimeFunction("step", start=0.1)(0.05) == 0.0 and TimeFunction("step", start=0.1)(0.1) == 1.0
    ramp = TimeFunction("ramp", start=0.1, duration=0.2)
    assert [ramp(t) for t in (0.0, 0.2, 0.3, 1.0)] == pytest.approx([0.0, 0.5, 1.0, 1.0])
    table = TimeFunction("table", times=[0.0, 1.0, 2.0], values=[0.0, 2.0, -1.0])
    assert [table(t) for t in (-1.0, 0.5, 1.5, 3.0)] == pytest.approx([0.0, 1.0, 0.5, -1.0])
    assert TimeFunction()(123.0) == 1.0


def test_base_reaction_balances_a_slowly_applied_load():
    """A pressure p ramped on the top over ten periods of the column (quasi-static) and held: the
    base reaction probe measures p W (the force per unit out-of-plane length), time-averaged over
    the last five periods; the tolerance covers the residual ringing of a ramp ten periods long."""
    dx, width, height, p = 0.1, 0.5, 2.0, 10.0e3
    period = 4.0 * height / SOIL["soil"].p_wave_speed  # the column's 1D period 4H/c [s]
    scene = Scene(simulation=Simulation(dim=2, dx=dx), materials=SOIL,
                  bodies=[Body("column", "soil", min=(0, 0, 0), max=(width, height, 0))],
                  boundaries=[Boundary("base", "fixed", "y", 0.0, "min"), Boundary("left", "slip", "x", 0.0, "min"),
                              Boundary("right", "slip", "x", width, "max")],
                  loads=[Load("top", "traction", "y", height, "max", traction=(0, -p, 0),
                              time_function=TimeFunction("ramp", duration=10 * period))],
                  probes=[Probe("reaction", "reaction", "y", boundary="base")]).validate()  # fmt: skip
    model, state = build(scene)
    scratch = model.state()
    scratch.assign(state)
    solver, probes, dt = Solver(model), Probes(model), scene.time_step
    n_hold = int(round(5 * period / dt))
    values = []
    for k in range(int(round(10 * period / dt)) + n_hold):
        solver.step(state, scratch, k * dt, dt)
        state, scratch = scratch, state
        values.append(probes.sample(host_fields(model, state))["reaction"])
    mean = np.mean(values[-n_hold:])
    print(f"\nbase reaction {mean:.1f} N/m for an applied {p * width:.1f} N/m "
          f"({100 * (mean / (p * width) - 1):+.2f} %)")
    assert mean == pytest.approx(p * width, rel=0.02)
