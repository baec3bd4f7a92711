"""Particle results in one HDF5 file (``results.h5``); layout in docs/output.md.

The file is opened, written and closed in every :meth:`ResultsWriter.write_frame`, so a run
killed between frames leaves a valid file. File locking is switched off on both sides, so a
viewer or :func:`load_results` holding the file open can never make a live run fail.
"""

from __future__ import annotations

import datetime
from pathlib import Path

import h5py
import numpy as np

FORMAT = "warpsph-results"
FORMAT_VERSION = 1
TRIAL_COLUMNS = 7
"""A safety trial's row in ``/phases/trials/<name>``: factor, outcome, ratio, steps, displacement, kinetic
energy, why."""
LIMIT_EQUILIBRIUM_COLUMNS = 6
"""A safety phase's row in ``/phases/limit_equilibrium``: Bishop's factor, Spencer's, the critical circle's
centre x, y and radius, Bishop's with the arcs kept above the rows of particles that do not shear."""
_SERIES_COLUMNS = {"step": np.int64, "time": np.float64, "value": np.float64}


def _open(path, mode: str) -> h5py.File:
    return h5py.File(path, mode, locking=False)


def _frames(f: h5py.File) -> list[str]:
    """Names of the complete frames (those carrying the ``step`` attribute, written last), in order."""
    if "frames" not in f:
        return []
    return sorted((k for k in f["frames"] if "step" in f["frames"][k].attrs), key=int)


def _plain(value):
    """HDF5 attribute value -> plain Python (str, int, float, list)."""
    if isinstance(value, bytes):
        return value.decode()
    if isinstance(value, np.ndarray):
        return value.tolist()
    return value.item() if isinstance(value, np.generic) else value


