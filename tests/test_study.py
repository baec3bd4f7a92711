"""warpsph study: study files and their errors, cartesian expansion, the Pareto front, runs through
a real Dask LocalCluster, resume, and the reports (docs/accuracy.md)."""

import csv
import json
import math
from pathlib import Path

import numpy as np
import pytest

from warpsph.cli import main
from warpsph.errors import SceneError
from warpsph.scene_toml import load_scene
from warpsph.study import metrics
from warpsph.study.execute import run_studies
from warpsph.study.report import pareto_front, write_reports
from warpsph.study import spec
from warpsph.study.spec import load_study

STUDIES = Path(__file__).resolve().parent.parent / "studies"
HEAD = '[study]\nscene = "{scene}"\nmetric = "wave_column"\n'


def study_file(tmp_path, scenes_dir, body, head=HEAD, name="s"):
    path = tmp_path / f"{name}.toml"
    path.write_text(head.format(scene=(scenes_dir / "wave_column.toml").as_posix()) + body)
    return path


def test_shipped_studies_parse():
    for name, metric, ladder in (("wave_column", "wave_column", 4), ("terzaghi", "terzaghi", 4),
                                 ("footing_prandtl", "prandtl_footing", 3)):  # fmt: skip
        study = load_study(STUDIES / f"{name}.toml")
        cases = study.cases()
        assert study.metric.name == metric and len({c.id for c in cases}) == len(cases)
        assert len(study.sweeps[0][1]["simulation.dx"]) >= ladder
        assert all(set(c.settings) == set(study.axes) for c in cases)


def test_cartesian_product_of_each_sweep_and_their_union(tmp_path, scenes_dir):
    body = ('[fixed]\n"simulation.artificial_viscosity" = 0.1\n'
            '[axes]\nsimulation.dx = [0.1, 0.05]\n"simulation.courant" = [0.5, 0.4, 0.3]\n'
            '[[sweeps]]\n"simulation.dx" = [0.1]\n"simulation.courant" = [0.5]\n'  # already in [axes]: run once
            '[[sweeps]]\n"simulation.dx" = [0.1]\n"simulation.kernel" = ["cubic_spline", "wendland_c2"]\n')
    cases = load_study(study_file(tmp_path, scenes_dir, body)).cases()
    # 2 x 3 from [axes]; the first sweep repeats one of them; cubic_spline at dx 0.1, courant 0.5 too
    assert len(cases) == 7
    assert [(c.settings["simulation.dx"], c.settings["simulation.courant"]) for c in cases[:6]] == [
        (0.1, 0.5), (0.1, 0.4), (0.1, 0.3), (0.05, 0.5), (0.05, 0.4), (0.05, 0.3)]
    assert cases[6].settings == {"simulation.dx": 0.1, "simulation.courant": 0.5, "simulation.kernel": "wendland_c2"}
    assert all(c.overrides["simulation.artificial_viscosity"] == 0.1 for c in cases)


def test_overrides_pick_list_entries_by_name(scenes_dir):
    overrides = {"loads.top.traction": [0, -1e3], "bodies.column.max": [0.3, 5]}
    scene = load_scene(scenes_dir / "wave_column.toml", overrides)
    assert scene.loads[0].traction == (0.0, -1e3, 0.0) and scene.bodies[0].max == (0.3, 5.0, 0.0)
    with pytest.raises(SceneError, match='loads.bottom: no entry named "bottom"; entries: "top"'):
        load_scene(scenes_dir / "wave_column.toml", {"loads.bottom.traction": [0, -1e3]})


