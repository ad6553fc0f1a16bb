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

No writable cache folder (a read-only install in a container or a shared
site-packages, a read-only home, ``NUMBA_CACHE_DIR`` unset): numba refuses
``cache=True`` with ``RuntimeError: cannot cache function ...: no locator available``
when the decorator is applied, i.e. when a kernel module is first imported. :func:`jit`
then compiles that kernel and every later one without the disk cache, for the rest of
the process, and says so once with a :class:`CacheWarning`: the results are the same
(the cache only stores compiled code), each new process just compiles again. Setting
``NUMBA_CACHE_DIR`` to a writable folder brings the cache back.

numba itself is imported on the first kernel, not with this module, so
``liebody.CacheWarning`` can be named (e.g. in a warnings filter) without loading it.
"""

from __future__ import annotations

import warnings

from liebody.errors import CacheWarning

#: Options every kernel is compiled with.
OPTIONS: dict = {"cache": True, "nogil": True, "error_model": "numpy"}

#: The reason the disk cache is off in this process (``None`` while it works).
_cache_off: str | None = None


def _no_cache(exc: Exception) -> None:
    """Turn the disk cache off for the rest of the process and warn once."""
    global _cache_off
    _cache_off = str(exc)
    warnings.warn(
        f"liebody: numba cannot cache compiled kernels ({exc}): no writable cache folder "
        f"was found, e.g. a read-only install. The kernels are compiled without the disk "
        f"cache, so every new process compiles them again (the results are the same). "
        f"Set the environment variable NUMBA_CACHE_DIR to a writable folder to cache them.",
        CacheWarning, stacklevel=4)


def _compile(fn, options: dict):
    from numba import njit

    if options.get("cache") and _cache_off is not None:
        options = {**options, "cache": False}
    try:
        return njit(**options)(fn)
    except RuntimeError as exc:  # raised by numba's cache locator search, and only there
        if not options.get("cache"):
            raise
        _no_cache(exc)
        return njit(**{**options, "cache": False})(fn)


def jit(*args, **extra):
    """``numba.njit`` with :data:`OPTIONS` (plus per-kernel extras such as ``inline``).

    Use as ``@jit`` or ``@jit(inline="always")``. Without a writable cache folder the
    kernel is compiled without the disk cache (see the module docstring).
    """
    options = {**OPTIONS, **extra}
    if args:
        return _compile(args[0], options)
    return lambda fn: _compile(fn, options)
