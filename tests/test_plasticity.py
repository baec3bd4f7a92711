"""Perzyna viscoplasticity at a material point, through the production Warp functions.

Units: stresses in Pa, times in s. Tension positive.

The relaxation closed form (verification.md, "Viscoplastic source integrator") at a frozen strain:
start from uniaxial stress σ₀ e_x⊗e_x plus any pressure, von Mises, N = 1. The flow d^vp = r
diag(1, −½, −½) is deviatoric, so the pressure stays put and the source −Dᵉ:d^vp = −2G d^vp
lowers σ_xx − σ_yy = σ_eq by 3G r, with r = γ (σ_eq − σ_Y)/F₀ the axial plastic strain rate. Hence
σ_eq − σ_Y = (σ₀ − σ_Y) exp(−E γ t/F₀) with E = 3G, which is Young's modulus at ν = ½ — the modulus
that relates the axial stress to the axial plastic strain when the lateral stresses follow (at
another ν a bar held in uniaxial stress would relax at E, the frozen 3D point at 3G). With linear
hardening H the overstress F = σ_eq − σ_Y0 − Hε̄ relaxes at (3G + H)γ/F₀ and σ_eq + 3Gε̄ is
conserved.
"""

import functools
import math

import numpy as np
import pytest
import warp as wp

from warpsph.environment import default_device
from warpsph.physics.plasticity import (
    RELAXATION_STEP,
    TRANSITION_ANGLE,
    YIELD_NAMES,
    material_struct,
    plastic_functions,
    viscoplastic_material,
)
from warpsph.sph.spec import Spec

wp.config.quiet = True
DEVICE = default_device()  # WARPSPH_DEVICE, else the CPU
RNG_SEED = 4
COHESION = 20e3
FRICTION = math.radians(30.0)
DILATANCY = math.radians(10.0)
SHEAR = 1.0e7  # G [Pa]
LAMBDA = 2.5e7  # λ [Pa]; tr d^vp = 0 for von Mises, so it does not enter the closed form
YOUNG = 3.0 * SHEAR  # E of the closed form
SIGMA_Y = 1.0e5


@functools.cache
def _kernels(spec: Spec, yield_name: str):
    real, mat33 = spec.real, spec.mat33
    Material = material_struct(spec)
    fn = plastic_functions(spec, yield_name)
    invariants, lode_angle = fn.invariants, fn.lode_angle
    yield_value, yield_gradient = fn.yield_value, fn.yield_gradient
    potential_value, potential_gradient = fn.potential_value, fn.potential_gradient
    perzyna_strain_rate, substep_count = fn.perzyna_strain_rate, fn.substep_count
    relaxation_step, source_increment = fn.relaxation_step, fn.source_increment
    tension_cutoff, material_update = fn.tension_cutoff, fn.material_update

    @wp.kernel(enable_backward=False, module="unique")
    def cutoff(sigma: wp.array(dtype=mat33), m: Material, out: wp.array(dtype=mat33), removed: wp.array(dtype=real)):
        """Per state: the tension cut-off's stress and the mean stress it removed [Pa]."""
        i = wp.tid()
        s, r = tension_cutoff(sigma[i], real(0.0), m)
        out[i] = s
        removed[i] = r

    @wp.kernel(enable_backward=False, module="unique")
    def evaluate(
        sigma: wp.array(dtype=mat33),
        eps: wp.array(dtype=real),
        m: Material,
        inv: wp.array(dtype=spec.vec4),
        f: wp.array(dtype=real),
        df: wp.array(dtype=mat33),
        g: wp.array(dtype=real),
        dg: wp.array(dtype=mat33),
        d_vp: wp.array(dtype=mat33),
        eps_rate: wp.array(dtype=real),
    ):
        """Per state: (I₁, J₂, J₃, ϑ), F, ∂F/∂σ, G, ∂G/∂σ, d^vp, dε̄/dt."""
        i = wp.tid()
        s = sigma[i]
        i1, j2, j3 = invariants(s)
        inv[i] = spec.vec4(i1, j2, j3, lode_angle(s))
        f[i] = yield_value(s, eps[i], m)
        df[i] = yield_gradient(s, m)
        g[i] = potential_value(s, m)
        dg[i] = potential_gradient(s, m)
        d, r = perzyna_strain_rate(s, eps[i], m)
        d_vp[i] = d
        eps_rate[i] = r

    @wp.kernel(enable_backward=False, module="unique")
    def relax(
        sigma0: mat33,
        eps0: real,
        spin: mat33,
        dt: real,
        lam: real,
        shear: real,
        m: Material,
        substepped: int,
        sigma: wp.array(dtype=mat33),
        eps: wp.array(dtype=real),
        counts: wp.array(dtype=wp.int32),
    ):
        """sigma[k], eps[k] after k intervals dt of source_increment (or of one unsub-stepped
        relaxation_step when substepped == 0); counts[k] the sub-steps interval k took."""
        s = sigma0
        e = eps0
        sigma[0] = s
        eps[0] = e
        for k in range(sigma.shape[0] - 1):
            counts[k] = substep_count(s, e, dt, lam, shear, m)
            if substepped != 0:
                ds, de = source_increment(s, e, spin, dt, lam, shear, m)
            else:
                ds, de = relaxation_step(s, e, spin, dt, lam, shear, m)
            s = s + ds
            e = e + de
            sigma[k + 1] = s
            eps[k + 1] = e

    @wp.kernel(enable_backward=False, module="unique")
    def update(
        sigma0: mat33,
        dt: real,
        lam: real,
        shear: real,
        m: Material,
        sigma: wp.array(dtype=mat33),
        removed: wp.array(dtype=real),
    ):
        """sigma[k] after k intervals dt of material_update at zero strain rate and spin; removed[k]
        the mean stress its cut-offs removed in interval k."""
        s = sigma0
        e = real(0.0)
        sigma[0] = s
        for k in range(sigma.shape[0] - 1):
            s, de, r = material_update(s, e, mat33(real(0.0)), dt, lam, shear, m)
            e = e + de
            removed[k] = r
            sigma[k + 1] = s

    kernels = {"evaluate": evaluate, "relax": relax, "cutoff": cutoff, "update": update}
    if fn.radial_return is not None:
        radial_return = fn.radial_return

        @wp.kernel(enable_backward=False, module="unique")
        def project(sigma: wp.array(dtype=mat33), eps: real, shear: real, m: Material, out: wp.array(dtype=mat33),
                    out_eps: wp.array(dtype=real)):  # fmt: skip
            i = wp.tid()
            s, e = radial_return(sigma[i], eps, shear, m)
            out[i] = s
            out_eps[i] = e

        kernels["project"] = project
    return kernels


