"""Strain-softening shear band regularised by the Perzyna rate (issue 4, item 5): the band's width
changes by less than 20 % when Δx is halved.

Set-up (SI units, tension positive). A **1D simple-shear layer**: a column 0 ≤ y ≤ H = 1 m (``dim =
1``: fields vary along y only, velocities and stresses keep all components), base fixed, top a
"velocity" plane moving along x at V = 0.05 m/s after a 0.02 s ramp (nominal shear rate 0.05 /s).
Von Mises soil, E = 10 MPa, ν = 0.3, ρ = 2000 kg/m³, c = 10 kPa softening linearly with
H = dc/dε̄ = −250 kPa to the residual c_r = 5 kPa (reached at ε̄ = 0.02), Perzyna N = 1,
F₀ = σ_Y0 = √3 c.

Why this set-up: in simple shear the band is parallel to the layer and its width is a 1D profile of
ε̄(y), measured on every particle; all boundaries are planes (no free surface: the free-surface
odd-even mode near clamped faces, docs/method.md *Known limits*, would mask the band); and the layer
is the classic set-up of the viscoplastic-regularisation literature (Needleman 1988; Wang, Sluys &
de Borst 1997). A 2D band (biaxial sample) is not covered here.

**Imperfection.** A weaker zone centred at y = 0.5 m whose cohesion dips linearly, as a function of
position, by 5 % at the centre to nothing at |y − 0.5| = 0.15 m, as 30 nested bodies of 5 mm steps
(each embedded in the next: the first body listed owns a point): the same physical imperfection at
every Δx used here. A seed of one weaker material a few particles thick has a Δx-dependent size,
and with it the band (measured: γ = 5 /s, 2 % weaker over |y − 0.5| ≤ 0.03 m: 3 particles at Δx = 0.02 m and 7 at
0.01 m, FWHM 0.042 and 0.029 m).

**Rate length.** Linearising simple shear about yield, τ = τ_y + η γ̇ᵖ with η = F₀/(3γ) and
h = dτ_y/dγᵖ = H/√3, perturbations e^{λt + iky} obey ρλ² + ηk²λ + hk² ≈ 0 (for |h| ≪ G; here
|h|/G = 0.04). With softening (h < 0) every wave grows; the rate rises with k to the limit |h|/η,
reaches 0.83 of it at k = 2√(ρ|h|)/η and is nearly that for all shorter waves, so the rate term sets
a length of order l = πη/√(ρ|h|) = π c_s t_r √(G/|h|) (c_s = √(G/ρ), t_r = η/G) below which the band
does not sharpen appreciably faster. Rate-independent softening has no length and localises into
the smallest width the particles allow. With γ = 2 /s: η = 2.9 kPa·s, t_r = 0.75 ms,
c_s t_r = 0.033 m (1.6 Δx at the coarse spacing), l = 0.53 m; the band measured below is 0.064 m
wide (FWHM), 3.2 Δx at the coarse spacing. The control: γ = 1e4 /s (l = 0.1 mm ≪ Δx) gives a band
whose width scales with Δx (test below).

**Validity of the 1D layer (found while building this test).** In ``dim = 1`` the neighbour search,
kernel values and the linear fit take the full 3D offset x_b − x_a, and the particles used to move
along x with the shear, so rows offset by the band's slip looked farther apart than they were (on an
elastic 1D column, rows moved by 0.3 Δx changed the stresses by 7.4e-2 of the peak). Points now move
only along the axes the scene uses (tests/stability/test_stiff_plasticity.py).

**Measure.** ε̄ of the particles against their initial y at t = 0.2 s (top displaced by 9.5 mm,
the same at every Δx). Width: the full width at half the peak of ε̄, the half-peak crossings
linearly interpolated between particles, over 0.25 < y < 0.75 m. Also printed: the standard
deviation of y weighted by ε̄ on the same window. The band core has softened to the residual
(ε̄ > 0.02 there) and flows as a perfectly viscoplastic zone, so the width is that of the zone that
reached the residual strength.

Measured (``python -m pytest tests/test_shear_band.py -s``, CPU, one thread, 5 s; ``-m slow`` for the
finer pair, 23 s): FWHM 0.0637 m (Δx = 0.02 m, 3.2 Δx), 0.0664 (0.01), 0.0674 (0.005), 0.0689
(0.0025): ratios 1.042 and 1.023 per halving (weighted s.d. 0.0350, 0.0324, 0.0331, 0.0336 m); the
peak ε̄ 0.054–0.056 at y = 0.500–0.503 m.
"""

import functools
import math

import numpy as np
import pytest
from test_plastic_solver import advance

from warpsph.fields import von_mises
from warpsph.scene import Body, Boundary, Effects, Material, Scene, Simulation, TimeFunction

