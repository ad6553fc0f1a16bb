"""Spacecraft attitude: roll-pitch-yaw angles and the orbital (LVLH) frame.

Roll-pitch-yaw angles (z-y-x, the aerospace sequence)
-----------------------------------------------------
Three rotations: yaw ``psi`` about z, then pitch ``theta`` about the new y, then roll
``phi`` about the new x (intrinsic z-y'-x''). The matrix

``R = Rz(yaw) Ry(pitch) Rx(roll)``

maps body to reference coordinates, ``r_ref = R r_body`` (the convention of every
liebody quaternion, scalar first ``(w, x, y, z)``, ``q = qz(yaw) qy(pitch) qx(roll)``).
Kuipers, *Quaternions and Rotation Sequences* (Princeton University Press, 1999),
sect. 7.7 (the aerospace sequence); Wie, *Space Vehicle Dynamics and Control*, 2nd ed.
(AIAA, 2008).

**Order of the angles.** Every array of angles here has the last axis
``(roll, pitch, yaw)``, in that order (the order of the name "rpy"). scipy's
``Rotation.from_euler('ZYX', [yaw, pitch, roll])`` takes the reverse order and is the
same rotation: ``rpy_to_quaternion(a)`` equals
``from_scipy(Rotation.from_euler('ZYX', a[..., ::-1]).as_quat())`` up to the sign of
the quaternion (scipy is scalar-last; convert with
:func:`liebody.quaternion.from_scipy`).

**Ranges and gimbal lock.** :func:`quaternion_to_rpy` returns ``pitch`` in
``[-pi/2, pi/2]`` and ``roll``, ``yaw`` in ``(-pi, pi]``. At ``pitch = +-pi/2`` only
``yaw - roll`` (``+pi/2``) or ``yaw + roll`` (``-pi/2``) is defined; there the
convention is ``roll = 0`` and ``yaw`` carries the whole angle (scipy's convention for
'ZYX': its third angle, roll, is set to zero), with ``pitch`` exactly ``+-pi/2``. It
applies where the split is undefined to round-off (:data:`SPLIT_TOL`); every output is
finite and the rotation is reproduced to round-off on both sides of the threshold
(scipy flags the lock from a wider band, about ``1e-7`` in pitch, and warns; the
rotation is the same either way, only the split of ``yaw`` and ``roll`` differs there).

The orbital frame (LVLH)
------------------------
The local-vertical/local-horizontal frame of a position ``r`` and velocity ``v``
(inertial): ``z = -r/|r|`` (nadir, towards the attracting centre),
``y = -(r x v)/|r x v|`` (the negative orbit normal) and ``x = y x z`` (along the
velocity on a circular orbit): roll, pitch and yaw axes of an Earth-pointing
satellite, the frame of :func:`liebody.analysis.gravity_gradient_stability`.
:func:`lvlh_quaternion` rotates LVLH to inertial coordinates
(``r_inertial = R(q) r_lvlh``) and :func:`attitude_in_lvlh` gives a body's attitude
relative to it. Hughes, *Spacecraft Attitude Dynamics* (Wiley, 1986), ch. 9; Wie (2008).

Inputs are validated: a ``ValueError``/``TypeError`` names the argument and the rule
(shape, finiteness, unit quaternions, ``r`` not parallel to ``v``). float64 throughout.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from liebody import quaternion as _quat
from liebody._validate import as_float_array, as_unit_quaternion

__all__ = [
    "PARALLEL_TOL",
    "SPLIT_TOL",
    "attitude_in_lvlh",
    "lvlh_axes",
    "lvlh_quaternion",
    "quaternion_to_rpy",
    "rpy_matrix",
    "rpy_to_quaternion",
]

Array = NDArray[np.float64]
Mask = NDArray[np.bool_]

#: The split of ``yaw`` and ``roll`` is treated as undefined (gimbal lock, ``roll = 0``)
#: where ``B = sqrt(2) cos(pitch/2 + pi/4)`` (pitch near ``pi/2``) or
#: ``A = sqrt(2) sin(pitch/2 + pi/4)`` (near ``-pi/2``), computed from the quaternion, is
#: at most ``4 eps = 8.9e-16`` (:func:`quaternion_to_rpy`). ``A`` and ``B`` come from
#: differences of ``O(1)`` components and carry a round-off of about ``eps``: for
#: ``pitch = +-pi/2`` given in float64 they come out up to ``1.25 eps``. Dropping a split
#: that small changes the rotation by ``~1e-15``.
SPLIT_TOL: float = 4.0 * float(np.finfo(np.float64).eps)

#: ``|r x v| <= PARALLEL_TOL |r| |v|`` (the sine of the angle between ``r`` and ``v``)
#: has no orbit normal: :func:`lvlh_axes` refuses it.
PARALLEL_TOL: float = 1e-12

_TWO_PI = 2.0 * np.pi


# --------------------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------------------


def _pi_not_minus_pi(a: np.ndarray) -> np.ndarray:
    """Angles to ``(-pi, pi]`` (``a`` in ``[-2 pi, 2 pi]``)."""
    a = np.where(a > np.pi, a - _TWO_PI, a)
    return np.where(a <= -np.pi, a + _TWO_PI, a)


def _angles(value: ArrayLike) -> Array:
    return as_float_array("angles", value, last_dim=3)


def _unit_rows(name: str, v: np.ndarray) -> tuple[Array, Array]:
    """``v / |v|`` over the last axis without overflow or underflow, and the scale."""
    m = np.max(np.abs(v), axis=-1)
    safe = np.where(m > 0.0, m, 1.0)
    s = v / safe[..., None]
    norm = np.sqrt(np.sum(s * s, axis=-1))
    if np.any(m == 0.0):
        raise ValueError(f"{name} must be a nonzero vector (the LVLH frame needs a "
                         f"position and a velocity), got a zero vector")
    return s / norm[..., None], m


# --------------------------------------------------------------------------------------
# roll-pitch-yaw angles
# --------------------------------------------------------------------------------------


def rpy_matrix(angles: ArrayLike) -> Array:
    """Rotation matrix ``R = Rz(yaw) Ry(pitch) Rx(roll)`` (reference <- body).

    Written out term by term from the three elementary rotations (Kuipers 1999,
    sect. 7.7): ``r_ref = R r_body``.

    Parameters
    ----------
    angles : array_like, shape (..., 3)
        ``(roll, pitch, yaw)`` in radians (any finite reals).

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    a = _angles(angles)
    cr, sr = np.cos(a[..., 0]), np.sin(a[..., 0])
    cp, sp = np.cos(a[..., 1]), np.sin(a[..., 1])
    cy, sy = np.cos(a[..., 2]), np.sin(a[..., 2])
    out = np.empty(a.shape[:-1] + (3, 3))
    out[..., 0, 0] = cy * cp
    out[..., 0, 1] = cy * sp * sr - sy * cr
    out[..., 0, 2] = cy * sp * cr + sy * sr
    out[..., 1, 0] = sy * cp
    out[..., 1, 1] = sy * sp * sr + cy * cr
    out[..., 1, 2] = sy * sp * cr - cy * sr
    out[..., 2, 0] = -sp
    out[..., 2, 1] = cp * sr
    out[..., 2, 2] = cp * cr
    return out


