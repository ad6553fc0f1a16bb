"""``integrate()``: validate, choose and plan the method, run the kernel, wrap the result.

Contract (a template method, after scipy's ``OdeSolver``):

1. validate every argument (``ValueError``/``TypeError`` naming it and the rule),
   including that the samples the run keeps fit in memory;
2. resolve the method (``None`` -> the scene's default) and check it can integrate the
   scene (by its capabilities);
3. plan it: a stage table made concrete for this body, initial state and step
   (set-up choices such as the axis ordering are recorded in ``Trajectory.info``);
4. run the driver of the plan's family through the run engine (``_ensemble.Run``: one
   body is an ensemble of one) in slices of bounded time (a fraction of a second each),
   so that Ctrl-C stops the run within about a second whatever the run's length;
   slicing does not change a bit of the result;
5. wrap the samples in a :class:`~liebody.trajectory.Trajectory`. Nothing fails
   silently: a non-finite state stops the run, keeps the samples before it, sets
   ``failed_at`` and warns; a failed implicit solve or a failing user torque raises
   (:class:`~liebody.errors.ConvergenceError`, :class:`~liebody.errors.TorqueError`)
   with the samples before it on the exception; Ctrl-C raises
   :class:`~liebody.errors.IntegrationInterrupted` with the samples so far; and a
   complete run whose invariants left their tolerance warns
   (:class:`~liebody.errors.InvariantWarning`).
"""

from __future__ import annotations

import contextlib
import math
import os
import warnings

import numpy as np

from liebody import _methods
from liebody._engine import (  # noqa: F401 - re-exported: the Stepper and distributed use them
    CASIMIR_TOL,
    ENERGY_TOL,
    FIRST_SLICE,
    MAX_MOMENTUM,
    QNORM_TOL,
    SHORT_TIMES_SAMPLES,
    SLICE_SECONDS,
    USER_FIRST_SLICE,
    _end_potentials,
    _energy_terms,
    _torque_is_finite,
    diagnostic_reference,
    diagnostics_dict,
    entry_point,
    failed_step_times,
    failed_step_words,
    first_slice,
    input_sizes,
    interrupt_after_call,
    one_body_arg_ends,
    one_body_args,
    time_slices,
    torque_stiffness,
    warn_invariants,
    write_controls,
)
from liebody._engine import PARAMS as ARG_PARAMS
from liebody._engine import T0 as ARG_T0
from liebody._ensemble import _DRIVERS as _ONE_DRIVERS
from liebody._ensemble import (
    _EXACT,
    CTL,
    NO_DMAX,
    NO_DREF,
    Run,
    exact_flow_times,
    one_body_drivers,
    resolve_threads,
)
from liebody._ensemble import drive as _drive
from liebody._kernels import stages as S
from liebody._methods import _REGISTRY
from liebody._ordering import ROWS_AT_ONCE
from liebody._validate import (
    F64,
    UNIT_TOL,
    as_float_array,
    as_positive_float,
    as_positive_int,
    clock_origin,
)
from liebody._validate import as_unit_quaternion as _as_unit_q
from liebody.errors import (
    ConvergenceError,
    TorqueError,
)
from liebody.scenes import _MEMO, Scene, TorqueModel, _memo
from liebody.trajectory import Trajectory

__all__ = ["ConvergenceError", "integrate"]

#: bytes one saved sample takes: t (8), q (32), L (24)
SAMPLE_BYTES = 64
#: the largest step count (float64 step indices stay exact below 2^53)
MAX_STEPS = 2**53
#: bytes an ensemble's run allocates per body beyond its samples and its per-body stage
#: parameters: state, records, diagnostics, the plan's set-up (measured 225-589 B without
#: diagnostics, 353-754 B with, on free bodies, tops, gyrostats, user torques and the
#: gravity gradient; ``tests/faults/test_memory.py``): an upper bound with a margin
RUN_BYTES_PER_BODY = 1024
#: bytes per body of the set-up's temporaries, for at most ``_ordering.ROWS_AT_ONCE``
#: bodies at a time (the axis-ordering choice works through the bodies in chunks: about
#: 1.2 kB a body, so that an ensemble below some 4e4 bodies peaked above
#: :data:`RUN_BYTES_PER_BODY` per body): counted once per run, at most 12.6 MB
SETUP_BYTES_PER_ROW = 1536
#: samples up to this size skip the check of the available memory (a file read)
SMALL_RUN_BYTES = 1 << 24

#: the exact flow's ``Trajectory.info`` (copied for each)
_NO_INFO: dict = {}
#: a scene's prepared short calls (``_ShortCall``, keyed by the arguments that decided
#: them), read directly on :func:`integrate`'s fast path, and how many a scene keeps
_SHORT_CALLS = _MEMO + "short_calls"
SHORT_CALLS_KEPT = 32
#: sample times of short runs, kept read-only and shared: (n_steps, save_every, dt) -> t
_SHORT_TIMES: dict = {}
SHORT_TIMES_KEPT = 256


def _initial_momentum(scene, L0, omega0, names=("L0", "omega0")) -> np.ndarray:
    """Body angular momentum ``(3,)`` or ``(N, 3)`` from ``L0`` or ``omega0`` (``names``:
    what messages call them)."""
    l_name, w_name = names
    if (L0 is None) == (omega0 is None):
        raise ValueError(f"give exactly one of {l_name} (body angular momentum) and "
                         f"{w_name} (body angular velocity)")
    # the common case, one state as three numbers or a float64 array: each entry's bound
    # also rules out NaN and inf (else the checks below say why)
    cls = L0.__class__
    if cls is np.ndarray:
        if L0.shape == (3,) and L0.dtype is F64:
            m1, m2, m3 = L0.tolist()
            if abs(m1) <= MAX_MOMENTUM and abs(m2) <= MAX_MOMENTUM and abs(m3) <= MAX_MOMENTUM:
                return L0.copy()
    elif (cls is list or cls is tuple) and len(L0) == 3 and all(
            v.__class__ is float or v.__class__ is int for v in L0):
        try:
            m1, m2, m3 = (float(v) for v in L0)
        except OverflowError:  # an int beyond float64: the general path below says so
            m1 = m2 = m3 = math.inf
        if abs(m1) <= MAX_MOMENTUM and abs(m2) <= MAX_MOMENTUM and abs(m3) <= MAX_MOMENTUM:
            return np.array((m1, m2, m3))
    if L0 is not None:
        name, m = l_name, np.array(as_float_array(l_name, L0, last_dim=3))
    else:
        omega = as_float_array(w_name, omega0, last_dim=3)
        _check_batch(w_name, omega)
        try:
            m = np.asarray(scene.moments) * omega
            l = getattr(scene, "rotor_momentum", None)
            if l is not None:  # a gyrostat: L = I omega + l
                m = m + np.asarray(l, dtype=float)
        except ValueError:
            raise ValueError(f"{w_name} of shape {omega.shape} does not broadcast against "
                             f"the scene's moments of shape {np.shape(scene.moments)}") \
                from None
        name = w_name
    _check_batch(name, m)
    size = max(map(abs, m.tolist())) if m.ndim == 1 else float(np.max(np.abs(m)))
    if not size <= MAX_MOMENTUM:
        raise ValueError(
            f"{name} is too large: its angular momentum reaches {size:.3g}, above "
            f"{MAX_MOMENTUM:.0e}; the kinetic energy |L|^2/(2 I) would overflow float64. "
            f"Rescale the units of time or inertia")
    return m


