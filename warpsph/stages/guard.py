"""Run guard: finds the first particle whose fields (position, velocity, stress, density and, with pore
water, pore pressure) are not finite, whose density is not positive or whose speed is too high, and
the first virtual point whose position or density is not finite or whose density is not positive."""

import functools
import math
from typing import NamedTuple

import numpy as np
import warp as wp

from warpsph.launching import launch
from warpsph.model import Model, State
from warpsph.sph.spec import Spec

NO_PARTICLE = 2**31 - 1
LARGEST_SPEED = 1.0e30
"""Speed [m/s] beyond which a particle is bad whatever the scene's speed limit (also with none: a
blow-up on its way to overflow is caught before it reaches float32's 3.4e38)."""


NOT_FINITE = ("position", "velocity", "stress", "density", "pore_pressure")
"""The fields a bad particle's snapshot marks as not finite, one bit each in this order."""


class Flagged(NamedTuple):
    """What the guard found, as it was at the step it found it: a bad particle (its index, position
    [m], speed [m/s], density [kg/m³] and the fields of ``NOT_FINITE`` that were not finite) or, where no
    particle was, a bad virtual point (its index, position and density)."""

    step: int
    particle: int | None
    point: int | None
    position: np.ndarray
    speed: float
    density: float
    not_finite: tuple[str, ...]


@functools.cache
def _kernel(spec: Spec):
    real, vec3, mat33 = spec.real, spec.vec3, spec.mat33
    pore_water = spec.effects.pore_water

    @wp.kernel(enable_backward=False, module="unique")
    def find_bad(
        step: int,
        q: wp.array(dtype=vec3),
        v: wp.array(dtype=vec3),
        stress: wp.array(dtype=mat33),
        density: wp.array(dtype=real),
        pore_pressure: wp.array(dtype=wp.float64),
        speed_limit: real,
        flags: wp.array(dtype=wp.int32),
    ):
        """Slot 2: the first step a particle was bad; slot 0: the lowest bad particle of that step."""
        a = wp.tid()
        if flags[2] < step:
            return
        ok = wp.isfinite(q[a]) and wp.isfinite(v[a]) and wp.isfinite(stress[a]) and density[a] > real(0.0)
        ok = ok and wp.isfinite(density[a])
        if wp.static(pore_water):
            ok = ok and wp.isfinite(pore_pressure[a])
        if not ok or wp.length(v[a]) > speed_limit:
            wp.atomic_min(flags, 2, step)
            wp.atomic_min(flags, 0, a)

    @wp.kernel(enable_backward=False, module="unique")
    def find_bad_virtual(step: int, q: wp.array(dtype=vec3), density: wp.array(dtype=real),
                         flags: wp.array(dtype=wp.int32)):  # fmt: skip
        """Slot 3: the first step a virtual point was bad; slot 1: the lowest bad point of that step."""
        i = wp.tid()
        if flags[3] < step:
            return
        if not (wp.isfinite(q[i]) and wp.isfinite(density[i]) and density[i] > real(0.0)):
            wp.atomic_min(flags, 3, step)
            wp.atomic_min(flags, 1, i)

    @wp.kernel(enable_backward=False, module="unique")
    def snapshot(
        step: int,
        q: wp.array(dtype=vec3),
        v: wp.array(dtype=vec3),
        stress: wp.array(dtype=mat33),
        density: wp.array(dtype=real),
        pore_pressure: wp.array(dtype=wp.float64),
        virtual_q: wp.array(dtype=vec3),
        virtual_density: wp.array(dtype=real),
        flags: wp.array(dtype=wp.int32),
        position: wp.array(dtype=wp.float64),
        marks: wp.array(dtype=wp.int32),
    ):
        """Keep what the messages name of the bad particle (or point) found at ``step``."""
        if flags[2] == step and marks[1] == 0:
            a = flags[0]
            for k in range(3):
                position[k] = wp.float64(q[a][k])
            position[3] = wp.float64(wp.length(v[a]))
            position[4] = wp.float64(density[a])
            m = int(0)
            if not wp.isfinite(q[a]):
                m = m | 1
            if not wp.isfinite(v[a]):
                m = m | 2
            if not wp.isfinite(stress[a]):
                m = m | 4
            if not wp.isfinite(density[a]):
                m = m | 8
            if wp.static(pore_water):
                if not wp.isfinite(pore_pressure[a]):
                    m = m | 16
            marks[0] = m
            marks[1] = 1
        if flags[3] == step and flags[2] > step and marks[1] == 0:
            i = flags[1]
            for k in range(3):
                position[k] = wp.float64(virtual_q[i][k])
            position[4] = wp.float64(virtual_density[i])
            marks[1] = 2

    return find_bad, find_bad_virtual, snapshot


