"""Collocated SPH baseline: one particle set, the same corrected operators, method of lines.

The whole system dΦ/dt = (∇·σ′/ρ + b + Π,  D:d + Wσ′ − σ′W,  −ρ tr d) is integrated by the
scene's Runge–Kutta scheme (RK2 midpoint or classic RK4) with particles fixed during the step and
moved by the RK-weighted velocity at its end. ∇f_a = M_a⁻¹ Σ V_b (f_b − f_a) ∇W_ab is exact for
linear fields. Π is Monaghan's artificial viscosity (coefficient α, zero by default).
"""


import functools

import warp as wp

from warpsph.launching import launch, launch_rows
from warpsph.physics.elastic import elastic_functions, elastic_struct
from warpsph.sph.kernels import smoothing_functions
from warpsph.sph.operators import operator_functions
from warpsph.sph.spec import Spec

RK_TABLEAU = {
    # (a: stage offsets from yⁿ, b: weights)
    "rk2": ((0.5,), (0.0, 1.0)),
    "rk4": ((0.5, 0.5, 1.0), (1.0 / 6.0, 1.0 / 3.0, 1.0 / 3.0, 1.0 / 6.0)),
}


@functools.cache
def collocated_kernels(spec: Spec):
    """``(rates, accumulate)`` kernels for ``spec``."""
    real, vec3, mat33 = spec.real, spec.vec3, spec.mat33
    moves = vec3(*map(real, spec.axis_mask))  # points move only along the used axes
    W, grad_W = smoothing_functions(spec)
    _fit, _weights, invert_correction, smallest_eigenvalue = operator_functions(spec)
    hooke_rate, _source, split_velocity_gradient = elastic_functions(spec)
    ElasticMaterials = elastic_struct(spec)
    zero = real(0.0)

    @wp.kernel(enable_backward=False, module="unique")
    def rates(
        first: int,
        h: real,
        alpha: real,
        gravity: vec3,
        surface_threshold: real,
        offsets: wp.array(dtype=wp.int32),
        nbr: wp.array(dtype=wp.int32),
        q: wp.array(dtype=vec3),
        v: wp.array(dtype=vec3),
        stress: wp.array(dtype=mat33),
        density: wp.array(dtype=real),
        mass: wp.array(dtype=real),
        material: wp.array(dtype=wp.int32),
        elastic: ElasticMaterials,
        dv: wp.array(dtype=vec3),
        dstress: wp.array(dtype=mat33),
        ddensity: wp.array(dtype=real),
        surface_normal: wp.array(dtype=vec3),
    ):
        a = first + wp.tid()
        x = q[a]
        start = offsets[a]
        end = offsets[a + 1]
        M = mat33(zero)
        g0 = vec3(zero, zero, zero)
        for k in range(start, end):
            b = nbr[k]
            g = grad_W(x - q[b], h) * (mass[b] / density[b])
            M += wp.outer(g, q[b] - x)
            g0 += g
        Minv, _corrected = invert_correction(M)
        va = v[a]
        sa = stress[a]
        rho = density[a]
        ca = elastic.wave_speed[material[a]]
        G = mat33(zero)
        div = vec3(zero, zero, zero)
        visc = vec3(zero, zero, zero)
        for k in range(start, end):
            b = nbr[k]
            gW = grad_W(x - q[b], h)
            phi = Minv * gW * (mass[b] / density[b])
            G += wp.outer(phi, v[b] - va)
            div += (stress[b] - sa) * phi
            xab = x - q[b]
            vab = va - v[b]
            vr = wp.dot(vab, xab)
            if alpha > zero and vr < zero:
                mu = h * vr / (wp.dot(xab, xab) + real(0.01) * h * h)
                cbar = real(0.5) * (ca + elastic.wave_speed[material[b]])
                rbar = real(0.5) * (rho + density[b])
                visc += (mass[b] * alpha * cbar * mu / rbar) * gW
        d, spin = split_velocity_gradient(G)
        mat = material[a]
        dv[a] = div / rho + gravity + visc
        dstress[a] = hooke_rate(d, elastic.lam[mat], elastic.shear[mat]) + spin * sa - sa * spin
        ddensity[a] = -rho * wp.trace(d)
        normal = vec3(zero, zero, zero)
        e = Minv * g0
        if smallest_eigenvalue(M) < surface_threshold and wp.length(e) > zero:
            normal = -wp.normalize(e)
        surface_normal[a] = normal

    @wp.func
    def traction_free(s: mat33, n: vec3):
        t = s * n
        return s - wp.outer(t, n) - wp.outer(n, t) + wp.dot(n, t) * wp.outer(n, n)

    @wp.kernel(enable_backward=False, module="unique")
    def accumulate(
        b_dt: real,
        a_dt: real,
        last: int,
        v0: wp.array(dtype=vec3),
        stress0: wp.array(dtype=mat33),
        density0: wp.array(dtype=real),
        dv: wp.array(dtype=vec3),
        dstress: wp.array(dtype=mat33),
        ddensity: wp.array(dtype=real),
        surface_normal: wp.array(dtype=vec3),
        v_stage: wp.array(dtype=vec3),
        stress_stage: wp.array(dtype=mat33),
        density_stage: wp.array(dtype=real),
        q_out: wp.array(dtype=vec3),
        v_out: wp.array(dtype=vec3),
        stress_out: wp.array(dtype=mat33),
        density_out: wp.array(dtype=real),
    ):
        """out += b Δt k (out starts as yⁿ); next stage = yⁿ + a Δt k; positions from stage velocity."""
        a = wp.tid()
        n = surface_normal[a]
        q_out[a] = q_out[a] + b_dt * wp.cw_mul(v_stage[a], moves)
        v_out[a] = v_out[a] + b_dt * dv[a]
        s_out = stress_out[a] + b_dt * dstress[a]
        density_out[a] = density_out[a] + b_dt * ddensity[a]
        if last == 1:
            s_out = traction_free(s_out, n)
        stress_out[a] = s_out
        if last == 0:
            v_stage[a] = v0[a] + a_dt * dv[a]
            stress_stage[a] = traction_free(stress0[a] + a_dt * dstress[a], n)
            density_stage[a] = density0[a] + a_dt * ddensity[a]

    return rates, accumulate


