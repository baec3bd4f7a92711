"""Scene validation: types, ranges and cross references, for TOML-built and Python-built scenes.

:func:`validate_scene` raises :class:`~warpsph.errors.SceneError` for the first problem found.
Key paths are dotted; items of ``bodies``, ``boundaries``, ``loads`` and ``probes`` are named by
their ``name`` (``bodies.column.material``), or by their index when the name itself is unusable
(``bodies[0].name``). Messages say what is accepted and what was given:
``materials.soil.poisson_ratio: must be in (-1, 0.5), got 0.6``.

Values are converted to their fields' types by :mod:`warpsph.scene_types`; a phase's ``changes`` are
typed here, once (:func:`validate_scene`).
"""

from __future__ import annotations

import copy
import math
import typing
from decimal import Decimal

import numpy as np

from warpsph.errors import SceneError
from warpsph.lattice import body_bounds, has_lattice_point, lattice_span, polygon_area, used_axes
from warpsph.phases import SWITCHED, change_target, phase_label, phase_scene
from warpsph.material_check import check_materials, needs_plasticity, needs_pore_water
from warpsph.scene_sections import (AXES, IMPLICIT_PHASE_KINDS, PHASE_KINDS, Body, Boundary, Drainage, Effects, Load,
                                    Output, Phase, PressureSolver, Probe, Region, Reservoir, Simulation,
                                    TimeFunction)  # fmt: skip
from warpsph.scene_types import (NON_NEGATIVE, POSITIVE, UNIT_INTERVAL, Interval,
                                 as_string, check_choice, check_instance, check_name, check_range, check_types,
                                 check_unique, convert_field, is_list, item_key, show)  # fmt: skip

if typing.TYPE_CHECKING:
    from warpsph.scene import Scene

PROBE_FIELDS = (
    *(f"velocity_{a}" for a in AXES),
    *(f"position_{a}" for a in AXES),
    *(f"displacement_{a}" for a in AXES),
    *(f"stress_{c}" for c in ("xx", "yy", "zz", "yz", "xz", "xy")),
    "mean_stress",
    "von_mises",
    "pore_pressure",
    "plastic_strain",
)
OUTPUT_FIELDS = ("velocity", "stress", "displacement", "pore_pressure", "darcy_velocity", "plastic_strain")
PORE_WATER_FIELDS = ("pore_pressure", "darcy_velocity")
"""Probe and output fields that need ``effects.pore_water``."""
PLASTICITY_FIELDS = ("plastic_strain",)
"""Probe and output fields that need ``effects.plasticity``."""
MAX_PARTICLES = 2**31 - 1
FACE_LOADS = ("traction", "plate")
"""The load kinds that lie on a face (a boundary plane of their own)."""
"""A run indexes particles with 32-bit integers; a body spanning more lattice points is refused before
its points are listed (a dx written in mm as metres would otherwise exhaust memory or time)."""

# --------------------------------------------------------------------------- the scene


def validate_scene(scene: Scene) -> None:
    """Check ``scene``; raise :class:`SceneError` naming the key path of the first problem. A scene
    with phases is checked as each phase runs it: the first phase's problems name the plain key, a
    later phase's are prefixed ``phases.<name>:``."""
    if not is_list(scene.phases):
        raise SceneError("phases", f"expected a list of phases, got {type(scene.phases).__name__}")
    if scene.phases:
        _check_phases(scene)
    else:
        _validate_one_phase(scene)
    _check_partly_saturated(scene)


def _check_partly_saturated(scene: Scene) -> None:
    """Partially saturated soil moves its water in flow phases: a coupled mechanical phase may not meet it."""
    coupled = [p for p in scene.phases
               if p.kind in ("equilibrium", "safety", "dynamic") and p.pore_pressure == "coupled"]  # fmt: skip
    if not scene.phases and scene.effects.pore_water:
        coupled = [Phase(name="the scene's one dynamic phase")]
    for name, material in scene.materials.items():
        if material.retention != "saturated" and coupled:
            raise SceneError(f"materials.{name}.retention", "partially saturated soil moves its water in flow phases; "
                             f"a mechanical phase with it holds the pore pressure: set pore_pressure = \"fixed\" "
                             f"in phase {show(coupled[0].name)}")  # fmt: skip


