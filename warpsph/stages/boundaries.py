"""Boundary planes: mirror ghosts of both particle sets, each field with its plane's parity, and the
prescribed values of the particles lying on the planes (docs/method.md, *Boundaries*).
"""


import functools

import numpy as np
import warp as wp

from warpsph.launching import launch
from warpsph.model import (PLANE_FIXED, PLANE_SLIP, PLANE_TRACTION, PLANE_VELOCITY, PLATE_NONE, PLATE_ROUGH,
                           PLATE_VELOCITY, Model)
from warpsph.physics.elastic import elastic_struct, strain_energy_function
from warpsph.sph.packed_stress import as_stored, as_tensor
from warpsph.sph.spec import Spec
from warpsph.stages.energy import BOUNDARIES, ledger_columns


@functools.cache
def plane_functions(spec: Spec):
    """``(traction_here, drainage_here, on_plate, plate_velocity)``: a plane's load, drainage and plate at
    a point of the plane."""
    real, vec3 = spec.real, spec.vec3
    Planes = planes_struct(spec)

    @wp.func
    def inside_extent(p: int, x: vec3, axis: int, lo: wp.array(dtype=vec3), hi: wp.array(dtype=vec3)):
        """Whether x lies in plane p's extent [lo, hi], measured along the plane (its own axis aside)."""
        inside = True
        for k in range(3):
            if k != axis and (x[k] < lo[p][k] or x[k] > hi[p][k]):
                inside = False
        return inside

    @wp.func
    def on_plate(p: int, x: vec3, axis: int, planes: Planes):
        """Whether a point that started at x lies under plane p's rigid plate (none: False)."""
        return planes.plate_contact[p] != PLATE_NONE and inside_extent(p, x, axis, planes.plate_lo, planes.plate_hi)

    @wp.func
    def plate_velocity(p: int, planes: Planes, x: vec3):
        """The velocity [m/s] of plane p's plate at the point that started at x: its translation (prescribed
        × f(t), or its force balance's) and its spin ω × (x − c) about its centre c."""
        v = planes.plate_velocity[p]
        if planes.plate_drive[p] == PLATE_VELOCITY:
            v = planes.plate_vector[p] * planes.factor[p]
        return v + wp.cross(planes.plate_spin[p], x - planes.plate_centre[p])

    @wp.func
    def traction_here(p: int, x: vec3, axis: int, vector: wp.array(dtype=vec3), lo: wp.array(dtype=vec3),
                      hi: wp.array(dtype=vec3), factor: wp.array(dtype=real)):  # fmt: skip
        """Traction t̄ f(t) of plane p at a point that started at x, zero outside the plane's extent."""
        if inside_extent(p, x, axis, lo, hi):
            return vector[p] * factor[p]
        return vec3(real(0.0), real(0.0), real(0.0))

    @wp.func
    def drainage_here(p: int, x: vec3, axis: int, planes: Planes):
        """Drainage kind of plane p at a point that started at x (0, impermeable, outside its extent;
        under a plate, the plate's base)."""
        if on_plate(p, x, axis, planes):
            return planes.plate_base[p]
        if inside_extent(p, x, axis, planes.drained_lo, planes.drained_hi):
            return planes.drainage[p]
        return 0

    return traction_here, drainage_here, on_plate, plate_velocity


@functools.cache
def planes_struct(spec: Spec):
    """The ``Planes`` @wp.struct of ``spec``'s precision: the boundary planes as the ghost and prescription
    kernels take them, (P,) each: axis, current position [m], outward sign, kind, prescribed vector (a
    velocity [m/s] or a traction [Pa]), extent lo and hi [m], the load factor f(t) of the time, the rigid
    plate on the plane (:mod:`warpsph.stages.plates`: its contact, drive, prescribed velocity [m/s] or
    force [N/m, N], extent, base drainage, current velocity [m/s], spin [rad/s] and centre [m]), and with
    pore water the drainage kind (0 impermeable, 1 drained, 2 inflow), its extent drained_lo and drained_hi
    [m], and the drained pressure [Pa], head [m] (NaN: none) and inflow [m/s] at the time
    (:meth:`Boundaries.with_drainage`)."""
    real, vec3 = spec.real, spec.vec3

    @wp.struct
    class Planes:
        axis: wp.array(dtype=wp.int32)
        position: wp.array(dtype=real)
        sign: wp.array(dtype=real)
        kind: wp.array(dtype=wp.int32)
        vector: wp.array(dtype=vec3)
        lo: wp.array(dtype=vec3)
        hi: wp.array(dtype=vec3)
        factor: wp.array(dtype=real)
        plate_contact: wp.array(dtype=wp.int32)
        plate_drive: wp.array(dtype=wp.int32)
        plate_vector: wp.array(dtype=vec3)
        plate_lo: wp.array(dtype=vec3)
        plate_hi: wp.array(dtype=vec3)
        plate_base: wp.array(dtype=wp.int32)
        plate_velocity: wp.array(dtype=vec3)
        plate_spin: wp.array(dtype=vec3)
        plate_centre: wp.array(dtype=vec3)
        drainage: wp.array(dtype=wp.int32)
        drained_lo: wp.array(dtype=vec3)
        drained_hi: wp.array(dtype=vec3)
        pressure: wp.array(dtype=wp.float64)
        head: wp.array(dtype=wp.float64)
        inflow: wp.array(dtype=wp.float64)

    return Planes


