"""Exact flow of the free rigid body (numba, float64), for any principal moments.

The flow of ``m' = m x omega``, ``q' = (1/2) q (0, omega)``, ``omega = m / I`` (body
angular momentum ``m`` in the principal frame, unit quaternion ``q`` scalar-first,
body -> space) for a time ``t`` of either sign. The momentum follows the Jacobi
elliptic solution of Landau & Lifshitz, *Mechanics*, 3rd ed. (1976), §37, in the form
of Celledoni, Fassò, Säfström & Zanna, SIAM J. Sci. Comput. 30 (2008) 2084-2112, with
P. Leroy's corrections (sign of ``lambda``, separatrix, cancellation-free ``Delta_j``
and ``k'^2``); the orientation formula is derived in liebody's docs (it is not the
``(m, m', m x m')`` frame method of Celledoni et al.).

Derivation, formulas and accuracy study: docs/derivations.md, section "Exact free-body
flow"; sources: docs/references.md.

Kernels
-------
exact_flow(I1, I2, I3, w, x, y, z, m1, m2, m3, t) -> (w, x, y, z, m1, m2, m3)
    One state, one time; allocation-free (the per-trajectory constants live in a
    plan on the kernel's stack, :data:`plan_buffer`). Use as the ``exp(t X_T)`` stage
    of splitting methods.
exact_flow_plan(I1, I2, I3, w, x, y, z, m1, m2, m3, plan)
    Writes the per-trajectory constants into ``plan`` (float64, ``PLAN_SIZE``).
exact_flow_eval(plan, t) -> (w, x, y, z, m1, m2, m3)
    State at time ``t`` from a plan; every time independently (no accumulation).
exact_flow_times(I, q0, m0, t, q_out, m_out)
    One trajectory at many times (``I (3,)``, ``q0 (4,)``, ``m0 (3,)``, ``t (n,)``,
    ``q_out (n, 4)``, ``m_out (n, 3)``): one plan, then ``exact_flow_eval`` per row.
exact_flow_rows(I, q, m, t, q_out, m_out)
    Many independent states, each with its own time (``I (3,)``, ``q (n, 4)``,
    ``m (n, 3)``, ``t (n,)``).

Method (in brief)
-----------------
* ``m = 0``: nothing moves; ``m`` along a principal axis (the unstable intermediate
  axis included): steady rotation ``q <- q exp(t omega)``.
* spherical body (moments equal within ``SYM_RTOL``): ``q <- q exp(t m / I)``.
* symmetric body: ``q <- q exp(t m / I_perp)``, then a rotation by
  ``a = t m_s (1/I_s - 1/I_perp)`` about the symmetry axis ``e_s`` of both ``m`` and
  ``q`` (they commute). Trig functions only.
* asymmetric body (axes relabelled ``I1 < I2 < I3`` by index bookkeeping only):
  ``m_p = s_p B_p dn(u)``, ``m_2 = -B_2 sn(u)``, ``m_o = B_o cn(u)``,
  ``u = u0 + lambda G t``, about the *polar* axis ``p`` (1 if ``Delta_2 < 0``, 3 if
  ``Delta_2 > 0``, ``Delta_j = |m|^2 - 2T I_j``); ``sn, cn, dn`` from a descending
  Landen chain computed once per trajectory, the initial phase entering only through
  the addition theorems. Orientation ``q(t) = q0 a(m0) (cos Phi/2, sin Phi/2 e)
  a(m(t))^*`` with ``a`` the shortest-arc rotation from ``e = s_p e_p`` to ``m/|m|``
  and ``Phi`` a third-kind integral evaluated with one Carlson ``R_J`` per call by an
  addition theorem. The separatrix ``Delta_2 == 0`` uses ``tanh``/``sech``.

Accuracy: ~1e-15 (relative to ``|m|`` for ``m``, absolute for ``q`` up to sign) at
``|omega t| ~ 10`` in every regime, growing only as the phase error ``|omega t| eps``
(checked against 34-digit mpmath in tests/test_exact_flow.py). A short step
(``sn^2(lambda G t) <= 1/4``, e.g. a splitting's drift between kicks) is formed in
increment form, ``m0 + dm`` and ``q0 + q0 (r - 1)`` with the changes computed without
cancellation (:func:`_increment`): measured against a 40-digit Taylor solution, one
step errs by at most 0.6 ulp in rotation and 0.35 ulp of ``|m|`` in momentum (0.15 ulp
rms; the direct formula: up to 2.6 ulp), and the errors are unbiased, so that ``|m|``,
the energy and ``|q|`` walk as ``sqrt(steps)`` when the flow is stepped
(tests/kernels/test_exact_roundoff.py). Cost of one
:func:`exact_flow` call on an asymmetric body: one Landen chain, one Carlson ``R_J``,
two ``atan2``, two ``sin``/``cos`` pairs and ~200 flops; :func:`exact_flow_times`
computes the plan once and then only the per-time part. Measured times:
bench/README.md.
"""

