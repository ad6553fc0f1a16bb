"""Coupled bodies: ns per body-step of a dipolar lattice against ``N``, beside a plain loop.

A simple cubic lattice of ``N = k^3`` dipolar rotors (spacing 1, dipoles along body axis
3, moments ``(1, 1.2, 0.4)``, neighbours within 1.5: 18 per site inside the lattice)
from random orientations at a low temperature, integrated with ``no_squish`` (the
5-rotation splitting in the fixed ordering z-y-x-y-z, one collective torque per step),
saving the final state only. Paths, each timed as the minimum of repeated calls:

* **liebody** — ``liebody.integrate(liebody.DipoleLattice(...))``: the collective torque
  (the built-in dipole model, through its C callback) once per step, the free flows on
  the SIMD kernels;
* **liebody, free part** — the same bodies coupled by a torque that writes zeros: what
  the kicks' bookkeeping and the free flows cost without the coupling;
* **plain numba loop** — the Strang splitting written here as a user would: one
  ``@njit`` function that calls the same dipole torque (``liebody._models.dipoles.torque``)
  and turns each body by five exact axis rotations with the C library's sin/cos, kicks
  merged (one torque per step). It is checked to agree with the liebody run (the same
  map: final states within 1e-9 after a few hundred steps).

Reported: ns per body-step of each path, the coupling's share, and the speed-up of
liebody over the plain loop. Run ``python -m bench --only coupled [--quick]``.
"""

from __future__ import annotations

import math
import time

import numpy as np
from numba import njit

import liebody
from bench import core
from liebody._models import dipoles
from liebody.coupled import CoupledBodies, DipoleLattice, thermal_momenta, uniform_orientations

MOMENTS = (1.0, 1.2, 0.4)
DT = 0.005


def settings(quick: bool) -> dict:
    return {"sides": [4, 5] if quick else [4, 8, 16, 24],
            "body_steps": 5e4 if quick else 4e6, "min_steps": 20, "repeat": 2 if quick else 3,
            "check_steps": 50 if quick else 200}


def _lattice(k: int):
    sites = np.stack(np.meshgrid(*[np.arange(float(k))] * 3, indexing="ij"), -1).reshape(-1, 3)
    n = len(sites)
    bodies = liebody.RigidBody.batch(np.tile(MOMENTS, (n, 1)), check_triangle=False)
    lat = DipoleLattice(bodies, sites, [0.0, 0.0, 1.0], cutoff=1.5)
    return lat, uniform_orientations(n, rng=k), thermal_momenta(lat.moments, 1e-3, rng=k + 1)


@njit(cache=True)
def _zero(t, q, L, p, out):
    out[:] = 0.0


@njit(cache=True)
def _axis(q, L, a, rate, tau):
    """The exact flow of rate L_a^2 / 2 about body axis a: L and q turn by rate L_a tau."""
    ang = rate * L[a] * tau
    c, s = math.cos(ang), math.sin(ang)
    b, d = (a + 1) % 3, (a + 2) % 3
    lb, ld = L[b], L[d]
    L[b] = c * lb + s * ld
    L[d] = c * ld - s * lb
    c2, s2 = math.cos(0.5 * ang), math.sin(0.5 * ang)
    w, va, vb, vd = q[0], q[1 + a], q[1 + b], q[1 + d]
    q[0] = c2 * w - s2 * va
    q[1 + a] = c2 * va + s2 * w
    q[1 + b] = c2 * vb + s2 * vd
    q[1 + d] = c2 * vd - s2 * vb


@njit(cache=True)
def strang(q, L, params, h, steps):
    """``steps`` Strang steps kick(h/2) - z y x y z - kick(h/2), end kicks merged."""
    n = q.shape[0]
    out = np.empty((n, 3))
    dipoles.torque(0.0, q, L, params, out)
    for i in range(n):
        L[i] += 0.5 * h * out[i]
    r0, r1, r2 = 1.0 / MOMENTS[0], 1.0 / MOMENTS[1], 1.0 / MOMENTS[2]
    for s in range(steps):
        for i in range(n):
            _axis(q[i], L[i], 2, r2, 0.5 * h)
            _axis(q[i], L[i], 1, r1, 0.5 * h)
            _axis(q[i], L[i], 0, r0, h)
            _axis(q[i], L[i], 1, r1, 0.5 * h)
            _axis(q[i], L[i], 2, r2, 0.5 * h)
        for i in range(n):  # the torque sees unit quaternions, as liebody's
            q[i] /= math.sqrt(q[i, 0] ** 2 + q[i, 1] ** 2 + q[i, 2] ** 2 + q[i, 3] ** 2)
        dipoles.torque(0.0, q, L, params, out)
        f = h if s < steps - 1 else 0.5 * h
        for i in range(n):
            L[i] += f * out[i]


