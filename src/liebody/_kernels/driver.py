"""The one composition driver: runs any method given as a stage table.

A method is data (see :mod:`liebody.registry`): a sequence of *stages*, each a
one-step map applied for ``coef * h``. The table is five arrays of equal length::

    kinds  int64 (s,)     which map (the STAGE_* constants of stages.py)
    axes   int64 (s,)     body axis for axis rotations (0, 1, 2), else unused
    coefs  float64 (s,)   fraction of the step h the stage runs for
    clock  float64 (s,)   fraction of h by which the clock advances during the stage
    params float64 (s, 8) per-stage constants:
                          AXIS, SPHERE: rate; DMV, EXACT: moments;
                          KICK: torque kind, c = M g cm; DAMP: moments, eps;
                          baselines: moments, torque kind, c, eps

Splitting methods are sequences of exact sub-flows (rotations, kicks),
compositions repeat a base table with scaled coefficients, and the other families
(DMV/RATTLE, the exact flow, the baselines) are single stages of their own kind, so
one loop runs them all. When the first and last stages are flows of the same
Hamiltonian (``merge_ends``), the last stage of one step and the first stage of the
next are applied as one (FSAL), except where the state is saved.

The state lives in seven local scalars inside the loop: nothing is allocated per
step. The loop stops at the first non-finite state (status 1) or at a DMV
non-convergence (status 2), so the caller can report how far it got.
"""

from __future__ import annotations

from numba import njit

from liebody._kernels.exact import exact_flow
from liebody._kernels.flows import (
    axis_flow,
    axis_flow_recurring,
    dmv_step,
    euler_step,
    lie_euler_step,
    rk4_step,
    rkmk4_step,
    sphere_flow,
)
from liebody._kernels.stages import (
    STAGE_AXIS,
    STAGE_DAMP,
    STAGE_DMV,
    STAGE_EULER,
    STAGE_EXACT,
    STAGE_KICK,
    STAGE_KICK_IMPLICIT,
    STAGE_LIE_EULER,
    STAGE_RK4,
    STAGE_SPHERE,
    STATUS_NO_CONVERGENCE,
    STATUS_NONFINITE,
    STATUS_OK,
)
from liebody._kernels.torque import damping_flow, torque_value

KICK_MAX_ITERATIONS = 100

MODE_AXES = 0  # every stage an axis rotation (splitting2 and its compositions)
MODE_ROTATIONS = 1  # axis and sphere rotations (sr2 and its compositions)
MODE_GENERAL = 2


@njit(cache=True)
def apply_stage(kind, axis, p, t, tau, w, x, y, z, m1, m2, m3, torque_fn):
    """Apply one stage (parameters ``p``, clock ``t``) for time ``tau``; state and status."""
    if kind == STAGE_AXIS:
        if p[1] != 0.0:
            r = axis_flow_recurring(w, x, y, z, m1, m2, m3, axis, p[0], tau)
        else:
            r = axis_flow(w, x, y, z, m1, m2, m3, axis, p[0], tau)
    elif kind == STAGE_SPHERE:
        r = sphere_flow(w, x, y, z, m1, m2, m3, p[0], tau)
    elif kind == STAGE_KICK:
        n1, n2, n3 = torque_value(int(p[0]), p[1], p[2], p[3], t, w, x, y, z, m1, m2, m3,
                                  torque_fn)
        r = (w, x, y, z, m1 + tau * n1, m2 + tau * n2, m3 + tau * n3)
    elif kind == STAGE_KICK_IMPLICIT:
        # m1' = m + tau torque(t, q, m1'): the adjoint of the explicit kick, so that
        # explicit kick - free flow - implicit kick is symmetric for L-dependent torques
        k1, k2, k3 = m1, m2, m3
        ok = False
        for _ in range(KICK_MAX_ITERATIONS):
            n1, n2, n3 = torque_value(int(p[0]), p[1], p[2], p[3], t, w, x, y, z, k1, k2, k3,
                                      torque_fn)
            j1, j2, j3 = m1 + tau * n1, m2 + tau * n2, m3 + tau * n3
            d = abs(j1 - k1) + abs(j2 - k2) + abs(j3 - k3)
            k1, k2, k3 = j1, j2, j3
            if d <= 8e-16 * (abs(k1) + abs(k2) + abs(k3)) + 1e-300:
                ok = True
                break
            if not (d < 1e300):
                break
        if not ok:
            return w, x, y, z, m1, m2, m3, STATUS_NO_CONVERGENCE
        r = (w, x, y, z, k1, k2, k3)
    elif kind == STAGE_DMV:
        r8 = dmv_step(w, x, y, z, m1, m2, m3, p[0], p[1], p[2], tau)
        st = STATUS_OK if r8[7] >= 0 else STATUS_NO_CONVERGENCE
        return r8[0], r8[1], r8[2], r8[3], r8[4], r8[5], r8[6], st
    elif kind == STAGE_EXACT:
        r = exact_flow(p[0], p[1], p[2], w, x, y, z, m1, m2, m3, tau)
    elif kind == STAGE_DAMP:
        r = damping_flow(w, x, y, z, m1, m2, m3, p[0], p[1], p[2], p[3], tau)
    elif kind == STAGE_EULER:
        r = euler_step(t, w, x, y, z, m1, m2, m3, p[0], p[1], p[2], int(p[3]), p[4], p[5],
                       p[6], p[7], tau, torque_fn)
    elif kind == STAGE_RK4:
        r = rk4_step(t, w, x, y, z, m1, m2, m3, p[0], p[1], p[2], int(p[3]), p[4], p[5],
                     p[6], p[7], tau, torque_fn)
    elif kind == STAGE_LIE_EULER:
        r = lie_euler_step(t, w, x, y, z, m1, m2, m3, p[0], p[1], p[2], int(p[3]), p[4],
                           p[5], p[6], p[7], tau, torque_fn)
    else:
        r = rkmk4_step(t, w, x, y, z, m1, m2, m3, p[0], p[1], p[2], int(p[3]), p[4], p[5],
                       p[6], p[7], tau, torque_fn)
    return r[0], r[1], r[2], r[3], r[4], r[5], r[6], STATUS_OK