@pytest.mark.parametrize("text, key", [
    ("[study\n", "TOML syntax error"),
    ('[study]\nscene = "x"\n[solver]\n', "solver: unknown section"),
    ('[axes]\n"simulation.dx" = [0.1]\n', "study: missing table [study]"),
    ('[study]\nmetric = "wave_column"\n', "study.scene: missing key"),
    ('[study]\nscene = "nope.toml"\nmetric = "wave_column"\n', "study.scene: cannot read scene file"),
    (HEAD + "speed = 1\n", "study.speed: unknown key"),
    (HEAD.replace("wave_column", "wave") + '[axes]\n"simulation.dx" = [0.1]\n', 'study.metric: unknown metric "wave"'),
    (HEAD.replace('"wave_column"', '"prandtl_footing"') + '[axes]\n"simulation.dx" = [0.1]\n',
     "study.metric: prandtl_footing needs the footing scene's layout"),
    (HEAD.replace('"wave_column"', '"terzaghi"') + '[axes]\n"simulation.dx" = [0.1]\n',
     "study.metric: terzaghi needs effects.pore_water = true"),
    (HEAD + 'error = "l1"\n', "study.error: must be one of profile_l2, front_speed_error"),
    (HEAD + 'cost = "money"\n', "study.cost: must be one of wall_seconds, cpu_seconds"),
    (HEAD, "axes: nothing to sweep"),
    (HEAD + '[axes]\n"simulation.dx" = 0.1\n', "axes.simulation.dx: expected a non-empty list of values"),
    (HEAD + "[axes]\nsimulation.dx = []\n", "axes.simulation.dx: expected a non-empty list of values"),
    (HEAD + '[axes]\n"simulation.courant" = [0.5, 3]\n',
     "axes.simulation.courant: must be in (0, 1.5] (the two_set rk4 step's energy grows at 1.7 on the wave column; "
     "docs/accuracy.md, *Stability limit*), got 3"),
    (HEAD + '[axes]\n"simulation.courrant" = [0.5]\n', "axes.simulation.courrant: unknown key; accepted:"),
    (HEAD + '[fixed]\n"simulation.dx" = -1\n[axes]\n"simulation.courant" = [0.5]\n', "fixed.simulation.dx: must be"),
    (HEAD + '[axes]\n"simulation.dx" = [0.1]\n[[sweeps]]\n"simulation.dx" = [0.1]\n'
     '[[sweeps]]\n"simulation.kernel" = ["gauss"]\n', 'sweeps[1].simulation.kernel: must be one of'),
    (HEAD + '[axes]\n"loads.bottom.traction" = [[0, 1]]\n', 'axes.loads.bottom.traction: no entry named "bottom"'),
])  # fmt: skip
def test_bad_study_file_is_one_line_and_exit_2(tmp_path, scenes_dir, capsys, text, key):
    path = study_file(tmp_path, scenes_dir, "", head=text)
    assert main(["study", str(path), "--dry-run", "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and key in err[0] and str(path) in err[0], err


def test_footing_plateau_on_a_synthetic_series():
    """The plateau is the mean of the pressure inside the settlement window, and the error compares it
    with (2 + π) c_u."""
    assert metrics.FOOTING_WINDOW == pytest.approx((0.025, 0.040))
    settlement = np.linspace(0.0, 0.06, 600)
    inside = (settlement >= 0.025) & (settlement <= 0.040)
    pressure = np.where(inside, 46.0e3, 1.0e6)  # wrong outside the window
    pressure[inside] += np.resize([1e3, -1e3], inside.sum())  # ± 1 kPa, an even count: mean 46 kPa
    mean, spread, count = metrics.footing_plateau(settlement, pressure, metrics.FOOTING_WINDOW)
    assert count == inside.sum() == 150 and mean == pytest.approx(46.0e3) and spread == pytest.approx(1e3)
    assert abs(mean / ((2 + math.pi) * 10e3) - 1) == pytest.approx(0.1053, abs=1e-4)
    assert metrics.footing_plateau(settlement[:200], pressure[:200], metrics.FOOTING_WINDOW)[2] == 0  # never reached


def test_footing_metric_on_a_short_coarse_run(monkeypatch):
    """The metric runs the footing scene with B/2 and the piston following Δx, reads the probes over
    its window and fails a run that is nowhere near the limit load (an elastic 1-2 mm window)."""
    scene_path = Path(__file__).resolve().parent.parent / "scenes" / "footing_prandtl.toml"
    scene = load_scene(scene_path, {"simulation.dx": 0.1})
    metric = metrics.METRICS["prandtl_footing"]
    metric.check(scene)
    adjusted = metrics.footing_scene(scene)
    assert adjusted.probes[0].scale == pytest.approx(1 / 0.55)  # footing particles at x = 0 ... 0.5
    probes = {p.name: p for p in adjusted.probes}
    assert adjusted.loads[0].region.min[1] == pytest.approx(3.075) == probes["footing_displacement"].region.min[1]
    assert probes["footing_contact_pressure"].scale == pytest.approx(-1 / 0.55)
    assert metrics.footing_scene(load_scene(scene_path, {"simulation.dx": 0.075})).probes[0].scale == pytest.approx(
        1 / 0.4875)  # x = 0 ... 0.45  # fmt: skip
    assert scene.probes[0].scale == pytest.approx(1.92)  # the scene itself (B/2 = 0.5208 m at 1/24 m) is left alone
    monkeypatch.setattr(metrics, "FOOTING_WINDOW", (0.001, 0.002))
    assert metric.end_time(scene) == pytest.approx(0.2)  # the end of the ramp: v T / 2 = 2 mm
    measured = metric.measure(scene, "cpu")
    settlement, pressure = (np.array(v) for v in zip(*measured.run.samples))
    assert settlement[-1] == pytest.approx(0.002, rel=0.05) and (np.diff(settlement) > 0).all()
    inside = (settlement >= 0.001) & (settlement <= 0.002)
    ratio = pressure[inside].mean() / ((2 + math.pi) * 10e3)
    assert measured.extras["signed_error"] == pytest.approx(ratio - 1.0)
    assert measured.errors["limit_load_error"] == pytest.approx(abs(ratio - 1.0)) and 0.1 < ratio < 0.5


def test_a_record_is_this_codes(monkeypatch):
    """A run's id covers the code as well as the scene: records measured by other code are not reused."""
    scene = load_scene(Path(__file__).resolve().parent.parent / "scenes" / "wave_column.toml")
    first = spec.run_id(scene, "wave_column", "cpu")
    assert spec.run_id(scene, "wave_column", "cpu") == first and len(spec.code_fingerprint()) == 16
    monkeypatch.setattr(spec, "code_fingerprint", lambda: "0" * 16)
    assert spec.run_id(scene, "wave_column", "cpu") != first


def test_pareto_front_on_a_hand_made_set():
    cost = [1.0, 2.0, 3.0, 4.0, 5.0, 2.0, math.nan, 0.5]
    error = [5.0, 3.0, 3.0, 1.0, 2.0, 3.0, 0.0, math.inf]
    # (3, 3) and (5, 2) are beaten; the two (2, 3) tie and both stay; non-finite points are never on it
    assert pareto_front(cost, error).tolist() == [True, True, False, True, False, True, False, False]
    assert not pareto_front([], []).any()


def test_dry_run_lists_runs_and_estimates(capsys, tmp_path):
    assert main(["study", str(STUDIES / "terzaghi.toml"), "--dry-run", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "terzaghi:" in out and "CPU-minutes" in out and "pressure.tolerance = 1e-06" in out


def test_runs_through_dask_resume_and_reports(tmp_path, scenes_dir):
    """Two runs through a LocalCluster of one worker; the study grown by an axis and started again
    (in this process) runs only the two new cases; then every report is written."""
    first = load_study(study_file(tmp_path, scenes_dir, '[axes]\n"simulation.scheme" = ["two_set", "collocated"]\n'))
    (outcome,) = run_studies([first], tmp_path / "out", workers=1, progress=False)
    assert (outcome.ran, outcome.skipped, outcome.lost) == (2, 0, [])
    records = {r["settings"]["simulation.scheme"]: r for r in outcome.records}
    assert all(r["status"] == "finished" and r["wall_seconds"] > 0 and r["steps"] > 0 for r in records.values())
    assert records["two_set"]["errors"]["front_speed_error"] < 0.01
    stored = sorted((tmp_path / "out" / "s" / "runs").glob("*.json"))
    assert len(stored) == 2 and not list(stored[0].parent.glob("*.partial"))

    grown = load_study(study_file(tmp_path, scenes_dir, '[axes]\n"simulation.scheme" = ["two_set", "collocated"]\n'
                                                        '"simulation.courant" = [0.5, 1.0]\n'))  # fmt: skip
    (outcome,) = run_studies([grown], tmp_path / "out", workers=0, progress=False)
    assert (outcome.ran, outcome.skipped) == (2, 2) and len(outcome.records) == 4

    names = {p.name for p in write_reports(outcome)}
    assert names == {"results.csv", "results.json", "results.md", "profile_l2_vs_time.png",
                     "front_speed_error_vs_time.png"}
    out = tmp_path / "out" / "s"
    rows = list(csv.DictReader(open(out / "results.csv")))
    assert len(rows) == 4 and {"simulation.scheme", "simulation.courant", "profile_l2", "wall_seconds",
                               "cpu_seconds", "compile_seconds", "pareto_profile_l2"} <= set(rows[0])
    document = json.loads((out / "results.json").read_text())
    assert document["invocation"]["ran"] == 2 and any(r["pareto"]["profile_l2"] for r in document["runs"])
    table = (out / "results.md").read_text()
    header = [cell.strip() for cell in next(line for line in table.splitlines() if line.startswith("|")).split("|")]
    assert header[1:4] == ["scheme", "courant", "profile_l2"] and "wall s" in header and "cpu s" in header
    assert table.count("★") >= 1 and "collocated" in table
    assert (out / "profile_l2_vs_time.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert np.isfinite([float(r["profile_l2"]) for r in rows]).all()
