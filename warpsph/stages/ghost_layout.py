"""Mirror-ghost layouts: which points are mirrored across which boundary planes, planned on the host at
build and, with ``simulation.large_deformation``, re-planned as the points move, and particles joining the
walls they reach (docs/method.md, *Large deformation*).
"""


import functools
import math

import numpy as np
import warp as wp

from warpsph.errors import SimulationError
from warpsph.launching import launch
from warpsph.model import PLANE_FIXED, PLANE_SLIP
from warpsph.sph.spec import Spec

GHOST_MARGIN = 0.25
"""Ghost band beyond the support radius 2h, as a fraction of 2h (room for motion between plans)."""
CONTACT = 0.8
"""A particle closer than this to a fixed or slip wall (not a symmetry plane), as a fraction of Δx,
joins it (large deformation). Measured on a block dropped onto a fixed floor (tests/test_large_deformation.py): the
mirror ghosts hold its bottom row 0.72 Δx above the plane, where it rocks and blows up by 0.3 s;
joining at 0.8 Δx, it lands and settles."""
ON_PLANE = 1.0e-6
"""A particle within this fraction of Δx of a plane lies on it (it is its own mirror: no ghost)."""


def plan_ghosts(points: np.ndarray, planes, band: float, tol: float):
    """Mirror ghosts of ``points`` (n,3) [m] across ``planes``, a sequence of (axis, position [m],
    outward sign): (ghost positions (g,3), source index (g,), plane chain (g,3), −1 unused)."""
    pos = np.asarray(points, dtype=float).reshape(-1, 3)
    src = np.arange(len(pos), dtype=np.int32)
    chain = np.full((len(pos), 3), -1, dtype=np.int32)
    n_owned = len(pos)
    for p_idx, (axis, position, sign) in enumerate(planes):
        depth = sign * (position - pos[:, axis])
        sel = np.nonzero((depth > tol) & (depth <= band) & (chain[:, 2] < 0))[0]
        mirrored = pos[sel].copy()
        mirrored[:, axis] = 2.0 * position - mirrored[:, axis]
        new_chain = chain[sel].copy()
        slot = np.argmax(new_chain < 0, axis=1)
        new_chain[np.arange(len(sel)), slot] = p_idx
        pos = np.concatenate([pos, mirrored])
        src = np.concatenate([src, src[sel]])
        chain = np.concatenate([chain, new_chain])
    return pos[n_owned:], src[n_owned:], chain[n_owned:]


@functools.cache
def _largest_move_kernel(spec: Spec):
    real, vec3 = spec.real, spec.vec3

    @wp.kernel(enable_backward=False, module="unique")
    def largest_move(q: wp.array(dtype=vec3), reference: wp.array(dtype=vec3), out: wp.array(dtype=real)):
        """out[0] = max |q − reference| over the points [m]."""
        i = wp.tid()
        wp.atomic_max(out, 0, wp.length(q[i] - reference[i]))

    return largest_move


