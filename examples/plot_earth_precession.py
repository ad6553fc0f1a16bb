"""
Precession and nutation of the Earth's axis under the Sun and the Moon
======================================================================

The Earth is an oblate top tilted by ``epsilon = 23.44`` degrees to the ecliptic. The Sun
and the Moon pull harder on the near side of the equatorial bulge than on the far side;
the torque ``tau = 3 GM / r^5 (r x I r)`` of each (:class:`liebody.GravityGradient`)
tries to straighten the axis, and the spinning Earth answers by precessing: its axis
turns westward about the pole of the ecliptic, about 50.4 arcseconds a year, once in
25,800 years (the precession of the equinoxes). Averaged over the orbits, a body of
mean motion ``n`` forces the rate ``-(3/2) (GM / a^3) (1 - e^2)^(-3/2) H cos(epsilon) /
omega``, ``H = (C - A)/C`` the dynamical flattening and ``omega`` the spin (Goldstein,
Poole & Safko, *Classical Mechanics*, sect. 5.8;
:func:`liebody.analysis.forced_precession_rate`). The Moon's orbit is tilted by
``i = 5.145`` degrees to the ecliptic and its node regresses once in 18.6 years: averaged
over the node its share is smaller by ``1 - (3/2) sin^2 i``, and the turning node rocks
the axis, the nutation, whose largest term is an 18.6-year oscillation of about 9.2
arcseconds in obliquity.

Here the Sun and the Moon are where an ephemeris puts them: the positions come from
`pyerfa <https://pypi.org/project/pyerfa/>`_ (the ERFA library of the IAU SOFA
algorithms; not a dependency of liebody: ``pip install pyerfa``) and enter the integrator
as :class:`liebody.orbits.Table` orbits, sampled positions interpolated inside the
compiled kernels. A century of the rigid Earth's rotation, spinning once a sidereal day,
is integrated at a step of 0.02 day.
"""

# %%
# The Sun and the Moon from an ephemeris
# --------------------------------------
#
# Time in days from J2000.0 (TT), lengths in astronomical units. ``erfa.epv00`` gives
# the Earth's heliocentric position (the Sun seen from the Earth is its negative),
# ``erfa.moon98`` the Moon's geocentric position (Meeus's series, 6 km RMS against
# ELP/MPP02); both in the GCRS/ICRS axes, the mean equator and equinox of J2000.0 to
# within 23 mas. The tables are sampled every day (the Sun) and every quarter of a day
# (the Moon) from a day before J2000.0 to the end of the century (where ``epv00``'s range
# of validity, 1900-2100, ends); each reports the estimated error of its interpolant.

import time

import erfa
import matplotlib.pyplot as plt
import numpy as np

import liebody
from liebody import analysis, bodies, quaternion
from liebody.orbits import Table

J2000 = 2451545.0  # Julian date of J2000.0
YEAR = 365.25  # days (Julian)
CENTURY = 100 * YEAR
AU = 1.495978707e11  # m (IAU 2012)
DAY = 86400.0  # s
ARCSEC = np.degrees(1.0) * 3600.0

t_sun = np.arange(-1.0, CENTURY + 0.5, 1.0)
sun = Table(t_sun, -erfa.epv00(J2000, t_sun)[0]["p"])
t_moon = np.arange(-1.0, CENTURY + 0.125, 0.25)
moon = Table(t_moon, erfa.moon98(J2000, t_moon)["p"])
for name, table in (("Sun", sun), ("Moon", moon)):
    r_min = table.min_distance
    print(f"{name:4s}: {table.t.size:6d} samples, interpolation error <= "
          f"{table.error_estimate * AU / 1e3:.2g} km ({table.error_estimate / r_min:.1e} of "
          f"the distance)")

# %%
# The rigid Earth and its state at J2000.0
# ----------------------------------------
#
# :func:`liebody.bodies.earth`: the moments scaled so that ``C = 1``, ``H`` from the
# IERS Conventions. ``GM`` of the Sun (IAU 2015 nominal) and of the Moon (DE430) in au^3
# per day^2. The figure axis starts on the Celestial Intermediate Pole of J2000.0
# (``erfa.xy06``, IAU 2006/2000A precession-nutation) with the angular momentum along
# it, one turn per sidereal day.

earth = bodies.earth()
GM_SUN = 1.3271244e20 * DAY**2 / AU**3
GM_MOON = 4.9028e12 * DAY**2 / AU**3
spin = 2 * np.pi / (bodies.SIDEREAL_DAY / DAY)  # rad/day
scene = liebody.GravityGradient(earth, [(GM_SUN, sun), (GM_MOON, moon)])

X, Y = erfa.xy06(J2000, 0.0)
pole = np.array([X, Y, np.sqrt(1.0 - X * X - Y * Y)])
turn = np.cross([0.0, 0.0, 1.0], pole)  # z -> the pole, about z x pole
q0 = quaternion.exp(turn / np.linalg.norm(turn) * np.arcsin(np.linalg.norm(turn)))
L0 = [0.0, 0.0, earth.moments[2] * spin]

# %%
# A century at a step of 0.02 day
# -------------------------------
#
# 1.8 million steps of ``splitting2``: kick - exact free flow of the symmetric Earth -
# kick, the torque's kicks exact (it depends on the time and the orientation only). The
# spin turns the Earth by 0.13 rad a step, far from the resonance of a kick-drift-kick
# splitting at ``h omega = 2 pi``. The first call compiles; the second is timed (the
# figure depends on the machine).

dt = 0.02
steps = round(CENTURY / dt)
liebody.integrate(scene, q0=q0, L0=L0, dt=dt, steps=10, method="splitting2")
start = time.perf_counter()
traj = liebody.integrate(scene, q0=q0, L0=L0, dt=dt, steps=steps, method="splitting2",
                         save_every=250)
