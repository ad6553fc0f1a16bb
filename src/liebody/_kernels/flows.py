"""One-step maps of the free rigid body (numba, float64 scalars, no allocation).

State: orientation ``q = (w, x, y, z)`` (body -> space) and body angular momentum
``m = (m1, m2, m3)``; ``omega = m / I``. Equations: ``m' = m x omega``,
``q' = q (0, omega) / 2``. Every map takes and returns the state as scalars, so the
driver keeps it in registers.

Sources (full references: docs/references.md): the axis sub-flows of McLachlan,
Phys. Rev. Lett. 71 (1993) 3043, Reich (1994), Touma & Wisdom, Astron. J. 107 (1994)
1189, and Dullweber, Leimkuhler & McLachlan, J. Chem. Phys. 107 (1997) 5840; the
symmetric-body + rotation splitting and the quaternion form of the discrete
Moser–Veselov step of Hairer & Vilmart, J. Phys. A 39 (2006) 13225 (Moser & Veselov,
Commun. Math. Phys. 139 (1991) 217); the Lie-group baselines of Crouch & Grossman (1993)
and Munthe-Kaas, BIT 38 (1998) 92. The failure modes of the baselines are derived in
their docstrings.
"""

from __future__ import annotations

import math

from liebody._kernels._jit import jit
from liebody._kernels.quat import (
    _two_sum,
    component,
    increment_defect,
    qexp,
    qexp_increment,
    qmul,
    qmul_increment,
    qproject_unit,
    qrotate_inv,
    qunit_increment,
)
from liebody._kernels.stages import (
    P_EPS,
    P_I1,
    P_I2,
    P_I3,
    P_L1,
    P_L2,
    P_L3,
    P_LD1,
    P_LD2,
    P_LD3,
    P_LT,
    P_TORQUE,
    TORQUE_NONE,
)
from liebody._kernels.torque import damping_rate, torque_value
from liebody._kernels.trig import fma, inline_into_callers, sincos_small, sincos_turn

#: a recurring rotation whose squared half angle is at least this (a turn of 1 rad or more
#: per step) keeps ``q`` on the unit sphere (``qproject_unit``); below, the increment
#: form's norm error is of order ``eps sin^2`` per step, the figures of the long-horizon
#: benchmark, and the hot paths of tops and symmetric bodies pay nothing more
LARGE_INCREMENT = 0.25
#: the gyrostat's axis turn (:func:`axis_flow_shifted`) is evaluated error-free from this
#: squared half angle on (a turn of 0.2 rad or more), where the increment's own rounding,
#: about ``2 |half|`` ulps, is no longer small against the sum's
COMPENSATED_TURN = 0.01
#: the gyrostat's axis turn scales ``q`` onto the unit sphere once the computed
#: ``| |q|^2 - 1 |`` passes this (a few ulps: the sum's own rounding stays below it)
UNIT_SLACK = 1e-15
#: DMV iteration limits
DMV_MAX_FIXED_POINT = 60
DMV_MAX_NEWTON = 30
DMV_CONTINUATION = 32


@jit(inline="always")
def axis_flow(w, x, y, z, m1, m2, m3, axis, rate, tau):
    """Exact flow of ``H_k = rate * m_k^2 / 2`` for time ``tau`` (``k = axis``).

    ``m_k`` is constant; ``m`` turns by ``-theta`` and ``q`` by ``+theta`` about body axis
    ``e_k``, ``theta = tau * rate * m_k``. With ``rate = 1/I_k`` this is the exact
    sub-flow of the kinetic-energy term ``T_k`` (McLachlan 1993; Reich 1994). Keeps
    ``|m|``, spatial ``L = R(q) m`` exactly and ``|q|`` to round-off.

    Applied in increment form, ``x + ((cos - 1) x + sin y)``: near a steady rotation the
    same small angle recurs step after step, and the plain form's ``cos``, rounded to the
    grid near 1, drifted ``|q|`` and ``|m|`` linearly (3.4e-11 per 1e6 steps). A small
    turn (``|half| < 0.1``) takes ``(sin, cos, cos - 1)`` from the polynomial
    :func:`~liebody._kernels.trig.sincos_turn` (no libm call; its pair's norm error,
    ``eps sin^2``, is far below round-off), a larger one libm's sin and cos.
    """
    return _rigid_turn(w, x, y, z, m1, m2, m3, axis,
                       0.5 * tau * rate * component(axis, m1, m2, m3))


@jit(inline="always")
def _rigid_turn(w, x, y, z, m1, m2, m3, axis, half):
    """:func:`axis_flow`'s turn by ``2 half``, in increment form (a large one from libm's
    sin and cos)."""
    if half * half < COMPENSATED_TURN:
        s2, c2, cm2 = sincos_turn(half)
    else:
        s2 = math.sin(half)
        c2 = math.cos(half)
        cm2 = c2 - 1.0
    return _turn_increment(w, x, y, z, m1, m2, m3, axis, s2, c2, cm2)


