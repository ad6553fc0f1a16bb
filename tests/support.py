"""Shared test helpers: standard bodies, orientation distance, the observed order.

Imported as ``from support import ...`` (``tests`` is on pytest's ``pythonpath``).
"""

from __future__ import annotations

import json
import math
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

import liebody
import liebody.testing
from liebody._kernels import stages as S


def hlw_body() -> liebody.RigidBody:
    """Hairer, Lubich & Wanner's body ``I = (2, 1, 2/3)`` (breaks the triangle inequality)."""
    return liebody.RigidBody([2.0, 1.0, 2.0 / 3.0], check_triangle=False)


HLW_L0 = np.array([np.cos(1.1), 0.0, np.sin(1.1)])


def physical_body() -> liebody.RigidBody:
    """A real asymmetric body: a uniform 3 x 2 x 1 box of mass 1, axes in no special order."""
    from liebody import inertia

    return liebody.RigidBody(inertia.box(1.0, 3.0, 2.0, 1.0), mass=1.0)


PHYSICAL_L0 = np.array([0.3, -0.2, 0.9])


def same_trajectory(a: liebody.Trajectory, b: liebody.Trajectory, scene: bool = True) -> None:
    """Assert the same fields and values (but the scene, with ``scene=False``: a run of
    another scene), and read-only arrays."""
    assert vars(a).keys() == vars(b).keys()
    for k, v in vars(b).items():
        if k == "scene" and not scene:
            continue
        got = getattr(a, k)
        assert np.array_equal(got, v) if isinstance(v, np.ndarray) else got == v, k
    for arr in (a.t, a.q, a.L):
        assert not arr.flags.writeable


def run_threads(targets: list[Callable[[], None]]) -> None:
    """Run the functions in threads at once, switching threads as often as possible."""
    import threading

    interval = sys.getswitchinterval()
    sys.setswitchinterval(1e-6)
    try:
        threads = [threading.Thread(target=f) for f in targets]
        for th in threads:
            th.start()
        for th in threads:
            th.join()
    finally:
        sys.setswitchinterval(interval)


#: Yoshida's triple jump (1990): a composition whose stages read the times -0.35 and 1.35
#: steps from the step's start, outside the step
TRIPLE_JUMP = (1.0 / (2.0 - 2.0 ** (1.0 / 3.0)), 1.0 - 2.0 / (2.0 - 2.0 ** (1.0 / 3.0)),
               1.0 / (2.0 - 2.0 ** (1.0 / 3.0)))


def table_gravity_gradient(free_flow: str = "auto") -> liebody.GravityGradient:
    """A gravity-gradient body under a source sampled by a ``Table`` of 101 positions on
    ``[0, 10]`` (of a circular orbit)."""
    from liebody.orbits import Circular, Table

    t = np.linspace(0.0, 10.0, 101)
    orbit = Circular(n=0.05, radius=10.0, inclination=0.2, raan=0.1, phase=0.3)
    return liebody.GravityGradient(liebody.RigidBody([1.0, 1.7, 2.6]),
                                   [(1.0, Table(t, orbit.position(t)))], free_flow=free_flow)


def rotation_distance(q1: np.ndarray, q2: np.ndarray) -> np.ndarray:
    """Max-norm distance between orientations, modulo the sign of the quaternion."""
    return np.minimum(np.abs(q1 - q2).max(axis=-1), np.abs(q1 + q2).max(axis=-1))


def state_error(traj, q_ref, L_ref) -> float:
    """Final-state error of a trajectory: ``|L|`` relative and ``q`` up to sign, the larger."""
    scale = float(np.linalg.norm(traj.L[0]))
    return max(float(np.abs(traj.L[-1] - L_ref).max()) / scale,
               float(rotation_distance(traj.q[-1], q_ref)))