from __future__ import annotations

import math

import numpy as np

from liebody._kernels._jit import jit

from .elliptic import carlson_rf, carlson_rj, landen_chain_into, landen_eval_at, landen_k_at
from .flows import recurring_exp, recurring_turn
from .quat import component, qaxis_rotation, qmul, qmul_increment

#: The kernel's own round-off guard for raw moments: within 4 ulps the symmetric-body
#: branch is taken (it then errs by ~SYM_RTOL |omega t|, below the t*eps phase error).
#: Bodies built through RigidBody have equal moments made exactly equal (the one
#: equal-moments policy of liebody.rigid_body), so they never sit in this window.
SYM_RTOL = 4.0 * 2.0**-52

# plan layout -------------------------------------------------------------------------
# head (39 floats), then the Landen chain: ks (16), kcs (16)
_KIND, _G, _QW, _QX, _QY, _QZ, _M1, _M2, _M3 = 0, 1, 2, 3, 4, 5, 6, 7, 8
# kinds
K_NONE, K_STEADY, K_SYMMETRIC, K_ELLIPTIC, K_SEPARATRIX = 0.0, 1.0, 2.0, 3.0, 4.0
# elliptic / separatrix slots (9..38); steady: 9..11 = omega; symmetric: 9..11 =
# m0/I_perp, 12 = symmetry axis, 13 = rate m_s (1/I_s - 1/I_perp)
(_IP, _I2, _IO, _SP, _EPS, _LAMG, _WP, _CL, _BP, _B2, _BO, _SO, _K2, _KC2, _K, _KC, _N,
 _RN1, _KAPPA, _GAMMA, _S0, _C0, _D0, _PIC, _QP0, _QP1, _QP2, _QP3, _NLEV, _KQ) = range(9, 39)
HEAD_SIZE = 39
_KS = HEAD_SIZE
_KCS = HEAD_SIZE + 16
#: Length of a plan array (float64).
PLAN_SIZE = HEAD_SIZE + 32


def _plan_buffer_py():
    """:func:`plan_buffer` for the uncompiled kernels."""
    return np.empty(PLAN_SIZE)


def _plan_buffer_intrinsic():
    from numba import types
    from numba.core import cgutils
    from numba.extending import intrinsic
    from numba.np.arrayobj import make_array, populate_array

    plan_type = types.Array(types.float64, 1, "C")

    @intrinsic
    def plan_buffer(typingctx):
        """A plan (``PLAN_SIZE`` float64, uninitialised) on the calling kernel's stack,
        as an array without a memory owner: no allocation, no reference count. It lives
        as long as that kernel's call, so it must not be returned or stored."""

        def codegen(context, builder, signature, args):
            data = cgutils.alloca_once(builder, context.get_value_type(types.float64),
                                       size=PLAN_SIZE)
            ary = make_array(plan_type)(context, builder)
            intp = context.get_value_type(types.intp)
            populate_array(ary, data=data, shape=[intp(PLAN_SIZE)], strides=[intp(8)],
                           itemsize=intp(8), meminfo=None)
            return ary._getvalue()

        return plan_type(), codegen

    return plan_buffer


def _make_plan_buffer():
    from numba.core import config

    return _plan_buffer_py if config.DISABLE_JIT else _plan_buffer_intrinsic()


#: ``plan_buffer()``: the exact flow's plan on the stack of the calling kernel (one
#: compiled :func:`_plan` and :func:`_eval` for every caller, and no allocation per
#: :func:`exact_flow` call); ``np.empty`` when numba's JIT is off.
plan_buffer = _make_plan_buffer()


@jit(inner=True)
def _cross_axis(ax, x, y, z):
    """``e_ax x (x, y, z)``."""
    if ax == 0:
        return 0.0, -z, y
    elif ax == 1:
        return z, 0.0, -x
    return -y, x, 0.0


@jit(inner=True)
def _steady(p, o1, o2, o3):
    """A steady rotation at the rate ``omega = (o1, o2, o3)`` into the plan ``p``."""
    p[_KIND] = K_STEADY
    p[9] = o1
    p[10] = o2
    p[11] = o3


