"""Defaults read from the environment (no Warp import, so the command line stays light).

``WARPSPH_DEVICE``: the Warp device runs use when none is named (``cpu``, ``cuda:0``); set it to run a
script, a study or the whole test suite on a GPU unchanged. ``WARPSPH_CPU_THREADS``: the threads CPU
row launches use (:mod:`warpsph.launching`).
"""

from __future__ import annotations

import os


def default_device() -> str:
    """``WARPSPH_DEVICE`` if set, else ``cpu``."""
    return os.environ.get("WARPSPH_DEVICE") or "cpu"


def default_cpu_threads() -> int:
    """``WARPSPH_CPU_THREADS`` if set, else the CPUs this process may run on."""
    env = os.environ.get("WARPSPH_CPU_THREADS")
    if env:
        return max(1, int(env))
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
