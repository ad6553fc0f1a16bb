"""``integrate()``: validate, choose and plan the method, run the kernel, wrap the result.

Contract (a template method, after scipy's ``OdeSolver``):

1. validate every argument (``ValueError``/``TypeError`` naming it and the rule);
2. resolve the method (``None`` -> the scene's default) and check it supports the scene;
3. plan it: a stage table made concrete for this body, initial state and step
   (set-up choices such as the axis ordering are recorded in ``Trajectory.info``);
4. run the one driver kernel (in chunks when a progress bar is asked for), which
   keeps the state in registers and writes only the saved samples;
5. wrap the samples in a :class:`~liebody.trajectory.Trajectory`; a run that produced
   a non-finite state stops there, warns, and sets ``failed_at``.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from liebody import _methods
from liebody._kernels import stages as S
from liebody._validate import as_float_array, as_positive_float, as_positive_int
from liebody._validate import as_unit_quaternion as _as_unit_q
from liebody.scenes import Scene
from liebody.trajectory import Trajectory

__all__ = ["ConvergenceError", "integrate"]

_PROGRESS_CHUNKS = 200
#: the most samples a run may keep (about 56 GB); beyond it save_every must grow
MAX_SAMPLES = 10**9


class ConvergenceError(RuntimeError):
    """An implicit method (``rattle``) failed to solve its step equation."""


def _initial_momentum(body, L0, omega0) -> np.ndarray:
    if (L0 is None) == (omega0 is None):
        raise ValueError("give exactly one of L0 (body angular momentum) and omega0 "
                         "(body angular velocity)")
    if L0 is not None:
        return as_float_array("L0", L0, shape=(3,)).copy()
    return body.moments * as_float_array("omega0", omega0, shape=(3,))


def _step_count(dt: float, steps, t_end) -> int:
    if (steps is None) == (t_end is None):
        raise ValueError("give exactly one of steps and t_end")
    if steps is not None:
        return as_positive_int("steps", steps)
    t_end = as_positive_float("t_end", t_end)
    n = t_end / dt
    k = round(n)
    if k < 1 or abs(n - k) > 1e-9 * max(1.0, n):
        raise ValueError(
            f"t_end must be a whole number of steps dt: t_end/dt = {n!r}; choose dt = "
            f"t_end/k for an integer k, or pass steps= instead")
    return int(k)


def integrate(scene, *, q0=(1.0, 0.0, 0.0, 0.0), L0=None, omega0=None, dt, steps=None,
              t_end=None, method=None, save_every=1, progress: bool = False) -> Trajectory:
    """Integrate a rigid-body scene with a fixed step.

    Parameters
    ----------
    scene
        What to integrate, e.g. :class:`liebody.FreeBody`.
    q0
        Initial orientation, scalar-first unit quaternion (body -> space). Its norm
        must be 1 within 1e-10 (normalise with :func:`liebody.quaternion.normalize`).
    L0, omega0
        Exactly one: initial body-frame angular momentum or angular velocity.
    dt
        Step size (> 0). For ``method="exact"`` it only sets the output spacing.
    steps, t_end
        Exactly one: number of steps, or final time (a whole multiple of ``dt``).
    method
        A name from :func:`liebody.methods` or ``None`` for the scene's default. For a
        :class:`~liebody.FreeBody` the default is ``"exact"``: the free body is
        integrable, so its exact flow is evaluated at the output times and no time
        stepping (and no discretisation error) is spent on it.
    save_every
        Keep every ``save_every``-th step (plus the start and the final state); memory
        is exactly the saved samples.
    progress
        Show a tqdm progress bar, running the kernel in chunks.

    Returns
    -------
    Trajectory
        ``t``, ``q``, ``L`` (body) and derived diagnostics. A baseline that blows up
        (non-finite state) returns the samples before the failure, sets
        ``failed_at`` and emits a ``RuntimeWarning``.

    Raises
    ------
    ValueError, TypeError
        Invalid arguments (each message names the argument and the rule).
    ConvergenceError
        ``rattle``'s implicit equation did not converge (step far too large).
    """
    if not isinstance(scene, Scene):
        raise TypeError(f"scene must be a liebody scene (FreeBody, HeavyTop, TorqueBody, "
                        f"DampedBody or a subclass of liebody.Scene), got {type(scene).__name__}")
    body = scene.body
    q_init = _as_unit_q("q0", q0)
    if q_init.shape != (4,):
        raise ValueError(f"q0 must have shape (4,), got {q_init.shape}")
    m_init = _initial_momentum(body, L0, omega0)
    dt = as_positive_float("dt", dt)
    n_steps = _step_count(dt, steps, t_end)
    save_every = as_positive_int("save_every", save_every)
    if not isinstance(progress, bool | np.bool_):
        raise TypeError(f"progress must be True or False, got {type(progress).__name__}")

    method = _methods.get(scene.default_method if method is None else method)
    _methods.check_supports(method, scene)

    # sample indices: 0, save_every, 2 save_every, ..., and the final step
    n_saves = n_steps // save_every + (1 if n_steps % save_every else 0)
    if n_saves > MAX_SAMPLES:
        raise ValueError(
            f"the run would save {n_saves + 1} samples ({56 * (n_saves + 1) / 1e9:.1f} GB): "
            f"more than {MAX_SAMPLES}; raise save_every (steps = {n_steps}, dt = {dt:g})")
    q_out = np.empty((n_saves + 1, 4))
    m_out = np.empty((n_saves + 1, 3))
    q_out[0], m_out[0] = q_init, m_init
    step_index = np.minimum(np.arange(n_saves + 1, dtype=np.int64) * save_every, n_steps)
    t = step_index * dt

    if method.sampled:
        from liebody._kernels.exact import exact_flow_times

        moments = np.ascontiguousarray(body.moments, dtype=np.float64)
        for a, b in _slices(len(t), 1, progress, "sample"):
            exact_flow_times(moments, q_init, m_init, t[a:b], q_out[a:b], m_out[a:b])
        return Trajectory(t, q_out, m_out, scene, method, dt)

    plan = method.plan(scene, m_init, dt)
    steps_done, n_saved, status = _run(plan, dt, n_steps, save_every, q_init, m_init,
                                       q_out[1:], m_out[1:], progress,
                                       scene.torque_model().callback)
    if status == S.STATUS_BAD_STAGE:  # pragma: no cover - a plan the family cannot run
        raise RuntimeError(f"{method.name}: the plan holds a stage its driver family "
                           f"{plan.family} does not run (a bug in its recipe)")
    if status in (S.STATUS_NO_CONVERGENCE, S.STATUS_KICK_NO_CONVERGENCE):
        raise ConvergenceError(
            f"{method.name}: the implicit step equation did not converge at step "
            f"{steps_done} (t = {steps_done * dt:g}); reduce dt (h|omega| is too large)")
    failed_at = None
    if status != S.STATUS_OK:
        failed_at = (steps_done + 1) * dt
        n_keep = 1 + n_saved
        q_out, m_out, t = q_out[:n_keep].copy(), m_out[:n_keep].copy(), t[:n_keep].copy()
        warnings.warn(
            f"{method.name}: the state became non-finite at step {steps_done + 1} "
            f"(t = {failed_at:g}); returning the {n_keep} samples before it "
            f"(Trajectory.failed_at is set)", RuntimeWarning, stacklevel=2)
    return Trajectory(t, q_out, m_out, scene, method, dt, failed_at=failed_at, info=plan.info)


def _slices(total: int, quantum: int, progress: bool, unit: str):
    """``(start, stop)`` pairs covering ``range(total)``: one slice, or, with a tqdm bar,
    about ``_PROGRESS_CHUNKS`` slices of whole ``quantum``s (the bar counts ``unit``s)."""
    if not progress:
        yield 0, total
        return
    from tqdm.auto import tqdm

    size = max(quantum, math.ceil(total / _PROGRESS_CHUNKS / quantum) * quantum)
    with tqdm(total=total, unit=unit, unit_scale=True) as bar:
        for start in range(0, total, size):
            stop = min(total, start + size)
            yield start, stop
            bar.update(stop - start)


def _run(plan, dt, n_steps, save_every, q_init, m_init, q_out, m_out, progress, torque_fn):
    """Run the driver over slices of whole save intervals; stop at the first failure."""
    from liebody._kernels.driver import run

    state = np.concatenate([q_init, m_init])
    args = (plan.family, plan.kinds, plan.axes, plan.coefs, plan.clock, plan.params, dt)
    done = saved = 0
    for a, b in _slices(n_steps, save_every, progress, "step"):
        d, s, status = run(*args, a * dt, b - a, save_every, plan.merge_ends, state,
                           q_out[saved:], m_out[saved:], torque_fn)
        done += d
        saved += s
        if status != S.STATUS_OK:
            return done, saved, status
    return done, saved, S.STATUS_OK
