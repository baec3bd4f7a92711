"""What a run writes besides its results' frames: a frame's content, the run record (``run.json``), the
check that the disk has room for a write, the short reason of an I/O error (docs/output.md)."""

from __future__ import annotations

import json
import os
import platform
import re
import shutil
from dataclasses import asdict
from pathlib import Path
from typing import NamedTuple

import numpy as np
import warp as wp

from warpsph.errors import OutputError
from warpsph.fields import tensor_to_voigt
from warpsph.model import Model, State, host_fields
from warpsph.version import __version__

OUTPUT_RESERVE = 1 << 20
"""Bytes a frame or checkpoint write leaves free on the disk beyond twice its arrays [B]."""


class FrameContent(NamedTuple):
    """A frame's content: the host fields (:func:`host_fields`), the arrays written, and the energy
    balance to write as series with it (a safety trial's, at its last state; else None)."""

    fields: dict
    frame: dict
    balance: dict | None



def frame_content(model: Model, state: State, origin: np.ndarray, wanted, staged: bool, projection,
                  flow) -> FrameContent:  # fmt: skip
    """What a frame of ``state`` holds: the host fields and the frame's arrays, those in ``wanted``
    (``output.fields``) and those of the effects (pore pressure, plastic strain, a flow's saturation);
    ``origin``: the positions displacements are measured from; ``staged``: with the particles' ids."""
    fields = host_fields(model, state)
    frame = {"position": fields["position"]}
    if staged:
        frame["id"] = model.particle_ids
    if "velocity" in wanted:
        frame["velocity"] = fields["velocity"]
    if "displacement" in wanted:
        frame["displacement"] = fields["position"] - origin
    if "stress" in wanted:
        frame["stress"] = tensor_to_voigt(fields["stress"])
    if "pore_pressure" in fields:
        frame["pore_pressure"] = fields["pore_pressure"]
    if "plastic_strain" in fields:
        frame["plastic_strain"] = fields["plastic_strain"]
    if "darcy_velocity" in wanted:
        frame["darcy_velocity"] = projection.darcy_velocity(state)
    if flow is not None:
        frame["saturation"] = flow.saturation_field()
    return FrameContent(fields, frame, None)


def run_record(scene, model: Model, projection, summary, status: str, message: str, end_time: float,
               resumed: bool) -> dict:  # fmt: skip
    """The run record (``run.json``, docs/output.md): the scene, how the run ended, versions, the
    model's settings, the ``summary`` (a :class:`~warpsph.runner.RunSummary`) and the pressure solves."""
    record = {
        "scene": scene.name,
        "status": status,
        "message": message,
        "warpsph_version": __version__,
        "warp_version": wp.config.version,
        "python": platform.python_version(),
        "device": str(model.device),
        "precision": model.spec.precision,
        "scheme": model.spec.scheme,
        "integrator": model.spec.integrator,
        "kernel": model.spec.kernel,
        "dim": model.spec.dim,
        "end_time": end_time,
        "resumed": resumed,
        **asdict(summary),
        "particle_steps_per_second": summary.particle_steps_per_second,
    }
    if projection is not None and projection.iterations:
        its = np.asarray(projection.iterations)
        record["pressure_solve"] = {
            "solver": scene.pressure.solver, "tolerance": scene.pressure.tolerance,
            "iterations_total": int(its.sum()), "iterations_mean": float(its.mean()),
            "iterations_max": int(its.max()), "residual_max": float(np.max(projection.residuals)),
            "missed_tolerance": projection.failures, "free_surface_warning": projection.surface_warning,
        }  # fmt: skip
    return record


def write_record(path: Path, record: dict) -> None:
    """Write the run record to ``path`` whole or not at all (a temporary file renamed over it)."""
    tmp = path.with_name(path.name + ".tmp")
    try:
        tmp.write_text(json.dumps(record, indent=2, default=str))
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def room_for(out: Path, arrays: dict, kept: str) -> None:
    """Stop with :class:`OutputError` before a write of ``arrays`` that the disk of ``out`` has no room
    for: HDF5 cut off by a full disk leaves its files and its own state broken (the process can crash
    on exit); ``kept``: what of the run is kept, for the message."""
    need = 2 * sum(np.asarray(a).nbytes for a in arrays.values()) + OUTPUT_RESERVE
    free = shutil.disk_usage(out).free
    if free < need:
        raise OutputError(f"cannot write the run's output in {out}: {free / 1e6:.3g} MB left on its disk, "
                          f"the next write needs {need / 1e6:.3g} MB; {kept}")  # fmt: skip


def os_reason(error: OSError) -> str:
    """The short reason of an I/O error ("No space left on device"), not HDF5's page of detail."""
    if error.strerror:
        return error.strerror
    found = re.search(r"error message = '([^']+)'", str(error))
    if found:
        return found.group(1)
    return str(error).splitlines()[0][:200] if str(error) else type(error).__name__
