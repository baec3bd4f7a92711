"""results.xdmf as real readers see it: VTK's vtkXdmfReader (ParaView's "XDMF Reader") must show
each stress component under its own name with the values of results.h5, and the positions of every
frame; docs/output.md, *results.xdmf in ParaView*, says what each reader shows."""

import xml.etree.ElementTree as ET

import h5py
import numpy as np
import pytest

from warpsph.io import ResultsWriter, XdmfIndex, write_xdmf
from warpsph.io.xdmf import VOIGT

N = 9
STEPS = (0, 40, 80)


def fields(k: int) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(100 + k)
    return {
        "position": rng.random((N, 3)) + k,  # every frame elsewhere, so a reader stuck on frame 0 shows
        "velocity": rng.standard_normal((N, 3)),
        "stress": rng.standard_normal((N, 6)) * 1e4 + np.arange(6) * 1e5,  # columns told apart by size
        "pore_pressure": rng.random(N) * 1e3,
    }


@pytest.fixture
def run(tmp_path):
    """A results file of three frames with its XDMF, appended after each frame as the runner does,
    plus an incomplete fourth frame (no ``step`` attribute: a write cut short) that a whole rewrite
    (a resumed run's) must not show."""
    path = tmp_path / "results.h5"
    with ResultsWriter(path, dim=3, scene_text="", particle_ids=np.arange(N), warpsph_version="0") as writer:
        index = XdmfIndex(path)
        for k, step in enumerate(STEPS):
            index.append(writer.write_frame(step, step * 1e-3, fields(k)))
    with h5py.File(path, "r+") as f:
        f["frames"].create_group("000003").create_dataset("position", data=np.zeros((N, 3)))
    return path, write_xdmf(path)


def test_layout(run):
    """One Scalar per stress component, each a HyperSlab over one column of the stored (N,6)
    dataset (no copy); no Tensor6, whose component order the readers disagree on."""
    _, xdmf = run
    grids = ET.parse(xdmf).getroot().findall("./Domain/Grid/Grid")
    assert [g.get("Name") for g in grids] == ["frame_000000", "frame_000001", "frame_000002"]
    attributes = {a.get("Name"): a for a in grids[1].findall("Attribute")}
    assert sorted(attributes) == sorted(["velocity", "pore_pressure", *(f"stress_{c}" for c in VOIGT)])
    assert {a.get("AttributeType") for a in attributes.values()} == {"Scalar", "Vector"}
    for column, component in enumerate(VOIGT):
        slab = attributes[f"stress_{component}"].find("DataItem")
        assert slab.get("ItemType") == "HyperSlab" and slab.get("Dimensions") == str(N)
        selection, source = slab.findall("DataItem")
        assert selection.text.split() == ["0", str(column), "1", "1", str(N), "1"]
        assert source.text == "results.h5:/frames/000001/stress" and source.get("Dimensions") == f"{N} 6"


@pytest.fixture
def vtk_frames():
    """Reads an XDMF file with vtkXdmfReader: [(time, points, {array name: values})] per time step."""
    xdmf2 = pytest.importorskip("vtkmodules.vtkIOXdmf2")
    from vtkmodules.util.numpy_support import vtk_to_numpy
    from vtkmodules.vtkCommonExecutionModel import vtkStreamingDemandDrivenPipeline

    def read(xdmf):
        reader = xdmf2.vtkXdmfReader()
        reader.SetFileName(str(xdmf))
        reader.UpdateInformation()
        times = reader.GetOutputInformation(0).Get(vtkStreamingDemandDrivenPipeline.TIME_STEPS())
        frames = []
        for t in times:
            reader.UpdateTimeStep(t)
            grid = reader.GetOutputDataObject(0)
            data = grid.GetPointData()
            arrays = {data.GetArrayName(i): vtk_to_numpy(data.GetArray(i)).copy()
                      for i in range(data.GetNumberOfArrays())}
            frames.append((t, vtk_to_numpy(grid.GetPoints().GetData()).copy(), arrays))
        return frames

    return read


