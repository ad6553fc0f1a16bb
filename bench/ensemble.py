"""Ensembles: ns per body-step against the number of bodies ``N`` and threads.

Four cases: the free asymmetric body with ``splitting2`` (the headline), the Simo–Wong
heavy top with ``splitting2``, the free body with ``rattle``, and a gravity-gradient
satellite with ``splitting2`` (:func:`gravity_gradient_problem`: ``I = (100, 120, 80)``
with a per-body spread of up to 5 %, one Earth source on a circular orbit of 7000 km,
tumbling at 0.5 rad/s; the axis splitting as the free flow, ``free_flow="axes"``, which
the SIMD kernels run: with the default exact free flow an ensemble takes the scalar path).
``N`` bodies start near the problem's state (random orientations for the free body and
the satellite, tilts of a few degrees for the top; momenta within 1e-3), and each path
integrates them for ``steps``
steps (``N * steps`` is about ``body_steps``, at least ``min_steps``), keeping the final
state only. For the batched paths two numbers are taken from each call: the
**stepping** time, the wall time during which any batch driver was running (the path
hook records each driver call: chunks over threads, time slices and all), which gives
the ns per body-step of the charts and targets; and the whole call, whose excess over
the stepping is the **set-up per body** (validation, planning: the ``splitting2`` axis
ordering is chosen per body, and building the trajectory). Paths:

* **single body** — one ``liebody.integrate()`` call of ``single_steps`` steps: the cost
  of the one-body kernel, call overhead amortised. The ratios below are to this.
* **integrate() loop** — a Python loop over ``integrate()``, one body per call, for the
  same ``steps`` (timed on at most ``loop_bodies`` bodies: the cost is linear in ``N``);
  the fixed cost of a call (validation, planning, ~0.1 ms) shows at small ``steps``.
* **batched scalar** — one ``integrate()`` call with ``q0`` ``(N, 4)``, ``L0`` ``(N, 3)``,
  ``threads`` 1 and 2 and ``simd=False``: the ensemble runs the one-body loop for each
  body (``batch_drivers.BATCH_RUNNERS``), bodies in contiguous chunks over the threads.
* **batched SIMD** — the same call with ``simd=True`` (the default for 3 or more bodies):
  the SIMD drivers (``liebody._kernels.batch.SIMD_RUNNERS``: the body loop innermost,
  vectorised, a polynomial sin/cos).
* **MuJoCo rollout** (where installed) — ``mujoco.rollout.Rollout(nthread=t)``: ``N``
  rollouts of a one-body model (free joint, gravity off; the top as a ball joint,
  built as in :mod:`bench.peers`) with MuJoCo's Euler and RK4, ``nstep = steps``, at
  most ``mujoco_max_steps`` (MuJoCo's Euler blows up on the free body near ``t = 106``)
  and fewer where the recorded states would pass ``mujoco_body_steps`` (rollout keeps
  every step's state). A run whose states are not all finite is flagged; MuJoCo's
  warnings are kept in the JSON, not written to ``MUJOCO_LOG.TXT``.
* **Dask LocalCluster** — ``liebody.distributed.integrate`` on a local cluster of 1 and
  2 worker processes (one thread each), at the two largest ``N``: the whole call, tasks
  of ``N / workers`` bodies, from a client in this process; the excess over the batched
  SIMD call of the same work is the overhead of the cluster (per task).

Every time is the median of repeated calls (one call where a call lasts longer than
``long_call_s``). The machine's 2-thread efficiency is probed before and after
(:func:`parallel_efficiency`): on a shared machine the 2-thread figures mean little when
it is below 1. The SIMD and scalar batched runs are checked to agree (:func:`paths_agree`:
the final states of runs of :data:`AGREE_STEPS` steps from the timed runs' states, within
1e-13 per step): they time the same computation. The check uses short runs because the
timed runs' own final states differ by round-off amplified by the dynamics (exponentially
on the tumbling satellite near its intermediate axis: 3e-16 per step after 100 steps,
4e-15 after 400). Targets reported against (never asserted): free ``splitting2`` at most
10 ns per body-step on one core (goal 7), i.e. at least 7x cheaper than the single-body
path measured in the same run, at least 1.8x faster on 2 threads; heavy top ``splitting2``
and free ``rattle`` at least 5x cheaper than their single-body paths; the gravity-gradient
satellite at most 10 ns per body-step on one core.

Run ``python -m bench --only ensemble [--quick]``.
"""

