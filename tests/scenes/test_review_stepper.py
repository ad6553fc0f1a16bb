"""Review of the Stepper as a spacecraft controller uses it: the clock it starts from and
that can be set (``t0``, ``t``), the state read as one pair while another thread steps,
and the control inputs it accepts. The references are :func:`liebody.integrate` (the
Stepper's bit-for-bit promise) and its refusals (the same rules and words)."""

from __future__ import annotations

import threading

import numpy as np
import pytest
from numba import njit

import liebody
from liebody import quaternion as Q
from support import InterruptingClock, stepper_states

I_SAT = np.array([100.0, 120.0, 80.0])
N_ORBIT = 2.0 * np.pi / 5400.0  # a 90-minute orbit
R_ORBIT = 7000.0
GM = N_ORBIT**2 * R_ORBIT**3
Q0 = Q.exp([0.3, -0.2, 0.5])
L0 = np.array([10.0, -30.0, 8.0])


def _satellite(body=None) -> liebody.GravityGradient:
    orbit = liebody.orbits.Circular(N_ORBIT, R_ORBIT, inclination=0.4)
    return liebody.GravityGradient(liebody.RigidBody(I_SAT) if body is None else body,
                                   [(GM, orbit)])


@njit
def _after_epoch(t, q, L):
    """A torque known from t = 1 on only (an ephemeris that starts at an epoch): NaN
    before, a decaying push about x after."""
    out = np.empty(3)
    if t < 1.0:
        out[:] = np.nan
    else:
        out[0], out[1], out[2] = 0.5 / t + 0.1 * q[2], -0.1 * q[1], 0.0
    return out


# ------------------------------------------------------------------------- the clock


@pytest.mark.parametrize("method", ["splitting2", "splitting4", "saba2", "rattle", "rk4"])
def test_a_stepper_started_at_t0_equals_integrate_from_t0(method):
    """``Stepper(t0=...)`` as ``integrate(t0=...)``: on an orbit (the gravity-gradient
    torque depends on the time) k calls step(n) are the samples of integrate(t0=t0,
    save_every=n), bit for bit. Before, the Stepper had no t0 (TypeError): its clock
    started at 0, and a stepper set to t0 after it was made had had its torque checked at
    t = 0 (below)."""
    t0, dt = 1234.5, 0.5
    ref = liebody.integrate(_satellite(), q0=Q0, L0=L0, dt=dt, steps=12, save_every=3,
                            method=method, t0=t0)
    s = liebody.Stepper(_satellite(), q0=Q0, L0=L0, dt=dt, method=method, t0=t0)
    assert s.t == t0
    q, L, t = stepper_states(s, 4, 3)
    np.testing.assert_array_equal(t, ref.t)
    np.testing.assert_array_equal(q, ref.q)
    np.testing.assert_array_equal(L, ref.L)
    # the torque saw t0's clock: a stepper whose clock starts at 0 is far off
    from_zero = liebody.Stepper(_satellite(), q0=Q0, L0=L0, dt=dt, method=method)
    from_zero.step(12)
    assert np.max(np.abs(from_zero.L - L[-1])) > 1e-6


def test_an_ensemble_stepper_started_at_t0_equals_integrate_from_t0():
    rng = np.random.default_rng(4)
    bodies = liebody.RigidBody.batch(I_SAT * rng.uniform(0.9, 1.1, size=(5, 3)),
                                     check_triangle=False)
    q0, L0s = Q.random(5, rng=5), rng.normal(scale=20.0, size=(5, 3))
    kw = {"q0": q0, "L0": L0s, "dt": 0.5, "method": "splitting2", "simd": False,
          "t0": 777.25}
    ref = liebody.integrate(_satellite(bodies), steps=8, save_every=4, **kw)
    s = liebody.Stepper(_satellite(bodies), **kw)
    q, L, t = stepper_states(s, 2, 4)
    np.testing.assert_array_equal(t, ref.t)
    np.testing.assert_array_equal(np.moveaxis(q, 1, 0), ref.q)
    np.testing.assert_array_equal(np.moveaxis(L, 1, 0), ref.L)


