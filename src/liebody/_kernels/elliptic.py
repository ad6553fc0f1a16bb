"""Elliptic integrals and Jacobi elliptic functions (numba, float64 scalars).

Written for the exact free-rigid-body flow (:mod:`liebody._kernels.exact`), usable on
their own. Every kernel is ``@jit``, takes and returns float64 scalars
(or tuples of them) and allocates nothing.

Parameters follow the *parameter* convention ``m = k^2`` and, wherever ``m`` may be
close to 1, the caller passes the complementary parameter ``mc = 1 - m`` as well,
computed without cancellation (for the rigid body from P. Leroy's formula for the
complementary parameter, see docs/derivations.md, "Exact free-body flow"). Nothing
here forms ``1 - m`` itself.

Algorithms, error analysis and measured accuracy: docs/derivations.md, section
"Elliptic integrals and Jacobi functions"; sources: docs/references.md.

Contents
--------
carlson_rf(x, y, z)
    Carlson's ``R_F``, duplication algorithm (B. C. Carlson, Numer. Algorithms 10 (1995)
    13-26, algorithm 1) with the degree-5 series, stopped at the relative spread
    ``(3 r)^(1/6)``, ``r = 2^-53``. Measured: <= 7e-16 relative (mpmath).
carlson_rj(x, y, z, p)
    Carlson's ``R_J`` (``p > 0``), Carlson 1995 algorithm 3, with ``R_C(1, 1 + e_m)`` in
    closed form and ``1 + e_m`` formed without the cancellation of the published form
    when ``p << x, y, z``. Measured: <= 5e-15 relative, median 1.5e-16 (mpmath).
landen_chain(k, kc), landen_k(k, nlev, ks), landen_eval(u, k, kc, nlev, ks, kcs, K)
    :func:`jacobi_landen` split into the per-modulus part (chain of moduli, up to 16
    levels, one ``sqrt`` each) and the per-argument part; the exact flow keeps the chain
    in its plan (``landen_chain_into``, ``landen_k_at``, ``landen_eval_at``: the chain
    at an offset of an array).
jacobi_landen(u, k, kc)
    ``(sn, cn, dn, j, K)`` of the *reduced* argument ``u - 2 j K`` in ``[-K, K]`` and
    ``K(k)``: descending Landen (Gauss) transformation (DLMF 22.7.1, A&S 16.12) down to
    ``k_N < 3e-9``, then back up; ``cn`` and ``dn`` rebuilt from ``sn`` where the ascent
    would double their errors, and the quarter-period reflection at the bottom level
    keeps them relatively accurate where they are ``O(k')``. One ``sqrt`` and one
    division per level and one ``sin``/``cos`` pair. Measured absolute error <= 4e-16
    for ``|u| <= 2K`` and all ``1e-300 <= k'^2 <= 1`` (mpmath). ``kc > 0``. Not
    recursive: numba's on-disk cache mis-handles self-recursive functions (segfault /
    unresolved symbol on reload).
jacobi_sncndn(u, m, mc), jacobi_am(u, m, mc)
    ``sn, cn, dn`` of the unreduced argument, and the continuous amplitude
    ``am(u) = j pi + atan2(sn_r, cn_r)`` (``cn_r >= 0`` on the reduced range).
ellipk(m, mc), ellipf(phi, m, mc), ellippi(n, phi, m, mc), ellippi_complete(n, m, mc)
    Legendre integrals via Carlson forms, e.g.
    ``Pi(n; phi | m) = s R_F(c^2, 1 - m s^2, 1) + (n/3) s^3 R_J(c^2, 1 - m s^2, 1, 1 - n s^2)``
    for ``|phi| <= pi/2`` (``s = sin phi``, ``c = cos phi``) and the quasi-periodicity
    ``Pi(n; phi + j pi) = 2 j Pi(n | m) + Pi(n; phi)``; ``n < 1``. ``1 - m s^2`` is
    formed as ``c^2 + mc s^2``.
"""

from __future__ import annotations

import math

from liebody._kernels._jit import jit

# Carlson 1995 termination constants for r = 2^-53 (unit round-off of float64):
# R_F: Q = (3 r)^(-1/6) max|A0 - x|;  R_J: Q = (r/4)^(-1/6) max|A0 - x|.
_RF_Q = (3.0 * 2.0**-53) ** (-1.0 / 6.0)
_RJ_Q = (0.25 * 2.0**-53) ** (-1.0 / 6.0)
_HALF_PI = 0.5 * math.pi
# bottom of the Landen descent: k_N^2 < 1e-17, so sin/cos are exact to round-off
_LANDEN_KMIN = 3.0e-9
_LANDEN_MAXDEPTH = 16


