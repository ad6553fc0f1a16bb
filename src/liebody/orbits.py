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
  for ``0 <= e < 1``.
"""

from __future__ import annotations

import math

import numpy as np

from liebody._validate import as_float_array, as_positive_float

__all__ = ["Circular", "Kepler", "Orbit"]


def _angle(name: str, value) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
        raise TypeError(f"{name} must be a real number (radians), got {type(value).__name__}")
    value = float(value)
    if not math.isfinite(value):
        raise ValueError(f"{name} must be finite, got {value}")
    return value


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

    row: np.ndarray  # (orbit.WIDTH,)

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
        return float(self.row[1])

    @property
    def period(self) -> float:
        """The orbital period ``2 pi / n``."""
        return 2.0 * math.pi / self.mean_motion

    @property
    def normal(self) -> np.ndarray:
        """The unit normal of the orbital plane, ``P x Q`` (the direction of the orbital
        angular momentum)."""
        return np.cross(self.row[5:8], self.row[8:11])

    def __eq__(self, other) -> bool:
        return type(other) is type(self) and np.array_equal(other.row, self.row)

    def __hash__(self) -> int:
        return hash((type(self).__name__, self.row.tobytes()))


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
        self.row = np.array([0.0, self.n, self.radius, self.radius, self.phase, *P, *Q])
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
    of ``Rz(raan) Rx(i) Rz(argp)``.

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
        self.row = np.array([e, n, self.a, b, self.M0, *P, *Q])
        self.row.flags.writeable = False

    def __repr__(self) -> str:
        return (f"Kepler(a={self.a:g}, e={self.e:g}, GM={self.GM:g}, i={self.i:g}, "
                f"raan={self.raan:g}, argp={self.argp:g}, M0={self.M0:g})")
