"""Point dipoles on fixed sites, each carried by a rigid body: the built-in coupled model.

Parameter row of body ``i``: ``(s_x, s_y, s_z, d_x, d_y, d_z, n_i, j_1, ..., j_K)``: its
site, its dipole moment in its body frame, and its neighbours (``n_i`` of them, body
indices stored as floats, the rest of the ``K`` slots -1); ``n_i = -1`` means every
other body (no cutoff). With ``mu_i = R(q_i) d_i`` and ``r = s_i - s_j`` (units in which
the coupling constant is 1):

* potential ``V = sum_{i<j} [mu_i . mu_j - 3 (mu_i . e)(mu_j . e)] / |r|^3``, ``e = r/|r|``;
* field at ``i`` ``B_i = sum_j [3 (mu_j . e) e - mu_j] / |r|^3``, torque (space)
  ``mu_i x B_i``, in the body frame ``d_i x (R(q_i)^T B_i)``.

Under a rotation of body ``i`` by ``eps`` the potential changes by
``-eps . (mu_i x B_i)``: the torque derives from ``V``. (J. D. Jackson, *Classical
Electrodynamics*, 3rd ed., 1999, eqs. 5.56 and 5.72, in units where ``mu_0 / 4 pi = 1``.)
"""

from __future__ import annotations

import math

import numpy as np
from numba import prange

from liebody._kernels._jit import jit
from liebody._kernels.quat import qrotate, qrotate_inv

#: numbers of a parameter row before the neighbour list
HEAD = 7


@jit
def _space_dipoles(q, params, mu):
    for i in range(q.shape[0]):
        w, x, y, z = q[i, 0], q[i, 1], q[i, 2], q[i, 3]
        n = math.sqrt(w * w + x * x + y * y + z * z)
        mu[i, 0], mu[i, 1], mu[i, 2] = qrotate(w / n, x / n, y / n, z / n, params[i, 3],
                                               params[i, 4], params[i, 5])


@jit(inline="always")
def _field(params, mu, i, j):
    """The field of dipole ``j`` at site ``i``."""
    r1 = params[i, 0] - params[j, 0]
    r2 = params[i, 1] - params[j, 1]
    r3 = params[i, 2] - params[j, 2]
    rr = r1 * r1 + r2 * r2 + r3 * r3
    inv3 = 1.0 / (rr * math.sqrt(rr))
    a = 3.0 * (mu[j, 0] * r1 + mu[j, 1] * r2 + mu[j, 2] * r3) / rr
    return (a * r1 - mu[j, 0]) * inv3, (a * r2 - mu[j, 1]) * inv3, (a * r3 - mu[j, 2]) * inv3


@jit
def _torque_rows(q, params, mu, out, lo, hi):
    """The torques of bodies ``lo .. hi - 1`` (the field summed in a fixed order)."""
    n = q.shape[0]
    for i in range(lo, hi):
        b1 = b2 = b3 = 0.0
        count = int(params[i, HEAD - 1])
        if count < 0:
            for j in range(n):
                if j != i:
                    f1, f2, f3 = _field(params, mu, i, j)
                    b1 += f1
                    b2 += f2
                    b3 += f3
        else:
            for c in range(count):
                f1, f2, f3 = _field(params, mu, i, int(params[i, HEAD + c]))
                b1 += f1
                b2 += f2
                b3 += f3
        w, x, y, z = q[i, 0], q[i, 1], q[i, 2], q[i, 3]
        nq = math.sqrt(w * w + x * x + y * y + z * z)
        c1, c2, c3 = qrotate_inv(w / nq, x / nq, y / nq, z / nq, b1, b2, b3)
        d1, d2, d3 = params[i, 3], params[i, 4], params[i, 5]
        out[i, 0] = d2 * c3 - d3 * c2
        out[i, 1] = d3 * c1 - d1 * c3
        out[i, 2] = d1 * c2 - d2 * c1


#: bodies per thread's chunk of the torque (fewer pairs than this: one thread, the
#: start of a parallel region costing more than the work)
CHUNK = 256


@jit(parallel=True)
def torque(t, q, L, params, out):
    """Every body's body-frame torque (the coupled-bodies interface): in chunks of
    :data:`CHUNK` bodies over numba's threads (``numba.set_num_threads``) when there are
    several chunks, each body's sum in a fixed order, so the numbers do not depend on the
    thread count."""
    n = q.shape[0]
    mu = np.empty((n, 3))
    _space_dipoles(q, params, mu)
    chunks = (n + CHUNK - 1) // CHUNK
    if chunks <= 1:
        _torque_rows(q, params, mu, out, 0, n)
        return
    for c in prange(chunks):
        _torque_rows(q, params, mu, out, c * CHUNK, min(n, (c + 1) * CHUNK))


@jit
def potential(t, q, params):
    """The dipole-dipole energy of the configuration ``q`` ``(N, 4)``."""
    n = q.shape[0]
    mu = np.empty((n, 3))
    _space_dipoles(q, params, mu)
    V = 0.0
    for i in range(n):
        count = int(params[i, HEAD - 1])
        last = n if count < 0 else count
        for c in range(last):
            j = c if count < 0 else int(params[i, HEAD + c])
            if j <= i:
                continue
            f1, f2, f3 = _field(params, mu, i, j)
            V -= mu[i, 0] * f1 + mu[i, 1] * f2 + mu[i, 2] * f3
    return V


_CALLBACK = None


def callback_address() -> int:
    """The address of :func:`torque` as the coupled driver's C callback
    (``_kernels.coupled.COUPLED_SIG``), compiled once and kept in numba's disk cache (a
    user's torque is wrapped afresh in every process; the built-in model need not be)."""
    global _CALLBACK
    if _CALLBACK is None:
        from numba import carray, cfunc, config

        from liebody._kernels.coupled import COUPLED_SIG, adapt_coupled_torque

        if config.DISABLE_JIT:
            return adapt_coupled_torque(torque)

        def dipole_callback(t, qp, lp, pp, op, n, k):
            torque(t, carray(qp, (n, 4)), carray(lp, (n, 3)), carray(pp, (n, k)),
                   carray(op, (n, 3)))

        try:
            _CALLBACK = cfunc(COUPLED_SIG, cache=True)(dipole_callback)
        except RuntimeError:  # no writable cache folder: compiled, not cached
            _CALLBACK = cfunc(COUPLED_SIG)(dipole_callback)
    return _CALLBACK.address
