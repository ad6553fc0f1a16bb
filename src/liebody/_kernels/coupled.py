"""The driver of coupled bodies: collective kicks between the bodies' free flows.

A method of a torqued scene is a sequence ``K(c_0 h) F_1 K(c_1 h) F_2 ... K(c_S h)`` of
kicks and free-flow segments (``liebody._plan``). For ``N`` coupled bodies a kick is the
exact flow of the potential ``V(t, q_1, ..., q_N)`` with every ``q`` fixed: one call of
the user's collective torque for all bodies (a C callback, :data:`COUPLED_SIG`), then
``L_i += tau N_i``. A segment is each body's own free flow, run on blocks of bodies by the
SIMD kernels of :mod:`liebody._kernels.batch` (axis and sphere rotations; the exact flow
body by body). Bodies whose free flows differ in structure (their axis ordering) form
groups; a block holds bodies of one group, and the kicks, shared by all, must fall at the
same times in every group's table (the Python side checks it).
"""

from __future__ import annotations

import math

from numba import config, types

from liebody._kernels._jit import jit
from liebody._kernels.batch import (
    BLOCK,
    FAST,
    FAST_LIMIT,
    M10,
    M20,
    M30,
    PROJECT,
    W0,
    X0,
    Y0,
    Z0,
    _apply,
)
from liebody._kernels.exact import exact_flow
from liebody._kernels.flows import dmv_step
from liebody._kernels.stages import (
    AXIS,
    DMV,
    EXACT,
    F_ROTATIONS,
    STATUS_NO_CONVERGENCE,
    STATUS_OK,
    STATUS_TORQUE,
)

#: rows of a block buffer the free flows use: w, x, y, z, m1, m2, m3
ROWS = 7
#: an empty rotation slot of a segment
NOOP = -1

#: ``torque(t, q, L, params, out, n, k)``: the collective torque of ``n`` bodies, ``q``
#: ``(n, 4)``, ``L`` ``(n, 3)``, ``params`` ``(n, k)`` and ``out`` ``(n, 3)`` as pointers
#: to C-contiguous float64 data
COUPLED_SIG = types.void(types.float64, types.CPointer(types.float64),
                         types.CPointer(types.float64), types.CPointer(types.float64),
                         types.CPointer(types.float64), types.intp, types.intp)

#: address -> adapter (kept alive while the driver may call it; the uncompiled kernels
#: call the Python function by its id)
_ADAPTERS: dict = {}
#: id(user torque) -> (the torque, its callback's address): compiled once per torque
_BY_TORQUE: dict = {}


def adapt_coupled_torque(user) -> int:
    """Wrap a user ``@njit`` torque ``torque(t, q, L, params, out)`` (writing every body's
    body-frame torque into ``out`` ``(N, 3)``) as a :data:`COUPLED_SIG` callback; returns
    its address. A callback cannot raise: a torque that raises fills ``out`` with NaN,
    so the driver stops at that step and the Python side calls the torque again to
    raise its error."""
    kept = _BY_TORQUE.get(id(user))
    if kept is not None and kept[0] is user:
        return kept[1]  # (one callback per torque: scenes that share it share it)
    import numpy as np

    def evaluate(t, q, L, p, out):
        try:
            user(t, q, L, p, out)
        except Exception:
            out[:] = np.nan

    if config.DISABLE_JIT:
        _ADAPTERS[id(evaluate)] = evaluate
        _BY_TORQUE[id(user)] = (user, id(evaluate))
        return id(evaluate)

    from numba import carray, cfunc, njit

    inner = njit(evaluate)  # (uncached, as the callback: the user's function is new)

    def body(t, qp, lp, pp, op, n, k):
        inner(t, carray(qp, (n, 4)), carray(lp, (n, 3)), carray(pp, (n, k)),
              carray(op, (n, 3)))

    adapter = cfunc(COUPLED_SIG)(body)
    _ADAPTERS[adapter.address] = adapter
    _BY_TORQUE[id(user)] = (user, adapter.address)
    return adapter.address


def _call_py(addr, t, q, L, p, out):
    _ADAPTERS[addr](t, q, L, p, out)


def _call_intrinsic():
    from llvmlite import ir
    from numba.core import cgutils
    from numba.extending import intrinsic

    @intrinsic
    def call_coupled(typingctx, addr, t, q, L, p, out):
        """Call the :data:`COUPLED_SIG` callback at ``addr`` with the arrays' data."""
        sig = types.void(addr, t, q, L, p, out)

        def codegen(context, builder, signature, args):
            fnty = ir.FunctionType(ir.VoidType(),
                                   [context.get_value_type(a) for a in COUPLED_SIG.args])
            fptr = builder.inttoptr(args[0], fnty.as_pointer())
            arrays = [context.make_array(signature.args[i])(context, builder, args[i])
                      for i in (2, 3, 4, 5)]
            n, k = cgutils.unpack_tuple(builder, arrays[2].shape, 2)
            builder.call(fptr, [args[1], arrays[0].data, arrays[1].data, arrays[2].data,
                                arrays[3].data, n, k])
            return context.get_dummy_value()

        return sig, codegen

    return call_coupled


