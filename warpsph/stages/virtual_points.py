"""Regenerating the virtual stress points from the real particles (large deformation; docs/method.md,
*Large deformation*).
"""

import functools
import itertools

import numpy as np
import warp as wp

from warpsph.errors import SimulationError
from warpsph.launching import launch
from warpsph.lattice import used_axes
from warpsph.sph.kernels import smoothing_functions
from warpsph.sph.neighbours import grid_dims
from warpsph.sph.spec import Spec

INSIDE_SHEPARD = 0.8
"""A lattice-cell centre whose Shepard sum of the real particles reaches this [-] is inside the body
(measured at the start's layout: at least 0.52 at the cell centres inside a box, its corners
included, at most 0.08 at the centres just outside it; cubic spline, h = 1.3 Δx, 2D)."""
TIE = 1.0e-5
"""Squared distances [h²] closer than this are a tie when a regenerated point takes the material of
its nearest real particle (above float32 rounding of r² ≤ 4h², far below the gap between lattice
neighbours' r², about 0.6 h²)."""


@functools.cache
def _sample_kernel(spec: Spec):
    real, vec3 = spec.real, spec.vec3
    W, _ = smoothing_functions(spec)
    tie_h2 = real(TIE)

    @wp.kernel(enable_backward=False, module="unique")
    def sample_reals(
        grid: wp.uint64,
        h: real,
        points: wp.array(dtype=vec3),
        q: wp.array(dtype=vec3),
        mass: wp.array(dtype=real),
        density: wp.array(dtype=real),
        origin: wp.array(dtype=vec3),
        material: wp.array(dtype=wp.int32),
        shepard: wp.array(dtype=real),
        density_out: wp.array(dtype=real),
        origin_out: wp.array(dtype=vec3),
        material_out: wp.array(dtype=wp.int32),
    ):
        """At each point: S = Σ V_b W; the Shepard mean of ρ [kg/m³]; the initial position [m], the
        point less the Shepard mean of the displacement (exact for a rigid translation, also at a
        surface, where a mean of the initial positions would be pulled inwards); and the material of
        the nearest owned real particle b, the larger material index where two lie equally near
        (within TIE h²: a point midway between two bodies' rows, whose rounding must not decide)."""
        c = wp.tid()
        x = points[c]
        s = real(0.0)
        rho = real(0.0)
        x0 = vec3(real(0.0), real(0.0), real(0.0))
        nearest = real(4.0) * h * h
        mat = int(-1)
        for b in wp.hash_grid_query(grid, x, real(2.0) * h):
            d = q[b] - x
            r2 = wp.dot(d, d)
            w = mass[b] / density[b] * W(wp.sqrt(r2), h)
            s += w
            rho += w * density[b]
            x0 += w * (q[b] - origin[b])
            tie = wp.abs(r2 - nearest) <= tie_h2 * h * h
            if (r2 < nearest and not tie) or (tie and material[b] > mat):
                nearest = wp.min(r2, nearest)
                mat = material[b]
        shepard[c] = s
        if s > real(0.0):
            density_out[c] = rho / s
            origin_out[c] = x - x0 / s
        material_out[c] = mat

    return sample_reals


def lattice_candidates(q: np.ndarray, dx: float, dim: int) -> np.ndarray:
    """Centres (k + ½)Δx [m] of the lattice cells holding or next to the points ``q`` (n,3)."""
    axes = used_axes(dim)
    cells = np.floor(q[:, axes] / dx).astype(np.int64)
    shifts = np.array(list(itertools.product((-1, 0, 1), repeat=len(axes))), dtype=np.int64)
    cells = np.unique((cells[:, None, :] + shifts[None, :, :]).reshape(-1, len(axes)), axis=0)
    out = np.zeros((len(cells), 3))
    out[:, axes] = (cells + 0.5) * dx
    return out


class VirtualRegenerator:
    """Rebuilds the owned virtual points of a two-set model from its real particles."""

    def __init__(self, model):
        self.model = model
        nx, ny, nz = grid_dims(np.asarray(model.extent, dtype=float), 2.0 * model.h, model.spec.dim)
        self.grid = wp.HashGrid(nx, ny, nz, device=model.device, dtype=model.spec.real)

    def sample(self, particle_q, particle_density, points: np.ndarray):
        """(S, ρ, x₀, material) of the owned real particles at ``points`` (k,3) [m], host arrays."""
        m, spec = self.model, self.model.spec
        n = m.particle_count
        self.grid.build(particle_q[:n], spec.real(2.0 * m.h))
        k = len(points)
        pts = wp.array(points, dtype=spec.vec3, device=m.device)
        out = [wp.zeros(k, dtype=spec.real, device=m.device), wp.zeros(k, dtype=spec.real, device=m.device),
               wp.zeros(k, dtype=spec.vec3, device=m.device), wp.zeros(k, dtype=wp.int32, device=m.device)]
        launch(_sample_kernel(spec), k,
               [wp.uint64(self.grid.id), spec.real(m.h), pts, particle_q, m.particle_mass, particle_density,
                m.particle_origin, m.particle_material, *out], m.device)  # fmt: skip
        return [a.numpy() for a in out]

    def regenerate(self, state, region_members) -> None:
        """Replace the owned virtual points of ``state`` (positions and densities) and of the model
        (count, mass, material, origin, velocity-region members: ``region_members(origins)``)."""
        m = self.model
        q = state.particle_q.numpy()[: m.particle_count].astype(float)
        candidates = lattice_candidates(q, m.dx, m.spec.dim)
        shepard, rho, origin, material = self.sample(state.particle_q, state.particle_density, candidates)
        inside = shepard >= INSIDE_SHEPARD
        count = int(np.count_nonzero(inside))
        if count > m.virtual_capacity:
            raise SimulationError(f"large deformation: {count} virtual points needed, room for {m.virtual_capacity}")
        for array, values in ((state.virtual_q, candidates[inside]), (state.virtual_density, rho[inside]),
                              (m.virtual_mass, rho[inside] * m.dx**m.spec.dim), (m.virtual_origin, origin[inside]),
                              (m.virtual_material, material[inside])):  # fmt: skip
            host = array.numpy()
            host[:count] = values
            array.assign(host)
        m.virtual_count = count
        index, load = region_members(origin[inside])
        m.region_virtual = wp.array(index, dtype=wp.int32, device=m.device)
        m.region_virtual_load = wp.array(load, dtype=wp.int32, device=m.device)