def _validate_one_phase(scene: Scene) -> None:
    as_string("name", scene.name)
    _check_simulation(scene.simulation)
    _check_effects(scene.effects)
    for effect in ("pore_water", "plasticity"):
        if getattr(scene.effects, effect) and scene.simulation.scheme != "two_set":
            raise SceneError("simulation.scheme", f'the {effect} effect runs with the "two_set" scheme only, '
                             f"got {show(scene.simulation.scheme)}")  # fmt: skip
    check_materials(scene.materials, scene.effects)
    _check_pressure(scene.pressure)
    bodies = _named_items(scene, "bodies", Body)
    if not bodies:
        raise SceneError("bodies", "at least one body is required, e.g. [[bodies]]")
    check_unique("body", ("bodies", bodies))
    for i, body in enumerate(bodies):
        _check_body(body, item_key("bodies", body.name, i), scene)
    boundaries = _named_items(scene, "boundaries", Boundary)
    loads = _named_items(scene, "loads", Load)
    check_unique("boundary or load", ("boundaries", boundaries), ("loads", loads))
    for i, boundary in enumerate(boundaries):
        _check_boundary(boundary, item_key("boundaries", boundary.name, i), scene)
    for i, load in enumerate(loads):
        _check_load(load, item_key("loads", load.name, i), scene)
    _check_one_record_per_plane(boundaries, loads)
    _check_pore_water_can_escape(scene)
    probes = _named_items(scene, "probes", Probe)
    check_unique("probe", ("probes", probes))
    for i, probe in enumerate(probes):
        _check_probe(probe, item_key("probes", probe.name, i), scene)
    _check_output(scene.output, scene.effects)
    reservoirs = _named_items(scene, "reservoirs", Reservoir)
    check_unique("reservoir", ("reservoirs", reservoirs))
    for i, reservoir in enumerate(reservoirs):
        key = item_key("reservoirs", reservoir.name, i)
        check_types(reservoir, key)
        needs_pore_water(key, scene.effects, "a reservoir ")
        _check_region(reservoir.region, f"{key}.region")
        _check_time_function(reservoir.time_function, f"{key}.time_function")


