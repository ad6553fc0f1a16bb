"""Classical rigid-body phenomena, simulated with liebody.integrate and checked against
the closed forms of liebody.analysis (long-run regression tests).

Each test integrates a free body, measures a phenomenon from the samples, and compares it
with the closed form (topics of Hand & Finch, *Analytical Mechanics*, ch. 8, "H&F", and
Landau & Lifshitz, *Mechanics*, §37):

* Chandler wobble of the rigid Earth (H&F: the force-free symmetric top; IERS 2010
  flattening): period A/(C - A) sidereal days, with the exact flow, sr2, and splitting2
  (whose error we predict);
* intermediate-axis instability (H&F: stability of rotation about the principal axes):
  growth rate sqrt(r1 r3) omega2, and the bounded oscillation about the smallest and
  largest axes for 1e4 periods;
* Dzhanibekov flips (Landau & Lifshitz §37): sign changes of L_2 every
  T_m / 2 = 2 K(k) / nu;
* body and space cones of a symmetric top (H&F: the symmetric top in the inertial
  frame), oblate and prolate;
* only rotation about a principal axis is torque-free (H&F: Euler's equations, the
  rotating dumbbell).

``method=None`` is the FreeBody default, the exact flow evaluated at the output times
(no stepping error): it isolates the measurement and the physics. The stepping methods
are then held to the same closed forms, with tolerances set by their known errors.
Tests marked ``long`` run in CI too (the whole file takes a few seconds).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import liebody
from liebody import analysis, bodies

# ------------------------------------------------------------------------------------------
# helpers
# ------------------------------------------------------------------------------------------


def angles_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise angle between vectors, accurate near 0 and pi."""
    return np.arctan2(np.linalg.norm(np.cross(a, b), axis=-1), np.sum(a * b, axis=-1))


def relative_error(measured: float, predicted: float) -> float:
    return abs(measured - predicted) / abs(predicted)


# ------------------------------------------------------------------------------------------
# Chandler wobble of the rigid Earth (H&F: the force-free symmetric top)
# ------------------------------------------------------------------------------------------

DAY = bodies.SIDEREAL_DAY
SPIN = bodies.earth_spin()
POLAR_OFFSET = 1e-6  # rad between omega and the figure axis (~6 m at the pole)
CHANDLER = analysis.chandler_period()  # 304.456 sidereal days (rigid Earth)


def simulate_earth(method, dt: float, n_wobbles: float = 3.0):
    """Rigid Earth spinning once per sidereal day, omega tilted by POLAR_OFFSET from the
    figure axis; samples every 6 hours for n_wobbles wobble periods."""
    omega0 = SPIN * np.array([math.sin(POLAR_OFFSET), 0.0, math.cos(POLAR_OFFSET)])
    steps = round(n_wobbles * CHANDLER * DAY / dt)
    save_every = max(1, round(DAY / 4 / dt))
    return liebody.integrate(liebody.FreeBody(bodies.earth()), omega0=omega0, dt=dt,
                             steps=steps, method=method, save_every=save_every)


@pytest.mark.parametrize(("method", "dt"), [(None, DAY / 4), ("sr2", DAY / 4), ("sr2", 3600.0)])
def test_chandler_period_exact_flow_and_sr2(method, dt):
    """The exact flow, and sr2 (exact for a symmetric body) even at 1-hour or 6-hour steps,
    reproduce A/(C - A) = 304.456 sidereal days to round-off (required: 1e-4)."""
    traj = simulate_earth(method, dt)
    period_days = analysis.wobble_period(traj, component=0) / DAY
    assert relative_error(period_days, CHANDLER) < 1e-9  # measured ~5e-13
    # the same period from the other equatorial component
    assert relative_error(analysis.wobble_period(traj, 1) / DAY, CHANDLER) < 1e-9
    # the pole circles the figure axis at a constant distance (omega1 = c cos, c = const)
    polar = np.hypot(traj.omega[:, 0], traj.omega[:, 1])
    np.testing.assert_allclose(polar, SPIN * math.sin(POLAR_OFFSET), rtol=1e-9)


