"""The Stepper as a run of integrate(): the kernels integrate() runs
(SIMD for ensembles), slices sized by time, Ctrl-C that keeps a consistent state,
copies, pickling and threads.

The reference is :func:`liebody.integrate`: ``k`` calls ``step(n)`` are
``integrate(steps=k n, save_every=n)`` bit for bit, with the same ``simd``. A step
interrupted by Ctrl-C leaves the stepper after ``m`` steps of the call, exactly as
``step(m)`` from the same state would have left it.
"""

from __future__ import annotations

import copy
import itertools
import json
import math
import pickle
import textwrap
import threading

import numpy as np
import pytest
from numba import njit

import liebody
from liebody import _engine, _stepper
from liebody import quaternion as Q
from liebody._kernels import batch
from support import InterruptingClock, interrupt_child, run_threads

N_ENS = 300  # well above SIMD_MIN_BODIES, more than one block of 128 bodies
assert batch.SIMD_MIN_BODIES <= 3 < N_ENS

RNG = np.random.default_rng(20)
Q_ENS = Q.random(N_ENS, rng=21)
L_ENS = RNG.normal(size=(N_ENS, 3))
MOMENTS_ENS = RNG.uniform(1.0, 1.8, size=(N_ENS, 3))  # every triangle holds


def _free():
    return liebody.FreeBody(liebody.RigidBody([1.0, 2.0, 2.5]))


def _top():
    return liebody.HeavyTop(liebody.RigidBody([1.0, 1.0, 0.5]), mass=1.0, cm=[0.0, 0.0, 0.3])


@njit
def _pull(t, q, L, u):
    """A controlled torque that reads the time, the momentum and the controls."""
    return np.array([u[0] - 0.1 * L[0], u[1] - 0.1 * L[1], 0.05 * np.cos(t) - 0.1 * L[2]])


def _controlled(bodies=None):
    body = liebody.RigidBody([1.0, 2.0, 2.5]) if bodies is None else bodies
    return liebody.ControlledBody(body, _pull, controls=2)


ENSEMBLES = {  # name -> scene, state (the top's omega is spin about its axis)
    "free": (lambda: _free(), {"q0": Q_ENS, "L0": L_ENS}),
    "free, per-body inertia": (lambda: liebody.FreeBody(liebody.RigidBody.batch(MOMENTS_ENS)),
                               {"q0": Q_ENS, "L0": L_ENS}),
    "top": (lambda: _top(), {"q0": Q_ENS, "L0": L_ENS + [0.0, 0.0, 8.0]}),
}


def _ensemble_cases():
    out = []
    for name, (make, _) in ENSEMBLES.items():
        for method in ("splitting2", "splitting4", "sr2", "rattle", "dmv4"):
            if liebody.methods()[method].supports(make()):
                out.append((name, method))
    return out


def _simd_of(info) -> bool | list[bool]:
    return info["simd"] if "simd" in info else [g["simd"] for g in info["groups"]]


# ----------------------------------------------------------------------- 1. SIMD kernels


@pytest.mark.filterwarnings("ignore::liebody.InvariantWarning")
@pytest.mark.parametrize("simd", [None, True, False])
@pytest.mark.parametrize(("scene", "method"), _ensemble_cases())
def test_ensemble_stepper_is_integrate_with_the_same_kernels(scene, method, simd):
    """An ensemble stepper runs the kernel integrate() runs (SIMD where it applies), so
    k calls step(n) are integrate(steps=k n, save_every=n) bit for bit. Before: the
    stepper always ran the scalar loop (75-255 ns per body-step against 8-18 ns), and
    with the SIMD kernels integrate() differed from it by round-off."""
    make, kw = ENSEMBLES[scene]
    sc = make()
    dt = 0.01
    ref = liebody.integrate(sc, dt=dt, steps=12, save_every=4, method=method, simd=simd,
                            threads=2, **kw)
    s = liebody.Stepper(sc, dt=dt, method=method, simd=simd, threads=2, **kw)
    assert _simd_of(s.info) == _simd_of(ref.info)
    for j in range(1, 4):
        s.step(4)
        np.testing.assert_array_equal(s.q, ref.q[:, j])
        np.testing.assert_array_equal(s.L, ref.L[:, j])
    assert s.t == ref.t[-1] and s.steps == 12
    ref1 = liebody.integrate(sc, dt=dt, steps=3, method=method, simd=simd, **kw)
    s1 = liebody.Stepper(sc, dt=dt, method=method, simd=simd, **kw)
    for j in range(1, 4):
        s1.step()
        np.testing.assert_array_equal(s1.q, ref1.q[:, j])
        np.testing.assert_array_equal(s1.L, ref1.L[:, j])


