"""Only the effects a scene calls for: a dry elastic scene allocates no pore-pressure or plastic
array and launches no projection or plasticity kernel."""

import dataclasses

import numpy as np
import pytest

from warpsph.builder import build
from warpsph.launching import record_launches
from warpsph.scene_toml import load_scene
from warpsph.solver import Solver, SolverConfig, stage_names

FORBIDDEN = ("pressure", "projection", "pore", "plastic", "yield")


def test_dry_elastic_scene_runs_no_pore_water_or_plasticity(scenes_dir):
    scene = load_scene(scenes_dir / "wave_column.toml")
    assert not scene.effects.pore_water and not scene.effects.plasticity
    model, state = build(scene)
    allocated = list(state.arrays()) + [k for k, v in vars(model).items() if hasattr(v, "dtype")]
    assert not [name for name in allocated if any(word in name for word in FORBIDDEN)]
    solver = Solver(model)
    assert not [s for s in solver.stage_names if any(word in s for word in FORBIDDEN)]
    scratch = model.state()
    with record_launches() as launched:
        solver.step(state, scratch, 0.0, scene.time_step)
    assert launched, "the recorder saw no launch"
    assert not [k for k in launched if any(word in k.lower() for word in FORBIDDEN)]
    assert np.isfinite(scratch.particle_stress.numpy()).all()


def test_schemes_have_their_own_stages(scenes_dir):
    scene = load_scene(scenes_dir / "wave_column.toml")
    two_set = Solver(build(scene)[0]).stage_names
    scene.simulation.scheme = "collocated"
    model, state = build(scene)
    assert state.virtual_q is None and model.virtual_count == 0
    collocated = Solver(model).stage_names
    assert "taylor_half_step" in two_set and "taylor_half_step" not in collocated
    assert "runge_kutta" in collocated and "runge_kutta" not in two_set


def test_plastic_scene_launches_the_plastic_variant(scenes_dir):
    """The reverse: with effects.plasticity the Taylor steps are the plastic variant and ε̄ exists
    (on every real particle and ghost), still without pore-water arrays or kernels."""
    scene = load_scene(scenes_dir / "wave_column.toml")
    scene.effects = dataclasses.replace(scene.effects, plasticity=True)
    soil = scene.materials["soil"]
    soil.model, soil.cohesion = "viscoplastic", 1e3
    model, state = build(scene.validate())
    assert state.particle_plastic_strain.shape == (model.particle_total,)
    assert state.particle_pore_pressure is None and model.pore is None
    solver = Solver(model)
    scratch = model.state()
    with record_launches() as launched:
        solver.step(state, scratch, 0.0, scene.time_step)
    assert {"half_step_plastic_von_mises", "full_step_plastic_von_mises"} <= launched
    assert not [k for k in launched if any(word in k.lower() for word in ("pressure", "projection", "pore"))]
    assert np.isfinite(scratch.particle_plastic_strain.numpy()).all()


def test_only_an_equilibrium_phase_compiles_local_damping(scenes_dir):
    """The effects rule per phase: the damping stage and its kernel exist in an equilibrium phase's
    solver only."""
    scene = load_scene(scenes_dir / "wave_column.toml")
    model, state = build(scene)
    assert "local_damping" not in Solver(model).stage_names
    damped = Solver(model, damping=0.8)
    assert damped.stage_names[-1] == "local_damping"
    scratch = model.state()
    with record_launches() as launched:
        damped.step(state, scratch, 0.0, scene.time_step)
    assert any("local_damping" in k for k in launched)
    with record_launches() as launched:
        Solver(model).step(state, scratch, 0.0, scene.time_step)
    assert not any("damping" in k for k in launched)


def test_a_flow_phase_runs_the_groundwater_kernels_only(scenes_dir, tmp_path):
    """A flow phase launches no Taylor step (the skeleton is fixed) and a dynamic phase of the same
    saturated scene no groundwater kernel."""
    from warpsph.runner import Run
    from warpsph.scene import Phase

    scene = load_scene(scenes_dir / "terzaghi.toml")
    scene.output = dataclasses.replace(scene.output, usd=False, xdmf=False)
    scene.phases = [Phase(name="flow", kind="flow", duration=1.0, frames=1),
                    Phase(name="dynamic", kind="dynamic", duration=2 * scene.time_step)]  # fmt: skip
    run = Run(scene.validate(), tmp_path)
    with record_launches() as launched:
        run.calculation.calculate(None)
    assert any("assemble_flow" in k for k in launched) and any("retention_fields" in k for k in launched)
    assert not [k for k in launched if "step" in k.lower() or "projection" in k.lower()]
    run._enter_phase(1, (run.model, run.state, run.origin))
    with record_launches() as launched:
        run.calculation.calculate(None)
    assert any("half_step" in k for k in launched)
    assert not [k for k in launched if "flow" in k or "retention" in k]


def test_the_stage_list_is_read_in_one_place(scenes_dir):
    """stage_names gives a step's stages in order from the options alone; the solver runs that list."""
    scene = load_scene(scenes_dir / "terzaghi.toml")
    config = SolverConfig.of(scene)
    assert stage_names(config) == ["ghosts", "neighbours", "corrections", "taylor_half_step", "virtual_ghosts",
                                   "taylor_full_step", "prescribed_values", "pressure_projection", "boundary_work"]
    every = dataclasses.replace(config, particle_shifting=0.1, hourglass_control=0.1, virtual_density="real_motion",
                                damping=0.8, fixed_pore_pressure=True)  # fmt: skip
    assert stage_names(every) == ["ghosts", "neighbours", "corrections", "taylor_half_step", "virtual_ghosts",
                                  "shifting", "taylor_full_step", "hourglass_control", "virtual_continuity",
                                  "prescribed_values", "boundary_work", "local_damping"]  # fmt: skip
    assert stage_names(dataclasses.replace(config, scheme="collocated", pore_water=False)) == [
        "ghosts", "neighbours", "runge_kutta", "prescribed_values", "boundary_work"]
    damped = Solver(build(scene)[0], damping=0.8, pore_pressure="fixed")
    assert damped.stage_names == stage_names(damped.config) and damped.config.velocity_filter == 0.5
    with pytest.raises(dataclasses.FrozenInstanceError):
        damped.config.dx = 1.0
