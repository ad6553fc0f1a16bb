"""The gravity-gradient torque of point masses on an extended body.

Parameter block: ``(I1, I2, I3, K)`` then ``K`` sources of ``1 + orbit.WIDTH`` numbers,
``(GM, orbit row)``, the orbit giving the source's position ``r`` seen from the body's
centre of mass in the inertial frame. With ``r_b = R(q)^T r`` (body frame):

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
HEAD = 4  # I1, I2, I3, K
SOURCE = 1 + orbit.WIDTH


@jit
def torque(t, w, x, y, z, mp):
    I1, I2, I3 = mp[0], mp[1], mp[2]
    t1 = t2 = t3 = 0.0
    for s in range(int(mp[3])):
        k = HEAD + s * SOURCE
        X, Y, Z = orbit.position(mp, k + 1, t)
        r1, r2, r3 = qrotate_inv(w, x, y, z, X, Y, Z)
        rr = r1 * r1 + r2 * r2 + r3 * r3
        f = 3.0 * mp[k] / (rr * rr * math.sqrt(rr))
        a1, a2, a3 = I1 * r1, I2 * r2, I3 * r3
        t1 += f * (r2 * a3 - r3 * a2)
        t2 += f * (r3 * a1 - r1 * a3)
        t3 += f * (r1 * a2 - r2 * a1)
    return t1, t2, t3


@jit
def potential(t, w, x, y, z, mp):
    n = math.sqrt(w * w + x * x + y * y + z * z)
    w, x, y, z = w / n, x / n, y / n, z / n
    I1, I2, I3 = mp[0], mp[1], mp[2]
    V = 0.0
    for s in range(int(mp[3])):
        k = HEAD + s * SOURCE
        X, Y, Z = orbit.position(mp, k + 1, t)
        r1, r2, r3 = qrotate_inv(w, x, y, z, X, Y, Z)
        rr = r1 * r1 + r2 * r2 + r3 * r3
        V += 1.5 * mp[k] / (rr * rr * math.sqrt(rr)) * (I1 * r1 * r1 + I2 * r2 * r2
                                                         + I3 * r3 * r3)
    return V
