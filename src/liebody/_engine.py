"""The run engine's shared pieces: slicing, the kernels' argument lists, controls, running
diagnostics, the end-of-run invariant check and the reports of a failing torque.

:func:`liebody.integrate` (``_integrate``), ensembles (``_ensemble``), the
:class:`liebody.Stepper` (``_stepper``) and ``liebody.distributed`` use these, so that
they run the kernels the same way; this module imports none of them.
"""

from __future__ import annotations

import itertools
import math
import os
import signal
import threading
import time
import warnings
from dataclasses import dataclass

import numpy as np

from liebody._kernels import stages as S
from liebody._plan import body_rows
from liebody.errors import ConvergenceError, InvariantWarning, TorqueError
from liebody.scenes import _memo as memo
from liebody.trajectory import Trajectory

#: wall time a slice of the run aims at: Ctrl-C is seen between slices
SLICE_SECONDS = 0.2
#: a slice is at most this many times the previous one (the first ones are noisy)
SLICE_GROWTH = 16
#: steps (or samples) in the first slice of a run; later slices are sized by the clock
FIRST_SLICE = 4096
#: the same for a user torque, whose cost per call is unknown
USER_FIRST_SLICE = 16
#: a run of at most this many samples is checked for finite numbers in Python floats
SHORT_TIMES_SAMPLES = 64

#: tolerances of the end-of-run check (InvariantWarning)
QNORM_TOL = 1e-6  # | |q| - 1 |, any method
CASIMIR_TOL = 1e-9  # relative |L| drift, methods that keep |L| on torque-free scenes
ENERGY_TOL = 1e-2  # relative energy error, symplectic or energy-keeping methods

#: what :class:`interrupt_after_call` needs (a POSIX signal mask)
_MASK = getattr(signal, "pthread_sigmask", None)
_SIGINT = {signal.SIGINT}

#: the largest |L| a run accepts or keeps: |L|^2 / (2 I) overflows float64 near 1e154
MAX_MOMENTUM = 1e150

#: a failing body's status, in words
REASONS = {S.STATUS_NONFINITE: "non-finite state",
           S.STATUS_NO_CONVERGENCE: "DMV equation not solved",
           S.STATUS_KICK_NO_CONVERGENCE: "implicit kick not solved",
           S.STATUS_TORQUE: "torque failed"}


@dataclass(frozen=True)
class StepFailure:
    """A body's failure, as the run's records hold it: the body (``None``: a one-body
    call's), the driver's status, the good steps before the failing one (counted from the
    run's start, or the call's for a :class:`liebody.Stepper`), the failing step's start
    ``t`` and end ``failed_at``, and the body's last good state ``(q, L)`` (7 numbers)."""

    body: int | None
    status: int
    step: int
    t: float
    failed_at: float
    state: np.ndarray

    @property
    def reason(self) -> str:
        """Why, in words (:data:`REASONS`)."""
        return REASONS.get(self.status, "unknown")


#: where both argument lists (:func:`one_body_args`, :func:`batch_args`) hold the clock and
#: the slice: the run's start time, the steps done before the call, the steps to do, the
#: save interval and whether the call is the run's last (the kernels' own parameters)
T0, STEP0, N_STEPS, SAVE_EVERY, FINAL = 8, 9, 10, 11, 12
#: where :func:`one_body_args` holds the stage parameters (a copy with the controls)
PARAMS = 4


def one_body_args(plan, params, merge_ends, h, t0, step0, n_steps, save_every, final, state,
                  ctl, q_out, m_out, torque_addr, dref, dmax) -> tuple:
    """The argument list of a one-body driver (``driver.RUNNERS``), in its order: the
    plan's stage table with ``params`` (the plan's, or a copy holding controls), the
    clock, the slice, the state and outputs, the user callback, the model's parameter
    row and shared block, the diagnostics' arrays and the model's token."""
    head, tail = one_body_arg_ends(plan, params, merge_ends, h, t0, step0, n_steps,
                                   save_every, final, torque_addr, dref, dmax)
    return (*head, state, ctl, q_out, m_out, *tail)


def one_body_arg_ends(plan, params, merge_ends, h, t0, step0, n_steps, save_every, final,
                      torque_addr, dref, dmax) -> tuple[tuple, tuple]:
    """:func:`one_body_args` before and after the state and outputs ``(state, ctl, q_out,
    m_out)``: what a caller that repeats one call with new arrays keeps."""
    return ((plan.kinds, plan.axes, plan.coefs, plan.clock, params, plan.slots, merge_ends, h,
             t0, step0, n_steps, save_every, final),
            (torque_addr, plan.first[1], plan.model_shared, dref, dmax, plan.token))


def entry_point(runner, args):
    """The compiled entry point of ``runner`` for ``args`` (a plain call skips numba's
    type dispatch: about 0.4 us less per call); the runner itself when numba is off or
    no compiled version takes these argument types yet. Every later call must pass
    arguments of the same types (arrays of the same dtype, rank, layout and
    writeability): the entry point does not check them."""
    overloads = getattr(runner, "overloads", None)
    if not overloads:
        return runner
    sig = tuple(runner.typeof_pyval(a) for a in args)
    cres = overloads.get(sig)
    return runner if cres is None else cres.entry_point


