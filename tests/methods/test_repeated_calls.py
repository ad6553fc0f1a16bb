"""A repeated short ``integrate()`` call (a control loop, an optimiser) checks only its new
initial state: the same numbers, refusals, warnings and failures as the first call."""

from __future__ import annotations

import warnings

import numba
import numpy as np
import pytest

import liebody
from liebody.errors import InvariantWarning
from support import same_trajectory


def _general(scene, q0, L0, **kw) -> liebody.Trajectory:
    """The call through the general path: ``q0`` and ``L0`` as lists, which the repeated
    call's check hands to it."""
    return liebody.integrate(scene, q0=list(np.asarray(q0, dtype=float)), L0=list(L0), **kw)


@pytest.mark.parametrize("method", ["splitting2", "no_squish", "splitting4", "rk4", "dmv4",
                                    "rattle", "saba2", "exact", None])
@pytest.mark.parametrize("t0, save_every", [(0.0, 1), (3.5, 1), (0.0, None), (1.0, 2)])
def test_repeated_calls_equal_the_general_path(hlw, method, t0, save_every):
    scene, L0 = hlw
    q0 = liebody.quaternion.random(rng=2)
    kw = dict(dt=0.01, steps=3, method=method, t0=t0, save_every=save_every)
    first = liebody.integrate(scene, q0=q0, L0=L0, **kw)
    for _ in range(3):
        again = liebody.integrate(scene, q0=q0, L0=L0, **kw)
        same_trajectory(again, first)
    assert len(vars(scene)["_memo_short_calls"]) == 1  # (the repeated path was taken)
    same_trajectory(again, _general(scene, q0, L0, **kw))
    kept = [0, 1, 2, 3] if save_every == 1 else [0, 2, 3] if save_every == 2 else [0, 3]
    np.testing.assert_array_equal(again.t, t0 + 0.01 * np.array(kept, dtype=float))
    # a new initial state: its own run, as a first call from it gives
    L1 = L0 * 1.01
    same_trajectory(liebody.integrate(scene, q0=q0, L0=L1, **kw), _general(scene, q0, L1, **kw))


def test_a_repeated_call_renormalises_q0_as_the_first(hlw):
    scene, L0 = hlw
    q0 = liebody.quaternion.random(rng=3) * (1.0 + 3e-11)
    kw = dict(dt=0.01, steps=2, method="splitting2")
    liebody.integrate(scene, q0=q0, L0=L0, **kw)
    again = liebody.integrate(scene, q0=q0, L0=L0, **kw)
    same_trajectory(again, _general(scene, q0, L0, **kw))
    np.testing.assert_array_equal(again.q[0], q0 / np.sqrt(np.sum(q0 * q0)))


@pytest.mark.parametrize("q0, L0, error, words", [
    (np.array([1.0, 1e-4, 0.0, 0.0]), None, ValueError, "q0 must be a unit quaternion"),
    (np.array([np.nan, 0.0, 0.0, 0.0]), None, ValueError, "q0 must be finite"),
    (np.array([1.0, 0.0, 0.0]), None, ValueError, "q0"),
    (None, np.array([np.nan, 0.0, 1.0]), ValueError, "L0"),
    (None, np.array([1e200, 0.0, 1.0]), ValueError, "L0 is too large"),
    (None, np.array([1.0, 0.0]), ValueError, "L0"),
])
def test_a_repeated_call_refuses_a_bad_state_as_the_first(hlw, q0, L0, error, words):
    scene, good_L0 = hlw
    kw = dict(dt=0.01, steps=1, method="splitting2")
    for _ in range(2):  # the second call takes the repeated path
        liebody.integrate(scene, L0=good_L0, **kw)
    with pytest.raises(error, match=words):
        liebody.integrate(scene, q0=np.array([1.0, 0, 0, 0]) if q0 is None else q0,
                          L0=good_L0 if L0 is None else L0, **kw)


def test_a_repeated_call_with_an_ensemble_state_runs_the_ensemble(hlw):
    scene, L0 = hlw
    kw = dict(dt=0.01, steps=2, method="splitting2")
    one = liebody.integrate(scene, L0=L0, **kw)
    liebody.integrate(scene, L0=L0, **kw)
    many = liebody.integrate(scene, L0=np.stack([L0, L0]), simd=False, **kw)
    assert many.q.shape == (2, 3, 4)
    np.testing.assert_array_equal(many.q[1], one.q)