@jit
def axis_flow_shifted(w, x, y, z, m1, m2, m3, axis, rate, shift, tau):
    """Exact flow of ``H_k = rate * (m_k - shift)^2 / 2``: the gyrostat's axis term, ``shift``
    the rotor momentum ``l_k`` (body frame).

    ``m_k`` is constant; ``m`` and ``q`` turn as in :func:`axis_flow` by
    ``theta = tau * rate * (m_k - l_k)``: the body's own angular velocity about ``e_k`` is
    ``(m_k - l_k) / I_k`` (Hughes, *Spacecraft Attitude Dynamics*, 1986, ch. 7; Wittenburg,
    *Dynamics of Systems of Rigid Bodies*, 1977). Keeps ``|m|`` and the spatial ``L``.
    For a rotor momentum linear in time (reaction wheels at constant motor torque) the
    driver passes ``l_k`` at the midpoint of the stage's clock interval
    (:func:`rotor_at`), which makes the flow exact: ``m_k`` is constant, so the angle is
    ``rate * integral of (m_k - l_k(t)) dt``.

    Rounding (the spatial ``L`` is kept to a random walk of roundings, so each one counts):
    a small turn is applied in increment form, ``x + ((cos - 1) x + sin y)`` (as
    :func:`axis_flow_recurring`, with the normalised ``(sin, cos, cos - 1)`` of the
    polynomial :func:`~liebody._kernels.trig.sincos_small`: no libm call), so that each
    component is rounded about once, and ``q`` is scaled back to the unit sphere once
    ``| |q|^2 - 1 |`` passes :data:`UNIT_SLACK` (``|q|`` stays within a few ulps of 1
    instead of a random walk, and the scaling rarely adds a rounding); a turn of 0.2 rad or
    more (:data:`COMPENSATED_TURN`) is evaluated error-free (:func:`_turn_compensated`). A
    zero ``shift`` is the rigid body's term and takes :func:`axis_flow`'s arithmetic, so
    that a rotor-free body of a gyrostat ensemble equals its one-body (rigid) run bit for
    bit. The splitting drivers run :func:`axis_flow_carried` instead, which rounds once
    per step rather than once per turn; this one is the generic family's.
    """
    half = 0.5 * tau * rate * (component(axis, m1, m2, m3) - shift)
    if shift == 0.0:  # the rigid body's term: its flow, bit for bit (ensembles mix them)
        return _rigid_turn(w, x, y, z, m1, m2, m3, axis, half)
    if half * half >= COMPENSATED_TURN:
        return _turn_compensated(w, x, y, z, m1, m2, m3, axis, half)
    s2, c2, cm2 = sincos_small(half)  # (|half| < 0.1: the polynomial, cm2 = c2 - 1)
    w, x, y, z, m1, m2, m3 = _turn_increment(w, x, y, z, m1, m2, m3, axis, s2, c2, cm2)
    d = (w * w + x * x) + (y * y + z * z) - 1.0
    if abs(d) > UNIT_SLACK:
        k = -0.5 * d
        w, x, y, z = w + k * w, x + k * x, y + k * y, z + k * z
    return w, x, y, z, m1, m2, m3


@jit(inner=True)
def _turn_increment(w, x, y, z, m1, m2, m3, axis, s2, c2, cm2):
    """Turn ``q`` by ``2 half`` and ``m`` by ``-2 half`` about body axis ``axis`` in
    increment form, ``x + ((cos - 1) x + sin y)``, from ``s2 = sin half``,
    ``c2 = cos half`` and ``cm2 = cos half - 1``. Inlined by LLVM into its callers, as
    :func:`recurring_turn` and :func:`recurring_exp` (``trig.inline_into_callers``): as
    calls, every rotation paid a call and got its seven numbers back through memory
    (one-body ``splitting2`` 59-62 against 53-54 ns a step, the heavy top 59-62 against
    48-50)."""
    inline_into_callers()
    cm = -2.0 * s2 * s2  # cos(2 half) - 1
    s = 2.0 * s2 * c2
    if axis == 0:
        m2, m3 = m2 + (cm * m2 + s * m3), m3 + (cm * m3 - s * m2)
        w, x, y, z = qmul_increment(w, x, y, z, cm2, s2, 0.0, 0.0)
    elif axis == 1:
        m3, m1 = m3 + (cm * m3 + s * m1), m1 + (cm * m1 - s * m3)
        w, x, y, z = qmul_increment(w, x, y, z, cm2, 0.0, s2, 0.0)
    else:
        m1, m2 = m1 + (cm * m1 + s * m2), m2 + (cm * m2 - s * m1)
        w, x, y, z = qmul_increment(w, x, y, z, cm2, 0.0, 0.0, s2)
    return w, x, y, z, m1, m2, m3


@jit(inner=True)
def _two_product(a, b):
    """``a * b`` as an exact sum ``p + e`` (one fused multiply-add)."""
    p = a * b
    return p, fma(a, b, -p)


@jit(inner=True)
def _dot2(a, b, c, d):
    """``a b + c d`` as ``s + e`` with ``e`` the error of ``s`` to within a few ulps of ``e``
    (error-free products and sum: Ogita, Rump & Oishi, SIAM J. Sci. Comput. 26 (2005) 1955)."""
    p1, e1 = _two_product(a, b)
    p2, e2 = _two_product(c, d)
    s, e3 = _two_sum(p1, p2)
    return s, e1 + (e2 + e3)


@jit(inner=True)
def _axis_pair(axis, v1, v2, v3):
    """The two components of ``v`` that a turn about body axis ``axis`` mixes, in the
    turn's order: ``(v2, v3)``, ``(v3, v1)`` or ``(v1, v2)``."""
    if axis == 0:
        return v2, v3
    if axis == 1:
        return v3, v1
    return v1, v2


@jit(inner=True)
def _with_axis_pair(axis, v1, v2, v3, a, b):
    """``v`` with the pair of :func:`_axis_pair` replaced by ``(a, b)``."""
    if axis == 0:
        return v1, a, b
    if axis == 1:
        return b, v2, a
    return a, b, v3


@jit(inner=True)
def _double_angle(half):
    """libm's pair ``(s, c) = (sin half, cos half)``, ``d = c^2 + s^2 - 1`` and the double
    angle's pair of the rounded ``(c, s)`` made unit, in double length: ``(c^2 - s^2) / (1 +
    d) = ch + cl`` and ``2 c s / (1 + d) = sh + sl`` (error-free products and sums)."""
    s2 = math.sin(half)
    c2 = math.cos(half)
    hc, lc = _two_product(c2, c2)
    hs, ls = _two_product(s2, s2)
    nn, en = _two_sum(hc, hs)
    d = (nn - 1.0) + (en + (lc + ls))  # c^2 + s^2 - 1 (nn - 1 exact: Sterbenz)
    ch, e = _two_sum(hc, -hs)
    cl = (e + (lc - ls)) - d * ch
    sc, lsc = _two_product(s2, c2)
    sh = 2.0 * sc
    sl = 2.0 * lsc - d * sh
    return s2, c2, d, ch, cl, sh, sl


