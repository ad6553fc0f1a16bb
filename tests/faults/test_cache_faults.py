"""A damaged numba disk cache: liebody recompiles with a warning instead of failing.

Before: a truncated or overwritten cache file (``*.nbi`` index, ``*.nbc`` data: a full
disk, a killed process on a file system without atomic rename, a copied cache) made
every call in every new process fail with ``UnpicklingError``, ``EOFError``,
``OverflowError`` or ``RuntimeError: LLVM bitcode parsing error``, naming neither the
cache nor the fix. Now a cache entry that cannot be loaded is a cache miss: the kernel is
compiled, the bad entry is replaced, and one :class:`liebody.CacheWarning` names the
file, its folder and how to clear the cache. Each case runs in fresh processes sharing a
cache folder of its own.
"""

from __future__ import annotations

import json
import os
import pickle
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import liebody
from liebody import quaternion as Q

_CHILD = r"""
import json, sys, warnings
if len(sys.argv) > 1 and sys.argv[1] == "readonly":
    from numba.core.caching import IndexDataCacheFile

    def refuse(self, path):
        raise PermissionError(13, "Permission denied", path)

    IndexDataCacheFile._open_for_write = refuse  # a cache folder that cannot be written
with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always")
    import liebody
    q = liebody.quaternion.multiply([0.6, 0.8, 0, 0], [0, 0, 0.6, 0.8])
    q2 = liebody.quaternion.multiply([[0.6, 0.8, 0, 0]], [[0, 0, 0.6, 0.8]])
print(json.dumps({
    "q": q.tolist(), "q2": q2.tolist(),
    "warnings": [[w.category.__name__, issubclass(w.category, liebody.CacheWarning),
                  str(w.message)] for w in caught],
}))
"""


def _env(cache: Path) -> dict:
    env = {k: v for k, v in os.environ.items()
           if k not in ("NUMBA_CACHE_DIR", "NUMBA_DISABLE_JIT", "NUMBA_CACHE_LOCATOR_CLASSES")}
    src = str(Path(liebody.__file__).resolve().parents[1])
    env["PYTHONPATH"] = os.pathsep.join([src, env.get("PYTHONPATH", "")])
    env["NUMBA_CACHE_DIR"] = str(cache)
    return env