def groups_info(groups, runners) -> dict:
    """``Trajectory.info`` of an ensemble: the plan's choices and whether the SIMD kernels
    ran, for its one group of bodies, or per group (with the group's bodies)."""
    if len(groups) == 1:
        return dict(groups[0][1].info, simd=runners[0][1])
    return {"groups": [dict(plan.info, bodies=idx, simd=r[1])
                       for (idx, plan), r in zip(groups, runners, strict=True)]}


def batch_args(plan, params, merge_ends, h, t0, step0, n_steps, save_every, final, state,
               ctl, q_out, m_out, saved, done, status, torque_addr, rows, dref, dmax) -> tuple:
    """The argument list of a batch or SIMD driver (``batch_drivers.BATCH_RUNNERS``,
    ``batch.SIMD_RUNNERS``) for the bodies ``rows`` (a slice) of a plan's group;
    ``params``: the group's distinct stage rows (``(1, r, P)`` shared, or per body of the
    group; ``plan.slots`` maps the stages to them)."""
    return (plan.kinds, plan.axes, plan.coefs, plan.clock, body_rows(params, rows),
            plan.slots, merge_ends, h, t0, step0,
            n_steps, save_every, final, state, ctl, q_out, m_out, saved, done, status,
            torque_addr, plan.model_rows(rows), plan.model_shared, dref, dmax, plan.token)


def resolve_threads(threads) -> int:
    """``threads=None``: every core; else a positive integer."""
    if threads is None:
        return os.cpu_count() or 1
    if isinstance(threads, bool) or not isinstance(threads, int | np.integer) or threads < 1:
        raise ValueError(f"threads must be a positive integer or None (every core), "
                         f"got {threads!r}")
    return int(threads)


def batch_runner(plan, code: int, n: int, simd, diagnostics: bool = False):
    """The batch driver of an ensemble's plan (``n`` bodies, torque model ``code``) and
    whether it is the SIMD one: the SIMD driver where ``simd`` allows it (``None``: for at
    least ``SIMD_MIN_BODIES`` bodies) and it supports the plan and the model, else the
    one-body loop per body. :func:`liebody.integrate` and the :class:`liebody.Stepper`
    choose by this rule, so that they run the same kernel."""
    from liebody._kernels import batch
    from liebody._kernels.batch_drivers import BATCH_RUNNERS, DIAG_BATCH_RUNNERS

    wanted = simd is not False and (simd or n >= batch.SIMD_MIN_BODIES)
    if wanted and batch.simd_supports(plan, code):
        return batch.SIMD_RUNNERS[(plan.family, bool(diagnostics))], True
    return (DIAG_BATCH_RUNNERS if diagnostics else BATCH_RUNNERS)[plan.family], False


def body_chunks(n: int, threads: int) -> list[slice]:
    """Contiguous chunks of ``n`` bodies, one per thread (at least 64 bodies each)."""
    if n < 128 or threads <= 1:
        return [slice(0, n)]  # (one chunk, at once)
    parts = min(threads, n // 64)  # (at least 2 here)
    edges = np.linspace(0, n, parts + 1).round().astype(int)
    return [slice(int(a), int(b)) for a, b in itertools.pairwise(edges) if b > a]


def failed_step_times(t0: float, step: int, dt: float) -> tuple[float, float]:
    """The start and the end of a run's failing step, after ``step`` good steps from
    ``t0``: ``IntegrationError.t`` (the time of the last good state) and
    ``Trajectory.failed_at``, on the grid of the sample times (``t0 + k dt``), as every
    run reports them (one body, ensembles, the Stepper)."""
    return t0 + step * dt, t0 + (step + 1) * dt


def failed_step_words(step: int, t: float, failed_at: float, counted: str = "") -> str:
    """Where a run failed, in the words of its fields: the step from ``t`` (the error's
    ``.t``) to ``failed_at`` (``Trajectory.failed_at``), after ``step`` good steps (the
    error's ``.step``; ``counted``, e.g. ``" of this call"``, says what they count)."""
    return (f"in the step from t = {t:.10g} to t = {failed_at:.10g} (after {step:,} "
            f"step{'' if step == 1 else 's'}{counted})")


def failure_message(method: str, status: np.ndarray, failed_at: np.ndarray) -> str | None:
    """The warning of an ensemble some of whose bodies failed (``None`` if none did): how
    many, why, and one body of each kind with its ``failed_at``."""
    bad = [i for i, s in enumerate(status) if str(s).startswith("failed")]
    if not bad:
        return None
    kinds: dict[str, list[int]] = {}
    for i in bad:
        kinds.setdefault(str(status[i])[8:] or "failed", []).append(i)
    words = "; ".join(f"{len(v)} {k} (e.g. body {v[0]} at t = {failed_at[v[0]]:.10g}, the "
                      f"end of its failing step)" for k, v in kinds.items())
    return (f"{method}: {len(bad)} of {len(status)} bodies failed: {words}; their samples "
            f"stop there (NaN after; Trajectory.failed_at and Trajectory.status per body), "
            f"the others finished")


def failure_summary(method: str, status, failed_at, dt: float, model=None, states=None,
                    u=None, reach: tuple = (0.0, 1.0)) -> str | None:
    """:func:`failure_message`, and for a torque that failed the first such body's own
    words (the exception's type and message, its non-finite values, or for a scene's own
    torque model a time outside its sampled orbits), from the records: ``states``
    ``(N, 7)`` the bodies' last good states, ``u`` the controls (``(k,)`` or ``(N, k)``),
    ``failed_at`` the end of each failing step, ``reach`` the plans' ``Plan.reach``."""
    message = failure_message(method, status, failed_at)
    if not message or model is None or states is None:
        return message
    bad = [i for i, s in enumerate(status) if str(s) == "failed: " + REASONS[S.STATUS_TORQUE]]
    if not bad:
        return message
    i = bad[0]
    ui = None if u is None else (u if np.ndim(u) == 1 else u[i])
    return message + f". Body {i}: " + torque_failure_words(
        model, states[i], float(failed_at[i]) - dt, dt, ui, i, reach)


def first_slice(model) -> int:
    """Steps (body-steps of an ensemble) in a run's first slice: :data:`FIRST_SLICE` for
    the built-in models, :data:`USER_FIRST_SLICE` for a user torque, whose cost is
    unknown (a torque of 1.4 ms made the first slice of 4096 steps last 12 s, and Ctrl-C
    waited for it); later slices are sized by the measured time."""
    return USER_FIRST_SLICE if model.function is not None else FIRST_SLICE


class interrupt_after_call:
    """Hold Ctrl-C (SIGINT) back during a kernel call and deliver it after the block, so
    that the call's results (steps done, samples saved) are stored before
    ``KeyboardInterrupt`` is raised: a finished slice is kept, not discarded. In the main
    thread of a POSIX process; elsewhere a plain block (Python sees Ctrl-C between calls
    anyway). (A class, not a generator: a microsecond a slice.)"""

    __slots__ = ("old",)

    def __enter__(self) -> None:
        self.old = None
        if _MASK is not None and threading.current_thread() is threading.main_thread():
            self.old = _MASK(signal.SIG_BLOCK, _SIGINT)

    def __exit__(self, *exc) -> bool:
        if self.old is not None:
            _MASK(signal.SIG_SETMASK, self.old)
        return False


def block_interrupts() -> None:
    """Block SIGINT in the calling (worker) thread, so that Ctrl-C is delivered to the
    main thread, where :func:`interrupt_after_call` holds it until a slice is counted."""
    if _MASK is not None:
        _MASK(signal.SIG_BLOCK, _SIGINT)


def time_slices(total: int, progress: bool, unit: str, first: int = FIRST_SLICE):
    """Sizes of consecutive slices covering ``total`` units, each aiming at
    :data:`SLICE_SECONDS` of wall time (the first, of ``first`` units, measures the rate).

    A run is cut into such slices so that Ctrl-C, which Python sees only between calls
    into compiled code, stops it within about a second; ``progress`` shows a tqdm bar.
    """
    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=total, unit=unit, unit_scale=True)
    done, size, last = 0, max(1, int(first)), None
    try:
        while done < total:
            n = min(size, total - done)
            start = time.perf_counter()
            yield n
            done += n
            if bar is not None:
                bar.update(n)
            size, last = next_slice(n, time.perf_counter() - start, size, last)
    finally:
        if bar is not None:
            bar.close()


