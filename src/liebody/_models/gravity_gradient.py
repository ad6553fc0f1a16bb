"""The gravity-gradient torque of point masses on an extended body.

Parameters: a body's row ``mp = (I1, I2, I3)``, its principal moments, and the block
``ms`` that every body of an ensemble shares (stored once, whatever the inertia):
``K``, then ``K`` sources one after the other, each ``(GM, orbit row)``: the orbit
(``liebody._models.orbit``: its first number is its kind, and its length follows from the
row, ``orbit.size``: 12 numbers for a Kepler orbit, ``6 + 4 m`` for a table of ``m``
samples) gives the source's position ``r`` seen from the body's centre of mass in the
inertial frame. The kernels walk the sources in order (source ``s + 1`` starts after
source ``s``'s orbit row). With ``r_b = R(q)^T r`` (body
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
from liebody._kernels.trig import fma, inline_into_callers, wide_vectors
from liebody._models import orbit

CODE = TORQUE_GRAVITY_GRADIENT
#: whether the torque may depend on the momentum (no: the orientation and time only)
MOMENTUM = False
#: numbers of a body's row (I1, I2, I3); the shared block starts with K, the sources after
ROW = 3
HEAD = 1


@jit(inline="always")
def _strength(GM, X, Y, Z):
    """``3 GM / r^5`` of a source at ``(X, Y, Z)`` (inertial frame): the time-only factor of
    its torque (``|R(q)^T r| = |r|`` for a unit ``q``)."""
    rr = X * X + Y * Y + Z * Z
    return 3.0 * GM / (rr * rr * math.sqrt(rr))


@jit(inline="always")
def _pull(w, x, y, z, I1, I2, I3, X, Y, Z, f):
    """One source's torque ``f (r_b x I r_b)``, ``r_b = R(q)^T (X, Y, Z)``, ``f`` its
    :func:`_strength`."""
    # R(q)^T v = v + w t + u x t, t = 2 u x v with u = -(x, y, z) (quat.qrotate_inv), written
    # out so that the SIMD block loop holds no call (LLVM vectorises it), with fused
    # multiply-adds (one rounding each, the same in every lane and in the scalar kernels)
    tx = 2.0 * fma(z, Y, -(y * Z))
    ty = 2.0 * fma(x, Z, -(z * X))
    tz = 2.0 * fma(y, X, -(x * Y))
    r1 = X + fma(w, tx, fma(z, ty, -(y * tz)))
    r2 = Y + fma(w, ty, fma(x, tz, -(z * tx)))
    r3 = Z + fma(w, tz, fma(y, tx, -(x * ty)))
    a1, a2, a3 = I1 * r1, I2 * r2, I3 * r3
    return f * fma(r2, a3, -(r3 * a2)), f * fma(r3, a1, -(r1 * a3)), f * fma(r1, a2, -(r2 * a1))


@jit
def torque(t, w, x, y, z, mp, ms):
    """The torque of the sources on a body of moments ``mp[0..2]`` at ``(t, q)``; inlined
    by LLVM into the kicks (:func:`~liebody._kernels.trig.inline_into_callers`: as a
    call, a kick paid the call and got its torque back through memory, 8-10 % of a
    one-body step on a circular orbit)."""
    inline_into_callers()
    I1, I2, I3 = mp[0], mp[1], mp[2]
    t1 = t2 = t3 = 0.0
    k = HEAD
    for _ in range(int(ms[0])):
        X, Y, Z = orbit.position(ms, k + 1, t)
        a, b, c = _pull(w, x, y, z, I1, I2, I3, X, Y, Z, _strength(ms[k], X, Y, Z))
        t1 += a
        t2 += b
        t3 += c
        k += 1 + orbit.size(ms, k + 1)
    return t1, t2, t3


@jit
def scratch_size(ms):
    """Numbers :func:`prepare` writes: the position and :func:`_strength` of every source."""
    return 4 * int(ms[0])


@jit
def prepare(t, ms, scratch):
    """The part of the torque that depends on the time only, the same for every body of an
    ensemble (the sources are shared): the sources' positions at ``t`` and their
    :func:`_strength`, into ``scratch``."""
    k = HEAD
    for s in range(int(ms[0])):
        X, Y, Z = orbit.position(ms, k + 1, t)
        scratch[4 * s], scratch[4 * s + 1], scratch[4 * s + 2] = X, Y, Z
        scratch[4 * s + 3] = _strength(ms[k], X, Y, Z)
        k += 1 + orbit.size(ms, k + 1)


@jit
def torque_prepared(scratch, w, x, y, z, mp):
    """:func:`torque` from :func:`prepare`'s numbers (the same arithmetic, bit for bit)."""
    t1 = t2 = t3 = 0.0
    for s in range(scratch.shape[0] // 4):
        a, b, c = _pull(w, x, y, z, mp[0], mp[1], mp[2], scratch[4 * s], scratch[4 * s + 1],
                        scratch[4 * s + 2], scratch[4 * s + 3])
        t1 += a
        t2 += b
        t3 += c
    return t1, t2, t3


@jit
def block_constants(mp):
    """The numbers of a body's parameter row that :func:`torque_block` reads from the
    gathered parameters (once per block, not per kick): its moments ``I1, I2, I3``."""
    return mp[0], mp[1], mp[2]


@jit
def torque_block(scratch, par, j, nb, state, rows, work):
    """:func:`torque_prepared` for ``nb`` bodies at once (the SIMD drivers): the state of
    body ``b`` at ``state[rows[0] + b]`` (w) .. ``state[rows[3] + b]`` (z), its moments
    at ``par[j, 0..2, b]`` (:func:`block_constants`), the torques into ``work[0..2, b]``;
    sources outermost, so that the body loop vectorises, and each body's sum in the
    scalar's order (bit for bit)."""
    wide_vectors()
    w0, x0, y0, z0 = rows[0], rows[1], rows[2], rows[3]
    for b in range(nb):  # (not "= a" for the first source: that branch stops the vectoriser)
        work[0, b] = 0.0
        work[1, b] = 0.0
        work[2, b] = 0.0
    for s in range(scratch.shape[0] // 4):
        X, Y, Z, f = scratch[4 * s], scratch[4 * s + 1], scratch[4 * s + 2], scratch[4 * s + 3]
        for b in range(nb):
            a1, a2, a3 = _pull(state[w0 + b], state[x0 + b], state[y0 + b], state[z0 + b],
                               par[j, 0, b], par[j, 1, b], par[j, 2, b], X, Y, Z, f)
            work[0, b] += a1
            work[1, b] += a2
            work[2, b] += a3


@jit
def potential(t, w, x, y, z, mp, ms):
    n = math.sqrt(w * w + x * x + y * y + z * z)
    w, x, y, z = w / n, x / n, y / n, z / n
    I1, I2, I3 = mp[0], mp[1], mp[2]
    V = 0.0
    k = HEAD
    for _ in range(int(ms[0])):
        X, Y, Z = orbit.position(ms, k + 1, t)
        r1, r2, r3 = qrotate_inv(w, x, y, z, X, Y, Z)
        rr = r1 * r1 + r2 * r2 + r3 * r3
        V += 1.5 * ms[k] / (rr * rr * math.sqrt(rr)) * (I1 * r1 * r1 + I2 * r2 * r2
                                                         + I3 * r3 * r3)
        k += 1 + orbit.size(ms, k + 1)
    return V


@jit
def torque_bound(mp, ms):
    """``|r x I r| = |r x (I - I_min) r| <= (I_max - I_min) r^2``, and ``r`` is at least
    the orbit's ``orbit.min_distance`` (the pericentre distance ``a (1 - e)``; for a table
    a lower bound on its interpolant's distance): ``sum_k 3 GM_k (I_max - I_min) /
    r_min^3`` (inf where no positive lower bound is known)."""
    spread = max(mp[0], mp[1], mp[2]) - min(mp[0], mp[1], mp[2])
    b = 0.0
    k = HEAD
    for _ in range(int(ms[0])):
        r = orbit.min_distance(ms, k + 1)
        if not r > 0.0:
            return math.inf
        b += 3.0 * ms[k] * spread / (r * r * r)
        k += 1 + orbit.size(ms, k + 1)
    return b * (1.0 + 1e-12)
