"""Safety phases: the factor of safety by strength reduction, each trial an equilibrium, the trials of a
round in turn or at once on Dask (docs/scenes.md, *Phases*)."""

from __future__ import annotations

import bisect
import contextlib
import copy
import math
import tempfile
from pathlib import Path
from typing import NamedTuple

import numpy as np

from warpsph.builder import plastic_materials
from warpsph.cluster import dask_client
from warpsph.environment import init_warp
from warpsph.errors import SimulationError
from warpsph.io.run_directory import CHECKPOINT
from warpsph.io.results import LIMIT_EQUILIBRIUM_COLUMNS
from warpsph.io.safety_figure import write_safety_figure
from warpsph.model import host_fields
from warpsph.phases.base import CHECK_EVERY, Stopped
from warpsph.phases.equilibrium import Equilibrium, largest_displacement
from warpsph.phases.limit_equilibrium import above_the_floor, critical_circle, ground, strength
from warpsph.phases.search import FactorSearch, reduced_strength
from warpsph.phases.staging import CONVERGED, NOT_CONVERGED
from warpsph.scene import FAILURE_DISPLACEMENT
from warpsph.solver import carried_pore_pressure
from warpsph.stages.energy import energy_unit
from warpsph.stages.surface_water import free_water


STANDS, FAILS, UNDECIDED = 1, 0, -1
"""A trial's outcome, as the second column of ``/phases/trials/<name>`` and the frame attribute ``outcome``."""
CONVERGED_WHY, DISPLACED, COLLAPSING, RAN_AWAY, CAPPED = range(5)
"""Why a trial stands, fails or is undecided (the last column of ``/phases/trials/<name>``), :data:`WHY`."""
WHY = ("its ratio fell below the tolerance and it stayed at rest", "it moved past the failure displacement",
       "collapsing: its displacement and kinetic energy stopped slowing down", "it ran away (the run guard stopped it)",
       "still slowing down at its extended cap")
"""What each of the codes above says, in a trial's line of the run's output."""


class TrialOutcome(NamedTuple):
    """What a safety trial did (:meth:`SafetyAnalysis.trial`)."""

    factor: float
    why: int
    """:data:`CONVERGED_WHY`, :data:`DISPLACED`, :data:`COLLAPSING`, :data:`RAN_AWAY` or :data:`CAPPED`."""
    ratio: float
    """The final unbalanced-force ratio (inf where the run guard stopped the trial)."""
    steps: int
    moved: float
    """The largest displacement from the phase's start [m] (inf where the run guard stopped the trial)."""
    energy: float
    """The kinetic energy at its last check [J, J/m in 2D] (inf where the run guard stopped the trial)."""
    frame: object
    """The :class:`~warpsph.runner.FrameContent` of its last state, or None."""
    state: dict | None = None
    """Its last state's arrays (:meth:`~warpsph.model.State.arrays`, on the host) where it stood in an
    ``incremental`` phase (later trials start from it), else None."""

    @property
    def outcome(self) -> int:
        """:data:`STANDS` (it converged), :data:`UNDECIDED` (still slowing down at its extended cap) or
        :data:`FAILS`."""
        return STANDS if self.why == CONVERGED_WHY else UNDECIDED if self.why == CAPPED else FAILS

    @property
    def stands(self) -> bool | None:
        """True where it stood, False where it failed, None where it is undecided."""
        return None if self.outcome == UNDECIDED else self.outcome == STANDS

    @property
    def row(self) -> list[float]:
        """Its row of ``/phases/trials/<name>``."""
        return [self.factor, self.outcome, self.ratio, self.steps, self.moved, self.energy, self.why]


