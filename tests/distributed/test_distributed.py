"""liebody.distributed on a LocalCluster of two worker processes.

The reference is the local batched call: the cluster's result must be the same, bit
for bit, whatever the chunks and whichever worker ran them, even when a worker dies
in the middle of the run.
"""

from __future__ import annotations

import contextlib
import os
import signal
import threading
import time

import numpy as np
import pytest

import liebody

distributed = pytest.importorskip("dask.distributed")


@pytest.fixture(scope="module")
def client():
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                       dashboard_address=None, silence_logs=40)
    c = distributed.Client(cluster)
    yield c
    c.close()
    cluster.close()


def _ensemble(n: int = 300):
    rng = np.random.default_rng(7)
    bodies = liebody.RigidBody.batch(rng.uniform(1.0, 3.0, size=(n, 3)), check_triangle=False)
    return liebody.FreeBody(bodies), liebody.quaternion.random(n, rng=8), rng.normal(size=(n, 3))


def test_the_cluster_gives_the_local_result(client):
    scene, q0, L0 = _ensemble()
    kw = {"q0": q0, "L0": L0, "dt": 0.01, "steps": 2000, "method": "splitting4",
          "save_every": 500, "diagnostics": True}
    local = liebody.integrate(scene, **kw)
    remote = liebody.distributed.integrate(scene, client=client, bodies_per_task=37, **kw)
    np.testing.assert_array_equal(remote.q, local.q)
    np.testing.assert_array_equal(remote.L, local.L)
    np.testing.assert_array_equal(remote.t, local.t)
    for k, v in local.diagnostics.items():
        np.testing.assert_array_equal(remote.diagnostics[k], v)
    assert remote.n_bodies == 300 and list(remote.status) == list(local.status)


def test_a_batched_heavy_top_and_dask_arrays(client):
    n = 64
    rng = np.random.default_rng(9)
    tops = liebody.HeavyTop(liebody.RigidBody([5.0, 5.0, 1.0]), mass=rng.uniform(1, 2, n),
                            cm=[0.0, 0.0, 1.0], g=9.81)
    kw = {"q0": liebody.quaternion.exp([0.3, 0, 0]),
          "omega0": np.column_stack([np.zeros((n, 2)), rng.uniform(20, 40, n)]),
          "dt": 1e-3, "steps": 500, "save_every": 100}
    local = liebody.integrate(tops, **kw)
    lazy = liebody.distributed.integrate(tops, client=client, bodies_per_task=10, gather=False,
                                         **kw)
    assert lazy.q.shape == local.q.shape and lazy.q.chunks[0][0] == 10
    np.testing.assert_array_equal(lazy.q[5:20].compute(), local.q[5:20])
    np.testing.assert_array_equal(lazy.to_trajectory().L, local.L)


def test_a_worker_lost_mid_run_loses_nothing(client):
    """Kill a worker process while its tasks run: the scheduler recomputes them on the
    other worker (and the restarted one), and the result is still the local one."""
    scene, q0, L0 = _ensemble(240)
    kw = {"q0": q0, "L0": L0, "dt": 0.01, "steps": 300_000, "method": "splitting2",
          "save_every": None}
    local = liebody.integrate(scene, **kw)  # a few seconds on the cluster
    victim = sorted(client.scheduler_info()["workers"])[0]
    killed = {}

    pid = next(n.process.process.pid for n in client.cluster.workers.values()
               if n.worker_address == victim)

    def kill():  # SIGKILL: the worker's process dies at once, as on a lost node
        time.sleep(1.0)
        killed["at"] = time.perf_counter()
        os.kill(pid, signal.SIGKILL)

    killer = threading.Thread(target=kill)
    killer.start()
    remote = liebody.distributed.integrate(scene, client=client, bodies_per_task=15, **kw)
    done = time.perf_counter()
    killer.join()
    assert killed["at"] < done  # the worker died before the run ended
    assert victim not in client.scheduler_info()["workers"]
    np.testing.assert_array_equal(remote.q, local.q)
    np.testing.assert_array_equal(remote.L, local.L)