E, NU, DENSITY = 10e6, 0.3, 2000.0
COHESION, SOFTENING, RESIDUAL = 10e3, -2.5e5, 5e3
"""c [Pa], H = dc/dε̄ [Pa], c_r [Pa]: the residual is reached at ε̄ = (c − c_r)/|H| = 0.02."""
SIGMA_Y = math.sqrt(3.0) * COHESION
HEIGHT, SPEED, RAMP, END, LONG_END = 1.0, 0.05, 0.02, 0.2, 1.0
"""Layer height [m], top speed [m/s], its ramp [s], the time of the measure [s] (top displaced 9.5 mm),
and of the long runs (49.5 mm)."""
CENTRE, SEED_HALF_WIDTH, SEED_DIP, SEED_STEPS = 0.5, 0.15, 0.05, 30
"""The imperfection: centre [m], half width [m], relative cohesion dip at the centre, nested bodies."""
WINDOW = (0.25, 0.75)
"""y-range [m] over which the band is measured (clear of the boundary layers at base and top)."""
REGULARISED = 2.0
"""γ [1/s] of the regularised band: rate length l = 0.53 m."""
STIFF = 1.0e4
"""γ [1/s] of a band without a resolved rate length: l = 0.1 mm, relaxation time F₀/(3Gγ) = 0.15 µs
(the stiff-plasticity case of the stability suite, tests/stability/test_stiff_plasticity.py)."""
SHEAR = E / (2.0 * (1.0 + NU))


def soil(name: str, cohesion: float, fluidity: float) -> Material:
    return Material(name=name, model="viscoplastic", density=DENSITY, youngs_modulus=E, poisson_ratio=NU,
                    yield_function="von_mises", cohesion=cohesion, hardening_modulus=SOFTENING,
                    residual_cohesion=RESIDUAL * cohesion / COHESION, fluidity=fluidity,
                    reference_stress=SIGMA_Y)  # fmt: skip


def shear_layer(dx: float, fluidity: float) -> Scene:
    """The simple-shear layer with its imperfection (module docstring) at spacing ``dx`` [m]."""
    materials, bodies = {}, []
    for j in range(SEED_STEPS):  # innermost (weakest) first: the first body listed owns a point
        half = SEED_HALF_WIDTH * (j + 1) / SEED_STEPS
        name = f"seed{j}"
        materials[name] = soil(name, COHESION * (1.0 - SEED_DIP * (1.0 - j / SEED_STEPS)), fluidity)
        bodies.append(Body(name=name, material=name, min=(0.0, CENTRE - half, 0.0), max=(0.0, CENTRE + half, 0.0),
                           embedded=True))
    materials["soil"] = soil("soil", COHESION, fluidity)
    bodies.append(Body(name="layer", material="soil", min=(0.0, 0.0, 0.0), max=(0.0, HEIGHT, 0.0)))
    top = Boundary(name="top", kind="velocity", axis="y", position=HEIGHT, side="max", velocity=(SPEED, 0.0, 0.0),
                   time_function=TimeFunction(kind="ramp", duration=RAMP))  # fmt: skip
    return Scene(
        name="shear_band",
        simulation=Simulation(dim=1, dx=dx, end_time=END),
        effects=Effects(plasticity=True),
        materials=materials,
        bodies=bodies,
        boundaries=[Boundary(name="base", kind="fixed", axis="y", position=0.0, side="min"), top],
    ).validate()


def steps_to(scene: Scene, time: float) -> int:
    return int(round(time / scene.time_step))


def profile(model, state) -> tuple[np.ndarray, np.ndarray]:
    """(initial y, ε̄) of the particles in the measuring window, sorted by y."""
    n = model.particle_count
    y = model.particle_x0[:n, 1]
    eps = state.particle_plastic_strain.numpy()[:n].astype(np.float64)
    inside = (y > WINDOW[0]) & (y < WINDOW[1])
    order = np.argsort(y[inside])
    return y[inside][order], eps[inside][order]


def band(y: np.ndarray, eps: np.ndarray) -> dict:
    """Peak position [m] and value, full width at half peak [m] (crossings interpolated linearly) and
    the ε̄-weighted standard deviation of y [m] of a sorted profile."""
    i = int(np.argmax(eps))
    half = 0.5 * eps[i]
    lo = i
    while lo > 0 and eps[lo] > half:
        lo -= 1
    hi = i
    while hi < len(eps) - 1 and eps[hi] > half:
        hi += 1
    if eps[lo] > half or eps[hi] > half:  # the band reaches the window's edge
        return dict(peak_at=y[i], peak=eps[i], width=math.inf, spread=math.inf)
    left = y[lo] + (half - eps[lo]) / (eps[lo + 1] - eps[lo]) * (y[lo + 1] - y[lo])
    right = y[hi - 1] + (eps[hi - 1] - half) / (eps[hi - 1] - eps[hi]) * (y[hi] - y[hi - 1])
    weight = eps / eps.sum()
    mean = float(np.sum(weight * y))
    return dict(peak_at=float(y[i]), peak=float(eps[i]), width=float(right - left),
                spread=math.sqrt(float(np.sum(weight * (y - mean) ** 2))))  # fmt: skip


