"""Reaction wheels (liebody.ReactionWheels): the total angular momentum of body and wheels
kept to round-off by construction, the orders of the splittings against DOP853 on
q' = q (0, w) / 2, L' = L x w, h' = u, w = I^-1 (L - A h), the constant-momentum wheels as
the gyrostat, saturation recorded and enforced, the Stepper against integrate(), ensembles
against one-body runs, the energy with the rotors, and the refusals of bad input."""

from __future__ import annotations

import itertools
import math
import pickle

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import liebody
from liebody import quaternion
from liebody.wheels import Saturation

I = np.array([10.0, 12.0, 8.0])
BODY = liebody.RigidBody(I)
PYRAMID = np.array([[math.cos(b) * math.cos(a), math.cos(b) * math.sin(a), math.sin(b)]
                    for a in (0.0, 0.5 * math.pi, math.pi, 1.5 * math.pi)
                    for b in (math.radians(54.7),)])
J = np.array([0.02, 0.03, 0.025, 0.02])
H0 = np.array([0.3, -0.5, 0.8, 0.1])
U = np.array([0.012, -0.02, 0.015, 0.007])
Q0 = quaternion.exp([0.1, 0.2, 0.3])
W0 = np.array([0.05, -0.03, 0.02])


def _pyramid(**kw):
    return liebody.ReactionWheels(BODY, PYRAMID, J, momentum=H0, **kw)


def _spatial_drift(tr) -> float:
    Ls = tr.L_space
    return float(np.abs(Ls - Ls[0]).max() / np.linalg.norm(Ls[0]))


def _reference(t_end, u=U, h0=H0, q0=Q0, L0=None):
    A = PYRAMID.T

    def rhs(t, y):
        q, L, h = y[:4], y[4:7], y[7:]
        w = (L - A @ h) / I
        return np.concatenate([0.5 * quaternion.multiply(q, [0.0, *w]), np.cross(L, w), u])

    y0 = np.concatenate([q0, L0, h0])
    y = solve_ivp(rhs, (0.0, t_end), y0, method="DOP853", rtol=1e-13, atol=1e-14).y[:, -1]
    return y[:4], y[4:7], y[7:]


def test_total_angular_momentum_is_kept_to_round_off():
    """Spinning wheels driven hard, a tumbling body, a large step: every stage is a rotation
    about a body axis, so the spatial L of body and wheels stays put: a random walk of
    rounding errors, about 0.7e-13 after 1e6 steps (docs/design.md); here 1e5 steps, which
    take the turns of both forms (the body spins up to turns of 0.36 rad per stage). |q|
    stays within a few ulps of 1 (a random walk of 1e-14 to 1e-13 without the wheel
    stage's scaling, which R(q) L doubles)."""
    scene = _pyramid()
    L0 = I * W0 + PYRAMID.T @ H0
    tr = liebody.integrate(scene, q0=Q0, L0=L0, dt=0.05, steps=100_000, save_every=500,
                           controls=U)
    assert np.ptp(tr.wheels[:, 0]) > 100 * abs(H0[0])  # the wheels did spin up
    assert _spatial_drift(tr) < 1e-13
    assert np.abs(np.linalg.norm(tr.q, axis=1) - 1.0).max() < 2e-15
    np.testing.assert_allclose(np.linalg.norm(tr.L, axis=1), np.linalg.norm(L0), rtol=1e-13)
    # the wheels' momenta are u t, exactly linear (no limit)
    np.testing.assert_allclose(tr.wheels, H0 + np.outer(tr.t, U), rtol=1e-13, atol=1e-12)


def _spatial_exact(q, m):
    """R(q / |q|) m in exact rational arithmetic."""
    from fractions import Fraction

    w, x, y, z = (Fraction(float(v)) for v in q)
    m = [Fraction(float(v)) for v in m]
    rows = ((w * w + x * x - y * y - z * z, 2 * (x * y - w * z), 2 * (x * z + w * y)),
            (2 * (x * y + w * z), w * w - x * x + y * y - z * z, 2 * (y * z - w * x)),
            (2 * (x * z - w * y), 2 * (y * z + w * x), w * w - x * x - y * y + z * z))
    n2 = w * w + x * x + y * y + z * z
    return [sum(r * c for r, c in zip(row, m, strict=True)) / n2 for row in rows]


