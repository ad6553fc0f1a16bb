"""The driver and the stage contract: families, unknown kinds, allocation, direct kernels."""

from __future__ import annotations

import os
import re

import numpy as np
import pytest

import liebody
from liebody._kernels import stages as S
from liebody._plan import Stage, compile_plan
from support import drive


def test_every_kind_has_a_contract_entry_and_a_general_family():
    for code, kind in S.KINDS.items():
        assert all(p in S.SLOTS for p in kind.params), (code, kind)
        assert S.family_of([code]) != S.F_GENERAL  # every kind has a small family
    assert len(set(S.SLOTS.values())) == S.N_PARAMS  # one meaning per slot


@pytest.mark.parametrize("family", sorted(S.FAMILIES))
def test_every_family_runs_every_kind_it_declares(family):
    """The driver of each family runs each kind the contract gives it (a kind missing
    from its dispatch would stop with STATUS_BAD_STAGE, or do nothing: the state must
    move), and refuses the others."""
    from liebody._kernels.driver import RUNNERS

    I = (1.0, 2.0, 3.0)
    for kind in sorted(S.KINDS):
        st = Stage(kind, 1.0, 1.0, axis=1, rate=0.7, moments=I,
                   torque=S.TORQUE_GRAVITY, eps=0.3)
        plan = compile_plan([st], model=np.array([[0.0, 0.4, 0.9]]))
        state = np.array([0.9, 0.1, -0.3, 0.2, 0.5, -0.4, 0.8])
        state[:4] /= np.linalg.norm(state[:4])
        before = state.copy()
        done, _, status = drive(plan, 0.1, 1, state, np.empty((1, 4)), np.empty((1, 3)),
                                runners=RUNNERS if family == plan.family else
                                {plan.family: RUNNERS[family]})
        if kind in S.FAMILIES[family]:
            assert (done, status) == (1, S.STATUS_OK), (S.KINDS[kind].name, family)
            assert not np.array_equal(state, before), (S.KINDS[kind].name, family)
        else:
            assert status == S.STATUS_BAD_STAGE, (S.KINDS[kind].name, family)


def test_unknown_stage_kind_is_an_error():
    with pytest.raises(ValueError, match="unknown stage kind 99"):
        Stage(99, 1.0)
    with pytest.raises(ValueError, match=r"unknown stage kind\(s\) \[42\]"):
        S.family_of([S.AXIS, 42])


@pytest.mark.parametrize(("kinds", "family"), [
    ([S.AXIS], S.F_AXES),
    ([S.AXIS, S.SPHERE], S.F_ROTATIONS),
    ([S.KICK, S.AXIS_RECURRING, S.SPHERE], S.F_KICKED),
    ([S.KICK, S.AXIS, S.KICK_IMPLICIT], S.F_SPLITTING),
    ([S.DAMP, S.AXIS], S.F_SPLITTING),
    ([S.DMV], S.F_DMV_FREE),
    ([S.KICK, S.DMV, S.KICK_IMPLICIT], S.F_DMV),
    ([S.DAMP, S.EXACT], S.F_EXACT),
    ([S.RK4], S.F_RK4),
    ([S.DMV, S.AXIS], S.F_GENERAL),
    ([S.AXIS_SHIFTED, S.AXIS], S.F_ROTOR),
    ([S.AXIS_SHIFTED, S.KICK], S.F_ROTOR_TORQUED),
    ([S.AXIS_SHIFTED, S.DAMP, S.SPHERE], S.F_ROTOR_TORQUED),
])
def test_plans_run_in_the_smallest_family(kinds, family):
    assert S.family_of(kinds) == family


