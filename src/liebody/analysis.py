"""Closed forms of classical rigid-body phenomena, and functions that measure them.

Every closed form cites its source: a topic of the rigid-body chapter of Hand & Finch,
*Analytical Mechanics* (Cambridge University Press, 1998), ch. 8 ("H&F"), or
Landau & Lifshitz, *Mechanics*, 3rd ed. (Pergamon, 1976), §37 ("L&L"). Full entries:
docs/references.md.

======================================  ================================================
closed form (source)                    measured from a :class:`~liebody.Trajectory` by
======================================  ================================================
:func:`precession_rate` (H&F)           :func:`wobble_period` (``2 pi / |Omega|``)
:func:`cone_angles` (H&F)               angles of ``omega``, ``L`` and the symmetry axis
:func:`space_precession_rate` (H&F)     :func:`measured_space_precession_rate`
:func:`stability` (H&F)                 :func:`fit_growth_rate`, :func:`wobble_period`
:func:`flip_period` (L&L §37)           :func:`zero_crossings` of ``L_2``
:func:`chandler_period` (H&F)           :func:`wobble_period` of the rigid Earth
:func:`steady_rotation_torque` (H&F)    (no integration)
======================================  ================================================

H&F topics used: the force-free symmetric top (body frame and inertial frame),
stability of rotation about the principal axes, Euler's equations.

Spacecraft and planets: :func:`dual_spin_stable` (Hughes, *Spacecraft Attitude
Dynamics*, 1986, ch. 7), :func:`gravity_gradient_stability` of an Earth-pointing
satellite (Hughes 1986, ch. 9; the orbital frame of :mod:`liebody.attitude`), and the
forced precession of a planet's spin axis, :func:`forced_precession_constant` and
:func:`forced_precession_rate` (Goldstein, Poole & Safko 2002, sect. 5.8; Ward 1974).

Conventions: body-frame ``omega`` and ``L`` (principal axes) unless named ``_space``;
rates in radians per unit of the trajectory's time; float64. Invalid input raises
``ValueError``/``TypeError`` naming the argument and the rule.
"""

from __future__ import annotations

import cmath
import math
import numbers
from typing import NamedTuple

import numpy as np

from liebody._validate import as_float_array, as_positive_float
from liebody.rigid_body import moments_equal

__all__ = [
    "Cones",
    "GravityGradientStability",
    "Stability",
    "axis_role",
    "chandler_period",
    "cone_angles",
    "dual_spin_stable",
    "fit_growth_rate",
    "flip_period",
    "forced_precession_constant",
    "forced_precession_rate",
    "gravity_gradient_stability",
    "measured_space_precession_rate",
    "precession_rate",
    "space_precession_rate",
    "stability",
    "steady_rotation_torque",
    "wobble_period",
    "zero_crossings",
]

_ROLES = ("smallest", "intermediate", "largest")


# ----------------------------------------------------------------------------------------
# validation helpers
# ----------------------------------------------------------------------------------------


