"""Faults at the edges of the input: nothing silent, nothing lost.

* a read-only install (numba finds no folder to cache compiled kernels in) still runs;
* arguments that used to pass silently (``tol=nan``) or fail with an error that names
  nothing (numpy's broadcast message, ``AttributeError``, ``ZeroDivisionError``) give a
  ``ValueError``/``TypeError`` naming the argument and the rule it broke;
* ``log(q) == log(-q)`` at angle pi and the inverse of every non-zero quaternion, as
  documented;
* error messages print huge numbers in short form.
"""

from __future__ import annotations

import json
import math
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import liebody
from liebody import euler as E
from liebody import inertia
from liebody import quaternion as Q
from liebody._validate import as_float_array, as_positive_int

# ------------------------------------------------------------------ read-only install

_NO_CACHE_RUN = r"""
import json, sys, warnings
import numba.core.caching as caching

caching.CacheImpl._locator_classes = []  # numba finds no writable cache folder
with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always")
    import liebody
    body = liebody.RigidBody([1, 2, 3])
    tr = liebody.integrate(liebody.FreeBody(body), L0=[1, 0, 0.1], dt=0.1, steps=10,
                           method="splitting2")
    # other kernels, compiled later in the same process: no second warning
    tr2 = liebody.integrate(liebody.DampedBody(body, 0.1), L0=[1, 0, 0.1], dt=0.1, steps=10,
                            method="rk4")
    q = liebody.quaternion.multiply([0.6, 0.8, 0, 0], [0, 0, 0.6, 0.8])
    # the other kernel families: the exact flow, the SIMD ensembles (their fused
    # multiply-adds go through the jit policy too), DMV, the kicks of a heavy top
    ex = liebody.integrate(liebody.FreeBody(body), L0=[1, 0, 0.1], dt=0.1, steps=10)
    ens = liebody.integrate(liebody.FreeBody(body), L0=[[1, 0, 0.1]] * 8, dt=0.1, steps=10,
                            method="splitting2", simd=True)
    top = liebody.HeavyTop(liebody.RigidBody([5, 5, 1]), 1.0, [0, 0, 1.0], g=1.0)
    ens2 = liebody.integrate(top, L0=[[0.1, 0, 5.0]] * 8, dt=0.01, steps=10, method="rattle",
                             simd=True)
print(json.dumps({
    "q": tr.q.tolist(), "L": tr.L.tolist(), "L2": tr2.L.tolist(), "qq": q.tolist(),
    "ex": ex.L.tolist(), "ens": ens.L.tolist(), "ens2": ens2.L.tolist(),
    "simd": [ens.info["simd"], ens2.info["simd"]],
    "warnings": [[w.category.__name__, issubclass(w.category, liebody.CacheWarning),
                  str(w.message)] for w in caught],
}))
"""


def _clean_env() -> dict:
    """This interpreter's environment with the liebody under test first on the path."""
    env = {k: v for k, v in os.environ.items()
           if k not in ("NUMBA_CACHE_DIR", "NUMBA_DISABLE_JIT", "NUMBA_CACHE_LOCATOR_CLASSES")}
    src = str(Path(liebody.__file__).resolve().parents[1])
    env["PYTHONPATH"] = os.pathsep.join([src, env.get("PYTHONPATH", "")])
    return env


