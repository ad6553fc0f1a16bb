"""The skeleton every benchmark fills in: command line, timing, files, charts, reports.

A benchmark is a :class:`Benchmark` record (see ``BENCHMARK`` at the end of each module):
its settings, a ``run`` that measures and returns what goes into ``NAME.json``, and
``csv``, ``plot`` and ``report`` that only read that summary. :func:`measure` does the
rest for all of them alike: the settings and the machine in the JSON (strict: non-finite
numbers become ``null``), one CSV, the chart with the machine at its foot, the run time.
:func:`main` is ``python -m bench``.
"""

from __future__ import annotations

import argparse
import contextlib
import csv
import datetime
import importlib
import json
import os
import platform
import statistics
import time
import warnings
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np

import liebody
from bench import BENCHMARKS

#: where ``python -m bench`` writes by default (relative to the working directory)
DEFAULT_OUT = "bench/results"


# ------------------------------------------------------------------------- the record


@dataclass(frozen=True)
class Option:
    """A command-line option of one benchmark, handed to its ``settings`` as ``dest=value``."""

    flag: str
    dest: str
    help: str
    type: Callable[[str], Any] = str
    choices: tuple | None = None
    repeat: bool = False  # may be given several times (a list)


@dataclass(frozen=True)
class Benchmark:
    """One benchmark: what it measures and how its results are written and shown.

    ``settings(quick, **options) -> cfg``; ``run(cfg, progress) -> results`` (the JSON
    body; :func:`measure` adds ``machine``, ``settings`` and ``runtime_s``); then, from the
    whole summary, ``csv(summary) -> (header, rows)``, ``plot(summary, plt) -> figure``
    and ``report(summary) -> text``.
    """

    name: str
    settings: Callable[..., dict]
    run: Callable[[dict, Progress], dict]
    csv: Callable[[dict], tuple[list[str], list[list]]]
    plot: Callable[[dict, Any], Any]
    report: Callable[[dict], str]
    options: tuple[Option, ...] = ()


def load(name: str) -> Benchmark:
    """The :class:`Benchmark` of the module ``bench.<name>``."""
    if name not in BENCHMARKS:
        raise ValueError(f"unknown benchmark {name!r}; choose from {BENCHMARKS}")
    return importlib.import_module(f"bench.{name}").BENCHMARK


def measure(bench: Benchmark, out: str | Path, quick: bool = False,
            show_progress: bool = True, **options) -> dict:
    """Run one benchmark and write ``NAME.json``, ``NAME.csv`` and ``NAME.png`` into ``out``.

    Returns the summary (what the JSON holds).
    """
    cfg = bench.settings(quick, **options)
    t0 = time.perf_counter()
    summary = {"machine": machine(), "settings": cfg, **bench.run(cfg, Progress(show_progress))}
    summary["runtime_s"] = time.perf_counter() - t0
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    write_json(out / f"{bench.name}.json", summary)
    write_csv(out / f"{bench.name}.csv", *bench.csv(summary))
    finish_figure(bench.plot(summary, pyplot()), out / f"{bench.name}.png")
    return summary


def run_all(out: str | Path = DEFAULT_OUT, quick: bool = False, only: Iterable[str] | None = None,
            show_progress: bool = True, options: dict | None = None) -> dict[str, dict]:
    """Run the benchmarks (all, or those named in ``only``) and print their reports.

    ``options`` maps a benchmark's name to keyword options for its ``settings``.
    Returns each benchmark's summary by name.
    """
    results = {}
    for name in only or BENCHMARKS:
        bench = load(name)
        t0 = time.perf_counter()
        print(f"--- {name} ({'quick' if quick else 'full'}) -> {out}/{name}.*", flush=True)
        summary = measure(bench, out, quick, show_progress, **(options or {}).get(name, {}))
        print(bench.report(summary))
        print(f"--- {name}: {time.perf_counter() - t0:.1f} s", flush=True)
        results[name] = summary
    return results


