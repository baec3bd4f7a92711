"""Pore-pressure projection of the fractional step (method.md §3), in float64 throughout.

After the Taylor predictor has given v* (with the lagged pressure force), the pressure at tⁿ⁺¹ is
found from the water mass balance (non-incremental form, solving for the excess pressure p directly
so that drained values and ghost parities enter as they are):

    p/(QΔt) − ∇·[(k + Δt/ρ) ∇p] = pⁿ/(QΔt) − ∇·v* − ∇·[(Δt/ρ) ∇pⁿ] − ρ_w b·v*/Q

then v = v* − (Δt/ρ) ∇(p − pⁿ). ∇·v* and ∇(p − pⁿ) follow the same real → virtual → real path as
the effective stress (linear fits of :mod:`warpsph.sph.operators`); the Laplacian is the symmetric
Morris form on real–real pairs, V_a V_b κ_ab (−x_ab·∇W_ab)/(r² + η²), η = 0.1h, with
κ_ab = 4 k_a k_b/(k_a + k_b) + Δt/ρ_a + Δt/ρ_b (twice the harmonic mean of k), scaled by a
constant that makes it exact for quadratics on the initial lattice (the plain form is biased there),
so the system is symmetric positive definite: Jacobi-preconditioned CG or weighted Jacobi solve it.
Dirichlet rows (drained planes, drained free surface) are eliminated; ghosts enter with the
pressure parity of their planes: even at impermeable planes, odd about the prescribed pressure at
drained planes, and with the prescribed gradient ∂p/∂n = q̄/k at inflow planes. In the Δt/ρ part the
increment is odd across impermeable traction planes, and an impermeable free surface gains the
pairs its particles lack outside, with a zero increment (docs/method.md, Saturated soil). Within
reach of a free surface the Δt/ρ part's right-hand side acts on pⁿ − θ(pⁿ − Πpⁿ), damping the pore
pressure's odd-even part (``roughness``; docs/method.md, *Pore-pressure roughness damping*).
"""

import functools
import math
import warnings

import numpy as np
import warp as wp

from warpsph.errors import SimulationError
from warpsph.launching import launch, launch_rows
from warpsph.model import PLANE_TRACTION, Model
from warpsph.scene import EXTENT_TOLERANCE
from warpsph.sph.kernels import kernel_derivative
from warpsph.sph.operators import fit_parts, operator_functions
from warpsph.sph.spec import Spec
from warpsph.stages.boundaries import plane_functions
from warpsph.stages.linear_solve import LinearSolver

DRAINED_SURFACE_EIGENVALUE = 0.6
"""Real particles whose correction eigenvalue is below this are on a free surface (≈0.5 on a flat
face, ≈0.66 one row in): with a drained free surface their pore pressure is zero."""
STABLE_SURFACE_RATIO = {"drained": 0.05, "impermeable": 0.01}
"""k ρ/Δt (the Darcy part of the projection's Laplacian over its Δt/ρ part) from which a free surface
of each kind is stable at every Courant number measured without the roughness damping
(``pressure.stabilisation`` = 0; also used below 1, where it was not measured). One step about rest
then has a real eigenvalue above 1, a pore pressure mode under the surface, below 0.040, 0.034,
0.024 and 0.020 at Courant 0.05–0.1, 0.25, 0.5 and 0.9 for a drained surface (whatever E and K_w),
and below about 0.003 at Courant 0.5 and 0.005 at 0.9 for an impermeable one, growing at up to
70 /s and 9 /s (docs/method.md, *Known limits*)."""
DAMPED_STABLE_SURFACE_RATIO = {"drained": 0.01, "impermeable": 0.0}
"""The same with the roughness damping at full weight (θ = 1): an impermeable surface stable down to
k_h = 1e-12 m/s at Courant 0.1–0.9 (1D column); a drained one stable at k ρ/Δt = 0.0071, 0.0014
and 0.00079 at Courant 0.1, 0.5 and 0.9, with a slow mode below (0.015–0.28 /s in 1D, 1.7 /s in a
2D column at k_h = 1e-8 m/s) instead of 52 /s."""
ETA = 0.1
"""Morris regularisation η/h."""


def _lattice_distances(dim: int, ratio: float) -> np.ndarray:
    """Distances from a point of the lattice of spacing 1 to the others within the support 2h (h = ratio)."""
    span = int(math.ceil(2.0 * ratio))
    axes = [np.arange(-span, span + 1)] * dim
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, dim).astype(float)
    r = np.linalg.norm(grid, axis=1)
    return r[(r > 0) & (r < 2.0 * ratio)]


def laplacian_scale(kind: str, dim: int, ratio: float) -> float:
    """Constant that makes the Morris Laplacian exact for |x|² on the lattice of spacing 1 (h = ratio)."""
    r = _lattice_distances(dim, ratio)
    # the operator is Σ V (κ_a + κ_b)(p_a − p_b)(x_ab·∇W)/(r² + η²); for κ = 1 and p = |x|²
    # (p_a − p_b = −r², x_ab·∇W = r W'(r)) it must give ∇²p = 2 dim
    morris = 2.0 * np.sum(-(r**2) * r * kernel_derivative(kind, dim, r, ratio) / (r**2 + (ETA * ratio) ** 2))
    return 2.0 * dim / morris


def lattice_morris_sum(kind: str, dim: int, dx: float, ratio: float) -> float:
    """Σ_b V_b m_ab [1/m²] over a full lattice neighbourhood (V_b = Δx^dim), m_ab the scaled Morris weight
    −(x_ab·∇W_ab)/(r² + η²): what a particle's pair weights sum to when no neighbour is missing."""
    r = _lattice_distances(dim, ratio) * dx
    h = ratio * dx
    weights = -r * kernel_derivative(kind, dim, r, h) / (r**2 + (ETA * h) ** 2)
    return float(dx**dim * laplacian_scale(kind, dim, ratio) * np.sum(weights))


