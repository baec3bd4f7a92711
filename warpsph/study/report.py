"""Study reports: CSV, JSON, a Markdown table and error-against-time plots with the Pareto front.

Cost is the study's cost measure: the wall time (``wall_seconds``) or the CPU time (``cpu_seconds``)
of the steps of a run, compile time apart. A run is on the Pareto front of an error when no other
finished run is at least as cheap and at least as accurate and better in one of the two.
"""

from __future__ import annotations

import csv
import json
import math

import matplotlib
import numpy as np

from warpsph.bench.record import markdown_table
from warpsph.study.execute import StudyOutcome
from warpsph.study.spec import COSTS, LADDER_KEY, scene_setting

COST_COLUMNS = {"wall_seconds": "wall s", "cpu_seconds": "cpu s"}
TIMING_COLUMNS = ("particles", "virtual_points", "steps", "time_step", "wall_seconds", "cpu_seconds", "compile_seconds",
                  "build_seconds", "particle_steps_per_second", "total_seconds")  # fmt: skip


def pareto_front(cost, error) -> np.ndarray:
    """Boolean mask of the points no other point dominates (cost ≤ and error ≤, one of them <);
    points with a non-finite cost or error are never on it."""
    cost, error = np.asarray(cost, dtype=float), np.asarray(error, dtype=float)
    ok = np.isfinite(cost) & np.isfinite(error)
    front = ok.copy()
    for i in np.flatnonzero(ok):
        beaten = ok & (cost <= cost[i]) & (error <= error[i]) & ((cost < cost[i]) | (error < error[i]))
        front[i] = not beaten.any()
    return front


def _error(record: dict, name: str) -> float:
    value = record.get("errors", {}).get(name)
    return float(value) if value is not None and record["status"] == "finished" else math.nan


def _cost(record: dict, cost: str) -> float:
    return float(record.get(cost, math.nan)) if record["status"] == "finished" else math.nan


def fronts(outcome: StudyOutcome) -> dict[str, np.ndarray]:
    """Error name → Pareto mask over the outcome's records."""
    cost = [_cost(r, outcome.study.cost) for r in outcome.records]
    return {e: pareto_front(cost, [_error(r, e) for r in outcome.records]) for e in outcome.study.metric.errors}


def varying_axes(outcome: StudyOutcome) -> list[str]:
    """Axis keys whose value differs between the records."""
    records = outcome.records
    return [k for k in outcome.study.axes if len({json.dumps(r["settings"].get(k)) for r in records}) > 1]


def short_names(keys: list[str]) -> dict[str, str]:
    """Dotted key → its last part, or the whole key where last parts collide."""
    last = [k.rsplit(".", 1)[-1] for k in keys]
    return {k: (n if last.count(n) == 1 else k) for k, n in zip(keys, last)}


def _show(value) -> str:
    if isinstance(value, float):
        return f"{value:.3g}"
    return str(value)


def write_reports(outcome: StudyOutcome) -> list:
    """Write ``results.csv``, ``results.json``, ``results.md`` and ``<error>_vs_time.png`` (one per
    error of the metric) into the outcome's directory; return their paths."""
    out = outcome.directory
    out.mkdir(parents=True, exist_ok=True)
    masks = fronts(outcome)
    paths = [_write_csv(outcome, masks, out / "results.csv"), _write_json(outcome, masks, out / "results.json"),
             _write_markdown(outcome, masks, out / "results.md")]  # fmt: skip
    paths += [_plot(outcome, e, masks[e], out / f"{e}_vs_time.png") for e in outcome.study.metric.errors]
    return paths


def _flat_row(record: dict, masks: dict, index: int, study) -> dict:
    row = {"id": record["id"], "status": record["status"]}
    row.update({k: json.dumps(v) if isinstance(v, (list, dict)) else v for k, v in record["settings"].items()})
    row.update({e: record.get("errors", {}).get(e, "") for e in study.metric.errors})
    row.update(record.get("extras", {}))
    row.update({f"pareto_{e}": bool(mask[index]) for e, mask in masks.items()})
    row.update({k: record.get(k, "") for k in TIMING_COLUMNS})
    solve = record.get("pressure_solve", {})
    row.update({f"pressure_{k}": v for k, v in solve.items()})
    row["message"] = record.get("message", "")
    return row


def _write_csv(outcome: StudyOutcome, masks: dict, path):
    rows = [_flat_row(r, masks, i, outcome.study) for i, r in enumerate(outcome.records)]
    columns = list(dict.fromkeys(k for row in rows for k in row))
    with open(path, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=columns)
        writer.writeheader()
        writer.writerows(rows)
    return path


def _write_json(outcome: StudyOutcome, masks: dict, path):
    study = outcome.study
    machines = list({json.dumps(r["machine"], sort_keys=True): r["machine"] for r in outcome.records}.values())
    document = {
        "study": {"name": study.name, "file": str(study.path), "scene": str(study.scene_path),
                  "metric": study.metric.name, "errors": study.metric.errors, "error": study.error, "cost": study.cost,
                  "fixed": study.fixed, "sweeps": dict(study.sweeps)},
        "machines": machines,
        "invocation": {"ran": outcome.ran, "skipped": outcome.skipped, "lost": outcome.lost,
                       "wall_seconds": outcome.wall_seconds},
        "runs": [{**r, "pareto": {e: bool(mask[i]) for e, mask in masks.items()}}
                 for i, r in enumerate(outcome.records)],
    }  # fmt: skip
    path.write_text(json.dumps(document, indent=2, default=str))
    return path


