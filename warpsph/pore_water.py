"""Static data of the pore_water effect: per-material hydraulic constants and per-plane drainage.

Pore pressure is stored as the *excess* over the hydrostatic pressure p_h(x) = ρ_w b·(x − x_wt)
(x_wt on the water table; with b = (0, −g, 0) this is ρ_w g (y_wt − y)), so a column at rest has
zero excess pressure exactly and Darcy's law reads w = k(−∇p + ρ_w b) = −k ∇p_excess. Results
report the total pressure p = p_excess + p_h.
"""

import functools
import math
from dataclasses import dataclass

import numpy as np
import warp as wp

from warpsph.physics.retention import RETENTION, RetentionLaws, retention_laws
from warpsph.scene import EXTENT_TOLERANCE, STANDARD_GRAVITY, Region, Scene
from warpsph.stages.surface_water import SurfaceWater, surface_water

DRAINAGE = {"impermeable": 0, "drained": 1, "inflow": 2}


@functools.cache
def water_struct(vec3):
    """The ``Water`` @wp.struct for positions of type ``vec3``: per material k, 1/Q, ρ_w and n (float64),
    with the gravity and the water table of the hydrostatic reference, as the pore-water kernels take them."""

    @wp.struct
    class Water:
        permeability: wp.array(dtype=wp.float64)
        inv_biot: wp.array(dtype=wp.float64)
        density: wp.array(dtype=wp.float64)
        porosity: wp.array(dtype=wp.float64)
        gravity: vec3
        water_table: wp.float64

    return Water


@dataclass
class PoreWaterModel:
    """Device arrays (float64) of the pore_water effect; P planes, n_materials materials."""

    water_table: float
    """Level y_wt of the hydrostatic reference [m]."""
    gravity: tuple
    """Body force b [m/s²] (the scene's gravity)."""
    retention: RetentionLaws
    """Each material's water retention law, α, n and S_r (:class:`~warpsph.physics.retention.RetentionLaws`)."""
    suction: int
    """1 where held pore pressures and the K0 procedure count suction (``pressure.suction = "counted"``), else 0."""
    plane_drainage: wp.array
    """(P,) int32: 0 impermeable, 1 drained, 2 inflow."""
    plane_pressure: wp.array
    """(P,) prescribed total pore pressure of a drained plane [Pa] (used when its head is NaN)."""
    plane_head: wp.array
    """(P,) prescribed head [m] of a drained plane, NaN when a pressure is given instead."""
    plane_inflow: wp.array
    """(P,) Darcy velocity into the body through an inflow plane [m/s]."""
    plane_drained_lo: wp.array
    """(P,) vec3 lower corner of the part of each plane that drains [m] (impermeable outside)."""
    plane_drained_hi: wp.array
    """(P,) vec3 upper corner of that part [m]."""
    planes: list
    """(P,) the planes' :class:`~warpsph.scene.Drainage` records (host)."""
    reservoirs: list
    """The scene's :class:`~warpsph.scene.Reservoir` records (host)."""
    surface_water: SurfaceWater
    """The water against the free surfaces: the hydrostatic reference and the reservoirs."""
    water: object
    """Per material (n_materials,) k = k_h/(ρ_w g) [m³·s/kg], 1/Q [1/Pa], ρ_w [kg/m³] and n [-], with the
    gravity and the water table, as one ``Water`` struct (:func:`water_struct`)."""

    def drained_plane_particles(self, model) -> tuple[np.ndarray, np.ndarray]:
        """(on, plane): the owned particles lying on drained planes (int32 mask) and the plane's index
        (−1 off them)."""
        m = model
        n = m.particle_count
        on, plane = np.zeros(n, np.int32), np.full(n, -1, np.int32)
        drainage = self.plane_drainage.numpy()
        x = m.particle_x0
        axes = m.plane_axis.numpy()
        plates = m.plates
        for a, planes, plate in zip(m.constraint_particle.numpy(), m.constraint_planes.numpy().reshape(-1, 3),
                                    plates.plate_of):  # fmt: skip
            for p in planes[planes >= 0]:
                drained = drainage[p] == 1 and self.planes[p].covers(x[a : a + 1], axes[p], EXTENT_TOLERANCE * m.dx)[0]
                if p == plate:  # a plate's base drains or not, whatever its face does beside it
                    drained = plates.base[p] == 1
                if drained:
                    on[a], plane[a] = 1, p
        return on, plane

    def hydrostatic(self, positions: np.ndarray, water_density: np.ndarray) -> np.ndarray:
        """p_h = ρ_w b·(x − x_wt) [Pa] at (N,3) positions (host)."""
        b = np.asarray(self.gravity, dtype=float)
        shifted = positions - np.array([0.0, self.water_table, 0.0])
        return water_density * (shifted @ b)


