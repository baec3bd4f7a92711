"""NeighbourList (hash grid + CSR) gives exactly the brute-force O(N²) neighbour sets |x_b − x_a| < 2h."""

import numpy as np
import pytest
import warp as wp

from warpsph.environment import default_device
from warpsph.sph.neighbours import NeighbourList
from warpsph.sph.spec import Spec

wp.config.quiet = True
DEVICE = default_device()  # WARPSPH_DEVICE, else the CPU
L = 1.0  # box edge [m]
RADIUS = 0.13  # support radius 2h [m]


def points(spec: Spec, n: int, lo: float, hi: float, rng) -> np.ndarray:
    """n uniform random points in [lo, hi]^dim on the used axes (1D: y; 2D: x-y), 0 elsewhere."""
    return rng.uniform(lo, hi, (n, 3)) * np.asarray(spec.axis_mask)


def brute_force(query: np.ndarray, source: np.ndarray, same_set: bool) -> tuple[list[np.ndarray], np.ndarray]:
    """Neighbour sets by |x_b − x_a|² < R², and a mask of pairs within 1e-5 R² of the boundary (only
    reached with float32 coordinates, where hash-grid and NumPy arithmetic may round differently)."""
    d2 = ((source[None, :, :] - query[:, None, :]) ** 2).sum(axis=-1)
    inside = d2 < RADIUS**2
    if same_set:
        np.fill_diagonal(inside, False)
    ambiguous = np.abs(d2 - RADIUS**2) < 1e-5 * RADIUS**2
    return [np.flatnonzero(row) for row in inside], ambiguous


def build(spec: Spec, query: np.ndarray, source: np.ndarray, same_set: bool, spare: int = 0) -> list[np.ndarray]:
    """Build with arrays ``spare`` entries longer than the live counts (filled with junk points)."""
    dtype = np.float64 if spec.precision == "float64" else np.float32
    junk = np.full((spare, 3), 0.5 * L)

    def device_array(x):
        return wp.array(np.vstack([x, junk]).astype(dtype), dtype=spec.vec3, device=DEVICE)

    q = device_array(query)
    s = q if same_set else device_array(source)
    nl = NeighbourList(spec, np.full(3, L), RADIUS, DEVICE, same_set=same_set)
    nl.build(q, len(query), s, len(source))
    assert nl.n_query == len(query)
    return nl.to_lists()


def assert_same_sets(got: list[np.ndarray], expected: list[np.ndarray], ambiguous: np.ndarray) -> None:
    assert len(got) == len(expected)
    for a, (g, e) in enumerate(zip(got, expected)):
        assert len(np.unique(g)) == len(g), f"query {a}: duplicate neighbours"
        diff = np.setxor1d(g, e)
        assert np.all(ambiguous[a, diff]), f"query {a}: differs from brute force at {diff[~ambiguous[a, diff]]}"


CASES = [(d, p) for d in (1, 2, 3) for p in ("float64", "float32")]


@pytest.mark.parametrize("dim,precision", CASES)
def test_query_against_other_set(dim, precision):
    """Distinct query and source sets (like virtual points against real particles), sources also
    outside the box by up to 2R (ghosts); arrays carry spare capacity beyond the live counts."""
    spec = Spec(precision=precision, dim=dim)
    rng = np.random.default_rng(10 + dim)
    n = {1: 200, 2: 600, 3: 1200}[dim]
    source = np.vstack([points(spec, n, 0.0, L, rng), points(spec, n // 3, -2 * RADIUS, L + 2 * RADIUS, rng)])
    query = points(spec, n // 2, 0.0, L, rng)
    if precision == "float32":
        source, query = source.astype(np.float32).astype(float), query.astype(np.float32).astype(float)
    expected, ambiguous = brute_force(query, source, same_set=False)
    got = build(spec, query, source, same_set=False, spare=7)
    assert_same_sets(got, expected, ambiguous)
    if precision == "float64":
        assert not ambiguous.any()  # the comparison above was exact
    assert sum(map(len, expected)) > 5 * len(query)  # the test is not vacuous


@pytest.mark.parametrize("dim,precision", CASES)
def test_same_set_excludes_self(dim, precision):
    """same_set=True: particles against themselves, self excluded, including ghosts beyond the box."""
    spec = Spec(precision=precision, dim=dim)
    rng = np.random.default_rng(20 + dim)
    n = {1: 200, 2: 600, 3: 1200}[dim]
    x = np.vstack([points(spec, n, 0.0, L, rng), points(spec, n // 4, -RADIUS, L + RADIUS, rng)])
    if precision == "float32":
        x = x.astype(np.float32).astype(float)
    expected, ambiguous = brute_force(x, x, same_set=True)
    got = build(spec, x, x, same_set=True)
    assert_same_sets(got, expected, ambiguous)
    assert all(a not in g for a, g in enumerate(got))


def test_rebuild_reuses_and_grows():
    """A second build with more points (buffers must grow) gives the new brute-force sets."""
    spec = Spec(dim=2)
    rng = np.random.default_rng(30)
    nl = NeighbourList(spec, np.full(3, L), RADIUS, DEVICE)
    for n in (50, 800, 100):
        source, query = points(spec, n, 0.0, L, rng), points(spec, n, 0.0, L, rng)
        q, s = (wp.array(x, dtype=spec.vec3, device=DEVICE) for x in (query, source))
        nl.build(q, n, s, n)
        expected, ambiguous = brute_force(query, source, same_set=False)
        assert_same_sets(nl.to_lists(), expected, ambiguous)


def test_empty_query_set():
    spec = Spec(dim=3)
    nl = NeighbourList(spec, np.full(3, L), RADIUS, DEVICE)
    x = wp.array(points(spec, 10, 0.0, L, np.random.default_rng(0)), dtype=spec.vec3, device=DEVICE)
    nl.build(x, 0, x, 10)
    assert nl.n_pairs == 0 and nl.to_lists() == []
