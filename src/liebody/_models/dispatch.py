"""The one dispatch on model codes: torque and potential of any model."""

from __future__ import annotations

import math

from liebody._kernels._jit import jit
from liebody._kernels.stages import N_CONTROLS, P_U0
from liebody._models import gravity_gradient, uniform_gravity, user_torque

#: model code -> the model's potential in plain Python for one orientation,
#: ``f(t, q, row)`` (models whose potential is a few flops; the others go through
#: :func:`potentials`)
PYTHON_POTENTIALS = {uniform_gravity.CODE: uniform_gravity.potential_py}


@jit(inline="always")
def torque(code, mp, p, addr, t, w, x, y, z, m1, m2, m3):
    """Body torque of model ``code`` with parameter block ``mp`` at ``(t, q, m)``; ``p`` is
    the stage's parameter row (the controls of a user torque), ``addr`` the address of a
    user torque's callback (0 for none)."""
    if code == uniform_gravity.CODE:
        return uniform_gravity.torque(t, w, x, y, z, mp)
    if code == gravity_gradient.CODE:
        return gravity_gradient.torque(t, w, x, y, z, mp)
    if code == user_torque.CODE:
        return user_torque.torque(t, w, x, y, z, m1, m2, m3, p, addr, mp)
    return 0.0, 0.0, 0.0


@jit
def scratch_size(code, mp):
    """Numbers :func:`prepare` writes for model ``code``."""
    if code == gravity_gradient.CODE:
        return gravity_gradient.scratch_size(mp)
    return 1


@jit
def prepare(code, mp, t, scratch):
    """The time-only part of model ``code``'s torque at ``t`` into ``scratch``, shared by
    every body of a block (the SIMD drivers call it once per kick and block)."""
    if code == gravity_gradient.CODE:
        gravity_gradient.prepare(t, mp, scratch)


@jit
def torque_prepared(code, mp, scratch, p, addr, t, w, x, y, z, m1, m2, m3):
    """:func:`torque` after :func:`prepare` (the same numbers, bit for bit)."""
    if code == uniform_gravity.CODE:
        return uniform_gravity.torque(t, w, x, y, z, mp)
    if code == gravity_gradient.CODE:
        return gravity_gradient.torque_prepared(scratch, w, x, y, z, mp)
    if code == user_torque.CODE:
        return user_torque.torque(t, w, x, y, z, m1, m2, m3, p, addr, mp)
    return 0.0, 0.0, 0.0


@jit
def torque_block(code, mpar, params, j, addr, t, scratch, idx, nb, state, rows, out, U, R):
    """:func:`torque_prepared` for the ``nb`` bodies ``idx`` of a SIMD block: body ``b``'s
    ``w, x, y, z, m1, m2, m3`` at ``state[rows[k] + b]``, its torque into ``out[0..2, b]``.
    A model with a vectorised block kernel runs it; a user torque is called once for the
    block through its block callback (``addr``: ``user_torque.adapt_user_block``; ``U``
    ``(BLOCK, N_CONTROLS)`` and ``R`` ``(BLOCK,)`` int64 are work arrays for the bodies'
    controls and parameter rows); any other is evaluated body by body (``params[i, j]``:
    body ``i``'s row of stage ``j``, ``(1, s, P)`` when shared)."""
    if code == gravity_gradient.CODE:
        gravity_gradient.torque_block(scratch, mpar, idx, nb, state, rows, out)
        return
    if code == user_torque.CODE and addr != 0:
        mshared = mpar.shape[0] == 1
        pshared = params.shape[0] == 1
        for b in range(nb):
            i = idx[b]
            R[b] = 0 if mshared else i
            for c in range(N_CONTROLS):
                U[b, c] = params[0 if pshared else i, j, P_U0 + c]
        user_torque.call_block(addr, t, nb, state, rows, U, mpar, R, out)
        return
    mshared = mpar.shape[0] == 1
    pshared = params.shape[0] == 1
    for b in range(nb):
        i = idx[b]
        out[0, b], out[1, b], out[2, b] = torque_prepared(
            code, mpar[0] if mshared else mpar[i], scratch, params[0 if pshared else i, j],
            addr, t, state[rows[0] + b], state[rows[1] + b], state[rows[2] + b],
            state[rows[3] + b], state[rows[4] + b], state[rows[5] + b], state[rows[6] + b])


@jit
def potential(code, mp, t, w, x, y, z):
    """Potential of model ``code`` at the rotation ``q / |q|`` stands for; NaN where the
    kernels cannot evaluate it (a user's Python potential), 0 for no model."""
    if code == uniform_gravity.CODE:
        return uniform_gravity.potential(t, w, x, y, z, mp)
    if code == gravity_gradient.CODE:
        return gravity_gradient.potential(t, w, x, y, z, mp)
    if code == user_torque.CODE:
        return user_torque.potential(t, w, x, y, z, mp)
    return 0.0


@jit
def potentials(code, mp, t, q, out):
    """``out[i] = potential(code, mp[i or 0], t[i], q[i])`` (for Python callers)."""
    rows = mp.shape[0]
    for i in range(q.shape[0]):
        out[i] = potential(code, mp[i if rows > 1 else 0], t[i], q[i, 0], q[i, 1], q[i, 2],
                           q[i, 3])


@jit
def torque_bound(code, mp):
    """A bound on ``|torque|`` at unit ``|q|`` over every orientation and time (for the
    SIMD drivers' fast path: how far the kicks can grow ``|m|``); inf where none is known
    (a user torque)."""
    if code == uniform_gravity.CODE:
        return uniform_gravity.torque_bound(mp)
    if code == gravity_gradient.CODE:
        return gravity_gradient.torque_bound(mp)
    if code == user_torque.CODE:
        return math.inf
    return 0.0
