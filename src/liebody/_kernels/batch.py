"""SIMD kernels across bodies: the ensemble drivers with the body loop innermost.

:data:`SIMD_RUNNERS` holds, for the families below and ``diag`` off/on, a driver with
exactly the signature and semantics of :data:`liebody._kernels.batch_drivers.BATCH_RUNNERS`
(read ``driver._runner`` and ``batch_drivers``): slices (``t0``, ``step0``,
``ctl``, ``final``), saving every ``save_every`` steps and at the end of the
last slice, first-same-as-last merging of end stages, per-body failure (status, steps
done, last good state; bodies with a non-zero status on entry are skipped) and the
running diagnostics. :func:`simd_supports` says whether a plan can run here.

Families and stages
-------------------
* ``F_AXES`` (free asymmetric ``splitting2``, ``no_squish``, ``splitting4/6/8``): AXIS;
* ``F_ROTATIONS`` (``sr2``, free symmetric bodies): AXIS, AXIS_RECURRING, SPHERE;
* ``F_KICKED`` and ``F_SPLITTING`` with explicit kicks (the splittings of every scene
  whose torque depends on the orientation and time only): the rotations and KICK;
* ``F_DMV_FREE`` (``rattle``, ``dmv4..10`` on a free body): DMV; ``F_DMV`` (``rattle``
  with kicks): DMV and KICK.

A kick of uniform gravity is one vectorised loop over the block; any other model's
kick goes through the one dispatch on model codes (``liebody._models.dispatch``) at the
stage's clock time (``t0``, ``step0``, ``clock``, as in the scalar driver): the model's
time-only part once for the block (the gravity gradient's source positions and
strengths), then its vectorised block kernel (the gravity gradient's), a user torque's
block callback, or lane by lane, so a new model runs here without an edit to these
kernels. The running diagnostics evaluate the
model's potential likewise.

Everything else (KICK_IMPLICIT, DAMP, the exact flow, the baselines) runs in the scalar
drivers.

Layout
------
Bodies are taken ``BLOCK`` (128) at a time: the bodies of a block are consecutive bodies
with status OK that share ``ctl`` (in practice all bodies of a chunk). A block's state
lives in one float64 buffer of rows of ``BLOCK`` numbers (structure of arrays: row
``R_W`` holds ``w`` of every body of the block, and so on) and each stage is one loop
over the block, so the stage dispatch (kind, axis) is outside the loop and the loop body
is branch-free. Every row sits at a compile-time offset of the one buffer (the kernels
are generated per axis by closures), so LLVM sees the dependence distances between rows
and vectorises without run-time alias checks: on an AVX-512 machine the rotation loops
compile to packed ``vfmadd...pd``/``vmulpd`` on ``zmm`` registers (8 bodies per
instruction; ``tests/kernels/test_batch.py`` checks the assembly for packed
instructions). The per-stage parameters are gathered once per call into a
``(stages, slots, BLOCK)`` array.

Fast sin/cos
------------
Every rotation of the trig families needs ``sin`` and ``cos`` of a half angle; libm
does not vectorise, so the kernels use a branch-free polynomial (``_kernels/trig.py``,
with :func:`fma`; the circular orbits use it too):

* range reduction ``x = k pi/2 + r``, ``k = floor(2x/pi + 1/2)``, by Cody and Waite's
  three-part ``pi/2`` (fdlibm's ``pio2_1``, ``pio2_2``, ``pio2_2t``: 33 + 33 + 53
  bits): ``r`` is exact to about an ulp for ``|x| <= 2^20 pi/2`` (1.6e6); beyond, its
  absolute error grows like ``eps |x|`` (the argument's own rounding), and ``r`` is
  clamped to ``[-0.8, 0.8]`` so that sin and cos stay bounded for any finite ``x``
  (NaN and inf give NaN);
* fdlibm's minimax polynomials on ``|r| <= pi/4`` (``__kernel_sin``: degree 13,
  ``__kernel_cos``: degree 14, both within ``2^-58`` of the functions), with
  ``cos r - 1`` kept as a small number to full relative accuracy;
* the quadrant by exact arithmetic on ``k`` and selects;
* one Newton step that normalises the pair in increment form,
  ``d = s^2 + cm (2 + cm)`` (``cm = cos - 1``), ``s -= s d/2``, ``cm -= (1 + cm) d/2``:
  the polynomial's own error is systematic (its leading coefficient differs from
  ``-1/6`` by ``3e-15``, a norm error ``~7e-15 x^4`` of one sign: about 1e-12 of
  ``|q|`` over 1e8 steps at the half angles of h|omega| = 0.16, by estimate); after
  the Newton step the pair is normalised to ``O(eps s^2)`` and only the final
  rounding of ``s`` and ``cos = 1 + cm`` remains, unbiased, as with libm's correctly
  rounded values.

Measured against ``math.sin``/``math.cos`` (2e5 random arguments per range; the tests
check 2e4):
at most 1 ulp on ``|x| <= pi/4``, 2 ulps on ``|x| <= 100``, 3 ulps up to ``1e9``;
``cos x - 1`` to 4 eps relative near 0. The Newton step leaves
``s^2 + (1 + cm)^2 - 1`` (exact) at most ``1.02 eps s^2``, mean 0; the plain pair
``(s, c)`` has libm's statistics (mean ``-2.8e-18``, rms ``6.5e-17``; libm
``-2.9e-18``, ``6.3e-17``).

Every rotation (AXIS, AXIS_RECURRING, SPHERE) is applied in increment form with ``cm``
straight from the polynomial (no ``-s^2/(1 + c)`` division), as on the scalar path
(``docs/design.md``, "Rounding that does not average out"): near a steady rotation even
an axis rotation's angle hardly changes from step to step. Where the angle recurs
exactly (AXIS_RECURRING, SPHERE) the pair is normalised as well, so that its norm error
does not recur; elsewhere :func:`~liebody._kernels.trig.sincos_small_raw` saves the
Newton step.

When every half angle of a stage is known to stay below 0.78 over the next steps (the
free families keep ``|m|``; with gravity kicks ``|m|`` grows at most by
``sum |tau| |c| |q|^2`` per step), the stage runs a variant without the range reduction.
It gives the same numbers bit for bit (``k = 0`` there; see "No fast-math" below),
so a body's result does not depend on the other bodies of its block.

No fast-math. ``fastmath={"contract"}`` (LLVM fuses ``a*b + c`` wherever it likes)
was measured 4 % faster, but the fusion chosen differs between the vectorised loop and
its scalar remainder and between code variants, so a body's last bits would depend on
its position in the block. Instead the rotation kernels call :func:`fma` explicitly
(``llvm.fma``: one rounding, never re-fused) in the polynomials, the Cody–Waite steps,
the Newton step and the rotation updates, and are otherwise IEEE in the order written:
every lane of a block, the scalar remainder, the fast and general variants and the
uncompiled kernels (``NUMBA_DISABLE_JIT=1``, where :func:`fma` is exact rational
arithmetic rounded once) give the same numbers, bit for bit. The DMV, kick and
diagnostics kernels repeat the scalar kernels' arithmetic operation for operation (no
FMA): the vectorised DMV step and gravity kick give the scalar driver's numbers bit
for bit.

Agreement with the one-body driver: the rotations differ from libm's by an ulp in
``sin``/``cos`` and by the fused roundings, a few 1e-16 per step; the difference then
grows with the phase error of the orbit, about linearly in time (below 1e-13 after 300
steps, see the tests). The DMV family (``rattle``, ``dmvN``, with or without gravity
kicks) agrees bit for bit.

DMV
---
The Gauss–Seidel fixed point of :func:`~liebody._kernels.flows.dmv_step` runs for the
whole block at once: each body stops updating once converged (a per-body mask, the
scalar's test), and the block iterates until every body has converged or the scalar's
budget (``DMV_MAX_FIXED_POINT``) is spent. A body that does not converge, or diverges,
is stepped by the scalar ``dmv_step`` for that step (Newton, then continuation),
whose failure is the body's ``STATUS_NO_CONVERGENCE``.

Failures
--------
A block runs in chunks of at most ``CHUNK`` steps, each ending before a save; the state
(and the diagnostics) are checkpointed at the start of a chunk. At its end a body is
suspect when a stage flagged it (a gravity torque that is not finite, a DMV step the
scalar solver could not do) or when ``|w| + ... + |m3|`` is not below 1e300. Then the
chunk is run again from the checkpoint one step at a time, and the scalar loop's test
(``|w + x + ... + m3| < 1e308`` and the stage flags, first failure first) finds the
failing step: the body's status, steps done and last good state are those of the
scalar loop; its lane then carries a harmless state (identity, ``m = 0``) and is
never written again. (A non-finite state stays non-finite under these stages, so
nothing is missed between checks.)
"""

