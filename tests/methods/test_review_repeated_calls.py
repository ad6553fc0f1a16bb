"""A hostile review of the repeated short ``integrate()`` call (``_integrate._ShortCall``):
where it could differ from a first call (the general path), the cases that did."""

from __future__ import annotations

import contextlib
import gc
import math
import warnings
import weakref

import numba
import numpy as np
import pytest

import liebody
from liebody import _methods
from liebody.errors import TorqueError
from support import hlw_body, same_trajectory

_CALLS = "_memo_short_calls"


def _try_to_write(t: np.ndarray) -> None:
    """What a user may do to a trajectory's times: make them (or the array they view)
    writeable, shift them."""
    while isinstance(t, np.ndarray):
        with contextlib.suppress(ValueError):
            t.flags.writeable = True
        with contextlib.suppress(ValueError):
            t[1:2] = -1.0
        t = t.base


@pytest.mark.parametrize("steps, t0", [(3, 0.0), (3, 2.5), (100, 0.0), (100, 2.5)])
def test_the_times_of_one_call_are_not_another_calls(hlw, steps, t0):
    """The repeated calls share their sample times: no trajectory may change them for the
    others (nor for the sample times' cache of the general path). 100 samples are beyond
    the cache of short runs' times: they were handed out writeable."""
    scene, L0 = hlw
    kw = dict(dt=0.01, steps=steps, method="splitting2", t0=t0)
    want = t0 + 0.01 * np.arange(steps + 1, dtype=float)
    first = liebody.integrate(scene, L0=L0, **kw)
    again = liebody.integrate(scene, L0=L0, **kw)
    for traj in (first, again):
        assert not traj.t.flags.writeable
        _try_to_write(traj.t)
    np.testing.assert_array_equal(first.t, want)
    np.testing.assert_array_equal(liebody.integrate(scene, L0=L0, **kw).t, want)
    np.testing.assert_array_equal(liebody.integrate(liebody.FreeBody(scene.body), L0=L0,
                                                    **kw).t, want)


def _blow_up_scenes():
    body = hlw_body()

    @numba.njit
    def none(t, q, L):
        return np.zeros(3)

    return [liebody.FreeBody(body), liebody.TorqueBody(body, none)]


@pytest.mark.parametrize("which", [0, 1])
def test_a_blow_up_warns_at_the_callers_line_on_every_call(hlw, which):
    """A baseline that blows up within a short run warns (``RuntimeWarning``) at the line
    of the caller, on the first call and on the repeated ones, as ``InvariantWarning``
    does (with a user torque, which the failure is first asked about, too)."""
    scene = _blow_up_scenes()[which]
    L0 = hlw[1] * 1e100
    got = []
    for _ in range(3):
        with warnings.catch_warnings(record=True) as w:
            warnings.simplefilter("always")
            traj = liebody.integrate(scene, L0=L0, dt=1e3, steps=3, method="euler")
        assert traj.status == "failed"
        got.append([(str(x.message), x.category, x.filename, x.lineno) for x in w])
    assert len(got[0]) == 1 and got[0][0][1] is RuntimeWarning
    assert "the state became non-finite" in got[0][0][0]
    assert got[0][0][2] == __file__
    assert got[0] == got[1] == got[2]


@pytest.mark.parametrize("which", [0, 1])
@pytest.mark.parametrize("kw", [dict(diagnostics=True), dict(steps=100_000)])
def test_a_blow_up_of_a_longer_run_warns_at_the_callers_line(hlw, which, kw):
    """The same for the general path's runs (with diagnostics; in slices)."""
    scene = _blow_up_scenes()[which]
    kw = {"steps": 3, **kw}
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        traj = liebody.integrate(scene, L0=hlw[1] * 1e100, dt=1e3, method="euler", **kw)
    assert traj.status == "failed"
    assert [x.category for x in w] == [RuntimeWarning], [str(x.message) for x in w]
    assert "the state became non-finite" in str(w[0].message)
    assert w[0].filename == __file__


def test_the_cached_times_of_short_runs_cannot_be_written(hlw):
    """A run of the general path (diagnostics) hands out the cache of short runs' sample
    times: no array over it can be made writeable, so no caller can change another's."""
    scene, L0 = hlw
    traj = liebody.integrate(scene, L0=L0, dt=0.01, steps=3, method="splitting2",
                             diagnostics=True)
    _try_to_write(traj.t)
    np.testing.assert_array_equal(
        liebody.integrate(scene, L0=L0, dt=0.01, steps=3, method="splitting2",
                          diagnostics=True).t, 0.01 * np.arange(4.0))


