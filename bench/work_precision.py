"""Work-precision: global error at T against wall time per unit of simulated time.

Every registered liebody method, scipy's ``solve_ivp`` (RK45, DOP853; numba-compiled
right-hand side) and MuJoCo (Euler, RK4, implicitfast; where installed and where the
body is physical) on the same problems, against the same reference, in one run
(:mod:`bench.problems` defines the problems and references).

For each problem the liebody methods run a ladder of steps ``h_max / 2^k`` twice:

* to ``T = 10``, timed as a user would call it (``integrate()`` with its validation and
  set-up, median of repeats), giving the ``T = 10`` chart;
* to the long horizon (``1e4``; ``100`` with ``--quick``) with samples on a grid,
  timed once per run (runs are long), giving the long-horizon chart and, from the
  samples, the global error and the worst energy error at every intermediate horizon
  at the same cost per unit time.

Peers run a tolerance (scipy) or step (MuJoCo) ladder to both horizons; a run whose
predicted time exceeds the budget is skipped and its line ends there.

Reported (``work_precision.json``):

* for error levels 1e-4, 1e-6, 1e-8, 1e-10 and both horizons, the cost of the best
  liebody method and the speed ratio to each peer (``cost_peer / cost_best``, by
  log-log interpolation along each line; ``None`` where a line never gets there);
* per problem and error level, the horizon beyond which the best geometric method
  beats liebody's own compiled ``rk4`` at equal cost, in global error and in energy
  error.

Run ``python -m bench --only work_precision [--quick] [--problem KEY ...]``.
"""

from __future__ import annotations

import math
import time

import numpy as np

import liebody
from bench import core
from bench import peers as P
from bench.problems import (
    PROBLEM_KEYS,
    energy,
    method_names,
    problems,
    reference,
    state_error,
)

#: error levels at which the speed ratios and crossovers are reported
ERROR_LEVELS = (1e-4, 1e-6, 1e-8, 1e-10)


def settings(quick: bool, problem_keys: list[str] | None = None) -> dict:
    """Ladders, horizons and time budgets; ``problem_keys`` (``--problem``) restricts
    the problems (default: all)."""
    cfg = _settings(quick)
    cfg["problems"] = list(problem_keys or PROBLEM_KEYS)
    return cfg


def _settings(quick: bool) -> dict:
    if quick:
        return {"T_short": 10.0, "T_long": 100.0, "horizons": [10.0, 30.0, 100.0],
                "halvings": [0, 2, 4, 6], "repeat": 3, "min_batch": 0.005, "cap_short": 0.05,
                "cap_long": 0.25,
                "cap_peer": 0.5, "rtols": [1e-4, 1e-7, 1e-10],
                "mujoco_h": [4e-3, 1e-3], "sample_dt": 0.05}
    return {"T_short": 10.0, "T_long": 1e4,
            "horizons": [10.0, 30.0, 100.0, 300.0, 1e3, 3e3, 1e4],
            "halvings": list(range(0, 13)), "repeat": 5, "min_batch": 0.02, "cap_short": 0.5,
            "cap_long": 3.0,
            "cap_peer": 15.0, "rtols": [10.0**-k for k in range(3, 14)],
            "mujoco_h": [1e-2, 4e-3, 1e-3, 4e-4, 1e-4, 4e-5, 1e-5],
            "sample_dt": 0.05}


# ------------------------------------------------------------------------ liebody runs


def _save_stride(n_first: int, h: float, sample_dt: float) -> int:
    """Largest divisor of ``n_first`` (steps to the first horizon) with stride*h <= sample_dt."""
    best = 1
    for d in range(1, n_first + 1):
        if n_first % d == 0 and d * h <= sample_dt * (1 + 1e-12):
            best = d
    return best