@functools.cache
def _kernels(spec: Spec):
    real, vec3 = spec.real, spec.vec3
    f64 = wp.float64
    _fit, fit_weights, _inv, _eig = operator_functions(spec)
    add_to_fit, finish_fit, _inv, _unused = fit_parts(spec)
    from warpsph.sph.kernels import smoothing_functions

    _W, grad_W = smoothing_functions(spec)
    _traction, drainage_here = plane_functions(spec)
    zero = f64(0.0)

    @wp.func
    def plane_excess(p: int, x: vec3, water_density: f64, gravity: vec3, water_table: f64,
                     drained_pressure: wp.array(dtype=f64), head: wp.array(dtype=f64)):  # fmt: skip
        """Prescribed excess pore pressure of drained plane p at point x [Pa]."""
        rho_g = water_density * f64(wp.length(gravity))
        total = drained_pressure[p]
        if not wp.isnan(head[p]):
            total = rho_g * (head[p] - f64(x[1]))
        hydro = water_density * (f64(gravity[0]) * f64(x[0]) + f64(gravity[1]) * (f64(x[1]) - water_table)
                                 + f64(gravity[2]) * f64(x[2]))  # fmt: skip
        return total - hydro

    @wp.func
    def ghost_affine(g: int, source: wp.array(dtype=wp.int32), chain: wp.array(dtype=wp.vec3i),
                     q: wp.array(dtype=vec3), where: vec3, plane_axis: wp.array(dtype=wp.int32),
                     plane_position: wp.array(dtype=real), plane_sign: wp.array(dtype=real),
                     plane_kind: wp.array(dtype=wp.int32), drainage: wp.array(dtype=wp.int32),
                     drained_lo: wp.array(dtype=vec3), drained_hi: wp.array(dtype=vec3),
                     drained_pressure: wp.array(dtype=f64), head: wp.array(dtype=f64), inflow: wp.array(dtype=f64),
                     water_density: f64, k: f64, gravity: vec3, water_table: f64, homogeneous: int):  # fmt: skip
        """(s, c, s_m, c_m) with p_ghost = s p_source + c for ghost g (c = 0 when ``homogeneous``);
        each plane drains (odd parity) where the initial position ``where`` lies in its drained extent.

        (s_m, c_m) is the parity of the pressure *increment* in the velocity correction: odd also at
        impermeable traction planes, whose total traction t̄ = σ′n − p n is prescribed, so that the
        correction −(Δt/ρ)∇δp leaves it unchanged (the effective stress takes up δp in the next
        predictor); water still does not cross them ((s, c) even)."""
        x = q[source[g]]
        s = f64(1.0)
        c = zero
        s_m = f64(1.0)
        c_m = zero
        planes = chain[g]
        for i in range(3):
            p = planes[i]
            if p >= 0:
                m = plane_axis[p]
                kind = drainage_here(p, where, m, drainage, drained_lo, drained_hi)
                traction = plane_kind[p] == PLANE_TRACTION
                if kind == 1:
                    s = -s
                    c = -c
                    s_m = -s_m
                    c_m = -c_m
                    if homogeneous == 0:
                        xp = x
                        xp[m] = plane_position[p]
                        excess = f64(2.0) * plane_excess(p, xp, water_density, gravity, water_table,
                                                         drained_pressure, head)  # fmt: skip
                        c += excess
                        c_m += excess
                else:
                    if kind == 2 and homogeneous == 0 and k > zero:
                        depth = f64(plane_sign[p] * (plane_position[p] - x[m]))
                        c += f64(2.0) * depth * inflow[p] / k
                        if not traction:
                            c_m += f64(2.0) * depth * inflow[p] / k
                    if traction:
                        s_m = -s_m
                        c_m = -c_m
                x[m] = real(2.0) * plane_position[p] - x[m]
        return s, c, s_m, c_m

    @wp.kernel(enable_backward=False, module="unique")
    def pressure_ghosts(
        n_owned: int, source: wp.array(dtype=wp.int32), chain: wp.array(dtype=wp.vec3i), q: wp.array(dtype=vec3),
        origin: wp.array(dtype=vec3), material: wp.array(dtype=wp.int32), plane_axis: wp.array(dtype=wp.int32),
        plane_position: wp.array(dtype=real), plane_sign: wp.array(dtype=real), plane_kind: wp.array(dtype=wp.int32),
        drainage: wp.array(dtype=wp.int32), drained_lo: wp.array(dtype=vec3), drained_hi: wp.array(dtype=vec3),
        drained_pressure: wp.array(dtype=f64), head: wp.array(dtype=f64), inflow: wp.array(dtype=f64),
        water_density: wp.array(dtype=f64), permeability: wp.array(dtype=f64), gravity: vec3, water_table: f64,
        homogeneous: int, momentum: int, p: wp.array(dtype=f64),
    ):  # fmt: skip
        g = wp.tid()
        src = source[g]
        mat = material[src]
        s, c, s_m, c_m = ghost_affine(g, source, chain, q, origin[src], plane_axis, plane_position, plane_sign,
                                      plane_kind, drainage, drained_lo, drained_hi, drained_pressure, head, inflow,
                                      water_density[mat], permeability[mat], gravity, water_table,
                                      homogeneous)  # fmt: skip
        if momentum == 1:
            s = s_m
            c = c_m
        p[n_owned + g] = s * p[src] + c

    @wp.kernel(enable_backward=False, module="unique")
    def fit_vector_at_virtual(
        first: int, h: real, offsets: wp.array(dtype=wp.int32), nbr: wp.array(dtype=wp.int32), vq: wp.array(dtype=vec3),
        c: wp.array(dtype=vec3), inv_den: wp.array(dtype=real), minv: wp.array(dtype=wp.types.matrix((3, 3), real)),
        xs: wp.array(dtype=vec3), ms: wp.array(dtype=real), rhos: wp.array(dtype=real), values: wp.array(dtype=vec3),
        out: wp.array(dtype=vec3),
    ):  # fmt: skip
        i = first + wp.tid()
        x = vq[i]
        acc = vec3(real(0.0), real(0.0), real(0.0))
        for k in range(offsets[i], offsets[i + 1]):
            b = nbr[k]
            psi, phi = fit_weights(xs[b] - x, h, c[i], inv_den[i], minv[i])
            acc += (ms[b] / rhos[b] * psi) * values[b]
        out[i] = acc

    @wp.kernel(enable_backward=False, module="unique")
    def fit_scalar_at_virtual(
        first: int, h: real, offsets: wp.array(dtype=wp.int32), nbr: wp.array(dtype=wp.int32), vq: wp.array(dtype=vec3),
        c: wp.array(dtype=vec3), inv_den: wp.array(dtype=real), minv: wp.array(dtype=wp.types.matrix((3, 3), real)),
        xs: wp.array(dtype=vec3), ms: wp.array(dtype=real), rhos: wp.array(dtype=real), values: wp.array(dtype=f64),
        out: wp.array(dtype=f64),
    ):  # fmt: skip
        i = first + wp.tid()
        x = vq[i]
        acc = zero
        for k in range(offsets[i], offsets[i + 1]):
            b = nbr[k]
            psi, phi = fit_weights(xs[b] - x, h, c[i], inv_den[i], minv[i])
            acc += f64(ms[b] / rhos[b] * psi) * values[b]
        out[i] = acc

    @wp.kernel(enable_backward=False, module="unique")
    def divergence_at_real(
        first: int, h: real, offsets: wp.array(dtype=wp.int32), nbr: wp.array(dtype=wp.int32), q: wp.array(dtype=vec3),
        c: wp.array(dtype=vec3), inv_den: wp.array(dtype=real), minv: wp.array(dtype=wp.types.matrix((3, 3), real)),
        e: wp.array(dtype=vec3), xs: wp.array(dtype=vec3), ms: wp.array(dtype=real), rhos: wp.array(dtype=real),
        values: wp.array(dtype=vec3), out: wp.array(dtype=f64),
    ):  # fmt: skip
        a = first + wp.tid()
        x = q[a]
        fit = vec3(real(0.0), real(0.0), real(0.0))
        div = zero
        for k in range(offsets[a], offsets[a + 1]):
            b = nbr[k]
            vol = ms[b] / rhos[b]
            psi, phi = fit_weights(xs[b] - x, h, c[a], inv_den[a], minv[a])
            fit += (vol * psi) * values[b]
            div += f64(vol * wp.dot(phi, values[b]))
        out[a] = div - f64(wp.dot(e[a], fit))

    @wp.kernel(enable_backward=False, module="unique")
    def gradient_at_real(
        first: int, h: real, offsets: wp.array(dtype=wp.int32), nbr: wp.array(dtype=wp.int32), q: wp.array(dtype=vec3),
        c: wp.array(dtype=vec3), inv_den: wp.array(dtype=real), minv: wp.array(dtype=wp.types.matrix((3, 3), real)),
        e: wp.array(dtype=vec3), xs: wp.array(dtype=vec3), ms: wp.array(dtype=real), rhos: wp.array(dtype=real),
        values: wp.array(dtype=f64), out: wp.array(dtype=wp.vec3d),
    ):  # fmt: skip
        """∇f at real particles fitted from the virtual points' f."""
        a = first + wp.tid()
        x = q[a]
        fit = zero
        grad = wp.vec3d(zero, zero, zero)
        for k in range(offsets[a], offsets[a + 1]):
            b = nbr[k]
            vol = ms[b] / rhos[b]
            psi, phi = fit_weights(xs[b] - x, h, c[a], inv_den[a], minv[a])
            fit += f64(vol * psi) * values[b]
            grad += wp.vec3d(f64(phi[0]), f64(phi[1]), f64(phi[2])) * (f64(vol) * values[b])
        ea = e[a]
        out[a] = grad - wp.vec3d(f64(ea[0]), f64(ea[1]), f64(ea[2])) * fit

    @wp.kernel(enable_backward=False, module="unique")
    def correct_velocity(first: int, dt: real, grad_dp: wp.array(dtype=wp.vec3d), density: wp.array(dtype=real),
                         v: wp.array(dtype=vec3)):  # fmt: skip
        """v −= (Δt/ρ) ∇Δp."""
        a = first + wp.tid()
        g = grad_dp[a] * (f64(dt) / f64(density[a]))
        v[a] = v[a] - vec3(real(g[0]), real(g[1]), real(g[2]))

    @wp.kernel(enable_backward=False, module="unique")
    def darcy(grad_p: wp.array(dtype=wp.vec3d), material: wp.array(dtype=wp.int32),
              permeability: wp.array(dtype=f64), w: wp.array(dtype=wp.vec3d)):  # fmt: skip
        """w = −k ∇p_excess [m/s]."""
        a = wp.tid()
        w[a] = -permeability[material[a]] * grad_p[a]

    @wp.kernel(enable_backward=False, module="unique")
    def mark_dirichlet(
        first: int, n: int, on_drained: wp.array(dtype=wp.int32), drained_value: wp.array(dtype=f64),
        eigenvalue: wp.array(dtype=real), drained_surface: int, q: wp.array(dtype=vec3),
        material: wp.array(dtype=wp.int32), water_density: wp.array(dtype=f64), gravity: vec3, water_table: f64,
        dirichlet: wp.array(dtype=wp.int32), value: wp.array(dtype=f64), p_start: wp.array(dtype=f64),
    ):  # fmt: skip
        """Drained rows and their values; a drained row's unknown starts the solve at its value
        (decoupled, it then stays there exactly)."""
        a = first + wp.tid()
        dirichlet[a] = 0
        value[a] = zero
        if on_drained[a] == 1:
            dirichlet[a] = 1
            value[a] = drained_value[a]
        elif drained_surface == 1 and eigenvalue[a] < real(DRAINED_SURFACE_EIGENVALUE):
            x = q[a]
            dirichlet[a] = 1  # p = 0: the excess is minus the hydrostatic pressure
            value[a] = -water_density[material[a]] * (f64(gravity[0]) * f64(x[0])
                       + f64(gravity[1]) * (f64(x[1]) - water_table) + f64(gravity[2]) * f64(x[2]))  # fmt: skip
        if dirichlet[a] == 1:
            p_start[a] = value[a]

    @wp.func
    def fit_source(j: int, a: int, n: int, p: wp.array(dtype=f64), dirichlet: wp.array(dtype=wp.int32),
                   origin: wp.array(dtype=vec3), material: wp.array(dtype=wp.int32),
                   permeability: wp.array(dtype=f64), water_density: wp.array(dtype=f64), gravity: vec3,
                   ghost_source: wp.array(dtype=wp.int32), ghost_chain: wp.array(dtype=wp.vec3i),
                   q: wp.array(dtype=vec3), plane_axis: wp.array(dtype=wp.int32),
                   plane_position: wp.array(dtype=real), plane_sign: wp.array(dtype=real),
                   plane_kind: wp.array(dtype=wp.int32), drainage: wp.array(dtype=wp.int32),
                   drained_lo: wp.array(dtype=vec3), drained_hi: wp.array(dtype=vec3),
                   drained_pressure: wp.array(dtype=f64), head: wp.array(dtype=f64), inflow: wp.array(dtype=f64),
                   water_table: f64):  # fmt: skip
        """(1, p_j) if neighbour j takes part in the roughness fit of particle a, else (0, 0): owned
        particles off the Dirichlet rows, and the ghosts of such particles across planes that mirror
        the pressure evenly (impermeable, inflow); a drained plane's odd images would show its jump."""
        if j < n:
            if dirichlet[j] == 1 or material[j] != material[a]:
                return 0, zero
            return 1, p[j]
        g = j - n
        src = ghost_source[g]
        if dirichlet[src] == 1 or material[src] != material[a]:
            return 0, zero
        mat = material[src]
        s, c, s_m, c_m = ghost_affine(g, ghost_source, ghost_chain, q, real(0.5) * (origin[a] + origin[src]),
                                      plane_axis, plane_position, plane_sign, plane_kind, drainage, drained_lo,
                                      drained_hi, drained_pressure, head, inflow, water_density[mat],
                                      permeability[mat], gravity, water_table, 0)  # fmt: skip
        if s < zero:
            return 0, zero
        return 1, s * p[src] + c

    @wp.kernel(enable_backward=False, module="unique")
    def mark_near_surface(first: int, n: int, offsets: wp.array(dtype=wp.int32), nbr: wp.array(dtype=wp.int32),
                          eigenvalue: wp.array(dtype=real), surface_band: real,
                          near_surface: wp.array(dtype=wp.int32)):  # fmt: skip
        """near_surface = 1 in a free surface's band (correction eigenvalue below ``surface_band``) and
        on the band's neighbours: the pairs the roughness damping acts on at full weight."""
        a = first + wp.tid()
        near = eigenvalue[a] < surface_band
        for k in range(offsets[a], offsets[a + 1]):
            j = nbr[k]
            if j < n:
                if eigenvalue[j] < surface_band:
                    near = True
        near_surface[a] = wp.where(near, 1, 0)

    @wp.kernel(enable_backward=False, module="unique")
    def roughness(
        first: int, h: real, n: int, offsets: wp.array(dtype=wp.int32), nbr: wp.array(dtype=wp.int32),
        q: wp.array(dtype=vec3), origin: wp.array(dtype=vec3), mass: wp.array(dtype=real),
        density: wp.array(dtype=real), material: wp.array(dtype=wp.int32), permeability: wp.array(dtype=f64),
        water_density: wp.array(dtype=f64), gravity: vec3, ghost_source: wp.array(dtype=wp.int32),
        ghost_chain: wp.array(dtype=wp.vec3i), plane_axis: wp.array(dtype=wp.int32),
        plane_position: wp.array(dtype=real), plane_sign: wp.array(dtype=real), plane_kind: wp.array(dtype=wp.int32),
        drainage: wp.array(dtype=wp.int32), drained_lo: wp.array(dtype=vec3), drained_hi: wp.array(dtype=vec3),
        drained_pressure: wp.array(dtype=f64), head: wp.array(dtype=f64), inflow: wp.array(dtype=f64), water_table: f64,
        near_surface: wp.array(dtype=wp.int32), everywhere: int, dirichlet: wp.array(dtype=wp.int32),
        p: wp.array(dtype=f64), out: wp.array(dtype=f64),
    ):  # fmt: skip
        """out = p − Πp [Pa]: Πp is the linear fit of p at the particle over itself and the neighbours
        ``fit_source`` admits, so a drained boundary's jump is not seen and linear fields give zero;
        0 on Dirichlet rows, where the fit is not corrected, and (unless ``everywhere``) where no
        neighbour is near a surface, since no damped pair reads it there."""
        a = first + wp.tid()
        out[a] = zero
        needed = everywhere == 1 or near_surface[a] == 1
        for k in range(offsets[a], offsets[a + 1]):
            j = nbr[k]
            if j < n:
                if near_surface[j] == 1:
                    needed = True
        if dirichlet[a] == 1 or not needed:
            return
        # the value fit Σ V ψ p = (Σ V W p − c·Σ V g p)/den, summed with the fit's moments in one pass
        x = q[a]
        origin_a = vec3(real(0.0), real(0.0), real(0.0))
        vol_a = mass[a] / density[a]
        w0, wr, g0, M = add_to_fit(origin_a, vol_a, h, real(0.0), origin_a, origin_a, spec.mat33(real(0.0)))
        wp_sum = f64(vol_a * _W(real(0.0), h)) * p[a]
        gp_sum = wp.vec3d(zero, zero, zero)
        for k in range(offsets[a], offsets[a + 1]):
            j = nbr[k]
            used, value = fit_source(j, a, n, p, dirichlet, origin, material, permeability, water_density, gravity,
                                     ghost_source, ghost_chain, q, plane_axis, plane_position, plane_sign, plane_kind,
                                     drainage, drained_lo, drained_hi, drained_pressure, head, inflow,
                                     water_table)  # fmt: skip
            if used == 1:
                r = q[j] - x
                vol = mass[j] / density[j]
                w0, wr, g0, M = add_to_fit(r, vol, h, w0, wr, g0, M)
                g = grad_W(-r, h) * vol
                wp_sum += f64(_W(wp.length(r), h) * vol) * value
                gp_sum += wp.vec3d(f64(g[0]), f64(g[1]), f64(g[2])) * value
        c, inv_den, Minv, e, corrected = finish_fit(w0, wr, g0, M)
        if corrected:
            fit = (wp_sum - (f64(c[0]) * gp_sum[0] + f64(c[1]) * gp_sum[1] + f64(c[2]) * gp_sum[2])) * f64(inv_den)
            out[a] = p[a] - fit

    @wp.kernel(enable_backward=False, module="unique")
    def assemble(
        first: int, h: real, dt: real, scale: f64, n: int, offsets: wp.array(dtype=wp.int32), nbr: wp.array(dtype=wp.int32),
        q: wp.array(dtype=vec3), origin: wp.array(dtype=vec3), mass: wp.array(dtype=real),
        density: wp.array(dtype=real), material: wp.array(dtype=wp.int32), permeability: wp.array(dtype=f64), inv_biot: wp.array(dtype=f64),
        water_density: wp.array(dtype=f64), gravity: vec3, v_star: wp.array(dtype=vec3),
        div_v_star: wp.array(dtype=f64), p_old: wp.array(dtype=f64), ghost_source: wp.array(dtype=wp.int32),
        ghost_chain: wp.array(dtype=wp.vec3i), plane_axis: wp.array(dtype=wp.int32),
        plane_position: wp.array(dtype=real), plane_sign: wp.array(dtype=real), plane_kind: wp.array(dtype=wp.int32),
        drainage: wp.array(dtype=wp.int32), drained_lo: wp.array(dtype=vec3), drained_hi: wp.array(dtype=vec3),
        drained_pressure: wp.array(dtype=f64), head: wp.array(dtype=f64), inflow: wp.array(dtype=f64), water_table: f64,
        dirichlet: wp.array(dtype=wp.int32), value: wp.array(dtype=f64),
        face_factor: wp.array(dtype=f64), momentum_image: wp.array(dtype=f64), eigenvalue: wp.array(dtype=real),
        exterior_threshold: real, lattice_sum: f64, rough: wp.array(dtype=f64), near_surface: wp.array(dtype=wp.int32),
        stabilisation: f64, interior_stabilisation: f64,
        weight: wp.array(dtype=f64), column: wp.array(dtype=wp.int32), diag: wp.array(dtype=f64),
        rhs: wp.array(dtype=f64),
    ):  # fmt: skip
        a = first + wp.tid()
        x = q[a]
        vol_a = f64(mass[a] / density[a]) * face_factor[a]  # a particle on a plane owns half its cell
        mat = material[a]
        k_a = permeability[mat]
        dt_rho_a = f64(dt) / f64(density[a])
        d = vol_a * inv_biot[mat] / f64(dt)
        b = d * p_old[a] - vol_a * div_v_star[a] - vol_a * inv_biot[mat] * water_density[mat] * f64(
            wp.dot(gravity, v_star[a]))
        eta2 = f64(ETA * ETA) * f64(h * h)
        present = zero  # Σ_b V_b m_ab over the neighbours there are [1/m²]
        for k in range(offsets[a], offsets[a + 1]):
            j = nbr[k]
            r = x - q[j]
            morris = -f64(wp.dot(r, grad_W(r, h))) / (f64(wp.dot(r, r)) + eta2) * scale
            vol_j = f64(mass[j] / density[j])
            present += vol_j * morris
            mat_j = material[j]
            k_j = permeability[mat_j]
            k_pair = zero  # twice the harmonic mean: flux continuity across layers of contrasting k
            if k_a + k_j > zero:
                k_pair = f64(4.0) * k_a * k_j / (k_a + k_j)
            w = vol_a * vol_j * (k_pair + dt_rho_a + f64(dt) / f64(density[j])) * morris
            w_dt = vol_a * vol_j * (dt_rho_a + f64(dt) / f64(density[j])) * morris
            d += w
            col = j
            s = f64(1.0)  # Darcy parity (the k part) ...
            cst = zero
            s_dt = f64(1.0)  # ... and momentum parity (the Δt/ρ part) of a ghost: p_ghost = s p_col + cst
            cst_dt = zero
            if j >= n:
                g = j - n
                col = ghost_source[g]
                # a pair meeting across a plane drains by its midpoint, as its mirror pair does: the
                # matrix stays symmetric where a drained extent ends
                s, cst, s_dt, cst_dt = ghost_affine(g, ghost_source, ghost_chain, q,
                                                    real(0.5) * (origin[a] + origin[col]), plane_axis,
                                                    plane_position, plane_sign, plane_kind, drainage, drained_lo,
                                                    drained_hi, drained_pressure, head, inflow, water_density[mat_j],
                                                    permeability[mat_j], gravity, water_table, 0)  # fmt: skip
            # a neighbour on an impermeable traction plane is its own odd mirror in the Δt/ρ part
            s_dt = s_dt * momentum_image[col]
            cst_dt = cst_dt * momentum_image[col]
            w_k = w - w_dt
            b += w_dt * (p_old[a] - (s_dt * p_old[col] + cst_dt))  # −V ∇·((Δt/ρ)∇pⁿ)
            b += w_k * cst + w_dt * cst_dt
            if dirichlet[a] == 0 and dirichlet[col] == 0 and mat_j == mat:  # damps p's roughness, drains nothing
                theta = interior_stabilisation
                if near_surface[a] == 1 or near_surface[col] == 1:
                    theta = stabilisation
                b -= theta * w_dt * (rough[a] - rough[col])
            coefficient = w_k * s + w_dt * s_dt  # the ghost's parities folded in: A x = diag x − Σ weight x[column]
            if dirichlet[col] == 1:
                b += coefficient * value[col]
                coefficient = zero
            if dirichlet[a] == 1:
                coefficient = zero
            weight[k] = coefficient
            column[k] = col
        if eigenvalue[a] < exterior_threshold and lattice_sum > present:
            # impermeable free surface: the Δt/ρ part gains the pairs missing outside, with a zero
            # increment there, as the predictor's surface term takes the pressure outside as zero
            exterior = vol_a * f64(2.0) * dt_rho_a * (lattice_sum - present)
            d += exterior
            b += exterior * p_old[a]
        if dirichlet[a] == 1:
            # p = p̄, scaled by the diagonal the row would have: with a unit diagonal a drained head of
            # kPa outweighed every other row's right-hand side in ‖b‖, the solve met its relative
            # tolerance without an iteration and the pressure froze (a ponded column stopped at 65-350 Pa off)
            if d == zero:
                d = f64(1.0)
            b = d * value[a]
        diag[a] = d
        rhs[a] = b

    @wp.kernel(enable_backward=False, module="unique")
    def difference(first: int, a_: wp.array(dtype=f64), b_: wp.array(dtype=f64), out: wp.array(dtype=f64)):
        i = first + wp.tid()
        out[i] = a_[i] - b_[i]

    return dict(
        pressure_ghosts=pressure_ghosts, fit_vector_at_virtual=fit_vector_at_virtual,
        fit_scalar_at_virtual=fit_scalar_at_virtual, divergence_at_real=divergence_at_real,
        gradient_at_real=gradient_at_real, correct_velocity=correct_velocity, darcy=darcy, mark_dirichlet=mark_dirichlet,
        mark_near_surface=mark_near_surface, roughness=roughness, assemble=assemble,
        difference=difference,
    )  # fmt: skip


