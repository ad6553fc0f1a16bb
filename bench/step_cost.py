"""Cost per step of every method against a plain C ``splitting2``; compile and import times.

The measurements, one run:

* **ns per step.** A small C implementation of the symmetric 5-rotation splitting
  (``bench/c/splitting2.c``: the same algorithm and axis ordering that
  ``integrate(method="splitting2")`` uses, exact axis sub-flows applied to ``m`` and
  ``q``, end rotations merged) is compiled with the system's ``gcc -O3`` into a
  temporary folder and timed in the same process, on the same body and state, as
  every registered liebody method run through the public ``integrate()``, on the HLW
  free body and (for the methods that support it) on the Simo–Wong heavy top. Every
  time is the median of repeated runs (min and max in the JSON); the ratio to C is
  reported. At the end, liebody's ``splitting2`` and the C code are checked to agree
  (bit for bit, or to about 1e-15), so the two timings are of the same computation.
  Without a C compiler the C column is skipped with a note.
* **Spacecraft scenes.** ns per step of one long ``integrate()`` on one body of the
  gravity-gradient satellite (circular orbit with the axis and the exact free flow, a
  Kepler orbit, a table of positions), a gyrostat and a body with four driven reaction
  wheels (:func:`scene_problems`), each against the free body's ``splitting2`` timed
  right before it.
* **Compile time.** In two fresh processes (``python -m bench.child first_calls``)
  sharing a new, empty ``NUMBA_CACHE_DIR`` (the user's cache is not touched): the first
  ``integrate()`` call of every method, in registry order, on the free body and on the
  heavy top, first with the cache empty (numba compiles and writes the cache), then
  with it full (numba loads it).
* **Fixed costs per call.** In this process, as multiples of one ``splitting2`` step on the
  free body measured in the same run: a one-step ``integrate()`` (free body; new initial
  state each call; the default exact flow; a user torque; a controlled body) and one
  :class:`liebody.Stepper` ``step()`` (free body, heavy top, controlled body with its
  controls set before each step). Targets: ``integrate()`` within
  :data:`FIXED_TARGETS` steps on a free body and with a user torque, ``step()`` within 20.
* **First call with an empty cache.** Fresh processes, each with its own empty numba
  cache: from ``import liebody`` to the end of the first ``integrate()`` of a stepping
  method (target: :data:`FIRST_CALL_TARGET_S`), and the whole first run of
  ``python -m liebody demo`` (target: :data:`DEMO_TARGET_S`).
* **Import time.** Medians over fresh processes (:mod:`bench.child`) of
  ``import liebody``, ``import liebody; liebody.integrate`` (the lazy attribute that
  loads numba) and the first ``integrate()`` call with a warm cache, less an empty child.

Target: ``splitting2`` through ``integrate()`` within 1.25x of the C code.
Timings are never asserted in the tests; this module is where they are measured.

Run ``python -m bench --only step_cost [--quick] [--steps N]``.
"""

from __future__ import annotations

import ctypes
import json
import math
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import liebody
from bench import core
from bench.problems import Problem, method_names, problems

TARGET_RATIO = 1.25  # target: splitting2 within 1.25x of the C code
#: fixed-cost targets, in steps of splitting2 on the free body
FIXED_TARGETS = {"integrate_free": 150, "integrate_user_torque": 150, "stepper_free": 20}
#: first call of a stepping method in a fresh process with an empty numba cache [s]
FIRST_CALL_TARGET_S = 3.0
#: the demo's first run with an empty numba cache [s]
DEMO_TARGET_S = 8.0

#: the C reference, built by :func:`build_c`
C_SOURCE = Path(__file__).resolve().parent / "c" / "splitting2.c"
#: the folder that holds the ``bench`` package (the children import it from there)
BENCH_ROOT = Path(__file__).resolve().parent.parent

#: the import-time children (:mod:`bench.child`), timed as whole processes; each but
#: the empty one also reports its own in-process time(s) from just before ``import liebody``
_IMPORT_CHILDREN = ("pass", "import", "integrate_attr", "first_call")


def settings(quick: bool, steps: int | None = None) -> dict:
    """Run parameters; ``quick`` trades precision for a run of well under a minute.

    ``steps`` is the number of steps per timed run (``splitting2`` on the free body and
    the C code always run exactly this many); a method whose run would last longer than
    ``cap_s`` runs fewer steps (at least ``min_steps``), so that the expensive methods
    do not dominate the run time. ``exact`` evaluates ``steps // exact_divisor`` samples.
    ``steps`` (the ``--steps`` option) overrides the default.
    """
    common = {"h_free": 0.01, "h_top": 0.01, "exact_divisor": 20, "min_steps": 10_000,
              "scene_steps": 200_000,
              "probe_steps": 10_000, "compile_steps": 10, "min_batch": 0.02}
    if quick:
        cfg = {**common, "steps": 200_000, "repeat": 3, "cap_s": 0.03, "import_repeat": 3,
               "scene_steps": 50_000, "quick": True}
    else:
        cfg = {**common, "steps": 2_000_000, "repeat": 5, "cap_s": 0.3, "import_repeat": 5}
    if steps is not None:
        if steps < 1:
            raise ValueError(f"steps must be >= 1, got {steps}")
        cfg["steps"] = int(steps)
        cfg["min_steps"] = min(cfg["min_steps"], cfg["steps"])
        cfg["probe_steps"] = min(cfg["probe_steps"], cfg["steps"])
    return cfg


# ------------------------------------------------------------------------- C reference


