"""Smoothing kernels: moments, compact support, NumPy twins, and ∇W against finite differences.

Every check evaluates the production Warp functions ``W``/``grad_W`` from ``smoothing_functions``
in a small test kernel; the NumPy twins are compared with them separately.
"""

import functools

import numpy as np
import pytest
import warp as wp

from warpsph.environment import default_device
from warpsph.sph.kernels import KERNELS, kernel_derivative, kernel_pair, kernel_value, smoothing_functions
from warpsph.sph.spec import Spec

wp.config.quiet = True
DEVICE = default_device()  # WARPSPH_DEVICE, else the CPU
H = 0.37  # smoothing length [m]; deliberately not 1 so that h-scaling errors show


@functools.cache
def _evaluate_kernel(spec: Spec):
    real, vec3 = spec.real, spec.vec3
    W, grad_W = smoothing_functions(spec)

    @wp.kernel(enable_backward=False, module="unique")
    def evaluate(x: wp.array(dtype=vec3), h: real, w: wp.array(dtype=real), g: wp.array(dtype=vec3)):
        i = wp.tid()
        w[i] = W(wp.length(x[i]), h)
        g[i] = grad_W(x[i], h)

    return evaluate


def evaluate(spec: Spec, x: np.ndarray, h: float = H) -> tuple[np.ndarray, np.ndarray]:
    """W(|x|, h) and ∇W(x, h) at offsets x = x_a − x_b (n, 3), computed by the Warp functions."""
    dtype = np.float64 if spec.precision == "float64" else np.float32
    xs = wp.array(x.astype(dtype), dtype=spec.vec3, device=DEVICE)
    w = wp.zeros(len(x), dtype=spec.real, device=DEVICE)
    g = wp.zeros(len(x), dtype=spec.vec3, device=DEVICE)
    wp.launch(_evaluate_kernel(spec), dim=len(x), inputs=[xs, spec.real(h), w, g], device=DEVICE)
    return w.numpy().astype(np.float64), g.numpy().astype(np.float64)


def embed(spec: Spec, u: np.ndarray) -> np.ndarray:
    """Place dim-component coordinates u (n, dim) on the used axes (1D: y; 2D: x-y)."""
    axes = np.flatnonzero(spec.axis_mask)
    x = np.zeros((len(u), 3))
    x[:, axes] = u
    return x


def random_offsets(spec: Spec, n: int, r_max: float, seed: int) -> np.ndarray:
    """n offsets in random directions of the used axes with |x| uniform in (0, r_max)."""
    rng = np.random.default_rng(seed)
    u = rng.standard_normal((n, spec.dim))
    u *= (rng.random(n) * r_max / np.linalg.norm(u, axis=1))[:, None]
    return embed(spec, u)


PARAMS = [(k, d) for k in KERNELS for d in (1, 2, 3)]


@pytest.mark.parametrize("precision", ["float64", "float32"])
@pytest.mark.parametrize("kernel,dim", PARAMS)
def test_moments_on_fine_lattice(kernel, dim, precision):
    """Lattice sums Δ^d Σ over x = (i + s)Δ, s a random shift (so symmetry does not zero anything):
        ∫W = 1,  ∫(x−x′)W = 0,  ∫∇W = 0,  ∫(x−x′)⊗∇W = −I on the used axes (0 elsewhere).

    Tolerance: the lattice sum of a compactly supported integrand is the trapezoidal rule, whose
    error (Euler–Maclaurin) comes only from where the integrand is not smooth. Both kernels are C²
    in x (|x|³ terms at the origin, jumps of the third derivative at the knots), so W-type integrands
    err by O((Δ/h)⁴) and ∇W-type ones, one derivative rougher, by at most O((Δ/h)³), with small
    constants (Bernoulli coefficients). We allow 0.05·(Δ/h)³ = 5e-5 at Δ = h/10 for all moments;
    measured worst 8.5e-6 (Wendland, 2D, ∫∇W), falling 10–16× when Δ is halved. float32 adds
    summation round-off of ~1e-7. A wrong normalisation or sign would show as an O(1) error.
    """
    spec = Spec(precision=precision, dim=dim, kernel=kernel)
    d = H / 10.0
    shift = np.random.default_rng(dim).random(dim)
    ticks = [(np.arange(-21, 21) + s) * d for s in shift]  # covers the support |x| < 2h = 20Δ
    u = np.stack(np.meshgrid(*ticks, indexing="ij"), axis=-1).reshape(-1, dim)
    x = embed(spec, u)
    w, g = evaluate(spec, x)
    vol = d**dim

    tol = 0.05 * (d / H) ** 3
    mask = np.diag(spec.axis_mask)
    assert abs(vol * w.sum() - 1.0) < tol
    assert np.abs(vol * (x * w[:, None]).sum(axis=0)).max() < tol * H
    assert np.abs(vol * g.sum(axis=0)).max() < tol / H
    assert np.abs(vol * np.einsum("ni,nj->ij", x, g) + mask).max() < tol


