"""Quaternion algebra kernels (numba, float64, scalar-first ``(w, x, y, z)``).

Two layers:

* scalar kernels that take and return components as tuples. They allocate
  nothing and are what the integrator hot loops call;
* batch kernels over ``(n, 4)`` / ``(n, 3)`` / ``(n, 3, 3)`` arrays writing into a
  caller-provided ``out``; :mod:`liebody.quaternion` wraps them with validation
  and broadcasting.

A unit quaternion ``q`` rotates body to space: ``v_space = q (0, v) q*``.
"""

from __future__ import annotations

import math

from liebody._kernels._jit import jit

# --------------------------------------------------------------------------------------
# scalar kernels
# --------------------------------------------------------------------------------------


@jit
def qmul(aw, ax, ay, az, bw, bx, by, bz):
    """Hamilton product ``a * b``."""
    return (
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    )


@jit(inner=True)
def qrotate(w, x, y, z, vx, vy, vz):
    """``R(q) v`` for a unit quaternion, via ``v + 2 u x (u x v + w v)``, ``u = (x, y, z)``."""
    tx = 2.0 * (y * vz - z * vy)
    ty = 2.0 * (z * vx - x * vz)
    tz = 2.0 * (x * vy - y * vx)
    return (
        vx + w * tx + (y * tz - z * ty),
        vy + w * ty + (z * tx - x * tz),
        vz + w * tz + (x * ty - y * tx),
    )


@jit(inner=True)
def qrotate_inv(w, x, y, z, vx, vy, vz):
    """``R(q)^T v`` (space to body) for a unit quaternion."""
    return qrotate(w, -x, -y, -z, vx, vy, vz)


@jit(inner=True)
def component(axis, x, y, z):
    """``(x, y, z)[axis]`` for a vector kept in scalars (``axis`` in 0, 1, 2)."""
    if axis == 0:
        return x
    if axis == 1:
        return y
    return z


@jit
def qexp(rx, ry, rz):
    """Unit quaternion of the rotation vector ``r`` (angle ``|r|`` about ``r/|r|``).

    ``(cos(|r|/2), sin(|r|/2) r/|r|)``; the factor ``sin(a/2)/a`` is evaluated by
    its Taylor series for ``a < 1e-3`` so the map is exact to round-off near 0.
    """
    a2 = rx * rx + ry * ry + rz * rz
    a = math.sqrt(a2)
    if a < 1e-3:
        # sin(a/2)/a = 1/2 - a^2/48 + a^4/3840 - ...; cos(a/2) = 1 - a^2/8 + a^4/384
        s = 0.5 - a2 / 48.0 + a2 * a2 / 3840.0
        c = 1.0 - a2 / 8.0 + a2 * a2 / 384.0
    else:
        s = math.sin(0.5 * a) / a
        c = math.cos(0.5 * a)
    return c, s * rx, s * ry, s * rz


@jit(inner=True)
def _two_square(a):
    """``a*a`` as an exact sum ``hi + lo`` (Dekker's error-free product).

    T. J. Dekker, Numer. Math. 18 (1971) 224-242, with Veltkamp's splitting.
    """
    p = a * a
    c = 134217729.0 * a  # 2^27 + 1: Veltkamp split
    ah = c - (c - a)
    al = a - ah
    return p, ((ah * ah - p) + 2.0 * ah * al) + al * al


@jit(inner=True)
def _two_sum(a, b):
    """``a + b`` as an exact sum ``s + e`` (Knuth's error-free sum).

    D. E. Knuth, *The Art of Computer Programming*, vol. 2, 3rd ed. (1997), §4.2.2.
    """
    s = a + b
    bb = s - a
    return s, (a - (s - bb)) + (b - bb)