def build_c(workdir: Path) -> tuple[ctypes.CDLL | None, str]:
    """Compile :data:`C_SOURCE` (``bench/c/splitting2.c``) with ``gcc -O3`` into ``workdir``.

    Returns
    -------
    dll, note
        The loaded library (``None`` where there is no compiler or the build failed)
        and a line saying what was used or why the C reference is missing.
    """
    cc = shutil.which("gcc") or shutil.which("cc")
    if cc is None:
        return None, "no C compiler (gcc or cc) found: the C reference is skipped"
    lib = workdir / "libsplitting2.so"
    # hardware fma for the explicit fma() calls, and no contraction of other a * b + c
    # (liebody's kernels contract none): the same arithmetic, so the same bits
    cmd = [cc, "-O3", "-march=native", "-ffp-contract=off", "-shared", "-fPIC",
           str(C_SOURCE), "-o", str(lib), "-lm"]
    try:
        subprocess.run(cmd, check=True, capture_output=True, text=True)
        dll = ctypes.CDLL(str(lib))
    except (subprocess.CalledProcessError, OSError) as exc:
        detail = getattr(exc, "stderr", "") or str(exc)
        return None, f"building the C reference failed ({detail.strip()[:200]}): skipped"
    dll.splitting2.argtypes = [ctypes.POINTER(ctypes.c_double), ctypes.POINTER(ctypes.c_int),
                               ctypes.POINTER(ctypes.c_double), ctypes.c_double,
                               ctypes.c_long]
    dll.splitting2.restype = None
    version = subprocess.run([cc, "--version"], capture_output=True, text=True).stdout
    return dll, (f"{Path(cc).name} -O3 -march=native -ffp-contract=off "
                 f"({version.splitlines()[0] if version else 'unknown'})")


def time_c(cfg: dict, order: tuple[int, int, int]) -> dict:
    """Time the C ``splitting2`` on the HLW body and check it against liebody's.

    Returns a dict with ``ns`` (median, min, max per step; ``None`` without a compiler),
    ``note`` and ``max_diff`` (largest difference of the final ``q``, ``L`` from
    ``integrate(method="splitting2")`` after the same steps).
    """
    pb = problems()["hlw"]
    n, h = cfg["steps"], cfg["h_free"]
    with tempfile.TemporaryDirectory(prefix="liebody-c-") as tmp:
        dll, note = build_c(Path(tmp))
        if dll is None:
            return {"ns": None, "note": note, "max_diff": None, "agree": None}
        state = np.concatenate([pb.q0, pb.L0])
        order_c = (ctypes.c_int * 3)(*order)
        moments_c = (ctypes.c_double * 3)(*pb.moments)

        def run_c() -> np.ndarray:
            s = state.copy()
            dll.splitting2(s.ctypes.data_as(ctypes.POINTER(ctypes.c_double)), order_c,
                           moments_c, h, n)
            return s

        c_state = run_c()
        med, times = core.median_time(run_c, cfg["repeat"], cfg["min_batch"])
    # same algorithm, same answer (a check that we time the same thing)
    ours = pb.integrate("splitting2", h, n, save_every=n)
    diff = float(max(np.abs(ours.L[-1] - c_state[4:]).max(),
                     np.abs(ours.q[-1] - c_state[:4]).max()))
    return {"ns": _ns(med, times, n), "steps": n, "note": note, "max_diff": diff,
            "agree": diff <= 1e-12}


def _ns(median: float, times: list[float], n: int) -> dict:
    """Per-step nanoseconds from run times of ``n`` steps: median, min, max."""
    return {"median": 1e9 * median / n, "min": 1e9 * min(times) / n,
            "max": 1e9 * max(times) / n}


# ------------------------------------------------------------------------ liebody runs


def axis_ordering(pb: Problem, h: float) -> tuple[int, int, int]:
    """The axis ordering ``integrate(method="splitting2")`` picks for this problem."""
    return tuple(int(k) for k in pb.integrate("splitting2", h, 1).info["axis_ordering"])