def material(spec: Spec, yield_name: str, **overrides):
    """Soil-like defaults: c = 20 kPa, φ = 30°, ψ = 10° (σ_Y = 100 kPa for von Mises), γ = 1/s,
    F₀ = strength."""
    strength = SIGMA_Y if yield_name == "von_mises" else COHESION
    params = dict(strength=strength, fluidity=1.0, reference_stress=strength, friction=FRICTION, dilatancy=DILATANCY)
    params.update(overrides)
    return viscoplastic_material(spec, yield_name, **params)


def evaluate(spec: Spec, yield_name: str, m, sigma: np.ndarray, eps=0.0) -> dict:
    """Run the evaluate kernel on stresses (n, 3, 3) and ε̄ (scalar or (n,)); numpy float64 out."""
    n = len(sigma)
    eps = wp.array(np.broadcast_to(np.asarray(eps, dtype=np.float64), (n,)), dtype=spec.real, device=DEVICE)
    out = {
        "inv": wp.zeros(n, dtype=spec.vec4, device=DEVICE),
        **{k: wp.zeros(n, dtype=spec.real, device=DEVICE) for k in ("f", "g", "eps_rate")},
        **{k: wp.zeros(n, dtype=spec.mat33, device=DEVICE) for k in ("df", "dg", "d_vp")},
    }
    s = wp.array(np.asarray(sigma), dtype=spec.mat33, device=DEVICE)
    names = ("inv", "f", "df", "g", "dg", "d_vp", "eps_rate")  # the kernel's output order
    wp.launch(_kernels(spec, yield_name)["evaluate"], dim=n, inputs=[s, eps, m, *(out[k] for k in names)],
              device=DEVICE)
    return {k: v.numpy().astype(np.float64) for k, v in out.items()}


def relax(spec: Spec, yield_name: str, m, sigma0: np.ndarray, dt: float, steps: int, eps0: float = 0.0,
          substepped: bool = True, spin: np.ndarray | None = None):  # fmt: skip
    """(σ history (steps+1, 3, 3), ε̄ history (steps+1,), sub-step counts (steps,))."""
    sigma = wp.zeros(steps + 1, dtype=spec.mat33, device=DEVICE)
    eps = wp.zeros(steps + 1, dtype=spec.real, device=DEVICE)
    counts = wp.zeros(steps, dtype=wp.int32, device=DEVICE)
    w = np.zeros((3, 3)) if spin is None else spin
    inputs = [spec.mat33(sigma0), spec.real(eps0), spec.mat33(w), spec.real(dt), spec.real(LAMBDA), spec.real(SHEAR),
              m, int(substepped), sigma, eps, counts]  # fmt: skip
    wp.launch(_kernels(spec, yield_name)["relax"], dim=1, inputs=inputs, device=DEVICE)
    return sigma.numpy().astype(np.float64), eps.numpy().astype(np.float64), counts.numpy()


# ---------------------------------------------------------------------------------------------
# Stress states


def rotation(rng) -> np.ndarray:
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    return q * np.sign(np.diag(r))


def principal(p: float, q: float, theta: float) -> np.ndarray:
    """Principal stresses (σ₁ ≥ σ₂ ≥ σ₃) of mean p, √J₂ = q and Lode angle ϑ (method convention)."""
    k = 2.0 / math.sqrt(3.0) * q
    return p + k * np.sin(theta + np.array([2.0, 0.0, -2.0]) * math.pi / 3.0)


def state(p: float, q: float, theta: float, rng) -> np.ndarray:
    r = rotation(rng)
    return r @ np.diag(principal(p, q, theta)) @ r.T


def random_states(rng, n: int) -> np.ndarray:
    """Symmetric stresses with compressive mean around −100 kPa and deviators of tens of kPa."""
    a = rng.normal(scale=40e3, size=(n, 3, 3))
    return 0.5 * (a + a.transpose(0, 2, 1)) - 100e3 * np.eye(3)


