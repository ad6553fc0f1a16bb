"""The one composition driver: runs any method given as a stage table.

A method is data (see :mod:`liebody.methods` and :mod:`liebody._plan`): a sequence
of *stages*, each a one-step map applied for ``coef * h``. The stage contract (kinds,
parameter slots, families, status codes) is :mod:`liebody._kernels.stages`. The
table is five arrays of equal length::

    kinds  int64 (s,)     which map (a kind code of stages.py)
    axes   int64 (s,)     body axis of an axis rotation (0, 1, 2), else unused
    coefs  float64 (s,)   fraction of the step h the stage runs for
    clock  float64 (s,)   fraction of h by which the clock advances during the stage
    params float64 (s, N_PARAMS)  the named parameter slots of stages.py

Splitting methods are sequences of exact sub-flows (rotations, kicks),
compositions repeat a base table with scaled coefficients, and the other methods
(DMV/RATTLE, the exact flow, the baselines) are single stages of their own kind, so
one loop runs them all. When the first and last stages are flows of the same
Hamiltonian (``merge_ends``), the last stage of one step and the first stage of the
next are applied as one (first-same-as-last), except where the state is saved.

Families. The loop is written once (:func:`_loop`) and compiled once per *family*
(``stages.F_*``), for that family's stage kinds only: :data:`RUNNERS` maps each family
to its driver, in which the family code is a compile-time constant that selects the
family's stage function. A free-body splitting therefore compiles two rotation kernels,
not the elliptic exact flow, DMV's Newton solver and the baselines. A kind outside the
family stops the run with ``STATUS_BAD_STAGE`` (the Python side never builds such a
plan). (The constant reaches the loop as a closure variable: numba's ``literally``
would do the same but measurably slows the compiled loop.)

The state lives in seven local scalars inside the loop: nothing is allocated per
step. The loop stops at the first non-finite state or failed implicit solve and
returns how far it got, so the caller can report it.
"""

from __future__ import annotations

from liebody._kernels._jit import jit
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
    AXIS,
    AXIS_RECURRING,
    DAMP,
    DMV,
    EULER,
    EXACT,
    F_AXES,
    F_DMV,
    F_EULER,
    F_EXACT,
    F_GENERAL,
    F_LIE_EULER,
    F_RK4,
    F_RKMK4,
    F_ROTATIONS,
    F_SPLITTING,
    FAMILIES,
    KICK,
    KICK_IMPLICIT,
    LIE_EULER,
    MEMBERS,
    P_C1,
    P_C2,
    P_C3,
    P_EPS,
    P_I1,
    P_I2,
    P_I3,
    P_RATE,
    P_TORQUE,
    RK4,
    RKMK4,
    SPHERE,
    STATUS_BAD_STAGE,
    STATUS_KICK_NO_CONVERGENCE,
    STATUS_NO_CONVERGENCE,
    STATUS_NONFINITE,
    STATUS_OK,
)
from liebody._kernels.torque import damping_flow, torque_value

#: fixed-point iterations allowed to the implicit (adjoint) kick
KICK_MAX_ITERATIONS = 100


# ------------------------------------------------------------------ stage groups
# Kernels for the stage kinds that need more than one call; each returns the state and
# a status. They are ordinary (not inlined) kernels: the family functions below are
# inlined into the loop, and numba inlines one level only.


@jit
def _kick(kind, p, t, tau, w, x, y, z, m1, m2, m3, torque_fn):
    """KICK (exact flow of an orientation-only torque) or KICK_IMPLICIT.

    The implicit kick ``m' = m + tau torque(t, q, m')`` is the adjoint of the explicit
    one, so that explicit kick - free flow - implicit kick is a symmetric step for
    torques that depend on ``m``; its fixed point is iterated to round-off.
    """
    tk = int(p[P_TORQUE])
    c1, c2, c3 = p[P_C1], p[P_C2], p[P_C3]
    if kind == KICK:
        n1, n2, n3 = torque_value(tk, c1, c2, c3, t, w, x, y, z, m1, m2, m3, torque_fn)
        return w, x, y, z, m1 + tau * n1, m2 + tau * n2, m3 + tau * n3, STATUS_OK
    k1, k2, k3 = m1, m2, m3
    for _ in range(KICK_MAX_ITERATIONS):
        n1, n2, n3 = torque_value(tk, c1, c2, c3, t, w, x, y, z, k1, k2, k3, torque_fn)
        j1, j2, j3 = m1 + tau * n1, m2 + tau * n2, m3 + tau * n3
        d = abs(j1 - k1) + abs(j2 - k2) + abs(j3 - k3)
        k1, k2, k3 = j1, j2, j3
        if d <= 8e-16 * (abs(k1) + abs(k2) + abs(k3)) + 1e-300:
            return w, x, y, z, k1, k2, k3, STATUS_OK
        if not (d < 1e300):
            break
    return w, x, y, z, m1, m2, m3, STATUS_KICK_NO_CONVERGENCE


