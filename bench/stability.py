"""Stability: where each method fails, and how.

Three experiments, one chart (``stability.png``, three panels):

(a) **Free body, step-size sweep.** The ``asym`` problem (I = (0.6, 0.8, 1.0)) with every
    registered stepping method, for ``x = h |omega_0|`` on a log grid from 0.01 to 10.
    Each run takes ``max(min_steps, min_periods * P / h)`` steps, where ``P`` is the
    period of the body-frame momentum ``L(t)`` (about 6.9 for ``asym``), so that every
    quarter of the run holds several periods. Recorded per run: the maximum relative
    energy error ``max |E/E0 - 1|``, ``max ||q| - 1|``, ``max ||L|/|L0| - 1|`` and whether
    the run failed (state became non-finite, ``ConvergenceError`` from ``rattle``/``dmv*``
    when the implicit step has no solution, ``ValueError`` from ``dmv4``..``dmv10`` when
    the step makes the modified moments negative).

    *Energy bounded* (the criterion, also in the JSON under ``definitions``): the run
    completes with a finite state, ``max |E/E0 - 1| <= 0.05``, and the error does not
    grow: with ``e_1`` and ``e_4`` the maxima over the first and the last quarter of the
    run, ``e_4 > 2 e_1`` counts as growth unless ``e_4 <= 1e-10`` (round-off). The
    threshold is 5 %, not 10 %: the Casimir-preserving methods keep ``|L|``, and on
    that sphere ``asym``'s energy can rise by at most 9.5 % (all momentum on the
    smallest-moment axis), so Lie–Euler, which saturates there, could never cross a
    10 % bound upwards. The splittings never blow up either (every sub-flow is an exact
    rotation) but their accuracy collapses, and the threshold catches that.

    *Quaternion norm bounded*: the run completes with a finite state and
    ``max |q| <= 1.1``. RK4 applied to ``q' = q (0, omega) / 2`` with frozen ``omega``
    has ``|R(iy)|^2 = 1 - y^6/72 + y^8/576``, ``y = h |omega| / 2``, so ``|q|`` shrinks
    for ``h |omega| < 4 sqrt 2 = 5.66`` and grows beyond; explicit Euler grows ``|q|``
    at every step size.

    The failure point of a method under a criterion is the smallest swept ``x`` at
    which it fails; it is then bracketed by bisection (in ``log x``) between that point
    and the passing point below it, and the smallest failing ``x`` found is reported
    as ``x_refined``. Swept points above the failure point at which the method passes
    again are listed as ``recovers_at``.

(b) **Heavy top, resonance.** The Simo–Wong fast top (``top``, nutation frequency
    ``omega_nut = 10``) with every method that integrates a ``HeavyTop``, for
    ``x = h omega_nut`` on a log grid from 0.1 to 10 plus a fine grid around
    ``2 pi``, each run ``ceil(T/h)`` steps (``T = 20``). The maximum relative energy
    error is recorded, the same *energy bounded* criterion gives the failure point,
    and the step-size resonance of the kick–drift splitting at ``h omega_nut = 2 pi``
    is located: per method, the ``x`` of the largest energy error between
    ``0.8 * 2 pi`` and ``1.25 * 2 pi``, its value and its ratio to the value at
    ``x = 4``.

(c) **Euler angles near gimbal lock.** A free symmetric body, I = (1, 1, 0.5), with
    ``|L| = 1``, its symmetry axis at ``alpha = 0.5`` from ``L``, and ``L`` tilted by
    ``alpha + theta_min`` from the vertical, so that the symmetry axis cones around
    ``L`` and its z-x-z Euler angle ``theta`` (the angle between body and space z-axes)
    oscillates between ``theta_min`` and ``2 alpha + theta_min``; the run starts at the
    largest ``theta`` and passes the closest approach twice (two precession periods,
    ``2 pi I_1/|L|`` each). The *same* classical RK4, same step, is applied (i) to the
    Euler angles with ``L`` from Euler's equations, a 6-dimensional system whose
    kinematics (:func:`liebody.euler.rates`) divide by ``sin theta``, and (ii) to
    ``(q, L)`` (liebody's ``rk4``). Both ``L`` histories are the same RK4 on the same
    equations; only the attitude coordinates differ. Reported: the angle between the
    computed and the exact final rotation (``method="exact"``), against ``theta_min``
    from 1e-1 down to 1e-6.

Outputs: ``stability.json`` (sweeps, failure points, resonance peaks, gimbal-lock
errors, the settings and the machine), ``stability.csv`` (one row per run) and
``stability.png``.

Run ``python -m bench --only stability [--quick]``.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable

import numpy as np

import liebody
from bench import core
from bench.problems import Problem, energy, problems
from liebody import analysis, euler, quaternion

#: relative energy error above which the energy no longer counts as bounded
E_TOL = 0.05
#: growth of the energy error (last quarter over first quarter) that counts as growth
GROWTH_FACTOR = 2.0
#: energy errors at or below this never count as growth (round-off random walk)
GROWTH_FLOOR = 1e-10
#: ``|q|`` above ``1 + Q_TOL`` counts as a growing quaternion norm
Q_TOL = 0.1
#: RK4's linear stability limit for the quaternion kinematics, ``h |omega| = 4 sqrt 2``
RK4_Q_LIMIT = 4.0 * math.sqrt(2.0)
#: where energy errors are drawn on the charts when larger or non-finite
_CEIL = 10.0
_FLOOR = 1e-16


def settings(quick: bool) -> dict:
    """Sweep sizes for the quick (about 15 s) or full (a few minutes) run."""
    if quick:
        return {"free_problem": "asym", "free_x": [0.01, 10.0], "free_points": 10,
                "free_min_steps": 1000, "free_min_periods": 8, "bisections": 4,
                "top_problem": "top", "top_x": [0.1, 10.0], "top_points": 9,
                "top_fine": [5.8, 7.0, 13], "top_T": 20.0,
                "gimbal_moments": [1.0, 1.0, 0.5], "gimbal_alpha": 0.5,
                "gimbal_theta_min": [1e-1, 1e-6], "gimbal_points": 6, "gimbal_h": [0.01],
                "gimbal_periods": 2}
    return {"free_problem": "asym", "free_x": [0.01, 10.0], "free_points": 40,
            "free_min_steps": 2000, "free_min_periods": 20, "bisections": 8,
            "top_problem": "top", "top_x": [0.1, 10.0], "top_points": 33,
            "top_fine": [5.6, 7.2, 81], "top_T": 20.0,
            "gimbal_moments": [1.0, 1.0, 0.5], "gimbal_alpha": 0.5,
            "gimbal_theta_min": [1e-1, 1e-6], "gimbal_points": 16, "gimbal_h": [0.01, 0.001],
            "gimbal_periods": 2}


def definitions() -> dict:
    """The failure criteria, as written to the JSON."""
    return {
        "energy_bounded": (
            f"run finite (no exception, no non-finite state), max |E/E0 - 1| <= {E_TOL:g}, "
            f"and no growth: max over the last quarter of the run <= {GROWTH_FACTOR:g} x max "
            f"over the first quarter, or <= {GROWTH_FLOOR:g}"),
        "qnorm_bounded": f"run finite and max |q| <= {1 + Q_TOL:g}",
        "failure_point": (
            "smallest swept x at which the criterion fails; 'x_refined' is the smallest "
            "failing x found by bisection in log x between it and the passing point below; "
            "null where the method never fails in the sweep"),
        "resonance_peak": "x of the largest max |E/E0 - 1| in [0.8, 1.25] x 2 pi",
        "orientation_error": "angle [rad] of the rotation between computed and exact, at T",
    }


# ------------------------------------------------------------------------------- runs


def _rel_energy(problem: Problem, q: np.ndarray, L: np.ndarray) -> np.ndarray:
    """``|E/E0 - 1|`` with the potential taken at ``q/|q|`` (the rotation a baseline's
    drifting quaternion stands for); non-finite where ``q`` vanished or overflowed."""
    with np.errstate(all="ignore"):
        rotation = q / np.linalg.norm(q, axis=-1, keepdims=True)
        return np.abs(energy(problem, rotation, L) / problem.E0 - 1.0)


def _grows(e: np.ndarray) -> tuple[bool, float]:
    """Whether the error grows (last quarter against first quarter) and by how much."""
    k = max(1, len(e) // 4)
    first, last = float(e[:k].max()), float(e[-k:].max())
    ratio = last / first if first > 0 else (math.inf if last > 0 else 1.0)
    return bool(last > GROWTH_FACTOR * first and last > GROWTH_FLOOR), ratio


def run_case(problem: Problem, method: str, x: float, h: float, steps: int) -> dict:
    """One run: its diagnostics and the verdict of both criteria.

    Parameters
    ----------
    problem
        The benchmark problem (initial state, scene).
    method
        A registered stepping method.
    x
        The swept variable (``h |omega_0|`` or ``h omega_nut``), recorded as given.
    h, steps
        Step and number of steps.

    Returns
    -------
    dict
        ``x``, ``h``, ``steps``, ``T``, ``status`` (``"ok"``, ``"non-finite at t=..."``
        or the exception's name), ``max_rel_energy_error``, ``max_q_norm_drift``,
        ``min_q_norm``, ``max_q_norm``, ``max_L_norm_drift``, ``growth`` (last/first quarter),
        ``energy_bounded``, ``qnorm_bounded`` and ``reason`` (why the energy is not
        bounded; empty when it is).
    """
    row = {"x": float(x), "h": float(h), "steps": int(steps), "T": float(h * steps),
           "status": "ok", "max_rel_energy_error": None, "max_q_norm_drift": None,
           "min_q_norm": None, "max_q_norm": None, "max_L_norm_drift": None, "growth": None,
           "energy_bounded": False, "qnorm_bounded": False, "reason": ""}
    try:
        tr = problem.integrate(method, h, steps)
    except liebody.ConvergenceError:
        row.update(status="ConvergenceError", reason="implicit step has no solution")
        return row
    except ValueError as exc:
        row.update(status="ValueError", reason=f"step rejected: {str(exc)[:90]}")
        return row
    e = _rel_energy(problem, tr.q, tr.L)
    with np.errstate(all="ignore"):
        nq = np.linalg.norm(tr.q, axis=-1)
        nL = np.linalg.norm(tr.L, axis=-1) / np.linalg.norm(problem.L0)
        row.update(max_rel_energy_error=float(np.max(e)),
                   max_q_norm_drift=float(np.max(np.abs(nq - 1.0))),
                   min_q_norm=float(np.min(nq)), max_q_norm=float(np.max(nq)),
                   max_L_norm_drift=float(np.max(np.abs(nL - 1.0))))
    if tr.failed_at is not None:
        row.update(status=f"non-finite at t={tr.failed_at:.4g}", reason="state non-finite")
        return row
    if not np.all(np.isfinite(e)):
        row.update(status="non-finite energy", reason="energy non-finite")
        return row
    grows, ratio = _grows(e)
    row["growth"] = ratio
    row["qnorm_bounded"] = bool(np.all(np.isfinite(nq)) and nq.max() <= 1.0 + Q_TOL)
    if row["max_rel_energy_error"] > E_TOL:
        row["reason"] = f"error > {E_TOL:g}"
    elif grows:
        row["reason"] = f"error grows x{ratio:.3g}"
    else:
        row["energy_bounded"] = True
    return row


def failure_point(rows: list[dict], key: str, evaluate: Callable[[float], dict],
                  bisections: int) -> dict:
    """Smallest swept ``x`` failing ``key`` (``energy_bounded`` or ``qnorm_bounded``),
    bracketed by bisection in ``log x``.

    Parameters
    ----------
    rows
        The sweep, sorted by ``x``.
    key
        The criterion.
    evaluate
        ``x -> row`` (a fresh run at ``x``), used by the bisection.
    bisections
        Number of halvings of the bracket (in ``log x``).

    Returns
    -------
    dict
        ``x`` (grid point, or ``None``), ``x_refined``, ``bracket`` ``[last pass, first
        fail]``, ``reason``, ``status`` and ``max_rel_energy_error`` of the refined failing run,
        ``pass_max_rel_energy_error`` of the last passing one, ``recovers_at`` (swept
        ``x`` above the failure point that pass) and ``bisection`` (the bisection's
        runs, as :func:`columns`).
    """
    first = next((i for i, r in enumerate(rows) if not r[key]), None)
    if first is None:
        return {"x": None, "x_refined": None, "bracket": None, "reason": "", "status": None,
                "max_rel_energy_error": None, "pass_max_rel_energy_error": None,
                "recovers_at": [], "bisection": columns([])}
    fail_row = rows[first]
    pass_row = rows[first - 1] if first > 0 else None
    extra = []
    if pass_row is not None:
        a, b = math.log(pass_row["x"]), math.log(fail_row["x"])
        for _ in range(bisections):
            mid = math.exp(0.5 * (a + b))
            r = evaluate(mid)
            extra.append(r)
            if r[key]:
                a, pass_row = math.log(mid), r
            else:
                b, fail_row = math.log(mid), r
    reason = fail_row["reason"] if key == "energy_bounded" else (
        fail_row["status"] if fail_row["status"] != "ok" else
        f"|q| up to {fail_row['max_q_norm']:.3g}")
    return {"x": rows[first]["x"], "x_refined": fail_row["x"],
            "bracket": [None if pass_row is None else pass_row["x"], fail_row["x"]],
            "reason": reason, "status": fail_row["status"],
            "max_rel_energy_error": fail_row["max_rel_energy_error"],
            "pass_max_rel_energy_error": (None if pass_row is None
                                          else pass_row["max_rel_energy_error"]),
            "recovers_at": [r["x"] for r in rows[first + 1:] if r[key]],
            "bisection": columns(extra)}


_COLUMNS = ("x", "h", "steps", "T", "status", "max_rel_energy_error", "max_q_norm_drift",
            "min_q_norm", "max_q_norm", "max_L_norm_drift", "growth", "energy_bounded",
            "qnorm_bounded", "reason")


def columns(rows: list[dict]) -> dict:
    """Rows of :func:`run_case` as one list per field (the JSON's ``sweep``)."""
    return {k: [r[k] for r in rows] for k in _COLUMNS}


def rows_of(sweep: dict) -> list[dict]:
    """Inverse of :func:`columns`."""
    return [dict(zip(sweep, vals, strict=True)) for vals in zip(*sweep.values(), strict=True)]


# ------------------------------------------------------------------ (a) free-body sweep


def momentum_period(problem: Problem) -> float:
    """Period of the body-frame momentum ``L(t)`` of a free body.

    For an asymmetric body, :func:`liebody.analysis.flip_period` (Landau & Lifshitz,
    *Mechanics*, §37: ``4 K(m) / nu``; ``L`` flips every half period); for a symmetric
    body or a steady rotation (no flips), ``2 pi / |omega_0|``.
    """
    try:
        return analysis.flip_period(problem.moments, problem.L0)
    except ValueError:
        return 2.0 * math.pi / problem.omega_max


def free_body_sweep(cfg: dict, bar) -> dict:
    """Panel (a): every method on the free body across ``x = h |omega_0|``."""
    pb = problems()[cfg["free_problem"]]
    period = momentum_period(pb)
    w0 = pb.omega_max
    xs = np.geomspace(*cfg["free_x"], cfg["free_points"])

    def steps(x: float) -> int:
        h = x / w0
        return max(cfg["free_min_steps"], math.ceil(cfg["free_min_periods"] * period / h))

    L2 = float(pb.L0 @ pb.L0)
    exact = pb.integrate("exact", period / 2000, 2000)
    w = np.linalg.norm(exact.L / pb.moments, axis=-1)
    out = {"problem": pb.key, "title": pb.title, "omega0": w0, "E0": pb.E0,
           "momentum_period": period, "x_name": "h |omega_0|",
           "omega_range_on_orbit": [float(w.min()), float(w.max())],
           "energy_range_on_momentum_sphere": [L2 / (2 * pb.moments.max() * pb.E0) - 1,
                                               L2 / (2 * pb.moments.min() * pb.E0) - 1],
           "rk4_qnorm_limit_theory": RK4_Q_LIMIT,
           # in x = h |omega_0|: |q| grows where h |omega(t)| > 4 sqrt 2 somewhere / everywhere
           "rk4_qnorm_limit_theory_on_orbit": [RK4_Q_LIMIT * w0 / float(w.max()),
                                               RK4_Q_LIMIT * w0 / float(w.min())],
           "methods": {}}
    for m in pb.methods():
        bar.set_postfix_str(f"free body {m}")

        def evaluate(x: float, m: str = m) -> dict:
            n = steps(x)
            return run_case(pb, m, x, x / w0, n)

        rows = [evaluate(float(x)) for x in xs]
        fe = failure_point(rows, "energy_bounded", evaluate, cfg["bisections"])
        fq = failure_point(rows, "qnorm_bounded", evaluate, cfg["bisections"])
        decays = [r["x"] for r in rows if r["min_q_norm"] is not None and r["min_q_norm"] < 0.9]
        out["methods"][m] = {"sweep": columns(rows), "energy_failure": fe, "qnorm_failure": fq,
                             "qnorm_below_0.9_from_x": decays[0] if decays else None}
        bar.update(1)
    return out


# ------------------------------------------------------------------- (b) heavy-top sweep


def top_grid(cfg: dict) -> np.ndarray:
    """Log grid from ``top_x`` plus the fine grid around ``2 pi`` and the point ``x = 4``."""
    lo, hi, n = cfg["top_fine"]
    xs = np.concatenate([np.geomspace(*cfg["top_x"], cfg["top_points"]),
                         np.linspace(lo, hi, int(n)), [4.0]])
    return np.unique(np.round(xs, 12))


def resonance_peak(rows: list[dict]) -> dict:
    """Largest energy error in ``[0.8, 1.25] x 2 pi`` and its ratio to the value at 4."""
    two_pi = 2.0 * math.pi
    win = [r for r in rows if 0.8 * two_pi <= r["x"] <= 1.25 * two_pi
           and r["status"] == "ok" and r["max_rel_energy_error"] is not None]
    at4 = next((r["max_rel_energy_error"] for r in rows
                if abs(r["x"] - 4.0) < 1e-9 and r["status"] == "ok"), None)
    if not win:
        return {"x": None, "max_rel_energy_error": None, "at_x4": at4, "ratio_to_x4": None}
    best = max(win, key=lambda r: r["max_rel_energy_error"])
    e = best["max_rel_energy_error"]
    return {"x": best["x"], "offset_from_2pi": best["x"] - two_pi, "max_rel_energy_error": e,
            "at_x4": at4, "ratio_to_x4": (e / at4) if at4 else None}


def top_sweep(cfg: dict, bar) -> dict:
    """Panel (b): the torqued methods on the fast heavy top across ``x = h omega_nut``."""
    pb = problems()[cfg["top_problem"]]
    w_nut = float(pb.extra["omega_nutation"])
    T = cfg["top_T"]
    xs = top_grid(cfg)
    out = {"problem": pb.key, "title": pb.title, "omega_nutation": w_nut, "T": T,
           "E0": pb.E0, "x_name": "h omega_nut", "methods": {}}
    for m in pb.methods():
        bar.set_postfix_str(f"heavy top {m}")

        def evaluate(x: float, m: str = m) -> dict:
            h = x / w_nut
            return run_case(pb, m, x, h, math.ceil(T / h - 1e-9))

        rows = [evaluate(float(x)) for x in xs]
        fe = failure_point(rows, "energy_bounded", evaluate, cfg["bisections"])
        out["methods"][m] = {"sweep": columns(rows), "energy_failure": fe,
                             "resonance_peak": resonance_peak(rows)}
        bar.update(1)
    return out


# --------------------------------------------------------------------- (c) gimbal lock


def _euler_rhs(y: np.ndarray, moments: np.ndarray) -> np.ndarray:
    """``(phi, theta, psi, L)' `` for rows ``y`` of shape ``(k, 6)``: z-x-z angle rates
    from the body angular velocity (singular at ``sin theta = 0``) and Euler's
    equations ``L' = L x omega``."""
    L = y[:, 3:]
    w = L / moments
    rates = euler.rates(y[:, :3], w, tol=0.0, singular="nan")
    return np.concatenate([rates, np.cross(L, w)], axis=1)


def rk4_euler_angles(y0: np.ndarray, moments: np.ndarray, h: float, steps: int) -> np.ndarray:
    """Classical RK4 on the Euler-angle system, all rows at once; returns the final rows."""
    y = np.array(y0, dtype=float)
    with np.errstate(all="ignore"):
        for _ in range(steps):
            k1 = _euler_rhs(y, moments)
            k2 = _euler_rhs(y + 0.5 * h * k1, moments)
            k3 = _euler_rhs(y + 0.5 * h * k2, moments)
            k4 = _euler_rhs(y + h * k3, moments)
            y = y + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    return y


def gimbal_initial(theta_min: float, alpha: float) -> tuple[np.ndarray, np.ndarray]:
    """Initial ``(q0, L0)`` (``|L| = 1``) whose symmetry axis comes within ``theta_min``
    of the vertical: body z-axis tilted by ``2 alpha + theta_min`` about space y, ``L``
    at ``alpha`` from it towards the vertical."""
    g = 2.0 * alpha + theta_min
    q0 = np.array([math.cos(g / 2), 0.0, math.sin(g / 2), 0.0])
    L0 = np.array([-math.sin(alpha), 0.0, math.cos(alpha)])
    return q0, L0


def _gimbal_stats(thetas: np.ndarray, err_angles: list, err_quat: list) -> dict:
    """Slope of log(error) against log(theta_min) over the first decade of the sweep,
    the largest Euler-angle error and where it occurs, the worst quaternion error."""
    ea = np.array([np.nan if e is None else e for e in err_angles])
    sel = (thetas >= thetas[0] / 10.0 * (1 - 1e-9)) & np.isfinite(ea) & (ea > 0)
    slope = (float(np.polyfit(np.log(thetas[sel]), np.log(ea[sel]), 1)[0])
             if sel.sum() >= 2 else None)
    k = int(np.nanargmax(ea)) if np.any(np.isfinite(ea)) else None
    return {"euler_angles_slope_first_decade": slope,
            "euler_angles_peak": None if k is None else {"theta_min": float(thetas[k]),
                                                         "error": float(ea[k])},
            "quaternion_max_error": float(np.max(err_quat))}


def gimbal_sweep(cfg: dict, bar) -> dict:
    """Panel (c): RK4 on Euler angles against RK4 on quaternions near gimbal lock."""
    moments = np.array(cfg["gimbal_moments"], dtype=float)
    alpha = cfg["gimbal_alpha"]
    scene = liebody.FreeBody(liebody.RigidBody(moments))
    thetas = np.geomspace(*cfg["gimbal_theta_min"], cfg["gimbal_points"])
    inits = [gimbal_initial(float(t), alpha) for t in thetas]
    q0s = np.array([q for q, _ in inits])
    L0s = np.array([L for _, L in inits])
    t_prec = 2.0 * math.pi * moments[0]  # |L| = 1
    t_closest = 0.5 * t_prec
    # the exact flow at the closest approach checks the construction
    th_exact = []
    for q0, L0 in inits:
        tr = liebody.integrate(scene, q0=q0, L0=L0, dt=t_closest, steps=1, method="exact")
        th_exact.append(float(euler.from_quaternion(tr.q[-1])[1]))
    out = {"moments": moments.tolist(), "alpha": alpha, "precession_period": t_prec,
           "theta_min": thetas.tolist(), "theta_at_closest_approach_exact": th_exact,
           "x_name": "theta_min", "runs": []}
    y0 = np.concatenate([euler.from_quaternion(q0s), L0s], axis=1)
    for h in cfg["gimbal_h"]:
        bar.set_postfix_str(f"gimbal lock h={h:g}")
        n = round(cfg["gimbal_periods"] * t_prec / h)
        t0 = time.perf_counter()
        y = rk4_euler_angles(y0, moments, h, n)
        wall_angles = time.perf_counter() - t0
        err_angles, err_quat, q_exact = [], [], []
        for k, (q0, L0) in enumerate(inits):
            ex = liebody.integrate(scene, q0=q0, L0=L0, dt=n * h, steps=1, method="exact")
            qe = ex.q[-1]
            r4 = liebody.integrate(scene, q0=q0, L0=L0, dt=h, steps=n, method="rk4",
                                   save_every=n)
            err_quat.append(float(quaternion.angle_between(quaternion.normalize(r4.q[-1]), qe)))
            if np.all(np.isfinite(y[k])):
                qa = euler.to_quaternion(y[k, :3])
                err_angles.append(float(quaternion.angle_between(qa, qe)))
            else:
                err_angles.append(None)
            q_exact.append(qe)
        out["runs"].append({"h": h, "steps": n, "T": n * h,
                            "euler_angles_rk4": err_angles, "quaternion_rk4": err_quat,
                            "wall_s_euler_angles": wall_angles,
                            **_gimbal_stats(thetas, err_angles, err_quat)})
        bar.update(1)
    return out


# ----------------------------------------------------------------------------- driver


def run(cfg: dict, progress: core.Progress) -> dict:
    """The three experiments."""
    n_jobs = (len(problems()[cfg["free_problem"]].methods())
              + len(problems()[cfg["top_problem"]].methods()) + len(cfg["gimbal_h"]))
    bar = progress(None, "stability", total=n_jobs)
    try:
        return {"definitions": definitions(), "free_body": free_body_sweep(cfg, bar),
                "heavy_top": top_sweep(cfg, bar), "gimbal_lock": gimbal_sweep(cfg, bar)}
    finally:
        bar.close()


_CSV_HEADER = ["panel", "problem", "method", "kind", "x_name", "x", "h", "steps", "T", "status",
               "max_rel_energy_error", "max_q_norm_drift", "max_L_norm_drift",
               "energy_bounded", "qnorm_bounded", "orientation_error"]


def csv_table(summary: dict) -> tuple[list[str], list[list]]:
    """One row per run: the sweeps, the bisections, the gimbal-lock errors."""
    rows = []
    for panel in ("free_body", "heavy_top"):
        info = summary[panel]
        for m, d in info["methods"].items():
            runs = [(r, "sweep") for r in rows_of(d["sweep"])]
            runs += [(r, "bisection") for fp in ("energy_failure", "qnorm_failure") if fp in d
                     for r in rows_of(d[fp]["bisection"])]
            for r, kind in runs:
                rows.append([panel, info["problem"], m, kind, info["x_name"], r["x"], r["h"],
                             r["steps"], r["T"], r["status"], r["max_rel_energy_error"],
                             r["max_q_norm_drift"], r["max_L_norm_drift"],
                             r["energy_bounded"], r["qnorm_bounded"], None])
    g = summary["gimbal_lock"]
    for run_ in g["runs"]:
        for label in ("euler_angles_rk4", "quaternion_rk4"):
            for th, err in zip(g["theta_min"], run_[label], strict=True):
                rows.append(["gimbal_lock", "symmetric free body", label, "sweep", g["x_name"],
                             th, run_["h"], run_["steps"], run_["T"],
                             "ok" if err is not None else "non-finite", None, None, None, None,
                             None, err])
    return _CSV_HEADER, rows


# ------------------------------------------------------------------------------ chart


def _energy_curve(rows: list[dict]) -> tuple[np.ndarray, np.ndarray]:
    """x and the energy error to draw: clipped to ``[_FLOOR, _CEIL]``, non-finite runs at
    ``_CEIL``, runs that raised left out (NaN: the line breaks)."""
    x = np.array([r["x"] for r in rows])
    y = np.array([math.nan if r["status"] in ("ConvergenceError", "ValueError")
                  else (_CEIL if r["status"] != "ok" or r["max_rel_energy_error"] is None
                        else r["max_rel_energy_error"]) for r in rows], dtype=float)
    return x, np.clip(y, _FLOOR, _CEIL)


def _marker_y(fp: dict) -> float:
    """Height of a failure marker: the failing run's energy error; where that run raised,
    the last passing run's (the end of the line); where it blew up, the ceiling."""
    if fp["status"] in _RAISED:
        e = fp["pass_max_rel_energy_error"]
        return _CEIL if e is None else float(np.clip(e, _FLOOR, _CEIL))
    e = fp["max_rel_energy_error"]
    if e is None or not np.isfinite(e):
        return _CEIL
    return float(np.clip(e, _FLOOR, _CEIL))


_RAISED = ("ConvergenceError", "ValueError")
_E_LABEL = "max |E/E₀ − 1|"


def _sweep_panel(ax, info: dict, with_q: bool, label_at: float | None) -> None:
    for m, d in info["methods"].items():
        st = core.style(m)
        x, y = _energy_curve(rows_of(d["sweep"]))
        ax.loglog(x, y, lw=1.2, **(st | {"ms": 2.5}))
        fe = d["energy_failure"]
        if fe["x_refined"] is not None:
            ax.plot(fe["x_refined"], _marker_y(fe), marker="*", ms=13, color=st["color"],
                    mec="k", mew=0.6, ls="none", zorder=6)
        fq = d.get("qnorm_failure")
        if with_q and fq and fq["x_refined"] is not None and fq["reason"].startswith("|q|"):
            ax.plot(fq["x_refined"], _marker_y(fq), marker="v", ms=9, color=st["color"],
                    mec="k", mew=0.6, ls="none", zorder=6)
    ax.axhline(E_TOL, color="0.3", lw=0.9, ls="-.",
               label=f"bounded-energy threshold {E_TOL:g}" if label_at is None else None)
    if label_at is not None:
        ax.text(label_at, E_TOL, f"bounded-energy threshold {E_TOL:g} ", color="0.3", fontsize=7,
                va="top", ha="right", transform=ax.get_yaxis_transform())
    ax.grid(True, which="both", alpha=0.25)


def plot(summary: dict, plt):
    """The three panels in one figure ((b) with a linear zoom on the resonance)."""
    from matplotlib.lines import Line2D

    fig = plt.figure(figsize=(16, 12.5))
    gs = fig.add_gridspec(2, 3, height_ratios=[1.1, 1.0], width_ratios=[1.25, 0.75, 1.1])
    ax_a = fig.add_subplot(gs[0, :])
    ax_b = fig.add_subplot(gs[1, 0])
    ax_z = fig.add_subplot(gs[1, 1])
    ax_c = fig.add_subplot(gs[1, 2])

    # (a) free body
    fb = summary["free_body"]
    _sweep_panel(ax_a, fb, with_q=True, label_at=0.3)
    ax_a.set_ylim(_FLOOR * 0.5, _CEIL * 3)
    ax_a.axvline(RK4_Q_LIMIT, color="k", lw=0.8, ls=":")
    ax_a.text(RK4_Q_LIMIT, 1e-15, " RK4 |q| limit\n h|ω| = 4√2", fontsize=7, va="bottom")
    n_min = min(n for d in fb["methods"].values() for n in d["sweep"]["steps"])
    core.label_axes(ax_a, "h |ω₀|  (step × initial angular speed) [rad]",
                    _E_LABEL + " over the run [–]",
                    f"(a) {fb['title']}: max relative energy error, every method "
                    f"(≥ {n_min} steps and ≥ {summary['settings']['free_min_periods']} "
                    f"periods of L(t) per run; ≥ {_CEIL:g} or non-finite drawn at {_CEIL:g}; "
                    "a line that stops: implicit step has no solution)", title_size=9.5)
    handles, labels = ax_a.get_legend_handles_labels()
    handles += [Line2D([], [], marker="*", ms=11, color="0.6", mec="k", ls="none"),
                Line2D([], [], marker="v", ms=8, color="0.6", mec="k", ls="none")]
    labels += ["energy no longer bounded\n(refined failure point)",
               f"|q| grows above {1 + Q_TOL:g}\n(refined failure point)"]
    ax_a.legend(handles, labels, fontsize=7.5, loc="upper left", bbox_to_anchor=(1.005, 1.0),
                ncol=1, frameon=False)

    # (b) heavy top, and its zoom on the resonance
    tp = summary["heavy_top"]
    _sweep_panel(ax_b, tp, with_q=False, label_at=None)
    ax_b.set_ylim(_FLOOR * 0.5, 1e6)
    ax_b.axvline(2 * math.pi, color="k", lw=0.8, ls=":")
    core.label_axes(ax_b, "h ω_nut  (step × nutation frequency) [rad]",
                    _E_LABEL + " over the run [–]",
                    f"(b) {tp['title']}\nmax relative energy error over T = {tp['T']:g}, "
                    f"ω_nut = {tp['omega_nutation']:g} rad/s (★: energy no longer bounded)",
                    title_size=9.5)
    ax_b.legend(fontsize=7, ncol=3, loc="upper center", columnspacing=0.8)
    lo, hi = summary["settings"]["top_fine"][:2]
    for m, d in tp["methods"].items():
        if liebody.methods()[m].family == "baseline":
            continue
        st = core.style(m)
        x, y = _energy_curve(rows_of(d["sweep"]))
        keep = (x >= lo - 1e-9) & (x <= hi + 1e-9)
        if np.all(np.isnan(y[keep])):
            continue
        ax_z.semilogy(x[keep], y[keep], lw=1.2, **(st | {"ms": 2.5}))
        pk = d["resonance_peak"]
        if pk["x"] is not None and lo <= pk["x"] <= hi:
            ax_z.plot(pk["x"], pk["max_rel_energy_error"], marker="o", ms=9, mfc="none",
                      mec=st["color"], mew=1.5, ls="none")
    ax_z.axvline(2 * math.pi, color="k", lw=0.8, ls=":")
    ax_z.text(2 * math.pi, 0.3, "h ω_nut = 2π ", fontsize=8, rotation=90, ha="right",
              va="center", transform=ax_z.get_xaxis_transform())
    ax_z.set_xlim(lo, hi)
    core.label_axes(ax_z, "h ω_nut [rad] (linear)", _E_LABEL + " [–]",
                    "(b) zoom: step-size resonance of the\nkick–drift splittings (○: peak)",
                    title_size=9.5)
    ax_z.legend(fontsize=7, loc="lower right")

    # (c) gimbal lock
    g = summary["gimbal_lock"]
    th = np.array(g["theta_min"])
    styles = ["-", "--", ":"]
    for i, run_ in enumerate(g["runs"]):
        ls = styles[i % len(styles)]
        ea = np.array([math.pi if e is None else e for e in run_["euler_angles_rk4"]])
        ax_c.loglog(th, np.maximum(ea, _FLOOR), color="#d62728", marker="s", ms=4, ls=ls,
                    label=f"RK4 on Euler angles (φ, θ, ψ), h = {run_['h']:g}")
        ax_c.loglog(th, np.maximum(run_["quaternion_rk4"], _FLOOR), color="k", marker="o",
                    ms=4, ls=ls, label=f"RK4 on quaternions (liebody rk4), h = {run_['h']:g}")
    first = g["runs"][0]["euler_angles_rk4"][0]
    if first is not None and len(th) > 1:
        guide = th[th >= th[0] / 30]
        ax_c.loglog(guide, 30 * first * (guide / th[0]) ** -3, color="0.4", lw=1.0, ls=":",
                    label="slope guide ∝ θ_min⁻³")
    ax_c.invert_xaxis()
    core.label_axes(ax_c, "closest approach to gimbal lock θ_min (z-x-z) [rad]",
                    "orientation error at T, angle to the exact rotation [rad]",
                    f"(c) Euler angles near gimbal lock: free symmetric body "
                    f"I = {tuple(g['moments'])},\nT = {g['runs'][0]['T']:.4g} "
                    f"(two close approaches), same RK4 and step for both", title_size=9.5)
    ax_c.legend(fontsize=7.5, loc="lower right", bbox_to_anchor=(1.0, 0.08))

    fig.suptitle("Stability: where each method fails", fontsize=13)
    return fig


# ----------------------------------------------------------------------------- report


def _fmt(v: float | None, spec: str = ".3g") -> str:
    return "-" if v is None else format(v, spec)


def report(summary: dict) -> str:
    """Failure points, resonance peaks and gimbal-lock errors as plain text."""
    lines = []
    fb = summary["free_body"]
    lines.append(f"== (a) {fb['title']}: x = h|omega_0| (|omega_0| = {fb['omega0']:.4g}), "
                 f"energy bounded = {summary['definitions']['energy_bounded']}")
    lines.append(f"   {'method':<11} {'energy: grid x':>14} {'refined':>8}  {'why':<30} "
                 f"{'|q|: grid x':>11} {'refined':>8}  why")
    for m, d in fb["methods"].items():
        fe, fq = d["energy_failure"], d["qnorm_failure"]
        n_rec = len(fe["recovers_at"])
        rec = f" [energy ok again at {n_rec} larger x]" if n_rec else ""
        lines.append(f"   {m:<11} {_fmt(fe['x']):>14} {_fmt(fe['x_refined'], '.4g'):>8}  "
                     f"{(fe['reason'] or 'never fails')[:30]:<30} {_fmt(fq['x']):>11} "
                     f"{_fmt(fq['x_refined'], '.4g'):>8}  {(fq['reason'] or '-')[:24]}{rec}")
    lo, hi = fb["rk4_qnorm_limit_theory_on_orbit"]
    rk4 = fb["methods"].get("rk4")
    lines.append(f"   theory: RK4 |q| grows for h|omega| > 4 sqrt 2 = {RK4_Q_LIMIT:.4g}; "
                 f"|omega| on the orbit is {fb['omega_range_on_orbit'][0]:.4g}..."
                 f"{fb['omega_range_on_orbit'][1]:.4g}, i.e. x = {lo:.4g}...{hi:.4g}")
    if rk4 is not None:
        lines.append(f"   rk4: |q| shrinks below 0.9 from x = {_fmt(rk4['qnorm_below_0.9_from_x'])}"
                     f" (|R(iy)| < 1 below the limit)")
    tp = summary["heavy_top"]
    lines.append(f"== (b) {tp['title']}: x = h omega_nut, T = {tp['T']:g}")
    for m, d in tp["methods"].items():
        fe, pk = d["energy_failure"], d["resonance_peak"]
        rec = f"; passes again at {len(fe['recovers_at'])} larger x" if fe["recovers_at"] else ""
        peak = ("no finite run near 2 pi" if pk["x"] is None else
                f"peak near 2 pi at x = {pk['x']:.4g} (max|dE|/E0 = "
                f"{pk['max_rel_energy_error']:.3g}, {_fmt(pk['ratio_to_x4'])}x the value at x=4)")
        lines.append(f"   {m:<11} energy fails at x = {_fmt(fe['x_refined'], '.4g')} "
                     f"({fe['reason'] or 'never'}{rec}); {peak}")
    g = summary["gimbal_lock"]
    lines.append(f"== (c) gimbal lock: orientation error at T [rad], RK4 on Euler angles vs "
                 f"RK4 on quaternions (I = {tuple(g['moments'])})")
    for run_ in g["runs"]:
        pk = run_["euler_angles_peak"]
        slope = _fmt(run_["euler_angles_slope_first_decade"], ".2f")
        lines.append(f"   h = {run_['h']:g}, {run_['steps']} steps, T = {run_['T']:.4g}: "
                     f"Euler-angle error ~ theta_min^{slope} "
                     f"over the first decade, largest {_fmt(pk and pk['error'], '.2e')} at "
                     f"theta_min = {_fmt(pk and pk['theta_min'], '.2e')}; quaternions at most "
                     f"{run_['quaternion_max_error']:.2e}")
        for th, ea, eq in zip(g["theta_min"], run_["euler_angles_rk4"], run_["quaternion_rk4"],
                              strict=True):
            lines.append(f"     theta_min = {th:8.2e}: Euler angles {_fmt(ea, '9.2e')}, "
                         f"quaternions {eq:9.2e}")
    return "\n".join(lines)


BENCHMARK = core.Benchmark(name="stability", settings=settings, run=run, csv=csv_table,
                           plot=plot, report=report)
