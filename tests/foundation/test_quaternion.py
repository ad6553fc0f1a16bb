"""liebody.quaternion against scipy's Rotation (scalar-last) and algebraic identities.

Marked ``kernel``: CI runs this module a second time with ``NUMBA_DISABLE_JIT=1``
so the numba kernels are also checked as plain Python.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.linalg import expm
from scipy.spatial.transform import Rotation

from liebody import quaternion as Q

pytestmark = pytest.mark.kernel

finite = st.floats(-1e3, 1e3, allow_nan=False, allow_infinity=False)
vec3 = arrays(np.float64, 3, elements=finite)
quat4 = arrays(np.float64, 4, elements=st.floats(-10, 10)).filter(
    lambda q: np.linalg.norm(q) > 1e-3)


def unit(q):
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def hat(v):
    return np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])


def same_rotation(p, q, atol=1e-14):
    """q and -q are the same rotation."""
    d = np.minimum(np.abs(p - q).max(axis=-1), np.abs(p + q).max(axis=-1))
    return np.all(d <= atol)


@pytest.fixture
def qs():
    return Q.random(200, rng=12345)


def test_scipy_order_conversion_round_trip(qs):
    xyzw = Q.to_scipy(qs)
    np.testing.assert_array_equal(xyzw[:, 3], qs[:, 0])
    np.testing.assert_array_equal(xyzw[:, :3], qs[:, 1:])
    np.testing.assert_array_equal(Q.from_scipy(xyzw), qs)
    # and scipy agrees on the rotation these numbers mean
    np.testing.assert_allclose(Rotation.from_quat(xyzw).as_matrix(), Q.to_matrix(qs),
                               atol=1e-15, rtol=0)
    assert same_rotation(Q.from_rotation(Q.to_rotation(qs)), qs)


def test_rotate_matches_scipy_and_matrix(qs):
    v = np.random.default_rng(1).normal(size=(200, 3))
    expected = Rotation.from_quat(Q.to_scipy(qs)).apply(v)
    np.testing.assert_allclose(Q.rotate(qs, v), expected, atol=1e-14, rtol=0)
    np.testing.assert_allclose(np.einsum("nij,nj->ni", Q.to_matrix(qs), v), expected,
                               atol=1e-14, rtol=0)


def test_rotate_inverse_matches_transpose_and_scipy(qs):
    """rotate_inverse(q, v) = R(q)^T v, the inverse rotation (space to body)."""
    v = np.random.default_rng(10).normal(size=(200, 3))
    back = Q.rotate_inverse(qs, v)
    expected = Rotation.from_quat(Q.to_scipy(qs)).inv().apply(v)
    np.testing.assert_allclose(back, expected, atol=1e-14, rtol=0)
    np.testing.assert_allclose(back, np.einsum("nji,nj->ni", Q.to_matrix(qs), v),
                               atol=1e-14, rtol=0)
    np.testing.assert_allclose(Q.rotate_inverse(qs, Q.rotate(qs, v)), v, atol=1e-14, rtol=0)
    # the space vertical seen from the body is the third row of R(q)
    np.testing.assert_allclose(Q.rotate_inverse(qs, [0.0, 0.0, 1.0]), Q.to_matrix(qs)[:, 2, :],
                               atol=1e-15, rtol=0)
    # q and -q are the same rotation
    np.testing.assert_array_equal(Q.rotate_inverse(-qs, v), back)


def test_rotate_inverse_broadcasts_and_rejects_non_unit_q():
    q = Q.random((2, 3), rng=11)
    assert Q.rotate_inverse(q, [1.0, 0.0, 0.0]).shape == (2, 3, 3)
    assert Q.rotate_inverse(q[0, 0], np.ones((5, 3))).shape == (5, 3)
    v = np.random.default_rng(12).normal(size=(4, 1, 3))
    out = Q.rotate_inverse(q[0], v)  # batch (3,) against (4, 1): (4, 3)
    assert out.shape == (4, 3, 3)
    R = Q.to_matrix(q[0])
    np.testing.assert_allclose(out, np.einsum("bji,abj->abi", R, np.broadcast_to(v, (4, 3, 3))),
                               atol=1e-14, rtol=0)
    assert Q.rotate_inverse(Q.IDENTITY, [1.0, 2.0, 3.0]).tolist() == [1.0, 2.0, 3.0]
    with pytest.raises(ValueError, match=r"q must be a unit quaternion.*normalize"):
        Q.rotate_inverse([1.0, 1e-4, 0.0, 0.0], [1.0, 0.0, 0.0])
    with pytest.raises(ValueError, match=r"q must be a unit quaternion"):
        Q.rotate_inverse(2.0 * q, [1.0, 0.0, 0.0])
    with pytest.raises(ValueError, match=r"v must have shape"):
        Q.rotate_inverse(Q.IDENTITY, [1.0, 0.0])


def test_rotate_is_conjugation_by_product(qs):
    v = np.random.default_rng(2).normal(size=(200, 3))
    pure = np.concatenate([np.zeros((200, 1)), v], axis=1)
    conj = Q.multiply(Q.multiply(qs, pure), Q.conjugate(qs))
    np.testing.assert_allclose(conj[:, 0], 0.0, atol=1e-14, rtol=0)
    np.testing.assert_allclose(conj[:, 1:], Q.rotate(qs, v), atol=1e-14, rtol=0)


def test_product_composes_rotations_and_matches_scipy(qs):
    p, q = qs[:100], qs[100:]
    pq = Q.multiply(p, q)
    np.testing.assert_allclose(Q.to_matrix(pq), Q.to_matrix(p) @ Q.to_matrix(q), atol=1e-14, rtol=0)
    scipy_pq = Rotation.from_quat(Q.to_scipy(p)) * Rotation.from_quat(Q.to_scipy(q))
    assert same_rotation(Q.from_rotation(scipy_pq), pq)


def test_hamilton_basis_relations():
    one, i, j, k = np.eye(4)
    np.testing.assert_array_equal(Q.multiply(i, j), k)
    np.testing.assert_array_equal(Q.multiply(j, k), i)
    np.testing.assert_array_equal(Q.multiply(k, i), j)
    np.testing.assert_array_equal(Q.multiply(j, i), -k)
    for u in (i, j, k):
        np.testing.assert_array_equal(Q.multiply(u, u), -one)


@given(quat4, quat4, quat4)
def test_product_is_associative_and_norm_multiplicative(a, b, c):
    np.testing.assert_allclose(Q.multiply(Q.multiply(a, b), c), Q.multiply(a, Q.multiply(b, c)),
                               rtol=1e-12, atol=1e-10)
    np.testing.assert_allclose(np.linalg.norm(Q.multiply(a, b)),
                               np.linalg.norm(a) * np.linalg.norm(b), rtol=1e-13)
    np.testing.assert_allclose(Q.multiply(a, Q.inverse(a)), [1, 0, 0, 0], atol=1e-13, rtol=0)
    np.testing.assert_allclose(Q.conjugate(Q.multiply(a, b)),
                               Q.multiply(Q.conjugate(b), Q.conjugate(a)), rtol=1e-12, atol=1e-10)


def test_broadcasting_shapes():
    q = Q.random((2, 3), rng=0)
    assert Q.multiply(q, Q.IDENTITY).shape == (2, 3, 4)
    np.testing.assert_array_equal(Q.multiply(q, Q.IDENTITY), q)
    assert Q.rotate(q, [1.0, 0.0, 0.0]).shape == (2, 3, 3)
    assert Q.rotate(q[0, 0], np.ones((5, 3))).shape == (5, 3)
    assert Q.to_matrix(q).shape == (2, 3, 3, 3)
    assert Q.from_matrix(Q.to_matrix(q)).shape == (2, 3, 4)
    assert Q.exp(np.zeros((4, 1, 3))).shape == (4, 1, 4)
    assert Q.log(q).shape == (2, 3, 3)
    assert Q.slerp(q[0, 0], q[1, 0], np.linspace(0, 1, 7)).shape == (7, 4)
    assert Q.random(rng=1).shape == (4,)
    assert Q.multiply(np.empty((0, 4)), Q.IDENTITY).shape == (0, 4)


def test_from_matrix_round_trip_all_regions():
    """Shepperd's branches: angles near 0 and near pi about every axis."""
    rng = np.random.default_rng(3)
    axes = unit(rng.normal(size=(60, 3)))
    axes[:3] = np.eye(3)
    for angle in (0.0, 1e-12, 1e-6, 0.5, 2.0, np.pi - 1e-6, np.pi - 1e-12, np.pi):
        q = Q.exp(angle * axes)
        back = Q.from_matrix(Q.to_matrix(q))
        assert np.all(back[:, 0] >= 0.0)
        assert same_rotation(back, q, atol=2e-15 * 4)
        ref = Rotation.from_matrix(Q.to_matrix(q)).as_matrix()
        np.testing.assert_allclose(Q.to_matrix(back), ref, atol=1e-15 * 4, rtol=0)