@jit
def _dmv(p, tau, w, x, y, z, m1, m2, m3):
    r = dmv_step(w, x, y, z, m1, m2, m3, p[P_I1], p[P_I2], p[P_I3], tau)
    status = STATUS_OK if r[7] >= 0 else STATUS_NO_CONVERGENCE
    return r[0], r[1], r[2], r[3], r[4], r[5], r[6], status


@jit
def _exact(p, tau, w, x, y, z, m1, m2, m3):
    r = exact_flow(p[P_I1], p[P_I2], p[P_I3], w, x, y, z, m1, m2, m3, tau)
    return r[0], r[1], r[2], r[3], r[4], r[5], r[6], STATUS_OK


@jit
def _damp(p, tau, w, x, y, z, m1, m2, m3):
    r = damping_flow(w, x, y, z, m1, m2, m3, p[P_I1], p[P_I2], p[P_I3], p[P_EPS], tau)
    return r[0], r[1], r[2], r[3], r[4], r[5], r[6], STATUS_OK


@jit
def _kick_or_damp(kind, p, t, tau, w, x, y, z, m1, m2, m3, torque_fn):
    """The splittings' stages other than rotations: kicks and dissipation."""
    if kind == KICK or kind == KICK_IMPLICIT:
        return _kick(kind, p, t, tau, w, x, y, z, m1, m2, m3, torque_fn)
    if kind == DAMP:
        return _damp(p, tau, w, x, y, z, m1, m2, m3)
    return w, x, y, z, m1, m2, m3, STATUS_BAD_STAGE


@jit(inline="always")
def _baseline(family, p, t, tau, w, x, y, z, m1, m2, m3, torque_fn):
    """One whole step of a classical method (EULER, RK4, LIE_EULER, RKMK4), chosen by its
    family code: a constant in the baselines' own drivers (one method compiled each)."""
    I1, I2, I3, eps = p[P_I1], p[P_I2], p[P_I3], p[P_EPS]
    tk, c1, c2, c3 = int(p[P_TORQUE]), p[P_C1], p[P_C2], p[P_C3]
    if family == F_EULER:
        r = euler_step(t, w, x, y, z, m1, m2, m3, I1, I2, I3, tk, c1, c2, c3, eps, tau,
                       torque_fn)
    elif family == F_RK4:
        r = rk4_step(t, w, x, y, z, m1, m2, m3, I1, I2, I3, tk, c1, c2, c3, eps, tau, torque_fn)
    elif family == F_LIE_EULER:
        r = lie_euler_step(t, w, x, y, z, m1, m2, m3, I1, I2, I3, tk, c1, c2, c3, eps, tau,
                           torque_fn)
    else:
        r = rkmk4_step(t, w, x, y, z, m1, m2, m3, I1, I2, I3, tk, c1, c2, c3, eps, tau,
                       torque_fn)
    return r[0], r[1], r[2], r[3], r[4], r[5], r[6], STATUS_OK


@jit
def _any_stage(kind, axis, p, t, tau, w, x, y, z, m1, m2, m3, torque_fn):
    """Any stage kind (the generic family, for plans that mix kinds of several families)."""
    if kind == AXIS:
        r = axis_flow(w, x, y, z, m1, m2, m3, axis, p[P_RATE], tau)
    elif kind == AXIS_RECURRING:
        r = axis_flow_recurring(w, x, y, z, m1, m2, m3, axis, p[P_RATE], tau)
    elif kind == SPHERE:
        r = sphere_flow(w, x, y, z, m1, m2, m3, p[P_RATE], tau)
    elif kind == DMV:
        return _dmv(p, tau, w, x, y, z, m1, m2, m3)
    elif kind == EXACT:
        return _exact(p, tau, w, x, y, z, m1, m2, m3)
    elif kind == EULER:
        return _baseline(F_EULER, p, t, tau, w, x, y, z, m1, m2, m3, torque_fn)
    elif kind == RK4:
        return _baseline(F_RK4, p, t, tau, w, x, y, z, m1, m2, m3, torque_fn)
    elif kind == LIE_EULER:
        return _baseline(F_LIE_EULER, p, t, tau, w, x, y, z, m1, m2, m3, torque_fn)
    elif kind == RKMK4:
        return _baseline(F_RKMK4, p, t, tau, w, x, y, z, m1, m2, m3, torque_fn)
    else:
        return _kick_or_damp(kind, p, t, tau, w, x, y, z, m1, m2, m3, torque_fn)
    return r[0], r[1], r[2], r[3], r[4], r[5], r[6], STATUS_OK


