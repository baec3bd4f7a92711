"""Groundwater flow phases: the steady seepage, or a transient in implicit steps, through the fixed
skeleton (docs/scenes.md, *Phases*)."""

from __future__ import annotations

import math

import numpy as np

from warpsph.phases.base import Calculation
from warpsph.phases.staging import CONVERGED, FINISHED, NOT_CONVERGED, STOPPED
from warpsph.stages.groundwater import GroundwaterFlow


MAX_FAILED_TRIES = 10
"""Consolidation tries in a row whose fixed-stress iteration fails (the step halved after each, to 1/1024 of
the first) after which the phase is stopped as unstable."""


class Flow(Calculation):
    """Groundwater flow through the fixed skeleton (:class:`~warpsph.stages.groundwater.GroundwaterFlow`):
    the steady state, or a transient of the phase's duration (:meth:`implicit_steps`)."""

    def build(self) -> None:
        run = self.run
        self.flow = GroundwaterFlow(run.model, run.solver, run.state, run.phase_scene.reservoirs, self.phase.tolerance,
                                    run.height(run.model.particle_x0))  # fmt: skip

    def calculate(self, progress) -> str:
        run, phase, flow, record = self.run, self.phase, self.flow, self.run.records[-1]
        if phase.steady:
            converged = flow.solve(0.0, None, max_iterations=phase.max_steps)
            run.step_index += flow.iterations
            run.summary.steps += flow.iterations
            self.series()
            record.criterion = flow.iterations
            run.write_frame()
            run.checkpoint()
            return CONVERGED if converged else NOT_CONVERGED
        return self.implicit_steps(flow, progress)

    def implicit_steps(self, stepper, progress) -> str:
        """A transient of the phase's duration in implicit steps of ``stepper`` (the flow, or the
        consolidation's split: ``solve(t, dt)``, ``undo()``, ``step_change``) sized by the pressure
        change they make (``STEP_CHANGE``), halved after one whose iteration fails, ending on each of
        the phase's frame times. A flow phase's ``max_steps`` caps its steps; a consolidation phase
        whose skeleton does not reach equilibrium within ``max_steps`` ends not converged."""
        run, phase, record = self.run, self.phase, self.run.records[-1]
        frame_times = phase.duration * np.arange(1, phase.frames + 1) / phase.frames
        dt = run.loop.get("dt", phase.time_step or phase.duration / 1000.0)
        stop = math.inf if run.stop_time is None else run.stop_time - run.phase_start_time
        rejected = None  # (change, step) of the first try of a step being retried shorter
        failures = 0  # consolidation tries in a row whose iteration did not converge
        framed = True  # whether the state has its frame (the phase's start has the one before it)
        while run.phase_time < phase.duration * (1.0 - 1e-12):
            t = run.phase_time
            if t >= stop:
                if not framed:  # a run stopped at its end time keeps its last state, as a dynamic one does
                    run.write_frame()
                    run.checkpoint()
                return STOPPED
            run.stop_if_interrupted()
            target = float(frame_times[np.searchsorted(frame_times, t * (1.0 + 1e-12) + 1e-300, side="right")])
            step = min(dt, target - t)
            steps = run.loop.get("steps", 0)
            if stepper is self.flow and steps >= phase.max_steps:
                return NOT_CONVERGED
            converged = stepper.solve(t + step, step)
            run.loop["time"] = t
            if stepper is self.split and stepper.collapsed:
                run.write_frame()
                return NOT_CONVERGED
            smallest = 1e-12 * phase.duration
            # a change that does not shrink with the step (a seepage face's exit point moving on, soil
            # that follows its neighbours at once) is not the step's error: the step stands
            step_driven = rejected is None or stepper.step_change < 0.75 * rejected[0]
            if not converged or (stepper.step_change > 1.5 and step_driven and step > smallest):
                dt = 0.5 * step if not converged else step * max(0.25, 0.8 / stepper.step_change)
                failures = failures + 1 if not converged else 0
                if dt < smallest:
                    run.unstable(f"the {phase.kind} does not converge even with a time step of {step:.3g} s")
                if stepper is self.split and failures >= MAX_FAILED_TRIES:
                    run.unstable(f"the consolidation's fixed-stress iteration does not converge: {failures} tries in a "
                                 f"row failed, the step halved to {step:.3g} s (a stall at the skeleton equilibrium's "
                                 "precision does not shrink with the step; docs/method.md, Known limits)")  # fmt: skip
                if converged:  # too large a change: put the step back
                    stepper.undo()
                    rejected = (stepper.step_change, step if rejected is None else rejected[1])
                continue
            run.loop["time"] = t + step if target - (t + step) > 1e-9 * phase.duration else target
            if not step_driven:  # the next step is tried as long as this one was first
                dt = rejected[1]
            elif step >= dt:  # not a step shortened to meet a frame time
                dt = step * min(1.5, 0.9 / max(stepper.step_change, 1e-300))
            rejected = None
            failures = 0
            run.loop["dt"], run.loop["steps"] = dt, steps + 1
            if stepper is self.flow:
                run.step_index += 1
                run.summary.steps += 1
            record.criterion = run.loop["time"]
            self.series()
            if not np.all(np.isfinite(run.state.particle_pore_pressure.numpy())):
                run.unstable("the pore pressure is not finite")
            framed = run.loop["time"] == target
            if framed:
                run.write_frame()
                run.checkpoint()
            if progress is not None:
                progress(run.time, run.step_index)
        return FINISHED

    def series(self) -> None:
        """A flow step's discharges, storage rate and iterations as series."""
        run, flow = self.run, self.flow
        for name, value in flow.discharge.items():
            run.results.append_series(f"discharge_{name}", run.step_index, run.time, value)
        run.results.append_series("storage_rate", run.step_index, run.time, flow.storage_rate)
        run.results.append_series("flow_iterations", run.step_index, run.time, flow.iterations)
        if self.split is not None:
            run.results.append_series("consolidation_iterations", run.step_index, run.time, self.split.iterations)
