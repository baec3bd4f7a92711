"""XDMF 3 index over a results file, so ParaView/VisIt can open ``results.xdmf`` directly; an (N,6) dataset
becomes one Scalar attribute per component, since the readers disagree on ``Tensor6``'s order
(docs/output.md, *results.xdmf in ParaView*).
"""

from __future__ import annotations

import os
from pathlib import Path
from xml.sax.saxutils import escape, quoteattr

import h5py
import numpy as np

from .results import _open

# Attribute type by trailing shape; (N,6) datasets become one Scalar per component (see above).
_ATTRIBUTE_TYPES = {(): "Scalar", (3,): "Vector", (9,): "Tensor"}
VOIGT = ("xx", "yy", "zz", "yz", "xz", "xy")  # column order of every (N,6) dataset
_NUMBER_TYPES = {"f": "Float", "i": "Int", "u": "UInt"}
_INDENT = "  "
TIME_NUDGE = 1e-9
"""A frame whose time is not after the one listed before it (the last frame of a phase and the first
of the next share their time) is listed this fraction of that time (of 1 s, before 1 s) later, so that
readers list every frame, in order; results.h5 keeps the frames' own times."""


def listed_time(time: float, before: float | None) -> float:
    """The time a frame at ``time`` is listed at after a frame listed at ``before`` (None: the first)."""
    if before is None or time > before:
        return time
    return before + TIME_NUDGE * max(abs(before), 1.0)


def _data_item(ref: str, ds: h5py.Dataset, depth: int) -> str:
    """Plain HDF DataItem over the whole dataset ``ds``."""
    dtype = ds.dtype
    return (f'{_INDENT * depth}<DataItem Format="HDF" NumberType="{_NUMBER_TYPES[dtype.kind]}" '
            f'Precision="{dtype.itemsize}" Dimensions="{" ".join(map(str, ds.shape))}">'
            f'{escape(f"{ref}:{ds.name}")}</DataItem>\n')


def _columns(ref: str, ds: h5py.Dataset, depth: int) -> list[str]:
    """One HyperSlab DataItem per column of the (N,M) dataset ``ds``, each selecting that column as
    an (N,) array: its first child holds start (row, column), stride and count, its second is the
    whole dataset."""
    n, m, dtype, pad = *ds.shape, ds.dtype, _INDENT * depth
    whole = _data_item(ref, ds, depth + 1)
    head = (f'{pad}<DataItem ItemType="HyperSlab" Dimensions="{n}" NumberType="{_NUMBER_TYPES[dtype.kind]}" '
            f'Precision="{dtype.itemsize}">\n{pad}{_INDENT}<DataItem Dimensions="3 2" Format="XML">')
    return [f"{head}0 {column} 1 1 {n} 1</DataItem>\n{whole}{pad}</DataItem>\n" for column in range(m)]


def _attribute(name: str, kind: str, item: str) -> str:
    pad = _INDENT * 4
    return f'{pad}<Attribute Name={quoteattr(name)} AttributeType="{kind}" Center="Node">\n{item}{pad}</Attribute>\n'


def _grid(frame: h5py.Group, vertex: h5py.Dataset | None, ref: str, time: float) -> str:
    """XML of one frame's Polyvertex grid listed at ``time`` ("" when the frame has no ``position``)."""
    if "position" not in frame:
        return ""
    position = frame["position"]
    n = position.shape[0]
    pad = _INDENT * 3
    xml = [f'{pad}<Grid Name={quoteattr("frame_" + frame.name.rsplit("/", 1)[1])} GridType="Uniform">\n',
           f'{pad}{_INDENT}<Time Value="{float(time)!r}" />\n',
           f'{pad}{_INDENT}<Topology TopologyType="Polyvertex" NumberOfElements="{n}" NodesPerElement="1"']
    if vertex is not None and vertex.shape == (n,):
        xml.append(f'>\n{_data_item(ref, vertex, 5)}{pad}{_INDENT}</Topology>\n')
    else:
        xml.append(" />\n")
    xml.append(f'{pad}{_INDENT}<Geometry GeometryType="XYZ">\n{_data_item(ref, position, 5)}'
               f'{pad}{_INDENT}</Geometry>\n')
    for key, ds in frame.items():
        if key == "position" or not isinstance(ds, h5py.Dataset):
            continue
        shape = ds.shape
        if shape[:1] != (n,) or ds.dtype.kind not in _NUMBER_TYPES:
            continue
        if shape[1:] == (len(VOIGT),):
            xml.extend(_attribute(f"{key}_{component}", "Scalar", item)
                       for component, item in zip(VOIGT, _columns(ref, ds, 5)))
        elif (kind := _ATTRIBUTE_TYPES.get(shape[1:])) is not None:
            xml.append(_attribute(key, kind, _data_item(ref, ds, 5)))
    xml.append(f"{pad}</Grid>\n")
    return "".join(xml)


