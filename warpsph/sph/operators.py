"""Corrected SPH operators as Warp functions (no kernels, no arrays of their own): the linear fit of a field
carried by a source set, its value and gradient at a point, exact for linear fields, with Shepard
interpolation where the fit is singular (docs/method.md, *Operators*).
"""


import functools

import warp as wp

from warpsph.sph.kernels import kernel_pair
from warpsph.sph.spec import Spec

MIN_MEAN_EIGENVALUE = 1.0e-2
"""Below this |det M|^(1/dim), the geometric mean of M's eigenvalues on the used axes (≈1 inside a
body, ≈0.07 at a 3D box corner), the fit falls back to Shepard + uncorrected gradient."""


@functools.cache
def used_axes_algebra(spec: Spec):
    """Warp functions ``(outer_of_used_rows, apply_on_used_axes, used_block_of)`` for vectors that are
    zero along the unused axes (gradient weights, kernel gradients): ``outer_of_used_rows(a, b)`` =
    a ⊗ b multiplying out only the used axes' rows, ``used_block_of(M)`` the block of an M that couples
    no used axis to an unused one (a correction matrix's inverse) as stored (``spec.used_block``), and
    ``apply_on_used_axes(B, a)`` = M a from that block B. The skipped products are exactly zero; a 2D
    pair loop's sums do a third less work."""
    real, vec3, mat33, block = spec.real, spec.vec3, spec.mat33, spec.used_block
    zero = real(0.0)

    if spec.dim == 3:

        @wp.func
        def used_block_of(M: mat33):
            return M

    else:

        @wp.func
        def used_block_of(M: mat33):
            return block(M[0, 0], M[0, 1], M[1, 0], M[1, 1])

    @wp.func
    def outer_of_used_rows(a: vec3, b: vec3):
        if wp.static(spec.dim == 3):
            return wp.outer(a, b)
        if wp.static(spec.dim == 2):
            return mat33(a[0] * b[0], a[0] * b[1], a[0] * b[2], a[1] * b[0], a[1] * b[1], a[1] * b[2],
                         zero, zero, zero)  # fmt: skip
        return mat33(zero, zero, zero, a[1] * b[0], a[1] * b[1], a[1] * b[2], zero, zero, zero)

    @wp.func
    def apply_on_used_axes(M: block, a: vec3):
        if wp.static(spec.dim == 3):
            return M * a
        if wp.static(spec.dim == 2):
            return vec3(M[0, 0] * a[0] + M[0, 1] * a[1], M[1, 0] * a[0] + M[1, 1] * a[1], zero)
        return vec3(zero, M[1, 1] * a[1], zero)

    return outer_of_used_rows, apply_on_used_axes, used_block_of


@functools.cache
def used_vectors(spec: Spec):
    """Warp functions ``(used_vector_of, full_vector)``: a vec3 zero along the unused axes (a fit's c and
    e) as stored (``spec.used_vector``), and back."""
    vec3, used = spec.vec3, spec.used_vector
    zero = spec.real(0.0)

    if spec.dim == 3:

        @wp.func
        def used_vector_of(a: vec3):
            return a

        @wp.func
        def full_vector(a: vec3):
            return a

    else:

        @wp.func
        def used_vector_of(a: vec3):
            return used(a[0], a[1])

        @wp.func
        def full_vector(a: used):
            return vec3(a[0], a[1], zero)

    return used_vector_of, full_vector


@functools.cache
def fit_parts(spec: Spec):
    """Warp functions ``add_to_fit`` (one source's share of w0, wr, g0, M) and ``finish_fit`` (those
    sums → (c, inv_den, Minv, e, corrected)): the two halves of ``fit_operator``, for fits over a
    chosen subset of a neighbour list."""
    real, vec3, mat33 = spec.real, spec.vec3, spec.mat33
    value_and_gradient = kernel_pair(spec)
    outer = used_axes_algebra(spec)[0]
    mask = spec.axis_mask
    unused = mat33(
        real(1.0 - mask[0]), real(0.0), real(0.0),
        real(0.0), real(1.0 - mask[1]), real(0.0),
        real(0.0), real(0.0), real(1.0 - mask[2]),
    )  # fmt: skip
    zero = real(0.0)
    min_det = real(MIN_MEAN_EIGENVALUE**spec.dim)

    @wp.func
    def invert_correction(M: mat33):
        """(M⁻¹, True) for a well-conditioned correction matrix, else (I, False)."""
        Mreg = M + unused
        if wp.abs(wp.determinant(Mreg)) > min_det:
            return wp.inverse(Mreg), True
        return wp.identity(3, dtype=real), False

    @wp.func
    def add_to_fit(r: vec3, vol: real, h: real, w0: real, wr: vec3, g0: vec3, M: mat33):
        """The sums with a source of volume ``vol`` at offset r = x_b − x added, and that source's
        weights V W and V ∇W (for fits of a field summed in the same pass)."""
        w, g = value_and_gradient(-r, h)
        w = w * vol
        g = g * vol
        return w0 + w, wr + w * r, g0 + g, M + outer(g, r), w, g

    @wp.func
    def finish_fit(w0: real, wr: vec3, g0: vec3, M: mat33):
        Minv, corrected = invert_correction(M)
        c = vec3(zero, zero, zero)
        if corrected:
            c = wp.transpose(Minv) * wr
        den = w0 - wp.dot(c, g0)
        if den <= real(0.1) * w0:
            corrected = False
            Minv = wp.identity(3, dtype=real)
            c = vec3(zero, zero, zero)
            den = w0
        inv_den = zero
        if den > zero:
            inv_den = real(1.0) / den
        e = Minv * g0
        return c, inv_den, Minv, e, corrected

    return add_to_fit, finish_fit, invert_correction, unused


