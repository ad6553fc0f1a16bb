"""
Monte Carlo of 100,000 tumbling T-handles
=========================================

A T-handle spun about its intermediate principal axis does not keep spinning: it
turns over, half a turn at a time, again and again (the Dzhanibekov or tennis-racket
effect). How long it waits between turns depends on how far from the axis it was
started. Here 100,000 handles, each started with a slightly different small tilt of
its angular momentum away from that axis, are integrated in ensemble calls of
:func:`liebody.integrate`; for every one the period of its flips is measured from its
trajectory and compared with the elliptic-integral formula of Landau & Lifshitz,
*Mechanics*, §37 (:func:`liebody.analysis.flip_period`).

Set the environment variable ``LIEBODY_EXAMPLE_BODIES`` to run fewer bodies (the
tests run 400).
"""

# %%
# The body: a T-handle
# --------------------
#
# A crossbar (30 g, 8 cm long, 1 cm thick, along ``x``) and a stem (20 g, 6 cm, along
# ``z``) that starts at the bar's middle, put together with
# :func:`liebody.inertia.composite`. :class:`liebody.RigidBody` diagonalises the
# tensor and orders the principal moments ``I1 < I2 < I3``, so body axis 2 (index 1)
# is the intermediate one; for these proportions it is the crossbar.

import math
import os
import time

import matplotlib.pyplot as plt
import numpy as np

import liebody
from liebody import analysis, inertia


def t_handle() -> liebody.RigidBody:
    """The T-handle: a 30 g crossbar along ``x`` and a 20 g stem along ``z``."""
    bar_axis_x = [[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]]  # cylinder z -> x
    bar = inertia.Part(0.030, [0.0, 0.0, 0.0],
                       inertia.solid_cylinder(0.030, 0.005, 0.08), bar_axis_x)
    stem = inertia.Part(0.020, [0.0, 0.0, 0.035], inertia.solid_cylinder(0.020, 0.005, 0.06))
    props = inertia.composite([bar, stem])
    return liebody.RigidBody(props.inertia, mass=props.mass)


body = t_handle()
I1, I2, I3 = body.moments
names = {0: "x (crossbar)", 1: "y", 2: "z (stem)"}
print(f"moments I1 < I2 < I3 = {I1:.4g}, {I2:.4g}, {I3:.4g} kg m^2")
print(f"intermediate axis: input-frame {names[int(np.argmax(abs(body.axes[:, 1])))]}")

# %%
# The ensemble of initial conditions
# ----------------------------------
#
# Every handle gets the same spin, ``|L| = I2 omega2`` with ``omega2`` = 4 turns per
# second, so the bodies differ only in the *direction* of ``L`` (and hence in their
# energy): ``L`` is along the intermediate axis plus a small random tilt, the two
# transverse components of the direction being independent normal numbers of
# standard deviation ``sigma = 0.05`` (about 3 degrees).
#
# Near the intermediate axis the motion is close to the separatrix, and the period
# grows like ``(4 / lambda) ln(4 / k')`` as the start approaches it
# (:func:`liebody.analysis.flip_period`), with ``lambda = sqrt(r1 r3) omega2`` the
# growth rate of the instability (:func:`liebody.analysis.stability`). The separatrix
# is not only the axis itself: it is two great circles through it on the sphere
# ``|L| = const``, so a tilt of any size in the right direction gives a long period.
# The periods therefore have a long tail.

N = int(os.environ.get("LIEBODY_EXAMPLE_BODIES", "100000"))
OMEGA2 = 2 * math.pi * 4.0   # rad/s about the intermediate axis
SIGMA = 0.05                 # rms tilt of L (rad, per transverse component)


def initial_momenta(n: int, G: float, sigma: float, seed: int = 2024) -> np.ndarray:
    """``n`` body-frame momenta of norm ``G``, tilted from axis 2 by ``sigma`` rms."""
    rng = np.random.default_rng(seed)
    d = np.empty((n, 3))
    d[:, [0, 2]] = sigma * rng.standard_normal((n, 2))
    d[:, 1] = 1.0
    return G * d / np.linalg.norm(d, axis=1, keepdims=True)


