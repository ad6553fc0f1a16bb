"""The one dispatch on model codes: torque and potential of any model."""

from __future__ import annotations

from liebody._kernels._jit import jit
from liebody._models import gravity_gradient, uniform_gravity, user_torque


@jit
def torque(code, mp, p, addr, t, w, x, y, z, m1, m2, m3):
    """Body torque of model ``code`` with parameter block ``mp`` at ``(t, q, m)``; ``p`` is
    the stage's parameter row (the controls of a user torque), ``addr`` the address of a
    user torque's callback (0 for none)."""
    if code == uniform_gravity.CODE:
        return uniform_gravity.torque(t, w, x, y, z, mp)
    if code == gravity_gradient.CODE:
        return gravity_gradient.torque(t, w, x, y, z, mp)
    if code == user_torque.CODE:
        return user_torque.torque(t, w, x, y, z, m1, m2, m3, p, addr, mp)
    return 0.0, 0.0, 0.0


@jit
def potential(code, mp, t, w, x, y, z):
    """Potential of model ``code`` at the rotation ``q / |q|`` stands for; NaN where the
    kernels cannot evaluate it (a user's Python potential), 0 for no model."""
    if code == uniform_gravity.CODE:
        return uniform_gravity.potential(t, w, x, y, z, mp)
    if code == gravity_gradient.CODE:
        return gravity_gradient.potential(t, w, x, y, z, mp)
    if code == user_torque.CODE:
        return user_torque.potential(t, w, x, y, z, mp)
    return 0.0


@jit
def potentials(code, mp, t, q, out):
    """``out[i] = potential(code, mp[i or 0], t[i], q[i])`` (for Python callers)."""
    rows = mp.shape[0]
    for i in range(q.shape[0]):
        out[i] = potential(code, mp[i if rows > 1 else 0], t[i], q[i, 0], q[i, 1], q[i, 2],
                           q[i, 3])
