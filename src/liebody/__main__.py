"""Command line: ``python -m liebody demo [--plot DIR]``, ``methods``.

The benchmarks are not part of the package: run ``python -m bench`` in a source checkout.
"""

from __future__ import annotations

import argparse
import sys

BENCH_MOVED = ("liebody bench: the benchmarks are not in the package; in a source checkout "
               "run 'python -m bench [--quick]' from the repository root (bench/README.md)")


def main(argv: list[str] | None = None) -> int:
    args_in = sys.argv[1:] if argv is None else list(argv)
    if args_in[:1] == ["bench"]:
        print(BENCH_MOVED, file=sys.stderr)
        return 2
    parser = argparse.ArgumentParser(prog="python -m liebody",
                                     description="liebody: rigid-body rotation on SO(3)")
    sub = parser.add_subparsers(dest="command", required=True)
    demo = sub.add_parser("demo", help="a short tour of rigid-body phenomena, checked against "
                                       "their closed forms")
    demo.add_argument("--plot", metavar="DIR", default=None,
                      help="also write PNG figures to DIR (needs the 'plot' extra)")
    table = sub.add_parser("methods", help="print the method registry as a table")
    table.add_argument("--markdown", action="store_true", help="Markdown (as in docs/methods.md)")
    args = parser.parse_args(args_in)
    if args.command == "methods":
        from liebody import methods

        print(methods().to_markdown() if args.markdown else methods())
        return 0
    if args.command == "demo":
        from liebody.demo import run

        return run(plot_dir=args.plot)
    return 2  # pragma: no cover - argparse rejects unknown commands


if __name__ == "__main__":
    sys.exit(main())
