"""A drained free surface over a saturated column, about rest (docs/method.md, *Known limits*).

The drained free surface holds zero pore pressure on its outermost row (Dirichlet rows found from
the fits). Once the Darcy part of the projection's Laplacian falls below a few hundredths of its
Δt/ρ part, k ρ/Δt < 0.024 at Courant 0.5, one step about rest has a real eigenvalue above 1: the
pore pressure of the row under the surface rises with the top rows' odd-even velocity and their
effective stress (measured with a 1D NumPy model of the step too: the half step's lagged pressure
force, which the skeleton's stress rate takes up, together with the surface band's weak traction
term; without either the step is stable). The solver warns at the first step of a run in that
regime. A 1D column, 1 m, Δx = 0.1 m, no gravity, K_w = 2.2e9 Pa: k ρ/Δt = 0.047 at
k_h = 1e-4 m/s, 0.0047 at 1e-5 m/s.
"""

import warnings

import numpy as np
import pytest

from stability_tools import expected_failure, step_jacobian
from warpsph.builder import build
from warpsph.scene import Body, Boundary, Effects, Material, Scene, Simulation
from warpsph.solver import Solver

pytestmark = pytest.mark.filterwarnings("ignore:material 'soil' under a drained free surface")


def column(hydraulic_conductivity: float) -> Scene:
    """1D saturated column on a fixed impermeable base; its top is a drained free surface."""
    soil = Material("soil", density=2000.0, youngs_modulus=20e6, poisson_ratio=0.3, porosity=0.3,
                    hydraulic_conductivity=hydraulic_conductivity)  # fmt: skip
    return Scene(simulation=Simulation(dim=1, dx=0.1), effects=Effects(pore_water=True), materials={"soil": soil},
                 bodies=[Body("column", "soil", min=(0, 0, 0), max=(0, 1.0, 0))],
                 boundaries=[Boundary("base", "fixed", "y", 0.0, "min")]).validate()  # fmt: skip


def spectral_radius(hydraulic_conductivity: float) -> float:
    radius = float(np.abs(np.linalg.eigvals(step_jacobian(column(hydraulic_conductivity)))).max())
    print(f"\ndrained free surface, k_h = {hydraulic_conductivity:g} m/s: spectral radius of a step {radius:.6f}")
    return radius


def test_permeable_enough_drained_surface_is_stable():
    assert spectral_radius(1e-4) <= 1.0 + 1e-9


@expected_failure("k ρ/Δt = 0.0047: a real eigenvalue 1.0225 (52 /s), the pore pressure of the row under the "
                  "surface rising with the top rows' odd-even velocity (measured, docs/method.md)")
def test_less_permeable_drained_surface_is_stable():
    assert spectral_radius(1e-5) <= 1.0 + 1e-9


def first_step_warnings(hydraulic_conductivity: float) -> list[str]:
    scene = column(hydraulic_conductivity)
    model, state = build(scene)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        Solver(model).step(state, model.state(), 0.0, scene.time_step)
    return [str(w.message) for w in caught if "drained free surface" in str(w.message)]


def test_the_unstable_regime_is_announced():
    (message,) = first_step_warnings(1e-5)
    assert "k ρ/Δt = 0.00473" in message and "simulation.courant to 0.047" in message
    assert first_step_warnings(2e-4) == []  # k ρ/Δt = 0.095