def _as_real(name: str, value) -> float:
    """A finite real scalar of any sign."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real | np.floating | np.integer):
        raise TypeError(f"{name} must be a real number, got {type(value).__name__}")
    v = float(value)
    if not math.isfinite(v):
        raise ValueError(f"{name} must be finite, got {v}")
    return v


def _as_moments(name: str, value) -> np.ndarray:
    """Three finite, strictly positive principal moments (any order)."""
    arr = as_float_array(name, value, shape=(3,))
    if np.any(arr <= 0):
        raise ValueError(f"{name} must be three principal moments > 0, got {arr.tolist()}")
    return arr


def _as_axis(name: str, value) -> int:
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{name} must be an integer axis index 0, 1 or 2, "
                        f"got {type(value).__name__}")
    k = int(value)
    if k not in (0, 1, 2):
        raise ValueError(f"{name} must be an axis index 0, 1 or 2, got {k}")
    return k


def _as_component(value) -> int:
    return _as_axis("component", value)


def _ldexp(what: str, mantissa: float, exponent: int) -> float:
    """``mantissa 2^exponent``, or a ``ValueError`` naming ``what`` beyond float64."""
    try:
        return math.ldexp(mantissa, exponent)
    except OverflowError:
        log10 = math.log10(abs(mantissa)) + exponent * math.log10(2.0)
        raise ValueError(
            f"{what} is about {10.0 ** (log10 % 1.0):.2g}e+{int(log10 // 1.0)}, beyond the "
            f"largest float64 {np.finfo(np.float64).max:.3g}: rescale the units of the "
            f"arguments") from None


def _one_body(traj, fname: str) -> None:
    """Refuse an ensemble trajectory (``q`` of shape ``(N, n, 4)``)."""
    q = getattr(traj, "q", None)
    if isinstance(q, np.ndarray) and q.ndim == 3:
        raise ValueError(
            f"{fname} takes one body's trajectory (q of shape (n, 4)), got an ensemble of "
            f"{q.shape[0]} bodies (q of shape {q.shape}): measure one body at a time, "
            f"e.g. {fname}(traj.body(i), ...)")


def _has_samples(traj, n: int, what: str) -> None:
    if len(traj) < n:
        raise ValueError(f"traj must have at least {n} samples for {what}, got {len(traj)}")


# ----------------------------------------------------------------------------------------
# force-free symmetric top (H&F ch. 8: the force-free symmetric top)
# ----------------------------------------------------------------------------------------


def precession_rate(I: float, I3: float, omega3: float) -> float:
    """Body-frame precession rate ``Omega = omega3 (I3 - I) / I`` of a symmetric top.

    Hand & Finch, *Analytical Mechanics*, ch. 8, the force-free symmetric top: with
    ``I1 = I2 = I``
    Euler's equations give ``omega3 = const`` and
    ``omega1 = c cos(Omega t + phi)``, ``omega2 = c sin(Omega t + phi)``: ``omega``
    circles the symmetry axis in the body frame at the angular frequency ``Omega``.

    Parameters
    ----------
    I : float
        Equal (equatorial) moment ``I1 = I2`` (> 0).
    I3 : float
        Moment about the symmetry axis (> 0).
    omega3 : float
        Component of ``omega`` along the symmetry axis (any sign).

    Returns
    -------
    float
        ``Omega``, signed: positive (counterclockwise about ``+x3`` seen from its tip)
        for an oblate top (``I3 > I``) with ``omega3 > 0``, negative for a prolate one.
        The wobble period is ``2 pi / |Omega|``. Evaluated from the mantissas and
        exponents of the factors, so it is returned whenever it is a float64 (a
        ``ValueError`` if it is beyond one).
    """
    I = as_positive_float("I", I)
    I3 = as_positive_float("I3", I3)
    omega3 = _as_real("omega3", omega3)
    if omega3 == 0.0 or I3 == I:
        return 0.0
    # omega3 (I3 - I) / I from the mantissas and exponents of its factors: no intermediate
    # overflow or underflow (omega3 (I3 - I) alone overflows at omega3 = I = 1e300)
    (mw, ew), (md, ed), (mi, ei) = (math.frexp(v) for v in (omega3, I3 - I, I))
    return _ldexp("Omega = omega3 (I3 - I) / I", mw * md / mi, ew + ed - ei)


class Cones(NamedTuple):
    """Half-angles of the body and space cones of a free symmetric top.

    Hand & Finch, *Analytical Mechanics*, ch. 8, the force-free symmetric top in the
    inertial frame (see :func:`cone_angles`).

    Attributes
    ----------
    alpha : float
        Angle between ``omega`` and the symmetry axis, ``tan alpha = omega_perp / omega3``.
    theta : float
        Angle between ``L`` and the symmetry axis,
        ``tan theta = I omega_perp / (I3 omega3)``; ``tan alpha = (I3 / I) tan theta``.
    body_cone : float
        Half-angle of the cone ``omega`` sweeps about the symmetry axis in the body
        (``= alpha``).
    space_cone : float
        Half-angle of the cone ``omega`` sweeps about the fixed ``L`` in space
        (``= |alpha - theta|``).
    oblate : bool
        ``I3 > I`` (pancake, ``alpha > theta``): the space cone rolls around *inside*
        the body cone. Otherwise prolate (cigar, ``alpha < theta``): the body cone
        rolls on the *outside* of the space cone.
    """

    alpha: float
    theta: float
    body_cone: float
    space_cone: float
    oblate: bool


def cone_angles(I: float, I3: float, omega_perp: float, omega3: float) -> Cones:
    """Body and space cones of a force-free symmetric top.

    Hand & Finch, *Analytical Mechanics*, ch. 8, the force-free symmetric top seen from
    the inertial frame: ``L``, ``omega`` and the symmetry axis ``z`` lie in one plane at
    fixed angles,
    ``tan alpha = omega_n / omega3``, ``tan theta = I omega_n / (I3 omega3)``, so
    ``tan alpha = (I3 / I) tan theta``; ``omega`` sweeps the body cone (half-angle
    ``alpha``) about ``z`` and the space cone (half-angle ``|alpha - theta|``) about
    the fixed ``L``. For an oblate top the space cone rolls inside the body cone; for a
    prolate top the body cone rolls on the outside of the space cone.

    Parameters
    ----------
    I, I3 : float
        Equatorial moment ``I1 = I2`` and the moment about the symmetry axis (> 0).
    omega_perp : float
        Magnitude (>= 0) of the component of ``omega`` perpendicular to the axis,
        ``omega_n = sqrt(omega1^2 + omega2^2)``.
    omega3 : float
        Component along the symmetry axis. Its sign only picks the half of the axis
        that the angles are measured from (the one on the side of ``omega``): the
        result depends on ``|omega3|``, and all angles lie in ``[0, pi/2]``.

    Returns
    -------
    Cones
        ``(alpha, theta, body_cone, space_cone, oblate)``, angles in radians.
    """
    I = as_positive_float("I", I)
    I3 = as_positive_float("I3", I3)
    omega_perp = as_positive_float("omega_perp", omega_perp, allow_zero=True)
    omega3 = _as_real("omega3", omega3)
    if omega_perp == 0.0 and omega3 == 0.0:
        raise ValueError("omega_perp and omega3 must not both be zero (no rotation, no cones)")
    alpha = math.atan2(omega_perp, abs(omega3))
    theta = math.atan2(I * omega_perp, I3 * abs(omega3))
    return Cones(alpha, theta, alpha, abs(alpha - theta), I3 > I)


def space_precession_rate(I: float, L_norm: float) -> float:
    """Rate ``|L| / I`` at which the ``omega``-axis plane precesses about the fixed ``L``.

    Hand & Finch, ch. 8, the force-free symmetric top in the inertial frame:
    ``omega = (L / I) L_hat - Omega z_hat`` with
    ``Omega = omega3 (I3 - I) / I``. The symmetry axis moves as
    ``dz/dt = omega x z = (L / I) L_hat x z``, i.e. it (and with it the plane of
    ``omega``, ``L`` and ``z``) turns about ``L_hat`` at the rate ``|L| / I``,
    counterclockwise seen from the tip of ``L``.

    Parameters
    ----------
    I : float
        Equatorial moment ``I1 = I2`` (> 0).
    L_norm : float
        ``|L|`` (>= 0).

    Returns
    -------
    float
        ``|L| / I`` (rad per unit time).
    """
    I = as_positive_float("I", I)
    L_norm = as_positive_float("L_norm", L_norm, allow_zero=True)
    return L_norm / I


# ----------------------------------------------------------------------------------------
# measurements on trajectories
# ----------------------------------------------------------------------------------------


def zero_crossings(t, y, *, direction: int = 0, interpolation: str = "cubic") -> np.ndarray:
    """Times at which sampled data ``y(t)`` changes sign, located between the samples.

    A sign change between samples ``i`` and ``i + 1`` (a sample exactly zero counts as
    positive) is refined on the cubic through samples ``i - 1 .. i + 2`` (error
    ``O(dt^4)``; Newton's method started from the linear estimate, falling back to the
    linear estimate if it leaves the interval) or, with ``interpolation="linear"``, on
    the chord (error ``O(dt^2)``, ``O(dt^3)`` at an inflection point such as a sine's
    zero).

    Parameters
    ----------
    t : array_like, shape (n,)
        Strictly increasing sample times.
    y : array_like, shape (n,)
        Sampled values.
    direction : {0, 1, -1}
        Keep all crossings (0), upward (``-`` to ``+``, 1) or downward (-1) only.
    interpolation : {"cubic", "linear"}

    Returns
    -------
    numpy.ndarray
        Crossing times, increasing.
    """
    t = as_float_array("t", t)
    y = as_float_array("y", y)
    if t.ndim != 1 or y.shape != t.shape:
        raise ValueError(f"t and y must be 1-D arrays of equal length, got shapes {t.shape} "
                         f"and {y.shape}")
    if t.size >= 2 and not np.all(np.diff(t) > 0):
        raise ValueError("t must be strictly increasing")
    if direction not in (0, 1, -1) or isinstance(direction, bool):
        raise ValueError(f"direction must be 0 (both), 1 (upward) or -1 (downward), "
                         f"got {direction!r}")
    if interpolation not in ("cubic", "linear"):
        raise ValueError(f"interpolation must be 'cubic' or 'linear', got {interpolation!r}")
    if t.size < 2:
        return np.empty(0)
    pos = y >= 0
    idx = np.flatnonzero(pos[:-1] != pos[1:])
    if direction == 1:
        idx = idx[~pos[idx]]
    elif direction == -1:
        idx = idx[pos[idx]]
    if idx.size == 0:
        return np.empty(0)
    t0, t1, y0, y1 = t[idx], t[idx + 1], y[idx], y[idx + 1]
    h = t1 - t0
    s_lin = y0 / (y0 - y1)  # position of the chord's root in [0, 1] (y0 != y1 here)
    if interpolation == "linear" or t.size < 4:
        return t0 + s_lin * h
    # cubic through 4 neighbouring samples, in the local variable s = (t - t0) / h
    j = np.clip(idx - 1, 0, t.size - 4)
    nodes = (t[j[:, None] + np.arange(4)] - t0[:, None]) / h[:, None]
    vals = y[j[:, None] + np.arange(4)]
    # Newton divided differences: p(s) = c0 + (s-x0)(c1 + (s-x1)(c2 + (s-x2) c3))
    c = vals.copy()
    for k in range(1, 4):
        c[:, k:] = (c[:, k:] - c[:, k - 1:-1]) / (nodes[:, k:] - nodes[:, :-k])
    s = s_lin.copy()
    for _ in range(30):
        p, dp = c[:, 3], np.zeros_like(s)
        for k in (2, 1, 0):
            dp = dp * (s - nodes[:, k]) + p
            p = p * (s - nodes[:, k]) + c[:, k]
        with np.errstate(divide="ignore", invalid="ignore"):
            step = np.where(dp != 0, p / dp, 0.0)
        s = s - step
        if np.all(np.abs(step) <= 1e-15):
            break
    ok = np.isfinite(s) & (s >= 0.0) & (s <= 1.0)
    s = np.where(ok, s, s_lin)
    return t0 + s * h


def wobble_period(traj, component: int = 0) -> float:
    """Period of the body-frame wobble of ``omega`` (equivalently of ``L``), measured.

    Hand & Finch, ch. 8, the force-free symmetric top: the component
    ``omega1 = c cos(Omega t + phi)`` of a free symmetric top oscillates with period
    ``2 pi / |Omega|`` (:func:`precession_rate`); for the rigid Earth this is the
    Chandler (Euler) wobble (:func:`chandler_period`). Also measures the
    small-oscillation period about a stable principal axis (:func:`stability`) and the
    period ``T_m`` of
    any periodic body-frame motion (:func:`flip_period`).

    The sign changes of ``traj.omega[:, component]`` are located by
    :func:`zero_crossings` (cubic interpolation). The period is averaged over all full
    periods: upward and downward crossings are used separately (each consecutive pair
    of the same direction spans one period, so an offset or an asymmetric wave shape
    does not bias it), ``P = sum(last - first) / sum(count - 1)``. With exactly two
    crossings (one half period) ``P = 2 (t2 - t1)``, which assumes a symmetric wave.
    ``L_i = I_i omega_i`` has the same sign changes, so the result holds for ``L``.

    Parameters
    ----------
    traj : Trajectory
        Samples of one body's run (of an ensemble: ``traj.body(i)``); sample more
        finely than about 1/10 of the period.
    component : {0, 1, 2}
        Body axis whose component oscillates about zero.

    Returns
    -------
    float
        The period, in the trajectory's time unit.

    Raises
    ------
    ValueError
        Fewer than 2 sign changes (run longer, or pick a component that oscillates
        about zero), or an ensemble trajectory.
    """
    _one_body(traj, "wobble_period")
    k = _as_component(component)
    y = traj.omega[:, k]
    up = zero_crossings(traj.t, y, direction=1)
    down = zero_crossings(traj.t, y, direction=-1)
    n = up.size + down.size
    if n < 2:
        raise ValueError(
            f"wobble_period needs at least 2 sign changes of omega[:, {k}], found {n}: "
            "run for longer than one period or choose a component that oscillates about zero")
    spans = [c[-1] - c[0] for c in (up, down) if c.size >= 2]
    counts = [c.size - 1 for c in (up, down) if c.size >= 2]
    if counts:
        return float(sum(spans) / sum(counts))
    both = np.sort(np.concatenate([up, down]))
    return float(2.0 * (both[1] - both[0]))


def measured_space_precession_rate(traj) -> float:
    """Rate at which ``omega_space`` turns about the fixed ``L_space``, measured.

    Hand & Finch, ch. 8, the force-free symmetric top in the inertial frame (closed form
    :func:`space_precession_rate`,
    ``|L| / I`` for a symmetric top): ``omega_space`` is projected on the plane
    perpendicular to ``L_hat = mean(L_space) / |mean(L_space)|``; its azimuth in that
    plane (right-handed about ``L_hat``) is unwrapped and fitted by a straight line in
    time, whose slope is returned. The samples must be dense enough that the azimuth
    advances by less than ``pi`` between them.

    Parameters
    ----------
    traj : Trajectory
        One free body's run (``L_space`` constant; of an ensemble: ``traj.body(i)``), at
        least 3 samples.

    Returns
    -------
    float
        Signed rate (rad per unit time), positive counterclockwise about ``L``.

    Raises
    ------
    ValueError
        Too few samples, ``L = 0``, ``omega`` (nearly) parallel to ``L`` at some
        sample (rotation about a principal axis: no precession to measure), or an
        ensemble trajectory.
    """
    _one_body(traj, "measured_space_precession_rate")
    _has_samples(traj, 3, "a linear fit")
    L_mean = np.mean(traj.L_space, axis=0)
    L_norm = float(np.linalg.norm(L_mean))
    if L_norm == 0.0:
        raise ValueError("traj has L = 0: there is no axis to precess about")
    n = L_mean / L_norm
    # an orthonormal basis (e1, e2) of the plane perpendicular to n, with e1 x e2 = n
    helper = np.eye(3)[int(np.argmin(np.abs(n)))]
    e1 = np.cross(n, helper)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(n, e1)
    w = traj.omega_space
    x, y = w @ e1, w @ e2
    perp = np.hypot(x, y)
    if np.any(perp <= 1e-12 * np.linalg.norm(w, axis=-1)):
        raise ValueError("omega_space is parallel to L_space at some sample (rotation about a "
                         "principal axis): the azimuth of omega about L is undefined")
    phi = np.unwrap(np.arctan2(y, x))
    slope = np.polyfit(traj.t - traj.t[0], phi, 1)[0]
    return float(slope)


def fit_growth_rate(traj, component: int | None = None, window=None) -> float:
    """Exponential growth rate of a perturbation, least-squares slope of ``log|...|``.

    Hand & Finch, ch. 8, stability of rotation about the principal axes: about the
    intermediate axis the linearised Euler equations give
    ``omega1, omega3 ~ exp(sqrt(r1 r3) omega2 t)`` (closed form :func:`stability`).
    This fits ``log|y| = a + lambda t`` with ``y = traj.omega[:, component]``, or for
    ``component=None`` the transverse amplitude ``sqrt(omega_b^2 + omega_c^2)`` about
    the axis ``a`` of the largest initial ``|omega_a|`` (it grows without oscillating).

    Choosing the window. The linear solution is ``y = A e^{lambda t} + B e^{-lambda t}``
    and the nonlinear terms are ``O(y^2 / omega^2)`` relative. The fitted slope is
    biased by ``~ 2 lambda (B/A) e^{-2 lambda t}`` while the decaying mode still
    matters, and by the nonlinearity once ``|y|`` is no longer small. So start the
    window when ``|y|`` has grown ``~1e3`` times beyond its initial size (the decaying
    mode is then ``< 1e-6`` of the growing one) and stop it while ``|y| <~ 1e-2 |omega|``
    (nonlinear error ``<~ 1e-4``); keep ``|y|`` well above round-off
    (``1e-16 |omega|``) throughout. The default window (``None``) applies exactly this
    rule: samples from the first with ``|y| >= max(1e3 |y0|, 1e-12 |omega0|)`` up to
    the last before ``|y|`` first exceeds ``1e-2 |omega0|``, where ``y0`` is the initial
    perturbation (``|y(0)|``, or the initial transverse amplitude if ``y(0) = 0``).
    Start with a perturbation ``<~ 1e-8 |omega|`` so that this window spans several
    e-foldings.

    Parameters
    ----------
    traj : Trajectory
        One body's run (of an ensemble: ``traj.body(i)``).
    component : {0, 1, 2} or None
        Body axis of the growing component, or ``None`` for the transverse amplitude.
    window : None, (t_start, t_end), or boolean mask of shape (len(traj),)
        Samples to fit; ``None`` chooses them as described above.

    Returns
    -------
    float
        The fitted rate ``lambda`` (per unit time).

    Raises
    ------
    ValueError
        Fewer than 3 usable samples in the window (sample more finely, start with a
        smaller perturbation, or give the window), a zero value inside it, or an
        ensemble trajectory.
    """
    _one_body(traj, "fit_growth_rate")
    _has_samples(traj, 3, "a linear fit")
    omega = traj.omega
    scale = float(np.linalg.norm(omega[0]))
    if scale == 0.0:
        raise ValueError("traj starts at rest (omega = 0): nothing can grow")
    dominant = int(np.argmax(np.abs(omega[0])))
    others = [k for k in range(3) if k != dominant]
    transverse = np.hypot(omega[:, others[0]], omega[:, others[1]])
    if component is None:
        y = transverse
    else:
        y = np.abs(omega[:, _as_component(component)])
    t = traj.t
    if window is None:
        y0 = float(y[0]) if y[0] > 0 else float(transverse[0])
        lower = max(1e3 * y0, 1e-12 * scale)
        upper = 1e-2 * scale
        above = np.flatnonzero(y > upper)
        stop = int(above[0]) if above.size else len(t)
        mask = np.zeros(len(t), dtype=bool)
        mask[:stop] = y[:stop] >= lower
        start = np.flatnonzero(mask)
        if start.size:
            mask[start[0]:stop] = True
    elif isinstance(window, tuple) and len(window) == 2:
        lo = _as_real("window[0]", window[0])
        hi = _as_real("window[1]", window[1])
        if not hi > lo:
            raise ValueError(f"window must be (t_start, t_end) with t_end > t_start, "
                             f"got {window!r}")
        mask = (t >= lo) & (t <= hi)
    else:
        mask = np.asarray(window)
        if mask.dtype != bool or mask.shape != t.shape:
            raise ValueError(
                "window must be None, a (t_start, t_end) tuple, or a boolean mask of shape "
                f"({len(t)},); got {type(window).__name__}"
                + (f" of dtype {mask.dtype} and shape {mask.shape}" if mask.ndim else ""))
    if int(np.count_nonzero(mask)) < 3:
        raise ValueError(
            "fit_growth_rate needs at least 3 samples in the window, found "
            f"{int(np.count_nonzero(mask))}: sample more finely, start with a smaller "
            "perturbation, or pass window=(t_start, t_end)")
    ys = y[mask]
    if np.any(ys <= 0):
        raise ValueError("the fitted quantity is zero inside the window (log undefined): "
                         "choose a window where the perturbation has grown")
    slope = np.polyfit(t[mask] - t[mask][0], np.log(ys), 1)[0]
    return float(slope)


# ----------------------------------------------------------------------------------------
# stability of the principal axes (H&F ch. 8)
# ----------------------------------------------------------------------------------------


class Stability(NamedTuple):
    """Linear stability of steady rotation about a principal axis.

    Hand & Finch, *Analytical Mechanics*, ch. 8, stability of rotation about the
    principal axes; see :func:`stability`.

    Attributes
    ----------
    stable : bool
        Small perturbations stay small.
    rate : float
        The small-oscillation angular frequency if ``stable``, else the exponential
        growth rate (``0.0`` for the marginal, equal-moment cases).
    """

    stable: bool
    rate: float


def axis_role(moments, axis: int) -> str:
    """``"smallest"``, ``"intermediate"`` or ``"largest"``: the rank of ``moments[axis]``.

    Ties (a symmetric top) are ranked by position; see :func:`stability` for how equal
    moments are treated.
    """
    I = _as_moments("moments", moments)
    k = _as_axis("axis", axis)
    return _ROLES[int(np.argsort(I, kind="stable").tolist().index(k))]


def stability(moments, omega: float, axis: int) -> Stability:
    """Stability of steady rotation ``omega`` about the principal axis ``axis``.

    Hand & Finch, *Analytical Mechanics*, ch. 8, stability of rotation about the
    principal axes (the asymmetric force-free top). With the moments sorted,
    ``I1 < I2 < I3``, and ``r1 = (I3 - I2)/I1``, ``r2 = (I3 - I1)/I2``,
    ``r3 = (I2 - I1)/I3`` (all > 0), linearising Euler's equations about the steady
    rotation gives

    * about the smallest-moment axis: ``omega2'' = -r2 r3 omega1^2 omega2``, stable,
      frequency ``sqrt(r2 r3) |omega1|``;
    * about the largest-moment axis: ``omega1' = -r1 omega3 omega2``,
      ``omega2' = r2 omega3 omega1``, so ``omega1'' = -r1 r2 omega3^2 omega1``, stable,
      frequency ``sqrt(r1 r2) |omega3|`` (derived the same way);
    * about the intermediate axis: ``omega1'' = +r1 r3 omega2^2 omega1``, unstable,
      growth rate ``sqrt(r1 r3) |omega2|`` (the rate ``lambda`` of :func:`flip_period`
      near the separatrix).

    ``moments`` may be in any order (e.g. a body's ``moments``); they are sorted
    internally and :func:`axis_role` tells which of the three ``axis`` is. In general
    ``omega_b'' = kappa omega_b`` with
    ``kappa = (I_a - I_b)(I_c - I_a) omega^2 / (I_b I_c)`` for rotation about ``a``, so
    these are the three signs of ``kappa``. Equal moments (within ``1e-10`` relative):
    about the symmetry axis of a symmetric top the frequency is ``|Omega|`` of
    :func:`precession_rate`; about an axis in the equal-moment plane ``kappa = 0`` and
    a perturbation drifts linearly (``stable=False, rate=0.0``); a spherical top is
    stable with ``rate=0.0``.

    Parameters
    ----------
    moments : array_like, shape (3,)
        Principal moments (> 0), any order.
    omega : float
        Angular velocity about ``axis`` (its sign does not matter).
    axis : {0, 1, 2}
        Index into ``moments`` of the rotation axis.

    Returns
    -------
    Stability
        ``(stable, rate)``: the oscillation frequency (stable) or the growth rate
        (unstable), in rad per unit time.
    """
    I = _as_moments("moments", moments)
    w = abs(_as_real("omega", omega))
    a = _as_axis("axis", axis)
    b, c = (a + 1) % 3, (a + 2) % 3
    I = np.ldexp(I, -math.frexp(float(np.max(I)))[1])  # kappa is scale-free: exact rescaling
    scale = float(np.max(I))
    eq_b, eq_c = moments_equal(I[a], I[b], scale), moments_equal(I[a], I[c], scale)
    if eq_b and eq_c:
        return Stability(True, 0.0)
    if (eq_b or eq_c) and not moments_equal(I[b], I[c], scale):
        return Stability(False, 0.0)  # axis in the equal-moment plane: linear drift
    kappa = (I[a] - I[b]) * (I[c] - I[a]) / (I[b] * I[c])
    if moments_equal(I[b], I[c], scale) or kappa < 0:
        # symmetric top about its symmetry axis, or the smallest/largest axis
        return Stability(True, float(math.sqrt(abs(kappa)) * w))
    return Stability(False, float(math.sqrt(kappa) * w))


def dual_spin_stable(moments, omega: float, axis: int, rotor: float) -> Stability:
    """Stability of a gyrostat's steady spin ``omega`` about the principal axis ``axis``
    with rotor momentum ``rotor`` along that axis (a dual-spin satellite).

    Hughes, *Spacecraft Attitude Dynamics* (1986), ch. 7. With ``l = rotor e_a`` the body
    turns at ``omega = (L_a - rotor) / I_a``; linearising ``L' = L x I^-1 (L - l)`` about
    ``L = (I_a omega + rotor) e_a`` gives, for the transverse components,
    ``L_b'' = -kappa L_b`` with

        ``kappa = ((I_a - I_b) omega + rotor) ((I_a - I_c) omega + rotor) / (I_b I_c)``:

    stable (oscillating at ``sqrt(kappa)``) when both factors have one sign, unstable
    (growing at ``sqrt(-kappa)``) when they differ. Without a rotor this is
    :func:`stability`'s rule (the intermediate axis is unstable); a rotor momentum of the
    spin's sign, ``|rotor| > (I_b - I_a) |omega|`` for the larger transverse moment ``I_b``,
    stabilises rotation about any axis, the intermediate one included. (Energy
    dissipation in the body changes the rule: the Iorillo/Likins criterion; not modelled
    here.)

    Parameters
    ----------
    moments : array_like, shape (3,)
        Principal moments of body and rotors together (> 0).
    omega : float
        The body's spin rate about ``axis`` (signed: ``rotor`` is measured along the same
        direction).
    axis : {0, 1, 2}
        The spin axis.
    rotor : float
        The rotor momentum along ``axis`` (signed).

    Returns
    -------
    Stability
        ``(stable, rate)``: the nutation frequency or the growth rate.
    """
    I = _as_moments("moments", moments)
    w = _as_real("omega", omega)
    h = _as_real("rotor", rotor)
    a = _as_axis("axis", axis)
    b, c = (a + 1) % 3, (a + 2) % 3
    # kappa is unchanged when moments and rotor scale together: rescaled exactly (a power
    # of two) so that the products of moments neither overflow nor underflow
    e = math.frexp(float(np.max(I)))[1]
    Is, hs = np.ldexp(I, -e), math.ldexp(h, -e)
    fb, fc = (Is[a] - Is[b]) * w + hs, (Is[a] - Is[c]) * w + hs
    kappa = fb * fc / (Is[b] * Is[c])
    if not math.isfinite(kappa):
        raise ValueError(f"the nutation rate overflows for moments {I.tolist()}, omega = {w}, "
                         f"rotor = {h}")
    return Stability(bool(kappa > 0), float(math.sqrt(abs(kappa))))


# ----------------------------------------------------------------------------------------
# Dzhanibekov flips (Landau & Lifshitz §37)
# ----------------------------------------------------------------------------------------


def flip_period(moments, L) -> float:
    """Period ``T_m = 4 K(k) / nu`` of the body-frame motion of ``L`` (asymmetric body).

    Landau & Lifshitz, *Mechanics*, 3rd ed. (1976), §37 (the asymmetrical top), with
    the moments sorted ``I1 < I2 < I3``, ``G^2 = |L|^2`` and ``E2 = 2T = sum L_i^2 / I_i``:

    * ``G^2 > E2 I2`` (``L`` circulates about the largest axis):
      ``nu = sqrt((I3 - I2)(G^2 - E2 I1) / (I1 I2 I3))``,
      ``k^2 = (I2 - I1)(E2 I3 - G^2) / ((I3 - I2)(G^2 - E2 I1))``;
    * ``G^2 < E2 I2`` (about the smallest axis):
      ``nu = sqrt((I2 - I1)(E2 I3 - G^2) / (I1 I2 I3))``,
      ``k^2 = (I3 - I2)(G^2 - E2 I1) / ((I2 - I1)(E2 I3 - G^2))``.

    ``K`` is the complete elliptic integral of the first kind with parameter
    ``m = k^2`` (scipy's convention). In both cases the intermediate component is
    ``L_2 ∝ sn(nu t)``, so the flips (sign changes of ``L_2``) happen every ``T_m / 2``;
    ``T_m`` is also the period of the component that changes sign along with it
    (``L_3`` resp. ``L_1``, ``∝ cn``), while the one that keeps its sign (``∝ dn``)
    has period ``T_m / 2``. Near the separatrix ``T_m ≈ (4 / lambda) ln(4 / k')``
    with ``lambda = sqrt(r1 r3) omega2`` (:func:`stability`); for ``L`` along the
    smallest or largest axis ``T_m`` is the small-oscillation period ``2 pi / nu``.
    Numerically, ``G^2 - E2 I_j = sum_i L_i^2 (I_i - I_j) / I_i`` is formed without
    cancellation and ``K`` is evaluated as ``ellipkm1(k'^2)``, accurate near the
    separatrix; the moments and ``L`` are first rescaled by powers of two
    (``T_m(c I, s L) = (c / s) T_m(I, L)``), so any ``L`` and moments whose ``T_m`` is
    a float64 give it (``|L| = 1e300`` as well as ``1e-300``).

    Parameters
    ----------
    moments : array_like, shape (3,)
        Principal moments (> 0, pairwise distinct), any order.
    L : array_like, shape (3,)
        Body angular momentum, components in the same order as ``moments``.

    Returns
    -------
    float
        ``T_m`` (flips every ``T_m / 2``), in the time unit of ``L / moments``.

    Raises
    ------
    ValueError
        A symmetric or spherical body (the body-frame motion is the uniform wobble of
        :func:`precession_rate`, period ``2 pi / |Omega|``), ``L = 0``, or ``L`` on the
        separatrix ``G^2 = 2 T I2`` (including steady rotation about the intermediate
        axis), where the period is infinite, or a ``T_m`` beyond float64's range.
    """
    from scipy.special import ellipkm1

    I_in = _as_moments("moments", moments)
    L_in = as_float_array("L", L, shape=(3,))
    order = np.argsort(I_in, kind="stable")
    I1, I2, I3 = (float(v) for v in I_in[order])
    if moments_equal(I1, I2, I3) or moments_equal(I2, I3, I3):
        raise ValueError(
            f"flip_period needs three distinct moments, got {I_in.tolist()}: a symmetric top "
            "has no flips; its body-frame motion is the uniform wobble at "
            "Omega = omega3 (I3 - I)/I (analysis.precession_rate), period 2 pi/|Omega|")
    if not np.any(L_in != 0.0):
        raise ValueError("L must be nonzero (a body at rest has no motion)")
    # T_m(c I, s L) = (c / s) T_m(I, L): evaluated in units (powers of two, exact) where
    # the largest moment and the largest |L_i| lie in [1/2, 1), so that L_i^2 and the
    # products of moments neither overflow nor underflow
    e_I = math.frexp(I3)[1]
    e_L = math.frexp(float(np.max(np.abs(L_in))))[1]
    I1, I2, I3 = (math.ldexp(v, -e_I) for v in (I1, I2, I3))
    L2 = np.ldexp(L_in[order], -e_L) ** 2
    I = (I1, I2, I3)
    # D_j = G^2 - E2 I_j = sum_i L_i^2 (I_i - I_j) / I_i, without cancellation
    d1 = sum(L2[i] * (I[i] - I1) / I[i] for i in (1, 2))          # >= 0
    d3 = sum(L2[i] * (I3 - I[i]) / I[i] for i in (0, 1))          # E2 I3 - G^2 >= 0
    t_lo, t_hi = L2[0] * (I1 - I2) / I1, L2[2] * (I3 - I2) / I3
    d2 = t_lo + t_hi                                              # G^2 - E2 I2
    if abs(d2) <= 8 * np.finfo(float).eps * (abs(t_lo) + abs(t_hi)):
        raise ValueError(
            "L lies on the separatrix G^2 = 2 T I2 (to round-off; e.g. steady rotation "
            "about the intermediate axis): the motion is asymptotic to the unstable "
            "rotation and the period is infinite")
    prod = I1 * I2 * I3
    if d2 > 0:
        nu = math.sqrt((I3 - I2) * d1 / prod)
        m1 = (I3 - I1) * d2 / ((I3 - I2) * d1)         # k'^2 = 1 - k^2
    else:
        nu = math.sqrt((I2 - I1) * d3 / prod)
        m1 = (I3 - I1) * (-d2) / ((I2 - I1) * d3)
    m1 = min(max(m1, 0.0), 1.0)
    period = float(4.0 * ellipkm1(m1) / nu)
    if not 0.0 < period < math.inf:  # the moments span beyond float64's range
        raise ValueError(
            f"flip_period: moments {I_in.tolist()} span too many orders of magnitude for "
            f"float64 (I1 I2 I3 / I3^3 underflows)")
    out = _ldexp("flip_period's T_m", period, e_I - e_L)
    if out == 0.0:
        raise ValueError(
            f"flip_period's T_m underflows float64 (below {np.finfo(np.float64).tiny:.3g}; "
            f"|L| / moments is too large): rescale the units of L or of the moments")
    return out


# ----------------------------------------------------------------------------------------
# torque for steady rotation (H&F ch. 8: Euler's equations)
# ----------------------------------------------------------------------------------------


def steady_rotation_torque(inertia, omega) -> np.ndarray:
    """Torque ``N = omega x (I omega)`` that keeps a body rotating at constant ``omega``.

    Hand & Finch, *Analytical Mechanics*, ch. 8, Euler's equations
    ``I_i omega_i' + eps_ijk omega_j omega_k I_k = N_i`` with ``omega' = 0`` give
    ``N = omega x L``, ``L = I omega`` (body frame; in components
    ``N1 = -omega2 omega3 (I2 - I3)`` etc.). ``N = 0`` iff ``L`` is parallel to
    ``omega``, i.e. ``omega`` lies along a principal axis: only rotation about a
    principal axis is torque-free. Sign: ``N`` is the torque that must be *applied*; a
    free body instead has
    ``dL/dt (body) = L x omega = -N``.

    The rotating dumbbell (Hand & Finch's example for Euler's equations:
    ``I1 = I2 = m l^2 / 2``, ``I3 = 0``, axis ``x3``) with
    ``omega = omega (sin th, 0, cos th)``: ``N = (0, omega^2 sin th cos th I1, 0)``
    (``N2 = omega3 L1 - omega1 L3``).

    Parameters
    ----------
    inertia : array_like, shape (3,) or (3, 3)
        Principal moments (``omega`` then in the principal frame) or a symmetric
        inertia tensor (``omega`` in the same frame). Zero moments are accepted (the
        ideal dumbbell or rod); negative ones are not.
    omega : array_like, shape (..., 3)
        Angular velocity (vectorised over leading axes).

    Returns
    -------
    numpy.ndarray, shape (..., 3)
        ``N``, in the frame of ``omega``.
    """
    arr = as_float_array("inertia", inertia)
    w = as_float_array("omega", omega, last_dim=3)
    if arr.shape == (3,):
        if np.any(arr < 0):
            raise ValueError(f"inertia moments must be >= 0, got {arr.tolist()}")
        L = arr * w
    elif arr.shape == (3, 3):
        from liebody.inertia import _check_symmetric

        arr = _check_symmetric("inertia", arr)
        ev = np.linalg.eigvalsh(arr)
        if ev[0] < -1e-12 * max(float(np.max(np.abs(ev))), np.finfo(float).tiny):
            raise ValueError(f"inertia tensor must be positive semidefinite, has eigenvalue "
                             f"{float(ev[0])!r}")
        L = w @ arr.T
    else:
        raise ValueError(f"inertia must be 3 principal moments, shape (3,), or a 3x3 tensor, "
                         f"got shape {arr.shape}")
    return np.cross(w, L)


# ----------------------------------------------------------------------------------------
# Chandler wobble (H&F ch. 8: the force-free symmetric top; IERS Conventions 2010)
# ----------------------------------------------------------------------------------------


def chandler_period(body=None) -> float:
    """Free (Euler) wobble period of a rigid body, in rotation periods (sidereal days).

    Hand & Finch, *Analytical Mechanics*, ch. 8, the force-free symmetric top: for a
    symmetric top spinning at ``omega3``, ``Omega = omega3 (C - A) / A``, so the wobble
    period is ``A / (C - A)`` spin periods. For the rigid Earth
    (:func:`liebody.bodies.earth`, dynamical flattening ``(C - A)/C = H = 0.0032737949``,
    IERS Conventions 2010, IERS Technical Note 36) that is ``(1 - H)/H = 304.456``
    sidereal days (= 303.6 solar days).

    The *observed* Chandler wobble has a period of about 433 days: the Earth is not
    rigid. The elastic mantle yields to the centrifugal bulge of the wobble itself
    (Love, Larmor), which reduces the effective ``C - A``; the oceans and the fluid core
    lengthen it further (M. L. Smith & F. A. Dahlen, Geophys. J. R. Astron. Soc. 64
    (1981) 223-281). Only the rigid-body value is computed here.

    Parameters
    ----------
    body : RigidBody, optional
        A symmetric top (period ``A / |C - A|`` about its symmetry axis) or an
        asymmetric body, which is taken to spin about its largest-moment axis ``C``
        (period ``sqrt(A B / ((C - A)(C - B)))``, the stable frequency of
        :func:`stability`). Default: :func:`liebody.bodies.earth`.

    Returns
    -------
    float
        The wobble period divided by the spin period ``2 pi / omega3``.

    Raises
    ------
    TypeError
        ``body`` is not a :class:`~liebody.RigidBody`.
    ValueError
        A spherical body (no wobble).
    """
    from liebody.rigid_body import RigidBody

    if body is None:
        from liebody.bodies import earth

        body = earth()
    if not isinstance(body, RigidBody):
        raise TypeError(f"body must be a liebody.RigidBody, got {type(body).__name__}")
    if body.is_spherical:
        raise ValueError("a spherical body does not wobble (C = A): the period is infinite")
    I = body.moments
    if body.is_symmetric:
        c = body.symmetry_axis
        A = float(I[(c + 1) % 3])
        C = float(I[c])
        return A / abs(C - A)
    c = int(np.argmax(I))
    A, B = (float(I[k]) for k in range(3) if k != c)
    C = float(I[c])
    return math.sqrt(A * B / ((C - A) * (C - B)))


# ----------------------------------------------------------------------------------------
# gravity-gradient stability of an Earth-pointing satellite (Hughes 1986, ch. 9)
# ----------------------------------------------------------------------------------------


class GravityGradientStability(NamedTuple):
    """Linear stability of a rigid satellite resting in the orbital (LVLH) frame of a
    circular orbit; see :func:`gravity_gradient_stability`.

    Attributes
    ----------
    pitch_stable : bool
        The pitch libration (about the orbit normal) is a stable oscillation.
    roll_yaw_stable : bool
        The coupled roll-yaw motion is a stable oscillation (both roots of the quartic
        purely imaginary and distinct).
    region : str
        ``"Lagrange"`` (stable, ``k1 > k3 > 0``: ``I_pitch > I_roll > I_yaw``),
        ``"DeBra-Delp"`` (stable with ``k1 < 0``, ``k3 < 0``:
        ``I_roll > I_yaw > I_pitch``) or ``"unstable"`` (anything else, the boundaries
        included).
    pitch_frequency : float or None
        ``sqrt(3 (I_roll - I_yaw) / I_pitch)``, in units of the mean motion ``n``, when
        ``pitch_stable``; else ``None``.
    roll_yaw_frequencies : tuple of two floats, or None
        The two roll-yaw frequencies ``(slow, fast)`` in units of ``n`` when
        ``roll_yaw_stable``; else ``None``.
    growth_rate : float
        The largest real part of the six eigenvalues of the linearised motion, in units
        of ``n``: ``0.0`` when stable (and on the marginal boundaries), the exponential
        growth rate of the fastest-growing mode otherwise.
    k1, k3 : float
        The inertia ratios ``k1 = (I_pitch - I_yaw)/I_roll`` and
        ``k3 = (I_pitch - I_roll)/I_yaw``.
    """

    pitch_stable: bool
    roll_yaw_stable: bool
    region: str
    pitch_frequency: float | None
    roll_yaw_frequencies: tuple[float, float] | None
    growth_rate: float
    k1: float
    k3: float


#: relative tolerance on ``b^2 - 4c`` below which the roll-yaw roots count as double
#: (marginal: a double root grows linearly)
_DOUBLE_ROOT_RTOL = 1e-12


def gravity_gradient_stability(moments) -> GravityGradientStability:
    """Linear stability of a satellite that keeps its principal axes in the orbital frame.

    Hughes, *Spacecraft Attitude Dynamics* (Wiley, 1986), ch. 9 (gravity-gradient
    stabilisation); Kane, Likins & Levinson, *Spacecraft Dynamics* (McGraw-Hill, 1983);
    Wie, *Space Vehicle Dynamics and Control*, 2nd ed. (AIAA, 2008). The stable
    region with ``k1, k3 < 0`` is the one found by DeBra & Delp (J. Astronaut. Sci. 8,
    1961).

    **Convention.** A circular orbit of mean motion ``n``; the orbital (LVLH) frame has
    axis 1 along the velocity (roll), axis 2 along the *negative* orbit normal (pitch),
    axis 3 towards the Earth's centre (yaw, nadir) (:func:`liebody.attitude.lvlh_axes`).
    The frame turns at ``omega_o = -n e2``. ``moments = (I1, I2, I3) =
    (I_roll, I_pitch, I_yaw)`` are the principal moments along these three axes in the
    equilibrium, in which the body rests in the orbital frame (its inertial angular
    velocity is ``-n e2``, one revolution per orbit).

    **Linearisation.** With small roll, pitch and yaw angles ``phi, theta, psi`` of the
    body relative to the orbital frame, the body's angular velocity is
    ``omega = (phi' - n psi, theta' - n, psi' + n phi)`` and the nadir in body axes is
    ``c = (-theta, phi, 1)`` to first order, so the gravity-gradient torque
    ``3 n^2 c x (I c)`` is ``3 n^2 ((I3 - I2) phi, (I3 - I1) theta, 0)``. Euler's
    equations ``I omega' + omega x I omega = 3 n^2 c x I c`` then read, to first order,

    * pitch: ``I2 theta'' + 3 n^2 (I1 - I3) theta = 0``, stable iff ``I1 > I3``
      (``I_roll > I_yaw``), libration frequency ``sqrt(3 (I1 - I3) / I2) n``. With the
      ratios below, ``I1 > I3`` is ``k1 > k3`` for every physical body (the triangle
      inequality ``I1 + I3 > I2`` holds): ``k1 - k3 = (I1 - I3)(I1 + I3 - I2)/(I1 I3)``
      and ``3 (I1 - I3)/I2 = 3 (k1 - k3)/(1 - k1 k3)``;
    * roll-yaw: ``phi'' + 4 k1 n^2 phi - (1 - k1) n psi' = 0`` and
      ``psi'' + k3 n^2 psi + (1 - k3) n phi' = 0`` with the inertia ratios
      ``k1 = (I2 - I3)/I1`` and ``k3 = (I2 - I1)/I3``. Their characteristic equation,
      in units of ``n``, is ``s^4 + b s^2 + c = 0`` with ``b = 1 + 3 k1 + k1 k3`` and
      ``c = 4 k1 k3``: both roots ``s^2`` are real, negative and distinct (a stable
      oscillation at ``|s|``) iff ``b > 0``, ``c > 0`` and ``b^2 - 4 c > 0``.

    Both stable: the Lagrange region ``k1 > k3 > 0`` (``I_pitch > I_roll > I_yaw``: the
    least moment along the local vertical, the largest along the orbit normal; all of it
    is roll-yaw stable for physical bodies) or the DeBra-Delp region (``k1 < 0``,
    ``k3 < 0``, ``k1 > k3`` and the roll-yaw conditions: ``I_roll > I_yaw > I_pitch``
    with ``|k1|`` small), which is stable only linearly (energy dissipation destabilises
    it: it is not a minimum of the Jacobi integral).

    Parameters
    ----------
    moments : array_like, shape (3,)
        ``(I_roll, I_pitch, I_yaw)`` (> 0), in the order of the orbital axes above.

    Returns
    -------
    GravityGradientStability
        The two verdicts, the region, the frequencies (in units of ``n``) when stable,
        the growth rate (in units of ``n``) and ``k1``, ``k3``. Boundaries (equal moments
        within ``1e-10`` relative, making a root zero, or a double roll-yaw root) are
        marginal: not stable, ``growth_rate`` from the remaining modes.

    Raises
    ------
    ValueError
        Moments that are not three finite numbers > 0, or whose ratios are so extreme
        (far from any physical body) that the coefficients above overflow float64.
    """
    I = _as_moments("moments", moments)
    I1, I2, I3 = (float(v) for v in I)
    scale = max(I1, I2, I3)
    k1 = 0.0 if moments_equal(I2, I3, scale) else (I2 - I3) / I1
    k3 = 0.0 if moments_equal(I2, I1, scale) else (I2 - I1) / I3

    # pitch: theta'' = -3 (I1 - I3)/I2 theta
    pitch_equal = moments_equal(I1, I3, scale)
    p = 0.0 if pitch_equal else 3.0 * (I1 - I3) / I2
    pitch_stable = p > 0.0
    pitch_frequency = math.sqrt(p) if pitch_stable else None
    growth = math.sqrt(-p) if p < 0.0 else 0.0

    # roll-yaw: s^4 + b s^2 + c = 0
    b = 1.0 + 3.0 * k1 + k1 * k3
    c = 4.0 * k1 * k3
    disc = b * b - 4.0 * c
    if not (math.isfinite(p) and math.isfinite(disc)):
        raise ValueError(
            f"moments {I.tolist()} span too many orders of magnitude for float64: the "
            f"coefficients of the linearised motion overflow (3 (I1 - I3)/I2 = {p:g}, "
            f"b^2 - 4 c = {disc:g})")
    double = abs(disc) <= _DOUBLE_ROOT_RTOL * max(b * b, abs(4.0 * c), 1e-300)
    roll_yaw_stable = b > 0.0 and c > 0.0 and disc > 0.0 and not double
    roll_yaw_frequencies = None
    if roll_yaw_stable:
        root = math.sqrt(disc)
        fast2 = 0.5 * (b + root)
        slow2 = c / fast2  # the product of the two roots s^2 is c: no cancellation
        roll_yaw_frequencies = (math.sqrt(slow2), math.sqrt(fast2))
    else:
        root = cmath.sqrt(disc)
        for mu in (0.5 * (-b + root), 0.5 * (-b - root)):  # the two roots s^2
            growth = max(growth, abs(cmath.sqrt(mu).real))

    if pitch_stable and roll_yaw_stable:
        region = "Lagrange" if (k1 > 0.0 and k3 > 0.0) else "DeBra-Delp"
    else:
        region = "unstable"
    return GravityGradientStability(bool(pitch_stable), bool(roll_yaw_stable), region,
                                    pitch_frequency, roll_yaw_frequencies, float(growth),
                                    float(k1), float(k3))


# ----------------------------------------------------------------------------------------
# forced precession of a planet's spin axis (Murray & Dermott 1999; Ward 1974)
# ----------------------------------------------------------------------------------------


def forced_precession_constant(moments, spin: float, GM: float, a: float, e: float = 0.0,
                               *, axis: int = 2) -> float:
    """Precession constant ``k`` of a spinning oblate planet's axis, forced by one body on a
    Kepler orbit.

    Goldstein, Poole & Safko, *Classical Mechanics*, 3rd ed. (Addison-Wesley, 2002),
    sect. 5.8 (precession of the equinoxes: the orbit-averaged torque on an oblate
    body); W. R. Ward, "Climatic variations on Mars: 1. Astronomical theory of
    insolation", J. Geophys. Res. 79 (1974) 3375-3386 (the precession constant with the
    eccentricity factor); Murray & Dermott, *Solar System Dynamics* (Cambridge
    University Press, 1999) for the orbit averages:

        ``k = (3/2) (GM / a^3) ((C - A) / C) / spin * (1 - e^2)^(-3/2)``.

    **Derivation.** With the figure axis ``s`` and ``I = A 1 + (C - A) s s^T``, the
    gravity-gradient torque of a mass ``GM`` at ``r`` (seen from the planet) is
    ``tau = 3 GM / r^5 r x I r = 3 GM (C - A) (s . r)(r x s) / r^5``. Averaged over the
    orbit (the axis moves little in one orbit), ``<r r^T / r^5> =
    (1 - n n^T) <1/r^3> / 2`` with ``n`` the orbit normal and
    ``<1/r^3> = a^-3 (1 - e^2)^(-3/2)`` (the time average over a Kepler ellipse), so
    ``<tau> = -(3/2) GM (C - A) a^-3 (1 - e^2)^(-3/2) (n . s)(n x s)``. For fast spin
    ``L = C spin s`` (the gyroscopic approximation: ``spin`` much faster than the
    orbital and the precession frequencies) and ``dL/dt = <tau>`` gives

        ``ds/dt = -k cos(eps) (n x s)``, ``cos(eps) = n . s``:

    the spin axis turns about the orbit normal at the rate ``-k cos(eps)`` at a fixed
    obliquity ``eps`` (:func:`forced_precession_rate`); negative: retrograde, the
    precession of the equinoxes. ``GM`` is the perturber's own gravitational parameter
    (for the Sun, ``GM / a^3`` is the square of the mean motion; for the Moon it is not:
    the mean motion involves the Earth's mass as well).

    Parameters
    ----------
    moments : array_like, shape (3,)
        Principal moments of the planet (> 0). ``C = moments[axis]`` is the spin axis;
        the equatorial moment ``A`` is the mean of the other two (exact for a symmetric
        planet, the spin-averaged value for a triaxial one).
    spin : float
        Spin rate about ``axis`` (rad per unit time, > 0).
    GM : float
        Gravitational parameter of the perturber (> 0), in the units of ``a`` and time.
    a : float
        Semi-major axis of the perturber's orbit relative to the planet (> 0).
    e : float, default 0.0
        Eccentricity, ``0 <= e < 1``.
    axis : {0, 1, 2}, default 2
        Index of the spin (figure) axis in ``moments``.

    Returns
    -------
    float
        ``k`` in rad per unit time: positive for an oblate planet (``C > A``), negative
        for a prolate one.
    """
    I = _as_moments("moments", moments)
    w = as_positive_float("spin", spin)
    GM = as_positive_float("GM", GM)
    a = as_positive_float("a", a)
    e = _as_real("e", e)
    if not 0.0 <= e < 1.0:
        raise ValueError(f"e (the eccentricity) must be in [0, 1) for a closed orbit, got {e}")
    c = _as_axis("axis", axis)
    C = float(I[c])
    A = 0.5 * (float(I[(c + 1) % 3]) + float(I[(c + 2) % 3]))
    flattening = 0.0 if moments_equal(C, A, float(np.max(I))) else (C - A) / C
    # GM / a^3 from mantissas and exponents: a^3 alone overflows for a > 5e102
    (mg, eg), (ma, ea) = math.frexp(GM), math.frexp(a)
    tidal = _ldexp("GM / a^3", mg / (ma * ma * ma), eg - 3 * ea)
    ecc = ((1.0 - e) * (1.0 + e)) ** -1.5
    k = 1.5 * tidal * flattening / w * ecc
    if not math.isfinite(k):
        raise ValueError(f"the precession constant overflows for GM = {GM:g}, a = {a:g}, "
                         f"spin = {w:g}: rescale the units")
    return float(k)


def forced_precession_rate(moments, spin: float, GM: float, a: float, obliquity: float,
                           e: float = 0.0, *, axis: int = 2) -> float:
    """Mean precession rate ``-k cos(obliquity)`` of a planet's spin axis about the normal
    of the perturber's orbit.

    ``k`` is :func:`forced_precession_constant` (Goldstein, Poole & Safko 2002,
    sect. 5.8; Ward 1974); the averaged equation ``ds/dt = -k cos(eps) (n x s)`` turns the spin axis
    ``s`` about the orbit normal ``n`` at this rate, keeping the obliquity ``eps``.
    Several perturbers (the Sun and the Moon on the Earth) add their rates when their
    orbits share a plane.

    Parameters
    ----------
    moments, spin, GM, a, e, axis
        As for :func:`forced_precession_constant`.
    obliquity : float
        Angle ``eps`` between the spin axis (the direction of the spin angular
        momentum) and the orbit normal, radians (any finite real).

    Returns
    -------
    float
        The rate in rad per unit time, signed about the orbit normal: negative
        (retrograde) for an oblate planet with ``eps < 90 deg``.
    """
    eps = _as_real("obliquity", obliquity)
    k = forced_precession_constant(moments, spin, GM, a, e, axis=axis)
    return float(-k * math.cos(eps))