@jit(inner=True)
def _turn_compensated(w, x, y, z, m1, m2, m3, axis, half):
    """Turn ``q`` by ``2 half`` and ``m`` by ``-2 half`` about body axis ``axis``, each
    component rounded about once (error-free products by fused multiply-adds, and sums).

    The rounded pair ``(c, s) = (cos half, sin half)`` defines the turn: ``q`` is multiplied
    by ``(c, s e_k) / |(c, s)|`` and ``m`` is turned by its double angle,
    ``((c^2 - s^2), 2 c s) / (c^2 + s^2)``, both in double-length arithmetic (error-free
    products and sums), so that ``q`` and ``m`` turn by the same angle to far below
    round-off; ``q`` is also scaled onto the unit sphere (its own ``|q|^2 - 1`` computed
    error-free). A large turn's plain form rounds each component several times, each
    rounding of the order of the component.
    """
    s2, c2, d, ch, cl, sh, sl = _double_angle(half)
    a, b = _axis_pair(axis, m1, m2, m3)
    ha, ea = _dot2(ch, a, sh, b)
    hb, eb = _dot2(ch, b, -sh, a)
    m1, m2, m3 = _with_axis_pair(axis, m1, m2, m3, ha + (ea + (cl * a + sl * b)),
                                 hb + (eb + (cl * b - sl * a)))
    qs, qe = _two_product(w, w)
    for comp in (x, y, z):
        p, pe = _two_product(comp, comp)
        qs, e2 = _two_sum(qs, p)
        qe += e2 + pe
    k = -0.5 * (((qs - 1.0) + qe) + d)  # 1 / |q (c, s)| - 1, to first order
    if axis == 0:
        pw, px = _dot2(c2, w, -s2, x), _dot2(c2, x, s2, w)
        py, pz = _dot2(c2, y, s2, z), _dot2(c2, z, -s2, y)
    elif axis == 1:
        pw, px = _dot2(c2, w, -s2, y), _dot2(c2, x, -s2, z)
        py, pz = _dot2(c2, y, s2, w), _dot2(c2, z, s2, x)
    else:
        pw, px = _dot2(c2, w, -s2, z), _dot2(c2, x, s2, y)
        py, pz = _dot2(c2, y, -s2, x), _dot2(c2, z, s2, w)
    return (pw[0] + (pw[1] + k * pw[0]), px[0] + (px[1] + k * px[0]),
            py[0] + (py[1] + k * py[0]), pz[0] + (pz[1] + k * pz[0]), m1, m2, m3)


@jit(inner=True)
def axis_flow_carried(w, x, y, z, m1, m2, m3, ew, ex, ey, ez, e1, e2, e3, axis, rate, shift,
                      tau):
    """:func:`axis_flow_shifted` on a state carried in double length, ``q + eq`` and ``m + em``
    (leading parts ``w .. m3``, trailing parts ``ew .. e3``): the turned state in the same
    form, fourteen numbers, the trailing parts of the order of an ulp of the leading ones.

    The driver carries the trailing parts from turn to turn within a step and adds them in
    once, at the step's end or before a stage of another kind (:func:`fold_carried`), so a
    step of several turns rounds each component about once instead of once per turn
    (error-free products and sums: Ogita, Rump & Oishi 2005). ``q`` is multiplied by the
    rounded pair's ``(c, s e_k)`` (its norm is left to the fold) and ``m`` turned by that
    quaternion's rotation, so that the two turn by the same angle to far below round-off.
    A small turn (``half^2 <`` :data:`COMPENSATED_TURN`) takes the pair from the polynomial
    :func:`~liebody._kernels.trig.sincos_turn` in increment form (``c = 1 + cm``), the
    leading terms ``s q_j`` and ``2 s m_j`` as exact products, the rest (of order
    ``half^2``) rounded, and ``m``'s rotation divided by the pair's norm ``1 + dn``
    (``dn`` computed exactly), so that ``m`` turns by ``q``'s angle whatever the
    polynomial's norm error (which is smooth in the angle: a bias, were it left in);
    a larger turn takes libm's pair with :func:`_turn_compensated`'s arithmetic. The
    trailing parts are turned in plain arithmetic (their rounding is of order ``eps^2``).
    A zero ``shift`` is the rigid body's term: the leading parts take :func:`axis_flow`'s
    arithmetic, bit for bit (the trailing ones, zero unless an earlier turn of the step had
    a rotor, are turned by its pair), so that a rotor-free body of a gyrostat ensemble
    equals its one-body (rigid) run bit for bit.
    """
    half = 0.5 * tau * rate * (component(axis, m1, m2, m3) - shift)
    a, b = _axis_pair(axis, m1, m2, m3)
    ea, eb = _axis_pair(axis, e1, e2, e3)
    # q (c, s e_k) = c q + s (pw, px, py, pz): the partners of w, x, y, z in the product
    pw, px, py, pz = _turn_partners(axis, w, x, y, z)
    fw, fx, fy, fz = _turn_partners(axis, ew, ex, ey, ez)
    if shift == 0.0:  # the rigid body's term: its flow, bit for bit (ensembles mix them)
        if half * half < COMPENSATED_TURN:
            s2, c2, cm2 = sincos_turn(half)
        else:
            s2 = math.sin(half)
            c2 = math.cos(half)
            cm2 = c2 - 1.0
        w, x, y, z, m1, m2, m3 = _turn_increment(w, x, y, z, m1, m2, m3, axis, s2, c2, cm2)
        cm = -2.0 * s2 * s2
        s = 2.0 * s2 * c2
        ea, eb = ea + (cm * ea + s * eb), eb + (cm * eb - s * ea)
        ew, ex = ew + (cm2 * ew + s2 * fw), ex + (cm2 * ex + s2 * fx)
        ey, ez = ey + (cm2 * ey + s2 * fy), ez + (cm2 * ez + s2 * fz)
        a, b = _axis_pair(axis, m1, m2, m3)
    elif half * half < COMPENSATED_TURN:
        s2, c2, cm2 = sincos_turn(half)
        # m turned by the rotation of q's factor (1 + cm2, s2 e_k), whatever its norm
        # 1 + dn: a + (s b + s r) / (1 + dn) with r = cm2 b - s2 a, and b - (s a - s r') /
        # (1 + dn) with r' = -(cm2 a + s2 b), s = 2 s2 (exact); dn = 2 cm2 + cm2^2 + s2^2,
        # of the order of eps s2^2, from an exact product and sum (2 cm2 + s2^2 is exact:
        # Sterbenz), so that the polynomial's own norm error turns m and q alike
        ps = s2 * s2
        dn = (ps + 2.0 * cm2) + (fma(s2, s2, -ps) + cm2 * cm2)
        s = 2.0 * s2
        ra = cm2 * b - s2 * a
        rb = -(cm2 * a + s2 * b)
        na, fa = _carried_add(a, ea, s, b, s * (ra - dn * (b + ra)), s * (eb - s2 * ea))
        b, eb = _carried_add(b, eb, -s, a, s * (rb + dn * (a - rb)), -s * (ea + s2 * eb))
        a, ea = na, fa
        # q (1 + cm2, s2 e_k) = q + s2 p + cm2 q
        w, ew = _carried_add(w, ew, s2, pw, cm2 * w, cm2 * ew + s2 * fw)
        x, ex = _carried_add(x, ex, s2, px, cm2 * x, cm2 * ex + s2 * fx)
        y, ey = _carried_add(y, ey, s2, py, cm2 * y, cm2 * ey + s2 * fy)
        z, ez = _carried_add(z, ez, s2, pz, cm2 * z, cm2 * ez + s2 * fz)
    else:
        s2, c2, d, ch, cl, sh, sl = _double_angle(half)
        ha, la = _dot2(ch, a, sh, b)
        hb, lb = _dot2(ch, b, -sh, a)
        ea, eb = (la + (cl * a + sl * b)) + (ch * ea + sh * eb), \
            (lb + (cl * b - sl * a)) + (ch * eb - sh * ea)
        a, b = ha, hb
        k = -0.5 * d  # 1 / |(c, s)| - 1, to first order
        w, ew = _carried_dot(c2, w, s2, pw, k, ew, fw)
        x, ex = _carried_dot(c2, x, s2, px, k, ex, fx)
        y, ey = _carried_dot(c2, y, s2, py, k, ey, fy)
        z, ez = _carried_dot(c2, z, s2, pz, k, ez, fz)
    m1, m2, m3 = _with_axis_pair(axis, m1, m2, m3, a, b)
    e1, e2, e3 = _with_axis_pair(axis, e1, e2, e3, ea, eb)
    return w, x, y, z, m1, m2, m3, ew, ex, ey, ez, e1, e2, e3


