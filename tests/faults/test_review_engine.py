"""The one run engine (one body is an ensemble of one) reports a one-body run's outcomes as
the one-body class before it did: errors raised with their samples, step, time and cause,
blow-ups returned with a warning at the caller's line, Ctrl-C keeping the finished slices,
the Stepper's failures the same as integrate()'s."""

from __future__ import annotations

import contextlib
import sys
import traceback
import warnings

import numpy as np
import pytest
from numba import njit

import liebody
from liebody import _engine, _ensemble
from support import HLW_L0, hlw_body

BODY = liebody.RigidBody([1.0, 2.0, 3.0])


def _hlw():
    return liebody.FreeBody(hlw_body())


@contextlib.contextmanager
def _recorded():
    """The warnings emitted in the block (integrate() is called in the test's own frame,
    so that a warning one frame too far out lands in pytest's file, not in this one)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        yield caught


def _at_caller(caught, category=RuntimeWarning, n: int = 1):
    """Exactly ``n`` warnings of ``category``, each pointing at this file (the caller)."""
    mine = [w for w in caught if w.category is category]
    assert len(mine) == n, [(w.category.__name__, str(w.message)) for w in caught]
    for w in mine:
        assert w.filename == __file__, (w.filename, w.lineno, str(w.message))
    return mine


@njit
def _nan_after_half(t, q, L):
    if t > 0.5:
        return np.array([np.nan, 0.0, 0.0])
    return -0.1 * q[1:]


@njit
def _raises_after(t, q, L):
    if t > 0.31:
        raise ValueError("no thruster data")
    return np.array([0.0, 0.0, 0.01])


@njit
def _huge_kick(t, q, L):
    return np.array([1e300, 0.0, 0.0])


# ----------------------------------------------------------------------- warnings' lines


@pytest.mark.parametrize("kw", [
    {"steps": 10_000, "method": "rk4"},  # long: sliced
    {"steps": 10_000, "method": "euler", "save_every": 3, "t0": 2.5},
    {"steps": 400, "method": "rk4", "diagnostics": True},  # one call, with diagnostics
    {"steps": 10_000, "method": "rk4", "diagnostics": True},
    {"steps": 400, "method": "rk4", "progress": True},
    {"steps": 40, "method": "rk4"},  # the short-call path
])
def test_a_one_body_blow_up_warns_at_the_callers_line(kw):
    """rk4/euler at a big step: the samples before the failing step, failed_at its end,
    one RuntimeWarning whose file is the caller's (not liebody's)."""
    dt = 0.5
    with _recorded() as caught:
        tr = liebody.integrate(_hlw(), L0=HLW_L0 * 1e3, dt=dt, **kw)
    (w,) = _at_caller(caught)
    assert "became non-finite" in str(w.message)
    t0 = kw.get("t0", 0.0)
    assert tr.status == "failed" and len(tr) >= 2
    assert np.isfinite(tr.q).all() and np.isfinite(tr.L).all()
    every = kw.get("save_every", 1)
    assert tr.t[0] == t0 and tr.t[-1] == pytest.approx(t0 + dt * every * (len(tr) - 1))
    assert tr.t[-1] < tr.failed_at <= tr.t[-1] + dt * every  # (the failing step's end)


@pytest.mark.parametrize("kw", [{"steps": 10}, {"steps": 5000}, {"steps": 10, "progress": True}])
def test_the_exact_flow_that_turns_non_finite_warns_at_the_callers_line(kw):
    scene = liebody.FreeBody(liebody.RigidBody([1e-50, 2e-50, 3e-50]))
    with _recorded() as caught:
        tr = liebody.integrate(scene, L0=[1e149, 0.0, 0.0], dt=1.0, **kw)
    assert tr.status == "failed" and len(tr) == 1 and tr.failed_at == 1.0
    ws = _at_caller(caught, n=2)  # the phase lost, and the non-finite state
    assert any("became non-finite" in str(w.message) for w in ws)


@pytest.mark.parametrize("save_every", [1, 3, None])
@pytest.mark.parametrize("steps", [10, 5000])
def test_an_overflowing_L_warns_at_the_callers_line(steps, save_every):
    scene = liebody.TorqueBody(BODY, _huge_kick, orientation_only=True)
    with _recorded() as caught:
        tr = liebody.integrate(scene, L0=[1.0, 0.5, 0.5], dt=0.01, steps=steps,
                               method="splitting2", save_every=save_every)
    (w,) = _at_caller(caught)
    assert "|L| reached" in str(w.message)
    assert tr.status == "failed" and np.all(np.abs(tr.L) <= 1e150)


@pytest.mark.parametrize("kw", [
    {"steps": 5000},  # the exact flow, sliced (before the fix: one frame past the caller)
    {"steps": 5000, "progress": True},
    {"steps": 50, "diagnostics": True},
    {"steps": 5000, "method": "splitting2"},
    {"steps": 5000, "method": "splitting2", "diagnostics": True},
])
def test_a_one_body_runs_invariant_warning_is_at_the_callers_line(monkeypatch, kw):
    """The end-of-run check's InvariantWarning (a drift made up here: the exact flow keeps
    its invariants) points at integrate()'s caller, for the exact flow as for a stepped
    run. Before the fix the exact flow's pointed one frame beyond it (a file "sys")."""
    monkeypatch.setattr(_engine, "_one_body_problems", lambda *a: ["made-up drift"])
    with _recorded() as caught:
        liebody.integrate(_hlw(), L0=HLW_L0, dt=0.1, **kw)
    (w,) = _at_caller(caught, liebody.InvariantWarning)
    assert "made-up drift" in str(w.message)