def test_methods_compile_only_their_family(hlw):
    """A free-body splitting runs in the axis-only family, a free body's RATTLE in DMV's
    alone; torqued ones add kicks only, explicit ones for an orientation-only torque."""
    scene, L0 = hlw
    fam = {m.name: m.plan(scene, L0, 0.01).family for m in liebody.methods()}
    assert fam["splitting2"] == fam["no_squish"] == S.F_AXES
    assert fam["sr2"] == S.F_ROTATIONS and fam["rattle"] == fam["dmv6"] == S.F_DMV_FREE
    assert fam["rk4"] == S.F_RK4 and fam["exact"] == S.F_EXACT
    top = liebody.HeavyTop(liebody.RigidBody([5.0, 5.0, 1.0]), 20.0, [0, 0, 1.0], g=1.0)
    assert liebody.methods()["splitting4"].plan(top, L0, 0.01).family == S.F_KICKED
    assert liebody.methods()["rattle"].plan(top, L0, 0.01).family == S.F_DMV
    damped = liebody.DampedBody(liebody.RigidBody([1.0, 2.0, 3.0]), eps=0.1)
    assert liebody.methods()["splitting2"].plan(damped, L0, 0.01).family == S.F_SPLITTING
    # a rotor's turn (double-length parts carried through the step) only where there is
    # a rotor: the rigid families do not compile it (a heavy top's first call 0.5 s less)
    for family in (S.F_AXES, S.F_ROTATIONS, S.F_KICKED, S.F_SPLITTING):
        assert not S.MEMBERS[family, S.AXIS_SHIFTED]
    gyro = liebody.Gyrostat(liebody.RigidBody([1.0, 2.0, 3.0]), [0.0, 0.0, 0.5])
    assert liebody.methods()["splitting2"].plan(gyro, L0, 0.01).family == S.F_ROTOR
    wheels = liebody.ReactionWheels(liebody.RigidBody([1.0, 2.0, 3.0]), np.eye(3),
                                    [0.1, 0.1, 0.1],
                                    sources=[(1.0, liebody.orbits.Circular(0.01))])
    assert liebody.methods()["splitting2"].plan(wheels, L0, 0.01).family == S.F_ROTOR_TORQUED


@pytest.mark.kernel
def test_a_kind_outside_the_family_stops_the_run(hlw):
    """The driver never runs a stage its family does not hold: it returns STATUS_BAD_STAGE."""
    scene, L0 = hlw
    plan = compile_plan([Stage(S.DMV, 1.0, 1.0, moments=tuple(scene.moments))])
    plan.family = S.F_ROTATIONS  # a corrupted plan
    state = np.concatenate([[1.0, 0.0, 0.0, 0.0], L0])
    done, saved, status = drive(plan, 0.1, 3, state, np.empty((3, 4)), np.empty((3, 3)))
    assert (done, saved, status) == (0, 0, S.STATUS_BAD_STAGE)
    np.testing.assert_array_equal(state[4:], L0)


def test_driver_loop_allocates_nothing(hlw):
    """The compiled driver contains no heap allocation (NRT_MemInfo_alloc*/NRT_Allocate).

    The driver is recompiled without the disk cache (cached code cannot be inspected),
    and a function that does allocate shows the pattern is found when present.
    """
    import numba

    if os.environ.get("NUMBA_DISABLE_JIT") == "1":
        pytest.skip("needs the compiled kernel")
    from liebody._kernels import driver

    pattern = re.compile(r"NRT_MemInfo_alloc\w*|NRT_Allocate\w*")

    @numba.njit
    def allocates(n):
        return np.empty(n).sum()

    allocates(3)
    assert all(pattern.search(ir) for ir in allocates.inspect_llvm().values())

    # the family drivers recompiled without the disk cache
    fresh = {f: numba.njit(r.py_func) for f, r in driver.RUNNERS.items()}
    scene, L0 = hlw
    top = liebody.HeavyTop(liebody.RigidBody([5.0, 5.0, 1.0]), 20.0, [0, 0, 1.0], g=1.0)
    families = set()
    for name, sc in (("splitting2", scene), ("sr2", scene), ("rattle", scene), ("rk4", scene),
                     ("splitting4", top)):
        plan = liebody.methods()[name].plan(sc, L0, 0.1)
        state = np.concatenate([[1.0, 0.0, 0.0, 0.0], L0])
        drive(plan, 0.1, 3, state, np.empty((3, 4)), np.empty((3, 3)), runners=fresh)
        families.add(plan.family)
    assert len(families) == 5
    for f in families:
        irs = fresh[f].inspect_llvm()
        assert len(irs) == 1
        for ir in irs.values():
            assert "define" in ir and not pattern.search(ir)


