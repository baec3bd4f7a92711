"""The corrected linear fit (fit_operator + fit_weights), used exactly as ``fit_fields`` uses it.

With r = x_b − x, V_b = m_b/ρ_b and (c, 1/den, M⁻¹, e) from fit_operator, fit_weights gives
ψ_b, φ_b and the fitted value and gradient at x are
    f = Σ V_b ψ_b f_b,    ∇f = Σ V_b φ_b f_b − e f     (G[k, j] = ∂v_j/∂x_k for vectors).
Both are exact for linear fields wherever the fit is corrected (det M not small), boundaries
included; M ≈ I inside a body, and where M is singular the fit falls back to Shepard.
"""

import functools

import numpy as np
import pytest
import warp as wp

from warpsph.environment import default_device
from warpsph.sph.kernels import KERNELS
from warpsph.sph.neighbours import NeighbourList
from warpsph.sph.operators import operator_functions, used_axes_algebra
from warpsph.sph.spec import Spec

wp.config.quiet = True
DEVICE = default_device()  # WARPSPH_DEVICE, else the CPU
DX = 0.1  # lattice spacing [m]
H_RATIO = 1.3  # h = 1.3 Δx, support 2h = 2.6 Δx
CELLS = {1: 12, 2: 10, 3: 8}  # box [0, n Δx]^dim


@functools.cache
def _fit_kernel(spec: Spec):
    real, vec3, mat33 = spec.real, spec.vec3, spec.mat33
    fit_operator, fit_weights, _, smallest_eigenvalue = operator_functions(spec)
    zero = real(0.0)

    @wp.kernel(enable_backward=False, module="unique")
    def fit(
        query: wp.array(dtype=vec3), offsets: wp.array(dtype=wp.int32), nbr: wp.array(dtype=wp.int32),
        xs: wp.array(dtype=vec3), vols: wp.array(dtype=real),
        fs: wp.array(dtype=real), vs: wp.array(dtype=vec3), h: real,
        f_out: wp.array(dtype=real), grad_out: wp.array(dtype=vec3), v_out: wp.array(dtype=vec3),
        G_out: wp.array(dtype=mat33), lam_out: wp.array(dtype=real), e_out: wp.array(dtype=vec3),
        corrected_out: wp.array(dtype=wp.int32),
    ):  # fmt: skip
        i = wp.tid()
        x = query[i]
        c, inv_den, Minv, e, M, corrected = fit_operator(x, offsets[i], offsets[i + 1], nbr, xs, vols, h)
        f = zero
        grad = vec3(zero, zero, zero)
        v = vec3(zero, zero, zero)
        G = mat33(zero)
        for k in range(offsets[i], offsets[i + 1]):
            b = nbr[k]
            vol = vols[b]
            psi, phi = fit_weights(xs[b] - x, h, c, inv_den, Minv)
            f += (vol * psi) * fs[b]
            grad += (vol * fs[b]) * phi
            v += (vol * psi) * vs[b]
            G += wp.outer(vol * phi, vs[b])
        f_out[i] = f
        grad_out[i] = grad - e * f
        v_out[i] = v
        G_out[i] = G - wp.outer(e, v)
        lam_out[i] = smallest_eigenvalue(M)
        e_out[i] = e
        corrected_out[i] = 0
        if corrected:
            corrected_out[i] = 1

    return fit


def fit(spec: Spec, query: np.ndarray, source: np.ndarray, f: np.ndarray, v: np.ndarray) -> dict:
    """Fit the source fields f (n,) and v (n, 3) at the query points; volumes Δx^dim."""
    dtype = np.float64 if spec.precision == "float64" else np.float32

    def arr(a, t):
        return wp.array(np.asarray(a, dtype=dtype), dtype=t, device=DEVICE)

    nq = len(query)
    q, xs = arr(query, spec.vec3), arr(source, spec.vec3)
    h = H_RATIO * DX
    nl = NeighbourList(spec, np.ptp(np.vstack([query, source]), axis=0) + 1.0, 2.0 * h, DEVICE)
    nl.build(q, nq, xs, len(source))
    types = {"f": spec.real, "grad": spec.vec3, "v": spec.vec3, "G": spec.mat33, "lam": spec.real,
             "e": spec.vec3, "corrected": wp.int32}  # fmt: skip
    out = {k: wp.zeros(nq, dtype=t, device=DEVICE) for k, t in types.items()}
    vols = arr(np.full(len(source), DX**spec.dim), spec.real)
    inputs = [q, nl.offsets, nl.indices, xs, vols, arr(f, spec.real), arr(v, spec.vec3), spec.real(h)]
    wp.launch(_fit_kernel(spec), dim=nq, inputs=inputs + list(out.values()), device=DEVICE)
    return {k: a.numpy().astype(np.float64) if k != "corrected" else a.numpy() for k, a in out.items()}


