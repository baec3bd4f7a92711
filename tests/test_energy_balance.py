"""The energy ledger (warpsph.stages.energy): the step's kernels book every energy they exchange, and
the balance closes where the discretisation conserves energy."""

from pathlib import Path

import pytest

from warpsph.builder import build
from warpsph.scene_toml import load_scene
from warpsph.solver import Solver
from warpsph.stages.energy import balance_warnings, energy_balance, stored_energies

SCENES = Path(__file__).resolve().parents[1] / "scenes"


def balance_after(scene, steps: int) -> dict[str, float]:
    model, state = build(scene)
    scratch = model.state()
    scratch.assign(state)
    solver = Solver(model)
    start = stored_energies(model, state)
    t, dt = 0.0, scene.time_step
    for _ in range(steps):
        solver.step(state, scratch, t, dt)
        state, scratch = scratch, state
        t += dt
    return energy_balance(model, state, solver.energy.totals(), start)


def test_wave_column_balance_closes_within_one_percent():
    """The 5 kPa step on the elastic column, past the front's reflection at the base (300 steps, 0.107 s):
    the load's work goes into equal kinetic and strain energies while the front runs down, and the
    balance closes within 1 % (measured 0.33 %; 0.7 % at most along the way)."""
    balance = balance_after(load_scene(SCENES / "wave_column.toml").validate(), 300)
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
