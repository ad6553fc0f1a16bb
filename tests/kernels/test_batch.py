"""The SIMD ensemble drivers (``liebody._kernels.batch``) against the scalar batch drivers
and the one-body ``integrate()``: every supported family and method, slices, saves,
merged ends, per-body failures, diagnostics, the fast sin/cos, vectorisation, and the
norms over 1e8 steps (long).

The rotation families differ from the scalar path by round-off (polynomial sin/cos,
FMA contraction); the DMV family repeats the scalar arithmetic and agrees bit for bit.
"""

from __future__ import annotations

import dataclasses
import math
import os
import platform
import re
from fractions import Fraction

import numpy as np
import pytest

import liebody
from liebody import quaternion
from liebody._kernels import stages as S
from liebody._kernels.batch import (
    SIMD_FAMILIES,
    SIMD_RUNNERS,
    simd_supports,
)
from liebody._kernels.batch_drivers import BATCH_RUNNERS, DIAG_BATCH_RUNNERS
from liebody._kernels.trig import sincos_array, sincos_plain_array

JIT = os.environ.get("NUMBA_DISABLE_JIT") != "1"
EPS = np.finfo(float).eps


# ------------------------------------------------------------------ set-up


def asym_body():
    return liebody.RigidBody([0.6, 0.8, 1.0])


def hlw_scene():
    return liebody.FreeBody(liebody.RigidBody([2.0, 1.0, 2.0 / 3.0], check_triangle=False))


def top_scene(mass=20.0):
    return liebody.HeavyTop(liebody.RigidBody([5.0, 5.0, 1.0]), mass, [0.0, 0.0, 1.0], g=1.0)


def bodies(n, L, seed=0, spread=1e-3, q_spread=None):
    """``n`` bodies near one orbit (one plan group): random orientations (or near the
    identity), momenta ``L`` perturbed by ``spread``."""
    rng = np.random.default_rng(seed)
    if q_spread is None:
        q0 = quaternion.normalize(rng.normal(size=(n, 4)))
    else:
        q0 = quaternion.normalize(np.r_[1.0, 0, 0, 0] + q_spread * rng.normal(size=(n, 4)))
    L0 = np.asarray(L, dtype=float) * (1.0 + spread * rng.normal(size=(n, 3)))
    return q0, L0


def one_plan(scene, method, L0, h):
    groups = liebody.methods()[method].plans(scene, L0, h)
    assert len(groups) == 1, [len(g[0]) for g in groups]
    return groups[0][1]


def largest_group(scene, method, L0, h):
    """The bodies of the largest plan group (near one orbit the axis ordering chosen
    may still differ between bodies) and its plan."""
    idx, plan = max(liebody.methods()[method].plans(scene, L0, h), key=lambda g: len(g[0]))
    return idx, plan


class Run:
    """The arrays of one ensemble run, as ``_ensemble`` builds them."""

    def __init__(self, plan, q0, L0, h, n_steps, save_every, scene=None):
        from liebody._integrate import diagnostic_reference

        n = len(q0)
        self.plan, self.h, self.n_steps, self.save_every = plan, h, n_steps, save_every
        self.state = np.ascontiguousarray(np.concatenate([q0, L0], axis=1))
        self.ctl = np.tile(np.array([save_every, 0], dtype=np.int64), (n, 1))
        k = 2 + n_steps // save_every
        self.q = np.full((n, k, 4), np.nan)
        self.m = np.full((n, k, 3), np.nan)
        self.saved = np.ones(n, dtype=np.int64)
        self.done = np.zeros(n, dtype=np.int64)
        self.status = np.zeros(n, dtype=np.int64)
        self.dref = (np.zeros((n, S.DREF_WIDTH)) if scene is None else np.ascontiguousarray(
            diagnostic_reference(scene, scene.torque_model(), q0, L0)))
        self.dmax = np.zeros((n, 3))

    def copy(self):
        new = object.__new__(Run)
        new.__dict__ = {k: (v.copy() if isinstance(v, np.ndarray) else v)
                        for k, v in self.__dict__.items()}
        return new

    def go(self, runner, slices=None, merge=None):
        p = self.plan
        slices = [self.n_steps] if slices is None else slices
        assert sum(slices) == self.n_steps
        merge = p.merge_ends if merge is None else merge
        done = 0
        for k in slices:
            runner(p.kinds, p.axes, p.coefs, p.clock, p.params, p.slots, merge, self.h, 0.0,
                   float(done), k, self.save_every, done + k == self.n_steps, self.state,
                   self.ctl, self.q, self.m, self.saved, self.done, self.status, 0,
                   p.model, p.model_shared, self.dref, self.dmax)
            done += k
        return self


def per_body(params, n):
    """A plan's stage parameters with a row per body (a copy: a test changes one body's)."""
    return np.array(np.broadcast_to(params, (n, *params.shape[1:])))


def simd(plan, diag=False):
    return SIMD_RUNNERS[(plan.family, diag)]


def scalar(plan, diag=False):
    return (DIAG_BATCH_RUNNERS if diag else BATCH_RUNNERS)[plan.family]


def assert_same_records(a: Run, b: Run):
    for k in ("saved", "done", "status", "ctl"):
        np.testing.assert_array_equal(getattr(a, k), getattr(b, k), err_msg=k)
    np.testing.assert_array_equal(np.isnan(a.q), np.isnan(b.q))


