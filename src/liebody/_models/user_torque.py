"""A user's compiled torque ``torque(t, q, L[, p][, u])``.

The user's ``@njit`` function is wrapped in a C callback of the fixed signature
:data:`TORQUE_SIG` ``(t, w, x, y, z, m1, m2, m3, u0, ..., u5, p, k) -> (tau1, tau2, tau3)``
(body frame; ``u`` the control inputs, held constant over a step; ``p`` a pointer to the
body's ``k`` parameters, the model's parameter block), passed to the drivers as its
address, a plain integer, and called through :func:`call_torque`. So the drivers are
compiled once and cached whatever the user's function is, and a call passes an integer
instead of a first-class function object (which numba would type and unbox, at several
microseconds, on every call). The potential of a user torque is a Python function,
which the kernels cannot call: :func:`potential` is NaN.
"""

from __future__ import annotations

import math

from numba import cfunc, config, types

from liebody._kernels._jit import jit
from liebody._kernels.stages import N_CONTROLS, P_U0, TORQUE_USER

CODE = TORQUE_USER
#: whether the torque may depend on the momentum (a user's may: implicit kicks)
MOMENTUM = True

TORQUE_SIG = types.UniTuple(types.float64, 3)(
    *([types.float64] * (8 + N_CONTROLS)), types.CPointer(types.float64), types.intp)

#: the type of a body's parameter row ``p`` as the user's torque receives it: read-only (it
#: is the run's, shared by its bodies and kept by the scene)
ROW = types.Array(types.float64, 1, "C", readonly=True)

#: address -> adapter, for the uncompiled kernels (NUMBA_DISABLE_JIT=1) and to keep
#: every adapter alive for as long as the drivers may call its address
_ADAPTERS: dict = {}


def adapt_user_torque(user, controls: int = 0, params: bool = False):
    """Wrap a user ``@njit`` torque as a :data:`TORQUE_SIG` callback; returns its address.

    The user's signature is ``torque(t, q, L)``, ``torque(t, q, L, p)`` with ``params``,
    and with ``controls = k`` (1 to ``N_CONTROLS``) the first ``k`` control inputs ``u``
    last: ``torque(t, q, L, u)`` or ``torque(t, q, L, p, u)``. The wrapper builds the
    ``q``, ``L`` (and ``u``) arrays for each call (small allocations per torque
    evaluation, the price of the friendly signature; ``p`` is the body's parameter row,
    read-only: a torque that writes to it does not compile). A callback cannot raise, so
    a torque that raises, or returns anything but three numbers, yields NaN: the driver
    stops at that step (``STATUS_TORQUE``) and the Python side calls the torque again to
    raise its error.
    The adapter is kept for the life of the process (its address is what the drivers
    call).
    """
    import numpy as np
    from numba import carray

    if not 0 <= controls <= N_CONTROLS:
        raise ValueError(f"controls must be 0 to {N_CONTROLS}, got {controls}")

    def evaluate(t, w, x, y, z, m1, m2, m3, u0, u1, u2, u3, u4, u5, p):
        q = np.empty(4)
        q[0], q[1], q[2], q[3] = w, x, y, z
        L = np.empty(3)
        L[0], L[1], L[2] = m1, m2, m3
        try:
            if controls:
                u = np.empty(controls)
                every = (u0, u1, u2, u3, u4, u5)
                for i in range(controls):
                    u[i] = every[i]
                tau = np.asarray(user(t, q, L, p, u) if params else user(t, q, L, u),
                                 dtype=np.float64)
            else:
                tau = np.asarray(user(t, q, L, p) if params else user(t, q, L),
                                 dtype=np.float64)
        except Exception:
            return math.nan, math.nan, math.nan
        if tau.ndim != 1 or tau.shape[0] != 3:
            return math.nan, math.nan, math.nan
        return tau[0], tau[1], tau[2]

    if config.DISABLE_JIT:  # the uncompiled kernels call the Python function by its id
        _ADAPTERS[id(evaluate)] = evaluate
        return id(evaluate)

    from numba import njit

    # (uncached, as the callback: the user's function is new; ``p`` typed read-only, so
    # that a torque writing to the run's parameters does not compile)
    inner = njit(TORQUE_SIG.return_type(*TORQUE_SIG.args[:-2], ROW))(evaluate)

    def body(t, w, x, y, z, m1, m2, m3, u0, u1, u2, u3, u4, u5, pp, k):
        return inner(t, w, x, y, z, m1, m2, m3, u0, u1, u2, u3, u4, u5, carray(pp, (k,)))

    adapter = cfunc(TORQUE_SIG)(body)
    _ADAPTERS[adapter.address] = adapter
    return adapter.address


