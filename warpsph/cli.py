"""Command line: ``warpsph run SCENE``, ``warpsph validate SCENE``, ``warpsph export RUN`` and ``warpsph study STUDY``.

Exit codes (every failure is one line on stderr, never a traceback): 0 success, 1 the run went
unstable (its output up to then is kept), 2 a bad scene or bad arguments, 3 an equilibrium phase did
not converge within its step cap, or a safety phase found no bracket of its factor of safety (its
output is kept; the phases after it were not run), 4 the output could not be written (the run
directory is read-only, the disk is full; the last checkpoint is kept), 5 the device is not one of
this machine's, 130 interrupted by SIGINT (Ctrl-C) or SIGTERM (checkpointed: ``--resume`` continues).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from warpsph.environment import default_device
from warpsph.errors import DeviceError, InputError, OutputError, SceneError, SimulationError, one_line
from warpsph.study import command as study_command

EXIT_UNSTABLE, EXIT_BAD_INPUT, EXIT_NOT_CONVERGED, EXIT_OUTPUT, EXIT_DEVICE, EXIT_INTERRUPTED = 1, 2, 3, 4, 5, 130


class HelpFormatter(argparse.ArgumentDefaultsHelpFormatter):
    """Appends an option's default to its help unless the help says it already, or there is none to say
    (None, or a flag's False)."""

    def _get_help_string(self, action) -> str:
        if "default:" in (action.help or "") or action.default in (None, False):
            return action.help
        return super()._get_help_string(action)


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="warpsph", description="Two-set Taylor-SPH for soils, on NVIDIA Warp.",
                                formatter_class=HelpFormatter)  # fmt: skip
    p.add_argument("--version", action="version", version=_version())
    sub = p.add_subparsers(dest="command", required=True)
    run = sub.add_parser("run", help="run a scene", formatter_class=HelpFormatter)
    run.add_argument("scene", type=Path, help="scene file (TOML, see docs/scenes.md)")
    run.add_argument("--device", default=default_device(),
                     help="Warp device: cpu or cuda:0 ($WARPSPH_DEVICE sets the default)")
    run.add_argument("--out", type=Path, default=None, help="run directory (default: runs/SCENE_NAME)")
    run.add_argument("--end-time", type=float, default=None, help="stop at this simulated time [s] "
                     "instead of the scene's simulation.end_time")  # fmt: skip
    run.add_argument("--precision", choices=("float32", "float64"), default=None,
                     help="override the scene's simulation.precision")
    run.add_argument("--resume", action="store_true", help="continue from the run directory's checkpoint")
    run.add_argument("--overwrite", action="store_true", help="replace the output of an earlier run in the run "
                     "directory")  # fmt: skip
    run.add_argument("--no-progress", action="store_true", help="no progress bar")
    run.add_argument("--workers", type=int, default=None, help="safety phases: run each round's trials at once on "
                     "this many local Dask worker processes (None or 1: in turn, in this process)")  # fmt: skip
    run.add_argument("--scheduler", default=None, help="safety phases: run each round's trials at once on the "
                     "workers of the Dask scheduler at this address, e.g. tcp://10.0.0.5:8786")  # fmt: skip
    val = sub.add_parser("validate", help="check a scene without running it")
    val.add_argument("scene", type=Path, help="scene file (TOML)")
    val.add_argument("--device", default=default_device(), help="Warp device the estimate is measured on")
    val.add_argument("--no-estimate", action="store_true", help="build the particles but time no step")
    exp = sub.add_parser("export", help="write a run's frames as VTK files (.vtu per frame, a .pvd collection)",
                         formatter_class=HelpFormatter)  # fmt: skip
    exp.add_argument("run_dir", type=Path, metavar="RUN", help="run directory (holding results.h5)")
    exp.add_argument("--out", type=Path, default=None, help="directory for the files (default: RUN/vtu)")
    study_command.add_parser(sub, HelpFormatter)
    return p


