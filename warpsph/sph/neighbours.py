"""Neighbour lists built with Warp's hash grid, stored as compressed rows (CSR).

A :class:`NeighbourList` holds, for each of the first ``n_query`` query points, the indices of the
source points closer than the support radius 2h (the query point itself excluded when both sets are
the same). It is built once per step and reused by every stage of that step; the hash-grid query
only yields candidates, so the distance test is done here.
"""


import functools

import numpy as np
import warp as wp

from warpsph.launching import launch_rows
from warpsph.sph.spec import Spec


@functools.cache
def _kernels(spec: Spec):
    real, vec3 = spec.real, spec.vec3

    @wp.kernel(enable_backward=False, module="unique")
    def gather(
        first: int,
        grid: wp.uint64,
        query: wp.array(dtype=vec3),
        source: wp.array(dtype=vec3),
        radius: real,
        same_set: int,
        width: int,
        counts: wp.array(dtype=wp.int32),
        padded: wp.array(dtype=wp.int32),
        overflow: wp.array(dtype=wp.int32),
    ):
        """One query pass (a row kernel): the neighbour count of every query point and its first
        ``width`` neighbours in row ``a`` of the padded table; ``overflow[0]`` = 1 where a count
        exceeds ``width`` (the only value any row stores there, so concurrent rows cannot race)."""
        a = first + wp.tid()
        x = query[a]
        n = int(0)
        row = a * width
        r2 = radius * radius
        for b in wp.hash_grid_query(grid, x, radius):
            if same_set == 1 and b == a:
                continue
            d = source[b] - x
            if wp.dot(d, d) < r2:
                if n < width:
                    padded[row + n] = b
                n += 1
        counts[a] = n
        if n > width:
            overflow[0] = 1

    @wp.kernel(enable_backward=False, module="unique")
    def compact(
        first: int,
        width: int,
        padded: wp.array(dtype=wp.int32),
        offsets: wp.array(dtype=wp.int32),
        indices: wp.array(dtype=wp.int32),
    ):
        """Copy row ``a`` of the padded table to its CSR place (a row kernel)."""
        a = first + wp.tid()
        start = offsets[a]
        row = a * width
        for k in range(offsets[a + 1] - start):
            indices[start + k] = padded[row + k]

    return gather, compact


def grid_dims(extent: np.ndarray, cell: float, dim: int, max_cells: int = 256) -> tuple[int, int, int]:
    """Hash-grid resolution covering ``extent`` [m] (3,) with cells of width ``cell`` [m]."""
    dims = [max(1, min(max_cells, int(np.ceil(e / cell)) + 2)) for e in extent]
    if dim < 3:
        dims[2] = 1
    if dim == 1:
        dims[0] = 1
    return dims[0], dims[1], dims[2]


class NeighbourScratch:
    """What a build needs only while it runs: the hash grid of the sources and the padded table of
    the query pass. Lists built one after the other share one (the solver's lists do), so these
    exist once, not once per list."""

    def __init__(self, spec: Spec, extent: np.ndarray, radius: float, device):
        nx, ny, nz = grid_dims(np.asarray(extent, dtype=float), radius, spec.dim)
        self.grid = wp.HashGrid(nx, ny, nz, device=device, dtype=spec.real)
        self.padded = wp.zeros(1, dtype=wp.int32, device=device)
        """(n_query × width,) int32 padded neighbour table of the last query pass."""
        self.device = device

    def table(self, size: int) -> wp.array:
        """The padded table, grown to at least ``size`` entries."""
        if self.padded.shape[0] < size:
            self.padded = wp.empty(size, dtype=wp.int32, device=self.device)
        return self.padded


class NeighbourList:
    """CSR neighbour list of query points against source points within ``radius`` [m].

    ``offsets`` (n_query + 1,) int32 and ``indices`` (n_pairs,) int32: the neighbours of query
    point a are ``indices[offsets[a]:offsets[a+1]]``, in hash-grid cell order.

    A build makes one hash-grid query pass: it stores up to ``width`` neighbours per query point
    in a padded (n_query, width) table (:class:`NeighbourScratch`) while counting them, then scans
    the counts and compacts the table into CSR. ``width`` adapts: when a point has more neighbours
    than the table holds (on the first build, and whenever the particles crowd), the table grows to
    1.25 × the largest count and the query pass is repeated.
    """

    GROWTH = 1.25
    """Headroom of the padded table over the largest neighbour count seen [-]."""
    INDEX_HEADROOM = 1.05
    """Headroom of the CSR indices over the pairs of the build that (re)allocates them [-]."""

    def __init__(self, spec: Spec, extent: np.ndarray, radius: float, device, same_set: bool = False,
                 scratch: NeighbourScratch | None = None):  # fmt: skip
        """``scratch``: shared with the lists built in turn with this one (a list of its own without)."""
        self.spec = spec
        self.radius = radius
        self.same_set = same_set
        self.device = device
        self.scratch = scratch or NeighbourScratch(spec, extent, radius, device)
        self.offsets = wp.zeros(1, dtype=wp.int32, device=device)
        self.counts = wp.zeros(1, dtype=wp.int32, device=device)
        self.indices = wp.zeros(1, dtype=wp.int32, device=device)
        self.width = 0
        """Neighbours per row of the padded table [-]."""
        self.overflow = wp.zeros(1, dtype=wp.int32, device=device)
        """(1,) int32 1 where the last query pass found more neighbours than ``width``."""
        self.n_query = 0
        self.n_pairs = 0

    def build(self, query: wp.array, n_query: int, source: wp.array, n_source: int) -> None:
        """Find the neighbours of ``query[:n_query]`` among ``source[:n_source]``."""
        gather, compact = _kernels(self.spec)
        real = self.spec.real
        src = source[:n_source]
        grid = self.scratch.grid
        grid.build(src, real(self.radius))
        if self.counts.shape[0] < n_query + 1:
            self.counts = wp.zeros(n_query + 1, dtype=wp.int32, device=self.device)
            self.offsets = wp.zeros(n_query + 1, dtype=wp.int32, device=self.device)
        self.n_query = n_query
        if n_query == 0:
            self.n_pairs = 0
            return
        args = [wp.uint64(grid.id), query, src, real(self.radius), int(self.same_set)]
        while True:
            padded = self.scratch.table(n_query * self.width)
            self.overflow.zero_()
            launch_rows(gather, n_query, [*args, self.width, self.counts, padded, self.overflow], self.device)
            if not self.overflow.numpy()[0]:
                break
            self.width = int(self.counts.numpy()[:n_query].max() * self.GROWTH) + 1
        self.counts[n_query : n_query + 1].zero_()
        wp.utils.array_scan(self.counts[: n_query + 1], self.offsets[: n_query + 1], inclusive=False)
        self.n_pairs = int(self.offsets[n_query : n_query + 1].numpy()[0])
        if self.indices.shape[0] < max(self.n_pairs, 1):
            self.indices = wp.zeros(int(self.n_pairs * self.INDEX_HEADROOM) + 16, dtype=wp.int32, device=self.device)
        launch_rows(compact, n_query, [self.width, padded, self.offsets, self.indices], self.device)

    def to_lists(self) -> list[np.ndarray]:
        """Host copy, one sorted index array per query point (for tests and probes)."""
        off = self.offsets.numpy()[: self.n_query + 1]
        idx = self.indices.numpy()
        return [np.sort(idx[off[a] : off[a + 1]]) for a in range(self.n_query)]