@njit
def _nan_after_p(t, q, L, p):
    if t > p[0]:
        return np.array([np.nan, 0.0, 0.0])
    return -0.1 * q[1:]


@pytest.mark.parametrize("simd", [False, True])
def test_an_ensembles_failure_summary_is_at_the_callers_line(simd):
    scene = liebody.TorqueBody(BODY, _nan_after_p, params=np.array([[0.1], [0.5], [1e9]]),
                               orientation_only=True)
    with _recorded() as caught:
        tr = liebody.integrate(scene, L0=[1.0, -0.5, 2.0], dt=0.01, steps=5000, simd=simd,
                               diagnostics=True)
    (w,) = _at_caller(caught)
    assert "2 of 3 bodies failed" in str(w.message)
    assert list(tr.status) == ["failed: torque failed"] * 2 + ["complete"]


@pytest.mark.parametrize("method", ["exact", "splitting2", "rk4"])
@pytest.mark.parametrize("bodies", [1, 2])
def test_an_energy_beyond_float64_brings_no_numpy_warning(method, bodies):
    """|L| = 1e149 (accepted) on moments of 1e-50: the energy is beyond float64. The run's
    own warnings come, each at the caller's line; the diagnostics' reference, the exact
    flow's sampled diagnostics and the ensemble's end-of-run check add no numpy
    "overflow encountered" warnings from liebody's lines (before the fix: up to four)."""
    scene = liebody.FreeBody(liebody.RigidBody([1e-50, 2e-50, 3e-50]))
    L0 = [1e149, 0.0, 0.0] if bodies == 1 else [[1e149, 0.0, 0.0], [1e-3, 0.0, 0.0]]
    with _recorded() as caught:
        tr = liebody.integrate(scene, L0=L0, dt=1.0, steps=10, method=method,
                               diagnostics=True)
    assert caught
    for w in caught:
        assert w.filename == __file__, (w.filename, w.lineno, str(w.message))
    assert len(tr) >= 1


# ----------------------------------------------------------------------- errors raised