def test_the_simd_kernels_run_where_integrate_runs_them():
    """The rule of integrate(): simd=None from SIMD_MIN_BODIES bodies, True for any
    ensemble, False never; not for a user torque."""
    free = _free()
    few = batch.SIMD_MIN_BODIES - 1

    def simd(n, **kw):
        s = liebody.Stepper(free, L0=np.tile([0.1, 1.0, 0.2], (n, 1)), dt=0.01,
                            method="splitting2", **kw)
        ref = liebody.integrate(free, L0=np.tile([0.1, 1.0, 0.2], (n, 1)), dt=0.01, steps=1,
                                method="splitting2", **kw)
        assert s.info["simd"] == ref.info["simd"]
        return s.info["simd"]

    assert simd(N_ENS) is True
    assert simd(batch.SIMD_MIN_BODIES) is True
    assert simd(few) is False
    assert simd(few, simd=True) is True
    assert simd(N_ENS, simd=False) is False
    s = liebody.Stepper(_controlled(), q0=Q_ENS, L0=L_ENS, dt=0.01, method="splitting2",
                        simd=True)
    assert not any(np.atleast_1d(_simd_of(s.info)))  # a user torque: the scalar loop


@pytest.mark.parametrize("simd", ["yes", 1, 0.0])
def test_a_bad_simd_setting_is_refused_by_name(simd):
    with pytest.raises(TypeError, match="simd must be True, False or None"):
        liebody.Stepper(_free(), L0=L_ENS, dt=0.01, method="splitting2", simd=simd)


@pytest.mark.parametrize("simd", [None, False])
@pytest.mark.parametrize("bodies", [None, 3])
def test_a_long_step_call_equals_integrate(bodies, simd):
    """The contract holds for any n, also over many slices of a long call (moved here
    from test_controller.py, which compared with simd=False only)."""
    free = _free()
    L0 = np.array([0.3, -1.0, 0.6]) if bodies is None else np.array(
        [[0.3, -1.0, 0.6], [1.0, 0.2, -0.1], [-0.2, 0.5, 0.9]])
    n = 70_000
    s = liebody.Stepper(free, L0=L0, dt=0.01, method="splitting2", simd=simd)
    s.step(n)
    ref = liebody.integrate(free, L0=L0, dt=0.01, steps=n, save_every=n, method="splitting2",
                            simd=simd)
    np.testing.assert_array_equal(s.q, ref.q[..., -1, :])
    np.testing.assert_array_equal(s.L, ref.L[..., -1, :])


# ----------------------------------------------------------------------- 3. slices by time


def _slices_cases():
    top, free = _top(), _free()
    ctl = _controlled()
    return {
        "top, one body": (top, {"L0": [0.2, -0.1, 8.0]}, "splitting2", {}),
        "controlled, one body": (ctl, {"L0": [0.3, -1.0, 0.6], "controls": [0.2, -0.1]},
                                 "splitting4", {}),
        "top, SIMD": (top, {"q0": Q_ENS, "L0": L_ENS + [0.0, 0.0, 8.0]}, "splitting2",
                      {"threads": 2}),
        "free, SIMD": (free, {"q0": Q_ENS, "L0": L_ENS}, "splitting2", {"threads": 2}),
        "controlled ensemble": (_controlled(liebody.RigidBody.batch(MOMENTS_ENS[:150])),
                                {"q0": Q_ENS[:150], "L0": L_ENS[:150],
                                 "controls": RNG.normal(size=(150, 2))}, "splitting2",
                                {"threads": 2}),
    }