@functools.cache
def gravity_struct(spec: Spec):
    """The ``Gravity`` @wp.struct of ``spec``'s precision: the body force b [m/s²] and, with pore water, the
    materials' water densities [kg/m³] and the water table [m] that give the water at rest its pressure,
    as the ghost and prescription kernels take them."""
    real, vec3 = spec.real, spec.vec3

    @wp.struct
    class Gravity:
        b: vec3
        water_density: wp.array(dtype=wp.float64)
        water_table: real

    return Gravity


@functools.cache
def water_functions(spec: Spec):
    """``(pore_pressure_at, Gravity)``: a point's total pore pressure and the struct it reads the water at
    rest from (:func:`gravity_struct`)."""
    real, vec3 = spec.real, spec.vec3
    Gravity = gravity_struct(spec)

    @wp.func
    def pore_pressure_at(i: int, x: vec3, pore: wp.array(dtype=wp.float64), material: wp.array(dtype=wp.int32),
                         gravity: Gravity):  # fmt: skip
        """Total pore pressure p_excess + ρ_w b·(x − x_wt) of point i at x [Pa] (pore water only)."""
        shifted = vec3(x[0], x[1] - gravity.water_table, x[2])
        return real(pore[i]) + real(gravity.water_density[material[i]]) * wp.dot(gravity.b, shifted)

    return pore_pressure_at, Gravity


