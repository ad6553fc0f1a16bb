"""liebody.euler against the definition of the Euler angles, scipy and exact derivatives.

References used here are independent of the implementation: the z-x-z rotation
matrices of Hand & Finch, *Analytical Mechanics*, ch. 8 (Euler angles) copied term by
term, scipy's ``Rotation`` ('ZXZ' intrinsic, scalar-last quaternions),
the product rule on ``V1 V2 V3`` and finite differences of ``V(t)``.

Property tests run without a hypothesis deadline: the first example of a test may
include the (one-off) numba compilation of the quaternion kernels.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from liebody import euler as E
from liebody import quaternion as Q

PI = np.pi
EPS = np.finfo(float).eps

angle = st.floats(-PI, PI, allow_nan=False)
big_angle = st.floats(-1e3, 1e3, allow_nan=False)
theta_canon = st.floats(0.0, PI, allow_nan=False)
rate = st.floats(-10.0, 10.0, allow_nan=False)
# offsets of theta from 0 (or pi) at and next to gimbal lock
tiny = st.sampled_from([0.0, 5e-324, 1e-300, 1e-200, 1e-20, 1e-16, 2e-16, 3e-16, 4.4e-16,
                        5e-16, 1e-15, 1e-12, 1e-8, 1e-6])


@st.composite
def gimbal_angles(draw):
    off = draw(tiny)
    theta = PI - off if draw(st.booleans()) else off
    return np.array([draw(angle), theta, draw(angle)])


@st.composite
def canonical_angles(draw, theta=theta_canon):
    return np.array([draw(angle), draw(theta), draw(angle)])


def ang_diff(a, b):
    """|a - b| modulo 2 pi, in [0, pi]."""
    return np.abs(np.angle(np.exp(1j * (np.asarray(a) - np.asarray(b)))))


def scipy_matrix(angles):
    return Rotation.from_euler("ZXZ", angles).as_matrix()


def scipy_quat(angles):
    """scipy's quaternion of the ZXZ angles, converted to scalar first."""
    xyzw = Rotation.from_euler("ZXZ", angles).as_quat()
    return np.concatenate([xyzw[..., 3:], xyzw[..., :3]], axis=-1)


def same_quat(p, q, atol):
    d = np.minimum(np.abs(p - q).max(axis=-1), np.abs(p + q).max(axis=-1))
    return np.all(d <= atol)


def V_of(angles):
    a = np.asarray(angles)
    return E.matrix(a[..., 0], a[..., 1], a[..., 2])


# --- Hand & Finch's definition of the Euler angles (ch. 8), copied term by term -----


def text_V(phi, theta, psi):
    cos, sin = np.cos, np.sin
    return np.array([
        [cos(psi) * cos(phi) - cos(theta) * sin(phi) * sin(psi),
         -sin(psi) * cos(phi) - cos(theta) * sin(phi) * cos(psi),
         sin(theta) * sin(phi)],
        [cos(psi) * sin(phi) + cos(theta) * cos(phi) * sin(psi),
         -sin(phi) * sin(psi) + cos(theta) * cos(phi) * cos(psi),
         -sin(theta) * cos(phi)],
        [sin(theta) * sin(psi), sin(theta) * cos(psi), cos(theta)],
    ])


def text_tilde_V1(phi):
    return np.array([[np.cos(phi), np.sin(phi), 0], [-np.sin(phi), np.cos(phi), 0], [0, 0, 1]])


def text_tilde_V2(theta):
    return np.array([[1, 0, 0], [0, np.cos(theta), np.sin(theta)],
                     [0, -np.sin(theta), np.cos(theta)]])


text_tilde_V3 = text_tilde_V1  # same form in psi


# --- matrix -------------------------------------------------------------------------


@settings(deadline=None)
@given(big_angle, big_angle, big_angle)
def test_matrix_matches_text_term_by_term(phi, theta, psi):
    np.testing.assert_allclose(E.matrix(phi, theta, psi), text_V(phi, theta, psi),
                               rtol=0, atol=1e-15)


