"""Short runs of every shipped scene, through all their phases, to show what a change of the code moves:
``python -m warpsph.regression run OUT`` before and after, then ``python -m warpsph.regression compare BEFORE AFTER``
(docs/output.md, *Comparing runs*).
"""

from __future__ import annotations

import argparse
import copy
import sys
import time
from pathlib import Path

from warpsph.phases import phase_scene
from warpsph.scene import Phase, Scene

SCENES = Path(__file__).resolve().parent.parent / "scenes"
STEPS = 20
"""Steps of a dynamic phase (a scene without phases: of its one dynamic phase)."""
EASY = 1e9
"""The unbalanced-force ratio a shortened equilibrium or safety trial stands at: an equilibrium ends at its
first check."""
FAR = 1e9
"""A shortened safety phase's failure displacement [m]: its trials never fail, and stand once the window
over which a trial must be at rest has passed (``TrialJudge.REST_STEPS``)."""
SHORTER = 100.0
"""A transient flow or consolidation phase runs this fraction of its duration."""
COARSER = 5.0
"""The consolidation variant's particle spacing over its scene's."""
SAFETY_FACTOR_MAX = 2.0
"""A shortened safety phase's largest factor: three trials, each one that stands."""


def shortened(scene: Scene) -> Scene:
    """``scene`` cut short, each of its phases run: a dynamic phase ``STEPS`` steps, an equilibrium to
    its first check, a safety trial to the end of the window over which it must be at rest, a transient
    flow or consolidation 1/``SHORTER`` of its duration in two frames; frames every 5 steps of the
    explicit phases."""
    out = copy.deepcopy(scene)
    if not out.phases:
        out.simulation.end_time = STEPS * scene.time_step
    for index, phase in enumerate(out.phases):
        dt = phase_scene(scene, index).time_step
        if phase.kind == "dynamic":
            phase.duration = STEPS * dt
        elif phase.kind in ("equilibrium", "safety"):
            phase.tolerance = EASY
            phase.factor_max = min(phase.factor_max, SAFETY_FACTOR_MAX)
            if phase.kind == "safety":
                phase.failure_displacement = FAR
        elif phase.kind in ("flow", "consolidation") and not phase.steady:
            phase.duration /= SHORTER
            phase.frames = 2
    out.output.frame_interval = 5 * scene.time_step
    out.output.checkpoint_interval = 0.0
    return out.validate()


def consolidation_variant(scene: Scene) -> Scene:
    """A one-dimensional consolidation scene's coupled transient as a consolidation phase of its end time,
    at ``COARSER`` times its particle spacing (each implicit step is an equilibrium of the skeleton)."""
    out = copy.deepcopy(scene)
    out.name = f"{scene.name}_consolidation"
    out.simulation.dx *= COARSER
    out.phases = [Phase(name="consolidation", kind="consolidation", duration=scene.simulation.end_time, frames=2)]
    return out.validate()


def without_safety(scene: Scene) -> Scene:
    """``scene`` with its safety phases run as equilibrium phases (a shortened safety phase finds no
    bracket, which ends the run): the phases after them run too."""
    out = copy.deepcopy(scene)
    out.name = f"{scene.name}_without_safety"
    for phase in out.phases:
        if phase.kind == "safety":
            phase.kind = "equilibrium"
    return out.validate()


def cases(names: list[str] | None = None) -> dict[str, Scene]:
    """The shipped scenes (``names``: only these), each with safety phases also without them, and the
    consolidation variant of Terzaghi's, by name."""
    from warpsph.scene_toml import load_scene

    scenes = {}
    for path in sorted(SCENES.glob("*.toml")):
        scene = load_scene(path)
        scenes[path.stem] = scene
        if any(p.kind == "safety" for p in scene.phases):
            variant = without_safety(scene)
            scenes[variant.name] = variant
    if "terzaghi" in scenes:
        variant = consolidation_variant(scenes["terzaghi"])
        scenes[variant.name] = variant
    if names:
        unknown = sorted(set(names) - set(scenes))
        if unknown:
            raise SystemExit(f"--only: no case {', '.join(unknown)}; the cases: {', '.join(scenes)}")
        scenes = {k: v for k, v in scenes.items() if k in names}
    return scenes


def run_all(out: Path, names: list[str] | None = None, device: str | None = None) -> None:
    """Run each case shortened into ``out``/NAME (replacing an earlier run there)."""
    from warpsph.errors import SimulationError
    from warpsph.runner import Run

    for name, scene in cases(names).items():
        start = time.perf_counter()
        short = shortened(scene)
        short.output.usd = False
        run = Run(short, out / name, device=device, overwrite=True)
        try:  # a run the guard stops is compared up to there
            status = run.run().status
        except SimulationError:
            status = "unstable"
        print(f"{name:<36} {status:<14} {run.step_index:>6} steps {time.perf_counter() - start:6.1f} s", flush=True)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m warpsph.regression", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    run = sub.add_parser("run", help="run every case shortened into OUT/NAME")
    run.add_argument("out", type=Path)
    run.add_argument("--only", nargs="+", default=None, help="only these cases (scene names)")
    run.add_argument("--device", default=None)
    compare = sub.add_parser("compare", help="the largest difference per field of two runs' output")
    compare.add_argument("a", type=Path)
    compare.add_argument("b", type=Path)
    compare.add_argument("--all", action="store_true", help="a line for every field, the identical ones too")
    args = parser.parse_args(argv)
    if args.command == "run":
        run_all(args.out, args.only, args.device)
        return 0
    from warpsph.io.compare import compare_runs

    try:
        comparison = compare_runs(args.a, args.b)
    except FileNotFoundError as e:
        print(f"compare: {e}", file=sys.stderr)
        return 2
    print("\n".join(comparison.lines(args.all)))
    return 0 if comparison.identical else 1


if __name__ == "__main__":
    sys.exit(main())