@functools.cache
def _keep_inside_kernel(spec: Spec):
    real, vec3 = spec.real, spec.vec3

    @wp.kernel(enable_backward=False, module="unique")
    def keep_inside(
        plane_count: int,
        contact: wp.array(dtype=real),
        plane_axis: wp.array(dtype=wp.int32),
        plane_position: wp.array(dtype=real),
        plane_sign: wp.array(dtype=real),
        plane_kind: wp.array(dtype=wp.int32),
        q: wp.array(dtype=vec3),
        v: wp.array(dtype=vec3),
        friction: wp.array(dtype=real),
        stress: wp.array(dtype=spec.mat33),
        density: wp.array(dtype=real),
        dt: real,
        dx: real,
    ):
        """A particle closer to a fixed or slip plane p than ``contact[p]`` [m], or beyond it, joins
        it: it goes onto the plane and keeps no velocity into it (fixed: no velocity at all), as the
        particles that start on a plane do. On a slip plane with friction μ the particles lying on it
        lose up to μ times their normal impulse per unit mass of tangential speed (Coulomb): the
        normal traction −σ_nn over the step, on the area V/Δx a particle stands for, plus the velocity
        into the plane just removed (the contact impulse of a particle the stress does not carry)."""
        a = wp.tid()
        x = q[a]
        u = v[a]
        for p in range(plane_count):
            kind = plane_kind[p]
            if kind == PLANE_FIXED or kind == PLANE_SLIP:
                m = plane_axis[p]
                if plane_sign[p] * (x[m] - plane_position[p]) > -contact[p]:
                    x[m] = plane_position[p]
                    if kind == PLANE_FIXED:
                        u = vec3(real(0.0), real(0.0), real(0.0))
                    else:
                        removed = real(0.0)
                        if plane_sign[p] * u[m] > real(0.0):
                            removed = wp.abs(u[m])
                            u[m] = real(0.0)
                        if friction[p] > real(0.0):
                            pn = wp.max(-stress[a][m, m], real(0.0))
                            dv = friction[p] * (pn * dt / (density[a] * dx) + removed)
                            ut = u
                            ut[m] = real(0.0)
                            speed = wp.length(ut)
                            if speed <= dv:
                                ut = vec3(real(0.0), real(0.0), real(0.0))
                            else:
                                ut = ut * ((speed - dv) / speed)
                            ut[m] = u[m]
                            u = ut
        q[a] = x
        v[a] = u

    return keep_inside


class _SetLayout:
    """One particle set's fields of the model, by name prefix: ``layout.count`` is
    ``model.particle_count`` or ``model.virtual_count``, and so on."""

    def __init__(self, model, prefix: str):
        self.model, self.prefix = model, prefix

    def __getattr__(self, name):
        return getattr(self.model, f"{self.prefix}_{name}")

    @property
    def owned(self) -> int:
        return self.count

    def assign(self, src: np.ndarray, chain: np.ndarray) -> None:
        """Make (src, chain) the live ghosts; their mass and material copy their sources'."""
        n, g = self.owned, len(src)
        if g > self.ghost_source.shape[0] or n + g > self.capacity:
            raise SimulationError(
                f"large deformation: {g} ghosts of the {self.prefix} set needed, room for "
                f"{self.ghost_source.shape[0]}; the body has spread along its boundary planes beyond what was "
                "allocated at the start (lower the resolution or split the run)")  # fmt: skip
        if g:
            self.ghost_source[:g].assign(src)
            self.ghost_planes[:g].assign(chain)
        for values in (self.mass, self.material):
            host = values.numpy()
            host[n : n + g] = host[src]
            values.assign(host)
        setattr(self.model, f"{self.prefix}_ghost_count", g)


