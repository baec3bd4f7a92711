"""Two-step Taylor-SPH with real particles and virtual stress points (docs/method.md, *One step*).

Half step, at the virtual points i, from the real particles' values Φⁿ = (v, σ′):
    Φ_i^{n+½} = Φ_iⁿ + Δt/2 (∇·σ′/ρ + b,  D:d) + ΔS(Δt/2)
Full step, at the real particles a, from the virtual points' Φ^{n+½}:
    Φ_a^{n+1} = Φ_aⁿ + Δt (∇·σ′/ρ + b,  D:d) + ΔS(Δt)
with values and gradients from the corrected linear fit (:mod:`warpsph.sph.operators`), ΔS the
Runge–Kutta increment of the Jaumann and Perzyna sources and, in the free-surface band, the weak
surface term of the traction; the kernels also move the points, advance the densities and book the
step's energy (docs/method.md, *One step*, *Operators*, *Energy balance*).
"""

import functools
from typing import Any

import warp as wp

from warpsph.launching import launch, launch_rows
from warpsph.physics.elastic import elastic_functions, elastic_struct, strain_energy_function
from warpsph.physics.plasticity import material_struct, plastic_functions
from warpsph.sph.kernels import smoothing_functions
from warpsph.sph.operators import operator_functions, used_axes_algebra, used_vectors
from warpsph.sph.packed_stress import as_stored, as_tensor, packed_stress_type
from warpsph.sph.spec import Spec
from warpsph.stages.corrections import fits_struct
from warpsph.stages.energy import BOUNDARIES, GRAVITY, PLASTIC, PORE_WATER, STABILISATION, VISCOUS, ledger_columns
from warpsph.stages.shifting import shifting_kernels
from warpsph.stages.surface_water import SurfaceWater, water_against_surface


SURFACE_SHARE_FLOOR = 0.45
"""Smallest share s_a [-] the full step's surface term is divided by (so at most 2.2 times the
undivided term): below a flat face's share, about 0.61, so only edges and corners are floored.
Measured on the free plate (docs/method.md): one step's spectral radius 1.000059 floored at 0.625,
1.000000023 at 0.45, the time integrator's own growth; floored at 0.7 the plate gains 2.6 % of its energy."""