def test_a_repeated_call_warns_as_the_first(hlw):
    """A step far too large for splitting2 breaks the energy: every call says so, and the
    warning points at the caller."""
    scene, L0 = hlw
    kw = dict(dt=2.0, steps=1, method="splitting2")
    caught = []
    for _ in range(3):
        with warnings.catch_warnings(record=True) as w:
            warnings.simplefilter("always")
            liebody.integrate(scene, L0=L0, **kw)
        caught.append([(str(x.message), x.category, x.filename) for x in w])
    assert caught[0] and caught[0][0][1] is InvariantWarning
    assert "the energy went from" in caught[0][0][0]
    assert caught[0][0][2] == __file__
    assert caught[1] == caught[0] == caught[2]


def test_a_repeated_call_keeps_quiet_when_the_first_does(hlw):
    scene, L0 = hlw
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for _ in range(3):
            liebody.integrate(scene, L0=L0, dt=0.01, steps=2, method="splitting2")


def test_a_replaced_method_is_not_run_from_the_old_call(hlw, registered):
    scene, L0 = hlw
    name = "test_repeated_composition"
    liebody.register_composition(name, [1.0], base="splitting2")
    registered.append(name)
    kw = dict(dt=0.05, steps=4, method=name)
    for _ in range(2):
        a = liebody.integrate(scene, L0=L0, **kw)
    np.testing.assert_array_equal(a.q, liebody.integrate(scene, L0=L0, dt=0.05, steps=4,
                                                         method="splitting2").q)
    gamma = 1.0 / (2.0 - 2.0 ** (1.0 / 3.0))  # Yoshida's triple jump: another method
    liebody.register_composition(name, [gamma, 1.0 - 2.0 * gamma, gamma], base="splitting2",
                                 replace=True)
    b = liebody.integrate(scene, L0=L0, **kw)
    assert b.method is liebody.methods()[name]
    ref = liebody.integrate(liebody.FreeBody(scene.body), L0=L0, **kw)
    np.testing.assert_array_equal(b.q, ref.q)
    assert not np.array_equal(b.q, a.q)


def test_a_user_torque_is_checked_on_every_initial_state(hlw):
    """The repeated call of a user torque still checks it on the new initial state first:
    a torque that breaks its ``orientation_only`` promise there is refused, as on a first
    call (the run itself would not notice)."""
    scene, L0 = hlw

    @numba.njit
    def torque(t, q, L):
        if q[1] > 0.5:
            return -0.1 * q[1:] + 0.01 * L
        return -0.1 * q[1:]

    body = liebody.TorqueBody(scene.body, torque, orientation_only=True)
    kw = dict(dt=0.01, steps=2, method="splitting2")
    for _ in range(2):
        liebody.integrate(body, L0=L0, **kw)
    bad = liebody.quaternion.normalize(np.array([0.5, 0.8, 0.0, 0.0]))
    with pytest.raises(ValueError, match="depends on L though orientation_only=True"):
        liebody.integrate(body, q0=bad, L0=L0, **kw)


def test_controls_are_read_on_every_call(hlw):
    scene, L0 = hlw
    body = liebody.ControlledBody(scene.body, numba.njit(lambda t, q, L, u: u), controls=3,
                                  orientation_only=True)
    kw = dict(L0=L0, dt=0.1, steps=2, method="splitting2")
    a = liebody.integrate(body, controls=[0.0, 0.0, 0.0], **kw)
    b = liebody.integrate(body, controls=[0.0, 0.0, 1.0], **kw)
    c = liebody.integrate(body, controls=[0.0, 0.0, 0.0], **kw)
    same_trajectory(a, c)
    assert abs((b.L[-1] - a.L[-1])[2] - 0.2) < 0.01  # the kick of u over 0.2


def test_a_loop_that_advances_the_clock_keeps_one_call():
    """A control loop under a time-dependent torque advances t0 from call to call: one
    kept call serves them all, with the numbers of a first call at each t0 (a new scene,
    the general path)."""
    from liebody.orbits import Circular

    body = liebody.RigidBody([1.0, 1.7, 2.6])
    sources = [(1.0, Circular(n=0.3, radius=2.0, inclination=0.4, phase=0.2))]
    scene = liebody.GravityGradient(body, sources)
    q, L = liebody.quaternion.random(rng=5), np.array([0.4, -1.1, 2.0])
    dt = 0.05
    for k in range(6):
        t0 = 7.0 + k * 2 * dt
        kw = dict(dt=dt, steps=2, method="splitting4", t0=t0)
        a = liebody.integrate(scene, q0=q, L0=L, **kw)
        fresh = liebody.GravityGradient(body, sources)
        same_trajectory(a, liebody.integrate(fresh, q0=q, L0=L, **kw), scene=False)
        np.testing.assert_array_equal(a.t, t0 + dt * np.arange(3.0))
        q, L = a.q[-1], a.L[-1]
    assert len(vars(scene)["_memo_short_calls"]) == 1


