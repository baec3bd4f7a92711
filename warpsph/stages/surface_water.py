"""The water against the free surfaces of saturated soil: reservoirs and the hydrostatic reference of
the excess pore pressure, as the Taylor steps' surface band and the projection's drained rows read
them (docs/method.md, *Reservoirs and free surfaces*).

The momentum balance carries the excess pore pressure p = p_w − p_h, so the band's traction term
pushes the extrapolated σ′ − pI towards (p_h − p_res) n: zero total traction on a dry face
(p_res = 0) and the water's pressure p_res = ρ_w g (level − y) below a reservoir's level.
"""

from __future__ import annotations

import numpy as np
import warp as wp

from warpsph.errors import SceneError

f64 = wp.float64


@wp.struct
class SurfaceWater:
    """Device data of the water against free surfaces (float64)."""

    gravity: wp.vec3d
    """Body force b [m/s²]."""
    water_table: f64
    """Level y_wt of the hydrostatic reference [m]."""
    count: int
    """Number of reservoirs."""
    level: wp.array(dtype=f64)
    """(R,) each reservoir's current level [m]."""
    lo: wp.array(dtype=wp.vec3d)
    """(R,) lower corner of each reservoir's region [m]."""
    hi: wp.array(dtype=wp.vec3d)
    """(R,) upper corner [m]."""


@wp.func
def reservoir_pressure(w: SurfaceWater, rho_w: f64, x0: f64, x1: f64, x2: f64):
    """(wet, p_res): whether a surface point at (x0, x1, x2) lies under a reservoir, and the water's
    pressure there [Pa] (the deepest reservoir's where regions overlap)."""
    wet = int(0)
    pressure = f64(0.0)
    rho_g = rho_w * wp.length(w.gravity)
    for r in range(w.count):
        lo = w.lo[r]
        hi = w.hi[r]
        if x0 >= lo[0] and x0 <= hi[0] and x1 >= lo[1] and x1 <= hi[1] and x2 >= lo[2] and x2 <= hi[2]:
            if x1 <= w.level[r]:
                wet = 1
                pressure = wp.max(pressure, rho_g * (w.level[r] - x1))
    return wet, pressure


@wp.func
def water_against_surface(w: SurfaceWater, rho_w: f64, x0: f64, x1: f64, x2: f64):
    """p_h − p_res [Pa] at a surface point: the excess-pressure traction σ′n − p n that the water
    against it balances (zero where the surface lies at the reference level and is dry)."""
    hydrostatic = rho_w * (w.gravity[0] * x0 + w.gravity[1] * (x1 - w.water_table) + w.gravity[2] * x2)
    _wet, pressure = reservoir_pressure(w, rho_w, x0, x1, x2)
    return hydrostatic - pressure


def surface_water(gravity, water_table: float, reservoirs: list, device) -> SurfaceWater:
    """A :class:`SurfaceWater` for ``reservoirs`` (:class:`~warpsph.scene.Reservoir`) at their full
    levels; :func:`set_levels` moves them."""
    w = SurfaceWater()
    w.gravity = wp.vec3d(*map(float, gravity))
    w.water_table = float(water_table)
    w.count = len(reservoirs)
    big = float(np.finfo(np.float64).max)
    lo = [np.clip(np.asarray(r.region.min, dtype=float), -big, big) for r in reservoirs] or [np.zeros(3)]
    hi = [np.clip(np.asarray(r.region.max, dtype=float), -big, big) for r in reservoirs] or [np.zeros(3)]
    w.lo = wp.array(np.array(lo), dtype=wp.vec3d, device=device)
    w.hi = wp.array(np.array(hi), dtype=wp.vec3d, device=device)
    w.level = wp.array(np.array([r.level for r in reservoirs] or [0.0]), dtype=f64, device=device)
    return w


def wetted_regions(reservoirs: list, positions: np.ndarray, surface: np.ndarray, dx: float) -> list:
    """Per reservoir, the mask of the free-surface particles (``surface``, at ``positions``) inside its
    region; a region with none raises :class:`~warpsph.errors.SceneError` (its water would do nothing)."""
    masks = []
    for r in reservoirs:
        inside = r.region.contains(positions, 1e-6 * dx) & surface
        if not inside.any():
            raise SceneError(f"reservoirs.{r.name}.region", "contains no free-surface particle: this water touches "
                             "no surface of the model")  # fmt: skip
        masks.append(inside)
    return masks


def free_water(reservoirs: list, level: np.ndarray, unit_weight: float):
    """The pressure [Pa] of ``reservoirs`` at ``level`` (R,) [m] on points (x, y) (each (C,) [m]) of a 2D
    model's surface, the deepest reservoir's where regions overlap (as :func:`reservoir_pressure`)."""

    def pressure(x: np.ndarray, y: np.ndarray) -> np.ndarray:
        points = np.stack([x, y, np.zeros_like(x)], axis=1)
        p = np.zeros(len(points))
        for reservoir, height in zip(reservoirs, level):
            p = np.where(reservoir.region.contains(points), np.maximum(p, unit_weight * (height - y)), p)
        return p

    return pressure


def levels(reservoirs: list, t: float) -> np.ndarray:
    """Each reservoir's level at time ``t`` of its phase [m]."""
    return np.array([r.level * r.time_function(t) for r in reservoirs] or [0.0])