class PressureProjection:
    """Assembles and solves the pressure equation and corrects the velocity (two-set scheme)."""

    def __init__(self, model: Model, solver):
        self.model, self.solver = model, solver
        m, dev = model, model.device
        n, ne, nv = m.particle_count, m.particle_capacity, m.virtual_capacity
        f64 = wp.float64
        self.k = _kernels(m.spec)
        settings = m.scene.pressure
        self.settings = settings
        ratio = m.scene.simulation.smoothing_ratio
        self.scale = laplacian_scale(m.spec.kernel, m.spec.dim, ratio)
        self.lattice_sum = lattice_morris_sum(m.spec.kernel, m.spec.dim, m.dx, ratio)
        impermeable_surface = settings.free_surface == "impermeable"
        self.exterior_threshold = m.scene.simulation.free_surface_threshold if impermeable_surface else 0.0
        """Correction eigenvalue below which a particle gains the exterior pairs (0: none do)."""
        self.water_on_surface = 1.0 if impermeable_surface else 0.0
        """Weight of the pore pressure in the surface band's weak traction term: 1 at an impermeable free
        surface (pushed as if the pressure were zero outside), 0 at a drained one, whose Dirichlet rows
        hold the zero pressure that the fitted gradient already carries (pushing with the particle's
        own pressure as well fed back on it: docs/method.md, *Drained free surfaces*)."""
        self.div_v_star = wp.zeros(n, dtype=f64, device=dev)
        self.virtual_v_star = wp.zeros(nv, dtype=m.spec.vec3, device=dev)
        self.p_old = wp.zeros(ne, dtype=f64, device=dev)
        self.dp = wp.zeros(ne, dtype=f64, device=dev)
        self.virtual_dp = wp.zeros(nv, dtype=f64, device=dev)
        self.grad = wp.zeros(n, dtype=wp.vec3d, device=dev)
        self.dirichlet = wp.zeros(n, dtype=wp.int32, device=dev)
        self.value = wp.zeros(n, dtype=f64, device=dev)
        self.diag = wp.zeros(n, dtype=f64, device=dev)
        self.rhs = wp.zeros(n, dtype=f64, device=dev)
        self.roughness = wp.zeros(n, dtype=f64, device=dev)
        self.near_surface = wp.zeros(n, dtype=wp.int32, device=dev)
        self.linear = LinearSolver(n, dev, settings)
        self.weight = self.column = None
        on, val = self._drained_plane_particles()
        self.on_drained = wp.array(on, dtype=wp.int32, device=dev)
        self.face_factor = wp.array(self._face_factor(), dtype=f64, device=dev)
        self.momentum_image = wp.array(self._momentum_image(on), dtype=f64, device=dev)
        self.drained_value = wp.array(val, dtype=f64, device=dev)
        self.iterations: list[int] = []
        self.residuals: list[float] = []
        self.failures = 0
        self._surface_checked = False
        self.surface_warning: str | None = None
        """The warning of ``_warn_unstable_free_surface``, if the run's free surface is in that regime."""

    def reset_statistics(self) -> None:
        """Forget the solves so far (the runner's warm-up step is not part of the run)."""
        self.iterations.clear()
        self.residuals.clear()
        self.failures = 0
        self._surface_checked = False  # its warning, if any, comes again with the run's first step
        self.surface_warning = None

    def _face_factor(self) -> np.ndarray:
        """½ per plane a particle lies on: the share of its cell inside the body. Scaling its row by
        it keeps the matrix symmetric once ghosts are folded onto their sources (a particle on a
        plane is its own mirror, so it meets each neighbour's mirror as well as the neighbour)."""
        m = self.model
        factor = np.ones(m.particle_count)
        for a, planes in zip(m.constraint_particle.numpy(), m.constraint_planes.numpy().reshape(-1, 3)):
            factor[a] = 0.5 ** int(np.count_nonzero(planes >= 0))
        return factor

    def _momentum_image(self, on_drained: np.ndarray) -> np.ndarray:
        """Weight of each owned particle as a neighbour in the Δt/ρ part of the matrix: 0 on an
        impermeable traction plane, else 1. A particle on a plane stands for itself and its mirror
        images, which coincide with it; the increment is odd across such a plane (``ghost_affine``),
        so the images' mean is zero there. The particle's own row already sees its neighbours'
        mirrors that way: without this the matrix was not symmetric (CG stalled on a loaded block,
        docs/method.md). On a drained plane the particle is a Dirichlet row and keeps weight 1."""
        m = self.model
        image = np.ones(m.particle_count)
        kinds = m.plane_kind.numpy()
        for a, planes in zip(m.constraint_particle.numpy(), m.constraint_planes.numpy().reshape(-1, 3)):
            if on_drained[a] == 0 and np.any(kinds[planes[planes >= 0]] == PLANE_TRACTION):
                image[a] = 0.0
        return image

    def _drained_plane_particles(self):
        """Owned particles lying on drained planes and their prescribed excess pressure (host)."""
        m, pw = self.model, self.model.pore
        n = m.particle_count
        on, val = np.zeros(n, np.int32), np.zeros(n)
        drainage = pw.plane_drainage.numpy()
        pressure, head = pw.plane_pressure.numpy(), pw.plane_head.numpy()
        x = m.particle_x0
        rho_w = pw.material_water_density.numpy()[m.particle_material.numpy()[:n]]
        hydro = pw.hydrostatic(x, rho_w)
        g = float(np.linalg.norm(pw.gravity))
        axes = m.plane_axis.numpy()
        for a, planes in zip(m.constraint_particle.numpy(), m.constraint_planes.numpy().reshape(-1, 3)):
            for p in planes[planes >= 0]:
                if drainage[p] == 1 and pw.planes[p].covers(x[a : a + 1], axes[p], EXTENT_TOLERANCE * m.dx)[0]:
                    total = pressure[p] if np.isnan(head[p]) else rho_w[a] * g * (head[p] - x[a, 1])
                    on[a], val[a] = 1, total - hydro[a]
        return on, val

    def _plane_args(self):
        m, pw, b = self.model, self.model.pore, self.solver.boundaries
        return [m.plane_axis, b.plane_position, m.plane_sign, m.plane_kind, pw.plane_drainage, pw.plane_drained_lo,
                pw.plane_drained_hi, pw.plane_pressure, pw.plane_head, pw.plane_inflow]  # fmt: skip

    def update_ghosts(self, q, p, homogeneous: bool, virtual: bool = False, momentum: bool = False) -> None:
        """Pressure-parity values of the ghosts of the real (or virtual) set in ``p`` (with ``momentum``:
        the parity of a pressure increment in the velocity correction, see ``ghost_affine``)."""
        m, pw = self.model, self.model.pore
        if virtual:
            n, src, chain, mat, count, origin = (m.virtual_count, m.virtual_ghost_source, m.virtual_ghost_planes,
                                                 m.virtual_material, m.virtual_ghost_count, m.virtual_origin)  # fmt: skip
        else:
            n, src, chain, mat, count, origin = (m.particle_count, m.particle_ghost_source, m.particle_ghost_planes,
                                                 m.particle_material, m.particle_ghost_count,
                                                 m.particle_origin)  # fmt: skip
        args = self._plane_args()
        launch(self.k["pressure_ghosts"], count,
               [n, src, chain, q, origin, mat, args[0], args[1], args[2], *args[3:], pw.material_water_density,
                pw.material_permeability, m.spec.vec3(*pw.gravity), wp.float64(pw.water_table), int(homogeneous), int(momentum), p],
               m.device)  # fmt: skip

    # -- the projection ---------------------------------------------------------------------------
    def project(self, si, so, dt: float) -> None:
        """Given v* in ``so.particle_v`` and pⁿ in ``si``, solve for pⁿ⁺¹ into ``so`` and correct v."""
        m, pw, sol = self.model, self.model.pore, self.solver
        real, dev, n = m.spec.real, m.device, m.particle_count
        h = real(m.h)
        rf, vf = sol.real_fits, sol.virtual_fits
        # ∇·v* along real → virtual → real (geometry at tⁿ, v* with kinematic ghost parities)
        sol.boundaries.update_real_ghosts(si.particle_q, so.particle_v, so.particle_stress, so.particle_density,
                                          si.particle_pore_pressure)
        nl_v = sol.virtual_to_real
        launch_rows(self.k["fit_vector_at_virtual"], m.virtual_count,
               [h, nl_v.offsets, nl_v.indices, si.virtual_q, vf.c, vf.inv_den, vf.minv, si.particle_q,
                m.particle_mass, si.particle_density, so.particle_v, self.virtual_v_star], dev)  # fmt: skip
        sol.boundaries.update_virtual_ghosts(si.virtual_q, self.virtual_v_star, sol.virtual_stress,
                                             si.virtual_density, sol.virtual_p)  # fmt: skip
        nl_r = sol.real_to_virtual
        launch_rows(self.k["divergence_at_real"], n,
               [h, nl_r.offsets, nl_r.indices, si.particle_q, rf.c, rf.inv_den, rf.minv, rf.e, si.virtual_q,
                m.virtual_mass, si.virtual_density, self.virtual_v_star, self.div_v_star], dev)  # fmt: skip
        # assemble on the real-real list
        nl = sol.real_to_real
        if self.weight is None or self.weight.shape[0] < nl.indices.shape[0]:
            size = nl.indices.shape[0]
            self.weight = wp.zeros(size, dtype=wp.float64, device=dev)
            self.column = wp.zeros(size, dtype=wp.int32, device=dev)
        wp.copy(self.p_old, si.particle_pore_pressure)
        # the solve's unknown: a copy of pⁿ (owned part), drained rows at their values
        x = so.particle_pore_pressure
        wp.copy(x, self.p_old, count=n)
        gravity = m.spec.vec3(*pw.gravity)
        drained_surface = int(self.settings.free_surface == "drained")
        launch(self.k["mark_dirichlet"], n,
               [0, n, self.on_drained, self.drained_value, rf.smallest_eigenvalue, drained_surface, si.particle_q,
                m.particle_material, pw.material_water_density, gravity, wp.float64(pw.water_table), self.dirichlet,
                self.value, x], dev)  # fmt: skip
        if not self._surface_checked:
            self._surface_checked = True
            self._warn_unstable_free_surface(si, dt)
        args = self._plane_args()
        if self.settings.stabilisation > 0.0 or self.settings.interior_stabilisation > 0.0:
            launch_rows(self.k["mark_near_surface"], n,
                        [n, nl.offsets, nl.indices, rf.smallest_eigenvalue,
                         real(m.scene.simulation.free_surface_threshold), self.near_surface], dev)  # fmt: skip
            launch_rows(self.k["roughness"], n,
                   [h, n, nl.offsets, nl.indices, si.particle_q, m.particle_origin, m.particle_mass,
                    si.particle_density, m.particle_material, pw.material_permeability, pw.material_water_density,
                    gravity, m.particle_ghost_source, m.particle_ghost_planes, *args, wp.float64(pw.water_table),
                    self.near_surface, int(self.settings.interior_stabilisation > 0.0), self.dirichlet, self.p_old,
                    self.roughness], dev)  # fmt: skip
        launch_rows(self.k["assemble"], n,
               [h, real(dt), wp.float64(self.scale), n, nl.offsets, nl.indices, si.particle_q, m.particle_origin,
                m.particle_mass,
                si.particle_density, m.particle_material, pw.material_permeability, pw.material_inv_biot,
                pw.material_water_density, gravity, so.particle_v, self.div_v_star, self.p_old,
                m.particle_ghost_source, m.particle_ghost_planes, *args, wp.float64(pw.water_table), self.dirichlet,
                self.value, self.face_factor, self.momentum_image, rf.smallest_eigenvalue,
                real(self.exterior_threshold), wp.float64(self.lattice_sum), self.roughness, self.near_surface,
                wp.float64(self.settings.stabilisation), wp.float64(self.settings.interior_stabilisation), self.weight, self.column, self.diag, self.rhs], dev)  # fmt: skip
        iterations, rel = self.linear.solve(self._matrix(), self.rhs, x)
        self.iterations.append(iterations)
        self.residuals.append(rel)
        if not rel <= self.settings.tolerance:
            self.failures += 1
            message = (f"pressure solve missed its tolerance {self.settings.tolerance:g}: relative residual "
                       f"{rel:.3g} after {iterations} iterations ({self.settings.solver})")  # fmt: skip
            if self.settings.on_failure == "stop":
                raise SimulationError(message)
            if self.failures == 1:
                warnings.warn(message + " (further misses are counted in run.json)", stacklevel=2)
        # v = v* − (Δt/ρ) ∇(p − pⁿ), along the same path
        self.update_ghosts(si.particle_q, x, homogeneous=False)
        launch(self.k["difference"], m.particle_count, [0, x, self.p_old, self.dp], dev)
        self.update_ghosts(si.particle_q, self.dp, homogeneous=True, momentum=True)
        self._gradient(si, self.dp, homogeneous=True, momentum=True)
        launch(self.k["correct_velocity"], n, [0, real(dt), self.grad, so.particle_density, so.particle_v], dev)

    def _warn_unstable_free_surface(self, si, dt: float) -> None:
        """Warn once if the free surface found at the first step is less permeable than it can be
        stably: k ρ/Δt below the limit of its kind (``DAMPED_STABLE_SURFACE_RATIO`` with θ = 1, else
        ``STABLE_SURFACE_RATIO``) on one of its particles (a drained surface's Dirichlet rows, an
        impermeable one's particles that gain the exterior pairs)."""
        m = self.model
        n = m.particle_count
        kind = self.settings.free_surface
        limits = DAMPED_STABLE_SURFACE_RATIO if self.settings.stabilisation == 1.0 else STABLE_SURFACE_RATIO
        limit = limits[kind]
        if kind == "drained":
            surface = (self.dirichlet.numpy()[:n] == 1) & (self.on_drained.numpy()[:n] == 0)
        else:
            surface = self.solver.real_fits.smallest_eigenvalue.numpy()[:n] < self.exterior_threshold
        if not surface.any() or limit == 0.0:
            return
        material = m.particle_material.numpy()[:n][surface]
        ratio = m.pore.material_permeability.numpy()[material] * si.particle_density.numpy()[:n][surface] / dt
        worst = int(np.argmin(ratio))
        if ratio[worst] < limit:
            name = list(m.scene.materials)[material[worst]]
            courant = m.scene.simulation.courant * ratio[worst] / limit
            self.surface_warning = (
                f"material {name!r} under a free surface (pressure.free_surface = {kind!r}): k ρ/Δt = "
                f"{ratio[worst]:.3g} is below {limit}, where the pore pressure under such a surface can grow without "
                "bound (docs/method.md, Known limits); make that face a plane (a zero-traction load with its "
                f"drainage), lower simulation.courant to {courant:.2g}"
                + (" or set pressure.interior_stabilisation (0.05 removed the slow mode measured)"
                   if kind == "drained" and self.settings.stabilisation == 1.0 else ""))
            warnings.warn(self.surface_warning, stacklevel=2)

    def _gradient(self, state, values, homogeneous: bool, momentum: bool = False) -> None:
        """``self.grad`` = ∇values at the real particles via the virtual points (geometry of ``state``);
        ``values`` has its real ghosts set; virtual ghosts get the same parity."""
        m, sol = self.model, self.solver
        h, dev = m.spec.real(m.h), m.device
        rf, vf = sol.real_fits, sol.virtual_fits
        nl_v, nl_r = sol.virtual_to_real, sol.real_to_virtual
        launch_rows(self.k["fit_scalar_at_virtual"], m.virtual_count,
               [h, nl_v.offsets, nl_v.indices, state.virtual_q, vf.c, vf.inv_den, vf.minv, state.particle_q,
                m.particle_mass, state.particle_density, values, self.virtual_dp], dev)  # fmt: skip
        self.update_ghosts(state.virtual_q, self.virtual_dp, homogeneous=homogeneous, virtual=True, momentum=momentum)
        launch_rows(self.k["gradient_at_real"], m.particle_count,
               [h, nl_r.offsets, nl_r.indices, state.particle_q, rf.c, rf.inv_den, rf.minv, rf.e, state.virtual_q,
                m.virtual_mass, state.virtual_density, self.virtual_dp, self.grad], dev)  # fmt: skip

    def darcy_velocity(self, state) -> np.ndarray:
        """(N,3) Darcy velocity w = −k ∇p [m/s] of ``state``, through the two-set path (host copy).

        Uses the neighbour lists and fit data of the step that produced ``state`` (its geometry
        differs from theirs by one step's motion)."""
        m = self.model
        self.update_ghosts(state.particle_q, state.particle_pore_pressure, homogeneous=False)
        self._gradient(state, state.particle_pore_pressure, homogeneous=False)
        w = wp.zeros(m.particle_count, dtype=wp.vec3d, device=m.device)
        launch(self.k["darcy"], m.particle_count,
               [self.grad, m.particle_material, m.pore.material_permeability, w], m.device)  # fmt: skip
        return w.numpy()

    def _matrix(self):
        return [self.solver.real_to_real.offsets, self.weight, self.column, self.diag]
