"""The one composition driver: runs any method given as a stage table.

A method is data (see :mod:`liebody.methods` and ``liebody._plan``): a sequence
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

Families. The loop is written once (in :func:`_runner`) and compiled once per *family*
(``stages.F_*``), for that family's stage kinds only: :data:`RUNNERS` maps each family
to its driver, a closure over the family's code. A free-body
splitting therefore compiles one rotation kernel, not the elliptic exact flow, DMV's
Newton solver and the baselines, and a free body's RATTLE compiles no kick. A kind
outside the family stops the run with ``STATUS_BAD_STAGE`` (the Python side never
builds such a plan).

The state lives in seven local scalars inside the loop (and their seven low-order
parts across a step's gyrostat turns, ``flows.axis_flow_carried``): nothing is allocated
per step. The loop stops at the first non-finite state, failed implicit solve or failing
torque and returns how far it got, so the caller can report it.
"""

from __future__ import annotations

import math

from numba.extending import overload

from liebody._kernels._jit import jit, overload_options
from liebody._kernels.exact import exact_flow
from liebody._kernels.flows import (
    axis_flow,
    axis_flow_carried,
    axis_flow_recurring,
    axis_flow_shifted,
    dmv_step,
    euler_step,
    fold_carried,
    lie_euler_step,
    rk4_step,
    rkmk4_step,
    rotor_at,
    sphere_flow,
)
from liebody._kernels.stages import (
    AXIS,
    AXIS_RECURRING,
    AXIS_SHIFTED,
    DAMP,
    DMV,
    EULER,
    EXACT,
    F_AXES,
    F_DMV,
    F_DMV_FREE,
    F_EULER,
    F_EXACT,
    F_GENERAL,
    F_KICKED,
    F_LIE_EULER,
    F_RK4,
    F_RKMK4,
    F_ROTATIONS,
    F_ROTOR,
    F_ROTOR_TORQUED,
    F_SPLITTING,
    FAMILIES,
    KICK,
    KICK_IMPLICIT,
    LIE_EULER,
    MEMBERS,
    P_EPS,
    P_I1,
    P_I2,
    P_I3,
    P_RATE,
    RK4,
    RKMK4,
    SPHERE,
    STATUS_BAD_STAGE,
    STATUS_KICK_NO_CONVERGENCE,
    STATUS_NO_CONVERGENCE,
    STATUS_NONFINITE,
    STATUS_OK,
    STATUS_TORQUE,
    family_tag,
)
from liebody._kernels.torque import damping_flow, torque_value
from liebody._models import dispatch

#: iterations allowed to the implicit (adjoint) kick: fixed point, then Newton
KICK_FIXED_POINT = 50
KICK_NEWTON = 30


# ------------------------------------------------------------------ stage kernels
# Kernels for the stage kinds that need more than one call; each returns the state and
# a status.


@jit(inline="always")
def _torque(p, t, w, x, y, z, m1, m2, m3, torque_addr, mp, ms, model):
    """The torque and whether it is a finite 3-vector (a user torque signals failure by NaN)."""
    n1, n2, n3 = torque_value(p, t, w, x, y, z, m1, m2, m3, torque_addr, mp, ms, model)
    return n1, n2, n3, abs(n1) + abs(n2) + abs(n3) < math.inf


@jit(inline="always")
def _explicit_kick(p, t, tau, w, x, y, z, m1, m2, m3, torque_addr, mp, ms, model):
    """KICK: the exact flow of an orientation-only torque, ``m += tau N(t, q)`` (inlined: as
    a call it cost a gravity-gradient step about 10 %)."""
    n1, n2, n3, ok = _torque(p, t, w, x, y, z, m1, m2, m3, torque_addr, mp, ms, model)
    if not ok:
        return w, x, y, z, m1, m2, m3, STATUS_TORQUE
    return w, x, y, z, m1 + tau * n1, m2 + tau * n2, m3 + tau * n3, STATUS_OK