#: ``block(t, nb, state, n_state, w0, x0, y0, z0, a0, b0, c0, U, P, n_rows, k, rows, out,
#: out_stride)``: the torque of ``nb`` bodies at once (the SIMD drivers), each body's state
#: at ``state[w0 + b]`` .. ``state[c0 + b]``, its controls ``U[b, :]`` (``(nb,
#: N_CONTROLS)``), its parameters ``P[rows[b]]`` (``(n_rows, k)``), its torque into
#: ``out[0..2, b]`` (``(3, out_stride)``)
BLOCK_SIG = types.void(types.float64, types.intp, types.CPointer(types.float64), types.intp,
                       *([types.intp] * 7), types.CPointer(types.float64),
                       types.CPointer(types.float64), types.intp, types.intp,
                       types.CPointer(types.int64), types.CPointer(types.float64), types.intp)


def adapt_user_block(user, controls: int = 0, params: bool = False) -> int:
    """Wrap a user ``@njit`` torque as a :data:`BLOCK_SIG` callback for many bodies at once;
    returns its address (the SIMD drivers call it once per kick and block of bodies).

    The user's function is called for each body with the same ``q``, ``L`` (and ``u``)
    arrays, refilled (no allocation of the wrapper's per body; a torque that returns a
    tuple of three numbers allocates nothing at all, one that returns an array
    allocates it). A body whose torque raises, or does not give three numbers, gets NaN.
    """
    import numpy as np
    from numba import carray

    if not 0 <= controls <= N_CONTROLS:
        raise ValueError(f"controls must be 0 to {N_CONTROLS}, got {controls}")
    width = max(controls, 1)

    def evaluate(t, nb, st, w0, x0, y0, z0, a0, b0, c0, U, P, rows, out):
        q = np.empty(4)
        L = np.empty(3)
        u = np.empty(width)
        for b in range(nb):
            q[0], q[1], q[2], q[3] = st[w0 + b], st[x0 + b], st[y0 + b], st[z0 + b]
            L[0], L[1], L[2] = st[a0 + b], st[b0 + b], st[c0 + b]
            for i in range(controls):
                u[i] = U[b, i]
            t1 = t2 = t3 = math.nan
            try:
                if controls:
                    tau = user(t, q, L, P[rows[b]], u[:controls]) if params else user(
                        t, q, L, u[:controls])
                else:
                    tau = user(t, q, L, P[rows[b]]) if params else user(t, q, L)
                if len(tau) == 3:
                    t1, t2, t3 = float(tau[0]), float(tau[1]), float(tau[2])
            except Exception:
                pass
            out[0, b], out[1, b], out[2, b] = t1, t2, t3

    if config.DISABLE_JIT:  # the uncompiled kernels call the Python function by its id
        _ADAPTERS[id(evaluate)] = evaluate
        return id(evaluate)

    from numba import njit

    c1, c2 = types.Array(types.float64, 1, "C"), types.Array(types.float64, 2, "C")
    # (uncached, as the callback; the parameters typed read-only, as in adapt_user_torque)
    inner = njit(types.void(types.float64, types.intp, c1, *([types.intp] * 7), c2,
                            types.Array(types.float64, 2, "C", readonly=True),
                            types.Array(types.int64, 1, "C"), c2))(evaluate)

    def body(t, nb, stp, n_state, w0, x0, y0, z0, a0, b0, c0, Up, Pp, n_rows, k, rowsp, outp,
             ostride):
        inner(t, nb, carray(stp, (n_state,)), w0, x0, y0, z0, a0, b0, c0,
              carray(Up, (nb, N_CONTROLS)), carray(Pp, (n_rows, k)), carray(rowsp, (nb,)),
              carray(outp, (3, ostride)))

    adapter = cfunc(BLOCK_SIG)(body)
    _ADAPTERS[adapter.address] = adapter
    return adapter.address