def rpy_to_quaternion(angles: ArrayLike) -> Array:
    """Unit quaternion ``q = qz(yaw) qy(pitch) qx(roll)`` of roll-pitch-yaw angles.

    With the half angles ``r, p, y`` of roll, pitch, yaw (``cr = cos r`` etc.)::

        q = (cy cp cr + sy sp sr,  cy cp sr - sy sp cr,
             cy sp cr + sy cp sr,  sy cp cr - cy sp sr)

    so that ``liebody.quaternion.to_matrix(q) == rpy_matrix(angles)``; the same rotation
    as scipy's ``Rotation.from_euler('ZYX', [yaw, pitch, roll])`` (note the reversed
    order). The sign is not canonicalised (``w`` may be negative): the exact product,
    continuous along continuous angle histories.

    Parameters
    ----------
    angles : array_like, shape (..., 3)
        ``(roll, pitch, yaw)`` in radians (any finite reals).

    Returns
    -------
    ndarray, shape (..., 4)
        Scalar-first ``(w, x, y, z)``.
    """
    a = _angles(angles)
    hr, hp, hy = 0.5 * a[..., 0], 0.5 * a[..., 1], 0.5 * a[..., 2]
    cr, sr = np.cos(hr), np.sin(hr)
    cp, sp = np.cos(hp), np.sin(hp)
    cy, sy = np.cos(hy), np.sin(hy)
    return np.stack([cy * cp * cr + sy * sp * sr,
                     cy * cp * sr - sy * sp * cr,
                     cy * sp * cr + sy * cp * sr,
                     sy * cp * cr - cy * sp * sr], axis=-1)


