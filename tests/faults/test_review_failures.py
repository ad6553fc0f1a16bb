"""Where a failed run stopped: one meaning for each field, and words that say the same.

The fields (``errors.IntegrationError``, ``Trajectory.failed_at``): ``exc.step`` the steps
completed before the failing one, ``exc.t = t0 + step dt`` the time of the last good
state (where the failing step starts), ``failed_at = t0 + (step + 1) dt`` the time the
failing step was to reach, on the grid of the sample times, for one body, every body of
an ensemble (scalar and SIMD kernels) and ``Trajectory.failures``. The message names the
same numbers. References are independent facts: a sampled orbit's table covers
``[0, 10]``, a step evaluates the torque at times in ``[t, t + dt]`` (the baselines
``euler`` and ``lie_euler`` at ``t`` only), and ``dt``.
"""

from __future__ import annotations

import re
import warnings

import numpy as np
import pytest
from numba import njit

import liebody
from liebody.errors import ConvergenceError, IntegrationError, TorqueError
from liebody.orbits import Circular
from support import table_gravity_gradient

ORBIT = Circular(n=0.05, radius=10.0, inclination=0.2, raan=0.1, phase=0.3)
BODY = liebody.RigidBody([1.0, 1.7, 2.6])
L0 = [0.4, -1.1, 2.0]
DT = 0.1


def _scene():
    return table_gravity_gradient()


def _where(step: int, t0: float = 0.0, dt: float = DT) -> str:
    """The words that must name the failing step: its start, its end, the steps done."""
    start, end = t0 + step * dt, t0 + (step + 1) * dt
    steps = "step" if step == 1 else "steps"
    return f"in the step from t = {start:.10g} to t = {end:.10g} (after {step:,} {steps})"


#: the step that leaves the table [0, 10] first: the one from t = 10 for a method that
#: evaluates the torque inside or at the end of its step, the one from t = 10.1 for the
#: baselines that evaluate it at the step's start only
FIRST_OUTSIDE = {"splitting2": 100, "rattle": 100, "rk4": 100,
                 "rkmk4": 100, "euler": 101, "lie_euler": 101}


@pytest.mark.parametrize("method", sorted(FIRST_OUTSIDE))
def test_a_run_that_leaves_the_table_reports_one_step_and_its_times(method):
    """Before: 'at step 101 (t = 10)' with exc.step == 100, exc.t == 10 and failed_at
    10.1 (= 10 + 0.1, not the sample grid's 101 * 0.1), and the baselines reported a
    'non-finite state' for the torque's failure."""
    k = FIRST_OUTSIDE[method]
    with pytest.raises(TorqueError) as info:
        liebody.integrate(_scene(), L0=L0, dt=DT, steps=200, method=method)
    exc = info.value
    assert exc.step == k and exc.t == k * DT
    tr = exc.trajectory
    assert tr.failed_at == (k + 1) * DT and tr.status == "failed"
    assert tr.failures == ((None, (k + 1) * DT, "failed"),)
    assert len(tr) == k + 1 and tr.t[-1] == k * DT  # every sample before the failing step
    msg = str(exc)
    assert "outside the times [0, 10] that the scene's sampled orbits" in msg, msg
    assert _where(k) in msg, msg
    assert not re.search(r"at step \d", msg), msg


@pytest.mark.parametrize("method", ["rattle", "splitting2", "rk4", "euler"])
@pytest.mark.parametrize("simd", [False, True])
def test_the_bodies_of_an_ensemble_fail_where_the_one_body_run_does(method, simd):
    """failed_at per body is the one-body run's, bit for bit; the reason is the torque's
    (before: a baseline's bodies failed with a 'non-finite state')."""
    k = FIRST_OUTSIDE[method]
    with pytest.raises(TorqueError) as info:
        liebody.integrate(_scene(), L0=L0, dt=DT, steps=200, method=method)
    one = info.value.trajectory
    with pytest.warns(RuntimeWarning) as caught:
        ens = liebody.integrate(_scene(), L0=[L0, L0, L0], dt=DT, steps=200, method=method,
                                simd=simd, threads=1)
    assert ens.info["simd"] == (simd and method == "rattle")
    assert ens.failures == tuple((i, one.failed_at, "torque failed") for i in range(3))
    assert np.array_equal(ens.failed_at, np.full(3, (k + 1) * DT))
    for i in range(3):
        body = ens.body(i)
        assert body.failed_at == one.failed_at and body.t[-1] == k * DT
        np.testing.assert_array_equal(body.q, one.q)
    text = " ".join(str(w.message) for w in caught)
    assert f"3 torque failed (e.g. body 0 at t = {(k + 1) * DT:.10g}, the end of its " \
           f"failing step)" in text, text
    assert "outside the times [0, 10]" in text, text


