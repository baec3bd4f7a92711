"""Shared fixtures: Warp quiet, a CPU device always and CUDA where present, the shipped scenes.

Under ``pytest -n N`` the N workers share the CPUs: each one's row launches use its share of them
(``WARPSPH_CPU_THREADS``, unless it is set already)."""

import os
from pathlib import Path

import pytest
import warp as wp

from warpsph.environment import default_cpu_threads

wp.config.log_level = wp.LOG_WARNING

_workers = int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1"))
if _workers > 1 and "WARPSPH_CPU_THREADS" not in os.environ:
    os.environ["WARPSPH_CPU_THREADS"] = str(max(1, default_cpu_threads() // _workers))

SCENES = Path(__file__).resolve().parent.parent / "scenes"


def _devices():
    devices = ["cpu"]
    if wp.is_cuda_available():
        devices.append("cuda:0")
    return devices


@pytest.fixture(params=_devices())
def device(request):
    """Every device this machine has: the CPU, and the first GPU where CUDA is available."""
    return request.param


@pytest.fixture
def scenes_dir() -> Path:
    return SCENES


def factor_of_safety_falls(scene_path: Path, out: Path, before: str, after: str):
    """Run the staged scene at ``scene_path`` into ``out``; check that both safety phases ``before``
    and ``after`` bracket a factor of safety, that the second is lower, and that one trial factor
    stands in the first and fails in the second. Returns the run's results."""
    import warpsph

    summary = warpsph.run_scene(warpsph.load_scene(scene_path), out, device="cpu")
    phases = {p["name"]: p for p in summary.phases}
    first, second = phases[before], phases[after]
    assert first["outcome"] == second["outcome"] == "converged"
    print(f"\nfactor of safety in {before} {first['criterion']:.3f}, in {after} {second['criterion']:.3f}")
    assert second["criterion"] < first["criterion"]
    stands = {factor for factor, outcome, *_ in first["trials"] if outcome == 1}
    fails = {factor for factor, outcome, *_ in second["trials"] if outcome == 0}
    assert stands & fails
    return warpsph.load_results(out / "results.h5"), first["criterion"], second["criterion"]


def factor_search(out: Path, tolerance: float):
    """Check the safety phase that ends the run in ``out``: it converged, its factor of safety lies between
    the strongest trial that stood and the weakest that failed, that bracket is at most 2 ``tolerance``
    wide, and every trial's last state is a frame. Returns the factor of safety, the trials and each
    trial's ``{factor: (start positions (N,3) [m], |displacement| (N,) [m])}`` in its last frame."""
    import numpy as np

    import warpsph

    results = warpsph.load_results(out / "results.h5")
    phase = results.phases[-1]
    trials, fos = phase["trials"], phase["criterion"]
    stood, failed = trials[trials[:, 1] == 1, 0], trials[trials[:, 1] == 0, 0]
    print(f"\nfactor of safety {fos:.4f} ± {tolerance}; trials (factor, outcome, ratio, steps, moved, energy, "
          f"why):\n{trials}")
    assert phase["outcome"] == "converged"
    assert stood.max() < fos < failed.min() and failed.min() - stood.max() <= 2 * tolerance + 1e-12
    factors = [results.frame_attrs(k).get("factor") for k in range(len(results.times))]
    frames = {f: k for k, f in enumerate(factors) if f is not None}
    assert set(frames) == set(trials[:, 0])
    mechanism = {}
    for factor, k in frames.items():
        frame = results.frame(k)
        mechanism[factor] = (frame["position"] - frame["displacement"], np.linalg.norm(frame["displacement"], axis=1))
    return fos, trials, mechanism