@functools.cache
def taylor_kernels(spec: Spec):
    """``(half_step, full_step, virtual_continuity, motion_over_step)`` kernels for ``spec``."""
    column = ledger_columns(spec)  # the energy ledger's column of each channel
    real, vec3, mat33, block = spec.real, spec.vec3, spec.mat33, spec.used_block
    used = spec.stored_axes  # of a stored M⁻¹ block
    stored_stress = packed_stress_type(spec)  # the virtual points' half-step stress
    stored_zero = stored_stress()
    _fit, fit_weights, _unused, _eig = operator_functions(spec)
    full_vector, used_vector = used_vectors(spec)[1], spec.used_vector
    _W, grad_W = smoothing_functions(spec)
    outer = used_axes_algebra(spec)[0]
    shift_scaled = shifting_kernels(spec)[2]
    hooke_rate, source_increment, split_velocity_gradient = elastic_functions(spec)
    psi = strain_energy_function(spec)
    ElasticMaterials = elastic_struct(spec)
    Fits = fits_struct(spec)
    zero, half, one, two, two_thirds = real(0.0), real(0.5), real(1.0), real(2.0), real(2.0 / 3.0)
    share_floor = real(SURFACE_SHARE_FLOOR)
    moves = vec3(*map(real, spec.axis_mask))  # points move only along the used axes (1D shear: v_x ≠ 0)
    used_x, used_z = spec.dim >= 2, spec.dim == 3  # y is used in every dimension
    pore_water = spec.effects.pore_water
    plasticity = spec.effects.plasticity
    # the plastic arrays' element types; a dry variant takes unused real arrays (passed None)
    PlasticMaterial = material_struct(spec) if plasticity else real
    plastic = plastic_functions(spec, spec.yield_function) if plasticity else None
    material_update = plastic.material_update if plasticity else None
    variant = f"_plastic_{spec.yield_function}" if plasticity else ""

    @wp.func
    def uncorrected(c: used_vector, Minv: block):
        """Whether a point's fit fell back to Shepard + the uncorrected gradient (its neighbours
        cannot fit a linear field): the fallback stores exactly c = 0 and M⁻¹ = I."""
        return c == used_vector() and Minv == wp.identity(wp.static(used), dtype=real)

    @wp.func
    def fit_value(
        x: vec3, start: int, end: int, nbr: wp.array(dtype=wp.int32), xs: wp.array(dtype=vec3),
        vols: wp.array(dtype=real), values: wp.array(dtype=real), h: real, c: used_vector, inv_den: real,
        Minv: block,
    ):  # fmt: skip
        """A scalar field fitted at x from the sources of volumes ``vols`` (the value part of the linear fit)."""
        value = zero
        for k in range(start, end):
            b = nbr[k]
            psi, phi = fit_weights(xs[b] - x, h, c, inv_den, Minv)
            value += (vols[b] * psi) * values[b]
        return value

    @wp.func
    def skeleton_body_force(gravity: vec3, rho: real, water_density: wp.array(dtype=wp.float64), mat: int):
        """Body force per unit mass [m/s²] in the momentum balance of a point of density ρ [kg/m³]: g, or
        under pore water the buoyant g(1 − ρ_w/ρ) (the excess pore pressure's balance: ∇p_h = ρ_w g)."""
        if wp.static(pore_water):
            return gravity * (one - real(water_density[mat]) / rho)
        return gravity

    @wp.func
    def point_water_density(water_density: wp.array(dtype=wp.float64), mat: int):
        """ρ_w of material ``mat`` [kg/m³] (0 without pore water)."""
        if wp.static(pore_water):
            return real(water_density[mat])
        return zero

    @wp.func
    def weight_above(depth: real, n: vec3, unit_weight: vec3):
        """What the weight of the soil between a point ``depth`` [m] below a free surface of outward
        normal n and the surface adds to the point's traction σn at rest [Pa]: depth (ŵ·n)² w, with
        w = ``unit_weight`` = ρb [N/m³]. Exact where only the stress on horizontal planes varies with
        depth, σ_yy = −γ(H − y): a layer's geostatic state, and a cut's with K₀ = 0 at its face (zero)
        and its crest corner; a slender beam carries its weight in shear instead (docs/method.md)."""
        w2 = wp.dot(unit_weight, unit_weight)
        if w2 == zero:
            return vec3(zero, zero, zero)
        along = wp.dot(unit_weight, n)
        return (depth * along * along / w2) * unit_weight

    @wp.func
    def depth_below_surface(
        x: vec3, start: int, end: int, nbr: wp.array(dtype=wp.int32), xs: wp.array(dtype=vec3), n: vec3,
        beyond_sources: real,
    ):  # fmt: skip
        """Distance [m] from x along its outward normal n to a free surface lying ``beyond_sources`` [m]
        past the outermost source, clamped at zero."""
        reach = real(-1.0e30)
        for k in range(start, end):
            reach = wp.max(reach, wp.dot(xs[nbr[k]] - x, n))
        return wp.max(reach + beyond_sources, zero)

    @wp.func
    def stress_on_drained_surface(
        depth: real, n: vec3, At: mat33, s: mat33, d0: mat33, d1: mat33, d2: mat33, p: real, dp: vec3,
    ):  # fmt: skip
        """The total stress σ′ − pI on a drained free surface ``depth`` [m] out along the outward normal
        n, extrapolated by the fitted gradients d_k = ∂σ′/∂x_k and dp = ∇p at tⁿ; σ′'s are mapped by
        At = F⁻¹ onto the configuration n lives on, the pore pressure's stays at tⁿ."""
        An = At * n  # n·∇ on that configuration, as weights of the ∂/∂x_k at tⁿ
        slope = An[0] * d0 + An[1] * d1 + An[2] * d2
        return s + depth * slope - (p + depth * wp.dot(dp, n)) * wp.identity(3, dtype=real)

    @wp.func
    def fit_fields(
        x: vec3, start: int, end: int, nbr: wp.array(dtype=wp.int32), xs: wp.array(dtype=vec3),
        vols: wp.array(dtype=real), vs: wp.array(dtype=vec3),
        sigmas: wp.array(dtype=Any), h: real, c: used_vector, inv_den: real, Minv: block, e: vec3,
        src: Fits, in_surface_band: bool, ps: wp.array(dtype=wp.float64), mid: real,
        water_on_surface: real, per_share: bool, beyond_sources: real, unit_weight: vec3,
        surface_water: SurfaceWater, rho_w: real, held_surface: real,
    ):  # fmt: skip
        """Velocity, effective stress, velocity gradient G[k,j] = ∂v_j/∂x_k, divergence of the total
        stress σ′ − pI and pore pressure fitted at x from the sources; in the surface band the
        divergence gains the weak normal-traction term of σ′ − w pI (w = ``water_on_surface``: 1 at an
        impermeable free surface or any while the pore pressures are held, 0 at a drained one, whose
        zero pore pressure the fitted gradient already takes from its Dirichlet rows), divided by the
        point's share of the sources' fits when ``per_share`` (the full step, whose real particles carry
        the mass). At a drained free surface the term takes the total stress extrapolated to the
        surface, ``beyond_sources`` [m] past the outermost source (``stress_on_drained_surface``), not
        the point's own; at a dry or impermeable one the point's own traction less the weight of the
        soil between it and the surface (``weight_above``; unit_weight = ρb [N/m³] with the point's
        body force, buoyant under pore water, zero with large deformation). With ``held_surface`` 1 (pore
        pressures held) that traction takes the pore pressure extrapolated to the surface and the weight the
        effective stress carries, ρb less the pore pressure's gradient, so that ground above the hydrostatic
        reference's level is loaded as dry ground is, whatever the slope of its face. The sources' positions are
        those at tⁿ; the gradients of v and σ′ (G, the divergence, the surface normal
        and weights) are taken on the configuration x + mid·v [s] where those fields live, through
        F⁻ᵀ = (I + mid G)⁻¹ (mid = 0: at tⁿ); the pore pressure's stays at tⁿ (the full step's is the
        lagged pⁿ). Also returned, for the ledger: the band's term, the water's load in it, the pore
        pressure's force (−∇p and the band's pressure part) and that pressure part."""
        v = vec3(zero, zero, zero)
        G = mat33(zero)
        surface_sum = vec3(zero, zero, zero)
        share = zero  # Σ_b V_b ψ_b(x): the point's weight in the sources' fits, integrated
        p = wp.float64(0.0)
        grad_p = vec3(zero, zero, zero)
        # the sums run over the stress's independent entries (xx, yy, zz, xy in 1D and 2D, with xz, yz in 3D)
        s_p = stored_stress()
        ds0_p = stored_stress()
        ds1_p = stored_stress()
        ds2_p = stored_stress()
        for k in range(start, end):
            b = nbr[k]
            vol = vols[b]
            psi, phi = fit_weights(xs[b] - x, h, c, inv_den, Minv)
            sigma = as_stored(sigmas[b], stored_zero)
            v += (vol * psi) * vs[b]
            s_p += (vol * psi) * sigma
            G += outer(vol * phi, vs[b])
            # φ's component along an unused axis is exactly zero, so is that axis's gradient
            if wp.static(used_x):
                ds0_p += (vol * phi[0]) * sigma
            ds1_p += (vol * phi[1]) * sigma
            if wp.static(used_z):
                ds2_p += (vol * phi[2]) * sigma
            if wp.static(pore_water):
                p += wp.float64(vol * psi) * ps[b]
                grad_p += (vol * real(ps[b])) * phi
            if in_surface_band:
                psi_b, phi_b = fit_weights(x - xs[b], h, src.c[b], src.inv_den[b], src.minv[b])
                surface_sum += vol * (psi_b * full_vector(src.e[b]) - phi_b)
                if per_share:
                    share += vol * psi_b
        s = as_tensor(s_p)
        # ∂σ′/∂x_k on the configuration at tⁿ, one matrix per axis k
        ds0 = as_tensor(ds0_p)
        ds1 = as_tensor(ds1_p)
        ds2 = as_tensor(ds2_p)
        G -= outer(e, v)
        # gradients at tⁿ → on the configuration x + mid·v: ∂/∂x′_m = A[m,k] ∂/∂x_k, A = F⁻ᵀ
        A = wp.inverse(wp.identity(n=3, dtype=real) + mid * G)
        G = A * G
        At = wp.transpose(A)
        # ∂σ′/∂x_k at tⁿ; div_j = ∂σ′_mj/∂x′_m = Σ_k (∂σ′/∂x_k)_jm A[m,k] (σ′ symmetric)
        ds0 -= e[0] * s
        ds1 -= e[1] * s
        ds2 -= e[2] * s
        div = ds0 * At[0] + ds1 * At[1] + ds2 * At[2]
        total = s
        if wp.static(pore_water):
            grad_p -= real(p) * e
            div -= grad_p  # pⁿ, a field at tⁿ: its gradient stays on that configuration
            total = s - water_on_surface * real(p) * wp.identity(3, dtype=real)
        normal_dir = A * e
        band = vec3(zero, zero, zero)
        water = vec3(zero, zero, zero)
        band_pressure = vec3(zero, zero, zero)
        if in_surface_band and wp.length(normal_dir) > zero:
            n = -wp.normalize(normal_dir)
            depth = depth_below_surface(x, start, end, nbr, xs, n, beyond_sources)
            drained = False
            if wp.static(pore_water):
                drained = water_on_surface == zero
            traction = total * n
            on_surface = water_on_surface * real(p)  # the pore pressure the traction carries
            if drained:
                traction = stress_on_drained_surface(depth, n, At, s, ds0, ds1, ds2, real(p), grad_p) * n
                on_surface = real(p) + depth * wp.dot(grad_p, n)
            else:
                carried = unit_weight
                if wp.static(pore_water):
                    if held_surface > zero:
                        on_surface = real(p) + depth * wp.dot(grad_p, n)
                        traction = s * n - on_surface * n
                        carried = unit_weight - held_surface * grad_p
                traction -= weight_above(depth, n, carried)
            load = vec3(zero, zero, zero)
            if wp.static(pore_water):  # the water against the surface (surface_water.py)
                at = x + depth * n
                load = -real(water_against_surface(surface_water, wp.float64(rho_w), wp.float64(at[0]),
                                                   wp.float64(at[1]), wp.float64(at[2]))) * n  # fmt: skip
            scale = one
            if per_share:
                scale = one / wp.max(share, share_floor)
            weight = scale * wp.dot(A * surface_sum, n)
            band = weight * traction
            water = weight * load
            div += band + water
            band_pressure = -(weight * on_surface) * n
        return v, s, G, div, p, band, water, band_pressure - grad_p, band_pressure

    @wp.kernel(enable_backward=False, module="unique", name=f"half_step{variant}" if plasticity else None)
    def half_step(
        first: int,
        h: real,
        dt: real,
        gravity: vec3,
        surface_threshold: real,
        water_on_surface: real,
        offsets: wp.array(dtype=wp.int32),
        nbr: wp.array(dtype=wp.int32),
        real_q: wp.array(dtype=vec3),
        real_volume: wp.array(dtype=real),
        real_v: wp.array(dtype=vec3),
        real_stress: wp.array(dtype=mat33),
        real_fit: Fits,
        virt_q: wp.array(dtype=vec3),
        virt_density: wp.array(dtype=real),
        virt_material: wp.array(dtype=wp.int32),
        virt_fit: Fits,
        elastic: ElasticMaterials,
        virt_v_half: wp.array(dtype=vec3),
        virt_stress_half: wp.array(dtype=stored_stress),
        virt_q_out: wp.array(dtype=vec3),
        virt_density_out: wp.array(dtype=real),
        real_p: wp.array(dtype=wp.float64),
        water_density: wp.array(dtype=wp.float64),
        virt_p: wp.array(dtype=wp.float64),
        real_plastic_strain: wp.array(dtype=real),
        plastic_material: wp.array(dtype=PlasticMaterial),
        virt_rate: wp.array(dtype=real),
        continuity: real,
        surface_weight: real,
        surface_water: SurfaceWater,
        pressure_held: int,
    ):
        """``continuity``: 1 to advance the virtual densities by the divergence fitted here, 0 when
        ``virtual_continuity`` advances them after the full step; ``surface_weight``: 1 to take the
        weight of the soil above a surface band's point off its traction, 0 not to (large deformation);
        ``pressure_held``: 1 with the pore pressures held."""
        i = first + wp.tid()
        x = virt_q[i]
        mat = virt_material[i]
        lam, shear = elastic.lam[mat], elastic.shear[mat]
        rho = virt_density[i]
        body_force = skeleton_body_force(gravity, rho, water_density, mat)
        v, s, G, div, p, _band, _water, _pressure, _band_pressure = fit_fields(
                                     x, offsets[i], offsets[i + 1], nbr, real_q, real_volume, real_v,
                                     real_stress, h, virt_fit.c[i], virt_fit.inv_den[i], virt_fit.minv[i],
                                     full_vector(virt_fit.e[i]), real_fit,
                                     virt_fit.smallest_eigenvalue[i] < surface_threshold, real_p, zero,
                                     water_on_surface, False, zero, surface_weight * rho * body_force, surface_water,
                                     point_water_density(water_density, mat),
                                     real(pressure_held) * surface_weight)  # fmt: skip
        d, spin = split_velocity_gradient(G)
        hdt = half * dt
        if wp.static(pore_water):
            virt_p[i] = p  # pⁿ at the virtual point, for the full step's lagged pressure force
        v_half = v + hdt * (div / rho + body_force)
        opening = zero
        if wp.static(plasticity):
            eps = fit_value(x, offsets[i], offsets[i + 1], nbr, real_q, real_volume, real_plastic_strain,
                            h, virt_fit.c[i], virt_fit.inv_den[i], virt_fit.minv[i])  # fmt: skip
            s_trial = s + hdt * hooke_rate(d, lam, shear)
            s_half, _d_eps, crack = material_update(s_trial, eps, spin, hdt, lam, shear, plastic_material[mat])
            # the crack opened over Δt/2 by the rate d opens twice as much over the Δt the density takes
            opening = two * crack / (lam + two_thirds * shear)
        else:
            s_half = s + hdt * hooke_rate(d, lam, shear) + source_increment(s, spin, hdt)
        virt_v_half[i] = v_half
        virt_stress_half[i] = as_stored(s_half, stored_zero)
        virt_rate[i] = wp.sqrt(wp.ddot(d, d))  # ‖d‖ [1/s], the rate particle shifting follows
        virt_q_out[i] = x + dt * wp.cw_mul(v_half, moves)
        virt_density_out[i] = rho * wp.exp(opening - continuity * dt * wp.trace(d))

    @wp.kernel(enable_backward=False, module="unique", name=f"full_step{variant}" if plasticity else None)
    def full_step(
        first: int,
        h: real,
        dt: real,
        gravity: vec3,
        surface_threshold: real,
        water_on_surface: real,
        alpha: real,
        offsets: wp.array(dtype=wp.int32),
        nbr: wp.array(dtype=wp.int32),
        virt_q: wp.array(dtype=vec3),
        virt_mass: wp.array(dtype=real),
        virt_density: wp.array(dtype=real),
        virt_volume: wp.array(dtype=real),
        virt_v_half: wp.array(dtype=vec3),
        virt_stress_half: wp.array(dtype=stored_stress),
        virt_fit: Fits,
        real_fit: Fits,
        q: wp.array(dtype=vec3),
        v: wp.array(dtype=vec3),
        stress: wp.array(dtype=mat33),
        density: wp.array(dtype=real),
        material: wp.array(dtype=wp.int32),
        elastic: ElasticMaterials,
        q_out: wp.array(dtype=vec3),
        v_out: wp.array(dtype=vec3),
        stress_out: wp.array(dtype=mat33),
        density_out: wp.array(dtype=real),
        virt_p: wp.array(dtype=wp.float64),
        water_density: wp.array(dtype=wp.float64),
        plastic_strain: wp.array(dtype=real),
        plastic_material: wp.array(dtype=PlasticMaterial),
        plastic_strain_out: wp.array(dtype=real),
        shifting: int,
        shifting_coefficient: real,
        shift: wp.array(dtype=vec3),
        own_velocity: int,
        stress_filter: real,
        velocity_filter: real,
        surface_per_share: int,
        spacing: real,
        surface_weight: real,
        surface_water: SurfaceWater,
        pressure_held: int,
        mass: wp.array(dtype=real),
        ledger: wp.array2d(dtype=wp.float64),
    ):
        """``surface_per_share``: 1 to divide the surface term by the particle's share (off with large
        deformation, docs/method.md); ``spacing``: the lattice spacing Δx [m], the virtual points lying half
        of it inside a free surface whose real particles lie on it; ``surface_weight`` as in the half step;
        ``pressure_held``: 1 with the pore pressures held, whose force is then booked as a load's work;
        ``ledger``: the particle's row gains the step's energies (:mod:`warpsph.stages.energy`)."""
        a = first + wp.tid()
        x = q[a]
        mat = material[a]
        lam, shear = elastic.lam[mat], elastic.shear[mat]
        rho = density[a]
        body_force = skeleton_body_force(gravity, rho, water_density, mat)
        v_half, s_half, G, div, p, band, water, pressure_force, band_pressure = fit_fields(
                                            x, offsets[a], offsets[a + 1], nbr, virt_q, virt_volume,
                                            virt_v_half, virt_stress_half, h, real_fit.c[a], real_fit.inv_den[a],
                                            real_fit.minv[a], full_vector(real_fit.e[a]), virt_fit,
                                            real_fit.smallest_eigenvalue[a] < surface_threshold,
                                            virt_p, half * dt, water_on_surface, surface_per_share != 0,
                                            half * spacing, surface_weight * rho * body_force, surface_water,
                                            point_water_density(water_density, mat),
                                            real(pressure_held) * surface_weight)  # fmt: skip
        # gradients on the midpoint configuration (Hughes–Winget): on the configuration at tⁿ a rigid
        # rotation's v^{n+½} has the divergence −Δt ω² (a spinning disc's rim drifted outward by
        # π ωΔt R per turn), and the force of its stress at t^{n+½}, turned by ωΔt/2 since tⁿ, missed
        # that turn against the points' motion by Δt v^{n+½}: a torque of π ωΔt L per turn
        free = offsets[a + 1] == offsets[a]
        if own_velocity != 0 and uncorrected(real_fit.c[a], real_fit.minv[a]):
            free = True
        if free:
            # no virtual point near (or, moving with its own velocity, too few to fit a linear
            # field): a particle in free flight (ballistic, its stress frozen)
            G = mat33(zero)
            div = vec3(zero, zero, zero)
            band = vec3(zero, zero, zero)
            water = vec3(zero, zero, zero)
            pressure_force = vec3(zero, zero, zero)
            band_pressure = vec3(zero, zero, zero)
            v_half = v[a]
        d, spin = split_velocity_gradient(G)
        s = stress[a]
        opening = zero
        if wp.static(plasticity):
            s_trial = s + dt * hooke_rate(d, lam, shear)
            s_new, d_eps, crack = material_update(s_trial, plastic_strain[a], spin, dt, lam, shear,
                                                  plastic_material[mat])  # fmt: skip
            opening = crack / (lam + two_thirds * shear)  # volumetric strain of the crack [-]
            plastic_strain_out[a] = plastic_strain[a] + d_eps
        else:
            s_new = s + dt * hooke_rate(d, lam, shear) + source_increment(s, spin, dt)
        vol = mass[a] / rho
        if wp.static(plasticity):
            # the law's work V σ̄:Δt d less the elastic energy it stores: the plastic dissipation
            stored = psi(s_new, lam, shear) - psi(s, lam, shear)
            ledger[a, wp.static(column[PLASTIC])] += wp.float64(vol * (dt * wp.ddot(half * (s + s_new), d) - stored))
        s_law = s_new
        if free:
            v_half = v[a] + half * dt * body_force
        visc = vec3(zero, zero, zero)
        if alpha > zero:
            # the particle's own velocity brought to t^{n+½}, the virtual points' time level: against
            # vⁿ the relative velocity would carry −Δt/2 times the acceleration, a drag proportional
            # to it (measured: the wave front 6 % fast with α = 0.2, at every spacing)
            va = v[a] + half * dt * (div / rho + body_force)
            ca = elastic.wave_speed[mat]
            for k in range(offsets[a], offsets[a + 1]):
                i = nbr[k]
                xai = x - virt_q[i]
                vr = wp.dot(va - virt_v_half[i], xai)
                if vr < zero:
                    mu = h * vr / (wp.dot(xai, xai) + real(0.01) * h * h)
                    rbar = half * (rho + virt_density[i])
                    visc += (virt_mass[i] * alpha * ca * mu / rbar) * grad_W(xai, h)
        dx = vec3(zero, zero, zero)
        d_v = vec3(zero, zero, zero)
        d_s = mat33(zero)
        if shifting != 0 and not free:
            # particle shifting: the particle moves by dx off its path and takes the fields there,
            # v + (dx·∇)v and σ′ + (dx·∇)σ′ with the fitted gradients of Φ^{n+½}
            dx = shift_scaled(shift[a], shifting_coefficient, h, dt * wp.sqrt(wp.ddot(d, d)))
            d_v = wp.transpose(G) * dx
            for k in range(offsets[a], offsets[a + 1]):
                i = nbr[k]
                psi_i, phi_i = fit_weights(virt_q[i] - x, h, real_fit.c[a], real_fit.inv_den[a], real_fit.minv[a])
                d_s += (virt_mass[i] / virt_density[i] * wp.dot(phi_i, dx)) * as_tensor(virt_stress_half[i])
            d_s -= wp.dot(full_vector(real_fit.e[a]), dx) * s_half
        v_force = v[a] + dt * (div / rho + body_force + visc)
        v_mean = half * (v[a] + v_force)
        ledger[a, wp.static(column[VISCOUS])] -= wp.float64(dt * mass[a] * wp.dot(v_mean, visc))
        # the surface band's term: the water's pressure on the surface is a load; the rest, the weak
        # traction-free condition (and the weight above the point), a stabilisation of the surface
        ledger[a, wp.static(column[BOUNDARIES])] += wp.float64(dt * vol * wp.dot(v_mean, water))
        if wp.static(pore_water):
            if pressure_held != 0:
                # held pore pressures are a load: the work of their force, the surface band's pressure
                # part taken off the band's stabilisation
                ledger[a, wp.static(column[PORE_WATER])] += wp.float64(dt * vol * wp.dot(v_mean, pressure_force))
                band -= band_pressure
            else:
                ledger[a, wp.static(column[PORE_WATER])] += wp.float64(vol * real(p) * dt * wp.trace(d))
        ledger[a, wp.static(column[STABILISATION])] -= wp.float64(dt * vol * wp.dot(v_mean, band))
        v_out[a] = v_force + d_v
        if velocity_filter > zero and not free:
            # the part of the particle's velocity the virtual points do not see: its own mid-step
            # velocity against the one fitted at it from their v^{n+½}, which moves it
            v_out[a] = v_out[a] - velocity_filter * (half * (v[a] + v_out[a]) - v_half)
        if stress_filter > zero and not free:
            # the part of the particle's stress the virtual points do not see: its own mid-step
            # value against the virtual points' Φ^{n+½} fitted back at it
            s_new -= stress_filter * (half * (s + s_new) - s_half)
        stress_out[a] = s_new + d_s
        # what the filters and the shift changed of the particle's kinetic and elastic energy
        kinetic = half * mass[a] * (wp.dot(v_out[a], v_out[a]) - wp.dot(v_force, v_force))
        strained = vol * (psi(stress_out[a], lam, shear) - psi(s_law, lam, shear))
        ledger[a, wp.static(column[STABILISATION])] -= wp.float64(kinetic + strained)
        if own_velocity != 0:
            # the particle moves with its own velocity, the mean of vⁿ and vⁿ⁺¹ (the shift's
            # correction of the field aside): a velocity it gains also moves it
            q_out[a] = x + dt * wp.cw_mul(half * (v[a] + v_out[a] - d_v), moves) + dx
        else:
            q_out[a] = x + dt * wp.cw_mul(v_half, moves) + dx
        density_out[a] = rho * wp.exp(opening - dt * wp.trace(d))
        ledger[a, wp.static(column[GRAVITY])] += wp.float64(mass[a] * wp.dot(body_force, q_out[a] - x))


    @wp.kernel(enable_backward=False, module="unique")
    def virtual_continuity(
        first: int, h: real, dt: real, offsets: wp.array(dtype=wp.int32), nbr: wp.array(dtype=wp.int32),
        real_q: wp.array(dtype=vec3), real_mass: wp.array(dtype=real), real_density: wp.array(dtype=real),
        real_motion: wp.array(dtype=vec3), virt_q: wp.array(dtype=vec3), virt_fit: Fits,
        virt_density: wp.array(dtype=real),
    ):  # fmt: skip
        """ρ_i ← ρ_i exp(−Δt tr d), d the rate of deformation of the real particles' motion over the step
        (their displacement / Δt) fitted at the virtual point, on the step's midpoint configuration."""
        i = first + wp.tid()
        x = virt_q[i]
        v = vec3(zero, zero, zero)
        G = mat33(zero)
        for k in range(offsets[i], offsets[i + 1]):
            b = nbr[k]
            vol = real_mass[b] / real_density[b]
            psi, phi = fit_weights(real_q[b] - x, h, virt_fit.c[i], virt_fit.inv_den[i], virt_fit.minv[i])
            v += (vol * psi) * real_motion[b]
            G += outer(vol * phi, real_motion[b])
        G -= outer(full_vector(virt_fit.e[i]), v)
        G = wp.inverse(wp.identity(n=3, dtype=real) + half * dt * G) * G
        virt_density[i] = virt_density[i] * wp.exp(-dt * wp.trace(G))

    @wp.kernel(enable_backward=False, module="unique")
    def motion_over_step(first: int, dt: real, q_in: wp.array(dtype=vec3), q_out: wp.array(dtype=vec3),
                         motion: wp.array(dtype=vec3)):  # fmt: skip
        """The velocity [m/s] each real particle moved with over the step."""
        a = first + wp.tid()
        motion[a] = (q_out[a] - q_in[a]) / dt

    return half_step, full_step, virtual_continuity, motion_over_step


