"""Undrained incompressible limit (issue 6, item 2): k_h = 1e-12 m/s, K_w = 1e12 Pa (two-set scheme
only: validation refuses pore water with the collocated scheme).

Covered elsewhere, not repeated here: the load carried by the water without a pressure checkerboard
(p/σ₀ within 1 %, neighbour jumps below 1 % of σ₀) at the time step of the drained case
(``tests/test_pore_water.py::test_undrained_limit_carries_the_load_in_the_water``).

- **Column, drained top** (``test_pore_water.loaded_column``, H = 10 m, σ₀ = 5 kPa, 100 steps): the
  displacement against the undrained closed form u(y) = −σ₀ y/(E_oed + Q) (no volumetric locking:
  the skeleton is not held stiffer than the water makes it). The drained top row carries the load in
  the skeleton at once and sends a drained wave down the column, so the closed form holds on the lower
  half (within 1 % of the undrained settlement S_u = Hσ₀/(E_oed + Q)); everywhere the displacement is
  within σ₀Δx/(2E_oed) of the closed form: the drained compression of the top row's half cell, the
  most one drained row can add (a drained face consolidates at once when k_h → 0).
- **Sealed column** (the same with an impermeable top): p = σ₀ Q/(Q + E_oed) within 2 % below the top
  two rows, the face particle following the row below it, and the same displacement bounds.
- **Plane-strain block with a free side** (1 m × 1 m half model: symmetry plane at x = 0, slip base,
  free side at x = 1 m, uniform load ramped over 3 shear transits on its impermeable top, the free
  surface impermeable), compared as means over transits 6–18 since the block keeps ringing after its
  ramp: undrained (ν_u = ½) settlement Hσ₀/(4G) within 5 %, the block's mean p within 1 % of σ₀/2, and
  p = σ₀/2 within 2 % at every particle — measured to miss it at the corner of the loaded top and the
  free side; and one step about rest of the same block with its top loaded and sealed is linearly
  stable.
"""

import numpy as np
import pytest
from stability_tools import expected_failure, march, step_jacobian
from test_pore_water import loaded_column, soil

from warpsph.runner import host_fields
from warpsph.scene import Body, Boundary, Effects, Load, PressureSolver, Scene, Simulation, TimeFunction

SIGMA0, HEIGHT = 5000.0, 10.0
UNDRAINED = soil(hydraulic_conductivity=1e-12, water_bulk_modulus=1e12)


def finite(model, state) -> bool:
    """Observer that stops a run once its fields are no longer finite."""
    n = model.particle_count
    return bool(np.all(np.isfinite(state.particle_v.numpy()[:n])) and
                np.all(np.isfinite(state.particle_pore_pressure.numpy()[:n])))  # fmt: skip


def column_after(top: str, steps: int = 100):
    """(heights y [m], displacement u_y [m], excess pore pressure [Pa]) of the loaded column."""
    model, state, _ = march(loaded_column(UNDRAINED, top, SIGMA0, HEIGHT), steps, lambda k, m, s: finite(m, s))
    y = model.particle_x0[:, 1]
    n = model.particle_count
    return y, state.particle_q.numpy()[:n, 1] - y, state.particle_pore_pressure.numpy()[:n]


def undrained_settlement():
    return HEIGHT * SIGMA0 / (UNDRAINED.oedometric_modulus + UNDRAINED.biot_modulus)


def test_drained_top_column_displacement():
    y, u, _ = column_after("drained")
    s_u = undrained_settlement()
    error = np.abs(u + SIGMA0 * y / (UNDRAINED.oedometric_modulus + UNDRAINED.biot_modulus))
    lower = y <= HEIGHT / 2
    top_row = SIGMA0 * 0.1 / (2 * UNDRAINED.oedometric_modulus)
    print(f"\nundrained column, drained top, 100 steps: lower half within {error[lower].max() / s_u:.2e} S_u "
          f"(S_u = {s_u:.3g} m), everywhere within {error.max() / s_u:.1f} S_u = {error.max() / top_row:.2f} of "
          f"the top row's drained compression")
    assert error[lower].max() < 0.01 * s_u
    assert error.max() < top_row


def test_sealed_column():
    """Loaded impermeable top: the water carries the load below the face without locking. The face
    particle's pressure is extrapolated from its neighbours (its own increment moves nothing, since
    the velocity correction holds a loaded impermeable face's total traction); the top cell
    consolidates partly before the water takes the step load, so the face and the row below it read
    less than the undrained value (docs/stability.md)."""
    y, u, p = column_after("impermeable")
    q, e_oed = UNDRAINED.biot_modulus, UNDRAINED.oedometric_modulus
    dx = 0.1
    interior = y < HEIGHT - 1.5 * dx  # all but the face row and the row below it
    ratio = p / (SIGMA0 * q / (q + e_oed))
    error = np.abs(u + SIGMA0 * y / (e_oed + q))
    face, second = ratio[np.argsort(y)[::-1][:2]]
    print(f"\nsealed undrained column, 100 steps: p / undrained in [{ratio[interior].min():.4g}, "
          f"{ratio[interior].max():.4g}] below the top two rows (face {face:.3g}, second row {second:.3g}); "
          f"lower half within {error[y <= HEIGHT / 2].max() / undrained_settlement():.2e} S_u")
    assert np.all(np.abs(ratio[interior] - 1.0) < 0.02)
    assert abs(face - second) < 0.02  # the face follows its neighbours
    assert error[y <= HEIGHT / 2].max() < 0.01 * undrained_settlement()
    assert error.max() < SIGMA0 * dx / (2 * e_oed)