def test_one_body_is_refused(client):
    with pytest.raises(ValueError, match="splits an ensemble over a cluster"):
        liebody.distributed.integrate(liebody.FreeBody(liebody.RigidBody([1.0, 2.0, 2.5])),
                                      L0=[1.0, 0.0, 0.0], dt=0.1, steps=10, client=client)


def test_small_tasks_run_the_kernels_of_the_local_call(client):
    """Tasks of 1 or 2 bodies (below SIMD_MIN_BODIES) still run the SIMD kernels the local
    call of the whole ensemble runs, so the result is the same bit for bit, and the
    info is the local call's."""
    scene, q0, L0 = _ensemble(7)
    kw = {"q0": q0, "L0": L0, "dt": 0.01, "steps": 300, "method": "splitting2",
          "save_every": 100}
    local = liebody.integrate(scene, **kw)
    groups = local.info.get("groups", [local.info])
    assert all(g["simd"] for g in groups)
    for per_task in (1, 2):
        remote = liebody.distributed.integrate(scene, client=client, bodies_per_task=per_task,
                                               **kw)
        np.testing.assert_array_equal(remote.q, local.q)
        np.testing.assert_array_equal(remote.L, local.L)
        assert _same(remote.info, local.info)  # (before: {"tasks": [...]} of their own)
    off = liebody.distributed.integrate(scene, client=client, bodies_per_task=2, simd=False,
                                        **kw)
    np.testing.assert_array_equal(off.q, liebody.integrate(scene, simd=False, **kw).q)


def test_the_same_call_twice_in_a_row(client):
    """A repeated call (same scene, same states) gives the same result; it once failed
    with 'lost dependencies' because both calls shared the scattered scene's key."""
    _, q0, L0 = _ensemble(40)
    scene = liebody.FreeBody(liebody.RigidBody([1.0, 2.0, 3.0]))  # one body, scattered
    kw = {"q0": q0, "L0": L0, "dt": 0.01, "steps": 200, "method": "splitting2",
          "save_every": None}
    results = [liebody.distributed.integrate(scene, client=client, **kw) for _ in range(3)]
    for r in results[1:]:
        np.testing.assert_array_equal(r.q, results[0].q)


def _commanded(t, q, L, u):
    return u[:3] * np.cos(t)


def test_failures_controls_t0_and_dask_arrays_as_the_local_call(client):
    """The failure warning counts the whole ensemble with the local call's body numbers
    (before: a task's own counts, 'body 1' for body 5); controls (one row per body) and
    t0 are passed on; gather=False keeps info, status and diagnostics."""
    from numba import njit

    n = 8
    scene = liebody.FreeBody(liebody.RigidBody([1.0, 2.0, 2.5]))
    L0 = np.tile([0.3, 1.0, 0.2], (n, 1))
    L0[5], L0[6] = [0.0, 500.0, 3.0], [0.0, 400.0, 3.0]  # rattle has no root there
    kw = {"L0": L0, "dt": 0.1, "steps": 20, "method": "rattle", "simd": False,
          "diagnostics": True}
    with pytest.warns(RuntimeWarning) as local_w:
        local = liebody.integrate(scene, **kw)
    with pytest.warns(RuntimeWarning) as remote_w:
        remote = liebody.distributed.integrate(scene, client=client, bodies_per_task=4, **kw)
    words = [str(w.message) for w in local_w if "bodies failed" in str(w.message)]
    assert [str(w.message) for w in remote_w if "bodies failed" in str(w.message)] == words
    assert "2 of 8 bodies failed" in words[0] and "body 5" in words[0]
    np.testing.assert_array_equal(remote.failed_at, local.failed_at)
    lazy = liebody.distributed.integrate(scene, client=client, bodies_per_task=4,
                                         gather=False, **kw).to_trajectory()
    assert list(lazy.status) == list(local.status) and lazy.info.keys() == local.info.keys()
    for k, v in local.diagnostics.items():
        np.testing.assert_array_equal(lazy.diagnostics[k], v)

    steered = liebody.ControlledBody(liebody.RigidBody([1.0, 2.0, 2.5]), njit(_commanded),
                                     controls=3)
    u = np.random.default_rng(3).normal(scale=0.1, size=(n, 3))
    kw = {"L0": [0.3, 1.0, 0.2], "q0": liebody.quaternion.random(n, rng=4), "dt": 0.01,
          "steps": 300, "method": "splitting2", "controls": u, "t0": 2.5, "save_every": 50}
    local = liebody.integrate(steered, **kw)
    remote = liebody.distributed.integrate(steered, client=client, bodies_per_task=3, **kw)
    np.testing.assert_array_equal(remote.q, local.q)
    np.testing.assert_array_equal(remote.t, local.t)


