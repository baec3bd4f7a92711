"""Output layer: results HDF5, XDMF index, USD clips cache, checkpoints, kill safety."""

import os
import signal
import subprocess
import sys
import textwrap
import xml.etree.ElementTree as ET
from pathlib import Path

import h5py
import numpy as np
import pytest

from warpsph.io import (
    ResultsWriter,
    UsdParticleCache,
    load_checkpoint,
    load_results,
    save_checkpoint,
    write_xdmf,
)

N = 7
SCENE = "name: test\ndim: 2\n"


def make_fields(k: int) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(k)
    position = rng.random((N, 3))
    position[:, 2] = 0.0
    return {
        "position": position,
        "velocity": rng.random((N, 3)),
        "displacement": rng.random((N, 3)),
        "stress": rng.standard_normal((N, 6)) * 1e4,
        "pore_pressure": rng.random(N) * 1e3,
        "plastic_strain": rng.random(N),
    }


def write_run(path: Path, steps=(0, 10, 20), **kwargs) -> ResultsWriter:
    writer = ResultsWriter(path, dim=2, scene_text=SCENE, particle_ids=np.arange(100, 100 + N),
                           warpsph_version="0.1.0", **kwargs)
    for step in steps:
        for s in range(step - 9 if step else 0, step + 1):
            writer.append_series("kinetic_energy", s, s * 1e-3, float(s) ** 2)
        writer.write_frame(step, step * 1e-3, make_fields(step))
    return writer


def test_results_round_trip(tmp_path):
    path = tmp_path / "results.h5"
    with write_run(path):
        pass
    r = load_results(path)
    assert len(r) == 3 and r.dim == 2 and r.scene_text == SCENE
    assert r.attrs["format"] == "warpsph-results" and r.attrs["format_version"] == 1
    assert r.attrs["warpsph_version"] == "0.1.0" and "created" in r.attrs
    np.testing.assert_array_equal(r.particle_ids, np.arange(100, 100 + N))
    assert r.particle_ids.dtype == np.int64
    np.testing.assert_array_equal(r.steps, [0, 10, 20])
    np.testing.assert_array_equal(r.times, [0.0, 0.01, 0.02])
    for i, step in enumerate((0, 10, 20)):
        frame = r.frame(i)
        expected = make_fields(step)
        assert frame.keys() == expected.keys()
        for name in expected:
            np.testing.assert_array_equal(frame[name], expected[name])
    assert r.field("stress").shape == (3, N, 6)
    np.testing.assert_array_equal(r.field("pore_pressure")[-1], make_fields(20)["pore_pressure"])
    assert r.series_names == ["kinetic_energy"]
    t, v = r.series("kinetic_energy")
    np.testing.assert_array_equal(t, np.arange(21) * 1e-3)
    np.testing.assert_array_equal(v, np.arange(21.0) ** 2)
    with h5py.File(path, "r") as f:
        assert list(f["frames"]) == ["000000", "000001", "000002"]
        assert f["series/kinetic_energy/step"].dtype == np.int64
        assert f["series/kinetic_energy/time"].maxshape == (None,)


def test_results_resume_truncates(tmp_path):
    path = tmp_path / "results.h5"
    write_run(path).close()
    with h5py.File(path, "r+") as f:  # an incomplete frame (no step attribute) left by a kill
        f["frames"].create_group("000003").create_dataset("position", data=np.zeros((N, 3)))
    assert len(load_results(path)) == 3  # incomplete frames are invisible
    with write_run(path, steps=(20,), resume_step=10):
        pass
    r = load_results(path)
    np.testing.assert_array_equal(r.steps, [0, 10, 20])
    with h5py.File(path, "r") as f:
        assert list(f["frames"]) == ["000000", "000001", "000002"]
    t, v = r.series("kinetic_energy")
    np.testing.assert_array_equal(t, np.arange(21) * 1e-3)  # 0..10 kept, 11..20 written again
    np.testing.assert_array_equal(v, np.arange(21.0) ** 2)