from __future__ import annotations

import contextlib
import importlib.util
import statistics
import time

import numpy as np

import liebody
from bench import core
from bench.problems import Problem, problems
from liebody import quaternion

#: (case key, problem key, method, step)
CASES = (("free-splitting2", "asym", "splitting2", 0.05),
         ("top-splitting2", "top", "splitting2", 1e-3),
         ("free-rattle", "asym", "rattle", 0.05),
         ("gg-splitting2", "gg", "splitting2", 0.5))
#: the liebody paths, in the order run and drawn
PATHS = ("integrate() loop", "batched scalar", "batched SIMD")
MUJOCO = ("Euler", "RK4")
TARGETS = {"free-splitting2": {"ns": 10.0, "goal_ns": 7.0, "ratio": 7.0, "threads2": 1.8},
           "top-splitting2": {"ratio": 5.0}, "free-rattle": {"ratio": 5.0},
           "gg-splitting2": {"ns": 10.0, "ratio": 5.0}}
#: the gravity-gradient satellite: the Earth's mu [m^3/s^2], the orbit radius [m], the
#: nominal moments [kg m^2] and their per-body spread (uniform, relative)
GG_MU, GG_RADIUS, GG_MOMENTS, GG_SPREAD = 3.98600436e14, 7.0e6, (100.0, 120.0, 80.0), 0.05


def gravity_gradient_scene(moments) -> liebody.GravityGradient:
    """A satellite (``moments`` ``(3,)``, or ``(N, 3)`` for per-body inertia) under the
    gravity gradient of the Earth on a circular orbit, the axis splitting as free flow."""
    from liebody.orbits import Circular

    moments = np.asarray(moments, dtype=float)
    body = (liebody.RigidBody(moments) if moments.ndim == 1
            else liebody.RigidBody.batch(moments))
    n = np.sqrt(GG_MU / GG_RADIUS**3)
    return liebody.GravityGradient(body, [(GG_MU, Circular(n, GG_RADIUS, phase=np.pi))],
                                   free_flow="axes")


def gravity_gradient_problem() -> Problem:
    """The satellite of the ``gg-splitting2`` case, tumbling near its intermediate axis."""
    moments = np.array(GG_MOMENTS)
    return Problem(
        key="gg", title="gravity-gradient satellite, I = (100, 120, 80) +- 5 %, LEO",
        scene=gravity_gradient_scene(moments),
        q0=quaternion.normalize(np.array([0.9, 0.1, -0.2, 0.3])),
        L0=moments * np.array([0.5, 0.01, 0.02]), h_max=4.0, physical=False,
        source="a tumbling satellite in a circular orbit of 7000 km",
        extra={"per_body_moments": True})


def problem_of(pkey: str) -> Problem:
    return gravity_gradient_problem() if pkey == "gg" else problems()[pkey]


def ensemble_scene(pb: Problem, n: int, seed: int):
    """The scene of an ``n``-body ensemble: the problem's, or for the satellite one with
    per-body moments (the nominal ones times ``1 + U(0, GG_SPREAD)``)."""
    if not pb.extra.get("per_body_moments"):
        return pb.scene
    rng = np.random.default_rng(seed + 7 * n)
    return gravity_gradient_scene(np.asarray(pb.moments)
                                  * (1.0 + GG_SPREAD * rng.random((n, 3))))


def settings(quick: bool) -> dict:
    """``N`` values, threads, the work per point and the repeats."""
    if quick:
        return {"n": [1, 10, 100, 1000, 4000], "threads": [1, 2], "body_steps": 2_000_000,
                "single_steps": 1_000_000, "loop_bodies": 10, "mujoco_body_steps": 20_000,
                "mujoco_max_steps": 1000,
                "min_steps": 50, "repeat": 3, "min_batch": 0.02, "long_call_s": 1.0,
                "seed": 1}
    return {"n": [1, 10, 100, 1000, 10_000, 100_000, 1_000_000], "threads": [1, 2],
            "body_steps": 20_000_000, "single_steps": 2_000_000, "loop_bodies": 50,
            "mujoco_body_steps": 200_000, "mujoco_max_steps": 1000, "min_steps": 100,
            "repeat": 5, "min_batch": 0.05, "long_call_s": 5.0, "seed": 1}