#: ``call_coupled(addr, t, q, L, params, out)``: the collective torque at ``addr``
call_coupled = _call_py if config.DISABLE_JIT else _call_intrinsic()


@jit
def _kick(bufs, blk_idx, blk_n, Q, Lm, out, params, addr, t, tau, lmax):
    """``L_i += tau N_i(t, q_1..q_N)`` for every body, ``q`` fixed (the torque sees the unit
    quaternions ``q / |q|`` and ``out`` cleared to zeros); returns the first body whose
    torque (or kicked ``L``) is not finite, -1 for none; ``lmax[b]``: the largest ``|L|``
    of block ``b`` after the kick."""
    for b in range(bufs.shape[0]):
        buf = bufs[b]
        for i in range(blk_n[b]):
            k = blk_idx[b, i]
            w, x, y, z = buf[W0 + i], buf[X0 + i], buf[Y0 + i], buf[Z0 + i]
            # the rotation the state stands for: a torque that rotates by q / |q| keeps
            # the cancellation of a rotation-invariant potential's net torque (|q| off 1
            # by rounding would scale each body's torque differently)
            n = math.sqrt(w * w + x * x + y * y + z * z)
            Q[k, 0], Q[k, 1], Q[k, 2], Q[k, 3] = w / n, x / n, y / n, z / n
            Lm[k, 0], Lm[k, 1], Lm[k, 2] = buf[M10 + i], buf[M20 + i], buf[M30 + i]
            out[k, 0] = out[k, 1] = out[k, 2] = 0.0  # (a torque may accumulate: out += ...)
    call_coupled(addr, t, Q, Lm, params, out)
    bad = -1
    for b in range(bufs.shape[0]):
        buf = bufs[b]
        big = 0.0
        for i in range(blk_n[b]):
            k = blk_idx[b, i]
            m1 = buf[M10 + i] + tau * out[k, 0]
            m2 = buf[M20 + i] + tau * out[k, 1]
            m3 = buf[M30 + i] + tau * out[k, 2]
            size = abs(out[k, 0]) + abs(out[k, 1]) + abs(out[k, 2]) + abs(m1) + abs(m2) \
                + abs(m3)
            if not size < math.inf and (bad < 0 or k < bad):
                bad = k
            buf[M10 + i], buf[M20 + i], buf[M30 + i] = m1, m2, m3
            m2s = m1 * m1 + m2 * m2 + m3 * m3
            big = m2s if m2s > big else big
        lmax[b] = math.sqrt(big)  # (the free flows keep |L|: a bound until the next kick)
    return bad


@jit
def _rotate(buf, kind, axis, par, j, nb, tau, moments, idx, fast):
    """One free-flow stage of a block: the rotations through the SIMD ensembles' stage
    (``batch._apply``; ``par[j, 0]`` the rates, without range reduction where ``fast``: every
    half angle below ``batch.FAST_LIMIT``); the exact flow and the discrete Moser-Veselov
    step (RATTLE's free part) body by body. Returns the first body whose implicit DMV
    equation was not solved, -1 for none."""
    if kind == EXACT:
        for i in range(nb):
            k = idx[i]
            r = exact_flow(moments[k, 0], moments[k, 1], moments[k, 2], buf[W0 + i],
                           buf[X0 + i], buf[Y0 + i], buf[Z0 + i], buf[M10 + i], buf[M20 + i],
                           buf[M30 + i], tau)
            buf[W0 + i], buf[X0 + i], buf[Y0 + i], buf[Z0 + i] = r[0], r[1], r[2], r[3]
            buf[M10 + i], buf[M20 + i], buf[M30 + i] = r[4], r[5], r[6]
    elif kind == DMV:
        for i in range(nb):
            k = idx[i]
            r = dmv_step(buf[W0 + i], buf[X0 + i], buf[Y0 + i], buf[Z0 + i], buf[M10 + i],
                         buf[M20 + i], buf[M30 + i], moments[k, 0], moments[k, 1],
                         moments[k, 2], tau)
            if r[7] < 0:
                return k
            buf[W0 + i], buf[X0 + i], buf[Y0 + i], buf[Z0 + i] = r[0], r[1], r[2], r[3]
            buf[M10 + i], buf[M20 + i], buf[M30 + i] = r[4], r[5], r[6]
    else:  # a recurring rotation puts q back on the unit sphere after a large turn
        flags = (FAST if fast else 0) | (0 if kind == AXIS else PROJECT)
        _apply(F_ROTATIONS, kind, axis, flags, buf, par, j, nb, tau)
    return -1


