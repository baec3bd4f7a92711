"""A run stopped and continued with --resume is bit-identical on the CPU to an uninterrupted run."""

import numpy as np

from warpsph.io import load_results
from warpsph.runner import Run
from warpsph.scene_toml import load_scene


def test_resume_is_bit_identical(scenes_dir, tmp_path):
    scene = load_scene(scenes_dir / "cantilever.toml")  # gravity, a fixed wall, free surfaces
    scene.output.usd = False
    dt = scene.time_step
    t_stop, t_end = 20.5 * dt, 41.5 * dt
    scene.output.frame_interval = 10 * dt

    whole = Run(scene, tmp_path / "whole", end_time=t_end)
    whole.run()
    first = Run(scene, tmp_path / "split", end_time=t_stop)
    first.run()
    second = Run(scene, tmp_path / "split", end_time=t_end, resume=True)
    assert second.step_index == 21
    second.run()

    for name, arr in whole.state.arrays().items():
        a, b = arr.numpy(), second.state.arrays()[name].numpy()
        assert np.array_equal(a, b), f"state array {name} differs after resume"
    a, b = load_results(tmp_path / "whole" / "results.h5"), load_results(tmp_path / "split" / "results.h5")
    assert a.steps[-1] == b.steps[-1] == 42
    for key, value in a.frame(len(a) - 1).items():
        assert np.array_equal(value, b.frame(len(b) - 1)[key]), key
    for name in a.series_names:
        ta, va = a.series(name)
        tb, vb = b.series(name)
        assert np.array_equal(ta, tb) and np.array_equal(va, vb), name