elapsed = time.perf_counter() - start
print(f"{steps:,} steps of 0.02 day (100 years) in {elapsed:.2f} s "
      f"({elapsed / steps * 1e9:.0f} ns a step)")

# %%
# Precession and nutation against the theory
# ------------------------------------------
#
# The figure axis in the frame of the J2000.0 ecliptic (turned by the obliquity
# ``eps0 = 84381.406"`` about the equinox), its longitude and its obliquity. A
# least-squares fit of a line and the 18.6-year term (the Moon's node,
# ``Omega = 125.04455501 deg - 1934.1362891 deg T``, T in Julian centuries; Simon et al.
# 1994) gives the precession rate and the nutation amplitudes. The theory: the sum of the
# Sun's and the Moon's forced rates, and for the nutation in obliquity the Moon's
# precession constant ``k`` times ``sin i cos i cos(eps)`` over the node's rate.

axis = quaternion.rotate(traj.q, [0.0, 0.0, 1.0])
eps0 = np.radians(84381.406 / 3600.0)
ce, se = np.cos(eps0), np.sin(eps0)
ecl = np.column_stack([axis[:, 0], ce * axis[:, 1] + se * axis[:, 2],
                       -se * axis[:, 1] + ce * axis[:, 2]])
longitude = np.unwrap(np.arctan2(ecl[:, 1], ecl[:, 0]))
obliquity = np.arccos(ecl[:, 2])
years = traj.t / YEAR
node = np.radians(125.04455501 - 1934.1362891 * traj.t / 36525.0)
node_rate = np.radians(1934.1362891) / 36525.0  # rad/day
design = np.column_stack([np.ones_like(years), years, np.cos(node), np.sin(node)])
fit_lon = np.linalg.lstsq(design, longitude, rcond=None)[0]
fit_obl = np.linalg.lstsq(design, obliquity, rcond=None)[0]
rate = fit_lon[1] * ARCSEC  # arcsec per year
nutation_obl = np.hypot(*fit_obl[2:]) * ARCSEC
nutation_lon = np.hypot(*fit_lon[2:]) * ARCSEC

a_moon, e_moon, i_moon = 384399e3 / AU, 0.0549, np.radians(5.145)
a_sun, e_sun = 1.00000261, 0.01671
rate_sun = analysis.forced_precession_rate(earth.moments, spin, GM_SUN, a_sun, eps0, e_sun)
rate_moon = (analysis.forced_precession_rate(earth.moments, spin, GM_MOON, a_moon, eps0,
                                             e_moon) * (1 - 1.5 * np.sin(i_moon) ** 2))
theory = (rate_sun + rate_moon) * YEAR * ARCSEC
k_moon = analysis.forced_precession_constant(earth.moments, spin, GM_MOON, a_moon, e_moon)
theory_obl = k_moon * np.sin(i_moon) * np.cos(i_moon) * np.cos(eps0) / node_rate * ARCSEC

print(f"precession:  {rate:+.3f} arcsec/yr; theory {theory:+.3f} "
      f"(Sun {rate_sun * YEAR * ARCSEC:+.2f}, Moon {rate_moon * YEAR * ARCSEC:+.2f}); "
      f"IAU 2006 luni-solar -50.385")
print(f"nutation in obliquity (18.6 yr): {nutation_obl:.3f} arcsec; theory "
      f"{theory_obl:.3f}; IAU 2000A (non-rigid Earth) 9.205")
print(f"nutation in longitude (18.6 yr): {nutation_lon:.3f} arcsec; IAU 2000A 17.206")
np.testing.assert_allclose(rate, theory, rtol=5e-4)
np.testing.assert_allclose(nutation_obl, theory_obl, rtol=5e-4)

# %%
# The rigid Earth against the IAU precession-nutation model
# ---------------------------------------------------------
#
# ``erfa.xy06`` gives the Celestial Intermediate Pole of the IAU 2006/2000A model, fitted
# to a century of observations of the real, non-rigid Earth. The integrated figure axis
# of the rigid Earth, driven by nothing but the two tables, stays within an arcsecond of
# it over the century.

X, Y = erfa.xy06(J2000, traj.t)
off = np.hypot(axis[:, 0] - X, axis[:, 1] - Y) * ARCSEC
print(f"largest distance from the IAU 2006/2000A pole over the century: {off.max():.2f} "
      f"arcsec")
assert off.max() < 1.0

fig, axes = plt.subplots(3, 1, figsize=(8, 9))
drift = (longitude - longitude[0]) * ARCSEC
axes[0].plot(years, drift, label="liebody")
axes[0].plot(years, theory * years, "--", label="averaged theory")
axes[0].set_ylabel("axis longitude [arcsec]")
axes[0].set_title("precession of the Earth's axis about the ecliptic pole")
axes[0].legend()
axes[1].plot(years, (longitude - design[:, :2] @ fit_lon[:2]) * ARCSEC, lw=0.6,
             label="longitude")
axes[1].plot(years, (obliquity - design[:, :2] @ fit_obl[:2]) * ARCSEC, lw=0.6,
             label="obliquity")
axes[1].set_ylabel("nutation [arcsec]")
axes[1].set_title("nutation: the 18.6-year term and the semi-annual and fortnightly ones")
axes[1].legend(fontsize=8)
axes[2].plot(years, off)
axes[2].set_xlabel("years from J2000.0")
axes[2].set_ylabel("distance [arcsec]")
axes[2].set_title("rigid Earth against the IAU 2006/2000A pole")
fig.tight_layout()
plt.show()
