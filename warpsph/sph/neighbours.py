"""Neighbour lists built with Warp's hash grid, stored as compressed rows (CSR).

A :class:`NeighbourList` holds, for each of the first ``n_query`` query points, the indices of the
source points closer than the support radius 2h (the query point itself excluded when both sets are
the same). It is built once per step, with no read of the device, and reused by every stage of that
step; :meth:`NeighbourList.check` grows its room at the run's check cadence (docs/performance.md).
"""


import functools

import numpy as np
import warp as wp

from warpsph.launching import launch_rows
from warpsph.sph.spec import Spec


@functools.cache
def _gather_kernel(spec: Spec):
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
        table_start: int,
        counts: wp.array(dtype=wp.int32),
        padded: wp.array(dtype=wp.int32),
        overflow: wp.array(dtype=wp.int32),
    ):
        """One query pass (a row kernel): the neighbour count of every query point and its first
        ``width`` neighbours in row ``a − table_start`` of the padded table; ``overflow[0]`` = 1 where a
        count exceeds ``width`` (the only value any row stores there, so concurrent rows cannot race)."""
        a = first + wp.tid()
        x = query[a]
        n = int(0)
        row = (a - table_start) * width
        r2 = radius * radius
        for b in wp.hash_grid_query(grid, x, radius):
            if same_set == 1 and b == a:
                continue
            d = source[b] - x
            if wp.dot(d, d) < r2:
                if n < width:
                    padded[row + n] = b
                n += 1
        if n > width:
            overflow[0] = 1
            if width > 0:
                n = width
        counts[a] = n

    return gather


@wp.kernel(enable_backward=False)
def place(first: int, table_start: int, scanned: wp.array(dtype=wp.int32), offsets: wp.array(dtype=wp.int32)):
    """End offset of row ``a`` (a row kernel): the chunk's start offset ``offsets[table_start]`` plus
    the inclusive scan of the chunk's counts."""
    a = first + wp.tid()
    offsets[a + 1] = offsets[table_start] + scanned[a - table_start]


@wp.kernel(enable_backward=False)
def compact(
    first: int,
    n_query: int,
    width: int,
    table_start: int,
    padded: wp.array(dtype=wp.int32),
    offsets: wp.array(dtype=wp.int32),
    indices: wp.array(dtype=wp.int32),
    overflow: wp.array(dtype=wp.int32),
):
    """Copy row ``a − table_start`` of the padded table to its CSR place (a row kernel), within the
    room of ``indices``: offsets past it are clamped to it (each row clamps its own start, the last
    row the end too; a row reading its neighbour's clamps it alike) and ``overflow[1]`` = 1."""
    a = first + wp.tid()
    room = indices.shape[0]
    start = wp.min(offsets[a], room)
    end = offsets[a + 1]
    if end > room:
        end = room
        overflow[1] = 1
    row = (a - table_start) * width
    for k in range(end - start):
        indices[start + k] = padded[row + k]
    offsets[a] = start
    if a == n_query - 1:
        offsets[a + 1] = end


def grid_dims(extent: np.ndarray, cell: float, dim: int, max_cells: int = 256) -> tuple[int, int, int]:
    """Hash-grid resolution covering ``extent`` [m] (3,) with cells of width ``cell`` [m]."""
    dims = [max(1, min(max_cells, int(np.ceil(e / cell)) + 2)) for e in extent]
    if dim < 3:
        dims[2] = 1
    if dim == 1:
        dims[0] = 1
    return dims[0], dims[1], dims[2]


class NeighbourScratch:
    """What a build needs only while it runs: the hash grid of the sources, the padded table of one
    chunk's query pass and the scan of its counts. Lists built one after the other share one (the
    solver's lists do), so these exist once, not once per list."""

    def __init__(self, spec: Spec, extent: np.ndarray, radius: float, device):
        nx, ny, nz = grid_dims(np.asarray(extent, dtype=float), radius, spec.dim)
        self.grid = wp.HashGrid(nx, ny, nz, device=device, dtype=spec.real)
        self.padded = wp.zeros(1, dtype=wp.int32, device=device)
        """(chunk rows × width,) int32 padded neighbour table of the last chunk's query pass."""
        self.scanned = wp.zeros(1, dtype=wp.int32, device=device)
        """(chunk rows,) int32 inclusive scan of the last chunk's counts."""
        self.device = device

    def table(self, rows: int, width: int) -> tuple[wp.array, wp.array]:
        """The padded table and the scan, grown to at least ``rows`` × ``width`` and ``rows`` entries."""
        if self.padded.shape[0] < rows * width:
            self.padded = wp.empty(rows * width, dtype=wp.int32, device=self.device)
        if self.scanned.shape[0] < rows:
            self.scanned = wp.empty(rows, dtype=wp.int32, device=self.device)
        return self.padded, self.scanned