def launch_half_step(model, config, nl, si, so, dt: float, *, real_volume, real_fits, virtual_fits, virtual_v,
                     virtual_stress, pressure, water_density, virtual_p, virtual_rate, integrated_density: bool,
                     water_on_surface, surface_weight, surface_water: SurfaceWater) -> None:  # fmt: skip
    """The half step at the virtual points over the neighbour list ``nl`` (virtual → real), from state
    ``si`` into ``so``'s virtual points and ``virtual_v``, ``virtual_stress`` (and ``virtual_p``);
    ``integrated_density``: the virtual densities by their own continuity (else the virtual continuity
    stage sets them)."""
    m, real = model, model.spec.real
    half_step, *_ = taylor_kernels(m.spec)
    launch_rows(half_step, m.virtual_count,
                [real(m.h), real(dt), m.spec.vec3(*m.gravity), real(config.free_surface_threshold),
                 water_on_surface, nl.offsets, nl.indices, si.particle_q, real_volume, si.particle_v,
                 si.particle_stress, real_fits.struct, si.virtual_q, si.virtual_density,
                 m.virtual_material, virtual_fits.struct,
                 m.material_elastic, virtual_v, virtual_stress, so.virtual_q,
                 so.virtual_density, pressure, water_density, virtual_p,
                 si.particle_plastic_strain, m.material_plasticity, virtual_rate,
                 real(1.0 if integrated_density else 0.0), surface_weight, surface_water,
                 int(config.fixed_pore_pressure)],
                m.device)  # fmt: skip