class ResultsWriter:
    """Writes frames (particle fields) and time series (scalars) to ``path``.

    ``resume_step`` reopens an existing file and drops everything written after that step
    (frames and series samples with ``step > resume_step``, and any incomplete frame), so a run
    resumed from a checkpoint continues exactly where the checkpoint was taken; the file's ``scene``
    becomes the resumed scene's text and ``resumed_at`` lists the steps runs were resumed from. A
    missing file is created fresh.
    """

    def __init__(self, path, *, dim: int, scene_text: str, particle_ids: np.ndarray,
                 warpsph_version: str, resume_step: int | None = None):
        self.path = Path(path)
        self._series: dict[str, list[tuple[int, float, float]]] = {}
        self._closed = False
        self._next_frame = 0
        if resume_step is not None and self.path.exists():
            self._truncate(int(resume_step), dim)
            with _open(self.path, "r+") as f:
                f.attrs["scene"] = scene_text
                f.attrs["resumed_at"] = np.append(f.attrs.get("resumed_at", np.zeros(0, np.int64)), int(resume_step))
            return
        self.path.parent.mkdir(parents=True, exist_ok=True)
        ids = np.asarray(particle_ids, dtype=np.int64)
        with _open(self.path, "w") as f:
            f.attrs.update(format=FORMAT, format_version=FORMAT_VERSION, dim=int(dim),
                           warpsph_version=warpsph_version, scene=scene_text,
                           created=datetime.datetime.now(datetime.timezone.utc).isoformat())
            f.create_dataset("particles/id", data=ids)
            # 0..N-1: the Polyvertex connectivity that write_xdmf points at.
            f.create_dataset("particles/vertex", data=np.arange(ids.size, dtype=np.int64))
            f.create_group("frames")
            f.create_group("series")

    def _truncate(self, resume_step: int, dim: int) -> None:
        with _open(self.path, "r+") as f:
            if f.attrs.get("format") != FORMAT:
                raise ValueError(f"{self.path} is not a warpsph results file")
            if int(f.attrs["dim"]) != int(dim):
                raise ValueError(f"{self.path} holds a {int(f.attrs['dim'])}D run, cannot resume a {dim}D run")
            frames = f.require_group("frames")
            for name in list(frames):
                step = frames[name].attrs.get("step")
                if step is None or step > resume_step:
                    del frames[name]
            self._next_frame = max((int(k) for k in frames), default=-1) + 1
            for group in f.require_group("series").values():
                keep = group["step"][()] <= resume_step
                if not keep.all():
                    for column in _SERIES_COLUMNS:
                        data = group[column][()][keep]
                        group[column].resize((data.size,))
                        group[column][...] = data

    def write_frame(self, step: int, time: float, fields: dict[str, np.ndarray], **attrs) -> str:
        """Append frame ``/frames/NNNNNN`` (time [s], step and the scalar ``attrs``, e.g. its phase) with
        one dataset per field, then flush the buffered series; return the frame's name ``NNNNNN``.
        The file is closed again before returning."""
        self._check_open()
        name = f"{self._next_frame:06d}"
        with _open(self.path, "r+") as f:
            group = f["frames"].create_group(name)
            for field_name, data in fields.items():
                group.create_dataset(field_name, data=np.asarray(data))
            group.attrs.update(attrs)
            group.attrs["time"] = float(time)
            group.attrs["step"] = int(step)  # written last: marks the frame complete
            self._flush_series(f)
        self._next_frame += 1
        return name

    def write_phases(self, records: list[dict]) -> None:
        """Replace ``/phases``: one row per phase, columns ``name``, ``kind``, ``outcome`` (strings),
        ``first_step``, ``last_step`` (int64), ``start_time``, ``end_time``, ``criterion``, ``resolution``,
        ``failing_mass`` (float64), ``limit_equilibrium`` (P,6), ``refined`` (P,2), and a safety phase's trials as
        ``/phases/trials/<name>``, (T,7) float64 rows (docs/output.md)."""
        self._check_open()
        with _open(self.path, "r+") as f:
            if "phases" in f:
                del f["phases"]
            group = f.create_group("phases")
            text = h5py.string_dtype()
            for column in ("name", "kind", "outcome"):
                group.create_dataset(column, data=np.array([r[column] for r in records], dtype=object), dtype=text)
            for column in ("first_step", "last_step"):
                group.create_dataset(column, data=np.array([r[column] for r in records], dtype=np.int64))
            for column in ("start_time", "end_time", "criterion", "resolution", "failing_mass"):
                group.create_dataset(column, data=np.array([r[column] for r in records], dtype=np.float64))
            width = LIMIT_EQUILIBRIUM_COLUMNS  # nan where none (other kinds) and in columns an older record lacks
            rows = [[*r["limit_equilibrium"], *[np.nan] * (width - len(r["limit_equilibrium"]))] for r in records]
            group.create_dataset("limit_equilibrium", data=np.array(rows, dtype=np.float64).reshape(-1, width))
            rows = [r.get("refined") or [np.nan] * 2 for r in records]
            group.create_dataset("refined", data=np.array(rows, dtype=np.float64).reshape(-1, 2))
            trials = group.create_group("trials")
            for r in records:
                if r.get("trials"):
                    rows = np.array(r["trials"], dtype=np.float64).reshape(-1, TRIAL_COLUMNS)
                    trials.create_dataset(r["name"], data=rows)

    def append_series(self, name: str, step: int, time: float, value: float) -> None:
        """Buffer one sample of scalar series ``name`` (time [s]); written at the next frame or close()."""
        self._check_open()
        self._series.setdefault(name, []).append((int(step), float(time), float(value)))

    def _flush_series(self, f: h5py.File) -> None:
        for name, rows in self._series.items():
            if not rows:
                continue
            group = f["series"].require_group(name)
            for column, (key, dtype) in enumerate(_SERIES_COLUMNS.items()):
                values = np.array([row[column] for row in rows], dtype=dtype)
                if key not in group:
                    group.create_dataset(key, shape=(0,), maxshape=(None,), dtype=dtype, chunks=(1024,))
                ds = group[key]
                ds.resize((ds.shape[0] + values.size,))
                ds[-values.size:] = values
            rows.clear()

    def close(self) -> None:
        """Write the buffered series; further writes raise."""
        if self._closed:
            return
        if any(self._series.values()):
            with _open(self.path, "r+") as f:
                self._flush_series(f)
        self._closed = True

    def _check_open(self) -> None:
        if self._closed:
            raise RuntimeError(f"ResultsWriter for {self.path} is closed")

    def __enter__(self) -> ResultsWriter:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


