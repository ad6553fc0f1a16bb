"""An ensemble Stepper of reaction wheels whose bodies reach their speed limits at different
steps of a call: a piece of the call that another body's saturation ends does not end a
body's merged step (splitting2 runs the last kick of a step with the next one's first),
so that every body keeps the numbers of its one-body stepper (simd=False), also when
Ctrl-C comes at any point of the call and when a body fails after such a cut."""

from __future__ import annotations

import numpy as np
import pytest

import liebody
from liebody import _stepper, _wheels
from liebody._kernels import stages as S
from liebody.wheels import Saturation
from support import InterruptingClock

I = np.array([3.0, 5.0, 7.0])
Q0 = liebody.quaternion.exp([0.3, -0.2, 0.1])
W0 = np.array([0.04, -0.03, 0.02])
U = np.array([[0.01, -0.02, 0.03], [-0.03, 0.01, 0.02], [0.06, 0.0, -0.01]])


def _scene():
    bodies = liebody.RigidBody.batch([I, [4.0, 5.0, 6.0], [3.5, 2.5, 6.0]])
    J = np.array([[0.05, 0.04, 0.06], [0.06, 0.05, 0.04], [0.03, 0.04, 0.05]])
    return liebody.ReactionWheels(bodies, np.eye(3), J, momentum=[0.1, 0.2, -0.1],
                                  max_speed=[12.0, 13.0, 14.0], max_torque=0.05)


SCENE = _scene()


def _ensemble(calls=()):
    s = liebody.Stepper(SCENE, q0=Q0, omega0=W0, dt=0.1, controls=U, simd=False)
    for n in calls:
        s.step(n)
    return s


def _one_body(i, calls):
    s = liebody.Stepper(SCENE.take(i), q0=Q0, omega0=W0, dt=0.1, controls=U[i])
    for n in calls:
        if n:
            s.step(n)
    return s


def _assert_bodies_are_their_one_body_steppers(s, calls, bodies=(0, 1, 2)):
    for i in bodies:
        one = _one_body(i, calls)
        np.testing.assert_array_equal(s.q[i], one.q)
        np.testing.assert_array_equal(s.L[i], one.L)
        np.testing.assert_array_equal(s.wheel_momentum[i], one.wheel_momentum)
        assert [e for e in s.saturations if e.body == i] == [
            e._replace(body=i) for e in one.saturations]
        assert s.t == one.t


def _assert_same(s, twin):
    assert s.t == twin.t and s.steps == twin.steps
    np.testing.assert_array_equal(s.q, twin.q)
    np.testing.assert_array_equal(s.L, twin.L)
    np.testing.assert_array_equal(s.wheel_momentum, twin.wheel_momentum)
    assert s.saturations == twin.saturations
    assert not s.failed.any()


def _assert_as_its_twin(s, m: int) -> None:
    """The stepper ``s``, interrupted after ``m`` steps of its third call, is one that took
    ``step(m)`` there, every body its one-body stepper's, then and after 150 steps more."""
    twin = _ensemble([100, 100, m] if m else [100, 100])
    _assert_same(s, twin)
    _assert_bodies_are_their_one_body_steppers(s, [100, 100, m])
    s.step(150)
    twin.step(150)
    _assert_same(s, twin)


def _step_interrupted(s, at: int, monkeypatch):
    """``s.step(100)`` with Ctrl-C at the ``at``-th clock reading: the exception (checked:
    a KeyboardInterrupt, at the stepper's time), or ``None`` when the call finished."""
    monkeypatch.setattr(_stepper, "time", InterruptingClock(at))
    try:
        s.step(100)
        return None
    except liebody.IntegrationInterrupted as exc:
        assert isinstance(exc, KeyboardInterrupt) and exc.t == s.t
        return exc
    finally:
        monkeypatch.undo()


