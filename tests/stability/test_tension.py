"""Tensile instability (issue 6, item 1), two-set scheme and collocated baseline; item 4, large rotation, is
:mod:`test_large_rotation`.

**Bar stretched at constant rate** (plane strain, L = 2 m, b = 0.4 m, Δx = 0.05 m, E = 10 MPa,
ν = 0.3, ρ = 2000 kg/m³): velocity planes at x = ±L/2 move apart at ±v₀, and the bar starts in the
matching homogeneous motion v_x = v₀ x/(L/2) (no wave is launched), plus a seeded random velocity
noise of 1 % of v₀ on every particle. The hypo-elastic closed form is homogeneous with the
logarithmic strain e = ln(1 + 2v₀t/L):

- *confined* (slip walls at y = 0 and b): σ_xx = E_oed e, σ_yy = σ_zz = λ e;
- *free* sides (plane strain, σ_yy = 0): σ_xx = E e/(1 − ν²), the sides contracting at −ν/(1 − ν) of
  the stretching rate (started with that motion too); the clamped ends (the velocity planes also
  hold v_y = 0) make it hold only away from them, so it is compared on the central half.

Criteria, sampled once per wave transit L/c for 20 transits: the closest particle pair stays above
half the initial spacing; the stress noise, the largest deviation of σ_xx and σ_yy from the closed
form (relative to σ_xx), stays below 1 % after the first transit (the seeded noise needs a transit to
spread); the largest speed stays below 2 v₀ (plus the lateral motion).

**Spinning disc** (R = 1 m, Δx = R/10, same material, rim speed ωR = 0.1 c, free, unstressed at
the start: it expands towards the centrifugal state, in tension, and breathes about it), two turns:
the total energy (kinetic + strain, :func:`stability_tools.energy`) never rises more than 0.1 %,
the closest pair stays above half the initial spacing; and the rim keeps its radius: the closed-form
plane-strain expansion is u(R)/R = (1 − ν′) ρω²R²/(4E′) = 0.17 % (E′ = E/(1 − ν²),
ν′ = ν/(1 − ν)), about which a disc started at rest in its frame breathes between 0 and twice that, so the mean rim
radius must stay within 0.5 % of R.
"""

import functools

import numpy as np
import pytest
from stability_tools import (
    CONSISTENT, DISC_DX, DISC_OMEGA, DISC_RADIUS, SCHEMES, SOLID, closest_pair, energy, expected_failure, largest_rise,
    march, scheme_params, spinning_disc,
)

from warpsph.scene import Body, Boundary, Scene, Simulation
from warpsph.sph.kernels import kernel_value

LENGTH, WIDTH, DX = 2.0, 0.4, 0.05
TRANSITS = 20
NOISE = 0.01


def blown_up(speed_ratio: float) -> bool:
    """A run is not followed further once its largest speed is 100 times the driving one (or not finite)."""
    return not speed_ratio < 100.0


def bar(scheme: str, sides: str, speed: float) -> Scene:
    """The bar with ends moving apart at ±``speed`` [m/s]; ``sides`` "confined" or "free"."""
    ends = [Boundary("left", "velocity", "x", -LENGTH / 2, "min", velocity=(-speed, 0, 0)),
            Boundary("right", "velocity", "x", LENGTH / 2, "max", velocity=(speed, 0, 0))]  # fmt: skip
    walls = [Boundary("bottom", "slip", "y", 0.0, "min"), Boundary("top", "slip", "y", WIDTH, "max")]
    return Scene(simulation=Simulation(dim=2, dx=DX, scheme=scheme), materials={"solid": SOLID},
                 bodies=[Body("bar", "solid", min=(-LENGTH / 2, 0, 0), max=(LENGTH / 2, WIDTH, 0))],
                 boundaries=ends + (walls if sides == "confined" else [])).validate()  # fmt: skip