@pytest.mark.kernel
def test_dmv_kernel_finds_roots_the_fixed_point_misses():
    """A case where Gauss-Seidel diverges: the root found solves the equation to rounding."""
    from liebody._kernels.flows import _dmv_residual, dmv_step

    I = np.array([0.5302758, 2.84320303, 1.15931761])
    m = np.array([0.10168855, -0.62317829, -1.65738965])
    h = 0.8207302663804338
    out = dmv_step(1.0, 0.0, 0.0, 0.0, *m, *I, h)
    assert out[7] > 0
    # recover c from the increment q = (1, c)/sqrt(1 + |c|^2) and check the equation
    c = np.array(out[1:4]) / out[0]
    a = 0.5 * h * m / I
    f = ((I[1] - I[2]) / I[0], (I[2] - I[0]) / I[1], (I[0] - I[1]) / I[2])
    assert np.abs(_dmv_residual(*c, *a, *f)).max() < 1e-14
    assert abs(np.linalg.norm(out[4:7]) - np.linalg.norm(m)) < 1e-15


@pytest.mark.kernel
def test_the_general_family_runs_mixed_plans(hlw):
    """A plan mixing kinds of several families runs in the generic driver and equals the
    stages run one family at a time."""
    scene, L0 = hlw
    moments = tuple(scene.moments)
    parts = [Stage(S.RK4, 1.0, 1.0, moments=moments), Stage(S.AXIS, 0.5, axis=1, rate=0.7),
             Stage(S.DMV, 0.3, moments=moments), Stage(S.EXACT, 0.2, moments=moments)]
    mixed = compile_plan(parts)
    assert mixed.family == S.F_GENERAL
    state = np.concatenate([liebody.quaternion.random(rng=6), L0])
    one = state.copy()
    assert drive(mixed, 0.1, 1, one, np.empty((1, 4)), np.empty((1, 3)))[2] == S.STATUS_OK
    for part in parts:
        plan = compile_plan([part])
        assert plan.family != S.F_GENERAL
        drive(plan, 0.1, 1, state, np.empty((1, 4)), np.empty((1, 3)))
    np.testing.assert_allclose(one, state, atol=1e-15, rtol=0)


def test_the_generated_batch_drivers_are_fresh():
    """batch_drivers.py is written by batch_gen from its template for the families of the
    stage contract; a change of either without regenerating fails here."""
    from liebody._kernels import batch_drivers, batch_gen

    assert batch_gen.TARGET.read_text() == batch_gen.source(), (
        "regenerate: python -m liebody._kernels.batch_gen")
    assert set(batch_drivers.BATCH_RUNNERS) == set(S.FAMILIES)
    assert set(batch_drivers.DIAG_BATCH_RUNNERS) == set(S.FAMILIES)
    # the generator follows the contract: one more family, one more pair of drivers
    fake = {**S.FAMILIES, 99: frozenset({S.AXIS})}
    import unittest.mock as mock

    with mock.patch.object(batch_gen, "FAMILIES", fake):
        text = batch_gen.source()
    assert "def batch_family99(" in text and "def batch_family99_diag(" in text


def test_the_argument_lists_hold_the_clock_where_the_drivers_take_it():
    """``_engine.one_body_args`` and ``batch_args`` build the drivers' arguments in one
    place; the Stepper and the runs write the clock and the slice at ``_engine.T0 ..
    FINAL``: those are the drivers' own parameters there (one-body, scalar batch, SIMD)."""
    import inspect

    from liebody import _engine
    from liebody._kernels import batch, batch_drivers, driver

    names = ("t0", "step0", "n_steps", "save_every", "final")
    where = (_engine.T0, _engine.STEP0, _engine.N_STEPS, _engine.SAVE_EVERY, _engine.FINAL)
    for runner in (driver.RUNNERS[S.F_AXES], batch_drivers.BATCH_RUNNERS[S.F_AXES],
                   batch.SIMD_RUNNERS[(S.F_AXES, False)]):
        params = list(inspect.signature(runner.py_func).parameters)
        assert [params[i] for i in where] == list(names), params


