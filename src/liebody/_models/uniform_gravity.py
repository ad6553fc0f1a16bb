"""Uniform gravity ``-g e_z`` on a body with a fixed point (the heavy top).

Parameter block ``(c1, c2, c3)``: the weight arm ``c = M g cm`` in the body frame.
Potential ``V = c . Gamma`` with ``Gamma = R(q)^T e_z``; torque ``Gamma x c``
(Hand & Finch, ch. 8, the heavy symmetric top). Depends on the orientation only;
conservative.
"""

from __future__ import annotations

import math

from liebody._kernels._jit import jit
from liebody._kernels.stages import TORQUE_GRAVITY

CODE = TORQUE_GRAVITY
#: whether the torque may depend on the momentum (no: the orientation only)
MOMENTUM = False
#: width of the parameter block
WIDTH = 3


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


@jit(inline="always")
def torque(t, w, x, y, z, mp):
    """The model's torque from its parameter block ``mp`` (``t`` unused)."""
    return gravity_torque(w, x, y, z, mp[0], mp[1], mp[2])


@jit
def potential(t, w, x, y, z, mp):
    """``V = c . Gamma`` at the rotation ``q / |q|`` stands for (``t`` unused)."""
    n2 = w * w + x * x + y * y + z * z
    return (mp[0] * 2.0 * (x * z - w * y) + mp[1] * 2.0 * (y * z + w * x)
            + mp[2] * (w * w - x * x - y * y + z * z)) / n2


def potential_py(t, q, row) -> float:
    """:func:`potential` in plain Python for one orientation (the end-of-run energy check
    of a one-body call: a kernel call through numba's dispatcher costs more than these
    flops); the same arithmetic."""
    w, x, y, z = q
    n2 = w * w + x * x + y * y + z * z
    return (row[0] * 2.0 * (x * z - w * y) + row[1] * 2.0 * (y * z + w * x)
            + row[2] * (w * w - x * x - y * y + z * z)) / n2


@jit
def torque_bound(mp):
    """``|Gamma x c| <= |c|`` for unit ``q`` (``|Gamma| = |q|^2``)."""
    return math.sqrt(mp[0] * mp[0] + mp[1] * mp[1] + mp[2] * mp[2])
