"""Shared pieces of the benchmarks: problems, references, timing, output and chart style.

Nothing here is imported by the library itself; the benchmarks are run by
``python -m liebody bench`` or the scripts in ``bench/``.
"""

from __future__ import annotations

import argparse
import contextlib
import csv
import datetime
import json
import os
import platform
import statistics
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path

import numpy as np

import liebody

# error levels at which the speed ratios are reported (issue #6)
ERROR_LEVELS = (1e-4, 1e-6, 1e-8, 1e-10)


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


# ---------------------------------------------------------------------------- problems


@dataclass(frozen=True)
class Problem:
    """One benchmark problem: a scene, its initial state and where it comes from.

    ``q0`` is scalar-first (body -> space) and ``L0`` body-frame, as everywhere in
    liebody. ``h_max`` is the largest step tried; step ladders halve it.
    """

    key: str
    title: str
    scene: object
    q0: np.ndarray
    L0: np.ndarray
    h_max: float
    source: str
    physical: bool  # MuJoCo accepts the inertia (triangle inequality)
    extra: dict = field(default_factory=dict)

    @property
    def moments(self) -> np.ndarray:
        return self.scene.body.moments

    @property
    def free(self) -> bool:
        return type(self.scene).__name__ == "FreeBody"

    @property
    def omega_max(self) -> float:
        """|omega| at the start (for a free body, the largest |omega| on the orbit is
        close to it; the benchmarks quote steps as h |omega_0|)."""
        return float(np.linalg.norm(self.L0 / self.moments))

    @property
    def E0(self) -> float:
        return float(energy(self, self.q0[None], self.L0[None])[0])

    def methods(self) -> list[str]:
        """Every registered time-stepping method that can integrate this scene."""
        return [m.name for m in liebody.methods()
                if m.family != "exact" and m.supports(self.scene)]


def _problems() -> dict[str, Problem]:
    from liebody import quaternion

    hlw = Problem(
        key="hlw", title="HLW free body, I = (2, 1, 2/3)",
        scene=liebody.FreeBody(liebody.RigidBody([2.0, 1.0, 2.0 / 3.0], check_triangle=False)),
        q0=np.array([1.0, 0.0, 0.0, 0.0]), L0=np.array([np.cos(1.1), 0.0, np.sin(1.1)]),
        h_max=0.4, physical=False,
        source="Hairer-Lubich-Wanner; integrators-literature.md section 8.1")
    asym = Problem(
        key="asym", title="asymmetric free body, I = (0.6, 0.8, 1.0)",
        scene=liebody.FreeBody(liebody.RigidBody([0.6, 0.8, 1.0])),
        q0=np.array([1.0, 0.0, 0.0, 0.0]), L0=np.array([1.8, 0.4, -0.9]),
        h_max=0.2, physical=True,
        source="Hairer-Vilmart DMV driver; integrators-literature.md section 8.2")
    top = Problem(
        key="top", title="Simo-Wong fast heavy top, J = (5, 5, 1), Mgl = 20, spin 50",
        scene=liebody.HeavyTop(liebody.RigidBody([5.0, 5.0, 1.0]), mass=20.0, cm=[0.0, 0.0, 1.0],
                               g=1.0),
        q0=quaternion.exp([0.05, 0.0, 0.0]), L0=np.array([0.0, 0.0, 50.0]),
        h_max=0.04, physical=True,
        source="Simo & Wong (1991); integrators-literature.md section 8.3",
        extra={"omega_nutation": 10.0})
    return {p.key: p for p in (hlw, asym, top)}


@cache
def problems() -> dict[str, Problem]:
    """The benchmark problems by key: ``hlw``, ``asym`` (physical), ``top``."""
    return _problems()


def energy(problem: Problem, q: np.ndarray, L: np.ndarray) -> np.ndarray:
    """Total energy (kinetic plus the scene's potential) of states ``(n, 4)``, ``(n, 3)``.

    ``q`` need not be unit (a peer's quaternion that has drifted is used as it is in
    the potential, as that peer's own equations would).
    """
    T = 0.5 * np.sum(np.asarray(L) ** 2 / problem.moments, axis=-1)
    return T + problem.scene.potential(np.asarray(q))


def state_error(problem: Problem, q, L, q_ref, L_ref) -> np.ndarray:
    """Global error: the larger of ``|L - L_ref| / |L0|`` and ``min(|q - q_ref|, |q + q_ref|)``
    (max-norms; q and -q are the same rotation)."""
    q, L, q_ref, L_ref = (np.atleast_2d(np.asarray(a, dtype=float)) for a in (q, L, q_ref, L_ref))
    eL = np.abs(L - L_ref).max(axis=-1) / np.linalg.norm(problem.L0)
    eq = np.minimum(np.abs(q - q_ref).max(axis=-1), np.abs(q + q_ref).max(axis=-1))
    return np.maximum(eL, eq)


# ---------------------------------------------------------------------------- references


