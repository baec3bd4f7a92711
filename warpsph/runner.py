"""Scripted runs: the phases in sequence (each kind's calculation in :mod:`warpsph.phases`), output
cadence, checkpoints, run guards, signals and the run record.

``run_scene(scene, out_dir)`` is what ``warpsph run`` calls. A run writes into ``out_dir``:
``results.h5`` (+ ``results.xdmf``), ``particles.usdc`` (+ clips), ``checkpoint.h5`` and ``run.json``
(docs/output.md). If a step produces NaN, infinity or a speed beyond the scene's bound, the run
stops with :class:`SimulationError`; everything written before, the last good checkpoint included,
stays on disk.
"""

from __future__ import annotations

import importlib.util
import json
import math
import signal
import threading
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
import warp as wp

from warpsph.builder import build
from warpsph.environment import check_device, default_device
from warpsph.errors import InputError, OutputError, SimulationError
from warpsph.io import ResultsWriter, UsdParticleCache, load_checkpoint, save_checkpoint
from warpsph.io.xdmf import XdmfIndex
from warpsph.io.run_directory import CHECKPOINT, RECORD, RESULTS, RunDirectory, first_difference, scene_record
from warpsph.model import host_fields
from warpsph.phases.base import CHECK_EVERY, Calculation, Stopped
from warpsph.phases.carry import ParticleIds, carry_state, phase_particles
from warpsph.phases.consolidation import Consolidation
from warpsph.phases.dynamic import Dynamic
from warpsph.phases.equilibrium import Equilibrium
from warpsph.phases.flow import Flow
from warpsph.phases.k0 import K0Procedure
from warpsph.phases.safety import SafetyAnalysis
from warpsph.phases.staging import NOT_CONVERGED, STOPPED, UNSTABLE, PhaseRecord, default_phases, phase_scene
from warpsph.probes import Probes
from warpsph.run_output import FrameContent, frame_content, os_reason, room_for, run_record, write_record
from warpsph.scene import IMPLICIT_PHASE_KINDS, Phase, Scene
from warpsph.scene_reach import check_probes_reach
from warpsph.solver import Solver, warm_up
from warpsph.stages.energy import EnergyGuard, balance_warnings, energy_balance
from warpsph.stages.guard import Guard
from warpsph.version import __version__

CALCULATIONS: dict[str, type[Calculation]] = {"k0": K0Procedure, "equilibrium": Equilibrium, "safety": SafetyAnalysis,
                                              "dynamic": Dynamic, "flow": Flow, "consolidation": Consolidation}  # fmt: skip
"""Each phase kind's calculation (:mod:`warpsph.phases`)."""


@dataclass
class RunSummary:
    """What a run did and what it cost."""

    steps: int = 0
    """Steps taken in this invocation."""
    final_step: int = 0
    final_time: float = 0.0
    """[s]"""
    time_step: float = 0.0
    """Δt [s]"""
    particles: int = 0
    virtual_particles: int = 0
    compile_seconds: float = 0.0
    """Kernel compilation and first-launch cost, measured by a warm-up step [s]."""
    wall_seconds: float = 0.0
    """Time in the step loop and output, compile time excluded [s]."""
    frames: int = 0
    stage_seconds: dict = field(default_factory=dict)
    status: str = ""
    """"finished", "stopped" (at ``--end-time``), "interrupted" (by SIGINT or SIGTERM, checkpointed to
    resume), "not converged" (an equilibrium phase reached its step cap: the phases after it are not
    run) or "failed"."""
    message: str = ""
    """What stopped a run that did not finish (an interruption, an instability, an output error),
    and where its checkpoint is."""
    phases: list = field(default_factory=list)
    """One {name, kind, outcome, criterion, resolution, limit_equilibrium, refined, failing_mass, warnings, steps,
    trials, energy, energy_warnings} per phase run (energy: the balance at the phase's end, docs/method.md
    *Energy balance*)."""

    @property
    def particle_steps_per_second(self) -> float:
        return self.particles * self.steps / self.wall_seconds if self.wall_seconds > 0 else 0.0