def time_method(pb: Problem, method: str, h: float, cfg: dict, full: bool = False) -> dict:
    """ns per step (per sample for ``exact``) of one method on one problem.

    A short probe (which also compiles or loads the kernels) estimates the cost; the
    timed run has ``cfg["steps"]`` steps, fewer where it would last longer than
    ``cfg["cap_s"]`` (never with ``full``). A method that blows up is timed on the steps
    before the blow-up, or not at all where they are fewer than ``cfg["min_steps"]``.
    """
    exact = liebody.methods()[method].family == "exact"
    n = max(cfg["steps"] // cfg["exact_divisor"], 1) if exact else cfg["steps"]
    probe = min(n, cfg["probe_steps"])
    try:
        pb.integrate(method, h, probe, 1 if exact else probe)  # compile / load the cache
        t0 = time.perf_counter()
        pb.integrate(method, h, probe, 1 if exact else probe)
        per_step = (time.perf_counter() - t0) / probe
        steps = n if full else min(n, max(cfg["min_steps"], int(cfg["cap_s"] / per_step)))
        note = ""
        tr = pb.integrate(method, h, steps, 1 if exact else steps)
        if tr.failed_at is not None:
            blown = round(tr.failed_at / h)
            stable = int(0.9 * (blown - 1))
            if stable < cfg["min_steps"]:
                return {"ns": None, "steps": None, "blew_up_at_step": blown,
                        "note": f"blew up after {blown} steps (too few to time)"}
            steps = min(steps, stable)
            note = f"blew up after {blown} steps; timed on the first {steps}"
    except (liebody.ConvergenceError, ValueError) as exc:
        return {"ns": None, "steps": None, "note": f"{type(exc).__name__}: {exc}"}
    save = 1 if exact else steps  # exact: one evaluation per output sample
    med, times = core.median_time(lambda: pb.integrate(method, h, steps, save), cfg["repeat"],
                                  cfg["min_batch"])
    out = {"ns": _ns(med, times, steps), "steps": steps, "note": note}
    if exact:
        out["per"] = "sample"
    return out


def call_overhead(cfg: dict) -> float:
    """Median seconds of a one-step ``integrate(method="splitting2")`` call (fixed cost)."""
    pb = problems()["hlw"]
    med, _ = core.median_time(lambda: pb.integrate("splitting2", cfg["h_free"], 1, 1),
                              cfg["repeat"], cfg["min_batch"])
    return med


# ------------------------------------------------------------------ scenes


def scene_problems() -> dict:
    """``key -> (label, scene, q0, L0, h, method, controls)``: the spacecraft and planetary
    scenes (a satellite of ``I = (100, 120, 80)`` in a 7000 km orbit of the Earth, tumbling
    at 0.5 rad/s; a gyrostat and a body with four reaction wheels), each with its default
    method, beside the free body's ``splitting2``."""
    from liebody.orbits import Circular, Kepler, Table

    mu, radius = 3.986004418e14, 7.0e6
    n = math.sqrt(mu / radius**3)
    body = liebody.RigidBody([100.0, 120.0, 80.0])
    w0 = np.array([0.01, 0.5, 0.02])
    L0 = body.moments * w0
    period = 2.0 * math.pi / n
    t_tab = np.linspace(-10.0, 20.0 * period, 20_001)  # (covers 200,000 steps of 0.5 s)
    r_tab = Circular(n, radius, phase=math.pi).position(t_tab)
    kepler = Kepler(radius, 0.1, mu, M0=math.pi)
    pyramid = np.array([[math.cos(b) * math.cos(a), math.cos(b) * math.sin(a), math.sin(b)]
                        for a in (0.0, 0.5 * math.pi, math.pi, 1.5 * math.pi)
                        for b in (math.radians(54.7),)])
    wheels = liebody.ReactionWheels(body, pyramid, [0.02, 0.03, 0.025, 0.02],
                                    momentum=[0.3, -0.5, 0.8, 0.1])
    circ = [(mu, Circular(n, radius, phase=math.pi))]
    q0 = np.array([1.0, 0.0, 0.0, 0.0])
    h = 0.5
    return {
        "gg_circular_axes": ("gravity gradient, circular orbit, free_flow='axes'",
                             liebody.GravityGradient(body, circ, free_flow="axes"), q0, L0, h,
                             "splitting2", None),
        "gg_circular_exact": ("gravity gradient, circular orbit, free_flow='exact'",
                              liebody.GravityGradient(body, circ, free_flow="exact"), q0, L0,
                              h, "splitting2", None),
        "gg_kepler": ("gravity gradient, Kepler orbit e = 0.1, free_flow='axes'",
                      liebody.GravityGradient(body, [(mu, kepler)], free_flow="axes"), q0, L0,
                      h, "splitting2", None),
        "gg_table": ("gravity gradient, Table of 20,001 positions, free_flow='axes'",
                     liebody.GravityGradient(body, [(mu, Table(t_tab, r_tab))],
                                             free_flow="axes"), q0, L0, h, "splitting2", None),
        "gyrostat": ("gyrostat, constant rotor momentum (3, -2, 5)",
                     liebody.Gyrostat(body, [3.0, -2.0, 5.0]), q0, L0, h, "splitting2", None),
        "wheels": ("four reaction wheels, driven (constant motor torques)", wheels, q0,
                   L0 + pyramid.T @ np.array([0.3, -0.5, 0.8, 0.1]), h, "splitting2",
                   np.array([1e-4, -2e-4, 1.5e-4, 0.7e-4])),
    }


def scene_costs(cfg: dict) -> dict:
    """ns per step of one long ``integrate()`` of each scene of :func:`scene_problems`
    (median of ``cfg["repeat"]``), and its ratio to the free body's ``splitting2``
    measured right before it (the HLW problem, same steps)."""
    steps = cfg["scene_steps"]
    free = problems()["hlw"]
    out = {}
    for key, (label, scene, q0, L0, h, method, u) in scene_problems().items():
        def call(scene=scene, q0=q0, L0=L0, h=h, method=method, u=u):
            kw = {} if u is None else {"controls": u}
            return liebody.integrate(scene, q0=q0, L0=L0, dt=h, steps=steps,
                                     save_every=steps, method=method, **kw)

        call()  # compile or load the kernels
        ref, _ = core.median_time(
            lambda: free.integrate("splitting2", cfg["h_free"], steps, steps), cfg["repeat"],
            cfg["min_batch"])
        med, times = core.median_time(call, cfg["repeat"], cfg["min_batch"])
        tr = call()
        out[key] = {"what": label, "method": method, "h": h, "steps": steps,
                    "info": {k: str(v) for k, v in tr.info.items()},
                    "ns": _ns(med, times, steps), "ratio_to_free": med / ref}
    return out


# ------------------------------------------------------------------ fixed costs


def _torques():
    """A user torque of the orientation (gravity-gradient-like) and a commanded torque."""
    from numba import njit

    @njit
    def gradient(t, q, L):
        w, x, y, z = q[0], q[1], q[2], q[3]
        g1, g2, g3 = 2.0 * (x * z - w * y), 2.0 * (y * z + w * x), w * w - x * x - y * y + z * z
        return np.array([3.0 * (g2 * g3), -3.0 * (g1 * g3), 0.0])

    @njit
    def commanded(t, q, L, u):
        return u.copy()

    return gradient, commanded


def fixed_costs(cfg: dict) -> dict:
    """Seconds per call of short ``integrate()`` calls and of ``Stepper.step()``."""
    pb, top = problems()["hlw"], problems()["top"]
    h = cfg["h_free"]
    gradient, commanded = _torques()
    body = pb.scene.body
    user = liebody.TorqueBody(body, gradient, orientation_only=True)
    controlled = liebody.ControlledBody(body, commanded, controls=3, orientation_only=True)
    rng = np.random.default_rng(1)
    fresh = [pb.L0 * (1.0 + 1e-3 * rng.standard_normal(3)) for _ in range(256)]
    k = iter(range(10**12))

    def new_state(method="splitting2"):
        return liebody.integrate(pb.scene, L0=fresh[next(k) % 256], dt=h, steps=1,
                                 method=method)

    top_fresh = [top.L0 * (1.0 + 1e-3 * rng.standard_normal(3)) for _ in range(256)]

    def new_top_state():
        return liebody.integrate(top.scene, q0=top.q0, L0=top_fresh[next(k) % 256],
                                 dt=cfg["h_top"], steps=1, method="splitting2")

    s_free = liebody.Stepper(pb.scene, q0=pb.q0, L0=pb.L0, dt=h, method="splitting2")
    s_top = liebody.Stepper(top.scene, q0=top.q0, L0=top.L0, dt=cfg["h_top"],
                            method="splitting2")
    s_ctl = liebody.Stepper(controlled, q0=pb.q0, L0=pb.L0, dt=h, method="splitting2")
    u = np.array([1e-3, -2e-3, 0.5e-3])

    def controlled_step():
        s_ctl.u = u
        s_ctl.step()

    cases = {
        "integrate_free": ("integrate(steps=1), free body, splitting2",
                           lambda: liebody.integrate(pb.scene, q0=pb.q0, L0=pb.L0, dt=h,
                                                     steps=1, method="splitting2")),
        "integrate_new_state": ("integrate(steps=1), free body, splitting2, a new initial "
                                "state each call (the axis ordering is chosen for each "
                                "orbit)", new_state),
        "integrate_new_state_fixed": ("integrate(steps=1), free body, no_squish (a fixed "
                                      "ordering), a new initial state each call",
                                      lambda: new_state("no_squish")),
        "integrate_new_state_top": ("integrate(steps=1), heavy top, splitting2, a new "
                                    "initial state each call", new_top_state),
        "integrate_exact": ("integrate(steps=1), free body, default method (exact flow)",
                            lambda: liebody.integrate(pb.scene, L0=pb.L0, dt=h, steps=1)),
        "integrate_user_torque": ("integrate(steps=1), user torque t(t, q, L), splitting2",
                                  lambda: liebody.integrate(user, L0=pb.L0, dt=h, steps=1,
                                                            method="splitting2")),
        "integrate_controlled": ("integrate(steps=1), controlled body, controls given",
                                 lambda: liebody.integrate(controlled, L0=pb.L0, dt=h, steps=1,
                                                           method="splitting2", controls=u)),
        "stepper_free": ("Stepper.step(), free body, splitting2", s_free.step),
        "stepper_top": ("Stepper.step(), heavy top, splitting2", s_top.step),
        "stepper_controlled": ("Stepper: u set, then step(), controlled body",
                               controlled_step),
    }
    out = {}
    for key, (what, fn) in cases.items():
        # warm up first: a first call that compiles (a user torque called from Python)
        # would make median_time time single calls, cold
        for _ in range(3):
            fn()
        med, times = core.median_time(fn, cfg["repeat"], cfg["min_batch"])
        out[key] = {"what": what, "s": med, "min_s": min(times), "max_s": max(times)}
    return out


def first_call_times(cfg: dict) -> dict:
    """Fresh processes, each with its own empty numba cache: the first ``integrate()`` of a
    few stepping methods (import included), and the first run of the demo."""
    pb, top = problems()["hlw"], problems()["top"]
    free_spec = {"scene": "free", "moments": pb.moments.tolist(), "q0": pb.q0.tolist(),
                 "L0": pb.L0.tolist(), "dt": cfg["h_free"], "steps": cfg["compile_steps"]}
    top_spec = {"scene": "top", "moments": top.moments.tolist(), "mass": 20.0,
                "cm": [0.0, 0.0, 1.0], "g": 1.0, "q0": top.q0.tolist(), "L0": top.L0.tolist(),
                "dt": cfg["h_top"], "steps": cfg["compile_steps"]}
    cases = [("free", "splitting2"), ("top", "splitting2")]
    if not cfg.get("quick"):
        cases += [("free", "rattle"), ("free", "rk4"), ("top", "rattle"), ("free", "exact")]
    out: dict = {"calls": {}}
    for scene, method in cases:
        spec = dict(free_spec if scene == "free" else top_spec, method=method)
        with tempfile.TemporaryDirectory(prefix="liebody-numba-cache-") as cache:
            line, wall, error = _child("first_call_spec", [json.dumps(spec)], Path(cache))
        key = f"{method} ({scene})"
        if error is not None:
            out["calls"][key] = {"error": error}
            continue
        total, alone = (float(v) for v in line.split())
        out["calls"][key] = {"import_to_done_s": total, "call_s": alone, "process_s": wall}
    with tempfile.TemporaryDirectory(prefix="liebody-numba-cache-") as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache, MPLBACKEND="Agg")
        t0 = time.perf_counter()
        res = subprocess.run([sys.executable, "-m", "liebody", "demo"], env=env,
                             capture_output=True, text=True, timeout=600)
        out["demo_first_run_s"] = time.perf_counter() - t0
        if res.returncode != 0:
            out["demo_error"] = res.stderr.strip()[-500:]
    return out


