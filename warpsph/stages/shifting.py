"""Particle shifting (large deformation, two-set scheme): both point sets kept near-uniform, each shifted
down the gradient of its own concentration (docs/method.md, *Large deformation*).
"""

import functools

import warp as wp

from warpsph.launching import launch, launch_rows
from warpsph.sph.kernels import smoothing_functions
from warpsph.sph.operators import used_vectors
from warpsph.sph.spec import Spec


@functools.cache
def shifting_kernels(spec: Spec):
    """``(shift, add)`` kernels and the ``scaled`` function for ``spec``."""
    real, vec3 = spec.real, spec.vec3
    _W, grad_W = smoothing_functions(spec)
    full_vector = used_vectors(spec)[1]
    moves = vec3(*map(real, spec.axis_mask))

    @wp.func
    def scaled(direction: vec3, coefficient: real, h: real, strain: real):
        """The shift A Δt‖d‖ · (−h²∇C) of a point whose strain increment is Δt‖d‖ = ``strain``, at
        most h Δt‖d‖ long (no farther than its neighbours moved relative to it in the step) [m]."""
        dx = (coefficient * strain) * direction
        length = wp.length(dx)
        if length > h * strain:
            dx = dx * (h * strain / length)
        return dx

    @wp.kernel(enable_backward=False, module="unique")
    def shift(
        first: int,
        h: real,
        dt: real,
        coefficient: real,
        surface_threshold: real,
        offsets: wp.array(dtype=wp.int32),
        nbr: wp.array(dtype=wp.int32),
        q: wp.array(dtype=vec3),
        mass: wp.array(dtype=real),
        density: wp.array(dtype=real),
        with_rate: int,
        rate: wp.array(dtype=real),
        fit_e: wp.array(dtype=spec.used_vector),
        fit_lambda: wp.array(dtype=real),
        out: wp.array(dtype=vec3),
    ):
        """out[a] = −h² ∇C at point a, its normal part removed in the surface band [m]; with_rate:
        the shift itself, times A Δt ‖d‖ and at most h Δt ‖d‖ long."""
        a = first + wp.tid()
        x = q[a]
        grad_c = vec3(real(0.0), real(0.0), real(0.0))
        for k in range(offsets[a], offsets[a + 1]):
            b = nbr[k]
            grad_c += (mass[b] / density[b]) * grad_W(x - q[b], h)
        dx = -(h * h) * grad_c
        e = full_vector(fit_e[a])
        if fit_lambda[a] < surface_threshold and wp.length(e) > real(0.0):
            n = wp.normalize(e)
            dx = dx - wp.dot(dx, n) * n
        dx = wp.cw_mul(dx, moves)
        if with_rate != 0:
            dx = scaled(dx, coefficient, h, dt * rate[a])
        out[a] = dx

    @wp.kernel(enable_backward=False, module="unique")
    def add(dx: wp.array(dtype=vec3), q: wp.array(dtype=vec3)):
        i = wp.tid()
        q[i] = q[i] + dx[i]

    return shift, add, scaled


def compute_shift(model, neighbours, q, n_owned: int, mass, density, rate, fits, out, dt: float) -> None:
    """Shift ``out[:n_owned]`` [m] of the points ``q`` down their own concentration gradient
    (``neighbours``: the same set's list, ghosts included; ``fits``: the points' FitData; ``rate``:
    their ‖d‖ [1/s], or None for the direction −h²∇C alone, which the full step scales by each real
    particle's own rate)."""
    shift = shifting_kernels(model.spec)[0]
    real = model.spec.real
    sim = model.scene.simulation
    launch_rows(shift, n_owned,
                [real(model.h), real(dt), real(sim.particle_shifting), real(sim.free_surface_threshold),
                 neighbours.offsets, neighbours.indices, q, mass, density, int(rate is not None), rate, fits.e,
                 fits.smallest_eigenvalue,
                 out], model.device)  # fmt: skip


def apply_shift(model, n: int, shift, q) -> None:
    """``q[:n] += shift[:n]`` [m]."""
    launch(shifting_kernels(model.spec)[1], n, [shift, q], model.device)
