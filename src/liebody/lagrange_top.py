"""The heavy symmetric (Lagrange) top (Hand & Finch, *Analytical Mechanics*, ch. 8).

A symmetric body (``I1 = I2``, moments taken **about the fixed point**) turns about a
fixed point at the origin in uniform gravity ``-g e_z``; its centre of mass lies on the
symmetry axis, body axis 3, at the distance ``l`` from the fixed point
(``cm = (0, 0, l)`` in the body frame), and ``M g l > 0``. With the z-x-z Euler angles
``(phi, theta, psi)`` of :mod:`liebody.euler` (``V = Rz(phi) Rx(theta) Rz(psi)`` body
-> space), ``theta`` is the tilt of the symmetry axis from the vertical and the
Lagrangian is (Hand & Finch, *Analytical Mechanics*, Cambridge University Press, 1998,
ch. 8, the heavy symmetric top; "H&F ch. 8" below)::

    L = 1/2 I1 (phidot^2 sin^2 theta + thetadot^2) + 1/2 I3 (psidot + phidot cos theta)^2
        - M g l cos theta

``phi`` and ``psi`` are cyclic, so ``p_phi`` (the vertical component of the angular
momentum) and ``p_psi = I3 omega_3`` (its component along the symmetry axis) are
conserved, and so are the energy ``E`` and ``E' = E - p_psi^2 / (2 I3)``. The tilt obeys
the 1-D motion ``E' = 1/2 I1 thetadot^2 + V_eff(theta)``.

Contents
--------
:class:`LagrangeTop`
    The top ``(I1, I3, mgl)``: Lagrangian, energy, the conserved quantities from Euler
    angles and rates or from a state ``(q, L)``, the effective potential, steady
    precession (exact rates, fast-top approximations, minimum spin, initial conditions).
:class:`TopMotion`
    One motion, given by its constants ``(p_phi, p_psi, E')``: turning points, nutation
    period (complete elliptic integral or quadrature), ``theta(t)`` and the kind of
    curve the symmetry axis draws (monotone precession, loops or cusps).

Conventions
-----------
Quaternions are scalar-first ``(w, x, y, z)``, unit, body -> space; ``L`` is the
body-frame angular momentum along the principal axes; angles in radians. In
``u = cos(theta)`` the turning points are written ``u1 = cos(theta1) >= u2 =
cos(theta2)`` (``theta1 <= theta2``: ``theta1`` is the highest position of the axis).
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass
from typing import Literal, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import integrate, optimize, special

from liebody import euler as _euler
from liebody._validate import as_float_array, as_positive_float, as_unit_quaternion
from liebody.rigid_body import EQUAL_MOMENTS_RTOL, RigidBody

__all__ = [
    "DOUBLE_ROOT_RTOL",
    "STANDARD_GRAVITY",
    "ConservedQuantities",
    "LagrangeTop",
    "SteadyPrecession",
    "TopMotion",
    "TurningPoints",
]

Array = NDArray[np.float64]

#: Default ``g`` of :meth:`LagrangeTop.from_body` (the same as :class:`liebody.HeavyTop`).
STANDARD_GRAVITY: float = 9.81

#: Default relative tolerance of :meth:`TopMotion.turning_points` below which the
#: maximum of the cubic ``f(u)`` on ``[-1, 1]`` counts as zero (a double root: steady
#: precession, ``theta1 == theta2``).
DOUBLE_ROOT_RTOL: float = 1e-12

_EPS = float(np.finfo(np.float64).eps)

#: The space vertical ``e_z`` (gravity acts along ``-e_z``).
_E_Z = np.array([0.0, 0.0, 1.0])
_E_Z.flags.writeable = False

Branch = Literal["slow", "fast"]
MotionKind = Literal["steady", "monotone", "loops", "cusps", "planar"]


# --------------------------------------------------------------------------------------
# validation helpers
# --------------------------------------------------------------------------------------


def _real(name: str, value) -> float:
    """A finite real scalar (any sign)."""
    if isinstance(value, bool | np.bool_) or not isinstance(
        value, numbers.Real | np.floating | np.integer
    ):
        raise TypeError(f"{name} must be a real number, got {type(value).__name__}")
    v = float(value)
    if not math.isfinite(v):
        raise ValueError(f"{name} must be finite, got {v}")
    return v


def _mgl(value) -> float:
    if isinstance(value, bool | np.bool_) or not isinstance(
        value, numbers.Real | np.floating | np.integer
    ):
        raise TypeError(f"mgl must be a real number, got {type(value).__name__}")
    v = float(value)
    if not (math.isfinite(v) and v > 0.0):
        raise ValueError(
            f"mgl = M g l must be finite and > 0 (centre of mass on the +body-axis-3 side "
            f"of the fixed point, l > 0, gravity -g e_z), got {v}. For a centre "
            f"of mass at l < 0 reverse body axis 3 (rotate the body frame by pi about axis 1)."
        )
    return v


def _theta_open(name: str, value) -> float:
    """A tilt strictly inside ``(0, pi)`` (steady precession needs ``sin(theta) != 0``)."""
    th = _real(name, value)
    if not (0.0 < th < math.pi) or math.sin(th) == 0.0:
        raise ValueError(
            f"{name} must lie in the open interval (0, pi), got {th!r}: at theta = 0 or pi "
            f"the symmetry axis is vertical (a sleeping top) and the precession rate "
            f"phidot = beta / (I1 sin^2 theta) of steady precession is undefined"
        )
    return th


def _scalar_out(a: np.ndarray):
    return float(a) if np.ndim(a) == 0 else a


def _branch(branch) -> Branch:
    if branch not in ("slow", "fast"):
        raise ValueError(f"branch must be 'slow' or 'fast', got {branch!r}")
    return branch


def _rates_pair(angles: ArrayLike, rates: ArrayLike) -> tuple[Array, Array]:
    a = as_float_array("angles", angles, last_dim=3)
    r = as_float_array("rates", rates, last_dim=3)
    try:
        a, r = np.broadcast_arrays(a, r)
    except ValueError:
        raise ValueError(
            f"angles (shape {a.shape}) and rates (shape {r.shape}) must broadcast against "
            f"each other over their leading axes"
        ) from None
    return a, r


def _state_pair(q: ArrayLike, L: ArrayLike) -> tuple[Array, Array]:
    qq = as_unit_quaternion("q", q)
    LL = as_float_array("L", L, last_dim=3)
    try:
        batch = np.broadcast_shapes(qq.shape[:-1], LL.shape[:-1])
    except ValueError:
        raise ValueError(
            f"q (shape {qq.shape}) and L (shape {LL.shape}) must broadcast against each "
            f"other over their leading axes"
        ) from None
    return np.broadcast_to(qq, batch + (4,)), np.broadcast_to(LL, batch + (3,))


# --------------------------------------------------------------------------------------
# result types
# --------------------------------------------------------------------------------------


class ConservedQuantities(NamedTuple):
    """The constants of motion of the Lagrange top (Hand & Finch, ch. 8, the heavy top).

    Each field is a float for a single state or an array of the batch shape.

    Attributes
    ----------
    p_phi
        ``dL/dphidot = (I1 sin^2 th + I3 cos^2 th) phidot + I3 psidot cos th``, the
        vertical (space ``z``) component of the angular momentum.
    p_psi
        ``dL/dpsidot = I3 (psidot + phidot cos th) = I3 omega_3``, the component along
        the symmetry axis (body ``L_3``).
    energy
        ``E = T + M g l cos th``.
    e_prime
        ``E' = E - p_psi^2 / (2 I3) = 1/2 I1 (phidot^2 sin^2 th + thetadot^2) + M g l cos th``.
    """

    p_phi: float | Array
    p_psi: float | Array
    energy: float | Array
    e_prime: float | Array


class TurningPoints(NamedTuple):
    """Turning points of the tilt, Hand & Finch ch. 8 (see :meth:`TopMotion.turning_points`).

    Attributes
    ----------
    theta1, theta2
        ``0 <= theta1 <= theta2 <= pi``: the tilt oscillates in ``[theta1, theta2]``.
    u1, u2
        ``u1 = cos(theta1) >= u2 = cos(theta2)``, the two roots of the cubic ``f(u)`` in
        ``[-1, 1]`` that bound the motion.
    u3
        The third root of ``f``, ``u3 >= u1`` (``u3 >= 1`` for a real motion).
    degenerate
        ``True`` for a double root (``theta1 == theta2``): steady precession, or a
        sleeping top at ``theta = 0``.
    """

    theta1: float
    theta2: float
    u1: float
    u2: float
    u3: float
    degenerate: bool


@dataclass(frozen=True)
class SteadyPrecession:
    """Steady precession at the tilt ``theta0`` with spin ``omega3`` (heavy symmetric top).

    Attributes
    ----------
    theta0, omega3
        The tilt and the spin ``omega_3 = p_psi / I3`` asked for.
    phidot_fast, phidot_slow
        The two exact precession rates ``phidot0 = beta / (I1 sin^2 theta0)``:
        ``|phidot_fast| >= |phidot_slow|``. ``fast`` is the ``+`` root of the quadratic
        in ``beta`` (Hand & Finch, ch. 8, the heavy symmetric top) and ``slow`` its ``-``
        root.
    beta_fast, beta_slow
        The two roots ``beta = p_phi - p_psi cos theta0`` of
        ``cos(theta0) beta^2 - p_psi sin^2(theta0) beta + M g l I1 sin^4(theta0) = 0``.
    omega3_min
        The minimum spin ``(2/I3) sqrt(M g l I1 cos theta0)`` (``0`` for
        ``theta0 >= pi/2``).
    """

    theta0: float
    omega3: float
    phidot_fast: float
    phidot_slow: float
    beta_fast: float
    beta_slow: float
    omega3_min: float


# --------------------------------------------------------------------------------------
# the top
# --------------------------------------------------------------------------------------


@dataclass(frozen=True)
class LagrangeTop:
    """A heavy symmetric (Lagrange) top (Hand & Finch, *Analytical Mechanics*, ch. 8).

    Parameters
    ----------
    I1
        Transverse moment ``I1 = I2`` **about the fixed point** (> 0). From the centre
        of mass: ``I1 = I1_cm + M l^2`` (:func:`liebody.inertia.parallel_axis`).
    I3
        Moment about the symmetry axis, body axis 3 (> 0).
    mgl
        ``M g l > 0``: mass times gravity times the distance of the centre of mass from
        the fixed point along ``+`` body axis 3. The potential is
        ``V = M g l cos(theta)``.

    Raises
    ------
    TypeError
        A parameter is not a real number.
    ValueError
        A parameter is not finite or not ``> 0``.

    Notes
    -----
    Use :meth:`from_body` (a :class:`~liebody.RigidBody` plus ``mgl`` or the centre of
    mass), :meth:`from_mass` (``mass``, ``l``, ``g``) or :meth:`from_heavy_top` (a
    :class:`liebody.HeavyTop` scene) to build one from other data.
    """

    I1: float
    I3: float
    mgl: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "I1", as_positive_float("I1", self.I1))
        object.__setattr__(self, "I3", as_positive_float("I3", self.I3))
        object.__setattr__(self, "mgl", _mgl(self.mgl))

    # ----------------------------------------------------------------------------------
    # constructors
    # ----------------------------------------------------------------------------------

    @classmethod
    def from_mass(
        cls, I1: float, I3: float, *, mass: float, l: float, g: float = STANDARD_GRAVITY
    ) -> LagrangeTop:
        """Top with ``mgl = mass * g * l`` (Hand & Finch, ch. 8, the heavy symmetric top).

        Parameters
        ----------
        I1, I3
            Moments about the fixed point (> 0).
        mass
            Total mass ``M > 0``.
        l
            Distance of the centre of mass from the fixed point along ``+`` body axis 3
            (must be > 0).
        g
            Gravitational acceleration (> 0), default :data:`STANDARD_GRAVITY`.

        Raises
        ------
        TypeError, ValueError
            As for the constructor; ``mass`` or ``g`` not > 0; ``l <= 0`` (reported as
            ``mgl <= 0``).
        """
        m = as_positive_float("mass", mass)
        gg = as_positive_float("g", g)
        ll = _real("l", l)
        return cls(I1, I3, _mgl(m * gg * ll))

    @classmethod
    def from_body(
        cls,
        body: RigidBody,
        *,
        mgl: float | None = None,
        l: float | None = None,
        cm: ArrayLike | None = None,
        mass: float | None = None,
        g: float = STANDARD_GRAVITY,
        rtol: float = EQUAL_MOMENTS_RTOL,
    ) -> LagrangeTop:
        """Top from a :class:`~liebody.RigidBody` whose moments are about the fixed point.

        The heavy symmetric top needs ``I1 = I2`` and the symmetry axis along body axis 3
        (index 2),
        the axis that carries the centre of mass. Give either ``mgl`` or the centre of
        mass (``l``, or the body-frame vector ``cm``, together with ``mass`` -- default
        ``body.mass`` -- and ``g``).

        Parameters
        ----------
        body
            The body; ``body.moments = (I1, I2, I3)`` about the fixed point.
        mgl
            ``M g l > 0`` directly.
        l
            Distance of the centre of mass along ``+`` body axis 3 (> 0).
        cm
            Centre of mass in the body (principal) frame, shape (3,), measured from the
            fixed point; must be ``(0, 0, l)`` with ``l > 0``: its distance from axis 3
            may be at most ``rtol * |cm|``.
        mass
            Total mass, default ``body.mass``.
        g
            Gravitational acceleration (> 0).
        rtol
            Relative tolerance of the checks ``|I1 - I2| <= rtol * max(moments)`` and
            ``hypot(cm_1, cm_2) <= rtol * |cm|``; ``I1`` is set to ``(I1 + I2) / 2``.

        Raises
        ------
        TypeError
            ``body`` is not a RigidBody; a number is not real.
        ValueError
            The symmetry axis is not body axis 3 (relabel the body: the symmetry axis
            must be the third principal axis); ``I1 != I2`` beyond ``rtol``; ``cm`` is
            off the symmetry axis; both or neither of ``mgl`` and ``l``/``cm`` given,
            or both ``l`` and ``cm``; no mass known; ``mgl <= 0`` (including ``l <= 0``).
        """
        if not isinstance(body, RigidBody):
            raise TypeError(f"body must be a liebody.RigidBody, got {type(body).__name__}")
        tol = as_positive_float("rtol", rtol)
        I = body.moments
        sym = body.symmetry_axis
        if sym is not None and sym != 2:
            order = [(sym + 1) % 3, (sym + 2) % 3, sym]
            raise ValueError(
                f"body must have its symmetry axis along body axis 3 (index 2) for the "
                f"Lagrange (heavy symmetric) top, got symmetry_axis = {sym} (moments "
                f"{[float(x) for x in I]}). Relabel the axes cyclically, e.g. "
                f"RigidBody(body.moments[{order}]), so that I1 = I2 and the centre of mass "
                f"lies on axis 3."
            )
        scale = float(np.max(I))
        if abs(float(I[0] - I[1])) > tol * scale:
            raise ValueError(
                f"body must be symmetric with I1 = I2 (a Lagrange top): moments "
                f"{[float(x) for x in I]} differ by |I1 - I2| = {abs(float(I[0] - I[1])):.3e} "
                f"> rtol * max(moments) = {tol * scale:.3e}; an asymmetric heavy top is not "
                f"a Lagrange top (use liebody.HeavyTop to integrate it)"
            )
        geometric = l is not None or cm is not None
        if l is not None and cm is not None:
            raise ValueError("give the centre of mass as l or as cm, not both")
        if mgl is not None and geometric:
            raise ValueError("give either mgl or the centre of mass (l or cm), not both")
        if mgl is None and not geometric:
            raise ValueError("give mgl = M g l, or the centre of mass as l or cm (with mass, g)")
        if mgl is None:
            if cm is not None:
                c = as_float_array("cm", cm, shape=(3,))
                off = math.hypot(float(c[0]), float(c[1]))
                if off > tol * float(np.linalg.norm(c)):
                    raise ValueError(
                        f"cm must lie on the symmetry axis (body axis 3), cm = (0, 0, l) "
                        f"(a Lagrange top): got cm = {c.tolist()}, at the distance {off:.3e} "
                        f"from the axis (> rtol * |cm|); a heavy top with an off-axis "
                        f"centre of mass is not a Lagrange top"
                    )
                ll = float(c[2])
            else:
                ll = _real("l", l)
            m = body.mass if mass is None else mass
            if m is None:
                raise ValueError(
                    "mass is required to compute M g l from the centre of mass: "
                    "body.mass is None; pass mass=... or mgl=..."
                )
            mgl = as_positive_float("mass", m) * as_positive_float("g", g) * ll
        I1 = 0.5 * (float(I[0]) + float(I[1]))
        return cls(I1, float(I[2]), _mgl(mgl))

    @classmethod
    def from_heavy_top(cls, scene, *, rtol: float = EQUAL_MOMENTS_RTOL) -> LagrangeTop:
        """Top from a :class:`liebody.HeavyTop` scene (body, mass, cm, g), Hand & Finch ch. 8.

        Raises
        ------
        TypeError
            ``scene`` is not a HeavyTop.
        ValueError
            As :meth:`from_body`: the scene is a general heavy top, not a Lagrange top.
        """
        from liebody.scenes import HeavyTop

        if not isinstance(scene, HeavyTop):
            raise TypeError(f"scene must be a liebody.HeavyTop, got {type(scene).__name__}")
        return cls.from_body(scene.body, cm=scene.cm, mass=scene.mass, g=scene.g, rtol=rtol)

    # ----------------------------------------------------------------------------------
    # Lagrangian, energy and the constants of motion
    # ----------------------------------------------------------------------------------

    def lagrangian(self, angles: ArrayLike, rates: ArrayLike) -> float | Array:
        """The Lagrangian of the heavy symmetric top (Hand & Finch, ch. 8), vectorised.

        ``L = 1/2 I1 (phidot^2 sin^2 th + thetadot^2) + 1/2 I3 (psidot + phidot cos th)^2
        - M g l cos th``.

        Parameters
        ----------
        angles
            ``(..., 3)`` z-x-z Euler angles ``(phi, theta, psi)`` (:mod:`liebody.euler`).
        rates
            ``(..., 3)`` rates ``(phidot, thetadot, psidot)``, broadcast against ``angles``.

        Returns
        -------
        float or ndarray, shape ``(...)``
        """
        a, r = _rates_pair(angles, rates)
        t, v = self._kinetic_potential(a, r)
        return _scalar_out(t - v)

    def energy(self, angles: ArrayLike, rates: ArrayLike) -> float | Array:
        """Total energy ``E = T + M g l cos(theta)`` (heavy symmetric top), vectorised.

        Parameters and returns as :meth:`lagrangian`.
        """
        a, r = _rates_pair(angles, rates)
        t, v = self._kinetic_potential(a, r)
        return _scalar_out(t + v)

    def _kinetic_potential(self, a: Array, r: Array) -> tuple[Array, Array]:
        th = a[..., 1]
        phid, thd, psid = r[..., 0], r[..., 1], r[..., 2]
        s, c = np.sin(th), np.cos(th)
        w3 = psid + phid * c
        t = 0.5 * self.I1 * (phid**2 * s**2 + thd**2) + 0.5 * self.I3 * w3**2
        return t, self.mgl * c

    def conserved(self, angles: ArrayLike, rates: ArrayLike) -> ConservedQuantities:
        """``p_phi``, ``p_psi``, ``E`` and ``E'`` from Euler angles and rates (H&F ch. 8).

        ``p_phi = (I1 sin^2 th + I3 cos^2 th) phidot + I3 psidot cos th``,
        ``p_psi = I3 (psidot + phidot cos th)``, ``E = T + M g l cos th`` and
        ``E' = E - p_psi^2 / (2 I3) = 1/2 I1 (phidot^2 sin^2 th + thetadot^2) + M g l cos th``
        (the last form is evaluated, without cancellation).

        Parameters
        ----------
        angles
            ``(..., 3)`` Euler angles ``(phi, theta, psi)``, z-x-z (:mod:`liebody.euler`). Valid at
            ``theta = 0`` too (``p_phi = p_psi = I3 (phidot + psidot)`` there).
        rates
            ``(..., 3)`` ``(phidot, thetadot, psidot)``, broadcast against ``angles``.

        Returns
        -------
        ConservedQuantities
            Floats, or arrays of the broadcast batch shape.
        """
        a, r = _rates_pair(angles, rates)
        th = a[..., 1]
        phid, thd, psid = r[..., 0], r[..., 1], r[..., 2]
        s, c = np.sin(th), np.cos(th)
        p_phi = (self.I1 * s**2 + self.I3 * c**2) * phid + self.I3 * psid * c
        p_psi = self.I3 * (psid + phid * c)
        e_prime = 0.5 * self.I1 * (phid**2 * s**2 + thd**2) + self.mgl * c
        energy = e_prime + p_psi**2 / (2.0 * self.I3)
        return ConservedQuantities(*(_scalar_out(x) for x in (p_phi, p_psi, energy, e_prime)))

    def conserved_from_state(self, q: ArrayLike, L: ArrayLike) -> ConservedQuantities:
        """``p_phi``, ``p_psi``, ``E`` and ``E'`` from a state ``(q, L)`` (Hand & Finch, ch. 8).

        With ``R = R(q)`` (body -> space) and the body angular momentum ``L``:
        ``p_psi = L_3``, ``p_phi = (R L)_z = L_space . e_z``,
        ``cos(theta) = R[2, 2]``, ``E = (L_1^2 + L_2^2) / (2 I1) + L_3^2 / (2 I3)
        + M g l cos(theta)`` and ``E' = (L_1^2 + L_2^2) / (2 I1) + M g l cos(theta)``.
        The third row of ``R`` is the space vertical seen from the body,
        ``gamma = R^T e_z`` (:func:`liebody.quaternion.rotate_inverse`), so
        ``p_phi = gamma . L`` and ``cos(theta) = gamma_3``.

        Parameters
        ----------
        q
            ``(..., 4)`` unit quaternions, scalar first, body -> space.
        L
            ``(..., 3)`` body-frame angular momentum, broadcast against ``q``.

        Returns
        -------
        ConservedQuantities
        """
        from liebody import quaternion  # loads numba: only when a state is given

        qq, LL = _state_pair(q, L)
        gamma = quaternion.rotate_inverse(qq, _E_Z)  # third row of R(q)
        L1, L2, L3 = LL[..., 0], LL[..., 1], LL[..., 2]
        p_phi = np.sum(gamma * LL, axis=-1)
        e_prime = (L1**2 + L2**2) / (2.0 * self.I1) + self.mgl * gamma[..., 2]
        energy = e_prime + L3**2 / (2.0 * self.I3)
        return ConservedQuantities(*(_scalar_out(v) for v in (p_phi, L3, energy, e_prime)))

    def state_from_euler(self, angles: ArrayLike, rates: ArrayLike) -> tuple[Array, Array]:
        """The state ``(q, L)`` of Euler angles and rates (Hand & Finch, ch. 8, Euler angles).

        ``q = liebody.euler.to_quaternion(angles)`` and ``L = (I1 w1, I1 w2, I3 w3)`` with
        ``w = liebody.euler.omega_body(angles, rates)``.

        Returns
        -------
        q : ndarray, shape ``(..., 4)``
        L : ndarray, shape ``(..., 3)``
        """
        a, r = _rates_pair(angles, rates)
        q = _euler.to_quaternion(a)
        omega = _euler.omega_body(a, r)
        return q, omega * np.array([self.I1, self.I1, self.I3])

    def motion(self, angles: ArrayLike, rates: ArrayLike) -> TopMotion:
        """The :class:`TopMotion` (constants of the motion, H&F ch. 8) through a state in angles.

        Parameters
        ----------
        angles, rates
            Shape ``(3,)`` each: ``(phi, theta, psi)`` and ``(phidot, thetadot, psidot)``.
        """
        as_float_array("angles", angles, shape=(3,))
        as_float_array("rates", rates, shape=(3,))
        c = self.conserved(angles, rates)
        return TopMotion(self, c.p_phi, c.p_psi, c.e_prime)

    def motion_from_state(self, q: ArrayLike, L: ArrayLike) -> TopMotion:
        """The :class:`TopMotion` (constants of the motion, H&F ch. 8) through a state ``(q, L)``.

        ``q`` has shape ``(4,)`` and ``L`` shape ``(3,)``.
        """
        as_float_array("q", q, shape=(4,))
        as_float_array("L", L, shape=(3,))
        c = self.conserved_from_state(q, L)
        return TopMotion(self, c.p_phi, c.p_psi, c.e_prime)

    # ----------------------------------------------------------------------------------
    # effective potential
    # ----------------------------------------------------------------------------------

    def effective_potential(self, theta: ArrayLike, p_phi: float, p_psi: float) -> float | Array:
        """``V_eff(th) = (p_phi - p_psi cos th)^2 / (2 I1 sin^2 th) + M g l cos th`` (H&F ch. 8).

        Parameters
        ----------
        theta
            Tilt(s), any shape.
        p_phi, p_psi
            The conserved momenta.

        Returns
        -------
        float or ndarray
            Where ``sin(theta) == 0`` exactly: ``+inf``, or ``M g l cos(theta)`` if the
            numerator vanishes there too (``p_phi = p_psi cos(theta)``, the limit).
        """
        th = as_float_array("theta", theta)
        pf, ps = _real("p_phi", p_phi), _real("p_psi", p_psi)
        s, c = np.sin(th), np.cos(th)
        num = (pf - ps * c) ** 2
        den = 2.0 * self.I1 * s**2
        with np.errstate(divide="ignore", invalid="ignore"):
            rot = np.where(den > 0.0, num / np.where(den > 0.0, den, 1.0),
                           np.where(num == 0.0, 0.0, np.inf))
        return _scalar_out(rot + self.mgl * c)

    def effective_potential_derivative(
        self, theta: ArrayLike, p_phi: float, p_psi: float
    ) -> float | Array:
        """``dV_eff/dtheta``, in the form of Hand & Finch (ch. 8, the heavy symmetric top)::

            dV_eff/dth = (-cos th beta^2 + p_psi sin^2 th beta) / (I1 sin^3 th) - M g l sin th,
            beta = p_phi - p_psi cos th

        Equivalently ``-Q(beta) / (I1 sin^3 th)`` with the quadratic
        ``Q(beta) = cos th beta^2 - p_psi sin^2 th beta + M g l I1 sin^4 th`` of the
        steady-precession condition. NaN where ``sin(theta) == 0``.
        """
        th = as_float_array("theta", theta)
        pf, ps = _real("p_phi", p_phi), _real("p_psi", p_psi)
        s, c = np.sin(th), np.cos(th)
        beta = pf - ps * c
        with np.errstate(divide="ignore", invalid="ignore"):
            d = (-c * beta**2 + ps * s**2 * beta) / (self.I1 * s**3) - self.mgl * s
        return _scalar_out(np.where(s != 0.0, d, np.nan))

    # ----------------------------------------------------------------------------------
    # steady precession
    # ----------------------------------------------------------------------------------

    def minimum_spin(self, theta0: float) -> float:
        """Minimum spin for steady precession at ``theta0`` (Hand & Finch, ch. 8, heavy top).

        ``omega3_min = (2 / I3) sqrt(M g l I1 cos theta0)`` for ``theta0 < pi/2``
        (from ``p_psi^2 >= 4 M g l I1 cos theta0``, the discriminant of the quadratic
        in ``beta``), and ``0`` for ``theta0 >= pi/2`` (no limit). At ``theta0 = 0`` it
        is the stability limit of the sleeping top, ``p_psi^2 > 4 M g l I1``.

        Parameters
        ----------
        theta0
            Tilt in ``[0, pi]``.

        Returns
        -------
        float
            The bound on ``|omega3|`` (``omega3 = p_psi / I3``).
        """
        th = _real("theta0", theta0)
        if not 0.0 <= th <= math.pi:
            raise ValueError(f"theta0 must lie in [0, pi], got {th!r}")
        c = math.cos(th)
        if c <= 0.0:
            return 0.0
        return 2.0 / self.I3 * math.sqrt(self.mgl * self.I1 * c)

    def steady_precession(self, theta0: float, omega3: float) -> SteadyPrecession:
        """Exact steady-precession rates at tilt ``theta0`` and spin ``omega3`` (H&F ch. 8).

        ``V_eff'(theta0) = 0`` with ``beta = p_phi - p_psi cos theta0`` is the quadratic
        ``cos th0 beta^2 - p_psi sin^2 th0 beta + M g l I1 sin^4 th0 = 0``, whose roots
        are (Hand & Finch, ch. 8, the heavy symmetric top)
        ``beta = p_psi sin^2 th0 / (2 cos th0) [1 +- sqrt(1 - 4 M g l I1 cos th0 / p_psi^2)]``,
        and ``phidot0 = beta / (I1 sin^2 th0)``. Evaluated without
        cancellation: with ``p = I3 omega3``, ``D = sqrt(p^2 - 4 M g l I1 cos th0)`` and
        ``Q = p + sign(p) D``,

            phidot_fast = Q / (2 I1 cos th0),    phidot_slow = 2 M g l / Q

        (the ``+`` and ``-`` roots; their product is ``M g l / (I1 cos th0)``).

        Signs. ``phidot_slow`` always has the sign of ``omega3`` (it tends to
        ``M g l / (I3 omega3)``), for ``theta0 < pi/2`` and ``> pi/2`` alike; the fast
        rate tends to ``I3 omega3 / (I1 cos theta0)`` and changes sign with
        ``cos theta0``. So for ``theta0 > pi/2`` the two rates have opposite signs. The
        usual statement that for ``theta0 > pi/2`` "slow precession has the opposite
        sense" holds for the sense relative to the spin axis, which then points
        downwards: ``sign(phidot cos theta0 / omega3)`` reverses for the slow rate and is
        kept for the fast one.

        Parameters
        ----------
        theta0
            Tilt in the open interval ``(0, pi)``.
        omega3
            Spin ``omega_3 = psidot + phidot cos theta = p_psi / I3`` (any sign; at
            ``omega3 = 0`` and ``theta0 > pi/2`` the two rates are the two senses of the
            conical pendulum).

        Returns
        -------
        SteadyPrecession

        Raises
        ------
        ValueError
            ``theta0`` not in ``(0, pi)``; ``|omega3| < omega3_min`` for
            ``theta0 < pi/2``: no steady precession at this tilt.
        """
        th = _theta_open("theta0", theta0)
        w3 = _real("omega3", omega3)
        s, c = math.sin(th), math.cos(th)
        p = self.I3 * w3
        k = self.mgl * self.I1
        disc = p * p - 4.0 * c * k
        wmin = self.minimum_spin(th)
        if disc < 0.0:
            if disc >= -8.0 * _EPS * (p * p + 4.0 * abs(c) * k):
                disc = 0.0  # at the minimum spin to round-off: the double root
            else:
                raise ValueError(
                    f"omega3 = {w3!r} is below the minimum spin omega3_min = (2/I3) "
                    f"sqrt(M g l I1 cos theta0) = {wmin!r} for theta0 = {th!r}: "
                    f"steady precession at this tilt is impossible (the quadratic in beta "
                    f"has no real root); |omega3| must be >= {wmin!r}"
                )
        D = math.sqrt(disc)
        Q = p + D if p >= 0.0 else p - D
        fast = Q / (2.0 * self.I1 * c)
        slow = 2.0 * self.mgl / Q
        return SteadyPrecession(
            theta0=th,
            omega3=w3,
            phidot_fast=fast,
            phidot_slow=slow,
            beta_fast=self.I1 * s * s * fast,
            beta_slow=self.I1 * s * s * slow,
            omega3_min=wmin,
        )

    def steady_precession_approx(self, theta0: float, omega3: float) -> tuple[float, float]:
        """Fast-top approximations of the precession rates (Hand & Finch, ch. 8, heavy top).

        ``phidot_fast ~ I3 omega3 / (I1 cos theta0)`` and
        ``phidot_slow ~ M g l / (I3 omega3)``, the first terms of the expansion of the
        exact roots in ``eps = 4 M g l I1 cos theta0 / p_psi^2``; the relative errors are
        ``eps / 4 + O(eps^2) ~ 1 / omega3^2``. (The fast rate carries ``I3``, the
        symmetry-axis moment, since ``p_psi = I3 omega3``; forms printed with ``I_2``, or
        with ``h`` for the distance ``l``, are typos.)

        Parameters
        ----------
        theta0
            Tilt in ``(0, pi)``.
        omega3
            Spin, nonzero.

        Returns
        -------
        (phidot_fast, phidot_slow) : tuple of float
        """
        th = _theta_open("theta0", theta0)
        w3 = _real("omega3", omega3)
        if w3 == 0.0:
            raise ValueError("omega3 must be nonzero for the fast-top approximations")
        return self.I3 * w3 / (self.I1 * math.cos(th)), self.mgl / (self.I3 * w3)

    def steady_precession_initial_conditions(
        self, theta0: float, omega3: float, branch: Branch = "slow", *,
        phi: float = 0.0, psi: float = 0.0,
    ) -> tuple[Array, Array]:
        """Euler angles and rates that start the top on steady precession (H&F ch. 8).

        ``angles = (phi, theta0, psi)``, ``rates = (phidot0, 0, omega3 - phidot0 cos
        theta0)`` with ``phidot0`` the exact rate of ``branch`` from
        :meth:`steady_precession`. The tilt then stays at ``theta0``; ``phidot`` and
        ``psidot`` stay constant.

        Parameters
        ----------
        theta0, omega3
            As :meth:`steady_precession` (which raises below the minimum spin).
        branch
            ``"slow"`` (default) or ``"fast"``.
        phi, psi
            Initial precession and spin angles.

        Returns
        -------
        angles, rates : ndarray, shape (3,)
        """
        b = _branch(branch)
        sp = self.steady_precession(theta0, omega3)
        phid = sp.phidot_fast if b == "fast" else sp.phidot_slow
        angles = np.array([_real("phi", phi), sp.theta0, _real("psi", psi)])
        rates = np.array([phid, 0.0, sp.omega3 - phid * math.cos(sp.theta0)])
        return angles, rates

    def steady_precession_state(
        self, theta0: float, omega3: float, branch: Branch = "slow", *,
        phi: float = 0.0, psi: float = 0.0,
    ) -> tuple[Array, Array]:
        """State ``(q, L)`` on steady precession: :meth:`steady_precession_initial_conditions`
        converted with :meth:`state_from_euler`.

        Returns
        -------
        q : ndarray, shape (4,)
        L : ndarray, shape (3,)
            Body angular momentum; ``L_3 = I3 omega3``.
        """
        angles, rates = self.steady_precession_initial_conditions(
            theta0, omega3, branch, phi=phi, psi=psi)
        return self.state_from_euler(angles, rates)


# --------------------------------------------------------------------------------------
# one motion
# --------------------------------------------------------------------------------------


@dataclass(frozen=True)
class TopMotion:
    """One motion of a Lagrange top, fixed by its constants (Hand & Finch, ch. 8).

    Parameters
    ----------
    top
        The top.
    p_phi, p_psi
        The conserved momenta.
    e_prime
        ``E' = E - p_psi^2 / (2 I3) = 1/2 I1 thetadot^2 + V_eff(theta)``.

    Notes
    -----
    With ``u = cos(theta)`` the energy equation becomes ``udot^2 = f(u)`` with the cubic
    (multiplying ``E' - V_eff`` by ``2 sin^2(theta) / I1``)::

        f(u) = (2 E'/I1 - 2 M g l u / I1) (1 - u^2) - ((p_phi - p_psi u) / I1)^2

    ``f(+-1) = -((p_phi -+ p_psi)/I1)^2 <= 0`` and ``f -> +inf`` as ``u -> +inf``: a real
    motion has three real roots ``u2 <= u1 <= u3`` with ``-1 <= u2 <= u1 <= 1 <= u3`` and
    ``f >= 0`` on ``[u2, u1]``.
    """

    top: LagrangeTop
    p_phi: float
    p_psi: float
    e_prime: float

    def __post_init__(self) -> None:
        if not isinstance(self.top, LagrangeTop):
            raise TypeError(f"top must be a LagrangeTop, got {type(self.top).__name__}")
        object.__setattr__(self, "p_phi", _real("p_phi", self.p_phi))
        object.__setattr__(self, "p_psi", _real("p_psi", self.p_psi))
        object.__setattr__(self, "e_prime", _real("e_prime", self.e_prime))

    # ----------------------------------------------------------------------------------
    # derived constants and rates
    # ----------------------------------------------------------------------------------

    @property
    def energy(self) -> float:
        """``E = E' + p_psi^2 / (2 I3)`` (Hand & Finch, ch. 8, the heavy symmetric top)."""
        return self.e_prime + self.p_psi**2 / (2.0 * self.top.I3)

    @property
    def omega3(self) -> float:
        """Spin ``omega_3 = p_psi / I3`` (constant; Hand & Finch, ch. 8, the heavy top)."""
        return self.p_psi / self.top.I3

    def effective_potential(self, theta: ArrayLike) -> float | Array:
        """``V_eff(theta)`` of this motion (H&F ch. 8); see
        :meth:`LagrangeTop.effective_potential`."""
        return self.top.effective_potential(theta, self.p_phi, self.p_psi)

    def effective_potential_derivative(self, theta: ArrayLike) -> float | Array:
        """``dV_eff/dtheta`` of this motion (H&F ch. 8); see
        :meth:`LagrangeTop.effective_potential_derivative`."""
        return self.top.effective_potential_derivative(theta, self.p_phi, self.p_psi)

    def precession_rate(self, theta: ArrayLike) -> float | Array:
        """``phidot = (p_phi - p_psi cos th) / (I1 sin^2 th)`` (Hand & Finch, ch. 8).

        NaN where ``sin(theta) == 0`` (the Euler angles are singular there).
        """
        th = as_float_array("theta", theta)
        s, c = np.sin(th), np.cos(th)
        with np.errstate(divide="ignore", invalid="ignore"):
            r = (self.p_phi - self.p_psi * c) / (self.top.I1 * s**2)
        return _scalar_out(np.where(s != 0.0, r, np.nan))

    def spin_rate(self, theta: ArrayLike) -> float | Array:
        """``psidot = p_psi / I3 - (p_phi - p_psi cos th) cos th / (I1 sin^2 th)`` (H&F ch. 8)."""
        th = as_float_array("theta", theta)
        return _scalar_out(self.omega3 - np.cos(th) * self.precession_rate(th))

    # ----------------------------------------------------------------------------------
    # the cubic and the turning points
    # ----------------------------------------------------------------------------------

    def cubic_coefficients(self) -> tuple[float, float, float, float]:
        """Coefficients ``(c3, c2, c1, c0)`` of ``f(u) = c3 u^3 + c2 u^2 + c1 u + c0``.

        With ``a = 2 E'/I1``, ``b = 2 M g l / I1``, ``al = p_phi / I1``,
        ``be = p_psi / I1`` (the energy equation of H&F ch. 8 in ``u = cos theta``)::

            c3 = b,  c2 = -(a + be^2),  c1 = 2 al be - b,  c0 = a - al^2
        """
        a, b, al, be = self._abab()
        return b, -(a + be * be), 2.0 * al * be - b, a - al * al

    def _abab(self) -> tuple[float, float, float, float]:
        I1 = self.top.I1
        return 2.0 * self.e_prime / I1, 2.0 * self.top.mgl / I1, self.p_phi / I1, self.p_psi / I1

    def cubic(self, u: ArrayLike) -> float | Array:
        """``f(u) = (2E'/I1 - 2 M g l u / I1)(1 - u^2) - ((p_phi - p_psi u)/I1)^2``
        so that ``udot^2 = f(u)`` for ``u = cos(theta)`` (H&F ch. 8, the heavy top)."""
        uu = as_float_array("u", u)
        return _scalar_out(self._f(uu))

    def _f(self, u):
        a, b, al, be = self._abab()
        return (a - b * u) * (1.0 - u * u) - (al - be * u) ** 2

    def _scale(self) -> float:
        a, b, al, be = self._abab()
        return abs(a) + b + (abs(al) + abs(be)) ** 2

    def turning_points(self, rtol: float = DOUBLE_ROOT_RTOL) -> TurningPoints:
        """Turning points ``theta1 <= theta2`` of the tilt (Hand & Finch, ch. 8, the heavy top).

        They are the zeros of ``E' - V_eff(theta)``, i.e. the roots ``u1 = cos(theta1)
        >= u2 = cos(theta2)`` in ``[-1, 1]`` of the cubic :meth:`cubic`. Method: the
        maximum of ``f`` on ``[-1, 1]`` lies at its local maximum ``u*`` (the smaller
        root of ``f'``; ``f(+-1) <= 0``); ``u2`` and ``u1`` are bracketed in
        ``[-1, u*]`` and ``[u*, 1]`` and found with :func:`scipy.optimize.brentq`; the
        third root is ``u3 = -c2/c3 - u1 - u2`` (Vieta).

        Parameters
        ----------
        rtol
            If ``|max f| <= rtol * scale`` (``scale = |a| + b + (|al| + |be|)^2`` in the
            notation of :meth:`cubic_coefficients`, the size of the terms of ``f``),
            ``u*`` is a double root: steady precession (or a sleeping top at
            ``theta = 0``), returned with ``theta1 == theta2`` and ``degenerate=True``.
            A double root is ill-conditioned: a relative error ``eps`` in the
            constants moves the roots by ``~sqrt(eps)``. The same tolerance on
            ``|f'(1)|`` detects the other double root a real motion can have,
            ``u1 = u3 = 1``: the constants of an unstable sleeping top
            (``p_phi = p_psi``, ``E' = M g l``, ``p_psi^2 < 4 M g l I1``), which also
            describe the separatrix motion that leaves ``theta = 0`` and creeps back;
            its band ``[theta1 = 0, theta2]`` is returned with ``u3 = 1``.

        Returns
        -------
        TurningPoints

        Raises
        ------
        ValueError
            ``max f < -rtol * scale``: ``E'`` is below the minimum of ``V_eff``, the
            constants belong to no motion.
        """
        tol = as_positive_float("rtol", rtol)
        c3, c2, c1, _ = self.cubic_coefficients()
        scale = self._scale()
        # critical points of f: 3 c3 u^2 + 2 c2 u + c1 = 0 (stable quadratic formula)
        cands = [-1.0, 1.0]
        disc = c2 * c2 - 3.0 * c3 * c1
        if disc >= 0.0:
            qq = -(c2 + math.copysign(math.sqrt(disc), c2))
            roots = [qq / (3.0 * c3)] + ([c1 / qq] if qq != 0.0 else [])
            um = min(roots)
            # within round-off of +-1 the endpoint stands for it (a sleeping top's double
            # root at u = 1 then gives theta = 0 exactly, not ~sqrt(eps))
            if abs(um) < 1.0 - 64.0 * _EPS:
                cands.append(um)
        fvals = [float(self._f(u)) for u in cands]
        i = int(np.argmax(fvals))
        ustar, fmax = cands[i], fvals[i]
        if fmax < -tol * scale:
            raise ValueError(
                f"no motion has these constants: E' = {self.e_prime!r} is below "
                f"the minimum of V_eff (max of f(u) on [-1, 1] is {fmax:.3e} < 0) for "
                f"p_phi = {self.p_phi!r}, p_psi = {self.p_psi!r}"
            )
        if fmax <= tol * scale:
            u1 = u2 = ustar
            degenerate = True
        else:
            u2 = -1.0 if self._f(-1.0) == 0.0 else optimize.brentq(
                self._f, -1.0, ustar, xtol=1e-300, rtol=4 * _EPS, maxiter=500)
            u1 = 1.0 if self._f(1.0) == 0.0 else optimize.brentq(
                self._f, ustar, 1.0, xtol=1e-300, rtol=4 * _EPS, maxiter=500)
            degenerate = False
        u3 = max(-c2 / c3 - u1 - u2, u1)
        # u1 = 1 is a double root (f'(1) = 0) only on the separatrix of the unstable
        # sleeping top (p_phi = p_psi, E' = M g l): then u3 = u1 = 1 exactly
        fp1 = 3.0 * c3 + 2.0 * c2 + c1
        if not degenerate and u1 >= 1.0 - 64.0 * _EPS and abs(fp1) <= tol * scale:
            u3 = u1
        return TurningPoints(
            theta1=math.acos(u1), theta2=math.acos(u2), u1=float(u1), u2=float(u2),
            u3=float(u3), degenerate=degenerate,
        )

    # ----------------------------------------------------------------------------------
    # nutation
    # ----------------------------------------------------------------------------------

    def nutation_period(
        self,
        method: Literal["elliptic", "quad_u", "quad_theta"] = "elliptic",
        *,
        rtol: float = DOUBLE_ROOT_RTOL,
    ) -> float:
        """Period of the nutation ``theta(t)`` between ``theta1`` and ``theta2`` (H&F ch. 8).

        ``T = 2 int_{theta1}^{theta2} dtheta / sqrt((2/I1)(E' - V_eff))
        = 2 int_{u2}^{u1} du / sqrt(f(u))``: Hand & Finch's ``t(theta)`` (ch. 8, the heavy
        symmetric top) over a full swing.

        ``"elliptic"`` (default): with the three roots ``u2 <= u1 <= u3`` of ``f`` and
        ``b = 2 M g l / I1``::

            T = 4 K(k) / sqrt(b (u3 - u2)),   k^2 = (u1 - u2) / (u3 - u2)

        (:func:`scipy.special.ellipk` takes ``m = k^2``; derivation: docs/derivations.md,
        section "Nutation period of the heavy symmetric top"). At a double root
        (``k = 0``) this is the small-oscillation period ``2 pi / sqrt(b (u3 - u0))
        = 2 pi sqrt(I1 / V_eff''(theta0))``; at a separatrix (``u3 = u1``, e.g. the
        unstable sleeping top) ``T = inf``.

        ``"quad_u"``: :func:`scipy.integrate.quad` of ``2 int du / sqrt(f(u))`` after
        ``u = u_mid + u_half sin(s)``, which removes the inverse-square-root endpoint
        singularities (the integrand tends to ``sqrt(2 u_half / |f'(u_end)|)``).
        ``"quad_theta"``: the same with the ``theta`` integrand of ``t(theta)`` and
        ``theta = theta_mid + theta_half sin(s)``. Both use the turning points only;
        at a double root they return the small-oscillation limit
        ``2 pi / sqrt(-f''(u0) / 2)``.

        Parameters
        ----------
        method
            ``"elliptic"``, ``"quad_u"`` or ``"quad_theta"``.
        rtol
            Passed to :meth:`turning_points`.

        Returns
        -------
        float
        """
        if method not in ("elliptic", "quad_u", "quad_theta"):
            raise ValueError(
                f"method must be 'elliptic', 'quad_u' or 'quad_theta', got {method!r}")
        tp = self.turning_points(rtol)
        b = 2.0 * self.top.mgl / self.top.I1
        if tp.u3 <= tp.u1 and not tp.degenerate:
            return math.inf  # separatrix: the motion creeps towards u1 = u3
        if method == "elliptic":
            m = (tp.u1 - tp.u2) / (tp.u3 - tp.u2)
            if m >= 1.0:
                return math.inf
            return 4.0 * float(special.ellipk(m)) / math.sqrt(b * (tp.u3 - tp.u2))
        c3, c2, _, _ = self.cubic_coefficients()
        if tp.degenerate or tp.u1 == tp.u2:
            w2 = -3.0 * c3 * tp.u1 - c2  # -f''(u0)/2
            return 2.0 * math.pi / math.sqrt(w2) if w2 > 0.0 else math.inf
        if method == "quad_u":
            return 2.0 * self._quad_u(tp)
        return 2.0 * self._quad_theta(tp)

    def _quad_u(self, tp: TurningPoints) -> float:
        um, uh = 0.5 * (tp.u1 + tp.u2), 0.5 * (tp.u1 - tp.u2)
        c3, c2, c1, _ = self.cubic_coefficients()

        def fprime(u):
            return 3.0 * c3 * u * u + 2.0 * c2 * u + c1

        lim_hi = math.sqrt(2.0 * uh / abs(fprime(tp.u1)))
        lim_lo = math.sqrt(2.0 * uh / abs(fprime(tp.u2)))

        def integrand(s: float) -> float:
            fu = float(self._f(um + uh * math.sin(s)))
            if fu <= 0.0:
                return lim_hi if s > 0.0 else lim_lo
            return uh * math.cos(s) / math.sqrt(fu)

        val, _ = integrate.quad(integrand, -0.5 * math.pi, 0.5 * math.pi,
                                epsabs=0.0, epsrel=1e-13, limit=200)
        return val

    def _quad_theta(self, tp: TurningPoints) -> float:
        tm, th = 0.5 * (tp.theta1 + tp.theta2), 0.5 * (tp.theta2 - tp.theta1)
        I1 = self.top.I1

        def lim(theta_end: float) -> float:
            d = abs(float(self.effective_potential_derivative(theta_end)))
            return math.sqrt(th * I1 / d) if d > 0.0 and math.isfinite(d) else 0.0

        lim_hi, lim_lo = lim(tp.theta2), lim(tp.theta1)

        def integrand(s: float) -> float:
            k = self.e_prime - float(self.effective_potential(tm + th * math.sin(s)))
            if not k > 0.0:
                return lim_hi if s > 0.0 else lim_lo
            return th * math.cos(s) / math.sqrt(2.0 * k / I1)

        val, _ = integrate.quad(integrand, -0.5 * math.pi, 0.5 * math.pi,
                                epsabs=0.0, epsrel=1e-13, limit=200)
        return val

    def theta_of_time(self, t: ArrayLike, *, rtol: float = DOUBLE_ROOT_RTOL) -> float | Array:
        """The tilt ``theta(t)``, inverting ``t(theta)`` (Hand & Finch, ch. 8, the heavy top).

        With ``t = 0`` at the highest position ``theta1`` (``u = u1``)::

            u(t) = u2 + (u1 - u2) cd^2(x | m),  x = t sqrt(b (u3 - u2)) / 2,
            m = k^2 = (u1 - u2) / (u3 - u2),     cd = cn / dn

        (Jacobi elliptic functions, :func:`scipy.special.ellipj`; this follows from the
        substitution of :meth:`nutation_period`, ``u = u2 + (u1 - u2) sn^2``, shifted
        by a half period: docs/derivations.md, section "Nutation period of the heavy
        symmetric top"). Period :meth:`nutation_period`.

        Parameters
        ----------
        t
            Times, any shape.
        rtol
            Passed to :meth:`turning_points`.

        Returns
        -------
        float or ndarray
            ``theta(t)`` in ``[theta1, theta2]`` (constant at a double root).
        """
        tt = as_float_array("t", t)
        tp = self.turning_points(rtol)
        if tp.degenerate:
            return _scalar_out(np.full(tt.shape, tp.theta1))
        b = 2.0 * self.top.mgl / self.top.I1
        span = max(tp.u3 - tp.u2, tp.u1 - tp.u2)
        m = min((tp.u1 - tp.u2) / span, 1.0)
        x = tt * math.sqrt(b * span) / 2.0
        _, cn, dn, _ = special.ellipj(x, m)
        u = tp.u2 + (tp.u1 - tp.u2) * (cn / dn) ** 2
        return _scalar_out(np.arccos(np.clip(u, -1.0, 1.0)))

    def motion_kind(self, tol: float = 1e-6, *, rtol: float = DOUBLE_ROOT_RTOL) -> MotionKind:
        """What curve the symmetry axis draws on the unit sphere (Hand & Finch, ch. 8).

        ``phidot = (p_phi - p_psi u) / (I1 (1 - u^2))`` has the sign of the linear
        function ``g(u) = p_phi - p_psi u``. With ``g1 = g(u1)``, ``g2 = g(u2)``:

        * ``"steady"``: ``theta1 == theta2`` (a double root: steady precession or a
          sleeping top);
        * ``"cusps"``: ``phidot`` vanishes at a turning point,
          ``min(|g1|, |g2|) <= tol * max(|g1|, |g2|)`` (equivalently ``p_phi / p_psi``
          lies within ``tol (u1 - u2)`` of ``u1`` or ``u2``), e.g. a top released with
          ``phidot = thetadot = 0``; the cusps point up (at ``theta1``);
        * ``"loops"``: ``g1 g2 < 0``, ``phidot`` changes sign between the turning points
          (``p_phi / p_psi`` strictly between ``u2`` and ``u1``);
        * ``"monotone"``: ``phidot`` keeps one sign (undulating precession);
        * ``"planar"``: ``p_phi = p_psi = 0``, ``phidot = 0`` throughout: the axis swings
          in a vertical plane (a physical pendulum through ``theta = pi``).

        Parameters
        ----------
        tol
            Relative tolerance of the cusp test (>= 0).
        rtol
            Passed to :meth:`turning_points`.

        Returns
        -------
        str
        """
        tl = as_positive_float("tol", tol, allow_zero=True)
        tp = self.turning_points(rtol)
        if tp.degenerate:
            return "steady"
        g1 = self.p_phi - self.p_psi * tp.u1
        g2 = self.p_phi - self.p_psi * tp.u2
        big = max(abs(g1), abs(g2))
        if big == 0.0:
            return "planar"
        if min(abs(g1), abs(g2)) <= tl * big:
            return "cusps"
        return "loops" if g1 * g2 < 0.0 else "monotone"
