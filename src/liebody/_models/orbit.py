"""Orbit kernels: where a source of gravity is, seen from the body, at time ``t``.

An orbit is a row of numbers whose first is its kind:

* :data:`KEPLER` (:data:`KEPLER_WIDTH` numbers), ``(KEPLER, e, n, a, b, M0, P1, P2, P3,
  Q1, Q2, Q3)``: eccentricity, mean motion, semi-major axis, semi-minor axis
  ``a sqrt(1 - e^2)``, mean anomaly at ``t = 0``, and the unit vectors ``P`` (to
  pericentre) and ``Q`` (90 degrees ahead in the direction of motion) of the orbital
  plane in the inertial frame. The position is ``a (cos E - e) P + b sin E Q`` with
  Kepler's equation ``E - e sin E = M``, ``M = M0 + n t``; a circular orbit is ``e = 0``
  (``E = M``, its sine and cosine by one polynomial call).
* :data:`TABLE` (``TABLE_HEAD + 4 m`` numbers), ``(TABLE, m, p, t_first, t_last,
  r_low)`` then the ``m`` sample times (increasing), and the ``m`` values of ``x``, of
  ``y`` and of ``z``: positions sampled at given times, interpolated by the Lagrange
  polynomial through the ``p`` samples nearest the interval that holds ``t`` (``p``
  even; centred, shifted inwards at the ends of the table), of order ``p`` (error
  ``O(h^p)``). ``r_low`` is a lower bound on the interpolant's distance (the torque
  bound's). The interval is found in O(1) on evenly spaced times (its index guessed
  from ``t``), by bisection otherwise. A time outside ``[t_first, t_last]`` (or NaN)
  gives NaN: the torque is not finite and the run stops there.

:func:`size` gives a row's length, so that rows of either kind can follow one another
in a model's parameters (the gravity gradient's shared block). Built by :mod:`liebody.orbits`.
"""

from __future__ import annotations

import math

from liebody._kernels._jit import jit
from liebody._kernels.trig import sincos_plain

#: the kinds of orbit (a row's first number)
KEPLER = 0
TABLE = 1
KEPLER_WIDTH = 12
TABLE_HEAD = 6
#: 2 pi in two parts for the reduction of the mean anomaly: ``float64(2 pi)`` and the rest
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
    """``M`` reduced to ``[-pi, pi]``, to within an ulp of ``M`` (measured: at most 0.75
    ulp; ``k 2 pi`` is rounded, the size of the rounding of ``M = M0 + n t`` itself). The
    result may lie outside ``[-pi, pi]`` by that much; from ``|M| ~ 2^53`` on (an ulp of 2)
    the phase is lost and ``M`` is not reduced reliably (a point on the orbit all the
    same)."""
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
    Returns ``E`` in ``[-pi, pi]`` (up to the ulp of ``M`` of :func:`reduce_anomaly`).
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


@jit(inline="always")
def _circular_position(orb, k, t):
    """A circular orbit's position (``e = 0``, ``E = M``): ``sin M`` and ``cos M`` by one
    polynomial call (``trig.sincos_plain``: Cody–Waite reduction, a few ulps, the pair not
    normalised: a position, not a turn) instead of two libm calls, a third of the cost."""
    s, c = sincos_plain(orb[k + 5] + orb[k + 2] * t)
    u, v = orb[k + 3] * c, orb[k + 4] * s
    return (u * orb[k + 6] + v * orb[k + 9], u * orb[k + 7] + v * orb[k + 10],
            u * orb[k + 8] + v * orb[k + 11])


@jit
def _kepler_position(orb, k, t):
    e, n, a, b = orb[k + 1], orb[k + 2], orb[k + 3], orb[k + 4]
    E = eccentric_anomaly(orb[k + 5] + n * t, e)
    s = math.sin(E)
    h = math.sin(0.5 * E)
    ce = (1.0 - e) - 2.0 * h * h  # cos E - e, without cancellation near pericentre
    u, v = a * ce, b * s
    return (u * orb[k + 6] + v * orb[k + 9], u * orb[k + 7] + v * orb[k + 10],
            u * orb[k + 8] + v * orb[k + 11])


@jit
def table_interval(orb, k, t):
    """The interval ``i`` of the table at ``orb[k:]`` with ``t_i <= t <= t_{i+1}``
    (``0 <= i <= m - 2``), ``-1`` for a time outside the table or NaN."""
    m = int(orb[k + 1])
    t0, t1 = orb[k + 3], orb[k + 4]
    if not (t >= t0 and t <= t1):
        return -1
    T = k + TABLE_HEAD
    # the guess is right on evenly spaced times, or one off by rounding
    i = min(int((t - t0) / (t1 - t0) * (m - 1)), m - 2)
    if orb[T + i] <= t:
        if t <= orb[T + i + 1]:
            return i
        if i + 2 < m and t <= orb[T + i + 2]:
            return i + 1
    elif i > 0 and orb[T + i - 1] <= t:
        return i - 1
    lo, hi = 0, m - 1  # t_lo <= t <= t_hi
    while hi - lo > 1:
        mid = (lo + hi) >> 1
        if orb[T + mid] <= t:
            lo = mid
        else:
            hi = mid
    return lo


@jit
def _table_position(orb, k, t):
    i = table_interval(orb, k, t)
    if i < 0:
        return math.nan, math.nan, math.nan
    m, p = int(orb[k + 1]), int(orb[k + 2])
    j = min(max(i - p // 2 + 1, 0), m - p)  # the stencil: samples j .. j + p - 1
    T = k + TABLE_HEAD + j
    x = y = z = 0.0
    for a in range(p):
        ta = orb[T + a]
        num = 1.0
        den = 1.0
        for b in range(p):
            if b != a:
                tb = orb[T + b]
                num *= t - tb
                den *= ta - tb
        w = num / den  # the Lagrange basis polynomial of sample j + a
        x += w * orb[T + m + a]
        y += w * orb[T + 2 * m + a]
        z += w * orb[T + 3 * m + a]
    return x, y, z


@jit(inline="always")
def position(orb, k, t):
    """The position at time ``t`` of the orbit whose row starts at ``orb[k]``."""
    if orb[k] == TABLE:
        return _table_position(orb, k, t)
    if orb[k + 1] == 0.0:
        return _circular_position(orb, k, t)
    return _kepler_position(orb, k, t)


@jit(inline="always")
def size(orb, k):
    """The length of the orbit row that starts at ``orb[k]``."""
    if orb[k] == TABLE:
        return TABLE_HEAD + 4 * int(orb[k + 1])
    return KEPLER_WIDTH


@jit
def min_distance(orb, k):
    """A lower bound on ``|r(t)|`` over all times (over the table's span for a table):
    the pericentre distance ``a (1 - e)``, or a table's ``r_low``."""
    if orb[k] == TABLE:
        return orb[k + 5]
    return orb[k + 3] * (1.0 - orb[k + 1])


@jit
def positions(orb, t, out):
    """``out[i] = position(orb, 0, t[i])`` (for Python callers)."""
    for i in range(t.shape[0]):
        out[i, 0], out[i, 1], out[i, 2] = position(orb, 0, t[i])
