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
from numba import njit

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


# ------------------------------------------------------------------------ satellites
#
# A satellite in the gravity gradient of the Earth (liebody.GravityGradient on a
# circular low Earth orbit), in SI units: a fast tumble under a weak torque (the torque
# turns L by about 1e-6 of its size per second) and a slow libration about the orbital
# frame (the torque is as strong as the motion). The horizons are a day and ten orbits,
# so these problems have their own ladders and reference instead of the T = 10 / 1e4 of
# the problems above. Run ``python -m bench.work_precision --satellite [--quick]
# [--out DIR]``: it writes work_precision_satellite.{json,csv,png}.

#: the Earth's gravitational parameter (m^3/s^2) and the orbit radius (m, 400 km up)
GM_EARTH, R_LEO = 3.986004418e14, 6778.0e3
#: the spacecraft's principal moments (kg m^2): I_pitch > I_roll > I_yaw, the
#: Lagrange region of gravity-gradient stability (analysis.gravity_gradient_stability)
SAT_MOMENTS = (100.0, 120.0, 80.0)
#: ``(label, method, free_flow)`` of the liebody runs: the defaults (``free_flow="auto"``
#: is the exact free flow between the kicks on a GravityGradient scene) and the axis
#: splitting between the kicks (``"axes"``), the drift of every scene but this one
SAT_CONTENDERS = (("splitting2", "splitting2", "auto"), ("splitting4", "splitting4", "auto"),
                  ("splitting6", "splitting6", "auto"), ("saba2", "saba2", "auto"),
                  ("saba3", "saba3", "auto"), ("saba4", "saba4", "auto"),
                  ("splitting2 axes", "splitting2", "axes"),
                  ("splitting4 axes", "splitting4", "axes"), ("rk4", "rk4", "auto"),
                  ("rattle", "rattle", "auto"))
#: error levels (rad) of the satellite report
SAT_LEVELS = (1e-2, 1e-4, 1e-6, 1e-8)


def satellite_problems(quick: bool) -> dict:
    """The two satellites: ``tumble`` (0.5 rad/s about the intermediate axis, a day)
    and ``libration`` (about the orbit-pointing attitude, ten orbits of 1.6 h)."""
    from liebody.attitude import lvlh_quaternion
    from liebody.orbits import Circular

    n = math.sqrt(GM_EARTH / R_LEO**3)
    I = np.array(SAT_MOMENTS)
    # the Earth seen from the satellite: the orbit's position vector reversed
    r_sat, v_sat = -R_LEO * np.array([1.0, 0.0, 0.0]), -R_LEO * n * np.array([0.0, 1.0, 0.0])
    return {
        "tumble": {"title": "spacecraft tumbling near its intermediate axis, |omega| = 0.5 rad/s,"
                            " LEO gravity gradient", "n": n, "T": 3600.0 if quick else 86400.0,
                   "q0": np.array([1.0, 0.0, 0.0, 0.0]), "L0": I * np.array([0.5, 0.01, 0.01]),
                   "h_max": 12.8, "orbit": Circular(n, R_LEO)},
        "libration": {"title": "spacecraft librating about the orbital frame, |omega| ~ n,"
                               " LEO gravity gradient", "n": n,
                      "T": 11520.0 if quick else 57600.0,
                      "q0": lvlh_quaternion(r_sat, v_sat),
                      "L0": I * np.array([0.2 * n, -1.1 * n, 0.15 * n]),
                      "h_max": 480.0, "orbit": Circular(n, R_LEO)},
    }


def _sat_scene(pb: dict, free_flow: str):
    return liebody.GravityGradient(liebody.RigidBody(SAT_MOMENTS), [(GM_EARTH, pb["orbit"])],
                                   free_flow=free_flow)