@settings(deadline=None)
@given(big_angle, big_angle, big_angle)
def test_matrix_is_product_of_text_rotations(phi, theta, psi):
    # V = V1 V2 V3 with V_i the transposes of the tilde V_i; tilde V = V3~ V2~ V1~
    tilde = text_tilde_V3(psi) @ text_tilde_V2(theta) @ text_tilde_V1(phi)
    V = E.matrix(phi, theta, psi)
    np.testing.assert_allclose(V, tilde.T, atol=1e-14, rtol=0)
    np.testing.assert_allclose(V, text_tilde_V1(phi).T @ text_tilde_V2(theta).T
                               @ text_tilde_V3(psi).T, atol=1e-14, rtol=0)


def test_matrix_matches_scipy_and_is_proper_rotation():
    rng = np.random.default_rng(0)
    a = rng.uniform(-10, 10, size=(500, 3))
    V = V_of(a)
    assert V.shape == (500, 3, 3)
    np.testing.assert_allclose(V, scipy_matrix(a), atol=2e-15, rtol=0)
    np.testing.assert_allclose(np.swapaxes(V, -1, -2) @ V, np.broadcast_to(np.eye(3), V.shape),
                               atol=2e-15, rtol=0)
    np.testing.assert_allclose(np.linalg.det(V), 1.0, atol=2e-15, rtol=0)
    # body to space: the body z axis lands on the third column of V
    ez = V @ np.array([0.0, 0.0, 1.0])
    np.testing.assert_allclose(ez, np.stack([np.sin(a[:, 1]) * np.sin(a[:, 0]),
                                             -np.sin(a[:, 1]) * np.cos(a[:, 0]),
                                             np.cos(a[:, 1])], axis=-1), atol=1e-15, rtol=0)


def test_matrix_broadcasts_and_accepts_scalars():
    phi = np.linspace(-3, 3, 5)[:, None]
    theta = np.linspace(0, 3, 4)[None, :]
    V = E.matrix(phi, theta, 0.7)
    assert V.shape == (5, 4, 3, 3)
    np.testing.assert_allclose(V[2, 3], text_V(phi[2, 0], theta[0, 3], 0.7), atol=1e-15, rtol=0)
    assert E.matrix(0.1, 0.2, 0.3).shape == (3, 3)
    assert E.matrix([0.1], 1, [0.3, 0.4]).shape == (2, 3, 3)
    np.testing.assert_array_equal(E.matrix(0, 0, 0), np.eye(3))


# --- to_quaternion ------------------------------------------------------------------


def test_to_quaternion_matches_scipy_and_matrix():
    rng = np.random.default_rng(1)
    a = rng.uniform(-10, 10, size=(500, 3))
    q = E.to_quaternion(a)
    assert q.shape == (500, 4)
    np.testing.assert_allclose(np.linalg.norm(q, axis=-1), 1.0, atol=1e-15, rtol=0)
    assert same_quat(q, scipy_quat(a), atol=1e-15)
    assert not np.allclose(q, scipy_quat(a)[..., [1, 2, 3, 0]])  # scalar first, not last
    np.testing.assert_allclose(Q.to_matrix(q), V_of(a), atol=5e-15, rtol=0)  # |a| <= 10


@settings(deadline=None)
@given(big_angle, big_angle, big_angle)
def test_to_quaternion_is_product_of_axis_quaternions(phi, theta, psi):
    def qz(t):
        return np.array([np.cos(t / 2), 0.0, 0.0, np.sin(t / 2)])

    def qx(t):
        return np.array([np.cos(t / 2), np.sin(t / 2), 0.0, 0.0])

    expected = Q.multiply(Q.multiply(qz(phi), qx(theta)), qz(psi))
    # the half-angle sums (phi +- psi)/2 round to ~eps |phi|: scale the tolerance
    atol = 1e-15 + 2 * EPS * (abs(phi) + abs(psi))
    np.testing.assert_allclose(E.to_quaternion([phi, theta, psi]), expected, atol=atol, rtol=0)


# --- from_quaternion / from_matrix --------------------------------------------------