def liebody_ladder(problem, method: str, cfg: dict, refs: dict, bar) -> list[dict]:
    """Both horizons for one method: rows of the CSV."""
    rows = []
    horizons = np.array(cfg["horizons"])
    T_s, T_l = cfg["T_short"], cfg["T_long"]
    q_s, L_s = refs["short"]
    q_h, L_h = refs["horizons"]
    short_done = long_done = False
    for k in cfg["halvings"]:
        h = problem.h_max / 2**k
        if short_done and long_done:
            break
        bar.set_postfix_str(f"{problem.key} {method} h={h:.3g}")
        if not short_done:
            n = round(T_s / h)
            tr, refused = _attempt(problem, T_s, method, h, n, 1)
            if refused:
                rows.append(refused)
                continue
            if tr.failed_at is not None:
                err = dE = math.inf
            else:
                err = float(state_error(problem, tr.q[-1], tr.L[-1], q_s, L_s)[0])
                dE = float(np.abs(tr.energy / problem.E0 - 1).max())
            wall, _ = core.median_time(lambda h=h, n=n: problem.integrate(method, h, n, n),
                                       cfg["repeat"], cfg["min_batch"])
            rows.append(_row(problem, T_s, method, "liebody", h, n, wall, err, dE))
            short_done = (err < 1e-13) or wall > cfg["cap_short"]
        if not long_done:
            n = round(T_l / h)
            stride = _save_stride(round(horizons[0] / h), h, cfg["sample_dt"])
            t0 = time.perf_counter()
            tr, refused = _attempt(problem, T_l, method, h, n, stride)
            if refused:
                rows.append(refused)
                continue
            wall = time.perf_counter() - t0
            if wall < 0.2:  # short enough to take a median (samples saved as above)
                wall, _ = core.median_time(
                    lambda h=h, n=n, s=stride: problem.integrate(method, h, n, s),
                    cfg["repeat"], cfg["min_batch"])
            idx = np.rint(horizons / (stride * h)).astype(int)
            if tr.failed_at is not None or len(tr.t) <= idx[-1]:
                errs = np.full(len(horizons), math.inf)
                dEs = np.full(len(horizons), math.inf)
                ok = len(tr.t)
                rel = np.abs(tr.energy / problem.E0 - 1)
                for j, i in enumerate(idx):
                    if i < ok:
                        errs[j] = state_error(problem, tr.q[i], tr.L[i], q_h[j], L_h[j])[0]
                        dEs[j] = rel[: i + 1].max()
            else:
                errs = state_error(problem, tr.q[idx], tr.L[idx], q_h, L_h)
                rel = np.abs(tr.energy / problem.E0 - 1)
                dEs = np.maximum.accumulate(rel)[idx]
            rows.append(_row(problem, T_l, method, "liebody", h, n, wall, float(errs[-1]),
                             float(dEs[-1]), horizons=horizons, errs=errs, dEs=dEs))
            long_done = (errs[-1] < 1e-12) or wall > cfg["cap_long"]
    return rows


def _attempt(problem, T: float, method: str, h: float, n: int, save_every: int):
    """``(trajectory, None)``, or ``(None, row)`` where the method refused the step
    (an implicit step without a solution, a step that makes the modified moments negative)."""
    try:
        return problem.integrate(method, h, n, save_every), None
    except (liebody.ConvergenceError, ValueError) as exc:
        return None, _row(problem, T, method, "liebody", h, n, None, None, None,
                          note=type(exc).__name__)


def _row(problem, T, method, source, setting, steps, wall, err, dE, note="", horizons=None,
         errs=None, dEs=None) -> dict:
    row = {"problem": problem.key, "T": T, "method": method, "source": source,
           "setting": setting, "steps": steps, "wall_s": wall,
           "cost_per_time": None if wall is None else wall / T, "error": err,
           "energy_error": dE, "note": note}
    if horizons is not None:
        row["by_horizon"] = {"T": list(horizons), "error": list(map(float, errs)),
                             "energy_error": list(map(float, dEs))}
    return row


# --------------------------------------------------------------------------- peer runs


def _peer_horizons(cfg: dict, refs: dict):
    """(T, reference state, time budget per run) for the short and the long horizon."""
    return ((cfg["T_short"], refs["short"], cfg["cap_peer"] / 10),
            (cfg["T_long"], refs["long"], cfg["cap_peer"]))


