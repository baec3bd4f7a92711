"""The energy ledger (warpsph.stages.energy): the step's kernels book every energy they exchange, the
balance closes where the discretisation conserves energy, a run writes it and its guard stops a run
whose steps make energy."""

import json
from pathlib import Path

import numpy as np
import pytest
import warp as wp

from warpsph.builder import build
from warpsph.errors import SimulationError
from warpsph.io import load_checkpoint, load_results
from warpsph.runner import ENERGY_GROWTH, ENERGY_MADE_LIMIT, GUARD_WINDOW, Run
from warpsph.scene_toml import load_scene
from warpsph.solver import Solver
from warpsph.stages.energy import (
    GRAVITY, LEDGER, NOT_FOUND, SIGNS, _growth_kernel, balance_warnings, energy_balance, energy_made,
)

SCENES = Path(__file__).resolve().parents[1] / "scenes"


def wave_column():
    return load_scene(SCENES / "wave_column.toml").validate()


def balance_after(scene, steps: int) -> dict[str, float]:
    model, state = build(scene)
    scratch = model.state()
    scratch.assign(state)
    solver = Solver(model)
    start = solver.energy.sums(state)
    t, dt = 0.0, scene.time_step
    for _ in range(steps):
        solver.step(state, scratch, t, dt)
        state, scratch = scratch, state
        t += dt
    return energy_balance(solver.energy.sums(state), start)


def test_wave_column_balance_closes_within_one_percent():
    """The 5 kPa step on the elastic column, past the front's reflection at the base (300 steps, 0.107 s):
    the load's work goes into equal kinetic and strain energies while the front runs down, and the
    balance closes within 1 %."""
    balance = balance_after(wave_column(), 300)
    print(balance)
    assert balance["boundary_work"] > 0.0 and balance["strain"] > 0.0
    assert balance["error_ratio"] < 0.01
    assert balance_warnings(balance) == []


def test_warnings_name_the_failed_check():
    balance = {"strain": 1.0, "stabilisation_dissipation": 0.2, "error": 0.05, "error_ratio": 0.05}
    lines = balance_warnings(balance)
    assert len(lines) == 2 and "0.2 times the strain energy" in lines[0] and "5 %" in lines[1]
    assert balance_warnings({**balance, "stabilisation_dissipation": 0.05, "error_ratio": 0.005}) == []
    with pytest.raises(KeyError):
        balance_warnings({})


def test_energy_made_counts_only_energy_from_nothing():
    start = np.zeros(10)
    start[:2] = (1.0, 3.0)  # kinetic and strain energy at the start
    held = {"kinetic": 1.0, "strain": 1.0, "plastic_dissipation": 0.0, "viscous_dissipation": 0.0,
            "stabilisation_dissipation": 0.0, "damping_dissipation": 0.0}
    given = {"gravity_work": 1.0, "boundary_work": 0.0, "rigid_load_work": 0.0, "pore_water_work": 0.0}
    balance = {**held, **given, "error": 1.0}
    assert energy_made(balance, 0.0, start) == pytest.approx(0.25)  # of the 4 J stored at the start
    assert energy_made(balance, 0.5, start) == pytest.approx(0.125)  # made since the error was 0.5 J
    assert energy_made({**balance, "error": -1.0}, 0.0, start) == 0.0  # energy lost is not made
    assert energy_made(balance, 0.0, np.zeros(10)) == pytest.approx(0.5)  # of the 2 J turned over


