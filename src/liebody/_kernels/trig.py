"""Fused multiply-add and a branch-free polynomial sine and cosine (numba, float64), and
two code-generation marks for kernels (wide vectors, inlining by LLVM).

The SIMD kernels' trigonometry (libm does not vectorise), and the circular orbits' (one
inlined call instead of two libm calls). Accuracy and rounding: ``liebody._kernels.batch``,
"Fast sin/cos" and "No fast-math".
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
from numba import types
from numba.core import config
from numba.extending import intrinsic, overload

from liebody._kernels._jit import jit, overload_options


# ------------------------------------------------------------------ fused multiply-add
def fma(a, b, c):
    """``a * b + c`` rounded once (IEEE fusedMultiplyAdd).

    Compiled: the ``llvm.fma`` intrinsic (one ``vfmadd`` instruction, packed in the
    vectorised loops). Uncompiled (``NUMBA_DISABLE_JIT=1``): exact rational arithmetic
    rounded once, so the kernels give the same numbers either way.
    """
    if math.isfinite(a) and math.isfinite(b) and math.isfinite(c):
        if a == 0.0 or b == 0.0:
            return a * b + c  # exact: the product is a signed zero
        r = Fraction(a) * Fraction(b) + Fraction(c)
        if r == 0:
            return 0.0
        try:
            return float(r)
        except OverflowError:
            return math.copysign(math.inf, r)
    return a * b + c


@intrinsic
def _llvm_fma(typingctx, a, b, c):
    sig = types.float64(types.float64, types.float64, types.float64)

    def codegen(context, builder, signature, args):
        return builder.fma(*args)

    return sig, codegen


# ------------------------------------------------------------------ vector width
#: the LLVM function attribute :func:`wide_vectors` sets
WIDE_VECTORS = '"prefer-vector-width"="512"'


def _no_mark():
    """Uncompiled: nothing to mark (:func:`wide_vectors`, :func:`inline_into_callers`)."""


def _wide_vectors_intrinsic():
    @intrinsic
    def wide_vectors(typingctx):
        """Mark the kernel whose body calls this to vectorise its loops with 512-bit
        registers where the CPU has them: LLVM's x86 backend prefers 256-bit vectors on
        AVX-512 CPUs (the clock throttling of the first ones), and the attribute
        ``prefer-vector-width`` of a function overrides that for the function alone, not
        for the process (``NUMBA_CPU_FEATURES`` would). On a CPU without AVX-512 the
        widest legal vectors are used, as before. Call it in the kernel's own body (a
        numba overload is a function of its own)."""

        def codegen(context, builder, signature, args):
            # (llvmlite knows only keyword attributes; a string attribute is written
            # into the function's attribute set as LLVM spells it. A hint: where an
            # llvmlite keeps its attributes otherwise, the kernel compiles without it)
            attrs = builder.function.attributes
            if isinstance(attrs, set):
                set.add(attrs, WIDE_VECTORS)
            return context.get_dummy_value()

        return types.void(), codegen

    return wide_vectors


#: ``wide_vectors()``: the SIMD kernels' first statement (:func:`_wide_vectors_intrinsic`)
wide_vectors = _no_mark if config.DISABLE_JIT else _wide_vectors_intrinsic()


def _inline_into_callers_intrinsic():
    @intrinsic
    def inline_into_callers(typingctx):
        """Mark the kernel whose body calls this for LLVM to inline wherever it is called
        (the LLVM attribute ``alwaysinline``): no call, and the caller's optimiser sees
        its arithmetic. numba's own ``inline="always"`` inlines at numba's IR level and
        types the body again at every call site: for the gravity-gradient torque that
        made the drivers' first compile 50 % longer, this costs nothing measurable. Call
        it in the kernel's own body."""

        def codegen(context, builder, signature, args):
            attrs = builder.function.attributes
            if "noinline" not in attrs:  # (a hint: never a compile error)
                attrs.add("alwaysinline")
            return context.get_dummy_value()

        return types.void(), codegen

    return inline_into_callers


