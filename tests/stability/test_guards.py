"""Run guards (issue 6, item 9): a blow-up is caught within one step, both schemes.

- **Courant 5** (the shipped wave column; validation accepts C ≤ 1.5, so the scene is changed after
  it is validated and run through :class:`warpsph.runner.Run`), with the default speed bound (the
  P-wave speed) and with none (``velocity_limit = inf``): the run raises one :class:`SimulationError`
  whose one-line message names the step, the time and the first bad particle and what is wrong with
  it; the step is the first whose fields are non-finite (density included: it overflows a step or two
  before the velocity), whose density is not positive (the collocated blow-up freezes at finite values
  with negative densities) or too fast, found by replaying the run in memory, unless the energy
  balance's growth stops the run before any field is bad; the checkpoint and the frames on disk are
  from earlier steps and finite; run.json records the failure.
- **Velocity limit** through the command line (``simulation.velocity_limit`` below the 0.021 m/s the
  5 kPa step gives the top): exit code 1, one line on stderr naming the step, the time, the particle
  and the limit, at the first step beyond it.
"""

import json
import math
import subprocess
import sys

import numpy as np
import pytest
from stability_tools import SCENES, SCHEMES, march

from warpsph.builder import build
from warpsph.errors import SimulationError
from warpsph.io import load_checkpoint, load_results
from warpsph.runner import CHECK_EVERY, Run
from warpsph.scene_toml import load_scene
from warpsph.stages.guard import LARGEST_SPEED, Guard


def wave_column(scheme: str):
    scene = load_scene(SCENES / "wave_column.toml")
    scene.simulation.scheme = scheme
    return scene.validate()


def first_bad_step(scene, limit: float, steps: int) -> int | None:
    """Replay ``scene`` in memory: the first step after which a particle's position, velocity, stress or
    density is not finite, its density is not positive or its speed exceeds ``limit`` [m/s], or a
    virtual point's position or density is not finite or its density not positive."""
    found = []

    def observe(k, model, state):
        n = model.particle_count
        fields = [state.particle_q.numpy()[:n], state.particle_v.numpy()[:n], state.particle_stress.numpy()[:n],
                  state.particle_density.numpy()[:n]]
        densities = [fields[3]]
        if state.virtual_q is not None:
            count = model.virtual_count
            fields += [state.virtual_q.numpy()[:count], state.virtual_density.numpy()[:count]]
            densities.append(fields[5])
        bad = (not all(np.all(np.isfinite(f)) for f in fields) or any(np.any(d <= 0.0) for d in densities)
               or np.linalg.norm(fields[1], axis=1).max() > limit)  # fmt: skip
        if bad and k > 0:
            found.append(k)
        return not bad

    march(scene, steps, observe)
    return found[0] if found else None


def test_a_bad_virtual_point_is_found():
    """The guard checks the virtual points too: a blow-up can reach their densities first."""
    model, state = build(wave_column("two_set"))
    guard = Guard(model, LARGEST_SPEED)
    assert guard.find(state) == (None, None)
    density = state.virtual_density.numpy()
    density[[7, 9]] = (np.nan, -1.0)
    state.virtual_density.assign(density)
    assert guard.find(state) == (None, 7)


def step_in(message: str) -> int:
    return int(message.split("unstable at step ")[1].split(",")[0])


@pytest.mark.parametrize("limit", [None, math.inf], ids=["p_wave_speed", "no_limit"])
@pytest.mark.parametrize("scheme", SCHEMES)
def test_courant_5_stops_within_a_step_and_keeps_its_output(scheme, limit, tmp_path):
    scene = wave_column(scheme)
    scene.simulation.velocity_limit = limit
    scene.simulation.courant = 5.0
    scene.output.frame_interval = 2 * scene.time_step
    with pytest.raises(SimulationError) as info:
        Run(scene, tmp_path, end_time=500 * scene.time_step).run()
    message = str(info.value)
    print(f"\n{scheme}, C = 5, velocity_limit = {limit}: {message}")
    step = step_in(message)
    assert "\n" not in message and f"t = {step * scene.time_step:.6g} s" in message
    bad = first_bad_step(scene, min(scene.speed_limit, LARGEST_SPEED), step + 1)
    if "the energy made from nothing grew" in message:  # the balance's guard: before any field is bad
        assert bad is None
    else:
        assert "particle " in message or "virtual point " in message
        assert step == bad
    if limit is None and "moves at" in message:
        assert f"beyond the largest P-wave speed {scene.max_p_wave_speed:.4g} m/s" in message
    checkpoint = load_checkpoint(tmp_path / "checkpoint.h5")
    assert checkpoint.step < step and f"checkpoint (step {checkpoint.step})" in message
    assert all(np.all(np.isfinite(a)) for a in checkpoint.arrays.values())
    results = load_results(tmp_path / "results.h5")
    assert len(results) >= 1 and results.steps[-1] < step
    assert np.all(np.isfinite(results.frame(len(results) - 1)["stress"]))
    record = json.loads((tmp_path / "run.json").read_text())
    assert record["status"] == "failed" and record["message"] == message


@pytest.mark.parametrize("scheme", SCHEMES)
def test_velocity_limit_through_the_command_line(scheme, tmp_path):
    limit = 0.015
    text = (SCENES / "wave_column.toml").read_text().replace(
        'scheme = "two_set"', f'scheme = "{scheme}"\nvelocity_limit = {limit}')
    path = tmp_path / "limited.toml"
    path.write_text(text)
    result = subprocess.run([sys.executable, "-m", "warpsph", "run", str(path), "--out", str(tmp_path / "out"),
                             "--no-progress", "--end-time", "0.05"], capture_output=True, text=True, timeout=600)
    lines = result.stderr.strip().splitlines()
    print(f"\n{scheme}: exit {result.returncode}: {result.stderr.strip()}")
    assert result.returncode == 1 and len(lines) == 1 and "Traceback" not in result.stderr
    assert f"beyond simulation.velocity_limit = {limit:g} m/s" in lines[0] and "particle " in lines[0]
    scene = load_scene(path)
    step = step_in(lines[0])
    assert step == first_bad_step(scene, limit, step + 1)
    assert load_checkpoint(tmp_path / "out" / "checkpoint.h5").step < step


def test_the_guards_read_the_device_only_at_the_output_cadence(tmp_path, monkeypatch):
    """The run guards mark bad steps on the device every step and are read every ``CHECK_EVERY`` steps
    and before each write (frames, probe samples, checkpoints): 200 steps with frames and probe samples
    every 50 read them at most 20 + 4 + 2 times, not 200."""
    scene = wave_column("two_set")
    scene.output.frame_interval = 50 * scene.time_step
    scene.output.probe_every = 50
    reads = []
    original = Guard.read
    monkeypatch.setattr(Guard, "read", lambda self: reads.append(1) or original(self))
    assert Run(scene, tmp_path, end_time=200 * scene.time_step).run().status == "finished"
    print(f"\n200 steps: {len(reads)} reads of the guard's flags")
    assert len(reads) <= 200 // CHECK_EVERY + 200 // 50 + 2