def main(argv: list[str] | None = None) -> int:
    """``python -m bench [--quick] [--only NAME ...] [--out DIR] [--no-progress]``, plus
    the options the benchmarks declare (they apply to that benchmark only)."""
    parser = argparse.ArgumentParser(
        prog="python -m bench", description="liebody's benchmarks (bench/README.md)")
    parser.add_argument("--quick", action="store_true",
                        help="short horizons and few points: about a minute (what CI runs)")
    parser.add_argument("--only", metavar="NAME", action="append", choices=BENCHMARKS,
                        help=f"run only this benchmark (repeatable): {', '.join(BENCHMARKS)}")
    parser.add_argument("--out", metavar="DIR", default=DEFAULT_OUT,
                        help=f"where the JSON, CSV and PNG files go (default: {DEFAULT_OUT})")
    parser.add_argument("--no-progress", action="store_true", help="no progress bars")
    parser.add_argument("--register", metavar="MODULE", action="append", default=[],
                        help="import this module first (repeatable): the methods it "
                             "registers (liebody.register_composition, "
                             "register_splitting, register) are benchmarked with the rest")
    owners = {}
    for name in BENCHMARKS:
        bench = load(name)
        group = parser.add_argument_group(f"{name} options") if bench.options else None
        for opt in bench.options:
            group.add_argument(opt.flag, dest=opt.dest, type=opt.type, choices=opt.choices,
                               action="append" if opt.repeat else "store", help=opt.help)
            owners[opt.dest] = name
    args = vars(parser.parse_args(argv))
    for module in args["register"]:
        importlib.import_module(module)
    options: dict[str, dict] = {}
    for dest, name in owners.items():
        if args[dest] is not None:
            options.setdefault(name, {})[dest] = args[dest]
    run_all(args["out"], quick=args["quick"], only=args["only"],
            show_progress=not args["no_progress"], options=options)
    return 0


# ------------------------------------------------------------------------- the machine


@cache
def machine() -> dict:
    """What the benchmarks ran on: CPU model, cores, OS and library versions."""
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:  # pragma: no cover - not Linux
        pass
    import numba
    import scipy

    info = {
        "cpu": cpu,
        "cores": os.cpu_count(),
        "os": f"{platform.system()} {platform.release()}",
        "python": platform.python_version(),
        "numpy": np.__version__,
        "numba": numba.__version__,
        "scipy": scipy.__version__,
        "liebody": liebody.__version__,
        "date": datetime.date.today().isoformat(),
    }
    try:
        import mujoco

        info["mujoco"] = mujoco.__version__
    except ImportError:
        info["mujoco"] = None
    return info


def machine_label() -> str:
    """One line for the foot of every chart."""
    m = machine()
    peers = f", MuJoCo {m['mujoco']}" if m["mujoco"] else ""
    return (f"{m['cpu']} ({m['cores']} cores), {m['os']}; Python {m['python']}, numba "
            f"{m['numba']}, scipy {m['scipy']}{peers}; liebody {m['liebody']}, {m['date']}")


# ----------------------------------------------------------------------------- timing


def median_time(fn: Callable[[], object], repeat: int, min_batch: float = 0.02
                ) -> tuple[float, list[float]]:
    """Median wall time of ``fn()`` over ``repeat`` measurements (after one warm-up call).

    A call shorter than ``min_batch`` seconds is repeated inside each measurement until
    the batch lasts that long, and the batch time is divided by the calls made, so that
    the timer's resolution and one-off hiccups do not dominate short runs.

    Returns the median and the individual per-call times.
    """
    t0 = time.perf_counter()
    fn()
    first = time.perf_counter() - t0
    inner = 1 if first >= min_batch else max(1, int(min_batch / max(first, 1e-7)))
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        for _ in range(inner):
            fn()
        times.append((time.perf_counter() - t0) / inner)
    return statistics.median(times), times