def resolution_warnings(failing_mass: float, dx: float, fewest: float = 8.0) -> list[str]:
    """A line when the failing mass is fewer than ``fewest`` spacings ``dx`` [m] high (to the nearest
    spacing; the phase's ``min_failing_mass``): the factor of safety is not yet converged in the spacing."""
    if not failing_mass < fewest - 0.5:
        return []
    return [f"the failing mass is {failing_mass:.1f} particle spacings high, fewer than {fewest:g}: the factor of "
            f"safety may move by more than 2 % when the spacing halves; set simulation.dx to "
            f"{dx * failing_mass / fewest:.2g} m or less (now {dx:g} m)"]  # fmt: skip


REFINED_CHANGE = 0.02
"""A factor of safety that moves by more than this fraction when the spacing halves is not converged in it."""


def refinement_warnings(criterion: float, refined, dx: float) -> list[str]:
    """A line when the factor at half the spacing ``dx`` [m] (``refined`` [factor, resolution]) differs
    from ``criterion`` by more than ``REFINED_CHANGE``."""
    if not refined or not abs(refined[0] / criterion - 1.0) > REFINED_CHANGE:
        return []
    return [f"the factor of safety moved by {100 * (refined[0] / criterion - 1.0):+.1f} % when the spacing halved "
            f"(more than {100 * REFINED_CHANGE:g} %): it is not converged in the spacing; run at simulation.dx = "
            f"{dx / 2:g} m with refine again"]  # fmt: skip


def floor_warnings(values, dx: float) -> list[str]:
    """A line when a safety phase's ``limit_equilibrium`` says that Bishop's factor rises by more than
    ``REFINED_CHANGE`` with the arcs kept above the rows of particles that do not shear (the soil's lowest,
    a stronger soil's): the critical circle runs along them, so the strength-reduction factor reads high."""
    change = values[5] / values[0] - 1.0 if len(values or []) > 5 else math.nan  # a resumed older record: 5
    if not change > REFINED_CHANGE:
        return []
    return [f"the critical slip circle runs along the bottom of the soil or the top of a stronger soil, whose rows of "
            f"particles do not shear: Bishop's factor is {values[0]:.3f} there and {values[5]:.3f} a row above "
            f"them ({100 * change:+.1f} %), so the factor of safety reads high; set simulation.dx to "
            f"{dx * REFINED_CHANGE / change:.2g} m or less (now {dx:g} m)"]  # fmt: skip


def limit_equilibrium_line(values) -> str:
    """The line that reports a safety phase's ``limit_equilibrium`` [Bishop, Spencer, x, y, r, Bishop above
    the rows that do not shear] ("" without one)."""
    if not values or not math.isfinite(values[0]):
        return ""
    bishop, spencer, x, y, r = values[:5]
    other = f"Spencer {spencer:.3f}" if math.isfinite(spencer) else "Spencer not found"
    raised = ""
    if len(values) > 5 and math.isfinite(values[5]):
        raised = f"; Bishop {values[5]:.3f} with the arc a row above the rows that do not shear"
    return (f"  limit equilibrium at the phase's start: Bishop {bishop:.3f}, {other} on the critical circle centred "
            f"at ({x:.2f}, {y:.2f}) m, radius {r:.2f} m{raised}")  # fmt: skip


def refined_line(criterion: float, refined, dx: float, name: str) -> str:
    """The line that reports a safety phase's ``refined`` [factor, resolution] at Δx/2 beside its own
    ``criterion`` at ``dx`` [m] ("" without one)."""
    if not refined:
        return ""
    where = f"at half the spacing (simulation.dx = {dx / 2:g} m, in refined_{name}/)"
    factor, resolution = refined
    if not math.isfinite(factor):
        return f"  {where}: the search did not bracket the factor of safety"
    return (f"  {where}: factor of safety {factor:.4g} ± {resolution:.2g}, "
            f"{100 * (factor / criterion - 1):+.1f} % from {criterion:.4g}")  # fmt: skip


