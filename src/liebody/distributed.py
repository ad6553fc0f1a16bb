"""Ensembles beyond one machine: :func:`integrate` on a Dask cluster.

``pip install "liebody[distributed]"`` installs Dask's distributed scheduler. The call
takes the arguments of :func:`liebody.integrate` and returns the same
:class:`~liebody.Trajectory`: the ensemble is split into chunks of bodies, each chunk
one task that runs ``liebody.integrate`` (the same kernels) on a worker, and the
results are gathered in body order. The result is the local batched call's, bit for
bit: each body's numbers do not depend on which chunk or machine computed them.

Tasks are pure functions of their inputs, so a worker lost mid-run loses nothing: the
scheduler recomputes its chunks on the workers that are left.

Running on a real cluster needs no change of code, only another client::

    from dask.distributed import Client
    client = Client("tcp://scheduler-host:8786")        # a running scheduler
    traj = liebody.distributed.integrate(scene, q0=q0, L0=L0, dt=1e-3, steps=10**6,
                                         client=client, save_every=None,
                                         diagnostics=True)

On a Slurm or PBS machine, ``dask-jobqueue`` starts the workers as batch jobs::

    from dask_jobqueue import SLURMCluster
    cluster = SLURMCluster(cores=32, processes=4, memory="64GB", walltime="02:00:00")
    cluster.scale(jobs=10)
    client = Client(cluster)

Every worker needs liebody installed (the same version). Each worker compiles the
kernels once (or loads them from its numba cache: point ``NUMBA_CACHE_DIR`` at a
shared or node-local folder), so give every task enough work (the default chunk is
a few thousand bodies). A user torque must be importable or picklable on the
workers (a module-level ``@njit`` function is; a lambda is not).

For very large runs, ``gather=False`` leaves the samples on the cluster as Dask
arrays (:class:`DistributedResult`) instead of bringing them home.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

__all__ = ["DistributedResult", "integrate"]

#: bodies per task when ``bodies_per_task`` is not given: enough work per task to hide
#: the scheduler's overhead, small enough to spread over many workers
DEFAULT_BODIES_PER_TASK = 4096


def _client(client):
    try:
        from dask.distributed import default_client
    except ImportError as exc:  # pragma: no cover - the extra is missing
        raise ImportError("liebody.distributed needs Dask's distributed scheduler: "
                          "pip install 'liebody[distributed]'") from exc
    if client is None:
        try:
            return default_client()
        except ValueError:
            raise ValueError("no Dask client: pass client=Client(...) or create one first "
                             "(dask.distributed.Client(), or a LocalCluster)") from None
    return client


def _run_chunk(scene, q0, m0, kwargs, controls=None):
    """One task: the local batched integrate of a chunk of bodies (runs on a worker)."""
    import warnings

    import liebody

    kwargs = dict(kwargs)
    kwargs[kwargs.pop("momentum")] = m0
    if controls is not None:
        kwargs["controls"] = controls
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        traj = liebody.integrate(scene, q0=q0, **kwargs)
    return {"t": traj.t, "q": traj.q, "L": traj.L, "failed_at": np.asarray(traj.failed_at),
            "status": np.asarray(traj.status), "info": traj.info,
            "diagnostics": traj.diagnostics,
            "warnings": [(w.category, str(w.message)) for w in caught]}


@dataclass
class DistributedResult:
    """An ensemble's samples left on the cluster (``gather=False``): Dask arrays with the
    body axis first, chunked by task. :meth:`to_trajectory` brings them home."""

    t: object
    q: object
    L: object
    failed_at: object
    scene: object
    method: object
    dt: float
    #: per task, a future of its (info, diagnostics, status): small, fetched by
    #: :meth:`to_trajectory`
    extras: list | None = None

    def to_trajectory(self):
        """Compute the arrays and wrap them in a :class:`liebody.Trajectory` (with the
        tasks' ``info``, ``status`` and ``diagnostics``, as the gathered call gives)."""
        import dask

        from liebody.trajectory import Trajectory

        t, q, L, failed = dask.compute(self.t, self.q, self.L, self.failed_at)
        if not self.extras:
            status = np.where(np.isnan(failed), "complete", "failed").astype(object)
            return Trajectory(t, q, L, self.scene, self.method, self.dt, failed_at=failed,
                              status=status)
        extras = self.extras[0].client.gather(self.extras)
        infos, diags, statuses = zip(*extras, strict=True)
        return Trajectory(t, q, L, self.scene, self.method, self.dt, failed_at=failed,
                          info=_one_info(list(infos)), status=np.concatenate(statuses),
                          diagnostics=_concat_diagnostics(list(diags)))


def integrate(scene, *, q0=(1.0, 0.0, 0.0, 0.0), L0=None, omega0=None, dt, steps=None,
              t_end=None, method=None, save_every=1, diagnostics: bool = False,
              controls=None, t0: float = 0.0, client=None,
              bodies_per_task: int | None = None, threads_per_task: int = 1,
              gather: bool = True, simd: bool | None = None):
    """:func:`liebody.integrate` for an ensemble, split over a Dask cluster.

    Parameters
    ----------
    scene, q0, L0, omega0, dt, steps, t_end, method, save_every, diagnostics, controls, t0, simd
        As for :func:`liebody.integrate` (the ensemble given by the body axis of the
        states and of the scene's parameters; ``controls`` ``(k,)`` or one row per body
        ``(N, k)``). ``simd=None`` is decided once for the whole ensemble, so that every
        task runs the kernels the local call would.
    client
        A ``dask.distributed.Client``; ``None``: the current default client.
    bodies_per_task
        Bodies per task (default ``DEFAULT_BODIES_PER_TASK``, at least one task
        per worker thread where there are enough bodies).
    threads_per_task
        Threads each task runs on (1: let Dask run one task per worker thread).
    gather
        ``True``: return a :class:`~liebody.Trajectory`, the same as the local call.
        ``False``: a :class:`DistributedResult` of Dask arrays left on the cluster.
    """
    import liebody
    from liebody import _methods
    from liebody._integrate import _bodies, _initial_momentum, as_controls
    from liebody._validate import as_positive_int
    from liebody._validate import as_unit_quaternion as _as_unit_q

    client = _client(client)
    q_init = _as_unit_q("q0", q0)
    m_init = _initial_momentum(scene, L0, omega0)
    n = _bodies(scene, q_init, m_init)
    # the workers get the caller's own numbers and validate them as the local call does
    # (normalising an already normalised q0 could move its last bit)
    q_raw = np.asarray(q0, dtype=float)
    m_raw, m_name = ((np.asarray(L0, dtype=float), "L0") if L0 is not None
                     else (np.asarray(omega0, dtype=float), "omega0"))
    if n is None:
        raise ValueError("liebody.distributed.integrate splits an ensemble over a cluster: "
                         "give q0 (N, 4), L0/omega0 (N, 3) or a scene with a body axis; "
                         "integrate one body with liebody.integrate")
    q_raw = np.ascontiguousarray(np.broadcast_to(q_raw, (n, 4)))
    m_raw = np.ascontiguousarray(np.broadcast_to(m_raw, (n, 3)))
    method = _methods.get(scene.default_method if method is None else method)
    _methods.check_supports(method, scene)
    per_task = (DEFAULT_BODIES_PER_TASK if bodies_per_task is None
                else as_positive_int("bodies_per_task", bodies_per_task))
    workers = max(1, sum(client.nthreads().values()))
    per_task = max(1, min(per_task, math.ceil(n / workers)))
    u = as_controls(scene, controls, n)  # checked here, as the local call checks it
    kwargs = {"dt": dt, "steps": steps, "t_end": t_end, "method": method.name, "momentum": m_name,
              "save_every": save_every, "diagnostics": diagnostics, "t0": t0,
              "threads": as_positive_int("threads_per_task", threads_per_task),
              "simd": _simd_for(simd, n)}
    edges = list(range(0, n, per_task)) + [n]
    chunks = [slice(a, b) for a, b in itertools.pairwise(edges)]
    batched = bool(scene.batch_shape)
    # a fresh key per call (hash=False): a repeated call with the same scene must not
    # reuse the key of data that the previous call's release may be dropping
    scene_f = client.scatter(scene, broadcast=True, hash=False) if not batched else None

    def controls_of(c):
        if controls is None:
            return None
        return u[c] if np.ndim(u) == 2 else u

    futures = [client.submit(_run_chunk, scene.take(c) if batched else scene_f,
                             q_raw[c], m_raw[c], kwargs, controls_of(c), pure=True)
               for c in chunks]
    if not gather:
        return _as_dask(futures, chunks, scene, method, float(dt), client)
    parts = client.gather(futures)
    return _assemble(parts, scene, method, float(dt), diagnostics, liebody)


def _simd_for(simd, n: int) -> bool:
    """The local call's choice for ``n`` bodies, made once for all tasks (a task of fewer
    bodies would otherwise fall below ``SIMD_MIN_BODIES`` and run other kernels)."""
    if simd is not None:
        if not isinstance(simd, bool | np.bool_):
            raise TypeError(f"simd must be True, False or None, got {type(simd).__name__}")
        return bool(simd)
    from liebody._kernels.batch import SIMD_MIN_BODIES

    return n >= SIMD_MIN_BODIES


def _assemble(parts, scene, method, dt, diagnostics, liebody):
    """One Trajectory from the chunks' results, in body order. The warnings about failed
    bodies and invariants are made again for the whole ensemble (a task's counts and
    body numbers are its own); any other warning is passed on once."""
    import warnings

    from liebody._ensemble import failure_message
    from liebody._integrate import warn_invariants
    from liebody.errors import InvariantWarning

    seen = set()
    for p in parts:
        for category, message in p["warnings"]:
            ours = issubclass(category, InvariantWarning) or (
                issubclass(category, RuntimeWarning) and " bodies failed: " in message)
            if not ours and (category, message) not in seen:
                seen.add((category, message))
                warnings.warn(message, category, stacklevel=3)
    status = np.concatenate([p["status"] for p in parts])
    failed_at = np.concatenate([p["failed_at"] for p in parts])
    message = failure_message(method.name, status, failed_at)
    if message:
        warnings.warn(message, RuntimeWarning, stacklevel=3)
    traj = liebody.Trajectory(
        parts[0]["t"], np.concatenate([p["q"] for p in parts]),
        np.concatenate([p["L"] for p in parts]), scene, method, dt, failed_at=failed_at,
        info=_one_info([p["info"] for p in parts]), status=status,
        diagnostics=_concat_diagnostics([p["diagnostics"] for p in parts]) if diagnostics
        else None)
    return warn_invariants(traj, stacklevel=4)


def _one_info(infos: list) -> dict:
    """The tasks' ``info``: one dict when they agree, else ``{"tasks": [...]}``."""
    return infos[0] if all(_same(i, infos[0]) for i in infos[1:]) else {"tasks": infos}


def _concat_diagnostics(diags: list) -> dict | None:
    if not diags or diags[0] is None:
        return None
    return {k: np.concatenate([d[k] for d in diags]) for k in diags[0]}


def _same(a, b) -> bool:
    """Equality of two tasks' ``info`` (dicts that may hold arrays: the bodies of groups)."""
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, list | tuple) and isinstance(b, list | tuple):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return np.array_equal(np.asarray(a), np.asarray(b))
    return a == b


def _as_dask(futures, chunks, scene, method, dt, client):
    import dask.array as da

    n_samples = None

    def part(name, width):
        arrays = []
        for f, c in zip(futures, chunks, strict=True):
            rows = c.stop - c.start
            shape = (rows, n_samples) + ((width,) if width else ())
            arrays.append(da.from_delayed(client.submit(lambda r, k=name: r[k], f, pure=True),
                                          shape=shape, dtype=float))
        return da.concatenate(arrays, axis=0)

    first = client.submit(lambda r: r["t"], futures[0], pure=True)
    t = client.gather(first)
    n_samples = len(t)
    q, L = part("q", 4), part("L", 3)
    failed = da.concatenate([
        da.from_delayed(client.submit(lambda r: r["failed_at"], f, pure=True),
                        shape=(c.stop - c.start,), dtype=float)
        for f, c in zip(futures, chunks, strict=True)])
    extras = [client.submit(lambda r: (r["info"], r["diagnostics"], r["status"]), f,
                            pure=True) for f in futures]
    return DistributedResult(t, q, L, failed, scene, method, dt, extras)