def test_no_writable_cache_folder_compiles_without_the_cache_and_warns_once():
    proc = subprocess.run([sys.executable, "-c", _NO_CACHE_RUN], capture_output=True,
                          text=True, env=_clean_env(), timeout=900)
    assert proc.returncode == 0, proc.stderr[-3000:]
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    ours = [w for w in out["warnings"] if w[1]]
    assert len(ours) == 1, out["warnings"]
    assert ours[0][0] == "CacheWarning"
    assert "NUMBA_CACHE_DIR" in ours[0][2] and "writable" in ours[0][2]
    # the same numbers as a run with the cache
    body = liebody.RigidBody([1, 2, 3])
    tr = liebody.integrate(liebody.FreeBody(body), L0=[1, 0, 0.1], dt=0.1, steps=10,
                           method="splitting2")
    tr2 = liebody.integrate(liebody.DampedBody(body, 0.1), L0=[1, 0, 0.1], dt=0.1, steps=10,
                            method="rk4")
    assert np.array_equal(np.array(out["q"]), tr.q)
    assert np.array_equal(np.array(out["L"]), tr.L)
    assert np.array_equal(np.array(out["L2"]), tr2.L)
    assert np.array_equal(np.array(out["qq"]), Q.multiply([0.6, 0.8, 0, 0], [0, 0, 0.6, 0.8]))
    ex = liebody.integrate(liebody.FreeBody(body), L0=[1, 0, 0.1], dt=0.1, steps=10)
    ens = liebody.integrate(liebody.FreeBody(body), L0=[[1, 0, 0.1]] * 8, dt=0.1, steps=10,
                            method="splitting2", simd=True)
    top = liebody.HeavyTop(liebody.RigidBody([5, 5, 1]), 1.0, [0, 0, 1.0], g=1.0)
    ens2 = liebody.integrate(top, L0=[[0.1, 0, 5.0]] * 8, dt=0.01, steps=10, method="rattle",
                             simd=True)
    assert out["simd"] == [True, True]
    assert np.array_equal(np.array(out["ex"]), ex.L)
    assert np.array_equal(np.array(out["ens"]), ens.L)
    assert np.array_equal(np.array(out["ens2"]), ens2.L)


def test_cache_warning_class_loads_no_numba():
    code = ("import sys, warnings, liebody; w = liebody.CacheWarning; "
            "print(issubclass(w, RuntimeWarning), 'numba' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True,
                         text=True, env=_clean_env()).stdout
    assert out.split() == ["True", "False"]


def test_every_kernel_is_compiled_with_the_documented_policy():
    """cache, nogil and numpy's error model (a division by zero gives inf, not a
    ZeroDivisionError from inside a kernel): the policy _jit.py and docs/design.md state."""
    from liebody._kernels import exact, quat, torque

    for kernel in (quat.qmul, exact.exact_flow, torque.damping_flow):
        options = kernel.targetoptions
        assert options.get("nogil") is True and options.get("error_model") == "numpy", options
    assert all(math.isnan(v) for v in quat.qnormalize(0.0, 0.0, 0.0, 0.0))  # 0/0, no raise


def _interleaved_saves(cache_file_class, folder: Path) -> dict:
    """Two writers of one cache index in the order that loses numba's unlocked save:
    both read the empty index, A writes the index, B writes the index and its data, A
    writes its data last. Returns what a later reader loads for each key."""
    import threading

    stamp = (0.0, 1)
    files = {k: cache_file_class(str(folder), "kernel-1", stamp) for k in "AB"}
    events = {name: threading.Event() for name in ("A loaded", "B loaded", "A indexed",
                                                   "B done")}

    def hook(k, method, before=None, after=None):
        original = getattr(files[k], method)

        def wrapped(*args):
            if before:
                events[before].wait(1.0)  # a writer that holds a lock is not waited for
            out = original(*args)
            if after:
                events[after].set()
            return out
        setattr(files[k], method, wrapped)

    hook("A", "_load_index", after="A loaded")
    hook("A", "_save_index", before="B loaded", after="A indexed")
    hook("A", "_save_data", before="B done")
    hook("B", "_load_index", before="A loaded", after="B loaded")
    hook("B", "_save_index", before="A indexed")

    def write(k):
        files[k].save(("key", k), f"code of {k}")
        if k == "B":
            events["B done"].set()

    threads = [threading.Thread(target=write, args=(k,)) for k in "AB"]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    reader = cache_file_class(str(folder), "kernel-1", stamp)
    return {k: reader.load(("key", k)) for k in "AB"}


