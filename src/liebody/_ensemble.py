"""The run engine: one :func:`liebody.integrate` call of ``N`` bodies after validation; one
body is an ensemble of one (its own kernels and reports). ``docs/design.md`` describes it.
"""

from __future__ import annotations

import itertools
import math
import warnings
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from liebody._engine import (  # noqa: F401 - REASONS and failure_message: re-exported
    FIRST_SLICE,
    MAX_MOMENTUM,
    REASONS,
    SHORT_TIMES_SAMPLES,
    StepFailure,
    batch_args,
    batch_runner,
    block_interrupts,
    body_chunks,
    diagnostic_reference,
    diagnostics_dict,
    entry_point,
    failed_step_times,
    failed_step_words,
    failure_error,
    failure_message,
    failure_summary,
    first_slice,
    groups_info,
    interrupt_after_call,
    one_body_args,
    resolve_threads,
    sample_diagnostics,
    time_slices,
    warn_invariants,
    widest_reach,
    with_controls,
    write_controls,
)
from liebody._kernels import stages as S
from liebody.errors import IntegrationInterrupted
from liebody.trajectory import Trajectory

#: the diagnostics' arrays of a one-body run without them (the drivers never touch them)
NO_DREF, NO_DMAX = np.zeros(S.DREF_WIDTH), np.zeros(3)
#: a one-body driver's control block: (save countdown, merged-step flag)
CTL = np.zeros(2, dtype=np.int64)
#: the body index of a one-body run's one group
_ONE = np.zeros(1, dtype=np.int64)
#: (RUNNERS, DIAG_RUNNERS) of the one-body drivers, once imported; the exact flow's kernel
_DRIVERS: list = []
_EXACT: list = []


def one_body_drivers() -> tuple:
    """``(RUNNERS, DIAG_RUNNERS)`` of the one-body drivers, imported on first use (numba
    loads with them) and then kept (an import statement per call costs a microsecond)."""
    if not _DRIVERS:
        from liebody._kernels.driver import DIAG_RUNNERS, RUNNERS

        _DRIVERS.append((RUNNERS, DIAG_RUNNERS))
    return _DRIVERS[0]


def exact_flow_times():
    """The exact flow's kernel at output times, imported on first use and then kept."""
    if not _EXACT:
        from liebody._kernels.exact import exact_flow_times as kernel

        _EXACT.append(kernel)
    return _EXACT[0]


def one_body_outputs(q0: np.ndarray, m0, n: int) -> tuple[np.ndarray, np.ndarray]:
    """A one-body run's sample arrays ``(n, 4)``, ``(n, 3)``, the initial state first."""
    q_out, m_out = np.empty((n, 4)), np.empty((n, 3))
    q_out[0] = q0
    m_out[0] = m0
    return q_out, m_out


def drive(runner, plan, args: tuple):
    """Call a one-body driver (``runner``, of ``plan``'s family) on ``args``
    (:func:`one_body_args`): through numba's dispatch on the plan's first call (which
    compiles or loads the driver), through the compiled entry point from its second call
    on (every argument then has the same type: about 0.4 us less a call; a plan made for
    one run, such as a new orbit's, never resolves it)."""
    fn = plan.entries.get(runner)
    if fn is not None:
        return fn(*args)
    out = runner(*args)
    if runner in plan.entries:
        plan.entries[runner] = entry_point(runner, args)
    else:
        plan.entries[runner] = None
    return out


def completed(scene, method, dt: float, info: dict, t: np.ndarray, t0: float,
              q_out: np.ndarray, m_out: np.ndarray, diagnostics, q0l: list, m0l: list,
              end: list, stacklevel: int) -> Trajectory | None:
    """The trajectory of a one-body run that finished (``end``: its final state as a
    list, which is its last sample: a saved step is never merged with the next), after
    the end-of-run check; ``None`` when its final ``L`` overflows :data:`MAX_MOMENTUM`."""
    L1 = end[4:]
    if not max(abs(L1[0]), abs(L1[1]), abs(L1[2])) <= MAX_MOMENTUM:
        return None
    q_out.setflags(write=False)  # ours: no view
    m_out.setflags(write=False)
    traj = Trajectory._complete(t if t0 == 0.0 else t0 + t, q_out, m_out, scene, method, dt,
                                info.copy(), diagnostics)  # (the plan's info is cached)
    return warn_invariants(traj, stacklevel, (q0l, end[:4], m0l, L1))


