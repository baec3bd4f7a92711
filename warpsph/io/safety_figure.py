"""A safety phase's figure in the run directory (``safety_<phase>.svg``, docs/output.md): the mechanism of
its weakest failing trial with the critical slip circle of limit equilibrium, and every trial's largest
displacement against its factor. Plain SVG, written without a plotting library."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

WIDTH, HEIGHT, MARGIN = 560.0, 300.0, 40.0
"""Each panel's size and margin [px]."""


def _colour(value: float) -> str:
    """White to dark red over [0, 1]."""
    v = min(max(value, 0.0), 1.0)
    return f"rgb({int(255 - 90 * v)},{int(255 - 255 * v)},{int(255 - 255 * v)})"


def write_safety_figure(path: Path, positions: np.ndarray | None, plastic_strain: np.ndarray | None, dx: float,
                        circle: list[float], trials: list, factor: float) -> None:  # fmt: skip
    """Write ``path``: above, the particles at ``positions`` (N,3) [m] coloured by ``plastic_strain`` (N,)
    (each particle a square of side ``dx``; None: no failing trial), with ``circle`` [x, y, r] [m] (empty:
    none); below, the ``trials`` rows (factor, outcome, ratio, steps, displacement, ...) as largest
    displacement against factor, the factor of safety ``factor`` marked."""
    parts = []
    if positions is not None and len(positions):
        lo, hi = positions[:, :2].min(axis=0) - dx, positions[:, :2].max(axis=0) + dx
        scale = min((WIDTH - 2 * MARGIN) / (hi[0] - lo[0]), (HEIGHT - 2 * MARGIN) / (hi[1] - lo[1]))

        def at(x: float, y: float) -> tuple[float, float]:
            return MARGIN + (x - lo[0]) * scale, HEIGHT - MARGIN - (y - lo[1]) * scale

        strain = np.zeros(len(positions)) if plastic_strain is None else np.asarray(plastic_strain, dtype=float)
        top = float(strain.max()) if strain.size and strain.max() > 0.0 else 1.0
        side = dx * scale
        for (x, y, _), e in zip(positions, strain):
            px, py = at(x, y)
            parts.append(f'<rect x="{px - side / 2:.1f}" y="{py - side / 2:.1f}" width="{side:.1f}" height='
                         f'"{side:.1f}" fill="{_colour(e / top)}" stroke="#999" stroke-width="0.3"/>')  # fmt: skip
        if circle:
            cx, cy = at(circle[0], circle[1])
            parts.append(f'<clipPath id="ground"><rect x="0" y="0" width="{WIDTH:.0f}" '
                         f'height="{HEIGHT:.0f}"/></clipPath>')  # fmt: skip
            parts.append(f'<circle cx="{cx:.1f}" cy="{cy:.1f}" r="{circle[2] * scale:.1f}" fill="none" '
                         f'stroke="#1f77b4" stroke-width="1.5" clip-path="url(#ground)"/>')  # fmt: skip
        parts.append(f'<text x="{MARGIN}" y="20">weakest failing trial: plastic strain (white 0, red {top:.3g}); '
                     f'blue: the critical slip circle</text>')  # fmt: skip
    rows = np.asarray(trials, dtype=float).reshape(len(trials), -1) if len(trials) else np.zeros((0, 5))
    finite = rows[np.isfinite(rows[:, 4])] if len(rows) else rows
    if len(finite):
        f_lo, f_hi = float(finite[:, 0].min()), float(finite[:, 0].max())
        d_hi = float(finite[:, 4].max()) or 1.0
        f_span = (f_hi - f_lo) or 1.0

        def plot(f: float, d: float) -> tuple[float, float]:
            return (MARGIN + (f - f_lo) / f_span * (WIDTH - 2 * MARGIN),
                    2 * HEIGHT - MARGIN - d / d_hi * (HEIGHT - 2 * MARGIN))  # fmt: skip

        x0, y0 = plot(f_lo, 0.0)
        x1, y1 = plot(f_hi, d_hi)
        parts.append(f'<path d="M{x0:.1f},{y1:.1f} L{x0:.1f},{y0:.1f} L{x1:.1f},{y0:.1f}" fill="none" stroke="black"/>')
        order = np.argsort(finite[:, 0])
        points = " ".join(f"{plot(f, d)[0]:.1f},{plot(f, d)[1]:.1f}" for f, d in finite[order][:, [0, 4]])
        parts.append(f'<polyline points="{points}" fill="none" stroke="#777"/>')
        marks = {1: "#2ca02c", 0: "#d62728", -1: "#ff7f0e"}
        for f, outcome, d in finite[:, [0, 1, 4]]:
            px, py = plot(f, d)
            parts.append(f'<circle cx="{px:.1f}" cy="{py:.1f}" r="3.5" fill="{marks.get(int(outcome), "black")}"/>')
        if math.isfinite(factor):
            fx, _ = plot(factor, 0.0)
            parts.append(f'<line x1="{fx:.1f}" y1="{y1:.1f}" x2="{fx:.1f}" y2="{y0:.1f}" stroke="black" '
                         f'stroke-dasharray="4 3"/>')  # fmt: skip
        parts.append(f'<text x="{MARGIN}" y="{HEIGHT + 20}">largest displacement (0 to {d_hi:.3g} m) against the '
                     f'factor ({f_lo:.3g} to {f_hi:.3g}): green stood, red failed, orange undecided; dashed: '
                     f'F = {factor:.4g}</text>')  # fmt: skip
    svg = (f'<svg xmlns="http://www.w3.org/2000/svg" width="{WIDTH:.0f}" height="{2 * HEIGHT:.0f}" '
           f'font-family="sans-serif" font-size="11">\n' + "\n".join(parts) + "\n</svg>\n")  # fmt: skip
    tmp = path.with_suffix(".svg.tmp")
    tmp.write_text(svg)
    tmp.replace(path)