def lattice(spec: Spec, n: int, offset: float) -> np.ndarray:
    """Points (k + offset) Δx, k = 0..n, on the used axes; offset 0 gives nodes, 0.5 cell centres."""
    ticks = [(np.arange(n + 1 - (offset > 0)) + offset) * DX] * spec.dim
    u = np.stack(np.meshgrid(*ticks, indexing="ij"), axis=-1).reshape(-1, spec.dim)
    x = np.zeros((len(u), 3))
    x[:, np.flatnonzero(spec.axis_mask)] = u
    return x


def boundary_class(spec: Spec, x: np.ndarray, n: int) -> np.ndarray:
    """Number of box faces within the support 2h of each point: 0 interior, 1 face, ≥ 2 edge/corner."""
    axes = np.flatnonzero(spec.axis_mask)
    gap = np.minimum(x[:, axes], n * DX - x[:, axes])
    return (gap < 2.0 * H_RATIO * DX - 1e-9).sum(axis=1)


def linear_fit_errors(spec: Spec, query: np.ndarray, source: np.ndarray, seed: int) -> tuple[dict, dict]:
    """Fit f = a + b·x and v = a_v + B x; return the fit and the errors per query point, relative to
    |a| + |b|L (values) and |b| (gradients). Exact: ∂f/∂x_k = b_k and G[k, j] = B[j, k] on used axes."""
    rng = np.random.default_rng(seed)
    mask, L = np.asarray(spec.axis_mask), CELLS[spec.dim] * DX
    a, b = 0.7, np.array([1.3, -0.4, 0.9])
    a_v, B = np.array([0.2, -1.1, 0.5]), rng.uniform(-1.0, 1.0, (3, 3))
    res = fit(spec, query, source, a + source @ b, a_v + source @ B.T)
    err = {
        "f": np.abs(res["f"] - (a + query @ b)) / (a + np.abs(b).sum() * L),
        "grad": np.abs(res["grad"] - b * mask).max(axis=1) / np.abs(b).max(),
        "v": np.abs(res["v"] - (a_v + query @ B.T)).max(axis=1) / (np.abs(a_v).max() + np.abs(B).max() * L),
        "G": np.abs(res["G"] - (B * mask).T).max(axis=(1, 2)) / np.abs(B).max(),
    }
    return res, err


def worst_by_class(err: dict, where: np.ndarray, ok: np.ndarray) -> dict:
    """Largest error of each field over (interior, face, edge/corner) points where ``ok``."""
    where = np.minimum(where, 2)
    return {k: [float(e[ok & (where == c)].max(initial=0.0)) for c in (0, 1, 2)] for k, e in err.items()}


CASES = [("float64", k, d, 1e-9) for k in KERNELS for d in (1, 2, 3)] + [("float32", "cubic_spline", 2, 2e-4)]


