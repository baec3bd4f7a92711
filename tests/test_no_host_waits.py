"""The step waits on the host only where the run checks: no read of the device and no allocation in the
dry or the saturated step between the neighbour lists' checks (docs/performance.md, *Host waits*), and
a list that overflows between checks is reported, not used in silence."""

import collections
from pathlib import Path

import numpy as np
import pytest
import warp as wp

from warpsph.bench.throughput import block_scene, build
from warpsph.errors import SimulationError
from warpsph.io import load_checkpoint
from warpsph.runner import Run
from warpsph.scene_toml import load_scene
from warpsph.solver import NEIGHBOUR_CHECK_EVERY, Solver
from warpsph.sph.neighbours import NeighbourList
from warpsph.sph.spec import Spec

wp.config.quiet = True
SCENES = Path(__file__).resolve().parents[1] / "scenes"


@pytest.fixture
def counted(monkeypatch):
    """Counts of the device reads (``wp.array.numpy``) and allocations (``wp.array._init_new``) made
    while the fixture is active, by the name of the function that made them."""
    counts = {"reads": collections.Counter(), "allocations": collections.Counter()}
    numpy, new = wp.array.numpy, wp.array._init_new

    def caller():
        import inspect

        return inspect.stack()[2].function

    def counted_numpy(self):
        counts["reads"][caller()] += 1
        return numpy(self)

    def counted_new(self, *args, **kwargs):
        counts["allocations"][caller()] += 1
        return new(self, *args, **kwargs)

    monkeypatch.setattr(wp.array, "numpy", counted_numpy)
    monkeypatch.setattr(wp.array, "_init_new", counted_new)
    return counts


@pytest.mark.parametrize("effects", ["dry", "saturated"])
def test_steps_read_the_device_only_at_the_neighbour_check(effects, counted):
    """A 2D block of 1024 particles, dry and saturated: after a first step (which sizes the lists) and
    a check, the next ``NEIGHBOUR_CHECK_EVERY`` steps read nothing and allocate nothing; the step after
    them checks the lists itself, reading each list's marks, largest count and pairs (three reads)."""
    scene = block_scene(1024, 2, effects=effects)
    model, state = build(scene, "cpu", "float64")
    solver = Solver(model)
    a, b, dt = state, model.state(), scene.time_step
    solver.step(a, b, 0.0, dt)
    a, b = b, a
    solver.check_neighbours()
    for key in counted:
        counted[key].clear()
    for k in range(1, NEIGHBOUR_CHECK_EVERY + 1):
        solver.step(a, b, k * dt, dt)
        a, b = b, a
    print(f"\n{effects}: {NEIGHBOUR_CHECK_EVERY} steps: {dict(counted['reads'])} reads, "
          f"{dict(counted['allocations'])} allocations")
    assert not counted["reads"] and not counted["allocations"]
    solver.step(a, b, (NEIGHBOUR_CHECK_EVERY + 1) * dt, dt)
    lists = len(solver.neighbour_lists)
    assert lists == (3 if effects == "saturated" else 2)
    assert counted["reads"] == {"check": 2 * lists, "n_pairs": lists}, dict(counted["reads"])
    assert not counted["allocations"]


def test_a_list_that_overflows_between_checks_is_reported_and_grows():
    """Points crowded to half their spacing after the list was sized: the next build keeps each point's
    first ``width`` neighbours and no more pairs than ``indices`` holds, the check reports it, and the
    build after it sizes the room again and is whole."""
    spec = Spec(dim=2)
    rng = np.random.default_rng(3)
    spread = rng.uniform(0.0, 1.0, (400, 3)) * np.asarray(spec.axis_mask)
    nl = NeighbourList(spec, np.full(3, 1.0), 0.13, "cpu")
    x = wp.array(spread, dtype=spec.vec3, device="cpu")
    nl.build(x, 400, x, 400)
    assert not nl.check()
    width, room = nl.width, nl.indices.shape[0]
    crowded = wp.array(0.5 * spread, dtype=spec.vec3, device="cpu")
    nl.build(crowded, 400, crowded, 400)
    offsets = nl.offsets.numpy()
    assert np.all(np.diff(offsets[:401]) <= width) and offsets[400] <= room
    assert nl.check()
    nl.build(crowded, 400, crowded, 400)
    assert not nl.check() and nl.width > width
    d2 = ((0.5 * spread[None, :, :2] - 0.5 * spread[:, None, :2]) ** 2).sum(axis=-1)
    expected = (d2 < 0.13**2).sum(axis=1)  # the point itself included: two sets
    assert np.array_equal(np.diff(nl.offsets.numpy()[:401]), expected)


def test_the_solver_stops_where_a_list_overflowed():
    """A solver's check raises on an overflow with one line saying what happened."""
    scene = block_scene(256, 2)
    model, state = build(scene, "cpu", "float64")
    solver = Solver(model)
    solver.step(state, model.state(), 0.0, scene.time_step)
    solver.virtual_to_real.overflow.fill_(1)
    with pytest.raises(SimulationError, match="more neighbours than its list held"):
        solver.check_neighbours()


def test_a_run_stops_at_the_first_step_after_its_last_check(tmp_path, monkeypatch):
    """A run whose list overflows at step 25, between its checks at steps 20 and 30, stops as unstable
    from step 21, keeping the checkpoint of step 20."""
    scene = load_scene(SCENES / "wave_column.toml").validate()
    scene.output.frame_interval = 10 * scene.time_step
    scene.output.probe_every = 10  # the run checks every 10 steps, not at every probe sample
    step = Run.step

    def overflow_at_25(run):
        step(run)
        if run.step_index == 25:  # as the gather kernel marks it
            run.solver.virtual_to_real.overflow.fill_(1)

    monkeypatch.setattr(Run, "step", overflow_at_25)
    with pytest.raises(SimulationError) as info:
        Run(scene, tmp_path, end_time=100 * scene.time_step).run()
    print(f"\n{info.value}")
    assert "unstable at step 21," in str(info.value) and "more neighbours than its list held" in str(info.value)
    assert load_checkpoint(tmp_path / "checkpoint.h5").step == 20
