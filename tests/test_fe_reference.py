"""The finite-element reference (tests/fe_reference.py) against the exact confined column, and its convergence."""

import numpy as np
import pytest

pytest.importorskip("skfem")

from fe_reference import elastic_gravity_state  # noqa: E402

RHO, G, E, NU = 2000.0, 9.81, 1.0e7, 0.3
SLOPE = [(0, 0), (16, 0), (16, 6), (12, 6), (4, 2), (0, 2)]  # 2:1 slope, 4 m high, on a 2 m foundation


def test_confined_column_matches_exact_solution():
    height = 2.0
    x, y = np.meshgrid([0.3, 1.0, 2.0, 3.1, 3.7], [0.2, 0.7, 1.3, 1.8])
    points = np.column_stack([x.ravel(), y.ravel()])
    state = elastic_gravity_state([(0, 0), (4, 0), (4, height), (0, height)], youngs_modulus=E, poisson_ratio=NU,
                                  density=RHO, gravity=G, element_size=0.5, points=points)
    syy = -RHO * G * (height - points[:, 1])
    exact = np.column_stack([NU / (1 - NU) * syy, syy, np.zeros_like(syy)])
    assert np.max(np.abs(state["stress"] - exact)) < 0.01 * RHO * G * height
    assert state["base_reaction_y"] == pytest.approx(RHO * G * 4 * height, rel=1e-3)


def test_slope_equilibrium_and_convergence():
    points = np.array([(2.0, 1.0), (6.0, 1.5), (8.0, 2.5), (11.0, 4.0), (14.0, 3.0), (14.0, 5.0)])
    coarse, fine = (elastic_gravity_state(SLOPE, youngs_modulus=E, poisson_ratio=NU, density=RHO, gravity=G,
                                          element_size=h, points=points) for h in (0.5, 0.25))
    area = 16 * 2 + 8 * 4 / 2 + 4 * 4  # foundation, slope triangle, crest block
    for state in (coarse, fine):
        assert state["weight"] == pytest.approx(RHO * G * area, rel=1e-12)
        assert state["base_reaction_y"] == pytest.approx(state["weight"], rel=1e-3)
    scale = RHO * G * 6.0
    assert np.max(np.abs(fine["stress"][:, 1] - coarse["stress"][:, 1])) < 0.02 * scale
    # far behind the crest the column is nearly laterally confined: sigma_yy close to the overburden
    assert fine["stress"][4:, 1] == pytest.approx(-RHO * G * (6.0 - points[4:, 1]), abs=0.02 * scale)
