"""One place where every stage launches its kernels, so that tests can see which ran.

``launch`` runs a kernel once. ``launch_rows`` runs a *row kernel* — one whose first parameter is
``first: int`` and whose thread ``wp.tid()`` handles row ``first + wp.tid()``, writing only that
row's outputs (a gather) — and on the CPU splits the rows into one contiguous chunk per thread,
launched concurrently: Warp runs each CPU launch on one thread and releases the GIL while it runs,
so the chunks run in parallel. Every row is computed by the same code whichever chunk holds it, so
results are bit-identical for any thread count. On a GPU it is one launch.
"""

from __future__ import annotations

import contextlib
from concurrent.futures import ThreadPoolExecutor

import warp as wp

from warpsph.environment import default_cpu_threads

_recorders: list[set] = []

MIN_ROWS_PER_THREAD = 1024
"""Rows below which another CPU thread is not worth its hand-off (≈ 20–50 µs) [-]."""


_threads = default_cpu_threads()
_pool: ThreadPoolExecutor | None = None
_loaded: set = set()
"""(kernel, device) pairs launched before: their modules are loaded, so threads may share them."""


def cpu_threads() -> int:
    """Threads ``launch_rows`` uses on the CPU."""
    return _threads


def set_cpu_threads(n: int) -> None:
    """Use ``n`` ≥ 1 threads for CPU row launches (1: every launch on the calling thread)."""
    global _threads, _pool
    if n < 1:
        raise ValueError(f"CPU threads must be >= 1, got {n}")
    if _pool is not None and n != _threads:
        _pool.shutdown()
        _pool = None
    _threads = n


def _record(kernel) -> None:
    for rec in _recorders:
        rec.add(kernel.key)


def launch(kernel, dim: int, inputs: list, device) -> None:
    """``wp.launch`` that skips empty launches and tells active recorders the kernel's name."""
    if dim == 0:
        return
    _record(kernel)
    wp.launch(kernel, dim=dim, inputs=inputs, device=device)


def launch_rows(kernel, rows: int, inputs: list, device, rows_per_item: int = 1,
                min_rows_per_thread: int | None = None, start: int = 0) -> None:  # fmt: skip
    """Launch row kernel ``kernel`` over rows [``start``, ``start`` + ``rows``) (``inputs`` without
    ``first``); on the CPU in ``cpu_threads()`` concurrent chunks of at least ``min_rows_per_thread``
    rows (default MIN_ROWS_PER_THREAD; cheap rows need more to pay for a thread). A kernel whose thread
    handles a block of ``rows_per_item`` matrix rows (a blocked reduction) counts its items as that
    many rows when the chunk count is chosen."""
    global _pool
    if rows == 0:
        return
    _record(kernel)
    chunks = 1
    if wp.get_device(device).is_cpu and (kernel, str(device)) in _loaded:
        chunks = max(1, min(_threads, rows * rows_per_item // (min_rows_per_thread or MIN_ROWS_PER_THREAD)))
    _loaded.add((kernel, str(device)))  # the first launch loads (or compiles) the module: one thread
    if chunks == 1:
        wp.launch(kernel, dim=rows, inputs=[start, *inputs], device=device)
        return
    if _pool is None:
        _pool = ThreadPoolExecutor(max_workers=_threads - 1, thread_name_prefix="warpsph-launch")
    bounds = [start + rows * k // chunks for k in range(chunks + 1)]
    futures = [_pool.submit(wp.launch, kernel, dim=bounds[k + 1] - bounds[k], inputs=[bounds[k], *inputs],
                            device=device) for k in range(1, chunks)]  # fmt: skip
    wp.launch(kernel, dim=bounds[1] - start, inputs=[start, *inputs], device=device)
    for f in futures:
        f.result()


@contextlib.contextmanager
def record_launches():
    """Collect the keys of the kernels launched inside the ``with`` block into the yielded set."""
    names: set = set()
    _recorders.append(names)
    try:
        yield names
    finally:
        _recorders.remove(names)