SLICE_CASES = _slices_cases()


@pytest.mark.parametrize("case", list(SLICE_CASES))
def test_slices_change_no_bit(case, monkeypatch):
    """A call cut into one-step slices (the slice time set to nothing) gives the numbers
    of the same call in a few slices, and of integrate()."""
    sc, kw, method, extra = SLICE_CASES[case]
    dt, n = 0.01, 300
    whole = liebody.Stepper(sc, dt=dt, method=method, **kw, **extra)
    whole.step(n)
    ref = liebody.integrate(sc, dt=dt, steps=n, save_every=n, method=method, **kw, **extra)
    np.testing.assert_array_equal(whole.q, ref.q[..., -1, :])

    calls = []
    monkeypatch.setattr(_engine, "SLICE_SECONDS", 1e-12)
    cut = liebody.Stepper(sc, dt=dt, method=method, **kw, **extra)
    if cut.n_bodies is None:
        inner = cut._call

        def counted(*args):
            calls.append(args[_engine.N_STEPS])
            return inner(*args)

        cut._call = counted
    else:
        run = _stepper.Stepper._run

        def counted(self, call, w, s, k, final):
            calls.append(k)
            return run(self, call, w, s, k, final)

        monkeypatch.setattr(_stepper.Stepper, "_run", counted)
    cut.step(n)
    # the first slice (before anything is measured) of at most _FIRST_WORK body-steps,
    # then one step each
    assert calls[0] <= _stepper._FIRST_WORK and set(calls[1:]) == {1}
    assert len(calls) >= n - _stepper._FIRST_WORK
    np.testing.assert_array_equal(cut.q, whole.q)
    np.testing.assert_array_equal(cut.L, whole.L)
    assert cut.t == whole.t and cut.steps == whole.steps == n


def test_slices_grow_with_the_measured_rate():
    """A cheap step: a long call takes few slices (the first small, then sized for about
    SLICE_SECONDS each), not one slice per 64 steps."""
    s = liebody.Stepper(_free(), L0=[0.3, -1.0, 0.6], dt=0.01, method="splitting2")
    calls = []
    inner = s._call

    def counted(*args):
        calls.append(args[_engine.N_STEPS])
        return inner(*args)

    s._call = counted
    s.step(200_000)
    assert sum(calls) == 200_000
    assert calls[0] <= _stepper._FIRST_WORK and len(calls) <= 8
    assert all(b <= _engine.SLICE_GROWTH * a for a, b in itertools.pairwise(calls))


# ----------------------------------------------------------------------- 2/3. Ctrl-C


def _interrupt_cases():
    top = _top()
    return {
        "top, one body": (top, {"L0": [0.2, -0.1, 8.0]}, "splitting2", {}),
        "free, one body, rattle": (_free(), {"L0": [0.3, -1.0, 0.6]}, "rattle", {}),
        "top, SIMD, 2 threads": (top, {"q0": Q_ENS, "L0": L_ENS + [0.0, 0.0, 8.0]},
                                 "splitting2", {"threads": 2}),
        "top, scalar, 2 threads": (top, {"q0": Q_ENS, "L0": L_ENS + [0.0, 0.0, 8.0]},
                                   "splitting2", {"threads": 2, "simd": False}),
    }


INTERRUPT_CASES = _interrupt_cases()


