"""Jacobi-preconditioned CG and weighted Jacobi for the pressure system A x = b (float64): blocked kernels on
the CPU, bit-identical for any thread count, and device-resident ones on a GPU (docs/performance.md,
*Pressure solve on CPU threads*).
"""

import math

import warp as wp

from warpsph.launching import launch, launch_rows

f64 = wp.float64

SOLVE_BLOCK = 256
"""Rows per item of the blocked CG and Jacobi kernels on the CPU: the unit of their partial sums,
fixed whatever the thread count (so the sums, and the solves, are bit-identical for any count)."""
SOLVE_ROWS_PER_THREAD = 4096
"""Fewest matrix rows worth another CPU thread in the solve's passes: a 16 384-row matrix pass took
465 µs on one thread, 236 µs for half of it and 308 µs for both halves on two threads, so a thread
hand-off costs ≈ 75 µs ≈ 2 600 rows of work (docs/performance.md)."""
TILE = 256
"""GPU threads per block of the device-resident kernels: the unit of their block sums."""
CHECK_EVERY = 8
"""Iterations between the device-resident solve's convergence checks while it is still short of
the previous solve's iteration count (then it checks every iteration)."""

# the device-resident scalar table: one row of COLUMNS per iteration, flattened
COLUMNS = wp.constant(4)
RZ, RR, BB, DAD = (wp.constant(k) for k in range(4))


@wp.struct
class SparseRows:
    """A x = diag x − Σ_k weight[k] x[col(k)] over row a's entries offsets[a] … offsets[a+1], where
    col(k) = column[k] below ``n`` and ghost_source[column[k] − n] above it: the columns are a
    neighbour list's own indices, whose ghosts stand for their sources (:func:`sparse_rows`)."""

    offsets: wp.array(dtype=wp.int32)
    weight: wp.array(dtype=f64)
    column: wp.array(dtype=wp.int32)
    ghost_source: wp.array(dtype=wp.int32)
    diag: wp.array(dtype=f64)
    n: int


def sparse_rows(offsets, weight, column, ghost_source, diag, n: int) -> SparseRows:
    """The :class:`SparseRows` of these arrays; ``n`` the owned points (the rows)."""
    rows = SparseRows()
    rows.offsets, rows.weight, rows.column, rows.ghost_source, rows.diag, rows.n = (offsets, weight, column,
                                                                                  ghost_source, diag, n)  # fmt: skip
    return rows


@wp.func
def apply_row(a: int, A: SparseRows, x: wp.array(dtype=f64)):
    """(A x)_a."""
    y = A.diag[a] * x[a]
    for k in range(A.offsets[a], A.offsets[a + 1]):
        col = A.column[k]
        if col >= A.n:
            col = A.ghost_source[col - A.n]
        y -= A.weight[k] * x[col]
    return y


@wp.func
def ratio(num: f64, den: f64):
    """num/den, or 0 where den is 0 (a converged or broken-down CG stands still)."""
    if den == f64(0.0):
        return f64(0.0)
    return num / den


@wp.func
def add_block_sum(table: wp.array(dtype=f64), row: int, col: int, value: f64):
    """table[row, col] += the sum of ``value`` over the thread block (one atomic per block)."""
    wp.tile_atomic_add(table, wp.tile_sum(wp.tile(value)), offset=(row * COLUMNS + col,))


# -- blocked kernels (CPU) ----------------------------------------------------------------------


@wp.kernel(enable_backward=False)
def residual_blocks(
    first: int, block: int, n: int, A: SparseRows,
    x: wp.array(dtype=f64), rhs: wp.array(dtype=f64), r: wp.array(dtype=f64), z: wp.array(dtype=f64),
    partial: wp.array(dtype=f64),
):  # fmt: skip
    """r = b − A x, z = r/diag; partial = (r·z, r·r, b·b) of the block."""
    i = first + wp.tid()
    rz = f64(0.0)
    rr = f64(0.0)
    bb = f64(0.0)
    for a in range(i * block, wp.min(n, (i + 1) * block)):
        ra = rhs[a] - apply_row(a, A, x)
        za = ra / A.diag[a]
        r[a] = ra
        z[a] = za
        rz += ra * za
        rr += ra * ra
        bb += rhs[a] * rhs[a]
    partial[3 * i] = rz
    partial[3 * i + 1] = rr
    partial[3 * i + 2] = bb


@wp.kernel(enable_backward=False)
def direction_rows(first: int, beta: f64, z: wp.array(dtype=f64), d: wp.array(dtype=f64)):
    """d = z + β d."""
    a = first + wp.tid()
    d[a] = z[a] + beta * d[a]


