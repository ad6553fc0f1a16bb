"""``python -m bench [--quick] [--only NAME ...] [--out DIR] [--no-progress]``."""

import argparse
import sys

from bench import BENCHMARKS, run_all

parser = argparse.ArgumentParser(prog="python -m bench", description="liebody's benchmarks")
parser.add_argument("--quick", action="store_true",
                    help="short horizons and few points: under two minutes (CI)")
parser.add_argument("--out", metavar="DIR", default="bench/results",
                    help="where the JSON, CSV and PNG files go (default: bench/results)")
parser.add_argument("--only", metavar="NAME", action="append", default=None,
                    choices=BENCHMARKS, help="run only this benchmark (repeatable)")
parser.add_argument("--no-progress", action="store_true", help="no progress bars")
args = parser.parse_args()
run_all(args.out, quick=args.quick, only=args.only, show_progress=not args.no_progress)
sys.exit(0)