def scipy_ladder(problem, method: str, cfg: dict, refs: dict, bar) -> list[dict]:
    rows = []
    label = P.label("scipy", method)
    for T, (q_r, L_r), cap in _peer_horizons(cfg, refs):
        predicted_per_time = 0.0
        for rtol in cfg["rtols"]:
            if predicted_per_time * T > cap:
                rows.append(_row(problem, T, label, "scipy", rtol, None, None, None, None,
                                 note="skipped: over the time budget"))
                break
            bar.set_postfix_str(f"{problem.key} {label} rtol={rtol:.0e} T={T:g}")

            def go(rtol=rtol, T=T):
                return P.scipy_solve(problem, T, method, rtol)

            res = go()
            wall, _ = core.median_time(go, cfg["repeat"] if T == cfg["T_short"] else 1,
                                    min_batch=0.0)
            err = float(state_error(problem, res["q"][-1], res["L"][-1], q_r, L_r)[0])
            dE = float(abs(energy(problem, res["q"], res["L"])[-1] / problem.E0 - 1))
            rows.append(_row(problem, T, label, "scipy", rtol, res["steps"], wall, err, dE))
            predicted_per_time = wall / T * 2.2  # the next, tighter tolerance costs more
    return rows


def mujoco_ladder(problem, integrator: str, cfg: dict, refs: dict, bar) -> list[dict]:
    rows = []
    label = P.label("MuJoCo", integrator)
    for T, (q_r, L_r), cap in _peer_horizons(cfg, refs):
        for h in cfg["mujoco_h"]:
            n = round(T / h)
            run = P.MujocoRun(problem, integrator, h)
            run.run(min(n, 1000))  # warm up
            t0 = time.perf_counter()
            run.run(min(n, 10000))
            predicted = (time.perf_counter() - t0) / min(n, 10000) * n
            if predicted > cap:
                rows.append(_row(problem, T, label, "MuJoCo", h, n, None, None, None,
                                 note="skipped: over the time budget"))
                break
            bar.set_postfix_str(f"{problem.key} {label} h={h:g} T={T:g}")
            wall, _ = core.median_time(lambda n=n, run=run: run.run(n),
                                    cfg["repeat"] if T == cfg["T_short"] else 1, min_batch=0.0)
            q, L = run.run(n)
            err = float(state_error(problem, q[-1], L[-1], q_r, L_r)[0])
            if not np.isfinite(err):
                err = math.inf
            dE = float(abs(energy(problem, q, L)[-1] / problem.E0 - 1))
            rows.append(_row(problem, T, label, "MuJoCo", h, n, wall, err, dE))
    return rows


# -------------------------------------------------------------------------- analysis


def cost_at(points: list[tuple[float, float]], level: float) -> float | None:
    """Cost at which a line (``(cost, error)`` points) first reaches ``error <= level``.

    Points are sorted by cost and the error made monotone (the best error so far); the
    cost is interpolated log-log between the two points around ``level``. A line whose
    cheapest point is already below ``level`` returns that point's cost (an upper bound).
    ``None`` where the line never gets there.
    """
    pts = sorted((c, e) for c, e in points if c is not None and e is not None and c > 0
                 and np.isfinite(e))
    best = math.inf
    prev = None
    for c, e in pts:
        e = min(e, best)
        if e <= level:
            if prev is None or prev[1] <= 0:
                return c
            c0, e0 = prev
            if e0 == e:
                return c
            frac = (math.log(level) - math.log(e0)) / (math.log(e) - math.log(e0))
            return math.exp(math.log(c0) + frac * (math.log(c) - math.log(c0)))
        best = e
        prev = (c, e)
    return None


def ratios(rows: list[dict], problem: str, T: float) -> dict:
    """Best liebody method and the speed ratio to every other line, per error level."""
    lines: dict[str, list[tuple[float, float]]] = {}
    for r in rows:
        if r["problem"] == problem and r["T"] == T and r["wall_s"] is not None:
            lines.setdefault(r["method"], []).append((r["cost_per_time"], r["error"]))
    out = {}
    for level in ERROR_LEVELS:
        costs = {name: cost_at(pts, level) for name, pts in lines.items()}
        ours = {n: c for n, c in costs.items() if n in method_names() and c is not None}
        if not ours:
            out[f"{level:.0e}"] = {"best": None}
            continue
        best = min(ours, key=ours.get)
        peers = {n: (None if c is None else c / ours[best]) for n, c in costs.items()
                 if n not in method_names() or n == "rk4"}
        out[f"{level:.0e}"] = {"best": best, "best_cost_per_time_s": ours[best],
                               "ratio_peer_over_best": peers}
    return out


