"""Consolidation: the coupled quasi-static response of soil and its pore water in implicit time steps,
by the fixed-stress split (docs/method.md, *Consolidation*).
"""

from __future__ import annotations

from typing import Callable

import numpy as np
import warp as wp

from warpsph.model import Model, State
from warpsph.stages.groundwater import GroundwaterFlow

ITERATION_TOLERANCE = 0.05
"""The fixed-stress iteration has converged when its iterates' pressures differ by less than this
fraction of the largest change a step may make (or by the phase's pressure tolerance) [-]."""
MAX_ITERATIONS = 30
"""Fixed-stress iterations of one step before it is retried with half the time step."""
STEP_CHANGE = 0.02
"""Accuracy of a step: the largest change of pore pressure it may make off the held rows, as a
fraction of the excess pore pressure that remains (the largest at the step's start or end) [-] (a step
that changes more is retried shorter; backward Euler's error in time is about proportional to it)."""


class FixedStressSplit:
    """One consolidation step at a time on ``model``: ``flow`` (the phase's
    :class:`~warpsph.stages.groundwater.GroundwaterFlow`) and ``equilibrate(t)``, which brings the
    skeleton to equilibrium under the state's pore pressures with the loads at time ``t`` and returns
    (converged, the state it left); ``state()`` gives the current state. The steps' interface is the
    flow's: :meth:`solve`, :meth:`undo`, ``step_change``, ``discharge``, ``storage_rate``."""

    def __init__(self, model: Model, solver, flow: GroundwaterFlow,
                 equilibrate: Callable[[float], tuple[bool, State]], state: Callable[[], State]):  # fmt: skip
        self.model, self.solver, self.flow = model, solver, flow
        self.equilibrate, self.state = equilibrate, state
        n, dim = model.particle_count, model.spec.dim
        materials = list(model.scene.materials.values())
        drained = np.array([m.lame_lambda + 2.0 * m.shear_modulus / dim for m in materials])
        self.compliance = 1.0 / drained[model.particle_material.numpy()[:n]]
        """1/K_d of each particle's material [1/Pa]."""
        self.saved = model.state()
        self.start_pressure = wp.zeros(n, dtype=wp.float64, device=model.device)
        self.iterations = 0
        """Fixed-stress iterations of the last step."""
        self.collapsed = False
        """The skeleton did not reach equilibrium in the last step (within the phase's step cap)."""
        self.step_change = 0.0
        """The last step's largest pressure change over STEP_CHANGE × the excess that remains [-]."""

    @property
    def discharge(self) -> dict[str, float]:
        return self.flow.discharge

    @property
    def storage_rate(self) -> float:
        return self.flow.storage_rate

    def _strain(self, state: State) -> np.ndarray:
        return -np.log(state.particle_density.numpy()[: self.model.particle_count].astype(np.float64))

    def solve(self, t: float, dt: float) -> bool:
        """Advance the state to time ``t`` by one step of ``dt`` [s]; False, with the state put back, if
        the iteration did not converge or the skeleton did not reach equilibrium (``collapsed``)."""
        n, flow = self.model.particle_count, self.flow
        state = self.state()
        self.saved.assign(state)
        wp.copy(self.start_pressure, state.particle_pore_pressure, count=n)
        start = self.start_pressure.numpy()
        # the first iterate's skeleton carries the boundary's pressures at t: on a drained face that
        # takes its load alone, held at the pressure before it, the stress a face particle is given and
        # its pore pressure would not sum to the load
        flow.state = state
        flow.hold_prescribed(t)
        strain_start = self._strain(state)
        self._seeping = flow.seeping.copy()
        self.collapsed = False
        relaxation, last_residual = 1.0, None
        for iteration in range(1, MAX_ITERATIONS + 1):
            self.iterations = iteration
            converged, state = self.equilibrate(t)
            if not converged:
                self.collapsed = True
                break
            flow.state = state
            self.solver.fit_geometry(state)
            saturation = flow.saturation_field()
            storage = saturation * saturation * self.compliance
            held = state.particle_pore_pressure.numpy()[:n].astype(np.float64)
            flow.coupling_storage.assign(storage)
            flow.coupling_source.assign(storage * held - saturation * (self._strain(state) - strain_start))
            if not flow.solve(t, dt, start=self.start_pressure):
                break
            pressure = state.particle_pore_pressure.numpy()[:n].astype(np.float64)
            residual = pressure - held
            change = float(np.max(np.abs(residual), initial=0.0))
            # steps and iterations sized on what remains to dissipate: on the phase's largest excess, the
            # late steps of a decaying excess grew until backward Euler's lag in the decay, and the
            # iterations' error summed over the steps, were a growing share of it
            remaining = max(float(np.max(np.abs(start), initial=0.0)), float(np.max(np.abs(pressure), initial=0.0)),
                            flow.tolerance)  # fmt: skip
            if change < max(flow.tolerance, ITERATION_TOLERANCE * STEP_CHANGE * remaining):
                self.step_change = flow.largest_change / (STEP_CHANGE * remaining)
                return True
            relaxation = self._relaxation(residual, relaxation, last_residual)
            last_residual = residual
            relaxed = np.where(flow.dirichlet.numpy() == 1, pressure, held + relaxation * residual)
            p = state.particle_pore_pressure
            p.assign(np.concatenate([relaxed, p.numpy()[n:]]))
        self.undo()
        return False

    @staticmethod
    def _relaxation(residual: np.ndarray, relaxation: float, last: np.ndarray | None) -> float:
        """Aitken's dynamic relaxation of the iterates, ω ← −ω r_k·(r_{k+1} − r_k)/|r_{k+1} − r_k|²
        (r the change the split's step makes), kept in [0.1, 4]: it turns the geometric tail of a
        nearly undrained step into a few iterations."""
        if last is None:
            return 1.0
        difference = residual - last
        norm = float(difference @ difference)
        if norm == 0.0:
            return relaxation
        return float(np.clip(-relaxation * float(last @ difference) / norm, 0.1, 4.0))

    def undo(self) -> None:
        """Put the state (skeleton and pore pressures) back to the start of the last step."""
        self.state().assign(self.saved)
        self.flow.seeping = self._seeping.copy()
