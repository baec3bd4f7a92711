"""Solver evidence for the pore-pressure projection: ``python -m warpsph.bench.pressure``.

For each size of a ladder of particle counts it builds a 2D consolidation problem (a saturated
elastic layer on a fixed, impermeable base between slip, impermeable sides, loaded at t = 0 by a
pressure step on its drained top, no gravity) and runs it with each pressure solver ("jacobi",
"cg") at the same relative tolerance: one warm-up step (compilation), a timed pass of ``--steps``
steps from the initial state, then a profiled pass of the same steps for the share of the
``pressure_projection`` stage. It prints a table and writes a JSON record (machine + one entry per
size and solver). docs/performance.md explains the numbers.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import warnings
from pathlib import Path

import numpy as np
import warp as wp

from warpsph.bench.record import machine_record, markdown_table, timing_fields, write_record
from warpsph.bench.throughput import DX, SOIL, WATER, block_shape, memory_bytes, timed
from warpsph.builder import build
from warpsph.model import Model, State
from warpsph.scene import (Body, Boundary, Drainage, Effects, Load, PressureSolver, Scene, Simulation,
                           TimeFunction)  # fmt: skip
from warpsph.solver import Solver

DEFAULT_SIZES = (1024, 4096, 16384)
"""Default particle counts (square layers at spacing DX; 128 × 128 = 16 384)."""
SOLVERS = ("jacobi", "cg")
LOAD = 10.0e3
"""Pressure step on the top face [Pa]."""
STAGE = "pressure_projection"


# -- scene ----------------------------------------------------------------------------------------
def consolidation_scene(n: int, solver: str, args) -> Scene:
    """Saturated layer of about ``n`` particles at spacing DX [m]: fixed impermeable base y = 0, slip
    impermeable sides, drained top loaded by a LOAD [Pa] step at t = 0; ``solver`` solves the pressure."""
    side, height = block_shape(n, 2)
    width, top = (side - 1) * DX, (height - 1) * DX
    soil = dataclasses.replace(SOIL, hydraulic_conductivity=args.hydraulic_conductivity,
                               **{**WATER, "water_bulk_modulus": args.water_bulk_modulus})  # fmt: skip
    walls = [Boundary("base", "fixed", "y", 0.0, "min"), Boundary("x_min", "slip", "x", 0.0, "min"),
             Boundary("x_max", "slip", "x", width, "max")]  # fmt: skip
    load = Load("surcharge", "traction", "y", top, "max", traction=(0.0, -LOAD, 0.0),
                time_function=TimeFunction("step"), drainage=Drainage("drained"))  # fmt: skip
    pressure = PressureSolver(solver=solver, tolerance=args.tolerance, max_iterations=args.max_iterations)
    sim = Simulation(dim=2, dx=DX, gravity=(0.0, 0.0, 0.0), precision=args.precision)
    body = Body(name="layer", material=soil.name, min=(0.0, 0.0, 0.0), max=(width, top, 0.0))
    return Scene(name=f"bench_consolidation_{n}_{solver}", simulation=sim, effects=Effects(pore_water=True),
                 materials={soil.name: soil}, bodies=[body], boundaries=walls, loads=[load],
                 pressure=pressure).validate()  # fmt: skip


def consolidation_coefficient(scene: Scene) -> float:
    """c_v = k_h / (ρ_w g (1/E_oed + 1/Q)) [m²/s] of the layer's material."""
    m = next(iter(scene.materials.values()))
    return m.hydraulic_conductivity / (m.water_density * 9.81 * (1.0 / m.oedometric_modulus + 1.0 / m.biot_modulus))


# -- measurement ------------------------------------------------------------------------------------
def run_steps(solver: Solver, start: State, steps: int, dt: float) -> list[State]:
    """Take ``steps`` steps of ``dt`` [s] from a copy of ``start`` at t = 0, synchronised; the state pair."""
    a, b = solver.model.state(), solver.model.state()
    a.assign(start)
    b.assign(start)
    for k in range(steps):
        solver.step(a, b, k * dt, dt)
        a, b = b, a
    wp.synchronize_device(solver.model.device)
    return [a, b]


def solve_record(solver: Solver) -> dict:
    """Iteration and residual statistics of the solves ``solver.projection`` recorded."""
    its = np.asarray(solver.projection.iterations)
    res = np.asarray(solver.projection.residuals)
    missed = solver.projection.failures
    return {"iterations_mean": float(its.mean()), "iterations_max": int(its.max()), "iterations_min": int(its.min()),
            "iterations_per_step": its.tolist(), "final_residual": float(res[-1]),
            "residual_max": float(res.max()), "missed_tolerance": missed}  # fmt: skip


def stage_seconds(model: Model, start: State, steps: int, dt: float) -> dict[str, float]:
    """Seconds per step of each stage from a profiled pass of ``steps`` steps from ``start`` (compiled)."""
    solver = Solver(model, profile=True)
    run_steps(solver, start, steps, dt)
    return {name: sec / steps for name, sec in solver.stage_seconds.items()}