OBSERVE_EVERY = 20
"""Steps between the checks of a run's stress and speed."""


def strength(scene: Scene, model, eps: np.ndarray) -> np.ndarray:
    """σ_Y(ε̄) = √3 max(c + Hε̄, c_r) of the owned particles, each with its own material's c and c_r."""
    materials = list(scene.materials.values())
    index = model.particle_material.numpy()[: model.particle_count]
    cohesion = np.array([m.cohesion for m in materials])[index]
    residual = np.array([m.residual_cohesion for m in materials])[index]
    return math.sqrt(3.0) * np.maximum(cohesion + SOFTENING * eps, residual)


@functools.cache
def layer_run(dx: float, fluidity: float, end: float = END) -> dict:
    """Run the layer to ``end`` [s] (once per session: the stability suite reads the same runs). Returns
    the band at the end (:func:`band`), the largest σ_eq/σ_Y(ε̄) − 1 of any particle and the largest
    particle speed [m/s] every ``OBSERVE_EVERY`` steps (``times``, ``speeds``), and whether every
    field stayed finite."""
    scene = shear_layer(dx, fluidity)
    steps = steps_to(scene, end)
    record = dict(times=[], speeds=[], overstress=-math.inf, finite=True, time_step=scene.time_step, scene=scene)
    for k, (t, model, state) in enumerate(advance(scene, steps), start=1):
        if k % OBSERVE_EVERY and k < steps:
            continue
        n = model.particle_count
        v = state.particle_v.numpy()[:n]
        sigma = state.particle_stress.numpy()[:n]
        eps = state.particle_plastic_strain.numpy()[:n].astype(np.float64)
        if not (np.isfinite(v).all() and np.isfinite(sigma).all() and np.isfinite(eps).all()):
            record["finite"] = False
            break
        over = float(np.max(von_mises(sigma) / strength(scene, model, eps) - 1.0))
        record["overstress"] = max(record["overstress"], over)
        record["times"].append(t)
        record["speeds"].append(float(np.linalg.norm(v, axis=1).max()))
    record["band"] = band(*profile(model, state)) if record["finite"] else None
    return record


def band_at(dx: float, fluidity: float, end: float = END) -> dict:
    """The band of :func:`layer_run` at ``end``, printed."""
    result = layer_run(dx, fluidity, end)["band"]
    assert result is not None, f"the run with Δx = {dx} m, γ = {fluidity:g} /s did not stay finite to t = {end} s"
    print(f"\nγ = {fluidity:g} /s, Δx = {dx} m, t = {end} s: peak ε̄ {result['peak']:.4f} at "
          f"y = {result['peak_at']:.3f} m, "
          f"FWHM {result['width']:.4f} m ({result['width'] / dx:.2f} Δx), weighted s.d. {result['spread']:.4f} m")
    return result


def check_refinement(coarse: float, fine: float, end: float = END) -> None:
    a, b = band_at(coarse, REGULARISED, end), band_at(fine, REGULARISED, end)
    ratio = b["width"] / a["width"]
    print(f"width ratio (Δx = {fine} over {coarse}): {ratio:.3f}; s.d. ratio {b['spread'] / a['spread']:.3f}")
    for r, dx in ((a, coarse), (b, fine)):
        assert r["peak"] > (COHESION - RESIDUAL) / abs(SOFTENING)  # the core has softened to the residual
        assert abs(r["peak_at"] - CENTRE) <= max(2.0 * dx, 0.02)  # the band sits on the imperfection
        assert r["width"] < SEED_HALF_WIDTH  # a band, narrower than the imperfection that seeds it
    assert abs(ratio - 1.0) < 0.2


def test_band_width_converges_when_dx_is_halved():
    check_refinement(0.02, 0.01)


@pytest.mark.slow
def test_band_width_converges_on_finer_spacings():
    check_refinement(0.005, 0.0025)


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason="measured: at t = 1 s (top displaced 49.5 mm) FWHM 0.0660 m (Δx = 0.02 m) "
                   "and 0.0745 m (0.01 m), ratio 1.13 (within 20 %), but the finer band's peak has moved to "
                   "y = 0.53 m, 3 Δx off the imperfection (criterion 2 Δx)")
def test_band_width_converges_after_five_times_the_displacement():
    check_refinement(0.02, 0.01, end=LONG_END)


def test_without_a_resolved_rate_length_the_band_narrows_with_dx():
    """The control: with γ = 1e4 /s (l = 0.1 mm ≪ Δx) the same measure is not converged — the band
    narrows when Δx is halved by more than the 20 % allowed above, so the criterion can fail and the
    convergence at γ = 2 /s is the rate term's doing."""
    a, b = band_at(0.02, STIFF), band_at(0.01, STIFF)
    ratio = b["width"] / a["width"]
    print(f"width ratio (Δx = 0.01 over 0.02): {ratio:.3f}")
    assert ratio < 0.8