@jit
def qunit_increment(w, x, y, z):
    """Make a unit *increment* quaternion unit to far below round-off, without bias.

    An exact rotation applied every step (a sub-flow, a DMV update) is a quaternion
    whose rounded components have ``|e|^2 - 1 = delta`` of order 1e-16; when the same
    angle recurs every step (a free body keeps ``|m|``), ``delta`` has the same sign
    every step and ``|q|`` drifts linearly. Here ``delta`` is computed exactly (error-
    free transformations) and removed by rescaling the vector part, whose fine
    granularity leaves a residual of order ``|v|^2 eps``. Only for ``|v|^2 >= 1e-4``,
    where the implied angle change (at most ``delta/|v|``) is below 1e-13 rad; smaller
    rotations are returned unchanged.
    """
    v2 = x * x + y * y + z * z
    if v2 < 1e-4:
        return w, x, y, z
    s, e = _two_square(w)
    for comp in (x, y, z):
        p, pe = _two_square(comp)
        s, e2 = _two_sum(s, p)
        e += e2 + pe
    delta = (s - 1.0) + e  # s - 1 is exact (Sterbenz): s is within a few ulps of 1
    k = 1.0 - 0.5 * delta / v2
    return w, k * x, k * y, k * z


@jit(inner=True)
def qexp_increment(rx, ry, rz):
    """:func:`qexp` as ``(cm, vx, vy, vz)`` with ``cm = cos(|r|/2) - 1`` kept to full
    relative accuracy, for :func:`qmul_increment`.

    An increment ``(1 + cm, v)`` never rounds its scalar part to the grid of numbers
    near 1 (spacing 1.1e-16), whose error, the same every step when the same rotation
    recurs, would make ``|q|`` drift linearly. Its norm error is of order
    ``eps |v|^2`` instead: 4e-20 per step at a rotation angle of 0.04.
    """
    c, vx, vy, vz = qexp(rx, ry, rz)
    v2 = vx * vx + vy * vy + vz * vz
    cm = -v2 / (1.0 + c) if c > 0.0 else c - 1.0
    return cm, vx, vy, vz


@jit(inner=True)
def increment_defect(cm, vx, vy, vz):
    """``delta = (1 + cm)^2 + |v|^2 - 1 = 2 cm + cm^2 + |v|^2`` of an increment, to far
    below round-off (error-free squares and sums: Dekker 1971, Knuth 1997).

    The rounded pair of a rotation by a large angle has ``delta`` of order 1e-16 (not
    ``eps |v|^2``, which is small only for small angles); when the angle recurs every
    step, ``delta`` has one sign every step and the norm would drift linearly.
    """
    s, e = _two_square(cm)
    s, e2 = _two_sum(2.0 * cm, s)
    e += e2
    for comp in (vx, vy, vz):
        p, pe = _two_square(comp)
        s, e2 = _two_sum(s, p)
        e += e2 + pe
    return s + e


@jit(inner=True)
def qproject_unit(w, x, y, z):
    """``q`` scaled onto the unit sphere: ``q (1 - delta/2)`` with ``delta = |q|^2 - 1``
    computed exactly (error-free squares and sums). Scaling leaves the rotation
    ``R(q / |q|)`` unchanged; it removes a norm error that would otherwise accumulate where
    a step's roundings repeat (a large rotation that recurs every step, at a step near a
    multiple of a half turn, rounds alike every other step), leaving ``| |q| - 1 |`` within
    a few ulps for good instead of a linear drift."""
    s, e = _two_square(w)
    for comp in (x, y, z):
        p, pe = _two_square(comp)
        s, e2 = _two_sum(s, p)
        e += e2 + pe
    k = -0.5 * ((s - 1.0) + e)  # s - 1 is exact (Sterbenz) for |q| near 1
    return w + k * w, x + k * x, y + k * y, z + k * z


@jit(inner=True)
def qmul_increment(w, x, y, z, cm, vx, vy, vz):
    """``q * (1 + cm, v)`` evaluated as ``q + (cm q + q * (0, v))``: the small update is
    formed first and added once, so its rounding does not depend on the grid near 1."""
    return (w + (cm * w - x * vx - y * vy - z * vz),
            x + (cm * x + w * vx + y * vz - z * vy),
            y + (cm * y + w * vy + z * vx - x * vz),
            z + (cm * z + w * vz + x * vy - y * vx))