from __future__ import annotations

import math

import numpy as np

from liebody._kernels._jit import jit
from liebody._kernels.flows import DMV_MAX_FIXED_POINT, LARGE_INCREMENT, dmv_step
from liebody._kernels.stages import (
    AXIS,
    AXIS_RECURRING,
    DMV,
    F_AXES,
    F_DMV,
    F_DMV_FREE,
    F_KICKED,
    F_ROTATIONS,
    F_SPLITTING,
    KICK,
    KINDS,
    MAX_MODEL_CODE,
    N_CONTROLS,
    P_I1,
    P_I2,
    P_I3,
    P_RATE,
    P_TORQUE,
    SPHERE,
    STATUS_BAD_STAGE,
    STATUS_NO_CONVERGENCE,
    STATUS_NONFINITE,
    STATUS_OK,
    STATUS_TORQUE,
    TORQUE_GRAVITY,
    TORQUE_NONE,
    family_tag,
)
from liebody._kernels.trig import (
    _cos_poly,
    _quadrant,
    _reduce,
    _sin_poly,
    fma,
    sincos,
    sincos_small,
    sincos_small_raw,
    wide_vectors,
)
from liebody._models import dispatch

#: bodies per block (the length of every row of the block buffer)
BLOCK = 128
#: steps per chunk between failure checks (a chunk also ends before every save)
CHUNK = 64
#: a stage whose half angles all stay below this runs without range reduction
FAST_LIMIT = 0.78
#: a recurring rotation (AXIS_RECURRING, SPHERE) whose half angle may reach this puts ``q``
#: back on the unit sphere after it (``_project_block``; ``flows.LARGE_INCREMENT``)
PROJECT_HALF = math.sqrt(LARGE_INCREMENT)
#: stage flags of a chunk (``_fast_flags``); CONSTANT: a recurring rotation whose angle is
#: the same at every step of the chunk (no other stage changes its ``m_k``), its sine and
#: cosine computed once at the chunk's start (``_constant_turns``)
FAST, PROJECT, CONSTANT = 1, 2, 4
#: the fewest bodies (of a chunk) for which the SIMD drivers beat the scalar ones: one
#: body is 10 % slower (DMV: 70 %), two break even for DMV, three win for every family
#: (measured on AVX-512: free splitting2 43 against 74 ns/body-step at 3 bodies, 8 ns
#: at 16); below 8 bodies every loop runs in its scalar remainder
SIMD_MIN_BODIES = 3

# ------------------------------------------------------------------ the block buffer
R_W, R_X, R_Y, R_Z, R_M1, R_M2, R_M3 = range(7)  # the state
R_CK = 7  # 7 rows: the state at the start of the chunk
R_SK = 14  # 7 rows: the state at the start of the step (replay)
R_FAIL = 21  # a stage's failure code (first one wins), 0.0 when none
R_BOUND = 22  # |m| bound over the chunk
R_D = 23  # 3 rows: running diagnostics
R_DCK = 26  # 3 rows: diagnostics at the start of the chunk
R_DSK = 29  # 3 rows: diagnostics at the start of the step (replay)
R_DREF = 32  # 10 rows: diagnostic references
R_C = 42  # 3 rows: DMV iterate c
R_A = 45  # 3 rows: DMV a = (h/2) m / I
R_CONV = 48  # DMV: 0 iterating, 1 converged, 2 to the scalar solver, 3 skip
N_ROWS = 49

W0, X0, Y0, Z0 = R_W * BLOCK, R_X * BLOCK, R_Y * BLOCK, R_Z * BLOCK
M10, M20, M30 = R_M1 * BLOCK, R_M2 * BLOCK, R_M3 * BLOCK
FAIL0 = R_FAIL * BLOCK
D00, D10, D20 = R_D * BLOCK, (R_D + 1) * BLOCK, (R_D + 2) * BLOCK
REF0 = R_DREF * BLOCK
C10, C20, C30 = R_C * BLOCK, (R_C + 1) * BLOCK, (R_C + 2) * BLOCK
A10, A20, A30 = R_A * BLOCK, (R_A + 1) * BLOCK, (R_A + 2) * BLOCK
CONV0 = R_CONV * BLOCK

# per-stage parameter slots of the gathered parameters (stage, slot, body)
N_SLOTS = 6  # rotations: rate; kicks: the model's 3 block constants, torque bound; DMV: I1..f3

# ------------------------------------------------------------------ the supported kinds
#: family -> the kinds its SIMD driver runs
SIMD_FAMILIES: dict[int, frozenset[int]] = {
    F_AXES: frozenset({AXIS}),
    F_ROTATIONS: frozenset({AXIS, AXIS_RECURRING, SPHERE}),
    F_KICKED: frozenset({AXIS, AXIS_RECURRING, SPHERE, KICK}),
    F_SPLITTING: frozenset({AXIS, AXIS_RECURRING, SPHERE, KICK}),
    F_DMV_FREE: frozenset({DMV}),
    F_DMV: frozenset({DMV, KICK}),
}


def _members() -> np.ndarray:
    table = np.zeros((max(SIMD_FAMILIES) + 1, max(KINDS) + 1), dtype=np.bool_)
    for code, members in SIMD_FAMILIES.items():
        table[code, sorted(members)] = True
    table.flags.writeable = False
    return table


