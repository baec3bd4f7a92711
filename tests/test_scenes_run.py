"""Every shipped scene validates and runs a few steps through the full run loop and output."""

import numpy as np
import pytest

from warpsph.io import load_results
from warpsph.runner import CHECK_EVERY, Run
from warpsph.scene_toml import load_scene
from conftest import SCENES

SHIPPED = sorted(SCENES.glob("*.toml"))


@pytest.mark.parametrize("path", SHIPPED, ids=[p.stem for p in SHIPPED])
def test_shipped_scene_runs(path, tmp_path, device):
    scene = load_scene(path)
    run = Run(scene, tmp_path, device=device, end_time=3.5 * scene.time_step)
    summary = run.run()
    # a staged scene's first steps are an equilibrium phase's, which stops at its next check, after the
    # iterations of a steady flow phase before it (timeless, so --end-time does not stop it)
    expected = CHECK_EVERY if any(p.kind in ("equilibrium", "safety") for p in scene.phases) else 4
    expected += sum(p["steps"] for p in summary.phases if p["kind"] == "flow")
    if any(p.kind == "consolidation" for p in scene.phases):
        # one implicit step past the end time, its equilibria as many explicit steps as they take
        assert summary.final_time >= 3.5 * scene.time_step and summary.steps > 4
        expected = summary.steps
    assert summary.steps == expected
    results = load_results(tmp_path / "results.h5")
    assert results.steps[0] == 0 and results.steps[-1] == expected
    frame = results.frame(len(results) - 1)
    assert frame["position"].shape == (run.model.particle_count, 3)
    assert np.isfinite(frame["position"]).all()
    for probe in scene.probes:
        t, v = results.series(probe.name)
        assert len(t) >= 2 and np.isfinite(v).all()
    assert (tmp_path / "results.xdmf").exists() and (tmp_path / "run.json").exists()
    assert (tmp_path / "particles.usdc").exists() == scene.output.usd
