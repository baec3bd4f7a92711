"""Model (what does not change during a run) and State (what a step advances).

Particle arrays of both sets are *extended*: the first ``*_count`` entries are owned particles, the
remaining ``*_ghost_count`` are mirror ghosts beyond boundary planes whose values the ghost stage
derives from their sources every time they are needed. Arrays that an effect does not need are not
allocated (they stay ``None``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
import warp as wp

from warpsph.pore_water import PoreWaterModel
from warpsph.scene import Scene
from warpsph.sph.spec import Spec

if TYPE_CHECKING:
    from warpsph.stages.plates import PlateLayout

# Boundary plane kinds as stored in ``Model.plane_kind``.
PLANE_FIXED, PLANE_SLIP, PLANE_TRACTION, PLANE_VELOCITY = 0, 1, 2, 3
PLATE_NONE, PLATE_ROUGH, PLATE_SMOOTH = 0, 1, 2
"""A plane's rigid plate: none, or its contact (docs/method.md, *Rigid plates*)."""
PLATE_VELOCITY, PLATE_FORCE = 0, 1
"""What drives a rigid plate: a prescribed velocity, or a total force."""


@dataclass
class Model:
    """Static device data of a run. Shapes: N owned real particles, G real ghosts, M virtual
    particles, GV virtual ghosts, P boundary planes, C particles lying on planes, R particles of
    velocity regions."""

    scene: Scene
    spec: Spec
    device: str
    dx: float
    """Initial particle spacing Δx [m]."""
    h: float
    """Smoothing length [m]."""
    extent: np.ndarray
    """Size of the initial bounding box, ghosts included [m] (3,)."""
    gravity: tuple
    """Body force [m/s²]."""

    particle_count: int
    particle_ghost_count: int
    """Live ghosts (the first of the ghost slots; changes when a large-deformation run re-plans)."""
    particle_mass: wp.array
    """(N+G,) mass [kg] (ghosts copy their source)."""
    particle_material: wp.array
    """(N+G,) int32 material index."""
    particle_x0: np.ndarray
    """(N,3) initial positions [m], host copy."""
    particle_origin: wp.array
    """(N,) vec3 initial positions [m]: load and drainage extents select particles by them."""
    particle_ghost_source: wp.array
    """(G,) int32 owned particle each ghost mirrors."""
    particle_ghost_planes: wp.array
    """(G,) vec3i planes the source is mirrored across, in order (−1 unused)."""

    virtual_count: int
    virtual_ghost_count: int
    virtual_mass: wp.array
    """(M+GV,) mass [kg] of the virtual stress points."""
    virtual_material: wp.array
    """(M+GV,) int32."""
    virtual_origin: wp.array
    """(M,) vec3 initial positions of the virtual points [m] (for extents, as particle_origin); for
    regenerated points the initial position interpolated from the real particles."""
    virtual_ghost_source: wp.array
    virtual_ghost_planes: wp.array

    material_elastic: object
    """Per material, Lamé's λ [Pa], the shear modulus G [Pa] and the drained P-wave speed [m/s], (n_materials,)
    each: an :func:`~warpsph.physics.elastic.elastic_struct`."""

    plane_count: int
    plane_axis: wp.array
    """(P,) int32 axis index 0, 1, 2."""
    plane_position: wp.array
    """(P,) plane coordinate [m]."""
    plane_sign: wp.array
    """(P,) +1 if the outward normal is +axis, −1 otherwise."""
    plane_kind: wp.array
    """(P,) int32, one of PLANE_FIXED, PLANE_SLIP, PLANE_TRACTION, PLANE_VELOCITY."""
    plane_vector: wp.array
    """(P,) vec3: the traction [Pa] or velocity [m/s] before the time factor."""
    plane_extent_lo: wp.array
    plane_extent_hi: wp.array
    """(P,) vec3 box [m] outside which a traction plane is traction-free."""
    plane_functions: list
    """Host time functions f(t) of the planes."""
    plane_names: list

    constraint_count: int
    constraint_particle: wp.array
    """(C,) int32 owned particles lying on planes."""
    constraint_planes: wp.array
    """(C,) vec3i planes each of those lies on (−1 unused)."""

    region_count: int
    region_particle: wp.array
    """(R,) int32 particles of rigid regions ("velocity" and "force" loads)."""
    region_load: wp.array
    """(R,) int32 index of the rigid load each belongs to, among the rigid loads."""
    region_virtual: wp.array
    """(RV,) int32 virtual points of rigid regions (two-set scheme)."""
    region_virtual_load: wp.array
    """(RV,) int32 index of the rigid load each belongs to."""

    material_plasticity: wp.array | None = None
    """(n_materials,) :func:`~warpsph.physics.plasticity.material_struct` values (plasticity only;
    elastic materials have fluidity 0, so they never relax)."""
    particle_ids: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    pore: PoreWaterModel | None = None
    """Hydraulic data, only with the pore_water effect."""
    plates: PlateLayout | None = None
    """The planes' rigid plates (:class:`~warpsph.stages.plates.PlateLayout`; every plane's contact
    ``PLATE_NONE`` without them)."""

    @property
    def particle_total(self) -> int:
        return self.particle_count + self.particle_ghost_count

    @property
    def virtual_total(self) -> int:
        return self.virtual_count + self.virtual_ghost_count

    @property
    def particle_capacity(self) -> int:
        """Owned particles and ghost slots: the length of every real-set array (≥ particle_total;
        larger with ``simulation.large_deformation``, whose ghost count changes)."""
        return self.particle_mass.shape[0]

    @property
    def virtual_capacity(self) -> int:
        """As particle_capacity, for the virtual set (its owned count changes too when a
        large-deformation run regenerates the virtual points)."""
        return self.virtual_mass.shape[0]

    def state(self) -> "State":
        """A zeroed State with every array this model's effects need."""
        return State.allocate(self)