def test_exp_matches_matrix_exponential_and_scipy():
    rng = np.random.default_rng(4)
    r = rng.normal(size=(50, 3)) * rng.uniform(0, 3, size=(50, 1))
    q = Q.exp(r)
    for ri, qi in zip(r, q, strict=True):
        # scipy's expm (scaling and squaring) is itself good to ~1e-14 at these angles
        np.testing.assert_allclose(Q.to_matrix(qi), expm(hat(ri)), atol=5e-14, rtol=0)
    assert same_rotation(Q.from_rotation(Rotation.from_rotvec(r)), q)


@pytest.mark.parametrize("a", [0.0, 1e-300, 1e-20, 1e-10, 1e-5, 9.99e-4, 1e-3, 1.0001e-3])
def test_exp_log_accurate_near_zero(a):
    """Series branch and trig branch agree to round-off at and across the switch."""
    n = unit(np.array([0.3, -0.5, 0.8]))
    q = Q.exp(a * n)
    expected = np.concatenate([[np.cos(a / 2)], np.sin(a / 2) * n])  # direct at these sizes
    np.testing.assert_allclose(q, expected, rtol=1e-15, atol=1e-300)
    np.testing.assert_allclose(Q.log(q), a * n, rtol=1e-14, atol=1e-300)


@given(vec3)
def test_log_inverts_exp_on_principal_branch(r):
    angle = np.linalg.norm(r)
    q = Q.exp(r)
    assert abs(np.linalg.norm(q) - 1.0) < 1e-15
    back = Q.log(q)
    # rotation vectors with angle > pi come back as the equivalent short rotation
    assert np.linalg.norm(back) <= np.pi + 1e-15
    np.testing.assert_allclose(Q.to_matrix(Q.exp(back)), Q.to_matrix(q), atol=1e-13, rtol=0)
    if angle < np.pi - 1e-6:
        np.testing.assert_allclose(back, r, rtol=1e-12, atol=1e-15)


