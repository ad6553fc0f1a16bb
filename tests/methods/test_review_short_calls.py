"""Review of the repeated short call keyed without t0 (``integrate()``'s kept call): a kept
call run from another clock origin, from another thread, into a failure or a Ctrl-C gives
what a first call on a fresh scene gives; and the failure reports' reach."""

from __future__ import annotations

import math
import warnings

import numba
import numpy as np
import pytest

import liebody
from liebody import _integrate
from liebody.errors import IntegrationInterrupted
from liebody.orbits import Circular
from support import hlw_body, run_threads, same_trajectory, table_gravity_gradient

BODY = liebody.RigidBody([1.0, 1.7, 2.6])
SOURCES = [(1.0, Circular(n=0.3, radius=2.0, inclination=0.4, phase=0.2))]
Q0 = liebody.quaternion.random(rng=7)
L0 = np.array([0.4, -1.1, 2.0])


def _gravity():
    """A torque that depends on the time (a circular orbit's source)."""
    return liebody.GravityGradient(BODY, SOURCES)


def _warned(fn):
    """``fn()``'s result (or exception) and its warnings as (category, words, file, line)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            out = fn()
        except Exception as exc:  # (compared with the first call's)
            out = exc
    return out, [(w.category, str(w.message), w.filename, w.lineno) for w in caught]


@pytest.mark.parametrize("method", ["splitting4", "rk4", "rattle"])
def test_a_kept_call_from_alternating_clocks_equals_first_calls(method):
    """One scene, one initial state (so the kept plan and driver arguments are reused), the
    clock origin alternating, negative, of other types (the general path, which leaves the
    kept call), a signed zero and large: every call equals a first call on a fresh scene,
    its times included."""
    scene = _gravity()
    origins = [7.0, -3.25, 7.0, np.float64(-3.25), 7, -3.25, 0.0, -0.0, 1e6, 0, 7.0, -3.25]
    for t0 in origins:
        kw = dict(dt=0.05, steps=2, method=method, t0=t0, save_every=1)
        got = liebody.integrate(scene, q0=Q0, L0=L0, **kw)
        same_trajectory(got, liebody.integrate(_gravity(), q0=Q0, L0=L0, **kw), scene=False)
        np.testing.assert_array_equal(got.t, float(t0) + 0.05 * np.arange(3.0))
    assert len(vars(scene)["_memo_short_calls"]) == 1


def test_threads_alternating_clocks_on_one_scene_get_their_own_runs():
    """Two threads alternate their own two clock origins on one scene's kept call: each
    run has its own times and numbers (the kept times and driver arguments are replaced
    whole, never changed in place)."""
    scene = _gravity()
    kw = dict(q0=Q0, L0=L0, dt=0.05, steps=2, method="splitting2", save_every=1)
    origins = [(1.0, 5.0), (9.0, 13.0)]
    ref = {t0: liebody.integrate(_gravity(), t0=t0, **kw) for pair in origins for t0 in pair}
    bad = []

    def loop(pair):
        for i in range(400):
            t0 = pair[i % 2]
            got = liebody.integrate(scene, t0=t0, **kw)
            if not (np.array_equal(got.t, ref[t0].t) and np.array_equal(got.q, ref[t0].q)
                    and np.array_equal(got.L, ref[t0].L)):
                bad.append(t0)

    run_threads([lambda p=p: loop(p) for p in origins])
    assert bad == []


@numba.njit
def _burst(t, q, L):
    """A torque that drives |L| beyond 1e150 (finite) in one step from t = 5 on."""
    if t >= 5.0:
        return np.array([1e153, 0.0, 0.0])
    return np.array([0.0, 0.0, 0.0])


def test_a_kept_call_that_overflows_at_a_later_clock_reports_as_a_first_call():
    """A kept call, made at t0 = 0, run from t0 = 5 where the torque drives |L| out of
    range: the samples, failed_at and the warning (words, category, the caller's line)
    of a first call from t0 = 5 on a fresh scene."""
    scene = liebody.TorqueBody(hlw_body(), _burst)
    kw = dict(q0=Q0, L0=L0, dt=0.1, steps=3, method="splitting2", save_every=1)
    liebody.integrate(scene, t0=0.0, **kw)
    got, got_w = _warned(lambda: liebody.integrate(scene, t0=5.0, **kw))
    fresh = liebody.TorqueBody(hlw_body(), _burst)
    first, first_w = _warned(lambda: liebody.integrate(fresh, t0=5.0, **kw))
    assert got.status == first.status == "failed" and got.failed_at == first.failed_at == 5.1
    for name in ("t", "q", "L"):
        np.testing.assert_array_equal(getattr(got, name), getattr(first, name))
    np.testing.assert_array_equal(got.t, [5.0])
    assert [w[:3] for w in got_w] == [w[:3] for w in first_w]
    assert len(got_w) == 1 and "|L| reached" in got_w[0][1] and "t = 5.1" in got_w[0][1]
    assert got_w[0][0] is RuntimeWarning and got_w[0][2] == __file__
    # back at t0 = 0 the kept call runs as before
    same_trajectory(liebody.integrate(scene, t0=0.0, **kw),
                    liebody.integrate(liebody.TorqueBody(hlw_body(), _burst), t0=0.0, **kw),
                    scene=False)


def _interrupt(*args, **kwargs):
    raise KeyboardInterrupt


@pytest.mark.parametrize("method", ["splitting2", "exact"])
def test_ctrl_c_in_a_kept_call_at_a_new_clock(monkeypatch, method):
    """Ctrl-C during a kept call's one driver (or exact flow) call, from a new clock
    origin: IntegrationInterrupted at that origin, after 0 steps, with the initial
    sample; the kept call then runs on."""
    scene = liebody.FreeBody(hlw_body())
    kw = dict(q0=Q0, dt=0.1, steps=3, method=method, save_every=1)
    first = liebody.integrate(scene, L0=L0, t0=1.0, **kw)
    if method == "exact":
        monkeypatch.setattr(_integrate, "_EXACT", [_interrupt])
    else:  # (a new initial state: a new plan, through the dispatch)
        monkeypatch.setattr(_integrate, "_drive", _interrupt)
    L1 = L0 * 1.5 if method != "exact" else L0
    with pytest.raises(IntegrationInterrupted, match=r"interrupted after 0 of 3 steps "
                                                     r"\(t = -2\.5\)") as info:
        liebody.integrate(scene, L0=L1, t0=-2.5, **kw)
    err = info.value
    assert err.step == 0 and err.t == -2.5
    assert err.trajectory.status == "interrupted"
    np.testing.assert_array_equal(err.trajectory.t, [-2.5])
    np.testing.assert_array_equal(err.trajectory.L, [L1])
    monkeypatch.undo()
    same_trajectory(liebody.integrate(scene, L0=L0, t0=1.0, **kw), first)


def test_a_repeated_exact_call_compiles_nothing_the_first_did_not():
    """The exact flow's kernel is given the first samples (contiguous, writeable copies),
    not the caller's L0: a read-only or strided L0 of a repeated call is no new argument
    type (before: numba compiled the kernel again for each, a fraction of a second)."""
    from liebody._kernels.exact import exact_flow_times

    scene = liebody.FreeBody(hlw_body())
    kw = dict(q0=Q0, dt=0.01, steps=3)
    first = liebody.integrate(scene, L0=L0.copy(), **kw)
    sigs = list(exact_flow_times.signatures)
    read_only = L0.copy()
    read_only.flags.writeable = False
    wide = np.zeros(6)
    wide[::2] = L0
    q_wide = np.zeros(8)
    q_wide[::2] = Q0
    for L in (read_only, wide[::2]):
        same_trajectory(liebody.integrate(scene, L0=L, **kw), first)
    same_trajectory(liebody.integrate(scene, L0=read_only, q0=q_wide[::2], dt=0.01, steps=3),
                    first)
    assert list(exact_flow_times.signatures) == sigs


def test_the_reach_of_a_plan_is_made_once(triple_jump):
    """Plan.reach (read by every long run, ensemble and Stepper) is kept on the plan; for
    Yoshida's (1990) triple jump g, 1 - 2g, g on a Strang splitting it is (1 - g, g)."""
    from liebody import _methods

    g = 1.0 / (2.0 - 2.0 ** (1.0 / 3.0))
    scene = liebody.FreeBody(hlw_body())
    plan = _methods.supported(triple_jump, scene).plan(scene, L0.copy(), 0.01)
    lo, hi = plan.reach
    assert math.isclose(lo, 1.0 - g, rel_tol=0.0, abs_tol=4e-16)
    assert math.isclose(hi, g, rel_tol=0.0, abs_tol=4e-16)
    assert plan.reach is plan.reach
    base = _methods.supported("splitting2", scene).plan(scene, L0.copy(), 0.01)
    assert base.reach == (0.0, 1.0)


def test_distributed_tasks_of_identical_bodies_and_a_composition_past_the_table(triple_jump):
    """Tasks of the same inputs (identical bodies) are one task on dask (pure keys): its
    result, shared by their futures, is read, not emptied (before: KeyError 'q' for the
    second, on an in-process cluster). A composition whose first stage reads the orbit
    before its table says so, as the local ensemble does."""
    distributed = pytest.importorskip("distributed")
    import liebody.distributed

    scene = table_gravity_gradient("axes")
    kw = dict(L0=[L0] * 4, dt=0.1, steps=5, method=triple_jump)
    local, local_w = _warned(lambda: liebody.integrate(scene, simd=False, **kw))
    words = r"Body 0: the time t = -0\.0351\d* is outside the times \[0, 10\]"
    with (distributed.Client(processes=False, n_workers=1, threads_per_worker=1,
                             dashboard_address=None, silence_logs=40) as client,
          pytest.warns(RuntimeWarning, match=words) as caught):
        got = liebody.distributed.integrate(scene, client=client, bodies_per_task=2, **kw)
    assert [str(w.message) for w in caught] == [w[1] for w in local_w]
    np.testing.assert_array_equal(got.status, local.status)
    np.testing.assert_array_equal(got.failed_at, local.failed_at)


@pytest.mark.parametrize("simd", [False, True])
def test_an_ensemble_names_the_time_outside_the_table_once(triple_jump, simd):
    """The ensemble's warning names the time its composition read outside the Table
    once (before: '... is outside the times [0, 10] ... at t = -0.0351207' again)."""

    scene = table_gravity_gradient("axes")
    with pytest.warns(RuntimeWarning, match=r"Body 0: the time t = -0\.0351207\d* is "
                                            r"outside the times \[0, 10\]") as caught:
        liebody.integrate(scene, L0=[L0] * 3, dt=0.1, steps=5, method=triple_jump,
                          simd=simd, threads=1)
    words = str(caught[0].message)
    assert words.count("t = -0.0351") == 1
    assert words.endswith("(extend the tables or shorten the run)")


@pytest.mark.parametrize("save_every", [None, 1, 2])
def test_the_exact_flows_kept_call_from_alternating_clocks_equals_first_calls(save_every):
    """The exact flow's kept call (a free body's default method) from alternating clock
    origins: every call equals a first call on a fresh scene, its times included."""
    scene = liebody.FreeBody(hlw_body())
    for t0 in [2.5, -1.25, 2.5, -0.0, 0.0, np.float64(-1.25), 1e6, 2.5]:
        kw = dict(q0=Q0, L0=L0, dt=0.01, steps=3, t0=t0, save_every=save_every)
        got = liebody.integrate(scene, **kw)
        same_trajectory(got, liebody.integrate(liebody.FreeBody(hlw_body()), **kw),
                        scene=False)
        kept = {None: [0, 3], 1: [0, 1, 2, 3], 2: [0, 2, 3]}[save_every]
        np.testing.assert_array_equal(got.t, float(t0) + 0.01 * np.array(kept, dtype=float))
    assert len(vars(scene)["_memo_short_calls"]) == 1