# ----------------------------------------------------------------------------------------
# one result as the local call, on an in-process cluster (no worker process to start)
# ----------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def inproc():
    c = distributed.Client(processes=False, n_workers=1, threads_per_worker=2,
                           dashboard_address=None, silence_logs=40)
    yield c
    c.close()


def _same(a, b) -> bool:
    """Deep equality of ``info`` dicts, which may hold arrays (NaN equal to NaN)."""
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, list | tuple) and isinstance(b, list | tuple):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return (isinstance(a, np.ndarray) and isinstance(b, np.ndarray)
                and a.shape == b.shape and np.array_equal(a, b, equal_nan=a.dtype.kind == "f"))
    return type(a) is type(b) and a == b


def _assert_local(remote, local, remote_w=(), local_w=()):
    """``remote`` is ``local``: samples, per-body records, info, diagnostics, warnings."""
    np.testing.assert_array_equal(remote.t, local.t)
    np.testing.assert_array_equal(remote.q, local.q)
    np.testing.assert_array_equal(remote.L, local.L)
    assert list(remote.status) == list(local.status)
    np.testing.assert_array_equal(remote.failed_at, local.failed_at)
    assert _same(remote.info, local.info), (remote.info, local.info)
    assert (remote.diagnostics is None) == (local.diagnostics is None)
    for k, v in (local.diagnostics or {}).items():
        np.testing.assert_array_equal(remote.diagnostics[k], v)
    assert ([(w.category, str(w.message)) for w in remote_w]
            == [(w.category, str(w.message)) for w in local_w])


def _flagged(t, q, L, p):
    """A torque that is NaN for the bodies whose p[0] is set (from the initial state on)."""
    out = np.empty(3)
    if p[0] > 0.0:
        out[:] = np.nan
    else:
        out[0], out[1], out[2] = 0.1 * q[1], 0.1 * q[2], -0.1 * q[3]
    return out


def _nan_above(t, q, L):
    """NaN where L[0] > 100 (a body's own state), else a small orientation torque."""
    out = np.empty(3)
    if L[0] > 100.0:
        out[:] = np.nan
    else:
        out[0], out[1], out[2] = 0.1 * q[1], 0.1 * q[2], -0.1 * q[3]
    return out


def _bad_body_scenes(bad: int, n: int = 8):
    """A torqued ensemble whose body ``bad`` has a NaN torque at its initial state: by a
    per-body parameter (a batched scene, split by take) and by its state (one scene,
    scattered)."""
    from numba import njit

    rng = np.random.default_rng(11)
    q0 = liebody.quaternion.random(n, rng=12)
    L0 = rng.normal(size=(n, 3))
    flags = np.zeros((n, 1))
    flags[bad] = 1.0
    body = liebody.RigidBody([1.0, 2.0, 2.5])
    by_params = liebody.TorqueBody(body, njit(_flagged), params=flags, orientation_only=True)
    L1 = L0.copy()
    L1[bad, 0] = 500.0
    by_state = liebody.TorqueBody(body, njit(_nan_above), orientation_only=True)
    return [(by_params, q0, L0), (by_state, q0, L1)]


