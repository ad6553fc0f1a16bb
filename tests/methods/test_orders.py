"""Verification: every registered stepping method converges at its declared order.

References are independent of the method: the exact flow (itself checked against
DOP853 at rtol 1e-13 and 34-digit mpmath in ``kernels/test_exact_flow.py``) and, for
the NO_SQUISH ordering, the (q, p) algorithm of Miller et al. (2002) written out here.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

import liebody
from support import HLW_L0, PHYSICAL_L0, hlw_body, observed_order, physical_body, state_error

STEPPERS = [m.name for m in liebody.methods() if not m.exact_when_free]
EXACT_WHEN_FREE = [m.name for m in liebody.methods() if m.exact_when_free and not m.sampled]


@pytest.mark.parametrize("body", ["hlw", "physical"])
@pytest.mark.parametrize("name", STEPPERS)
def test_observed_order_matches_declared(name, body):
    """Log-log slope of the final error against the exact flow equals the declared order.

    The ladder starts at one step over the whole interval and halves the step; steps a
    method refuses, fails at or is far from its asymptotic range at are left out.
    """
    scene = liebody.FreeBody(hlw_body() if body == "hlw" else physical_body())
    L0 = HLW_L0 if body == "hlw" else PHYSICAL_L0
    method = liebody.methods()[name]
    t_end = 4.0
    ref = liebody.integrate(scene, L0=L0, dt=t_end, steps=1)  # exact flow

    def error(n):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # a blow-up at a large step
            tr = liebody.integrate(scene, L0=L0, dt=t_end / n, steps=n, method=name,
                                   save_every=n)
        return math.inf if tr.failed_at is not None else state_error(tr, ref.q[-1], ref.L[-1])

    floor = 1e-12 if method.order >= 10 else 1e-11  # the exact-flow reference: ~1e-15
    found = observed_order(error, 1, t_end, floor=floor)
    assert abs(found.order - method.order) < 0.3, found


@pytest.mark.parametrize("name", EXACT_WHEN_FREE)
def test_kick_and_exact_flow_splittings_are_exact_on_a_free_body(name):
    """SABA_n on a free body: its kicks vanish and its drifts are the exact flow, so at
    any step it is the exact flow (sampled by the ``exact`` method) to round-off; its
    order is measured on the torqued scenes (tests/scenes)."""
    assert EXACT_WHEN_FREE, "no such method registered: the test would check nothing"
    scene = liebody.FreeBody(hlw_body())
    for n in (1, 3, 40):
        ref = liebody.integrate(scene, L0=HLW_L0, dt=4.0 / n, steps=n)
        tr = liebody.integrate(scene, L0=HLW_L0, dt=4.0 / n, steps=n, method=name)
        assert state_error(tr, ref.q[-1], ref.L[-1]) < 5e-15 * (1 + n)


def test_observed_order_helper_rejects_what_it_cannot_measure():
    """No asymptotic range (an error at round-off from the start) is an error, not a pass."""
    with pytest.raises(AssertionError, match="no asymptotic range"):
        observed_order(lambda n: 1e-16, 4, 1.0)
    # a synthetic order-3 error, with a large-step regime refused and a round-off floor
    def error(n):
        h = 1.0 / n
        if h > 0.3:
            raise ValueError("step too large")
        return max(0.7 * h**3, 3e-13)

    found = observed_order(error, 1, 1.0)
    assert abs(found.order - 3.0) < 1e-9 and found.steps[1] < found.steps[0] <= 0.3


def _no_squish_step(q, p, I, h):
    """One NO_SQUISH step in Miller et al.'s (q, p) variables (free rotor), written out from
    their paper: sub-steps 3, 2, 1, 2, 3 with ``zeta = p . P_k q / (4 I_k)`` and
    ``(q, p) <- cos(zeta t) (q, p) + sin(zeta t) (P_k q, P_k p)``."""

    def perm(k, v):
        w, x, y, z = v
        return (np.array([-x, w, z, -y]), np.array([-y, -z, w, x]),
                np.array([-z, y, -x, w]))[k]

    for k, t in ((2, h / 2), (1, h / 2), (0, h), (1, h / 2), (2, h / 2)):
        zeta = p @ perm(k, q) / (4.0 * I[k])
        c, s = np.cos(zeta * t), np.sin(zeta * t)
        q, p = c * q + s * perm(k, q), c * p + s * perm(k, p)
    return q, p


def test_no_squish_is_miller_et_als_algorithm(physical):
    """The registered ``no_squish`` reproduces the published (q, p) algorithm to round-off."""
    scene, L0 = physical
    q0 = liebody.quaternion.random(rng=5)
    I = scene.moments
    q = q0.copy()
    p = 2.0 * liebody.quaternion.multiply(q0, np.r_[0.0, L0])  # p = 2 q (0, L)
    h, n = 0.05, 400
    for _ in range(n):
        q, p = _no_squish_step(q, p, I, h)
    L = 0.5 * liebody.quaternion.multiply(liebody.quaternion.conjugate(q), p)[1:]
    tr = liebody.integrate(scene, q0=q0, L0=L0, dt=h, steps=n, method="no_squish")
    assert tr.info["axis_ordering"] == (2, 1, 0)
    assert np.abs(tr.L[-1] - L).max() < 1e-12
    assert min(np.abs(tr.q[-1] - q).max(), np.abs(tr.q[-1] + q).max()) < 1e-12
