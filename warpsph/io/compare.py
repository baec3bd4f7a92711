"""Two runs side by side: the largest difference per field of their output (``warpsph compare A B``).

Compares the results files, the checkpoints and the run records' outcomes of two run directories (or
of every run directory the two have in common under them), dataset by dataset; docs/output.md,
*Comparing runs*.
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import h5py
import numpy as np

FILES = ("results.h5", "checkpoint.h5")
RECORD = "run.json"
RECORD_KEYS = ("status", "steps", "final_step", "final_time", "time_step", "particles", "virtual_particles",
               "frames", "phases", "pressure_solve")  # fmt: skip
"""What a run record says about the run itself (its timings, versions and paths differ from run to run)."""
UNCOMPARED_ATTRS = {"created", "warpsph_version"}
"""Root attributes that record when and by what a file was written, not what it holds."""


@dataclass
class Comparison:
    """The largest difference per field of two runs: ``differences[field]`` is the largest absolute
    difference (0.0: identical, inf: only in one, another shape, or other text)."""

    differences: dict[str, float] = field(default_factory=dict)

    def add(self, name: str, difference: float) -> None:
        self.differences[name] = max(self.differences.get(name, 0.0), difference)

    @property
    def identical(self) -> bool:
        return not any(self.differences.values())

    def lines(self, every: bool = False) -> list[str]:
        """One line per field that differs (``every``: per field, the different ones first), then the verdict."""
        shown = [k for k in self.differences if every or self.differences[k]]
        width = max((len(k) for k in shown), default=0)
        order = sorted(shown, key=lambda k: (self.differences[k] == 0.0, k))
        rows = [f"{k:<{width}}  {_shown(self.differences[k])}" for k in order]
        differ = sum(1 for v in self.differences.values() if v)
        verdict = "identical" if not differ else f"{differ} of {len(self.differences)} fields differ"
        return rows + [verdict]


def _shown(difference: float) -> str:
    if difference == 0.0:
        return "0"
    return "differs (missing, shape or text)" if math.isinf(difference) else f"{difference:.3e}"


def compare_runs(a, b) -> Comparison:
    """The largest difference per field between run directories ``a`` and ``b``; where neither holds a
    results file, between each run directory directly under both (field names prefixed ``NAME/``).
    FileNotFoundError where there is nothing to compare."""
    a, b = Path(a), Path(b)
    for d in (a, b):
        if not d.is_dir():
            raise FileNotFoundError(f"{d} is not a directory")
    out = Comparison()
    if (a / FILES[0]).exists() or (b / FILES[0]).exists():
        _compare_run(a, b, "", out)
        return out
    names = sorted({p.parent.name for d in (a, b) for p in d.glob(f"*/{FILES[0]}")})
    if not names:
        raise FileNotFoundError(f"neither {a} nor {b} holds a run ({FILES[0]}), nor run directories with one")
    for name in names:
        _compare_run(a / name, b / name, f"{name}/", out)
    return out


def _compare_run(a: Path, b: Path, prefix: str, out: Comparison) -> None:
    if (a / FILES[0]).exists() != (b / FILES[0]).exists():  # a run on one side only
        out.add(prefix.rstrip("/") or FILES[0], math.inf)
        return
    for name in FILES:
        pa, pb = a / name, b / name
        if not (pa.exists() and pb.exists()):
            if pa.exists() or pb.exists():
                out.add(f"{prefix}{name}", math.inf)
            continue
        with h5py.File(pa, "r", locking=False) as fa, h5py.File(pb, "r", locking=False) as fb:
            _compare_group(fa, fb, f"{prefix}{name}:", out)
    ra, rb = _record(a / RECORD), _record(b / RECORD)
    for key in sorted(set(ra) | set(rb)):
        out.add(f"{prefix}{RECORD}:{key}", _difference(ra.get(key), rb.get(key)))


def _field(path: str) -> str:
    """A dataset's or attribute's field name: its path with frame names and phase names kept, numbers
    of frames dropped (``frames/000012/position`` → ``frames/position``)."""
    return re.sub(r"/\d+(?=/|@|$)", "", path)


def _compare_group(ga: h5py.Group, gb: h5py.Group, prefix: str, out: Comparison) -> None:
    for key in sorted(set(ga.attrs) | set(gb.attrs)):
        if ga.name == "/" and key in UNCOMPARED_ATTRS:
            continue
        out.add(_field(f"{prefix}{ga.name.rstrip('/')}@{key}"), _difference(_attr(ga, key), _attr(gb, key)))
    for key in sorted(set(ga) | set(gb)):
        name = _field(f"{prefix}{ga.name.rstrip('/')}/{key}")
        if key not in ga or key not in gb or type(ga[key]) is not type(gb[key]):
            out.add(name, math.inf)
        elif isinstance(ga[key], h5py.Group):
            _compare_group(ga[key], gb[key], prefix, out)
        else:
            out.add(name, _difference(ga[key][()], gb[key][()]))


def _attr(group: h5py.Group, key: str):
    return group.attrs[key] if key in group.attrs else None


def _record(path: Path) -> dict:
    """The run record's entries that describe the run (``RECORD_KEYS``), flattened to dotted keys."""
    if not path.exists():
        return {}
    record = json.loads(path.read_text())
    flat: dict = {}

    def walk(value, key: str) -> None:
        if isinstance(value, dict):
            for k, v in value.items():
                walk(v, f"{key}.{k}")
        elif isinstance(value, list) and any(isinstance(v, (dict, list)) for v in value):
            for i, v in enumerate(value):
                walk(v, f"{key}[{i}]")
        else:
            flat.setdefault(re.sub(r"\[\d+\]", "", key), []).append(value)

    for key in RECORD_KEYS:
        if key in record:
            walk(record[key], key)
    return flat


def _difference(x, y) -> float:
    """The largest absolute difference of two values (arrays, numbers, text; NaN equals NaN)."""
    if x is None or y is None:
        return 0.0 if x is None and y is None else math.inf
    if isinstance(x, bytes):
        x = x.decode()
    if isinstance(y, bytes):
        y = y.decode()
    try:
        xa, ya = np.asarray(x), np.asarray(y)
    except (ValueError, TypeError):
        return 0.0 if x == y else math.inf
    if xa.shape != ya.shape:
        return math.inf
    if xa.dtype.kind in "biuf" and ya.dtype.kind in "biuf":
        xa, ya = xa.astype(np.float64), ya.astype(np.float64)
        same = (xa == ya) | (np.isnan(xa) & np.isnan(ya))
        if same.all():
            return 0.0
        return float(np.max(np.abs(xa - ya)[~same]))  # inf where only one is finite
    return 0.0 if np.array_equal(xa, ya) else math.inf
