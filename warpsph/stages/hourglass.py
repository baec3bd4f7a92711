"""Hourglass control of the two-set step: the gradient of a dissipation potential of the part of the
real particles' velocity field that their own corrected linear fit does not hold, zero for every
linear field (docs/method.md, "Choice — hourglass control").

A pair's residual r_ab = v_b − v_a − ½(L_a + L_b)ᵀ x_ab, L the particles' fitted velocity gradients,
gives s_ab = r_ab·e_ab; Φ = ½ Σ_pairs w_ab s_ab² with w_ab = α c h ρ̄ V_a V_b F_ab/r_ab, and each
particle's velocity loses Δt ∂Φ/∂v / m, the fits' dependence on the neighbours' velocities included.
"""

import functools

import warp as wp

from warpsph.launching import launch_rows
from warpsph.model import Model, State
from warpsph.physics.elastic import elastic_struct
from warpsph.sph.kernels import smoothing_functions
from warpsph.sph.neighbours import NeighbourList
from warpsph.sph.operators import operator_functions, used_axes_algebra, used_vectors
from warpsph.sph.spec import Spec
from warpsph.stages.corrections import FitData, compute_fit_data, fits_struct
from warpsph.stages.energy import STABILISATION, ledger_columns


@functools.cache
def _kernels(spec: Spec):
    column = ledger_columns(spec)  # the energy ledger's column of each channel
    real, vec3, mat33 = spec.real, spec.vec3, spec.mat33
    ElasticMaterials = elastic_struct(spec)
    Fits = fits_struct(spec)
    _fit, fit_weights, _unused, _eig = operator_functions(spec)
    full_vector = used_vectors(spec)[1]
    _W, grad_W = smoothing_functions(spec)
    outer = used_axes_algebra(spec)[0]
    zero, half = real(0.0), real(0.5)

    @wp.kernel(enable_backward=False, module="unique")
    def velocity_gradient(
        first: int, h: real, offsets: wp.array(dtype=wp.int32), nbr: wp.array(dtype=wp.int32),
        q: wp.array(dtype=vec3), v: wp.array(dtype=vec3), volume: wp.array(dtype=real),
        fit: Fits, gradient: wp.array(dtype=mat33),
    ):  # fmt: skip
        """G_a = ∇v at the real particle a (G_ij = ∂_i v_j) from the corrected fit over its real
        neighbours (itself excluded)."""
        a = first + wp.tid()
        x = q[a]
        fitted = vec3(zero, zero, zero)
        G = mat33(zero)
        for k in range(offsets[a], offsets[a + 1]):
            b = nbr[k]
            psi, phi = fit_weights(q[b] - x, h, fit.c[a], fit.inv_den[a], fit.minv[a])
            fitted += (volume[b] * psi) * v[b]
            G += outer(volume[b] * phi, v[b])
        gradient[a] = G - outer(full_vector(fit.e[a]), fitted)

    @wp.func
    def pair_residual(a: int, b: int, n_owned: int, q: wp.array(dtype=vec3), v: wp.array(dtype=vec3),
                      gradient: wp.array(dtype=mat33), h: real, volume: wp.array(dtype=real),
                      density: wp.array(dtype=real)):  # fmt: skip
        """(x_ab, s_ab = r_ab·e_ab, w_ab / (α c h)) of the pair; a ghost b's gradient is taken as a's."""
        x_ab = q[b] - q[a]
        r2 = wp.dot(x_ab, x_ab)
        if r2 == zero:
            return x_ab, zero, zero
        Ga = gradient[a]
        Gb = Ga
        if b < n_owned:
            Gb = gradient[b]
        r = wp.sqrt(r2)
        residual = v[b] - v[a] - half * (wp.transpose(Ga + Gb) * x_ab)
        weight = -wp.dot(grad_W(x_ab, h), x_ab) / r2  # F_ab / r ≥ 0
        rho = half * (density[a] + density[b])
        return x_ab, wp.dot(residual, x_ab) / r, rho * volume[a] * volume[b] * weight

    @wp.kernel(enable_backward=False, module="unique")
    def pair_terms(
        first: int, h: real, n_owned: int, offsets: wp.array(dtype=wp.int32), nbr: wp.array(dtype=wp.int32),
        q: wp.array(dtype=vec3), v: wp.array(dtype=vec3), volume: wp.array(dtype=real),
        density: wp.array(dtype=real), gradient: wp.array(dtype=mat33), direct: wp.array(dtype=vec3),
        moment: wp.array(dtype=mat33),
    ):  # fmt: skip
        """Per owned a: the pairs' direct force Σ_b w s e and the moment T_a = Σ_b w s e ⊗ x_ab through
        which a's own gradient depends on its neighbours' velocities (both over α c h)."""
        a = first + wp.tid()
        f = vec3(zero, zero, zero)
        T = mat33(zero)
        for k in range(offsets[a], offsets[a + 1]):
            x_ab, s_ab, w = pair_residual(a, nbr[k], n_owned, q, v, gradient, h, volume, density)
            if w > zero:
                e = x_ab / wp.sqrt(wp.dot(x_ab, x_ab))
                f += (w * s_ab) * e
                T += wp.outer((w * s_ab) * e, x_ab)
        direct[a] = f
        moment[a] = T

    @wp.kernel(enable_backward=False, module="unique")
    def damp_residual(
        first: int, h: real, dt: real, alpha: real, n_owned: int, offsets: wp.array(dtype=wp.int32),
        nbr: wp.array(dtype=wp.int32), q: wp.array(dtype=vec3), volume: wp.array(dtype=real),
        mass: wp.array(dtype=real), material: wp.array(dtype=wp.int32), elastic: ElasticMaterials,
        fit: Fits, direct: wp.array(dtype=vec3), moment: wp.array(dtype=mat33),
        v_out: wp.array(dtype=vec3), ledger: wp.array2d(dtype=wp.float64),
    ):  # fmt: skip
        """F_c = −∂Φ/∂v_c, Φ = ½ Σ_pairs w s²: the direct force and, through each owned neighbour a's
        fit, ½ V_c (T_a φ_ac − ψ_ac T_a e_a); v_out[c] += Δt F_c / m_c, its kinetic energy booked."""
        c = first + wp.tid()
        f = direct[c]
        x = q[c]
        for k in range(offsets[c], offsets[c + 1]):
            a = nbr[k]
            if a < n_owned:
                psi, phi = fit_weights(x - q[a], h, fit.c[a], fit.inv_den[a], fit.minv[a])
                f += (half * volume[c]) * (moment[a] * phi - psi * (moment[a] * full_vector(fit.e[a])))
        before = v_out[c]
        after = before + (dt * alpha * elastic.wave_speed[material[c]] * h / mass[c]) * f
        v_out[c] = after
        gained = half * mass[c] * (wp.dot(after, after) - wp.dot(before, before))
        ledger[c, wp.static(column[STABILISATION])] -= wp.float64(gained)

    return velocity_gradient, pair_terms, damp_residual


