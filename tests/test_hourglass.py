"""The hourglass control (``simulation.hourglass_control``, docs/method.md, *Hourglass control*): pairwise
along each pair, so it keeps the linear and angular momentum of a free body, and the kinetic energy it
removes is booked in the energy ledger as stabilisation."""

import numpy as np
import pytest

from warpsph.builder import build
from warpsph.errors import SceneError
from warpsph.scene import Body, Scene, Simulation
from warpsph.solver import Solver
from warpsph.stability.tools import SOLID
from warpsph.stages.energy import LEDGER, STABILISATION


def noisy_plate_step(alpha: float):
    """One step of a free plate (2 m × 0.4 m, Δx = 0.1 m) with random velocities of 1 mm/s: the start
    state, the state after the step, the model and the solver."""
    scene = Scene(simulation=Simulation(dim=2, dx=0.1, hourglass_control=alpha), materials={"solid": SOLID},
                  bodies=[Body("plate", "solid", min=(0, 0, 0), max=(2, 0.4, 0))]).validate()  # fmt: skip
    model, state = build(scene)
    v = state.particle_v.numpy()
    n = model.particle_count
    v[:n, :2] = 1e-3 * np.random.default_rng(1).standard_normal((n, 2))
    state.particle_v.assign(v)
    out = model.state()
    solver = Solver(model)
    solver.step(state, out, 0.0, scene.time_step)
    return state, out, model, solver


def test_the_control_keeps_momentum_and_books_the_energy_it_removes():
    start, damped, model, solver = noisy_plate_step(0.5)
    _, free, _, bare = noisy_plate_step(0.0)
    n = model.particle_count
    mass = model.particle_mass.numpy()[:n, None]
    change = damped.particle_v.numpy()[:n] - free.particle_v.numpy()[:n]
    x = start.particle_q.numpy()[:n]
    momentum = np.abs((mass * start.particle_v.numpy()[:n]).sum(axis=0)).sum()
    linear = np.abs((mass * change).sum(axis=0)).max()
    angular = np.abs((mass[:, 0] * np.cross(x, change)[:, 2]).sum())
    kinetic = 0.5 * (mass[:, 0] * (np.sum(free.particle_v.numpy()[:n] ** 2, axis=1)
                                   - np.sum(damped.particle_v.numpy()[:n] ** 2, axis=1))).sum()  # fmt: skip
    booked = solver.energy.sums(damped)[LEDGER + STABILISATION] - bare.energy.sums(free)[LEDGER + STABILISATION]
    print(f"\nlargest velocity change {np.abs(change).max():.3g} m/s; momentum change {linear:.3g} (of "
          f"{momentum:.3g}), angular {angular:.3g}; kinetic energy removed {kinetic:.4g} J/m, booked beyond the surface band's {booked:.4g}")
    assert np.abs(change).max() > 1e-6
    assert linear < 1e-12 * momentum and angular < 1e-12 * momentum
    assert kinetic > 0.0
    assert booked == pytest.approx(kinetic, rel=1e-3)


def test_the_collocated_scheme_refuses_it():
    scene = Scene(simulation=Simulation(dim=2, scheme="collocated", hourglass_control=0.1), materials={"solid": SOLID},
                  bodies=[Body("plate", "solid", min=(0, 0, 0), max=(1, 0.4, 0))])  # fmt: skip
    with pytest.raises(SceneError, match="simulation.hourglass_control: damps what the two sets' fits miss"):
        scene.validate()
