"""Saturated columns: at rest under gravity, and in the undrained limit (verification.md).

- Hydrostatic and geostatic column: a saturated column under gravity, drained at its top, started
  from p = ρ_w g depth and σ′_v = −(ρ − ρ_w) g depth, stays at rest for 10 000 steps.
- Undrained limit (k_h = 1e-12 m/s, K_w = 1e12 Pa): a step load is carried by the water,
  p = σ₀ within 1 % after 100 steps a few spacings from the drained face, with no checkerboard,
  at the time step of the drained case (the step does not depend on Q or k).
"""

import numpy as np

from warpsph.builder import build
from warpsph.runner import host_fields
from warpsph.scene import Body, Boundary, Drainage, Effects, Load, Material, Scene, Simulation
from warpsph.solver import Solver


def soil(**kw):
    base = dict(density=1700.0, youngs_modulus=30e6, poisson_ratio=0.2, porosity=0.3, grain_density=2000.0,
                water_bulk_modulus=100e6, hydraulic_conductivity=1e-3)  # fmt: skip
    base.update(kw)
    return Material("soil", **base)


def advance(scene, steps):
    model, state = build(scene)
    scratch = model.state()
    scratch.assign(state)
    solver, dt = Solver(model), scene.time_step
    vmax = 0.0
    for k in range(steps):
        solver.step(state, scratch, k * dt, dt)
        state, scratch = scratch, state
        vmax = max(vmax, float(np.abs(state.particle_v.numpy()[: model.particle_count]).max()))
    return model, state, solver, vmax


def resting_column(height=10.0, g=9.81):
    """1D saturated column under gravity, drained at its free top, started geostatic and hydrostatic."""
    return Scene(simulation=Simulation(dim=1, dx=0.2, gravity=(0, -g, 0)), effects=Effects(pore_water=True),
                 materials={"soil": soil()},
                 bodies=[Body("column", "soil", min=(0, 0, 0), max=(0, height, 0), geostatic=True)],
                 boundaries=[Boundary("base", "fixed", "y", 0.0, "min"),
                             Boundary("top", "free", "y", height, "max", drainage=Drainage("drained"))],
                 ).validate()  # fmt: skip


def rest_errors(steps, height=10.0, g=9.81):
    """Run :func:`resting_column` for ``steps``: (largest speed [m/s], largest pore-pressure error over
    ρ_w g H, largest effective-stress error over (ρ − ρ_w) g H)."""
    model, state, solver, vmax = advance(resting_column(height, g), steps)
    fields = host_fields(model, state)
    depth = height - model.particle_x0[:, 1]
    pressure = np.max(np.abs(fields["pore_pressure"] - 1000.0 * g * depth)) / (1000.0 * g * height)
    stress = np.max(np.abs(fields["stress"][:, 1, 1] + (1700.0 - 1000.0) * g * depth)) / (700.0 * g * height)
    return vmax, pressure, stress


def test_saturated_column_stays_at_rest():
    vmax, pressure, stress = rest_errors(10_000)
    print(f"\n10 000 steps at rest: max speed {vmax:.2e} m/s, pore pressure error {pressure:.2e} of ρ_w g H, "
          f"effective stress error {stress:.2e}")
    assert vmax < 1e-8
    assert pressure < 1e-3
    assert stress < 1e-3


def loaded_column(material, top="drained", sigma0=5000.0, height=10.0, dx=0.1):
    """1D saturated column on a fixed impermeable base under a step load σ₀ [Pa] on its top face,
    whose drainage kind is ``top`` (tests/stability reuses it)."""
    return Scene(simulation=Simulation(dim=1, dx=dx), effects=Effects(pore_water=True), materials={"soil": material},
                 bodies=[Body("column", "soil", min=(0, 0, 0), max=(0, height, 0))],
                 boundaries=[Boundary("base", "fixed", "y", 0.0, "min")],
                 loads=[Load("top", "traction", "y", height, "max", traction=(0, -sigma0, 0),
                             drainage=Drainage(top))]).validate()  # fmt: skip


def test_undrained_limit_carries_the_load_in_the_water():
    sigma0, height, dx = 5000.0, 10.0, 0.1
    undrained = soil(hydraulic_conductivity=1e-12, water_bulk_modulus=1e12)
    scene = loaded_column(undrained, sigma0=sigma0, height=height, dx=dx)
    drained = Scene(simulation=scene.simulation, effects=scene.effects, materials={"soil": soil()},
                    bodies=scene.bodies, boundaries=scene.boundaries, loads=scene.loads)  # fmt: skip
    assert scene.time_step == drained.time_step  # Δt from the drained wave speed, whatever Q and k
    model, state, solver, _ = advance(scene, 100)
    y = model.particle_x0[:, 1]
    p = state.particle_pore_pressure.numpy()[: model.particle_count]
    order = np.argsort(y)
    interior = (y < height - 3 * dx)
    ratio = p[interior] / sigma0
    neighbours = np.abs(np.diff(p[order][y[order] < height - 3 * dx])) / sigma0
    print(f"\nundrained, 100 steps: p/σ₀ in [{ratio.min():.4f}, {ratio.max():.4f}], "
          f"largest neighbour jump {neighbours.max():.2e} σ₀, CG iterations max {max(solver.projection.iterations)}")
    assert np.all(np.abs(ratio - 1.0) < 0.01)
    assert neighbours.max() < 0.01


def test_missed_tolerance_warns_or_stops(tmp_path):
    """One CG iteration cannot reach 1e-12: "warn" warns once and counts the misses in run.json,
    "stop" ends the run with a SimulationError (the CLI's exit code 1)."""
    import json

    import pytest

    from warpsph.errors import SimulationError
    from warpsph.runner import Run
    from warpsph.scene import PressureSolver

    def scene(on_failure):
        return Scene(simulation=Simulation(dim=1, dx=0.2), effects=Effects(pore_water=True),
                     materials={"soil": soil()}, bodies=[Body("column", "soil", min=(0, 0, 0), max=(0, 4, 0),
                                                              pore_pressure=1000.0)],
                     boundaries=[Boundary("base", "fixed", "y", 0.0, "min"),
                                 Boundary("top", "free", "y", 4.0, "max", drainage=Drainage("drained"))],
                     pressure=PressureSolver(tolerance=1e-12, max_iterations=1, on_failure=on_failure),
                     ).validate()  # fmt: skip

    warned = scene("warn")
    warned.output.usd = False
    with pytest.warns(UserWarning, match="missed its tolerance"):
        Run(warned, tmp_path / "warn", end_time=5 * warned.time_step).run()
    record = json.loads((tmp_path / "warn" / "run.json").read_text())
    assert record["pressure_solve"]["missed_tolerance"] == 5 and record["status"] == "finished"
    stopped = scene("stop")
    stopped.output.usd = False
    with pytest.raises(SimulationError, match="missed its tolerance"):
        Run(stopped, tmp_path / "stop", end_time=5 * stopped.time_step).run()
    assert json.loads((tmp_path / "stop" / "run.json").read_text())["status"] == "failed"