# ------------------------------------------------------------------ code generation


@pytest.mark.skipif(os.environ.get("NUMBA_DISABLE_JIT") == "1",
                    reason="needs the compiled kernels")
def test_the_rotations_are_inlined_into_the_drivers():
    """The increment-form turns, kernels of their own, are inlined by LLVM into the
    one-body drivers (``trig.inline_into_callers``: a call per rotation cost the one-body
    step 10-20 %). The drivers of a free body's and a heavy top's ``splitting2``, compiled
    afresh, hold no call to them, and give the cached drivers' numbers."""
    import numba

    from liebody._kernels.driver import RUNNERS

    free = liebody.FreeBody(liebody.RigidBody([1.0, 2.0, 3.0]))
    top = liebody.HeavyTop(liebody.RigidBody([5.0, 5.0, 1.0]), mass=2.0, cm=[0, 0, 1.0])
    L0 = np.array([0.3, -0.2, 0.5])
    for scene, turns in ((free, ("_turn_increment",)),
                         (top, ("recurring_turn", "recurring_exp"))):
        plan = liebody.methods()["splitting2"].plan(scene, L0, 0.01)
        runner = RUNNERS[plan.family]
        opts = {k: v for k, v in runner.targetoptions.items() if k not in ("cache", "nopython")}
        fresh = numba.njit(**opts)(runner.py_func)
        out = []
        for r in (runner, fresh):
            q_out, m_out = np.empty((20, 4)), np.empty((20, 3))
            state = np.concatenate([[1.0, 0.0, 0.0, 0.0], L0])
            drive(plan, 0.01, 20, state, q_out, m_out, runners={plan.family: r})
            out.append((q_out, m_out))
        assert np.array_equal(out[0][0], out[1][0]) and np.array_equal(out[0][1], out[1][1])
        ir = fresh.inspect_llvm(fresh.signatures[0])
        for name in turns:
            calls = re.findall(
                rf"call [^\n]*@(_ZN7liebody8_kernels5flows{len(name)}{name}\S*)\(", ir)
            assert not calls, (name, calls)


@pytest.mark.skipif(os.environ.get("NUMBA_DISABLE_JIT") == "1",
                    reason="needs the compiled kernels")
def test_the_gravity_gradient_torque_is_inlined_into_its_callers():
    """The gravity-gradient torque, a kernel of its own (numba's IR inlining doubled the
    drivers' compile time), is inlined by LLVM (``trig.inline_into_callers``): a kernel
    that calls it, compiled afresh, holds no call to it, and gives the same numbers."""
    import math

    import numba

    from liebody._models import gravity_gradient
    from liebody.orbits import Circular

    scene = liebody.GravityGradient(liebody.RigidBody([100.0, 120.0, 80.0]),
                                    [(3.986e14, Circular(1.1e-3, 7.0e6, phase=math.pi))])
    model = scene.torque_model()
    mp, ms = np.asarray(model.params[0], dtype=float), np.asarray(model.shared, dtype=float)
    kick = numba.njit(lambda t, q, mp, ms: gravity_gradient.torque(
        t, q[0], q[1], q[2], q[3], mp, ms))
    q = np.array([0.9, 0.1, -0.2, 0.3]) / np.linalg.norm([0.9, 0.1, -0.2, 0.3])
    assert kick(12.5, q, mp, ms) == gravity_gradient.torque(12.5, *q, mp, ms)
    ir = kick.inspect_llvm(kick.signatures[0])
    calls = re.findall(r"call [^\n]*@(_ZN7liebody7_models16gravity_gradient6torque\S*)\(", ir)
    assert not calls, calls
