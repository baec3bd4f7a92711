"""Closed-form solutions and the error measures of docs/verification (shared/docs/verification.md).

Step-loaded elastic column (top at y = H loaded at t = 0 by a compressive traction σ₀, front speed
c): before the front reaches the base, −σ_yy/σ₀ = 1 for H − y < c t, 0 below. A step is smeared by
any discretisation, so the front speed is measured from the loaded length d(t) = ∫(−σ_yy/σ₀) dy,
which grows at exactly c, and the plateau as a window mean behind the front.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


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


def sample_column_stress(scene, t_end: float, n_frames: int = 12, device: str = "cpu"):
    """Run ``scene`` to ``t_end`` [s] in memory and return (times, [(y, σ_yy)] profiles) at about
    ``n_frames`` evenly spaced steps, for :func:`step_wave_metrics`."""
    from warpsph.builder import build
    from warpsph.solver import Solver

    model, state = build(scene, device=device)
    scratch = model.state()
    scratch.assign(state)
    solver = Solver(model)
    dt = scene.time_step
    n_end = int(np.ceil(t_end / dt - 1e-9))
    every = max(1, n_end // n_frames)
    n = model.particle_count
    times, profiles = [], []
    for k in range(n_end):
        solver.step(state, scratch, k * dt, dt)
        state, scratch = scratch, state
        if (k + 1) % every == 0:
            q = state.particle_q.numpy()[:n].astype(np.float64)
            s = state.particle_stress.numpy()[:n, 1, 1].astype(np.float64)
            times.append((k + 1) * dt)
            profiles.append(column_profile(q, s, scene.simulation.dx))
    return times, profiles