def launch_full_step(model, config, nl, si, so, dt: float, *, virtual_volume, virtual_v, virtual_stress,
                     virtual_fits, real_fits, virtual_p, water_density, real_shift, water_on_surface, surface_weight,
                     surface_water: SurfaceWater, ledger) -> None:  # fmt: skip
    """The full step at the real particles over the neighbour list ``nl`` (real → virtual), from state
    ``si`` and the virtual points' half-step values into ``so``, booking its energy in ``ledger``."""
    m, real = model, model.spec.real
    _, full_step, *_ = taylor_kernels(m.spec)
    own = int(config.particle_velocity == "own")
    launch_rows(full_step, m.particle_count,
                [real(m.h), real(dt), m.spec.vec3(*m.gravity), real(config.free_surface_threshold),
                 water_on_surface, real(config.artificial_viscosity), nl.offsets, nl.indices,
                 si.virtual_q, m.virtual_mass, si.virtual_density, virtual_volume, virtual_v,
                 virtual_stress,
                 virtual_fits.struct, real_fits.struct, si.particle_q, si.particle_v,
                 si.particle_stress, si.particle_density, m.particle_material, m.material_elastic,
                 so.particle_q, so.particle_v, so.particle_stress, so.particle_density,
                 virtual_p, water_density, si.particle_plastic_strain, m.material_plasticity,
                 so.particle_plastic_strain, int(config.particle_shifting > 0.0), real(config.particle_shifting),
                 real_shift,
                 own, real(config.stress_filter), real(config.velocity_filter),
                 int(not config.large_deformation), real(config.dx), surface_weight,
                 surface_water, int(config.fixed_pore_pressure), m.particle_mass, ledger], m.device)  # fmt: skip


def launch_real_motion(model, si, so, dt: float, real_motion) -> None:
    """The real particles' velocity over the step, (x^{n+1} − xⁿ)/Δt, into ``real_motion``."""
    m = model
    *_, motion_over_step = taylor_kernels(m.spec)
    launch(motion_over_step, m.particle_count, [0, m.spec.real(dt), si.particle_q, so.particle_q, real_motion],
           m.device)  # fmt: skip


def launch_virtual_continuity(model, nl, si, so, dt: float, real_motion, virtual_fits) -> None:
    """The virtual points' densities by continuity with the rate of deformation of ``real_motion`` over
    the neighbour list ``nl`` (virtual → real), into ``so``."""
    m, real = model, model.spec.real
    *_, virtual_continuity, _ = taylor_kernels(m.spec)
    launch_rows(virtual_continuity, m.virtual_count,
                [real(m.h), real(dt), nl.offsets, nl.indices, si.particle_q, m.particle_mass, si.particle_density,
                 real_motion, si.virtual_q, virtual_fits.struct, so.virtual_density],
                m.device)  # fmt: skip