def test_a_torque_known_from_an_epoch_on_is_checked_at_t0():
    """A torque that is NaN before t = 1: integrate(t0=5) runs it; the one-body Stepper
    refused it (its check called the torque at t = 0, and it had no t0). Now
    Stepper(t0=5) checks it at t0 and steps as integrate does, bit for bit."""
    scene = liebody.TorqueBody(liebody.RigidBody([1.0, 2.0, 2.5]), _after_epoch,
                               orientation_only=True)
    kw = {"q0": Q0, "L0": [0.3, -1.0, 0.6], "dt": 0.05, "method": "splitting2"}
    ref = liebody.integrate(scene, steps=20, save_every=5, t0=5.0, **kw)
    s = liebody.Stepper(scene, t0=5.0, **kw)
    q, L, t = stepper_states(s, 4, 5)
    np.testing.assert_array_equal(t, ref.t)
    np.testing.assert_array_equal(q, ref.q)
    np.testing.assert_array_equal(L, ref.L)
    with pytest.raises(liebody.errors.TorqueError, match="non-finite"):
        liebody.Stepper(scene, **kw)  # at t0 = 0 the torque is NaN: refused, as before


@pytest.mark.parametrize(("value", "error", "words"), [
    (1e17, ValueError, r"t0 \+ dt == t0 in float64"),
    (np.nan, ValueError, "t0 must be finite"),
    ("1", TypeError, "t0 must contain real numbers"),
    ([1.0], ValueError, r"t0 must have shape \(\)"),
])
def test_a_bad_t0_is_refused_as_integrate_refuses_it(value, error, words):
    free = liebody.FreeBody(liebody.RigidBody([1.0, 2.0, 2.5]))
    kw = {"L0": [0.3, -1.0, 0.6], "dt": 0.01}
    with pytest.raises(error, match=words) as local:
        liebody.integrate(free, steps=1, t0=value, **kw)
    with pytest.raises(error, match=words) as stepper:
        liebody.Stepper(free, t0=value, **kw)
    assert str(stepper.value) == str(local.value)


def test_setting_t_where_the_clock_cannot_advance_is_refused():
    """t = 1e17 with dt = 0.01: t + dt == t in float64, so the time the torque sees would
    stand still for ~1600 steps at a time (integrate() refuses such a t0). The setter
    accepted it; now it refuses it with integrate()'s words, and the stepper keeps its
    clock. A time where the clock advances is still taken exactly."""
    s = liebody.Stepper(_satellite(), q0=Q0, L0=L0, dt=0.01, method="splitting2")
    s.step(3)
    before = (s.t, s.steps, s.q, s.L)
    with pytest.raises(ValueError, match=r"t = 1e\+17 and dt = 0\.01: t \+ dt == t in "
                                         r"float64 \(times near t are 16 apart\)"):
        s.t = 1e17
    assert (s.t, s.steps) == before[:2]
    np.testing.assert_array_equal(s.q, before[2])
    s.t = 2.0**40  # ulp 2.4e-4 < dt: the clock advances
    s.step()
    assert s.t == 2.0**40 + 0.01


# ------------------------------------------------------------------------- the state


def test_the_state_is_one_state_while_another_thread_steps():
    """``stepper.state`` read q and L under two separate holds of the lock, so a step()
    on another thread could come between them: the pair was q before the step and L
    after it. Made to happen here: the other thread steps as soon as q has been read."""
    s = liebody.Stepper(_satellite(), q0=Q0, L0=L0, dt=0.5, method="splitting2")
    s.step()
    q_before, L_before = s.q, s.L
    view = s._view
    other = []

    def view_then_step(sl):
        out = view(sl)
        if not other:  # after the first read (q): a step on another thread
            th = threading.Thread(target=s.step)
            other.append(th)
            th.start()
            th.join(timeout=0.5)  # it waits for the lock while the pair is read
        return out

    s._view = view_then_step
    q, L = s.state
    del s._view
    other[0].join()
    np.testing.assert_array_equal(q, q_before)
    np.testing.assert_array_equal(L, L_before)
    assert s.steps == 2 and not np.array_equal(s.L, L_before)  # the step was taken, after


# ------------------------------------------------------------------------- the controls


@njit
def _commanded(t, q, L, u):
    return u.copy()


