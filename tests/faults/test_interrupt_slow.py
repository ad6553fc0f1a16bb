"""Ctrl-C in integrate() with a slow user torque: seen within seconds (the first slice of
a user torque is small, later ones sized by their measured time), and the finished steps
are kept on the exception's trajectory."""

from __future__ import annotations

import textwrap

import pytest

from support import interrupt_child

_CHILD = textwrap.dedent("""
import json, signal, sys, time
import numpy as np
from numba import njit
import liebody

signal.signal(signal.SIGINT, signal.default_int_handler)  # (background jobs ignore it)


@njit
def slow(t, q, L):
    s = 0.0
    for i in range(100_000):  # a few milliseconds (a serial chain of sines)
        s = np.sin(s + 1e-9 * i)
    return np.array([0.0, 0.0, 1e-3 + 0.0 * s])


scene = liebody.TorqueBody(liebody.RigidBody([1.0, 2.0, 3.0]), slow, orientation_only=True)
bodies = int(sys.argv[2])
L0 = [0.3, -1.0, 0.6] if bodies == 1 else [[0.3, -1.0, 0.6 + 0.1 * i] for i in range(bodies)]
kw = dict(L0=L0, dt=0.01, method="splitting2", save_every=1)
if bodies > 1:
    kw["threads"] = 2
liebody.integrate(scene, steps=2, **kw)  # compiled
t = time.perf_counter()
liebody.integrate(scene, steps=20, **kw)
cost = (time.perf_counter() - t) / 20 / max(1, bodies // 2)  # (two threads)
print("ready", flush=True)
try:
    liebody.integrate(scene, steps=int(sys.argv[1]), **kw)
    print(json.dumps({"interrupted": False}), flush=True)
except liebody.IntegrationInterrupted as exc:
    traj = exc.trajectory
    print(json.dumps({"interrupted": True, "cost": cost, "kept": len(traj.t)}), flush=True)
    fresh = liebody.integrate(scene, steps=len(traj.t) - 1, **kw)
    same = bool(np.array_equal(fresh.q, traj.q) and np.array_equal(fresh.L, traj.L))
    print(json.dumps({"same": same, "step": exc.step}), flush=True)
""")


@pytest.mark.parametrize("bodies", [1, 4])
def test_ctrl_c_with_a_slow_torque_is_seen_within_seconds_and_keeps_the_steps_done(bodies):
    """One body, and an ensemble on two threads (every thread finishes its slice before
    the interruption is raised; the slices finished are kept for every body)."""
    lines, latency = interrupt_child(_CHILD, ["100000", str(bodies)], 2.0)
    out, check = lines[0], lines[-1]
    assert out["interrupted"], out
    assert out["cost"] > 1.2e-3  # the torque is slow, or the test proves nothing
    assert latency < 4.0  # (before: the first slice of 4096 steps, 5 s and more)
    # the steps of every finished slice are kept (2 s of steps at least), and they are the
    # run's own numbers
    assert out["kept"] > 1 + 1.0 / out["cost"] / 4, out
    assert check["same"] and check["step"] == out["kept"] - 1, check
