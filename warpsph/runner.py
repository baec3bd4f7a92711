"""Scripted runs: time loop, output cadence, checkpoints, run guards and the run record.

``run_scene(scene, out_dir)`` is what ``warpsph run`` calls. A run writes into ``out_dir``:
``results.h5`` (+ ``results.xdmf``), ``particles.usdc`` (+ clips), ``checkpoint.h5`` and ``run.json``
(docs/output.md). If a step produces NaN, infinity or a speed beyond the scene's bound, the run
stops with :class:`SimulationError`; everything written before, the last good checkpoint included,
stays on disk.
"""

from __future__ import annotations

import json
import math
import platform
import time
import warnings
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
import warp as wp

import warpsph
from warpsph.builder import build
from warpsph.errors import InputError, SimulationError
from warpsph.fields import tensor_to_voigt
from warpsph.io import ResultsWriter, UsdParticleCache, load_checkpoint, save_checkpoint, write_xdmf
from warpsph.model import Model, State
from warpsph.probes import Probes
from warpsph.scene import Scene
from warpsph.solver import Solver
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

    @property
    def particle_steps_per_second(self) -> float:
        return self.particles * self.steps / self.wall_seconds if self.wall_seconds > 0 else 0.0


def host_fields(model: Model, state: State) -> dict[str, np.ndarray]:
    """Owned-particle fields on the host: position, velocity (N,3) [m, m/s], stress (N,3,3) [Pa],
    density [kg/m³], with pore water the total pore pressure (N,) [Pa] and with plasticity the
    equivalent plastic strain (N,) [-]."""
    n = model.particle_count
    fields = {
        "position": state.particle_q.numpy()[:n].astype(np.float64),
        "velocity": state.particle_v.numpy()[:n].astype(np.float64),
        "stress": state.particle_stress.numpy()[:n].astype(np.float64),
        "density": state.particle_density.numpy()[:n].astype(np.float64),
    }
    if model.pore is not None:
        water_density = model.pore.material_water_density.numpy()[model.particle_material.numpy()[:n]]
        hydrostatic = model.pore.hydrostatic(fields["position"], water_density)
        fields["pore_pressure"] = state.particle_pore_pressure.numpy()[:n] + hydrostatic
    if state.particle_plastic_strain is not None:
        fields["plastic_strain"] = state.particle_plastic_strain.numpy()[:n].astype(np.float64)
    return fields


def warm_up(solver: Solver, guard: Guard, state: State, scratch: State, t: float, dt: float) -> float:
    """Compile every kernel by one throw-away step from ``state`` into ``scratch`` (which is reset
    to ``state`` afterwards) and clear the solver's statistics; return its wall time [s]."""
    start = time.perf_counter()
    with warnings.catch_warnings():  # the throw-away step reports nothing
        warnings.simplefilter("ignore")
        solver.step(state, scratch, t, dt)
    guard.find(scratch)
    wp.synchronize_device(solver.model.device)
    scratch.assign(state)
    solver.stage_seconds.clear()
    if solver.projection is not None:
        solver.projection.reset_statistics()
    return time.perf_counter() - start