@pytest.mark.parametrize("kernel,dim", PARAMS)
def test_compact_support(kernel, dim):
    """W = 0 and ∇W = 0 for |x| ≥ 2h exactly; W > 0 just inside 2h and over the whole support."""
    spec = Spec(dim=dim, kernel=kernel)
    x = random_offsets(spec, 200, 1.0, seed=1)
    x /= np.linalg.norm(x, axis=1)[:, None]
    outside = x * np.linspace(2.0 * H, 4.0 * H, len(x))[:, None]
    w, g = evaluate(spec, outside)
    assert np.all(w == 0.0) and np.all(g == 0.0)
    inside = x * np.linspace(1e-6 * H, 2.0 * H * (1.0 - 1e-6), len(x))[:, None]
    w, g = evaluate(spec, inside)
    assert np.all(w > 0.0)
    # ∇W points back to the centre: x·∇W < 0 inside the support (W decreases with r).
    assert np.all(np.einsum("ni,ni->n", inside, g) < 0.0)


@pytest.mark.parametrize("precision,rtol", [("float64", 1e-12), ("float32", 2e-6)])
@pytest.mark.parametrize("kernel,dim", PARAMS)
def test_numpy_twin_matches_warp(kernel, dim, precision, rtol):
    """kernel_value / kernel_derivative·x/r equal the Warp W / grad_W at random offsets up to 2.5h.

    Tolerance: the two evaluate the same polynomials in different operation order (pow vs products),
    a few ulps; relative to the kernel's peak so that values that vanish at q → 2 do not amplify it.
    float32 uses 2e-6 (~16 ulps) for the same reason. Measured: 3e-16 (float64), 1.8e-7 (float32)."""
    spec = Spec(precision=precision, dim=dim, kernel=kernel)
    x = random_offsets(spec, 500, 2.5 * H, seed=2)
    if precision == "float32":
        x = x.astype(np.float32).astype(np.float64)
    w, g = evaluate(spec, x)
    r = np.linalg.norm(x, axis=1)
    w_ref = kernel_value(kernel, dim, r, H)
    g_ref = (kernel_derivative(kernel, dim, r, H) / r)[:, None] * x
    w_scale = kernel_value(kernel, dim, 0.0, H)
    g_scale = np.abs(kernel_derivative(kernel, dim, np.linspace(0, 2 * H, 1001), H)).max()
    np.testing.assert_allclose(w, w_ref, rtol=rtol, atol=rtol * w_scale)
    np.testing.assert_allclose(g, g_ref, rtol=rtol, atol=rtol * g_scale)


@pytest.mark.parametrize("kernel,dim", PARAMS)
def test_gradient_matches_finite_differences(kernel, dim):
    """grad_W(x)_i = [W(|x + εe_i|) − W(|x − εe_i|)] / 2ε on the used axes, ε = 1e-5 h.

    Tolerance: truncation ε²/6·W‴ (~1e-10 relative; W is C² so the bound holds across the knots)
    plus round-off ulp/ε (~1e-11), against 1e-8 of the kernel's largest slope (measured 2.6e-10).
    On unused axes grad_W must be exactly 0."""
    spec = Spec(dim=dim, kernel=kernel)
    x = random_offsets(spec, 300, 2.2 * H, seed=3)
    eps = 1e-5 * H
    _, g = evaluate(spec, x)
    g_scale = np.abs(kernel_derivative(kernel, dim, np.linspace(0, 2 * H, 1001), H)).max()
    for axis in np.flatnonzero(spec.axis_mask):
        step = np.zeros(3)
        step[axis] = eps
        w_plus, _ = evaluate(spec, x + step)
        w_minus, _ = evaluate(spec, x - step)
        np.testing.assert_allclose(g[:, axis], (w_plus - w_minus) / (2 * eps), rtol=0, atol=1e-8 * g_scale)
    unused = np.flatnonzero(np.asarray(spec.axis_mask) == 0.0)
    assert np.all(g[:, unused] == 0.0)


@functools.cache
def _evaluate_pair(spec: Spec):
    real, vec3 = spec.real, spec.vec3
    value_and_gradient = kernel_pair(spec)

    @wp.kernel(enable_backward=False, module="unique")
    def evaluate_pair(x: wp.array(dtype=vec3), h: real, w: wp.array(dtype=real), g: wp.array(dtype=vec3)):
        i = wp.tid()
        value, gradient = value_and_gradient(x[i], h)
        w[i] = value
        g[i] = gradient

    return evaluate_pair


@pytest.mark.parametrize("kernel,dim", PARAMS)
def test_value_and_gradient_of_a_pair_are_w_and_grad_w_bit_for_bit(kernel, dim):
    """The pair loops' one evaluation per pair gives the bits of W and grad_W evaluated apart
    (the self pair, r = 0, included)."""
    spec = Spec(dim=dim, kernel=kernel)
    x = np.vstack([np.zeros((1, 3)), random_offsets(spec, 500, 2.2 * H, seed=3)])
    w_ref, g_ref = evaluate(spec, x)
    xs = wp.array(x, dtype=spec.vec3, device=DEVICE)
    w = wp.zeros(len(x), dtype=spec.real, device=DEVICE)
    g = wp.zeros(len(x), dtype=spec.vec3, device=DEVICE)
    wp.launch(_evaluate_pair(spec), dim=len(x), inputs=[xs, spec.real(H), w, g], device=DEVICE)
    assert np.array_equal(w.numpy(), w_ref) and np.array_equal(g.numpy(), g_ref)
