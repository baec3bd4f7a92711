"""Carrying a run's state from one phase's model to the next (docs/scenes.md, *Phases*).

Particles keep their identity across phases by their lattice point: every body of the scene is filled
once, in the builder's order, and a particle's id is its row in that union. A phase's model holds the
active bodies' particles; those it shares with the phase before take over their fields (position,
velocity, stress, density, pore pressure, plastic strain; the virtual points their position and
density), the newly activated ones keep the state the builder gives them.
"""

from __future__ import annotations

import numpy as np

from warpsph.builder import merge_unique
from warpsph.lattice import fill_body, fill_cells, lattice_codes
from warpsph.model import Model, State
from warpsph.phases.staging import phase_scene
from warpsph.scene import Scene


def lattice_rows(reference: np.ndarray, points: np.ndarray, dx: float) -> np.ndarray:
    """For each of the (M,3) lattice ``points``, its row in the (N,3) ``reference`` points, or −1."""
    keys_ref, keys = lattice_codes(reference, dx), lattice_codes(points, dx)
    if not len(keys):
        return np.zeros(0, dtype=np.int64)
    both, inverse = np.unique(np.concatenate([keys_ref, keys]), return_inverse=True)
    inverse = inverse.reshape(-1)
    row_of = np.full(len(both), -1, dtype=np.int64)
    row_of[inverse[: len(keys_ref)][::-1]] = np.arange(len(keys_ref))[::-1]  # the first row of a repeated key
    return row_of[inverse[len(keys_ref):]]


class ParticleIds:
    """Ids of the real particles and virtual points over all the scene's bodies."""

    def __init__(self, scene: Scene):
        sim = scene.simulation
        self.dx = sim.dx
        self.real, _ = merge_unique([fill_body(b, sim.dx, sim.dim) for b in scene.bodies], sim.dx)
        self.virtual, _ = merge_unique([fill_cells(b, sim.dx, sim.dim) for b in scene.bodies], sim.dx)

    def of(self, points: np.ndarray) -> np.ndarray:
        """Ids of a model's (N,3) lattice ``points`` (its ``particle_x0``)."""
        return lattice_rows(self.real, points, self.dx)

    def of_virtual(self, points: np.ndarray) -> np.ndarray:
        """Ids of a model's virtual points from their (M,3) initial positions."""
        return lattice_rows(self.virtual, points, self.dx)


def phase_particles(scene: Scene) -> list[np.ndarray]:
    """Each phase's particles (N_k,3) [m]: the lattice points of the bodies active in it."""
    out = []
    for index in range(len(scene.phases)):
        staged = phase_scene(scene, index)
        dx, dim = staged.simulation.dx, staged.simulation.dim
        out.append(merge_unique([fill_body(b, dx, dim) for b in staged.bodies], dx)[0])
    return out


def _virtual_ids(ids: ParticleIds, model: Model) -> np.ndarray:
    return ids.of_virtual(model.virtual_origin.numpy()[: model.virtual_count]) if model.virtual_count else np.zeros(0)


def carry_state(ids: ParticleIds, old: Model, old_state: State, new: Model, new_state: State,
                old_origin: np.ndarray) -> np.ndarray:  # fmt: skip
    """Copy the fields of the particles ``new`` shares with ``old`` into ``new_state`` (owned rows; the
    ghosts follow at the next step) and return the new model's displacement origins (N,3) [m]: the
    carried particles keep theirs (``old_origin``), new ones start from their lattice point."""
    origin = new.particle_x0.copy()
    src = _rows(old.particle_ids, new.particle_ids)
    take = src >= 0
    for name, arr in new_state.arrays().items():
        if name.startswith("virtual_"):
            continue
        before = getattr(old_state, name)
        if before is None:
            continue
        values = arr.numpy()
        values[: new.particle_count][take] = before.numpy()[: old.particle_count][src[take]]
        arr.assign(values)
    origin[take] = old_origin[src[take]]
    if new.virtual_count and old.virtual_count:
        vsrc = _rows(_virtual_ids(ids, old), _virtual_ids(ids, new))
        vtake = vsrc >= 0
        for name in ("virtual_q", "virtual_density"):
            values = getattr(new_state, name).numpy()
            values[: new.virtual_count][vtake] = getattr(old_state, name).numpy()[: old.virtual_count][vsrc[vtake]]
            getattr(new_state, name).assign(values)
    return origin


def _rows(old_ids: np.ndarray, new_ids: np.ndarray) -> np.ndarray:
    """For each id of ``new_ids``, its row in ``old_ids`` or −1."""
    order = np.argsort(old_ids, kind="stable")
    pos = np.clip(np.searchsorted(old_ids[order], new_ids), 0, max(len(old_ids) - 1, 0))
    if not len(old_ids):
        return np.full(len(new_ids), -1, dtype=np.int64)
    found = old_ids[order][pos] == new_ids
    return np.where(found, order[pos], -1)