@jit
def _kick(kind, p, t, tau, w, x, y, z, m1, m2, m3, torque_addr, mp, ms, model):
    """KICK (exact flow of an orientation-only torque) or KICK_IMPLICIT.

    The implicit kick solves ``k = m + tau N(t, q, k)``: the adjoint of the explicit one,
    so that explicit kick - free flow - implicit kick is a symmetric step for torques
    that depend on ``m``. Fixed-point iteration first (cheap, converges when
    ``tau |dN/dm| < 1``), then Newton with a finite-difference Jacobian (stiff torques
    such as strong damping), each to round-off.
    """
    n1, n2, n3, ok = _torque(p, t, w, x, y, z, m1, m2, m3, torque_addr, mp, ms, model)
    if not ok:
        return w, x, y, z, m1, m2, m3, STATUS_TORQUE
    e1, e2, e3 = m1 + tau * n1, m2 + tau * n2, m3 + tau * n3  # the explicit kick
    if kind == KICK:
        return w, x, y, z, e1, e2, e3, STATUS_OK
    k1, k2, k3 = e1, e2, e3
    scale = abs(m1) + abs(m2) + abs(m3)
    for _ in range(KICK_FIXED_POINT):
        n1, n2, n3, ok = _torque(p, t, w, x, y, z, k1, k2, k3, torque_addr, mp, ms, model)
        if not ok:
            return w, x, y, z, m1, m2, m3, STATUS_TORQUE
        j1, j2, j3 = m1 + tau * n1, m2 + tau * n2, m3 + tau * n3
        d = abs(j1 - k1) + abs(j2 - k2) + abs(j3 - k3)
        k1, k2, k3 = j1, j2, j3
        if d <= 8e-16 * (abs(k1) + abs(k2) + abs(k3)) + 1e-300:
            return w, x, y, z, k1, k2, k3, STATUS_OK
        if not (d < 1e3 * (scale + 1e-300)):
            break  # diverging: the torque is too stiff for the fixed point at this step
    # Newton on G(k) = k - m - tau N(k), from the explicit kick
    k1, k2, k3 = e1, e2, e3
    for _ in range(KICK_NEWTON):
        n1, n2, n3, ok = _torque(p, t, w, x, y, z, k1, k2, k3, torque_addr, mp, ms, model)
        if not ok:
            return w, x, y, z, m1, m2, m3, STATUS_TORQUE
        g1, g2, g3 = k1 - m1 - tau * n1, k2 - m2 - tau * n2, k3 - m3 - tau * n3
        size = abs(k1) + abs(k2) + abs(k3) + 1e-300
        if abs(g1) + abs(g2) + abs(g3) <= 8e-16 * size:
            return w, x, y, z, k1, k2, k3, STATUS_OK
        # J = 1 - tau dN/dk, by forward differences
        e = 1.5e-8 * size
        a1, a2, a3, ok1 = _torque(p, t, w, x, y, z, k1 + e, k2, k3, torque_addr, mp, ms, model)
        b1, b2, b3, ok2 = _torque(p, t, w, x, y, z, k1, k2 + e, k3, torque_addr, mp, ms, model)
        d1, d2, d3, ok3 = _torque(p, t, w, x, y, z, k1, k2, k3 + e, torque_addr, mp, ms, model)
        if not (ok1 and ok2 and ok3):
            return w, x, y, z, m1, m2, m3, STATUS_TORQUE
        f = tau / e
        j11, j21, j31 = 1.0 - f * (a1 - n1), -f * (a2 - n2), -f * (a3 - n3)
        j12, j22, j32 = -f * (b1 - n1), 1.0 - f * (b2 - n2), -f * (b3 - n3)
        j13, j23, j33 = -f * (d1 - n1), -f * (d2 - n2), 1.0 - f * (d3 - n3)
        det = (j11 * (j22 * j33 - j23 * j32) - j12 * (j21 * j33 - j23 * j31)
               + j13 * (j21 * j32 - j22 * j31))
        if det == 0.0 or not (abs(det) < math.inf):
            break
        s1 = (g1 * (j22 * j33 - j23 * j32) - j12 * (g2 * j33 - j23 * g3)
              + j13 * (g2 * j32 - j22 * g3)) / det
        s2 = (j11 * (g2 * j33 - j23 * g3) - g1 * (j21 * j33 - j23 * j31)
              + j13 * (j21 * g3 - g2 * j31)) / det
        s3 = (j11 * (j22 * g3 - g2 * j32) - j12 * (j21 * g3 - g2 * j31)
              + g1 * (j21 * j32 - j22 * j31)) / det
        k1, k2, k3 = k1 - s1, k2 - s2, k3 - s3
        if abs(s1) + abs(s2) + abs(s3) <= 4e-16 * size:
            return w, x, y, z, k1, k2, k3, STATUS_OK
    return w, x, y, z, m1, m2, m3, STATUS_KICK_NO_CONVERGENCE