@pytest.mark.parametrize("case", [0, 1], ids=["per-body parameter", "state"])
def test_a_torque_failing_at_a_tasks_first_body_fails_that_body_only(inproc, case):
    """Body 4 starts the second task (bodies_per_task=4) and its torque is NaN at
    the initial state. Before, the task refused its first body and the whole run raised
    TorqueError; now that body fails alone, as in the local call."""
    scene, q0, L0 = _bad_body_scenes(4)[case]
    kw = {"q0": q0, "L0": L0, "dt": 0.01, "steps": 200, "method": "splitting2",
          "save_every": 50, "diagnostics": True}
    with pytest.warns(RuntimeWarning) as local_w:
        local = liebody.integrate(scene, **kw)
    assert local.status[4] == "failed: torque failed" and list(local.status).count("complete") == 7
    with pytest.warns(RuntimeWarning) as remote_w:
        remote = liebody.distributed.integrate(scene, client=inproc, bodies_per_task=4, **kw)
    _assert_local(remote, local, remote_w, local_w)


def test_a_torque_failing_at_body_0_as_the_local_call(inproc):
    """Body 0 is no exception: a body whose torque fails at the initial state fails alone
    (one rule for every body), in the tasks as in the local call."""
    scene, q0, L0 = _bad_body_scenes(0)[0]
    kw = {"q0": q0, "L0": L0, "dt": 0.01, "steps": 200, "method": "splitting2",
          "save_every": 50}
    with warnings_recorded() as local_w:
        local = liebody.integrate(scene, **kw)
    with warnings_recorded() as remote_w:
        remote = liebody.distributed.integrate(scene, client=inproc, bodies_per_task=4, **kw)
    _assert_local(remote, local, remote_w, local_w)


def warnings_recorded():
    import warnings

    return warnings.catch_warnings(record=True)


def test_failed_bodies_come_from_the_records_not_the_words(inproc, monkeypatch):
    """The tasks' own summaries of their failed bodies are known from their
    records (status, failed_at), whatever their words. Before, they were recognised by
    the text ' bodies failed: ' and, worded otherwise, were passed on as extra warnings
    (one per task, with the task's own body numbers)."""
    import liebody._engine as ens

    words = ens.failure_message

    def reworded(method, status, failed_at):
        text = words(method, status, failed_at)
        return None if text is None else text.replace(" bodies failed: ", " bodies stopped: ")

    monkeypatch.setattr(ens, "failure_message", reworded)
    scene, q0, L0 = _bad_body_scenes(5)[1]
    L0[2, 0] = 500.0  # a second failing body, in the first task
    kw = {"q0": q0, "L0": L0, "dt": 0.01, "steps": 100, "method": "splitting2",
          "save_every": None}
    with pytest.warns(RuntimeWarning) as local_w:
        local = liebody.integrate(scene, **kw)
    with pytest.warns(RuntimeWarning) as remote_w:
        remote = liebody.distributed.integrate(scene, client=inproc, bodies_per_task=3, **kw)
    assert "2 of 8 bodies stopped" in str(local_w[0].message)
    _assert_local(remote, local, remote_w, local_w)


def _no_tasks(client, monkeypatch):
    """Make any submission to ``client`` fail the test."""
    def refuse(*args, **kwargs):
        raise AssertionError("a task or data reached the cluster before the input was "
                             "validated")

    for name in ("submit", "scatter", "map", "compute"):
        monkeypatch.setattr(client, name, refuse)


@pytest.mark.parametrize(("change", "words"), [
    ({"dt": -0.1}, "dt must be > 0"),
    ({"dt": float("nan")}, "dt must be finite"),
    ({"steps": 0}, "steps must be a positive integer"),
    ({"steps": None, "t_end": 1.005}, "t_end must be a whole number of steps"),
    ({"save_every": 0}, "save_every must be a positive integer"),
    ({"L0": np.full((5, 3), np.nan)}, "L0 must be finite"),
    ({"bodies_per_task": 0}, "bodies_per_task must be a positive integer"),
    ({"threads_per_task": 1.5}, "threads_per_task must be a positive integer"),
])
def test_bad_input_is_refused_on_the_client_before_any_task(inproc, monkeypatch, change, words):
    """Before, dt, steps, save_every were validated by the tasks on the
    workers (tracebacks in their logs), after the scene was scattered."""
    _no_tasks(inproc, monkeypatch)
    scene, _, L0 = _ensemble(5)
    kw = {"L0": L0, "dt": 0.01, "steps": 10, "method": "splitting2", **change}
    with pytest.raises(ValueError, match=words):
        liebody.distributed.integrate(scene, client=inproc, **kw)