@pytest.mark.parametrize("at", [2, 4, 5])
@pytest.mark.parametrize("case", list(INTERRUPT_CASES))
def test_ctrl_c_leaves_the_stepper_as_a_shorter_call_would(case, at, monkeypatch):
    """Ctrl-C between slices of a call: IntegrationInterrupted (a KeyboardInterrupt)
    with exc.step = m, and the stepper is exactly a stepper after step(m): state, t,
    steps; it then goes on as that one does. (A merged end stage is completed: m may
    be one more than the slices done.)"""
    sc, kw, method, extra = INTERRUPT_CASES[case]
    dt, n = 0.01, 50_000
    s = liebody.Stepper(sc, dt=dt, method=method, **kw, **extra)
    s.step(7)
    s.t = 0.25
    monkeypatch.setattr(_stepper, "time", InterruptingClock(at))
    with pytest.raises(liebody.IntegrationInterrupted) as info:
        s.step(n)
    monkeypatch.undo()
    m = info.value.step
    assert isinstance(info.value, KeyboardInterrupt)
    assert 0 <= m < n and s.steps == 7 + m and info.value.t == s.t
    if at % 2 == 0:
        assert m > 0  # the slices done are kept
    twin = liebody.Stepper(sc, dt=dt, method=method, **kw, **extra)
    twin.step(7)
    twin.t = 0.25
    if m:
        twin.step(m)
    assert s.t == twin.t
    np.testing.assert_array_equal(s.q, twin.q)
    np.testing.assert_array_equal(s.L, twin.L)
    if s.n_bodies is not None:
        assert not s.failed.any()
    s.step(5)
    twin.step(5)
    np.testing.assert_array_equal(s.q, twin.q)
    np.testing.assert_array_equal(s.L, twin.L)


def test_ctrl_c_in_a_one_step_call_keeps_the_step_it_took(monkeypatch):
    """The fast path (step() of one body): Ctrl-C as the kernel returns keeps its step
    with the clock."""
    sc = _top()
    s = liebody.Stepper(sc, L0=[0.2, -0.1, 8.0], dt=0.01, method="splitting2")
    twin = liebody.Stepper(sc, L0=[0.2, -0.1, 8.0], dt=0.01, method="splitting2")
    s.step()
    twin.step()
    inner = s._call

    def interrupted(*args):
        inner(*args)
        raise KeyboardInterrupt

    s._call = interrupted
    with pytest.raises(liebody.IntegrationInterrupted) as info:
        s.step()
    s._call = inner
    twin.step()
    assert info.value.step == 1 and s.steps == 2 and s.t == twin.t
    np.testing.assert_array_equal(s.q, twin.q)
    s.step()
    twin.step()
    np.testing.assert_array_equal(s.q, twin.q)


_ENSEMBLE_CHILD = textwrap.dedent("""
    import json, signal, sys, time
    import numpy as np
    import liebody
    from liebody import quaternion as Q
    # a job started in the background without job control inherits SIGINT ignored
    signal.signal(signal.SIGINT, signal.default_int_handler)
    method, simd = sys.argv[1], json.loads(sys.argv[2])
    scene = liebody.FreeBody(liebody.RigidBody([1.0, 2.0, 2.5]))
    rng = np.random.default_rng(0)
    kw = dict(q0=Q.random(4000, rng=1), L0=rng.normal(size=(4000, 3)), dt=1e-3,
              method=method, threads=2, simd=simd)
    liebody.Stepper(scene, **kw).step(3)  # compiled (or loaded) before the clock starts
    s = liebody.Stepper(scene, **kw)
    print("ready", flush=True)
    try:
        s.step(10**7)
        out = {"interrupted": False}
    except liebody.IntegrationInterrupted as exc:
        out = {"interrupted": True, "step": exc.step, "steps": s.steps,
               "t": s.t == s.steps * 1e-3 and exc.t == s.t,
               "failed": int(s.failed.sum()), "finite": bool(np.isfinite(s.q).all())}
        print(json.dumps(out), flush=True)
        twin = liebody.Stepper(scene, **kw)
        twin.step(s.steps)
        out["same"] = bool(np.array_equal(twin.q, s.q) and np.array_equal(twin.L, s.L))
        s.step(50)
        twin.step(50)
        out["failed_after"] = int(s.failed.sum())
        out["same_after"] = bool(np.array_equal(twin.q, s.q))
    print(json.dumps(out), flush=True)
""")


@pytest.mark.parametrize(("method", "simd"), [("splitting2", None), ("splitting2", False),
                                              ("rattle", None)])
