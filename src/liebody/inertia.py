"""Inertia tensors: point masses, the parallel axis theorem, standard solids, composites.

Everything here is plain NumPy, float64. The theory is that of Hand & Finch,
*Analytical Mechanics* (Cambridge University Press, 1998), ch. 8: the definition of
the *moment of inertia tensor*, the parallel axis theorem (with its thin-disk example)
and the transformation law of the tensor under rotations (principal axes).

Conventions
-----------
* An inertia tensor is a symmetric ``(3, 3)`` array
  ``I_ij = sum_a m_a (r_a^2 delta_ij - r_a,i r_a,j)`` about a stated origin.
* The standard solids (:func:`thin_disk`, :func:`solid_cone`, ...) return their
  **principal moments about their centre of mass** as a ``(3,)`` array
  ``(I1, I2, I3)`` about the body's own ``x, y, z`` axes. A body with an axis of
  rotational symmetry always has it along ``z`` (axis 3), so ``I1 == I2``. Turn the
  moments into a tensor with :func:`moments_to_tensor` (optionally rotated), or pass
  them straight to :class:`liebody.RigidBody` or to a :class:`Part` of
  :func:`composite`.
* Orientations (of a :class:`Part`) are rotations *part frame -> composite frame*,
  given as a proper ``(3, 3)`` rotation matrix or a unit quaternion ``(w, x, y, z)``
  (scalar first, the package convention), ``v_composite = R v_part``.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from typing import Any, NamedTuple

import numpy as np

from liebody._validate import as_float_array, as_positive_float, as_unit_quaternion

__all__ = [
    "ROTATION_TOL",
    "SYMMETRY_RTOL",
    "MassProperties",
    "Part",
    "box",
    "composite",
    "ellipsoid",
    "hollow_sphere",
    "moments_to_tensor",
    "parallel_axis",
    "rotate_tensor",
    "solid_cone",
    "solid_cylinder",
    "solid_sphere",
    "tensor",
    "thin_disk",
    "thin_ring",
    "thin_rod",
]

#: A tensor counts as symmetric when ``max|I - I^T| <= SYMMETRY_RTOL * max|I|``.
SYMMETRY_RTOL = 1e-12

#: A matrix counts as orthogonal when ``max|R^T R - 1| <= ROTATION_TOL``.
ROTATION_TOL = 1e-10

_EYE = np.eye(3)


# --------------------------------------------------------------------------------------
# private helpers (also used by liebody.rigid_body)
# --------------------------------------------------------------------------------------


def _check_symmetric(name: str, arr: np.ndarray) -> np.ndarray:
    """Check that ``arr`` (``(..., 3, 3)``) is symmetric to round-off; return it symmetrised."""
    dev = np.max(np.abs(arr - np.swapaxes(arr, -1, -2)), axis=(-2, -1))
    scale = np.max(np.abs(arr), axis=(-2, -1))
    bad = dev > SYMMETRY_RTOL * scale
    if np.any(bad):
        worst = float(np.max(np.where(bad, dev, 0.0)))
        raise ValueError(
            f"{name} must be a symmetric tensor (I_ij = I_ji): max |I - I^T| = {worst:.3e} "
            f"exceeds {SYMMETRY_RTOL:.0e} x max |I_ij|"
        )
    return 0.5 * (arr + np.swapaxes(arr, -1, -2))


def _as_tensor3(name: str, value) -> np.ndarray:
    """A finite symmetric ``(..., 3, 3)`` float64 tensor."""
    arr = as_float_array(name, value)
    if arr.ndim < 2 or arr.shape[-2:] != (3, 3):
        raise ValueError(f"{name} must have shape (..., 3, 3) (an inertia tensor), got {arr.shape}")
    return _check_symmetric(name, arr)


def _as_rotation(name: str, value) -> np.ndarray:
    """A proper rotation matrix from a ``(3, 3)`` matrix or a unit quaternion ``(4,)``."""
    arr = as_float_array(name, value)
    if arr.shape == (4,):
        from liebody import quaternion  # numba kernels: imported on first use only

        return quaternion.to_matrix(as_unit_quaternion(name, arr))
    if arr.shape != (3, 3):
        raise ValueError(
            f"{name} must be a (3, 3) rotation matrix or a unit quaternion (w, x, y, z) of "
            f"shape (4,), got shape {arr.shape}"
        )
    err = float(np.max(np.abs(arr.T @ arr - _EYE)))
    if err > ROTATION_TOL:
        raise ValueError(
            f"{name} must be a rotation matrix (orthogonal): max |R^T R - 1| = {err:.3e} "
            f"exceeds {ROTATION_TOL:.0e}"
        )
    det = float(np.linalg.det(arr))
    if det < 0:
        raise ValueError(
            f"{name} must be a proper rotation (det R = +1), got det R = {det:.6f} "
            f"(a reflection)"
        )
    return arr


_MAX = float(np.finfo(np.float64).max)


def _finite_result(what: str, rule: str, out: np.ndarray) -> np.ndarray:
    """``out``, or a ``ValueError`` naming ``what`` if an entry overflowed to inf/NaN."""
    if not np.isfinite(out).all():
        raise ValueError(
            f"{what}: the result is beyond the largest float64 ({_MAX:.3g}); {rule}")
    return out


def _pow2_scale(values: np.ndarray, axis=None) -> np.ndarray:
    """Exponents ``e`` with ``max |values| / 2^e`` in ``[1/2, 1)`` (0 where all are 0)."""
    big = np.max(np.abs(values), axis=axis, keepdims=axis is not None, initial=0.0)
    return np.frexp(big)[1]


def _center_of_mass(m: np.ndarray, p: np.ndarray) -> np.ndarray:
    """``sum m_a p_a / sum m_a`` in units (powers of two) where it cannot overflow."""
    em, ep = _pow2_scale(m), _pow2_scale(p)
    ms = np.ldexp(m, -em)
    return np.ldexp((ms @ np.ldexp(p, -ep)) / ms.sum(), ep)


def _mass_times_squares(M: float, terms) -> float:
    """``M sum_j c_j l_j^2`` for ``terms = [(c_j, l_j), ...]``, with the lengths in units
    of a power of two near the largest and ``M`` split into mantissa and exponent, so
    that no intermediate overflows or underflows; inf if the value is beyond float64."""
    lengths = np.array([abs(length) for _, length in terms])
    el = int(_pow2_scale(lengths))
    total = sum(c * math.ldexp(length, -el) ** 2 for c, length in terms)
    mM, eM = math.frexp(M)
    try:
        return math.ldexp(mM * total, eM + 2 * el)
    except OverflowError:
        return math.inf


def _solid(name: str, lengths: str, M: float, *moments) -> np.ndarray:
    """The principal moments ``[_mass_times_squares(M, terms) for terms in moments]``;
    a ``ValueError`` naming the solid and its arguments beyond float64."""
    out = np.array([_mass_times_squares(M, terms) for terms in moments])
    return _finite_result(name, f"the moments scale as mass * ({lengths})^2: express mass "
                          f"or {lengths} in larger units", out)


# --------------------------------------------------------------------------------------
# point masses, parallel axis theorem, rotations
# --------------------------------------------------------------------------------------


def tensor(masses, positions, origin=None) -> np.ndarray:
    """Inertia tensor of point masses, ``I_ij = sum_a m_a (r_a^2 delta_ij - r_a,i r_a,j)``.

    Implements the definition of the *moment of inertia tensor* (Hand & Finch, ch. 8),
    as the discrete sum.

    Parameters
    ----------
    masses : array_like, shape (n,)
        Point masses, ``n >= 1``. Each must be finite and ``>= 0`` (zero entries are
        allowed, e.g. to switch points off), and their total must be ``> 0``.
    positions : array_like, shape (n, 3)
        Positions of the masses.
    origin : array_like, shape (3,), optional
        Point about which the tensor is taken, ``r_a = positions[a] - origin``.
        ``None`` (default) means the centre of mass.

    Returns
    -------
    numpy.ndarray, shape (3, 3)
        The symmetric inertia tensor in the frame of ``positions``.
    """
    m = as_float_array("masses", masses)
    if m.ndim != 1 or m.shape[0] == 0:
        raise ValueError(f"masses must have shape (n,) with n >= 1, got {m.shape}")
    if np.any(m < 0):
        raise ValueError(f"masses must be >= 0, got min(masses) = {float(m.min())}")
    if not np.any(m > 0):
        raise ValueError("masses must have a positive total (all masses are zero)")
    p = as_float_array("positions", positions)
    if p.shape != (m.shape[0], 3):
        raise ValueError(
            f"positions must have shape (n, 3) = ({m.shape[0]}, 3) to match masses, "
            f"got {p.shape}"
        )
    if origin is None:
        o = _center_of_mass(m, p)
    else:
        o = as_float_array("origin", origin, shape=(3,))
    with np.errstate(over="ignore", invalid="ignore"):
        r = p - o
    _finite_result("tensor", "positions - origin overflows: express the positions in larger "
                   "units", r)
    # in units 2^em of mass and 2^er of length (exact scalings): no intermediate overflow
    em, er = _pow2_scale(m), _pow2_scale(r)
    ms, rs = np.ldexp(m, -em), np.ldexp(r, -er)
    mr = ms[:, None] * rs
    out = np.sum(mr * rs) * _EYE - mr.T @ rs
    with np.errstate(over="ignore"):
        out = np.ldexp(0.5 * (out + out.T), em + 2 * er)
    return _finite_result("tensor", "its entries scale as mass * length^2: express the "
                          "masses or the positions in larger units", out)


def parallel_axis(I_cm, mass, a) -> np.ndarray:
    """Move an inertia tensor from the centre of mass to another origin.

    Implements the parallel axis theorem (Hand & Finch, ch. 8),
    ``I_ij = I_ij^CM + M (a^2 delta_ij - a_i a_j)``.

    Parameters
    ----------
    I_cm : array_like, shape (..., 3, 3)
        Symmetric inertia tensor about the **centre of mass** (the theorem does not
        hold about any other point: shift through the centre of mass).
    mass : float or array_like, shape (...)
        Total mass ``M > 0``.
    a : array_like, shape (..., 3)
        Displacement between the centre of mass and the new origin. Its sign does
        not matter (the shift is quadratic in ``a``).

    Returns
    -------
    numpy.ndarray, shape (..., 3, 3)
        The tensor about the new origin; the leading axes of ``I_cm``, ``mass`` and
        ``a`` broadcast.

    Examples
    --------
    The thin-disk example of the theorem (``M = 2``, ``R = 3``): ``I_zz`` is ``M R^2 / 2``
    about the centre and ``3 M R^2 / 2`` about a point of the rim.

    >>> I = moments_to_tensor(thin_disk(2.0, 3.0))
    >>> float(I[2, 2]), float(parallel_axis(I, 2.0, [3.0, 0.0, 0.0])[2, 2])
    (9.0, 27.0)
    """
    I0 = _as_tensor3("I_cm", I_cm)
    m = as_float_array("mass", mass)
    if np.any(m <= 0):
        raise ValueError(f"mass must be > 0, got {mass!r}")
    d = as_float_array("a", a, last_dim=3)
    try:
        np.broadcast_shapes(I0.shape[:-2], m.shape, d.shape[:-1])
    except ValueError:
        raise ValueError(
            f"I_cm (shape {I0.shape}), mass (shape {m.shape}) and a (shape {d.shape}) must "
            f"broadcast against each other over their leading axes") from None
    # M (a^2 delta_ij - a_i a_j) in units 2^em of mass and 2^ea of length (exact
    # scalings), so that a^2 cannot overflow where M a^2 is a float64
    ea = _pow2_scale(d, axis=-1)
    ds = np.ldexp(d, -ea)
    mm, em = np.frexp(m)
    shift = (np.sum(ds * ds, axis=-1)[..., None, None] * _EYE
             - ds[..., :, None] * ds[..., None, :])
    with np.errstate(over="ignore", invalid="ignore"):
        out = I0 + np.ldexp(mm[..., None, None] * shift, (em[..., None] + 2 * ea)[..., None])
    return _finite_result("parallel_axis", "I_cm + mass (a^2 1 - a a^T) scales as mass * "
                          "length^2: express mass or a in larger units", out)


def rotate_tensor(I, orientation) -> np.ndarray:
    """Express a tensor in a rotated frame: ``R I R^T`` (Hand & Finch, ch. 8, principal axes).

    Parameters
    ----------
    I : array_like, shape (3, 3)
        Symmetric tensor in frame A.
    orientation : array_like, shape (3, 3) or (4,)
        Rotation frame A -> frame B (``v_B = R v_A``): a proper rotation matrix or a
        unit quaternion ``(w, x, y, z)``.

    Returns
    -------
    numpy.ndarray, shape (3, 3)
        The same tensor in frame B.
    """
    I0 = _as_tensor3("I", I)
    if I0.shape != (3, 3):
        raise ValueError(f"I must have shape (3, 3), got {I0.shape}")
    R = _as_rotation("orientation", orientation)
    out = R @ I0 @ R.T
    return 0.5 * (out + out.T)


def moments_to_tensor(moments, orientation=None) -> np.ndarray:
    """Tensor with the given principal moments: ``R diag(moments) R^T``.

    Parameters
    ----------
    moments : array_like, shape (3,)
        Principal moments ``(I1, I2, I3)``.
    orientation : array_like, shape (3, 3) or (4,), optional
        Rotation principal frame -> target frame (a proper rotation matrix whose
        columns are the principal axes, or a unit quaternion). ``None``: identity,
        i.e. the diagonal tensor.

    Returns
    -------
    numpy.ndarray, shape (3, 3)
    """
    mom = as_float_array("moments", moments, shape=(3,))
    D = np.diag(mom)
    if orientation is None:
        return D
    return rotate_tensor(D, orientation)


# --------------------------------------------------------------------------------------
# standard solids: principal moments about the centre of mass, symmetry axis = z
# --------------------------------------------------------------------------------------


def thin_disk(mass: float, radius: float) -> np.ndarray:
    """Uniform thin disk in the ``xy`` plane: ``(M R^2/4, M R^2/4, M R^2/2)``.

    Hand & Finch's thin-disk example (ch. 8, parallel axis theorem) computes
    ``I_zz = M R^2 / 2``; the in-plane moments follow from the perpendicular axis rule
    ``I_xx + I_yy = I_zz`` of a planar body (so the disk sits exactly on the triangle
    inequality).
    """
    M = as_positive_float("mass", mass)
    R = as_positive_float("radius", radius)
    return _solid("thin_disk", "radius", M, [(0.25, R)], [(0.25, R)], [(0.5, R)])


def thin_ring(mass: float, radius: float) -> np.ndarray:
    """Uniform thin ring (hoop) in the ``xy`` plane: ``(M R^2/2, M R^2/2, M R^2)``."""
    M = as_positive_float("mass", mass)
    R = as_positive_float("radius", radius)
    return _solid("thin_ring", "radius", M, [(0.5, R)], [(0.5, R)], [(1.0, R)])


def thin_rod(mass: float, length: float) -> np.ndarray:
    """Uniform thin rod along ``z``: ``(M l^2/12, M l^2/12, 0)``.

    The axial moment is exactly zero (all mass on the axis), so this is useful only
    as a :class:`Part` of a :func:`composite`; :class:`liebody.RigidBody` rejects it
    on its own (the ideal dumbbell, all mass on one line, has the same problem). Use
    :func:`solid_cylinder` for a rod of finite thickness.
    """
    M = as_positive_float("mass", mass)
    L = as_positive_float("length", length)
    return _solid("thin_rod", "length", M, [(1 / 12, L)], [(1 / 12, L)], [(0.0, L)])


def solid_sphere(mass: float, radius: float) -> np.ndarray:
    """Uniform solid ball: ``2/5 M R^2`` about every axis."""
    M = as_positive_float("mass", mass)
    R = as_positive_float("radius", radius)
    return _solid("solid_sphere", "radius", M, *[[(0.4, R)]] * 3)


def hollow_sphere(mass: float, radius: float) -> np.ndarray:
    """Uniform thin spherical shell: ``2/3 M R^2`` about every axis."""
    M = as_positive_float("mass", mass)
    R = as_positive_float("radius", radius)
    return _solid("hollow_sphere", "radius", M, *[[(2 / 3, R)]] * 3)


def box(mass: float, a: float, b: float, c: float) -> np.ndarray:
    """Uniform rectangular box with edge lengths ``a, b, c`` along ``x, y, z``.

    Returns ``(M (b^2 + c^2)/12, M (a^2 + c^2)/12, M (a^2 + b^2)/12)``. Edges may be
    zero: ``c = 0`` is a thin rectangular plate in the ``xy`` plane.
    """
    M = as_positive_float("mass", mass)
    a = as_positive_float("a", a, allow_zero=True)
    b = as_positive_float("b", b, allow_zero=True)
    c = as_positive_float("c", c, allow_zero=True)
    k = 1 / 12
    return _solid("box", "a, b, c", M, [(k, b), (k, c)], [(k, a), (k, c)], [(k, a), (k, b)])


def solid_cylinder(mass: float, radius: float, height: float) -> np.ndarray:
    """Uniform solid circular cylinder, axis along ``z``.

    Returns ``(M (3 R^2 + h^2)/12, M (3 R^2 + h^2)/12, M R^2/2)`` about the centre.
    """
    M = as_positive_float("mass", mass)
    R = as_positive_float("radius", radius)
    h = as_positive_float("height", height)
    t = [(0.25, R), (1 / 12, h)]
    return _solid("solid_cylinder", "radius, height", M, t, t, [(0.5, R)])


def solid_cone(mass: float, radius: float, height: float) -> np.ndarray:
    """Uniform solid right circular cone about its **centre of mass**, axis along ``z``.

    The centre of mass lies on the axis a quarter of the height above the base: in
    the returned frame the base is the disk at ``z = -h/4`` and the apex is at
    ``z = +3h/4``. The moments are

    * transverse ``I1 = I2 = 3/80 M (4 R^2 + h^2)``
      (= ``3/5 M (R^2/4 + h^2)`` about the apex minus ``M (3h/4)^2``, parallel axis
      theorem);
    * axial ``I3 = 3/10 M R^2``.
    """
    M = as_positive_float("mass", mass)
    R = as_positive_float("radius", radius)
    h = as_positive_float("height", height)
    t = [(0.15, R), (3 / 80, h)]
    return _solid("solid_cone", "radius, height", M, t, t, [(0.3, R)])


def ellipsoid(mass: float, a: float, b: float, c: float) -> np.ndarray:
    """Uniform solid ellipsoid with semi-axes ``a, b, c`` along ``x, y, z``.

    Returns ``(M (b^2 + c^2)/5, M (a^2 + c^2)/5, M (a^2 + b^2)/5)``. Semi-axes may be
    zero (``c = 0``: the flat limit, a uniform elliptic *plate* is a different body).
    """
    M = as_positive_float("mass", mass)
    a = as_positive_float("a", a, allow_zero=True)
    b = as_positive_float("b", b, allow_zero=True)
    c = as_positive_float("c", c, allow_zero=True)
    k = 0.2
    return _solid("ellipsoid", "a, b, c", M, [(k, b), (k, c)], [(k, a), (k, c)],
                  [(k, a), (k, b)])


# --------------------------------------------------------------------------------------
# composite bodies
# --------------------------------------------------------------------------------------


class Part(NamedTuple):
    """One part of a :func:`composite` body.

    Attributes
    ----------
    mass : float
        Mass of the part, ``> 0``.
    position : array_like, shape (3,)
        Position of the part's centre of mass in the composite frame.
    inertia : array_like, shape (3,) or (3, 3)
        The part's inertia **about its own centre of mass**, in the part frame:
        principal moments (e.g. from :func:`solid_cylinder`) or a symmetric tensor.
        Default ``(0, 0, 0)``: a point mass.
    orientation : array_like, shape (3, 3) or (4,), optional
        Rotation part frame -> composite frame: a proper rotation matrix or a unit
        quaternion ``(w, x, y, z)``. ``None`` (default): the frames are parallel.
    """

    mass: float
    position: Any
    inertia: Any = (0.0, 0.0, 0.0)
    orientation: Any = None


class MassProperties(NamedTuple):
    """Mass, centre of mass and central inertia tensor of a body (see :func:`composite`)."""

    mass: float
    center_of_mass: np.ndarray
    inertia: np.ndarray

    def about(self, point) -> np.ndarray:
        """Inertia tensor about ``point`` (composite frame), by the parallel axis theorem."""
        p = as_float_array("point", point, shape=(3,))
        return parallel_axis(self.inertia, self.mass, p - self.center_of_mass)


def _as_part(index: int, part) -> Part:
    if isinstance(part, Part):
        return part
    if isinstance(part, Mapping):
        try:
            return Part(**part)
        except TypeError as exc:
            raise TypeError(
                f"parts[{index}] must have keys mass, position and optionally inertia, "
                f"orientation: {exc}"
            ) from None
    if isinstance(part, tuple | list) and 2 <= len(part) <= 4:
        return Part(*part)
    raise TypeError(
        f"parts[{index}] must be a liebody.inertia.Part, a mapping or a tuple "
        f"(mass, position[, inertia[, orientation]]), got {type(part).__name__}"
    )


def composite(parts: Iterable) -> MassProperties:
    """Mass properties of a body made of rigidly joined parts.

    Each part's central tensor is rotated into the composite frame (``R I R^T``, the
    transformation law of Hand & Finch, ch. 8, principal axes) and moved to the combined
    centre of mass with the parallel axis theorem, then the tensors are summed.

    Parameters
    ----------
    parts : iterable of Part
        At least one part. Each may also be a tuple
        ``(mass, position[, inertia[, orientation]])`` or a mapping with those keys;
        see :class:`Part` for the meaning and conventions of each field. A point mass
        is a part with zero inertia (the default).

    Returns
    -------
    MassProperties
        ``(mass, center_of_mass, inertia)``: total mass, combined centre of mass
        (composite frame, ``(3,)``) and the inertia tensor about it (``(3, 3)``,
        composite frame).
    """
    if isinstance(parts, Part | Mapping):
        raise TypeError("parts must be an iterable of parts (wrap a single Part in a list)")
    items = [_as_part(i, p) for i, p in enumerate(parts)]
    if not items:
        raise ValueError("parts must contain at least one part")
    masses = np.empty(len(items))
    positions = np.empty((len(items), 3))
    tensors = np.empty((len(items), 3, 3))
    for i, part in enumerate(items):
        masses[i] = as_positive_float(f"parts[{i}].mass", part.mass)
        positions[i] = as_float_array(f"parts[{i}].position", part.position, shape=(3,))
        name = f"parts[{i}].inertia"
        inert = as_float_array(name, part.inertia)
        if inert.shape == (3,):
            if np.any(inert < 0):
                raise ValueError(f"{name} principal moments must be >= 0, got {inert.tolist()}")
            inert = np.diag(inert)
        elif inert.shape == (3, 3):
            inert = _check_symmetric(name, inert)
            lam = np.linalg.eigvalsh(inert)
            if lam[0] < -SYMMETRY_RTOL * float(np.max(np.abs(inert))):
                raise ValueError(
                    f"{name} must be positive semi-definite (no negative principal moment), "
                    f"got eigenvalues {lam.tolist()}"
                )
        else:
            raise ValueError(
                f"{name} must be principal moments of shape (3,) or a tensor of shape "
                f"(3, 3), got {inert.shape}"
            )
        if part.orientation is not None:
            R = _as_rotation(f"parts[{i}].orientation", part.orientation)
            inert = R @ inert @ R.T
        tensors[i] = inert
    with np.errstate(over="ignore"):
        total = _finite_result("composite", "the total mass overflows: express the masses "
                               "in larger units", np.array(masses.sum())).item()
    com = _center_of_mass(masses, positions)
    with np.errstate(over="ignore", invalid="ignore"):
        d = positions - com
    shifted = parallel_axis(tensors, masses, d)
    out = shifted.sum(axis=0)
    return MassProperties(total, com, 0.5 * (out + out.T))