@jit
def carlson_rf(x, y, z):
    """Carlson's symmetric integral ``R_F(x, y, z)``, ``x, y, z >= 0``, at most one zero.

    ``R_F = (1/2) int_0^inf dt / sqrt((t + x)(t + y)(t + z))``. Duplication algorithm of
    Carlson (1995) with the degree-5 series; relative error ~1e-16.
    """
    a0 = (x + y + z) / 3.0
    q = _RF_Q * max(abs(a0 - x), abs(a0 - y), abs(a0 - z))
    a = a0
    x0 = x
    y0 = y
    f = 1.0  # 4^-m
    while q * f >= abs(a):
        sx = math.sqrt(x)
        sy = math.sqrt(y)
        sz = math.sqrt(z)
        lam = sx * sy + sx * sz + sy * sz
        x = 0.25 * (x + lam)
        y = 0.25 * (y + lam)
        z = 0.25 * (z + lam)
        a = 0.25 * (a + lam)
        f *= 0.25
        if f < 1e-30:  # only for degenerate input (two zeros): avoid looping forever
            break
    xx = (a0 - x0) * f / a
    yy = (a0 - y0) * f / a
    zz = -(xx + yy)
    e2 = xx * yy - zz * zz
    e3 = xx * yy * zz
    return (1.0 - 0.1 * e2 + e3 / 14.0 + e2 * e2 / 24.0 - 3.0 * e2 * e3 / 44.0) / math.sqrt(a)


@jit(inner=True)
def _rc1(e, y):
    """``R_C(1, y)`` with ``y = 1 + e > 0``, both supplied (each formed without cancellation).

    ``atan(sqrt e)/sqrt e`` for ``e > 0``; ``atanh(s)/s = log((1 + s)/sqrt y)/s`` with
    ``s = sqrt(-e)`` for ``e < 0`` (exact also as ``y -> 0``); Taylor series
    ``sum (-e)^j / (2 j + 1)`` for ``|e| < 1e-3`` (error < 1e-19).
    """
    if abs(e) < 1e-3:
        return 1.0 - e * (1.0 / 3.0 - e * (0.2 - e * (1.0 / 7.0 - e * (1.0 / 9.0 - e / 11.0))))
    if e > 0.0:
        s = math.sqrt(e)
        return math.atan(s) / s
    s = math.sqrt(-e)
    return math.log((1.0 + s) / math.sqrt(y)) / s


@jit
def carlson_rj(x, y, z, p):
    """Carlson's ``R_J(x, y, z, p)``, ``x, y, z >= 0`` (at most one zero), ``p > 0``.

    ``R_J = (3/2) int_0^inf dt / ((t + p) sqrt((t + x)(t + y)(t + z)))``. Carlson (1995)
    algorithm with ``R_C(1, 1 + e_m)`` in closed form; relative error ~1e-16 (measured
    against ``scipy.special.elliprj``).
    """
    a0 = (x + y + z + 2.0 * p) / 5.0
    delta = (p - x) * (p - y) * (p - z)
    q = _RJ_Q * max(abs(a0 - x), abs(a0 - y), abs(a0 - z), abs(a0 - p))
    a = a0
    x0 = x
    y0 = y
    z0 = z
    f = 1.0  # 4^-m
    f3 = 1.0  # 4^-3m
    acc = 0.0
    while q * f >= abs(a):
        sx = math.sqrt(x)
        sy = math.sqrt(y)
        sz = math.sqrt(z)
        sp = math.sqrt(p)
        lam = sx * sy + sx * sz + sy * sz
        d = (sp + sx) * (sp + sy) * (sp + sz)
        # e_m = 4^-3m delta / d^2 and 1 + e_m = 2 sqrt(p) (p + lam) / d (from
        # d^2 + 4^-3m delta = 2 sqrt(p) (p + lam) d): no cancellation when p << x, y, z
        e = f3 * delta / (d * d)
        acc += f * _rc1(e, 2.0 * sp * (p + lam) / d) / d
        x = 0.25 * (x + lam)
        y = 0.25 * (y + lam)
        z = 0.25 * (z + lam)
        p = 0.25 * (p + lam)
        a = 0.25 * (a + lam)
        f *= 0.25
        f3 *= 0.015625
        if f < 1e-30:
            break
    xx = (a0 - x0) * f / a
    yy = (a0 - y0) * f / a
    zz = (a0 - z0) * f / a
    pp = -0.5 * (xx + yy + zz)
    p2 = pp * pp
    xyz = xx * yy * zz
    e2 = xx * yy + xx * zz + yy * zz - 3.0 * p2
    e3 = xyz + 2.0 * e2 * pp + 4.0 * p2 * pp
    e4 = (2.0 * xyz + e2 * pp + 3.0 * p2 * pp) * pp
    e5 = xyz * p2
    ser = (1.0 - 3.0 * e2 / 14.0 + e3 / 6.0 + 9.0 * e2 * e2 / 88.0 - 3.0 * e4 / 22.0
           - 9.0 * e2 * e3 / 52.0 + 3.0 * e5 / 26.0)
    return f * ser / (a * math.sqrt(a)) + 6.0 * acc


