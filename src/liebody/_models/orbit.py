"""Orbit kernels: where a source of gravity is, seen from the body, at time ``t``.

An orbit is a row of :data:`WIDTH` numbers, ``(e, n, a, b, M0, P1, P2, P3, Q1, Q2, Q3)``:
eccentricity, mean motion, semi-major axis, semi-minor axis ``a sqrt(1 - e^2)``, mean
anomaly at ``t = 0``, and the unit vectors ``P`` (to pericentre) and ``Q`` (90 degrees
ahead in the direction of motion) of the orbital plane in the inertial frame. The
position is ``a (cos E - e) P + b sin E Q`` with Kepler's equation ``E - e sin E = M``,
``M = M0 + n t``; a circular orbit is ``e = 0`` (``E = M``). Built by
:mod:`liebody.orbits`.
"""

from __future__ import annotations

import math

from liebody._kernels._jit import jit

WIDTH = 11
#: 2 pi in two parts (the first exact in 33 bits) for the reduction of the mean anomaly
_TWO_PI_HI = 6.28318530717958623200e+00
_TWO_PI_LO = 2.44929359829470635445e-16
_MAX_ITER = 200


@jit
def _e_minus_sin(E):
    """``E - sin E`` to full relative accuracy (a series below 1, where it cancels)."""
    if E >= 1.0:
        return E - math.sin(E)
    E2 = E * E
    term = E * E2 / 6.0
    s = term
    k = 3.0
    for _ in range(12):  # E^27 / 27! < 1e-28 E^3 for E < 1
        term = -term * E2 / ((k + 1.0) * (k + 2.0))
        s += term
        k += 2.0
    return s


@jit
def reduce_anomaly(M):
    """``M`` reduced to ``[-pi, pi]`` (two-part 2 pi: exact to about an ulp of ``M``)."""
    if abs(M) <= math.pi:
        return M
    k = math.floor(M / _TWO_PI_HI + 0.5)
    return (M - k * _TWO_PI_HI) - k * _TWO_PI_LO


@jit
def eccentric_anomaly(M, e):
    """Solve Kepler's equation ``E - e sin E = M`` for ``0 <= e < 1`` to round-off.

    ``M`` is reduced to ``[-pi, pi]`` and the odd symmetry used, so ``0 <= M <= pi``,
    where ``f(E) = (1 - e) E + e (E - sin E) - M`` is increasing and convex: Newton's
    method from ``E0 = min(pi, M + e)`` (``f(E0) >= 0``) decreases monotonically to the
    root. ``f`` and ``f' = (1 - e) + 2 e sin^2(E/2)`` are evaluated without cancellation,
    so the root is accurate to a few ulps also for ``e`` near 1 and ``M`` near 0.
    Returns ``E`` in ``[-pi, pi]``.
    """
    M = reduce_anomaly(M)
    if e == 0.0 or M == 0.0:
        return M
    sign = 1.0
    if M < 0.0:
        sign, M = -1.0, -M
    ome = 1.0 - e
    E = min(math.pi, M + e)
    for _ in range(_MAX_ITER):
        f = ome * E + e * _e_minus_sin(E) - M
        s = math.sin(0.5 * E)
        d = ome + 2.0 * e * s * s
        step = f / d
        En = E - step
        if En < 0.0:
            En = 0.5 * E  # (round-off only: the iteration stays in [0, pi])
        if abs(step) <= 4.4e-16 * En or En == E:
            E = En
            break
        E = En
    return sign * E


@jit
def position(orb, k, t):
    """The position at time ``t`` of the orbit stored at ``orb[k : k + WIDTH]``."""
    e, n, a, b = orb[k], orb[k + 1], orb[k + 2], orb[k + 3]
    E = eccentric_anomaly(orb[k + 4] + n * t, e)
    s = math.sin(E)
    h = math.sin(0.5 * E)
    ce = (1.0 - e) - 2.0 * h * h  # cos E - e, without cancellation near pericentre
    u, v = a * ce, b * s
    return (u * orb[k + 5] + v * orb[k + 8], u * orb[k + 6] + v * orb[k + 9],
            u * orb[k + 7] + v * orb[k + 10])


@jit
def positions(orb, t, out):
    """``out[i] = position(orb, 0, t[i])`` (for Python callers)."""
    for i in range(t.shape[0]):
        out[i, 0], out[i, 1], out[i, 2] = position(orb, 0, t[i])
