"""Elliptic-function kernels (liebody._kernels.elliptic) against scipy.special.

Marked ``kernel``: CI also runs this module with ``NUMBA_DISABLE_JIT=1``.

Where scipy itself is inaccurate the comparison uses identities instead: ``ellipj``
near ``m = 1`` (its ``m > 1 - 1e-9`` branch is an asymptotic formula; errors ~1e-10 were
seen) and ``elliprj`` with ``p << x, y, z`` (errors ~1e-13).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.special import (
    ellipj,
    ellipk,
    ellipkinc,
    ellipkm1,
    elliprd,
    elliprf,
    elliprj,
)

from liebody._kernels import elliptic as E

pytestmark = pytest.mark.kernel


def _rel(a, b):
    return abs(a - b) / abs(b)


def test_rf_matches_scipy():
    rng = np.random.default_rng(1)
    worst = 0.0
    for i in range(300):
        x, y, z = 10.0 ** rng.uniform(-14, 4, 3)
        if i % 4 == 0:
            x = 0.0
        worst = max(worst, _rel(E.carlson_rf(x, y, z), elliprf(x, y, z)))
    assert worst < 2e-15


def test_rf_special_values():
    assert E.carlson_rf(1.0, 1.0, 1.0) == pytest.approx(1.0, rel=1e-16)
    # R_F(0, 1, 1) = pi/2; R_F(0, 1, 2) = K(1/2)... via scipy
    assert E.carlson_rf(0.0, 1.0, 1.0) == pytest.approx(math.pi / 2, rel=2e-16)
    assert E.carlson_rf(0.0, 0.5, 1.0) == pytest.approx(ellipk(0.5), rel=2e-16)
    # homogeneity R_F(a x, a y, a z) = a^-1/2 R_F(x, y, z)
    assert E.carlson_rf(4e6, 9e6, 1e6) == pytest.approx(E.carlson_rf(4, 9, 1) / 1e3, rel=4e-16)


def test_rj_matches_scipy():
    rng = np.random.default_rng(2)
    worst = 0.0
    for i in range(300):
        x, y, z = 10.0 ** rng.uniform(-12, 3, 3)
        p = 10.0 ** rng.uniform(-1, 3) * max(x, y, z)  # scipy is accurate here
        if i % 4 == 0:
            x = 0.0
        worst = max(worst, _rel(E.carlson_rj(x, y, z, p), elliprj(x, y, z, p)))
    assert worst < 5e-15


def test_rj_small_p_no_cancellation():
    """p << x, y, z: Carlson's published 1 + e_m cancels; the kernel forms it stably."""
    rng = np.random.default_rng(3)
    for _ in range(40):
        x, y, z = 10.0 ** rng.uniform(-1, 3, 3)
        p = 10.0 ** rng.uniform(-13, -6)
        assert _rel(E.carlson_rj(x, y, z, p), elliprj(x, y, z, p)) < 1e-12
    # R_J(x, y, z, z) = R_D(x, y, z), and a direct quadrature at tiny p
    for x, y, z in [(0.3, 2.0, 5.0), (0.0, 1.0, 7.0), (1e-9, 1e-3, 1.0)]:
        assert _rel(E.carlson_rj(x, y, z, z), elliprd(x, y, z)) < 4e-15
    x, y, z, p = 90.0, 210.0, 2.5, 1.4e-12

    def f(s):  # t = s^2
        return 3.0 * s / ((s * s + p) * math.sqrt((s * s + x) * (s * s + y) * (s * s + z)))

    ref = quad(f, 0.0, 1e-6, epsabs=0, epsrel=1e-13, limit=200)[0] + quad(
        f, 1e-6, np.inf, epsabs=0, epsrel=1e-13, limit=200)[0]
    assert _rel(E.carlson_rj(x, y, z, p), ref) < 1e-12


def test_sncndn_matches_scipy():
    rng = np.random.default_rng(4)
    worst = 0.0
    for i in range(400):
        m = [rng.uniform(0, 1), 10.0 ** rng.uniform(-20, -1), 1 - 10.0 ** rng.uniform(-8, -1)][
            i % 3]
        m = min(m, 0.999)
        u = rng.uniform(-40, 40)
        s, c, d = E.jacobi_sncndn(u, m, 1.0 - m)
        S, C, D, _ = ellipj(u, m)
        worst = max(worst, max(abs(s - S), abs(c - C), abs(d - D)) / (1 + abs(u)))
    assert worst < 2e-15  # argument error ~ |u| eps