def test_concurrent_cache_writes_never_map_a_key_to_another_kernel(tmp_path):
    """Processes compiling at once (Dask workers, a process pool) share numba's cache
    folder. numba's unlocked save can leave the index naming one kernel's code for
    another's key, so a later process runs the wrong kernel silently (seen here: an
    ensemble's bodies all NaN after concurrent first compiles). liebody's cache file
    saves under a file lock, data before index."""
    from numba.core.caching import IndexDataCacheFile

    from liebody._kernels import _jit, quat

    (tmp_path / "numba").mkdir()
    (tmp_path / "ours").mkdir()
    # the schedule reproduces the loss with numba's own class ...
    lost = _interleaved_saves(IndexDataCacheFile, tmp_path / "numba")
    assert lost["B"] == "code of A"
    # ... and not with the class every liebody kernel gets
    assert type(quat.qmul._cache._cache_file) is _jit.LockedCacheFile
    kept = _interleaved_saves(_jit.LockedCacheFile, tmp_path / "ours")
    assert kept == {"A": "code of A", "B": "code of B"}


_ENSEMBLES_RUN = r"""
import json, sys, numpy as np, liebody
scene = liebody.FreeBody(liebody.RigidBody([1.0, 2.0, 2.5]))
out = {}
for method in sys.argv[1:]:
    tr = liebody.integrate(scene, L0=[[0.3, 1.0, 0.2]] * 4, dt=0.01, steps=50,
                           method=method, simd=False)
    out[method] = np.nan_to_num(tr.q[:, -1]).tolist()
print(json.dumps(out))
"""


def _ensembles(cache: Path, *methods) -> dict:
    env = {**_clean_env(), "NUMBA_CACHE_DIR": str(cache)}
    proc = subprocess.run([sys.executable, "-c", _ENSEMBLES_RUN, *methods],
                          capture_output=True, text=True, env=env, timeout=900)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


def test_kernels_cached_by_different_processes_are_not_mixed_up(tmp_path):
    """Two ensembles of different methods, each first run in a process of its own, then
    both in a third process that loads them from the cache. Before: the second ensemble
    ran the first method's driver (the drivers were closures of one name, and numba
    linked the cached caller to the other's callee), wrong numbers and no word."""
    shared, fresh = tmp_path / "shared", tmp_path / "fresh"
    _ensembles(shared, "rk4")
    _ensembles(shared, "splitting2")
    assert _ensembles(shared, "rk4", "splitting2") == _ensembles(fresh, "rk4", "splitting2")


def test_a_cache_folder_that_refuses_locks_still_saves(tmp_path, monkeypatch):
    """A file system without flock (some network mounts): the save goes on unlocked
    instead of failing the compile."""
    import fcntl

    from liebody._kernels import _jit

    def refuse(fd, op):
        raise OSError(38, "Function not implemented")

    monkeypatch.setattr(fcntl, "flock", refuse)
    cls = _jit._locked_cache_file_class()
    cls(str(tmp_path), "kernel-1", (0.0, 1)).save(("key", "A"), "code of A")
    assert cls(str(tmp_path), "kernel-1", (0.0, 1)).load(("key", "A")) == "code of A"


def test_two_kernels_of_one_name_are_refused():
    """Factories give each kernel a tag; two kernels of one name are an error."""
    from liebody._kernels import _jit

    def factory(k, tag=None):
        def kernel(x):
            return x + k
        return _jit.jit(kernel, tag=tag)

    assert factory(1, tag="one")(1.0) == 2.0 and factory(2, tag="two")(1.0) == 3.0
    factory(3)
    with pytest.raises(RuntimeError, match=r"two kernels are named .*kernel.*tag"):
        factory(4)


# ------------------------------------------------------------------ tolerances


@pytest.mark.parametrize("tol", [math.nan, -1e-9, math.inf])
def test_from_matrix_rejects_a_tolerance_that_is_not_a_number_ge_0(tol):
    reflection = np.diag([1.0, 1.0, -1.0])
    with pytest.raises(ValueError, match=r"tol must be"):
        Q.from_matrix(reflection, tol=tol)
    with pytest.raises(ValueError, match=r"tol must be"):
        Q.is_unit([1.0, 0, 0, 0], tol=tol)


def test_from_matrix_rejects_a_tolerance_that_is_not_a_real_number():
    with pytest.raises(TypeError, match=r"tol must be a real number"):
        Q.from_matrix(np.eye(3), tol="1e-9")
    with pytest.raises(TypeError, match=r"tol must be a real number"):
        Q.is_unit([1.0, 0, 0, 0], tol=None)
    # still a proper rotation check with a valid tol, 0 included
    with pytest.raises(ValueError, match=r"proper rotation"):
        Q.from_matrix(np.diag([1.0, 1.0, -1.0]), tol=0.5)
    assert np.array_equal(Q.from_matrix(np.eye(3), tol=0.0), [1.0, 0, 0, 0])


