"""Rigid regions: the particles and virtual points that start inside a "velocity" or "force" load's
region move together as one rigid body in translation (a footing, a piston; docs/method.md, *Boundaries*).
"""

import functools

import numpy as np
import warp as wp

from warpsph.launching import launch
from warpsph.sph.spec import Spec
from warpsph.stages.energy import RIGID, ledger_columns

MODE_VELOCITY, MODE_FORCE = 0, 1
RIGID_LOAD_KINDS = {"velocity": MODE_VELOCITY, "force": MODE_FORCE}


@functools.cache
def _kernels(spec: Spec):
    column = ledger_columns(spec)  # the energy ledger's column of each channel
    real, vec3, mat33 = spec.real, spec.vec3, spec.mat33

    @wp.kernel(enable_backward=False, module="unique")
    def sum_momentum(
        particle: wp.array(dtype=wp.int32),
        load: wp.array(dtype=wp.int32),
        mass: wp.array(dtype=real),
        v: wp.array(dtype=vec3),
        momentum: wp.array(dtype=vec3),
    ):
        """momentum[k] += m v of every particle of region k [kg m/s]."""
        i = wp.tid()
        a = particle[i]
        wp.atomic_add(momentum, load[i], mass[a] * v[a])

    @wp.kernel(enable_backward=False, module="unique")
    def region_velocity(
        mode: wp.array(dtype=wp.int32),
        velocity: wp.array(dtype=vec3),
        force: wp.array(dtype=vec3),
        factor: wp.array(dtype=real),
        total_mass: wp.array(dtype=real),
        momentum: wp.array(dtype=vec3),
        impulse_dt: real,
        v_rigid: wp.array(dtype=vec3),
    ):
        """The rigid velocity of region k [m/s]: prescribed, or from its free momentum and the
        impulse impulse_dt F f(t) of its applied force."""
        k = wp.tid()
        if mode[k] == MODE_VELOCITY:
            v_rigid[k] = velocity[k] * factor[k]
        else:
            v_rigid[k] = (momentum[k] + impulse_dt * factor[k] * force[k]) / total_mass[k]

    @wp.kernel(enable_backward=False, module="unique")
    def assign(
        particle: wp.array(dtype=wp.int32),
        load: wp.array(dtype=wp.int32),
        mass: wp.array(dtype=real),
        constrained: wp.array(dtype=mat33),
        v_rigid: wp.array(dtype=vec3),
        v: wp.array(dtype=vec3),
        impulse: wp.array(dtype=vec3),
        ledger: wp.array2d(dtype=wp.float64),
    ):
        """Set the constrained part of the region's particle velocities (all of it for a rough
        contact, the drive direction's for a smooth one) to the rigid velocity, summing the drive's
        impulse [N s] and entering the kinetic energy it gives the particle in the energy ledger."""
        i = wp.tid()
        a = particle[i]
        k = load[i]
        dv = constrained[k] * (v_rigid[k] - v[a])
        wp.atomic_add(impulse, k, mass[a] * dv)
        v_new = v[a] + dv
        given = real(0.5) * mass[a] * (wp.dot(v_new, v_new) - wp.dot(v[a], v[a]))
        ledger[a, wp.static(column[RIGID])] += wp.float64(given)
        v[a] = v_new

    @wp.kernel(enable_backward=False, module="unique")
    def start_velocity(first: wp.array(dtype=wp.int32), v: wp.array(dtype=vec3), v_start: wp.array(dtype=vec3)):
        """The rigid velocity at the step's start: that of the region's first particle (all alike)."""
        k = wp.tid()
        v_start[k] = v[first[k]]

    @wp.kernel(enable_backward=False, module="unique")
    def assign_virtual(
        point: wp.array(dtype=wp.int32),
        load: wp.array(dtype=wp.int32),
        mode: wp.array(dtype=wp.int32),
        velocity: wp.array(dtype=vec3),
        factor_half: wp.array(dtype=real),
        v_start: wp.array(dtype=vec3),
        constrained: wp.array(dtype=mat33),
        v: wp.array(dtype=vec3),
    ):
        """Half-step velocity of the regions' virtual points (its constrained part): v̄ f(t + Δt/2)
        if prescribed, else the rigid velocity at the step's start."""
        i = wp.tid()
        k = load[i]
        target = v_start[k]
        if mode[k] == MODE_VELOCITY:
            target = velocity[k] * factor_half[k]
        c = point[i]
        v[c] = v[c] + constrained[k] * (target - v[c])

    return sum_momentum, region_velocity, assign, start_velocity, assign_virtual


def _constrained(load) -> np.ndarray:
    """Projector onto the velocity components a rigid load prescribes: all (rough contact) or the drive
    direction's, that of its velocity or force (smooth)."""
    if load.contact == "rough":
        return np.eye(3)
    drive = np.asarray(load.velocity if load.kind == "velocity" else load.force, dtype=float)
    d = drive / np.linalg.norm(drive)
    return np.outer(d, d)


