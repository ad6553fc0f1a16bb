"""Exceptions and warnings of liebody: nothing fails silently, nothing computed is lost.

A run that cannot be completed raises an :class:`IntegrationError` (or, on Ctrl-C,
:class:`IntegrationInterrupted`) that carries the samples computed before it stopped
as ``.trajectory``, with the step and time where it stopped. A run that completes but
whose result should not be trusted (a state that became non-finite, an invariant the
method should keep that left its tolerance) warns.
"""

from __future__ import annotations

__all__ = ["CacheWarning", "ConvergenceError", "IntegrationError", "IntegrationInterrupted",
           "InvariantWarning", "TorqueError"]


class IntegrationError(RuntimeError):
    """A run stopped before its end.

    Attributes
    ----------
    trajectory : liebody.Trajectory or None
        The samples saved before the failing step (the initial state at least).
    step : int or None
        The steps completed before the failing one (its index counted from 0); for a
        :class:`~liebody.Stepper`, the steps of the failing call that succeeded.
    t : float or None
        The time of the last good state, where the failing step starts: ``t0 + step dt``
        (a Stepper's clock after the steps that succeeded). The step was to reach
        ``t + dt``, the trajectory's ``failed_at``. The message names the same three
        numbers: "in the step from t = <t> to t = <t + dt> (after <step> steps)".
    """

    def __init__(self, message: str, trajectory=None, step: int | None = None,
                 t: float | None = None) -> None:
        super().__init__(message)
        self.trajectory = trajectory
        self.step = step
        self.t = t


class ConvergenceError(IntegrationError):
    """An implicit equation (RATTLE/DMV's, or the implicit kick of a torque that depends
    on ``L``) was not solved at some step."""


class TorqueError(IntegrationError):
    """A user torque raised, or returned something other than three finite numbers.

    The torque's own exception, where there is one, is the ``__cause__``.
    """


class IntegrationInterrupted(KeyboardInterrupt):
    """Ctrl-C (``KeyboardInterrupt``) during a run: the samples computed so far are kept.

    Catching ``KeyboardInterrupt`` catches it too. Attributes as :class:`IntegrationError`.
    """

    def __init__(self, message: str, trajectory=None, step: int | None = None,
                 t: float | None = None) -> None:
        super().__init__(message)
        self.trajectory = trajectory
        self.step = step
        self.t = t


class InvariantWarning(RuntimeWarning):
    """A run completed, but an invariant its method should keep (or ``|q| = 1``) has left
    its tolerance by the end: the step is too large for the scene, or the method is a
    baseline that does not keep it."""


class CacheWarning(RuntimeWarning):
    """numba's disk cache could not be used as it should; the results are not affected.

    Emitted once per process and kind:

    * no writable cache folder (e.g. a read-only install), or a save that failed: the
      kernels compile in every new process. Set the environment variable
      ``NUMBA_CACHE_DIR`` to a writable folder to cache compiled kernels again;
    * a damaged cache file (a truncated or overwritten ``*.nbi``/``*.nbc``): it is
      deleted, the kernel compiles again and its new entry replaces it. The warning names
      the file and how to clear the cache (delete the folder, or point
      ``NUMBA_CACHE_DIR`` at an empty one).
    """

