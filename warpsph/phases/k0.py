"""The K0 procedure: geostatic effective stresses, no step (docs/scenes.md, *Phases*)."""

from __future__ import annotations

import numpy as np

from warpsph.initial_stress import geostatic_stress, geostatic_unit_weight, overburden
from warpsph.phases.base import Calculation
from warpsph.phases.staging import CONVERGED
from warpsph.solver import carried_pore_pressure


class K0Procedure(Calculation):
    """Geostatic effective stresses of every active body at once: σ′_v = σ_v + χ p_w, the total weight
    above each particle in its column (with the free water on a submerged column) less the part χ p_w
    of the pore pressures the phase starts from that the total stress carries; σ′_h = K0 σ′_v."""

    def prepare(self) -> None:
        run = self.run
        m, scene = run.model, run.phase_scene
        mats = list(scene.materials.values())
        material = m.particle_material.numpy()[: m.particle_count]
        gravity = scene.simulation.gravity
        unit_weight = np.array([geostatic_unit_weight(mt, gravity, False) for mt in mats])[material]
        k0 = np.array([mt.earth_pressure_at_rest for mt in mats])[material]
        if m.pore is None:
            vertical = overburden(m.particle_x0, unit_weight, m.dx)
        else:
            vertical = self._effective_vertical(unit_weight, material)
        stress = run.state.particle_stress.numpy()
        stress[: m.particle_count] = geostatic_stress(vertical, k0)
        run.state.particle_stress.assign(stress)

    def _effective_vertical(self, unit_weight: np.ndarray, material: np.ndarray) -> np.ndarray:
        """σ′_v = σ_v + χ p_w [Pa] under the state's total pore pressures p_w: σ_v the soil's weight above
        each particle and the free water on a column whose top is under water (p_w > 0 there); χ = 1 at
        p_w ≥ 0, under suction Bishop's S_e or 0 (``pressure.suction``), as held pore pressures."""
        m, state = self.run.model, self.run.state
        pw, n = m.pore, m.particle_count
        positions = state.particle_q.numpy()[:n].astype(float)
        hydrostatic = pw.hydrostatic(positions, pw.water.density.numpy()[material])
        held = carried_pore_pressure(m, state).numpy()  # the excess whose total is χ p_w
        total = state.particle_pore_pressure.numpy()[:n] + hydrostatic
        weight = overburden(m.particle_x0, unit_weight, m.dx, surface_load=np.maximum(total, 0.0))
        return weight + held + hydrostatic

    def calculate(self, progress) -> str:
        return CONVERGED