@njit(cache=True)
def _sat_rhs(t, y, inv_moments, moments, k, radius, n):  # pragma: no cover - compiled
    """(q, L)' under the gravity-gradient torque of a source on the circular orbit
    ``radius (cos n t, sin n t, 0)``: ``3 GM / r^5 (r x I r)``, ``r`` in the body frame."""
    w, x, yq, z = y[0], y[1], y[2], y[3]
    o0, o1, o2 = y[4] * inv_moments[0], y[5] * inv_moments[1], y[6] * inv_moments[2]
    out = np.empty(7)
    out[0] = 0.5 * (-x * o0 - yq * o1 - z * o2)
    out[1] = 0.5 * (w * o0 + yq * o2 - z * o1)
    out[2] = 0.5 * (w * o1 + z * o0 - x * o2)
    out[3] = 0.5 * (w * o2 + x * o1 - yq * o0)
    s = 1.0 / (w * w + x * x + yq * yq + z * z)
    rx, ry = radius * math.cos(n * t), radius * math.sin(n * t)
    # r in the body frame: R(q)^T r with R(q) of the normalised q (r has no z part)
    b0 = ((1.0 - 2.0 * s * (yq * yq + z * z)) * rx + 2.0 * s * (x * yq + w * z) * ry)
    b1 = (2.0 * s * (x * yq - w * z) * rx + (1.0 - 2.0 * s * (x * x + z * z)) * ry)
    b2 = (2.0 * s * (x * z + w * yq) * rx + 2.0 * s * (yq * z - w * x) * ry)
    c = 3.0 * k / (rx * rx + ry * ry) ** 2.5
    i0, i1, i2 = moments[0] * b0, moments[1] * b1, moments[2] * b2
    out[4] = y[5] * o2 - y[6] * o1 + c * (b1 * i2 - b2 * i1)
    out[5] = y[6] * o0 - y[4] * o2 + c * (b2 * i0 - b0 * i2)
    out[6] = y[4] * o1 - y[5] * o0 + c * (b0 * i1 - b1 * i0)
    return out


def _sat_dop853(pb: dict, rtol: float) -> tuple[np.ndarray, int]:
    from scipy.integrate import solve_ivp

    I = np.array(SAT_MOMENTS)
    L0 = pb["L0"]
    atol = np.r_[np.full(4, rtol), np.full(3, rtol * np.linalg.norm(L0))]
    sol = solve_ivp(_sat_rhs, (0.0, pb["T"]), np.concatenate([pb["q0"], L0]), method="DOP853",
                    rtol=rtol, atol=atol, args=(1.0 / I, I, GM_EARTH, R_LEO, pb["n"]))
    return sol.y[:4, -1], int(sol.nfev)


def _sat_liebody(pb: dict, method: str, free_flow: str, h: float):
    steps = round(pb["T"] / h)
    scene = _sat_scene(pb, free_flow)
    with core.quiet_runtime_warnings():
        def go():
            return liebody.integrate(scene, q0=pb["q0"], L0=pb["L0"], dt=h, steps=steps,
                                     method=method, save_every=steps)
        return go, go()


def _angle(q, q_ref) -> float:
    q = np.asarray(q, dtype=float)
    if not np.all(np.isfinite(q)):
        return math.inf
    return float(liebody.quaternion.angle_between(q / np.linalg.norm(q), q_ref))


def satellite_settings(quick: bool) -> dict:
    return {"quick": quick, "halvings": list(range(0, 6 if quick else 12)),
            "repeat": 3 if quick else 5, "min_batch": 0.005 if quick else 0.02,
            "cap": 0.3 if quick else 3.0,
            "rtols": [10.0**-k for k in range(3, 11 if quick else 13)]}


def satellite_run(cfg: dict, progress: core.Progress) -> dict:
    """Every contender's step ladder and DOP853's tolerance ladder on both satellites,
    against DOP853 at rtol = atol = 1e-13, checked against ``splitting6`` (exact free
    flow) at a fine step: their difference is the reference uncertainty."""
    rows: list[dict] = []
    out: dict = {"problems": {}}
    for key, pb in satellite_problems(cfg["quick"]).items():
        q_ref, _ = _sat_dop853(pb, 1e-13)
        _, check = _sat_liebody(pb, "splitting6", "auto", pb["h_max"] / 64)
        floor = max(_angle(check.q[-1], q_ref), 1e-14)
        bar = progress([*SAT_CONTENDERS, ("scipy DOP853", None, None)], f"satellite {key}")
        for label, method, free_flow in bar:
            if method is None:
                for rtol in cfg["rtols"]:
                    wall, _ = core.median_time(lambda r=rtol, pb=pb: _sat_dop853(pb, r), 1, 0.0)
                    q, nfev = _sat_dop853(pb, rtol)
                    rows.append({"problem": key, "method": label, "setting": rtol,
                                 "steps": nfev, "wall_s": wall, "error": _angle(q, q_ref)})
                    if wall > cfg["cap"]:
                        break
                continue
            for k in cfg["halvings"]:
                h = pb["h_max"] / 2**k
                bar.set_postfix_str(f"{key} {label} h={h:.3g}")
                try:
                    go, tr = _sat_liebody(pb, method, free_flow, h)
                except (liebody.ConvergenceError, ValueError):
                    continue  # an implicit step without a solution: a smaller step
                err = math.inf if tr.failed_at is not None else _angle(tr.q[-1], q_ref)
                wall, _ = core.median_time(go, cfg["repeat"], cfg["min_batch"])
                rows.append({"problem": key, "method": label, "setting": h,
                             "steps": round(pb["T"] / h), "wall_s": wall, "error": err,
                             "free_flow": tr.info.get("free_flow", "")})
                if err < floor or wall > cfg["cap"]:
                    break
        lines: dict[str, list] = {}
        for r in rows:
            if r["problem"] == key:
                lines.setdefault(r["method"], []).append((r["wall_s"], r["error"]))
        table = {}
        for level in SAT_LEVELS:
            costs = {m: cost_at(p, level) for m, p in lines.items()}
            costs = {m: c for m, c in costs.items() if c is not None}
            if not costs or level < floor:
                table[f"{level:.0e}"] = {"best": None}
                continue
            best = min(costs, key=costs.get)
            table[f"{level:.0e}"] = {"best": best, "best_wall_s": costs[best],
                                     "ratio_over_best": {m: (costs[m] / costs[best]
                                                             if m in costs else None)
                                                         for m in lines}}
        out["problems"][key] = {"title": pb["title"], "T": pb["T"],
                                "reference": "DOP853 rtol = atol = 1e-13",
                                "uncertainty": floor, "winners": table}
    out["rows"] = rows
    return out


