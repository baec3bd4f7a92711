"""``warpsph export RUN``: a run's frames as .vtu files and a .pvd collection, read back by meshio and by
VTK's XML reader (docs/output.md, *Other readers*)."""

import xml.etree.ElementTree as ET

import numpy as np
import pytest

from warpsph.cli import main
from warpsph.io import load_results
from warpsph.io.xdmf import VOIGT
from warpsph.regression import cases, shortened
from warpsph.runner import Run


@pytest.fixture(scope="module")
def staged_run(tmp_path_factory):
    """The shipped slope cut short through K0, gravity and the first trials of its safety phase."""
    out = tmp_path_factory.mktemp("export") / "slope"
    scene = shortened(cases(["slope_fos"])["slope_fos"])
    scene.output.usd = False
    Run(scene, out, device="cpu").run()
    return out


def test_every_frame_reads_back_with_meshio_and_vtk(staged_run, capsys):
    meshio = pytest.importorskip("meshio")
    from vtkmodules.util.numpy_support import vtk_to_numpy
    from vtkmodules.vtkIOXML import vtkXMLUnstructuredGridReader

    assert main(["export", str(staged_run)]) == 0
    assert "results.pvd" in capsys.readouterr().out
    results = load_results(staged_run / "results.h5")
    entries = ET.parse(staged_run / "vtu" / "results.pvd").getroot().findall("./Collection/DataSet")
    times = [float(e.get("timestep")) for e in entries]
    assert len(entries) == len(results) > 3 and np.all(np.diff(times) > 0)  # trials' frames share a time
    np.testing.assert_allclose(times, results.times, atol=1e-8)
    for k, entry in enumerate(entries):
        frame = results.frame(k)
        mesh = meshio.read(staged_run / "vtu" / entry.get("file"))
        np.testing.assert_array_equal(mesh.points, frame["position"])
        assert len(mesh.cells_dict["vertex"]) == len(frame["position"])
        np.testing.assert_array_equal(mesh.point_data["id"], frame["id"])
        for i, component in enumerate(VOIGT):
            np.testing.assert_array_equal(mesh.point_data[f"stress_{component}"], frame["stress"][:, i])
        reader = vtkXMLUnstructuredGridReader()
        reader.SetFileName(str(staged_run / "vtu" / entry.get("file")))
        reader.Update()
        data = reader.GetOutput().GetPointData()
        np.testing.assert_array_equal(vtk_to_numpy(data.GetArray("plastic_strain")), frame["plastic_strain"])


def test_export_needs_a_run(tmp_path, capsys):
    assert main(["export", str(tmp_path)]) == 2
    assert "holds no results.h5" in capsys.readouterr().err
