"""Scripted runs: time loop, output cadence, checkpoints, run guards and the run record.

``run_scene(scene, out_dir)`` is what ``warpsph run`` calls. A run writes into ``out_dir``:
``results.h5`` (+ ``results.xdmf``), ``particles.usdc`` (+ clips), ``checkpoint.h5`` and ``run.json``
(docs/output.md). If a step produces NaN, infinity or a speed beyond the scene's bound, the run
stops with :class:`SimulationError`; everything written before, the last good checkpoint included,
stays on disk.
"""

from __future__ import annotations

import contextlib
import copy
import importlib.util
import json
import math
import re
import os
import shutil
import signal
import threading
import platform
import time
import warnings
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import NamedTuple

import numpy as np
import warp as wp

import warpsph
from warpsph.builder import build, plastic_materials
from warpsph.environment import check_device, default_device
from warpsph.errors import InputError, OutputError, SimulationError
from warpsph.fields import tensor_to_voigt
from warpsph.io import ResultsWriter, UsdParticleCache, load_checkpoint, save_checkpoint
from warpsph.io.xdmf import XdmfIndex
from warpsph.io.run_directory import RunDirectory, first_difference, scene_record
from warpsph.initial_stress import geostatic_stress, geostatic_unit_weight
from warpsph.model import PLANE_TRACTION, Model, State
from warpsph.phase_state import ParticleIds, carry_state
from warpsph.phases import AT_REST, CONVERGED, FINISHED, NOT_CONVERGED, STOPPED, UNSTABLE, PhaseRecord, default_phases
from warpsph.phases import FactorSearch, phase_scene, reduced_strength
from warpsph.probes import Probes
from warpsph.scene import FAILURE_DISPLACEMENT, IMPLICIT_PHASE_KINDS, Phase, Scene
from warpsph.solver import Solver
from warpsph.stages.consolidation import FixedStressSplit
from warpsph.stages.energy import EnergyGuard, balance_warnings, energy_balance
from warpsph.stages.groundwater import GroundwaterFlow
from warpsph.stages.guard import Guard

RESULTS, CHECKPOINT, RECORD = "results.h5", "checkpoint.h5", "run.json"


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
    """One {name, kind, outcome, criterion, steps, trials, energy, energy_warnings} per phase run
    (energy: the balance at the phase's end, docs/method.md *Energy balance*)."""

    @property
    def particle_steps_per_second(self) -> float:
        return self.particles * self.steps / self.wall_seconds if self.wall_seconds > 0 else 0.0


class FrameContent(NamedTuple):
    """A frame's content: the host fields (:func:`host_fields`), the arrays written, and the energy
    balance to write as series with it (a safety trial's, at its last state; else None)."""

    fields: dict
    frame: dict
    balance: dict | None


class TrialOutcome(NamedTuple):
    """What a safety trial did (:meth:`Run.safety_trial`)."""

    factor: float
    converged: bool
    ratio: float
    """The final unbalanced-force ratio (inf where the run guard stopped the trial)."""
    steps: int
    moved: float
    """The largest displacement from the phase's start [m] (inf where the run guard stopped the trial)."""
    frame: FrameContent | None


def host_fields(model: Model, state: State, rows: np.ndarray | None = None,
                index: wp.array | None = None) -> dict[str, np.ndarray]:  # fmt: skip
    """Owned-particle fields on the host: position, velocity (N,3) [m, m/s], stress (N,3,3) [Pa],
    density [kg/m³], with pore water the total pore pressure (N,) [Pa] and with plasticity the
    equivalent plastic strain (N,) [-]. ``rows``: only these particles, gathered on the device
    before the copy (``index``: the same rows as a device int32 array, when one is kept)."""
    n = model.particle_count
    if rows is None or not len(rows):
        def read(arr):
            return arr.numpy()[: n if rows is None else 0]
    else:
        if index is None:
            index = wp.array(rows.astype(np.int32), dtype=wp.int32, device=model.device)

        def read(arr):
            return wp.indexedarray(arr, [index]).numpy()
    fields = {
        "position": read(state.particle_q).astype(np.float64),
        "velocity": read(state.particle_v).astype(np.float64),
        "stress": read(state.particle_stress).astype(np.float64),
        "density": read(state.particle_density).astype(np.float64),
    }
    if model.pore is not None:
        material = model.particle_material.numpy()[:n] if rows is None else read(model.particle_material)
        water_density = model.pore.material_water_density.numpy()[material]
        hydrostatic = model.pore.hydrostatic(fields["position"], water_density)
        fields["pore_pressure"] = read(state.particle_pore_pressure) + hydrostatic
    if state.particle_plastic_strain is not None:
        fields["plastic_strain"] = read(state.particle_plastic_strain).astype(np.float64)
    return fields


