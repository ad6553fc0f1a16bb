"""Unit quaternions: scalar-first ``(w, x, y, z)``, rotating body to space.

A unit quaternion ``q`` represents the rotation ``R(q)`` with
``r_space = R(q) r_body = q (0, r_body) q*``. ``q`` and ``-q`` are the same
rotation; functions that return a canonical representative choose ``w >= 0``.

scipy's :class:`scipy.spatial.transform.Rotation` stores quaternions
**scalar-last** ``(x, y, z, w)``: convert with :func:`to_scipy` and
:func:`from_scipy` (or :func:`to_rotation` / :func:`from_rotation`), never by
passing arrays across directly.

Every function accepts a single quaternion ``(4,)`` or an array ``(..., 4)`` and
broadcasts its arguments like numpy. The arithmetic runs in the numba kernels of
``liebody._kernels.quat`` (compiled on first use, cached on disk).
"""

from __future__ import annotations

import math
import numbers

import numpy as np
from numpy.typing import ArrayLike, NDArray

from liebody._kernels import quat as _k
from liebody._validate import (
    UNIT_TOL,
    as_float_array,
    as_positive_float,
    as_unit_quaternion,
    show,
)

__all__ = [
    "IDENTITY",
    "angle_between",
    "conjugate",
    "exp",
    "from_matrix",
    "from_rotation",
    "from_scipy",
    "inverse",
    "is_unit",
    "log",
    "multiply",
    "normalize",
    "random",
    "rotate",
    "rotate_inverse",
    "slerp",
    "to_matrix",
    "to_rotation",
    "to_scipy",
]

Array = NDArray[np.float64]

#: The identity rotation ``(1, 0, 0, 0)`` (a fresh copy is never needed: it is read-only).
IDENTITY: Array = np.array([1.0, 0.0, 0.0, 0.0])
IDENTITY.flags.writeable = False


def _kernel_array(a: np.ndarray) -> np.ndarray:
    """``a`` as the kernels take it: C-contiguous and writeable (a read-only array, such as
    a Trajectory's, is copied: numba would compile a second version of every kernel for
    read-only input)."""
    return np.require(a, dtype=np.float64, requirements=("C", "W"))


def _rows(*arrays: np.ndarray, dims: tuple[tuple[int, ...], ...], names: tuple[str, ...]):
    """Broadcast the leading (batch) axes and flatten them to one row axis.

    Arguments whose batch axes do not broadcast raise a ``ValueError`` that names them
    (``names``) and gives their shapes.
    """
    batches = [a.shape[: a.ndim - len(d)] for a, d in zip(arrays, dims, strict=True)]
    try:
        batch = np.broadcast_shapes(*batches)
    except ValueError:
        args = ", ".join(f"{n} (shape {a.shape})" for n, a in zip(names, arrays, strict=True))
        lead = ", ".join(str(b) for b in batches)
        raise ValueError(
            f"{args} must broadcast against each other over their leading (batch) axes; "
            f"they are {lead}") from None
    flat = [
        _kernel_array(np.broadcast_to(a, batch + d)).reshape((-1, *d))
        for a, d in zip(arrays, dims, strict=True)
    ]
    return batch, flat


def multiply(p: ArrayLike, q: ArrayLike) -> Array:
    """Hamilton product ``p * q`` (apply ``q`` first, then ``p``: ``R(pq) = R(p) R(q)``).

    Parameters
    ----------
    p, q
        Quaternions, shape ``(..., 4)``, broadcast against each other. They need not
        be unit quaternions.

    Raises
    ------
    ValueError
        A component of the product beyond the largest float64 (``~1.8e308``). Products
        whose components are representable are returned even where the plain sums of
        four terms overflow (those rows are redone in rescaled units).
    """
    p = as_float_array("p", p, last_dim=4)
    q = as_float_array("q", q, last_dim=4)
    batch, (a, b) = _rows(p, q, dims=((4,), (4,)), names=("p", "q"))
    out = np.empty_like(a)
    _k.multiply_rows(a, b, out)
    if not (all(map(math.isfinite, out[0].tolist())) if out.shape[0] == 1
            else np.isfinite(out).all()):
        _multiply_rescaled(a, b, out)
    return out.reshape(batch + (4,))