@pytest.mark.parametrize("mc", [1e-3, 1e-9, 1e-14, 1e-30, 1e-200])
def test_sncndn_near_one(mc):
    """m -> 1 (complementary parameter given exactly): identities and F(am u) = u."""
    m = 1.0 - mc
    k = E.ellipk(m, mc)
    assert k == pytest.approx(ellipkm1(mc), rel=2e-15)
    s, c, d, j, kq = E.jacobi_landen(0.3, math.sqrt(m), math.sqrt(mc))
    assert kq == pytest.approx(k, rel=2e-15) and j == 0.0
    for u in np.linspace(-3 * k, 3 * k, 37):
        s, c, d = E.jacobi_sncndn(u, m, mc)
        assert abs(s * s + c * c - 1) < 3e-15
        assert d == pytest.approx(math.sqrt(mc + m * c * c), rel=3e-15, abs=1e-300)
    # am(F(phi)) = phi (well conditioned: d am/du = dn <= 1); F from Carlson's R_F
    for phi in np.linspace(-7.0, 7.0, 29):
        u = E.ellipf(phi, m, mc)
        assert E.jacobi_am(u, m, mc) == pytest.approx(phi, abs=2e-15 * (1 + abs(u)))
    # near the quarter period cn and dn are O(k'): relatively accurate
    # cn(K - x) = k' sd(x), dn(K - x) = k' nd(x); sd, nd -> tanh, cosh for m -> 1
    x = 2.0
    s, c, d = E.jacobi_sncndn(k - x, m, mc)
    kc = math.sqrt(mc)
    if mc < 1e-14:
        assert c == pytest.approx(kc * math.sinh(x), rel=1e-12)
        assert d == pytest.approx(kc * math.cosh(x), rel=1e-12)


def test_sncndn_hyperbolic_limit():
    for u in [-30.0, -2.0, 0.0, 0.7, 25.0]:
        s, c, d = E.jacobi_sncndn(u, 1.0, 0.0)
        assert s == pytest.approx(math.tanh(u), abs=1e-16)
        assert c == pytest.approx(1 / math.cosh(u), rel=1e-15)
        assert d == c
        assert E.jacobi_am(u, 1.0, 0.0) == pytest.approx(math.atan(math.sinh(u)), abs=1e-16)


def test_am_continuous_and_quasi_periodic():
    for m in [0.0, 0.3, 0.9, 1 - 1e-10]:
        mc = 1.0 - m if m < 0.5 else {0.9: 0.1, 1 - 1e-10: 1e-10}[m]
        m = 1.0 - mc
        k = E.ellipk(m, mc)
        us = np.linspace(-7 * k, 7 * k, 301)
        am = np.array([E.jacobi_am(u, m, mc) for u in us])
        assert np.all(np.diff(am) > 0)
        for u in [0.1, 1.3, -2.2]:
            assert E.jacobi_am(u + 2 * k, m, mc) == pytest.approx(
                E.jacobi_am(u, m, mc) + math.pi, abs=4e-15 * (1 + k))
        if m < 0.999:
            phi = am[10:-10:7]
            assert np.allclose(ellipkinc(phi, m), us[10:-10:7], rtol=2e-14, atol=1e-14)


def _pi_scipy(n, phi, m):
    """Pi(n; phi | m) for |phi| <= pi/2 from scipy's Carlson functions."""
    s, c = math.sin(phi), math.cos(phi)
    y = c * c + (1 - m) * s * s  # = 1 - m s^2 without cancellation (m >= 1/2: 1 - m exact)
    return s * elliprf(c * c, y, 1) + n / 3 * s**3 * elliprj(c * c, y, 1, 1 - n * s * s)


def test_ellippi_matches_scipy():
    rng = np.random.default_rng(5)
    worst = 0.0
    for _ in range(200):
        m = rng.choice([rng.uniform(0, 1), 1 - 10.0 ** rng.uniform(-12, -1)])
        n = -(10.0 ** rng.uniform(-3, 3)) if rng.uniform() < 0.8 else rng.uniform(0, 0.9)
        phi = rng.uniform(-math.pi / 2, math.pi / 2)
        # the Carlson combination cancels for n < 0: compare on the scale of its terms
        sc, cc = math.sin(phi), math.cos(phi)
        y = cc * cc + (1 - m) * sc * sc
        scale = abs(sc * elliprf(cc * cc, y, 1)) + abs(n / 3 * sc**3 * elliprj(cc * cc, y, 1,
                                                                             1 - n * sc * sc))
        err = abs(E.ellippi(n, phi, m, 1 - m) - _pi_scipy(n, phi, m)) / scale
        worst = max(worst, err)
    assert worst < 4e-15


def test_ellippi_quasi_periodic_and_quadrature():
    for n, m in [(-3.0, 0.5), (-0.2, 0.99), (0.4, 0.3), (-50.0, 1 - 1e-8)]:
        mc = 1 - m
        pic = E.ellippi_complete(n, m, mc)
        assert pic == pytest.approx(_pi_scipy(n, math.pi / 2, m), rel=1e-14)
        for phi in [0.4, 2.0, -5.0, 11.0]:
            j = math.floor(phi / math.pi + 0.5)
            ref = 2 * j * pic + _pi_scipy(n, phi - j * math.pi, m)
            assert E.ellippi(n, phi, m, mc) == pytest.approx(ref, rel=1e-14)
        if m < 0.999:  # quad is reliable here
            def f(th, n=n, m=m):
                s2 = math.sin(th) ** 2
                return 1 / ((1 - n * s2) * math.sqrt(1 - m * s2))

            ref = quad(f, 0, 2.0, epsabs=0, epsrel=1e-13, limit=200)[0]
            assert E.ellippi(n, 2.0, m, mc) == pytest.approx(ref, rel=1e-12)


def test_ellipk_and_f():
    for m in [0.0, 0.1, 0.5, 0.99]:
        assert E.ellipk(m, 1 - m) == pytest.approx(ellipk(m), rel=2e-15)
        for phi in [0.3, 1.2, 4.0, -7.5]:
            assert E.ellipf(phi, m, 1 - m) == pytest.approx(ellipkinc(phi, m), rel=4e-15)
