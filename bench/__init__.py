"""Benchmarks: speed against accuracy, long horizons, and where methods fail.

Each module compares liebody's methods with each other and with what users would
otherwise pick (scipy's ``solve_ivp``; MuJoCo where ``pip install 'liebody[bench]'``
installed it) on the same problems in one run, and writes ``NAME.json``, ``NAME.csv``
and a chart ``NAME.png`` into the output folder (``bench/results`` by default):

* :mod:`~liebody.benchmarks.step_cost` — ns per step of every method beside a C
  reference, compile time (empty and filled cache) and import time;
* :mod:`~liebody.benchmarks.work_precision` — global error against wall time per unit
  of simulated time at ``T = 10`` and ``T = 1e4``, speed ratios at fixed error levels,
  and the horizon beyond which the geometric methods beat ``rk4``;
* :mod:`~liebody.benchmarks.long_horizon` — energy, ``|q|`` and momentum drift over
  ``1e8`` steps;
* :mod:`~liebody.benchmarks.stability` — where each method stops keeping the energy
  bounded, the nutation resonance, and Euler angles against quaternions near gimbal lock.

Run them all with ``python -m liebody bench [--quick]``; ``--quick`` (short horizons,
few points) finishes in under two minutes and is what CI runs. Nothing here is
imported by ``import liebody``.
"""

from __future__ import annotations

import importlib
import time
from pathlib import Path

#: the benchmark modules, in the order ``python -m liebody bench`` runs them
BENCHMARKS = ("step_cost", "work_precision", "long_horizon", "stability")


def run_all(out: str | Path = "bench/results", quick: bool = False, only=None,
            show_progress: bool = True) -> dict[str, dict]:
    """Run the benchmarks (all, or those named in ``only``) and print their reports.

    Returns each benchmark's summary (what its JSON file holds) by name.
    """
    names = list(only if only else BENCHMARKS)
    unknown = [n for n in names if n not in BENCHMARKS]
    if unknown:
        raise ValueError(f"only: unknown benchmark(s) {unknown}; choose from {BENCHMARKS}")
    out = Path(out)
    results = {}
    for name in names:
        module = importlib.import_module(f"bench.{name}")
        t0 = time.perf_counter()
        print(f"--- {name} ({'quick' if quick else 'full'}) -> {out}/{name}.*", flush=True)
        summary = module.run(out, quick=quick, show_progress=show_progress)
        print(module.report(summary))
        print(f"--- {name}: {time.perf_counter() - t0:.1f} s", flush=True)
        results[name] = summary
    return results
