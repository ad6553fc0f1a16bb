"""The result of :func:`liebody.integrate`: saved samples and derived diagnostics."""

from __future__ import annotations

import numbers
from dataclasses import MISSING, dataclass, field, fields
from functools import cached_property
from typing import NamedTuple

import numpy as np

from liebody._methods import Method


class Failure(NamedTuple):
    """One body's failure, as a record: which body (``None`` for a one-body run), the
    time the failing step was to reach, and why (``"non-finite state"``, ``"DMV equation
    not solved"``, ``"implicit kick not solved"``, ``"torque failed"``)."""

    body: int | None
    t: float
    reason: str


#: the fields' defaults of :class:`Trajectory` (and subclasses), for ``_complete``
_DEFAULTS: dict = {}


#: a unit quaternion standing in for a failed sample's orientation
_IDENTITY = np.array([1.0, 0.0, 0.0, 0.0])


def _takes_time(potential) -> bool:
    """Whether a scene's ``potential`` takes the time as a second argument
    (``potential(q, t)``, as the time-dependent scenes define it; ``potential(q)`` for
    the others and for a user's subclass that says nothing of time)."""
    import inspect

    try:
        params = list(inspect.signature(potential).parameters.values())
    except (TypeError, ValueError):
        return False
    return len(params) >= 2 and params[1].kind in (
        inspect.Parameter.POSITIONAL_ONLY, inspect.Parameter.POSITIONAL_OR_KEYWORD)