#: ``SIMD_MEMBERS[family, kind]``: whether the family's SIMD driver runs the kind
SIMD_MEMBERS = _members()


def simd_supports(plan, torque_code) -> bool:
    """Whether ``plan`` (a :class:`liebody._plan.Plan`) can run in a :data:`SIMD_RUNNERS`
    driver: its family is one of :data:`SIMD_FAMILIES` and every stage kind is one that
    family's SIMD driver runs (the kicks of any model)."""
    family = int(plan.family)
    if family not in SIMD_FAMILIES:
        return False
    kinds = [int(k) for k in plan.kinds]
    if not kinds or any(k not in SIMD_FAMILIES[family] for k in kinds):
        return False
    return not (KICK in kinds and not 0 < int(torque_code) <= MAX_MODEL_CODE)


# ------------------------------------------------------------------ rotation kernels
@jit(inline="always")
def _sincos_raw(x):
    """:func:`~liebody._kernels.trig.sincos` for the general rigid axis turn, but
    :func:`~liebody._kernels.trig.sincos_small_raw`'s pair where ``|x| <= FAST_LIMIT``:
    a body's turn then has the fast kernel's numbers whatever the other bodies of its
    block turn (the normalised pair differs from the raw one in the last bit)."""
    s, c, cm = sincos(x)
    rs, rc, rcm = sincos_small_raw(x)
    small = abs(x) <= FAST_LIMIT
    return (rs if small else s), (rc if small else c), (rcm if small else cm)


def _axis_kernel(axis: int, general: bool, recurring: bool, constant: bool = False):
    """The loop over a block of the exact flow of ``rate m_k^2 / 2`` about axis ``k``, in
    increment form (:func:`~liebody._kernels.flows.axis_flow_recurring`), for every axis
    rotation, recurring or not: near a steady rotation the plain form's ``cos``, rounded
    to the grid near 1, recurs and drifted ``|q|`` and ``|m|`` linearly (5.7e-12 per 1e6
    steps). ``general``: with range reduction. ``recurring``: the angle recurs exactly
    (``m_k`` constant), so the polynomial pair is normalised (its norm error, ``eps
    sin^2``, would recur too); otherwise the cheaper pair as it comes. The rows are
    compile-time offsets: ``k`` and the two axes after it in cyclic order (the formulas
    of ``qaxis_rotation`` for every axis). ``constant``: the angle's sine and cosine are
    read from ``par[j, 1..4]`` (:func:`_constant_turns`: the same numbers).
    """
    ms = (M10, M20, M30)
    qs = (X0, Y0, Z0)
    OA, OB, OC = ms[axis], ms[(axis + 1) % 3], ms[(axis + 2) % 3]
    OP, OU, OV = qs[axis], qs[(axis + 1) % 3], qs[(axis + 2) % 3]
    trig = (sincos if recurring else _sincos_raw) if general else \
        sincos_small if recurring else sincos_small_raw
    tag = (f"axis{axis}_{'recurring' if recurring else 'increment'}_"
           f"{'general' if general else 'small'}{'_constant' if constant else ''}")

    @jit(tag=tag)
    def kernel(buf, par, j, nb, tau):
        wide_vectors()
        ht = 0.5 * tau
        for i in range(nb):
            if constant:
                s2, cm2, s, cm = par[j, 1, i], par[j, 2, i], par[j, 3, i], par[j, 4, i]
            else:
                s2, c2, cm2 = trig(ht * par[j, 0, i] * buf[OA + i])
                cm = -2.0 * s2 * s2  # cos(2 half) - 1
                s = 2.0 * s2 * c2
            mb = buf[OB + i]
            mc = buf[OC + i]
            buf[OB + i] = mb + fma(cm, mb, s * mc)
            buf[OC + i] = mc + fma(cm, mc, -(s * mb))
            w = buf[W0 + i]
            p = buf[OP + i]
            u = buf[OU + i]
            v = buf[OV + i]
            buf[W0 + i] = w + fma(cm2, w, -(s2 * p))
            buf[OP + i] = p + fma(cm2, p, s2 * w)
            buf[OU + i] = u + fma(cm2, u, s2 * v)
            buf[OV + i] = v + fma(cm2, v, -(s2 * u))

    return kernel


def _sphere_kernel(general: bool):
    """The loop over a block of the sphere flow ``q <- q exp(tau rate m)`` in increment
    form (:func:`~liebody._kernels.flows.sphere_flow`): ``(cos(|r|/2) - 1, v)`` with
    ``v = sin(|r|/2) r / |r|``, normalised by one Newton step. ``sin(x) / x`` and
    ``cos x - 1`` are polynomials in ``x^2 = |r|^2 / 4``: no square root below a quarter
    turn (it was a tenth of a heavy top's SIMD step)."""

    @jit(tag="general" if general else "small")
    def kernel(buf, par, j, nb, tau):
        wide_vectors()
        for i in range(nb):
            a = tau * par[j, 0, i]
            r1 = a * buf[M10 + i]
            r2 = a * buf[M20 + i]
            r3 = a * buf[M30 + i]
            nr2 = fma(r1, r1, fma(r2, r2, r3 * r3))
            if general:  # (below a quarter turn, the fast variant's numbers: k = 0)
                nr = math.sqrt(nr2)
                k, r = _reduce(0.5 * nr)
                z = r * r if k != 0.0 else 0.25 * nr2
            else:  # the polynomials in z = (|r|/2)^2 need no square root
                k, z = 0.0, 0.25 * nr2
            sp = z * _sin_poly(z)
            cm = z * fma(z, _cos_poly(z), -0.5)
            f = 0.5 * (1.0 + sp)  # sin(x) / |r| = sin(x) / (2 x)
            if general:
                _, sx, cx = _quadrant(k, fma(r, sp, r), 1.0 + cm)
                f = f if k == 0.0 else sx / nr
                cm = cm if k == 0.0 else cx - 1.0
            vx, vy, vz = f * r1, f * r2, f * r3
            g = 0.5 * fma(vx, vx, fma(vy, vy, fma(vz, vz, cm * (2.0 + cm))))
            vx, vy, vz = fma(-vx, g, vx), fma(-vy, g, vy), fma(-vz, g, vz)
            cm = fma(-(1.0 + cm), g, cm)
            w = buf[W0 + i]
            qx = buf[X0 + i]
            qy = buf[Y0 + i]
            qz = buf[Z0 + i]
            buf[W0 + i] = w + (cm * w - qx * vx - qy * vy - qz * vz)
            buf[X0 + i] = qx + (cm * qx + w * vx + qy * vz - qz * vy)
            buf[Y0 + i] = qy + (cm * qy + w * vy + qz * vx - qx * vz)
            buf[Z0 + i] = qz + (cm * qz + w * vz + qx * vy - qy * vx)

    return kernel


