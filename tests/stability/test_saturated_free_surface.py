"""A saturated column whose top is a free surface, drained or impermeable, about rest
(docs/method.md, *Known limits* and *Pore-pressure roughness damping*).

A drained free surface holds zero pore pressure on its outermost row (Dirichlet rows found from
the fits), and its surface band pushes with the total stress extrapolated to the surface; an
impermeable one gains the pairs it lacks outside in the projection's Δt/ρ part. The projection's
Δt/ρ part acts on pressure increments, so the pore pressure's odd-even part, which the fitted
gradients do not see, is damped only by the Darcy part: without the roughness damping
(``pressure.stabilisation`` = 0), once k ρ/Δt falls below about 0.003 at Courant 0.5, one step
about rest has a real eigenvalue above 1, that part under the surface rising with the top rows'
odd-even velocity and effective stress. The damping (θ = 1, the default) removes it at every k
measured. The solver warns at the first step of a run in a regime measured unstable. A 1D column,
1 m, Δx = 0.1 m, no gravity, K_w = 2.2e9 Pa: k ρ/Δt = 0.047 at k_h = 1e-4 m/s, 0.0047 at 1e-5 m/s.
"""

import json
import warnings

import numpy as np
import pytest

from stability_tools import step_jacobian
from warpsph.builder import build
from warpsph.runner import Run
from warpsph.scene import Body, Boundary, Effects, Material, PressureSolver, Scene, Simulation
from warpsph.solver import Solver

pytestmark = pytest.mark.filterwarnings("ignore:material 'soil' under a free surface")


def column(hydraulic_conductivity: float, free_surface: str, stabilisation: float = 1.0) -> Scene:
    """1D saturated column on a fixed impermeable base; its top is a free surface of that kind."""
    soil = Material("soil", density=2000.0, youngs_modulus=20e6, poisson_ratio=0.3, porosity=0.3,
                    hydraulic_conductivity=hydraulic_conductivity)  # fmt: skip
    return Scene(simulation=Simulation(dim=1, dx=0.1), effects=Effects(pore_water=True), materials={"soil": soil},
                 bodies=[Body("column", "soil", min=(0, 0, 0), max=(0, 1.0, 0))],
                 boundaries=[Boundary("base", "fixed", "y", 0.0, "min")],
                 pressure=PressureSolver(free_surface=free_surface,
                                         stabilisation=stabilisation)).validate()  # fmt: skip


def spectral_radius(hydraulic_conductivity: float, free_surface: str, stabilisation: float = 1.0) -> float:
    scene = column(hydraulic_conductivity, free_surface, stabilisation)
    radius = float(np.abs(np.linalg.eigvals(step_jacobian(scene))).max())
    print(f"\n{free_surface} free surface, k_h = {hydraulic_conductivity:g} m/s, θ = {stabilisation:g}: spectral "
          f"radius of a step {radius:.7f}")
    return radius


@pytest.mark.parametrize("free_surface, hydraulic_conductivity", [("drained", 1e-4), ("impermeable", 1e-5)])
def test_permeable_enough_free_surface_is_stable(free_surface, hydraulic_conductivity):
    assert spectral_radius(hydraulic_conductivity, free_surface) <= 1.0 + 1e-9


@pytest.mark.parametrize("free_surface, hydraulic_conductivity", [
    ("drained", 1e-5), ("drained", 1e-8), ("impermeable", 1e-8), ("impermeable", 1e-12)])  # fmt: skip
def test_less_permeable_free_surface_is_stable(free_surface, hydraulic_conductivity):
    """At 1e-8 m/s (k ρ/Δt = 4.7e-6) a drained surface whose band pushes with the effective stress of its
    own particles keeps a slow real eigenvalue, 1.0000039, stress and pore pressure over the whole
    column."""
    assert spectral_radius(hydraulic_conductivity, free_surface) <= 1.0 + 1e-9


@pytest.mark.parametrize("free_surface, hydraulic_conductivity, radius", [
    ("drained", 1e-6, 1.0036), ("impermeable", 1e-8, 1.0028)])  # fmt: skip
def test_without_the_roughness_damping_the_surface_mode_grows(free_surface, hydraulic_conductivity, radius):
    """What the damping buys: the modes it removes (the drained one 1.0286 at 1e-5 m/s while the band
    pushed with its particles' own effective stress)."""
    assert spectral_radius(hydraulic_conductivity, free_surface, stabilisation=0.0) == pytest.approx(radius, abs=1e-4)


def first_step_warnings(hydraulic_conductivity: float, free_surface: str, stabilisation: float = 1.0) -> list[str]:
    scene = column(hydraulic_conductivity, free_surface, stabilisation)
    model, state = build(scene)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        Solver(model).step(state, model.state(), 0.0, scene.time_step)
    return [str(w.message) for w in caught if "under a free surface" in str(w.message)]


def test_the_unstable_regime_is_announced():
    assert first_step_warnings(1e-12, "drained") == []  # stable with the damping
    assert first_step_warnings(1e-12, "impermeable") == []
    assert first_step_warnings(4e-5, "drained", stabilisation=0.0) == []  # k ρ/Δt = 0.019
    (undamped,) = first_step_warnings(1e-5, "drained", stabilisation=0.0)
    assert "k ρ/Δt = 0.00473 is below 0.015" in undamped and "simulation.courant to 0.16" in undamped
    (impermeable,) = first_step_warnings(1e-6, "impermeable", stabilisation=0.0)
    assert "'impermeable'" in impermeable and "k ρ/Δt = 0.000473 is below 0.01" in impermeable
    assert first_step_warnings(1e-4, "impermeable", stabilisation=0.0) == []


def test_the_run_record_keeps_the_warning(tmp_path):
    scene = column(1e-6, "drained", stabilisation=0.0)
    scene.simulation.end_time = 5 * scene.time_step
    Run(scene, tmp_path).run()
    record = json.loads((tmp_path / "run.json").read_text())
    assert "k ρ/Δt = 0.000473" in record["pressure_solve"]["free_surface_warning"]