# ------------------------------------------------------------------ families
@jit(inline="always")
def apply_stage(family, kind, axis, params, j, t, tau, w, x, y, z, m1, m2, m3, torque_fn):
    """Stage ``j`` of the table for time ``tau`` at clock ``t``: state and status.

    ``family`` is a compile-time constant in every driver, and numba removes the
    branches of the other families before typing them: each family compiles the
    kernels of its own stage kinds only. The loop has checked every kind against the
    family (``stages.MEMBERS``), so each family's last branch needs no test.
    """
    if family == F_AXES:
        r = axis_flow(w, x, y, z, m1, m2, m3, axis, params[j, P_RATE], tau)
    elif family == F_ROTATIONS or family == F_SPLITTING:
        if family == F_SPLITTING:
            if kind == KICK or kind == KICK_IMPLICIT:
                return _kick(kind, params[j], t, tau, w, x, y, z, m1, m2, m3, torque_fn)
            if kind == DAMP:
                return _damp(params[j], tau, w, x, y, z, m1, m2, m3)
        if kind == AXIS:
            r = axis_flow(w, x, y, z, m1, m2, m3, axis, params[j, P_RATE], tau)
        elif kind == AXIS_RECURRING:
            r = axis_flow_recurring(w, x, y, z, m1, m2, m3, axis, params[j, P_RATE], tau)
        else:
            r = sphere_flow(w, x, y, z, m1, m2, m3, params[j, P_RATE], tau)
    elif family == F_DMV:
        if kind == DMV:
            return _dmv(params[j], tau, w, x, y, z, m1, m2, m3)
        return _kick(kind, params[j], t, tau, w, x, y, z, m1, m2, m3, torque_fn)
    elif family == F_EXACT:
        if kind == EXACT:
            return _exact(params[j], tau, w, x, y, z, m1, m2, m3)
        return _kick_or_damp(kind, params[j], t, tau, w, x, y, z, m1, m2, m3, torque_fn)
    elif family == F_GENERAL:
        return _any_stage(kind, axis, params[j], t, tau, w, x, y, z, m1, m2, m3, torque_fn)
    else:  # the baselines: one whole step each, torque and dissipation inside
        return _baseline(family, params[j], t, tau, w, x, y, z, m1, m2, m3, torque_fn)
    return r[0], r[1], r[2], r[3], r[4], r[5], r[6], STATUS_OK


# ------------------------------------------------------------------ the loop
@jit(inline="always")
def _loop(family, kinds, axes, coefs, clock, params, h, t0, n_steps, save_every, merge_ends,
          state, q_out, m_out, torque_fn):
    """Advance ``state`` (w, x, y, z, m1, m2, m3) by ``n_steps`` steps of size ``h`` from ``t0``.

    ``family`` (a ``stages.F_*`` code) is a compile-time constant. The state after
    every ``save_every``-th step, and after the last step, is written to consecutive
    rows of ``q_out`` / ``m_out`` (row 0 is the first save *after* the start). ``state``
    is updated in place with the last state reached. ``torque_fn`` is the user torque
    callback (``torque.TORQUE_SIG``) or ``None``.

    Returns ``(steps_done, n_saved, status)``. On a non-finite state or a failed
    implicit solve the loop stops and ``state`` holds the last finite state, the one
    after ``steps_done`` steps (for methods with merged end stages it may already
    contain the first stage of the failed step); the caller decides how to report it.
    """
    ns = kinds.shape[0]
    for j in range(ns):  # every kind must be one the family runs
        if kinds[j] < 0 or kinds[j] >= MEMBERS.shape[1] or not MEMBERS[family, kinds[j]]:
            return 0, 0, STATUS_BAD_STAGE
    w, x, y, z = state[0], state[1], state[2], state[3]
    m1, m2, m3 = state[4], state[5], state[6]
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
            w, x, y, z, m1, m2, m3, status = apply_stage(
                family, kinds[j], axes[j], params, j, t, coefs[j] * h, w, x, y, z, m1, m2, m3,
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
            w, x, y, z, m1, m2, m3, status = apply_stage(
                family, kinds[last], axes[last], params, last, t, tau, w, x, y, z, m1, m2, m3,
                torque_fn)
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



def _runner(family: int):
    """The driver compiled for one family (``family`` is a compile-time constant)."""

    @jit
    def run(kinds, axes, coefs, clock, params, h, t0, n_steps, save_every, merge_ends, state,
            q_out, m_out, torque_fn):
        return _loop(family, kinds, axes, coefs, clock, params, h, t0, n_steps, save_every,
                     merge_ends, state, q_out, m_out, torque_fn)

    return run


#: family code -> its driver (compiled on first call, cached on disk)
RUNNERS = {family: _runner(family) for family in FAMILIES}


def run(family, kinds, axes, coefs, clock, params, h, t0, n_steps, save_every, merge_ends,
        state, q_out, m_out, torque_fn):
    """Run a stage table with the driver of its ``family`` (see :func:`_loop`)."""
    return RUNNERS[family](kinds, axes, coefs, clock, params, h, t0, n_steps, save_every,
                           merge_ends, state, q_out, m_out, torque_fn)
