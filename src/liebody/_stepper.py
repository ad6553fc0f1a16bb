"""``Stepper``: a prepared integrator for control loops and other short, repeated calls.

:func:`liebody.integrate` validates, plans and allocates on every call: right for a
run, too much for a controller that advances the body by one control period at a
time. A :class:`Stepper` does that work once (validation, the method's plan, the
compiled driver and its argument list) and then :meth:`Stepper.step` only calls the
compiled kernel on its state, in place. Between calls the state (``q``, ``L``, the
time ``t``) and the control inputs ``u`` of a :class:`~liebody.ControlledBody` can be
read and set.
"""

from __future__ import annotations

import itertools
import math
import warnings

import numpy as np

from liebody import _methods
from liebody._kernels import stages as S
from liebody._validate import as_float_array, as_positive_float, as_positive_int
from liebody._validate import as_unit_quaternion as _as_unit_q
from liebody.errors import ConvergenceError, IntegrationError, IntegrationInterrupted
from liebody.scenes import Scene

__all__ = ["Stepper"]

#: steps in one kernel call of a long ``step(n)`` (Ctrl-C is seen between calls)
_SLICE = 1 << 16


def _entry_point(runner, args):
    """The compiled entry point of ``runner`` for ``args`` (a plain call skips numba's
    type dispatch: about 0.4 us less per call); the runner itself when numba is off."""
    overloads = getattr(runner, "overloads", None)
    if not overloads:
        return runner
    sig = tuple(runner.typeof_pyval(a) for a in args)
    cres = overloads.get(sig)
    return runner if cres is None else cres.entry_point