def _call_block_py(addr, t, nb, st, offsets, U, P, rows, out):
    """:func:`call_block` for the uncompiled kernels: the adapter's Python function."""
    _ADAPTERS[addr](t, nb, st, *offsets, U, P, rows, out)


def _call_block_intrinsic():
    from llvmlite import ir
    from numba.core import cgutils
    from numba.extending import intrinsic

    @intrinsic
    def call_block_raw(typingctx, addr, t, nb, st, offsets, U, P, rows, out):
        """Call the :data:`BLOCK_SIG` callback at ``addr`` with the arrays' data pointers
        and shapes (``offsets``: a tuple of the seven state rows' offsets)."""
        sig = types.void(addr, t, nb, st, offsets, U, P, rows, out)

        def codegen(context, builder, signature, args):
            fnty = ir.FunctionType(ir.VoidType(),
                                   [context.get_value_type(a) for a in BLOCK_SIG.args])
            fptr = builder.inttoptr(args[0], fnty.as_pointer())
            st_a = context.make_array(signature.args[3])(context, builder, args[3])
            u_a = context.make_array(signature.args[5])(context, builder, args[5])
            p_a = context.make_array(signature.args[6])(context, builder, args[6])
            r_a = context.make_array(signature.args[7])(context, builder, args[7])
            o_a = context.make_array(signature.args[8])(context, builder, args[8])
            offs = cgutils.unpack_tuple(builder, args[4], 7)
            n_state = cgutils.unpack_tuple(builder, st_a.shape, 1)[0]
            n_rows, k = cgutils.unpack_tuple(builder, p_a.shape, 2)
            ostride = cgutils.unpack_tuple(builder, o_a.shape, 2)[1]
            builder.call(fptr, [args[1], args[2], st_a.data, n_state, *offs, u_a.data,
                                p_a.data, n_rows, k, r_a.data, o_a.data, ostride])
            return context.get_dummy_value()

        return sig, codegen

    return call_block_raw


#: ``call_block(addr, t, nb, state, offsets, U, P, rows, out)``: call the user torque's
#: block callback at ``addr`` (:func:`adapt_user_block`); ``state`` 1-d, ``offsets`` the
#: seven rows' offsets, ``U`` ``(nb, N_CONTROLS)``, ``P`` ``(n_rows, k)``, ``rows``
#: ``(nb,)`` int64, ``out`` ``(3, m)``, all C-contiguous
call_block = _call_block_py if config.DISABLE_JIT else _call_block_intrinsic()


def _call_torque_py(addr, t, w, x, y, z, m1, m2, m3, u0, u1, u2, u3, u4, u5, mp):
    """:func:`call_torque` for the uncompiled kernels: the adapter's Python function."""
    return _ADAPTERS[addr](t, w, x, y, z, m1, m2, m3, u0, u1, u2, u3, u4, u5, mp)


def _call_torque_intrinsic():
    from llvmlite import ir
    from numba.core import cgutils
    from numba.extending import intrinsic

    @intrinsic
    def call_torque(typingctx, addr, t, w, x, y, z, m1, m2, m3, u0, u1, u2, u3, u4, u5, mp):
        """Call the :data:`TORQUE_SIG` callback at the integer address ``addr`` with the
        data pointer and length of the 1-d float64 array ``mp``."""
        sig = TORQUE_SIG.return_type(types.intp, *TORQUE_SIG.args[:-2], mp)

        def codegen(context, builder, signature, args):
            fnty = ir.FunctionType(context.get_value_type(TORQUE_SIG.return_type),
                                   [context.get_value_type(a) for a in TORQUE_SIG.args])
            fptr = builder.inttoptr(args[0], fnty.as_pointer())
            ary = context.make_array(signature.args[-1])(context, builder, args[-1])
            length = cgutils.unpack_tuple(builder, ary.shape, 1)[0]
            return builder.call(fptr, [*args[1:-1], ary.data, length])

        return sig, codegen

    return call_torque


#: ``call_torque(addr, t, w, x, y, z, m1, m2, m3, u0, ..., u5, mp)``: call the user torque
#: callback whose address is ``addr`` (an adapter made by :func:`adapt_user_torque`)
call_torque = _call_torque_py if config.DISABLE_JIT else _call_torque_intrinsic()


