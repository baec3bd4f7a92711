"""A saturated 2D column bounded by planes only (slip sides, fixed base, a drained zero-traction top),
about rest without gravity, at low permeability (docs/method.md, *Pore-pressure roughness damping*).

Without any roughness damping one step has real eigenvalues above 1 at k_h = 1e-8 m/s: the pore
pressure's odd-even part under the drained top plane (1.0015, 3.5 /s) and at the corners of the
base (1.0007, 1.7 /s). The damping near free surfaces does not reach them (there are none); the
interior weight ``pressure.interior_stabilisation`` does. In 1D the same column is stable at every k.
"""

import numpy as np
import pytest

from stability_tools import step_jacobian
from warpsph.scene import Body, Boundary, Drainage, Effects, Load, Material, PressureSolver, Scene, Simulation


def plane_bounded_column(hydraulic_conductivity: float, interior_stabilisation: float) -> Scene:
    """0.4 m × 1 m, Δx = 0.1 m (55 particles), K_w = 2.2e9 Pa."""
    soil = Material("soil", density=2000.0, youngs_modulus=20e6, poisson_ratio=0.3, porosity=0.3,
                    hydraulic_conductivity=hydraulic_conductivity)  # fmt: skip
    return Scene(simulation=Simulation(dim=2, dx=0.1), effects=Effects(pore_water=True), materials={"soil": soil},
                 bodies=[Body("column", "soil", min=(0, 0, 0), max=(0.4, 1.0, 0))],
                 boundaries=[Boundary("base", "fixed", "y", 0.0, "min"), Boundary("left", "slip", "x", 0.0, "min"),
                             Boundary("right", "slip", "x", 0.4, "max")],
                 loads=[Load("top", "traction", "y", 1.0, "max", traction=(0, 0, 0), drainage=Drainage("drained"))],
                 pressure=PressureSolver(interior_stabilisation=interior_stabilisation)).validate()  # fmt: skip


def spectral_radius(hydraulic_conductivity: float, interior_stabilisation: float) -> float:
    scene = plane_bounded_column(hydraulic_conductivity, interior_stabilisation)
    radius = float(np.abs(np.linalg.eigvals(step_jacobian(scene))).max())
    print(f"\nplane-bounded 2D column, k_h = {hydraulic_conductivity:g} m/s, interior θ = {interior_stabilisation:g}: "
          f"spectral radius of a step {radius:.7f}")
    return radius


def test_without_interior_damping_a_plane_bounded_column_is_unstable_at_low_k():
    assert spectral_radius(1e-8, 0.0) == pytest.approx(1.0015, abs=2e-4)


@pytest.mark.parametrize("hydraulic_conductivity", [1e-6, 1e-8])
def test_interior_damping_keeps_a_plane_bounded_column_stable(hydraulic_conductivity):
    assert spectral_radius(hydraulic_conductivity, 0.02) <= 1.0 + 1e-9