def mises(sigma: np.ndarray) -> np.ndarray:
    s = sigma - np.trace(sigma, axis1=-2, axis2=-1)[..., None, None] / 3.0 * np.eye(3)
    return np.sqrt(1.5 * np.einsum("...ij,...ij->...", s, s))


# ---------------------------------------------------------------------------------------------
# Invariants and yield surfaces


def test_invariants_and_lode_angle_convention():
    """I₁, J₂, J₃ match numpy; ϑ = +30° in triaxial compression (two larger principal stresses equal,
    tension positive) and −30° in triaxial extension, ϑ of principal(p, q, ϑ) comes back; a pure
    pressure (J₂ = 0, and J₂ at round-off) gives ϑ = 0 and finite gradients."""
    spec = Spec()
    rng = np.random.default_rng(RNG_SEED)
    angles = np.radians([30.0, -30.0, 0.0, 12.0, -27.0])
    sigma = np.array([np.diag([-100e3, -100e3, -300e3]), np.diag([-100e3, -300e3, -300e3])]
                     + [state(-50e3, 30e3, t, rng) for t in angles[2:]]
                     + [-70e3 * np.eye(3), -70e3 * np.eye(3) + 1e-9 * random_states(rng, 1)[0]])  # fmt: skip
    for name in YIELD_NAMES:
        out = evaluate(spec, name, material(spec, name), sigma)
        assert np.all(np.isfinite(out["df"])) and np.all(np.isfinite(out["dg"])), name
    i1, j2, j3, theta = out["inv"].T
    s = sigma - np.trace(sigma, axis1=1, axis2=2)[:, None, None] / 3.0 * np.eye(3)
    assert np.allclose(i1, np.trace(sigma, axis1=1, axis2=2), rtol=1e-14, atol=1e-9)
    assert np.allclose(j2, 0.5 * np.einsum("nij,nij->n", s, s), rtol=1e-12, atol=1e-9)
    assert np.allclose(j3, np.linalg.det(s), rtol=1e-9, atol=1e-3)
    assert np.allclose(theta[:5], angles, atol=1e-7), np.degrees(theta)
    assert theta[5] == 0.0


def fd_check(spec, name, m, sigma, rng, h_rel=1e-6) -> tuple[float, float]:
    """Largest relative mismatch of ∂F/∂σ : E and ∂G/∂σ : E against central differences of F and G
    along random symmetric unit directions E (step h = h_rel·|σ|)."""
    e = rng.normal(size=sigma.shape)
    e = 0.5 * (e + e.transpose(0, 2, 1))
    e /= np.linalg.norm(e, axis=(1, 2))[:, None, None]
    h = h_rel * np.linalg.norm(sigma, axis=(1, 2))[:, None, None]
    mid, plus, minus = (evaluate(spec, name, m, x) for x in (sigma, sigma + h * e, sigma - h * e))
    mismatch = []
    for value, grad in (("f", "df"), ("g", "dg")):
        fd = (plus[value] - minus[value]) / (2.0 * h[:, 0, 0])
        exact = np.einsum("nij,nij->n", mid[grad], e)
        mismatch.append(float(np.max(np.abs(fd - exact) / np.linalg.norm(mid[grad], axis=(1, 2)))))
    return tuple(mismatch)


@pytest.mark.parametrize("name", YIELD_NAMES)
def test_gradients_match_finite_differences(name):
    """∂F/∂σ and ∂G/∂σ (ψ = 10° ≠ φ = 30°: non-associated for DP and MC) against central differences
    of F and G, float64, at 40 random states and, for every yield, at Lode angles on both sides of
    the Mohr–Coulomb transition ±25° and at and next to the corners ±30°. Mismatch relative to |∂F|
    below 1e-6 (measured ≤ 5e-10: FD truncation and round-off)."""
    spec = Spec()
    rng = np.random.default_rng(RNG_SEED)
    near = [t + d for t in (TRANSITION_ANGLE, -TRANSITION_ANGLE) for d in (-1e-4, 1e-4)]
    corners = [math.radians(a) for a in (30.0, -30.0, 29.99, -29.99, 29.0, -29.0)]
    sigma = np.concatenate([random_states(rng, 40),
                            [state(-60e3, 25e3, t, rng) for t in near + corners],
                            [state(5e3, 2e3, t, rng) for t in near + corners]])  # fmt: skip  # near the MC apex
    m = material(spec, name)
    mismatch = fd_check(spec, name, m, sigma, rng)
    assert max(mismatch) < 1e-6, mismatch


def classic_mohr_coulomb(sigma: np.ndarray) -> np.ndarray:
    """(σ₁ − σ₃)/2 + (σ₁ + σ₃)/2 sinφ − c cosφ from the principal stresses."""
    w = np.linalg.eigvalsh(sigma)
    s1, s3 = w[..., 2], w[..., 0]
    return 0.5 * (s1 - s3) + 0.5 * (s1 + s3) * math.sin(FRICTION) - COHESION * math.cos(FRICTION)


