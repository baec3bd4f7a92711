"""Warp kernels of the pore-pressure projection (float64 throughout) and the Morris Laplacian's lattice
constants; :mod:`warpsph.stages.pressure` assembles, solves and corrects with them, and
:mod:`warpsph.stages.groundwater_kernels` shares ``ghost_affine`` (docs/method.md, *Saturated soil*).
"""

import functools
import math

import numpy as np
import warp as wp

from warpsph.model import PLANE_TRACTION
from warpsph.pore_water import water_struct
from warpsph.sph.kernels import kernel_derivative, smoothing_functions
from warpsph.sph.operators import fit_parts, operator_functions, used_vectors
from warpsph.sph.spec import Spec
from warpsph.stages.boundaries import plane_functions, planes_struct
from warpsph.stages.corrections import fits_struct
from warpsph.stages.surface_water import SurfaceWater, reservoir_pressure, water_against_surface

DRAINED_SURFACE_EIGENVALUE = 0.6
"""Real particles whose correction eigenvalue is below this are on a free surface (≈0.5 on a flat
face, ≈0.66 one row in): with a drained free surface their pore pressure is zero."""
ETA = 0.1
"""Morris regularisation η/h."""
NEAR_FREE_SURFACE, NEAR_SEALED_FACE = 1, 2
"""``mark_near_surface`` marks: in or next to a free surface's band, on or next to a loaded impermeable
face (0 elsewhere)."""
DRAINING_RATIO = 0.01
"""k ρ/Δt [-] of a pair (its Darcy weight over its Δt/ρ weight) at which the roughness damping away from
free surfaces falls to half its weight: below about 0.005 a step about rest of a plane-bounded block
grows, above 0.05 the Darcy part alone damps the roughness (measured, docs/method.md *Pore-pressure
roughness damping*)."""
LOW_PERMEABILITY_WEIGHT = 0.02
"""Weight of the roughness damping, relative to ``pressure.stabilisation``, away from free surfaces and
loaded impermeable faces where the Darcy part does not drain (k ρ/Δt → 0); faded by DRAINING_RATIO."""


@wp.func
def faded_by_draining(weight: wp.float64, draining: wp.float64) -> wp.float64:
    """A roughness-damping weight faded as a pair's Darcy part drains, ``draining`` = k ρ/Δt [-]
    (halved at DRAINING_RATIO). Called from kernels and, with ``wp.float64`` arguments, from Python."""
    return weight / (wp.float64(1.0) + draining / wp.float64(DRAINING_RATIO))


@wp.func
def fold_conditions(coefficient: wp.float64, rhs: wp.float64, held_column: int, column_value: wp.float64,
                    held_row: int):  # fmt: skip
    """(weight, rhs) of a pair with the Dirichlet rows folded in: a held neighbour's value moves to the
    right-hand side, and a held row keeps no off-diagonal weight (the matrix stays symmetric)."""
    w = coefficient
    b = rhs
    if held_column == 1:
        b += w * column_value
        w = wp.float64(0.0)
    if held_row == 1:
        w = wp.float64(0.0)
    return w, b


