"""Equilibrium phases: locally damped steps until the unbalanced-force ratio falls below the phase's
tolerance (docs/scenes.md, *Phases*)."""

from __future__ import annotations

import math

import numpy as np
import warp as wp

from warpsph.model import PLANE_TRACTION
from warpsph.phases.base import CHECK_EVERY, Calculation, Stopped
from warpsph.phases.staging import CONVERGED, NOT_CONVERGED
from warpsph.scene import Region


class Equilibrium(Calculation):
    """Damped steps to equilibrium under the phase's loads; the ratio reached is its criterion."""

    damped = True

    def __init__(self, run, phase):
        super().__init__(run, phase)
        self._load_scale = None  # the phase's constant parts of the applied force (applied_force)
        self.kinetic_energy = math.nan
        """The kinetic energy at the last check [J, J/m in 2D] (the mean over the steps since the one before)."""

    def calculate(self, progress) -> str:
        converged, ratio = self.equilibrate(progress, self.run.phase_start_step)
        self.run.records[-1].criterion = ratio
        return CONVERGED if converged else NOT_CONVERGED

    def applied_force(self) -> float:
        """Σ m‖g‖ over the particles plus the loads' resultants at the phase's time [N/m or N]: the
        scale of the unbalanced-force ratio (docs/scenes.md, *Phases*)."""
        if self._load_scale is None:
            self._load_scale = self._applied_force_parts()
        total, loads = self._load_scale
        for resultant, time_function in loads:
            total += resultant * abs(time_function(self.run.phase_time))
        return total

    def _applied_force_parts(self) -> tuple[float, list]:
        """What :meth:`applied_force` needs that a phase does not change: Σ m‖g‖, and each traction
        plane's, force load's and force-driven plate's full resultant with its time function (a plate's
        moment as a force at its radius of gyration)."""
        m = self.run.model
        weight = float(np.sum(m.particle_mass.numpy()[: m.particle_count])) * float(np.linalg.norm(m.gravity))
        kinds, vectors = m.plane_kind.numpy(), m.plane_vector.numpy()
        loads = [(loaded_particles(m, p) * m.dx ** (m.spec.dim - 1) * float(np.linalg.norm(vectors[p])),
                  m.plane_functions[p]) for p in range(m.plane_count) if kinds[p] == PLANE_TRACTION]  # fmt: skip
        loads += [(float(np.linalg.norm(ld.force)), ld.time_function) for ld in self.run.phase_scene.loads
                  if ld.kind == "force" or (ld.kind == "plate" and ld.drive == "force")]  # fmt: skip
        plates = m.plates
        for p in np.nonzero(np.any(plates.moment * plates.spin_axes != 0.0, axis=1))[0]:
            # a moment as the force that turns the plate's particles at their radius of gyration
            gyration = math.sqrt(float(np.max(plates.inertia[p] * plates.spin_axes[p])) / plates.mass[p])
            loads.append((float(np.linalg.norm(plates.moment[p] * plates.spin_axes[p])) / gyration,
                          m.plane_functions[p]))  # fmt: skip
        return weight, loads

    def equilibrate(self, progress, first: int, output: bool = True, judge=None) -> tuple[bool, float]:
        """Damped steps from step ``first`` until the unbalanced-force ratio falls below the phase's
        tolerance (True) or its step cap is reached (False); also the last ratio. ``output``: write
        frames and checkpoints at their cadence (a safety trial writes its last frame only).
        ``judge``: a safety trial's :class:`~warpsph.phases.safety.TrialJudge`, whose ``settled`` decides
        where the ratio's fall ends the steps and which, called as ``judge(positions, k, kinetic energy)``
        in place of the step cap at each check that has not converged, is True where the steps end."""
        run, phase = self.run, self.phase
        frame_every, ck_every = run.cadence(True)
        ratio = run.loop.get("ratio", math.inf)
        stop = run.stop_step()
        while True:
            run.step()
            k = run.step_index - first
            converged = capped = False
            if k % CHECK_EVERY == 0:
                unbalanced, self.kinetic_energy = run.solver.damping.read()
                ratio = unbalanced / max(self.applied_force(), 1e-300)
                run.loop["ratio"] = ratio
                run.results.append_series("unbalanced_force_ratio", run.step_index, run.time, ratio)
                run.results.append_series("kinetic_energy", run.step_index, run.time, self.kinetic_energy)
                converged = ratio < phase.tolerance
                if judge is not None:  # a safety trial stands where it also stays at rest (TrialJudge.settled)
                    converged = judge.settled(converged, run.state.particle_q, k)
                if not converged and judge is None:
                    capped = k >= phase.max_steps
                elif not converged:
                    capped = judge(run.state.particle_q, k, self.kinetic_energy)
            stopped = stop is not None and run.step_index >= stop and k % CHECK_EVERY == 0
            if output:
                run.output(converged or capped or stopped, frame_every, ck_every)
            if progress is not None:
                progress(run.time, run.step_index)
            if converged or capped or stopped:
                if stopped and not (converged or capped):
                    raise Stopped()
                return converged, ratio
            if k % CHECK_EVERY == 0:  # where a checkpoint resumes bit-identical (a safety trial keeps none)
                run.stop_if_interrupted(checkpoint=output)


def loaded_particles(model, p: int) -> int:
    """The particles on traction plane ``p`` whose start lies inside its extent: those it loads (the
    kernels' ``traction_here``)."""
    on = np.any(model.constraint_planes.numpy().reshape(-1, 3) == p, axis=1)
    start = model.particle_origin.numpy()[model.constraint_particle.numpy()[on]]
    extent = Region(model.plane_extent_lo.numpy()[p], model.plane_extent_hi.numpy()[p])  # as built, grown
    return int(np.count_nonzero(extent.contains_on_face(start, int(model.plane_axis.numpy()[p]))))


def largest_displacement(positions: wp.array, start: np.ndarray) -> float:
    """The largest distance [m] of the owned particles' ``positions`` from their ``start`` (N,3)."""
    moved = positions.numpy()[: len(start)] - start
    return float(np.sqrt(np.max(np.sum(moved * moved, axis=1))))