def next_slice(k: int, seconds: float, size: int, last: tuple | None) -> tuple[int, tuple]:
    """The next slice's size after one of ``k`` units that took ``seconds`` (``size``:
    the size asked for it; ``last``: what this returned after the slice before), and the
    record to pass on: about :data:`SLICE_SECONDS` of stepping, beyond a fixed cost per
    call where there is one.

    A call costs ``a + b k`` for ``k`` steps; the fixed part ``a`` (gathering a large
    ensemble's per-body parameters, the blocks' set-up) shows in two slices of different
    sizes, and the cost per step ``b`` measured so is kept while the slices keep their
    size. Sized by the rate ``k / (a + b k)`` alone, slices stayed at one step when ``a``
    was most of a slice (a million satellites of per-body inertia on one thread: 0.17 s a
    call, 176 ns a body-step instead of 8). A slice grows at most
    :data:`SLICE_GROWTH` times over the last, and lasts about ``a + SLICE_SECONDS`` (or,
    before the cost is measured, twice the slice before at most)."""
    seconds = max(seconds, 1e-7)
    per = seconds / k  # (the rate alone: a and b together)
    b = None
    if last is not None:
        k0, s0, b0 = last
        if k0 != k:
            fit = (seconds - s0) / (k - k0)
            if 0.0 < fit <= per * (1.0 + 1e-6):  # (a fixed cost a = seconds - b k >= 0)
                b = min(fit, per)
        elif b0 is not None:
            b = min(b0, per)  # (the same size again: the cost per step measured before)
    if b is not None:
        want = SLICE_SECONDS / b
    else:
        want = SLICE_SECONDS / per
        if seconds < SLICE_SECONDS and want < 2 * k:
            want = 2 * k  # (a second size, to tell a fixed cost from the steps' cost)
    return int(min(max(want, 1), SLICE_GROWTH * max(k, size))), (k, seconds, b)


def with_controls(params: np.ndarray, u: np.ndarray | None, n: int) -> np.ndarray:
    """A plan's stage parameters (its distinct rows: ``(1, r, P)`` shared, or ``(n, r, P)``)
    with the controls ``u`` (``(k,)``, or ``(n, k)`` one row per body) in the control slots
    of every row (the stages that do not call the torque ignore them): a new array, with a row per
    body when ``u`` has one; the plan's own array unchanged without controls."""
    if u is None:
        return params
    rows = n if (u.ndim == 2 or params.shape[0] != 1) else 1
    out = np.array(np.broadcast_to(params, (rows, *params.shape[1:])))
    write_controls(out, u)
    return out


