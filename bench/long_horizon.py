"""Runs :mod:`liebody.benchmarks.long_horizon` (``--quick``, ``--out DIR``; see bench/README.md)."""

import sys

from liebody.benchmarks.long_horizon import main

if __name__ == "__main__":
    sys.exit(main())
