"""Finite input near the ends of float64's range: the right value or a named ValueError.

Each result is compared with a reference in exact rational arithmetic
(:class:`fractions.Fraction`, rounded once by ``float``), or with a closed form
evaluated in ordinary units and rescaled by hand; never NaN or inf silently.
"""

from __future__ import annotations

import math
from fractions import Fraction as F

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from scipy.special import ellipk

from liebody import analysis, euler, inertia
from liebody import quaternion as Q

MAX = float(np.finfo(np.float64).max)


# ----------------------------------------------------------------------------------------
# quaternion.multiply and quaternion.slerp
# ----------------------------------------------------------------------------------------


def exact_product(p, q):
    """Hamilton product in rationals, rounded once (OverflowError beyond float64)."""
    pw, px, py, pz = (F(float(v)) for v in p)
    qw, qx, qy, qz = (F(float(v)) for v in q)
    return [float(v) for v in (pw * qw - px * qx - py * qy - pz * qz,
                               pw * qx + px * qw + py * qz - pz * qy,
                               pw * qy - px * qz + py * qw + pz * qx,
                               pw * qz + px * qy - py * qx + pz * qw)]


def test_multiply_gives_representable_products_whose_sums_overflow():
    rng = np.random.default_rng(21)
    p, q = rng.normal(size=(2, 64, 4))
    # scale each row so that the product's largest component is 0.99 of the float64 limit
    k = np.sqrt(0.99 * MAX) / np.sqrt(np.abs(Q.multiply(p, q)).max(axis=1, keepdims=True))
    p, q = p * k, q * k
    with np.errstate(over="ignore", invalid="ignore"):  # the plain sums overflow somewhere
        naive = np.stack([p[:, 0] * q[:, 0] - p[:, 1] * q[:, 1] - p[:, 2] * q[:, 2]
                          - p[:, 3] * q[:, 3]], axis=-1)
    assert not np.isfinite(naive).all()  # the case this test is about does occur
    got = Q.multiply(p, q)
    expected = np.array([exact_product(a, b) for a, b in zip(p, q, strict=True)])
    np.testing.assert_allclose(got, expected, rtol=0, atol=4e-16 * MAX)


def test_multiply_mixes_ordinary_and_rescaled_rows_and_keeps_the_batch_shape():
    big_p = [3e153, 9e153, 8e153, 5e153]
    big_q = [1.6e153, -1.9e153, 9e153, 1.2e154]
    p = np.array([[[1.0, 2.0, 3.0, 4.0], big_p]])
    q = np.array([[[0.5, -1.0, 0.25, 2.0], big_q]])
    try:
        expected = [exact_product(a, b) for a, b in zip(p[0], q[0], strict=True)]
    except OverflowError:  # pragma: no cover - the numbers above are representable
        pytest.fail("bad test data")
    got = Q.multiply(p, q)
    assert got.shape == (1, 2, 4)
    np.testing.assert_array_equal(got[0, 0], expected[0])
    np.testing.assert_allclose(got[0, 1], expected[1], rtol=1e-15, atol=1e-15 * MAX)


def test_multiply_refuses_a_product_beyond_float64():
    p, q = [1e200, 0.0, 0.0, 0.0], [1e200, 1.0, 0.0, 0.0]
    with pytest.raises(OverflowError):
        exact_product(p, q)  # the reference agrees that it is not a float64
    with pytest.raises(ValueError, match=r"p \* q overflows float64.*1\.8e\+308"):
        Q.multiply(p, q)


def test_slerp_refuses_a_rotation_beyond_the_exp_limit():
    a, b = Q.random(rng=1), Q.random(rng=2)
    with pytest.raises(ValueError, match=r"t: .*\|t\| \* angle\(q0, q1\).*MAX_ROTATION_ANGLE"):
        Q.slerp(a, b, 1e300)
    with pytest.raises(ValueError, match=r"^t: "):  # one bad row of a batch is enough
        Q.slerp(a, b, [0.5, -1e200])


def test_slerp_extrapolates_within_the_limit_like_scipy():
    a, b = Q.random(rng=3), Q.random(rng=4)
    t = 1e6
    ra, rb = Rotation.from_quat(Q.to_scipy(a)), Rotation.from_quat(Q.to_scipy(b))
    rel = (ra.inv() * rb).as_rotvec()  # angle in [0, pi]: the short arc
    expected = (ra * Rotation.from_rotvec(t * rel)).as_matrix()
    # the angle t |rel| ~ 1e6 is known to ~1e6 eps: compare the rotations to that
    np.testing.assert_allclose(Q.to_matrix(Q.slerp(a, b, t)), expected, atol=1e-8)


