"""Tests of liebody.RigidBody: principal axes, degeneracy, T and L, validation."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.spatial.transform import Rotation

import liebody
from liebody import inertia
from liebody.rigid_body import EQUAL_MOMENTS_RTOL, RigidBody, moments_equal

HYP = settings(max_examples=40, deadline=None)

rotations = st.integers(0, 2**32 - 1).map(lambda s: Rotation.random(random_state=s))
vectors = arrays(np.float64, (3,), elements=st.floats(-10.0, 10.0, allow_nan=False))


@st.composite
def physical_moments(draw):
    """Principal moments of a real body: I1 = B + C, I2 = A + C, I3 = A + B, with the
    second moments A, B, C > 0 (so the triangle inequality holds)."""
    s = draw(arrays(np.float64, (3,), elements=st.floats(0.1, 10.0)))
    return np.array([s[1] + s[2], s[0] + s[2], s[0] + s[1]])


def test_lazy_export():
    assert liebody.RigidBody is RigidBody


# ------------------------------------------------------------------------------------
# construction from principal moments and from tensors
# ------------------------------------------------------------------------------------


def test_principal_moments_keep_their_order():
    b = RigidBody([3.0, 1.0, 2.5], mass=2.0)
    np.testing.assert_array_equal(b.moments, [3.0, 1.0, 2.5])
    np.testing.assert_array_equal(b.axes, np.eye(3))
    np.testing.assert_array_equal(b.inertia_tensor, np.diag([3.0, 1.0, 2.5]))
    assert b.mass == 2.0
    assert b.moments.dtype == np.float64


def test_diagonal_tensor_is_sorted_ascending_with_permuted_axes():
    b = RigidBody(np.diag([3.0, 1.0, 2.5]))
    np.testing.assert_array_equal(b.moments, [1.0, 2.5, 3.0])
    # principal axes are the coordinate axes y, z, x (signs as chosen)
    np.testing.assert_allclose(np.abs(b.axes), [[0, 0, 1], [1, 0, 0], [0, 1, 0]], atol=1e-15,
                               rtol=0)
    assert np.linalg.det(b.axes) == pytest.approx(1.0, abs=1e-15)


def test_tensor_with_products_of_inertia_by_hand():
    # [[2, -1, 0], [-1, 2, 0], [0, 0, 2.5]]: eigenvalues 1 (x+y), 2.5 (z), 3 (x-y)
    T = np.array([[2.0, -1.0, 0.0], [-1.0, 2.0, 0.0], [0.0, 0.0, 2.5]])
    b = RigidBody(T)
    np.testing.assert_allclose(b.moments, [1.0, 2.5, 3.0], rtol=1e-15)
    s = np.sqrt(0.5)
    # deterministic signs: largest component positive (first one on a tie), A3 = A1 x A2
    np.testing.assert_allclose(b.axes[:, 0], [s, s, 0.0], atol=1e-15, rtol=0)
    np.testing.assert_allclose(b.axes[:, 1], [0.0, 0.0, 1.0], atol=1e-15, rtol=0)
    np.testing.assert_allclose(b.axes[:, 2], [s, -s, 0.0], atol=1e-15, rtol=0)
    np.testing.assert_allclose(b.inertia_tensor, T, atol=1e-15, rtol=0)


@HYP
@given(physical_moments(), rotations)
def test_rotated_tensor_is_diagonalised(moments, rot):
    Q = rot.as_matrix()
    T = Q @ np.diag(moments) @ Q.T
    T = 0.5 * (T + T.T)
    b = RigidBody(T)
    scale = moments.max()
    np.testing.assert_allclose(b.moments, np.sort(moments), atol=1e-13 * scale, rtol=0)
    assert np.all(np.diff(b.moments) >= 0)
    A = b.axes
    np.testing.assert_allclose(A.T @ A, np.eye(3), atol=1e-14, rtol=0)
    assert np.linalg.det(A) == pytest.approx(1.0, abs=1e-14)
    np.testing.assert_allclose(A @ np.diag(b.moments) @ A.T, T, atol=1e-13 * scale, rtol=0)
    np.testing.assert_array_equal(b.inertia_tensor, b.inertia_tensor.T)
    np.testing.assert_allclose(b.inertia_tensor, T, atol=1e-13 * scale, rtol=0)
    # each column is an eigenvector (including degenerate draws)
    for k in range(3):
        np.testing.assert_allclose(T @ A[:, k], b.moments[k] * A[:, k], atol=1e-13 * scale, rtol=0)
    # sign convention of columns 0 and 1
    for k in (0, 1):
        assert A[np.argmax(np.abs(A[:, k])), k] > 0


@HYP
@given(physical_moments(), rotations)
def test_axes_are_deterministic(moments, rot):
    Q = rot.as_matrix()
    T = Q @ np.diag(moments) @ Q.T
    a, b = RigidBody(T), RigidBody(T.copy())
    np.testing.assert_array_equal(a.axes, b.axes)
    np.testing.assert_array_equal(a.moments, b.moments)


def test_arrays_are_read_only_and_attributes_cannot_be_set():
    b = RigidBody([1.0, 2.0, 2.5], mass=1.0)
    for arr in (b.moments, b.axes, b.inertia_tensor):
        with pytest.raises(ValueError, match="read-only"):
            arr[0] = 7.0
    with pytest.raises(AttributeError):
        b.moments = np.ones(3)
    with pytest.raises(AttributeError):
        b.anything = 1


def test_input_array_is_copied():
    m = np.array([1.0, 2.0, 2.5])
    b = RigidBody(m)
    m[0] = 99.0
    assert b.moments[0] == 1.0


def test_repr():
    assert repr(RigidBody([1.0, 2.0, 2.5], mass=3.0)) == (
        "RigidBody(moments=[1.0, 2.0, 2.5], mass=3.0)"
    )


# ------------------------------------------------------------------------------------
# degenerate spectra
# ------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("moments", "axis", "free"),
    [
        ([2.0, 2.0, 3.0], 2, (0, 1)),
        ([3.0, 2.0, 3.0], 1, (0, 2)),
        ([2.0, 3.0, 3.0], 0, (1, 2)),
        ([1.0, 2.0, 2.5], None, ()),
    ],
)
def test_symmetry_axis_of_principal_moments(moments, axis, free):
    b = RigidBody(moments)
    assert b.symmetry_axis == axis
    assert b.free_axes == free
    assert b.is_symmetric is (axis is not None)
    assert b.is_spherical is False


def test_spherical_top():
    for b in (RigidBody([5.0, 5.0, 5.0]),
              RigidBody(inertia.moments_to_tensor(inertia.solid_sphere(2.0, 0.5),
                                                  Rotation.from_rotvec([1, 2, 3]).as_matrix()))):
        assert b.is_spherical is True
        assert b.is_symmetric is False
        assert b.symmetry_axis is None
        assert b.free_axes == (0, 1, 2)
        np.testing.assert_allclose(b.axes.T @ b.axes, np.eye(3), atol=1e-15, rtol=0)
        assert np.linalg.det(b.axes) == pytest.approx(1.0, abs=1e-15)


@HYP
@given(rotations, st.floats(0.5, 5.0), st.floats(0.05, 0.95))
def test_rotated_symmetric_top_finds_its_axis(rot, I, frac):
    # I1 = I2 = I, I3 = I (1 + frac) or I (1 - frac): the axis goes to either end
    Q = rot.as_matrix()
    for I3 in (I * (1 + frac), I * (1 - frac)):
        if I3 > 2 * I:  # triangle inequality
            continue
        T = Q @ np.diag([I, I, I3]) @ Q.T
        b = RigidBody(0.5 * (T + T.T))
        expected_axis = 2 if I3 > I else 0
        assert b.symmetry_axis == expected_axis
        assert b.is_symmetric
        assert b.free_axes == tuple(k for k in range(3) if k != expected_axis)
        # the symmetry axis of the body is Q's third column (up to sign)
        assert abs(b.axes[:, expected_axis] @ Q[:, 2]) == pytest.approx(1.0, abs=1e-12)
        assert np.linalg.det(b.axes) == pytest.approx(1.0, abs=1e-14)
        np.testing.assert_allclose(b.inertia_tensor, T, atol=1e-13 * I, rtol=0)


def test_equal_moments_policy():
    assert EQUAL_MOMENTS_RTOL == 1e-10  # documented value
    assert RigidBody([1.0, 1.0 + 5e-11, 1.5]).symmetry_axis == 2
    assert RigidBody([1.0, 1.0 + 5e-10, 1.5]).symmetry_axis is None
    eps = EQUAL_MOMENTS_RTOL
    assert RigidBody([1.0, 1.0 + 0.1 * eps, 1.5]).symmetry_axis == 2
    assert RigidBody([1.0, 1.0 + 100 * eps, 1.5]).symmetry_axis is None
    # a chain of two "equal" pairs counts as spherical
    chain = RigidBody([1.0, 1.0 + 0.6 * eps, 1.0 + 1.2 * eps])
    assert chain.is_spherical and chain.symmetry_axis is None
    # equal moments are made exactly equal (their mean), so every later decision agrees
    near = RigidBody([1.0, 1.0 + 0.5 * eps, 1.5])
    assert near.moments[0] == near.moments[1] == 1.0 + 0.25 * eps
    assert chain.moments[0] == chain.moments[1] == chain.moments[2]
    np.testing.assert_allclose(chain.moments, 1.0 + 0.6 * eps, rtol=1e-15)
    # a symmetric top's tensor in a rotated frame: eigh returns its moments ulps apart
    R = liebody.quaternion.to_matrix(liebody.quaternion.random(rng=2))
    top = RigidBody(R @ np.diag([2.0, 2.0, 1.0]) @ R.T)
    assert top.moments[1] == top.moments[2] and top.symmetry_axis == 0
    assert moments_equal(1.0, 1.0 + 0.5 * eps, 1.0) and not moments_equal(1.0, 1.0 + 2 * eps, 1.0)


def test_solids_symmetry():
    assert RigidBody(inertia.solid_cylinder(1.0, 0.5, 3.0)).symmetry_axis == 2
    assert RigidBody(inertia.solid_cone(1.0, 0.5, 3.0)).symmetry_axis == 2
    assert RigidBody(inertia.box(1.0, 1.0, 2.0, 3.0)).symmetry_axis is None
    assert RigidBody(inertia.hollow_sphere(1.0, 2.0)).is_spherical
    # the thin disk lies exactly on the triangle inequality I3 = I1 + I2: accepted
    disk = RigidBody(inertia.thin_disk(2.0, 3.0))
    assert disk.symmetry_axis == 2
    # ... also when it arrives as a rotated tensor carrying round-off
    Q = Rotation.from_rotvec([0.7, -0.2, 1.9]).as_matrix()
    rotated = RigidBody(inertia.moments_to_tensor(inertia.thin_disk(2.0, 3.0), Q))
    np.testing.assert_allclose(rotated.moments, [4.5, 4.5, 9.0], rtol=1e-14)
    assert rotated.symmetry_axis == 2


# ------------------------------------------------------------------------------------
# kinetic energy, angular momentum, angular velocity (principal axes, Hand & Finch ch. 8)
# ------------------------------------------------------------------------------------


def test_energy_and_momentum_by_hand():
    b = RigidBody([1.0, 2.0, 2.5])
    w = [1.0, -2.0, 2.0]
    assert b.kinetic_energy(w) == 0.5 * (1.0 + 8.0 + 10.0)
    np.testing.assert_array_equal(b.angular_momentum(w), [1.0, -4.0, 5.0])
    np.testing.assert_array_equal(b.angular_velocity([1.0, -4.0, 5.0]), w)


@HYP
@given(physical_moments(), vectors)
def test_energy_is_half_L_dot_omega_and_omega_inverts_L(moments, w):
    b = RigidBody(moments)
    L = b.angular_momentum(w)
    np.testing.assert_allclose(L, moments * w, rtol=1e-15)
    T = b.kinetic_energy(w)
    np.testing.assert_allclose(T, 0.5 * float(L @ w), rtol=1e-13, atol=0)
    hand = 0.5 * sum(moments[k] * w[k] ** 2 for k in range(3))
    np.testing.assert_allclose(T, hand, rtol=1e-13, atol=0)
    np.testing.assert_allclose(b.angular_velocity(L), w, rtol=1e-14, atol=1e-300)


def test_methods_are_vectorised():
    b = RigidBody([1.0, 2.0, 2.5])
    rng = np.random.default_rng(1)
    w = rng.normal(size=(4, 5, 3))
    T = b.kinetic_energy(w)
    L = b.angular_momentum(w)
    assert T.shape == (4, 5)
    assert L.shape == (4, 5, 3)
    for i in range(4):
        for j in range(5):
            assert T[i, j] == pytest.approx(b.kinetic_energy(w[i, j]), rel=1e-15)
            np.testing.assert_array_equal(L[i, j], b.angular_momentum(w[i, j]))
    np.testing.assert_allclose(b.angular_velocity(L), w, rtol=1e-15)


@HYP
@given(physical_moments(), rotations, vectors)
def test_energy_in_input_frame_equals_principal_form(moments, rot, w_in):
    # principal axes: T = 1/2 omega . I omega in any frame = 1/2 sum I_k omega_k^2 in principal
    Q = rot.as_matrix()
    T_in = Q @ np.diag(moments) @ Q.T
    b = RigidBody(T_in)
    w_p = b.to_principal(w_in)
    np.testing.assert_allclose(b.from_principal(w_p), w_in, atol=1e-13, rtol=0)
    ref = 0.5 * w_in @ T_in @ w_in
    assert b.kinetic_energy(w_p) == pytest.approx(ref, rel=1e-12, abs=1e-12)
    np.testing.assert_allclose(b.from_principal(b.angular_momentum(w_p)), T_in @ w_in,
                               atol=1e-12 * (1 + np.abs(T_in @ w_in).max()), rtol=0)


def test_principal_frame_conversion_of_the_axes():
    b = RigidBody(np.array([[2.0, -1.0, 0.0], [-1.0, 2.0, 0.0], [0.0, 0.0, 2.5]]))
    np.testing.assert_allclose(b.to_principal(b.axes.T), np.eye(3), atol=1e-15, rtol=0)
    np.testing.assert_allclose(b.from_principal(np.eye(3)), b.axes.T, atol=1e-15, rtol=0)


@pytest.mark.parametrize("method", ["kinetic_energy", "angular_momentum", "angular_velocity",
                                    "to_principal", "from_principal"])
def test_method_validation(method):
    b = RigidBody([1.0, 2.0, 2.5])
    with pytest.raises(ValueError, match=r"must have shape \(\.\.\., 3\)"):
        getattr(b, method)([1.0, 2.0])
    with pytest.raises(ValueError, match="must be finite"):
        getattr(b, method)([1.0, np.nan, 2.0])


# ------------------------------------------------------------------------------------
# from_point_masses
# ------------------------------------------------------------------------------------


def test_from_point_masses_planar_cross():
    # masses 1 at (+-1, 0, 0) and 2 at (0, +-1, 0): I_xx = 4, I_yy = 2, I_zz = 6 (= 2 + 4),
    # so ascending the principal axes are y, x, z
    masses = [1.0, 1.0, 2.0, 2.0]
    positions = [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0]]
    b = RigidBody.from_point_masses(masses, positions)
    assert b.mass == 6.0
    np.testing.assert_allclose(b.moments, [2.0, 4.0, 6.0], rtol=1e-15)
    np.testing.assert_allclose(np.abs(b.axes), [[0, 1, 0], [1, 0, 0], [0, 0, 1]], atol=1e-15,
                               rtol=0)


def test_from_point_masses_about_a_fixed_point():
    masses = [1.0, 1.0, 2.0, 2.0]
    positions = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0]], dtype=float)
    b = RigidBody.from_point_masses(masses, positions, origin=[0.0, 0.0, 1.0])
    # parallel-axis theorem: + M (a^2 - a_i^2) = +6 on x and y
    np.testing.assert_allclose(b.moments, [6.0, 8.0, 10.0], rtol=1e-15)


@HYP
@given(st.integers(0, 2**32 - 1))
def test_from_point_masses_matches_eigen_decomposition(seed):
    rng = np.random.default_rng(seed)
    masses = rng.uniform(0.5, 2.0, 6)
    positions = rng.normal(size=(6, 3))
    b = RigidBody.from_point_masses(masses, positions)
    ref = inertia.tensor(masses, positions)
    np.testing.assert_allclose(b.moments, np.linalg.eigvalsh(ref), rtol=1e-12)
    np.testing.assert_allclose(b.inertia_tensor, ref, atol=1e-12 * np.abs(ref).max(), rtol=0)
    assert b.mass == pytest.approx(masses.sum(), rel=1e-15)


def test_dumbbell_of_section_1_4_1_has_a_zero_moment():
    with pytest.raises(ValueError, match=r"zero principal moment.*dumbbell.*I3 = 0.*thickness"):
        RigidBody.from_point_masses([1.0, 1.0], [[0, 0, -1], [0, 0, 1]])
    with pytest.raises(ValueError, match="zero principal moment"):
        RigidBody([0.5, 0.5, 0.0])
    with pytest.raises(ValueError, match="zero principal moment"):
        RigidBody(inertia.thin_rod(1.0, 2.0))
    # tilted rod: the zero eigenvalue only vanishes up to round-off
    Q = Rotation.from_rotvec([0.3, 0.4, 0.5]).as_matrix()
    with pytest.raises(ValueError, match="zero principal moment"):
        RigidBody(inertia.moments_to_tensor(inertia.thin_rod(1.0, 2.0), Q))
    # ... and a thickened rod is fine
    assert RigidBody(inertia.solid_cylinder(1.0, 0.01, 2.0)).symmetry_axis == 2


# ------------------------------------------------------------------------------------
# validation
# ------------------------------------------------------------------------------------


def test_triangle_inequality_and_hlw_body():
    with pytest.raises(ValueError, match=r"triangle inequality.*I2 \+ I3 = .* < I1 = 2.0"):
        RigidBody([2.0, 1.0, 2.0 / 3.0])
    with pytest.raises(ValueError, match="check_triangle=False"):
        RigidBody([1.0, 1.0, 2.5])
    with pytest.raises(ValueError, match="triangle inequality"):
        RigidBody(np.diag([1.0, 3.0, 1.0]))
    hlw = RigidBody([2.0, 1.0, 2.0 / 3.0], check_triangle=False)
    np.testing.assert_array_equal(hlw.moments, [2.0, 1.0, 2.0 / 3.0])
    assert hlw.symmetry_axis is None
    # equality (planar body) up to round-off is accepted; a visible violation is not
    RigidBody([1.0, 2.0, 3.0 * (1 + 1e-15)])
    with pytest.raises(ValueError, match="triangle inequality"):
        RigidBody([1.0, 2.0, 3.0 * (1 + 1e-9)])


@pytest.mark.parametrize(
    ("kwargs", "exc", "match"),
    [
        ({"inertia": [1.0, np.nan, 1.0]}, ValueError, "inertia must be finite"),
        ({"inertia": np.full((3, 3), np.inf)}, ValueError, "inertia must be finite"),
        ({"inertia": [1.0, 1.0]}, ValueError, r"inertia must be three principal moments.*\(2,\)"),
        ({"inertia": np.eye(4)}, ValueError, r"inertia must be three principal moments"),
        ({"inertia": np.ones((1, 3))}, ValueError, r"inertia must be three principal moments"),
        ({"inertia": 1.0}, ValueError, r"inertia must be three principal moments"),
        ({"inertia": [[2.0, 0.1, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 3.0]]}, ValueError,
         "inertia must be a symmetric tensor"),
        ({"inertia": [1.0, -2.0, 2.5]}, ValueError,
         r"inertia must be positive definite: principal moment I2 = -2.0"),
        ({"inertia": -np.diag([1.0, 2.0, 2.5])}, ValueError,
         "inertia must be positive definite: eigenvalue of the inertia tensor"),
        ({"inertia": [0.0, 0.0, 0.0]}, ValueError, "zero principal moment"),
        ({"inertia": [1.0, 2.0, 2.5], "mass": 0.0}, ValueError, "mass must be > 0"),
        ({"inertia": [1.0, 2.0, 2.5], "mass": -1.0}, ValueError, "mass must be > 0"),
        ({"inertia": [1.0, 2.0, 2.5], "mass": np.nan}, ValueError, "mass must be finite"),
        ({"inertia": [1.0, 2.0, 2.5], "mass": "1"}, TypeError, "mass must be a real number"),
        ({"inertia": [1.0, 2.0, 2.5], "check_triangle": 0}, TypeError,
         "check_triangle must be a bool"),
        ({"inertia": [1.0 + 0j, 2.0, 2.5]}, TypeError, "inertia must contain real numbers"),
        ({"inertia": ["a", "b", "c"]}, TypeError, "inertia must contain real numbers"),
    ],
)
def test_validation(kwargs, exc, match):
    with pytest.raises(exc, match=match):
        RigidBody(**kwargs)


def test_symmetry_tolerance_is_relative():
    T = np.diag([2.0e6, 2.5e6, 3.0e6])
    ok = T.copy()
    ok[0, 1] += 1e-7  # 3e-14 relative to the largest entry
    RigidBody(ok)
    bad = T.copy()
    bad[0, 1] += 1e-3  # 3e-10 relative
    with pytest.raises(ValueError, match="symmetric"):
        RigidBody(bad)