def test_mohr_coulomb_is_the_classic_surface_away_from_corners():
    """Without apex rounding (a = 0) and for |ϑ| ≤ ϑ_T = 25°, F equals the principal-stress form
    (σ₁ − σ₃)/2 + (σ₁ + σ₃)/2 sinφ − c cosφ (to 1e-9 c) at random states, and is 0 at states moved
    onto that surface. With the default apex (f = 0.05) F exceeds it by at most a sinφ = f c cosφ.
    Beyond ϑ_T the rounding lies inside the classic surface: at the corners ±30° K exceeds the
    classic K by 4.5 % (φ = 30°, measured, asserted < 6 %) and between ϑ_T and 30° by less."""
    spec = Spec()
    rng = np.random.default_rng(RNG_SEED)
    thetas = rng.uniform(-TRANSITION_ANGLE, TRANSITION_ANGLE, 30)
    sigma = np.array([state(rng.uniform(-200e3, 20e3), rng.uniform(1e3, 80e3), t, rng) for t in thetas])
    sharp = evaluate(spec, "mohr_coulomb", material(spec, "mohr_coulomb", apex_fraction=0.0), sigma)
    classic = classic_mohr_coulomb(sigma)
    assert np.max(np.abs(sharp["f"] - classic)) < 1e-9 * COHESION
    on_surface = sigma - (classic / math.sin(FRICTION))[:, None, None] * np.eye(3)  # shift the mean stress
    assert np.max(np.abs(evaluate(spec, "mohr_coulomb", material(spec, "mohr_coulomb", apex_fraction=0.0),
                                  on_surface)["f"])) < 1e-9 * COHESION  # fmt: skip
    rounded = evaluate(spec, "mohr_coulomb", material(spec, "mohr_coulomb"), sigma)["f"] - classic
    assert np.all(rounded >= -1e-9) and np.all(rounded <= 0.05 * COHESION * math.cos(FRICTION) + 1e-9)
    # corners: F + k_c c − β I₁ = √J₂ K at a = 0, so K = that / √J₂
    q = 30e3
    outer = np.radians([25.0, 27.0, 29.0, 30.0, -25.0, -27.0, -29.0, -30.0])
    corner_states = np.array([np.diag(principal(0.0, q, t)) for t in outer])
    k = (evaluate(spec, "mohr_coulomb", material(spec, "mohr_coulomb", apex_fraction=0.0), corner_states)["f"]
         + COHESION * math.cos(FRICTION)) / q  # fmt: skip
    k_classic = np.cos(outer) - math.sin(FRICTION) * np.sin(outer) / math.sqrt(3.0)
    excess = k / k_classic - 1.0
    assert np.all(excess >= -1e-12) and np.all(np.diff(excess[:4]) > 0) and np.all(np.diff(excess[4:]) > 0)
    assert excess.max() < 0.06 and abs(excess[0]) < 1e-12, excess


def deviatoric_circle(omega: np.ndarray, p: float = -80e3, q: float = 30e3) -> np.ndarray:
    """Diagonal stresses of mean p and √J₂ = q at polar angle ω in the deviatoric plane; for
    |ω| ≤ 30° the diagonal is ordered σ₁ ≥ σ₂ ≥ σ₃ and ϑ = ω."""
    return np.array([np.diag(principal(p, q, w)) for w in omega])


def test_rounded_mohr_coulomb_is_smooth_around_the_deviatoric_plane():
    """A full turn of the deviatoric plane at fixed p, √J₂ (all six sextants, corners included), in
    M = 720 and 1440 samples: neighbours differ in ∂F/∂σ by at most C/M relative to max |∂F| and
    halving the spacing halves the largest jump, in F and in ∂F/∂σ (a jump or a kink would keep
    it). Measured: C = 48.8 (asserted < 100), largest where the rounding is tightest, next to the
    triaxial-compression corner ϑ = 30°; ratios 2.00 and 1.99. F changes by at most 177 Pa per 0.5°."""
    spec = Spec()
    m = material(spec, "mohr_coulomb")

    def largest_jump(samples):
        out = evaluate(spec, "mohr_coulomb", m, deviatoric_circle(2.0 * np.pi * (np.arange(samples) + 0.5) / samples))
        grad = out["df"]
        jump = np.linalg.norm(np.diff(grad, axis=0, append=grad[:1]), axis=(1, 2)).max()
        return jump / np.linalg.norm(grad, axis=(1, 2)).max(), np.abs(np.diff(out["f"])).max()

    (g1, f1), (g2, f2) = largest_jump(720), largest_jump(1440)
    assert g1 * 720 < 100.0 and 1.8 < g1 / g2 < 2.2, (g1, g2)
    assert f1 < 1e3 and 1.8 < f1 / f2 < 2.2, (f1, f2)
    # straddling the transitions ±ϑ_T and the corners ±30° by ±δ, δ = 1e-6 rad: ∂F/∂σ differs by
    # (measured) 2.5–16 δ relative, asserted < 50 δ; a slope mismatch of K at ϑ_T would leave O(1e-2)
    centres = np.array([TRANSITION_ANGLE, -TRANSITION_ANGLE, np.pi / 6, -np.pi / 6])
    delta = 1e-6
    straddling = deviatoric_circle(np.concatenate([centres - delta, centres + delta]))
    grad = evaluate(spec, "mohr_coulomb", m, straddling)["df"]
    jump = np.linalg.norm(grad[4:] - grad[:4], axis=(1, 2)) / np.linalg.norm(grad, axis=(1, 2)).max()
    assert np.all(jump < 50.0 * delta), jump / delta


