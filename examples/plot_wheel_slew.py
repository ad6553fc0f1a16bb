"""
A rest-to-rest slew with reaction wheels under quaternion feedback
==================================================================

A spacecraft turns by 60 degrees and stops, driven by four reaction wheels in a pyramid
(:class:`liebody.ReactionWheels`). The controller is the quaternion feedback regulator of
Wie, Weiss & Arapostathis ("Quaternion feedback regulator for spacecraft eigenaxis
rotations", J. Guidance 12 (1989) 375, eq. 10): the body should feel the torque
``-K e - C omega`` (``e`` the vector part of the error quaternion, ``K = k I``,
``C = c I``) plus a cancellation of the gyroscopic torque ``omega x (I omega + A h)``. The
wheels give the body ``-A u`` for motor torques ``u``, so
``u = A^+ (K e + C omega - omega x (I omega + A h))`` with ``A^+`` the pseudo-inverse of the
four wheels' axes (the least motor torques that do it).

A :class:`liebody.Stepper` runs the loop: each control period it reads the attitude, the
body's momentum and the wheels' momenta, sets the motor torques and steps. The motors'
torques are internal: the total angular momentum of body and wheels in space does not
move (to round-off, by construction of the method), and what the body gains the wheels
lose.
"""

# %%
# The spacecraft and the controller
# ---------------------------------

import matplotlib.pyplot as plt
import numpy as np

import liebody
from liebody import quaternion

I_nominal = np.array([40.0, 50.0, 30.0])  # kg m^2, without the wheels' axial inertia
beta = np.radians(54.74)  # the pyramid's elevation: equal control about every axis
axes = np.array([[np.cos(beta) * np.cos(a), np.cos(beta) * np.sin(a), np.sin(beta)]
                 for a in np.radians([45.0, 135.0, 225.0, 315.0])])
A = axes.T
A_pinv = np.linalg.pinv(A)
J = 0.05  # kg m^2, each wheel
h_bias = np.array([3.0, 1.0, -2.0, 0.5])  # N m s: the wheels start spinning
target = quaternion.exp(np.radians(60.0) * np.array([1.0, 2.0, 2.0]) / 3.0)
wn, zeta = 0.25, 0.9  # rad/s and the damping ratio of the small-angle closed loop
K, C = 2.0 * wn**2 * I_nominal, 2.0 * zeta * wn * I_nominal
dt, periods = 0.1, 700  # 70 s


def motor_torques(q, omega, h):
    """Wie-Weiss-Arapostathis quaternion feedback, for one body or a batch (rows)."""
    err = quaternion.multiply(quaternion.conjugate(target), q)  # body frame error
    e = np.where(err[..., :1] < 0.0, -err[..., 1:], err[..., 1:])  # the shorter way round
    wanted = -K * e - C * omega + np.cross(omega, I_nominal * omega + h @ axes)
    return -wanted @ A_pinv.T  # the body feels -A u


craft = liebody.ReactionWheels(liebody.RigidBody(I_nominal), axes, J, momentum=h_bias,
                               max_torque=0.5, max_speed=2000.0)
stepper = liebody.Stepper(craft, omega0=[0.0, 0.0, 0.0], dt=dt)
L_space0 = quaternion.rotate(stepper.q, stepper.L)
t, angle, wheels, drift, body_space, wheels_space = [], [], [], [], [], []
for _ in range(periods):
    omega = craft.omega(stepper.L, stepper.wheel_momentum)
    stepper.u = motor_torques(stepper.q, omega, stepper.wheel_momentum)
    stepper.step()
    q, L, h = stepper.q, stepper.L, stepper.wheel_momentum
    t.append(stepper.t)
    angle.append(quaternion.angle_between(q, target))
    wheels.append(h)
    drift.append(np.abs(quaternion.rotate(q, L) - L_space0).max())
    body_space.append(quaternion.rotate(q, L - A @ h))  # the body's own I omega, in space
    wheels_space.append(quaternion.rotate(q, A @ h))  # the wheels' A h, in space
t, angle, wheels = np.array(t), np.array(angle), np.array(wheels)
body_space, wheels_space = np.array(body_space), np.array(wheels_space)


def settling(a):
    """The time after which the error stays below 0.1 degree."""
    out = np.flatnonzero(~(a < np.radians(0.1)))
    return t[out[-1] + 1] if len(out) else t[0]


print(f"attitude error after {t[-1]:.0f} s: {np.degrees(angle[-1]):.2e} deg; within 0.1 "
      f"deg from t = {settling(angle):.1f} s")
print(f"largest change of the total angular momentum in space: {max(drift):.2e} N m s "
      f"(|L| = {np.linalg.norm(L_space0):.3f} N m s)")
print(f"largest momentum of the body itself during the slew: "
      f"{np.linalg.norm(body_space, axis=1).max():.3f} N m s")
print(f"saturations: {len(stepper.saturations)} (the first: {stepper.saturations[:1]})")
assert angle[-1] < np.radians(1e-3)  # the slew converged
assert max(drift) < 1e-13 * np.linalg.norm(L_space0)  # round-off
# what the body gained (in space) the wheels lost, at every period, to round-off
gain = body_space - body_space[0]
assert np.linalg.norm(gain, axis=1).max() > 1.0  # the body did carry momentum
np.testing.assert_allclose(wheels_space - wheels_space[0], -gain, rtol=0, atol=1e-13)
np.testing.assert_allclose(body_space[-1], 0.0, atol=1e-5)  # and is at rest again

# %%
# A small Monte Carlo: the inertia known to 10 %
# ----------------------------------------------
#
# The same controller (with the nominal inertia) flies 32 spacecraft whose true inertia
# differs by up to 10 % per axis: one ensemble :class:`liebody.Stepper` with per-body
# moments (``RigidBody.batch``), the motor torques one row per body.

rng = np.random.default_rng(7)
moments = I_nominal * rng.uniform(0.9, 1.1, size=(32, 3))
fleet = liebody.ReactionWheels(liebody.RigidBody.batch(moments), axes, J,
                               momentum=h_bias, max_torque=0.5, max_speed=2000.0)
ens = liebody.Stepper(fleet, omega0=np.zeros(3), dt=dt)
L0s = quaternion.rotate(ens.q, ens.L)
angles = []
for _ in range(periods):
    omega = fleet.omega(ens.L, ens.wheel_momentum)
    ens.u = motor_torques(ens.q, omega, ens.wheel_momentum)
    ens.step()
    angles.append(quaternion.angle_between(ens.q, target))
angles = np.array(angles)  # (periods, 32)
settle = np.array([settling(angles[:, i]) for i in range(32)])
print(f"settling to 0.1 deg: {settle.min():.1f} to {settle.max():.1f} s (nominal "
      f"{settling(angle):.1f} s); saturation records: {len(ens.saturations)}")
assert np.all(angles[-1] < np.radians(1e-2))
assert np.abs(quaternion.rotate(ens.q, ens.L) - L0s).max() < 1e-12

# %%
# The slew and the wheels
# -----------------------

fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 3.6))
a1.semilogy(t, np.degrees(angle), label="nominal")
a1.semilogy(t, np.degrees(angles), color="0.7", lw=0.5)
a1.set_xlabel("t [s]")
a1.set_ylabel("attitude error [deg]")
a1.legend()
a2.plot(t, wheels)
a2.set_xlabel("t [s]")
a2.set_ylabel("wheel momentum $h_k$ [N m s]")
fig.tight_layout()
plt.show()
