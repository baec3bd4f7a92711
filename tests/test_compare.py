"""Comparing two runs (warpsph.io.compare) and the shortened shipped scenes it compares
(warpsph.regression; docs/output.md, *Comparing runs*)."""

import math
import shutil

import h5py
import pytest

from warpsph.io.compare import compare_runs
from warpsph.regression import EASY, FAR, STEPS, cases, main, shortened


@pytest.fixture(scope="module")
def two_runs(tmp_path_factory):
    """The shortened wave column run twice, into a/wave_column and b/wave_column."""
    root = tmp_path_factory.mktemp("compare")
    for side in ("a", "b"):
        assert main(["run", str(root / side), "--only", "wave_column"]) == 0
    return root


def test_the_same_run_twice_is_identical(two_runs, capsys):
    comparison = compare_runs(two_runs / "a", two_runs / "b")
    assert comparison.identical and comparison.lines() == ["identical"]
    assert "wave_column/results.h5:/frames/position" in comparison.differences
    assert "wave_column/run.json:final_step" in comparison.differences
    assert main(["compare", str(two_runs / "a"), str(two_runs / "b")]) == 0
    assert capsys.readouterr().out.strip() == "identical"


def test_a_changed_value_is_found_with_its_size(two_runs, tmp_path, capsys):
    changed = tmp_path / "wave_column"
    shutil.copytree(two_runs / "a" / "wave_column", changed)
    with h5py.File(changed / "results.h5", "r+") as f:
        name = sorted(f["frames"])[-1]
        f["frames"][name]["velocity"][3, 1] += 0.25
    (changed / "checkpoint.h5").unlink()
    comparison = compare_runs(two_runs / "a" / "wave_column", changed)
    assert comparison.differences["results.h5:/frames/velocity"] == pytest.approx(0.25)
    assert math.isinf(comparison.differences["checkpoint.h5"])
    assert comparison.differences["results.h5:/frames/position"] == 0.0
    assert main(["compare", str(two_runs / "a" / "wave_column"), str(changed)]) == 1
    out = capsys.readouterr().out.splitlines()
    assert out[-1].startswith("2 of ") and out[-1].endswith(" fields differ")
    assert out[0].startswith("checkpoint.h5 ") and out[1].startswith("results.h5:/frames/velocity ")
    assert main(["compare", str(two_runs / "a"), str(tmp_path / "missing")]) == 2


def test_shortened_scenes_run_every_phase_briefly():
    scenes = cases()
    assert {"slope_fos", "slope_fos_without_safety", "terzaghi_consolidation"} <= set(scenes)
    slope = shortened(scenes["slope_fos"])
    kinds = {p.kind: p for p in slope.phases}
    assert kinds["equilibrium"].tolerance == kinds["safety"].tolerance == EASY
    assert kinds["safety"].failure_displacement == FAR
    assert kinds["dynamic"].duration == pytest.approx(STEPS * slope.time_step)
    assert all(p.kind != "safety" for p in scenes["slope_fos_without_safety"].phases)
    dyke = shortened(scenes["dyke_rising_water"])
    transient = [p for p in dyke.phases if p.kind == "flow" and not p.steady]
    assert transient and all(p.frames == 2 for p in transient)
