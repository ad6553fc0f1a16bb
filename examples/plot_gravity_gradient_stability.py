"""
A stability map of gravity-gradient satellites
==============================================

A satellite on a circular orbit can keep its principal axes fixed in the orbital
(LVLH) frame: axis 1 along the velocity (roll), axis 2 along the negative orbit normal
(pitch), axis 3 towards the Earth (yaw). Whether that attitude is stable depends only on
two inertia ratios, those of Kane, Likins & Levinson (*Spacecraft Dynamics*, 1983) and
Hughes (*Spacecraft Attitude Dynamics*, 1986, ch. 9), also written ``k_R`` and ``k_Y``:

``k1 = k_R = (I_pitch - I_yaw) / I_roll``,  ``k3 = k_Y = (I_pitch - I_roll) / I_yaw``.

Linearised about the equilibrium, the pitch libration is stable for ``k1 > k3``, and the
coupled roll-yaw motion for ``1 + 3 k1 + k1 k3 > 0``, ``k1 k3 > 0`` and
``(1 + 3 k1 + k1 k3)^2 > 16 k1 k3``
(:func:`liebody.analysis.gravity_gradient_stability`). Both hold in the Lagrange region
``k1 > k3 > 0`` (largest moment along the orbit normal, least along the vertical) and in
the thin DeBra-Delp region with ``k1, k3 < 0`` (DeBra & Delp, J. Astronaut. Sci. 8,
1961), stable only to first order.

Here 3200 satellites, each with its own inertia, start 0.01 rad off that attitude in
roll, pitch and yaw and are integrated over ten orbits in one ensemble call, through the
built-in gravity-gradient scene (:class:`liebody.GravityGradient`) with the Earth on a
circular orbit (``liebody.orbits.Circular``). Each is classified as bounded or not by
its largest angle from the LVLH frame, and the map is compared with the linear theory.
"""

# %%
# Two grids of inertia ratios in one ensemble
# -------------------------------------------
#
# For given ``k1``, ``k3`` the moments, scaled so that ``I_pitch = 1``, are
# ``I_roll = (1 - k3)/(1 - k1 k3)`` and ``I_yaw = (1 - k1)/(1 - k1 k3)``; every point
# of the open square ``|k1|, |k3| < 1`` is a physical body (the triangle inequalities
# read ``(1 -+ k1)(1 +- k3) > 0``). A 40 x 40 grid of cell centres covers the square;
# the DeBra-Delp region is a sliver at most 0.15 wide in ``k1``, so a second
# 40 x 40 grid covers ``-0.2 < k1 < 0``, ``-1 < k3 < 0``. Both go into one
# ``RigidBody.batch`` of 3200 bodies.

import time

import matplotlib.pyplot as plt
import numpy as np

import liebody
from liebody import analysis, attitude, quaternion
from liebody.orbits import Circular


def moments(k1, k3):
    """(I_roll, I_pitch, I_yaw) with I_pitch = 1, for the ratios k1, k3."""
    k1, k3 = np.asarray(k1, float), np.asarray(k3, float)
    d = 1.0 - k1 * k3
    return np.stack([(1.0 - k3) / d, np.ones_like(k1), (1.0 - k1) / d], axis=-1)


def linear_theory(k1, k3):
    """Stable (True) or not, by liebody.analysis.gravity_gradient_stability."""
    I = moments(np.ravel(k1), np.ravel(k3))
    stable = [analysis.gravity_gradient_stability(row).region != "unstable" for row in I]
    return np.array(stable).reshape(np.shape(k1))


def centres(lo, hi, m):
    return lo + (hi - lo) * (np.arange(m) + 0.5) / m


m = 40
grids = {"full": ((-1.0, 1.0), (-1.0, 1.0)), "DeBra-Delp": ((-0.2, 0.0), (-1.0, 0.0))}
K1, K3, H1, H3 = [], [], [], []
for (lo1, hi1), (lo3, hi3) in grids.values():
    a, b = np.meshgrid(centres(lo1, hi1, m), centres(lo3, hi3, m), indexing="ij")
    K1.append(a.ravel())
    K3.append(b.ravel())
    H1.append(np.full(m * m, (hi1 - lo1) / m))  # the cell sizes
    H3.append(np.full(m * m, (hi3 - lo3) / m))
k1, k3, h1, h3 = (np.concatenate(x) for x in (K1, K3, H1, H3))
body = liebody.RigidBody.batch(moments(k1, k3))
print(f"{len(body)} satellites")

# %%
# Near the Earth-pointing attitude, ten orbits
# --------------------------------------------
#
# Units with the mean motion ``n = 1`` (one orbit lasts ``2 pi``). The Earth, seen from
# the satellite, runs on a circular orbit of radius 1 with ``GM = n^2``; the satellite
# is at ``r = -r_Earth`` with velocity ``n e_z x r``. Every satellite starts with its
# axes on the LVLH axes (``liebody.attitude.lvlh_quaternion``) turned by 0.01 rad in
# roll, pitch and yaw, turning with the frame: ``omega = (0, -n, 0)`` in the body.
# ``splitting2`` with the axis splitting as its drift, the gravity-gradient kicks in the
# SIMD ensemble kernels, 100 steps an orbit.

n = 1.0
earth = Circular(n)
scene = liebody.GravityGradient(body, [(n**2, earth)], free_flow="axes")


def satellite(t):
    r = -earth.position(t)
    return r, np.cross([0.0, 0.0, n], r)