def observed_order(error: Callable[[int], float], n0: int, t_end: float, *,
                   floor: float = 1e-11, ceiling: float = 1e-2, levels: int = 20,
                   settle: float = 0.1) -> liebody.testing.Order:
    """Observed order of a method from a ladder of halved steps ``h = t_end / (n0 2^k)``:
    :func:`liebody.testing.observed_order` on ``error``, the library's estimate.

    ``error(n)`` is the final error after ``n`` steps of size ``t_end / n``; a step at
    which the method refuses (``ValueError``) or does not converge
    (:class:`liebody.ConvergenceError`) counts as outside the asymptotic range. No
    asymptotic range is an ``AssertionError`` (a test that measured nothing fails).
    """
    def guarded(n: int) -> float:
        try:
            return float(error(n))
        except (ValueError, liebody.ConvergenceError):
            return math.inf

    try:
        return liebody.testing.observed_order(
            error=guarded, t_end=t_end, h_max=t_end / n0, floor=floor, ceiling=ceiling,
            settle=settle, levels=levels, max_steps=n0 * 2 ** (levels - 1))
    except ValueError as exc:
        raise AssertionError(str(exc)) from None


def drive(plan, h: float, n: int, state: np.ndarray, q_out: np.ndarray, m_out: np.ndarray,
          torque_addr=0, runners=None):
    """Call the driver kernel of the plan's family directly (one slice from step 0, saving
    every step)."""
    if runners is None:
        from liebody._kernels.driver import RUNNERS as runners
    ctl = np.array([1, 0], dtype=np.int64)
    return runners[plan.family](plan.kinds, plan.axes, plan.coefs, plan.clock, plan.params[0],
                                plan.slots, plan.merge_ends, h, 0.0, 0.0, n, 1, True, state,
                                ctl, q_out, m_out, torque_addr, plan.model[0], plan.model_shared,
                                np.zeros(S.DREF_WIDTH), np.zeros(3))


def kernel_run(name: str, scene, L0, h: float, n: int, q0=(1.0, 0.0, 0.0, 0.0)):
    """``n`` steps of method ``name`` straight through the driver: final state and samples."""
    plan = liebody.methods()[name].plan(scene, L0, abs(h))
    q_out, m_out = np.empty((n, 4)), np.empty((n, 3))
    state = np.concatenate([q0, L0]).astype(float)
    drive(plan, h, n, state, q_out, m_out)
    return state, q_out, m_out


_ROOT = Path(__file__).resolve().parents[1]


def interrupt_child(script: str, args: list[str], wait: float) -> tuple[list[dict], float]:
    """Run ``script``, SIGINT it ``wait`` s after it prints "ready"; its JSON lines and
    the seconds from the signal to its first line after it."""
    proc = subprocess.Popen([sys.executable, "-c", script, *args], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, cwd=_ROOT)
    try:
        assert proc.stdout.readline().strip() == "ready", proc.stderr.read()
        time.sleep(wait)
        sent = time.perf_counter()
        proc.send_signal(signal.SIGINT)
        first = proc.stdout.readline()
        latency = time.perf_counter() - sent
        # bounded: a child that ignores the signal fails the test, never hangs it
        rest, stderr = proc.communicate(timeout=120)
    except subprocess.TimeoutExpired:
        pytest.fail("the child did not finish within 120 s of SIGINT")
    finally:
        proc.kill()
    lines = [json.loads(x) for x in (first + rest).splitlines() if x.strip()]
    assert lines and proc.returncode == 0, (proc.returncode, stderr)
    return lines, latency


def stepper_states(stepper, calls: int, n: int):
    """The states and times ``(q, L, t)`` of a stepper at the start and after each of
    ``calls`` calls ``step(n)`` (arrays with a leading axis of ``calls + 1``)."""
    qs, Ls, ts = [stepper.q], [stepper.L], [stepper.t]
    for _ in range(calls):
        stepper.step(n)
        qs.append(stepper.q)
        Ls.append(stepper.L)
        ts.append(stepper.t)
    return np.array(qs), np.array(Ls), np.array(ts)


class InterruptingClock:
    """``time`` for a module (the stepper's) whose ``perf_counter`` raises
    KeyboardInterrupt at its ``at``-th call: a slice reads the clock before and after its
    kernel call, so an even ``at`` is Ctrl-C seen as a slice returns and an odd ``at``
    Ctrl-C just before the next slice starts, after ``(at - 1) / 2`` slices done."""

    def __init__(self, at: int) -> None:
        self.at, self.calls = at, 0

    def perf_counter(self) -> float:
        self.calls += 1
        if self.calls == self.at:
            raise KeyboardInterrupt
        return time.perf_counter()