class RungeKuttaStep:
    """The collocated scheme's step: the rates of every Runge–Kutta stage at the particles, accumulated
    into the new state, with the boundaries' ghosts set at each stage's time."""

    def __init__(self, model, config, boundaries, neighbours):
        m, s, dev = model, model.spec, model.device
        self.model, self.config, self.boundaries, self.neighbours = model, config, boundaries, neighbours
        n, ne = m.particle_count, m.particle_capacity
        self.surface_normal = wp.zeros(n, dtype=s.vec3, device=dev)
        self.stage_v = wp.zeros(ne, dtype=s.vec3, device=dev)
        self.stage_stress = wp.zeros(ne, dtype=s.mat33, device=dev)
        self.stage_density = wp.zeros(ne, dtype=s.real, device=dev)
        self.rate_v = wp.zeros(n, dtype=s.vec3, device=dev)
        self.rate_stress = wp.zeros(n, dtype=s.mat33, device=dev)
        self.rate_density = wp.zeros(n, dtype=s.real, device=dev)

    def run(self, si, so, t: float, dt: float) -> None:
        m = self.model
        real, sim = m.spec.real, self.config
        rates, accumulate = collocated_kernels(m.spec)
        a_coef, b_coef = RK_TABLEAU[m.spec.integrator]
        c_coef = (0.0, *a_coef)
        n, nl = m.particle_count, self.neighbours
        wp.copy(self.stage_v, si.particle_v)
        wp.copy(self.stage_stress, si.particle_stress)
        wp.copy(self.stage_density, si.particle_density)
        for name in ("particle_q", "particle_v", "particle_stress", "particle_density"):
            wp.copy(getattr(so, name), getattr(si, name), count=n)
        for i, b in enumerate(b_coef):
            if i > 0:
                self.boundaries.set_time(t + c_coef[i] * dt)
                self.boundaries.update_real_ghosts(si.particle_q, self.stage_v, self.stage_stress,
                                                   self.stage_density)  # fmt: skip
            launch_rows(rates, n,
                        [real(m.h), real(sim.artificial_viscosity), m.spec.vec3(*m.gravity),
                         real(sim.free_surface_threshold), nl.offsets, nl.indices, si.particle_q, self.stage_v,
                         self.stage_stress, self.stage_density, m.particle_mass, m.particle_material,
                         m.material_elastic, self.rate_v, self.rate_stress,
                         self.rate_density, self.surface_normal], m.device)  # fmt: skip
            last = i == len(b_coef) - 1
            a_next = 0.0 if last else a_coef[i]
            launch(accumulate, n,
                   [real(b * dt), real(a_next * dt), int(last), si.particle_v, si.particle_stress,
                    si.particle_density, self.rate_v, self.rate_stress, self.rate_density, self.surface_normal,
                    self.stage_v, self.stage_stress, self.stage_density, so.particle_q, so.particle_v,
                    so.particle_stress, so.particle_density], m.device)  # fmt: skip