@pytest.mark.parametrize("bodies", [None, 3])
def test_controls_given_as_strings_are_refused_as_integrate_refuses_them(bodies):
    """``stepper.u = ["1", "2", "3"]`` was converted to numbers (NumPy parses strings
    when asked for float64), while ``integrate(controls=["1", "2", "3"])`` refuses them;
    now the setter refuses them with the same words, and u stays as it was."""
    body = (liebody.RigidBody([1200.0, 1100.0, 800.0]) if bodies is None else
            liebody.RigidBody.batch(np.tile([1200.0, 1100.0, 800.0], (bodies, 1))))
    craft = liebody.ControlledBody(body, _commanded, controls=3, orientation_only=True)
    s = liebody.Stepper(craft, omega0=[0.02, -0.03, 0.05], dt=0.1, method="splitting2",
                        controls=[0.1, 0.2, 0.3])
    before = s.u
    value = ["1", "2", "3"] if bodies is None else [["1", "2", "3"]] * bodies
    with pytest.raises(TypeError, match="must contain real numbers") as local:
        liebody.integrate(craft, omega0=[0.02, -0.03, 0.05], dt=0.1, steps=1, controls=value)
    with pytest.raises(TypeError, match="u must contain real numbers") as stepper:
        s.u = value
    assert str(stepper.value) == str(local.value).replace("controls", "u")
    np.testing.assert_array_equal(s.u, before)
    # numbers of other types are numbers: integers, and float32 (widened exactly)
    s.u = np.array([1, 2, 3]) if bodies is None else np.ones((bodies, 3), dtype=np.int32)
    s.u = np.array([0.5, 0.25, -0.125], dtype=np.float32)
    np.testing.assert_array_equal(s.u, np.broadcast_to([0.5, 0.25, -0.125], before.shape))


# ------------------------------------------------------------------------- the physics


def _gravity_gradient_rhs(t, y, inc):
    """The satellite's equations written out (an independent reference): ``q' = q (0, w)
    / 2``, ``L' = L x w + tau``, ``w = L / I``, ``tau = 3 GM / r^5 (r_b x I r_b)`` with
    ``r_b = R(q)^T r(t)`` and ``r(t)`` the circular orbit of radius ``R_ORBIT`` in the
    plane turned by ``inc`` about x (MacCullagh's formula)."""
    q, L = y[:4], y[4:]
    w0, x, y_, z = q / np.linalg.norm(q)
    Rq = np.array([[1 - 2 * (y_ * y_ + z * z), 2 * (x * y_ - w0 * z), 2 * (x * z + w0 * y_)],
                   [2 * (x * y_ + w0 * z), 1 - 2 * (x * x + z * z), 2 * (y_ * z - w0 * x)],
                   [2 * (x * z - w0 * y_), 2 * (y_ * z + w0 * x), 1 - 2 * (x * x + y_ * y_)]])
    r = R_ORBIT * (np.cos(N_ORBIT * t) * np.array([1.0, 0.0, 0.0])
                   + np.sin(N_ORBIT * t) * np.array([0.0, np.cos(inc), np.sin(inc)]))
    rb = Rq.T @ r
    tau = 3.0 * GM / np.linalg.norm(rb) ** 5 * np.cross(rb, I_SAT * rb)
    w = L / I_SAT
    qw, qx, qy, qz = q
    dq = 0.5 * np.array([-qx * w[0] - qy * w[1] - qz * w[2], qw * w[0] + qy * w[2] - qz * w[1],
                         qw * w[1] - qx * w[2] + qz * w[0], qw * w[2] + qx * w[1] - qy * w[0]])
    return np.concatenate([dq, np.cross(L, w) + tau])