def test_the_third_call_is_cut_where_bodies_keep_their_merged_steps(monkeypatch):
    """The case the tests below interrupt: the call from step 200 is cut at 273 and 274
    by body 1's landing on its limit, where bodies 0 and 2 go on merged (before the fix
    every body's step ended unmerged there, and they differed from their one-body
    steppers by round-off)."""
    pieces = []
    advance = _stepper.Stepper._advance

    def counted(self, n, keep=None, carry=False):
        pieces.append((self.steps, n, None if keep is None else keep.tolist()))
        return advance(self, n, keep, carry)

    s = _ensemble([100, 100])
    monkeypatch.setattr(_stepper.Stepper, "_advance", counted)
    s.step(100)
    assert pieces == [(200, 73, [True, False, True]), (273, 1, [True, False, True]),
                      (274, 26, None)]
    assert s.saturations[-1] == Saturation(1, s.saturations[-1].t, 0, "speed")
    assert s.saturations[-1].t == pytest.approx(27.4, abs=1e-12)
    _assert_bodies_are_their_one_body_steppers(s, [100, 100, 100])


def test_ctrl_c_between_slices_leaves_every_body_as_a_shorter_call_would(monkeypatch):
    """Ctrl-C as a slice returns or before the next starts, at every point of the cut
    call (also at the end of a piece that left bodies merged, which the next step of the
    call completes): IntegrationInterrupted with exc.step = m, the stepper equal to one
    that took step(m) there, every body to its one-body stepper, then and after 150 steps
    more."""
    seen = set()
    for at in range(1, 25):
        s = _ensemble([100, 100])
        exc = _step_interrupted(s, at, monkeypatch)
        m = None if exc is None else exc.step
        if m is None:
            break
        seen.add(m)
        assert 0 <= m <= 100 and s.steps == 200 + m
        _assert_as_its_twin(s, m)
        _assert_bodies_are_their_one_body_steppers(s, [100, 100, m, 150])
    # the slices ending the cut pieces (73, 74) were interrupted: completed one step on
    assert {0, 74, 75, 100} <= seen


class _Interrupting:
    """A method raising KeyboardInterrupt at its calls ``at`` (counted from 1), before it
    runs or after."""

    def __init__(self, inner, at, after: bool) -> None:
        self.inner, self.at, self.after, self.calls = inner, set(at), after, 0

    def __call__(self, obj, *args):
        self.calls += 1
        if self.calls in self.at and not self.after:
            raise KeyboardInterrupt
        out = self.inner(obj, *args)
        if self.calls in self.at and self.after:
            raise KeyboardInterrupt
        return out


@pytest.mark.parametrize("after", [False, True])
@pytest.mark.parametrize(("where", "at"), [
    ("segment", (1,)), ("segment", (2,)), ("segment", (3,)), ("segment", (3, 4)),
    ("segment", (3, 4, 5)), ("_write", (1,)), ("_write", (2,)), ("_write", (1, 2)),
    ("_write", (2, 3)), ("_write", (1, 2, 3))])
def test_ctrl_c_between_the_pieces_of_a_call(where, at, after, monkeypatch):
    """Ctrl-C while the next piece is planned (WheelState.segment: the wheels advanced to
    it or not) or its stage rows written (WheelStepper._write), with bodies left merged
    by the last piece, and again while that merged step is completed: the stepper is one
    that took exc.step steps of the call, every body its one-body stepper's."""
    s = _ensemble([100, 100])
    owner = _wheels.WheelState if where == "segment" else _wheels.WheelStepper
    hook = _Interrupting(getattr(owner, where), at, after)
    monkeypatch.setattr(owner, where, lambda obj, *args: hook(obj, *args))
    with pytest.raises(liebody.IntegrationInterrupted) as info:
        s.step(100)
    monkeypatch.undo()
    m = info.value.step
    assert m in (0, 74, 75) and s.steps == 200 + m and info.value.t == s.t
    _assert_as_its_twin(s, m)