#: ``inline_into_callers()``: a kernel's first statement
#: (:func:`_inline_into_callers_intrinsic`); uncompiled, nothing
inline_into_callers = _no_mark if config.DISABLE_JIT else _inline_into_callers_intrinsic()


@overload(fma, jit_options=overload_options())
def _fma_overload(a, b, c):
    return lambda a, b, c: _llvm_fma(a, b, c)


# ------------------------------------------------------------------ fast sin and cos
TWO_OVER_PI = 6.36619772367581382433e-01
PIO2_1 = 1.57079632673412561417e+00  # first 33 bits of pi/2
PIO2_2 = 6.07710050630396597660e-11  # next 33 bits
PIO2_2T = 2.02226624879595063154e-21  # pi/2 - (PIO2_1 + PIO2_2)
R_CLAMP = 0.8  # bound on the reduced argument (only reached for |x| beyond 2^52)
# fdlibm __kernel_sin: sin x = x + x^3 (S1 + x^2 S2 + ... + x^10 S6), |x| <= pi/4
S1 = -1.66666666666666324348e-01
S2 = 8.33333333332248946124e-03
S3 = -1.98412698298579493134e-04
S4 = 2.75573137070700676789e-06
S5 = -2.50507602534068634195e-08
S6 = 1.58969099521155010221e-10
# fdlibm __kernel_cos: cos x = 1 - x^2/2 + x^4 (C1 + x^2 C2 + ... + x^10 C6)
C1 = 4.16666666666666019037e-02
C2 = -1.38888888888741095749e-03
C3 = 2.48015872894767294178e-05
C4 = -2.75573143513906633035e-07
C5 = 2.08757232129817482790e-09
C6 = -1.13596475577881948265e-11


@jit(inline="always")
def _sin_poly(z):
    """``(sin r / r - 1) / r^2`` as a polynomial in ``z = r^2`` (Horner, FMA)."""
    return fma(z, fma(z, fma(z, fma(z, fma(z, S6, S5), S4), S3), S2), S1)


@jit(inline="always")
def _cos_poly(z):
    """``cos r - 1 = z (-1/2 + z p(z))``: this is ``p``."""
    return fma(z, fma(z, fma(z, fma(z, fma(z, C6, C5), C4), C3), C2), C1)


@jit(inline="always")
def _normalise(s, cm):
    """One Newton step on the pair ``(s, 1 + cm)`` towards ``s^2 + (1 + cm)^2 = 1``,
    in increment form (``cm`` small, kept to full relative accuracy)."""
    g = 0.5 * fma(s, s, cm * (2.0 + cm))
    return fma(-s, g, s), fma(-(1.0 + cm), g, cm)


@jit(inline="always")
def sincos_small(x):
    """``(sin x, cos x, cos x - 1)`` for ``|x| <= 0.78``, normalised (no range reduction)."""
    z = x * x
    s = fma(x, z * _sin_poly(z), x)
    cm = z * fma(z, _cos_poly(z), -0.5)
    s, cm = _normalise(s, cm)
    return s, 1.0 + cm, cm


@jit(inline="always")
def sincos_small_raw(x):
    """:func:`sincos_small` without the normalisation: for a turn in increment form, whose
    pair's norm error ``eps sin^2`` is already far below round-off (cheaper by three
    fused multiply-adds)."""
    z = x * x
    cm = z * fma(z, _cos_poly(z), -0.5)
    return fma(x, z * _sin_poly(z), x), 1.0 + cm, cm


