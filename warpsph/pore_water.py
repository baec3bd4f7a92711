"""Static data of the pore_water effect: per-material hydraulic constants and per-plane drainage.

Pore pressure is stored as the *excess* over the hydrostatic pressure p_h(x) = ρ_w b·(x − x_wt)
(x_wt on the water table; with b = (0, −g, 0) this is ρ_w g (y_wt − y)), so a column at rest has
zero excess pressure exactly and Darcy's law reads w = k(−∇p + ρ_w b) = −k ∇p_excess. Results
report the total pressure p = p_excess + p_h.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import warp as wp

from warpsph.scene import STANDARD_GRAVITY, Region, Scene

DRAINAGE = {"impermeable": 0, "drained": 1, "inflow": 2}


@dataclass
class PoreWaterModel:
    """Device arrays (float64) of the pore_water effect; P planes, n_materials materials."""

    water_table: float
    """Level y_wt of the hydrostatic reference [m]."""
    gravity: tuple
    """Body force b [m/s²] (the scene's gravity)."""
    material_permeability: wp.array
    """(n_materials,) k = k_h/(ρ_w g) [m³·s/kg]."""
    material_inv_biot: wp.array
    """(n_materials,) 1/Q [1/Pa]."""
    material_water_density: wp.array
    """(n_materials,) ρ_w [kg/m³]."""
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

    def hydrostatic(self, positions: np.ndarray, water_density: np.ndarray) -> np.ndarray:
        """p_h = ρ_w b·(x − x_wt) [Pa] at (N,3) positions (host)."""
        b = np.asarray(self.gravity, dtype=float)
        shifted = positions - np.array([0.0, self.water_table, 0.0])
        return water_density * (shifted @ b)


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
    return PoreWaterModel(
        water_table=top if scene.pressure.water_table is None else scene.pressure.water_table,
        gravity=tuple(scene.simulation.gravity),
        material_permeability=arr([m.hydraulic_conductivity / (m.water_density * STANDARD_GRAVITY) for m in mats]),
        material_inv_biot=arr([0.0 if math.isinf(m.biot_modulus) else 1.0 / m.biot_modulus for m in mats]),
        material_water_density=arr([m.water_density for m in mats]),
        plane_drainage=arr([DRAINAGE[d.kind] for d in planes_drainage] or [0], wp.int32),
        plane_pressure=arr([d.pore_pressure for d in planes_drainage] or [0.0]),
        plane_head=arr([nan if d.head is None else d.head for d in planes_drainage] or [nan]),
        plane_inflow=arr([d.inflow for d in planes_drainage] or [0.0]),
        plane_drained_lo=arr(np.clip(np.array([e.min for e in extents]) - grow, -big, big), vec3),
        plane_drained_hi=arr(np.clip(np.array([e.max for e in extents]) + grow, -big, big), vec3),
        planes=list(planes_drainage),
    )
