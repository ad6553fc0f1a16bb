"""Leading modified-Hamiltonian term of symmetric splittings of the free rigid body.

A palindromic splitting ``X1(h/2) X2(h/2) ... Xk(h) ... X2(h/2) X1(h/2)`` of
``T = X1 + ... + Xk`` into quadratic pieces ``Xi = m^T D_i m / 2`` (``D_i``
diagonal) exactly preserves a modified Hamiltonian ``T + h^2 H3 + O(h^4)`` with

    H3 = sum_{i<k} [ -(1/24) {Xi, {Xi, Ri}} + (1/12) {Ri, {Ri, Xi}} ],  Ri = X_{i+1} + ... + Xk,

(nested BCH, literature section 1.3; bracket ``{F, G}(m) = -m . (grad F x grad G)``).
The energy error along a run is therefore ``-h^2 [H3(m_n) - H3(m_0)]`` to leading
order, and its size is the range of ``H3`` over the orbit of ``m0``. The orbit's
squares ``u = m^2`` fill the segment ``{u >= 0, sum u = |m|^2, sum u/I = 2T}``, so the
range is found by sampling that segment.

This module is the numerical counterpart of the closed forms in the literature
(checked against them in the tests); :mod:`liebody.registry` uses it to choose the
axis ordering of ``splitting2`` and the base of the compositions.
"""

from __future__ import annotations

import numpy as np


def _bracket(A, B, m):
    """``{a, b}(m)`` for quadratic ``a = m.A.m/2``, ``b = m.B.m/2`` (A, B as diagonals)."""
    return -np.einsum("...i,...i->...", m, np.cross(A * m, B * m))


def _grad_bracket(A, B, m):
    """Gradient of ``{a, b}(m) = -m . (A m x B m)`` for diagonal symmetric ``A``, ``B``."""
    Am, Bm = A * m, B * m
    return -(np.cross(Am, Bm) + A * np.cross(Bm, m) + B * np.cross(m, Am))


def _nested(X, Y, m):
    """``{x, {x, y}}(m)``."""
    return -np.einsum("...i,...i->...", m, np.cross(X * m, _grad_bracket(X, Y, m)))


def h3(pieces: list[np.ndarray], m: np.ndarray) -> np.ndarray:
    """Evaluate ``H3`` of the nested palindromic splitting with the given pieces.

    Parameters
    ----------
    pieces
        Diagonals ``D_i`` (length-3 arrays), outermost piece first, the centre last.
    m
        Points ``(..., 3)``.
    """
    m = np.asarray(m, dtype=float)
    total = np.zeros(m.shape[:-1])
    for i in range(len(pieces) - 1):
        X = np.asarray(pieces[i], dtype=float)
        R = np.sum(pieces[i + 1:], axis=0)
        total += -_nested(X, R, m) / 24.0 + _nested(R, X, m) / 12.0
    return total


def orbit_samples(moments: np.ndarray, m0: np.ndarray, n: int = 257) -> np.ndarray:
    """Points ``m`` (with non-negative components) whose squares span the orbit of ``m0``.

    The free-body invariants ``|m|^2`` and ``2T`` fix ``u = m^2`` to a segment of a line;
    the orbit covers the part with ``u >= 0``. Returns ``(n, 3)`` (a single point for
    steady rotations and spherical bodies, whose orbit in the body frame is a point).
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


def energy_error_constant(pieces: list[np.ndarray], moments, m0) -> float:
    """``max - min`` of ``H3`` over the orbit of ``m0``: ``|dT| <~ h^2 * this``."""
    vals = h3(pieces, orbit_samples(moments, m0))
    return float(np.max(vals) - np.min(vals))