def kick(kind, p, t, tau, w, x, y, z, m1, m2, m3, torque_addr, mp, ms, model):
    """:func:`_kick`, compiled with its implicit (Newton) half only where the run's model
    (the token ``model``) may depend on the momentum; for the others (uniform gravity, the
    gravity gradient: explicit kicks only) an implicit kick is ``STATUS_BAD_STAGE``."""
    return _kick(kind, p, t, tau, w, x, y, z, m1, m2, m3, torque_addr, mp, ms, model)


@overload(kick, jit_options=overload_options())
def _kick_of(kind, p, t, tau, w, x, y, z, m1, m2, m3, torque_addr, mp, ms, model):
    if dispatch.momentum_dependent(model):
        def impl(kind, p, t, tau, w, x, y, z, m1, m2, m3, torque_addr, mp, ms, model):
            return _kick(kind, p, t, tau, w, x, y, z, m1, m2, m3, torque_addr, mp, ms, model)
    else:
        def impl(kind, p, t, tau, w, x, y, z, m1, m2, m3, torque_addr, mp, ms, model):
            if kind != KICK:
                return w, x, y, z, m1, m2, m3, STATUS_BAD_STAGE
            return _explicit_kick(p, t, tau, w, x, y, z, m1, m2, m3, torque_addr, mp, ms, model)
    return impl


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
def _kick_or_damp(kind, p, t, tau, w, x, y, z, m1, m2, m3, torque_addr, mp, ms, model):
    """The splittings' stages other than rotations: kicks and dissipation."""
    if kind == KICK or kind == KICK_IMPLICIT:
        return kick(kind, p, t, tau, w, x, y, z, m1, m2, m3, torque_addr, mp, ms, model)
    if kind == DAMP:
        return _damp(p, tau, w, x, y, z, m1, m2, m3)
    return w, x, y, z, m1, m2, m3, STATUS_BAD_STAGE


@jit
def _any_stage(kind, axis, p, t, tau, w, x, y, z, m1, m2, m3, torque_addr, mp, ms, model,
               span=0.0):
    """Any stage kind (the generic family, for plans that mix kinds of several families);
    ``span`` is the time the clock advances during the stage."""
    if kind == AXIS:
        r = axis_flow(w, x, y, z, m1, m2, m3, axis, p[P_RATE], tau)
    elif kind == AXIS_RECURRING:
        r = axis_flow_recurring(w, x, y, z, m1, m2, m3, axis, p[P_RATE], tau)
    elif kind == AXIS_SHIFTED:  # the rotor momentum at the midpoint of the stage's clock
        r = axis_flow_shifted(w, x, y, z, m1, m2, m3, axis, p[P_RATE],
                              rotor_at(p, axis, t + 0.5 * span), tau)
    elif kind == SPHERE:
        r = sphere_flow(w, x, y, z, m1, m2, m3, p[P_RATE], tau)
    elif kind == DMV:
        return _dmv(p, tau, w, x, y, z, m1, m2, m3)
    elif kind == EXACT:
        return _exact(p, tau, w, x, y, z, m1, m2, m3)
    elif kind == EULER:
        r = euler_step(t, w, x, y, z, m1, m2, m3, p, tau, torque_addr, mp, ms, model)
    elif kind == RK4:
        r = rk4_step(t, w, x, y, z, m1, m2, m3, p, tau, torque_addr, mp, ms, model)
    elif kind == LIE_EULER:
        r = lie_euler_step(t, w, x, y, z, m1, m2, m3, p, tau, torque_addr, mp, ms, model)
    elif kind == RKMK4:
        r = rkmk4_step(t, w, x, y, z, m1, m2, m3, p, tau, torque_addr, mp, ms, model)
    else:
        return _kick_or_damp(kind, p, t, tau, w, x, y, z, m1, m2, m3, torque_addr, mp, ms, model)
    return r[0], r[1], r[2], r[3], r[4], r[5], r[6], STATUS_OK


