"""Cost per step of every method, side by side with a plain C ``splitting2``.

Run: ``python bench/step_cost.py [--steps N]``. It writes a small C implementation
of the symmetric 5-rotation splitting (the same algorithm and axis ordering that
``integrate(method="splitting2")`` uses: exact axis sub-flows applied to ``m`` and
``q``, end rotations merged), compiles it with the system's ``gcc -O3``, and times
it in the same process, on the same body and state, as every liebody method run
through the public ``integrate()``. It reports ns per step and the ratio to C.

Target (issue #3): ``splitting2`` through ``integrate()`` within 1.25x of the C code.
Timings are never asserted in the tests; this script is where they are measured.
"""

from __future__ import annotations

import argparse
import ctypes
import shutil
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

import liebody
from liebody import registry

C_SOURCE = r"""
#include <math.h>

/* exact flow of T_k = m_k^2/(2 I_k) for time tau: m <- R_k(theta)^T m, q <- q (c, s e_k) */
static inline void axis_flow(double *q, double *m, int k, double rate, double tau) {
    double half = 0.5 * tau * rate * m[k];
    double s2 = sin(half), c2 = cos(half);
    double c = 1.0 - 2.0 * s2 * s2, s = 2.0 * s2 * c2;
    int i = (k + 1) % 3, j = (k + 2) % 3;
    double mi = m[i], mj = m[j];
    m[i] = c * mi + s * mj;
    m[j] = c * mj - s * mi;
    double w = q[0], x = q[1], y = q[2], z = q[3];
    if (k == 0) {
        q[0] = c2 * w - s2 * x; q[1] = c2 * x + s2 * w; q[2] = c2 * y + s2 * z; q[3] = c2 * z - s2 * y;
    } else if (k == 1) {
        q[0] = c2 * w - s2 * y; q[1] = c2 * x - s2 * z; q[2] = c2 * y + s2 * w; q[3] = c2 * z + s2 * x;
    } else {
        q[0] = c2 * w - s2 * z; q[1] = c2 * x + s2 * y; q[2] = c2 * y - s2 * x; q[3] = c2 * z + s2 * w;
    }
}

/* n steps of a-b-c-b-a with the trailing a(h/2) merged into the next leading a(h/2) */
void splitting2(double *state, const int *order, const double *moments, double h, long n) {
    double q[4] = {state[0], state[1], state[2], state[3]};
    double m[3] = {state[4], state[5], state[6]};
    int a = order[0], b = order[1], c = order[2];
    double ra = 1.0 / moments[a], rb = 1.0 / moments[b], rc = 1.0 / moments[c];
    axis_flow(q, m, a, ra, 0.5 * h);
    for (long s = 0; s < n; ++s) {
        axis_flow(q, m, b, rb, 0.5 * h);
        axis_flow(q, m, c, rc, h);
        axis_flow(q, m, b, rb, 0.5 * h);
        axis_flow(q, m, a, ra, s == n - 1 ? 0.5 * h : h);
    }
    for (int i = 0; i < 4; ++i) state[i] = q[i];
    for (int i = 0; i < 3; ++i) state[4 + i] = m[i];
}
"""


def build_c(workdir: Path) -> ctypes.CDLL:
    gcc = shutil.which("gcc") or shutil.which("cc")
    if gcc is None:
        raise SystemExit("gcc not found: the C reference cannot be built")
    src = workdir / "splitting2.c"
    lib = workdir / "libsplitting2.so"
    src.write_text(C_SOURCE)
    subprocess.run([gcc, "-O3", "-shared", "-fPIC", str(src), "-o", str(lib), "-lm"],
                   check=True)
    dll = ctypes.CDLL(str(lib))
    dll.splitting2.argtypes = [ctypes.POINTER(ctypes.c_double), ctypes.POINTER(ctypes.c_int),
                               ctypes.POINTER(ctypes.c_double), ctypes.c_double,
                               ctypes.c_long]
    dll.splitting2.restype = None
    return dll


def best_of(fn, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=2_000_000)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args(argv)
    n = args.steps

    body = liebody.RigidBody([2.0, 1.0, 2.0 / 3.0], check_triangle=False)  # HLW body
    scene = liebody.FreeBody(body)
    L0 = np.array([np.cos(1.1), 0.0, np.sin(1.1)])
    h = 0.01
    order, _ = registry.best_axis_ordering(body.moments, L0)

    with tempfile.TemporaryDirectory() as tmp:
        dll = build_c(Path(tmp))
        state = np.concatenate([[1.0, 0.0, 0.0, 0.0], L0])
        order_c = (ctypes.c_int * 3)(*order)
        moments_c = (ctypes.c_double * 3)(*body.moments)

        def run_c():
            s = state.copy()
            dll.splitting2(s.ctypes.data_as(ctypes.POINTER(ctypes.c_double)), order_c,
                           moments_c, h, n)
            return s

        c_state = run_c()
        t_c = best_of(run_c, args.repeat)

    # same algorithm, same answer (a check that we time the same thing)
    ours = liebody.integrate(scene, L0=L0, dt=h, steps=n, method="splitting2", save_every=n)
    diff = max(np.abs(ours.L[-1] - c_state[4:]).max(), np.abs(ours.q[-1] - c_state[:4]).max())

    c_ns = 1e9 * t_c / n
    print(f"HLW body I = (2, 1, 2/3), h = {h}, {n} steps, best of {args.repeat}; "
          f"axis ordering {order}")
    print(f"C gcc -O3 splitting2: {c_ns:7.1f} ns/step  (|liebody - C| at the end: {diff:.1e})")
    print(f"{'method':12s} {'ns/step':>10s} {'x C splitting2':>15s}")
    for m in liebody.methods():
        steps = n if m.family != "exact" else max(n // 20, 1)
        save = steps if m.family != "exact" else 1  # exact: one evaluation per output sample

        def run_py(name=m.name, steps=steps, save=save):
            return liebody.integrate(scene, L0=L0, dt=h, steps=steps, method=name,
                                     save_every=save)

        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            first = run_py()  # compile / load the cache
            t = best_of(run_py, args.repeat)
        label = m.name + (" (per sample)" if m.family == "exact" else "")
        if first.failed_at is not None:
            done = round(first.failed_at / h)
            print(f"{label:12s} {'blew up':>10s}   (non-finite after {done} steps, as expected)")
            continue
        ns = 1e9 * t / steps
        print(f"{label:12s} {ns:10.1f} {ns / c_ns:15.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