def _child(cache: Path, *args) -> dict:
    proc = subprocess.run([sys.executable, "-c", _CHILD, *args], capture_output=True,
                          text=True, env=_env(cache), timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


@pytest.fixture(scope="module")
def filled_cache(tmp_path_factory) -> Path:
    """A cache folder filled by one process (the quaternion product's kernels)."""
    cache = tmp_path_factory.mktemp("filled") / "numba"
    out = _child(cache)
    assert not out["warnings"], out["warnings"]
    assert list(cache.rglob("*.nbc")) and list(cache.rglob("*.nbi"))
    return cache


def _expected() -> tuple[list, list]:
    q = Q.multiply([0.6, 0.8, 0, 0], [0, 0, 0.6, 0.8])
    q2 = Q.multiply([[0.6, 0.8, 0, 0]], [[0, 0, 0.6, 0.8]])
    return q.tolist(), q2.tolist()


def _break_object_code(path: Path) -> None:
    """Keep the pickle readable but spoil the compiled code it holds (LLVM refuses it)."""
    from numba.core.serialize import dumps

    def spoil(x):
        if isinstance(x, bytes) and len(x) > 100:
            return bytes(b ^ 0x5A for b in x[:64]) + x[64:]
        if isinstance(x, tuple):
            return tuple(spoil(y) for y in x)
        if isinstance(x, list):
            return [spoil(y) for y in x]
        return x

    path.write_bytes(dumps(spoil(pickle.loads(path.read_bytes()))))


_DAMAGE = {
    "truncated data": ("*.nbc", lambda p: p.write_bytes(p.read_bytes()[:20])),
    "garbage data": ("*.nbc", lambda p: p.write_bytes(os.urandom(500))),
    "empty data": ("*.nbc", lambda p: p.write_bytes(b"")),
    "broken object code": ("*.nbc", _break_object_code),
    "truncated index": ("*.nbi", lambda p: p.write_bytes(p.read_bytes()[:20])),
    "garbage index": ("*.nbi", lambda p: p.write_bytes(b"\x80\x04garbage" + os.urandom(300))),
    "empty index": ("*.nbi", lambda p: p.write_bytes(b"")),
}


@pytest.mark.parametrize("damage", list(_DAMAGE))
def test_a_damaged_cache_file_is_recompiled_with_a_warning_and_replaced(filled_cache,
                                                                       tmp_path, damage):
    cache = tmp_path / "numba"
    shutil.copytree(filled_cache, cache)
    pattern, spoil = _DAMAGE[damage]
    damaged = sorted(cache.rglob(pattern))
    for path in damaged:
        spoil(path)
    out = _child(cache)
    assert [out["q"], out["q2"]] == list(_expected())
    ours = [w for w in out["warnings"] if w[1]]
    assert len(ours) == 1, out["warnings"]  # once per process, however many files
    assert not [w for w in out["warnings"] if not w[1]], out["warnings"]
    text = ours[0][2]
    assert any(p.name in text for p in damaged), text
    assert str(damaged[0].parent) in text
    assert "NUMBA_CACHE_DIR" in text and "delete" in text
    # the bad entries were replaced: the next process loads them without a word
    again = _child(cache)
    assert [again["q"], again["q2"]] == list(_expected())
    assert not again["warnings"], again["warnings"]


def test_a_damaged_cache_that_cannot_be_rewritten_still_runs(filled_cache, tmp_path):
    """A damaged entry in a folder where nothing can be written (a shared, read-only
    cache): the kernel compiles, the run goes on, and the warning says so."""
    cache = tmp_path / "numba"
    shutil.copytree(filled_cache, cache)
    for path in cache.rglob("*.nbi"):
        path.write_bytes(b"")
    out = _child(cache, "readonly")
    assert [out["q"], out["q2"]] == list(_expected())
    ours = [w for w in out["warnings"] if w[1]]
    assert ours and all(w[0] == "CacheWarning" for w in ours), out["warnings"]
    assert any("could not" in w[2] or "cannot" in w[2] for w in ours), ours


def test_a_status_no_driver_knows_names_the_cache_as_a_cause(monkeypatch):
    """Swapped cache data (another kernel's code under this one's key) shows as a status
    the driver does not return. Before: blamed on "a bug in its recipe" alone; now the
    message names the numba cache, its folder and how to clear it."""
    from liebody._kernels import driver

    scene = liebody.FreeBody(liebody.RigidBody([1.0, 2.0, 3.0]))
    plan = liebody.methods()["splitting2"].plan(scene, np.array([1.0, 0.2, 0.1]), 0.1)

    def swapped(*args):
        return 0, 0, 97  # no driver returns this status

    monkeypatch.setitem(driver.RUNNERS, plan.family, swapped)
    with pytest.raises(RuntimeError) as info:
        liebody.integrate(scene, L0=[1.0, 0.2, 0.1], dt=0.1, steps=3, method="splitting2")
    text = str(info.value)
    assert "cache" in text and "NUMBA_CACHE_DIR" in text and "delete" in text, text


@pytest.mark.parametrize("method", ["splitting2", "splitting4", "saba2", "rk4"])
def test_writing_to_a_trajectorys_info_leaves_the_cached_plan_alone(method):
    """Plans are cached and shared by the runs of one scene (and, for the splittings, by
    the states of one key): a trajectory's ``info`` and a Stepper's are their own copies,
    so a caller who writes to them changes no later run's ``info``."""
    scene = liebody.FreeBody(liebody.RigidBody([1.0, 2.0, 3.0]))
    first = liebody.integrate(scene, L0=[1.0, 0.2, 0.1], dt=0.01, steps=3, method=method)
    expected = dict(first.info)
    first.info["written"] = True
    liebody.Stepper(scene, L0=[1.0, 0.2, 0.1], dt=0.01, method=method).info["also"] = True
    for steps in (3, 300):  # the short path and the run object
        again = liebody.integrate(scene, L0=[1.0, 0.2, 0.1], dt=0.01, steps=steps,
                                  method=method, save_every=steps)
        assert again.info == expected