def rel_diff(a: Run, b: Run) -> float:
    scale = np.abs(b.state[:, 4:]).max()
    dq = np.nanmax(np.abs(a.q - b.q))
    dm = np.nanmax(np.abs(a.m - b.m)) / scale
    ds = max(np.abs(a.state[:, :4] - b.state[:, :4]).max(),
             np.abs(a.state[:, 4:] - b.state[:, 4:]).max() / scale)
    return float(max(dq, dm, ds))


# the supported methods: (id, scene, method, h, L, exact agreement)
CASES = [
    ("splitting2", hlw_scene, "splitting2", 0.05, [math.cos(1.1), 0.0, math.sin(1.1)], False),
    ("no_squish", lambda: liebody.FreeBody(asym_body()), "no_squish", 0.05, [1.8, 0.4, -0.9],
     False),
    ("splitting4", lambda: liebody.FreeBody(asym_body()), "splitting4", 0.1, [1.8, 0.4, -0.9],
     False),
    ("sr2-asym", lambda: liebody.FreeBody(asym_body()), "sr2", 0.05, [1.8, 0.4, -0.9], False),
    ("sr2-symmetric", lambda: liebody.FreeBody(liebody.RigidBody([1.0, 1.0, 0.5])), "sr2",
     1e-2, [1.5, 0.5, 25.0], False),
    ("splitting2-symmetric", lambda: liebody.FreeBody(liebody.RigidBody([1.0, 1.0, 0.5])),
     "splitting2", 1e-2, [1.5, 0.5, 25.0], False),
    ("top-splitting2", top_scene, "splitting2", 1e-3, [0.0, 0.0, 50.0], False),
    ("top-splitting4", top_scene, "splitting4", 2e-3, [0.0, 0.0, 50.0], False),
    ("rattle", lambda: liebody.FreeBody(asym_body()), "rattle", 0.05, [1.8, 0.4, -0.9], True),
    ("dmv6", hlw_scene, "dmv6", 0.05, [math.cos(1.1), 0.0, math.sin(1.1)], True),
    ("top-rattle", top_scene, "rattle", 1e-3, [0.0, 0.0, 50.0], True),
]


def _case_run(case, n, n_steps, save_every, seed=0, diag=False):
    _, scene_of, method, h, L, _ = case
    scene = scene_of()
    top = "top" in case[0]
    q0, L0 = bodies(3 * n, L, seed, q_spread=0.05 if top else None)
    if top:  # tilted tops: the gravity torque is not zero
        q0 = quaternion.multiply(quaternion.exp([0.05, 0.0, 0.0]), q0)
    idx, _ = largest_group(scene, method, L0, h)
    assert len(idx) >= n
    q0, L0 = q0[idx[:n]], L0[idx[:n]]
    plan = one_plan(scene, method, L0, h)
    return Run(plan, q0, L0, h, n_steps, save_every, scene if diag else None), scene


# ------------------------------------------------------------------ what runs here


def test_simd_supports_the_free_and_gravity_families_only():
    free, top = liebody.FreeBody(asym_body()), top_scene()
    L = np.array([[1.8, 0.4, -0.9]])
    for method in ("splitting2", "no_squish", "splitting4", "splitting8", "sr2", "rattle",
                   "dmv6"):
        plan = liebody.methods()[method].plan(free, L[0], 0.05)
        assert simd_supports(plan, S.TORQUE_NONE), method
    for method in ("splitting2", "splitting4", "rattle"):
        plan = liebody.methods()[method].plan(top, [0.0, 0.0, 50.0], 1e-3)
        assert plan.family in (S.F_KICKED, S.F_SPLITTING, S.F_DMV)
        assert simd_supports(plan, S.TORQUE_GRAVITY), method
    for method in ("exact", "rk4", "euler", "rkmk4", "lie_euler"):
        assert not simd_supports(liebody.methods()[method].plan(free, L[0], 0.05), 0), method
    damped = liebody.DampedBody(asym_body(), 0.1)
    assert not simd_supports(liebody.methods()["splitting2"].plan(damped, L[0], 0.05), 0)
    from numba import njit

    @njit
    def spin(t, q, L):
        return np.array([0.0, 0.0, 1.0])

    # explicit kicks of a user torque run here (through its callback), implicit kicks not
    for only, supported in ((True, True), (False, False)):
        user = liebody.TorqueBody(asym_body(), spin, orientation_only=only)
        plan = liebody.methods()["splitting2"].plan(user, L[0], 0.05)
        assert simd_supports(plan, S.TORQUE_USER) is supported
        assert not simd_supports(plan, S.TORQUE_NONE)  # a kick of no model
    assert set(SIMD_RUNNERS) == {(f, d) for f in SIMD_FAMILIES for d in (False, True)}