def _multiply_rescaled(a: np.ndarray, b: np.ndarray, out: np.ndarray) -> None:
    """Redo the rows of ``out = a * b`` that overflowed, in units of powers of two.

    A product whose components are all float64 can still overflow in its sums of four
    terms (``|p_i q_j|`` up to ``|p| |q|``). Each failing row is recomputed as
    ``2^(e_a + e_b) (a / 2^e_a)(b / 2^e_b)`` with ``max |a_i / 2^e_a|`` in ``[1/2, 1)``
    (exact scalings), which cannot overflow; a component beyond the largest float64
    raises ``ValueError``.
    """
    rows = np.flatnonzero(~np.isfinite(out).all(axis=1))
    a, b = a[rows], b[rows]
    _, ea = np.frexp(np.max(np.abs(a), axis=1, keepdims=True))
    _, eb = np.frexp(np.max(np.abs(b), axis=1, keepdims=True))
    scaled = np.empty_like(a)
    _k.multiply_rows(np.ldexp(a, -ea), np.ldexp(b, -eb), scaled)
    with np.errstate(over="ignore"):
        redone = np.ldexp(scaled, ea + eb)
    if not np.isfinite(redone).all():
        i = int(np.flatnonzero(~np.isfinite(redone).all(axis=1))[0])
        big = np.abs(scaled[i]).max()
        log10 = float(np.log10(big) + (ea[i, 0] + eb[i, 0]) * np.log10(2.0))
        raise ValueError(
            f"p * q overflows float64: a component of the product is about "
            f"{10.0 ** (log10 % 1.0):.2g}e+{int(log10 // 1.0)} "
            f"(row {int(rows[i])}), beyond the largest float64 "
            f"{np.finfo(np.float64).max:.3g}; scale p or q down first")
    out[rows] = redone


def conjugate(q: ArrayLike) -> Array:
    """Conjugate ``(w, -x, -y, -z)``; for a unit quaternion this is the inverse rotation."""
    q = as_float_array("q", q, last_dim=4)
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def inverse(q: ArrayLike) -> Array:
    """Multiplicative inverse ``q* / |q|^2`` (any non-zero quaternion).

    Evaluated as ``p* / |p|^2 / 2^e`` with ``p = q / 2^e`` scaled by a power of two (an
    exact scaling) to ``max |p_i|`` in ``[1/2, 1)``, so ``|q|^2`` neither overflows nor
    underflows: every non-zero quaternion whose inverse is a float64 (``|q|`` above
    ``1 / max float ~ 5.6e-309``) gets it to round-off.
    """
    q = as_float_array("q", q, last_dim=4)
    big = np.max(np.abs(q), axis=-1, keepdims=True, initial=0.0)
    if np.any(big == 0.0):
        raise ValueError("q must be non-zero to have an inverse")
    _, e = np.frexp(big)
    p = np.ldexp(q, -e)
    p = p * np.array([1.0, -1.0, -1.0, -1.0]) / np.sum(p * p, axis=-1, keepdims=True)
    with np.errstate(over="ignore"):
        out = np.ldexp(p, -e)
    if not np.all(np.isfinite(out)):
        norm = np.ldexp(np.linalg.norm(np.ldexp(q, -e), axis=-1), e[..., 0])
        raise ValueError(
            f"q's inverse overflows float64: |q| = {float(np.min(norm)):.3g} is below "
            f"1 / max float = {1.0 / np.finfo(np.float64).max:.3g}")
    return out


def rotate(q: ArrayLike, v: ArrayLike) -> Array:
    """Rotate vectors: ``R(q) v`` (body to space when ``v`` is in body coordinates).

    Parameters
    ----------
    q
        Unit quaternions ``(..., 4)``; ``| |q| - 1 | <= 1e-10`` is required.
    v
        Vectors ``(..., 3)``, broadcast against ``q``.
    """
    q = as_unit_quaternion("q", q)
    v = as_float_array("v", v, last_dim=3)
    batch, (a, b) = _rows(q, v, dims=((4,), (3,)), names=("q", "v"))
    out = np.empty_like(b)
    _k.rotate_rows(a, b, out)
    return out.reshape(batch + (3,))


def rotate_inverse(q: ArrayLike, v: ArrayLike) -> Array:
    """Rotate vectors back: ``R(q)^T v`` (space to body when ``v`` is in space coordinates).

    For example ``rotate_inverse(q, [0, 0, 1])`` is the space vertical ``e_z`` seen from
    the body, the direction gravity acts along in a heavy top's body frame.

    Parameters
    ----------
    q
        Unit quaternions ``(..., 4)``; ``| |q| - 1 | <= 1e-10`` is required.
    v
        Vectors ``(..., 3)``, broadcast against ``q``.
    """
    q = as_unit_quaternion("q", q)
    return rotate(q * np.array([1.0, -1.0, -1.0, -1.0]), v)


