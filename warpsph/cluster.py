"""Dask clients for work that runs at once on several processes or machines: a study's cases, a safety
phase's trials (docs/dask.md)."""

from __future__ import annotations

import os
from contextlib import contextmanager


@contextmanager
def dask_client(scheduler: str | None, workers: int | None):
    """A client of the scheduler at ``scheduler``, or of a LocalCluster of ``workers`` processes
    (default: one per core), one Dask thread each, whose row launches share the cores evenly
    (``WARPSPH_CPU_THREADS`` = cores // workers, so concurrent runs do not oversubscribe the CPU)."""
    from dask.distributed import Client, LocalCluster

    if scheduler:
        with Client(scheduler) as client:
            yield client
        return
    n_workers = workers or os.cpu_count() or 1
    env = {"WARPSPH_CPU_THREADS": str(max(1, (os.cpu_count() or 1) // n_workers))}
    with LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=True, env=env,
                      dashboard_address=":0") as cluster, Client(cluster) as client:  # fmt: skip  (any free port)
        yield client