# ------------------------------------------------------------------ broadcasting


I2 = np.tile([1.0, 0, 0, 0], (2, 1))
I3 = np.tile([1.0, 0, 0, 0], (3, 1))
V3 = np.tile([1.0, 0, 0], (3, 1))


@pytest.mark.parametrize("call, names", [
    (lambda: Q.multiply(I2, I3), [r"p \(shape \(2, 4\)\)", r"q \(shape \(3, 4\)\)"]),
    (lambda: Q.rotate(I2, V3), [r"q \(shape \(2, 4\)\)", r"v \(shape \(3, 3\)\)"]),
    (lambda: Q.rotate_inverse(I2, V3), [r"q \(shape \(2, 4\)\)", r"v \(shape \(3, 3\)\)"]),
    (lambda: Q.slerp(I2, I3, 0.5), [r"q0 \(shape \(2, 4\)\)", r"q1 \(shape \(3, 4\)\)"]),
    (lambda: Q.slerp(I2, I2, [0.1, 0.2, 0.3]),
     [r"q0 \(shape \(2, 4\)\)", r"q1 \(shape \(2, 4\)\)", r"t \(shape \(3,\)\)"]),
    (lambda: Q.angle_between(I2, I3), [r"p \(shape \(2, 4\)\)", r"q \(shape \(3, 4\)\)"]),
    (lambda: E.rotation_angle([0.1, 0.2], [0.1, 0.2, 0.3], 0.0),
     [r"phi \(shape \(2,\)\)", r"theta \(shape \(3,\)\)", r"psi \(shape \(\)\)"]),
    (lambda: E.rotation_axis([0.1, 0.2], 0.0, [0.1, 0.2, 0.3]),
     [r"phi \(shape \(2,\)\)", r"psi \(shape \(3,\)\)"]),
    (lambda: inertia.parallel_axis(np.tile(np.eye(3), (2, 1, 1)), [1.0, 2.0, 3.0], [1, 0, 0]),
     [r"I_cm \(shape \(2, 3, 3\)\)", r"mass \(shape \(3,\)\)", r"a \(shape \(3,\)\)"]),
])
def test_broadcast_errors_name_the_arguments_and_shapes(call, names):
    with pytest.raises(ValueError, match=r"must broadcast") as info:
        call()
    for name in names:
        assert re.search(name, str(info.value)), (name, str(info.value))


# ------------------------------------------------------------------ scipy Rotation


def test_from_rotation_expects_a_scipy_rotation():
    with pytest.raises(TypeError, match=r"rotation must be a scipy.*Rotation.*from_scipy"):
        Q.from_rotation(np.array([0.0, 0.0, 0.0, 1.0]))
    q = Q.from_rotation(Rotation.from_rotvec([0.0, 0.0, -0.5]))
    np.testing.assert_allclose(q, [np.cos(0.25), 0, 0, -np.sin(0.25)], rtol=1e-15)


# ------------------------------------------------------------------ log at angle pi


@pytest.mark.kernel
@pytest.mark.parametrize("v", [(0.6, 0.8, 0.0), (0.0, -0.6, 0.8), (0.0, 0.0, -1.0),
                               (-1.0, 0.0, 0.0), (-0.48, 0.6, 0.64)])
def test_log_is_sign_invariant_at_angle_pi(v):
    q = np.array([0.0, *v])
    a, b = Q.log(q), Q.log(-q)
    assert np.array_equal(a, b)
    np.testing.assert_allclose(np.linalg.norm(a), np.pi, rtol=1e-15)
    nz = a[np.flatnonzero(a)[0]]
    assert nz > 0  # canonical: first non-zero component positive
    assert np.abs(Q.exp(a) - q).max() < 1e-15 or np.abs(Q.exp(a) + q).max() < 1e-15
    # just short of pi, either sign of w: the short rotation, continuous with pi
    for w in (1e-17, -1e-17, 1e-9):
        p = Q.normalize([w, *v])
        np.testing.assert_allclose(Q.log(p), Q.log(-p), rtol=0, atol=1e-15)
    batch = Q.log(np.stack([q, -q]))
    assert np.array_equal(batch[0], batch[1])


