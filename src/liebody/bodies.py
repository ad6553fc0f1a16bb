"""Ready-made bodies: the rigid Earth, Mars and the Moon, and test bodies.

The Earth model is the force-free symmetric top of Hand & Finch, *Analytical
Mechanics* (Cambridge University Press, 1998), ch. 8, with the dynamical flattening of
the IERS Conventions (2010) (G. Petit & B. Luzum (eds.), IERS Technical Note 36). Mars
is a symmetric top as well, with the dynamical flattening of the JPL gravity and
orientation solutions (A. S. Konopliv et al., Icarus 211 (2011) 401-428); the Moon is
triaxial, its moments fixed by the libration parameters of lunar laser ranging
(J. G. Williams et al., J. Geophys. Res. Planets 119 (2014) 1546-1578). The test bodies
are the standard ones of the geometric-integration papers listed in
docs/references.md.
"""

from __future__ import annotations

import math

from liebody._validate import as_positive_float
from liebody.rigid_body import RigidBody

__all__ = ["EARTH_C", "EARTH_H", "MARS_C", "MARS_C_MR2", "MARS_H", "MARS_J2", "MARS_SIDEREAL_DAY",
           "MOON_BETA", "MOON_C", "MOON_C_MR2", "MOON_GAMMA", "MOON_SIDEREAL_MONTH",
           "SIDEREAL_DAY", "book", "earth", "earth_spin", "hlw", "mars", "mars_spin", "moon",
           "moon_spin"]

#: Sidereal day in SI seconds: the Earth's rotation period relative to the fixed stars
#: (23 h 56 min 4.0905 s).
SIDEREAL_DAY = 86164.0905

#: Dynamical ellipticity (dynamical flattening) ``H = (C - A) / C`` of the Earth: the IERS
#: value, as given by the ``ahrs`` package's constants (``DYNAMIC_ELLIPTICITY``); the
#: numerical standards of the IERS Conventions (2010) (IERS Technical Note 36, ch. 1)
#: give ``H = 3273795e-9``.
EARTH_H = 0.0032737949

#: Polar moment of inertia of the Earth, ``C ≈ 0.3307 M a^2 ≈ 8.034e37 kg m^2``
#: (``M = 5.972e24 kg``, ``a = 6378137 m``); only needed for physical units.
EARTH_C = 8.034e37


def earth(C: float = 1.0) -> RigidBody:
    """The rigid Earth as a symmetric top: moments ``(A, A, C)``, ``A = C (1 - H)``.

    Hand & Finch, *Analytical Mechanics*, ch. 8, the force-free symmetric top, whose
    example is the Earth; ``H = EARTH_H`` is the dynamical ellipticity ``(C - A)/C``
    (IERS Conventions 2010, IERS Technical Note 36).
    The figure (symmetry) axis is body axis 3 (index 2). Spinning once per
    :data:`SIDEREAL_DAY` (:func:`earth_spin`), its free wobble has the period
    ``A / (C - A) = (1 - H)/H = 304.456`` sidereal days
    (:func:`liebody.analysis.chandler_period`).

    Parameters
    ----------
    C : float, default 1.0
        Polar moment. The dynamics of a free body depend only on the ratios of the
        moments, so the default normalises ``C = 1``; pass :data:`EARTH_C`
        (``8.034e37 kg m^2``) for ``L`` and energies in SI units.

    Returns
    -------
    RigidBody
    """
    C = as_positive_float("C", C)
    A = C * (1.0 - EARTH_H)
    return RigidBody([A, A, C])


def earth_spin() -> float:
    """The Earth's spin rate ``2 pi / SIDEREAL_DAY = 7.292115e-5`` rad/s."""
    return 2.0 * math.pi / SIDEREAL_DAY


# ----------------------------------------------------------------------------------------
# Mars (Konopliv et al. 2011, 2016; Folkner et al. 1997)
# ----------------------------------------------------------------------------------------

#: Sidereal rotation period of Mars in SI seconds, ``88642.663 s = 24.62296 h``: the
#: rotation rate ``350.891985307 deg/day`` of the JPL orientation solution of A. S.
#: Konopliv, R. S. Park & W. M. Folkner, "An improved JPL Mars gravity field and
#: orientation from Mars orbiter and lander tracking data", Icarus 274 (2016) 253-260.
MARS_SIDEREAL_DAY = 86400.0 * 360.0 / 350.891985307

#: Second-degree zonal gravity coefficient of Mars (unnormalised, reference radius
#: 3396 km), ``J2 = (C - (A + B)/2) / (M R^2) = 1.9566e-3``: the JPL gravity fields of
#: A. S. Konopliv et al., "Mars high resolution gravity fields from MRO, Mars seasonal
#: gravity, and other dynamical parameters", Icarus 211 (2011) 401-428 (normalised
#: ``C20 = -8.7502e-4``; ``J2 = -sqrt(5) C20``).
MARS_J2 = 1.9566e-3