@pytest.mark.parametrize("method", ["splitting2", "rattle", "rk4", "lie_euler", "rkmk4"])
def test_a_stepper_that_leaves_the_table_raises_the_torque_error(method):
    """The Stepper's error carries the steps of the call that succeeded and the time of
    the state it failed from (before, a baseline raised a non-finite state)."""
    st = liebody.Stepper(_scene(), L0=L0, dt=DT, method=method)
    st.step(50)
    with pytest.raises(TorqueError, match=r"outside the times \[0, 10\]") as info:
        st.step(150)
    k = FIRST_OUTSIDE[method]
    assert info.value.step == k - 50 and info.value.t == k * DT
    assert st.t == 50 * DT  # left as before the call
    # the words are the fields: the steps of this call, the failing step's start and end
    text = str(info.value)
    assert f"in the step from t = {k * DT:.10g} to t = {(k + 1) * DT:.10g} (after " \
           f"{k - 50:,} steps of this call)" in text, text


@njit
def _nan_after_half(t, q, L):
    if t > 0.5:
        return np.array([np.nan, 0.0, 0.0])
    return np.array([0.0, 0.0, 0.1])


@njit
def _spin_up(t, q, L):
    return np.array([0.0, 0.0, 20.0])


@pytest.mark.parametrize(("method", "k"), [("rk4", 4), ("rkmk4", 4), ("euler", 5),
                                            ("lie_euler", 5)])
def test_a_user_torque_that_fails_stops_a_baseline_ensemble_as_a_torque_failure(method, k):
    """A user torque NaN after t = 0.5, dt = 1/8 (exact in binary): rk4 and rkmk4 ask it
    at t + dt/2 first in the step from 0.5 (k = 4 steps done), euler and lie_euler at the
    step's start, first beyond 0.5 in the step from 0.625. Each body stops there as the
    one-body run does (before: a 'non-finite state')."""
    scene = liebody.TorqueBody(BODY, _nan_after_half)
    dt = 0.125
    with pytest.raises(TorqueError, match=r"returned non-finite values") as info:
        liebody.integrate(scene, L0=L0, dt=dt, steps=20, method=method)
    assert info.value.step == k and info.value.t == k * dt
    assert info.value.trajectory.failed_at == (k + 1) * dt
    with pytest.warns(RuntimeWarning, match="torque failed"):
        ens = liebody.integrate(scene, L0=[L0, L0], dt=dt, steps=20, method=method, threads=1)
    assert ens.failures == ((0, (k + 1) * dt, "torque failed"), (1, (k + 1) * dt,
                                                                  "torque failed"))


def test_a_convergence_error_names_its_step_as_its_fields_do():
    """An unsolved DMV equation, from t0 = 0.3: the same fields and words."""
    scene = liebody.TorqueBody(liebody.RigidBody([1.0, 2.0, 2.5]), _spin_up,
                               orientation_only=True)
    dt, t0 = 0.01, 0.3
    with pytest.raises(ConvergenceError) as info:
        liebody.integrate(scene, L0=[0.3, 0.2, 1.0], dt=dt, steps=100_000, method="rattle",
                          t0=t0)
    exc = info.value
    k = exc.step
    assert 100 < k < 100_000 and exc.t == t0 + k * dt
    tr = exc.trajectory
    assert tr.failed_at == t0 + (k + 1) * dt and len(tr) == k + 1 and tr.t[-1] == exc.t
    assert _where(k, t0, dt) in str(exc), str(exc)


