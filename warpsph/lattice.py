"""Filling bodies with particles on the regular lattice of spacing Δx.

The lattice holds the points whose used coordinates are integer multiples of Δx (``k Δx``);
the used axes are y in 1D, x and y in 2D, and x, y and z in 3D, and unused coordinates are 0.
A point belongs to a body when it lies inside its shape, faces included, with a tolerance of
``1e-9 Δx``. Results are (N, 3) float64 arrays sorted lexicographically by (z, y, x).
"""

from __future__ import annotations

import math
from collections.abc import Iterator

import numpy as np

from warpsph.scene_sections import Body

TOLERANCE = 1e-9
"""Boundary tolerance, as a fraction of Δx."""

_CHUNK_POINTS = 1 << 16
"""Upper bound on the candidate points tested at once (memory guard for large bodies)."""


def used_axes(dim: int) -> tuple[int, ...]:
    """Indices of the coordinates a ``dim``-dimensional scene uses: (1,), (0, 1) or (0, 1, 2)."""
    return {1: (1,), 2: (0, 1), 3: (0, 1, 2)}[dim]


def lattice_keys(points: np.ndarray, dx: float) -> np.ndarray:
    """(N,3) int64 keys of the (N,3) ``points`` on the half-spacing lattice: equal for the same lattice
    point or cell centre, so bodies' points are merged and particles identified across phases by them."""
    return np.round(np.asarray(points, dtype=float) / dx * 2.0).astype(np.int64)


CODE_SPAN = 1 << 21
"""Half-spacing lattice keys per axis that :func:`lattice_codes` can tell apart (about a million Δx)."""


def lattice_codes(points: np.ndarray, dx: float) -> np.ndarray:
    """(N,) int64 codes of the (N,3) ``points``' :func:`lattice_keys`, one number per lattice point or
    cell centre: cheaper to sort and compare than the keys. A code moves by :func:`code_step` per Δx
    along an axis."""
    keys = lattice_keys(points, dx) + CODE_SPAN // 2
    if keys.size and (keys.min() < 0 or keys.max() >= CODE_SPAN):
        raise ValueError(f"the bodies span more than {CODE_SPAN // 4} dx from the origin along an axis")
    return (keys[:, 2] * CODE_SPAN + keys[:, 1]) * CODE_SPAN + keys[:, 0]


def code_step(axis: int) -> int:
    """How much a :func:`lattice_codes` code changes for one Δx along ``axis``."""
    return 2 * CODE_SPAN**axis


def fill_body(body: Body, dx: float, dim: int) -> np.ndarray:
    """Lattice points inside ``body``: (N, 3) float64, sorted by (z, y, x)."""
    return _fill(body, dx, dim, offset=0.0, shrink=0.0)


def fill_cells(body: Body, dx: float, dim: int) -> np.ndarray:
    """Centres of the lattice cells (points offset by Δx/2 on every used axis) belonging to ``body``.

    For a box these are the cells lying wholly inside it, i.e. between lattice points of the box;
    for a polygon or circle, the cells whose centre is inside the shape. Sorted by (z, y, x).
    """
    shrink = 0.5 * dx if body.shape == "box" else 0.0
    return _fill(body, dx, dim, offset=0.5, shrink=shrink)


def lattice_span(body: Body, dx: float, dim: int) -> int:
    """Number of lattice points in the body's bounding box, computed without listing them: the count of
    :func:`fill_body` for a box, an upper bound of it for other shapes."""
    return math.prod(max(0, last - first + 1) for first, last in _index_bounds(body, dx, dim, 0.0, 0.0))


def has_lattice_point(body: Body, dx: float, dim: int) -> bool:
    """Whether :func:`fill_body` would return any point; stops at the first chunk that holds one (a box
    is decided from its bounds alone)."""
    if body.shape == "box":
        return lattice_span(body, dx, dim) > 0
    tol = TOLERANCE * dx
    ranges = _index_ranges(body, dx, dim, offset=0.0, shrink=0.0)
    return any(np.any(_contains(body, p, dim, tol)) for p in _candidates(ranges, dx, dim, 0.0))


def count_lattice_points(body: Body, dx: float, dim: int) -> int:
    """Number of points :func:`fill_body` would return, without holding them all in memory."""
    ranges = _index_ranges(body, dx, dim, offset=0.0, shrink=0.0)
    if body.shape == "box":
        return math.prod(len(r) for r in ranges)
    tol = TOLERANCE * dx
    return sum(int(np.count_nonzero(_contains(body, p, dim, tol))) for p in _candidates(ranges, dx, dim, 0.0))