def test_ctrl_c_on_an_ensemble_on_threads(method, simd):
    """4000 bodies on 2 threads, SIGINT after 2 s (before: the threads went on running
    their slice while the state was restored under them, later steps marked healthy
    bodies failed, then SIGSEGV): the threads are joined, no body is marked, and the
    stepper is one that took exc.step steps, bit for bit."""
    lines, latency = interrupt_child(_ENSEMBLE_CHILD, [method, json.dumps(simd)], 2.0)
    first, out = lines[0], lines[-1]
    assert first["interrupted"] and latency < 10.0
    assert out["step"] == out["steps"] > 0 and out["t"] and out["finite"]
    assert out["failed"] == 0 and out["same"]
    assert out["failed_after"] == 0 and out["same_after"]


_SLOW_CHILD = textwrap.dedent("""
    import json, math, signal, sys, time
    import numpy as np
    from numba import njit
    import liebody
    signal.signal(signal.SIGINT, signal.default_int_handler)
    BUSY = int(sys.argv[1])

    @njit
    def slow(t, q, L):  # a torque that costs milliseconds per call
        acc = 0.0
        for i in range(BUSY):
            acc += math.sin(t + i * 1e-9)
        return np.array([0.0, 1e-30 * acc, -0.01 * L[2]])

    scene = liebody.TorqueBody(liebody.RigidBody([1.0, 2.0, 2.5]), slow)
    kw = dict(L0=[0.3, -1.0, 0.6], dt=1e-3, method="splitting2")
    probe = liebody.Stepper(scene, **kw)
    probe.step()
    t = time.perf_counter()
    probe.step()
    cost = time.perf_counter() - t
    s = liebody.Stepper(scene, **kw)
    print("ready", flush=True)
    try:
        s.step(100000)
        out = {"interrupted": False}
    except liebody.IntegrationInterrupted as exc:
        out = {"interrupted": True, "step": exc.step, "steps": s.steps, "cost": cost}
        print(json.dumps(out), flush=True)
        twin = liebody.Stepper(scene, **kw)
        twin.step(s.steps)
        out["same"] = bool(np.array_equal(twin.q, s.q) and np.array_equal(twin.L, s.L)
                           and twin.t == s.t)
    print(json.dumps(out), flush=True)
""")


def test_ctrl_c_stops_steps_with_a_slow_torque_within_seconds():
    """A step of milliseconds (a slow user torque): SIGINT is seen within seconds, since
    the slices are sized by their measured cost (before: slices of 65,536 steps, about
    100 s to see it), and the steps done are kept."""
    lines, latency = interrupt_child(_SLOW_CHILD, ["400000"], 1.5)
    first, out = lines[0], lines[-1]
    assert first["interrupted"], first
    assert first["cost"] > 5e-4  # the torque is slow, or the test proves nothing
    assert latency < 5.0
    assert out["step"] == out["steps"] > 0 and out["same"]


# ----------------------------------------------------------------------- 4. copies


@pytest.mark.parametrize("how", [copy.copy, copy.deepcopy])
@pytest.mark.parametrize("bodies", [None, N_ENS])
def test_a_copy_is_an_independent_stepper(how, bodies):
    """Before: copy.copy shared the state array, so stepping the copy moved the
    original's q while its t stayed."""
    sc = _controlled() if bodies is None else _controlled(liebody.RigidBody.batch(MOMENTS_ENS))
    kw = ({"L0": [0.3, -1.0, 0.6], "controls": [0.2, -0.1]} if bodies is None else
          {"q0": Q_ENS, "L0": L_ENS, "controls": RNG.normal(size=(N_ENS, 2))})
    s = liebody.Stepper(sc, dt=0.01, method="splitting2", **kw)
    s.step(3)
    s.step()
    q, L, t, u = s.q, s.L, s.t, s.u
    c = how(s)
    assert c is not s and c.t == t and c.steps == s.steps
    c.step(5)
    c.step()
    c.u = -2.0 * u
    c.step(2)
    np.testing.assert_array_equal(s.q, q)
    np.testing.assert_array_equal(s.L, L)
    np.testing.assert_array_equal(s.u, u)
    assert s.t == t and s.steps == 4
    s.step(5)
    s.step()
    s.u = -2.0 * u
    s.step(2)
    np.testing.assert_array_equal(s.q, c.q)
    np.testing.assert_array_equal(s.L, c.L)
    assert s.t == c.t and s.steps == c.steps == 12