def _check_phases(scene: Scene) -> None:
    """The phases' own keys and changes (typed in place), then every phase's scene
    (:func:`warpsph.phases.phase_scene`)."""
    phases = _named_items(scene, "phases", Phase)
    check_unique("phase", ("phases", phases))
    items = {section: [getattr(item, "name", None) for item in getattr(scene, section)] for section in SWITCHED}
    known = {name for names in items.values() for name in names}
    for i, phase in enumerate(phases):
        key = item_key("phases", phase.name, i)
        check_types(phase, key)
        check_choice(f"{key}.kind", phase.kind, PHASE_KINDS)
        if phase.kind == "dynamic":
            check_range(f"{key}.duration", phase.duration, POSITIVE)
        check_range(f"{key}.tolerance", phase.tolerance, POSITIVE)
        check_range(f"{key}.max_steps", phase.max_steps, Interval(1.0, lo_closed=True, hi_closed=True))
        check_range(f"{key}.damping", phase.damping, Interval(0.0, 1.0, lo_closed=True))
        check_range(f"{key}.at_rest", phase.at_rest, Interval(0.0, 1.0, lo_closed=True))
        check_range(f"{key}.factor_tolerance", phase.factor_tolerance, Interval(0.0, 0.5, hi_closed=True))
        check_range(f"{key}.factor_max", phase.factor_max, Interval(1.0, lo_closed=True))
        check_range(f"{key}.failure_displacement", phase.failure_displacement, NON_NEGATIVE)
        check_range(f"{key}.min_failing_mass", phase.min_failing_mass, Interval(1.0, lo_closed=True))
        if phase.refine and phase.kind != "safety":
            raise SceneError(f"{key}.refine",
                             f"only a safety phase refines its search; this phase is {show(phase.kind)}")
        if phase.slip_region != Region():
            if phase.kind != "safety":
                raise SceneError(f"{key}.slip_region", "only a safety phase searches slip circles; this phase is "
                                 f"{show(phase.kind)}")  # fmt: skip
            _check_region(phase.slip_region, f"{key}.slip_region")
        if phase.incremental and phase.kind != "safety":
            raise SceneError(f"{key}.incremental",
                             f"only a safety phase runs trials, incremental or not; this phase is {show(phase.kind)}")
        check_choice(f"{key}.pore_pressure", phase.pore_pressure, ("coupled", "fixed"))
        if phase.pore_pressure == "fixed":
            needs_pore_water(f"{key}.pore_pressure", scene.effects, '"fixed" pore pressures ')
        if phase.kind in IMPLICIT_PHASE_KINDS:
            _check_flow_phase(phase, key, scene)
        if phase.kind == "safety" and not scene.effects.plasticity:
            raise SceneError(f"{key}.kind", '"safety" reduces strengths: it needs effects.plasticity = true and '
                             'a viscoplastic material')  # fmt: skip
        for list_key in ("activate", "deactivate"):
            for j, name in enumerate(getattr(phase, list_key)):
                if name not in known:
                    raise SceneError(f"{key}.{list_key}[{j}]", f"no body, load or boundary named {show(name)}; "
                                     f"defined: {', '.join(sorted(map(str, known))) or 'none'}")  # fmt: skip
        if phase.kind == "k0" and i != 0:
            raise SceneError(f"{key}.kind", '"k0" sets the initial stresses: it is accepted for the first phase only')
    _type_changes(scene)
    for i, phase in enumerate(phases):
        key = item_key("phases", phase.name, i)
        staged = phase_scene(scene, i)
        if not staged.bodies:
            raise SceneError(f"{key}.deactivate", "this phase leaves no body active: a phase needs particles")
        if phase.kind == "safety" and not any(staged.materials[b.material].model == "viscoplastic"
                                              for b in staged.bodies):
            raise SceneError(f"{key}.kind", '"safety" reduces strengths, but no active body is of a viscoplastic '
                             'material: it would do nothing')  # fmt: skip
        if phase.kind in ("equilibrium", "safety") and not any(staged.simulation.gravity) and not staged.loads:
            raise SceneError(f"{key}.kind", f"an {phase.kind} phase needs gravity or a load to balance; this one "
                             "has neither, so it would do nothing")  # fmt: skip
        if phase.kind == "safety" and phase.slip_region != Region():
            _check_slip_region(phase.slip_region, f"{key}.slip_region", staged)
        try:
            _validate_one_phase(staged)
        except SceneError as e:
            if i == 0:
                raise
            raise SceneError(key, f"{e.key}: {e.message}" if e.key else e.message) from None


def _check_slip_region(region: Region, key: str, staged: Scene) -> None:
    """A safety phase's ``slip_region`` must meet the ground of its active bodies, in a scene where limit
    equilibrium is searched (2D, gravity along −y)."""
    dim, gravity = staged.simulation.dim, staged.simulation.gravity
    if dim != 2 or not (gravity[1] < 0.0 and gravity[0] == 0.0):
        raise SceneError(key, "limit equilibrium searches slip circles in 2D with gravity along -y only; this "
                         f"scene is {dim}D with gravity {show(list(gravity))}")  # fmt: skip
    bounds = [body_bounds(body, dim) for body in staged.bodies]
    lo, hi = np.min([b[0] for b in bounds], axis=0), np.max([b[1] for b in bounds], axis=0)
    if not (region.min[0] < hi[0] and region.max[0] > lo[0] and region.min[1] < hi[1]):
        raise SceneError(key, f"lies outside the ground (x from {lo[0]:g} to {hi[0]:g} m, y up to {hi[1]:g} m): "
                         f"no slip circle could cut it; got x from {show(region.min[0])} to {show(region.max[0])} "
                         f"m, y from {show(region.min[1])} m")  # fmt: skip