# --------------------------------------------------------------------------------------
# Jacobi elliptic functions
# --------------------------------------------------------------------------------------


@jit(inner=True)
def _landen_step(k, kc):
    """One descending Landen step ``(k, k') -> ((k/(1+k'))^2, 2 sqrt(k')/(1+k'))``.

    Identity once the bottom (``k < 3e-9``) is reached, so that a fixed number of calls
    can be chained without branches in the caller.
    """
    if k < _LANDEN_KMIN:
        return k, kc
    t = k / (1.0 + kc)
    return t * t, 2.0 * math.sqrt(kc) / (1.0 + kc)


@jit
def landen_chain(k, kc):
    """Descending Landen moduli ``k_0 = k, k_1, ..., k_N`` (``N <= 16``).

    Returns ``(N, ks, kcs)`` with ``ks[i] = k_{i+1}`` and ``kcs[i] = k'_i`` for
    ``i < 16`` (16-tuples; entries past ``N`` repeat the bottom values). ``N`` is the
    number of steps until ``k_N < 3e-9``; ``N <= 14`` for every ``k' >= 5e-324``.
    Costs one ``sqrt`` per step; a per-modulus constant, so the exact flow computes it
    once per trajectory.
    """
    c0 = kc
    k1, c1 = _landen_step(k, c0)
    k2, c2 = _landen_step(k1, c1)
    k3, c3 = _landen_step(k2, c2)
    k4, c4 = _landen_step(k3, c3)
    k5, c5 = _landen_step(k4, c4)
    k6, c6 = _landen_step(k5, c5)
    k7, c7 = _landen_step(k6, c6)
    k8, c8 = _landen_step(k7, c7)
    k9, c9 = _landen_step(k8, c8)
    k10, c10 = _landen_step(k9, c9)
    k11, c11 = _landen_step(k10, c10)
    k12, c12 = _landen_step(k11, c11)
    k13, c13 = _landen_step(k12, c12)
    k14, c14 = _landen_step(k13, c13)
    k15, c15 = _landen_step(k14, c14)
    k16, _ = _landen_step(k15, c15)
    ks = (k1, k2, k3, k4, k5, k6, k7, k8, k9, k10, k11, k12, k13, k14, k15, k16)
    kcs = (c0, c1, c2, c3, c4, c5, c6, c7, c8, c9, c10, c11, c12, c13, c14, c15)
    nlev = 0
    kk = k
    while kk >= _LANDEN_KMIN and nlev < _LANDEN_MAXDEPTH:
        kk = ks[nlev]
        nlev += 1
    return nlev, ks, kcs


@jit(inner=True)
def landen_chain_into(k, kc, out, ks0, kcs0):
    """:func:`landen_chain` written into an array: ``out[ks0 + i] = k_{i+1}``,
    ``out[kcs0 + i] = k'_i`` (``i < 16``); returns ``N``. The same numbers as the tuples
    of :func:`landen_chain`, in a loop (the exact flow keeps them in its plan)."""
    c = kc
    kk = k
    for i in range(_LANDEN_MAXDEPTH):
        out[kcs0 + i] = c
        kk, c = _landen_step(kk, c)
        out[ks0 + i] = kk
    nlev = 0
    kk = k
    while kk >= _LANDEN_KMIN and nlev < _LANDEN_MAXDEPTH:
        kk = out[ks0 + nlev]
        nlev += 1
    return nlev


