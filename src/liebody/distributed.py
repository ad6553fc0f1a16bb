"""Ensembles beyond one machine: :func:`integrate` on a Dask cluster.

``pip install "liebody[distributed]"`` installs Dask's distributed scheduler. The call
takes the arguments of :func:`liebody.integrate` and returns the same
:class:`~liebody.Trajectory`: the ensemble is split into chunks of bodies, each chunk
one task that runs the local ensemble run (the same kernels) on a worker, and the
results are gathered in body order. The result is the local batched call's, bit for
bit: each body's numbers do not depend on which chunk or machine computed them, and
``status``, ``failed_at``, ``info`` (with the bodies of each group numbered in the
whole ensemble) and the warnings are those of the local call.

The client does everything that can fail before the run, as the local call does:
it validates every argument, checks that the client is a running
``dask.distributed.Client``, calls the scene's own functions on the initial state
(a user torque of the wrong shape or that reads ``L`` though the scene promises
``orientation_only``, a user potential that fails), warns where the exact flow's
phase is lost, plans the ensemble (``info``, and a step the method refuses), and
refuses a run whose gathered samples do not fit in its memory, or whose tasks'
samples do not fit in a worker's memory limit, before any task is submitted.
Reaction wheels (:class:`~liebody.ReactionWheels`) are refused: their runs are
cut where the wheels saturate and return the wheels' momenta, which the tasks do not
do. The tasks only run: a body that fails on a worker (a non-finite state, an
unsolved implicit equation, a torque that fails, even at the initial state) fails
alone, with its status and time, as in the local call.

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

import contextlib
import itertools
import math
import threading
import warnings
from dataclasses import dataclass

import numpy as np

__all__ = ["DistributedResult", "integrate"]

#: bodies per task when ``bodies_per_task`` is not given: enough work per task to hide
#: the scheduler's overhead, small enough to spread over many workers
DEFAULT_BODIES_PER_TASK = 4096


# ----------------------------------------------------------------------------------------
# the client
# ----------------------------------------------------------------------------------------


def _client(client):
    """A running, synchronous ``dask.distributed.Client`` (``None``: the default one), or
    a ``TypeError``/``ValueError`` that names ``client`` and says what it must be."""
    try:
        from dask.distributed import Client, default_client
    except ImportError as exc:  # pragma: no cover - the extra is missing
        raise ImportError("liebody.distributed needs Dask's distributed scheduler: "
                          "pip install 'liebody[distributed]'") from exc
    if client is None:
        try:
            client = default_client()
        except ValueError:
            raise ValueError("client=None but there is no default Dask client: pass "
                             "client=Client(...) or create one first "
                             "(dask.distributed.Client(), or a LocalCluster)") from None
    if isinstance(client, str | bytes):
        raise TypeError(f"client must be a dask.distributed.Client, not the address "
                        f"{client!r}: connect first, client=Client({client!r})")
    if not isinstance(client, Client):
        raise TypeError(f"client must be a dask.distributed.Client (or None for the "
                        f"default client), got {type(client).__name__}")
    if client.asynchronous:
        raise ValueError("client is asynchronous; liebody.distributed.integrate blocks "
                         "until the run ends and needs a synchronous Client")
    if client.status != "running":
        raise ValueError(f"client must be a running Client, but its status is "
                         f"{client.status!r} (closed, or not yet connected): create a "
                         f"new Client")
    return client


# ----------------------------------------------------------------------------------------
# the validated call (made on the client)
# ----------------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Call:
    """A validated call: what the client decided before submitting any task."""

    scene: object
    method: object
    q: np.ndarray  # (N, 4), validated and normalised as the local call does
    m: np.ndarray  # (N, 3)
    u: np.ndarray | None  # controls (k,) or (N, k)
    dt: float
    n_steps: int
    save_every: int
    t0: float
    times: np.ndarray  # the sample times, t0 + k dt
    diagnostics: bool
    simd: bool
    #: the local call's groups of bodies (global indices) and their plans' info; None
    #: for a sampled method (the exact flow plans nothing)
    groups: list | None

    @property
    def n(self) -> int:
        return self.q.shape[0]

    def task_spec(self, threads: int) -> dict:
        """What every task gets besides its bodies (small)."""
        return {"dt": self.dt, "n_steps": self.n_steps, "save_every": self.save_every,
                "t0": self.t0, "diagnostics": self.diagnostics, "simd": self.simd,
                "threads": threads}


def _validate(scene, q0, L0, omega0, dt, steps, t_end, method, save_every, diagnostics,
              controls, t0, simd, gather) -> _Call:
    """The checks of :func:`liebody.integrate`, in its order and with its messages, on
    the client: with ``gather``, that the ensemble's samples fit in the client's
    available memory (the local call's check, naming the size and a ``save_every``
    that fits); and its plans of the ensemble (a method's refusal of the step, the
    ``info`` of the groups)."""
    from liebody import _methods
    from liebody._integrate import (
        RUN_BYTES_PER_BODY,
        _bodies,
        _check_batch,
        _check_phase,
        _check_potential,
        _check_torque,
        _first_row,
        _initial_momentum,
        _sample_times,
        _stage_bytes_per_body,
        _step_count,
        as_controls,
    )
    from liebody._validate import as_positive_float, as_positive_int, clock_origin
    from liebody._validate import as_unit_quaternion as _as_unit_q
    from liebody.scenes import Scene

    if not isinstance(scene, Scene):
        from liebody._integrate import _is_coupled

        if _is_coupled(scene):
            raise TypeError(f"liebody.distributed.integrate splits an ensemble of independent "
                            f"bodies over a cluster; {type(scene).__name__} is one system of "
                            f"coupled bodies (every kick reads all of them): integrate it "
                            f"with liebody.integrate")
        raise TypeError(f"scene must be a liebody scene (FreeBody, HeavyTop, TorqueBody, "
                        f"DampedBody or a subclass of liebody.Scene), got {type(scene).__name__}")
    q = _as_unit_q("q0", q0)
    _check_batch("q0", q)
    m = _initial_momentum(scene, L0, omega0)
    dt = as_positive_float("dt", dt)
    if t0 != 0.0:
        t0 = clock_origin("t0", t0, dt)  # (the local call's refusal and words)
    n_steps = _step_count(dt, steps, t_end)
    save_every = n_steps if save_every is None else as_positive_int("save_every", save_every)
    if not isinstance(diagnostics, bool | np.bool_):
        raise TypeError(f"diagnostics must be True or False, got {type(diagnostics).__name__}")
    if simd is not None and not isinstance(simd, bool | np.bool_):
        raise TypeError(f"simd must be True, False or None, got {type(simd).__name__}")
    n = _bodies(scene, q, m)
    if n is None:
        raise ValueError("liebody.distributed.integrate splits an ensemble over a cluster: "
                         "give q0 (N, 4), L0/omega0 (N, 3) or a scene with a body axis; "
                         "integrate one body with liebody.integrate")
    method = _methods.get(scene.default_method if method is None else method)
    _methods.check_supports(method, scene)
    if scene.moving_rotor:
        raise ValueError(f"liebody.distributed.integrate does not run {type(scene).__name__} "
                         f"scenes (reaction wheels: the local call cuts each body's run where "
                         f"its wheels saturate and returns their momenta and saturations); "
                         f"use liebody.integrate")
    # the local call's checks of the scene's own functions on the initial state, before
    # any task: a user potential that fails, the exact flow's lost phase (a warning), a
    # torque of the wrong shape or that breaks its orientation_only promise
    model = scene.torque_model()
    _check_potential(scene, model, q, n, t0)
    u = as_controls(scene, controls, n)
    if method.sampled:
        _check_phase(scene, m, n_steps * dt)
    q = np.ascontiguousarray(np.broadcast_to(q, (n, 4)))
    m = np.ascontiguousarray(np.broadcast_to(m, (n, 3)))
    _check_torque(model, q[0], m[0], _first_row(u), float(t0), ensemble=True,
                  orientation_only=(model.function is not None
                                    and "momentum" not in scene.capabilities.torque))
    # the local call's memory check (its words too): the samples and each body's other
    # arrays (gathered, only the samples come back to this process)
    t = (_sample_times(n_steps, save_every, dt, n,
                       RUN_BYTES_PER_BODY + _stage_bytes_per_body(scene, method, m, dt, u))
         if gather else _sample_times(n_steps, save_every, dt, 1))
    times = t if t0 == 0.0 else t0 + t
    groups = None
    if not method.sampled:
        # the local call's plans of the whole ensemble: a step the method refuses is
        # refused here, in the local words and body numbers; only the groups' info is kept
        groups = [(idx, plan.info) for idx, plan in method.plans(scene, m, dt)]
    return _Call(scene, method, q, m, u, dt, n_steps, save_every, float(t0), times,
                 bool(diagnostics), _simd_for(simd, n), groups)


def _simd_for(simd, n: int) -> bool:
    """``simd`` for every task: the local call's choice for the whole ensemble of ``n``
    bodies (``None``: at least ``SIMD_MIN_BODIES``), so that a task of fewer bodies runs
    the kernels the local call runs."""
    if simd is not None:
        return bool(simd)
    from liebody._kernels.batch import SIMD_MIN_BODIES

    return n >= SIMD_MIN_BODIES


def _check_workers_memory(client, call: _Call, per_task: int) -> None:
    """Refuse (``ValueError``, naming the sizes) a run whose largest task's samples
    exceed a worker's memory limit, before any task is submitted."""
    from liebody._integrate import _per_sample

    try:
        workers = client.scheduler_info().get("workers", {}).values()
        limits = [int(w.get("memory_limit") or 0) for w in workers]
    except Exception:  # pragma: no cover - an old scheduler: no limits to check against
        limits = []
    limits = [x for x in limits if x > 0]
    if not limits:
        return
    limit = min(limits)
    k = len(call.times)
    need = k * _per_sample(per_task)
    if need > limit:
        # the bodies whose samples fit in half the limit (a body's share of a sample:
        # the bytes of two bodies' sample less one body's)
        per_body = _per_sample(2) - _per_sample(1)
        fit = max(1, int((limit // 2 - 8 * k) // (k * per_body)))
        raise ValueError(
            f"bodies_per_task = {per_task:,}: a task keeps {k:,} samples of {per_task:,} "
            f"bodies ({need / 1e9:.3g} GB), more than a worker's memory limit of "
            f"{limit / 1e9:.3g} GB; give bodies_per_task = {fit:,} or less, or raise "
            f"save_every")


# ----------------------------------------------------------------------------------------
# a task (runs on a worker)
# ----------------------------------------------------------------------------------------


def _run_task(scene, method, q0, m0, u, spec):
    """One task: the local ensemble run of a chunk of bodies, on a worker.

    The inputs were validated and planned on the client, so the task only runs:
    :class:`liebody._ensemble.Run`, the run engine behind the local call, with no
    check of its own (a body whose torque fails at the initial state fails alone, as
    any other failing body does). Returns the samples and the run's records: status,
    failed_at, diagnostics, which bodies ran the SIMD kernels, and the warnings the run
    emitted.
    """
    from liebody._engine import failure_summary
    from liebody._ensemble import Run
    from liebody._integrate import _sample_times

    rows = q0.shape[0]
    t = _sample_times(spec["n_steps"], spec["save_every"], spec["dt"], rows)
    run = Run(scene, method, q0, m0, spec["dt"], spec["n_steps"], spec["save_every"], t,
              scene.torque_model(), False, spec["threads"], spec["diagnostics"], u,
              spec["t0"], spec["simd"])
    with _task_warnings() as caught:
        traj = run.sampled() if method.sampled else run.stepped()
    return {"q": traj.q, "L": traj.L, "status": np.asarray(traj.status),
            "failed_at": np.asarray(traj.failed_at), "diagnostics": traj.diagnostics,
            "simd": _simd_record(traj.info, rows), "warnings": caught,
            "state": run.state, "reach": run.reach, "summary": failure_summary(
                method.name, traj.status, traj.failed_at, spec["dt"], run.model, run.state,
                u, run.reach)}


def _simd_record(info: dict, rows: int) -> np.ndarray | None:
    """Per body, whether it ran the SIMD kernels (from a run's ``info``; ``None`` where
    the run records no choice: the exact flow)."""
    if "groups" in info:
        flags = np.zeros(rows, dtype=bool)
        for g in info["groups"]:
            flags[g["bodies"]] = g["simd"]
        return flags
    if "simd" in info:
        return np.full(rows, bool(info["simd"]))
    return None


# the warnings of the tasks that run in the threads of one worker process: one
# process-wide hook (installed while any task runs) sends each warning to the task of
# its thread (warnings.catch_warnings swaps process-wide state and is not safe when
# two tasks run at once)
_capture_lock = threading.Lock()
_capture_logs: dict[int, list] = {}
_capture_saved: list = []


def _route(message, category, filename, lineno, file=None, line=None):
    log = _capture_logs.get(threading.get_ident())
    if log is not None:
        log.append((category, str(message)))
    elif _capture_saved:
        _capture_saved[1](message, category, filename, lineno, file, line)


@contextlib.contextmanager
def _task_warnings():
    """Record (category, message) of every warning this thread emits inside."""
    log: list = []
    me = threading.get_ident()
    with _capture_lock:
        if not _capture_logs:
            _capture_saved[:] = [warnings.filters, warnings.showwarning]
            warnings.filters = list(warnings.filters)
            warnings.simplefilter("always")
            warnings.showwarning = _route
        _capture_logs[me] = log
    try:
        yield log
    finally:
        with _capture_lock:
            del _capture_logs[me]
            if not _capture_logs:
                warnings.filters, warnings.showwarning = _capture_saved
                _capture_saved.clear()
                mutated = getattr(warnings, "_filters_mutated", None)
                if mutated is not None:
                    mutated()


# ----------------------------------------------------------------------------------------
# the result (made on the client)
# ----------------------------------------------------------------------------------------


def _finish(call: _Call, q, L, records: list, stacklevel: int):
    """The Trajectory of the whole ensemble from the samples ``q``, ``L`` and the tasks'
    records, in body order, with the local call's ``info`` and warnings: the failed
    bodies come from the records (``status``, ``failed_at``), the warnings about them
    and about the invariants are made for the whole ensemble; any other warning a task
    emitted is passed on once."""
    from liebody._engine import failure_summary, widest_reach
    from liebody._integrate import warn_invariants
    from liebody.errors import InvariantWarning
    from liebody.trajectory import Trajectory

    name = call.method.name
    status = np.concatenate([r["status"] for r in records])
    failed_at = np.concatenate([r["failed_at"] for r in records])
    # a task's own summary of its failed bodies, known from its records; the invariants
    # are checked again below over the whole ensemble
    model = call.scene.torque_model()
    summaries = {r["summary"] for r in records}
    seen = set()
    for r in records:
        for category, message in r["warnings"]:
            if issubclass(category, InvariantWarning) or message in summaries:
                continue
            if (category, message) not in seen:
                seen.add((category, message))
                warnings.warn(message, category, stacklevel=stacklevel + 1)
    states = (None if any(r["state"] is None for r in records)
              else np.concatenate([r["state"] for r in records]))
    message = failure_summary(name, status, failed_at, call.dt, model, states, call.u,
                              widest_reach(r["reach"] for r in records))
    if message:
        warnings.warn(message, RuntimeWarning, stacklevel=stacklevel + 1)
    diag = None
    if call.diagnostics:
        diag = {k: np.concatenate([r["diagnostics"][k] for r in records])
                for k in records[0]["diagnostics"]}
    traj = Trajectory(call.times, q, L, call.scene, call.method, call.dt,
                      failed_at=failed_at, info=_info(call, records), status=status,
                      diagnostics=diag)
    return warn_invariants(traj, stacklevel=stacklevel + 2)


def _info(call: _Call, records: list) -> dict:
    """The local call's ``info``: the plan's choices, and for several groups of bodies
    each group's choices with its bodies (indices in the whole ensemble); ``simd`` as
    the tasks ran them."""
    if call.groups is None:
        return {}
    parts = [r["simd"] for r in records]
    flags = np.concatenate(parts) if all(p is not None for p in parts) else None

    def simd_of(idx):
        if flags is None:  # pragma: no cover - a stepped run records its kernels
            return None
        f = flags[idx]
        return bool(f[0]) if f.all() or not f.any() else f.copy()

    if len(call.groups) == 1:
        idx, info = call.groups[0]
        return dict(info, simd=simd_of(idx))
    return {"groups": [dict(info, bodies=idx, simd=simd_of(idx))
                       for idx, info in call.groups]}


@dataclass
class DistributedResult:
    """An ensemble's samples left on the cluster (``gather=False``): Dask arrays with the
    body axis first, chunked by task. :meth:`to_trajectory` brings them home.

    Attributes
    ----------
    t : ndarray
        The sample times (on the client).
    q, L, failed_at : dask.array.Array
        ``(N, n, 4)``, ``(N, n, 3)`` and ``(N,)``, one chunk per task.
    scene, method, dt
        What was integrated, how, and the step.
    extras : list
        Per task, a future of its records (status, failed_at, diagnostics, kernels,
        warnings): small, fetched by :meth:`to_trajectory`.
    """

    t: object
    q: object
    L: object
    failed_at: object
    scene: object
    method: object
    dt: float
    extras: list | None = None
    _call: _Call | None = None

    def to_trajectory(self):
        """Compute the arrays and wrap them in a :class:`liebody.Trajectory`: the one the
        gathered call returns (``info``, ``status``, ``diagnostics`` and warnings
        included).

        Raises
        ------
        ValueError
            The samples do not fit in the available memory (the local call's check,
            with a ``save_every`` that fits); nothing is computed.
        """
        import dask

        from liebody._integrate import _sample_times

        call = self._call
        _sample_times(call.n_steps, call.save_every, call.dt, call.n)
        q, L = dask.compute(self.q, self.L)
        records = self.extras[0].client.gather(self.extras)
        return _finish(call, q, L, records, stacklevel=2)


# ----------------------------------------------------------------------------------------
# the call
# ----------------------------------------------------------------------------------------


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
        A running ``dask.distributed.Client``; ``None``: the current default client.
    bodies_per_task
        Bodies per task (default ``DEFAULT_BODIES_PER_TASK``, at least one task
        per worker thread where there are enough bodies).
    threads_per_task
        Threads each task runs on (1: let Dask run one task per worker thread).
    gather
        ``True``: return a :class:`~liebody.Trajectory`, the same as the local call.
        ``False``: a :class:`DistributedResult` of Dask arrays left on the cluster.

    Returns
    -------
    Trajectory or DistributedResult
        The local call's result: ``q``, ``L``, ``status``, ``failed_at``,
        ``diagnostics`` and ``info`` (its groups' ``bodies`` numbered in the whole
        ensemble), and the same warnings (one for the failed bodies of the whole
        ensemble, one for its invariants).

    Raises
    ------
    TypeError, ValueError
        Invalid arguments (as the local call; the messages name the argument), a
        ``client`` that is not a running ``dask.distributed.Client`` (an address
        string, a closed client), one body (use :func:`liebody.integrate`), samples
        that do not fit the client's available memory (``gather=True``) or a worker's
        memory limit: all before any task is submitted.
    Exception
        A task that raised (a worker that ran out of memory, a torque that cannot be
        unpickled on a worker): its exception, with a note naming its bodies; the
        other tasks are cancelled.
    """
    from liebody._validate import as_positive_int

    client = _client(client)
    per_task = (DEFAULT_BODIES_PER_TASK if bodies_per_task is None
                else as_positive_int("bodies_per_task", bodies_per_task))
    threads = as_positive_int("threads_per_task", threads_per_task)
    if not isinstance(gather, bool | np.bool_):
        raise TypeError(f"gather must be True or False, got {type(gather).__name__}")
    call = _validate(scene, q0, L0, omega0, dt, steps, t_end, method, save_every,
                     diagnostics, controls, t0, simd, bool(gather))
    n = call.n
    workers = max(1, sum(client.nthreads().values()))
    per_task = max(1, min(per_task, math.ceil(n / workers)))
    _check_workers_memory(client, call, per_task)

    edges = list(range(0, n, per_task)) + [n]
    chunks = [slice(a, b) for a, b in itertools.pairwise(edges)]
    # a scene with one row per body is split with the bodies; one of a single row (a
    # batch of one, which the states' N bodies share) is sent whole, as an unbatched one
    batched = scene.batch_shape not in ((), (1,))
    spec = call.task_spec(threads)
    # a fresh key per call (hash=False): a repeated call with the same scene must not
    # reuse the key of data that the previous call's release may be dropping
    scene_f = client.scatter(scene, broadcast=True, hash=False) if not batched else None
    u = call.u

    def controls_of(c):
        if u is None:
            return None
        return u[c] if u.ndim == 2 else u

    futures = [client.submit(_run_task, scene.take(c) if batched else scene_f, call.method,
                             call.q[c], call.m[c], controls_of(c), spec, pure=True)
               for c in chunks]
    if not gather:
        return _as_dask(futures, chunks, call, client)
    return _gather(client, futures, chunks, call)


def _gather(client, futures, chunks, call: _Call):
    """Bring the tasks' samples home into the ensemble's arrays, one task at a time
    (the client holds the result and one task's part), releasing each on the cluster."""
    k = len(call.times)
    q = np.empty((call.n, k, 4))
    L = np.empty((call.n, k, 3))
    records = []
    try:
        for f, c in zip(futures, chunks, strict=True):
            try:
                part = f.result()
            except Exception as exc:
                if hasattr(exc, "add_note"):
                    exc.add_note(f"liebody.distributed: in the task of bodies {c.start} to "
                                 f"{c.stop - 1} (the other tasks were cancelled)")
                raise
            # (a copy: tasks of the same inputs are one task, whose result they share)
            part = dict(part)
            q[c], L[c] = part.pop("q"), part.pop("L")
            records.append(part)
            f.release()
    except BaseException:
        client.cancel(futures)
        raise
    return _finish(call, q, L, records, stacklevel=3)


def _as_dask(futures, chunks, call: _Call, client):
    import dask.array as da

    n_samples = len(call.times)

    def part(name, width):
        arrays = []
        for f, c in zip(futures, chunks, strict=True):
            rows = c.stop - c.start
            shape = (rows, n_samples) + ((width,) if width else ())
            arrays.append(da.from_delayed(client.submit(lambda r, k=name: r[k], f, pure=True),
                                          shape=shape, dtype=float))
        return da.concatenate(arrays, axis=0)

    q, L = part("q", 4), part("L", 3)
    failed = da.concatenate([
        da.from_delayed(client.submit(lambda r: r["failed_at"], f, pure=True),
                        shape=(c.stop - c.start,), dtype=float)
        for f, c in zip(futures, chunks, strict=True)])
    extras = [client.submit(lambda r: {k: v for k, v in r.items() if k not in ("q", "L")},
                            f, pure=True) for f in futures]
    return DistributedResult(call.times, q, L, failed, call.scene, call.method, call.dt,
                             extras, call)