# ------------------------------------------------------------------ fresh processes


def _child(name: str, args: list, cache_dir: Path) -> tuple[str | None, float, str | None]:
    """Run ``python -m bench.child NAME ARGS`` with a private numba cache.

    The child imports liebody from where this process did and the ``bench`` package
    from :data:`BENCH_ROOT`. Returns its last line of output (``None`` on failure), the
    process wall time and an error message (``None`` on success).
    """
    env = dict(os.environ)
    env["NUMBA_CACHE_DIR"] = str(cache_dir)
    roots = (str(Path(liebody.__file__).resolve().parent.parent), str(BENCH_ROOT),
             env.get("PYTHONPATH"))
    env["PYTHONPATH"] = os.pathsep.join(p for p in roots if p)
    cmd = [sys.executable, "-m", "bench.child", name, *map(str, args)]
    t0 = time.perf_counter()
    try:
        res = subprocess.run(cmd, env=env, cwd=BENCH_ROOT, capture_output=True, text=True,
                             timeout=600)
    except subprocess.TimeoutExpired:
        return None, time.perf_counter() - t0, "timed out after 600 s"
    wall = time.perf_counter() - t0
    if res.returncode != 0:
        return None, wall, res.stderr.strip()[-500:]
    lines = res.stdout.strip().splitlines()
    return (lines[-1] if lines else ""), wall, None