def to_matrix(q: ArrayLike) -> Array:
    """Rotation matrices ``R(q)`` of shape ``(..., 3, 3)`` (space <- body)."""
    q = as_unit_quaternion("q", q)
    batch, (a,) = _rows(q, dims=((4,),), names=("q",))
    out = np.empty((a.shape[0], 3, 3))
    _k.to_matrix_rows(a, out)
    return out.reshape(batch + (3, 3))


def from_matrix(matrix: ArrayLike, *, tol: float = 1e-9) -> Array:
    """Unit quaternions (``w >= 0``) from rotation matrices, Shepperd's stable method.

    S. W. Shepperd, "Quaternion from rotation matrix", J. Guidance and Control 1 (1978)
    223-224.

    The largest of ``|w|, |x|, |y|, |z|`` is taken from a square root of the trace
    or a diagonal combination and the other three are divided by it, so the result
    is accurate to round-off for every rotation, including angles near 0 and pi.

    Parameters
    ----------
    matrix
        Proper rotation matrices ``(..., 3, 3)``.
    tol
        Accepted deviation ``max |R^T R - 1|`` and ``|det R - 1|`` (a finite number
        ``>= 0``); a matrix that is not a proper rotation within ``tol`` raises
        ``ValueError``.
    """
    tol = as_positive_float("tol", tol, allow_zero=True)
    m = as_float_array("matrix", matrix)
    if m.ndim < 2 or m.shape[-2:] != (3, 3):
        raise ValueError(f"matrix must have shape (..., 3, 3), got {m.shape}")
    orth = np.abs(np.swapaxes(m, -1, -2) @ m - np.eye(3)).max(axis=(-2, -1), initial=0.0)
    det = np.linalg.det(m) if m.size else np.zeros(m.shape[:-2])
    if np.any(orth > tol) or np.any(np.abs(det - 1.0) > tol):
        raise ValueError(
            f"matrix must be a proper rotation (R^T R = 1 and det R = +1 within {tol:g}); "
            f"max |R^T R - 1| = {np.max(orth):.3e}, det = {np.ravel(det)[:3]}..."
        )
    batch = m.shape[:-2]
    flat = _kernel_array(m.reshape(-1, 3, 3))
    out = np.empty((flat.shape[0], 4))
    _k.from_matrix_rows(flat, out)
    return out.reshape(batch + (4,))


#: the largest rotation angle :func:`exp` takes (its square must not overflow)
MAX_ROTATION_ANGLE = 1e150


def exp(rotvec: ArrayLike) -> Array:
    """Exponential map: rotation vector (angle ``|r|`` about ``r/|r|``) to unit quaternion.

    ``exp(r) = (cos(|r|/2), sin(|r|/2) r/|r|)``, exact to round-off near ``r = 0``
    (series for ``sin(a/2)/a``). ``R(exp(r)) = expm(hat(r))``.
    """
    r = as_float_array("rotvec", rotvec, last_dim=3)
    if r.size and float(np.abs(r).max()) > MAX_ROTATION_ANGLE:
        raise ValueError(
            f"rotvec: a rotation angle |r| above {MAX_ROTATION_ANGLE:g} rad (got a component "
            f"of {float(np.abs(r).max()):.3g}); its square overflows, and beyond about 1e16 "
            f"the angle modulo 2 pi is lost to rounding anyway. Reduce the angle modulo "
            f"2 pi first")
    batch = r.shape[:-1]
    flat = _kernel_array(r.reshape(-1, 3))
    out = np.empty((flat.shape[0], 4))
    _k.exp_rows(flat, out)
    return out.reshape(batch + (4,))


def log(q: ArrayLike) -> Array:
    """Logarithm: unit quaternion to rotation vector with angle in ``[0, pi]``.

    Inverse of :func:`exp` on angles ``<= pi``; ``log(q) == log(-q)``. At angle pi
    (``w = 0``), where the rotations by pi about ``n`` and ``-n`` coincide, the vector
    whose first non-zero component is positive is returned.
    """
    q = as_unit_quaternion("q", q)
    batch = q.shape[:-1]
    flat = _kernel_array(q.reshape(-1, 4))
    out = np.empty((flat.shape[0], 3))
    _k.log_rows(flat, out)
    return out.reshape(batch + (3,))


