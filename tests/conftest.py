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
    stands = {factor for factor, converged, *_ in first["trials"] if converged}
    fails = {factor for factor, converged, *_ in second["trials"] if not converged}
    assert stands & fails
    return warpsph.load_results(out / "results.h5"), first["criterion"], second["criterion"]
