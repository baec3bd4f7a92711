"""One place where every stage launches its kernels, so that tests can see which ran."""

from __future__ import annotations

import contextlib

import warp as wp

_recorders: list[set] = []


def launch(kernel, dim: int, inputs: list, device) -> None:
    """``wp.launch`` that skips empty launches and tells active recorders the kernel's name."""
    if dim == 0:
        return
    for rec in _recorders:
        rec.add(kernel.key)
    wp.launch(kernel, dim=dim, inputs=inputs, device=device)


@contextlib.contextmanager
def record_launches():
    """Collect the keys of the kernels launched inside the ``with`` block into the yielded set."""
    names: set = set()
    _recorders.append(names)
    try:
        yield names
    finally:
        _recorders.remove(names)
