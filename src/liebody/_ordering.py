"""Which axis ordering? The leading modified-Hamiltonian term of free-body splittings.

A palindromic splitting ``X1(h/2) X2(h/2) ... Xk(h) ... X2(h/2) X1(h/2)`` of
``T = X1 + ... + Xk`` into quadratic pieces ``Xi = m^T D_i m / 2`` (``D_i``
diagonal) exactly preserves a modified Hamiltonian ``T + h^2 H3 + O(h^4)`` with

    H3 = sum_{i<k} [ -(1/24) {Xi, {Xi, Ri}} + (1/12) {Ri, {Ri, Xi}} ],  Ri = X_{i+1} + ... + Xk,

(nested Baker–Campbell–Hausdorff formula; Hairer, Lubich & Wanner, *Geometric Numerical
Integration*, 2006, sect. III.5; bracket ``{F, G}(m) = -m . (grad F x grad G)``).
The energy error along a run is therefore ``-h^2 [H3(m_n) - H3(m_0)]`` to leading
order, and its size is the range of ``H3`` over the orbit of ``m0``. The orbit's
squares ``u = m^2`` fill the segment ``{u >= 0, sum u = |m|^2, sum u/I = 2T}``, so the
range is found by sampling that segment.

This module is the numerical counterpart of the closed forms of Fassò (2003) and
McLachlan (1993) (checked against them in the tests); the splitting recipes of
``liebody._plan`` use :func:`best_axis_ordering` and :func:`best_sr2_variant` to
choose the axis ordering of ``splitting2`` and the base of the compositions.
"""

from __future__ import annotations

import functools
import itertools
import math

import numpy as np