@functools.cache
def stretch(scheme: str, sides: str, strain: float):
    """Stretch the bar to the nominal ``strain`` in 20 transits: per transit (time [s], closest pair / Δx,
    stress noise, largest speed / v₀), and the closed-form σ_xx at the end [Pa]."""
    duration = TRANSITS * LENGTH / SOLID.p_wave_speed
    rate = strain / duration
    speed = rate * LENGTH / 2
    scene = bar(scheme, sides, speed)
    nu = SOLID.poisson_ratio
    lateral = -nu / (1 - nu) * rate if sides == "free" else 0.0
    modulus = SOLID.oedometric_modulus if sides == "confined" else SOLID.youngs_modulus / (1 - nu**2)
    across = SOLID.lame_lambda if sides == "confined" else 0.0

    def start(model, state):
        n = model.particle_count
        v = state.particle_v.numpy()
        x = model.particle_x0
        v[:n, 0] = rate * x[:, 0]
        v[:n, 1] = lateral * (x[:, 1] - WIDTH / 2)
        v[:n, :2] += NOISE * speed * np.random.default_rng(0).standard_normal((n, 2))
        state.particle_v.assign(v)

    rows = []

    def observe(k, model, state):
        n, x0 = model.particle_count, model.particle_x0
        stress = state.particle_stress.numpy()[:n].astype(np.float64)
        t = k * scene.time_step
        e = np.log1p(rate * t)
        reach = LENGTH / 4 if sides == "free" else LENGTH / 2 - 2 * scene.smoothing_length
        inner = np.abs(x0[:, 0]) <= reach
        noise = 0.0
        if e > 0:
            noise = max(np.max(np.abs(stress[inner, 0, 0] - modulus * e)),
                        np.max(np.abs(stress[inner, 1, 1] - across * e))) / (modulus * e)  # fmt: skip
        v = state.particle_v.numpy()[:n]
        rows.append((t, closest_pair(state.particle_q.numpy()[:n]) / DX, noise,
                     np.max(np.linalg.norm(v, axis=1)) / speed))  # fmt: skip
        return not blown_up(rows[-1][3])

    steps = int(np.ceil(duration / scene.time_step))
    march(scene, steps, observe, every=int(round(steps / TRANSITS)), setup=start)
    return np.array(rows)


def check_bar(rows, label):
    after_first = rows[2:]
    print(f"\n{label}: closest pair {np.nanmin(rows[:, 1]):.3f} Δx, stress noise after the first transit "
          f"{np.max(after_first[:, 2]):.2e} (at the end {rows[-1, 2]:.2e}), "
          f"largest speed {np.max(rows[:, 3]):.3g} v₀")
    assert np.all(np.isfinite(rows))
    assert np.min(rows[:, 1]) > 0.5
    assert np.max(after_first[:, 2]) < 0.01
    assert np.max(rows[:, 3]) < 2.0


def check_blown_up(rows, label: str) -> None:
    """The contrast of a collocated baseline: its run was stopped at 100 times the driving speed (or
    became non-finite) before its end."""
    print(f"\n{label}: stopped after {len(rows) - 1} samples, largest speed {np.nanmax(rows[:, -1]):.3g} (contrast)")
    assert not np.all(np.isfinite(rows)) or blown_up(np.nanmax(rows[:, -1]))


@pytest.mark.parametrize("scheme", SCHEMES)
def test_confined_bar_stretched_to_twice_its_length(scheme):
    """The two-set bar stays clean to twice its length; the collocated baseline is the contrast: it blows
    up (between 70 % and 75 % stretch, measured, where the support 2h = 2.6 Δx₀ holds about 1.5
    spacings along the bar)."""
    rows = stretch(scheme, "confined", 1.0)
    if scheme == "collocated":
        check_blown_up(rows, "collocated, confined bar to 100 % stretch")
        return
    check_bar(rows, f"{scheme}, confined bar to 100 % stretch")


@pytest.mark.parametrize("scheme", ["collocated"])
def test_confined_bar_stretched_by_half(scheme):
    """The collocated baseline holds to 50 % stretch."""
    check_bar(stretch(scheme, "confined", 0.5), f"{scheme}, confined bar to 50 % stretch")


@pytest.mark.parametrize("scheme", scheme_params({
    "two_set": "a mode grows at the clamped ends' free corners: largest speed 31.7 v₀ after 20 transits, "
               "stress noise 4.4e-2 (known limit, docs/method.md; measured, docs/stability.md)"}))
def test_free_bar_stretched_by_one_percent(scheme):
    """The collocated baseline is the contrast: it blows up at the clamped ends' free corners (within 5
    transits, measured)."""
    rows = stretch(scheme, "free", 0.01)
    if scheme == "collocated":
        check_blown_up(rows, "collocated, free-sided bar to 1 % stretch")
        return
    check_bar(rows, f"{scheme}, free-sided bar to 1 % stretch")


@functools.cache
def spin(scheme: str, alpha: float, turns: float = 2.0, **options):
    """The spinning disc for ``turns`` (``options``: more Simulation settings): per quarter turn (turns,
    mean rim radius / R − 1, energy, closest pair / Δx)."""
    radius, dx, omega = DISC_RADIUS, DISC_DX, DISC_OMEGA
    scene = spinning_disc(scheme=scheme, artificial_viscosity=alpha, **options)
    period = 2 * np.pi / omega
    rows = []

    def observe(k, model, state):
        q = state.particle_q.numpy()[: model.particle_count]
        rim = np.linalg.norm(model.particle_x0[:, :2], axis=1) > radius - 0.5 * dx
        r = np.linalg.norm(q[rim, :2], axis=1).mean() / np.linalg.norm(model.particle_x0[rim, :2], axis=1).mean()
        v = np.linalg.norm(state.particle_v.numpy()[: model.particle_count], axis=1).max() / (omega * radius)
        rows.append((k * scene.time_step / period, r - 1.0, energy(model, state), closest_pair(q) / dx))
        return not blown_up(v)

    steps = int(np.ceil(turns * period / scene.time_step))
    march(scene, steps, observe, every=int(round(steps / (4 * turns))))
    return np.array(rows)