class Results:
    """Read-only view of a results file. Every access reopens the file, so the file of a live
    run can be inspected (a read that races a frame being written may fail; retry it)."""

    def __init__(self, path):
        self.path = Path(path)
        with self._open() as f:
            if f.attrs.get("format") != FORMAT:
                raise ValueError(f"{self.path} is not a warpsph results file")

    def _open(self) -> h5py.File:
        return _open(self.path, "r")

    @property
    def attrs(self) -> dict:
        """Root attributes (format, format_version, dim, warpsph_version, scene, created)."""
        with self._open() as f:
            return {k: _plain(v) for k, v in f.attrs.items()}

    @property
    def dim(self) -> int:
        return int(self.attrs["dim"])

    @property
    def scene_text(self) -> str:
        return self.attrs["scene"]

    @property
    def particle_ids(self) -> np.ndarray:
        with self._open() as f:
            return f["particles/id"][()]

    def _frame_attr(self, key: str, dtype) -> np.ndarray:
        with self._open() as f:
            return np.array([f["frames"][k].attrs[key] for k in _frames(f)], dtype=dtype)

    @property
    def times(self) -> np.ndarray:
        """Frame times [s], shape (F,)."""
        return self._frame_attr("time", np.float64)

    @property
    def steps(self) -> np.ndarray:
        """Frame step numbers, shape (F,)."""
        return self._frame_attr("step", np.int64)

    def __len__(self) -> int:
        with self._open() as f:
            return len(_frames(f))

    def frame(self, i: int) -> dict[str, np.ndarray]:
        """All datasets of frame ``i`` (negative counts from the end)."""
        with self._open() as f:
            group = f["frames"][_frames(f)[i]]
            return {k: group[k][()] for k in group}

    def frame_attrs(self, i: int) -> dict:
        """The attributes of frame ``i``: time, step, phase and, for a safety trial's frame, factor and
        converged."""
        with self._open() as f:
            return {k: _plain(v) for k, v in f["frames"][_frames(f)[i]].attrs.items()}

    def field(self, name: str) -> np.ndarray:
        """Field ``name`` stacked over all frames, shape (F, N, ...)."""
        with self._open() as f:
            return np.stack([f["frames"][k][name][()] for k in _frames(f)])

    @property
    def phases(self) -> list[dict]:
        """The phases run, in order: dicts with name, kind, outcome, first_step, last_step, start_time,
        end_time, criterion, resolution, failing_mass, limit_equilibrium (6,), refined (2,) and trials (a safety phase's
        (T,7) array, docs/output.md; (0,7) for other kinds); [] for a run without phases."""
        with self._open() as f:
            if "phases" not in f:
                return []
            g = f["phases"]
            trials = g["trials"] if "trials" in g else {}
            rows = [{k: _plain(g[k][i]) if g[k].ndim == 1 else g[k][i] for k in g if k != "trials"}
                    for i in range(len(g["name"]))]  # fmt: skip
            for row in rows:
                row["trials"] = trials[row["name"]][()] if row["name"] in trials else np.zeros((0, TRIAL_COLUMNS))
            return rows

    @property
    def frame_phases(self) -> np.ndarray:
        """The phase index of each frame, shape (F,) (0 for a run without phases)."""
        with self._open() as f:
            return np.array([f["frames"][k].attrs.get("phase", 0) for k in _frames(f)], dtype=np.int64)

    @property
    def series_names(self) -> list[str]:
        with self._open() as f:
            return sorted(f["series"]) if "series" in f else []

    def series(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        """Series ``name`` as (time [s], value)."""
        with self._open() as f:
            group = f["series"][name]
            return group["time"][()], group["value"][()]

    def __repr__(self) -> str:
        return f"Results({str(self.path)!r}, frames={len(self)})"


def load_results(path) -> Results:
    """Open a results file written by :class:`ResultsWriter` for reading."""
    return Results(path)