def splitting2_period_error(h: float, ordering: tuple[int, int, int]) -> float:
    """Relative wobble-period error of splitting2 (axis ordering a-b-c-b-a) at step h.

    Linearise each exact axis sub-flow about L = (0, 0, G) of the symmetric Earth
    (A, A, C), with (x, y) = (L_1, L_2): the flow of T_3 for a time tau rotates (x, y) by
    -tau G/C, that of T_1 shears y += tau (G/A) x, that of T_2 shears x -= tau (G/A) y.
    One step is their product M (2 x 2, det 1), a rotation by the numerical wobble angle
    theta per step, 4 sin^2(theta/2) = 2 - tr M; the exact angle is h Omega. Multiplying
    out (phi = h G/C, s = h G/A, delta = 2 sin(phi/2) - s cos(phi/2)):
    2 - tr M = delta^2 when T_3 is the second rotation (b = 2), and
    delta (delta - s^2 sin(phi/2) / 2) otherwise. For small h this is
    (h omega)^2 (1/(12 H) + 1/24) resp. -(h omega)^2 (1/(24 H) + 1/12 + ...).
    """
    A, C = 1.0 - bodies.EARTH_H, 1.0
    G = C * SPIN
    phi, s = h * G / C, h * G / A
    # 2 sin(phi/2) - s cos(phi/2), without cancelling its two O(h) terms in round-off
    delta = 2 * math.cos(phi / 2) * (math.tan(phi / 2) - s / 2)
    if ordering[1] == 2:
        two_minus_trace = delta**2
    else:
        two_minus_trace = delta * (delta - s**2 * math.sin(phi / 2) / 2)
    theta = 2 * math.asin(math.sqrt(two_minus_trace) / 2)
    omega_wobble = SPIN * (C - A) / A
    return h * omega_wobble / theta - 1.0


def test_chandler_period_splitting2_fails_at_one_hour_as_predicted():
    """Plain axis splitting at 1-hour steps (h omega = 0.26) is 33% off: the wobble is
    a small difference of large rotations, so the relative error of its frequency is
    ~ (h omega)^2 / H, H = 0.00327. Its one-step map predicts the error exactly; sr2 at
    the same step is exact (previous test)."""
    traj = simulate_earth("splitting2", 3600.0)
    ordering = traj.info["axis_ordering"]
    period_days = analysis.wobble_period(traj) / DAY
    error = period_days / CHANDLER - 1.0
    assert abs(error) > 0.1  # measured +0.326 (403.8 days)
    assert error == pytest.approx(splitting2_period_error(3600.0, ordering), rel=1e-8)


@pytest.mark.long
def test_chandler_period_splitting2_small_steps_second_order():
    """splitting2 converges at second order, with error ~ (h omega)^2 / (12 H): a step of
    20 s (h omega = 1.5e-3, 3.9e6 steps) meets the 1e-4 requirement."""
    errors = {}
    for dt in (60.0, 20.0):
        traj = simulate_earth("splitting2", dt)
        errors[dt] = analysis.wobble_period(traj) / DAY / CHANDLER - 1.0
        predicted = splitting2_period_error(dt, traj.info["axis_ordering"])
        assert errors[dt] == pytest.approx(predicted, rel=1e-5)  # measured 3e-8
        scale = (dt * SPIN) ** 2 / bodies.EARTH_H
        assert 1 / 30 < abs(errors[dt]) / scale < 1 / 10  # measured 1/12
    assert errors[60.0] / errors[20.0] == pytest.approx(9.0, rel=1e-2)
    assert abs(errors[20.0]) < 1e-4  # measured 5.4e-5


def test_chandler_space_precession():
    """In space, omega and the figure axis circle the fixed L at |L|/A (H&F: inertial frame): once
    per (sidereal) day, slightly faster."""
    traj = simulate_earth(None, DAY / 64, n_wobbles=0.02)  # 6 days, 64 samples a day
    A = bodies.earth().moments[0]
    predicted = analysis.space_precession_rate(A, float(np.linalg.norm(traj.L[0])))
    assert relative_error(analysis.measured_space_precession_rate(traj), predicted) < 1e-10
    assert predicted == pytest.approx(SPIN / (1 - bodies.EARTH_H), rel=1e-9)


# ------------------------------------------------------------------------------------------
# stability of the principal axes (H&F: stability of rotation about the principal axes)
# ------------------------------------------------------------------------------------------

MOMENTS = np.array([1.0, 2.0, 3.0])
FREE_123 = liebody.FreeBody(liebody.RigidBody(MOMENTS))


@pytest.mark.parametrize("method", [None, "splitting2"])
def test_intermediate_axis_grows_at_sqrt_r1_r3_omega2(method):
    """omega = (1e-8, 1, 1e-8) about the middle axis: the perturbation grows like
    exp(sqrt(r1 r3) omega2 t) until it is no longer small."""
    w2 = 1.0
    traj = liebody.integrate(FREE_123, omega0=[1e-8, w2, 1e-8], dt=0.01, t_end=40.0,
                             method=method)
    predicted = analysis.stability(MOMENTS, w2, axis=1)
    assert not predicted.stable
    r1, r3 = (3.0 - 2.0) / 1.0, (2.0 - 1.0) / 3.0
    assert predicted.rate == pytest.approx(math.sqrt(r1 * r3) * w2)
    for component in (0, 2, None):  # omega_1, omega_3, transverse amplitude
        fitted = analysis.fit_growth_rate(traj, component=component)
        assert relative_error(fitted, predicted.rate) < 1e-4  # measured 1e-6 .. 7e-6
    # and it does grow to order one: a flip
    assert np.max(np.abs(traj.omega[:, 0])) > 0.5


