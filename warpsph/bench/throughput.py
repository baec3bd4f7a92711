"""Throughput benchmark of the full step: ``python -m warpsph.bench``.

For each size of a ladder of particle counts and each effect set (dry elastic, saturated,
viscoplastic) it builds a block (fixed base, slip sides, free top, gravity), compiles the kernels
by one warm-up step, times ``--steps`` steps, then runs a separate short profiled pass for the
share of each solver stage. It prints a table and writes a JSON record (machine + one entry per
size, effect set, scheme and CPU thread count). docs/performance.md explains the numbers.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import resource
import sys
import time
from pathlib import Path

import warp as wp

from warpsph.bench import peer
from warpsph.bench.record import cpu_model, machine_record, markdown_table, timing_fields, write_record
from warpsph.builder import build
from warpsph.launching import cpu_threads, set_cpu_threads
from warpsph.model import Model, State
from warpsph.scene import Body, Boundary, Effects, Material, Scene, Simulation
from warpsph.solver import Solver
from warpsph.sph.neighbours import NeighbourList

DEFAULT_SIZES = {2: (1024, 4096, 16384), 3: (512, 4096, 13824)}
"""Default particle-count ladders per dimension (128 × 128 = 16 384 is the 2D reference size)."""
LADDER_SIZES = {2: (4096, 16384, 65536), 3: (4096, 16384, 32768)}
"""``--ladder`` sizes per dimension (with every effect set)."""
QUICK_SIZES, QUICK_STEPS = (64, 256), 3
"""``--quick``: a smoke test of every code path in a few seconds."""
STEP_BUDGET = {2: 2.0e6, 3: 0.5e6}
"""Default timed steps per size: STEP_BUDGET[dim] particle-steps / particles, clamped to [10, 200]
(fewer at large sizes; a 3D pair loop is ≈ 4× a 2D one)."""
DX = 0.05
"""Particle spacing of every block [m] (so Δt is the same at every size)."""
PROFILE_STEPS = 5
"""Steps of the separate profiled pass (after one untimed profiled step)."""
SOIL = Material(name="soil", density=1700.0, youngs_modulus=30.0e6, poisson_ratio=0.2)
WATER = dict(porosity=0.3, grain_density=2000.0, water_density=1000.0, water_bulk_modulus=100.0e6)
"""Pore-water constants of a saturated block (with SOIL's E = 30 MPa, ν = 0.2, ρ = 1700 kg/m³, the mixture)."""
COHESION = 20.0e3
"""Undrained strength c_u [Pa] of the viscoplastic block (von Mises, σ_Y = √3 c_u): the lower part of
a 6.35 m block under gravity yields, so the plastic source does real work."""
EFFECT_SETS = {
    "dry": (Effects(), SOIL),
    "saturated": (Effects(pore_water=True), dataclasses.replace(SOIL, **WATER, hydraulic_conductivity=1.0e-3)),
    "viscoplastic": (Effects(plasticity=True),
                     dataclasses.replace(SOIL, model="viscoplastic", yield_function="von_mises", cohesion=COHESION,
                                         fluidity=10.0, reference_stress=math.sqrt(3.0) * COHESION)),
}  # fmt: skip
"""Effect set name -> (effects, material): dry elastic, saturated (pore_water, CG projection,
k_h = 1e-3 m/s) and viscoplastic (plasticity, von Mises, Perzyna γ = 10 1/s). Only the two-set
scheme has the effects; the collocated baseline runs dry only."""


# -- scene ----------------------------------------------------------------------------------------
def block_shape(n: int, dim: int) -> tuple[int, ...]:
    """Lattice points per axis of a near-square (2D) or near-cube (3D) block of about ``n`` points."""
    side = max(2, round(n ** (1.0 / dim)))
    height = max(2, round(n / side ** (dim - 1)))
    return (side, height) if dim == 2 else (side, height, side)


def block_scene(n: int, dim: int = 2, scheme: str = "two_set", integrator: str = "rk4",
                precision: str = "float64", effects: str = "dry") -> Scene:  # fmt: skip
    """Block of about ``n`` particles at spacing DX [m] of the EFFECT_SETS material ``effects``:
    fixed base y = 0, slip (impermeable) sides, free (drained) top, gravity."""
    fx, soil = EFFECT_SETS[effects]
    shape = block_shape(n, dim)
    size = [(k - 1) * DX for k in shape] + [0.0] * (3 - dim)
    sides = [Boundary("base", "fixed", "y", 0.0, "min")]
    for axis, length in zip(("x", "z")[: dim - 1], (size[0], size[2])):
        sides += [Boundary(f"{axis}_min", "slip", axis, 0.0, "min"),
                  Boundary(f"{axis}_max", "slip", axis, length, "max")]  # fmt: skip
    sim = Simulation(dim=dim, dx=DX, smoothing_ratio=1.3, scheme=scheme, integrator=integrator,
                     gravity=(0.0, -9.81, 0.0), precision=precision)  # fmt: skip
    body = Body(name="block", material=soil.name, min=(0.0, 0.0, 0.0), max=tuple(size))
    return Scene(name=f"bench_block_{dim}d_{n}_{effects}", simulation=sim, effects=fx,
                 materials={soil.name: soil}, bodies=[body], boundaries=sides).validate()  # fmt: skip


# -- object walking: arrays and neighbour lists -------------------------------------------------------
def reachable(*roots) -> list:
    """Every object reachable from ``roots`` through the attributes of warpsph objects and through
    lists, tuples and dict values, each once (cycles are fine)."""
    seen, stack, found = set(), list(roots), []
    while stack:
        obj = stack.pop()
        if id(obj) in seen:
            continue
        seen.add(id(obj))
        found.append(obj)
        if isinstance(obj, (list, tuple)):
            stack.extend(obj)
        elif isinstance(obj, dict):
            stack.extend(obj.values())
        elif type(obj).__module__.startswith("warpsph") and hasattr(obj, "__dict__"):
            stack.extend(vars(obj).values())
    return found


def device_arrays(*roots) -> dict[int, wp.array]:
    """The allocated wp.arrays reachable from ``roots``, keyed by their memory address."""
    return {a.ptr: a for a in reachable(*roots) if isinstance(a, wp.array) and a.ptr}


def memory_bytes(model: Model, states: list[State], solver: Solver) -> dict[str, int]:
    """Bytes of the wp.arrays of the model, of the states and the solver's own scratch (each counted once)."""
    model_arrays = device_arrays(model)
    state_arrays = {k: a for k, a in device_arrays(*states).items() if k not in model_arrays}
    counted = model_arrays.keys() | state_arrays.keys()
    solver_arrays = {k: a for k, a in device_arrays(solver).items() if k not in counted}
    return {name: sum(a.capacity for a in arrays.values())
            for name, arrays in (("model", model_arrays), ("states", state_arrays), ("solver", solver_arrays))}


def neighbour_pairs(solver: Solver) -> int:
    """Pairs in all of the solver's neighbour lists as last built (one step's worth)."""
    return sum(nl.n_pairs for nl in reachable(solver) if isinstance(nl, NeighbourList))


# -- measurement ------------------------------------------------------------------------------------
def advance(solver: Solver, states: list[State], steps: int, dt: float) -> list[State]:
    """Take ``steps`` steps of ``dt`` [s] from ``states[0]`` (swapping), synchronised; return the pair."""
    a, b = states
    for k in range(steps):
        solver.step(a, b, k * dt, dt)
        a, b = b, a
    wp.synchronize_device(solver.model.device)
    return [a, b]


def timed(fn, *args):
    """(result, wall seconds) of ``fn(*args)``."""
    start = time.perf_counter()
    result = fn(*args)
    return result, time.perf_counter() - start


def stage_profile(model: Model, states: list[State], dt: float, steps: int) -> dict[str, float]:
    """Seconds per step of each stage, from a separate profiled solver (one untimed step first)."""
    solver = Solver(model, profile=True)
    states = advance(solver, states, 1, dt)
    solver.stage_seconds.clear()
    advance(solver, states, steps, dt)
    return {name: sec / steps for name, sec in solver.stage_seconds.items()}


def default_steps(n: int, dim: int) -> int:
    """Timed steps for about ``n`` particles: STEP_BUDGET[dim] / n in [10, 200]."""
    return int(min(200, max(10, round(STEP_BUDGET[dim] / n))))


def bench_size(n: int, scheme: str, effects: str, threads: int, args) -> dict:
    """Build, warm up, time and profile one block of about ``n`` particles with ``threads`` CPU
    threads; the result record."""
    set_cpu_threads(threads)
    steps = args.steps or default_steps(n, args.dim)
    scene = block_scene(n, args.dim, scheme, args.integrator, args.precision, effects)
    (model, state), build_s = timed(build, scene, args.device, args.precision)
    states = [state, model.state()]
    dt = scene.time_step
    solver = Solver(model)
    _, compile_s = timed(advance, solver, states, 1, dt)
    states[1].assign(state)
    wp.synchronize_device(model.device)
    if solver.projection is not None:
        solver.projection.reset_statistics()
    states, wall = timed(advance, solver, states, steps, dt)
    iterations = solver.projection.iterations if solver.projection is not None else None
    pairs = neighbour_pairs(solver)
    stage = stage_profile(model, states, dt, min(steps, PROFILE_STEPS))
    memory = memory_bytes(model, states, solver)
    total_stage = sum(stage.values())
    particles = model.particle_count
    return {
        "requested": n,
        "scheme": model.spec.scheme,
        "effects": effects,
        "threads": threads if wp.get_device(args.device).is_cpu else None,
        "dim": model.spec.dim,
        "precision": model.spec.precision,
        "integrator": model.spec.integrator,
        "block_shape": list(block_shape(n, args.dim)),
        "particles": particles,
        "virtual_points": model.virtual_count,
        "ghost_particles": model.particle_ghost_count,
        "virtual_ghosts": model.virtual_ghost_count,
        **timing_fields(particles, steps, dt, build_s, compile_s, wall),
        "neighbour_pairs_per_step": pairs,
        "neighbour_interactions_per_second": pairs * steps / wall,
        "solve_iterations_per_step": sum(iterations) / len(iterations) if iterations else None,
        "stage_seconds_per_step": stage,
        "stage_share": {name: sec / total_stage for name, sec in stage.items()},
        "memory_bytes": memory,
        "memory_bytes_per_particle": sum(memory.values()) / particles,
        "max_rss_bytes": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024,
    }


# -- reporting --------------------------------------------------------------------------------------
COLUMNS = (
    ("scheme", "{scheme}"),
    ("effects", "{effects}"),
    ("threads", "{threads}"),
    ("particles", "{particles:d}"),
    ("virtual", "{virtual_points:d}"),
    ("steps", "{steps:d}"),
    ("wall s", "{wall_seconds:.3f}"),
    ("compile s", "{compile_seconds:.2f}"),
    ("ms/step", "{ms_per_step:.2f}"),
    ("particle-steps/s", "{particle_steps_per_second:.3g}"),
    ("pairs/step", "{neighbour_pairs_per_step:d}"),
    ("interactions/s", "{neighbour_interactions_per_second:.3g}"),
    ("solve it/step", "{solve_iterations}"),
    ("bytes/particle", "{memory_bytes_per_particle:.0f}"),
)


def throughput_table(results: list[dict]) -> str:
    """The main table: one row per size and scheme."""
    def cells(r: dict) -> list[str]:
        its = r["solve_iterations_per_step"]
        extra = {"ms_per_step": 1e3 * r["seconds_per_step"], "solve_iterations": "-" if its is None else f"{its:.1f}"}
        return [fmt.format(**extra, **r) for _, fmt in COLUMNS]

    rows = [cells(r) for r in results]
    return markdown_table([name for name, _ in COLUMNS], rows)


def stage_table(results: list[dict]) -> str:
    """Per-stage share of the step time [%] of results of one scheme, one row per size."""
    names = list(dict.fromkeys(s for r in results for s in r["stage_share"]))
    rows = [[r["scheme"], r["effects"], str(r["threads"]), str(r["particles"]),
             *(f"{100 * r['stage_share'].get(s, 0.0):.1f}" for s in names)] for r in results]  # fmt: skip
    return markdown_table(["scheme", "effects", "threads", "particles", *(f"{s} %" for s in names)], rows)


# -- command line -----------------------------------------------------------------------------------
def parse_args(argv: list[str] | None) -> argparse.Namespace:
    p = argparse.ArgumentParser(prog="python -m warpsph.bench", description=__doc__.splitlines()[0],
                                formatter_class=argparse.ArgumentDefaultsHelpFormatter)  # fmt: skip
    p.add_argument("--sizes", type=int, nargs="+", default=None,
                   help="particle counts (default: 1024 4096 16384 in 2D, 512 4096 13824 in 3D)")
    p.add_argument("--dim", type=int, choices=(2, 3), nargs="+", default=[2],
                   help="dimension of the block (several only with --peer)")
    p.add_argument("--device", default="cpu", help="Warp device: cpu or cuda:0")
    p.add_argument("--scheme", choices=("two_set", "collocated", "both"), default="two_set")
    p.add_argument("--precision", choices=("float32", "float64"), default="float64")
    p.add_argument("--integrator", choices=("rk2", "rk4"), default="rk4")
    p.add_argument("--effects", nargs="+", choices=tuple(EFFECT_SETS), default=["dry"],
                   help="effect sets (saturated and viscoplastic: two_set only)")
    p.add_argument("--threads", type=int, nargs="+", default=[cpu_threads()],
                   help="CPU threads of the row launches; several values compare them in one run")
    p.add_argument("--steps", type=int, default=None,
                   help="timed steps per size (default: 2e6 (2D) or 5e5 (3D) / particles, in [10, 200])")
    p.add_argument("--ladder", action="store_true",
                   help="every effect set at the ladder sizes (2D: 4096 16384 65536; 3D: 4096 16384 32768)")
    p.add_argument("--quick", action="store_true", help=f"sizes {QUICK_SIZES}, {QUICK_STEPS} steps (a smoke test)")
    p.add_argument("--json", type=Path, default=Path("bench_results.json"), help="where to write the results")
    p.add_argument("--peer", choices=("pysph",), default=None,
                   help="side by side with PySPH's elastic scheme, interleaved (warpsph/peer.py); "
                        "--dim 2 3 picks the blocks, --threads the thread counts")
    p.add_argument("--rounds", type=int, default=2, help="--peer: interleaved rounds (the table gives medians)")
    p.add_argument("--peer-python", default=None,
                   help="--peer: a Python that imports pysph (default: installed on demand, peer.PEER_ENV)")
    args = p.parse_args(argv)
    if args.peer is None:
        if len(args.dim) > 1:
            p.error("--dim takes one dimension unless --peer is given")
        args.dim = args.dim[0]
    if args.ladder:
        args.sizes = args.sizes or list(LADDER_SIZES[args.dim])
        args.effects = list(EFFECT_SETS)
    if args.quick:
        args.sizes, args.steps = list(QUICK_SIZES), QUICK_STEPS
    if (args.steps is not None and args.steps < 1) or any(n < 4 for n in args.sizes or [4]):
        p.error("--steps must be >= 1 and every size >= 4")
    if any(t < 1 for t in args.threads):
        p.error("--threads must be >= 1")
    if args.rounds < 1:
        p.error("--rounds must be >= 1")
    if args.peer is None:
        args.sizes = args.sizes or list(DEFAULT_SIZES[args.dim])
    return args


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    if args.peer:
        return peer_main(args)
    wp.config.log_level = wp.LOG_WARNING
    if args.device.startswith("cuda") and not wp.is_cuda_available():
        print(f"warpsph.bench: error: --device {args.device}: no CUDA device is available", file=sys.stderr)
        return 2
    machine = machine_record(args.device)
    steps = args.steps or f"{STEP_BUDGET[args.dim]:g}/N in [10, 200]"
    print(f"{machine['device_name']} ({machine['cpu']}, {machine['cpu_count']} CPUs), warp {machine['warp_version']}, "
          f"{args.dim}D, {args.precision}, {args.integrator}, {steps} steps per size")  # fmt: skip
    schemes = ("two_set", "collocated") if args.scheme == "both" else (args.scheme,)
    cases = [(s, e) for e in args.effects for s in schemes if s == "two_set" or e == "dry"]
    results = []
    threads_before = cpu_threads()
    try:
        for scheme, effects in cases:
            for n in args.sizes:
                for threads in args.threads:
                    r = bench_size(n, scheme, effects, threads, args)
                    results.append(r)
                    print(f"  {scheme} {effects} {r['particles']} particles, {threads} thread(s): "
                          f"{r['wall_seconds']:.2f} s", flush=True)  # fmt: skip
    finally:
        set_cpu_threads(threads_before)
    print("\n" + throughput_table(results))
    for scheme, effects in cases:
        rows = [r for r in results if (r["scheme"], r["effects"]) == (scheme, effects)]
        print(f"\nstage share of the step time ({scheme}, {effects}):\n" + stage_table(rows))
    write_record(args.json, {"machine": machine, "settings": vars(args), "results": results})
    return 0


def peer_main(args) -> int:
    """``--peer pysph``: warpsph and PySPH interleaved on the same blocks (warpsph/peer.py)."""
    cases = [(dim, n, t) for dim in args.dim for n in (args.sizes or [peer.PEER_SIZES[dim]])
             for t in args.threads]  # fmt: skip
    print(f"{cpu_model()} ({os.cpu_count()} CPUs): warpsph (dry two-set step, float64) against PySPH "
          f"{peer.PEER_VERSION} (elastic solids, EPEC), {args.rounds} interleaved rounds")  # fmt: skip
    record = peer.compare(cases, args.rounds, args.peer_python, args.steps)
    print("\n" + peer.summary_table(record))
    write_record(args.json, {"machine": machine_record("cpu"), "settings": vars(args), **record})
    return 0


if __name__ == "__main__":
    sys.exit(main())
