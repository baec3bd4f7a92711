"""Restart checkpoints: one HDF5 file holding arrays bit-exactly plus step, time and metadata."""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

import h5py
import numpy as np

FORMAT = "warpsph-checkpoint"
FORMAT_VERSION = 1


@dataclass
class Checkpoint:
    """A loaded checkpoint: ``time`` in s; ``arrays`` with the dtypes and shapes they were saved with."""

    step: int
    time: float
    arrays: dict[str, np.ndarray] = field(default_factory=dict)
    meta: dict[str, str | int | float] = field(default_factory=dict)


def _fsync(path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def save_checkpoint(path, *, step: int, time: float, arrays: dict[str, np.ndarray],
                    meta: dict[str, str | int | float]) -> None:
    """Write the checkpoint atomically: ``PATH.tmp``, fsync, rename over ``path``, so a kill at
    any moment leaves either the previous checkpoint or the new one, never a mix.

    Array names must not contain ``/``; ``meta`` values are stored as HDF5 attributes.
    """
    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    try:
        with h5py.File(tmp, "w", locking=False) as f:
            f.attrs.update(format=FORMAT, format_version=FORMAT_VERSION, step=int(step), time=float(time))
            group = f.create_group("arrays")
            for name, data in arrays.items():
                group.create_dataset(name, data=np.asarray(data))
            f.create_group("meta").attrs.update(meta)
        _fsync(tmp)
        os.replace(tmp, path)
    finally:  # a write that failed (a full disk) leaves the previous checkpoint and no temporary file
        tmp.unlink(missing_ok=True)
    if os.name == "posix":  # make the rename itself durable
        _fsync(path.parent)


def load_checkpoint(path) -> Checkpoint:
    """Read a checkpoint; FileNotFoundError if missing, ValueError if not a warpsph checkpoint."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"checkpoint {path} does not exist")
    try:
        f = h5py.File(path, "r", locking=False)
    except OSError as e:
        raise ValueError(f"{path} is not a warpsph checkpoint (not an HDF5 file)") from e
    with f:
        if f.attrs.get("format") != FORMAT:
            raise ValueError(f"{path} is not a warpsph checkpoint (root attribute format != {FORMAT!r})")
        meta = {k: v.item() if isinstance(v, np.generic) else v for k, v in f["meta"].attrs.items()}
        return Checkpoint(step=int(f.attrs["step"]), time=float(f.attrs["time"]),
                          arrays={k: ds[()] for k, ds in f["arrays"].items()}, meta=meta)
