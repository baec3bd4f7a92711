"""A run's frames as VTK files any mesh library reads: one ``.vtu`` per frame and a ``.pvd`` collection
of them at the frames' times (``warpsph export RUN``; docs/output.md, *Other readers*). Needs meshio."""

from __future__ import annotations

import importlib.util
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

from .results import load_results
from .xdmf import VOIGT, listed_time

COLLECTION = "results.pvd"


def export_vtu(run_dir, out_dir=None) -> Path:
    """Write every frame of the run in ``run_dir`` as ``out_dir``/frame_NNNNNN.vtu (default out_dir:
    ``run_dir``/vtu), particles as vertex cells with the frame's fields as point data ((N,6) stresses as
    one scalar per component, ``NAME_xx`` ... ``NAME_xy``, as in results.xdmf), and the collection
    ``results.pvd`` listing them at the frames' times (distinct, as :func:`~warpsph.io.xdmf.listed_time`);
    return the collection's path. FileNotFoundError without a results file; ImportError without meshio."""
    if importlib.util.find_spec("meshio") is None:
        raise ImportError("exporting needs meshio: pip install 'warpsph[export]'")
    import meshio

    run_dir = Path(run_dir)
    if not (run_dir / "results.h5").is_file():
        raise FileNotFoundError(f"{run_dir} holds no results.h5")
    results = load_results(run_dir / "results.h5")
    out = Path(out_dir) if out_dir is not None else run_dir / "vtu"
    out.mkdir(parents=True, exist_ok=True)
    entries, listed = [], None
    for k, time in enumerate(results.times):
        frame = results.frame(k)
        points = frame.pop("position")
        data = {}
        for name, values in frame.items():
            if values.shape[1:] == (len(VOIGT),):
                data.update({f"{name}_{c}": values[:, i] for i, c in enumerate(VOIGT)})
            elif values.shape[:1] == points.shape[:1]:
                data[name] = values.reshape(len(points), -1) if values.ndim > 2 else values
        name = f"frame_{k:06d}.vtu"
        cells = [("vertex", np.arange(len(points), dtype=np.int64).reshape(-1, 1))]
        meshio.write(out / name, meshio.Mesh(points, cells, point_data=data), file_format="vtu")
        listed = listed_time(float(time), listed)
        entries.append(f'    <DataSet timestep="{listed!r}" part="0" file={quoteattr(name)}/>\n')
    collection = out / COLLECTION
    collection.write_text('<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">\n  <Collection>\n'
                          + "".join(entries) + "  </Collection>\n</VTKFile>\n")  # fmt: skip
    return collection
