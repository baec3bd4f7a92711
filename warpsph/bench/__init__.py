"""Benchmarks (docs/performance.md): ``python -m warpsph.bench`` the full step's throughput
(:mod:`~warpsph.bench.throughput`, with ``--peer pysph`` side by side with PySPH: :mod:`~warpsph.bench.peer`),
``python -m warpsph.bench.pressure`` the pore-pressure solvers, ``python -m warpsph.bench.solve`` the
pressure solve's CPU threading; :mod:`~warpsph.bench.record` what every record carries."""