@jit(inner=True)
def _plan(I1, I2, I3, qw, qx, qy, qz, m1, m2, m3, full, p):
    """Per-trajectory constants into the plan ``p`` (``PLAN_SIZE``); docs/derivations.md,
    "Exact free-body flow".

    ``full`` (1.0 or 0.0, a float so that both callers share one compiled version) also
    computes the complete ``Pi(n | k^2)`` and ``K(k)`` (else left NaN and computed on
    demand, only when ``|lambda t| > K``). Unused slots are 0, an unused Landen chain
    ``k = 0``, ``k' = 1``.
    """
    for i in range(9, HEAD_SIZE):
        p[i] = 0.0
    for i in range(16):
        p[_KS + i] = 0.0
        p[_KCS + i] = 1.0
    p[_KIND] = K_NONE
    p[_G] = 0.0
    p[_QW] = qw
    p[_QX] = qx
    p[_QY] = qy
    p[_QZ] = qz
    p[_M1] = m1
    p[_M2] = m2
    p[_M3] = m3
    amax = max(abs(m1), abs(m2), abs(m3))
    if amax == 0.0:
        return
    g = amax * math.sqrt((m1 / amax) ** 2 + (m2 / amax) ** 2 + (m3 / amax) ** 2)
    p[_G] = g
    # along a principal axis (two components exactly zero): steady rotation
    nz = 0  # (explicit count: numpy bools would OR under NUMBA_DISABLE_JIT)
    if m1 != 0.0:
        nz += 1
    if m2 != 0.0:
        nz += 1
    if m3 != 0.0:
        nz += 1
    if nz == 1:
        _steady(p, m1 / I1, m2 / I2, m3 / I3)
        return
    imax = max(I1, I2, I3)
    tol = SYM_RTOL * imax
    e12 = abs(I1 - I2) <= tol
    e13 = abs(I1 - I3) <= tol
    e23 = abs(I2 - I3) <= tol
    if (e12 and e13) or (e12 and e23) or (e13 and e23):
        ia = (I1 + I2 + I3) / 3.0
        _steady(p, m1 / ia, m2 / ia, m3 / ia)
        return
    if e12 or e13 or e23:
        if e12:
            ax, ip_, is_ = 2, 0.5 * (I1 + I2), I3
        elif e13:
            ax, ip_, is_ = 1, 0.5 * (I1 + I3), I2
        else:
            ax, ip_, is_ = 0, 0.5 * (I2 + I3), I1
        ms = component(ax, m1, m2, m3)
        p[_KIND] = K_SYMMETRIC
        p[9] = m1 / ip_
        p[10] = m2 / ip_
        p[11] = m3 / ip_
        p[12] = float(ax)
        p[13] = ms * (1.0 / is_ - 1.0 / ip_)
        return
    # ---- asymmetric body: relabel I_a < I_b < I_c (index bookkeeping only) ----
    if I1 < I2:
        if I2 < I3:
            i1, i2, i3 = 0, 1, 2
        elif I1 < I3:
            i1, i2, i3 = 0, 2, 1
        else:
            i1, i2, i3 = 2, 0, 1
    else:
        if I1 < I3:
            i1, i2, i3 = 1, 0, 2
        elif I2 < I3:
            i1, i2, i3 = 1, 2, 0
        else:
            i1, i2, i3 = 2, 1, 0
    eps = 1.0 if (i2 - i1) % 3 == 1 else -1.0  # cyclic (even) permutation or not
    A1 = component(i1, I1, I2, I3)
    A2 = component(i2, I1, I2, I3)
    A3 = component(i3, I1, I2, I3)
    x1 = component(i1, m1, m2, m3) / g
    x2 = eps * component(i2, m1, m2, m3) / g
    x3 = component(i3, m1, m2, m3) / g
    I21 = A2 - A1
    I31 = A3 - A1
    I32 = A3 - A2
    D1 = x2 * x2 * (I21 / A2) + x3 * x3 * (I31 / A3)  # Delta_1 >= 0
    D3 = x1 * x1 * (I31 / A1) + x2 * x2 * (I32 / A2)  # -Delta_3 >= 0
    D2 = x3 * x3 * (I32 / A3) - x1 * x1 * (I21 / A1)  # Delta_2
    if D1 <= 1e-290 or D3 <= 1e-290:
        # within ~1e-145 of the smallest/largest axis: steady rotation to round-off
        _steady(p, m1 / I1, m2 / I2, m3 / I3)
        return
    if D2 <= 0.0:  # case (i), polar axis = smallest moment (and the separatrix)
        ipc, ioc, Ip, Io, Dp, Do, I2p, Io2, xp, xo = i1, i3, A1, A3, D1, D3, I21, I32, x1, x3
    else:  # case (ii), polar axis = largest moment
        ipc, ioc, Ip, Io, Dp, Do, I2p, Io2, xp, xo = i3, i1, A3, A1, D3, D1, I32, I21, x3, x1
    sp = 1.0 if xp >= 0.0 else -1.0
    so = 1.0 if xo >= 0.0 else -1.0
    bp = math.sqrt(Ip * Do / I31)
    bo = math.sqrt(Io * Dp / I31)
    b2 = math.sqrt(A2 * Dp / I2p)
    lam_abs = math.sqrt(I2p * Do / (A1 * A2 * A3))
    n = -(Ip * Io2) / (Io * I2p)
    cc = 1.0 / Ip - 1.0 / Io
    rn1 = math.sqrt(1.0 - n)
    # a(m0) and QPRE = q0 a(m0)
    apw = 1.0 + abs(xp)
    cx, cy, cz = _cross_axis(ipc, m1 / g, m2 / g, m3 / g)
    sc = 1.0 / math.sqrt(2.0 * apw)
    qp = qmul(qw, qx, qy, qz, apw * sc, sp * cx * sc, sp * cy * sc, sp * cz * sc)
    p[_IP] = float(ipc)
    p[_I2] = float(i2)
    p[_IO] = float(ioc)
    p[_SP] = sp
    p[_EPS] = eps
    p[_WP] = g / Ip
    p[_BP] = bp
    p[_B2] = b2
    p[_BO] = bo
    p[_SO] = so
    p[_N] = n
    p[_RN1] = rn1
    p[_QP0] = qp[0]
    p[_QP1] = qp[1]
    p[_QP2] = qp[2]
    p[_QP3] = qp[3]
    if D2 == 0.0:
        # separatrix: sn = tanh, cn = dn = sech; u0 from sinh u0 = sn0 / cn0
        lam = -sp * so * lam_abs
        s0 = -x2 / b2
        c0 = abs(xo) / bo
        p[_KIND] = K_SEPARATRIX
        p[_LAMG] = lam * g
        p[_CL] = cc / lam
        p[_K2] = 1.0
        p[_K] = 1.0
        p[_S0] = math.asinh(s0 / c0) if c0 > 0.0 else math.copysign(745.0, s0)  # u0
        return
    k2 = Dp * Io2 / (I2p * Do)
    kc2 = abs(D2) * I31 / (Do * I2p)
    ssum = k2 + kc2  # = 1 up to round-off; make the pair consistent
    k2 /= ssum
    kc2 /= ssum
    k = math.sqrt(k2)
    kc = math.sqrt(kc2)
    lam = -sp * lam_abs
    s0 = -x2 / b2
    c0 = xo / bo
    r = math.sqrt(s0 * s0 + c0 * c0)
    p[_KIND] = K_ELLIPTIC
    p[_LAMG] = lam * g
    p[_CL] = cc / lam
    p[_K2] = k2
    p[_KC2] = kc2
    p[_K] = k
    p[_KC] = kc
    p[_KAPPA] = math.sqrt(-n / ((1.0 - n) * (k2 - n)))
    p[_GAMMA] = math.sqrt(-n * (1.0 - n) * (k2 - n))
    p[_S0] = s0 / r
    p[_C0] = c0 / r
    p[_D0] = min(abs(xp) / bp, 1.0)
    p[_NLEV] = float(landen_chain_into(k, kc, p, _KS, _KCS))
    if full != 0.0:
        kq = carlson_rf(0.0, kc2, 1.0)
        p[_KQ] = kq
        p[_PIC] = kq + n / 3.0 * carlson_rj(0.0, kc2, 1.0, 1.0 - n)
    else:
        p[_KQ] = math.nan
        p[_PIC] = math.nan