@pytest.mark.kernel
def test_a_plan_it_cannot_run_stops_like_the_scalar_driver():
    """A kind outside the SIMD family (here the exact flow in the axis family), or a kick
    of no model (an unknown model code): STATUS_BAD_STAGE for every body still running."""
    run, _ = _case_run(CASES[0], 5, 3, 1)
    p = run.plan
    p.kinds = p.kinds.copy()
    p.kinds[1] = S.EXACT
    run.status[3] = S.STATUS_NONFINITE
    run.go(simd(p))
    assert list(run.status) == [S.STATUS_BAD_STAGE] * 3 + [S.STATUS_NONFINITE,
                                                           S.STATUS_BAD_STAGE]
    assert np.all(run.done == 0) and np.all(run.saved == 1)
    top, _ = _case_run(CASES[6], 4, 3, 1)
    top.plan.params = per_body(top.plan.params, 4)
    kick = int(np.flatnonzero(top.plan.kinds == S.KICK)[0])
    top.plan.params[2, top.plan.slots[kick], S.P_TORQUE] = S.MAX_MODEL_CODE + 1
    top.go(simd(top.plan))
    assert list(top.status) == [0, 0, S.STATUS_BAD_STAGE, 0]
    top, _ = _case_run(CASES[6], 4, 3, 1)
    top.plan.params = per_body(top.plan.params, 4)
    top.plan.params[1, top.plan.slots[kick], S.P_TORQUE] = S.TORQUE_NONE
    top.go(simd(top.plan))
    assert list(top.status) == [0, S.STATUS_BAD_STAGE, 0, 0]


# ------------------------------------------------------------------ agreement


@pytest.mark.kernel
@pytest.mark.parametrize("case", CASES, ids=[c[0] for c in CASES])
def test_simd_matches_the_scalar_batch_driver(case):
    """130 bodies (a full block and a partial one), slices of odd lengths, saving every
    3rd step, merged ends: the same records, the same samples to round-off (DMV: bit
    for bit)."""
    run, _ = _case_run(case, 130, 39, 3)
    slices = [1, 4, 7, 17, 10]
    a = run.copy().go(simd(run.plan), slices)
    b = run.copy().go(scalar(run.plan), slices)
    assert_same_records(a, b)
    assert np.all(a.status == 0) and np.all(a.saved == 1 + 13) and np.all(a.done == 39)
    if case[-1]:
        np.testing.assert_array_equal(a.q, b.q)
        np.testing.assert_array_equal(a.m, b.m)
        np.testing.assert_array_equal(a.state, b.state)
    else:
        assert rel_diff(a, b) < 2e-13, rel_diff(a, b)


@pytest.mark.kernel
def test_slicing_does_not_change_a_bit():
    """The SIMD driver over one call or over slices (merged ends carried in ``ctl``)."""
    for case in (CASES[0], CASES[6]):
        run, _ = _case_run(case, 20, 30, 4)
        a = run.copy().go(simd(run.plan))
        b = run.copy().go(simd(run.plan), [3, 1, 11, 2, 13])
        assert_same_records(a, b)
        np.testing.assert_array_equal(a.q, b.q)
        np.testing.assert_array_equal(a.state, b.state)


@pytest.mark.parametrize("case", [CASES[0], CASES[3], CASES[4], CASES[6], CASES[7], CASES[8],
                                  CASES[10]], ids=lambda c: c[0])
def test_each_body_agrees_with_its_single_body_integrate(case):
    """Per body, the one-body ``integrate()`` and the SIMD driver: one step agrees to a few
    ulps, 300 steps to 1e-13 (the difference grows with the phase error); DMV bit for
    bit."""
    from liebody._validate import as_unit_quaternion

    n, steps = 6, 300
    run, scene = _case_run(case, n, steps, 1)
    for i in range(n):  # integrate() renormalises q0: start both from its q0
        run.state[i, :4] = as_unit_quaternion("q0", run.state[i, :4])
    q0, L0 = run.state[:, :4].copy(), run.state[:, 4:].copy()
    a = run.go(simd(run.plan))
    for i in range(n):
        tr = liebody.integrate(scene, q0=q0[i], L0=L0[i], dt=run.h, steps=steps,
                               method=case[2])
        scale = np.linalg.norm(L0[i])
        one = max(np.abs(tr.q[1] - a.q[i, 1]).max(), np.abs(tr.L[1] - a.m[i, 1]).max() / scale)
        every = max(np.abs(tr.q[1:] - a.q[i, 1:steps + 1]).max(),
                    np.abs(tr.L[1:] - a.m[i, 1:steps + 1]).max() / scale)
        if case[-1]:
            assert every == 0.0
        else:
            assert one < 8 * EPS, one
            assert every < 1e-13, every


# ------------------------------------------------------------------ failures


def _with_bad_bodies(case, n, steps, save_every, bad):
    """A run of ``n`` healthy bodies with ``bad`` (index -> L0) put among them."""
    run, _ = _case_run(case, n, steps, save_every)
    for i, L in bad.items():
        run.state[i, 4:] = L
    return run


@pytest.mark.kernel
@pytest.mark.parametrize("case", [CASES[0], CASES[3], CASES[6], CASES[8]],
                         ids=lambda c: c[0])
def test_a_failing_body_leaves_the_others_alone(case):
    """A NaN momentum and a NaN orientation fail at their first step, as in the scalar
    driver (status, steps done, samples, state); the others give the numbers of a run
    without them, bit for bit. (An infinite momentum fails alike; the uncompiled scalar
    driver raises on ``math.sin(inf)``, so it is not used here.)"""
    bad = {3: [math.nan, 0.0, 1.0], 7: None}
    run = _with_bad_bodies(case, 12, 10, 3, {3: bad[3]})
    run.state[7, 1] = math.nan
    a = run.copy().go(simd(run.plan), [4, 6])
    b = run.copy().go(scalar(run.plan), [4, 6])
    assert_same_records(a, b)
    assert a.status[3] != 0 and a.status[7] != 0  # NONFINITE, NO_CONVERGENCE or TORQUE
    for i in bad:
        assert a.done[i] == 0 and a.saved[i] == 1
        np.testing.assert_array_equal(a.state[i], run.state[i])
        assert np.isnan(a.q[i]).all()
    good = [i for i in range(12) if i not in bad]
    alone = Run(run.plan, run.state[good, :4], run.state[good, 4:], run.h, 10, 3)
    alone.plan = dataclasses.replace(run.plan, params=per_body(run.plan.params, 12)[good])
    alone.go(simd(alone.plan), [4, 6])
    np.testing.assert_array_equal(a.q[good], alone.q)
    np.testing.assert_array_equal(a.state[good], alone.state)