class RigidRegions:
    """The rigid regions of a model: their velocities, and the contact force each exerts."""

    def __init__(self, model, ledger: wp.array):
        self.model, self.ledger = model, ledger
        """The energy ledger (:mod:`warpsph.stages.energy`) the drives' energy is entered in."""
        m, real, vec3 = model, model.spec.real, model.spec.vec3
        loads = [ld for ld in model.scene.loads if ld.kind in RIGID_LOAD_KINDS]
        self.names = [ld.name for ld in loads]
        self.functions = [ld.time_function for ld in loads]
        k, dev = max(len(loads), 1), model.device
        self.mode = wp.array([RIGID_LOAD_KINDS[ld.kind] for ld in loads] or [0], dtype=wp.int32, device=dev)
        self.velocity = wp.array([ld.velocity for ld in loads] or [(0.0,) * 3], dtype=vec3, device=dev)
        self.force = wp.array([ld.force for ld in loads] or [(0.0,) * 3], dtype=vec3, device=dev)
        self.constrained = wp.array([_constrained(ld) for ld in loads] or [np.eye(3)], dtype=model.spec.mat33,
                                    device=dev)  # fmt: skip
        """(K,) projector onto the velocity a region makes rigid: I (rough), d ⊗ d (smooth)."""
        mass = np.zeros(k)
        np.add.at(mass, m.region_load.numpy(), m.particle_mass.numpy()[m.region_particle.numpy()])
        self.mass = mass
        """(K,) mass of each region's real particles [kg per m in 2D]."""
        self.total_mass = wp.array(np.maximum(mass, 1e-300), dtype=real, device=dev)
        self.factor = wp.zeros(k, dtype=real, device=dev)
        self.factor_half = wp.zeros(k, dtype=real, device=dev)
        first = np.zeros(k, dtype=np.int32)
        for index in range(len(loads)):
            members = m.region_particle.numpy()[m.region_load.numpy() == index]
            first[index] = members[0] if len(members) else 0
        self.first = wp.array(first, dtype=wp.int32, device=dev)
        self.momentum = wp.zeros(k, dtype=vec3, device=dev)
        self.impulse = wp.zeros(k, dtype=vec3, device=dev)
        self.v_rigid = wp.zeros(k, dtype=vec3, device=dev)
        self.v_start = wp.zeros(k, dtype=vec3, device=dev)
        self.dt = 1.0
        self._applied = False

    @property
    def count(self) -> int:
        return len(self.names)

    def begin_step(self, v, t: float, dt: float) -> None:
        """Start a step at time t [s] of size dt [s] from the particle velocities ``v``: the load
        factors, the rigid velocities at the start, the drive's impulse zeroed."""
        self.dt = dt
        if not self.count:
            return
        m = self.model
        self.factor.assign(np.array([f(t + dt) for f in self.functions]))
        self.factor_half.assign(np.array([f(t + 0.5 * dt) for f in self.functions]))
        *_, start_velocity, _ = _kernels(m.spec)
        launch(start_velocity, self.count, [self.first, v, self.v_start], m.device)
        self.impulse.zero_()
        self._applied = False

    def prescribe_virtual(self, v_half) -> None:
        """Half-step velocity of the regions' virtual points."""
        m = self.model
        if not self.count:
            return
        *_, assign_virtual = _kernels(m.spec)
        launch(assign_virtual, len(m.region_virtual),
               [m.region_virtual, m.region_virtual_load, self.mode, self.velocity, self.factor_half, self.v_start,
                self.constrained, v_half], m.device)  # fmt: skip

    def prescribe(self, v) -> None:
        """Make the regions' particles in ``v`` rigid (after a velocity update of the step)."""
        m = self.model
        if not self.count:
            return
        sum_momentum, region_velocity, assign, *_ = _kernels(m.spec)
        self.momentum.zero_()
        launch(sum_momentum, m.region_count, [m.region_particle, m.region_load, m.particle_mass, v, self.momentum],
               m.device)  # fmt: skip
        impulse_dt = 0.0 if self._applied else self.dt
        launch(region_velocity, self.count,
               [self.mode, self.velocity, self.force, self.factor, self.total_mass, self.momentum,
                m.spec.real(impulse_dt), self.v_rigid], m.device)  # fmt: skip
        self._applied = True
        launch(assign, m.region_count, [m.region_particle, m.region_load, m.particle_mass, self.constrained,
                                        self.v_rigid, v, self.impulse, self.ledger], m.device)  # fmt: skip

    def contact_forces(self) -> np.ndarray:
        """(K,3) force each region exerts on the rest of the body over the last step [N/m or N]."""
        gravity = np.asarray(self.model.gravity, dtype=float)
        # only the constrained part is the region's (a smooth region's first point slides across)
        dv = np.einsum("kij,kj->ki", self.constrained.numpy().astype(float),
                       self.v_rigid.numpy().astype(float) - self.v_start.numpy().astype(float))
        impulse = self.impulse.numpy().astype(float)
        return self.mass[:, None] * gravity + (impulse - self.mass[:, None] * dv) / self.dt