@jit(inner=True)
def _place(h, xp, x2, xo):
    """The internal (polar, mid, other) components in the caller's axes."""
    ipc = int(h[_IP])
    i2 = int(h[_I2])
    if ipc == 0:
        v0 = xp
        v1, v2 = (h[_EPS] * x2, xo) if i2 == 1 else (xo, h[_EPS] * x2)
    elif ipc == 1:
        v1 = xp
        v0, v2 = (h[_EPS] * x2, xo) if i2 == 0 else (xo, h[_EPS] * x2)
    else:
        v2 = xp
        v0, v1 = (h[_EPS] * x2, xo) if i2 == 0 else (xo, h[_EPS] * x2)
    return v0, v1, v2


@jit(inner=True)
def _finish(h, phi, xp, x2, xo):
    """Map the internal unit momentum back to the caller's frame and build ``q``."""
    g = h[_G]
    ipc = int(h[_IP])
    sp = h[_SP]
    v0, v1, v2 = _place(h, xp, x2, xo)
    # q = QPRE (cos Phi/2, sin Phi/2 e) a(m)^*
    sh = math.sin(0.5 * phi)
    ch = math.cos(0.5 * phi)
    rw, rx, ry, rz = qaxis_rotation(h[_QP0], h[_QP1], h[_QP2], h[_QP3], ipc, sp * sh, ch)
    apw = 1.0 + abs(xp)
    cx, cy, cz = _cross_axis(ipc, v0, v1, v2)
    sc = 1.0 / math.sqrt(2.0 * apw)
    w, x, y, z = qmul(rw, rx, ry, rz, apw * sc, -sp * cx * sc, -sp * cy * sc, -sp * cz * sc)
    return w, x, y, z, g * v0, g * v1, g * v2


