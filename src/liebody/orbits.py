"""Orbits as data: where a source of gravity is, seen from the body's centre of mass.

An orbit gives the position ``r(t)`` of a source (the Earth below a satellite, the Sun
seen from a planet) relative to the body's centre of mass, in the inertial (space)
frame, as a function of time. With all angles zero every orbit lies in the x-y plane
and runs counter-clockwise about ``+z``; the orientation angles follow the usual
``R = Rz(raan) Rx(inclination) Rz(argp)`` convention of orbital elements (Murray &
Dermott, *Solar System Dynamics*, 1999, sect. 2.8). The kernels evaluate the same
numbers (``liebody._models.orbit``) inside the integrators.

* :class:`Circular` — a circular orbit of mean motion ``n``;
* :class:`Kepler` — a two-body (Kepler) ellipse, Kepler's equation solved to round-off
  for ``0 <= e < 1``;
* :class:`Table` — positions sampled at given times (from an ephemeris), interpolated
  to order 4 or higher, with an estimate of the interpolation error.
"""

from __future__ import annotations

import math

import numpy as np

from liebody._validate import as_float_array, as_positive_float

__all__ = ["Circular", "Kepler", "Orbit", "Table"]


def _angle(name: str, value) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
        raise TypeError(f"{name} must be a real number (radians), got {type(value).__name__}")
    value = float(value)
    if not math.isfinite(value):
        raise ValueError(f"{name} must be finite, got {value}")
    return value


def _kind(name: str) -> float:
    """An orbit kind of the kernels (``liebody._models.orbit``; imported on use: importing
    liebody loads no numba)."""
    from liebody._models import orbit

    return float(getattr(orbit, name))


def _plane(inclination: float, raan: float, argp: float) -> tuple[np.ndarray, np.ndarray]:
    """The unit vectors ``P`` (to pericentre) and ``Q`` of ``Rz(raan) Rx(i) Rz(argp)``."""
    cO, sO = math.cos(raan), math.sin(raan)
    ci, si = math.cos(inclination), math.sin(inclination)
    cw, sw = math.cos(argp), math.sin(argp)
    P = np.array([cO * cw - sO * ci * sw, sO * cw + cO * ci * sw, si * sw])
    Q = np.array([-cO * sw - sO * ci * cw, -sO * sw + cO * ci * cw, si * cw])
    return P, Q


class Orbit:
    """Base of the orbits: a row of numbers the kernels read (``liebody._models.orbit``)."""

    row: np.ndarray  # the kernels' orbit row (its kind first)

    def position(self, t) -> np.ndarray:
        """The position ``r(t)`` in the inertial frame: ``(3,)`` for a number, ``(..., 3)``
        for an array of times."""
        from liebody._models.orbit import positions

        t_arr = as_float_array("t", t)
        flat = np.ascontiguousarray(t_arr.reshape(-1))
        out = np.empty((flat.shape[0], 3))
        positions(self.row, flat, out)
        return out.reshape(t_arr.shape + (3,))

    @property
    def mean_motion(self) -> float:
        """The mean motion ``n`` (rad per unit time) of a :class:`Circular` or
        :class:`Kepler` orbit."""
        return float(self.row[2])

    @property
    def period(self) -> float:
        """The orbital period ``2 pi / n``."""
        return 2.0 * math.pi / self.mean_motion

    @property
    def normal(self) -> np.ndarray:
        """The unit normal of the orbital plane, ``P x Q`` (the direction of the orbital
        angular momentum)."""
        return np.cross(self.row[6:9], self.row[9:12])

    def __eq__(self, other) -> bool:
        return type(other) is type(self) and np.array_equal(other.row, self.row)

    def __hash__(self) -> int:
        # + 0.0 turns -0.0 into 0.0: rows equal under __eq__ have the same bytes
        return hash((type(self).__name__, (self.row + 0.0).tobytes()))


