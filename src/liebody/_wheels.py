"""Reaction wheels in the run code: the wheels' momenta as anchored linear pieces, the cuts
where a wheel saturates, ``integrate()`` and the ``Stepper`` of a
:class:`~liebody.ReactionWheels` scene.

The kernels see the wheels as a gyrostat's rotor momentum that is linear in time,
``l(t) = P_L + P_LD (t - P_LT)`` in the stages' rotor slots (``_kernels/stages.py``). Here
the wheels' momenta ``h`` (``(N, k)``) are kept as *anchored* linear functions of the step
count ``m``: ``h(m) = h_a + r ((m - m_a) dt)``, re-anchored only where a body's wheel rates
``r`` change (a new command, a torque clipped, a wheel reaching its speed limit). The
stages then hold ``P_L = A h_a``, ``P_LD = A r`` and ``P_LT = t0 + m_a dt``, the same
numbers whether the steps come from one ``integrate()`` call or from a ``Stepper``'s calls,
one body or an ensemble: the runs agree bit for bit.

:meth:`WheelState.segment` gives the next piece of steps over which every body's rates
are constant and no wheel passes its limit: up to the step in which a wheel would pass
it, then that one step with the rate that brings the wheel exactly onto its limit at the
step's end, then the wheel held there (rate 0) while the command pushes it outward.
"""

from __future__ import annotations

import copy
import math
import warnings
from typing import NamedTuple

import numpy as np

from liebody._kernels import stages as S
from liebody._stepper import Stepper
from liebody._validate import as_float_array

_ROTOR = slice(S.P_L1, S.P_L3 + 1)
_RATE = slice(S.P_LD1, S.P_LD3 + 1)


class Saturation(NamedTuple):
    """A wheel reaching one of its limits, as a record.

    ``body`` (``None`` for a one-body run), ``t`` the time the limit takes effect (the
    start of the step whose commanded torque is clipped; the end of the step at which
    the wheel's momentum reaches ``J_k * max_speed``), ``wheel`` its index and ``limit``
    ``"torque"`` or ``"speed"``. A record marks the start of an episode: the limit stays
    active (the torque clipped, or the wheel held at its speed while the command pushes
    it further) without a new record until it is left.
    """

    body: int | None
    t: float
    wheel: int
    limit: str



def _refuse_sampled(method) -> None:
    if method.sampled:
        raise ValueError(
            f"method {method.name!r} evaluates the rigid body's exact flow at the output times; "
            f"a body with reaction wheels is stepped: use splitting2 (its default), "
            f"splitting4/6/8, no_squish or a baseline (euler, rk4, lie_euler, rkmk4)")


def wheel_controls(scene, controls, n_bodies: int | None, name: str = "controls"
                   ) -> np.ndarray:
    """The wheels' motor torques ``u``: ``(k,)`` or one row per body ``(N, k)`` (zeros when
    not given), as an ``(N or 1, k)`` array."""
    k = scene.n_wheels
    if controls is None:
        return np.zeros((1 if n_bodies is None else n_bodies, k))
    u = np.array(as_float_array(name, controls), dtype=float)
    if u.ndim == 0 or u.shape[-1] != k or u.ndim > 2:
        raise ValueError(f"{name}: the motor torques of the {k} wheels, shape ({k},) or one "
                         f"row per body (N, {k}); got shape {u.shape}")
    if u.ndim == 2:
        if n_bodies is None or u.shape[0] != n_bodies:
            told = "one body" if n_bodies is None else f"{n_bodies} bodies"
            raise ValueError(f"{name} of shape {u.shape} give one row per body for "
                             f"{u.shape[0]} bodies, but the run has {told}")
        return u
    return np.broadcast_to(u, (1 if n_bodies is None else n_bodies, k)).copy()


def rotor(axes: np.ndarray, h: np.ndarray) -> np.ndarray:
    """``A h`` for rows ``h`` ``(N, k)``, summed in wheel order (the same rounding for a body
    alone and in an ensemble)."""
    out = h[:, 0, None] * axes[0]
    for j in range(1, axes.shape[0]):
        out = out + h[:, j, None] * axes[j]
    return out


