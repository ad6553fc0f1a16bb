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

Processes that compile at the same time (a Dask ``LocalCluster``'s workers, a
multiprocessing pool, two test runs) share the cache folder. numba's own cache write
reads the index, picks a data file name, writes the index and then the data, with no
lock. Two processes saving different compiled versions of one function (the drivers of
two families are closures of one function, so they share one index) could both pick the
same data file, and the index then named one version's code for the other's key. A later
process would run the wrong kernel and return wrong numbers without a word.
:class:`LockedCacheFile` closes that race: the whole save runs under a file lock
(``fcntl.flock`` on ``<index>.lock``), and the data is written before the index names
it, so an index never points at data that is missing or belongs to another key.

Every kernel has its own name. numba names a compiled function by its module, its
qualified name and a counter of the compiling process, and a kernel that calls another
refers to it by that name. Kernels made by a factory (the driver of each family, the
SIMD loops of each axis) are closures of one qualified name, so two of them compiled in
two processes could carry the same name, and a third process loading both from the cache
linked a caller to the wrong one: two ensembles of different methods, each first run in a
process of its own, gave the second method's bodies the first method's numbers when run
again in one process. A factory therefore gives each kernel a ``tag``, appended to its
qualified name (``_runner.<locals>.run_family3``), and :func:`jit` refuses two kernels of
one name.

A damaged cache entry (a truncated or overwritten ``*.nbi`` index or ``*.nbc`` data file:
a full disk, a write interrupted on a file system without atomic rename, a cache copied
by hand) made numba fail every call of the kernel in every new process, with
``UnpicklingError``, ``EOFError`` or ``RuntimeError: LLVM bitcode parsing error``, naming
neither the cache nor the fix. Every cached kernel therefore gets :class:`SafeCache`, a
numba cache whose load treats any failure as a cache miss: the kernel compiles again,
the bad file is deleted and replaced by the new entry, and the first such entry of a
process warns (:class:`~liebody.errors.CacheWarning`, naming the file, its folder and how
to clear the cache). A save that fails (a folder that cannot be written) warns the same
way instead of failing the compile: the kernel runs, uncached.

Wrappers. numba builds two wrappers around every compiled function besides its code:
one that Python calls (argument unboxing) and a C-callable one (for first-class function
values). liebody calls no kernel as a first-class function, so no kernel gets the C
wrapper; a helper called only from other kernels (``jit(inner=True)``) gets neither.
Each wrapper is lowered and optimised by LLVM like a small kernel, about 12 and 17 ms
of a first compile per kernel. Calling an inner helper from Python raises
``TypeError`` (numba itself would jump to the missing wrapper); with the JIT off it is
the plain Python function.

