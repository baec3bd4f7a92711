"""Stiff plasticity (issue 6, item 7): strain softening with a small relaxation time. Two-set scheme
only: validation refuses the plasticity effect with the collocated baseline
(``tests/test_scene_errors.py``, "plasticity with the collocated scheme"), so that column is n/a.

The softening simple-shear layer of ``tests/test_shear_band.py`` (H = 1 m, top driven at V = 0.05 m/s,
von Mises c = 10 kPa softening with H = −250 kPa to c_r = 5 kPa, a 5 % linear imperfection of half
width 0.15 m at y = 0.5 m), with the fluidity raised from 2 /s to γ = 1e4 /s: the overstress
relaxes at λ_vp = γ(3G + √3|H|)/F₀ = 6.9e6 /s, so λ_vp Δt = 842 at Δx = 0.02 m (421 at 0.01 m) and
the source integrator takes that many RK4 sub-steps per interval (``RELAXATION_STEP``: λ_vp h ≤ 1,
under the cap of 1000). The rate length l = πη/√(ρ|h|) (test_shear_band) is 0.1 mm, far below Δx:
the rate does not regularise this band, which narrows with Δx
(``test_shear_band.py::test_without_a_resolved_rate_length_the_band_narrows_with_dx``), but it must
not collapse onto one particle row.

The band forms abruptly here: the shear stress drops from about 9.5 kPa towards the residual's 5 kPa
within about 20 ms, and the unloading waves, doubled on reflection at the base, take it down to
about 0 (*exploration*: smallest τ −0.14 kPa at Δx = 0.02 m, 0 at 0.01 m, at t = 0.10–0.17 s); the
band then slips at several V. That is elastic dynamics, not instability, so the speed bound is the
most two superposed elastic waves can carry while |τ| ≤ c outside the band.

Criteria, checked every 20 steps to t = 0.2 s (top displaced 9.5 mm):

- stable: every field finite; the largest particle speed below V + 2c/(ρ c_s) = 5.6 V, and no growth:
  the largest speed over the last quarter of the run at most the largest before it;
- on the softened surface: σ_eq ≤ σ_Y(ε̄)(1 + 1e-3) at every particle, σ_Y(ε̄) = √3 max(c + Hε̄, c_r)
  with the particle's own c and c_r (the source acts after the flux, and with λ_vp Δt ≫ 1 it relaxes
  the step's overstress onto the surface within the step; the continuous Perzyna overstress F₀ ε̄̇/γ
  would be 1e-3 of the residual strength only at ε̄̇ = 2.5 /s);
- resolved: the band (full width at half the peak of ε̄, as in test_shear_band) at least 2 Δx wide, its
  peak within 2 Δx of the imperfection's centre, its core softened to the residual.

Longer (slow, strict expected failure): the same criteria to t = 1 s at Δx = 0.01 m. The run blows up
between t = 0.50 and 0.55 s, when the band's slip has moved rows two apart 16.9 mm from each other
along x: in ``dim = 1`` the neighbour search, kernel and linear fit take the full 3D offset, so
the pair, 20 mm apart along y, is 26.2 mm apart for them, beyond the support 2h = 26 mm. The
effect is isolated on an elastic 1D column (``test_1d_operators_ignore_offsets_along_x``, strict
expected failure): moving its rows along x, which a 1D model must not notice, changes its stresses
(7.4 % of the peak at 0.3 Δx per row). It is a limit of the 1D layer (in 2D the band's neighbours
along x are other particles), not of the plastic sub-stepping, which keeps every particle on its
softened surface to round-off up to the blow-up.
"""

import math

import numpy as np
import pytest
from stability_tools import SCENES, march
from test_shear_band import (CENTRE, COHESION, DENSITY, END, LONG_END, RESIDUAL, SHEAR, SOFTENING, SPEED, STIFF,
                             band_at, layer_run)  # fmt: skip
from test_wave_column import column