_AXIS_FAST = tuple(_axis_kernel(a, False, False) for a in range(3))
_AXIS_GENERAL = tuple(_axis_kernel(a, True, False) for a in range(3))
_RECURRING_FAST = tuple(_axis_kernel(a, False, True) for a in range(3))
_AX0F, _AX1F, _AX2F = _AXIS_FAST
_AX0G, _AX1G, _AX2G = _AXIS_GENERAL
_RC0F, _RC1F, _RC2F = _RECURRING_FAST
_RC0G, _RC1G, _RC2G = (_axis_kernel(a, True, True) for a in range(3))
_RC0C, _RC1C, _RC2C = (_axis_kernel(a, False, True, True) for a in range(3))
_SPHERE_FAST = _sphere_kernel(False)
_SPHERE_GENERAL = _sphere_kernel(True)


@jit
def _project_block(buf, nb, sphere, axis, par, j, tau):
    """After a recurring rotation (``sphere``, or about ``axis``), ``q`` of every body whose
    half angle is large (``flows.LARGE_INCREMENT``, decided per body from its own state as
    the scalar flows decide it) back on the unit sphere: ``q (1 - delta/2)`` with
    ``delta = |q|^2 - 1`` exact (squares split by FMA), the scalar ``quat.qproject_unit``;
    the other bodies are left bit for bit (``k = 0``). After a large rotation that recurs
    every step the roundings can repeat (at a step near a multiple of a half turn), and
    ``|q|`` would drift."""
    wide_vectors()
    for i in range(nb):
        w = buf[W0 + i]
        x = buf[X0 + i]
        y = buf[Y0 + i]
        z = buf[Z0 + i]
        a = tau * par[j, 0, i]
        m1 = buf[M10 + i]
        m2 = buf[M20 + i]
        m3 = buf[M30 + i]
        if sphere:
            r1, r2, r3 = a * m1, a * m2, a * m3
            big = r1 * r1 + r2 * r2 + r3 * r3 >= 4.0 * LARGE_INCREMENT
        else:
            half = 0.5 * a * (m1 if axis == 0 else (m2 if axis == 1 else m3))
            big = half * half >= LARGE_INCREMENT
        s = w * w
        e = fma(w, w, -s)
        for c in (x, y, z):
            p = c * c
            pe = fma(c, c, -p)
            t = s + p
            bb = t - s
            e += ((s - (t - bb)) + (p - bb)) + pe
            s = t
        k = -0.5 * ((s - 1.0) + e) if big else 0.0
        buf[W0 + i] = w + k * w
        buf[X0 + i] = x + k * x
        buf[Y0 + i] = y + k * y
        buf[Z0 + i] = z + k * z


# ------------------------------------------------------------------ kicks, DMV, diagnostics
@jit
def _kick_block(buf, par, j, nb, tau):
    """Uniform-gravity kick ``m += tau (Gamma x c)`` over a block (the scalar ``_kick``'s
    arithmetic); a torque that is not finite flags ``STATUS_TORQUE``."""
    wide_vectors()
    for i in range(nb):
        w = buf[W0 + i]
        x = buf[X0 + i]
        y = buf[Y0 + i]
        z = buf[Z0 + i]
        g1 = 2.0 * (x * z - w * y)
        g2 = 2.0 * (y * z + w * x)
        g3 = w * w - x * x - y * y + z * z
        c1, c2, c3 = par[j, 0, i], par[j, 1, i], par[j, 2, i]
        n1 = g2 * c3 - g3 * c2
        n2 = g3 * c1 - g1 * c3
        n3 = g1 * c2 - g2 * c1
        _add_kick(buf, i, n1, n2, n3, tau)


@jit(inline="always")
def _add_kick(buf, i, n1, n2, n3, tau):
    """``m += tau n`` for body ``i`` of a block, flagging ``STATUS_TORQUE`` (the first flag
    wins) when the torque ``n`` is not finite."""
    f = buf[FAIL0 + i]
    ok = abs(n1) + abs(n2) + abs(n3) < math.inf
    buf[FAIL0 + i] = f if (f != 0.0 or ok) else float(STATUS_TORQUE)
    buf[M10 + i] = buf[M10 + i] + tau * n1
    buf[M20 + i] = buf[M20 + i] + tau * n2
    buf[M30 + i] = buf[M30 + i] + tau * n3


@jit
def _model_kick_block(buf, mc, par, j, nb, t, tau):
    """Any model's kick ``m += tau N(t, q, m)`` over a block through the one dispatch on
    model codes (a model's vectorised block kernel, or body by body; the scalar
    ``_explicit_kick``'s arithmetic); a torque that is not finite flags ``STATUS_TORQUE``.
    ``mc`` is the block's model context (see ``_run_block``), ``par`` the gathered
    parameters (the model's ``block_constants`` in ``par[j, 0..2]``)."""
    wide_vectors()
    code, addr, mpar, params, idx, scratch = mc[0], mc[2], mc[3], mc[4], mc[5], mc[6]
    slot = mc[11][j]  # the stage's row of params
    # the time-only part (the sources' positions) once for the block, from the shared block
    dispatch.prepare(code, mc[10], t, scratch)
    out = mc[7]
    dispatch.torque_block(code, mpar, params, par, j, slot, addr, t, scratch, idx, nb, buf,
                          (W0, X0, Y0, Z0, M10, M20, M30), out, mc[8], mc[9])
    for b in range(nb):
        _add_kick(buf, b, out[0, b], out[1, b], out[2, b], tau)


@jit(inline="always")
def _two_square(a):
    p = a * a
    c = 134217729.0 * a
    ah = c - (c - a)
    al = a - ah
    return p, ((ah * ah - p) + 2.0 * ah * al) + al * al


@jit(inline="always")
def _two_sum(a, b):
    s = a + b
    bb = s - a
    return s, (a - (s - bb)) + (b - bb)


@jit(inline="always")
def _unit_increment(w, x, y, z):
    """:func:`~liebody._kernels.quat.qunit_increment`, operation for operation."""
    v2 = x * x + y * y + z * z
    s, e = _two_square(w)
    p, pe = _two_square(x)
    s, e2 = _two_sum(s, p)
    e += e2 + pe
    p, pe = _two_square(y)
    s, e2 = _two_sum(s, p)
    e += e2 + pe
    p, pe = _two_square(z)
    s, e2 = _two_sum(s, p)
    e += e2 + pe
    delta = (s - 1.0) + e
    k = 1.0 - 0.5 * delta / v2
    if v2 < 1e-4:
        k = 1.0
    return w, k * x, k * y, k * z


