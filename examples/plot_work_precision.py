"""
Speed against accuracy: a work-precision chart
==============================================

Which method is cheapest for a given accuracy? On Simo & Wong's fast heavy top (spin 50
rad/s, the reference problem ``"top"`` of :mod:`liebody.testing`) every method runs a
ladder of halved steps to ``T = 10``; its error against the certified reference is
plotted against the wall time of the call. The slopes are the orders; the splittings
integrate the spin exactly and win at every accuracy, while a compiled RK4 must resolve
the spin. On free bodies at loose accuracy and short horizons a compiled RK4 can win:
see the method guide and the benchmarks, which also time scipy and MuJoCo.
"""

# %%
# The ladder
# ----------

import time
import warnings

import matplotlib.pyplot as plt
import numpy as np

import liebody
from liebody import testing

# the baselines drift and, at large steps, blow up: that is what the chart shows
warnings.simplefilter("ignore", liebody.InvariantWarning)
warnings.simplefilter("ignore", RuntimeWarning)

problem = testing.problem("top")
T = problem.t_end
q_ref, L_ref = problem.reference(T)
methods = ["splitting2", "rattle", "splitting4", "splitting6", "splitting8", "rk4",
           "lie_euler"]
results = {}
for name in methods:
    rows = []
    for k in range(16):
        n = 20 * 2**k
        start = time.perf_counter()
        try:
            traj = liebody.integrate(problem.scene, q0=problem.q0, L0=problem.L0,
                                     dt=T / n, steps=n, method=name, save_every=None)
        except liebody.ConvergenceError:  # RATTLE's implicit step beyond h |omega| ~ 1
            continue
        cost = time.perf_counter() - start
        if traj.status != "complete":
            continue
        err = testing.state_error(traj.q[-1], traj.L[-1], q_ref, L_ref)
        rows.append((T / n, cost, err))
        if err < 1e-11 or cost > 0.5:
            break
    results[name] = np.array(rows)

# %%
# The chart
# ---------

fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.5))
for name, r in results.items():
    ok = np.isfinite(r[:, 2]) & (r[:, 2] < 1)
    style = "--" if name in ("rk4", "lie_euler") else "-"
    ax1.loglog(r[ok, 0], r[ok, 2], "o" + style, ms=3, label=name)
    ax2.loglog(r[ok, 1], r[ok, 2], "o" + style, ms=3, label=name)
for ax in (ax1, ax2):
    ax.axhline(problem.uncertainty, color="0.6", lw=0.8, ls=":")
    ax.set_ylabel("error at T = 10 (vs certified reference)")
    ax.grid(alpha=0.3, which="both")
ax1.set_xlabel("step h")
ax1.set_title("error against step: the slopes are the orders")
ax2.set_xlabel("wall time of the call [s]")
ax2.set_title("error against cost")
ax2.legend(fontsize=8)
fig.suptitle("Simo & Wong's fast top")
fig.tight_layout()

# %%
# Observed orders and the cheapest method at 1e-8
# -----------------------------------------------
#
# :func:`liebody.testing.observed_order` finds the asymptotic range of each ladder and
# must give the declared order.


def cost_at(r, level):
    """Interpolated (log-log) wall time at which the error reaches ``level``."""
    ok = np.isfinite(r[:, 2])
    e, c = np.log(r[ok, 2]), np.log(r[ok, 1])
    below = np.flatnonzero(e <= np.log(level))
    if not len(below) or below[0] == 0:
        return np.nan
    i = below[0]
    f = (np.log(level) - e[i - 1]) / (e[i] - e[i - 1])
    return float(np.exp(c[i - 1] + f * (c[i] - c[i - 1])))


for name in methods:
    m = liebody.methods()[name]
    found = testing.observed_order(name, problem)
    print(f"{name:11s} declared order {m.order}, observed {found.order:.2f}; "
          f"time to 1e-8: {cost_at(results[name], 1e-8) * 1e3:8.2f} ms")
    assert abs(found.order - m.order) < 0.25, (name, found)
best = min(methods, key=lambda n: np.nan_to_num(cost_at(results[n], 1e-8), nan=np.inf))
print(f"cheapest at 1e-8: {best}; rk4 costs "
      f"{cost_at(results['rk4'], 1e-8) / cost_at(results[best], 1e-8):.1f}x as much")
assert best.startswith("splitting")
plt.show()