@jit
def save(bufs, blk_idx, blk_n, q_out, m_out, row):
    """Every body's state into sample ``row`` of ``q_out`` ``(N, S, 4)``, ``m_out``."""
    for b in range(bufs.shape[0]):
        buf = bufs[b]
        for i in range(blk_n[b]):
            k = blk_idx[b, i]
            q_out[k, row, 0], q_out[k, row, 1] = buf[W0 + i], buf[X0 + i]
            q_out[k, row, 2], q_out[k, row, 3] = buf[Y0 + i], buf[Z0 + i]
            m_out[k, row, 0], m_out[k, row, 1] = buf[M10 + i], buf[M20 + i]
            m_out[k, row, 2] = buf[M30 + i]


@jit
def run(kc, kt, rk, ra, rc, blk_group, blk_idx, blk_n, rates, rmax, moments, merge_ends, h,
        t0, step0, n_steps, save_every, final, bufs, ctl, Q, Lm, out, params, addr, q_out,
        m_out, row0, lmax):
    """Advance the coupled bodies by ``n_steps`` steps of size ``h``.

    ``kc``, ``kt`` ``(S + 1,)``: the kicks' fractions of the step and their times within
    it (fractions of ``h``); ``rk``, ``ra``, ``rc`` ``(G, S, R)``: each group's free-flow
    stages of segment ``s`` (kind or :data:`NOOP`, axis, fraction of the step);
    ``blk_group`` ``(B,)``, ``blk_idx`` ``(B, BLOCK)``, ``blk_n`` ``(B,)``: each block's
    group, bodies and count; ``rates`` ``(B, S, R, 1, BLOCK)``: each stage's rate per body,
    ``rmax`` ``(B, S, R)`` its largest ``|rate|`` over the block; ``lmax`` ``(B,)``: work
    (each block's largest ``|L|``, set by every kick; start it with the initial one);
    ``moments`` ``(N, 3)`` (the exact flow); ``bufs`` ``(B, ROWS * BLOCK)``: the state
    (updated in place); ``ctl`` ``(3,)``: steps left until the next save and whether the
    first kick of the next step was merged into this one's last (in place, across
    slices), and where a run stops, the kick (or the segment) that failed; ``Q``, ``Lm``,
    ``out``: work arrays ``(N, 4)``, ``(N, 3)``, ``(N, 3)`` (after a failing kick, the
    ``q / |q|`` and ``L`` its torque was called with);
    ``params`` ``(N, k)``; ``addr`` the torque callback. Saved samples go to rows
    ``row0, row0 + 1, ...`` of ``q_out`` / ``m_out``.

    Returns ``(steps_done, n_saved, status, body)``: at a torque that is not finite
    (``STATUS_TORQUE``) or a DMV equation not solved (``STATUS_NO_CONVERGENCE``) the run
    stops in that step, ``body`` the first such body (the saved samples before it are
    good).
    """
    S = kc.shape[0] - 1
    R = rk.shape[2]
    until_save = ctl[0]
    pending = ctl[1] != 0
    n_saved = 0
    for step in range(n_steps):
        t = t0 + (step0 + step) * h
        until_save -= 1
        save_now = until_save == 0 or (final and step == n_steps - 1)
        merge = merge_ends and not save_now
        for s in range(S + 1):
            if not (s == 0 and pending):
                tau = kc[s] * h
                if s == S and merge:
                    tau = (kc[S] + kc[0]) * h
                bad = _kick(bufs, blk_idx, blk_n, Q, Lm, out, params, addr, t + kt[s] * h,
                            tau, lmax)
                if bad >= 0:
                    ctl[2] = s
                    return step, n_saved, STATUS_TORQUE, bad
            if s < S:
                for b in range(bufs.shape[0]):
                    g = blk_group[b]
                    for r in range(R):
                        kind = rk[g, s, r]
                        if kind == NOOP:
                            break
                        tau = rc[g, s, r] * h
                        half = 0.5 * abs(tau) * rmax[b, s, r] * lmax[b]
                        bad = _rotate(bufs[b], kind, ra[g, s, r], rates[b, s], r, blk_n[b],
                                      tau, moments, blk_idx[b],
                                      half * (1.0 + 1e-6) <= FAST_LIMIT)
                        if bad >= 0:
                            ctl[2] = s
                            return step, n_saved, STATUS_NO_CONVERGENCE, bad
        pending = merge
        if save_now:
            until_save = save_every
            save(bufs, blk_idx, blk_n, q_out, m_out, row0 + n_saved)
            n_saved += 1
    ctl[0] = until_save
    ctl[1] = 1 if pending else 0
    return n_steps, n_saved, STATUS_OK, -1


#: bodies per block (the SIMD kernels' block)
__all__ = ["BLOCK", "COUPLED_SIG", "NOOP", "ROWS", "adapt_coupled_torque", "run"]