class Circular(Orbit):
    """A circular orbit of mean motion ``n`` and ``radius``.

    ``r(t) = radius (cos(n t + phase) P + sin(n t + phase) Q)``, the plane turned by
    ``inclination`` about the x axis, then by ``raan`` about z (with all angles zero,
    ``r(0) = (radius, 0, 0)`` and the orbit runs counter-clockwise about ``+z``).

    Parameters
    ----------
    n
        Mean motion (rad per unit time, > 0).
    radius
        Radius (> 0).
    inclination, raan, phase
        Inclination, right ascension of the ascending node, and the phase at ``t = 0``
        (radians).
    """

    def __init__(self, n, radius=1.0, inclination=0.0, raan=0.0, phase=0.0) -> None:
        self.n = as_positive_float("n", n)
        self.radius = as_positive_float("radius", radius)
        self.inclination = _angle("inclination", inclination)
        self.raan = _angle("raan", raan)
        self.phase = _angle("phase", phase)
        P, Q = _plane(self.inclination, self.raan, 0.0)
        self.row = np.array([_kind("KEPLER"), 0.0, self.n, self.radius, self.radius, self.phase, *P,
                             *Q])
        self.row.flags.writeable = False

    def __repr__(self) -> str:
        return (f"Circular(n={self.n:g}, radius={self.radius:g}, "
                f"inclination={self.inclination:g}, raan={self.raan:g}, phase={self.phase:g})")


class Kepler(Orbit):
    """A two-body (Kepler) orbit: an ellipse of semi-major axis ``a`` and eccentricity ``e``.

    The mean motion is ``n = sqrt(GM / a^3)`` (``GM`` of the two-body problem), the mean
    anomaly ``M = M0 + n t``, Kepler's equation ``E - e sin E = M`` is solved to round-off
    in the kernels (also for ``e`` near 1 and large ``t``), and
    ``r = a (cos E - e) P + a sqrt(1 - e^2) sin E Q`` with ``P, Q`` the first two columns
    of ``Rz(raan) Rx(i) Rz(argp)``. ``M`` is formed in float64, so the phase carries an
    error of about an ulp of ``M`` (``1e-15`` rad in the first orbit, ``1e-12`` after
    ``10^3`` orbits, ``1e-6`` after ``10^9``), and is lost beyond ``|M| ~ 2^53``.

    Parameters
    ----------
    a
        Semi-major axis (> 0).
    e
        Eccentricity, ``0 <= e < 1``.
    GM
        Gravitational parameter of the two-body problem (> 0).
    i, raan, argp, M0
        Inclination, right ascension of the ascending node, argument of pericentre and
        mean anomaly at ``t = 0`` (radians).
    """

    def __init__(self, a, e, GM, i=0.0, raan=0.0, argp=0.0, M0=0.0) -> None:
        self.a = as_positive_float("a", a)
        e = _angle("e", e)
        if not 0.0 <= e < 1.0:
            raise ValueError(f"e (the eccentricity) must be in [0, 1) for a closed orbit, "
                             f"got {e}")
        self.e = e
        self.GM = as_positive_float("GM", GM)
        self.i = _angle("i", i)
        self.raan = _angle("raan", raan)
        self.argp = _angle("argp", argp)
        self.M0 = _angle("M0", M0)
        n = math.sqrt(self.GM / self.a) / self.a
        if not (n > 0.0 and math.isfinite(n)):
            raise ValueError(f"the mean motion sqrt(GM / a^3) = {n} is not a positive finite "
                             f"number for a = {self.a:g}, GM = {self.GM:g}")
        b = self.a * math.sqrt((1.0 - e) * (1.0 + e))
        P, Q = _plane(self.i, self.raan, self.argp)
        self.row = np.array([_kind("KEPLER"), e, n, self.a, b, self.M0, *P, *Q])
        self.row.flags.writeable = False

    def __repr__(self) -> str:
        return (f"Kepler(a={self.a:g}, e={self.e:g}, GM={self.GM:g}, i={self.i:g}, "
                f"raan={self.raan:g}, argp={self.argp:g}, M0={self.M0:g})")


#: intervals per chunk of the table's checks (bounds the memory of the dense samples)
_CHUNK = 8192
#: samples per interval for the error estimate's ``max |omega|`` and the distance bound
_DENSE = 33
#: the divided differences of order ``points`` next to a stencil ``j .. j + points - 1``
#: that the error estimate takes the largest of: those starting at ``j - 2 .. j + 1``
_NEAR = np.arange(-2, 2)
#: the error estimate's factor of safety on the leading term
_SAFETY = 2.0