def _version() -> str:
    """``warpsph X (warp-lang Y, Python Z)``, read without importing Warp."""
    import platform
    from importlib.metadata import PackageNotFoundError, version

    from warpsph.version import __version__

    try:
        warp = version("warp-lang")
    except PackageNotFoundError:
        warp = "not installed"
    return f"warpsph {__version__} (warp-lang {warp}, Python {platform.python_version()})"


def _fail(code: int, message: str) -> int:
    print(f"warpsph: error: {one_line(message)}", file=sys.stderr)
    return code


def _validate(args) -> int:
    from warpsph.environment import check_device
    from warpsph.planning import plan
    from warpsph.scene_toml import load_scene

    scene = load_scene(args.scene)
    lines = plan(scene, check_device(args.device), timed=not args.no_estimate).lines()
    print(f"{args.scene}: valid scene '{scene.name}' ({scene.simulation.dim}D, {len(scene.bodies)} bodies)")
    for line in lines:
        print(f"  {line}")
    return 0


def _run(args) -> int:
    from warpsph.scene_toml import load_scene

    scene = load_scene(args.scene)
    if args.end_time is not None and not args.end_time > 0:
        raise SceneError("--end-time", f"must be > 0, got {args.end_time}")
    from tqdm import tqdm

    from warpsph.phases.safety import limit_equilibrium_line, refined_line, trial_lines
    from warpsph.runner import Run

    out = args.out or Path("runs") / scene.name
    if args.workers is not None and args.workers < 1:
        raise SceneError("--workers", f"must be >= 1, got {args.workers}")
    run = Run(scene, out, device=args.device, precision=args.precision, end_time=args.end_time,
              resume=args.resume, overwrite=args.overwrite, trial_workers=args.workers,
              scheduler=args.scheduler)  # fmt: skip
    print(f"{scene.name}: {run.model.particle_count} particles, {run.model.virtual_count} virtual points, "
          f"dt = {run.dt:.4g} s, output in {out}")  # fmt: skip
    from warpsph.planning import count_steps

    for note in count_steps(scene)[3]:
        if note.startswith("warning"):
            print(f"warpsph: {note}", file=sys.stderr)
    interactive = sys.stderr.isatty()
    total = None if run.staged else run.end_time
    bar = tqdm(total=total, initial=run.time, unit="s", disable=args.no_progress,
               mininterval=0.5 if interactive else 30.0,
               bar_format="{l_bar}{bar}| t = {n:.4g}/{total:.4g} s [{elapsed}<{remaining}{postfix}]" if total else
               "t = {n:.4g} s [{elapsed}{postfix}]")  # fmt: skip

    def progress(t: float, step: int) -> None:
        projection = run.solver.projection
        solve = ""
        if projection is not None and projection.iterations:
            solve = f", {projection.settings.solver} {projection.iterations[-1]} it"
        if run.flow is not None:
            stepper = run.split or run.flow
            what = "fixed-stress iterations" if run.split else "iterations"
            solve = f", Δt = {run.loop.get('dt', 0.0):.3g} s, {stepper.iterations} {what}"
        phase = f"phase {run.phase.name} ({run.phase.kind}), " if run.staged else ""
        if run.phase.kind == "safety" and "search" in run.loop:
            factors = run.loop["search"]["factors"]
            phase += f"trial{'s' * (len(factors) > 1)} F = {', '.join(f'{f:.4g}' for f in factors)}, "
        ratio = f", ratio {run.loop['ratio']:.3g}" if "ratio" in run.loop else ""
        bar.set_postfix_str(f"{phase}step {step}{solve}{ratio}", refresh=False)
        bar.update((min(t, run.end_time) if total else t) - bar.n)

    def phase_done(p: dict) -> None:
        """Print a phase's result as it ends (above the progress bar), then its energy checks' warnings."""
        if run.staged:
            criterion = {"equilibrium": "unbalanced-force ratio", "safety": "factor of safety",
                         "dynamic": "kinetic energy / peak"}.get(p["kind"])  # fmt: skip
            reached = f", {criterion} {p['criterion']:.4g}" if criterion and p["criterion"] == p["criterion"] else ""
            if p["kind"] == "safety" and p["outcome"] == "converged":
                reached += f" ± {p['resolution']:.2g}"
            bar.write(f"phase {p['name']} ({p['kind']}): {p['outcome']} after {p['steps']} steps{reached}",
                      file=sys.stdout)  # fmt: skip
            for line in [limit_equilibrium_line(p.get("limit_equilibrium")),
                         refined_line(p["criterion"], p.get("refined"), scene.simulation.dx, p["name"]),
                         *trial_lines(p.get("trials", []), scene.simulation.dim)]:
                if line:
                    bar.write(line, file=sys.stdout)
        where = f"phase {p['name']}: " if run.staged else ""
        for line in p["warnings"] + p["energy_warnings"]:  # the phase's own, the energy balance's checks
            bar.write(f"warpsph: warning: {where}{line}", file=sys.stderr)

    try:
        s = run.run(progress=progress, phase_done=phase_done)
    finally:
        bar.close()
    print(f"done: {s.steps} steps to t = {s.final_time:.6g} s in {s.wall_seconds:.2f} s "
          f"({s.particle_steps_per_second:.3g} particle-steps/s), compile {s.compile_seconds:.2f} s, "
          f"{s.frames} frames")  # fmt: skip
    if s.status == "interrupted":
        return _fail(EXIT_INTERRUPTED, s.message)
    print(f"results in {out}: results.h5 (warpsph.load_results)"
          + (", results.xdmf (ParaView's XDMF Reader)" if scene.output.xdmf else "")
          + (", particles.usdc (usdview, Omniverse)" if scene.output.usd else ""))
    if s.status == "not converged" and run.phase.kind == "safety":
        return _fail(EXIT_NOT_CONVERGED, f"phase {s.phases[-1]['name']} found no factor of safety between 0.05 and "
                     f"factor_max = {run.phase.factor_max:g}; the phases after it were not run (results in {out})")
    if s.status == "not converged" and run.phase.kind == "flow":
        return _fail(EXIT_NOT_CONVERGED, f"phase {s.phases[-1]['name']} did not converge within its max_steps = "
                     f"{run.phase.max_steps}; the phases after it were not run (results in {out})")
    if s.status == "not converged":
        return _fail(EXIT_NOT_CONVERGED, f"phase {s.phases[-1]['name']} did not reach equilibrium within its "
                     f"max_steps = {run.phase.max_steps}; the phases after it were not run (results in {out})")
    return 0