@jit
def _dmv_block(buf, p, nb, tau):
    """The DMV step (:func:`~liebody._kernels.flows.dmv_step`) over a block: the
    Gauss–Seidel fixed point for every body at once (per-body convergence mask, common
    iteration count), the scalar step for the bodies it does not settle, then the
    update. ``p`` holds the rows I1, I2, I3, f1, f2, f3. Bit for bit the scalar step."""
    wide_vectors()
    if tau == 0.0:
        return
    hh = 0.5 * tau
    for i in range(nb):
        a1 = hh * buf[M10 + i] / p[0, i]
        a2 = hh * buf[M20 + i] / p[1, i]
        a3 = hh * buf[M30 + i] / p[2, i]
        f1, f2, f3 = p[3, i], p[4, i], p[5, i]
        c1 = a1 + f1 * a2 * a3
        c2 = a2 + f2 * c1 * a3
        c3 = a3 + f3 * c1 * c2
        buf[A10 + i] = a1
        buf[A20 + i] = a2
        buf[A30 + i] = a3
        buf[C10 + i] = c1
        buf[C20 + i] = c2
        buf[C30 + i] = c3
        buf[CONV0 + i] = 3.0 if buf[FAIL0 + i] != 0.0 else 0.0
    for _ in range(DMV_MAX_FIXED_POINT):
        active = 0
        for i in range(nb):
            cv = buf[CONV0 + i]
            c1 = buf[C10 + i]
            c2 = buf[C20 + i]
            c3 = buf[C30 + i]
            a1 = buf[A10 + i]
            a2 = buf[A20 + i]
            a3 = buf[A30 + i]
            alpha = 1.0 + c1 * c1 + c2 * c2 + c3 * c3
            n1 = alpha * a1 + p[3, i] * c2 * c3
            n2 = alpha * a2 + p[4, i] * n1 * c3
            n3 = alpha * a3 + p[5, i] * n1 * n2
            d = abs(n1 - c1) + abs(n2 - c2) + abs(n3 - c3)
            size = abs(n1) + abs(n2) + abs(n3)
            diverging = (not (d < 1e300)) | (not (size < 1e150))
            run = cv == 0.0
            upd = run & (not diverging)
            buf[C10 + i] = n1 if upd else c1
            buf[C20 + i] = n2 if upd else c2
            buf[C30 + i] = n3 if upd else c3
            done = d <= 8e-16 * size + 1e-300
            new = 2.0 if (run & diverging) else (1.0 if (upd & done) else cv)
            buf[CONV0 + i] = new
            active += 1 if new == 0.0 else 0
        if active == 0:
            break
    for i in range(nb):  # the scalar solver for the bodies the fixed point left
        cv = buf[CONV0 + i]
        if cv == 0.0 or cv == 2.0:
            r = dmv_step(buf[W0 + i], buf[X0 + i], buf[Y0 + i], buf[Z0 + i], buf[M10 + i],
                         buf[M20 + i], buf[M30 + i], p[0, i], p[1, i], p[2, i], tau)
            if r[7] >= 0:
                buf[W0 + i], buf[X0 + i], buf[Y0 + i], buf[Z0 + i] = r[0], r[1], r[2], r[3]
                buf[M10 + i], buf[M20 + i], buf[M30 + i] = r[4], r[5], r[6]
            elif buf[FAIL0 + i] == 0.0:
                buf[FAIL0 + i] = float(STATUS_NO_CONVERGENCE)
    for i in range(nb):
        ok = buf[CONV0 + i] == 1.0
        c1 = buf[C10 + i]
        c2 = buf[C20 + i]
        c3 = buf[C30 + i]
        alpha = 1.0 + c1 * c1 + c2 * c2 + c3 * c3
        n = math.sqrt(alpha)
        uw, ux, uy, uz = _unit_increment(1.0 / n, c1 / n, c2 / n, c3 / n)
        w = buf[W0 + i]
        x = buf[X0 + i]
        y = buf[Y0 + i]
        z = buf[Z0 + i]
        nw = w * uw - x * ux - y * uy - z * uz
        nx = w * ux + x * uw + y * uz - z * uy
        ny = w * uy - x * uz + y * uw + z * ux
        nz = w * uz + x * uy - y * ux + z * uw
        # R(u)^T m = qrotate(u*, m)
        vx = buf[M10 + i]
        vy = buf[M20 + i]
        vz = buf[M30 + i]
        qx, qy, qz = -ux, -uy, -uz
        tx = 2.0 * (qy * vz - qz * vy)
        ty = 2.0 * (qz * vx - qx * vz)
        tz = 2.0 * (qx * vy - qy * vx)
        m1 = vx + uw * tx + (qy * tz - qz * ty)
        m2 = vy + uw * ty + (qz * tx - qx * tz)
        m3 = vz + uw * tz + (qx * ty - qy * tx)
        buf[W0 + i] = nw if ok else w
        buf[X0 + i] = nx if ok else x
        buf[Y0 + i] = ny if ok else y
        buf[Z0 + i] = nz if ok else z
        buf[M10 + i] = m1 if ok else vx
        buf[M20 + i] = m2 if ok else vy
        buf[M30 + i] = m3 if ok else vz


@jit
def _diagnose_block(buf, nb, mc, t):
    """``driver._diagnose`` for every body of a block (rows ``R_D``, references ``R_DREF``)
    at time ``t``: uniform gravity's potential vectorised (its weight arm in the reference
    rows 3..5, zero without a potential), any other model's lane by lane."""
    wide_vectors()
    dcode, mpar, idx, ms = mc[1], mc[3], mc[5], mc[10]
    mshared = mpar.shape[0] == 1
    # another model's potential first, lane by lane, into the torque rows (free here);
    # the loop below then stays branch-free and vectorised
    vm = mc[7][0]
    if dcode == TORQUE_NONE or dcode == TORQUE_GRAVITY:
        for i in range(nb):
            vm[i] = 0.0
    else:
        for i in range(nb):
            vm[i] = dispatch.potential(dcode, mpar[0] if mshared else mpar[idx[i]], ms, t,
                                       buf[W0 + i], buf[X0 + i], buf[Y0 + i], buf[Z0 + i])
    for i in range(nb):
        w = buf[W0 + i]
        x = buf[X0 + i]
        y = buf[Y0 + i]
        z = buf[Z0 + i]
        m1 = buf[M10 + i]
        m2 = buf[M20 + i]
        m3 = buf[M30 + i]
        n2 = w * w + x * x + y * y + z * z
        T = 0.5 * (m1 * m1 * buf[REF0 + i] + m2 * m2 * buf[REF0 + BLOCK + i]
                   + m3 * m3 * buf[REF0 + 2 * BLOCK + i])
        V = (buf[REF0 + 3 * BLOCK + i] * 2.0 * (x * z - w * y)
             + buf[REF0 + 4 * BLOCK + i] * 2.0 * (y * z + w * x)
             + buf[REF0 + 5 * BLOCK + i] * (w * w - x * x - y * y + z * z)) / n2
        V = V + vm[i]  # (exactly V for gravity, exactly the model's otherwise)
        e = abs(T + V - buf[REF0 + 6 * BLOCK + i]) * buf[REF0 + 7 * BLOCK + i]
        qe = abs(math.sqrt(n2) - 1.0)
        le = (abs(math.sqrt(m1 * m1 + m2 * m2 + m3 * m3) - buf[REF0 + 8 * BLOCK + i])
              * buf[REF0 + 9 * BLOCK + i])
        d0 = buf[D00 + i]
        d1 = buf[D10 + i]
        d2 = buf[D20 + i]
        buf[D00 + i] = e if e > d0 else d0
        buf[D10 + i] = qe if qe > d1 else d1
        buf[D20 + i] = le if le > d2 else d2


