"""Throughput benchmark of the full dry step: ``python -m warpsph.bench``.

For each size of a ladder of particle counts it builds an elastic block (fixed base, slip sides,
free top, gravity), compiles the kernels by one warm-up step, times ``--steps`` steps, then runs a
separate short profiled pass for the share of each solver stage. It prints a table and writes a
JSON record (machine + one entry per size and scheme). docs/performance.md explains the numbers.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from pathlib import Path

import warp as wp

import warpsph
from warpsph.builder import build
from warpsph.model import Model, State
from warpsph.scene import Body, Boundary, Material, Scene, Simulation
from warpsph.solver import Solver
from warpsph.sph.neighbours import NeighbourList

DEFAULT_SIZES = {2: (1024, 4096, 16384), 3: (512, 4096, 13824)}
"""Default particle-count ladders per dimension (128 × 128 = 16 384 is the 2D reference size)."""
DX = 0.05
"""Particle spacing of every block [m] (so Δt is the same at every size)."""
PROFILE_STEPS = 5
"""Steps of the separate profiled pass (after one untimed profiled step)."""
TARGET = {"particles": 16384, "dim": 2, "precision": "float64", "particle_steps_per_second": 3.6e5}
"""Project target: PySPH 1.0b2's two-thread elastic scheme on these machines."""
SOIL = Material(name="soil", density=1700.0, youngs_modulus=30.0e6, poisson_ratio=0.2)


# -- scene ----------------------------------------------------------------------------------------
def block_shape(n: int, dim: int) -> tuple[int, ...]:
    """Lattice points per axis of a near-square (2D) or near-cube (3D) block of about ``n`` points."""
    side = max(2, round(n ** (1.0 / dim)))
    height = max(2, round(n / side ** (dim - 1)))
    return (side, height) if dim == 2 else (side, height, side)


def block_scene(n: int, dim: int = 2, scheme: str = "two_set", integrator: str = "rk4",
                precision: str = "float64") -> Scene:  # fmt: skip
    """Elastic block of about ``n`` particles at spacing DX: fixed base y = 0, slip sides, free top."""
    shape = block_shape(n, dim)
    size = [(k - 1) * DX for k in shape] + [0.0] * (3 - dim)
    sides = [Boundary("base", "fixed", "y", 0.0, "min")]
    for axis, length in zip(("x", "z")[: dim - 1], (size[0], size[2])):
        sides += [Boundary(f"{axis}_min", "slip", axis, 0.0, "min"),
                  Boundary(f"{axis}_max", "slip", axis, length, "max")]  # fmt: skip
    sim = Simulation(dim=dim, dx=DX, smoothing_ratio=1.3, scheme=scheme, integrator=integrator,
                     gravity=(0.0, -9.81, 0.0), precision=precision)  # fmt: skip
    body = Body(name="block", material=SOIL.name, min=(0.0, 0.0, 0.0), max=tuple(size))
    return Scene(name=f"bench_block_{dim}d_{n}", simulation=sim, materials={SOIL.name: SOIL}, bodies=[body],
                 boundaries=sides).validate()  # fmt: skip


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


def bench_size(n: int, scheme: str, args) -> dict:
    """Build, warm up, time and profile one block of about ``n`` particles; the result record."""
    scene = block_scene(n, args.dim, scheme, args.integrator, args.precision)
    (model, state), build_s = timed(build, scene, args.device, args.precision)
    states = [state, model.state()]
    dt = scene.time_step
    solver = Solver(model)
    _, compile_s = timed(advance, solver, states, 1, dt)
    states[1].assign(state)
    wp.synchronize_device(model.device)
    states, wall = timed(advance, solver, states, args.steps, dt)
    pairs = neighbour_pairs(solver)
    stage = stage_profile(model, states, dt, min(args.steps, PROFILE_STEPS))
    memory = memory_bytes(model, states, solver)
    total_stage = sum(stage.values())
    particles = model.particle_count
    return {
        "requested": n,
        "scheme": model.spec.scheme,
        "dim": model.spec.dim,
        "precision": model.spec.precision,
        "integrator": model.spec.integrator,
        "block_shape": list(block_shape(n, args.dim)),
        "particles": particles,
        "virtual_points": model.virtual_count,
        "ghost_particles": model.particle_ghost_count,
        "virtual_ghosts": model.virtual_ghost_count,
        **timing_fields(particles, args.steps, dt, build_s, compile_s, wall),
        "neighbour_pairs_per_step": pairs,
        "neighbour_interactions_per_second": pairs * args.steps / wall,
        "stage_seconds_per_step": stage,
        "stage_share": {name: sec / total_stage for name, sec in stage.items()},
        "memory_bytes": memory,
        "memory_bytes_per_particle": sum(memory.values()) / particles,
    }