def test_log_is_sign_invariant(qs):
    np.testing.assert_allclose(Q.log(qs), Q.log(-qs), atol=0, rtol=0)


def test_normalize_extreme_scales():
    q = np.array([[3e200, 4e200, 0, 0], [3e-200, 0, 4e-200, 0], [0.5, 0.5, 0.5, 0.5]])
    n = Q.normalize(q)
    np.testing.assert_allclose(n, [[0.6, 0.8, 0, 0], [0.6, 0, 0.8, 0], [0.5] * 4], rtol=1e-15)
    assert np.all(Q.is_unit(n, tol=1e-15))
    with pytest.raises(ValueError, match="q must be non-zero"):
        Q.normalize([0.0, 0.0, 0.0, 0.0])


def test_slerp_endpoints_constant_speed_and_scipy():
    from scipy.spatial.transform import Slerp

    q0, q1 = Q.random(2, rng=7)
    t = np.linspace(0.0, 1.0, 11)
    path = Q.slerp(q0, q1, t)
    assert same_rotation(path[0], q0) and same_rotation(path[-1], q1)
    steps = Q.angle_between(path[:-1], path[1:])
    np.testing.assert_allclose(steps, steps[0], rtol=1e-12)
    np.testing.assert_allclose(steps.sum(), Q.angle_between(q0, q1), rtol=1e-12)
    ref = Slerp([0.0, 1.0], Rotation.from_quat(Q.to_scipy(np.stack([q0, q1]))))(t)
    assert same_rotation(Q.from_rotation(ref), path, atol=1e-13)


