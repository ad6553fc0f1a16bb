"""Error against cost for every method (a work-precision chart).

Run: ``python bench/work_precision.py [--body hlw|hv|flat] [--plot FILE.png]``.

For each registered stepping method and a ladder of step sizes, integrate the free
body to ``t_end`` and measure the final-state error against the exact flow (itself
checked against DOP853 at rtol 1e-13 in the tests), the worst energy error along
the run, and the wall time per run (best of 3). Prints a table and, with
``--plot``, draws error against time (log-log), one line per method.
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

import liebody

BODIES = {
    # literature section 8
    "hlw": ([2.0, 1.0, 2.0 / 3.0], [np.cos(1.1), 0.0, np.sin(1.1)]),
    "hv": ([0.6, 0.8, 1.0], [1.8, 0.4, -0.9]),
    "flat": ([0.345, 0.653, 1.0], [1.8, 0.4, -0.9]),
}


def measure(scene, L0, name, h, t_end):
    n = round(t_end / h)
    ref = liebody.integrate(scene, L0=L0, dt=t_end, steps=1)

    def go():
        return liebody.integrate(scene, L0=L0, dt=t_end / n, steps=n, method=name,
                                 save_every=max(1, n // 100))

    go()
    best = np.inf
    for _ in range(3):
        t0 = time.perf_counter()
        tr = go()
        best = min(best, time.perf_counter() - t0)
    dq = min(np.abs(tr.q[-1] - ref.q[-1]).max(), np.abs(tr.q[-1] + ref.q[-1]).max())
    err = max(np.abs(tr.L[-1] - ref.L[-1]).max() / np.linalg.norm(L0), dq)
    dE = np.abs(tr.energy - tr.energy[0]).max() / tr.energy[0]
    return best, err, dE


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="error against cost, every method")
    parser.add_argument("--body", choices=sorted(BODIES), default="hlw")
    parser.add_argument("--t-end", type=float, default=100.0)
    parser.add_argument("--plot", metavar="FILE", default=None)
    args = parser.parse_args(argv)
    moments, L0 = BODIES[args.body]
    scene = liebody.FreeBody(liebody.RigidBody(moments, check_triangle=False))
    L0 = np.asarray(L0, dtype=float)

    results: dict[str, list[tuple[float, float, float, float]]] = {}
    print(f"body {args.body}: I = {moments}, L0 = {L0.tolist()}, t_end = {args.t_end}")
    print(f"{'method':12s} {'h':>8s} {'time [s]':>10s} {'error':>10s} {'max dE/E':>10s}")
    for m in liebody.methods():
        if m.family == "exact":
            continue
        rows = []
        for h in (0.4, 0.2, 0.1, 0.05, 0.025, 0.0125, 0.00625, 0.003125):
            if m.family == "baseline" and m.order == 1 and h > 0.05:
                continue
            t, err, dE = measure(scene, L0, m.name, h, args.t_end)
            rows.append((h, t, err, dE))
            print(f"{m.name:12s} {h:8.5f} {t:10.2e} {err:10.2e} {dE:10.2e}")
            if err < 1e-13:
                break
        results[m.name] = rows

    if args.plot:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(8, 6))
        colors = plt.get_cmap("tab20").colors
        for k, (name, rows) in enumerate(results.items()):
            r = np.array(rows)
            fam = liebody.methods()[name].family
            style = "--" if fam == "baseline" else "-"
            ax.loglog(r[:, 1], np.maximum(r[:, 2], 1e-16), style, marker="o", ms=3,
                      color=colors[(2 * k) % 20 + (k >= 10)], label=name)
        ax.set_xlabel("wall time per run [s]")
        ax.set_ylabel(f"final error at t = {args.t_end:g} (max of |dL|/|L|, |dq|)")
        ax.set_title(f"Work-precision, free rigid body ({args.body}: I = "
                     f"{np.round(moments, 3).tolist()})")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8, ncol=2)
        fig.tight_layout()
        fig.savefig(args.plot, dpi=120)
        print(f"wrote {args.plot}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