def first_calls(cache_dir: Path, cfg: dict) -> dict:
    """One fresh process timing the first ``integrate()`` call of every method.

    Returns the child's report (``import_s``, ``setup_s`` for building the scenes, per
    method ``free`` and ``top`` seconds, ``None`` where unsupported), with
    ``process_wall_s`` and ``total_s`` (set-up and first calls) added, or
    ``{"error": ...}`` where the process failed.
    """
    line, wall, error = _child("first_calls", [cfg["compile_steps"], cfg["h_free"],
                                               cfg["h_top"], *method_names()], cache_dir)
    if error is not None:
        return {"error": error, "process_wall_s": wall}
    try:
        out = json.loads(line)
    except ValueError:
        return {"error": f"unreadable output: {line[-500:]!r}", "process_wall_s": wall}
    out["process_wall_s"] = wall
    out["total_s"] = out["setup_s"] + sum(
        v for row in out["methods"].values() for k, v in row.items()
        if k in ("free", "top") and v is not None)
    return out


def compile_times(cache_dir: Path, cfg: dict) -> dict:
    """First calls with an empty numba cache, then in a new process with it filled."""
    empty = first_calls(cache_dir, cfg)
    cached = first_calls(cache_dir, cfg)
    return {"cache_dir": "fresh temporary NUMBA_CACHE_DIR (the user's cache is not touched)",
            "steps_per_call": cfg["compile_steps"], "empty": empty, "cached": cached,
            "note": _compile_note(empty, cached)}


def _compile_note(empty: dict, cached: dict) -> str:
    """Who pays for the compilation, in words."""
    if "methods" not in empty or "methods" not in cached or empty["total_s"] <= 0:
        return ""
    per = {m: sum(v for k, v in row.items() if k in ("free", "top") and v is not None)
           for m, row in empty["methods"].items()}
    big = [m for m, s in per.items() if s > 0.05 * empty["total_s"]]
    rest = max((s for m, s in per.items() if m not in big), default=0.0)
    return (f"{' and '.join(big) or 'no method'} take {sum(per[m] for m in big):.1f} s of the "
            f"{empty['total_s']:.1f} s: the driver is compiled once per family of stage "
            f"kinds, so the first method of each family (axis rotations, all rotations, "
            f"torqued splittings, DMV, the exact flow, each baseline) compiles its own "
            f"kernels and the later methods of a family reuse them (at most "
            f"{1e3 * rest:.1f} ms each). The scene set-up is the process's first numba call "
            f"(quaternion.exp): numba's one-off start-up lands there "
            f"({cached['setup_s']:.2f} s even with the cache full).")


def import_times(cache_dir: Path, cfg: dict) -> dict:
    """Import and first-call times of fresh processes (:data:`_IMPORT_CHILDREN`).

    The children are run round-robin ``cfg["import_repeat"]`` times with the cache in
    ``cache_dir`` (filled by :func:`compile_times`). Reported: the median whole-process
    wall time of each, less the median of the empty child, and the median in-process
    time from just before ``import liebody`` (the wall-time differences are noisier: a
    few ms of import drown in the interpreter's start-up). The first call is
    ``splitting2`` on the HLW body.
    """
    hlw = problems()["hlw"]
    first_call = [cfg["h_free"], cfg["compile_steps"], "splitting2",
                  *(float(v) for v in (*hlw.moments, *hlw.L0))]
    walls: dict[str, list[float]] = {k: [] for k in _IMPORT_CHILDREN}
    inside: dict[str, list[float]] = {k: [] for k in _IMPORT_CHILDREN if k != "pass"}
    first_call_alone: list[float] = []
    errors = {}
    for _ in range(cfg["import_repeat"]):
        for key in _IMPORT_CHILDREN:
            line, wall, error = _child(key, first_call if key == "first_call" else [],
                                       cache_dir)
            walls[key].append(wall)
            if error is not None:
                errors[key] = error
            elif key != "pass":
                try:
                    nums = [float(v) for v in line.split()]
                    inside[key].append(nums[0])
                except (ValueError, IndexError):
                    errors[key] = f"unreadable output: {line[-500:]!r}"
                    continue
                if key == "first_call":
                    first_call_alone.append(nums[1])

    def med(v: list[float]) -> float | None:
        return statistics.median(v) if v else None

    base = med(walls["pass"])
    less_base = {k: med(v) - base for k, v in walls.items() if k != "pass"}
    in_proc = {k: med(v) for k, v in inside.items()}
    out = {
        "repeat": cfg["import_repeat"],
        "python_startup_s": base,
        "import_liebody_s": less_base["import"],
        "import_and_integrate_attr_s": less_base["integrate_attr"],
        "first_integrate_warm_cache_s": less_base["first_call"],
        "in_process_s": {"import_liebody": in_proc["import"],
                         "import_and_integrate_attr": in_proc["integrate_attr"],
                         "import_to_first_integrate_done": in_proc["first_call"],
                         "first_integrate_call_alone": med(first_call_alone)},
        "process_walls_s": walls,
        "note": "process wall times (medians) less that of an empty child "
                "('python -m bench.child pass'), and in-process times from just before "
                "'import liebody'; the first call is splitting2 on the HLW body, "
                f"{cfg['compile_steps']} steps, with the numba cache full",
    }
    if errors:
        out["errors"] = errors
    return out


# ----------------------------------------------------------------------------- driver


