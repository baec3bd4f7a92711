"""Closed-form solutions (step wave, Terzaghi consolidation, Gardner infiltration) and the error measures that
the accuracy studies and the tests share, and :func:`run_sampled`, which steps a scene in memory and times the
steps apart from compilation and sampling (docs/accuracy.md, *Error measures*).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

GUARD_EVERY = 500
"""Steps between run-guard checks of :func:`run_sampled` (besides every sample)."""


@dataclass
class WaveMetrics:
    """Measures of a step wave in a column; speeds in m/s, the rest relative to σ₀."""

    front_speed: float
    """Slope of the loaded length d(t) while the front is 30–70 % down the column [m/s]."""
    plateau_mean: float
    """Window mean of −σ_yy/σ₀ from 20Δx behind the front to 10Δx below the loaded face."""
    overshoot: float
    """max(−σ_yy/σ₀) − 1 over the frames used."""
    l2_error: float
    """RMS of −σ_yy/σ₀ minus the exact step, over the column, at the last frame used."""


def column_profile(position: np.ndarray, stress_yy: np.ndarray, dx: float) -> tuple[np.ndarray, np.ndarray]:
    """Average σ_yy over particles of equal height: (heights y [m], σ_yy [Pa]), sorted by y."""
    levels = np.round(position[:, 1] / dx * 1e3).astype(np.int64)
    keys, inverse = np.unique(levels, return_inverse=True)
    sums = np.bincount(inverse, weights=stress_yy)
    counts = np.bincount(inverse)
    return keys * dx * 1e-3, sums / counts


def loaded_length(y: np.ndarray, ratio: np.ndarray) -> float:
    """d = ∫ ratio dy by the trapezoid rule [m], ratio = −σ_yy/σ₀ over heights y."""
    return float(np.sum(0.5 * (ratio[1:] + ratio[:-1]) * np.diff(y)))


def step_wave_metrics(times, profiles, *, height: float, speed: float, sigma0: float, dx: float) -> WaveMetrics:
    """Measures of a step wave from frames at ``times`` [s], ``profiles`` = [(y, σ_yy), ...]."""
    times = np.asarray(times, dtype=float)
    used = [(t, y, -s / sigma0) for t, (y, s) in zip(times, profiles) if 0.3 * height <= speed * t <= 0.7 * height]
    if len(used) < 2:
        raise ValueError("need at least two frames while the front is 30-70 % down the column")
    t_used = np.array([u[0] for u in used])
    d = np.array([loaded_length(y, r) for _, y, r in used])
    front_speed = float(np.polyfit(t_used, d, 1)[0])
    t, y, r = used[-1]
    front = height - speed * t
    window = (y >= front + 20 * dx) & (y <= height - 10 * dx)
    plateau = float(np.mean(r[window])) if np.any(window) else float("nan")
    overshoot = float(max(np.max(u[2]) for u in used) - 1.0)
    exact = (y > front).astype(float)
    l2 = float(np.sqrt(np.mean((r - exact) ** 2)))
    return WaveMetrics(front_speed, plateau, overshoot, l2)


@dataclass
class SampledRun:
    """States sampled from an in-memory run (:func:`run_sampled`) and what the stepping cost."""

    model: Any
    solver: Any
    times: list[float]
    """Simulated times of the samples [s]."""
    samples: list
    steps: int
    """Steps taken."""
    time_step: float
    """Δt [s]."""
    build_seconds: float
    """Wall time of building the model and initial state on the host and the device [s]."""
    compile_seconds: float
    """Wall time of the warm-up step: kernel compilation or cache load, first launch [s]."""
    step_seconds: float
    """Wall time of the steps alone, sampling and run-guard checks excluded [s]."""
    step_cpu_seconds: float
    """CPU time of this process over the same steps [s]: on a busy machine, steadier than the wall time."""

    @property
    def particle_steps_per_second(self) -> float:
        return self.model.particle_count * self.steps / self.step_seconds if self.step_seconds > 0 else 0.0


def run_sampled(scene, sample_steps: Iterable[int], extract: Callable, device: str | None = None) -> SampledRun:
    """Build ``scene`` on ``device``, compile by one throw-away step (timed apart), step to the
    largest of ``sample_steps`` and keep ``extract(model, state)`` after each of them. Raises
    :class:`~warpsph.errors.SimulationError` when the run guard finds a non-finite field or a speed
    beyond the scene's :attr:`~warpsph.scene.Scene.speed_limit` (checked at every sample and every
    ``GUARD_EVERY`` steps)."""
    import warp as wp

    from warpsph.builder import build
    from warpsph.errors import SimulationError
    from warpsph.solver import Solver, warm_up
    from warpsph.stages.guard import Guard

    start = time.perf_counter()
    model, state = build(scene, device=device)
    build_seconds = time.perf_counter() - start
    scratch = model.state()
    scratch.assign(state)
    solver, guard, dt = Solver(model), Guard(model, scene.speed_limit), scene.time_step
    compile_seconds = warm_up(solver, guard, state, scratch, 0.0, dt)
    wanted = set(sample_steps)
    stops = sorted(wanted | set(range(GUARD_EVERY, max(wanted, default=0), GUARD_EVERY)))
    times, samples, step, step_seconds, step_cpu_seconds = [], [], 0, 0.0, 0.0
    for stop in stops:
        start, start_cpu = time.perf_counter(), time.process_time()
        while step < stop:
            solver.step(state, scratch, step * dt, dt)
            state, scratch = scratch, state
            step += 1
        wp.synchronize_device(model.device)
        step_seconds += time.perf_counter() - start
        step_cpu_seconds += time.process_time() - start_cpu
        bad, point = guard.find(state)
        if bad is not None:
            raise SimulationError(f"unstable by step {step}, t = {step * dt:.6g} s: particle {bad} has a non-finite "
                                  f"field or a speed beyond {scene.speed_limit_text}")  # fmt: skip
        if point is not None:
            raise SimulationError(f"unstable by step {step}, t = {step * dt:.6g} s: virtual point {point} has a "
                                  "non-finite position or density or a non-positive density")  # fmt: skip
        if stop in wanted:
            times.append(step * dt)
            samples.append(extract(model, state))
    return SampledRun(model, solver, times, samples, step, dt, build_seconds, compile_seconds, step_seconds,
                      step_cpu_seconds)


def column_stress_profile(model, state) -> tuple[np.ndarray, np.ndarray]:
    """(heights y [m], σ_yy [Pa]) of the owned particles of ``state``, by :func:`column_profile`."""
    n = model.particle_count
    q = state.particle_q.numpy()[:n].astype(np.float64)
    s = state.particle_stress.numpy()[:n, 1, 1].astype(np.float64)
    return column_profile(q, s, model.dx)


def column_stress_run(scene, t_end: float, n_frames: int = 12, device: str | None = None) -> SampledRun:
    """Run ``scene`` to ``t_end`` [s] in memory, sampling :func:`column_stress_profile` at about
    ``n_frames`` evenly spaced steps, for :func:`step_wave_metrics`."""
    n_end = int(np.ceil(t_end / scene.time_step - 1e-9))
    every = max(1, n_end // n_frames)
    return run_sampled(scene, range(every, n_end + 1, every), column_stress_profile, device=device)


def sample_column_stress(scene, t_end: float, n_frames: int = 12, device: str | None = None):
    """(times, [(y, σ_yy)] profiles) of :func:`column_stress_run`."""
    run = column_stress_run(scene, t_end, n_frames, device)
    return run.times, run.samples


# -------------------------------------------------------------------------- Terzaghi consolidation


class Consolidation(NamedTuple):
    """Terzaghi constants of a saturated column of height H under a step load σ₀."""

    p0: float
    """Initial excess pore pressure σ₀ Q/(Q + E_oed) [Pa]."""
    cv: float
    """Coefficient of consolidation k_h/(ρ_w g (1/E_oed + 1/Q)) [m²/s], g = 9.81 m/s²."""
    s0: float
    """Undrained settlement Hσ₀/(E_oed + Q) [m]."""
    s_inf: float
    """Final settlement Hσ₀/E_oed [m]."""


def consolidation_constants(material, height: float, sigma0: float) -> Consolidation:
    """:class:`Consolidation` of ``material`` (a :class:`warpsph.scene.Material`), height [m], σ₀ [Pa]."""
    e_oed, q = material.oedometric_modulus, material.biot_modulus
    cv = material.hydraulic_conductivity / (material.water_density * 9.81 * (1 / e_oed + 1 / q))
    return Consolidation(sigma0 * q / (q + e_oed), cv, height * sigma0 / (e_oed + q), height * sigma0 / e_oed)


def _modes(terms: int) -> list[float]:
    return [math.pi * (2 * m + 1) / 2 for m in range(terms)]


def terzaghi_pressure(zeta, height: float, p0: float, tv: float, terms: int = 400):
    """Excess pore pressure [Pa] at depths ``zeta`` [m] below the drained top, time factor ``tv``: Terzaghi's
    p(ζ, t) = Σ (2p₀/M) sin(Mζ/H) exp(−M² T_v), M = π(2m + 1)/2, T_v = c_v t/H², for a column of height H
    with a drained top and an impermeable base under a step load σ₀ from the undrained state."""
    return sum(2 * p0 / M * np.sin(M * np.asarray(zeta) / height) * math.exp(-M * M * tv) for M in _modes(terms))


def degree_of_consolidation(tv: float, terms: int = 400) -> float:
    """U(T_v) = 1 − Σ (2/M²) exp(−M² T_v)."""
    return 1.0 - sum(2.0 / M**2 * math.exp(-M * M * tv) for M in _modes(terms))


def pressure_l2(pressure, zeta, height: float, p0: float, tv: float) -> float:
    """RMS over the particles of the pore pressure [Pa] minus :func:`terzaghi_pressure`, over p₀."""
    exact = terzaghi_pressure(zeta, height, p0, tv)
    return float(np.sqrt(np.mean((np.asarray(pressure) - exact) ** 2)) / p0)


def gardner_infiltration(z, t: float, length: float, alpha: float, storage: float, conductivity: float,
                         rate_before: float, rate: float, terms: int = 200) -> np.ndarray:
    """K/K_s [-] at heights ``z`` [m] above the water table, ``t`` [s] after the surface's infiltration
    rate turned from ``rate_before`` to ``rate`` [m/s]; ``storage`` = θ_s − θ_r [-], α [1/m], K_s =
    ``conductivity`` [m/s].

    Srivastava & Yeh (1991), a homogeneous Gardner column: with K = K_s exp(−αψ) and θ − θ_r = (θ_s − θ_r)
    exp(−αψ), Richards' equation is linear in K* = K/K_s, c ∂K*/∂t = ∂²K*/∂z² + α ∂K*/∂z with
    c = α(θ_s − θ_r)/K_s, z the height above the water table (K* = 1 there) and the flux K_s (K*_z/α + K*) = q
    at the surface z = L. From the steady profile of the rate q_A, K*_A = q_A/K_s + (1 − q_A/K_s) e^(−αz),
    the rate turns to q_B at t = 0: K* is the steady profile of q_B plus
    e^(−αz/2) Σ a_k sin(λ_k z) exp(−(λ_k² + α²/4) t/c), tan(λ_k L) = −2λ_k/α."""
    z = np.asarray(z, dtype=float)
    c = alpha * storage / conductivity

    def steady(q, at):
        return q / conductivity + (1.0 - q / conductivity) * np.exp(-alpha * at)

    grid = np.linspace(0.0, length, 4001)
    initial = np.exp(0.5 * alpha * grid) * (steady(rate_before, grid) - steady(rate, grid))
    out = steady(rate, z)
    for k in range(terms):  # λ_k in ((k + ½)π/L, (k + 1)π/L), by bisection
        lo, hi = (k + 0.5) * math.pi / length, (k + 1.0) * math.pi / length
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            f_lo = lo * math.cos(lo * length) + 0.5 * alpha * math.sin(lo * length)
            f_mid = mid * math.cos(mid * length) + 0.5 * alpha * math.sin(mid * length)
            lo, hi = (lo, mid) if f_lo * f_mid <= 0.0 else (mid, hi)
        lam = 0.5 * (lo + hi)
        mode = np.sin(lam * grid)
        coefficient = np.trapezoid(initial * mode, grid) / np.trapezoid(mode * mode, grid)
        decay = math.exp(-(lam**2 + 0.25 * alpha**2) * t / c)
        out = out + coefficient * decay * np.exp(-0.5 * alpha * z) * np.sin(lam * z)
    return out


class Mandel(NamedTuple):
    """Constants of Mandel's problem for a material (incompressible grains aside, Biot's α = 1)."""

    skempton: float
    """B = Q/(K + Q) [-]."""
    nu: float
    nu_u: float
    """Drained and undrained Poisson ratios [-]."""
    shear: float
    """G [Pa]."""
    c: float
    """Consolidation coefficient 2κB²G(1 − ν)(1 + ν_u)²/[9(1 − ν_u)(ν_u − ν)] [m²/s], κ = k_h/γ_w."""


def mandel_constants(material) -> Mandel:
    """:class:`Mandel` of ``material`` (a :class:`~warpsph.scene.Material` with pore water)."""
    shear, q = material.shear_modulus, material.biot_modulus
    bulk = material.lame_lambda + 2.0 * shear / 3.0
    undrained = bulk + q
    nu, nu_u = material.poisson_ratio, (3.0 * undrained - 2.0 * shear) / (2.0 * (3.0 * undrained + shear))
    b = q / undrained
    c = 2.0 * material.permeability * b**2 * shear * (1 - nu) * (1 + nu_u) ** 2 / (9.0 * (1 - nu_u) * (nu_u - nu))
    return Mandel(b, nu, nu_u, shear, c)


def _mandel_roots(m: Mandel, terms: int) -> np.ndarray:
    """The first ``terms`` roots α_n of tan α = (1 − ν)/(ν_u − ν) α, one in each ((n − 1)π, (n − ½)π)."""
    from scipy.optimize import brentq

    slope = (1.0 - m.nu) / (m.nu_u - m.nu)
    gap = 1e-12
    return np.array([brentq(lambda a: math.tan(a) - slope * a, (n * math.pi) + gap, (n + 0.5) * math.pi - gap)
                     for n in range(terms)])  # fmt: skip


def mandel_undrained_pressure(half_width: float, force: float, m: Mandel) -> float:
    """p(x, 0⁺) = F B (1 + ν_u)/(3a) [Pa], uniform across the specimen (a = ``half_width``, F = ``force``)."""
    return force * m.skempton * (1 + m.nu_u) / (3.0 * half_width)


def mandel_pressure(x, half_width: float, force: float, t: float, m: Mandel, terms: int = 200) -> np.ndarray:
    """Pore pressure p(x, t) [Pa] of a specimen 2a wide (a = ``half_width``) under a force 2F
    (F = ``force`` [N/m], on the half-width) applied at t = 0, at distances ``x`` from its centre (Cheng
    & Detournay 1988); p(x, 0⁺) = F B (1 + ν_u)/(3a)."""
    x = np.asarray(x, dtype=float)
    a = half_width
    if t <= 0.0:
        return np.full_like(x, mandel_undrained_pressure(a, force, m))
    alpha = _mandel_roots(m, terms)
    sin, cos = np.sin(alpha), np.cos(alpha)
    weight = sin / (alpha - sin * cos) * np.exp(-(alpha**2) * m.c * t / a**2)
    modes = np.cos(np.outer(x / a, alpha)) - cos
    return 2.0 * mandel_undrained_pressure(a, force, m) * (modes @ weight)


def mandel_settlement(height: float, half_width: float, force: float, t: float, m: Mandel, terms: int = 200) -> float:
    """The plates' approach: how far the plate at ``height`` above the mid-plane moves towards it [m]."""
    a = half_width
    alpha = _mandel_roots(m, terms)
    sin, cos = np.sin(alpha), np.cos(alpha)
    decay = np.exp(-(alpha**2) * m.c * max(t, 0.0) / a**2)
    strain = (-force * (1 - m.nu) / (2 * m.shear * a)
              + force * (1 - m.nu_u) / (m.shear * a) * float(np.sum(sin * cos / (alpha - sin * cos) * decay)))
    return -strain * height

