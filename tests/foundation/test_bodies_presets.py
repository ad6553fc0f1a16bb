"""The planetary presets of liebody.bodies (Mars, the Moon) against their published sources.

* the moments reproduce the cited ratios: Mars's dynamical ellipticity
  ``H = J2 / (C/(M R^2))`` (A. S. Konopliv et al., Icarus 211 (2011) 401-428), the
  Moon's libration parameters ``beta``, ``gamma`` (J. G. Williams et al., J. Geophys.
  Res. Planets 119 (2014) 1546-1578);
* the Moon's ratios against the independent GRAIL gravity field (``J2``, ``C22``,
  Williams et al. 2014) and the Lunar Prospector moment of inertia (Konopliv et al.,
  Science 281 (1998) 1476);
* Mars's precession rate from liebody.analysis.forced_precession_rate against the
  measured rates (Folkner et al. 1997; Konopliv et al. 2011, 2016);
* the Moon's free librations from liebody.analysis.gravity_gradient_stability against
  the free modes found in the lunar ephemeris (N. Rambaux & J. G. Williams, Celest.
  Mech. Dyn. Astron. 109 (2011) 85-100), and an integrated libration in longitude.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import liebody
from liebody import analysis, bodies
from liebody import quaternion as Q
from liebody.orbits import Circular

YEAR = 365.25 * 86400.0  # Julian year [s]
MAS = math.degrees(1.0) * 3600e3  # milliarcseconds per radian


# ------------------------------------------------------------------------------------------
# the moments reproduce the cited ratios
# ------------------------------------------------------------------------------------------


def test_mars_is_a_symmetric_top_with_the_cited_flattening():
    I = bodies.mars().moments
    assert I[0] == I[1] < I[2] == 1.0
    # Konopliv et al. 2011: J2 = 1.9566e-3 (R = 3396 km), C/(M R^2) = 0.3644
    assert (I[2] - I[0]) / I[2] == pytest.approx(1.9566e-3 / 0.3644, rel=1e-12)
    assert (I[2] - I[0]) / I[2] == pytest.approx(0.00537, abs=1e-5)
    # scaled to SI units: only the scale changes
    np.testing.assert_allclose(bodies.mars(C=bodies.MARS_C).moments, bodies.MARS_C * I,
                               rtol=1e-15)
    # C = 0.3644 M R^2 with GM = 42828.376 km^3/s^2 (Konopliv et al. 2016), G = 6.6743e-11
    assert bodies.MARS_C == pytest.approx(0.3644 * 42828.376e9 / 6.6743e-11 * 3396e3**2,
                                          rel=1e-3)


def test_mars_rotation_period():
    # 350.891985307 deg/day (Konopliv et al. 2016): 24 h 37 min 22.66 s
    assert bodies.MARS_SIDEREAL_DAY / 3600 == pytest.approx(24.6229, abs=1e-4)
    assert bodies.MARS_SIDEREAL_DAY == pytest.approx(24 * 3600 + 37 * 60 + 22.663, abs=1e-3)
    assert bodies.mars_spin() == pytest.approx(math.radians(350.891985307) / 86400, rel=1e-12)


def test_moon_reproduces_the_lunar_laser_ranging_ratios():
    A, B, C = bodies.moon().moments
    assert A < B < C == 1.0
    # Williams et al. 2014: beta = 631.0213e-6, gamma = 227.7317e-6
    assert (C - A) / B == pytest.approx(631.0213e-6, rel=1e-9)
    assert (B - A) / C == pytest.approx(227.7317e-6, rel=1e-9)
    # the third ratio, alpha = (C - B)/A, follows: (beta - gamma)/(1 - beta gamma)
    assert (C - B) / A == pytest.approx((631.0213e-6 - 227.7317e-6)
                                        / (1 - 631.0213e-6 * 227.7317e-6), rel=1e-9)
    np.testing.assert_allclose(bodies.moon(C=2.5).moments, 2.5 * np.array([A, B, C]),
                               rtol=1e-15)


def test_moon_ratios_agree_with_the_grail_gravity_field():
    """LLR's beta and gamma (the rotation) against GRAIL's J2 and C22 (the gravity field),
    two independent measurements (Williams et al. 2014, J2 = 203.30517e-6 and
    C22 = 22.42635e-6 at R = 1738 km): ``J2 / C22 = 4 (C - (A+B)/2) / (B - A)`` depends
    on the moment ratios only, and with the Lunar Prospector ``C/(M R^2) = 0.3932``
    (Konopliv et al. 1998) the moments give ``C22 = (B - A) / (4 M R^2)``. Both agree to
    0.2 % (the fluid core and the permanent tide in J2 make the rest)."""
    A, B, C = bodies.moon(C=bodies.MOON_C_MR2).moments  # in units of M R^2
    J2 = C - 0.5 * (A + B)
    C22 = 0.25 * (B - A)
    assert J2 / C22 == pytest.approx(203.30517 / 22.42635, rel=3e-3)
    assert C22 == pytest.approx(22.42635e-6, rel=3e-3)
    assert J2 == pytest.approx(203.30517e-6, rel=3e-3)
    # and in SI units: C = 0.3932 M R^2, GM = 4902.80007 km^3/s^2, G = 6.6743e-11
    assert bodies.MOON_C == pytest.approx(0.3932 * 4902.80007e9 / 6.6743e-11 * 1738e3**2,
                                          rel=1e-3)


def test_moon_rotation_is_synchronous():
    assert bodies.MOON_SIDEREAL_MONTH / 86400 == pytest.approx(27.321661, abs=1e-9)
    # the IAU rotation rate 13.17635815 deg/day (Archinal et al. 2018)
    assert bodies.moon_spin() == pytest.approx(math.radians(13.17635815) / 86400, rel=1e-7)


# ------------------------------------------------------------------------------------------
# Mars: the precession of the spin axis under the Sun
# ------------------------------------------------------------------------------------------


def test_mars_precession_rate_against_the_measured_rates():
    """The Sun's torque on the rigid Mars precesses its axis at ``-k cos(eps)``
    (analysis.forced_precession_rate). With the mean motion n0 = 191.408 deg/yr,
    e = 0.09341 (Konopliv et al. 2011) and the obliquity 25.1893823 deg (Konopliv et al.
    2016), plus the geodetic (relativistic) precession +6.7 mas/yr and the planets'
    -0.2 mas/yr (Konopliv et al. 2011), the rate is the measured one: -7594 +- 10 mas/yr
    (Konopliv et al. 2011, whose C/(M R^2) the preset uses), within 0.3 % of
    -7608.3 +- 2.1 (Konopliv et al. 2016) and -7576 +- 35 (Folkner et al. 1997)."""
    n0 = math.radians(191.408) / YEAR  # rad/s
    GM_sun = 1.32712440041e20  # m^3/s^2
    a = (GM_sun / n0**2) ** (1 / 3)  # the Sun at Mars's distance, GM/a^3 = n0^2
    eps, e = math.radians(25.1893823), 0.09341
    solar = analysis.forced_precession_rate(bodies.mars().moments, bodies.mars_spin(), GM_sun,
                                            a, eps, e) * YEAR * MAS
    rate = solar + 6.7 - 0.2
    assert rate < 0  # retrograde
    assert rate == pytest.approx(-7594.0, abs=2 * 10.0)
    assert rate == pytest.approx(-7608.3, rel=3e-3)
    assert rate == pytest.approx(-7576.0, rel=3e-3)
    # the precession constant k (the rate at zero obliquity): about 8.4 arcsec/yr,
    # a period of 2 pi / (k cos eps) = 171,000 years
    k = analysis.forced_precession_constant(bodies.mars().moments, bodies.mars_spin(),
                                            GM_sun, a, e)
    assert k * math.cos(eps) == pytest.approx(-solar / YEAR / MAS, rel=1e-12)
    assert 2 * math.pi / (k * math.cos(eps)) / YEAR == pytest.approx(1.71e5, rel=0.01)


def test_mars_free_wobble_period():
    # the rigid Euler period (1 - H)/H sidereal days (190 solar days); the observed
    # Chandler wobble of Mars is longer (elastic yielding): the rigid value only here
    assert analysis.chandler_period(bodies.mars()) == pytest.approx(
        (1 - 1.9566e-3 / 0.3644) / (1.9566e-3 / 0.3644), rel=1e-12)
    assert 185 < analysis.chandler_period(bodies.mars()) < 186


# ------------------------------------------------------------------------------------------
# the Moon: free librations
# ------------------------------------------------------------------------------------------


def _moon_in_the_orbital_frame():
    """The Moon's moments along the roll (orbital velocity, B), pitch (orbit normal, C)
    and yaw (towards the Earth, A) axes of its synchronous rotation."""
    A, B, C = bodies.moon().moments
    return np.array([B, C, A])


def test_moon_free_librations_against_the_lunar_ephemeris():
    """The linear gravity-gradient theory of a rigid Moon on a circular orbit
    (analysis.gravity_gradient_stability): the free libration in longitude at
    ``n sqrt(3 gamma)`` and the slow roll-yaw mode, the wobble. Rambaux & Williams
    (2011) find in the ephemeris DE421 the periods 1056.13 days (longitude) and
    27257.27 days (74.63 years, wobble); the rigid circular model gives them to about
    1 % (the orbit's eccentricity, e = 0.055, and the solar perturbations make the
    rest)."""
    month = bodies.MOON_SIDEREAL_MONTH / 86400  # days
    g = analysis.gravity_gradient_stability(_moon_in_the_orbital_frame())
    assert g.region == "Lagrange"
    assert g.k1 == pytest.approx(bodies.MOON_BETA, rel=1e-9)
    assert g.pitch_frequency == pytest.approx(math.sqrt(3 * bodies.MOON_GAMMA), rel=1e-6)
    longitude = month / g.pitch_frequency
    wobble = month / g.roll_yaw_frequencies[0]
    assert longitude == pytest.approx(1056.13, rel=0.015)
    assert wobble == pytest.approx(27257.27, rel=0.015)
    assert 1040 < longitude < 1050 and 74.0 < wobble / 365.25 < 74.5


def test_moon_libration_in_longitude_integrated():
    """The preset in a GravityGradient scene: the Moon resting in its orbital frame (n = 1)
    with a 0.01 rad libration in longitude librates at sqrt(3 gamma) n to 1e-4."""
    moments = bodies.moon().moments
    orbit = Circular(1.0)  # the Earth seen from the Moon
    scene = liebody.GravityGradient(liebody.RigidBody(moments), [(1.0, orbit)])
    theta0 = 0.01
    # axis 1 (A) towards the Earth at t = 0 (the Earth is at +x), turned by theta0
    q0 = Q.exp([0.0, 0.0, theta0])
    freq = math.sqrt(3 * bodies.MOON_GAMMA)
    period = 2 * math.pi / freq
    tr = liebody.integrate(scene, q0=q0, omega0=[0.0, 0.0, 1.0], dt=0.1,
                           t_end=0.1 * round(1.6 * period / 0.1), method="splitting2")
    axis = Q.rotate(tr.q, [1.0, 0.0, 0.0])
    angle = np.unwrap(np.arctan2(axis[:, 1], axis[:, 0])) - tr.t  # from the Earth
    crossings = analysis.zero_crossings(tr.t, angle)
    measured = math.pi / np.mean(np.diff(crossings))
    assert measured == pytest.approx(freq, rel=1e-4)
    assert np.abs(angle).max() == pytest.approx(theta0, rel=1e-3)
