"""XDMF 3 index over a results file, so ParaView/VisIt can open ``results.xdmf`` directly.

Only shapes and attributes are read (no particle data), the XML of frames seen before is reused,
and the file is replaced atomically, so rewriting it after every frame is cheap and a kill never
leaves half a file.
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from pathlib import Path

import h5py

from .results import _frames, _open

# Attribute type by trailing shape. Tensor6 data stays in our Voigt order (xx,yy,zz,yz,xz,xy);
# docs/output.md says how ParaView labels its components.
_ATTRIBUTE_TYPES = {(): "Scalar", (3,): "Vector", (6,): "Tensor6", (9,): "Tensor"}
_NUMBER_TYPES = {"f": "Float", "i": "Int", "u": "UInt"}


def _data_item(parent: ET.Element, ref: str, ds: h5py.Dataset) -> None:
    item = ET.SubElement(parent, "DataItem", Format="HDF", NumberType=_NUMBER_TYPES[ds.dtype.kind],
                         Precision=str(ds.dtype.itemsize), Dimensions=" ".join(map(str, ds.shape)))
    item.text = f"{ref}:{ds.name}"


def _grid(frame: h5py.Group, vertex: h5py.Dataset | None, ref: str) -> str:
    """XML of one frame's Polyvertex grid ("" when the frame has no ``position``)."""
    if "position" not in frame:
        return ""
    n = frame["position"].shape[0]
    grid = ET.Element("Grid", Name=f"frame_{frame.name.rsplit('/', 1)[1]}", GridType="Uniform")
    ET.SubElement(grid, "Time", Value=repr(float(frame.attrs["time"])))
    topology = ET.SubElement(grid, "Topology", TopologyType="Polyvertex",
                             NumberOfElements=str(n), NodesPerElement="1")
    if vertex is not None and vertex.shape == (n,):
        _data_item(topology, ref, vertex)
    _data_item(ET.SubElement(grid, "Geometry", GeometryType="XYZ"), ref, frame["position"])
    for key, ds in frame.items():
        kind = _ATTRIBUTE_TYPES.get(ds.shape[1:]) if ds.shape[:1] == (n,) else None
        if key == "position" or kind is None or ds.dtype.kind not in _NUMBER_TYPES:
            continue
        _data_item(ET.SubElement(grid, "Attribute", Name=key, AttributeType=kind, Center="Node"), ref, ds)
    ET.indent(grid, space="  ", level=3)
    return "      " + ET.tostring(grid, encoding="unicode").rstrip() + "\n"


# Frames never change once complete, so their XML is kept per (results file, xdmf file) and only
# reused while the file's ``created`` stamp and the frame's step and time still match.
_cache: dict[tuple[str, str], dict[str, tuple[tuple, str]]] = {}


def write_xdmf(h5_path, xdmf_path=None) -> Path:
    """Write the XDMF file for ``h5_path`` (default: same stem, ``.xdmf``) and return its path.

    One Polyvertex grid per frame in a temporal collection; geometry from ``position``, one
    attribute per other dataset with shape (N,), (N,3), (N,6) or (N,9) and a numeric dtype.
    """
    h5_path = Path(h5_path)
    xdmf_path = Path(xdmf_path) if xdmf_path is not None else h5_path.with_suffix(".xdmf")
    ref = Path(os.path.relpath(h5_path.resolve(), xdmf_path.resolve().parent)).as_posix()
    key = (str(h5_path.resolve()), str(xdmf_path.resolve()))
    old, new = _cache.get(key, {}), {}
    with _open(h5_path, "r") as f:
        vertex, created = f.get("particles/vertex"), f.attrs.get("created")
        for name in _frames(f):
            frame = f["frames"][name]
            stamp = (created, frame.attrs["step"], frame.attrs["time"])
            cached = old.get(name)
            new[name] = cached if cached and cached[0] == stamp else (stamp, _grid(frame, vertex, ref))
    _cache[key] = new

    tmp = xdmf_path.with_name(f".{xdmf_path.name}.tmp")
    with open(tmp, "w", encoding="utf-8") as out:
        out.write('<?xml version="1.0" encoding="utf-8"?>\n<Xdmf Version="3.0">\n  <Domain>\n'
                  '    <Grid Name="particles" GridType="Collection" CollectionType="Temporal">\n')
        out.writelines(xml for _, xml in new.values())
        out.write("    </Grid>\n  </Domain>\n</Xdmf>\n")
    os.replace(tmp, xdmf_path)
    return xdmf_path
