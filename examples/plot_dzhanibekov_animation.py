"""
The Dzhanibekov flip of a tumbling T-handle (animation)
=======================================================

In 1985 the cosmonaut Vladimir Dzhanibekov watched a wing nut spin off its bolt on the
Salyut 7 station and turn over, half a turn, every few seconds, while keeping its spin.
A rigid body spun about its intermediate principal axis does that: the rotation is
unstable (Hand & Finch, *Analytical Mechanics*, ch. 8), and the angular momentum, seen
from the body, runs along a separatrix to the opposite side and back, with the period of
Landau & Lifshitz's elliptic-integral formula (*Mechanics*, §37). Here a T-handle is
spun about its intermediate axis, animated, and its flips timed against the formula.
"""

# %%
# A T-handle of point masses
# --------------------------
#
# A crossbar of two 0.1 kg masses at ``x = +-4 cm`` and a 0.15 kg mass at the end of a
# 5 cm stem along ``z``. About the centre of mass the tensor is diagonal in these axes,
# so the body frame is the drawing frame; the stem axis ``z`` has the intermediate
# moment.

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.animation import FuncAnimation

import liebody
from liebody import analysis, quaternion

masses = np.array([0.1, 0.1, 0.15])
points = np.array([[0.04, 0.0, 0.0], [-0.04, 0.0, 0.0], [0.0, 0.0, 0.05]])
points -= masses @ points / masses.sum()  # about the centre of mass
tensor = sum(m * (p @ p * np.eye(3) - np.outer(p, p)) for m, p in zip(masses, points,
                                                                         strict=True))
moments = np.diag(tensor).copy()
print("moments [kg m^2]:", moments, "(intermediate: z, the stem)")
assert np.allclose(tensor, np.diag(moments)) and moments[0] < moments[2] < moments[1]
body = liebody.RigidBody(moments)

# %%
# Spun about the intermediate axis
# --------------------------------
#
# 6 turns per second about the stem with a 1e-3 rad wobble; the exact flow, 2 ms samples.

spin = 2 * np.pi * 6.0
omega0 = spin * np.array([1e-3, 1e-3, 1.0])
traj = liebody.integrate(liebody.FreeBody(body), omega0=omega0, dt=0.002, t_end=8.0)
L = traj.L
crossings = analysis.zero_crossings(traj.t, L[:, 2])
period = analysis.flip_period(moments, L[0])
measured = np.diff(crossings)
print(f"flips every {measured.mean():.6f} s; Landau & Lifshitz T_m / 2 = {period / 2:.6f} s")
np.testing.assert_allclose(measured, period / 2, rtol=1e-6)

fig, ax = plt.subplots(figsize=(8, 3.5))
for k, name in enumerate(("$L_x$ (smallest)", "$L_y$ (largest)",
                          "$L_z$ (intermediate: the spin)")):
    ax.plot(traj.t, L[:, k] / np.linalg.norm(L[0]), label=name)
ax.set_xlabel("time [s]")
ax.set_ylabel("$L / |L|$ in the body frame")
ax.set_title(f"the spin reverses every {period / 2:.3f} s")
ax.legend(loc="lower right", fontsize=8)
fig.tight_layout()

# %%
# The animation
# -------------
#
# The handle drawn in space, ``r_space = R(q) r_body``, over its first two flips (every
# 6th sample): the stem turns over while the handle keeps spinning. Its spatial angular
# momentum (the arrow) stays fixed.

bar_line = points[:2]
stem_line = np.array([[0.0, 0.0, points[0, 2]], points[2]])  # from the bar to the tip
L_dir = traj.L_space[0] / np.linalg.norm(traj.L_space[0]) * 0.06

fig3 = plt.figure(figsize=(5, 5))
ax3 = fig3.add_subplot(projection="3d")
ax3.set_xlim(-0.06, 0.06)
ax3.set_ylim(-0.06, 0.06)
ax3.set_zlim(-0.06, 0.06)
ax3.set_box_aspect((1, 1, 1))
ax3.set_axis_off()
ax3.quiver(0, 0, 0, *L_dir, color="tab:red")
(bar_artist,) = ax3.plot([], [], [], lw=5, color="tab:blue", solid_capstyle="round")
(stem_artist,) = ax3.plot([], [], [], lw=5, color="tab:orange", solid_capstyle="round")
title = ax3.set_title("")
frames = np.arange(0, round(1.1 * period / 0.002), 6)


def draw(k):
    q = traj.q[k]
    b = quaternion.rotate(q, bar_line)
    s = quaternion.rotate(q, stem_line)
    bar_artist.set_data_3d(b[:, 0], b[:, 1], b[:, 2])
    stem_artist.set_data_3d(s[:, 0], s[:, 1], s[:, 2])
    title.set_text(f"t = {traj.t[k]:.2f} s")
    return bar_artist, stem_artist, title


ani = FuncAnimation(fig3, draw, frames=frames, interval=40, blit=False)