def test_a_state_that_blows_up_names_its_step_as_the_fields_do():
    """Explicit Euler far beyond its stability (h |omega| ~ 100): a non-finite state, not a
    torque failure (the torque at the last good state is finite), with the same fields
    and words; the Stepper raises with the same step and time."""
    scene = liebody.GravityGradient(BODY, [(1.0, ORBIT)])
    L = np.array(L0) * 1e3
    with pytest.warns(RuntimeWarning, match="state became non-finite") as caught:
        tr = liebody.integrate(scene, L0=L, dt=DT, steps=2000, method="euler", t0=0.5)
    assert tr.status == "failed"
    k = len(tr) - 1  # (every step saved)
    assert tr.t[-1] == 0.5 + k * DT and tr.failed_at == 0.5 + (k + 1) * DT
    assert tr.failures == ((None, tr.failed_at, "failed"),)
    text = " ".join(str(w.message) for w in caught)
    assert _where(k, 0.5) in text, text
    st = liebody.Stepper(scene, L0=L, dt=DT, method="euler", t0=0.5)
    with pytest.raises(IntegrationError, match="non-finite") as info:
        st.step(2000)
    assert type(info.value) is IntegrationError
    assert info.value.step == k and info.value.t == 0.5 + k * DT
    assert _where(k, 0.5).replace(" steps)", " steps of this call)") in str(info.value)


def test_the_exact_flow_names_the_samples_it_failed_between():
    """The exact flow at its samples: the failing 'step' is the stretch between two
    samples (here of one step each)."""
    scene = liebody.FreeBody(liebody.RigidBody([1e-50, 2e-50, 3e-50]))
    with pytest.warns(RuntimeWarning, match="state became non-finite") as caught:
        tr = liebody.integrate(scene, L0=[1e149, 0.0, 0.0], dt=1.0, steps=10)
    assert tr.status == "failed" and len(tr) == 1 and tr.failed_at == 1.0
    text = " ".join(str(w.message) for w in caught)
    assert _where(0, 0.0, 1.0) in text, text


def test_a_healthy_baseline_run_to_the_end_of_the_table_completes():
    """The check of the torque runs only on a failing step: a baseline run whose last step
    reaches the table's end (rk4 evaluates its torque at t = 10 there) completes without
    a warning (bit-for-bit agreement of every driver is tests/kernels/test_driver.py's)."""
    for method in ("rk4", "rkmk4", "euler", "lie_euler"):
        with warnings.catch_warnings():
            warnings.simplefilter("error", RuntimeWarning)
            warnings.simplefilter("ignore", liebody.InvariantWarning)  # (euler's |q| grows)
            tr = liebody.integrate(_scene(), L0=L0, dt=DT, steps=100, method=method)
        assert tr.status == "complete" and tr.t[-1] == 100 * DT


def test_a_composition_that_reads_before_the_table_says_so(triple_jump):
    """The first step's first stage reads the orbit at -0.35 dt, before the table: the
    one-body error, the ensemble's warning and the Stepper's error say that time is
    outside the table (before: 'its parameters overflow')."""
    scene = table_gravity_gradient("axes")
    words = r"the time t = -0\.035\d* is outside the times \[0, 10\]"
    for steps in (5, 5000):  # a short run, and one in slices
        with pytest.raises(TorqueError, match=words) as info:
            liebody.integrate(scene, L0=L0, dt=DT, steps=steps, method=triple_jump)
        assert info.value.step == 0 and "overflow" not in str(info.value)
    for simd in (False, True):
        with pytest.warns(RuntimeWarning, match=words):
            liebody.integrate(scene, L0=[L0, L0, L0], dt=DT, steps=5, method=triple_jump,
                              simd=simd, threads=1)
    with pytest.raises(TorqueError, match=words) as info:
        liebody.Stepper(scene, L0=L0, dt=DT, method=triple_jump).step(5)
    assert info.value.step == 0 and "overflow" not in str(info.value)


def test_a_composition_that_reads_past_the_table_says_so(triple_jump):
    """Started inside, the run fails in the step whose last stages read past t = 10."""
    with pytest.raises(TorqueError, match=r"the time t = 10\.0\d* is outside the times "
                                          r"\[0, 10\]") as info:
        liebody.integrate(table_gravity_gradient("axes"), L0=L0, dt=DT, steps=200,
                          method=triple_jump, t0=0.1)
    assert info.value.t < 10.0 < info.value.t + 1.36 * DT