def test_slerp_over_a_zero_angle_takes_any_finite_t():
    # the rule bounds the rotation |t| angle, not t: over an angle of exactly 0 (q1 = q0 =
    # the identity, so q0* q1 has no round-off) any finite t stays at q0
    np.testing.assert_array_equal(Q.slerp(Q.IDENTITY, Q.IDENTITY, [1e300, -1e308]),
                                  [Q.IDENTITY, Q.IDENTITY])


# ----------------------------------------------------------------------------------------
# inertia
# ----------------------------------------------------------------------------------------


def exact_tensor(masses, positions, origin=None):
    m = [F(float(v)) for v in masses]
    p = [[F(float(v)) for v in row] for row in positions]
    if origin is None:
        total = sum(m)
        o = [sum(mi * pi[k] for mi, pi in zip(m, p, strict=True)) / total for k in range(3)]
    else:
        o = [F(float(v)) for v in origin]
    out = [[F(0)] * 3 for _ in range(3)]
    for mi, pi in zip(m, p, strict=True):
        r = [pi[k] - o[k] for k in range(3)]
        r2 = sum(v * v for v in r)
        for i in range(3):
            for j in range(3):
                out[i][j] += mi * ((r2 if i == j else 0) - r[i] * r[j])
    return np.array([[float(v) for v in row] for row in out])


@pytest.mark.parametrize("masses, positions", [
    ([1e300], [[1e10, 0.0, 0.0]]),                                  # one point: zero
    ([1e300, 1e300], [[1e10 + 1.0, 2.0, 0.0], [1e10 - 1.0, 0.0, 3.0]]),
    ([1e308, 1e308], [[0.5, 0.0, 0.0], [-0.5, 0.0, 0.0]]),          # sum of masses is inf
    ([1e-300, 2e-300, 3e-300], [[1e150, 0.0, 0.0], [0.0, 1e150, 0.0], [0.0, 0.0, 2e150]]),
])
def test_tensor_about_the_center_of_mass_without_overflow(masses, positions):
    got = inertia.tensor(masses, positions)
    expected = exact_tensor(masses, positions)
    np.testing.assert_allclose(got, expected, rtol=1e-14, atol=1e-14 * np.abs(expected).max())