def _check_canonical_ranges(a):
    assert np.all((a[..., 1] >= 0.0) & (a[..., 1] <= PI))
    assert np.all((a[..., 0] > -PI) & (a[..., 0] <= PI))
    assert np.all((a[..., 2] > -PI) & (a[..., 2] <= PI))


@settings(max_examples=200, deadline=None)
@given(canonical_angles())
def test_round_trip_angles_quaternion_angles(a):
    q = E.to_quaternion(a)
    b = E.from_quaternion(q)
    _check_canonical_ranges(b)
    np.testing.assert_allclose(V_of(b), Q.to_matrix(q), atol=1.5e-15, rtol=0)
    np.testing.assert_array_equal(E.from_quaternion(-q), b)  # q ~ -q, bit for bit
    # the angles themselves, where phi and psi are defined: their condition number is
    # 1 / sin(theta/2) for phi - psi and 1 / cos(theta/2) for phi + psi
    s, c = np.sin(a[1] / 2), np.cos(a[1] / 2)
    if min(s, c) > 1e-6:
        tol = 2e-15 * (1 / s + 1 / c)
        assert ang_diff(b[0], a[0]) <= tol
        assert ang_diff(b[2], a[2]) <= tol
        assert abs(b[1] - a[1]) <= 2e-15


@settings(max_examples=200, deadline=None)
@given(canonical_angles())
def test_round_trip_angles_matrix_angles(a):
    V = V_of(a)
    b, mask = E.from_matrix(V, return_mask=True)
    _check_canonical_ranges(b)
    np.testing.assert_allclose(V_of(b), V, atol=2e-15, rtol=0)
    s, c = np.sin(a[1] / 2), np.cos(a[1] / 2)
    if min(s, c) > 1e-6:
        assert not mask
        tol = 4e-15 * (1 / s + 1 / c)
        assert ang_diff(b[0], a[0]) <= tol
        assert ang_diff(b[2], a[2]) <= tol
        assert abs(b[1] - a[1]) <= 4e-15


@settings(max_examples=300, deadline=None)
@given(gimbal_angles())
def test_round_trip_at_and_next_to_gimbal_lock(a):
    q = E.to_quaternion(a)
    b, mask = E.from_quaternion(q, return_mask=True)
    _check_canonical_ranges(b)
    np.testing.assert_allclose(V_of(b), Q.to_matrix(q), rtol=0, atol=1e-15)
    np.testing.assert_array_equal(E.from_quaternion(-q), b)
    # through the matrix (Shepperd) as well
    V = V_of(a)
    np.testing.assert_allclose(V_of(E.from_matrix(V)), V, rtol=0, atol=1.5e-15)
    # the defined combination is recovered
    if mask and b[1] == 0.0:
        assert ang_diff(b[0], a[0] + a[2]) <= 1e-15
    elif mask:
        assert ang_diff(b[0], a[0] - a[2]) <= 1e-15


@settings(max_examples=300, deadline=None)
@given(st.sampled_from([0.0, 1e-300, 1e-17, 1e-16, 2.2e-16, 2.3e-16, 4e-16, 1e-15, 1e-9]),
       angle, angle, st.booleans())
def test_quaternions_straddling_the_split_threshold(r, sigma, delta, near_pi):
    """Raw unit quaternions with |(x, y)| (or |(w, z)|) = r on both sides of SPLIT_TOL."""
    c = np.sqrt(1.0 - r * r)
    if near_pi:
        r, c = c, r
    q = np.array([c * np.cos(sigma), r * np.cos(delta), r * np.sin(delta), c * np.sin(sigma)])
    b, mask = E.from_quaternion(q, return_mask=True)
    np.testing.assert_allclose(V_of(b), Q.to_matrix(q), rtol=0, atol=1e-15)
    assert mask == (min(r, c) <= E.SPLIT_TOL)


