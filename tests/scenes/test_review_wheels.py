"""Review of the reaction-wheel and gyrostat scenes against independent references: the
equations of body and wheels written out here (H = I w + A h in the body frame,
dH/dt = H x w + tau, dh/dt = u, q' = q (0, w) / 2) and solved by scipy's DOP853 at tight
tolerances, an independent statement of the saturation rule, the work of the motors
against the energy of body and wheels, and the bit-for-bit promises (the Stepper against
integrate(), ensembles against one-body runs)."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import liebody
from liebody import quaternion
from liebody.errors import InvariantWarning
from liebody.wheels import Saturation

I = np.array([3.0, 5.0, 7.0])
BODY = liebody.RigidBody(I)
Q0 = quaternion.exp([0.3, -0.2, 0.1])
W0 = np.array([0.4, -0.3, 0.2])


def _skew_axes(n: int = 4, seed: int = 1) -> np.ndarray:
    """``n`` unit axes in general position (not along the principal axes)."""
    g = np.random.default_rng(seed).normal(size=(n, 3))
    return g / np.linalg.norm(g, axis=1)[:, None]


def _qmul(a, b):
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return np.array([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2])


def _rot(q) -> np.ndarray:
    """R(q) of the unit quaternion ``q / |q|`` (body to space), written out."""
    w, x, y, z = np.asarray(q) / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def _reference(moments, axes, q0, L0, h0, pieces, tau=None, work=False):
    """DOP853 (rtol 1e-13, atol 1e-15) through the zero-order-hold ``pieces``
    ``[(t_a, t_b, u), ...]`` of q' = q (0, w) / 2, L' = L x w + tau(t, q), h' = u with
    w = I^-1 (L - A h); with ``work``, also the motors' work, the integral of
    sum_k u_k (h_k / J_k - g_k . w) (``work`` is J)."""
    A = np.asarray(axes).T
    y = np.concatenate([q0, L0, h0, [0.0]])
    for ta, tb, u in pieces:
        u = np.asarray(u, dtype=float)

        def rhs(t, s, u=u):
            q, L, h = s[:4], s[4:7], s[7:-1]
            w = (L - A @ h) / moments
            dL = np.cross(L, w) + (0.0 if tau is None else tau(t, q))
            dw = np.sum(u * (h / work - A.T @ w)) if work is not False else 0.0
            return np.concatenate([0.5 * _qmul(q, [0.0, *w]), dL, u, [dw]])

        y = solve_ivp(rhs, (ta, tb), y, method="DOP853", rtol=1e-13, atol=1e-15).y[:, -1]
    return y[:4], y[4:7], y[7:-1], y[-1]


def _same_sign(q, ref):
    return q if np.dot(q, ref) >= 0 else -q


def test_integrate_equals_the_stepper_when_a_wheel_lands_inside_a_call():
    """k calls step(n) give what integrate(steps=k n, save_every=n) saves, bit for bit, when
    a wheel reaches its speed limit inside a call: the Stepper's call is cut there (each
    part ending on its full state), so integrate()'s piece must end unmerged as well.
    (Before the fix the splittings merged the end stages across integrate()'s cut and the
    two differed by about 1e-16 after 313 steps.)"""
    scene = liebody.ReactionWheels(liebody.RigidBody([3.0, 5.0, 7.0]), np.eye(3),
                                   [0.05, 0.04, 0.06], momentum=[0.1, 0.2, -0.1],
                                   max_speed=[12.0, 13.0, 14.0])
    u = np.array([0.01, -0.02, 0.03])  # wheel 2 lands after 313.3 steps, wheel 0 after 500
    w0 = np.array([0.04, -0.03, 0.02])
    for method in ("splitting2", "splitting4", "no_squish", "rk4"):
        for n, k in ((499, 1), (600, 1), (125, 6)):
            tr = liebody.integrate(scene, q0=Q0, omega0=w0, dt=0.1, steps=n * k, save_every=n,
                                   controls=u, method=method)
            s = liebody.Stepper(scene, q0=Q0, omega0=w0, dt=0.1, controls=u, method=method)
            for j in range(k):
                s.step(n)
                np.testing.assert_array_equal(s.q, tr.q[j + 1])
                np.testing.assert_array_equal(s.L, tr.L[j + 1])
                np.testing.assert_array_equal(s.wheel_momentum, tr.wheels[j + 1])
            assert s.saturations == tr.saturations
            assert [(e.t, e.wheel) for e in tr.saturations if e.limit == "speed"][:1] == [
                (pytest.approx(31.4), 2)]


def test_trajectory_omega_is_the_bodys_rate_with_the_wheels_subtracted():
    """Trajectory.omega is the body's angular velocity I^-1 (L - A h) at every sample (the
    omega0 given at the first), for one body and for an ensemble with per-body inertia and
    wheel momenta; omega_space is R(q) of it. (Before the fix it was L / I, the wheels'
    momentum counted as the body's: 0.07 rad/s off at the first sample here.)"""
    axes = _skew_axes()
    J = np.array([0.05, 0.04, 0.06, 0.03])
    h0 = np.array([0.2, -0.1, 0.3, 0.05])
    u = np.array([0.01, -0.02, 0.005, 0.015])
    scene = liebody.ReactionWheels(BODY, axes, J, momentum=h0)
    tr = liebody.integrate(scene, q0=Q0, omega0=W0, dt=0.05, steps=100, controls=u,
                           save_every=10)
    np.testing.assert_allclose(tr.omega[0], W0, rtol=0, atol=1e-16)
    want = (tr.L - tr.wheels @ axes) / I
    np.testing.assert_allclose(tr.omega, want, rtol=0, atol=1e-15)
    np.testing.assert_allclose(tr.omega_space,
                               [_rot(q) @ w for q, w in zip(tr.q, want, strict=True)],
                               rtol=0, atol=1e-14)
    bodies = liebody.RigidBody.batch([I, [4.0, 5.0, 6.0]])
    ens = liebody.ReactionWheels(bodies, axes, J, momentum=[h0, -h0])
    tr = liebody.integrate(ens, q0=Q0, omega0=W0, dt=0.05, steps=100, controls=u,
                           save_every=10)
    for i in range(2):
        want = (tr.L[i] - tr.wheels[i] @ axes) / np.asarray(bodies.moments)[i]
        np.testing.assert_allclose(tr.omega[i], want, rtol=0, atol=1e-15)
        np.testing.assert_allclose(tr.omega[i, 0], W0, rtol=0, atol=1e-16)
        np.testing.assert_allclose(tr.body(i).omega, want, rtol=0, atol=1e-15)


def test_an_ensemble_steppers_bodies_equal_their_one_body_steppers_through_saturations():
    """simd=False: every body of an ensemble Stepper gets exactly the numbers of its
    one-body Stepper, also when another body's wheel lands on its speed limit inside a
    step(n) call."""
    bodies = liebody.RigidBody.batch([I, [4.0, 5.0, 6.0], [3.5, 2.5, 6.0]])
    J = np.array([[0.05, 0.04, 0.06], [0.06, 0.05, 0.04], [0.03, 0.04, 0.05]])
    scene = liebody.ReactionWheels(bodies, np.eye(3), J, momentum=[0.1, 0.2, -0.1],
                                   max_speed=[12.0, 13.0, 14.0], max_torque=0.05)
    u = np.array([[0.01, -0.02, 0.03], [-0.03, 0.01, 0.02], [0.06, 0.0, -0.01]])
    w0 = np.array([0.04, -0.03, 0.02])
    ens = liebody.Stepper(scene, q0=Q0, omega0=w0, dt=0.1, controls=u, simd=False)
    ones = [liebody.Stepper(scene.take(i), q0=Q0, omega0=w0, dt=0.1, controls=u[i])
            for i in range(3)]
    for _ in range(7):
        ens.step(100)
        for s in ones:
            s.step(100)
    assert len(ens.saturations) >= 6
    for i, s in enumerate(ones):
        np.testing.assert_array_equal(ens.wheel_momentum[i], s.wheel_momentum)
        np.testing.assert_array_equal(ens.q[i], s.q)
        np.testing.assert_array_equal(ens.L[i], s.L)


def test_a_gyrostat_ensembles_rotor_free_body_equals_its_one_body_run():
    """simd=False: each body of a Gyrostat ensemble equals integrate(scene.take(i)) bit for
    bit, the rotor-free one included: it is planned as the rigid body it is (its own axis
    ordering, here (0, 2, 1)), not as a gyrostat (it was: 1.2e-4 off in L after 300
    steps)."""
    l = np.array([0.7, -1.1, 0.4])
    scene = liebody.Gyrostat(BODY, np.array([l, -l, np.zeros(3)]))
    tr = liebody.integrate(scene, q0=Q0, omega0=W0, dt=0.05, steps=300, save_every=7,
                           simd=False)
    for i in range(3):
        one = liebody.integrate(scene.take(i), q0=Q0, omega0=W0, dt=0.05, steps=300,
                                save_every=7)
        # a gyrostat's ordering is (0, 1, 2); the rigid body's its orbit's best
        assert (one.info["axis_ordering"] == (0, 1, 2)) == (i < 2)
        np.testing.assert_array_equal(tr.q[i], one.q)
        np.testing.assert_array_equal(tr.L[i], one.L)


# ---------------------------------------------------------------------- against DOP853
J4 = np.array([0.05, 0.04, 0.06, 0.03])
H4 = np.array([0.2, -0.1, 0.3, 0.05])


def _commands(n: int, seed: int = 0) -> list[np.ndarray]:
    """Motor torques changed every step (a smooth command plus noise)."""
    rng = np.random.default_rng(seed)
    return [0.02 * np.sin(0.35 * k + np.arange(4)) + 0.005 * rng.normal(size=4)
            for k in range(n)]


@pytest.mark.parametrize("method", ["splitting6", "splitting8"])
def test_driven_wheels_follow_dop853_with_commands_changed_every_step(method):
    """Four wheels on skew axes, the Stepper given a new command every step, against the
    equations solved by DOP853 through the same zero-order hold: measured 1.6e-15 (q),
    2.9e-15 (L) and 3.3e-16 (h) for splitting6 after 500 steps of 0.01."""
    axes = _skew_axes()
    scene = liebody.ReactionWheels(BODY, axes, J4, momentum=H4)
    dt, n = 0.01, 500
    us = _commands(n)
    s = liebody.Stepper(scene, q0=Q0, omega0=W0, dt=dt, method=method)
    for u in us:
        s.u = u
        s.step()
    L0 = I * W0 + axes.T @ H4
    q, L, h, _ = _reference(I, axes, Q0, L0, H4,
                            [(k * dt, (k + 1) * dt, u) for k, u in enumerate(us)])
    np.testing.assert_allclose(_same_sign(s.q, q), q, rtol=0, atol=2e-14)
    np.testing.assert_allclose(s.L, L, rtol=0, atol=2e-14)
    np.testing.assert_allclose(s.wheel_momentum, h, rtol=0, atol=2e-15)
    np.testing.assert_allclose(s.omega, (L - axes.T @ h) / I, rtol=0, atol=2e-14)


def _pyramid_in_orbit():
    b = math.radians(50.0)
    axes = np.array([[math.cos(b) * math.cos(a), math.cos(b) * math.sin(a), math.sin(b)]
                     for a in (0.0, 0.5 * math.pi, math.pi, 1.5 * math.pi)])
    J = np.full(4, 0.05)
    orbit = liebody.orbits.Circular(0.7, radius=1.3, inclination=0.4, raan=0.2, phase=0.1)
    scene = liebody.ReactionWheels(BODY, axes, J, momentum=H4, sources=[(2.0, orbit)])
    I_all = I + np.einsum("k,ki,ki->i", J, axes, axes)

    def tau(t, q):  # MacCullagh on all the mass, the orbit's position in the body frame
        r = _rot(q).T @ orbit.position(t)
        return 3.0 * 2.0 / np.linalg.norm(r) ** 5 * np.cross(r, I_all * r)

    return scene, axes, tau


@pytest.mark.parametrize(("method", "order"), [("splitting2", 2), ("splitting4", 4),
                                               ("splitting6", 6), ("no_squish", 2),
                                               ("rk4", 4), ("euler", 1)])
def test_declared_orders_with_wheels_driven_in_orbit(method, order):
    """The observed order (liebody.testing.observed_order) against DOP853, wheels driven
    by constant commands on a pyramid symmetric about z, in a circular orbit under the
    gravity gradient on all the mass. Measured 2.001, 3.993, 6.000, 2.002, 3.918, 1.001."""
    scene, axes, tau = _pyramid_in_orbit()
    u = np.array([0.01, -0.02, 0.005, 0.015])
    T = 2.0
    q, L, _, _ = _reference(I, axes, Q0, I * W0 + axes.T @ H4, H4, [(0.0, T, u)], tau=tau)

    def error(n):
        tr = liebody.integrate(scene, q0=Q0, omega0=W0, dt=T / n, steps=n, save_every=n,
                               controls=u, method=method)
        return max(np.abs(_same_sign(tr.q[-1], q) - q).max(), np.abs(tr.L[-1] - L).max())

    with warnings.catch_warnings():  # (|q| of euler and rk4 at the large steps)
        warnings.simplefilter("ignore", InvariantWarning)
        o = liebody.testing.observed_order(error=error, t_end=T, h_max=T / 8)
    assert o.rounded == order, o


def test_orders_with_commands_changed_on_a_grid():
    """splitting4 through the Stepper, the command changed every 0.25 time units (on the
    grid of every step of the ladder): order 4 against DOP853 on the same pieces."""
    axes = _skew_axes()
    scene = liebody.ReactionWheels(BODY, axes, J4, momentum=H4)
    T, period = 2.0, 0.25
    us = _commands(8, seed=3)
    pieces = [(k * period, (k + 1) * period, u) for k, u in enumerate(us)]
    q, L, h, _ = _reference(I, axes, Q0, I * W0 + axes.T @ H4, H4, pieces)

    def error(n):
        s = liebody.Stepper(scene, q0=Q0, omega0=W0, dt=T / n, method="splitting4")
        for u in us:
            s.u = u
            s.step(n // len(us))
        np.testing.assert_allclose(s.wheel_momentum, h, rtol=0, atol=1e-15)
        return max(np.abs(_same_sign(s.q, q) - q).max(), np.abs(s.L - L).max())

    o = liebody.testing.observed_order(error=error, t_end=T, h_max=T / 8)
    assert o.rounded == 4, o


def test_the_motors_work_is_the_change_of_the_energy_of_body_and_wheels():
    """T = (L - A h)^T I^-1 (L - A h) / 2 + sum h^2 / (2 J) changes by the motors' work,
    the integral of sum_k u_k (h_k / J_k - g_k . w) (integrated by DOP853 with the
    state): the scene's kinetic_energy and Trajectory.energy against it. Measured: the
    reference's work and change of T agree to 2.5e-15, splitting8's T to 1e-15."""
    axes = _skew_axes()
    scene = liebody.ReactionWheels(BODY, axes, J4, momentum=H4)
    dt, n = 0.01, 500
    us = _commands(n, seed=4)
    L0 = I * W0 + axes.T @ H4
    _, L, h, work = _reference(I, axes, Q0, L0, H4,
                               [(k * dt, (k + 1) * dt, u) for k, u in enumerate(us)],
                               work=J4)
    T0 = 0.5 * np.sum((L0 - axes.T @ H4) ** 2 / I) + 0.5 * np.sum(H4 ** 2 / J4)
    T1 = 0.5 * np.sum((L - axes.T @ h) ** 2 / I) + 0.5 * np.sum(h ** 2 / J4)
    assert abs((T1 - T0) - work) <= 1e-14 * T0
    assert abs(work) > 5e-4 * T0  # the motors do work
    s = liebody.Stepper(scene, q0=Q0, omega0=W0, dt=dt, method="splitting8")
    assert scene.kinetic_energy(s.L, s.wheel_momentum) == pytest.approx(T0, rel=1e-15)
    for u in us:
        s.u = u
        s.step()
    assert abs(scene.kinetic_energy(s.L, s.wheel_momentum) - T0 - work) <= 1e-14 * T0
    tr = liebody.integrate(scene, q0=Q0, omega0=W0, dt=dt, steps=3, controls=us[0])
    np.testing.assert_allclose(tr.energy, [
        0.5 * np.sum((L_ - axes.T @ h_) ** 2 / I) + 0.5 * np.sum(h_ ** 2 / J4)
        for L_, h_ in zip(tr.L, tr.wheels, strict=True)], rtol=1e-15)


def test_spatial_momentum_kept_with_commands_changed_every_step_and_saturating():
    """2e4 steps of splitting2 with random commands through the Stepper, clipped and
    speed-limited (hundreds of saturation records): the spatial L of body and wheels,
    R(q) L with R written out here, moves 1.3e-14 relative (measured)."""
    axes = np.array([[math.cos(b) * math.cos(a), math.cos(b) * math.sin(a), math.sin(b)]
                     for a in (0.0, 0.5 * math.pi, math.pi, 1.5 * math.pi)
                     for b in (math.radians(54.7),)])
    scene = liebody.ReactionWheels(liebody.RigidBody([10.0, 12.0, 8.0]), axes,
                                   [0.02, 0.03, 0.025, 0.02], momentum=[0.3, -0.5, 0.8, 0.1],
                                   max_torque=0.015, max_speed=200.0)
    s = liebody.Stepper(scene, q0=Q0, omega0=[0.05, -0.03, 0.02], dt=0.05)
    Ls0 = _rot(s.q) @ s.L
    rng = np.random.default_rng(3)
    for _ in range(20000):
        s.u = rng.normal(scale=0.02, size=4)
        s.step()
    assert np.abs(_rot(s.q) @ s.L - Ls0).max() <= 1e-13 * np.linalg.norm(Ls0)
    assert len(s.saturations) > 100
    assert abs(np.linalg.norm(s.q) - 1.0) <= 1e-15


# ---------------------------------------------------------------------- saturation
def _saturate(h0, us, dt, tmax, lim):
    """The documented rule, stated independently: per step, clip to max_torque (a
    record where a clipping episode starts, at the step's start); a wheel at its limit
    pushed outward is held (a record where that starts); a wheel that would pass its
    limit within the step gets the rate that lands it on the limit at the step's end (a
    record at the step's end). Returns the rates per step, the records and the momenta."""
    h = np.array(h0, dtype=float)
    k = len(h)
    at_t, at_s = np.zeros(k, bool), np.zeros(k, bool)
    rates, events, hs = [], [], [h.copy()]
    for m, u in enumerate(us):
        uc = np.clip(u, -tmax, tmax)
        clipped = np.abs(u) > tmax
        events += [(m * dt, int(w), "torque") for w in np.flatnonzero(clipped & ~at_t)]
        at_t = clipped
        held = (uc != 0) & (np.sign(uc) * h >= lim)
        events += [(m * dt, int(w), "speed") for w in np.flatnonzero(held & ~at_s)]
        at_s = held.copy()
        r = np.where(held, 0.0, uc)
        passes = (r != 0) & (np.abs(h + r * dt) >= lim)
        for w in np.flatnonzero(passes):
            r[w] = (np.sign(r[w]) * lim[w] - h[w]) / dt
            events.append(((m + 1) * dt, int(w), "speed"))
            at_s[w] = True
        h = np.where(passes, np.sign(r) * lim, h + r * dt)
        rates.append(r)
        hs.append(h.copy())
    return rates, sorted(events), np.array(hs)


def test_saturation_follows_an_independent_statement_of_the_rule():
    """Random commands held for 37 steps, torque and speed limits per wheel: the
    Stepper's momenta, records (times, wheels, limits) and trajectory against the rule
    written out here and DOP853 through its rates; then a constant command through
    integrate() (three wheels reach their speed limits) against the same."""
    axes = np.eye(3)
    J = np.array([0.05, 0.04, 0.06])
    h0 = np.array([0.2, -0.1, 0.3])
    tmax = np.array([0.03, 0.05, 0.04])
    lim = J * np.array([12.0, 10.0, 8.0])
    scene = liebody.ReactionWheels(BODY, axes, J, momentum=h0, max_torque=tmax,
                                   max_speed=[12.0, 10.0, 8.0])
    w0 = np.array([0.04, -0.03, 0.02])
    L0 = I * w0 + h0
    dt, n = 0.1, 400
    rng = np.random.default_rng(1)
    us = [rng.normal(scale=0.05, size=3) for _ in range(n // 37 + 1)]
    us = [us[k // 37] for k in range(n)]
    rates, events, hs = _saturate(h0, us, dt, tmax, lim)
    assert sum(e[2] == "speed" for e in events) == 4 and len(events) == 12
    s = liebody.Stepper(scene, q0=Q0, omega0=w0, dt=dt, method="splitting6")
    for k, u in enumerate(us):
        s.u = u
        s.step()
        # (the rule adds r dt per step; the run code anchors h_a + r (m - m_a) dt)
        np.testing.assert_allclose(s.wheel_momentum, hs[k + 1], rtol=0, atol=5e-15)
        assert np.all(np.abs(s.wheel_momentum) <= lim)
    got = [(e.t, e.wheel, e.limit) for e in s.saturations]
    assert [g[1:] for g in got] == [e[1:] for e in events]
    np.testing.assert_allclose([g[0] for g in got], [e[0] for e in events], rtol=1e-15)
    assert all(e.body is None for e in s.saturations)
    q, L, h, _ = _reference(I, axes, Q0, L0, h0,
                            [(k * dt, (k + 1) * dt, r) for k, r in enumerate(rates)])
    np.testing.assert_allclose(_same_sign(s.q, q), q, rtol=0, atol=1e-13)
    np.testing.assert_allclose(s.L, L, rtol=0, atol=1e-13)
    np.testing.assert_allclose(s.wheel_momentum, h, rtol=0, atol=1e-14)  # (400 pieces)

    u = np.array([0.08, -0.02, 0.039])
    tr = liebody.integrate(scene, q0=Q0, omega0=w0, dt=dt, steps=n, save_every=8,
                           controls=u, method="splitting6")
    rates, events, hs = _saturate(h0, [u] * n, dt, tmax, lim)
    assert [(e.wheel, e.limit) for e in tr.saturations] == [e[1:] for e in events]
    assert [e[:2] for e in events] == [(0.0, 0), (pytest.approx(4.7), 2),
                                       (pytest.approx(13.4), 0), (pytest.approx(15.0), 1)]
    np.testing.assert_allclose([e.t for e in tr.saturations], [e[0] for e in events],
                               rtol=1e-15)
    np.testing.assert_allclose(tr.wheels, hs[::8], rtol=0, atol=1e-15)
    q, L, _, _ = _reference(I, axes, Q0, L0, h0,
                            [(k * dt, (k + 1) * dt, r) for k, r in enumerate(rates)])
    np.testing.assert_allclose(_same_sign(tr.q[-1], q), q, rtol=0, atol=1e-13)
    np.testing.assert_allclose(tr.L[-1], L, rtol=0, atol=1e-13)
    assert tr.saturations[0] == Saturation(None, 0.0, 0, "torque")


def test_piecewise_integrate_and_the_stepper_agree_to_round_off():
    """A command per piece of 50 steps: integrate() continued piece by piece (q, L, the
    wheels via with_momentum, t0) against a Stepper given the same commands: to
    round-off (measured 1.4e-14 after 12 pieces with splitting4; the clocks are
    t0 + m dt against m dt, so not bit for bit), with the Stepper's speed records among
    the pieces' (each piece, a new run, also records a wheel held at its limit at its
    start)."""
    axes = _skew_axes()
    scene = liebody.ReactionWheels(BODY, axes, J4, momentum=H4, max_torque=0.03,
                                   max_speed=5.0)  # wheel 2 starts at it
    rng = np.random.default_rng(1)
    s = liebody.Stepper(scene, q0=Q0, omega0=W0, dt=0.05, method="splitting2")
    piece, q, L, t, speed = scene, Q0, None, 0.0, []
    for _ in range(12):
        u = rng.normal(scale=0.03, size=4)
        s.u = u
        s.step(50)
        start = {"omega0": W0} if L is None else {"L0": L}
        tr = liebody.integrate(piece, q0=q, dt=0.05, steps=50, save_every=50, controls=u,
                               t0=t, method="splitting2", **start)
        q, L, t = tr.q[-1], tr.L[-1], tr.t[-1]
        piece = piece.with_momentum(tr.wheels[-1])
        speed += [(e.t, e.wheel) for e in tr.saturations if e.limit == "speed"]
    np.testing.assert_allclose(s.q, q, rtol=0, atol=1e-13)
    np.testing.assert_allclose(s.L, L, rtol=0, atol=1e-13)
    np.testing.assert_allclose(s.wheel_momentum, piece.momentum, rtol=0, atol=1e-15)
    mine = [(e.t, e.wheel) for e in s.saturations if e.limit == "speed"]
    assert len(mine) == 4 and mine[0] == (0.0, 2)
    for t, w in mine:
        assert any(abs(t - t2) <= 1e-12 and w == w2 for t2, w2 in speed)
    for t, w in speed:
        assert (any(abs(t - t2) <= 1e-12 and w == w2 for t2, w2 in mine)
                or abs(t / 2.5 - round(t / 2.5)) <= 1e-12)


# ---------------------------------------------------------------------- bad input
@pytest.mark.parametrize(("momentum", "inertia", "where"), [
    (0.3, [[0.05] * 3, [0.02] * 3], "wheel 0 of body 1"),  # h for every body, J per body
    ([[0.0, 0.0, 0.0], [0.0, 0.3, 0.0]], 0.02, "wheel 1 of body 1"),
    (0.3, 0.02, "wheel 0 "),
])
def test_momentum_beyond_the_speed_limit_is_refused_by_name(momentum, inertia, where):
    """A ValueError naming the momentum, the wheel and the body (before the fix, momentum
    for every wheel with per-body inertia raised an IndexError from the message)."""
    body = liebody.RigidBody.batch([I, I]) if np.ndim(inertia) == 2 or np.ndim(momentum) == 2 \
        else BODY
    with pytest.raises(ValueError, match=f"momentum must be within the speed limit.*got h = "
                                         f"0.3 for {where}"):
        liebody.ReactionWheels(body, np.eye(3), inertia, momentum=momentum, max_speed=10.0)


@pytest.mark.parametrize(("kwargs", "error", "match"), [
    ({"axes": [[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0]]}, ValueError, "axes must be linearly"),
    ({"axes": [[1.0, 0, 0], [0, 1.0, 0], [-1.0, 0, 0], [0, -1.0, 0]]}, ValueError,
     "axes of 4 wheels .* must span"),
    ({"axes": [[0.0, 0.0, 0.0]]}, ValueError, "axes must be unit vectors"),
    ({"axes": [[math.nan, 0.0, 0.0]]}, ValueError, "axes must be finite"),
    ({"axes": np.eye(3) * (1 + 0j)}, TypeError, "axes must contain real numbers"),
    ({"inertia": [0.1, 0.0, 0.1]}, ValueError, "inertia must be > 0.*index 1"),
    ({"inertia": math.inf}, ValueError, "inertia must be finite"),
    ({"max_torque": math.nan}, ValueError, "max_torque must be finite"),
    ({"max_speed": [[1.0, 2.0, 3.0]]}, ValueError, "max_speed must be a number or one per"),
])
def test_bad_scene_input_is_refused_by_name(kwargs, error, match):
    args = {"axes": np.eye(3), "inertia": 0.1} | kwargs
    with pytest.raises(error, match=match):
        liebody.ReactionWheels(BODY, args.pop("axes"), args.pop("inertia"), **args)


def test_non_finite_commands_and_momenta_are_refused_by_name():
    scene = liebody.ReactionWheels(BODY, np.eye(3), 0.1)  # no limits: nothing clips them
    for bad in (math.nan, math.inf):
        with pytest.raises(ValueError, match="controls must be finite"):
            liebody.integrate(scene, omega0=W0, dt=0.1, steps=2, controls=[bad, 0.0, 0.0])
        s = liebody.Stepper(scene, omega0=W0, dt=0.1)
        with pytest.raises(ValueError, match="u must be finite"):
            s.u = [0.0, bad, 0.0]
        with pytest.raises(ValueError, match="wheel_momentum must be finite"):
            s.wheel_momentum = [0.0, 0.0, bad]
        with pytest.raises(ValueError, match="momentum must be finite"):
            scene.with_momentum([bad, 0.0, 0.0])
        np.testing.assert_array_equal(s.u, 0.0)
        np.testing.assert_array_equal(s.wheel_momentum, 0.0)


# ---------------------------------------------------------------------- the gyrostat
def test_gyrostat_against_dop853_and_its_invariants():
    """A gyrostat with a skew rotor momentum l is the wheel equations with h constant
    (wheels along the body axes, h = l): splitting8 against DOP853 (measured 4.4e-14),
    omega0 meaning L = I omega0 + l, and over 2e5 steps of splitting2 the spatial L
    (R(q) L written out; measured 8.9e-14) and the energy (L - l)^T I^-1 (L - l) / 2,
    which equals I omega0 . omega0 / 2 at the start."""
    l = np.array([0.7, -1.1, 0.4])
    scene = liebody.Gyrostat(BODY, l)
    q, L, _, _ = _reference(I, np.eye(3), Q0, I * W0 + l, l, [(0.0, 6.0, np.zeros(3))])
    tr = liebody.integrate(scene, q0=Q0, omega0=W0, dt=0.03, steps=200, save_every=200,
                           method="splitting8")
    np.testing.assert_array_equal(tr.L[0], I * W0 + l)
    np.testing.assert_allclose(tr.omega[0], W0, rtol=0, atol=1e-16)
    np.testing.assert_allclose(_same_sign(tr.q[-1], q), q, rtol=0, atol=2e-13)
    np.testing.assert_allclose(tr.L[-1], L, rtol=0, atol=2e-13)
    tr = liebody.integrate(scene, q0=Q0, omega0=W0, dt=0.05, steps=200000, save_every=1000)
    Ls = np.array([_rot(q) @ L for q, L in zip(tr.q, tr.L, strict=True)])
    assert np.abs(Ls - Ls[0]).max() <= 5e-13 * np.linalg.norm(Ls[0])
    assert tr.energy[0] == pytest.approx(0.5 * np.sum(I * W0 * W0), rel=1e-15)
    assert np.abs(tr.energy - tr.energy[0]).max() <= 1e-4 * tr.energy[0]  # (3.2e-5, bounded)


@pytest.mark.parametrize("rotor", [2.5, 1.5, -2.5, -1.5, 0.0, 3.0])
def test_dual_spin_stability_against_a_simulation(rotor):
    """Spin at 1 rad/s about the intermediate axis of (3, 5, 7) with a rotor along it,
    perturbed by 1e-8: splitting4 over 40 time units oscillates at dual_spin_stable's
    nutation frequency (zero crossings; measured within 0.03%) or grows at its rate
    (log-linear fit; within 0.01%)."""
    st = liebody.analysis.dual_spin_stable(I, 1.0, 1, rotor)
    scene = liebody.Gyrostat(BODY, [0.0, rotor, 0.0])
    tr = liebody.integrate(scene, L0=[1e-8, I[1] + rotor, 0.0], dt=0.01, steps=4000,
                           method="splitting4")
    x, t = tr.L[:, 0], tr.t
    if st.stable:
        crossings = t[1:][np.sign(x[1:]) != np.sign(x[:-1])]
        assert math.pi / np.mean(np.diff(crossings)) == pytest.approx(st.rate, rel=1e-3)
        assert np.abs(x).max() <= 1.01e-8
    else:
        size = np.hypot(tr.L[:, 0], tr.L[:, 2])
        sel = (size > 1e-6) & (size < 1e-3)
        assert sel.sum() > 100
        assert np.polyfit(t[sel], np.log(size[sel]), 1)[0] == pytest.approx(st.rate, rel=1e-3)


def test_a_run_that_ends_on_a_landing_step_ends_on_the_limit():
    """A wheel that would pass J max_speed within a step lands exactly on it at the
    step's end: also in Trajectory.wheels when the run ends with that step (before the
    fix its last sample was h + r dt, off the limit by an ulp and beyond it in 61 of 300
    random cases, and differing from Stepper.wheel_momentum in 112), and in the
    Stepper."""
    rng = np.random.default_rng(0)
    for _ in range(60):
        J = float(rng.uniform(0.01, 0.1))
        w_max = float(rng.uniform(5.0, 20.0))
        h0 = float(rng.uniform(-0.99, 0.5)) * J * w_max
        dt = float(rng.choice([0.1, 0.3, 1 / 3, 0.7]))
        u = float(rng.uniform(1.0, 3.0)) * (J * w_max - h0) / dt  # passes it in one step
        scene = liebody.ReactionWheels(BODY, [[1.0, 0.0, 0.0]], J, momentum=h0,
                                       max_speed=w_max)
        tr = liebody.integrate(scene, omega0=W0, dt=dt, steps=1, controls=[u])
        s = liebody.Stepper(scene, omega0=W0, dt=dt, controls=[u])
        s.step()
        assert tr.wheels[-1, 0] == s.wheel_momentum[0] == scene.momentum_limit[0]
        assert tr.saturations == s.saturations == (Saturation(None, dt, 0, "speed"),)
        tr = liebody.integrate(scene, omega0=W0, dt=dt, steps=3, controls=[u])
        np.testing.assert_array_equal(tr.wheels[1:, 0], scene.momentum_limit[0])


def test_an_ensemble_steppers_failed_body_keeps_its_wheels_with_its_state():
    """A body of an ensemble Stepper that fails is left at its state before the call and
    skipped afterwards: its wheels too (before the fix they went on turning, and
    recording saturations, to the end of the run). Euler with a large step blows up body
    1 in the first call and body 0 at t = 418 (integrate() agrees)."""
    bodies = liebody.RigidBody.batch([[3.0, 5.0, 7.0], [3.0, 5.0, 7.0]])
    scene = liebody.ReactionWheels(bodies, np.eye(3), 0.1, momentum=np.zeros((2, 3)),
                                   max_speed=5.0)
    L0 = [[0.01, 0.02, 0.03], [30.0, 50.0, 70.0]]
    u = [[0.01, 0.0, 0.0]] * 2
    with pytest.warns(RuntimeWarning, match="2 of 2 bodies failed"):
        tr = liebody.integrate(scene, L0=L0, dt=1.0, steps=2000, method="euler",
                               controls=u)
    np.testing.assert_array_equal(tr.failed_at, [418.0, 9.0])
    s = liebody.Stepper(scene, L0=L0, dt=1.0, method="euler", controls=u, simd=False)
    with pytest.warns(RuntimeWarning, match="failed in this step"):
        for _ in range(200):
            s.step(10)
    assert list(s.failed) == [True, True]
    np.testing.assert_array_equal(s.L[1], L0[1])  # left before its first call
    np.testing.assert_array_equal(s.wheel_momentum[1], 0.0)
    np.testing.assert_array_equal(s.wheel_momentum[0], tr.wheels[0, 410])  # at t = 410
    np.testing.assert_array_equal(s.L[0], tr.L[0, 410])
    assert s.saturations == (Saturation(0, 50.0, 0, "speed"),) == tr.saturations


def test_ensembles_in_orbit_with_per_body_wheels_equal_their_one_body_runs():
    """Per-body inertia and wheel inertia, commands per body, limits, a gravity-gradient
    source on all the mass, a start at t0 = 1.5: each body of integrate() equals its
    one-body integrate() and its one-body Stepper (t set to 1.5, step(10) per sample)
    bit for bit, with the same records (times from t0); the ensemble Stepper stepping one
    step at a time (simd=False) equals the ensemble integrate()."""
    b = math.radians(50.0)
    axes = np.array([[math.cos(b) * math.cos(a), math.cos(b) * math.sin(a), math.sin(b)]
                     for a in (0.0, 0.5 * math.pi, math.pi, 1.5 * math.pi)])
    J = np.array([np.full(4, 0.05), np.full(4, 0.08), np.full(4, 0.02)])
    orbit = liebody.orbits.Circular(0.7, radius=1.3, inclination=0.4)
    bodies = liebody.RigidBody.batch([I, [4.0, 5.0, 6.0], [3.5, 3.0, 6.0]])
    scene = liebody.ReactionWheels(bodies, axes, J, momentum=0.1 * H4, sources=[(2.0, orbit)],
                                   max_speed=10.0, max_torque=0.05)
    u = np.array([[0.01, -0.02, 0.005, 0.015], [0.1, 0.0, 0.0, 0.0], [0.0, 0.0, -0.04, 0.03]])
    tr = liebody.integrate(scene, q0=Q0, omega0=W0, dt=0.05, steps=400, save_every=10,
                           controls=u, t0=1.5)
    records = []
    for i in range(3):
        one = liebody.integrate(scene.take(i), q0=Q0, omega0=W0, dt=0.05, steps=400,
                                save_every=10, controls=u[i], t0=1.5)
        np.testing.assert_array_equal(tr.q[i], one.q)
        np.testing.assert_array_equal(tr.L[i], one.L)
        np.testing.assert_array_equal(tr.wheels[i], one.wheels)
        s = liebody.Stepper(scene.take(i), q0=Q0, omega0=W0, dt=0.05, controls=u[i])
        s.t = 1.5
        for _ in range(40):
            s.step(10)
        np.testing.assert_array_equal(s.q, one.q[-1])
        np.testing.assert_array_equal(s.L, one.L[-1])
        np.testing.assert_array_equal(s.wheel_momentum, one.wheels[-1])
        assert s.saturations == one.saturations
        records += [e._replace(body=i) for e in one.saturations]
    assert sorted(records) == sorted(tr.saturations) and len(records) == 4
    assert min(e.t for e in records) == 1.5  # body 1's torque clipped from the start
    s = liebody.Stepper(scene, q0=Q0, omega0=W0, dt=0.05, controls=u, simd=False)
    s.t = 1.5
    for _ in range(400):
        s.step()
    one = liebody.integrate(scene, q0=Q0, omega0=W0, dt=0.05, steps=400, controls=u, t0=1.5)
    np.testing.assert_array_equal(s.q, one.q[:, -1])
    np.testing.assert_array_equal(s.L, one.L[:, -1])
    np.testing.assert_array_equal(s.wheel_momentum, one.wheels[:, -1])
    assert set(s.saturations) == set(tr.saturations)


def test_setting_the_wheel_momenta_keeps_the_total_momentum():
    """Stepper.wheel_momentum = h re-anchors the wheels and keeps L, the total momentum
    of body and wheels (an internal exchange): omega becomes I^-1 (L - A h), and the
    spatial L stays put across the setting and the steps after it."""
    axes = _skew_axes()
    scene = liebody.ReactionWheels(BODY, axes, J4, momentum=H4)
    s = liebody.Stepper(scene, q0=Q0, omega0=W0, dt=0.05, controls=[0.01, 0.0, -0.01, 0.0])
    s.step(20)
    L, Ls = s.L, _rot(s.q) @ s.L
    s.wheel_momentum = [0.5, -0.5, 0.0, 0.2]
    np.testing.assert_array_equal(s.L, L)
    np.testing.assert_allclose(s.omega, (L - axes.T @ [0.5, -0.5, 0.0, 0.2]) / I, rtol=0,
                               atol=1e-16)
    s.step(100)
    np.testing.assert_allclose(s.wheel_momentum, [0.5 + 0.05, -0.5, -0.05, 0.2], rtol=0,
                               atol=1e-15)
    np.testing.assert_allclose(_rot(s.q) @ s.L, Ls, rtol=0, atol=1e-14)


def test_a_wheel_ensembles_info_says_the_simd_kernels_did_not_run():
    """Trajectory.info["simd"] says whether the SIMD kernels ran (integrate()'s docs);
    they do not run a moving rotor, so False for a wheel ensemble whatever simd asks, as
    the Stepper's info says (before the fix the key was missing: KeyError)."""
    bodies = liebody.RigidBody.batch([I, [4.0, 5.0, 6.0], [3.5, 3.0, 6.0], [5.0, 6.0, 7.0]])
    scene = liebody.ReactionWheels(bodies, np.eye(3), 0.1, momentum=[0.1, 0.2, 0.3])
    for simd in (None, True, False):
        tr = liebody.integrate(scene, omega0=W0, dt=0.05, steps=10, simd=simd,
                               controls=[0.01, 0.02, -0.03])
        s = liebody.Stepper(scene, omega0=W0, dt=0.05, simd=simd)
        assert tr.info["simd"] is False and s.info["simd"] is False


@pytest.mark.parametrize("setter", ["L", "omega", "q", "t", "wheel_momentum"])
def test_setting_the_steppers_state_mid_run_against_dop853(setter):
    """After 100 steps, one of q, L, omega, t or the wheel momenta is set, then 100 more
    steps of splitting6 (the rotor slots rewritten, the plan made again for L): against
    DOP853 from the state set (measured 1e-15 to 4e-15)."""
    axes = _skew_axes()
    scene = liebody.ReactionWheels(BODY, axes, J4, momentum=H4)
    u = np.array([0.01, -0.02, 0.005, 0.015])
    s = liebody.Stepper(scene, q0=Q0, omega0=W0, dt=0.01, controls=u, method="splitting6")
    s.step(100)
    value = {"L": s.L + [0.1, 0.0, 0.0], "omega": [0.2, 0.1, -0.1],
             "q": quaternion.exp([0.1, 0.1, 0.1]), "t": 7.0,
             "wheel_momentum": [0.1, 0.2, 0.3, 0.4]}[setter]
    setattr(s, setter, value)
    q1, L1, h1, t1 = s.q, s.L, s.wheel_momentum, s.t
    s.step(100)
    q, L, h, _ = _reference(I, axes, q1, L1, h1, [(t1, t1 + 1.0, u)])
    np.testing.assert_allclose(_same_sign(s.q, q), q, rtol=0, atol=2e-14)
    np.testing.assert_allclose(s.L, L, rtol=0, atol=2e-14)
    np.testing.assert_allclose(s.wheel_momentum, h, rtol=0, atol=1e-15)
    assert s.t == pytest.approx(t1 + 1.0, rel=1e-15)
