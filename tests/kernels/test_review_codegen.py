"""Review of the code-generation marks (``trig.wide_vectors``: the LLVM attribute
``prefer-vector-width=512``; ``trig.inline_into_callers``: ``alwaysinline``) and of the
planning of gyrostat ensembles whose bodies carry a rotor or not.

The marks must change no number: a SIMD body's samples do not depend on how many bodies
share its block (a short block runs the loops' scalar remainder, a full one their packed
lanes), the disk cache returns the code it stored, and a build for a CPU without AVX-512
(``NUMBA_CPU_NAME`` / ``NUMBA_CPU_FEATURES``) gives the same numbers as the AVX-512 one.
"""

from __future__ import annotations

import ast
import json
import os
import platform
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import liebody
from liebody import quaternion

JIT = os.environ.get("NUMBA_DISABLE_JIT") != "1"
SRC = Path(liebody.__file__).resolve().parent
MARKS = ("wide_vectors", "inline_into_callers")


# ------------------------------------------------------------------ where the marks are


def _decorated_inline(dec: ast.expr) -> bool:
    """Whether a decorator asks numba to inline the function at its IR level
    (``jit(inline="always")``, ``overload(..., inline="always")``)."""
    return isinstance(dec, ast.Call) and any(
        k.arg == "inline" and not (isinstance(k.value, ast.Constant) and k.value.value == "never")
        for k in dec.keywords)


def test_no_function_that_carries_a_mark_is_inlined_by_numba():
    """The marks write an attribute into the LLVM function being lowered. numba's
    ``inline="always"`` lowers the callee's body inside its caller, so a mark there would
    land on the caller (checked in :func:`test_a_mark_in_a_numba_inlined_function_lands_on_
    its_caller`): a driver would be forced inline or widened by a helper's mark. No
    function of the package that calls a mark is inlined by numba, nor nested in one."""
    offenders, marked = [], 0
    for path in sorted(SRC.rglob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))

        def visit(node, inlined: bool, path=path) -> None:
            nonlocal marked
            for child in ast.iter_child_nodes(node):
                if isinstance(child, ast.FunctionDef):
                    here = inlined or any(_decorated_inline(d) for d in child.decorator_list)
                    calls = [c for c in ast.walk(child) if isinstance(c, ast.Call)
                             and isinstance(c.func, ast.Name) and c.func.id in MARKS]
                    own = [c for c in calls if not any(
                        c in ast.walk(f) for f in ast.walk(child)
                        if isinstance(f, ast.FunctionDef) and f is not child)]
                    marked += len(own)
                    if here and own:
                        offenders.append(f"{path.relative_to(SRC)}:{child.name}")
                    visit(child, here)
                else:
                    visit(child, inlined)

        visit(tree, False)
    assert marked >= 15, marked  # (the SIMD loops, the torque and the turns carry them)
    assert not offenders, offenders


@pytest.mark.skipif(not JIT, reason="needs the compiled kernels")
def test_a_mark_in_a_numba_inlined_function_lands_on_its_caller():
    """Why the rule above: a mark called in a function that numba inlines at its IR level
    marks the caller (here ``alwaysinline`` on ``caller``), not the function."""
    import numba

    from liebody._kernels.trig import inline_into_callers

    @numba.njit(inline="always")
    def helper(x):
        inline_into_callers()
        return x + 1.0

    @numba.njit
    def caller(x):
        return 2.0 * helper(x)

    assert caller(1.0) == 4.0
    ir = caller.inspect_llvm(caller.signatures[0])
    head = re.search(r"define [^\n]*@_ZN[^\n]*6caller[^\n]*#(\d+)", ir)
    assert head, ir[:2000]
    attrs = re.search(rf"attributes #{head.group(1)} = {{([^}}]*)}}", ir).group(1)
    assert "alwaysinline" in attrs