def warm_up(solver: Solver, guard: Guard, state: State, scratch: State, t: float, dt: float) -> float:
    """Compile every kernel by one throw-away step from ``state`` into ``scratch`` (which is reset
    to ``state`` afterwards) and clear the solver's statistics and what it booked; return its wall time [s]."""
    start = time.perf_counter()
    ledger = wp.clone(solver.energy.ledger)
    with warnings.catch_warnings():  # the throw-away step reports nothing
        warnings.simplefilter("ignore")
        solver.step(state, scratch, t, dt)
    guard.find(scratch)
    wp.synchronize_device(solver.model.device)
    scratch.assign(state)
    solver.energy.ledger.assign(ledger)
    solver.stage_seconds.clear()
    if solver.projection is not None:
        solver.projection.reset_statistics()
    return time.perf_counter() - start


OUTPUT_RESERVE = 1 << 20
"""Bytes a frame or checkpoint write leaves free on the disk beyond twice its arrays [B]."""
CHECK_EVERY = 10
"""Steps between two reads of an equilibrium phase's unbalanced force, a dynamic phase's kinetic
energy, or the energy balance written as series: each read waits for the device."""
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
        self.phase_index, self.flow, self.split = 0, None, None
        if not 0 <= phase_index < len(self.phases):
            raise InputError("--resume: the checkpoint's phase is not one of this scene's")
        self._enter_phase(phase_index)
        if ck is not None:
            self._restore(ck)
        start_step = self.step_index if self.resumed else None
        self._scene_record = json.dumps(scene_record(scene))
        self.results = ResultsWriter(self.out / RESULTS, dim=scene.simulation.dim, scene_text=scene.source_text,
                                     particle_ids=self.model.particle_ids, warpsph_version=warpsph.__version__,
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
        self.model, self.state = build(phase_scene_, device=self.device, precision=self.precision)
        self.model.particle_ids = self.ids.of(self.model.particle_x0)
        origin = self.model.particle_x0.copy()
        if before is not None:
            origin = carry_state(self.ids, before[0], before[1], self.model, self.state, before[2])
        self.phase_scene = phase_scene_
        if phase.kind == "k0":
            self._k0_procedure()
        damped = phase.kind in ("equilibrium", "safety", "consolidation")
        pore_pressure = "fixed" if phase.kind == "consolidation" else phase.pore_pressure
        self.solver = Solver(self.model, profile=self.profile, damping=phase.damping if damped else None,
                             pore_pressure=pore_pressure)  # fmt: skip
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
        self._start_energy()
        self._load_scale = None  # the phase's constant parts of the applied force (_applied_force)
        self.flow = self.split = None
        if phase.kind in IMPLICIT_PHASE_KINDS:
            height = self._height(self.model.particle_x0)
            self.flow = GroundwaterFlow(self.model, self.solver, self.state, phase_scene_.reservoirs, phase.tolerance,
                                        height)  # fmt: skip
        if phase.kind == "consolidation":
            self.split = FixedStressSplit(self.model, self.solver, self.flow, self._equilibrate_held,
                                          lambda: self.state)  # fmt: skip
        self.phase_start_step, self.phase_start_time = self.step_index, now
        self.records.append(PhaseRecord(phase.name, phase.kind, self.step_index, self.phase_start_time))

    @property
    def _books_energy(self) -> bool:
        """Whether the phase's steps book their energies (docs/method.md, *Energy balance*): the two-set
        scheme's explicit steps; a flow or consolidation phase's implicit steps do not."""
        return self.model.spec.scheme == "two_set" and self.phase.kind not in IMPLICIT_PHASE_KINDS

    def _energy_balance(self) -> dict[str, float] | None:
        """The energy balance since the phase's start (a safety trial's: since the trial's), or None for
        a phase whose steps do not book it."""
        start = self.loop.get("energy_start")
        return None if start is None else energy_balance(self.solver.energy.sums(self.state), start)

    def _k0_procedure(self) -> None:
        """Geostatic effective stresses of every active body at once (the K0 procedure): σ′_v from the
        (buoyant, with pore water) weight above each particle in its column, σ′_h = K0 σ′_v."""
        m, scene = self.model, self.phase_scene
        mats = list(scene.materials.values())
        material = m.particle_material.numpy()[: m.particle_count]
        gravity, pore_water = scene.simulation.gravity, m.pore is not None
        unit_weight = np.array([geostatic_unit_weight(mt, gravity, pore_water) for mt in mats])[material]
        k0 = np.array([mt.earth_pressure_at_rest for mt in mats])[material]
        stress = self.state.particle_stress.numpy()
        stress[: m.particle_count] = geostatic_stress(m.particle_x0, unit_weight, k0, m.dx)
        self.state.particle_stress.assign(stress)

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
        self.scratch.assign(self.state)
        self.step_index = self.checkpoint_step = ck.step
        self.resumed = True

    def _checkpoint(self) -> None:
        self._check()  # nothing is written from a step the guards marked
        if "energy_start" in self.loop:
            self.loop["energy_error"], self.loop["energy_windows"] = self.energy_guard.progress_so_far()
        arrays = {name: arr.numpy() for name, arr in self.state.arrays().items()}
        if self.solver.layout is not None:
            arrays.update(self.solver.layout.arrays())
        arrays["displacement_origin"] = self.origin
        arrays["energy_ledger"] = self.solver.energy.ledger.numpy()
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
        """Stop with :class:`OutputError` before a write that the disk has no room for: HDF5 cut off
        by a full disk leaves its files and its own state broken (the process can crash on exit)."""
        need = 2 * sum(np.asarray(a).nbytes for a in arrays.values()) + OUTPUT_RESERVE
        free = shutil.disk_usage(self.out).free
        if free < need:
            raise OutputError(f"cannot write the run's output in {self.out}: {free / 1e6:.3g} MB left on its disk, "
                              f"the next write needs {need / 1e6:.3g} MB; {self._kept}")  # fmt: skip

    # -- output -----------------------------------------------------------------------------------
    def _sample_probes(self, fields=None) -> None:
        if not self.probes.probes:
            return
        self._check()  # nothing is written from a step the guards marked
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

    def _frame(self) -> FrameContent:
        """What a frame of the current state holds: the host fields and the frame's arrays."""
        fields = host_fields(self.model, self.state)
        frame = {"position": fields["position"]}
        if self.staged:
            frame["id"] = self.model.particle_ids
        wanted = self.phase_scene.output.fields
        if "velocity" in wanted:
            frame["velocity"] = fields["velocity"]
        if "displacement" in wanted:
            frame["displacement"] = fields["position"] - self.origin
        if "stress" in wanted:
            frame["stress"] = tensor_to_voigt(fields["stress"])
        if "pore_pressure" in fields:
            frame["pore_pressure"] = fields["pore_pressure"]
        if "plastic_strain" in fields:
            frame["plastic_strain"] = fields["plastic_strain"]
        if "darcy_velocity" in wanted:
            frame["darcy_velocity"] = self.solver.projection.darcy_velocity(self.state)
        if self.flow is not None:
            frame["saturation"] = self.flow.saturation_field()
        return FrameContent(fields, frame, None)

    def _write_frame(self, content: FrameContent | None = None, **attrs) -> None:
        """Write a frame of the current state, or the ``content`` of one made elsewhere (a safety trial's
        last state; ``attrs``: extra attributes of the frame)."""
        self._check()  # nothing is written from a step the guards marked
        fields, frame, balance = content or self._frame()
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
                                 {k: v for k, v in frame.items() if k not in ("position", "id")})  # fmt: skip
        self.summary.frames += 1

    def _write_record(self, status: str, message: str = "") -> None:
        record = {
            "scene": self.scene.name,
            "status": status,
            "message": message,
            "warpsph_version": warpsph.__version__,
            "warp_version": wp.config.version,
            "python": platform.python_version(),
            "device": str(self.model.device),
            "precision": self.model.spec.precision,
            "scheme": self.model.spec.scheme,
            "integrator": self.model.spec.integrator,
            "kernel": self.model.spec.kernel,
            "dim": self.model.spec.dim,
            "end_time": self.end_time,
            "resumed": self.resumed,
            **asdict(self.summary),
            "particle_steps_per_second": self.summary.particle_steps_per_second,
        }
        projection = self.solver.projection
        if projection is not None and projection.iterations:
            its = np.asarray(projection.iterations)
            record["pressure_solve"] = {
                "solver": self.scene.pressure.solver, "tolerance": self.scene.pressure.tolerance,
                "iterations_total": int(its.sum()), "iterations_mean": float(its.mean()),
                "iterations_max": int(its.max()), "residual_max": float(np.max(projection.residuals)),
                "missed_tolerance": projection.failures, "free_surface_warning": projection.surface_warning,
            }  # fmt: skip
        tmp = self.out / (RECORD + ".tmp")
        try:
            tmp.write_text(json.dumps(record, indent=2, default=str))
            os.replace(tmp, self.out / RECORD)
        finally:
            tmp.unlink(missing_ok=True)

    # -- one step ---------------------------------------------------------------------------------
    def _warm_up(self) -> None:
        if self.phase.kind == "flow":  # no mechanical step: the flow kernels compile at their first use
            return
        self.summary.compile_seconds += warm_up(self.solver, self.guard, self.state, self.scratch, self.phase_time,
                                                self.dt)  # fmt: skip
        if self.solver.damping is not None:
            self.solver.damping.read()

    def _check(self) -> None:
        """Read what the run guards marked on the device since the last read; stop the run at the first
        step they marked, naming what was wrong then (once a step)."""
        if self._checked == self.step_index:
            return
        self._checked = self.step_index
        flagged = self.guard.read()
        grown = self.energy_guard.read() if "energy_start" in self.loop else None
        if grown is not None and (flagged is None or grown[0] < flagged.step):
            step, window, made, ratio = grown
            self._unstable(f"the energy made from nothing grew over three windows of {GUARD_WINDOW} steps, to "
                           f"{window:.4g} J in the last, {100 * made:.3g} % of the energy in play (limit "
                           f"{100 * ENERGY_MADE_LIMIT:g} %) and {ratio:.3g} times the first's (limit "
                           f"{ENERGY_GROWTH:g})", step)  # fmt: skip
        if flagged is None:
            return
        where = np.array2string(flagged.position, precision=4)
        if flagged.particle is None:
            self._unstable(f"virtual point {flagged.point} at {where} m has the density {flagged.density:.4g} kg/m³",
                           flagged.step)  # fmt: skip
        broken = [f"a non-finite {name.replace('_', ' ')}" for name in flagged.not_finite]
        if not flagged.density > 0.0 and "density" not in flagged.not_finite:
            broken.append(f"a non-positive density ({flagged.density:.4g} kg/m³)")
        if broken:
            what = f"has {' and '.join(broken)}"
        else:
            what = f"moves at {flagged.speed:.4g} m/s, beyond {self.phase_scene.speed_limit_text}"
        self._unstable(f"particle {flagged.particle} at {where} m {what}", flagged.step)

    def _unstable(self, what: str, step: int | None = None):
        """Stop the run, unstable at ``step`` (default: this one) of the current phase."""
        step = self.step_index if step is None else step
        where = f" (phase {self.phase.name})" if self.staged else ""
        time = self.time - (self.step_index - step) * self.dt
        raise SimulationError(
            f"unstable at step {step}{where}, t = {time:.6g} s: {what}; the last good checkpoint "
            f"(step {self.checkpoint_step}) and the frames written are kept in {self.out}")

    def _step(self) -> None:
        self.solver.step(self.state, self.scratch, self.phase_time, self.dt)
        self.state, self.scratch = self.scratch, self.state
        self.step_index += 1
        self.summary.steps += 1
        self.guard.mark(self.state, self.step_index)
        k = self.step_index - self.phase_start_step
        if k % GUARD_WINDOW == 0 and "energy_start" in self.loop:
            self.energy_guard.mark(self.state, self.step_index)
        if k % CHECK_EVERY == 0:
            self._check()
            if self.phase.kind != "safety" and "energy_start" in self.loop:  # a trial's is written with its frame
                self._energy_series(self._energy_balance())
        self._record_pressure_solve()

    def _output(self, last: bool, frame_every: int, ck_every: int) -> None:
        """Frames, probe samples and checkpoints at their cadence (steps since the phase's start)."""
        k = self.step_index - self.phase_start_step
        if k % frame_every == 0 or last:
            self._write_frame()
        elif self.step_index % self.phase_scene.output.probe_every == 0:
            self._sample_probes()
        if k % ck_every == 0 or last:
            self._checkpoint()

    def _cadence(self, damped: bool) -> tuple[int, int]:
        out = self.phase_scene.output
        frame_every = max(1, round(out.frame_interval / self.dt))
        ck_every = max(1, round(out.checkpoint_interval / self.dt)) if out.checkpoint_interval > 0 else frame_every
        if damped:  # checkpoints where the damping's sums have just been read
            ck_every = CHECK_EVERY * math.ceil(ck_every / CHECK_EVERY)
        return frame_every, ck_every

    def _stop_step(self) -> int | None:
        """The step at which ``--end-time`` stops the run (None without it, or without phases)."""
        if self.stop_time is None or not self.staged or self.phase.kind in IMPLICIT_PHASE_KINDS:
            return None
        return self.phase_start_step + math.ceil((self.stop_time - self.phase_start_time) / self.dt - 1e-9)

    # -- phases' loops ----------------------------------------------------------------------------
    def _run_dynamic(self, progress) -> str:
        phase = self.phase
        duration = phase.duration if self.staged else self.end_time
        n_end = max(self.step_index, self.phase_start_step + math.ceil(duration / self.dt - 1e-9))
        if self.staged:
            n_end = min(n_end, self.phase_start_step + phase.max_steps)
        stop = self._stop_step()
        if stop is not None and stop < n_end:
            n_end = max(self.step_index, stop)
        frame_every, ck_every = self._cadence(False)
        outcome = FINISHED if stop is None or stop >= n_end else STOPPED
        mass = self.model.particle_mass.numpy()[: self.model.particle_count]
        while self.step_index < n_end:
            self._step()
            k = self.step_index - self.phase_start_step
            at_rest = False
            if phase.at_rest > 0.0 and k % CHECK_EVERY == 0:
                v = self.state.particle_v.numpy()[: self.model.particle_count].astype(np.float64)
                energy = 0.5 * float(np.sum(mass * np.sum(v * v, axis=1)))
                peak = max(self.loop.get("peak_energy", 0.0), energy)
                self.loop["peak_energy"] = peak
                self.results.append_series("kinetic_energy", self.step_index, self.time, energy)
                at_rest = peak > 0.0 and energy < phase.at_rest * peak
                self.records[-1].criterion = energy / peak if peak > 0.0 else 0.0
            self._output(self.step_index == n_end or at_rest, frame_every, ck_every)
            if progress is not None:
                progress(self.time, self.step_index)
            if at_rest:
                return AT_REST
            self._stop_if_interrupted()
        return outcome

    def _run_flow(self, progress) -> str:
        """Groundwater flow through the fixed skeleton (:class:`~warpsph.stages.groundwater.GroundwaterFlow`):
        the steady state, or a transient of the phase's duration (:meth:`_implicit_steps`)."""
        phase, flow, record = self.phase, self.flow, self.records[-1]
        if phase.steady:
            converged = flow.solve(0.0, None, max_iterations=phase.max_steps)
            self.step_index += flow.iterations
            self.summary.steps += flow.iterations
            self._flow_series()
            record.criterion = flow.iterations
            self._write_frame()
            self._checkpoint()
            return CONVERGED if converged else NOT_CONVERGED
        return self._implicit_steps(flow, progress)

    def _run_consolidation(self, progress) -> str:
        """The coupled quasi-static transient of the phase's duration
        (:class:`~warpsph.stages.consolidation.FixedStressSplit`, :meth:`_implicit_steps`)."""
        return self._implicit_steps(self.split, progress)

    def _equilibrate_held(self, t: float) -> tuple[bool, State]:
        """A consolidation iterate's skeleton: equilibrium under the state's pore pressures held, the
        loads at phase time ``t`` [s]; (converged within the phase's step cap, the state)."""
        self.loop["time"] = t
        self.scratch.assign(self.state)
        self.solver.hold_pore_pressure(self.state)
        self.loop.pop("ratio", None)
        converged, _ratio = self._equilibrate(None, self.step_index, output=False)
        return converged, self.state

    def _implicit_steps(self, stepper, progress) -> str:
        """A transient of the phase's duration in implicit steps of ``stepper`` (the flow, or the
        consolidation's split: ``solve(t, dt)``, ``undo()``, ``step_change``) sized by the pressure
        change they make (``STEP_CHANGE``), halved after one whose iteration fails, ending on each of
        the phase's frame times. A flow phase's ``max_steps`` caps its steps; a consolidation phase
        whose skeleton does not reach equilibrium within ``max_steps`` ends not converged."""
        phase, record = self.phase, self.records[-1]
        frame_times = phase.duration * np.arange(1, phase.frames + 1) / phase.frames
        dt = self.loop.get("dt", phase.time_step or phase.duration / 1000.0)
        stop = math.inf if self.stop_time is None else self.stop_time - self.phase_start_time
        rejected = None  # (change, step) of the first try of a step being retried shorter
        if stepper is self.split:  # the split's scale of the pressure changes, kept in checkpoints
            stepper.pressure_scale = self.loop.get("pressure_scale", stepper.pressure_scale)
        while self.phase_time < phase.duration * (1.0 - 1e-12):
            t = self.phase_time
            if t >= stop:
                return STOPPED
            self._stop_if_interrupted()
            target = float(frame_times[np.searchsorted(frame_times, t * (1.0 + 1e-12) + 1e-300, side="right")])
            step = min(dt, target - t)
            steps = self.loop.get("steps", 0)
            if stepper is self.flow and steps >= phase.max_steps:
                return NOT_CONVERGED
            converged = stepper.solve(t + step, step)
            self.loop["time"] = t
            if stepper is self.split and stepper.collapsed:
                self._write_frame()
                return NOT_CONVERGED
            smallest = 1e-12 * phase.duration
            # a change that does not shrink with the step (a seepage face's exit point moving on, soil
            # that follows its neighbours at once) is not the step's error: the step stands
            step_driven = rejected is None or stepper.step_change < 0.75 * rejected[0]
            if not converged or (stepper.step_change > 1.5 and step_driven and step > smallest):
                dt = 0.5 * step if not converged else step * max(0.25, 0.8 / stepper.step_change)
                if dt < smallest:
                    self._unstable(f"the {phase.kind} does not converge even with a time step of {step:.3g} s")
                if converged:  # too large a change: put the step back
                    stepper.undo()
                    rejected = (stepper.step_change, step if rejected is None else rejected[1])
                continue
            self.loop["time"] = t + step if target - (t + step) > 1e-9 * phase.duration else target
            if not step_driven:  # the next step is tried as long as this one was first
                dt = rejected[1]
            elif step >= dt:  # not a step shortened to meet a frame time
                dt = step * min(1.5, 0.9 / max(stepper.step_change, 1e-300))
            rejected = None
            self.loop["dt"], self.loop["steps"] = dt, steps + 1
            if stepper is self.flow:
                self.step_index += 1
                self.summary.steps += 1
            else:
                self.loop["pressure_scale"] = stepper.pressure_scale
            record.criterion = self.loop["time"]
            self._flow_series()
            if not np.all(np.isfinite(self.state.particle_pore_pressure.numpy())):
                self._unstable("the pore pressure is not finite")
            if self.loop["time"] == target:
                self._write_frame()
                self._checkpoint()
            if progress is not None:
                progress(self.time, self.step_index)
        return FINISHED

    def _flow_series(self) -> None:
        """A flow step's discharges, storage rate and iterations as series."""
        flow = self.flow
        for name, value in flow.discharge.items():
            self.results.append_series(f"discharge_{name}", self.step_index, self.time, value)
        self.results.append_series("storage_rate", self.step_index, self.time, flow.storage_rate)
        self.results.append_series("flow_iterations", self.step_index, self.time, flow.iterations)
        if self.split is not None:
            self.results.append_series("consolidation_iterations", self.step_index, self.time, self.split.iterations)

    def _applied_force(self) -> float:
        """Σ m‖g‖ over the particles plus the loads' resultants at the phase's time [N/m or N]: the
        scale of the unbalanced-force ratio (docs/scenes.md, *Phases*)."""
        if self._load_scale is None:
            self._load_scale = self._applied_force_parts()
        total, loads = self._load_scale
        for resultant, time_function in loads:
            total += resultant * abs(time_function(self.phase_time))
        return total

    def _applied_force_parts(self) -> tuple[float, list]:
        """What :meth:`_applied_force` needs that a phase does not change: Σ m‖g‖, and each traction
        plane's and force load's full resultant with its time function."""
        m = self.model
        weight = float(np.sum(m.particle_mass.numpy()[: m.particle_count])) * float(np.linalg.norm(m.gravity))
        counts = np.bincount(m.constraint_planes.numpy().reshape(-1, 3).ravel() + 1, minlength=m.plane_count + 1)
        kinds, vectors = m.plane_kind.numpy(), m.plane_vector.numpy()
        loads = [(counts[p + 1] * m.dx ** (m.spec.dim - 1) * float(np.linalg.norm(vectors[p])), m.plane_functions[p])
                 for p in range(m.plane_count) if kinds[p] == PLANE_TRACTION]  # fmt: skip
        loads += [(float(np.linalg.norm(ld.force)), ld.time_function) for ld in self.phase_scene.loads
                  if ld.kind == "force"]  # fmt: skip
        return weight, loads

    def _equilibrate(self, progress, first: int, output: bool = True,
                     start: tuple[np.ndarray, float] | None = None) -> tuple[bool, float]:
        """Damped steps from step ``first`` until the unbalanced-force ratio falls below the phase's
        tolerance (True) or its step cap is reached (False); also the last ratio. ``output``: write
        frames and checkpoints at their cadence (a safety trial writes its last frame only).
        ``start`` = (positions (N,3) [m], limit [m]): also False once a particle has moved farther
        than the limit from its start position (a safety trial's failure displacement)."""
        phase = self.phase
        frame_every, ck_every = self._cadence(True)
        ratio = self.loop.get("ratio", math.inf)
        stop = self._stop_step()
        while True:
            self._step()
            k = self.step_index - first
            converged = capped = False
            if k % CHECK_EVERY == 0:
                unbalanced, energy = self.solver.damping.read()
                ratio = unbalanced / max(self._applied_force(), 1e-300)
                self.loop["ratio"] = ratio
                self.results.append_series("unbalanced_force_ratio", self.step_index, self.time, ratio)
                self.results.append_series("kinetic_energy", self.step_index, self.time, energy)
                converged = ratio < phase.tolerance
                capped = not converged and k >= phase.max_steps
                if start is not None and not converged:
                    capped = capped or largest_displacement(self.state.particle_q, start[0]) > start[1]
            stopped = stop is not None and self.step_index >= stop and k % CHECK_EVERY == 0
            if output:
                self._output(converged or capped or stopped, frame_every, ck_every)
            if progress is not None:
                progress(self.time, self.step_index)
            if converged or capped or stopped:
                if stopped and not (converged or capped):
                    raise _Stopped()
                return converged, ratio
            if k % CHECK_EVERY == 0:  # where a checkpoint resumes bit-identical (a safety trial keeps none)
                self._stop_if_interrupted(checkpoint=output)

    def _stop_if_interrupted(self, checkpoint: bool = True) -> None:
        """After SIGINT or SIGTERM: checkpoint this step (unless told not to) and stop the run."""
        if self.interrupted is not None:
            if checkpoint:
                self._checkpoint()
            raise _Interrupted()

    def _on_signal(self, signum, frame) -> None:
        if self.interrupted is not None:  # a second signal: stop at once
            raise KeyboardInterrupt
        self.interrupted = signal.Signals(signum).name

    def _run_equilibrium(self, progress) -> str:
        converged, ratio = self._equilibrate(progress, self.phase_start_step)
        self.records[-1].criterion = ratio
        return CONVERGED if converged else NOT_CONVERGED

    def _run_safety(self, progress) -> str:
        """Strength reduction (:class:`~warpsph.phases.FactorSearch`): each trial an equilibrium from
        the phase's start state with c, tan φ and tan ψ divided by the trial factor F; a trial stands
        when it converges within the phase's step cap, and fails at the cap or once a particle has
        moved farther than the failure displacement. Each trial's last state is written as a frame
        (attributes ``factor`` and ``converged``), the state is then put back to the phase's start and
        checkpointed, so the next phase starts from the unreduced state. With trial workers (``Run``'s
        ``trial_workers`` or ``scheduler``) the trials of a round run at once on Dask, one per worker,
        each from the phase's start checkpoint (:func:`remote_safety_trial`); their steps count as if run in
        turn."""
        phase, record = self.phase, self.records[-1]
        with contextlib.ExitStack() as stack:
            client = None
            if self.scheduler or (self.trial_workers or 0) > 1:
                from warpsph.study.execute import dask_client

                client = stack.enter_context(dask_client(self.scheduler, self.trial_workers))
            width = len(client.scheduler_info()["workers"]) if client is not None else 1
            search = FactorSearch(phase.factor_tolerance, phase.factor_max, self.loop.get("search"), width)
            self.loop["search"] = search.state
            while search.factors:
                if client is None:
                    outcomes = [self.safety_trial(search.factor, progress)]
                else:
                    outcomes = self._remote_trials(client, search.factors)
                for outcome in outcomes:
                    record.trials.append([outcome.factor, int(outcome.converged), outcome.ratio, outcome.steps,
                                          outcome.moved])  # fmt: skip
                    self.step_index += outcome.steps
                    if client is not None:
                        self.summary.steps += outcome.steps
                    if outcome.frame is not None:
                        self._write_frame(outcome.frame, factor=outcome.factor, converged=int(outcome.converged))
                    search.record(outcome.factor, outcome.converged)
                self._checkpoint()
                if progress is not None:
                    progress(self.time, self.step_index)
                stop = self._stop_step()
                if search.factors and stop is not None and self.step_index >= stop:
                    raise _Stopped()
                self._stop_if_interrupted(checkpoint=False)
        record.criterion = search.result
        return CONVERGED if search.bracketed else NOT_CONVERGED

    def _remote_trials(self, client, factors: list[float]) -> list[TrialOutcome]:
        """The trials at ``factors`` on the Dask workers of ``client``, in the order of ``factors``."""
        checkpoint = (self.out / CHECKPOINT).read_bytes()  # the phase's start and the search so far
        futures = [client.submit(remote_safety_trial, self.scene, checkpoint, factor, self.device, self.precision,
                                 key=f"warpsph-trial-{self.phase.name}-{factor!r}-{self.step_index}")
                   for factor in factors]  # fmt: skip
        return client.gather(futures)

    def safety_trial(self, factor: float, progress=None) -> TrialOutcome:
        """One trial of the current safety phase at ``factor`` from the current state (the phase's start),
        which it then puts back with the step index; the outcome carries the frame of its last state
        (None where the run guard stopped it: a mechanism ran away, the trial failed)."""
        phase = self.phase
        start = {name: arr.numpy().copy() for name, arr in self.state.arrays().items()}
        materials = list(self.phase_scene.materials.values())
        spec, device = self.model.spec, self.model.device
        positions = start["particle_q"][: self.model.particle_count]
        limit = phase.failure_displacement or FAILURE_DISPLACEMENT * self._height(positions)
        self.model.material_plasticity = plastic_materials(spec, [reduced_strength(m, factor) for m in materials],
                                                           device)  # fmt: skip
        first = self.step_index
        self.loop.pop("ratio", None)
        self._start_energy()
        self.guard.clear()
        self._checked = None
        try:
            converged, ratio = self._equilibrate(progress, first, output=False, start=(positions, limit))
            moved = largest_displacement(self.state.particle_q, positions)
        except SimulationError:
            converged, ratio, moved = False, math.inf, math.inf
        frame = self._frame()._replace(balance=self._energy_balance()) if math.isfinite(moved) else None
        steps = self.step_index - first
        for name, arr in self.state.arrays().items():
            arr.assign(start[name])
        self.scratch.assign(self.state)
        self.step_index = first
        self._start_energy()
        self.guard.clear()
        self._checked = None
        self.model.material_plasticity = plastic_materials(spec, materials, device)
        return TrialOutcome(factor, converged, ratio, steps, moved, frame)

    def _energy_series(self, balance: dict[str, float] | None) -> None:
        """The energy balance as series (``energy_kinetic``, …) at the current step."""
        for key, value in (balance or {}).items():
            self.results.append_series(f"energy_{key}", self.step_index, self.time, value)

    def _start_energy(self) -> None:
        """Start the energy balance (and the run guard's check of it) from the current state."""
        if self._books_energy:
            self.loop["energy_start"] = self.solver.energy.sums(self.state).tolist()
            self.loop["energy_error"], self.loop["energy_windows"] = 0.0, []
            self.energy_guard.begin(self.loop["energy_start"])

    def _energy_report(self) -> dict:
        """The phase's energy balance at its end and one line per check it fails (:func:`balance_warnings`;
        the command line prints them): ``{"energy": ..., "energy_warnings": [...]}``, the balance None
        for a phase that keeps none and for a safety phase (each trial's is with the trial's frame)."""
        balance = self._energy_balance() if self.phase.kind != "safety" else None
        return {"energy": balance, "energy_warnings": balance_warnings(balance) if balance is not None else []}

    def _height(self, positions: np.ndarray) -> float:
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
            self._warm_up()
            start = time.perf_counter()
            if not self.resumed:
                self._write_frame()
                self._checkpoint()
            loops = {"k0": lambda progress: CONVERGED, "dynamic": self._run_dynamic,
                     "equilibrium": self._run_equilibrium, "safety": self._run_safety,
                     "flow": self._run_flow, "consolidation": self._run_consolidation}  # fmt: skip
            while True:
                record = self.records[-1]
                outcome = loops[self.phase.kind](progress)
                record.last_step, record.end_time, record.outcome = self.step_index, self.time, outcome
                self.summary.phases.append({"name": record.name, "kind": record.kind, "outcome": outcome,
                                            "criterion": record.criterion, "steps": record.last_step
                                            - record.first_step, "trials": record.trials,
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
                self._warm_up()
                start += time.perf_counter() - compile_before
                self._write_frame()
                self._checkpoint()
        except (_Stopped, _Interrupted) as e:
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


def os_reason(error: OSError) -> str:
    """The short reason of an I/O error ("No space left on device"), not HDF5's page of detail."""
    if error.strerror:
        return error.strerror
    found = re.search(r"error message = '([^']+)'", str(error))
    if found:
        return found.group(1)
    return str(error).splitlines()[0][:200] if str(error) else type(error).__name__


def largest_displacement(positions: wp.array, start: np.ndarray) -> float:
    """The largest distance [m] of the owned particles' ``positions`` from their ``start`` (N,3)."""
    moved = positions.numpy()[: len(start)] - start
    return float(np.sqrt(np.max(np.sum(moved * moved, axis=1))))


class _Stopped(Exception):
    """``--end-time`` reached inside an equilibrium phase."""


class _Interrupted(Exception):
    """SIGINT or SIGTERM asked the run to stop."""


def remote_safety_trial(scene: Scene, checkpoint: bytes, factor: float, device: str | None,
                        precision: str | None) -> TrialOutcome:  # fmt: skip
    """One trial of a safety phase on a Dask worker: the run resumed from the phase's ``checkpoint``
    (the bytes of its file) in a scratch directory, without USD or XDMF output, and its trial at
    ``factor`` (:meth:`Run.safety_trial`)."""
    import tempfile

    from warpsph.environment import init_warp

    init_warp()
    scene = copy.deepcopy(scene)
    scene.output.usd = scene.output.xdmf = False
    with tempfile.TemporaryDirectory(prefix="warpsph-trial-") as scratch:
        (Path(scratch) / CHECKPOINT).write_bytes(checkpoint)
        run = Run(scene, scratch, device=device, precision=precision, resume=True)
        try:
            run._warm_up()
            return run.safety_trial(factor)
        finally:
            run.results.close()
            run.directory.release()


def run_scene(scene: Scene, out_dir, **kwargs) -> RunSummary:
    """Build, run and write ``scene`` into ``out_dir``; keyword arguments as for :class:`Run`."""
    progress = kwargs.pop("progress", None)
    return Run(scene, out_dir, **kwargs).run(progress=progress)