def test_vtk_xdmf_reader(run, vtk_frames):
    path, xdmf = run
    frames = vtk_frames(xdmf)
    assert [t for t, _, _ in frames] == pytest.approx([s * 1e-3 for s in STEPS])
    with h5py.File(path, "r") as f:
        for k, (_, points, arrays) in enumerate(frames):
            stored = {name: ds[()] for name, ds in f[f"frames/{k:06d}"].items()}
            # Positions move: frames 0, 1 and 2 are each read from their own geometry.
            np.testing.assert_array_equal(points, stored["position"])
            assert sorted(arrays) == sorted(["velocity", "pore_pressure", *(f"stress_{c}" for c in VOIGT)])
            for column, component in enumerate(VOIGT):
                values = arrays[f"stress_{component}"]
                assert values.shape == (N,), component  # one scalar per particle, not a tensor
                np.testing.assert_array_equal(values, stored["stress"][:, column], err_msg=component)
            np.testing.assert_array_equal(arrays["velocity"], stored["velocity"])
            np.testing.assert_array_equal(arrays["pore_pressure"], stored["pore_pressure"])
    assert not np.array_equal(frames[0][1], frames[2][1])


def test_meshio_cannot_read_it(run):
    """docs/output.md says meshio's TimeSeriesReader cannot read results.xdmf (mesh from the first
    frame only, no HyperSlab DataItems) and points to load_results instead. Should meshio learn
    HyperSlabs this fails: then update that paragraph."""
    meshio = pytest.importorskip("meshio")
    _, xdmf = run
    with meshio.xdmf.TimeSeriesReader(xdmf) as reader:
        points, _ = reader.read_points_cells()
        np.testing.assert_array_equal(points, fields(0)["position"])
        with pytest.raises(KeyError, match="Format"):
            reader.read_data(1)


def test_index_appends_each_frame_alone(tmp_path, monkeypatch):
    """XdmfIndex (what a run writes) builds each frame's grid once and appends it: after every frame
    the file is byte-identical to a whole write_xdmf, and the grids built grow by one per frame, not
    with the frames before (constant cost per frame)."""
    import warpsph.io.xdmf as xdmf

    path = tmp_path / "results.h5"
    writer = ResultsWriter(path, dim=3, scene_text="", particle_ids=np.arange(N), warpsph_version="0")
    built = []
    grid = xdmf._grid
    monkeypatch.setattr(xdmf, "_grid", lambda *args: built.append(1) or grid(*args))
    index = xdmf.XdmfIndex(path)
    for k, step in enumerate(STEPS):
        before = len(built)
        index.append(writer.write_frame(step, step * 1e-3, fields(k)))
        assert len(built) == before + 1
        monkeypatch.setattr(xdmf, "_grid", grid)
        whole = write_xdmf(path, tmp_path / "whole.xdmf").read_bytes()
        monkeypatch.setattr(xdmf, "_grid", lambda *args: built.append(1) or grid(*args))
        assert index.path.read_bytes() == whole


def test_frames_that_share_a_time_are_all_listed(tmp_path, vtk_frames):
    """A phase's last frame and the next phase's first share their time (a K0 frame and the first
    lift's at t = 0, with other particles): the XDMF lists them at distinct increasing times, so a
    reader shows every frame, each with its own particles; results.h5 keeps the shared times."""
    path = tmp_path / "results.h5"
    times = (0.0, 0.0, 1e-3, 2e-3, 2e-3, 3e-3)
    counts = (N, N + 3, N + 3, N + 3, N + 5, N + 5)
    with ResultsWriter(path, dim=3, scene_text="", particle_ids=np.arange(N + 5), warpsph_version="0") as writer:
        index = XdmfIndex(path)
        for k, (t, n) in enumerate(zip(times, counts)):
            index.append(writer.write_frame(k, t, {"position": np.random.default_rng(k).random((n, 3)) + k}))
    listed = [t for t, _, _ in vtk_frames(index.path)]
    assert len(listed) == len(times) and np.all(np.diff(listed) > 0)
    np.testing.assert_allclose(listed, times, atol=1e-8)
    assert [len(points) for _, points, _ in vtk_frames(index.path)] == list(counts)
    assert index.path.read_bytes() == write_xdmf(path, tmp_path / "whole.xdmf").read_bytes()  # the same listing
    with h5py.File(path, "r") as f:
        assert [float(f["frames"][k].attrs["time"]) for k in sorted(f["frames"])] == list(times)
