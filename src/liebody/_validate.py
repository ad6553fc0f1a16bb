"""Input validation shared by the public API.

Every public function converts its inputs with these helpers so that bad input
fails early with a ``ValueError``/``TypeError`` that names the argument and the
rule it broke, instead of producing NaN deep inside a kernel.

Values in messages are printed short (:func:`show`): an integer of more than 15
digits in ``%g`` form (``1e+300``, never its 300 digits), a float as its shortest
repr, anything else cut to a few dozen characters; an array is never printed whole
(the position of its first offending entry is given instead).
"""

from __future__ import annotations

import math
import numbers

import numpy as np

#: Default tolerance on ``| |q| - 1 |`` accepted for a "unit" quaternion.
UNIT_TOL = 1e-10

#: Largest count :func:`as_positive_int` accepts: counts are int64 in the kernels.
INT64_MAX = 2**63 - 1

_SHOW_CHARS = 40


def _short_int(v: int) -> str:
    """``%g``-like form of an integer of any size (``str`` of a huge int is slow, and
    refused beyond 4300 digits)."""
    if abs(v) < 10**15:
        return str(v)
    if abs(v) < 10**300:
        return f"{float(v):.6g}"
    a = abs(v)
    e = int((a.bit_length() - 1) * math.log10(2.0))  # floor(log10 a) or one below it
    if a >= 10 ** (e + 1):
        e += 1
    lead = a // 10 ** (e - 6)  # 7 significant digits, rounded below to 6
    mantissa = f"{lead / 1e6:.6g}"
    if mantissa == "10":
        mantissa, e = "1", e + 1
    return f"{'-' if v < 0 else ''}{mantissa}e+{e}"


def show(value) -> str:
    """``value`` as an error message should print it: short, whatever its size.

    Integers beyond 15 digits in ``%g`` form (``1e+300``), floats as their shortest
    repr (at most 24 characters), arrays and sequences by shape and dtype only, anything
    else as its repr cut to 40 characters.
    """
    if isinstance(value, bool | np.bool_):
        return repr(bool(value))
    if isinstance(value, numbers.Integral):
        return _short_int(int(value))
    if isinstance(value, float | np.floating):
        return repr(float(value))
    if isinstance(value, np.ndarray):
        return f"an array of shape {value.shape} and dtype {value.dtype}"
    if isinstance(value, list | tuple) and len(value) > 8:
        return f"a {type(value).__name__} of length {len(value)}"
    if isinstance(value, numbers.Real):  # Fraction, Decimal, ...: a float is close enough
        try:
            return f"{float(value):.6g}"
        except (OverflowError, ValueError):
            pass
    text = repr(value)
    return text if len(text) <= _SHOW_CHARS else text[: _SHOW_CHARS - 3] + "..."


def _first_nonfinite(arr: np.ndarray) -> str:
    """Where the first NaN or inf of ``arr`` is, and how many there are."""
    bad = ~np.isfinite(arr)
    if arr.ndim == 0:
        return f"got {show(float(arr))}"
    index = tuple(int(i) for i in np.argwhere(bad)[0])
    where = index[0] if len(index) == 1 else index
    count = int(np.count_nonzero(bad))
    return (f"got {show(float(arr[index]))} at index {where} ({count} of {arr.size} "
            f"entries not finite)")


def as_float_array(name: str, value, *, last_dim: int | None = None,
                   shape: tuple[int, ...] | None = None,
                   allow_nonfinite: bool = False) -> np.ndarray:
    """Convert ``value`` to a float64 array and check its shape and finiteness.

    Parameters
    ----------
    name
        Argument name used in error messages.
    value
        Anything ``numpy.asarray`` accepts. Complex, string or object input is
        rejected with a ``TypeError``.
    last_dim
        Required size of the last axis (e.g. 4 for quaternions, 3 for vectors).
    shape
        Required exact shape.
    allow_nonfinite
        If false (default), NaN or infinite entries raise ``ValueError``.
    """
    try:
        arr = np.asarray(value)
    except Exception as exc:  # pragma: no cover - numpy raises many kinds
        raise TypeError(f"{name} must be array-like of real numbers: {exc}") from exc
    if arr.dtype == object and arr.size and all(
            isinstance(v, (int, float, np.integer, np.floating)) for v in arr.flat):
        # numpy keeps an int beyond int64 as an object (10**30 is a float64 all the same)
        try:
            arr = arr.astype(np.float64)
        except OverflowError:
            raise ValueError(f"{name} holds an integer beyond float64's range (about "
                             f"1.8e308)") from None
    if arr.dtype == object or arr.dtype.kind not in "biuf":
        raise TypeError(
            f"{name} must contain real numbers, got dtype {arr.dtype} "
            f"(complex, string and object arrays are not accepted)"
        )
    arr = arr.astype(np.float64, copy=False)
    if shape is not None and arr.shape != tuple(shape):
        raise ValueError(f"{name} must have shape {tuple(shape)}, got {arr.shape}")
    if last_dim is not None and (arr.ndim == 0 or arr.shape[-1] != last_dim):
        raise ValueError(
            f"{name} must have shape (..., {last_dim}) (last axis of length {last_dim}), "
            f"got {arr.shape}"
        )
    if not allow_nonfinite and not (
            all(map(math.isfinite, arr.tolist())) if arr.ndim == 1 and arr.size <= 16
            else bool(np.isfinite(arr).all())):
        raise ValueError(f"{name} must be finite (no NaN or inf), {_first_nonfinite(arr)}")
    return arr


