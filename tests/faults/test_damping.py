"""Stiff dissipation: the damped body must lose energy and settle, for any ``eps dt``.

The dissipative part of :class:`liebody.DampedBody` (double-bracket dissipation,
``m' = eps m x (m x omega)``, ``q' = q (0, eps m x omega) / 2``) is checked against
independent references: scipy's DOP853 on the ODE itself, and the geometric phase by
quadrature (the exact flow turns ``q`` by the solid angle between the path of
``m / |m|`` and the great circle back, about ``m``, beyond the shortest arc the kernel
takes: an ``O(tau^3)`` difference in the rotation about ``L`` alone).
"""

from __future__ import annotations

import itertools
import math
import warnings

import numpy as np
import pytest
from scipy.integrate import IntegrationWarning, quad, solve_ivp

import liebody
from liebody._kernels.torque import damping_flow
from support import observed_order, rotation_distance

I = np.array([1.0, 2.0, 2.5])
M0 = np.array([1.2, 0.3, 0.4])
Q0 = np.array([0.9, 0.1, -0.3, 0.2]) / math.sqrt(0.95)
ULP = np.finfo(float).eps


def qmul(a, b):
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return np.array([aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw])


def rotate(q, v):
    """``R(q) v`` from the matrix of ``q`` (independent of the kernels)."""
    w, x, y, z = q
    R = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                  [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                  [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])
    return R @ v


def energy(m, moments=I):
    return 0.5 * float(np.sum(m * m / moments))


def d_flow(q, m, eps, tau, moments=I):
    """The kernel's dissipative step."""
    r = damping_flow(*map(float, q), *map(float, m), *map(float, moments), eps, tau)
    return np.array(r[:4]), np.array(r[4:])


def dissipative_rhs(moments, eps, spin=True):
    """``(q, m)' `` of the dissipative part (``spin``: plus the free rigid body)."""
    def f(t, y):
        q, m = y[:4], y[4:]
        om = m / moments
        od = eps * np.cross(m, om) + (om if spin else 0.0)
        return np.concatenate([0.5 * qmul(q, np.array([0.0, *od])), np.cross(m, od)])
    return f


def dop853(q, m, eps, tau, moments=I, spin=False):
    sol = solve_ivp(dissipative_rhs(moments, eps, spin), (0.0, tau), np.concatenate([q, m]),
                    method="DOP853", rtol=1e-13, atol=1e-16)
    assert sol.success
    return sol.y[:4, -1], sol.y[4:, -1]


def geometric_phase(m0, eps, tau, moments=I):
    """``phi = int u0 . (u x u') / (1 + u0 . u) dt`` along ``u = m(t)/|m|``: the solid
    angle enclosed by the path of ``u`` and the great circle from ``u(t)`` back to
    ``u0``, by which the exact flow turns beyond the shortest arc (about ``m(t)``)."""
    a = 1.0 / moments
    c = eps * float(m0 @ m0)
    u0 = m0 / np.linalg.norm(m0)

    def integrand(t):
        w = u0 * np.exp(-c * (a - a.min()) * t)
        n = np.linalg.norm(w)
        u = w / n
        du = -c * a * u
        du -= u * (u @ du)
        return float(u0 @ np.cross(u, du) / (1.0 + u0 @ u))

    lam = c * np.ptp(a)  # the decay rate: subintervals resolve the initial layer
    edges = sorted({0.0, tau, *(min(tau, 2.0**k / lam) for k in range(-4, 12))})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IntegrationWarning)
        return sum(quad(integrand, lo, hi, epsabs=1e-16, epsrel=1e-13, limit=200)[0]
                   for lo, hi in itertools.pairwise(edges))


# ------------------------------------------------------------------ the dissipative step


@pytest.mark.kernel
@pytest.mark.parametrize("eps, tau", [(1.0, 1.0), (1e3, 1.0)], ids=["c tau 1.7", "c tau 1690"])
def test_dissipative_step_is_the_closed_form_against_dop853(eps, tau):
    q, m = d_flow(Q0, M0, eps, tau)
    qr, mr = dop853(Q0, M0, eps, tau)
    G = np.linalg.norm(M0)
    np.testing.assert_allclose(m, mr, rtol=1e-12, atol=1e-12 * G)
    # the spatial L of both is the initial one
    assert np.abs(rotate(q, m) - rotate(Q0, M0)).max() < 8 * ULP * G
    assert np.abs(rotate(qr, mr) - rotate(Q0, M0)).max() < 1e-12 * G
    # the orientation: the exact flow is the kernel's shortest arc, then a turn by the
    # geometric phase about m(t)
    phi = geometric_phase(M0, eps, tau)
    assert abs(phi) > 1e-3  # the comparison below sees the phase
    u = m / np.linalg.norm(m)
    turn = np.array([math.cos(phi / 2), *(-math.sin(phi / 2) * u)])
    assert rotation_distance(qmul(q, turn), qr) < 1e-12


@pytest.mark.kernel
def test_dissipative_step_is_exact_when_m_stays_in_a_principal_plane():
    """With one component zero the path of m/|m| is a great circle: no phase."""
    m0 = np.array([1.2, 0.0, 0.4])
    for eps, tau in [(1.0, 1.0), (1e3, 1.0)]:
        q, m = d_flow(Q0, m0, eps, tau)
        qr, mr = dop853(Q0, m0, eps, tau)
        np.testing.assert_allclose(m, mr, rtol=1e-12, atol=1e-12 * np.linalg.norm(m0))
        assert m[1] == 0.0
        assert rotation_distance(q, qr) < 1e-12


