"""Warp kernels of groundwater flow through the fixed skeleton (flow phases), float64 throughout;
:mod:`warpsph.stages.groundwater` drives them (docs/method.md, *Groundwater flow*).
"""

import functools

import warp as wp

from warpsph.physics.retention import RetentionLaws, material_retention_state
from warpsph.pore_water import water_struct
from warpsph.sph.kernels import smoothing_functions
from warpsph.sph.spec import Spec
from warpsph.stages.boundaries import plane_functions, planes_struct
from warpsph.stages.linear_solve import SparseRows, apply_row
from warpsph.stages.pressure_kernels import ETA, fold_conditions, held_row, pressure_kernels


@wp.struct
class WaterContent:
    """A flow step's per-particle water content (N,) each: the retention's S, C = n dS/dp [1/Pa] and k_r at
    the iterate, S and the excess pressure [Pa] at the step's start, and a consolidation step's coupling
    β [1/Pa] and s [-] (zero in a flow phase)."""

    saturation: wp.array(dtype=wp.float64)
    capacity: wp.array(dtype=wp.float64)
    relative: wp.array(dtype=wp.float64)
    saturation_start: wp.array(dtype=wp.float64)
    p_start: wp.array(dtype=wp.float64)
    coupling_storage: wp.array(dtype=wp.float64)
    coupling_source: wp.array(dtype=wp.float64)


