"""Runs :mod:`liebody.benchmarks.stability` (``--quick``, ``--out DIR``; see bench/README.md)."""

import sys

from liebody.benchmarks.stability import main

if __name__ == "__main__":
    sys.exit(main())