def test_drucker_prager_matches_mohr_coulomb_in_plane_strain():
    """Plane strain with associated DP flow: d^vp_zz = 0 makes s_zz = −2α√J₂, then
    F_DP = 3 F_MC / (cosφ √(9 + 12 tan²φ)) with F_MC the in-plane (σ₁, σ₃) Mohr–Coulomb function —
    the two surfaces agree in plane strain. States: random in-plane principal stresses and
    orientation, σ_zz from that condition; checked ∂F/∂σ_zz = 0 and the ratio to 1e-9."""
    spec = Spec()
    rng = np.random.default_rng(RNG_SEED)
    tan = math.tan(FRICTION)
    alpha = tan / math.sqrt(9.0 + 12.0 * tan * tan)
    sigma, f_mc = [], []
    for _ in range(20):
        centre, radius = rng.uniform(-150e3, 0.0), rng.uniform(5e3, 60e3)  # in-plane p′ and t
        s_zz = -2.0 * alpha * radius / math.sqrt(1.0 - 3.0 * alpha * alpha)  # J₂ = t²/(1 − 3α²)
        c, s = math.cos(a := rng.uniform(0, np.pi)), math.sin(a)
        r = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        sigma.append(r @ np.diag([centre + radius, centre - radius, centre + 1.5 * s_zz]) @ r.T)
        f_mc.append(radius + centre * math.sin(FRICTION) - COHESION * math.cos(FRICTION))
    out = evaluate(spec, "drucker_prager", material(spec, "drucker_prager", dilatancy=FRICTION), np.array(sigma))
    assert np.max(np.abs(out["df"][:, 2, 2])) < 1e-12
    ratio = 3.0 / (math.cos(FRICTION) * math.sqrt(9.0 + 12.0 * tan * tan))
    assert np.max(np.abs(out["f"] - ratio * np.array(f_mc))) < 1e-9 * COHESION


# ---------------------------------------------------------------------------------------------
# Perzyna relaxation


def uniaxial(sigma0: float, pressure: float = -50e3) -> np.ndarray:
    """σ₀ e_x⊗e_x plus a pressure (that von Mises ignores)."""
    return np.diag([sigma0, 0.0, 0.0]) + pressure * np.eye(3)


def overstress_error(spec, m, dt, steps, sigma0=1.5 * SIGMA_Y, substepped=True, hardening=0.0, exponent=1.0):
    """Largest |σ_eq − σ_eq,exact| over the history, relative to the initial overstress; the
    sub-step counts. Exact: F(t) = F₀′ e^{−(3G+H)γt/F₀} for N = 1 and
    F₀′/(1 + (3G+H)γF₀′t/F₀²) for N = 2 (F₀′ the initial overstress)."""
    sigma, eps, counts = relax(spec, "von_mises", m, uniaxial(sigma0), dt, steps, substepped=substepped)
    t = dt * np.arange(steps + 1)
    f_init = sigma0 - SIGMA_Y
    modulus = (3.0 * SHEAR + hardening) * float(m.fluidity) / float(m.reference_stress)
    if exponent == 1.0:
        f = f_init * np.exp(-modulus * t)
    else:
        f = f_init / (1.0 + modulus * f_init / float(m.reference_stress) * t)
    exact = SIGMA_Y + hardening * (f_init - f) / (3.0 * SHEAR + hardening) + f
    return float(np.abs(mises(sigma) - exact).max() / f_init), counts, sigma, eps


@pytest.mark.parametrize("integrator,order,steps", [("rk4", 4, 8), ("rk2", 2, 8)])
def test_relaxation_converges_to_closed_form_at_integrator_order(integrator, order, steps):
    """Frozen strain, N = 1, von Mises, no hardening, λ_vp = Eγ/F₀ = 100/s over T = 0.02 s
    (λT = 2), N and 2N intervals with one sub-step each (λΔt ≤ RELAXATION_STEP; the counts are
    checked): the observed order log2(e_N/e_2N) is within ±0.3 of 4 (RK4) or 2 (RK2). The stress
    stays uniaxial plus the initial pressure (I₁ exact, σ_yy = σ_zz, no shear). Measured (e = max
    over the history of |σ_eq − exact| / initial overstress): RK4 N = 8: 1.48e-5 → 8.3e-7, order
    4.15 (4.30 from N = 4, 4.08 from N = 16); RK2 N = 8: 4.6e-3 → 1.05e-3, order 2.14."""
    spec = Spec(integrator=integrator)
    rate = 100.0
    m = material(spec, "von_mises", fluidity=rate * SIGMA_Y / YOUNG)
    dt = 2.0 / rate / steps
    e1, c1, sigma, _ = overstress_error(spec, m, dt, steps)
    e2, c2, _, _ = overstress_error(spec, m, dt / 2, 2 * steps)
    assert np.all(c1 == 1) and np.all(c2 == 1), (c1, c2)
    observed = np.log2(e1 / e2)
    assert abs(observed - order) < 0.3, (e1, e2, observed)
    assert np.allclose(np.trace(sigma, axis1=1, axis2=2), np.trace(uniaxial(1.5 * SIGMA_Y)), rtol=1e-14)
    assert np.allclose(sigma[:, 1, 1], sigma[:, 2, 2], rtol=0, atol=1e-9)
    assert np.all(sigma[:, ~np.eye(3, dtype=bool)] == 0.0)


