"""Safety phases: the factor of safety by strength reduction, each trial an equilibrium, the trials of a
round in turn or at once on Dask (docs/scenes.md, *Phases*)."""

from __future__ import annotations

import contextlib
import copy
import math
import tempfile
from pathlib import Path
from typing import NamedTuple

from warpsph.builder import plastic_materials
from warpsph.cluster import dask_client
from warpsph.environment import init_warp
from warpsph.errors import SimulationError
from warpsph.io.run_directory import CHECKPOINT
from warpsph.phases.base import Stopped
from warpsph.phases.equilibrium import Equilibrium, largest_displacement
from warpsph.phases.search import FactorSearch, reduced_strength
from warpsph.phases.staging import CONVERGED, NOT_CONVERGED
from warpsph.scene import FAILURE_DISPLACEMENT


class TrialOutcome(NamedTuple):
    """What a safety trial did (:meth:`SafetyAnalysis.trial`)."""

    factor: float
    converged: bool
    ratio: float
    """The final unbalanced-force ratio (inf where the run guard stopped the trial)."""
    steps: int
    moved: float
    """The largest displacement from the phase's start [m] (inf where the run guard stopped the trial)."""
    frame: object
    """The :class:`~warpsph.runner.FrameContent` of its last state, or None."""


class SafetyAnalysis(Equilibrium):
    """Strength reduction (:class:`~warpsph.phases.search.FactorSearch`): each trial an equilibrium from
    the phase's start state with c, tan φ and tan ψ divided by the trial factor F; a trial stands
    when it converges within the phase's step cap, and fails at the cap or once a particle has
    moved farther than the failure displacement. Each trial's last state is written as a frame
    (attributes ``factor`` and ``converged``), the state is then put back to the phase's start and
    checkpointed, so the next phase starts from the unreduced state. With trial workers (the run's
    ``trial_workers`` or ``scheduler``) the trials of a round run at once on Dask, one per worker,
    each from the phase's start checkpoint (:func:`remote_trial`); their steps count as if run in
    turn."""

    def calculate(self, progress) -> str:
        run, phase, record = self.run, self.phase, self.run.records[-1]
        with contextlib.ExitStack() as stack:
            client = None
            if run.scheduler or (run.trial_workers or 0) > 1:
                client = stack.enter_context(dask_client(run.scheduler, run.trial_workers))
            width = len(client.scheduler_info()["workers"]) if client is not None else 1
            search = FactorSearch(phase.factor_tolerance, phase.factor_max, run.loop.get("search"), width)
            run.loop["search"] = search.state
            while search.factors:
                if client is None:
                    outcomes = [self.trial(search.factor, progress)]
                else:
                    outcomes = self._remote_trials(client, search.factors)
                for outcome in outcomes:
                    record.trials.append([outcome.factor, int(outcome.converged), outcome.ratio, outcome.steps,
                                          outcome.moved])  # fmt: skip
                    run.step_index += outcome.steps
                    if client is not None:
                        run.summary.steps += outcome.steps
                    if outcome.frame is not None:
                        run.write_frame(outcome.frame, factor=outcome.factor, converged=int(outcome.converged))
                    search.record(outcome.factor, outcome.converged)
                run.checkpoint()
                if progress is not None:
                    progress(run.time, run.step_index)
                stop = run.stop_step()
                if search.factors and stop is not None and run.step_index >= stop:
                    raise Stopped()
                run.stop_if_interrupted(checkpoint=False)
        record.criterion = search.result
        return CONVERGED if search.bracketed else NOT_CONVERGED

    def _remote_trials(self, client, factors: list[float]) -> list[TrialOutcome]:
        """The trials at ``factors`` on the Dask workers of ``client``, in the order of ``factors``."""
        run = self.run
        checkpoint = (run.out / CHECKPOINT).read_bytes()  # the phase's start and the search so far
        futures = [client.submit(remote_trial, type(run), run.scene, checkpoint, factor, run.device, run.precision,
                                 key=f"warpsph-trial-{self.phase.name}-{factor!r}-{run.step_index}")
                   for factor in factors]  # fmt: skip
        return client.gather(futures)

    def trial(self, factor: float, progress=None) -> TrialOutcome:
        """One trial at ``factor`` from the current state (the phase's start), which it then puts back
        with the step index; the outcome carries the frame of its last state (None where the run guard
        stopped it: a mechanism ran away, the trial failed)."""
        run, phase = self.run, self.phase
        start = {name: arr.numpy().copy() for name, arr in run.state.arrays().items()}
        materials = list(run.phase_scene.materials.values())
        spec, device = run.model.spec, run.model.device
        positions = start["particle_q"][: run.model.particle_count]
        limit = phase.failure_displacement or FAILURE_DISPLACEMENT * run.height(positions)
        run.model.material_plasticity = plastic_materials(spec, [reduced_strength(m, factor) for m in materials],
                                                          device)  # fmt: skip
        first = run.step_index
        run.loop.pop("ratio", None)
        run.start_energy()
        run.clear_guards()
        try:
            converged, ratio = self.equilibrate(progress, first, output=False, start=(positions, limit))
            moved = largest_displacement(run.state.particle_q, positions)
        except SimulationError:
            converged, ratio, moved = False, math.inf, math.inf
        frame = run.frame()._replace(balance=run.balance_since_start()) if math.isfinite(moved) else None
        steps = run.step_index - first
        for name, arr in run.state.arrays().items():
            arr.assign(start[name])
        run.scratch.assign(run.state)
        run.step_index = first
        run.start_energy()
        run.clear_guards()
        run.model.material_plasticity = plastic_materials(spec, materials, device)
        return TrialOutcome(factor, converged, ratio, steps, moved, frame)


def remote_trial(run_type: type, scene, checkpoint: bytes, factor: float, device: str | None,
                 precision: str | None) -> TrialOutcome:  # fmt: skip
    """One trial of a safety phase on a Dask worker: the run (a ``run_type``) resumed from the phase's
    ``checkpoint`` (the bytes of its file) in a scratch directory, without USD or XDMF output, and its
    trial at ``factor`` (:meth:`SafetyAnalysis.trial`)."""
    init_warp()
    scene = copy.deepcopy(scene)
    scene.output.usd = scene.output.xdmf = False
    with tempfile.TemporaryDirectory(prefix="warpsph-trial-") as scratch:
        (Path(scratch) / CHECKPOINT).write_bytes(checkpoint)
        run = run_type(scene, scratch, device=device, precision=precision, resume=True)
        try:
            run.warm_up()
            return run.calculation.trial(factor)
        finally:
            run.results.close()
            run.directory.release()
