"""The solver: a time step as the ordered list of named stages :func:`stage_names` gives.

``Solver(model).step(state_in, state_out, t, dt)`` advances from tⁿ = t to tⁿ⁺¹ = t + Δt; the caller
swaps the states. The step's options are a :class:`SolverConfig`, read once from the scene and the
phase. With ``profile=True`` every stage is synchronised and timed into ``stage_seconds``.
"""

from __future__ import annotations

import functools
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass

import warp as wp

from warpsph.builder import rigid_region_members
from warpsph.errors import SimulationError
from warpsph.launching import launch_rows
from warpsph.model import Model, State
from warpsph.sph.neighbours import NeighbourList, NeighbourScratch
from warpsph.sph.packed_stress import packed_stress_type
from warpsph.stages.boundaries import Boundaries
from warpsph.stages.collocated import RungeKuttaStep
from warpsph.stages.corrections import FitData, compute_fit_data, compute_volumes
from warpsph.stages.damping import EQUILIBRIUM_VELOCITY_FILTER, LocalDamping
from warpsph.stages.energy import EnergyLedger
from warpsph.stages.ghost_layout import GhostLayout
from warpsph.stages.groundwater_kernels import groundwater_kernels
from warpsph.stages.hourglass import HourglassControl
from warpsph.stages.plates import Plates
from warpsph.stages.rigid import RigidRegions
from warpsph.stages.surface_water import SurfaceWater, levels, surface_water
from warpsph.stages.shifting import apply_shift, compute_shift
from warpsph.stages.virtual_points import VirtualRegenerator
from warpsph.stages.pressure import PressureProjection
from warpsph.stages.taylor import launch_full_step, launch_half_step, launch_real_motion, launch_virtual_continuity

NEIGHBOUR_CHECK_EVERY = 10
"""Steps beyond which a step checks the neighbour lists that nothing else has checked: a caller that
checks them every this many steps (a run: every ``phases.base.CHECK_EVERY`` steps and before each
write) is the one that finds an overflow."""


@dataclass(frozen=True, kw_only=True)
class SolverConfig:
    """The step's options, read once from the scene and the phase (docs/scenes.md): the stages launch
    with these, never with the scene's values."""

    scheme: str
    """"two_set" or "collocated" (``simulation.scheme``)."""
    pore_water: bool
    """The pore_water effect: a pressure projection (two-set scheme)."""
    large_deformation: bool
    virtual_points: str
    """"advected" or "regenerated" (``simulation.virtual_points``)."""
    virtual_density: str
    particle_velocity: str
    free_surface_threshold: float
    artificial_viscosity: float
    particle_shifting: float
    stress_filter: float
    velocity_filter: float
    """The full step's β: ``simulation.velocity_filter``, at least ``EQUILIBRIUM_VELOCITY_FILTER`` when damped."""
    hourglass_control: float
    dx: float
    """Δx [m]."""
    damping: float | None = None
    """The coefficient α of an equilibrium phase's local damping (None: undamped)."""
    fixed_pore_pressure: bool = False
    """The pore pressures are held (a phase's ``pore_pressure = "fixed"``, with pore water): no
    projection, and the total stress carries Bishop's χ p_w of the state's pressures."""

    @classmethod
    def of(cls, scene, damping: float | None = None, pore_pressure: str = "coupled") -> SolverConfig:
        """The options of ``scene``'s steps in a phase damped by ``damping`` (None: undamped), with its
        pore pressures "coupled" or "fixed"."""
        sim = scene.simulation
        velocity_filter = sim.velocity_filter if damping is None else max(sim.velocity_filter,
                                                                          EQUILIBRIUM_VELOCITY_FILTER)  # fmt: skip
        return cls(scheme=sim.scheme, pore_water=scene.effects.pore_water, large_deformation=sim.large_deformation,
                   virtual_points=sim.virtual_points, virtual_density=sim.virtual_density,
                   particle_velocity=sim.particle_velocity, free_surface_threshold=sim.free_surface_threshold,
                   artificial_viscosity=sim.artificial_viscosity, particle_shifting=sim.particle_shifting,
                   stress_filter=sim.stress_filter, velocity_filter=velocity_filter,
                   hourglass_control=sim.hourglass_control, dx=sim.dx, damping=damping,
                   fixed_pore_pressure=pore_pressure == "fixed" and scene.effects.pore_water)  # fmt: skip