def _stamp(frames: h5py.Group, name: str, step: np.ndarray, time: np.ndarray) -> tuple[int, float] | None:
    """(step, time) of frame ``name``, or None while it is incomplete (no ``step`` attribute, which
    is written last; the rule of results._frames). Low-level reads: this runs for every frame on
    every call, and h5py's ``attrs`` costs twice as much."""
    group = h5py.h5g.open(frames.id, name.encode())
    try:
        h5py.h5a.open(group, b"step").read(step)
    except KeyError:
        return None
    h5py.h5a.open(group, b"time").read(time)
    return int(step), float(time)


_HEAD = ('<?xml version="1.0" encoding="utf-8"?>\n<Xdmf Version="3.0">\n  <Domain>\n'
         '    <Grid Name="particles" GridType="Collection" CollectionType="Temporal">\n')
_TAIL = "    </Grid>\n  </Domain>\n</Xdmf>\n"


def _paths(h5_path, xdmf_path) -> tuple[Path, Path, str]:
    h5_path = Path(h5_path)
    xdmf_path = Path(xdmf_path) if xdmf_path is not None else h5_path.with_suffix(".xdmf")
    ref = Path(os.path.relpath(h5_path.resolve(), xdmf_path.resolve().parent)).as_posix()
    return h5_path, xdmf_path, ref


def write_xdmf(h5_path, xdmf_path=None) -> Path:
    """Write the XDMF file for ``h5_path`` (default: same stem, ``.xdmf``) and return its path: whole, to a
    temporary file renamed over the old one, reading only shapes and attributes (no particle data).

    One Polyvertex grid per complete frame in a temporal collection, at distinct increasing times
    (:func:`listed_time`); geometry from ``position``, one attribute per other dataset with shape (N,),
    (N,3) or (N,9) and a numeric dtype, and one Scalar attribute ``NAME_xx`` ... ``NAME_xy`` per
    component of an (N,6) dataset.
    """
    return _write_xdmf(h5_path, xdmf_path)[0]


def _write_xdmf(h5_path, xdmf_path=None) -> tuple[Path, float | None]:
    """:func:`write_xdmf`, and the time its last frame is listed at (None: no frame)."""
    h5_path, xdmf_path, ref = _paths(h5_path, xdmf_path)
    grids, listed = [], None
    with _open(h5_path, "r") as f:
        vertex, frames = f.get("particles/vertex"), f.get("frames")
        step, time = np.empty((), np.int64), np.empty((), np.float64)
        for name in sorted(frames, key=int) if frames is not None else []:
            if _stamp(frames, name, step, time) is not None:
                listed = listed_time(float(time), listed)
                grids.append(_grid(frames[name], vertex, ref, listed))
    tmp = xdmf_path.with_name(f".{xdmf_path.name}.tmp")
    try:
        with open(tmp, "w", encoding="utf-8") as out:
            out.write(_HEAD)
            out.writelines(grids)
            out.write(_TAIL)
        os.replace(tmp, xdmf_path)
    finally:
        tmp.unlink(missing_ok=True)
    return xdmf_path, listed


class XdmfIndex:
    """The XDMF file of a results file being written: :func:`write_xdmf` at creation (the frames
    already there, e.g. of a resumed run), then :meth:`append` per new frame at a constant cost: the
    frame's grid and the closing tags go in one write over the old closing tags, so a killed process
    leaves the old or the new file, whole (docs/output.md, *Kill safety*)."""

    def __init__(self, h5_path, xdmf_path=None):
        self.h5_path, self.path, self._ref = _paths(h5_path, xdmf_path)
        self._listed = _write_xdmf(self.h5_path, self.path)[1]
        """The time the last frame is listed at."""
        self._end = self.path.stat().st_size - len(_TAIL.encode())
        """Byte offset of the closing tags, where the next frame's grid goes."""

    def append(self, frame: str) -> None:
        """Add frame ``frame`` (its group name under ``/frames``, complete) after the others."""
        if not hasattr(os, "pwrite"):  # no positioned write (Windows): the whole file again
            self._listed = _write_xdmf(self.h5_path, self.path)[1]
            return
        with _open(self.h5_path, "r") as f:
            group = f["frames"][frame]
            self._listed = listed_time(float(group.attrs["time"]), self._listed)
            grid = _grid(group, f.get("particles/vertex"), self._ref, self._listed).encode()
        fd = os.open(self.path, os.O_WRONLY)
        try:
            os.pwrite(fd, grid + _TAIL.encode(), self._end)  # one write: old file or new, whole
        finally:
            os.close(fd)
        self._end += len(grid)
