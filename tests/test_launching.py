"""Row launches split over CPU threads compute every row exactly as one launch does."""

import numpy as np
import pytest
import warp as wp

from warpsph import launching
from warpsph.bench.throughput import block_scene
from warpsph.builder import build
from warpsph.solver import Solver
from warpsph.stages import linear_solve


@wp.kernel(enable_backward=False)
def _row_index(first: int, out: wp.array(dtype=wp.int32)):
    out[first + wp.tid()] = first + wp.tid()


@pytest.fixture
def threads():
    """Restores the thread count a test changes."""
    before = launching.cpu_threads()
    yield launching.set_cpu_threads
    launching.set_cpu_threads(before)


def test_chunks_cover_every_row_once(threads, monkeypatch):
    monkeypatch.setattr(launching, "MIN_ROWS_PER_THREAD", 1)
    threads(3)
    out = wp.full(10, -1, dtype=wp.int32, device="cpu")
    launching.launch_rows(_row_index, 10, [out], "cpu")
    assert np.array_equal(out.numpy(), np.arange(10))
    with pytest.raises(ValueError):
        threads(0)


@pytest.mark.parametrize("scheme, effects", [("two_set", "dry"), ("collocated", "dry"), ("two_set", "saturated"),
                                             ("two_set", "viscoplastic")])  # fmt: skip
def test_threaded_steps_are_bit_identical(threads, scheme, effects):
    """Five steps of a 48 × 48 block (2 304 particles, two chunks) with one and with two threads."""
    results = []
    for n in (1, 2):
        threads(n)
        scene = block_scene(2304, scheme=scheme, effects=effects)
        model, a = build(scene, "cpu", "float64")
        b = model.state()
        solver = Solver(model)
        for k in range(5):
            solver.step(a, b, k * scene.time_step, scene.time_step)
            a, b = b, a
        results.append({name: arr.numpy() for name, arr in a.arrays().items()})
    for name, value in results[0].items():
        assert np.array_equal(value, results[1][name]), name


@pytest.mark.parametrize("method", ["cg", "jacobi"])
def test_blocked_pressure_solves_match_the_row_kernels(threads, method, monkeypatch):
    """The CPU's blocked, row-threaded CG and Jacobi (partial sums per 256-row block) give the same
    bits on one and two threads, and take the same iterations as the one-thread-per-row kernels
    and block sums (the GPU path, checking every iteration on the CPU) to the same pressures up to rounding, over five
    saturated steps of a 2 304-particle block (nine blocks, two chunks)."""
    monkeypatch.setattr(linear_solve, "SOLVE_ROWS_PER_THREAD", 1024)  # split the solve of this small block too
    results = []
    for blocked, n in ((True, 1), (True, 2), (False, 1)):
        threads(n)
        scene = block_scene(2304, scheme="two_set", effects="saturated")
        scene.pressure.solver = method
        model, a = build(scene, "cpu", "float64")
        b = model.state()
        solver = Solver(model)
        solver.projection.linear.blocked = blocked
        for k in range(5):
            solver.step(a, b, k * scene.time_step, scene.time_step)
            a, b = b, a
        results.append((list(solver.projection.iterations), {name: arr.numpy() for name, arr in a.arrays().items()}))
    (its_1, one), (its_2, two), (its_rows, rows) = results
    assert its_1 == its_2 == its_rows and min(its_rows) > 2
    for name, value in one.items():
        assert np.array_equal(value, two[name]), name
    p_blocked, p_rows = one["particle_pore_pressure"], rows["particle_pore_pressure"]
    assert np.allclose(p_blocked, p_rows, rtol=1e-9, atol=1e-9 * np.abs(p_rows).max())


def test_bench_solve_runs(capsys):
    """python -m warpsph.bench.solve: a smoke run of both solve paths on 1 and 2 threads."""
    from warpsph.bench.solve import main

    main(["--size", "256", "--cycles", "1", "--steps", "1", "--solve-only"])
    out = capsys.readouterr().out
    assert out.count("threads 1") == 2 and out.count("threads 2") == 2 and "iterations" in out
