"""Ensembles: :func:`liebody.integrate` for ``N`` bodies in one call.

The bodies share the scene's kind and the method; their initial states (``q0`` ``(N, 4)``,
``L0``/``omega0`` ``(N, 3)``) and the scene's parameters (moments ``(N, 3)``, a heavy
top's mass and centre of mass, a damping strength) may differ, broadcast like numpy
arrays. The recipe plans all bodies at once (``liebody._plan``): bodies whose steps
share a structure (the same axis ordering, say) form a group with per-body parameters.
Each group runs in the batch driver of its family, split into contiguous chunks of
bodies over ``threads`` threads (the kernels release the GIL) and into time slices (so
Ctrl-C stops it within about a second).

Failures are per body: a body whose state becomes non-finite, whose implicit equation
has no solution or whose torque fails stops there (``failed_at`` per body, its later
samples NaN) and the others finish; one warning sums up.
"""

from __future__ import annotations

import itertools
import warnings
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from liebody._engine import (  # noqa: F401 - REASONS and failure_message: re-exported
    REASONS,
    batch_args,
    block_interrupts,
    diagnostic_reference,
    diagnostics_dict,
    failure_message,
    failure_summary,
    first_slice,
    groups_info,
    interrupt_after_call,
    resolve_threads,
    sample_diagnostics,
    time_slices,
    warn_invariants,
    widest_reach,
    with_controls,
)
from liebody._kernels import stages as S
from liebody.errors import IntegrationInterrupted
from liebody.trajectory import Trajectory