@pytest.mark.long
@pytest.mark.parametrize(("axis", "method", "dt", "tol"), [
    (0, None, None, 1e-6),
    (2, None, None, 1e-6),
    (0, "splitting2", 0.05, 1e-3),
    (2, "splitting2", 0.05, 1e-3),
])
def test_smallest_and_largest_axes_stay_bounded_for_1e4_periods(axis, method, dt, tol):
    """Rotation about the smallest or largest axis with a 1e-4 perturbation oscillates at
    sqrt(r2 r3) omega1 resp. sqrt(r1 r2) omega3 (O(amplitude^2) = 1e-8 nonlinear
    correction) and stays bounded for 1e4 periods. splitting2 at dt = 0.05 is off by its
    O(h^2) phase error (measured 9e-6 and 2.3e-4)."""
    amplitude = 1e-4
    omega0 = np.full(3, amplitude)
    omega0[axis] = 1.0
    predicted = analysis.stability(MOMENTS, 1.0, axis)
    assert predicted.stable
    period = 2 * math.pi / predicted.rate
    n_periods = 10_000
    samples_per_period = 20
    if method is None:  # exact flow: dt only sets the output spacing
        dt, save_every = period / samples_per_period, 1
    else:
        save_every = max(1, round(period / samples_per_period / dt))
    traj = liebody.integrate(FREE_123, omega0=omega0, dt=dt,
                             steps=round(n_periods * period / dt), method=method,
                             save_every=save_every)
    transverse = np.delete(traj.omega, axis, axis=1)
    assert np.max(np.abs(transverse)) < 3 * amplitude  # bounded (ellipse, no growth)
    for component in (k for k in range(3) if k != axis):
        measured = 2 * math.pi / analysis.wobble_period(traj, component)
        assert relative_error(measured, predicted.rate) < tol
    # the linear theory's frequency is the k -> 0 limit of the exact elliptic period
    exact_period = analysis.flip_period(MOMENTS, MOMENTS * omega0)
    assert relative_error(exact_period, period) < 1e-7


# ------------------------------------------------------------------------------------------
# Dzhanibekov flips (Landau & Lifshitz §37)
# ------------------------------------------------------------------------------------------


@pytest.mark.parametrize(("L0", "method"), [
    ([1e-2, 2.0, 1e-2], None),          # G^2 < 2 T I2: near the smallest-axis side
    ([1e-4, 2.0, 1e-4], None),          # closer to the separatrix: longer period
    ([1e-2, 2.0, 0.02], None),          # G^2 > 2 T I2: the largest-axis side
    pytest.param([1e-2, 2.0, 1e-2], "splitting8", marks=pytest.mark.long),
])
def test_flips_repeat_every_half_period(L0, method):
    """The sign changes of L_2 (the intermediate component) come every T_m / 2 =
    2 K(k) / nu, flip after flip."""
    L0 = np.array(L0)
    period = analysis.flip_period(MOMENTS, L0)
    n_flips = 40
    traj = liebody.integrate(FREE_123, L0=L0, dt=0.01,
                             steps=round(n_flips * period / 2 / 0.01), method=method)
    flips = analysis.zero_crossings(traj.t, traj.L[:, 1])
    assert flips.size == n_flips
    spacing = np.diff(flips)
    # each one, to 1e-9 (required 1e-6; measured 5e-14 exact flow, 8e-11 splitting8)
    np.testing.assert_allclose(spacing, period / 2, rtol=1e-9)
    # no drift: the flip times lie on a straight line of slope T_m / 2
    k = np.arange(flips.size)
    slope, _ = np.polyfit(k, flips, 1)
    assert relative_error(slope, period / 2) < 1e-9


# ------------------------------------------------------------------------------------------
# cones of the symmetric top (H&F: the symmetric top in the inertial frame)
# ------------------------------------------------------------------------------------------