def test_samples_that_do_not_fit_are_refused_before_any_task(inproc, monkeypatch):
    """The gathered size is checked on the client (the local call's check and
    words: the size, and a save_every that fits) before any task runs; before, tasks of
    a few bodies each passed their own checks and the client ran out of memory
    gathering them."""
    import liebody._integrate as integ

    monkeypatch.setattr(integ, "_available_memory", lambda: 200_000_000)
    scene, _, L0 = _ensemble(100)
    kw = {"L0": L0, "dt": 0.01, "steps": 100_000, "method": "splitting2", "save_every": 1}
    with pytest.raises(ValueError, match="save_every") as local:
        liebody.integrate(scene, **kw)
    _no_tasks(inproc, monkeypatch)
    words = r"samples of 100 bodies of 5608 B \(0\.561 GB\)"
    with pytest.raises(ValueError, match=words) as remote:
        liebody.distributed.integrate(scene, client=inproc, bodies_per_task=1, **kw)
    assert str(remote.value) == str(local.value)


@contextlib.contextmanager
def _small_cluster():
    """A client of one in-process worker with a 50 MB memory limit."""
    cluster = distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                                       memory_limit="50MB", dashboard_address=None,
                                       silence_logs=40)
    with cluster, distributed.Client(cluster) as client:
        yield client


def test_tasks_larger_than_a_workers_memory_limit_are_refused():
    with _small_cluster() as small:
        scene, _, L0 = _ensemble(64)
        with pytest.raises(ValueError, match=r"bodies_per_task = 64: a task keeps 200,001 "
                                             r"samples of 64 bodies \(0\.718 GB\)"):
            liebody.distributed.integrate(scene, client=small, L0=L0, dt=0.01,
                                          steps=200_000, method="splitting2", gather=False)


def test_a_client_must_be_a_running_client(inproc):
    """An address string or a closed client was an AttributeError from deep
    inside; now a TypeError/ValueError naming client and what it must be."""
    scene, _, L0 = _ensemble(5)
    kw = {"L0": L0, "dt": 0.01, "steps": 10}
    with pytest.raises(TypeError, match=r"client must be a dask\.distributed\.Client, not the "
                                        r"address 'tcp://127\.0\.0\.1:8786'"):
        liebody.distributed.integrate(scene, client="tcp://127.0.0.1:8786", **kw)
    with pytest.raises(TypeError, match=r"client must be a dask\.distributed\.Client"):
        liebody.distributed.integrate(scene, client=object(), **kw)
    closed = distributed.Client(processes=False, n_workers=1, threads_per_worker=1,
                                dashboard_address=None, silence_logs=40,
                                set_as_default=False)
    closed.close()
    with pytest.raises(ValueError, match=r"client must be a running Client.*'closed'"):
        liebody.distributed.integrate(scene, client=closed, **kw)


def test_info_is_the_local_calls_with_global_body_numbers(inproc):
    """Bodies of other axis orderings form groups; info lists them with their
    numbers in the whole ensemble, as the local call does (before: one info per task,
    {"tasks": [...]}, with each task's own numbers), gathered or not."""
    scene, q0, L0 = _ensemble(40)
    kw = {"q0": q0, "L0": L0, "dt": 0.01, "steps": 50, "method": "splitting4",
          "save_every": 10, "diagnostics": True}
    local = liebody.integrate(scene, **kw)
    assert len(local.info["groups"]) > 1 and local.info["groups"][0]["simd"] is True
    remote = liebody.distributed.integrate(scene, client=inproc, bodies_per_task=7, **kw)
    _assert_local(remote, local)
    lazy = liebody.distributed.integrate(scene, client=inproc, bodies_per_task=7,
                                         gather=False, **kw).to_trajectory()
    _assert_local(lazy, local)
    one = liebody.distributed.integrate(scene, client=inproc, bodies_per_task=1, simd=False,
                                        **kw)
    _assert_local(one, liebody.integrate(scene, simd=False, **kw))


