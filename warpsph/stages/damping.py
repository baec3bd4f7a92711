"""Local (non-viscous) damping of equilibrium phases, and the unbalanced force it drives to zero
(docs/method.md, *Phases*).
"""

import functools
from typing import Any

import numpy as np
import warp as wp

from warpsph.launching import launch
from warpsph.model import PLANE_VELOCITY, Model
from warpsph.sph.spec import Spec
from warpsph.stages.energy import DAMPING, ledger_columns


EQUILIBRIUM_VELOCITY_FILTER = 0.5
"""Fraction β [-] of the real particles' velocity that their virtual points do not see removed each step
of an equilibrium phase (the largest ``simulation.velocity_filter`` accepts). Measured on an elastic 2:1
slope under gravity (Δx = 0.2 m, α = 0.8): with β = 0 the mode grows along the toe's free surface and the
unbalanced-force ratio stalls at 7e-3 before the run blows up; β = 0.1 stalls at 1.2e-5; β = 0.5 reaches
1e-5 in 0.7 s of damped time."""


@wp.func
def damped(a: Any, v: Any, alpha: Any):
    """Local damping's acceleration, each component a_k − α |a_k| sign(v_k), against the velocity v (the
    particles' here, a rigid plate's in :mod:`warpsph.stages.plates`)."""
    out = a
    for k in range(3):
        out[k] = a[k] - alpha * wp.abs(a[k]) * wp.sign(v[k])
    return out


@functools.cache
def damping_kernel(spec: Spec):
    column = ledger_columns(spec)  # the energy ledger's column of each channel
    real, vec3 = spec.real, spec.vec3

    @wp.kernel(enable_backward=False, module="unique")
    def local_damping(
        alpha: real,
        dt: real,
        mass: wp.array(dtype=real),
        free: wp.array(dtype=wp.int32),
        v_in: wp.array(dtype=vec3),
        v_out: wp.array(dtype=vec3),
        sums: wp.array(dtype=wp.float64),
        ledger: wp.array2d(dtype=wp.float64),
    ):
        i = wp.tid()
        a = (v_out[i] - v_in[i]) / dt
        if free[i] != 0:
            undamped = v_out[i]
            v_out[i] = v_in[i] + dt * damped(a, v_in[i], alpha)
            removed = real(0.5) * mass[i] * (wp.dot(undamped, undamped) - wp.dot(v_out[i], v_out[i]))
            ledger[i, wp.static(column[DAMPING])] += wp.float64(removed)
        wp.atomic_add(sums, 0, wp.float64(mass[i] * wp.length(a)))
        wp.atomic_add(sums, 1, wp.float64(real(0.5) * mass[i] * wp.dot(v_out[i], v_out[i])))

    return local_damping


def velocity_prescribed(model: Model) -> np.ndarray:
    """(N,) bool: owned particles on a velocity plane, under a rigid plate or in a rigid "velocity" load's region."""
    out = np.zeros(model.particle_count, dtype=bool)
    kinds = model.plane_kind.numpy()
    planes = model.constraint_planes.numpy().reshape(-1, 3)
    on_velocity_plane = np.any((planes >= 0) & (kinds[np.maximum(planes, 0)] == PLANE_VELOCITY), axis=1)
    on_velocity_plane |= model.plates.plate_of >= 0  # a plate's particles move with it (its force balance damped)
    out[model.constraint_particle.numpy()[on_velocity_plane]] = True
    rigid = [ld for ld in model.scene.loads if ld.kind in ("velocity", "force")]
    velocity_loads = np.array([ld.kind == "velocity" for ld in rigid] or [False])
    members, load = model.region_particle.numpy(), model.region_load.numpy()
    out[members[velocity_loads[load]]] = True
    return out


class LocalDamping:
    """The damping pass of an equilibrium phase: ``run`` after the step's prescribed values; the sums
    accumulate over the steps between two :meth:`read` calls."""

    def __init__(self, model: Model, alpha: float, ledger: wp.array):
        self.model, self.alpha, self.ledger = model, alpha, ledger
        dev = model.device
        self.free = wp.array((~velocity_prescribed(model)).astype(np.int32), dtype=wp.int32, device=dev)
        self.sums = wp.zeros(2, dtype=wp.float64, device=dev)
        self.steps = 0

    def run(self, si, so, dt: float) -> None:
        m = self.model
        launch(damping_kernel(m.spec), m.particle_count,
               [m.spec.real(self.alpha), m.spec.real(dt), m.particle_mass, self.free, si.particle_v, so.particle_v,
                self.sums, self.ledger], m.device)  # fmt: skip
        self.steps += 1

    def read(self) -> tuple[float, float]:
        """(Σ m‖a‖ [N or N/m], ½ Σ m v² [J or J/m]), each the mean over the steps since the last read."""
        sums = self.sums.numpy() / max(self.steps, 1)
        self.sums.zero_()
        self.steps = 0
        return float(sums[0]), float(sums[1])
