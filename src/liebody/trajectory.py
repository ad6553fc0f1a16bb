"""The result of :func:`liebody.integrate`: saved samples and derived diagnostics."""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from liebody._methods import Method


@dataclass(frozen=True)
class Trajectory:
    """Saved samples of a run. Memory is exactly the saved samples.

    Attributes
    ----------
    t : (n,) array
        Sample times.
    q : (n, 4) array
        Orientation, scalar-first unit quaternions (body -> space).
    L : (n, 3) array
        Body-frame angular momentum (principal axes).
    scene, method, dt
        What was integrated, how, and the step.
    failed_at : float or None
        Time of the first step that produced a non-finite state (baselines that blow
        up); the samples stop before it. ``None`` for a complete run.
    info : dict
        Choices made at set-up (axis ordering, base of a composition, ...).
    status : str
        ``"complete"``; ``"failed"`` (a non-finite state, a failed implicit solve or a
        failing torque: the samples stop before the failing step); ``"interrupted"``
        (Ctrl-C: the samples computed so far).

    The arrays are read-only: derived quantities (``orientation``, energies, ...) are
    computed from them once and stay valid.
    """

    t: np.ndarray
    q: np.ndarray
    L: np.ndarray
    scene: object
    method: Method
    dt: float
    failed_at: float | None = None
    info: dict = field(default_factory=dict)
    status: str = "complete"

    def __post_init__(self) -> None:
        for name in ("t", "q", "L"):
            arr = getattr(self, name)
            if arr.flags.writeable:
                arr = arr.view()
                arr.flags.writeable = False
                object.__setattr__(self, name, arr)

    def __len__(self) -> int:
        return int(self.t.shape[0])

    @property
    def moments(self) -> np.ndarray:
        return self.scene.body.moments

    @property
    def omega(self) -> np.ndarray:
        """Body-frame angular velocity ``omega_i = L_i / I_i``."""
        return self.L / self.moments

    @property
    def kinetic_energy(self) -> np.ndarray:
        """``T = sum L_i^2 / (2 I_i)``."""
        return 0.5 * np.sum(self.L * self.L / self.moments, axis=-1)

    @cached_property
    def orientation(self) -> np.ndarray:
        """``q / |q|``: the rotation the samples stand for (the baselines let ``|q|`` drift).

        Computed once (energy, ``L_space``, ``omega_space`` and the Euler angles all
        use it) and read-only.
        """
        from liebody import quaternion

        out = quaternion.normalize(self.q) if len(self) else self.q.copy()
        out.flags.writeable = False
        return out

    @property
    def potential_energy(self) -> np.ndarray:
        """The scene's potential at the samples (zero for a free body)."""
        return self.scene.potential(self.orientation)

    @property
    def energy(self) -> np.ndarray:
        """Total energy: kinetic plus the scene's potential."""
        return self.kinetic_energy + self.potential_energy

    @property
    def L_space(self) -> np.ndarray:
        """Space-frame angular momentum ``R(q) L`` (constant for a free body)."""
        from liebody import quaternion

        return quaternion.rotate(self.orientation, self.L) if len(self) else np.empty((0, 3))

    @property
    def omega_space(self) -> np.ndarray:
        """Space-frame angular velocity ``R(q) omega``."""
        from liebody import quaternion

        return (quaternion.rotate(self.orientation, self.omega) if len(self)
                else np.empty((0, 3)))

    @property
    def casimir(self) -> np.ndarray:
        """``|L|`` (a Casimir of the Lie–Poisson bracket)."""
        return np.linalg.norm(self.L, axis=-1)

    @property
    def quaternion_norm(self) -> np.ndarray:
        """``|q|`` (1 for methods that stay on the unit sphere)."""
        return np.linalg.norm(self.q, axis=-1)

    def euler_angles(self, unwrap: bool = False) -> np.ndarray:
        """The z-x-z Euler angles ``(phi, theta, psi)`` of :mod:`liebody.euler` (Hand & Finch,
        ch. 8), shape ``(n, 3)``.

        ``unwrap=True`` removes the ``2 pi`` jumps of ``phi`` and ``psi`` for plotting
        long histories.
        """
        from liebody import euler

        angles = euler.from_quaternion(self.orientation)
        return euler.unwrap(angles) if unwrap else angles

    def __repr__(self) -> str:
        status = (f"failed at t={self.failed_at:g}" if self.failed_at is not None
                  else self.status)
        return (f"Trajectory(method={self.method.name!r}, dt={self.dt:g}, samples={len(self)}, "
                f"t=[{self.t[0] if len(self) else 0:g}, {self.t[-1] if len(self) else 0:g}], "
                f"{status})")
