"""Input validation shared by the public API.

Every public function converts its inputs with these helpers so that bad input
fails early with a ``ValueError``/``TypeError`` that names the argument and the
rule it broke, instead of producing NaN deep inside a kernel.
"""

from __future__ import annotations

import numbers

import numpy as np

#: Default tolerance on ``| |q| - 1 |`` accepted for a "unit" quaternion.
UNIT_TOL = 1e-10


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
    if not allow_nonfinite and not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite (no NaN or inf), got {value!r}")
    return arr


def as_unit_quaternion(name: str, value, *, tol: float = UNIT_TOL) -> np.ndarray:
    """Convert to a float64 ``(..., 4)`` array of unit quaternions.

    Quaternions whose norm differs from 1 by more than ``tol`` raise a
    ``ValueError`` that says how to normalise. Accepted quaternions are
    returned renormalised to round-off.
    """
    q = as_float_array(name, value, last_dim=4)
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
    if isinstance(value, bool) or not isinstance(value, numbers.Real | np.floating | np.integer):
        raise TypeError(f"{name} must be a real number, got {type(value).__name__}")
    v = float(value)
    if not np.isfinite(v):
        raise ValueError(f"{name} must be finite, got {v}")
    if allow_zero:
        if v < 0:
            raise ValueError(f"{name} must be >= 0, got {v}")
    elif v <= 0:
        raise ValueError(f"{name} must be > 0, got {v}")
    return v


def as_positive_int(name: str, value) -> int:
    """A strictly positive integer (bools and non-integral floats are rejected)."""
    if isinstance(value, bool):
        raise TypeError(f"{name} must be a positive integer, got a bool")
    integral = isinstance(value, numbers.Integral)
    if integral or (isinstance(value, numbers.Real) and float(value).is_integer()):
        v = int(value)  # 1e6 written as a float is accepted: its value is an integer
    else:
        raise ValueError(f"{name} must be a positive integer, got {value!r}")
    if v <= 0:
        raise ValueError(f"{name} must be a positive integer, got {v}")
    return v
