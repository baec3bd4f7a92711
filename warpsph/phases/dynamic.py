"""Dynamic phases: explicit steps for the phase's duration, or until the bodies come to rest
(docs/scenes.md, *Phases*)."""

from __future__ import annotations

import math

import numpy as np

from warpsph.phases.base import CHECK_EVERY, Calculation
from warpsph.phases.staging import AT_REST, FINISHED, STOPPED


class Dynamic(Calculation):
    """Undamped steps to the phase's duration (a scene without phases: to its end time), capped at
    ``max_steps``; with ``at_rest``, until the kinetic energy falls below that fraction of its peak."""

    def calculate(self, progress) -> str:
        run, phase = self.run, self.phase
        duration = phase.duration if run.staged else run.end_time
        n_end = max(run.step_index, run.phase_start_step + math.ceil(duration / run.dt - 1e-9))
        if run.staged:
            n_end = min(n_end, run.phase_start_step + phase.max_steps)
        stop = run.stop_step()
        if stop is not None and stop < n_end:
            n_end = max(run.step_index, stop)
        frame_every, ck_every = run.cadence(False)
        outcome = FINISHED if stop is None or stop >= n_end else STOPPED
        mass = run.model.particle_mass.numpy()[: run.model.particle_count]
        while run.step_index < n_end:
            run.step()
            k = run.step_index - run.phase_start_step
            at_rest = False
            if phase.at_rest > 0.0 and k % CHECK_EVERY == 0:
                v = run.state.particle_v.numpy()[: run.model.particle_count].astype(np.float64)
                energy = 0.5 * float(np.sum(mass * np.sum(v * v, axis=1)))
                peak = max(run.loop.get("peak_energy", 0.0), energy)
                run.loop["peak_energy"] = peak
                run.results.append_series("kinetic_energy", run.step_index, run.time, energy)
                at_rest = peak > 0.0 and energy < phase.at_rest * peak
                run.records[-1].criterion = energy / peak if peak > 0.0 else 0.0
            run.output(run.step_index == n_end or at_rest, frame_every, ck_every)
            if progress is not None:
                progress(run.time, run.step_index)
            if at_rest:
                return AT_REST
            run.stop_if_interrupted()
        return outcome