numba itself is imported on the first kernel, not with this module, so
``liebody.CacheWarning`` can be named (e.g. in a warnings filter) without loading it.
"""

from __future__ import annotations

import contextlib
import os
import warnings

from liebody.errors import CacheWarning

#: Options every kernel is compiled with.
OPTIONS: dict = {"cache": True, "nogil": True, "error_model": "numpy",
                 "no_cfunc_wrapper": True}
#: Options added for a helper called only from kernels (``jit(inner=True)``).
INNER_OPTIONS: dict = {"no_cpython_wrapper": True}

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


@contextlib.contextmanager
def _file_lock(path: str):
    """An exclusive inter-process lock held on ``path`` (created if needed). No lock where
    ``fcntl`` is not available (Windows) or the file system refuses it: the save then
    goes on unlocked, data before index, rather than fail the compile."""
    try:
        import fcntl
    except ImportError:  # pragma: no cover - not POSIX
        yield
        return
    try:
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o666)
    except OSError:  # no lock file here: save as numba does (data first still)
        yield
        return
    try:
        with contextlib.suppress(OSError):  # a file system without flock (network mounts)
            fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)  # releases the lock


def _locked_cache_file_class():
    """:class:`LockedCacheFile`, made on first use (it subclasses a numba class)."""
    global LockedCacheFile
    if LockedCacheFile is not None:
        return LockedCacheFile
    from numba.core.caching import IndexDataCacheFile

    class _LockedCacheFile(IndexDataCacheFile):
        """numba's index-and-data cache file with its save made safe between processes:
        under a lock on ``<index>.lock``, the data is written before the index names it.
        ``reading`` is the file a load is reading (what to blame when it fails)."""

        reading: str | None = None

        def load(self, key):
            self.reading = self._index_path
            overloads = self._load_index()
            data_name = overloads.get(key)
            if data_name is None:
                return None
            self.reading = self._data_path(data_name)
            try:
                return self._load_data(data_name)
            except FileNotFoundError:  # removed while the index still names it: a miss
                return None

        def save(self, key, data):
            with _file_lock(self._index_path + ".lock"):
                try:
                    overloads = self._load_index()
                except Exception:  # a damaged index: rewritten with this entry alone
                    overloads = {}
                data_name = overloads.get(key)
                if data_name is None:
                    existing = set(overloads.values())
                    number = 1
                    while self._data_name(number) in existing:
                        number += 1
                    data_name = self._data_name(number)
                    self._save_data(data_name, data)
                    overloads[key] = data_name
                    self._save_index(overloads)
                else:
                    self._save_data(data_name, data)

    LockedCacheFile = _LockedCacheFile
    return LockedCacheFile


#: The cache file class of every cached kernel (made on the first kernel).
LockedCacheFile = None


#: the warnings of the disk cache given in this process (each kind once)
_WARNED: set[str] = set()
#: the folder numba caches liebody's kernels in (``None`` before the first cached kernel)
_FOLDER: str | None = None


def cache_folder() -> str:
    """The folder numba's disk cache keeps liebody's compiled kernels in, in words."""
    from numba.core import config

    root = getattr(config, "CACHE_DIR", "") or ""
    if root:
        return f"{root} (NUMBA_CACHE_DIR)"
    if _FOLDER is not None:
        return f"{os.path.dirname(_FOLDER)} (NUMBA_CACHE_DIR is not set)"
    return "numba's default cache folder (NUMBA_CACHE_DIR is not set)"


def cache_advice() -> str:
    """How to clear numba's disk cache of liebody's kernels, for messages."""
    return (f"to clear numba's disk cache, delete the folder {cache_folder()} or set the "
            f"environment variable NUMBA_CACHE_DIR to an empty folder, then start a new "
            f"process")


def _warn_once(kind: str, message: str) -> None:
    if kind in _WARNED:
        return
    _WARNED.add(kind)
    warnings.warn(message, CacheWarning, stacklevel=3)


def _damaged(cache, exc: Exception) -> None:
    """A cache load raised: delete the file it was reading (the compile that follows
    writes a new entry) and warn, once per process."""
    path = getattr(cache._cache_file, "reading", None)
    removed = False
    if path is not None:
        index = cache._cache_file._index_path
        with _file_lock(index + ".lock"), contextlib.suppress(OSError):
            os.unlink(path)
            removed = True
    what = (f"the cache file {path}" if path is not None
            else f"an entry of the cache folder {cache._cache_path}")
    done = ("it was deleted and the kernel compiled again (its new entry replaces it)"
            if removed else "the kernel was compiled again, but the file could not be "
                            "deleted")
    _warn_once("damaged", (
        f"liebody: numba could not load {what} ({type(exc).__name__}: "
        f"{str(exc)[:200]}): the file is damaged (truncated or overwritten: a full disk, "
        f"an interrupted write, a copied cache). {done[0].upper()}{done[1:]}; results are "
        f"not affected. Later damaged entries in this process are treated the same way "
        f"without another warning. If this recurs, {cache_advice()}."))


def _unsaved(cache, exc: Exception) -> None:
    _warn_once("unsaved", (
        f"liebody: numba could not write a compiled kernel to its disk cache in "
        f"{cache._cache_path} ({type(exc).__name__}: {str(exc)[:200]}). The kernel runs "
        f"(results are the same), but new processes compile it again. Set the "
        f"environment variable NUMBA_CACHE_DIR to a writable folder to cache it."))


def _safe_cache_class(base):
    """:class:`SafeCache` for numba's cache class ``base`` (made once per class)."""
    cls = _SAFE_CACHES.get(base)
    if cls is not None:
        return cls

    class SafeCache(base):
        """numba's cache of one kernel, whose failing load is a cache miss (the bad file
        deleted, a :class:`~liebody.errors.CacheWarning`) and whose failing save warns
        instead of failing the compile."""

        def load_overload(self, sig, target_context):
            self._cache_file.reading = None
            try:
                return super().load_overload(sig, target_context)
            except Exception as exc:
                _damaged(self, exc)
                return None

        def save_overload(self, sig, data):
            try:
                super().save_overload(sig, data)
            except Exception as exc:
                _unsaved(self, exc)

    SafeCache.__name__ = SafeCache.__qualname__ = f"Safe{base.__name__}"
    _SAFE_CACHES[base] = SafeCache
    return SafeCache