def bench_case(n: int, solver_name: str, args) -> dict:
    """Build, warm up, time and profile one layer of about ``n`` particles with one pressure solver."""
    scene = consolidation_scene(n, solver_name, args)
    (model, start), build_s = timed(build, scene, args.device, args.precision)
    dt = scene.time_step
    solver = Solver(model)
    _, compile_s = timed(run_steps, solver, start, 1, dt)
    solver.projection.reset_statistics()  # the warm-up solve is not part of the record
    states, wall = timed(run_steps, solver, start, args.steps, dt)
    solves = solve_record(solver)
    stage = stage_seconds(model, start, args.steps, dt)
    total_stage = sum(stage.values())
    particles = model.particle_count
    return {
        "requested": n,
        "solver": solver_name,
        "particles": particles,
        "virtual_points": model.virtual_count,
        "block_shape": list(block_shape(n, 2)),
        "precision": model.spec.precision,
        "tolerance": args.tolerance,
        "max_iterations": args.max_iterations,
        "hydraulic_conductivity": args.hydraulic_conductivity,
        "water_bulk_modulus": args.water_bulk_modulus,
        "consolidation_coefficient": consolidation_coefficient(scene),
        **timing_fields(particles, args.steps, dt, build_s, compile_s, wall),
        **solves,
        "solve_seconds_per_step": stage[STAGE],
        "solve_share": stage[STAGE] / total_stage,
        "stage_seconds_per_step": stage,
        "memory_bytes_per_particle": sum(memory_bytes(model, states, solver).values()) / particles,
    }


# -- reporting --------------------------------------------------------------------------------------
COLUMNS = (
    ("solver", "{solver}"),
    ("particles", "{particles:d}"),
    ("steps", "{steps:d}"),
    ("mean it", "{iterations_mean:.1f}"),
    ("max it", "{iterations_max:d}"),
    ("solve ms/step", "{solve_ms:.2f}"),
    ("solve share %", "{share_percent:.1f}"),
    ("ms/step", "{ms_per_step:.2f}"),
    ("particle-steps/s", "{particle_steps_per_second:.3g}"),
    ("final rel. residual", "{final_residual:.2e}"),
    ("missed", "{missed_tolerance:d}"),
)


def solver_table(results: list[dict]) -> str:
    """One row per size and solver."""
    rows = [[fmt.format(solve_ms=1e3 * r["solve_seconds_per_step"], share_percent=100 * r["solve_share"],
                        ms_per_step=1e3 * r["seconds_per_step"], **r) for _, fmt in COLUMNS]
            for r in results]  # fmt: skip
    return markdown_table([name for name, _ in COLUMNS], rows)


# -- command line -----------------------------------------------------------------------------------
def parse_args(argv: list[str] | None) -> argparse.Namespace:
    p = argparse.ArgumentParser(prog="python -m warpsph.bench.pressure", description=__doc__.splitlines()[0],
                                formatter_class=argparse.ArgumentDefaultsHelpFormatter)  # fmt: skip
    p.add_argument("--sizes", type=int, nargs="+", default=list(DEFAULT_SIZES), help="particle counts")
    p.add_argument("--solvers", nargs="+", choices=SOLVERS, default=list(SOLVERS), help="pressure solvers")
    p.add_argument("--tolerance", type=float, default=1e-8, help="relative residual of every solve")
    p.add_argument("--max-iterations", type=int, default=1000, help="iteration cap of a solve")
    p.add_argument("--hydraulic-conductivity", type=float, default=1e-3,
                   help="k_h [m/s]; e.g. 1e-8 for a low-permeability (clay) case")
    p.add_argument("--water-bulk-modulus", type=float, default=100e6,
                   help="K_w [Pa]; 'inf' for incompressible water (with rigid grains: a pure Poisson solve)")
    p.add_argument("--device", default="cpu", help="Warp device: cpu or cuda:0")
    p.add_argument("--precision", choices=("float32", "float64"), default="float64")
    p.add_argument("--steps", type=int, default=50, help="timed (and profiled) steps per size and solver")
    p.add_argument("--json", type=Path, default=Path("bench_pressure.json"), help="where to write the results")
    args = p.parse_args(argv)
    if args.steps < 1 or args.max_iterations < 1 or any(n < 4 for n in args.sizes):
        p.error("--steps and --max-iterations must be >= 1 and every size >= 4")
    if not 0.0 < args.tolerance < 1.0:
        p.error("--tolerance must be in (0, 1)")
    return args


def settings_line(args, machine: dict) -> str:
    return (f"{machine['device_name']} ({machine['cpu']}, {machine['cpu_count']} CPUs), "
            f"warp {machine['warp_version']}, "
            f"2D, {args.precision}, tolerance {args.tolerance:g}, k_h = {args.hydraulic_conductivity:g} m/s, "
            f"K_w = {args.water_bulk_modulus:g} Pa, {args.steps} steps per case")  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    wp.config.log_level = wp.LOG_WARNING
    if args.device.startswith("cuda") and not wp.is_cuda_available():
        print(f"warpsph.bench_pressure: error: --device {args.device}: no CUDA device is available", file=sys.stderr)
        return 2
    machine = machine_record(args.device)
    print(settings_line(args, machine))
    results = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # missed tolerances are counted in the table instead
        for n in args.sizes:
            for name in args.solvers:
                results.append(bench_case(n, name, args))
                r = results[-1]
                print(f"  {name} {r['particles']} particles: {r['wall_seconds']:.2f} s, "
                      f"{r['iterations_mean']:.1f} iterations per step", flush=True)  # fmt: skip
    print("\n" + solver_table(results))
    missed = [r for r in results if r["missed_tolerance"]]
    for r in missed:
        print(f"{r['solver']} at {r['particles']} particles missed the tolerance in {r['missed_tolerance']} of "
              f"{r['steps']} solves (max residual {r['residual_max']:.2e})")  # fmt: skip
    write_record(args.json, {"machine": machine, "settings": vars(args), "load_pa": LOAD, "results": results})
    return 0


if __name__ == "__main__":
    sys.exit(main())
