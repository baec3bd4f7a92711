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



def test_reaction_areas_are_the_planes_tributary_areas():
    """On a plane's lattice each particle stands for Δx^(dim−1), half of it at an edge (where the points
    end, at a gap too), a quarter at a corner: the trapezoidal rule; the areas follow an in-plane affine
    deformation A exactly (each scaled by det A), and a plane with no in-plane axis (1D) has unit area."""
    from warpsph.lattice import lattice_neighbours
    from warpsph.probes import tributary_areas

    dx = 0.25
    line = np.column_stack([np.array([0, 1, 2, 4, 5]) * dx, np.zeros(5), np.zeros(5)])  # a gap at 3 Δx
    areas = tributary_areas(1.1 * line, lattice_neighbours(line, dx, [0]), [0])
    assert np.allclose(areas, 1.1 * dx * np.array([0.5, 1, 0.5, 0.5, 0.5]))
    i, k = np.meshgrid(np.arange(4), np.arange(3), indexing="ij")
    patch = np.column_stack([i.ravel() * dx, np.full(12, 2.0), k.ravel() * dx])
    neighbours = lattice_neighbours(patch, dx, [0, 2])
    edges = (i.ravel() % 3 == 0).astype(int) + (k.ravel() % 2 == 0)
    undeformed = tributary_areas(patch, neighbours, [0, 2])
    assert np.allclose(undeformed, dx**2 * 0.5**edges) and np.isclose(undeformed.sum(), 6 * dx**2)
    shear = np.array([[1.02, 0.0, 0.03], [0.0, 1.0, 0.0], [-0.01, 0.0, 0.97]])
    deformed = tributary_areas(patch @ shear.T, neighbours, [0, 2])
    assert np.allclose(deformed, undeformed * (1.02 * 0.97 + 0.03 * 0.01))
    assert np.array_equal(tributary_areas(line[:2], lattice_neighbours(line[:2], dx, []), []), [1.0, 1.0])