def block(material, side: str, load: float, ramp: float = 0.0) -> Scene:
    """The 1 m × 1 m half block (Δx = 0.1 m) under ``load`` [Pa] ramped over ``ramp`` [s] on its
    impermeable top, its side at x = 1 m "free" (an impermeable free surface) or "slip"."""
    sides = [Boundary("side", "slip", "x", 1.0, "max")] if side == "slip" else []
    return Scene(simulation=Simulation(dim=2, dx=0.1), effects=Effects(pore_water=True),
                 materials={"soil": material}, bodies=[Body("block", "soil", min=(0, 0, 0), max=(1.0, 1.0, 0))],
                 boundaries=[Boundary("base", "slip", "y", 0.0, "min"), Boundary("axis", "symmetry", "x", 0.0, "min"),
                             *sides],
                 loads=[Load("top", "traction", "y", 1.0, "max", traction=(0, -load, 0),
                             time_function=TimeFunction("ramp", duration=ramp))],
                 pressure=PressureSolver(free_surface="impermeable")).validate()  # fmt: skip


@pytest.mark.parametrize("side, material", [("slip", UNDRAINED),
                                            ("free", soil(hydraulic_conductivity=1e-6, water_bulk_modulus=2.2e9))],
                         ids=["undrained_slip_side", "k_1e-6_free_side"])
def test_loaded_sealed_face_step_is_linearly_stable(side, material):
    """One step about rest of the block with its loaded impermeable top: spectral radius ≤ 1 + 1e-5,
    which the roughness damping next to such faces keeps (docs/method.md, *Loaded impermeable faces*)."""
    radius = float(np.abs(np.linalg.eigvals(step_jacobian(block(material, side, 0.0)))).max())
    print(f"\nblock with a loaded sealed top, {side} side, k_h = {material.hydraulic_conductivity:g} m/s: spectral "
          f"radius of a step {radius:.7f}")
    assert radius <= 1.0 + 1e-5


RINGING = (6.0, 18.0)
"""Window [shear transits] over which the free-sided block's response is averaged: after its 3-transit
ramp the undamped elastic skeleton keeps ringing (settlement 0.90–1.02 of Hσ₀/(4G), periods of 2–3
transits), as an exact solution would, so the static closed form is compared with time means."""


@pytest.fixture(scope="module")
def block_with_a_free_side():
    """(settlement / Hσ₀/(4G), p/σ₀ of every particle) of the 1 m × 1 m block, each the mean over the
    ``RINGING`` window."""
    height = 1.0
    shear_transit = height / np.sqrt(UNDRAINED.shear_modulus / UNDRAINED.density)
    scene = block(UNDRAINED, "free", SIGMA0, ramp=3 * shear_transit)
    first, last = (int(t * shear_transit / scene.time_step) for t in RINGING)
    sums = {"samples": 0, "settlement": 0.0, "pressure": 0.0}

    def accumulate(k, model, state):
        if k >= first:
            fields = host_fields(model, state)
            top = np.abs(model.particle_x0[:, 1] - height) < 1e-9
            sums["settlement"] += height - fields["position"][top, 1].mean()
            sums["pressure"] = sums["pressure"] + fields["pore_pressure"] / SIGMA0
            sums["samples"] += 1
        return finite(model, state)

    march(scene, last, accumulate)
    settlement = sums["settlement"] / sums["samples"] / (height * SIGMA0 / (4 * UNDRAINED.shear_modulus))
    p = sums["pressure"] / sums["samples"]
    print(f"\nundrained plane-strain block, means over transits {RINGING[0]:g}-{RINGING[1]:g}: settlement "
          f"{settlement:.4g} of Hσ₀/(4G), p/σ₀ in [{p.min():.4g}, {p.max():.4g}], block mean {p.mean():.4g}")
    return settlement, p


def test_plane_strain_block_with_a_free_side_settles_undrained(block_with_a_free_side):
    """No volumetric locking: the undrained (ν_u = ½) settlement Hσ₀/(4G) within 5 % (0.963 while
    the loaded face's particles kept their pressure, a snapshot at 6 transits)."""
    settlement, _ = block_with_a_free_side
    assert abs(settlement - 1.0) < 0.05


def test_plane_strain_block_with_a_free_side_carries_half_the_load_in_the_water_on_average(block_with_a_free_side):
    """The water carries half the load over the block: the mean of p/σ₀ (time means) within 1 % of ½."""
    _, p = block_with_a_free_side
    assert abs(p.mean() - 0.5) < 0.005


@expected_failure("time means over transits 6-18: p/σ₀ in [0.491, 0.538]; the 7 particles off by 2 % or more "
                  "lie within 0.3 m of the corner of the loaded top and the free side (0.538 at (1.0, 0.9) m; "
                  "at Δx = 0.05 m 12 particles within 0.15 m and 0.561 at the corner, so it does not converge "
                  "there; measured, docs/stability.md)")
def test_plane_strain_block_with_a_free_side_carries_half_the_load_in_the_water(block_with_a_free_side):
    """The undrained closed form p = σ₀/2 (time means) within 2 % at every particle."""
    _, p = block_with_a_free_side
    assert np.all(np.abs(p - 0.5) < 0.02)