GUARD_WINDOW = 2
"""Steps between two checks of the energy balance by the run guard (a divisor of ``CHECK_EVERY``): the
window over which it measures the energy made, short enough to stop an unstable mode within a few
steps of its start, while its checkpoint before is still good."""
ENERGY_MADE_LIMIT = 0.05
"""The run guard stops a run whose last ``GUARD_WINDOW`` steps made more than this fraction of the energy
in play from nothing (:func:`~warpsph.stages.energy.energy_made`), after three windows each of which
made more than the one before, the last more than ``ENERGY_GROWTH`` times the first: an unstable mode's
energy grows from one window to the next, where a phase's first steps, adjusting to what it changed,
make theirs once, and a balance that does not close makes its share steadily."""
ENERGY_GROWTH = 2.0


class Run:
    """One simulation run of ``scene`` into ``out_dir`` (see module docstring): its phases in order
    (one dynamic phase to the end time for a scene without phases; docs/scenes.md, *Phases*)."""

    def __init__(self, scene: Scene, out_dir, *, device: str | None = None, precision: str | None = None,
                 end_time: float | None = None, resume: bool = False, overwrite: bool = False,
                 profile: bool = False, trial_workers: int | None = None, scheduler: str | None = None):  # fmt: skip
        self.scene = scene
        self.out = Path(out_dir)
        check_device(device or default_device())
        self.trial_workers, self.scheduler = trial_workers, scheduler
        """Dask workers of a local cluster (more than 1), or the address of a Dask scheduler, that run the
        trials of a safety phase's rounds at once; None: the trials run in turn in this process."""
        if (scheduler or (trial_workers or 0) > 1) and importlib.util.find_spec("distributed") is None:
            raise InputError("--workers, --scheduler: the safety trials run on dask.distributed: "
                             "pip install 'warpsph[study]'")  # fmt: skip
        self.directory = RunDirectory(self.out, resume=resume, overwrite=overwrite)
        try:
            self._start(scene, device, precision, end_time, resume, profile)
        except OSError as e:
            self.directory.release()
            raise OutputError(f"cannot write the run's output in {self.out}: {os_reason(e)}") from None
        except BaseException:
            self.directory.release()
            raise

    def _start(self, scene, device, precision, end_time, resume, profile) -> None:
        self.device, self.precision, self.profile = device, precision, profile
        self.phases = default_phases(scene)
        self.staged = bool(scene.phases)
        self.stop_time = end_time
        """``--end-time``: the run stops at this simulated time [s] (None: after the last phase)."""
        self.end_time = scene.simulation.end_time if end_time is None else end_time
        self.ids = ParticleIds(scene)
        if self.staged and not resume:  # a resumed run's scene is the one checked at its start
            check_probes_reach(scene, phase_particles(scene))
        self.records: list[PhaseRecord] = []
        self.step_index = 0
        self.phase_start_step, self.phase_start_time, self.dt = 0, 0.0, 0.0
        self.checkpoint_step = None  # step of the last checkpoint written or resumed from
        self.resumed = False
        self.interrupted: str | None = None
        """The signal (SIGINT, SIGTERM) that asked the run to stop: it stops at the next step a
        checkpoint resumes from bit-identical, and checkpoints there."""
        self.loop: dict = {}
        """Loop state of the current phase that a checkpoint keeps (the last ratio, the peak energy)."""
        ck = None
        if resume and (self.out / CHECKPOINT).exists():
            ck = load_checkpoint(self.out / CHECKPOINT)
        elif resume:
            raise InputError(f"--resume: no {CHECKPOINT} in {self.out}")
        if ck is not None and "scene_record" in ck.meta:
            changed = first_difference(json.loads(ck.meta["scene_record"]), scene_record(scene))
            if changed is not None:
                raise InputError(f"--resume: {changed} differs from the scene the checkpoint was written with (a "
                                 "resumed run may change only its output and simulation.end_time)")  # fmt: skip
        phase_index = int(ck.meta.get("phase", 0)) if ck is not None else 0
        self.phase_index, self.calculation = 0, None
        if not 0 <= phase_index < len(self.phases):
            raise InputError("--resume: the checkpoint's phase is not one of this scene's")
        self._enter_phase(phase_index)
        if ck is not None:
            self._restore(ck)
        start_step = self.step_index if self.resumed else None
        self._scene_record = json.dumps(scene_record(scene))
        self.results = ResultsWriter(self.out / RESULTS, dim=scene.simulation.dim, scene_text=scene.source_text,
                                     particle_ids=self.model.particle_ids, warpsph_version=__version__,
                                     resume_step=start_step)  # fmt: skip
        self.xdmf = XdmfIndex(self.out / RESULTS) if scene.output.xdmf else None
        self.usd = None
        if scene.output.usd:
            self.usd = UsdParticleCache(self.out, radius=0.5 * self.model.dx, resume_step=start_step)
        self.summary = RunSummary(time_step=self.dt, particles=self.model.particle_count,
                                  virtual_particles=self.model.virtual_count)  # fmt: skip

    # -- phases -----------------------------------------------------------------------------------
    @property
    def phase(self) -> Phase:
        return self.phases[self.phase_index]

    def _enter_phase(self, index: int, before: tuple | None = None) -> None:
        """Build phase ``index``'s model, solver and state; ``before`` = (model, state, origin) of the
        phase before, whose state is carried over."""
        now = self.time  # the phase before's end, taken before Δt changes
        self.phase_index = index
        phase = self.phases[index]
        phase_scene_ = phase_scene(self.scene, index) if self.staged else self.scene
        self.model, self.state = build(phase_scene_, device=self.device, precision=self.precision, staged=self.staged)
        self.model.particle_ids = self.ids.of(self.model.particle_x0)
        origin = self.model.particle_x0.copy()
        if before is not None:
            origin = carry_state(self.ids, before[0], before[1], self.model, self.state, before[2])
        self.phase_scene = phase_scene_
        self.calculation = CALCULATIONS[phase.kind](self, phase)
        self.calculation.prepare()
        damping = phase.damping if self.calculation.damped else None
        self.solver = Solver(self.model, profile=self.profile, damping=damping,
                             pore_pressure=self.calculation.pore_pressure)  # fmt: skip
        self.scratch = self.model.state()
        self.scratch.assign(self.state)
        self.guard = Guard(self.model, phase_scene_.speed_limit)
        self._checked = None
        """The step the guards were last read at."""
        self.energy_guard = EnergyGuard(self.solver.energy, ENERGY_MADE_LIMIT, ENERGY_GROWTH)
        self.probes = Probes(self.model)
        self._probe_index = None  # the probes' rows on the device, made at the first sample
        self.dt = phase_scene_.time_step
        self.origin = origin
        if phase.reset_displacements:
            self.origin = host_fields(self.model, self.state)["position"]
        self.probes.displacement_origin = self.origin
        self.loop = {}
        self.start_energy()
        self.calculation.build()
        self.phase_start_step, self.phase_start_time = self.step_index, now
        self.records.append(PhaseRecord(phase.name, phase.kind, self.step_index, self.phase_start_time))

    @property
    def flow(self):
        """The current phase's groundwater flow (None: it solves none)."""
        return self.calculation.flow

    @property
    def split(self):
        """The current consolidation phase's fixed-stress split (None: not a consolidation phase)."""
        return self.calculation.split

    def clear_guards(self) -> None:
        """Forget what the run guards and the neighbour lists marked (a safety trial's start and end)."""
        self.guard.clear()
        self.solver.forget_neighbour_overflow()
        self._checked = None

    @property
    def _books_energy(self) -> bool:
        """Whether the phase's steps book their energies (docs/method.md, *Energy balance*): the two-set
        scheme's explicit steps; a flow or consolidation phase's implicit steps do not."""
        return self.model.spec.scheme == "two_set" and self.phase.kind not in IMPLICIT_PHASE_KINDS

    def balance_since_start(self) -> dict[str, float] | None:
        """The energy balance since the phase's start (a safety trial's: since the trial's), or None for
        a phase whose steps do not book it."""
        start = self.loop.get("energy_start")
        return None if start is None else energy_balance(self.solver.energy.sums(self.state), start)

    @property
    def phase_time(self) -> float:
        """Time since the start of the current phase [s]: the loads' time functions run on it (a flow
        and consolidation phase's implicit steps keep their own sum)."""
        if self.phase.kind in IMPLICIT_PHASE_KINDS:
            return self.loop.get("time", 0.0)
        return (self.step_index - self.phase_start_step) * self.dt

    @property
    def time(self) -> float:
        """Simulated time of the current state [s] (the phase's start plus steps × Δt, so restarts
        reproduce it exactly)."""
        return self.phase_start_time + self.phase_time
    # -- checkpoints ------------------------------------------------------------------------------
    def _restore(self, ck) -> None:
        if int(ck.meta.get("phase", 0)) != self.phase_index:
            raise InputError("--resume: the checkpoint's phase is not the one restored")
        for name, arr in self.state.arrays().items():
            if name not in ck.arrays or ck.arrays[name].shape != arr.numpy().shape:
                raise InputError(f"--resume: the checkpoint does not match this scene (array {name})")
            arr.assign(ck.arrays[name])
        if self.solver.layout is not None:
            self.solver.layout.restore(ck.arrays)
        if float(ck.meta.get("time_step", self.dt)) != self.dt:
            raise InputError("--resume: the checkpoint was written with another time step")
        if self.flow is not None and "flow_seeping" in ck.arrays:
            self.flow.seeping = ck.arrays["flow_seeping"].copy()
        if "energy_ledger" in ck.arrays:
            self.solver.energy.ledger.assign(ck.arrays["energy_ledger"])
        if "displacement_origin" in ck.arrays:
            self.origin = ck.arrays["displacement_origin"]
            self.probes.displacement_origin = self.origin
        if "phases" in ck.meta:
            self.records = [PhaseRecord(**r) for r in json.loads(ck.meta["phases"])]
            self.loop = json.loads(ck.meta["loop"])
            if "energy_start" in self.loop:
                self.energy_guard.begin(self.loop["energy_start"], self.loop["energy_error"],
                                        self.loop["energy_windows"])  # fmt: skip
            self.phase_start_step, self.phase_start_time = self.records[-1].first_step, self.records[-1].start_time
        self.calculation.restore(ck.arrays)
        self.scratch.assign(self.state)
        self.step_index = self.checkpoint_step = ck.step
        self.resumed = True

    def checkpoint(self) -> None:
        self.check_guards()  # nothing is written from a step the guards marked
        if "energy_start" in self.loop:
            self.loop["energy_error"], self.loop["energy_windows"] = self.energy_guard.progress_so_far()
        arrays = {name: arr.numpy() for name, arr in self.state.arrays().items()}
        if self.solver.layout is not None:
            arrays.update(self.solver.layout.arrays())
        arrays["displacement_origin"] = self.origin
        arrays["energy_ledger"] = self.solver.energy.ledger.numpy()
        arrays.update(self.calculation.checkpoint_arrays())
        if self.flow is not None:
            arrays["flow_seeping"] = self.flow.seeping
        self._room_for(arrays)
        save_checkpoint(self.out / CHECKPOINT, step=self.step_index, time=self.time, arrays=arrays,
                        meta={"time_step": self.dt, "scene": self.scene.name, "precision": self.model.spec.precision,
                              "phase": self.phase_index, "phases": json.dumps([asdict(r) for r in self.records]),
                              "loop": json.dumps(self.loop), "scene_record": self._scene_record})  # fmt: skip
        self.checkpoint_step = self.step_index

    @property
    def _kept(self) -> str:
        if self.checkpoint_step is None:
            return "no checkpoint was written yet"
        return f"the last checkpoint (step {self.checkpoint_step}) is kept"

    def _room_for(self, arrays: dict) -> None:
        room_for(self.out, arrays, self._kept)

    # -- output -----------------------------------------------------------------------------------
    def _sample_probes(self, fields=None) -> None:
        for name, value in self.solver.plate_series(self.state).items():
            self.results.append_series(name, self.step_index, self.time, value)
        if not self.probes.probes:
            return
        self.check_guards()  # nothing is written from a step the guards marked
        rows = None if fields is not None else self.probes.rows
        if rows is not None and self._probe_index is None and len(rows):  # once per phase
            self._probe_index = wp.array(rows.astype(np.int32), dtype=wp.int32, device=self.model.device)
        fields = fields or host_fields(self.model, self.state, rows, self._probe_index)
        for name, value in self.probes.sample(fields, self.solver.rigid.contact_forces(), rows).items():
            self.results.append_series(name, self.step_index, self.time, value)

    def _record_pressure_solve(self) -> None:
        """Iterations and final relative residual of this step's pressure solve, as series."""
        projection = self.solver.projection
        if projection is None or not projection.iterations:  # none without pore water or with it fixed
            return
        self.results.append_series("pressure_iterations", self.step_index, self.time, projection.iterations[-1])
        self.results.append_series("pressure_residual", self.step_index, self.time, projection.residuals[-1])

    def frame(self) -> FrameContent:
        """What a frame of the current state holds: the host fields and the frame's arrays."""
        return frame_content(self.model, self.state, self.origin, self.phase_scene.output.fields, self.staged,
                             self.solver.projection, self.flow)  # fmt: skip

    def write_frame(self, content: FrameContent | None = None, **attrs) -> None:
        """Write a frame of the current state, or the ``content`` of one made elsewhere (a safety trial's
        last state; ``attrs``: extra attributes of the frame)."""
        self.check_guards()  # nothing is written from a step the guards marked
        fields, frame, balance = content or self.frame()
        self._room_for(fields)
        self._sample_probes(fields)
        self._energy_series(balance)
        name = self.results.write_frame(self.step_index, self.time, frame, phase=self.phase_index, **attrs)
        if self.staged:
            self.results.write_phases([asdict(r) for r in self.records])
        if self.xdmf is not None:
            self.xdmf.append(name)
        if self.usd is not None:
            self.usd.write_frame(self.step_index, self.time, frame["position"],
                                 {k: v for k, v in frame.items() if k not in ("position", "id")},
                                 ids=self.model.particle_ids)  # fmt: skip
        self.summary.frames += 1

    def _write_record(self, status: str, message: str = "") -> None:
        write_record(self.out / RECORD, run_record(self.scene, self.model, self.solver.projection, self.summary,
                                                   status, message, self.end_time, self.resumed))  # fmt: skip

    # -- one step ---------------------------------------------------------------------------------
    def warm_up(self) -> None:
        if self.phase.kind == "flow":  # no mechanical step: the flow kernels compile at their first use
            return
        self.summary.compile_seconds += warm_up(self.solver, self.guard, self.state, self.scratch, self.phase_time,
                                                self.dt)  # fmt: skip
        if self.solver.damping is not None:
            self.solver.damping.read()

    def check_guards(self) -> None:
        """Read what the run guards marked on the device since the last read; stop the run at the first
        step they marked, naming what was wrong then, or at the first step after the last read where a
        neighbour list overflowed (once a step)."""
        if self._checked == self.step_index:
            return
        previous, self._checked = self._checked, self.step_index
        flagged = self.guard.read()
        grown = self.energy_guard.read() if "energy_start" in self.loop else None
        if grown is not None and (flagged is None or grown[0] < flagged.step):
            step, window, made, ratio = grown
            self.unstable(f"the energy made from nothing grew over three windows of {GUARD_WINDOW} steps, to "
                           f"{window:.4g} J in the last, {100 * made:.3g} % of the energy in play (limit "
                           f"{100 * ENERGY_MADE_LIMIT:g} %) and {ratio:.3g} times the first's (limit "
                           f"{ENERGY_GROWTH:g})", step)  # fmt: skip
        if flagged is None:
            try:
                self.solver.check_neighbours()
            except SimulationError as e:
                self.unstable(str(e), self.step_index if previous is None else min(previous + 1, self.step_index))
            return
        where = np.array2string(flagged.position, precision=4)
        if flagged.particle is None:
            self.unstable(f"virtual point {flagged.point} at {where} m has the density {flagged.density:.4g} kg/m³",
                           flagged.step)  # fmt: skip
        broken = [f"a non-finite {name.replace('_', ' ')}" for name in flagged.not_finite]
        if not flagged.density > 0.0 and "density" not in flagged.not_finite:
            broken.append(f"a non-positive density ({flagged.density:.4g} kg/m³)")
        if broken:
            what = f"has {' and '.join(broken)}"
        else:
            what = f"moves at {flagged.speed:.4g} m/s, beyond {self.phase_scene.speed_limit_text}"
        self.unstable(f"particle {flagged.particle} at {where} m {what}", flagged.step)

    def unstable(self, what: str, step: int | None = None):
        """Stop the run, unstable at ``step`` (default: this one) of the current phase."""
        step = self.step_index if step is None else step
        where = f" (phase {self.phase.name})" if self.staged else ""
        time = self.time - (self.step_index - step) * self.dt
        raise SimulationError(
            f"unstable at step {step}{where}, t = {time:.6g} s: {what}; the last good checkpoint "
            f"(step {self.checkpoint_step}) and the frames written are kept in {self.out}")

    def step(self) -> None:
        self.solver.step(self.state, self.scratch, self.phase_time, self.dt)
        self.state, self.scratch = self.scratch, self.state
        self.step_index += 1
        self.summary.steps += 1
        self.guard.mark(self.state, self.step_index)
        k = self.step_index - self.phase_start_step
        if k % GUARD_WINDOW == 0 and "energy_start" in self.loop:
            self.energy_guard.mark(self.state, self.step_index)
        if k % CHECK_EVERY == 0:
            self.check_guards()
            if self.phase.kind != "safety" and "energy_start" in self.loop:  # a trial's is written with its frame
                self._energy_series(self.balance_since_start())
        self._record_pressure_solve()

    def output(self, last: bool, frame_every: int, ck_every: int) -> None:
        """Frames, probe samples and checkpoints at their cadence (steps since the phase's start)."""
        k = self.step_index - self.phase_start_step
        if k % frame_every == 0 or last:
            self.write_frame()
        elif self.step_index % self.phase_scene.output.probe_every == 0:
            self._sample_probes()
        if k % ck_every == 0 or last:
            self.checkpoint()

    def cadence(self, damped: bool) -> tuple[int, int]:
        out = self.phase_scene.output
        frame_every = max(1, round(out.frame_interval / self.dt))
        ck_every = max(1, round(out.checkpoint_interval / self.dt)) if out.checkpoint_interval > 0 else frame_every
        if damped:  # checkpoints where the damping's sums have just been read
            ck_every = CHECK_EVERY * math.ceil(ck_every / CHECK_EVERY)
        return frame_every, ck_every

    def stop_step(self) -> int | None:
        """The step at which ``--end-time`` stops the run (None without it, or without phases)."""
        if self.stop_time is None or not self.staged or self.phase.kind in IMPLICIT_PHASE_KINDS:
            return None
        return self.phase_start_step + math.ceil((self.stop_time - self.phase_start_time) / self.dt - 1e-9)

    def stop_if_interrupted(self, checkpoint: bool = True) -> None:
        """After SIGINT or SIGTERM: checkpoint this step (unless told not to) and stop the run."""
        if self.interrupted is not None:
            if checkpoint:
                self.checkpoint()
            raise _Interrupted()

    def _on_signal(self, signum, frame) -> None:
        if self.interrupted is not None:  # a second signal: stop at once
            raise KeyboardInterrupt
        self.interrupted = signal.Signals(signum).name

    def _energy_series(self, balance: dict[str, float] | None) -> None:
        """The energy balance as series (``energy_kinetic``, …) at the current step."""
        for key, value in (balance or {}).items():
            self.results.append_series(f"energy_{key}", self.step_index, self.time, value)

    def start_energy(self) -> None:
        """Start the energy balance (and the run guard's check of it) from the current state."""
        if self._books_energy:
            self.loop["energy_start"] = self.solver.energy.sums(self.state).tolist()
            self.loop["energy_error"], self.loop["energy_windows"] = 0.0, []
            self.energy_guard.begin(self.loop["energy_start"])

    def _energy_report(self) -> dict:
        """The phase's energy balance at its end and one line per check it fails (:func:`balance_warnings`;
        the command line prints them): ``{"energy": ..., "energy_warnings": [...]}``, the balance None
        for a phase that keeps none and for a safety phase (each trial's is with the trial's frame)."""
        balance = self.balance_since_start() if self.phase.kind != "safety" else None
        warnings = balance_warnings(balance, self.model.spec.dim) if balance is not None else []
        return {"energy": balance, "energy_warnings": warnings}

    def height(self, positions: np.ndarray) -> float:
        """The bodies' extent along gravity [m] (their largest extent without gravity)."""
        g = np.asarray(self.model.gravity, dtype=float)
        if np.any(g):
            along = positions @ (g / np.linalg.norm(g))
            return float(along.max() - along.min())
        return float(np.max(positions.max(axis=0) - positions.min(axis=0)))

    # -- the loop ---------------------------------------------------------------------------------
    def run(self, progress=None, phase_done=None) -> RunSummary:
        """Run the phases in turn, writing frames, probes and checkpoints; return the summary.

        ``progress(time, step)`` is called after every step when given, and ``phase_done(result)`` as
        each phase ends, with its entry of the summary's ``phases``.
        """
        status, message = "failed", ""
        start = time.perf_counter()
        handlers = {}
        if threading.current_thread() is threading.main_thread():
            handlers = {sig: signal.signal(sig, self._on_signal) for sig in (signal.SIGINT, signal.SIGTERM)}
        try:
            self.warm_up()
            start = time.perf_counter()
            if not self.resumed:
                self.write_frame()
                self.checkpoint()
            while True:
                record = self.records[-1]
                outcome = self.calculation.calculate(progress)
                record.last_step, record.end_time, record.outcome = self.step_index, self.time, outcome
                self.summary.phases.append({"name": record.name, "kind": record.kind, "outcome": outcome,
                                            "criterion": record.criterion, "resolution": record.resolution,
                                            "limit_equilibrium": record.limit_equilibrium,
                                            "refined": record.refined,
                                            "failing_mass": record.failing_mass,
                                            "warnings": self.calculation.warnings(record),
                                            "steps": record.last_step - record.first_step, "trials": record.trials,
                                            **self._energy_report()})  # fmt: skip
                if self.staged:
                    self.results.write_phases([asdict(r) for r in self.records])
                if phase_done is not None:
                    phase_done(self.summary.phases[-1])
                if outcome in (STOPPED, NOT_CONVERGED):
                    status = "stopped" if outcome == STOPPED else "not converged"
                    break
                if self.phase_index + 1 == len(self.phases):
                    status = "finished"
                    break
                before = (self.model, self.state, self.origin)
                self._enter_phase(self.phase_index + 1, before)
                compile_before = time.perf_counter()
                self.warm_up()
                start += time.perf_counter() - compile_before
                self.write_frame()
                self.checkpoint()
        except (Stopped, _Interrupted) as e:
            status = "interrupted" if isinstance(e, _Interrupted) else "stopped"
            if status == "interrupted":
                message = (f"interrupted by {self.interrupted} at step {self.step_index}, t = {self.time:.6g} s; the "
                           f"checkpoint of step {self.checkpoint_step} and the frames written are kept in {self.out} "
                           "(continue with --resume)")  # fmt: skip
            self.records[-1].last_step, self.records[-1].end_time = self.step_index, self.time
            self.records[-1].outcome = STOPPED
        except SimulationError as e:
            message = str(e)
            self.records[-1].last_step, self.records[-1].end_time = self.step_index, self.time
            self.records[-1].outcome = UNSTABLE
            raise
        except KeyboardInterrupt:
            status, message = "interrupted", f"interrupted at step {self.step_index}, t = {self.time:.6g} s"
            raise
        except OutputError as e:
            message = str(e)
            raise
        except OSError as e:
            message = f"cannot write the run's output in {self.out}: {os_reason(e)}"
            raise OutputError(f"{message}; {self._kept}") from None
        finally:
            for sig, handler in handlers.items():
                signal.signal(sig, handler)
            wp.synchronize_device(self.model.device)
            self.summary.wall_seconds = time.perf_counter() - start
            self.summary.final_step, self.summary.final_time = self.step_index, self.time
            self.summary.stage_seconds = dict(self.solver.stage_seconds)
            self.summary.status, self.summary.message = status, message
            try:
                if self.staged:
                    self.results.write_phases([asdict(r) for r in self.records])
                self.results.close()
                self._write_record(status, message)
            except OSError:
                if status != "failed":  # an output error is already on its way out
                    raise OutputError(f"cannot write the run's output in {self.out}") from None
            finally:
                self.directory.release()
        return self.summary


class _Interrupted(Exception):
    """SIGINT or SIGTERM asked the run to stop."""


def run_scene(scene: Scene, out_dir, **kwargs) -> RunSummary:
    """Build, run and write ``scene`` into ``out_dir``; keyword arguments as for :class:`Run`."""
    progress = kwargs.pop("progress", None)
    return Run(scene, out_dir, **kwargs).run(progress=progress)