# ------------------------------------------------------------------ one step of a block
@jit(inline="always")
def _apply(family, kind, axis, fast, buf, par, j, nb, tau):
    """A stage of kind ``kind`` for time ``tau`` on a block (``p``: its parameter rows),
    but for the kicks of models other than uniform gravity (:func:`_step`); ``fast``: the
    stage's flags (``FAST``: no range reduction needed; ``PROJECT``: a large recurring
    rotation, after which ``q`` is put back on the unit sphere)."""
    if family == F_DMV or family == F_DMV_FREE:
        if kind == DMV:
            _dmv_block(buf, par[j], nb, tau)
        else:
            _kick_block(buf, par, j, nb, tau)
        return
    if (family == F_SPLITTING or family == F_KICKED) and kind == KICK:
        _kick_block(buf, par, j, nb, tau)
        return
    if kind == AXIS_RECURRING and fast & CONSTANT:
        if axis == 0:
            _RC0C(buf, par, j, nb, tau)
        elif axis == 1:
            _RC1C(buf, par, j, nb, tau)
        else:
            _RC2C(buf, par, j, nb, tau)
    elif kind == AXIS_RECURRING and fast & FAST:
        if axis == 0:
            _RC0F(buf, par, j, nb, tau)
        elif axis == 1:
            _RC1F(buf, par, j, nb, tau)
        else:
            _RC2F(buf, par, j, nb, tau)
    elif kind == AXIS_RECURRING:  # (the normalised pair, as the fast recurring kernel's)
        if axis == 0:
            _RC0G(buf, par, j, nb, tau)
        elif axis == 1:
            _RC1G(buf, par, j, nb, tau)
        else:
            _RC2G(buf, par, j, nb, tau)
    elif family == F_AXES or kind == AXIS:
        if fast & FAST:
            if axis == 0:
                _AX0F(buf, par, j, nb, tau)
            elif axis == 1:
                _AX1F(buf, par, j, nb, tau)
            else:
                _AX2F(buf, par, j, nb, tau)
        elif axis == 0:
            _AX0G(buf, par, j, nb, tau)
        elif axis == 1:
            _AX1G(buf, par, j, nb, tau)
        else:
            _AX2G(buf, par, j, nb, tau)
    elif fast & FAST:
        _SPHERE_FAST(buf, par, j, nb, tau)
    else:
        _SPHERE_GENERAL(buf, par, j, nb, tau)
    if fast & PROJECT:
        _project_block(buf, nb, kind == SPHERE, axis, par, j, tau)


@jit
def _steps(family, diag, kinds, axes, coefs, clock, par, fast, merge_ends, h, t0, step0,
           n_steps, final, buf, nb, pending, until_save, s0, s1, mcode, mc):
    """Steps ``s0 .. s1 - 1`` of the run on the block (the scalar loop's stage sequence, its
    clock and saving countdown included); returns ``(pending, until_save)``.

    A called function, not an inlined one: the model context ``mc`` (a tuple holding
    arrays) is a parameter here, so the step loop touches no reference count (an inlined
    function binds its arguments afresh at every call, an atomic increment and decrement
    per array: 30 % of a free body's step); the kicks of models other than uniform gravity
    are regular calls that borrow it."""
    wide_vectors()
    ns = kinds.shape[0]
    last = ns - 1
    models = mcode != TORQUE_GRAVITY
    for s in range(s0, s1):
        until_save -= 1
        save_now = until_save == 0 or (final and s == n_steps - 1)
        t = t0 + (step0 + s) * h
        j0 = 0
        if pending:
            j0 = 1
            t += clock[0] * h
        for j in range(j0, last):
            if models and kinds[j] == KICK:
                _model_kick_block(buf, mc, par, j, nb, t, coefs[j] * h)
            else:
                _apply(family, kinds[j], axes[j], fast[j], buf, par, j, nb, coefs[j] * h)
            t += clock[j] * h
        if ns > 1 and merge_ends and not save_now:
            tau = (coefs[last] + coefs[0]) * h
            pending = True
        else:
            tau = coefs[last] * h
            pending = False
        if models and kinds[last] == KICK:
            _model_kick_block(buf, mc, par, last, nb, t, tau)
        else:
            _apply(family, kinds[last], axes[last], fast[last], buf, par, last, nb, tau)
        if diag:
            _diagnose_block(buf, nb, mc, t0 + (step0 + s + 1) * h)
    return pending, until_save


@jit
def _copy_rows(buf, src, dst, rows, nb):
    wide_vectors()
    for r in range(rows):
        a = (src + r) * BLOCK
        b = (dst + r) * BLOCK
        for i in range(nb):
            buf[b + i] = buf[a + i]


@jit
def _constant_turns(buf, par, j, nb, tau, axis):
    """The sine and cosine of a recurring rotation's turn at the chunk's start, for its
    CONSTANT kernel: ``(s2, cm2, s, cm)`` into ``par[j, 1..4]``, the numbers the
    recurring kernel computes at every step (the same expressions)."""
    wide_vectors()
    ht = 0.5 * tau
    oa = M10 if axis == 0 else (M20 if axis == 1 else M30)
    for i in range(nb):
        s2, c2, cm2 = sincos_small(ht * par[j, 0, i] * buf[oa + i])
        par[j, 1, i], par[j, 2, i] = s2, cm2
        par[j, 3, i], par[j, 4, i] = 2.0 * s2 * c2, -2.0 * s2 * s2


@jit
def _keeps_component(kinds, axes, par, nb, mcode, j):
    """Whether every stage but ``j`` keeps ``m_k``, ``k = axes[j]``, exactly: sphere
    rotations, rotations about ``k``, and uniform-gravity kicks whose weight arm has no
    component off ``k`` in any body of the block (their torque's ``k`` component is
    ``g_i c_j - g_j c_i = 0``)."""
    k = axes[j]
    for i in range(kinds.shape[0]):
        if i == j or kinds[i] == SPHERE:
            continue
        if (kinds[i] == AXIS or kinds[i] == AXIS_RECURRING) and axes[i] == k:
            continue
        if kinds[i] != KICK or mcode != TORQUE_GRAVITY:
            return False
        for b in range(nb):
            if par[i, (k + 1) % 3, b] != 0.0 or par[i, (k + 2) % 3, b] != 0.0:
                return False
    return True