def test_slerp_nearly_identical_quaternions_is_accurate():
    """No 0/0 for a 1e-12 rad arc: the midpoint is half-way to round-off (absolute)."""
    q0 = Q.random(rng=8)
    q1 = Q.multiply(q0, Q.exp([1e-12, 0, 0]))
    rel = Q.log(Q.multiply(Q.conjugate(q0), q1))  # the arc as actually represented
    mid = Q.slerp(q0, q1, 0.5)
    np.testing.assert_allclose(Q.log(Q.multiply(Q.conjugate(q0), mid)), 0.5 * rel, atol=3e-16,
                               rtol=0)
    assert np.all(np.isfinite(mid))


def test_random_is_seeded_and_uniform():
    a = Q.random(20000, rng=np.random.default_rng(5))
    b = Q.random(20000, rng=5)
    np.testing.assert_array_equal(a, b)
    assert np.all(a[:, 0] >= 0) and np.all(Q.is_unit(a, tol=1e-14))
    # Haar measure: the rotation angle has density (1 - cos x)/pi on [0, pi]; E[cos x] = -1/2
    # and E[R] = 0 (each matrix entry averages to zero). 6-sigma bounds for n = 20000.
    angles = 2 * np.arccos(np.clip(a[:, 0], -1, 1))
    assert abs(np.mean(np.cos(angles)) + 0.5) < 6 * 0.56 / np.sqrt(20000)
    assert np.abs(Q.to_matrix(a).mean(axis=0)).max() < 6 * 0.58 / np.sqrt(20000)


@pytest.mark.parametrize("size, shape", [(0, (0, 4)), (3, (3, 4)), (np.int64(2), (2, 4)),
                                         ((2, 3), (2, 3, 4)), ((), (4,)), (None, (4,))])
def test_random_shapes(size, shape):
    q = Q.random(size, rng=1)
    assert q.shape == shape and np.all(Q.is_unit(q, tol=1e-14))


@pytest.mark.parametrize("size, exc", [(-1, ValueError), ((2, -1), ValueError),
                                       (2.5, TypeError), (2.0, TypeError), (True, TypeError),
                                       ("3", TypeError), ((2, 1.5), TypeError)])
def test_random_refuses_a_bad_size_naming_it(size, exc):
    with pytest.raises(exc, match=r"^size must be .*(integer|non-negative)"):
        Q.random(size, rng=1)


@pytest.mark.parametrize("rng, exc, match", [
    ("abc", TypeError, r"^rng must be a numpy.random.Generator.*got str"),
    (1.5, TypeError, r"^rng must be a numpy.random.Generator.*got float"),
    (True, TypeError, r"^rng must be a numpy.random.Generator.*got bool"),
    (-1, ValueError, r"^rng: an integer seed must be >= 0, got -1"),
])
def test_random_refuses_a_bad_rng_naming_it(rng, exc, match):
    with pytest.raises(exc, match=match):
        Q.random(2, rng=rng)


def test_random_takes_what_default_rng_takes():
    ref = Q.random(3, rng=np.random.default_rng(np.random.SeedSequence(4)))
    np.testing.assert_array_equal(Q.random(3, rng=np.random.SeedSequence(4)), ref)
    np.testing.assert_array_equal(Q.random(3, rng=np.random.PCG64(np.random.SeedSequence(4))),
                                  ref)


def test_from_scipy_refuses_non_unit_quaternions():
    with pytest.raises(ValueError, match=r"q_xyzw must be scipy's scalar-last unit quaternions"
                                         r".*tolerance 1\.0e-10"):
        Q.from_scipy([1.0, 2.0, 3.0, 4.0])
    with pytest.raises(ValueError, match=r"q_xyzw"):
        Q.from_scipy([[0.0, 0.0, 0.0, 1.0], [0.0, 0.0, 0.0, 1.0 + 1e-9]])
    # within the tolerance: accepted, and only reordered (scipy normalises silently)
    xyzw = np.array([0.0, 0.6, 0.0, 0.8 * (1 + 1e-12)])
    np.testing.assert_array_equal(Q.from_scipy(xyzw), xyzw[[3, 0, 1, 2]])
    r = Rotation.from_quat([1.0, 2.0, 3.0, 4.0])  # the documented way for raw numbers
    np.testing.assert_allclose(Q.to_matrix(Q.from_rotation(r)), r.as_matrix(), atol=1e-15)


def test_angle_between_sign_invariant():
    q = Q.random(10, rng=9)
    r = Q.exp(np.array([0.0, 0.0, 0.7]))
    np.testing.assert_allclose(Q.angle_between(q, Q.multiply(q, r)), 0.7, rtol=1e-14)
    np.testing.assert_allclose(Q.angle_between(q, -q), 0.0, atol=1e-15, rtol=0)