def crossover(rows: list[dict], problem: str, T_long: float) -> dict:
    """Horizon beyond which the best geometric method beats ``rk4`` at equal cost.

    From the long runs: at each intermediate horizon the error (global, and worst
    relative energy error so far) of each run is known, and its cost per unit time is
    that of the run. At each error level, compare the cheapest geometric method with
    ``rk4``; the crossover is the first horizon from which the geometric method stays
    cheaper.
    """
    geo = {m.name for m in liebody.methods() if m.family not in ("baseline", "exact")}
    runs = [r for r in rows if r["problem"] == problem and r["T"] == T_long
            and "by_horizon" in r and r["wall_s"] is not None]
    if not runs:
        return {}
    horizons = runs[0]["by_horizon"]["T"]
    out = {}
    for key in ("error", "energy_error"):
        per_level = {}
        for level in ERROR_LEVELS:
            table = []
            for j, T in enumerate(horizons):
                lines: dict[str, list] = {}
                for r in runs:
                    lines.setdefault(r["method"], []).append(
                        (r["cost_per_time"], r["by_horizon"][key][j]))
                c_rk4 = cost_at(lines.get("rk4", []), level)
                c_geo = {n: cost_at(p, level) for n, p in lines.items() if n in geo}
                c_geo = {n: c for n, c in c_geo.items() if c is not None}
                best = min(c_geo, key=c_geo.get) if c_geo else None
                table.append({"T": T, "rk4": c_rk4, "best_geometric": best,
                              "geometric": c_geo.get(best) if best else None})
            per_level[f"{level:.0e}"] = {"by_horizon": table,
                                         "verdict": _verdict(table, T_long)}
        out[key] = per_level
    return out


def _verdict(table: list[dict], T_long: float) -> str:
    wins = []
    for row in table:
        g, r = row["geometric"], row["rk4"]
        if g is None and r is None:
            wins.append(None)
        elif r is None:
            wins.append(True)
        elif g is None:
            wins.append(False)
        else:
            wins.append(g < r)
    known = [(row["T"], w) for row, w in zip(table, wins, strict=True) if w is not None]
    if not known:
        return "neither reaches this level within the budget"
    if all(w for _, w in known):
        return f"geometric wins at every horizon (from T = {known[0][0]:g})"
    if not any(w for _, w in known):
        return f"rk4 wins at every horizon up to T = {known[-1][0]:g}"
    last_loss = max(T for T, w in known if not w)
    after = [T for T, w in known if w and T > last_loss]
    if not after:
        return f"rk4 wins at T = {last_loss:g}, the longest horizon measured"
    return f"rk4 wins up to T = {last_loss:g}; geometric from T = {after[0]:g}"


# ----------------------------------------------------------------------------- driver


def run(cfg: dict, progress: core.Progress) -> dict:
    """Every ladder on every problem; per problem the reference, ratios and crossovers."""
    rows: list[dict] = []
    out: dict = {"problems": {}, "mujoco_warnings": {}}
    have_mujoco = P.mujoco_available()
    for pb in (problems()[k] for k in cfg["problems"]):
        horizons = np.array(cfg["horizons"])
        q_h, L_h, info = reference(pb, horizons)
        refs = {"short": (q_h[0], L_h[0]), "long": (q_h[-1], L_h[-1]), "horizons": (q_h, L_h)}
        assert horizons[0] == cfg["T_short"] and horizons[-1] == cfg["T_long"]
        bar = progress(P.contenders(pb, have_mujoco), f"work-precision {pb.key}")
        for source, m in bar:
            # the baselines' blow-ups overflow in the diagnostics: expected, recorded
            with np.errstate(over="ignore", invalid="ignore"), core.quiet_runtime_warnings():
                rows += _LADDERS[source](pb, m, cfg, refs, bar)
            if source == "MuJoCo":
                out["mujoco_warnings"][f"{pb.key} {P.label(source, m)}"] = (
                    P.MUJOCO_WARNINGS.take())
        out["problems"][pb.key] = {
            "title": pb.title, "source": pb.source, "reference": info,
            "h_omega_max_at_h_max": pb.h_max * pb.omega_max,
            "mujoco": "run" if (have_mujoco and pb.physical) else
                      ("not installed" if not have_mujoco else
                       "not run: inertia breaks the triangle inequality"),
            "ratios": {f"T={T:g}": ratios(rows, pb.key, T)
                       for T in (cfg["T_short"], cfg["T_long"])},
            "crossover_vs_rk4": crossover(rows, pb.key, cfg["T_long"]),
        }
    out["rows"] = rows
    return out