@jit
def _baseline_torque_ok(kind, p, t, h, w, x, y, z, m1, m2, m3, torque_addr, mp, ms, model):
    """Whether the torque of a baseline step of ``kind`` from ``t`` (size ``h``) is finite
    at the step's start state, its ``q`` normalised, at the clock values the step
    evaluates it at: ``t`` (euler, lie_euler), also ``t + h/2`` and ``t + h`` (rk4,
    rkmk4; the same floating-point times).

    The baselines add the torque to the state unchecked, so a torque that fails (a time
    outside a sampled orbit's table, a user torque's NaN) shows as a non-finite state; the
    driver asks this only then (no cost to a healthy step), to report ``STATUS_TORQUE``
    as the splittings' kicks do (they see unit quaternions). ``q`` is normalised so that a
    blow-up of the baseline itself (euler's ``|q|`` grows until a torque quadratic in
    ``q`` overflows) stays a non-finite state. True for any other kind."""
    if kind != EULER and kind != LIE_EULER and kind != RK4 and kind != RKMK4:
        return True
    n2 = w * w + x * x + y * y + z * z
    if not (0.0 < n2 < math.inf):
        return True  # (no orientation to ask the torque at: the state's own failure)
    s = 1.0 / math.sqrt(n2)
    w, x, y, z = w * s, x * s, y * s, z * s
    if not _torque(p, t, w, x, y, z, m1, m2, m3, torque_addr, mp, ms, model)[3]:
        return False
    if kind == RK4 or kind == RKMK4:
        b = 0.5 * h
        if not _torque(p, t + b, w, x, y, z, m1, m2, m3, torque_addr, mp, ms, model)[3]:
            return False
        if not _torque(p, t + h, w, x, y, z, m1, m2, m3, torque_addr, mp, ms, model)[3]:
            return False
    return True


# ------------------------------------------------------------------ the loop
@jit
def _diagnose(t, w, x, y, z, m1, m2, m3, mp, ms, dref, dmax, model):
    """Update the running diagnostics ``dmax`` with the state at time ``t`` (see
    :func:`_runner`)."""
    n2 = w * w + x * x + y * y + z * z
    d1, d2, d3 = m1 - dref[10], m2 - dref[11], m3 - dref[12]  # (m - l: a gyrostat's rotor)
    T = 0.5 * (d1 * d1 * dref[0] + d2 * d2 * dref[1] + d3 * d3 * dref[2])
    V = dispatch.potential_of(model, int(dref[3]), mp, ms, t, w, x, y, z)
    e = abs(T + V - dref[6]) * dref[7]
    qe = abs(math.sqrt(n2) - 1.0)
    le = abs(math.sqrt(m1 * m1 + m2 * m2 + m3 * m3) - dref[8]) * dref[9]
    if e > dmax[0]:
        dmax[0] = e
    if qe > dmax[1]:
        dmax[1] = qe
    if le > dmax[2]:
        dmax[2] = le