def _write_markdown(outcome: StudyOutcome, masks: dict, path):
    study, records = outcome.study, outcome.records
    axes = varying_axes(outcome)
    names = short_names(axes)
    errors = list(study.metric.errors)
    extras = list(dict.fromkeys(k for r in records for k in r.get("extras", {})))
    solve = any("pressure_solve" in r for r in records)
    header = [names[k] for k in axes] + errors + extras + ["particles", "steps", "wall s", "cpu s", "compile s"]
    header += ["solver it/step", "missed"] if solve else []
    header += [f"front ({study.error})"]
    rows = []
    for i, r in enumerate(records):
        row = [_show(r["settings"][k]) for k in axes]
        if r["status"] == "finished":
            row += [f"{r['errors'][e]:.3g}" for e in errors] + [f"{r['extras'].get(x, math.nan):.3g}" for x in extras]
            row += [str(r["particles"]), str(r["steps"]), f"{r['wall_seconds']:.3g}",
                    f"{r.get('cpu_seconds', math.nan):.3g}", f"{r['compile_seconds']:.2f}"]  # fmt: skip
            if solve:
                s = r.get("pressure_solve", {})
                row += [f"{s.get('iterations_mean', math.nan):.3g}", str(s.get("missed_tolerance", ""))]
        else:
            row += [r["status"]] + [""] * (len(errors) + len(extras) + 4 + (2 if solve else 0))
        row.append("★" if masks[study.error][i] else "")
        rows.append(row)
    machine = records[0]["machine"] if records else {}
    lines = [f"# Study `{study.name}`", ""]
    if study.description:
        lines += [study.description, ""]
    lines += [f"Scene `{study.scene_path.name}`, metric `{study.metric.name}`: {study.metric.description}.", ""]
    lines += [f"- `{e}`: {text}" for e, text in study.metric.errors.items()]
    cost = COST_COLUMNS[study.cost]
    lines += [f"- cost: `wall s` and `cpu s` are the wall and CPU time of the steps alone (compilation, building and "
              f"sampling apart), on {machine.get('device_name', '?')} ({machine.get('cpu', '?')}, "
              f"{machine.get('cpu_count', '?')} CPUs), warp {machine.get('warp_version', '?')}",
              f"- ★: on the Pareto front of `{study.error}` against `{cost}` (no other run is both as cheap and "
              f"as accurate)",
              f"- fixed: {', '.join(f'`{k} = {v}`' for k, v in study.fixed.items()) or 'nothing'}; other settings "
              f"as in the scene", ""]  # fmt: skip
    lines += [markdown_table(header, rows), ""]
    failed = [r for r in records if r["status"] != "finished"]
    for r in failed:
        settings = ", ".join(f"{names[k]} = {_show(r['settings'][k])}" for k in axes)
        lines.append(f"- {r['status']}: {settings}: {r['message']}")
    path.write_text("\n".join(lines).rstrip() + "\n")
    return path


def _plot(outcome: StudyOutcome, error: str, front: np.ndarray, path):
    """Log-log error against cost; runs differing only in Δx joined by a line and labelled by what
    differs from the base scene (with ``fixed``), the front ringed and joined by a dashed step line."""
    from matplotlib.figure import Figure

    study, records = outcome.study, outcome.records
    axes = varying_axes(outcome)
    names = short_names(axes)
    grouping = [k for k in axes if k != LADDER_KEY]
    base_scene = study.scene(study.fixed)
    base = {k: json.dumps(scene_setting(base_scene, k)) for k in grouping}
    series: dict[tuple, list[int]] = {}
    for i, r in enumerate(records):
        if r["status"] == "finished" and _error(r, error) > 0:
            series.setdefault(tuple(json.dumps(r["settings"][k]) for k in grouping), []).append(i)

    def point(i: int) -> tuple[float, float]:
        return _cost(records[i], study.cost), _error(records[i], error)

    fig = Figure(figsize=(10, 5.5), layout="constrained")
    ax = fig.subplots()
    colours = [matplotlib.colormaps["tab10"](i % 10) for i in range(len(series))]
    for n, (key, members) in enumerate(series.items()):
        members.sort(key=point)
        changed = [f"{names[k]} = {_show(json.loads(v))}" for k, v in zip(grouping, key) if v != base[k]]
        ax.plot(*zip(*map(point, members)), marker="os^Dv<>p"[n // 10 % 8], ls="-" if n < 10 else "--", ms=4,
                color=colours[n], label=", ".join(changed) or "scene settings")  # fmt: skip
        if LADDER_KEY in axes:
            for i in members:
                ax.annotate(f"{records[i]['settings'][LADDER_KEY]:g}", point(i), textcoords="offset points",
                            xytext=(3, 3), fontsize=6, color="0.4")  # fmt: skip
    on_front = sorted((i for i in np.flatnonzero(front) if _error(records[i], error) > 0), key=point)
    if on_front:
        x, y = zip(*map(point, on_front))
        ax.step(x, y, where="post", color="k", lw=1, ls=":", label="Pareto front")
        ax.plot(x, y, "o", ms=11, mfc="none", mec="k")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel(f"{COSTS[study.cost]} [s] (compile time apart)")
    ax.set_ylabel(error)
    ladder = f"; points labelled by {names[LADDER_KEY]} [m]" if LADDER_KEY in axes else ""
    ax.set_title(f"{study.name}: {error} against cost{ladder}", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    fig.legend(fontsize=7, loc="outside right upper", title="differs from the scene", title_fontsize=7)
    fig.savefig(path, dpi=110)
    return path
