"""Rigid plates: a footing or plate on a boundary plane, driven by a velocity or a total force, that the
mirror ghosts of the plane hold the soil to (docs/method.md, *Rigid plates*).
"""

import functools
from dataclasses import dataclass

import numpy as np
import warp as wp

from warpsph.launching import launch
from warpsph.model import PLATE_FORCE, PLATE_NONE, PLATE_ROUGH, PLATE_SMOOTH, PLATE_VELOCITY
from warpsph.lattice import lattice_neighbours, used_axes
from warpsph.scene_sections import AXES
from warpsph.sph.spec import Spec
from warpsph.stages.damping import damped
from warpsph.stages.boundaries import planes_struct, water_functions

PLATE_CONTACTS = {"rough": PLATE_ROUGH, "smooth": PLATE_SMOOTH}
PLATE_DRIVES = {"velocity": PLATE_VELOCITY, "force": PLATE_FORCE}


@dataclass
class PlateLayout:
    """The plates of a model's planes, (P,) each (a plane without a plate has contact ``PLATE_NONE``), and
    which particles lying on the planes each one holds."""

    contact: np.ndarray
    """(P,) int32 ``PLATE_NONE``, ``PLATE_ROUGH`` or ``PLATE_SMOOTH``."""
    drive: np.ndarray
    """(P,) int32 ``PLATE_VELOCITY`` or ``PLATE_FORCE``."""
    vector: np.ndarray
    """(P,3) the prescribed velocity [m/s] or the total force [N/m in 2D, N in 3D], before f(t)."""
    lo: np.ndarray
    hi: np.ndarray
    """(P,3) the plate's extent along its plane [m] (grown by the extent tolerance)."""
    base: np.ndarray
    """(P,) int32 drainage of the plate's base: 0 impermeable, 1 drained."""
    mass: np.ndarray
    """(P,) the mass [kg, kg/m in 2D] the force balance moves: the particles under the plate, each by the
    share of its cell the plate covers."""
    plate_of: np.ndarray
    """(C,) int32 per particle lying on a plane (the model's constraint list): the plane whose plate holds
    it, −1 none."""
    area: np.ndarray
    """(C,) the plate's area [m^(dim−1)] each of those stands for: its lattice cell's overlap with the plate."""
    centre: np.ndarray
    """(P,3) the centre [m] a plate spins about: the centroid of the area its particles stand for."""
    inertia: np.ndarray
    """(P,3) the moments of inertia [kg m², kg m in 2D] of a plate's particles about the axes through its
    centre."""
    spin_axes: np.ndarray
    """(P,3) 1 for the axes a plate may spin about (those along its face, used by the dimension, when its
    rotation is free), else 0."""
    moment: np.ndarray
    """(P,3) the moment [N m/m in 2D, N m in 3D] applied about its centre, before f(t)."""

    @property
    def count(self) -> int:
        return int(np.count_nonzero(self.contact != PLATE_NONE))


def plate_layout(plates: list, axes: list[int], on_plane: np.ndarray, points: np.ndarray, mass: np.ndarray,
                 dx: float, dim: int, grow: float) -> PlateLayout:  # fmt: skip
    """The :class:`PlateLayout` of the planes: ``plates`` (P,) a "plate" :class:`~warpsph.scene.Load` or None,
    ``axes`` (P,) their normal axes; ``on_plane`` (C,3) the planes each particle lying on one lies on (−1
    unused), at ``points`` (C,3) [m] with ``mass`` (C,) [kg]."""
    count = len(plates)
    big = np.finfo(np.float32).max
    layout = PlateLayout(
        contact=np.array([PLATE_CONTACTS[p.contact] if p else PLATE_NONE for p in plates], np.int32),
        drive=np.array([PLATE_DRIVES[p.drive] if p else PLATE_VELOCITY for p in plates], np.int32),
        vector=np.array([(p.force if p.drive == "force" else p.velocity) if p else (0.0,) * 3 for p in plates],
                        dtype=float).reshape(count, 3),
        lo=np.full((count, 3), big), hi=np.full((count, 3), -big),
        base=np.array([int(p.base_drainage == "drained") if p else 0 for p in plates], np.int32),
        mass=np.zeros(count), plate_of=np.full(len(on_plane), -1, np.int32), area=np.zeros(len(on_plane)),
        centre=np.zeros((count, 3)), inertia=np.ones((count, 3)), spin_axes=np.zeros((count, 3)),
        moment=np.array([p.moment if p else (0.0,) * 3 for p in plates], dtype=float).reshape(count, 3),
    )  # fmt: skip
    for k, plate in enumerate(plates):
        if plate is None:
            continue
        extent_lo = np.full(3, -np.inf) if plate.extent is None else np.asarray(plate.extent.min, dtype=float)
        extent_hi = np.full(3, np.inf) if plate.extent is None else np.asarray(plate.extent.max, dtype=float)
        layout.lo[k], layout.hi[k] = np.clip(extent_lo - grow, -big, big), np.clip(extent_hi + grow, -big, big)
        along = [a for a in used_axes(dim) if a != axes[k]]
        on = np.nonzero(np.any(on_plane == k, axis=1) & (layout.plate_of < 0))[0]
        neighbours = lattice_neighbours(points[on], dx, along)
        share = np.ones(len(on))
        for j, a in enumerate(along):
            # the particle's cell on the face, [x − Δx/2, x + Δx/2] cut at the face's edge, within the plate
            lower, upper = neighbours[j]
            low = np.maximum(points[on, a] - np.where(lower >= 0, 0.5 * dx, 0.0), extent_lo[a])
            high = np.minimum(points[on, a] + np.where(upper >= 0, 0.5 * dx, 0.0), extent_hi[a])
            share *= np.clip(high - low, 0.0, dx) / dx
        # held: where the kernels put it under the plate (its start inside the grown extent), with some area
        inside = np.all((points[on][:, along] >= layout.lo[k, along]) & (points[on][:, along] <= layout.hi[k, along]),
                        axis=1)  # fmt: skip
        held = inside & (share > 0.0)
        holds = on[held]
        layout.plate_of[holds] = k
        layout.area[holds] = share[held] * dx ** (dim - 1)
        weights = share[held] * mass[holds]
        layout.mass[k] = float(np.sum(weights))
        if not len(holds):
            continue
        layout.centre[k] = np.average(points[holds], axis=0, weights=layout.area[holds])
        arm = points[holds] - layout.centre[k]
        for a in range(3):  # Σ m (|r|² − r_a²): about the axis a through the centre
            layout.inertia[k, a] = max(float(np.sum(weights * (np.sum(arm**2, axis=1) - arm[:, a] ** 2))), 1e-300)
        if plate.rotation == "free":
            spin = [2] if dim == 2 else [a for a in along]  # in 2D about z, normal to the plane of motion
            layout.spin_axes[k, spin] = 1.0
    return layout


