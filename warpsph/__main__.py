"""``python -m warpsph`` is the ``warpsph`` command."""

import sys

from warpsph.cli import main

sys.exit(main())