@pytest.mark.kernel
def test_a_body_that_fails_later_stops_at_its_last_good_step():
    """A momentum near the overflow threshold (its rates scaled down so that its angles
    are of order 0.01): finite for 192 steps, then ``w + ... + m3`` overflows. Status,
    step and samples are the scalar driver's; a run of exactly ``done`` steps of that
    body alone gives its samples."""
    run = _with_bad_bodies(CASES[0], 9, 200, 2, {4: [0.7e308, 0.0, 0.3e308]})
    run.plan.params = per_body(run.plan.params, len(run.status))
    run.plan.params[4, :, S.P_RATE] *= 1e-308
    a = run.copy().go(simd(run.plan), [5, 195])
    b = run.copy().go(scalar(run.plan), [5, 195])
    assert_same_records(a, b)
    assert a.status[4] == S.STATUS_NONFINITE and a.done[4] == 192 and a.saved[4] == 1 + 96
    assert np.all(a.status[[0, 1, 2, 3, 5, 6, 7, 8]] == 0)
    assert rel_diff(a, b) < 1e-12
    one = Run(dataclasses.replace(run.plan, params=run.plan.params[4:5]),
              run.state[4:5, :4], run.state[4:5, 4:], run.h, 192, 2)
    one.go(simd(one.plan), [192])
    np.testing.assert_array_equal(a.q[4, 1:97], one.q[0, 1:97])
    np.testing.assert_array_equal(a.state[4], one.state[0])
    assert np.isnan(a.q[4, 97:]).all()


@pytest.mark.kernel
def test_a_dmv_failure_later_in_the_run_matches_the_scalar_driver():
    """Heavy tops under rattle with a weight 30 times the Simo-Wong top's: gravity spins
    most of them up until the DMV equation has no solution, at steps from 4 to 49;
    status, step, samples and state are the scalar driver's, bit for bit."""
    n, steps = 10, 60
    q0, L0 = bodies(n, [0.0, 0.0, 5.0], seed=3, q_spread=0.05)
    q0 = quaternion.multiply(quaternion.exp([0.6, 0.0, 0.0]), q0)
    plan = one_plan(top_scene(), "rattle", L0, 0.05)
    plan.model = plan.model * 30.0  # the weight arm: the model's parameter block
    run = Run(plan, q0, L0, 0.05, steps, 3)
    a = run.copy().go(simd(plan), [7, 53])
    b = run.copy().go(scalar(plan), [7, 53])
    assert_same_records(a, b)
    failed = a.status == S.STATUS_NO_CONVERGENCE
    assert 0 < failed.sum() < n and np.all(a.status[~failed] == 0)
    assert a.done[failed].max() > 20
    np.testing.assert_array_equal(a.q, b.q)
    np.testing.assert_array_equal(a.state, b.state)


@pytest.mark.kernel
def test_a_torque_that_fails_is_reported_as_the_scalar_driver_does():
    """A gravity constant that is not finite: STATUS_TORQUE at the first kick."""
    run, _ = _case_run(CASES[6], 6, 5, 1)
    model = np.repeat(run.plan.model, 6, axis=0) if len(run.plan.model) == 1 else (
        run.plan.model.copy())
    model[1, 0] = math.inf  # body 1's weight arm
    run.plan.model = model
    a = run.copy().go(simd(run.plan))
    b = run.copy().go(scalar(run.plan))
    assert_same_records(a, b)
    assert a.status[1] == S.STATUS_TORQUE and a.done[1] == 0


@pytest.mark.kernel
def test_bodies_that_failed_before_are_skipped_and_ctl_may_differ():
    """Status set on entry: the body is not touched. Bodies whose ``ctl`` differs (steps
    to the next save) run in blocks of their own, as the scalar driver runs them."""
    run, _ = _case_run(CASES[3], 11, 12, 4)
    run.status[[0, 6]] = S.STATUS_NONFINITE
    run.ctl[1::2, 0] = 1
    run.ctl[4, 0] = 3
    a = run.copy().go(simd(run.plan), [5, 7])
    b = run.copy().go(scalar(run.plan), [5, 7])
    assert_same_records(a, b)
    assert rel_diff(a, b) < 1e-13
    for i in (0, 6):
        np.testing.assert_array_equal(a.state[i], run.state[i])
        assert a.done[i] == 0 and np.isnan(a.q[i]).all()


# ------------------------------------------------------------------ diagnostics


@pytest.mark.kernel
@pytest.mark.parametrize("case", [CASES[0], CASES[4], CASES[6], CASES[10]],
                         ids=lambda c: c[0])