@pytest.mark.parametrize("t0, words", [(1e20, "the clock could not advance"),
                                       (np.inf, "t0"), (np.nan, "t0")])
def test_a_repeated_call_refuses_a_bad_clock_as_the_first(hlw, t0, words):
    scene, L0 = hlw
    kw = dict(dt=0.01, steps=1, method="splitting2")
    for _ in range(2):
        liebody.integrate(scene, L0=L0, t0=1.0, **kw)
    with pytest.raises(ValueError, match=words):
        liebody.integrate(scene, L0=L0, t0=float(t0), **kw)


def test_a_repeated_exact_flow_call_warns_of_a_lost_phase_as_the_first(hlw):
    """The exact flow asked for a phase |omega| t beyond 1e15 rad: every call warns, at
    the caller's line."""
    scene, L0 = hlw
    caught = []
    for _ in range(3):
        with warnings.catch_warnings(record=True) as w:
            warnings.simplefilter("always")
            liebody.integrate(scene, L0=L0, dt=1e15, steps=2)
        caught.append([(str(x.message), x.category, x.filename) for x in w])
    assert caught[0] and caught[0][0][1] is RuntimeWarning and "phase" in caught[0][0][0]
    assert caught[0][0][2] == __file__
    assert caught[0] == caught[1] == caught[2]
    assert len(vars(scene)["_memo_short_calls"]) == 1  # (kept, and its check made)


def test_a_controlled_loop_keeps_one_call_with_the_first_calls_numbers(hlw):
    """A controller calling integrate() with new controls each time (array or numbers):
    one kept call, each run the numbers of a first call with those controls on a new
    scene (the general path)."""
    scene, L0 = hlw

    @numba.njit
    def torque(t, q, L, u):
        return np.array([u[0] * q[1], u[1], -u[0] * L[2]])

    def controlled():
        return liebody.ControlledBody(scene.body, torque, controls=2)

    body = controlled()
    q = liebody.quaternion.random(rng=9)
    for k, u in enumerate([np.array([0.1, -0.2]), [0.3, 1], (0, 0.0), np.zeros(2), None]):
        kw = dict(dt=0.05, steps=3, method="splitting2", t0=0.15 * k)
        a = liebody.integrate(body, q0=q, L0=L0, controls=u, **kw)
        same_trajectory(a, liebody.integrate(controlled(), q0=q, L0=L0, controls=u, **kw),
                        scene=False)
    assert len(vars(body)["_memo_short_calls"]) == 1


@pytest.mark.parametrize("u, error, words", [
    ([np.nan, 0.0], ValueError, "controls must be finite"),
    (np.array([0.1, 0.2, 0.3]), ValueError, "controls"),
    (np.zeros((2, 2)), ValueError, "controls"),
    (["a", 0.0], TypeError, "controls"),
])
def test_a_repeated_controlled_call_refuses_bad_controls_as_the_first(hlw, u, error, words):
    scene, L0 = hlw
    body = liebody.ControlledBody(scene.body, numba.njit(lambda t, q, L, u: u[0] * q[1:]),
                                  controls=2, orientation_only=True)
    kw = dict(L0=L0, dt=0.05, steps=1, method="splitting2")
    for _ in range(2):
        liebody.integrate(body, controls=[0.1, 0.2], **kw)
    with pytest.raises(error, match=words):
        liebody.integrate(body, controls=u, **kw)


def test_controls_for_a_scene_without_them_are_refused_on_a_repeated_call(hlw):
    scene, L0 = hlw
    for _ in range(2):
        liebody.integrate(scene, L0=L0, dt=0.05, steps=1, method="splitting2")
    with pytest.raises(ValueError, match="takes no control inputs"):
        liebody.integrate(scene, L0=L0, dt=0.05, steps=1, method="splitting2",
                          controls=[1.0])