# ------------------------------------------------------------------ timing the drivers


class Stepping:
    """Wall-clock intervals of the batch driver calls (from any thread); :attr:`seconds`
    is the length of their union: the time during which the ensemble was stepping."""

    def __init__(self) -> None:
        self.spans: list[tuple[float, float]] = []

    def clear(self) -> None:
        self.spans.clear()

    @property
    def seconds(self) -> float:
        total, end = 0.0, -np.inf
        for a, b in sorted(self.spans):
            if b > end:
                total += b - max(a, end)
                end = b
        return total


@contextlib.contextmanager
def recording(stepping: Stepping):
    """Record the wall-clock span of every batch driver call (scalar and SIMD, from any
    thread) in ``stepping``: the drivers in ``batch_drivers.BATCH_RUNNERS``,
    ``DIAG_BATCH_RUNNERS`` and ``batch.SIMD_RUNNERS`` (the dicts the ensembles read at
    every call) are wrapped for the duration, and restored on exit. Which of them runs
    is ``integrate``'s own switch (``simd=True`` / ``False``)."""
    from liebody._kernels import batch, batch_drivers

    tables = (batch_drivers.BATCH_RUNNERS, batch_drivers.DIAG_BATCH_RUNNERS,
              batch.SIMD_RUNNERS)
    saved = [dict(t) for t in tables]
    try:
        for table in tables:
            for key, runner in list(table.items()):
                table[key] = _timed(runner, stepping)
        yield
    finally:
        for table, old in zip(tables, saved, strict=True):
            table.clear()
            table.update(old)


def _timed(runner, stepping: Stepping):
    def run(*args):
        t0 = time.perf_counter()
        out = runner(*args)
        stepping.spans.append((t0, time.perf_counter()))
        return out

    return run


# ------------------------------------------------------------------ measurements


