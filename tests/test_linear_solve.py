"""The pressure system's CG and Jacobi (warpsph/stages/linear_solve.py) against a dense solve, on both
implementations: blocked (the CPU's) and device-resident (the GPU's, here on the CPU as well, with the
GPU's delayed convergence checks)."""

from types import SimpleNamespace

import numpy as np
import pytest
import warp as wp

from warpsph.environment import default_device
from warpsph.stages.linear_solve import LinearSolver, sparse_rows

DEVICE = default_device()  # WARPSPH_DEVICE, else the CPU


def poisson_system(n: int, rng):
    """A symmetric positive definite system shaped like the projection's: a 1D Morris-like Laplacian
    with random positive couplings plus a storage term, 2 neighbours a side; (rows, A dense, b)."""
    offsets, weight, column = [0], [], []
    dense = np.zeros((n, n))
    for a in range(n):
        for j in (a - 2, a - 1, a + 1, a + 2):
            if 0 <= j < n:
                w = 1.0 + 0.5 * np.sin(a + j)  # symmetric in (a, j)
                weight.append(w)
                column.append(j)
                dense[a, j] = -w
        offsets.append(len(weight))
    diag = -dense.sum(axis=1) + 1e-2 * (1.0 + rng.random(n))
    dense[np.arange(n), np.arange(n)] = diag
    no_ghosts = wp.zeros(1, dtype=wp.int32, device=DEVICE)
    rows = sparse_rows(wp.array(offsets, dtype=wp.int32, device=DEVICE),
                       wp.array(weight, dtype=wp.float64, device=DEVICE),
                       wp.array(column, dtype=wp.int32, device=DEVICE), no_ghosts,
                       wp.array(diag, dtype=wp.float64, device=DEVICE), n)  # fmt: skip
    return rows, dense, rng.standard_normal(n)


@pytest.mark.parametrize("method", ["cg", "jacobi"])
@pytest.mark.parametrize("path", ["blocked", "resident", "resident, delayed checks"])
def test_solves_match_a_dense_solve(method, path):
    if path == "blocked" and not wp.get_device(DEVICE).is_cpu:
        pytest.skip("the blocked kernels are the CPU's")
    n = 700  # three blocked items, three GPU thread blocks, the last two partly padding
    rows, dense, b = poisson_system(n, np.random.default_rng(1))
    settings = SimpleNamespace(solver=method, tolerance=1e-10, max_iterations=20000, jacobi_weight=0.8)
    solver = LinearSolver(n, DEVICE, settings)
    solver.blocked = path == "blocked"
    if path.endswith("delayed checks"):
        solver.check_every = 8
    x = wp.zeros(n, dtype=wp.float64, device=DEVICE)
    iterations, rel = solver.solve(rows, wp.array(b, dtype=wp.float64, device=DEVICE), x)
    exact = np.linalg.solve(dense, b)
    got = x.numpy()
    residual = np.linalg.norm(b - dense @ got) / np.linalg.norm(b)
    assert rel <= 1e-10 and residual <= 1.01e-10 and iterations > 10
    assert np.linalg.norm(got - exact) <= 1e-10 * np.linalg.cond(dense) * np.linalg.norm(exact)
    if path.endswith("delayed checks") and method == "cg":
        # the first solve checks every 8th iteration; a second one from the same start also checks
        # every iteration from one before the first's count, so it stops no later than the first
        assert iterations % 8 == 0
        again = wp.zeros(n, dtype=wp.float64, device=DEVICE)
        second = solver.solve(rows, wp.array(b, dtype=wp.float64, device=DEVICE), again)[0]
        assert iterations - 8 < second <= iterations


def test_a_converged_start_takes_no_iteration():
    n = 300
    rows, dense, b = poisson_system(n, np.random.default_rng(2))
    settings = SimpleNamespace(solver="cg", tolerance=1e-8, max_iterations=100, jacobi_weight=0.8)
    for blocked in (True, False) if wp.get_device(DEVICE).is_cpu else (False,):
        solver = LinearSolver(n, DEVICE, settings)
        solver.blocked = blocked
        x = wp.array(np.linalg.solve(dense, b), dtype=wp.float64, device=DEVICE)
        assert solver.solve(rows, wp.array(b, dtype=wp.float64, device=DEVICE), x)[0] == 0


def test_ghost_columns_stand_for_their_sources():
    """A column at or past ``n`` (a neighbour list's ghost) multiplies its source's unknown: the same
    system written with some columns as ghosts gives the same solution's bits."""
    n = 300
    rows, dense, b = poisson_system(n, np.random.default_rng(3))
    column = rows.column.numpy()
    sources = np.unique(column[::3])  # every third entry through a ghost of its column
    ghost_of = {j: g for g, j in enumerate(sources)}
    through_ghosts = column.copy()
    through_ghosts[::3] = [n + ghost_of[j] for j in column[::3]]
    ghosts = sparse_rows(rows.offsets, rows.weight, wp.array(through_ghosts, dtype=wp.int32, device=DEVICE),
                         wp.array(sources, dtype=wp.int32, device=DEVICE), rows.diag, n)  # fmt: skip
    settings = SimpleNamespace(solver="cg", tolerance=1e-10, max_iterations=2000, jacobi_weight=0.8)
    rhs = wp.array(b, dtype=wp.float64, device=DEVICE)
    solutions = []
    for matrix in (rows, ghosts):
        x = wp.zeros(n, dtype=wp.float64, device=DEVICE)
        LinearSolver(n, DEVICE, settings).solve(matrix, rhs, x)
        solutions.append(x.numpy())
    assert np.array_equal(*solutions)
    assert np.linalg.norm(dense @ solutions[0] - b) <= 1e-9 * np.linalg.norm(b)