@jit
def _fast_flags(kinds, axes, coefs, par, merge_ends, h, buf, nb, alive, steps, fast, mcode):
    """Per stage, whether every half angle stays below :data:`FAST_LIMIT` for ``steps``
    steps: ``|half| <= |tau| |rate| |m| / 2`` with ``|m|`` kept by the rotations and
    grown by at most ``sum |tau_kick| B |q|^2`` per step by the kicks, ``B`` the model's
    torque bound (``dispatch.torque_bound``; inf for a user torque: never fast)."""
    wide_vectors()
    ns = kinds.shape[0]
    kick_h = 0.0
    for j in range(ns):
        if kinds[j] == KICK:
            kick_h += abs(coefs[j]) * abs(h)
    for i in range(nb):
        m1, m2, m3 = buf[M10 + i], buf[M20 + i], buf[M30 + i]
        bound = math.sqrt(m1 * m1 + m2 * m2 + m3 * m3)
        if kick_h > 0.0:
            w, x, y, z = buf[W0 + i], buf[X0 + i], buf[Y0 + i], buf[Z0 + i]
            q2 = w * w + x * x + y * y + z * z
            cmax = 0.0
            for j in range(ns):
                if kinds[j] == KICK:
                    cmax = max(cmax, par[j, 3, i])  # the model's torque bound
            bound += steps * kick_h * cmax * q2 * 1.001
        buf[R_BOUND * BLOCK + i] = bound * (1.0 + 1e-6) if alive[i] else 0.0
    last = ns - 1
    for j in range(ns):
        fast[j] = 0
        if kinds[j] == KICK or kinds[j] == DMV:
            continue
        tau = abs(coefs[j]) * abs(h)
        if merge_ends and ns > 1 and (j == 0 or j == last):
            tau = max(tau, abs(coefs[0] + coefs[last]) * abs(h))
        worst = 0.0
        for i in range(nb):
            v = abs(par[j, 0, i]) * buf[R_BOUND * BLOCK + i]
            worst = v if v > worst else worst
        worst = worst if worst == worst else math.inf  # NaN (0 * inf too): not fast
        half = 0.5 * tau * worst
        fast[j] = FAST if half <= FAST_LIMIT else 0
        if (kinds[j] == AXIS_RECURRING or kinds[j] == SPHERE) and not half < PROJECT_HALF:
            fast[j] |= PROJECT
        # a recurring rotation inside the step (an end stage's time changes when merged)
        # whose angle no other stage changes: its turn computed once for the chunk
        if (kinds[j] == AXIS_RECURRING and fast[j] & FAST
                and not (merge_ends and ns > 1 and (j == 0 or j == last))
                and _keeps_component(kinds, axes, par, nb, mcode, j)):
            fast[j] |= CONSTANT
            _constant_turns(buf, par, j, nb, coefs[j] * h, axes[j])


# ------------------------------------------------------------------ the drivers
@jit(inline="always")
def _gather(kinds, params, slots, mpar, ms, idx, nb, par):
    """The block's stage parameters into ``par`` ``(stages, N_SLOTS, BLOCK)`` (a kick's from
    the model's parameter rows ``mpar``, shared or per body, and its shared block ``ms``:
    the model's ``dispatch.block_constants`` and torque bound)."""
    shared = mpar.shape[0] == 1
    pshared = params.shape[0] == 1
    for j in range(kinds.shape[0]):
        k = kinds[j]
        for b in range(nb):
            row = params[0 if pshared else idx[b], slots[j]]
            mrow = mpar[0] if shared else mpar[idx[b]]
            if k == DMV:
                I1, I2, I3 = row[P_I1], row[P_I2], row[P_I3]
                par[j, 0, b], par[j, 1, b], par[j, 2, b] = I1, I2, I3
                par[j, 3, b] = (I2 - I3) / I1
                par[j, 4, b] = (I3 - I1) / I2
                par[j, 5, b] = (I1 - I2) / I3
            elif k == KICK:
                code = int(row[P_TORQUE])
                c1, c2, c3 = dispatch.block_constants(code, mrow)
                par[j, 0, b], par[j, 1, b], par[j, 2, b] = c1, c2, c3
                par[j, 3, b] = dispatch.torque_bound(code, mrow, ms)
            else:
                par[j, 0, b] = row[P_RATE]


