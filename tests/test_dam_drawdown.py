"""The shipped earth dam under a rapid drawdown (scenes/dam_rapid_drawdown.toml): the reservoir falls
faster than the dam drains, the upstream slope keeps its pore water without the reservoir's pressure,
and its factor of safety falls below the full reservoir's (docs/scenes.md, *Groundwater flow*)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import factor_of_safety_falls

SCENE = Path(__file__).resolve().parent.parent / "scenes" / "dam_rapid_drawdown.toml"
CREST_MIDDLE = 16.5  # m


@pytest.mark.slow
def test_a_rapid_drawdown_lowers_the_upstream_slopes_factor_of_safety(tmp_path):
    results, full, drawn = factor_of_safety_falls(SCENE, tmp_path, "full_safety", "drawdown_safety")
    assert drawn < full - 0.2
    index = {name: i for i, name in enumerate(p["name"] for p in results.phases)}
    bishop = results.phases[index["drawdown_safety"]]["limit_equilibrium"][0]
    # measured 1.094 against 1.167, the circle upstream too; the trial at 1.125 fails by the upstream wedge
    # creeping along the rock, and with psi = 0 the factor reads low by 6 % (1.219 with psi = phi; docs/scenes.md,
    # *Limit equilibrium*)
    assert drawn == pytest.approx(bishop, rel=0.07)
    first_failed = next(i for i in range(len(results.times)) if results.frame_phases[i] == index["drawdown_safety"]
                        and results.frame_attrs(i).get("outcome") == 0)  # fmt: skip
    frame = results.frame(first_failed)
    moved = np.linalg.norm(frame["displacement"], axis=1)
    sliding = moved > 0.5 * moved.max()
    assert np.mean(frame["position"][sliding, 0] < CREST_MIDDLE) > 0.9  # the upstream slope fails
    _t, p = results.series("pore_pressure_in_upstream_slope")
    assert p[-1] > 0.4 * p.max()  # the slope kept its water: far above the lowered reservoir's 0 there