@jit
def landen_k(k, nlev, ks):
    """``K(k) = (pi/2)(1 + k_N^2/4) (1 + k_1) ... (1 + k_N)`` from a Landen chain.

    Relative error ~``N eps``; :func:`ellipk` (Carlson ``R_F``) is accurate to ~1 ulp.
    """
    return landen_k_at(k, nlev, ks, 0)


@jit(inner=True)
def landen_k_at(k, nlev, a, ks0):
    """:func:`landen_k` of the chain ``a[ks0], ..., a[ks0 + N - 1]``."""
    kb = a[ks0 + nlev - 1] if nlev > 0 else k
    kq = _HALF_PI * (1.0 + 0.25 * kb * kb)
    for i in range(nlev):
        kq *= 1.0 + a[ks0 + i]
    return kq


@jit
def landen_eval(u, k, kc, nlev, ks, kcs, kq):
    """Reduced ``(sn, cn, dn, j, K)`` from a precomputed :func:`landen_chain`.

    ``ks``, ``kcs`` may be tuples or float64 arrays. ``kq`` is ``K(k)`` used for the
    reduction modulo ``2K`` (pass ``R_F(0, k'^2, 1)`` when ``|u| > K`` for full accuracy,
    or ``0.0`` to use the chain product :func:`landen_k`). See :func:`jacobi_landen`.
    """
    return landen_eval_at(u, k, kc, nlev, ks, 0, kcs, 0, kq)


@jit(inner=True)
def landen_eval_at(u, k, kc, nlev, ks, ks0, kcs, kcs0, kq):
    """:func:`landen_eval` of the chain ``ks[ks0 + i]``, ``kcs[kcs0 + i]`` (one array may
    hold both, e.g. the exact flow's plan)."""
    kb = ks[ks0 + nlev - 1] if nlev > 0 else k
    kcb = kcs[kcs0 + nlev] if nlev < _LANDEN_MAXDEPTH else math.sqrt(1.0 - kb * kb)
    k2 = kb * kb
    kqb = _HALF_PI * (1.0 + 0.25 * k2)  # K(k_N)
    if kq <= 0.0:
        kq = landen_k_at(k, nlev, ks, ks0)
    # reduce at the top level (error ~ eps |u|), then descend z_{i+1} = z_i / (1 + k_{i+1})
    j = math.floor(u / (2.0 * kq) + 0.5)
    z = u - 2.0 * j * kq
    for i in range(nlev):
        z = z / (1.0 + ks[ks0 + i])
    ar = abs(z)
    if ar <= 0.5 * kqb:
        s = math.sin(z)
        c = math.cos(z)
        d = 1.0 - 0.5 * k2 * s * s
    else:
        # reflection about the quarter period: sn(K - x) = cd x, cn(K - x) = k' sd x,
        # dn(K - x) = k' nd x; keeps cn, dn relatively accurate where they are small.
        xr = kqb - ar
        sx = math.sin(xr)
        cx = math.cos(xr)
        dx = 1.0 - 0.5 * k2 * sx * sx
        s = cx / dx
        if z < 0.0:
            s = -s
        c = kcb * sx / dx
        d = kcb / dx
    # ascend (Gauss transformation, DLMF 22.7.1 with dn rewritten cancellation-free)
    for i in range(nlev - 1, -1, -1):
        k1 = ks[ks0 + i]
        kcp = kcs[kcs0 + i]
        ss = s * s
        inv = 1.0 / (1.0 + k1 * ss)
        one_m_k1 = 2.0 * kcp / (1.0 + kcp)
        s, c, d = (1.0 + k1) * s * inv, c * d * inv, (c * c + one_m_k1 * ss) * inv
        if k1 > 0.05 and s * s <= 0.5:
            # The products above double relative errors per level where k_1 is not small
            # (dn_1 varies); while sn is not close to 1, rebuild cn and dn from sn
            # (relatively accurate) and this level's k' (accurate from the chain).
            c = math.sqrt((1.0 - s) * (1.0 + s))
            d = math.sqrt(c * c + kcp * kcp * s * s)
    return s, c, d, j, kq


