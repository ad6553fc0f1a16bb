"""Round-off of one exact-flow step (liebody._kernels.exact) and of many steps in a row.

A splitting that steps the exact free flow between kicks evaluates it once per step,
so what one evaluation adds is what the run accumulates. Here, against an independent
reference, the solution of the free-body equations ``q' = q (0, omega) / 2``,
``m' = m x omega`` by its Taylor series in 40-digit arithmetic (mpmath; the recursion
for the Taylor coefficients of a quadratic vector field, written here):

* one step is accurate to a fraction of an ulp, in rotation and in momentum;
* the errors are unbiased: over thousands of steps, ``|m|^2`` and the energy walk as
  ``sqrt(steps)``, and their mean over many trajectories stays within its statistical
  spread of zero (a bias of 0.2 ulp per step would give a linear drift).
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest

from liebody._kernels.exact import exact_flow, exact_flow_rows

EPS = 2.0**-52
#: (name, moments, |omega| of the orbits) of the bodies checked: a spacecraft that
#: tumbles near its intermediate axis, the Hairer-Vilmart body, the HLW body
BODIES = [
    ("spacecraft", (100.0, 120.0, 80.0)),
    ("hairer-vilmart", (0.6, 0.8, 1.0)),
    ("hlw", (2.0, 1.0, 2.0 / 3.0)),
]


def _states(moments, count, seed):
    """Random unit quaternions and momenta of unit length (random directions: every
    regime of the asymmetric body, near the separatrix included)."""
    rng = np.random.default_rng(seed)
    q = rng.normal(size=(count, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    m = rng.normal(size=(count, 3))
    m /= np.linalg.norm(m, axis=1, keepdims=True)
    if moments[0] == 100.0:  # the spacecraft: most momentum on the intermediate axis
        m[:, 0] += 8.0 * np.sign(m[:, 0])
        m /= np.linalg.norm(m, axis=1, keepdims=True)
    return q, m * 50.0


def _taylor_flow(mp, moments, q, m, t):
    """The free-body flow for time ``t`` by Taylor series in mpmath (the working
    precision set by the caller), in sub-steps of ``|omega| dt <= 0.25``."""
    inv = [1 / mp.mpf(float(v)) for v in moments]
    y = [mp.mpf(float(v)) for v in (*q, *m)]
    rate = max(abs(float(m[i])) / float(moments[i]) for i in range(3)) * 1.8
    nsub = int(abs(t) * rate / 0.25) + 1
    h = mp.mpf(float(t)) / nsub
    tol = mp.mpf(10) ** (-mp.mp.dps - 2)
    for _ in range(nsub):
        coef = [y]
        for k in range(200):  # coefficient k + 1 from the products of coefficients 0..k
            om = [[coef[j][4 + i] * inv[i] for i in range(3)] for j in range(k + 1)]
            fq = [mp.mpf(0)] * 4
            fm = [mp.mpf(0)] * 3
            for j in range(k + 1):
                w, x, yy, z, m1, m2, m3 = coef[j]
                o1, o2, o3 = om[k - j]
                fq[0] += -x * o1 - yy * o2 - z * o3
                fq[1] += w * o1 + yy * o3 - z * o2
                fq[2] += w * o2 + z * o1 - x * o3
                fq[3] += w * o3 + x * o2 - yy * o1
                fm[0] += m2 * o3 - m3 * o2
                fm[1] += m3 * o1 - m1 * o3
                fm[2] += m1 * o2 - m2 * o1
            nxt = [v / (2 * (k + 1)) for v in fq] + [v / (k + 1) for v in fm]
            coef.append(nxt)
            if k > 4 and max(abs(v) for v in nxt) * abs(h) ** (k + 1) < tol:
                break
        y = [sum((c[i] * h**p for p, c in enumerate(coef)), mp.mpf(0)) for i in range(7)]
    return y


@pytest.mark.kernel
@pytest.mark.parametrize("name, moments", BODIES, ids=[b[0] for b in BODIES])
def test_one_step_is_accurate_to_a_fraction_of_an_ulp(name, moments):
    mp = pytest.importorskip("mpmath")
    mp.mp.dps = 40
    q0, m0 = _states(moments, 24, seed=7)
    rot, mom = [], []
    for q, m in zip(q0, m0, strict=True):
        # a step of a splitting: a rotation by about 0.1 rad
        t = 0.1 / np.linalg.norm(m / np.asarray(moments))
        r = exact_flow(*moments, *q, *m, float(t))
        ref = _taylor_flow(mp, moments, q, m, t)
        # rotation error: the vector part of ref^* q, doubled (body frame, radians)
        a = [ref[0], -ref[1], -ref[2], -ref[3]]
        b = [mp.mpf(float(v)) for v in r[:4]]
        vec = (a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
               a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
               a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0])
        rot.append([float(2 * v) / EPS for v in vec])
        g = float(np.linalg.norm(m))
        mom.append([float(mp.mpf(float(r[4 + i])) - ref[4 + i]) / g / EPS for i in range(3)])
    rot, mom = np.abs(rot), np.abs(mom)
    # (the former evaluation: rotation 0.5-0.9 ulp rms, up to 2.5; momentum up to 1.8)
    assert rot.max() <= 1.0, f"{name}: rotation error {rot.max():.2f} ulp"
    assert np.sqrt(np.mean(rot**2)) <= 0.35
    assert mom.max() <= 1.0, f"{name}: momentum error {mom.max():.2f} ulp of |m|"
    assert np.sqrt(np.mean(mom**2)) <= 0.3


def _relative_change(a, b, weights):
    """``(sum w b^2 - sum w a^2) / sum w a^2`` per row, in exact rational arithmetic."""
    out = []
    for ra, rb in zip(a, b, strict=True):
        sa = sum(Fraction(w) * Fraction(v) ** 2 for w, v in zip(weights, ra, strict=True))
        sb = sum(Fraction(w) * Fraction(v) ** 2 for w, v in zip(weights, rb, strict=True))
        out.append(float((sb - sa) / sa))
    return np.array(out)


@pytest.mark.parametrize("name, moments", BODIES[:2], ids=[b[0] for b in BODIES[:2]])
def test_stepping_drifts_as_a_random_walk(name, moments):
    """|m|^2, the energy and |q|^2 over 4 x 800 steps of 64 trajectories: their changes
    are centred on zero and their spread grows as sqrt(steps) (x2 from 800 to 3200
    steps, where a bias would give x4)."""
    count, blocks, per_block = 64, 4, 800
    I = np.asarray(moments)
    q, m = _states(moments, count, seed=11)
    t = 0.1 / np.linalg.norm(m / I, axis=1)
    q_out, m_out = np.empty_like(q), np.empty_like(m)
    start_q, start_m = q.copy(), m.copy()
    spread = {}
    for block in range(blocks):
        for _ in range(per_block):
            exact_flow_rows(I, q, m, t, q_out, m_out)
            q, q_out = q_out, q
            m, m_out = m_out, m
        steps = (block + 1) * per_block
        if block in (0, blocks - 1):
            changes = {"|m|^2": _relative_change(start_m, m, (1.0, 1.0, 1.0)),
                       "energy": _relative_change(start_m, m, 1.0 / I),
                       "|q|^2": _relative_change(start_q, q, (1.0,) * 4)}
            for key, c in changes.items():
                c = c / EPS
                mean, sd = float(np.mean(c)), float(np.std(c))
                # centred: the mean within 4 standard errors (plus the grid of |q|^2,
                # whose granularity near 1 is an ulp)
                assert abs(mean) <= 4.0 * sd / np.sqrt(count) + 1.0, \
                    f"{name} {key}: mean change {mean:.1f} ulp after {steps} steps (sd {sd:.1f})"
                spread[key, steps] = sd
    for key in ("|m|^2", "energy"):
        ratio = spread[key, blocks * per_block] / spread[key, per_block]
        assert ratio < 3.0, f"{name} {key}: spread grew x{ratio:.2f} over x4 steps"
        assert spread[key, blocks * per_block] <= 1.0 * np.sqrt(blocks * per_block), \
            f"{name} {key}: {spread[key, blocks * per_block]:.1f} ulp after " \
            f"{blocks * per_block} steps"