@jit(inner=True)
def _turn_partners(axis, w, x, y, z):
    """``q (c, s e_k) = c q + s (pw, px, py, pz)``: the partners ``(pw, px, py, pz)``."""
    if axis == 0:
        return -x, w, z, -y
    if axis == 1:
        return -y, -z, w, x
    return -z, y, -x, w


@jit(inner=True)
def _carried_add(v, ev, s, p, rest, erest):
    """``(v + ev) + (s p + rest) + erest`` in double length: the increment ``s p + rest``
    (``rest`` small against ``s p``) rounded once and its rounding kept, ``s p - inc`` being
    of the order of ``rest`` (``erest``: the trailing parts' own terms)."""
    inc = fma(s, p, rest)
    hv, t = _two_sum(v, inc)
    return hv, ev + ((t + (fma(s, p, -inc) + rest)) + erest)


@jit(inner=True)
def _carried_dot(c, v, s, p, k, ev, fp):
    """``(1 + k) (c (v + ev) + s (p + fp))`` in double length (``k`` of order ``eps``)."""
    h, e = _dot2(c, v, s, p)
    return h, (e + k * h) + (c * ev + s * fp)


@jit(inner=True)
def fold_carried(w, x, y, z, m1, m2, m3, ew, ex, ey, ez, e1, e2, e3):
    """Add the trailing parts of a carried state (:func:`axis_flow_carried`) into its leading
    parts, each component rounded once; ``q`` is scaled onto the unit sphere on the way once
    the computed ``| |q + eq|^2 - 1 |`` passes :data:`UNIT_SLACK` (``|q|`` stays within a few
    ulps of 1 instead of a random walk, which ``R(q) m`` would double, and the scaling adds
    no rounding). Scaling at every fold instead made the spatial ``L`` drift (measured in
    docs/design.md)."""
    d = (((w * w + x * x) + (y * y + z * z)) - 1.0) + 2.0 * ((w * ew + x * ex) + (y * ey + z * ez))
    if abs(d) > UNIT_SLACK:
        k = -0.5 * d
        ew, ex, ey, ez = ew + k * w, ex + k * x, ey + k * y, ez + k * z
    return w + ew, x + ex, y + ey, z + ez, m1 + e1, m2 + e2, m3 + e3


@jit
def axis_flow_recurring(w, x, y, z, m1, m2, m3, axis, rate, tau):
    """:func:`axis_flow` for a rotation whose angle recurs every step (``m_k`` constant).

    About the symmetry axis of a symmetric body ``m_k`` never changes, so the same
    rounded ``(cos, sin)`` pairs are applied every step and their norm error, of one
    sign and of order 1e-16, makes ``|q|`` and ``|m|`` drift linearly (1.5e-10 per 1e6
    steps of ``splitting4`` on the Simo–Wong top). Here both rotations are applied in
    increment form, ``x + ((cos - 1) x + sin y)`` with ``cos - 1`` accurate (see
    ``qexp_increment``), which leaves a norm error of order
    ``eps sin^2``. Same sub-flow, a few more flops.
    """
    return recurring_turn(w, x, y, z, m1, m2, m3, axis,
                          0.5 * tau * rate * component(axis, m1, m2, m3))


