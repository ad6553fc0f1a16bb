"""The gravity-gradient torque of point masses on an extended body.

Parameter block: ``(I1, I2, I3, K)`` then ``K`` sources one after the other, each
``(GM, orbit row)``: the orbit (``liebody._models.orbit``: its first number is its kind,
and its length follows from the row, ``orbit.size``: 12 numbers for a Kepler orbit,
``6 + 4 m`` for a table of ``m`` samples) gives the source's position ``r`` seen from the
body's centre of mass in the inertial frame. The kernels walk the sources in order
(source ``s + 1`` starts after source ``s``'s orbit row). With ``r_b = R(q)^T r`` (body
frame):

* torque ``tau = sum_k 3 GM_k / r_k^5 (r_b x I r_b)``;
* potential ``V = sum_k 3 GM_k / (2 r_k^5) r_b^T I r_b`` (the orientation-dependent part of
  the body's potential in the source's field to quadrupole order; MacCullagh's formula).

Under a body rotation by ``eps``, ``r_b -> r_b - eps x r_b`` and ``V`` changes by
``-eps . tau``: the torque derives from ``V``. Depends on the time and the orientation;
Hamiltonian (time-dependent), so the kick with ``q`` fixed is its exact flow.
"""

from __future__ import annotations

import math

from liebody._kernels._jit import jit
from liebody._kernels.quat import qrotate_inv
from liebody._kernels.stages import TORQUE_GRAVITY_GRADIENT
from liebody._models import orbit

CODE = TORQUE_GRAVITY_GRADIENT
#: whether the torque may depend on the momentum (no: the orientation and time only)
MOMENTUM = False
HEAD = 4  # I1, I2, I3, K


@jit(inline="always")
def _pull(w, x, y, z, I1, I2, I3, X, Y, Z, GM):
    """One source's torque: ``3 GM / r^5 (r_b x I r_b)`` with ``r_b = R(q)^T (X, Y, Z)``."""
    # R(q)^T v = v + 2 u x (u x v + w v) with u = -(x, y, z): quat.qrotate_inv, written out
    # so that the SIMD block loop holds no call (LLVM vectorises it)
    tx = 2.0 * (-y * Z + z * Y)
    ty = 2.0 * (-z * X + x * Z)
    tz = 2.0 * (-x * Y + y * X)
    r1 = X + w * tx + (-y * tz + z * ty)
    r2 = Y + w * ty + (-z * tx + x * tz)
    r3 = Z + w * tz + (-x * ty + y * tx)
    rr = r1 * r1 + r2 * r2 + r3 * r3
    f = 3.0 * GM / (rr * rr * math.sqrt(rr))
    a1, a2, a3 = I1 * r1, I2 * r2, I3 * r3
    return f * (r2 * a3 - r3 * a2), f * (r3 * a1 - r1 * a3), f * (r1 * a2 - r2 * a1)


@jit
def torque(t, w, x, y, z, mp):
    t1 = t2 = t3 = 0.0
    k = HEAD
    for _ in range(int(mp[3])):
        X, Y, Z = orbit.position(mp, k + 1, t)
        a, b, c = _pull(w, x, y, z, mp[0], mp[1], mp[2], X, Y, Z, mp[k])
        t1 += a
        t2 += b
        t3 += c
        k += 1 + orbit.size(mp, k + 1)
    return t1, t2, t3


@jit
def scratch_size(mp):
    """Numbers :func:`prepare` writes: the position and ``GM`` of every source."""
    return 4 * int(mp[3])


@jit
def prepare(t, mp, scratch):
    """The part of the torque that depends on the time only, the same for every body of an
    ensemble (the sources are shared): the sources' positions at ``t``, into ``scratch``."""
    k = HEAD
    for s in range(int(mp[3])):
        X, Y, Z = orbit.position(mp, k + 1, t)
        scratch[4 * s], scratch[4 * s + 1], scratch[4 * s + 2] = X, Y, Z
        scratch[4 * s + 3] = mp[k]
        k += 1 + orbit.size(mp, k + 1)