def test_gimbal_lock_convention_psi_zero():
    phi = np.array([0.3, -2.0, 3.0, 1.0])
    psi = np.array([0.4, 1.5, 0.5, -1.0])
    # theta = 0: only phi + psi is defined
    a0 = np.stack([phi, np.zeros(4), psi], axis=-1)
    b0, m0 = E.from_quaternion(E.to_quaternion(a0), return_mask=True)
    assert m0.all()
    np.testing.assert_array_equal(b0[:, 1], 0.0)
    np.testing.assert_array_equal(b0[:, 2], 0.0)
    np.testing.assert_allclose(ang_diff(b0[:, 0], phi + psi), 0.0, atol=1e-15, rtol=0)
    assert abs(b0[2, 0] - (3.5 - 2 * PI)) < 1e-15  # wrapped into (-pi, pi]
    # theta = pi: only phi - psi is defined
    api = np.stack([phi, np.full(4, PI), psi], axis=-1)
    bpi, mpi = E.from_matrix(V_of(api), return_mask=True)
    assert mpi.all()
    np.testing.assert_array_equal(bpi[:, 1], PI)
    np.testing.assert_array_equal(bpi[:, 2], 0.0)
    np.testing.assert_allclose(ang_diff(bpi[:, 0], phi - psi), 0.0, atol=1e-15, rtol=0)
    # next to gimbal lock the split is kept
    b, m = E.from_quaternion(E.to_quaternion([0.3, 1e-8, 0.4]), return_mask=True)
    assert not m
    np.testing.assert_allclose(b, [0.3, 1e-8, 0.4], rtol=1e-7)


def test_minus_pi_is_mapped_to_plus_pi():
    # z rotation by pi: atan2(-0.0, -1) = -pi internally
    for q in ([0.0, 0.0, 0.0, 1.0], [0.0, 0.0, 0.0, -1.0]):
        np.testing.assert_array_equal(E.from_quaternion(q), [PI, 0.0, 0.0])
    # general branch with signed zeros making atan2 return -pi
    a = PI / 3
    b = E.from_quaternion([np.cos(a), -np.sin(a), -0.0, 0.0])
    _check_canonical_ranges(b)
    assert b[0] == PI and b[2] == PI
    assert E.from_quaternion(E.to_quaternion([-PI, 1.0, -PI]))[0] > 0


def test_from_quaternion_random_rotations_and_shapes():
    q = Q.random((20, 30), rng=3)
    a = E.from_quaternion(q)
    assert a.shape == (20, 30, 3)
    _check_canonical_ranges(a)
    np.testing.assert_allclose(V_of(a), Q.to_matrix(q), atol=2e-15, rtol=0)
    np.testing.assert_allclose(E.from_matrix(Q.to_matrix(q)), a, atol=1e-13, rtol=0)
    assert E.from_quaternion([1, 0, 0, 0]).shape == (3,)
    assert E.from_quaternion(np.zeros((0, 4))).shape == (0, 3)
    _, mask = E.from_quaternion(q, return_mask=True)
    assert mask.shape == (20, 30) and not mask.any()


# --- gimbal_lock mask ----------------------------------------------------------------


def test_gimbal_lock_mask():
    thetas = np.array([0.0, 1e-13, 1e-8, PI / 2, PI - 1e-13, PI])
    a = np.stack([np.ones(6), thetas, np.ones(6)], axis=-1)
    np.testing.assert_array_equal(E.gimbal_lock(a), [1, 1, 0, 0, 1, 1])
    np.testing.assert_array_equal(E.gimbal_lock(a, tol=1e-7), [1, 1, 1, 0, 1, 1])
    np.testing.assert_array_equal(E.gimbal_lock(a, tol=0.0), [1, 0, 0, 0, 0, 0])
    assert E.gimbal_lock([0.0, 0.0, 0.0]) and not E.gimbal_lock([0.0, 1.0, 0.0])
    assert E.gimbal_lock(a.reshape(2, 3, 3)).shape == (2, 3)


# --- rotation angle and axis -----------------------------------------------------------


@settings(max_examples=200, deadline=None)
@given(st.one_of(canonical_angles(), gimbal_angles(),
                 st.builds(lambda *x: np.array(x), big_angle, big_angle, big_angle)))