def _type_changes(scene: Scene) -> None:
    """Convert each phase's ``changes`` to the types of the keys they set, in place (checked and converted
    as a scene file's values; errors name ``phases.<name>.changes.<key path>``), applying them in turn
    so that a key under an item a change replaced is found."""
    staged = copy.deepcopy(scene)
    staged.phases = []
    for i, phase in enumerate(scene.phases):
        where = f"phases.{phase_label(phase, i)}.changes"
        for path, value in phase.changes.items():
            owner, name = change_target(staged, path, where)
            typed = convert_field(type(owner), name, f"{where}.{path}", value)
            setattr(owner, name, typed)
            phase.changes[path] = typed


def _check_flow_phase(phase: Phase, key: str, scene: Scene) -> None:
    if not scene.effects.pore_water:
        raise SceneError(f"{key}.kind", f'"{phase.kind}" moves the pore water: it needs effects.pore_water = true')
    if phase.kind == "consolidation" and phase.steady:
        raise SceneError(f"{key}.steady", 'a consolidation phase is a transient of its duration; the steady state '
                         'is a "flow" phase\'s')  # fmt: skip
    if not phase.steady:
        check_range(f"{key}.duration", phase.duration, POSITIVE)
    check_range(f"{key}.time_step", phase.time_step, NON_NEGATIVE)
    check_range(f"{key}.frames", phase.frames, Interval(1.0, lo_closed=True, hi_closed=True))
    drained = any(face.drainage.kind != "impermeable" for face in [*scene.boundaries, *scene.loads])
    drained |= _drained_plate(scene)
    if (phase.kind == "consolidation" and not drained and not scene.reservoirs
            and scene.pressure.free_surface == "impermeable"):  # fmt: skip
        raise SceneError(f"{key}.kind", "a consolidation phase drains the pore water, and this scene has nowhere "
                         "for it to go: add a drained boundary, load or plate, a reservoir, or set "
                         'pressure.free_surface = "drained"')  # fmt: skip
    if phase.steady and not drained and not scene.reservoirs:
        raise SceneError(f"{key}.steady", "a steady flow needs water to come from somewhere: a drained or inflow "
                         "boundary, or a reservoir; with seepage faces alone the soil drains to nothing")  # fmt: skip


def _named_items(scene: Scene, section: str, cls) -> list:
    """The list ``scene.<section>``, checked to hold ``cls`` instances with valid names."""
    items = getattr(scene, section)
    if not isinstance(items, list):
        raise SceneError(section, f"expected a list of {cls.__name__}, got {type(items).__name__}")
    for i, item in enumerate(items):
        check_instance(f"{section}[{i}]", item, cls)
        check_name(f"{section}[{i}].name", item.name)
    return items


