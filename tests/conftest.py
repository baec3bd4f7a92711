"""Shared fixtures: Warp quiet, a CPU device always and CUDA where present, the shipped scenes."""

from pathlib import Path

import pytest
import warp as wp

wp.config.log_level = wp.LOG_WARNING

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