@jit(inner=True)
def _increment(h, s, c, d, vr, t):
    """State at time ``t`` in increment form, for a short step.

    ``(s, c, d)`` are ``sn, cn, dn`` of ``vr = lambda G t``, unreduced (``j = 0``), with
    ``sn^2 <= 1/4``: then ``cn >= 0.86`` and the addition theorems' denominator
    ``dn0^2 + k^2 sn0^2 cn^2 = 1 - k^2 sn0^2 sn^2`` is at least 3/4, so the second form
    loses nothing (near the saddle, where ``dn0`` is small, the first form is needed
    once ``cn`` is small too: :func:`_eval` keeps it for longer steps).
    The step is formed as a change and added once to the state it starts from:

    * momentum: ``m(t) = m0 + G (Delta x)`` with the change of ``(sn, cn, dn)`` at
      ``u0 + vr`` from the addition theorems (DLMF 22.8.1-22.8.3) rewritten, with
      ``1 - cn = sn^2 / (1 + cn)``, ``1 - dn = k^2 sn^2 / (1 + dn)`` and the denominator
      ``1 - k^2 sn0^2 sn^2``, so that no term cancels: each change is a sum of terms of
      its own size;
    * orientation: ``q(t) = q0 a(m0) R(Phi) a(m(t))^* = q0 r1 r2`` with
      ``r1 = a(m0) R(Phi) a(m0)^* = (cos Phi/2, sin Phi/2 m0/|m0|)`` and
      ``r2 = a(m0) a(m(t))^*``, the product of the two shortest arcs (unnormalised
      ``A(m) = (1 + e.m, e x m)``: ``A0 A1^*`` has the vector part
      ``-w0 (e x dm) + (e.dm) v0 - v0 x (e x dm)``, linear in the change ``dm``), and
      ``q(t) = q0 + q0 (r1 r2 - 1)`` with ``r_i - 1`` formed to full relative accuracy
      (:func:`~liebody._kernels.quat.qmul_increment`).

    The errors are then a few ulps *of the change*, plus one rounding of each
    component when the change is added: unbiased, so a stepped exact flow drifts as a
    random walk (``sqrt(steps)``) instead of linearly. The formulas are those of
    :func:`_eval` (docs/derivations.md, "Exact free-body flow"), regrouped.
    """
    k2 = h[_K2]
    n = h[_N]
    s0 = h[_S0]
    c0 = h[_C0]
    d0 = h[_D0]
    ss = s * s
    cm = ss / (1.0 + c)  # 1 - cn
    dm = k2 * ss / (1.0 + d)  # 1 - dn
    a = k2 * s0 * s0 * ss
    inv = 1.0 / (1.0 - a)  # 1 / (dn0^2 + k^2 sn0^2 cn^2)
    ds = (s0 * ((a - cm) - dm * (1.0 - cm)) + s * c0 * d0) * inv
    dc = (c0 * (a - cm) - s0 * s * d0 * d) * inv
    dd = (d0 * (a - dm) - k2 * s0 * s * c0 * c) * inv
    s1 = s0 + ds
    c1 = c0 + dc
    d1 = d0 + dd
    # the angle Phi, as in _eval (j = 0), with sn1 cn0 - cn1 sn0 = ds cn0 - dc sn0
    pv = vr
    if s != 0.0:
        pv += n / 3.0 * ss * s * carlson_rj(c * c, d * d, 1.0, 1.0 - n * ss)
    dp = pv - h[_KAPPA] * math.atan2(h[_GAMMA] * s0 * s * s1,
                                     1.0 - n * s1 * s1 + n * s0 * s * c1 * d1)
    rn1 = h[_RN1]
    dpsi = math.atan2(rn1 * (ds * c0 - dc * s0), c1 * c0 + (1.0 - n) * s1 * s0)
    bp = h[_BP]
    phi = h[_WP] * t - h[_CL] * (dp - bp / rn1 * dpsi)
    # the momentum: the change of the unit vector, in the caller's axes
    g = h[_G]
    sp = h[_SP]
    u0, u1, u2 = _place(h, sp * bp * dd, -h[_B2] * ds, h[_BO] * dc)
    m1, m2, m3 = h[_M1], h[_M2], h[_M3]
    e0, e1, e2 = m1 / g, m2 / g, m3 / g  # m0 / |m0|
    # r2 = a(m0) a(m1)^*: A = (1 + e.m, e x m) with e = sp e_p
    ipc = int(h[_IP])
    w0 = 1.0 + sp * component(ipc, e0, e1, e2)
    vx, vy, vz = _cross_axis(ipc, e0, e1, e2)
    vx, vy, vz = sp * vx, sp * vy, sp * vz
    dw = sp * component(ipc, u0, u1, u2)
    dx, dy, dz = _cross_axis(ipc, u0, u1, u2)
    dx, dy, dz = sp * dx, sp * dy, sp * dz
    bx = -w0 * dx + dw * vx - (vy * dz - vz * dy)
    by = -w0 * dy + dw * vy - (vz * dx - vx * dz)
    bz = -w0 * dz + dw * vz - (vx * dy - vy * dx)
    bw = w0 * (w0 + dw) + (vx * (vx + dx) + vy * (vy + dy) + vz * (vz + dz))
    nb = 1.0 / math.sqrt(bw * bw + (bx * bx + by * by + bz * bz))
    bx, by, bz = bx * nb, by * nb, bz * nb
    bm = -(bx * bx + by * by + bz * bz) / (1.0 + bw * nb)  # r2 - 1, scalar part
    # r1 = (cos Phi/2, sin Phi/2 e0)
    half = 0.5 * phi
    sh = math.sin(half)
    am = -sh * sh / (1.0 + math.cos(half))  # cos(Phi/2) - 1
    ax, ay, az = sh * e0, sh * e1, sh * e2
    # r1 r2 - 1 = (r1 - 1) + (r2 - 1) + (r1 - 1)(r2 - 1)
    rm = am + bm + (am * bm - (ax * bx + ay * by + az * bz))
    rx = ax + bx + (am * bx + bm * ax + (ay * bz - az * by))
    ry = ay + by + (am * by + bm * ay + (az * bx - ax * bz))
    rz = az + bz + (am * bz + bm * az + (ax * by - ay * bx))
    w, x, y, z = qmul_increment(h[_QW], h[_QX], h[_QY], h[_QZ], rm, rx, ry, rz)
    return w, x, y, z, m1 + g * u0, m2 + g * u1, m3 + g * u2