_LADDERS = {"liebody": liebody_ladder, "scipy": scipy_ladder, "MuJoCo": mujoco_ladder}

_CSV_FIELDS = ("problem", "T", "method", "source", "setting", "steps", "wall_s",
               "cost_per_time", "error", "energy_error", "note")


def csv_table(summary: dict) -> tuple[list[str], list[list]]:
    """One row per run."""
    header = [f if f != "cost_per_time" else "cost_per_time_s" for f in _CSV_FIELDS]
    return header, [[r[f] for f in _CSV_FIELDS] for r in summary["rows"]]


def plot(summary: dict, plt):
    """Error against cost per problem, at the short and the long horizon."""
    cfg = summary["settings"]
    keys = list(summary["problems"])
    fig, axes = plt.subplots(len(keys), 2, figsize=(13, 4.6 * len(keys)), squeeze=False)
    rows = summary["rows"]
    for i, key in enumerate(keys):
        info = summary["problems"][key]
        for j, T in enumerate((cfg["T_short"], cfg["T_long"])):
            ax = axes[i, j]
            names = []
            for r in rows:
                if r["problem"] == key and r["T"] == T and r["method"] not in names:
                    names.append(r["method"])
            for name in names:
                pts = sorted((r["cost_per_time"], r["error"]) for r in rows
                             if r["problem"] == key and r["T"] == T and r["method"] == name
                             and r["wall_s"] is not None and r["error"] is not None
                             and np.isfinite(r["error"]))
                if pts:
                    x, y = np.array(pts).T
                    ax.loglog(x, np.maximum(y, 1e-16), **core.style(name))
            floor = info["reference"]["uncertainty"]
            ax.axhline(floor, color="0.6", lw=0.8)
            ax.text(0.99, floor, " reference uncertainty",
                    transform=ax.get_yaxis_transform(), ha="right", va="bottom",
                    fontsize=7, color="0.4")
            core.label_axes(ax, "wall time per unit of simulated time [s]",
                            f"global error at T = {T:g}", f"{info['title']}\nT = {T:g}")
            if j == 0:
                ax.legend(fontsize=7, ncol=2, loc="lower left")
    fig.suptitle("Work-precision: global error against cost (lower left is better)")
    return fig


def report(summary: dict) -> str:
    """The ratio tables and crossover verdicts as text."""
    lines = []
    for info in summary["problems"].values():
        lines.append(f"== {info['title']} (reference: {info['reference']['reference']})")
        for hz, table in info["ratios"].items():
            for level, entry in table.items():
                if entry["best"] is None:
                    lines.append(f"  {hz} error {level}: no liebody method got there")
                    continue
                peers = ", ".join(f"{n} {'-' if v is None else f'{v:.3g}x'}"
                                  for n, v in entry["ratio_peer_over_best"].items())
                lines.append(f"  {hz} error {level}: best {entry['best']} "
                             f"({entry['best_cost_per_time_s']:.3g} s per unit time); "
                             f"peer/best: {peers}")
        for kind, per_level in info["crossover_vs_rk4"].items():
            for level, entry in per_level.items():
                lines.append(f"  vs rk4, {kind} {level}: {entry['verdict']}")
    return "\n".join(lines)


BENCHMARK = core.Benchmark(
    name="work_precision", settings=settings, run=run, csv=csv_table, plot=plot, report=report,
    options=(core.Option("--problem", "problem_keys", choices=PROBLEM_KEYS,
                         repeat=True, help="only this problem (repeatable)"),))
