"""The :class:`RigidBody`: principal moments, principal axes, ``T`` and ``L`` of a body.

Implements the principal axes of Hand & Finch, *Analytical Mechanics* (Cambridge
University Press, 1998), ch. 8: the principal axis transformation that diagonalises the
inertia tensor, and ``L`` and ``T`` in the principal axis system. The zero-moment check
is motivated by the ideal dumbbell of the same chapter (Euler's equations), whose
axial moment is zero. Plain NumPy, float64.

Equal moments: one policy for all of liebody
--------------------------------------------
Two principal moments that differ by at most :data:`EQUAL_MOMENTS_RTOL` (``1e-10``) of
the largest are the *same* moment (:func:`moments_equal`). :class:`RigidBody` makes
them exactly equal (replaces them by their mean: a tensor diagonalised in floating
point returns a symmetric top's equal moments a few ulps apart) and records the
symmetry in ``symmetry_axis`` / ``is_spherical``. Everything downstream reads those
attributes or calls :func:`moments_equal`: the symmetric-body flows of the exact flow
and of the splittings, the analysis of the stability of the axes, the Lagrange top.
The exact-flow kernel, which can also be called on raw moments, keeps a round-off
guard of its own (moments within 4 ulps take its trig-only branch, where the two
branches agree to round-off); a body built through :class:`RigidBody` never reaches
it with moments that are not either exactly equal or more than ``1e-10`` apart.

Range of the moments
--------------------
Every principal moment must lie in ``[MOMENT_MIN, MOMENT_MAX] = [1e-100, 1e100]``, in
whatever units the body is given. The integrators and analyses form products of up to
three moments (``I1 I2 I3`` in the exact flow's frequency, the determinant of the
inertia, the stability exponents), and these stay inside float64's normal range
(``2.2e-308`` to ``1.8e308``) exactly when each moment does: outside it they overflow
to ``inf`` or lose their digits to underflow, far from where the moments were given.
Bodies beyond the range are refused with the advice to rescale the units (the Earth,
``C = 8.034e37 kg m^2``, is well inside it; a galaxy is ``~1e68 kg m^2`` in
``kg kpc^2`` units).
"""

from __future__ import annotations

import numpy as np

from liebody._validate import as_float_array, as_positive_float
from liebody.inertia import _check_symmetric, tensor

__all__ = ["EQUAL_MOMENTS_RTOL", "MOMENT_MAX", "MOMENT_MIN", "TRIANGLE_RTOL", "ZERO_RTOL",
           "RigidBody", "moments_equal"]

#: A principal moment ``|I_k| <= ZERO_RTOL * max_i |I_i|`` is treated as zero.
ZERO_RTOL = 1e-12

#: ``I_i + I_j >= I_k - TRIANGLE_RTOL * max(I)`` is accepted (planar bodies sit on equality).
TRIANGLE_RTOL = 1e-12

#: Two moments are the same moment when ``|I_i - I_j| <= EQUAL_MOMENTS_RTOL * max(I)``.
EQUAL_MOMENTS_RTOL = 1e-10

#: Accepted range of every principal moment, in any units: products of three moments
#: stay within float64's normal range (module docstring, "Range of the moments").
MOMENT_MIN = 1e-100
MOMENT_MAX = 1e100

_AXIS_NAMES = ("I1", "I2", "I3")


def _readonly(arr: np.ndarray) -> np.ndarray:
    arr = np.array(arr, dtype=np.float64, copy=True)
    arr.flags.writeable = False
    return arr