class GhostLayout:
    """Re-plans the ghosts of both sets of a model as its points move (large deformation)."""

    def __init__(self, model, plane_position: wp.array, regenerator=None, region_members=None):
        self.model = model
        self.regenerator = regenerator
        """A :class:`~warpsph.stages.virtual_points.VirtualRegenerator` that rebuilds the virtual
        points at every re-plan (two-set scheme), with ``region_members(origins)`` for its
        velocity regions."""
        self.region_members = region_members
        self.plane_position = plane_position
        self.band = 2.0 * model.h * (1.0 + GHOST_MARGIN)
        self.skin = 0.5 * 2.0 * model.h * GHOST_MARGIN
        self.tol = ON_PLANE * model.dx
        self.sets = [_SetLayout(model, "particle")]
        if model.virtual_count:
            self.sets.append(_SetLayout(model, "virtual"))
        self.reference: list = [None] * len(self.sets)
        self._largest = wp.zeros(1, dtype=model.spec.real, device=model.device)
        # symmetry planes are not walls: material only may not cross them (joining them at 0.8 Δx
        # piled particles onto the plane and onto a corner: measured, a collapsing column's centre)
        boundaries = model.scene.boundaries
        self.plane_contact = self._per_plane([0.0 if b.kind == "symmetry" else CONTACT * model.dx for b in boundaries])
        self.plane_friction = self._per_plane([math.tan(math.radians(b.friction_angle)) for b in boundaries])
        """(P,) Coulomb friction coefficient μ = tan φ_b of each plane [-]."""
        self.replans = 0
        """Number of re-plans so far [-]."""

    def _per_plane(self, boundary_values: list) -> wp.array:
        """(P,) array of a value per boundary record's plane, 0 on the planes of loads."""
        m = self.model
        values = boundary_values + [0.0] * (m.plane_count - len(boundary_values))
        return wp.array(values or [0.0], dtype=m.spec.real, device=m.device)

    def keep_inside(self, q: wp.array, v: wp.array, stress, density, dt) -> None:
        """Owned real particles that reach a wall (or cross any fixed or slip plane) join it."""
        m = self.model
        launch(_keep_inside_kernel(m.spec), m.particle_count,
               [m.plane_count, self.plane_contact, m.plane_axis, self.plane_position, m.plane_sign, m.plane_kind, q,
                v, self.plane_friction, stress, density, m.spec.real(dt), m.spec.real(m.dx)], m.device)  # fmt: skip

    def _positions(self, state) -> list:
        return [state.particle_q, state.virtual_q][: len(self.sets)]

    def update(self, state) -> None:
        """Re-plan if a point of ``state`` has moved farther than the skin since the last plan; the
        first call only takes the reference."""
        positions = self._positions(state)
        if self.reference[0] is None:
            self._take_reference(positions)
            return
        self._largest.zero_()
        largest_move = _largest_move_kernel(self.model.spec)
        for layout, q, ref in zip(self.sets, positions, self.reference):
            launch(largest_move, layout.owned, [q, ref, self._largest], self.model.device)
        if float(self._largest.numpy()[0]) > self.skin:
            self.replan(state)

    def replan(self, state) -> None:
        """Regenerate the virtual points (if asked) and plan the ghosts of every set from ``state``'s
        positions and the current plane positions."""
        m = self.model
        if self.regenerator is not None:
            self.regenerator.regenerate(state, self.region_members)
        positions = self._positions(state)
        planes = list(zip(m.plane_axis.numpy(), self.plane_position.numpy().astype(float), m.plane_sign.numpy()))
        for layout, q in zip(self.sets, positions):
            _, src, chain = plan_ghosts(q.numpy()[: layout.owned], planes, self.band, self.tol)
            layout.assign(src, chain)
        self._take_reference(positions)
        self.replans += 1

    def _take_reference(self, positions: list[wp.array]) -> None:
        self.reference = [wp.clone(q[: layout.owned]) for layout, q in zip(self.sets, positions)]

    # -- checkpoints ------------------------------------------------------------------------------
    def arrays(self) -> dict[str, np.ndarray]:
        """The layout as host arrays (for checkpoints: a resumed run continues with the same ghosts)."""
        out = {}
        for layout, ref in zip(self.sets, self.reference):
            g = layout.ghost_count
            out[f"{layout.prefix}_ghost_source"] = layout.ghost_source.numpy()[:g]
            out[f"{layout.prefix}_ghost_planes"] = layout.ghost_planes.numpy()[:g]
            if ref is not None:
                out[f"{layout.prefix}_layout_reference"] = ref.numpy()
        return out

    def restore(self, arrays: dict[str, np.ndarray]) -> None:
        """Take a layout written by :meth:`arrays`."""
        for k, layout in enumerate(self.sets):
            layout.assign(arrays[f"{layout.prefix}_ghost_source"], arrays[f"{layout.prefix}_ghost_planes"])
            ref = arrays.get(f"{layout.prefix}_layout_reference")
            if ref is not None:
                self.reference[k] = wp.array(ref, dtype=self.model.spec.vec3, device=self.model.device)