def _best(fn, repeat: int) -> float:
    fn()
    return min(_timed(fn) for _ in range(repeat))


def _timed(fn) -> float:
    t = time.perf_counter()
    fn()
    return time.perf_counter() - t


def run(cfg: dict, progress: core.Progress) -> dict:
    rows = []
    for k in cfg["sides"]:
        lat, q0, L0 = _lattice(k)
        n = lat.n_bodies
        steps = max(cfg["min_steps"], int(cfg["body_steps"] / n))
        free = CoupledBodies(liebody.RigidBody.batch(lat.moments, check_triangle=False), _zero,
                             params=lat.params)
        kw = {"q0": q0, "L0": L0, "dt": DT, "steps": steps, "method": "no_squish",
              "save_every": None}
        t_lb = _best(lambda kw=kw, lat=lat: liebody.integrate(lat, **kw), cfg["repeat"])
        t_free = _best(lambda kw=kw, free=free: liebody.integrate(free, **kw), cfg["repeat"])

        def plain(q0=q0, L0=L0, lat=lat, steps=steps):
            q, L = q0.copy(), L0.copy()
            strang(q, L, lat.params, DT, steps)
            return q, L

        t_plain = _best(plain, cfg["repeat"])
        # the two compute the same map
        ck = cfg["check_steps"]
        a = liebody.integrate(lat, q0=q0, L0=L0, dt=DT, steps=ck, method="no_squish",
                              save_every=None)
        q, L = q0.copy(), L0.copy()
        strang(q, L, lat.params, DT, ck)
        diff = max(float(np.abs(a.L[:, -1] - L).max()),
                   float(np.minimum(np.abs(a.q[:, -1] - q), np.abs(a.q[:, -1] + q)).max()))
        per = 1e9 / (n * steps)
        rows.append({"N": n, "steps": steps, "neighbours": float(lat.params[:, 6].mean()),
                     "liebody_ns": t_lb * per,
                     "free_part_ns": t_free * per, "coupling_ns": (t_lb - t_free) * per,
                     "plain_ns": t_plain * per,
                     "speedup": t_plain / t_lb, "agreement": diff})
        print(f"N = {n}: liebody {t_lb * per:.1f} ns, free part {t_free * per:.1f} ns, "
                      f"plain loop {t_plain * per:.1f} ns per body-step", flush=True)
    return {"rows": rows}


def csv_table(summary: dict):
    keys = ["N", "steps", "neighbours", "liebody_ns", "free_part_ns", "coupling_ns",
            "plain_ns", "speedup", "agreement"]
    return keys, [[r[k] for k in keys] for r in summary["rows"]]


def plot(summary: dict, plt):
    rows = summary["rows"]
    N = [r["N"] for r in rows]
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.loglog(N, [r["liebody_ns"] for r in rows], "o-", label="liebody DipoleLattice")
    ax.loglog(N, [r["free_part_ns"] for r in rows], "s--", label="liebody, free part")
    ax.loglog(N, [r["plain_ns"] for r in rows], "^-", label="plain numba Strang loop")
    ax.set_xlabel("rotors N")
    ax.set_ylabel("ns per body-step")
    ax.set_title("dipolar lattice (18 neighbours), no_squish, one thread")
    ax.legend()
    return fig


def report(summary: dict) -> str:
    lines = ["N       liebody ns  free part ns  plain loop ns  speed-up  agreement"]
    for r in summary["rows"]:
        lines.append(f"{r['N']:<7d} {r['liebody_ns']:10.1f} {r['free_part_ns']:13.1f} "
                     f"{r['plain_ns']:14.1f} {r['speedup']:9.2f}x {r['agreement']:10.1e}")
    return "\n".join(lines)


BENCHMARK = core.Benchmark(name="coupled", settings=settings, run=run, csv=csv_table, plot=plot,
                           report=report)