def test_running_diagnostics_match_the_scalar_driver(case):
    run, _ = _case_run(case, 20, 50, 50, diag=True)
    a = run.copy().go(simd(run.plan, True), [13, 37], merge=False)
    b = run.copy().go(scalar(run.plan, True), [13, 37], merge=False)
    assert_same_records(a, b)
    if case[-1]:
        np.testing.assert_array_equal(a.dmax, b.dmax)
        return
    np.testing.assert_allclose(a.dmax[:, 0], b.dmax[:, 0], rtol=1e-6, atol=1e-14)
    assert np.all(a.dmax[:, 1] < 1e-14) and np.all(b.dmax[:, 1] < 1e-14)
    if "top" in case[0]:  # |L| is not an invariant of the top: the same numbers
        np.testing.assert_allclose(a.dmax[:, 2], b.dmax[:, 2], rtol=1e-9)
    else:
        assert np.all(a.dmax[:, 2] < 1e-14) and np.all(b.dmax[:, 2] < 1e-14)


@pytest.mark.kernel
def test_diagnostics_of_a_failed_body_stop_at_its_last_good_step():
    case = CASES[0]
    run, _ = _case_run(case, 5, 20, 20, diag=True)
    run.state[2, 4:] = [math.nan, 1.0, 0.0]
    run.dmax[:] = 0.25
    a = run.copy().go(simd(run.plan, True), merge=False)
    b = run.copy().go(scalar(run.plan, True), merge=False)
    assert_same_records(a, b)
    np.testing.assert_array_equal(a.dmax[2], [0.25, 0.25, 0.25])
    np.testing.assert_array_equal(a.dmax[2], b.dmax[2])


# ------------------------------------------------------------------ the fast sin and cos


def _sincos(x, small=False):
    s, c, cm = np.empty_like(x), np.empty_like(x), np.empty_like(x)
    sincos_array(np.ascontiguousarray(x), s, c, cm, small)
    return s, c, cm


def _ulps(got, ref):
    return float(np.max(np.abs(got - ref) / np.spacing(np.abs(ref))))


@pytest.mark.kernel
@pytest.mark.parametrize("plain", [False, True])
@pytest.mark.parametrize(("lo", "hi", "limit"), [
    (0.0, math.pi / 4, 1.0), (0.0, 100.0, 2.0), (100.0, 1e6, 3.0), (1e6, 1e9, 4.0)])
def test_fast_sincos_is_within_a_few_ulps_of_libm(lo, hi, limit, plain):
    """``trig.sincos`` (normalised: its ``cos - 1`` too), and ``trig.sincos_plain`` (the
    pair without normalisation, a circular orbit's position: as accurate)."""
    rng = np.random.default_rng(7)
    x = rng.uniform(lo, hi, 20_000) * rng.choice([-1.0, 1.0], 20_000)
    if plain:
        s, c = np.empty_like(x), np.empty_like(x)
        sincos_plain_array(x, s, c)
    else:
        s, c, cm = _sincos(x)
    assert _ulps(s, np.array([math.sin(v) for v in x])) <= limit
    assert _ulps(c, np.array([math.cos(v) for v in x])) <= limit
    assert np.max(np.abs(np.hypot(s, c) - 1.0)) < 4 * EPS
    first = np.abs(x) < math.pi / 4  # cos - 1 to full relative accuracy near 0
    if first.any() and not plain:
        ref = np.array([-2.0 * math.sin(0.5 * v) ** 2 for v in x[first]])
        assert np.max(np.abs(cm[first] - ref) / np.abs(ref)) < 4 * EPS


@pytest.mark.kernel
def test_fast_sincos_without_reduction_gives_the_same_numbers():
    """Below 0.78 the variant without range reduction is the same function, bit for bit
    (so a body's numbers do not depend on the bodies that share its block)."""
    x = np.random.default_rng(8).uniform(-0.78, 0.78, 20_000)
    for got, ref in zip(_sincos(x, True), _sincos(x, False), strict=True):
        np.testing.assert_array_equal(got, ref)


@pytest.mark.kernel
def test_fast_sincos_pairs_are_normalised_far_below_round_off():
    """The Newton step leaves ``s^2 + (1 + cm)^2 - 1`` (exact, in rationals) at the level
    ``eps s^2``, with no bias; the plain pair ``(s, c)`` has libm's statistics."""
    x = np.random.default_rng(9).uniform(-0.78, 0.78, 1500)
    s, c, cm = _sincos(x, True)
    d = np.array([float(Fraction(a) ** 2 + Fraction(b) * (2 + Fraction(b)))
                  for a, b in zip(s, cm, strict=True)])
    rel = d / (EPS * s * s)
    assert np.max(np.abs(rel)) < 2.0
    assert abs(np.mean(rel)) < 0.1
    plain = np.array([float(Fraction(a) ** 2 + Fraction(b) ** 2 - 1)
                      for a, b in zip(s, c, strict=True)])
    libm = np.array([float(Fraction(math.sin(v)) ** 2 + Fraction(math.cos(v)) ** 2 - 1)
                     for v in x])
    assert np.std(plain) < 1.5 * np.std(libm)
    assert abs(np.mean(plain)) < 3 * np.std(libm) / math.sqrt(len(x))


