"""The one dispatch on model codes: torque and potential of any model."""

from __future__ import annotations

import math

from numba.extending import overload

from liebody._kernels._jit import jit, overload_options
from liebody._kernels.stages import MAX_MODEL_CODE, N_CONTROLS, P_U0, TORQUE_NONE
from liebody._models import gravity_gradient, uniform_gravity, user_torque

#: the model code of :func:`token` for "any model" (the kernels read it from the stage rows)
ANY = -1


def token(code: int) -> tuple:
    """The argument that specialises the one-body drivers to the model ``code`` (or
    :data:`ANY`): a tuple of ``code + 2`` zeros, whose *type* (its length) names the model,
    so that numba compiles each model's driver apart and types that model's torque only
    (a heavy top's driver never compiles the Kepler solver of the gravity-gradient model).
    Uncompiled (``NUMBA_DISABLE_JIT``) the kernels ignore it."""
    if not (code == ANY or 0 <= code <= MAX_MODEL_CODE):
        raise ValueError(f"unknown torque model code {code}")
    return (0,) * (code + 2)


def momentum_dependent(model) -> bool:
    """Whether the model of a token's numba type (:func:`token`) may have a torque that
    depends on the momentum (so that the drivers need the implicit kick): the model's
    ``MOMENTUM``; true for :data:`ANY`, false without a model."""
    c = _token_code(model)
    if c == ANY:
        return True
    return {TORQUE_NONE: False, uniform_gravity.CODE: uniform_gravity.MOMENTUM,
            gravity_gradient.CODE: gravity_gradient.MOMENTUM,
            user_torque.CODE: user_torque.MOMENTUM}[c]


def _token_code(tok) -> int:
    """The model code a token's numba type stands for (:data:`ANY` for anything else, such
    as an omitted argument)."""
    count = getattr(tok, "count", None)
    return count - 2 if isinstance(count, int) and 0 <= count - 2 <= MAX_MODEL_CODE else ANY

#: model code -> the model's potential in plain Python for one orientation,
#: ``f(t, q, row)`` (models whose potential is a few flops; the others go through
#: :func:`potentials`)
PYTHON_POTENTIALS = {uniform_gravity.CODE: uniform_gravity.potential_py}


@jit(inline="always")
def torque(code, mp, ms, p, addr, t, w, x, y, z, m1, m2, m3):
    """Body torque of model ``code`` with the body's parameter row ``mp`` and the block
    ``ms`` shared by every body at ``(t, q, m)``; ``p`` is the stage's parameter row (the
    controls of a user torque), ``addr`` the address of a user torque's callback (0 for
    none)."""
    if code == uniform_gravity.CODE:
        return uniform_gravity.torque(t, w, x, y, z, mp)
    if code == gravity_gradient.CODE:
        return gravity_gradient.torque(t, w, x, y, z, mp, ms)
    if code == user_torque.CODE:
        return user_torque.torque(t, w, x, y, z, m1, m2, m3, p, addr, mp)
    return 0.0, 0.0, 0.0


def torque_of(model, code, mp, ms, p, addr, t, w, x, y, z, m1, m2, m3):
    """:func:`torque` specialised at compile time to the model of the token ``model``
    (:func:`token`; for :data:`ANY`, the stage's ``code``). Only the kernels compile it
    (an overload); uncompiled, it is :func:`torque` of ``code``."""
    return torque(code, mp, ms, p, addr, t, w, x, y, z, m1, m2, m3)


# The overloads' implementations for the gravity gradient are inlined by numba: a regular
# overload's implementation is a function of its own, which LLVM inlines together with the
# atomic reference-count increments and decrements of its array arguments (two more of them
# per kick when the model's shared block came in beside its row: 10-15 % of a one-body
# gravity-gradient step). The other models' torques are inlined functions themselves, and
# numba's IR inliner does not nest them (its SSA checks fail), so they keep the regular
# overloads below; the two cover disjoint models.