@jit(inner=True)
def recurring_turn(w, x, y, z, m1, m2, m3, axis, half):
    """Turn ``q`` by ``2 half`` and ``m`` by ``-2 half`` about body axis ``axis`` in
    increment form (:func:`axis_flow_recurring`; also the exact flow's symmetric-body
    turn, which recurs every step of a splitting likewise)."""
    inline_into_callers()
    s2 = math.sin(half)
    c2 = math.cos(half)
    cm2 = -s2 * s2 / (1.0 + c2) if c2 > 0.0 else c2 - 1.0
    if half * half < LARGE_INCREMENT:
        return _turn_increment(w, x, y, z, m1, m2, m3, axis, s2, c2, cm2)
    cm = -2.0 * s2 * s2  # cos(2 half) - 1
    s = 2.0 * s2 * c2
    # a large angle: the m-rotation's pair has a norm error of order eps (removed, to far
    # below round-off), and q is kept on the unit sphere (qproject_unit)
    k = -0.5 * increment_defect(cm, s, 0.0, 0.0)
    if axis == 0:
        u2, u3 = cm * m2 + s * m3, cm * m3 - s * m2
        m2, m3 = m2 + (u2 + k * (m2 + u2)), m3 + (u3 + k * (m3 + u3))
        w, x, y, z = qmul_increment(w, x, y, z, cm2, s2, 0.0, 0.0)
    elif axis == 1:
        u3, u1 = cm * m3 + s * m1, cm * m1 - s * m3
        m3, m1 = m3 + (u3 + k * (m3 + u3)), m1 + (u1 + k * (m1 + u1))
        w, x, y, z = qmul_increment(w, x, y, z, cm2, 0.0, s2, 0.0)
    else:
        u1, u2 = cm * m1 + s * m2, cm * m2 - s * m1
        m1, m2 = m1 + (u1 + k * (m1 + u1)), m2 + (u2 + k * (m2 + u2))
        w, x, y, z = qmul_increment(w, x, y, z, cm2, 0.0, 0.0, s2)
    w, x, y, z = qproject_unit(w, x, y, z)
    return w, x, y, z, m1, m2, m3


@jit
def sphere_flow(w, x, y, z, m1, m2, m3, rate, tau):
    """Exact flow of ``rate * |m|^2 / 2``: ``m`` fixed, ``q <- q exp(tau rate m)``.

    Together with an :func:`axis_flow` about the symmetry axis (they commute) this
    is the exact flow of a symmetric body (Touma & Wisdom 1994; Hairer & Vilmart's SR2). The
    rotation recurs every step on a free body (``|m|`` is constant), so it is applied
    in increment form (``qmul_increment``): no drift of
    ``|q|`` from the rounding of ``cos`` near 1.
    """
    a = tau * rate
    w, x, y, z = recurring_exp(w, x, y, z, a * m1, a * m2, a * m3)
    return w, x, y, z, m1, m2, m3


@jit(inner=True)
def recurring_exp(w, x, y, z, r1, r2, r3):
    """``q exp(r)`` in increment form (:func:`sphere_flow`; also the exact flow's steady
    and symmetric-body rotations, which recur every step of a splitting likewise)."""
    inline_into_callers()
    cm, vx, vy, vz = qexp_increment(r1, r2, r3)
    w, x, y, z = qmul_increment(w, x, y, z, cm, vx, vy, vz)
    if r1 * r1 + r2 * r2 + r3 * r3 >= 4.0 * LARGE_INCREMENT:  # a large angle: qproject_unit
        w, x, y, z = qproject_unit(w, x, y, z)
    return w, x, y, z


@jit
def _dmv_residual(c1, c2, c3, a1, a2, a3, f1, f2, f3):
    """Residual of ``c = (1 + |c|^2) a + F .* (c_j c_k)`` (the DMV equation divided by I)."""
    alpha = 1.0 + c1 * c1 + c2 * c2 + c3 * c3
    return (c1 - alpha * a1 - f1 * c2 * c3,
            c2 - alpha * a2 - f2 * c3 * c1,
            c3 - alpha * a3 - f3 * c1 * c2)


@jit
def _dmv_newton(c1, c2, c3, a1, a2, a3, f1, f2, f3):
    """Damped Newton on the DMV equation from ``c``; returns ``(c, iterations, converged)``.

    Converged when the residual is at rounding level,
    ``|G|_1 <= 8 eps (|c|_1 + |a|_1 (1 + |c|^2) + |F .* (c_j c_k)|_1)``; a step that does
    not lower the residual is halved (up to 30 times).
    """
    eps8 = 8.0 * 2.220446049250313e-16
    it = 0
    g1, g2, g3 = _dmv_residual(c1, c2, c3, a1, a2, a3, f1, f2, f3)
    r = abs(g1) + abs(g2) + abs(g3)
    for _ in range(DMV_MAX_NEWTON):
        alpha = 1.0 + c1 * c1 + c2 * c2 + c3 * c3
        scale = (abs(c1) + abs(c2) + abs(c3) + (abs(a1) + abs(a2) + abs(a3)) * alpha
                 + abs(f1 * c2 * c3) + abs(f2 * c3 * c1) + abs(f3 * c1 * c2))
        if r <= eps8 * scale:
            return c1, c2, c3, it, True
        it += 1
        j11 = 1.0 - 2.0 * c1 * a1
        j12 = -2.0 * c2 * a1 - f1 * c3
        j13 = -2.0 * c3 * a1 - f1 * c2
        j21 = -2.0 * c1 * a2 - f2 * c3
        j22 = 1.0 - 2.0 * c2 * a2
        j23 = -2.0 * c3 * a2 - f2 * c1
        j31 = -2.0 * c1 * a3 - f3 * c2
        j32 = -2.0 * c2 * a3 - f3 * c1
        j33 = 1.0 - 2.0 * c3 * a3
        det = (j11 * (j22 * j33 - j23 * j32) - j12 * (j21 * j33 - j23 * j31)
               + j13 * (j21 * j32 - j22 * j31))
        if det == 0.0 or not (abs(det) < 1e300):
            return c1, c2, c3, it, False
        d1 = (g1 * (j22 * j33 - j23 * j32) - j12 * (g2 * j33 - j23 * g3)
              + j13 * (g2 * j32 - j22 * g3)) / det
        d2 = (j11 * (g2 * j33 - j23 * g3) - g1 * (j21 * j33 - j23 * j31)
              + j13 * (j21 * g3 - g2 * j31)) / det
        d3 = (j11 * (j22 * g3 - g2 * j32) - j12 * (j21 * g3 - g2 * j31)
              + g1 * (j21 * j32 - j22 * j31)) / det
        lam = 1.0
        for _halving in range(30):
            n1, n2, n3 = c1 - lam * d1, c2 - lam * d2, c3 - lam * d3
            h1, h2, h3 = _dmv_residual(n1, n2, n3, a1, a2, a3, f1, f2, f3)
            rn = abs(h1) + abs(h2) + abs(h3)
            if rn < r or lam < 1e-8:
                break
            lam *= 0.5
        if not (rn < r):
            # no decrease even for tiny steps: at rounding level already, or stuck
            return c1, c2, c3, it, r <= 64.0 * eps8 * scale
        c1, c2, c3, g1, g2, g3, r = n1, n2, n3, h1, h2, h3, rn
    return c1, c2, c3, it, False


