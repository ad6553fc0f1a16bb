"""Long horizons: energy error, ``|q| - 1`` and momentum drift against time, log-log.

Every liebody method that can integrate the scene runs ``1e8`` steps (``1e5`` with
``--quick``) of one fixed step ``h``; ``splitting6`` and ``splitting8`` (9 and 17 base
steps per step) run a tenth of that, to keep the full run near ten minutes. Peers
run the same problem over the time their budget allows: scipy's DOP853 and RK45 at a
fixed tolerance, MuJoCo (where installed; physical bodies only) at the same step as
liebody. Samples are taken on three nested uniform grids (every step of the first
``n/1e4``, then coarser), so the log-log chart shows early and late times alike.

Plotted quantities, each the worst value so far (a running maximum, so a bounded error
is a flat line and a drift a rising one):

* relative energy error ``|E(t)/E(0) - 1|`` (kinetic plus potential);
* ``||q| - 1|``: liebody's geometric methods act by unit quaternions and never
  renormalise; scipy's equations drift off the sphere; MuJoCo renormalises every step;
* the momentum invariant: ``||L|/|L0| - 1|`` for a free body (its Casimir), and the
  vertical spatial component ``|L_z - L_z(0)| / |L0|`` for the heavy top.

Run ``python -m bench --only long_horizon [--quick]``.
"""

from __future__ import annotations

import time

import numpy as np

from bench import core
from bench import peers as P
from bench.problems import energy, problems
from liebody import quaternion

# step per problem: h |omega_0| = 0.16 (asym) and h omega_spin = 0.05 (top)
STEPS = {"asym": 0.05, "top": 1e-3}
SCIPY_RTOL = {"DOP853": 1e-10, "RK45": 1e-8}


def settings(quick: bool) -> dict:
    """Steps per run, samples per grid and the peers' time budget."""
    if quick:
        return {"steps": 10**5, "slow_steps": 10**4, "samples": 400, "peer_budget": 1.0,
                "mujoco_steps": 10**5, "problems": ["asym", "top"]}
    return {"steps": 10**8, "slow_steps": 10**7, "samples": 2000, "peer_budget": 30.0,
            "mujoco_steps": 3 * 10**6, "problems": ["asym", "top"]}


SLOW = ("splitting6", "splitting8")


