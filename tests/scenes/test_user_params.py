"""User torques with per-body parameters: ``torque(t, q, L, p)`` and ``torque(t, q, L, p, u)``.

References: the same torque with its constants compiled in (bit for bit), the one-body
call of each row (bit for bit), the built-in heavy top (the same physics).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from numba import njit

import liebody
from liebody import quaternion


@njit
def _gravity_p(t, q, L, p):
    """Uniform gravity with the weight arm in p: Gamma x c."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    g = np.array([2.0 * (x * z - w * y), 2.0 * (y * z + w * x), w * w - x * x - y * y + z * z])
    return np.cross(g, p[:3])


def _gravity_potential_p(t, q, p):
    from liebody._models.uniform_gravity import vertical_in_body

    return float(np.dot(vertical_in_body(*q), p[:3]))


@njit
def _drag_p(t, q, L, p):
    return -p[0] * L


@njit
def _drag_fixed(t, q, L):
    return -0.25 * L


@njit
def _steer_p(t, q, L, p, u):
    return p[0] * u - p[1] * L


ARM = np.array([0.0, 0.0, 20.0])
TOP_BODY = liebody.RigidBody([5.0, 5.0, 1.0])
Q0 = quaternion.exp([0.3, 0.0, 0.0])


def test_shared_params_equal_constants_compiled_in():
    body = liebody.RigidBody([1.0, 2.0, 3.0])
    a = liebody.TorqueBody(body, _drag_p, params=[0.25])
    b = liebody.TorqueBody(body, _drag_fixed)
    for method in ("splitting2", "rk4", "rattle"):
        ta = liebody.integrate(a, L0=[1.0, -0.5, 2.0], dt=0.05, steps=50, method=method)
        tb = liebody.integrate(b, L0=[1.0, -0.5, 2.0], dt=0.05, steps=50, method=method)
        np.testing.assert_array_equal(ta.q, tb.q)
        np.testing.assert_array_equal(ta.L, tb.L)


def test_a_user_torque_with_params_is_the_built_in_heavy_top():
    """Orientation-only gravity through params: the heavy top's kicks, so the same numbers
    to round-off, and the potential(t, q, p) enters the energy."""
    user = liebody.TorqueBody(TOP_BODY, _gravity_p, potential=_gravity_potential_p,
                              params=ARM, orientation_only=True)
    top = liebody.HeavyTop(TOP_BODY, 20.0, [0.0, 0.0, 1.0], g=1.0)
    tu = liebody.integrate(user, q0=Q0, L0=[0.0, 0.0, 5.0], dt=0.01, steps=500)
    tt = liebody.integrate(top, q0=Q0, L0=[0.0, 0.0, 5.0], dt=0.01, steps=500)
    np.testing.assert_allclose(tu.q, tt.q, atol=1e-12)
    np.testing.assert_allclose(tu.L, tt.L, atol=1e-11)
    np.testing.assert_allclose(user.potential(tu.q), top.potential(tu.q), rtol=1e-14,
                               atol=1e-14)
    assert user.capabilities.conservative


def test_per_body_params_give_each_body_its_one_body_call():
    rates = np.array([[0.1], [0.4], [0.9], [0.0]])
    body = liebody.RigidBody([1.0, 2.0, 3.0])
    scene = liebody.TorqueBody(body, _drag_p, params=rates)
    assert scene.batch_shape == (4,)
    L0 = np.array([1.0, -0.5, 2.0])
    for method in ("splitting2", "rk4"):
        ens = liebody.integrate(scene, L0=L0, dt=0.05, steps=60, save_every=20,
                                method=method, threads=2)
        for i in range(4):
            one = liebody.integrate(liebody.TorqueBody(body, _drag_p, params=rates[i]),
                                    L0=L0, dt=0.05, steps=60, save_every=20, method=method)
            np.testing.assert_array_equal(ens.q[i], one.q)
            np.testing.assert_array_equal(ens.L[i], one.L)
    # |L| decays as exp(-rate t) (the drag is along L): the rows reached the right bodies
    ens = liebody.integrate(scene, L0=L0, dt=0.01, steps=300, method="rk4")
    np.testing.assert_allclose(np.linalg.norm(ens.L[:, -1], axis=1),
                               np.linalg.norm(L0) * np.exp(-3.0 * rates[:, 0]), rtol=1e-9)