@functools.cache
def _kernels(spec: Spec):
    real, vec3 = spec.real, spec.vec3
    pore_water = spec.effects.pore_water
    Planes = planes_struct(spec)
    pore_pressure_at, Gravity = water_functions(spec)

    @wp.kernel(enable_backward=False, module="unique")
    def plate_forces(
        particle: wp.array(dtype=wp.int32),
        plate_of: wp.array(dtype=wp.int32),
        area: wp.array(dtype=real),
        planes: Planes,
        gravity: Gravity,
        material: wp.array(dtype=wp.int32),
        pore: wp.array(dtype=wp.float64),
        q: wp.array(dtype=vec3),
        stress: wp.array(dtype=spec.mat33),
        origin: wp.array(dtype=vec3),
        force: wp.array(dtype=vec3),
        torque: wp.array(dtype=vec3),
    ):
        """force[p] += A σ n of each particle the plate on plane p holds, the force the plate passes into the
        soil [N/m in 2D, N in 3D], σ the total stress (the effective stress less the pore pressure), and
        torque[p] += (x₀ − c) × A σ n its moment about the plate's centre c [N m/m, N m]."""
        i = wp.tid()
        p = plate_of[i]
        if p < 0:
            return
        a = particle[i]
        s = stress[a]
        if wp.static(pore_water):
            s = s - pore_pressure_at(a, q[a], pore, material, gravity) * wp.identity(3, dtype=real)
        normal = vec3(real(0.0), real(0.0), real(0.0))
        normal[planes.axis[p]] = planes.sign[p]
        passed = area[i] * (s * normal)
        wp.atomic_add(force, p, passed)
        wp.atomic_add(torque, p, wp.cross(origin[a] - planes.plate_centre[p], passed))

    @wp.kernel(enable_backward=False, module="unique")
    def plate_step(
        planes: Planes,
        mass: wp.array(dtype=real),
        force: wp.array(dtype=vec3),
        inertia: wp.array(dtype=vec3),
        spin_axes: wp.array(dtype=vec3),
        moment: wp.array(dtype=vec3),
        torque: wp.array(dtype=vec3),
        damping: real,
        dt: real,
        v_in: wp.array(dtype=vec3),
        v_out: wp.array(dtype=vec3),
        spin_in: wp.array(dtype=vec3),
        spin_out: wp.array(dtype=vec3),
        rotation_in: wp.array(dtype=vec3),
        rotation_out: wp.array(dtype=vec3),
    ):
        """The velocity of the plate on plane p over the step [m/s]: a force-driven plate is accelerated by
        its force F f(t) less the force it passes into the soil, over the mass it moves (a smooth plate
        along its normal only; an equilibrium phase's local damping α on each component); a
        velocity-driven one keeps its prescribed velocity. A plate free to rotate spins about its centre by
        its moment balance, M f(t) less the soil's, over its particles' moment of inertia, likewise damped;
        its rotation [rad] is the spin's integral."""
        p = wp.tid()
        v = v_in[p]
        spin = spin_in[p]
        if planes.plate_contact[p] != PLATE_NONE and planes.plate_drive[p] == PLATE_FORCE:
            acc = (planes.plate_vector[p] * planes.factor[p] - force[p]) / mass[p]
            if planes.plate_contact[p] == PLATE_SMOOTH:
                m = planes.axis[p]
                normal_acc = acc[m]
                acc = vec3(real(0.0), real(0.0), real(0.0))
                acc[m] = normal_acc
            v = v + dt * damped(acc, v, damping)
        elif planes.plate_contact[p] != PLATE_NONE:
            v = planes.plate_vector[p] * planes.factor[p]
        spin_acc = moment[p] * planes.factor[p] - torque[p]
        for k in range(3):
            spin_acc[k] = spin_axes[p][k] * spin_acc[k] / inertia[p][k]
        spin = spin + dt * damped(spin_acc, spin, damping)
        v_out[p] = v
        spin_out[p] = spin
        rotation_out[p] = rotation_in[p] + dt * spin
        planes.plate_velocity[p] = v
        planes.plate_spin[p] = spin

    return plate_forces, plate_step