def test_rotation_angle_trace_relation_and_axis(a):
    Phi = E.rotation_angle(a)
    assert 0.0 <= Phi <= PI
    V = V_of(a)
    # V uses sin/cos of each angle, the quaternion route the sum phi + psi: for large
    # angles the two differ by the rounding ~eps |phi| of that sum
    atol = 1e-14 + 4 * EPS * np.abs(a).sum()
    np.testing.assert_allclose(1 + 2 * np.cos(Phi), np.trace(V), atol=atol, rtol=0)
    # cos(Phi/2) = cos((phi+psi)/2) cos(theta/2), up to the Phi <-> 2pi - Phi choice
    np.testing.assert_allclose(np.cos(Phi / 2),
                               abs(np.cos((a[0] + a[2]) / 2) * np.cos(a[1] / 2)),
                               atol=1e-14, rtol=0)
    axis = E.rotation_axis(a)
    np.testing.assert_allclose(np.linalg.norm(axis), 1.0, atol=1e-15, rtol=0)
    np.testing.assert_allclose(V @ axis, axis, atol=atol, rtol=0)  # eigenvalue 1
    # right-handed rotation by Phi about axis
    np.testing.assert_allclose(Rotation.from_rotvec(Phi * axis).as_matrix(), V, atol=atol, rtol=0)


def test_rotation_angle_vs_scipy_magnitude_and_small_angles():
    rng = np.random.default_rng(2)
    a = rng.uniform(-10, 10, size=(1000, 3))
    np.testing.assert_allclose(E.rotation_angle(a), Rotation.from_euler("ZXZ", a).magnitude(),
                               atol=1e-14, rtol=0)
    assert E.rotation_angle(a).shape == (1000,)
    # accurate to relative round-off for tiny rotations (acos of the trace is not)
    for small in (1e-9, 1e-200):
        assert E.rotation_angle([small, 0.0, 0.0]) == pytest.approx(small, rel=1e-15)
        assert E.rotation_angle([0.0, small, 0.0]) == pytest.approx(small, rel=1e-15)
        np.testing.assert_allclose(E.rotation_axis([0.0, small, 0.0]), [1, 0, 0], atol=1e-15,
                                   rtol=0)
        np.testing.assert_allclose(E.rotation_axis([0.0, -small, 0.0]), [-1, 0, 0], atol=1e-15,
                                   rtol=0)
    # Phi > pi by the trace relation comes back as 2 pi - Phi about the opposite axis
    assert E.rotation_angle([1.5 * PI, 0.0, 0.0]) == pytest.approx(0.5 * PI, rel=1e-15)
    np.testing.assert_allclose(E.rotation_axis([1.5 * PI, 0.0, 0.0]), [0, 0, -1], atol=1e-15,
                               rtol=0)
    assert E.rotation_angle([PI, 0.0, 0.0]) == pytest.approx(PI, rel=1e-15)
    # identity: the documented default axis
    assert E.rotation_angle([0.0, 0.0, 0.0]) == 0.0
    np.testing.assert_array_equal(E.rotation_axis([0.0, 0.0, 0.0]), [0.0, 0.0, 1.0])
    np.testing.assert_array_equal(E.rotation_axis([[0.5, 0.0, -0.5], [0, 0, 0]])[1], [0, 0, 1])


# --- angular velocity ------------------------------------------------------------------


def Rz(a):
    return np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])


def Rx(a):
    return np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])


def dRz(a):
    return np.array([[-np.sin(a), -np.cos(a), 0], [np.cos(a), -np.sin(a), 0], [0, 0, 0]])


def dRx(a):
    return np.array([[0, 0, 0], [0, -np.sin(a), -np.cos(a)], [0, np.cos(a), -np.sin(a)]])


def vee(A):
    return np.array([A[2, 1], A[0, 2], A[1, 0]])