@jit(inline="always")
def sincos_turn(x):
    """:func:`sincos_small_raw` with the polynomials evaluated in Estrin's scheme: the
    same coefficients, the terms paired as ``(a + b z) + z^2 ((c + d z) + z^2 (e + f z))``,
    so that the chain from ``x`` to the pair is three fused multiply-adds shorter than
    Horner's (within an ulp of the correctly rounded values and with the pair's norm
    error ``eps sin^2``-small, as Horner's).
    The one-body axis turn takes it: its step is a chain of dependent turns, so the
    latency is its cost (``splitting2`` on a free body 52 -> 46 ns a step); the SIMD
    loops, bound by throughput, keep Horner's (one multiplication fewer)."""
    z = x * x
    z2 = z * z
    sp = fma(z2, fma(z2, fma(z, S6, S5), fma(z, S4, S3)), fma(z, S2, S1))
    cp = fma(z2, fma(z2, fma(z, C6, C5), fma(z, C4, C3)), fma(z, C2, C1))
    cm = z * fma(z, cp, -0.5)
    return fma(x, z * sp, x), 1.0 + cm, cm


@jit(inline="always")
def _reduce(x):
    """``x = k pi/2 + r``: ``(k, r)``, Cody–Waite in three parts, ``r`` clamped."""
    k = np.floor(x * TWO_OVER_PI + 0.5)
    r = fma(-k, PIO2_2T, fma(-k, PIO2_2, fma(-k, PIO2_1, x)))
    r = R_CLAMP if r > R_CLAMP else r  # keeps NaN
    r = -R_CLAMP if r < -R_CLAMP else r
    return k, r


@jit(inline="always")
def _quadrant(k, s, c):
    """``(sin x, cos x)`` from ``(sin r, cos r)`` and the quadrant ``k`` (exact)."""
    kq = k - 4.0 * np.floor(0.25 * k)  # k mod 4, exact
    hi = np.floor(0.5 * kq)  # kq in {2, 3}
    odd = kq - 2.0 * hi  # kq in {1, 3}
    sx = (c if odd != 0.0 else s) * (1.0 - 2.0 * hi)
    cx = (s if odd != 0.0 else c) * (1.0 - 2.0 * abs(odd - hi))
    return kq, sx, cx


@jit(inline="always")
def sincos(x):
    """``(sin x, cos x, cos x - 1)`` for any ``x``, normalised; equal to
    :func:`sincos_small` bit for bit where ``|x| < pi/4``.

    In the first quadrant (``k = 0 mod 4``) the pair is normalised in increment form,
    ``(s, cm)``; elsewhere ``cos x`` is not near 1 and the plain pair ``(s, c)`` is
    normalised (``cm = c - 1`` is then only needed to absolute accuracy).
    """
    k, r = _reduce(x)
    z = r * r
    s = fma(r, z * _sin_poly(z), r)
    cm = z * fma(z, _cos_poly(z), -0.5)
    kq, sx, cx = _quadrant(k, s, 1.0 + cm)
    first = kq == 0.0
    g = 0.5 * (fma(s, s, cm * (2.0 + cm)) if first else fma(sx, sx, fma(cx, cx, -1.0)))
    sx = fma(-sx, g, sx)
    cm = fma(-(1.0 + cm), g, cm)
    cx = fma(-cx, g, cx)
    cmx = cm if first else cx - 1.0
    cx = 1.0 + cm if first else cx
    return sx, cx, cmx


@jit(inline="always")
def sincos_plain(x):
    """``(sin x, cos x)`` for any ``x``: :func:`sincos`'s reduction and polynomials in
    Estrin's scheme (:func:`sincos_turn`), without the normalisation of the pair (within
    a few ulps of the correctly rounded values; the pair's norm is off 1 by as much). For
    a value that is not a turn (a circular orbit's position): a shorter chain."""
    k, r = _reduce(x)
    s, c, _ = sincos_turn(r)
    _, sx, cx = _quadrant(k, s, c)
    return sx, cx


@jit
def sincos_array(x, s, c, cm, small):
    """:func:`sincos` (or :func:`sincos_small`) of every element of ``x`` (tests)."""
    for i in range(x.shape[0]):
        if small:
            s[i], c[i], cm[i] = sincos_small(x[i])
        else:
            s[i], c[i], cm[i] = sincos(x[i])


@jit
def sincos_plain_array(x, s, c):
    """:func:`sincos_plain` of every element of ``x`` (tests)."""
    for i in range(x.shape[0]):
        s[i], c[i] = sincos_plain(x[i])
