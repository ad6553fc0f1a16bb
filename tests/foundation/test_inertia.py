"""Tests of liebody.inertia against hand computations, closed forms and quadrature."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy import integrate
from scipy.spatial.transform import Rotation

from liebody import inertia
from liebody.inertia import MassProperties, Part

HYP = settings(max_examples=40, deadline=None)

finite = st.floats(-5.0, 5.0, allow_nan=False, allow_infinity=False)
positive = st.floats(0.1, 10.0, allow_nan=False, allow_infinity=False)


@st.composite
def point_clouds(draw, min_n=1, max_n=8):
    n = draw(st.integers(min_n, max_n))
    m = draw(arrays(np.float64, (n,), elements=positive))
    p = draw(arrays(np.float64, (n, 3), elements=finite))
    return m, p


rotations = st.integers(0, 2**32 - 1).map(lambda s: Rotation.random(random_state=s))


def central_tensor_reference(points, weights):
    """Independent (loop-free but formula-level) reference: mass, CM, I about the CM."""
    M = weights.sum()
    com = (weights[:, None] * points).sum(axis=0) / M
    r = points - com
    I = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            I[i, j] = np.sum(weights * ((r * r).sum(axis=1) * (i == j) - r[:, i] * r[:, j]))
    return M, com, I


# ------------------------------------------------------------------------------------
# tensor
# ------------------------------------------------------------------------------------


def test_tensor_two_masses_on_x_axis_by_hand():
    I = inertia.tensor([1.0, 1.0], [[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0]])
    np.testing.assert_array_equal(I, np.diag([0.0, 2.0, 2.0]))


def test_tensor_three_masses_on_axes_about_origin_by_hand():
    I = inertia.tensor([1.0, 2.0, 3.0], np.eye(3), origin=[0.0, 0.0, 0.0])
    # I_xx = 2 + 3, I_yy = 1 + 3, I_zz = 1 + 2, no products of inertia
    np.testing.assert_array_equal(I, np.diag([5.0, 4.0, 3.0]))


def test_tensor_products_of_inertia_by_hand():
    m = [1.0, 2.0]
    p = [[1.0, 1.0, 0.0], [0.0, 1.0, 2.0]]
    about_origin = np.array([[11.0, -1.0, 0.0], [-1.0, 9.0, -4.0], [0.0, -4.0, 4.0]])
    np.testing.assert_allclose(inertia.tensor(m, p, origin=np.zeros(3)), about_origin, atol=1e-14,
                               rtol=0)
    # CM = (1/3, 1, 4/3); relative positions (2/3, 0, -4/3), (-1/3, 0, 2/3)
    about_cm = np.array([[8 / 3, 0.0, 4 / 3], [0.0, 10 / 3, 0.0], [4 / 3, 0.0, 2 / 3]])
    np.testing.assert_allclose(inertia.tensor(m, p), about_cm, atol=1e-14, rtol=0)


def test_tensor_dumbbell_of_section_1_4_1():
    m, l = 3.0, 2.0
    I = inertia.tensor([m, m], [[0.0, 0.0, -l / 2], [0.0, 0.0, l / 2]])
    np.testing.assert_array_equal(I, np.diag([m * l**2 / 2, m * l**2 / 2, 0.0]))


def test_tensor_zero_mass_points_are_ignored():
    p = [[1.0, 2.0, 3.0], [-1.0, 0.5, 2.0], [7.0, 7.0, 7.0]]
    with_zero = inertia.tensor([1.0, 2.0, 0.0], p)
    without = inertia.tensor([1.0, 2.0], p[:2])
    np.testing.assert_allclose(with_zero, without, rtol=1e-14, atol=1e-14)


@HYP
@given(point_clouds())
def test_tensor_matches_reference_and_is_symmetric(cloud):
    m, p = cloud
    _, _, ref = central_tensor_reference(p, m)
    I = inertia.tensor(m, p)
    np.testing.assert_array_equal(I, I.T)
    np.testing.assert_allclose(I, ref, rtol=1e-10, atol=1e-10 * np.abs(ref).max() + 1e-12)


@HYP
@given(point_clouds(), arrays(np.float64, (3,), elements=finite))
def test_tensor_about_origin_is_parallel_axis_of_central_tensor(cloud, origin):
    m, p = cloud
    com = m @ p / m.sum()
    about_origin = inertia.tensor(m, p, origin=origin)
    shifted = inertia.parallel_axis(inertia.tensor(m, p), m.sum(), com - origin)
    scale = np.abs(about_origin).max() + 1.0
    np.testing.assert_allclose(shifted, about_origin, atol=1e-11 * scale, rtol=0)


@HYP
@given(point_clouds(min_n=2), rotations)
def test_tensor_rotates_as_a_tensor_and_keeps_eigenvalues(cloud, rot):
    m, p = cloud
    Q = rot.as_matrix()
    I = inertia.tensor(m, p)
    I_rot = inertia.tensor(m, p @ Q.T)
    scale = np.abs(I).max() + 1.0
    np.testing.assert_allclose(I_rot, Q @ I @ Q.T, atol=1e-11 * scale, rtol=0)
    np.testing.assert_allclose(np.linalg.eigvalsh(I_rot), np.linalg.eigvalsh(I), atol=1e-11 * scale,
                               rtol=0)


@HYP
@given(point_clouds(), arrays(np.float64, (3,), elements=finite))
def test_central_tensor_is_translation_invariant(cloud, t):
    m, p = cloud
    I = inertia.tensor(m, p)
    scale = np.abs(I).max() + 1.0
    np.testing.assert_allclose(inertia.tensor(m, p + t), I, atol=1e-11 * scale, rtol=0)


@HYP
@given(point_clouds())
def test_point_mass_tensor_is_psd_and_satisfies_triangle_inequality(cloud):
    m, p = cloud
    lam = np.linalg.eigvalsh(inertia.tensor(m, p))
    tol = 1e-11 * (lam.max() + 1.0)
    assert lam[0] >= -tol
    assert lam[0] + lam[1] >= lam[2] - tol


@pytest.mark.parametrize(
    ("masses", "positions", "origin", "exc", "match"),
    [
        ([[1.0]], [[0.0, 0.0, 0.0]], None, ValueError, r"masses must have shape \(n,\)"),
        ([], np.zeros((0, 3)), None, ValueError, r"masses must have shape \(n,\) with n >= 1"),
        ([1.0, -1.0], np.eye(3)[:2], None, ValueError, "masses must be >= 0"),
        ([0.0, 0.0], np.eye(3)[:2], None, ValueError, "masses must have a positive total"),
        ([1.0, np.nan], np.eye(3)[:2], None, ValueError, "masses must be finite"),
        ([1.0, 2.0], np.eye(3), None, ValueError, r"positions must have shape \(n, 3\)"),
        ([1.0], [[0.0, 0.0]], None, ValueError, r"positions must have shape \(n, 3\)"),
        ([1.0], [[np.inf, 0.0, 0.0]], None, ValueError, "positions must be finite"),
        ([1.0], [[0.0, 0.0, 0.0]], [0.0, 0.0], ValueError, r"origin must have shape \(3,\)"),
        ([1.0 + 1j], [[0.0, 0.0, 0.0]], None, TypeError, "masses must contain real numbers"),
        (["a"], [[0.0, 0.0, 0.0]], None, TypeError, "masses must contain real numbers"),
    ],
)
def test_tensor_validation(masses, positions, origin, exc, match):
    with pytest.raises(exc, match=match):
        inertia.tensor(masses, positions, origin)


# ------------------------------------------------------------------------------------
# parallel axis theorem and its thin-disk example (Hand & Finch, ch. 8)
# ------------------------------------------------------------------------------------


def test_thin_disk_example_of_section_1_2_1_is_exact():
    M, R = 2.0, 3.0
    I_cm = inertia.moments_to_tensor(inertia.thin_disk(M, R))
    assert I_cm[2, 2] == M * R**2 / 2 == 9.0
    I_edge = inertia.parallel_axis(I_cm, M, [R, 0.0, 0.0])
    assert I_edge[2, 2] == 3 * M * R**2 / 2 == 27.0
    # in-plane: 4.5 about the diameter through the edge point, 4.5 + M R^2 across it
    np.testing.assert_array_equal(I_edge, np.diag([4.5, 22.5, 27.0]))


def test_parallel_axis_point_mass_by_hand():
    a = np.array([1.0, 2.0, 3.0])
    expected = 2.0 * np.array([[13.0, -2.0, -3.0], [-2.0, 10.0, -6.0], [-3.0, -6.0, 5.0]])
    np.testing.assert_array_equal(inertia.parallel_axis(np.zeros((3, 3)), 2.0, a), expected)


def test_parallel_axis_sign_of_a_is_irrelevant_and_zero_shift_is_identity():
    I_cm = inertia.moments_to_tensor(inertia.box(3.0, 1.0, 2.0, 3.0), Rotation.from_euler(
        "zyx", [0.3, -0.2, 1.1]).as_matrix())
    a = np.array([0.5, -1.5, 2.0])
    np.testing.assert_array_equal(
        inertia.parallel_axis(I_cm, 3.0, a), inertia.parallel_axis(I_cm, 3.0, -a)
    )
    np.testing.assert_allclose(inertia.parallel_axis(I_cm, 3.0, np.zeros(3)), I_cm, rtol=0,
                               atol=1e-15)


def test_parallel_axis_is_vectorised():
    rng = np.random.default_rng(0)
    I_cm = np.array([inertia.moments_to_tensor(inertia.box(1.0, *rng.uniform(0.5, 2.0, 3)),
                                               Rotation.random(random_state=k).as_matrix())
                     for k in range(5)])
    masses = rng.uniform(0.5, 3.0, 5)
    a = rng.normal(size=(5, 3))
    batch = inertia.parallel_axis(I_cm, masses, a)
    assert batch.shape == (5, 3, 3)
    for k in range(5):
        np.testing.assert_allclose(batch[k], inertia.parallel_axis(I_cm[k], masses[k], a[k]),
                                   rtol=1e-15, atol=1e-15)
    # one tensor, many displacements
    many = inertia.parallel_axis(I_cm[0], masses[0], a)
    assert many.shape == (5, 3, 3)
    np.testing.assert_allclose(many[3], inertia.parallel_axis(I_cm[0], masses[0], a[3]))


@pytest.mark.parametrize(
    ("I_cm", "mass", "a", "exc", "match"),
    [
        (np.eye(3) + np.triu(np.ones((3, 3)), 1), 1.0, np.zeros(3), ValueError,
         "I_cm must be a symmetric tensor"),
        (np.eye(2), 1.0, np.zeros(3), ValueError, r"I_cm must have shape \(\.\.\., 3, 3\)"),
        (np.eye(3), 0.0, np.zeros(3), ValueError, "mass must be > 0"),
        (np.eye(3), -1.0, np.zeros(3), ValueError, "mass must be > 0"),
        (np.eye(3), np.nan, np.zeros(3), ValueError, "mass must be finite"),
        (np.eye(3), 1.0, np.zeros(2), ValueError, r"a must have shape \(\.\.\., 3\)"),
        (np.full((3, 3), np.nan), 1.0, np.zeros(3), ValueError, "I_cm must be finite"),
    ],
)
def test_parallel_axis_validation(I_cm, mass, a, exc, match):
    with pytest.raises(exc, match=match):
        inertia.parallel_axis(I_cm, mass, a)


# ------------------------------------------------------------------------------------
# rotations
# ------------------------------------------------------------------------------------


@HYP
@given(rotations, arrays(np.float64, (3,), elements=positive))
def test_moments_to_tensor_with_matrix_and_quaternion(rot, moments):
    Q = rot.as_matrix()
    q = rot.as_quat(scalar_first=True)
    expected = Q @ np.diag(moments) @ Q.T
    np.testing.assert_allclose(inertia.moments_to_tensor(moments, Q), expected, atol=1e-13 * 10,
                               rtol=0)
    np.testing.assert_allclose(inertia.moments_to_tensor(moments, q), expected, atol=1e-13 * 10,
                               rtol=0)
    np.testing.assert_allclose(inertia.rotate_tensor(np.diag(moments), q), expected,
                               atol=1e-13 * 10, rtol=0)


def test_moments_to_tensor_default_is_diagonal():
    np.testing.assert_array_equal(inertia.moments_to_tensor([1.0, 2.0, 3.0]),
                                  np.diag([1.0, 2.0, 3.0]))


def test_quaternion_convention_rotates_body_to_space():
    # 90 degrees about z: (w, x, y, z) = (cos 45, 0, 0, sin 45) maps x -> y
    q = [np.sqrt(0.5), 0.0, 0.0, np.sqrt(0.5)]
    I = inertia.rotate_tensor(np.diag([1.0, 2.0, 3.0]), q)
    np.testing.assert_allclose(I, np.diag([2.0, 1.0, 3.0]), atol=1e-15, rtol=0)


@pytest.mark.parametrize(
    ("orientation", "match"),
    [
        (np.diag([1.0, 1.0, -1.0]), r"orientation must be a proper rotation \(det R = \+1\)"),
        (np.diag([1.0, 1.0, 1.1]), "orientation must be a rotation matrix"),
        ([1.0, 0.0, 0.0, 0.1], "orientation must be a unit quaternion"),
        (np.eye(2), r"orientation must be a \(3, 3\) rotation matrix or a unit quaternion"),
    ],
)
def test_rotation_validation(orientation, match):
    with pytest.raises(ValueError, match=match):
        inertia.rotate_tensor(np.eye(3), orientation)


# ------------------------------------------------------------------------------------
# standard solids: closed forms
# ------------------------------------------------------------------------------------

SOLIDS = {
    "thin_disk": (inertia.thin_disk, (2.0, 3.0), [4.5, 4.5, 9.0]),
    "thin_ring": (inertia.thin_ring, (2.0, 3.0), [9.0, 9.0, 18.0]),
    "thin_rod": (inertia.thin_rod, (3.0, 2.0), [1.0, 1.0, 0.0]),
    "solid_sphere": (inertia.solid_sphere, (5.0, 2.0), [8.0, 8.0, 8.0]),
    "hollow_sphere": (inertia.hollow_sphere, (3.0, 2.0), [8.0, 8.0, 8.0]),
    "box": (inertia.box, (12.0, 1.0, 2.0, 3.0), [13.0, 10.0, 5.0]),
    "solid_cylinder": (inertia.solid_cylinder, (4.0, 1.0, 3.0), [4.0, 4.0, 2.0]),
    # 3/80 * 80 * (4 + 16) = 60 ; 3/10 * 80 * 1 = 24
    "solid_cone": (inertia.solid_cone, (80.0, 1.0, 4.0), [60.0, 60.0, 24.0]),
    "ellipsoid": (inertia.ellipsoid, (5.0, 1.0, 2.0, 3.0), [13.0, 10.0, 5.0]),
}


@pytest.mark.parametrize("name", sorted(SOLIDS))
def test_solid_closed_form_exact(name):
    func, args, expected = SOLIDS[name]
    out = func(*args)
    assert out.shape == (3,)
    assert out.dtype == np.float64
    np.testing.assert_array_equal(out, expected)


def test_solids_with_symmetry_axis_have_it_along_z():
    for out in (inertia.thin_disk(1.3, 0.7), inertia.thin_ring(1.3, 0.7),
                inertia.thin_rod(1.3, 0.7), inertia.solid_cylinder(1.3, 0.7, 2.1),
                inertia.solid_cone(1.3, 0.7, 2.1)):
        assert out[0] == out[1]
        assert out[2] != out[0]


def test_planar_bodies_satisfy_perpendicular_axis_rule():
    d = inertia.thin_disk(1.7, 0.9)
    assert d[2] == d[0] + d[1]
    plate = inertia.box(1.7, 0.9, 1.3, 0.0)
    np.testing.assert_allclose(plate, 1.7 * np.array([1.3**2, 0.9**2, 0.9**2 + 1.3**2]) / 12,
                               rtol=1e-15)
    assert plate[2] == pytest.approx(plate[0] + plate[1], rel=1e-15)


def test_cone_about_apex_matches_textbook_closed_form():
    M, R, h = 2.5, 0.8, 1.7
    I_cm = inertia.moments_to_tensor(inertia.solid_cone(M, R, h))
    # the apex is 3h/4 above the CM along z
    I_apex = inertia.parallel_axis(I_cm, M, [0.0, 0.0, 3 * h / 4])
    transverse = 3 * M * (R**2 / 4 + h**2) / 5
    np.testing.assert_allclose(np.diag(I_apex), [transverse, transverse, 3 * M * R**2 / 10],
                               rtol=1e-14)


# ------------------------------------------------------------------------------------
# standard solids: numerical integration (Gauss-Legendre product rules, exact for
# polynomials, spectrally accurate in the angles) and scipy.integrate
# ------------------------------------------------------------------------------------


def _gl(n, lo, hi):
    x, w = np.polynomial.legendre.leggauss(n)
    return 0.5 * (hi - lo) * x + 0.5 * (hi + lo), 0.5 * (hi - lo) * w


def _grid(*rules):
    nodes = np.meshgrid(*[r[0] for r in rules], indexing="ij")
    weights = np.meshgrid(*[r[1] for r in rules], indexing="ij")
    return [n.ravel() for n in nodes], np.prod([w.ravel() for w in weights], axis=0)


N = 24


def _quad_cylinder(R, h):
    (r, t, z), w = _grid(_gl(N, 0, R), _gl(N, 0, 2 * np.pi), _gl(N, -h / 2, h / 2))
    return np.c_[r * np.cos(t), r * np.sin(t), z], w * r


def _quad_cone(R, h):
    # base disk at z = 0, apex at z = h; the radius shrinks linearly
    (s, t, z), w = _grid(_gl(N, 0, 1), _gl(N, 0, 2 * np.pi), _gl(N, 0, h))
    rz = R * (1 - z / h)
    r = s * rz
    return np.c_[r * np.cos(t), r * np.sin(t), z], w * r * rz


def _quad_ball(a, b, c):
    (r, th, ph), w = _grid(_gl(N, 0, 1), _gl(N, 0, np.pi), _gl(N, 0, 2 * np.pi))
    x = np.c_[a * r * np.sin(th) * np.cos(ph), b * r * np.sin(th) * np.sin(ph), c * r * np.cos(th)]
    return x, w * r**2 * np.sin(th)


def _quad_shell(R):
    (th, ph), w = _grid(_gl(N, 0, np.pi), _gl(N, 0, 2 * np.pi))
    return R * np.c_[np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)], w * np.sin(th)


def _quad_box(a, b, c):
    (x, y, z), w = _grid(_gl(4, -a / 2, a / 2), _gl(4, -b / 2, b / 2), _gl(4, -c / 2, c / 2))
    return np.c_[x, y, z], w


def _quad_disk(R):
    (r, t), w = _grid(_gl(N, 0, R), _gl(N, 0, 2 * np.pi))
    return np.c_[r * np.cos(t), r * np.sin(t), 0 * r], w * r


def _quad_ring(R):
    t, w = _gl(N, 0, 2 * np.pi)
    return R * np.c_[np.cos(t), np.sin(t), 0 * t], w


def _quad_rod(length):
    z, w = _gl(4, -length / 2, length / 2)
    return np.c_[0 * z, 0 * z, z], w


QUADRATURE = {
    "thin_disk": (inertia.thin_disk, (1.3, 0.7), lambda: _quad_disk(0.7)),
    "thin_ring": (inertia.thin_ring, (1.3, 0.7), lambda: _quad_ring(0.7)),
    "thin_rod": (inertia.thin_rod, (1.3, 0.7), lambda: _quad_rod(0.7)),
    "solid_sphere": (inertia.solid_sphere, (1.3, 0.7), lambda: _quad_ball(0.7, 0.7, 0.7)),
    "hollow_sphere": (inertia.hollow_sphere, (1.3, 0.7), lambda: _quad_shell(0.7)),
    "box": (inertia.box, (1.3, 0.7, 1.1, 2.3), lambda: _quad_box(0.7, 1.1, 2.3)),
    "solid_cylinder": (inertia.solid_cylinder, (1.3, 0.7, 2.3), lambda: _quad_cylinder(0.7, 2.3)),
    "solid_cone": (inertia.solid_cone, (1.3, 0.7, 2.3), lambda: _quad_cone(0.7, 2.3)),
    "ellipsoid": (inertia.ellipsoid, (1.3, 0.7, 1.1, 2.3), lambda: _quad_ball(0.7, 1.1, 2.3)),
}


@pytest.mark.parametrize("name", sorted(QUADRATURE))
def test_solid_matches_numerical_integration(name):
    func, args, make = QUADRATURE[name]
    mass = args[0]
    points, volume_weights = make()
    _, _, I_num = central_tensor_reference(points, mass * volume_weights / volume_weights.sum())
    scale = np.abs(I_num).max()
    np.testing.assert_allclose(np.diag(I_num), func(*args), rtol=1e-10, atol=1e-12 * scale)
    off = I_num - np.diag(np.diag(I_num))
    assert np.abs(off).max() <= 1e-10 * scale


def test_cone_centre_of_mass_is_a_quarter_height_above_base():
    points, w = _quad_cone(0.7, 2.3)
    com = (w[:, None] * points).sum(axis=0) / w.sum()
    np.testing.assert_allclose(com, [0.0, 0.0, 2.3 / 4], atol=1e-12, rtol=0)


def _tplquad_cylindrical(f, h0, h1, r_of_z):
    """int dz int_0^{2 pi} dtheta int_0^{r(z)} r dr f(r, theta, z) with scipy.integrate."""
    val, _ = integrate.tplquad(
        lambda r, t, z: f(r, t, z) * r, h0, h1, 0.0, 2 * np.pi, 0.0,
        lambda z, t: r_of_z(z), epsabs=1e-13, epsrel=1e-12,
    )
    return val


def test_cone_central_transverse_moment_by_scipy_tplquad():
    # the CM moment of a cone is easy to get wrong: integrate it directly
    M, R, h = 1.3, 0.7, 2.3
    radius = lambda z: R * (1 - z / h)  # noqa: E731
    vol = _tplquad_cylindrical(lambda r, t, z: 1.0, 0.0, h, radius)
    zc = _tplquad_cylindrical(lambda r, t, z: z, 0.0, h, radius) / vol
    assert zc == pytest.approx(h / 4, rel=1e-10)
    Ixx = M / vol * _tplquad_cylindrical(
        lambda r, t, z: (r * np.sin(t)) ** 2 + (z - zc) ** 2, 0.0, h, radius
    )
    Izz = M / vol * _tplquad_cylindrical(lambda r, t, z: r**2, 0.0, h, radius)
    I = inertia.solid_cone(M, R, h)
    assert I[0] == pytest.approx(Ixx, rel=1e-9)
    assert I[2] == pytest.approx(Izz, rel=1e-9)


def test_cylinder_moments_by_scipy_tplquad():
    M, R, h = 1.3, 0.7, 2.3
    radius = lambda z: R  # noqa: E731
    vol = _tplquad_cylindrical(lambda r, t, z: 1.0, -h / 2, h / 2, radius)
    assert vol == pytest.approx(np.pi * R**2 * h, rel=1e-12)
    Ixx = M / vol * _tplquad_cylindrical(
        lambda r, t, z: (r * np.sin(t)) ** 2 + z**2, -h / 2, h / 2, radius
    )
    Izz = M / vol * _tplquad_cylindrical(lambda r, t, z: r**2, -h / 2, h / 2, radius)
    I = inertia.solid_cylinder(M, R, h)
    assert I[0] == pytest.approx(Ixx, rel=1e-9)
    assert I[2] == pytest.approx(Izz, rel=1e-9)


@pytest.mark.parametrize(
    ("call", "exc", "match"),
    [
        (lambda: inertia.thin_disk(-1.0, 1.0), ValueError, "mass must be > 0"),
        (lambda: inertia.thin_disk(0.0, 1.0), ValueError, "mass must be > 0"),
        (lambda: inertia.thin_ring(1.0, 0.0), ValueError, "radius must be > 0"),
        (lambda: inertia.thin_rod(1.0, np.nan), ValueError, "length must be finite"),
        (lambda: inertia.solid_sphere(1.0, -2.0), ValueError, "radius must be > 0"),
        (lambda: inertia.hollow_sphere(np.inf, 1.0), ValueError, "mass must be finite"),
        (lambda: inertia.box(1.0, 1.0, -1.0, 1.0), ValueError, "b must be >= 0"),
        (lambda: inertia.solid_cylinder(1.0, 1.0, 0.0), ValueError, "height must be > 0"),
        (lambda: inertia.solid_cone(1.0, 0.0, 1.0), ValueError, "radius must be > 0"),
        (lambda: inertia.ellipsoid(1.0, 1.0, 1.0, -0.5), ValueError, "c must be >= 0"),
        (lambda: inertia.solid_cone(True, 1.0, 1.0), TypeError, "mass must be a real number"),
        (lambda: inertia.solid_cylinder(1.0, "1", 1.0), TypeError, "radius must be a real"),
    ],
)
def test_solid_validation(call, exc, match):
    with pytest.raises(exc, match=match):
        call()


# ------------------------------------------------------------------------------------
# composite bodies
# ------------------------------------------------------------------------------------


def test_two_half_boxes_make_a_box():
    M, a, b, c = 6.0, 2.0, 1.0, 3.0
    half = inertia.box(M / 2, a / 2, b, c)
    props = inertia.composite([
        Part(M / 2, [-a / 4, 0.0, 0.0], half),
        Part(M / 2, [a / 4, 0.0, 0.0], half),
    ])
    assert isinstance(props, MassProperties)
    assert props.mass == M
    np.testing.assert_array_equal(props.center_of_mass, np.zeros(3))
    np.testing.assert_allclose(props.inertia, np.diag(inertia.box(M, a, b, c)), rtol=1e-15,
                               atol=1e-15)


def test_eight_octant_boxes_make_a_box_off_origin():
    M, a, b, c = 8.0, 1.0, 2.0, 4.0
    centre = np.array([1.0, -2.0, 0.5])
    parts = [
        Part(M / 8, centre + [sx * a / 4, sy * b / 4, sz * c / 4], inertia.box(M / 8, a / 2,
                                                                              b / 2, c / 2))
        for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)
    ]
    props = inertia.composite(parts)
    np.testing.assert_allclose(props.center_of_mass, centre, atol=1e-15, rtol=0)
    np.testing.assert_allclose(props.inertia, np.diag(inertia.box(M, a, b, c)), rtol=1e-14,
                               atol=1e-14)


def test_two_half_cylinders_stacked_make_a_cylinder():
    M, R, h = 3.0, 0.5, 2.0
    half = inertia.solid_cylinder(M / 2, R, h / 2)
    props = inertia.composite([(M / 2, [0, 0, -h / 4], half), (M / 2, [0, 0, h / 4], half)])
    np.testing.assert_allclose(props.inertia, np.diag(inertia.solid_cylinder(M, R, h)),
                               rtol=1e-15)


def test_rotated_disk_equals_rotated_tensor_and_edge_example():
    M, R = 2.0, 3.0
    rot = Rotation.from_rotvec([0.3, -1.2, 0.4])
    Q = rot.as_matrix()
    expected = Q @ np.diag(inertia.thin_disk(M, R)) @ Q.T
    for orientation in (Q, rot.as_quat(scalar_first=True)):
        props = inertia.composite([Part(M, [1.0, 2.0, 3.0], inertia.thin_disk(M, R), orientation)])
        assert props.mass == M
        np.testing.assert_array_equal(props.center_of_mass, [1.0, 2.0, 3.0])
        np.testing.assert_allclose(props.inertia, expected, atol=1e-14, rtol=0)
    # unrotated: the thin-disk example (axis through the rim) through MassProperties.about
    props = inertia.composite([Part(M, [1.0, 2.0, 3.0], inertia.thin_disk(M, R))])
    assert props.about([1.0 + R, 2.0, 3.0])[2, 2] == 27.0


@HYP
@given(point_clouds())
def test_composite_of_point_masses_equals_tensor(cloud):
    m, p = cloud
    props = inertia.composite([Part(mi, pi) for mi, pi in zip(m, p, strict=True)])
    assert props.mass == pytest.approx(m.sum(), rel=1e-15)
    np.testing.assert_allclose(props.center_of_mass, m @ p / m.sum(), atol=1e-12, rtol=0)
    ref = inertia.tensor(m, p)
    np.testing.assert_allclose(props.inertia, ref, atol=1e-11 * (np.abs(ref).max() + 1), rtol=0)


def test_dumbbell_of_two_balls_closed_form():
    m, r, d = 1.5, 0.25, 2.0
    ball = inertia.solid_sphere(m, r)
    props = inertia.composite([{"mass": m, "position": [0, 0, -d], "inertia": ball},
                               {"mass": m, "position": [0, 0, d], "inertia": ball}])
    t = 2 * (2 * m * r**2 / 5 + m * d**2)
    np.testing.assert_allclose(props.inertia, np.diag([t, t, 4 * m * r**2 / 5]), rtol=1e-15)


def test_rocket_cylinder_plus_cone_matches_quadrature():
    # cylinder (R, H) with axis z and base at z = 0, a cone of the same radius on top
    R, H, h, rho = 0.6, 2.0, 1.5, 1.7
    m_cyl = rho * np.pi * R**2 * H
    m_cone = rho * np.pi * R**2 * h / 3
    tilt = Rotation.from_rotvec([0.0, 0.4, 0.0])
    props = inertia.composite([
        Part(m_cyl, tilt.apply([0, 0, H / 2]), inertia.solid_cylinder(m_cyl, R, H),
             tilt.as_matrix()),
        Part(m_cone, tilt.apply([0, 0, H + h / 4]), inertia.solid_cone(m_cone, R, h),
             tilt.as_quat(scalar_first=True)),
    ])
    pc, wc = _quad_cylinder(R, H)
    pk, wk = _quad_cone(R, h)
    points = tilt.apply(np.r_[pc + [0, 0, H / 2], pk + [0, 0, H]])
    M, com, I = central_tensor_reference(points, rho * np.r_[wc, wk])
    assert props.mass == pytest.approx(M, rel=1e-12)
    np.testing.assert_allclose(props.center_of_mass, com, atol=1e-12, rtol=0)
    np.testing.assert_allclose(props.inertia, I, atol=1e-10 * np.abs(I).max(), rtol=0)


@HYP
@given(point_clouds(max_n=4), rotations, arrays(np.float64, (3,), elements=finite))
def test_composite_is_covariant_under_rigid_motions(cloud, rot, t):
    m, p = cloud
    Q = rot.as_matrix()
    parts = [Part(mi, pi, inertia.box(mi, 1.0, 0.5 + k, 0.3), Rotation.random(random_state=k)
                  .as_matrix()) for k, (mi, pi) in enumerate(zip(m, p, strict=True))]
    moved = [Part(pt.mass, Q @ pt.position + t, pt.inertia, Q @ pt.orientation) for pt in parts]
    a, b = inertia.composite(parts), inertia.composite(moved)
    scale = np.abs(a.inertia).max()
    np.testing.assert_allclose(b.center_of_mass, Q @ a.center_of_mass + t, atol=1e-11 * 10, rtol=0)
    np.testing.assert_allclose(b.inertia, Q @ a.inertia @ Q.T, atol=1e-11 * scale, rtol=0)


def test_composite_accepts_a_generator_and_tensor_inertia():
    Q = Rotation.from_rotvec([1.0, 0.0, 0.0]).as_matrix()
    T = Q @ np.diag([1.0, 2.0, 3.0]) @ Q.T
    props = inertia.composite(Part(1.0, [0.0, 0.0, 0.0], T) for _ in range(2))
    np.testing.assert_allclose(props.inertia, 2 * T, atol=1e-15, rtol=0)


@pytest.mark.parametrize(
    ("parts", "exc", "match"),
    [
        ([], ValueError, "parts must contain at least one part"),
        (Part(1.0, [0, 0, 0]), TypeError, "parts must be an iterable of parts"),
        ([42], TypeError, r"parts\[0\] must be a liebody.inertia.Part"),
        ([(1.0,)], TypeError, r"parts\[0\] must be a liebody.inertia.Part"),
        ([{"mass": 1.0}], TypeError, r"parts\[0\] must have keys mass, position"),
        ([Part(1.0, [0, 0, 0]), Part(0.0, [0, 0, 0])], ValueError,
         r"parts\[1\].mass must be > 0"),
        ([Part(1.0, [0, 0])], ValueError, r"parts\[0\].position must have shape \(3,\)"),
        ([Part(1.0, [0, 0, 0], [1.0, -1.0, 1.0])], ValueError,
         r"parts\[0\].inertia principal moments must be >= 0"),
        ([Part(1.0, [0, 0, 0], -np.eye(3))], ValueError,
         r"parts\[0\].inertia must be positive semi-definite"),
        ([Part(1.0, [0, 0, 0], np.triu(np.ones((3, 3))))], ValueError,
         r"parts\[0\].inertia must be a symmetric tensor"),
        ([Part(1.0, [0, 0, 0], np.ones(2))], ValueError,
         r"parts\[0\].inertia must be principal moments of shape \(3,\)"),
        ([Part(1.0, [0, 0, 0], np.ones(3), -np.eye(3))], ValueError,
         r"parts\[0\].orientation must be a proper rotation"),
        ([Part(1.0, [0, 0, 0], np.ones(3), [2.0, 0.0, 0.0, 0.0])], ValueError,
         r"parts\[0\].orientation must be a unit quaternion"),
    ],
)
def test_composite_validation(parts, exc, match):
    with pytest.raises(exc, match=match):
        inertia.composite(parts)