class PlaneDrainage:
    """The planes' prescribed pore pressure, head and inflow at a time: the pore-water model's, each
    multiplied by its drainage ``time_function`` f(t) of the phase's time (docs/scenes.md, *Drainage*),
    as device arrays the kernels read and as the excess pore pressure held on the owned particles that
    lie on drained planes (``on``, ``plane``, ``value``)."""

    def __init__(self, model):
        pw = model.pore
        self.functions = [d.time_function for d in pw.planes]
        self.changing = any(f.kind != "constant" for f in self.functions)
        """Whether a plane's values change in time (else :meth:`set_time` never changes them)."""
        self._base = [a.numpy().copy() for a in (pw.plane_pressure, pw.plane_head, pw.plane_inflow)]
        self.pressure, self.head, self.inflow = (wp.clone(a) for a in (pw.plane_pressure, pw.plane_head,
                                                                      pw.plane_inflow))  # fmt: skip
        self.on, self.plane = pw.drained_plane_particles(model)
        rows = np.flatnonzero(self.on)
        x = model.particle_x0[rows]
        rho_w = pw.water.density.numpy()[model.particle_material.numpy()[rows]]
        self._rows, self._y = rows, x[:, 1]
        self._rho_g = rho_w * float(np.linalg.norm(pw.gravity))
        self._hydrostatic = pw.hydrostatic(x, rho_w)
        self.factors = np.ones(max(len(self.functions), 1))
        self.value = self._values()
        """(n,) the excess pore pressure [Pa] held on the particles on drained planes (0 off them)."""

    def _values(self) -> np.ndarray:
        pressure, head = (base * self.factors for base in self._base[:2])
        p = self.plane[self._rows]
        total = np.where(np.isnan(head[p]), pressure[p], self._rho_g * (head[p] - self._y))
        value = np.zeros(len(self.on))
        value[self._rows] = total - self._hydrostatic
        return value

    def set_time(self, t: float) -> bool:
        """The values at time ``t`` [s]; whether they changed since the last call."""
        factors = np.array([f(t) for f in self.functions] or [1.0])
        if np.array_equal(factors, self.factors):
            return False
        self.factors = factors
        for array, base in zip((self.pressure, self.head, self.inflow), self._base):
            array.assign(base * factors)
        self.value = self._values()
        return True


def build_pore_water(scene: Scene, planes_drainage: list, top: float, vec3, grow: float, device) -> PoreWaterModel:
    """Arrays of the pore_water effect for ``scene``; ``planes_drainage`` is one Drainage per plane
    (in the model's plane order), ``top`` the highest particle level [m] (default water table),
    ``vec3`` the Warp vector type of positions, ``grow`` [m] the margin added to drainage extents."""
    mats = list(scene.materials.values())
    big = float(np.finfo(np.float32).max)
    extents = [d.extent or Region() for d in planes_drainage] or [Region()]

    def arr(values, dtype=wp.float64):
        return wp.array(np.asarray(values), dtype=dtype, device=device)

    nan = float("nan")
    water_table = top if scene.pressure.water_table is None else scene.pressure.water_table
    water = water_struct(vec3)()
    water.permeability = arr([m.hydraulic_conductivity / (m.water_density * STANDARD_GRAVITY) for m in mats])
    water.inv_biot = arr([0.0 if math.isinf(m.biot_modulus) else 1.0 / m.biot_modulus for m in mats])
    water.density = arr([m.water_density for m in mats])
    water.porosity = arr([m.porosity for m in mats])
    water.gravity = vec3(*scene.simulation.gravity)
    water.water_table = wp.float64(water_table)
    return PoreWaterModel(
        water_table=water_table,
        gravity=tuple(scene.simulation.gravity),
        retention=retention_laws(arr([RETENTION[m.retention] for m in mats], wp.int32),
                                 arr([m.retention_alpha for m in mats]), arr([m.retention_n for m in mats]),
                                 arr([m.residual_saturation for m in mats])),
        suction=int(scene.pressure.suction == "counted"),
        plane_drainage=arr([DRAINAGE[d.kind] for d in planes_drainage] or [0], wp.int32),
        plane_pressure=arr([d.pore_pressure for d in planes_drainage] or [0.0]),
        plane_head=arr([nan if d.head is None else d.head for d in planes_drainage] or [nan]),
        plane_inflow=arr([d.inflow for d in planes_drainage] or [0.0]),
        plane_drained_lo=arr(np.clip(np.array([e.min for e in extents]) - grow, -big, big), vec3),
        plane_drained_hi=arr(np.clip(np.array([e.max for e in extents]) + grow, -big, big), vec3),
        planes=list(planes_drainage),
        reservoirs=list(scene.reservoirs),
        surface_water=surface_water(scene.simulation.gravity, water_table, scene.reservoirs, device),
        water=water,
    )
