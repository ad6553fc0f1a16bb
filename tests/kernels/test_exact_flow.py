"""Exact free-rigid-body flow (liebody._kernels.exact) in every regime.

References: 34-digit values (mpmath Taylor ODE solver, computed once and pasted here,
so CI needs no mpmath), reference values for the standard test bodies computed
independently of liebody (DOP853 at rtol 1e-13, cross-checked with an eighth-order
composition; docs/references.md), and scipy's DOP853
(rtol 1e-13, atol 1e-15) on the 7-dimensional system; plus identities (group
property, time reversal, invariants, permutation equivariance, Dzhanibekov period).

Marked ``kernel``: CI also runs this module with ``NUMBA_DISABLE_JIT=1``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation
from scipy.special import ellipkm1

from liebody._kernels.exact import (
    K_ELLIPTIC,
    K_SEPARATRIX,
    K_STEADY,
    K_SYMMETRIC,
    PLAN_SIZE,
    exact_flow,
    exact_flow_eval,
    exact_flow_plan,
    exact_flow_rows,
    exact_flow_times,
)

pytestmark = pytest.mark.kernel

C11, S11 = math.cos(1.1), math.sin(1.1)
QG = (0.5360562674188974, -0.32163376045133846, 0.7504787743864564, 0.214422506967559)
HLW = ((2.0, 1.0, 2.0 / 3.0), (C11, 0.0, S11))


def flow(I, q, m, t):
    r = exact_flow(I[0], I[1], I[2], q[0], q[1], q[2], q[3], m[0], m[1], m[2], float(t))
    return np.array(r[:4]), np.array(r[4:])


def qdist(a, b):
    """Distance of unit quaternions up to sign."""
    return min(np.abs(np.asarray(a) - b).max(), np.abs(np.asarray(a) + b).max())


def kind(I, q, m):
    plan = np.empty(PLAN_SIZE)
    exact_flow_plan(I[0], I[1], I[2], *q, *m, plan)
    return plan[0]


def _rhs(t, y, inv_i):
    w, x, yy, z = y[:4]
    m = y[4:]
    o = m * inv_i
    return np.array([
        0.5 * (-x * o[0] - yy * o[1] - z * o[2]),
        0.5 * (w * o[0] + yy * o[2] - z * o[1]),
        0.5 * (w * o[1] - x * o[2] + z * o[0]),
        0.5 * (w * o[2] + x * o[1] - yy * o[0]),
        m[1] * o[2] - m[2] * o[1],
        m[2] * o[0] - m[0] * o[2],
        m[0] * o[1] - m[1] * o[0],
    ])


def dop853(I, q0, m0, ts):
    """Reference by DOP853 on (q, m) in R^7, nothing normalised."""
    ts = np.asarray(ts, float)
    sol = solve_ivp(_rhs, (0.0, ts[-1]), np.concatenate([q0, m0]), method="DOP853",
                    rtol=1e-13, atol=1e-15, t_eval=ts, args=(1.0 / np.asarray(I, float),))
    assert sol.success
    return sol.y.T


# ---------------------------------------------------------------------------------------
# high-precision references (mpmath odefun, 34 digits; inputs are the exact floats shown)
# ---------------------------------------------------------------------------------------
M_SADDLE_PLUS = (0.001, 1.9999989996997498, 0.0017323971830963015)  # Delta_2 = +1e-10 G^2
M_SADDLE_MINUS = (0.001, 1.99999900029975, 0.0017317043627594175)  # Delta_2 = -1e-10 G^2
MP_REFS = [
    ("hlw", HLW[0], (1.0, 0.0, 0.0, 0.0), HLW[1], 10.0,
     (0.7651110308293111, 0.3743195514832238, 0.10285413145504164, 0.5137226990540092,
      0.4070661365880411, 0.2830074268128431, 0.8684491676615619)),
    ("hlw", HLW[0], (1.0, 0.0, 0.0, 0.0), HLW[1], 100.0,
     (0.8870943102642873, -0.2616786950327893, 0.22583910742775548, 0.3059160715276324,
      -0.17734831387498012, -0.5904185243334233, 0.7873712857919346)),
    ("hairer-vilmart", (0.6, 0.8, 1.0), QG, (1.8, 0.4, -0.9), 50.0,
     (0.1650933155274183, -0.06197504023711238, 0.8873233408786881, 0.42609926107382085,
      1.6609810971375483, -1.2012679911401918, -0.08998337854156792)),
    ("flat", (0.345, 0.653, 1.0), QG, (1.8, 0.4, -0.9), 50.0,
     (-0.1166944774738038, -0.6285245233210273, 0.21576961449940857, 0.7380940292198332,
      1.8105645470569796, 0.1540132087413481, 0.9529616741892344)),
    ("near-separatrix", (1.0, 2.0, 3.0), QG, (1e-06, 2.0, 1e-06), 60.0,
     (-0.31593683243108867, 0.5068234688753643, 0.22273585527848255, 0.7705210107997806,
      9.770162674545238e-06, -1.999999999905544, 1.6863221402247875e-05)),
    ("delta2=+1e-10", (1.0, 2.0, 3.0), QG, M_SADDLE_PLUS, 40.0,
     (-0.3868293035320724, 0.005323946229771516, 0.01684364499006887, 0.9219821240939994,
      -0.003736779361666532, -1.9999860361312547, 0.006472384413284706)),
    ("delta2=-1e-10", (1.0, 2.0, 3.0), QG, M_SADDLE_MINUS, 40.0,
     (0.3850870652916791, -0.006544186762793597, -0.013870032112462223, -0.9227528097891955,
      0.0037360855991051935, -1.999986041915689, -0.006470997358330757)),
    ("separatrix", (1.0, 1.5, 3.0), QG, (0.3, 1.0, 0.3), 30.0,
     (0.634422404652532, 0.07430725003199312, -0.6909255798200876, 0.3385387543810274,
      5.985141741759645e-06, 1.0862780490870447, 5.985141741759645e-06)),
    ("near-symmetric", (1.0, 1.000001, 2.0), QG, (0.9, 0.4, 0.0001), 10.0,
     (0.12368515313791605, -0.46145019525172265, -0.2465942253119113, 0.843182654137415,
      0.8998034929853267, 0.40044184935987126, 9.63983986894974e-05)),
]


@pytest.mark.parametrize("case", MP_REFS, ids=[f"{c[0]}-t{c[4]:g}" for c in MP_REFS])
def test_high_precision_reference(case):
    _, I, q0, m0, t, ref = case
    q, m = flow(I, q0, m0, t)
    g = np.linalg.norm(m0)
    omt = np.linalg.norm(np.asarray(m0) / I) * t
    tol = 2e-15 * max(1.0, omt / 10.0)  # round-off, then |omega t| eps phase error
    assert np.abs(m - ref[4:]).max() / g < tol
    assert qdist(q, ref[:4]) < tol


def test_literature_values():
    """Reference values at t = 10 (12 digits) for the HLW, Hairer–Vilmart and flat bodies.

    Computed independently of liebody (not published values): DOP853 at rtol 1e-13,
    cross-checked with an eighth-order composition to 5e-14.
    """
    q, m = flow(HLW[0], (1.0, 0.0, 0.0, 0.0), HLW[1], 10.0)
    assert np.allclose(m, [0.407066136588, 0.283007426813, 0.868449167662], rtol=0, atol=1e-12)
    assert qdist(q, [0.765111030829, 0.374319551483, 0.102854131455, 0.513722699054]) < 1e-12
    q, m = flow((0.6, 0.8, 1.0), (1.0, 0.0, 0.0, 0.0), (1.8, 0.4, -0.9), 10.0)
    assert np.allclose(m, [1.765962508518, -0.695464197033, 0.779554981482], rtol=0, atol=1e-12)
    assert qdist(q, [-0.736061364161, -0.570786951240, -0.299388571831, -0.206839086105]) < 1e-12
    q, m = flow((0.345, 0.653, 1.0), (1.0, 0.0, 0.0, 0.0), (1.8, 0.4, -0.9), 10.0)
    assert np.allclose(m, [1.805748694153, -0.293159070052, 0.929155214811], rtol=0, atol=1e-12)
    assert qdist(q, [-0.590953130060, 0.749777146604, -0.277567350599, -0.107540663867]) < 1e-12


# ---------------------------------------------------------------------------------------
# DOP853 in every regime
# ---------------------------------------------------------------------------------------
DOP_CASES = [
    ("hlw", HLW[0], HLW[1], K_ELLIPTIC),
    ("hairer-vilmart", (0.6, 0.8, 1.0), (1.8, 0.4, -0.9), K_ELLIPTIC),
    ("flat", (0.345, 0.653, 1.0), (1.8, 0.4, -0.9), K_ELLIPTIC),
    ("about-largest", (1.0, 2.0, 3.0), (0.3, 0.5, 2.0), K_ELLIPTIC),
    ("about-smallest", (1.0, 2.0, 3.0), (2.0, 0.5, 0.3), K_ELLIPTIC),
    ("near-separatrix", (1.0, 2.0, 3.0), (1e-6, 2.0, 1e-6), K_ELLIPTIC),
    ("delta2=+1e-10", (1.0, 2.0, 3.0), M_SADDLE_PLUS, K_ELLIPTIC),
    ("delta2=-1e-10", (1.0, 2.0, 3.0), M_SADDLE_MINUS, K_ELLIPTIC),
    ("separatrix", (1.0, 1.5, 3.0), (0.3, 1.0, 0.3), K_SEPARATRIX),
    ("separatrix-neg", (1.0, 1.5, 3.0), (-0.3, 1.0, 0.3), K_SEPARATRIX),
    ("unsorted-231", (2.0 / 3.0, 2.0, 1.0), (S11, C11, 0.0), K_ELLIPTIC),
    ("unsorted-312", (1.0, 2.0 / 3.0, 2.0), (0.0, S11, C11), K_ELLIPTIC),
    ("unsorted-213", (1.0, 2.0, 2.0 / 3.0), (0.0, C11, S11), K_ELLIPTIC),
    ("near-axis-1", (1.0, 2.0, 3.0), (1.0, 1e-9, -1e-9), K_ELLIPTIC),
    ("near-symmetric", (1.0, 1.0 + 1e-9, 2.0), (0.3, -0.5, 0.8), K_ELLIPTIC),
    ("symmetric-oblate", (1.0, 1.0, 2.0), (0.3, -0.5, 0.8), K_SYMMETRIC),
    ("symmetric-prolate", (2.0, 1.0, 2.0), (0.3, -0.5, 0.8), K_SYMMETRIC),
    ("symmetric-x", (0.5, 1.5, 1.5), (0.3, -0.5, 0.8), K_SYMMETRIC),
    ("spherical", (1.5, 1.5, 1.5), (0.3, -0.5, 0.8), K_STEADY),
    ("steady-1", (1.0, 2.0, 3.0), (0.7, 0.0, 0.0), K_STEADY),
    ("steady-2-unstable", (1.0, 2.0, 3.0), (0.0, -0.7, 0.0), K_STEADY),
    ("steady-3", (3.0, 2.0, 1.0), (0.0, 0.0, 0.7), K_STEADY),
]


@pytest.mark.parametrize("case", DOP_CASES, ids=[c[0] for c in DOP_CASES])
def test_against_dop853(case):
    _, I, m0, expected_kind = case
    assert kind(I, QG, m0) == expected_kind
    ts = np.array([0.7, 3.0, 9.0, 20.0])
    ref = dop853(I, np.array(QG), np.array(m0, float), ts)
    g = np.linalg.norm(m0)
    for t, y in zip(ts, ref, strict=True):
        q, m = flow(I, QG, m0, t)
        assert np.abs(m - y[4:]).max() / g < 3e-12
        assert qdist(q, y[:4]) < 3e-12


def test_steady_rotations_exact():
    I = (1.0, 2.0, 3.0)
    for ax in range(3):
        m0 = np.zeros(3)
        m0[ax] = 0.7
        q, m = flow(I, (1.0, 0.0, 0.0, 0.0), m0, 10.0)
        assert np.array_equal(m, m0)  # the unstable axis included
        ang = 10.0 * 0.7 / I[ax]
        ref = np.zeros(4)
        ref[0], ref[1 + ax] = math.cos(ang / 2), math.sin(ang / 2)
        assert qdist(q, ref) < 1e-15


def test_zero_and_tiny_momentum():
    q, m = flow(HLW[0], QG, (0.0, 0.0, 0.0), 123.0)
    assert np.array_equal(q, QG) and np.all(m == 0.0)
    # scaling: flow(alpha m, t / alpha) = (q(t), alpha m(t)), down to 1e-300
    q1, m1 = flow(HLW[0], QG, HLW[1], 7.0)
    for alpha in (1e-300, 1e-150, 1e-8, 1e8, 1e150):
        q, m = flow(HLW[0], QG, alpha * np.array(HLW[1]), 7.0 / alpha)
        assert np.abs(m / alpha - m1).max() < 1e-15
        assert qdist(q, q1) < 1e-14


def test_zero_time_and_continuity():
    for I, m0 in [(c[1], c[2]) for c in DOP_CASES]:
        q, m = flow(I, QG, m0, 0.0)
        assert np.abs(q - QG).max() < 4e-16  # continuous branch: +q0, not -q0
        assert np.abs(m - m0).max() <= 1e-15 * np.linalg.norm(m0)
        om = np.linalg.norm(np.asarray(m0) / I)
        qs = np.array([flow(I, QG, m0, t)[0] for t in np.linspace(-6, 6, 121) / om])
        assert np.abs(np.diff(qs, axis=0)).max() < 0.2  # no sign flips along the orbit


# ---------------------------------------------------------------------------------------
# identities
# ---------------------------------------------------------------------------------------
WELL_CONDITIONED = [
    (HLW[0], HLW[1]),
    ((0.6, 0.8, 1.0), (1.8, 0.4, -0.9)),
    ((0.345, 0.653, 1.0), (1.8, 0.4, -0.9)),
    ((3.0, 1.0, 2.0), (0.3, 1.1, -0.8)),
    ((1.0, 1.0, 2.0), (0.3, -0.5, 0.8)),
    ((1.0, 1.5, 3.0), (0.3, 1.0, 0.3)),  # separatrix branch
]


@pytest.mark.parametrize("I, m0", WELL_CONDITIONED)
def test_time_reversal_and_group_property(I, m0):
    rng = np.random.default_rng(11)
    g = np.linalg.norm(m0)
    om = np.linalg.norm(np.asarray(m0) / I)
    for _ in range(8):
        t, s = rng.uniform(-40.0, 40.0, 2)
        tol = 2e-15 + 8e-16 * om * (abs(t) + abs(s))  # round-off + |omega t| eps phase
        q1, m1 = flow(I, QG, m0, t)
        qb, mb = flow(I, q1, m1, -t)
        assert np.abs(mb - m0).max() / g < tol and qdist(qb, QG) < tol
        qa, ma = flow(I, QG, m0, t + s)
        q2, m2 = flow(I, q1, m1, s)
        assert np.abs(ma - m2).max() / g < tol and qdist(qa, q2) < tol


def test_group_property_near_separatrix_is_conditioning_limited():
    """Rounding the intermediate state moves it to a neighbouring orbit: for
    Delta_2 ~ 2.5e-13 G^2 the composition differs by ~1e-9 (the problem's own
    sensitivity, not the kernel's); time reversal from the saddle region is still exact."""
    I, m0 = (1.0, 2.0, 3.0), (1e-6, 2.0, 1e-6)
    q1, m1 = flow(I, QG, m0, 11.0)
    q2, m2 = flow(I, q1, m1, 13.0)
    qa, ma = flow(I, QG, m0, 24.0)
    assert np.abs(ma - m2).max() < 1e-8 and qdist(qa, q2) < 1e-8
    q1, m1 = flow(I, QG, m0, 3.0)  # still near the saddle: well conditioned
    qb, mb = flow(I, q1, m1, -3.0)
    assert np.abs(mb - m0).max() < 1e-15 and qdist(qb, QG) < 1e-15


def _rot(q):
    return Rotation.from_quat([q[1], q[2], q[3], q[0]]).as_matrix()


@pytest.mark.parametrize("I", [(2.0, 1.0, 2.0 / 3.0), (0.345, 0.653, 1.0), (3.0, 1.0, 2.0),
                               (1.0, 2.0, 3.0), (1.0, 1.0, 2.0), (1.0, 1.0 + 1e-7, 2.0)])
def test_invariants_long_times(I):
    I = np.array(I)
    rng = np.random.default_rng(5)
    for _ in range(6):
        m0 = rng.normal(size=3) * 10.0 ** rng.uniform(-3, 3)
        q0 = rng.normal(size=4)
        q0 /= np.linalg.norm(q0)
        g = np.linalg.norm(m0)
        e0 = (m0**2 / I).sum()
        l0 = _rot(q0) @ m0
        om = np.linalg.norm(m0 / I)
        for t in (17.3 / om, 1e3 / om, -1e3 / om):
            q, m = flow(I, q0, m0, t)
            assert abs(np.linalg.norm(m) - g) / g < 5e-15
            assert abs((m**2 / I).sum() - e0) / e0 < 8e-15
            assert np.abs(_rot(q) @ m - l0).max() / g < 5e-15
            assert abs(np.linalg.norm(q) - 1.0) < 1e-15


PROPER_PERMS = [np.array(p, float) for p in (
    [[0, 1, 0], [0, 0, 1], [1, 0, 0]],  # cyclic
    [[0, 0, 1], [1, 0, 0], [0, 1, 0]],  # cyclic
    [[0, 1, 0], [1, 0, 0], [0, 0, -1]],  # transposition with a sign flip
    [[-1, 0, 0], [0, 0, 1], [0, 1, 0]],
)]


@pytest.mark.parametrize("P", PROPER_PERMS, ids=["cyc1", "cyc2", "swap12", "swap23"])
@pytest.mark.parametrize("I, m0", [(HLW[0], HLW[1]), ((1.0, 2.0, 3.0), (1e-6, 2.0, 1e-6)),
                                   ((1.0, 1.5, 3.0), (0.3, 1.0, 0.3)),
                                   ((1.0, 1.0, 2.0), (0.3, -0.5, 0.8))])
def test_relabelled_body_gives_relabelled_answer(P, I, m0):
    """Body axes relabelled by a proper rotation P: I' = I o perm, m' = P m, q' = q p*."""
    I, m0 = np.array(I), np.array(m0)
    perm = np.abs(P).argmax(axis=1)  # (P v)_i = +-v_perm[i]
    I2 = I[perm]
    pq = Rotation.from_matrix(P).as_quat()  # scalar last
    p = np.array([pq[3], pq[0], pq[1], pq[2]])

    def mul(a, b):
        return np.array([a[0] * b[0] - a[1:] @ b[1:],
                         *(a[0] * b[1:] + b[0] * a[1:] + np.cross(a[1:], b[1:]))])

    pc = p * [1, -1, -1, -1]
    q02 = mul(np.array(QG), pc)
    for t in (0.9, 25.0):
        q, m = flow(I, QG, m0, t)
        q2, m2 = flow(I2, q02, P @ m0, t)
        assert np.abs(m2 - P @ m).max() < 1e-15 * np.linalg.norm(m0) * (1 + t)
        assert qdist(q2, mul(q, pc)) < 1e-15 * (1 + t)


def test_near_symmetric_is_continuous():
    """Moments equal within SYM_RTOL take the trig-only branch; slightly above it the
    elliptic branch agrees with it to ~delta |omega t|."""
    m0 = (0.3, -0.5, 0.8)
    qs, ms = flow((1.0, 1.0, 2.0), QG, m0, 10.0)
    for delta in (1e-15, 1e-13, 1e-10):
        I = (1.0, 1.0 + delta, 2.0)
        q, m = flow(I, QG, m0, 10.0)
        assert np.abs(m - ms).max() < 20 * delta + 1e-15
        assert qdist(q, qs) < 20 * delta + 1e-15
    assert kind((1.0, 1.0 + 2e-16, 2.0), QG, m0) == K_SYMMETRIC
    assert kind((1.0, 1.0 + 1e-13, 2.0), QG, m0) == K_ELLIPTIC


def test_separatrix_limit_from_both_sides():
    """Delta_2 -> 0 from both sides: elliptic branch approaches the separatrix branch."""
    I = (1.0, 1.5, 3.0)
    q0, m0 = flow(I, QG, (0.3, 1.0, 0.3), 8.0)
    for eps in (1e-9, -1e-9, 1e-13, -1e-13):
        m = (0.3, 1.0, 0.3 * (1 + eps))
        assert kind(I, QG, m) == K_ELLIPTIC
        q, mm = flow(I, QG, m, 8.0)
        assert np.abs(mm - m0).max() < 1e3 * abs(eps)
        assert qdist(q, q0) < 1e3 * abs(eps)


def test_dzhanibekov_period():
    """Landau & Lifshitz §37: I = (1, 2, 3), m0 = (1e-2, 2, 1e-2); period 4 K(k)/nu = 42.913457."""
    I = np.array([1.0, 2.0, 3.0])
    m0 = np.array([1e-2, 2.0, 1e-2])
    i1, i2, i3 = I
    g2 = m0 @ m0
    e2 = (m0**2 / I).sum()
    assert g2 < e2 * i2  # circulates about axis 1
    nu = math.sqrt((i2 - i1) * (e2 * i3 - g2) / (i1 * i2 * i3))
    # Leroy's cancellation-free complementary parameter 1 - k^2 = Delta_2 I31 / (Delta_3 I21)
    d2 = m0[0] ** 2 * (i2 - i1) / i1 - m0[2] ** 2 * (i3 - i2) / i3
    d3 = m0[0] ** 2 * (i3 - i1) / i1 + m0[1] ** 2 * (i3 - i2) / i2
    period = 4.0 * ellipkm1(d2 * (i3 - i1) / (d3 * (i2 - i1))) / nu
    assert period == pytest.approx(42.913457, abs=5e-7)
    _, m = flow(I, QG, m0, period)
    assert np.abs(m - m0).max() < 1e-12
    _, m = flow(I, QG, m0, period / 2)  # half a period: m2 flipped
    assert np.abs(m - [m0[0], -m0[1], -m0[2]]).max() < 1e-12


# ---------------------------------------------------------------------------------------
# plan / batch forms
# ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("I, m0", [(c[1], c[2]) for c in DOP_CASES[::3]])
def test_times_and_rows_match_single_calls(I, m0):
    I = np.array(I, float)
    m0 = np.array(m0, float)
    q0 = np.array(QG)
    t = np.array([0.0, 0.3, -2.0, 17.0, 450.0, -3000.0])
    qo = np.empty((t.size, 4))
    mo = np.empty((t.size, 3))
    exact_flow_times(I, q0, m0, t, qo, mo)
    plan = np.empty(PLAN_SIZE)
    exact_flow_plan(I[0], I[1], I[2], *q0, *m0, plan)
    g = np.linalg.norm(m0)
    for i, ti in enumerate(t):
        q, m = flow(I, q0, m0, ti)
        tol = 1e-15 * (2 + np.linalg.norm(m0 / I) * abs(ti))
        assert np.abs(mo[i] - m).max() / g < tol and qdist(qo[i], q) < tol
        r = np.array(exact_flow_eval(plan, ti))
        assert np.array_equal(r[:4], qo[i]) and np.array_equal(r[4:], mo[i])
    qr = np.empty((t.size, 4))
    mr = np.empty((t.size, 3))
    exact_flow_rows(I, np.tile(q0, (t.size, 1)), np.tile(m0, (t.size, 1)), t, qr, mr)
    for i, ti in enumerate(t):
        q, m = flow(I, q0, m0, ti)
        assert np.array_equal(qr[i], q) and np.array_equal(mr[i], m)
