"""The shipped dyke in a flood (scenes/dyke_rising_water.toml), through its phases up to the factor
of safety at the flood's peak: the flood's water seeps under and into the dyke, raising the pore
pressure beneath the landward slope, and the factor of safety falls (docs/scenes.md, *Groundwater
flow*)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import warpsph

SCENE = Path(__file__).resolve().parent.parent / "scenes" / "dyke_rising_water.toml"


@pytest.mark.slow
def test_a_flood_lowers_the_dykes_factor_of_safety(tmp_path):
    scene = warpsph.load_scene(SCENE)
    summary = warpsph.run_scene(scene.validate(), tmp_path, device="cpu")
    phases = {p["name"]: p for p in summary.phases}
    low, high = phases["low_water_safety"], phases["flood_safety"]
    assert low["outcome"] == high["outcome"] == "converged"
    print(f"\nfactor of safety at low water {low['criterion']:.3f}, at the flood's peak {high['criterion']:.3f}")
    assert high["criterion"] < low["criterion"]
    # one trial factor stands at low water and fails at the flood's peak
    stands = {factor for factor, converged, *_ in low["trials"] if converged}
    fails = {factor for factor, converged, *_ in high["trials"] if not converged}
    assert stands & fails
    results = warpsph.load_results(tmp_path / "results.h5")
    _t, p = results.series("pore_pressure_under_landward_slope")
    assert p[-1] > p[0] + 5e3  # the seepage raised it by more than half a metre of water
    flows = {name: results.series(name)[1] for name in results.series_names if name.startswith("discharge_")}
    stored = results.series("storage_rate")[1]
    out = sum(flows.values())
    np.testing.assert_allclose(-out[-1], stored[-1], rtol=1e-5, atol=1e-9 * abs(flows["discharge_river"][-1]))