@dataclass
class State:
    """Fields advanced by a step, on owned particles and their ghosts."""

    particle_q: wp.array
    """(N+G,) vec3 positions [m]."""
    particle_v: wp.array
    """(N+G,) vec3 velocities [m/s]."""
    particle_stress: wp.array
    """(N+G,) mat33 effective Cauchy stress [Pa], tension positive."""
    particle_density: wp.array
    """(N+G,) mass density [kg/m³]."""
    virtual_q: wp.array | None
    """(M+GV,) vec3 positions of the virtual stress points [m] (two-set scheme only)."""
    virtual_density: wp.array | None
    """(M+GV,) density at the virtual points [kg/m³] (two-set scheme only)."""
    particle_pore_pressure: wp.array | None = None
    """(N+G,) float64 excess pore pressure over hydrostatic [Pa, compression positive] (pore_water only)."""
    particle_plastic_strain: wp.array | None = None
    """(N+G,) accumulated equivalent plastic strain ε̄ = ∫√(⅔ d^vp:d^vp) dt [-] (plasticity only)."""
    plate_velocity: wp.array | None = None
    """(P,) vec3 velocity of each plane's rigid plate [m/s] (only with plates)."""
    plate_spin: wp.array | None = None
    """(P,) vec3 its angular velocity about its centre [rad/s] (only with plates)."""
    plate_rotation: wp.array | None = None
    """(P,) vec3 its rotation [rad], the spin's integral (only with plates)."""

    @classmethod
    def allocate(cls, model: Model) -> "State":
        s, dev = model.spec, model.device
        n, m = model.particle_capacity, model.virtual_capacity
        two_set = s.scheme == "two_set"
        return cls(
            particle_q=wp.zeros(n, dtype=s.vec3, device=dev),
            particle_v=wp.zeros(n, dtype=s.vec3, device=dev),
            particle_stress=wp.zeros(n, dtype=s.mat33, device=dev),
            particle_density=wp.zeros(n, dtype=s.real, device=dev),
            virtual_q=wp.zeros(m, dtype=s.vec3, device=dev) if two_set else None,
            virtual_density=wp.zeros(m, dtype=s.real, device=dev) if two_set else None,
            particle_pore_pressure=wp.zeros(n, dtype=wp.float64, device=dev) if s.effects.pore_water else None,
            particle_plastic_strain=wp.zeros(n, dtype=s.real, device=dev) if s.effects.plasticity else None,
            **{name: (wp.zeros(model.plane_count, dtype=s.vec3, device=dev)
                      if model.plates is not None and model.plates.count else None)
               for name in ("plate_velocity", "plate_spin", "plate_rotation")},
        )

    def arrays(self) -> dict[str, wp.array]:
        """The allocated arrays by name (for checkpoints and copies)."""
        return {k: v for k, v in vars(self).items() if isinstance(v, wp.array)}

    def assign(self, other: "State") -> None:
        """Copy every array of ``other`` into this state."""
        for name, arr in other.arrays().items():
            wp.copy(getattr(self, name), arr)

    def host_copy(self) -> dict[str, np.ndarray]:
        """A copy of every array on the host, by name (:meth:`assign_host` puts it back)."""
        return {name: arr.numpy().copy() for name, arr in self.arrays().items()}

    def assign_host(self, arrays: dict[str, np.ndarray]) -> None:
        """Copy the host ``arrays`` of :meth:`host_copy` into this state."""
        for name, arr in self.arrays().items():
            arr.assign(arrays[name])


def host_fields(model: Model, state: State, rows: np.ndarray | None = None,
                index: wp.array | None = None) -> dict[str, np.ndarray]:  # fmt: skip
    """Owned-particle fields on the host: position, velocity (N,3) [m, m/s], stress (N,3,3) [Pa],
    density [kg/m³], with pore water the total pore pressure (N,) [Pa] and with plasticity the
    equivalent plastic strain (N,) [-]. ``rows``: only these particles, gathered on the device
    before the copy (``index``: the same rows as a device int32 array, when one is kept)."""
    n = model.particle_count
    if rows is None or not len(rows):
        def read(arr):
            return arr.numpy()[: n if rows is None else 0]
    else:
        if index is None:
            index = wp.array(rows.astype(np.int32), dtype=wp.int32, device=model.device)

        def read(arr):
            return wp.indexedarray(arr, [index]).numpy()
    fields = {
        "position": read(state.particle_q).astype(np.float64),
        "velocity": read(state.particle_v).astype(np.float64),
        "stress": read(state.particle_stress).astype(np.float64),
        "density": read(state.particle_density).astype(np.float64),
    }
    if model.pore is not None:
        material = model.particle_material.numpy()[:n] if rows is None else read(model.particle_material)
        water_density = model.pore.water.density.numpy()[material]
        hydrostatic = model.pore.hydrostatic(fields["position"], water_density)
        fields["pore_pressure"] = read(state.particle_pore_pressure) + hydrostatic
    if state.particle_plastic_strain is not None:
        fields["plastic_strain"] = read(state.particle_plastic_strain).astype(np.float64)
    return fields