@pytest.mark.parametrize("integrator", ["rk4", "rk2"])
def test_substepping_keeps_stiff_relaxation_stable_and_accurate(integrator):
    """λ_vp Δt = 50: one unsub-stepped RK step (relaxation_step over Δt) overshoots the surface by
    2.0e5 (RK4) and 1.0e3 (RK2) times the initial overstress — unstable; source_increment takes
    ceil(50/RELAXATION_STEP) sub-steps (50 RK4, 100 RK2), lands on σ_Y to 1e-9 of the overstress
    and stays there over 10 intervals. Over one interval at λΔt from 0.3 to 20 the error against
    the closed form stays below 1 % (RK4) and 3 % (RK2) of the initial overstress; the worst case
    is λΔt = 1 (measured in a sweep over (0, 30]: RK4 0.71 %, one sub-step at λh = 1; RK2 2.3 %,
    two at λh = ½)."""
    spec = Spec(integrator=integrator)
    rate = 1000.0
    m = material(spec, "von_mises", fluidity=rate * SIGMA_Y / YOUNG)
    dt = 50.0 / rate
    unstable, _, _, _ = overstress_error(spec, m, dt, 1, substepped=False)
    assert unstable > 1e2, unstable
    error, counts, _, _ = overstress_error(spec, m, dt, 10)
    assert np.all(counts[:1] == math.ceil(50.0 / RELAXATION_STEP[integrator])) and np.all(counts[1:] == 1), counts
    assert error < 1e-9, error
    errors = [overstress_error(spec, m, x / rate, 1)[0] for x in (0.3, 0.7, 1.0, 1.5, 2.5, 4.0, 7.0, 20.0)]
    assert max(errors) < {"rk4": 0.01, "rk2": 0.03}[integrator], errors


@pytest.mark.parametrize("hardening", [0.5 * SHEAR, -0.5 * SHEAR])
def test_hardening_and_softening_relax_consistently(hardening):
    """Linear hardening (H = +G/2) and softening (H = −G/2), N = 1, RK4: the overstress follows
    F(t) = F(0) e^{−(3G+H)γt/F₀} (to 1e-7 of F(0) at λΔt = 0.05; measured 2e-8), σ_eq + 3Gε̄ stays
    constant (the plastic strain is what the stress lost: to 1e-10 relative; measured 1e-15), ε̄
    tends to (σ₀ − σ_Y0)/(3G + H) (to e^{−20}), and the plastic work ∫σ:d^vp dt, from σ:d^vp
    evaluated on the history (Simpson), equals the elastic energy lost (σ_eq0² − σ_eq²)/(6G) to
    1e-6 (measured 2e-7), as does ∫σ_eq dε̄ (trapezoid, exact for σ_eq linear in ε̄) to 1e-10."""
    spec = Spec(integrator="rk4")
    rate = 100.0
    m = material(spec, "von_mises", fluidity=rate * SIGMA_Y / YOUNG, hardening=hardening)
    sigma0 = 1.5 * SIGMA_Y
    relaxation = rate * (3.0 * SHEAR + hardening) / YOUNG
    dt, steps = 0.05 / relaxation, 400  # to λt = 20
    error, counts, sigma, eps = overstress_error(spec, m, dt, steps, sigma0=sigma0, hardening=hardening)
    assert error < 1e-7, error
    q = mises(sigma)
    assert np.abs(q + 3.0 * SHEAR * eps - sigma0).max() < 1e-10 * sigma0
    assert abs(eps[-1] / ((sigma0 - SIGMA_Y) / (3.0 * SHEAR + hardening)) - 1.0) < 1e-8
    power = np.einsum("nij,nij->n", sigma, evaluate(spec, "von_mises", m, sigma, eps)["d_vp"])
    work = dt / 3.0 * (power[0] + 4.0 * power[1:-1:2].sum() + 2.0 * power[2:-1:2].sum() + power[-1])
    energy = (sigma0**2 - q[-1] ** 2) / (6.0 * SHEAR)
    conjugate = np.sum(0.5 * (q[1:] + q[:-1]) * np.diff(eps))
    assert abs(work / energy - 1.0) < 1e-6 and abs(conjugate / energy - 1.0) < 1e-10, (work, energy, conjugate)


def test_exponent_two_follows_its_closed_form():
    """N = 2: dF/dt = −3Gγ(F/F₀)², F(t) = F(0)/(1 + 3GγF(0)t/F₀²); RK4 with sub-steps sized from the
    initial (largest) rate, λΔt = 0.2: error below 1e-5 of the initial overstress (measured 4.4e-7)."""
    spec = Spec(integrator="rk4")
    m = material(spec, "von_mises", fluidity=100.0 * SIGMA_Y / YOUNG, exponent=2.0)
    error, _, _, _ = overstress_error(spec, m, 0.002, 50, exponent=2.0)
    assert error < 1e-5, error


