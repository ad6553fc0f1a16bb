"""liebody.attitude against scipy, the elementary rotations and the LVLH definition.

References: scipy's ``Rotation.from_euler('ZYX', [yaw, pitch, roll])`` and
``as_euler('ZYX')`` (scalar-last quaternions, converted explicitly), the elementary
rotation matrices Rx, Ry, Rz written out here, and the definition of the LVLH axes
(nadir, negative orbit normal, x = y x z) evaluated with numpy on liebody.orbits
positions.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from liebody import attitude as A
from liebody import quaternion as Q
from liebody.orbits import Circular, Kepler

PI = np.pi
EPS = np.finfo(float).eps


def _scipy_quat(angles):
    """scipy's quaternion of (roll, pitch, yaw), scalar first."""
    a = np.asarray(angles, dtype=float)
    xyzw = Rotation.from_euler("ZYX", a[..., ::-1].reshape(-1, 3)).as_quat()
    return np.concatenate([xyzw[:, 3:], xyzw[:, :3]], axis=-1).reshape(a.shape[:-1] + (4,))


def _scipy_rpy(q):
    """scipy's ZYX angles of scalar-first q, reordered to (roll, pitch, yaw)."""
    q = np.asarray(q, dtype=float)
    xyzw = np.concatenate([q[..., 1:], q[..., :1]], axis=-1).reshape(-1, 4)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # scipy's gimbal-lock warning
        ypr = Rotation.from_quat(xyzw).as_euler("ZYX")
    return ypr[:, ::-1].reshape(q.shape[:-1] + (3,))