def test_tensor_refuses_entries_beyond_float64():
    with pytest.raises(OverflowError):
        exact_tensor([1e300], [[1e10, 0.0, 0.0]], origin=[0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match=r"tensor: .*largest float64.*masses or the positions"):
        inertia.tensor([1e300], [[1e10, 0.0, 0.0]], origin=[0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match=r"tensor: .*positions - origin"):
        inertia.tensor([1.0], [[1e308, 0.0, 0.0]], origin=[-1e308, 0.0, 0.0])


@pytest.mark.parametrize("mass, a", [(1e-200, [1e160, 0.0, 0.0]),
                                     (1e-300, [1e150, 2e150, -3e150]),
                                     (1e300, [1e-5, 0.0, 1e-4])])
def test_parallel_axis_without_overflow(mass, a):
    I0 = np.diag([1.0, 2.0, 3.0])
    A = [F(v) for v in a]
    a2 = sum(v * v for v in A)
    expected = np.array([[float(F(I0[i, j]) + F(mass) * ((a2 if i == j else 0) - A[i] * A[j]))
                          for j in range(3)] for i in range(3)])
    got = inertia.parallel_axis(I0, mass, a)
    np.testing.assert_allclose(got, expected, rtol=1e-14, atol=1e-14 * np.abs(expected).max())


def test_parallel_axis_batched_and_refusing_overflow():
    I0 = np.zeros((2, 3, 3))
    got = inertia.parallel_axis(I0, [1e-200, 1.0], [[1e160, 0.0, 0.0], [0.0, 2.0, 0.0]])
    np.testing.assert_allclose(np.diagonal(got, axis1=-2, axis2=-1),
                               [[0.0, 1e120, 1e120], [4.0, 0.0, 4.0]], rtol=1e-15)
    with pytest.raises(ValueError, match=r"parallel_axis: .*largest float64.*mass or a"):
        inertia.parallel_axis(np.eye(3), 1.0, [1e200, 0.0, 0.0])


def _moments(c, M, *terms):
    """float(M * sum(c_j l_j^2)) for each moment, exactly; c, l as Fractions."""
    return [float(F(M) * sum(F(k) * F(length) ** 2 for k, length in moment))
            for moment in terms]


SOLIDS = [  # (function, args, closed form in rationals)
    (inertia.solid_sphere, (1e308, 1.0),
     lambda M, R: _moments(None, M, *[[(F(2, 5), R)]] * 3)),
    (inertia.solid_sphere, (1e-300, 1e250),
     lambda M, R: _moments(None, M, *[[(F(2, 5), R)]] * 3)),
    (inertia.hollow_sphere, (1e308, 1.0),
     lambda M, R: _moments(None, M, *[[(F(2, 3), R)]] * 3)),
    (inertia.thin_disk, (1e308, 1.5), lambda M, R: _moments(
        None, M, [(F(1, 4), R)], [(F(1, 4), R)], [(F(1, 2), R)])),
    (inertia.thin_ring, (1e-200, 1e200), lambda M, R: _moments(
        None, M, [(F(1, 2), R)], [(F(1, 2), R)], [(F(1), R)])),
    (inertia.thin_rod, (1e308, 3.0), lambda M, L: _moments(
        None, M, [(F(1, 12), L)], [(F(1, 12), L)], [(F(0), L)])),
    (inertia.box, (1e-100, 1e200, 0.0, 0.0), lambda M, a, b, c: _moments(
        None, M, [(F(1, 12), b), (F(1, 12), c)], [(F(1, 12), a), (F(1, 12), c)],
        [(F(1, 12), a), (F(1, 12), b)])),
    (inertia.box, (1e-300, 1e160, 2e160, 3e160), lambda M, a, b, c: _moments(
        None, M, [(F(1, 12), b), (F(1, 12), c)], [(F(1, 12), a), (F(1, 12), c)],
        [(F(1, 12), a), (F(1, 12), b)])),
    (inertia.ellipsoid, (1e-300, 1e160, 2e160, 3e160), lambda M, a, b, c: _moments(
        None, M, [(F(1, 5), b), (F(1, 5), c)], [(F(1, 5), a), (F(1, 5), c)],
        [(F(1, 5), a), (F(1, 5), b)])),
    (inertia.solid_cylinder, (1e-300, 1e160, 3e160), lambda M, R, h: _moments(
        None, M, [(F(1, 4), R), (F(1, 12), h)], [(F(1, 4), R), (F(1, 12), h)],
        [(F(1, 2), R)])),
    (inertia.solid_cone, (1e308, 1.0, 1.0), lambda M, R, h: _moments(
        None, M, [(F(3, 20), R), (F(3, 80), h)], [(F(3, 20), R), (F(3, 80), h)],
        [(F(3, 10), R)])),
]


@pytest.mark.parametrize("fn, args, exact", SOLIDS,
                         ids=[f"{fn.__name__}{args}" for fn, args, _ in SOLIDS])
def test_solids_near_the_ends_of_float64(fn, args, exact):
    np.testing.assert_allclose(fn(*args), exact(*args), rtol=4e-16, atol=0)


@pytest.mark.parametrize("fn, args", [(inertia.solid_sphere, (1e300, 1e10)),
                                      (inertia.box, (1.0, 1e200, 0.0, 0.0)),
                                      (inertia.solid_cone, (1e308, 10.0, 1.0))])
def test_solids_beyond_float64_raise_naming_the_solid(fn, args):
    with pytest.raises(ValueError, match=rf"^{fn.__name__}: .*largest float64.*mass"):
        fn(*args)


def test_composite_of_huge_masses():
    parts = [(1e300, [1e10 + 1.0, 0.0, 0.0]), (1e300, [1e10 - 1.0, 0.0, 0.0])]
    props = inertia.composite(parts)
    np.testing.assert_allclose(props.center_of_mass, [1e10, 0.0, 0.0], rtol=1e-15)
    expected = exact_tensor([1e300, 1e300], [p for _, p in parts])
    np.testing.assert_allclose(props.inertia, expected, rtol=1e-14, atol=1e-14 * 2e300)


# ----------------------------------------------------------------------------------------
# euler.to_quaternion
# ----------------------------------------------------------------------------------------


@pytest.mark.parametrize("angles", [[1e308, 0.5, 1e308], [-1.7e308, 2.0, -1.7e308],
                                    [1.7e308, 1.0, -1.7e308]])
def test_euler_to_quaternion_of_huge_angles(angles):
    q = euler.to_quaternion(angles)
    assert np.all(np.isfinite(q))
    phi, theta, psi = angles
    # qz(phi) qx(theta) qz(psi) multiplied out by hand from the half angles
    def qz(a):
        return np.array([math.cos(a / 2), 0.0, 0.0, math.sin(a / 2)])
    qx = np.array([math.cos(theta / 2), math.sin(theta / 2), 0.0, 0.0])
    expected = exact_product(exact_product(qz(phi), qx), qz(psi))
    d = min(np.abs(q - expected).max(), np.abs(q + expected).max())
    assert d <= 1e-15
    # and scipy agrees on the rotation
    np.testing.assert_allclose(Q.to_matrix(q),
                               Rotation.from_euler("ZXZ", angles).as_matrix(), atol=1e-14)


# ----------------------------------------------------------------------------------------
# analysis.precession_rate and analysis.flip_period
# ----------------------------------------------------------------------------------------


@pytest.mark.parametrize("I, I3, omega3", [(1e300, 1.0, 1e300), (1e-300, 1e300, 1e-300),
                                           (1e-300, 2e-300, -1e300), (2.0, 3.0, 1e308)])
def test_precession_rate_without_overflow(I, I3, omega3):
    expected = float(F(omega3) * (F(I3) - F(I)) / F(I))
    assert analysis.precession_rate(I, I3, omega3) == pytest.approx(expected, rel=4e-16)


def test_precession_rate_beyond_float64_raises():
    with pytest.raises(OverflowError):
        float(F(1e300) * (F(1e300) - F(1e-300)) / F(1e-300))
    with pytest.raises(ValueError, match=r"Omega = omega3 \(I3 - I\) / I .*largest float64"):
        analysis.precession_rate(1e-300, 1e300, 1e300)


def flip_period_reference(I, L):
    """Landau & Lifshitz §37 evaluated directly (moments sorted, ordinary magnitudes)."""
    I1, I2, I3 = I
    G2 = sum(v * v for v in L)
    E2 = sum(v * v / m for v, m in zip(L, I, strict=True))
    if G2 > E2 * I2:
        nu = math.sqrt((I3 - I2) * (G2 - E2 * I1) / (I1 * I2 * I3))
        k2 = (I2 - I1) * (E2 * I3 - G2) / ((I3 - I2) * (G2 - E2 * I1))
    else:
        nu = math.sqrt((I2 - I1) * (E2 * I3 - G2) / (I1 * I2 * I3))
        k2 = (I3 - I2) * (G2 - E2 * I1) / ((I2 - I1) * (E2 * I3 - G2))
    return 4.0 * ellipk(k2) / nu


@pytest.mark.parametrize("L", [[1.0, 2.0, 3.0], [3.0, 0.5, 0.2]])
@pytest.mark.parametrize("s_L, s_I", [(1e200, 1.0), (1e-200, 1.0), (1e300, 1e250),
                                      (1e-250, 1e-250), (1.0, 1e300)])
def test_flip_period_of_huge_and_tiny_L_and_moments(L, s_L, s_I):
    I = [1.0, 2.0, 3.0]
    # T_m(c I, s L) = (c / s) T_m(I, L): the reference in ordinary units, rescaled
    expected = flip_period_reference(I, L) * s_I / s_L
    got = analysis.flip_period([v * s_I for v in I], [v * s_L for v in L])
    assert got == pytest.approx(expected, rel=1e-13)


def test_flip_period_beyond_float64_raises():
    with pytest.raises(ValueError, match=r"T_m .*largest float64"):
        analysis.flip_period([1e300, 2e300, 3e300], [1e-300, 2e-300, 3e-300])
    with pytest.raises(ValueError, match=r"T_m underflows"):
        analysis.flip_period([1e-300, 2e-300, 3e-300], [1e300, 2e300, 3e300])


@pytest.mark.parametrize(("kw", "name"), [
    (dict(L0=[10**400, 0, 0]), "L0"), (dict(L0=(1.0, 2.0, -10**400)), "L0"),
    (dict(q0=[10**400, 0, 0, 0], L0=[1.0, 0.0, 0.0]), "q0"),
    (dict(omega0=(0, -10**400, 0)), "omega0")])
def test_an_integer_beyond_float64_is_refused_by_name(kw, name):
    """Python integers have no bound: one beyond float64's range is a ValueError naming the
    argument (before: a bare OverflowError from the conversion)."""
    import liebody

    scene = liebody.FreeBody(liebody.RigidBody([1.0, 2.0, 3.0]))
    with pytest.raises(ValueError, match=f"{name} holds an integer beyond float64's range"):
        liebody.integrate(scene, dt=0.1, steps=1, **kw)


def test_an_integer_beyond_int64_within_float64_is_a_number():
    """10**30 is beyond int64, so numpy keeps it as an object: it is still a float64."""
    import liebody

    scene = liebody.FreeBody(liebody.RigidBody([1.0, 2.0, 3.0]))
    a = liebody.integrate(scene, omega0=[np.float64(1.0), False, 10**30], dt=1e-32, steps=2,
                          method="rk4")
    b = liebody.integrate(scene, omega0=[1.0, 0.0, 1e30], dt=1e-32, steps=2, method="rk4")
    np.testing.assert_array_equal(a.L, b.L)