def stage_names(config: SolverConfig) -> list[str]:
    """A step's stages in order for the scheme, effects and phase of ``config`` (docs/method.md)."""
    if config.scheme == "collocated":
        names = ["ghosts", "neighbours", "runge_kutta", "prescribed_values"]
    else:
        names = ["ghosts", "neighbours", "corrections", "taylor_half_step", "virtual_ghosts",
                 *(["shifting"] if config.particle_shifting > 0.0 else []),
                 "taylor_full_step",
                 *(["hourglass_control"] if config.hourglass_control > 0.0 else []),
                 *(["virtual_continuity"] if config.virtual_density == "real_motion" else []),
                 "prescribed_values",
                 *(["pressure_projection"] if config.pore_water and not config.fixed_pore_pressure else [])]
    return names + ["boundary_work", *(["local_damping"] if config.damping is not None else [])]


@dataclass
class Stage:
    """A named part of a step: ``run(state_in, state_out, t, dt)``."""

    name: str
    run: Callable[[State, State, float, float], None]


class Solver:
    """Advances a State by one step with the scheme the model's spec selects."""

    def __init__(self, model: Model, profile: bool = False, damping: float | None = None,
                 pore_pressure: str = "coupled"):  # fmt: skip
        self.model = model
        self.config = SolverConfig.of(model.scene, damping, pore_pressure)
        c = self.config
        self.held_pressure: wp.array | None = None
        """The pore pressures held with ``config.fixed_pore_pressure``: Bishop's χ p_w of a state's."""
        self.profile = profile
        self.stage_seconds: dict[str, float] = {}
        self.boundaries = Boundaries(model)
        self.plates = Plates(model, self.boundaries) if model.plates.count else None
        """The rigid plates' force balance (none without plates)."""
        self.energy = EnergyLedger(model)
        """The particles' energy ledger the step adds to (:mod:`warpsph.stages.energy`)."""
        self.rigid = RigidRegions(model, self.energy.ledger)
        s = model.spec
        self.layout: GhostLayout | None = None
        """Re-plans the ghosts as the body moves (``simulation.large_deformation`` only)."""
        if c.large_deformation:
            regenerate = s.scheme == "two_set" and c.virtual_points == "regenerated"
            regenerator = VirtualRegenerator(model) if regenerate else None
            self.layout = GhostLayout(model, self.boundaries.plane_position, regenerator,
                                      functools.partial(rigid_region_members, model.scene))  # fmt: skip
        self.support = 2.0 * model.h
        self.neighbour_lists: list[NeighbourList] = []
        self._unchecked = 0
        """Steps since the neighbour lists were last checked."""
        self.projection: PressureProjection | None = None  # pore_water only (two-set)
        if s.scheme == "two_set":
            self._init_two_set()
        else:
            self._init_collocated()
        self._moving_reservoirs = model.pore is not None and any(
            r.time_function.kind != "constant" for r in model.pore.reservoirs)
        """Whether a reservoir's level changes in time (its level is then set every step)."""
        self.damping: LocalDamping | None = None
        """Local damping of an equilibrium phase (``damping`` = its coefficient α), the last stage."""
        if damping is not None:
            self.damping = LocalDamping(model, damping, self.energy.ledger)
        runs = {"ghosts": self._ghosts_two_set, "neighbours": self._neighbours_two_set,
                "corrections": self._corrections, "taylor_half_step": self._half_step,
                "virtual_ghosts": self._virtual_ghosts, "shifting": self._shifting, "taylor_full_step": self._full_step,
                "hourglass_control": lambda si, so, t, dt: self.hourglass.run(si, so, dt),
                "virtual_continuity": self._virtual_continuity, "prescribed_values": self._prescribe,
                "pressure_projection": self._project, "boundary_work": self._boundary_work,
                "local_damping": lambda si, so, t, dt: self.damping.run(si, so, dt)}  # fmt: skip
        if s.scheme != "two_set":
            runs.update(ghosts=self._ghosts_collocated, neighbours=self._neighbours_collocated,
                        runge_kutta=self.runge_kutta.run)  # fmt: skip
        self.stages = [Stage(name, runs[name]) for name in stage_names(c)]

    def _neighbour_list(self, same_set: bool = False) -> NeighbourList:
        """A neighbour list within the support, built in turn with the solver's others (one scratch)."""
        m = self.model
        nl = NeighbourList(m.spec, m.extent, self.support, m.device, same_set, self.neighbour_scratch)
        self.neighbour_lists.append(nl)
        return nl

    def check_neighbours(self) -> None:
        """Check every neighbour list built since the last check (:meth:`NeighbourList.check`: one wait
        for the device) and grow their room ahead of need; a step calls it after more than
        ``NEIGHBOUR_CHECK_EVERY`` steps unchecked, a run at its own check cadence. Raises
        :class:`SimulationError` where a point had more neighbours than its list held."""
        self._unchecked = 0
        if any([nl.check() for nl in self.neighbour_lists]):
            raise SimulationError(
                f"a point had more neighbours than its list held (particles crowded by more than "
                f"{NeighbourList.GROWTH - 1:.0%} within {NEIGHBOUR_CHECK_EVERY} steps, which a stable run does not do)")

    def forget_neighbour_overflow(self) -> None:
        """Read and forget the neighbour lists' marks (a safety trial's end: the crowding of a trial that ran
        away ended with it); a list that overflowed sizes its room anew at its next build."""
        self._unchecked = 0
        for nl in self.neighbour_lists:
            nl.check()

    # -- two-set Taylor-SPH -------------------------------------------------------------------
    def _init_two_set(self) -> None:
        m, s, dev = self.model, self.model.spec, self.model.device
        self.virtual_v = wp.zeros(m.virtual_capacity, dtype=s.vec3, device=dev)
        self.virtual_stress = wp.zeros(m.virtual_capacity, dtype=packed_stress_type(s), device=dev)
        """The virtual points' half-step stress, by its independent entries (:mod:`warpsph.sph.packed_stress`)."""
        self.real_volume = wp.zeros(m.particle_capacity, dtype=s.real, device=dev)
        """V = m/ρ [m^dim] of the real particles and their ghosts at tⁿ, the pair loops' weights."""
        self.virtual_volume = wp.zeros(m.virtual_capacity, dtype=s.real, device=dev)
        """As real_volume, for the virtual points and their ghosts: the full step's too, since the
        ghosts' densities the virtual_ghosts stage copies from their sources are those of the ghosts stage."""
        self.neighbour_scratch = NeighbourScratch(s, m.extent, self.support, dev)
        self.virtual_to_real = self._neighbour_list()
        self.real_to_virtual = self._neighbour_list()
        self.real_fits = FitData(s, m.particle_capacity, dev)
        self.virtual_fits = FitData(s, m.virtual_capacity, dev)
        self.virtual_rate = wp.zeros(m.virtual_capacity, dtype=s.real, device=dev)
        shifting = self.config.particle_shifting > 0.0
        self.real_shift = wp.zeros(m.particle_capacity if shifting else 1, dtype=s.vec3, device=dev)
        self.real_motion = None
        """The real particles' velocity over the step [m/s] (``virtual_density = "real_motion"`` only)."""
        if self.config.virtual_density == "real_motion":
            self.real_motion = wp.zeros(m.particle_capacity, dtype=s.vec3, device=dev)
        if shifting:
            self.virtual_shift = wp.zeros(m.virtual_capacity, dtype=s.vec3, device=dev)
            self.shift_real_to_real = self._neighbour_list(same_set=True)
            self.shift_virtual_to_virtual = self._neighbour_list(same_set=True)
        alpha = self.config.hourglass_control
        if alpha > 0.0:
            self.hourglass = HourglassControl(m, alpha, self._neighbour_list(same_set=True), self.real_volume,
                                              self.energy.ledger)  # fmt: skip
        self.virtual_p = None
        if s.effects.pore_water:
            self.virtual_p = wp.zeros(m.virtual_capacity, dtype=wp.float64, device=dev)
            self.real_to_real = self._neighbour_list(same_set=True)
            self.projection = PressureProjection(m, self)

    def _ghosts_two_set(self, si: State, so: State, t: float, dt: float) -> None:
        self.boundaries.set_time(t)
        if self.model.pore is not None and self._moving_reservoirs:
            self.model.pore.surface_water.level.assign(levels(self.model.pore.reservoirs, t))
        self.rigid.begin_step(si.particle_v, t, dt)
        pressure = self._stress_pressure(si)
        self._step_plates(si, so, pressure, dt)
        self.boundaries.move_planes(si.particle_q)
        if self.layout is not None:
            self.layout.update(si)
        self.boundaries.update_real_ghosts(si.particle_q, si.particle_v, si.particle_stress, si.particle_density,
                                           pressure)
        if si.particle_plastic_strain is not None:
            self.boundaries.copy_to_real_ghosts(si.particle_plastic_strain)
        if self.projection is not None:
            self.projection.set_time(t)
            self.projection.update_ghosts(si.particle_q, pressure, homogeneous=False)
        self.boundaries.update_virtual_ghosts(si.virtual_q, self.virtual_v, self.virtual_stress, si.virtual_density,
                                              self.virtual_p)

    def _step_plates(self, si: State, so: State, pressure, dt: float) -> None:
        """The rigid plates' velocities over the step (none where ``si`` is ``so``: geometry alone)."""
        if self.plates is not None and si is not so:
            damping = self.damping.alpha if self.damping is not None else 0.0
            self.plates.step(si, so, pressure, dt, damping)

    def _neighbours_two_set(self, si: State, so: State, t: float, dt: float) -> None:
        m = self.model
        self.virtual_to_real.build(si.virtual_q, m.virtual_count, si.particle_q, m.particle_total)
        self.real_to_virtual.build(si.particle_q, m.particle_count, si.virtual_q, m.virtual_total)
        if self.projection is not None:
            self.real_to_real.build(si.particle_q, m.particle_count, si.particle_q, m.particle_total)

    def _corrections(self, si: State, so: State, t: float, dt: float) -> None:
        m = self.model
        compute_volumes(m, m.particle_mass, si.particle_density, self.real_volume, 0, m.particle_total)
        compute_volumes(m, m.virtual_mass, si.virtual_density, self.virtual_volume, 0, m.virtual_total)
        compute_fit_data(m, self.virtual_to_real, si.virtual_q, m.virtual_count, si.particle_q, self.real_volume,
                         self.virtual_fits, m.virtual_ghost_source, m.virtual_ghost_planes,
                         m.virtual_ghost_count)  # fmt: skip
        compute_fit_data(m, self.real_to_virtual, si.particle_q, m.particle_count, si.virtual_q, self.virtual_volume,
                         self.real_fits, m.particle_ghost_source, m.particle_ghost_planes,
                         m.particle_ghost_count)  # fmt: skip

    def _half_step(self, si: State, so: State, t: float, dt: float) -> None:
        launch_half_step(self.model, self.config, self.virtual_to_real, si, so, dt, real_volume=self.real_volume,
                         real_fits=self.real_fits, virtual_fits=self.virtual_fits, virtual_v=self.virtual_v,
                         virtual_stress=self.virtual_stress, pressure=self._stress_pressure(si),
                         water_density=self._water_density, virtual_p=self.virtual_p, virtual_rate=self.virtual_rate,
                         integrated_density=self.real_motion is None, water_on_surface=self._water_on_surface,
                         surface_weight=self._surface_weight, surface_water=self._surface_water)  # fmt: skip

    def _shifting(self, si: State, so: State, t: float, dt: float) -> None:
        """Shifts of both sets from the configuration at tⁿ: the virtual points' are applied to their
        new positions here, the real particles' in the full step (with their fields)."""
        m = self.model
        nv = m.virtual_count
        if self.config.virtual_points == "advected":
            self.shift_virtual_to_virtual.build(si.virtual_q, nv, si.virtual_q, m.virtual_total)
            compute_shift(m, self.shift_virtual_to_virtual, si.virtual_q, nv, m.virtual_mass, si.virtual_density,
                          self.virtual_rate, self.virtual_fits, self.virtual_shift, dt)  # fmt: skip
            apply_shift(m, nv, self.virtual_shift, so.virtual_q)
        self.shift_real_to_real.build(si.particle_q, m.particle_count, si.particle_q, m.particle_total)
        compute_shift(m, self.shift_real_to_real, si.particle_q, m.particle_count, m.particle_mass,
                      si.particle_density, None, self.real_fits, self.real_shift, dt)  # fmt: skip

    def _virtual_ghosts(self, si: State, so: State, t: float, dt: float) -> None:
        self.boundaries.set_time(t + 0.5 * dt)
        self.rigid.prescribe_virtual(self.virtual_v)
        self.boundaries.update_virtual_ghosts(si.virtual_q, self.virtual_v, self.virtual_stress, si.virtual_density,
                                              self.virtual_p)
        if self.projection is not None:
            self.projection.update_ghosts(si.virtual_q, self.virtual_p, homogeneous=False, virtual=True)

    def _full_step(self, si: State, so: State, t: float, dt: float) -> None:
        launch_full_step(self.model, self.config, self.real_to_virtual, si, so, dt, virtual_volume=self.virtual_volume,
                         virtual_v=self.virtual_v, virtual_stress=self.virtual_stress, virtual_fits=self.virtual_fits,
                         real_fits=self.real_fits, virtual_p=self.virtual_p, water_density=self._water_density,
                         real_shift=self.real_shift, water_on_surface=self._water_on_surface,
                         surface_weight=self._surface_weight, surface_water=self._surface_water,
                         ledger=self.energy.ledger)  # fmt: skip

    def _virtual_continuity(self, si: State, so: State, t: float, dt: float) -> None:
        """The virtual points' densities follow the motion of the real particles around them over the
        step (continuity with the rate of deformation of that motion; docs/method.md)."""
        launch_real_motion(self.model, si, so, dt, self.real_motion)
        # the motion's ghosts as velocities (the call also refreshes the ghosts of so's stress and density,
        # which the next step's ghost stage sets anew)
        self.boundaries.update_real_ghosts(si.particle_q, self.real_motion, so.particle_stress, so.particle_density,
                                           self._stress_pressure(si))  # fmt: skip
        launch_virtual_continuity(self.model, self.virtual_to_real, si, so, dt, self.real_motion, self.virtual_fits)

    @property
    def _surface_weight(self):
        """1 to take the weight of the soil above a surface band's point off its traction; 0 with large
        deformation, whose flows it destabilised (docs/method.md, *The weight of the soil*)."""
        return self.model.spec.real(0.0 if self.config.large_deformation else 1.0)

    @functools.cached_property
    def _surface_water(self) -> SurfaceWater:
        """The water against the free surfaces (pore water), or an empty one for dry scenes."""
        m = self.model
        if m.pore is not None:
            return m.pore.surface_water
        return surface_water(m.gravity, 0.0, [], m.device)

    @property
    def _water_on_surface(self):
        """1 where a free surface pushes with its point's own total stress σ′ − pI less the weight of the soil
        above (an impermeable surface, and any surface while the pore pressures are held: the skeleton is
        then loaded as dry soil is, under the seepage forces held), 0 where a drained surface pushes with the
        total stress extrapolated to it (its pore pressure a Dirichlet row of the projection; docs/method.md,
        *Drained free surfaces*)."""
        if self.projection is None:
            return self.model.spec.real(0.0)
        held = self.config.fixed_pore_pressure
        return self.model.spec.real(1.0 if held else self.projection.water_on_surface)

    @property
    def _water_density(self):
        return self.model.pore.water.density if self.model.pore is not None else None

    def _project(self, si: State, so: State, t: float, dt: float) -> None:
        """Pressure projection, then the prescribed velocities again (the correction moves them)."""
        self.projection.set_time(t + dt)
        self.projection.project(si, so, dt)
        self.boundaries.prescribe(so.particle_q, so.particle_v, so.particle_stress, so.particle_density,
                                  self.energy.ledger, so.particle_pore_pressure)
        self.rigid.prescribe(so.particle_v)

    def _prescribe(self, si: State, so: State, t: float, dt: float) -> None:
        self.boundaries.set_time(t + dt)
        if self.layout is not None:
            self.layout.keep_inside(so.particle_q, so.particle_v, so.particle_stress, so.particle_density, dt)
        self.boundaries.prescribe(so.particle_q, so.particle_v, so.particle_stress, so.particle_density,
                                  self.energy.ledger, self._stress_pressure(si))
        self.rigid.prescribe(so.particle_v)

    def _boundary_work(self, si: State, so: State, t: float, dt: float) -> None:
        """The boundary planes' work on the particles lying on them over the step (the ledger's)."""
        if self.model.pore is None:
            self.energy.add_boundary_work(si, so)
            return
        before = self._stress_pressure(si)
        self.energy.add_boundary_work(si, so, before, before if self.config.fixed_pore_pressure else so.particle_pore_pressure)

    def plate_series(self, state: State) -> dict[str, float]:
        """Each rigid plate's force into the soil [N/m in 2D, N in 3D] and displacement [m] in ``state``, by
        series name (``<plate>_force_y``, ``<plate>_displacement_y``, …); none without plates."""
        plates = self.plates
        return {} if plates is None else plates.series(state, self._stress_pressure(state))

    def _stress_pressure(self, si: State):
        """The pore pressure the step's total stress carries: the state's, or with fixed pore pressures
        the excess of Bishop's χ p_w, computed from the first state stepped (the pressures do not change)."""
        if not self.config.fixed_pore_pressure:
            return si.particle_pore_pressure
        if self.held_pressure is None:
            self.hold_pore_pressure(si)
        return self.held_pressure

    def hold_pore_pressure(self, state: State, suction: int | None = None) -> None:
        """Fixed pore pressures: hold those of ``state`` from the next step on (a consolidation step's
        new iterate), counting suction where ``suction`` is 1 (None: as ``pressure.suction`` says)."""
        if self.held_pressure is None:
            self.held_pressure = wp.clone(state.particle_pore_pressure)
        else:
            wp.copy(self.held_pressure, state.particle_pore_pressure)
        carried_pore_pressure(self.model, state, self.held_pressure, suction)

    # -- collocated baseline --------------------------------------------------------------------
    def _init_collocated(self) -> None:
        m, s, dev = self.model, self.model.spec, self.model.device
        self.projection = None  # no pore water in the collocated scheme (the run loop asks)
        self.neighbour_scratch = NeighbourScratch(s, m.extent, self.support, dev)
        self.real_to_real = self._neighbour_list(same_set=True)
        self.runge_kutta = RungeKuttaStep(m, self.config, self.boundaries, self.real_to_real)

    def _ghosts_collocated(self, si: State, so: State, t: float, dt: float) -> None:
        self.boundaries.set_time(t)
        self.rigid.begin_step(si.particle_v, t, dt)
        self._step_plates(si, so, None, dt)
        self.boundaries.move_planes(si.particle_q)
        if self.layout is not None:
            self.layout.update(si)
        self.boundaries.update_real_ghosts(si.particle_q, si.particle_v, si.particle_stress, si.particle_density)

    def _neighbours_collocated(self, si: State, so: State, t: float, dt: float) -> None:
        m = self.model
        self.real_to_real.build(si.particle_q, m.particle_count, si.particle_q, m.particle_total)

    def fit_geometry(self, state: State) -> None:
        """Ghosts, neighbour lists and corrections at the positions of ``state`` (a fixed skeleton's,
        or a state about to be checked), with no step taken."""
        for stage in ("ghosts", "neighbours", "corrections"):
            self.stages[self.stage_names.index(stage)].run(state, state, 0.0, self.model.scene.time_step)

    # -- driver -----------------------------------------------------------------------------------
    @property
    def stage_names(self) -> list[str]:
        return [s.name for s in self.stages]

    def step(self, state_in: State, state_out: State, t: float, dt: float) -> None:
        """Advance ``state_in`` at time ``t`` [s] by ``dt`` [s] into ``state_out``."""
        for stage in self.stages:
            if self.profile:
                wp.synchronize_device(self.model.device)
                start = time.perf_counter()
                stage.run(state_in, state_out, t, dt)
                wp.synchronize_device(self.model.device)
                self.stage_seconds[stage.name] = self.stage_seconds.get(stage.name, 0.0) + time.perf_counter() - start
            else:
                stage.run(state_in, state_out, t, dt)
        self._unchecked += 1
        if self._unchecked > NEIGHBOUR_CHECK_EVERY:
            self.check_neighbours()