@pytest.mark.parametrize("spun_up", [0.0, 3.0e4])  # small turns; turns up to 2 rad
def test_a_step_rounds_the_spatial_momentum_about_once(spun_up):
    """Each step of splitting2 moves R(q) L by the rounding of its end state only: the
    turns carry the low-order parts of q and L from one to the next, and each component
    is rounded once, at the step's end. Derived: a component x rounded to nearest moves
    by a uniform error of RMS ulp(x) / sqrt(12), with E[(ulp(x) / x)^2] = 0.54 eps^2 for
    log-uniform mantissas, so L moves by 0.21 eps |L| RMS, and q's rounding (3/4 of it
    tangential, a rotation by twice that) turns L by 0.30 eps |L|: 0.37 eps per step in
    all (measured: 0.30 and 0.32). Rounding after each of the step's five turns (every
    state is saved, so no step is merged) gave 0.60 and 0.70 eps. Measured in exact
    rational arithmetic over 4 x 150 steps, with small turns and with fast ones (the
    wheels spun up by the commands for `spun_up` seconds: the body turns up to 2 rad a
    stage, the error-free form)."""
    rng = np.random.default_rng(3)
    eps = np.finfo(float).eps
    moves = []
    for _ in range(4):
        q0 = rng.normal(size=4)
        q0 /= np.linalg.norm(q0)
        L0 = I * (W0 + 0.03 * rng.normal(size=3)) + PYRAMID.T @ H0
        scene = _pyramid() if spun_up == 0.0 else liebody.ReactionWheels(
            BODY, PYRAMID, J, momentum=H0 + spun_up * U)
        tr = liebody.integrate(scene, q0=q0, L0=L0, dt=0.05, steps=150, save_every=1,
                               controls=U)
        Ls = [_spatial_exact(q, m) for q, m in zip(tr.q, tr.L, strict=True)]
        for a, b in itertools.pairwise(Ls):
            moves.append(math.sqrt(float(sum((u - v) ** 2 for u, v in zip(a, b,
                                                                          strict=True))))
                         / np.linalg.norm(L0))
    if spun_up:
        assert np.abs(tr.omega).max() * 0.05 > 1.5  # the fast turns (the error-free form)
    assert math.sqrt(np.mean(np.square(moves))) < 0.45 * eps


@pytest.mark.parametrize(("method", "order"), [("splitting2", 2), ("splitting4", 4),
                                               ("no_squish", 2), ("rk4", 4), ("rkmk4", 4),
                                               ("lie_euler", 1)])
def test_orders_against_dop853(method, order):
    scene = _pyramid()
    L0 = I * W0 + PYRAMID.T @ H0 + np.array([0.4, 0.1, -0.2])
    q_ref, L_ref, h_ref = _reference(20.0, L0=L0)
    errs = []
    for h in (0.2, 0.1):
        tr = liebody.integrate(scene, q0=Q0, L0=L0, dt=h, t_end=20.0, method=method,
                               controls=U)
        np.testing.assert_allclose(tr.wheels[-1], h_ref, rtol=1e-12, atol=1e-13)
        dq = quaternion.multiply(quaternion.conjugate(q_ref), tr.q[-1])[1:]
        errs.append(max(np.abs(tr.L[-1] - L_ref).max(), np.abs(dq).max()))
    assert abs(math.log2(errs[0] / errs[1]) - order) < 0.15, errs


def test_constant_wheels_are_the_gyrostat():
    wheels = liebody.ReactionWheels(BODY, PYRAMID, J, momentum=H0)
    gyro = liebody.Gyrostat(BODY, PYRAMID.T @ H0)
    L0 = I * W0 + PYRAMID.T @ H0
    for method in ("splitting2", "splitting4", "rk4"):
        a = liebody.integrate(wheels, q0=Q0, L0=L0, dt=0.1, steps=300, method=method)
        b = liebody.integrate(gyro, q0=Q0, L0=L0, dt=0.1, steps=300, method=method)
        np.testing.assert_allclose(a.q, b.q, rtol=0, atol=1e-15)
        np.testing.assert_allclose(a.L, b.L, rtol=0, atol=1e-15)
        np.testing.assert_array_equal(a.wheels, np.broadcast_to(H0, a.wheels.shape))


def test_energy_with_the_rotors_is_conserved_without_torques():
    scene = _pyramid()
    L0 = I * W0 + PYRAMID.T @ H0
    tr = liebody.integrate(scene, q0=Q0, L0=L0, dt=0.1, steps=20_000, save_every=20)
    E = tr.energy
    wheel_part = 0.5 * np.sum(H0**2 / J)
    assert wheel_part > 10 * (E[0] - wheel_part)  # the wheels hold most of it
    assert np.abs(E - E[0]).max() < 1e-4 * (E[0] - wheel_part)  # bounded, small
    half = len(E) // 2
    assert np.abs(E[half:] - E[0]).max() < 2 * np.abs(E[:half] - E[0]).max()
    # the motors do work: driven, the energy changes by sum u h (the body's part aside)
    drv = liebody.integrate(scene, q0=Q0, L0=L0, dt=0.1, steps=200, controls=U)
    assert abs(drv.energy[-1] - drv.energy[0]) > 1e-3