@settings(max_examples=200, deadline=None)
@given(big_angle, big_angle, big_angle, rate, rate, rate)
def test_omega_against_exact_derivative_of_V(phi, theta, psi, phid, thetad, psid):
    V = Rz(phi) @ Rx(theta) @ Rz(psi)
    dV = (phid * dRz(phi) @ Rx(theta) @ Rz(psi) + thetad * Rz(phi) @ dRx(theta) @ Rz(psi)
          + psid * Rz(phi) @ Rx(theta) @ dRz(psi))
    a, r = [phi, theta, psi], [phid, thetad, psid]
    A_body = V.T @ dV
    A_space = dV @ V.T
    np.testing.assert_allclose(A_body, -A_body.T, atol=1e-13, rtol=0)
    wb, ws = E.omega_body(a, r), E.omega_space(a, r)
    np.testing.assert_allclose(wb, vee(A_body), atol=1e-13, rtol=0)
    np.testing.assert_allclose(ws, vee(A_space), atol=1e-13, rtol=0)
    np.testing.assert_allclose(ws, E.matrix(phi, theta, psi) @ wb, atol=1e-13, rtol=0)


def test_omega_body_against_finite_differences_of_matrix():
    """4th-order central differences of V(t) along a smooth angle history."""
    def angles(t):
        return np.stack([0.3 + 1.1 * t + 0.2 * t**2, 1.0 + 0.4 * np.sin(t), -0.5 + 2.0 * t],
                        axis=-1)

    def angle_rates(t):
        return np.stack([1.1 + 0.4 * t, 0.4 * np.cos(t), np.full_like(t, 2.0)], axis=-1)

    t = np.linspace(-2.0, 2.0, 9)
    h = 1e-3
    dV = (8 * (V_of(angles(t + h)) - V_of(angles(t - h)))
          - (V_of(angles(t + 2 * h)) - V_of(angles(t - 2 * h)))) / (12 * h)
    V = V_of(angles(t))
    A = np.swapaxes(V, -1, -2) @ dV
    w_fd = np.stack([A[:, 2, 1], A[:, 0, 2], A[:, 1, 0]], axis=-1)
    np.testing.assert_allclose(E.omega_body(angles(t), angle_rates(t)), w_fd, atol=1e-9, rtol=0)
    B = dV @ np.swapaxes(V, -1, -2)
    w_fd_space = np.stack([B[:, 2, 1], B[:, 0, 2], B[:, 1, 0]], axis=-1)
    np.testing.assert_allclose(E.omega_space(angles(t), angle_rates(t)), w_fd_space, atol=1e-9,
                               rtol=0)


def test_omega_broadcasting():
    a = np.random.default_rng(4).uniform(-3, 3, size=(7, 3))
    r = [0.1, -0.2, 0.3]
    wb = E.omega_body(a, r)
    assert wb.shape == (7, 3)
    np.testing.assert_allclose(wb[3], E.omega_body(a[3], r), atol=0, rtol=0)
    assert E.omega_space(a[None], np.ones((2, 1, 3))).shape == (2, 7, 3)


@settings(max_examples=200, deadline=None)
@given(canonical_angles(theta=st.floats(1e-3, PI - 1e-3)), rate, rate, rate)
def test_rates_inverts_omega_body(a, phid, thetad, psid):
    r = np.array([phid, thetad, psid])
    w = E.omega_body(a, r)
    cond = 1.0 / np.sin(a[1])
    np.testing.assert_allclose(E.rates(a, w), r, atol=1e-13 * cond, rtol=0)
    np.testing.assert_allclose(E.omega_body(a, E.rates(a, w)), w, atol=1e-13, rtol=0)


def test_rates_raises_at_gimbal_lock():
    a = np.array([[0.1, 0.5, 0.2], [0.1, 0.0, 0.2], [0.3, 1.0, 0.1], [0.1, PI, 0.2]])
    w = np.array([0.1, 0.2, 0.3])
    with pytest.raises(ValueError, match=r"angles.*gimbal lock.*2 sample.*\(1,\).*\(3,\)"):
        E.rates(a, w)
    with pytest.raises(ValueError, match="single sample"):
        E.rates([0.0, 0.0, 0.0], w)
    with pytest.raises(ValueError, match="gimbal lock"):
        E.rates([0.0, 1e-8, 0.0], w, tol=1e-6)
    E.rates([0.0, 1e-8, 0.0], w)  # fine at the default tolerance
    with pytest.raises(ValueError, match="gimbal lock"):  # sin(theta) = 0 exactly
        E.rates([0.0, 0.0, 0.0], w, tol=0.0)
    r = E.rates(a, w, singular="nan")
    assert np.isnan(r[[1, 3]][:, [0, 2]]).all()
    assert np.isfinite(r[[0, 2]]).all() and np.isfinite(r[:, 1]).all()
    np.testing.assert_allclose(r[0], E.rates(a[0], w), atol=0, rtol=0)
    # thetadot is still w1 cos psi - w2 sin psi at the singular samples
    np.testing.assert_allclose(r[1, 1], 0.1 * np.cos(0.2) - 0.2 * np.sin(0.2), atol=1e-16, rtol=0)