@jit
def torque_prepared(scratch, w, x, y, z, mp):
    """:func:`torque` from :func:`prepare`'s numbers (the same arithmetic, bit for bit)."""
    t1 = t2 = t3 = 0.0
    for s in range(int(mp[3])):
        a, b, c = _pull(w, x, y, z, mp[0], mp[1], mp[2], scratch[4 * s], scratch[4 * s + 1],
                        scratch[4 * s + 2], scratch[4 * s + 3])
        t1 += a
        t2 += b
        t3 += c
    return t1, t2, t3


@jit
def torque_block(scratch, mpar, idx, nb, state, rows, work):
    """:func:`torque_prepared` for ``nb`` bodies ``idx`` at once (the SIMD drivers): the
    state of body ``b`` at ``state[rows[0] + b]`` (w) .. ``state[rows[3] + b]`` (z), the
    torques into ``work[0..2, b]`` (``work[3..5]``: the bodies' moments, gathered first);
    sources outermost, so that the body loop vectorises, and each body's sum in the
    scalar's order (bit for bit)."""
    shared = mpar.shape[0] == 1
    w0, x0, y0, z0 = rows[0], rows[1], rows[2], rows[3]
    for b in range(nb):
        i = 0 if shared else idx[b]
        work[3, b] = mpar[i, 0]
        work[4, b] = mpar[i, 1]
        work[5, b] = mpar[i, 2]
        work[0, b] = 0.0
        work[1, b] = 0.0
        work[2, b] = 0.0
    for s in range(int(mpar[0 if shared else idx[0], 3])):
        X, Y, Z, GM = scratch[4 * s], scratch[4 * s + 1], scratch[4 * s + 2], scratch[4 * s + 3]
        for b in range(nb):
            a1, a2, a3 = _pull(state[w0 + b], state[x0 + b], state[y0 + b], state[z0 + b],
                               work[3, b], work[4, b], work[5, b], X, Y, Z, GM)
            work[0, b] += a1
            work[1, b] += a2
            work[2, b] += a3


@jit
def potential(t, w, x, y, z, mp):
    n = math.sqrt(w * w + x * x + y * y + z * z)
    w, x, y, z = w / n, x / n, y / n, z / n
    I1, I2, I3 = mp[0], mp[1], mp[2]
    V = 0.0
    k = HEAD
    for _ in range(int(mp[3])):
        X, Y, Z = orbit.position(mp, k + 1, t)
        r1, r2, r3 = qrotate_inv(w, x, y, z, X, Y, Z)
        rr = r1 * r1 + r2 * r2 + r3 * r3
        V += 1.5 * mp[k] / (rr * rr * math.sqrt(rr)) * (I1 * r1 * r1 + I2 * r2 * r2
                                                         + I3 * r3 * r3)
        k += 1 + orbit.size(mp, k + 1)
    return V


@jit
def torque_bound(mp):
    """``|r x I r| = |r x (I - I_min) r| <= (I_max - I_min) r^2``, and ``r`` is at least
    the orbit's ``orbit.min_distance`` (the pericentre distance ``a (1 - e)``; for a table
    a lower bound on its interpolant's distance): ``sum_k 3 GM_k (I_max - I_min) /
    r_min^3`` (inf where no positive lower bound is known)."""
    spread = max(mp[0], mp[1], mp[2]) - min(mp[0], mp[1], mp[2])
    b = 0.0
    k = HEAD
    for _ in range(int(mp[3])):
        r = orbit.min_distance(mp, k + 1)
        if not r > 0.0:
            return math.inf
        b += 3.0 * mp[k] * spread / (r * r * r)
        k += 1 + orbit.size(mp, k + 1)
    return b * (1.0 + 1e-12)