def test_running_diagnostics_follow_the_energy_with_the_rotors():
    scene = _pyramid()
    L0 = I * W0 + PYRAMID.T @ H0
    free = liebody.integrate(scene, q0=Q0, L0=L0, dt=0.1, steps=2000, save_every=1,
                             diagnostics=True)
    T = free.kinetic_energy - 0.5 * np.sum(H0**2 / J)  # the body's part
    assert free.diagnostics["max_energy_error"] == pytest.approx(
        np.abs(T - T[0]).max() / T[0], rel=1e-6)
    driven = liebody.integrate(scene, q0=Q0, L0=L0, dt=0.1, steps=20, diagnostics=True,
                               controls=U)
    assert math.isnan(driven.diagnostics["max_energy_error"])  # the motors do work
    assert driven.diagnostics["max_qnorm_error"] < 1e-14


def test_saturation_is_recorded_and_enforced():
    scene = liebody.ReactionWheels(BODY, np.eye(3), 0.01, momentum=[0.1, -0.2, 0.3],
                                   max_torque=0.05, max_speed=600.0)
    u = [0.01, -0.02, 0.07]  # wheel 2: clipped to 0.05, reaches 6 after (6 - 0.3) / 0.05
    tr = liebody.integrate(scene, omega0=W0, q0=Q0, dt=0.1, steps=2000, controls=u)
    t_full = (6.0 - 0.3) / 0.05
    assert tr.saturations == (Saturation(None, 0.0, 2, "torque"),
                              Saturation(None, pytest.approx(math.ceil(t_full / 0.1) * 0.1),
                                         2, "speed"))
    h2 = tr.wheels[:, 2]
    before = tr.t < t_full - 0.1
    np.testing.assert_allclose(h2[before], 0.3 + 0.05 * tr.t[before], rtol=1e-13)  # clipped
    assert np.all(h2 <= 6.0) and h2[-1] == 6.0 and np.all(h2[tr.t >= 114.0] == 6.0)
    np.testing.assert_allclose(tr.wheels[-1, :2], [0.1 + 0.01 * 200, -0.2 - 0.02 * 200])
    assert _spatial_drift(tr) < 1e-14  # the internal torques moved nothing
    # the body felt the clipped torque: its momentum I omega changed by -A (h - h0)
    omega = scene.omega(tr.L, tr.wheels)
    np.testing.assert_allclose(I * omega[-1] - I * omega[0],
                               tr.L[-1] - tr.L[0] - (tr.wheels[-1] - tr.wheels[0]),
                               atol=1e-12)
    # a command back inward leaves the limit: a run continued from the end
    back = liebody.integrate(scene.with_momentum(tr.wheels[-1]), q0=tr.q[-1], L0=tr.L[-1],
                             dt=0.1, steps=10, controls=[0.0, 0.0, -0.01], t0=200.0)
    assert back.saturations == () and back.wheels[-1, 2] == pytest.approx(6.0 - 0.01)


def test_a_wheel_at_its_limit_pushed_outward_is_held():
    scene = liebody.ReactionWheels(BODY, np.eye(3), 0.01, momentum=[0.0, 0.0, -6.0],
                                   max_speed=600.0)
    tr = liebody.integrate(scene, omega0=W0, dt=0.1, steps=50, controls=[0.0, 0.0, -1.0])
    assert tr.saturations == (Saturation(None, 0.0, 2, "speed"),)
    assert np.all(tr.wheels[:, 2] == -6.0)