def _check_batch(name: str, a: np.ndarray) -> None:
    if a.ndim > 2:
        raise ValueError(f"{name} must be one state (..., shape ({a.shape[-1]},)) or one per "
                         f"body, shape (N, {a.shape[-1]}); got shape {a.shape}")
    if a.ndim == 2 and a.shape[0] == 0:
        raise ValueError(f"{name} holds no body (shape {a.shape}): an ensemble needs at "
                         f"least one")


def _step_count(dt: float, steps, t_end) -> int:
    if (steps is None) == (t_end is None):
        raise ValueError("give exactly one of steps and t_end")
    if steps is not None:
        n = as_positive_int("steps", steps)
        if n > MAX_STEPS:
            raise ValueError(f"steps must be at most 2^53 = {MAX_STEPS:.3g}, got {n:.3g}")
        return n
    t_end = as_positive_float("t_end", t_end)
    n = t_end / dt
    if not n <= MAX_STEPS:
        raise ValueError(f"t_end/dt = {n:.3g} steps: more than 2^53 = {MAX_STEPS:.3g}; "
                         f"raise dt or lower t_end")
    k = round(n)
    # t_end/dt is rounded to ~eps relative: a whole number of steps is within a few ulps
    if k < 1 or abs(n - k) > 8.0 * 2.0**-52 * max(1.0, n):
        raise ValueError(
            f"t_end must be a whole number of steps dt: t_end/dt = {n!r}; choose dt = "
            f"t_end/k for an integer k, or pass steps= instead")
    return int(k)


def _per_sample(bodies: int) -> int:
    """Bytes a sample takes: its time, and ``q``, ``L`` of every body."""
    return SAMPLE_BYTES if bodies == 1 else 8 + (SAMPLE_BYTES - 8) * bodies


def _available_memory() -> int | None:
    """Bytes of memory available to a new allocation: Linux ``MemAvailable`` (or the free
    pages), and no more than the address space the process may still map under a limit
    (``RLIMIT_AS``, as batch systems set it); None when neither is known."""
    avail = None
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    avail = int(line.split()[1]) * 1024
                    break
    except (OSError, ValueError, IndexError):
        pass
    if avail is None:
        with contextlib.suppress(AttributeError, ValueError, OSError):  # (not POSIX)
            avail = os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    room = _address_space_left()
    if room is not None:
        avail = room if avail is None else min(avail, room)
    return avail


def _address_space_left() -> int | None:
    """Bytes the process may still map under ``RLIMIT_AS`` (None without a limit)."""
    try:
        import resource

        limit = resource.getrlimit(resource.RLIMIT_AS)[0]
        if limit == resource.RLIM_INFINITY or limit < 0:
            return None
        with open("/proc/self/statm") as fh:
            used = int(fh.read().split()[0]) * os.sysconf("SC_PAGE_SIZE")
        return max(0, limit - used)
    except (ImportError, OSError, ValueError, IndexError, AttributeError):
        return None


