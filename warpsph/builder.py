"""Scene → (Model, State): fills bodies with real particles and virtual stress points, lays out
boundary planes and their mirror ghosts, and sets initial fields.

The first ghost layout is planned here from the initial positions (``stages/ghost_layout.py``);
with ``simulation.large_deformation`` the ghost arrays get room for the body to spread along its
planes (one more ghost per point and plane, up to three planes), which the solver re-plans into.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import warp as wp

from warpsph.fields import voigt_to_tensor
from warpsph.initial_stress import geostatic_stress, geostatic_unit_weight, overburden
from warpsph.lattice import fill_body, fill_cells, lattice_codes
from warpsph.environment import default_device, init_warp
from warpsph.model import PLANE_FIXED, PLANE_SLIP, PLANE_TRACTION, PLANE_VELOCITY, Model, State
from warpsph.physics.elastic import elastic_struct
from warpsph.physics.plasticity import material_struct, viscoplastic_material
from warpsph.pore_water import build_pore_water
from warpsph.errors import SceneError
from warpsph.scene import AXES, EXTENT_TOLERANCE, Scene
from warpsph.scene_reach import check_reach, plane_section
from warpsph.sph.spec import Spec
from warpsph.stages.ghost_layout import GHOST_MARGIN, ON_PLANE, plan_ghosts
from warpsph.stages.plates import plate_layout
from warpsph.stages.rigid import RIGID_LOAD_KINDS

_BOUNDARY_KINDS = {"fixed": PLANE_FIXED, "slip": PLANE_SLIP, "symmetry": PLANE_SLIP, "free": PLANE_TRACTION,
                   "velocity": PLANE_VELOCITY}  # fmt: skip


def _planes(scene: Scene):
    """One record per boundary plane: boundaries first, then traction and plate loads (the plate last)."""
    planes = []
    for b in scene.boundaries:
        vec = b.velocity if b.kind == "velocity" else (0.0, 0.0, 0.0)
        planes.append((b.name, b.axis_index, b.position, b.outward_sign, _BOUNDARY_KINDS[b.kind], vec, None,
                       b.time_function, b.drainage, None))  # fmt: skip
    for ld in scene.loads:
        if ld.kind in ("traction", "plate"):  # a plate's face is traction-free beside it
            traction = ld.traction if ld.kind == "traction" else (0.0, 0.0, 0.0)
            planes.append((ld.name, ld.axis_index, ld.position, ld.outward_sign, PLANE_TRACTION, traction,
                           ld.extent if ld.kind == "traction" else None, ld.time_function, ld.drainage,
                           ld if ld.kind == "plate" else None))  # fmt: skip
    return planes


def merge_unique(point_sets: list[np.ndarray], dx: float) -> tuple[np.ndarray, np.ndarray]:
    """Concatenate point sets, dropping points that an earlier set already has; also the set index."""
    sets = [np.asarray(pts, dtype=float).reshape(-1, 3) for pts in point_sets]
    points = np.concatenate(sets) if sets else np.zeros((0, 3))
    owner = np.repeat(np.arange(len(sets), dtype=np.int32), [len(pts) for pts in sets])
    if not len(points):
        return points, owner
    _, first = np.unique(lattice_codes(points, dx), return_index=True)
    keep = np.sort(first)
    return points[keep], owner[keep]


def _with_room(ghosts, points: np.ndarray, plane_count: int, large_deformation: bool):
    """A ghost plan (positions, sources, chains) padded with unused slots for a large-deformation run:
    one more ghost per point and plane, up to three (``plane_count`` + 1 for the virtual set, whose
    regenerated points may outnumber the start's). Unused slots copy point 0 and mirror
    across no plane; only the first len(plan) ghosts are live."""
    if not large_deformation or not len(points):
        return ghosts
    pos, src, chain = ghosts
    room = len(points) * min(plane_count, 3)
    return (np.concatenate([pos, np.repeat(points[:1], room, axis=0)]),
            np.concatenate([src, np.zeros(room, np.int32)]),
            np.concatenate([chain, np.full((room, 3), -1, np.int32)]))  # fmt: skip


def rigid_region_members(scene: Scene, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Indices of the ``points`` [m] inside the region of each rigid ("velocity" or "force") load,
    and that load's index among the rigid loads."""
    index, load = [], []
    rigid_loads = [ld for ld in scene.loads if ld.kind in RIGID_LOAD_KINDS]
    for k, ld in enumerate(rigid_loads):
        inside = np.nonzero(ld.region.contains(points, ON_PLANE * scene.simulation.dx))[0]
        index.extend(inside.tolist())
        load.extend([k] * len(inside))
    return np.array(index, np.int32), np.array(load, np.int32)


def _initial_velocity(body, points: np.ndarray) -> np.ndarray:
    v = np.tile(np.asarray(body.velocity, dtype=float), (len(points), 1))
    if body.angular_velocity:
        r = points - np.asarray(body.center, dtype=float)
        v[:, 0] -= body.angular_velocity * r[:, 1]
        v[:, 1] += body.angular_velocity * r[:, 0]
    return v


def _geostatic(material, points: np.ndarray, gravity, dx: float, pore_water: bool) -> np.ndarray:
    """Geostatic effective stress (…,3,3) [Pa] of one body's ``points``: σ′_yy = −(ρ − ρ_w) g depth below
    the body's highest particle in each one's column (ρ_w only with pore water: the buoyant weight),
    σ′_xx = σ′_zz = K0 σ′_yy."""
    n = len(points)
    vertical = overburden(points, np.full(n, geostatic_unit_weight(material, gravity, pore_water)), dx)
    return geostatic_stress(vertical, np.full(n, material.earth_pressure_at_rest))


def plastic_materials(spec: Spec, materials, device: str) -> wp.array:
    """One viscoplastic material struct per material [SI units]; von Mises takes σ_Y = √3 c (c = c_u)
    and scales H and the residual alike. Elastic materials get fluidity 0: they never relax."""
    structs = []
    for mat in materials:
        if mat.model != "viscoplastic":
            structs.append(viscoplastic_material(spec, spec.yield_function, strength=0.0, fluidity=0.0,
                                                 reference_stress=1.0))  # fmt: skip
            continue
        scale = math.sqrt(3.0) if spec.yield_function == "von_mises" else 1.0
        structs.append(viscoplastic_material(
            spec, spec.yield_function, strength=scale * mat.cohesion, fluidity=mat.fluidity,
            reference_stress=mat.reference_stress, hardening=scale * mat.hardening_modulus,
            residual_strength=scale * mat.residual_cohesion, friction=math.radians(mat.friction_angle),
            dilatancy=math.radians(mat.dilatancy_angle), exponent=mat.rate_exponent,
        ))  # fmt: skip
    return wp.array(structs, dtype=material_struct(spec), device=device)


def elastic_materials(spec: Spec, materials, arr):
    """The :func:`~warpsph.physics.elastic.elastic_struct` of ``materials``, its arrays made by ``arr``."""
    npr = np.float64 if spec.precision == "float64" else np.float32
    elastic = elastic_struct(spec)()
    elastic.lam = arr(np.array([m.lame_lambda for m in materials], npr), spec.real)
    elastic.shear = arr(np.array([m.shear_modulus for m in materials], npr), spec.real)
    elastic.wave_speed = arr(np.array([m.p_wave_speed for m in materials], npr), spec.real)
    return elastic


def _check_drained_planes(scene: Scene, planes, on_plane: np.ndarray, points: np.ndarray) -> None:
    """A drained or inflow plane needs particles on it, in its extent: the pressure is prescribed there."""
    for p_idx, plane in enumerate(planes):
        name, drainage = plane[0], plane[8]
        on = np.any(on_plane == p_idx, axis=1)
        tol = EXTENT_TOLERANCE * scene.simulation.dx
        if drainage.kind != "impermeable" and not np.any(drainage.covers(points[on], plane[1], tol)):
            raise SceneError(f"{plane_section(scene, name)}.{name}.position",
                             f"no particle lies on this {drainage.kind} plane ({AXES[plane[1]]} = {plane[2]:g})"
                             f"{' inside its drainage.extent' if drainage.extent else ''}; put it on a face of a "
                             "body, on the lattice of spacing dx")  # fmt: skip


def _check_plates(scene: Scene, planes, plates) -> None:
    """A plate needs particles under it: it holds them to its motion and passes its force through them."""
    for p_idx, plane in enumerate(planes):
        if plane[9] is not None and not np.any(plates.plate_of == p_idx):
            raise SceneError(f"loads.{plane[0]}.extent",
                             f"no particle lies under this plate on its face ({AXES[plane[1]]} = {plane[2]:g}); put "
                             "it on a face of a body and give it an extent at least one dx wide there")  # fmt: skip


def build(scene: Scene, device: str | None = None, precision: str | None = None,
          staged: bool = False) -> tuple[Model, State]:  # fmt: skip
    """Turn a validated ``scene`` into a Model and its initial State on ``device`` (default:
    :func:`~warpsph.launching.default_device`). ``staged``: ``scene`` is a phase's
    (:func:`~warpsph.phases.phase_scene`): the model's scene leaves out the point and region probes that
    reach none of its particles (they sample in the phases they reach) instead of refusing them."""
    init_warp()
    device = device or default_device()
    spec = Spec.from_scene(scene, precision)
    sim = scene.simulation
    dx, dim = sim.dx, sim.dim
    h = scene.smoothing_length
    band = 2.0 * h * (1.0 + GHOST_MARGIN)
    tol = ON_PLANE * dx
    cell_volume = dx**dim

    mat_names = list(scene.materials)
    mats = [scene.materials[m] for m in mat_names]
    body_mat = [mat_names.index(b.material) for b in scene.bodies]

    body_points = [fill_body(b, dx, dim) for b in scene.bodies]
    real_pts, real_body = merge_unique(body_points, dx)
    n = len(real_pts)
    density0 = np.array([mats[body_mat[b]].density for b in real_body])
    velocity0 = np.zeros((n, 3))
    stress0 = np.zeros((n, 3, 3))
    pore = spec.effects.pore_water
    pore0 = np.zeros(n)
    for i, body in enumerate(scene.bodies):
        sel = real_body == i
        velocity0[sel] = _initial_velocity(body, real_pts[sel])
        stress0[sel] = voigt_to_tensor(body.stress)
        if body.geostatic and np.any(sel):
            stress0[sel] += _geostatic(mats[body_mat[i]], real_pts[sel], sim.gravity, dx, pore)
        pore0[sel] = body.pore_pressure

    planes = _planes(scene)
    mirrors = [(p[1], p[2], p[3]) for p in planes]
    g_plan = plan_ghosts(real_pts, mirrors, band, tol)
    g_pos, g_src, g_chain = _with_room(g_plan, real_pts, len(planes), sim.large_deformation)

    two_set = spec.scheme == "two_set"
    if two_set:
        virt_pts, virt_body = merge_unique([fill_cells(b, dx, dim) for b in scene.bodies], dx)
        if not len(virt_pts):
            raise SceneError(f"bodies.{scene.bodies[0].name}", f"holds no virtual stress point at dx = {dx:g} m: "
                             "the two-set scheme needs a body at least one dx thick along every axis; refine dx")
    else:
        virt_pts, virt_body = np.zeros((0, 3)), np.zeros(0, dtype=np.int32)
    vg_plan = plan_ghosts(virt_pts, mirrors, band, tol)
    vg_pos, vg_src, vg_chain = _with_room(vg_plan, virt_pts, len(planes) + 1, sim.large_deformation)
    virt_density = np.array([mats[body_mat[b]].density for b in virt_body])

    # particles lying on planes get the plane's prescribed values
    on_plane = np.full((n, 3), -1, dtype=np.int32)
    counts = np.zeros(n, dtype=np.int32)
    for p_idx, (_n, axis, position, *_rest) in enumerate(planes):
        hit = np.abs(real_pts[:, axis] - position) <= tol
        for a in np.nonzero(hit)[0]:
            if counts[a] < 3:
                on_plane[a, counts[a]] = p_idx
                counts[a] += 1
    constrained = np.nonzero(counts)[0].astype(np.int32)
    plates = plate_layout([p[9] for p in planes], [p[1] for p in planes], on_plane[constrained], real_pts[constrained],
                          density0[constrained] * cell_volume, dx, dim, EXTENT_TOLERANCE * dx)  # fmt: skip
    _check_plates(scene, planes, plates)
    unreached = check_reach(scene, planes, on_plane, real_pts, real_body, body_points, staged)
    if unreached:
        scene = dataclasses.replace(scene, probes=[p for p in scene.probes if p.name not in unreached])
    if pore:
        _check_drained_planes(scene, planes, on_plane, real_pts)

    region_particle, region_load = rigid_region_members(scene, real_pts)
    region_virtual, region_virtual_load = rigid_region_members(scene, virt_pts)

    all_pts = np.concatenate([real_pts, g_pos, virt_pts, vg_pos])
    extent = all_pts.max(axis=0) - all_pts.min(axis=0)

    real, vec3 = spec.real, spec.vec3
    npr = np.float64 if spec.precision == "float64" else np.float32

    def arr(values, dtype, shape_if_empty=None):
        values = np.asarray(values)
        if values.size == 0 and shape_if_empty is not None:
            values = np.zeros(shape_if_empty)
        return wp.array(values, dtype=dtype, device=device)

    def ext(owned, sources):
        return np.concatenate([owned, owned[sources]]) if len(sources) else owned

    real_mass = density0 * cell_volume
    virt_mass = virt_density * cell_volume
    grow = EXTENT_TOLERANCE * dx  # an extent edge on a lattice point or a virtual column includes it
    lo = [np.asarray(p[6].min if p[6] is not None else (-np.inf,) * 3, dtype=float) - grow for p in planes]
    hi = [np.asarray(p[6].max if p[6] is not None else (np.inf,) * 3, dtype=float) + grow for p in planes]
    big = np.finfo(np.float32).max
    model = Model(
        scene=scene,
        spec=spec,
        device=device,
        dx=dx,
        h=h,
        extent=extent,
        gravity=tuple(sim.gravity),
        particle_count=n,
        particle_ghost_count=len(g_plan[1]),
        particle_mass=arr(ext(real_mass, g_src).astype(npr), real),
        particle_material=arr(ext(np.array([body_mat[b] for b in real_body], np.int32), g_src), wp.int32),
        particle_x0=real_pts.copy(),
        particle_origin=arr(real_pts.astype(npr), vec3, (0, 3)),
        particle_ghost_source=arr(g_src, wp.int32),
        particle_ghost_planes=arr(g_chain, wp.vec3i, (0, 3)),
        virtual_count=len(virt_pts),
        virtual_ghost_count=len(vg_plan[1]),
        virtual_mass=arr(ext(virt_mass, vg_src).astype(npr), real),
        virtual_origin=arr(np.concatenate([virt_pts, vg_pos]).astype(npr), vec3, (0, 3)),
        virtual_material=arr(ext(np.array([body_mat[b] for b in virt_body], np.int32), vg_src), wp.int32),
        virtual_ghost_source=arr(vg_src, wp.int32),
        virtual_ghost_planes=arr(vg_chain, wp.vec3i, (0, 3)),
        material_elastic=elastic_materials(spec, mats, arr),
        plane_count=len(planes),
        plane_axis=arr(np.array([p[1] for p in planes], np.int32), wp.int32),
        plane_position=arr(np.array([p[2] for p in planes], npr), real),
        plane_sign=arr(np.array([p[3] for p in planes], npr), real),
        plane_kind=arr(np.array([p[4] for p in planes], np.int32), wp.int32),
        plane_vector=arr(np.array([p[5] for p in planes], npr), vec3, (0, 3)),
        plane_extent_lo=arr(np.clip(np.array(lo), -big, big).astype(npr), vec3, (0, 3)),
        plane_extent_hi=arr(np.clip(np.array(hi), -big, big).astype(npr), vec3, (0, 3)),
        plane_functions=[p[7] for p in planes],
        plane_names=[p[0] for p in planes],
        constraint_count=len(constrained),
        constraint_particle=arr(constrained, wp.int32),
        constraint_planes=arr(on_plane[constrained], wp.vec3i, (0, 3)),
        region_count=len(region_particle),
        region_particle=arr(region_particle, wp.int32),
        region_load=arr(region_load, wp.int32),
        region_virtual=arr(region_virtual, wp.int32),
        region_virtual_load=arr(region_virtual_load, wp.int32),
        material_plasticity=plastic_materials(spec, mats, device) if spec.effects.plasticity else None,
        particle_ids=np.arange(n, dtype=np.int64),
        plates=plates,
        pore=(build_pore_water(scene, [p[8] for p in planes], float(real_pts[:, 1].max()), vec3, grow, device)
              if pore else None),
    )

    state = model.state()
    state.particle_q.assign(np.concatenate([real_pts, g_pos]).astype(npr))
    state.particle_v.assign(ext(velocity0, g_src).astype(npr))
    state.particle_stress.assign(ext(stress0, g_src).astype(npr))
    state.particle_density.assign(ext(density0, g_src).astype(npr))
    if pore:
        state.particle_pore_pressure.assign(ext(pore0, g_src))
    if two_set:
        state.virtual_q.assign(np.concatenate([virt_pts, vg_pos]).astype(npr))
        state.virtual_density.assign(ext(virt_density, vg_src).astype(npr))
    return model, state