# ----------------------------------------------------------------------- 5. pickle, threads


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
@pytest.mark.parametrize("bodies", [None, N_ENS])
def test_a_pickled_stepper_goes_on_as_the_original(bodies):
    """State, clock, step count, controls, failure marks and the plan (made for the
    momentum it was made for, not the current one) survive pickling."""
    sc = _controlled() if bodies is None else _controlled(liebody.RigidBody.batch(MOMENTS_ENS))
    kw = ({"L0": [0.3, -1.0, 0.6], "controls": [0.2, -0.1]} if bodies is None else
          {"q0": Q_ENS, "L0": L_ENS, "controls": RNG.normal(size=(N_ENS, 2))})
    s = liebody.Stepper(sc, dt=0.01, method="splitting2", **kw)
    s.step(40)  # the plan was made for L0, the state has moved on
    s.t = 1.5
    s.step(3)
    c = pickle.loads(pickle.dumps(s))
    assert (c.t, c.steps, c.method.name, c.dt) == (s.t, s.steps, s.method.name, s.dt)
    np.testing.assert_array_equal(c.u, s.u)
    for x in (s, c):
        x.step(7)
        x.step()
    np.testing.assert_array_equal(c.q, s.q)
    np.testing.assert_array_equal(c.L, s.L)
    s.L = s.L * 1.1  # set: re-planned at the next step, in both
    c = pickle.loads(pickle.dumps(s))
    for x in (s, c):
        x.step(4)
    np.testing.assert_array_equal(c.q, s.q)
    np.testing.assert_array_equal(c.L, s.L)


def test_pickling_keeps_the_failure_marks_of_an_ensemble():
    @njit
    def fails_for_big_L(t, q, L):
        if abs(L[0]) > 1.5:
            return np.array([np.nan, 0.0, 0.0])
        return np.array([0.0, 0.0, -0.01 * L[2]])

    L0 = np.array([[0.3, -1.0, 0.6], [2.0, 0.1, 0.2], [0.1, 0.2, 0.3]])
    sc = liebody.TorqueBody(liebody.RigidBody([1.0, 2.0, 2.5]), fails_for_big_L)
    s = liebody.Stepper(sc, L0=L0, dt=0.01, method="splitting2", simd=False)
    with pytest.warns(RuntimeWarning, match="1 of 3 bodies failed"):
        s.step(3)
    c = pickle.loads(pickle.dumps(s))
    np.testing.assert_array_equal(c.failed, [False, True, False])
    for x in (s, c):
        x.step(3)
    np.testing.assert_array_equal(c.q, s.q)


@pytest.mark.parametrize("bodies", [None, N_ENS])
def test_steps_from_many_threads_are_serialised(bodies):
    """8 threads stepping one stepper at once: the state of as many calls made one after
    another (before: the kernel's arguments and the clock were shared unlocked, and
    the results differed)."""
    sc = _top()
    kw = ({"L0": [0.2, -0.1, 8.0]} if bodies is None else
          {"q0": Q_ENS, "L0": L_ENS + [0.0, 0.0, 8.0], "threads": 2})
    n, calls = (1, 400) if bodies is None else (3, 20)
    s = liebody.Stepper(sc, dt=1e-3, method="splitting2", **kw)
    serial = liebody.Stepper(sc, dt=1e-3, method="splitting2", **kw)
    s.step(n)
    serial.step(n)
    for _ in range(8 * calls):
        serial.step(n)
    errors = []
    start = threading.Barrier(8)

    def work():
        try:
            start.wait()
            for _ in range(calls):
                s.step(n)
                _ = s.t, s.q  # reads between steps
        except Exception as exc:  # pragma: no cover - reported below
            errors.append(exc)

    run_threads([work] * 8)
    assert not errors
    assert s.steps == serial.steps and s.t == serial.t
    assert math.isclose(s.t, (8 * calls + 1) * n * 1e-3, rel_tol=1e-12)
    np.testing.assert_array_equal(s.q, serial.q)
    np.testing.assert_array_equal(s.L, serial.L)


# ----------------------------------------------------------------------- integrate()'s rules