@jit
def _run_block(family, diag, kinds, axes, coefs, clock, params, slots, merge_ends, h, t0,
               step0, n_steps, save_every, final, state, ctl, q_out, m_out, saved, done,
               status, torque_addr, mpar, ms, dref, dmax, idx, nb, buf, par, fast, alive):
    """Run ``n_steps`` steps of the ``nb`` bodies ``idx[:nb]`` (same ``ctl``).

    ``family`` and ``diag`` are run-time values here (the drivers pass them as plain
    ``int64``/``bool_``, not literals): this function is compiled once for every SIMD
    driver (about 19 s with an empty cache, then about 1.5 s for each further driver,
    29 s for all eight) instead of once per driver (about 9 s each, 75 s); the stage
    dispatch per block and stage that this costs is not measurable."""
    wide_vectors()
    for b in range(nb):
        i = idx[b]
        for r in range(7):
            buf[r * BLOCK + b] = state[i, r]
        buf[FAIL0 + b] = 0.0
        alive[b] = True
        if diag:
            for r in range(3):
                buf[(R_D + r) * BLOCK + b] = dmax[i, r]
            for r in range(10):
                buf[(R_DREF + r) * BLOCK + b] = dref[i, r]
            # the potential's constants: uniform gravity's weight arm, the one model here
            gravity = int(dref[i, 3]) == TORQUE_GRAVITY
            mrow = mpar[0] if mpar.shape[0] == 1 else mpar[i]
            for r in range(3):
                buf[(R_DREF + 3 + r) * BLOCK + b] = mrow[r] if gravity else 0.0
    _gather(kinds, params, slots, mpar, ms, idx, nb, par)
    # the model context of the kicks and diagnostics: (kick model code, potential code of
    # the diagnostics, user callback address, model rows, stage rows, body indices,
    # scratch for the time-only part of the torque, the block's torques and work rows,
    # a user torque's controls and parameter rows per body, the model's shared block, the
    # stages' rows of params)
    mcode = 0
    for j in range(kinds.shape[0]):
        if kinds[j] == KICK:
            mcode = int(params[0 if params.shape[0] == 1 else idx[0], slots[j], P_TORQUE])
    dcode = int(dref[idx[0], 3]) if diag else 0
    scratch = np.empty(dispatch.scratch_size(mcode, ms))
    mc = (mcode, dcode, torque_addr, mpar, params, idx, scratch, np.empty((6, BLOCK)),
          np.zeros((BLOCK, N_CONTROLS)), np.zeros(BLOCK, dtype=np.int64), ms, slots)
    until_save = ctl[idx[0], 0]
    pending = ctl[idx[0], 1] != 0
    n_saved = 0
    n_alive = nb
    step = 0
    while step < n_steps and n_alive > 0:
        t = min(CHUNK, n_steps - step)
        if until_save >= 1:
            t = min(t, until_save)
        for b in range(nb):  # the lanes of failed bodies carry a harmless state
            if not alive[b]:
                buf[W0 + b], buf[X0 + b], buf[Y0 + b], buf[Z0 + b] = 1.0, 0.0, 0.0, 0.0
                buf[M10 + b], buf[M20 + b], buf[M30 + b] = 0.0, 0.0, 0.0
            buf[FAIL0 + b] = 0.0
        if family != F_DMV and family != F_DMV_FREE:
            _fast_flags(kinds, axes, coefs, par, merge_ends, h, buf, nb, alive, t, fast,
                        mcode)
        _copy_rows(buf, R_W, R_CK, 7, nb)
        if diag:
            _copy_rows(buf, R_D, R_DCK, 3, nb)
        u0, p0 = until_save, pending
        pending, until_save = _steps(family, diag, kinds, axes, coefs, clock, par, fast,
                                     merge_ends, h, t0, step0, n_steps, final, buf, nb,
                                     pending, until_save, step, step + t, mcode, mc)
        suspect = False
        for b in range(nb):
            if alive[b]:
                size = (abs(buf[W0 + b]) + abs(buf[X0 + b]) + abs(buf[Y0 + b])
                        + abs(buf[Z0 + b]) + abs(buf[M10 + b]) + abs(buf[M20 + b])
                        + abs(buf[M30 + b]))
                if buf[FAIL0 + b] != 0.0 or not (size < 1e300):
                    suspect = True
        if suspect:  # again from the checkpoint, one step at a time
            _copy_rows(buf, R_CK, R_W, 7, nb)
            if diag:
                _copy_rows(buf, R_DCK, R_D, 3, nb)
            until_save, pending = u0, p0
            for b in range(nb):
                buf[FAIL0 + b] = 0.0
            for s in range(step, step + t):
                _copy_rows(buf, R_W, R_SK, 7, nb)
                if diag:
                    _copy_rows(buf, R_D, R_DSK, 3, nb)
                pending, until_save = _steps(family, diag, kinds, axes, coefs, clock, par,
                                             fast, merge_ends, h, t0, step0, n_steps, final,
                                             buf, nb, pending, until_save, s, s + 1, mcode,
                                             mc)
                for b in range(nb):
                    if not alive[b]:
                        continue
                    code = int(buf[FAIL0 + b])
                    if code == STATUS_OK:
                        acc = (buf[W0 + b] + buf[X0 + b] + buf[Y0 + b] + buf[Z0 + b]
                               + buf[M10 + b] + buf[M20 + b] + buf[M30 + b])
                        if not (abs(acc) < 1e308):
                            code = STATUS_NONFINITE
                    if code != STATUS_OK:
                        i = idx[b]
                        for r in range(7):
                            state[i, r] = buf[(R_SK + r) * BLOCK + b]
                        if diag:
                            for r in range(3):
                                dmax[i, r] = buf[(R_DSK + r) * BLOCK + b]
                        status[i] = code
                        done[i] += s
                        saved[i] += n_saved
                        alive[b] = False
                        n_alive -= 1
                        buf[W0 + b], buf[X0 + b] = 1.0, 0.0
                        buf[Y0 + b], buf[Z0 + b] = 0.0, 0.0
                        buf[M10 + b], buf[M20 + b], buf[M30 + b] = 0.0, 0.0, 0.0
                    buf[FAIL0 + b] = 0.0
        step += t
        if until_save == 0 or (final and step == n_steps):
            until_save = save_every
            for b in range(nb):
                if alive[b]:
                    i = idx[b]
                    row = saved[i] + n_saved
                    q_out[i, row, 0], q_out[i, row, 1] = buf[W0 + b], buf[X0 + b]
                    q_out[i, row, 2], q_out[i, row, 3] = buf[Y0 + b], buf[Z0 + b]
                    m_out[i, row, 0], m_out[i, row, 1] = buf[M10 + b], buf[M20 + b]
                    m_out[i, row, 2] = buf[M30 + b]
            n_saved += 1
    for b in range(nb):
        if alive[b]:
            i = idx[b]
            for r in range(7):
                state[i, r] = buf[r * BLOCK + b]
            if diag:
                for r in range(3):
                    dmax[i, r] = buf[(R_D + r) * BLOCK + b]
            ctl[i, 0] = until_save
            ctl[i, 1] = 1 if pending else 0
            done[i] += n_steps
            saved[i] += n_saved


def _simd_runner(family: int, diag: bool = False):
    """The SIMD driver of one family for many bodies (``family``, ``diag``: compile-time
    constants); the signature and semantics of ``batch_drivers.BATCH_RUNNERS[family]``."""

    @jit(tag=family_tag(family, diag))
    def run(kinds, axes, coefs, clock, params, slots, merge_ends, h, t0, step0, n_steps,
            save_every, final, state, ctl, q_out, m_out, saved, done, status, torque_addr,
            mpar, ms, dref, dmax, model=(0,)):
        # (``model``, the one-body drivers' model token, is not used: the block kernels
        # are compiled once for every model)
        ns = kinds.shape[0]
        n = state.shape[0]
        bad = ns == 0 or slots.shape[0] != ns
        for j in range(ns):
            k = kinds[j]
            if (k < 0 or k >= SIMD_MEMBERS.shape[1] or not SIMD_MEMBERS[family, k]
                    or slots[j] < 0 or slots[j] >= params.shape[1]):
                bad = True
        for i in range(n):  # bodies whose plan this driver cannot run
            if status[i] != STATUS_OK:
                continue
            if bad:
                status[i] = STATUS_BAD_STAGE
                continue
            for j in range(ns):  # a kick of no model, or an unknown one
                code = params[0 if params.shape[0] == 1 else i, slots[j], P_TORQUE]
                if kinds[j] == KICK and not (0 < code <= MAX_MODEL_CODE):
                    status[i] = STATUS_BAD_STAGE
        if bad or n_steps <= 0:
            return 0
        buf = np.zeros(N_ROWS * BLOCK)
        par = np.zeros((ns, N_SLOTS, BLOCK))
        idx = np.empty(BLOCK, dtype=np.int64)
        alive = np.zeros(BLOCK, dtype=np.bool_)
        fast = np.zeros(ns, dtype=np.int64)
        i = 0
        while i < n:
            nb = 0
            u0 = 0
            p0 = 0
            while i < n and nb < BLOCK:
                if status[i] != STATUS_OK:
                    i += 1
                    continue
                if nb == 0:
                    u0, p0 = ctl[i, 0], ctl[i, 1]
                elif ctl[i, 0] != u0 or ctl[i, 1] != p0:
                    break
                idx[nb] = i
                nb += 1
                i += 1
            if nb > 0:  # family, diag as plain values: one compilation for all drivers
                _run_block(np.int64(family), np.bool_(diag), kinds, axes, coefs, clock,
                           params, slots, merge_ends, h, t0, step0, n_steps, save_every, final,
                           state, ctl, q_out, m_out, saved, done, status, torque_addr, mpar,
                           ms, dref, dmax, idx, nb, buf, par, fast, alive)
        return 0

    return run


#: ``(family, diag)`` -> the SIMD driver for many bodies (compiled on first call, cached)
SIMD_RUNNERS = {(family, diag): _simd_runner(family, diag)
                for family in SIMD_FAMILIES for diag in (False, True)}