def _runner(family: int, diag: bool = False):
    """The driver of one family: the loop below, for that family's stage kinds only.

    ``family`` and ``diag`` are closure constants: numba removes the branches of the
    other families before typing (so it compiles the family's stage kernels only), and
    the diagnostics when ``diag`` is false. The closure captures plain integers only,
    which numba's disk cache keys on. (The family dispatch sits in the loop body itself:
    numba's IR inlining of a shared stage function tripled the compile time, and a
    stage function per family called from the loop was not inlined by LLVM and doubled
    the cost of a torqued step.)
    """

    @jit(tag=family_tag(family, diag))
    def run(kinds, axes, coefs, clock, params, slots, merge_ends, h, t0, step0, n_steps,
            save_every, final, state, ctl, q_out, m_out, torque_addr, mp, ms, dref, dmax,
            model=(0,)):
        """Advance ``state`` (w, x, y, z, m1, m2, m3) by ``n_steps`` steps of size ``h``.

        The run may be cut into slices (calls) of any length without changing a bit of
        the result: the clock is ``t = t0 + (step0 + step) h`` with ``t0`` the run's start
        time and ``step0`` (a float) the steps done before this call, and ``ctl`` (int64,
        in place) carries across calls the steps left until the next save (``ctl[0]``,
        start a run with ``save_every``) and whether the first stage of the next step was
        already applied, merged into the last stage of this one (``ctl[1]``, start with
        0). Every ``save_every``-th
        step of the run, and the last step of the last slice (``final``), is written to
        consecutive rows of ``q_out`` / ``m_out``. ``state`` is updated in place.
        Stage ``j`` reads its parameters from row ``slots[j]`` of ``params`` (the plan's
        distinct rows, ``_plan.Plan``).
        ``torque_addr`` is the address of the user torque callback
        (``user_torque.adapt_user_torque``), 0 for none, ``mp`` and ``ms`` the torque model's
        parameters (``liebody._models``): the body's row and the block shared by every body
        (1-d arrays), and ``model`` the model's token
        (``dispatch.token(code)``: numba compiles a driver per model, holding that model's
        torque and potential only; omitted, the kernels dispatch on the stage rows' codes).

        Returns ``(steps_done, n_saved, status)``. On a non-finite state, a failed
        implicit solve or a torque that fails, the loop stops and ``state`` holds the
        last good state, the one after ``steps_done`` steps (for methods with merged end
        stages it may already contain the first stage of the failed step).

        Running diagnostics (``diag``, a compile-time constant): after every step,
        ``dmax`` (in place) keeps the largest relative energy error ``|E - E0| / scale``,
        ``| |q| - 1 |`` and relative ``| |L| - |L0| |`` seen, with ``dref`` = ``(1/I1,
        1/I2, 1/I3, code, 0, 0, E0, 1/scale, |L0|, 1/|L0|, l1, l2, l3)`` (``code``: the
        torque model whose potential the energy includes, evaluated at the step's end time;
        ``l`` a gyrostat's rotor momentum, the kinetic energy ``(m - l) I^-1 (m - l) / 2``).
        Run with ``merge_ends`` false, so that every step ends on a full step's state.
        """
        ns = kinds.shape[0]
        if slots.shape[0] != ns:
            return 0, 0, STATUS_BAD_STAGE
        for j in range(ns):  # every kind must be one the family runs, every row exist
            if kinds[j] < 0 or kinds[j] >= MEMBERS.shape[1] or not MEMBERS[family, kinds[j]]:
                return 0, 0, STATUS_BAD_STAGE
            if slots[j] < 0 or slots[j] >= params.shape[0]:
                return 0, 0, STATUS_BAD_STAGE
        w, x, y, z = state[0], state[1], state[2], state[3]
        m1, m2, m3 = state[4], state[5], state[6]
        last = ns - 1
        until_save = ctl[0]  # countdown: no integer division in the loop
        pending = ctl[1] != 0  # first stage of this step already applied
        n_saved = 0
        # the trailing parts of the state carried between a step's gyrostat turns
        # (AXIS_SHIFTED: flows.axis_flow_carried), added in at the step's end or before any
        # other stage (flows.fold_carried); zero, and carried false, between steps
        ew, ex, ey, ez, e1, e2, e3 = 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
        carried = False
        for step in range(n_steps):
            gw, gx, gy, gz, g1, g2, g3 = w, x, y, z, m1, m2, m3  # last good state
            status = STATUS_OK
            t = t0 + (step0 + step) * h  # the step's start (no accumulated rounding)
            j0 = 0
            if pending:
                j0 = 1
                t += clock[0] * h
            until_save -= 1
            save_now = until_save == 0 or (final and step == n_steps - 1)
            # the last stage also runs the next step's first one, unless the state is saved
            merge = ns > 1 and merge_ends and not save_now
            for j in range(j0, ns):
                tau = coefs[j] * h
                if j == last and merge:
                    tau = (coefs[last] + coefs[0]) * h
                kind = kinds[j]
                sj = slots[j]  # its row of params
                # (the families with AXIS_SHIFTED: the test compiles away in the others)
                if (family == F_ROTOR or family == F_ROTOR_TORQUED) and carried \
                        and kind != AXIS_SHIFTED:
                    w, x, y, z, m1, m2, m3 = fold_carried(w, x, y, z, m1, m2, m3, ew, ex, ey,
                                                          ez, e1, e2, e3)
                    ew, ex, ey, ez, e1, e2, e3 = 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
                    carried = False
                # the stage: the branches of this driver's family only survive compilation
                if family == F_AXES:
                    r = axis_flow(w, x, y, z, m1, m2, m3, axes[j], params[sj, P_RATE], tau)
                    w, x, y, z, m1, m2, m3 = r[0], r[1], r[2], r[3], r[4], r[5], r[6]
                elif (family == F_ROTATIONS or family == F_KICKED or family == F_SPLITTING
                      or family == F_ROTOR or family == F_ROTOR_TORQUED):
                    if family == F_KICKED and kind == KICK:
                        w, x, y, z, m1, m2, m3, status = _explicit_kick(
                            params[sj], t, tau, w, x, y, z, m1, m2, m3, torque_addr, mp, ms, model)
                    elif (family == F_SPLITTING or family == F_ROTOR_TORQUED) and (
                            kind == KICK or kind == KICK_IMPLICIT):
                        w, x, y, z, m1, m2, m3, status = kick(
                            kind, params[sj], t, tau, w, x, y, z, m1, m2, m3, torque_addr, mp, ms,
                            model)
                    elif (family == F_SPLITTING or family == F_ROTOR_TORQUED) and kind == DAMP:
                        w, x, y, z, m1, m2, m3, status = _damp(params[sj], tau, w, x, y, z,
                                                               m1, m2, m3)
                    elif kind == AXIS:
                        r = axis_flow(w, x, y, z, m1, m2, m3, axes[j], params[sj, P_RATE], tau)
                        w, x, y, z, m1, m2, m3 = r[0], r[1], r[2], r[3], r[4], r[5], r[6]
                    elif kind == AXIS_RECURRING:
                        r = axis_flow_recurring(w, x, y, z, m1, m2, m3, axes[j],
                                                params[sj, P_RATE], tau)
                        w, x, y, z, m1, m2, m3 = r[0], r[1], r[2], r[3], r[4], r[5], r[6]
                    elif (family == F_ROTOR or family == F_ROTOR_TORQUED) \
                            and kind == AXIS_SHIFTED:
                        # the rotor momentum at the midpoint of the stage's clock interval
                        # (exact for a rotor momentum linear in time: stages.py)
                        span = clock[j] * h
                        if j == last and merge:
                            span = (clock[last] + clock[0]) * h
                        rotor = rotor_at(params[sj], axes[j], t + 0.5 * span)
                        r = axis_flow_carried(w, x, y, z, m1, m2, m3, ew, ex, ey, ez, e1, e2,
                                              e3, axes[j], params[sj, P_RATE], rotor, tau)
                        w, x, y, z, m1, m2, m3 = r[0], r[1], r[2], r[3], r[4], r[5], r[6]
                        ew, ex, ey, ez, e1, e2, e3 = r[7], r[8], r[9], r[10], r[11], r[12], r[13]
                        if rotor != 0.0:  # (a zero rotor: the rigid body's turn, nothing carried)
                            carried = True
                    else:
                        r = sphere_flow(w, x, y, z, m1, m2, m3, params[sj, P_RATE], tau)
                        w, x, y, z, m1, m2, m3 = r[0], r[1], r[2], r[3], r[4], r[5], r[6]
                elif family == F_DMV_FREE:
                    w, x, y, z, m1, m2, m3, status = _dmv(params[sj], tau, w, x, y, z, m1, m2,
                                                          m3)
                elif family == F_DMV:
                    if kind == DMV:
                        w, x, y, z, m1, m2, m3, status = _dmv(params[sj], tau, w, x, y, z, m1,
                                                              m2, m3)
                    else:
                        w, x, y, z, m1, m2, m3, status = kick(
                            kind, params[sj], t, tau, w, x, y, z, m1, m2, m3, torque_addr, mp, ms,
                            model)
                elif family == F_EXACT:
                    if kind == EXACT:
                        w, x, y, z, m1, m2, m3, status = _exact(params[sj], tau, w, x, y, z,
                                                                m1, m2, m3)
                    else:
                        w, x, y, z, m1, m2, m3, status = _kick_or_damp(
                            kind, params[sj], t, tau, w, x, y, z, m1, m2, m3, torque_addr, mp, ms,
                            model)
                elif family == F_EULER:
                    r = euler_step(t, w, x, y, z, m1, m2, m3, params[sj], tau, torque_addr, mp, ms,
                                   model)
                    w, x, y, z, m1, m2, m3 = r[0], r[1], r[2], r[3], r[4], r[5], r[6]
                elif family == F_RK4:
                    r = rk4_step(t, w, x, y, z, m1, m2, m3, params[sj], tau, torque_addr, mp, ms,
                                 model)
                    w, x, y, z, m1, m2, m3 = r[0], r[1], r[2], r[3], r[4], r[5], r[6]
                elif family == F_LIE_EULER:
                    r = lie_euler_step(t, w, x, y, z, m1, m2, m3, params[sj], tau, torque_addr, mp,
                                       ms, model)
                    w, x, y, z, m1, m2, m3 = r[0], r[1], r[2], r[3], r[4], r[5], r[6]
                elif family == F_RKMK4:
                    r = rkmk4_step(t, w, x, y, z, m1, m2, m3, params[sj], tau, torque_addr, mp, ms,
                                   model)
                    w, x, y, z, m1, m2, m3 = r[0], r[1], r[2], r[3], r[4], r[5], r[6]
                else:
                    span = clock[j] * h
                    if j == last and merge:
                        span = (clock[last] + clock[0]) * h
                    w, x, y, z, m1, m2, m3, status = _any_stage(
                        kind, axes[j], params[sj], t, tau, w, x, y, z, m1, m2, m3, torque_addr, mp,
                        ms, model, span)
                if status != STATUS_OK:
                    break
                t += clock[j] * h
            # the step's end: its turns' trailing parts added in, once
            if (family == F_ROTOR or family == F_ROTOR_TORQUED) and carried:
                w, x, y, z, m1, m2, m3 = fold_carried(w, x, y, z, m1, m2, m3, ew, ex, ey, ez,
                                                      e1, e2, e3)
                ew, ex, ey, ez, e1, e2, e3 = 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
                carried = False
            if status == STATUS_OK:
                pending = merge
                acc = w + x + y + z + m1 + m2 + m3
                if not (abs(acc) < 1e308):
                    status = STATUS_NONFINITE
                    # a baseline step (one stage): its unchecked torque, or the dynamics?
                    if ns == 1 and (family == F_EULER or family == F_RK4 or family == F_LIE_EULER
                                    or family == F_RKMK4 or family == F_GENERAL) and not \
                            _baseline_torque_ok(kinds[0], params[slots[0]],
                                                t0 + (step0 + step) * h, coefs[0] * h, gw, gx,
                                                gy, gz, g1, g2, g3, torque_addr, mp, ms, model):
                        status = STATUS_TORQUE
            if status != STATUS_OK:
                state[0], state[1], state[2], state[3] = gw, gx, gy, gz
                state[4], state[5], state[6] = g1, g2, g3
                return step, n_saved, status
            if diag:
                _diagnose(t0 + (step0 + step + 1) * h, w, x, y, z, m1, m2, m3, mp, ms, dref,
                          dmax, model)
            if save_now:
                until_save = save_every
                q_out[n_saved, 0], q_out[n_saved, 1] = w, x
                q_out[n_saved, 2], q_out[n_saved, 3] = y, z
                m_out[n_saved, 0], m_out[n_saved, 1], m_out[n_saved, 2] = m1, m2, m3
                n_saved += 1
        state[0], state[1], state[2], state[3] = w, x, y, z
        state[4], state[5], state[6] = m1, m2, m3
        ctl[0] = until_save
        ctl[1] = 1 if pending else 0
        return n_steps, n_saved, STATUS_OK

    return run


#: family code -> its driver (compiled on first call, cached on disk)
RUNNERS = {family: _runner(family) for family in FAMILIES}
#: the same, keeping running diagnostics
DIAG_RUNNERS = {family: _runner(family, True) for family in FAMILIES}
