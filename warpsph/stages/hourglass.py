"""Hourglass control of the two-set step: a pairwise damping of the part of the real particles' velocity
field that their own corrected linear fit does not hold (docs/method.md, *Hourglass control*).

Each real particle's velocity gradient L_a is the corrected linear fit over its real neighbours, exact
for every linear field at every particle, surfaces and corners included. A pair's residual is its
relative velocity less what the pair's mean gradient predicts, r_ab = v_b − v_a − ½(L_a + L_b)ᵀ x_ab;
its component along the pair is damped with the stiffness-scaled viscosity α ρ c h.
"""

import functools

import warp as wp

from warpsph.launching import launch_rows
from warpsph.model import Model, State
from warpsph.sph.kernels import smoothing_functions
from warpsph.sph.neighbours import NeighbourList
from warpsph.sph.operators import operator_functions, used_axes_algebra
from warpsph.sph.spec import Spec
from warpsph.stages.corrections import FitData, compute_fit_data
from warpsph.stages.energy import STABILISATION


@functools.cache
def _kernels(spec: Spec):
    real, vec3, mat33 = spec.real, spec.vec3, spec.mat33
    _fit, fit_weights, _unused, _eig = operator_functions(spec)
    _W, grad_W = smoothing_functions(spec)
    outer = used_axes_algebra(spec)[0]
    zero, half = real(0.0), real(0.5)

    @wp.kernel(enable_backward=False, module="unique")
    def velocity_gradient(
        first: int, h: real, offsets: wp.array(dtype=wp.int32), nbr: wp.array(dtype=wp.int32),
        q: wp.array(dtype=vec3), v: wp.array(dtype=vec3), volume: wp.array(dtype=real),
        fit_c: wp.array(dtype=vec3), fit_inv_den: wp.array(dtype=real), fit_minv: wp.array(dtype=mat33),
        fit_e: wp.array(dtype=vec3), gradient: wp.array(dtype=mat33),
    ):  # fmt: skip
        """G_a = ∇v at the real particle a (G_ij = ∂_i v_j) from the corrected fit over its real
        neighbours (itself excluded)."""
        a = first + wp.tid()
        x = q[a]
        fitted = vec3(zero, zero, zero)
        G = mat33(zero)
        for k in range(offsets[a], offsets[a + 1]):
            b = nbr[k]
            psi, phi = fit_weights(q[b] - x, h, fit_c[a], fit_inv_den[a], fit_minv[a])
            fitted += (volume[b] * psi) * v[b]
            G += outer(volume[b] * phi, v[b])
        gradient[a] = G - outer(fit_e[a], fitted)

    @wp.kernel(enable_backward=False, module="unique")
    def damp_residual(
        first: int, h: real, dt: real, alpha: real, n_owned: int, offsets: wp.array(dtype=wp.int32),
        nbr: wp.array(dtype=wp.int32), q: wp.array(dtype=vec3), v: wp.array(dtype=vec3),
        volume: wp.array(dtype=real), density: wp.array(dtype=real), mass: wp.array(dtype=real),
        material: wp.array(dtype=wp.int32), wave_speed: wp.array(dtype=real), gradient: wp.array(dtype=mat33),
        v_out: wp.array(dtype=vec3), ledger: wp.array2d(dtype=wp.float64),
    ):  # fmt: skip
        """v_out[a] += Δt/m_a Σ_b α ρ̄ c h V_a V_b (F_ab/r) (r_ab·e) e, F_ab/r = −∇W·x_ab/r² ≥ 0; a ghost
        neighbour's gradient is taken as a's own. The kinetic energy it removes is booked as
        stabilisation."""
        a = first + wp.tid()
        x = q[a]
        Ga = gradient[a]
        c = wave_speed[material[a]]
        force = vec3(zero, zero, zero)
        for k in range(offsets[a], offsets[a + 1]):
            b = nbr[k]
            x_ab = q[b] - x
            r2 = wp.dot(x_ab, x_ab)
            if r2 > zero:
                Gb = Ga
                if b < n_owned:
                    Gb = gradient[b]
                residual = v[b] - v[a] - half * (wp.transpose(Ga + Gb) * x_ab)
                weight = -wp.dot(grad_W(-x_ab, h), -x_ab) / r2  # F_ab / r [1/m^(dim+2)]
                rho = half * (density[a] + density[b])
                force += (rho * volume[b] * weight * wp.dot(residual, x_ab) / r2) * x_ab
        before = v_out[a]
        after = before + (dt * alpha * c * h * volume[a] / mass[a]) * force
        v_out[a] = after
        ledger[a, STABILISATION] -= wp.float64(half * mass[a] * (wp.dot(after, after) - wp.dot(before, before)))

    return velocity_gradient, damp_residual


class HourglassControl:
    """The hourglass control stage (``simulation.hourglass_control`` = α > 0): the real particles'
    own velocity gradients from a real–real fit, then the pairs' residual damped into the new velocities."""

    def __init__(self, model: Model, alpha: float, neighbours: NeighbourList, volume: wp.array, ledger: wp.array):
        self.model, self.alpha, self.neighbours, self.volume, self.ledger = model, alpha, neighbours, volume, ledger
        self.fits = FitData(model.spec, model.particle_capacity, model.device)
        self.gradient = wp.zeros(model.particle_capacity, dtype=model.spec.mat33, device=model.device)

    def run(self, si: State, so: State, dt: float) -> None:
        """Damp the residual of ``si``'s velocities (positions, densities and ghosts at tⁿ) into ``so``'s."""
        m, nl = self.model, self.neighbours
        real = m.spec.real
        velocity_gradient, damp_residual = _kernels(m.spec)
        nl.build(si.particle_q, m.particle_count, si.particle_q, m.particle_total)
        compute_fit_data(m, nl, si.particle_q, m.particle_count, si.particle_q, self.volume, self.fits,
                         m.particle_ghost_source, m.particle_ghost_planes, m.particle_ghost_count)  # fmt: skip
        launch_rows(velocity_gradient, m.particle_count,
                    [real(m.h), nl.offsets, nl.indices, si.particle_q, si.particle_v, self.volume,
                     *self.fits.arrays()[:4], self.gradient], m.device)  # fmt: skip
        launch_rows(damp_residual, m.particle_count,
                    [real(m.h), real(dt), real(self.alpha), m.particle_count, nl.offsets, nl.indices, si.particle_q,
                     si.particle_v, self.volume, si.particle_density, m.particle_mass, m.particle_material,
                     m.material_wave_speed, self.gradient, so.particle_v, self.ledger], m.device)  # fmt: skip
