"""
The heavy top's apex: loops, cusps and waves
============================================

A heavy symmetric top nutates: its tilt ``theta`` swings between two turning points of
the effective potential while the axis precesses about the vertical (Hand & Finch,
*Analytical Mechanics*, ch. 8, the heavy symmetric top). Whether the precession rate
``phidot = (p_phi - p_psi cos theta) / (I1 sin^2 theta)`` changes sign between the
turning points decides the curve the apex draws on the sphere: **loops** when it does,
**cusps** when it vanishes at the upper turning point (a top released from rest), and
**waves** when it never does. Three tops, the same but for their initial precession
rate, integrated with ``splitting2`` and checked against the analysis of
:mod:`liebody.lagrange_top` (the turning points and the nutation period).
"""

# %%
# One top, three starts
# ---------------------
#
# ``I1 = I2 = 1``, ``I3 = 0.4`` about the pivot, ``M g l = 9.81``, spin 15 rad/s, tilt
# 0.8 rad, ``thetadot = 0``, and ``phidot = -1.5``, ``0`` or ``0.8`` rad/s.

import matplotlib.pyplot as plt
import numpy as np

import liebody
from liebody import analysis, quaternion
from liebody import lagrange_top as lt

top = liebody.HeavyTop(liebody.RigidBody([1.0, 1.0, 0.4]), mass=1.0, cm=[0.0, 0.0, 1.0],
                       g=9.81)
model = lt.LagrangeTop.from_heavy_top(top)
starts = {"loops": -1.5, "cusps": 0.0, "waves": 0.8}
theta0, spin = 0.8, 15.0

runs = {}
for name, phidot in starts.items():
    angles, rates = [0.0, theta0, 0.0], [phidot, 0.0, spin]
    motion = model.motion(angles, rates)
    kind = motion.motion_kind()
    expected = {"loops": "loops", "cusps": "cusps", "waves": "monotone"}[name]
    assert kind == expected, (name, kind)
    q0, L0 = model.state_from_euler(angles, rates)
    traj = liebody.integrate(top, q0=q0, L0=L0, dt=1e-3, t_end=4.0, method="splitting2")
    band = motion.turning_points()
    theta = traj.euler_angles()[:, 1]
    print(f"{name:6s}: theta in [{theta.min():.6f}, {theta.max():.6f}], turning points "
          f"[{band.theta1:.6f}, {band.theta2:.6f}], nutation period "
          f"{motion.nutation_period():.4f} s")
    # the integrated tilt stays in the analytic band; its extremes reach it (to dt^2)
    assert band.theta1 - 1e-6 < theta.min() < band.theta1 + 1e-4
    assert band.theta2 - 1e-4 < theta.max() < band.theta2 + 1e-6
    assert np.ptp(traj.energy) / abs(traj.energy[0]) < 1e-5  # bounded: the splitting
    # the tilt crosses the middle of its band twice a nutation period: every other
    # crossing is one period of the analysis apart
    crossings = analysis.zero_crossings(traj.t, theta - 0.5 * (band.theta1 + band.theta2))
    np.testing.assert_allclose(crossings[2:] - crossings[:-2], motion.nutation_period(),
                               rtol=1e-4)
    runs[name] = traj

# %%
# The apex on the unit sphere
# ---------------------------
#
# The symmetry axis ``R(q) e_3`` in space, seen from above (the pivot at the centre)
# and in ``(phi, theta)``.

fig = plt.figure(figsize=(11, 4))
for i, (name, traj) in enumerate(runs.items()):
    apex = quaternion.rotate(traj.q, [0.0, 0.0, 1.0])
    ax = fig.add_subplot(1, 3, i + 1, projection="3d")
    u, v = np.mgrid[0:2 * np.pi:30j, 0:0.65 * np.pi:12j]
    ax.plot_wireframe(np.cos(u) * np.sin(v), np.sin(u) * np.sin(v), np.cos(v), color="0.85",
                      lw=0.4)
    ax.plot(*apex.T, lw=1.2, color="tab:blue")
    ax.view_init(elev=55, azim=-60)
    ax.set_box_aspect((1, 1, 0.6))
    ax.set_axis_off()
    ax.set_title(f"{name} ($\\dot\\phi_0$ = {starts[name]})")
fig.suptitle("apex of a heavy symmetric top: three kinds of nutation")

fig2, ax2 = plt.subplots(figsize=(8, 3.6))
for name, traj in runs.items():
    phi, theta, _ = traj.euler_angles(unwrap=True).T
    ax2.plot(phi, theta, label=name)
ax2.invert_yaxis()
ax2.set_xlabel(r"precession angle $\phi$ [rad]")
ax2.set_ylabel(r"tilt $\theta$ [rad]")
ax2.set_title(r"the apex in $(\phi, \theta)$; the upper turning point is $\theta_0 = 0.8$")
ax2.legend()
fig2.tight_layout()
plt.show()
