"""
A stability map of free rotation
================================

Which rotations of a free rigid body are stable? Linearising Euler's equations (Hand &
Finch, *Analytical Mechanics*, ch. 8, stability of rotation about the principal axes)
says: about the axes of smallest and largest moment a small perturbation oscillates;
about the intermediate axis it grows like ``exp(lambda t)`` with
``lambda = omega sqrt((I2 - I1)(I3 - I2) / (I1 I3))``. Here every direction of the
angular momentum on the sphere is integrated at once, in one ensemble call, and coloured
by how far ``L`` wanders from where it started.
"""

# %%
# 20,000 initial directions in one call
# -------------------------------------
#
# A grid of directions of the body-frame ``L`` on the unit sphere, one body each
# (``L0`` of shape ``(N, 3)``), integrated with the exact flow up to ``t = 60`` (with
# ``|L| = 1``: about ten turns about axis 1, three about axis 3); the measure is the
# largest angle between ``L(t)`` and ``L(0)``.

import matplotlib.pyplot as plt
import numpy as np

import liebody
from liebody import analysis

moments = np.array([1.0, 2.0, 3.0])
body = liebody.RigidBody(moments)
lon = np.linspace(-np.pi, np.pi, 200)
lat = np.linspace(-np.pi / 2 + 0.01, np.pi / 2 - 0.01, 100)
LON, LAT = np.meshgrid(lon, lat)
L0 = np.stack([np.cos(LAT) * np.cos(LON), np.cos(LAT) * np.sin(LON), np.sin(LAT)], axis=-1)
L0 = L0.reshape(-1, 3)
traj = liebody.integrate(liebody.FreeBody(body), L0=L0, dt=0.25, t_end=60.0)
cos_wander = np.einsum("nsk,nk->ns", traj.L, L0).min(axis=1)
wander = np.degrees(np.arccos(np.clip(cos_wander, -1, 1))).reshape(LAT.shape)
print(f"{len(L0):,} bodies x {len(traj.t)} samples")

fig, ax = plt.subplots(figsize=(9, 4.5))
im = ax.pcolormesh(np.degrees(LON), np.degrees(LAT), wander, cmap="magma", shading="auto")
for name, (lo, la) in {"axis 1 (smallest)": (0, 0), "axis 2 (intermediate)": (90, 0),
                       "axis 3 (largest)": (0, 90)}.items():
    ax.plot(lo, min(la, 88), "c*", ms=10)
    ax.annotate(name, (lo, min(la, 88)), xytext=(6, -12), textcoords="offset points",
                color="c", fontsize=8)
ax.set_xlabel("longitude of $L_0$ in the body frame [deg]")
ax.set_ylabel("latitude [deg]")
ax.set_title(r"largest angle between $L(t)$ and $L(0)$ up to $t = 60$, $I = (1, 2, 3)$")
fig.colorbar(im, ax=ax, label="degrees")
fig.tight_layout()

# stable caps about axes 1 and 3, the flips through axis 2
near = {k: wander[np.argmin(np.abs(lat - la)), np.argmin(np.abs(lon - lo))]
        for k, (lo, la) in {"1": (0.0, 0.0), "2": (np.pi / 2, 0.0),
                            "3": (0.0, np.pi / 2 - 0.01)}.items()}
print("wander next to each axis [deg]:", {k: round(float(v), 2) for k, v in near.items()})
assert near["1"] < 5 and near["3"] < 5 and near["2"] > 170

# %%
# The growth rate on the intermediate axis
# ----------------------------------------
#
# Spun at ``omega = 1`` about axis 2 with a 1e-8 perturbation, the small components grow
# exponentially until the flip; the fitted rate against the linear theory
# (:func:`liebody.analysis.stability`).

omega = 1.0
traj2 = liebody.integrate(liebody.FreeBody(body), omega0=[1e-8, omega, 1e-8], dt=0.01,
                          t_end=30.0, method="splitting2")
rate = analysis.fit_growth_rate(traj2)
theory = analysis.stability(moments, omega, axis=1).rate
print(f"growth rate: measured {rate:.6f}, linear theory {theory:.6f}")
np.testing.assert_allclose(rate, theory, rtol=1e-3)

fig2, ax2 = plt.subplots(figsize=(8, 3.5))
ax2.semilogy(traj2.t, np.abs(traj2.omega[:, 0]), label=r"$|\omega_1|$")
ax2.semilogy(traj2.t, np.abs(traj2.omega[:, 2]), label=r"$|\omega_3|$")
ax2.semilogy(traj2.t, 1e-8 * np.exp(theory * traj2.t), "k--", lw=1,
             label=rf"$e^{{\lambda t}}$, $\lambda$ = {theory:.4f}")
ax2.set_xlabel("time")
ax2.set_ylabel("perturbation")
ax2.set_title("rotation about the intermediate axis is unstable")
ax2.legend()
fig2.tight_layout()
plt.show()