class Guard:
    """Marks, on the device and with no read, the first step at which a particle or a virtual point
    went bad and keeps what it was then (:meth:`mark`); :meth:`read` reads it, one wait for the device,
    at the run's output cadence."""

    def __init__(self, model: Model, speed_limit: float):
        self.model = model
        self.speed_limit = min(speed_limit, LARGEST_SPEED)
        self.flags = wp.zeros(4, dtype=wp.int32, device=model.device)
        self.position = wp.zeros(5, dtype=wp.float64, device=model.device)
        """The bad point's position [m], then the particle's speed [m/s] and density [kg/m³]."""
        self.marks = wp.zeros(2, dtype=wp.int32, device=model.device)
        """The ``NOT_FINITE`` bits of the bad particle; 1 once a particle is kept, 2 a virtual point."""
        self._none = wp.zeros(1, dtype=model.spec.vec3, device=model.device)
        self._no_density = wp.zeros(1, dtype=model.spec.real, device=model.device)
        self.clear()

    def clear(self) -> None:
        self.flags.fill_(NO_PARTICLE)
        self.marks.zero_()

    def mark(self, state: State, step: int) -> None:
        """Check ``state``, the state after step ``step``, on the device."""
        m = self.model
        find_bad, find_bad_virtual, snapshot = _kernel(m.spec)
        launch(find_bad, m.particle_count,
               [step, state.particle_q, state.particle_v, state.particle_stress, state.particle_density,
                state.particle_pore_pressure, m.spec.real(self.speed_limit), self.flags],
               m.device)  # fmt: skip
        virtual = state.virtual_q is not None
        if virtual:
            launch(find_bad_virtual, m.virtual_count, [step, state.virtual_q, state.virtual_density, self.flags],
                   m.device)  # fmt: skip
        launch(snapshot, 1,
               [step, state.particle_q, state.particle_v, state.particle_stress, state.particle_density,
                state.particle_pore_pressure, state.virtual_q if virtual else self._none,
                state.virtual_density if virtual else self._no_density, self.flags, self.position, self.marks],
               m.device)  # fmt: skip

    def read(self) -> Flagged | None:
        """The first bad particle or point marked since :meth:`clear`, None where there is none."""
        particle, point, particle_step, point_step = (int(f) for f in self.flags.numpy())
        if particle_step == NO_PARTICLE and point_step == NO_PARTICLE:
            return None
        kept = self.position.numpy()
        bits = int(self.marks.numpy()[0])
        if particle_step <= point_step:
            not_finite = tuple(name for k, name in enumerate(NOT_FINITE) if bits & (1 << k))
            return Flagged(particle_step, particle, None, kept[:3].copy(), float(kept[3]), float(kept[4]), not_finite)
        return Flagged(point_step, None, point, kept[:3].copy(), math.nan, float(kept[4]), ())

    def find(self, state: State) -> tuple[int | None, int | None]:
        """(the lowest index of a bad owned particle of ``state``, that of a bad owned virtual point), each
        None where there is none; one read."""
        self.clear()
        self.mark(state, 0)
        flagged = self.read()
        self.clear()
        if flagged is None:
            return None, None
        return flagged.particle, flagged.point
