"""``Stepper``: a prepared integrator for control loops and other short, repeated calls.

:func:`liebody.integrate` validates, plans and allocates on every call: right for a
run, too much for a controller that advances the body by one control period at a
time. A :class:`Stepper` does that work once (validation, the method's plan, the
compiled driver and its argument list) and then :meth:`Stepper.step` only calls the
compiled kernel on its state, in place. Between calls the state (``q``, ``L``, the
time ``t``) and the control inputs ``u`` of a :class:`~liebody.ControlledBody` can be
read and set.

A long ``step(n)`` runs in slices of steps sized by their measured cost (each about
:data:`~liebody._engine.SLICE_SECONDS` of wall time), so that Ctrl-C, which Python sees only between
calls into compiled code, stops it soon whatever a step costs. The drivers carry their
control across slices, so the slices change no bit of the result. On Ctrl-C the steps
finished are kept (a step whose last stage was merged with the next step's first is
completed), every thread is joined, and the stepper is left after ``m`` steps of the
call exactly as ``step(m)`` would have left it.
"""

from __future__ import annotations

import math
import threading
import time
import warnings

import numpy as np

from liebody import _methods
from liebody._engine import (
    FINAL,
    N_STEPS,
    STEP0,
    T0,
    StepFailure,
    batch_args,
    batch_runner,
    body_chunks,
    failed_step_times,
    failed_step_words,
    failure_error,
    groups_info,
    next_slice,
    one_body_args,
)
from liebody._engine import entry_point as _entry_point
from liebody._kernels import stages as S
from liebody._validate import as_positive_float, as_positive_int, clock_origin
from liebody._validate import as_unit_quaternion as _as_unit_q
from liebody.errors import IntegrationError, IntegrationInterrupted
from liebody.scenes import Scene

__all__ = ["Stepper"]

#: the dtype of the state and the controls (the setter of ``u`` compares it by identity)
_FLOAT64 = np.dtype(np.float64)

#: body-steps in the first slice of a stepper that has not measured its cost yet (the
#: later ones: ``_engine.next_slice``, about ``_engine.SLICE_SECONDS`` each)
_FIRST_WORK = 64


def _join(pool) -> None:
    """Wait for every task given to ``pool`` (a second Ctrl-C does not cut the wait
    short: the tasks are kernel slices of a fraction of a second)."""
    while True:
        try:
            pool.shutdown(wait=True)
            return
        except KeyboardInterrupt:
            continue


