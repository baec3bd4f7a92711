"""The factor of safety of an undrained clay slope against Taylor's chart (a ``safety`` phase, docs/scenes.md,
*Phases*).

A 60° slope H = 2 m high in undrained clay (φ = 0, c_u = 12 kPa, ρ = 2000 kg/m³, dry, in total stress) on
1 m of the same clay over a rough firm base (depth factor D = 1.5), 2 m of level ground in front of the toe
and 4.85 m behind the crest, smooth sides. Taylor (1937, "Stability of earth slopes", J. Boston Soc. Civ.
Eng. 24, 197–246; the φ = 0 chart of his Fundamentals of Soil Mechanics, 1948): slopes steeper than 53°
fail on a toe circle whatever D, with the stability number N_s = c_u/(F γ H) = 0.191 at 60°, so
F = c_u/(0.191 γ H) = 1.601.

Measured (CPU, 2 cores): at Δx = 0.25 m (8 particles over H) the search brackets 1.547 ± 0.047 with trials
capped at 8000 steps (3.4 % below Taylor, about 70 s), 1.535 ± 0.012 to ± 0.02 with 12 000 steps (4.1 %
below), so the coarse case asks for 6 %; at Δx = 0.2 m (10 particles over H, trials of 15 000 steps)
1.576 ± 0.006 to ± 0.01 (1.6 % below, about 4 min) and 1.582 ± 0.012 to ± 0.02. Trials just below the
factor of safety creep towards rest for thousands of steps, so a shorter cap counts some of them as
failures (1.484 with 4000 steps at Δx = 0.25 m).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import warpsph
from conftest import factor_search

from warpsph.validation.safety import (BASE, CREST, CU, RHO, SLOPE, TAYLOR, TOE, H, strength_reduction_phases,
                                      undrained_clay)  # fmt: skip


def taylor_slope(tmp_path, dx: float, max_steps: int, tolerance: float) -> float:
    """Run the slope at ``dx`` with trials capped at ``max_steps`` and searched to ± ``tolerance``; check the
    mechanism of the failing trial nearest the factor of safety: its largest displacement lies on the slope's
    face and the ground more than 2H behind the crest moves less than a tenth of it. Returns the factor of
    safety."""
    summary = warpsph.run_scene(undrained_clay("taylor", SLOPE, dx, strength_reduction_phases(max_steps, tolerance),
                                               CU, RHO), tmp_path, device="cpu")  # fmt: skip
    assert summary.status == "finished"
    fos, trials, mechanism = factor_search(tmp_path, tolerance)
    start, moved = mechanism[trials[trials[:, 1] == 0, 0].min()]
    face = np.array([CREST - TOE, H]) / math.hypot(CREST - TOE, H)
    at = start[np.argmax(moved), :2] - (TOE, BASE)
    behind = start[:, 0] > CREST + 2 * H
    print(f"Taylor {TAYLOR:.4f}: {fos / TAYLOR - 1:+.2%}; failing trial's largest displacement {moved.max():.4f} m "
          f"at {at + (TOE, BASE)}, {moved[behind].max() / moved.max():.2f} of it 2H behind the crest")
    assert abs(at[0] * face[1] - at[1] * face[0]) <= 1.5 * dx and 0.0 <= at[1] <= H
    assert moved[behind].max() < 0.1 * moved.max()
    return fos


def test_undrained_slope_factor_of_safety_meets_taylors_chart(tmp_path):
    """8 particles over H, trials capped at 8000 steps, searched to ± 0.05: within 6 % of Taylor's 1.601."""
    fos = taylor_slope(tmp_path, 0.25, 8000, 0.05)
    assert fos == pytest.approx(TAYLOR, rel=0.06)


@pytest.mark.slow
def test_undrained_slope_factor_of_safety_meets_taylors_chart_refined(tmp_path):
    """10 particles over H, trials capped at 15 000 steps, searched to ± 0.01: within 3 % of Taylor's 1.601."""
    fos = taylor_slope(tmp_path, 0.2, 15000, 0.01)
    assert fos == pytest.approx(TAYLOR, rel=0.03)
