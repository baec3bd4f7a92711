"""What a run of a scene will cost before it starts: particles, time step, steps, run time on this
machine (from a few timed steps) and output size; ``warpsph validate`` prints it (docs/output.md,
*Before a run*)."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

from warpsph.errors import SimulationError
from warpsph.phases import default_phases, phase_scene
from warpsph.scene import IMPLICIT_PHASE_KINDS, Scene

TIMED_STEPS, TIMED_SECONDS = 20, 2.0
"""The estimate times steps until either is reached, after one compiling step."""
MANY_STEPS = 10_000_000
"""A run planned for more steps than this gets a warning: mostly a unit typed wrong."""
LONG_RUN, LARGE_OUTPUT = 86400.0, 10e9
"""A run estimated to take longer than this [s], or to write more than this [B], gets a warning."""
_COMPONENTS = {"position": 3, "id": 1, "velocity": 3, "displacement": 3, "stress": 6, "pore_pressure": 1,
               "plastic_strain": 1, "darcy_velocity": 3, "saturation": 1}  # fmt: skip


@dataclass
class RunPlan:
    """The plan of a run (see module docstring)."""

    particles: int
    virtual_points: int
    time_step: float
    """The mechanical phases' Δt [s] (the first one's)."""
    steps: int
    """Explicit steps of the dynamic phases, plus the step caps of the equilibrium and safety phases
    (a safety search counted as seven trials, each at its cap), which they seldom reach."""
    capped: bool
    """Whether ``steps`` counts a cap (an upper bound) rather than a duration."""
    frames: int
    seconds_per_step: float
    output_bytes: float
    notes: list[str] = field(default_factory=list)
    phase_particles: dict[str, int] = field(default_factory=dict)
    """A staged scene's particles in each phase, by phase name."""

    @property
    def seconds(self) -> float:
        return self.steps * self.seconds_per_step

    def lines(self) -> list[str]:
        bound = "at most " if self.capped else ""
        time = (f"{bound or 'about '}{_duration(self.seconds)} on this machine ({1e3 * self.seconds_per_step:.3g} "
                "ms per step measured), " if self.seconds_per_step > 0 else "")  # fmt: skip
        why = (" (the equilibrium and safety phases counted at their step caps, max_steps, which they stop short "
               "of once they converge)" if self.capped else "")  # fmt: skip
        counts = ""
        if len(set(self.phase_particles.values())) > 1:
            counts = f" ({', '.join(f'{n} in {name}' for name, n in self.phase_particles.items())})"
        out = [f"{self.particles} particles{counts}, {self.virtual_points} virtual points, dt = {self.time_step:.4g} s",
               f"{bound}{self.steps:,} steps, {self.frames} frames: {time}{bound or 'about '}"
               f"{_size(self.output_bytes)} of output{why}"]
        if self.seconds > LONG_RUN:
            out.append(f"warning: the run may take {_duration(self.seconds)} on this machine: coarsen simulation.dx, "
                       "shorten the phases or simulation.end_time, or run it on a GPU (--device cuda:0)")
        if self.output_bytes > LARGE_OUTPUT:
            out.append(f"warning: the run may write {_size(self.output_bytes)}: raise output.frame_interval or "
                       "write fewer output.fields")  # fmt: skip
        return out + self.notes


def check_reservoirs_reach(model, state) -> None:
    """Refuse, as the run would at its first step, a reservoir whose region holds no free-surface particle
    of ``model`` at ``state`` (:func:`~warpsph.stages.surface_water.wetted_regions`)."""
    from warpsph.solver import Solver

    if model.pore is None or not model.pore.reservoirs:
        return
    solver = Solver(model)
    solver.fit_geometry(state)
    solver.projection.check_reservoirs(state)


