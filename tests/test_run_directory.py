"""The run directory and failures outside the scene (docs/output.md, *The run directory*): one run
at a time, earlier output replaced only with --overwrite, a resumed scene that changed refused, SIGINT
and SIGTERM checkpoint and stop so that --resume continues bit-identical, an output that cannot be
written, a device that is not there: each one line with its own exit code."""

import errno
import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

import warpsph
from warpsph.cli import EXIT_BAD_INPUT, EXIT_DEVICE, EXIT_INTERRUPTED, EXIT_OUTPUT, main
from warpsph.errors import InputError, OutputError
from warpsph.io import load_checkpoint, load_results
from warpsph.io.run_directory import LOCK, RunDirectory
from warpsph.runner import Run
from warpsph.scene_toml import load_scene

END = 0.02  # s of the wave column: 57 steps


@pytest.fixture
def column(scenes_dir):
    return load_scene(scenes_dir / "wave_column.toml", {"output.usd": False})


def only_line(stderr: str) -> str:
    lines = stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in stderr, stderr
    return lines[0]


def test_earlier_output_is_replaced_only_with_overwrite(scenes_dir, tmp_path, capsys):
    scene = str(scenes_dir / "wave_column.toml")
    args = ["run", scene, "--out", str(tmp_path), "--end-time", "0.004", "--no-progress"]
    assert main(args) == 0
    assert f"results in {tmp_path}" in capsys.readouterr().out
    before = (tmp_path / "results.h5").stat().st_mtime_ns
    assert main(args) == EXIT_BAD_INPUT
    line = only_line(capsys.readouterr().err)
    assert "holds an earlier run's results.h5" in line and "--overwrite" in line
    assert (tmp_path / "results.h5").stat().st_mtime_ns == before
    assert main([*args[:-3], "--end-time", "0.002", "--no-progress", "--overwrite"]) == 0
    assert load_results(tmp_path / "results.h5").times[-1] < 0.003


def test_a_second_run_into_a_directory_in_use_is_refused(column, tmp_path):
    held = RunDirectory(tmp_path)
    with pytest.raises(InputError, match=f"another run \\(process {os.getpid()}\\) is writing into it"):
        Run(column, tmp_path, end_time=END)
    held.release()
    assert Run(column, tmp_path, end_time=END).run().status == "finished"
    assert not (tmp_path / LOCK).exists()  # a run that ends takes its lock file with it


def test_resume_refuses_a_changed_scene_and_records_the_resumed_one(column, tmp_path):
    Run(column, tmp_path, end_time=END).run()
    checkpoint_step = load_checkpoint(tmp_path / "checkpoint.h5").step
    heavier = load_scene_with(column, {"simulation.gravity": [0.0, -19.62]})
    with pytest.raises(InputError, match="simulation.gravity differs from the scene the checkpoint was written with"):
        Run(heavier, tmp_path, end_time=2 * END, resume=True)
    longer = load_scene_with(column, {"simulation.end_time": 1.0, "output.frame_interval": 0.01})
    Run(longer, tmp_path, end_time=2 * END, resume=True).run()
    results = load_results(tmp_path / "results.h5")
    assert results.scene_text == longer.source_text != column.source_text
    assert list(results.attrs["resumed_at"]) == [checkpoint_step]


def load_scene_with(scene, overrides):
    from warpsph.scene_toml import parse_scene

    return parse_scene(scene.source_text, name=scene.name, overrides={"output.usd": False, **overrides})


def test_sigint_checkpoints_and_resume_is_bit_identical(column, tmp_path):
    whole = tmp_path / "whole"
    Run(column, whole, end_time=END).run()

    def interrupt(t, step):
        if step == 20:
            os.kill(os.getpid(), signal.SIGINT)

    split = tmp_path / "split"
    summary = Run(column, split, end_time=END).run(progress=interrupt)
    assert summary.status == "interrupted" and summary.final_step == 20
    assert "interrupted by SIGINT at step 20" in summary.message and "--resume" in summary.message
    assert load_checkpoint(split / "checkpoint.h5").step == 20
    assert json.loads((split / "run.json").read_text())["status"] == "interrupted"
    assert Run(column, split, end_time=END, resume=True).run().status == "finished"
    a, b = load_results(whole / "results.h5"), load_results(split / "results.h5")
    assert np.array_equal(a.times, b.times)
    for name in ("position", "velocity", "stress"):
        assert np.array_equal(a.frame(-1)[name], b.frame(-1)[name]), name