# ------------------------------------------------------------------ inverse


@pytest.mark.kernel
@pytest.mark.parametrize("q, expected", [
    ([1e-170, 0, 0, 0], [1e170, 0, 0, 0]),
    ([1e170, 0, 0, 0], [1e-170, 0, 0, 0]),
    ([0, 3e-170, 0, 4e-170], [0, -1.2e169, 0, -1.6e169]),
    ([0, 3e170, 0, -4e170], [0, -1.2e-171, 0, 1.6e-171]),
    ([3e-300, 0, 4e-300, 0], [1.2e299, 0, -1.6e299, 0]),
])
def test_inverse_of_every_non_zero_quaternion(q, expected):
    q = np.array(q, dtype=float)
    inv = Q.inverse(q)
    np.testing.assert_allclose(inv, expected, rtol=4e-16, atol=0)
    np.testing.assert_allclose(Q.multiply(inv, q), [1.0, 0, 0, 0], rtol=0, atol=4e-16)
    np.testing.assert_allclose(Q.multiply(q, inv), [1.0, 0, 0, 0], rtol=0, atol=4e-16)


@pytest.mark.kernel
def test_inverse_of_subnormal_and_mixed_scale_rows():
    # |q| < 1 / max float: the inverse is beyond float64, a rule of its own
    q = np.array([[2.0**-1023, 0, 0, 0], [1.0, 2.0, 2.0, 4.0], [1e300, 1e300, 0, 0],
                  [5e-324, 0, 0, 0], [0, 2.0**-1060, 0, 0]])
    for row in (3, 4):
        with pytest.raises(ValueError, match=r"q.*inverse.*overflow"):
            Q.inverse(q[[0, 1, row]])
    inv = Q.inverse(q[:3])  # 2^-1023 is subnormal, its inverse 2^1023 a float64
    np.testing.assert_array_equal(inv[0], [2.0**1023, 0, 0, 0])
    np.testing.assert_allclose(inv[1], np.array([1.0, -2, -2, -4]) / 25.0, rtol=4e-16)
    np.testing.assert_allclose(inv[2], [0.5e-300, -0.5e-300, 0, 0], rtol=4e-16)
    with pytest.raises(ValueError, match=r"q must be non-zero"):
        Q.inverse([[1.0, 0, 0, 0], [0.0, 0, 0, 0]])


# ------------------------------------------------------------------ numbers in messages


@pytest.mark.parametrize("value, shown", [
    (-10**300, "-1e+300"), (-10**5000, "-1e+5000"), (-123456789012345678901234, "-1.23457e+23"),
], ids=["1e300", "1e5000", "24 digits"])  # str(10**5000) itself raises (4300-digit limit)
def test_huge_integers_are_printed_short(value, shown):
    with pytest.raises(ValueError) as info:
        as_positive_int("steps", value)
    msg = str(info.value)
    assert msg.startswith("steps must be") and shown in msg and len(msg) < 120, msg


def test_step_counts_beyond_int64_are_refused_by_name():
    scene = liebody.FreeBody(liebody.RigidBody([1, 2, 3]))
    with pytest.raises(ValueError, match=r"^steps must be at most 9.22337e\+18 .* got 1e\+300$"):
        liebody.integrate(scene, L0=[1, 0, 0.1], dt=0.1, steps=10**300, method="splitting2")
    with pytest.raises(ValueError, match=r"save_every must be at most"):
        liebody.integrate(scene, L0=[1, 0, 0.1], dt=0.1, steps=10, save_every=2**63)
    assert as_positive_int("steps", 2**63 - 1) == 2**63 - 1


def test_non_finite_entries_of_a_long_array_are_located_not_printed():
    big = [1.0] * 100_000
    big[7_000] = math.nan
    with pytest.raises(ValueError) as info:
        as_float_array("L0", big)
    msg = str(info.value)
    assert msg.startswith("L0 must be finite") and "7000" in msg and len(msg) < 200, msg