G = I2 * OMEGA2
L0 = initial_momenta(N, G, SIGMA)
lam = analysis.stability(body.moments, OMEGA2, axis=1).rate
print(f"{N} bodies, |L| = {G:.4g} kg m^2/s, growth rate lambda = {lam:.3f} 1/s")

# %%
# What "flip period" means, and what the formula gives
# ----------------------------------------------------
#
# In the body frame ``L`` runs round a closed curve on the sphere ``|L| = G``, and
# the intermediate component is ``L_2 ∝ sn(nu t)`` (Landau & Lifshitz §37). One full
# cycle of that motion, ``T_m = 4 K(k) / nu``, is what
# :func:`~liebody.analysis.flip_period` returns. In one cycle the handle flips
# *twice*: ``L_2`` goes from ``+`` to ``-`` and back, so the flips (sign changes of
# ``L_2``) come every ``T_m / 2``. To measure exactly the formula's ``T_m`` we use
# the *upward* zero crossings of ``L_2`` only: consecutive ones are one full cycle
# apart. The formula is evaluated for every body (a Python loop:
# ``flip_period`` takes one body at a time).

t0 = time.perf_counter()
T_formula = np.array([analysis.flip_period(body.moments, L) for L in L0])
print(f"formula for {N} bodies: {time.perf_counter() - t0:.2f} s; periods "
      f"{T_formula.min():.3f} .. {T_formula.max():.3f} s (median {np.median(T_formula):.3f})")


def sn_frequency(moments, L) -> np.ndarray:
    """``nu`` of Landau & Lifshitz §37 per body (``L`` ``(N, 3)``, moments ascending).

    Only used for the interpolation error bound below: ``L_2 = A sn(nu t + c)``.
    """
    J1, J2, J3 = moments
    L2 = np.asarray(L) ** 2
    d1 = L2[:, 1] * (J2 - J1) / J2 + L2[:, 2] * (J3 - J1) / J3    # G^2 - 2T I1
    d3 = L2[:, 0] * (J3 - J1) / J1 + L2[:, 1] * (J3 - J2) / J2    # 2T I3 - G^2
    d2 = L2[:, 0] * (J1 - J2) / J1 + L2[:, 2] * (J3 - J2) / J3    # G^2 - 2T I2
    prod = J1 * J2 * J3
    return np.where(d2 > 0, np.sqrt((J3 - J2) * d1 / prod), np.sqrt((J2 - J1) * d3 / prod))


nu = sn_frequency(body.moments, L0)

# %%
# Measuring the period from a trajectory
# --------------------------------------
#
# ``L_2`` is sampled every ``ds``. An upward crossing lies between a negative sample
# and the next non-negative one; its time is refined as the root of the cubic
# through the four samples around it (the method of
# :func:`liebody.analysis.zero_crossings`, here vectorised over bodies). The period
# is the time from the first to the last upward crossing divided by the number of
# cycles between them.
#
# **Error bound.** The cubic's error at the crossing is at most
# ``max|L_2''''| ds^4 / 24`` (the node polynomial is at most ``ds^4`` on the
# interval), and it moves the root by that divided by the slope ``|L_2'|``. With
# ``L_2 = A sn(nu t + c)``: ``|L_2'| = A nu`` at a zero and
# ``|L_2''''| <= C4 A nu^4``, where ``C4 = 4.0859`` is the largest ``|d^4 sn / du^4|``
# over all moduli (reached at ``k = 1``, ``sn = tanh``). So each crossing is off by at
# most ``C4 nu^3 ds^4 / 24`` (to leading order: we allow a factor 2), and the period
# over ``n`` cycles by twice that over ``n``.

C4 = 4.0859  # max over u and 0 <= k <= 1 of |d^4 sn(u|k) / du^4|