@pytest.mark.kernel
def test_orientation_of_the_dissipative_step_has_local_error_tau3():
    taus = 0.2 / 2.0 ** np.arange(5)
    errs = []
    for tau in taus:
        q, _ = d_flow(Q0, M0, 1.0, tau)
        qr, _ = dop853(Q0, M0, 1.0, tau)
        errs.append(float(rotation_distance(q, qr)))
    slopes = np.diff(np.log(errs)) / np.diff(np.log(taus))
    assert np.all(np.abs(slopes - 3.0) < 0.1), (errs, slopes)


@pytest.mark.kernel
def test_dissipative_step_keeps_m_norm_and_spatial_L_and_lowers_energy_for_any_tau():
    rng = np.random.default_rng(5)
    for _ in range(20):
        moments = rng.uniform(0.5, 3.0, 3)
        m0 = rng.normal(size=3) * 10.0 ** rng.uniform(-3, 3)
        q0 = rng.normal(size=4)
        q0 /= np.linalg.norm(q0)
        G, T0 = np.linalg.norm(m0), energy(m0, moments)
        Tmin = G**2 / (2 * moments.max())
        for ct in 10.0 ** np.arange(-8, 13):
            eps = ct / G**2
            q, m = d_flow(q0, m0, eps, 1.0, moments)
            assert abs(np.linalg.norm(m) - G) <= 4 * ULP * G
            assert abs(np.linalg.norm(q) - 1.0) <= 4 * ULP
            assert np.abs(rotate(q, m) - rotate(q0, m0)).max() <= 8 * ULP * G
            T = energy(m, moments)
            assert Tmin * (1 - 4 * ULP) <= T <= T0 * (1 + 4 * ULP)
            assert np.all(m * m0 >= 0)  # the signs of the components never change
        # the stiff limit: the largest-moment axis
        k = int(np.argmax(moments))
        assert abs(abs(m[k]) - G) <= 4 * ULP * G


@pytest.mark.kernel
def test_dissipative_step_is_reversible_and_a_flow():
    G = np.linalg.norm(M0)
    q1, m1 = d_flow(Q0, M0, 0.7, 0.4)
    q2, m2 = d_flow(q1, m1, 0.7, -0.4)
    assert np.abs(m2 - M0).max() < 1e-14 * G and rotation_distance(q2, Q0) < 1e-14
    # the m part is the exact flow: two half steps are one step
    _, ma = d_flow(*d_flow(Q0, M0, 0.7, 0.2), 0.7, 0.2)
    assert np.abs(ma - m1).max() < 1e-14 * G
    # zero momentum and zero time are left alone
    q, m = d_flow(Q0, np.zeros(3), 5.0, 1.0)
    assert np.array_equal(q, Q0) and np.array_equal(m, np.zeros(3))
    q, m = d_flow(Q0, M0, 5.0, 0.0)
    assert np.array_equal(m, M0) and rotation_distance(q, Q0) == 0.0


# ------------------------------------------------------------------ the damped body


@pytest.mark.parametrize("free_flow", ["auto", "exact"])
def test_stiff_damping_settles_on_the_major_axis_with_falling_energy(free_flow):
    body = liebody.RigidBody([1.0, 2.0, 2.5])
    scene = liebody.DampedBody(body, eps=1e4, free_flow=free_flow)
    tr = liebody.integrate(scene, L0=M0, dt=0.01, steps=500)
    G = np.linalg.norm(M0)
    E = tr.energy
    assert np.all(np.diff(E) <= 4 * ULP * E[:-1]), np.diff(E).max()
    np.testing.assert_allclose(E[-1], G**2 / (2 * 2.5), rtol=8 * ULP)
    assert abs(abs(tr.L[-1, 2]) - G) <= 8 * ULP * G
    assert np.abs(tr.casimir - G).max() <= 1e-14 * G
    assert np.abs(tr.L_space - tr.L_space[0]).max() <= 1e-14 * G


@pytest.mark.parametrize("free_flow", ["auto", "exact"])
@pytest.mark.parametrize("eps_dt", 10.0 ** np.arange(-3, 5))
def test_energy_never_rises_whatever_eps_dt(eps_dt, free_flow):
    dt = 0.01
    body = liebody.RigidBody([1.0, 2.0, 2.5])
    scene = liebody.DampedBody(body, eps=eps_dt / dt, free_flow=free_flow)
    tr = liebody.integrate(scene, L0=M0, dt=dt, steps=2000)
    E = tr.energy
    assert np.all(np.diff(E) <= 4 * ULP * E[:-1]), (np.diff(E).max(), E[0])
    assert E[-1] < E[0]
    assert np.abs(tr.casimir - np.linalg.norm(M0)).max() <= 1e-13 * np.linalg.norm(M0)


def test_damped_body_splitting_is_second_order_against_dop853():
    eps, t_end = 0.3, 2.0
    body = liebody.RigidBody([1.0, 2.0, 2.5])
    scene = liebody.DampedBody(body, eps=eps)
    q_ref, m_ref = dop853(np.array([1.0, 0, 0, 0]), M0, eps, t_end, spin=True)

    def error(n):
        tr = liebody.integrate(scene, L0=M0, dt=t_end / n, steps=n)
        return max(float(np.abs(tr.L[-1] - m_ref).max()) / np.linalg.norm(M0),
                   float(rotation_distance(tr.q[-1], q_ref)))

    order = observed_order(error, 8, t_end)
    assert abs(order.order - 2.0) < 0.1, order