def satellite_csv(summary: dict) -> tuple[list[str], list[list]]:
    fields = ("problem", "method", "setting", "steps", "wall_s", "error")
    return list(fields), [[r[f] for f in fields] for r in summary["rows"]]


def satellite_plot(summary: dict, plt):
    keys = list(summary["problems"])
    fig, axes = plt.subplots(1, len(keys), figsize=(6.5 * len(keys), 4.8), squeeze=False)
    for ax, key in zip(axes[0], keys, strict=True):
        info = summary["problems"][key]
        names = []
        for r in summary["rows"]:
            if r["problem"] == key and r["method"] not in names:
                names.append(r["method"])
        for name in names:
            pts = sorted((r["wall_s"], r["error"]) for r in summary["rows"]
                         if r["problem"] == key and r["method"] == name
                         and np.isfinite(r["error"]))
            if pts:
                x, y = np.array(pts).T
                style = core.style(name.split()[0] if name != "scipy DOP853" else name)
                style["label"] = name
                if name.endswith(" axes"):
                    style.update(ls="--", marker="x")
                ax.loglog(x, np.clip(y, 1e-16, np.pi), **style)
        ax.axhline(info["uncertainty"], color="0.6", lw=0.8)
        core.label_axes(ax, "wall time of the run [s]",
                        f"orientation error at T = {info['T']:g} s [rad]",
                        f"{info['title']}\n{info['T'] / 3600:g} h")
        ax.legend(fontsize=7, ncol=2, loc="lower left")
    fig.suptitle("Work-precision on a gravity-gradient satellite (lower left is better)")
    return fig


def satellite_report(summary: dict) -> str:
    lines = []
    for key, info in summary["problems"].items():
        lines.append(f"== {key}: {info['title']} (uncertainty {info['uncertainty']:.1e} rad)")
        for level, entry in info["winners"].items():
            if entry["best"] is None:
                lines.append(f"  error {level}: below the reference or not reached")
                continue
            others = ", ".join(f"{m} {'-' if v is None else f'{v:.3g}x'}"
                               for m, v in entry["ratio_over_best"].items() if m != entry["best"])
            lines.append(f"  error {level}: best {entry['best']} ({entry['best_wall_s']:.3g} s);"
                         f" cost / best: {others}")
    return "\n".join(lines)


SATELLITE_BENCHMARK = core.Benchmark(
    name="work_precision_satellite", settings=satellite_settings, run=satellite_run,
    csv=satellite_csv, plot=satellite_plot, report=satellite_report)


if __name__ == "__main__":  # python -m bench.work_precision --satellite [--quick] [--out DIR]
    import argparse

    parser = argparse.ArgumentParser(prog="python -m bench.work_precision")
    parser.add_argument("--satellite", action="store_true", required=True,
                        help="the gravity-gradient satellites (the chart of the method guide)")
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--out", default=core.DEFAULT_OUT)
    args = parser.parse_args()
    print(satellite_report(core.measure(SATELLITE_BENCHMARK, args.out, args.quick)))