def _check_simulation(sim: Simulation) -> None:
    check_instance("simulation", sim, Simulation)
    check_types(sim, "simulation")
    check_choice("simulation.dim", sim.dim, (1, 2, 3))
    check_range("simulation.dx", sim.dx, POSITIVE)
    check_range("simulation.end_time", sim.end_time, POSITIVE)
    check_range("simulation.smoothing_ratio", sim.smoothing_ratio, Interval(1.1, 2.0, True, True))
    check_choice("simulation.kernel", sim.kernel, ("cubic_spline", "wendland_c2"))
    check_choice("simulation.scheme", sim.scheme, ("two_set", "collocated"))
    check_choice("simulation.integrator", sim.integrator, ("rk2", "rk4"))
    limit, unstable = MAX_COURANT[sim.scheme, sim.integrator]
    check_range("simulation.courant", sim.courant, Interval(0.0, limit, hi_closed=True),
                note=f" (the {sim.scheme} {sim.integrator} step's energy grows at {unstable:g} on the wave column; "
                     "docs/accuracy.md, *Stability limit*)")  # fmt: skip
    check_choice("simulation.precision", sim.precision, ("float32", "float64"))
    check_range("simulation.artificial_viscosity", sim.artificial_viscosity, NON_NEGATIVE)
    check_range("simulation.stress_filter", sim.stress_filter, Interval(0.0, 0.5, lo_closed=True, hi_closed=True))
    check_range("simulation.hourglass_control", sim.hourglass_control,
                Interval(0.0, 1.0, lo_closed=True, hi_closed=True))
    check_range("simulation.velocity_filter", sim.velocity_filter, Interval(0.0, 0.5, lo_closed=True, hi_closed=True))
    if sim.velocity_limit is not None:
        check_range("simulation.velocity_limit", sim.velocity_limit, POSITIVE)
    check_range("simulation.free_surface_threshold", sim.free_surface_threshold, Interval(0.0, 1.0))
    check_choice("simulation.virtual_points", sim.virtual_points, ("advected", "regenerated"))
    check_choice("simulation.particle_velocity", sim.particle_velocity, ("fitted", "own"))
    check_choice("simulation.virtual_density", sim.virtual_density, ("integrated", "real_motion"))
    check_range("simulation.particle_shifting", sim.particle_shifting, NON_NEGATIVE)
    two_set_only = (("stress_filter", sim.stress_filter > 0.0, "acts between the two point sets"),
                    ("velocity_filter", sim.velocity_filter > 0.0, "acts between the two point sets"),
                    ("hourglass_control", sim.hourglass_control > 0.0, "damps what the two sets' fits miss"),
                    ("virtual_density", sim.virtual_density != "integrated", "is the virtual points' density"))
    for key, used, what in two_set_only:
        if used and sim.scheme != "two_set":
            raise SceneError(f"simulation.{key}", f"{what}: it needs scheme = \"two_set\"")
    if (sim.particle_shifting > 0.0 or sim.particle_velocity != "fitted") and not (
            sim.large_deformation and sim.scheme == "two_set"):
        raise SceneError("simulation", "particle_shifting and particle_velocity = \"own\" are large-deformation "
                         "choices of the two-set scheme: they need large_deformation = true and scheme = \"two_set\"")


def _check_effects(effects: Effects) -> None:
    check_instance("effects", effects, Effects)
    check_types(effects, "effects")


MAX_COURANT = {("two_set", "rk2"): (1.5, 1.7), ("two_set", "rk4"): (1.5, 1.7),
               ("collocated", "rk2"): (0.5, 0.6), ("collocated", "rk4"): (1.5, 4.0)}  # fmt: skip
"""Per scheme and integrator: (the largest Courant number accepted, the smallest at which the wave
column's energy was measured to grow); the first is below the step's stability limit, the second beyond
it (docs/accuracy.md, *Stability limit*)."""


def _check_pressure(pressure: PressureSolver) -> None:
    check_instance("pressure", pressure, PressureSolver)
    check_types(pressure, "pressure")
    check_choice("pressure.solver", pressure.solver, ("cg", "jacobi"))
    check_range("pressure.tolerance", pressure.tolerance, UNIT_INTERVAL)
    check_range("pressure.max_iterations", pressure.max_iterations, Interval(1.0, lo_closed=True, hi_closed=True))
    check_range("pressure.jacobi_weight", pressure.jacobi_weight, Interval(0.0, 1.0, hi_closed=True))
    check_choice("pressure.on_failure", pressure.on_failure, ("warn", "stop"))
    check_choice("pressure.free_surface", pressure.free_surface, ("drained", "impermeable"))
    check_choice("pressure.suction", pressure.suction, ("ignored", "counted"))
    for key in ("stabilisation", "interior_stabilisation"):
        check_range(f"pressure.{key}", getattr(pressure, key), Interval(0.0, 1.0, lo_closed=True, hi_closed=True))