#: plain Python containers and numbers the scalar fast paths take as they are
_SEQUENCES = (list, tuple)
_REALS = (float, int)
#: the dtype the array fast paths take as it is
F64 = np.dtype(np.float64)


def as_unit_quaternion(name: str, value, *, tol: float = UNIT_TOL) -> np.ndarray:
    """Convert to a float64 ``(..., 4)`` array of unit quaternions.

    Quaternions whose norm differs from 1 by more than ``tol`` raise a
    ``ValueError`` that says how to normalise. Accepted quaternions are
    returned renormalised to round-off.
    """
    # the fixed cost of every call: one quaternion as four numbers or a float64 array;
    # a norm within tol of 1 is finite, so it also rules out NaN and inf
    if value.__class__ is np.ndarray:
        if value.shape == (4,) and value.dtype is F64:
            w, x, y, z = value.tolist()
            n = math.sqrt(w * w + x * x + y * y + z * z)
            if n == 1.0:  # (x / 1 is x)
                return value.copy()
            if abs(n - 1.0) <= tol:  # (else the general path below says why)
                return np.array((w / n, x / n, y / n, z / n))
    elif value.__class__ in _SEQUENCES and len(value) == 4 and all(
            v.__class__ in _REALS for v in value):
        try:
            w, x, y, z = (float(v) for v in value)
        except OverflowError:  # an int beyond float64: the general path below says so
            w = x = y = z = math.nan
        n = math.sqrt(w * w + x * x + y * y + z * z)
        if abs(n - 1.0) <= tol:
            return np.array((w / n, x / n, y / n, z / n))
    q = as_float_array(name, value, last_dim=4)
    if q.ndim == 1:  # one quaternion: scalar arithmetic (the fixed cost of every call)
        w, x, y, z = q.tolist()
        n = math.sqrt(w * w + x * x + y * y + z * z)
        if not abs(n - 1.0) <= tol:
            raise ValueError(
                f"{name} must be a unit quaternion (w, x, y, z), scalar first: "
                f"| |q| - 1 | = {abs(n - 1.0):.3e} exceeds the tolerance {tol:.1e}. "
                f"Normalise it first, e.g. with liebody.quaternion.normalize(q).")
        return q / n
    norm = np.linalg.norm(q, axis=-1)
    bad = np.abs(norm - 1.0) > tol
    if np.any(bad):
        worst = float(np.max(np.abs(norm - 1.0)))
        raise ValueError(
            f"{name} must be a unit quaternion (w, x, y, z), scalar first: "
            f"| |q| - 1 | = {worst:.3e} exceeds the tolerance {tol:.1e}. "
            f"Normalise it first, e.g. with liebody.quaternion.normalize(q)."
        )
    return q / norm[..., None]


def as_positive_float(name: str, value, *, allow_zero: bool = False) -> float:
    """A finite real scalar that is > 0 (or >= 0 with ``allow_zero``)."""
    if type(value) is float and 0.0 < value < math.inf:  # the common case, at once
        return value
    if isinstance(value, bool) or not isinstance(value, numbers.Real | np.floating | np.integer):
        raise TypeError(f"{name} must be a real number, got {type(value).__name__}")
    try:
        v = float(value)
    except OverflowError:  # an integer beyond float64
        raise ValueError(f"{name} must be finite, got {show(value)}") from None
    if not np.isfinite(v):
        raise ValueError(f"{name} must be finite, got {show(v)}")
    if allow_zero:
        if v < 0:
            raise ValueError(f"{name} must be >= 0, got {show(v)}")
    elif v <= 0:
        raise ValueError(f"{name} must be > 0, got {show(v)}")
    return v


def as_positive_int(name: str, value) -> int:
    """A positive integer up to :data:`INT64_MAX` (bools and non-integral floats are
    rejected; counts are 64-bit integers in the kernels)."""
    if type(value) is int and 0 < value <= INT64_MAX:  # the common case, at once
        return value
    if isinstance(value, bool | np.bool_):
        raise TypeError(f"{name} must be a positive integer, got a bool")
    if isinstance(value, numbers.Integral):
        v = int(value)
    elif isinstance(value, numbers.Real) and _is_whole(value):
        v = int(value)  # 1e6 written as a float is accepted: its value is an integer
    else:
        raise ValueError(f"{name} must be a positive integer, got {show(value)}")
    if v <= 0:
        raise ValueError(f"{name} must be a positive integer, got {show(v)}")
    if v > INT64_MAX:
        raise ValueError(f"{name} must be at most {show(INT64_MAX)} (2**63 - 1, a 64-bit "
                         f"integer), got {show(v)}")
    return v


def _is_whole(value) -> bool:
    """Whether a real number is an integer (exactly: a Fraction 10**300/3 is not)."""
    try:
        return bool(value == math.floor(value))
    except (OverflowError, ValueError, TypeError):  # inf, nan
        return False


def clock_origin(name: str, value, dt: float) -> float:
    """``value`` as the clock's origin (a finite number), or the error naming ``name``;
    refused where ``value + dt == value`` in float64: the clock could not advance (the
    ``t0`` of integrate() and the Stepper, the Stepper's ``t``)."""
    t = float(as_float_array(name, value, shape=()))
    if t + dt == t:
        raise ValueError(
            f"{name} = {t!r} and dt = {dt!r}: {name} + dt == {name} in float64 (times near "
            f"{name} are {math.ulp(t):.3g} apart), so the clock could not advance. Measure "
            f"the time from a later origin (subtract a reference time from {name}), or use a "
            f"dt above {0.5 * math.ulp(t):.3g}")
    return t
