"""The K0 procedure: geostatic effective stresses, no step (docs/scenes.md, *Phases*)."""

from __future__ import annotations

import numpy as np

from warpsph.initial_stress import geostatic_stress, geostatic_unit_weight
from warpsph.phases.base import Calculation
from warpsph.phases.staging import CONVERGED


class K0Procedure(Calculation):
    """Geostatic effective stresses of every active body at once: σ′_v from the (buoyant, with pore
    water) weight above each particle in its column, σ′_h = K0 σ′_v."""

    def prepare(self) -> None:
        run = self.run
        m, scene = run.model, run.phase_scene
        mats = list(scene.materials.values())
        material = m.particle_material.numpy()[: m.particle_count]
        gravity, pore_water = scene.simulation.gravity, m.pore is not None
        unit_weight = np.array([geostatic_unit_weight(mt, gravity, pore_water) for mt in mats])[material]
        k0 = np.array([mt.earth_pressure_at_rest for mt in mats])[material]
        stress = run.state.particle_stress.numpy()
        stress[: m.particle_count] = geostatic_stress(m.particle_x0, unit_weight, k0, m.dx)
        run.state.particle_stress.assign(stress)

    def calculate(self, progress) -> str:
        return CONVERGED