#: Normalised polar moment of inertia of Mars, ``C / (M R^2) = 0.3644 +- 0.0005``
#: (``R = 3396 km``; Konopliv et al. 2011), from their precession rate
#: ``-7594 +- 10 mas/yr`` and ``J2``. The Pathfinder value of W. M. Folkner et al.,
#: Science 278 (1997) 1749-1752, is ``0.3662 +- 0.0017`` (precession
#: ``-7576 +- 35 mas/yr``).
MARS_C_MR2 = 0.3644

#: Dynamical ellipticity ``H = (C - A)/C = J2 / (C/(M R^2)) = 5.3694e-3`` of Mars, ``A``
#: the mean equatorial moment (Konopliv et al. 2011: :data:`MARS_J2` over
#: :data:`MARS_C_MR2`). It sets the precession of the spin axis under the Sun's torque
#: (:func:`liebody.analysis.forced_precession_rate`).
MARS_H = MARS_J2 / MARS_C_MR2

#: Polar moment of inertia of Mars, ``C = 0.3644 M R^2 = 2.697e36 kg m^2``
#: (``GM = 42828.376 km^3/s^2``, Konopliv et al. 2016, ``G = 6.6743e-11``, ``R = 3396
#: km``); only needed for physical units.
MARS_C = 2.697e36


def mars(C: float = 1.0) -> RigidBody:
    """Rigid Mars as a symmetric top: moments ``(A, A, C)``, ``A = C (1 - H)``.

    ``H = MARS_H = 5.3694e-3`` is the dynamical ellipticity ``(C - A)/C`` with ``A`` the
    mean equatorial moment: ``J2 = 1.9566e-3`` over ``C/(M R^2) = 0.3644`` (A. S.
    Konopliv et al., Icarus 211 (2011) 401-428; :data:`MARS_J2`, :data:`MARS_C_MR2`).
    The figure (symmetry) axis is body axis 3 (index 2). Spinning once per
    :data:`MARS_SIDEREAL_DAY` (24.62296 h, :func:`mars_spin`), its free (Euler) wobble
    has the period ``(1 - H)/H = 185.24`` sidereal days
    (:func:`liebody.analysis.chandler_period`). Under the Sun's torque its axis precesses
    at about ``-7.6 arcsec/yr`` (W. M. Folkner et al., Science 278 (1997) 1749-1752:
    ``-7576 +- 35 mas/yr``; Konopliv et al. 2011: ``-7594 +- 10``; A. S. Konopliv, R. S.
    Park & W. M. Folkner, Icarus 274 (2016) 253-260: ``-7608.3 +- 2.1``), which
    :func:`liebody.analysis.forced_precession_rate` reproduces from these moments.

    The real Mars is slightly triaxial: its two equatorial moments differ by about
    ``2.5e-4 M R^2`` (``(B - A)/C`` about ``7e-4``, an eighth of ``(C - A)/C``; from the
    sectorial gravity coefficients ``C22``, ``S22``, first measured with Mariner 9:
    J. Lorell et al., Science 175 (1972) 317-320). The symmetric top keeps their mean,
    which is what the orbit-averaged precession depends on.

    Parameters
    ----------
    C : float, default 1.0
        Polar moment. The free dynamics depend only on the ratios of the moments, so the
        default normalises ``C = 1``; pass :data:`MARS_C` (``2.697e36 kg m^2``) for ``L``
        and energies in SI units.

    Returns
    -------
    RigidBody
    """
    C = as_positive_float("C", C)
    A = C * (1.0 - MARS_H)
    return RigidBody([A, A, C])


def mars_spin() -> float:
    """Mars's spin rate ``2 pi / MARS_SIDEREAL_DAY = 7.088218e-5`` rad/s."""
    return 2.0 * math.pi / MARS_SIDEREAL_DAY


# ----------------------------------------------------------------------------------------
# the Moon (Williams et al. 2014; Konopliv et al. 1998)
# ----------------------------------------------------------------------------------------

#: Libration parameter ``beta = (C - A)/B = 631.0213e-6 (+- 0.0031e-6)`` of the Moon,
#: from lunar laser ranging: J. G. Williams et al., "Lunar interior properties from the
#: GRAIL mission", J. Geophys. Res. Planets 119 (2014) 1546-1578.
MOON_BETA = 631.0213e-6

#: Libration parameter ``gamma = (B - A)/C = 227.7317e-6 (+- 0.0042e-6)`` of the Moon
#: (Williams et al. 2014, lunar laser ranging).
MOON_GAMMA = 227.7317e-6

#: Normalised polar moment of inertia of the Moon, ``C/(M R^2) = 0.3932 +- 0.0002``
#: (``R = 1738 km``): A. S. Konopliv et al., "Improved gravity field of the Moon from
#: Lunar Prospector", Science 281 (1998) 1476-1480.
MOON_C_MR2 = 0.3932