@pytest.mark.kernel
def test_the_one_body_turns_pair_is_correctly_rounded_to_an_ulp():
    """``trig.sincos_turn`` (the one-body small turn's pair, ``|x| < 0.1``: the fdlibm
    polynomials in Estrin's scheme, for a shorter dependency chain): ``sin x`` and
    ``cos x - 1`` within an ulp of the correctly rounded values (mpmath, 40 digits), and
    the pair's norm error ``s^2 + (1 + cm)^2 - 1`` (exact, in rationals) at the level
    ``eps s^2``, with no bias, as Horner's evaluation of the same polynomials."""
    import mpmath
    from numba import njit

    from liebody._kernels.trig import sincos_small_raw, sincos_turn

    @njit
    def pairs(x, estrin):
        out = np.empty((x.shape[0], 3))
        for i in range(x.shape[0]):
            r = sincos_turn(x[i]) if estrin else sincos_small_raw(x[i])
            out[i, 0], out[i, 1], out[i, 2] = r[0], r[1], r[2]
        return out

    rng = np.random.default_rng(11)
    x = np.concatenate([rng.uniform(-0.1, 0.1, 600), [1e-300, -1e-9, 0.0999999, 1e-5]])
    got = pairs(x, True)
    mpmath.mp.dps = 40
    for v, (s, _, cm) in zip(x, got, strict=True):
        exact_s, exact_cm = mpmath.sin(mpmath.mpf(v)), mpmath.cos(mpmath.mpf(v)) - 1
        # (an ulp from the correctly rounded value: 1.5 ulp from the exact one)
        assert abs(mpmath.mpf(s) - exact_s) <= 1.5 * np.spacing(abs(float(exact_s))), v
        assert abs(mpmath.mpf(cm) - exact_cm) <= 1.5 * np.spacing(abs(float(exact_cm))), v
    big = np.abs(x) > 1e-3
    s, cm = got[big, 0], got[big, 2]
    norm = np.array([float(Fraction(a) ** 2 + Fraction(b) * (2 + Fraction(b)))
                     for a, b in zip(s, cm, strict=True)])
    rel = norm / (EPS * s * s)
    horner = pairs(x[big], False)
    ref = np.array([float(Fraction(a) ** 2 + Fraction(b) * (2 + Fraction(b)))
                    for a, b in zip(horner[:, 0], horner[:, 2], strict=True)]) / (EPS * s * s)
    assert np.max(np.abs(rel)) <= max(2.0, np.max(np.abs(ref)))
    assert abs(np.mean(rel)) < 0.1
    np.testing.assert_array_equal(got[:, 1], 1.0 + got[:, 2])


@pytest.mark.kernel
def test_fast_sincos_at_the_edges():
    x = np.array([0.0, -0.0, 5e-324, 1e-300, 1e15, 1e300, -1e300, math.inf, -math.inf,
                  math.nan])
    s, c, _ = _sincos(x)
    assert s[0] == 0.0 and c[0] == 1.0 and s[2] == 5e-324 and s[3] == 1e-300
    assert np.all(np.abs(s[4:7]) <= 1.0) and np.all(np.abs(c[4:7]) <= 1.0)
    assert np.all(np.abs(s[4:7] ** 2 + c[4:7] ** 2 - 1.0) < 4 * EPS)
    assert np.isnan(s[7:]).all() and np.isnan(c[7:]).all()
    assert abs(s[4] - math.sin(1e15)) < 4 * EPS  # FMA (or 3-part) reduction still good


# ------------------------------------------------------------------ vectorisation


def _block_loops():
    """Each SIMD stage loop with arguments to compile it, recompiled without the disk
    cache (cached code cannot be inspected)."""
    import numba

    from liebody._kernels import batch as B
    from liebody._models import gravity_gradient

    buf = np.zeros(B.N_ROWS * B.BLOCK)
    p = np.ones((6, B.BLOCK))
    par = p[None]  # (stages, slots, BLOCK): the rates, a kick's arm or moments in stage 0
    idx = np.arange(B.BLOCK)
    mc = (0, 0, 0, np.zeros((1, 1)), np.zeros((1, 1, 15)), idx, np.zeros(1),
          np.zeros((6, B.BLOCK)), np.zeros((B.BLOCK, 6)), np.zeros(B.BLOCK, dtype=np.int64),
          np.zeros(1))
    rows = (B.W0, B.X0, B.Y0, B.Z0)
    for fn, args in ((B._AX0F, (buf, par, 0, 3, 0.1)), (B._AX2G, (buf, par, 0, 3, 0.1)),
                     (B._AX1F, (buf, par, 0, 3, 0.1)), (B._RC2C, (buf, par, 0, 3, 0.1)),
                     (B._SPHERE_FAST, (buf, par, 0, 3, 0.1)),
                     (B._SPHERE_GENERAL, (buf, par, 0, 3, 0.1)),
                     (B._kick_block, (buf, par, 0, 3, 0.1)), (B._dmv_block, (buf, p, 3, 0.1)),
                     (B._diagnose_block, (buf, 3, mc, 0.0)),
                     (B._project_block, (buf, 3, True, 0, par, 0, 0.1)),
                     (gravity_gradient.torque_block,
                      (np.ones(4), par, 0, 16, buf, rows, np.zeros((6, B.BLOCK))))):
        opts = {k: v for k, v in fn.targetoptions.items() if k not in ("cache", "nopython")}
        fresh = numba.njit(**opts)(fn.py_func)
        fresh(*args)
        yield fn.py_func.__qualname__, fresh


#: packed double-precision arithmetic (mulpd, vfmadd...pd, ...) and its register
PACKED = re.compile(r"\bv?(?:mul|add|sub|fn?m(?:add|sub)\d*)pd\s+%?([xyz]mm)")


