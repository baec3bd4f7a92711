"""``warpsph study STUDY.toml [...]``: the command-line face of :mod:`warpsph.study`."""

from __future__ import annotations

import argparse
import importlib.util
import sys
from pathlib import Path

from warpsph.environment import default_device
from warpsph.errors import InputError, SceneError

EXTRA_HINT = "warpsph study needs dask.distributed and matplotlib: pip install 'warpsph[study]'"


def add_parser(sub, formatter_class=argparse.ArgumentDefaultsHelpFormatter) -> None:
    """Add the ``study`` sub-command to the ``warpsph`` parser's sub-parsers ``sub``."""
    p = sub.add_parser("study", help="sweep settings of closed-form scenes: error against run time (docs/accuracy.md)",
                       formatter_class=formatter_class)  # fmt: skip
    p.add_argument("studies", type=Path, nargs="+", help="study files (TOML, see docs/accuracy.md)")
    p.add_argument("--out", type=Path, default=Path("runs/studies"),
                   help="reports go to OUT/<study name>/, one record per run to OUT/<study name>/runs/")
    p.add_argument("--scheduler", default=None, help="address of a running Dask scheduler, e.g. tcp://10.0.0.5:8786; "
                   "None: a local cluster")  # fmt: skip
    p.add_argument("--workers", type=int, default=None, help="worker processes of the local cluster; None: one per "
                   "core; 0: the runs go in this process, without Dask")  # fmt: skip
    p.add_argument("--device", default=default_device(),
                   help="Warp device of the runs: cpu or cuda:0 ($WARPSPH_DEVICE sets the default)")
    p.add_argument("--dry-run", action="store_true", help="list the runs and their estimated CPU time; run nothing")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")


def main(args) -> int:
    """Run the studies of ``args`` and write their reports; 1 if some runs raised (they are not
    recorded and run again next time), else 0."""
    if not all(importlib.util.find_spec(m) for m in ("distributed", "matplotlib")):
        raise InputError(EXTRA_HINT)
    if args.workers is not None and args.workers < 0:
        raise InputError(f"--workers: must be >= 0, got {args.workers}")
    if args.device.startswith("cuda") and not args.scheduler and not args.dry_run:
        from warpsph.environment import init_warp

        if not init_warp().is_cuda_available():
            raise InputError(f"--device {args.device}: no CUDA device is available")
    from warpsph.study.execute import RunStore, run_studies
    from warpsph.study.report import write_reports
    from warpsph.study.spec import load_study

    studies = []
    for path in args.studies:
        try:
            study = load_study(path)
            cases = study.cases(args.device)
        except SceneError as e:
            raise InputError(f"{path}: {e}") from None
        studies.append(study)
        if args.dry_run:
            store = RunStore(args.out / study.name / "runs")
            done = [store.load(c.id) is not None for c in cases]
            todo = sum(c.estimated_seconds for c, d in zip(cases, done) if not d)
            print(f"{study.name}: {len(cases)} runs, {sum(done)} done, about {todo / 60:.1f} CPU-minutes to go")
            for case, finished in zip(cases, done):
                settings = ", ".join(f"{k} = {v}" for k, v in case.settings.items())
                print(f"  {case.id}  {'done' if finished else f'~{case.estimated_seconds:7.1f} s'}  {settings}")
    if args.dry_run:
        return 0
    outcomes = run_studies(studies, args.out, scheduler=args.scheduler, workers=args.workers, device=args.device,
                           progress=not args.no_progress)  # fmt: skip
    for outcome in outcomes:
        paths = write_reports(outcome)
        unstable = sum(r["status"] != "finished" for r in outcome.records)
        print(f"{outcome.study.name}: {len(outcome.records)} runs ({outcome.ran} ran now, {outcome.skipped} done "
              f"before, {unstable} unstable or failed); reports in {outcome.directory}: "
              f"{', '.join(p.name for p in paths)}")  # fmt: skip
        for lost in outcome.lost:
            print(f"  not recorded (runs again next time): {lost}", file=sys.stderr)
    print(f"wall time {outcomes[0].wall_seconds:.1f} s" if outcomes else "")
    return 1 if any(o.lost for o in outcomes) else 0