def test_a_satellite_stepped_from_t0_follows_its_orbit_as_dop853_does():
    """A satellite librating slowly (a rate of order the orbit's) under the gravity
    gradient, from t0 = 1000 s for 2000 s, stepped by splitting4 from Stepper(t0=...):
    against scipy's DOP853 at rtol 1e-13 on the equations written out, the error falls
    by 2^4 when the step halves (the method's order) and is 1e-11 of |L0| at dt = 5 s;
    the same stepper with its clock from 0 is 0.13 of |L0| off (the orbit's phase)."""
    from scipy.integrate import solve_ivp

    inc, t0, span = 0.4, 1000.0, 2000.0
    L0s = I_SAT * np.array([0.002, -0.001, 0.0015])
    sol = solve_ivp(_gravity_gradient_rhs, (t0, t0 + span), np.concatenate([Q0, L0s]),
                    method="DOP853", rtol=1e-13, atol=1e-15, args=(inc,))
    q_ref, L_ref = sol.y[:4, -1], sol.y[4:, -1]
    orbit = liebody.orbits.Circular(N_ORBIT, R_ORBIT, inclination=inc)
    scene = liebody.GravityGradient(liebody.RigidBody(I_SAT), [(GM, orbit)])
    errors = []
    for dt in (10.0, 5.0):
        s = liebody.Stepper(scene, q0=Q0, L0=L0s, dt=dt, method="splitting4", t0=t0)
        s.step(int(span / dt))
        assert s.t == t0 + span
        errors.append(max(np.max(np.abs(s.L - L_ref)) / np.linalg.norm(L0s),
                          np.max(np.abs(s.q - q_ref))))
    assert errors[0] / errors[1] > 12.0, errors  # order 4: 16
    assert errors[1] < 1e-10, errors
    from_zero = liebody.Stepper(scene, q0=Q0, L0=L0s, dt=5.0, method="splitting4")
    from_zero.step(int(span / 5.0))
    assert np.max(np.abs(from_zero.L - L_ref)) / np.linalg.norm(L0s) > 0.01


# ------------------------------------------------------------------------- Ctrl-C


@pytest.mark.parametrize("method", ["splitting2", "rattle", "rk4"])
@pytest.mark.parametrize("at", [3, 5])
def test_ctrl_c_before_a_slice_keeps_the_slices_done(method, at, monkeypatch):
    """One body, Ctrl-C just before the second or third slice of a long step(n): the
    slices done are kept (m > 0; a merged end stage is completed), and the stepper is
    exactly a stepper after step(m), as an ensemble's is. Before, the one-body stepper
    went back to the start of the call (m = 0), losing the slices it had done, though its
    state was theirs."""
    from liebody import _stepper

    kw = {"q0": Q0, "L0": L0, "dt": 0.5, "method": method, "t0": 100.0}
    s = liebody.Stepper(_satellite(), **kw)
    s.step(3)
    monkeypatch.setattr(_stepper, "time", InterruptingClock(at))
    with pytest.raises(liebody.IntegrationInterrupted) as info:
        s.step(100_000)
    monkeypatch.undo()
    m = info.value.step
    assert m > 0 and s.steps == 3 + m
    twin = liebody.Stepper(_satellite(), **kw)
    twin.step(3)
    twin.step(m)
    assert s.t == twin.t
    np.testing.assert_array_equal(s.q, twin.q)
    np.testing.assert_array_equal(s.L, twin.L)
    s.step(4)
    twin.step(4)
    np.testing.assert_array_equal(s.L, twin.L)


def test_a_wheel_stepper_started_at_t0_equals_integrate_from_t0():
    """``Stepper(wheels, t0=...)`` (the reaction-wheel stepper, made by ``Stepper``) takes
    t0 as the Stepper does: wheels in orbit under the gravity gradient, with torques
    that saturate the wheels' speed, equal integrate(t0=...) bit for bit, wheel momenta
    and the saturations' times included. Before, it refused t0 (TypeError)."""
    orbit = liebody.orbits.Circular(N_ORBIT, R_ORBIT, inclination=0.3)
    craft = liebody.ReactionWheels(liebody.RigidBody([10.0, 12.0, 8.0]), np.eye(3), 0.01,
                                   momentum=[0.1, -0.2, 0.3], max_torque=0.05, max_speed=60.0,
                                   sources=[(GM, orbit)])
    kw = {"q0": Q.exp([0.1, 0.2, 0.3]), "omega0": [0.01, 0.02, -0.01], "dt": 0.5,
          "controls": [0.02, -0.01, 0.03], "t0": 250.0, "method": "splitting2"}
    ref = liebody.integrate(craft, steps=400, save_every=100, **kw)
    s = liebody.Stepper(craft, **kw)
    q, L, t = stepper_states(s, 4, 100)
    np.testing.assert_array_equal(t, ref.t)
    np.testing.assert_array_equal(q, ref.q)
    np.testing.assert_array_equal(L, ref.L)
    np.testing.assert_array_equal(s.wheel_momentum, ref.wheels[-1])
    assert len(ref.saturations) == 3
    assert [x.t for x in s.saturations] == [x.t for x in ref.saturations]