@pytest.mark.parametrize("kw", [
    {"steps": 5000}, {"steps": 5000, "t0": 0.2, "save_every": 4}, {"steps": 15, "dt": 0.05},
    {"steps": 5000, "method": "rk4"}, {"steps": 5000, "method": "splitting4"},
    {"steps": 5000, "diagnostics": True}, {"steps": 100, "progress": True},
])
def test_a_torque_returning_nan_raises_with_the_samples_before(kw):
    """One body, long (sliced) or short: TorqueError with the samples before the failing
    step on .trajectory, .step and .t where that step starts, failed_at its end."""
    kw = {"dt": 0.01, **kw}
    dt = kw["dt"]
    scene = liebody.TorqueBody(BODY, _nan_after_half, orientation_only=True)
    with pytest.raises(liebody.TorqueError, match=r"returned non-finite values \[nan") as info:
        liebody.integrate(scene, L0=[1.0, -0.5, 2.0], **kw)
    exc = info.value
    t0, every = kw.get("t0", 0.0), kw.get("save_every", 1)
    assert exc.t == pytest.approx(t0 + exc.step * dt) and exc.t >= 0.5 - 2 * dt
    tr = exc.trajectory
    assert tr.status == "failed" and tr.failed_at == pytest.approx(exc.t + dt)
    assert len(tr) == 1 + exc.step // every
    fresh = liebody.integrate(scene, L0=[1.0, -0.5, 2.0], steps=exc.step,
                              **{k: v for k, v in kw.items() if k not in ("steps", "progress")})
    np.testing.assert_array_equal(tr.q, fresh.q[:len(tr)])
    np.testing.assert_array_equal(tr.L, fresh.L[:len(tr)])


@pytest.mark.parametrize("steps", [100, 10])
def test_a_torque_that_raises_is_the_errors_cause(steps):
    scene = liebody.TorqueBody(BODY, _raises_after)
    dt = 0.01 if steps == 100 else 0.05
    with pytest.raises(liebody.TorqueError, match="raised ValueError") as info:
        liebody.integrate(scene, L0=[1.0, -0.5, 2.0], dt=dt, steps=steps)
    exc = info.value
    assert type(exc.__cause__) is ValueError and exc.__suppress_context__
    assert exc.t <= 0.31 < exc.t + dt + 1e-12
    assert len(exc.trajectory) == exc.step + 1


def _raise_while_handling(fn):
    try:
        raise LookupError("the user's own, handled")
    except LookupError:
        fn()


@pytest.mark.parametrize("where", ["long", "short", "stepper"])
def test_a_torque_error_hides_the_callers_handled_exception(where):
    """A TorqueError raised from the torque's words (here: it returned NaN, no exception
    of its own) is raised as ``raise ... from`` raised it: a caller's exception being
    handled is not shown as its context. Before the fix it was ("During handling of the
    above exception, another exception occurred")."""
    scene = liebody.TorqueBody(BODY, _nan_after_half, orientation_only=True)
    L0 = [1.0, -0.5, 2.0]
    if where == "stepper":
        def fn():
            liebody.Stepper(scene, L0=L0, dt=0.01).step(100)
    else:
        def fn():
            liebody.integrate(scene, L0=L0, dt=0.01 if where == "long" else 0.1,
                              steps=5000 if where == "long" else 15)
    with pytest.raises(liebody.TorqueError) as info:
        _raise_while_handling(fn)
    exc = info.value
    assert exc.__suppress_context__ and exc.__cause__ is None
    text = "".join(traceback.format_exception(exc))
    assert "LookupError" not in text, text


# ----------------------------------------------------------------------- convergence


@njit
def _spin_up(t, q, L):
    return np.array([0.0, 0.0, 20.0])


@pytest.mark.parametrize("steps", [50, 100_000])
def test_an_implicit_equation_without_root_raises_as_the_stepper_does(steps):
    """integrate() and the Stepper name the same failing step and time."""
    scene = liebody.TorqueBody(liebody.RigidBody([1.0, 2.0, 2.5]), _spin_up,
                               orientation_only=True)
    kw = {"L0": [0.3, 0.2, 1.0], "dt": 0.01, "method": "rattle"}
    if steps == 50:  # at the first step
        scene, kw = _hlw(), {"L0": HLW_L0 * 1e4, "dt": 10.0, "method": "rattle"}
    with pytest.raises(liebody.ConvergenceError, match="reduce dt") as a:
        liebody.integrate(scene, steps=steps, **kw)
    s = liebody.Stepper(scene, **kw)
    with pytest.raises(liebody.ConvergenceError, match="reduce dt") as b:
        s.step(100_000)
    assert (a.value.step, a.value.t) == (b.value.step, b.value.t)
    assert len(a.value.trajectory) == a.value.step + 1
    assert a.value.trajectory.failed_at == pytest.approx(a.value.t + kw["dt"])


