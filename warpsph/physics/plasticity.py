"""Perzyna viscoplasticity at a material point: stress invariants, the von Mises, Drucker–Prager and rounded
Mohr–Coulomb yield surfaces in the one form F = β I₁ + √(J₂ K(ϑ)² + a²) − k_c s_y(ε̄), their gradient, and
the sub-stepped relaxation source (docs/method.md, *Viscoplasticity*).
"""

import functools
import math
from typing import Callable, NamedTuple

import warp as wp

from warpsph.physics.elastic import elastic_functions
from warpsph.sph.spec import Spec

YIELD_NAMES = ("von_mises", "drucker_prager", "mohr_coulomb")
TRANSITION_ANGLE = math.radians(25.0)
"""Abbo–Sloan transition Lode angle ϑ_T [rad] beyond which the Mohr–Coulomb K(ϑ) is rounded."""
APEX_FRACTION = 0.05
"""Default f of the Abbo–Sloan apex distance f c₀ cotφ along the hydrostatic axis (the form above uses
a = f c₀ cotφ sinφ): at zero mean stress the hyperbola lies within f²/2 ≈ 0.13 % (in √J₂) of the cone."""
J2_FLOOR = 1e-30
"""[Pa²] below which the deviator has no direction (n = 0, ϑ = 0)."""
RELAXATION_STEP = {"rk4": 1.0, "rk2": 0.5}
"""Largest λ_vp h per sub-step. The stability limits of a linear relaxation are λh ≈ 2.78 (RK4) and
2 (RK2); these values keep a margin and hold the per-sub-step amplification error |R(−λh) − e^{−λh}|
below 0.8 % (RK4: R(−1) = 0.375 vs e^{−1} = 0.368) and 1.8 % (RK2: R(−½) = 0.625 vs 0.607); over a
whole interval the overstress is then within 0.7 % (RK4) and 2.3 % (RK2) of exact, relative to its
initial value, at any λ_vp Δt."""
MAX_SUBSTEPS = 1000
"""Cap on sub-steps per interval: RK4 stays stable up to λ_vp Δt ≈ 2780, RK2 up to 2000; stiffer
points belong to the rate-independent limit (a return mapping)."""


@functools.cache
def material_struct(spec: Spec):
    """The Warp struct of one viscoplastic material in ``spec``'s precision; build it with
    :func:`viscoplastic_material` (its coefficients depend on the yield function)."""
    real = spec.real

    @wp.struct
    class ViscoplasticMaterial:
        fluidity: real  # γ [1/s]
        reference_stress: real  # F₀ [Pa]
        exponent: real  # N [-]
        strength: real  # s_y0: σ_Y0 (von Mises) or c₀ (Drucker–Prager, Mohr–Coulomb) [Pa]
        hardening: real  # H = ds_y/dε̄ [Pa]; < 0 softens
        residual_strength: real  # s_r, the floor of s_y under softening [Pa]
        strength_factor: real  # k_c [-]
        yield_slope: real  # β of F [-]
        yield_sine: real  # sinφ, shapes K(ϑ) of a Mohr–Coulomb F [-]
        yield_apex: real  # a of F [Pa]
        flow_slope: real  # β of G [-]
        flow_sine: real  # sinψ [-]
        flow_apex: real  # a of G [Pa]

    return ViscoplasticMaterial


def _cone(yield_name: str, angle: float) -> tuple[float, float, float]:
    """(β, sine, k_c) of a yield surface or potential of friction or dilatancy angle [rad]."""
    if yield_name == "von_mises":
        return 0.0, 0.0, 1.0
    if yield_name == "drucker_prager":
        tan = math.tan(angle)
        root = math.sqrt(9.0 + 12.0 * tan * tan)
        return tan / root, 0.0, 3.0 / root
    return math.sin(angle) / 3.0, math.sin(angle), math.cos(angle)