@njit
def _depends_on_L(t, q, L):
    return -0.1 * L


@njit
def _nan_for_body_0(t, q, L, p):
    if p[0] < 0.0:
        return np.array([np.nan, 0.0, 0.0])
    return np.array([0.0, 0.0, p[0] * q[3]])


def test_the_stepper_checks_an_orientation_only_promise_as_integrate_does():
    scene = liebody.TorqueBody(liebody.RigidBody([1.0, 2.0, 3.0]), _depends_on_L,
                               orientation_only=True)
    with pytest.raises(ValueError, match="orientation_only"):
        liebody.Stepper(scene, L0=[1.0, 0.5, 0.2], dt=0.01)


def test_a_stepper_ensemble_fails_a_body_whose_torque_fails_at_its_start_alone():
    """Body 0 as any other (integrate's rule): before, the Stepper refused the ensemble."""
    scene = liebody.TorqueBody(liebody.RigidBody([1.0, 2.0, 3.0]), _nan_for_body_0,
                               params=[[-1.0], [0.5], [0.7]], orientation_only=True)
    st = liebody.Stepper(scene, L0=[1.0, 0.5, 0.2], dt=0.01)
    with pytest.warns(RuntimeWarning):
        st.step(5)
    assert list(st.failed) == [True, False, False]


@pytest.mark.parametrize(("fixed", "per_step"), [(0.17, 0.004), (0.0, 1e-4), (0.05, 1e-6)])
def test_slices_outgrow_a_fixed_cost_per_call(monkeypatch, fixed, per_step):
    """A call of k steps costing ``fixed + per_step k`` (a million satellites of per-body
    inertia on one thread: 0.17 s of set-up per call, 4 ms a step): after a few slices
    each slice holds about SLICE_SECONDS of stepping beyond the fixed cost. Sized by the
    rate alone they stayed at one step (each step paid the set-up: 176 ns a body-step
    instead of 8); without a fixed cost the sizes are the rate's, as before."""
    class Clock:
        now = 0.0

        def perf_counter(self):
            return self.now

    clock = Clock()
    monkeypatch.setattr(_engine, "time", clock)
    sizes = []
    for k in _engine.time_slices(10**9, False, "step", first=1):
        sizes.append(k)
        clock.now += fixed + per_step * k
        if len(sizes) == 10:
            break
    assert sizes[-1] == pytest.approx(_engine.SLICE_SECONDS / per_step, rel=0.03)
    assert all(b <= _engine.SLICE_GROWTH * a for a, b in itertools.pairwise(sizes))
    assert fixed + per_step * max(sizes) <= fixed + 2 * _engine.SLICE_SECONDS


def test_an_ensembles_failing_torque_is_named_in_its_words():
    """The warning of an ensemble Stepper whose body's torque failed gives the torque's
    own words at the failing step, as integrate()'s ensemble does (before: the reason
    'torque failed' alone)."""
    @njit
    def refuses_big_L(t, q, L):
        if abs(L[0]) > 1.5:
            raise ValueError("L[0] too big")
        return np.array([0.0, 0.0, -0.01 * L[2]])

    L0 = np.array([[0.3, -1.0, 0.6], [2.0, 0.1, 0.2], [0.1, 0.2, 0.3]])
    sc = liebody.TorqueBody(liebody.RigidBody([1.0, 2.0, 2.5]), refuses_big_L)
    words = r"raised ValueError \(L\[0\] too big\) at t = 0\.05"
    with pytest.warns(RuntimeWarning, match=r"Body 1: the torque .*" + words):
        liebody.integrate(sc, L0=L0, dt=0.01, steps=8, t0=0.05, method="splitting2",
                          simd=False)
    for simd in (False, True):
        s = liebody.Stepper(sc, L0=L0, dt=0.01, method="splitting2", simd=simd, t0=0.05)
        with pytest.warns(RuntimeWarning, match=r"1 of 3 bodies failed in this step\(3\) "
                                                r"call \(e\.g\. body 1: torque failed: the "
                                                r"torque .*" + words):
            s.step(3)
        np.testing.assert_array_equal(s.failed, [False, True, False])