@pytest.mark.parametrize("name", ["drucker_prager", "mohr_coulomb"])
def test_frictional_relaxation_reaches_the_surface(name):
    """Non-associated DP and MC (φ = 30°, ψ = 10°), frozen strain from a state 40 % beyond the
    surface in shear, RK4: F decreases monotonically to |F| < 1e-6 c; ε̄ ≥ √(⅔)|Dᵉ⁻¹:Δσ| (the plastic
    strain the stress loss implies; ε̄ integrates its rate along the path), with equality for DP,
    whose flow direction n/2 + α_ψ I stays fixed (to 1e-9 relative; measured 2e-16; MC exceeds it
    by 1e-4)."""
    spec = Spec(integrator="rk4")
    rng = np.random.default_rng(RNG_SEED)
    m = material(spec, name)
    sigma0 = state(-60e3, 80e3, math.radians(20.0), rng)
    f0 = evaluate(spec, name, m, sigma0[None])["f"][0]
    assert f0 > 0.2 * COHESION, f0
    sigma, eps, counts = relax(spec, name, m, sigma0, 5e-4, 200)
    f = evaluate(spec, name, m, sigma, eps)["f"]
    assert np.all(np.diff(f) < 1e-9 * COHESION) and abs(f[-1]) < 1e-6 * COHESION, (f[:3], f[-1])
    bulk = LAMBDA + 2.0 * SHEAR / 3.0
    d = sigma[-1] - sigma0
    mean = np.trace(d) / 3.0
    strain = (d - mean * np.eye(3)) / (2.0 * SHEAR) + mean / (3.0 * bulk) * np.eye(3)  # Dᵉ⁻¹:Δσ
    implied = math.sqrt(2.0 / 3.0) * np.linalg.norm(strain)
    assert eps[-1] >= implied * (1.0 - 1e-9), (eps[-1], implied)
    if name == "drucker_prager":
        assert abs(eps[-1] / implied - 1.0) < 1e-9, (eps[-1], implied)


def test_stiff_perzyna_limit_is_the_radial_return():
    """von Mises with hardening, λ_vp Δt = 200 in one interval (200 RK4 sub-steps): the Perzyna state
    equals the closest-point (radial) return of the same trial stress to 1e-9 relative, and the
    return lands on the hardened surface σ_eq = σ_Y0 + Hε̄."""
    spec = Spec(integrator="rk4")
    rng = np.random.default_rng(RNG_SEED)
    hardening = 0.2 * SHEAR
    rate = 200.0 * YOUNG / (3.0 * SHEAR + hardening)
    m = material(spec, "von_mises", fluidity=rate * SIGMA_Y / YOUNG, hardening=hardening)
    trials = [state(-40e3, 1.3 * SIGMA_Y / math.sqrt(3.0), t, rng) for t in np.radians([-20.0, 0.0, 28.0])]
    out = wp.zeros(3, dtype=spec.mat33, device=DEVICE)
    out_eps = wp.zeros(3, dtype=spec.real, device=DEVICE)
    trial_array = wp.array(np.array(trials), dtype=spec.mat33, device=DEVICE)
    wp.launch(_kernels(spec, "von_mises")["project"], dim=3, device=DEVICE,
              inputs=[trial_array, spec.real(0.0), spec.real(SHEAR), m, out, out_eps])  # fmt: skip
    returned, returned_eps = out.numpy(), out_eps.numpy()
    assert np.allclose(mises(returned), SIGMA_Y + hardening * returned_eps, rtol=1e-12)
    for trial, r, e in zip(trials, returned, returned_eps):
        sigma, eps, counts = relax(spec, "von_mises", m, trial, 1.0, 1)
        assert counts[0] == 200
        assert np.abs(sigma[-1] - r).max() < 1e-9 * SIGMA_Y and abs(eps[-1] / e - 1.0) < 1e-9


def test_spin_rotates_the_relaxing_stress_without_changing_its_invariants():
    """Relaxation under a rigid spin W about z (ω = 3 rad/s) equals the relaxation without spin
    turned by R(t) = exp(Wt): σ_W(t) = R σ(t) Rᵀ, since the relaxation is isotropic and the Jaumann
    term Wσ − σW only turns σ (to 1e-6 of σ_Y, measured 8e-10: RK truncation at ωΔt = 0.003)."""
    spec = Spec(integrator="rk4")
    m = material(spec, "von_mises", fluidity=50.0 * SIGMA_Y / YOUNG)
    omega = 3.0
    spin = omega * np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    still, _, _ = relax(spec, "von_mises", m, uniaxial(1.5 * SIGMA_Y), 1e-3, 60)
    turning, _, _ = relax(spec, "von_mises", m, uniaxial(1.5 * SIGMA_Y), 1e-3, 60, spin=spin)
    angle = omega * 1e-3 * np.arange(61)
    c, s = np.cos(angle), np.sin(angle)
    r = np.zeros((61, 3, 3))
    r[:, 0, 0], r[:, 0, 1], r[:, 1, 0], r[:, 1, 1], r[:, 2, 2] = c, -s, s, c, 1.0
    assert np.abs(turning[-1, 0, 1]) > 1e3  # it did turn
    assert np.abs(turning - r @ still @ r.transpose(0, 2, 1)).max() < 1e-6 * SIGMA_Y