@overload(torque_of, jit_options=overload_options(), inline="always")
def _torque_of_inlined(model, code, mp, ms, p, addr, t, w, x, y, z, m1, m2, m3):
    if _token_code(model) != gravity_gradient.CODE:
        return None

    def impl(model, code, mp, ms, p, addr, t, w, x, y, z, m1, m2, m3):
        return gravity_gradient.torque(t, w, x, y, z, mp, ms)
    return impl


@overload(torque_of, jit_options=overload_options())
def _torque_of(model, code, mp, ms, p, addr, t, w, x, y, z, m1, m2, m3):
    c = _token_code(model)
    if c == gravity_gradient.CODE:
        return None  # (_torque_of_inlined)
    if c == uniform_gravity.CODE:
        def impl(model, code, mp, ms, p, addr, t, w, x, y, z, m1, m2, m3):
            return uniform_gravity.torque(t, w, x, y, z, mp)
    elif c == user_torque.CODE:
        def impl(model, code, mp, ms, p, addr, t, w, x, y, z, m1, m2, m3):
            return user_torque.torque(t, w, x, y, z, m1, m2, m3, p, addr, mp)
    elif c == TORQUE_NONE:
        def impl(model, code, mp, ms, p, addr, t, w, x, y, z, m1, m2, m3):
            return 0.0, 0.0, 0.0
    else:
        def impl(model, code, mp, ms, p, addr, t, w, x, y, z, m1, m2, m3):
            return torque(code, mp, ms, p, addr, t, w, x, y, z, m1, m2, m3)
    return impl


def potential_of(model, code, mp, ms, t, w, x, y, z):
    """:func:`potential` specialised to the model of the token ``model`` (:func:`token`):
    that model's potential where ``code`` is its code, else 0 (``code`` is a run's
    diagnostic code, the model's or ``TORQUE_NONE``); for :data:`ANY`, :func:`potential`
    of ``code``."""
    return potential(code, mp, ms, t, w, x, y, z)


@overload(potential_of, jit_options=overload_options(), inline="always")
def _potential_of_inlined(model, code, mp, ms, t, w, x, y, z):
    c = _token_code(model)
    if c != gravity_gradient.CODE:
        return None

    def impl(model, code, mp, ms, t, w, x, y, z):
        return gravity_gradient.potential(t, w, x, y, z, mp, ms) if code == c else 0.0
    return impl


@overload(potential_of, jit_options=overload_options())
def _potential_of(model, code, mp, ms, t, w, x, y, z):
    c = _token_code(model)
    if c == gravity_gradient.CODE:
        return None  # (_potential_of_inlined)
    if c == uniform_gravity.CODE:
        def impl(model, code, mp, ms, t, w, x, y, z):
            return uniform_gravity.potential(t, w, x, y, z, mp) if code == c else 0.0
    elif c == user_torque.CODE:
        def impl(model, code, mp, ms, t, w, x, y, z):
            return user_torque.potential(t, w, x, y, z, mp) if code == c else 0.0
    elif c == TORQUE_NONE:
        def impl(model, code, mp, ms, t, w, x, y, z):
            return 0.0
    else:
        def impl(model, code, mp, ms, t, w, x, y, z):
            return potential(code, mp, ms, t, w, x, y, z)
    return impl


@jit
def scratch_size(code, ms):
    """Numbers :func:`prepare` writes for model ``code`` (shared block ``ms``)."""
    if code == gravity_gradient.CODE:
        return gravity_gradient.scratch_size(ms)
    return 1


@jit(inline="always")
def prepare(code, ms, t, scratch):
    """The time-only part of model ``code``'s torque at ``t`` into ``scratch``: it reads
    the shared block ``ms`` only, so it is the same for every body (the SIMD drivers call
    it once per kick and block; inlined there, as :func:`torque_block`: two calls with
    their arrays cost a gravity-gradient kick about 15 %)."""
    if code == gravity_gradient.CODE:
        gravity_gradient.prepare(t, ms, scratch)


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
def block_constants(code, mp):
    """Three numbers of a body's parameter row ``mp`` that model ``code``'s block kernels
    read from the SIMD drivers' gathered parameters (gathered once per block, not per kick):
    uniform gravity's weight arm, the gravity gradient's moments; zeros for the others."""
    if code == uniform_gravity.CODE:
        return mp[0], mp[1], mp[2]
    if code == gravity_gradient.CODE:
        return gravity_gradient.block_constants(mp)
    return 0.0, 0.0, 0.0