def test_a_body_failing_after_a_merged_cut_is_left_at_its_state_before_the_call(
        monkeypatch):
    """Body 0 goes on merged across the cut at step 273 and is reported failed by the
    driver in the next piece (the failure injected: its status set before the piece
    runs, so the driver skips it). It is left at its state before the call, not at the
    merged state it entered the piece with, its wheels too; the others go on as their
    one-body steppers, and body 0 stays there."""
    s = _ensemble([100, 100])
    q0, L0, h0 = s.q[0], s.L[0], s.wheel_momentum[0]
    records = s.saturations
    run = _stepper.Stepper._run

    def failing(self, call, w, start, k, final):
        if call["k0"] + start == 273:
            g = w["g"]
            g["status"][np.flatnonzero(g["idx"] == 0)] = S.STATUS_NONFINITE
        return run(self, call, w, start, k, final)

    monkeypatch.setattr(_stepper.Stepper, "_run", failing)
    with pytest.warns(RuntimeWarning, match="1 of 3 bodies failed"):
        s.step(100)
    monkeypatch.undo()
    assert s.failed.tolist() == [True, False, False]
    np.testing.assert_array_equal(s.q[0], q0)
    np.testing.assert_array_equal(s.L[0], L0)
    np.testing.assert_array_equal(s.wheel_momentum[0], h0)
    _assert_bodies_are_their_one_body_steppers(s, [100, 100, 100], bodies=(1, 2))
    s.step(250)
    np.testing.assert_array_equal(s.L[0], L0)
    np.testing.assert_array_equal(s.wheel_momentum[0], h0)
    assert [e for e in s.saturations if e.body == 0] == [e for e in records if e.body == 0]
    _assert_bodies_are_their_one_body_steppers(s, [100, 100, 100, 250], bodies=(1, 2))


def test_ctrl_c_in_a_one_body_call_counts_the_steps_of_the_call(monkeypatch):
    """One body cut by its own landing (at steps 273 and 274 of a call from 200): Ctrl-C
    at any slice gives exc.step counted from the call's start (before the fix, from the
    piece's: 0 or 26 where 74 or 100 steps of the call were done), and the stepper is
    one that took step(exc.step)."""
    seen = set()
    for at in range(1, 40):
        s = _one_body(1, [100, 100])
        exc = _step_interrupted(s, at, monkeypatch)
        m = None if exc is None else exc.step
        if m is not None:
            assert f"after {m:,} of 100 steps" in str(exc)
        if m is None:
            break
        seen.add(m)
        assert s.steps == 200 + m
        twin = _one_body(1, [100, 100, m])
        assert s.t == twin.t
        np.testing.assert_array_equal(s.q, twin.q)
        np.testing.assert_array_equal(s.L, twin.L)
        np.testing.assert_array_equal(s.wheel_momentum, twin.wheel_momentum)
        assert s.saturations == twin.saturations
    assert {0, 73, 74, 100} <= seen


@pytest.mark.parametrize("method", ["splitting2", "splitting4"])
def test_a_large_ensemble_on_two_threads_equals_its_one_body_steppers(method):
    """130 bodies in two chunks on two threads, random commands and limits (hundreds of
    saturations over calls of 100, 37, 250, 1 and 113 steps): each body equals its
    one-body stepper bit for bit (before the fix every body differed, by round-off)."""
    rng = np.random.default_rng(3)
    n = 130
    bodies = liebody.RigidBody.batch(np.array([4.0, 5.0, 6.0]) * rng.uniform(0.9, 1.1, (n, 3)))
    scene = liebody.ReactionWheels(bodies, np.eye(3), rng.uniform(0.03, 0.06, (n, 3)),
                                   momentum=[0.1, 0.2, -0.1], max_speed=12.0, max_torque=0.05)
    u = rng.uniform(-0.04, 0.04, (n, 3))
    q0 = liebody.quaternion.random(n, rng=1)
    w0 = rng.normal(scale=0.1, size=(n, 3))
    calls = [100, 37, 250, 1, 113]
    ens = liebody.Stepper(scene, q0=q0, omega0=w0, dt=0.1, controls=u, simd=False,
                          threads=2, method=method)
    for c in calls:
        ens.step(c)
    assert len(ens._work) == 2 and len(ens.saturations) > 200
    for i in range(n):
        one = liebody.Stepper(scene.take(i), q0=q0[i], omega0=w0[i], dt=0.1, controls=u[i],
                              method=method)
        for c in calls:
            one.step(c)
        np.testing.assert_array_equal(ens.q[i], one.q)
        np.testing.assert_array_equal(ens.L[i], one.L)
        np.testing.assert_array_equal(ens.wheel_momentum[i], one.wheel_momentum)
