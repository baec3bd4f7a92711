"""Study files: a base scene, the settings to sweep and the error metric, read into the runs of a study
(docs/accuracy.md, *Study files*).
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import itertools
import json
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from warpsph.errors import SceneError
from warpsph.scene import Scene
from warpsph.scene_toml import parse_scene
from warpsph.study.metrics import METRICS, PLANNED_METRICS, Metric
from warpsph.scene_types import show

SECTIONS = ("axes", "fixed", "study", "sweeps")
STUDY_KEYS = ("cost", "description", "error", "metric", "name", "scene")
COSTS = {"wall_seconds": "wall time of the steps", "cpu_seconds": "CPU time of the steps"}
"""Cost measures a study can put against the error (compile time apart in both) [s]."""
LADDER_KEY = "simulation.dx"
"""The axis whose runs the plots join into lines (a refinement ladder)."""


@dataclass(frozen=True)
class Case:
    """One run of a study."""

    id: str
    """Hash of the run's scene (all settings, name aside), metric and device: the key of its record."""
    overrides: dict
    """Dotted scene key → value set over the base scene."""
    settings: dict
    """Every axis key of the study → its value in this run (from the scene, defaults included)."""
    estimated_seconds: float
    """Rough CPU time of the run [s] (:meth:`Metric.estimated_seconds`): longest runs go first."""


@dataclass
class Study:
    """A parsed study file."""

    name: str
    path: Path
    scene_path: Path
    scene_text: str
    metric: Metric
    error: str
    """The error measure whose Pareto front the table marks."""
    cost: str = "wall_seconds"
    """The cost measure of the plots and Pareto fronts, a key of ``COSTS``."""
    description: str = ""
    fixed: dict = field(default_factory=dict)
    sweeps: list[tuple[str, dict]] = field(default_factory=list)
    """(study-file key of the sweep, {dotted scene key: [values]}) in file order."""

    @property
    def scene_name(self) -> str:
        return self.scene_path.stem

    @property
    def axes(self) -> list[str]:
        """Every swept key, in order of first appearance."""
        return list(dict.fromkeys(k for _, sweep in self.sweeps for k in sweep))

    def scene(self, overrides: dict) -> Scene:
        """The base scene with ``overrides`` (:func:`warpsph.scene_toml.parse_scene`)."""
        return parse_scene(self.scene_text, name=self.scene_name, overrides=overrides)

    def cases(self, device: str | None = None) -> list[Case]:
        """Every run: the cartesian product of each sweep's values over ``fixed``, in file order,
        runs with the same scene once. Raises :class:`SceneError` naming the study key of the first
        override the scene refuses, or ``study.metric`` when the scene does not fit the metric."""
        cases: dict[str, Case] = {}
        for where, sweep in self.sweeps:
            keys = list(sweep)
            for values in itertools.product(*(sweep[k] for k in keys)):
                overrides = {**self.fixed, **dict(zip(keys, values))}
                try:
                    scene = self.scene(overrides)
                except SceneError as e:
                    raise self._blame(e, where, overrides) from None
                self.metric.check(scene)
                case_id = run_id(scene, self.metric.name, device)
                if case_id not in cases:
                    settings = {k: scene_setting(scene, k) for k in self.axes}
                    cases[case_id] = Case(case_id, overrides, settings, self.metric.estimated_seconds(scene))
        return list(cases.values())

    def _blame(self, error: SceneError, where: str, overrides: dict) -> SceneError:
        """Name the study key whose override the scene refused (or show the overrides)."""
        for key in overrides:
            if error.key == key or error.key.startswith((key + ".", key + "[")) or key.startswith(error.key + "."):
                section = "fixed" if key in self.fixed and key not in dict(self.sweeps)[where] else where
                return SceneError(f"{section}.{key}", error.message)
        given = ", ".join(f"{k} = {show(v)}" for k, v in overrides.items())
        return SceneError(error.key, f"{error.message} (scene {self.scene_path} with {given})")


@functools.cache
def code_fingerprint() -> str:
    """16 hex digits of the SHA-256 of warpsph's Python sources (paths and contents): a record measured
    by other code is not this code's measurement."""
    root = Path(__file__).resolve().parent.parent
    digest = hashlib.sha256()
    for path in sorted(root.rglob("*.py")):
        digest.update(path.relative_to(root).as_posix().encode() + b"\0" + path.read_bytes())
    return digest.hexdigest()[:16]