@jit(inline="always")
def torque_block(code, mpar, params, par, j, slot, addr, t, scratch, idx, nb, state, rows, out,
                 U, R):
    """:func:`torque_prepared` for the ``nb`` bodies ``idx`` of a SIMD block: body ``b``'s
    ``w, x, y, z, m1, m2, m3`` at ``state[rows[k] + b]``, its torque into ``out[0..2, b]``
    (``par[j, 0..2, b]``: its :func:`block_constants`).
    A model with a vectorised block kernel runs it; a user torque is called once for the
    block through its block callback (``addr``: ``user_torque.adapt_user_block``; ``U``
    ``(BLOCK, N_CONTROLS)`` and ``R`` ``(BLOCK,)`` int64 are work arrays for the bodies'
    controls and parameter rows); any other is evaluated body by body (``params[i, slot]``:
    body ``i``'s row of stage ``j``, ``(1, r, P)`` when shared)."""
    if code == gravity_gradient.CODE:
        gravity_gradient.torque_block(scratch, par, j, nb, state, rows, out)
        return
    if code == user_torque.CODE and addr != 0:
        mshared = mpar.shape[0] == 1
        pshared = params.shape[0] == 1
        for b in range(nb):
            i = idx[b]
            R[b] = 0 if mshared else i
            for c in range(N_CONTROLS):
                U[b, c] = params[0 if pshared else i, slot, P_U0 + c]
        user_torque.call_block(addr, t, nb, state, rows, U, mpar, R, out)
        return
    mshared = mpar.shape[0] == 1
    pshared = params.shape[0] == 1
    for b in range(nb):
        i = idx[b]
        out[0, b], out[1, b], out[2, b] = torque_prepared(
            code, mpar[0] if mshared else mpar[i], scratch, params[0 if pshared else i, slot],
            addr, t, state[rows[0] + b], state[rows[1] + b], state[rows[2] + b],
            state[rows[3] + b], state[rows[4] + b], state[rows[5] + b], state[rows[6] + b])


@jit
def potential(code, mp, ms, t, w, x, y, z):
    """Potential of model ``code`` (body row ``mp``, shared block ``ms``) at the rotation
    ``q / |q|`` stands for; NaN where the kernels cannot evaluate it (a user's Python
    potential), 0 for no model."""
    if code == uniform_gravity.CODE:
        return uniform_gravity.potential(t, w, x, y, z, mp)
    if code == gravity_gradient.CODE:
        return gravity_gradient.potential(t, w, x, y, z, mp, ms)
    if code == user_torque.CODE:
        return user_torque.potential(t, w, x, y, z, mp)
    return 0.0


@jit
def potentials(code, mp, ms, t, q, out):
    """``out[i] = potential(code, mp[i or 0], ms, t[i], q[i])`` (for Python callers)."""
    rows = mp.shape[0]
    for i in range(q.shape[0]):
        out[i] = potential(code, mp[i if rows > 1 else 0], ms, t[i], q[i, 0], q[i, 1],
                           q[i, 2], q[i, 3])


@jit
def torque_bound(code, mp, ms):
    """A bound on ``|torque|`` at unit ``|q|`` over every orientation and time (for the
    SIMD drivers' fast path: how far the kicks can grow ``|m|``); inf where none is known
    (a user torque)."""
    if code == uniform_gravity.CODE:
        return uniform_gravity.torque_bound(mp)
    if code == gravity_gradient.CODE:
        return gravity_gradient.torque_bound(mp, ms)
    if code == user_torque.CODE:
        return math.inf
    return 0.0
