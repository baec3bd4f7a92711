"""Probes: scalar time series sampled from the particle fields on the host, following the material particles
they start with (docs/scenes.md, *[[probes]]*; reaction probes: docs/method.md, *Boundaries*).
"""

from __future__ import annotations

import numpy as np

from warpsph.fields import mean_stress, von_mises
from warpsph.lattice import lattice_neighbours, used_axes
from warpsph.model import Model
from warpsph.stages.rigid import RIGID_LOAD_KINDS

_COMPONENT = {"x": 0, "y": 1, "z": 2}
EXTREMA = {"maximum": np.max, "minimum": np.min}
"""Probe kinds that reduce a field over their particles to its extreme value."""
_STRESS = {"xx": (0, 0), "yy": (1, 1), "zz": (2, 2), "yz": (1, 2), "xz": (0, 2), "xy": (0, 1)}


def field_values(name: str, fields: dict[str, np.ndarray], x0: np.ndarray) -> np.ndarray:
    """Per-particle values of the probe field ``name`` from host arrays position, velocity, stress."""
    kind, _, comp = name.rpartition("_")
    if kind == "velocity":
        return fields["velocity"][:, _COMPONENT[comp]]
    if kind == "position":
        return fields["position"][:, _COMPONENT[comp]]
    if kind == "displacement":
        return fields["position"][:, _COMPONENT[comp]] - x0[:, _COMPONENT[comp]]
    if kind == "stress":
        i, j = _STRESS[comp]
        return fields["stress"][:, i, j]
    if name == "mean_stress":
        return mean_stress(fields["stress"])
    if name == "von_mises":
        return von_mises(fields["stress"])
    if name in ("pore_pressure", "plastic_strain"):
        return fields[name]
    raise ValueError(f"unknown probe field {name!r}")


def total_stress(fields: dict[str, np.ndarray]) -> np.ndarray:
    """σ = σ′ − p I [Pa] (N,3,3): the effective stress, less the pore pressure where there is one."""
    if "pore_pressure" not in fields:
        return fields["stress"]
    return fields["stress"] - fields["pore_pressure"][:, None, None] * np.eye(3)


def tributary_areas(x: np.ndarray, neighbours: np.ndarray, axes: list[int]) -> np.ndarray:
    """The area (M,) [m^(dim−1)] each of the points at ``x`` (M,3) [m] stands for on a plane whose
    in-plane ``axes`` (none in 1D, one in 2D, two in 3D) and lattice ``neighbours``
    (:func:`lattice_neighbours`) are given: the area spanned along the plane by d_a = (x_{+a} − x_{−a})/2,
    a missing neighbour replaced by the point itself (the trapezoidal rule's weights on the current
    positions, projected onto the plane)."""
    spans = []
    for k in range(len(axes)):
        lower, upper = neighbours[k]
        below = np.where(lower[:, None] >= 0, x[np.maximum(lower, 0)], x)
        above = np.where(upper[:, None] >= 0, x[np.maximum(upper, 0)], x)
        spans.append(0.5 * (above - below)[:, axes])
    if not spans:
        return np.ones(len(x))
    if len(spans) == 1:
        return np.abs(spans[0][:, 0])
    return np.abs(spans[0][:, 0] * spans[1][:, 1] - spans[0][:, 1] * spans[1][:, 0])


class Probes:
    """The scene's probes, resolved against a model's particles."""

    def __init__(self, model: Model):
        self.model = model
        self.probes = list(model.scene.probes)
        x0 = model.particle_x0
        self.displacement_origin = x0
        """(N,3) positions displacements are measured from [m] (a phase may reset them)."""
        tol = 1.0e-6 * model.dx
        self.selection: list[np.ndarray] = []
        self.normal: list[np.ndarray | None] = []
        self.plane_axes: list[list[int]] = []
        """Each reaction probe's in-plane axes among the scene's (none for the other probes)."""
        self.neighbours: list[np.ndarray | None] = []
        """Each reaction probe's lattice neighbours on its plane (:func:`lattice_neighbours`)."""
        used = used_axes(model.spec.dim)
        rigid = [ld.name for ld in model.scene.loads if ld.kind in RIGID_LOAD_KINDS]
        self.rigid_index: list[int | None] = []
        for p in self.probes:
            normal = neighbours = None
            axes = []
            self.rigid_index.append(rigid.index(p.boundary) if p.kind == "reaction" and p.boundary in rigid else None)
            if self.rigid_index[-1] is not None:
                sel = np.zeros(0, dtype=np.int64)
            elif p.kind == "point":
                sel = np.array([np.argmin(np.sum((x0 - np.asarray(p.point)) ** 2, axis=1))])
            elif p.kind == "region_mean" or (p.kind in EXTREMA and p.region is not None):
                sel = np.nonzero(p.region.contains(x0, tol))[0]
            elif p.kind in EXTREMA:
                sel = np.arange(len(x0))
            else:
                plane = model.plane_names.index(p.boundary)
                axis = int(model.plane_axis.numpy()[plane])
                position = float(model.plane_position.numpy()[plane])
                sel = np.nonzero(np.abs(x0[:, axis] - position) <= tol)[0]
                normal = np.zeros(3)
                normal[axis] = float(model.plane_sign.numpy()[plane])
                axes = [k for k in used if k != axis]
                neighbours = lattice_neighbours(x0[sel], model.dx, axes)
            self.selection.append(sel)
            self.normal.append(normal)
            self.plane_axes.append(axes)
            self.neighbours.append(neighbours)
        everything = any(p.kind in EXTREMA and p.region is None for p in self.probes)
        self.rows = None if everything else np.unique(np.concatenate([np.zeros(0, np.int64), *self.selection]))
        """The particles the probes read, sorted (None: all of them), so that a sample between frames
        copies only these from the device (:meth:`sample` with ``rows``)."""

    @property
    def names(self) -> list[str]:
        return [p.name for p in self.probes]

    def sample(self, fields: dict[str, np.ndarray], rigid_contact: np.ndarray | None = None,
               rows: np.ndarray | None = None) -> dict[str, float]:  # fmt: skip
        """Probe values from host fields position (N,3), velocity (N,3), stress (N,3,3), density (N,)
        and, for reactions of rigid regions, their contact forces ``rigid_contact`` (K,3) [N/m or N]
        (NaN without them). ``rows``: the fields hold only these particles (:attr:`rows`)."""
        out = {}
        x0 = self.displacement_origin
        selections = self.selection
        if rows is not None:
            x0 = x0[rows]
            selections = [np.searchsorted(rows, sel) for sel in self.selection]
        for p, sel, normal, axes, neighbours, k in zip(self.probes, selections, self.normal, self.plane_axes,
                                                      self.neighbours, self.rigid_index):  # fmt: skip
            if k is not None:
                known = rigid_contact is not None
                out[p.name] = p.scale * float(rigid_contact[k, _COMPONENT[p.field]]) if known else float("nan")
            elif p.kind == "reaction":
                traction = total_stress(fields)[sel] @ normal
                area = tributary_areas(fields["position"][sel], neighbours, axes)
                out[p.name] = p.scale * float(np.sum(traction[:, _COMPONENT[p.field]] * area))
            else:
                values = field_values(p.field, {k: v[sel] for k, v in fields.items()}, x0[sel])
                reduce = EXTREMA.get(p.kind, np.mean)
                out[p.name] = p.scale * float(reduce(values)) if len(values) else float("nan")
        return out