@functools.cache
def operator_functions(spec: Spec):
    """Warp functions ``fit_operator``, ``fit_weights``, ``invert_correction``, ``smallest_eigenvalue``."""
    real, vec3, mat33, block, used = spec.real, spec.vec3, spec.mat33, spec.used_block, spec.used_vector
    value_and_gradient = kernel_pair(spec)
    _outer, apply_on_used_axes, used_block_of = used_axes_algebra(spec)
    used_vector_of, full_vector = used_vectors(spec)
    add_to_fit, finish_fit, invert_correction, unused = fit_parts(spec)
    zero = real(0.0)
    half = real(0.5)

    @wp.func
    def fit_operator(
        x: vec3,
        start: int,
        end: int,
        nbr: wp.array(dtype=wp.int32),
        xs: wp.array(dtype=vec3),
        vols: wp.array(dtype=real),
        h: real,
    ):
        """The fit data at x from the sources ``xs`` of volumes ``vols`` [m^dim] listed in nbr[start:end]:
        c and M⁻¹ as stored (``used_vectors``, ``used_axes_algebra``) and as ``fit_weights`` takes them,
        1/den, e, M and whether corrected."""
        w0 = zero
        wr = vec3(zero, zero, zero)
        g0 = vec3(zero, zero, zero)
        M = mat33(zero)
        for k in range(start, end):
            b = nbr[k]
            w0, wr, g0, M, w, g = add_to_fit(xs[b] - x, vols[b], h, w0, wr, g0, M)
        c, inv_den, Minv, e, corrected = finish_fit(w0, wr, g0, M)
        return used_vector_of(c), inv_den, used_block_of(Minv), e, M, corrected

    @wp.func
    def fit_weights(r: vec3, h: real, c: used, inv_den: real, Minv: block):
        """Value weight ψ and gradient weight φ of a source at offset r = x_b − x (times V_b); ``c`` and
        ``Minv`` as stored (``used_vectors``, ``used_axes_algebra``)."""
        w, g = value_and_gradient(-r, h)
        psi = (w - wp.dot(full_vector(c), g)) * inv_den
        return psi, apply_on_used_axes(Minv, g)

    @wp.func
    def smallest_eigenvalue(M: mat33):
        """Smallest eigenvalue of sym(M) + unused axes (≈1 inside a body, ≈0.5 on its surface),
        by the closed form for symmetric 3×3 matrices (trigonometric, no iteration); in 2D that of
        the x–y block (a quadratic's root) against the unused z axis's 1."""
        S = real(0.5) * (M + wp.transpose(M)) + unused
        if wp.static(spec.dim == 2):
            mean = real(0.5) * (S[0, 0] + S[1, 1])
            dev = real(0.5) * (S[0, 0] - S[1, 1])
            return wp.min(S[2, 2], mean - wp.sqrt(dev * dev + S[0, 1] * S[0, 1]))
        off = S[0, 1] * S[0, 1] + S[0, 2] * S[0, 2] + S[1, 2] * S[1, 2]
        q = wp.trace(S) / real(3.0)
        d0 = S[0, 0] - q
        d1 = S[1, 1] - q
        d2 = S[2, 2] - q
        p2 = d0 * d0 + d1 * d1 + d2 * d2 + real(2.0) * off
        if p2 <= real(1.0e-30):
            return wp.min(S[0, 0], wp.min(S[1, 1], S[2, 2]))
        p = wp.sqrt(p2 / real(6.0))
        B = (S - q * wp.identity(3, dtype=real)) / p
        r = wp.clamp(wp.determinant(B) * half, real(-1.0), real(1.0))
        phi = wp.acos(r) / real(3.0)
        return q + real(2.0) * p * wp.cos(phi + real(2.0943951023931953))

    return fit_operator, fit_weights, invert_correction, smallest_eigenvalue
