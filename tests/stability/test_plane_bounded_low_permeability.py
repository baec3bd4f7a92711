"""Saturated 2D domains bounded by planes only, at low permeability (docs/method.md,
*Pore-pressure roughness damping*): a column (slip sides, fixed base, a drained zero-traction top)
about rest without gravity, and the strip footing's loaded block.

Without any roughness damping one step has real eigenvalues above 1 at k_h = 1e-8 m/s: the pore
pressure's odd-even part under the drained top plane (1.0015, 3.5 /s) and at the corners of the
base (1.0007, 1.7 /s). The damping near free surfaces does not reach them (there are none); its
low-permeability weight away from them (``LOW_PERMEABILITY_WEIGHT`` of ``pressure.stabilisation``,
faded as k ρ/Δt grows) does, and so does an explicit ``pressure.interior_stabilisation``. In 1D the
same column is stable at every k. A footing's load edge at low k stays bounded but above the
criterion (an expected failure below).
"""

import numpy as np
import pytest

from stability_tools import expected_failure, march, step_jacobian
from warpsph.scene import Body, Boundary, Drainage, Effects, Load, Material, PressureSolver, Scene, Simulation


def plane_bounded_column(hydraulic_conductivity: float, interior_stabilisation: float,
                         stabilisation: float = 1.0) -> Scene:
    """0.4 m × 1 m, Δx = 0.1 m (55 particles), K_w = 2.2e9 Pa."""
    soil = Material("soil", density=2000.0, youngs_modulus=20e6, poisson_ratio=0.3, porosity=0.3,
                    hydraulic_conductivity=hydraulic_conductivity)  # fmt: skip
    return Scene(simulation=Simulation(dim=2, dx=0.1), effects=Effects(pore_water=True), materials={"soil": soil},
                 bodies=[Body("column", "soil", min=(0, 0, 0), max=(0.4, 1.0, 0))],
                 boundaries=[Boundary("base", "fixed", "y", 0.0, "min"), Boundary("left", "slip", "x", 0.0, "min"),
                             Boundary("right", "slip", "x", 0.4, "max")],
                 loads=[Load("top", "traction", "y", 1.0, "max", traction=(0, 0, 0), drainage=Drainage("drained"))],
                 pressure=PressureSolver(stabilisation=stabilisation,
                                         interior_stabilisation=interior_stabilisation)).validate()  # fmt: skip


def spectral_radius(hydraulic_conductivity: float, interior_stabilisation: float, stabilisation: float = 1.0) -> float:
    scene = plane_bounded_column(hydraulic_conductivity, interior_stabilisation, stabilisation)
    radius = float(np.abs(np.linalg.eigvals(step_jacobian(scene))).max())
    print(f"\nplane-bounded 2D column, k_h = {hydraulic_conductivity:g} m/s, θ = {stabilisation:g}, interior θ = "
          f"{interior_stabilisation:g}: spectral radius of a step {radius:.7f}")
    return radius


def test_without_roughness_damping_a_plane_bounded_column_is_unstable_at_low_k():
    assert spectral_radius(1e-8, 0.0, stabilisation=0.0) == pytest.approx(1.0015, abs=2e-4)


@pytest.mark.parametrize("interior_stabilisation", [0.0, 0.02], ids=["default", "interior_0.02"])
@pytest.mark.parametrize("hydraulic_conductivity", [1e-6, 1e-8])
def test_roughness_damping_keeps_a_plane_bounded_column_stable(hydraulic_conductivity, interior_stabilisation):
    """By default (the low-permeability weight) and with an explicit interior weight."""
    assert spectral_radius(hydraulic_conductivity, interior_stabilisation) <= 1.0 + 1e-9


def loaded_strip_block(hydraulic_conductivity: float, interior_stabilisation: float, end_time: float) -> Scene:
    """The shipped strip footing (q = 50 kPa over 0.1 s, sealed under the footing, drained beside it,
    geostatic start) on a 3 m × 2 m block at Δx = 0.25 m, water table at its top, less permeable."""
    import re
    from pathlib import Path

    from warpsph.scene_toml import parse_scene

    text = (Path(__file__).parents[2] / "scenes" / "strip_footing.toml").read_text()
    for old, new in [("max = [10.0, 5.0]", "max = [3.0, 2.0]"), ("position = 10.0", "position = 3.0"),
                     ("position = 5.0", "position = 2.0"), ("max = [1.125, 6.0]", "max = [1.125, 3.0]"),
                     ("min = [-1.125, 4.0]", "min = [-1.125, 1.0]"),
                     ("extent = { min = [1.125, 4.0], max = [11.0, 6.0] }",
                      "extent = { min = [1.125, 1.0], max = [4.0, 3.0] }"),
                     ("water_table = 5.0", "water_table = 2.0"),
                     ("hydraulic_conductivity = 1e-3", f"hydraulic_conductivity = {hydraulic_conductivity}"),
                     ("[pressure]", f"[pressure]\ninterior_stabilisation = {interior_stabilisation}")]:  # fmt: skip
        assert old in text, old
        text = text.replace(old, new)
    text = re.sub(r"\[\[probes\]\].*?(?=\n\[\[|\n\[[a-z]|\Z)", "", text, flags=re.S)
    text = re.sub(r"end_time = [0-9.e+-]+", f"end_time = {end_time}", text)
    return parse_scene(text, name="loaded_strip")


@expected_failure("excess 53, 61, 63, 62, 60, 58 kPa at 0.25-1.5 s for q = 50 kPa, largest on the row below the "
                  "face at the footing edge (x = 1 m) to 1 s, then under the footing; docs/method.md, *Known limits*")
def test_loaded_strip_at_low_permeability_stays_bounded():
    """The load edge at low k (docs/method.md, *Known limits*): with the default damping the excess
    pore pressure must stay below 1.2 q and stop rising once the load is on."""
    scene = loaded_strip_block(1e-5, 0.0, 1.5)
    q, dt = 50e3, scene.time_step
    peaks = {}

    def excess_peak(k, model, state):
        p = state.particle_pore_pressure.numpy()[: model.particle_count]  # the excess over hydrostatic
        peaks[round(k * dt, 2)] = float(np.abs(p).max())
        return bool(np.isfinite(p).all())

    steps = int(1.5 / dt)
    march(scene, steps, excess_peak, every=steps // 6)
    times = sorted(peaks)
    print("\nloaded strip, k_h = 1e-5 m/s, default damping: largest |excess| "
          + ", ".join(f"{peaks[t] / 1e3:.0f}" for t in times) + f" kPa at {times} s")
    assert max(peaks.values()) < 1.2 * q
    assert peaks[times[-1]] <= peaks[times[-3]] * 1.01