# --- unwrap ------------------------------------------------------------------------------


def test_unwrap_long_history():
    t = np.arange(0.0, 1000.0, 0.05)
    truth = np.stack([0.3 * t, 1.0 + 0.5 * np.sin(0.01 * t), 0.7 - 2.1 * t], axis=-1)
    wrapped = E.from_quaternion(E.to_quaternion(truth))
    _check_canonical_ranges(wrapped)
    assert np.abs(np.diff(wrapped[:, 0])).max() > 6.0  # there are jumps to remove
    un = E.unwrap(wrapped)
    np.testing.assert_allclose(un, truth, rtol=0, atol=1e-10)
    assert np.abs(np.diff(un[:, [0, 2]], axis=0)).max() < 0.2
    np.testing.assert_array_equal(un[:, 1], wrapped[:, 1])  # theta untouched
    # batch of histories with time along another axis
    two = np.stack([wrapped, wrapped[::-1]])  # (2, n, 3)
    for ax in (1, -2):
        u2 = E.unwrap(two, axis=ax)
        np.testing.assert_allclose(u2[0], truth, atol=1e-10, rtol=0)
        assert np.abs(np.diff(u2[1][:, [0, 2]], axis=0)).max() < 0.2
    np.testing.assert_array_equal(E.unwrap(np.swapaxes(two, 0, 1), axis=0)[:, 0], un)


# --- validation --------------------------------------------------------------------------

NAN3 = [0.0, np.nan, 0.0]
GOOD3 = [0.1, 0.2, 0.3]

CASES = [
    (E.matrix, (np.nan, 0.0, 0.0), {}, ValueError, "phi"),
    (E.matrix, (0.0, np.inf, 0.0), {}, ValueError, "theta"),
    (E.matrix, (0.0, 0.0, "a"), {}, TypeError, "psi"),
    (E.matrix, (0.0, 1j, 0.0), {}, TypeError, "theta"),
    (E.matrix, (np.zeros(2), 0.0, np.zeros(3)), {}, ValueError, "phi, theta and psi"),
    (E.to_quaternion, ([0.0, 1.0],), {}, ValueError, "angles"),
    (E.to_quaternion, (NAN3,), {}, ValueError, "angles"),
    (E.to_quaternion, (0.5,), {}, ValueError, "angles"),
    (E.to_quaternion, ([1j, 0, 0],), {}, TypeError, "angles"),
    (E.from_quaternion, ([1.0, 0.0, 0.0],), {}, ValueError, "q"),
    (E.from_quaternion, ([2.0, 0.0, 0.0, 0.0],), {}, ValueError, "unit quaternion"),
    (E.from_quaternion, ([np.nan, 0.0, 0.0, 0.0],), {}, ValueError, "q must be finite"),
    (E.from_matrix, (np.eye(2),), {}, ValueError, "V must have shape"),
    (E.from_matrix, (np.eye(3).ravel(),), {}, ValueError, "V must have shape"),
    (E.from_matrix, (2 * np.eye(3),), {}, ValueError, "V must be a proper rotation"),
    (E.from_matrix, (np.diag([1.0, 1.0, -1.0]),), {}, ValueError, "V must be a proper rotation"),
    (E.from_matrix, (np.full((3, 3), np.nan),), {}, ValueError, "V must be finite"),
    (E.from_matrix, (np.eye(3),), {"tol": -1.0}, ValueError, "tol"),
    (E.gimbal_lock, ([0.0, 0.0],), {}, ValueError, "angles"),
    (E.gimbal_lock, (GOOD3,), {"tol": -1e-3}, ValueError, "tol"),
    (E.gimbal_lock, (GOOD3,), {"tol": "x"}, TypeError, "tol"),
    (E.rotation_angle, (NAN3,), {}, ValueError, "angles"),
    (E.rotation_angle, ([[0.0, 0.0, 0.0, 0.0]],), {}, ValueError, "angles"),
    (E.rotation_axis, (NAN3,), {}, ValueError, "angles"),
    (E.omega_body, (GOOD3, [1.0, 2.0]), {}, ValueError, "rates"),
    (E.omega_body, ([0.0, 0.0], GOOD3), {}, ValueError, "angles"),
    (E.omega_body, (GOOD3, NAN3), {}, ValueError, "rates"),
    (E.omega_body, (np.zeros((2, 3)), np.zeros((3, 3))), {}, ValueError, "angles.*rates"),
    (E.omega_space, (NAN3, GOOD3), {}, ValueError, "angles"),
    (E.omega_space, (GOOD3, [[1.0, 2.0]]), {}, ValueError, "rates"),
    (E.rates, (GOOD3, [1.0, 2.0]), {}, ValueError, "omega_body"),
    (E.rates, (NAN3, GOOD3), {}, ValueError, "angles"),
    (E.rates, (GOOD3, GOOD3), {"singular": "bogus"}, ValueError, "singular"),
    (E.rates, (GOOD3, GOOD3), {"tol": np.nan}, ValueError, "tol"),
    (E.rates, (np.zeros((2, 3)), np.zeros((3, 3))), {}, ValueError, "angles.*omega_body"),
    (E.unwrap, (GOOD3,), {}, ValueError, "angles must have shape"),
    (E.unwrap, ([NAN3, GOOD3],), {}, ValueError, "angles"),
    (E.unwrap, ([GOOD3, GOOD3],), {"axis": -1}, ValueError, "axis"),
    (E.unwrap, ([GOOD3, GOOD3],), {"axis": 2}, ValueError, "axis"),
    (E.unwrap, ([GOOD3, GOOD3],), {"axis": 0.5}, TypeError, "axis"),
]