def run(cfg: dict, progress: core.Progress) -> dict:
    """Measure everything: the C reference, every method on both problems, the
    ``integrate()`` call overhead, compile and import times (the body of the JSON)."""
    free, top = problems()["hlw"], problems()["top"]
    order = axis_ordering(free, cfg["h_free"])
    jobs = ["C", *method_names(), "scenes", "compile", "first calls", "import", "fixed costs"]
    bar = progress(jobs, "step cost")
    c_ref: dict = {}
    rows: dict[str, dict] = {}
    compile_info: dict = {}
    imports: dict = {}
    first: dict = {}
    fixed: dict = {}
    scenes: dict = {}
    with tempfile.TemporaryDirectory(prefix="liebody-numba-cache-") as cache:
        for job in bar:
            bar.set_postfix_str(job)
            if job == "C":
                c_ref = time_c(cfg, order)
            elif job == "compile":
                compile_info = compile_times(Path(cache), cfg)
            elif job == "import":
                imports = import_times(Path(cache), cfg)
            elif job == "first calls":
                first = first_call_times(cfg)
            elif job == "fixed costs":
                fixed = fixed_costs(cfg)
            elif job == "scenes":
                scenes = scene_costs(cfg)
            else:
                m = liebody.methods()[job]
                row = {"family": m.family,
                       "free": time_method(free, job, cfg["h_free"], cfg,
                                           full=(job == "splitting2"))}
                row["top"] = (time_method(top, job, cfg["h_top"], cfg)
                              if m.supports(top.scene) else None)
                c_ns = c_ref.get("ns")
                row["ratio_to_c"] = (row["free"]["ns"]["median"] / c_ns["median"]
                                     if c_ns and row["free"]["ns"] else None)
                rows[job] = row
    overhead = call_overhead(cfg)
    step_ns = (rows.get("splitting2", {}).get("free") or {}).get("ns")
    if step_ns:  # fixed costs in steps of splitting2 on the free body, this run
        for key, row in fixed.items():
            row["steps"] = row["s"] * 1e9 / step_ns["median"]
            if key in FIXED_TARGETS:
                row["target_steps"] = FIXED_TARGETS[key]
                row["met"] = bool(row["steps"] <= FIXED_TARGETS[key])
    for row in first.get("calls", {}).values():
        if "import_to_done_s" in row:
            row["met"] = bool(row["import_to_done_s"] <= FIRST_CALL_TARGET_S)
    if "demo_first_run_s" in first:
        first["demo_met"] = bool(first["demo_first_run_s"] <= DEMO_TARGET_S)

    s2 = rows.get("splitting2", {}).get("ratio_to_c")
    return {
        "problems": {"free": {"key": free.key, "title": free.title, "h": cfg["h_free"],
                              "axis_ordering": list(order)},
                     "top": {"key": top.key, "title": top.title, "h": cfg["h_top"]}},
        "c_reference": c_ref,
        "methods": rows,
        "target": {"what": f"splitting2 through integrate() within {TARGET_RATIO}x of C",
                   "ratio": s2, "limit": TARGET_RATIO,
                   "met": None if s2 is None else bool(s2 <= TARGET_RATIO)},
        "integrate_call_overhead_s": overhead,
        "fixed_costs": fixed,
        "scenes": scenes,
        "first_calls": {**first, "target_s": FIRST_CALL_TARGET_S,
                        "demo_target_s": DEMO_TARGET_S},
        "compile": compile_info,
        "import": imports,
    }


def csv_table(summary: dict) -> tuple[list[str], list[list]]:
    """One row per method (and one for C): ns/step on both problems, compile times."""
    header = ["method", "family", "free_ns_median", "free_ns_min", "free_ns_max", "free_steps",
              "ratio_to_c", "top_ns_median", "top_ns_min", "top_ns_max", "top_steps",
              "compile_empty_free_s", "compile_empty_top_s", "cached_free_s", "cached_top_s",
              "note"]
    table = []
    c = summary["c_reference"]
    if c.get("ns"):
        table.append(["C splitting2", "reference", c["ns"]["median"], c["ns"]["min"],
                      c["ns"]["max"], c["steps"], 1.0, None, None, None, None, None, None,
                      None, None, c["note"]])
    comp = summary["compile"]
    for name, row in summary["methods"].items():
        cells = [name, row["family"]]
        for key in ("free", "top"):
            r = row[key] or {}
            ns = r.get("ns") or {}
            cells += [ns.get("median"), ns.get("min"), ns.get("max"), r.get("steps")]
            if key == "free":
                cells.append(row["ratio_to_c"])
        for phase in ("empty", "cached"):
            per = comp.get(phase, {}).get("methods", {}).get(name, {})
            cells += [per.get("free"), per.get("top")]
        notes = [f"{k}: {row[k]['note']}" for k in ("free", "top") if row[k] and row[k]["note"]]
        if row["free"].get("per") == "sample":
            notes.insert(0, "ns per output sample (no time stepping)")
        cells.append("; ".join(notes))
        table.append(cells)
    return header, table


# ------------------------------------------------------------------------------ chart


