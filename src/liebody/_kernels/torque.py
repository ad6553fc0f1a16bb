"""Torques, kicks and dissipation (numba, float64 scalars).

A *kick* is the exact flow of the torque alone: ``q`` fixed, ``m' = tau(t, q)``, so
``m <- m + dt tau(t, q)``; it is exact whenever the torque depends on the
orientation (and time) only. Kicks sandwich a free flow in the splittings of
torqued scenes: kick(h/2) – free flow(h) – kick(h/2), a Strang splitting
(McLachlan 1993; Dullweber, Leimkuhler & McLachlan 1997). The torques themselves are
the physics models' (:mod:`liebody._models`). Dissipation sandwiches the free flow the
same way with :func:`damping_flow`, the closed-form step of the double-bracket
dissipation (``m`` exact, ``q`` to ``O(dt^3)``; stable and energy-decreasing for any
``eps dt``).
"""

from __future__ import annotations

import math

from liebody._kernels._jit import jit
from liebody._kernels.quat import qmul
from liebody._kernels.stages import P_TORQUE
from liebody._models import dispatch


@jit(inline="always")
def torque_value(p, t, w, x, y, z, m1, m2, m3, torque_addr, mp, ms, model):
    """Body torque of the model named by the stage row ``p`` (``P_TORQUE``), with the
    model's parameters ``mp`` (the body's row) and ``ms`` (shared by every body) and a user
    torque's callback address ``torque_addr`` (0 for none); ``model`` the run's model token
    (``dispatch.token``), which selects the model at compile time."""
    return dispatch.torque_of(model, int(p[P_TORQUE]), mp, ms, p, torque_addr, t, w, x, y, z,
                              m1, m2, m3)


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