def _check_body(body: Body, key: str, scene: Scene) -> None:
    check_types(body, key)
    if body.material not in scene.materials:
        defined = ", ".join(show(m) for m in scene.materials)
        raise SceneError(f"{key}.material", f"unknown material {show(body.material)}; defined materials: {defined}")
    if body.pore_pressure != 0.0:
        needs_pore_water(f"{key}.pore_pressure", scene.effects, "a non-zero initial pore pressure ")
    check_choice(f"{key}.shape", body.shape, ("box", "polygon", "circle"))
    dim, dx = scene.simulation.dim, scene.simulation.dx
    if body.shape == "box":
        for a in used_axes(dim):
            if not body.max[a] > body.min[a]:
                raise SceneError(
                    f"{key}.max",
                    f"must be > min on every axis of a {dim}D scene, "
                    f"got max {AXES[a]} = {show(body.max[a])}, min {AXES[a]} = {show(body.min[a])}",
                )
    elif body.shape == "polygon":
        if dim != 2:
            raise SceneError(f"{key}.shape", f'"polygon" is only accepted in 2D, got simulation.dim = {dim}')
        if len(body.vertices) < 3:
            raise SceneError(f"{key}.vertices", f"a polygon needs at least 3 vertices, got {len(body.vertices)}")
        extent = np.ptp(np.asarray(body.vertices, dtype=float), axis=0)
        if abs(polygon_area(body.vertices)) <= 1e-12 * float(extent.max()) ** 2:
            raise SceneError(f"{key}.vertices", "the polygon has zero area")
    else:
        check_range(f"{key}.radius", body.radius, POSITIVE)
    span = lattice_span(body, dx, dim)
    if span > MAX_PARTICLES:
        raise SceneError(key, f"spans {Decimal(span):.3g} lattice points of spacing dx = {show(dx)}, more than the "
                              f"{MAX_PARTICLES} particles a run can index (dx is in metres)")  # fmt: skip
    if not has_lattice_point(body, dx, dim):
        raise SceneError(key, f"empty body: no lattice point of spacing dx = {show(dx)} lies inside it")


def _check_one_record_per_plane(boundaries: list, loads: list) -> None:
    """Two boundaries or traction loads on the same face would mirror its particles twice."""
    seen: dict = {}
    planes = [("boundaries", b) for b in boundaries] + [("loads", ld) for ld in loads if ld.kind in FACE_LOADS]
    for section, item in planes:
        face = (item.axis, float(item.position), item.side)
        if face in seen:
            raise SceneError(f"{section}.{item.name}",
                             f"lies on the same face ({item.axis} = {item.position:g}, side {item.side}) as "
                             f"{seen[face]}; a face takes one boundary, traction load or plate (a load or plate "
                             "with an extent leaves the rest of its face traction-free)")  # fmt: skip
        seen[face] = f"{section}.{item.name}"


def _check_boundary(boundary: Boundary, key: str, scene: Scene) -> None:
    check_types(boundary, key)
    check_choice(f"{key}.kind", boundary.kind, ("fixed", "slip", "symmetry", "free", "velocity"))
    check_range(f"{key}.friction_angle", boundary.friction_angle, Interval(0.0, 90.0, True, False))
    if boundary.friction_angle > 0.0 and not (boundary.kind == "slip" and scene.simulation.large_deformation):
        raise SceneError(f"{key}.friction_angle",
                         "friction acts on the particles that join a slip plane: it needs kind = \"slip\" and "
                         "simulation.large_deformation = true")  # fmt: skip
    _check_face(boundary, key, scene.simulation.dim)
    _check_time_function(boundary.time_function, f"{key}.time_function")
    _check_drainage(boundary.drainage, f"{key}.drainage", scene.effects)