@pytest.mark.parametrize("shape", ["oblate", "prolate"])
@pytest.mark.parametrize("method", [None, "sr2"])
def test_body_and_space_cones(shape, method):
    """omega sweeps the body cone (half-angle alpha) about the figure axis and the space
    cone (|alpha - theta|) about the fixed L; omega, L and the axis stay coplanar; the
    plane turns about L at |L|/I (H&F). Oblate: alpha > theta; prolate: alpha <
    theta."""
    I, I3 = (1.0, 1.8) if shape == "oblate" else (2.0, 1.0)
    body = liebody.RigidBody([I, I, I3])
    omega_perp, omega3 = 0.4, 1.5
    omega0 = np.array([omega_perp, 0.0, omega3])
    q0 = liebody.quaternion.normalize([0.9, 0.2, -0.3, 0.1])
    traj = liebody.integrate(liebody.FreeBody(body), q0=q0, omega0=omega0, dt=0.01,
                             t_end=60.0, method=method)
    cones = analysis.cone_angles(I, I3, omega_perp, omega3)
    assert cones.oblate == (shape == "oblate")
    assert (cones.alpha > cones.theta) == cones.oblate

    z_body = np.array([0.0, 0.0, 1.0])
    body_cone = angles_between(traj.omega, z_body)
    np.testing.assert_allclose(body_cone, cones.body_cone, rtol=0, atol=1e-12)
    np.testing.assert_allclose(angles_between(traj.L, z_body), cones.theta, rtol=0, atol=1e-12)
    space_cone = angles_between(traj.omega_space, traj.L_space)
    np.testing.assert_allclose(space_cone, cones.space_cone, rtol=0, atol=1e-12)

    # omega, L and the symmetry axis lie in one plane (checked in space, where the axis
    # z_space = R(q) e3 comes from the integrated orientation): triple product ~ 0
    z_space = liebody.quaternion.rotate(traj.orientation, z_body)
    triple = np.einsum("ij,ij->i", traj.omega_space, np.cross(traj.L_space, z_space))
    scale = np.linalg.norm(traj.omega, axis=1) * np.linalg.norm(traj.L, axis=1)
    assert np.max(np.abs(triple) / scale) < 1e-12

    # body frame: omega circles the axis at Omega (force-free symmetric top), sense included
    Omega = analysis.precession_rate(I, I3, omega3)
    assert relative_error(analysis.wobble_period(traj, 0), 2 * math.pi / abs(Omega)) < 1e-9
    azimuth = np.unwrap(np.arctan2(traj.omega[:, 1], traj.omega[:, 0]))
    assert relative_error(np.polyfit(traj.t, azimuth, 1)[0], Omega) < 1e-9

    # space frame: the plane turns about the fixed L at |L| / I
    L_norm = float(np.linalg.norm(traj.L[0]))
    predicted = analysis.space_precession_rate(I, L_norm)
    assert relative_error(analysis.measured_space_precession_rate(traj), predicted) < 1e-9
    # ... and so does the figure axis: angle(z_space, L) = theta throughout
    np.testing.assert_allclose(angles_between(z_space, traj.L_space), cones.theta, atol=1e-12,
                               rtol=0)


# ------------------------------------------------------------------------------------------
# only rotation about a principal axis is torque-free (H&F: Euler's equations)
# ------------------------------------------------------------------------------------------

BOOK = bodies.book()


@pytest.mark.parametrize("axis", [0, 1, 2])
@pytest.mark.parametrize("method", [None, "splitting2"])
def test_rotation_about_a_principal_axis_keeps_omega(axis, method):
    """Steady rotation about any principal axis needs no torque: a free body keeps omega
    to round-off (even about the unstable intermediate axis, with no perturbation)."""
    omega0 = np.zeros(3)
    omega0[axis] = 5.0
    assert np.all(analysis.steady_rotation_torque(BOOK.moments, omega0) == 0.0)
    traj = liebody.integrate(liebody.FreeBody(BOOK), omega0=omega0, dt=1e-3, t_end=10.0,
                             method=method)
    assert np.max(np.abs(traj.omega - omega0)) <= 1e-13 * 5.0


@pytest.mark.parametrize("method", [None, "splitting2"])
def test_rotation_about_a_non_principal_axis_does_not_keep_omega(method):
    """Started about a non-principal axis, a free body's omega changes at once, at the
    rate -I^-1 N with N = omega x (I omega) the torque that would hold it steady."""
    omega0 = 5.0 * np.array([0.6, 0.0, 0.8])  # in the x-z plane, as the dumbbell of 1.4.1
    N = analysis.steady_rotation_torque(BOOK.moments, omega0)
    # as for the rotating dumbbell: only N_2 = omega1 omega3 (I1 - I3) is needed, not zero
    I1, _, I3 = BOOK.moments
    np.testing.assert_allclose(N, [0.0, omega0[0] * omega0[2] * (I1 - I3), 0.0], rtol=1e-14,
                               atol=0.0)
    assert N[1] != 0.0
    dt = 1e-4
    traj = liebody.integrate(liebody.FreeBody(BOOK), omega0=omega0, dt=dt, t_end=2.0,
                             method=method)
    change = np.max(np.linalg.norm(traj.omega - omega0, axis=1))
    assert change > 0.1 * np.linalg.norm(omega0)  # far beyond round-off
    # the initial rate of change of L (body frame) is -N: second-order one-sided difference
    dL = (-3 * traj.L[0] + 4 * traj.L[1] - traj.L[2]) / (2 * dt)
    np.testing.assert_allclose(dL, -N, rtol=1e-6, atol=1e-9 * np.linalg.norm(N))