def trial_lines(trials, dim: int) -> list[str]:
    """One line per row of a safety phase's ``trials`` (:attr:`TrialOutcome.row`) in a ``dim``-D run: the
    factor, the outcome and why, with the ratio, kinetic energy, displacement and steps it was decided on."""
    unit, lines = energy_unit(dim), []
    for factor, outcome, ratio, steps, moved, energy, why in trials:
        said = {STANDS: "stands", FAILS: "fails", UNDECIDED: "undecided"}[int(outcome)]
        lines.append(f"  trial F = {factor:.4g}: {said}, {WHY[int(why)]} (ratio {ratio:.3g}, kinetic energy "
                     f"{energy:.3g} {unit}, largest displacement {moved:.3g} m, {int(steps)} steps)")  # fmt: skip
    return lines


class TrialJudge:
    """Decides whether a safety trial stands (:meth:`settled`) and, at each check at which it does not,
    whether it has failed or must go on (docs/scenes.md, *Phases*): it fails once a particle has moved
    farther than ``limit`` [m] from ``start`` (N,3), or when, at its step cap ``cap``, it is collapsing:
    over the cap's last quarter the largest displacement grew by at least ``SLOWING`` times what it grew
    over the quarter before (and by more than ``MOVING`` of the limit), while the mean kinetic energy
    stayed at ``SLOWING`` times the quarter before's or more. A trial that is still slowing down at its
    cap is extended by the cap, at most ``EXTENSIONS`` times; one that is slowing down at the last is
    undecided (:attr:`why`)."""

    SLOWING = 0.95
    MOVING = 1e-3
    EXTENSIONS = 2
    REST_WINDOW = 0.1
    """The window over which a trial's rate of displacement is measured, as a fraction of its steps (at
    least ``REST_STEPS``) [-]."""
    REST_STEPS = 200
    REST_RATE = 0.1
    """A trial whose ratio is below the tolerance is at rest where its displacement grows at less than this
    fraction of the fastest it grew over any window before (or by less than ``MOVING`` of the limit) [-]."""

    def __init__(self, start: np.ndarray, limit: float, cap: int):
        self.start, self.limit, self.cap = start, limit, cap
        self.quarter = max(1, cap // (4 * CHECK_EVERY))  # checks per quarter of the cap
        self.energy: list[float] = []
        self.decision = cap  # the step of the next look at the cap
        self.why = CAPPED
        self.steps: list[int] = [0]
        self.moved: list[float] = [0.0]
        """The largest displacement [m] at each check, at ``steps``."""
        self.fastest = 0.0
        """The largest rate of displacement over a window so far [m/step]."""

    def measure(self, positions, k: int) -> None:
        """The largest displacement at step ``k`` into :attr:`moved` (once a step)."""
        if self.steps[-1] != k:
            self.steps.append(k)
            self.moved.append(largest_displacement(positions, self.start))

    def settled(self, balanced: bool, positions, k: int) -> bool:
        """Whether the trial at step ``k`` of its own (``positions``) stands: its unbalanced-force ratio is
        below the tolerance (``balanced``) and it is at rest, its largest displacement growing over the last
        ``REST_WINDOW`` of its steps (at least ``REST_STEPS``) by less than ``MOVING`` of the limit or at
        less than ``REST_RATE`` of the fastest rate of any window before. A mass sliding at a steady speed
        has little unbalanced force, so the ratio alone would let it stand; the equilibrium's slow creep
        (docs/method.md, *Known limits*) is a small fraction of the motion a reduced strength starts
        (docs/scenes.md, *Phases*)."""
        self.measure(positions, k)
        window = max(self.REST_STEPS, self.REST_WINDOW * k)
        if k < window:
            return False
        first = bisect.bisect_left(self.steps, k - window)
        grown = self.moved[-1] - self.moved[first]
        rate = grown / (k - self.steps[first])
        resting = grown < self.MOVING * self.limit or rate < self.REST_RATE * self.fastest
        self.fastest = max(self.fastest, rate)
        return balanced and resting

    def __call__(self, positions, k: int, energy: float) -> bool:
        """True where the trial at step ``k`` of its own (``positions``, kinetic energy ``energy``) ends."""
        self.measure(positions, k)
        self.energy.append(energy)
        if self.moved[-1] > self.limit:
            self.why = DISPLACED
            return True
        if k < self.decision:
            return False
        if self.collapsing():
            self.why = COLLAPSING
            return True
        self.decision += self.cap
        return k >= self.cap * (1 + self.EXTENSIONS)

    def collapsing(self) -> bool:
        """Whether the displacement and the kinetic energy have stopped slowing down (over the last two
        quarters of the cap)."""
        n = self.quarter
        if len(self.moved) < 2 * n + 1:
            return False
        before, last = self.moved[-1 - n] - self.moved[-1 - 2 * n], self.moved[-1] - self.moved[-1 - n]
        energy_before, energy_last = np.mean(self.energy[-2 * n : -n]), np.mean(self.energy[-n:])
        moving = last > self.MOVING * self.limit
        return moving and last >= self.SLOWING * before and energy_last >= self.SLOWING * energy_before


class SafetyAnalysis(Equilibrium):
    """Strength reduction (:class:`~warpsph.phases.search.FactorSearch`): each trial an equilibrium with
    c, tan φ and tan ψ divided by the trial factor F, from the state of the strongest trial that stood
    below F (from the phase's start where none has, or without the phase's ``incremental``); a trial stands
    when it converges within the phase's step cap, and fails at the cap or once a particle has
    moved farther than the failure displacement. Each trial's last state is written as a frame
    (attributes ``factor`` and ``outcome``), the state is then put back to the phase's start and
    checkpointed, so the next phase starts from the unreduced state. With trial workers (the run's
    ``trial_workers`` or ``scheduler``) the trials of a round run at once on Dask, one per worker,
    each from the phase's checkpoint (:func:`remote_trial`); their steps count as if run in
    turn."""

    STANDING = "standing_"
    """The prefix of the standing state's arrays in the run's checkpoint (its factor is ``loop["standing"]``)."""

    def __init__(self, run, phase):
        super().__init__(run, phase)
        self.standing: tuple[float, dict] | None = None
        """The factor and state (:attr:`TrialOutcome.state`) of the strongest trial that stood below every
        trial that failed, which later trials start from."""

    def checkpoint_arrays(self) -> dict:
        if self.standing is None:
            return {}
        return {self.STANDING + name: arr for name, arr in self.standing[1].items()}

    def restore(self, arrays: dict) -> None:
        factor = self.run.loop.get("standing")
        if factor is not None:
            n = len(self.STANDING)
            self.standing = (factor, {k[n:]: v for k, v in arrays.items() if k.startswith(self.STANDING)})

    def keep_standing(self, outcomes: list[TrialOutcome], failed: float | None) -> None:
        """Keep the state of the strongest of a round's ``outcomes`` that stood below ``failed`` (the
        smallest factor that failed, None: none yet), where it is stronger than the one kept."""
        stood = [o for o in outcomes if o.state is not None and (failed is None or o.factor < failed)]
        best = max(stood, key=lambda o: o.factor, default=None)
        if best is not None and (self.standing is None or best.factor > self.standing[0]):
            self.standing = (best.factor, best.state)
            self.run.loop["standing"] = best.factor

    def calculate(self, progress) -> str:
        run, phase, record = self.run, self.phase, self.run.records[-1]
        if not record.limit_equilibrium:  # once, at the phase's start (a resumed phase has it in its record)
            self.limit_equilibrium(record)
        weakest = (math.inf, None)  # the weakest failing trial run here: its factor and last frame
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
                    record.trials.append(outcome.row)
                    run.step_index += outcome.steps
                    if client is not None:
                        run.summary.steps += outcome.steps
                    if outcome.frame is not None:
                        run.write_frame(outcome.frame, factor=outcome.factor, outcome=outcome.outcome)
                        if outcome.outcome == FAILS and outcome.factor < weakest[0]:
                            weakest = (outcome.factor, outcome.frame)
                    search.record(outcome.factor, outcome.stands)
                if phase.incremental:
                    self.keep_standing(outcomes, search.high)
                run.checkpoint()
                if progress is not None:
                    progress(run.time, run.step_index)
                stop = run.stop_step()
                if search.factors and stop is not None and run.step_index >= stop:
                    raise Stopped()
                run.stop_if_interrupted(checkpoint=False)
        record.criterion, record.resolution = search.result, search.resolution
        if phase.refine and not record.refined:
            record.refined = self.refined()
        fields = weakest[1].fields if weakest[1] is not None else {}
        if "position" in fields:
            record.failing_mass = self.mechanism_height(fields["position"]) / run.model.dx
        circle = record.limit_equilibrium[2:] if math.isfinite(record.limit_equilibrium[0]) else []
        write_safety_figure(run.out / f"safety_{phase.name}.svg", fields.get("position"), fields.get("plastic_strain"),
                            run.model.dx, circle, record.trials, record.criterion)  # fmt: skip
        return CONVERGED if search.bracketed else NOT_CONVERGED

    def refined(self) -> list[float]:
        """[factor, resolution] of the same search at half the spacing: the scene's phases up to this one
        rebuilt at Δx/2 and run in ``RUN_DIR/refined_NAME`` ([nan, nan] where that search did not bracket
        the factor, or the run guard stopped it)."""
        run = self.run
        scene = copy.deepcopy(run.scene)
        scene.simulation.dx /= 2.0
        scene.phases = scene.phases[: run.phase_index + 1]
        scene.phases[-1].refine = False
        scene.output.usd = False
        finer = type(run)(scene.validate(), run.out / f"refined_{self.phase.name}", device=run.device,
                          precision=run.precision, overwrite=True, trial_workers=run.trial_workers,
                          scheduler=run.scheduler)  # fmt: skip
        try:
            last = finer.run().phases[-1]
        except SimulationError:
            return [math.nan, math.nan]
        if last["outcome"] != CONVERGED:
            return [math.nan, math.nan]
        return [last["criterion"], last["resolution"]]

    def mechanism_height(self, positions: np.ndarray) -> float:
        """The height [m] of the mechanism of a trial that ended at ``positions`` (N,3), the state being at
        the phase's start: the extent along gravity of the particles that moved more than half as far as
        the farthest 1 % (not the farthest one: a particle thrown off the surface), plus one spacing."""
        start = self.run.state.particle_q.numpy()[: len(positions)].astype(float)
        moved = np.linalg.norm(positions - start, axis=1)
        return self.run.height(start[moved > 0.5 * np.percentile(moved, 99.0)]) + self.run.model.dx

    def warnings(self, record) -> list[str]:
        dx = self.run.model.dx
        return (resolution_warnings(record.failing_mass, dx, self.phase.min_failing_mass)
                + refinement_warnings(record.criterion, record.refined, dx)
                + floor_warnings(record.limit_equilibrium, dx))  # fmt: skip

    def limit_equilibrium(self, record) -> None:
        """Bishop's and Spencer's factors on the critical slip circle of the phase's start state and
        Bishop's with the arcs kept above the rows of particles that do not shear, into ``record``
        (:mod:`~warpsph.phases.limit_equilibrium`); nan where the run is not 2D with gravity along −y, or
        no circle cuts the ground."""
        run, m = self.run, self.run.model
        g = np.asarray(m.gravity, dtype=float)
        circle = None
        if m.spec.dim == 2 and g[1] < 0.0 and g[0] == 0.0:
            n = m.particle_count
            fields = host_fields(m, run.state)
            materials = list(run.phase_scene.materials.values())
            strengths = np.array([strength(mat) for mat in materials])
            water = max(mat.water_density for mat in materials)
            material = m.particle_material.numpy()[:n]
            g_norm = float(np.linalg.norm(g))
            weight = m.particle_mass.numpy()[:n].astype(float) * g_norm
            where = self.phase.slip_region
            standing = None  # the reservoirs' pressure on the ground's surface, at their levels now
            pore, suction = fields.get("pore_pressure"), False
            if m.pore is not None:
                if m.pore.reservoirs:
                    standing = free_water(m.pore.reservoirs, m.pore.surface_water.level.numpy(), water * g_norm)
                suction = bool(m.pore.suction)
                if suction:  # the part χ p_w the total stress carries: its excess plus the hydrostatic pressure
                    hydrostatic = pore - run.state.particle_pore_pressure.numpy()[:n]
                    pore = carried_pore_pressure(m, run.state).numpy() + hydrostatic
            soil = ground(fields["position"], weight, strengths[material, 0], strengths[material, 1], pore, m.dx,
                          water * g_norm, standing, suction)  # fmt: skip
            region = (where.min[0], where.max[0], where.min[1])
            circle = critical_circle(soil, region)
        if circle is None:
            record.limit_equilibrium = [math.nan] * LIMIT_EQUILIBRIUM_COLUMNS
            return
        record.limit_equilibrium = [circle.bishop, circle.spencer, *circle.centre, circle.radius,
                                    above_the_floor(soil, region, circle)]  # fmt: skip

    def _remote_trials(self, client, factors: list[float]) -> list[TrialOutcome]:
        """The trials at ``factors`` on the Dask workers of ``client``, in the order of ``factors``."""
        run = self.run
        checkpoint = (run.out / CHECKPOINT).read_bytes()  # the phase's start and the search so far
        futures = [client.submit(remote_trial, type(run), run.scene, checkpoint, factor, run.device, run.precision,
                                 key=f"warpsph-trial-{self.phase.name}-{factor!r}-{run.step_index}")
                   for factor in factors]  # fmt: skip
        return client.gather(futures)

    def trial(self, factor: float, progress=None) -> TrialOutcome:
        """One trial at ``factor`` from the standing state below it (:attr:`standing`) or the current state
        (the phase's start), which it then puts back with the step index; displacements count from the
        phase's start. The outcome carries the frame of its last state (None where the run guard
        stopped it: a mechanism ran away, the trial failed) and, where it stood, that state."""
        run, phase = self.run, self.phase
        start = run.state.host_copy()
        if phase.incremental and self.standing is not None and self.standing[0] < factor:
            run.state.assign_host(self.standing[1])
            run.scratch.assign(run.state)
        materials = list(run.phase_scene.materials.values())
        spec, device = run.model.spec, run.model.device
        positions = start["particle_q"][: run.model.particle_count]
        limit = phase.failure_displacement or FAILURE_DISPLACEMENT * run.height(positions)
        judge = TrialJudge(positions, limit, phase.max_steps)
        run.model.material_plasticity = plastic_materials(spec, [reduced_strength(m, factor) for m in materials],
                                                          device)  # fmt: skip
        first = run.step_index
        run.loop.pop("ratio", None)
        run.start_energy()
        run.clear_guards()
        try:
            converged, ratio = self.equilibrate(progress, first, output=False, judge=judge)
            moved, energy = largest_displacement(run.state.particle_q, positions), self.kinetic_energy
            why = CONVERGED_WHY if converged else judge.why
            frame = run.frame()._replace(balance=run.balance_since_start()) if math.isfinite(moved) else None
            run.check_guards()  # the marks of its last steps and of its frame's neighbour lists are the trial's
            run.solver.check_neighbours()
        except SimulationError:
            ratio, moved, energy, why, frame = math.inf, math.inf, math.inf, RAN_AWAY, None
        end = run.state.host_copy() if why == CONVERGED_WHY and phase.incremental else None  # later trials' start
        steps = run.step_index - first
        run.state.assign_host(start)
        run.scratch.assign(run.state)
        run.step_index = first
        run.start_energy()
        run.clear_guards()
        run.model.material_plasticity = plastic_materials(spec, materials, device)
        return TrialOutcome(factor, why, ratio, steps, moved, energy, frame, end)


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