@pytest.mark.skipif(not JIT, reason="needs the compiled kernels")
@pytest.mark.skipif(platform.machine() not in ("x86_64", "AMD64"), reason="x86 assembly")
def test_a_mark_in_an_overload_or_an_inlined_kernel_keeps_its_loops_wide():
    """``wide_vectors`` in an overload's implementation, or in a kernel that LLVM inlines
    into an unmarked caller, still widens its own loop: numba optimises (and vectorises)
    each function in its own module before the caller inlines it, so the caller's
    preference (no merge rule for the attribute) does not undo it. Without the mark the
    same loop runs on ymm registers (an AVX-512 target)."""
    from numba.core.registry import cpu_target

    features = cpu_target.target_context.codegen().magic_tuple()[2].split(",")
    if "+avx512f" not in features:
        pytest.skip("numba compiles for a CPU without AVX-512 here")
    import numba
    from numba.extending import overload

    from liebody._kernels.trig import wide_vectors

    def axpy(a, b, n):  # pragma: no cover - replaced by its overload
        pass

    def axpy_plain(a, b, n):  # pragma: no cover - replaced by its overload
        pass

    def loop(mark):
        def impl(a, b, n):
            if mark:
                wide_vectors()
            for i in range(n):
                a[i] = a[i] * b[i] + 1.5 * b[i]
        return impl

    overload(axpy)(lambda a, b, n: loop(True))
    overload(axpy_plain)(lambda a, b, n: loop(False))
    kernel = numba.njit(loop(True))

    @numba.njit
    def via_overload(a, b, n):
        axpy(a, b, n)

    @numba.njit
    def via_plain(a, b, n):
        axpy_plain(a, b, n)

    @numba.njit
    def via_kernel(a, b, n):
        kernel(a, b, n)

    packed = re.compile(r"\bv?(?:mul|add|fn?m(?:add|sub)\d*)pd\s+.*?%([xyz]mm)\d")
    regs = {}
    for f in (via_overload, via_plain, via_kernel):
        a, b = np.zeros(64), np.ones(64)
        f(a, b, 64)
        assert np.array_equal(a, np.full(64, 1.5))
        regs[f.__name__] = set(packed.findall(f.inspect_asm(f.signatures[0])))
        calls = re.findall(r"call [^\n]*@_ZN\S*4impl", f.inspect_llvm(f.signatures[0]))
        assert not calls, (f.__name__, calls)  # (inlined by LLVM)
    assert "zmm" in regs["via_overload"] and "zmm" in regs["via_kernel"], regs
    assert "zmm" not in regs["via_plain"], regs


# ------------------------------------------------------------------ SIMD blocks


def _scenes():
    rng = np.random.default_rng(7)
    n = 133  # a full block of 128 and one of 5
    I = rng.uniform(2.0, 3.0, size=(n, 3))
    q0 = quaternion.normalize(rng.normal(size=(n, 4)))
    L0 = rng.normal(size=(n, 3))
    free = liebody.FreeBody(liebody.RigidBody.batch(I))
    top = liebody.HeavyTop(liebody.RigidBody([5.0, 5.0, 1.0]), mass=2.0, cm=[0, 0, 1.0])
    from liebody.orbits import Circular

    gg = liebody.GravityGradient(liebody.RigidBody.batch(40.0 * I),
                                 [(3.986e14, Circular(1.1e-3, 7.0e6))], free_flow="axes")
    return {"free": (free, q0, L0, 0.05), "top": (top, q0, L0, 0.01),
            "gg": (gg, q0, 1e-3 * L0, 5.0)}


@pytest.mark.skipif(not JIT, reason="needs the compiled kernels")
@pytest.mark.parametrize(("name", "method"), [
    ("free", "splitting2"), ("free", "splitting4"), ("free", "sr2"), ("free", "rattle"),
    ("free", "dmv4"), ("top", "splitting2"), ("top", "rattle"), ("gg", "splitting2")])
def test_a_simd_bodys_numbers_do_not_depend_on_its_blocks_size_or_lane(name, method):
    """simd=True: every body of a 133-body run (a block of 128, packed lanes, and one of
    5, the loops' scalar remainder) equals, bit for bit, the same body run in a block of
    5 bodies taken in reverse order (another lane, the scalar remainder), samples and
    diagnostics alike. With 512-bit vectors a lane and the remainder differ in nothing
    but the registers: no fast-math contraction, no vector math library."""
    scene, q0, L0, dt = _scenes()[name]
    kw = {"dt": dt, "steps": 60, "save_every": 20, "method": method, "simd": True,
          "threads": 1, "diagnostics": True}
    whole = liebody.integrate(scene, q0=q0, L0=L0, **kw)
    groups = whole.info.get("groups", [whole.info])
    assert all(g["simd"] for g in groups), groups
    n = len(q0)
    for sel in (np.arange(4, -1, -1), np.arange(n - 1, n - 6, -1), np.array([60, 127, 0, 3])):
        sub = scene.take(sel) if getattr(scene, "batch_shape", ()) else scene
        part = liebody.integrate(sub, q0=q0[sel], L0=L0[sel], **kw)
        np.testing.assert_array_equal(part.q, whole.q[sel])
        np.testing.assert_array_equal(part.L, whole.L[sel])
        for key, value in whole.diagnostics.items():
            np.testing.assert_array_equal(np.asarray(part.diagnostics[key]),
                                          np.asarray(value)[sel], err_msg=key)