def test_xdmf(tmp_path):
    path = tmp_path / "results.h5"
    write_run(path).close()
    xdmf = write_xdmf(path)
    assert xdmf == tmp_path / "results.xdmf"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["results.h5", "results.xdmf"]
    root = ET.parse(xdmf).getroot()
    grids = root.findall("./Domain/Grid/Grid")
    assert [float(g.find("Time").get("Value")) for g in grids] == [0.0, 0.01, 0.02]
    kinds = {a.get("Name"): a.get("AttributeType") for a in grids[0].findall("Attribute")}
    # stress: one Scalar per component, each a HyperSlab over one column (tests/test_xdmf_readers.py)
    assert kinds == {"velocity": "Vector", "displacement": "Vector", "pore_pressure": "Scalar",
                     "plastic_strain": "Scalar",
                     **{f"stress_{c}": "Scalar" for c in ("xx", "yy", "zz", "yz", "xz", "xy")}}
    assert grids[0].find("Topology").get("TopologyType") == "Polyvertex"
    items = [item for item in root.iter("DataItem") if item.get("Format") == "HDF"]  # not the HyperSlabs' selections
    with h5py.File(path, "r") as f:
        for item in items:
            file, dataset = item.text.strip().split(":")
            assert file == "results.h5"
            assert " ".join(map(str, f[dataset].shape)) == item.get("Dimensions")
    assert grids[2].find("Geometry/DataItem").text.strip() == "results.h5:/frames/000002/position"

    # A new run in the same file must not reuse the previous run's frame XML.
    with ResultsWriter(path, dim=2, scene_text=SCENE, particle_ids=np.arange(N), warpsph_version="0") as w:
        w.write_frame(0, 0.0, {"position": np.zeros((N, 3))})
    grids = ET.parse(write_xdmf(path)).getroot().findall("./Domain/Grid/Grid")
    assert len(grids) == 1 and grids[0].findall("Attribute") == []


def test_import_does_not_need_pxr():
    code = "import sys, warpsph.io; assert 'pxr' not in sys.modules"
    subprocess.run([sys.executable, "-c", code], check=True, cwd=Path(__file__).parents[1])


def test_usd_cache(tmp_path):
    from pxr import Usd, UsdGeom

    positions = []
    cache = UsdParticleCache(tmp_path, radius=0.005)
    for k, step in enumerate((0, 10, 20)):
        fields = make_fields(step)
        positions.append(fields["position"])
        cache.write_frame(step, step * 1e-3, fields["position"],
                          {name: fields[name] for name in ("velocity", "stress", "pore_pressure")},
                          ids=np.arange(N) + 100 * k)  # fmt: skip
    cache.close()

    stage = Usd.Stage.Open(str(tmp_path / "particles.usdc"))
    prim = stage.GetPrimAtPath("/Particles")
    assert prim.IsA(UsdGeom.Points)
    assert (stage.GetStartTimeCode(), stage.GetEndTimeCode()) == (0, 2)
    points = UsdGeom.Points(prim)
    np.testing.assert_allclose(np.array(points.GetPointsAttr().Get(1)), positions[1], rtol=1e-6, atol=1e-7)
    assert prim.GetAttribute("warpsph:time").Get(1) == pytest.approx(0.01)
    assert list(points.GetIdsAttr().Get(2)) == list(np.arange(N) + 200)  # each frame's particles by id
    assert list(points.GetWidthsAttr().Get()) == pytest.approx([0.01])
    primvars = UsdGeom.PrimvarsAPI(prim)
    for name in ("velocity", "pore_pressure", "stress_mean", "stress_von_mises"):
        assert primvars.GetPrimvar(name).GetInterpolation() == "vertex"
        assert len(primvars.GetPrimvar(name).Get(2)) == N
    stress = make_fields(20)["stress"]
    np.testing.assert_allclose(np.array(primvars.GetPrimvar("stress_mean").Get(2)),
                               stress[:, :3].mean(axis=1), rtol=1e-5)
    del stage, prim, points, primvars

    # Resume from step 10: the clip of step 20 goes, the next frame takes its place.
    cache = UsdParticleCache(tmp_path, radius=0.005, resume_step=10)
    clips = tmp_path / "particles_clips"
    assert not (clips / "frame.000002.usdc").exists() and (clips / "frame.000001.usdc").exists()
    stage = Usd.Stage.Open(str(tmp_path / "particles.usdc"))
    assert stage.GetEndTimeCode() == 1
    del stage
    cache.write_frame(30, 0.03, positions[0] + 1.0, {"pore_pressure": np.zeros(N)})
    stage = Usd.Stage.Open(str(tmp_path / "particles.usdc"))
    prim = stage.GetPrimAtPath("/Particles")
    assert stage.GetEndTimeCode() == 2 and prim.GetAttribute("warpsph:step").Get(2) == 30
    np.testing.assert_allclose(np.array(UsdGeom.Points(prim).GetPointsAttr().Get(2)), positions[0] + 1.0, rtol=1e-6)
    assert UsdGeom.PrimvarsAPI(prim).GetPrimvar("velocity").Get(1) is not None  # earlier primvars kept