def upward_crossings(t: np.ndarray, y: np.ndarray, idx: np.ndarray) -> np.ndarray:
    """Refine the upward zero crossing of row ``i`` of ``y`` between samples ``idx[i]``
    and ``idx[i] + 1``: the root of the cubic through 4 neighbouring samples (Newton
    from the chord; the chord's root if Newton leaves the interval)."""
    rows = np.arange(y.shape[0])
    n = t.size
    t0, h = t[idx], t[idx + 1] - t[idx]
    y0, y1 = y[rows, idx], y[rows, idx + 1]
    s_lin = y0 / (y0 - y1)
    j = np.clip(idx - 1, 0, n - 4)[:, None] + np.arange(4)
    nodes = (t[j] - t0[:, None]) / h[:, None]
    c = y[rows[:, None], j].copy()                 # Newton divided differences
    for k in range(1, 4):
        c[:, k:] = (c[:, k:] - c[:, k - 1:-1]) / (nodes[:, k:] - nodes[:, :-k])
    s = s_lin.copy()
    for _ in range(30):
        p, dp = c[:, 3], np.zeros_like(s)
        for k in (2, 1, 0):
            dp = dp * (s - nodes[:, k]) + p
            p = p * (s - nodes[:, k]) + c[:, k]
        step = np.divide(p, dp, out=np.zeros_like(p), where=dp != 0)
        s -= step
        if np.all(np.abs(step) <= 1e-15):
            break
    s = np.where(np.isfinite(s) & (s >= 0) & (s <= 1), s, s_lin)
    return t0 + s * h


