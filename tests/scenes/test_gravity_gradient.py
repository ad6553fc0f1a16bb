"""Orbits, the gravity-gradient model and scene, against independent references.

References: Kepler's equation solved in 50-digit decimal arithmetic; orbital geometry
from the elements (vis-viva, the plane's normal); the potential written here with
scipy's Rotation (scalar-last, converted explicitly); DOP853 at tight tolerance on
Euler's equations with the torque written here in numpy.
"""

from __future__ import annotations

import math
from decimal import Decimal, getcontext

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

import liebody
from liebody import quaternion
from liebody.orbits import Circular, Kepler

EPS = np.finfo(float).eps


# ------------------------------------------------------------------ Kepler's equation
def _dsin(x: Decimal) -> Decimal:
    term, s, k = x, x, 1
    while abs(term) > Decimal(10) ** -60:
        term = -term * x * x / ((2 * k) * (2 * k + 1))
        s += term
        k += 1
    return s


def _dcos(x: Decimal) -> Decimal:
    term, s, k = Decimal(1), Decimal(1), 1
    while abs(term) > Decimal(10) ** -60:
        term = -term * x * x / ((2 * k - 1) * (2 * k))
        s += term
        k += 1
    return s


_DPI = Decimal("3.14159265358979323846264338327950288419716939937510582097494459")


def _kepler_reference(M: float, e: float) -> float:
    """``E`` with ``E - e sin E = M`` (M reduced to [-pi, pi]), in 50-digit arithmetic."""
    getcontext().prec = 60
    Md, ed = Decimal(M), Decimal(e)
    two_pi = 2 * _DPI
    Md -= two_pi * (Md / two_pi + Decimal("0.5")).to_integral_value(rounding="ROUND_FLOOR")
    E = Md + ed * _dsin(Md) if e < 0.8 else (_DPI if Md > 0 else -_DPI)
    for _ in range(200):
        step = (E - ed * _dsin(E) - Md) / (1 - ed * _dcos(E))
        E -= step
        if abs(step) < Decimal(10) ** -55:
            break
    return float(E)


@pytest.mark.parametrize("e", [0.0, 0.2, 0.7, 0.97, 0.999, 1.0 - 1e-9])
def test_kepler_equation_to_round_off(e):
    from liebody._models.orbit import eccentric_anomaly

    for M in [1e-12, 1e-6, 1e-3, 0.05, 0.5, 1.5, 2.5, 3.1, 3.14159, -0.7, -3.0]:
        E = eccentric_anomaly(M, e)
        ref = _kepler_reference(M, e)
        assert abs(E - ref) <= 4 * EPS * abs(ref), (M, e, E, ref)


def test_kepler_equation_at_large_times():
    """The mean anomaly of a long run (1e6 rad) is reduced exactly enough: the error is
    that of M's own rounding, amplified by dE/dM = 1 / (1 - e cos E)."""
    from liebody._models.orbit import eccentric_anomaly

    for e in (0.1, 0.9):
        for M in (1e6 + 0.3, -2.5e7 + 1.1, 123456.789):
            E = eccentric_anomaly(M, e)
            ref = _kepler_reference(M, e)
            gain = 1.0 / (1.0 - e * math.cos(ref))
            assert abs(E - ref) <= 4 * EPS * (abs(M) * gain + abs(ref)), (M, e, E, ref)