def test_a_kept_call_does_not_keep_its_scene_alive(hlw):
    """The call kept on a scene holds no reference to it: a scene the caller drops (and
    the plan cache has let go of) is freed at once, not kept by a reference cycle until
    the cyclic garbage collector runs (a loop over new scenes, each holding a sampled
    orbit's tables, say)."""
    L0 = hlw[1]
    scene = liebody.FreeBody(hlw_body())
    for _ in range(2):
        liebody.integrate(scene, L0=L0, dt=0.01, steps=2, method="splitting2")
    assert len(vars(scene)[_CALLS]) == 1
    for key, entry in list(_methods._PLANS.items()):  # (the plan cache keeps scenes)
        if entry[1] is scene:
            del _methods._PLANS[key]
    for key, entry in list(_methods._LAST.items()):
        if entry[1] is scene:
            del _methods._LAST[key]
    ref = weakref.ref(scene)
    gc.disable()
    try:
        del scene
        assert ref() is None
    finally:
        gc.enable()


@pytest.mark.parametrize("q0, L0", [
    ([1.0, 0.0, 0.0, 0.0], [0.3, 0.0, 0.8]),
    ((0.6, 0.8, 0, 0), (1, 0, 2)),
    ([0.6, 0.8 * (1 + 3e-11), 0.0, 0.0], [0.3, -0.2, 0.9]),
])
def test_a_state_given_as_numbers_repeats_the_call(hlw, q0, L0):
    """A loop that passes its state as lists or tuples of numbers (``traj.L[-1].tolist()``)
    takes the repeated call too, with the numbers of the general path (the lists' rules of
    ``as_unit_quaternion`` and ``_initial_momentum``), instead of building a new call each
    time."""
    scene = hlw[0]
    kw = dict(dt=0.01, steps=3, method="splitting2")
    first = liebody.integrate(scene, q0=q0, L0=L0, **kw)
    call = vars(scene)[_CALLS][(kw["method"], 0.01, 3, 1)]
    for _ in range(2):
        again = liebody.integrate(scene, q0=q0, L0=L0, **kw)
        same_trajectory(again, first)
        assert vars(scene)[_CALLS][(kw["method"], 0.01, 3, 1)] is call
    other = liebody.integrate(liebody.FreeBody(scene.body), q0=np.array(q0, dtype=float),
                              L0=np.array(L0, dtype=float), **kw)
    same_trajectory(again, other, scene=False)


@pytest.mark.parametrize("q0, L0, error", [
    ([1.0, 1e-4, 0.0, 0.0], [0.3, 0.0, 0.8], "q0 must be a unit quaternion"),
    ([1.0, 0.0, 0.0, 0.0], [1e200, 0.0, 0.8], "L0 is too large"),
    ([1.0, 0.0, 0.0, 0.0], [math.nan, 0.0, 0.8], "L0"),
    ([1.0, 0.0, 0.0], [0.3, 0.0, 0.8], "q0"),
    ([1.0, 0.0, 0.0, 0.0], [0.3, 0.8], "L0"),
])
def test_a_bad_state_as_numbers_is_refused_on_a_repeated_call(hlw, q0, L0, error):
    scene, good = hlw
    kw = dict(dt=0.01, steps=3, method="splitting2")
    for _ in range(2):
        liebody.integrate(scene, q0=[1.0, 0.0, 0.0, 0.0], L0=good.tolist(), **kw)
    with pytest.raises(ValueError, match=error):
        liebody.integrate(scene, q0=q0, L0=L0, **kw)


def test_a_negative_zero_start_time_is_not_the_default_one(hlw):
    """``t0 = -0.0`` equals ``0.0`` (and hashes alike): a call kept for one must not
    answer for the other. The user torque sees the time the caller gave, and the error
    of a torque that fails on the initial state carries it."""
    L0 = hlw[1]

    @numba.njit
    def torque(t, q, L):
        if L[0] > 5.0:
            return np.full(3, np.nan)
        return -0.1 * q[1:]

    scene = liebody.TorqueBody(hlw_body(), torque)
    kw = dict(dt=0.01, steps=2, method="splitting2")
    for t0 in (-0.0, 0.0):
        for _ in range(2):  # (a repeated call from the other zero first)
            liebody.integrate(scene, L0=L0, t0=-t0, **kw)
        with pytest.raises(TorqueError) as info:
            liebody.integrate(scene, L0=np.array([6.0, 0.0, 0.0]), t0=t0, **kw)
        assert math.copysign(1.0, info.value.t) == math.copysign(1.0, t0)


def test_a_first_call_checks_its_user_torque_once(hlw, monkeypatch):
    """The first call of a user torque asks its compiled check of the initial state once
    (``integrate()`` did, before the short run; the run asked again), a repeated call
    once too."""
    from liebody import _integrate

    L0 = hlw[1]

    @numba.njit
    def torque(t, q, L):
        return -0.1 * q[1:]

    scene = liebody.TorqueBody(hlw_body(), torque)
    check = _integrate._initial_ok()
    asked = []

    def counted(*args):
        asked.append(args[1])
        return check(*args)

    monkeypatch.setattr(_integrate, "_INITIAL_OK", [counted])
    kw = dict(dt=0.01, steps=2, method="splitting2")
    first = liebody.integrate(scene, L0=L0, **kw)
    assert len(asked) == 1
    again = liebody.integrate(scene, L0=L0, **kw)
    assert len(asked) == 2
    same_trajectory(again, first)