def measure_periods(t: np.ndarray, L2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Full periods of ``L2`` ``(N, n)`` sampled at ``t``: (periods, cycles counted).

    Bodies with fewer than two upward crossings get NaN (the window was too short).
    """
    neg = L2 < 0
    up = neg[:, :-1] & ~neg[:, 1:]                  # - then + : an upward crossing
    n_up = up.sum(axis=1)
    first = np.argmax(up, axis=1)
    last = up.shape[1] - 1 - np.argmax(up[:, ::-1], axis=1)
    cycles = np.maximum(n_up - 1, 0)
    with np.errstate(invalid="ignore", divide="ignore"):
        period = (upward_crossings(t, L2, last) - upward_crossings(t, L2, first)) / cycles
    return np.where(cycles >= 1, period, np.nan), cycles


def period_tolerance(nu: np.ndarray, ds: float, cycles: np.ndarray) -> np.ndarray:
    """Bound on ``|measured - T_m|`` from sampling ``L_2 = A sn(nu t + c)`` every
    ``ds`` (cubic interpolation; a factor 2 for higher-order terms)."""
    per_crossing = 2.0 * C4 * nu**3 * ds**4 / 24.0
    return 2.0 * per_crossing / np.maximum(cycles, 1)


# %%
# The run: chunks of bodies, modest samples
# -----------------------------------------
#
# Every body must show at least two upward crossings, which can take two full
# periods; the window is 2.2 times the longest predicted period (the predictions set
# only the window). ``L_2`` is saved every ``ds = 0.05`` s, more than 20 samples per
# period. An ensemble's memory is its saved samples, 56 bytes per body and sample
# (``q`` and ``L``): 100,000 bodies at once would need 1.3 GB. So the bodies go
# through :func:`liebody.integrate` in chunks of ``CHUNK = 10,000`` (128 MB of
# samples each); each chunk is measured and dropped before the next, and only the
# periods (and ``L_2`` of three bodies, for a plot) are kept.
#
# First with the free body's default method, the **exact flow**: the Jacobi elliptic
# functions evaluated at the output times, no time stepping and no discretisation
# error, so what differs from the formula is the measurement alone.

CHUNK = 10_000
DS = 0.05
t_end = 2.2 * float(T_formula.max())
n_samples = math.ceil(t_end / DS)
scene = liebody.FreeBody(body)
print(f"window {n_samples * DS:.2f} s, {n_samples + 1} samples per body; a chunk of "
      f"{min(CHUNK, N)} bodies holds {min(CHUNK, N) * (n_samples + 1) * 56 / 1e6:.0f} MB")


def run_ensemble(L0, *, method, dt, steps, save_every, chunk=CHUNK, keep=()):
    """Integrate ``L0`` ``(N, 3)`` chunk by chunk; measure every body's period.

    Returns ``(t, periods, cycles, wall seconds, L_2 samples of the bodies keep)``.
    """
    periods, cycles = np.empty(len(L0)), np.empty(len(L0), dtype=np.int64)
    keep = np.asarray(keep, dtype=np.int64)
    wall, kept, t = 0.0, None, None
    for lo in range(0, len(L0), chunk):
        sl = slice(lo, min(lo + chunk, len(L0)))
        start = time.perf_counter()
        traj = liebody.integrate(scene, L0=L0[sl], dt=dt, steps=steps, method=method,
                                 save_every=save_every, threads=None)
        wall += time.perf_counter() - start
        t, L2 = traj.t, traj.L[:, :, 1]
        periods[sl], cycles[sl] = measure_periods(t, L2)
        if kept is None:
            kept = np.empty((keep.size, t.size))
        mine = (keep >= sl.start) & (keep < sl.stop)
        kept[mine] = L2[keep[mine] - sl.start]
        del traj, L2
    return t, periods, cycles, wall, kept


# compile (or load from numba's cache) before timing
liebody.integrate(scene, L0=L0[:2], dt=DS, steps=4, method="exact", save_every=1)
order = np.argsort(T_formula)
shown = [order[0], order[N // 2], order[-1]]  # shortest, median, longest period
t, T_exact, cyc_exact, wall, L2_shown = run_ensemble(
    L0, method="exact", dt=DS, steps=n_samples, save_every=1, keep=shown)
print(f"exact flow: {wall:.2f} s wall, {wall / (N * n_samples) * 1e9:.0f} ns per "
      "body-sample (each sample one evaluation of the flow)")

rel_exact = T_exact / T_formula - 1
tol_exact = period_tolerance(nu, DS, cyc_exact) / T_formula
print(f"unmeasured bodies: {np.isnan(T_exact).sum()}; cycles per body "
      f"{cyc_exact.min()} .. {cyc_exact.max()}")
print(f"measured / formula - 1: median |.| {np.median(abs(rel_exact)):.1e}, "
      f"max {np.nanmax(abs(rel_exact)):.1e}; bound from ds: median "
      f"{np.median(tol_exact):.1e}, exceeded by {np.sum(abs(rel_exact) > tol_exact)} bodies")

# %%
# What is being measured: ``L_2(t)`` of three handles, with a short, a median and a
# long period, and their upward crossings one full period ``T_m`` apart.

fig, ax = plt.subplots(figsize=(10, 3.6))
for i, y, colour in zip(shown, L2_shown, ("C0", "C1", "C3"), strict=True):
    ax.plot(t, y / G, color=colour, lw=1.2,
            label=f"T_m = {T_formula[i]:.2f} s (formula), {T_exact[i]:.2f} s (measured)")
    up = np.flatnonzero((y[:-1] < 0) & (y[1:] >= 0))
    ax.plot(t[up], np.zeros(up.size), "o", color=colour, ms=5)
ax.axhline(0, color="0.6", lw=0.8)
ax.set_xlabel("t (s)")
ax.set_ylabel("L_2 / |L|")
ax.set_title("flips: L_2 changes sign every T_m / 2; dots: upward crossings, T_m apart")
ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)
fig.tight_layout()

# %%
# The same Monte Carlo with a stepping integrator
# -----------------------------------------------
#
# The exact flow exists only for the free body. With a torque one steps, e.g. with
# ``"splitting2"``, the fast symplectic splitting. Its step here is
# ``dt = 2`` ms (``h |omega| = 0.05``); ``L_2`` is saved every 25 steps, at the same
# times as above. Its own error now adds to the measured period: splitting2 keeps
# ``|L|`` exactly and a modified energy, so each body runs on a slightly shifted
# orbit, and the period's sensitivity to the orbit grows without bound near the
# separatrix (the ``ln(4/k')`` above). The comparison with the exact flow separates
# the two errors.

DT = 0.002
SAVE = round(DS / DT)
liebody.integrate(scene, L0=L0[:2], dt=DT, steps=SAVE, method="splitting2", save_every=SAVE)
t_s2, T_s2, cyc_s2, wall_s2, _ = run_ensemble(
    L0, method="splitting2", dt=DT, steps=n_samples * SAVE, save_every=SAVE)
assert np.allclose(t_s2, t)
body_steps = N * n_samples * SAVE
print(f"splitting2: {wall_s2:.2f} s wall for {body_steps:.3g} body-steps, "
      f"{wall_s2 / body_steps * 1e9:.1f} ns per body-step ({os.cpu_count()} cores)")
rel_s2 = T_s2 / T_formula - 1
print(f"measured / formula - 1: median {np.median(rel_s2):.1e}, "
      f"95% within {np.nanpercentile(abs(rel_s2), 95):.1e}, max {np.nanmax(abs(rel_s2)):.1e}")

# %%
# Histograms
# ----------
#
# Left: the measured periods and the formula's, indistinguishable at this scale.
# Right: how far they differ. The exact flow's differences are the interpolation
# error, below the bound derived from ``ds``; splitting2's are its own O(h^2) error,
# largest for the long periods (bodies near the separatrix).

fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4))
bins = np.linspace(T_formula.min(), np.nanmax(T_exact), 80)
ax1.hist(T_exact, bins=bins, color="C0", alpha=0.5, label="measured (exact flow)")
ax1.hist(T_s2, bins=bins, histtype="step", color="C1", lw=1.2, label="measured (splitting2)")
ax1.hist(T_formula, bins=bins, histtype="step", color="k", lw=1.2,
         label="formula 4 K(k) / nu")
ax1.set_xlabel("full period T_m (s): flips every T_m / 2")
ax1.set_ylabel("bodies")
ax1.set_yscale("log")
ax1.legend(fontsize=8)

tiny = 1e-16
lbins = np.logspace(-12, 0, 97)
ax2.hist(np.maximum(abs(rel_exact), tiny), bins=lbins, color="C0", alpha=0.5,
         label="exact flow")
ax2.hist(np.maximum(abs(rel_s2), tiny), bins=lbins, color="C1", alpha=0.5,
         label=f"splitting2, h = {DT * 1e3:g} ms")
ax2.hist(tol_exact, bins=lbins, histtype="step", color="k", lw=1.0,
         label="bound from sampling every ds")
ax2.set_xscale("log")
ax2.set_yscale("log")
ax2.set_xlabel("|measured / formula - 1|")
ax2.set_ylabel("bodies")
ax2.legend(fontsize=8)
fig.tight_layout()

# %%
# splitting2's error against the period: the longer the period, the closer the body
# came to the separatrix, and the more a small shift of its orbit matters. The few
# bodies that start closer to the separatrix than splitting2 shifts it (by
# ``O(h^2)``) get errors of order one, and theirs is not even monotonic in ``h``: the
# shifted separatrix can move across such a start as ``h`` shrinks (one of them is
# 0.2 % off at 2 ms and 4 % at 1 ms). The exact flow's errors are the interpolation's,
# independent of the period.

fig, ax = plt.subplots(figsize=(6.5, 4))
sub = np.random.default_rng(1).permutation(N)[:5000]
ax.loglog(T_formula[sub], np.maximum(abs(rel_s2[sub]), tiny), ".", ms=2, color="C1",
          label="splitting2")
ax.loglog(T_formula[sub], np.maximum(abs(rel_exact[sub]), tiny), ".", ms=2, color="C0",
          label="exact flow")
ax.set_xlabel("T_m from the formula (s)")
ax.set_ylabel("|measured / formula - 1|")
ax.legend()
fig.tight_layout()

# %%
# One call for many bodies, or a loop of one-body calls?
# ------------------------------------------------------
#
# The same splitting2 run for a subset of bodies, as one ensemble call (on every
# core and on one thread) and as a Python loop of one-body :func:`liebody.integrate`
# calls. The loop pays the set-up of a call (validation, and planning the step,
# which for splitting2 depends on the initial state) once per body, and runs on one
# core; the ensemble call plans all bodies at once and splits them over the cores.

n_loop = min(200, N)
sub_L0 = L0[:n_loop]
steps = n_samples * SAVE
kw = dict(dt=DT, steps=steps, method="splitting2", save_every=SAVE)
liebody.integrate(scene, L0=sub_L0[0], **kw)  # compile the one-body path first
start = time.perf_counter()
for L in sub_L0:
    liebody.integrate(scene, L0=L, **kw)
loop = time.perf_counter() - start
timings = {"python loop": loop}
for threads in (1, None):
    start = time.perf_counter()
    liebody.integrate(scene, L0=sub_L0, threads=threads, **kw)
    timings[f"one call, threads={threads}"] = time.perf_counter() - start
for name, sec in timings.items():
    print(f"{name:>22}: {sec:.3f} s, {sec / (n_loop * steps) * 1e9:.1f} ns per body-step, "
          f"{loop / sec:.2f}x the loop's speed")

plt.show()
