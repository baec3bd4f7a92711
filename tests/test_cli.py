"""The command line: validate, run, bad input (exit 2, one line) and blow-ups (exit 1, output kept)."""

import subprocess
import sys

import h5py
import pytest

from warpsph.cli import main
from warpsph.environment import default_device
from warpsph.io import load_checkpoint, load_results


def warpsph(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "warpsph", *map(str, args)], capture_output=True, text=True,
                          cwd=cwd, timeout=600)  # fmt: skip


def test_validate_shipped_scene(scenes_dir, capsys):
    assert main(["validate", str(scenes_dir / "wave_column.toml"), "--no-estimate"]) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    assert lines[0] == f"{scenes_dir / 'wave_column.toml'}: valid scene 'wave_column' (2D, 1 bodies)"
    assert "404 particles" in lines[1] and "ms per step" not in lines[2]


def test_validate_estimates_the_run(scenes_dir, tmp_path, capsys):
    """Particles, time step, steps, run time measured on this machine and output size; a run of
    more than 1e7 steps is warned of (a unit typed wrong), by validate and by run."""
    assert main(["validate", str(scenes_dir / "wave_column.toml")]) == 0
    out = capsys.readouterr().out
    assert "404 particles, 300 virtual points, dt = 0.0003571 s" in out
    assert "197 steps, 16 frames: about " in out and "ms per step measured" in out and "MB of output" in out
    long = tmp_path / "long.toml"
    long.write_text((scenes_dir / "wave_column.toml").read_text().replace("end_time = 0.07", "end_time = 5000.0"))
    assert main(["validate", str(long)]) == 0
    assert "warning: 14,002,801 steps, more than 10,000,000" in capsys.readouterr().out
    assert main(["run", str(long), "--out", str(tmp_path / "out"), "--end-time", "0.001", "--no-progress"]) == 0
    assert "warning: 14,002,801 steps" in capsys.readouterr().err


def test_validate_reports_a_scene_whose_first_steps_go_unstable(tmp_path, capsys):
    """A column 1000 times softer than soil under gravity: its timed steps crowd the particles past their
    neighbour lists; validate still exits 0, with a warning line that says where the run will stop."""
    from test_scene_errors import BASE

    soft = tmp_path / "soft.toml"
    soft.write_text(BASE.replace("youngs_modulus = 1e7", "youngs_modulus = 1000.0"))
    assert main(["validate", str(soft)]) == 0
    (line,) = [ln for ln in capsys.readouterr().out.splitlines() if "went unstable" in ln]
    assert "warning: phase dynamic went unstable in its first" in line and "neighbours" in line


@pytest.mark.parametrize("text, key", [
    ("[simulation]\ncourrant = 0.5\n", "simulation.courrant"),
    ("[simulation]\ndx = 0.1\n[materials.soil]\npoisson_ratio = 0.5\n"
     "[[bodies]]\nmaterial = 'soil'\nmin = [0, 0]\nmax = [1, 1]\n", "materials.soil.poisson_ratio"),
    ("[simulation\n", "TOML"),
])
def test_bad_scene_is_one_line_and_exit_2(tmp_path, text, key):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    for command in ("validate", "run"):
        result = warpsph(command, path, "--out", tmp_path / "out") if command == "run" else warpsph(command, path)
        assert result.returncode == 2
        lines = result.stderr.strip().splitlines()
        assert len(lines) == 1 and key in lines[0] and "Traceback" not in result.stderr


def test_missing_scene_file(tmp_path):
    result = warpsph("validate", tmp_path / "nope.toml")
    assert result.returncode == 2 and "Traceback" not in result.stderr


def test_run_writes_results(scenes_dir, tmp_path):
    result = warpsph("run", scenes_dir / "wave_column.toml", "--out", tmp_path, "--end-time", "0.006",
                     "--no-progress")  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert "particle-steps/s" in result.stdout and "compile" in result.stdout
    results = load_results(tmp_path / "results.h5")
    assert results.attrs["format"] == "warpsph-results" and len(results) >= 2
    assert results.scene_text == (scenes_dir / "wave_column.toml").read_text()


def test_the_estimate_counts_what_a_run_writes_and_warns_of_a_long_or_large_one(scenes_dir, tmp_path):
    """The frames counted are those the run writes (the first, every frame_interval, the last); a plan
    counted at step caps says so and why; a run of more than a day or 10 GB is warned of."""
    from warpsph.io import load_results
    from warpsph.planning import RunPlan, count_steps, plan
    from warpsph.scene_toml import load_scene

    scene = load_scene(scenes_dir / "wave_column.toml")
    warpsph("run", scenes_dir / "wave_column.toml", "--out", tmp_path / "run", "--no-progress")
    assert count_steps(scene)[2] == len(load_results(tmp_path / "run" / "results.h5").times) == 16
    capped = plan(load_scene(scenes_dir / "slope_fos.toml"), "cpu", timed=False).lines()[1]
    assert capped.startswith("at most ") and "counted at their step caps, max_steps" in capped
    lines = RunPlan(10**6, 10**6, 1e-4, 10**8, False, 10**4, 1e-3, 2e10).lines()
    assert lines[2].startswith("warning: the run may take 27.8 h on this machine: coarsen simulation.dx")
    assert lines[3] == "warning: the run may write 20 GB: raise output.frame_interval or write fewer output.fields"


def test_help_shows_defaults():
    """Each option's default once, and none where there is none to show."""
    result = warpsph("run", "--help")
    assert result.returncode == 0 and "--end-time" in result.stdout and f"default: {default_device()}" in result.stdout
    text = " ".join(result.stdout.split())
    assert text.count("default: runs/SCENE_NAME") == 1 and "default: None" not in text and "default: False" not in text


def test_blow_up_stops_with_message_and_keeps_output(scenes_dir, tmp_path):
    """A speed bound below the wave's particle speed (5 kPa / (ρ c_p) = 18 mm/s): the guard stops
    the run at the first step that exceeds it, as it stops a blow-up."""
    scene = (scenes_dir / "wave_column.toml").read_text()
    scene = scene.replace("courant = 0.5", "courant = 0.5\nvelocity_limit = 0.01")
    scene = scene.replace("frame_interval = 0.005", "frame_interval = 0.0036")
    path = tmp_path / "unstable.toml"
    path.write_text(scene)
    result = warpsph("run", path, "--out", tmp_path / "out", "--no-progress", "--end-time", "1.0")
    assert result.returncode == 1
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "unstable at step" in lines[0] and "particle" in lines[0]
    step = int(lines[0].split("unstable at step ")[1].split(",")[0])
    checkpoint = load_checkpoint(tmp_path / "out" / "checkpoint.h5")
    assert 0 <= checkpoint.step < step
    results = load_results(tmp_path / "out" / "results.h5")
    assert len(results) >= 1 and results.steps[-1] < step
    with h5py.File(tmp_path / "out" / "results.h5", "r") as f:
        assert f.attrs["format"] == "warpsph-results"


def test_collocated_scene_runs(scenes_dir, tmp_path):
    """The run loop on a collocated scene, whose solver has no pressure projection."""
    from warpsph.runner import run_scene
    from warpsph.scene_toml import load_scene

    scene = load_scene(scenes_dir / "wave_column.toml", {"simulation.scheme": "collocated", "output.usd": False})
    assert run_scene(scene, tmp_path, end_time=0.002).steps > 0
