"""Torques, kicks and dissipation (numba, float64 scalars).

A *kick* is the exact flow of the torque alone: ``q`` fixed, ``m' = tau(t, q)``, so
``m <- m + dt tau(t, q)``; it is exact whenever the torque depends on the
orientation (and time) only. Kicks sandwich a free flow in the splittings of
torqued scenes: kick(h/2) – free flow(h) – kick(h/2), a Strang splitting
(McLachlan 1993; Dullweber, Leimkuhler & McLachlan 1997). Dissipation sandwiches it
the same way with :func:`damping_flow`, the closed-form step of the double-bracket
dissipation (``m`` exact, ``q`` to ``O(dt^3)``; stable and energy-decreasing for any
``eps dt``).

User torques reach the kernels as a C callback of the fixed signature
:data:`TORQUE_SIG` ``(t, w, x, y, z, m1, m2, m3, u0, ..., u5) -> (tau1, tau2, tau3)``
(body frame; ``u`` the control inputs, held constant over a step), passed to the
drivers as its address, a plain integer (0: no user torque), and called through
:func:`call_torque`. So the drivers are compiled once and cached whatever the user's
function is, free bodies and user torques share one compiled driver, and a call passes
an integer instead of a first-class function object (which numba would type and unbox,
at several microseconds, on every call).
"""

from __future__ import annotations

import math

from numba import cfunc, config, types

from liebody._kernels._jit import jit
from liebody._kernels.quat import qmul
from liebody._kernels.stages import (
    N_CONTROLS,
    P_C1,
    P_C2,
    P_C3,
    P_TORQUE,
    P_U0,
    TORQUE_GRAVITY,
    TORQUE_USER,
)

TORQUE_SIG = types.UniTuple(types.float64, 3)(*([types.float64] * (8 + N_CONTROLS)))


#: address -> adapter, for the uncompiled kernels (NUMBA_DISABLE_JIT=1) and to keep
#: every adapter alive for as long as the drivers may call its address
_ADAPTERS: dict = {}


def adapt_user_torque(user, controls: int = 0):
    """Wrap a user ``@njit`` torque as a :data:`TORQUE_SIG` callback; returns its address.

    ``controls = 0``: ``torque(t, q, L) -> (3,)``; ``controls = k`` (1 to
    ``N_CONTROLS``): ``torque(t, q, L, u) -> (3,)`` with ``u`` the first ``k`` control
    inputs. The wrapper builds the ``q``, ``L`` (and ``u``) arrays for each call (small
    allocations per torque evaluation, the price of the friendly signature). A
    callback cannot raise, so a torque that raises, or returns anything but three
    numbers, yields NaN: the driver stops at that step (``STATUS_TORQUE``) and the
    Python side calls the torque again to raise its error. The adapter is kept for the
    life of the process (its address is what the drivers call).
    """
    import math

    import numpy as np

    if not 0 <= controls <= N_CONTROLS:
        raise ValueError(f"controls must be 0 to {N_CONTROLS}, got {controls}")

    def body(t, w, x, y, z, m1, m2, m3, u0, u1, u2, u3, u4, u5):
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
                tau = np.asarray(user(t, q, L, u), dtype=np.float64)
            else:
                tau = np.asarray(user(t, q, L), dtype=np.float64)
        except Exception:
            return math.nan, math.nan, math.nan
        if tau.ndim != 1 or tau.shape[0] != 3:
            return math.nan, math.nan, math.nan
        return tau[0], tau[1], tau[2]

    if config.DISABLE_JIT:  # the uncompiled kernels call the Python function by its id
        _ADAPTERS[id(body)] = body
        return id(body)
    adapter = cfunc(TORQUE_SIG)(body)
    _ADAPTERS[adapter.address] = adapter
    return adapter.address


def _call_torque_py(addr, t, w, x, y, z, m1, m2, m3, u0, u1, u2, u3, u4, u5):
    """:func:`call_torque` for the uncompiled kernels: the adapter's Python function."""
    return _ADAPTERS[addr](t, w, x, y, z, m1, m2, m3, u0, u1, u2, u3, u4, u5)


def _call_torque_intrinsic():
    from llvmlite import ir
    from numba.extending import intrinsic

    @intrinsic
    def call_torque(typingctx, addr, t, w, x, y, z, m1, m2, m3, u0, u1, u2, u3, u4, u5):
        """Call the :data:`TORQUE_SIG` callback at the integer address ``addr``."""
        sig = TORQUE_SIG.return_type(types.intp, *TORQUE_SIG.args)

        def codegen(context, builder, signature, args):
            fnty = ir.FunctionType(context.get_value_type(TORQUE_SIG.return_type),
                                   [context.get_value_type(a) for a in TORQUE_SIG.args])
            fptr = builder.inttoptr(args[0], fnty.as_pointer())
            return builder.call(fptr, args[1:])

        return sig, codegen

    return call_torque


