"""Correction stage: the linear-fit data of every point of both sets, computed once per step.

For each query point (virtual points fitted from real particles, real particles fitted from
virtual points) it stores c, 1/den, M⁻¹ and e of :mod:`warpsph.sph.operators` and the smallest
eigenvalue λ of the correction matrix (surface detection: λ < threshold). Ghost points get their
source's data reflected across their planes (c → Rc, e → Re, M⁻¹ → R M⁻¹ R), so sums over
ghosts see the same operator as over owned points.
"""

import functools

import warp as wp

from warpsph.launching import launch, launch_rows
from warpsph.model import Model
from warpsph.sph.neighbours import NeighbourList
from warpsph.sph.operators import operator_functions, used_vectors
from warpsph.sph.spec import Spec


@functools.cache
def fits_struct(spec: Spec):
    """The ``Fits`` @wp.struct of ``spec``'s precision: a point set's linear-fit data as the kernels take
    it, (n,) each: c, 1/den, M⁻¹, e (as stored: their parts on the used axes) and the correction
    matrix's smallest eigenvalue (:class:`FitData`)."""
    real, used, block = spec.real, spec.used_vector, spec.used_block

    @wp.struct
    class Fits:
        c: wp.array(dtype=used)
        inv_den: wp.array(dtype=real)
        minv: wp.array(dtype=block)
        e: wp.array(dtype=used)
        smallest_eigenvalue: wp.array(dtype=real)

    return Fits


@functools.cache
def _kernels(spec: Spec):
    real, vec3 = spec.real, spec.vec3
    Fits = fits_struct(spec)
    fit_operator, _weights, _unused, smallest_eigenvalue = operator_functions(spec)
    used_vector_of = used_vectors(spec)[0]
    axes = spec.stored_axes  # of the stored c, e and M⁻¹

    @wp.kernel(enable_backward=False, module="unique")
    def compute_fits(
        first: int,
        h: real,
        offsets: wp.array(dtype=wp.int32),
        nbr: wp.array(dtype=wp.int32),
        q: wp.array(dtype=vec3),
        src_q: wp.array(dtype=vec3),
        src_volume: wp.array(dtype=real),
        fit: Fits,
    ):
        i = first + wp.tid()
        c, inv_den, Minv, e, M, corrected = fit_operator(q[i], offsets[i], offsets[i + 1], nbr, src_q, src_volume,
                                                         h)  # fmt: skip
        fit.c[i] = c
        fit.inv_den[i] = inv_den
        fit.minv[i] = Minv
        fit.e[i] = used_vector_of(e)
        fit.smallest_eigenvalue[i] = smallest_eigenvalue(M)

    @wp.kernel(enable_backward=False, module="unique")
    def mirror_fits(
        n_owned: int,
        source: wp.array(dtype=wp.int32),
        chain: wp.array(dtype=wp.vec3i),
        plane_axis: wp.array(dtype=wp.int32),
        fit: Fits,
    ):
        g = wp.tid()
        src = source[g]
        c = fit.c[src]
        e = fit.e[src]
        Minv = fit.minv[src]
        planes = chain[g]
        for k in range(3):
            p = planes[k]
            if p >= 0 and plane_axis[p] < wp.static(axes):
                m = plane_axis[p]
                c[m] = -c[m]
                e[m] = -e[m]
                for j in range(wp.static(axes)):
                    if j != m:
                        Minv[m, j] = -Minv[m, j]
                        Minv[j, m] = -Minv[j, m]
        fit.c[n_owned + g] = c
        fit.e[n_owned + g] = e
        fit.minv[n_owned + g] = Minv
        fit.inv_den[n_owned + g] = fit.inv_den[src]
        fit.smallest_eigenvalue[n_owned + g] = fit.smallest_eigenvalue[src]

    @wp.kernel(enable_backward=False, module="unique")
    def volumes(first: int, mass: wp.array(dtype=real), density: wp.array(dtype=real), volume: wp.array(dtype=real)):
        """V = m/ρ [m^dim] of the point ``first`` + tid, once per step for the pair loops that weight by it."""
        i = first + wp.tid()
        volume[i] = mass[i] / density[i]

    return compute_fits, mirror_fits, volumes


class FitData:
    """Per-point fit data of one particle set (owned points and ghosts)."""

    def __init__(self, spec: Spec, count: int, device):
        self.c = wp.zeros(count, dtype=spec.used_vector, device=device)
        """(n,) c = M⁻ᵀ Σ V W r [m] (``spec.used_vector``)."""
        self.inv_den = wp.zeros(count, dtype=spec.real, device=device)
        """(n,) 1 / (Σ V W − c·Σ V ∇W) [-]."""
        self.minv = wp.zeros(count, dtype=spec.used_block, device=device)
        """(n,) the inverse correction matrix's block on the used axes (``spec.used_block``) [-]."""
        self.e = wp.zeros(count, dtype=spec.used_vector, device=device)
        """(n,) e = M⁻¹ Σ V ∇W [1/m] (``spec.used_vector``); −e points out of a free surface."""
        self.smallest_eigenvalue = wp.zeros(count, dtype=spec.real, device=device)
        """(n,) smallest eigenvalue of the correction matrix [-] (≈1 inside, ≈0.5 on a surface)."""
        self.struct = fits_struct(spec)()
        """The arrays above as the kernels take them (:func:`fits_struct`)."""
        for name in ("c", "inv_den", "minv", "e", "smallest_eigenvalue"):
            setattr(self.struct, name, getattr(self, name))


def compute_volumes(model: Model, mass, density, volume, first: int, count: int) -> None:
    """volume = mass / density for the points [first, first + count)."""
    launch(_kernels(model.spec)[2], count, [first, mass, density, volume], model.device)


def compute_fit_data(model: Model, neighbours: NeighbourList, q, n_owned: int, src_q, src_volume,
                     fits: FitData, ghost_source, ghost_planes, n_ghosts: int) -> None:  # fmt: skip
    """Fill ``fits`` for the owned query points ``q[:n_owned]`` from sources of volumes ``src_volume``
    and mirror them onto their ghosts."""
    compute_fits, mirror_fits, _ = _kernels(model.spec)
    launch_rows(compute_fits, n_owned,
           [model.spec.real(model.h), neighbours.offsets, neighbours.indices, q, src_q, src_volume,
            fits.struct], model.device)  # fmt: skip
    launch(mirror_fits, n_ghosts, [n_owned, ghost_source, ghost_planes, model.plane_axis, fits.struct],
           model.device)