def plot(summary: dict, plt):
    """ns/step bars (log x) with the C line; compile and import times beside them."""
    cfg = summary["settings"]
    fig = plt.figure(figsize=(14, 8.5))
    grid = fig.add_gridspec(2, 2, width_ratios=(1.25, 1), height_ratios=(1.5, 1))
    ax = fig.add_subplot(grid[:, 0])
    names = list(summary["methods"])
    y = np.arange(len(names))
    bar_h = 0.38
    shown: list[float] = []
    for k, (key, label, colour) in enumerate(
            (("free", summary["problems"]["free"]["title"], "#1f77b4"),
             ("top", summary["problems"]["top"]["title"].split(",")[0], "#ff7f0e"))):
        vals = []
        for name in names:
            r = summary["methods"][name][key]
            vals.append(r["ns"]["median"] if r and r["ns"] else np.nan)
        vals = np.array(vals)
        shown += [float(v) for v in vals if np.isfinite(v)]
        pos = y - bar_h / 2 + k * bar_h
        ax.barh(pos, vals, height=bar_h, color=colour, label=f"{label}, h = {cfg['h_' + key]}")
        for p, v in zip(pos, vals, strict=True):
            if np.isfinite(v):
                ax.text(v * 1.05, p, f"{v:.0f}", va="center", fontsize=7)
    for i, name in enumerate(names):
        for k, key in enumerate(("free", "top")):
            r = summary["methods"][name][key]
            if r is not None and r["ns"] is None:
                ax.text(0.01, y[i] - bar_h / 2 + k * bar_h, f"{key}: blew up, not timed",
                        va="center", fontsize=7, color="0.4",
                        transform=ax.get_yaxis_transform())
    c = summary["c_reference"]
    if c.get("ns"):
        ax.axvline(c["ns"]["median"], color="k", lw=1.2, ls="--",
                   label=f"C gcc -O3 splitting2 (HLW): {c['ns']['median']:.0f} ns")
        ax.axvline(TARGET_RATIO * c["ns"]["median"], color="0.5", lw=0.8, ls=":",
                   label=f"target: {TARGET_RATIO}x C")
    else:
        ax.text(0.99, 0.01, f"no C reference: {c.get('note', '')[:60]}", ha="right",
                va="bottom", fontsize=7, color="0.4", transform=ax.transAxes)
    ax.set_xscale("log")
    ax.set_yticks(y)
    ax.set_yticklabels([n + (" (per sample)" if summary["methods"][n]["free"].get("per")
                             else "") for n in names])
    ax.invert_yaxis()
    core.label_axes(ax, f"wall time per step [ns] (median of {cfg['repeat']} runs of up to "
                        f"{cfg['steps']:.0e} steps)", title="Cost per step through integrate()",
                    title_size=11, grid_axis="x", pad=48)
    ax.legend(fontsize=8, loc="lower center", bbox_to_anchor=(0.5, 1.0), ncol=2)
    shown += [c["ns"]["median"]] if c.get("ns") else []
    if shown:
        ax.set_xlim(10.0 ** np.floor(np.log10(min(shown))), max(shown) * 2.5)

    # compile times: per method, free + top, empty and cached
    axc = fig.add_subplot(grid[0, 1])
    comp = summary["compile"]
    ok = all("methods" in comp.get(p, {}) for p in ("empty", "cached"))
    if ok:
        yc = np.arange(len(names) + 1)
        for k, (phase, word, colour) in enumerate((("empty", "empty", "#d62728"),
                                                   ("cached", "full", "#2ca02c"))):
            tot = comp[phase]["total_s"]
            vals = [comp[phase]["setup_s"]] + [
                sum(v for kk, v in comp[phase]["methods"][n].items()
                    if kk in ("free", "top") and v is not None) for n in names]
            axc.barh(yc - bar_h / 2 + k * bar_h, vals, height=bar_h, color=colour,
                     label=f"cache {word}: {tot:.2f} s in all "
                           f"(whole process {comp[phase]['process_wall_s']:.1f} s)")
        axc.set_xscale("log")
        axc.set_yticks(yc)
        axc.set_yticklabels(["scene set-up (1st numba call)", *names], fontsize=8)
        axc.invert_yaxis()
        axc.legend(fontsize=8, loc="center right")
    else:
        axc.text(0.5, 0.5, "compile-time measurement failed (see the JSON)", ha="center",
                 transform=axc.transAxes)
    core.label_axes(axc, "first integrate() call, free body + heavy top [s]",
                    title=f"Compile: first call per method in a fresh process "
                          f"({cfg['compile_steps']} steps)", grid_axis="x")

    # import times
    axi = fig.add_subplot(grid[1, 1])
    imp = summary["import"]
    ip = imp.get("in_process_s", {})
    items = [("empty child process, whole\n(for scale)", imp.get("python_startup_s")),
             ("import liebody", ip.get("import_liebody")),
             ("import liebody; liebody.integrate\n(loads numba)",
              ip.get("import_and_integrate_attr")),
             ("... + first integrate(), cache full", ip.get("import_to_first_integrate_done"))]
    labels = [lab for lab, v in items]
    vals = [np.nan if v is None else max(v, 1e-4) for _, v in items]
    yi = np.arange(len(items))
    axi.barh(yi, vals, color=["0.7", "#9467bd", "#8c564b", "#e377c2"])
    for p, v in zip(yi, vals, strict=True):
        if np.isfinite(v):
            axi.text(v * 1.05, p, _fmt_seconds(v), va="center", fontsize=8)
    axi.set_yticks(yi)
    axi.set_yticklabels(labels, fontsize=8)
    axi.invert_yaxis()
    axi.set_xscale("log")
    axi.set_xlim(right=max([v for v in vals if np.isfinite(v)] + [1e-3]) * 3)
    core.label_axes(axi, f"time from just before 'import liebody' [s]\n(in-process, median of "
                         f"{cfg['import_repeat']} fresh processes)",
                    title="Import and first call in a fresh process", grid_axis="x")
    fig.suptitle("liebody step cost, compile and import times")
    return fig


# ---------------------------------------------------------------------------- report


def _fmt_seconds(v: float) -> str:
    """``1.23 s``, ``456 ms`` or ``7.8 ms``."""
    if abs(v) >= 1.0:
        return f"{v:.2f} s"
    if abs(v) >= 0.01:
        return f"{1e3 * v:.0f} ms"
    return f"{1e3 * v:.1f} ms"