# ----------------------------------------------------------------------------------------
# the local call's checks of the scene's own functions, on the client
# ----------------------------------------------------------------------------------------


def _depends_on_L(t, q, L):
    """Promised orientation-only, but reads L: the explicit kicks would be wrong."""
    return -0.3 * L


def _depends_on_large_L(t, q, L):
    """Reads L only where |L| > 10: not at the scene's own probe state (|L| < 4 there), at
    the initial state of the run below (|L0| above 20)."""
    return -0.3 * L if L @ L > 100.0 else np.zeros(3)


def _small_tilt(t, q, L):
    return np.array([0.1 * q[1], 0.1 * q[2], -0.1 * q[3]])


def _nan_potential(q):
    return float("nan")


def _check_cases():
    """name -> (scene, the call's arguments): each refused by the local call before its
    run (the torque's false promise, the potential at the initial state, a clock that
    cannot advance)."""
    from numba import njit

    body = liebody.RigidBody([1.0, 2.0, 2.5])
    L0 = np.random.default_rng(5).normal(size=(6, 3))
    kw = {"L0": L0, "dt": 0.01, "steps": 10, "method": "splitting2"}
    return {
        "orientation_only promise": (
            liebody.TorqueBody(body, njit(_depends_on_L), orientation_only=True), kw),
        "orientation_only promise at the initial state": (
            liebody.TorqueBody(body, njit(_depends_on_large_L), orientation_only=True),
            {**kw, "L0": 20.0 * L0}),
        "potential": (liebody.TorqueBody(body, njit(_small_tilt), potential=_nan_potential,
                                         orientation_only=True), kw),
        "t0 + dt == t0": (liebody.FreeBody(body), {**kw, "t0": 1e17}),
    }


@pytest.mark.parametrize("case", ["orientation_only promise",
                                  "orientation_only promise at the initial state",
                                  "potential", "t0 + dt == t0"])
def test_the_local_calls_checks_of_the_scene_are_made_on_the_client(inproc, monkeypatch,
                                                                    case):
    """A torque that reads L though the scene promises orientation_only, a potential that
    is not finite at the initial orientation and t0 = 1e17 with dt = 0.01 (t0 + dt == t0)
    are refused by the local call, with these words; the cluster refused none of them
    (before): it ran the false promise's explicit kicks (a first-order method, without a
    word), the NaN potential, and a clock that never advanced."""
    scene, kw = _check_cases()[case]
    with pytest.raises(ValueError) as local:
        liebody.integrate(scene, **kw)
    _no_tasks(inproc, monkeypatch)
    with pytest.raises(ValueError) as remote:
        liebody.distributed.integrate(scene, client=inproc, **kw)
    assert str(remote.value) == str(local.value)


def test_the_exact_flows_lost_phase_is_reported_as_by_the_local_call(inproc):
    """The exact flow asked for a phase |omega| t beyond float64's resolution: the local
    call warns (RuntimeWarning); the cluster's result came without it (before)."""
    scene = liebody.FreeBody(liebody.RigidBody([1.0, 2.0, 2.5]))
    kw = {"L0": np.random.default_rng(5).normal(size=(4, 3)) * 1e10, "dt": 1e6,
          "steps": 10, "method": "exact"}
    with pytest.warns(RuntimeWarning, match="float64 rounds an angle") as local_w:
        local = liebody.integrate(scene, **kw)
    with pytest.warns(RuntimeWarning, match="float64 rounds an angle") as remote_w:
        remote = liebody.distributed.integrate(scene, client=inproc, bodies_per_task=3, **kw)
    assert ([str(w.message) for w in remote_w if "rounds an angle" in str(w.message)]
            == [str(w.message) for w in local_w if "rounds an angle" in str(w.message)])
    np.testing.assert_array_equal(remote.q, local.q)