@pytest.mark.parametrize("query_set", ["cell_centres", "particles", "particles_from_centres"])
@pytest.mark.parametrize("precision,kernel,dim,tol", CASES)
def test_linear_fields_are_exact(precision, kernel, dim, tol, query_set):
    """Linear f and v fitted on a perturbed lattice are exact at interior, face and corner points.

    Particles: the box's lattice nodes jittered by ≤ 0.2Δx per axis. "cell_centres": particles
    queried at the cell centres (the two-set half step); "particles": particles queried at
    themselves (self included, as a query coinciding with a source); "particles_from_centres": the
    cell centres queried at the particles (the full step). The fit must be corrected (not Shepard)
    everywhere, except that in the full-step geometry edge/corner particles pushed outward by the
    jitter may fall back (det M or den below the guards, see test_full_step_fit_at_box_corners).

    Tolerance: exactness is algebraic (the block system is solved in closed form), so only
    round-off remains: cond(M) ≲ 20 at corners times ~100 summed terms times ε (2e-16) is ~1e-12
    relative in float64 (measured ≤ 1e-13), asserted at 1e-9; float32 (ε = 6e-8, measured 1.1e-5) at 2e-4."""
    spec = Spec(precision=precision, dim=dim, kernel=kernel)
    n = CELLS[dim]
    nodes = lattice(spec, n, 0.0)
    particles = nodes + np.random.default_rng(dim).uniform(-0.2, 0.2, nodes.shape) * DX * np.asarray(spec.axis_mask)
    query, source = {
        "cell_centres": (lattice(spec, n, 0.5), particles),
        "particles": (particles, particles),
        "particles_from_centres": (particles, lattice(spec, n, 0.5)),
    }[query_set]
    if precision == "float32":
        source, query = source.astype(np.float32).astype(float), query.astype(np.float32).astype(float)
    res, err = linear_fit_errors(spec, query, source, seed=dim)

    where = boundary_class(spec, query, n)
    assert set(where) == ({0, 1} if dim == 1 else {0, 1, 2}) | ({3} if dim == 3 else set())
    corrected = res["corrected"] == 1
    must_correct = where <= (1 if query_set == "particles_from_centres" else 3)
    assert np.all(corrected[must_correct]), f"Shepard fallback at {query[must_correct & ~corrected] / DX} Δx"
    worst = worst_by_class(err, where, corrected)
    assert max(max(w) for w in worst.values()) < tol, f"worst (interior, face, edge/corner): {worst}"


@pytest.mark.parametrize("dim", [1, 2, 3])
@pytest.mark.parametrize("kernel", KERNELS)
def test_full_step_fit_at_box_corners(kernel, dim):
    """Unperturbed box, as built at t = 0: particles at the nodes fitted from the cell centres. The
    fit must be corrected and exact at every particle, corners included (verification.md).

    A 3D corner node sees only an octant of centres (det M ≈ 2.9e-4, cond M ≈ 10): the
    conditioning test uses |det M|^(1/dim), so it stays corrected."""
    spec = Spec(dim=dim, kernel=kernel)
    n = CELLS[dim]
    query = lattice(spec, n, 0.0)
    res, err = linear_fit_errors(spec, query, lattice(spec, n, 0.5), seed=dim)
    corrected = res["corrected"] == 1
    assert np.all(corrected), f"Shepard fallback at {query[~corrected] / DX} Δx"
    worst = worst_by_class(err, boundary_class(spec, query, n), corrected)
    assert max(max(w) for w in worst.values()) < 1e-9, worst


def test_shepard_fallback_when_M_is_singular():
    """2D query point whose neighbours all lie on one line (y = 0): M has a zero row and column, so
    det M = 0 and the fit must fall back to Shepard (ψ = W/Σ V W), which reproduces a constant to
    round-off, and the uncorrected gradient Σ V ∇W f_b − g₀ f, which vanishes for a constant."""
    spec = Spec(dim=2)
    source = np.zeros((9, 3))
    source[:, 0] = np.array([-4, -3, -2, -1, 0.3, 1, 2, 3.5, 4]) * DX
    query = np.array([[0.05 * DX, 0.0, 0.0], [-0.7 * DX, 0.0, 0.0]])
    const = 3.7
    res = fit(spec, query, source, np.full(9, const), np.tile([const, -const, 0.0], (9, 1)))
    assert np.all(res["corrected"] == 0)
    np.testing.assert_allclose(res["f"], const, rtol=1e-14)
    np.testing.assert_allclose(res["v"], [[const, -const, 0.0]] * 2, rtol=1e-14, atol=0)
    assert np.abs(res["grad"]).max() < 1e-12 * const / DX
    assert np.abs(res["G"]).max() < 1e-12 * const / DX