def ensemble_state(pb, n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """``n`` initial states near the problem's."""
    rng = np.random.default_rng(seed + n)
    if pb.free or pb.extra.get("per_body_moments"):
        q0 = quaternion.normalize(rng.normal(size=(n, 4)))
    else:
        tilt = np.c_[0.05 + 0.02 * rng.random(n), 0.02 * rng.normal(size=(n, 2))]
        q0 = quaternion.exp(tilt)
    L0 = pb.L0 * (1.0 + 1e-3 * rng.normal(size=(n, 3)))
    if not pb.free and not pb.extra.get("per_body_moments"):
        L0[:, :2] = pb.L0[:2]
    return q0, L0


def steps_for(cfg: dict, n: int) -> int:
    return max(cfg["min_steps"], round(cfg["body_steps"] / n))


def _ns(median: float, bodies: int, steps: int) -> float:
    return 1e9 * median / (bodies * steps)


def time_single(cfg: dict, pb, method: str, h: float) -> float:
    """ns per step of one long ``integrate()`` call (the one-body kernel)."""
    n = cfg["single_steps"]
    pb.integrate(method, h, 10, 10)
    med, _ = core.median_time(lambda: pb.integrate(method, h, n, n), cfg["repeat"],
                              cfg["min_batch"])
    return 1e9 * med / n


def time_loop(cfg: dict, pb, method: str, h: float, n: int) -> float:
    """ns per body-step of a Python loop over ``integrate()``, one body per call."""
    q0, L0 = ensemble_state(pb, n, cfg["seed"])
    k = min(n, cfg["loop_bodies"])
    steps = steps_for(cfg, n)

    def loop():
        for i in range(k):
            liebody.integrate(pb.scene, q0=q0[i], L0=L0[i], dt=h, steps=steps, method=method,
                              save_every=None)

    med, _ = core.median_time(loop, cfg["repeat"], cfg["min_batch"])
    return _ns(med, k, steps)


#: steps of the runs that check the SIMD and scalar paths against each other
AGREE_STEPS = 100


def paths_agree(cfg: dict, pb, method: str, h: float, n: int) -> float:
    """The largest difference per step between the final states of the batched SIMD and
    scalar runs of ``n`` bodies over :data:`AGREE_STEPS` steps (``q`` to its unit length,
    ``L`` relative to ``|L0|``: a satellite's ``L`` is about 60)."""
    q0, L0 = ensemble_state(pb, n, cfg["seed"])
    scene = ensemble_scene(pb, n, cfg["seed"])
    finals = []
    for simd in (False, True):
        tr = liebody.integrate(scene, q0=q0, L0=L0, dt=h, steps=AGREE_STEPS, method=method,
                               save_every=None, threads=1, simd=simd)
        finals.append(np.concatenate([tr.q[:, -1], tr.L[:, -1]], axis=1))
    d = np.abs(finals[1] - finals[0])
    return float(max(d[:, :4].max(), d[:, 4:].max() / np.linalg.norm(pb.L0))) / AGREE_STEPS


def time_batched(cfg: dict, pb, method: str, h: float, n: int, threads: int,
                 path: str) -> tuple[dict, np.ndarray]:
    """One ensemble ``integrate()`` call: ns per body-step of the stepping, of the whole
    call, the set-up per body, and the final states."""
    q0, L0 = ensemble_state(pb, n, cfg["seed"])
    scene = ensemble_scene(pb, n, cfg["seed"])
    steps = steps_for(cfg, n)
    rec = Stepping()

    def call():
        return liebody.integrate(scene, q0=q0, L0=L0, dt=h, steps=steps, method=method,
                                 save_every=None, threads=threads,
                                 simd=path == "batched SIMD")

    with recording(rec):
        t0 = time.perf_counter()
        tr = call()  # compiles or loads the kernels the first time
        first = time.perf_counter() - t0
        totals, inner = [], []
        for _ in range(cfg["repeat"] if first < cfg["long_call_s"] else 1):
            rec.clear()
            t0 = time.perf_counter()
            call()
            totals.append(time.perf_counter() - t0)
            inner.append(rec.seconds)
    total, stepping = statistics.median(totals), statistics.median(inner)
    final = np.concatenate([tr.q[:, -1], tr.L[:, -1]], axis=1)
    return {"ns": _ns(stepping, n, steps), "total_ns": _ns(total, n, steps),
            "setup_us_per_body": 1e6 * (total - stepping) / n}, final


def time_mujoco(cfg: dict, pb, h: float, n: int, threads: int, integrator: str) -> dict:
    """ns per body-step of ``N`` MuJoCo rollouts of a one-body model."""
    import mujoco
    from mujoco import rollout

    from bench import peers as P

    mujoco.set_mju_user_warning(P.MUJOCO_WARNINGS)  # kept, not written to MUJOCO_LOG.TXT
    model = mujoco.MjModel.from_xml_string(P._mujoco_xml(pb, integrator, h))
    data = mujoco.MjData(model)
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    size = mujoco.mj_stateSize(model, spec)
    q0, L0 = ensemble_state(pb, n, cfg["seed"])
    if pb.free:  # state: time, qpos (position, quaternion), qvel (linear, angular)
        qi, wi = slice(4, 8), slice(11, 14)
    else:  # ball joint: time, qpos (quaternion), qvel (angular)
        qi, wi = slice(1, 5), slice(5, 8)
    state = np.empty(size)
    mujoco.mj_getState(model, data, state, spec)
    init = np.tile(state, (n, 1))
    init[:, qi] = q0
    init[:, wi] = L0 / pb.moments
    steps = max(1, min(steps_for(cfg, n), cfg["mujoco_max_steps"],
                       cfg["mujoco_body_steps"] // n))
    with rollout.Rollout(nthread=threads) as r:
        datas = [mujoco.MjData(model) for _ in range(threads)]

        def call():
            return r.rollout(model, datas, init, nstep=steps)

        med, _ = core.median_time(call, cfg["repeat"], cfg["min_batch"])
        states, _ = call()
    return {"ns": _ns(med, n, steps), "steps": steps, "finite": bool(np.isfinite(states).all())}


def distributed_rows(cfg: dict, case: tuple, progress) -> list[dict]:
    """``liebody.distributed.integrate`` on a ``LocalCluster`` of 1 and 2 worker processes
    (one thread each) at the two largest ``N``: ns per body-step of the whole call, and
    the overhead per task against the batched SIMD call's stepping."""
    if importlib.util.find_spec("dask.distributed") is None:
        return []
    import logging

    from dask.distributed import Client, LocalCluster

    import liebody.distributed as dist

    key, pkey, method, h = case
    pb = problem_of(pkey)
    rows = []
    sizes = sorted(cfg["n"])[-2:] if len(cfg["n"]) > 5 else sorted(cfg["n"])[-1:]
    for workers in (1, 2):
        with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                          dashboard_address=None, silence_logs=logging.ERROR) as cluster, \
                Client(cluster) as client:
            for n in progress(sizes, desc=f"{key} Dask x{workers}"):
                q0, L0 = ensemble_state(pb, n, cfg["seed"])
                steps = steps_for(cfg, n)

                def call(q0=q0, L0=L0, steps=steps):
                    return dist.integrate(pb.scene, q0=q0, L0=L0, dt=h, steps=steps,
                                          method=method, save_every=None, client=client)

                call()  # the workers compile or load the kernels
                times = []
                for _ in range(cfg["repeat"]):
                    t0 = time.perf_counter()
                    call()
                    times.append(time.perf_counter() - t0)
                seconds = statistics.median(times)
                rows.append({"case": key, "path": "Dask LocalCluster", "threads": workers,
                             "n": n, "steps": steps, "ns": _ns(seconds, n, steps),
                             "tasks": workers})
    return rows


def parallel_efficiency(repeat: int = 5) -> float:
    """How much of a second core this machine gives right now: a plain compiled loop on
    two threads (twice the work) against one, ``t1 / t2`` (1 when the second core is
    free, 0.5 when it is busy with another load); the median of ``repeat`` trials."""
    from concurrent.futures import ThreadPoolExecutor

    from numba import njit

    @njit(nogil=True)
    def spin(n):
        s = 0.0
        for i in range(n):
            s += (i % 7) * 1e-9
        return s

    n = 30_000_000
    spin(10)
    out = []
    with ThreadPoolExecutor(2) as pool:
        for _ in range(repeat):
            t0 = time.perf_counter()
            spin(n)
            t1 = time.perf_counter() - t0
            t0 = time.perf_counter()
            list(pool.map(spin, [n, n]))
            out.append(t1 / (time.perf_counter() - t0))
    return statistics.median(out)


def run(cfg: dict, progress) -> dict:
    from bench import peers as P

    efficiency = [parallel_efficiency()]
    have_mujoco = P.mujoco_available()
    rows: list[dict] = []
    cases = {}
    mujoco_done: dict[str, list[dict]] = {}
    for case in CASES:
        key, pkey, method, h = case
        pb = problem_of(pkey)
        single = time_single(cfg, pb, method, h)
        agree = 0.0
        for n in progress(cfg["n"], desc=key):
            steps = steps_for(cfg, n)
            rows.append({"case": key, "path": "integrate() loop", "threads": 1, "n": n,
                         "steps": steps, "ns": time_loop(cfg, pb, method, h, n)})
            for threads in cfg["threads"]:
                for path in ("batched scalar", "batched SIMD"):
                    r, _ = time_batched(cfg, pb, method, h, n, threads, path)
                    rows.append({"case": key, "path": path, "threads": threads, "n": n,
                                 "steps": steps, **r})
            agree = max(agree, paths_agree(cfg, pb, method, h, n))
        if have_mujoco and pb.physical:
            if pkey not in mujoco_done:
                mj = []
                for n in progress(cfg["n"], desc=f"{pkey} MuJoCo"):
                    for threads in cfg["threads"]:
                        for integ in MUJOCO:
                            r = time_mujoco(cfg, pb, h, n, threads, integ)
                            mj.append({"path": f"MuJoCo {integ}", "threads": threads, "n": n,
                                       **r})
                mujoco_done[pkey] = mj
            rows += [{"case": key, **r} for r in mujoco_done[pkey]]
        if key == CASES[0][0]:  # the cluster's overhead: the headline case is enough
            rows += distributed_rows(cfg, case, progress)
        cases[key] = {"problem": pb.title, "method": method, "h": h,
                      "single_body_ns": single, "simd_vs_scalar_diff_per_step": agree,
                      "agree": agree <= 1e-13}
    for r in rows:  # Dask: the overhead per task over the batched SIMD call's stepping
        if r["path"] == "Dask LocalCluster":
            simd = _ns_of(rows, r["case"], "batched SIMD", 1, r["n"])
            ideal = r["n"] * r["steps"] * simd * 1e-9 / r["threads"]
            whole = r["n"] * r["steps"] * r["ns"] * 1e-9
            r["overhead_ms_per_task"] = 1e3 * (whole - ideal) / r["tasks"]
    for key, c in cases.items():
        c.update(_figures(key, c, rows, cfg))
    notes = [] if have_mujoco else ["MuJoCo is not installed: no rollout rows"]
    blown = sorted({f"{r['case']} {r['path']} N = {r['n']}" for r in rows
                    if r.get("finite") is False})
    if blown:
        notes.append("MuJoCo runs with non-finite states (timed anyway): " + "; ".join(blown))
    warnings = P.MUJOCO_WARNINGS.take() if have_mujoco else {}
    if importlib.util.find_spec("dask.distributed") is None:
        notes.append("dask.distributed is not installed: no Dask rows")
    efficiency.append(parallel_efficiency())
    if min(efficiency) < 0.9:
        notes.append(f"the second core was shared with another load during this run (a "
                     f"plain 2-thread probe gave {efficiency[0]:.2f} before and "
                     f"{efficiency[1]:.2f} after, 1 = a free core): the 2-thread figures "
                     f"understate the speed-up")
    return {"cases": cases, "rows": rows, "notes": notes, "mujoco_warnings": warnings,
            "two_thread_efficiency": efficiency}


def _field(rows, key, path, threads, n, name):
    for r in rows:
        if r["case"] == key and r["path"] == path and r["threads"] == threads and r["n"] == n:
            return r.get(name)
    return None


def _ns_of(rows, key, path, threads, n):
    return _field(rows, key, path, threads, n, "ns")


#: the N of the headline figures and targets: blocks of bodies whose states stay in the
#: caches (10,000 bodies: 0.6 MB); beyond, memory bandwidth takes over and is reported
#: separately (``largest_n``)
TARGET_N = 10_000


def _figures(key: str, case: dict, rows: list[dict], cfg: dict) -> dict:
    """The headline numbers of a case at :data:`TARGET_N` bodies (or the largest ``N``
    run, if smaller): ns per body-step per path, the ratio single-body / SIMD per core,
    the 2-thread speed-up, the targets; and the SIMD figures at the largest ``N``."""
    n = min(TARGET_N, max(cfg["n"]))
    simd1 = _ns_of(rows, key, "batched SIMD", 1, n)
    simd2 = _ns_of(rows, key, "batched SIMD", 2, n)
    scal1 = _ns_of(rows, key, "batched scalar", 1, n)
    scal2 = _ns_of(rows, key, "batched scalar", 2, n)
    out = {"n": n, "simd_ns_1": simd1, "simd_ns_2": simd2, "scalar_ns_1": scal1,
           "scalar_ns_2": scal2,
           "ratio_single_over_simd": case["single_body_ns"] / simd1,
           "ratio_scalar_over_simd": scal1 / simd1,
           "simd_speedup_2_threads": simd1 / simd2 if simd2 else None,
           "scalar_speedup_2_threads": scal1 / scal2 if scal2 else None,
           "setup_us_per_body": _field(rows, key, "batched SIMD", 1, n, "setup_us_per_body"),
           "simd_total_ns_1": _field(rows, key, "batched SIMD", 1, n, "total_ns")}
    big = max(cfg["n"])
    out["largest_n"] = {"n": big, "simd_ns_1": _ns_of(rows, key, "batched SIMD", 1, big),
                        "simd_ns_2": _ns_of(rows, key, "batched SIMD", 2, big),
                        "scalar_ns_1": _ns_of(rows, key, "batched scalar", 1, big)}
    t = TARGETS[key]
    met = {"ratio": out["ratio_single_over_simd"] >= t["ratio"]}
    if "ns" in t:
        met["ns"] = simd1 <= t["ns"]
    if "goal_ns" in t:
        met["goal_ns"] = simd1 <= t["goal_ns"]
    if "threads2" in t:
        met["threads2"] = (out["simd_speedup_2_threads"] or 0.0) >= t["threads2"]
    out["targets"] = t
    out["met"] = met
    return out


# ------------------------------------------------------------------ files


def csv_table(summary: dict) -> tuple[list[str], list[list]]:
    header = ["case", "path", "threads", "n", "steps", "ns_per_body_step",
              "whole_call_ns_per_body_step", "setup_us_per_body"]
    rows = [[r["case"], r["path"], r["threads"], r["n"], r["steps"], r["ns"],
             r.get("total_ns", ""), r.get("setup_us_per_body", "")] for r in summary["rows"]]
    for key, c in summary["cases"].items():
        rows.append([key, "single body (one long integrate call)", 1, 1,
                     summary["settings"]["single_steps"], c["single_body_ns"], "", ""])
    return header, rows


_STYLE = {"integrate() loop": ("0.45", "--", "s"), "batched scalar": ("#1f77b4", "-", "o"),
          "batched SIMD": ("#d62728", "-", "o"), "MuJoCo Euler": ("#c49c94", ":", "^"),
          "MuJoCo RK4": ("#843c39", ":", "^"), "Dask LocalCluster": ("#2ca02c", "-.", "D")}


def plot(summary: dict, plt):
    cases = summary["cases"]
    fig = plt.figure(figsize=(5.2 * len(cases), 5.8))
    grid = fig.add_gridspec(2, len(cases), height_ratios=(5.0, 1.0))
    axes = [fig.add_subplot(grid[0, 0])]
    axes += [fig.add_subplot(grid[0, k], sharey=axes[0]) for k in range(1, len(cases))]
    legend_ax = fig.add_subplot(grid[1, :])
    legend_ax.axis("off")
    for ax, (key, c) in zip(axes, cases.items(), strict=True):
        lines: dict[tuple, list] = {}
        for r in summary["rows"]:
            if r["case"] == key:
                lines.setdefault((r["path"], r["threads"]), []).append((r["n"], r["ns"]))
        for (path, threads), pts in lines.items():
            pts.sort()
            colour, ls, marker = _STYLE.get(path, ("0.5", "-", "x"))
            ax.plot(*zip(*pts, strict=True), color=colour, ls=ls, marker=marker, ms=3,
                    lw=1.0 if threads == 1 else 2.0, alpha=1.0 if threads == 1 else 0.7,
                    label=f"{path}, {threads} thread{'s' if threads > 1 else ''}"
                    if path != "integrate() loop" else path)
        ax.axhline(c["single_body_ns"], color="0.2", lw=0.8, ls="-.",
                   label="single body (long integrate call)")
        if "ns" in c["targets"]:
            ax.axhline(c["targets"]["ns"], color="#d62728", lw=0.6, ls=(0, (1, 3)),
                       label=f"target {c['targets']['ns']:g} ns")
        ax.set_xscale("log")
        ax.set_yscale("log")
        core.label_axes(ax, "bodies N", "ns per body-step" if ax is axes[0] else None,
                        title=f"{c['problem']}\n{c['method']}, h = {c['h']:g}", title_size=9)
    handles, labels = {}, []
    for ax in axes:  # one legend for all panels, below them
        for hd, lb in zip(*ax.get_legend_handles_labels(), strict=True):
            if lb not in handles:
                handles[lb] = hd
                labels.append(lb)
    legend_ax.legend([handles[lb] for lb in labels], labels, loc="center", ncol=5,
                     fontsize=7, frameon=False)
    fig.suptitle("Ensembles: cost per body and step against the number of bodies "
                 "(thin: 1 thread, thick: 2; batched paths: the stepping)")
    return fig


def report(summary: dict) -> str:
    cfg = summary["settings"]
    lines = [f"== ns per body-step (median of {cfg['repeat']}; about "
             f"{cfg['body_steps']:,} body-steps per point, at least {cfg['min_steps']} "
             f"steps, final state kept only). Batched paths: the stepping (driver calls' "
             f"wall time); the integrate() loop: whole calls"]
    for key, c in summary["cases"].items():
        lines.append(f"-- {key}: {c['problem']}, {c['method']}, h = {c['h']:g}; single "
                     f"body (one call of {cfg['single_steps']:,} steps): "
                     f"{c['single_body_ns']:.1f} ns/step")
        paths = []
        for r in summary["rows"]:
            if r["case"] == key and (r["path"], r["threads"]) not in paths:
                paths.append((r["path"], r["threads"]))
        head = f"{'path':28s} {'thr':>3s} " + " ".join(f"{n:>9,d}" for n in cfg["n"])
        lines.append(head)
        for path, threads in paths:
            cells = []
            for n in cfg["n"]:
                v = _ns_of(summary["rows"], key, path, threads, n)
                cells.append(f"{v:>9.1f}" if v is not None else f"{'-':>9s}")
            lines.append(f"{path:28s} {threads:>3d} " + " ".join(cells))
        s2 = c["simd_speedup_2_threads"]
        lines.append(
            f"at N = {c['n']:,}: SIMD {c['simd_ns_1']:.2f} ns (1 thread), "
            f"{c['simd_ns_2']:.2f} ns (2 threads, x{s2:.2f}); single body / SIMD per core "
            f"= {c['ratio_single_over_simd']:.1f}x, batched scalar / SIMD = "
            f"{c['ratio_scalar_over_simd']:.1f}x; SIMD and scalar final states agree to "
            f"{c['simd_vs_scalar_diff_per_step']:.1e} per step")
        steps = _field(summary["rows"], key, "batched SIMD", 1, c["n"], "steps")
        lines.append(
            f"whole SIMD call at N = {c['n']:,}, {steps} steps: "
            f"{c['simd_total_ns_1']:.1f} ns per body-step; set-up "
            f"{c['setup_us_per_body']:.1f} us per body (validation, planning, trajectory)")
        t, met = c["targets"], c["met"]
        words = [f"single/SIMD >= {t['ratio']:g}x: {'met' if met['ratio'] else 'NOT met'}"]
        if "ns" in t:
            words.append(f"<= {t['ns']:g} ns: {'met' if met['ns'] else 'NOT met'}")
        if "goal_ns" in t:
            words.append(f"goal {t['goal_ns']:g} ns: {'met' if met['goal_ns'] else 'not met'}")
        if "threads2" in t:
            words.append(f"2 threads >= {t['threads2']:g}x: "
                         f"{'met' if met['threads2'] else 'NOT met'}")
        lines.append("targets: " + "; ".join(words))
        big = c.get("largest_n")
        if big and big["n"] != c["n"]:
            lines.append(f"at the largest N = {big['n']:,} (states beyond the caches: memory "
                         f"bandwidth): SIMD {big['simd_ns_1']:.2f} ns (1 thread), "
                         f"{big['simd_ns_2']:.2f} ns (2 threads), batched scalar "
                         f"{big['scalar_ns_1']:.1f} ns")
    dask = [r for r in summary["rows"] if r["path"] == "Dask LocalCluster"]
    for r in dask:
        lines.append(f"Dask LocalCluster, {r['threads']} worker(s), {r['case']}, "
                     f"N = {r['n']:,}: {r['ns']:.1f} ns per body-step (whole call), "
                     f"overhead {r['overhead_ms_per_task']:.0f} ms per task")
    lines += summary["notes"]
    return "\n".join(lines)


BENCHMARK = core.Benchmark(name="ensemble", settings=settings, run=run, csv=csv_table,
                           plot=plot, report=report)