def write_controls(params: np.ndarray, u: np.ndarray) -> None:
    """Put the controls ``u`` (``(k,)``, or ``(N, k)`` with ``params`` ``(N, r, P)``)
    in the control slots of every stage's parameters, in place."""
    k = u.shape[-1]
    if u.ndim == 2:
        params[..., S.P_U0:S.P_U0 + k] = u[:, None, :]
    else:
        params[..., S.P_U0:S.P_U0 + k] = u


def rotor_momentum(scene) -> np.ndarray:
    """A gyrostat's rotor momentum ``l`` (body frame; ``(3,)`` or ``(N, 3)``), zeros for a
    rigid body: the kinetic energy is ``(L - l)^T I^-1 (L - l) / 2``."""
    l = getattr(scene, "rotor_momentum", None)
    return np.zeros(3) if l is None else np.asarray(l, dtype=float)


def diagnostic_reference(scene, model, q0: np.ndarray, m0: np.ndarray, t0: float = 0.0
                         ) -> np.ndarray:
    """The kernel's reference values for the running diagnostics, ``(N, DREF_WIDTH)``:
    ``1/I``, the torque model's code, 0, 0, ``E0``, ``1/scale``, ``|L0|``, ``1/|L0|``, and
    a gyrostat's rotor momentum ``l`` (``E0`` NaN where the kernels cannot follow the
    energy: a user's Python potential, a potential that depends on the time)."""
    from liebody._models.dispatch import potentials

    q0, m0 = np.atleast_2d(q0), np.atleast_2d(m0)
    n = q0.shape[0]
    inv = np.broadcast_to(1.0 / np.asarray(scene.moments, dtype=float), (n, 3))
    rotor = np.broadcast_to(rotor_momentum(scene), (n, 3))
    V0 = np.zeros(n)
    potentials(model.code, model.params, model.shared, np.full(n, float(t0)),
               np.ascontiguousarray(q0), V0)
    code = np.full(n, float(model.code))
    if model.code == S.TORQUE_USER:  # a Python potential, which the kernels cannot call
        code[:] = S.TORQUE_NONE  # (without one, the energy error is the change of T)
        V0[:] = np.nan if scene.capabilities.conservative else 0.0
    if model.time_dependent:
        V0[:] = np.nan
    g = np.linalg.norm(m0, axis=1)
    zero = np.zeros(n)
    # (an energy beyond float64 is inf, without numpy's warning)
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        T0 = 0.5 * np.sum((m0 - rotor) ** 2 * inv, axis=1)
        ref = np.column_stack([inv, code, zero, zero, T0 + V0, 1.0 / (T0 + np.abs(V0)), g,
                               1.0 / g, rotor])
    return np.ascontiguousarray(np.where(np.isinf(ref), 0.0, ref))


def diagnostics_dict(dmax: np.ndarray, one: bool, dref: np.ndarray) -> dict:
    """``Trajectory.diagnostics`` from the kernel's running maxima ``(N, 3)``; the energy
    error is NaN where the reference energy is (a user torque's potential, which the
    kernel cannot evaluate: its running maximum never moved from 0)."""
    dmax = np.array(dmax, dtype=float)
    dmax[np.isnan(np.atleast_2d(dref)[:, 6]), 0] = np.nan
    keys = ("max_energy_error", "max_qnorm_error", "max_casimir_error")
    return {k: (float(dmax[0, i]) if one else dmax[:, i].copy()) for i, k in enumerate(keys)}


def sample_diagnostics(dref: np.ndarray, q: np.ndarray, m: np.ndarray) -> np.ndarray:
    """The running diagnostics of the kernels (``driver._diagnose``) over saved samples of
    the exact free flow (no potential): ``dref`` ``(N, 10)``, ``q`` ``(N, n, 4)``, ``m``
    ``(N, n, 3)`` -> ``(N, 3)``."""
    w, x, y, z = np.moveaxis(q, -1, 0)
    n2 = w * w + x * x + y * y + z * z
    d = dref[:, None, :]
    with np.errstate(over="ignore", invalid="ignore"):  # (an energy beyond float64)
        T = 0.5 * np.sum(m * m * d[..., :3], axis=-1)
        e = np.abs(T - d[..., 6]) * d[..., 7]
    qe = np.abs(np.sqrt(n2) - 1.0)
    le = np.abs(np.linalg.norm(m, axis=-1) - d[..., 8]) * d[..., 9]
    return np.stack([np.max(e, axis=1), np.max(qe, axis=1), np.max(le, axis=1)], axis=1)


def warn_invariants(traj: Trajectory, stacklevel: int, ends: tuple | None = None
                    ) -> Trajectory:
    """Warn when an invariant the method should keep left its tolerance by the end.

    ``ends``: a one-body run's first and last ``q`` and ``L`` as lists, ``(q0, q1, L0,
    L1)``, when the caller has them (the same numbers as the trajectory's)."""
    try:
        problems = _invariant_problems(traj) if ends is None else \
            _one_body_problems(traj, *ends)
    except Exception as exc:  # a user's potential that fails: never lose the trajectory
        warnings.warn(f"{traj.method.name}: the end-of-run invariant check failed "
                      f"({type(exc).__name__}: {exc}); the trajectory is returned unchecked",
                      InvariantWarning, stacklevel=stacklevel)
        return traj
    if problems:
        drifts = [p for p in problems if not p.startswith(_OWN_REASON)]
        own = [p[len(_OWN_REASON):] for p in problems if p.startswith(_OWN_REASON)]
        text = "; ".join(drifts)
        if drifts:
            text += (" (the step may be too large for this scene, or the method does not "
                     "keep this invariant)")
        warnings.warn(f"{traj.method.name}: " + "; ".join([text] * bool(drifts) + own),
                      InvariantWarning, stacklevel=stacklevel)
    return traj


