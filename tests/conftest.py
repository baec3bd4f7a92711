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