def carried_pore_pressure(model: Model, state: State, out: wp.array | None = None,
                          suction: int | None = None) -> wp.array:  # fmt: skip
    """``out`` (N,) float64 [Pa] (allocated where None), returned: the excess pressure whose total is the part
    χ p_w of ``state``'s pore pressure that the total stress σ′ − χ p_w I carries (χ = 1 at p_w ≥ 0; under
    suction Bishop's S_e where ``suction`` is 1, 0 where it is 0, None: as ``pressure.suction`` says)."""
    pw = model.pore
    if out is None:
        out = wp.zeros(model.particle_count, dtype=wp.float64, device=model.device)
    launch_rows(groundwater_kernels(model.spec)["bishop_excess"], model.particle_count,
                [state.particle_q, model.particle_material, pw.water, pw.retention,
                 pw.suction if suction is None else suction, state.particle_pore_pressure, out],
                model.device)  # fmt: skip
    return out


def warm_up(solver: Solver, guard, state: State, scratch: State, t: float, dt: float) -> float:
    """Compile every kernel by one throw-away step from ``state`` into ``scratch`` (which is reset
    to ``state`` afterwards), read what the run ``guard`` (:class:`~warpsph.stages.guard.Guard`) found,
    and clear the solver's statistics and what it booked; return its wall time [s]."""
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