def test_sigterm_stops_the_command_with_exit_130(scenes_dir, tmp_path):
    out = tmp_path / "out"
    command = [sys.executable, "-m", "warpsph", "run", str(scenes_dir / "wave_column.toml"), "--out", str(out),
               "--end-time", "5.0", "--no-progress"]  # fmt: skip
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    process.stdout.readline()  # the scene's line: the model is built
    time.sleep(1.0)
    process.send_signal(signal.SIGTERM)
    _, stderr = process.communicate(timeout=300)
    assert process.returncode == EXIT_INTERRUPTED
    assert "interrupted by SIGTERM at step" in only_line(stderr)
    record = json.loads((out / "run.json").read_text())
    assert record["status"] == "interrupted" and record["final_time"] < 5.0
    assert load_checkpoint(out / "checkpoint.h5").step == record["final_step"]
    assert not list(out.glob("*.tmp"))


def test_an_output_that_cannot_be_written_is_exit_4_and_keeps_the_checkpoint(scenes_dir, tmp_path, monkeypatch,
                                                                            capsys):  # fmt: skip
    from warpsph.io.results import ResultsWriter

    write_frame = ResultsWriter.write_frame
    written = []

    def disk_fills(self, *args, **kwargs):
        if len(written) == 3:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        written.append(1)
        return write_frame(self, *args, **kwargs)

    monkeypatch.setattr(ResultsWriter, "write_frame", disk_fills)
    args = ["run", str(scenes_dir / "wave_column.toml"), "--out", str(tmp_path), "--end-time", "0.1", "--no-progress"]
    assert main(args) == EXIT_OUTPUT
    line = only_line(capsys.readouterr().err)
    assert "No space left on device" in line and "the last checkpoint" in line
    assert load_checkpoint(tmp_path / "checkpoint.h5").step > 0
    assert json.loads((tmp_path / "run.json").read_text())["status"] == "failed"
    assert not list(tmp_path.glob("*.tmp")) and len(load_results(tmp_path / "results.h5")) == 3
    monkeypatch.undo()  # room on the disk again: the directory is free and the run continues
    assert main([*args, "--resume"]) == 0


def test_run_directory_errors(scenes_dir, tmp_path, capsys):
    scene = str(scenes_dir / "wave_column.toml")
    (tmp_path / "a_file").write_text("")
    assert main(["run", scene, "--out", str(tmp_path / "a_file")]) == EXIT_BAD_INPUT
    assert "is a file, not a directory" in only_line(capsys.readouterr().err)
    assert main(["run", scene, "--out", str(tmp_path / "a_file" / "run")]) == EXIT_OUTPUT
    assert "cannot write there" in only_line(capsys.readouterr().err)
    with pytest.raises(OutputError):
        RunDirectory(tmp_path / "a_file" / "run")


@pytest.mark.parametrize("device, message", [("gpu", "not a Warp device name; accepted: cpu, cuda, cuda:N"),
                                             ("cpu:1", "not a Warp device name"), ("cuda:7", "cuda:7")])
def test_a_device_not_here_is_exit_5(scenes_dir, tmp_path, capsys, device, message):
    import warp as wp

    if device == "cuda:7" and wp.get_cuda_device_count() > 7:
        pytest.skip("this machine has a cuda:7")
    args = ["run", str(scenes_dir / "wave_column.toml"), "--out", str(tmp_path), "--device", device]
    assert main(args) == EXIT_DEVICE
    assert message in only_line(capsys.readouterr().err)
    assert not (tmp_path / "results.h5").exists()


def test_version_and_a_quiet_api(tmp_path):
    result = subprocess.run([sys.executable, "-m", "warpsph", "--version"], capture_output=True, text=True)
    assert result.returncode == 0 and result.stdout.startswith(f"warpsph {warpsph.__version__} (warp-lang ")
    assert {"run_scene", "Run", "Solver", "build", "load_results"} <= set(dir(warpsph))
    script = ("import warpsph; s = warpsph.load_scene(r'{}', {{'output.usd': False}}); "
              "warpsph.run_scene(s, r'{}', end_time=0.002)").format(
        os.path.join(os.path.dirname(__file__), "..", "scenes", "wave_column.toml"), tmp_path / "out")  # fmt: skip
    quiet = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=600)
    assert quiet.returncode == 0, quiet.stderr
    assert quiet.stdout == "" and quiet.stderr == ""
    loud = subprocess.run([sys.executable, "-c", script.replace("out'", "loud'")], capture_output=True, text=True,
                          timeout=600, env={**os.environ, "WARPSPH_VERBOSE": "1"})  # fmt: skip
    assert "Warp " in loud.stdout + loud.stderr