_SAFE_CACHES: dict = {}


def _lock_cache(dispatcher) -> None:
    """Give a cached kernel the safe cache file and cache (see the module docstring)."""
    global _FOLDER
    cache = getattr(dispatcher, "_cache", None)
    cache_file = getattr(cache, "_cache_file", None)
    cls = _locked_cache_file_class()
    if cache_file is not None and isinstance(cache_file, cls.__bases__[0]):
        cache_file.__class__ = cls
        if type(cache) in _SAFE_CACHES.values():
            return
        cache.__class__ = _safe_cache_class(type(cache))
        if _FOLDER is None:
            _FOLDER = getattr(cache, "_cache_path", None)


def _compile(fn, options: dict):
    from numba import njit

    if options.get("cache") and _cache_off is not None:
        options = {**options, "cache": False}
    try:
        dispatcher = njit(**options)(fn)
    except RuntimeError as exc:  # raised by numba's cache locator search, and only there
        if not options.get("cache"):
            raise
        _no_cache(exc)
        return njit(**{**options, "cache": False})(fn)
    if options.get("cache"):
        _lock_cache(dispatcher)
    return dispatcher


def _inner_class(base):
    """The dispatcher class of an inner helper: ``base`` whose call from Python raises
    (made once per class)."""
    cls = _INNER_CLASSES.get(base)
    if cls is None:
        def __call__(self, *args, **kwargs):
            raise TypeError(
                f"{self.py_func.__module__}.{self.py_func.__qualname__} is a helper of "
                f"liebody's compiled kernels, compiled without a Python entry point; it "
                f"can be called only from other kernels")

        cls = type(f"Inner{base.__name__}", (base,), {"__call__": __call__})
        _INNER_CLASSES[base] = cls
    return cls


_INNER_CLASSES: dict = {}


#: ``module:qualname`` of every kernel made so far (each name once: see the docstring)
_NAMES: dict[str, object] = {}


def _name(fn, tag: str | None):
    """Append ``tag`` to ``fn``'s qualified name and check that no other kernel has it."""
    if tag is not None:
        fn.__qualname__ = f"{fn.__qualname__}_{tag}"
    key = f"{fn.__module__}:{fn.__qualname__}"
    if _NAMES.setdefault(key, fn) is not fn:
        raise RuntimeError(
            f"two kernels are named {key}: numba would link one for the other when both "
            f"come from its disk cache; give each kernel a factory makes its own "
            f"jit(tag=...)")
    return fn


def jit(*args, tag: str | None = None, inner: bool = False, **extra):
    """``numba.njit`` with :data:`OPTIONS` (plus per-kernel extras such as ``inline``).

    Use as ``@jit`` or ``@jit(inline="always")``; a kernel made by a factory takes a
    ``tag`` that makes its name its own (``@jit(tag=f"family{family}")``, see the module
    docstring). ``inner=True``: a helper called only from other kernels, compiled
    without the wrapper Python calls (:data:`INNER_OPTIONS`; a call from Python raises
    ``TypeError``). Without a writable cache folder the kernel is compiled without the
    disk cache.
    """
    options = {**OPTIONS, **(INNER_OPTIONS if inner else {}), **extra}

    def make(fn):
        dispatcher = _compile(_name(fn, tag), options)
        if inner and hasattr(dispatcher, "py_func"):  # (not with NUMBA_DISABLE_JIT)
            dispatcher.__class__ = _inner_class(type(dispatcher))
        return dispatcher

    if args:
        return make(args[0])
    return make


def overload_options() -> dict:
    """The ``jit_options`` of a numba ``@overload`` implementation: :data:`OPTIONS`
    without the disk cache. An overload is compiled into each kernel that calls it, and
    that kernel is cached (or not) by :func:`jit`; asking numba to cache the overload
    itself bypassed the no-cache fallback and failed a read-only install. (The
    wrapper options are left to numba: an overload is compiled into its caller.)"""
    return {k: v for k, v in OPTIONS.items() if k not in ("cache", "no_cfunc_wrapper")}