@jit
def dmv_step(w, x, y, z, m1, m2, m3, I1, I2, I3, h):
    """Discrete Moser–Veselov step (= RATTLE on SO(3)) in quaternion form.

    Solves ``I c + c x (I c) = (h/2)(1 + |c|^2) m`` for ``c`` (the quaternion form of the
    Moser–Veselov step of Hairer & Vilmart 2006), by Gauss–Seidel fixed-point iteration
    to round-off, falling back to damped Newton from the last iterate and then to Newton
    continuation in ``h`` from ``c = 0`` (which follows the physical root; beyond
    h|omega| of order 1 it may cease to exist), then
    ``q <- q u`` and ``m <- R(u)^T m`` with ``u = (1, c) / sqrt(1 + |c|^2)`` (in exact
    arithmetic the same as Hairer & Vilmart's update
    ``m <- m + 4/(h alpha) ((I2-I3) c2 c3, (I3-I1) c3 c1, (I1-I2) c1 c2)``, but applied as
    a rotation it keeps ``|m|`` and ``R(q) m`` to round-off without a systematic drift).

    Order 2, symplectic, time-reversible; for the free body it conserves energy,
    ``|m|`` and spatial ``L`` exactly (up to round-off).

    Returns the new state and the iteration count; a negative count means the
    implicit equation did not converge (the state is then returned unchanged).
    """
    if h == 0.0:
        return w, x, y, z, m1, m2, m3, 0
    hh = 0.5 * h
    a1, a2, a3 = hh * m1 / I1, hh * m2 / I2, hh * m3 / I3
    f1, f2, f3 = (I2 - I3) / I1, (I3 - I1) / I2, (I1 - I2) / I3
    c1 = a1 + f1 * a2 * a3
    c2 = a2 + f2 * c1 * a3
    c3 = a3 + f3 * c1 * c2
    it = 0
    converged = False
    # Gauss-Seidel fixed point. Near the solution rounding can make the iterates
    # alternate between neighbours a few ulps apart, so convergence is declared at
    # 8 eps relative (the residual is then checked at rounding level below).
    last1, last2, last3 = c1, c2, c3  # last finite iterate, Newton's start if needed
    while it < DMV_MAX_FIXED_POINT:
        it += 1
        alpha = 1.0 + c1 * c1 + c2 * c2 + c3 * c3
        n1 = alpha * a1 + f1 * c2 * c3
        n2 = alpha * a2 + f2 * n1 * c3
        n3 = alpha * a3 + f3 * n1 * n2
        d = abs(n1 - c1) + abs(n2 - c2) + abs(n3 - c3)
        if not (d < 1e300) or not (abs(n1) + abs(n2) + abs(n3) < 1e150):
            break  # diverging (large h|omega|): Newton from the last finite iterate
        c1, c2, c3 = n1, n2, n3
        last1, last2, last3 = c1, c2, c3
        if d <= 8e-16 * (abs(c1) + abs(c2) + abs(c3)) + 1e-300:
            converged = True
            break
    if not converged:
        c1, c2, c3, nit, converged = _dmv_newton(last1, last2, last3, a1, a2, a3, f1, f2, f3)
        it += nit
    if not converged:
        # continuation in the step from c = 0 (h = 0) follows the physical root, which
        # exists beyond the fixed point's reach (roughly h|omega| > 0.9)
        c1, c2, c3 = 0.0, 0.0, 0.0
        for k in range(1, DMV_CONTINUATION + 1):
            s = k / DMV_CONTINUATION
            c1, c2, c3, nit, converged = _dmv_newton(c1, c2, c3, s * a1, s * a2, s * a3,
                                                     f1, f2, f3)
            it += nit
            if not converged:
                break
    if not converged:
        return w, x, y, z, m1, m2, m3, -it
    alpha = 1.0 + c1 * c1 + c2 * c2 + c3 * c3
    # the increment (1, c)/sqrt(alpha) applied to q, and its inverse rotation to m, so that
    # R(q) m is updated as one rotation and its inverse (spatial L kept to round-off)
    n = math.sqrt(alpha)
    uw, ux, uy, uz = qunit_increment(1.0 / n, c1 / n, c2 / n, c3 / n)
    w, x, y, z = qmul(w, x, y, z, uw, ux, uy, uz)
    m1, m2, m3 = qrotate_inv(uw, ux, uy, uz, m1, m2, m3)
    return w, x, y, z, m1, m2, m3, it


@jit(inline="always")
def rotor_at(p, k, t):
    """The rotor momentum's component ``k`` at time ``t`` from a stage's parameters:
    ``l_k(t) = P_L[k] + P_LD[k] (t - P_LT)`` (exactly ``P_L[k]`` when it does not move)."""
    return p[P_L1 + k] + p[P_LD1 + k] * (t - p[P_LT])


@jit
def _omega_e(m1, m2, m3, I1, I2, I3, eps):
    o1, o2, o3 = m1 / I1, m2 / I2, m3 / I3
    if eps != 0.0:
        d1, d2, d3 = damping_rate(m1, m2, m3, I1, I2, I3, eps)
        o1, o2, o3 = o1 + d1, o2 + d2, o3 + d3
    return o1, o2, o3


@jit(inline="always")
def _omega(m1, m2, m3, I1, I2, I3, eps, l1, l2, l3):
    """``omega_e`` of a gyrostat: ``I^-1 (m - l)`` (``l`` the rotor momentum, body frame;
    ``omega_e`` itself for ``l = 0``) plus the dissipation's term."""
    o1, o2, o3 = _omega_e(m1, m2, m3, I1, I2, I3, eps)
    if l1 == 0.0 and l2 == 0.0 and l3 == 0.0:
        return o1, o2, o3
    return o1 - l1 / I1, o2 - l2 / I2, o3 - l3 / I3


