"""``python -m warpsph.bench``: the throughput benchmark (:mod:`warpsph.bench.throughput`)."""

import sys

from warpsph.bench.throughput import main

sys.exit(main())
