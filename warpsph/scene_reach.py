"""Checks that need the particles: a scene whose loads, extents, rigid regions or probes reach no
particle, whose bodies lie beyond their planes, or whose bodies overlap, would run and do nothing
(or something else); :func:`check_reach` refuses it with one line naming the key path
(docs/scenes.md, *Errors*)."""

from __future__ import annotations

import numpy as np

from warpsph.errors import SceneError
from warpsph.lattice import code_step, lattice_codes, used_axes
from warpsph.scene import AXES, EXTENT_TOLERANCE, Scene

POINT_PROBE_REACH = 2.0
"""A point probe follows the particle nearest its point; that particle must lie within this many
Δx of it."""


def check_reach(scene: Scene, planes, on_plane: np.ndarray, points: np.ndarray, owner: np.ndarray,
                body_points: list[np.ndarray], staged: bool = False) -> list[str]:  # fmt: skip
    """``planes`` as ``builder._planes``, ``on_plane`` (N,3) the planes each particle lies on (−1 for
    none), ``points`` (N,3) the particles and ``owner`` their body; ``body_points`` every body's own
    lattice points, before bodies filled earlier took theirs. ``staged``: ``scene`` is a phase's, whose
    point and region probes sample in the phases whose particles they reach (:func:`check_probes_reach`
    checks each reaches some phase's): the names of those that reach none of these particles are
    returned, not refused."""
    dx = scene.simulation.dx
    _check_bodies_inside_planes(scene, planes, points, owner)
    _check_overlaps(scene, body_points, dx)
    for p_idx, plane in enumerate(planes):
        name, axis, position, extent = plane[0], plane[1], plane[2], plane[6]
        if not any(ld.name == name for ld in scene.loads):
            continue
        on = points[np.any(on_plane == p_idx, axis=1)]
        if not len(on):
            raise SceneError(f"loads.{name}.position", f"no particle lies on this traction face ({AXES[axis]} = "
                             f"{position:g}); put it on a face of a body, on the lattice of spacing dx")  # fmt: skip
        if extent is not None and not np.any(extent.contains_on_face(on, axis, EXTENT_TOLERANCE * dx)):
            raise SceneError(f"loads.{name}.extent", f"reaches none of the {len(on)} particles on the face "
                             f"{AXES[axis]} = {position:g}")  # fmt: skip
    for ld in scene.loads:
        if ld.region is not None and ld.kind in ("velocity", "force") and not np.any(ld.region.contains(points)):
            raise SceneError(f"loads.{ld.name}.region", "contains no particle: the rigid region moves nothing")
    plane_names = [plane[0] for plane in planes]
    unreached = []
    for probe in scene.probes:
        problem = probe_problem(probe, points, dx)
        if problem is not None and staged:
            unreached.append(probe.name)
        elif problem is not None:
            raise SceneError(*problem[:2])
        elif probe.kind == "reaction" and probe.boundary in plane_names:
            if not np.any(on_plane == plane_names.index(probe.boundary)):
                raise SceneError(f"probes.{probe.name}.boundary", f"no particle lies on plane {probe.boundary!r}")
    return unreached


def probe_problem(probe, points: np.ndarray, dx: float, where: str = "") -> tuple[str, str, float] | None:
    """(key, message, distance [m] to the nearest particle, inf for a region) of a point or region ``probe``
    that reaches none of the particles at ``points`` (N,3) [m] (``where``: of which particles, for the
    message), else None."""
    key = f"probes.{probe.name}"
    if probe.kind == "point":
        distance = np.sqrt(np.min(np.sum((points - np.asarray(probe.point, float)) ** 2, axis=1)))
        if distance > POINT_PROBE_REACH * dx:
            return (f"{key}.point", f"the nearest particle{where} is {distance:.4g} m away; a point probe follows "
                    f"the particle nearest its point, which must lie within {POINT_PROBE_REACH:g} dx",
                    distance)  # fmt: skip
    elif probe.region is not None and not np.any(probe.region.contains(points, 1e-6 * dx)):
        return f"{key}.region", f"contains no particle{where}", np.inf
    return None


def check_probes_reach(scene: Scene, phase_points: list[np.ndarray]) -> None:
    """Refuse a point or region probe of a staged ``scene`` that reaches no particle in any phase
    (``phase_points``: each phase's particles), naming it as in the phase it comes nearest in."""
    dx = scene.simulation.dx
    for probe in scene.probes:
        problems = [probe_problem(probe, points, dx, " in any phase") for points in phase_points if len(points)]
        if problems and all(problems):
            raise SceneError(*min(problems, key=lambda p: p[2])[:2])


def _check_bodies_inside_planes(scene: Scene, planes, points: np.ndarray, owner: np.ndarray) -> None:
    """Every particle inside every plane's half-space (a plane bounds the domain on its ``side``)."""
    tol = 1e-6 * scene.simulation.dx
    for name, axis, position, sign, *_ in planes:
        beyond = (points[:, axis] - position) * sign > tol
        if np.any(beyond):
            body = scene.bodies[int(owner[np.argmax(beyond)])].name
            inside, plane = ("<=" if sign > 0 else ">="), f"{plane_section(scene, name)}.{name}"
            raise SceneError(f"bodies.{body}", f"{int(np.sum(beyond))} particles lie beyond {plane} (the "
                             f"domain is {AXES[axis]} {inside} {position:g} on its side {'max' if sign > 0 else 'min'}"
                             "); move the body or the plane, or check the plane's side")  # fmt: skip


def plane_section(scene: Scene, name: str) -> str:
    """The scene section a plane comes from: "boundaries", or "loads" for a traction load's face."""
    return "boundaries" if any(b.name == name for b in scene.boundaries) else "loads"


def _check_overlaps(scene: Scene, body_points: list[np.ndarray], dx: float) -> None:
    """Bodies may share a face (a lattice row, which goes to the body listed first), not a volume,
    unless the earlier one is ``embedded``: a point both hold whose lattice neighbours along every used
    axis both hold too is an overlap."""
    axes = used_axes(scene.simulation.dim)
    codes = [lattice_codes(pts, dx) for pts in body_points]
    for j in range(len(codes)):
        for i in range(j):
            if scene.bodies[i].embedded:
                continue
            shared = np.intersect1d(codes[i], codes[j])
            if not len(shared):
                continue
            interior = np.ones(len(shared), bool)
            for axis in axes:
                for sign in (-1, 1):
                    interior &= np.isin(shared + sign * code_step(axis), shared)
            if np.any(interior):
                raise SceneError(f"bodies.{scene.bodies[j].name}", f"overlaps bodies.{scene.bodies[i].name} "
                                 f"({int(np.sum(interior))} lattice points inside both); bodies may share a "
                                 "face, not a volume, unless the one inside is listed first with embedded = true")
