"""One rule for every body of an ensemble: a torque that fails at a body's state fails that
body, whichever it is, and the warning says why."""

from __future__ import annotations

import numpy as np
import pytest
from numba import njit

import liebody


@njit
def _bad_where_p_is_negative(t, q, L, p):
    """A torque of the orientation only (explicit kicks: the SIMD kernels run it too)."""
    if p[0] < 0.0:
        return np.array([np.nan, 0.0, 0.0])
    return -p[0] * q[1:]


@njit
def _raises_where_p_is_negative(t, q, L, p):
    if p[0] < 0.0:
        raise ValueError("negative drag")
    return -p[0] * L


@pytest.mark.parametrize("bad", [0, 1, 3])
@pytest.mark.parametrize("simd", [False, True])
def test_a_torque_nan_at_one_bodys_start_fails_that_body_only(bad, simd):
    rates = np.array([[0.1], [0.2], [0.3], [0.4]])
    rates[bad] = -1.0
    scene = liebody.TorqueBody(liebody.RigidBody([1.0, 2.0, 3.0]), _bad_where_p_is_negative,
                               params=rates, orientation_only=True)
    with pytest.warns(RuntimeWarning, match=rf"1 of 4 bodies failed.*torque failed "
                                            rf"\(e\.g\. body {bad} .*non-finite values"):
        tr = liebody.integrate(scene, L0=[1.0, -0.5, 2.0], dt=0.05, steps=30, save_every=10,
                               simd=simd)
    assert tr.status[bad].startswith("failed")
    assert np.isfinite(tr.failed_at[bad]) and np.isnan(tr.q[bad, 1:]).all()
    # the failure as a record, not words to parse
    assert tr.failures == ((bad, tr.failed_at[bad], "torque failed"),)
    assert tr.failures[0].body == bad and tr.failures[0].reason == "torque failed"
    for i in set(range(4)) - {bad}:
        assert tr.status[i] == "complete"
        one = liebody.integrate(liebody.TorqueBody(liebody.RigidBody([1.0, 2.0, 3.0]),
                                                   _bad_where_p_is_negative, params=rates[i],
                                                   orientation_only=True),
                                L0=[1.0, -0.5, 2.0], dt=0.05, steps=30, save_every=10)
        np.testing.assert_allclose(tr.q[i], one.q, rtol=0, atol=1e-15)


def test_an_ensembles_torque_warning_shows_the_exception():
    rates = np.array([[0.1], [-0.2], [0.3]])
    scene = liebody.TorqueBody(liebody.RigidBody([1.0, 2.0, 3.0]), _raises_where_p_is_negative,
                               params=rates)
    with pytest.warns(RuntimeWarning, match=r"Body 1: the torque _raises_where_p_is_negative"
                                            r"\(t, q, L, p\) raised ValueError \(negative drag"):
        tr = liebody.integrate(scene, L0=[1.0, -0.5, 2.0], dt=0.05, steps=5)
    assert [s == "complete" for s in tr.status] == [True, False, True]


def test_one_body_still_refuses_a_torque_that_fails_at_its_start():
    scene = liebody.TorqueBody(liebody.RigidBody([1.0, 2.0, 3.0]), _bad_where_p_is_negative,
                               params=[-1.0])
    with pytest.raises(liebody.TorqueError, match="non-finite values"):
        liebody.integrate(scene, L0=[1.0, -0.5, 2.0], dt=0.05, steps=5)


@njit
def _fails_after_half_a_second(t, q, L, p):
    if t > 0.5:
        return np.array([np.nan, 0.0, 0.0])
    return -p[0] * q[1:]


@pytest.mark.parametrize("n", [None, 3])
def test_a_run_whose_bodies_all_failed_stops(monkeypatch, n):
    """Once every body has failed, no further slice of the run is started (before, an
    ensemble stepped through the rest of its steps, every body skipped); one body and
    an ensemble take the same engine and the same rule."""
    from liebody import _engine, _ensemble

    monkeypatch.setattr(_engine, "USER_FIRST_SLICE", 4)
    issued = []
    slices = _ensemble.time_slices
    monkeypatch.setattr(_ensemble, "time_slices",
                        lambda *a: (issued.append(k) or k for k in slices(*a)))
    rates = [0.1] if n is None else np.array([[0.1], [0.2], [0.3]])
    scene = liebody.TorqueBody(liebody.RigidBody([1.0, 2.0, 3.0]), _fails_after_half_a_second,
                               params=rates, orientation_only=True)
    steps = 200_000
    if n is None:
        with pytest.raises(liebody.TorqueError, match="non-finite values") as info:
            liebody.integrate(scene, L0=[1.0, -0.5, 2.0], dt=0.05, steps=steps)
        assert info.value.step == 10
    else:
        with pytest.warns(RuntimeWarning, match="3 of 3 bodies failed"):
            tr = liebody.integrate(scene, L0=[1.0, -0.5, 2.0], dt=0.05, steps=steps,
                                   simd=False)
        assert [r.reason for r in tr.failures] == ["torque failed"] * 3
    assert issued and sum(issued) < 1000 < steps  # stopped after the failures