@wp.kernel(enable_backward=False)
def matvec_blocks(
    first: int, block: int, n: int, A: SparseRows,
    d: wp.array(dtype=f64), Ad: wp.array(dtype=f64), partial: wp.array(dtype=f64),
):  # fmt: skip
    """Ad = A d; partial[0] = d·Ad of the block."""
    i = first + wp.tid()
    dad = f64(0.0)
    for a in range(i * block, wp.min(n, (i + 1) * block)):
        y = apply_row(a, A, d)
        Ad[a] = y
        dad += d[a] * y
    partial[3 * i] = dad


@wp.kernel(enable_backward=False)
def update_blocks(
    first: int, block: int, n: int, alpha: f64, d: wp.array(dtype=f64), Ad: wp.array(dtype=f64),
    diag: wp.array(dtype=f64), x: wp.array(dtype=f64), r: wp.array(dtype=f64), z: wp.array(dtype=f64),
    partial: wp.array(dtype=f64),
):  # fmt: skip
    """x += α d, r −= α Ad, z = r/diag; partial = (r·z, r·r) of the block."""
    i = first + wp.tid()
    rz = f64(0.0)
    rr = f64(0.0)
    for a in range(i * block, wp.min(n, (i + 1) * block)):
        x[a] = x[a] + alpha * d[a]
        ra = r[a] - alpha * Ad[a]
        za = ra / diag[a]
        r[a] = ra
        z[a] = za
        rz += ra * za
        rr += ra * ra
    partial[3 * i] = rz
    partial[3 * i + 1] = rr


@wp.kernel(enable_backward=False)
def jacobi_blocks(
    first: int, block: int, n: int, omega: f64, A: SparseRows,
    x: wp.array(dtype=f64), rhs: wp.array(dtype=f64), x_new: wp.array(dtype=f64), partial: wp.array(dtype=f64),
):  # fmt: skip
    """x_new = x + ω (b − A x)/diag; partial = (r·r, b·b) of x in the block."""
    i = first + wp.tid()
    rr = f64(0.0)
    bb = f64(0.0)
    for a in range(i * block, wp.min(n, (i + 1) * block)):
        ra = rhs[a] - apply_row(a, A, x)
        x_new[a] = x[a] + omega * ra / A.diag[a]
        rr += ra * ra
        bb += rhs[a] * rhs[a]
    partial[3 * i] = rr
    partial[3 * i + 1] = bb


# -- device-resident kernels (GPU): one thread per row, padded to whole blocks -----------------


@wp.kernel(enable_backward=False)
def residual_rows(
    n: int, A: SparseRows, x: wp.array(dtype=f64), rhs: wp.array(dtype=f64), r: wp.array(dtype=f64),
    z: wp.array(dtype=f64), d: wp.array(dtype=f64), table: wp.array(dtype=f64),
):  # fmt: skip
    """r = b − A x, z = d = r/diag; table[0] += (r·z, r·r, b·b)."""
    a = wp.tid()
    ra = f64(0.0)
    za = f64(0.0)
    ba = f64(0.0)
    if a < n:
        ba = rhs[a]
        ra = ba - apply_row(a, A, x)
        za = ra / A.diag[a]
        r[a] = ra
        z[a] = za
        d[a] = za
    add_block_sum(table, 0, RZ, ra * za)
    add_block_sum(table, 0, RR, ra * ra)
    add_block_sum(table, 0, BB, ba * ba)


@wp.kernel(enable_backward=False)
def matvec_rows(
    n: int, it: int, A: SparseRows, d: wp.array(dtype=f64), Ad: wp.array(dtype=f64), table: wp.array(dtype=f64),
):  # fmt: skip
    """Ad = A d; table[it, DAD] += d·Ad."""
    a = wp.tid()
    dad = f64(0.0)
    if a < n:
        y = apply_row(a, A, d)
        Ad[a] = y
        dad = d[a] * y
    add_block_sum(table, it, DAD, dad)


@wp.kernel(enable_backward=False)
def update_rows(
    n: int, it: int, d: wp.array(dtype=f64), Ad: wp.array(dtype=f64), diag: wp.array(dtype=f64),
    x: wp.array(dtype=f64), r: wp.array(dtype=f64), z: wp.array(dtype=f64), table: wp.array(dtype=f64),
):  # fmt: skip
    """α = (r·z)_(it−1) / (d·Ad)_it; x += α d, r −= α Ad, z = r/diag; table[it] += (r·z, r·r)."""
    a = wp.tid()
    dad = table[it * COLUMNS + DAD]
    alpha = f64(0.0)  # d·Ad ≤ 0 (not positive definite, or d = 0): stand still, the host stops at its next check
    if dad > f64(0.0):
        alpha = table[(it - 1) * COLUMNS + RZ] / dad
    ra = f64(0.0)
    za = f64(0.0)
    if a < n:
        x[a] = x[a] + alpha * d[a]
        ra = r[a] - alpha * Ad[a]
        za = ra / diag[a]
        r[a] = ra
        z[a] = za
    add_block_sum(table, it, RZ, ra * za)
    add_block_sum(table, it, RR, ra * ra)


