"""A diagnostic never loses a computed trajectory; a potential that cannot work is refused
before the run."""

from __future__ import annotations

import numpy as np
import pytest
from numba import njit

import liebody


@njit
def _gravity(t, q, L):
    w, x, y, z = q[0], q[1], q[2], q[3]
    return np.array([2.0 * (y * z + w * x), -2.0 * (x * z - w * y), 0.0])


def _potential_failing_far_from_the_start(q):
    if q[0] < 0.99:
        raise RuntimeError("no potential here")
    return float(q[3] ** 2 - q[1] ** 2 - q[2] ** 2 + q[0] ** 2)


def _potential_returning_an_array(q):
    return np.array([1.0, 2.0])


def _potential_nan(q):
    return float("nan")


def _scene(potential):
    return liebody.TorqueBody(liebody.RigidBody([2.0, 2.0, 1.0]), _gravity, potential=potential,
                              orientation_only=True)


def test_a_potential_that_raises_at_the_end_warns_and_returns_the_run():
    scene = _scene(_potential_failing_far_from_the_start)
    with pytest.warns(liebody.InvariantWarning, match="invariant check failed.*RuntimeError.*"
                                                      "no potential here.*returned unchecked"):
        tr = liebody.integrate(scene, L0=[3.0, 0.0, 1.0], dt=0.01, steps=300)
    assert tr.status == "complete" and tr.q.shape == (301, 4)
    assert tr.q[-1, 0] < 0.99  # the run did go where the potential fails


@pytest.mark.parametrize(("potential", "match"), [
    (_potential_returning_an_array, "potential raised TypeError on the initial orientation"),
    (_potential_nan, r"potential is not finite on the initial orientation \(V = nan\)"),
    (lambda q: 1 / 0, "potential raised ZeroDivisionError"),
])
def test_a_potential_that_cannot_work_is_refused_before_the_run(potential, match):
    with pytest.raises(ValueError, match=match):
        liebody.integrate(_scene(potential), L0=[3.0, 0.0, 1.0], dt=0.01, steps=10)