@jit
def _rhs(t, w, x, y, z, m1, m2, m3, p, torque_addr, mp, ms, model):
    """Right-hand side ``(q', m')`` in R^7 (no constraint), with torque and dissipation.

    ``omega_e = omega + eps m x omega``; ``q' = q (0, omega_e)/2``;
    ``m' = m x omega_e + tau(t, q, m)``. ``p``: the stage's parameter row (moments,
    ``eps``, the torque and its controls).
    """
    o1, o2, o3 = _omega(m1, m2, m3, p[P_I1], p[P_I2], p[P_I3], p[P_EPS], rotor_at(p, 0, t),
                        rotor_at(p, 1, t), rotor_at(p, 2, t))
    dw, dx, dy, dz = qmul(w, x, y, z, 0.0, 0.5 * o1, 0.5 * o2, 0.5 * o3)
    n1, n2, n3 = torque_value(p, t, w, x, y, z, m1, m2, m3, torque_addr, mp, ms, model)
    return (dw, dx, dy, dz,
            m2 * o3 - m3 * o2 + n1, m3 * o1 - m1 * o3 + n2, m1 * o2 - m2 * o1 + n3)


@jit
def euler_step(t, w, x, y, z, m1, m2, m3, p, h, torque_addr, mp, ms, model):
    """Explicit Euler on ``(q, m)`` in R^7, no renormalisation (baseline: fails).

    Order 1. For the free body energy and ``|m|`` grow every step and ``|q|`` grows
    like ``sqrt(1 + (h |omega| / 2)^2)`` per step (derived: with ``f = m x omega``,
    ``omega . f = m . f = 0``, so ``T`` and ``|m|^2`` grow by ``(h^2/2) f^T I^-1 f`` and
    ``h^2 |f|^2``).
    """
    k = _rhs(t, w, x, y, z, m1, m2, m3, p, torque_addr, mp, ms, model)
    return (w + h * k[0], x + h * k[1], y + h * k[2], z + h * k[3],
            m1 + h * k[4], m2 + h * k[5], m3 + h * k[6])


@jit
def rk4_step(t, w, x, y, z, m1, m2, m3, p, h, torque_addr, mp, ms, model):
    """Classical Runge–Kutta 4 on ``(q, m)`` in R^7, no renormalisation (baseline).

    Order 4; not symplectic, not symmetric: energy and ``|m|`` drift linearly,
    ``|q|`` decays by about ``(h|omega|/2)^6 / 144`` per step (derived: for frozen ``omega``
    ``|R(iy)|^2 = 1 - y^6/72 + y^8/576``, ``y = h|omega|/2``).
    """
    k1 = _rhs(t, w, x, y, z, m1, m2, m3, p, torque_addr, mp, ms, model)
    b = 0.5 * h
    k2 = _rhs(t + b, w + b * k1[0], x + b * k1[1], y + b * k1[2], z + b * k1[3],
              m1 + b * k1[4], m2 + b * k1[5], m3 + b * k1[6], p, torque_addr, mp, ms, model)
    k3 = _rhs(t + b, w + b * k2[0], x + b * k2[1], y + b * k2[2], z + b * k2[3],
              m1 + b * k2[4], m2 + b * k2[5], m3 + b * k2[6], p, torque_addr, mp, ms, model)
    k4 = _rhs(t + h, w + h * k3[0], x + h * k3[1], y + h * k3[2], z + h * k3[3],
              m1 + h * k3[4], m2 + h * k3[5], m3 + h * k3[6], p, torque_addr, mp, ms, model)
    s = h / 6.0
    return (w + s * (k1[0] + 2.0 * (k2[0] + k3[0]) + k4[0]),
            x + s * (k1[1] + 2.0 * (k2[1] + k3[1]) + k4[1]),
            y + s * (k1[2] + 2.0 * (k2[2] + k3[2]) + k4[2]),
            z + s * (k1[3] + 2.0 * (k2[3] + k3[3]) + k4[3]),
            m1 + s * (k1[4] + 2.0 * (k2[4] + k3[4]) + k4[4]),
            m2 + s * (k1[5] + 2.0 * (k2[5] + k3[5]) + k4[5]),
            m3 + s * (k1[6] + 2.0 * (k2[6] + k3[6]) + k4[6]))


@jit
def _coadjoint(w, x, y, z, m1, m2, m3, s1, s2, s3):
    """Apply the group increment ``sigma``: ``q <- q exp(sigma)``, ``m <- exp(-hat sigma) m``."""
    ew, ex, ey, ez = qexp(s1, s2, s3)
    n1, n2, n3 = qrotate_inv(ew, ex, ey, ez, m1, m2, m3)
    w, x, y, z = qmul(w, x, y, z, ew, ex, ey, ez)
    return w, x, y, z, n1, n2, n3


@jit
def lie_euler_step(t, w, x, y, z, m1, m2, m3, p, h, torque_addr, mp, ms, model):
    """Lie–Euler: ``sigma = h omega_e(m)``, coadjoint update, plus ``h tau(t, q, m)``.

    Order 1 (Crouch & Grossman 1993; Iserles et al., Acta Numerica 9 (2000) 215); stays on
    SO(3); without an external torque it keeps ``|m|`` exactly, but it is neither
    symplectic nor symmetric: it drives ``m`` towards the axis of maximum energy.
    """
    n1, n2, n3 = torque_value(p, t, w, x, y, z, m1, m2, m3, torque_addr, mp, ms, model)
    o1, o2, o3 = _omega(m1, m2, m3, p[P_I1], p[P_I2], p[P_I3], p[P_EPS], rotor_at(p, 0, t),
                        rotor_at(p, 1, t), rotor_at(p, 2, t))
    r = _coadjoint(w, x, y, z, m1, m2, m3, h * o1, h * o2, h * o3)
    return r[0], r[1], r[2], r[3], r[4] + h * n1, r[5] + h * n2, r[6] + h * n3


@jit
def _dexpinv(u1, u2, u3, v1, v2, v3):
    """``dexp^{-1}_{-u}(v) = v + u x v / 2 + u x (u x v) / 12`` (truncated, enough for order 4).

    For the body (right) action ``Q = Q0 exp(hat u)`` of ``Q' = Q hat(omega)``.
    """
    c1 = u2 * v3 - u3 * v2
    c2 = u3 * v1 - u1 * v3
    c3 = u1 * v2 - u2 * v1
    d1 = u2 * c3 - u3 * c2
    d2 = u3 * c1 - u1 * c3
    d3 = u1 * c2 - u2 * c1
    return (v1 + 0.5 * c1 + d1 / 12.0, v2 + 0.5 * c2 + d2 / 12.0, v3 + 0.5 * c3 + d3 / 12.0)