def _check_load(load: Load, key: str, scene: Scene) -> None:
    check_types(load, key)
    check_choice(f"{key}.kind", load.kind, ("traction", "plate", "velocity", "force"))
    check_choice(f"{key}.contact", load.contact, ("rough", "smooth"))
    if load.kind == "plate":
        _check_plate(load, key, scene)
    if load.kind in FACE_LOADS:
        _check_face(load, key, scene.simulation.dim)
    elif load.contact == "smooth" and not any(load.velocity if load.kind == "velocity" else load.force):
        raise SceneError(f"{key}.contact", f'a "smooth" {load.kind} load needs a nonzero {load.kind} (its direction)')
    elif load.region is None:
        raise SceneError(f"{key}.region", f'a {show(load.kind)} load needs region = {{ min = [...], max = [...] }}')
    for name in ("extent", "region"):
        if getattr(load, name) is not None:
            _check_region(getattr(load, name), f"{key}.{name}")
    _check_time_function(load.time_function, f"{key}.time_function")
    _check_drainage(load.drainage, f"{key}.drainage", scene.effects)
    if load.kind not in FACE_LOADS and load.drainage.kind != "impermeable":
        raise SceneError(
            f"{key}.drainage.kind",
            f"must be \"impermeable\" for a {show(load.kind)} load (only faces drain), got {show(load.drainage.kind)}",
        )


def _check_plate(load: Load, key: str, scene: Scene) -> None:
    """A plate's drive, its base's drainage and what drives it."""
    check_choice(f"{key}.drive", load.drive, ("force", "velocity"))
    check_choice(f"{key}.base_drainage", load.base_drainage, ("impermeable", "drained"))
    check_choice(f"{key}.rotation", load.rotation, ("fixed", "free"))
    if any(load.moment) and load.rotation != "free":
        raise SceneError(f"{key}.moment", 'a plate takes a moment when it may rotate: set rotation = "free"')
    if load.base_drainage != "impermeable":
        needs_pore_water(f"{key}.base_drainage", scene.effects, "")
    other = "velocity" if load.drive == "force" else "force"
    if any(getattr(load, other)):
        raise SceneError(f"{key}.{other}", f'a plate with drive = "{load.drive}" takes {load.drive} only; '
                         f'set drive = "{other}" to drive it by its {other}')  # fmt: skip
    if load.region is not None or any(load.traction):
        extra = "region" if load.region is not None else "traction"
        raise SceneError(f"{key}.{extra}", "a plate lies on its face over extent = { min = [...], max = [...] }; it "
                         f"takes no {extra}")  # fmt: skip


def _check_drainage(drainage: Drainage, key: str, effects: Effects) -> None:
    check_choice(f"{key}.kind", drainage.kind, ("impermeable", "drained", "inflow"))
    _check_time_function(drainage.time_function, f"{key}.time_function")
    if drainage.kind != "impermeable":
        needs_pore_water(f"{key}.kind", effects, "")
    if drainage.extent is not None:
        _check_region(drainage.extent, f"{key}.extent")


def _check_pore_water_can_escape(scene: Scene) -> None:
    """Refuse saturated soil whose water can neither leave (no drained face) nor compress."""
    if not scene.effects.pore_water or scene.pressure.free_surface == "drained":
        return
    if any(face.drainage.kind == "drained" for face in [*scene.boundaries, *scene.loads]) or _drained_plate(scene):
        return
    if all(math.isinf(scene.materials[body.material].biot_modulus) for body in scene.bodies):
        raise SceneError(
            "effects.pore_water",
            "the pore water can neither drain nor compress: add a drained boundary or a finite water_bulk_modulus",
        )


