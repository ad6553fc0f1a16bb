"""Fast unit tests of liebody.analysis and liebody.bodies.

Each closed form is checked against an independent derivation: the eigenvalues of the
Jacobian of Euler's equations (numpy.linalg.eigvals), the vector geometry of omega, L
and the symmetry axis, independently computed flip periods (8 digits), high-precision values
(mpmath, computed once and pasted here so CI needs no mpmath) and scipy's DOP853. The
measurement functions are checked on synthetic samples with known answers. No
numba kernels run here (the simulations are in test_phenomena.py).
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

import liebody
from liebody import analysis, bodies

# ------------------------------------------------------------------------------------------
# independent helpers
# ------------------------------------------------------------------------------------------


def euler_rhs(moments: np.ndarray, omega: np.ndarray) -> np.ndarray:
    """Free Euler equations solved for omega': I omega' = (I omega) x omega."""
    return np.cross(moments * omega, omega) / moments


def jacobian(moments, omega, h: float = 1e-6) -> np.ndarray:
    """Jacobian of euler_rhs at omega by central differences (exact: the rhs is quadratic)."""
    moments = np.asarray(moments, dtype=float)
    J = np.empty((3, 3))
    for k in range(3):
        e = np.zeros(3)
        e[k] = h
        J[:, k] = (euler_rhs(moments, omega + e) - euler_rhs(moments, omega - e)) / (2 * h)
    return J


def angle(a: np.ndarray, b: np.ndarray) -> float:
    """Angle between two vectors, accurate for small and large angles."""
    return math.atan2(np.linalg.norm(np.cross(a, b)), float(np.dot(a, b)))


class FakeTrajectory(SimpleNamespace):
    """The attributes the measurement functions read, from synthetic samples."""

    def __len__(self) -> int:
        return len(self.t)


# ------------------------------------------------------------------------------------------
# precession rate (Hand & Finch ch. 8: the force-free symmetric top)
# ------------------------------------------------------------------------------------------


@pytest.mark.parametrize(("I", "I3", "omega3"), [(1.0, 2.0, 3.0), (2.0, 1.0, 3.0),
                                                 (2.0, 3.0, -0.7), (1.0 - 0.00327, 1.0, 1.0)])
def test_precession_rate_is_the_linearised_euler_frequency(I, I3, omega3):
    Omega = analysis.precession_rate(I, I3, omega3)
    assert Omega == pytest.approx(omega3 * (I3 - I) / I, rel=1e-15)
    J = jacobian([I, I, I3], np.array([0.0, 0.0, omega3]))
    ev = np.linalg.eigvals(J)
    np.testing.assert_allclose(np.sort(np.abs(ev.imag)), [0.0, abs(Omega), abs(Omega)],
                               rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(ev.real, 0.0, atol=1e-12, rtol=0)
    # sense: omega2' = +Omega omega1, i.e. (omega1, omega2) turns counterclockwise about +x3
    # for Omega > 0 (omega1 = c cos(Omega t), omega2 = c sin(Omega t), as in Hand & Finch)
    assert J[1, 0] == pytest.approx(Omega, rel=1e-9)
    assert J[0, 1] == pytest.approx(-Omega, rel=1e-9)


def test_precession_rate_sign_oblate_positive_prolate_negative():
    assert analysis.precession_rate(1.0, 2.0, 1.0) > 0
    assert analysis.precession_rate(2.0, 1.0, 1.0) < 0
    assert analysis.precession_rate(1.0, 1.0, 5.0) == 0.0


# ------------------------------------------------------------------------------------------
# cones (Hand & Finch ch. 8: the symmetric top in the inertial frame)
# ------------------------------------------------------------------------------------------


@pytest.mark.parametrize(("I", "I3"), [(1.0, 1.8), (2.0, 1.0), (1.0, 1.0001), (3.0, 0.5)])
@pytest.mark.parametrize(("omega_perp", "omega3"), [(0.3, 1.0), (2.0, 0.5), (1e-7, 1.0),
                                                    (0.4, -1.0)])
def test_cone_angles_against_vector_geometry(I, I3, omega_perp, omega3):
    cones = analysis.cone_angles(I, I3, omega_perp, omega3)
    phase = 0.37
    omega = np.array([omega_perp * math.cos(phase), omega_perp * math.sin(phase), omega3])
    L = np.array([I, I, I3]) * omega
    z = np.array([0.0, 0.0, math.copysign(1.0, omega3)])  # the half-axis on omega's side
    assert cones.alpha == pytest.approx(angle(omega, z), rel=1e-13, abs=1e-15)
    assert cones.theta == pytest.approx(angle(L, z), rel=1e-13, abs=1e-15)
    assert cones.body_cone == cones.alpha
    assert cones.space_cone == pytest.approx(angle(omega, L), rel=1e-9, abs=1e-15)
    # tan alpha = (I3 / I) tan theta
    assert math.tan(cones.alpha) == pytest.approx(I3 / I * math.tan(cones.theta), rel=1e-12)
    assert cones.oblate == (I3 > I)
    if cones.oblate:
        assert cones.alpha > cones.theta
    else:
        assert cones.alpha < cones.theta


def test_cone_angles_is_a_named_tuple():
    alpha, theta, body_cone, space_cone, oblate = analysis.cone_angles(1.0, 2.0, 1.0, 1.0)
    assert body_cone == alpha
    assert alpha == pytest.approx(math.pi / 4)
    assert theta == pytest.approx(math.atan(0.5))
    assert space_cone == pytest.approx(alpha - theta)
    assert oblate is True


# ------------------------------------------------------------------------------------------
# space precession (Hand & Finch ch. 8: the symmetric top in the inertial frame)
# ------------------------------------------------------------------------------------------


@pytest.mark.parametrize(("I", "I3"), [(1.0, 1.8), (2.0, 1.0)])
def test_omega_decomposition_and_space_precession_rate(I, I3):
    rng = np.random.default_rng(3)
    z = np.array([0.0, 0.0, 1.0])
    for omega in rng.normal(size=(20, 3)):
        L = np.array([I, I, I3]) * omega
        Lnorm = float(np.linalg.norm(L))
        Omega = analysis.precession_rate(I, I3, omega[2])
        rate = analysis.space_precession_rate(I, Lnorm)
        assert rate == pytest.approx(Lnorm / I, rel=1e-15)
        # omega = (L/I) L_hat - Omega z_hat  (Hand & Finch, ch. 8)
        np.testing.assert_allclose(rate * L / Lnorm - Omega * z, omega, rtol=0, atol=1e-13)
        # the symmetry axis moves as dz/dt = omega x z = rate (L_hat x z): a rotation about
        # L_hat at the rate |L| / I, counterclockwise
        np.testing.assert_allclose(np.cross(omega, z), rate * np.cross(L / Lnorm, z),
                                   atol=1e-13, rtol=0)


# ------------------------------------------------------------------------------------------
# stability of the axes (Hand & Finch ch. 8: stability of rotation about the principal axes)
# ------------------------------------------------------------------------------------------


def test_stability_text_formulas_for_123():
    I1, I2, I3 = 1.0, 2.0, 3.0
    r1, r2, r3 = (I3 - I2) / I1, (I3 - I1) / I2, (I2 - I1) / I3
    w = 1.7
    assert analysis.stability([I1, I2, I3], w, 0) == (True, pytest.approx(math.sqrt(r2 * r3) * w))
    assert analysis.stability([I1, I2, I3], w, 1) == (False, pytest.approx(math.sqrt(r1 * r3) * w))
    assert analysis.stability([I1, I2, I3], w, 2) == (True, pytest.approx(math.sqrt(r1 * r2) * w))
    stable, rate = analysis.stability([I1, I2, I3], -w, axis=2)  # sign of omega is irrelevant
    assert stable and rate == pytest.approx(math.sqrt(r1 * r2) * w)
    assert [analysis.axis_role([I1, I2, I3], k) for k in range(3)] == [
        "smallest", "intermediate", "largest"]


@pytest.mark.parametrize("seed", range(8))
def test_stability_matches_jacobian_eigenvalues_any_order(seed):
    rng = np.random.default_rng(seed)
    moments = rng.uniform(0.5, 3.0, size=3)  # random order
    w = rng.uniform(-3.0, 3.0)
    for axis in range(3):
        omega = np.zeros(3)
        omega[axis] = w
        ev = np.linalg.eigvals(jacobian(moments, omega))
        res = analysis.stability(moments, w, axis)
        role = analysis.axis_role(moments, axis)
        assert role == ("smallest", "intermediate", "largest")[
            int(np.argsort(moments).tolist().index(axis))]
        if res.stable:
            assert role != "intermediate"
            np.testing.assert_allclose(np.sort(np.abs(ev.imag)), [0, res.rate, res.rate],
                                       rtol=1e-8, atol=1e-12)
            np.testing.assert_allclose(ev.real, 0, atol=1e-9, rtol=0)
        else:
            assert role == "intermediate"
            np.testing.assert_allclose(np.sort(ev.real), [-res.rate, 0, res.rate],
                                       rtol=1e-8, atol=1e-12)


def test_stability_equal_moments():
    # symmetric top about its symmetry axis: frequency |Omega| of the free precession
    res = analysis.stability([2.0, 2.0, 3.0], 1.5, axis=2)
    assert res.stable and res.rate == pytest.approx(abs(analysis.precession_rate(2, 3, 1.5)))
    res = analysis.stability([3.0, 1.0, 3.0], 1.5, axis=1)
    assert res.stable and res.rate == pytest.approx(abs(analysis.precession_rate(3, 1, 1.5)))
    # axis in the equal-moment plane: kappa = 0, linear drift
    assert analysis.stability([2.0, 2.0, 3.0], 1.0, axis=0) == (False, 0.0)
    # sphere: every rotation is steady
    assert analysis.stability([2.0, 2.0, 2.0], 1.0, axis=0) == (True, 0.0)


# ------------------------------------------------------------------------------------------
# flip period (Landau & Lifshitz, Mechanics, §37)
# ------------------------------------------------------------------------------------------

# 4 K(k)/nu for I = (1, 2, 3), L = (eps, 2, eps), mpmath at 40 digits (computed once).
# FLIP_INDEPENDENT: values computed independently of liebody to 8 digits (not published
# values). Its 106.7251 for eps = 1e-6 is off in the 6th digit (the log formula
# (4/lambda) ln(4/k') also gives 106.72577); the other two agree to all 8 digits given.
FLIP_MPMATH = {1e-2: 42.91345688065830512, 1e-4: 74.82021109745867717,
               1e-6: 106.7257662822632664}
FLIP_INDEPENDENT = {1e-2: (42.913457, 2e-8), 1e-4: (74.820211, 2e-8), 1e-6: (106.7251, 1e-5)}


@pytest.mark.parametrize("eps", [1e-2, 1e-4, 1e-6])
def test_flip_period_literature_and_high_precision_values(eps):
    period = analysis.flip_period([1.0, 2.0, 3.0], [eps, 2.0, eps])
    assert period == pytest.approx(FLIP_MPMATH[eps], rel=1e-13)
    value, rel = FLIP_INDEPENDENT[eps]
    assert period == pytest.approx(value, rel=rel)
    # near the separatrix: T ~ (4/lambda) ln(4/k'), lambda = sqrt(r1 r3) omega2
    lam = analysis.stability([1.0, 2.0, 3.0], 1.0, axis=1).rate
    k_prime = math.sqrt(2 / 3) * eps  # k'^2 = (I3 - I1)(E2 I2 - G^2) / ((I2 - I1)(E2 I3 - G^2))
    assert period == pytest.approx(4 / lam * math.log(4 / k_prime), rel=2 * eps)


def _dop853_l2_zeros(moments, L0, t_end):
    moments = np.asarray(moments, dtype=float)
    sol = solve_ivp(lambda t, L: np.cross(L, L / moments), (0.0, t_end), L0, method="DOP853",
                    rtol=1e-12, atol=1e-14, events=lambda t, L: L[1])
    return sol.t_events[0]


@pytest.mark.parametrize(("moments", "L0", "case"), [
    ([1.0, 2.0, 3.0], [1e-2, 2.0, 1e-2], "low"),       # G^2 < 2 T I2: about the smallest axis
    ([1.0, 2.0, 3.0], [0.3, 1.0, 2.0], "high"),         # G^2 > 2 T I2: about the largest axis
    ([2.0, 1.0, 2.0 / 3.0], [math.cos(1.1), 0.0, math.sin(1.1)], "hlw"),
])
def test_flip_period_against_dop853(moments, L0, case):
    T = analysis.flip_period(moments, L0)
    zeros = _dop853_l2_zeros(moments, np.array(L0, dtype=float), 2.6 * T)
    # flips every T/2: the zeros of L2 (the intermediate component)
    mid = int(np.argsort(moments)[1])
    if mid != 1:
        pytest.fail("test data: the intermediate moment must be the second")
    spacing = np.diff(zeros)
    assert spacing.size >= 3
    np.testing.assert_allclose(spacing, T / 2, rtol=1e-9)


def test_flip_period_small_amplitude_limits_are_stable_frequencies():
    moments = [1.0, 2.0, 3.0]
    for axis, L0 in ((0, [1.0, 1e-7, 1e-7]), (2, [1e-7, 1e-7, 3.0])):
        omega_axis = L0[axis] / moments[axis]
        freq = analysis.stability(moments, omega_axis, axis).rate
        assert analysis.flip_period(moments, L0) == pytest.approx(2 * math.pi / freq, rel=1e-12)


def test_flip_period_any_order_of_moments():
    T = analysis.flip_period([1.0, 2.0, 3.0], [0.3, 1.0, 2.0])
    perm = [2, 0, 1]
    assert analysis.flip_period(np.array([1.0, 2.0, 3.0])[perm],
                                np.array([0.3, 1.0, 2.0])[perm]) == pytest.approx(T, rel=1e-14)


def test_flip_period_errors():
    with pytest.raises(ValueError, match="separatrix"):
        analysis.flip_period([1.0, 2.0, 3.0], [0.0, 2.0, 0.0])  # steady intermediate axis
    with pytest.raises(ValueError, match="separatrix"):
        # G^2 = 2 T I2: -L1^2 + L3^2 / 3 = 0
        analysis.flip_period([1.0, 2.0, 3.0], [1.0, 0.5, math.sqrt(3.0)])
    with pytest.raises(ValueError, match="symmetric top"):
        analysis.flip_period([1.0, 1.0, 3.0], [0.1, 0.2, 1.0])
    with pytest.raises(ValueError, match="nonzero"):
        analysis.flip_period([1.0, 2.0, 3.0], [0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="moments"):
        analysis.flip_period([1.0, -2.0, 3.0], [0.1, 0.2, 1.0])
    with pytest.raises(ValueError, match="L must have shape"):
        analysis.flip_period([1.0, 2.0, 3.0], [0.1, 0.2])


# ------------------------------------------------------------------------------------------
# steady-rotation torque (Hand & Finch ch. 8: Euler's equations, the rotating dumbbell)
# ------------------------------------------------------------------------------------------


@pytest.mark.parametrize("th", [0.0, 0.3, math.pi / 4, 1.2, math.pi / 2])
def test_dumbbell_torque_text_1_4_1(th):
    m, l, w = 2.0, 0.5, 3.0
    I1 = m * l * l / 2
    N = analysis.steady_rotation_torque([I1, I1, 0.0], w * np.array([math.sin(th), 0.0,
                                                                     math.cos(th)]))
    np.testing.assert_allclose(N, [0.0, w * w * math.sin(th) * math.cos(th) * I1, 0.0],
                               atol=1e-14, rtol=0)


def test_dumbbell_from_point_masses_in_the_tensor_frame():
    # two masses m/2 at +-l/2 on z: I = diag(m l^2/4, m l^2/4, 0) about the centre
    m, l, w, th = 2.0, 1.0, 1.5, 0.4
    I = liebody.inertia.tensor([m / 2, m / 2], [[0, 0, l / 2], [0, 0, -l / 2]])
    N = analysis.steady_rotation_torque(I, w * np.array([math.sin(th), 0.0, math.cos(th)]))
    np.testing.assert_allclose(N, [0, w * w * math.sin(th) * math.cos(th) * I[0, 0], 0],
                               atol=1e-14, rtol=0)


def test_torque_is_zero_exactly_along_principal_axes_and_nonzero_otherwise():
    moments = np.array([1.0, 2.0, 3.0])
    for k in range(3):
        omega = np.zeros(3)
        omega[k] = 2.5
        assert np.all(analysis.steady_rotation_torque(moments, omega) == 0.0)
    assert np.linalg.norm(analysis.steady_rotation_torque(moments, [1.0, 1.0, 0.0])) > 0.5
    # a tensor in a rotated frame: zero (to round-off) along its principal axes only
    R = Rotation.from_euler("zyx", [0.3, -0.7, 1.1]).as_matrix()
    I = R @ np.diag(moments) @ R.T
    for k in range(3):
        assert np.linalg.norm(analysis.steady_rotation_torque(I, 2.5 * R[:, k])) < 1e-14
    assert np.linalg.norm(analysis.steady_rotation_torque(I, R @ [1.0, 1.0, 0.0])) > 0.5


def test_torque_is_minus_the_free_body_rate_and_frame_covariant():
    rng = np.random.default_rng(7)
    moments = np.array([1.0, 1.5, 2.2])
    R = Rotation.from_rotvec([0.2, 0.9, -0.4]).as_matrix()
    for omega in rng.normal(size=(10, 3)):
        N = analysis.steady_rotation_torque(moments, omega)
        # a free body has I omega' = -(omega x I omega): the applied torque cancels it
        np.testing.assert_allclose(N, -moments * euler_rhs(moments, omega), atol=1e-13, rtol=0)
        # the component form of Euler's equations: N1 = -omega2 omega3 (I2 - I3), cyclically
        I1, I2, I3 = moments
        w1, w2, w3 = omega
        np.testing.assert_allclose(N, [-w2 * w3 * (I2 - I3), -w3 * w1 * (I3 - I1),
                                       -w1 * w2 * (I1 - I2)], atol=1e-13, rtol=0)
        N_rot = analysis.steady_rotation_torque(R @ np.diag(moments) @ R.T, R @ omega)
        np.testing.assert_allclose(N_rot, R @ N, atol=1e-13, rtol=0)
    # vectorised over leading axes
    W = rng.normal(size=(4, 5, 3))
    assert analysis.steady_rotation_torque(moments, W).shape == (4, 5, 3)


def test_torque_validation():
    with pytest.raises(ValueError, match="inertia moments must be >= 0"):
        analysis.steady_rotation_torque([1.0, -1.0, 2.0], [1.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="symmetric"):
        analysis.steady_rotation_torque([[1, 2, 0], [0, 1, 0], [0, 0, 1]], [1.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="positive semidefinite"):
        analysis.steady_rotation_torque(np.diag([1.0, -1.0, 1.0]), [1.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="shape"):
        analysis.steady_rotation_torque([1.0, 2.0], [1.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="omega must have shape"):
        analysis.steady_rotation_torque([1.0, 2.0, 3.0], [1.0, 0.0])
    with pytest.raises(ValueError, match="omega must be finite"):
        analysis.steady_rotation_torque([1.0, 2.0, 3.0], [1.0, np.nan, 0.0])
    with pytest.raises(TypeError, match="inertia must contain real numbers"):
        analysis.steady_rotation_torque(["a", "b", "c"], [1.0, 0.0, 0.0])


# ------------------------------------------------------------------------------------------
# Chandler period and the bodies module
# ------------------------------------------------------------------------------------------


def test_chandler_period_rigid_earth():
    H = bodies.EARTH_H
    assert analysis.chandler_period() == pytest.approx((1 - H) / H, rel=1e-14)
    assert analysis.chandler_period() == pytest.approx(304.4559, abs=1e-4)
    assert analysis.chandler_period(bodies.earth(bodies.EARTH_C)) == pytest.approx(
        analysis.chandler_period(), rel=1e-13)
    # in solar days: 303.6
    solar_day = 86400.0
    assert analysis.chandler_period() * bodies.SIDEREAL_DAY / solar_day == pytest.approx(
        303.6, abs=0.05)


def test_chandler_period_is_the_precession_and_stability_period():
    earth = bodies.earth()
    A, _, C = earth.moments
    spin = bodies.earth_spin()
    Omega = analysis.precession_rate(A, C, spin)
    period_days = 2 * math.pi / Omega / bodies.SIDEREAL_DAY
    assert analysis.chandler_period(earth) == pytest.approx(period_days, rel=1e-12)
    # a triaxial body spinning about its largest axis: 2 pi / sqrt(r1 r2) omega3
    tri = liebody.RigidBody([1.0, 1.1, 1.3])
    freq = analysis.stability(tri.moments, 1.0, axis=2).rate
    assert analysis.chandler_period(tri) == pytest.approx(1.0 / freq, rel=1e-14)
    # prolate symmetric top: A / |C - A|
    assert analysis.chandler_period(liebody.RigidBody([2.0, 2.0, 1.0])) == pytest.approx(2.0)


def test_chandler_period_errors():
    with pytest.raises(ValueError, match="spherical"):
        analysis.chandler_period(liebody.RigidBody([1.0, 1.0, 1.0]))
    with pytest.raises(TypeError, match="RigidBody"):
        analysis.chandler_period([1.0, 1.0, 2.0])


def test_bodies():
    assert bodies.SIDEREAL_DAY == 86164.0905
    assert bodies.EARTH_H == 0.0032737949
    e = bodies.earth()
    np.testing.assert_allclose(e.moments, [1 - bodies.EARTH_H, 1 - bodies.EARTH_H, 1.0],
                               rtol=1e-15)
    assert e.symmetry_axis == 2 and e.is_symmetric
    assert (e.moments[2] - e.moments[0]) / e.moments[2] == pytest.approx(bodies.EARTH_H,
                                                                          rel=1e-12)
    assert bodies.earth(bodies.EARTH_C).moments[2] == bodies.EARTH_C
    assert bodies.earth_spin() == pytest.approx(7.2921159e-5, rel=1e-8)
    np.testing.assert_allclose(bodies.hlw().moments, [2.0, 1.0, 2.0 / 3.0])
    b = bodies.book()
    assert b.moments[0] < b.moments[1] < b.moments[2] and b.mass == 1.0
    assert analysis.axis_role(b.moments, 1) == "intermediate"
    with pytest.raises(ValueError, match="C must be > 0"):
        bodies.earth(0.0)


# ------------------------------------------------------------------------------------------
# measurement functions on synthetic samples
# ------------------------------------------------------------------------------------------


def test_zero_crossings_of_a_sampled_sine():
    w, phase = 0.7, 0.3
    t = np.arange(0.0, 60.0, 0.4)  # about 22 samples per period
    y = np.sin(w * t + phase)
    exact = (np.arange(1, 40) * math.pi - phase) / w
    exact = exact[exact < t[-1]]
    cubic = analysis.zero_crossings(t, y)
    linear = analysis.zero_crossings(t, y, interpolation="linear")
    np.testing.assert_allclose(cubic, exact, atol=2e-5, rtol=0)  # measured 8.5e-6
    np.testing.assert_allclose(linear, exact, atol=1e-3, rtol=0)  # measured 5.0e-4
    up = analysis.zero_crossings(t, y, direction=1)
    down = analysis.zero_crossings(t, y, direction=-1)
    np.testing.assert_allclose(np.sort(np.concatenate([up, down])), cubic)
    assert np.all(np.cos(w * up + phase) > 0) and np.all(np.cos(w * down + phase) < 0)


def test_zero_crossings_cubic_is_fourth_order_on_a_skewed_wave():
    def f(t):
        return np.sin(t) + 0.4 * np.sin(2 * t) + 0.1

    from scipy.optimize import brentq

    t_fine = np.linspace(0, 20, 200001)
    y_fine = f(t_fine)
    i = np.flatnonzero(np.sign(y_fine[:-1]) != np.sign(y_fine[1:]))
    exact = np.array([brentq(f, t_fine[k], t_fine[k + 1], xtol=1e-15) for k in i])
    errs, errs_lin = [], []
    for dt in (0.2, 0.1):
        t = np.arange(0, 20 + dt / 2, dt)
        errs.append(np.max(np.abs(analysis.zero_crossings(t, f(t)) - exact)))
        errs_lin.append(np.max(np.abs(analysis.zero_crossings(t, f(t), interpolation="linear")
                                      - exact)))
    assert errs[1] < 5e-5  # measured 2.5e-5
    assert errs[0] / errs[1] > 12  # fourth order: ratio ~16 (measured 17)
    assert 3 < errs_lin[0] / errs_lin[1] < 6  # the chord: second order


def test_wobble_period_synthetic_and_offset():
    t = np.arange(0.0, 100.0, 0.05)
    P = 7.3
    omega = np.zeros((t.size, 3))
    omega[:, 0] = 0.2 + np.cos(2 * math.pi * t / P)  # offset: half periods are unequal
    omega[:, 2] = 1.0
    traj = FakeTrajectory(t=t, omega=omega)
    assert analysis.wobble_period(traj, component=0) == pytest.approx(P, rel=1e-7)
    with pytest.raises(ValueError, match="at least 2 sign changes"):
        analysis.wobble_period(traj, component=2)
    with pytest.raises(ValueError, match="component must be an axis index"):
        analysis.wobble_period(traj, component=3)
    # exactly two crossings: twice their distance
    short = FakeTrajectory(t=t[t < 6.0], omega=np.c_[np.cos(2 * math.pi * t[t < 6.0] / P),
                                                    np.zeros((np.sum(t < 6.0), 2))])
    assert analysis.wobble_period(short) == pytest.approx(P, rel=1e-7)


def test_fit_growth_rate_synthetic():
    lam, w2 = 0.5773502691896258, 1.0
    t = np.arange(0.0, 40.0, 0.02)
    A, B = -0.37e-8, 1.37e-8  # growing and decaying modes, as from a 1e-8 kick
    omega = np.zeros((t.size, 3))
    omega[:, 0] = A * np.exp(lam * t) + B * np.exp(-lam * t)
    omega[:, 1] = w2
    omega[:, 2] = 0.5 * (A * np.exp(lam * t) - B * np.exp(-lam * t))
    traj = FakeTrajectory(t=t, omega=omega)
    assert analysis.fit_growth_rate(traj, component=0) == pytest.approx(lam, rel=1e-6)
    assert analysis.fit_growth_rate(traj) == pytest.approx(lam, rel=1e-6)  # transverse
    assert analysis.fit_growth_rate(traj, 0, window=(12.0, 20.0)) == pytest.approx(lam,
                                                                                 rel=1e-6)
    mask = (t > 12.0) & (t < 20.0)
    assert analysis.fit_growth_rate(traj, 0, window=mask) == pytest.approx(lam, rel=1e-6)
    # a window that starts too early is biased by the decaying mode (the documented rule)
    early = analysis.fit_growth_rate(traj, 0, window=(0.5, 8.0))
    assert abs(early / lam - 1) > 1e-2
    with pytest.raises(ValueError, match="at least 3 samples"):
        analysis.fit_growth_rate(traj, 0, window=(100.0, 200.0))
    with pytest.raises(ValueError, match="window must be"):
        analysis.fit_growth_rate(traj, 0, window=np.ones(3, dtype=bool))
    with pytest.raises(ValueError, match="t_end > t_start"):
        analysis.fit_growth_rate(traj, 0, window=(5.0, 1.0))


def test_measured_space_precession_rate_synthetic():
    t = np.linspace(0.0, 10.0, 400)
    rate = 1.3
    n = np.array([1.0, 2.0, 2.0]) / 3.0  # L_hat
    e1 = np.cross(n, [0.0, 0.0, 1.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(n, e1)
    omega_space = (2.0 * n + 0.3 * (np.cos(rate * t)[:, None] * e1
                                    + np.sin(rate * t)[:, None] * e2))
    traj = FakeTrajectory(t=t, omega_space=omega_space, L_space=np.tile(5.0 * n, (t.size, 1)))
    assert analysis.measured_space_precession_rate(traj) == pytest.approx(rate, rel=1e-12)
    traj_rev = FakeTrajectory(t=t, omega_space=omega_space, L_space=np.tile(-5.0 * n,
                                                                           (t.size, 1)))
    assert analysis.measured_space_precession_rate(traj_rev) == pytest.approx(-rate, rel=1e-12)
    steady = FakeTrajectory(t=t, omega_space=np.tile(n, (t.size, 1)),
                            L_space=np.tile(n, (t.size, 1)))
    with pytest.raises(ValueError, match="parallel"):
        analysis.measured_space_precession_rate(steady)


# ------------------------------------------------------------------------------------------
# ensembles: the measurements take one body; Trajectory.body(i) and equality
# ------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def free_ensemble():
    body = liebody.RigidBody([1.0, 2.0, 3.0])
    q0 = liebody.quaternion.random(3, rng=1)
    L0 = np.array([[1.0, 0.1, 0.2], [0.2, 0.1, 1.0], [0.05, 1.0, 1e-9]])
    scene = liebody.FreeBody(body)
    return scene, q0, L0, liebody.integrate(scene, q0=q0, L0=L0, dt=0.01, t_end=30.0)


@pytest.mark.parametrize("measure", [analysis.wobble_period, analysis.fit_growth_rate,
                                     analysis.measured_space_precession_rate])
def test_measurements_refuse_an_ensemble_naming_the_way_out(free_ensemble, measure):
    traj = free_ensemble[3]
    assert traj.q.shape[:2] == (3, len(traj))
    with pytest.raises(ValueError, match=rf"^{measure.__name__} takes one body's trajectory"
                                         r".*ensemble of 3 bodies.*traj\.body\(i\)"):
        measure(traj)


def test_body_of_an_ensemble_is_that_body_run_alone(free_ensemble):
    scene, q0, L0, traj = free_ensemble
    for i in (0, 1, 2, -1):
        one = traj.body(i)
        alone = liebody.integrate(scene, q0=q0[i], L0=L0[i], dt=0.01, t_end=30.0)
        assert one.n_bodies is None and one.q.shape == alone.q.shape
        np.testing.assert_array_equal(one.t, alone.t)
        np.testing.assert_allclose(one.q, alone.q, atol=1e-12, rtol=0)
        np.testing.assert_allclose(one.L, alone.L, atol=1e-12, rtol=0)
        assert one.status == "complete" and one.failed_at is None
    # and the measurements work on it, as on the body run alone (L0[0]: about the
    # smallest axis; L0[1]: about the largest)
    alone = liebody.integrate(scene, q0=q0[1], L0=L0[1], dt=0.01, t_end=30.0)
    assert analysis.wobble_period(traj.body(1)) == pytest.approx(analysis.wobble_period(alone),
                                                                 rel=1e-10)
    expected = analysis.flip_period(scene.moments, L0[1])
    assert analysis.wobble_period(traj.body(1)) == pytest.approx(expected, rel=1e-4)


def test_body_of_a_batched_scene_takes_that_body():
    bodies_ = liebody.RigidBody.batch([[1.0, 2.0, 3.0], [2.0, 3.0, 5.0]])
    scene = liebody.FreeBody(bodies_)
    L0 = [[1.0, 0.2, 0.1], [0.3, 0.1, 1.0]]
    traj = liebody.integrate(scene, L0=L0, dt=0.01, steps=100)
    one = traj.body(1)
    np.testing.assert_array_equal(one.moments, [2.0, 3.0, 5.0])
    np.testing.assert_allclose(one.omega, traj.L[1] / np.array([2.0, 3.0, 5.0]), rtol=1e-15)


def test_body_validation(free_ensemble):
    traj = free_ensemble[3]
    with pytest.raises(ValueError, match=r"i must be a body index in \[-3, 3\), got 3"):
        traj.body(3)
    with pytest.raises(TypeError, match=r"i must be an integer"):
        traj.body(1.0)
    with pytest.raises(ValueError, match=r"body\(i\) picks one body of an ensemble"):
        traj.body(0).body(0)


def test_trajectory_equality_is_identity(free_ensemble):
    scene, q0, L0, traj = free_ensemble
    a = liebody.integrate(scene, q0=q0[0], L0=L0[0], dt=0.01, steps=10)
    b = liebody.integrate(scene, q0=q0[0], L0=L0[0], dt=0.01, steps=10)
    assert np.array_equal(a.q, b.q)  # the same numbers ...
    assert (a == a) is True and (a == b) is False and (a != b) is True  # ... two results
    assert traj == traj and traj != traj.body(0)
    assert len({a, b, a}) == 2  # hashable, by identity


# ------------------------------------------------------------------------------------------
# validation of the scalar closed forms
# ------------------------------------------------------------------------------------------


@pytest.mark.parametrize(("call", "exc", "match"), [
    (lambda: analysis.precession_rate(0.0, 1.0, 1.0), ValueError, "I must be > 0"),
    (lambda: analysis.precession_rate(1.0, -1.0, 1.0), ValueError, "I3 must be > 0"),
    (lambda: analysis.precession_rate(1.0, 1.0, math.inf), ValueError, "omega3 must be finite"),
    (lambda: analysis.precession_rate(1.0, 1.0, "1"), TypeError, "omega3 must be a real"),
    (lambda: analysis.cone_angles(1.0, 2.0, -0.1, 1.0), ValueError, "omega_perp must be >= 0"),
    (lambda: analysis.cone_angles(1.0, 2.0, 0.0, 0.0), ValueError, "both be zero"),
    (lambda: analysis.space_precession_rate(1.0, -1.0), ValueError, "L_norm must be >= 0"),
    (lambda: analysis.stability([1.0, 2.0, 3.0], 1.0, 3), ValueError, "axis must be"),
    (lambda: analysis.stability([1.0, 2.0, 3.0], 1.0, 1.0), TypeError, "axis must be"),
    (lambda: analysis.stability([1.0, 2.0, 3.0], 1.0, True), TypeError, "axis must be"),
    (lambda: analysis.stability([1.0, 0.0, 3.0], 1.0, 0), ValueError, "moments must be"),
    (lambda: analysis.stability([1.0, 2.0, 3.0], np.nan, 0), ValueError, "omega must be"),
    (lambda: analysis.zero_crossings([0.0, 1.0, 0.5], [1.0, -1.0, 1.0]), ValueError,
     "strictly increasing"),
    (lambda: analysis.zero_crossings([0.0, 1.0], [1.0]), ValueError, "equal length"),
    (lambda: analysis.zero_crossings([0.0, 1.0], [1.0, -1.0], direction=2), ValueError,
     "direction"),
    (lambda: analysis.zero_crossings([0.0, 1.0], [1.0, -1.0], interpolation="spline"),
     ValueError, "interpolation"),
])
def test_validation(call, exc, match):
    with pytest.raises(exc, match=match):
        call()