def run_id(scene: Scene, metric: str, device: str) -> str:
    """16 hex digits of the SHA-256 of the scene's settings (name and source text aside), the metric,
    the device and the code (:func:`code_fingerprint`): equal scenes share a record however their
    overrides were written, and a change to the code measures afresh."""
    settings = dataclasses.asdict(scene)
    del settings["name"], settings["source_text"]
    text = json.dumps({"scene": settings, "metric": metric, "device": device, "code": code_fingerprint()},
                      sort_keys=True, default=str)  # fmt: skip
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def scene_setting(scene: Scene, key: str):
    """The value at dotted ``key`` of ``scene`` (entries of lists by name), as JSON-ready data."""
    node = scene
    for part in key.split("."):
        if isinstance(node, dict):
            node = node[part]
        elif isinstance(node, list):
            node = next(entry for entry in node if entry.name == part)
        else:
            node = getattr(node, part)
    if dataclasses.is_dataclass(node):
        return dataclasses.asdict(node)
    return list(node) if isinstance(node, tuple) else node


def load_study(path: str | Path) -> Study:
    """Read and check the study file ``path``; every problem raises :class:`SceneError` naming its key."""
    path = Path(path)
    try:
        document = tomllib.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError) as exc:
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
        raise SceneError("", f"cannot read study file {path}: {reason}") from None
    except tomllib.TOMLDecodeError as exc:
        raise SceneError("", f"TOML syntax error: {' '.join(str(exc).split())}") from None
    for key in document:
        if key not in SECTIONS:
            raise SceneError(key, f"unknown section; accepted: {', '.join(SECTIONS)}")
    head = _table(document, "study", required=True)
    for key in head:
        if key not in STUDY_KEYS:
            raise SceneError(f"study.{key}", f"unknown key; accepted: {', '.join(STUDY_KEYS)}")
    scene_path = path.parent / _string(head, "scene", required=True)
    try:
        scene_text = scene_path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
        raise SceneError("study.scene", f"cannot read scene file {scene_path}: {reason}") from None
    metric = _metric(_string(head, "metric", required=True))
    error = _string(head, "error") or metric.default_error
    if error not in metric.errors:
        accepted = ", ".join(metric.errors)
        raise SceneError("study.error", f"must be one of {accepted} (metric {metric.name}), got {show(error)}")
    cost = _string(head, "cost") or "wall_seconds"
    if cost not in COSTS:
        raise SceneError("study.cost", f"must be one of {', '.join(COSTS)}, got {show(cost)}")
    sweeps = [("axes", _axes("axes", _table(document, "axes")))] if "axes" in document else []
    listed = document.get("sweeps", [])
    if not isinstance(listed, list):
        raise SceneError("sweeps", f"expected an array of tables [[sweeps]], got {show(listed)}")
    sweeps += [(f"sweeps[{i}]", _axes(f"sweeps[{i}]", table)) for i, table in enumerate(listed)]
    if not sweeps or not all(sweep for _, sweep in sweeps):
        raise SceneError("axes", "nothing to sweep: give [axes] (or [[sweeps]]) with a dotted scene key and a list "
                                 "of values")
    study = Study(name=_string(head, "name") or path.stem, path=path, scene_path=scene_path, scene_text=scene_text,
                  metric=metric, error=error, cost=cost, description=_string(head, "description") or "",
                  fixed=_flatten(_table(document, "fixed")), sweeps=sweeps)  # fmt: skip
    try:
        study.scene({})
    except SceneError as e:
        raise SceneError("study.scene", f"{scene_path}: {e}") from None
    return study


def _metric(name: str) -> Metric:
    if name in PLANNED_METRICS:
        raise SceneError("study.metric", f"{name}: {PLANNED_METRICS[name]}")
    if name not in METRICS:
        raise SceneError("study.metric", f"unknown metric {show(name)}; accepted: {', '.join(sorted(METRICS))}")
    return METRICS[name]


def _table(document: dict, key: str, required: bool = False) -> dict:
    if key not in document:
        if required:
            raise SceneError(key, f"missing table [{key}]")
        return {}
    if not isinstance(document[key], dict):
        raise SceneError(key, f"expected a table [{key}], got {show(document[key])}")
    return document[key]


def _string(table: dict, key: str, required: bool = False) -> str | None:
    if key not in table:
        if required:
            raise SceneError(f"study.{key}", "missing key")
        return None
    if not isinstance(table[key], str) or not table[key]:
        raise SceneError(f"study.{key}", f"expected a non-empty string, got {show(table[key])}")
    return table[key]


def _flatten(table: dict, path: str = "") -> dict:
    """{dotted key: value} of a table written with quoted or TOML dotted keys (tables merge key by key)."""
    flat = {}
    for key, value in table.items():
        dotted = f"{path}.{key}" if path else key
        if isinstance(value, dict):
            flat.update(_flatten(value, dotted))
        else:
            flat[dotted] = value
    return flat


def _axes(prefix: str, table) -> dict:
    """{dotted key: [values]} of one sweep; each value list non-empty."""
    if not isinstance(table, dict):
        raise SceneError(prefix, f"expected a table, got {show(table)}")
    axes = _flatten(table)
    for key, values in axes.items():
        if not isinstance(values, list) or not values:
            raise SceneError(f"{prefix}.{key}", f"expected a non-empty list of values to sweep, got {show(values)}")
    return axes