def _grids(n: int, samples: int) -> list[tuple[int, int]]:
    """Nested uniform grids: (steps, save_every) covering n/1e4, n/1e2 and n steps."""
    out = []
    for frac in (1e-4, 1e-2, 1.0):
        m = max(round(n * frac), 1)
        out.append((m, max(m // samples, 1)))
    return out


def invariants(problem, t, q, L) -> dict[str, np.ndarray]:
    """The three drifts (not yet running maxima) along a sampled trajectory."""
    q, L = np.asarray(q), np.asarray(L)
    E = energy(problem, q, L)
    out = {"t": np.asarray(t), "energy": np.abs(E / problem.E0 - 1),
           "qnorm": np.abs(np.linalg.norm(q, axis=1) - 1)}
    L0 = np.linalg.norm(problem.L0)
    if problem.free:
        out["momentum"] = np.abs(np.linalg.norm(L, axis=1) / L0 - 1)
    else:
        Lz = _space_z(q, L)
        out["momentum"] = np.abs(Lz - Lz[0]) / L0
    return out


def _space_z(q: np.ndarray, L: np.ndarray) -> np.ndarray:
    """Vertical component of ``L_space = R(q) L``, with ``R`` the rotation of ``q / |q|``
    (a peer's ``q`` may drift off the unit sphere); NaN where the state is not finite."""
    norm = np.linalg.norm(q, axis=1)
    ok = np.isfinite(norm) & (norm > 0) & np.all(np.isfinite(L), axis=1)
    Lz = np.full(len(q), np.nan)
    if ok.any():
        Lz[ok] = quaternion.rotate(q[ok] / norm[ok, None], L[ok])[:, 2]
    return Lz


def _merge(parts: list[dict]) -> dict:
    """Samples of nested runs on one time axis (finer grids win where they overlap)."""
    keep = []
    covered = 0.0
    for p in parts:
        sel = p["t"] > covered if covered else np.ones(len(p["t"]), bool)
        keep.append({k: v[sel] for k, v in p.items()})
        covered = max(covered, float(p["t"][-1]))
    return {k: np.concatenate([p[k] for p in keep]) for k in keep[0]}


def liebody_run(problem, method: str, h: float, n: int, samples: int) -> dict:
    parts = []
    wall = 0.0
    failed_at = None
    for steps, every in _grids(n, samples):
        t0 = time.perf_counter()
        tr = problem.integrate(method, h, steps, save_every=every)
        wall = time.perf_counter() - t0  # the last (longest) run's time
        parts.append(invariants(problem, tr.t, tr.q, tr.L))
        if tr.failed_at is not None:
            failed_at = tr.failed_at
            break
    merged = _merge(parts)
    merged.update(source="liebody", wall_s=wall, steps=n, h=h, failed_at=failed_at)
    return merged


def scipy_run(problem, method: str, budget: float, T_max: float, samples: int) -> dict:
    rtol = SCIPY_RTOL[method]
    P.scipy_solve(problem, 1.0, method, rtol)  # compiles the RHS (or loads it) untimed
    t0 = time.perf_counter()
    P.scipy_solve(problem, 10.0, method, rtol)
    per_time = (time.perf_counter() - t0) / 10.0
    T = min(T_max, budget / per_time)
    T = _round_down(T)
    t_eval = np.unique(np.concatenate([np.geomspace(T * 1e-5, T, samples), [T]]))
    t0 = time.perf_counter()
    res = P.scipy_solve(problem, T, method, rtol, t_eval=t_eval)
    out = invariants(problem, res["t"], res["q"], res["L"])
    out.update(source="scipy", wall_s=time.perf_counter() - t0, steps=None, h=None, rtol=rtol,
               failed_at=None)
    return out


def _round_down(T: float) -> float:
    """1, 2 or 5 times a power of ten, not above T."""
    e = 10 ** np.floor(np.log10(T))
    for m in (5, 2, 1):
        if m * e <= T:
            return float(m * e)
    return float(e)  # pragma: no cover


def mujoco_run(problem, integrator: str, h: float, n: int, samples: int) -> dict:
    run = P.MujocoRun(problem, integrator, h)
    parts = []
    t0 = time.perf_counter()
    for steps, every in _grids(n, samples):
        n_saves = steps // every
        q, L = run.run(n_saves * every, n_saves)
        t = h * every * np.arange(1, n_saves + 1)
        q = np.vstack([problem.q0, q])
        L = np.vstack([problem.L0, L])
        parts.append(invariants(problem, np.r_[0.0, t], q, L))
        if not np.all(np.isfinite(q)):
            break
    out = _merge(parts)
    bad = ~np.isfinite(out["energy"])
    failed_at = float(out["t"][np.argmax(bad)]) if bad.any() else None
    out.update(source="MuJoCo", wall_s=time.perf_counter() - t0, steps=n, h=h,
               failed_at=failed_at)
    return out


def _one(source: str, m: str, pb, h: float, cfg: dict, T_max: float) -> dict:
    if source == "liebody":
        n = cfg["slow_steps"] if m in SLOW else cfg["steps"]
        return liebody_run(pb, m, h, n, cfg["samples"])
    if source == "scipy":
        return scipy_run(pb, m, cfg["peer_budget"], T_max, cfg["samples"])
    return mujoco_run(pb, m, h, cfg["mujoco_steps"], cfg["samples"])


def run(cfg: dict, progress: core.Progress) -> dict:
    """Every method and peer on each problem: curves (envelopes) and first/last deciles."""
    out: dict = {"problems": {}, "mujoco_warnings": {}}
    have_mujoco = P.mujoco_available()
    for key in cfg["problems"]:
        pb = problems()[key]
        h = STEPS[key]
        jobs = P.contenders(pb, have_mujoco)
        T_max = cfg["steps"] * h
        curves = {}
        for source, m in progress(jobs, f"long horizon {key}"):
            with np.errstate(over="ignore", invalid="ignore"):
                res = _one(source, m, pb, h, cfg, T_max)
            label = P.label(source, m)
            curves[label] = res
            if source == "MuJoCo":
                out["mujoco_warnings"][f"{key} {label}"] = P.MUJOCO_WARNINGS.take()
        out["problems"][key] = {
            "title": pb.title, "h": h, "h_omega0": h * pb.omega_max,
            "momentum_invariant": "|L|" if pb.free else "L_z (space)",
            "curves": {label: envelope(res) for label, res in curves.items()},
            "final": {label: _final(res) for label, res in curves.items()},
        }
    return out


def csv_table(summary: dict) -> tuple[list[str], list[list]]:
    """One row per run: where it went, how long it took, the worst finite values."""
    header = ["problem", "method", "source", "h", "rtol", "steps", "t_end", "wall_s",
              "max_energy_error", "max_qnorm_error", "max_momentum_drift", "failed_at"]
    rows = []
    for key, info in summary["problems"].items():
        for label, c in info["curves"].items():
            f = info["final"][label]
            worst = [f[k]["max"] if np.isfinite(f[k]["max"]) else 0.0
                     for k in ("energy", "qnorm", "momentum")]
            rows.append([key, label, c["source"], c["h"], c.get("rtol"), c["steps"],
                         f["t_end"], c["wall_s"], *worst, f["failed_at"]])
    return header, rows


def envelope(res: dict, points: int = 400) -> dict:
    """A curve as stored and plotted: the worst value so far of each quantity, at up to
    ``points`` log-spaced times (the raw samples run to tens of thousands)."""
    t = np.asarray(res["t"], dtype=float)
    keep = t > 0
    out = {k: v for k, v in res.items() if not isinstance(v, np.ndarray)}
    if not keep.any():
        out.update(t=[], energy=[], qnorm=[], momentum=[])
        return out
    t = t[keep]
    grid = np.unique(np.searchsorted(t, np.geomspace(t[0], t[-1], points), side="left"))
    grid = grid[grid < len(t)]
    out["t"] = t[grid].tolist()
    for k in ("energy", "qnorm", "momentum"):
        v = np.asarray(res[k], dtype=float)[keep]
        finite = np.where(np.isfinite(v), v, np.inf)
        worst = np.maximum.accumulate(finite)  # inf from the first non-finite sample on
        out[k] = worst[grid].tolist()
    return out


def _final(res: dict) -> dict:
    """Worst value in the first and in the last tenth of the run (bounded or drifting?)."""
    t = np.asarray(res["t"])
    out = {"t_end": float(t[-1]), "failed_at": res["failed_at"]}
    for k in ("energy", "qnorm", "momentum"):
        v = np.asarray(res[k])
        fin = np.isfinite(v)
        t_end = res["failed_at"] or t[-1]
        late = fin & (t >= 0.9 * t_end)
        early = fin & (t <= 0.1 * t_end) & (t >= 0.01 * t_end)
        # a window with no finite sample (the run blew up before it) reads inf
        out[k] = {"max": float(v[fin].max()) if fin.any() else np.inf,
                  "early_decile": float(v[early].max()) if early.any() else np.inf,
                  "last_decile": float(v[late].max()) if late.any() else np.inf}
    return out


def plot(summary: dict, plt):
    """Energy error, ``||q| - 1|`` and momentum drift against time, one row per problem."""
    keys = list(summary["problems"])
    fig, axes = plt.subplots(len(keys), 3, figsize=(16, 4.8 * len(keys)), squeeze=False)
    for i, key in enumerate(keys):
        info = summary["problems"][key]
        momentum = "||L|/|L0| - 1|" if info["momentum_invariant"] == "|L|" else (
            "|L_z - L_z(0)| / |L0|")
        ylabels = {"energy": "relative energy error (worst so far)",
                   "qnorm": "||q| - 1| (worst so far)", "momentum": f"{momentum} (worst so far)"}
        for j, quantity in enumerate(("energy", "qnorm", "momentum")):
            ax = axes[i, j]
            for label, res in info["curves"].items():
                t = np.asarray(res["t"], dtype=float)
                v = np.asarray([np.nan if x is None else x for x in res[quantity]], float)
                sel = (t > 0) & np.isfinite(v)
                if not sel.any():
                    continue
                y = np.maximum(v[sel], 1e-17)
                st = core.style(label)
                st.pop("marker")
                ax.loglog(t[sel], y, **st, lw=1.2)
            ax.set_ylim(1e-17, 1e3)
            core.label_axes(ax, "time t [time units of the problem]", ylabels[quantity],
                            f"{info['title']}\nh = {info['h']:g} (h|omega0| = "
                            f"{info['h_omega0']:.3g})", title_size=9)
            if j == 0:
                ax.legend(fontsize=7, ncol=2, loc="upper left")
    fig.suptitle("Long horizons: bounded errors for the geometric methods, drift for the rest")
    return fig


def report(summary: dict) -> str:
    lines = []
    for info in summary["problems"].values():
        lines.append(f"== {info['title']}, h = {info['h']:g}; invariant "
                     f"{info['momentum_invariant']}")
        lines.append(f"  {'method':22s} {'t_end':>9s} {'energy: early':>13s} {'late':>9s} "
                     f"{'|q|-1 late':>10s} {'momentum late':>13s}")
        for label, f in info["final"].items():
            fail = f"  blew up at t = {f['failed_at']:g}" if f["failed_at"] else ""
            lines.append(f"  {label:22s} {f['t_end']:9.3g} {f['energy']['early_decile']:13.2e} "
                         f"{f['energy']['last_decile']:9.2e} {f['qnorm']['last_decile']:10.2e} "
                         f"{f['momentum']['last_decile']:13.2e}{fail}")
    return "\n".join(lines)


BENCHMARK = core.Benchmark(name="long_horizon", settings=settings, run=run, csv=csv_table,
                           plot=plot, report=report)
