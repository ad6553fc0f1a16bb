"""Reaction wheels: rotors whose spin is state, driven by motor torques (control inputs).

A spacecraft with ``n`` reaction wheels (Hughes, *Spacecraft Attitude Dynamics*, 1986,
ch. 7; Schaub & Junkins, *Analytical Mechanics of Space Systems*, 2nd ed. 2009, sec.
4.5, the gyrostat with reaction wheels). Wheel ``k`` is an axisymmetric rotor with unit
spin axis ``g_k`` (body frame), axial moment of inertia ``J_k`` and *absolute* axial
angular momentum ``h_k = J_k (Omega_k + g_k . omega)`` (``Omega_k`` its spin relative to
the body). With ``A = [g_1 .. g_n]`` (3 x n) the wheels carry ``l = A h`` and

* the total angular momentum of body and wheels, in the body frame, is
  ``L = I omega + A h``, so the body turns at ``omega = I^-1 (L - A h)``;
* ``dL/dt = L x omega + tau_ext`` (body frame): the motors' torques are internal, so
  ``L`` does not see them (and the spatial ``R(q) L`` is conserved without an external
  torque);
* the motor torque ``u_k`` on wheel ``k`` changes its axial momentum,
  ``dh_k/dt = u_k`` (the body feels ``-A u``), and bearing friction is left out;
* the energy is ``T = (L - A h)^T I^-1 (L - A h) / 2 + sum_k h_k^2 / (2 J_k)``.

``I`` is the inertia of the spacecraft *without the wheels' axial inertia*:
``I = I_total - sum_k J_k g_k g_k^T``, with ``I_total`` the inertia of everything (body and
wheels, the wheels' transverse inertia included) about the centre of mass. It must be
diagonal in the body frame: the :class:`~liebody.RigidBody` gives its principal moments,
and the wheel axes are given in its principal frame (Schaub & Junkins, eq. 4.147, write
``[I_s]`` for it).

With the motor torques held over a step (a zero-order hold), ``h`` is linear in time and
the axis sub-flows of ``(L_k - l_k(t))^2 / (2 I_k)`` are exact (each stage reads the rotor
momentum at the midpoint of its clock interval): every stage is a rotation about a
body axis, so ``|L|`` and the spatial ``L`` are kept to round-off whatever the step.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from liebody._validate import as_float_array
from liebody._wheels import Saturation
from liebody.rigid_body import RigidBody
from liebody.scenes import (
    _FREE,
    _GRAVITY_GRADIENT,
    _NO_TORQUE,
    Capabilities,
    GravityGradient,
    Scene,
    TorqueModel,
    _init_body,
    _memo,
    _per_body,
)

__all__ = ["AXIS_TOL", "RANK_TOL", "ReactionWheels", "Saturation"]

Saturation.__module__ = __name__  # (defined with the run code; documented and pickled here)

#: the largest ``| |g_k| - 1 |`` accepted for a wheel axis
AXIS_TOL = 1e-10
#: the smallest singular value of ``A`` (unit columns) below which the axes are dependent
RANK_TOL = 1e-9


def _limit(name: str, value, k: int) -> np.ndarray | None:
    """``None``, or a positive finite limit per wheel (a number for every wheel or ``(k,)``)."""
    if value is None:
        return None
    a = np.array(as_float_array(name, value), dtype=float)
    if a.ndim == 0:
        a = np.full(k, float(a))
    if a.shape != (k,):
        raise ValueError(f"{name} must be a number or one per wheel, shape ({k},), got shape "
                         f"{a.shape}")
    if np.any(a <= 0):
        i = int(np.argmin(a))
        raise ValueError(f"{name} must be > 0 for every wheel (None: no limit), got {a[i]!r} "
                         f"for wheel {i}")
    a.flags.writeable = False
    return a


def _per_wheel(name: str, value, k: int, positive: bool) -> np.ndarray:
    """A number per wheel, ``(k,)``, or one row per body ``(N, k)`` (a number: every wheel)."""
    a = np.array(as_float_array(name, value), dtype=float)
    if a.ndim == 0:
        a = np.full(k, float(a))
    if a.ndim not in (1, 2) or a.shape[-1] != k or (a.ndim == 2 and a.shape[0] == 0):
        raise ValueError(f"{name} must be one number per wheel, shape ({k},), or one row per "
                         f"body, shape (N, {k}); got shape {a.shape}")
    if positive and np.any(a <= 0):
        i = np.unravel_index(int(np.argmin(a)), a.shape)
        raise ValueError(f"{name} must be > 0 for every wheel, got {a[i]!r} at index "
                         f"{tuple(int(v) for v in i) if a.ndim == 2 else int(i[0])}")
    a.flags.writeable = False
    return a


def _axes(axes) -> np.ndarray:
    """The wheels' unit spin axes ``(n, 3)``: unit, and independent (``n <= 3``) or spanning
    3-D (``n > 3``)."""
    g = np.array(as_float_array("axes", axes), dtype=float)
    if g.ndim == 1 and g.shape == (3,):
        g = g[None, :]
    if g.ndim != 2 or g.shape[1] != 3 or g.shape[0] == 0:
        raise ValueError(f"axes must be the wheels' spin axes, one unit vector per row, shape "
                         f"(n, 3) with n >= 1; got shape {g.shape}")
    norms = np.linalg.norm(g, axis=1)
    bad = np.abs(norms - 1.0) > AXIS_TOL
    if bad.any():
        i = int(np.argmax(bad))
        raise ValueError(f"axes must be unit vectors (| |g| - 1 | <= {AXIS_TOL:g}); axes[{i}] "
                         f"has |g| = {norms[i]!r}: divide it by its norm")
    n = g.shape[0]
    s = np.linalg.svd(g, compute_uv=False)
    need = min(n, 3)
    if s[need - 1] <= RANK_TOL:
        if n <= 3:
            raise ValueError(f"axes must be linearly independent for {n} wheel(s): their "
                             f"smallest singular value is {s[need - 1]:.3g} (at most "
                             f"{RANK_TOL:g}); two wheels on one axis are one wheel")
        raise ValueError(f"axes of {n} wheels (redundant wheels) must span the three body "
                         f"axes (rank 3): their third singular value is {s[2]:.3g} (at most "
                         f"{RANK_TOL:g}), so some body axis has no wheel to control it")
    g.flags.writeable = False
    return g


@dataclass(frozen=True, init=False, eq=False)
class ReactionWheels(Scene):
    """A rigid body with reaction wheels whose momenta are state, driven by motor torques.

    Parameters
    ----------
    body
        The spacecraft's inertia **without the wheels' axial inertia**,
        ``I = I_total - sum_k J_k g_k g_k^T`` about the centre of mass, which must be
        diagonal in the body frame (its principal moments; the wheels' transverse inertia is
        part of it). :meth:`liebody.RigidBody.batch` makes an ensemble (per-body inertia).
    axes
        The wheels' spin axes ``g_k`` in the body (principal) frame, one unit vector per
        row, ``(n, 3)`` (a ``(3,)`` vector: one wheel). Refused: an axis that is not a unit
        vector (``| |g| - 1 | > 1e-10``), up to 3 wheels whose axes are linearly dependent,
        and more than 3 wheels (redundant sets, e.g. a pyramid of 4) whose axes do not
        span 3-D (rank < 3); "dependent" means a singular value of ``[g_1 .. g_n]`` at
        most ``1e-9``.
    inertia
        The wheels' axial moments of inertia ``J_k`` (> 0): a number for every wheel,
        ``(n,)``, or one row per body ``(N, n)``.
    momentum
        The wheels' initial absolute axial angular momenta ``h_k`` (default 0): a number,
        ``(n,)``, or one row per body ``(N, n)``; within the speed limit.
    max_torque
        ``None`` (no limit) or the largest motor torque ``|u_k|`` (> 0; a number for every
        wheel, or ``(n,)``). A commanded torque beyond it is clipped.
    max_speed
        ``None`` (no limit) or the largest wheel speed (> 0; a number, or ``(n,)``), where
        the *speed* is the wheel's absolute axial rate ``h_k / J_k = Omega_k + g_k .
        omega`` (rad per unit time): ``|h_k| <= J_k max_speed``. (The motor's own speed
        ``Omega_k`` differs from it by the body's rate about ``g_k``, small for a slowly
        turning spacecraft.) A wheel that would pass it is stopped at it.
    sources
        ``None``, or the gravitating bodies of :class:`~liebody.GravityGradient`
        (``(GM, orbit)`` pairs): a satellite with wheels in orbit. The gravity-gradient
        torque acts on all the mass, ``I_total = I + sum_k J_k g_k g_k^T``, which must then
        be diagonal in the body frame too (wheels along the principal axes, a symmetric
        pyramid about one of them, ...).
    free_flow
        ``"auto"`` or ``"axes"``: the axis splitting (the exact and symmetric-body flows are
        the rigid body's, and are refused).

    The state is the orientation, the total angular momentum ``L`` of body and wheels
    (body frame: ``L0`` in :func:`liebody.integrate`) and the wheels' momenta; ``omega0``
    gives the body's angular velocity instead, ``L = I omega0 + A h0``.

    The motor torques ``u`` (``(n,)``, or ``(N, n)``) are the control inputs: held over a
    whole run by ``liebody.integrate(scene, ..., controls=u)`` and set between steps by a
    :class:`liebody.Stepper` (``stepper.u = ...``), which also reads and sets the wheel
    momenta (``stepper.wheel_momentum``). Note that ``scene.controls`` (the inputs of a
    *user torque*) is 0: the wheel torques do not reach a torque function. The
    trajectory gives the wheel momenta at its samples (``Trajectory.wheels``, ``(n_samples,
    n)`` or ``(N, n_samples, n)``) and the saturations as records
    (``Trajectory.saturations``: :class:`Saturation`); its ``energy`` includes the wheels'.

    *Method.* With ``u`` constant over a step the wheel momenta are linear in time, and
    the body sees the gyrostat (:class:`~liebody.Gyrostat`) with a rotor momentum
    ``l(t) = A h(t)``: the axis splittings (``splitting2``, ``no_squish``, ``splitting4/6/8``,
    user splittings of ``T1, T2, T3``) integrate it with exact sub-flows, rotations about
    the body axes, so the spatial angular momentum of body and wheels is kept to
    round-off by construction, whatever the step, and the methods keep their order (a
    rotation reads ``l`` at the middle of its clock advance, so a user splitting of order
    2 or more must advance the clock symmetrically, or it is refused here). The
    baselines (``euler``, ``rk4``, ``lie_euler``, ``rkmk4``) read ``l(t)`` at their stage
    times; the rigid body's own flows (``exact``, ``sr2``, ``rattle``, ``dmv*``) are
    refused with a message naming these.

    *Saturation.* ``max_torque`` clips each ``|u_k|``. With ``max_speed``, a wheel that
    would pass ``J_k max_speed`` within a step gets, for that step, the rate that brings it
    exactly to the limit at the step's end, and no torque outward after it (a torque back
    inward moves it again). Each episode is recorded (:class:`Saturation`: body, time,
    wheel, which limit) and the run goes on with the limited torque: ``integrate()`` cuts
    the run into pieces of constant wheel rates there (the samples are those of one run).

    Examples
    --------
    Three orthogonal wheels on a small satellite, spun up about its z axis:

    >>> import numpy as np
    >>> import liebody as lb
    >>> craft = lb.ReactionWheels(lb.RigidBody([10.0, 12.0, 8.0]), np.eye(3), 0.01,
    ...                           max_torque=0.05, max_speed=600.0)
    >>> tr = lb.integrate(craft, omega0=[0.0, 0.0, 0.0], dt=0.1, steps=100,
    ...                   controls=[0.0, 0.0, 0.02])
    >>> round(float(tr.wheels[-1, 2]), 6)  # h = u t
    0.2
    >>> round(float(tr.L_space[-1, 2]), 12)  # body and wheels: nothing changed
    0.0
    """

    body: RigidBody
    axes: np.ndarray
    inertia: np.ndarray
    momentum: np.ndarray
    max_torque: np.ndarray | None
    max_speed: np.ndarray | None
    sources: tuple | None
    free_flow: str

    per_body: ClassVar[dict[str, int]] = {"inertia": 1, "momentum": 1}
    #: the rotor momentum changes in time: the run code writes it into the stages
    moving_rotor: ClassVar[bool] = True

    def _integrate_run(self, *args, **kwargs):
        """:func:`liebody.integrate` of this scene (``liebody._wheels.integrate_wheels``):
        the run code reaches it through the scene, so that it imports no wheel module."""
        from liebody._wheels import integrate_wheels

        return integrate_wheels(self, *args, **kwargs)

    def _stepper_class(self):
        """The :class:`liebody.Stepper` of this scene (``liebody._wheels.WheelStepper``)."""
        from liebody._wheels import WheelStepper

        return WheelStepper

    def __init__(self, body: RigidBody, axes, inertia, momentum=0.0, max_torque=None,
                 max_speed=None, sources=None, free_flow: str = "auto") -> None:
        if free_flow == "exact":
            raise ValueError("free_flow='exact' is the rigid body's elliptic flow; reaction "
                             "wheels are integrated by the axis splitting: free_flow='auto' "
                             "or 'axes'")
        _init_body(self, body, free_flow)
        g = _axes(axes)
        k = g.shape[0]
        J = _per_wheel("inertia", inertia, k, positive=True)
        h = _per_wheel("momentum", momentum, k, positive=False)
        t_max = _limit("max_torque", max_torque, k)
        w_max = _limit("max_speed", max_speed, k)
        try:
            np.broadcast_shapes(body.shape, J.shape[:-1], h.shape[:-1])
        except ValueError:
            raise ValueError(
                f"the body ({body.shape[0] if body.shape else 1} bodies), inertia {J.shape} "
                f"and momentum {h.shape} must describe the same number of bodies") from None
        if w_max is not None:
            over = np.abs(h) > J * w_max  # (k,) or (N, k): h or J may be per body
            if over.any():
                i = np.unravel_index(int(np.argmax(over)), over.shape)
                where = f"wheel {int(i[-1])}" + (f" of body {int(i[0])}" if over.ndim == 2
                                                 else "")
                raise ValueError(f"momentum must be within the speed limit, |h_k| <= J_k "
                                 f"max_speed; got h = "
                                 f"{float(np.broadcast_to(h, over.shape)[i])!r} for {where} "
                                 f"(J_k max_speed = "
                                 f"{float(np.broadcast_to(J * w_max, over.shape)[i])!r})")
        for name, v in (("axes", g), ("inertia", J), ("momentum", h), ("max_torque", t_max),
                        ("max_speed", w_max)):
            object.__setattr__(self, name, v)
        if sources is not None:
            ggrad = GravityGradient(self._total_body(), sources)
            object.__setattr__(self, "sources", ggrad.sources)
            object.__setattr__(self, "_memo_gravity", ggrad)
        else:
            object.__setattr__(self, "sources", None)

    # ------------------------------------------------------------------ the scene
    @property
    def capabilities(self) -> Capabilities:
        return _FREE if self.sources is None else _GRAVITY_GRADIENT

    @property
    def batch_shape(self) -> tuple[int, ...]:
        return np.broadcast_shapes(self.body.shape, self.inertia.shape[:-1],
                                   self.momentum.shape[:-1])

    def _total_body(self) -> RigidBody:
        """The inertia of all the mass, ``I + sum_k J_k g_k g_k^T``, for the
        gravity-gradient torque (refused unless diagonal in the body frame)."""
        J = np.atleast_2d(self.inertia)  # (1 or N, k)
        D = np.einsum("nk,ki,kj->nij", J, self.axes, self.axes)
        off = D - D * np.eye(3)
        scale = np.max(np.abs(D), axis=(1, 2))
        if np.any(np.max(np.abs(off), axis=(1, 2)) > 1e-12 * scale):
            raise ValueError(
                "sources: the gravity-gradient torque acts on the whole inertia I + sum_k J_k "
                "g_k g_k^T, which must be diagonal in the body frame; these wheel axes and "
                "inertias add off-diagonal terms (put the wheels along the principal axes, or "
                "in a pattern symmetric about them)")
        moments = np.asarray(self.body.moments, dtype=float) + np.diagonal(D, axis1=1, axis2=2)
        if moments.shape[0] == 1 and not self.body.shape:
            return RigidBody(moments[0])
        return RigidBody.batch(np.broadcast_to(moments, np.broadcast_shapes(
            moments.shape, (self.body.shape[0] if self.body.shape else 1, 3))))

    def torque_model(self) -> TorqueModel:
        if self.sources is None:
            return _NO_TORQUE
        return _memo(self, "gravity", lambda: GravityGradient(self._total_body(),
                                                              self.sources)).torque_model()

    def potential(self, q, t=0.0) -> np.ndarray:
        """The gravity-gradient potential at orientations ``q`` and times ``t`` (zeros
        without ``sources``)."""
        if self.sources is None:
            return np.zeros(np.shape(q)[:-1])
        return _memo(self, "gravity", lambda: GravityGradient(self._total_body(),
                                                              self.sources)).potential(q, t)

    def take(self, idx) -> ReactionWheels:
        out = super().take(idx)
        if self.sources is not None:  # the gravity-gradient scene of the bodies taken
            object.__setattr__(out, "_memo_gravity", GravityGradient(out._total_body(),
                                                                     out.sources))
        return out

    # ------------------------------------------------------------------ the wheels
    @property
    def n_wheels(self) -> int:
        """The number of wheels ``n``."""
        return int(self.axes.shape[0])

    @property
    def matrix(self) -> np.ndarray:
        """``A = [g_1 .. g_n]``, ``(3, n)``: the rotor momentum is ``l = A h``."""
        return self.axes.T

    @property
    def momentum_limit(self) -> np.ndarray:
        """``J_k max_speed`` per wheel (``(n,)`` or ``(N, n)``; inf without a speed limit)."""
        if self.max_speed is None:
            return np.full(self.inertia.shape, math.inf)
        return self.inertia * self.max_speed

    def rotor_momentum_of(self, h) -> np.ndarray:
        """``l = A h`` (body frame, ``(..., 3)``) for wheel momenta ``h`` ``(..., n)``."""
        h = as_float_array("h", h, last_dim=self.n_wheels)
        out = h[..., 0, None] * self.axes[0]
        for j in range(1, self.n_wheels):  # (in order, the same rounding for every body)
            out = out + h[..., j, None] * self.axes[j]
        return out

    def omega(self, L, h) -> np.ndarray:
        """The body's angular velocity ``I^-1 (L - A h)`` at total momenta ``L`` and wheel
        momenta ``h`` (a batch: the body axis first)."""
        L = as_float_array("L", L, last_dim=3)
        return (L - self.rotor_momentum_of(h)) / _per_body(self.moments, L)

    def kinetic_energy(self, L, h) -> np.ndarray:
        """``T = (L - A h)^T I^-1 (L - A h) / 2 + sum_k h_k^2 / (2 J_k)`` at total momenta
        ``L`` ``(..., 3)`` and wheel momenta ``h`` ``(..., n)`` (a batch: the body axis
        first)."""
        L = as_float_array("L", L, last_dim=3)
        h = as_float_array("h", h, last_dim=self.n_wheels)
        d = L - self.rotor_momentum_of(h)
        body = 0.5 * np.sum(d * d / _per_body(self.moments, L), axis=-1)
        return body + 0.5 * np.sum(h * h / _per_body(self.inertia, h), axis=-1)

    def with_momentum(self, momentum) -> ReactionWheels:
        """The same spacecraft with the wheels at ``momentum`` (to continue a run from its
        last sample: ``scene.with_momentum(traj.wheels[-1])``)."""
        out = ReactionWheels.__new__(ReactionWheels)
        for name in ("body", "axes", "inertia", "max_torque", "max_speed", "sources",
                     "free_flow"):
            object.__setattr__(out, name, getattr(self, name))
        h = _per_wheel("momentum", momentum, self.n_wheels, positive=False)
        try:
            np.broadcast_shapes(self.batch_shape, h.shape[:-1])
        except ValueError:
            raise ValueError(f"momentum of shape {h.shape} does not fit the scene's "
                             f"{self.batch_shape[0]} bodies") from None
        lim = self.momentum_limit
        if np.any(np.abs(h) > lim):
            raise ValueError("momentum must be within the speed limit, |h_k| <= J_k max_speed")
        object.__setattr__(out, "momentum", h)
        gravity = vars(self).get("_memo_gravity")
        if gravity is not None:
            object.__setattr__(out, "_memo_gravity", gravity)
        return out

    def __repr__(self) -> str:
        if self.batch_shape:
            return (f"ReactionWheels(<batch of {self.batch_shape[0]} bodies>, "
                    f"{self.n_wheels} wheels)")
        return (f"ReactionWheels(body={self.body!r}, axes={self.axes.tolist()}, "
                f"inertia={self.inertia.tolist()}, momentum={self.momentum.tolist()})")