#: Polar moment of inertia of the Moon, ``C = 0.3932 M R^2 = 8.725e34 kg m^2``
#: (``GM = 4902.80007 km^3/s^2``, Williams et al. 2014, ``G = 6.6743e-11``,
#: ``R = 1738 km``); only needed for physical units.
MOON_C = 8.725e34

#: Sidereal month in SI seconds, ``27.321661 days``: the Moon's orbital period relative
#: to the fixed stars and, in synchronous rotation, its rotation period (the IAU
#: rotation rate ``13.17635815 deg/day``, B. A. Archinal et al., Celest. Mech. Dyn.
#: Astron. 130 (2018) 22, gives ``27.3216617 days``).
MOON_SIDEREAL_MONTH = 27.321661 * 86400.0


def moon(C: float = 1.0) -> RigidBody:
    """The rigid Moon, a triaxial body: moments ``(A, B, C)`` from the libration parameters.

    ``beta = (C - A)/B = MOON_BETA`` and ``gamma = (B - A)/C = MOON_GAMMA`` from lunar
    laser ranging (J. G. Williams et al., J. Geophys. Res. Planets 119 (2014)
    1546-1578) fix the ratios: ``B = C (1 + gamma)/(1 + beta)``, ``A = B - gamma C``
    (``A/C = 0.999369``, ``B/C = 0.999597``). Body axis 1 (index 0), the smallest moment
    ``A``, points towards the Earth in the Moon's synchronous rotation; axis 2 (``B``)
    lies along the orbital velocity; axis 3 (``C``) is the spin axis, along the orbit
    normal. In the orbital (LVLH) frame of the Moon's orbit the roll, pitch and yaw
    moments are ``(B, C, A)``: the Lagrange region of
    :func:`liebody.analysis.gravity_gradient_stability` with ``k1 = beta`` and
    ``k3 = (C - B)/A``. Its free librations follow from that linear theory: in longitude
    (pitch) at ``sqrt(3 gamma)`` times the orbital rate, a period of 1045 days on a
    circular orbit of one :data:`MOON_SIDEREAL_MONTH` (1056 days observed: N. Rambaux &
    J. G. Williams, Celest. Mech. Dyn. Astron. 109 (2011) 85-100), and the wobble (the
    slow roll-yaw mode) at about 74 years (74.6 years observed).

    Parameters
    ----------
    C : float, default 1.0
        Polar moment. The default normalises ``C = 1``; pass :data:`MOON_C`
        (``8.725e34 kg m^2``) for SI units, or :data:`MOON_C_MR2` for moments in units
        of ``M R^2``.

    Returns
    -------
    RigidBody
    """
    C = as_positive_float("C", C)
    B = C * (1.0 + MOON_GAMMA) / (1.0 + MOON_BETA)
    A = B - MOON_GAMMA * C
    return RigidBody([A, B, C])


def moon_spin() -> float:
    """The Moon's (synchronous) spin rate ``2 pi / MOON_SIDEREAL_MONTH = 2.661699e-6``
    rad/s, equal to its mean orbital motion."""
    return 2.0 * math.pi / MOON_SIDEREAL_MONTH


def hlw() -> RigidBody:
    """The Hairer–Lubich–Wanner test body ``I = (2, 1, 2/3)``.

    The free-rigid-body test problem of E. Hairer, C. Lubich & G. Wanner, *Geometric
    Numerical Integration*, 2nd ed. (Springer, 2006).

    Its moments violate the triangle inequality (``1 + 2/3 < 2``), so it is built with
    ``check_triangle=False``; the standard initial momentum is
    ``L0 = (cos 1.1, 0, sin 1.1)``.
    """
    return RigidBody([2.0, 1.0, 2.0 / 3.0], check_triangle=False)


def book(mass: float = 1.0, a: float = 0.24, b: float = 0.17, c: float = 0.03) -> RigidBody:
    """A uniform book-shaped box (edges ``a > b > c`` along body x, y, z), asymmetric.

    Moments ``M (b^2 + c^2)/12 < M (a^2 + c^2)/12 < M (a^2 + b^2)/12``
    (:func:`liebody.inertia.box`): spun about its middle axis ``y`` (index 1) it shows
    the instability of rotation about the intermediate axis (Hand & Finch, *Analytical
    Mechanics*, ch. 8, stability of rotation about the principal axes; tennis racket /
    Dzhanibekov effect); about ``x`` or ``z`` it is stable.

    Parameters
    ----------
    mass : float
        Mass in kg (> 0).
    a, b, c : float
        Edge lengths in m (> 0), default a 24 x 17 x 3 cm paperback.
    """
    from liebody import inertia

    return RigidBody(inertia.box(mass, a, b, c), mass=mass)