def _rx(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def _ry(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def _rz(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def _ang_diff(a, b):
    return np.abs(np.angle(np.exp(1j * (np.asarray(a) - np.asarray(b)))))


def _random_angles(rng, size, big=False):
    if big:
        return rng.uniform(-50.0, 50.0, (size, 3))
    return np.column_stack([rng.uniform(-PI, PI, size), rng.uniform(-PI / 2, PI / 2, size),
                            rng.uniform(-PI, PI, size)])


# ------------------------------------------------------------------------------------------
# roll-pitch-yaw angles
# ------------------------------------------------------------------------------------------


def test_matrix_is_the_product_of_the_elementary_rotations_and_scipys():
    rng = np.random.default_rng(1)
    a = _random_angles(rng, 50, big=True)
    M = A.rpy_matrix(a)
    for k in range(len(a)):
        roll, pitch, yaw = a[k]
        np.testing.assert_allclose(M[k], _rz(yaw) @ _ry(pitch) @ _rx(roll), atol=4 * EPS)
    np.testing.assert_allclose(M, Rotation.from_euler("ZYX", a[:, ::-1]).as_matrix(),
                               atol=4 * EPS)
    # body -> reference: the body x axis (nose) after a pure yaw points at (cos, sin, 0)
    np.testing.assert_allclose(A.rpy_matrix([0.0, 0.0, 0.3]) @ [1, 0, 0],
                               [math.cos(0.3), math.sin(0.3), 0.0], atol=EPS)


@pytest.mark.parametrize("big", [False, True])
def test_quaternion_matches_scipy(big):
    rng = np.random.default_rng(2)
    a = _random_angles(rng, 2000, big=big)
    q = A.rpy_to_quaternion(a)
    ref = _scipy_quat(a)
    # q and -q are one rotation: compare up to the sign
    sign = np.sign(np.sum(q * ref, axis=-1))[:, None]
    np.testing.assert_allclose(q, sign * ref, atol=4 * EPS * (50 if big else 1))
    np.testing.assert_allclose(np.linalg.norm(q, axis=-1), 1.0, atol=4 * EPS)
    np.testing.assert_allclose(Q.to_matrix(q), A.rpy_matrix(a), atol=1e-14 * (50 if big else 1))


def test_angles_match_scipy_and_round_trip():
    rng = np.random.default_rng(3)
    a = _random_angles(rng, 5000)
    q = Q.random(5000, rng=rng)
    for qq in (q, -q, A.rpy_to_quaternion(a)):
        ours = A.quaternion_to_rpy(qq)
        ref = _scipy_rpy(qq)
        away = np.abs(np.cos(ref[:, 1])) > 1e-6  # off gimbal lock, the split is defined
        assert np.all(_ang_diff(ours[away], ref[away]) < 1e-12)
        # the rotation is reproduced everywhere
        assert np.all(Q.angle_between(A.rpy_to_quaternion(ours), qq) < 4e-15 * 4)
        # ranges: roll, yaw in (-pi, pi], pitch in [-pi/2, pi/2]
        assert np.all((ours[:, [0, 2]] > -PI) & (ours[:, [0, 2]] <= PI))
        assert np.all(np.abs(ours[:, 1]) <= PI / 2)
    back = A.quaternion_to_rpy(A.rpy_to_quaternion(a))
    assert np.all(_ang_diff(back, a) < 1e-12)


@pytest.mark.parametrize("pitch", [PI / 2, -PI / 2])
def test_gimbal_lock_convention(pitch):
    rng = np.random.default_rng(4)
    for _ in range(50):
        roll, yaw = rng.uniform(-PI, PI, 2)
        q = A.rpy_to_quaternion([roll, pitch, yaw])
        ang, mask = A.quaternion_to_rpy(q, return_mask=True)
        assert mask and np.all(np.isfinite(ang))
        assert ang[0] == 0.0 and ang[1] == pitch  # roll = 0, pitch exactly +-pi/2
        # yaw carries yaw - roll (pitch = pi/2) or yaw + roll (pitch = -pi/2)
        combo = yaw - roll if pitch > 0 else yaw + roll
        assert _ang_diff(ang[2], combo) < 1e-14
        assert _ang_diff(ang[2], _scipy_rpy(q)[2]) < 1e-12  # scipy: its third angle zero
        assert Q.angle_between(A.rpy_to_quaternion(ang), q) < 1e-15 * 8
    # next to the lock (pitch off by 1e-9 .. 1e-15): finite, and the rotation kept
    for off in (1e-9, 1e-12, 1e-15, 3e-16):
        for roll, yaw in rng.uniform(-PI, PI, (20, 2)):
            q = A.rpy_to_quaternion([roll, pitch - math.copysign(off, pitch), yaw])
            ang = A.quaternion_to_rpy(q)
            assert np.all(np.isfinite(ang)) and abs(ang[1]) <= PI / 2
            assert Q.angle_between(A.rpy_to_quaternion(ang), q) < 1e-14


def test_broadcast_shapes_and_scalars():
    rng = np.random.default_rng(5)
    a = _random_angles(rng, 24).reshape(2, 3, 4, 3)
    q = A.rpy_to_quaternion(a)
    assert q.shape == (2, 3, 4, 4) and A.rpy_matrix(a).shape == (2, 3, 4, 3, 3)
    assert A.quaternion_to_rpy(q).shape == (2, 3, 4, 3)
    ang, mask = A.quaternion_to_rpy(q, return_mask=True)
    assert mask.shape == (2, 3, 4) and not mask.any()
    np.testing.assert_array_equal(ang, A.quaternion_to_rpy(q))
    np.testing.assert_allclose(A.rpy_to_quaternion([0, 0, 0]), [1, 0, 0, 0])
    assert A.rpy_to_quaternion([1, 2, 3]).dtype == np.float64  # integers accepted


def test_rpy_bad_input():
    with pytest.raises(ValueError, match=r"angles must have shape \(\.\.\., 3\)"):
        A.rpy_to_quaternion([0.1, 0.2])
    with pytest.raises(ValueError, match="angles must be finite"):
        A.rpy_to_quaternion([0.1, np.nan, 0.2])
    with pytest.raises(ValueError, match="angles must be finite"):
        A.rpy_matrix([[0.1, 0.2, np.inf]])
    with pytest.raises(TypeError, match="angles must contain real numbers"):
        A.rpy_to_quaternion(["a", "b", "c"])
    with pytest.raises(ValueError, match="q must be a unit quaternion"):
        A.quaternion_to_rpy([1.0, 1.0, 0.0, 0.0])
    with pytest.raises(ValueError, match=r"q must have shape \(\.\.\., 4\)"):
        A.quaternion_to_rpy([1.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="q must be finite"):
        A.quaternion_to_rpy([np.nan, 0.0, 0.0, 0.0])


# ------------------------------------------------------------------------------------------
# the LVLH frame
# ------------------------------------------------------------------------------------------


def _lvlh_ref(r, v):
    """The definition, one vector pair at a time."""
    z = -r / np.linalg.norm(r)
    h = np.cross(r, v)
    y = -h / np.linalg.norm(h)
    return np.column_stack([np.cross(y, z), y, z])


def test_lvlh_axes_follow_the_definition():
    rng = np.random.default_rng(6)
    r = rng.normal(size=(200, 3)) * 7000.0
    v = rng.normal(size=(200, 3)) * 7.5
    M = A.lvlh_axes(r, v)
    for k in range(len(r)):
        np.testing.assert_allclose(M[k], _lvlh_ref(r[k], v[k]), atol=4 * EPS)
    # a proper rotation; the axes: z towards the centre, y against r x v, x ahead
    np.testing.assert_allclose(np.swapaxes(M, -1, -2) @ M, np.broadcast_to(np.eye(3), M.shape),
                               atol=4 * EPS)
    np.testing.assert_allclose(np.linalg.det(M), 1.0, atol=4 * EPS)
    assert np.all(np.einsum("ki,ki->k", M[:, :, 2], r) < 0)
    assert np.all(np.einsum("ki,ki->k", M[:, :, 1], np.cross(r, v)) < 0)
    assert np.all(np.einsum("ki,ki->k", M[:, :, 0], v) > 0)
    # the quaternion rotates LVLH to inertial coordinates
    q = A.lvlh_quaternion(r, v)
    np.testing.assert_allclose(Q.to_matrix(q), M, atol=1e-15 * 8)


def test_lvlh_on_orbits():
    """On a circular orbit x is the velocity direction; on an inclined Kepler orbit y is
    minus the orbit's normal (liebody.orbits) all along. Velocities by central
    differences of the positions."""
    o = Circular(0.3, radius=2.0, inclination=0.7, raan=-0.4)
    t = np.linspace(0.0, 30.0, 97)
    d = 1e-6
    r = o.position(t)
    v = (o.position(t + d) - o.position(t - d)) / (2 * d)
    M = A.lvlh_axes(r, v)
    np.testing.assert_allclose(M[..., 0], v / np.linalg.norm(v, axis=-1, keepdims=True),
                               atol=1e-9)
    k = Kepler(3.0, 0.6, 2.0, i=1.1, raan=0.3, argp=2.0)
    r = k.position(t)
    v = (k.position(t + d) - k.position(t - d)) / (2 * d)
    M = A.lvlh_axes(r, v)
    np.testing.assert_allclose(M[..., 1], np.broadcast_to(-k.normal, r.shape), atol=1e-9)
    np.testing.assert_allclose(M[..., 2], -r / np.linalg.norm(r, axis=-1, keepdims=True),
                               atol=4 * EPS)
    # huge and tiny scales: no overflow or underflow in r x v
    np.testing.assert_allclose(A.lvlh_axes(r[:3] * 1e300, v[:3] * 1e300), M[:3], atol=4 * EPS)
    np.testing.assert_allclose(A.lvlh_axes(r[:3] * 1e-300, v[:3] * 1e-300), M[:3], atol=4 * EPS)


def test_attitude_in_lvlh():
    rng = np.random.default_rng(7)
    r = rng.normal(size=(100, 3))
    v = rng.normal(size=(100, 3))
    a = _random_angles(rng, 100)
    M = A.lvlh_axes(r, v)
    # a body turned by roll-pitch-yaw from the LVLH axes: body -> inertial = M R_rpy
    q_body = Q.from_matrix(M @ A.rpy_matrix(a))
    q_rel, ang = A.attitude_in_lvlh(q_body, r, v, rpy=True)
    np.testing.assert_allclose(Q.to_matrix(q_rel), A.rpy_matrix(a), atol=1e-14)
    assert np.all(_ang_diff(ang, a) < 1e-12)
    assert A.attitude_in_lvlh(q_body, r, v).shape == (100, 4)
    # resting in LVLH: the identity
    q_rel = A.attitude_in_lvlh(A.lvlh_quaternion(r, v), r, v)
    np.testing.assert_allclose(np.abs(q_rel[:, 0]), 1.0, atol=4 * EPS)
    # one body against many positions (broadcasting)
    q_rel = A.attitude_in_lvlh(Q.IDENTITY, r, v)
    np.testing.assert_allclose(Q.to_matrix(q_rel), np.swapaxes(M, -1, -2), atol=1e-14)


def test_lvlh_bad_input():
    with pytest.raises(ValueError, match="r and v must not be parallel"):
        A.lvlh_axes([1.0, 2.0, 3.0], [-2.0, -4.0, -6.0])
    with pytest.raises(ValueError, match="r and v must not be parallel"):
        A.lvlh_quaternion([[1.0, 0.0, 0.0], [1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0], [1e3, 1e-12, 0]])
    with pytest.raises(ValueError, match="r must be a nonzero vector"):
        A.lvlh_axes([0.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    with pytest.raises(ValueError, match="v must be a nonzero vector"):
        A.lvlh_axes([1.0, 0.0, 0.0], [0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="v must be finite"):
        A.lvlh_axes([1.0, 0.0, 0.0], [0.0, np.inf, 0.0])
    with pytest.raises(ValueError, match=r"r must have shape \(\.\.\., 3\)"):
        A.lvlh_axes([1.0, 0.0], [0.0, 1.0, 0.0])
    with pytest.raises(ValueError, match="must broadcast"):
        A.lvlh_axes(np.ones((2, 3)), np.eye(3))
    with pytest.raises(ValueError, match="q_body must be a unit quaternion"):
        A.attitude_in_lvlh([2.0, 0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    with pytest.raises(ValueError, match=r"q_body .* must broadcast"):
        A.attitude_in_lvlh(Q.random(3), np.eye(3)[:2], np.eye(3)[[1, 2]])
