"""The compile-time choices that select one variant of every Warp kernel.

A :class:`Spec` is frozen and hashable: kernel factories are cached on it, so each combination of
precision, dimension, smoothing kernel and effects compiles once per process. Per-particle material
values stay data (arrays) and never multiply variants.
"""

from __future__ import annotations

from dataclasses import dataclass

import warp as wp

from warpsph.scene import Effects

_TYPES = {
    "float32": (wp.float32, wp.vec3f, wp.mat33f, wp.vec4f, wp.mat44f, wp.mat22f, wp.vec2f),
    "float64": (wp.float64, wp.vec3d, wp.mat33d, wp.vec4d, wp.mat44d, wp.mat22d, wp.vec2d),
}


@dataclass(frozen=True)
class Spec:
    """precision ("float32"|"float64"), dim (1, 2, 3), kernel ("cubic_spline"|"wendland_c2"),
    scheme ("two_set"|"collocated"), integrator ("rk2"|"rk4"), the scene's effects and, with
    plasticity, its yield function."""

    precision: str = "float64"
    dim: int = 2
    kernel: str = "cubic_spline"
    scheme: str = "two_set"
    integrator: str = "rk4"
    effects: Effects = Effects()
    yield_function: str = ""
    """The viscoplastic materials' yield function with the plasticity effect, "" without."""

    @classmethod
    def from_scene(cls, scene, precision: str | None = None) -> "Spec":
        """The variant a scene needs; ``precision`` overrides the scene's."""
        sim = scene.simulation
        return cls(precision or sim.precision, sim.dim, sim.kernel, sim.scheme, sim.integrator, scene.effects,
                   scene.yield_function)  # fmt: skip

    @property
    def real(self):
        """Warp scalar type of particle fields."""
        return _TYPES[self.precision][0]

    @property
    def vec3(self):
        return _TYPES[self.precision][1]

    @property
    def mat33(self):
        return _TYPES[self.precision][2]

    @property
    def vec4(self):
        return _TYPES[self.precision][3]

    @property
    def mat44(self):
        return _TYPES[self.precision][4]

    @property
    def stored_axes(self) -> int:
        """Axes of a per-point vector or matrix as stored: 3 in 3D, the x–y pair in 1D and 2D (1D's y axis
        is the pair's second, its x axis the identity's or zero)."""
        return 3 if self.dim == 3 else 2

    @property
    def used_block(self):
        """Warp matrix type of a matrix's block on the used axes as stored per point: mat33 in 3D, the
        x–y block (mat22) in 1D and 2D, whose unused axes are the identity's."""
        return _TYPES[self.precision][2 if self.stored_axes == 3 else 5]

    @property
    def used_vector(self):
        """Warp vector type of a vector zero along the unused axes as stored per point: vec3 in 3D, its
        x–y part (vec2) in 1D and 2D."""
        return _TYPES[self.precision][1 if self.stored_axes == 3 else 6]

    @property
    def axis_mask(self) -> tuple[float, float, float]:
        """1 on the axes a scene of this dimension uses: 1D is the y axis, 2D is x-y."""
        return {1: (0.0, 1.0, 0.0), 2: (1.0, 1.0, 0.0), 3: (1.0, 1.0, 1.0)}[self.dim]
