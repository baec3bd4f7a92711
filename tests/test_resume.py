"""A run stopped and continued with --resume is bit-identical on the CPU to an uninterrupted run."""

import numpy as np

from warpsph.io import load_results
from warpsph.runner import Run
from warpsph.scene_toml import load_scene


def whole_and_resumed(scene, tmp_path, stop_step: int, end_step: int):
    """Runs of ``scene`` to ``end_step`` in one go and stopped after ``stop_step`` then resumed:
    (whole, first part, resumed part); asserts their final states are bit-identical."""
    scene.output.usd = False
    dt = scene.time_step
    whole = Run(scene, tmp_path / "whole", end_time=(end_step + 0.5) * dt)
    whole.run()
    first = Run(scene, tmp_path / "split", end_time=(stop_step + 0.5) * dt)
    first.run()
    second = Run(scene, tmp_path / "split", end_time=(end_step + 0.5) * dt, resume=True)
    assert second.step_index == stop_step + 1
    second.run()
    for name, arr in whole.state.arrays().items():
        a, b = arr.numpy(), second.state.arrays()[name].numpy()
        assert np.array_equal(a, b), f"state array {name} differs after resume"
    return whole, first, second


def test_resume_is_bit_identical(scenes_dir, tmp_path):
    scene = load_scene(scenes_dir / "cantilever.toml")  # gravity, a fixed wall, free surfaces
    scene.output.frame_interval = 10 * scene.time_step
    whole_and_resumed(scene, tmp_path, 20, 41)
    a, b = load_results(tmp_path / "whole" / "results.h5"), load_results(tmp_path / "split" / "results.h5")
    assert a.steps[-1] == b.steps[-1] == 42
    for key, value in a.frame(len(a) - 1).items():
        assert np.array_equal(value, b.frame(len(b) - 1)[key]), key
    for name in a.series_names:
        ta, va = a.series(name)
        tb, vb = b.series(name)
        assert np.array_equal(ta, tb) and np.array_equal(va, vb), name