def reference(problem: Problem, times: np.ndarray) -> tuple[np.ndarray, np.ndarray, dict]:
    """Reference states at ``times`` (each a whole multiple of the smallest).

    Free bodies: the exact flow (Jacobi elliptic functions), itself checked in the tests
    against 34-digit mpmath and against DOP853 at rtol 1e-13. The heavy top has no closed
    form in (q, L): the reference is ``splitting8`` at ``h = 1e-3`` (Kahan–Li order 8 on
    the exact symmetric-top flow), checked here against a second method, ``splitting6`` at
    ``h = 5e-4``, at every time, and against scipy's DOP853 at rtol = atol = 1e-13 at the
    first time. The largest of the two differences is returned as ``info["uncertainty"]``;
    errors below it are not resolved.
    """
    times = np.asarray(times, dtype=float)
    base = times[0]
    idx = np.rint(times / base).astype(np.int64)
    if not np.allclose(idx * base, times, rtol=1e-12, atol=0):
        raise ValueError("reference times must be whole multiples of the first")
    if problem.free:
        tr = liebody.integrate(problem.scene, q0=problem.q0, L0=problem.L0, dt=base,
                               steps=int(idx[-1]), method="exact")
        return tr.q[idx], tr.L[idx], {"reference": "exact flow", "uncertainty": 1e-14}

    def fine(method, h):
        n_per = round(base / h)
        tr = liebody.integrate(problem.scene, q0=problem.q0, L0=problem.L0, dt=base / n_per,
                               steps=int(idx[-1]) * n_per, method=method, save_every=n_per)
        return tr.q[idx], tr.L[idx]

    q, L = fine("splitting8", 1e-3)
    q2, L2 = fine("splitting6", 5e-4)
    spread = float(state_error(problem, q, L, q2, L2).max())
    from bench.peers import scipy_solve

    res = scipy_solve(problem, float(times[0]), "DOP853", 1e-13, t_eval=None)
    vs_dop = float(state_error(problem, q[0], L[0], res["q"][-1], res["L"][-1])[0])
    info = {"reference": "splitting8 h=1e-3 (checked: splitting6 h=5e-4, DOP853 rtol 1e-13)",
            "spread_vs_splitting6": spread, "vs_dop853_at_first_time": vs_dop,
            "uncertainty": max(spread, vs_dop, 1e-14)}
    return q, L, info


# ------------------------------------------------------------------------------ output


def write_json(path: Path, data) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
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
    if isinstance(o, np.floating):
        return float(o)
    if isinstance(o, np.ndarray):
        return o.tolist()
    raise TypeError(f"not JSON serialisable: {type(o).__name__}")


def write_csv(path: Path, header: list[str], rows: list[list]) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(header)
        for r in rows:
            w.writerow([f"{v:.6g}" if isinstance(v, float) else v for v in r])


def pyplot():
    """matplotlib.pyplot with the non-interactive backend (charts need the 'plot' extra)."""
    try:
        import matplotlib
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise ImportError("the benchmark charts need matplotlib: pip install 'liebody[plot]'"
                          ) from exc
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def finish_figure(fig, path: Path) -> None:
    """Machine line at the foot, tight layout, 120 dpi PNG."""
    fig.text(0.5, 0.005, "ran on: " + machine_label(), ha="center", va="bottom", fontsize=7,
             color="0.35", wrap=True)
    fig.tight_layout(rect=(0, 0.03, 1, 1))
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    import matplotlib.pyplot as plt

    plt.close(fig)


# one colour and marker per method, the same on every chart
_COLOURS = {
    "splitting2": "#1f77b4", "sr2": "#aec7e8", "rattle": "#ff7f0e", "splitting4": "#2ca02c",
    "splitting6": "#98df8a", "splitting8": "#17becf", "dmv4": "#d62728", "dmv6": "#ff9896",
    "dmv8": "#9467bd", "dmv10": "#c5b0d5", "euler": "#7f7f7f", "rk4": "#000000",
    "lie_euler": "#bcbd22", "rkmk4": "#8c564b",
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


@contextlib.contextmanager
def quiet_runtime_warnings():
    """Silence the baselines' expected blow-up warnings (``failed_at`` records them)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        yield


def progress(iterable, desc: str, enabled: bool, total: int | None = None):
    """A tqdm bar on stderr (or the plain iterable when disabled)."""
    if not enabled:
        return iterable
    from tqdm.auto import tqdm

    return tqdm(iterable, desc=desc, total=total, leave=False)


def command_line(doc: str, run: Callable[..., dict], report: Callable[[dict], str],
                 argv: list[str] | None, extra: Callable | None = None) -> int:
    """The shared command line of the benchmark modules (``--quick``, ``--out``,
    ``--no-progress``, plus what ``extra(parser)`` adds, passed on to ``run`` by name)."""
    parser = argparse.ArgumentParser(description=doc.splitlines()[0])
    parser.add_argument("--quick", action="store_true",
                        help="short horizons and few points (what CI runs)")
    parser.add_argument("--out", default="bench/results", help="output folder")
    parser.add_argument("--no-progress", action="store_true", help="no progress bars")
    if extra is not None:
        extra(parser)
    args = vars(parser.parse_args(argv))
    out, quick, show = Path(args.pop("out")), args.pop("quick"), not args.pop("no_progress")
    print(report(run(out, quick, show, **args)))
    return 0