# ------------------------------------------------------------------ disk cache, AVX2

_CHILD = r"""
import json, sys
import numpy as np
import liebody
from liebody.orbits import Circular

rng = np.random.default_rng(3)
n = 21
I = rng.uniform(2.0, 3.0, size=(n, 3))
q0 = liebody.quaternion.normalize(rng.normal(size=(n, 4)))
L0 = rng.normal(size=(n, 3))
free = liebody.FreeBody(liebody.RigidBody.batch(I))
ens = liebody.integrate(free, q0=q0, L0=L0, dt=0.05, steps=40, save_every=20,
                        method="splitting2", simd=True, threads=1)
gg = liebody.GravityGradient(liebody.RigidBody([100.0, 120.0, 80.0]),
                             [(3.986e14, Circular(1.1e-3, 7.0e6, phase=1.0))])
one = liebody.integrate(gg, q0=q0[0], L0=[0.01, 0.02, 0.03], dt=5.0, steps=40,
                        method="splitting2")
from liebody._kernels import batch
from liebody._kernels.driver import RUNNERS
hits = sum(sum(d.stats.cache_hits.values()) for d in batch.SIMD_RUNNERS.values())
hits += sum(sum(d.stats.cache_hits.values()) for d in RUNNERS.values())
print(json.dumps({"ens_q": ens.q.tolist(), "ens_L": ens.L.tolist(), "one_q": one.q.tolist(),
                  "one_L": one.L.tolist(), "hits": hits,
                  "simd": [g["simd"] for g in ens.info["groups"]]}))
"""

#: an AVX2 CPU (Haswell) for numba, whatever the host: no AVX-512
_AVX2 = {"NUMBA_CPU_NAME": "haswell",
         "NUMBA_CPU_FEATURES": "+64bit,+avx,+avx2,+bmi,+bmi2,+cmov,+cx16,+f16c,+fma,+fsgsbase,"
                               "+lzcnt,+mmx,+movbe,+pclmul,+popcnt,+rdrnd,+sahf,+sse,+sse2,"
                               "+sse3,+sse4.1,+sse4.2,+ssse3,+xsave,+xsaveopt"}


def _child(cache: Path, **env_extra) -> dict:
    env = {k: v for k, v in os.environ.items()
           if k not in ("NUMBA_CACHE_DIR", "NUMBA_DISABLE_JIT", "NUMBA_CPU_NAME",
                        "NUMBA_CPU_FEATURES")}
    env["PYTHONPATH"] = os.pathsep.join([str(SRC.parent), env.get("PYTHONPATH", "")])
    env["NUMBA_CACHE_DIR"] = str(cache)
    env.update(env_extra)
    proc = subprocess.run([sys.executable, "-W", "ignore", "-c", _CHILD], capture_output=True,
                          text=True, env=env, timeout=900)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


def _packed_registers(cache: Path, pattern: str) -> set[str]:
    """The registers of the packed double arithmetic in the object code the cache holds
    for the files matching ``pattern`` (``objdump``)."""
    import pickle

    def elves(x):
        if isinstance(x, bytes) and x[:4] == b"\x7fELF":
            yield x
        elif isinstance(x, tuple | list):
            for y in x:
                yield from elves(y)

    packed = re.compile(r"\bv?(?:mul|add|sub|fn?m(?:add|sub)\d*)pd\s+.*?%([xyz]mm)\d")
    regs = set()
    for path in cache.rglob(pattern):
        for obj in elves(pickle.loads(path.read_bytes())):
            out = cache / "obj.o"
            out.write_bytes(obj)
            asm = subprocess.run(["objdump", "-d", "--no-show-raw-insn", str(out)],
                                 capture_output=True, text=True, check=True).stdout
            regs |= set(packed.findall(asm))
    return regs