@functools.cache
def groundwater_kernels(spec: Spec):
    """The flow phase's Warp kernels for ``spec``, by name."""
    real, vec3 = spec.real, spec.vec3
    f64 = wp.float64
    zero = f64(0.0)
    _W, grad_W = smoothing_functions(spec)
    drainage_here = plane_functions(spec)[1]
    ghost_affine = pressure_kernels(spec)["ghost_affine"]
    Planes = planes_struct(spec)
    Water = water_struct(vec3)

    @wp.func
    def hydrostatic(x: vec3, water_density: f64, gravity: vec3, water_table: f64):
        """p_h = ρ_w b·(x − x_wt) [Pa]."""
        return water_density * (f64(gravity[0]) * f64(x[0]) + f64(gravity[1]) * (f64(x[1]) - water_table)
                                + f64(gravity[2]) * f64(x[2]))  # fmt: skip

    @wp.kernel(enable_backward=False, module="unique")
    def retention_fields(
        first: int, q: wp.array(dtype=vec3), material: wp.array(dtype=wp.int32), water: Water,
        retention: RetentionLaws, p: wp.array(dtype=f64),
        saturation: wp.array(dtype=f64), capacity: wp.array(dtype=f64), relative: wp.array(dtype=f64),
    ):  # fmt: skip
        """S, the specific moisture capacity n dS/dp [1/Pa] and k_r at the excess pressure ``p``."""
        a = first + wp.tid()
        mat = material[a]
        rho_w = water.density[mat]
        total = p[a] + hydrostatic(q[a], rho_w, water.gravity, water.water_table)
        s, slope, kr = material_retention_state(retention, mat, rho_w * f64(wp.length(water.gravity)), total)
        saturation[a] = s
        capacity[a] = water.porosity[mat] * slope
        relative[a] = kr

    @wp.func
    def flow_pair(
        a: int, j: int, n: int, h: real, scale: f64, q: wp.array(dtype=vec3), origin: wp.array(dtype=vec3),
        mass: wp.array(dtype=real), density: wp.array(dtype=real), material: wp.array(dtype=wp.int32),
        water: Water, relative: wp.array(dtype=f64), ghost_source: wp.array(dtype=wp.int32),
        ghost_chain: wp.array(dtype=wp.vec3i), planes: Planes,
    ):  # fmt: skip
        """(col, w, s, c, plane) of row a's neighbour j: the pair's Darcy weight V_a V_j κ_aj m_aj with
        κ = twice the harmonic mean of k times the mean k_r, the owned particle ``col`` it reads and
        its ghost parity p_j = s p_col + c; ``plane`` the drained or inflow plane a ghost lies across
        (−1 for an owned neighbour or across impermeable planes only)."""
        r = q[a] - q[j]
        eta2 = f64(ETA * ETA) * f64(h * h)
        morris = -f64(wp.dot(r, grad_W(r, h))) / (f64(wp.dot(r, r)) + eta2) * scale
        col = j
        s = f64(1.0)
        c = zero
        plane = -1
        mat_j = material[j]
        if j >= n:
            g = j - n
            col = ghost_source[g]
            where = real(0.5) * (origin[a] + origin[col])
            s, c, _s_m, _c_m = ghost_affine(g, ghost_source, ghost_chain, q, where, planes, water, mat_j,
                                            water.permeability[mat_j] * relative[col], 0)  # fmt: skip
            chain = ghost_chain[g]
            for i in range(3):
                pl = chain[i]
                if pl >= 0 and plane < 0:
                    axis = planes.axis[pl]
                    if drainage_here(pl, where, axis, planes) != 0:
                        plane = pl
        k_a = water.permeability[material[a]]
        k_j = water.permeability[mat_j]
        k_pair = zero
        if k_a + k_j > zero:
            k_pair = f64(2.0) * k_a * k_j / (k_a + k_j) * (relative[a] + relative[col])
        vol_a = f64(mass[a] / density[a])
        vol_j = f64(mass[j] / density[j])
        return col, vol_a * vol_j * k_pair * morris, s, c, plane

    @wp.func
    def storage(
        a: int, inv_dt: f64, mass: wp.array(dtype=real), density: wp.array(dtype=real),
        face_factor: wp.array(dtype=f64), material: wp.array(dtype=wp.int32), water: Water, c: WaterContent,
        p_iter: wp.array(dtype=f64),
    ):  # fmt: skip
        """(diagonal, rhs) of row a's storage: V_a [C pᵐ⁺¹ + (S/Q) pᵐ⁺¹ + β pᵐ⁺¹]/Δt against
        V_a [C pᵐ − n(S(pᵐ) − Sⁿ) + (S/Q) pⁿ + s]/Δt, with the skeleton's coupling β and s of a
        consolidation step (:mod:`warpsph.stages.consolidation`; zero in a flow phase)."""
        mat = material[a]
        vol_a = f64(mass[a] / density[a]) * face_factor[a]
        s, inv_q = c.saturation[a], water.inv_biot[mat]
        d = vol_a * inv_dt * (c.capacity[a] + s * inv_q + c.coupling_storage[a])
        b = vol_a * inv_dt * (c.capacity[a] * p_iter[a] - water.porosity[mat] * (s - c.saturation_start[a])
                              + s * inv_q * c.p_start[a] + c.coupling_source[a])  # fmt: skip
        return d, b

    @wp.kernel(enable_backward=False, module="unique")
    def assemble_flow(
        first: int, h: real, inv_dt: f64, scale: f64, n: int, offsets: wp.array(dtype=wp.int32),
        nbr: wp.array(dtype=wp.int32), q: wp.array(dtype=vec3), origin: wp.array(dtype=vec3),
        mass: wp.array(dtype=real), density: wp.array(dtype=real), material: wp.array(dtype=wp.int32),
        water: Water, content: WaterContent, p_iter: wp.array(dtype=f64),
        ghost_source: wp.array(dtype=wp.int32), ghost_chain: wp.array(dtype=wp.vec3i), planes: Planes,
        dirichlet: wp.array(dtype=wp.int32), value: wp.array(dtype=f64), face_factor: wp.array(dtype=f64),
        weight: wp.array(dtype=f64), diag: wp.array(dtype=f64), rhs: wp.array(dtype=f64),
    ):  # fmt: skip
        """Row a of  V_a [(θ(pᵐ) − θⁿ) + C(pᵐ)(pᵐ⁺¹ − pᵐ) + (S/Q)(pᵐ⁺¹ − pⁿ)]/Δt + Σ_b w_ab (p_a − p_b)ᵐ⁺¹ = 0
        (θ = n S, C = n dS/dp; ``inv_dt`` = 0: the steady state); Dirichlet rows as in the projection."""
        a = first + wp.tid()
        d, b = storage(a, inv_dt, mass, density, face_factor, material, water, content, p_iter)
        for k in range(offsets[a], offsets[a + 1]):
            col, w, s, c, _plane = flow_pair(a, nbr[k], n, h, scale, q, origin, mass, density, material, water,
                                             content.relative, ghost_source, ghost_chain, planes)  # fmt: skip
            w = w * face_factor[a]
            d += w
            b += w * c
            coefficient, b = fold_conditions(w * s, b, dirichlet[col], value[col], dirichlet[a])
            weight[k] = coefficient
        if dirichlet[a] == 1:
            d, b = held_row(d, value[a])
        diag[a] = d
        rhs[a] = b

    @wp.kernel(enable_backward=False, module="unique")
    def flow_balance(
        first: int, h: real, inv_dt: f64, scale: f64, n: int, offsets: wp.array(dtype=wp.int32),
        nbr: wp.array(dtype=wp.int32), q: wp.array(dtype=vec3), origin: wp.array(dtype=vec3),
        mass: wp.array(dtype=real), density: wp.array(dtype=real), material: wp.array(dtype=wp.int32),
        water: Water, content: WaterContent, p_iter: wp.array(dtype=f64),
        ghost_source: wp.array(dtype=wp.int32), ghost_chain: wp.array(dtype=wp.vec3i), planes: Planes,
        dirichlet: wp.array(dtype=wp.int32), face_factor: wp.array(dtype=f64), tag: wp.array(dtype=wp.int32),
        n_tags: int, p: wp.array(dtype=f64), released: wp.array(dtype=f64), discharge: wp.array(dtype=f64),
        stored: wp.array(dtype=f64),
    ):  # fmt: skip
        """At the solution ``p`` of the iteration from ``p_iter``: ``released`` = the value row a's
        equation gives with its neighbours at p (a seepage row's test: water would enter where it is
        below the atmosphere's); for a row without a condition, ``discharge[a, tag]`` = the rate
        [m³/s, per metre in 2D] at which it passes water to the conditioned rows and planes of each
        tag, and ``stored`` the rate at which its water content grows."""
        a = first + wp.tid()
        d, b = storage(a, inv_dt, mass, density, face_factor, material, water, content, p_iter)
        stored[a] = d * p[a] - b
        for t in range(n_tags):
            discharge[a * n_tags + t] = zero
        for k in range(offsets[a], offsets[a + 1]):
            col, w, s, c, plane = flow_pair(a, nbr[k], n, h, scale, q, origin, mass, density, material, water,
                                            content.relative, ghost_source, ghost_chain, planes)  # fmt: skip
            w = w * face_factor[a]
            neighbour = s * p[col] + c
            d += w
            b += w * neighbour
            if dirichlet[a] == 0:
                to = -1
                if dirichlet[col] == 1:
                    to = tag[col]
                elif plane >= 0:
                    to = plane
                if to >= 0:
                    discharge[a * n_tags + to] += w * (p[a] - neighbour)
        released[a] = p[a]
        if d > zero:
            released[a] = b / d

    @wp.kernel(enable_backward=False, module="unique")
    def bishop_excess(
        first: int, q: wp.array(dtype=vec3), material: wp.array(dtype=wp.int32), water: Water,
        retention: RetentionLaws, suction: int, p: wp.array(dtype=f64), out: wp.array(dtype=f64),
    ):  # fmt: skip
        """The excess pressure whose total is Bishop's χ p_w, χ = S_e (1 at p_w ≥ 0 and in saturated
        soil; 0 under suction unless ``suction`` is 1): the pore pressure the total stress σ′ − χ p_w I
        carries."""
        a = first + wp.tid()
        mat = material[a]
        rho_w = water.density[mat]
        hydro = hydrostatic(q[a], rho_w, water.gravity, water.water_table)
        total = p[a] + hydro
        s, _slope, _kr = material_retention_state(retention, mat, rho_w * f64(wp.length(water.gravity)), total)
        chi = (s - retention.residual[mat]) / (f64(1.0) - retention.residual[mat])
        if suction == 0 and total < f64(0.0):
            chi = f64(0.0)
        out[a] = chi * total - hydro

    @wp.kernel(enable_backward=False, module="unique")
    def residual(
        first: int, A: SparseRows, x: wp.array(dtype=f64), rhs: wp.array(dtype=f64), out: wp.array(dtype=f64),
        increment: wp.array(dtype=f64),
    ):  # fmt: skip
        """out = b − A x and a zero increment: the iteration solves A δ = b − A pᵐ, so that the solve's
        relative tolerance applies to the change (with the storage term of a short step, pᵐ alone
        already met it)."""
        a = first + wp.tid()
        out[a] = rhs[a] - apply_row(a, A, x)
        increment[a] = zero

    @wp.kernel(enable_backward=False, module="unique")
    def add_increment(first: int, base: wp.array(dtype=f64), increment: wp.array(dtype=f64),
                      out: wp.array(dtype=f64)):  # fmt: skip
        a = first + wp.tid()
        out[a] = base[a] + increment[a]

    return dict(retention_fields=retention_fields, assemble_flow=assemble_flow, flow_balance=flow_balance,
                residual=residual, add_increment=add_increment, bishop_excess=bishop_excess)  # fmt: skip