# ----------------------------------------------------------------------------- validation


def test_non_unit_quaternion_is_rejected_with_advice():
    with pytest.raises(ValueError, match=r"q must be a unit quaternion.*normalize"):
        Q.rotate([1.0, 1e-4, 0.0, 0.0], [1.0, 0.0, 0.0])  # |q| - 1 = 5e-9
    # within 1e-10 is accepted
    Q.rotate([1.0 + 5e-11, 0.0, 0.0, 0.0], [1.0, 0.0, 0.0])


@pytest.mark.parametrize(
    ("call", "exc", "match"),
    [
        (lambda: Q.multiply([1, 0, 0], [1, 0, 0, 0]), ValueError,
         r"p must have shape \(\.\.\., 4\)"),
        (lambda: Q.multiply([1, 0, 0, np.nan], [1, 0, 0, 0]), ValueError, "p must be finite"),
        (lambda: Q.rotate([1, 0, 0, 0], [1, 0]), ValueError, r"v must have shape"),
        (lambda: Q.exp([1j, 0, 0]), TypeError, "rotvec must contain real numbers"),
        (lambda: Q.exp(["a", "b", "c"]), TypeError, "rotvec must contain real numbers"),
        (lambda: Q.from_matrix(np.eye(2)), ValueError, r"matrix must have shape"),
        (lambda: Q.from_matrix(np.diag([1.0, 1.0, -1.0])), ValueError, "proper rotation"),
        (lambda: Q.from_matrix(2 * np.eye(3)), ValueError, "proper rotation"),
        (lambda: Q.slerp([1, 0, 0, 0], [1, 0, 0, 0], np.inf), ValueError, "t must be finite"),
        (lambda: Q.inverse([0, 0, 0, 0]), ValueError, "non-zero"),
    ],
)
def test_validation_errors(call, exc, match):
    with pytest.raises(exc, match=match):
        call()


@settings(max_examples=50)
@given(arrays(np.float64, (3, 4), elements=st.floats(-5, 5)).filter(
    lambda q: np.all(np.linalg.norm(q, axis=-1) > 1e-2)))
def test_to_matrix_is_proper_rotation(q):
    R = Q.to_matrix(Q.normalize(q))
    np.testing.assert_allclose(np.swapaxes(R, -1, -2) @ R, np.broadcast_to(np.eye(3), R.shape),
                               atol=1e-14, rtol=0)
    np.testing.assert_allclose(np.linalg.det(R), 1.0, atol=1e-14, rtol=0)


def test_unit_increment_removes_the_norm_defect_without_turning():
    """qunit_increment: |e|^2 - 1 (computed exactly with fractions) drops far below eps
    for rotations of a recurring angle, and the rotation angle moves by < 1e-13 rad."""
    from fractions import Fraction

    from liebody._kernels.quat import qexp, qunit_increment

    rng = np.random.default_rng(3)
    before, after = [], []
    for _ in range(200):
        r = rng.normal(size=3)
        r *= 0.07 / np.linalg.norm(r)  # the same angle every time, as in a free-body run
        e = qexp(*r)
        f = qunit_increment(*e)
        before.append(abs(float(sum(Fraction(c) ** 2 for c in e) - 1)))
        after.append(abs(float(sum(Fraction(c) ** 2 for c in f) - 1)))
        assert Q.angle_between(np.array(e), np.array(f)) < 1e-13
    assert np.mean(after) < 0.05 * np.mean(before)
    assert max(after) < 1e-17
    tiny = qexp(1e-4, 0.0, 0.0)  # small rotations are left alone
    assert qunit_increment(*tiny) == tiny


def test_exp_refuses_angles_whose_square_overflows():
    """Before: NaN returned silently above |r| = 1.34e154."""
    with pytest.raises(ValueError, match=r"rotvec: a rotation angle \|r\| above 1e\+150"):
        Q.exp([1.35e154, 0.0, 0.0])
    with pytest.raises(ValueError, match="rotvec"):
        Q.exp([[0.1, 0.0, 0.0], [0.0, -2e150, 0.0]])
    assert np.isfinite(Q.exp([1e149, 0.0, 0.0])).all()