def test_float32_compiles_and_relaxes():
    """float32: all three yields compile and their gradients agree with float64 to 1e-5 of the
    largest component (measured: von Mises 4e-7, DP 3e-7, MC 2.9e-6); the von Mises RK4 relaxation
    (λΔt = 0.5, 20 intervals) follows the float64 one to 1e-5 of the initial overstress in σ_eq and
    of the final value in ε̄ (measured 1.7e-7 and 5e-7: round-off, far below the 2.9e-4 truncation
    error both share at this step)."""
    spec32, spec64 = Spec(precision="float32", integrator="rk4"), Spec(integrator="rk4")
    runs = [overstress_error(s, material(s, "von_mises", fluidity=100.0 * SIGMA_Y / YOUNG), 0.005, 20)
            for s in (spec32, spec64)]  # fmt: skip
    (_, _, sigma32, eps32), (_, _, sigma64, eps64) = runs
    assert np.abs(mises(sigma32) - mises(sigma64)).max() < 1e-5 * 0.5 * SIGMA_Y
    assert np.abs(eps32 - eps64).max() < 1e-5 * eps64[-1]
    rng = np.random.default_rng(RNG_SEED)
    sigma = random_states(rng, 10)
    for name in YIELD_NAMES:
        g32 = evaluate(spec32, name, material(spec32, name), sigma)["df"]
        g64 = evaluate(Spec(), name, material(Spec(), name), sigma)["df"]
        assert np.abs(g32 - g64).max() < 1e-5 * np.abs(g64).max(), name


@pytest.mark.parametrize("name", YIELD_NAMES)
def test_tension_cutoff_caps_the_mean_stress_at_the_apex(name):
    """Beyond the apex (F > 0 with no deviator) the mean stress is cut back to it, the deviator kept;
    below it, and always for von Mises (no apex), the stress is untouched."""
    spec = Spec(precision="float64")
    m = material(spec, name)
    rng = np.random.default_rng(7)
    sigma = np.concatenate([random_states(rng, 50), random_states(rng, 50) + 200e3 * np.eye(3)])
    n = len(sigma)
    out, removed = wp.zeros(n, dtype=spec.mat33, device=DEVICE), wp.zeros(n, dtype=spec.real, device=DEVICE)
    wp.launch(_kernels(spec, name)["cutoff"], dim=n,
              inputs=[wp.array(sigma, dtype=spec.mat33, device=DEVICE), m, out, removed], device=DEVICE)  # fmt: skip
    cut, removed = out.numpy(), removed.numpy()
    mean, cut_mean = np.trace(sigma, axis1=1, axis2=2) / 3, np.trace(cut, axis1=1, axis2=2) / 3
    np.testing.assert_allclose(cut - cut_mean[:, None, None] * np.eye(3), sigma - mean[:, None, None] * np.eye(3),
                               atol=1e-9 * COHESION)  # fmt: skip
    np.testing.assert_allclose(mean - cut_mean, removed, atol=1e-9 * COHESION)
    hydrostatic = evaluate(spec, name, m, cut_mean[:, None, None] * np.eye(3))["f"]
    beyond = removed > 0
    if name == "von_mises":
        assert not beyond.any()
        return
    assert beyond.sum() >= 50 and (~beyond).sum() >= 40  # the tensile states are cut, most others not
    np.testing.assert_allclose(hydrostatic[beyond], 0.0, atol=1e-9 * COHESION)  # on the apex
    assert np.all(evaluate(spec, name, m, mean[~beyond, None, None] * np.eye(3))["f"] <= 1e-9 * COHESION)
    np.testing.assert_array_equal(cut[~beyond], sigma[~beyond])


@pytest.mark.parametrize("integrator", ["rk4", "rk2"])
def test_a_trial_beyond_the_apex_with_a_small_deviator_is_cut_off_before_it_relaxes(integrator):
    """Mohr–Coulomb with ψ = 0 (c = 20 kPa, φ = 30°, γ = 10/s, F₀ = c), the state a tension crack leaves on a
    rough base: a trial 80 Pa of mean stress beyond the apex with a 45 Pa deviator, over intervals of 2 ms.
    The update cuts the excess first, so the relaxation sees only the deviator's small overstress, which
    decays: the deviator and F never grow. Relaxed before the cut, the excess's F turned the deviator through
    zero and out to 600 Pa and back, interval after interval (the potential's axis has no flow direction at
    ψ = 0)."""
    spec = Spec(integrator=integrator)
    m = material(spec, "mohr_coulomb", dilatancy=0.0, fluidity=10.0)
    apex = 0.95 * COHESION / math.tan(FRICTION)  # the rounded surface's apex mean stress, f = 0.05
    sigma0 = (apex + 80.0) * np.eye(3) + np.array([[20.0, 40.0, 0.0], [40.0, -20.0, 0.0], [0.0, 0.0, 0.0]])
    steps = 20
    sigma = wp.zeros(steps + 1, dtype=spec.mat33, device=DEVICE)
    removed = wp.zeros(steps, dtype=spec.real, device=DEVICE)
    inputs = [spec.mat33(sigma0), spec.real(2e-3), spec.real(LAMBDA), spec.real(SHEAR), m, sigma, removed]
    wp.launch(_kernels(spec, "mohr_coulomb")["update"], dim=1, inputs=inputs, device=DEVICE)
    removed = removed.numpy()
    state = evaluate(spec, "mohr_coulomb", m, sigma.numpy())
    q, f = np.sqrt(state["inv"][:, 1]), state["f"][1:]  # √J₂ from the start, F after each interval
    np.testing.assert_allclose(removed[0], 80.0, rtol=1e-3)  # the mean stress beyond the apex
    assert np.all(np.diff(q) <= 1e-9 * q[0]) and q[-1] > 0.0, q
    assert 0.0 < f[0] < 0.05 * q[0] and np.all(np.diff(f) <= 0.0) and f[-1] < 0.1 * f[0], f  # relaxes to the surface
