"""Command line: ``python -m liebody demo [--plot DIR]``, ``bench [--quick]``, ``methods``."""

from __future__ import annotations

import argparse
import sys


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m liebody",
                                     description="liebody: rigid-body rotation on SO(3)")
    sub = parser.add_subparsers(dest="command", required=True)
    demo = sub.add_parser("demo", help="a short tour of rigid-body phenomena, checked against "
                                       "their closed forms")
    demo.add_argument("--plot", metavar="DIR", default=None,
                      help="also write PNG figures to DIR (needs the 'plot' extra)")
    bench = sub.add_parser("bench", help="run the benchmarks (bench/README.md)")
    bench.add_argument("--quick", action="store_true",
                       help="short horizons and few points: under two minutes (CI)")
    bench.add_argument("--out", metavar="DIR", default="bench/results",
                       help="where the JSON, CSV and PNG files go (default: bench/results)")
    bench.add_argument("--only", metavar="NAME", action="append", default=None,
                       help="run only this benchmark (repeatable): step_cost, "
                            "work_precision, long_horizon, stability")
    bench.add_argument("--no-progress", action="store_true", help="no progress bars")
    table = sub.add_parser("methods", help="print the method registry as a table")
    table.add_argument("--markdown", action="store_true", help="Markdown (as in docs/methods.md)")
    args = parser.parse_args(argv)
    if args.command == "methods":
        from liebody import methods

        print(methods().to_markdown() if args.markdown else methods())
        return 0
    if args.command == "bench":
        from liebody.benchmarks import run_all

        run_all(args.out, quick=args.quick, only=args.only,
                show_progress=not args.no_progress)
        return 0
    if args.command == "demo":
        from liebody.demo import run

        return run(plot_dir=args.plot)
    return 2  # pragma: no cover - argparse rejects unknown commands


if __name__ == "__main__":
    sys.exit(main())