@njit
def _stiff(t, q, L):
    return -1e4 * L * (L[0] * L[0] + L[1] * L[1] + L[2] * L[2])


@pytest.mark.parametrize("steps", [5, 50])
def test_an_implicit_kick_that_does_not_converge_raises_as_the_stepper_does(steps):
    scene = liebody.TorqueBody(BODY, _stiff)
    kw = {"L0": [1.0, 0.5, 0.5], "dt": 0.1, "method": "splitting2"}
    with pytest.raises(liebody.ConvergenceError, match="implicit kick") as a:
        liebody.integrate(scene, steps=steps, **kw)
    with pytest.raises(liebody.ConvergenceError, match="implicit kick") as b:
        liebody.Stepper(scene, **kw).step(steps)
    assert (a.value.step, a.value.t) == (b.value.step, b.value.t)


# ----------------------------------------------------------------------- Ctrl-C


@pytest.mark.parametrize("after", [False, True])
def test_ctrl_c_in_a_long_one_body_run_keeps_the_finished_slices(monkeypatch, after):
    """Ctrl-C seen at the second slice (as it starts, or as it returns: a slice that is
    not counted is not kept): the first slice's samples, its step count and time, the
    run's own numbers."""
    kw = {"L0": HLW_L0, "dt": 0.01, "method": "splitting2", "save_every": 7, "t0": 1.25}
    liebody.integrate(_hlw(), steps=3, **kw)  # (compiled)
    real, calls = _ensemble.drive, []

    def drive(*a):
        calls.append(1)
        if len(calls) == 2 and not after:
            raise KeyboardInterrupt
        out = real(*a)
        if len(calls) == 2:
            raise KeyboardInterrupt
        return out

    monkeypatch.setattr(_ensemble, "drive", drive)
    with pytest.raises(liebody.IntegrationInterrupted) as info:
        liebody.integrate(_hlw(), steps=100_000, **kw)
    monkeypatch.undo()
    exc = info.value
    first = _engine.FIRST_SLICE
    assert isinstance(exc, KeyboardInterrupt)
    assert exc.step == first and exc.t == pytest.approx(1.25 + first * 0.01)
    tr = exc.trajectory
    assert tr.status == "interrupted" and len(tr) == 1 + first // 7
    fresh = liebody.integrate(_hlw(), steps=first, **kw)
    np.testing.assert_array_equal(tr.q, fresh.q[:len(tr)])
    np.testing.assert_array_equal(tr.L, fresh.L[:len(tr)])
    np.testing.assert_array_equal(tr.t, fresh.t[:len(tr)])


# ----------------------------------------------------------------------- the stop rule


@pytest.mark.parametrize("simd", [False, True])
def test_an_ensemble_whose_bodies_fail_at_different_times_stops_after_the_last(
        monkeypatch, simd):
    """The bodies fail at 0.1, 0.3 and 0.5: the run slices on until the last has failed
    and then stops, every body's records as a run to the end would give them."""
    monkeypatch.setattr(_engine, "USER_FIRST_SLICE", 4)
    issued = []
    slices = _ensemble.time_slices
    monkeypatch.setattr(_ensemble, "time_slices",
                        lambda *a: (issued.append(k) or k for k in slices(*a)))
    scene = liebody.TorqueBody(BODY, _nan_after_p, params=np.array([[0.1], [0.3], [0.5]]),
                               orientation_only=True)
    with pytest.warns(RuntimeWarning, match="3 of 3 bodies failed"):
        tr = liebody.integrate(scene, L0=[1.0, -0.5, 2.0], dt=0.01, steps=10**6, simd=simd)
    assert tr.info["simd"] is simd
    assert 50 <= sum(issued) < 10_000
    for i, t_fail in enumerate([0.1, 0.3, 0.5]):
        assert t_fail <= tr.failed_at[i] <= t_fail + 0.02
        kept = round(tr.failed_at[i] / 0.01)  # the samples before the failing step
        assert np.isfinite(tr.q[i, :kept]).all() and np.isnan(tr.q[i, kept:]).all()


