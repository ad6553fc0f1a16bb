"""The one jit policy of liebody's kernels.

Every kernel is compiled with :func:`jit`, so the options live here and nowhere else:

* ``cache=True`` — compiled code is written to numba's disk cache on first use and
  loaded from it in later processes (nothing compiles at ``import liebody``);
* ``nogil=True`` — a running kernel releases the GIL, so several threads can
  integrate at once;
* ``error_model="numpy"`` — a division by zero gives ``inf``/``nan`` like numpy
  instead of raising ``ZeroDivisionError`` from deep inside a kernel; every driver
  checks its state for non-finite values and reports where it failed;
* no ``fastmath``: results are reproducible bit for bit and agree with the
  uncompiled kernels (``NUMBA_DISABLE_JIT=1``) to round-off.
"""

from __future__ import annotations

from numba import njit

#: Options every kernel is compiled with.
OPTIONS: dict = {"cache": True, "nogil": True, "error_model": "numpy"}


def jit(*args, **extra):
    """``numba.njit`` with :data:`OPTIONS` (plus per-kernel extras such as ``inline``).

    Use as ``@jit`` or ``@jit(inline="always")``.
    """
    return njit(*args, **{**OPTIONS, **extra})
