"""Probes between frames copy from the device only the particles they read (docs/output.md,
*Probes*): the same values as from every particle's fields, from a small fraction of them."""

import numpy as np

from warpsph.builder import build
from warpsph.probes import Probes
from warpsph.runner import host_fields
from warpsph.scene_toml import load_scene
from warpsph.solver import Solver


def test_probes_read_only_their_particles(scenes_dir):
    scene = load_scene(scenes_dir / "undrained_footing.toml")  # point, region_mean and reaction probes
    model, state = build(scene, device="cpu")
    solver, scratch = Solver(model), model.state()
    scratch.assign(state)
    for k in range(3):
        solver.step(state, scratch, k * scene.time_step, scene.time_step)
        state, scratch = scratch, state
    probes = Probes(model)
    assert probes.rows is not None and len(probes.rows) < 0.2 * model.particle_count
    contact = solver.rigid.contact_forces()
    whole = probes.sample(host_fields(model, state), contact)
    part = probes.sample(host_fields(model, state, probes.rows), contact, probes.rows)
    assert list(whole) == [p.name for p in scene.probes]
    for name in whole:
        assert part[name] == whole[name] or (np.isnan(part[name]) and np.isnan(whole[name])), name


def test_a_probe_over_every_particle_reads_them_all(scenes_dir):
    scene = load_scene(scenes_dir / "column_collapse.toml")  # the front: a maximum over all particles
    model, _ = build(scene, device="cpu")
    assert Probes(model).rows is None
