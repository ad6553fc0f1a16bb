"""Torques, kicks and dissipation (numba, float64 scalars).

A *kick* is the exact flow of the torque alone: ``q`` fixed, ``m' = tau(t, q)``, so
``m <- m + dt tau(t, q)``; it is exact whenever the torque depends on the
orientation (and time) only. Kicks sandwich a free flow in the splittings of
torqued scenes: kick(h/2) – free flow(h) – kick(h/2), a Strang splitting
(McLachlan 1993; Dullweber, Leimkuhler & McLachlan 1997).

User torques reach the kernels as a C callback of the fixed signature
:data:`TORQUE_SIG` ``(t, w, x, y, z, m1, m2, m3) -> (tau1, tau2, tau3)`` (body frame),
so the driver is compiled once and cached whatever the user's function is.
"""

from __future__ import annotations

from numba import cfunc, types

from liebody._kernels._jit import jit
from liebody._kernels.quat import qexp, qmul, qrotate_inv
from liebody._kernels.stages import TORQUE_GRAVITY, TORQUE_USER

TORQUE_SIG = types.UniTuple(types.float64, 3)(
    types.float64, types.float64, types.float64, types.float64, types.float64,
    types.float64, types.float64, types.float64)


def adapt_user_torque(user):
    """Wrap a user ``@njit`` function ``torque(t, q, L) -> (3,)`` as a :data:`TORQUE_SIG` callback.

    The wrapper builds the ``q`` and ``L`` arrays for each call (two small allocations
    per torque evaluation, the price of the friendly signature). A callback cannot
    raise, so a torque that raises, or returns anything but three numbers, yields NaN:
    the driver stops at that step (``STATUS_TORQUE``) and the Python side calls the
    torque again to raise its error.
    """
    import math

    import numpy as np

    @cfunc(TORQUE_SIG)
    def adapter(t, w, x, y, z, m1, m2, m3):
        q = np.empty(4)
        q[0], q[1], q[2], q[3] = w, x, y, z
        L = np.empty(3)
        L[0], L[1], L[2] = m1, m2, m3
        try:
            tau = np.asarray(user(t, q, L), dtype=np.float64)
        except Exception:
            return math.nan, math.nan, math.nan
        if tau.ndim != 1 or tau.shape[0] != 3:
            return math.nan, math.nan, math.nan
        return tau[0], tau[1], tau[2]

    return adapter


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
def torque_value(kind, c1, c2, c3, t, w, x, y, z, m1, m2, m3, torque_fn):
    """Body torque of the scene: none, uniform gravity (``c = M g cm``) or the user's.

    ``torque_fn`` is the user's callback, or ``None`` for scenes without one: the
    compiler then drops the call (no callback is typed or passed).
    """
    if kind == TORQUE_GRAVITY:
        return gravity_torque(w, x, y, z, c1, c2, c3)
    if torque_fn is None:
        return 0.0, 0.0, 0.0
    if kind == TORQUE_USER:
        return torque_fn(t, w, x, y, z, m1, m2, m3)
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
    """Second-order step of the dissipative part ``m' = m x Od(m)``, ``q' = q (0, Od)/2``.

    Lie midpoint (RKMK2): ``sigma = tau Od(exp(-hat(tau Od(m)/2)) m)``, applied as
    ``q <- q exp(sigma)``, ``m <- exp(-hat sigma) m``: ``|m|`` and the spatial ``L`` are
    kept exactly, only the kinetic energy is lowered.
    """
    d1, d2, d3 = damping_rate(m1, m2, m3, I1, I2, I3, eps)
    ew, ex, ey, ez = qexp(0.5 * tau * d1, 0.5 * tau * d2, 0.5 * tau * d3)
    h1, h2, h3 = qrotate_inv(ew, ex, ey, ez, m1, m2, m3)
    d1, d2, d3 = damping_rate(h1, h2, h3, I1, I2, I3, eps)
    ew, ex, ey, ez = qexp(tau * d1, tau * d2, tau * d3)
    m1, m2, m3 = qrotate_inv(ew, ex, ey, ez, m1, m2, m3)
    w, x, y, z = qmul(w, x, y, z, ew, ex, ey, ez)
    return w, x, y, z, m1, m2, m3