def test_the_stepper_reads_sets_and_equals_integrate():
    scene = liebody.ReactionWheels(BODY, PYRAMID, J, momentum=H0, max_torque=0.015,
                                   max_speed=60.0)
    L0 = I * W0 + PYRAMID.T @ H0
    tr = liebody.integrate(scene, q0=Q0, L0=L0, dt=0.1, steps=600, controls=U)
    s = liebody.Stepper(scene, q0=Q0, L0=L0, dt=0.1, controls=U)
    np.testing.assert_array_equal(s.wheel_momentum, H0)
    np.testing.assert_array_equal(s.u, U)
    for k in range(600):
        s.step()
        s.u = U  # (set each period, unchanged: the same numbers)
        if k % 50 == 49:
            np.testing.assert_array_equal(s.wheel_momentum, tr.wheels[k + 1])
    np.testing.assert_array_equal(s.q, tr.q[-1])
    np.testing.assert_array_equal(s.L, tr.L[-1])
    assert s.saturations == tr.saturations and len(tr.saturations) >= 2
    # setting the wheel momenta and the commands, then stepping: h moves by u dt
    s.wheel_momentum = np.zeros(4)
    s.u = [0.01, 0.0, 0.0, 0.0]
    Ls = quaternion.rotate(s.q, s.L)
    s.step(10)
    np.testing.assert_allclose(s.wheel_momentum, [0.01, 0.0, 0.0, 0.0], rtol=1e-14)
    np.testing.assert_allclose(quaternion.rotate(s.q, s.L), Ls, rtol=0, atol=1e-14)
    with pytest.raises(ValueError, match="wheel_momentum must be within the speed limit"):
        s.wheel_momentum = [100.0, 0.0, 0.0, 0.0]
    with pytest.raises(ValueError, match="u: the motor torques of the 4 wheels"):
        s.u = [1.0, 2.0]
    c = pickle.loads(pickle.dumps(s))
    s.step(20)
    c.step(20)
    np.testing.assert_array_equal(c.q, s.q)
    np.testing.assert_array_equal(c.wheel_momentum, s.wheel_momentum)


def test_ensembles_equal_one_body_runs():
    bodies = liebody.RigidBody.batch([I, [11.0, 12.0, 8.0], [10.0, 13.0, 9.0]])
    h0 = np.array([H0, np.zeros(4), -H0])
    scene = liebody.ReactionWheels(bodies, PYRAMID, J, momentum=h0, max_torque=0.015,
                                   max_speed=40.0)
    u = np.array([U, -U, 2 * U])
    ens = liebody.integrate(scene, q0=Q0, omega0=W0, dt=0.1, steps=800, save_every=10,
                            controls=u)
    stepper = liebody.Stepper(scene, q0=Q0, omega0=W0, dt=0.1, controls=u)
    for _ in range(800):
        stepper.step()
    sat = []
    for i in range(3):
        one = liebody.integrate(scene.take(i), q0=Q0, omega0=W0, dt=0.1, steps=800,
                                save_every=10, controls=u[i])
        np.testing.assert_array_equal(ens.q[i], one.q)
        np.testing.assert_array_equal(ens.L[i], one.L)
        np.testing.assert_array_equal(ens.wheels[i], one.wheels)
        np.testing.assert_array_equal(ens.body(i).wheels, one.wheels)
        assert ens.body(i).saturations == one.saturations
        # (the stepper saves every step, so no stage is merged across steps: save_every=1)
        one = liebody.integrate(scene.take(i), q0=Q0, omega0=W0, dt=0.1, steps=800,
                                controls=u[i])
        np.testing.assert_array_equal(stepper.q[i], one.q[-1])
        np.testing.assert_array_equal(stepper.L[i], one.L[-1])
        np.testing.assert_array_equal(stepper.wheel_momentum[i], one.wheels[-1])
        sat += [s._replace(body=i) for s in one.saturations]
    assert len(sat) >= 3 and set(ens.saturations) == set(sat)
    assert set(stepper.saturations) == set(sat)


def test_only_the_methods_that_handle_a_moving_rotor_run():
    scene = _pyramid()
    for method in ("exact", "sr2", "rattle", "dmv4"):
        with pytest.raises(ValueError, match=r"rigid body's|splitting2"):
            liebody.integrate(scene, omega0=W0, dt=0.1, steps=5, method=method, controls=U)
    with pytest.raises(ValueError, match="splitting2"):
        liebody.Stepper(scene, omega0=W0, dt=0.1, method="exact")


