"""``python -m bench [--quick] [--only NAME ...] [--out DIR] [--no-progress]``."""

import sys

from bench.core import main

sys.exit(main())