def viscoplastic_material(
    spec: Spec,
    yield_name: str,
    *,
    strength: float,
    fluidity: float,
    reference_stress: float,
    hardening: float = 0.0,
    friction: float = 0.0,
    dilatancy: float = 0.0,
    exponent: float = 1.0,
    apex_fraction: float = APEX_FRACTION,
    residual_strength: float = -math.inf,
):
    """A :func:`material_struct` instance. strength: σ_Y0 (von Mises) or cohesion c₀ [Pa]; fluidity γ
    [1/s]; reference_stress F₀ [Pa]; hardening H [Pa] per unit ε̄; friction φ and dilatancy ψ [rad]
    (ignored by von Mises); exponent N; apex_fraction f of the Mohr–Coulomb apex a = f c₀ cotφ (the
    term a sinφ = f c₀ cosφ, so φ = 0 stays finite); residual_strength s_r [Pa], the floor of the
    softened strength s_y0 + Hε̄ (−∞: none). Pass the same yield_name to plastic_functions."""
    if yield_name not in YIELD_NAMES:
        raise ValueError(f"unknown yield function {yield_name!r}; expected one of {YIELD_NAMES}")
    yield_slope, yield_sine, strength_factor = _cone(yield_name, friction)
    flow_slope, flow_sine, _ = _cone(yield_name, dilatancy)
    yield_apex = flow_apex = 0.0
    if yield_name == "mohr_coulomb":
        yield_apex = apex_fraction * strength * math.cos(friction)  # a sinφ with a = f c₀ cotφ
        flow_apex = yield_apex * flow_sine / yield_sine if yield_sine > 0.0 else yield_apex
    m = material_struct(spec)()
    real = spec.real
    for name, value in dict(
        fluidity=fluidity, reference_stress=reference_stress, exponent=exponent, strength=strength,
        hardening=hardening, residual_strength=residual_strength, strength_factor=strength_factor,
        yield_slope=yield_slope, yield_sine=yield_sine,
        yield_apex=yield_apex, flow_slope=flow_slope, flow_sine=flow_sine, flow_apex=flow_apex,
    ).items():  # fmt: skip
        setattr(m, name, real(value))
    return m


class PlasticFunctions(NamedTuple):
    """Warp functions of one yield function (``m`` is a :func:`material_struct` value)."""

    invariants: Callable
    """(σ) → (I₁ [Pa], J₂ [Pa²], J₃ [Pa³])."""
    lode_angle: Callable
    """(σ) → ϑ [rad] in [−π/6, π/6]; 0 where J₂ ≤ J2_FLOOR."""
    yield_value: Callable
    """(σ, ε̄, m) → F [Pa]."""
    yield_gradient: Callable
    """(σ, m) → ∂F/∂σ [-]."""
    potential_value: Callable
    """(σ, m) → G [Pa] (defined up to a constant)."""
    potential_gradient: Callable
    """(σ, m) → ∂G/∂σ [-]."""
    perzyna_strain_rate: Callable
    """(σ, ε̄, m) → (d^vp [1/s], dε̄/dt [1/s])."""
    relaxation_rate: Callable
    """(σ, ε̄, λ, G, m) → λ_vp [1/s], the linearised relaxation rate at the state."""
    substep_count: Callable
    """(σ, ε̄, dt, λ, G, m) → int sub-steps the source takes over dt [s]."""
    relaxation_step: Callable
    """(σ, ε̄, W, h, λ, G, m) → (Δσ, Δε̄): one RK step of size h [s], no sub-stepping."""
    source_increment: Callable
    """(σ, ε̄, W, dt, λ, G, m) → (Δσ, Δε̄) over dt [s]: spin and relaxation, sub-stepped."""
    radial_return: Callable | None
    """von Mises only: (σ, ε̄, G, m) → (σ, ε̄) on the surface, the rate-independent limit γ → ∞."""
    tension_cutoff: Callable
    """(σ, ε̄, m) → (σ with its mean stress capped at the apex of the yield surface [Pa], the mean
    stress removed [Pa]) (frictional surfaces; von Mises: σ unchanged, 0)."""
    material_update: Callable
    """(σ_trial, ε̄, W, dt, λ, G, m) → (σ [Pa], Δε̄, mean stress the cut-offs removed [Pa]) over dt [s]."""