@jit(inner=True)
def qlog(w, x, y, z):
    """Rotation vector of a unit quaternion, angle in ``[0, pi]``.

    ``q`` and ``-q`` give the same result (the short rotation is returned). At angle
    pi exactly (``w = 0``) the rotations by ``pi`` about ``n`` and ``-n`` are the same
    and the one whose first non-zero component is positive is returned.
    Uses ``atan2`` so it is accurate at all angles, including near 0 and pi.
    """
    if w < 0.0 or (w == 0.0 and (x < 0.0 or (x == 0.0 and (y < 0.0 or (y == 0.0 and z < 0.0))))):
        w, x, y, z = -w, -x, -y, -z
    n = math.sqrt(x * x + y * y + z * z)
    if n < 1e-8:
        # angle = 2 atan2(n, w) ~ 2 n / w (1 - n^2/(3 w^2)); factor = angle / n
        f = 2.0 / w * (1.0 - n * n / (3.0 * w * w))
    else:
        f = 2.0 * math.atan2(n, w) / n
    return f * x, f * y, f * z


@jit
def qnormalize(w, x, y, z):
    """``q / |q|`` (scaled to avoid overflow/underflow)."""
    m = max(abs(w), abs(x), abs(y), abs(z))
    w, x, y, z = w / m, x / m, y / m, z / m
    n = math.sqrt(w * w + x * x + y * y + z * z)
    return w / n, x / n, y / n, z / n


@jit(inner=True)
def qaxis_rotation(w, x, y, z, axis, s, c):
    """``q * (c, s e_axis)``: right-multiply by a rotation about body axis ``axis`` (0, 1, 2).

    ``c = cos(theta/2)``, ``s = sin(theta/2)`` for a rotation by ``theta``. Costs 8
    multiplications: this is the orientation part of an exact axis sub-flow.
    """
    if axis == 0:
        return (c * w - s * x, c * x + s * w, c * y + s * z, c * z - s * y)
    elif axis == 1:
        return (c * w - s * y, c * x - s * z, c * y + s * w, c * z + s * x)
    else:
        return (c * w - s * z, c * x + s * y, c * y - s * x, c * z + s * w)


# --------------------------------------------------------------------------------------
# batch kernels over rows
# --------------------------------------------------------------------------------------


@jit
def multiply_rows(a, b, out):
    for i in range(out.shape[0]):
        r = qmul(a[i, 0], a[i, 1], a[i, 2], a[i, 3], b[i, 0], b[i, 1], b[i, 2], b[i, 3])
        out[i, 0], out[i, 1], out[i, 2], out[i, 3] = r
    return out


@jit
def rotate_rows(q, v, out):
    for i in range(out.shape[0]):
        r = qrotate(q[i, 0], q[i, 1], q[i, 2], q[i, 3], v[i, 0], v[i, 1], v[i, 2])
        out[i, 0], out[i, 1], out[i, 2] = r
    return out


@jit
def exp_rows(r, out):
    for i in range(out.shape[0]):
        out[i, 0], out[i, 1], out[i, 2], out[i, 3] = qexp(r[i, 0], r[i, 1], r[i, 2])
    return out


@jit
def log_rows(q, out):
    for i in range(out.shape[0]):
        out[i, 0], out[i, 1], out[i, 2] = qlog(q[i, 0], q[i, 1], q[i, 2], q[i, 3])
    return out


@jit
def normalize_rows(q, out):
    for i in range(out.shape[0]):
        out[i, 0], out[i, 1], out[i, 2], out[i, 3] = qnormalize(q[i, 0], q[i, 1], q[i, 2], q[i, 3])
    return out