SPEED_BOUND = SPEED + 2.0 * COHESION / math.sqrt(DENSITY * SHEAR)
"""V + 2c/(ρ c_s) [m/s] with c_s = √(G/ρ), i.e. 2c/√(ρG)."""


def relaxation_steps(scene) -> float:
    """λ_vp Δt of a von Mises point flowing in shear (docs/method.md, source integration)."""
    material = scene.materials["soil"]
    rate = material.fluidity * (3.0 * SHEAR + math.sqrt(3.0) * abs(SOFTENING)) / material.reference_stress
    return rate * scene.time_step


def check_stiff_run(dx: float, end: float) -> None:
    run = layer_run(dx, STIFF, end)
    assert relaxation_steps(run["scene"]) > 100  # sub-stepping active: hundreds of RK4 sub-steps a step
    speeds = np.array(run["speeds"])
    late = np.array(run["times"]) > 0.75 * end
    late_speed = speeds[late].max() if late.any() else math.nan
    print(f"\nΔx = {dx} m, to t = {end} s: λ_vp Δt = {relaxation_steps(run['scene']):.0f}; finite {run['finite']} "
          f"(last check t = {run['times'][-1]:.3f} s); largest σ_eq/σ_Y(ε̄) − 1 = {run['overstress']:.2e}; "
          f"largest speed {speeds.max() / SPEED:.2f} V (bound {SPEED_BOUND / SPEED:.2f} V), "
          f"over the last quarter {late_speed / SPEED:.2f} V")
    assert run["finite"]
    assert speeds.max() < SPEED_BOUND
    assert late_speed <= speeds[~late].max()
    assert run["overstress"] < 1e-3
    result = band_at(dx, STIFF, end)
    assert result["peak"] > (COHESION - RESIDUAL) / abs(SOFTENING)
    assert abs(result["peak_at"] - CENTRE) <= 2.0 * dx
    assert result["width"] >= 2.0 * dx


@pytest.mark.parametrize("dx", [0.02, 0.01])
def test_stiff_softening_band_is_stable_and_resolved(dx):
    check_stiff_run(dx, END)


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason="measured: Δx = 0.01 m blows up between t = 0.50 and 0.55 s (top displaced "
                   "24-27 mm; 3.2 V at 0.50 s, 364 V at 0.55 s), when particles two rows apart are offset by "
                   "16.9 mm along x: their 1D kernel distance √(20² + 16.9²) = 26.2 mm exceeds 2h = 26 mm")
def test_stiff_softening_band_over_a_longer_run():
    check_stiff_run(0.01, LONG_END)


@pytest.mark.xfail(strict=True, reason="measured: offsetting the rows of the 1D wave column along x by 0.3 Δx each "
                   "(q_x += 0.3 y) changes σ_yy after 300 steps by 7.4e-2 of its peak (0.1 Δx: 3.5e-3; 0.6 Δx: "
                   "0.33; 1.0 Δx: 0.55): the 1D neighbour search, kernel and fit use the full 3D offset")
def test_1d_operators_ignore_offsets_along_x():
    """The likely cause of the long run's blow-up, isolated: a 1D body's fields vary along y only, so
    where its points lie along x must not matter. The shipped 1D wave column (elastic, no plasticity),
    300 steps, with and without every point (particles, virtual points, ghosts) moved along x by
    0.3 y, as a band's slip moves them: σ_yy must agree to round-off."""

    def moved(model, state):
        for array in (state.particle_q, state.virtual_q):
            q = array.numpy()
            q[:, 0] += 0.3 * q[:, 1]
            array.assign(q)

    profiles = []
    for setup in (None, moved):
        model, state, _ = march(column(SCENES, 1), 300, setup=setup)
        n = model.particle_count
        profiles.append(state.particle_stress.numpy()[:n, 1, 1][np.argsort(model.particle_x0[:n, 1])])
    change = np.abs(profiles[1] - profiles[0]).max() / np.abs(profiles[0]).max()
    print(f"\nσ_yy change with rows offset by 0.3 Δx along x: {change:.2e} of its peak")
    assert change < 1e-9