@functools.cache
def plastic_functions(spec: Spec, yield_name: str) -> PlasticFunctions:
    """Warp functions for ``yield_name`` (one of :data:`YIELD_NAMES`), RK order from
    ``spec.integrator``. Only the chosen yield function is compiled into a kernel that uses them."""
    if yield_name not in YIELD_NAMES:
        raise ValueError(f"unknown yield function {yield_name!r}; expected one of {YIELD_NAMES}")
    real, mat33 = spec.real, spec.mat33
    Material = material_struct(spec)
    hooke_rate = elastic_functions(spec)[0]
    zero, half, one, two, three = real(0.0), real(0.5), real(1.0), real(2.0), real(3.0)
    two_thirds, sqrt3 = real(2.0 / 3.0), real(math.sqrt(3.0))
    lode_scale = real(1.5 * math.sqrt(3.0))  # 3√3/2
    j2_floor = real(J2_FLOOR)
    sin_t, cos_t = real(math.sin(TRANSITION_ANGLE)), real(math.cos(TRANSITION_ANGLE))
    sin3_t, cos3_t = real(math.sin(3.0 * TRANSITION_ANGLE)), real(math.cos(3.0 * TRANSITION_ANGLE))
    constant_shape = real({"von_mises": math.sqrt(3.0), "drucker_prager": 1.0, "mohr_coulomb": 0.0}[yield_name])
    lode_dependent = yield_name == "mohr_coulomb"
    step_limit = real(RELAXATION_STEP[spec.integrator])
    max_substeps, max_substeps_real = MAX_SUBSTEPS, real(MAX_SUBSTEPS)
    sixth = real(1.0 / 6.0)

    @wp.func
    def invariants(sigma: mat33):
        """(I₁, J₂, J₃) of σ."""
        i1 = wp.trace(sigma)
        s = sigma - (i1 / three) * wp.identity(3, dtype=real)
        return i1, half * wp.ddot(s, s), wp.determinant(s)

    @wp.func
    def deviator_direction(sigma: mat33):
        """(I₁, q = √J₂, n = s/q); q = 0 and n = 0 where J₂ ≤ J2_FLOOR."""
        i1 = wp.trace(sigma)
        s = sigma - (i1 / three) * wp.identity(3, dtype=real)
        j2 = half * wp.ddot(s, s)
        q = zero
        inv_q = zero
        if j2 > j2_floor:
            q = wp.sqrt(j2)
            inv_q = one / q
        return i1, q, s * inv_q

    @wp.func
    def lode_sine(n: mat33):
        """ξ = sin 3ϑ = −(3√3/2) det n, clamped to [−1, 1]."""
        return wp.clamp(-lode_scale * wp.determinant(n), -one, one)

    @wp.func
    def lode_angle(sigma: mat33):
        """ϑ [rad]."""
        i1, q, n = deviator_direction(sigma)
        return wp.asin(lode_sine(n)) / three

    @wp.func
    def lode_sine_direction(n: mat33):
        """M = J₂ ∂ξ/∂σ / √J₂, bounded; meaningful where n ≠ 0 (elsewhere its weight t is 0)."""
        n_det = wp.determinant(n)
        return -lode_scale * (n * n - two_thirds * wp.identity(3, dtype=real) - (real(1.5) * n_det) * n)

    @wp.func
    def rounded_shape(xi: real, sine: real):
        """(K, dK/dξ) of the Abbo–Sloan rounded Mohr–Coulomb deviatoric section at ξ = sin 3ϑ."""
        k = zero
        dk_dxi = zero
        if wp.abs(xi) <= sin3_t:
            theta = wp.asin(xi) / three
            c = wp.cos(theta)
            s = wp.sin(theta)
            k = c - sine * s / sqrt3
            dk_dxi = (-s - sine * c / sqrt3) / (three * wp.sqrt(one - xi * xi))  # dK/dϑ / (dξ/dϑ)
        else:
            side = wp.sign(xi)
            b = (side * sin_t + sine * cos_t / sqrt3) / (three * cos3_t)
            a = cos_t - side * sine * sin_t / sqrt3 + b * side * sin3_t
            k = a - b * xi
            dk_dxi = -b
        return k, dk_dxi

    @wp.func
    def shape(n: mat33, sine: real):
        """(K, dK/dξ) for deviatoric direction n."""
        k = constant_shape
        dk_dxi = zero
        if wp.static(lode_dependent):
            k, dk_dxi = rounded_shape(lode_sine(n), sine)
        return k, dk_dxi

    @wp.func
    def surface_value(sigma: mat33, slope: real, sine: real, apex: real):
        """β I₁ + √(J₂K² + a²) [Pa]."""
        i1, q, n = deviator_direction(sigma)
        k, dk_dxi = shape(n, sine)
        return slope * i1 + wp.sqrt(q * q * k * k + apex * apex)

    @wp.func
    def surface_gradient(sigma: mat33, slope: real, sine: real, apex: real):
        """∂/∂σ of β I₁ + √(J₂K² + a²)."""
        i1, q, n = deviator_direction(sigma)
        k, dk_dxi = shape(n, sine)
        r = wp.sqrt(q * q * k * k + apex * apex)
        t = zero
        if r > zero:
            t = q * k / r
        grad = slope * wp.identity(3, dtype=real) + (half * k * t) * n
        if wp.static(lode_dependent):
            grad = grad + (dk_dxi * t) * lode_sine_direction(n)
        return grad

    @wp.func
    def yield_value(sigma: mat33, eps: real, m: Material):
        """F(σ, ε̄) [Pa]; > 0 outside the elastic domain."""
        strength = wp.max(m.strength + m.hardening * eps, m.residual_strength)
        return surface_value(sigma, m.yield_slope, m.yield_sine, m.yield_apex) - m.strength_factor * strength

    @wp.func
    def yield_gradient(sigma: mat33, m: Material):
        """∂F/∂σ."""
        return surface_gradient(sigma, m.yield_slope, m.yield_sine, m.yield_apex)

    @wp.func
    def potential_value(sigma: mat33, m: Material):
        """G(σ) [Pa]."""
        return surface_value(sigma, m.flow_slope, m.flow_sine, m.flow_apex)

    @wp.func
    def potential_gradient(sigma: mat33, m: Material):
        """∂G/∂σ, the direction of d^vp."""
        return surface_gradient(sigma, m.flow_slope, m.flow_sine, m.flow_apex)

    @wp.func
    def overstress_rate(f: real, m: Material):
        """γ ⟨F/F₀⟩^N [1/s]."""
        rate = zero
        if f > zero:
            rate = m.fluidity * wp.pow(f / m.reference_stress, m.exponent)
        return rate

    @wp.func
    def perzyna_strain_rate(sigma: mat33, eps: real, m: Material):
        """(d^vp = γ⟨F/F₀⟩^N ∂G/∂σ [1/s], dε̄/dt = √(⅔ d^vp:d^vp) [1/s])."""
        d_vp = overstress_rate(yield_value(sigma, eps, m), m) * potential_gradient(sigma, m)
        return d_vp, wp.sqrt(two_thirds * wp.ddot(d_vp, d_vp))

    @wp.func
    def relaxation_rate(sigma: mat33, eps: real, lam: real, shear: real, m: Material):
        """λ_vp = γN⟨F/F₀⟩^{N−1}/F₀ (|∂F:Dᵉ:∂G| + k_c|H|√(⅔ ∂G:∂G)) [1/s]; 0 inside the surface."""
        f = yield_value(sigma, eps, m)
        rate = zero
        if f > zero:
            flow = potential_gradient(sigma, m)
            stiffness = wp.abs(wp.ddot(yield_gradient(sigma, m), hooke_rate(flow, lam, shear)))
            stiffness += m.strength_factor * wp.abs(m.hardening) * wp.sqrt(two_thirds * wp.ddot(flow, flow))
            slope = m.fluidity * m.exponent / m.reference_stress * wp.pow(f / m.reference_stress, m.exponent - one)
            rate = slope * stiffness
        return rate

    @wp.func
    def substep_count(sigma: mat33, eps: real, dt: real, lam: real, shear: real, m: Material):
        """ceil(λ_vp dt / RELAXATION_STEP), within [1, MAX_SUBSTEPS] (NaN → MAX_SUBSTEPS)."""
        x = relaxation_rate(sigma, eps, lam, shear, m) * dt / step_limit
        count = max_substeps
        if x <= max_substeps_real:
            count = wp.max(wp.int32(wp.ceil(x)), 1)
        return count

    @wp.func
    def source_rate(sigma: mat33, eps: real, spin: mat33, lam: real, shear: real, m: Material):
        """(dσ/dt, dε̄/dt) of the source: Jaumann spin Wσ − σW and relaxation −Dᵉ:d^vp."""
        d_vp, eps_rate = perzyna_strain_rate(sigma, eps, m)
        return spin * sigma - sigma * spin - hooke_rate(d_vp, lam, shear), eps_rate

    if spec.integrator == "rk4":

        @wp.func
        def relaxation_step(sigma: mat33, eps: real, spin: mat33, h: real, lam: real, shear: real, m: Material):
            """One RK4 step of size h [s]: (Δσ, Δε̄)."""
            hh = half * h
            k1s, k1e = source_rate(sigma, eps, spin, lam, shear, m)
            k2s, k2e = source_rate(sigma + hh * k1s, eps + hh * k1e, spin, lam, shear, m)
            k3s, k3e = source_rate(sigma + hh * k2s, eps + hh * k2e, spin, lam, shear, m)
            k4s, k4e = source_rate(sigma + h * k3s, eps + h * k3e, spin, lam, shear, m)
            w = h * sixth
            return w * (k1s + two * k2s + two * k3s + k4s), w * (k1e + two * k2e + two * k3e + k4e)

    else:

        @wp.func
        def relaxation_step(sigma: mat33, eps: real, spin: mat33, h: real, lam: real, shear: real, m: Material):
            """One RK2 (midpoint) step of size h [s]: (Δσ, Δε̄)."""
            hh = half * h
            k1s, k1e = source_rate(sigma, eps, spin, lam, shear, m)
            k2s, k2e = source_rate(sigma + hh * k1s, eps + hh * k1e, spin, lam, shear, m)
            return h * k2s, h * k2e

    @wp.func
    def source_increment(sigma: mat33, eps: real, spin: mat33, dt: real, lam: real, shear: real, m: Material):
        """(Δσ [Pa], Δε̄) of the source over dt [s] in substep_count equal RK sub-steps."""
        count = substep_count(sigma, eps, dt, lam, shear, m)
        h = dt / real(count)
        d_sigma = sigma * zero
        d_eps = zero
        for _ in range(count):
            ds, de = relaxation_step(sigma + d_sigma, eps + d_eps, spin, h, lam, shear, m)
            d_sigma = d_sigma + ds
            d_eps = d_eps + de
        return d_sigma, d_eps

    @wp.func
    def tension_cutoff(sigma: mat33, eps: real, m: Material):
        """σ less the mean stress beyond the apex p_t = (k_c s_y(ε̄) − a)/(3β), where F = 0 with no
        deviator [Pa]: no deviatoric flow (and, with ψ < φ, little volumetric flow) brings a stress
        beyond the apex back, so it is cut off at once (a tension crack: the volume the elastic law
        gave that mean stress opens between the particles; the caller keeps it out of the density)."""
        out = sigma
        removed = zero
        if m.yield_slope > zero:
            apex_mean = -yield_value(sigma * zero, eps, m) / (three * m.yield_slope)
            excess = wp.trace(sigma) / three - apex_mean
            if excess > zero:
                out = sigma - excess * wp.identity(3, dtype=real)
                removed = excess
        return out, removed

    @wp.func
    def material_update(sigma: mat33, eps: real, spin: mat33, dt: real, lam: real, shear: real, m: Material):
        """(σ [Pa], Δε̄, mean stress removed [Pa]) after dt [s] from the elastic trial σ: the tension
        beyond the apex cut off, the source over dt, then cut off again. Cut first because the crack
        opens at once: left to the relaxation, a trial beyond the apex with a small deviator has F of
        the excess but ∂G of the deviator alone (a cylinder's axis at ψ = 0), and turns it through zero."""
        s, removed = tension_cutoff(sigma, eps, m)
        d_s, d_eps = source_increment(s, eps, spin, dt, lam, shear, m)
        out, more = tension_cutoff(s + d_s, eps + d_eps, m)
        return out, d_eps, removed + more

    radial_return = None
    if yield_name == "von_mises":

        @wp.func
        def radial_return(sigma: mat33, eps: real, shear: real, m: Material):
            """Closest-point projection of a trial σ onto √(3J₂) = σ_Y0 + Hε̄ (linear hardening, 3G + H
            > 0): Δε̄ = F/(3G + H), s scaled by 1 − 3GΔε̄/√(3J₂); the pressure is unchanged."""
            f = yield_value(sigma, eps, m)
            out_sigma = sigma
            out_eps = eps
            if f > zero:
                i1, q, n = deviator_direction(sigma)
                d_eps = f / (three * shear + m.hardening)
                out_sigma = sigma - (sqrt3 * shear * d_eps) * n  # s ← s − 2G Δε̄ (√3/2) n
                out_eps = eps + d_eps
            return out_sigma, out_eps

    return PlasticFunctions(
        invariants, lode_angle, yield_value, yield_gradient, potential_value, potential_gradient,
        perzyna_strain_rate, relaxation_rate, substep_count, relaxation_step, source_increment, radial_return,
        tension_cutoff, material_update,
    )  # fmt: skip