def _export(args) -> int:
    from warpsph.io.export import export_vtu

    try:
        collection = export_vtu(args.run_dir, args.out)
    except ImportError as e:
        raise InputError(str(e)) from None
    print(f"{collection}: the frames of {args.run_dir} as .vtu files (ParaView, pyvista.read, meshio.read)")
    return 0


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """Warnings as one line each on stderr, ``warpsph: warning: ...``."""
    print(f"warpsph: warning: {one_line(str(message))}", file=sys.stderr)


def main(argv: list[str] | None = None) -> int:
    import warnings

    warnings.showwarning = _show_warning
    args = _parser().parse_args(argv)
    try:
        return {"validate": _validate, "run": _run, "export": _export, "study": study_command.main}[args.command](args)
    except DeviceError as e:
        return _fail(EXIT_DEVICE, str(e))
    except SceneError as e:
        return _fail(EXIT_BAD_INPUT, f"{getattr(args, 'scene', '')}: {e}")
    except (FileNotFoundError, InputError) as e:
        return _fail(EXIT_BAD_INPUT, str(e))
    except SimulationError as e:
        return _fail(EXIT_UNSTABLE, str(e))
    except OutputError as e:
        return _fail(EXIT_OUTPUT, str(e))
    except KeyboardInterrupt:
        return _fail(EXIT_INTERRUPTED, "interrupted")


if __name__ == "__main__":
    sys.exit(main())