class Run:
    """One simulation run of ``scene`` into ``out_dir`` (see module docstring)."""

    def __init__(self, scene: Scene, out_dir, *, device: str | None = None, precision: str | None = None,
                 end_time: float | None = None, resume: bool = False, profile: bool = False):  # fmt: skip
        self.scene = scene
        self.out = Path(out_dir)
        self.out.mkdir(parents=True, exist_ok=True)
        self.end_time = scene.simulation.end_time if end_time is None else end_time
        self.model, self.state = build(scene, device=device, precision=precision)
        self.scratch = self.model.state()
        self.scratch.assign(self.state)
        self.solver = Solver(self.model, profile=profile)
        self.guard = Guard(self.model, scene.speed_limit)
        self.probes = Probes(self.model)
        self.dt = scene.time_step
        self.step_index = 0
        self.checkpoint_step = None  # step of the last checkpoint written or resumed from
        self.resumed = False
        if resume and (self.out / CHECKPOINT).exists():
            self._restore(load_checkpoint(self.out / CHECKPOINT))
        elif resume:
            raise InputError(f"--resume: no {CHECKPOINT} in {self.out}")
        start_step = self.step_index if self.resumed else None
        self.results = ResultsWriter(self.out / RESULTS, dim=scene.simulation.dim, scene_text=scene.source_text,
                                     particle_ids=self.model.particle_ids, warpsph_version=warpsph.__version__,
                                     resume_step=start_step)  # fmt: skip
        self.usd = None
        if scene.output.usd:
            self.usd = UsdParticleCache(self.out, radius=0.5 * self.model.dx, resume_step=start_step)
        self.summary = RunSummary(time_step=self.dt, particles=self.model.particle_count,
                                  virtual_particles=self.model.virtual_count)  # fmt: skip

    @property
    def time(self) -> float:
        """Simulated time of the current state [s] (step × Δt, so restarts reproduce it exactly)."""
        return self.step_index * self.dt

    # -- checkpoints ------------------------------------------------------------------------------
    def _restore(self, ck) -> None:
        for name, arr in self.state.arrays().items():
            if name not in ck.arrays or ck.arrays[name].shape != arr.numpy().shape:
                raise InputError(f"--resume: the checkpoint does not match this scene (array {name})")
            arr.assign(ck.arrays[name])
        if self.solver.layout is not None:
            self.solver.layout.restore(ck.arrays)
        if float(ck.meta.get("time_step", self.dt)) != self.dt:
            raise InputError("--resume: the checkpoint was written with another time step")
        self.scratch.assign(self.state)
        self.step_index = self.checkpoint_step = ck.step
        self.resumed = True

    def _checkpoint(self) -> None:
        self.checkpoint_step = self.step_index
        arrays = {name: arr.numpy() for name, arr in self.state.arrays().items()}
        if self.solver.layout is not None:
            arrays.update(self.solver.layout.arrays())
        save_checkpoint(self.out / CHECKPOINT, step=self.step_index, time=self.time, arrays=arrays,
                        meta={"time_step": self.dt, "scene": self.scene.name,
                              "precision": self.model.spec.precision})  # fmt: skip

    # -- output -----------------------------------------------------------------------------------
    def _sample_probes(self, fields=None) -> None:
        if not self.probes.probes:
            return
        fields = fields or host_fields(self.model, self.state)
        for name, value in self.probes.sample(fields, self.solver.rigid.contact_forces()).items():
            self.results.append_series(name, self.step_index, self.time, value)

    def _record_pressure_solve(self) -> None:
        """Iterations and final relative residual of this step's pressure solve, as series."""
        projection = self.solver.projection
        if projection is None:
            return
        self.results.append_series("pressure_iterations", self.step_index, self.time, projection.iterations[-1])
        self.results.append_series("pressure_residual", self.step_index, self.time, projection.residuals[-1])

    def _write_frame(self) -> None:
        fields = host_fields(self.model, self.state)
        frame = {"position": fields["position"]}
        wanted = self.scene.output.fields
        if "velocity" in wanted:
            frame["velocity"] = fields["velocity"]
        if "displacement" in wanted:
            frame["displacement"] = fields["position"] - self.model.particle_x0
        if "stress" in wanted:
            frame["stress"] = tensor_to_voigt(fields["stress"])
        if "pore_pressure" in fields:
            frame["pore_pressure"] = fields["pore_pressure"]
        if "plastic_strain" in fields:
            frame["plastic_strain"] = fields["plastic_strain"]
        if "darcy_velocity" in wanted:
            frame["darcy_velocity"] = self.solver.projection.darcy_velocity(self.state)
        self._sample_probes(fields)
        self.results.write_frame(self.step_index, self.time, frame)
        if self.scene.output.xdmf:
            write_xdmf(self.out / RESULTS)
        if self.usd is not None:
            self.usd.write_frame(self.step_index, self.time, frame["position"],
                                 {k: v for k, v in frame.items() if k != "position"})  # fmt: skip
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
        (self.out / RECORD).write_text(json.dumps(record, indent=2, default=str))

    # -- the loop ---------------------------------------------------------------------------------
    def _warm_up(self) -> None:
        self.summary.compile_seconds = warm_up(self.solver, self.guard, self.state, self.scratch, self.time, self.dt)

    def _check(self) -> None:
        bad, point = self.guard.find(self.state)
        if bad is None:
            if point is not None:
                q = self.state.virtual_q.numpy()[point]
                density = float(self.state.virtual_density.numpy()[point])
                self._unstable(f"virtual point {point} at {np.array2string(q, precision=4)} m has the density "
                               f"{density:.4g} kg/m³")  # fmt: skip
            return
        f = host_fields(self.model, self.state)
        broken = [f"a non-finite {name.replace('_', ' ')}" for name in ("position", "velocity", "stress", "density",
                  "pore_pressure") if name in f and not np.all(np.isfinite(f[name][bad]))]  # fmt: skip
        if f["density"][bad] <= 0.0:
            broken.append(f"a non-positive density ({f['density'][bad]:.4g} kg/m³)")
        if broken:
            what = f"has {' and '.join(broken)}"
        else:
            what = f"moves at {float(np.linalg.norm(f['velocity'][bad])):.4g} m/s, beyond {self.scene.speed_limit_text}"
        self._unstable(f"particle {bad} at {np.array2string(f['position'][bad], precision=4)} m {what}")

    def _unstable(self, what: str):
        raise SimulationError(
            f"unstable at step {self.step_index}, t = {self.time:.6g} s: {what}; the last good checkpoint "
            f"(step {self.checkpoint_step}) and the frames written are kept in {self.out}")

    def run(self, progress=None) -> RunSummary:
        """Step to the end time, writing frames, probes and checkpoints; return the summary.

        ``progress(time, step)`` is called after every step when given.
        """
        out = self.scene.output
        n_end = max(self.step_index, math.ceil(self.end_time / self.dt - 1e-9))
        frame_every = max(1, round(out.frame_interval / self.dt))
        ck_every = max(1, round(out.checkpoint_interval / self.dt)) if out.checkpoint_interval > 0 else frame_every
        status, message = "failed", ""
        start = time.perf_counter()
        try:
            self._warm_up()
            start = time.perf_counter()
            if not self.resumed:
                self._write_frame()
                self._checkpoint()
            while self.step_index < n_end:
                self.solver.step(self.state, self.scratch, self.time, self.dt)
                self.state, self.scratch = self.scratch, self.state
                self.step_index += 1
                self.summary.steps += 1
                self._check()
                self._record_pressure_solve()
                last = self.step_index == n_end
                if self.step_index % frame_every == 0 or last:
                    self._write_frame()
                elif self.step_index % out.probe_every == 0:
                    self._sample_probes()
                if self.step_index % ck_every == 0 or last:
                    self._checkpoint()
                if progress is not None:
                    progress(self.time, self.step_index)
            status = "finished"
        except SimulationError as e:
            message = str(e)
            raise
        finally:
            wp.synchronize_device(self.model.device)
            self.summary.wall_seconds = time.perf_counter() - start
            self.summary.final_step, self.summary.final_time = self.step_index, self.time
            self.summary.stage_seconds = dict(self.solver.stage_seconds)
            self.results.close()
            self._write_record(status, message)
        return self.summary


def run_scene(scene: Scene, out_dir, **kwargs) -> RunSummary:
    """Build, run and write ``scene`` into ``out_dir``; keyword arguments as for :class:`Run`."""
    progress = kwargs.pop("progress", None)
    return Run(scene, out_dir, **kwargs).run(progress=progress)
