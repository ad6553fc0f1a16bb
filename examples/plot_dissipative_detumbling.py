"""
Detumbling by internal dissipation: Explorer 1
==============================================

Explorer 1, the first American satellite (1958), was a long thin cylinder spun about its
long axis, the axis of *smallest* moment. Rotation about that axis is stable for a rigid
body, but its four whip antennas flexed and dissipated energy. A body that loses energy
at constant angular momentum must end where the energy ``T = |L|^2 / (2 I)`` is least:
rotating about its axis of *largest* moment. Within hours Explorer 1 was tumbling end
over end, the first lesson of spacecraft attitude dynamics (Hand & Finch, *Analytical
Mechanics*, ch. 8, stability of rotation about the principal axes). Here the
dissipation is the double bracket of Bloch, Krishnaprasad, Marsden & Ratiu (1996),
:class:`liebody.DampedBody`, which keeps ``|L|`` and lowers the energy.
"""

# %%
# A long thin cylinder, spun about its long axis
# ----------------------------------------------
#
# 14 kg, 2.03 m long, 0.16 m across (the moments of :func:`liebody.inertia.solid_cylinder`),
# with the transverse moments split by 0.4 % (the antennas), spun at 750 rpm with a
# 0.01 rad wobble. The dissipation strength is exaggerated so that the flip takes a
# minute instead of hours.

import matplotlib.pyplot as plt
import numpy as np

import liebody
from liebody import inertia, quaternion

cylinder = inertia.solid_cylinder(14.0, 0.08, 2.03)
axial, transverse = cylinder[2], cylinder[0]  # principal moments, axis along z
moments = np.array([axial, 0.998 * transverse, 1.002 * transverse])
body = liebody.RigidBody(moments)
spin = 750 * 2 * np.pi / 60
omega0 = spin * np.array([1.0, 0.01, 0.0])
scene = liebody.DampedBody(body, eps=2e-3)
traj = liebody.integrate(scene, omega0=omega0, dt=2e-4, t_end=120.0, save_every=50)

L = np.linalg.norm(traj.L[0])
E = traj.kinetic_energy
E_start, E_end = L**2 / (2 * moments[0]), L**2 / (2 * moments[2])
print(f"moments: {moments.round(4)} kg m^2")
print(f"energy: {E[0]:.4f} J -> {E[-1]:.6f} J; |L|^2 / (2 I_max) = {E_end:.6f} J")

# |L| and the spatial L are kept to round-off; the energy never rises; the body ends
# on its largest-moment axis
np.testing.assert_allclose(np.linalg.norm(traj.L, axis=1), L, rtol=1e-12)
np.testing.assert_allclose(traj.L_space, np.broadcast_to(traj.L_space[0], traj.L.shape),
                           atol=1e-11 * L)
assert np.all(np.diff(E) <= 1e-12 * E[0])
np.testing.assert_allclose(E[-1], E_end, rtol=1e-6)

# %%
# Energy and the angle of the long axis to L
# ------------------------------------------

long_axis = quaternion.rotate(traj.q, [1.0, 0.0, 0.0])
L_hat = traj.L_space[0] / L
angle = np.degrees(np.arccos(np.clip(long_axis @ L_hat, -1, 1)))

fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
ax1.semilogy(traj.t, E, label="kinetic energy")
ax1.axhline(E_start, color="0.6", ls=":", label=r"$|L|^2/(2 I_{min})$: spin about the long axis")
ax1.axhline(E_end, color="0.3", ls="--", label=r"$|L|^2/(2 I_{max})$: flat spin")
ax1.set_ylabel("energy [J]")
ax1.legend(fontsize=8)
ax1.set_title("Explorer 1: energy lost at constant |L|")
ax2.plot(traj.t, angle)
ax2.set_xlabel("time [s] (dissipation exaggerated)")
ax2.set_ylabel("long axis to L [deg]")
ax2.set_ylim(0, 95)
fig.tight_layout()

# %%
# The angular momentum in the body frame
# --------------------------------------
#
# ``L`` leaves the axis of smallest moment, crosses the separatrix and settles on the
# axis of largest moment, spiralling over the sphere ``|L| = const``.

fig2 = plt.figure(figsize=(6, 6))
ax = fig2.add_subplot(projection="3d")
ax.plot(*(traj.L / L).T, lw=0.6)
ax.scatter(*(traj.L[0] / L), color="tab:green", label="start")
ax.scatter(*(traj.L[-1] / L), color="tab:red", label="end")
ax.set_xlabel("$L_1$ (long axis)")
ax.set_ylabel("$L_2$")
ax.set_zlabel("$L_3$ (largest $I$)")
ax.set_box_aspect((1, 1, 1))
ax.legend()
plt.show()