@jit(inner=True)
def _eval(h, t):
    """State at time ``t`` from the plan ``h``."""
    kind = h[_KIND]
    if kind == K_ELLIPTIC:
        dl = h[_LAMG] * t
        k2 = h[_K2]
        n = h[_N]
        nlev = int(h[_NLEV])
        kq = h[_KQ]
        if kq != kq:  # not in the plan: the chain product suffices unless |dl| > K
            kq = landen_k_at(h[_K], nlev, h, _KS)
            if abs(dl) > kq:
                kq = carlson_rf(0.0, h[_KC2], 1.0)
        s, c, d, j, kq = landen_eval_at(dl, h[_K], h[_KC], nlev, h, _KS, h, _KCS, kq)
        vr = dl - 2.0 * j * kq
        if j == 0.0 and s * s <= 0.25:  # a short step (a splitting's): increment form
            return _increment(h, s, c, d, vr, t)
        s0 = h[_S0]
        c0 = h[_C0]
        d0 = h[_D0]
        # addition theorems: (s1, c1, d1) at u0 + vr
        inv = 1.0 / (d0 * d0 + k2 * s0 * s0 * c * c)
        s1 = (s0 * c * d + s * c0 * d0) * inv
        c1 = (c0 * c - s0 * s * d0 * d) * inv
        d1 = (d0 * d - k2 * s0 * s * c0 * c) * inv
        # P(vr) - [P(u0) + P(vr) - P(u0 + vr)]
        pv = vr
        if s != 0.0:
            ss = s * s
            pv += n / 3.0 * ss * s * carlson_rj(c * c, d * d, 1.0, 1.0 - n * ss)
        ss0 = s0 * s
        dp = pv - h[_KAPPA] * math.atan2(h[_GAMMA] * ss0 * s1,
                                         1.0 - n * s1 * s1 + n * ss0 * c1 * d1)
        rn1 = h[_RN1]
        dpsi = math.atan2(rn1 * (s1 * c0 - c1 * s0), c1 * c0 + (1.0 - n) * s1 * s0)
        if j != 0.0:
            pic = h[_PIC]
            if pic != pic:
                pic = kq + n / 3.0 * carlson_rj(0.0, h[_KC2], 1.0, 1.0 - n)
            dp += 2.0 * j * pic
            dpsi += j * math.pi
            if j % 2.0 != 0.0:
                s1 = -s1
                c1 = -c1
        bp = h[_BP]
        phi = h[_WP] * t - h[_CL] * (dp - bp / rn1 * dpsi)
        return _finish(h, phi, h[_SP] * bp * d1, -h[_B2] * s1, h[_BO] * c1)
    if kind == K_SEPARATRIX:
        dl = h[_LAMG] * t
        u0 = h[_S0]
        u1 = u0 + dl
        n = h[_N]
        rn = math.sqrt(-n)
        rn1 = h[_RN1]
        e = math.exp(-abs(u1))
        sech = 2.0 * e / (1.0 + e * e)
        th = math.tanh(u1)
        dp = (dl + rn * (math.atan(rn * th) - math.atan(rn * math.tanh(u0)))) / (1.0 - n)
        # (sinh clipped at |u| = 700: atan has saturated to pi/2 to round-off long before)
        dpsi = (math.atan(rn1 * math.sinh(max(-700.0, min(700.0, u1))))
                - math.atan(rn1 * math.sinh(max(-700.0, min(700.0, u0)))))
        bp = h[_BP]
        phi = h[_WP] * t - h[_CL] * (dp - bp / rn1 * dpsi)
        return _finish(h, phi, h[_SP] * bp * sech, -h[_B2] * th, h[_SO] * h[_BO] * sech)
    qw, qx, qy, qz = h[_QW], h[_QX], h[_QY], h[_QZ]
    m1, m2, m3 = h[_M1], h[_M2], h[_M3]
    if kind == K_STEADY or kind == K_SYMMETRIC:
        # q exp(t omega), then (symmetric body) the turn about the symmetry axis that
        # takes m along, both in increment form: stepped in a splitting the same
        # rotations recur, and the direct products' rounding drifted |q| linearly
        # (4e-17 per step)
        w, x, y, z = recurring_exp(qw, qx, qy, qz, t * h[9], t * h[10], t * h[11])
        if kind == K_STEADY:
            return w, x, y, z, m1, m2, m3
        return recurring_turn(w, x, y, z, m1, m2, m3, int(h[12]), 0.5 * (h[13] * t))
    return qw, qx, qy, qz, m1, m2, m3


