"""The run directory: one run writes into it at a time, and an earlier run's output is replaced only
when asked (docs/output.md, *The run directory*).

A run holds an exclusive lock on ``.warpsph.lock`` in the directory while it writes (``fcntl.flock``:
the system drops it when the process ends, however it ends, so a killed run leaves no stale lock; a
run that ends removes the file).
A new run into a directory that holds output refuses unless ``overwrite`` (then the output goes
first) or ``resume``.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

from warpsph.errors import InputError, OutputError

LOCK = ".warpsph.lock"
RESULTS, CHECKPOINT, RECORD = "results.h5", "checkpoint.h5", "run.json"
OUTPUT_FILES = (RESULTS, "results.xdmf", CHECKPOINT, f"{CHECKPOINT}.tmp", RECORD, "particles.usdc")
OUTPUT_FOLDERS = ("particles_clips",)
"""What a run writes into its directory (docs/output.md), and so what ``overwrite`` removes."""


class RunDirectory:
    """Claims ``path`` for one run (see module docstring); :meth:`release` (or the process's end)
    frees it. Raises :class:`InputError` when the path is a file, another run holds it, or it holds
    output that neither ``resume`` nor ``overwrite`` allows to touch, and :class:`OutputError` when it
    cannot be created or written."""

    def __init__(self, path, *, resume: bool = False, overwrite: bool = False):
        self.path = Path(path)
        if self.path.exists() and not self.path.is_dir():
            raise InputError(f"--out {self.path}: is a file, not a directory")
        try:
            self.path.mkdir(parents=True, exist_ok=True)
            self._file = open(self.path / LOCK, "a+")
        except OSError as e:
            raise OutputError(f"--out {self.path}: cannot write there ({e.strerror or e})") from None
        try:
            import fcntl
        except ImportError:  # no flock (Windows): runs are not kept apart
            fcntl = None
        if fcntl is not None:
            try:
                fcntl.flock(self._file, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError:
                self._file.seek(0)
                holder = self._file.read().strip() or "another process"
                self._file.close()
                raise InputError(f"--out {self.path}: another run ({holder}) is writing into it") from None
        self._file.seek(0)
        self._file.truncate()
        self._file.write(f"process {os.getpid()}")
        self._file.flush()
        if not resume:
            earlier = [n for n in OUTPUT_FILES + OUTPUT_FOLDERS if (self.path / n).exists()]
            if earlier and not overwrite:
                self.release()
                raise InputError(f"--out {self.path}: holds an earlier run's {', '.join(earlier)}; pass --overwrite "
                                 "to replace it, or --resume to continue it")  # fmt: skip
            for name in earlier:
                target = self.path / name
                shutil.rmtree(target) if target.is_dir() else target.unlink()

    def release(self) -> None:
        """Free the directory for the next run: the lock file goes, then its lock."""
        if not self._file.closed:
            (self.path / LOCK).unlink(missing_ok=True)
            self._file.close()  # closing drops the flock


RESUMABLE = ("source_text", "output", "simulation.end_time")
"""What a resumed scene may change: how it was written down, its output, and (without phases) how
far it runs."""


def scene_record(scene) -> dict:
    """The scene's settings a resumed run must keep (everything but :data:`RESUMABLE`), as JSON data."""
    import dataclasses
    import json

    record = dataclasses.asdict(scene)
    for key in RESUMABLE:
        *parents, last = key.split(".")
        node = record
        for part in parents:
            node = node[part]
        node.pop(last, None)
    return json.loads(json.dumps(record, default=str))


def first_difference(before, now, path: str = "") -> str | None:
    """The key path of the first setting in which two :func:`scene_record` values differ (None if
    none does)."""
    if isinstance(before, dict) and isinstance(now, dict):
        for key in sorted(set(before) | set(now)):
            where = f"{path}.{key}" if path else str(key)
            if key not in before or key not in now:
                return where
            found = first_difference(before[key], now[key], where)
            if found is not None:
                return found
        return None
    tables = isinstance(before, list) and any(isinstance(item, dict) for item in before)
    if tables and isinstance(now, list) and len(before) == len(now):  # bodies, loads, phases: by item
        for i, (a, b) in enumerate(zip(before, now)):
            found = first_difference(a, b, f"{path}[{i}]")
            if found is not None:
                return found
        return None
    return None if before == now else (path or "scene")