# -- reporting --------------------------------------------------------------------------------------
def cpu_model() -> str:
    """The CPU's model name (Linux /proc/cpuinfo), else platform.processor()."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor()


def machine_record(device: str) -> dict:
    """Where the benchmark ran."""
    return {
        "platform": platform.platform(),
        "cpu": cpu_model(),
        "cpu_count": os.cpu_count(),
        "python": platform.python_version(),
        "warp_version": wp.config.version,
        "warpsph_version": warpsph.__version__,
        "device": device,
        "device_name": wp.get_device(device).name,
    }


COLUMNS = (
    ("scheme", "{scheme}"),
    ("particles", "{particles:d}"),
    ("virtual", "{virtual_points:d}"),
    ("steps", "{steps:d}"),
    ("wall s", "{wall_seconds:.3f}"),
    ("compile s", "{compile_seconds:.2f}"),
    ("ms/step", "{ms_per_step:.2f}"),
    ("particle-steps/s", "{particle_steps_per_second:.3g}"),
    ("pairs/step", "{neighbour_pairs_per_step:d}"),
    ("interactions/s", "{neighbour_interactions_per_second:.3g}"),
    ("bytes/particle", "{memory_bytes_per_particle:.0f}"),
)


def markdown_table(header: list[str], rows: list[list[str]]) -> str:
    """A Markdown table with right-aligned, padded columns."""
    widths = [max(len(c) for c in col) for col in zip(header, *rows)]

    def line(cells) -> str:
        return "| " + " | ".join(c.rjust(w) for c, w in zip(cells, widths)) + " |"

    return "\n".join([line(header), "|" + "|".join("-" * (w + 1) + ":" for w in widths) + "|", *map(line, rows)])


def throughput_table(results: list[dict]) -> str:
    """The main table: one row per size and scheme."""
    rows = [[fmt.format(ms_per_step=1e3 * r["seconds_per_step"], **r) for _, fmt in COLUMNS] for r in results]
    return markdown_table([name for name, _ in COLUMNS], rows)


def stage_table(results: list[dict]) -> str:
    """Per-stage share of the step time [%] of results of one scheme, one row per size."""
    names = list(dict.fromkeys(s for r in results for s in r["stage_share"]))
    rows = [[r["scheme"], str(r["particles"]), *(f"{100 * r['stage_share'].get(s, 0.0):.1f}" for s in names)]
            for r in results]  # fmt: skip
    return markdown_table(["scheme", "particles", *(f"{s} %" for s in names)], rows)


def target_line(results: list[dict]) -> str | None:
    """How the reference row compares with the project target, when this run has one."""
    for r in results:
        if all(r[k] == TARGET[k] for k in ("particles", "dim", "precision")):
            ratio = r["particle_steps_per_second"] / TARGET["particle_steps_per_second"]
            return (f"target: {TARGET['particle_steps_per_second']:.2g} particle-steps/s at {TARGET['particles']} "
                    f"particles (2D, float64); {r['scheme']} measured {r['particle_steps_per_second']:.3g} "
                    f"= {ratio:.2f} × target")  # fmt: skip
    return None


# -- command line -----------------------------------------------------------------------------------
def parse_args(argv: list[str] | None) -> argparse.Namespace:
    p = argparse.ArgumentParser(prog="python -m warpsph.bench", description=__doc__.splitlines()[0],
                                formatter_class=argparse.ArgumentDefaultsHelpFormatter)  # fmt: skip
    p.add_argument("--sizes", type=int, nargs="+", default=None,
                   help="particle counts (default: 1024 4096 16384 in 2D, 512 4096 13824 in 3D)")
    p.add_argument("--dim", type=int, choices=(2, 3), default=2, help="dimension of the block")
    p.add_argument("--device", default="cpu", help="Warp device: cpu or cuda:0")
    p.add_argument("--scheme", choices=("two_set", "collocated", "both"), default="two_set")
    p.add_argument("--precision", choices=("float32", "float64"), default="float64")
    p.add_argument("--integrator", choices=("rk2", "rk4"), default="rk4")
    p.add_argument("--steps", type=int, default=200, help="timed steps per size")
    p.add_argument("--json", type=Path, default=Path("bench_results.json"), help="where to write the results")
    args = p.parse_args(argv)
    if args.steps < 1 or any(n < 4 for n in args.sizes or [4]):
        p.error("--steps must be >= 1 and every size >= 4")
    args.sizes = args.sizes or list(DEFAULT_SIZES[args.dim])
    return args


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    wp.config.log_level = wp.LOG_WARNING
    if args.device.startswith("cuda") and not wp.is_cuda_available():
        print(f"warpsph.bench: error: --device {args.device}: no CUDA device is available", file=sys.stderr)
        return 2
    machine = machine_record(args.device)
    print(f"{machine['device_name']} ({machine['cpu']}, {machine['cpu_count']} CPUs), warp {machine['warp_version']}, "
          f"{args.dim}D, {args.precision}, {args.integrator}, {args.steps} steps per size")  # fmt: skip
    schemes = ("two_set", "collocated") if args.scheme == "both" else (args.scheme,)
    results = []
    for scheme in schemes:
        for n in args.sizes:
            results.append(bench_size(n, scheme, args))
            print(f"  {scheme} {results[-1]['particles']} particles: {results[-1]['wall_seconds']:.2f} s", flush=True)
    print("\n" + throughput_table(results))
    for scheme in schemes:
        rows = [r for r in results if r["scheme"] == scheme]
        print(f"\nstage share of the step time ({scheme}):\n" + stage_table(rows))
    line = target_line(results)
    if line:
        print("\n" + line)
    write_record(args.json, {"machine": machine, "settings": vars(args), "target": TARGET, "results": results})
    return 0


def timing_fields(particles: int, steps: int, dt: float, build_s: float, compile_s: float, wall: float) -> dict:
    """The timing entries every benchmark row carries (times in s)."""
    return {
        "time_step": dt,
        "steps": steps,
        "build_seconds": build_s,
        "compile_seconds": compile_s,
        "wall_seconds": wall,
        "seconds_per_step": wall / steps,
        "particle_steps_per_second": particles * steps / wall,
    }


def write_record(path, record: dict) -> None:
    """Write a benchmark record as JSON to ``path`` and say so."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(record, indent=2, default=str))
    print(f"\nwrote {path}")


if __name__ == "__main__":
    sys.exit(main())