class NeighbourList:
    """CSR neighbour list of query points against source points within ``radius`` [m].

    ``offsets`` (n_query + 1,) int32 and ``indices`` int32: the neighbours of query point a are
    ``indices[offsets[a]:offsets[a+1]]``, in hash-grid cell order.

    A build makes one hash-grid query pass in up to ``CHUNKS`` chunks of rows: each chunk stores up to
    ``width`` neighbours per query point in a padded table (:class:`NeighbourScratch`, one chunk's
    rows, a quarter of a large set's points) while counting them, scans its counts onto the offsets of the
    chunks before it and compacts its table into CSR. A build of as many points as the last reads
    nothing from the device: it marks on the device a point with more neighbours than ``width``
    (which keeps its first ``width``) or more pairs than ``indices`` holds, and :meth:`check`, called
    at the run's check cadence, reads the marks and grows the room ahead of need (``GROWTH`` over the
    largest count, ``INDEX_HEADROOM`` over the pairs). The first build, and one of a different number
    of points, sizes the room exactly, reading the device.
    """

    GROWTH = 1.25
    """Room of the padded table over the largest neighbour count seen [-]."""
    INDEX_HEADROOM = 1.1
    """Room of the CSR indices over the pairs seen [-]."""
    CHUNKS = 4
    """Chunks of rows a build's query pass is split into, of about ``CHUNK_ROWS`` rows or more: the padded
    table holds one chunk's rows."""
    CHUNK_ROWS = 4096
    """Rows of a chunk, about: a build of fewer than 1.5 times as many is one chunk (four launches), since
    a small step's cost is its launches."""

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
        self.overflow = wp.zeros(2, dtype=wp.int32, device=device)
        """(2,) int32: [0] 1 where a build since the last check found more neighbours than ``width``,
        [1] 1 where one found more pairs than ``indices`` holds."""
        self._sizing = wp.zeros(2, dtype=wp.int32, device=device)
        """The sizing pass's marks (the counts are what it is for)."""
        self.n_query = 0
        self.n_source = 0

    def build(self, query: wp.array, n_query: int, source: wp.array, n_source: int) -> None:
        """Find the neighbours of ``query[:n_query]`` among ``source[:n_source]``."""
        real = self.spec.real
        src = source[:n_source]
        grid = self.scratch.grid
        grid.build(src, real(self.radius))
        if self.counts.shape[0] < n_query + 1:
            self.counts = wp.zeros(n_query + 1, dtype=wp.int32, device=self.device)
            self.offsets = wp.zeros(n_query + 1, dtype=wp.int32, device=self.device)
        sized = (n_query, n_source) == (self.n_query, self.n_source) and self.width > 0
        self.n_query, self.n_source = n_query, n_source
        if n_query == 0:
            self.offsets.zero_()
            return  # offsets[0] stays 0: allocated zero, and the first row's start is clamped to it
        args = [wp.uint64(grid.id), query, src, real(self.radius), int(self.same_set)]
        if not sized:
            self._size(args)
        gather = _gather_kernel(self.spec)
        rows = -(-n_query // max(1, min(self.CHUNKS, round(n_query / self.CHUNK_ROWS))))
        padded, scanned = self.scratch.table(rows, self.width)
        for start in range(0, n_query, rows):
            chunk = min(rows, n_query - start)
            launch_rows(gather, chunk, [*args, self.width, start, self.counts, padded, self.overflow], self.device,
                        start=start)  # fmt: skip
            wp.utils.array_scan(self.counts[start : start + chunk], scanned[:chunk], inclusive=True)
            launch_rows(place, chunk, [start, scanned, self.offsets], self.device, start=start)
            launch_rows(compact, chunk, [n_query, self.width, start, padded, self.offsets, self.indices,
                                         self.overflow], self.device, start=start)  # fmt: skip

    def _size(self, args: list) -> None:
        """The ``width`` a build of these points needs, ``GROWTH`` over the largest count, and the room of
        ``indices``, from a query pass that only counts (reads the device)."""
        launch_rows(_gather_kernel(self.spec), self.n_query,
                    [*args, 0, 0, self.counts, self.scratch.padded, self._sizing], self.device)  # fmt: skip
        counts = self.counts.numpy()[: self.n_query]
        self.width = int(counts.max() * self.GROWTH) + 1
        self._room(int(counts.sum()))

    def _room(self, pairs: int) -> None:
        """``indices`` grown to ``INDEX_HEADROOM`` over ``pairs`` where it holds less."""
        if self.indices.shape[0] < pairs * self.INDEX_HEADROOM:
            self.indices = wp.zeros(int(pairs * self.INDEX_HEADROOM) + 16, dtype=wp.int32, device=self.device)

    @property
    def n_pairs(self) -> int:
        """Pairs in the list as last built (reads the device)."""
        return int(self.offsets[self.n_query : self.n_query + 1].numpy()[0]) if self.n_query else 0

    def check(self) -> bool:
        """Read the marks of the builds since the last check (one wait for the device) and grow the room
        where the last build left less than ``GROWTH`` (neighbours) or ``INDEX_HEADROOM`` (pairs) of it;
        True where a build overflowed, so that its points lost neighbours (the next build then sizes the
        room as a first build does)."""
        overflowed = bool(self.overflow.numpy().any())
        self.overflow.zero_()
        if overflowed:
            self.width = 0  # the next build sizes the room again
        elif self.n_query:
            largest = int(self.counts.numpy()[: self.n_query].max())
            if largest * self.GROWTH > self.width:
                self.width = int(largest * self.GROWTH) + 1
            self._room(self.n_pairs)
        return overflowed

    def to_lists(self) -> list[np.ndarray]:
        """Host copy, one sorted index array per query point (for tests and probes)."""
        off = self.offsets.numpy()[: self.n_query + 1]
        idx = self.indices.numpy()
        return [np.sort(idx[off[a] : off[a + 1]]) for a in range(self.n_query)]