def plan(scene: Scene, device: str | None = None, timed: bool = True) -> RunPlan:
    """Build every phase's model (which checks what its particles show, :mod:`warpsph.scene_reach`: the
    loads, regions and probes of each phase against its bodies; a staged scene's point and region probes
    against every phase's particles; the reservoirs against each phase's free surfaces), time a few
    steps of the first mechanical phase (unless not ``timed``) and count the rest."""
    from warpsph.builder import build
    from warpsph.scene_reach import check_probes_reach
    from warpsph.solver import Solver, warm_up
    from warpsph.stages.guard import Guard

    phases = default_phases(scene)
    mechanical = [i for i, p in enumerate(phases) if p.kind != "k0" and p.kind not in IMPLICIT_PHASE_KINDS]
    timed_index = mechanical[0] if mechanical else 0
    counts, points = {}, []
    if scene.phases:  # every phase's model, one at a time, each built with its checks
        for index, phase in enumerate(phases):
            phase_model, phase_state = build(phase_scene(scene, index), device=device, staged=True)
            check_reservoirs_reach(phase_model, phase_state)
            counts[phase.name] = phase_model.particle_count
            points.append(phase_model.particle_x0)
            if index == timed_index:
                model, state = phase_model, phase_state
        check_probes_reach(scene, points)  # the point and region probes against every phase's particles
    else:
        model, state = build(scene, device=device)
        check_reservoirs_reach(model, state)
    first = phase_scene(scene, timed_index) if scene.phases else scene
    dt = first.time_step
    seconds_per_step, unstable = 0.0, []
    if mechanical and timed:
        phase = phases[mechanical[0]]
        damped = phase.kind in ("equilibrium", "safety")
        solver = Solver(model, damping=phase.damping if damped else None, pore_pressure=phase.pore_pressure)
        scratch = model.state()
        scratch.assign(state)
        start, n = time.perf_counter(), 0
        try:
            warm_up(solver, Guard(model, first.speed_limit), state, scratch, 0.0, dt)
            start = time.perf_counter()
            while n < TIMED_STEPS and time.perf_counter() - start < TIMED_SECONDS:
                solver.step(state, scratch, n * dt, dt)
                state, scratch = scratch, state
                n += 1
            solver.check_neighbours()
        except SimulationError as error:
            unstable = [f"warning: phase {phase.name} went unstable in its first {n + 1} steps, where the run "
                        f"will stop: {error}; check the materials' moduli and simulation.courant"]  # fmt: skip
        import warp as wp

        wp.synchronize_device(model.device)
        seconds_per_step = (time.perf_counter() - start) / max(n, 1)
    steps, capped, frames, notes = count_steps(scene)
    notes = unstable + notes
    fields = ["position", "pore_pressure", "plastic_strain"] + list(scene.output.fields)
    itemsize = 8 if model.spec.precision == "float64" else 4
    per_frame = model.particle_count * sum(_COMPONENTS.get(f, 1) for f in set(fields)) * itemsize
    output = frames * per_frame * (2 if scene.output.usd else 1)
    particles = max(counts.values(), default=model.particle_count)
    return RunPlan(particles, model.virtual_count, dt, steps, capped, frames, seconds_per_step, float(output), notes,
                   counts)  # fmt: skip


def count_steps(scene: Scene) -> tuple[int, bool, int, list[str]]:
    """(steps, capped, frames, notes) of :class:`RunPlan`, from the scene alone (no model is built);
    the notes warn of more than :data:`MANY_STEPS` steps."""
    phases = default_phases(scene)
    steps, frames, capped, notes = 0, 1, False, []
    for i, phase in enumerate(phases):
        sc = phase_scene(scene, i) if scene.phases else scene
        frame_every = max(1, round(sc.output.frame_interval / sc.time_step))
        frames += i > 0  # the frame a phase starts with (the run's first: the one counted above)
        if phase.kind == "dynamic":
            n = min(math.ceil(phase.duration / sc.time_step - 1e-9), phase.max_steps)
            steps += n
            frames += n // frame_every + (n % frame_every > 0)  # every frame_every steps, and the last
        elif phase.kind == "equilibrium":
            steps, capped = steps + phase.max_steps, True
            frames += phase.max_steps // frame_every + (phase.max_steps % frame_every > 0)
        elif phase.kind == "safety":
            steps, capped, frames = steps + 7 * phase.max_steps, True, frames + 8
        elif phase.kind in IMPLICIT_PHASE_KINDS:
            frames += 1 if phase.steady else phase.frames
            notes.append(f"phase {phase.name} ({phase.kind}): implicit steps sized by accuracy, not counted")
    if steps > MANY_STEPS and not capped:
        notes.append(f"warning: {steps:,} steps, more than {MANY_STEPS:,}: check simulation.end_time, and the "
                     "units of the materials' moduli (Pa) and densities (kg/m3), which set the time step")  # fmt: skip
    return steps, capped, frames, notes


def _duration(seconds: float) -> str:
    if seconds < 120:
        return f"{seconds:.3g} s"
    if seconds < 7200:
        return f"{seconds / 60:.3g} min"
    if seconds < 2 * 86400:
        return f"{seconds / 3600:.3g} h"
    return f"{seconds / 86400:.3g} days"


def _size(n: float) -> str:
    for unit, scale in (("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if n >= scale:
            return f"{n / scale:.3g} {unit}"
    return f"{int(n)} B"

