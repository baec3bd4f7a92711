"""Smoothing kernels W(r, h) with support 2h, in 1D, 2D (plane strain) and 3D.

``smoothing_functions(spec)`` returns Warp functions for the kernel selected by ``spec``:
``W(r, h)`` [1/m^dim] and ``grad_W(x_ab, h)`` = ∇_a W(|x_a − x_b|, h) [1/m^(dim+1)], where
``x_ab = x_a − x_b``. ``kernel_value``/``kernel_derivative`` are NumPy twins used by tests.
"""


import functools
import math

import numpy as np
import warp as wp

from warpsph.sph.spec import Spec

KERNELS = ("cubic_spline", "wendland_c2")

# Normalisation σ_d such that W = σ_d / h^d · f(q), q = r / h.
_NORM = {
    "cubic_spline": {1: 2.0 / 3.0, 2: 10.0 / (7.0 * math.pi), 3: 1.0 / math.pi},
    "wendland_c2": {1: 5.0 / 8.0, 2: 7.0 / (4.0 * math.pi), 3: 21.0 / (16.0 * math.pi)},
}


def kernel_value(kind: str, dim: int, r: np.ndarray, h: float) -> np.ndarray:
    """NumPy W(r, h) [1/m^dim]."""
    q = np.asarray(r, dtype=float) / h
    s = 0.5 * q
    if kind == "cubic_spline":
        f = np.where(q < 1.0, 1.0 - 1.5 * q**2 + 0.75 * q**3, np.where(q < 2.0, 0.25 * (2.0 - q) ** 3, 0.0))
    elif dim == 1:
        f = np.where(q < 2.0, (1.0 - s) ** 3 * (1.0 + 1.5 * q), 0.0)
    else:
        f = np.where(q < 2.0, (1.0 - s) ** 4 * (1.0 + 2.0 * q), 0.0)
    return _NORM[kind][dim] / h**dim * f


def kernel_derivative(kind: str, dim: int, r: np.ndarray, h: float) -> np.ndarray:
    """NumPy dW/dr [1/m^(dim+1)]."""
    q = np.asarray(r, dtype=float) / h
    s = 0.5 * q
    if kind == "cubic_spline":
        f = np.where(q < 1.0, -3.0 * q + 2.25 * q**2, np.where(q < 2.0, -0.75 * (2.0 - q) ** 2, 0.0))
    elif dim == 1:
        f = np.where(q < 2.0, -3.0 * q * (1.0 - s) ** 2, 0.0)
    else:
        f = np.where(q < 2.0, -5.0 * q * (1.0 - s) ** 3, 0.0)
    return _NORM[kind][dim] / h ** (dim + 1) * f


@functools.cache
def _shape_functions(spec: Spec):
    """``(shape, shape_derivative, inv_h_pow)``: f(q), f′(q) and 1/h^dim as Warp functions."""
    real = spec.real
    dim = spec.dim
    one, two, half = real(1.0), real(2.0), real(0.5)

    if spec.kernel == "cubic_spline":

        @wp.func
        def shape(q: real):
            if q < one:
                return one - real(1.5) * q * q + real(0.75) * q * q * q
            if q < two:
                t = two - q
                return real(0.25) * t * t * t
            return real(0.0)

        @wp.func
        def shape_derivative(q: real):
            if q < one:
                return real(-3.0) * q + real(2.25) * q * q
            if q < two:
                t = two - q
                return real(-0.75) * t * t
            return real(0.0)

    elif dim == 1:

        @wp.func
        def shape(q: real):
            if q < two:
                t = one - half * q
                return t * t * t * (one + real(1.5) * q)
            return real(0.0)

        @wp.func
        def shape_derivative(q: real):
            if q < two:
                t = one - half * q
                return real(-3.0) * q * t * t
            return real(0.0)

    else:

        @wp.func
        def shape(q: real):
            if q < two:
                t = one - half * q
                return t * t * t * t * (one + two * q)
            return real(0.0)

        @wp.func
        def shape_derivative(q: real):
            if q < two:
                t = one - half * q
                return real(-5.0) * q * t * t * t
            return real(0.0)

    @wp.func
    def inv_h_pow(h: real):
        ih = one / h
        r = ih
        for _k in range(dim - 1):
            r = r * ih
        return r

    return shape, shape_derivative, inv_h_pow


@functools.cache
def smoothing_functions(spec: Spec):
    """Return ``(W, grad_W)`` Warp functions for ``spec.kernel`` in ``spec.dim`` dimensions."""
    real, vec3 = spec.real, spec.vec3
    norm = real(_NORM[spec.kernel][spec.dim])
    shape, shape_derivative, inv_h_pow = _shape_functions(spec)

    @wp.func
    def W(r: real, h: real):
        return norm * inv_h_pow(h) * shape(r / h)

    @wp.func
    def grad_W(x_ab: vec3, h: real):
        r = wp.length(x_ab)
        if r <= real(1.0e-12) * h:
            return vec3(real(0.0), real(0.0), real(0.0))
        dwdr = norm * inv_h_pow(h) / h * shape_derivative(r / h)
        return x_ab * (dwdr / r)

    return W, grad_W


@functools.cache
def kernel_pair(spec: Spec):
    """Warp function ``value_and_gradient(x_ab, h)`` = (W(|x_ab|, h), grad_W(x_ab, h)) from one
    distance and one 1/h^dim: what a pair loop that needs both evaluates once per pair."""
    real, vec3 = spec.real, spec.vec3
    norm = real(_NORM[spec.kernel][spec.dim])
    shape, shape_derivative, inv_h_pow = _shape_functions(spec)

    @wp.func
    def value_and_gradient(x_ab: vec3, h: real):
        r = wp.length(x_ab)
        scale = norm * inv_h_pow(h)
        q = r / h
        w = scale * shape(q)
        if r <= real(1.0e-12) * h:
            return w, vec3(real(0.0), real(0.0), real(0.0))
        return w, x_ab * (scale / h * shape_derivative(q) / r)  # the same arithmetic as W and grad_W

    return value_and_gradient
