"""Long runs (issue 6, item 5): the saturated column at rest for 1e5 steps without drift (slow).

``test_pore_water.resting_column`` (10 m, Δx = 0.2 m, geostatic and hydrostatic start, drained top,
two-set scheme) for 100 000 steps, ten times ``test_saturated_column_stays_at_rest``: the largest
speed over the run and the pore-pressure and effective-stress errors at the end stay at round-off
(bounds 1e-10 m/s and 1e-9 of ρ_w g H and (ρ − ρ_w) g H; 10 000 steps measure 6e-16, 6e-16, 3e-18).
"""

import pytest
from test_pore_water import rest_errors


@pytest.mark.slow
def test_saturated_column_at_rest_for_1e5_steps():
    vmax, pressure, stress = rest_errors(100_000)
    print(f"\n100 000 steps at rest: max speed {vmax:.2e} m/s, pore pressure error {pressure:.2e} of ρ_w g H, "
          f"effective stress error {stress:.2e}")
    assert vmax < 1e-10
    assert pressure < 1e-9
    assert stress < 1e-9