@pytest.mark.parametrize("scheme, alpha, options", [
    pytest.param("two_set", 0.0, (), marks=expected_failure(
        "energy +0.45 % at half a turn, +3.9 % at one, +14 % at 1.5, blow-up before 2: the virtual points' "
        "densities drift at the rim (measured, docs/stability.md)")),
    ("two_set", 0.0, CONSISTENT),
    ("collocated", 0.0, ()),
    ("collocated", 0.3, ()),
    ("two_set", 0.3, ()),
])
def test_spinning_disc_energy_and_spacing(scheme, alpha, options):
    """The collocated baseline is the contrast: it blows up before 2 turns, with or without artificial
    viscosity (within a quarter and half a turn, measured)."""
    rows = spin(scheme, alpha, **dict(options))
    if scheme == "collocated":
        print(f"\ncollocated, α = {alpha}: stopped at {rows[-1, 0]:.2f} turns (contrast)")
        assert rows[-1, 0] < 2.0 - 1e-9 or not np.all(np.isfinite(rows))
        return
    print(f"\n{scheme}, α = {alpha}, {dict(options)}: after {rows[-1, 0]:.2f} turns energy "
          f"{rows[-1, 2] / rows[0, 2]:.4f} of the initial, largest rise {largest_rise(rows[:, 2]):.2e}, closest pair "
          f"{np.min(rows[:, 3]):.3f} Δx, rim radius +{100 * rows[-1, 1]:.2f} % R")
    assert np.all(np.isfinite(rows))
    assert largest_rise(rows[:, 2]) <= 1e-3
    assert np.min(rows[:, 3]) > 0.5


@pytest.mark.parametrize("scheme, alpha, options", [("two_set", 0.3, ()), ("two_set", 0.0, CONSISTENT)])
def test_spinning_disc_keeps_its_radius(scheme, alpha, options):
    """The rim stays at the centrifugal expansion (closed form 0.17 % of R at ωR = 0.1 c): the full step
    takes its rate of deformation on the step's midpoint configuration, where a rigid rotation's
    half-step velocity has no divergence."""
    rows = spin(scheme, alpha, **dict(options))
    print(f"\n{scheme}, α = {alpha}, {dict(options)}: mean rim radius +{100 * rows[-1, 1]:.2f} % R "
          f"after {rows[-1, 0]:.2f} turns ({100 * rows[-1, 1] / rows[-1, 0]:.2f} % per turn)")
    assert np.max(np.abs(rows[:, 1])) < 0.005


def density_around(model, state) -> np.ndarray:
    """Each virtual point's density over the density of the real particles around it (their volumes'
    Shepard mean at the point: ρ_i / (m_i Σ_a W_ia / Σ_a V_a W_ia))."""
    n, nv = model.particle_count, model.virtual_count
    x, xv = state.particle_q.numpy()[:n], state.virtual_q.numpy()[:nv]
    volume = model.particle_mass.numpy()[:n] / state.particle_density.numpy()[:n]
    w = kernel_value(model.spec.kernel, 2, np.linalg.norm(xv[:, None, :] - x[None, :, :], axis=2), model.h)
    around = model.virtual_mass.numpy()[:nv] * w.sum(axis=1) / (w @ volume)
    return state.virtual_density.numpy()[:nv] / around


@pytest.mark.parametrize("virtual_density", [
    pytest.param("integrated", marks=expected_failure(
        "after 2 turns the virtual points' densities lie between 0.60 and 1.37 of the reals' around them, the "
        "reals' own within 0.6 % of ρ: a point integrates the divergence of the reals' velocities fitted at "
        "it, which at the rim holds a velocity the particles do not move with (measured, docs/method.md)")),
    "real_motion",
])
def test_spinning_disc_virtual_points_keep_the_density_around_them(virtual_density):
    """The virtual points' volumes weight every fit at the real particles; in a disc turning without
    deforming they must keep the density of the real particles around them (within 1 %, α = 0.3)."""
    scene = spinning_disc(artificial_viscosity=0.3, virtual_density=virtual_density)
    model, state, _ = march(scene, int(np.ceil(2 * 2 * np.pi / DISC_OMEGA / scene.time_step)))
    ratio = density_around(model, state)
    print(f"\ntwo-set disc, α = 0.3, virtual_density = {virtual_density!r}, 2 turns: virtual density / the "
          f"reals' around it in [{ratio.min():.4f}, {ratio.max():.4f}]")
    assert np.all(np.abs(ratio - 1.0) < 0.01)