class Table(Orbit):
    """Positions sampled at given times (an ephemeris), interpolated in the kernels.

    ``r(t)`` is the Lagrange polynomial through the ``points`` samples nearest ``t``:
    those of the interval ``[t_i, t_{i+1}]`` that holds ``t`` and ``points/2 - 1`` more
    on each side (shifted inwards at the ends of the table), so the interpolant is
    continuous, passes through every sample, and its error is ``O(h^points)`` for
    samples ``h`` apart (order ``points``; ``points = 4``: piecewise cubic). The times
    need not be evenly spaced; on evenly spaced times the interval is found in O(1),
    otherwise by bisection. A time outside ``[t[0], t[-1]]`` is an error:
    :meth:`position` raises ``ValueError`` naming it, and in a run the kernels' torque is
    NaN there, so the run stops at that step with a torque failure
    (``Trajectory.failures``); :attr:`span` is the range to integrate over.

    **Error estimate.** The error of the interpolant through the samples
    ``t_j .. t_{j+p-1}`` is ``r(t) - P(t) = r[t_j, ..., t_{j+p-1}, t] omega(t)``,
    ``omega(t) = prod_a (t - t_{j+a})`` (K. E. Atkinson, *An Introduction to Numerical
    Analysis*, 2nd ed., Wiley, 1989, sect. 3.2: the divided-difference form of the
    interpolation error). ``error_estimate`` replaces the unknown divided difference
    with the largest in norm of the four divided differences of order ``p`` of the
    samples around it (``p + 1`` consecutive samples from ``t_{j-2}``, ``t_{j-1}``,
    ``t_j`` or ``t_{j+1}``, each sharing at least ``p - 1`` with the stencil), takes ``max
    |omega|`` over each interval (33 points of it), and reports twice the largest
    product over the table (a factor of safety), plus ``points * eps * max |r|`` for the
    rounding. It is the leading term
    of the error, not a rigorous bound: it assumes that the ``p``-th derivative of
    ``r`` changes little over ``p + 1`` samples (the samples resolve the motion).

    Parameters
    ----------
    t : array_like, shape (m,)
        Sample times, finite and strictly increasing, in the run's time unit.
    r : array_like, shape (m, 3)
        The source's position seen from the body's centre of mass in the inertial frame
        at each time (finite, nonzero).
    points : int, default 4
        Samples per interpolant: 4, 6 or 8 (orders 4, 6, 8). The table needs at least
        ``points + 1`` samples (the interpolant's and one more for its error estimate).

    Attributes
    ----------
    t, r : numpy.ndarray
        The samples (read-only copies).
    points : int
        Samples per interpolant (the order).
    error_estimate : float
        Estimated largest error of the interpolated position over the table, in the
        unit of ``r`` (see above).
    min_distance : float
        A lower bound on the interpolant's ``|r(t)|`` over the table: the least distance
        at 33 points of every interval less the longest step between those points (the
        torque bound of the SIMD kernels uses it).

    Examples
    --------
    The Moon from an ephemeris (``erfa.moon98``: geocentric, the Earth's equator and
    equinox, au), every quarter of a day for a year::

        t = np.arange(0.0, 365.25, 0.25)
        r = erfa.moon98(2451545.0, t)[:, 0]  # (m, 3)
        moon = Table(t, r)
    """

    def __init__(self, t, r, points=4) -> None:
        if isinstance(points, bool) or not isinstance(points, int | np.integer):
            raise TypeError(f"points must be an integer (4, 6 or 8), got "
                            f"{type(points).__name__}")
        if int(points) not in (4, 6, 8):
            raise ValueError(f"points must be 4, 6 or 8 (samples per interpolant: orders 4, 6, "
                             f"8), got {points}")
        p = int(points)
        t = np.array(as_float_array("t", t), dtype=np.float64)
        if t.ndim != 1:
            raise ValueError(f"t must be one-dimensional (the sample times), got shape "
                             f"{t.shape}")
        m = t.shape[0]
        if m < p + 1:
            raise ValueError(f"t and r must hold at least points + 1 = {p + 1} samples (a "
                             f"Lagrange interpolant through {p} and one more for its error "
                             f"estimate), got {m}")
        step = np.diff(t)
        if not np.all(step > 0.0):
            i = int(np.argmin(step > 0.0))
            raise ValueError(f"t must be strictly increasing: t[{i + 1}] = "
                             f"{float(t[i + 1])!r} does not exceed t[{i}] = {float(t[i])!r}")
        r = np.array(as_float_array("r", r, allow_nonfinite=True), dtype=np.float64)
        if r.shape != (m, 3):
            raise ValueError(f"r must have shape (m, 3) = ({m}, 3), one position per time, "
                             f"got {r.shape}")
        bad = ~np.isfinite(r).all(axis=1)
        if bad.any():
            i = int(np.argmax(bad))
            raise ValueError(f"r must be finite (no NaN or inf): r[{i}] = {r[i].tolist()} at "
                             f"t = {float(t[i])!r}")
        dist = np.linalg.norm(r, axis=1)
        if not np.all(dist > 0.0):
            i = int(np.argmin(dist > 0.0))
            raise ValueError(f"r must not vanish (a source at the body's centre of mass): "
                             f"r[{i}] = 0 at t = {float(t[i])!r}")
        from liebody._models import orbit

        self.t, self.r, self.points = t, r, p
        head = orbit.TABLE_HEAD
        row = np.empty(head + 4 * m)
        row[:head] = (orbit.TABLE, m, p, t[0], t[-1], 0.0)  # r_low (row[5]) set below
        row[head:] = np.concatenate([t, r[:, 0], r[:, 1], r[:, 2]])
        self.row = row
        self.error_estimate, self.min_distance = self._checks()
        row[5] = self.min_distance
        for a in (self.t, self.r, self.row):
            a.flags.writeable = False

    def _checks(self) -> tuple[float, float]:
        """The error estimate and the lower bound on the distance (see the class)."""
        from liebody._models.orbit import positions

        t, r, p = self.t, self.r, self.points
        m = t.shape[0]
        dd = r
        for k in range(1, p + 1):
            dd = (dd[1:] - dd[:-1]) / (t[k:] - t[:-k])[:, None]
        D = np.linalg.norm(dd, axis=1)  # |r[t_i .. t_{i+p}]|, i = 0 .. m - p - 1
        u = np.linspace(0.0, 1.0, _DENSE)
        est, low, hop = 0.0, math.inf, 0.0
        for start in range(0, m - 1, _CHUNK):
            i = np.arange(start, min(start + _CHUNK, m - 1))
            j = np.clip(i - p // 2 + 1, 0, m - p)
            nearby = np.max(D[np.clip(j[:, None] + _NEAR, 0, m - p - 1)], axis=1)
            s = t[i, None] + (t[i + 1] - t[i])[:, None] * u
            s[:, -1] = t[i + 1]
            omega = np.ones_like(s)
            for a in range(p):
                omega *= s - t[j + a, None]
            est = max(est, float(np.max(nearby * np.max(np.abs(omega), axis=1))))
            P = np.empty((s.size, 3))
            positions(self.row, np.ascontiguousarray(s.reshape(-1)), P)
            low = min(low, float(np.min(np.linalg.norm(P, axis=1))))
            hop = max(hop, float(np.max(np.linalg.norm(np.diff(
                P.reshape(s.shape + (3,)), axis=1), axis=2))))
        rounding = p * np.finfo(float).eps * float(np.max(np.abs(r)))
        return _SAFETY * est + rounding, low - hop

    @property
    def span(self) -> tuple[float, float]:
        """The times the table covers, ``(t[0], t[-1])``."""
        return float(self.t[0]), float(self.t[-1])

    def position(self, t) -> np.ndarray:
        """The interpolated position ``r(t)``: ``(3,)`` for a number, ``(..., 3)`` for an
        array of times. Raises ``ValueError`` naming a time outside :attr:`span`."""
        t_arr = as_float_array("t", t, allow_nonfinite=True)
        lo, hi = self.span
        outside = ~((t_arr >= lo) & (t_arr <= hi))
        if outside.any():
            bad = float(t_arr.reshape(-1)[int(np.argmax(outside.reshape(-1)))])
            raise ValueError(f"t = {bad!r} is outside the table's times [{lo!r}, {hi!r}]")
        return super().position(t_arr)

    @property
    def mean_motion(self) -> float:
        raise AttributeError("a Table has no mean motion (it is sampled, not a conic)")

    @property
    def period(self) -> float:
        raise AttributeError("a Table has no period (it is sampled, not a conic)")

    @property
    def normal(self) -> np.ndarray:
        raise AttributeError("a Table has no orbital plane (it is sampled, not a conic)")

    def __repr__(self) -> str:
        lo, hi = self.span
        return (f"Table({self.t.shape[0]} samples, t in [{lo:g}, {hi:g}], "
                f"points={self.points}, error_estimate={self.error_estimate:.3g})")