# ------------------------------------------------------------------ orbital geometry
def test_circular_orbit_lies_in_the_xy_plane_counter_clockwise():
    o = Circular(0.5, radius=7.0)
    np.testing.assert_allclose(o.position(0.0), [7.0, 0.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(o.position(math.pi), [0.0, 7.0, 0.0], atol=1e-14)
    r0, r1 = o.position([0.0, 0.01])
    assert np.cross(r0, r1)[2] > 0  # counter-clockwise about +z
    t = np.linspace(0.0, 30.0, 101)
    np.testing.assert_allclose(np.linalg.norm(o.position(t), axis=-1), 7.0, rtol=1e-15)
    np.testing.assert_allclose(o.position(t + o.period), o.position(t), atol=1e-12)


def test_kepler_orbit_geometry_from_the_elements():
    a, e, GM, i, raan, argp = 2.0, 0.6, 3.0, 0.4, 1.1, -0.7
    o = Kepler(a, e, GM, i=i, raan=raan, argp=argp)
    # pericentre at t = 0 (M0 = 0), at distance a (1 - e)
    r0 = o.position(0.0)
    assert abs(np.linalg.norm(r0) - a * (1 - e)) <= 4 * EPS * a
    normal = [math.sin(raan) * math.sin(i), -math.cos(raan) * math.sin(i), math.cos(i)]
    np.testing.assert_allclose(o.normal, normal, atol=1e-15)
    t = np.linspace(0.0, 7.0, 57)
    r = o.position(t)
    np.testing.assert_allclose(r @ o.normal, 0.0, atol=1e-14)  # in the plane
    # vis-viva, speed by central differences
    d = 1e-5
    v = (o.position(t + d) - o.position(t - d)) / (2 * d)
    rn = np.linalg.norm(r, axis=-1)
    np.testing.assert_allclose(np.sum(v * v, axis=-1), GM * (2 / rn - 1 / a), rtol=1e-8)
    # Kepler's third law and the sense of motion (the orbital angular momentum along +normal)
    assert abs(o.period - 2 * math.pi * math.sqrt(a**3 / GM)) <= 1e-14 * o.period
    assert np.all(np.cross(r, v) @ o.normal > 0)
    np.testing.assert_allclose(o.position(t + o.period), r, atol=1e-12)


@pytest.mark.parametrize(("make", "match"), [
    (lambda: Kepler(1.0, 1.0, 1.0), "e .*eccentricity.* must be in \\[0, 1\\)"),
    (lambda: Kepler(1.0, -0.1, 1.0), "e .*must be in \\[0, 1\\)"),
    (lambda: Kepler(1.0, 0.1, 0.0), "GM"),
    (lambda: Kepler(-1.0, 0.1, 1.0), "a"),
    (lambda: Circular(0.0), "n"),
    (lambda: Circular(1.0, radius=-2.0), "radius"),
    (lambda: Circular(1.0, inclination=math.nan), "inclination"),
])
def test_bad_orbits_are_refused_by_name(make, match):
    with pytest.raises(ValueError, match=match):
        make()


def test_bad_sources_are_refused_by_name():
    body = liebody.RigidBody([1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="at least one"):
        liebody.GravityGradient(body, [])
    with pytest.raises(ValueError, match=r"sources\[0\] GM"):
        liebody.GravityGradient(body, [(-1.0, Circular(1.0))])
    with pytest.raises(TypeError, match=r"sources\[1\]: the orbit"):
        liebody.GravityGradient(body, [(1.0, Circular(1.0)), (1.0, [1, 0, 0])])


# ------------------------------------------------------------------ the model
SOURCES = [(2.0, Kepler(3.0, 0.4, 5.0, i=0.3, raan=0.2, argp=1.0, M0=0.5)),
           (0.7, Circular(0.9, radius=2.5, inclination=1.2, phase=0.4))]
MOMENTS = np.array([1.0, 1.7, 2.6])


def _r_space(t):
    return [(GM, o.position(t)) for GM, o in SOURCES]


def _potential_ref(t, q):
    """MacCullagh's V written with scipy's Rotation (scalar-last: converted here)."""
    R = Rotation.from_quat(np.roll(q / np.linalg.norm(q), -1))
    V = 0.0
    for GM, r in _r_space(t):
        rb = R.inv().apply(r)
        V += 1.5 * GM / np.linalg.norm(rb) ** 5 * rb @ (MOMENTS * rb)
    return V


def _torque_ref(t, q):
    R = Rotation.from_quat(np.roll(q / np.linalg.norm(q), -1))
    tau = np.zeros(3)
    for GM, r in _r_space(t):
        rb = R.inv().apply(r)
        tau += 3 * GM / np.linalg.norm(rb) ** 5 * np.cross(rb, MOMENTS * rb)
    return tau


def test_potential_and_torque_against_the_formulas_and_each_other():
    from liebody._models import dispatch

    scene = liebody.GravityGradient(liebody.RigidBody(MOMENTS), SOURCES)
    model = scene.torque_model()
    rng = np.random.default_rng(4)
    for _ in range(5):
        q = quaternion.random(rng=rng)
        t = float(rng.uniform(-3, 3))
        V = float(scene.potential(q, t))
        assert abs(V - _potential_ref(t, q)) <= 1e-13 * abs(V)
        p = np.zeros(16)
        tau = np.array(dispatch.torque(model.code, model.params[0], model.shared, p, 0, t, *q,
                                       0.0, 0.0, 0.0))
        np.testing.assert_allclose(tau, _torque_ref(t, q), rtol=1e-13, atol=1e-15)
        # the torque is minus the derivative of V under a body rotation by eps e_k
        for k in range(3):
            d = 1e-5
            e = np.zeros(3)
            e[k] = d
            up = scene.potential(quaternion.multiply(q, quaternion.exp(e)), t)
            down = scene.potential(quaternion.multiply(q, quaternion.exp(-e)), t)
            assert abs(-(up - down) / (2 * d) - tau[k]) <= 1e-8 * np.abs(tau).max()


def _reference(t_end, q0, L0):
    def rhs(t, y):
        q, L = y[:4], y[4:]
        w = L / MOMENTS
        dq = 0.5 * quaternion.multiply(q, [0.0, *w])
        return np.concatenate([dq, np.cross(L, w) + _torque_ref(t, q)])

    sol = solve_ivp(rhs, (0.0, t_end), np.concatenate([q0, L0]), method="DOP853",
                    rtol=1e-13, atol=1e-15)
    return sol.y[:4, -1], sol.y[4:, -1]


@pytest.mark.parametrize(("method", "order"), [("splitting2", 2), ("splitting4", 4),
                                               ("rattle", 2)])
def test_orders_against_dop853(method, order):
    scene = liebody.GravityGradient(liebody.RigidBody(MOMENTS), SOURCES)
    q0, L0, t_end = quaternion.exp([0.3, -0.2, 0.5]), np.array([0.4, -1.1, 2.0]), 2.0
    q_ref, L_ref = _reference(t_end, q0, L0)
    errs = []
    hs = [0.1, 0.05, 0.025] if order == 2 else [0.2, 0.1, 0.05]
    for h in hs:
        tr = liebody.integrate(scene, q0=q0, L0=L0, dt=h, t_end=t_end, method=method)
        errs.append(max(np.abs(tr.L[-1] - L_ref).max(),
                        np.abs(quaternion.multiply(quaternion.conjugate(q_ref),
                                                   tr.q[-1])[1:]).max()))
    slopes = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all(np.abs(slopes - order) < 0.25), (errs, slopes)


def test_jacobi_integral_bounded_by_the_splitting():
    """One source on a circular orbit: the Jacobi integral's error stays bounded over
    1e5 steps (no drift: the second half's spread is that of the first)."""
    scene = liebody.GravityGradient(liebody.RigidBody([1.0, 2.0, 3.0]),
                                    [(1.0, Circular(1.0))])
    tr = liebody.integrate(scene, q0=quaternion.exp([0.2, 0.1, 0.0]), L0=[0.1, 0.0, 3.2],
                           dt=0.05, steps=100_000, save_every=50, method="splitting2")
    J = scene.jacobi_integral(tr)
    err = np.abs(J - J[0])
    half = len(J) // 2
    assert err.max() < 1e-3 * abs(J[0])
    assert err[half:].max() < 1.5 * err[:half].max()
    with pytest.raises(ValueError, match="one source on a Circular orbit"):
        liebody.GravityGradient(liebody.RigidBody(MOMENTS), SOURCES).jacobi_integral(tr)


def test_energy_diagnostic_is_nan_for_a_time_dependent_potential():
    scene = liebody.GravityGradient(liebody.RigidBody(MOMENTS), SOURCES)
    tr = liebody.integrate(scene, L0=[0.4, -1.1, 2.0], dt=0.05, steps=20, diagnostics=True)
    assert math.isnan(tr.diagnostics["max_energy_error"])
    assert tr.diagnostics["max_qnorm_error"] < 1e-14


def test_ensemble_with_per_body_inertia_equals_one_body_calls():
    """The one-body loop per body gives each body's one-body numbers bit for bit; the SIMD
    kernels the same to round-off."""
    moments = np.array([[1.0, 1.7, 2.6], [2.0, 2.0, 1.0], [1.5, 0.7, 2.0]])
    # the axis splitting between the kicks: the drift the SIMD kernels run (the default,
    # the elliptic exact flow, runs in the one-body loop)
    scene = liebody.GravityGradient(liebody.RigidBody.batch(moments), SOURCES,
                                    free_flow="axes")
    L0 = np.array([[0.4, -1.1, 2.0], [0.1, 0.2, 1.0], [1.0, 0.0, -0.5]])
    ens = liebody.integrate(scene, L0=L0, dt=0.05, steps=40, save_every=10,
                            method="splitting4", threads=1, simd=False)
    simd = liebody.integrate(scene, L0=L0, dt=0.05, steps=40, save_every=10,
                             method="splitting4", threads=1, simd=True)
    groups = simd.info.get("groups", [simd.info])  # (one group per drift of the bodies)
    assert all(g["simd"] for g in groups)  # the gravity-gradient kicks run in SIMD kernels
    # which round sin and cos by a polynomial: agreement to round-off
    np.testing.assert_allclose(simd.q, ens.q, rtol=0, atol=1e-13)
    np.testing.assert_allclose(simd.L, ens.L, rtol=0, atol=1e-13)
    for i in range(3):
        one = liebody.integrate(liebody.GravityGradient(liebody.RigidBody(moments[i]),
                                                        SOURCES, free_flow="axes"),
                                L0=L0[i], dt=0.05, steps=40, save_every=10,
                                method="splitting4")
        np.testing.assert_array_equal(ens.q[i], one.q)
        np.testing.assert_array_equal(ens.L[i], one.L)