@pytest.mark.skipif(not JIT, reason="needs the compiled kernels")
@pytest.mark.skipif(platform.machine() not in ("x86_64", "AMD64"), reason="x86 targets")
def test_the_marked_kernels_survive_the_disk_cache_and_an_avx2_build(tmp_path):
    """One process compiles into an empty cache, a second loads from it (cache hits): the
    same numbers bit for bit, a SIMD ensemble and a one-body gravity-gradient run (the
    torque inlined into a driver compiled against it). A third process builds for an
    AVX2 CPU (numba's NUMBA_CPU_NAME / NUMBA_CPU_FEATURES) into a cache of its own: the
    same numbers again. Where objdump is at hand, the cached object code of the SIMD
    drivers holds packed arithmetic on zmm registers for an AVX-512 target, none for the
    AVX2 one."""
    from numba.core.registry import cpu_target

    cache = tmp_path / "numba"
    first = _child(cache)
    assert all(first["simd"]), first["simd"]
    second = _child(cache)
    assert second["hits"] > 0 and first["hits"] == 0
    avx2_cache = tmp_path / "avx2"
    avx2 = _child(avx2_cache, **_AVX2)
    for key in ("ens_q", "ens_L", "one_q", "one_L"):
        assert first[key] == second[key] == avx2[key], key
    if shutil.which("objdump") is None:
        return
    # (the features numba compiles for, not the host's: NUMBA_CPU_FEATURES may differ)
    features = cpu_target.target_context.codegen().magic_tuple()[2].split(",")
    wide = _packed_registers(cache, "batch._simd_runner*.nbc")
    if "+avx512f" in features:
        assert "zmm" in wide, wide
    narrow = _packed_registers(avx2_cache, "batch._simd_runner*.nbc")
    assert narrow and "zmm" not in narrow, narrow


# ------------------------------------------------------------------ gyrostat ensembles


def _gyrostats(n=9, seed=3):
    rng = np.random.default_rng(seed)
    I = rng.uniform(2.0, 3.0, size=(n, 3))
    l = rng.normal(size=(n, 3))
    l[[0, 3, n - 1]] = 0.0
    l[4] = [-0.0, 0.0, -0.0]  # (a signed zero: no rotor, as one body)
    scene = liebody.Gyrostat(liebody.RigidBody.batch(I), l)
    q0 = quaternion.normalize(rng.normal(size=(n, 4)))
    return scene, l, q0, rng.normal(size=(n, 3))


@pytest.mark.parametrize("method", ["splitting2", "splitting4", "no_squish"])
def test_a_mixed_gyrostat_ensembles_stepper_equals_its_one_body_steppers(method):
    """A Gyrostat ensemble with rotor-free bodies (one with a signed-zero rotor) and
    per-body moments: its Stepper (simd=False) equals integrate() and each body's own
    Stepper bit for bit, call by call; each group holds bodies of one kind, and the
    rotor-free ones are planned as rigid bodies (their orbits' orderings)."""
    scene, l, q0, L0 = _gyrostats()
    n, dt = len(q0), 0.05
    tr = liebody.integrate(scene, q0=q0, L0=L0, dt=dt, steps=90, save_every=30,
                           method=method, simd=False)
    rotor = np.any(l != 0.0, axis=1)
    seen = np.concatenate([g["bodies"] for g in tr.info["groups"]])
    assert sorted(seen.tolist()) == list(range(n))
    for g in tr.info["groups"]:
        assert len(set(rotor[g["bodies"]].tolist())) == 1, g
    ens = liebody.Stepper(scene, q0=q0, L0=L0, dt=dt, method=method, simd=False)
    ones = [liebody.Stepper(scene.take(i), q0=q0[i], L0=L0[i], dt=dt, method=method)
            for i in range(n)]
    for k in range(3):
        ens.step(30)
        np.testing.assert_array_equal(ens.q, tr.q[:, k + 1])
        np.testing.assert_array_equal(ens.L, tr.L[:, k + 1])
        for i, s in enumerate(ones):
            s.step(30)
            np.testing.assert_array_equal(s.q, ens.q[i])
            np.testing.assert_array_equal(s.L, ens.L[i])