class HourglassControl:
    """The hourglass control stage (``simulation.hourglass_control`` = α > 0): the real particles'
    own velocity gradients from a real–real fit, then −Δt ∂Φ/∂v / m added to the new velocities."""

    def __init__(self, model: Model, alpha: float, neighbours: NeighbourList, volume: wp.array, ledger: wp.array):
        self.model, self.alpha, self.neighbours, self.volume, self.ledger = model, alpha, neighbours, volume, ledger
        self.fits = FitData(model.spec, model.particle_capacity, model.device)
        self.gradient = wp.zeros(model.particle_capacity, dtype=model.spec.mat33, device=model.device)
        self.direct = wp.zeros(model.particle_capacity, dtype=model.spec.vec3, device=model.device)
        self.moment = wp.zeros(model.particle_capacity, dtype=model.spec.mat33, device=model.device)

    def run(self, si: State, so: State, dt: float) -> None:
        """Damp the residual of ``si``'s velocities (positions, densities and ghosts at tⁿ) into ``so``'s."""
        m, nl = self.model, self.neighbours
        real = m.spec.real
        velocity_gradient, pair_terms, damp_residual = _kernels(m.spec)
        nl.build(si.particle_q, m.particle_count, si.particle_q, m.particle_total)
        compute_fit_data(m, nl, si.particle_q, m.particle_count, si.particle_q, self.volume, self.fits,
                         m.particle_ghost_source, m.particle_ghost_planes, m.particle_ghost_count)  # fmt: skip
        launch_rows(velocity_gradient, m.particle_count,
                    [real(m.h), nl.offsets, nl.indices, si.particle_q, si.particle_v, self.volume,
                     self.fits.struct, self.gradient], m.device)  # fmt: skip
        launch_rows(pair_terms, m.particle_count,
                    [real(m.h), m.particle_count, nl.offsets, nl.indices, si.particle_q, si.particle_v, self.volume,
                     si.particle_density, self.gradient, self.direct, self.moment], m.device)  # fmt: skip
        launch_rows(damp_residual, m.particle_count,
                    [real(m.h), real(dt), real(self.alpha), m.particle_count, nl.offsets, nl.indices, si.particle_q,
                     self.volume, m.particle_mass, m.particle_material, m.material_elastic, self.fits.struct,
                     self.direct, self.moment, so.particle_v, self.ledger], m.device)  # fmt: skip
