"""
The Chandler wobble of a rigid Earth
====================================

A symmetric top spinning about an axis slightly off its figure axis does not keep that
axis: seen from the body, the rotation axis turns about the figure axis at the rate
``Omega = omega3 (C - A) / A`` (Hand & Finch, *Analytical Mechanics*, ch. 8, the
force-free symmetric top). For the Earth, with a dynamical flattening
``H = (C - A) / C = 0.00327``, Euler predicted a free wobble of ``A / (C - A) = 304.5``
sidereal days. Chandler found one in 1891, but with a period of about 433 days: the
Earth is not rigid (its elastic mantle, oceans and core lengthen the period). Here the
rigid-Earth wobble is integrated, measured and compared with the formula.
"""

# %%
# The rigid Earth, spinning 1e-6 rad off its figure axis
# ------------------------------------------------------
#
# :func:`liebody.bodies.earth` is the rigid Earth (moments scaled so that ``C = 1``) and
# :func:`liebody.bodies.earth_spin` its rotation rate. A free symmetric body's default
# method is its exact flow, evaluated once a day for three wobble periods.

import matplotlib.pyplot as plt
import numpy as np

import liebody
from liebody import analysis, bodies, quaternion

earth = bodies.earth()
day = bodies.SIDEREAL_DAY
spin = bodies.earth_spin()
offset = 1e-6  # rad between the rotation axis and the figure axis: about 6 m at the pole
omega0 = spin * np.array([np.sin(offset), 0.0, np.cos(offset)])

predicted = analysis.chandler_period(earth)  # in sidereal days
n_days = round(3 * predicted)
traj = liebody.integrate(liebody.FreeBody(earth), omega0=omega0, dt=day, steps=n_days)
measured = analysis.wobble_period(traj) / day
print(f"Euler's period A/(C - A): {predicted:.6f} sidereal days")
print(f"measured from the run:    {measured:.6f} sidereal days")
np.testing.assert_allclose(measured, predicted, rtol=1e-9)

# %%
# The pole's path in the body frame
# ---------------------------------
#
# The direction of the rotation axis, seen from the Earth, in milliarcseconds: a circle
# of radius 206 mas (1e-6 rad) traced once every 304.5 days. The closed form
# ``omega_1 + i omega_2 = omega_perp exp(i Omega t)`` is drawn under the samples.

mas = 180 / np.pi * 3600e3  # milliarcseconds per radian
polar = traj.omega[:, :2] / spin * mas
Omega = analysis.precession_rate(earth.moments[0], earth.moments[2], omega0[2])
closed = omega0[0] / spin * mas * np.exp(1j * Omega * traj.t)
np.testing.assert_allclose(polar[:, 0] + 1j * polar[:, 1], closed, atol=1e-9 * mas)

fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 4.2))
ax1.plot(closed.real, closed.imag, color="0.8", lw=6, label="closed form")
ax1.plot(polar[:, 0], polar[:, 1], ".", ms=2, label="liebody, daily samples")
ax1.set_aspect("equal")
ax1.set_xlabel("x [mas]")
ax1.set_ylabel("y [mas]")
ax1.set_title("rotation pole seen from the body")
ax1.legend(loc="lower left", fontsize=8)

t_days = traj.t / day
ax2.plot(t_days, polar[:, 0], label="x")
ax2.plot(t_days, polar[:, 1], label="y")
ax2.set_xlabel("time [sidereal days]")
ax2.set_ylabel("pole offset [mas]")
ax2.set_title(f"period {measured:.2f} days (rigid); observed about 433")
ax2.legend()
fig.tight_layout()

# %%
# The invariants of the run
# -------------------------
#
# The exact flow keeps the energy and the spatial angular momentum to round-off; from
# space, the figure axis and the rotation axis precess about the fixed ``L`` about once
# a day, on cones of half-angles ``(1 - H)`` times the offset and ``H`` times the offset
# (:func:`liebody.analysis.cone_angles`); the run's angles to ``L`` are those.

E = traj.energy
Ls = traj.L_space
print(f"relative energy change: {np.ptp(E) / E[0]:.1e}")
print(f"spatial L change:       {np.ptp(Ls, axis=0).max() / np.linalg.norm(Ls[0]):.1e}")
assert np.ptp(E) / E[0] < 1e-14
assert np.ptp(Ls, axis=0).max() / np.linalg.norm(Ls[0]) < 1e-14
cones = analysis.cone_angles(earth.moments[0], earth.moments[2],
                             spin * np.sin(offset), spin * np.cos(offset))
H = (earth.moments[2] - earth.moments[0]) / earth.moments[2]
L_hat = Ls / np.linalg.norm(Ls, axis=1, keepdims=True)
figure_axis = quaternion.rotate(traj.q, [0.0, 0.0, 1.0])
rotation_axis = traj.omega_space / np.linalg.norm(traj.omega_space, axis=1, keepdims=True)
to_L = {name: np.arcsin(np.linalg.norm(np.cross(v, L_hat), axis=1))  # small angles
        for name, v in (("figure", figure_axis), ("rotation", rotation_axis))}
print(f"figure axis to L:   {to_L['figure'].max():.6e} rad; (1 - H) offset "
      f"{(1 - H) * offset:.6e}; cone_angles {cones.theta:.6e}")
print(f"rotation axis to L: {to_L['rotation'].max():.6e} rad; H offset "
      f"{H * offset:.6e}; cone_angles {cones.space_cone:.6e}")
np.testing.assert_allclose(to_L["figure"], cones.theta, rtol=1e-9)
np.testing.assert_allclose(to_L["rotation"], cones.space_cone, rtol=1e-9)
np.testing.assert_allclose([cones.theta, cones.space_cone], [(1 - H) * offset, H * offset],
                           rtol=1e-6)