@pytest.mark.parametrize("kernel,dim", [(k, d) for k in KERNELS for d in (1, 2, 3)])
def test_surface_detection(kernel, dim):
    """Particles at the lattice nodes of a box fitted from the cell centres (volume Δx^dim), as in
    the two-set full step: λ_min(sym M) ≥ 0.9 at particles with full support (M → I as the lattice
    sum → ∫ (x′−x)⊗∇W = I), < 0.75 on the faces (half the support missing), and −e/|e| is the
    outward normal of the face (dot ≥ 0.9) at face particles ≥ 2h from any other face.
    Measured: λ_min 0.97–1.01 inside, ≤ 0.51 on faces; dot = 1 (the lattice is symmetric)."""
    spec = Spec(dim=dim, kernel=kernel)
    n = CELLS[dim]
    particles, centres = lattice(spec, n, 0.0), lattice(spec, n, 0.5)
    res = fit(spec, particles, centres, np.zeros(len(centres)), np.zeros((len(centres), 3)))
    axes = np.flatnonzero(spec.axis_mask)
    where = boundary_class(spec, particles, n)
    lam = res["lam"]
    assert lam[where == 0].min() >= 0.9, lam[where == 0]
    on_face = np.isclose(particles[:, axes], 0.0) | np.isclose(particles[:, axes], n * DX)
    on_face_only = on_face.any(axis=1) & (where == 1)
    assert lam[on_face.any(axis=1)].max() < 0.75

    outward = np.zeros((len(particles), 3))
    outward[:, axes] = np.isclose(particles[:, axes], n * DX) * 1.0 - np.isclose(particles[:, axes], 0.0)
    e = res["e"][on_face_only]
    normal = -e / np.linalg.norm(e, axis=1)[:, None]
    dots = np.einsum("ni,ni->n", normal, outward[on_face_only])
    assert on_face_only.sum() == 2 * dim * (n - 5) ** (dim - 1) and dots.min() >= 0.9, dots


@functools.cache
def _used_axes_products(spec: Spec):
    vec3, mat33 = spec.vec3, spec.mat33
    outer_of_used_rows, apply_on_used_axes, used_block_of = used_axes_algebra(spec)

    @wp.kernel(enable_backward=False, module="unique")
    def products(a: wp.array(dtype=vec3), b: wp.array(dtype=vec3), M: wp.array(dtype=mat33),
                 outer: wp.array(dtype=mat33), outer_full: wp.array(dtype=mat33), applied: wp.array(dtype=vec3),
                 applied_full: wp.array(dtype=vec3)):  # fmt: skip
        i = wp.tid()
        outer[i] = outer_of_used_rows(a[i], b[i])
        outer_full[i] = wp.outer(a[i], b[i])
        applied[i] = apply_on_used_axes(used_block_of(M[i]), a[i])
        applied_full[i] = M[i] * a[i]

    return products


@pytest.mark.parametrize("dim", [1, 2, 3])
def test_products_on_the_used_axes_are_the_full_products(dim):
    """For an ``a`` zero along the unused axes and an M that couples no used axis to an unused one
    (1 on the unused diagonal, as a correction matrix's inverse), the pair loops' reduced products
    give the full products' bits."""
    spec = Spec(dim=dim)
    rng = np.random.default_rng(7)
    mask = np.asarray(spec.axis_mask)
    a = rng.standard_normal((200, 3)) * mask
    b = rng.standard_normal((200, 3))
    M = rng.standard_normal((200, 3, 3)) * np.outer(mask, mask) + np.diag(1.0 - mask)
    arrays = [wp.array(a, dtype=spec.vec3, device=DEVICE), wp.array(b, dtype=spec.vec3, device=DEVICE),
              wp.array(M, dtype=spec.mat33, device=DEVICE)]  # fmt: skip
    outs = [wp.zeros(200, dtype=t, device=DEVICE) for t in (spec.mat33, spec.mat33, spec.vec3, spec.vec3)]
    wp.launch(_used_axes_products(spec), dim=200, inputs=arrays + outs, device=DEVICE)
    outer, outer_full, applied, applied_full = (o.numpy() for o in outs)
    assert np.array_equal(outer, outer_full) and np.array_equal(applied, applied_full)
