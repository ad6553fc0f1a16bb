"""Euler angles in the z-x-z convention (Hand & Finch, *Analytical Mechanics*, ch. 8).

The orientation is given by three rotations ``(phi, theta, psi)`` (the definition of
the Euler angles in Hand & Finch, *Analytical Mechanics*, Cambridge University Press,
1998, ch. 8); the matrix

``V = V1(phi) V2(theta) V3(psi) = Rz(phi) Rx(theta) Rz(psi)``

maps body to space coordinates, ``r_space = V r_body``. It is the
same matrix as scipy's ``Rotation.from_euler('ZXZ', [phi, theta, psi]).as_matrix()``
(intrinsic z-x'-z'') and as :func:`liebody.quaternion.to_matrix` of
:func:`to_quaternion`, ``q = qz(phi) qx(theta) qz(psi)`` (scalar first ``(w, x, y, z)``).

Array conventions
-----------------
* :func:`matrix` takes the three angles as separate, broadcastable arrays
  ``matrix(phi, theta, psi)`` (the form in which the matrix is usually written).
* Every other function takes ``angles`` of shape ``(..., 3)`` whose last axis is
  ``(phi, theta, psi)``; rates are ``(..., 3)`` arrays ``(phidot, thetadot, psidot)``
  and angular velocities ``(..., 3)`` vectors. Leading axes broadcast like numpy.
* Python scalars and lists are accepted; everything is float64. Input angles may
  be any finite reals; the functions that *return* angles give ``theta`` in
  ``[0, pi]`` and ``phi``, ``psi`` in ``(-pi, pi]`` (use :func:`unwrap` for
  continuous histories).

Gimbal lock
-----------
At ``sin(theta) = 0`` only ``phi + psi`` (``theta = 0``) or ``phi - psi``
(``theta = pi``) is defined. :func:`from_quaternion` and :func:`from_matrix` then
return ``psi = 0`` and let ``phi`` carry the whole angle, with ``theta`` exactly
``0`` or ``pi``. The convention is applied only where the split is undefined to
round-off, i.e. where ``sin(theta/2)`` or ``cos(theta/2)`` is at most the machine
epsilon ``2.2e-16`` (:data:`SPLIT_TOL`): dropping a tilt that small changes the
rotation matrix by at most ``~2 * SPLIT_TOL``, and above the threshold the split is
computed from well-conditioned ``atan2`` expressions, so the rotation is reproduced
to round-off on both sides of it. :func:`gimbal_lock` is a separate diagnostic with
a user tolerance (default :data:`GIMBAL_TOL`) for the ill-conditioning of
:func:`rates`, whose ``phidot``, ``psidot`` carry a relative error
``~ eps / |sin theta|``.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from liebody._validate import as_float_array, as_positive_float, as_unit_quaternion

__all__ = [
    "GIMBAL_TOL",
    "SPLIT_TOL",
    "from_matrix",
    "from_quaternion",
    "gimbal_lock",
    "matrix",
    "omega_body",
    "omega_space",
    "rates",
    "rotation_angle",
    "rotation_axis",
    "to_quaternion",
    "unwrap",
]

Array = NDArray[np.float64]
Mask = NDArray[np.bool_]

#: Default tolerance on ``|sin theta|`` below which :func:`gimbal_lock` flags a sample
#: and :func:`rates` refuses to divide by ``sin theta``.
GIMBAL_TOL: float = 1e-12

#: ``sin(theta/2)`` (or ``cos(theta/2)``) at or below which :func:`from_quaternion`
#: treats ``theta`` as exactly ``0`` (or ``pi``) and applies the ``psi = 0`` convention.
SPLIT_TOL: float = float(np.finfo(np.float64).eps)

_TWO_PI = 2.0 * np.pi


# --------------------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------------------


def _angles(name: str, value: ArrayLike) -> Array:
    return as_float_array(name, value, last_dim=3)


def _angles_or_triple(angles, theta, psi) -> Array:
    """``angles (..., 3)``, or three separate arguments ``(phi, theta, psi)``."""
    if theta is None and psi is None:
        return _angles("angles", angles)
    if theta is None or psi is None:
        raise TypeError("give either angles of shape (..., 3) or all three of phi, theta, psi")
    phi = as_float_array("phi", angles)
    th = as_float_array("theta", theta)
    ps = as_float_array("psi", psi)
    try:
        return np.stack(np.broadcast_arrays(phi, th, ps), axis=-1)
    except ValueError:
        raise ValueError(
            f"phi (shape {phi.shape}), theta (shape {th.shape}) and psi (shape {ps.shape}) "
            f"must broadcast against each other") from None


def _broadcast(name_a: str, a: np.ndarray, name_b: str, b: np.ndarray):
    """Broadcast two ``(..., 3)`` arrays over their leading axes."""
    try:
        return np.broadcast_arrays(a, b)
    except ValueError:
        raise ValueError(
            f"{name_a} (shape {a.shape}) and {name_b} (shape {b.shape}) must broadcast "
            f"against each other over their leading axes"
        ) from None


def _pi_not_minus_pi(a: np.ndarray) -> np.ndarray:
    """Map ``-pi`` (which ``atan2`` can return) to ``+pi``: range ``[-pi, pi]`` -> ``(-pi, pi]``."""
    return np.where(a <= -np.pi, a + _TWO_PI, a)


def _scalar(a: np.ndarray):
    """0-d arrays to numpy scalars; other arrays unchanged."""
    return a[()]


def _quaternion(a: np.ndarray) -> Array:
    """``qz(phi) qx(theta) qz(psi)`` of validated angles ``(..., 3)``."""
    phi, theta, psi = a[..., 0], a[..., 1], a[..., 2]
    # halved before they are added: phi + psi overflows for angles near the float64 limit
    # (the same numbers otherwise: halving is exact outside the subnormal range)
    sigma = 0.5 * phi + 0.5 * psi
    delta = 0.5 * phi - 0.5 * psi
    ct, st = np.cos(0.5 * theta), np.sin(0.5 * theta)
    return np.stack(
        [ct * np.cos(sigma), st * np.cos(delta), st * np.sin(delta), ct * np.sin(sigma)],
        axis=-1,
    )


def _scaled_norm(v: np.ndarray) -> np.ndarray:
    """Euclidean norm over the last axis without underflow for tiny vectors."""
    m = np.max(np.abs(v), axis=-1)
    safe = np.where(m > 0.0, m, 1.0)
    return m * np.sqrt(np.sum((v / safe[..., None]) ** 2, axis=-1))


def _angles_from_unit_q(q: np.ndarray) -> tuple[Array, Mask]:
    """Euler angles of normalised quaternions and the mask where ``psi = 0`` was imposed."""
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    r = np.hypot(x, y)  # sin(theta/2)
    c = np.hypot(w, z)  # cos(theta/2)
    theta = 2.0 * np.arctan2(r, c)
    # e^{i sigma} ~ w + i z and e^{i delta} ~ x + i y with sigma = (phi+psi)/2 and
    # delta = (phi-psi)/2, so e^{i phi} ~ (w + i z)(x + i y), e^{i psi} ~ (w + i z)(x - i y).
    # Each angle is one atan2 of products: accurate to round-off, unchanged (bit for bit)
    # by q -> -q, and already in [-pi, pi].
    phi = np.arctan2(w * y + z * x, w * x - z * y)
    psi = np.arctan2(z * x - w * y, w * x + z * y)

    lock0 = r <= SPLIT_TOL  # theta = 0: only phi + psi = 2 sigma is defined
    lockpi = c <= SPLIT_TOL  # theta = pi: only phi - psi = 2 delta is defined
    if np.any(lock0) or np.any(lockpi):
        # phi = arg((w + i z)^2) resp. arg((x + i y)^2), psi = 0
        phi0 = np.arctan2(2.0 * w * z, (w - z) * (w + z))
        phipi = np.arctan2(2.0 * x * y, (x - y) * (x + y))
        phi = np.where(lock0, phi0, np.where(lockpi, phipi, phi))
        psi = np.where(lock0 | lockpi, 0.0, psi)
        theta = np.where(lock0, 0.0, np.where(lockpi, np.pi, theta))
    out = np.stack([_pi_not_minus_pi(phi), theta, _pi_not_minus_pi(psi)], axis=-1)
    return out, lock0 | lockpi


# --------------------------------------------------------------------------------------
# public API
# --------------------------------------------------------------------------------------


def matrix(phi: ArrayLike, theta: ArrayLike, psi: ArrayLike) -> Array:
    """Rotation matrix ``V = V1(phi) V2(theta) V3(psi)`` (space <- body).

    Written out term by term as in the definition of the Euler angles (Hand & Finch,
    ch. 8), so that ``r_space = V r_body``. Identical to scipy's
    ``Rotation.from_euler('ZXZ', [phi, theta, psi]).as_matrix()``.

    Parameters
    ----------
    phi, theta, psi
        The three z-x-z Euler angles (radians) as separate arrays that broadcast
        against each other (any finite reals). To pass an ``angles`` array of shape
        ``(..., 3)`` use ``matrix(*np.moveaxis(angles, -1, 0))``.

    Returns
    -------
    ndarray, shape ``(..., 3, 3)``
        ``...`` is the broadcast shape of the three angles.
    """
    phi_a = as_float_array("phi", phi)
    theta_a = as_float_array("theta", theta)
    psi_a = as_float_array("psi", psi)
    try:
        phi_a, theta_a, psi_a = np.broadcast_arrays(phi_a, theta_a, psi_a)
    except ValueError:
        raise ValueError(
            f"phi, theta and psi must broadcast against each other, got shapes "
            f"{np.shape(phi_a)}, {np.shape(theta_a)}, {np.shape(psi_a)}"
        ) from None
    cf, sf = np.cos(phi_a), np.sin(phi_a)
    ct, st = np.cos(theta_a), np.sin(theta_a)
    cp, sp = np.cos(psi_a), np.sin(psi_a)
    out = np.empty(phi_a.shape + (3, 3))
    out[..., 0, 0] = cp * cf - ct * sf * sp
    out[..., 0, 1] = -sp * cf - ct * sf * cp
    out[..., 0, 2] = st * sf
    out[..., 1, 0] = cp * sf + ct * cf * sp
    out[..., 1, 1] = -sf * sp + ct * cf * cp
    out[..., 1, 2] = -st * cf
    out[..., 2, 0] = st * sp
    out[..., 2, 1] = st * cp
    out[..., 2, 2] = ct
    return out


def to_quaternion(angles: ArrayLike) -> Array:
    """Unit quaternion of the Euler angles, ``q = qz(phi) qx(theta) qz(psi)``.

    The definition of the Euler angles (Hand & Finch, ch. 8) as a quaternion:
    ``to_matrix(to_quaternion(angles)) == matrix(phi, theta, psi)``. With
    ``sigma = (phi + psi)/2`` and ``delta = (phi - psi)/2``::

        q = (cos(theta/2) cos(sigma), sin(theta/2) cos(delta),
             sin(theta/2) sin(delta), cos(theta/2) sin(sigma))

    The sign is *not* canonicalised (``w`` may be negative): the result is the exact
    product above, which is continuous along continuous angle histories.

    Parameters
    ----------
    angles
        ``(..., 3)`` array of ``(phi, theta, psi)`` in radians (any finite reals).

    Returns
    -------
    ndarray, shape ``(..., 4)``
        Scalar-first ``(w, x, y, z)``.
    """
    return _quaternion(_angles("angles", angles))


def from_quaternion(q: ArrayLike, *, return_mask: bool = False) -> Array | tuple[Array, Mask]:
    """Euler angles of unit quaternions (inverse of :func:`to_quaternion`).

    The definition of the Euler angles (Hand & Finch, ch. 8) inverted, computed without
    ``acos``/``asin``: ``theta = 2 atan2(hypot(x, y), hypot(w, z))``,
    ``phi = arg((w + i z)(x + i y))``, ``psi = arg((w + i z)(x - i y))``, which are
    accurate to round-off for every rotation, including next to gimbal lock, and give
    bit-identical angles for ``q`` and ``-q``.

    At gimbal lock (``sin(theta/2) <= SPLIT_TOL`` or ``cos(theta/2) <= SPLIT_TOL``)
    ``theta`` is returned as exactly ``0`` or ``pi``, ``psi = 0`` and ``phi`` is the
    whole defined angle (``phi + psi`` resp. ``phi - psi``); the rotation is still
    reproduced to ``~1e-15`` (see the module docstring).

    Parameters
    ----------
    q
        ``(..., 4)`` unit quaternions, scalar first; ``| |q| - 1 | <= 1e-10`` is
        required and ``q`` is renormalised.
    return_mask
        Also return the boolean mask ``(...)`` of samples where the gimbal-lock
        convention ``psi = 0`` was applied.

    Returns
    -------
    angles : ndarray, shape ``(..., 3)``
        ``(phi, theta, psi)`` with ``theta`` in ``[0, pi]`` and ``phi``, ``psi`` in
        ``(-pi, pi]``.
    mask : ndarray of bool, shape ``(...)``
        Only if ``return_mask``.
    """
    angles, mask = _angles_from_unit_q(as_unit_quaternion("q", q))
    return (angles, mask) if return_mask else angles


def from_matrix(
    V: ArrayLike, *, tol: float = 1e-9, return_mask: bool = False
) -> Array | tuple[Array, Mask]:
    """Euler angles of rotation matrices ``V`` (space <- body).

    The definition of the Euler angles (Hand & Finch, ch. 8) inverted, as
    ``from_quaternion(quaternion.from_matrix(V))``: Shepperd's stable conversion to a
    quaternion (S. W. Shepperd, J. Guidance and Control 1 (1978) 223-224) followed by
    the well-conditioned extraction of :func:`from_quaternion` (same ranges and
    gimbal-lock convention).

    Parameters
    ----------
    V
        ``(..., 3, 3)`` proper rotation matrices.
    tol
        Accepted deviation ``max |V^T V - 1|`` and ``|det V - 1|``.
    return_mask
        Also return the mask of samples where the convention ``psi = 0`` was applied.

    Returns
    -------
    angles : ndarray, shape ``(..., 3)``
    mask : ndarray of bool, shape ``(...)``
        Only if ``return_mask``.
    """
    from liebody import quaternion

    m = as_float_array("V", V)
    if m.ndim < 2 or m.shape[-2:] != (3, 3):
        raise ValueError(f"V must have shape (..., 3, 3), got {m.shape}")
    tol = as_positive_float("tol", tol)
    orth = np.abs(np.swapaxes(m, -1, -2) @ m - np.eye(3)).max(axis=(-2, -1), initial=0.0)
    det = np.linalg.det(m) if m.size else np.ones(m.shape[:-2])
    if np.any(orth > tol) or np.any(np.abs(det - 1.0) > tol):
        raise ValueError(
            f"V must be a proper rotation matrix (V^T V = 1 and det V = +1 within "
            f"tol = {tol:g}); got max |V^T V - 1| = {np.max(orth, initial=0.0):.3e}, "
            f"max |det V - 1| = {np.max(np.abs(det - 1.0), initial=0.0):.3e}"
        )
    q = quaternion.from_matrix(m, tol=tol)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    angles, mask = _angles_from_unit_q(q)
    return (angles, mask) if return_mask else angles


def gimbal_lock(angles: ArrayLike, *, tol: float = GIMBAL_TOL) -> Mask:
    """Boolean mask of samples at gimbal lock, ``|sin theta| <= tol``.

    There ``phi`` and ``psi`` are not separately defined, and :func:`rates` cannot
    recover ``phidot``, ``psidot`` from the angular velocity (Hand & Finch, ch. 8, the
    angular velocity in Euler angles).

    Parameters
    ----------
    angles
        ``(..., 3)`` array of ``(phi, theta, psi)``.
    tol
        Tolerance on ``|sin theta|`` (``>= 0``), default :data:`GIMBAL_TOL`.

    Returns
    -------
    ndarray of bool, shape ``(...)`` (a numpy bool for a single sample).
    """
    a = _angles("angles", angles)
    tol = as_positive_float("tol", tol, allow_zero=True)
    return _scalar(np.abs(np.sin(a[..., 1])) <= tol)


def rotation_angle(angles: ArrayLike, theta: ArrayLike | None = None,
                   psi: ArrayLike | None = None) -> Array:
    """Rotation angle ``Phi`` of ``V`` about its invariant axis, in ``[0, pi]``.

    The trace relation ``cos(Phi/2) = cos((phi + psi)/2) cos(theta/2)`` (Hand & Finch,
    ch. 8, Euler angles)
    (i.e. ``1 + 2 cos Phi = trace V``) defines ``Phi`` in ``[0, 2 pi]``; a rotation
    by ``Phi > pi`` is the rotation by ``2 pi - Phi`` about the opposite axis, and
    this function returns the latter, ``Phi in [0, pi]``, consistently with
    :func:`rotation_axis` (``V = exp(Phi hat(axis))``). It is evaluated as
    ``Phi = 2 atan2(|(x, y, z)|, |w|)`` from :func:`to_quaternion`, accurate at all
    angles (``acos`` of the trace loses half the digits near ``0`` and ``pi``).

    Parameters
    ----------
    angles
        ``(..., 3)`` array of ``(phi, theta, psi)``; or
        ``rotation_angle(phi, theta, psi)`` with three broadcastable arrays.

    Returns
    -------
    ndarray, shape ``(...)`` (a numpy float for a single sample).
    """
    q = _quaternion(_angles_or_triple(angles, theta, psi))
    return _scalar(2.0 * np.arctan2(_scaled_norm(q[..., 1:]), np.abs(q[..., 0])))


def rotation_axis(angles: ArrayLike, theta: ArrayLike | None = None,
                  psi: ArrayLike | None = None) -> Array:
    """Unit rotation axis of ``V``: the eigenvector with eigenvalue 1 (Hand & Finch, ch. 8).

    Oriented so that ``V`` is a right-handed rotation by :func:`rotation_angle`
    ``Phi in [0, pi]`` about it. At ``Phi = pi`` both orientations describe the same
    rotation. For the identity (``Phi = 0`` exactly) every vector is invariant and
    ``(0, 0, 1)`` is returned.

    Parameters
    ----------
    angles
        ``(..., 3)`` array of ``(phi, theta, psi)``, or ``phi`` with ``theta`` and
        ``psi`` given separately (as for :func:`rotation_angle`).

    Returns
    -------
    ndarray, shape ``(..., 3)``
    """
    q = _quaternion(_angles_or_triple(angles, theta, psi))
    v = np.where(q[..., :1] < 0.0, -q[..., 1:], q[..., 1:])
    m = np.max(np.abs(v), axis=-1, keepdims=True)
    zero = m == 0.0
    vs = v / np.where(zero, 1.0, m)  # scale first: subnormal vectors normalise accurately
    axis = vs / np.linalg.norm(vs, axis=-1, keepdims=True).clip(min=1.0)
    return np.where(zero, np.array([0.0, 0.0, 1.0]), axis)


def omega_body(angles: ArrayLike, rates: ArrayLike) -> Array:
    """Angular velocity in body coordinates from Euler-angle rates (Hand & Finch, ch. 8).

    ``hat(omega_body) = V^T dV/dt``::

        omega_1 = thetadot cos(psi) + phidot sin(psi) sin(theta)
        omega_2 = -thetadot sin(psi) + phidot cos(psi) sin(theta)
        omega_3 = psidot + phidot cos(theta)

    Parameters
    ----------
    angles
        ``(..., 3)`` array of ``(phi, theta, psi)``.
    rates
        ``(..., 3)`` array of ``(phidot, thetadot, psidot)``, broadcast against
        ``angles``.

    Returns
    -------
    ndarray, shape ``(..., 3)``
    """
    a, r = _broadcast("angles", _angles("angles", angles), "rates", _angles("rates", rates))
    theta, psi = a[..., 1], a[..., 2]
    phid, thetad, psid = r[..., 0], r[..., 1], r[..., 2]
    st, ct = np.sin(theta), np.cos(theta)
    sp, cp = np.sin(psi), np.cos(psi)
    return np.stack(
        [thetad * cp + phid * sp * st, -thetad * sp + phid * cp * st, psid + phid * ct],
        axis=-1,
    )


def omega_space(angles: ArrayLike, rates: ArrayLike) -> Array:
    """Angular velocity in space coordinates from Euler-angle rates (Hand & Finch, ch. 8).

    ``hat(omega_space) = dV/dt V^T`` and ``omega_space = V omega_body``::

        omega_x = thetadot cos(phi) + psidot sin(phi) sin(theta)
        omega_y = thetadot sin(phi) - psidot cos(phi) sin(theta)
        omega_z = phidot + psidot cos(theta)

    Parameters
    ----------
    angles
        ``(..., 3)`` array of ``(phi, theta, psi)``.
    rates
        ``(..., 3)`` array of ``(phidot, thetadot, psidot)``, broadcast against
        ``angles``.

    Returns
    -------
    ndarray, shape ``(..., 3)``
    """
    a, r = _broadcast("angles", _angles("angles", angles), "rates", _angles("rates", rates))
    phi, theta = a[..., 0], a[..., 1]
    phid, thetad, psid = r[..., 0], r[..., 1], r[..., 2]
    st, ct = np.sin(theta), np.cos(theta)
    sf, cf = np.sin(phi), np.cos(phi)
    return np.stack(
        [thetad * cf + psid * sf * st, thetad * sf - psid * cf * st, phid + psid * ct],
        axis=-1,
    )


def rates(
    angles: ArrayLike,
    omega_body: ArrayLike,
    *,
    tol: float = GIMBAL_TOL,
    singular: Literal["raise", "nan"] = "raise",
) -> Array:
    """Euler-angle rates from the body angular velocity (inverse of :func:`omega_body`).

    Solving the body-frame formula (Hand & Finch, ch. 8, Euler angles) for the rates::

        phidot   = (omega_1 sin(psi) + omega_2 cos(psi)) / sin(theta)
        thetadot = omega_1 cos(psi) - omega_2 sin(psi)
        psidot   = omega_3 - phidot cos(theta)

    ``phidot`` and ``psidot`` are singular at gimbal lock ``sin(theta) = 0`` and
    carry a relative error ``~ eps / |sin theta|`` near it.

    Parameters
    ----------
    angles
        ``(..., 3)`` array of ``(phi, theta, psi)``.
    omega_body
        ``(..., 3)`` body angular velocities, broadcast against ``angles``.
    tol
        Samples with ``|sin theta| <= tol`` (default :data:`GIMBAL_TOL`) are singular.
    singular
        ``'raise'`` (default): a ``ValueError`` listing the singular samples;
        ``'nan'``: ``phidot`` and ``psidot`` are NaN there (``thetadot`` is kept).

    Returns
    -------
    ndarray, shape ``(..., 3)``
        ``(phidot, thetadot, psidot)``.

    Raises
    ------
    ValueError
        If ``singular='raise'`` and some sample is at gimbal lock.
    """
    if singular not in ("raise", "nan"):
        raise ValueError(f"singular must be 'raise' or 'nan', got {singular!r}")
    tol = as_positive_float("tol", tol, allow_zero=True)
    a, w = _broadcast(
        "angles", _angles("angles", angles), "omega_body", _angles("omega_body", omega_body)
    )
    theta, psi = a[..., 1], a[..., 2]
    w1, w2, w3 = w[..., 0], w[..., 1], w[..., 2]
    st, ct = np.sin(theta), np.cos(theta)
    sp, cp = np.sin(psi), np.cos(psi)
    bad = np.abs(st) <= tol
    if np.any(bad) and singular == "raise":
        if bad.ndim == 0:
            where = "the single sample"
        else:
            idx = [tuple(int(i) for i in row) for row in np.argwhere(bad)]
            more = " ..." if len(idx) > 5 else ""
            where = f"{len(idx)} sample(s), at indices {idx[:5]}{more}"
        raise ValueError(
            f"angles is at gimbal lock (|sin theta| <= tol = {tol:g}) for {where}: "
            f"phidot and psidot are undefined there (only phidot + psidot at theta = 0, "
            f"or phidot - psidot at theta = pi, is determined). Pass singular='nan' to get "
            f"NaN for them instead."
        )
    safe = np.where(bad, 1.0, st)
    phid = (w1 * sp + w2 * cp) / safe
    thetad = w1 * cp - w2 * sp
    psid = w3 - phid * ct
    phid = np.where(bad, np.nan, phid)
    psid = np.where(bad, np.nan, psid)
    return np.stack([phid, thetad, psid], axis=-1)


def unwrap(angles: ArrayLike, axis: int = 0) -> Array:
    """Continuous angle histories: ``numpy.unwrap`` of ``phi`` and ``psi`` along ``axis``.

    Removes the ``2 pi`` jumps that the ranges ``(-pi, pi]`` of :func:`from_quaternion`
    introduce along a long trajectory; ``theta`` (in ``[0, pi]``, no jumps) is returned
    unchanged. Jumps of exactly ``pi`` in ``phi`` and ``psi`` that occur when a
    trajectory passes through gimbal lock (``theta`` touching ``0`` or ``pi``) are a
    property of the chart, not wrapping, and are not removed. (A utility for
    trajectories expressed in Euler angles, not part of the theory.)

    Parameters
    ----------
    angles
        ``(..., 3)`` array of ``(phi, theta, psi)`` with at least one leading axis.
    axis
        The time axis of ``angles`` (must not be its last, component axis).

    Returns
    -------
    ndarray, same shape as ``angles``
    """
    a = _angles("angles", angles)
    if a.ndim < 2:
        raise ValueError(
            f"angles must have shape (n, ..., 3) with a time axis, got shape {a.shape}"
        )
    if isinstance(axis, bool) or not isinstance(axis, int | np.integer):
        raise TypeError(f"axis must be an integer, got {type(axis).__name__}")
    ax = int(axis)
    if not -a.ndim <= ax < a.ndim:
        raise ValueError(f"axis {axis} is out of range for angles of shape {a.shape}")
    ax %= a.ndim
    if ax == a.ndim - 1:
        raise ValueError(
            f"axis must be a time axis of angles, not its last (phi, theta, psi) axis; "
            f"got axis={axis} for shape {a.shape}"
        )
    out = a.copy()
    out[..., 0] = np.unwrap(a[..., 0], axis=ax)
    out[..., 2] = np.unwrap(a[..., 2], axis=ax)
    return out