def _rpy_from_unit_q(q: np.ndarray) -> tuple[Array, Mask]:
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    # With half angles (r, p, y) and u = p + pi/4 (in [0, pi/2] for pitch in
    # [-pi/2, pi/2]): w + y = sqrt(2) sin u cos(y - r), z - x = sqrt(2) sin u sin(y - r),
    # w - y = sqrt(2) cos u cos(y + r), z + x = sqrt(2) cos u sin(y + r).
    a = np.hypot(w + y, z - x)  # sqrt(2) sin u
    b = np.hypot(w - y, z + x)  # sqrt(2) cos u
    pitch = 2.0 * np.arctan2(a, b) - 0.5 * np.pi
    diff = 2.0 * np.arctan2(z - x, w + y)  # yaw - roll
    summ = 2.0 * np.arctan2(z + x, w - y)  # yaw + roll
    yaw = 0.5 * (summ + diff)
    roll = 0.5 * (summ - diff)
    up = b <= SPLIT_TOL  # pitch = +pi/2: only yaw - roll is defined
    down = a <= SPLIT_TOL  # pitch = -pi/2: only yaw + roll is defined
    lock = up | down
    if np.any(lock):
        yaw = np.where(up, diff, np.where(down, summ, yaw))
        roll = np.where(lock, 0.0, roll)
        pitch = np.where(up, 0.5 * np.pi, np.where(down, -0.5 * np.pi, pitch))
    # summ, diff in [-2 pi, 2 pi]: yaw, roll in [-2 pi, 2 pi]
    out = np.stack([_pi_not_minus_pi(roll), pitch, _pi_not_minus_pi(yaw)], axis=-1)
    return out, lock


def quaternion_to_rpy(q: ArrayLike, *, return_mask: bool = False) -> Array | tuple[Array, Mask]:
    """Roll-pitch-yaw angles of unit quaternions (inverse of :func:`rpy_to_quaternion`).

    Computed without ``asin`` (ill-conditioned at ``pitch = +-pi/2``): with the half
    angles ``r, p, y`` and ``u = p + pi/4``, ``w + y = sqrt(2) sin u cos(y - r)``,
    ``z - x = sqrt(2) sin u sin(y - r)``, ``w - y = sqrt(2) cos u cos(y + r)`` and
    ``z + x = sqrt(2) cos u sin(y + r)``, so ``pitch = 2 atan2(A, B) - pi/2`` with
    ``A = hypot(w + y, z - x)``, ``B = hypot(w - y, z + x)``, and ``yaw -+ roll`` are two
    ``atan2``: accurate to round-off for every rotation, ``q`` and ``-q`` alike. The
    same angles as scipy's ``Rotation.as_euler('ZYX')`` reversed (``[yaw, pitch,
    roll]`` there) wherever the split is defined.

    At gimbal lock (``B <= SPLIT_TOL``: ``pitch = pi/2``; ``A <= SPLIT_TOL``:
    ``pitch = -pi/2``) ``pitch`` is exactly ``+-pi/2``, ``roll = 0`` and ``yaw`` carries
    the defined combination (``yaw - roll`` resp. ``yaw + roll``), as in scipy; the
    rotation is reproduced to ``~1e-15``.

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Unit quaternions, scalar first; ``| |q| - 1 | <= 1e-10`` is required and ``q``
        is renormalised.
    return_mask : bool, default False
        Also return the boolean mask ``(...)`` of the samples where the gimbal-lock
        convention ``roll = 0`` was applied.

    Returns
    -------
    angles : ndarray, shape (..., 3)
        ``(roll, pitch, yaw)``: ``pitch`` in ``[-pi/2, pi/2]``, ``roll`` and ``yaw`` in
        ``(-pi, pi]``.
    mask : ndarray of bool, shape (...)
        Only if ``return_mask``.
    """
    angles, mask = _rpy_from_unit_q(as_unit_quaternion("q", q))
    return (angles, mask) if return_mask else angles


# --------------------------------------------------------------------------------------
# the orbital (LVLH) frame
# --------------------------------------------------------------------------------------