def test_reaction_wheels_are_refused_before_any_task(inproc, monkeypatch):
    """The local call of a ReactionWheels ensemble cuts each body's run where its wheels
    saturate and returns the wheels' momenta; the tasks ran it as a rigid body (before):
    q 0.1 away from the local call's after 10 s, and no wheel momenta. Refused now, by
    name."""
    craft = liebody.ReactionWheels(liebody.RigidBody([10.0, 12.0, 8.0]), np.eye(3), 0.01,
                                   momentum=[0.1, -0.2, 0.3], max_torque=0.05,
                                   max_speed=600.0)
    kw = {"omega0": np.random.default_rng(1).normal(scale=0.1, size=(4, 3)), "dt": 0.1,
          "steps": 100, "save_every": 50}
    assert liebody.integrate(craft, **kw).wheels.shape == (4, 3, 3)
    _no_tasks(inproc, monkeypatch)
    with pytest.raises(ValueError, match=r"does not run ReactionWheels scenes.*use "
                                         r"liebody\.integrate"):
        liebody.distributed.integrate(craft, client=inproc, **kw)


def _tilt_p(t, q, L, p):
    return np.array([p[0] * q[1], p[1] * q[2], -0.1 * q[3]])


def test_a_scene_batch_of_one_shared_by_the_states_bodies(inproc):
    """A scene with a body axis of length one (``RigidBody.batch`` of one body, params of
    one row) and five bodies given by the states: the local call broadcasts the scene's
    row over them. The tasks split the scene with the bodies (``scene.take``), which gave
    tasks after the first an empty scene, and the run raised a shape mismatch from a
    worker (before); now it is the local result."""
    from numba import njit

    one = liebody.RigidBody.batch([[1.0, 2.0, 2.5]])
    scenes = [liebody.FreeBody(one),
              liebody.TorqueBody(liebody.RigidBody([1.0, 2.0, 2.5]), njit(_tilt_p),
                                 params=[[0.1, -0.2]], orientation_only=True)]
    kw = {"q0": liebody.quaternion.random(5, rng=1),
          "L0": np.random.default_rng(2).normal(size=(5, 3)), "dt": 0.01, "steps": 20,
          "method": "splitting2", "save_every": 10, "diagnostics": True}
    for scene in scenes:
        assert scene.batch_shape == (1,)
        local = liebody.integrate(scene, **kw)
        remote = liebody.distributed.integrate(scene, client=inproc, bodies_per_task=2, **kw)
        _assert_local(remote, local)


def test_the_bodies_per_task_advised_are_those_that_fit_in_half_a_workers_limit():
    """The refusal advises the largest bodies_per_task whose samples fit in half a
    worker's memory limit: with 20,001 samples of 56 B a body (q, L) and 8 B of time, 22
    bodies fit in 25 MB and 23 do not. It advised 11: each body counted twice."""
    import re

    with _small_cluster() as small:
        scene, _, L0 = _ensemble(64)
        with pytest.raises(ValueError, match=r"bodies_per_task = 64: .*give bodies_per_task "
                                             r"= (\d+) or less") as info:
            liebody.distributed.integrate(scene, client=small, L0=L0, dt=0.01,
                                          steps=20_000, method="splitting2", gather=False)
    fit = int(re.search(r"give bodies_per_task = (\d+)", str(info.value)).group(1))
    k, half = 20_001, 50_000_000 // 2
    assert k * (8 + 56 * fit) <= half < k * (8 + 56 * (fit + 1))


def test_coupled_bodies_are_refused_as_one_system(inproc, monkeypatch):
    """A DipoleLattice is one system (each kick reads every body): refused by name before
    any task. It was told it was not a liebody scene, naming FreeBody, HeavyTop and the
    like, as if it were a wrong argument."""
    from liebody.coupled import DipoleLattice

    bodies = liebody.RigidBody.batch(np.tile([1.0, 2.0, 3.0], (3, 1)))
    lattice = DipoleLattice(bodies, [[0, 0, 0], [0, 1, 0], [1, 0, 0]], [0, 0, 1])
    _no_tasks(inproc, monkeypatch)
    with pytest.raises(TypeError, match=r"DipoleLattice is one system of coupled bodies.*"
                                        r"liebody\.integrate"):
        liebody.distributed.integrate(lattice, L0=np.zeros((3, 3)), dt=0.01, steps=10,
                                      client=inproc)