def test_non_integral_values_are_printed_short():
    from fractions import Fraction

    with pytest.raises(ValueError) as info:
        as_positive_int("steps", Fraction(10**300 + 1, 3))
    assert len(str(info.value)) < 120, str(info.value)


# ------------------------------------------------------------------ moments of inertia


@pytest.mark.parametrize("moments", [[1e103, 2e103, 2.5e103], [1e101, 1e101, 1e101],
                                     [1e-101, 1e-101, 1.5e-101]])
def test_moments_whose_products_leave_float64_are_refused_with_advice(moments):
    with pytest.raises(ValueError, match=r"inertia.*1e-100.*1e\+100.*rescale"):
        liebody.RigidBody(moments)
    with pytest.raises(ValueError, match=r"inertia.*rescale"):
        liebody.RigidBody(np.diag(moments))


def test_moments_at_the_ends_of_the_range_integrate():
    from liebody import bodies

    earth = bodies.earth(bodies.EARTH_C)  # kg m^2, SI units
    omega = [1e-9, 0.0, bodies.earth_spin()]
    for method in ("exact", "splitting2"):
        tr = liebody.integrate(liebody.FreeBody(earth), omega0=omega, dt=3600.0, steps=24,
                               method=method)
        unit = liebody.integrate(liebody.FreeBody(bodies.earth()), omega0=omega, dt=3600.0,
                                 steps=24, method=method)
        np.testing.assert_allclose(tr.q, unit.q, rtol=0, atol=1e-13)
    assert liebody.RigidBody([1e-100, 1.5e-100, 2e-100]).moments[0] == 1e-100
    assert liebody.RigidBody([0.6e100, 0.8e100, 1e100]).moments[2] == 1e100
    for scale in (1e-100, 0.25e100):  # moments from 1e-100 to 6.25e99
        body = liebody.RigidBody(scale * np.array([1.0, 2.0, 2.5]))
        L0 = scale * np.array([1.0, 0.2, 0.1])
        for method in ("exact", "splitting2", "rattle", "rk4"):
            tr = liebody.integrate(liebody.FreeBody(body), L0=L0, dt=0.05, steps=20,
                                   method=method)
            ref = liebody.integrate(liebody.FreeBody(liebody.RigidBody([1.0, 2.0, 2.5])),
                                    L0=L0 / scale, dt=0.05, steps=20, method=method)
            np.testing.assert_allclose(tr.q, ref.q, rtol=0, atol=1e-13)
            np.testing.assert_allclose(tr.L / scale, ref.L, rtol=0, atol=1e-13)


@pytest.mark.parametrize("method", ["dmv4", "dmv6", "dmv8", "dmv10"])
@pytest.mark.parametrize("scale", [1e-90, 1e-40, 1e40, 1e90])
def test_preprocessed_dmv_is_the_same_at_any_scale_of_the_moments(method, scale):
    """I -> s I, L -> s L changes nothing (the same angular velocities): before, det^4 and
    I^-4 in the modified moments overflowed inside the accepted range of moments (dmv6 at
    1e90 off by 3e-5 with numpy warnings; dmv8 at 1e-40 refused, blaming the step)."""
    import warnings

    moments, L0 = np.array([1.0, 2.0, 2.5]), np.array([0.3, 0.1, 2.0])
    ref = liebody.integrate(liebody.FreeBody(liebody.RigidBody(moments)), L0=L0, dt=0.1,
                            steps=100, method=method)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)  # no overflow on the way
        tr = liebody.integrate(liebody.FreeBody(liebody.RigidBody(moments * scale)),
                               L0=L0 * scale, dt=0.1, steps=100, method=method)
    # moments * scale and L0 * scale are rounded anew (a relative 1e-16 change of the
    # orbit), which 100 steps of a tumbling body amplify to about 1e-14
    np.testing.assert_allclose(tr.q, ref.q, rtol=0, atol=1e-13)
    np.testing.assert_allclose(tr.L / scale, ref.L, rtol=0, atol=1e-13)