# ----------------------------------------------------------------------- reaction wheels


def _wheel_scene(n: int = 1):
    body = BODY if n == 1 else liebody.RigidBody.batch([[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]])
    return liebody.ReactionWheels(body, np.eye(3), np.array([0.05, 0.04, 0.06]),
                                  momentum=[0.1, 0.2, -0.1], max_speed=12.0, max_torque=0.05)


@pytest.mark.parametrize(("method", "steps"), [("rk4", 9000), ("euler", 200)])
def test_a_wheel_runs_blow_up_warns_at_the_callers_line(method, steps):
    """One body with reaction wheels (a run of its own, cut where the rates change): the
    samples before the failing step and one warning, at the caller's line. Before the
    fix it was at liebody/wheels.py (two frames short)."""
    with _recorded() as caught:
        tr = liebody.integrate(_wheel_scene(), omega0=[40.0, -30.0, 20.0], dt=0.5, steps=steps,
                               controls=[0.01, -0.02, 0.03], method=method)
    (w,) = _at_caller(caught)
    assert "became non-finite" in str(w.message)
    assert tr.status == "failed" and tr.failed_at > tr.t[-1]
    assert np.isfinite(tr.q).all() and len(tr.wheels) == len(tr)


def test_a_wheel_runs_end_check_warns_at_the_callers_line(monkeypatch):
    """The wheels' end-of-run check (|q| off 1: made up here) warns at the caller's line,
    for one body and for an ensemble (whose bodies run one at a time; before the fix
    the warnings pointed into liebody: _wheels.py and _integrate.py)."""
    from liebody import _wheels

    monkeypatch.setattr(_wheels, "_QNORM_TOL", -1.0)
    kw = {"omega0": [0.04, -0.03, 0.02], "dt": 0.1, "steps": 300,
          "controls": [0.01, -0.02, 0.03], "save_every": 3}
    with _recorded() as caught:
        liebody.integrate(_wheel_scene(), **kw)
    (w,) = _at_caller(caught, liebody.InvariantWarning)
    assert "|q| =" in str(w.message)
    with _recorded() as caught:
        liebody.integrate(_wheel_scene(2), **kw)
    assert all("|q| =" in str(w.message)
               for w in _at_caller(caught, liebody.InvariantWarning, n=2))


def test_a_wheel_ensembles_failure_summary_warns_at_the_callers_line():
    """One body of two blows up: one summary warning, at the caller's line (before the
    fix at liebody/_integrate.py), and the other body's end check at the caller's too."""
    with _recorded() as caught:
        tr = liebody.integrate(_wheel_scene(2), omega0=[[0.04, -0.03, 0.02], [40.0, -30.0, 20.0]],
                               dt=0.5, steps=700, controls=[0.01, -0.02, 0.03], method="rk4")
    (w,) = _at_caller(caught)
    assert "1 of 2 bodies failed" in str(w.message)
    _at_caller(caught, liebody.InvariantWarning)  # body 0's |q| at rk4's large step
    assert list(tr.status) == ["complete", "failed: non-finite state"]


def test_a_wheel_runs_overflow_warns_at_the_callers_line(monkeypatch):
    """|L| beyond the largest accepted (lowered here to 1, so that a plain wheel run
    reaches it) stops a wheel run with a warning at the caller's line."""
    monkeypatch.setattr(_engine, "MAX_MOMENTUM", 1.0)
    monkeypatch.setattr(_ensemble, "MAX_MOMENTUM", 1.0)
    with _recorded() as caught:
        tr = liebody.integrate(_wheel_scene(), omega0=[40.0, -30.0, 20.0], dt=0.01,
                               steps=300, controls=[0.01, -0.02, 0.03])
    (w,) = _at_caller(caught)
    assert "|L| reached" in str(w.message)
    assert tr.status == "failed" and tr.failed_at is not None


if __name__ == "__main__":  # pragma: no cover
    sys.exit(pytest.main([__file__, "-q"]))