def test_a_mixed_gyrostat_ensembles_diagnostics_equal_its_one_body_runs():
    """diagnostics=True, simd=False: each body's samples and diagnostics equal its
    one-body run's bit for bit (the groups' rows put back in body order)."""
    scene, _, q0, L0 = _gyrostats(n=7, seed=11)
    kw = {"dt": 0.05, "steps": 60, "save_every": 7, "diagnostics": True}
    tr = liebody.integrate(scene, q0=q0, L0=L0, simd=False, **kw)
    assert len(tr.info["groups"]) >= 2
    for i in range(len(q0)):
        one = liebody.integrate(scene.take(i), q0=q0[i], L0=L0[i], **kw)
        np.testing.assert_array_equal(tr.q[i], one.q)
        np.testing.assert_array_equal(tr.L[i], one.L)
        for key, value in tr.diagnostics.items():
            np.testing.assert_array_equal(np.asarray(value)[i],
                                          np.asarray(one.diagnostics[key]), err_msg=key)


@pytest.mark.parametrize("method", ["dmv4", "dmv8"])
def test_a_mixed_gyrostat_ensemble_is_refused_as_a_gyrostat_not_by_a_bodys_step(method):
    """A method that refuses gyrostats refuses a Gyrostat ensemble with some rotor-free
    bodies as a gyrostat, as it did before such bodies were planned apart: not with the
    rotor-free bodies' own refusal, which named a body by its place among them (here
    'for 1 of 3 bodies (e.g. body 2)' for the ensemble's body 3, the step too large for
    preprocessed DMV) and sent the user to reduce a step that would not help."""
    I = np.array([[1.0, 2.0, 3.0]] * 4)
    l = np.zeros((4, 3))
    l[1] = [0.5, 0.1, 0.0]
    scene = liebody.Gyrostat(liebody.RigidBody.batch(I), l)
    L0 = np.array([[0.1, 0.1, 0.1], [1.0, 1.0, 1.0], [0.1, 0.2, 0.1], [2.0, 2.0, 2.0]])
    with pytest.raises(ValueError, match=r"rigid body's flow, not a gyrostat's") as info:
        liebody.integrate(scene, L0=L0, dt=2.0, steps=1, method=method, simd=False)
    assert "too large" not in str(info.value)
    # (each rotor-free body alone: the step's own refusal, by its own number)
    with pytest.raises(ValueError, match=r"too large for preprocessed DMV"):
        liebody.integrate(scene.take(3), L0=L0[3], dt=2.0, steps=1, method=method)


# ------------------------------------------------------------------ the memory check


def test_the_memory_refusal_adds_up_to_what_it_counts(monkeypatch):
    """The refusal of too many bodies states what it counts, and its numbers add up:
    ``N`` bodies times the bytes each, plus the set-up's temporaries (counted once, for
    ``min(N, ROWS_AT_ONCE)`` bodies), make the total it gives. (It gave the total with the
    set-up in it beside ``N`` times the bytes each, which did not make it.)"""
    from liebody import _integrate
    from liebody._ordering import ROWS_AT_ONCE

    monkeypatch.setattr(_integrate, "_available_memory", lambda: 100_000_000)
    scene = liebody.FreeBody(liebody.RigidBody([1.0, 2.0, 3.0]))
    n = 200_000
    with pytest.raises(ValueError, match=r"bodies need") as info:
        liebody.integrate(scene, L0=np.ones((n, 3)), dt=0.01, steps=3, save_every=None)
    text = str(info.value)
    m = re.search(r"([0-9,]+) bodies need ([0-9,]+) B each beyond their samples .*? and "
                  r"([0-9.]+) MB for the set-up \(([0-9.]+) GB in all\)", text)
    assert m, text
    bodies, each = (int(m[i].replace(",", "")) for i in (1, 2))
    setup, total = float(m[3]) * 1e6, float(m[4]) * 1e9
    assert bodies == n
    assert setup == pytest.approx(_integrate.SETUP_BYTES_PER_ROW * ROWS_AT_ONCE, rel=5e-3)
    assert total == pytest.approx(bodies * each + setup, rel=5e-3)
