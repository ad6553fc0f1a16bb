"""Memory: what an ensemble allocates beyond its samples is bounded per body and counted by
the check before the run, and the check respects a limit on the address space."""

from __future__ import annotations

import subprocess
import sys
import tracemalloc

import numpy as np
import pytest

import liebody
from liebody import _integrate


def _beyond_samples(scene, method: str, n: int) -> float:
    """Peak bytes per body an ensemble run allocates beyond the samples it returns."""
    L0 = np.random.default_rng(0).normal(size=(n, 3))
    liebody.integrate(scene, L0=L0[:8], dt=0.01, steps=3, method=method, save_every=None)
    tracemalloc.start()
    try:
        tr = liebody.integrate(scene, L0=L0, dt=0.01, steps=3, method=method,
                               save_every=None, diagnostics=True)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    return (peak - tr.q.nbytes - tr.L.nbytes - tr.t.nbytes) / n


@pytest.mark.parametrize("method", ["splitting2", "splitting8", "rattle", "dmv8"])
def test_an_ensemble_of_one_scene_allocates_a_bounded_amount_per_body(method):
    """Shared stage parameters are stored once (splitting8 kept 6 kB per body: 8.5 kB in
    all beyond the samples), and the ordering choice works through the bodies in chunks."""
    scene = liebody.FreeBody(liebody.RigidBody([1.0, 2.0, 3.0]))
    assert _beyond_samples(scene, method, 40_000) <= _integrate.RUN_BYTES_PER_BODY


def test_shared_parameters_are_stored_once_and_per_body_ones_per_body():
    m0 = np.random.default_rng(1).normal(size=(50, 3))
    shared = liebody.methods()["splitting8"].plans(
        liebody.FreeBody(liebody.RigidBody([1.0, 2.0, 3.0])), m0, 0.01)
    assert all(plan.params.shape[0] == 1 for _, plan in shared)
    moments = np.tile([1.0, 2.0, 3.0], (50, 1)) * np.linspace(1.0, 2.0, 50)[:, None]
    per_body = liebody.methods()["splitting8"].plans(
        liebody.FreeBody(liebody.RigidBody.batch(moments)), m0, 0.01)
    assert all(plan.params.shape[0] == len(idx) for idx, plan in per_body)


def test_the_check_counts_what_the_run_allocates_beyond_the_samples(monkeypatch):
    """Samples of 22 MB fit in 100 MB, but 200,000 bodies' other arrays do not: refused
    before the run (it passed the check and died inside the set-up before)."""
    monkeypatch.setattr(_integrate, "_available_memory", lambda: 100_000_000)
    scene = liebody.FreeBody(liebody.RigidBody([1.0, 2.0, 3.0]))
    L0 = np.ones((200_000, 3))
    with pytest.raises(ValueError, match=r"200,000 bodies need 1,024 B each beyond their "
                                         r"samples .* more than the 0\.1 GB"):
        liebody.integrate(scene, L0=L0, dt=0.01, steps=3, method="splitting2",
                          save_every=None)
    # per-body stage parameters are counted too: 96 B a stage for per-body inertia
    moments = np.tile([1.0, 2.0, 3.0], (60_000, 1)) * np.linspace(1, 2, 60_000)[:, None]
    batch = liebody.FreeBody(liebody.RigidBody.batch(moments))
    with pytest.raises(ValueError, match=r"60,000 bodies need [0-9,]+ B each"):
        liebody.integrate(batch, L0=L0[:60_000], dt=0.01, steps=3, method="splitting8",
                          save_every=None)
    liebody.integrate(scene, L0=L0[:20_000], dt=0.01, steps=3, method="splitting8",
                      save_every=None)  # shared: fits


def test_the_available_memory_respects_an_address_space_limit():
    code = (
        "import os, resource\n"
        "from liebody import _integrate\n"
        "with open('/proc/self/statm') as fh:\n"
        "    used = int(fh.read().split()[0]) * os.sysconf('SC_PAGE_SIZE')\n"
        "resource.setrlimit(resource.RLIMIT_AS, (used + 300_000_000, resource.RLIM_INFINITY))\n"
        "print(_integrate._available_memory())\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert 0 < int(out) <= 300_000_000
