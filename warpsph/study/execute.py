"""Running the cases of studies through dask.distributed, one JSON record per finished run.

Each run is :func:`run_case`, a function of (scene text, overrides, metric, device) alone, so the
runs go to any Dask cluster unchanged: a ``LocalCluster`` of one worker process per core by default
(each run's row launches on cores ÷ workers threads), or the scheduler at an address. Records are
written by the client, atomically, to ``<study out>/runs/<case id>.json``; a study started again
skips the cases that have one.
"""

from __future__ import annotations

import json
import os
import time
from dataclasses import dataclass, field
from pathlib import Path

from warpsph.cluster import dask_client
from warpsph.errors import InputError, SimulationError
from warpsph.study.spec import Case, Study


def run_case(scene_text: str, scene_name: str, overrides: dict, metric: str, device: str | None = None) -> dict:
    """Build and run the scene with ``overrides``, measure ``metric``; return the run's record:
    status ("finished", "unstable" or "failed": the scene could not be built), errors, extras and
    timings [s] (``wall_seconds`` counts the steps alone, ``compile_seconds`` the warm-up step)."""
    from warpsph.bench.record import machine_record, timing_fields
    from warpsph.environment import init_warp
    from warpsph.scene_toml import parse_scene
    from warpsph.environment import default_device
    from warpsph.study.metrics import METRICS

    init_warp()
    device = device or default_device()
    record = {"overrides": overrides, "metric": metric, "status": "finished", "message": "", "errors": {},
              "extras": {}, "machine": machine_record(device)}  # fmt: skip
    start = time.perf_counter()
    try:
        measured = METRICS[metric].measure(parse_scene(scene_text, name=scene_name, overrides=overrides), device)
    except SimulationError as e:
        record.update(status="unstable", message=str(e))
    except InputError as e:
        record.update(status="failed", message=str(e))
    else:
        run = measured.run
        record.update(errors=measured.errors, extras=measured.extras, particles=run.model.particle_count,
                      virtual_points=run.model.virtual_count,
                      **timing_fields(run.model.particle_count, run.steps, run.time_step, run.build_seconds,
                                      run.compile_seconds, run.step_seconds),
                      cpu_seconds=run.step_cpu_seconds)  # fmt: skip
        projection = run.solver.projection
        if projection is not None and projection.iterations:
            its = projection.iterations
            record["pressure_solve"] = {"iterations_mean": float(sum(its) / len(its)), "iterations_max": int(max(its)),
                                        "missed_tolerance": int(projection.failures)}  # fmt: skip
    record["total_seconds"] = time.perf_counter() - start
    return record


class RunStore:
    """One JSON record per case under ``directory``, named by the case id, written atomically."""

    def __init__(self, directory: Path):
        self.directory = Path(directory)

    def path(self, case_id: str) -> Path:
        return self.directory / f"{case_id}.json"

    def load(self, case_id: str) -> dict | None:
        """The record of ``case_id``, or None when there is none (or it cannot be read)."""
        try:
            return json.loads(self.path(case_id).read_text())
        except (OSError, ValueError):
            return None

    def save(self, record: dict) -> None:
        self.directory.mkdir(parents=True, exist_ok=True)
        target = self.path(record["id"])
        partial = target.with_name(f".{target.name}.{os.getpid()}.partial")
        partial.write_text(json.dumps(record, indent=2, default=str))
        os.replace(partial, target)


@dataclass
class StudyOutcome:
    """What one invocation did for one study."""

    study: Study
    directory: Path
    records: list[dict] = field(default_factory=list)
    """Records of every case that has one, in case order."""
    ran: int = 0
    skipped: int = 0
    """Cases that already had a record."""
    lost: list[str] = field(default_factory=list)
    """'case id: error' of runs that raised (no record written; they run again next time)."""
    wall_seconds: float = 0.0
    """Wall time of this invocation for all its studies together [s]."""


def run_studies(studies: list[Study], out_dir, *, scheduler: str | None = None, workers: int | None = None,
                device: str | None = None, progress: bool = True) -> list[StudyOutcome]:
    """Run every case of ``studies`` that has no record yet under ``out_dir/<study name>/runs``,
    longest first, through Dask (``workers=0``: in this process, without Dask); return the outcomes
    (reports are :func:`warpsph.study.report.write_reports`'s)."""
    from tqdm import tqdm

    from warpsph.environment import default_device

    device = device or default_device()
    start = time.perf_counter()
    outcomes, pending = [], []
    for study in studies:
        outcome = StudyOutcome(study, Path(out_dir) / study.name)
        store = RunStore(outcome.directory / "runs")
        cases = study.cases(device)
        todo = [case for case in cases if store.load(case.id) is None]
        outcome.skipped = len(cases) - len(todo)
        pending += [(outcome, store, case) for case in todo]
        outcomes.append((outcome, store, cases))
    pending.sort(key=lambda item: -item[2].estimated_seconds)
    total = sum(len(cases) for _, _, cases in outcomes)
    bar = tqdm(total=total, initial=total - len(pending), unit="run", disable=not progress,
               desc=", ".join(s.name for s in studies))  # fmt: skip

    def finished(outcome: StudyOutcome, store: RunStore, case: Case, record: dict) -> None:
        store.save({"id": case.id, "study": outcome.study.name, "settings": case.settings, **record})
        outcome.ran += 1
        bar.update()
        bar.set_postfix_str(f"{bar.total - bar.n} remaining", refresh=False)

    try:
        if workers == 0:
            for outcome, store, case in pending:
                function, *args = _submit_args(outcome.study, case, device)
                try:
                    finished(outcome, store, case, function(*args))
                except Exception as e:  # noqa: BLE001 - reported, the case runs again next time
                    outcome.lost.append(f"{case.id}: {type(e).__name__}: {e}")
        elif pending:
            from dask.distributed import as_completed

            with dask_client(scheduler, workers) as client:
                futures = {client.submit(*_submit_args(outcome.study, case, device),
                                         key=f"warpsph-{outcome.study.name}-{case.id}"): (outcome, store, case)
                           for outcome, store, case in pending}  # fmt: skip
                for future in as_completed(futures):
                    outcome, store, case = futures[future]
                    try:
                        finished(outcome, store, case, future.result())
                    except Exception as e:  # noqa: BLE001 - reported, the case runs again next time
                        outcome.lost.append(f"{case.id}: {type(e).__name__}: {e}")
    finally:
        bar.close()
    wall = time.perf_counter() - start
    for outcome, store, cases in outcomes:
        # settings from this study file: a record made by an earlier version of it may lack new axes
        loaded = ((case, store.load(case.id)) for case in cases)
        outcome.records = [{**record, "settings": case.settings} for case, record in loaded if record is not None]
        outcome.wall_seconds = wall
    return [outcome for outcome, _, _ in outcomes]


def _submit_args(study: Study, case: Case, device: str) -> tuple:
    return run_case, study.scene_text, study.scene_name, case.overrides, study.metric.name, device