@jit(inline="always")
def torque(t, w, x, y, z, m1, m2, m3, p, addr, mp):
    """The user torque with the stage's controls ``p[P_U0:]`` and the parameters ``mp``."""
    if addr == 0:
        return 0.0, 0.0, 0.0
    return call_torque(addr, t, w, x, y, z, m1, m2, m3, p[P_U0], p[P_U0 + 1], p[P_U0 + 2],
                       p[P_U0 + 3], p[P_U0 + 4], p[P_U0 + 5], mp)


@jit
def initial_ok(addr, t, q, m, u, mp, promise):
    """Whether the callback at ``addr`` gives three finite numbers at the state ``(t, q,
    m)`` with the controls ``u`` (0 to ``N_CONTROLS``, the rest zero) and the parameters
    ``mp`` and, with ``promise`` (an orientation-only torque), the same numbers at
    ``L = 2 m + 1``: a run's initial state checked in one compiled call, on what the
    drivers call. False says only that the Python side must look (a torque that raises,
    or gives another shape, is NaN here)."""
    n = u.shape[0]
    u0 = u[0] if n > 0 else 0.0
    u1 = u[1] if n > 1 else 0.0
    u2 = u[2] if n > 2 else 0.0
    u3 = u[3] if n > 3 else 0.0
    u4 = u[4] if n > 4 else 0.0
    u5 = u[5] if n > 5 else 0.0
    w, x, y, z, m1, m2, m3 = q[0], q[1], q[2], q[3], m[0], m[1], m[2]
    a1, a2, a3 = call_torque(addr, t, w, x, y, z, m1, m2, m3, u0, u1, u2, u3, u4, u5, mp)
    if not (math.isfinite(a1) and math.isfinite(a2) and math.isfinite(a3)):
        return False
    if not promise:
        return True
    b1, b2, b3 = call_torque(addr, t, w, x, y, z, 2.0 * m1 + 1.0, 2.0 * m2 + 1.0,
                             2.0 * m3 + 1.0, u0, u1, u2, u3, u4, u5, mp)
    return a1 == b1 and a2 == b2 and a3 == b3


def initial_ok_entry():
    """:func:`initial_ok` compiled (or loaded from the cache) for 1-d float64 arrays of any
    layout and writeability, as its entry point: called without numba's type dispatch
    (about 0.2 us less a call), it takes any such arrays (it reads them through their
    strides), and nothing else; the function itself with the JIT off."""
    if config.DISABLE_JIT:
        return initial_ok
    arr = types.Array(types.float64, 1, "A", readonly=True)
    sig = (types.intp, types.float64, arr, arr, arr, arr, types.boolean)
    initial_ok.compile(sig)
    return initial_ok.overloads[sig].entry_point


@jit
def potential(t, w, x, y, z, mp):
    """A user potential is Python: not evaluable in the kernels."""
    return math.nan


@jit
def broken_promise(addr, t, q, m, u, P):
    """The first row ``i`` of the parameters ``P`` ``(n_rows, k)`` for which the callback at
    ``addr`` breaks an ``orientation_only`` promise at ``(t, q)`` with the controls ``u``
    (``(N_CONTROLS,)``): finite torques at ``L = m`` and at ``L = 2 m + 1`` that differ;
    -1 for none (a row whose torque is not finite there is not judged)."""
    w, x, y, z, m1, m2, m3 = q[0], q[1], q[2], q[3], m[0], m[1], m[2]
    for i in range(P.shape[0]):
        a1, a2, a3 = call_torque(addr, t, w, x, y, z, m1, m2, m3, u[0], u[1], u[2], u[3],
                                 u[4], u[5], P[i])
        b1, b2, b3 = call_torque(addr, t, w, x, y, z, 2.0 * m1 + 1.0, 2.0 * m2 + 1.0,
                                 2.0 * m3 + 1.0, u[0], u[1], u[2], u[3], u[4], u[5], P[i])
        finite = (math.isfinite(a1) and math.isfinite(a2) and math.isfinite(a3)
                  and math.isfinite(b1) and math.isfinite(b2) and math.isfinite(b3))
        if finite and not (a1 == b1 and a2 == b2 and a3 == b3):
            return i
    return -1
