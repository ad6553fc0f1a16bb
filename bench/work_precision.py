"""Runs :mod:`liebody.benchmarks.work_precision` (``--quick``, ``--out DIR``; bench/README.md)."""

import sys

from liebody.benchmarks.work_precision import main

if __name__ == "__main__":
    sys.exit(main())
