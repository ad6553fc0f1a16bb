"""Shared test helpers: standard bodies, orientation distance, the observed order.

Imported as ``from support import ...`` (``tests`` is on pytest's ``pythonpath``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

import liebody


def hlw_body() -> liebody.RigidBody:
    """Hairer, Lubich & Wanner's body ``I = (2, 1, 2/3)`` (breaks the triangle inequality)."""
    return liebody.RigidBody([2.0, 1.0, 2.0 / 3.0], check_triangle=False)


HLW_L0 = np.array([np.cos(1.1), 0.0, np.sin(1.1)])


def physical_body() -> liebody.RigidBody:
    """A real asymmetric body: a uniform 3 x 2 x 1 box of mass 1, axes in no special order."""
    from liebody import inertia

    return liebody.RigidBody(inertia.box(1.0, 3.0, 2.0, 1.0), mass=1.0)


PHYSICAL_L0 = np.array([0.3, -0.2, 0.9])


def rotation_distance(q1: np.ndarray, q2: np.ndarray) -> np.ndarray:
    """Max-norm distance between orientations, modulo the sign of the quaternion."""
    return np.minimum(np.abs(q1 - q2).max(axis=-1), np.abs(q1 + q2).max(axis=-1))


def state_error(traj, q_ref, L_ref) -> float:
    """Final-state error of a trajectory: ``|L|`` relative and ``q`` up to sign, the larger."""
    scale = float(np.linalg.norm(traj.L[0]))
    return max(float(np.abs(traj.L[-1] - L_ref).max()) / scale,
               float(rotation_distance(traj.q[-1], q_ref)))


@dataclass
class Order:
    """An observed order: the slope and the steps and errors it was read from."""

    order: float
    steps: tuple[float, float]
    hs: np.ndarray
    errors: np.ndarray

    def __repr__(self) -> str:
        pairs = ", ".join(f"{h:.3g}: {e:.3g}" for h, e in zip(self.hs, self.errors, strict=True))
        return (f"Order({self.order:.3f} from h = {self.steps[0]:.3g} -> {self.steps[1]:.3g}; "
                f"errors {{{pairs}}})")


def observed_order(error: Callable[[int], float], n0: int, t_end: float, *,
                   floor: float = 1e-11, ceiling: float = 1e-2, levels: int = 20,
                   settle: float = 0.1) -> Order:
    """Observed order of a method from a ladder of halved steps ``h = t_end / (n0 2^k)``.

    ``error(n)`` is the final error after ``n`` steps of size ``t_end / n``; a step at
    which the method refuses (``ValueError``) or does not converge
    (:class:`liebody.ConvergenceError`) counts as outside the asymptotic range. The
    ladder halves the step until the error drops below the round-off ``floor``, or
    until the last two slopes inside the range ``(floor, ceiling)`` agree to
    ``settle`` (the asymptotic regime reached). The order is the slope between the two
    smallest steps whose errors lie in the range, so it works for any order
    (1, 3, 10, ...) without a table of starting steps.
    """
    hs, errs = [], []

    def slope(i: int, j: int) -> float:
        return float(np.log(errs[i] / errs[j]) / np.log(hs[i] / hs[j]))

    for k in range(levels):
        n = n0 * 2**k
        try:
            e = float(error(n))
        except (ValueError, liebody.ConvergenceError):
            e = math.inf
        hs.append(t_end / n)
        errs.append(e)
        if e <= floor:
            break
        inside = [floor < v < ceiling for v in errs[-3:]]
        if len(inside) == 3 and all(inside) and abs(slope(-3, -2) - slope(-2, -1)) < settle:
            break
    hs, errs = np.array(hs), np.array(errs)
    ok = np.flatnonzero((errs > floor) & (errs < ceiling))
    if len(ok) < 2 or ok[-1] - ok[-2] != 1:
        raise AssertionError(f"no asymptotic range between {floor:g} and {ceiling:g}: "
                             f"{dict(zip(hs.round(6), errs, strict=True))}")
    i, j = ok[-2], ok[-1]
    return Order(slope(i, j), (float(hs[i]), float(hs[j])), hs, errs)


def drive(plan, h: float, n: int, state: np.ndarray, q_out: np.ndarray, m_out: np.ndarray,
          torque_addr=0, runners=None):
    """Call the driver kernel of the plan's family directly (one slice from step 0, saving
    every step)."""
    if runners is None:
        from liebody._kernels.driver import RUNNERS as runners
    ctl = np.array([1, 0], dtype=np.int64)
    return runners[plan.family](plan.kinds, plan.axes, plan.coefs, plan.clock, plan.params[0],
                                plan.merge_ends, h, 0.0, 0.0, n, 1, True, state, ctl, q_out,
                                m_out,
                                torque_addr, np.zeros(10), np.zeros(3))


def kernel_run(name: str, scene, L0, h: float, n: int, q0=(1.0, 0.0, 0.0, 0.0)):
    """``n`` steps of method ``name`` straight through the driver: final state and samples."""
    plan = liebody.methods()[name].plan(scene, L0, abs(h))
    q_out, m_out = np.empty((n, 4)), np.empty((n, 3))
    state = np.concatenate([q0, L0]).astype(float)
    drive(plan, h, n, state, q_out, m_out)
    return state, q_out, m_out