@functools.cache
def _kernels(spec: Spec, stress_type=None):
    """The planes' kernels; ``update_ghosts`` for stresses stored as ``stress_type`` (default mat33; the
    virtual points' scratch is :mod:`warpsph.sph.packed_stress`'s)."""
    column = ledger_columns(spec)  # the energy ledger's column of each channel
    real, vec3, mat33 = spec.real, spec.vec3, spec.mat33
    stress_type = stress_type or mat33
    two = real(2.0)
    pore_water = spec.effects.pore_water
    traction_here, drainage_here, on_plate, plate_velocity = plane_functions(spec)
    psi = strain_energy_function(spec)
    ElasticMaterials = elastic_struct(spec)
    Planes = planes_struct(spec)
    pore_pressure_at, Gravity = water_functions(spec)

    @wp.kernel(enable_backward=False, module="unique")
    def update_ghosts(
        n_owned: int,
        source: wp.array(dtype=wp.int32),
        chain: wp.array(dtype=wp.vec3i),
        planes: Planes,
        gravity: Gravity,
        material: wp.array(dtype=wp.int32),
        pore: wp.array(dtype=wp.float64),
        origin: wp.array(dtype=vec3),
        q: wp.array(dtype=vec3),
        v: wp.array(dtype=vec3),
        stress: wp.array(dtype=stress_type),
        density: wp.array(dtype=real),
    ):
        g = wp.tid()
        src = source[g]
        x = q[src]
        u = v[src]
        s = as_tensor(stress[src])
        weight = density[src]  # the stress gradient at a wall balances (ρ − ρ_w) b
        if wp.static(pore_water):
            weight = weight - real(gravity.water_density[material[src]])
        on = chain[g]
        for c in range(3):
            p = on[c]
            if p >= 0:
                m = planes.axis[p]
                kind = planes.kind[p]
                depth = planes.sign[p] * (planes.position[p] - x[m])
                x[m] = two * planes.position[p] - x[m]
                plate = kind == PLANE_TRACTION and on_plate(p, origin[src], m, planes)
                if kind != PLANE_TRACTION or plate:
                    # at rest against a wall ∂σ_nn/∂n = −ρ b·n: continue σ_nn linearly, not evenly
                    s[m, m] = s[m, m] - two * depth * weight * planes.sign[p] * gravity.b[m]
                if kind == PLANE_FIXED:
                    u = -u
                elif kind == PLANE_VELOCITY:
                    u = two * planes.vector[p] * planes.factor[p] - u
                elif kind == PLANE_SLIP or (plate and planes.plate_contact[p] != PLATE_ROUGH):
                    # a slip plane, or a smooth plate: the normal velocity mirrored about the plane's, no shear
                    u_n = real(0.0)
                    if plate:
                        u_n = plate_velocity(p, planes, origin[src])[m]
                    u[m] = two * u_n - u[m]
                    for k in range(3):
                        if k != m:
                            s[m, k] = -s[m, k]
                            s[k, m] = -s[k, m]
                elif plate:
                    u = two * plate_velocity(p, planes, origin[src]) - u
                else:
                    # the load at the source's own point: a ghost of a ghost across a symmetry
                    # plane sees the mirror image of the load, not the load at its mirrored place
                    t = traction_here(p, origin[src], m, planes.vector, planes.lo, planes.hi, planes.factor)
                    sign = planes.sign[p]
                    for k in range(3):
                        s[m, k] = two * sign * t[k] - s[m, k]
                        if k != m:
                            s[k, m] = s[m, k]
                    if wp.static(pore_water):
                        # an impermeable face carries the load with the pore water: σ′n = t̄ + p n; a
                        # drained face is in contact with water at its own pressure, so σ′n = t̄
                        p_face = real(0.0)
                        if drainage_here(p, origin[src], m, planes) != 1:
                            p_face = pore_pressure_at(src, q[src], pore, material, gravity)
                        s[m, m] = s[m, m] + two * p_face
        q[n_owned + g] = x
        v[n_owned + g] = u
        stress[n_owned + g] = as_stored(s, stress[src])
        density[n_owned + g] = density[src]

    @wp.kernel(enable_backward=False, module="unique")
    def prescribe_on_planes(
        particle: wp.array(dtype=wp.int32),
        planes_of: wp.array(dtype=wp.vec3i),
        planes: Planes,
        gravity: Gravity,
        material: wp.array(dtype=wp.int32),
        pore: wp.array(dtype=wp.float64),
        origin: wp.array(dtype=vec3),
        q: wp.array(dtype=vec3),
        v: wp.array(dtype=vec3),
        stress: wp.array(dtype=mat33),
        mass: wp.array(dtype=real),
        density: wp.array(dtype=real),
        elastic: ElasticMaterials,
        ledger: wp.array2d(dtype=wp.float64),
    ):
        """The planes' values on their particles; the kinetic and elastic energy this gives a particle is
        the planes' work on it in the energy ledger."""
        i = wp.tid()
        a = particle[i]
        u = v[a]
        s = stress[a]
        on = planes_of[i]
        for c in range(3):
            p = on[c]
            if p >= 0:
                m = planes.axis[p]
                kind = planes.kind[p]
                if kind == PLANE_FIXED:
                    u = vec3(real(0.0), real(0.0), real(0.0))
                elif kind == PLANE_VELOCITY:
                    u = planes.vector[p] * planes.factor[p]
                elif kind == PLANE_SLIP:
                    u[m] = real(0.0)
                elif on_plate(p, origin[a], m, planes):
                    plate_u = plate_velocity(p, planes, origin[a])
                    if planes.plate_contact[p] == PLATE_ROUGH:
                        u = plate_u
                    else:
                        u[m] = plate_u[m]
                        for k in range(3):
                            if k != m:
                                s[m, k] = real(0.0)
                                s[k, m] = real(0.0)
                else:
                    t = traction_here(p, origin[a], m, planes.vector, planes.lo, planes.hi, planes.factor)
                    for k in range(3):
                        s[m, k] = planes.sign[p] * t[k]
                        s[k, m] = s[m, k]
                    if wp.static(pore_water):
                        # as for the ghosts: only an impermeable face shares its load
                        if drainage_here(p, origin[a], m, planes) != 1:
                            s[m, m] = s[m, m] + pore_pressure_at(a, q[a], pore, material, gravity)
        mat = material[a]
        given = real(0.5) * mass[a] * (wp.dot(u, u) - wp.dot(v[a], v[a]))
        given += mass[a] / density[a] * (psi(s, elastic.lam[mat], elastic.shear[mat])
                                         - psi(stress[a], elastic.lam[mat], elastic.shear[mat]))
        ledger[a, wp.static(column[BOUNDARIES])] += wp.float64(given)
        v[a] = u
        stress[a] = s

    @wp.kernel(enable_backward=False, module="unique")
    def sum_plane_positions(
        particle: wp.array(dtype=wp.int32),
        planes_of: wp.array(dtype=wp.vec3i),
        plate_of: wp.array(dtype=wp.int32),
        planes: Planes,
        q: wp.array(dtype=vec3),
        sums: wp.array(dtype=real),
    ):
        """sums[p] += the coordinate along plane p's axis of each particle lying on it (on a plane with a
        plate, those the plate holds: the plane is the plate's base)."""
        i = wp.tid()
        on = planes_of[i]
        for c in range(3):
            p = on[c]
            if p >= 0 and (planes.plate_contact[p] == PLATE_NONE or plate_of[i] == p):
                wp.atomic_add(sums, p, q[particle[i]][planes.axis[p]])

    @wp.kernel(enable_backward=False, module="unique")
    def move_planes(
        plane_kind: wp.array(dtype=wp.int32),
        initial_position: wp.array(dtype=real),
        on_plane_count: wp.array(dtype=real),
        sums: wp.array(dtype=real),
        position: wp.array(dtype=real),
    ):
        p = wp.tid()
        kind = plane_kind[p]
        position[p] = initial_position[p]
        if (kind == PLANE_TRACTION or kind == PLANE_VELOCITY) and on_plane_count[p] > real(0.0):
            position[p] = sums[p] / on_plane_count[p]

    return update_ghosts, prescribe_on_planes, sum_plane_positions, move_planes