def test_per_body_params_and_inertia_in_a_stepper():
    moments = np.array([[1.0, 2.0, 3.0], [2.0, 2.5, 1.0]])
    params = np.array([[0.2, 0.1], [0.5, 0.0]])
    scene = liebody.ControlledBody(liebody.RigidBody.batch(moments), _steer_p, controls=3,
                                   params=params)
    st = liebody.Stepper(scene, L0=[[1.0, 0.0, 0.5], [0.0, 1.0, 0.0]], dt=0.02,
                         method="splitting2")
    st.u = [[1.0, 0.0, 0.0], [0.0, 0.0, 2.0]]
    st.step(25)
    ref = liebody.integrate(scene, L0=[[1.0, 0.0, 0.5], [0.0, 1.0, 0.0]], dt=0.02, steps=25,
                            method="splitting2", controls=[[1.0, 0.0, 0.0], [0.0, 0.0, 2.0]],
                            threads=1, simd=False)
    np.testing.assert_array_equal(st.L, ref.L[:, -1])
    np.testing.assert_array_equal(st.q, ref.q[:, -1])


@pytest.mark.parametrize(("params", "err", "match"), [
    (np.ones((3, 1)), ValueError, "params of shape \\(3, 1\\) give 3 rows.*2 bodies"),
    (np.zeros((2, 0)), ValueError, "params must be an array \\(k,\\)"),
    ([1.0, np.nan], ValueError, "params"),
    ("abc", TypeError, "params"),
])
def test_bad_params_are_refused_by_name(params, err, match):
    with pytest.raises(err, match=match):
        liebody.TorqueBody(liebody.RigidBody.batch([[1.0, 2.0, 3.0]] * 2), _drag_p,
                           params=params)


def test_a_torque_without_the_p_argument_is_refused_with_params():
    with pytest.raises(ValueError, match=r"torque\(t, q, L, p\) failed on a test call"):
        liebody.TorqueBody(liebody.RigidBody([1.0, 2.0, 3.0]), _drag_fixed, params=[1.0])


@njit
def _steer_q(t, q, L, p, u):
    """Orientation-only, with per-body parameters and controls, returning a tuple."""
    return (p[0] * u[0] - p[1] * q[1], p[0] * u[1] - p[1] * q[2], p[0] * u[2] - p[1] * q[3])


@njit
def _raises_for_negative_gain(t, q, L, p, u):
    if p[0] < 0.0:
        raise ValueError("negative gain")
    return np.array([p[0] * u[0], p[0] * u[1], -p[1] * q[3]])


@pytest.mark.parametrize("torque", [_steer_q, _raises_for_negative_gain])
def test_user_torques_run_in_the_simd_kernels_as_in_the_one_body_loop(torque):
    """Per-body parameters and controls reach each body's call of the user torque inside
    the SIMD kernels (one callback per block of bodies) as in the one-body loop; a body
    whose torque raises fails alone."""
    n = 40
    rng = np.random.default_rng(5)
    params = np.column_stack([rng.uniform(0.5, 2.0, n), rng.uniform(0.0, 1.0, n)])
    if torque is _raises_for_negative_gain:
        params[7, 0] = -1.0
    u = rng.normal(size=(n, 3))
    moments = np.tile([1.0, 2.0, 3.0], (n, 1)) * rng.uniform(1.0, 1.5, (n, 1))
    scene = liebody.ControlledBody(liebody.RigidBody.batch(moments), torque, controls=3,
                                   params=params, orientation_only=True)
    L0 = rng.normal(size=(n, 3))
    runs = {}
    for simd in (True, False):
        with warnings.catch_warnings(record=True):
            warnings.simplefilter("always")
            runs[simd] = liebody.integrate(scene, L0=L0, dt=0.02, steps=60, save_every=20,
                                           controls=u, simd=simd, threads=1)
    groups = runs[True].info.get("groups", [runs[True].info])
    assert all(g["simd"] for g in groups)
    assert list(runs[True].status) == list(runs[False].status)
    ok = np.array([s == "complete" for s in runs[True].status])
    assert ok.sum() == (n - 1 if torque is _raises_for_negative_gain else n)
    np.testing.assert_allclose(runs[True].q[ok], runs[False].q[ok], rtol=0, atol=1e-13)
    np.testing.assert_allclose(runs[True].L[ok], runs[False].L[ok], rtol=0, atol=1e-13)