@njit(cache=True, inline="always")
def _apply(mode, kinds, axes, params, j, t, tau, w, x, y, z, m1, m2, m3, torque_fn):
    """Stage ``j`` for time ``tau``, dispatched on the loop-invariant ``mode``.

    Inlined so that LLVM can specialise the stepping loop per mode: splittings then
    run without the branches (and register pressure) of the other stage kinds.
    """
    if mode == MODE_AXES:
        r = axis_flow(w, x, y, z, m1, m2, m3, axes[j], params[j, 0], tau)
        return r[0], r[1], r[2], r[3], r[4], r[5], r[6], STATUS_OK
    if mode == MODE_ROTATIONS:
        if kinds[j] == STAGE_AXIS:
            if params[j, 1] != 0.0:
                r = axis_flow_recurring(w, x, y, z, m1, m2, m3, axes[j], params[j, 0], tau)
            else:
                r = axis_flow(w, x, y, z, m1, m2, m3, axes[j], params[j, 0], tau)
        else:
            r = sphere_flow(w, x, y, z, m1, m2, m3, params[j, 0], tau)
        return r[0], r[1], r[2], r[3], r[4], r[5], r[6], STATUS_OK
    return apply_stage(kinds[j], axes[j], params[j], t, tau, w, x, y, z, m1, m2, m3,
                       torque_fn)


@njit(cache=True)
def run(kinds, axes, coefs, clock, params, h, t0, n_steps, save_every, merge_ends, state,
        q_out, m_out, torque_fn):
    """Advance ``state`` (w, x, y, z, m1, m2, m3) by ``n_steps`` steps of size ``h`` from ``t0``.

    The state after every ``save_every``-th step, and after the last step, is written
    to consecutive rows of ``q_out`` / ``m_out`` (row 0 is the first save *after* the
    start). ``state`` is updated in place with the last state reached. ``torque_fn``
    is the user torque callback (``torque.TORQUE_SIG``), used by user-torque stages.

    Returns ``(steps_done, n_saved, status)``. On a non-finite state or a DMV
    failure the loop stops and ``state`` holds the last finite state, the one after
    ``steps_done`` steps (for methods with merged end stages it may already contain
    the first stage of the failed step); the caller decides how to report it.
    """
    w, x, y, z = state[0], state[1], state[2], state[3]
    m1, m2, m3 = state[4], state[5], state[6]
    ns = kinds.shape[0]
    mode = MODE_AXES
    for j in range(ns):
        if mode == MODE_AXES and (kinds[j] == STAGE_SPHERE or (
                kinds[j] == STAGE_AXIS and params[j, 1] != 0.0)):
            mode = MODE_ROTATIONS
        elif kinds[j] != STAGE_AXIS and kinds[j] != STAGE_SPHERE:
            mode = MODE_GENERAL
    last = ns - 1
    pending = False  # first stage of this step already applied (merged into the previous one)
    n_saved = 0
    until_save = save_every  # countdown: no integer division in the loop
    for step in range(n_steps):
        gw, gx, gy, gz, g1, g2, g3 = w, x, y, z, m1, m2, m3  # last good state
        status = STATUS_OK
        t = t0 + step * h  # clock at the start of the step (no accumulated rounding)
        j0 = 0
        if pending:
            j0 = 1
            t += clock[0] * h
        for j in range(j0, last):
            w, x, y, z, m1, m2, m3, status = _apply(mode, kinds, axes, params, j, t,
                                                    coefs[j] * h, w, x, y, z, m1, m2, m3,
                                                    torque_fn)
            if status != STATUS_OK:
                break
            t += clock[j] * h
        until_save -= 1
        save_now = until_save == 0 or step == n_steps - 1
        if status == STATUS_OK:
            if ns > 1 and merge_ends and not save_now:
                tau = (coefs[last] + coefs[0]) * h
                pending = True
            else:
                tau = coefs[last] * h
                pending = False
            w, x, y, z, m1, m2, m3, status = _apply(mode, kinds, axes, params, last, t, tau,
                                                    w, x, y, z, m1, m2, m3, torque_fn)
        if status == STATUS_OK:
            acc = w + x + y + z + m1 + m2 + m3
            if not (abs(acc) < 1e308):
                status = STATUS_NONFINITE
        if status != STATUS_OK:
            state[0], state[1], state[2], state[3] = gw, gx, gy, gz
            state[4], state[5], state[6] = g1, g2, g3
            return step, n_saved, status
        if save_now:
            until_save = save_every
            q_out[n_saved, 0], q_out[n_saved, 1] = w, x
            q_out[n_saved, 2], q_out[n_saved, 3] = y, z
            m_out[n_saved, 0], m_out[n_saved, 1], m_out[n_saved, 2] = m1, m2, m3
            n_saved += 1
    state[0], state[1], state[2], state[3] = w, x, y, z
    state[4], state[5], state[6] = m1, m2, m3
    return n_steps, n_saved, STATUS_OK