class Plates:
    """The force balance of a model's rigid plates: :meth:`step` moves a force-driven plate's velocity
    over a step, :meth:`forces` is the force each passes into the soil."""

    def __init__(self, model, boundaries):
        self.model, self.boundaries = model, boundaries
        m, real = model, model.spec.real
        self.force = wp.zeros(max(m.plane_count, 1), dtype=m.spec.vec3, device=m.device)
        self.torque = wp.zeros_like(self.force)
        npr = np.float64 if m.spec.precision == "float64" else np.float32
        self.inertia, self.spin_axes, self.moment = (wp.array(getattr(m.plates, name).astype(npr), dtype=m.spec.vec3,
                                                              device=m.device) for name in ("inertia", "spin_axes",
                                                                                            "moment"))  # fmt: skip
        self.mass = wp.array(np.maximum(m.plates.mass, 1e-300), dtype=real, device=m.device)
        self.plate_of = boundaries.plate_of
        self.area = wp.array(m.plates.area, dtype=real, device=m.device)
        particles = m.constraint_particle.numpy()
        held = [particles[m.plates.plate_of == p] for p in range(m.plane_count)]
        ends = np.cumsum([0, *map(len, held)])
        self._held_ranges = {p: (int(ends[p]), int(ends[p + 1])) for p in range(m.plane_count) if len(held[p])}
        rows = np.concatenate([np.zeros(0, np.int32), *held]).astype(np.int32)
        self._held = wp.array(rows, dtype=wp.int32, device=m.device)
        """The particles each plate holds, plate after plate (``_held_ranges``), and their start positions."""
        self._held_x0 = m.particle_x0[rows]

    def _sum_forces(self, state, pore) -> None:
        m, b = self.model, self.boundaries
        self.force.zero_()
        self.torque.zero_()
        plate_forces, _ = _kernels(m.spec)
        launch(plate_forces, m.constraint_count,
               [m.constraint_particle, self.plate_of, self.area, b.planes, *b.water_args(m.particle_material, pore),
                state.particle_q, state.particle_stress, m.particle_origin, self.force, self.torque],
               m.device)  # fmt: skip

    def step(self, si, so, pore, dt: float, damping: float) -> None:
        """The plates' velocities over the step from ``si`` into ``so`` (``pore``: the excess pore pressure
        ``si``'s total stress carries; ``damping``: an equilibrium phase's α, else 0)."""
        m = self.model
        self._sum_forces(si, pore)
        _, plate_step = _kernels(m.spec)
        real = m.spec.real
        launch(plate_step, m.plane_count,
               [self.boundaries.planes, self.mass, self.force, self.inertia, self.spin_axes, self.moment, self.torque,
                real(damping), real(dt), si.plate_velocity, so.plate_velocity, si.plate_spin, so.plate_spin,
                si.plate_rotation, so.plate_rotation], m.device)  # fmt: skip

    def forces(self, state, pore) -> np.ndarray:
        """(P,3) the force each plane's plate passes into the soil in ``state`` [N/m in 2D, N in 3D]."""
        self._sum_forces(state, pore)
        return self.force.numpy()[: self.model.plane_count].astype(np.float64)

    def series(self, state, pore) -> dict[str, float]:
        """Each plate's force into the soil (:meth:`forces`) and displacement since the run's start [m], the
        mean of its particles', by component of the scene's axes (``<plate>_force_y`` and so on), and a plate
        free to rotate its rotation [rad] about each axis it spins about (``<plate>_rotation_z``)."""
        m = self.model
        forces = self.forces(state, pore)
        moved = wp.indexedarray(state.particle_q, [self._held]).numpy().astype(np.float64) - self._held_x0
        rotation = state.plate_rotation.numpy().astype(np.float64)
        out = {}
        for p, (start, end) in self._held_ranges.items():
            name = m.plane_names[p]
            displacement = moved[start:end].mean(axis=0)
            for axis in used_axes(m.spec.dim):
                out[f"{name}_force_{AXES[axis]}"] = float(forces[p, axis])
                out[f"{name}_displacement_{AXES[axis]}"] = float(displacement[axis])
            for axis in np.nonzero(m.plates.spin_axes[p])[0]:
                out[f"{name}_rotation_{AXES[axis]}"] = float(rotation[p, axis])
        return out