def test_wheels_in_orbit_under_the_gravity_gradient():
    """A satellite with three driven wheels along its principal axes on a circular orbit,
    against DOP853 on L' = L x w + 3 GM / r^5 (r_b x I_total r_b), h' = u: the torque acts on
    all the mass, I_total = I + diag(J) (wheels heavy enough here for it to matter)."""
    from liebody.orbits import Circular

    GM, r, Jw = 1.0, 1.0, np.array([0.5, 0.8, 0.6])
    src = [(GM, Circular(math.sqrt(GM / r**3), radius=r))]
    scene = liebody.ReactionWheels(BODY, np.eye(3), Jw, momentum=[0.2, -0.1, 0.4],
                                   sources=src)
    u = np.array([0.01, 0.02, -0.015])
    I_total = I + Jw
    L0 = I * W0 + np.array([0.2, -0.1, 0.4])

    def rhs(t, y):
        q, L, h = y[:4], y[4:7], y[7:]
        w = (L - h) / I
        pos = r * np.array([math.cos(t), math.sin(t), 0.0])
        rb = quaternion.rotate_inverse(q / np.linalg.norm(q), pos)
        tau = 3.0 * GM / r**5 * np.cross(rb, I_total * rb)
        return np.concatenate([0.5 * quaternion.multiply(q, [0.0, *w]), np.cross(L, w) + tau,
                               u])

    ref = solve_ivp(rhs, (0.0, 10.0), np.concatenate([Q0, L0, [0.2, -0.1, 0.4]]),
                    method="DOP853", rtol=1e-13, atol=1e-14).y[:, -1]
    errs = []
    for h in (0.1, 0.05):
        tr = liebody.integrate(scene, q0=Q0, L0=L0, dt=h, t_end=10.0, method="splitting4",
                               controls=u)
        np.testing.assert_allclose(tr.wheels[-1], ref[7:], rtol=1e-13)
        dq = quaternion.multiply(quaternion.conjugate(ref[:4]), tr.q[-1])[1:]
        errs.append(max(np.abs(tr.L[-1] - ref[4:7]).max(), np.abs(dq).max()))
    assert errs[1] < 1e-5  # (|L| ~ 1: converging to the reference)
    assert abs(math.log2(errs[0] / errs[1]) - 4) < 0.2, errs
    with pytest.raises(ValueError, match="sources: the gravity-gradient torque acts on"):
        liebody.ReactionWheels(BODY, [[1.0, 0.0, 0.0], [0.6, 0.8, 0.0], [0.0, 0.0, 1.0]],
                               0.01, sources=src)


@pytest.mark.parametrize(("kwargs", "error", "match"), [
    ({"axes": [[1.0, 0.0, 0.0], [0.0, 2.0, 0.0]]}, ValueError,
     r"axes must be unit vectors.*axes\[1\]"),
    ({"axes": [[1.0, 0.0, 0.0], [1.0, 0.0, 0.0]]}, ValueError, "axes must be linearly independent"),
    ({"axes": [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.6, 0.8, 0.0]]}, ValueError,
     "linearly independent"),
    ({"axes": [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.6, 0.8, 0.0], [0.8, 0.6, 0.0]]},
     ValueError, "span the three body axes"),
    ({"axes": [[1.0, 0.0]]}, ValueError, "axes must be"),
    ({"axes": "x"}, TypeError, "axes"),
    ({"inertia": [0.01, 0.0, 0.01]}, ValueError, "inertia must be > 0"),
    ({"inertia": -1.0}, ValueError, "inertia must be > 0"),
    ({"inertia": [0.01, 0.01]}, ValueError, "inertia must be one number per wheel"),
    ({"max_torque": 0.0}, ValueError, "max_torque must be > 0"),
    ({"max_speed": [1.0, -1.0, 1.0]}, ValueError, "max_speed must be > 0"),
    ({"max_speed": np.nan}, ValueError, "max_speed must be finite"),
    ({"momentum": [1.0, 0.0, 0.0], "max_speed": 10.0}, ValueError,
     "momentum must be within the speed limit"),
    ({"momentum": [1.0, np.inf, 0.0]}, ValueError, "momentum must be finite"),
    ({"free_flow": "exact"}, ValueError, "free_flow='exact'"),
])
def test_bad_input_is_refused_by_name(kwargs, error, match):
    args = {"axes": np.eye(3), "inertia": 0.01, **kwargs}
    body = args.pop("body", BODY)
    with pytest.raises(error, match=match):
        liebody.ReactionWheels(body, **args)


def test_bad_controls_are_refused_by_name():
    scene = _pyramid()
    with pytest.raises(ValueError, match="controls: the motor torques of the 4 wheels"):
        liebody.integrate(scene, omega0=W0, dt=0.1, steps=5, controls=[1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="controls of shape \\(2, 4\\) give one row per body"):
        liebody.integrate(scene, omega0=W0, dt=0.1, steps=5, controls=np.zeros((2, 4)))
    with pytest.raises(ValueError, match="controls must be finite"):
        liebody.integrate(scene, omega0=W0, dt=0.1, steps=5, controls=[np.nan, 0, 0, 0])