def _sample_times(n_steps: int, save_every: int, dt: float, bodies: int = 1,
                  per_body: int | None = None) -> np.ndarray:
    """Times of the saved samples: steps 0, save_every, 2 save_every, ..., and the last.

    Refuses (``ValueError``) a run whose samples for ``bodies`` bodies, with ``per_body``
    bytes of each body's other arrays (:data:`RUN_BYTES_PER_BODY` by default for an
    ensemble), do not fit in the available memory, saying which ``save_every`` would.
    """
    n_saves = n_steps // save_every + (1 if n_steps % save_every else 0)
    n_samples = n_saves + 1
    per = _per_sample(bodies)
    if per_body is None:
        per_body = 0 if bodies == 1 else RUN_BYTES_PER_BODY
    # the set-up's temporaries, a chunk of bodies at a time
    setup = SETUP_BYTES_PER_ROW * min(bodies, ROWS_AT_ONCE) if bodies > 1 else 0
    fixed = bodies * per_body + setup
    need = n_samples * per + fixed
    avail = None if need <= SMALL_RUN_BYTES else _available_memory()
    if avail is not None and fixed > avail:
        raise ValueError(
            f"{bodies:,} bodies need {per_body:,} B each beyond their samples (the run's "
            f"state, plan and diagnostics) and {setup / 1e6:.3g} MB for the set-up "
            f"({fixed / 1e9:.3g} GB in all), more than the {avail / 1e9:.3g} GB of memory "
            f"available; run fewer bodies per call (or liebody.distributed)")
    if avail is not None and need > avail:
        # suggest a save_every whose samples take at most half the memory left
        fit = max(1, (avail - fixed) // (2 * per) - 1)
        every = max(save_every + 1, math.ceil(n_steps / fit))
        kept = n_steps // every + (1 if n_steps % every else 0) + 1
        what = "samples" if bodies == 1 else f"samples of {bodies:,} bodies"
        if fixed + 2 * per > avail:  # not even the fewest samples: no save_every helps
            raise ValueError(
                f"{bodies:,} bodies need {2 * per / 1e9:.3g} GB for their "
                f"2 samples (the initial and final states at least) and "
                f"{fixed / 1e9:.3g} GB for the run's other arrays, more than the "
                f"{avail / 1e9:.3g} GB of memory available; run fewer bodies per call (or "
                f"liebody.distributed)")
        hint = "" if fit > 1 else "; or keep the final states only (save_every=None)"
        beyond = f" and {fixed / 1e9:.3g} GB for the run's other arrays" if fixed else ""
        raise ValueError(
            f"save_every = {save_every:,} keeps {n_samples:.4g} {what} of "
            f"{per} B ({n_samples * per / 1e9:.3g} GB){beyond}, more than the "
            f"{avail / 1e9:.3g} GB of memory available; save_every = {every:,} keeps "
            f"{kept:,} samples ({kept * per / 1e9:.3g} GB){hint}")
    key = (n_steps, save_every, dt)  # (after the check: it depends on the bodies)
    cached = _SHORT_TIMES.get(key)
    if cached is not None:
        return cached
    try:
        t = np.arange(n_samples, dtype=np.float64)
    except MemoryError:  # pragma: no cover - the check above should have refused it
        raise MemoryError(f"no memory for {n_samples:.4g} samples "
                          f"({need / 1e9:.3g} GB); raise save_every") from None
    t *= save_every
    t[-1] = n_steps
    t *= dt
    if n_samples <= SHORT_TIMES_SAMPLES:  # the short runs of control loops and optimisers
        # shared by every run of the key: over an immutable buffer, which no array can be
        # made to write to (numpy lets a read-only array that owns its data be made
        # writeable again, and a trajectory hands its times out)
        t = np.frombuffer(t.tobytes())
        if len(_SHORT_TIMES) >= SHORT_TIMES_KEPT:
            # (None: another thread may have dropped the same oldest entry)
            _SHORT_TIMES.pop(next(iter(_SHORT_TIMES)), None)
        _SHORT_TIMES[key] = t
    return t


_DEFAULT_Q0 = (1.0, 0.0, 0.0, 0.0)
_IDENTITY = np.array(_DEFAULT_Q0)
#: what the flags accept
_BOOLS = (bool, np.bool_)


def integrate(scene, *, q0=_DEFAULT_Q0, L0=None, omega0=None, dt, steps=None,
              t_end=None, method=None, save_every=1, progress: bool = False,
              threads: int | None = None, diagnostics: bool = False,
              controls=None, t0: float = 0.0, simd: bool | None = None) -> Trajectory:
    """Integrate a rigid-body scene with a fixed step.

    Parameters
    ----------
    scene
        What to integrate, e.g. :class:`liebody.FreeBody`.
    q0
        Initial orientation, scalar-first unit quaternion (body -> space), ``(4,)``, or
        one per body ``(N, 4)``. Its norm must be 1 within 1e-10 (normalise with
        :func:`liebody.quaternion.normalize`).
    L0, omega0
        Exactly one: initial body-frame angular momentum or angular velocity, ``(3,)``
        or one per body ``(N, 3)``.
    dt
        Step size (> 0). For ``method="exact"`` it only sets the output spacing.
    steps, t_end
        Exactly one: number of steps (at most 2^53), or the duration of the run (a
        whole multiple of ``dt``; the run ends at ``t0 + t_end``).
    method
        A name from :func:`liebody.methods` or ``None`` for the scene's default. For a
        :class:`~liebody.FreeBody` the default is ``"exact"``: the free body is
        integrable, so its exact flow is evaluated at the output times and no time
        stepping (and no discretisation error) is spent on it.
    save_every
        Keep every ``save_every``-th step (plus the start and the final state); memory
        is exactly the saved samples, 64 bytes each (56 per body and 8 for the time in
        an ensemble). ``None`` keeps the start and the final state only. A run whose
        samples do not fit in the available memory is refused up front, with the
        ``save_every`` that would fit.
    progress
        Show a tqdm progress bar.
    threads
        Threads an ensemble runs on (``None``: every core; the kernels release the GIL).
    diagnostics
        Keep running diagnostics in the kernel, checked after every step:
        ``Trajectory.diagnostics`` holds the largest relative energy error
        ``|E - E0| / (T0 + |V0|)``, the largest ``| |q| - 1 |`` and the largest relative
        ``|L|`` drift over the whole run (per body for an ensemble), whatever was
        saved: with ``save_every=None`` a million bodies need a few megabytes. (The
        energy includes the potential of uniform gravity; it is NaN for a user torque's
        potential, which the kernel cannot call. First-same-as-last merging of
        splitting steps is off, so every step ends on a full step.)
    controls
        The control inputs ``u`` of a :class:`~liebody.ControlledBody`'s torque, held
        for the whole run: ``(k,)``, or one row per body ``(N, k)`` (zeros when not
        given). To change them during a run (a controller), use a
        :class:`liebody.Stepper`, or integrate piece by piece.
    t0
        The time of the initial state (default 0): the samples are at ``t0 + k dt`` and a
        time-dependent torque sees that clock, so a run can continue where another
        ended. ``t0 + dt`` must differ from ``t0`` in float64 (a ``t0`` so large that it
        does not would freeze the clock: ``ValueError``).
    simd
        Ensembles only: the kernels that step a block of bodies at once in SIMD
        registers (a polynomial sine and cosine instead of the C library's, about 10x
        cheaper per body-step) for the methods and scenes they support: the splittings,
        their compositions and ``rattle`` on free bodies and under a torque that depends
        on the time and orientation only (uniform gravity, the gravity gradient, a user
        torque with ``orientation_only``: explicit kicks), ``sr2`` and ``dmv*`` on free
        bodies; not a torque that depends on the momentum (implicit kicks), dissipation,
        rotors (gyrostats, reaction wheels), the SABA_n, the exact flow or the baselines
        (``info["simd"]`` is then false). ``None`` (default): used for ensembles of at
        least ``SIMD_MIN_BODIES`` (3) bodies; ``True``: for any ensemble; ``False``: never
        (every body then gets exactly the numbers of its one-body call).
        ``Trajectory.info["simd"]`` says whether they ran. Their results agree with the
        one-body call to round-off (a few 1e-16 per step, growing with the orbit's phase
        error), not bit for bit.

    Returns
    -------
    Trajectory
        ``t``, ``q``, ``L`` (body) and derived diagnostics. A run whose state becomes
        non-finite (a baseline that blows up, an overflowing state), or whose final
        ``|L|`` exceeds ``MAX_MOMENTUM`` (1e150: a torque that drives ``L`` out of
        float64's range; the samples are cut before the first such sample), returns the
        samples before the failure, sets ``failed_at`` and ``status = "failed"`` and emits
        a ``RuntimeWarning``. A complete run whose invariants left their tolerance by the
        end (``|q|`` off 1 by more than 1e-6; ``|L|`` for methods that keep it on a
        torque-free scene; the energy, by more than 1 %, for symplectic methods on a
        conservative scene; for any method on a dissipative scene, an energy that rose
        from the first to the last sample, or by more than 1 % of its initial value above
        its lowest earlier sample) emits an :class:`~liebody.errors.InvariantWarning`;
        a potential that is not finite at the ends says so in that warning. The exact
        flow asked for a phase ``|omega| t`` beyond ``PHASE_LIMIT`` (1e15 rad, where
        float64 rounds the angle to about 0.2 rad) emits a ``RuntimeWarning``: the
        samples' phase is lost.

    Raises
    ------
    ValueError, TypeError
        Invalid arguments (each message names the argument and the rule), including a
        user torque that depends on ``L`` in a scene that promises ``orientation_only``
        (checked by a second call at ``L = 2 L0 + 1`` on the initial state).
    ConvergenceError
        An implicit equation was not solved (RATTLE/DMV at ``h |omega|`` beyond about 1,
        or the implicit kick of a stiff momentum-dependent torque); ``.trajectory`` holds
        the samples before the failing step.
    TorqueError
        A user torque raised or returned something other than three finite numbers;
        the torque's exception is the cause, ``.trajectory`` holds the samples before.
    IntegrationInterrupted
        Ctrl-C during the run (a ``KeyboardInterrupt``); ``.trajectory`` holds the
        samples computed so far. The run stops within about a second.

    Notes
    -----
    **Ensembles.** Give ``q0`` ``(N, 4)`` and/or ``L0``/``omega0`` ``(N, 3)`` (a single state
    broadcasts), or a scene whose parameters have a body axis (moments ``(N, 3)``, a
    heavy top's ``mass`` ``(N,)`` and ``cm`` ``(N, 3)``, ...): one call integrates the
    ``N`` bodies. The trajectory's arrays then keep a leading body axis, ``q``
    ``(N, n, 4)``, ``L`` ``(N, n, 3)``, ``t`` ``(n,)``, and every diagnostic works per
    body. Each body's numbers are those of a one-body call, bit for bit. Failures are
    per body: a body that fails stops (``failed_at[i]``, its later samples NaN, one
    warning for all) and the others finish.
    """
    key = None
    if not isinstance(scene, Scene):
        if _is_coupled(scene):
            return _integrate_coupled(scene, q0, L0, omega0, dt, steps, t_end, method,
                                      save_every, progress, diagnostics, controls, t0,
                                      threads, simd)
        raise TypeError(f"scene must be a liebody scene (FreeBody, HeavyTop, TorqueBody, "
                        f"DampedBody or a subclass of liebody.Scene), got {type(scene).__name__}")
    if (omega0 is None and t_end is None and progress is False and diagnostics is False
            and threads is None and simd is None
            and dt.__class__ is float and steps.__class__ is int
            and (save_every is None or save_every.__class__ is int) and t0.__class__ is float
            and (method is None or method.__class__ is str)):
        # a call whose arguments but the initial state and time were checked before (a
        # loop; a clock that advances from call to call keeps the call)
        key = (method, dt, steps, save_every)
        calls = scene.__dict__.get(_SHORT_CALLS)
        if calls is not None:
            call = calls.get(key)
            if call is not None:
                start = call.start(q0, L0)
                u = None if controls is None and not call.k else call.controls(controls)
                # (t0 + dt == t0 refused by the general path: clock_origin)
                if start is not None and u is not False and (
                        t0 == 0.0 or (t0 + dt != t0 and t0 - t0 == 0.0)):
                    return call.run(scene, t0, u, *start)
    q_init = _IDENTITY.copy() if q0 is _DEFAULT_Q0 else _as_unit_q("q0", q0)
    if q_init.ndim != 1:
        _check_batch("q0", q_init)
    m_init = _initial_momentum(scene, L0, omega0)
    if not (dt.__class__ is float and 0.0 < dt < math.inf):  # (else a float at once)
        dt = as_positive_float("dt", dt)
    if t0 != 0.0:
        t0 = clock_origin("t0", t0, dt)
    elif t0.__class__ is not float:  # a zero of another type: the drivers take a float
        t0 = float(as_float_array("t0", t0, shape=()))
    if t_end is None and steps.__class__ is int and 0 < steps <= MAX_STEPS:
        n_steps = steps  # (the common case, at once)
    else:
        n_steps = _step_count(dt, steps, t_end)
    if save_every is None:
        save_every = n_steps
    elif not (save_every.__class__ is int and 0 < save_every <= MAX_STEPS):
        save_every = as_positive_int("save_every", save_every)
    if progress is not False and not isinstance(progress, _BOOLS):
        raise TypeError(f"progress must be True or False, got {type(progress).__name__}")
    if diagnostics is not False and not isinstance(diagnostics, _BOOLS):
        raise TypeError(f"diagnostics must be True or False, got {type(diagnostics).__name__}")
    if simd is not None and not isinstance(simd, _BOOLS):
        raise TypeError(f"simd must be True, False or None, got {type(simd).__name__}")
    batch = scene.__dict__.get(_BATCH_SHAPE)
    if q_init.ndim == 1 and m_init.ndim == 1 and batch is not None and not batch:
        n_bodies = None  # (one body, at once)
    else:
        n_bodies = _bodies(scene, q_init, m_init)
    if threads is not None or n_bodies is not None:
        threads = resolve_threads(threads)

    method = _methods.supported(scene.default_method if method is None else method, scene)
    if scene.moving_rotor:  # reaction wheels: cut where they saturate
        return scene._integrate_run(method, q_init, m_init, dt, n_steps, save_every,
                                    progress, n_bodies, diagnostics, controls, t0,
                                    omega_given=omega0 is not None)
    user = scene.__dict__.get(_USER)  # a user torque's model and checks, once known
    if user is not None:
        model = user.model
    else:
        model = scene.torque_model()
        if model.function is not None:
            user = _memo(scene, "user_torque", _UserTorque, scene, model)
    if user is not None and user.conservative:
        _check_potential(scene, model, q_init, n_bodies, t0)
    u = None if controls is None and not scene.controls else \
        as_controls(scene, controls, n_bodies)
    promise = user is not None and user.promise
    if method.sampled:
        _check_phase(scene, m_init, n_steps * dt)
    if n_bodies is None:
        if user is not None:
            if not (_INITIAL_OK[0] if _INITIAL_OK else _initial_ok())(
                    model.address, t0, q_init, m_init, _NO_U if u is None else u, user.row,
                    promise):
                _check_torque(model, q_init, m_init, u, t0, orientation_only=promise,
                              compiled=False)
            first = USER_FIRST_SLICE
        else:
            first = FIRST_SLICE
        t = _SHORT_TIMES.get((n_steps, save_every, dt))  # (a short run's: they fit)
        if t is None:
            t = _sample_times(n_steps, save_every, dt)
        if (t.shape[0] - 1 <= FIRST_SLICE if method.sampled else n_steps <= first) and not (
                progress or diagnostics):
            call = _ShortCall(scene, method, dt, n_steps, save_every, t, model, user)
            if key is not None and (user is None or not user.conservative):
                calls = _memo(scene, "short_calls", dict)
                if len(calls) >= SHORT_CALLS_KEPT:
                    calls.clear()
                calls[key] = call
            return call.run(scene, t0, u, q_init.tolist(), m_init.tolist(), m_init, q_init)
        run = Run(scene, method, q_init, m_init, dt, n_steps, save_every, t, model, progress,
                  1, diagnostics, u, t0)
    else:
        q_init = np.ascontiguousarray(np.broadcast_to(q_init, (n_bodies, 4)))
        m_init = np.ascontiguousarray(np.broadcast_to(m_init, (n_bodies, 3)))
        _check_torque(model, q_init[0], m_init[0], _first_row(u), t0, ensemble=True,
                      orientation_only=promise)
        t = _sample_times(n_steps, save_every, dt, n_bodies,
                          RUN_BYTES_PER_BODY + _stage_bytes_per_body(scene, method, m_init, dt,
                                                                     u))
        run = Run(scene, method, q_init, m_init, dt, n_steps, save_every, t, model,
                  progress, threads, diagnostics, u, t0, simd)
    return run.sampled() if method.sampled else run.stepped()


def _is_coupled(scene) -> bool:
    """Whether ``scene`` (not a :class:`Scene`) is a :class:`liebody.CoupledBodies`."""
    from liebody.coupled import CoupledBodies

    return isinstance(scene, CoupledBodies)


def _integrate_coupled(scene, q0, L0, omega0, dt, steps, t_end, method, save_every,
                       progress, diagnostics, controls, t0, threads=None, simd=None):
    """:func:`integrate` for :class:`liebody.CoupledBodies` (``liebody.coupled``)."""
    from liebody.coupled import integrate_coupled

    if controls is not None:
        raise ValueError("controls are inputs of a ControlledBody's torque; a coupled "
                         "system's torque takes params (CoupledBodies(..., params=...))")
    if not isinstance(diagnostics, bool | np.bool_):
        raise TypeError(f"diagnostics must be True or False, got {type(diagnostics).__name__}")
    if diagnostics:
        raise ValueError("diagnostics=True: the running diagnostics follow independent "
                         "bodies; a coupled system's energy is Trajectory.energy (the "
                         "total, kinetic plus V) and energy_drift(traj)")
    if not isinstance(progress, bool | np.bool_):
        raise TypeError(f"progress must be True or False, got {type(progress).__name__}")
    dt = as_positive_float("dt", dt)
    t0 = clock_origin("t0", t0, dt)
    n_steps = _step_count(dt, steps, t_end)
    save_every = n_steps if save_every is None else as_positive_int("save_every", save_every)
    t = _sample_times(n_steps, save_every, dt, scene.n_bodies, RUN_BYTES_PER_BODY)
    return integrate_coupled(scene, q0=q0, L0=L0, omega0=omega0, dt=dt, n_steps=n_steps,
                             save_every=save_every, method=method, progress=bool(progress),
                             t0=t0, t=t, threads=threads, simd=simd)


def _bodies(scene, q0: np.ndarray, m0: np.ndarray) -> int | None:
    """The number of bodies of an ensemble run (``None`` for one body): the length of the
    body axis of ``q0``, of ``L0``/``omega0`` and of the scene's parameters, broadcast."""
    if q0.ndim == 1 and m0.ndim == 1 and not scene_batch_shape(scene):
        return None
    shapes = {"q0": q0.shape[:-1], "L0/omega0": m0.shape[:-1],
              "the scene's parameters": scene_batch_shape(scene)}
    try:
        batch = np.broadcast_shapes(*shapes.values())
    except ValueError:
        told = ", ".join(f"{k} {v[0] if v else 'one body'}" for k, v in shapes.items())
        raise ValueError(f"the numbers of bodies do not match: {told}") from None
    if batch and batch[0] == 0:
        empty = ", ".join(k for k, v in shapes.items() if v and v[0] == 0)
        raise ValueError(f"an ensemble needs at least one body: {empty} has none "
                         f"(shape (0, ...))")
    return batch[0] if batch else None


def scene_batch_shape(scene) -> tuple[int, ...]:
    """The body axis of a scene's parameters: ``()`` for one body, ``(N,)`` for many
    (kept on the scene: it is immutable)."""
    return _memo(scene, "batch_shape", _batch_shape_of, scene)


def _batch_shape_of(scene) -> tuple[int, ...]:
    return tuple(getattr(scene, "batch_shape", ()))


#: the key of that memo (``liebody.scenes``), read directly on the one-body fast path
_BATCH_SHAPE = _MEMO + "batch_shape"


def _stage_bytes_per_body(scene, method, m0: np.ndarray, dt: float, u=None) -> int:
    """Bytes of stage parameters an ensemble's plan keeps per body: none when every body
    shares them (a scene without per-body parameters or controls ``u`` per body), else its
    distinct stage rows (from the plan of body 0; another group's plan may hold a row
    more, which :data:`RUN_BYTES_PER_BODY`'s margin covers)."""
    per_body_u = u is not None and u.ndim == 2
    if method.sampled or not (scene_batch_shape(scene) or per_body_u):
        return 0
    try:
        plan = method.plan(scene.take(0) if scene_batch_shape(scene) else scene, m0[0], dt)
    except ValueError:
        return 0  # refused: the run says why
    return plan.params.shape[1] * S.N_PARAMS * 8


def _check_potential(scene, model, q0: np.ndarray, n_bodies, t0: float) -> None:
    """A user's potential (Python, called at the end of the run for the energy check) is
    called once on the initial orientation: a finite number, or a clear error before the
    run starts rather than a lost run at its end."""
    if model.code != S.TORQUE_USER or not scene.capabilities.conservative:
        return
    one = scene.take(0) if n_bodies is not None and scene_batch_shape(scene) else scene
    q = np.asarray(q0, dtype=float).reshape(-1, 4)[:1]
    try:
        V = np.asarray(one.potential(q, t0) if getattr(one, "params", None) is not None
                       else one.potential(q), dtype=float)
    except Exception as exc:
        raise ValueError(f"the scene's potential raised {type(exc).__name__} on the initial "
                         f"orientation: {exc}") from exc
    if V.shape != (1,):
        raise ValueError(f"the scene's potential must give one number per orientation, got "
                         f"shape {V.shape[1:]} for one orientation")
    if not np.isfinite(V[0]):
        raise ValueError(f"the scene's potential is not finite on the initial orientation "
                         f"(V = {V[0]})")


class _UserTorque:
    """What :func:`integrate` knows of a user-torque scene, found once per scene (a scene
    is frozen): its torque model and the model's parameter row of body 0, whether its
    potential is checked (:func:`_check_potential`) and whether it promises
    ``orientation_only``."""

    __slots__ = ("conservative", "model", "promise", "row")

    def __init__(self, scene, model: TorqueModel) -> None:
        caps = scene.capabilities
        self.model, self.row = model, model.params[0]
        self.conservative = caps.conservative
        self.promise = "momentum" not in caps.torque


#: the key of that memo (``liebody.scenes``), read directly on the one-body fast path
_USER = _MEMO + "user_torque"
#: the controls of a torque without them
_NO_U = np.zeros(0)
#: ``user_torque.initial_ok``'s entry point, found on first use
_INITIAL_OK: list = []


def _initial_ok():
    """``user_torque.initial_ok``'s entry point (``initial_ok_entry``), kept."""
    if not _INITIAL_OK:
        from liebody._models.user_torque import initial_ok_entry

        _INITIAL_OK.append(initial_ok_entry())
    return _INITIAL_OK[0]


def _check_torque(model: TorqueModel, q0: np.ndarray, m0: np.ndarray, u=None,
                  t0: float = 0.0, ensemble: bool = False,
                  orientation_only: bool = False, compiled: bool = True) -> None:
    """A user torque is called once on the initial state: three numbers, or a clear error
    before the run starts. One body: they must be finite too. An ensemble (``q0``, ``m0``,
    ``u`` of its body 0): a torque that raises or is not finite at one body's state fails
    that body in the run, whichever body it is; only a wrong shape refuses the run.

    ``orientation_only``: the scene promises a torque that does not depend on ``L``; a
    second call at ``L = 2 L0 + 1`` (same ``t``, ``q``, ``u``) must give the same numbers,
    else ``ValueError`` (a false promise ran at order 1 without a word).

    The calls go to the torque's C callback first, in one compiled call
    (``user_torque.initial_ok``: the same compiled function on the same numbers as the
    drivers'; skipped with ``compiled=False``, when the caller made it); only when that
    finds a fault is the torque called from Python, which raises the error that names
    it. ``q0``, ``m0`` and ``u`` are 1-d float64 arrays."""
    if model.function is None:
        return
    if compiled and _initial_ok()(model.address, t0, q0, m0, _NO_U if u is None else u,
                                  model.params[0], orientation_only):
        return
    sig = model.signature
    try:
        value = np.asarray(model(t0, q0, m0, u), dtype=float)
    except Exception as exc:
        if ensemble:
            return
        raise TorqueError(f"the torque {sig} raised {type(exc).__name__} on the "
                          f"initial state: {exc}{input_sizes(model, exc)}", step=0,
                          t=t0) from exc
    if value.shape != (3,):
        raise ValueError(f"the torque {sig} must return 3 numbers, got shape "
                         f"{value.shape} on the initial state")
    finite = all(map(math.isfinite, value.tolist()))
    if not ensemble and not finite:
        raise TorqueError(f"the torque {sig} returned non-finite values "
                          f"{value.tolist()} on the initial state", step=0, t=t0)
    if orientation_only and finite:
        _check_orientation_only(model, q0, m0, u, t0, value)


def _check_orientation_only(model: TorqueModel, q0: np.ndarray, m0: np.ndarray, u,
                            t0: float, value: np.ndarray) -> None:
    """The torque at ``L = 2 L0 + 1`` must equal ``value``, its value at ``L0``."""
    other_L = 2.0 * m0 + 1.0
    why = ("orientation_only=True promises a torque of t, q (and u) alone, whose kicks "
           "are then explicit and exact; for a torque that depends on L, pass "
           "orientation_only=False (the default: implicit kicks, the method's order kept)")
    try:
        other = np.asarray(model(t0, q0, other_L, u), dtype=float)
    except Exception as exc:
        raise ValueError(
            f"the torque {model.signature} depends on L though orientation_only=True: it "
            f"raised {type(exc).__name__} ({exc}) at L = 2 L0 + 1 = {other_L.tolist()} "
            f"(same t and q), not at L0. {why}") from exc
    if other.shape != (3,) or other.tolist() != value.tolist():
        raise ValueError(
            f"the torque {model.signature} depends on L though orientation_only=True: at "
            f"the initial t and q it gives {value.tolist()} at L0 = {m0.tolist()} and "
            f"{other.tolist()} at L = 2 L0 + 1. {why}")


#: |omega| t beyond which the exact flow's phase is lost: float64 rounds an angle of
#: 1e15 rad to about 0.1 rad
PHASE_LIMIT = 1e15


def _check_phase(scene, m0: np.ndarray, duration: float) -> None:
    """Warn when the exact flow is asked for a phase ``|omega| t`` beyond float64's
    resolution (:data:`PHASE_LIMIT`)."""
    if m0.ndim == 1 and np.ndim(scene.moments) == 1:
        L1, L2, L3 = m0.tolist()
        I1, I2, I3 = scene.moments.tolist()
        try:
            w = math.hypot(L1 / I1, L2 / I2, L3 / I3)
        except OverflowError:  # |L| / I beyond float64
            w = math.inf
        where = ""
    else:
        with np.errstate(over="ignore"):
            ws = np.linalg.norm(m0 / np.asarray(scene.moments, dtype=float), axis=-1)
        i = int(np.argmax(ws))
        w = float(ws.flat[i])
        where = f" (body {i})"
    phase = w * duration
    if not phase > PHASE_LIMIT:
        return
    warnings.warn(
        f"exact: the run reaches |omega| t = {phase:.3g} rad{where} (|omega| = {w:.3g}, "
        f"t = {duration:.3g} after t0). float64 rounds an angle that large to about "
        f"{phase * 2.0**-52:.2g} rad, more than {PHASE_LIMIT * 2.0**-52:.2g} rad: the phase "
        f"of the motion (the orientation about L, and L along its orbit) is lost beyond "
        f"t = {PHASE_LIMIT / w:.3g} (|L|, the energy and |q| are still right). Shorten the "
        f"run, or rescale the units of time", RuntimeWarning, stacklevel=3)


def as_controls(scene, controls, n_bodies: int | None, name: str = "controls"
                ) -> np.ndarray | None:
    """The control inputs ``u`` of a :class:`~liebody.ControlledBody`: ``(k,)``, or one
    row per body ``(N, k)``; ``None`` for a scene without controls (``name``: the
    argument's name in messages)."""
    k = getattr(scene, "controls", 0)
    if not k:
        if controls is not None:
            raise ValueError(f"{name}: the scene {type(scene).__name__} takes no control "
                             f"inputs (use a liebody.ControlledBody)")
        return None
    if controls is None:
        u = np.zeros(k)
    else:
        u = np.array(as_float_array(name, controls, last_dim=k))
        _check_batch(name, u)
    if u.ndim == 2 and (n_bodies is None or u.shape[0] != n_bodies):
        told = "one body" if n_bodies is None else f"{n_bodies} bodies"
        raise ValueError(f"{name} of shape {u.shape} give one row per body for "
                         f"{u.shape[0]} bodies, but the run has {told}")
    return u


def _first_row(u):
    """The first body's controls (``None`` for none)."""
    return None if u is None else u.reshape(-1, u.shape[-1])[0]


class _ShortCall:
    """A one-body run of one driver call, without progress bar or diagnostics (the fixed
    cost of control loops and optimisers): :meth:`Run.stepped` without a run object, for
    one method, step, step count, save interval and model.

    Without a user torque whose potential is called, the call is
    kept on the scene (frozen) under the arguments that decided it (:func:`integrate`'s
    fast path): a repeated call then checks its initial state and time only
    (:meth:`start`; the sample times and the driver's arguments of the last start time
    are kept, so a loop that advances the clock reuses the call too). The
    call holds no reference to its scene (:meth:`run` is given it): kept on the scene, it
    would make a cycle that frees the scene only when the cyclic garbage collector runs.
    An interrupted, overflowing or failed run is handed to :class:`Run`, which reports it
    as a longer run would."""

    __slots__ = ("at", "casimir", "ctl", "dt", "energy", "fields", "inertia", "k", "keep",
                 "last", "method", "model", "moments", "n_steps", "rotor", "save_every", "t",
                 "user")

    def __init__(self, scene, method, dt: float, n_steps: int, save_every: int,
                 t: np.ndarray, model, user) -> None:
        self.method, self.dt = method, dt
        self.n_steps, self.save_every, self.t = n_steps, save_every, t
        self.at = None  # (t0, the sample times t0 + t) of the last start time
        self.model, self.user = model, user
        self.k = scene.controls  # the number of control inputs (0: none)
        # the exact flow's moments (a free body's flow evaluated at the sample times)
        self.inertia = np.ascontiguousarray(scene.moments, dtype=np.float64) \
            if method.sampled else None
        self.fields = None  # the trajectories' other fields, from the first one
        self.last = None  # (L0's bytes, its plan): the plan of a repeated initial state
        self.ctl = ctl = CTL.copy()
        ctl[0] = save_every
        # the end-of-run check in scalar arithmetic (:func:`_one_body_problems`'s rules)
        # where it needs no potential; else that function
        caps, self.moments, self.rotor = _energy_terms(scene)
        self.casimir = method.keeps_casimir and not caps.torque
        self.energy = (method.symplectic or method.keeps_energy) and caps.conservative
        self.keep = not (caps.torque and self.energy) and not (
            caps.dissipative and not caps.torque)

    def start(self, q0, L0) -> tuple | None:
        """``(q0, L0)`` as lists when they take the common forms (a float64 ``(4,)`` unit
        quaternion, four floats or ints in a list or tuple, or the default ``q0``; a
        float64 ``(3,)`` ``L0`` in range, or three floats or ints: the rules of
        :func:`liebody._validate.as_unit_quaternion` and :func:`_initial_momentum`, with
        the same numbers) and the method is still the registry's; else ``None``, and the
        general path checks them and says why."""
        cls = q0.__class__
        qa = None  # q0 as an array for the user torque's check, where it is at hand
        if cls is np.ndarray:
            if q0.shape != (4,) or q0.dtype is not F64:
                return None
            ql = q0.tolist()
            w, x, y, z = ql
            n = math.sqrt(w * w + x * x + y * y + z * z)
            if n != 1.0:
                if not abs(n - 1.0) <= UNIT_TOL:
                    return None
                ql = [w / n, x / n, y / n, z / n]
            else:
                qa = q0
        elif q0 is _DEFAULT_Q0:
            ql = [1.0, 0.0, 0.0, 0.0]
            qa = _IDENTITY
        elif (cls is list or cls is tuple) and len(q0) == 4 and all(
                v.__class__ is float or v.__class__ is int for v in q0):
            try:
                w, x, y, z = (float(v) for v in q0)
            except OverflowError:  # (an int beyond float64: the general path says so)
                return None
            n = math.sqrt(w * w + x * x + y * y + z * z)
            if not abs(n - 1.0) <= UNIT_TOL:
                return None
            ql = [w / n, x / n, y / n, z / n]  # (as_unit_quaternion divides these always)
        else:
            return None
        cls = L0.__class__
        if cls is np.ndarray:
            if L0.shape != (3,) or L0.dtype is not F64:
                return None
            ml = L0.tolist()
            m1, m2, m3 = ml
            owned = False
        elif (cls is list or cls is tuple) and len(L0) == 3 and all(
                v.__class__ is float or v.__class__ is int for v in L0):
            try:
                m1, m2, m3 = ml = [float(v) for v in L0]
            except OverflowError:
                return None
            owned = True
        else:
            return None
        if not (abs(m1) <= MAX_MOMENTUM and abs(m2) <= MAX_MOMENTUM and abs(m3) <= MAX_MOMENTUM):
            return None
        method = self.method
        if _REGISTRY.get(method.name) is not method:
            return None
        if self.inertia is not None:  # the exact flow: a phase beyond float64's resolution
            I1, I2, I3 = self.moments  # is warned of by the general path (_check_phase)
            if not math.hypot(m1 / I1, m2 / I2, m3 / I3) * (self.n_steps * self.dt) \
                    <= PHASE_LIMIT:
                return None
        if owned:
            L0 = np.array(ml)
        return ql, ml, L0, qa, owned, False

    def controls(self, controls) -> np.ndarray | bool | None:
        """A repeated call's controls ``u``: a new float64 ``(k,)`` array (zeros when not
        given), ``None`` for a scene without them, or ``False`` when they take another
        form than a float64 ``(k,)`` array or ``k`` floats or ints, finite (the rules and
        numbers of :func:`as_controls`): the general path then checks them and says
        why."""
        k = self.k
        if not k:
            return None if controls is None else False
        if controls is None:
            return np.zeros(k)
        cls = controls.__class__
        if cls is np.ndarray:
            if controls.shape != (k,) or controls.dtype is not F64:
                return False
            values = controls.tolist()
        elif (cls is list or cls is tuple) and len(controls) == k and all(
                v.__class__ is float or v.__class__ is int for v in controls):
            try:
                values = [float(v) for v in controls]
            except OverflowError:
                return False
        else:
            return False
        for v in values:
            if v - v != 0.0:  # (NaN or inf: the general path refuses it)
                return False
        return np.array(values)

    def run(self, scene, t0: float, u, ql: list, ml: list, m0: np.ndarray,
            q0: np.ndarray | None = None, owned: bool = True,
            checked: bool = True) -> Trajectory:
        """The run of ``scene`` from ``q0`` and ``m0`` at ``t0`` under the controls ``u``
        (``None`` for none; ``q0``: ``ql`` as an array, read only, or ``None``: made from
        ``ql`` where needed; ``owned``: whether ``m0`` is the run's own copy, else the
        caller's, which a new plan must not keep; ``checked``: whether :func:`integrate`
        checked the user torque on this initial state, as a first call does); its
        warnings point at :func:`integrate`'s caller."""
        method, dt = self.method, self.dt
        at = self.at
        # (t0 = -0.0 equals 0.0: the drivers and the torque get the caller's zero)
        if at is not None and (t0 is at[0] or (t0 == at[0] and math.copysign(
                1.0, t0) == math.copysign(1.0, at[0]))):
            times = at[1]
        else:
            # the sample times every trajectory from t0 shares: its own copy (a longer
            # run's are writeable; the cache of short runs' times is shared) over an
            # immutable buffer, which no array can be made to write to (a read-only array
            # that owns its data, or the base of a view, numpy lets its user make
            # writeable again)
            times = np.frombuffer((t0 + self.t if t0 != 0.0 else self.t).tobytes())
            self.at = (t0, times)
        user = self.user
        if user is not None and not checked:
            # a repeated call: the torque at the initial state, in one compiled call
            model = self.model
            if q0 is None:
                q0 = np.array(ql)
            if not (_INITIAL_OK[0] if _INITIAL_OK else _initial_ok())(
                    model.address, t0, q0, m0, _NO_U if u is None else u, user.row,
                    user.promise):
                _check_torque(model, q0, m0, u, t0, orientation_only=user.promise,
                              compiled=False)
        if self.inertia is not None:
            return self._exact(scene, t0, times, ql, ml, m0, q0)
        key = m0.tobytes()
        last = self.last
        if last is not None and last[0] == key:
            _, plan, head, tail, fn = last
            if head[ARG_T0] is not t0:  # the driver's clock origin: the caller's
                head = (*head[:ARG_T0], t0, *head[ARG_T0 + 1:])
                self.last = (key, plan, head, tail, fn)
            if u is not None:  # this call's controls, in a copy of the stage rows
                params = plan.first[0].copy()
                write_controls(params, u)
                head = (*head[:ARG_PARAMS], params, *head[ARG_PARAMS + 1:])
        else:
            plan = method.plan(scene, m0 if owned else m0.copy(), dt)
            params = plan.first[0]
            if u is not None:
                params = params.copy()
                write_controls(params, u)
            head, tail = one_body_arg_ends(plan, params, plan.merge_ends, dt, t0, 0.0,
                                           self.n_steps, self.save_every, True,
                                           self.model.address, NO_DREF, NO_DMAX)
            fn = None
            self.last = (key, plan, head, tail, fn)
        state = np.array(ql + ml)
        ctl = self.ctl.copy()
        n = self.t.shape[0]
        q_out, m_out = np.empty((n, 4)), np.empty((n, 3))
        q_out[0] = ql
        m_out[0] = m0
        args = (*head, state, ctl, q_out[1:], m_out[1:], *tail)
        try:
            if fn is not None:
                done, saved, status = fn(*args)
            else:  # numba's dispatch, then its entry point (:func:`_drive`)
                runner = (_ONE_DRIVERS[0] if _ONE_DRIVERS else one_body_drivers())[False][
                    plan.family]
                done, saved, status = _drive(runner, plan, args)
                fn = plan.entries.get(runner)
                if fn is not None:
                    self.last = (key, plan, head, tail, fn)
        except KeyboardInterrupt:
            done = saved = 0
            status = None
        if status == S.STATUS_OK:
            end = state.tolist()
            b1, b2, b3 = end[4:]
            if max(abs(b1), abs(b2), abs(b3)) <= MAX_MOMENTUM:
                return self._complete(scene, times, q_out, m_out, plan.info, end, ql, ml, 5)
        run = self._run(scene, t0, u, ql, m0, q0, q_out, m_out)
        run.info = dict(plan.info)
        run.reach = plan.reach
        if status is None:
            run.interrupted_one(1, 0)
        if status == S.STATUS_OK:
            return run.overflowed()
        return run.failed(status, done, saved, state)

    def _run(self, scene, t0, u, ql, m0, q0, q_out, m_out) -> Run:
        """The run object that reports an outcome other than a complete run, as a longer
        run's (its warnings point at :func:`integrate`'s caller from a method of
        :class:`_ShortCall` called by :meth:`run`)."""
        return Run(scene, self.method, np.array(ql) if q0 is None else q0, m0, self.dt,
                   self.n_steps, self.save_every, self.t, self.model, False, 1, False, u, t0,
                   outputs=(q_out, m_out))


    def _complete(self, scene, times, q_out, m_out, info: dict, end: list, ql: list,
                  ml: list, stacklevel: int) -> Trajectory:
        """A complete run's trajectory (``info`` copied: the plan's is shared), after the
        end-of-run check of its last state ``end`` from ``L0 = ml``: by
        :func:`_one_body_problems`'s rules in scalar arithmetic where they need no
        potential, else (or when a rule is broken) :func:`warn_invariants`, whose warning
        points ``stacklevel`` frames up (at :func:`integrate`'s caller)."""
        q_out.setflags(write=False)  # ours: no view
        m_out.setflags(write=False)
        fields = self.fields
        if fields is None:  # the first run: the template of the next ones
            traj = Trajectory._complete(times, q_out, m_out, scene, self.method, self.dt,
                                        info.copy(), None)
            # (every key, in order, in a table the next ones' dicts clone at
            # once; the scene's None: the call holds no reference to it)
            fields = {**traj.__dict__}
            for name in ("t", "q", "L", "info", "scene"):
                fields[name] = None
            self.fields = fields
        else:  # Trajectory._complete from the template, with the scene
            traj = object.__new__(Trajectory)
            d = traj.__dict__
            d.update(fields)
            d["t"] = times
            d["q"] = q_out
            d["L"] = m_out
            d["scene"] = scene
            d["info"] = info.copy()
        w, x, y, z, b1, b2, b3 = end
        if self.keep and abs(math.hypot(w, x, y, z) - 1.0) <= QNORM_TOL:
            a1, a2, a3 = ml
            g0 = math.hypot(a1, a2, a3)
            if not self.casimir or abs(math.hypot(b1, b2, b3) - g0) <= CASIMIR_TOL * g0:
                if not self.energy:
                    return traj
                I1, I2, I3 = self.moments
                if self.rotor is not None:  # a gyrostat: (L - l)^T I^-1 (L - l) / 2
                    l1, l2, l3 = self.rotor
                    a1, a2, a3 = a1 - l1, a2 - l2, a3 - l3
                    b1, b2, b3 = b1 - l1, b2 - l2, b3 - l3
                e0 = 0.5 * (a1 * a1 / I1 + a2 * a2 / I2 + a3 * a3 / I3)
                e1 = 0.5 * (b1 * b1 / I1 + b2 * b2 / I2 + b3 * b3 / I3)
                if not e0 > 0 or abs(e1 - e0) <= ENERGY_TOL * e0:
                    return traj
        # a problem, or a check that needs the potential: the words
        return warn_invariants(traj, stacklevel, (ql, end[:4], ml, end[4:]))

    def _exact(self, scene, t0, times, ql, ml, m0, q0) -> Trajectory:
        """The exact flow evaluated at the sample times (:meth:`Run.sampled` for one call
        of its kernel); its warnings point at :func:`integrate`'s caller."""
        n = self.t.shape[0]
        q_out, m_out = np.empty((n, 4)), np.empty((n, 3))
        q_out[0] = ql
        m_out[0] = m0
        try:
            # the initial state from the first samples: contiguous and writeable, as a
            # first call's copies (a repeated call's m0 is the caller's L0, which may be
            # read-only or strided: numba would compile the kernel again for it)
            (_EXACT[0] if _EXACT else exact_flow_times())(self.inertia, q_out[0], m_out[0],
                                                          self.t[1:], q_out[1:], m_out[1:])
        except KeyboardInterrupt:
            self._run(scene, t0, None, ql, m0, q0, q_out, m_out).interrupted_one(1, 0)
        if not math.isfinite(float(q_out.sum()) + float(m_out.sum())):
            bad = ~(np.isfinite(q_out).all(axis=1) & np.isfinite(m_out).all(axis=1))
            k = int(np.argmax(bad))
            run = self._run(scene, t0, None, ql, m0, q0, q_out, m_out)
            return run.failed_nonfinite(k, run._step_of_sample(k - 1), t0 + self.t[k - 1],
                                        t0 + self.t[k], stacklevel=5)
        return self._complete(scene, times, q_out, m_out, _NO_INFO,
                              q_out[-1].tolist() + m_out[-1].tolist(), ql, ml, 6)