@pytest.mark.skipif(not JIT, reason="needs the compiled kernels")
@pytest.mark.skipif(platform.machine() not in ("x86_64", "AMD64"), reason="x86 assembly")
def test_the_block_loops_compile_to_packed_instructions():
    """Each stage loop holds packed double-precision arithmetic (``mulpd``/``vfmadd...pd``
    on xmm/ymm/zmm registers): LLVM vectorised the loop over the block."""
    for name, fresh in _block_loops():
        asm = fresh.inspect_asm(fresh.signatures[0])
        assert len(PACKED.findall(asm)) >= 8, name


@pytest.mark.skipif(not JIT, reason="needs the compiled kernels")
@pytest.mark.skipif(platform.machine() not in ("x86_64", "AMD64"), reason="x86 assembly")
def test_the_block_loops_use_the_widest_vectors():
    """Each stage loop asks LLVM for 512-bit vectors (``trig.wide_vectors``: LLVM prefers
    256 bits on AVX-512 CPUs), and on a CPU with AVX-512 its packed arithmetic runs on
    zmm registers, 8 bodies per instruction."""
    from numba.core.registry import cpu_target

    from liebody._kernels.trig import WIDE_VECTORS

    # (the features numba compiles for: NUMBA_CPU_NAME / NUMBA_CPU_FEATURES may name a CPU
    # without AVX-512 on a host that has it)
    features = cpu_target.target_context.codegen().magic_tuple()[2].split(",")
    avx512 = "+avx512f" in features
    for name, fresh in _block_loops():
        assert WIDE_VECTORS in fresh.inspect_llvm(fresh.signatures[0]), name
        if avx512:
            regs = PACKED.findall(fresh.inspect_asm(fresh.signatures[0]))
            assert regs.count("zmm") >= 8, (name, sorted(set(regs)))


@pytest.mark.kernel
def test_a_recurring_turn_is_constant_only_where_no_other_stage_changes_its_component():
    """A symmetric top's spin rotation (AXIS_RECURRING about its axis) keeps its angle
    through a chunk when the other stages keep ``m_3``: sphere rotations, rotations about
    the same axis, gravity kicks with the weight arm on the axis in every body of the
    block. Not with an arm off the axis in one body, another model's kicks or a rotation
    about another axis."""
    from liebody._kernels import batch as B

    kinds = np.array([S.KICK, S.SPHERE, S.AXIS_RECURRING, S.KICK])
    axes = np.array([0, 0, 2, 0])
    par = np.zeros((4, B.N_SLOTS, B.BLOCK))
    par[0, 2, :] = par[3, 2, :] = 20.0  # the weight arm (0, 0, 20) of every body
    assert B._keeps_component(kinds, axes, par, 5, S.TORQUE_GRAVITY, 2)
    assert not B._keeps_component(kinds, axes, par, 5, S.TORQUE_GRAVITY_GRADIENT, 2)
    par[3, 0, 4] = 1e-3  # body 4's arm off the axis
    assert not B._keeps_component(kinds, axes, par, 5, S.TORQUE_GRAVITY, 2)
    assert B._keeps_component(kinds, axes, par, 4, S.TORQUE_GRAVITY, 2)  # (not in block)
    kinds[1], axes[1] = S.AXIS, 1
    assert not B._keeps_component(kinds, axes, par, 4, S.TORQUE_GRAVITY, 2)
    axes[1] = 2
    assert B._keeps_component(kinds, axes, par, 4, S.TORQUE_GRAVITY, 2)


@pytest.mark.kernel
def test_a_turn_computed_once_per_chunk_gives_the_same_numbers():
    """Two blocks of the same tilted fast tops, one of which holds a top whose arm is a
    little off its axis: the spin rotation's turn is computed once per chunk in the
    first block and at every step in the second, and each top's samples are the same,
    bit for bit (a body's numbers do not depend on the other bodies of its block)."""
    from liebody._kernels import batch as B

    n = B.BLOCK
    q0, L0 = bodies(n, [0.0, 0.0, 50.0], seed=3, q_spread=0.05)
    q0 = quaternion.multiply(quaternion.exp([0.05, 0.0, 0.0]), q0)
    cm = np.tile([0.0, 0.0, 1.0], (2 * n, 1))
    cm[-1, 0] = 1e-3
    tops = liebody.HeavyTop(liebody.RigidBody([5.0, 5.0, 1.0]), 20.0, cm, g=1.0)
    tr = liebody.integrate(tops, q0=np.r_[q0, q0], L0=np.r_[L0, L0], dt=1e-3, steps=300,
                           save_every=100, method="splitting2", simd=True, threads=1)
    assert tr.info["simd"] is True and tr.info["free_flow"] == "symmetric"
    np.testing.assert_array_equal(tr.q[:n - 1], tr.q[n:-1])
    np.testing.assert_array_equal(tr.L[:n - 1], tr.L[n:-1])
    assert not np.array_equal(tr.q[n - 1], tr.q[-1])  # (the off-axis top moves apart)



@pytest.mark.parametrize("method", ["splitting2", "no_squish"])
def test_a_rigid_axis_turn_does_not_depend_on_a_large_turn_in_its_block(method):
    """Two blocks of the same asymmetric free bodies, the second with one body spinning
    so fast that its block takes the general axis kernels (range reduction): the other
    bodies' samples are the same, bit for bit (the general kernel's normalised pair
    differed from the fast one's raw pair in the last bit below a quarter turn)."""
    from liebody._kernels import batch as B

    n = B.BLOCK
    L0 = np.random.default_rng(0).normal(size=(n, 3)) * 5.0
    L0b = L0.copy()
    L0b[-1] = [0.0, 0.0, 4000.0]
    body = liebody.RigidBody([1.0, 2.0, 3.0])  # (one ordering: one group)
    tr = liebody.integrate(liebody.FreeBody(body), L0=np.r_[L0, L0b], dt=1e-2,
                           steps=20, save_every=10, method=method, simd=True, threads=1)
    assert tr.info["simd"] is True
    np.testing.assert_array_equal(tr.q[:n - 1], tr.q[n:-1])
    np.testing.assert_array_equal(tr.L[:n - 1], tr.L[n:-1])