@jit
def jacobi_landen(u, k, kc):
    """Reduced Jacobi functions and the quarter period.

    Parameters
    ----------
    u : float
        Argument.
    k, kc : float
        Modulus and complementary modulus, ``k^2 + kc^2 = 1``, ``kc > 0``.

    Returns
    -------
    sn, cn, dn, j, K : float
        ``K = K(k)``; ``j = round(u / 2K)`` (as a float) and ``sn, cn, dn`` are evaluated
        at ``u_r = u - 2 j K`` in ``[-K, K]`` (so ``cn >= 0``). Then
        ``sn(u) = (-1)^j sn(u_r)``, ``cn(u) = (-1)^j cn(u_r)``, ``dn(u) = dn(u_r)``.
        Absolute error ~1e-16 plus the argument error ``|u| eps``; ``cn`` and ``dn`` are
        also relatively accurate near ``u_r = +-K``.
    """
    nlev, ks, kcs = landen_chain(k, kc)
    kq = landen_k(k, nlev, ks)
    if abs(u) > kq:
        kq = carlson_rf(0.0, kc * kc, 1.0)
    return landen_eval(u, k, kc, nlev, ks, kcs, kq)


@jit
def jacobi_sncndn(u, m, mc):
    """``(sn(u|m), cn(u|m), dn(u|m))`` for ``0 <= m <= 1``, ``mc = 1 - m``.

    ``mc == 0`` gives the hyperbolic limit ``(tanh u, sech u, sech u)``.
    """
    if mc <= 0.0:
        e = math.exp(-abs(u))
        sech = 2.0 * e / (1.0 + e * e)
        return math.tanh(u), sech, sech
    s, c, d, j, _ = jacobi_landen(u, math.sqrt(m), math.sqrt(mc))
    if j % 2.0 != 0.0:
        return -s, -c, d
    return s, c, d


@jit
def jacobi_am(u, m, mc):
    """Continuous Jacobi amplitude ``am(u|m)`` (``am(u + 2K) = am(u) + pi``)."""
    if mc <= 0.0:
        return math.atan(math.sinh(u))  # Gudermannian
    s, c, _, j, _ = jacobi_landen(u, math.sqrt(m), math.sqrt(mc))
    return j * math.pi + math.atan2(s, c)


# --------------------------------------------------------------------------------------
# Legendre integrals
# --------------------------------------------------------------------------------------


@jit
def ellipk(m, mc):
    """Complete integral of the first kind ``K(m) = R_F(0, mc, 1)`` (``mc = 1 - m > 0``)."""
    return carlson_rf(0.0, mc, 1.0)


@jit
def ellippi_complete(n, m, mc):
    """Complete integral of the third kind ``Pi(n | m) = R_F(0, mc, 1) + n/3 R_J(0, mc, 1, 1 - n)``.

    ``n < 1``, ``mc = 1 - m > 0``.
    """
    return carlson_rf(0.0, mc, 1.0) + n / 3.0 * carlson_rj(0.0, mc, 1.0, 1.0 - n)


@jit(inner=True)
def _reduce_phi(phi):
    """``phi = j pi + r`` with ``|r| <= pi/2``; returns ``(j, sin r, cos r)``."""
    j = math.floor(phi / math.pi + 0.5)
    r = phi - j * math.pi
    return j, math.sin(r), math.cos(r)


@jit
def ellipf(phi, m, mc):
    """Incomplete integral of the first kind ``F(phi | m)`` for any real ``phi``."""
    j, s, c = _reduce_phi(phi)
    y = c * c + mc * s * s
    res = s * carlson_rf(c * c, y, 1.0)
    if j != 0.0:
        res += 2.0 * j * carlson_rf(0.0, mc, 1.0)
    return res


@jit
def ellippi(n, phi, m, mc):
    """Incomplete integral of the third kind ``Pi(n; phi | m)``, any real ``phi``, ``n < 1``.

    ``Pi = int_0^phi dt / ((1 - n sin^2 t) sqrt(1 - m sin^2 t))`` (A&S 17.2.14 convention,
    as ``scipy``'s Carlson combination and Mathematica's ``EllipticPi[n, phi, m]``).
    """
    j, s, c = _reduce_phi(phi)
    c2 = c * c
    y = c2 + mc * s * s
    res = s * carlson_rf(c2, y, 1.0)
    if s != 0.0:
        res += n / 3.0 * s * s * s * carlson_rj(c2, y, 1.0, 1.0 - n * s * s)
    if j != 0.0:
        res += 2.0 * j * ellippi_complete(n, m, mc)
    return res