@wp.func
def held_row(diagonal: wp.float64, value: wp.float64):
    """(diagonal, rhs) of a row held at ``value``: p = p̄ scaled by the diagonal the row would have
    (with a unit diagonal a drained head of kPa outweighed every other row's right-hand side in ‖b‖, the
    solve met its relative tolerance without an iteration and the pressure froze: a ponded column
    stopped at 65-350 Pa off)."""
    d = diagonal
    if d == wp.float64(0.0):
        d = wp.float64(1.0)
    return d, d * value


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
def pressure_kernels(spec: Spec):
    """The projection's Warp kernels for ``spec``, by name."""
    real, vec3 = spec.real, spec.vec3
    f64 = wp.float64
    _fit, fit_weights, _inv, _eig = operator_functions(spec)
    full_vector = used_vectors(spec)[1]
    add_to_fit, finish_fit, _inv, _unused = fit_parts(spec)

    _W, grad_W = smoothing_functions(spec)
    _traction, drainage_here, on_plate, _plate_velocity = plane_functions(spec)
    Planes = planes_struct(spec)
    Fits = fits_struct(spec)
    Water = water_struct(vec3)
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
                     q: wp.array(dtype=vec3), where: vec3, planes: Planes, water: Water, mat: int, k: f64,
                     homogeneous: int):  # fmt: skip
        """(s, c, s_m, c_m) with p_ghost = s p_source + c for ghost g of a source of material ``mat``, whose
        permeability there is k (c = 0 when ``homogeneous``); each plane drains (odd parity) where the
        initial position ``where`` lies in its drained extent.

        (s_m, c_m) is the parity of the pressure *increment* in the velocity correction: odd also at
        impermeable traction planes, whose total traction t̄ = σ′n − p n is prescribed, so that the
        correction −(Δt/ρ)∇δp leaves it unchanged (the effective stress takes up δp in the next
        predictor); water still does not cross them ((s, c) even)."""
        x = q[source[g]]
        s = f64(1.0)
        c = zero
        s_m = f64(1.0)
        c_m = zero
        on = chain[g]
        for i in range(3):
            p = on[i]
            if p >= 0:
                m = planes.axis[p]
                kind = drainage_here(p, where, m, planes)
                traction = planes.kind[p] == PLANE_TRACTION and not on_plate(p, where, m, planes)
                if kind == 1:
                    s = -s
                    c = -c
                    s_m = -s_m
                    c_m = -c_m
                    if homogeneous == 0:
                        xp = x
                        xp[m] = planes.position[p]
                        excess = f64(2.0) * plane_excess(p, xp, water.density[mat], water.gravity,
                                                         water.water_table, planes.pressure, planes.head)  # fmt: skip
                        c += excess
                        c_m += excess
                else:
                    if kind == 2 and homogeneous == 0 and k > zero:
                        depth = f64(planes.sign[p] * (planes.position[p] - x[m]))
                        c += f64(2.0) * depth * planes.inflow[p] / k
                        if not traction:
                            c_m += f64(2.0) * depth * planes.inflow[p] / k
                    if traction:
                        s_m = -s_m
                        c_m = -c_m
                x[m] = real(2.0) * planes.position[p] - x[m]
        return s, c, s_m, c_m

    @wp.kernel(enable_backward=False, module="unique")
    def pressure_ghosts(
        n_owned: int, source: wp.array(dtype=wp.int32), chain: wp.array(dtype=wp.vec3i), q: wp.array(dtype=vec3),
        origin: wp.array(dtype=vec3), material: wp.array(dtype=wp.int32), planes: Planes, water: Water,
        homogeneous: int, momentum: int, p: wp.array(dtype=f64),
    ):  # fmt: skip
        g = wp.tid()
        src = source[g]
        mat = material[src]
        s, c, s_m, c_m = ghost_affine(g, source, chain, q, origin[src], planes, water, mat, water.permeability[mat],
                                      homogeneous)  # fmt: skip
        if momentum == 1:
            s = s_m
            c = c_m
        p[n_owned + g] = s * p[src] + c

    def fit_at_virtual_kernel(value_type):
        """The kernel that fits a field of the real set (``value_type``: vec3 or f64) at the virtual
        points, out_i = Σ_b V_b ψ_b values_b with each point's linear-fit data and the sources' volumes V."""
        weight_type = f64 if value_type is f64 else real  # a scalar f64 field sums in f64

        @wp.kernel(enable_backward=False, module="unique")
        def kernel(
            first: int, h: real, offsets: wp.array(dtype=wp.int32), nbr: wp.array(dtype=wp.int32),
            vq: wp.array(dtype=vec3), fits: Fits, xs: wp.array(dtype=vec3), volume: wp.array(dtype=real),
            values: wp.array(dtype=value_type), out: wp.array(dtype=value_type),
        ):  # fmt: skip
            i = first + wp.tid()
            x = vq[i]
            acc = value_type(real(0.0))
            for k in range(offsets[i], offsets[i + 1]):
                b = nbr[k]
                psi, phi = fit_weights(xs[b] - x, h, fits.c[i], fits.inv_den[i], fits.minv[i])
                acc += weight_type(volume[b] * psi) * values[b]
            out[i] = acc

        return kernel

    fit_vector_at_virtual = fit_at_virtual_kernel(vec3)
    fit_scalar_at_virtual = fit_at_virtual_kernel(f64)

    @wp.kernel(enable_backward=False, module="unique")
    def divergence_at_real(
        first: int, h: real, offsets: wp.array(dtype=wp.int32), nbr: wp.array(dtype=wp.int32), q: wp.array(dtype=vec3),
        fits: Fits, xs: wp.array(dtype=vec3), volume: wp.array(dtype=real), values: wp.array(dtype=vec3),
        out: wp.array(dtype=f64),
    ):  # fmt: skip
        a = first + wp.tid()
        x = q[a]
        fit = vec3(real(0.0), real(0.0), real(0.0))
        div = zero
        for k in range(offsets[a], offsets[a + 1]):
            b = nbr[k]
            vol = volume[b]
            psi, phi = fit_weights(xs[b] - x, h, fits.c[a], fits.inv_den[a], fits.minv[a])
            fit += (vol * psi) * values[b]
            div += f64(vol * wp.dot(phi, values[b]))
        out[a] = div - f64(wp.dot(full_vector(fits.e[a]), fit))

    @wp.kernel(enable_backward=False, module="unique")
    def gradient_at_real(
        first: int, h: real, offsets: wp.array(dtype=wp.int32), nbr: wp.array(dtype=wp.int32), q: wp.array(dtype=vec3),
        fits: Fits, xs: wp.array(dtype=vec3), volume: wp.array(dtype=real), values: wp.array(dtype=f64),
        out: wp.array(dtype=wp.vec3d),
    ):  # fmt: skip
        """∇f at real particles fitted from the virtual points' f."""
        a = first + wp.tid()
        x = q[a]
        fit = zero
        grad = wp.vec3d(zero, zero, zero)
        for k in range(offsets[a], offsets[a + 1]):
            b = nbr[k]
            vol = volume[b]
            psi, phi = fit_weights(xs[b] - x, h, fits.c[a], fits.inv_den[a], fits.minv[a])
            fit += f64(vol * psi) * values[b]
            grad += wp.vec3d(f64(phi[0]), f64(phi[1]), f64(phi[2])) * (f64(vol) * values[b])
        ea = full_vector(fits.e[a])
        out[a] = grad - wp.vec3d(f64(ea[0]), f64(ea[1]), f64(ea[2])) * fit

    @wp.kernel(enable_backward=False, module="unique")
    def correct_velocity(first: int, dt: real, grad_dp: wp.array(dtype=wp.vec3d), density: wp.array(dtype=real),
                         v: wp.array(dtype=vec3)):  # fmt: skip
        """v −= (Δt/ρ) ∇Δp."""
        a = first + wp.tid()
        g = grad_dp[a] * (f64(dt) / f64(density[a]))
        v[a] = v[a] - vec3(real(g[0]), real(g[1]), real(g[2]))

    @wp.kernel(enable_backward=False, module="unique")
    def darcy(grad_p: wp.array(dtype=wp.vec3d), material: wp.array(dtype=wp.int32), water: Water,
              w: wp.array(dtype=wp.vec3d)):  # fmt: skip
        """w = −k ∇p_excess [m/s]."""
        a = wp.tid()
        w[a] = -water.permeability[material[a]] * grad_p[a]

    @wp.kernel(enable_backward=False, module="unique")
    def mark_dirichlet(
        first: int, n: int, on_drained: wp.array(dtype=wp.int32), drained_value: wp.array(dtype=f64),
        eigenvalue: wp.array(dtype=real), drained_surface: int, q: wp.array(dtype=vec3),
        material: wp.array(dtype=wp.int32), water: Water, surface_water: SurfaceWater,
        dirichlet: wp.array(dtype=wp.int32), value: wp.array(dtype=f64), p_start: wp.array(dtype=f64),
    ):  # fmt: skip
        """Drained rows and their values: drained planes' particles, free-surface particles under a
        reservoir (at its pressure) and, with a drained free surface, the other free-surface particles
        (at zero); a drained row's unknown starts the solve at its value (decoupled, it then stays there
        exactly)."""
        a = first + wp.tid()
        dirichlet[a] = 0
        value[a] = zero
        if on_drained[a] == 1:
            dirichlet[a] = 1
            value[a] = drained_value[a]
        elif eigenvalue[a] < real(DRAINED_SURFACE_EIGENVALUE):
            x = q[a]
            rho_w = water.density[material[a]]
            x0, x1, x2 = f64(x[0]), f64(x[1]), f64(x[2])
            wet, pressure = reservoir_pressure(surface_water, rho_w, x0, x1, x2)
            if wet == 1 or drained_surface == 1:
                dirichlet[a] = 1  # p_w = p_res (0 where dry): the excess is p_res minus the hydrostatic pressure
                value[a] = -water_against_surface(surface_water, rho_w, x0, x1, x2)
        if dirichlet[a] == 1:
            p_start[a] = value[a]

    @wp.func
    def source_of(j: int, n: int, ghost_source: wp.array(dtype=wp.int32)):
        """The owned particle that neighbour j is or mirrors."""
        if j < n:
            return j
        return ghost_source[j - n]

    @wp.func
    def fit_source(j: int, a: int, n: int, p: wp.array(dtype=f64), dirichlet: wp.array(dtype=wp.int32),
                   origin: wp.array(dtype=vec3), material: wp.array(dtype=wp.int32), water: Water,
                   ghost_source: wp.array(dtype=wp.int32), ghost_chain: wp.array(dtype=wp.vec3i),
                   q: wp.array(dtype=vec3), planes: Planes):  # fmt: skip
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
                                      planes, water, mat, water.permeability[mat], 0)  # fmt: skip
        if s < zero:
            return 0, zero
        return 1, s * p[src] + c

    @wp.kernel(enable_backward=False, module="unique")
    def mark_near_surface(first: int, n: int, offsets: wp.array(dtype=wp.int32), nbr: wp.array(dtype=wp.int32),
                          ghost_source: wp.array(dtype=wp.int32), eigenvalue: wp.array(dtype=real),
                          surface_band: real, sealed_face: wp.array(dtype=wp.int32),
                          near_surface: wp.array(dtype=wp.int32)):  # fmt: skip
        """near_surface = NEAR_FREE_SURFACE in a free surface's band (correction eigenvalue below
        ``surface_band``) and on the band's neighbours (a ghost stands for its source), else
        NEAR_SEALED_FACE on a loaded impermeable face's particles and their neighbours, else 0: where
        the roughness damping acts on a pair beyond its interior weight."""
        a = first + wp.tid()
        near = eigenvalue[a] < surface_band
        sealed = sealed_face[a] == 1
        for k in range(offsets[a], offsets[a + 1]):
            j = source_of(nbr[k], n, ghost_source)
            near = near or eigenvalue[j] < surface_band
            sealed = sealed or sealed_face[j] == 1
        near_surface[a] = wp.where(near, NEAR_FREE_SURFACE, wp.where(sealed, NEAR_SEALED_FACE, 0))

    @wp.func
    def fitted_pressure(
        a: int, with_self: int, h: real, n: int, offsets: wp.array(dtype=wp.int32), nbr: wp.array(dtype=wp.int32),
        q: wp.array(dtype=vec3), origin: wp.array(dtype=vec3), volume: wp.array(dtype=real),
        material: wp.array(dtype=wp.int32), water: Water,
        ghost_source: wp.array(dtype=wp.int32), ghost_chain: wp.array(dtype=wp.vec3i), planes: Planes,
        dirichlet: wp.array(dtype=wp.int32), p: wp.array(dtype=f64),
    ):  # fmt: skip
        """(Πp [Pa], corrected, found): the linear fit of p at particle a over the neighbours
        ``fit_source`` admits, and a itself if ``with_self`` (else neither a nor its mirror images);
        corrected = 0 where the fit falls back to a Shepard mean, found = 0 where no source has
        weight. The value fit Σ V ψ p = (Σ V W p − c·Σ V g p)/den is summed with the fit's moments
        in one pass."""
        x = q[a]
        origin_a = vec3(real(0.0), real(0.0), real(0.0))
        w0, wr, g0, M = real(0.0), origin_a, origin_a, spec.mat33(real(0.0))
        wp_sum = zero
        gp_sum = wp.vec3d(zero, zero, zero)
        if with_self == 1:
            w0, wr, g0, M, w, g = add_to_fit(origin_a, volume[a], h, w0, wr, g0, M)
            wp_sum = f64(w) * p[a]
        for k in range(offsets[a], offsets[a + 1]):
            j = nbr[k]
            if with_self == 1 or source_of(j, n, ghost_source) != a:
                used, value = fit_source(j, a, n, p, dirichlet, origin, material, water, ghost_source, ghost_chain,
                                         q, planes)  # fmt: skip
                if used == 1:
                    w0, wr, g0, M, w, g = add_to_fit(q[j] - x, volume[j], h, w0, wr, g0, M)
                    wp_sum += f64(w) * value
                    gp_sum += wp.vec3d(f64(g[0]), f64(g[1]), f64(g[2])) * value
        if w0 <= real(0.0):
            return zero, 0, 0
        c, inv_den, Minv, e, corrected = finish_fit(w0, wr, g0, M)
        fit = (wp_sum - (f64(c[0]) * gp_sum[0] + f64(c[1]) * gp_sum[1] + f64(c[2]) * gp_sum[2])) * f64(inv_den)
        return fit, wp.where(corrected, 1, 0), 1

    def pressure_fit_kernel(sealed_faces: bool):
        """The kernel that fits p over each selected particle's neighbours (``fitted_pressure``):

        - ``roughness`` (``sealed_faces`` False): out = p − Πp [Pa], Πp over the particle itself and
          the neighbours ``fit_source`` admits, so a drained boundary's jump is not seen and linear
          fields give zero; 0 on Dirichlet rows, where the fit is not corrected, and (unless
          ``everywhere``) where neither the particle nor a neighbour is ``selected`` (near a free
          surface or a loaded impermeable face), since no damped pair reads it there.
        - ``extrapolate_to_sealed_faces`` (True): out = p, except on the ``selected`` particles (those
          on a loaded impermeable face), where out = Πp over the neighbours and their even images
          across the face, without the particle and its own images (∂p/∂n = 0): an increment on
          such a particle moves nothing, so its own row cannot set its pressure (docs/method.md,
          *Loaded impermeable faces*).
        """

        @wp.kernel(enable_backward=False, module="unique")
        def kernel(
            first: int, h: real, n: int, offsets: wp.array(dtype=wp.int32), nbr: wp.array(dtype=wp.int32),
            q: wp.array(dtype=vec3), origin: wp.array(dtype=vec3), volume: wp.array(dtype=real),
            material: wp.array(dtype=wp.int32), water: Water,
            ghost_source: wp.array(dtype=wp.int32), ghost_chain: wp.array(dtype=wp.vec3i), planes: Planes,
            selected: wp.array(dtype=wp.int32), everywhere: int, dirichlet: wp.array(dtype=wp.int32),
            p: wp.array(dtype=f64), out: wp.array(dtype=f64),
        ):  # fmt: skip
            a = first + wp.tid()
            if wp.static(sealed_faces):
                out[a] = p[a]
                needed = selected[a] == 1
            else:
                out[a] = zero
                needed = everywhere == 1 or selected[a] != 0
                for k in range(offsets[a], offsets[a + 1]):
                    if selected[source_of(nbr[k], n, ghost_source)] != 0:
                        needed = True
            if dirichlet[a] == 1 or not needed:
                return
            fit, corrected, found = fitted_pressure(a, wp.static(0 if sealed_faces else 1), h, n, offsets, nbr, q,
                                                    origin, volume, material, water, ghost_source, ghost_chain, planes,
                                                    dirichlet, p)  # fmt: skip
            if wp.static(sealed_faces):
                if found == 1:
                    out[a] = fit
            elif corrected == 1:
                out[a] = p[a] - fit

        return kernel

    roughness = pressure_fit_kernel(False)
    extrapolate_to_sealed_faces = pressure_fit_kernel(True)

    @wp.kernel(enable_backward=False, module="unique")
    def assemble(
        first: int, h: real, dt: real, scale: f64, n: int, offsets: wp.array(dtype=wp.int32),
        nbr: wp.array(dtype=wp.int32), q: wp.array(dtype=vec3), origin: wp.array(dtype=vec3),
        volume: wp.array(dtype=real), density: wp.array(dtype=real), material: wp.array(dtype=wp.int32),
        water: Water, v_star: wp.array(dtype=vec3),
        div_v_star: wp.array(dtype=f64), p_old: wp.array(dtype=f64), ghost_source: wp.array(dtype=wp.int32),
        ghost_chain: wp.array(dtype=wp.vec3i), planes: Planes,
        dirichlet: wp.array(dtype=wp.int32), value: wp.array(dtype=f64),
        face_factor: wp.array(dtype=f64), momentum_image: wp.array(dtype=f64), eigenvalue: wp.array(dtype=real),
        exterior_threshold: real, lattice_sum: f64, rough: wp.array(dtype=f64), near_surface: wp.array(dtype=wp.int32),
        stabilisation: f64, interior_stabilisation: f64,
        weight: wp.array(dtype=f64), diag: wp.array(dtype=f64), rhs: wp.array(dtype=f64),
    ):  # fmt: skip
        a = first + wp.tid()
        x = q[a]
        vol_a = f64(volume[a]) * face_factor[a]  # a particle on a plane owns half its cell
        mat = material[a]
        k_a = water.permeability[mat]
        dt_rho_a = f64(dt) / f64(density[a])
        d = vol_a * water.inv_biot[mat] / f64(dt)
        b = d * p_old[a] - vol_a * div_v_star[a] - vol_a * water.inv_biot[mat] * water.density[mat] * f64(
            wp.dot(water.gravity, v_star[a]))
        eta2 = f64(ETA * ETA) * f64(h * h)
        present = zero  # Σ_b V_b m_ab over the neighbours there are [1/m²]
        for k in range(offsets[a], offsets[a + 1]):
            j = nbr[k]
            r = x - q[j]
            morris = -f64(wp.dot(r, grad_W(r, h))) / (f64(wp.dot(r, r)) + eta2) * scale
            vol_j = f64(volume[j])
            present += vol_j * morris
            mat_j = material[j]
            k_j = water.permeability[mat_j]
            k_pair = zero  # twice the harmonic mean: flux continuity across layers of contrasting k
            if k_a + k_j > zero:
                k_pair = f64(4.0) * k_a * k_j / (k_a + k_j)
            dt_rho_j = f64(dt) / f64(density[j])
            w = vol_a * vol_j * (k_pair + dt_rho_a + dt_rho_j) * morris
            w_dt = vol_a * vol_j * (dt_rho_a + dt_rho_j) * morris
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
                                                    real(0.5) * (origin[a] + origin[col]), planes, water, mat_j,
                                                    water.permeability[mat_j], 0)  # fmt: skip
            # a neighbour on an impermeable traction plane is its own odd mirror in the Δt/ρ part
            s_dt = s_dt * momentum_image[col]
            cst_dt = cst_dt * momentum_image[col]
            w_k = w - w_dt
            b += w_dt * (p_old[a] - (s_dt * p_old[col] + cst_dt))  # −V ∇·((Δt/ρ)∇pⁿ)
            b += w_k * cst + w_dt * cst_dt
            if dirichlet[a] == 0 and dirichlet[col] == 0 and mat_j == mat:  # damps p's roughness, drains nothing
                theta = stabilisation
                if near_surface[a] != NEAR_FREE_SURFACE and near_surface[col] != NEAR_FREE_SURFACE:
                    # faded out as the pair's Darcy part takes over damping the roughness
                    base = stabilisation * f64(LOW_PERMEABILITY_WEIGHT)
                    if near_surface[a] == NEAR_SEALED_FACE or near_surface[col] == NEAR_SEALED_FACE:
                        base = stabilisation
                    draining = k_pair / (dt_rho_a + dt_rho_j)  # k ρ/Δt
                    theta = wp.max(faded_by_draining(base, draining), interior_stabilisation)
                b -= theta * w_dt * (rough[a] - rough[col])
            # the ghost's parities folded in (SparseRows: A x = diag x − Σ weight x[col])
            coefficient = w_k * s + w_dt * s_dt
            coefficient, b = fold_conditions(coefficient, b, dirichlet[col], value[col], dirichlet[a])
            weight[k] = coefficient
        if eigenvalue[a] < exterior_threshold and lattice_sum > present:
            # impermeable free surface: the Δt/ρ part gains the pairs missing outside, with a zero
            # increment there, as the predictor's surface term takes the pressure outside as zero
            exterior = vol_a * f64(2.0) * dt_rho_a * (lattice_sum - present)
            d += exterior
            b += exterior * p_old[a]
        if dirichlet[a] == 1:
            d, b = held_row(d, value[a])
        diag[a] = d
        rhs[a] = b

    @wp.kernel(enable_backward=False, module="unique")
    def difference(first: int, a_: wp.array(dtype=f64), b_: wp.array(dtype=f64), out: wp.array(dtype=f64)):
        i = first + wp.tid()
        out[i] = a_[i] - b_[i]

    return dict(
        pressure_ghosts=pressure_ghosts, fit_vector_at_virtual=fit_vector_at_virtual,
        fit_scalar_at_virtual=fit_scalar_at_virtual, divergence_at_real=divergence_at_real,
        gradient_at_real=gradient_at_real, correct_velocity=correct_velocity, darcy=darcy,
        mark_dirichlet=mark_dirichlet, mark_near_surface=mark_near_surface, roughness=roughness,
        extrapolate_to_sealed_faces=extrapolate_to_sealed_faces, assemble=assemble,
        difference=difference, ghost_affine=ghost_affine,
    )  # fmt: skip
