"""
Precession of the Earth's axis under the Sun's torque
=====================================================

The Earth is an oblate top tilted by ``epsilon = 23.44`` degrees to its orbit. The Sun
pulls harder on the near side of the equatorial bulge than on the far side; the torque
``N = 3 n^2 r x (I r)`` (``n`` the orbital rate, ``r`` the unit vector to the Sun in
the body frame) tries to straighten the axis, and a spinning top answers by precessing:
the axis turns slowly westward about the normal of the orbit. Averaged over a year the
rate is ``(3 n^2 / (2 omega)) H cos(epsilon)``, with ``omega`` the spin and
``H = (C - A)/C`` the dynamical flattening (Hand & Finch, *Analytical Mechanics*,
ch. 8, the heavy symmetric top in the fast-top limit, with the Sun's orbit-averaged
torque). For the Sun alone that is about 15.9 arcseconds a year; the Moon adds about
twice as much, for the 50.3"/yr (a 25,800-year cycle) of the precession of the
equinoxes. Here the Sun's torque is a user torque of :class:`liebody.TorqueBody`, and
a century of the rigid Earth's rotation is integrated, a step per day.
"""

# %%
# The rigid Earth and the Sun's torque
# ------------------------------------
#
# Time in days, the Earth's moments scaled so that ``C = 1``
# (:func:`liebody.bodies.earth`, ``H`` from the IERS Conventions), the Sun on a circular
# orbit in the ``x-y`` plane (the ecliptic). The torque depends on time and orientation
# only; for a symmetric Earth it does not depend on the spin angle, and the spin itself
# is integrated exactly by the symmetric-body free flow. The step must still stay away
# from the spin period: a kick-drift-kick splitting resonates at ``h omega = 2 pi``
# (see the last section).

import matplotlib.pyplot as plt
import numba
import numpy as np

import liebody
from liebody import bodies, quaternion

earth = bodies.earth()
A, C = earth.moments[0], earth.moments[2]
H = (C - A) / C
year = 365.25  # days
n = 2 * np.pi / year  # the Sun's mean motion [rad/day]
spin = 2 * np.pi / (bodies.SIDEREAL_DAY / 86400.0)  # [rad/day]
epsilon = np.radians(23.44)


@numba.njit
def sun_torque(t, q, L):
    c, s = np.cos(n * t), np.sin(n * t)  # direction to the Sun in space: (c, s, 0)
    w, x, y, z = q[0], q[1], q[2], q[3]
    r1 = (1 - 2 * (y * y + z * z)) * c + 2 * (x * y + w * z) * s  # R(q)^T r
    r2 = 2 * (x * y - w * z) * c + (1 - 2 * (x * x + z * z)) * s
    r3 = 2 * (x * z + w * y) * c + 2 * (y * z - w * x) * s
    k = 3 * n * n
    return np.array([k * r2 * r3 * (C - A), k * r3 * r1 * (A - C), 0.0])  # r x (I r)


scene = liebody.TorqueBody(earth, sun_torque, orientation_only=True)

# %%
# A century, ten steps a day
# --------------------------

q0 = quaternion.exp([epsilon, 0.0, 0.0])  # the axis tilted by epsilon towards -y
traj = liebody.integrate(scene, q0=q0, omega0=[0.0, 0.0, spin], dt=0.1,
                         steps=int(100 * year / 0.1), method="splitting2", save_every=50)
axis = quaternion.rotate(traj.q, [0.0, 0.0, 1.0])
longitude = np.unwrap(np.arctan2(axis[:, 1], axis[:, 0]))
years = traj.t / year
rate = np.polyfit(years, longitude, 1)[0]  # rad per year
arcsec = np.degrees(1.0) * 3600
predicted = -1.5 * n**2 / spin * H * np.cos(epsilon) * year  # westward, rad per year
print(f"H = {H:.10f}")
print(f"measured precession:  {rate * arcsec:+.4f} arcsec/yr")
print(f"averaged theory:      {predicted * arcsec:+.4f} arcsec/yr "
      f"(a cycle of {2 * np.pi / abs(predicted):,.0f} years for the Sun alone)")
np.testing.assert_allclose(rate, predicted, rtol=5e-3)
tilt = np.degrees(np.arccos(axis[:, 2]))
print(f"obliquity stays within {tilt.min():.5f} .. {tilt.max():.5f} deg")
assert np.ptp(tilt) * 3600 < 1.2  # the solar semi-annual nutation, about 0.55" each way

# %%
# The axis's longitude and the semi-annual nutation
# -------------------------------------------------
#
# The Sun's torque vanishes at the equinoxes and peaks at the solstices: the precession
# advances in steps twice a year, the solar semi-annual nutation on top of the steady
# drift.

fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(8, 6))
drift = (longitude - longitude[0]) * arcsec
ax1.plot(years, drift, label="liebody")
ax1.plot(years, predicted * arcsec * years, "--", label="orbit-averaged theory")
ax1.set_xlabel("time [years]")
ax1.set_ylabel("axis longitude [arcsec]")
ax1.set_title("precession of the rigid Earth's axis under the Sun's torque")
ax1.legend()
first = years < 3
ax2.plot(years[first], (drift - predicted * arcsec * years)[first])
ax2.set_xlabel("time [years]")
ax2.set_ylabel("departure [arcsec]")
ax2.set_title("semi-annual nutation")
fig.tight_layout()

# %%
# A step of one day: the resonance
# --------------------------------
#
# With ``dt = 1`` day the step is within 0.3 % of the sidereal day: ``h omega`` is
# ``2 pi`` to three digits, where a kick-drift-kick splitting resonates (the stability
# benchmark finds the same on the heavy top). The precession rate is still right, but
# the obliquity shows a spurious oscillation twenty times the physical nutation.

coarse = liebody.integrate(scene, q0=q0, omega0=[0.0, 0.0, spin], dt=1.0, steps=3 * 365,
                           method="splitting2")
tilt_coarse = np.degrees(np.arccos(quaternion.rotate(coarse.q, [0.0, 0.0, 1.0])[:, 2]))
print(f"obliquity range, dt = 1 day:   {np.ptp(tilt_coarse) * 3600:.2f} arcsec")
print(f"obliquity range, dt = 0.1 day: {np.ptp(tilt[years < 3]) * 3600:.2f} arcsec")
assert np.ptp(tilt_coarse) > 5 * np.ptp(tilt[years < 3])

fig3, ax3 = plt.subplots(figsize=(8, 3.4))
ax3.plot(coarse.t / year, (tilt_coarse - 23.44) * 3600, label="dt = 1 day (h omega ~ 2 pi)")
ax3.plot(years[first], (tilt[first] - 23.44) * 3600, label="dt = 0.1 day")
ax3.set_xlabel("time [years]")
ax3.set_ylabel("obliquity - 23.44 deg [arcsec]")
ax3.legend(fontsize=8)
fig3.tight_layout()
plt.show()
