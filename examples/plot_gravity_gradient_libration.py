"""
Gravity-gradient libration of a satellite
=========================================

A satellite in a circular orbit is pulled a little harder on its near side than on its
far side. The difference, the gravity-gradient torque ``N = 3 n^2 r x (I r)`` (``n`` the
orbital rate, ``r`` the unit vector from the Earth's centre, in the body frame), turns
the axis of smallest moment towards the Earth: a long boom hangs radially, as the Moon
keeps one face to the Earth. Displaced by a small pitch angle, the satellite librates
about that attitude at ``omega = n sqrt(3 (I2 - I1) / I3)`` (axis 1 radial, axis 3 along
the orbit normal). liebody's :class:`liebody.GravityGradient` scene gives this torque
for any number of point masses on :mod:`liebody.orbits` orbits; here it is also written
by hand as a user torque of time and orientation (:class:`liebody.TorqueBody`), the two
agree, and the libration frequency is measured against the linear theory.
"""

# %%
# The torque, compiled with numba
# -------------------------------
#
# A 90-minute circular orbit in the space ``x-y`` plane. ``torque(t, q, L)`` rotates the
# radial direction into the body frame (``R(q)^T r``) and returns ``3 n^2 r x (I r)``.

import matplotlib.pyplot as plt
import numba
import numpy as np

import liebody
from liebody import analysis, quaternion

n = 2 * np.pi / 5400.0  # orbital rate [rad/s]
moments = np.array([100.0, 400.0, 450.0])  # boom radial (1), pitch axis 3 [kg m^2]
I1, I2, I3 = moments


@numba.njit
def gravity_gradient(t, q, L):
    c, s = np.cos(n * t), np.sin(n * t)  # r = (c, s, 0) in space
    w, x, y, z = q[0], q[1], q[2], q[3]
    # r_body = R(q)^T r: the columns of R(q) dotted with r
    r1 = (1 - 2 * (y * y + z * z)) * c + 2 * (x * y + w * z) * s
    r2 = 2 * (x * y - w * z) * c + (1 - 2 * (x * x + z * z)) * s
    r3 = 2 * (x * z + w * y) * c + 2 * (y * z - w * x) * s
    a1, a2, a3 = I1 * r1, I2 * r2, I3 * r3
    k = 3 * n * n
    return np.array([k * (r2 * a3 - r3 * a2), k * (r3 * a1 - r1 * a3),
                     k * (r1 * a2 - r2 * a1)])


scene = liebody.TorqueBody(liebody.RigidBody(moments), gravity_gradient,
                           orientation_only=True)

# %%
# The same torque, built in
# -------------------------
#
# The Earth seen from the satellite runs on a circular orbit of radius 1 and mean motion
# ``n`` (``GM / r^3 = n^2``); the built-in model's torque is ``3 GM / r^5 (r x I r)``.

built_in = liebody.GravityGradient(liebody.RigidBody(moments),
                                   [(n**2, liebody.orbits.Circular(n))])

# %%
# Ten orbits from a 3-degree pitch offset
# ---------------------------------------
#
# The body starts turning with the orbit (``omega = n`` about the orbit normal) with its
# boom 3 degrees off the radial direction.

theta0 = np.radians(3.0)
q0 = quaternion.exp([0.0, 0.0, theta0])
traj = liebody.integrate(scene, q0=q0, omega0=[0.0, 0.0, n], dt=5.0, t_end=10 * 5400.0,
                         method="splitting2")
boom = quaternion.rotate(traj.q, [1.0, 0.0, 0.0])
pitch = np.unwrap(np.arctan2(boom[:, 1], boom[:, 0])) - n * traj.t  # from the radial

omega_lin = n * np.sqrt(3 * (I2 - I1) / I3)
crossings = analysis.zero_crossings(traj.t, pitch)
measured = 2 * np.pi / (2 * np.mean(np.diff(crossings)))
# the pendulum's finite-amplitude correction: omega ~ omega_lin (1 - (2 theta0)^2 / 16)
theory = omega_lin * (1 - (2 * theta0) ** 2 / 16)
print(f"linear theory n sqrt(3 (I2 - I1)/I3) = {omega_lin / n:.6f} n")
print(f"with the amplitude correction         = {theory / n:.6f} n")
print(f"measured                               = {measured / n:.6f} n")
np.testing.assert_allclose(measured, theory, rtol=2e-4)
assert np.abs(pitch).max() < 1.001 * theta0  # a libration, not a tumble
# the motion stays in the orbit plane: no roll or yaw
assert np.abs(boom[:, 2]).max() < 1e-12
# the built-in model gives the same motion (to round-off), and its Jacobi integral (the
# energy in the frame turning with the orbit) stays bounded
same = liebody.integrate(built_in, q0=q0, omega0=[0.0, 0.0, n], dt=5.0, t_end=10 * 5400.0,
                         method="splitting2")
np.testing.assert_allclose(same.q, traj.q, atol=1e-10)
jacobi = built_in.jacobi_integral(same)
print(f"Jacobi integral: relative spread {np.ptp(jacobi) / abs(jacobi[0]):.2e}")
assert np.ptp(jacobi) < 1e-6 * abs(jacobi[0])

# %%
# The libration
# -------------

fig, ax = plt.subplots(figsize=(8, 3.6))
orbits = traj.t / 5400.0
ax.plot(orbits, np.degrees(pitch), label="liebody, splitting2, dt = 5 s")
ax.plot(orbits, np.degrees(theta0 * np.cos(theory * traj.t)), "--", lw=1,
        label=r"$\theta_0 \cos(\omega t)$")
ax.set_xlabel("time [orbits]")
ax.set_ylabel("pitch [deg]")
ax.set_title(f"gravity-gradient libration at {measured / n:.4f} n "
             f"(theory {theory / n:.4f} n)")
ax.legend(loc="lower right", fontsize=8)
fig.tight_layout()
plt.show()
