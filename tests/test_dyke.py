"""The shipped dyke in a flood (scenes/dyke_rising_water.toml), through its phases up to the factor
of safety at steady high water: the flood's water seeps under and into the dyke, raising the pore
pressure beneath the landward slope, and the factor of safety falls (docs/scenes.md, *Groundwater
flow*), with the numbers docs/tutorials/dyke_rising_river.md quotes."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import factor_of_safety_falls

TUTORIAL = Path(__file__).resolve().parent.parent / "docs" / "tutorials" / "dyke_rising_river.md"

SCENE = Path(__file__).resolve().parent.parent / "scenes" / "dyke_rising_water.toml"


@pytest.mark.slow
def test_a_flood_lowers_the_dykes_factor_of_safety(tmp_path):
    results, low, high = factor_of_safety_falls(SCENE, tmp_path, "low_water_safety", "high_water_safety")
    names = [phase["name"] for phase in results.phases]
    under_slope = []
    for name in ("low_water_seepage", "flood", "high_water_seepage"):
        last = max(i for i, k in enumerate(results.frame_phases) if k == names.index(name))
        frame = results.frame(last)
        i = np.argmin(np.sum((frame["position"][:, :2] - [17.0, 1.0]) ** 2, axis=1))
        under_slope.append(frame["pore_pressure"][i])
    print(f"pore pressure 1 m under the landward slope [kPa]: {np.round(np.array(under_slope) / 1e3, 2)}")
    assert under_slope[0] + 5e3 < under_slope[1] < under_slope[2]  # the seepage raises it, to steady
    flows = {name: results.series(name)[1] for name in results.series_names if name.startswith("discharge_")}
    stored = results.series("storage_rate")[1]
    out = sum(flows.values())
    np.testing.assert_allclose(-out[-1], stored[-1], rtol=1e-5, atol=1e-9 * abs(flows["discharge_river"][-1]))
    page = TUTORIAL.read_text()
    flood = next(phase for phase in results.phases if phase["name"] == "flood_safety")["criterion"]
    for factor in (low, flood, high):
        assert f"factor of safety {factor:.4g} ± " in page  # as `warpsph run` prints it
    assert (round(low, 2), round(flood, 2), round(high, 2)) == (1.75, 1.72, 1.61)
    for phase in results.phases:  # limit equilibrium beside each factor, measured within 3 % of it
        if phase["kind"] == "safety":
            assert 0.97 < phase["limit_equilibrium"][0] / phase["criterion"] < 1.03
    for name, p in zip(("low_water_seepage", "flood", "high_water_seepage"), under_slope):
        assert f"{name}: pore pressure under the landward slope {p / 1e3:.2f} kPa" in page
    assert f"river inflow at steady high water {-flows['discharge_river'][-1] * 86400:.2f} m³/day" in page