@contextlib.contextmanager
def quiet_runtime_warnings():
    """Silence the baselines' expected blow-up warnings (``failed_at`` records them)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        yield


class Progress:
    """Progress bars on stderr (tqdm), or silent stand-ins with the same methods."""

    def __init__(self, enabled: bool) -> None:
        self.enabled = enabled

    def __call__(self, items: Iterable | None = None, desc: str = "", total: int | None = None):
        """A bar over ``items`` (or counting to ``total`` by ``update``)."""
        if not self.enabled:
            return _SilentBar(items)
        from tqdm.auto import tqdm

        return tqdm(items, desc=desc, total=total, leave=False)


class _SilentBar:
    def __init__(self, items: Iterable | None) -> None:
        self._items = () if items is None else items

    def __iter__(self):
        return iter(self._items)

    def set_postfix_str(self, s: str) -> None:
        pass

    def update(self, n: int = 1) -> None:
        pass

    def close(self) -> None:
        pass


# ------------------------------------------------------------------------------ files


def write_json(path: Path, data) -> None:
    """Strict JSON (``allow_nan=False``): non-finite floats become ``null``."""
    with open(path, "w") as fh:
        json.dump(_finite(data), fh, indent=1, default=_json_default, allow_nan=False)
        fh.write("\n")


def _finite(o):
    """Non-finite floats become None (strict JSON); containers are walked."""
    if isinstance(o, dict):
        return {k: _finite(v) for k, v in o.items()}
    if isinstance(o, list | tuple):
        return [_finite(v) for v in o]
    if isinstance(o, np.ndarray):
        return _finite(o.tolist())
    if isinstance(o, float | np.floating):
        return float(o) if np.isfinite(o) else None
    return o


def _json_default(o):
    if isinstance(o, np.integer):
        return int(o)
    if isinstance(o, np.bool_):
        return bool(o)
    raise TypeError(f"not JSON serialisable: {type(o).__name__}")


def write_csv(path: Path, header: list[str], rows: list[list]) -> None:
    """One header line, then the rows; floats to 6 significant digits."""
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(header)
        for r in rows:
            w.writerow([f"{v:.6g}" if isinstance(v, float) else v for v in r])


# ----------------------------------------------------------------------------- charts


def pyplot():
    """matplotlib.pyplot with the non-interactive backend."""
    try:
        import matplotlib
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise ImportError("the benchmark charts need matplotlib: pip install -e '.[bench]'"
                          ) from exc
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def finish_figure(fig, path: Path) -> None:
    """Machine line at the foot, tight layout, 120 dpi PNG."""
    fig.text(0.5, 0.005, "ran on: " + machine_label(), ha="center", va="bottom", fontsize=7,
             color="0.35", wrap=True)
    fig.tight_layout(rect=(0, 0.03, 1, 1))
    fig.savefig(path, dpi=120)
    pyplot().close(fig)


def label_axes(ax, xlabel: str, ylabel: str | None = None, title: str | None = None,
               title_size: float = 10, grid_axis: str = "both", **title_kw) -> None:
    """Axis labels, a title and the light grid (major and minor ticks) of every chart."""
    ax.set_xlabel(xlabel)
    if ylabel is not None:
        ax.set_ylabel(ylabel)
    if title is not None:
        ax.set_title(title, fontsize=title_size, **title_kw)
    ax.grid(True, axis=grid_axis, which="both", alpha=0.25)


# one colour per method, the same on every chart
_COLOURS = {
    "splitting2": "#1f77b4", "sr2": "#aec7e8", "rattle": "#ff7f0e", "splitting4": "#2ca02c",
    "splitting6": "#98df8a", "splitting8": "#17becf", "dmv4": "#d62728", "dmv6": "#ff9896",
    "dmv8": "#9467bd", "dmv10": "#c5b0d5", "euler": "#7f7f7f", "rk4": "#000000",
    "lie_euler": "#bcbd22", "rkmk4": "#8c564b",
    "saba2": "#e6550d", "saba3": "#a63603", "saba4": "#7f2704",
    "scipy RK45": "#e377c2", "scipy DOP853": "#f7b6d2",
    "MuJoCo Euler": "#c49c94", "MuJoCo RK4": "#843c39", "MuJoCo implicitfast": "#ad494a",
}


def style(name: str) -> dict:
    """Line style of a method or peer: solid for liebody's geometric methods, dashed
    for its baselines, dotted for scipy and MuJoCo."""
    fam = None
    with contextlib.suppress(KeyError, ValueError):
        fam = liebody.methods()[name].family
    ls = "-" if fam not in (None, "baseline") else ("--" if fam == "baseline" else ":")
    marker = "o" if fam not in (None, "baseline") else ("s" if fam == "baseline" else "^")
    return {"color": _COLOURS.get(name, "0.5"), "ls": ls, "marker": marker, "ms": 3,
            "label": name}
