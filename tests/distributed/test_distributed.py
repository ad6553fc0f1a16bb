"""liebody.distributed on a LocalCluster of two worker processes.

The reference is the local batched call: the cluster's result must be the same, bit
for bit, whatever the chunks and whichever worker ran them, even when a worker dies
in the middle of the run.
"""

from __future__ import annotations

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
    call of the whole ensemble runs, so the result is the same bit for bit; tasks whose
    plans differ (other axis orderings) keep their own info."""
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
        assert "tasks" in remote.info or remote.info == local.info
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