@functools.cache
def _copy_kernel(spec: Spec):
    """Even-parity scalar ghosts: each ghost takes its source's value (e.g. ε̄)."""

    @wp.kernel(enable_backward=False, module="unique")
    def copy_scalar_to_ghosts(n_owned: int, source: wp.array(dtype=wp.int32), values: wp.array(dtype=spec.real)):
        g = wp.tid()
        values[n_owned + g] = values[source[g]]

    return copy_scalar_to_ghosts


class Boundaries:
    """Launches the ghost and prescription kernels of a model; holds the per-time load factors."""

    def __init__(self, model: Model):
        self.model = model
        real = model.spec.real
        self.plane_factor = wp.zeros(max(model.plane_count, 1), dtype=real, device=model.device)
        self._time = None
        self.plane_position = wp.clone(model.plane_position)
        """(P,) current plane coordinates [m]."""
        self._plane_sums = wp.zeros_like(model.plane_position)
        counts = np.zeros(model.plane_count)
        plates = model.plates
        for planes, plate in zip(model.constraint_planes.numpy().reshape(-1, 3), plates.plate_of):
            for p in planes[planes >= 0]:
                counts[p] += plates.contact[p] == PLATE_NONE or plate == p
        self._on_plane_count = wp.array(counts, dtype=real, device=model.device)
        self.plate_of = wp.array(plates.plate_of, dtype=wp.int32, device=model.device)
        """(C,) the plane whose plate holds each particle lying on a plane, −1 none."""
        self.planes = planes_struct(model.spec)()
        self.gravity = gravity_struct(model.spec)()
        """The body force and the water at rest (:func:`gravity_struct`)."""
        self.gravity.b = model.spec.vec3(*model.gravity)
        if model.pore is not None:
            self.gravity.water_density = model.pore.water.density
            self.gravity.water_table = model.spec.real(model.pore.water_table)
        """The planes as the kernels take them (their current positions and load factors)."""
        p = self.planes
        p.axis, p.position, p.sign, p.kind = model.plane_axis, self.plane_position, model.plane_sign, model.plane_kind
        p.vector, p.lo, p.hi = model.plane_vector, model.plane_extent_lo, model.plane_extent_hi
        p.factor = self.plane_factor
        arr = functools.partial(wp.array, device=model.device)
        npr = np.float64 if model.spec.precision == "float64" else np.float32
        p.plate_contact, p.plate_drive = arr(plates.contact, dtype=wp.int32), arr(plates.drive, dtype=wp.int32)
        p.plate_vector = arr(plates.vector.astype(npr), dtype=model.spec.vec3)
        p.plate_lo = arr(plates.lo.astype(npr), dtype=model.spec.vec3)
        p.plate_hi = arr(plates.hi.astype(npr), dtype=model.spec.vec3)
        p.plate_base = arr(plates.base, dtype=wp.int32)
        p.plate_velocity = wp.zeros(max(model.plane_count, 1), dtype=model.spec.vec3, device=model.device)
        p.plate_spin = wp.zeros(max(model.plane_count, 1), dtype=model.spec.vec3, device=model.device)
        p.plate_centre = arr(plates.centre.astype(npr), dtype=model.spec.vec3)
        if model.pore is not None:
            p.drainage, p.drained_lo, p.drained_hi = (model.pore.plane_drainage, model.pore.plane_drained_lo,
                                                      model.pore.plane_drained_hi)  # fmt: skip

    def with_drainage(self, drainage) -> object:
        """The planes as the pore-water kernels take them: :attr:`planes` with the drained values of
        ``drainage`` (a :class:`~warpsph.pore_water.PlaneDrainage`, whose arrays it refers to)."""
        struct = planes_struct(self.model.spec)
        planes = struct()
        for name in struct.vars:
            setattr(planes, name, getattr(self.planes, name))
        planes.pressure, planes.head, planes.inflow = drainage.pressure, drainage.head, drainage.inflow
        return planes

    def set_time(self, t: float) -> None:
        """Evaluate every load's time function at ``t`` [s] (a no-op if already there)."""
        if t == self._time:
            return
        m = self.model
        if m.plane_count:
            self.plane_factor.assign(np.array([f(t) for f in m.plane_functions]))
        self._time = t

    def move_planes(self, q) -> None:
        """Put traction and velocity planes at the mean position of their particles in ``q``."""
        m = self.model
        *_, sum_positions, move = _kernels(m.spec)
        self._plane_sums.zero_()
        launch(sum_positions, m.constraint_count,
               [m.constraint_particle, m.constraint_planes, self.plate_of, self.planes, q, self._plane_sums],
               m.device)  # fmt: skip
        launch(move, m.plane_count,
               [m.plane_kind, m.plane_position, self._on_plane_count, self._plane_sums, self.plane_position],
               m.device)  # fmt: skip

    def water_args(self, material, pore):
        """Body force and pore-water arguments of the ghost and prescription kernels."""
        return [self.gravity, material, pore if self.model.pore is not None else None]

    def update_real_ghosts(self, q, v, stress, density, pore=None) -> None:
        """Ghost entries of the real set from their sources (``pore``: their excess pore pressure)."""
        m = self.model
        update_ghosts, *_ = _kernels(m.spec)
        launch(update_ghosts, m.particle_ghost_count,
               [m.particle_count, m.particle_ghost_source, m.particle_ghost_planes, self.planes,
                *self.water_args(m.particle_material, pore), m.particle_origin, q, v, stress,
                density],
               m.device)  # fmt: skip

    def update_virtual_ghosts(self, q, v, stress, density, pore=None) -> None:
        """Ghost entries of the virtual set from their sources (``pore``: their excess pore pressure)."""
        m = self.model
        update_ghosts, *_ = _kernels(m.spec, stress.dtype)
        launch(update_ghosts, m.virtual_ghost_count,
               [m.virtual_count, m.virtual_ghost_source, m.virtual_ghost_planes, self.planes,
                *self.water_args(m.virtual_material, pore), m.virtual_origin, q, v, stress,
                density],
               m.device)  # fmt: skip

    def copy_to_real_ghosts(self, values) -> None:
        """Ghost entries of the real set's scalar field ``values`` from their sources, unchanged."""
        m = self.model
        launch(_copy_kernel(m.spec), m.particle_ghost_count, [m.particle_count, m.particle_ghost_source, values],
               m.device)  # fmt: skip

    def prescribe(self, q, v, stress, density, ledger, pore=None) -> None:
        """Set prescribed velocities and tractions on plane particles (tractions are total stresses:
        with pore water, ``pore`` holds the excess pore pressure), entering the energy they give in
        ``ledger`` (:mod:`warpsph.stages.energy`); rigid regions are :mod:`warpsph.stages.rigid`'s."""
        m = self.model
        _, on_planes, *_ = _kernels(m.spec)
        launch(on_planes, m.constraint_count,
               [m.constraint_particle, m.constraint_planes, self.planes,
                *self.water_args(m.particle_material, pore), m.particle_origin, q, v, stress,
                m.particle_mass, density, m.material_elastic, ledger], m.device)  # fmt: skip
