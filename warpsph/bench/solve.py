"""CPU threading of the pressure solve, A/B in one process: ``python -m warpsph.bench.solve``.

The saturated step of ``warpsph.bench``'s block with the solve on the device-resident
one-thread-per-row kernels (``projection.linear.blocked = False``: the GPU path) or on the blocked,
row-threaded kernels (the CPU default), on 1 and 2 CPU threads. Every trial runs ``--steps`` steps
from the same state; the configurations cycle ``--cycles`` times (after one warm-up cycle), so that
a change of load on a shared machine hits all of them. ``--solve-only`` times one assembled solve
instead of whole steps (docs/performance.md, "Pressure solve on CPU threads").
"""

from __future__ import annotations

import argparse
import collections
import statistics
import time


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=16384, help="particles of the saturated block")
    parser.add_argument("--cycles", type=int, default=6)
    parser.add_argument("--steps", type=int, default=5, help="steps per trial")
    parser.add_argument("--solver", choices=("cg", "jacobi"), default="cg")
    parser.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--solve-only", action="store_true", help="time one assembled solve per trial")
    args = parser.parse_args(argv)

    import warp as wp

    wp.config.quiet = True
    import warpsph.stages.pressure as pressure
    from warpsph import launching
    from warpsph.bench.throughput import block_scene
    from warpsph.builder import build
    from warpsph.solver import Solver

    scene = block_scene(args.size, scheme="two_set", effects="saturated")
    scene.pressure.solver = args.solver
    model, a = build(scene, "cpu", "float64")
    b = model.state()
    solver, dt = Solver(model), scene.time_step
    for k in range(3):
        solver.step(a, b, k * dt, dt)
        a, b = b, a
    snapshot = model.state()
    snapshot.assign(a)
    projection = solver.projection
    spent = [0.0]
    project = pressure.PressureProjection.project

    def timed_project(self, *a_, **kw):
        start = time.perf_counter()
        project(self, *a_, **kw)
        spent[0] += time.perf_counter() - start

    pressure.PressureProjection.project = timed_project
    threads_before = launching.cpu_threads()
    try:
        x0, x = wp.clone(projection.p_old), wp.clone(projection.p_old)  # the last step's system and start
        configs = [(blocked, t) for t in args.threads for blocked in (False, True)]
        results = collections.defaultdict(list)
        for cycle in range(args.cycles + 1):
            for blocked, threads in configs:
                launching.set_cpu_threads(threads)
                projection.linear.blocked = blocked
                projection.iterations.clear()
                if args.solve_only:
                    wp.copy(x, x0)
                    start = time.perf_counter()
                    its, _ = projection.linear.solve(projection._matrix(), projection.rhs, x)
                    row = ((time.perf_counter() - start) * 1e3, float("nan"), its)
                else:
                    a.assign(snapshot)
                    spent[0] = 0.0
                    start = time.perf_counter()
                    for k in range(args.steps):
                        solver.step(a, b, (3 + k) * dt, dt)
                        a, b = b, a
                    its = projection.iterations
                    row = ((time.perf_counter() - start) / args.steps * 1e3, spent[0] / args.steps * 1e3,
                           sum(its) / len(its))  # fmt: skip
                if cycle > 0:
                    results[(blocked, threads)].append(row)
    finally:
        pressure.PressureProjection.project = project
        launching.set_cpu_threads(threads_before)
    what = "one solve" if args.solve_only else f"step ({args.steps} steps a trial)"
    print(f"saturated block, {model.particle_count} particles, {args.solver}, {args.cycles} cycles; "
          f"ms per {what} and of the projection: min / median")  # fmt: skip
    for (blocked, threads), rows in results.items():
        step, proj = [r[0] for r in rows], [r[1] for r in rows]
        name = "blocked, row-threaded" if blocked else "device-resident rows"
        print(f"  {name:22s} threads {threads}: {min(step):8.2f} / {statistics.median(step):8.2f}   "
              f"projection {min(proj):7.2f} / {statistics.median(proj):7.2f}   iterations {rows[0][2]:.1f}")


if __name__ == "__main__":
    main()
