"""Run guard: finds the first particle whose fields (position, velocity, stress, density and, with pore
water, pore pressure) are not finite, whose density is not positive or whose speed is too high, and
the first virtual point whose position or density is not finite or whose density is not positive."""

import functools

import warp as wp

from warpsph.launching import launch
from warpsph.model import Model, State
from warpsph.sph.spec import Spec

NO_PARTICLE = 2**31 - 1
LARGEST_SPEED = 1.0e30
"""Speed [m/s] beyond which a particle is bad whatever the scene's speed limit (also with none: a
blow-up on its way to overflow is caught before it reaches float32's 3.4e38)."""


@functools.cache
def _kernel(spec: Spec):
    real, vec3, mat33 = spec.real, spec.vec3, spec.mat33
    pore_water = spec.effects.pore_water

    @wp.kernel(enable_backward=False, module="unique")
    def find_bad(
        q: wp.array(dtype=vec3),
        v: wp.array(dtype=vec3),
        stress: wp.array(dtype=mat33),
        density: wp.array(dtype=real),
        pore_pressure: wp.array(dtype=wp.float64),
        speed_limit: real,
        flags: wp.array(dtype=wp.int32),
    ):
        a = wp.tid()
        ok = wp.isfinite(q[a]) and wp.isfinite(v[a]) and wp.isfinite(stress[a]) and density[a] > real(0.0)
        ok = ok and wp.isfinite(density[a])
        if wp.static(pore_water):
            ok = ok and wp.isfinite(pore_pressure[a])
        if not ok or wp.length(v[a]) > speed_limit:
            wp.atomic_min(flags, 0, a)  # slot 0: particles

    @wp.kernel(enable_backward=False, module="unique")
    def find_bad_virtual(q: wp.array(dtype=vec3), density: wp.array(dtype=real), flags: wp.array(dtype=wp.int32)):
        i = wp.tid()
        if not (wp.isfinite(q[i]) and wp.isfinite(density[i]) and density[i] > real(0.0)):
            wp.atomic_min(flags, 1, i)  # slot 1: virtual points

    return find_bad, find_bad_virtual


class Guard:
    """``find(state)`` returns (the lowest index of a bad owned particle, that of a bad owned virtual
    point), each None where there is none; one read from the device for both."""

    def __init__(self, model: Model, speed_limit: float):
        self.model = model
        self.speed_limit = min(speed_limit, LARGEST_SPEED)
        self.flags = wp.zeros(2, dtype=wp.int32, device=model.device)

    def find(self, state: State) -> tuple[int | None, int | None]:
        m = self.model
        find_bad, find_bad_virtual = _kernel(m.spec)
        self.flags.fill_(NO_PARTICLE)
        launch(find_bad, m.particle_count,
               [state.particle_q, state.particle_v, state.particle_stress, state.particle_density,
                state.particle_pore_pressure, m.spec.real(self.speed_limit), self.flags],
               m.device)  # fmt: skip
        if state.virtual_q is not None:
            launch(find_bad_virtual, m.virtual_count, [state.virtual_q, state.virtual_density, self.flags], m.device)
        particle, point = (int(f) for f in self.flags.numpy())
        return (None if particle == NO_PARTICLE else particle), (None if point == NO_PARTICLE else point)