class EnsembleRun:
    """One :func:`liebody.integrate` call for ``N`` bodies, after validation."""

    def __init__(self, scene, method, q0, m0, dt, n_steps, save_every, t, model, progress,
                 threads, diagnostics=False, u=None, t0=0.0, simd=None):
        self.scene, self.method, self.dt = scene, method, dt
        self.q0, self.m0 = q0, m0
        self.n_steps, self.save_every, self.t = n_steps, save_every, t
        self.model, self.progress = model, progress
        self.threads = threads
        self.u = u  # the controls: (k,) or (N, k), or None
        self.t0 = t0  # the start time; self.t holds the sample times relative to it
        self.simd = simd  # None: automatic; True / False: where supported / never
        self.slices = time_slices
        self.reach = (0.0, 1.0)  # the times the plans' stages read, in steps (Plan.reach)
        n, k = q0.shape[0], t.shape[0]
        self.q_out = np.empty((n, k, 4))
        self.m_out = np.empty((n, k, 3))
        self.q_out[:, 0], self.m_out[:, 0] = q0, m0
        self.status = np.zeros(n, dtype=np.int64)
        self.state = np.empty((n, 7))  # each body's last good state
        self.done = np.zeros(n, dtype=np.int64)
        self.saved = np.zeros(n, dtype=np.int64)
        self.info: dict = {}
        self.diag = diagnostics
        # (without diagnostics the drivers never read them: rows of no numbers, no memory)
        self.dref = (diagnostic_reference(scene, model, q0, m0, t0) if diagnostics
                     else np.zeros((n, 0)))
        self.dmax = np.zeros((n, 3 if diagnostics else 0))
        #: the body of each row of the samples while the groups run (None: body order)
        self.order: np.ndarray | None = None

    @property
    def n(self) -> int:
        return self.q0.shape[0]

    def _chunks(self, n: int) -> list[slice]:
        """Contiguous chunks of ``n`` bodies, one per thread (at least 64 bodies each)."""
        parts = max(1, min(self.threads, n // 64))
        edges = np.linspace(0, n, parts + 1).round().astype(int)
        return [slice(a, b) for a, b in itertools.pairwise(edges) if b > a]

    def _map(self, pool, fn, chunks):
        if pool is None:
            return [fn(c) for c in chunks]
        return [f.result() for f in [pool.submit(fn, c) for c in chunks]]

    # -------------------------------------------------------------- the exact flow
    def sampled(self) -> Trajectory:
        from liebody._kernels.exact import exact_flow_bodies

        self.info = {"simd": False}  # (no SIMD kernel evaluates the exact flow)
        moments = np.ascontiguousarray(np.broadcast_to(self.scene.moments, (self.n, 3)))
        t, q, m = self.t, self.q_out, self.m_out
        chunks = self._chunks(self.n)
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

    # -------------------------------------------------------------- stepping
    def _runner(self, plan):
        """The batch driver of a plan: the SIMD one where it applies, else the one-body
        loop per body; and whether it is the SIMD one."""
        from liebody._kernels.batch_drivers import BATCH_RUNNERS, DIAG_BATCH_RUNNERS

        wanted = self.simd is not False and (self.simd or self.n >= _simd().SIMD_MIN_BODIES)
        if wanted and _simd().simd_supports(plan, self.model.code):
            return _simd().SIMD_RUNNERS[(plan.family, bool(self.diag))], True
        return (DIAG_BATCH_RUNNERS if self.diag else BATCH_RUNNERS)[plan.family], False

    def stepped(self) -> Trajectory:
        groups = self.method.plans(self.scene, self.m0, self.dt)
        runners = [self._runner(plan) for _, plan in groups]
        self.info = groups_info(groups, runners)
        self.reach = widest_reach(plan.reach for _, plan in groups)
        if len(groups) > 1:  # each group on contiguous rows of the samples, in this order
            self.order = np.concatenate([idx for idx, _ in groups])
            self.q_out[:, 0], self.m_out[:, 0] = self.q0[self.order], self.m0[self.order]
        starts = np.cumsum([0] + [len(idx) for idx, _ in groups[:-1]])
        work = [self._group(idx, plan, r[0], r[1], slice(a, a + len(idx)))
                for (idx, plan), r, a in zip(groups, runners, starts, strict=True)]
        chunks = [(g, c) for g in work for c in self._chunks(len(g["idx"]))]
        done = 0
        with _pool(min(self.threads, len(chunks))) as pool:
            try:
                for k in self.slices(self.n_steps, self.progress, "step",
                                     max(1, first_slice(self.model) // self.n)):
                    final = done + k == self.n_steps
                    # Ctrl-C is delivered once every chunk has finished the slice and it
                    # is counted (the pool's threads never take SIGINT): finished slices
                    # are kept, and no thread writes while the result is made
                    with interrupt_after_call():
                        self._map(pool, lambda gc, done=done, k=k, final=final:
                                  self._run_chunk(gc[0], gc[1], done, k, final), chunks)
                        done += k
            except KeyboardInterrupt:
                self._collect(work)
                self._interrupted(1 + done // self.save_every)
        self._collect(work)
        return self._result(len(self.t))

    def _group(self, idx, plan, runner, simd: bool = False, rows: slice = slice(None)
               ) -> dict:
        """A group's arrays: views of the ensemble's when its bodies are all of them; its
        samples are the rows ``rows`` of the ensemble's (in the groups' order, put back in
        body order by :meth:`_collect`)."""
        whole = len(idx) == self.n
        sel = slice(None) if whole else idx
        # "saved" starts at 1: the kernel writes sample 1 + (samples saved so far)
        params = with_controls(plan.params, None if self.u is None else (
            self.u if self.u.ndim == 1 else self.u[sel]), len(idx))
        g = {"idx": idx, "plan": plan, "params": params, "runner": runner, "whole": whole,
             "addr": self.model.driver_address(simd),
             "state": np.ascontiguousarray(np.concatenate([self.q0[sel], self.m0[sel]], axis=1)),
             "ctl": np.tile(np.array([self.save_every, 0], dtype=np.int64), (len(idx), 1)),
             "saved": np.ones(len(idx), dtype=np.int64),
             "done": np.zeros(len(idx), dtype=np.int64),
             "status": np.zeros(len(idx), dtype=np.int64),
             "dref": self.dref[sel], "dmax": np.zeros((len(idx), self.dmax.shape[1]))}
        g["q"], g["m"] = self.q_out[rows], self.m_out[rows]
        return g

    def _run_chunk(self, g, c: slice, done: int, k: int, final: bool) -> None:
        p = g["plan"]
        g["runner"](*batch_args(p, g["params"], p.merge_ends and not self.diag, self.dt, self.t0,
                                float(done), k, self.save_every, final, g["state"][c],
                                g["ctl"][c], g["q"][c], g["m"][c], g["saved"][c],
                                g["done"][c], g["status"][c], g["addr"], c,
                                g["dref"][c], g["dmax"][c]))

    def _collect(self, work) -> None:
        if self.order is not None:  # the samples back in body order (once)
            from liebody._kernels.rows import unpermute_rows

            order, self.order = self.order, None
            for a in (self.q_out, self.m_out):
                unpermute_rows(a.reshape(self.n, -1), order, np.zeros(self.n, dtype=np.bool_))
        for g in work:
            idx = g["idx"]
            self.status[idx] = g["status"]
            self.state[idx] = g["state"]
            self.done[idx] = g["done"]
            self.saved[idx] = g["saved"] - 1
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

    def _times(self) -> np.ndarray:
        """The sample times ``t0 + t``."""
        return self.t if self.t0 == 0.0 else self.t0 + self.t


def _simd():
    """The SIMD kernels' module (imported on the first ensemble that steps)."""
    from liebody._kernels import batch

    return batch


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