class Run:
    """One :func:`liebody.integrate` call of ``N`` bodies after validation: ``q0`` ``(N, 4)``
    and ``m0`` ``(N, 3)``; or one body, ``(4,)`` and ``(3,)``, run as an ensemble of one
    (its one group, chunk and records) by the one-body drivers and reported as one body
    (its errors raised, its diagnostics scalars; ``outputs``: its sample arrays, if made
    already)."""

    def __init__(self, scene, method, q0, m0, dt, n_steps, save_every, t, model, progress,
                 threads=1, diagnostics=False, u=None, t0=0.0, simd=None, outputs=None):
        self.scene, self.method, self.dt = scene, method, dt
        self.n_steps, self.save_every, self.t = n_steps, save_every, t
        self.model, self.progress = model, progress
        self.threads = threads
        self.u = u  # the controls: (k,) or (N, k), or None
        self.t0 = t0  # the start time; self.t holds the sample times relative to it
        self.simd = simd  # None: automatic; True / False: where supported / never
        self.slices = time_slices
        self.reach = (0.0, 1.0)  # the times the plans' stages read, in steps (Plan.reach)
        self.one = one = q0.ndim == 1
        k = t.shape[0]
        if one:  # the body's own sample arrays (the trajectory's), seen with a body axis
            self.q_one, self.m_one = (one_body_outputs(q0, m0, k) if outputs is None
                                      else outputs)
            self.q_out, self.m_out = self.q_one[None], self.m_one[None]
            q0, m0 = q0[None], m0[None]
        else:
            self.q_out = np.empty((q0.shape[0], k, 4))
            self.m_out = np.empty((q0.shape[0], k, 3))
            self.q_out[:, 0], self.m_out[:, 0] = q0, m0
        self.q0, self.m0 = q0, m0
        n = q0.shape[0]
        self.status = np.zeros(n, dtype=np.int64)
        self.state = np.empty((n, 7))  # each body's last good state
        self.done = np.zeros(n, dtype=np.int64)
        self.saved = np.zeros(n, dtype=np.int64)
        self.info: dict = {}
        self.diag = diagnostics
        if diagnostics:
            self.dref = diagnostic_reference(scene, model, q0, m0, t0)
            self.dmax = np.zeros((n, 3))
        elif one:  # (the drivers without diagnostics never touch them: shared)
            self.dref, self.dmax = NO_DREF[None], NO_DMAX[None]
        else:  # (rows of no numbers, no memory)
            self.dref, self.dmax = np.zeros((n, 0)), np.zeros((n, 0))
        #: the body of each row of the samples while the groups run (None: body order)
        self.order: np.ndarray | None = None

    @property
    def n(self) -> int:
        return self.q0.shape[0]

    def _map(self, pool, fn, chunks):
        if pool is None:
            return [fn(c) for c in chunks]
        return [f.result() for f in [pool.submit(fn, c) for c in chunks]]

    def _times(self) -> np.ndarray:
        """The sample times ``t0 + t``."""
        return self.t if self.t0 == 0.0 else self.t0 + self.t

    def _step_of_sample(self, k: int) -> int:
        return min(k * self.save_every, self.n_steps)

    # -------------------------------------------------------------- the exact flow
    def sampled(self) -> Trajectory:
        """The exact flow evaluated at the output times, in slices of samples."""
        if self.one:
            return self._sampled_one()
        from liebody._kernels.exact import exact_flow_bodies

        self.info = {"simd": False}  # (no SIMD kernel evaluates the exact flow)
        moments = np.ascontiguousarray(np.broadcast_to(self.scene.moments, (self.n, 3)))
        t, q, m = self.t, self.q_out, self.m_out
        chunks = body_chunks(self.n, self.threads)
        done = 1
        with _pool(min(self.threads, len(chunks))) as pool:
            try:
                for k in self.slices(len(t) - 1, self.progress, "sample", 4096 // self.n):
                    sl = slice(done, done + k)
                    tk = t[sl]

                    def work(c, sl=sl, tk=tk):
                        st = np.zeros(c.stop - c.start, dtype=np.int64)
                        st[self.status[c] != 0] = -1
                        exact_flow_bodies(moments[c], self.q0[c], self.m0[c], tk,
                                          q[c, sl], m[c, sl], st)
                        return c, st

                    for c, st in self._map(pool, work, chunks):
                        new = np.flatnonzero(st > 0)
                        for i in new + c.start:
                            first = done + int(st[i - c.start]) - 1  # the first bad sample
                            self.status[i] = S.STATUS_NONFINITE
                            self.done[i] = min((first - 1) * self.save_every, self.n_steps)
                            self.saved[i] = first - 1
                    done += k
                    self.saved[self.status == 0] = done - 1
            except KeyboardInterrupt:
                self._interrupted(done)
        self.saved[self.status == 0] = len(t) - 1
        return self._result(len(t))

    def _sampled_one(self) -> Trajectory:
        """One body's exact flow (its kernel at the sample times), in slices of samples."""
        kernel = _EXACT[0] if _EXACT else exact_flow_times()
        moments = np.ascontiguousarray(self.scene.moments, dtype=np.float64)
        t, q, m = self.t, self.q_one, self.m_one
        done = 1  # sample 0 is the initial state
        total = len(t) - 1
        try:
            slices = (total,) if total <= FIRST_SLICE and not self.progress else \
                self.slices(total, self.progress, "sample", FIRST_SLICE)
            for n in slices:
                sl = slice(done, done + n)
                kernel(moments, self.q0[0], self.m0[0], t[sl], q[sl], m[sl])
                if n <= SHORT_TIMES_SAMPLES and all(map(
                        math.isfinite, q[sl].ravel().tolist() + m[sl].ravel().tolist())):
                    done += n  # (a few samples: checked as numbers, at once)
                    continue
                bad = ~(np.isfinite(q[sl]).all(axis=1) & np.isfinite(m[sl]).all(axis=1))
                if bad.any():
                    k = done + int(np.argmax(bad))
                    return self.failed_nonfinite(k, self._step_of_sample(k - 1),
                                                 self.t0 + t[k - 1], self.t0 + t[k],
                                                 stacklevel=5)
                done += n
        except KeyboardInterrupt:
            self.interrupted_one(done, self._step_of_sample(done - 1))
        diag = None
        if self.diag:  # the exact flow keeps its invariants: measured on the samples
            diag = diagnostics_dict(sample_diagnostics(self.dref, q[None], m[None]), True,
                                    self.dref[0])
        q.setflags(write=False)  # ours: no view
        m.setflags(write=False)
        traj = Trajectory._complete(self._times(), q, m, self.scene, self.method, self.dt,
                                    self.info, diag)
        return warn_invariants(traj, stacklevel=5)  # (sampled, integrate: the caller)

    # -------------------------------------------------------------- stepping
    def _runner(self, plan):
        """A plan's driver and whether it is the SIMD one: for one body its one-body
        driver; for an ensemble :func:`batch_runner`'s choice."""
        if self.one:
            return one_body_drivers()[bool(self.diag)][plan.family], False
        return batch_runner(plan, self.model.code, self.n, self.simd, self.diag)

    def stepped(self) -> Trajectory:
        """Run the plans' stage tables through the drivers of their families: the groups
        of bodies that share a plan, in chunks over the threads, in time slices."""
        first = max(1, first_slice(self.model) // self.n)
        if self.one:  # its one group and chunk
            plan = self.method.plan(self.scene, self.m0[0], self.dt)
            self.info = dict(plan.info)  # the trajectory's own (the plan's is cached)
            self.reach = plan.reach
            g = self._group(_ONE, plan, self._runner(plan)[0])
            work, chunks, run = [g], [(g, None)], self._run_one
            # a short run: one call (Ctrl-C during it reports the initial sample)
            short = self.n_steps <= first and not self.progress
        else:
            groups = self.method.plans(self.scene, self.m0, self.dt)
            runners = [self._runner(plan) for _, plan in groups]
            self.info = groups_info(groups, runners)
            self.reach = widest_reach(plan.reach for _, plan in groups)
            if len(groups) > 1:  # each group on contiguous rows of the samples, in order
                self.order = np.concatenate([idx for idx, _ in groups])
                self.q_out[:, 0], self.m_out[:, 0] = self.q0[self.order], self.m0[self.order]
            starts = itertools.accumulate([len(idx) for idx, _ in groups], initial=0)
            work = [self._group(idx, plan, r[0], r[1], slice(a, a + len(idx)))
                    for (idx, plan), r, a in zip(groups, runners, starts, strict=False)]
            chunks = [(g, c) for g in work for c in body_chunks(len(g["idx"]), self.threads)]
            run, short = self._run_chunk, False
        done = 0
        with _pool(min(self.threads, len(chunks))) as pool:
            try:
                if short:
                    run(g, None, 0, self.n_steps, True)
                for k in () if short else self.slices(self.n_steps, self.progress, "step",
                                                      first):
                    final = done + k == self.n_steps
                    # Ctrl-C is delivered once every chunk has finished the slice and it
                    # is counted (the pool's threads never take SIGINT): finished slices
                    # are kept, and no thread writes while the result is made
                    with interrupt_after_call():
                        if pool is None:
                            for g, c in chunks:
                                run(g, c, done, k, final)
                        else:
                            self._map(pool, lambda gc, done=done, k=k, final=final:
                                      run(gc[0], gc[1], done, k, final), chunks)
                        done += k
                    if not any(np.count_nonzero(g["status"]) < len(g["idx"]) for g in work):
                        break  # (every body failed)
            except KeyboardInterrupt:
                self._collect(work)
                if self.one:
                    self.interrupted_one(1 + int(self.saved[0]), int(self.done[0]))
                self._interrupted(1 + done // self.save_every)
        self._collect(work)
        return self._result(len(self.t))

    def _group(self, idx, plan, runner, simd: bool = False, rows: slice = slice(None)
               ) -> dict:
        """A group's arrays: views of the ensemble's when its bodies are all of them; its
        samples are the rows ``rows`` of the ensemble's (in the groups' order, put back in
        body order by :meth:`_collect`)."""
        n = len(idx)
        whole = n == self.n
        sel = slice(None) if whole else idx
        if self.one:  # the body's stage rows (a copy holding its controls, if any)
            params = plan.first[0]
            if self.u is not None:
                params = params.copy()
                write_controls(params, self.u)
        else:
            params = with_controls(plan.params, None if self.u is None else (
                self.u if self.u.ndim == 1 else self.u[sel]), n)
        state = np.empty((n, 7))
        state[:, :4], state[:, 4:] = self.q0[sel], self.m0[sel]
        ctl = np.zeros((n, 2), dtype=np.int64)
        ctl[:, 0] = self.save_every
        # "saved" starts at 1: the kernel writes sample 1 + (samples saved so far)
        return {"idx": idx, "plan": plan, "params": params, "runner": runner, "whole": whole,
                "addr": self.model.driver_address(simd), "state": state, "ctl": ctl,
                "saved": np.ones(n, dtype=np.int64), "done": np.zeros(n, dtype=np.int64),
                "status": np.zeros(n, dtype=np.int64), "dref": self.dref[sel],
                "dmax": self.dmax[sel] if self.one else np.zeros((n, self.dmax.shape[1])),
                "q": self.q_out[rows], "m": self.m_out[rows]}

    def _run_chunk(self, g, c: slice, done: int, k: int, final: bool) -> None:
        p = g["plan"]
        g["runner"](*batch_args(p, g["params"], p.merge_ends and not self.diag, self.dt, self.t0,
                                float(done), k, self.save_every, final, g["state"][c],
                                g["ctl"][c], g["q"][c], g["m"][c], g["saved"][c],
                                g["done"][c], g["status"][c], g["addr"], c,
                                g["dref"][c], g["dmax"][c]))

    def _run_one(self, g, c: slice | None, done: int, k: int, final: bool,
                 merge: bool | None = None) -> None:
        """Steps ``done .. done + k`` of one body, by its one-body driver (the ensemble's
        records kept in its group: steps done, samples saved, status); ``merge``: whether
        the steps merge their end stages (default: where the plan allows it)."""
        p = g["plan"]
        s = int(g["saved"][0])
        if merge is None:
            merge = p.merge_ends and not self.diag
        d, s1, status = drive(g["runner"], p, one_body_args(
            p, g["params"], merge, self.dt, self.t0, float(done), k,
            self.save_every, final, g["state"][0], g["ctl"][0], self.q_one[s:],
            self.m_one[s:], g["addr"], g["dref"][0], g["dmax"][0]))
        g["done"][0] += d
        g["saved"][0] = s + s1
        g["status"][0] = status

    def _collect(self, work) -> None:
        if self.order is not None:  # the samples back in body order (once)
            from liebody._kernels.rows import unpermute_rows

            order, self.order = self.order, None
            for a in (self.q_out, self.m_out):
                unpermute_rows(a.reshape(self.n, -1), order, np.zeros(self.n, dtype=np.bool_))
        for g in work:
            idx = slice(None) if g["whole"] else g["idx"]
            self.status[idx] = g["status"]
            self.state[idx] = g["state"]
            self.done[idx] = g["done"]
            self.saved[idx] = g["saved"] - 1
            if self.diag:
                self.dmax[idx] = g["dmax"]

    # -------------------------------------------------------------- outcomes
    def _blank_after_failures(self, n_keep: int) -> np.ndarray:
        """NaN every sample a failed body did not reach; its ``failed_at`` (else NaN)."""
        failed_at = np.full(self.n, np.nan)
        for i in np.flatnonzero(self.status != S.STATUS_OK):
            first = 1 + int(self.saved[i])
            self.q_out[i, first:n_keep] = np.nan
            self.m_out[i, first:n_keep] = np.nan
            failed_at[i] = self.t0 + (self.done[i] + 1) * self.dt
        return failed_at

    def _result(self, n_keep: int) -> Trajectory:
        if self.one:  # one body: its trajectory, or its failure's report
            status = int(self.status[0])
            if status == S.STATUS_OK:
                traj = completed(self.scene, self.method, self.dt, self.info, self.t, self.t0,
                                 self.q_one, self.m_one, self._diagnostics(),
                                 self.q0[0].tolist(), self.m0[0].tolist(),
                                 self.state[0].tolist(), stacklevel=6)
                return self.overflowed(stacklevel=5) if traj is None else traj
            return self.failed(status, int(self.done[0]), int(self.saved[0]),
                               self.state[0].copy(), stacklevel=6)
        failed_at = self._blank_after_failures(n_keep)
        status = np.array(["complete"] * self.n, dtype=object)
        bad = np.flatnonzero(self.status != S.STATUS_OK)
        for i in bad:
            status[i] = "failed: " + REASONS.get(int(self.status[i]), "unknown")
        message = failure_summary(self.method.name, status, failed_at, self.dt, self.model,
                                  self.state, self.u, self.reach)
        if message:
            warnings.warn(message, RuntimeWarning, stacklevel=4)
        diag = None
        if self.diag:
            if self.method.sampled:  # the exact flow: measured on the samples
                self.dmax = sample_diagnostics(self.dref, self.q_out, self.m_out)
            self.dmax[self.status != S.STATUS_OK] = np.nan
            diag = diagnostics_dict(self.dmax, False, self.dref)
        traj = Trajectory(self._times()[:n_keep], self.q_out[:, :n_keep], self.m_out[:, :n_keep],
                          self.scene, self.method, self.dt, failed_at=failed_at,
                          info=self.info, status=status, diagnostics=diag)
        return warn_invariants(traj, stacklevel=5)

    def _interrupted(self, n_keep: int):
        n_keep = min(n_keep, len(self.t))
        failed_at = self._blank_after_failures(n_keep)
        status = np.array(["interrupted"] * self.n, dtype=object)
        traj = Trajectory(self._times()[:n_keep].copy(), self.q_out[:, :n_keep].copy(),
                          self.m_out[:, :n_keep].copy(), self.scene, self.method, self.dt,
                          failed_at=failed_at, info=self.info, status=status)
        step = min((n_keep - 1) * self.save_every, self.n_steps)
        raise IntegrationInterrupted(
            f"{self.method.name}: interrupted near step {step:,} of {self.n_steps:,}; the "
            f"{n_keep:,} samples of each of the {self.n:,} bodies computed so far are on this "
            f"exception's .trajectory", traj, step, self.t0 + step * self.dt) from None

    # -------------------------------------------------------------- one body's reports
    def _diagnostics(self) -> dict | None:
        if not self.diag:
            return None
        return diagnostics_dict(self.dmax[:1], True, self.dref[0])

    def partial(self, n_keep: int, status: str, failed_at: float | None = None
                ) -> Trajectory:
        """One body's first ``n_keep`` samples (copies), with ``status``."""
        return Trajectory(self._times()[:n_keep].copy(), self.q_one[:n_keep].copy(),
                          self.m_one[:n_keep].copy(), self.scene, self.method, self.dt,
                          failed_at=failed_at, info=self.info, status=status)

    def interrupted_one(self, n_keep: int, step: int):
        """Raise one body's :class:`IntegrationInterrupted`, its ``n_keep`` samples kept."""
        traj = self.partial(n_keep, "interrupted")
        raise IntegrationInterrupted(
            f"{self.method.name}: interrupted after {step:,} of {self.n_steps:,} steps "
            f"(t = {self.t0 + step * self.dt:.6g}); the {n_keep:,} samples computed so far are "
            f"on this exception's .trajectory", traj, step, self.t0 + step * self.dt) from None

    def failed_nonfinite(self, n_keep: int, step: int, t_start: float, t_fail: float,
                         stacklevel: int = 4) -> Trajectory:
        """One body's samples before a non-finite state, and the warning (at
        :func:`integrate`'s caller: ``stacklevel`` counts this method's frame and those
        up to it)."""
        traj = self.partial(n_keep, "failed", failed_at=t_fail)
        warnings.warn(
            f"{self.method.name}: the state became non-finite "
            f"{failed_step_words(step, t_start, t_fail)}; returning the {n_keep:,} samples "
            f"before it (Trajectory.failed_at is set)", RuntimeWarning, stacklevel=stacklevel)
        return traj

    def overflowed(self, stacklevel: int = 4) -> Trajectory:
        """One body's run ended with ``|L|`` beyond :data:`MAX_MOMENTUM` (a torque that
        drives it out of float64's range): the samples before the first such sample are
        returned, with ``failed_at`` set and a warning, as for a non-finite state."""
        size = np.max(np.abs(self.m_one), axis=1)
        k = int(np.argmax(~(size <= MAX_MOMENTUM)))
        step = self._step_of_sample(k)
        t_fail = self.t0 + float(self.t[k])
        traj = self.partial(k, "failed", failed_at=t_fail)
        warnings.warn(
            f"{self.method.name}: |L| reached {size[k]:.3g} by step {step:,} (t = "
            f"{t_fail:.6g}), beyond {MAX_MOMENTUM:.0e}: the torque drove L out of float64's "
            f"range (the kinetic energy |L|^2/(2 I) overflows, and the rotation per step "
            f"is beyond resolution); returning the {k:,} samples before it "
            f"(Trajectory.failed_at is set). Check the torque's size, or rescale the units",
            RuntimeWarning, stacklevel=stacklevel)
        return traj

    def failed(self, status: int, done: int, saved: int, state: np.ndarray,
               stacklevel: int = 5) -> Trajectory:
        """One body's failure after ``done`` steps and ``saved`` samples (``state``: its
        last good state): the error of :func:`failure_error`, raised with the samples
        before it; a blow-up of the dynamics returns them with a warning
        (``stacklevel``: as for :meth:`failed_nonfinite`)."""
        n_keep = 1 + saved
        failure = StepFailure(None, status, done,
                              *failed_step_times(self.t0, done, self.dt), state)
        where = (f"{failed_step_words(done, failure.t, failure.failed_at)}; the {n_keep:,} "
                 f"samples before it are on this exception's .trajectory")
        # failed_at is the time the failing step was to reach, as for a blow-up and for
        # the bodies of an ensemble; the exception's .t is where that step starts
        traj = self.partial(n_keep, "failed", failed_at=failure.failed_at)
        error = failure_error(self.method.name, self.scene, self.model, failure, self.dt,
                              where, traj, self.u, self.reach)
        if error is None:
            return self.failed_nonfinite(n_keep, done, failure.t, failure.failed_at,
                                         stacklevel=stacklevel)
        raise error


class _pool:
    """A thread pool for more than one chunk (none for one: no thread overhead)."""

    def __init__(self, n: int) -> None:
        self.n = n
        self.pool = None

    def __enter__(self):
        if self.n > 1:
            self.pool = ThreadPoolExecutor(max_workers=self.n, initializer=block_interrupts)
        return self.pool

    def __exit__(self, *exc):
        if self.pool is not None:
            self.pool.shutdown(wait=True, cancel_futures=True)
        return False