def _cross(a, b):
    """Cross product over the last axis (cheaper than ``np.cross`` for small inputs)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def h3_vector(pieces: list[np.ndarray]) -> np.ndarray:
    """The vector ``V`` with ``H3(m) = V . w(m^2)`` (see :func:`h3`), ``(..., 3)``.

    For quadratic pieces ``X = a . m^2 / 2``, ``Y = b . m^2 / 2`` the bracket is a cubic,
    ``{X, Y} = -s(a x b) m1 m2 m3`` with ``s(v) = v1 + v2 + v3``, and one more bracket
    gives ``{X, {X, Y}} = s(a x b) a . w(u)``, ``u = m^2``, ``w(u) = (u1 u3 - u1 u2,
    u1 u2 - u2 u3, u2 u3 - u1 u3)``. Summed over the levels ``i`` (piece ``a_i``, the
    rest ``r_i``): ``V = sum_i s(a_i x r_i) (-a_i / 24 - r_i / 12)``.
    """
    V = 0.0
    for i in range(len(pieces) - 1):
        a = np.asarray(pieces[i], dtype=float)
        r = np.sum(np.asarray(pieces[i + 1:], dtype=float), axis=0)
        s = np.sum(_cross(a, r), axis=-1)
        V = V + s[..., None] * (-a / 24.0 - r / 12.0)
    return np.asarray(V)


def _w(u: np.ndarray) -> np.ndarray:
    """``w(u) = (u1 u3 - u1 u2, u1 u2 - u2 u3, u2 u3 - u1 u3)`` over the last axis."""
    u1, u2, u3 = u[..., 0], u[..., 1], u[..., 2]
    return np.stack([u1 * (u3 - u2), u2 * (u1 - u3), u3 * (u2 - u1)], axis=-1)


def h3(pieces: list[np.ndarray], m: np.ndarray) -> np.ndarray:
    """Evaluate ``H3`` of the nested palindromic splitting with the given pieces.

    ``H3`` is a quadratic form in ``u = m^2``: ``H3 = V . w(u)`` (:func:`h3_vector`),
    the closed form of the nested brackets for diagonal pieces.

    Parameters
    ----------
    pieces
        Diagonals ``D_i`` (arrays ``(..., 3)`` broadcasting against ``m``), outermost
        piece first, the centre last.
    m
        Points ``(..., 3)``.
    """
    m = np.asarray(m, dtype=float)
    return np.sum(h3_vector(pieces) * _w(m * m), axis=-1)


def orbit_samples(moments: np.ndarray, m0: np.ndarray, n: int = 3) -> np.ndarray:
    """Points ``m`` (with non-negative components) whose squares span the orbit of ``m0``.

    The free-body invariants ``|m|^2`` and ``2T`` fix ``u = m^2`` to a segment of a line;
    the orbit covers the part with ``u >= 0``. Returns ``(n, 3)`` points equally spaced
    in ``u`` (a single point for steady rotations and spherical bodies, whose orbit in
    the body frame is a point).
    """
    inv = 1.0 / np.asarray(moments, dtype=float)
    u0 = np.asarray(m0, dtype=float) ** 2
    d = np.cross(np.ones(3), inv)
    dn = np.linalg.norm(d)
    if dn == 0.0 or not np.any(u0):
        return np.sqrt(u0)[None, :]
    d = d / dn
    lo, hi = -np.inf, np.inf
    for i in range(3):
        if d[i] > 1e-14:
            lo, hi = max(lo, -u0[i] / d[i]), hi
        elif d[i] < -1e-14:
            hi = min(hi, -u0[i] / d[i])
    if not (np.isfinite(lo) and np.isfinite(hi)) or hi <= lo:
        return np.sqrt(u0)[None, :]
    s = np.linspace(lo, hi, n)
    u = np.clip(u0[None, :] + s[:, None] * d[None, :], 0.0, None)
    return np.sqrt(u)


def orbit_segments(moments: np.ndarray, m0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`orbit_samples` for many orbits at once: ``(N, 3, 3)`` samples and a mask.

    Row ``i`` holds three points equally spaced in ``u = m^2`` along the orbit of
    ``m0[i]`` for the moments ``moments[i]``; ``point[i]`` is true where the orbit is a
    single point (its three samples are then that point).
    """
    inv = 1.0 / np.asarray(moments, dtype=float)
    u0 = np.asarray(m0, dtype=float) ** 2
    d = _cross(np.ones_like(inv), inv)
    dn = np.linalg.norm(d, axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        d = d / dn[:, None]
        bound = -u0 / d
    lo = np.max(np.where(d > 1e-14, bound, -np.inf), axis=-1)
    hi = np.min(np.where(d < -1e-14, bound, np.inf), axis=-1)
    point = ((dn == 0.0) | ~np.any(u0, axis=-1) | ~(np.isfinite(lo) & np.isfinite(hi))
             | (hi <= lo))
    lo, hi = np.where(point, 0.0, lo), np.where(point, 0.0, hi)
    d = np.where(point[:, None], 0.0, d)
    s = lo[:, None] + (hi - lo)[:, None] * np.array([0.0, 0.5, 1.0])  # (N, 3)
    u = np.clip(u0[:, None, :] + s[:, :, None] * d[:, None, :], 0.0, None)
    return np.sqrt(u), point


def _quadratic_range(f0, f1, f2):
    """Range over ``[0, 1]`` of the quadratic through ``f(0), f(1/2), f(1)``."""
    a = 2.0 * (f0 - 2.0 * f1 + f2)  # f(s) = a s^2 + b s + f0
    b = f2 - f0 - a
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(a != 0.0, -b / (2.0 * a), -1.0)
    inside = (s > 0.0) & (s < 1.0)
    fv = np.where(inside, f0 + s * (b + a * s), f0)
    hi = np.maximum(np.maximum(f0, f2), fv)
    lo = np.minimum(np.minimum(f0, f2), fv)
    return hi - lo


def energy_error_constants(pieces: list[np.ndarray], moments, m0) -> np.ndarray:
    """``max - min`` of ``H3`` over the orbit of ``m0``, for a batch of splittings.

    ``pieces[i]`` has shape ``(B, 3)``: nesting level ``i`` of ``B`` splittings. The
    energy error of a run is ``|dT| <~ h^2 * constant``.

    ``H3`` is a quadratic form in ``u = m^2`` and ``u`` is affine along the orbit's
    segment, so ``H3`` is a quadratic in the segment parameter: three samples determine
    it, and its range is taken exactly from the end points and the vertex.
    """
    batch = [np.asarray(p, dtype=float)[:, None, :] for p in pieces]
    samples = orbit_samples(moments, m0, 3)
    if samples.shape[0] == 1:
        return np.zeros(batch[0].shape[0])
    f0, f1, f2 = np.moveaxis(h3(batch, samples), -1, 0)  # at s = 0, 1/2, 1
    return _quadratic_range(f0, f1, f2)


def energy_error_constant(pieces: list[np.ndarray], moments, m0) -> float:
    """``max - min`` of ``H3`` over the orbit of ``m0`` for one splitting."""
    return float(energy_error_constants([np.asarray(p)[None, :] for p in pieces],
                                        moments, m0)[0])


# ----------------------------------------------------------------------------------------
# the orderings of the two second-order splittings, scored on an orbit
# ----------------------------------------------------------------------------------------

#: the six orderings (permutations of the body axes)
ORDERINGS = tuple(itertools.permutations(range(3)))


def axis_pieces(moments, ordering) -> list[np.ndarray]:
    """Diagonals of ``T_a, T_b, T_c`` (``T_k = m_k^2 / (2 I_k)``) for ``a-b-c-b-a``."""
    pieces = []
    for i in ordering:
        d = np.zeros(3)
        d[i] = 1.0 / moments[i]
        pieces.append(d)
    return pieces


def sr2_rates(moments, variant) -> tuple[float, float]:
    """Rates of SR2 variant ``(a, b, c)``: ``R = r_b m_b^2/2`` and the ``m_c^2/2`` part of ``S``.

    ``S = |m|^2 / (2 I_a) + (1/I_c - 1/I_a) m_c^2 / 2`` is a symmetric body (exact,
    trig only) and ``R = (1/I_b - 1/I_a) m_b^2 / 2`` the rest; the step is
    ``R(h/2) S(h) R(h/2)`` (Touma & Wisdom 1994; Hairer & Vilmart 2006).
    """
    a, b, c = variant
    return 1.0 / moments[b] - 1.0 / moments[a], 1.0 / moments[c] - 1.0 / moments[a]


def sr2_pieces(moments, variant) -> list[np.ndarray]:
    """Diagonals of ``R`` and ``S`` for SR2 variant ``(a, b, c)``."""
    a, b, c = variant
    rate_r, rate_c = sr2_rates(moments, variant)
    R = np.zeros(3)
    R[b] = rate_r
    S = np.full(3, 1.0 / moments[a])
    S[c] += rate_c
    return [R, S]


@functools.lru_cache(maxsize=256)
def _best(pieces_of, moments: tuple, u0: tuple) -> tuple[tuple[int, int, int], float]:
    """The ordering with the smallest energy-error constant, and that constant.

    Cached on (splitting family, moments, ``m0^2``): the orbit, hence the choice,
    depends on nothing else, and repeated runs from one initial state skip the set-up.
    The same arithmetic as :func:`best_orderings` (one body), so a body of an ensemble
    gets the choice it gets alone.
    """
    best = _best_scalar(_one_body_h3_rows(pieces_of, moments), _one_orbit_w(moments, u0))
    if best is not None:
        return best
    k, scores = _best_rows(pieces_of, np.array([moments]), np.sqrt(np.array([u0])),
                           _one_orbit(moments, u0), _one_body_h3(pieces_of, moments))
    return ORDERINGS[int(k[0])], float(scores[0])


@functools.lru_cache(maxsize=256)
def _one_body_direction(moments: tuple) -> tuple | None:
    """The direction in ``u = m^2`` of one body's orbit segments (:func:`orbit_segments`)
    as numbers, and the signs that pick their bounds; ``None`` where every orbit is a
    point (a sphere)."""
    inv = 1.0 / np.array([moments])
    d = _cross(np.ones_like(inv), inv)
    dn = np.linalg.norm(d, axis=-1)
    if dn[0] == 0.0:
        return None
    d = (d / dn[:, None])[0].tolist()
    return d, [1 if v > 1e-14 else -1 if v < -1e-14 else 0 for v in d]


@functools.lru_cache(maxsize=256)
def _one_body_h3_rows(pieces_of, moments: tuple) -> list:
    """:func:`_one_body_h3` as numbers: the ``H3`` vector of every ordering."""
    return _one_body_h3(pieces_of, moments)[:, 0, :].tolist()


@functools.lru_cache(maxsize=256)
def _one_orbit_w(moments: tuple, u0: tuple):
    """What :func:`_best_rows` scores every splitting family on, for one body's orbit, in
    Python numbers: ``w`` of the three samples and the squared norm (``(W, g2)``), ``()``
    for an orbit that is a point, ``None`` where a number is not finite. The same
    floating-point operations in the same order as :func:`orbit_segments` and
    :func:`_best_rows` (the sums of three terms left to right as numpy's), so the same
    bits."""
    direction = _one_body_direction(moments)
    m = [math.sqrt(v) for v in u0]
    u = [v * v for v in m]  # (orbit_segments squares the momenta it is given)
    g2 = (u[0] + u[1]) + u[2]
    point = direction is None or not (u[0] or u[1] or u[2])
    if not point:
        d, sides = direction
        lo, hi = -math.inf, math.inf
        for i in range(3):
            if sides[i]:
                bound = -u[i] / d[i]
                if sides[i] > 0:
                    lo = bound if bound > lo else lo
                else:
                    hi = bound if bound < hi else hi
        point = not (math.isfinite(lo) and math.isfinite(hi)) or hi <= lo
    if point:  # a steady rotation (or a sphere's orbit)
        return ()
    if not math.isfinite(g2):
        return None
    g2 = g2 if g2 > 0.0 else 1.0
    width = hi - lo
    W = []
    for c in (0.0, 0.5, 1.0):
        s = lo + width * c
        w = []
        for i in range(3):
            x = u[i] + s * d[i]
            x = math.sqrt(x if x > 0.0 else 0.0)
            w.append((x * x) / g2)
        u1, u2, u3 = w
        W.append((u1 * (u3 - u2), u2 * (u1 - u3), u3 * (u2 - u1)))
    return W, g2


def _best_scalar(V: list, orbit) -> tuple[tuple[int, int, int], float] | None:
    """:func:`_best_rows` of one body in Python numbers (``V``: :func:`_one_body_h3_rows`,
    ``orbit``: :func:`_one_orbit_w`): the same floating-point operations in the same
    order, ``max``/``min`` giving the second of equal numbers as ``np.maximum``/
    ``np.minimum``, the first of equal scores as ``np.argmin``, so the same choice and
    score bits at a fraction of the cost of numpy's calls on arrays of one row. ``None``
    where a number is not finite (extreme moments or momenta): :func:`_best_rows` then
    decides, with its own rules for infinities and NaN."""
    if orbit is None:
        return None
    if not orbit:  # a point: every ordering scores 0
        return ORDERINGS[0], 0.0
    ((a0, a1, a2), (b0, b1, b2), (c0, c1, c2)), g2 = orbit
    best_k, best = 0, math.inf
    for k, (v0, v1, v2) in enumerate(V):
        f0 = ((v0 * a0 + v1 * a1) + v2 * a2) * g2 * g2
        f1 = ((v0 * b0 + v1 * b1) + v2 * b2) * g2 * g2
        f2 = ((v0 * c0 + v1 * c1) + v2 * c2) * g2 * g2
        a = 2.0 * ((f0 - 2.0 * f1) + f2)
        b = (f2 - f0) - a
        fv = f0
        if a != 0.0:
            s = -b / (2.0 * a)
            if 0.0 < s < 1.0:
                fv = f0 + s * (b + a * s)
        hi = f0 if f0 > f2 else f2
        hi = hi if hi > fv else fv
        lo = f0 if f0 < f2 else f2
        lo = lo if lo < fv else fv
        score = hi - lo
        if not math.isfinite(score):
            return None
        if score < best:
            best_k, best = k, score
    return ORDERINGS[best_k], best


@functools.lru_cache(maxsize=256)
def _one_orbit(moments: tuple, u0: tuple) -> tuple[np.ndarray, np.ndarray]:
    """:func:`orbit_segments` of one body, shared by the splitting families (read-only)."""
    out = orbit_segments(np.array([moments]), np.sqrt(np.array([u0])))
    for a in out:
        a.flags.writeable = False
    return out


@functools.lru_cache(maxsize=256)
def _one_body_h3(pieces_of, moments: tuple) -> np.ndarray:
    """:func:`h3_vector` of every ordering of one body: it depends on the moments only, so
    a new initial state of the same body reuses it (read-only)."""
    V = h3_vector(_levels(pieces_of, np.array([moments])))
    V.flags.writeable = False
    return V


def _key(moments, m0) -> tuple[tuple, tuple]:
    if (moments.__class__ is np.ndarray and m0.__class__ is np.ndarray
            and moments.dtype == np.float64 and m0.dtype == np.float64):
        return tuple(moments.tolist()), tuple(float(v) ** 2 for v in m0.tolist())
    return tuple(float(v) for v in moments), tuple(float(v) ** 2 for v in m0)


def best_axis_ordering(moments, m0) -> tuple[tuple[int, int, int], float]:
    """The axis ordering ``(a, b, c)`` of ``a-b-c-b-a`` with the smallest energy-error constant.

    Returns the ordering and its constant (the range of ``H3`` over the orbit of ``m0``).
    """
    return _best(axis_pieces, *_key(moments, m0))


def best_sr2_variant(moments, m0) -> tuple[tuple[int, int, int], float]:
    """The SR2 variant with the smallest energy-error constant (0 for a symmetric body)."""
    return _best(sr2_pieces, *_key(moments, m0))


def _levels(pieces_of, moments: np.ndarray) -> list[np.ndarray]:
    """The pieces of every ordering for every body: level ``l`` has shape ``(6, N, 3)``."""
    n = moments.shape[0]
    inv = 1.0 / moments
    if pieces_of is axis_pieces:
        levels = [np.zeros((6, n, 3)) for _ in range(3)]
        for o, order in enumerate(ORDERINGS):
            for lev, k in zip(levels, order, strict=True):
                lev[o, :, k] = inv[:, k]
        return levels
    if pieces_of is sr2_pieces:
        R, S = np.zeros((6, n, 3)), np.zeros((6, n, 3))
        for o, (a, b, c) in enumerate(ORDERINGS):
            R[o, :, b] = inv[:, b] - inv[:, a]
            S[o] = inv[:, a, None]
            S[o, :, c] += inv[:, c] - inv[:, a]
        return [R, S]
    raise ValueError(f"unknown splitting family {pieces_of!r}")  # pragma: no cover


#: bodies whose ordering choice is computed at once (bounds the temporaries)
ROWS_AT_ONCE = 8192


def best_orderings(pieces_of, moments, m0) -> tuple[np.ndarray, np.ndarray]:
    """:func:`best_axis_ordering` (``pieces_of = axis_pieces``) or :func:`best_sr2_variant`
    (``sr2_pieces``) for many bodies at once: the index into :data:`ORDERINGS` and the
    energy-error constant of each body, arrays ``(N,)``."""
    if (moments.__class__ is np.ndarray and m0.__class__ is np.ndarray
            and moments.shape == m0.shape == (1, 3)):  # one body (Bodies' rows), at once
        order, score = _best(pieces_of, *_key(moments[0], m0[0]))
        return np.array([ORDERINGS.index(order)]), np.array([score])
    moments = np.atleast_2d(np.asarray(moments, dtype=float))
    m0 = np.atleast_2d(np.asarray(m0, dtype=float))
    if moments.shape[0] == 1 and m0.shape[0] == 1:  # one body: the cached route
        order, score = _best(pieces_of, *_key(moments[0], m0[0]))
        return np.array([ORDERINGS.index(order)]), np.array([score])
    moments, m0 = np.broadcast_arrays(moments, m0)
    n = moments.shape[0]
    if n <= ROWS_AT_ONCE:
        return _best_rows(pieces_of, moments, np.abs(m0))
    # in chunks of bodies: the temporaries (about 1.2 kB a body) stay bounded, and every
    # body's result is the same bits (the arithmetic is per body, in a fixed order)
    order = np.empty(n, dtype=np.int64)
    score = np.empty(n)
    for a in range(0, n, ROWS_AT_ONCE):
        b = min(n, a + ROWS_AT_ONCE)
        order[a:b], score[a:b] = _best_rows(pieces_of, moments[a:b], np.abs(m0[a:b]))
    return order, score


def _best_rows(pieces_of, moments: np.ndarray, m0: np.ndarray, segments=None, V=None):
    """The best ordering of each body and its score; ``segments`` (the orbits' samples)
    and ``V`` (the ``H3`` vectors) may be given when known, with the same values."""
    samples, point = orbit_segments(moments, m0) if segments is None else segments
    if V is None:
        V = h3_vector(_levels(pieces_of, moments))  # (6, N, 3)
    # H3 is homogeneous of degree 4 in m: evaluate it on m / |m0| and scale back by
    # |m0|^2 twice, so that moments and momenta near the ends of float64 do not overflow
    g2 = np.sum(m0 * m0, axis=-1)
    g2 = np.where(g2 > 0.0, g2, 1.0)[None, :, None]
    unit = samples * samples / g2[0, :, :, None]
    W = _w(unit)[None]  # (1, N, 3 samples, 3)
    V = V[:, :, None, :]  # (6, N, 1, 3)
    # H3 at the samples, (6, N, 3), summed in one fixed order for any N (a body's score
    # is the same bits in an ensemble as alone)
    f = V[..., 0] * W[..., 0] + V[..., 1] * W[..., 1] + V[..., 2] * W[..., 2]
    f = (f * g2) * g2
    scores = _quadratic_range(f[..., 0], f[..., 1], f[..., 2])
    scores = np.where(point[None, :], 0.0, scores)
    k = np.argmin(scores, axis=0)
    return k, scores[k, np.arange(k.size)]