class WheelState:
    """The wheels of ``n`` bodies: anchored linear momenta, rates, limits and records."""

    def __init__(self, scene, n: int, dt: float, t0: float = 0.0):
        k = scene.n_wheels
        self.axes = scene.axes
        self.dt = dt
        self.t0 = t0  # the clock: step m is at t0 + m dt
        self.lim = np.ascontiguousarray(np.broadcast_to(scene.momentum_limit, (n, k)),
                                        dtype=float)
        self.tmax = (np.full(k, math.inf) if scene.max_torque is None
                     else np.asarray(scene.max_torque, dtype=float))
        self.h_a = np.array(np.broadcast_to(scene.momentum, (n, k)), dtype=float)
        self.m_a = np.zeros(n)
        self.rate = np.zeros((n, k))
        self.landing = np.zeros((n, k), dtype=bool)  # reach the limit after step m_a + 1
        self.land_value = np.zeros((n, k))
        self.at_speed = np.zeros((n, k), dtype=bool)
        self.at_torque = np.zeros((n, k), dtype=bool)
        self.events: list[tuple[int, float, int, str]] = []  # (body, t, wheel, limit)
        #: (m_a, h_a, rate) of every anchor, per body (the samples' momenta)
        self.history: list[list] = [[(0.0, self.h_a[i].copy(), self.rate[i].copy())]
                                    for i in range(n)]
        self.moved = False  # whether any rate was ever nonzero

    def copy(self) -> WheelState:
        out = copy.copy(self)
        for name in ("h_a", "m_a", "rate", "landing", "land_value", "at_speed", "at_torque"):
            setattr(out, name, getattr(self, name).copy())
        out.events = list(self.events)
        out.history = [list(h) for h in self.history]
        return out

    def now(self, m: float) -> np.ndarray:
        """The momenta ``(n, k)`` after step count ``m`` (at or after every anchor)."""
        h = self.h_a + self.rate * ((m - self.m_a)[:, None] * self.dt)
        land = self.landing & ((m - self.m_a) >= 1.0)[:, None]
        return np.where(land, self.land_value, h)

    def set(self, h: np.ndarray, m: float) -> None:
        """Set the momenta ``(n, k)`` at step count ``m`` (re-anchors every body)."""
        self._anchor(np.ones(self.h_a.shape[0], dtype=bool), h, m, self.rate)
        self.landing[:] = False
        self.at_speed[:] = False

    def rebase(self, m: float, t0: float) -> None:
        """The clock was set: step count ``m`` becomes step 0 at time ``t0``."""
        h = self.now(m)
        self.t0 = t0
        self._anchor(np.ones(self.h_a.shape[0], dtype=bool), h, 0.0, self.rate)
        self.landing[:] = False

    def _anchor(self, which: np.ndarray, h: np.ndarray, m: float, rate: np.ndarray) -> None:
        self.h_a[which] = h[which]
        self.m_a[which] = m
        self.rate[which] = rate[which]
        for i in np.flatnonzero(which):
            self.history[i].append((float(m), self.h_a[i].copy(), self.rate[i].copy()))

    def slots(self, which=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The stages' rotor slots of the bodies ``which`` (all by default):
        ``P_L = A h_a``, ``P_LD = A r``, ``P_LT = t0 + m_a dt``."""
        w = slice(None) if which is None else which
        return (rotor(self.axes, self.h_a[w]), rotor(self.axes, self.rate[w]),
                self.t0 + self.m_a[w] * self.dt)

    def segment(self, u: np.ndarray, m: float, n_left: int) -> tuple[int, np.ndarray]:
        """The next piece of at most ``n_left`` steps from step count ``m`` under the
        commands ``u`` ``(n, k)``: its length and which bodies were re-anchored (their
        stages' rotor slots must be written). Records the saturations it starts."""
        dt = self.dt
        h = self.now(m)
        u_c = np.clip(u, -self.tmax, self.tmax)
        clipped = np.abs(u) > self.tmax
        self._record(clipped & ~self.at_torque, self.t0 + m * dt, "torque")
        self.at_torque = clipped
        s = np.sign(u_c)
        held = (s != 0) & (s * h >= self.lim)  # at the limit, pushed outward
        self._record(held & ~self.at_speed, self.t0 + m * dt, "speed")
        self.at_speed = held
        r = np.where(held, 0.0, u_c)
        changed = np.any(r != self.rate, axis=1) | np.any(self.landing, axis=1)
        self.landing[:] = False
        if changed.any():
            self._anchor(changed, h, m, r)
        moving = self.rate != 0.0
        if not moving.any():
            return n_left, changed
        self.moved = True
        # steps from the anchor until the wheel reaches its limit: the least J with
        # |h_a + r J dt| >= lim (J = ceil(room / (|r| dt)), checked on the formula)
        sr = np.sign(self.rate)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            room = self.lim - sr * self.h_a
            J = np.where(moving, np.ceil(room / (np.abs(self.rate) * dt)), math.inf)
            J = np.maximum(J, 1.0)
            for _ in range(2):
                reach = sr * (self.h_a + self.rate * ((J - 1.0) * dt)) >= self.lim
                J = np.where(moving & reach & (J > 1.0), J - 1.0, J)
                short = sr * (self.h_a + self.rate * (J * dt)) < self.lim
                J = np.where(moving & short & np.isfinite(J), J + 1.0, J)
        ahead = J - (m - self.m_a)[:, None]  # steps from now; 1: this step reaches it
        hit = moving & (ahead <= 1.0)
        if hit.any():  # one step, with the rate that lands those wheels on their limit
            bodies = np.any(hit, axis=1)
            rate = self.rate.copy()
            rate[hit] = (sr * self.lim - h)[hit] / dt
            self._anchor(bodies, h, m, rate)
            self.landing[hit] = True
            self.land_value[hit] = (sr * self.lim)[hit]
            self._record(hit, self.t0 + (m + 1.0) * dt, "speed")
            self.at_speed |= hit
            return 1, changed | bodies
        first = float(np.min(ahead[moving])) - 1.0
        return int(min(float(n_left), first)), changed

    def _record(self, mask: np.ndarray, t: float, limit: str) -> None:
        for b, w in zip(*np.nonzero(mask), strict=True):
            self.events.append((int(b), float(t), int(w), limit))

    def samples(self, i: int, steps: np.ndarray) -> np.ndarray:
        """Body ``i``'s momenta at the step counts ``steps`` (after the anchors)."""
        hist = self.history[i]
        starts = np.array([a[0] for a in hist])
        which = np.searchsorted(starts, steps, side="right") - 1
        out = np.empty((len(steps), self.h_a.shape[1]))
        for j, (m_a, h_a, r) in enumerate(hist):
            sel = which == j
            if sel.any():
                out[sel] = h_a + r * ((steps[sel] - m_a)[:, None] * self.dt)
        if self.landing[i].any():  # a run that ends on a landing: on the limit, as now()
            after = (which == len(hist) - 1) & (steps - hist[-1][0] >= 1.0)
            lands = after[:, None] & self.landing[i]
            out[lands] = np.broadcast_to(self.land_value[i], out.shape)[lands]
        return out

    def records(self, body: int | None, until: float = math.inf, index: int | None = None
                ) -> tuple[Saturation, ...]:
        """The saturations up to time ``until`` as records (of body ``index``, given
        ``body``'s number in them; every body with ``index=None``)."""
        return tuple(Saturation(body if index is not None else b, t, w, lim)
                     for b, t, w, lim in sorted(self.events, key=lambda e: (e[1], e[0], e[2]))
                     if t <= until and (index is None or b == index))


def write_slots(params: np.ndarray, state: WheelState, which=None) -> None:
    """Write the rotor slots of the bodies ``which`` into every stage of ``params``
    (``(s, P)`` for one body, ``(n, s, P)`` one row per body)."""
    L, R, T = state.slots(which)
    if params.ndim == 2:
        params[:, _ROTOR] = L[0]
        params[:, _RATE] = R[0]
        params[:, S.P_LT] = T[0]
        return
    rows = slice(None) if which is None else which
    params[rows, :, _ROTOR] = L[:, None, :]
    params[rows, :, _RATE] = R[:, None, :]
    params[rows, :, S.P_LT] = T[:, None]


# ---------------------------------------------------------------------- integrate()
def with_wheels(scene, m: np.ndarray) -> np.ndarray:
    """The total momentum ``I omega + A h0`` from the body's own ``I omega`` (``omega0``
    gives the body's angular velocity; the wheels carry their initial momenta)."""
    h0 = np.atleast_2d(scene.momentum)
    out = m + rotor(scene.axes, h0)
    return out[0] if m.ndim == 1 and out.shape[0] == 1 else out


def integrate_wheels(scene, method, q0, m0, dt, n_steps, save_every, progress, n_bodies,
                     diagnostics, controls, t0, omega_given=False):
    """:func:`liebody.integrate` of a :class:`~liebody.ReactionWheels` scene (validated
    by it up to the controls): one body, or each body of an ensemble in turn. With
    ``omega0`` (``omega_given``) the total momentum is ``I omega0 + A h0``."""
    from liebody._integrate import _sample_times

    _refuse_sampled(method)
    u = wheel_controls(scene, controls, n_bodies)
    if omega_given:
        m0 = with_wheels(scene, m0)
    model = scene.torque_model()
    if n_bodies is None:
        t = _sample_times(n_steps, save_every, dt)
        return _WheelRun(scene, method, q0, m0, dt, n_steps, save_every, t, model, progress,
                         diagnostics, u, t0).stepped()
    return _ensemble(scene, method, q0, m0, dt, n_steps, save_every, progress, n_bodies,
                     diagnostics, u, t0)


def _sample_steps(n_steps: int, save_every: int, n_samples: int) -> np.ndarray:
    steps = np.arange(n_samples, dtype=float) * save_every
    steps[-1] = n_steps
    return steps


def _run_class():
    from liebody._ensemble import _ONE, Run

    class WheelRun(Run):
        """``integrate()``'s one-body run, cut where the wheels' rates change."""

        def __init__(self, scene, method, q0, m0, dt, n_steps, save_every, t, model,
                     progress, diagnostics, u, t0):
            super().__init__(scene, method, q0, m0, dt, n_steps, save_every, t, model,
                             progress, 1, diagnostics, None, t0)
            self.wu = u
            self.wheels = WheelState(scene, 1, dt, t0)
            # the pieces of the whole run, planned at once (a few: where rates change)
            plan_state = self.wheels.copy()
            self.pieces = []
            m = 0
            while m < n_steps:
                snap = plan_state.copy()
                length, changed = plan_state.segment(u, float(m), n_steps - m)
                self.pieces.append((m, length, bool(changed[0]), snap, plan_state.copy()))
                m += length
            self.final_state = plan_state
            if diagnostics:  # the kernel's energy: the body's part with the rotor A h0
                h0 = np.atleast_2d(scene.momentum)[:1]
                rot = rotor(scene.axes, h0)[0]
                inv = 1.0 / np.asarray(scene.moments, dtype=float)
                T0 = 0.5 * float(np.sum((m0 - rot) ** 2 * inv))
                dref = self.dref[0]
                dref[10:13] = rot
                dref[6] = math.nan if (plan_state.moved or scene.sources) else T0
                dref[7] = 1.0 / T0 if T0 > 0 else 0.0

        def stepped(self):
            from liebody._engine import first_slice, interrupt_after_call

            plan = self.method.plan(self.scene, self.m0[0], self.dt)
            self.info = dict(plan.info)
            g = self._group(_ONE, plan, self._runner(plan)[0])
            g["params"] = params = g["params"].copy()  # (its rotor slots change per piece)
            merge = plan.merge_ends and not self.diag
            pieces = iter(self.pieces)
            end = 0  # the end of the current piece
            done = 0
            try:
                for n in self.slices(self.n_steps, self.progress, "step",
                                     first_slice(self.model)):
                    stop = done + n
                    while done < stop and not g["status"][0]:
                        if done == end:
                            start, length, _, _, after = next(pieces)
                            write_slots(params, after)
                            end = start + length
                        k = min(stop, end) - done
                        # a piece's last step ends on its full state (unmerged), as the
                        # Stepper's call that the cut ends does: the same numbers
                        cut = int(bool(merge) and done + k == end)
                        for steps, merged in ((k - cut, merge), (cut, False)):
                            if steps and not g["status"][0]:
                                with interrupt_after_call():
                                    self._run_one(g, None, done, steps,
                                                  done + steps == self.n_steps, merged)
                                    done = int(g["done"][0])
                    if g["status"][0]:
                        break
            except KeyboardInterrupt:
                self._collect([g])
                self.interrupted_one(1 + int(self.saved[0]), int(self.done[0]))
            self._collect([g])
            status = int(self.status[0])
            if status == S.STATUS_OK:
                from liebody._engine import MAX_MOMENTUM
                from liebody.trajectory import Trajectory

                if not np.max(np.abs(self.m_one[-1])) <= MAX_MOMENTUM:
                    return self.overflowed(stacklevel=6)  # (at integrate()'s caller)
                self.q_one.flags.writeable = self.m_one.flags.writeable = False
                traj = Trajectory(self._times(), self.q_one, self.m_one, self.scene,
                                  self.method, self.dt, info=self.info,
                                  diagnostics=self._diagnostics(),
                                  wheels=self._wheel_samples(len(self.t)),
                                  saturations=self.final_state.records(None, index=0))
                return _check(traj)
            return self.failed(status, int(self.done[0]), int(self.saved[0]),
                               self.state[0].copy(), stacklevel=7)

        def _wheel_samples(self, n_keep: int) -> np.ndarray:
            steps = _sample_steps(self.n_steps, self.save_every, len(self.t))[:n_keep]
            out = self.final_state.samples(0, steps)
            out.flags.writeable = False
            return out

        def partial(self, n_keep, status, failed_at=None):
            from liebody.trajectory import Trajectory

            until = self.t0 + float(self.t[n_keep - 1]) if failed_at is None else failed_at
            return Trajectory(self._times()[:n_keep].copy(), self.q_one[:n_keep].copy(),
                              self.m_one[:n_keep].copy(), self.scene, self.method, self.dt,
                              failed_at=failed_at, info=self.info, status=status,
                              wheels=self._wheel_samples(n_keep),
                              saturations=self.final_state.records(None, until, index=0))

    return WheelRun


class _LazyRun:
    cls = None

    def __call__(self, *args, **kwargs):
        if _LazyRun.cls is None:
            _LazyRun.cls = _run_class()
        return _LazyRun.cls(*args, **kwargs)


_WheelRun = _LazyRun()

#: tolerances of the end-of-run check of a wheel run (as for integrate())
_QNORM_TOL = 1e-6
_ENERGY_TOL = 1e-2


def _check(traj):
    """``integrate()``'s end-of-run check, for wheels: ``|q|``, and the energy of body and
    wheels for a symplectic method when nothing drives them (no command, no torque)."""
    from liebody.errors import InvariantWarning

    q1 = traj.q[-1]
    problems = []
    qn = float(np.linalg.norm(q1))
    if not abs(qn - 1.0) <= _QNORM_TOL:
        problems.append(f"|q| = {qn:.6g} at the end, off 1 by more than {_QNORM_TOL:g}")
    still = not np.any(np.diff(traj.wheels, axis=0)) if len(traj.t) > 1 else True
    if traj.method.symplectic and traj.scene.sources is None and still:
        T = traj.kinetic_energy
        if not abs(T[-1] - T[0]) <= _ENERGY_TOL * T[0]:
            problems.append(f"the energy went from {T[0]:.6g} to {T[-1]:.6g}, more than "
                            f"{_ENERGY_TOL:.0%}")
    if problems:
        warnings.warn(f"{traj.method.name}: " + "; ".join(problems) + " (the step may be too "
                      "large for this scene)", InvariantWarning, stacklevel=6)
    return traj


def _ensemble(scene, method, q0, m0, dt, n_steps, save_every, progress, n, diagnostics, u, t0):
    """An ensemble of wheel bodies: each body's one-body run in turn (so each body's numbers
    are its one-body call's), stacked; a body that fails stops there (NaN after) and one
    warning sums up."""
    from liebody._engine import failure_message
    from liebody._integrate import _sample_times
    from liebody.errors import IntegrationError
    from liebody.trajectory import Trajectory

    t = _sample_times(n_steps, save_every, dt, n)
    q0 = np.broadcast_to(q0, (n, 4))
    m0 = np.broadcast_to(m0, (n, 3))
    batched = bool(scene.batch_shape)
    k = scene.n_wheels
    q = np.full((n, len(t), 4), np.nan)
    L = np.full((n, len(t), 3), np.nan)
    W = np.full((n, len(t), k), np.nan)
    failed_at = np.full(n, np.nan)
    status = np.array(["complete"] * n, dtype=object)
    sat: list = []
    diag: dict = {}
    info: dict = {}
    for i in range(n):
        one = scene.take(i) if batched else scene
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                tr = _WheelRun(one, method, np.ascontiguousarray(q0[i]),
                               np.ascontiguousarray(m0[i]), dt, n_steps, save_every, t,
                               one.torque_model(), progress, diagnostics, u[i:i + 1],
                               t0).stepped()
            except IntegrationError as exc:  # (IntegrationInterrupted propagates)
                tr = exc.trajectory
        for w in caught:
            if not issubclass(w.category, RuntimeWarning) or tr.failed_at is None:
                warnings.warn(w.message, stacklevel=5)  # (at integrate()'s caller)
        info = tr.info
        j = len(tr.t)
        q[i, :j], L[i, :j], W[i, :j] = tr.q, tr.L, tr.wheels
        if tr.failed_at is not None:
            failed_at[i] = tr.failed_at
            status[i] = "failed: non-finite state"
        sat.extend(s._replace(body=i) for s in tr.saturations)
        if tr.diagnostics:
            for key, v in tr.diagnostics.items():
                diag.setdefault(key, np.full(n, np.nan))[i] = v
    message = failure_message(method.name, status, failed_at)
    if message:
        warnings.warn(message, RuntimeWarning, stacklevel=5)
    for a in (q, L, W):
        a.flags.writeable = False
    sat.sort(key=lambda s: (s.t, s.body, s.wheel))
    return Trajectory((t if t0 == 0.0 else t0 + t), q, L, scene, method, dt,
                      failed_at=failed_at, info=dict(info, simd=False),  # (no rotor in SIMD)
                      status=status.astype(str),
                      diagnostics=diag or None, wheels=W, saturations=tuple(sat))


# ---------------------------------------------------------------------- the Stepper
class WheelStepper(Stepper):
    """:class:`liebody.Stepper` of a :class:`~liebody.ReactionWheels` scene (made by
    ``Stepper(scene, ...)``): :attr:`u` are the wheels' motor torques, held over the
    following steps; :attr:`wheel_momentum` reads and sets the wheels' momenta;
    :attr:`saturations` lists the saturations so far."""

    def __init__(self, scene, *, q0=(1.0, 0.0, 0.0, 0.0), L0=None, omega0=None, dt,
                 method=None, controls=None, threads: int | None = None,
                 simd: bool | None = None, t0: float = 0.0) -> None:
        from liebody import _methods

        m = _methods.get(scene.default_method if method is None else method)
        _refuse_sampled(m)
        self._wheels = None
        if omega0 is not None:  # the body's angular velocity: L = I omega0 + A h0
            from liebody._integrate import _initial_momentum

            L0, omega0 = with_wheels(scene, _initial_momentum(scene, None, omega0)), None
        super().__init__(scene, q0=q0, L0=L0, omega0=omega0, dt=dt, method=method,
                         controls=None, threads=threads, simd=simd, t0=t0)
        self._wu = wheel_controls(scene, controls, self._n, name="controls")
        self._wheels = WheelState(scene, self._n or 1, self._dt, self._t0)
        self._write()

    # the stages' rotor slots
    def _write(self, which=None) -> None:
        if self._n is None:
            write_slots(self._head[4], self._wheels)
            return
        for g in self._groups:
            idx = g["idx"]
            sel = np.ones(len(idx), dtype=bool) if which is None else which[idx]
            if not sel.any():
                continue
            L, R, T = self._wheels.slots(idx[sel])
            p = g["params"]
            p[sel, :, _ROTOR] = L[:, None, :]
            p[sel, :, _RATE] = R[:, None, :]
            p[sel, :, S.P_LT] = T[:, None]

    def _plan(self, momentum=None) -> None:
        super()._plan(momentum)
        # whether an ensemble's pieces may end some bodies merged: a method that merges
        # end stages, on the scalar drivers (their countdown and merge are per body)
        self._keeps = self._n is not None and (
            any(g["merge"] for g in self._groups) and not any(g["simd"] for g in self._groups))
        if getattr(self, "_wheels", None) is not None:
            self._write()

    def step(self, n: int = 1) -> None:
        """Advance ``n`` steps (``n >= 1``) with the motor torques :attr:`u` held, cut where
        a wheel reaches a limit (:attr:`saturations`); errors as :meth:`Stepper.step`."""
        from liebody._validate import as_positive_int
        from liebody.errors import IntegrationInterrupted

        with self._lock:
            n = as_positive_int("n", n)
            if self._n is not None:
                self._step_bodies(n)
                return
            done = 0
            while done < n:
                before = self._wheels.copy()
                length, changed = self._wheels.segment(self._wu, self._k, n - done)
                if changed.any():
                    self._write(changed)
                try:
                    Stepper.step(self, length)
                except IntegrationInterrupted as exc:
                    if exc.step == 0:
                        self._wheels = before
                        self._write()
                    m = done + exc.step  # (the steps of this call, not of its piece)
                    raise self._interruption(n, m) from None
                except BaseException:
                    self._wheels = before
                    self._write()
                    raise
                done += length

    def _step_bodies(self, n: int) -> None:
        """An ensemble's ``step(n)``: the pieces of :meth:`WheelState.segment` (cut where
        any body's rates change), each body's last step of a piece unmerged only where its
        own rates change after it (where its one-body stepper cuts the call) or at the
        call's end; the others go on merged into the next piece, whose stage rows are
        theirs unchanged. So every body gets its one-body stepper's numbers. A body that
        fails is left at its state before the call, its wheels too (:meth:`_hold`)."""
        if self._stale:
            self._plan()
        self._gather()
        steps0 = self._steps
        start = {"k": self._k, "wheels": self._wheels.copy(), "state": self._state.copy()}
        merges = self._keeps
        for g in self._groups:
            g["ctl"][:, 1] = 0  # every body starts the call on a full step
        handled = self._status != S.STATUS_OK  # failed bodies, whose wheels are held
        u = np.where(handled[:, None], 0.0, self._wu)
        snap = (self._k, start["wheels"])  # the wheels before the piece at step count k
        ahead = None  # the next piece, planned with this one: (wheels, length, changed)
        try:
            while self._steps - steps0 < n:
                left = n - (self._steps - steps0)
                if ahead is not None:  # (snap: a state no longer changed)
                    snap = (self._k, self._wheels)
                    self._wheels, length, changed = ahead
                    ahead = None
                else:
                    if self._k != snap[0]:
                        snap = (self._k, self._wheels.copy())
                    length, changed = self._wheels.segment(u, self._k, left)
                if changed.any():
                    self._write(changed)
                keep = None
                if merges and length < left:  # the bodies the next piece re-anchors end
                    nxt = self._wheels.copy()  # this one unmerged; the others go on merged
                    ahead = (nxt, *nxt.segment(u, self._k + length, left - length))
                    keep = None if ahead[2].all() else ~ahead[2]
                self._advance(length, keep, carry=True)
                if self._fail(handled, start):  # their wheels held: plan again
                    u = np.where(handled[:, None], 0.0, self._wu)
                    ahead = None
        except KeyboardInterrupt:  # (IntegrationInterrupted too)
            self._interrupted(n, steps0, start, snap, handled)
        except BaseException:
            if self._k == snap[0]:
                self._wheels = snap[1]
                self._write()
            raise

    def _pending(self) -> bool:
        """Whether a healthy body's last step ran the next one's first stage (merged)."""
        return any(bool(np.any(g["ctl"][:, 1][g["status"] == S.STATUS_OK]))
                   for g in self._groups)

    def _interrupted(self, n: int, steps0: int, start: dict, snap: tuple,
                     handled: np.ndarray):
        """Ctrl-C during an ensemble's ``step(n)``: the wheels of the piece not begun
        dropped, the failures of the last piece taken, a step left merged at a piece's end
        completed (the call's next step, unmerged for every body), then raise. Every part
        can be repeated (a second Ctrl-C runs it again)."""

        while True:
            try:
                if self._k == snap[0]:  # no step of this piece: its wheels undone
                    self._wheels = snap[1].copy()
                    self._write()
                self._fail(handled, start)
                if not self._pending():
                    break
                # the bodies kept merged at the end of the last piece (the others ended it
                # unmerged): the next piece's first step, every body unmerged
                snap = (self._k, self._wheels.copy())
                u = np.where(handled[:, None], 0.0, self._wu)
                self._wheels.segment(u, self._k, n - (self._steps - steps0))
                self._write()
                self._advance(1, None, carry=True)
            except KeyboardInterrupt:
                continue
        raise self._interruption(n, self._steps - steps0) from None

    def _fail(self, handled: np.ndarray, start: dict) -> bool:
        """The bodies that failed in this call and are not yet ``handled``: left at their
        state before the call (they may have failed after a merged step), their wheels
        too; ``handled`` updated in place. Whether there were any. Repeatable."""
        fresh = (self._status != S.STATUS_OK) & ~handled
        if not fresh.any():
            return False
        self._gather()
        self._state[fresh] = start["state"][fresh]
        for g in self._groups:
            if not g["whole"]:
                sel = fresh[g["idx"]]
                g["state"][sel] = start["state"][g["idx"][sel]]
        self._hold(fresh, start["wheels"], start["k"])
        handled |= fresh
        return True

    def _hold(self, fresh: np.ndarray, before: WheelState, k: float) -> None:
        """Bodies ``fresh`` failed and were left at their state at step count ``k``, when
        the wheels were ``before``: so are their wheels (held there, their records since
        then dropped). Repeatable."""
        w = self._wheels
        h = w.h_a.copy()
        h[fresh] = before.now(k)[fresh]
        w._anchor(fresh, h, self._k, np.zeros_like(w.rate))
        for name in ("landing", "at_speed", "at_torque"):
            getattr(w, name)[fresh] = getattr(before, name)[fresh]
        w.landing[fresh] = False
        w.events = before.events + [e for e in w.events[len(before.events):]
                                    if not fresh[e[0]]]
        self._write(fresh)

    @property
    def u(self) -> np.ndarray:
        """The wheels' motor torques ``(k,)`` (``(N, k)`` for an ensemble), held over the
        following steps: as commanded (the steps clip them to ``max_torque`` where the
        scene has one, and record it in :attr:`saturations`)."""
        with self._lock:
            return (self._wu[0] if self._n is None else self._wu).copy()

    @u.setter
    def u(self, value) -> None:
        if value is None:
            raise TypeError("u must be the wheels' motor torques (an array of numbers), "
                            "got None")
        u = wheel_controls(self._scene, value, self._n, name="u")
        with self._lock:
            self._wu = u

    @property
    def wheel_momentum(self) -> np.ndarray:
        """The wheels' absolute axial angular momenta ``h`` now, ``(k,)`` or ``(N, k)``
        (a copy; settable, within the speed limits)."""
        with self._lock:
            h = self._wheels.now(self._k)
            return h[0].copy() if self._n is None else h

    @wheel_momentum.setter
    def wheel_momentum(self, value) -> None:
        k = self._scene.n_wheels
        h = np.array(as_float_array("wheel_momentum", value), dtype=float)
        n = self._n or 1
        if h.shape not in ((k,), (n, k)) or (self._n is None and h.ndim != 1):
            raise ValueError(f"wheel_momentum must be shape ({k},)"
                             + ("" if self._n is None else f" or ({n}, {k})")
                             + f", got {h.shape}")
        h = np.array(np.broadcast_to(h, (n, k)))
        if np.any(np.abs(h) > self._wheels.lim):
            raise ValueError("wheel_momentum must be within the speed limit, |h_k| <= J_k "
                             "max_speed")
        with self._lock:
            self._wheels.set(h, self._k)
            self._write()

    @property
    def omega(self) -> np.ndarray:
        """The body's angular velocity ``I^-1 (L - A h)`` (settable: ``L = I omega + A h``
        with the wheels' momenta now, which re-plans the method at the next step)."""
        return (self.L - self.rotor_momentum) / np.asarray(self._scene.moments)

    @omega.setter
    def omega(self, value) -> None:
        from liebody._integrate import _initial_momentum

        m = _initial_momentum(self._scene, None, value, names=("L", "omega"))
        with self._lock:
            self.L = m + self.rotor_momentum

    @property
    def rotor_momentum(self) -> np.ndarray:
        """``l = A h``, the wheels' momentum in the body frame now (``(3,)`` or ``(N, 3)``)."""
        h = np.atleast_2d(self.wheel_momentum)
        out = rotor(self._scene.axes, h)
        return out[0] if self._n is None else out

    @property
    def saturations(self) -> tuple[Saturation, ...]:
        """The saturations so far (:class:`liebody.wheels.Saturation` records, in time
        order; ``body`` ``None`` for one body)."""
        with self._lock:
            if self._n is None:
                return self._wheels.records(None, index=0)
            return self._wheels.records(None)

    @property
    def t(self) -> float:
        return Stepper.t.fget(self)

    @t.setter
    def t(self, value) -> None:
        with self._lock:
            m = self._k
            Stepper.t.fset(self, value)
            self._wheels.rebase(m, self._t0)
            self._write()

    def __getstate__(self) -> dict:
        state = super().__getstate__()
        with self._lock:
            state["wheels"] = self._wheels.copy()
            state["wu"] = self._wu.copy()
        return state

    def __setstate__(self, state: dict) -> None:
        self._wheels = state["wheels"].copy()
        self._wu = state["wu"].copy()
        super().__setstate__(state)
