"""Cost per step, compile and import times: see :mod:`liebody.benchmarks.step_cost`."""

import sys

from liebody.benchmarks.step_cost import main

sys.exit(main())