#: marks a problem that carries its own reason (not a drift the step size explains)
_OWN_REASON = "\0"

#: an energy rise in a dissipative scene above its lowest value so far, relative to the
#: initial energy, that warns for any method (the energy can only fall)
DISSIPATIVE_RISE_TOL = ENERGY_TOL


#: bodies the ensemble check works through at a time (its temporaries, about 200 B a
#: body, stay bounded)
CHECK_CHUNK = 1 << 15


def _invariant_problems(traj: Trajectory) -> list[str]:
    """The invariants of ``traj`` that left their tolerance between its first and last
    sample, in words (empty for a healthy run). For an ensemble, per body: the words say
    how many bodies and give one (failed bodies are left out: they warned already)."""
    if traj.q.ndim == 2:
        return _one_body_problems(traj)
    n = traj.q.shape[0]
    found: dict[int, list] = {}  # check -> [bodies, first body, its words]
    for a in range(0, n, CHECK_CHUNK):
        for key, count, i, text in _chunk_problems(traj, a, min(n, a + CHECK_CHUNK)):
            if key in found:
                found[key][0] += count
            else:
                found[key] = [count, i, text]
    out = []
    for key in sorted(found):
        count, i, text = found[key]
        own = text.startswith(_OWN_REASON)  # (the mark stays first)
        out.append(_OWN_REASON * own + f"{count} of {n} bodies (e.g. body {i}): " + text[own:])
    return out


def _chunk_problems(traj: Trajectory, a: int, b: int) -> list[tuple[int, int, int, str]]:
    """The checks of :func:`_invariant_problems` that bodies ``a .. b - 1`` of an ensemble
    fail: ``(check, bodies, first body, its words)``."""
    method, scene = traj.method, traj.scene
    caps = scene.capabilities
    q, L = traj.q[a:b], traj.L[a:b]
    ok = np.isfinite(q[:, -1]).all(axis=1) & np.isfinite(L[:, -1]).all(axis=1)
    moments = np.broadcast_to(_chunk_rows(scene.moments, a, b), (b - a, 3))
    out = []

    def report(key, bad, words):
        bad = bad & ok
        if bad.any():
            i = int(np.argmax(bad))
            out.append((key, int(bad.sum()), a + i, words(i)))

    qn = np.linalg.norm(q[:, -1], axis=1)
    report(0, ~(np.abs(qn - 1.0) <= QNORM_TOL),
           lambda i: f"|q| = {qn[i]:.6g} at the end, off 1 by more than {QNORM_TOL:g}")
    size = np.max(np.abs(L[:, -1]), axis=1)
    report(1, ~(size <= MAX_MOMENTUM),
           lambda i: f"{_OWN_REASON}|L| reached {size[i]:.3g} at the end, beyond "
                     f"{MAX_MOMENTUM:.0e}: the torque drove L out of float64's range (the "
                     f"kinetic energy overflows; the end state is not to be trusted)")
    if method.keeps_casimir and not caps.torque:
        g0, g1 = np.linalg.norm(L[:, 0], axis=1), np.linalg.norm(L[:, -1], axis=1)
        report(2, ~(np.abs(g1 - g0) <= CASIMIR_TOL * g0),
               lambda i: f"|L| went from {g0[i]:.6g} to {g1[i]:.6g}, more than "
                         f"{CASIMIR_TOL:g} relative")
    rotor = np.broadcast_to(_chunk_rows(rotor_momentum(scene), a, b), (b - a, 3))  # (gyrostats)
    with np.errstate(over="ignore"):  # (an energy beyond float64: inf, no numpy warning)
        T0 = 0.5 * np.sum((L[:, 0] - rotor) ** 2 / moments, axis=1)
        T1 = 0.5 * np.sum((L[:, -1] - rotor) ** 2 / moments, axis=1)
    if (method.symplectic or method.keeps_energy) and caps.conservative:
        ends = np.stack([q[:, 0], q[:, -1]], axis=1)  # (n, 2, 4)
        ends = np.where(ok[:, None, None], ends, [1.0, 0.0, 0.0, 0.0])
        V = np.asarray(_chunk_potential(scene, a, b, ends / np.linalg.norm(
            ends, axis=-1)[..., None]))
        V = np.broadcast_to(V, ends.shape[:2])
        finite = np.isfinite(V).all(axis=1)
        report(3, ~finite,
               lambda i: f"{_OWN_REASON}the scene's potential is not finite (V = "
                         f"{V[i, 0]:.6g} at the start, {V[i, 1]:.6g} at the end), so the "
                         f"energy could not be checked: check potential(q) at these "
                         f"orientations")
        e0, e1 = T0 + V[:, 0], T1 + V[:, 1]
        scale = T0 + np.abs(V[:, 0])
        with np.errstate(invalid="ignore"):  # (inf - inf: NaN, a drift reported)
            drift = ~(np.abs(e1 - e0) <= ENERGY_TOL * scale)
        report(4, finite & (scale > 0) & drift,
               lambda i: f"the energy went from {e0[i]:.6g} to {e1[i]:.6g}, more than "
                         f"{ENERGY_TOL:.0%} of its scale {scale[i]:.3g}")
    if caps.dissipative and not caps.torque:  # (a torque may add energy)
        rise, k = _dissipative_rise(L, moments)
        report(5, (T1 > T0 * (1.0 + 1e-9)) | (rise > DISSIPATIVE_RISE_TOL * T0),
               lambda i: _rose_words(traj.t, T0[i], T1[i], rise[i], k[i]))
    return out