@jit
def exact_flow(I1, I2, I3, w, x, y, z, m1, m2, m3, t):
    """Exact free-rigid-body flow of one state for time ``t`` (any sign, any size).

    Parameters
    ----------
    I1, I2, I3 : float
        Principal moments of inertia in the caller's body axes (any order, > 0; any two
        may be equal).
    w, x, y, z : float
        Unit quaternion (scalar first, body -> space).
    m1, m2, m3 : float
        Body angular momentum.
    t : float
        Time.

    Returns
    -------
    tuple of float
        ``(w, x, y, z, m1, m2, m3)`` at time ``t``. ``|m|`` and the spatial angular
        momentum are preserved to round-off; ``q`` keeps the norm of the input and is
        continuous in ``t`` (equals the input at ``t = 0``).

    Notes
    -----
    Regimes and formulas: the module docstring and docs/derivations.md, section "Exact
    free-body flow" (Landau & Lifshitz §37; Celledoni et al. 2008 with Leroy's
    corrections). Costs one Landen chain (4-9 ``sqrt``), one ``sin``/``cos`` pair, one
    Carlson ``R_J``, two ``atan2``, one more ``sin``/``cos`` pair and ~200 flops (plus
    one ``R_F`` and one ``R_J`` when ``|lambda t| > K``); trig only for symmetric
    bodies. Measured times: bench/README.md.
    """
    plan = plan_buffer()
    _plan(I1, I2, I3, w, x, y, z, m1, m2, m3, 0.0, plan)
    return _eval(plan, t)