#: ``call_torque(addr, t, w, x, y, z, m1, m2, m3, u0, ..., u5)``: call the user torque
#: callback whose address is ``addr`` (an adapter made by :func:`adapt_user_torque`)
call_torque = _call_torque_py if config.DISABLE_JIT else _call_torque_intrinsic()


@jit
def vertical_in_body(w, x, y, z):
    """``Gamma = R(q)^T e_z``: the space vertical in body coordinates (third row of R)."""
    return (2.0 * (x * z - w * y), 2.0 * (y * z + w * x), w * w - x * x - y * y + z * z)


@jit
def gravity_torque(w, x, y, z, c1, c2, c3):
    """Body torque ``Gamma x c`` of the potential ``V = c . Gamma`` (``c = M g cm``).

    ``V = M g (R(q) cm) . e_z``; under a body rotation by ``eps`` it changes by
    ``-eps . (Gamma x c)``, so the torque is ``Gamma x c``.
    """
    g1, g2, g3 = vertical_in_body(w, x, y, z)
    return g2 * c3 - g3 * c2, g3 * c1 - g1 * c3, g1 * c2 - g2 * c1


@jit
def torque_value(p, t, w, x, y, z, m1, m2, m3, torque_addr):
    """Body torque of the scene whose stage parameters are ``p``: none, uniform gravity
    (``c = M g cm`` in ``P_C1..P_C3``) or the user's (with the controls ``P_U0..``).

    ``torque_addr`` is the address of the user's callback (:func:`adapt_user_torque`),
    or 0 for scenes without one.
    """
    kind = int(p[P_TORQUE])
    if kind == TORQUE_GRAVITY:
        return gravity_torque(w, x, y, z, p[P_C1], p[P_C2], p[P_C3])
    if kind == TORQUE_USER and torque_addr != 0:
        return call_torque(torque_addr, t, w, x, y, z, m1, m2, m3, p[P_U0], p[P_U0 + 1],
                           p[P_U0 + 2], p[P_U0 + 3], p[P_U0 + 4], p[P_U0 + 5])
    return 0.0, 0.0, 0.0


@jit
def damping_rate(m1, m2, m3, I1, I2, I3, eps):
    """Extra body angular velocity ``eps (m x omega)`` of the double-bracket dissipation.

    ``m' = m x omega + eps m x (m x omega) = m x (omega + eps m x omega)``: a rotation
    of ``m``, so ``|m|`` is kept and ``T' = -eps |m x omega|^2 <= 0``.
    """
    o1, o2, o3 = m1 / I1, m2 / I2, m3 / I3
    return eps * (m2 * o3 - m3 * o2), eps * (m3 * o1 - m1 * o3), eps * (m1 * o2 - m2 * o1)