r0, v0 = satellite(0.0)
offset = 0.01
q0 = quaternion.multiply(attitude.lvlh_quaternion(r0, v0),
                         attitude.rpy_to_quaternion([offset, offset, offset]))
per_orbit, orbits = 100, 10
dt = 2 * np.pi / n / per_orbit
run = dict(q0=q0, omega0=[0.0, -n, 0.0], dt=dt, method="splitting2", simd=True)
liebody.integrate(scene, steps=10, **run)  # compiles (or loads the cache)
start = time.perf_counter()
traj = liebody.integrate(scene, steps=orbits * per_orbit, save_every=per_orbit // 10, **run)
elapsed = time.perf_counter() - start
groups = traj.info.get("groups", [traj.info])
assert all(g["simd"] for g in groups)  # the SIMD ensemble kernels ran every body
steps = len(body) * orbits * per_orbit
print(f"{len(body)} bodies x {orbits * per_orbit} steps in {elapsed:.2f} s "
      f"({elapsed / steps * 1e9:.0f} ns per body-step)")

# %%
# Bounded or not, against the linear theory
# -----------------------------------------
#
# The attitude relative to the LVLH frame (``liebody.attitude.attitude_in_lvlh``): its
# rotation angle ``2 arccos |w|``, largest over the ten orbits. A satellite counts as
# bounded if that stays below 0.3 rad (17 degrees, 17 times the start): the linearly
# stable ones stay within a few times the offset, the unstable ones grow at
# ``exp(lambda t)`` and tumble. Near a boundary of the stable region the growth rate
# ``lambda`` goes to zero and ten orbits cannot tell; a cell counts as away from the
# boundaries when the theory gives the same verdict at its eight neighbours (one cell
# width away).

r, v = satellite(traj.t)
q_rel = attitude.attitude_in_lvlh(traj.q, r, v)
excursion = 2 * np.arccos(np.clip(np.abs(q_rel[..., 0]), 0.0, 1.0)).max(axis=1)
bounded = excursion < 0.3
stable = linear_theory(k1, k3)
near = np.zeros(len(k1), bool)
for s1 in (-1, 0, 1):
    for s3 in (-1, 0, 1):
        # (clipped to the physical square: its edges are no boundary of stability)
        near |= linear_theory(np.clip(k1 + s1 * h1, -0.999, 0.999),
                              np.clip(k3 + s3 * h3, -0.999, 0.999)) != stable
agree = bounded == stable
away = agree[~near].mean()
print(f"agreement with the linear theory: {agree.mean():.1%} of all {len(k1)} cells, "
      f"{away:.1%} of the {np.sum(~near)} away from the boundaries")
full, zoom = slice(0, m * m), slice(m * m, 2 * m * m)
for name, part in (("full square", full), ("DeBra-Delp zoom", zoom)):
    sel = ~near[part]
    print(f"  {name}: {agree[part][sel].mean():.1%} of {np.sum(sel)} cells away from "
          f"the boundaries; stable in theory and bounded: "
          f"{np.sum(stable[part] & bounded[part])}")
assert away >= 0.97
assert agree.mean() >= 0.95
# both stable regions are found, and the DeBra-Delp one is resolved in the zoom
debra_delp = stable & (k1 < 0) & ~near
assert np.sum(debra_delp[zoom]) > 100 and bounded[debra_delp].all()
assert bounded[stable & (k1 > 0) & ~near].all()

# %%
# The map
# -------
#
# The largest excursion from the LVLH frame, with the boundaries of the linear theory
# (its verdict on a finer grid, contoured) and the cells where the run and the theory
# disagree.

fig, axes = plt.subplots(1, 2, figsize=(10, 4.6), width_ratios=[1.15, 1])
for ax, part, ((lo1, hi1), (lo3, hi3)) in zip(axes, (full, zoom), grids.values(), strict=True):
    img = np.degrees(excursion[part]).reshape(m, m).T
    mesh = ax.pcolormesh(np.linspace(lo1, hi1, m + 1), np.linspace(lo3, hi3, m + 1), img,
                         cmap="viridis", norm="log", vmin=0.5, vmax=180)
    f1 = np.linspace(lo1, hi1, 161)[1:-1]
    f3 = np.linspace(lo3, hi3, 161)[1:-1]
    F1, F3 = np.meshgrid(f1, f3)
    ax.contour(F1, F3, linear_theory(F1, F3).astype(float), levels=[0.5], colors="w",
               linewidths=1.2)
    miss = ~agree[part]
    ax.plot(k1[part][miss], k3[part][miss], "rx", ms=4, label="run and theory disagree")
    ax.set_xlabel(r"$k_1 = (I_\mathrm{pitch} - I_\mathrm{yaw}) / I_\mathrm{roll}$")
    ax.set_ylabel(r"$k_3 = (I_\mathrm{pitch} - I_\mathrm{roll}) / I_\mathrm{yaw}$")
axes[0].text(0.55, 0.2, "Lagrange", color="w", ha="center")
axes[0].annotate("DeBra-Delp", xy=(-0.05, -0.6), xytext=(-0.75, -0.8), color="w",
                 fontsize=9, arrowprops=dict(arrowstyle="->", color="w"))
axes[0].set_title("largest angle from LVLH over 10 orbits")
axes[1].text(-0.03, -0.5, "DeBra-Delp", color="w", ha="right", rotation=90, va="center")
axes[1].set_title(r"zoom: $-0.2 < k_1 < 0$")
axes[1].legend(loc="lower left", fontsize=8)
fig.colorbar(mesh, ax=axes, label="degrees")
plt.show()
