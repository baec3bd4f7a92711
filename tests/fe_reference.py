"""Plane-strain linear-elastic finite-element reference (scikit-fem, P2 triangles) for a 2D body under gravity.

The polygon is meshed here (Delaunay triangulation of boundary and lattice points), its base is fixed, its vertical
sides are on rollers and the rest is traction free; the stress is projected onto continuous P1 and read at given
points. An independent check of the SPH stress fields, used only by the tests.
"""

from collections.abc import Callable, Sequence

import numpy as np
from scipy.spatial import Delaunay
from skfem import (Basis, ElementTriP1, ElementTriP2, ElementVector, FacetBasis, LinearForm, MeshTri, asm, condense,
                   solve)
from skfem.helpers import sym_grad
from skfem.models.elasticity import lame_parameters, linear_elasticity, linear_stress


def _signed_area(poly: np.ndarray) -> float:
    x, y = poly.T
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def _inside(poly: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Even-odd ray casting: which of ``pts`` lie inside ``poly``."""
    a, b = poly, np.roll(poly, -1, axis=0)
    x, y = pts[:, 0, None], pts[:, 1, None]
    crosses = (a[:, 1] > y) != (b[:, 1] > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        x_cross = a[:, 0] + (y - a[:, 1]) * (b[:, 0] - a[:, 0]) / (b[:, 1] - a[:, 1])
    return np.count_nonzero(crosses & (x < x_cross), axis=1) % 2 == 1


def _boundary_distance(poly: np.ndarray, pts: np.ndarray) -> np.ndarray:
    a, b = poly, np.roll(poly, -1, axis=0)
    ab = b - a
    ap = pts[:, None, :] - a
    t = np.clip(np.sum(ap * ab, axis=2) / np.sum(ab * ab, axis=1), 0.0, 1.0)
    return np.min(np.linalg.norm(ap - t[..., None] * ab, axis=2), axis=1)


def polygon_mesh(vertices: Sequence[Sequence[float]], element_size: float) -> MeshTri:
    """Triangles of size about ``element_size`` filling the polygon exactly.

    Every boundary edge is split into segments no longer than ``element_size``; interior points of an equilateral
    lattice are kept only farther than ``0.55 * element_size`` from the boundary, so that no point lies in the
    diametral circle of a boundary segment and the Delaunay triangulation contains every segment (for polygons whose
    angles are not acute, as here). Triangles whose centroid lies outside the polygon are then dropped.
    """
    poly = np.asarray(vertices, dtype=float)
    h = float(element_size)
    boundary = []
    for a, b in zip(poly, np.roll(poly, -1, axis=0)):
        n = max(1, int(np.ceil(np.linalg.norm(b - a) / h - 1e-9)))
        boundary.append(a + (b - a) * (np.arange(n) / n)[:, None])
    (x0, y0), (x1, y1) = poly.min(axis=0), poly.max(axis=0)
    rows = np.arange(y0, y1 + h, h * np.sqrt(3.0) / 2.0)
    lattice = np.array([(x, y) for i, y in enumerate(rows) for x in np.arange(x0 + 0.5 * h * (i % 2), x1 + h, h)])
    keep = _inside(poly, lattice) & (_boundary_distance(poly, lattice) > 0.55 * h)
    p = np.vstack(boundary + [lattice[keep]])
    t = Delaunay(p).simplices
    t = t[_inside(poly, p[t].mean(axis=1))]
    d1, d2 = p[t[:, 1]] - p[t[:, 0]], p[t[:, 2]] - p[t[:, 0]]
    area = 0.5 * (d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0])
    t[area < 0] = t[area < 0][:, [0, 2, 1]]
    if np.min(np.abs(area)) < 1e-6 * h * h or not np.isclose(np.abs(area).sum(), abs(_signed_area(poly)), rtol=1e-9):
        raise ValueError("the Delaunay triangulation does not fill the polygon (acute corners?)")
    return MeshTri(np.ascontiguousarray(p.T), np.ascontiguousarray(t.T))


def elastic_gravity_state(
    vertices: Sequence[Sequence[float]],
    *,
    youngs_modulus: float,
    poisson_ratio: float,
    density: float,
    gravity: float = 9.81,
    element_size: float,
    points: np.ndarray,
) -> dict[str, np.ndarray | float]:
    """Elastic state of the polygon ``vertices`` under its own weight, in plane strain.

    The base (y = min y) is fixed, the sides x = min x and x = max x are on rollers, the other edges are free.
    Returns ``stress``: (M, 3) σ_xx, σ_yy, σ_xy in Pa at ``points`` (M, 2), tension positive; ``base_reaction_y``:
    the upward force of the base on the body in N/m; ``weight``: density * gravity * area in N/m.
    """
    poly = np.asarray(vertices, dtype=float)
    (x0, y0), (x1, _) = poly.min(axis=0), poly.max(axis=0)
    mesh = polygon_mesh(poly, element_size)
    basis = Basis(mesh, ElementVector(ElementTriP2()))
    lam, mu = lame_parameters(youngs_modulus, poisson_ratio)  # 3D Lamé constants: plane strain
    stiffness = asm(linear_elasticity(lam, mu), basis)
    load = asm(LinearForm(lambda v, w: -density * gravity * v[1]), basis)

    base = basis.get_dofs(lambda x: np.isclose(x[1], y0))
    sides = basis.get_dofs(lambda x: np.isclose(x[0], x0) | np.isclose(x[0], x1))
    fixed = np.union1d(base.all(), sides.all("u^1"))
    u = solve(*condense(stiffness, load, D=fixed))
    reaction = stiffness @ u - load

    sigma = linear_stress(lam, mu)(sym_grad(basis.interpolate(u)))
    scalar = basis.with_element(ElementTriP1())
    probes = scalar.probes(np.asarray(points, dtype=float).reshape(-1, 2).T)
    stress = np.column_stack([probes @ scalar.project(sigma[i, j]) for i, j in ((0, 0), (1, 1), (0, 1))])
    return {
        "stress": stress,
        "base_reaction_y": float(reaction[base.all("u^2")].sum()),
        "weight": density * gravity * abs(_signed_area(poly)),
    }


def elastic_excavation_displacement(
    vertices: Sequence[Sequence[float]],
    *,
    youngs_modulus: float,
    poisson_ratio: float,
    initial_stress: Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray, np.ndarray]],
    excavated: Callable[[np.ndarray, np.ndarray], np.ndarray],
    element_size: float,
    points: np.ndarray,
) -> np.ndarray:
    """Displacement (M, 2) [m] at ``points`` (M, 2) caused by excavating a linear-elastic body in plane strain.

    ``vertices`` is the polygon left after the excavation, in equilibrium with gravity before it under the
    ``initial_stress(x, y)`` → (σ_xx, σ_yy, σ_xy) [Pa], tension positive. Excavating frees the boundary facets where
    ``excavated(x, y)`` holds: the displacement is that of the body loaded there by the traction −σ₀n it loses,
    without body force (the initial state balances gravity). Base fixed and vertical sides on rollers, as above.
    """
    poly = np.asarray(vertices, dtype=float)
    (x0, y0), (x1, _) = poly.min(axis=0), poly.max(axis=0)
    mesh = polygon_mesh(poly, element_size)
    element = ElementVector(ElementTriP2())
    basis = Basis(mesh, element)
    lam, mu = lame_parameters(youngs_modulus, poisson_ratio)
    stiffness = asm(linear_elasticity(lam, mu), basis)
    facets = mesh.facets_satisfying(lambda x: excavated(x[0], x[1]), boundaries_only=True)
    surface = FacetBasis(mesh, element, facets=facets)

    @LinearForm
    def released(v, w):
        sxx, syy, sxy = initial_stress(w.x[0], w.x[1])
        n = w.n
        return -((sxx * n[0] + sxy * n[1]) * v[0] + (sxy * n[0] + syy * n[1]) * v[1])

    load = asm(released, surface)
    base = basis.get_dofs(lambda x: np.isclose(x[1], y0))
    sides = basis.get_dofs(lambda x: np.isclose(x[0], x0) | np.isclose(x[0], x1))
    u = solve(*condense(stiffness, load, D=np.union1d(base.all(), sides.all("u^1"))))
    at = np.asarray(points, dtype=float).reshape(-1, 2).T
    return np.column_stack([part.probes(at) @ u[dofs] for part, dofs in zip(basis.split_bases(),
                                                                          basis.split_indices())])  # fmt: skip
