"""Where users wait: ``python -m warpsph.bench.phases`` runs whole staged scenes and reports each phase's
cost (steps, wall time; a safety phase's trials and steps per trial; a consolidation phase's implicit
steps and fixed-stress iterations per step). docs/performance.md, *Where users wait*, has the numbers.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from warpsph.bench.record import machine_record, markdown_table, write_record
from warpsph.io import load_results
from warpsph.regression import SCENES, consolidation_variant
from warpsph.runner import Run
from warpsph.scene_toml import load_scene

CASES = ("slope_fos", "slope_fos_incremental", "terzaghi_consolidation")
"""The shipped safety search (the slope of the tutorial), the same with incremental trials, and Terzaghi's
column as a consolidation phase (:func:`warpsph.regression.consolidation_variant`)."""


def case_scene(name: str):
    """The scene of case ``name``: a shipped scene, ``<scene>_consolidation`` for its consolidation variant,
    or ``<scene>_incremental`` for the scene with its safety phases' ``incremental`` on."""
    if name.endswith("_consolidation"):
        return consolidation_variant(load_scene(SCENES / f"{name.removesuffix('_consolidation')}.toml"))
    if name.endswith("_incremental"):
        scene = load_scene(SCENES / f"{name.removesuffix('_incremental')}.toml")
        scene.phases = [dataclasses.replace(p, incremental=True) if p.kind == "safety" else p for p in scene.phases]
        return scene.validate()
    return load_scene(SCENES / f"{name}.toml")


def phase_costs(scene, out: Path, device: str | None = None) -> list[dict]:
    """Run ``scene`` into ``out``; one record per phase: its kind, steps and wall seconds, with a safety
    phase's trials and steps per trial and a consolidation phase's implicit steps and fixed-stress
    iterations per step."""
    scene.output.usd = False
    marks = [time.perf_counter()]
    rows = []

    def done(phase: dict) -> None:
        marks.append(time.perf_counter())
        rows.append({"phase": phase["name"], "kind": phase["kind"], "outcome": phase["outcome"],
                     "steps": phase["steps"], "wall_seconds": marks[-1] - marks[-2]})  # fmt: skip
        if phase["kind"] == "safety":
            trials = len(phase["trials"])
            rows[-1].update(trials=trials, steps_per_trial=phase["steps"] / max(trials, 1), factor=phase["criterion"])

    Run(scene, out, device=device, overwrite=True).run(phase_done=done)
    results = load_results(out / "results.h5")
    if "consolidation_iterations" in results.series_names:
        times, iterations = results.series("consolidation_iterations")
        for row in rows:
            if row["kind"] == "consolidation":
                row.update(implicit_steps=len(times), iterations_per_step=float(np.mean(iterations)))
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m warpsph.bench.phases", description=__doc__.splitlines()[0])
    parser.add_argument("--cases", nargs="+", default=list(CASES), help="shipped scene names (NAME_consolidation: "
                        "the scene's consolidation variant; NAME_incremental: its safety phases' trials "
                        "incremental)")  # fmt: skip
    parser.add_argument("--device", default="cpu")
    parser.add_argument("--json", type=Path, default=Path("runs/bench/phases.json"))
    args = parser.parse_args(argv)
    record = {"machine": machine_record(args.device), "cases": {}}
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.cases:
            record["cases"][name] = phase_costs(case_scene(name), Path(tmp) / name, args.device)
    header = ["case", "phase", "kind", "steps", "wall s", "trials", "steps/trial", "factor", "implicit steps",
              "iterations/step"]  # fmt: skip
    rows = [[name, r["phase"], r["kind"], str(r["steps"]), f"{r['wall_seconds']:.1f}", str(r.get("trials", "")),
             f"{r['steps_per_trial']:.0f}" if "steps_per_trial" in r else "",
             f"{r['factor']:.4g}" if "factor" in r else "", str(r.get("implicit_steps", "")),
             f"{r['iterations_per_step']:.1f}" if "iterations_per_step" in r else ""]
            for name, case in record["cases"].items() for r in case]  # fmt: skip
    print(markdown_table(header, rows))
    write_record(args.json, record)
    return 0


if __name__ == "__main__":
    sys.exit(main())
