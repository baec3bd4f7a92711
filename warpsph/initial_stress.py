"""Geostatic initial stresses: the weight of the soil above each particle (docs/scenes.md, *Phases*).

The depth of a particle is measured up its own lattice column (the particles sharing its x, and z in
3D) to the highest particle of that column, so a slope's toe carries the cover above the toe, not the
height of the crest. Layers of different unit weights add up: σ′_v = −Σ γ′ Δy, integrated by the
trapezoidal rule between the column's particles.
"""

from __future__ import annotations

import numpy as np


def overburden(points: np.ndarray, unit_weight: np.ndarray, dx: float,
               surface_load: np.ndarray | None = None) -> np.ndarray:
    """Vertical stress σ_v [Pa] (tension positive, so ≤ 0) at the (N,3) lattice ``points`` from the
    weight of the particles above each in its column; ``unit_weight`` (N,) is γ [N/m³] per particle, and
    ``surface_load`` (N,) [Pa], if given, a pressure on each column's top, read at its highest particle.

    A column is split into layers, runs of one unit weight from the top down: inside a layer
    σ_v = −(W + γ (y_top − y)) with W the weight above the layer's top particle, so a uniform column
    is exact to rounding and no sum runs across columns."""
    n = len(points)
    if n == 0:
        return np.zeros(0)
    columns = np.round(points[:, [0, 2]] / dx).astype(np.int64)
    _, column = np.unique(columns, axis=0, return_inverse=True)
    column = column.reshape(-1)
    order = np.lexsort((-points[:, 1], column))  # by column, then from the top down
    y, gamma, col = points[order, 1], unit_weight[order], column[order]
    same_column = np.r_[False, col[1:] == col[:-1]]
    layer_start = np.flatnonzero(~same_column | np.r_[False, gamma[1:] != gamma[:-1]])
    layer_end = np.r_[layer_start[1:], n]
    above = np.zeros(len(layer_start))  # W of each layer
    if surface_load is not None:
        tops = ~same_column[layer_start]
        above[tops] = surface_load[order[layer_start[tops]]]
    for k in range(1, len(layer_start)):
        first = layer_start[k]
        if same_column[first]:
            last = first - 1  # the layer above's bottom particle
            above[k] = (above[k - 1] + gamma[last] * (y[layer_start[k - 1]] - y[last])
                        + 0.5 * (gamma[last] + gamma[first]) * (y[last] - y[first]))
    layer = np.repeat(np.arange(len(layer_start)), layer_end - layer_start)
    out = np.empty(n)
    out[order] = -(above[layer] + gamma * (y[layer_start][layer] - y))
    return out


def geostatic_unit_weight(material, gravity, pore_water: bool) -> float:
    """The unit weight γ′ [N/m³] that loads ``material``'s skeleton under ``gravity`` (3,) [m/s²]:
    the buoyant (ρ − ρ_w)(−g_y) with pore water, ρ(−g_y) without."""
    return (material.density - (material.water_density if pore_water else 0.0)) * (-gravity[1])


def geostatic_stress(vertical: np.ndarray, k0: np.ndarray) -> np.ndarray:
    """(N,3,3) geostatic effective stress [Pa]: σ′_yy = ``vertical`` (N,) [Pa] (:func:`overburden`),
    σ′_xx = σ′_zz = K0 σ′_yy with ``k0`` (N,) per particle."""
    out = np.zeros((len(vertical), 3, 3))
    out[:, 0, 0] = out[:, 2, 2] = k0 * vertical
    out[:, 1, 1] = vertical
    return out
