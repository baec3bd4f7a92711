"""Two-step Taylor-SPH with real particles and virtual stress points (method.md §4).

Half step, at the virtual points i, from the real particles' values Φⁿ = (v, σ′):
    Φ_i^{n+½} = Φ_iⁿ + Δt/2 (∇·σ′/ρ + b,  D:d) + ΔS(Δt/2)
Full step, at the real particles a, from the virtual points' Φ^{n+½}:
    Φ_a^{n+1} = Φ_aⁿ + Δt (∇·σ′/ρ + b,  D:d) + ΔS(Δt)
where values and gradients come from the linear fit of :mod:`warpsph.sph.operators`, and ΔS is the
Runge–Kutta increment of the Jaumann source. Virtual points move with their half-step velocity,
real particles with the half-step velocity fitted at them; densities follow continuity. Both use
the configuration at tⁿ. Real particles whose correction matrix has a small eigenvalue are surface
particles: their normal traction is removed (traction-free surface).
"""


import functools

import warp as wp

from warpsph.physics.elastic import elastic_functions
from warpsph.sph.operators import operator_functions
from warpsph.sph.spec import Spec


@functools.cache
def taylor_kernels(spec: Spec):
    """``(half_step, full_step)`` kernels for ``spec``."""
    real, vec3, mat33 = spec.real, spec.vec3, spec.mat33
    fit_operator, fit_weights, _unused, smallest_eigenvalue = operator_functions(spec)
    hooke_rate, source_increment, split_velocity_gradient = elastic_functions(spec)
    zero, half = real(0.0), real(0.5)

    @wp.func
    def fit_fields(
        x: vec3, start: int, end: int, nbr: wp.array(dtype=wp.int32), xs: wp.array(dtype=vec3),
        ms: wp.array(dtype=real), rhos: wp.array(dtype=real), vs: wp.array(dtype=vec3),
        sigmas: wp.array(dtype=mat33), h: real,
    ):  # fmt: skip
        """Velocity, stress, velocity gradient G[k,j] = ∂v_j/∂x_k and ∇·σ fitted at x, plus the
        correction matrix M and the vector e (−e is along the outward surface normal)."""
        c, inv_den, Minv, e, M, corrected = fit_operator(x, start, end, nbr, xs, ms, rhos, h)
        v = vec3(zero, zero, zero)
        s = mat33(zero)
        G = mat33(zero)
        div = vec3(zero, zero, zero)
        for k in range(start, end):
            b = nbr[k]
            vol = ms[b] / rhos[b]
            psi, phi = fit_weights(xs[b] - x, h, c, inv_den, Minv)
            v += (vol * psi) * vs[b]
            s += (vol * psi) * sigmas[b]
            G += wp.outer(vol * phi, vs[b])
            div += sigmas[b] * (vol * phi)
        G -= wp.outer(e, v)
        div -= s * e
        return v, s, G, div, M, e

    @wp.kernel(enable_backward=False, module="unique")
    def half_step(
        h: real,
        dt: real,
        gravity: vec3,
        offsets: wp.array(dtype=wp.int32),
        nbr: wp.array(dtype=wp.int32),
        real_q: wp.array(dtype=vec3),
        real_mass: wp.array(dtype=real),
        real_density: wp.array(dtype=real),
        real_v: wp.array(dtype=vec3),
        real_stress: wp.array(dtype=mat33),
        virt_q: wp.array(dtype=vec3),
        virt_density: wp.array(dtype=real),
        virt_material: wp.array(dtype=wp.int32),
        lam: wp.array(dtype=real),
        shear: wp.array(dtype=real),
        virt_v_half: wp.array(dtype=vec3),
        virt_stress_half: wp.array(dtype=mat33),
        virt_q_out: wp.array(dtype=vec3),
        virt_density_out: wp.array(dtype=real),
    ):
        i = wp.tid()
        x = virt_q[i]
        v, s, G, div, M, e = fit_fields(x, offsets[i], offsets[i + 1], nbr, real_q, real_mass, real_density,
                                        real_v, real_stress, h)  # fmt: skip
        d, spin = split_velocity_gradient(G)
        mat = virt_material[i]
        rho = virt_density[i]
        hdt = half * dt
        v_half = v + hdt * (div / rho + gravity)
        s_half = s + hdt * hooke_rate(d, lam[mat], shear[mat]) + source_increment(s, spin, hdt)
        virt_v_half[i] = v_half
        virt_stress_half[i] = s_half
        virt_q_out[i] = x + dt * v_half
        virt_density_out[i] = rho * wp.exp(-dt * wp.trace(d))

    @wp.kernel(enable_backward=False, module="unique")
    def full_step(
        h: real,
        dt: real,
        gravity: vec3,
        surface_threshold: real,
        offsets: wp.array(dtype=wp.int32),
        nbr: wp.array(dtype=wp.int32),
        virt_q: wp.array(dtype=vec3),
        virt_mass: wp.array(dtype=real),
        virt_density: wp.array(dtype=real),
        virt_v_half: wp.array(dtype=vec3),
        virt_stress_half: wp.array(dtype=mat33),
        q: wp.array(dtype=vec3),
        v: wp.array(dtype=vec3),
        stress: wp.array(dtype=mat33),
        density: wp.array(dtype=real),
        material: wp.array(dtype=wp.int32),
        lam: wp.array(dtype=real),
        shear: wp.array(dtype=real),
        q_out: wp.array(dtype=vec3),
        v_out: wp.array(dtype=vec3),
        stress_out: wp.array(dtype=mat33),
        density_out: wp.array(dtype=real),
        surface_normal: wp.array(dtype=vec3),
    ):
        a = wp.tid()
        x = q[a]
        v_half, s_half, G, div, M, e = fit_fields(x, offsets[a], offsets[a + 1], nbr, virt_q, virt_mass,
                                                  virt_density, virt_v_half, virt_stress_half, h)  # fmt: skip
        d, spin = split_velocity_gradient(G)
        mat = material[a]
        rho = density[a]
        s = stress[a]
        s_new = s + dt * hooke_rate(d, lam[mat], shear[mat]) + source_increment(s, spin, dt)
        normal = vec3(zero, zero, zero)
        if smallest_eigenvalue(M) < surface_threshold and wp.length(e) > zero:
            normal = -wp.normalize(e)
            t = s_new * normal
            s_new = s_new - wp.outer(t, normal) - wp.outer(normal, t) + wp.dot(normal, t) * wp.outer(normal, normal)
        surface_normal[a] = normal
        v_out[a] = v[a] + dt * (div / rho + gravity)
        stress_out[a] = s_new
        q_out[a] = x + dt * v_half
        density_out[a] = rho * wp.exp(-dt * wp.trace(d))

    return half_step, full_step