@jit
def to_matrix_rows(q, out):
    """Rotation matrices ``R(q)`` (space <- body) of unit quaternions."""
    for i in range(out.shape[0]):
        w, x, y, z = q[i, 0], q[i, 1], q[i, 2], q[i, 3]
        xx, yy, zz = x * x, y * y, z * z
        xy, xz, yz = x * y, x * z, y * z
        wx, wy, wz = w * x, w * y, w * z
        out[i, 0, 0] = 1.0 - 2.0 * (yy + zz)
        out[i, 0, 1] = 2.0 * (xy - wz)
        out[i, 0, 2] = 2.0 * (xz + wy)
        out[i, 1, 0] = 2.0 * (xy + wz)
        out[i, 1, 1] = 1.0 - 2.0 * (xx + zz)
        out[i, 1, 2] = 2.0 * (yz - wx)
        out[i, 2, 0] = 2.0 * (xz - wy)
        out[i, 2, 1] = 2.0 * (yz + wx)
        out[i, 2, 2] = 1.0 - 2.0 * (xx + yy)
    return out


@jit
def from_matrix_rows(m, out):
    """Unit quaternions (``w >= 0``) from rotation matrices, Shepperd's method.

    S. W. Shepperd, "Quaternion from rotation matrix", J. Guidance and Control 1 (1978)
    223-224.

    The largest of ``4w^2, 4x^2, 4y^2, 4z^2`` (read off the trace and diagonal) is
    computed by a square root and the other three by division by it, so no
    component is obtained from a difference of nearly equal numbers.
    """
    for i in range(out.shape[0]):
        m00, m01, m02 = m[i, 0, 0], m[i, 0, 1], m[i, 0, 2]
        m10, m11, m12 = m[i, 1, 0], m[i, 1, 1], m[i, 1, 2]
        m20, m21, m22 = m[i, 2, 0], m[i, 2, 1], m[i, 2, 2]
        tr = m00 + m11 + m22
        if tr >= m00 and tr >= m11 and tr >= m22:
            s = math.sqrt(1.0 + tr) * 2.0  # 4w
            w = 0.25 * s
            x = (m21 - m12) / s
            y = (m02 - m20) / s
            z = (m10 - m01) / s
        elif m00 >= m11 and m00 >= m22:
            s = math.sqrt(1.0 + m00 - m11 - m22) * 2.0  # 4x
            w = (m21 - m12) / s
            x = 0.25 * s
            y = (m01 + m10) / s
            z = (m02 + m20) / s
        elif m11 >= m22:
            s = math.sqrt(1.0 + m11 - m00 - m22) * 2.0  # 4y
            w = (m02 - m20) / s
            x = (m01 + m10) / s
            y = 0.25 * s
            z = (m12 + m21) / s
        else:
            s = math.sqrt(1.0 + m22 - m00 - m11) * 2.0  # 4z
            w = (m10 - m01) / s
            x = (m02 + m20) / s
            y = (m12 + m21) / s
            z = 0.25 * s
        if w < 0.0:
            w, x, y, z = -w, -x, -y, -z
        out[i, 0], out[i, 1], out[i, 2], out[i, 3] = qnormalize(w, x, y, z)
    return out


@jit
def slerp_rows(a, b, t, out):
    """Spherical linear interpolation along the short arc from ``a`` to ``b``."""
    for i in range(out.shape[0]):
        aw, ax, ay, az = a[i, 0], a[i, 1], a[i, 2], a[i, 3]
        bw, bx, by, bz = b[i, 0], b[i, 1], b[i, 2], b[i, 3]
        d = aw * bw + ax * bx + ay * by + az * bz
        if d < 0.0:
            bw, bx, by, bz, d = -bw, -bx, -by, -bz, -d
        # relative rotation r = a* b, then a * exp(t log r): accurate for tiny angles too
        rw, rx, ry, rz = qmul(aw, -ax, -ay, -az, bw, bx, by, bz)
        lx, ly, lz = qlog(rw, rx, ry, rz)
        ti = t[i]
        ew, ex, ey, ez = qexp(ti * lx, ti * ly, ti * lz)
        out[i, 0], out[i, 1], out[i, 2], out[i, 3] = qmul(aw, ax, ay, az, ew, ex, ey, ez)
    return out