def _chunk_rows(value, a: int, b: int) -> np.ndarray:
    """Bodies ``a .. b - 1``'s rows of a vector per body (``(N, 3)``), or the vector every
    body shares (``(3,)``, or one row ``(1, 3)``: a batch of one broadcast to the bodies)."""
    v = np.asarray(value, dtype=float)
    return v if v.ndim == 1 or v.shape[0] == 1 else v[a:b]


def _chunk_potential(scene, a: int, b: int, q: np.ndarray) -> np.ndarray:
    """The potential of bodies ``a .. b - 1`` of an ensemble at orientations ``q`` (a
    scene's batch of one stands for every body)."""
    shape = getattr(scene, "batch_shape", ())
    if shape and shape[0] > 1 and (a, b) != (0, shape[0]):
        scene = scene.take(slice(a, b))
    return scene.potential(q)


def _dissipative_rise(L: np.ndarray, moments: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For ``L`` ``(N, n, 3)``: each body's largest rise of the kinetic energy above its
    lowest value at an earlier sample, and the sample where it is reached (in chunks of
    bodies: a few arrays ``(chunk, n)`` at a time)."""
    N, n = L.shape[:2]
    rise, where = np.zeros(N), np.zeros(N, dtype=np.int64)
    if n < 3:  # the end-to-start comparison says it all
        return rise, where
    chunk = max(1, (1 << 20) // n)
    inv = 0.5 / np.broadcast_to(moments, (N, 3))
    for a in range(0, N, chunk):
        b = min(N, a + chunk)
        T = np.einsum("knj,kj->kn", L[a:b] ** 2, inv[a:b])
        up = T[:, 1:] - np.minimum.accumulate(T, axis=1)[:, :-1]
        up = np.where(np.isfinite(up), up, -np.inf)  # failed bodies' NaN samples
        where[a:b] = np.argmax(up, axis=1) + 1
        rise[a:b] = np.maximum(up[np.arange(b - a), where[a:b] - 1], 0.0)
    return rise, where


def _rose_words(t: np.ndarray, T0: float, T1: float, rise: float, k: int) -> str:
    """The words of an energy that rose in a dissipative scene."""
    if T1 > T0 * (1.0 + 1e-9):
        return (f"the energy rose from {T0:.6g} to {T1:.6g} in a dissipative scene (whose "
                f"energy can only fall)")
    return (f"the energy rose by {rise:.3g} ({rise / T0:.1%} of its initial {T0:.6g}) above "
            f"its lowest earlier value by t = {float(t[k]):.6g} in a dissipative scene "
            f"(whose energy can only fall): the end state is not to be trusted")


def _energy_terms(scene) -> tuple:
    """What the one-body check reads of a scene (kept on it: :func:`_energy_terms_of`)."""
    return memo(scene, "energy_terms", _energy_terms_of, scene)


def _energy_terms_of(scene) -> tuple:
    """The scene's capabilities, moments ``(I1, I2, I3)`` and a gyrostat's rotor momentum
    (a list; ``None`` for a rigid body)."""
    l = getattr(scene, "rotor_momentum", None)
    return (scene.capabilities, tuple(scene.moments.tolist()),
            None if l is None else np.asarray(l, dtype=float).tolist())


def _one_body_problems(traj: Trajectory, q0: list | None = None, q1: list | None = None,
                       L0: list | None = None, L1: list | None = None) -> list[str]:
    """:func:`_invariant_problems` for one body, in scalar arithmetic (a few
    microseconds: this check runs at the end of every call); ``q0, q1, L0, L1``: the
    first and last samples as lists, when the caller has them."""
    method, scene = traj.method, traj.scene
    caps, (I1, I2, I3), l = _energy_terms(scene)
    if q0 is None:
        q0, q1 = traj.q[0].tolist(), traj.q[-1].tolist()
        L0, L1 = traj.L[0].tolist(), traj.L[-1].tolist()
        if not all(map(math.isfinite, q1 + L1)):
            return []  # failed: warned already
    # (ends given: a complete run's, finite)
    out = []
    w, x, y, z = q1
    qn = math.hypot(w, x, y, z)
    if not abs(qn - 1.0) <= QNORM_TOL:
        out.append(f"|q| = {qn:.6g} at the end, off 1 by more than {QNORM_TOL:g}")
    a1, a2, a3 = L0
    b1, b2, b3 = L1
    torque = caps.torque
    if method.keeps_casimir and not torque:
        g0, g1 = math.hypot(a1, a2, a3), math.hypot(b1, b2, b3)
        if not abs(g1 - g0) <= CASIMIR_TOL * g0:
            out.append(f"|L| went from {g0:.6g} to {g1:.6g}, more than {CASIMIR_TOL:g} "
                       f"relative")
    energy = (method.symplectic or method.keeps_energy) and caps.conservative
    dissipative = caps.dissipative and not torque  # every method (a torque may add energy)
    if not (energy or dissipative):
        return out
    if l is not None:  # a gyrostat: (L - l)^T I^-1 (L - l) / 2
        l1, l2, l3 = l
        a1, a2, a3 = a1 - l1, a2 - l2, a3 - l3
        b1, b2, b3 = b1 - l1, b2 - l2, b3 - l3
    T0 = 0.5 * (a1 * a1 / I1 + a2 * a2 / I2 + a3 * a3 / I3)
    T1 = 0.5 * (b1 * b1 / I1 + b2 * b2 / I2 + b3 * b3 / I3)
    if energy:
        V0 = V1 = 0.0
        if torque:
            V0, V1 = _end_potentials(scene, q0, q1, float(traj.t[0]), float(traj.t[-1]))
        e0, e1, scale = T0 + V0, T1 + V1, T0 + abs(V0)
        if not (math.isfinite(V0) and math.isfinite(V1)):
            out.append(f"{_OWN_REASON}the scene's potential is not finite (V = {V0:.6g} at "
                       f"the start, {V1:.6g} at the end), so the energy could not be "
                       f"checked: check potential(q) at these orientations")
        elif scale > 0 and not abs(e1 - e0) <= ENERGY_TOL * scale:
            out.append(f"the energy went from {e0:.6g} to {e1:.6g}, more than "
                       f"{ENERGY_TOL:.0%} of its scale {scale:.3g}")
    if dissipative:
        rise = k = 0
        if len(traj.t) > 2:
            r, w = _dissipative_rise(traj.L[None], np.asarray(scene.moments, dtype=float))
            rise, k = float(r[0]), int(w[0])
        if T1 > T0 * (1.0 + 1e-9) or rise > DISSIPATIVE_RISE_TOL * T0:
            out.append(_rose_words(traj.t, T0, T1, rise, k))
    return out


def _end_potentials(scene, q0: list, q1: list, t0: float = 0.0, t1: float = 0.0
                    ) -> tuple[float, float]:
    """The scene's potential at the first and last orientation (normalised) and times."""
    model = scene.torque_model()
    if model.code != S.TORQUE_USER:
        from liebody._models.dispatch import PYTHON_POTENTIALS, potentials

        fast = PYTHON_POTENTIALS.get(model.code)
        if fast is not None and model.params.shape[0] == 1:  # a few flops, no kernel call
            row = model.params[0].tolist()
            return fast(t0, q0, row), fast(t1, q1, row)
        V = np.zeros(2)
        potentials(model.code, model.params, model.shared, np.array([t0, t1]),
                   np.array([q0, q1]), V)
        return float(V[0]), float(V[1])
    ends = np.array([q0, q1])
    V = np.asarray(scene.potential(ends / np.linalg.norm(ends, axis=-1)[:, None]))
    return float(V[0]), float(V[1])


def _torque_is_finite(model, state, times, u=None, i: int = 0) -> bool:
    """Whether the user torque gives three finite numbers at ``state`` for every time."""
    return all(torque_failure(model, state, t, u, i)[1] is None for t in times)


def input_sizes(model, exc: BaseException | None = None) -> str:
    """For an ``IndexError`` of a user torque (``exc``; any exception when ``None``): how
    many entries its inputs ``u`` and ``p`` hold, as ``" (u has 2 entries ...)"``; an
    empty string otherwise."""
    if exc is not None and not isinstance(exc, IndexError):
        return ""
    words = []
    if model.controls:
        words.append(f"u has {model.controls} entries (controls={model.controls})")
    if model.takes_params:
        words.append(f"p has {model.params.shape[-1]} entries (a row of params)")
    return f" ({'; '.join(words)})" if words else ""


def torque_failure(model, state, t, u=None, i: int = 0):
    """What is wrong with body ``i``'s user torque at ``state`` and time ``t``:
    ``(exception or None, words)``, ``words`` None when it gives three finite numbers.
    A scene's own torque model (no Python function: uniform gravity, gravity gradient)
    that the kernel found non-finite is described as such."""
    if model.function is None:
        span = getattr(model, "span", None)
        if span is not None and not span[0] <= t <= span[1]:
            return None, (f"the time t = {t:.10g} is outside the times [{span[0]:.10g}, "
                          f"{span[1]:.10g}] that the scene's sampled orbits "
                          f"(liebody.orbits.Table) cover: the sources' positions are not "
                          f"known there (extend the tables or shorten the run)")
        return None, (f"the scene's torque model (code {model.code}) gave non-finite values "
                      f"(its parameters overflow float64 at this state)")
    sig = model.signature
    q, m = state[:4], state[4:]
    try:
        value = np.asarray(model(t, q, m, u, i), dtype=float)
    except Exception as exc:
        return exc, f"the torque {sig} raised {type(exc).__name__} ({exc}){input_sizes(model, exc)}"
    if value.shape != (3,):
        return None, f"the torque {sig} returned shape {value.shape}, not 3 numbers,"
    if not np.all(np.isfinite(value)):
        return None, f"the torque {sig} returned non-finite values {value.tolist()}"
    return None, None


def _failure_times(model, t0: float, dt: float, reach: tuple = (0.0, 1.0)) -> list[float]:
    """The step's clock values at which to ask why the torque failed: a time outside the
    model's data (a sampled orbit's span) first, where there is one; ``reach``: the
    earliest and latest times the step's stages read, in steps (``Plan.reach``: a
    composition with negative weights reads times outside its step)."""
    times = [t0, t0 + 0.5 * dt, t0 + dt]
    lo, hi = reach
    if lo < 0.0:
        times.append(t0 + lo * dt)
    if hi > 1.0:
        times.append(t0 + hi * dt)
    span = getattr(model, "span", None)
    if span is not None:
        times.sort(key=lambda t: span[0] <= t <= span[1])
    return times


def widest_reach(reaches) -> tuple[float, float]:
    """The earliest and latest of several plans' ``Plan.reach`` (``(0, 1)`` for none)."""
    reaches = list(reaches)
    return (min([0.0] + [r[0] for r in reaches]), max([1.0] + [r[1] for r in reaches]))


def torque_error(model, name, where, state, t0, dt, traj, step, u=None, i: int = 0,
                 reach: tuple = (0.0, 1.0)) -> TorqueError:
    """Call the user's torque at the last good state (at the step's clock values
    ``t0``, ``t0 + dt/2``, ``t0 + dt``, and where its stages ``reach`` outside the step)
    for its own error: the :class:`TorqueError` to raise, the torque's exception as its
    cause; ``traj`` (or ``None``) goes on it."""
    for t in _failure_times(model, t0, dt, reach):
        exc, words = torque_failure(model, state, t, u, i)
        if words is not None:
            error = TorqueError(f"{name}: {words} {where}", traj, step, t0)
            error.__cause__ = exc  # as ``raise ... from exc``: the context suppressed,
            error.__suppress_context__ = True  # also where the torque raised nothing
            return error
    return TorqueError(f"{name}: the torque {model.signature} raised or returned non-finite "
                       f"values inside the step {where} (it is well behaved at the step's "
                       f"start state)", traj, step, t0)


def failure_error(name: str, scene, model, failure: StepFailure, dt: float, where: str, traj,
                  u=None, reach: tuple = (0.0, 1.0)) -> Exception | None:
    """The error of one body's ``failure`` in a run of the method ``name`` (``where``: the
    words that place it; ``traj``: the samples before it, or ``None``): a user torque's
    :class:`TorqueError` (asked why at the failing step's times, also for a non-finite
    state inside a step whose torque misbehaves there), a :class:`ConvergenceError` for an
    implicit equation, ``None`` for a non-finite state of the dynamics (a blow-up, which
    the caller reports: :func:`liebody.integrate` returns the samples with a warning)."""
    status, state, t0, step = failure.status, failure.state, failure.t, failure.step
    i = failure.body or 0
    if status == S.STATUS_NONFINITE:
        # a user torque that fails inside a baseline's step at a state other than its
        # start (the driver asks it there) shows as a non-finite state: ask the torque
        # at the step's clock values before blaming the dynamics
        if model.function is None or _torque_is_finite(
                model, state, (t0, t0 + 0.5 * dt, t0 + dt), u, i):
            return None
        status = S.STATUS_TORQUE
    if status == S.STATUS_TORQUE:
        return torque_error(model, name, where, state, t0, dt, traj, step, u, i, reach)
    if status == S.STATUS_NO_CONVERGENCE:
        w = float(np.max(np.abs(state[4:] / np.asarray(scene.moments, dtype=float))))
        return ConvergenceError(
            f"{name}: the implicit DMV (RATTLE) equation has no solution {where}. "
            f"h |omega| = {dt * w:.3g} there; the physical root exists up to about 1: "
            f"reduce dt below about {0.7 / w:.3g}", traj, step, t0)
    if status == S.STATUS_KICK_NO_CONVERGENCE:
        stiff = torque_stiffness(model, state, t0, u, i)
        return ConvergenceError(
            f"{name}: the implicit kick of the momentum-dependent torque did not "
            f"converge {where}. (dt/2) |dN/dL| = {0.5 * dt * stiff:.3g} there; "
            f"reduce dt, or check that the torque is smooth in L", traj, step, t0)
    from liebody._kernels._jit import cache_advice

    return RuntimeError(
        f"{name}: the driver returned status {status}, which no driver returns for a "
        f"plan it can run. Either numba's disk cache gave this process another "
        f"kernel's compiled code (a damaged or mixed-up cache: {cache_advice()}), or "
        f"the method's recipe holds a stage its driver does not run (a bug: please "
        f"report it if a fresh cache does not help)")


def torque_failure_words(model, state, t0, dt, u=None, i: int = 0,
                         reach: tuple = (0.0, 1.0)) -> str:
    """Why body ``i``'s torque failed in the step from ``t0`` (for an ensemble's warning)."""
    for t in _failure_times(model, t0, dt, reach):
        words = torque_failure(model, state, t, u, i)[1]
        if words is not None:
            span = getattr(model, "span", None)
            if model.function is None and span is not None and not span[0] <= t <= span[1]:
                return words  # (a time outside a sampled orbit's span: named already)
            return f"{words} at t = {t:.6g}"
    return (f"the torque {model.signature} raised or returned non-finite values inside the "
            f"step from t = {t0:.6g} (well behaved at the step's start state)")


def torque_stiffness(model, state, t0, u=None, i: int = 0) -> float:
    """``max |dN/dL|`` of a user torque at ``state``, by central differences (a diagnosis)."""
    if model.function is None:
        return math.nan
    q, m = state[:4], state[4:]
    e = 1e-6 * max(1.0, float(np.max(np.abs(m))))
    J = np.empty((3, 3))
    try:
        for k in range(3):
            d = np.zeros(3)
            d[k] = e
            J[:, k] = (np.asarray(model(t0, q, m + d, u, i))
                       - np.asarray(model(t0, q, m - d, u, i))) / (2 * e)
    except Exception:
        return math.nan
    return float(np.max(np.abs(J)))