@pytest.mark.parametrize(("func", "args", "kwargs", "exc", "match"), CASES,
                         ids=[f"{c[0].__name__}-{i}" for i, c in enumerate(CASES)])
def test_validation_errors_name_the_argument(func, args, kwargs, exc, match):
    with pytest.raises(exc, match=match):
        func(*args, **kwargs)


def test_python_scalars_and_lists_accepted():
    assert E.to_quaternion([0, 1, 0]).shape == (4,)
    assert E.from_quaternion([1, 0, 0, 0]).dtype == np.float64
    assert np.ndim(E.rotation_angle((0.1, 0.2, 0.3))) == 0
    assert E.rotation_axis([[0.1, 0.2, 0.3]]).shape == (1, 3)
    assert E.omega_body([0, 1, 0], [1, 0, 0]).dtype == np.float64
    assert E.rates([0, 1, 0], [1, 0, 0]).shape == (3,)
    assert E.from_matrix(np.eye(3).tolist()).shape == (3,)
    assert E.unwrap([[0, 1, 0], [3, 1, -3]]).shape == (2, 3)


def test_rotation_angle_accepts_the_texts_three_arguments():
    phi, theta, psi = np.array([0.3, -2.0]), 1.1, np.array([0.7, 2.9])
    stacked = np.stack(np.broadcast_arrays(phi, theta, psi), axis=-1)
    np.testing.assert_array_equal(E.rotation_angle(phi, theta, psi), E.rotation_angle(stacked))
    np.testing.assert_array_equal(E.rotation_axis(phi, theta, psi), E.rotation_axis(stacked))
    # the trace relation in the form cos(Phi/2) = cos((phi + psi)/2) cos(theta/2)
    Phi = E.rotation_angle(0.3, 1.1, 0.7)
    assert abs(abs(np.cos(Phi / 2)) - abs(np.cos((0.3 + 0.7) / 2) * np.cos(1.1 / 2))) < 1e-15
    with pytest.raises(TypeError, match="all three of phi, theta, psi"):
        E.rotation_angle(0.3, 1.1)
