"""Limit equilibrium beside strength reduction: Bishop's simplified method and Spencer's on circular
slip surfaces, the critical circle searched over a grid, on a 2D model's particles taken as slices
(docs/scenes.md, *Limit equilibrium*)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

SUBSLICES = 4
"""Slices per column of particles: each particle's cell split into vertical strips, so the base's
curvature across a column is integrated."""
SMALLEST_M_ALPHA = 0.2
"""A circle whose slices have m_α = cos α + sin α tan φ′/F below this is left out (Whitman & Bailey's
limit: a base steeper than the soil's friction allows at the toe)."""
FEWEST_SLICES = 3
"""A circle must cut at least this many columns of particles."""
GRID = 16
"""Centres (per axis) and radii (per centre) of the coarse search; each refinement as many again."""
REFINEMENTS = 3


def strength(material) -> tuple[float, float]:
    """A scene material's (c′ [Pa], tan φ′) on a slip surface: von Mises its cohesion alone (c_u), the
    Mohr–Coulomb and Drucker–Prager criteria both; a material that does not yield (inf, 0)."""
    if material.model != "viscoplastic":
        return math.inf, 0.0
    if material.yield_function == "von_mises":
        return material.cohesion, 0.0
    return material.cohesion, math.tan(math.radians(material.friction_angle))


@dataclass(frozen=True)
class Ground:
    """A 2D model's particles in vertical strips ``width`` [m] wide, ``SUBSLICES`` to a column of
    particles: the slices of every circle. Per strip, ascending: the particles' heights [m], the weight
    at and above each (one entry more, the last 0) [N/m], and each particle's cohesion [Pa], tan φ′ and pore
    pressure [Pa] (compression positive, negative only where suction counts); per strip, its surface's height
    [m] and the pressure of free water standing on it [Pa] (a reservoir)."""

    x: np.ndarray
    width: float
    cell: float
    """The particle spacing [m]: the height of a particle's cell."""
    y: list
    above: list
    weight: list
    cohesion: list
    tan_phi: list
    pore: list
    surface: np.ndarray
    ponded: np.ndarray
    water_unit_weight: float

    @property
    def bottom(self) -> float:
        return min(float(y[0]) for y in self.y) - 0.5 * self.cell

    @property
    def top(self) -> float:
        return max(float(y[-1]) for y in self.y) + 0.5 * self.cell


def ground(position: np.ndarray, weight: np.ndarray, cohesion: np.ndarray, tan_phi: np.ndarray,
           pore_pressure: np.ndarray | None, width: float, water_unit_weight: float = 9.81e3,
           free_water=None, suction: bool = False) -> Ground:  # fmt: skip
    """The columns of particles at ``position`` (N,3) [m] (x across, y up) with ``weight`` (N,) [N/m],
    ``cohesion`` (N,) [Pa] (inf: a body that does not yield), ``tan_phi`` (N,) and ``pore_pressure``
    (N,) [Pa] or None, ``width`` the particle spacing [m]; ``water_unit_weight`` ρ_w g [N/m³];
    ``free_water(x, y)`` the pressure [Pa] of free water standing on the ground's surface at x, y (C,)
    [m], or None where there is none; ``suction``: a negative pore pressure (Bishop's χ p_w under
    suction) adds to the base's normal stress, as the effective stress σ′ = σ − χ p_w takes it (False:
    it counts as zero, Bishop's method's and SLOPE/W's convention)."""
    column = np.round((position[:, 0] - position[:, 0].min()) / width).astype(np.int64)
    pore = np.zeros(len(position)) if pore_pressure is None else np.asarray(pore_pressure, dtype=float)
    if not suction:
        pore = np.maximum(pore, 0.0)
    xs, ys, above, weights, cs, ts, us, tops = [], [], [], [], [], [], [], []
    strips = (np.arange(SUBSLICES) + 0.5) / SUBSLICES - 0.5
    order = np.lexsort((position[:, 1], column))  # by column, then upwards
    starts = np.flatnonzero(np.diff(column[order], prepend=column[order][0] - 1))
    for rows in np.split(order, starts[1:]):
        strip = weight[rows].astype(float) / SUBSLICES
        for offset in strips:
            xs.append(float(np.mean(position[rows, 0])) + offset * width)
            ys.append(position[rows, 1].astype(float))
            weights.append(strip)
            above.append(np.append(np.cumsum(strip[::-1])[::-1], 0.0))
            cs.append(cohesion[rows].astype(float))
            ts.append(tan_phi[rows].astype(float))
            us.append(pore[rows].astype(float))
            tops.append(float(position[rows[-1], 1]))
    xs, surface = np.array(xs), np.array(tops) + 0.5 * width
    ponded = np.zeros(len(xs)) if free_water is None else np.maximum(free_water(xs, surface), 0.0)
    return Ground(xs, float(width) / SUBSLICES, float(width), ys, above, weights, cs, ts, us, surface,
                  ponded, float(water_unit_weight))  # fmt: skip


@dataclass(frozen=True)
class Slices:
    """The slices of K circles over a ground's C columns, each (K, C); a column the circle does not cut
    has no weight."""

    weight: np.ndarray
    sin: np.ndarray
    """sin α, α the base's inclination, positive where the base rises in the direction of sliding."""
    cos: np.ndarray
    cohesion: np.ndarray
    tan_phi: np.ndarray
    pore: np.ndarray
    thrust: np.ndarray
    """Free water's horizontal thrust on the sliding mass's end slices [N/m], positive in the
    direction of sliding."""
    thrust_moment: np.ndarray
    """That thrust's moment about the centre in the sense of sliding, over the radius [N/m]."""
    width: float
    valid: np.ndarray
    """(K,): the circle cuts at least ``FEWEST_SLICES`` columns, stays above the model's bottom and
    inside its sides."""


EVERYWHERE = (-math.inf, math.inf, -math.inf)
"""A slip region that holds every circle."""


def slices(g: Ground, circles: np.ndarray, region: tuple[float, float, float] = EVERYWHERE) -> Slices:
    """The slices of ``circles`` (K,3: centre x, centre y, radius [m]) over the columns of ``g``: each
    column's soil above the circle's lower arc and the free water on it, its base where the arc crosses
    the column's middle; free water beside the sliding mass (each run of cut slices) pushes on its end
    slices, hydrostatic from the water's level down to where the arc ends. A circle is valid only where
    the columns it cuts lie within ``region`` (x from, x to, lowest y [m], the last one for all slices or
    one per slice): their x between the first two, their bases at or above the third."""
    xc, yc, r = (circles[:, i : i + 1] for i in range(3))
    dx = g.x[None, :] - xc
    inside = np.abs(dx) < r
    base = yc - np.sqrt(np.maximum(r * r - dx * dx, 0.0))
    k_count, c_count = base.shape
    weight, cohesion, tan_phi, pore = (np.zeros((k_count, c_count)) for _ in range(4))
    below_bottom = np.zeros(k_count, dtype=bool)
    outside = np.zeros(k_count, dtype=bool)
    half = 0.5 * g.cell
    for j in range(c_count):
        y, b = g.y[j], base[:, j]
        lower = y - half
        first = np.searchsorted(lower, b)  # the first particle wholly above the base
        cut = np.clip(first - 1, 0, len(y) - 1)  # the particle the base passes through
        part = np.where(first > 0, np.clip((y[cut] + half - b) / g.cell, 0.0, 1.0), 0.0)
        w = np.where(inside[:, j], g.above[j][first] + part * g.weight[j][cut], 0.0)
        weight[:, j] = w
        cohesion[:, j], tan_phi[:, j] = g.cohesion[j][cut], g.tan_phi[j][cut]
        pore[:, j] = np.interp(b, y, g.pore[j])
        below_bottom |= (w > 0.0) & (b < lower[0] - 1e-9 * g.cell)
        floor = region[2] if np.isscalar(region[2]) else region[2][j]
        outside |= (w > 0.0) & ((g.x[j] < region[0]) | (g.x[j] > region[1]) | (b < floor - 1e-9 * g.cell))
    sin = np.clip(dx / r, -1.0, 1.0)
    cut_columns = weight > 0.0
    weight += np.where(cut_columns, g.ponded * g.width, 0.0)
    edge = np.pad(cut_columns, ((0, 0), (1, 1)))
    level = g.surface + g.ponded / g.water_unit_weight
    ends, moment = np.zeros((k_count, c_count)), np.zeros((k_count, c_count))
    for side, outer in ((1.0, ~edge[:, :-2]), (-1.0, ~edge[:, 2:])):  # each run's left end, then its right
        dx_side = dx - 0.5 * side * g.width  # the run's end: its end slice's outer side, where its arc ends
        exit_ = yc - np.sqrt(np.maximum(r * r - dx_side * dx_side, 0.0))
        depth = np.where(cut_columns & outer & (g.ponded > 0.0), np.maximum(level - exit_, 0.0), 0.0)
        push = side * 0.5 * g.water_unit_weight * depth**2  # the water's thrust along +x, down to the arc
        ends += push
        moment += (exit_ + depth / 3.0 - yc) * push / r  # clockwise about the centre, over r
    direction = np.where(np.sum(weight * sin + moment, axis=1, keepdims=True) < 0.0, -1.0, 1.0)
    sin = direction * sin  # α positive where the base rises in the sliding direction
    inside_sides = ~cut_columns[:, 0] & ~cut_columns[:, -1]  # the arc leaves through the surface, not a side
    valid = (np.sum(cut_columns, axis=1) >= FEWEST_SLICES * SUBSLICES) & ~below_bottom & inside_sides & ~outside
    return Slices(weight, sin, np.sqrt(1.0 - sin * sin), cohesion, tan_phi, pore, -direction * ends, direction * moment,
                  g.width, valid)  # fmt: skip


def bishop(s: Slices, iterations: int = 100) -> np.ndarray:
    """Bishop's simplified factor of safety of each circle (K,): moment equilibrium about the centre,
    interslice forces horizontal, F = Σ (c′b + (W − ub) tan φ′)/m_α / (Σ W sin α + M_w/R), M_w the free
    water's end thrusts' moment; inf where a circle is not valid or a slice's m_α falls below
    ``SMALLEST_M_ALPHA``."""
    cut = s.weight > 0.0
    driving = np.sum(s.weight * s.sin + s.thrust_moment, axis=1)
    resisting = np.where(cut, s.cohesion * s.width + np.maximum(s.weight - s.pore * s.width, 0.0) * s.tan_phi, 0.0)
    factor = np.ones(len(driving))
    ok = s.valid & (driving > 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        for _ in range(iterations):
            m = s.cos + s.sin * s.tan_phi / factor[:, None]
            new = np.sum(np.where(cut, resisting / m, 0.0), axis=1) / driving
            done = np.abs(new - factor) <= 1e-9 * np.abs(factor)
            factor = np.where(ok, new, factor)
            if np.all(done | ~ok):
                break
        m = s.cos + s.sin * s.tan_phi / factor[:, None]
        ok &= np.all(~cut | (m >= SMALLEST_M_ALPHA), axis=1) & np.isfinite(factor) & (factor > 0.0)
    return np.where(ok, factor, np.inf)


def spencer(s: Slices, k: int, near: float) -> tuple[float, float]:
    """Spencer's factor of safety of circle ``k`` and the inclination θ [rad] of its interslice forces:
    force and moment equilibrium together, the forces parallel. Each slice's interslice resultant is
    Q = ((c′b/cos α + (W cos α − H sin α − ub/cos α) tan φ′)/F − W sin α − H cos α) / m_θ,
    m_θ = cos(α − θ) + sin(α − θ) tan φ′/F, H free water's thrust on an end slice;
    ΣQ = 0 (forces) and ΣQ cos(α − θ) = M_w/R − ΣH cos α (moments about the centre, the thrusts acting
    above the bases) fix F and θ, F sought within a factor 2 of ``near`` (Bishop's) where every m_θ > 0,
    θ within ±1.2 rad, the first where both are continuous in θ. (nan, nan) where none is found."""
    cut = s.weight[k] > 0.0
    w, sin, cos, c, t, u, h = (a[k][cut] for a in (s.weight, s.sin, s.cos, s.cohesion, s.tan_phi, s.pore, s.thrust))
    alpha, b = np.arctan2(sin, cos), s.width
    lifted = float(np.sum(s.thrust_moment[k]) - np.sum(h * cos))  # the thrusts' moment beyond that at the bases

    def sums(factor: float, theta: float) -> tuple[float, float]:
        m = np.cos(alpha - theta) + np.sin(alpha - theta) * t / factor
        if np.any(m <= 0.0):
            return math.nan, math.nan
        q = ((c * b / cos + (w * cos - h * sin - u * b / cos) * t) / factor - w * sin - h * cos) / m
        return float(np.sum(q)), float(np.sum(q * np.cos(alpha - theta))) - lifted

    def solve(f, start: float) -> float:
        """A root of ``f`` by the secant method from ``start`` and 1.01 ``start``; nan where it leaves
        [start/2, 2 start] or does not converge."""
        a, z = start, 1.01 * start
        fa, fz = f(a), f(z)
        for _ in range(40):
            if not (np.isfinite(fa) and np.isfinite(fz)) or fz == fa:
                return math.nan
            a, z, fa = z, z - fz * (z - a) / (fz - fa), fz
            if not 0.5 * start <= z <= 2.0 * start:
                return math.nan
            fz = f(z)
            if abs(z - a) <= 1e-10 * abs(z):
                return z
        return math.nan

    def by(which: int):
        return lambda theta: solve(lambda f: sums(f, theta)[which], near)

    forces, moments = by(0), by(1)
    grid = np.linspace(-1.2, 1.2, 25)
    gaps = [forces(th) - moments(th) for th in grid]
    for a, ga, z, gz in zip(grid, gaps, grid[1:], gaps[1:]):
        if not (np.isfinite(ga) and np.isfinite(gz) and ga * gz <= 0.0):
            continue
        for _ in range(40):
            mid = 0.5 * (a + z)
            gm = forces(mid) - moments(mid)
            if not np.isfinite(gm):
                break
            a, ga, z = (a, ga, mid) if ga * gm <= 0.0 else (mid, gm, z)
        theta = 0.5 * (a + z)
        factor = moments(theta)
        if abs(forces(theta) - factor) <= 1e-6 * abs(factor):  # a root, not a jump between two branches
            return factor, theta
    return math.nan, math.nan


@dataclass(frozen=True)
class CriticalCircle:
    """The slip circle of least factor of safety found (Bishop's) and Spencer's on it."""

    centre: tuple[float, float]
    radius: float
    bishop: float
    spencer: float
    theta: float
    """Spencer's interslice force inclination [rad]."""
    circles: int
    """The circles tried."""


def critical_circle(g: Ground, region: tuple[float, float, float] = EVERYWHERE) -> CriticalCircle | None:
    """The circle of least Bishop factor over a grid of centres above the ground (from its top to 1.5
    heights above it, across its width) and radii whose arcs reach from its top to its bottom, refined
    ``REFINEMENTS`` times around the best, and Spencer's factor on it; with ``region`` (x from, x to,
    lowest y [m], for all slices or one per slice) the centres span its width and the circles are those
    whose sliding mass lies within it (:func:`slices`). None where no circle cuts the ground validly."""
    left, right = max(float(g.x.min()), region[0]), min(float(g.x.max()), region[1])
    height = g.top - max(g.bottom, float(np.min(region[2])))
    if not (left < right and height > 0.0):
        return None
    best, best_factor, tried = None, math.inf, 0
    span = np.array([right - left, 1.5 * height, height])
    lo = np.array([left, g.top + 0.02 * height, 0.0])
    for level in range(REFINEMENTS + 1):
        if level:
            span = span * 4.0 / GRID
            lo = best - 0.5 * span
        xs = np.linspace(lo[0], lo[0] + span[0], GRID)
        ys = np.linspace(max(lo[1], g.top + 1e-3 * height), lo[1] + span[1], GRID)
        centres = np.array([(x, y) for x in xs for y in ys])
        if level == 0:
            depth = np.linspace(0.02, 1.0, GRID)  # the arc's lowest point, from the top down to the bottom
            circles = np.array([(x, y, y - g.top + d * height) for x, y in centres for d in depth])
        else:
            radii = np.linspace(best[2] - 0.5 * span[2], best[2] + 0.5 * span[2], GRID)
            circles = np.array([(x, y, r) for x, y in centres for r in radii if r > 0.0])
        factors = bishop(slices(g, circles, region))
        tried += len(circles)
        k = int(np.argmin(factors))
        if not np.isfinite(factors[k]):
            if best is None:
                return None
            continue
        if best is None or factors[k] <= best_factor:
            best, best_factor = circles[k], float(factors[k])
    spencer_factor, theta = spencer(slices(g, best[None, :], region), 0, best_factor)
    return CriticalCircle((float(best[0]), float(best[1])), float(best[2]), best_factor, float(spencer_factor),
                          float(theta), tried)  # fmt: skip


def unsheared_top(g: Ground) -> np.ndarray:
    """Per slice, a spacing above the rows of particles that a slip through the slice does not shear: its
    lowest row, which rests on the soil's bottom, and the run up from it of particles stronger at their own
    vertical effective stress than the slice's weakest soil would be there (a stronger layer, a body that
    does not yield). Above that level the particles' shear band can form."""
    top = np.empty(len(g.x))
    for j, (y, c, t) in enumerate(zip(g.y, g.cohesion, g.tan_phi)):
        stress = np.maximum((g.above[j][:-1] - 0.5 * g.weight[j]) / g.width + g.ponded[j] - g.pore[j], 0.0)
        soils = np.unique(np.stack([c, t], axis=1), axis=0)
        weakest = np.min(soils[:, :1] + stress[None, :] * soils[:, 1:], axis=0)
        stronger = c + stress * t > weakest * (1.0 + 1e-9)
        rows = len(y) if stronger.all() else int(np.argmin(stronger))
        top[j] = y[max(rows, 1) - 1] + g.cell
    return top


def above_the_floor(g: Ground, region: tuple, critical: CriticalCircle) -> float:
    """Bishop's factor with the arcs kept above the rows of particles that do not shear (:func:`unsheared_top`),
    where the ``critical`` circle of ``region`` dips below them (nan where it stays higher): a strength-reduction
    mechanism along the soil's bottom or the top of a stronger layer forms its band in the rows above, at least
    as high as this circle."""
    (xc, yc), r = critical.centre, critical.radius
    j = int(np.argmin(np.abs(g.x - xc)))  # the arc's lowest slice in the ground
    lowest = yc - math.sqrt(max(r * r - (g.x[j] - xc) ** 2, 0.0))
    floor = np.maximum(unsheared_top(g), region[2])
    if lowest >= floor[j]:
        return math.nan
    raised = critical_circle(g, (region[0], region[1], floor))
    return raised.bishop if raised is not None else math.nan
