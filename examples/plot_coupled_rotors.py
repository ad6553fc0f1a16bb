"""
Coupled rotors: a dipolar lattice relaxing, two bodies exchanging spin
======================================================================

Rigid molecules, polar rotors in a crystal, binary asteroids and coupled gyroscopes are
``N`` rigid bodies with one potential of all their orientations,
``H = sum_i L_i^T I_i^-1 L_i / 2 + V(q_1, ..., q_N)``. :class:`liebody.CoupledBodies`
integrates them with liebody's splittings: a kick of every body by the collective torque
with all orientations fixed, between each body's exact free flows. The step is
symplectic, so the total energy stays within a bounded error; for a potential invariant
under a common rotation of all bodies the total angular momentum in space is kept to
round-off by every step.
"""

# %%
# A lattice of dipolar rotors relaxing from random orientations
# -------------------------------------------------------------
#
# 64 rotors on a simple cubic lattice, each carrying a point dipole along its body axis
# 3, interacting through the dipole-dipole potential (:class:`liebody.DipoleLattice`,
# nearest and next-nearest neighbours). Started at random orientations and nearly at
# rest, the lattice turns potential energy into rotation: the kinetic temperature
# rises while the total energy stays put.

import time

import matplotlib.pyplot as plt
import numpy as np
from numba import njit

import liebody
from liebody import quaternion as Q
from liebody.coupled import thermal_momenta, uniform_orientations

k = 4
sites = np.stack(np.meshgrid(*[np.arange(float(k))] * 3, indexing="ij"), -1).reshape(-1, 3)
n = len(sites)
bodies = liebody.RigidBody.batch(np.tile([1.0, 1.0, 0.4], (n, 1)))
lattice = liebody.DipoleLattice(bodies, sites, dipoles=[0.0, 0.0, 1.0], cutoff=1.5)
q0 = uniform_orientations(n, rng=1)
L0 = thermal_momenta(lattice.moments, 1e-3, rng=2)

start = time.perf_counter()
traj = liebody.integrate(lattice, q0=q0, L0=L0, dt=0.005, t_end=60.0, save_every=20)
print(f"{n} rotors, {(len(traj.t) - 1) * 20} steps: {time.perf_counter() - start:.2f} s")

E, V = traj.energy, traj.potential_energy
T = traj.temperature
print(f"potential energy {V[0]:.4f} -> {V[-1]:.4f}; temperature {T[0]:.2e} -> {T[-1]:.4f}; "
      f"largest energy error {np.abs(E - E[0]).max():.2e}")
assert V[-1] < V[0] - 1.0 and T[-1] > 10 * T[0]  # it relaxed, and warmed up
assert np.abs(E - E[0]).max() < 1e-3 * abs(V[0] - V[-1])  # the energy stayed put

fig = plt.figure(figsize=(10, 4))
ax = fig.add_subplot(1, 2, 1)
ax.plot(traj.t, V - V[0], label="potential V")
ax.plot(traj.t, traj.kinetic_energy.sum(axis=0) - traj.kinetic_energy[:, 0].sum(),
        label="kinetic")
ax.plot(traj.t, E - E[0], "k", label="total")
ax.set_xlabel("t")
ax.set_ylabel("change of energy")
ax.legend()
ax3 = fig.add_subplot(1, 2, 2, projection="3d")
mu = Q.rotate(traj.orientation[:, -1], [0.0, 0.0, 1.0])
ax3.quiver(*sites.T, *(0.4 * mu.T), color="C3")
ax3.set_title("dipoles at the end")
fig.tight_layout()

# %%
# Two bodies exchanging spin
# --------------------------
#
# Two asymmetric bodies whose body-fixed vectors ``a_i`` attract,
# ``V = -k (R(q_1) a_1) . (R(q_2) a_2)``: the potential is unchanged by a common rotation
# of both, so the total angular momentum in space cannot change, and the bodies trade
# spin. The torque is the user's compiled function, with its parameters per body.


@njit
def _rotate(q, v):
    w, x, y, z = q[0], q[1], q[2], q[3]
    tx, ty, tz = 2 * (y * v[2] - z * v[1]), 2 * (z * v[0] - x * v[2]), 2 * (x * v[1] - y * v[0])
    return np.array([v[0] + w * tx + (y * tz - z * ty), v[1] + w * ty + (z * tx - x * tz),
                     v[2] + w * tz + (x * ty - y * tx)])


@njit
def torque(t, q, L, p, out):
    """Body i: a_i x (R(q_i)^T k R(q_j) a_j), the other body's vector in i's frame."""
    for i in range(2):
        j = 1 - i
        field = p[i, 3] * _rotate(q[j], p[j, :3])
        c = _rotate(np.array([q[i, 0], -q[i, 1], -q[i, 2], -q[i, 3]]), field)
        a = p[i, :3]
        out[i, 0] = a[1] * c[2] - a[2] * c[1]
        out[i, 1] = a[2] * c[0] - a[0] * c[2]
        out[i, 2] = a[0] * c[1] - a[1] * c[0]


@njit
def potential(t, q, p):
    return -p[0, 3] * np.dot(_rotate(q[0], p[0, :3]), _rotate(q[1], p[1, :3]))


pair = liebody.CoupledBodies(
    [liebody.RigidBody([1.0, 2.0, 3.0]), liebody.RigidBody([2.0, 2.5, 1.5])], torque,
    potential, params=[[1.0, 0.0, 0.0, 0.5], [0.0, 1.0, 0.0, 0.5]])
spin = liebody.integrate(pair, q0=uniform_orientations(2, rng=3),
                         L0=[[0.0, 0.0, 3.0], [0.0, 0.0, 0.0]], dt=0.01, t_end=100.0,
                         method="splitting4", save_every=10)
Ls = spin.total_L_space
each = np.linalg.norm(spin.L, axis=-1)
drift = np.abs(Ls - Ls[0]).max() / np.linalg.norm(Ls[0])
print(f"|L| of body 2: 0 -> up to {each[1].max():.3f}; total spatial L kept to {drift:.1e}")
assert each[1].max() > 1.0 and drift < 1e-13
# the torque is the potential's (a sign or a factor wrong would not change the total L,
# but the energy): the total energy stays put while V swings by about 1
E2, V2 = spin.energy, spin.potential_energy
print(f"potential swings by {np.ptp(V2):.3f}; total energy kept to {np.ptp(E2):.1e}")
assert np.ptp(E2) < 1e-8 * np.ptp(V2) and np.ptp(V2) > 0.5

fig, ax = plt.subplots(figsize=(6, 3.5))
ax.plot(spin.t, each[0], label="|L| of body 1")
ax.plot(spin.t, each[1], label="|L| of body 2")
ax.plot(spin.t, np.linalg.norm(Ls, axis=-1), "k--", label="|total L in space|")
ax.set_xlabel("t")
ax.legend()
fig.tight_layout()
plt.show()