def normalize(q: ArrayLike) -> Array:
    """``q / |q|``, robust to overflow and underflow; the zero quaternion raises."""
    q = as_float_array("q", q, last_dim=4)
    if np.any(np.all(q == 0.0, axis=-1)):
        raise ValueError("q must be non-zero to be normalised")
    batch = q.shape[:-1]
    flat = _kernel_array(q.reshape(-1, 4))
    out = np.empty_like(flat)
    _k.normalize_rows(flat, out)
    return out.reshape(batch + (4,))


def is_unit(q: ArrayLike, tol: float = UNIT_TOL) -> NDArray[np.bool_]:
    """Boolean mask ``| |q| - 1 | <= tol`` (``tol`` a finite number ``>= 0``)."""
    tol = as_positive_float("tol", tol, allow_zero=True)
    q = as_float_array("q", q, last_dim=4, allow_nonfinite=True)
    return np.abs(np.linalg.norm(q, axis=-1) - 1.0) <= tol


def slerp(q0: ArrayLike, q1: ArrayLike, t: ArrayLike) -> Array:
    """Spherical linear interpolation on the short arc: ``q0 exp(t log(q0* q1))``.

    ``t = 0`` gives ``q0``, ``t = 1`` gives ``q1`` up to sign; the angular speed is
    constant in ``t``. ``q0``, ``q1`` and ``t`` broadcast (``t`` over the batch axes).

    ``t`` may lie outside ``[0, 1]`` (extrapolation along the same great circle), but
    the rotation it asks for, ``|t|`` times the angle between ``q0`` and ``q1``, must
    be at most ``MAX_ROTATION_ANGLE`` (the limit of :func:`exp`); a larger one
    raises ``ValueError`` (its square overflows, and beyond about ``1e16`` rad the
    angle modulo ``2 pi`` is lost to rounding anyway). A finite ``t`` is required.
    """
    a = as_unit_quaternion("q0", q0)
    b = as_unit_quaternion("q1", q1)
    t = as_float_array("t", t)
    batch, (a, b, tt) = _rows(a, b, t, dims=((4,), (4,), ()), names=("q0", "q1", "t"))
    if tt.size and float(np.abs(tt).max()) * np.pi > MAX_ROTATION_ANGLE:
        # only then can |t| times an angle in [0, pi] exceed the limit
        r = np.empty_like(a)
        _k.multiply_rows(a * np.array([1.0, -1.0, -1.0, -1.0]), b, r)
        angle = 2.0 * np.arctan2(np.linalg.norm(r[:, 1:], axis=1), np.abs(r[:, 0]))
        turn = np.abs(tt) * angle
        if np.any(turn > MAX_ROTATION_ANGLE):
            i = int(np.argmax(turn))
            raise ValueError(
                f"t: the interpolated rotation |t| * angle(q0, q1) must be at most "
                f"MAX_ROTATION_ANGLE = {MAX_ROTATION_ANGLE:g} rad, got |t| = "
                f"{float(abs(tt[i])):.3g} times an angle of {float(angle[i]):.3g} rad; its "
                f"square overflows, and beyond about 1e16 rad the angle modulo 2 pi is lost "
                f"to rounding anyway")
    out = np.empty_like(a)
    _k.slerp_rows(a, b, tt, out)
    return out.reshape(batch + (4,))


def random(size: int | tuple[int, ...] | None = None,
           rng: np.random.Generator | int | None = None) -> Array:
    """Uniformly (Haar) distributed random unit quaternions with ``w >= 0``.

    Normalised 4-D standard normal vectors are uniform on the 3-sphere, hence
    uniform on SO(3).

    Parameters
    ----------
    size
        Batch shape: a non-negative integer or a tuple of them; ``None`` returns a
        single ``(4,)`` quaternion.
    rng
        A ``numpy.random.Generator``, or what ``numpy.random.default_rng`` takes as a
        seed: ``None``, a non-negative integer, a ``SeedSequence`` or a ``BitGenerator``.

    Raises
    ------
    TypeError
        ``size`` is not ``None``, an integer or a tuple of integers (a float such as
        ``2.5`` or a bool is refused), or ``rng`` is none of the above.
    ValueError
        A negative ``size`` entry or a negative integer seed.
    """
    shape = _random_shape(size)
    if not isinstance(rng, np.random.Generator):
        if not (rng is None or isinstance(rng, np.random.SeedSequence | np.random.BitGenerator)
                or (isinstance(rng, numbers.Integral) and not isinstance(rng, bool | np.bool_))):
            raise TypeError(
                f"rng must be a numpy.random.Generator, None, a non-negative integer seed, a "
                f"SeedSequence or a BitGenerator, got {type(rng).__name__}")
        if isinstance(rng, numbers.Integral) and int(rng) < 0:
            raise ValueError(f"rng: an integer seed must be >= 0, got {show(rng)}")
        rng = np.random.default_rng(rng)
    g = rng.standard_normal(shape + (4,))
    n = np.linalg.norm(g, axis=-1, keepdims=True)
    q = g / n
    return np.where(q[..., :1] < 0.0, -q, q)