def test_checkpoint_round_trip(tmp_path):
    rng = np.random.default_rng(1)
    arrays = {
        "x": rng.standard_normal((50, 3)),
        "rho": rng.standard_normal(50).astype(np.float32),
        "ids": np.arange(50, dtype=np.int32),
        "cells": rng.integers(-5, 5, (4, 5, 6), dtype=np.int64),
    }
    meta = {"scene": "dam", "version": "0.1.0", "n": 50, "dt": 1.25e-5}
    path = tmp_path / "checkpoint.h5"
    save_checkpoint(path, step=1234, time=0.5, arrays=arrays, meta=meta)
    save_checkpoint(path, step=1235, time=0.6, arrays=arrays, meta=meta)  # overwrite in place
    assert sorted(p.name for p in tmp_path.iterdir()) == ["checkpoint.h5"]
    ck = load_checkpoint(path)
    assert (ck.step, ck.time, ck.meta) == (1235, 0.6, meta)
    assert ck.arrays.keys() == arrays.keys()
    for name, a in arrays.items():
        assert ck.arrays[name].dtype == a.dtype and ck.arrays[name].shape == a.shape
        assert ck.arrays[name].tobytes() == a.tobytes()


def test_checkpoint_errors(tmp_path):
    with pytest.raises(FileNotFoundError):
        load_checkpoint(tmp_path / "missing.h5")
    (tmp_path / "text.h5").write_text("not hdf5")
    with pytest.raises(ValueError, match="not a warpsph checkpoint"):
        load_checkpoint(tmp_path / "text.h5")
    write_run(tmp_path / "results.h5", steps=(0,)).close()
    with pytest.raises(ValueError, match="not a warpsph checkpoint"):
        load_checkpoint(tmp_path / "results.h5")


KILLED_WRITER = textwrap.dedent("""
    import sys, time
    import numpy as np
    from warpsph.io import ResultsWriter, UsdParticleCache, write_xdmf
    out = sys.argv[1]
    results = ResultsWriter(out + "/results.h5", dim=3, scene_text="", particle_ids=np.arange(100),
                            warpsph_version="test")
    usd = UsdParticleCache(out, radius=0.01)
    for k in range(1000):
        p = np.random.default_rng(k).random((100, 3))
        results.append_series("e", k, k * 0.1, k)
        results.write_frame(k, k * 0.1, {"position": p, "pore_pressure": p[:, 0]})
        write_xdmf(out + "/results.h5")
        usd.write_frame(k, k * 0.1, p, {"pore_pressure": p[:, 0]})
        print(k, flush=True)
        time.sleep(0.5)
""")


def test_kill_safety(tmp_path):
    from pxr import Usd

    proc = subprocess.Popen([sys.executable, "-c", KILLED_WRITER, str(tmp_path)], stdout=subprocess.PIPE,
                            text=True, env={**os.environ, "PYTHONPATH": os.pathsep.join(
                                filter(None, [str(Path(__file__).parents[1]), os.environ.get("PYTHONPATH")]))})
    try:
        for _ in range(2):
            assert proc.stdout.readline(), "writer died before writing two frames"
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait()
    r = load_results(tmp_path / "results.h5")
    assert len(r) >= 1 and r.frame(-1)["position"].shape == (100, 3)
    assert len(r.series("e")[0]) >= 1
    ET.parse(tmp_path / "results.xdmf")
    stage = Usd.Stage.Open(str(tmp_path / "particles.usdc"))
    assert stage.GetPrimAtPath("/Particles").IsValid() and stage.GetEndTimeCode() >= 1