@dataclass(frozen=True, eq=False)
class Trajectory:
    """Saved samples of a run. Memory is exactly the saved samples.

    Attributes
    ----------
    t : (n,) array
        Sample times.
    q : (n, 4) array
        Orientation, scalar-first unit quaternions (body -> space); ``(N, n, 4)`` for an
        ensemble of ``N`` bodies.
    L : (n, 3) array
        Body-frame angular momentum (principal axes); ``(N, n, 3)`` for an ensemble.
    scene, method, dt
        What was integrated, how, and the step.
    failed_at : float or None
        The time the failing step was to reach (its end): the first step that produced
        a non-finite state (baselines that blow up), whose implicit equation had no
        solution, or whose torque failed; the samples stop before it. After ``k`` good
        steps from ``t0`` it is ``t0 + (k + 1) dt``, the time its sample would have had
        (the error a failure raises carries ``step = k`` and ``t = t0 + k dt``, the
        step's start). ``None`` for a complete run. For an ensemble, an array ``(N,)``:
        that time per body, NaN for bodies that completed.
    info : dict
        Choices made at set-up (axis ordering, base of a composition, ...). For the
        axis splittings, ``energy_error_constant`` is the range over the orbit of the
        leading term of the modified Hamiltonian of the ordering chosen (the energy
        error is about ``h^2`` times it; Fassò 2003); NaN for a gyrostat, whose
        ordering is fixed at ``(0, 1, 2)`` (the choice weighs the rigid body's
        splitting error, which does not apply).
    status : str
        ``"complete"``; ``"failed"`` (a non-finite state, a failed implicit solve or a
        failing torque: the samples stop before the failing step); ``"interrupted"``
        (Ctrl-C: the samples computed so far). For an ensemble, an array ``(N,)`` per
        body (``"failed: non-finite state"``, ...); :attr:`failures` gives the failed
        bodies as records.

    diagnostics : dict or None
        With ``integrate(..., diagnostics=True)``: ``max_energy_error``,
        ``max_qnorm_error`` and ``max_casimir_error`` over every step of the run (per
        body for an ensemble).
    wheels : (n, k) array or None
        The wheels' absolute axial angular momenta at the samples, for a
        :class:`~liebody.ReactionWheels` scene (``(N, n, k)`` for an ensemble); ``None``
        otherwise.
    saturations : tuple of Saturation
        The wheels' saturations (:class:`liebody.wheels.Saturation` records: body, time,
        wheel, ``"torque"`` or ``"speed"``), in time order; empty when none.

    The arrays are read-only: derived quantities (``orientation``, energies, ...) are
    computed from them once and stay valid.

    Equality is identity: ``a == b`` only if ``a is b`` (and trajectories hash by
    identity). Two runs with the same numbers are distinct results; compare their
    samples with ``numpy.array_equal(a.q, b.q)`` etc.
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
    diagnostics: dict | None = None
    wheels: np.ndarray | None = None
    saturations: tuple = ()

    def __post_init__(self) -> None:
        for name in ("t", "q", "L", "failed_at", "status"):  # (per-body arrays of ensembles)
            arr = getattr(self, name)
            if isinstance(arr, np.ndarray) and arr.flags.writeable:
                arr = arr.view()
                arr.flags.writeable = False
                object.__setattr__(self, name, arr)
        if self.diagnostics:
            for value in self.diagnostics.values():
                if isinstance(value, np.ndarray):
                    value.flags.writeable = False

    @classmethod
    def _complete(cls, t: np.ndarray, q: np.ndarray, L: np.ndarray, scene, method, dt: float,
                  info: dict, diagnostics: dict | None) -> Trajectory:
        """A complete run's trajectory, as ``Trajectory(t, q, L, scene, method, dt,
        info=info, diagnostics=diagnostics)`` builds it, without the dataclass machinery
        (the one-body run's fixed cost): ``q`` and ``L`` must be read-only already (the
        caller's promise: not checked)."""
        if t.flags.writeable:
            t = t.view()
            t.flags.writeable = False
        obj = object.__new__(cls)
        d = obj.__dict__
        defaults = _DEFAULTS.get(cls)
        if defaults is None:  # every field's default, once per class
            defaults = _DEFAULTS[cls] = {f.name: f.default for f in fields(cls)
                                         if f.default is not MISSING}
        d.update(defaults)
        d["t"] = t
        d["q"] = q
        d["L"] = L
        d["scene"] = scene
        d["method"] = method
        d["dt"] = dt
        d["info"] = info
        d["diagnostics"] = diagnostics
        if diagnostics:
            for value in diagnostics.values():
                if isinstance(value, np.ndarray):
                    value.flags.writeable = False
        return obj

    def __len__(self) -> int:
        return int(self.t.shape[0])

    @property
    def failures(self) -> tuple[Failure, ...]:
        """The failed bodies as records (``Failure``: body, time, reason), in body
        order; empty for a complete or interrupted run. Read these rather than the
        warning's words."""
        if np.ndim(self.status) == 0:
            if self.failed_at is None:
                return ()
            reason = str(self.status)[8:] if str(self.status).startswith("failed: ") else ""
            return (Failure(None, float(self.failed_at), reason or "failed"),)
        status = np.asarray(self.status)
        at = np.asarray(self.failed_at, dtype=float)
        return tuple(Failure(int(i), float(at[i]), str(status[i])[8:] or "failed")
                     for i in range(status.shape[0]) if str(status[i]).startswith("failed"))

    @property
    def n_bodies(self) -> int | None:
        """The number of bodies of an ensemble run; ``None`` for one body."""
        return self.q.shape[0] if self.q.ndim == 3 else None

    def body(self, i: int) -> Trajectory:
        """Body ``i`` of an ensemble run as a one-body trajectory.

        Its samples are those body ``i`` reached (a failed body's NaN samples after its
        failure are left out), its scene is ``scene.take(i)`` when the scene is batched,
        and ``failed_at``, ``status`` and ``diagnostics`` are body ``i``'s. The arrays
        are views of this trajectory's (read-only).

        Parameters
        ----------
        i : int
            Index of the body, ``-n_bodies <= i < n_bodies``.

        Raises
        ------
        ValueError
            A one-body trajectory (it has no bodies to pick), or ``i`` out of range.
        TypeError
            ``i`` not an integer.
        """
        n = self.n_bodies
        if n is None:
            raise ValueError("body(i) picks one body of an ensemble trajectory (q of shape "
                             f"(N, n, 4)); this one is one body's (q of shape {self.q.shape})")
        if isinstance(i, bool | np.bool_) or not isinstance(i, numbers.Integral):
            raise TypeError(f"i must be an integer body index, got {type(i).__name__}")
        if not -n <= int(i) < n:
            raise ValueError(f"i must be a body index in [-{n}, {n}), got {int(i)}")
        i = int(i) % n
        q, L = self.q[i], self.L[i]
        ok = np.isfinite(q).all(axis=-1) & np.isfinite(L).all(axis=-1)
        keep = len(ok) if ok.all() else int(np.argmin(ok))  # finite samples come first
        failed = None if self.failed_at is None else float(np.asarray(self.failed_at)[i])
        scene = self.scene.take(i) if getattr(self.scene, "batch_shape", ()) else self.scene
        diag = None
        if self.diagnostics is not None:
            diag = {k: (float(np.asarray(v)[i]) if np.ndim(v) else v)
                    for k, v in self.diagnostics.items()}
        wheels, sat = None, ()
        if self.wheels is not None:
            wheels = self.wheels[i, :keep]
            sat = tuple(s._replace(body=None) for s in self.saturations if s.body == i)
        return Trajectory(self.t[:keep], q[:keep], L[:keep], scene, self.method, self.dt,
                          failed_at=None if failed is None or np.isnan(failed) else failed,
                          info=self.info, status=str(np.asarray(self.status)[i]),
                          diagnostics=diag, wheels=wheels, saturations=sat)

    @property
    def moments(self) -> np.ndarray:
        """Principal moments, shaped to broadcast against ``L``: ``(3,)``, or ``(N, 1, 3)``
        for an ensemble whose bodies differ."""
        m = np.asarray(self.scene.moments, dtype=float)
        return m[:, None, :] if (m.ndim == 2 and self.q.ndim == 3) else m

    @property
    def _rotor(self):
        """A gyrostat's rotor momentum ``l``, shaped to broadcast against ``L`` (``None``
        for a rigid body)."""
        l = getattr(self.scene, "rotor_momentum", None)
        if l is None:
            return None
        l = np.asarray(l, dtype=float)
        return l[:, None, :] if (l.ndim == 2 and self.q.ndim == 3) else l

    @property
    def omega(self) -> np.ndarray:
        """Body-frame angular velocity ``omega_i = L_i / I_i`` (a gyrostat's
        ``(L_i - l_i) / I_i``, ``l`` its rotor momentum; with reaction wheels
        (:attr:`wheels`) ``l = A h`` at each sample)."""
        l = self._rotor if self.wheels is None else self.scene.rotor_momentum_of(self.wheels)
        return (self.L if l is None else self.L - l) / self.moments

    @property
    def kinetic_energy(self) -> np.ndarray:
        """``T = sum L_i^2 / (2 I_i)`` (a gyrostat's ``sum (L_i - l_i)^2 / (2 I_i)``); with
        reaction wheels (:attr:`wheels`) the scene's
        kinetic energy of body and wheels,
        ``(L - A h)^T I^-1 (L - A h) / 2 + sum_k h_k^2 / (2 J_k)``."""
        if self.wheels is not None:
            return self.scene.kinetic_energy(self.L, self.wheels)
        l = self._rotor
        d = self.L if l is None else self.L - l  # a gyrostat: (L - l)^T I^-1 (L - l) / 2
        return 0.5 * np.sum(d * d / self.moments, axis=-1)

    def _finite(self) -> np.ndarray:
        """Mask of the samples with a finite state (an ensemble's failed bodies have NaN
        samples after their failure)."""
        return np.isfinite(self.q).all(axis=-1) & np.isfinite(self.L).all(axis=-1)

    def _on_finite(self, fn, width: int | None, *arrays) -> np.ndarray:
        """``fn(*arrays)`` on the finite samples, NaN elsewhere (every sample of a one-body
        run is finite: a run stops before a non-finite state)."""
        mask = self._finite()
        if mask.all():
            return fn(*arrays)
        shape = mask.shape + ((width,) if width else ())
        out = np.full(shape, np.nan)
        if mask.any():
            out[mask] = fn(*(a[mask] for a in arrays))
        return out

    @cached_property
    def orientation(self) -> np.ndarray:
        """``q / |q|``: the rotation the samples stand for (the baselines let ``|q|`` drift).

        Computed once (energy, ``L_space``, ``omega_space`` and the Euler angles all
        use it) and read-only.
        """
        from liebody import quaternion

        out = (self._on_finite(quaternion.normalize, 4, self.q) if len(self)
               else self.q.copy())
        out.flags.writeable = False
        return out

    @property
    def potential_energy(self) -> np.ndarray:
        """The scene's potential at the samples (zero for a free body): at their orientations
        and, for a scene whose ``potential(q, t)`` takes the time (a
        :class:`~liebody.GravityGradient`, a :class:`~liebody.TorqueBody`), at their times.
        An ensemble's failed samples are NaN; its bodies keep their axis (per-body
        parameters read each body's row)."""
        q = self.orientation
        mask = self._finite()
        whole = bool(mask.all())
        if not whole:  # (a unit placeholder where a body failed: its V is set to NaN)
            q = np.where(mask[..., None], q, _IDENTITY)
        potential = self.scene.potential
        if _takes_time(potential):
            V = potential(q, np.broadcast_to(self.t, q.shape[:-1]))
        else:
            V = potential(q)
        V = np.asarray(V, dtype=float)
        return V if whole else np.where(mask, V, np.nan)

    @property
    def energy(self) -> np.ndarray:
        """Total energy: kinetic plus the scene's potential."""
        return self.kinetic_energy + self.potential_energy

    @property
    def L_space(self) -> np.ndarray:
        """Space-frame angular momentum ``R(q) L`` (constant for a free body)."""
        from liebody import quaternion

        if not len(self):
            return np.empty(self.L.shape)
        return self._on_finite(quaternion.rotate, 3, self.orientation, self.L)

    @property
    def omega_space(self) -> np.ndarray:
        """Space-frame angular velocity ``R(q) omega``."""
        from liebody import quaternion

        if not len(self):
            return np.empty(self.L.shape)
        omega = np.broadcast_to(self.omega, self.L.shape)
        return self._on_finite(quaternion.rotate, 3, self.orientation, omega)

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
        ch. 8), shape ``(n, 3)`` (``(N, n, 3)`` for an ensemble).

        ``unwrap=True`` removes the ``2 pi`` jumps of ``phi`` and ``psi`` along the
        samples, for plotting long histories.
        """
        from liebody import euler

        angles = self._on_finite(euler.from_quaternion, 3, self.orientation)
        if not unwrap:
            return angles
        mask = self._finite()
        if mask.all():
            return euler.unwrap(angles, axis=-2)
        out = angles.copy()  # a failed body: unwrap its samples before the failure
        rows = out if out.ndim == 3 else out[None]
        for body, ok in zip(rows, mask if mask.ndim == 2 else mask[None], strict=True):
            n = int(ok.sum())  # the finite samples are the first n
            if n:
                body[:n] = euler.unwrap(body[:n], axis=-2)
        return out

    def __repr__(self) -> str:
        span = (f"t=[{self.t[0] if len(self) else 0:g}, {self.t[-1] if len(self) else 0:g}]")
        method = (self.method.name if self.method is not None  # a user step (run_step)
                  else self.info.get("step", "user step"))
        if self.n_bodies is not None:
            failed = int(np.sum(np.isfinite(np.asarray(self.failed_at, dtype=float))))
            state = f"{failed} failed" if failed else str(np.asarray(self.status).flat[0])
            return (f"Trajectory(method={method!r}, dt={self.dt:g}, "
                    f"bodies={self.n_bodies}, samples={len(self)}, {span}, {state})")
        status = (f"failed at t={self.failed_at:g}" if self.failed_at is not None
                  else self.status)
        return (f"Trajectory(method={method!r}, dt={self.dt:g}, samples={len(self)}, "
                f"{span}, {status})")