def _random_shape(size) -> tuple[int, ...]:
    """The batch shape of :func:`random`'s ``size``, validated."""
    if size is None:
        return ()
    entries = size if isinstance(size, tuple | list) else (size,)
    for n in entries:
        if isinstance(n, bool | np.bool_) or not isinstance(n, numbers.Integral):
            raise TypeError(
                f"size must be None, a non-negative integer or a tuple of them, got "
                f"{show(size)} ({type(n).__name__} entry)")
        if n < 0:
            raise ValueError(f"size must be non-negative (a batch shape), got {show(size)}")
    return tuple(int(n) for n in entries)


def angle_between(p: ArrayLike, q: ArrayLike) -> Array:
    """Angle in ``[0, pi]`` of the rotation ``p* q`` (sign-invariant distance on SO(3))."""
    r = multiply(conjugate(as_unit_quaternion("p", p)), as_unit_quaternion("q", q))
    vec = np.linalg.norm(r[..., 1:], axis=-1)
    return 2.0 * np.arctan2(vec, np.abs(r[..., 0]))


def to_scipy(q: ArrayLike) -> Array:
    """Scalar-first ``(w, x, y, z)`` to scipy's scalar-last ``(x, y, z, w)``."""
    q = as_float_array("q", q, last_dim=4)
    return np.concatenate([q[..., 1:], q[..., :1]], axis=-1)


def from_scipy(q_xyzw: ArrayLike) -> Array:
    """scipy's scalar-last unit quaternions ``(x, y, z, w)`` to scalar-first ``(w, x, y, z)``.

    Like every function here that takes a rotation, it requires unit quaternions,
    ``| |q| - 1 | <= 1e-10`` (``liebody._validate.UNIT_TOL``); anything else raises
    ``ValueError`` (scipy's ``Rotation.from_quat`` normalises silently;
    ``Rotation.as_quat`` returns unit quaternions, which are accepted). The numbers are
    only reordered, bit for bit, sign included: ``from_scipy(to_scipy(q)) == q``.
    """
    q = as_float_array("q_xyzw", q_xyzw, last_dim=4)
    dev = np.abs(np.linalg.norm(q, axis=-1) - 1.0)
    if np.any(dev > UNIT_TOL):
        raise ValueError(
            f"q_xyzw must be scipy's scalar-last unit quaternions (x, y, z, w): "
            f"| |q| - 1 | = {float(np.max(dev)):.3e} exceeds the tolerance {UNIT_TOL:.1e}. "
            f"Normalise it first, or build a Rotation with Rotation.from_quat(q_xyzw), which "
            f"normalises, and convert that with from_rotation")
    return np.concatenate([q[..., 3:], q[..., :3]], axis=-1)


def to_rotation(q: ArrayLike):
    """A :class:`scipy.spatial.transform.Rotation` (scalar-last inside) of ``q``."""
    from scipy.spatial.transform import Rotation

    return Rotation.from_quat(to_scipy(as_unit_quaternion("q", q)))


def from_rotation(rotation) -> Array:
    """Scalar-first unit quaternions of a scipy ``Rotation`` (``w >= 0``).

    For scipy's scalar-last quaternion arrays ``(x, y, z, w)`` use :func:`from_scipy`.
    """
    from scipy.spatial.transform import Rotation

    if not isinstance(rotation, Rotation):
        hint = (" For an array of scipy's scalar-last quaternions (x, y, z, w) use "
                "liebody.quaternion.from_scipy(q_xyzw), or build the Rotation first with "
                "Rotation.from_quat(q_xyzw)." if isinstance(rotation, np.ndarray | list | tuple)
                else "")
        raise TypeError(f"rotation must be a scipy.spatial.transform.Rotation, got "
                        f"{type(rotation).__name__}.{hint}")
    q = from_scipy(rotation.as_quat())
    return np.where(q[..., :1] < 0.0, -q, q)