@wp.kernel(enable_backward=False)
def direction_from_table(it: int, z: wp.array(dtype=f64), d: wp.array(dtype=f64), table: wp.array(dtype=f64)):
    """d = z + β d, β = (r·z)_it / (r·z)_(it−1)."""
    a = wp.tid()
    d[a] = z[a] + ratio(table[it * COLUMNS + RZ], table[(it - 1) * COLUMNS + RZ]) * d[a]


@wp.kernel(enable_backward=False)
def jacobi_rows(
    n: int, it: int, omega: f64, A: SparseRows, x: wp.array(dtype=f64), rhs: wp.array(dtype=f64),
    x_new: wp.array(dtype=f64), table: wp.array(dtype=f64),
):  # fmt: skip
    """x_new = x + ω (b − A x)/diag; table[it] += (r·r, b·b) of x."""
    a = wp.tid()
    ra = f64(0.0)
    ba = f64(0.0)
    if a < n:
        ba = rhs[a]
        ra = ba - apply_row(a, A, x)
        x_new[a] = x[a] + omega * ra / A.diag[a]
    add_block_sum(table, it, RR, ra * ra)
    add_block_sum(table, it, BB, ba * ba)


class LinearSolver:
    """Solves A x = b for one matrix size ``n`` on ``device`` with the settings of a scene's
    ``[pressure]`` (solver "cg" or "jacobi", tolerance on ‖r‖/‖b‖, max_iterations, jacobi_weight)."""

    def __init__(self, n: int, device, settings):
        self.n, self.device, self.settings = n, device, settings
        self.work = [wp.zeros(n, dtype=f64, device=device) for _ in range(4)]
        self.blocked = wp.get_device(device).is_cpu
        """Blocked kernels (the CPU default) or device-resident ones (the GPU default; on the CPU they
        run one row per block and check every iteration, which tests use)."""
        self.blocks = (n + SOLVE_BLOCK - 1) // SOLVE_BLOCK
        self.partial = wp.zeros(3 * max(self.blocks, 1), dtype=f64, device=device)
        self.partial_host = self.partial.numpy().reshape(-1, 3) if self.blocked else None  # shares the memory
        self.table = wp.zeros((settings.max_iterations + 2) * COLUMNS, dtype=f64, device=device)
        self.check_every = 1 if wp.get_device(device).is_cpu else CHECK_EVERY
        self.last_iterations = 0

    def solve(self, matrix: SparseRows, rhs, x) -> tuple[int, float]:
        """Solve ``matrix`` (a :class:`SparseRows`) x = ``rhs`` from the start ``x`` (in
        place); return (iterations, relative residual ‖b − A x‖/‖b‖ of the last one checked)."""
        cg = self.settings.solver == "cg"
        if self.blocked:
            result = self._cg_blocked(matrix, rhs, x) if cg else self._jacobi_blocked(matrix, rhs, x)
        else:
            result = self._cg_resident(matrix, rhs, x) if cg else self._jacobi_resident(matrix, rhs, x)
        self.last_iterations = result[0]
        return result

    # -- blocked (CPU) --

    def _blocks(self, kernel, inputs: list, threaded: bool = True) -> None:
        """Launch a blocked kernel over the rows, SOLVE_BLOCK per item: on the CPU threads when
        ``threaded`` (the matrix passes), else on this thread (vector updates of a few tens of µs,
        which a second thread's hand-off would slow down)."""
        if threaded:
            launch_rows(kernel, self.blocks, [SOLVE_BLOCK, self.n, *inputs], self.device, rows_per_item=SOLVE_BLOCK,
                        min_rows_per_thread=SOLVE_ROWS_PER_THREAD)  # fmt: skip
        else:
            launch(kernel, self.blocks, [0, SOLVE_BLOCK, self.n, *inputs], self.device)

    def _sum(self, column: int) -> float:
        """Sum of the blocks' partial sums ``column``, in block order (the same for any thread count)."""
        return float(self.partial_host[: self.blocks, column].sum())

    def _cg_blocked(self, matrix, rhs, x):
        r, z, d, Ad = self.work
        s = self.settings
        self._blocks(residual_blocks, [matrix, x, rhs, r, z, self.partial])
        rz, rr, bb = self._sum(0), self._sum(1), self._sum(2)
        target = s.tolerance**2 * max(bb, 1e-300)
        if rr <= target:
            return 0, math.sqrt(rr / max(bb, 1e-300))
        d.zero_()
        beta = 0.0
        for it in range(1, s.max_iterations + 1):
            launch(direction_rows, self.n, [0, f64(beta), z, d], self.device)
            self._blocks(matvec_blocks, [matrix, d, Ad, self.partial])
            dAd = self._sum(0)
            if dAd <= 0.0:
                break
            self._blocks(update_blocks, [f64(rz / dAd), d, Ad, matrix.diag, x, r, z, self.partial], threaded=False)
            rz_new, rr = self._sum(0), self._sum(1)
            if rr <= target:
                return it, math.sqrt(rr / max(bb, 1e-300))
            beta, rz = rz_new / rz, rz_new
        return s.max_iterations, math.sqrt(rr / max(bb, 1e-300))

    def _jacobi_blocked(self, matrix, rhs, x):
        s = self.settings
        current, nxt = x, self.work[0]
        rel = math.inf
        for it in range(s.max_iterations + 1):
            self._blocks(jacobi_blocks, [f64(s.jacobi_weight), matrix, current, rhs, nxt, self.partial])
            rel = math.sqrt(self._sum(0) / max(self._sum(1), 1e-300))
            if rel <= s.tolerance:
                break  # ``current`` met the tolerance
            current, nxt = nxt, current
        if current is not x:
            wp.copy(x, current, count=self.n)
        return it, rel

    # -- device-resident (GPU) --

    def _rows(self, kernel, inputs: list) -> None:
        """One thread per row, padded to whole TILE-thread blocks (the padding rows add zeros)."""
        padded = (self.n + TILE - 1) // TILE * TILE
        wp.launch(kernel, dim=padded, inputs=inputs, device=self.device, block_dim=TILE)

    def _rows_read(self, first: int, end: int):
        """Rows [first, end) of the scalar table as an (end − first, COLUMNS) array (one host read:
        it waits for the kernels before it)."""
        return self.table[first * COLUMNS : end * COLUMNS].numpy().reshape(-1, COLUMNS)

    def _due(self, it: int) -> bool:
        """Whether iteration ``it`` reads the scalar table to test convergence."""
        near = self.last_iterations > 0 and it >= self.last_iterations - 1
        return near or it % self.check_every == 0 or it == self.settings.max_iterations

    def _cg_resident(self, matrix, rhs, x):
        r, z, d, Ad = self.work
        s, n, table = self.settings, self.n, self.table
        table.zero_()
        self._rows(residual_rows, [n, matrix, x, rhs, r, z, d, table])
        _, rr, bb = (float(v) for v in self._rows_read(0, 1)[0, :3])
        target = s.tolerance**2 * max(bb, 1e-300)
        if rr <= target:
            return 0, math.sqrt(rr / max(bb, 1e-300))
        checked = 0  # iterations whose scalars the host has read
        for it in range(1, s.max_iterations + 1):
            if it > 1:
                launch(direction_from_table, n, [it - 1, z, d, table], self.device)
            self._rows(matvec_rows, [n, it, matrix, d, Ad, table])
            self._rows(update_rows, [n, it, d, Ad, matrix.diag, x, r, z, table])
            if self._due(it):
                rows = self._rows_read(checked + 1, it + 1)  # one host read for the iterations since the last
                checked = it
                rr = float(rows[-1, RR])
                if rr <= target:
                    return it, math.sqrt(rr / max(bb, 1e-300))
                if not (rows[:, DAD] > 0.0).all():
                    break  # not positive definite (or converged to zero direction): as the blocked CG
        return s.max_iterations, math.sqrt(rr / max(bb, 1e-300))

    def _jacobi_resident(self, matrix, rhs, x):
        s, n, table = self.settings, self.n, self.table
        current, nxt = x, self.work[0]
        rel = math.inf
        table.zero_()
        for it in range(s.max_iterations + 1):
            self._rows(jacobi_rows, [n, it, f64(s.jacobi_weight), matrix, current, rhs, nxt, table])
            if it == 0 or self._due(it):
                rr, bb = (float(v) for v in self._rows_read(it, it + 1)[0, RR : BB + 1])
                rel = math.sqrt(rr / max(bb, 1e-300))
                if rel <= s.tolerance:
                    break  # ``current`` met the tolerance
            current, nxt = nxt, current
        if current is not x:
            wp.copy(x, current, count=n)
        return it, rel