def _drained_plate(scene: Scene) -> bool:
    """Whether a plate's base drains."""
    return any(ld.kind == "plate" and ld.base_drainage == "drained" for ld in scene.loads)


def _check_face(face: Boundary | Load, key: str, dim: int) -> None:
    """Check the plane of a boundary or traction load: an axis the scene uses and a side."""
    axes = [AXES[a] for a in used_axes(dim)]
    check_choice(f"{key}.axis", face.axis, axes, note=f" (simulation.dim = {dim})")
    check_choice(f"{key}.side", face.side, ("min", "max"))


def _check_region(region: Region, key: str) -> None:
    for a, (lo, hi) in enumerate(zip(region.min, region.max)):
        if lo > hi:
            raise SceneError(
                f"{key}.max",
                f"must be >= min on every axis, got max {AXES[a]} = {show(hi)}, min {AXES[a]} = {show(lo)}",
            )


def _check_time_function(tf: TimeFunction, key: str) -> None:
    check_choice(f"{key}.kind", tf.kind, ("constant", "step", "ramp", "table"))
    check_range(f"{key}.duration", tf.duration, NON_NEGATIVE)
    if tf.kind != "table":
        return
    if len(tf.times) != len(tf.values) or len(tf.times) < 2:
        raise SceneError(
            f"{key}.times",
            f"times and values must have the same length, at least 2, got {len(tf.times)} and {len(tf.values)}",
        )
    for i in range(1, len(tf.times)):
        if not tf.times[i] > tf.times[i - 1]:
            raise SceneError(
                f"{key}.times[{i}]",
                f"times must be strictly increasing, got {show(tf.times[i])} after {show(tf.times[i - 1])}",
            )


def _check_probe(probe: Probe, key: str, scene: Scene) -> None:
    check_types(probe, key)
    check_choice(f"{key}.kind", probe.kind, ("point", "region_mean", "maximum", "minimum", "reaction"))
    if probe.kind == "reaction":
        check_choice(f"{key}.field", probe.field, AXES, note=" (force component of a reaction probe)")
        faces = [b.name for b in scene.boundaries] + [ld.name for ld in scene.loads]
        if probe.boundary not in faces:
            accepted = ", ".join(show(f) for f in faces) or "none defined"
            raise SceneError(
                f"{key}.boundary",
                f"must name a boundary or load ({accepted}), got {show(probe.boundary)}",
            )
        return
    check_choice(f"{key}.field", probe.field, PROBE_FIELDS)
    if probe.field in PORE_WATER_FIELDS:
        needs_pore_water(f"{key}.field", scene.effects, f"{show(probe.field)} ")
    if probe.field in PLASTICITY_FIELDS:
        needs_plasticity(f"{key}.field", scene.effects, f"{show(probe.field)} ")
    if probe.kind == "region_mean":
        if probe.region is None:
            raise SceneError(f"{key}.region", 'a "region_mean" probe needs region = { min = [...], max = [...] }')
    if probe.region is not None:
        _check_region(probe.region, f"{key}.region")


def _check_output(output: Output, effects: Effects) -> None:
    check_instance("output", output, Output)
    check_types(output, "output")
    check_range("output.frame_interval", output.frame_interval, POSITIVE)
    for i, name in enumerate(output.fields):
        check_choice(f"output.fields[{i}]", name, OUTPUT_FIELDS)
        if name in PORE_WATER_FIELDS:
            needs_pore_water(f"output.fields[{i}]", effects, f"{show(name)} ")
        if name in PLASTICITY_FIELDS:
            needs_plasticity(f"output.fields[{i}]", effects, f"{show(name)} ")
    check_range("output.checkpoint_interval", output.checkpoint_interval, NON_NEGATIVE)
    check_range("output.probe_every", output.probe_every, Interval(1.0, lo_closed=True, hi_closed=True))
