"""Defaults read from the environment (no Warp import, so the command line stays light).

``WARPSPH_DEVICE``: the Warp device runs use when none is named (``cpu``, ``cuda:0``); set it to run a
script, a study or the whole test suite on a GPU unchanged. ``WARPSPH_CPU_THREADS``: the threads CPU
row launches use (:mod:`warpsph.launching`). ``WARPSPH_VERBOSE=1``: keep Warp's start-up banner and its
per-module load messages, which runs silence otherwise.
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


def verbose() -> bool:
    """``WARPSPH_VERBOSE`` set to anything but empty or ``0``."""
    return os.environ.get("WARPSPH_VERBOSE", "0") not in ("", "0")


def init_warp():
    """Import and initialise Warp, quiet unless :func:`verbose`: its log level at warnings (no banner,
    no module load lines) and its native start-up warning (no CUDA driver on a CPU machine) kept off
    stderr, which is left for warpsph's own one-line errors. Idempotent; returns the ``warp`` module."""
    import warp as wp

    global _warp_ready
    if _warp_ready or verbose():
        wp.init()
        _warp_ready = True
        return wp
    wp.config.log_level = wp.LOG_WARNING
    saved = os.dup(2)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 2)
            wp.init()
    finally:
        os.dup2(saved, 2)
        os.close(saved)
    _warp_ready = True
    return wp


_warp_ready = False


def check_device(name: str) -> str:
    """``name`` if it is a device of this machine (``cpu``, ``cuda``, ``cuda:N``), else
    :class:`~warpsph.errors.DeviceError` saying which ones are."""
    from warpsph.errors import DeviceError

    wp = init_warp()
    here = [str(d) for d in wp.get_devices()]
    known = name == "cpu" or name == "cuda" or (name.startswith("cuda:") and name[5:].isdigit())
    if not known:
        raise DeviceError(f"--device {name}: not a Warp device name; accepted: cpu, cuda, cuda:N (here: "
                          f"{', '.join(here)})")  # fmt: skip
    if name != "cpu" and not wp.is_cuda_available():
        raise DeviceError(f"--device {name}: no CUDA device is available (here: {', '.join(here)})")
    if name.startswith("cuda:") and name not in here:
        raise DeviceError(f"--device {name}: no such device (here: {', '.join(here)})")
    return name