def polygon_area(vertices) -> float:
    """Signed area of a polygon given as [[x, y], ...] (shoelace formula; > 0 if counter-clockwise)."""
    v = np.asarray(vertices, dtype=float).reshape(-1, 2)
    x, y = v[:, 0], v[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


def _fill(body: Body, dx: float, dim: int, offset: float, shrink: float) -> np.ndarray:
    tol = TOLERANCE * dx
    ranges = _index_ranges(body, dx, dim, offset, shrink)
    kept = [p[_contains(body, p, dim, tol, shrink)] for p in _candidates(ranges, dx, dim, offset)]
    return np.concatenate(kept) if kept else np.zeros((0, 3))


def body_bounds(body: Body, dim: int) -> tuple[np.ndarray, np.ndarray]:
    """Axis-aligned bounding box of the shape (3-vectors; unused axes are ignored by callers)."""
    if body.shape == "box":
        return np.asarray(body.min, dtype=float), np.asarray(body.max, dtype=float)
    if body.shape == "circle":
        c = np.asarray(body.center, dtype=float)
        return c - body.radius, c + body.radius
    if body.shape == "polygon":
        if dim != 2:
            raise ValueError("polygon bodies exist only in 2D")
        v = np.asarray(body.vertices, dtype=float).reshape(-1, 2)
        return np.append(v.min(axis=0), 0.0), np.append(v.max(axis=0), 0.0)
    raise ValueError(f"unknown body shape {body.shape!r}")


def _index_bounds(body: Body, dx: float, dim: int, offset: float, shrink: float) -> list[tuple[int, int]]:
    """(first, last) lattice index k per axis (x, y, z) whose coordinate (k + offset) Δx may lie in the
    body; (0, 0) on unused axes."""
    lo, hi = body_bounds(body, dim)
    tol = TOLERANCE * dx
    bounds = [(0, 0)] * 3
    for a in used_axes(dim):
        bounds[a] = (math.ceil((lo[a] + shrink - tol) / dx - offset), math.floor((hi[a] - shrink + tol) / dx - offset))
    return bounds


def _index_ranges(body: Body, dx: float, dim: int, offset: float, shrink: float) -> list[np.ndarray]:
    """Lattice indices k per axis (x, y, z) whose coordinate (k + offset) Δx may lie in the body."""
    return [np.arange(first, last + 1, dtype=np.int64) for first, last in _index_bounds(body, dx, dim, offset, shrink)]


def _candidates(ranges: list[np.ndarray], dx: float, dim: int, offset: float) -> Iterator[np.ndarray]:
    """Candidate points in (z, y, x) order, in chunks along the outermost used axis."""
    outer = used_axes(dim)[-1]
    inner = math.prod(len(r) for a, r in enumerate(ranges) if a != outer)
    if inner == 0:
        return
    step = max(1, _CHUNK_POINTS // inner)
    shift = np.array([offset if a in used_axes(dim) else 0.0 for a in range(3)])
    for start in range(0, len(ranges[outer]), step):
        part = list(ranges)
        part[outer] = ranges[outer][start : start + step]
        kz, ky, kx = np.meshgrid(part[2], part[1], part[0], indexing="ij")
        k = np.stack([kx.ravel(), ky.ravel(), kz.ravel()], axis=1)
        yield (k + shift) * dx


def _contains(body: Body, points: np.ndarray, dim: int, tol: float, shrink: float = 0.0) -> np.ndarray:
    """Mask of ``points`` inside the shape (box shrunk by ``shrink``), within ``tol`` of its boundary."""
    axes = list(used_axes(dim))
    p = points[:, axes]
    if body.shape == "box":
        lo = np.asarray(body.min, dtype=float)[axes] + shrink - tol
        hi = np.asarray(body.max, dtype=float)[axes] - shrink + tol
        return np.all((p >= lo) & (p <= hi), axis=1)
    if body.shape == "circle":
        d = p - np.asarray(body.center, dtype=float)[axes]
        return np.einsum("ij,ij->i", d, d) <= (body.radius + tol) ** 2
    return _polygon_contains(np.asarray(body.vertices, dtype=float).reshape(-1, 2), p, tol)


def _polygon_contains(vertices: np.ndarray, p: np.ndarray, tol: float) -> np.ndarray:
    """Even-odd point-in-polygon test for (M, 2) points, counting points within ``tol`` of an edge."""
    a = vertices[None, :, :]
    b = np.roll(vertices, -1, axis=0)[None, :, :]
    q = p[:, None, :]
    # crossings of the ray from q towards +x with each edge a-b
    straddles = (a[..., 1] > q[..., 1]) != (b[..., 1] > q[..., 1])
    with np.errstate(divide="ignore", invalid="ignore"):
        x_cross = a[..., 0] + (q[..., 1] - a[..., 1]) * (b[..., 0] - a[..., 0]) / (b[..., 1] - a[..., 1])
    inside = np.count_nonzero(straddles & (q[..., 0] < x_cross), axis=1) % 2 == 1
    # distance to each edge segment
    ab = b - a
    length2 = np.einsum("...i,...i->...", ab, ab)
    t = np.clip(np.einsum("...i,...i->...", q - a, ab) / np.where(length2 > 0, length2, 1.0), 0.0, 1.0)
    nearest = a + t[..., None] * ab
    dist2 = np.einsum("...i,...i->...", q - nearest, q - nearest)
    return inside | np.any(dist2 <= tol * tol, axis=1)


def lattice_neighbours(x0: np.ndarray, dx: float, axes: list[int]) -> np.ndarray:
    """(len(axes), 2, M) indices into ``x0`` (M,3) [m] of each point's lattice neighbours at −Δx and +Δx
    along each of ``axes`` among the same points, −1 where there is none."""
    out = np.full((len(axes), 2, len(x0)), -1, dtype=np.int64)
    if not len(x0):
        return out
    codes = lattice_codes(x0, dx)
    order = np.argsort(codes)
    for k, axis in enumerate(axes):
        for side, step in enumerate((-1, 1)):
            wanted = codes + step * code_step(axis)
            at = np.minimum(np.searchsorted(codes, wanted, sorter=order), len(codes) - 1)
            found = codes[order[at]] == wanted
            out[k, side] = np.where(found, order[at], -1)
    return out