def lvlh_axes(r: ArrayLike, v: ArrayLike) -> Array:
    """The LVLH axes of a position ``r`` and a velocity ``v`` as the columns of a matrix.

    ``z = -r/|r|`` (nadir), ``y = -(r x v)/|r x v|`` (negative orbit normal),
    ``x = y x z`` (along the velocity on a circular orbit; in general the direction of
    the velocity's part perpendicular to ``r``). Hughes, *Spacecraft Attitude
    Dynamics* (1986), ch. 9.

    Parameters
    ----------
    r, v : array_like, shape (..., 3)
        Inertial position (from the attracting centre) and velocity, finite,
        broadcasting over their leading axes. ``r`` and ``v`` must be nonzero and not
        parallel: ``|r x v| > PARALLEL_TOL |r| |v|``.

    Returns
    -------
    ndarray, shape (..., 3, 3)
        ``M = [x y z]`` (columns), the rotation from LVLH to inertial coordinates:
        ``r_inertial = M r_lvlh``.
    """
    r_a = as_float_array("r", r, last_dim=3)
    v_a = as_float_array("v", v, last_dim=3)
    try:
        r_a, v_a = np.broadcast_arrays(r_a, v_a)
    except ValueError:
        raise ValueError(f"r (shape {r_a.shape}) and v (shape {v_a.shape}) must broadcast "
                         f"against each other over their leading axes") from None
    rh, _ = _unit_rows("r", r_a)
    vh, _ = _unit_rows("v", v_a)
    h = np.cross(rh, vh)  # |h| = sin of the angle between r and v
    sin = np.sqrt(np.sum(h * h, axis=-1))
    if np.any(sin <= PARALLEL_TOL):
        worst = float(np.min(sin))
        raise ValueError(
            f"r and v must not be parallel (the orbit normal r x v is undefined): "
            f"|r x v| / (|r| |v|) = {worst:.3e} <= PARALLEL_TOL = {PARALLEL_TOL:g}")
    z = -rh
    y = -h / sin[..., None]
    x = np.cross(y, z)
    x /= np.sqrt(np.sum(x * x, axis=-1))[..., None]  # unit to round-off already
    return np.stack([x, y, z], axis=-1)


def lvlh_quaternion(r: ArrayLike, v: ArrayLike) -> Array:
    """Quaternion rotating the LVLH frame of ``r``, ``v`` to the inertial frame.

    ``R(q) = [x y z]`` of :func:`lvlh_axes` (``r_inertial = R(q) r_lvlh``), from the
    matrix by Shepperd's method (:func:`liebody.quaternion.from_matrix`), ``w >= 0``.

    Parameters
    ----------
    r, v : array_like, shape (..., 3)
        As for :func:`lvlh_axes`.

    Returns
    -------
    ndarray, shape (..., 4)
        Scalar-first unit quaternions.
    """
    return _quat.from_matrix(lvlh_axes(r, v))


def attitude_in_lvlh(q_body: ArrayLike, r: ArrayLike, v: ArrayLike, *,
                     rpy: bool = False) -> Array | tuple[Array, Array]:
    """A body's orientation relative to the LVLH frame of ``r``, ``v``.

    ``q_rel = q_lvlh* q_body`` rotates body to LVLH coordinates
    (``r_lvlh = R(q_rel) r_body``): the identity when the body's axes 1, 2, 3 are the
    LVLH roll, pitch and yaw axes (the equilibrium of
    :func:`liebody.analysis.gravity_gradient_stability`).

    Parameters
    ----------
    q_body : array_like, shape (..., 4)
        The body's unit quaternions (body -> inertial), e.g. ``Trajectory.q``.
    r, v : array_like, shape (..., 3)
        As for :func:`lvlh_axes`; all three broadcast over their leading axes.
    rpy : bool, default False
        Also return the roll-pitch-yaw angles of ``q_rel`` (:func:`quaternion_to_rpy`).

    Returns
    -------
    q_rel : ndarray, shape (..., 4)
        Scalar-first; its sign follows ``q_body`` (not canonicalised).
    angles : ndarray, shape (..., 3)
        ``(roll, pitch, yaw)`` relative to LVLH; only if ``rpy``.
    """
    q = as_unit_quaternion("q_body", q_body)
    q_lvlh = lvlh_quaternion(r, v)
    try:
        np.broadcast_shapes(q.shape[:-1], q_lvlh.shape[:-1])
    except ValueError:
        raise ValueError(f"q_body (shape {q.shape}) and r, v (leading shape "
                         f"{q_lvlh.shape[:-1]}) must broadcast against each other over "
                         f"their leading axes") from None
    q_rel = _quat.multiply(_quat.conjugate(q_lvlh), q)
    if rpy:
        return q_rel, quaternion_to_rpy(_quat.normalize(q_rel))
    return q_rel
