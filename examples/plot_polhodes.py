"""
Polhodes on the angular-momentum sphere
=======================================

A free rigid body keeps two quantities: the length of its angular momentum, ``|L|``,
and its kinetic energy ``T = sum L_i^2 / (2 I_i)``. Seen from the body, ``L`` therefore
moves on the intersection of a sphere and an ellipsoid: the polhodes (Hand & Finch,
*Analytical Mechanics*, ch. 8; Landau & Lifshitz, *Mechanics*, §37). About the axes of
smallest and largest moment they are small closed loops: rotation there is stable.
Through the intermediate axis pass the two separatrices, at ``T = |L|^2 / (2 I_2)``:
rotation there is unstable.
"""

# %%
# A family of orbits, integrated
# ------------------------------
#
# Initial momenta on the unit sphere, from near the smallest axis to near the largest,
# all integrated in one ensemble call (a leading body axis on ``L0``) with the exact
# flow. Each orbit is coloured by its energy.

import matplotlib.pyplot as plt
import numpy as np

import liebody

moments = np.array([1.0, 2.0, 3.0])
body = liebody.RigidBody(moments)
angles = np.linspace(0.08, np.pi / 2 - 0.08, 7)
L0 = np.concatenate([
    np.stack([np.cos(angles), np.zeros_like(angles), np.sin(angles)], axis=1),   # x-z plane
    np.stack([np.zeros_like(angles), np.cos(angles), np.sin(angles)], axis=1),   # y-z plane
    [[np.sqrt(1 - 0.05**2), 0.05, 0.0], [0.05, np.sqrt(1 - 0.05**2), 0.0]],
])
traj = liebody.integrate(liebody.FreeBody(body), L0=L0, dt=0.02, steps=1500)
energy = traj.kinetic_energy  # (bodies, samples)

# each orbit stays on the sphere and on its energy ellipsoid, to round-off
np.testing.assert_allclose(np.linalg.norm(traj.L, axis=-1), 1.0, atol=1e-14)
np.testing.assert_allclose(energy, np.broadcast_to(energy[:, :1], energy.shape), rtol=1e-13)
separatrix = 1.0 / (2 * moments[1])
print(f"separatrix energy |L|^2/(2 I2) = {separatrix:.6f}")
print("orbit energies:", np.round(energy[:, 0], 4))

# the last two orbits start 0.05 off axis 1 and off axis 2. The first is a small closed
# loop about axis 1 whose L3 reaches the sphere and ellipsoid's intersection at L2 = 0,
# L3^2 = (1/I1 - 2T) / (1/I1 - 1/I3); the second runs along the separatrix to the
# opposite side of the sphere
near_1, near_2 = traj.L[-2], traj.L[-1]
T1 = energy[-2, 0]
L3_max = np.sqrt((1 / moments[0] - 2 * T1) / (1 / moments[0] - 1 / moments[2]))
print(f"off axis 1: largest L3 {np.abs(near_1[:, 2]).max():.6f}, closed form {L3_max:.6f}; "
      f"off axis 2: L2 from {near_2[0, 1]:.3f} down to {near_2[:, 1].min():.3f}")
np.testing.assert_allclose(np.abs(near_1[:, 2]).max(), L3_max, rtol=1e-4)
assert near_1[:, 0].min() > np.cos(0.1) and near_2[:, 1].min() < -0.9

# %%
# The sphere, the separatrices and the polhodes
# ---------------------------------------------
#
# The separatrices are drawn from their closed form: on ``|L| = 1`` with
# ``T = 1/(2 I2)``, ``L_1^2 (1/I1 - 1/I2) = L_3^2 (1/I2 - 1/I3)``, two great circles
# through the intermediate axis.

fig = plt.figure(figsize=(7.5, 7))
ax = fig.add_subplot(projection="3d")
u, v = np.mgrid[0:2 * np.pi:40j, 0:np.pi:20j]
ax.plot_surface(np.cos(u) * np.sin(v), np.sin(u) * np.sin(v), np.cos(v), color="0.92",
                alpha=0.35, linewidth=0)
cmap = plt.get_cmap("viridis")
norm = plt.Normalize(1 / (2 * moments[2]), 1 / (2 * moments[0]))
for i in range(len(L0)):
    for sign in (1, -1):  # each orbit and its mirror image through the origin
        x, y, z = sign * traj.L[i].T
        ax.plot(x, y, z, color=cmap(norm(energy[i, 0])), lw=1.4)
slope = np.sqrt((1 / moments[0] - 1 / moments[1]) / (1 / moments[1] - 1 / moments[2]))
s = np.linspace(0, 2 * np.pi, 400)
for sgn in (1, -1):
    a = np.array([1.0, 0.0, sgn * slope]) / np.hypot(1.0, slope)  # L3 = +- slope L1
    ax.plot(a[0] * np.cos(s), np.sin(s), a[2] * np.cos(s), "k--", lw=1)
ax.set_xlabel("$L_1$ (smallest $I$)")
ax.set_ylabel("$L_2$ (intermediate)")
ax.set_zlabel("$L_3$ (largest $I$)")
ax.set_box_aspect((1, 1, 1))
ax.set_title("polhodes on $|L| = 1$, $I = (1, 2, 3)$; dashed: separatrices")
fig.colorbar(plt.cm.ScalarMappable(norm=norm, cmap=cmap), ax=ax, shrink=0.6,
             label="kinetic energy $T$")

# the separatrix circles lie on the sphere and on the separatrix energy
on_circle = np.stack([np.cos(s), np.sin(s), slope * np.cos(s)], axis=1)
on_circle /= np.linalg.norm(on_circle, axis=1, keepdims=True)
np.testing.assert_allclose(0.5 * np.sum(on_circle**2 / moments, axis=1), separatrix,
                           rtol=1e-14)

# %%
# The energy ellipsoid of one orbit
# ---------------------------------
#
# The same picture the other way round: the orbit closest to the intermediate axis and
# the ellipsoid ``sum L_i^2 / I_i = 2T`` it lies on, which touches the sphere's
# separatrix.

i = len(L0) - 1
T = energy[i, 0]
fig = plt.figure(figsize=(7, 6))
ax = fig.add_subplot(projection="3d")
ax.plot_surface(*(np.sqrt(2 * T * moments)[:, None, None]
                  * np.array([np.cos(u) * np.sin(v), np.sin(u) * np.sin(v), np.cos(v)])),
                color="tab:orange", alpha=0.25, linewidth=0)
ax.plot_surface(np.cos(u) * np.sin(v), np.sin(u) * np.sin(v), np.cos(v), color="0.8",
                alpha=0.25, linewidth=0)
ax.plot(*traj.L[i].T, color="k", lw=2)
ax.plot(*(-traj.L[i]).T, color="k", lw=2)
ax.set_box_aspect((1, 1, 1))
ax.set_title(f"sphere $|L| = 1$ and energy ellipsoid $T = {T:.4f}$")
plt.show()