def report(summary: dict) -> str:
    """The ns/step table, the target, compile and import times as text."""
    cfg = summary["settings"]
    pf, pt = summary["problems"]["free"], summary["problems"]["top"]
    lines = [f"== ns per step through integrate(): {pf['title']}, h = {pf['h']} (axis ordering "
             f"{tuple(pf['axis_ordering'])}); {pt['title']}, h = {pt['h']}",
             f"   median of {cfg['repeat']} runs of {cfg['steps']} steps (fewer where a run "
             f"would exceed {cfg['cap_s']} s; min/max in the JSON)"]
    c = summary["c_reference"]
    if c.get("ns"):
        agree = ("agree bit for bit" if c["max_diff"] == 0 else
                 f"differ by {c['max_diff']:.1e}" + ("" if c["agree"] else
                                                     " -- NOT the same computation"))
        lines.append(f"C {c['note']} splitting2: {c['ns']['median']:.1f} ns/step "
                     f"(min {c['ns']['min']:.1f}, max {c['ns']['max']:.1f}); liebody and C "
                     f"{agree} after {c['steps']} steps")
    else:
        lines.append(f"C reference: {c.get('note')}")
    lines.append(f"{'method':22s} {'HLW ns/step':>11s} {'x C':>6s} {'top ns/step':>11s}  note")
    for name, row in summary["methods"].items():
        label = name + (" (per sample)" if row["free"].get("per") == "sample" else "")
        f, t = row["free"], row["top"]
        fs = "-" if f["ns"] is None else f"{f['ns']['median']:.1f}"
        rs = "-" if row["ratio_to_c"] is None else f"{row['ratio_to_c']:.2f}"
        ts = "n/a" if t is None else ("-" if t["ns"] is None else f"{t['ns']['median']:.1f}")
        notes = [f"{k}: {r['note']}" for k, r in (("HLW", f), ("top", t)) if r and r["note"]]
        lines.append(f"{label:22s} {fs:>11s} {rs:>6s} {ts:>11s}  {'; '.join(notes)}")
    tg = summary["target"]
    if tg["ratio"] is None:
        lines.append(f"target: splitting2 within {tg['limit']}x of C: not measurable without "
                     "the C reference")
    else:
        lines.append(f"target: splitting2 within {tg['limit']}x of C: "
                     f"{tg['ratio']:.2f}x -> {'met' if tg['met'] else 'NOT met'}")
    lines.append(f"integrate() fixed cost per call (1 step): "
                 f"{1e6 * summary['integrate_call_overhead_s']:.0f} us")
    fixed = summary.get("fixed_costs") or {}
    if fixed:
        lines.append("== fixed costs per call, in steps of splitting2 on the free body (this run)")
        for row in fixed.values():
            steps = row.get("steps")
            tgt = (f"  (target <= {row['target_steps']}: "
                   f"{'met' if row['met'] else 'NOT met'})" if "target_steps" in row else "")
            st = "?" if steps is None else f"{steps:7.1f}"
            lines.append(f"{row['what']:72s} {1e6 * row['s']:8.2f} us = {st} steps{tgt}")
    scenes = summary.get("scenes") or {}
    if scenes:
        lines.append("== ns per step of the spacecraft scenes, one body, one long integrate() "
                     "(x: against the free body's splitting2 in the same run)")
        for row in scenes.values():
            lines.append(f"{row['what']:64s} {row['method']:11s} "
                         f"{row['ns']['median']:8.1f} ns  x{row['ratio_to_free']:.2f}")
    first = summary.get("first_calls") or {}
    if first.get("calls"):
        lines.append(f"== first call in a fresh process with an empty numba cache (import "
                     f"included; target <= {first['target_s']:g} s)")
        for key, row in first["calls"].items():
            if "error" in row:
                lines.append(f"{key:22s} failed: {row['error']}")
                continue
            lines.append(f"{key:22s} {row['import_to_done_s']:6.2f} s (the call "
                         f"{row['call_s']:.2f} s) -> {'met' if row['met'] else 'NOT met'}")
        if "demo_first_run_s" in first:
            lines.append(f"python -m liebody demo, first run: {first['demo_first_run_s']:.1f} s "
                         f"(target <= {first['demo_target_s']:g} s: "
                         f"{'met' if first['demo_met'] else 'NOT met'})")

    comp = summary["compile"]
    lines.append(f"== compile: first integrate() call ({comp['steps_per_call']} steps) per "
                 f"method, registry order, in a fresh process; {comp['cache_dir']}")
    if all("methods" in comp.get(p, {}) for p in ("empty", "cached")):
        e, k = comp["empty"], comp["cached"]
        lines.append(f"{'method':12s} {'empty free':>11s} {'empty top':>10s} "
                     f"{'cached free':>12s} {'cached top':>11s}  [s]")
        txt = [f"{e['setup_s']:.4f}", "", f"{k['setup_s']:.4f}", ""]
        lines.append(f"{'scene set-up':12s} {txt[0]:>11s} {txt[1]:>10s} {txt[2]:>12s} "
                     f"{txt[3]:>11s}")
        for name in e["methods"]:
            cells = [e["methods"][name].get("free"), e["methods"][name].get("top"),
                     k["methods"][name].get("free"), k["methods"][name].get("top")]
            txt = ["-" if v is None else f"{v:.4f}" for v in cells]
            lines.append(f"{name:12s} {txt[0]:>11s} {txt[1]:>10s} {txt[2]:>12s} {txt[3]:>11s}")
        lines.append(f"total: empty cache {e['total_s']:.2f} s, cached {k['total_s']:.3f} s; "
                     f"whole process (import, problems, all first calls): "
                     f"{e['process_wall_s']:.1f} s and {k['process_wall_s']:.1f} s")
        lines.append(comp["note"])
    else:
        for p in ("empty", "cached"):
            if "error" in comp.get(p, {}):
                lines.append(f"{p} cache: failed: {comp[p]['error']}")

    imp = summary["import"]
    ip = imp["in_process_s"]

    def ms(v: float | None) -> str:
        return "?" if v is None else _fmt_seconds(v)

    lines.append(f"== import: medians of {imp['repeat']} fresh processes, in-process time from "
                 f"just before 'import liebody' [in brackets: process wall time less that of "
                 f"an empty child process, {ms(imp['python_startup_s'])}]")
    lines.append(f"import liebody: {ms(ip['import_liebody'])} "
                 f"[{ms(imp['import_liebody_s'])}]")
    lines.append(f"import liebody; liebody.integrate (loads numba): "
                 f"{ms(ip['import_and_integrate_attr'])} "
                 f"[{ms(imp['import_and_integrate_attr_s'])}]")
    lines.append(f"... and the first integrate() (splitting2, 10 steps, cache full): "
                 f"{ms(ip['import_to_first_integrate_done'])} "
                 f"[{ms(imp['first_integrate_warm_cache_s'])}], of which the call itself "
                 f"{ms(ip['first_integrate_call_alone'])} (mostly numba's one-off start-up, "
                 f"not the cache load: see the compile table)")
    if imp.get("errors"):
        lines.append(f"import errors: {imp['errors']}")
    return "\n".join(lines)


BENCHMARK = core.Benchmark(
    name="step_cost", settings=settings, run=run, csv=csv_table, plot=plot, report=report,
    options=(core.Option("--steps", "steps", type=int,
                         help="steps per timed run (default 2e6, 2e5 with --quick)"),))
