"""
A dual-spin satellite: a rotor stabilises the intermediate axis
===============================================================

A rigid body spinning about its axis of intermediate moment is unstable: it flips (the
tennis racket theorem, Hand & Finch ch. 8). A spacecraft with a rotor spinning inside it
along that axis, a dual-spin satellite or gyrostat, is not: with the rotor's momentum
``h`` along the spin axis the linearised motion of ``L' = L x I^-1 (L - l)`` obeys
``L_1'' = -kappa L_1`` with

``kappa = ((I2 - I1) omega + h) ((I2 - I3) omega + h) / (I1 I3)``:

stable, nutating at ``sqrt(kappa)``, when both factors have one sign, so (for ``h >= 0``)
when ``h > (I3 - I2) omega``; otherwise the tilt grows at ``sqrt(-kappa)``
(Hughes, *Spacecraft Attitude Dynamics*, 1986, ch. 7). :class:`liebody.Gyrostat`
integrates the gyrostat with the axis splitting of ``H = (L - l)^T I^-1 (L - l) / 2``;
:func:`liebody.analysis.dual_spin_stable` gives the linear theory.
"""

# %%
# Spin about the intermediate axis, with rotors of increasing momentum
# --------------------------------------------------------------------

import matplotlib.pyplot as plt
import numpy as np

import liebody
from liebody import analysis

moments = np.array([80.0, 100.0, 120.0])  # kg m^2
omega, nudge = 1.0, 1e-3
runs = {}
for h in (0.0, 10.0, 40.0):
    scene = liebody.Gyrostat(liebody.RigidBody(moments), [0.0, h, 0.0])
    L0 = np.array([nudge, moments[1] * omega + h, nudge])
    traj = liebody.integrate(scene, L0=L0, dt=0.01, t_end=400.0, save_every=20)
    theory = analysis.dual_spin_stable(moments, omega, 1, h)
    I1, I2, I3 = moments
    kappa = ((I2 - I1) * omega + h) * ((I2 - I3) * omega + h) / (I1 * I3)
    assert theory.stable == (kappa > 0)
    np.testing.assert_allclose(theory.rate, np.sqrt(abs(kappa)), rtol=1e-12)
    off = np.hypot(traj.L[:, 0], traj.L[:, 2]) / np.linalg.norm(L0)
    print(f"h = {h:5.1f}: linear theory {'stable' if theory.stable else 'unstable'} "
          f"(rate {theory.rate:.3f} rad/s); largest tilt of L from the axis: {off.max():.3f}")
    assert bool(off.max() < 0.01) == theory.stable
    runs[h] = (traj, theory)

# %%
# The stable gyrostat nutates at the rate of the linear theory
# ------------------------------------------------------------

traj, theory = runs[40.0]
crossings = analysis.zero_crossings(traj.t, traj.L[:, 0])
measured = np.pi / np.mean(np.diff(crossings))
print(f"nutation: measured {measured:.5f} rad/s, linear theory {theory.rate:.5f} rad/s")
np.testing.assert_allclose(measured, theory.rate, rtol=1e-3)

# %%
# The component of L across the spin axis
# ---------------------------------------

fig, ax = plt.subplots(figsize=(8, 3.6))
for h, (traj, theory) in runs.items():
    ax.plot(traj.t, traj.L[:, 0], label=f"h = {h:g} ({'stable' if theory.stable else 'flips'})")
ax.set_xlabel("t [s]")
ax.set_ylabel(r"$L_1$ [kg m$^2$/s]")
ax.set_title("spin about the intermediate axis, with and without a rotor")
ax.legend(fontsize=8)
fig.tight_layout()
plt.show()