@jit
def exact_flow_plan(I1, I2, I3, w, x, y, z, m1, m2, m3, plan):
    """Per-trajectory constants of :func:`exact_flow` into ``plan`` (float64, ``PLAN_SIZE``).

    Layout: ``plan[0]`` kind (0 none, 1 steady/spherical, 2 symmetric, 3 elliptic,
    4 separatrix), ``plan[1]`` ``|m|``, ``plan[2:6]`` ``q0``, ``plan[6:9]`` ``m0``;
    for kinds 3/4 ``plan[9:39]`` = polar/mid/other caller axis indices, ``s_p``, ``eps``,
    ``lambda G``, ``G/I_p``, ``c/lambda``, ``B_p, B_2, B_o``, ``s_o``, ``k^2, k'^2, k, k'``,
    ``n``, ``sqrt(1-n)``, ``kappa``, ``gamma``, ``(sn, cn, dn)(u0)`` (``u0`` for kind 4),
    complete ``Pi(n|k^2)``, ``q0 a(m0)`` (4), Landen depth ``N``, ``K(k)``;
    ``plan[39:55]`` the Landen moduli ``k_1..k_16``, ``plan[55:71]`` ``k'_0..k'_15``
    (``PLAN_SIZE = 71``). Kind 1: ``plan[9:12] = omega``; kind 2: ``plan[9:12] =
    m0/I_perp``, ``plan[12]`` symmetry axis, ``plan[13]`` rate ``m_s (1/I_s - 1/I_perp)``.
    """
    _plan(I1, I2, I3, w, x, y, z, m1, m2, m3, 1.0, plan)
    return plan


@jit
def exact_flow_eval(plan, t):
    """State ``(w, x, y, z, m1, m2, m3)`` at time ``t`` from a plan (:func:`exact_flow_plan`)."""
    return _eval(plan, t)


@jit
def exact_flow_times(I, q0, m0, t, q_out, m_out):
    """One trajectory at many times: ``q_out[i], m_out[i]`` = flow of ``(q0, m0)`` for ``t[i]``.

    The constants (case, modulus, Landen chain, ``lambda``, phase, amplitudes, complete
    ``Pi``, frame quaternion) are computed once; each time is then evaluated
    independently (no accumulation) and costs only the per-time part of
    :func:`exact_flow` (no Landen chain). Measured times: bench/README.md.
    """
    plan = plan_buffer()
    _plan(I[0], I[1], I[2], q0[0], q0[1], q0[2], q0[3], m0[0], m0[1], m0[2], 1.0, plan)
    for i in range(t.shape[0]):
        r = _eval(plan, t[i])
        q_out[i, 0], q_out[i, 1], q_out[i, 2], q_out[i, 3] = r[0], r[1], r[2], r[3]
        m_out[i, 0], m_out[i, 1], m_out[i, 2] = r[4], r[5], r[6]
    return t.shape[0]  # a count, not the arrays: returning arrays calls back into Python


@jit
def exact_flow_rows(I, q, m, t, q_out, m_out):
    """Independent states: row ``i`` of ``(q, m)`` advanced by ``t[i]`` (same body ``I``)."""
    for i in range(t.shape[0]):
        r = exact_flow(I[0], I[1], I[2], q[i, 0], q[i, 1], q[i, 2], q[i, 3],
                       m[i, 0], m[i, 1], m[i, 2], t[i])
        q_out[i, 0], q_out[i, 1], q_out[i, 2], q_out[i, 3] = r[0], r[1], r[2], r[3]
        m_out[i, 0], m_out[i, 1], m_out[i, 2] = r[4], r[5], r[6]
    return t.shape[0]  # a count, not the arrays: returning arrays calls back into Python


@jit
def exact_flow_bodies(I, q0, m0, t, q_out, m_out, status):
    """Many bodies at many times: ``q_out[i, k], m_out[i, k]`` = flow of body ``i`` for ``t[k]``.

    ``I``, ``q0``, ``m0`` ``(N, 3)``, ``(N, 4)``, ``(N, 3)``; ``t`` ``(K,)``; ``status``
    ``(N,)`` int64: a body whose status is not 0 is skipped, and a body whose samples
    become non-finite gets the index of its first non-finite sample plus one (so the
    caller can keep the samples before it). Returns the number of bodies that failed.
    """
    failed = 0
    for i in range(q0.shape[0]):
        if status[i] != 0:
            continue
        exact_flow_times(I[i], q0[i], m0[i], t, q_out[i], m_out[i])
        for k in range(t.shape[0]):
            acc = (q_out[i, k, 0] + q_out[i, k, 1] + q_out[i, k, 2] + q_out[i, k, 3]
                   + m_out[i, k, 0] + m_out[i, k, 1] + m_out[i, k, 2])
            if not (abs(acc) < 1e308):
                status[i] = k + 1
                failed += 1
                break
    return failed

