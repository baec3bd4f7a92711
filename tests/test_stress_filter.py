"""The stress filter of the two-set scheme (``simulation.stress_filter`` β, docs/method.md "Stress filter").

A real particle's stress reaches the momentum equation only through its fit to the virtual points, and
that fit does not see an odd-even (checkerboard) pattern of the particles' stresses: without the filter
the pattern stays, with it the pattern decays by the factor (1 − β) per step, while a linear stress
field, which the fits reproduce exactly, is left untouched.
"""

import numpy as np
import pytest
from stability.stability_tools import march

from warpsph.scene import Body, Boundary, Material, Scene, Simulation

SOLID = Material("solid", density=2000.0, youngs_modulus=10e6, poisson_ratio=0.3)
DX, STEPS, AMPLITUDE = 0.1, 40, 1e3


def walled_block(beta: float, **simulation) -> Scene:
    """A 1 m × 1 m elastic block between four fixed walls."""
    walls = [Boundary(f"{axis}{side}", "fixed", axis, 1.0 if side == "max" else 0.0, side)
             for axis in "xy" for side in ("min", "max")]  # fmt: skip
    return Scene(simulation=Simulation(dim=2, dx=DX, stress_filter=beta, **simulation), materials={"solid": SOLID},
                 bodies=[Body("block", "solid", min=(0, 0, 0), max=(1, 1, 0))], boundaries=walls).validate()


def checkerboard_after(beta: float):
    """(interior checkerboard amplitude after STEPS steps / its start, largest speed [m/s])."""
    signs = {}

    def seed(model, state):
        x = model.particle_x0[:, :2]
        signs["s"] = (-1.0) ** np.round(x / DX).sum(axis=1)
        stress = state.particle_stress.numpy()
        stress[: model.particle_count, 0, 0] = AMPLITUDE * signs["s"]
        stress[: model.particle_count, 1, 1] = AMPLITUDE * signs["s"]
        state.particle_stress.assign(stress)

    model, state, _ = march(walled_block(beta), STEPS, setup=seed)
    n = model.particle_count
    x = model.particle_x0[:, :2]
    interior = np.all((x > 2.5 * DX) & (x < 1.0 - 2.5 * DX), axis=1)
    s = state.particle_stress.numpy()[:n]
    amplitude = np.mean(s[interior, 0, 0] * signs["s"][interior]) / AMPLITUDE
    return amplitude, float(np.abs(state.particle_v.numpy()[:n]).max())


def test_without_the_filter_the_checkerboard_stays():
    """The null mode: the virtual points do not see it, so nothing moves and it does not decay."""
    amplitude, speed = checkerboard_after(0.0)
    print(f"\nβ = 0: checkerboard {amplitude:.6f} of its start after {STEPS} steps, largest speed {speed:.2e} m/s")
    assert amplitude == pytest.approx(1.0, abs=1e-3)


@pytest.mark.parametrize("beta", [0.02, 0.05])
def test_the_filter_removes_the_checkerboard_at_its_rate(beta):
    amplitude, speed = checkerboard_after(beta)
    print(f"\nβ = {beta}: checkerboard {amplitude:.6f} of its start after {STEPS} steps, (1 - β)^n = "
          f"{(1 - beta) ** STEPS:.6f}")
    assert amplitude == pytest.approx((1.0 - beta) ** STEPS, rel=0.01)


def geostatic_error(beta: float) -> tuple[float, float]:
    """(largest speed [m/s], largest σ_yy error / ρgH) of a geostatic block at rest after 200 steps:
    slip sides, fixed base, traction-free top plane."""
    boundaries = [Boundary("base", "fixed", "y", 0.0, "min"), Boundary("left", "slip", "x", 0.0, "min"),
                  Boundary("right", "slip", "x", 1.0, "max"), Boundary("top", "free", "y", 1.0, "max")]  # fmt: skip
    scene = Scene(simulation=Simulation(dim=2, dx=DX, gravity=(0.0, -9.81, 0.0), stress_filter=beta),
                  materials={"solid": SOLID}, boundaries=boundaries,
                  bodies=[Body("block", "solid", min=(0, 0, 0), max=(1, 1, 0), geostatic=True)]).validate()  # fmt: skip
    model, state, _ = march(scene, 200)
    n = model.particle_count
    y = model.particle_x0[:, 1]
    weight = SOLID.density * 9.81 * 1.0
    error = state.particle_stress.numpy()[:n, 1, 1] + SOLID.density * 9.81 * (1.0 - y)
    return float(np.abs(state.particle_v.numpy()[:n]).max()), float(np.abs(error).max() / weight)


def test_a_linear_stress_field_is_left_alone():
    """A geostatic block at rest is as much at rest with the filter as without it."""
    (speed0, error0), (speed, error) = geostatic_error(0.0), geostatic_error(0.05)
    print(f"\ngeostatic block, 200 steps: β = 0: {speed0:.2e} m/s, σ_yy error {error0:.2e} ρgH; "
          f"β = 0.05: {speed:.2e} m/s, {error:.2e} ρgH")
    assert speed < 1e-9 and error < 1e-9