@jit
def _rkmk_stage(m1, m2, m3, u1, u2, u3, I1, I2, I3, eps, h, l1, l2, l3):
    """``dexpinv(u, h omega_e(exp(-hat u) m))``: one coadjoint RKMK stage derivative."""
    ew, ex, ey, ez = qexp(u1, u2, u3)
    n1, n2, n3 = qrotate_inv(ew, ex, ey, ez, m1, m2, m3)
    o1, o2, o3 = _omega(n1, n2, n3, I1, I2, I3, eps, l1, l2, l3)
    return _dexpinv(u1, u2, u3, h * o1, h * o2, h * o3)


@jit
def _rkmk4_coadjoint(w, x, y, z, m1, m2, m3, I1, I2, I3, eps, h, l1, l2, l3):
    k1 = _omega(m1, m2, m3, I1, I2, I3, eps, l1, l2, l3)
    k1 = (h * k1[0], h * k1[1], h * k1[2])
    k2 = _rkmk_stage(m1, m2, m3, 0.5 * k1[0], 0.5 * k1[1], 0.5 * k1[2], I1, I2, I3, eps, h,
                     l1, l2, l3)
    k3 = _rkmk_stage(m1, m2, m3, 0.5 * k2[0], 0.5 * k2[1], 0.5 * k2[2], I1, I2, I3, eps, h,
                     l1, l2, l3)
    k4 = _rkmk_stage(m1, m2, m3, k3[0], k3[1], k3[2], I1, I2, I3, eps, h, l1, l2, l3)
    s1 = (k1[0] + 2.0 * (k2[0] + k3[0]) + k4[0]) / 6.0
    s2 = (k1[1] + 2.0 * (k2[1] + k3[1]) + k4[1]) / 6.0
    s3 = (k1[2] + 2.0 * (k2[2] + k3[2]) + k4[2]) / 6.0
    return _coadjoint(w, x, y, z, m1, m2, m3, s1, s2, s3)


@jit
def _rkmk4_stage_torqued(t, w, x, y, z, u1, u2, u3, m1, m2, m3, p, h, torque_addr, mp, ms, model):
    """Stage derivatives on SO(3) x R^3: ``(dexpinv(u, h omega_e), h m')`` at ``(q exp(u), m)``."""
    ew, ex, ey, ez = qexp(u1, u2, u3)
    qw, qx, qy, qz = qmul(w, x, y, z, ew, ex, ey, ez)
    o1, o2, o3 = _omega(m1, m2, m3, p[P_I1], p[P_I2], p[P_I3], p[P_EPS], rotor_at(p, 0, t),
                        rotor_at(p, 1, t), rotor_at(p, 2, t))
    n1, n2, n3 = torque_value(p, t, qw, qx, qy, qz, m1, m2, m3, torque_addr, mp, ms, model)
    a1, a2, a3 = _dexpinv(u1, u2, u3, h * o1, h * o2, h * o3)
    return (a1, a2, a3, h * (m2 * o3 - m3 * o2 + n1), h * (m3 * o1 - m1 * o3 + n2),
            h * (m1 * o2 - m2 * o1 + n3))


@jit
def rkmk4_step(t, w, x, y, z, m1, m2, m3, p, h, torque_addr, mp, ms, model):
    """Runge–Kutta–Munthe-Kaas with the classical RK4 tableau (Munthe-Kaas, BIT 38 (1998) 92).

    Order 4; stays on SO(3). Without an external torque ``m`` moves by the coadjoint
    action (``|m|`` kept exactly); with one, or with a rotor momentum that changes in
    time (reaction wheels), the method runs on SO(3) x R^3 (``m`` additive, ``l(t)`` read at
    each stage's time). Energy drifts linearly.
    """
    if (int(p[P_TORQUE]) == TORQUE_NONE and p[P_LD1] == 0.0 and p[P_LD2] == 0.0
            and p[P_LD3] == 0.0):  # (a moving rotor: the stages below read l(t))
        return _rkmk4_coadjoint(w, x, y, z, m1, m2, m3, p[P_I1], p[P_I2], p[P_I3], p[P_EPS],
                                h, p[P_L1], p[P_L2], p[P_L3])
    b = 0.5 * h
    k1 = _rkmk4_stage_torqued(t, w, x, y, z, 0.0, 0.0, 0.0, m1, m2, m3, p, h, torque_addr, mp, ms,
                              model)
    k2 = _rkmk4_stage_torqued(t + b, w, x, y, z, 0.5 * k1[0], 0.5 * k1[1], 0.5 * k1[2],
                              m1 + 0.5 * k1[3], m2 + 0.5 * k1[4], m3 + 0.5 * k1[5],
                              p, h, torque_addr, mp, ms, model)
    k3 = _rkmk4_stage_torqued(t + b, w, x, y, z, 0.5 * k2[0], 0.5 * k2[1], 0.5 * k2[2],
                              m1 + 0.5 * k2[3], m2 + 0.5 * k2[4], m3 + 0.5 * k2[5],
                              p, h, torque_addr, mp, ms, model)
    k4 = _rkmk4_stage_torqued(t + h, w, x, y, z, k3[0], k3[1], k3[2],
                              m1 + k3[3], m2 + k3[4], m3 + k3[5],
                              p, h, torque_addr, mp, ms, model)
    s0 = (k1[0] + 2.0 * (k2[0] + k3[0]) + k4[0]) / 6.0
    s1 = (k1[1] + 2.0 * (k2[1] + k3[1]) + k4[1]) / 6.0
    s2 = (k1[2] + 2.0 * (k2[2] + k3[2]) + k4[2]) / 6.0
    ew, ex, ey, ez = qexp(s0, s1, s2)
    w, x, y, z = qmul(w, x, y, z, ew, ex, ey, ez)
    return (w, x, y, z, m1 + (k1[3] + 2.0 * (k2[3] + k3[3]) + k4[3]) / 6.0,
            m2 + (k1[4] + 2.0 * (k2[4] + k3[4]) + k4[4]) / 6.0,
            m3 + (k1[5] + 2.0 * (k2[5] + k3[5]) + k4[5]) / 6.0)