@jit
def damping_flow(w, x, y, z, m1, m2, m3, I1, I2, I3, eps, tau):
    """The dissipative part ``m' = m x Od``, ``q' = q (0, Od)/2``, ``Od = eps m x omega``,
    over ``tau``: ``m`` exactly (closed form), ``q`` to ``O(tau^3)``, stable for any
    ``eps tau``.

    The double-bracket dissipation of A. Bloch, P. S. Krishnaprasad, J. E. Marsden &
    T. S. Ratiu, "The Euler–Poincaré equations and double bracket dissipation", Commun.
    Math. Phys. 175 (1996) 1–42: ``m' = eps m x (m x omega)``, ``omega = m / I``, in
    components ``m_i' = eps (2T - |m|^2 a_i) m_i`` with ``a_i = 1 / I_i`` and
    ``2T = sum a_j m_j^2``. ``|m|`` is constant, and ``p_i = m_i^2 / |m|^2`` obeys the
    replicator equation ``p_i' = 2c (abar - a_i) p_i`` (``c = eps |m|^2``,
    ``abar = sum a_j p_j``), whose solution is the exponential (Boltzmann) weighting
    ``p_i(t) = p_i(0) exp(-2c a_i t) / sum_j p_j(0) exp(-2c a_j t)``. Hence

        ``m_i(t) = m_i(0) exp(-c a_i t) |m| / sqrt(sum_j m_j(0)^2 exp(-2c a_j t))``:

    the components never change sign, and ``T`` falls monotonically to
    ``|m|^2 / (2 I_max)`` (``dT/dt = -eps |m x omega|^2``). The exponents are shifted by
    that of the smallest ``a_j`` (largest moment) among the non-zero components (the
    largest ``a_j`` for ``tau < 0``), and the vectors scaled by their largest component, so
    nothing overflows or underflows for any ``eps tau``: the stiff limit is the
    largest-moment axis.

    The orientation keeps the spatial ``L = R(q) m``: ``q(t) = q(0) U`` with
    ``R(U) m(t) = m(0)``. ``U`` is taken as the shortest arc from ``m(t)/|m|`` to
    ``m(0)/|m|`` (never antipodal: ``m(t) . m(0) >= 0`` as ``m_i(t) m_i(0) >= 0``);
    ``m`` is the closed form, so its signs are kept exactly and a component that
    underflows is exactly zero; ``|m|`` and the spatial ``L`` are kept to round-off,
    and ``T`` does not rise by more than round-off for any ``tau >= 0``. The exact ``U``
    has body angular velocity ``Od`` perpendicular to ``m``, so its rotation vector
    is ``tau Od(0) + tau^2/2 Od'(0) + O(tau^3)`` with no component along ``m`` up to
    ``O(tau^3)`` (``Od . m = 0`` for all ``t`` gives ``Od'(0) . m(0) = 0``): it agrees
    with the shortest arc to ``O(tau^2)``, a local error ``O(tau^3)`` that keeps the
    splitting D(h/2) – free flow(h) – D(h/2) of second order. The exact ``U`` turns
    further about ``m(t)`` by the geometric phase, the solid angle between the path of
    ``m/|m|`` and the great circle back; it is ``O(tau^3)`` and bounded for any
    ``tau``, and vanishes when the path is a great circle (``m`` in a principal plane).
    ``D(-tau)`` inverts ``D(tau)`` exactly (the step is symmetric). No allocation.
    """
    mu = max(abs(m1), abs(m2), abs(m3))
    if mu == 0.0 or tau == 0.0:
        return w, x, y, z, m1, m2, m3
    u1, u2, u3 = m1 / mu, m2 / mu, m3 / mu
    g2 = u1 * u1 + u2 * u2 + u3 * u3
    a1, a2, a3 = 1.0 / I1, 1.0 / I2, 1.0 / I3
    k = eps * tau * mu * mu * g2  # c tau (inf when huge: the stiff limit)
    # reference rate: smallest a among the non-zero components (largest for tau < 0)
    ar = math.inf if k > 0.0 else -math.inf
    if u1 != 0.0 and (a1 < ar if k > 0.0 else a1 > ar):
        ar = a1
    if u2 != 0.0 and (a2 < ar if k > 0.0 else a2 > ar):
        ar = a2
    if u3 != 0.0 and (a3 < ar if k > 0.0 else a3 > ar):
        ar = a3
    v1 = u1 * _decay(k, a1 - ar)
    v2 = u2 * _decay(k, a2 - ar)
    v3 = u3 * _decay(k, a3 - ar)
    vm = max(abs(v1), abs(v2), abs(v3))
    v1, v2, v3 = v1 / vm, v2 / vm, v3 / vm
    # unit vectors h = m(t)/|m|, g = m(0)/|m|; U = (1 + h.g, h x g) normalised
    nv = math.sqrt(v1 * v1 + v2 * v2 + v3 * v3)
    ng = math.sqrt(g2)
    h1, h2, h3 = v1 / nv, v2 / nv, v3 / nv
    e1, e2, e3 = u1 / ng, u2 / ng, u3 / ng
    uw = 1.0 + (h1 * e1 + h2 * e2 + h3 * e3)
    ux, uy, uz = h2 * e3 - h3 * e2, h3 * e1 - h1 * e3, h1 * e2 - h2 * e1
    n = math.sqrt(uw * uw + ux * ux + uy * uy + uz * uz)
    uw, ux, uy, uz = uw / n, ux / n, uy / n, uz / n
    w, x, y, z = qmul(w, x, y, z, uw, ux, uy, uz)
    return w, x, y, z, (h1 * ng) * mu, (h2 * ng) * mu, (h3 * ng) * mu  # h |m|


@jit
def _decay(k, da):
    """``exp(-k da)`` with ``k da >= 0``, and 1 for ``da = 0`` even when ``k`` is infinite."""
    if da == 0.0:
        return 1.0
    return math.exp(-k * da)