class Stepper:
    """Advance a scene step by step, with the state and the controls set between steps.

    Prepared once (validation, the method's plan for this body and step, the compiled
    kernel), then :meth:`step` advances the state in place for the cost of a compiled
    call: about 10 splitting steps on a free body, against about 100 for a one-step
    :func:`liebody.integrate` (``bench/step_cost.py`` measures both).

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

    Notes
    -----
    *Agreement with integrate().* ``k`` calls ``step(n)`` give the states that
    ``integrate(..., steps=k * n, save_every=n)`` saves, bit for bit (in particular
    ``step()`` repeated equals ``save_every=1``), when the state is not set between
    the calls: the kernel, the plan and the clock ``t = (k + j) dt`` are the same.
    With a larger ``save_every`` the splittings merge the last kick of a step with the
    first of the next, and the two agree to round-off. The exact flow advances the
    state by ``n dt`` per call, and agrees with ``integrate()``'s samples (evaluated
    from the initial state) to round-off.

    *Zero-order hold.* The controls ``u`` are held constant over every step of a call:
    set them, then call ``step()``, as a digital controller does each period.

    *Setting the state.* ``q``, ``L`` (or ``omega``) and ``t`` may be set between calls
    (``L`` and ``omega`` re-plan the method at the next step, since some plans are made
    for the orbit of the state, such as the axis ordering of the splittings or the
    modified moments of preprocessed DMV; ``q`` and ``t`` cost nothing).

    *Failures.* For one body, a step that fails (a non-finite state, an implicit
    equation not solved, a torque that fails) raises the error of
    :func:`liebody.integrate` (:class:`~liebody.errors.IntegrationError` for a
    non-finite state) and leaves the stepper as it was before the call: the failed
    call changes nothing, and ``exc.step`` tells how many of its steps succeeded. For
    an ensemble the failing bodies are left at their state before the call, marked in
    :attr:`failed` and skipped by later calls (a ``RuntimeWarning`` says which); the
    others go on. Setting the state clears the marks.

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

    def __init__(self, scene, *, q0=(1.0, 0.0, 0.0, 0.0), L0=None, omega0=None, dt,
                 method=None, controls=None, threads: int | None = None) -> None:
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
        q = _as_unit_q("q0", q0)
        _check_batch("q0", q)
        m = _initial_momentum(scene, L0, omega0)
        self._dt = as_positive_float("dt", dt)
        self._threads = resolve_threads(threads)
        n = _bodies(scene, q, m)
        self._method = _methods.get(scene.default_method if method is None else method)
        _methods.check_supports(self._method, scene)
        self._scene = scene
        self._model = scene.torque_model()
        self._n = n
        self._u = as_controls(scene, controls, n)
        if n is not None and self._u is not None:  # one row per body
            self._u = np.array(np.broadcast_to(self._u, (n, self._u.shape[-1])))
        if n is None:
            _check_torque(self._model, q, m, self._u)
            self._state = np.concatenate([q, m])
        else:
            self._state = np.empty((n, 7))
            self._state[:, :4], self._state[:, 4:] = q, m
            _check_torque(self._model, self._state[0, :4], self._state[0, 4:],
                          _first_row(self._u))
        self._status = np.zeros(1 if n is None else n, dtype=np.int64)
        self._t0 = 0.0  # the clock: t = t0 + k dt, k the steps since t was last set
        self._k = 0.0
        self._steps = 0
        self._pool = None
        self._plan()

    # ------------------------------------------------------------------ set-up
    def _plan(self) -> None:
        """Plan the method for the current state and build the kernel's arguments."""
        from liebody._integrate import write_controls

        self._stale = False
        self._fast = False
        if self._method.sampled:
            self.info: dict = {}
            return
        from liebody._kernels.driver import BATCH_RUNNERS, RUNNERS

        if self._n is None:
            plan = self._method.plan(self._scene, self._state[4:], self._dt)
            params = plan.params[0].copy()
            if self._u is not None:
                write_controls(params, self._u)
            self.info = plan.info
            self._pu = params[:, S.P_U0:S.P_U0 + max(1, self._scene.controls)]
            self._ctl = np.zeros(2, dtype=np.int64)
            self._head = (plan.kinds, plan.axes, plan.coefs, plan.clock, params,
                          bool(plan.merge_ends), self._dt)
            self._tail = (True, self._state, self._ctl, np.empty((1, 4)), np.empty((1, 3)),
                          self._model.address, plan.model[0], np.zeros(10), np.zeros(3))
            runner = RUNNERS[plan.family]
            self._ctl[:] = (1, 0)
            args = [*self._head, self._t0, 0.0, 0, 1, *self._tail]
            runner(*args)  # compiles on first use; no step
            self._call = _entry_point(runner, args)
            # one step: save_every = 1 leaves ctl at (1, 0), as the next step needs it
            args[9] = 1
            self._args = args
            self._fast = True
            return
        groups = self._method.plans(self._scene, self._state[:, 4:], self._dt)
        self.info = (groups[0][1].info if len(groups) == 1
                     else {"groups": [dict(p.info, bodies=idx) for idx, p in groups]})
        self._groups = []
        for idx, plan in groups:
            whole = len(idx) == self._n
            params = plan.params.copy()
            if self._u is not None:
                write_controls(params, self._u if self._u.ndim == 1 else self._u[idx])
            g = len(idx)
            state = self._state if whole else np.ascontiguousarray(self._state[idx])
            self._groups.append({
                "idx": idx, "whole": whole, "params": params, "state": state,
                "pu": params[:, :, S.P_U0:S.P_U0 + max(1, self._scene.controls)],
                "plan": plan, "runner": BATCH_RUNNERS[plan.family],
                "ctl": np.zeros((g, 2), dtype=np.int64), "q": np.empty((g, 1, 4)),
                "m": np.empty((g, 1, 3)), "saved": np.zeros(g, dtype=np.int64),
                "done": np.zeros(g, dtype=np.int64),
                "status": self._status[idx].copy(),
                "dref": np.zeros((g, 10)), "dmax": np.zeros((g, 3))})

    # ------------------------------------------------------------------ stepping
    def step(self, n: int = 1) -> None:
        """Advance the state by ``n`` steps (``n >= 1``) in place, with the controls
        :attr:`u` held over them.

        Raises the errors of :func:`liebody.integrate` for one body (the stepper is then
        as before the call); marks failing bodies of an ensemble (:attr:`failed`).
        """
        if type(n) is int and n == 1 and self._fast:  # the control loop: one compiled call
            args = self._args
            args[8] = self._k
            status = self._call(*args)[2]
            if status != S.STATUS_OK:  # the kernel has restored the state before the step
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
            self._many(n)
        self._steps += n
        self._k += n

    def _one(self, n: int) -> None:
        """One body: the compiled driver on the state, in slices of steps that carry the
        driver's control across (so the slices change no bit of the result)."""
        ctl = self._ctl
        start = self._state.copy()
        done = 0
        head, (_, *tail) = self._head, self._tail
        ctl[0], ctl[1] = n, 0  # save once, after the n-th step
        try:
            while done < n:
                k = min(n - done, _SLICE)
                d, _, status = self._call(*head, self._t0, self._k + done, k, n,
                                          done + k == n, *tail)
                if status != S.STATUS_OK:
                    bad = self._state.copy()
                    self._state[:] = start
                    ctl[0], ctl[1] = 1, 0
                    self._raise(status, done + d, bad)
                done += k
            ctl[0], ctl[1] = 1, 0
        except KeyboardInterrupt:
            self._state[:] = start
            ctl[0], ctl[1] = 1, 0
            raise IntegrationInterrupted(
                f"Stepper.step({n}) interrupted after {done:,} steps; the stepper is left "
                f"as it was before the call", None, done, self._clock(done)) from None

    def _raise(self, status: int, done: int, state: np.ndarray):
        """The error of a failed step, after ``done`` good steps of this call from the
        stepper's state (``state``: the last good state)."""
        from liebody._integrate import raise_torque_error, torque_stiffness

        name, dt = self._method.name, self._dt
        t0 = self._clock(done)
        where = (f"at step {done + 1} of this call (t = {t0:.6g}); the stepper is left as it "
                 f"was before the call")
        if status == S.STATUS_TORQUE or (status == S.STATUS_NONFINITE
                                         and self._model.function is not None):
            from liebody._integrate import _torque_is_finite

            if status == S.STATUS_TORQUE or not _torque_is_finite(
                    self._model, state, (t0, t0 + 0.5 * dt, t0 + dt), self._u):
                raise_torque_error(self._model, name, where, state, t0, dt, None, done,
                                   self._u)
        if status == S.STATUS_NONFINITE:
            raise IntegrationError(f"{name}: the state became non-finite {where}", None, done,
                                   t0)
        if status == S.STATUS_NO_CONVERGENCE:
            w = float(np.max(np.abs(state[4:] / self._scene.moments)))
            raise ConvergenceError(
                f"{name}: the implicit DMV (RATTLE) equation has no solution {where}. "
                f"h |omega| = {dt * w:.3g} there; reduce dt below about {0.7 / w:.3g}",
                None, done, t0)
        if status == S.STATUS_KICK_NO_CONVERGENCE:
            stiff = torque_stiffness(self._model, state, t0, self._u)
            raise ConvergenceError(
                f"{name}: the implicit kick of the momentum-dependent torque did not converge "
                f"{where}. (dt/2) |dN/dL| = {0.5 * dt * stiff:.3g} there; reduce dt",
                None, done, t0)
        raise RuntimeError(f"{name}: status {status} from the driver")  # pragma: no cover

    def _many(self, n: int) -> None:
        """An ensemble: the batch driver of each group, chunks of bodies over threads."""
        chunks = [(g, c) for g in self._groups for c in self._chunks(len(g["idx"]))]
        starts = [g["state"].copy() for g in self._groups]
        before = [g["status"].copy() for g in self._groups]
        pool = self._thread_pool() if len(chunks) > 1 else None
        done = 0
        for g in self._groups:
            g["ctl"][:] = (n, 0)  # save once, after the n-th step
            g["saved"][:] = 0
        try:
            while done < n:
                k = min(n - done, _SLICE)

                def run(gc, k=k, step0=self._k + done, final=done + k == n):
                    g, c = gc
                    g["runner"](g["plan"].kinds, g["plan"].axes, g["plan"].coefs,
                                g["plan"].clock, g["params"][c], g["plan"].merge_ends,
                                self._dt, self._t0, step0, k, n, final, g["state"][c],
                                g["ctl"][c],
                                g["q"][c], g["m"][c], g["saved"][c], g["done"][c],
                                g["status"][c], self._model.address,
                                g["plan"].model_rows(c), g["dref"][c],
                                g["dmax"][c])

                if pool is None:
                    for gc in chunks:
                        run(gc)
                else:
                    for f in [pool.submit(run, gc) for gc in chunks]:
                        f.result()
                done += k
        except KeyboardInterrupt:
            for g, s, b in zip(self._groups, starts, before, strict=True):
                g["state"][:] = s
                g["status"][:] = b
            raise IntegrationInterrupted(
                f"Stepper.step({n}) interrupted after about {done:,} steps; the stepper is "
                f"left as it was before the call", None, done, self._clock(done)) from None
        new = []
        for g, s, b in zip(self._groups, starts, before, strict=True):
            fresh = (g["status"] != S.STATUS_OK) & (b == S.STATUS_OK)
            if fresh.any():
                g["state"][fresh] = s[fresh]
                new.extend(g["idx"][fresh].tolist())
            if not g["whole"]:
                self._state[g["idx"]] = g["state"]
            self._status[g["idx"]] = g["status"]
        if new:
            from liebody._ensemble import REASONS

            first = new[0]
            warnings.warn(
                f"{self._method.name}: {len(new)} of {self._n} bodies failed in this "
                f"step({n}) call (e.g. body {first}: "
                f"{REASONS.get(int(self._status[first]), 'failed')}); they are left at their "
                f"state before the call and skipped from now on (Stepper.failed)",
                RuntimeWarning, stacklevel=3)

    def _chunks(self, n: int) -> list[slice]:
        parts = max(1, min(self._threads, n // 64))
        edges = np.linspace(0, n, parts + 1).round().astype(int)
        return [slice(int(a), int(b)) for a, b in itertools.pairwise(edges) if b > a]

    def _thread_pool(self):
        if self._pool is None:
            import weakref
            from concurrent.futures import ThreadPoolExecutor

            self._pool = ThreadPoolExecutor(max_workers=self._threads)
            weakref.finalize(self, self._pool.shutdown, wait=False)
        return self._pool

    def _exact(self, n: int) -> None:
        """The exact flow: the state advanced by ``n dt`` in closed form."""
        tau = np.array([n * self._dt])
        if self._n is None:
            from liebody._kernels.exact import exact_flow_times

            q, m = np.empty((1, 4)), np.empty((1, 3))
            moments = np.ascontiguousarray(self._scene.moments, dtype=np.float64)
            exact_flow_times(moments, self._state[:4].copy(), self._state[4:].copy(), tau, q,
                             m)
            if not (np.isfinite(q).all() and np.isfinite(m).all()):
                raise IntegrationError(f"exact: the state became non-finite (t = "
                                       f"{self.t:.6g}); the stepper is left as it was before "
                                       f"the call", None, 0, self.t)
            self._state[:4], self._state[4:] = q[0], m[0]
            return
        from liebody._kernels.exact import exact_flow_bodies

        moments = np.ascontiguousarray(np.broadcast_to(self._scene.moments, (self._n, 3)))
        q, m = np.empty((self._n, 1, 4)), np.empty((self._n, 1, 3))
        st = np.where(self._status != 0, -1, 0).astype(np.int64)
        exact_flow_bodies(moments, np.ascontiguousarray(self._state[:, :4]),
                          np.ascontiguousarray(self._state[:, 4:]), tau, q, m, st)
        ok = st == 0
        self._state[ok, :4], self._state[ok, 4:] = q[ok, 0], m[ok, 0]
        fresh = st > 0
        if fresh.any():
            self._status[fresh] = S.STATUS_NONFINITE
            warnings.warn(f"exact: {int(fresh.sum())} of {self._n} bodies became non-finite; "
                          f"they are left at their state before the call (Stepper.failed)",
                          RuntimeWarning, stacklevel=3)

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
        return self._steps

    @property
    def t(self) -> float:
        """The time, ``k dt`` after ``k`` steps from 0; settable (the clock the torque sees
        continues from there)."""
        return self._t0 + self._k * self._dt

    @t.setter
    def t(self, value) -> None:
        self._t0 = float(as_float_array("t", value, shape=()))
        self._k = 0.0
        if self._fast:
            self._args[7] = self._t0

    def _clock(self, done: int) -> float:
        """The time after ``done`` more steps."""
        return self._t0 + (self._k + done) * self._dt

    def replan(self) -> None:
        """Plan the method again for the current state (the axis ordering of the
        splittings, the modified moments of preprocessed DMV are chosen for the orbit of
        the state): worthwhile when a controller has moved the body to a very different
        orbit. Setting :attr:`L` does it too."""
        self._stale, self._fast = True, False

    @property
    def q(self) -> np.ndarray:
        """Orientation, scalar-first unit quaternion (body -> space): ``(4,)``, or
        ``(N, 4)`` for an ensemble (a copy; set it to change the state)."""
        return self._view(slice(0, 4))

    @q.setter
    def q(self, value) -> None:
        q = _as_unit_q("q", value)
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
        self._set(slice(4, 7), m, "L")
        self._stale, self._fast = True, False

    @property
    def omega(self) -> np.ndarray:
        """Body angular velocity ``L / I`` (settable like :attr:`L`)."""
        return self.L / np.asarray(self._scene.moments)

    @omega.setter
    def omega(self, value) -> None:
        from liebody._integrate import _initial_momentum

        m = _initial_momentum(self._scene, None, value, names=("L", "omega"))
        self._set(slice(4, 7), m, "omega")
        self._stale, self._fast = True, False

    @property
    def state(self) -> tuple[np.ndarray, np.ndarray]:
        """``(q, L)`` (copies); set both at once with ``stepper.state = (q, L)``."""
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
        self._set(slice(0, 4), q, "q")
        self._set(slice(4, 7), m, "L")
        self._stale, self._fast = True, False

    @property
    def u(self) -> np.ndarray | None:
        """Control inputs of a :class:`~liebody.ControlledBody` (``(k,)``, or ``(N, k)``
        one row per body), held over the following steps; ``None`` for other scenes."""
        return None if self._u is None else self._u.copy()

    @u.setter
    def u(self, value) -> None:
        if self._u is None:
            raise ValueError(f"u: the scene {type(self._scene).__name__} takes no control "
                             f"inputs (use a liebody.ControlledBody)")
        if value is None:
            raise TypeError("u must be the control inputs (an array of numbers), got None")
        try:
            u = np.array(value, dtype=np.float64)
        except (TypeError, ValueError):
            u = None
        if u is None or u.shape != self._u.shape or not (
                all(map(math.isfinite, u.tolist())) if u.ndim == 1
                else bool(np.isfinite(u).all())):
            from liebody._integrate import as_controls

            u = as_controls(self._scene, value, self._n, name="u")  # raises, naming the rule
            u = np.array(np.broadcast_to(u, self._u.shape))
        self._u = u
        if self._method.sampled:
            return
        if self._n is None:
            self._pu[...] = u
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
        return self._status != S.STATUS_OK

    def _view(self, sl: slice) -> np.ndarray:
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

    def __repr__(self) -> str:
        who = "" if self._n is None else f", {self._n} bodies"
        return (f"Stepper({type(self._scene).__name__}, method={self._method.name!r}, "
                f"dt={self._dt:g}, t={self.t:g}{who})")