def test_the_device_guard_measures_as_energy_made():
    """The guard's window on the device (:class:`EnergyGuard`'s kernel) measures the energy made as
    :func:`energy_made` does, and keeps the first step at which three windows grew past its limits: the
    kinetic energy rises by 1 J over 4 J stored while gravity gives 1 J less the balance's error."""
    wp.init()
    start = np.zeros(10)
    start[:2] = (1.0, 3.0)
    arrays = [wp.array(a, dtype=wp.float64, device="cpu") for a in (start, SIGNS, np.zeros(5), np.zeros(3))]
    start_d, signs, progress, what = arrays
    found = wp.array([NOT_FOUND], dtype=wp.int32, device="cpu")
    errors = [0.1, 0.3, 0.7, 1.5]  # the balance's error after each window [J]: windows of 0.1, 0.2, 0.4, 0.8 J
    for step, error in enumerate(errors, start=1):
        now = start.copy()
        now[0] += 1.0
        now[LEDGER + GRAVITY] = 1.0 - error
        wp.launch(_growth_kernel, 1, [step, wp.array(now, dtype=wp.float64, device="cpu"), start_d, signs,
                                      wp.float64(0.05), wp.float64(2.0), progress, found, what], device="cpu")  # fmt: skip
        since = errors[step - 2] if step > 1 else 0.0
        made = energy_made(energy_balance(now, start), since, start)
        assert progress.numpy()[3] == pytest.approx(error - since)
        if step == 3:
            assert what.numpy() == pytest.approx([0.4, made, 4.0])  # 0.4 J, 10 % of the 4 J stored, 4 × 0.1 J
    assert int(found.numpy()[0]) == 3


def test_a_run_writes_its_balance_and_resumes_it(tmp_path):
    """The series every 10 steps (where the run guard reads the balance), the phase's balance in
    run.json, and the ledger in the checkpoint: a run stopped part-way and resumed writes the same
    balance as one run through."""
    scene = wave_column()
    scene.simulation.end_time = 60 * scene.time_step
    scene.output.frame_interval = 20 * scene.time_step
    Run(scene, tmp_path / "whole").run()
    Run(scene, tmp_path / "parts", end_time=35 * scene.time_step).run()
    Run(scene, tmp_path / "parts", resume=True).run()
    whole, parts = (load_results(tmp_path / name / "results.h5") for name in ("whole", "parts"))
    for name in ("energy_kinetic", "energy_strain", "energy_boundary_work", "energy_error"):
        (t, value), (t_parts, value_parts) = whole.series(name), parts.series(name)
        assert len(t) == 6 and np.array_equal(t, t_parts) and np.array_equal(value, value_parts), name
    record = json.loads((tmp_path / "whole" / "run.json").read_text())
    assert record["phases"][0]["energy_warnings"] == []
    balance = record["phases"][0]["energy"]
    assert balance["boundary_work"] == pytest.approx(whole.series("energy_boundary_work")[1][-1])
    assert balance["boundary_work"] > 0.0 and balance["error_ratio"] < 0.01
    assert "energy_ledger" in load_checkpoint(tmp_path / "whole" / "checkpoint.h5").arrays


def test_the_guard_stops_steps_that_make_energy(tmp_path):
    """The wave column at Courant 2, beyond the integrator's stability limit (the scene is changed after
    validation, which refuses it): its odd-even mode makes energy from step 3 on, 0.016, 0.022 and
    0.076 J over steps 3-4, 5-6 and 7-8, the last 12 % of the energy in play; the guard stops the run at
    step 8, within 5 steps of the growth's start, where the speed bound alone let it run to step 62
    and 17.5 MPa. The checkpoint kept, from step 6, is still below the load's first overshoot. The
    stable run at Courant 1.5 makes none."""
    scene = wave_column()
    scene.simulation.courant = 2.0
    scene.output.frame_interval = GUARD_WINDOW * scene.time_step
    with pytest.raises(SimulationError) as info:
        Run(scene, tmp_path / "unstable", end_time=200 * scene.time_step).run()
    message = str(info.value)
    print(message)
    assert "unstable at step 8," in message and "\n" not in message
    assert f"the energy made from nothing grew over three windows of {GUARD_WINDOW} steps" in message
    assert f"(limit {100 * ENERGY_MADE_LIMIT:g} %) and 4.67 times the first's (limit {ENERGY_GROWTH:g})" in message
    checkpoint = load_checkpoint(tmp_path / "unstable" / "checkpoint.h5")
    assert checkpoint.step == 6 and np.abs(checkpoint.arrays["particle_stress"]).max() < 2 * 5000.0
    scene.simulation.courant = 1.5
    assert Run(scene, tmp_path / "stable", end_time=200 * scene.time_step).run().status == "finished"