def test_a_recurring_turn_does_not_depend_on_a_large_turn_in_its_block():
    """Two blocks of the same tops, the second with one top spinning so fast that its
    block takes the general kernels: the recurring spin rotation's general kernel keeps
    the normalised pair of the fast one, and the other tops' samples are the same, bit
    for bit (they are not if it takes the rigid turn's raw pair)."""
    from liebody._kernels import batch as B

    n = B.BLOCK
    q0, L0 = bodies(n, [0.3, -0.2, 50.0], seed=5, q_spread=0.05)
    L0b = L0.copy()
    L0b[-1] = [0.0, 0.0, 2000.0]
    tops = liebody.HeavyTop(liebody.RigidBody([5.0, 5.0, 1.0]), 20.0, [0.0, 0.0, 1.0], g=1.0)
    tr = liebody.integrate(tops, q0=np.r_[q0, q0], L0=np.r_[L0, L0b], dt=1e-3, steps=150,
                           save_every=50, method="splitting2", simd=True, threads=1)
    assert tr.info["simd"] is True
    np.testing.assert_array_equal(tr.q[:n - 1], tr.q[n:-1])
    np.testing.assert_array_equal(tr.L[:n - 1], tr.L[n:-1])


# ------------------------------------------------------------------ long horizons


LONG = [
    ("asym-splitting2", lambda: liebody.FreeBody(asym_body()), "splitting2", 0.05,
     [1.8, 0.4, -0.9], None, True),
    ("symmetric-splitting2", lambda: liebody.FreeBody(liebody.RigidBody([1.0, 1.0, 0.5])),
     "splitting2", 1e-3, [3.0, 1.0, 25.0], 0.05, True),
    ("symmetric-sr2", lambda: liebody.FreeBody(liebody.RigidBody([1.0, 1.0, 0.5])), "sr2",
     1e-3, [0.0, 0.0, 25.0], 0.05, True),
    ("simo-wong-splitting2", top_scene, "splitting2", 1e-3, [0.0, 0.0, 50.0], 0.05, False),
]


@pytest.mark.long
@pytest.mark.skipif(not JIT, reason="1e8 steps need the compiled kernels")
@pytest.mark.parametrize("case", LONG, ids=[c[0] for c in LONG])
def test_norms_over_1e8_steps(case):
    """Eight bodies, 1e8 steps, every step checked (running diagnostics): ``| |q| - 1 |``
    and the relative ``|L|`` drift stay at the level of the scalar path, the rounding of
    1e8 steps. Measured on these runs, ``| |q| - 1 |``, median over the bodies (max),
    SIMD against the scalar driver on the same bodies: asym ``splitting2`` 1.3e-12
    (2.1e-12) / 1.3e-12 (2.4e-12); symmetric ``splitting2`` 1.0e-12 (2.0e-12) / 1.3e-12
    (2.1e-12); symmetric ``sr2`` 1.2e-12 (2.9e-12) / 1.1e-12 (3.5e-12); Simo-Wong top
    1.0e-12 (1.8e-12) / 1.6e-12 (2.6e-12); ``|L|`` alike. The recurring rotations (the
    symmetric bodies' spin, the sphere flow) are included.
    Growth from 1e6 to 1e8 steps by much less than 100 (a systematic drift from the
    polynomial sin/cos would be linear), and the energy error bounded."""
    _, scene_of, method, h, L, tilt, keeps_L = case
    scene = scene_of()
    n = 8
    q0, L0 = bodies(n, L, seed=11, q_spread=None if tilt is None else 1e-3)
    if tilt is not None:
        q0 = quaternion.multiply(quaternion.exp([tilt, 0.0, 0.0]), q0)
    plan = one_plan(scene, method, L0, h)
    run = Run(plan, q0, L0, h, 10**8, 10**8, scene)
    runner = simd(plan, True)
    done = 0
    early = None
    for k in [10**6] + [10**7 - 10**6] + [10**7] * 9:
        run.n_steps = done + k
        p = run.plan
        runner(p.kinds, p.axes, p.coefs, p.clock, p.params, p.slots, False, h, 0.0,
               float(done), k, 10**8, done + k == 10**8, run.state, run.ctl, run.q, run.m,
               run.saved,
               run.done, run.status, 0, p.model, p.model_shared, run.dref, run.dmax)
        done += k
        if done == 10**6:
            early = run.dmax.copy()
    assert np.all(run.status == 0) and np.all(run.done == 10**8)
    assert np.all(run.dmax[:, 0] <= 1.5 * early[:, 0] + 1e-14)  # the energy stays bounded
    qn = run.dmax[:, 1]
    assert qn.max() <= 5e-12, qn
    assert np.median(qn) <= 2e-12, qn
    assert np.median(qn) / np.median(early[:, 1]) < 40.0
    if keeps_L:
        Ln = run.dmax[:, 2]
        assert Ln.max() <= 5e-12, Ln
        assert np.median(Ln) <= 2e-12, Ln