class Stepper:
    """Advance a scene step by step, with the state and the controls set between steps.

    Prepared once (validation, the method's plan for this body and step, the compiled
    kernel), then :meth:`step` advances the state in place for the cost of a compiled
    call: about 1 µs on a free body (some 20 one-body ``splitting2`` steps), against about
    10 µs for a one-step :func:`liebody.integrate` (``bench/step_cost.py`` measures both).

    Parameters
    ----------
    scene
        What to integrate (:class:`~liebody.FreeBody`, :class:`~liebody.HeavyTop`,
        :class:`~liebody.TorqueBody`, :class:`~liebody.ControlledBody`, ...), one body or
        an ensemble (its parameters with a body axis).
    q0, L0, omega0
        The initial state, as for :func:`liebody.integrate` (``(4,)``/``(3,)``, or one
        row per body).
    dt
        The step (> 0); for the exact flow, the time one step advances.
    method
        A method name, or ``None`` for the scene's default (the exact flow for a free
        body).
    controls
        Initial control inputs ``u`` of a :class:`~liebody.ControlledBody` (``(k,)`` or
        ``(N, k)``); zeros when not given. Set :attr:`u` between steps.
    threads
        Threads an ensemble's steps run on (``None``: every core); one body runs on
        the calling thread.
    simd
        Ensembles only, as for :func:`liebody.integrate`: the kernels that step a block
        of bodies at once in SIMD registers, for the methods and scenes they support.
        ``None`` (default): used for ensembles of at least ``SIMD_MIN_BODIES`` (3)
        bodies; ``True``: for any ensemble; ``False``: never (every body then gets
        exactly the numbers of its one-body stepper). ``info["simd"]`` says whether
        they run (per group in ``info["groups"]``).
    t0
        The time of the initial state (default 0), as for :func:`liebody.integrate`: the
        clock the torque sees starts there (a user torque is checked on the initial
        state at ``t0``); refused where ``t0 + dt == t0`` in float64, as is setting
        :attr:`t` to such a time.

    Notes
    -----
    *Agreement with integrate().* ``k`` calls ``step(n)`` give the states that
    ``integrate(..., steps=k * n, save_every=n)`` saves, bit for bit (in particular
    ``step()`` repeated equals ``save_every=1``), when the state is not set between
    the calls and, for an ensemble, ``simd`` is the same (and ``t0``): the kernel, the
    plan and the clock ``t = t0 + (k + j) dt`` are the same. With a larger
    ``save_every`` the splittings merge the last kick of a step with the first of the
    next, and the two agree to round-off. The exact flow advances the state by ``n dt``
    per call, and agrees with ``integrate()``'s samples (evaluated from the initial
    state) to round-off.

    *Zero-order hold.* The controls ``u`` are held constant over every step of a call:
    set them, then call ``step()``, as a digital controller does each period.

    *Setting the state.* ``q``, ``L`` (or ``omega``) and ``t`` may be set between calls
    (``L`` and ``omega`` re-plan the method at the next step, since some plans are made
    for the orbit of the state, such as the axis ordering of the splittings or the
    modified moments of preprocessed DMV; ``q`` and ``t`` cost nothing).

    *Failures.* For one body, a step that fails raises: an implicit equation not
    solved or a torque that fails raise the error of :func:`liebody.integrate`
    (:class:`~liebody.errors.ConvergenceError`, :class:`~liebody.errors.TorqueError`),
    a non-finite state :class:`~liebody.errors.IntegrationError` (where ``integrate()``
    returns the samples before it, with a ``RuntimeWarning``). The stepper is left as
    it was before the call: the failed call changes nothing, and ``exc.step`` tells
    how many of its steps succeeded. For an ensemble the failing bodies are left at
    their state before the call, marked in :attr:`failed` and skipped by later calls (a
    ``RuntimeWarning`` says which); the others go on. Setting the state clears the
    marks.

    *Ctrl-C.* A long ``step(n)`` runs in slices of about 0.2 s (sized by their measured
    cost), so Ctrl-C stops it within about that whatever a step costs; the slices
    change no bit of the result. It raises :class:`~liebody.errors.IntegrationInterrupted`
    (a ``KeyboardInterrupt``) once every thread has finished its slice, with the steps
    done kept: the stepper is left after ``exc.step`` steps of the call, with
    :attr:`t` and :attr:`steps` advanced by as many, exactly as ``step(exc.step)``
    would have left it (a step whose last stage had been merged with the next one's
    first is completed first).

    *Reaction wheels.* For a :class:`~liebody.ReactionWheels` scene, ``controls`` and
    :attr:`u` are the wheels' motor torques (``(n,)`` or ``(N, n)``), clipped to the
    scene's ``max_torque``; ``stepper.wheel_momentum`` reads and sets the wheels'
    momenta, ``stepper.saturations`` lists the saturations so far (records:
    :class:`liebody.wheels.Saturation`), ``omega`` is the body's ``I^-1 (L - A h)``
    (``omega0`` too: ``L = I omega0 + A h0``), and a call is cut where a wheel reaches a
    limit, by the rule of :func:`liebody.integrate`, so the two agree bit for bit.

    *Copies, pickling and threads.* ``copy.copy``, ``copy.deepcopy`` and pickling give
    an independent stepper with its own state, time, controls and failure marks (the
    scene, immutable, is shared), which continues bit for bit as the original would.
    Calls from several threads are serialised by a lock: ``step()`` called from many
    threads at once gives the state of the same number of calls made one after another.

    Examples
    --------
    >>> import numpy as np
    >>> import liebody as lb
    >>> top = lb.HeavyTop(lb.RigidBody([1.0, 1.0, 0.5]), mass=1.0, cm=[0, 0, 0.3])
    >>> s = lb.Stepper(top, omega0=[0.0, 0.0, 40.0], dt=1e-3)
    >>> for _ in range(1000):
    ...     s.step()
    >>> round(s.t, 9)
    1.0
    """

    def __new__(cls, scene=None, *args, **kwargs):
        """A :class:`~liebody.ReactionWheels` scene gets the wheels' stepper
        (``liebody._wheels.WheelStepper``: the motor torques as :attr:`u`, the wheel
        momenta and the saturations); a :class:`~liebody.CoupledBodies` system the
        coupled one (``liebody.coupled.CoupledStepper``: the state of all bodies)."""
        if cls is Stepper and getattr(scene, "moving_rotor", False):
            cls = scene._stepper_class()
        if cls is Stepper and not isinstance(scene, Scene) and scene is not None:
            from liebody.coupled import CoupledBodies, CoupledStepper

            if isinstance(scene, CoupledBodies):  # (not a Stepper: __init__ is not re-run)
                return CoupledStepper(scene, *args, **kwargs)
        return super().__new__(cls)

    def __init__(self, scene, *, q0=(1.0, 0.0, 0.0, 0.0), L0=None, omega0=None, dt,
                 method=None, controls=None, threads: int | None = None,
                 simd: bool | None = None, t0: float = 0.0) -> None:
        from liebody._ensemble import resolve_threads
        from liebody._integrate import (
            _bodies,
            _check_batch,
            _check_torque,
            _first_row,
            _initial_momentum,
            as_controls,
        )

        if not isinstance(scene, Scene):
            raise TypeError(f"scene must be a liebody scene (a subclass of liebody.Scene), "
                            f"got {type(scene).__name__}")
        if simd is not None and not isinstance(simd, bool | np.bool_):
            raise TypeError(f"simd must be True, False or None, got {type(simd).__name__}")
        q = _as_unit_q("q0", q0)
        _check_batch("q0", q)
        m = _initial_momentum(scene, L0, omega0)
        self._dt = as_positive_float("dt", dt)
        t0 = 0.0 if t0.__class__ is float and t0 == 0.0 else clock_origin("t0", t0, self._dt)
        self._threads = resolve_threads(threads)
        self._simd = None if simd is None else bool(simd)
        n = _bodies(scene, q, m)
        self._method = _methods.get(scene.default_method if method is None else method)
        _methods.check_supports(self._method, scene)
        self._scene = scene
        self._model = scene.torque_model()
        self._n = n
        self._u = as_controls(scene, controls, n)
        if n is not None and self._u is not None:  # one row per body
            self._u = np.array(np.broadcast_to(self._u, (n, self._u.shape[-1])))
        # integrate()'s rules: an orientation_only promise is checked, and in an ensemble a
        # torque that fails at one body's start fails that body only
        promise = (self._model.function is not None
                   and "momentum" not in scene.capabilities.torque)
        if n is None:
            _check_torque(self._model, q, m, self._u, t0, orientation_only=promise)
            self._state = np.concatenate([q, m])
        else:
            self._state = np.empty((n, 7))
            self._state[:, :4], self._state[:, 4:] = q, m
            _check_torque(self._model, self._state[0, :4], self._state[0, 4:],
                          _first_row(self._u), t0, ensemble=True, orientation_only=promise)
        self._status = np.zeros(1 if n is None else n, dtype=np.int64)
        self._t0 = t0  # the clock: t = t0 + k dt, k the steps since t was last set
        self._k = 0.0
        self._steps = 0
        self._ready()
        self._plan()

    def _ready(self) -> None:
        """What a stepper holds besides its state and settings (also after a copy)."""
        self._pool = None
        self._lock = threading.RLock()  # step() and the state, one thread at a time
        self._size = max(1, _FIRST_WORK // (self._n or 1))  # the next slice, in steps
        self._last_slice = None  # the last slice's (steps, seconds): engine.next_slice

    # ------------------------------------------------------------------ set-up
    def _plan(self, momentum: np.ndarray | None = None) -> None:
        """Plan the method for the current state (or for ``momentum``: the one an
        earlier plan was made for) and build the kernel's arguments."""
        from liebody._integrate import write_controls

        self._stale = False
        self._fast = False
        if self._method.sampled:  # (an ensemble's: no SIMD kernel, as integrate() says)
            self.info: dict = {} if self._n is None else {"simd": False}
            self._reach = (0.0, 1.0)
            self._plan_m = None
            return
        from liebody._kernels.driver import RUNNERS

        m = self._state[..., 4:] if momentum is None else momentum
        self._plan_m = np.array(m, dtype=np.float64)  # a copy: what the plan was made for
        if self._n is None:
            plan = self._method.plan(self._scene, self._plan_m, self._dt)
            params = plan.params[0].copy()
            if self._u is not None:
                write_controls(params, self._u)
            self.info = dict(plan.info)  # its own (the plan is cached and shared)
            self._reach = plan.reach  # (a failure's report looks where the stages read)
            self._pu = params[:, S.P_U0:S.P_U0 + max(1, self._scene.controls)]
            self._ctl = np.zeros(2, dtype=np.int64)
            args = list(one_body_args(plan, params, bool(plan.merge_ends), self._dt, self._t0,
                                      0.0, 0, 1, True, self._state, self._ctl,
                                      np.empty((1, 4)), np.empty((1, 3)), self._model.address,
                                      np.zeros(S.DREF_WIDTH), np.zeros(3)))
            # (the clock and the slice go between, per call; ``final`` leads the tail)
            self._head, self._tail = tuple(args[:T0]), tuple(args[FINAL:])
            runner = RUNNERS[plan.family]
            self._ctl[:] = (1, 0)
            runner(*args)  # compiles on first use; no step
            self._call = _entry_point(runner, args)
            # one step: save_every = 1 leaves ctl at (1, 0), as the next step needs it
            args[N_STEPS] = 1
            self._args = args
            self._fast = True
            return
        groups = self._method.plans(self._scene, self._plan_m, self._dt)
        runners = [self._runner(plan) for _, plan in groups]
        self.info = groups_info(groups, runners)
        self._groups = []
        for (idx, plan), (runner, simd) in zip(groups, runners, strict=True):
            # a row per body where controls may be set per body, else as the plan stores
            # them (one row when every body shares them)
            rows = (len(idx) if self._scene.controls or getattr(self._scene, "moving_rotor",
                                                                   False)
                    else plan.params.shape[0])
            params = np.array(np.broadcast_to(plan.params, (rows, *plan.params.shape[1:])))
            if self._u is not None:
                write_controls(params, self._u if self._u.ndim == 1 else self._u[idx])
            self._groups.append(self._group(idx, plan, params, runner, simd))
        self._work = [self._chunk(g, c) for g in self._groups for c in self._chunks(len(g["idx"]))]

    def _chunk(self, g: dict, c: slice) -> dict:
        """The driver's arguments for the bodies ``c`` of group ``g``, but for the clock
        and the slice (``t0, step0, n_steps, save_every, final``): views, built once."""
        args = batch_args(g["plan"], g["params"], g["merge"], self._dt, self._t0, 0.0, 0, 1,
                          False, g["state"][c], g["ctl"][c], g["q"][c], g["m"][c],
                          g["saved"][c], g["done"][c], g["status"][c],
                          self._model.driver_address(g["simd"]), c, g["dref"][c],
                          g["dmax"][c])
        return {"g": g, "c": c, "fn": g["runner"], "resolved": False,
                "head": args[:T0], "tail": args[FINAL + 1:]}

    def _group(self, idx, plan, params, runner, simd: bool) -> dict:
        """The arrays of a group of bodies that share a plan: views of the stepper's
        own when the group is every body."""
        g = len(idx)
        whole = g == self._n
        state = self._state if whole else np.ascontiguousarray(self._state[idx])
        return {"idx": idx, "whole": whole, "params": params, "state": state,
                "pu": params[:, :, S.P_U0:S.P_U0 + max(1, self._scene.controls)],
                "plan": plan, "runner": runner, "simd": simd,
                "merge": bool(plan.merge_ends),
                "ctl": np.zeros((g, 2), dtype=np.int64), "q": np.empty((g, 2, 4)),
                "m": np.empty((g, 2, 3)), "saved": np.zeros(g, dtype=np.int64),
                "done": np.zeros(g, dtype=np.int64),
                "status": self._status[idx].copy(),
                "dref": np.zeros((g, S.DREF_WIDTH)), "dmax": np.zeros((g, 3))}

    def _runner(self, plan):
        """The batch driver of a group's plan and whether it is the SIMD one: the rule
        of :func:`liebody.integrate` (:func:`~liebody._engine.batch_runner`), so that a
        stepper runs the kernel ``integrate()`` runs."""
        return batch_runner(plan, self._model.code, self._n, self._simd)

    # ------------------------------------------------------------------ stepping
    def step(self, n: int = 1) -> None:
        """Advance the state by ``n`` steps (``n >= 1``) in place, with the controls
        :attr:`u` held over them.

        Raises the errors of :func:`liebody.integrate` for one body (the stepper is then
        as before the call); marks failing bodies of an ensemble (:attr:`failed`). On
        Ctrl-C raises :class:`~liebody.errors.IntegrationInterrupted` with the steps
        done kept (``exc.step`` of them: the stepper is as ``step(exc.step)`` leaves
        it).
        """
        lock = self._lock
        lock.acquire()
        try:
            if n.__class__ is int and n == 1 and self._fast:  # the control loop
                args, ctl = self._args, self._ctl
                args[STEP0] = self._k
                ctl[0] = 2  # a good step leaves 1 (save_every): tells whether it ran
                try:
                    status = self._call(*args)[2]
                except KeyboardInterrupt:  # raised as the call returned: it has run
                    self._fast_interrupted()
                if status != S.STATUS_OK:  # the kernel has restored the state before it
                    self._raise(status, 0, self._state.copy())
                self._steps += 1
                self._k += 1.0
                return
            n = as_positive_int("n", n)
            if self._stale:
                self._plan()
            if self._method.sampled:
                self._exact(n)
            elif self._n is None:
                self._one(n)
            else:
                self._advance(n)
        finally:
            lock.release()

    def _fast_interrupted(self):
        """Ctrl-C during (or just after) a one-step call: keep the step if it was taken
        (``ctl[0]`` is back at 1 after a good step, still 2 otherwise)."""
        ran = self._ctl[0] == 1
        self._ctl[0] = 1
        if ran:
            self._steps += 1
            self._k += 1.0
        raise IntegrationInterrupted(
            f"Stepper.step(1) interrupted after {int(ran)} of 1 steps; the stepper is left "
            f"after it (t = {self.t:.6g}, steps = {self._steps:,})", None, int(ran),
            self.t) from None

    def _one(self, n: int) -> None:
        """One body: the compiled driver on the state, in slices of about
        :data:`~liebody._engine.SLICE_SECONDS` that carry the driver's control across (so the slices
        change no bit of the result).

        The countdown to the next save starts at ``n + 1``, which no step reaches (the
        last step saves because it is ``final``, as it would at ``n``: the same numbers),
        and a save resets it to ``n + 2``: so ``ctl[0]`` tells how far the call got
        whenever Ctrl-C comes, even as a kernel call returns.
        """
        ctl, state = self._ctl, self._state
        head, tail = self._head, self._tail[1:]  # (final) goes between
        steps0, k0 = self._steps, self._k
        start = state.copy()
        ctl[0], ctl[1] = n + 1, 0
        # the slice in flight: its first step, its length and the state it starts from
        # (the call's start for the first slice: a copy only where there are several)
        flight = [0, 0, start]
        try:
            done, size = 0, self._size
            while done < n:
                k = min(size, n - done)
                if done:
                    if flight[2] is start:
                        flight[2] = state.copy()
                    else:
                        flight[2][:] = state
                flight[0], flight[1] = done, k
                t = time.perf_counter()
                d, _, status = self._call(*head, self._t0, k0 + done, k, n + 2, done + k == n,
                                          *tail)
                if status != S.STATUS_OK:
                    break
                size, self._last_slice = next_slice(k, time.perf_counter() - t, size,
                                                    self._last_slice)
                self._size = size
                done += k
            else:
                ctl[0], ctl[1] = 1, 0  # as the next one-step call needs it
                self._steps, self._k = steps0 + n, k0 + n
                return
        except KeyboardInterrupt:
            self._one_interrupted(n, steps0, k0, start, flight)
        bad = state.copy()  # a step failed: back to the start, and its error
        state[:] = start
        ctl[0], ctl[1] = 1, 0
        self._raise(status, done + d, bad)

    def _one_interrupted(self, n: int, steps0: int, k0: float, start: np.ndarray,
                         flight: list):
        """Ctrl-C during ``_one``: keep the steps done (read from ``ctl[0]``), complete
        a step whose last stage was merged with the next one's first, raise."""
        ctl, state = self._ctl, self._state
        head, tail = self._head, self._tail[1:]
        m = pending = None
        completed = False
        while True:  # a second Ctrl-C runs this again (every part can be repeated)
            try:
                if m is None:
                    s, k, before = flight
                    if ctl[0] == n + 2:
                        m = n
                    elif k > 0 and ctl[0] == n + 1 - (s + k):
                        m = s + k
                    elif ctl[0] == n + 1 - s and np.array_equal(state, before):
                        # the slice did not run (or failed and left the state it started
                        # from, whose step the completion below runs again): s steps
                        m = s
                    else:  # the slice failed after some steps: its outcome is unknown
                        state[:] = start
                        ctl[1] = 0
                        m = 0
                if pending is None:
                    pending = 0 < m < n and ctl[1] != 0
                if pending and not completed:
                    # mid-step: the last stage of step m ran the first of step m + 1;
                    # one more step, saved (so unmerged), ends on the state of m + 1
                    # steps, and its save sets ctl[0] to n + 3. A failed step leaves
                    # the state it started from: trying again is the same step
                    if ctl[0] != n + 3:
                        status = self._call(*head, self._t0, k0 + m, 1, n + 3, True,
                                            *tail)[2]
                        if status != S.STATUS_OK:  # back to the start of the call
                            state[:] = start
                            m, pending = 0, False
                    if pending and ctl[0] == n + 3:
                        m, completed = m + 1, True
                ctl[0], ctl[1] = 1, 0
                self._steps, self._k = steps0 + m, k0 + m
                break
            except KeyboardInterrupt:
                continue
        raise self._interruption(n, m) from None

    def _interruption(self, n: int, m: int) -> IntegrationInterrupted:
        """The error of a ``step(n)`` call that Ctrl-C stopped after ``m`` of its steps,
        the stepper left as ``step(m)`` would have left it."""
        return IntegrationInterrupted(
            f"Stepper.step({n:,}) interrupted after {m:,} of {n:,} steps; the stepper is "
            f"left after them, as step({m:,}) would have left it (t = {self.t:.6g}, steps "
            f"= {self._steps:,})", None, m, self.t)

    def _raise(self, status: int, done: int, state: np.ndarray):
        """The error of a failed step, after ``done`` good steps of this call from the
        stepper's state (``state``: the last good state): :func:`failure_error`'s, or
        for a blow-up an :class:`IntegrationError`."""
        name, dt = self._method.name, self._dt
        failure = StepFailure(None, status, done,
                              *failed_step_times(self._t0, self._k + done, dt), state)
        where = (failed_step_words(done, failure.t, failure.failed_at, " of this call")
                 + "; the stepper is left as it was before the call")
        error = failure_error(name, self._scene, self._model, failure, dt, where, None,
                              self._u, self._reach)
        if error is None:
            error = IntegrationError(f"{name}: the state became non-finite {where}", None,
                                     done, failure.t)
        raise error

    def _advance(self, n: int, keep: np.ndarray | None = None, carry: bool = False) -> None:
        """``n`` steps of the batch driver of each group (for one body, the one body),
        chunks of bodies over threads, in slices of about :data:`~liebody._engine.SLICE_SECONDS`.

        Every body's last step is unmerged (``final``), but for the bodies ``keep`` (a
        mask over the bodies): their last stage runs the next step's first, which the
        next call, made with ``carry``, continues from (the driver's ``ctl`` of each body
        holds it; without ``carry`` a call starts every body on a full step). Ctrl-C
        completes a merged step of the call's middle for every body, not one left at the
        call's end by ``keep``: the caller completes that (``WheelStepper``)."""
        work = self._work
        call = {"n": n, "steps0": self._steps, "k0": self._k, "issued": [],
                "starts": [g["state"].copy() for g in self._groups],
                "before": [g["status"].copy() for g in self._groups],
                "d0": [g["done"].copy() for g in self._groups], "pool": None,
                "last": keep is None}
        for g in self._groups:
            ctl = g["ctl"]
            ctl[:, 0] = n  # save once, after the n-th step
            if keep is not None:  # never: the call ends mid-step (merged), unsaved
                ctl[keep[g["idx"]], 0] = n + 1
            if not carry:
                ctl[:, 1] = 0
            g["saved"][:] = 0
        if len(work) > 1:
            call["pool"] = self._thread_pool()
        interrupted = False
        try:
            done, size = 0, self._size
            while done < n:
                k = min(size, n - done)
                # (with keep, the countdown ends the other bodies unmerged at the n-th step)
                final = done + k == n and call["last"]
                call["issued"].append((done, k, final))
                start = time.perf_counter()
                self._slice(call, done, k, final)
                # (a call's last slice may be short: it measures, it does not cap)
                size, self._last_slice = next_slice(k, time.perf_counter() - start, size,
                                                    self._last_slice)
                self._size = size
                done += k
        except KeyboardInterrupt:
            interrupted = True
        while True:  # bring every chunk to one step count and take stock, Ctrl-C or not
            try:
                m = self._settle(call) if interrupted else n
                error = self._finish(call, m, interrupted)
                break
            except KeyboardInterrupt:
                interrupted = True
        if error is not None:
            raise error

    def _slice(self, call: dict, s: int, k: int, final: bool) -> None:
        """Steps ``s .. s + k`` of the call on every chunk (over the pool, if any)."""
        pool = call["pool"]
        if pool is None:
            for w in self._work:
                self._run(call, w, s, k, final)
            return
        futures = [pool.submit(self._run, call, w, s, k, final) for w in self._work]
        for f in futures:
            f.result()

    def _run(self, call: dict, w: dict, s: int, k: int, final: bool) -> None:
        """Steps ``s .. s + k`` of the call on the chunk ``w``."""
        args = (*w["head"], self._t0, call["k0"] + s, k, call["n"], final, *w["tail"])
        w["fn"](*args)
        if not w["resolved"]:  # compiled now: call its entry point from now on
            w["fn"], w["resolved"] = _entry_point(w["g"]["runner"], args), True

    def _settle(self, call: dict) -> int:
        """After Ctrl-C: join the threads, bring every chunk to the same step count ``m``
        of the call (the kernels' counters tell each chunk's), complete a step whose
        last stage was merged with the next one's first, and return ``m``. Safe to run
        again if a second Ctrl-C cuts it short."""
        if call["pool"] is not None:
            _join(call["pool"])
            if self._pool is call["pool"]:
                self._pool = None  # shut down: a new one next time
            call["pool"] = None
        ok = S.STATUS_OK

        def progress(gi, g, c):
            alive = g["status"][c] == ok
            if not alive.any():
                return None  # every body failed (they go back to the call's start)
            return int(np.max((g["done"][c] - call["d0"][gi][c])[alive]))

        index = {id(g): gi for gi, g in enumerate(self._groups)}
        where = [progress(index[id(w["g"])], w["g"], w["c"]) for w in self._work]
        m = max((p for p in where if p is not None), default=0)
        for w, p in zip(self._work, where, strict=True):
            for s, k, final in call["issued"]:  # the slices this chunk missed
                if p is not None and p <= s < m:
                    self._run(call, w, s, k, final)
        n = call["n"]
        if m < n and any(bool(np.any(g["ctl"][:, 1][g["status"] == ok]))
                         for g in self._groups):
            # mid-step: the last stage of step m ran the first of step m + 1; one more
            # step, saved (so unmerged), ends on the state of m + 1 steps
            call["issued"] = [e for e in call["issued"] if e[0] < m] + [(m, 1, True)]
            for w in self._work:
                self._run(call, w, m, 1, True)
            m += 1
        return m

    def _finish(self, call: dict, m: int, interrupted: bool):
        """Take stock of a call after ``m`` of its steps: failed bodies back to their
        state before the call, the state and the clock advanced by ``m`` steps; the
        exception to raise (``None`` if none). Idempotent (a second Ctrl-C may run it
        again)."""
        n = call["n"]
        if "outcome" not in call:  # (count_nonzero: the cheap test of the usual case)
            call["outcome"] = [None if not np.count_nonzero(g["status"]) else
                               (g["status"] != S.STATUS_OK) & (b == S.STATUS_OK)
                               for g, b in zip(self._groups, call["before"], strict=True)]
            if self._n is None and call["outcome"][0] is not None:  # one body failed
                g = self._groups[0]
                call["failure"] = (int(g["status"][0]),
                                   int(g["done"][0] - call["d0"][0][0]), g["state"][0].copy())
        if self._n is None and "failure" in call:
            g = self._groups[0]
            g["state"][:] = call["starts"][0]
            g["status"][:] = S.STATUS_OK
            status, done, bad = call["failure"]
            try:
                self._raise(status, done, bad)
            except Exception as exc:  # the error of the failure (numerical or a torque's)
                return exc
        new = []
        for gi, (g, s, fresh) in enumerate(zip(self._groups, call["starts"], call["outcome"],
                                               strict=True)):
            if fresh is not None and fresh.any():
                if "words" not in call:  # (the first failed body's, before its reset)
                    row = int(np.flatnonzero(fresh)[0])
                    call["words"] = self._failure_words(g, row, call["d0"][gi][row],
                                                        call["k0"])
                g["state"][fresh] = s[fresh]
                new.extend(g["idx"][fresh].tolist())
            if self._n is not None:
                if not g["whole"]:
                    self._state[g["idx"]] = g["state"]
                self._status[g["idx"]] = g["status"]
        self._steps = call["steps0"] + m
        self._k = call["k0"] + m
        if new and not call.get("warned"):
            call["warned"] = True
            warnings.warn(
                f"{self._method.name}: {len(new)} of {self._n} bodies failed in this "
                f"step({n}) call (e.g. body {new[0]}: {call['words']}); they are left at "
                f"their state before the call and skipped from now on (Stepper.failed)",
                RuntimeWarning, stacklevel=4)
        if not interrupted:
            return None
        return self._interruption(n, m)

    def _failure_words(self, g: dict, row: int, d0: int, k0: float) -> str:
        """Why the body of row ``row`` of group ``g`` failed, for the warning: its reason,
        and for a torque that failed the torque's own words, asked at the body's last
        good state (its row of ``g["state"]``) and its failing step's times."""
        from liebody._engine import REASONS, torque_failure_words

        status = int(g["status"][row])
        reason = REASONS.get(status, "failed")
        if status != S.STATUS_TORQUE:
            return reason
        i = int(g["idx"][row])
        t_start = failed_step_times(self._t0, k0 + int(g["done"][row] - d0), self._dt)[0]
        u = None if self._u is None else (self._u if self._u.ndim == 1 else self._u[i])
        return f"{reason}: " + torque_failure_words(
            self._model, g["state"][row].copy(), t_start, self._dt, u, i, g["plan"].reach)

    def _chunks(self, n: int) -> list[slice]:
        return body_chunks(n, self._threads)

    def _thread_pool(self):
        if self._pool is None:
            import weakref
            from concurrent.futures import ThreadPoolExecutor

            self._pool = ThreadPoolExecutor(max_workers=self._threads)
            weakref.finalize(self, self._pool.shutdown, wait=False)
        return self._pool

    def _exact(self, n: int) -> None:
        """The exact flow: the state advanced by ``n dt`` in closed form (one compiled
        call; Ctrl-C during it leaves the stepper as before the call)."""
        from liebody._kernels.exact import exact_flow_bodies, exact_flow_times

        tau = np.array([n * self._dt])
        try:
            if self._n is None:
                q, m = np.empty((1, 4)), np.empty((1, 3))
                moments = np.ascontiguousarray(self._scene.moments, dtype=np.float64)
                exact_flow_times(moments, self._state[:4].copy(), self._state[4:].copy(),
                                 tau, q, m)
                if not (np.isfinite(q).all() and np.isfinite(m).all()):
                    raise IntegrationError(f"exact: the state became non-finite (t = "
                                           f"{self.t:.6g}); the stepper is left as it was "
                                           f"before the call", None, 0, self.t)
                q, m = q[0], m[0]
                ok = fresh = slice(0, 0)
            else:
                moments = np.ascontiguousarray(np.broadcast_to(self._scene.moments,
                                                               (self._n, 3)))
                q, m = np.empty((self._n, 1, 4)), np.empty((self._n, 1, 3))
                st = np.where(self._status != 0, -1, 0).astype(np.int64)
                exact_flow_bodies(moments, np.ascontiguousarray(self._state[:, :4]),
                                  np.ascontiguousarray(self._state[:, 4:]), tau, q, m, st)
                ok, fresh = st == 0, st > 0
                q, m = q[ok, 0], m[ok, 0]
                bad = int(fresh.sum())
        except KeyboardInterrupt:
            raise IntegrationInterrupted(
                f"Stepper.step({n:,}) interrupted after 0 of {n:,} steps; the stepper is "
                f"left as it was before the call", None, 0, self.t) from None
        # the state and the clock together (no call in between: Ctrl-C waits for both)
        if self._n is None:
            self._state[:4] = q
            self._state[4:] = m
        else:
            self._state[ok, :4] = q
            self._state[ok, 4:] = m
            self._status[fresh] = S.STATUS_NONFINITE
        self._steps += n
        self._k += n
        if self._n is not None and bad:
            warnings.warn(f"exact: {bad} of {self._n} bodies became non-finite; "
                          f"they are left at their state before the call (Stepper.failed)",
                          RuntimeWarning, stacklevel=4)

    # ------------------------------------------------------------------ the state
    @property
    def scene(self):
        """The scene being integrated."""
        return self._scene

    @property
    def method(self) -> _methods.Method:
        """The method (a :class:`~liebody.Method`)."""
        return self._method

    @property
    def dt(self) -> float:
        """The step."""
        return self._dt

    @property
    def n_bodies(self) -> int | None:
        """The number of bodies of an ensemble, ``None`` for one body."""
        return self._n

    @property
    def steps(self) -> int:
        """Steps taken since the stepper was made."""
        with self._lock:
            return self._steps

    @property
    def simd(self) -> bool | None:
        """The ``simd`` setting (``info["simd"]`` says whether the SIMD kernels run)."""
        return self._simd

    @property
    def t(self) -> float:
        """The time, ``k dt`` after ``k`` steps from 0; settable (the clock the torque sees
        continues from there)."""
        with self._lock:
            return self._t0 + self._k * self._dt

    @t.setter
    def t(self, value) -> None:
        t0 = clock_origin("t", value, self._dt)
        with self._lock:
            self._t0 = t0
            self._k = 0.0
            if self._fast:
                self._args[T0] = self._t0

    def replan(self) -> None:
        """Plan the method again for the current state (the axis ordering of the
        splittings, the modified moments of preprocessed DMV are chosen for the orbit of
        the state): worthwhile when a controller has moved the body to a very different
        orbit. Setting :attr:`L` does it too."""
        with self._lock:
            self._stale, self._fast = True, False

    @property
    def q(self) -> np.ndarray:
        """Orientation, scalar-first unit quaternion (body -> space): ``(4,)``, or
        ``(N, 4)`` for an ensemble (a copy; set it to change the state)."""
        return self._view(slice(0, 4))

    @q.setter
    def q(self, value) -> None:
        q = _as_unit_q("q", value)
        with self._lock:
            self._set(slice(0, 4), q, "q")

    @property
    def L(self) -> np.ndarray:
        """Body angular momentum ``(3,)`` or ``(N, 3)`` (a copy; settable, which re-plans
        the method at the next step)."""
        return self._view(slice(4, 7))

    @L.setter
    def L(self, value) -> None:
        from liebody._integrate import _initial_momentum

        m = _initial_momentum(self._scene, value, None, names=("L", "omega"))
        with self._lock:
            self._set(slice(4, 7), m, "L")
            self._stale, self._fast = True, False

    @property
    def omega(self) -> np.ndarray:
        """Body angular velocity ``L / I`` (a gyrostat's ``(L - l) / I``; settable like
        :attr:`L`)."""
        l = getattr(self._scene, "rotor_momentum", None)
        L = self.L if l is None else self.L - np.asarray(l, dtype=float)
        return L / np.asarray(self._scene.moments)

    @omega.setter
    def omega(self, value) -> None:
        from liebody._integrate import _initial_momentum

        m = _initial_momentum(self._scene, None, value, names=("L", "omega"))
        with self._lock:
            self._set(slice(4, 7), m, "omega")
            self._stale, self._fast = True, False

    @property
    def state(self) -> tuple[np.ndarray, np.ndarray]:
        """``(q, L)`` (copies, of one state: read under the lock, so that a step on
        another thread cannot come between them); set both at once with
        ``stepper.state = (q, L)``."""
        with self._lock:
            return self.q, self.L

    @state.setter
    def state(self, value) -> None:
        from liebody._integrate import _initial_momentum

        try:
            q, L = value
        except (TypeError, ValueError):
            raise ValueError("state must be a pair (q, L)") from None
        q = self._fit(_as_unit_q("q", q), "q")  # both checked before either is set
        m = self._fit(_initial_momentum(self._scene, L, None, names=("L", "omega")), "L")
        with self._lock:
            self._set(slice(0, 4), q, "q")
            self._set(slice(4, 7), m, "L")
            self._stale, self._fast = True, False

    @property
    def u(self) -> np.ndarray | None:
        """Control inputs of a :class:`~liebody.ControlledBody` (``(k,)``, or ``(N, k)``
        one row per body), held over the following steps; ``None`` for other scenes."""
        with self._lock:
            return None if self._u is None else self._u.copy()

    @u.setter
    def u(self, value) -> None:
        if self._u is None:
            raise ValueError(f"u: the scene {type(self._scene).__name__} takes no control "
                             f"inputs (use a liebody.ControlledBody)")
        if value is None:
            raise TypeError("u must be the control inputs (an array of numbers), got None")
        try:
            u = np.array(value)  # (a copy, of the value's own type: strings stay strings)
        except (TypeError, ValueError):
            u = None
        if u is not None and u.dtype is not _FLOAT64:
            u = u.astype(np.float64) if u.dtype.kind in "biuf" else None
        if u is None or u.shape != self._u.shape or not (
                all(map(math.isfinite, u.tolist())) if u.ndim == 1
                else bool(np.isfinite(u).all())):
            from liebody._integrate import as_controls

            u = as_controls(self._scene, value, self._n, name="u")  # raises, naming the rule
            u = np.array(np.broadcast_to(u, self._u.shape))
        with self._lock:
            self._u = u
            if self._method.sampled:
                return
            if self._n is None:
                self._pu[...] = u  # (the one-body group shares these parameters)
            else:
                for g in self._groups:
                    g["pu"][...] = (u if u.ndim == 1 else
                                    (u if g["whole"] else u[g["idx"]])[:, None, :])

    @property
    def failed(self) -> np.ndarray | bool:
        """Which bodies of an ensemble failed (skipped by later steps); for one body,
        always ``False`` (a failing step raises)."""
        if self._n is None:
            return False
        with self._lock:
            return self._status != S.STATUS_OK

    def _view(self, sl: slice) -> np.ndarray:
        with self._lock:
            if self._n is None:
                return self._state[sl].copy()
            self._gather()
            return self._state[:, sl].copy()

    def _gather(self) -> None:
        if self._n is not None and not self._method.sampled:
            for g in self._groups:
                if not g["whole"]:
                    self._state[g["idx"]] = g["state"]

    def _fit(self, value: np.ndarray, name: str) -> np.ndarray:
        """``value`` shaped for the stepper's bodies, or a ValueError naming ``name``."""
        if self._n is None:
            if value.ndim != 1:
                raise ValueError(f"{name} must be one state for a one-body stepper, got shape "
                                 f"{value.shape}")
            return value
        try:
            return np.broadcast_to(value, (self._n, value.shape[-1]))
        except ValueError:
            raise ValueError(f"{name} of shape {value.shape} does not fit {self._n} bodies") \
                from None

    def _set(self, sl: slice, value: np.ndarray, name: str) -> None:
        value = self._fit(value, name)
        if self._n is None:
            self._state[sl] = value
            return
        self._gather()
        self._state[:, sl] = value
        self._status[:] = S.STATUS_OK
        if not self._method.sampled:
            for g in self._groups:
                g["status"][:] = S.STATUS_OK
                if not g["whole"]:
                    g["state"][:] = self._state[g["idx"]]

    # ------------------------------------------------------------------ copies, pickling
    def __getstate__(self) -> dict:
        """The stepper's state, settings and the momentum its plan was made for (copies:
        the plan, the kernel's arguments, the lock and the threads are rebuilt)."""
        with self._lock:
            self._gather()
            return {"scene": self._scene, "method": self._method, "dt": self._dt,
                    "threads": self._threads, "simd": self._simd, "n": self._n,
                    "u": None if self._u is None else self._u.copy(),
                    "state": self._state.copy(), "status": self._status.copy(),
                    "t0": self._t0, "k": self._k, "steps": self._steps,
                    "plan_m": None if self._plan_m is None else self._plan_m.copy(),
                    "stale": self._stale, "size": self._size}

    def __setstate__(self, state: dict) -> None:
        self._scene, self._method, self._dt = state["scene"], state["method"], state["dt"]
        self._threads, self._simd, self._n = state["threads"], state["simd"], state["n"]
        self._model = self._scene.torque_model()
        self._u, self._state, self._status = state["u"], state["state"], state["status"]
        self._t0, self._k, self._steps = state["t0"], state["k"], state["steps"]
        self._ready()
        self._size = state["size"]
        self._last_slice = None
        self._plan(state["plan_m"])  # the plan the original runs (not re-planned)
        if state["stale"]:
            self._stale, self._fast = True, False

    def __copy__(self) -> Stepper:
        """An independent stepper: its own state, clock, controls and failure marks
        (``copy.copy`` shares no array with the original)."""
        new = type(self).__new__(type(self))
        new.__setstate__(self.__getstate__())
        return new

    def __deepcopy__(self, memo) -> Stepper:
        """As :meth:`__copy__` (the scene, immutable, is shared)."""
        return self.__copy__()

    def __repr__(self) -> str:
        who = "" if self._n is None else f", {self._n} bodies"
        return (f"Stepper({type(self._scene).__name__}, method={self._method.name!r}, "
                f"dt={self._dt:g}, t={self.t:g}{who})")