def _principal_axes(sym: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Ascending eigenvalues and a proper rotation of eigenvectors with fixed signs.

    Columns 1 and 2 are signed so that their largest-magnitude component (the first,
    on a tie) is positive; column 3 is their cross product, so ``det = +1``. Works on
    one tensor ``(3, 3)`` or a stack ``(N, 3, 3)``.
    """
    w, V = np.linalg.eigh(sym)
    V = V.copy()
    for k in (0, 1):
        col = V[..., :, k]
        big = np.take_along_axis(col, np.argmax(np.abs(col), axis=-1)[..., None], axis=-1)
        V[..., :, k] = np.where(big < 0, -col, col)
    V[..., :, 2] = np.cross(V[..., :, 0], V[..., :, 1])
    return w, V


def moments_equal(a: float, b: float, scale: float) -> bool:
    """Whether moments ``a`` and ``b`` of a body whose largest moment is ``scale`` are the
    same moment (the one policy: ``|a - b| <= EQUAL_MOMENTS_RTOL * scale``)."""
    return abs(a - b) <= EQUAL_MOMENTS_RTOL * scale


_PAIRS = ((0, 1), (0, 2), (1, 2))


def _equalize(moments: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Make equal moments (:func:`moments_equal`) exactly equal: their mean.

    ``moments`` ``(N, 3)``. Returns the moments and which of the pairs (0, 1), (0, 2),
    (1, 2) are equal, ``(N, 3)`` bool. Two pairs equal make a sphere.
    """
    scale = np.max(moments, axis=-1)
    equal = np.stack([np.abs(moments[:, i] - moments[:, j]) <= EQUAL_MOMENTS_RTOL * scale
                      for i, j in _PAIRS], axis=-1)
    out = np.array(moments, dtype=np.float64)
    sphere = equal.sum(axis=-1) >= 2
    out[sphere] = out[sphere].mean(axis=-1, keepdims=True)
    one = equal.sum(axis=-1) == 1
    for p, (i, j) in enumerate(_PAIRS):
        rows = one & equal[:, p]
        mean = 0.5 * (out[rows, i] + out[rows, j])
        out[rows, i] = mean
        out[rows, j] = mean
    return out, equal


class RigidBody:
    """A rigid body described by its principal moments of inertia.

    Hand & Finch, *Analytical Mechanics*, ch. 8, principal axes: a real symmetric
    inertia tensor is diagonalised by a rotation, ``I = A diag(I1, I2, I3) A^T``, whose
    columns are the principal axes. The body frame used by every other part of liebody
    is this principal frame: ``omega`` and ``L`` are components along the principal axes
    (``L_k = I_k omega_k`` and ``T = 1/2 sum_k I_k omega_k^2`` in the principal axis
    system).

    Parameters
    ----------
    inertia : array_like, shape (3,) or (3, 3)
        Either the three principal moments ``(I1, I2, I3)`` -- kept **in the given
        order**, which defines body axes 1, 2, 3, with ``axes`` the identity -- or a
        symmetric inertia tensor in some input frame, which is diagonalised with
        :func:`numpy.linalg.eigh` (moments in **ascending** order). For many bodies at
        once (an ensemble of different inertias), see :meth:`batch`.
    mass : float, optional
        Total mass (``> 0``), or ``None`` (default) when only the rotation matters.
    check_triangle : bool, default True
        Reject principal moments that violate the triangle inequality
        ``I_i + I_j >= I_k``: no distribution of positive mass has them. Pass
        ``False`` to study such bodies anyway, e.g. the Hairer--Lubich--Wanner test
        problem ``I = (2, 1, 2/3)``.

    Raises
    ------
    TypeError
        ``inertia`` is not real-valued, ``mass`` not a real number, or
        ``check_triangle`` not a bool.
    ValueError
        ``inertia`` has the wrong shape, is not finite, is a non-symmetric tensor
        (``max|I - I^T| > 1e-12 max|I|``), has a negative principal moment, has a zero
        principal moment (``<= ZERO_RTOL * max``: an ideal rod or dumbbell, all mass on
        one line, has no finite rotational dynamics about its axis), has a principal
        moment outside ``[MOMENT_MIN, MOMENT_MAX] = [1e-100, 1e100]`` (products of
        three moments would leave float64: rescale the units, see the module
        docstring), or violates the triangle inequality beyond ``TRIANGLE_RTOL * max``
        (unless ``check_triangle=False``); ``mass`` is not finite and positive.

    Attributes
    ----------
    moments : numpy.ndarray, shape (3,) (``(N, 3)`` for a batch)
        Principal moments ``(I1, I2, I3)`` (read-only).
    axes : numpy.ndarray, shape (3, 3)
        Proper rotation (``det = +1``) whose columns are the principal axes expressed
        in the input frame, so ``inertia_tensor == axes @ diag(moments) @ axes.T``
        (read-only). For tensor input the signs are deterministic: columns 1 and 2
        have their largest-magnitude component positive and column 3 is their cross
        product.
    inertia_tensor : numpy.ndarray, shape (3, 3)
        The inertia tensor in the input frame (read-only).
    mass : float or None
    symmetry_axis : int or None
        Index (0, 1 or 2) of the distinct moment when exactly two moments are equal
        (a symmetric top), else ``None``. Moments are equal when they differ by at
        most ``EQUAL_MOMENTS_RTOL * max(moments)`` (``1e-10``), and are then made exactly
        equal (their mean; see the module docstring); when two different pairs are
        equal to that tolerance the body counts as spherical.
    is_symmetric : bool
        Exactly two moments equal (a symmetric top, not a sphere).
    is_spherical : bool
        All three moments equal (a spherical top).
    free_axes : tuple of int
        Indices of the principal axes that the inertia does not determine: ``()``
        for an asymmetric body, the two equal-moment indices for a symmetric top (any
        orthonormal pair in their plane, i.e. any rotation of ``axes`` about the
        symmetry axis, is equally principal), ``(0, 1, 2)`` for a spherical top
        (every frame is principal). ``axes`` is still a valid proper rotation; which
        one is returned is deterministic but conventional.
    """

    __slots__ = ("_axes", "_equal", "_mass", "_moments", "_tensor")

    def __init__(self, inertia, mass=None, check_triangle: bool = True, *,
                 _batch: bool = False) -> None:
        if not isinstance(check_triangle, bool | np.bool_):
            raise TypeError(
                f"check_triangle must be a bool, got {type(check_triangle).__name__}"
            )
        arr = as_float_array("inertia", inertia)
        batch = bool(_batch)
        if batch and arr.ndim >= 2 and arr.shape[0] == 0:
            raise ValueError("inertia of a batch must hold at least one body, got shape "
                             f"{arr.shape}")
        shapes = ((3,), (3, 3)) if not batch else ((None, 3), (None, 3, 3))
        if arr.ndim == len(shapes[0]) and arr.shape[-1] == 3:
            moments = arr.reshape(-1, 3).copy()
            axes = np.broadcast_to(np.eye(3), (moments.shape[0], 3, 3))
            tensor_input = False
        elif arr.ndim == len(shapes[1]) and arr.shape[-2:] == (3, 3):
            moments, axes = _principal_axes(_check_symmetric("inertia", arr).reshape(-1, 3, 3))
            tensor_input = True
        elif batch:
            raise ValueError("inertia of a batch must be principal moments per body, shape "
                             f"(N, 3), or tensors, shape (N, 3, 3); got shape {arr.shape}")
        else:
            raise ValueError(
                "inertia must be three principal moments, shape (3,), or a symmetric "
                f"3x3 tensor, shape (3, 3); got shape {arr.shape} (a batch of bodies: "
                "RigidBody.batch)"
            )
        self._check_moments(moments, tensor_input, bool(check_triangle), batch)
        moments, equal = _equalize(moments)
        t = np.einsum("nij,nj,nkj->nik", axes, moments, axes)
        t = 0.5 * (t + np.swapaxes(t, -1, -2))
        if not batch:
            moments, axes, t, equal = moments[0], axes[0], t[0], equal[0]
        self._moments = _readonly(moments)
        self._axes = _readonly(axes)
        self._tensor = _readonly(t)
        self._equal = equal
        self._mass = None if mass is None else self._as_mass(mass, batch)

    def _as_mass(self, mass, batch: bool):
        if not batch or np.ndim(mass) == 0:
            return as_positive_float("mass", mass)
        m = as_float_array("mass", mass, shape=(len(self),))
        if np.any(m <= 0):
            raise ValueError(f"mass must be > 0 for every body, got {m.min():g} at body "
                             f"{int(np.argmin(m))}")
        return _readonly(m)

    @staticmethod
    def _check_moments(moments: np.ndarray, tensor_input: bool, check_triangle: bool,
                       batch: bool) -> None:
        """Validate principal moments ``(N, 3)``; the message names the first bad body."""
        what = "eigenvalue of the inertia tensor" if tensor_input else "principal moment"
        scale = np.max(np.abs(moments), axis=-1, keepdims=True)

        def first(bad: np.ndarray) -> tuple[str, int, int] | None:
            if not bad.any():
                return None
            n, k = np.argwhere(bad)[0]
            return (f"body {n}: " if batch else ""), int(n), int(k)

        hit = first(moments < -ZERO_RTOL * scale)
        if hit:
            who, n, k = hit
            raise ValueError(
                f"inertia must be positive definite: {who}{what} {_AXIS_NAMES[k]} = "
                f"{float(moments[n, k])!r} is negative; moments of inertia are > 0")
        hit = first(np.abs(moments) <= ZERO_RTOL * scale)
        if hit:
            who, n, k = hit
            raise ValueError(
                f"inertia has a zero principal moment ({who}{what} {_AXIS_NAMES[k]} = "
                f"{float(moments[n, k])!r}, below {ZERO_RTOL:.0e} x the largest): an ideal thin "
                "rod or dumbbell (all mass on one line, I3 = 0) has no finite "
                "rotational dynamics about that axis "
                "(omega = L / I is undefined). Give it a small thickness, e.g. "
                "liebody.inertia.solid_cylinder instead of thin_rod.")
        hit = first(~((MOMENT_MIN <= moments) & (moments <= MOMENT_MAX)))
        if hit:
            who, n, k = hit
            v = float(moments[n, k])
            raise ValueError(
                f"inertia: {who}{what} {_AXIS_NAMES[k]} = {v:.6g} is outside "
                f"[{MOMENT_MIN:g}, {MOMENT_MAX:g}]: the integrators form products of "
                f"three moments (I1 I2 I3), which would {'over' if v > 1 else 'under'}"
                f"flow float64; rescale the units, e.g. kg km^2 instead of kg m^2 "
                f"(1 kg km^2 = 1e6 kg m^2), and L or omega with them")
        if check_triangle:
            for k in range(3):
                i, j = (k + 1) % 3, (k + 2) % 3
                hit = first((moments[:, i] + moments[:, j]
                             < moments[:, k] - TRIANGLE_RTOL * scale[:, 0])[:, None])
                if hit:
                    who, n, _ = hit
                    ni, nj, nk = (_AXIS_NAMES[m] for m in sorted((i, j)) + [k])
                    raise ValueError(
                        f"inertia principal moments violate the triangle inequality "
                        f"I_i + I_j >= I_k: {who}{ni} + {nj} = "
                        f"{float(moments[n, i] + moments[n, j])!r} < {nk} = "
                        f"{float(moments[n, k])!r}. No real body has these moments; pass "
                        "check_triangle=False to use them anyway (e.g. the "
                        "Hairer-Lubich-Wanner test problem I = (2, 1, 2/3)).")

    # ----------------------------------------------------------------------------------
    # bodies of a batch
    # ----------------------------------------------------------------------------------

    @classmethod
    def batch(cls, inertia, mass=None, check_triangle: bool = True) -> RigidBody:
        """``N`` bodies in one object: principal moments ``(N, 3)`` or tensors ``(N, 3, 3)``.

        An ensemble of different inertias for :func:`liebody.integrate`, validated as
        :class:`RigidBody` validates one body (a message names the first bad body). The
        attributes carry the body axis: ``moments`` ``(N, 3)``, ``axes`` and
        ``inertia_tensor`` ``(N, 3, 3)``, ``mass`` a float or ``(N,)``,
        ``symmetry_axis`` an int array (``-1``: not a symmetric top), ``is_symmetric``
        and ``is_spherical`` bool arrays; ``len(bodies)`` is ``N`` and ``bodies[i]`` is
        body ``i`` as a single :class:`RigidBody`.
        """
        return cls(inertia, mass, check_triangle, _batch=True)

    @property
    def shape(self) -> tuple[int, ...]:
        """``()`` for one body, ``(N,)`` for a batch of ``N`` bodies."""
        return self._moments.shape[:-1]

    def __len__(self) -> int:
        if not self.shape:
            raise TypeError("a single RigidBody has no len(); a batch of bodies has")
        return self.shape[0]

    def __getitem__(self, i) -> RigidBody:
        """Body ``i`` of a batch as a single :class:`RigidBody`; a slice or an index array
        gives a smaller batch."""
        if not self.shape:
            raise TypeError("a single RigidBody cannot be indexed; a batch of bodies can")
        single = np.ndim(i) == 0 and not isinstance(i, slice)
        if single:
            i = int(i)
        mass = self._mass
        if mass is not None and np.ndim(mass):
            mass = float(mass[i]) if single else _readonly(mass[i])
        out = RigidBody.__new__(RigidBody)
        out._moments = _readonly(self._moments[i])
        out._axes = _readonly(self._axes[i])
        out._tensor = _readonly(self._tensor[i])
        out._equal = self._equal[i]
        out._mass = mass
        return out

    # ----------------------------------------------------------------------------------
    # constructors
    # ----------------------------------------------------------------------------------

    @classmethod
    def from_point_masses(
        cls, masses, positions, origin=None, *, check_triangle: bool = True
    ) -> RigidBody:
        """Body made of point masses; see :func:`liebody.inertia.tensor`.

        The tensor is taken about ``origin`` (default: the centre of mass; another
        point is a fixed point: Hand & Finch, ch. 8, motion of a body with one point
        fixed) and diagonalised; ``mass`` is the total mass.
        """
        I = tensor(masses, positions, origin)
        total = float(np.sum(np.asarray(masses, dtype=np.float64)))
        return cls(I, mass=total, check_triangle=check_triangle)

    # ----------------------------------------------------------------------------------
    # read-only attributes
    # ----------------------------------------------------------------------------------

    @property
    def moments(self) -> np.ndarray:
        """Principal moments ``(I1, I2, I3)``, shape (3,)."""
        return self._moments

    @property
    def axes(self) -> np.ndarray:
        """Principal axes as the columns of a proper rotation, input frame."""
        return self._axes

    @property
    def inertia_tensor(self) -> np.ndarray:
        """``axes @ diag(moments) @ axes.T``: the inertia tensor in the input frame."""
        return self._tensor

    @property
    def mass(self):
        """Total mass, or ``None`` (an array ``(N,)`` for a batch given one per body)."""
        return self._mass

    @property
    def symmetry_axis(self):
        """Index of the distinct moment of a symmetric top, else ``None``.

        For a batch, an int array ``(N,)`` with ``-1`` where a body is not a symmetric top.
        """
        e = np.asarray(self._equal)
        axis = np.where(e.sum(axis=-1) == 1, 2 * e[..., 0] + e[..., 1] + 0 * e[..., 2], -1)
        # the distinct moment of pair (0, 1) is 2, of (0, 2) is 1, of (1, 2) is 0
        if not self.shape:
            return None if axis < 0 else int(axis)
        return axis

    @property
    def is_symmetric(self):
        """Exactly two equal moments (symmetric, not spherical, top); per body for a batch."""
        out = np.asarray(self._equal).sum(axis=-1) == 1
        return bool(out) if not self.shape else out

    @property
    def is_spherical(self):
        """All three moments equal; per body for a batch."""
        out = np.asarray(self._equal).sum(axis=-1) >= 2
        return bool(out) if not self.shape else out

    @property
    def free_axes(self) -> tuple[int, ...]:
        """Indices of principal axes not fixed by the inertia (degenerate moments)."""
        if self.shape:
            raise TypeError("free_axes is per body: take one body of the batch, body[i]")
        e = self._equal
        if e.sum() >= 2:
            return (0, 1, 2)
        for p, pair in enumerate(_PAIRS):
            if e[p]:
                return pair
        return ()

    # ----------------------------------------------------------------------------------
    # dynamics helpers (T and L in the principal axis system), vectorised over (..., 3)
    # ----------------------------------------------------------------------------------

    def kinetic_energy(self, omega) -> np.ndarray | float:
        """Rotational kinetic energy ``T = 1/2 sum_k I_k omega_k^2`` (principal axes).

        Parameters
        ----------
        omega : array_like, shape (..., 3)
            Angular velocity, principal-frame (body) components.

        Returns
        -------
        float or numpy.ndarray, shape (...)
        """
        w = as_float_array("omega", omega, last_dim=3)
        return 0.5 * np.sum(self._moments * w * w, axis=-1)

    def angular_momentum(self, omega) -> np.ndarray:
        """Body angular momentum ``L_k = I_k omega_k`` (principal axes), shape (..., 3)."""
        w = as_float_array("omega", omega, last_dim=3)
        return self._moments * w

    def angular_velocity(self, L) -> np.ndarray:
        """Body angular velocity ``omega_k = L_k / I_k``, the inverse of
        :meth:`angular_momentum`, shape (..., 3)."""
        Lb = as_float_array("L", L, last_dim=3)
        return Lb / self._moments

    def to_principal(self, v) -> np.ndarray:
        """Components along the principal axes of a vector given in the input frame:
        ``axes.T @ v``, vectorised over (..., 3) (per body for a batch)."""
        x = as_float_array("v", v, last_dim=3)
        return np.einsum("...i,...ij->...j", x, self._axes)

    def from_principal(self, v) -> np.ndarray:
        """Input-frame components of a vector given along the principal axes:
        ``axes @ v``, vectorised over (..., 3) (per body for a batch)."""
        x = as_float_array("v", v, last_dim=3)
        return np.einsum("...j,...ij->...i", x, self._axes)

    def __repr__(self) -> str:
        if self.shape:
            return f"RigidBody(<batch of {len(self)} bodies>)"
        moments = [float(x) for x in self._moments]
        return f"RigidBody(moments={moments!r}, mass={self._mass!r})"
