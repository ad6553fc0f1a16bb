"""Scenes: what is being integrated (a body and the forces on it).

A scene is modelled with no more than it needs: a :class:`FreeBody` has no torque
kicks, and its default method is the exact flow evaluated at the output times.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from liebody._kernels.stages import TORQUE_GRAVITY, TORQUE_NONE, TORQUE_USER
from liebody._validate import as_float_array, as_positive_float
from liebody.body import RigidBody


@dataclass(frozen=True, eq=False)
class FreeBody:
    """A torque-free rigid body (reference text, "The Force-Free Symmetric Top" and
    "Stability of Axes"; Euler's equations with ``N = 0``).

    Invariants: kinetic energy ``T = sum L_i^2 / (2 I_i)``, ``|L|`` and the spatial
    angular momentum ``L_space = R(q) L``.

    Default method: ``"exact"``. The free body is integrable, so the exact flow
    (trig functions for a symmetric body, Jacobi elliptic functions otherwise) is
    evaluated directly at the output times: no time stepping is wasted and there is
    no discretisation error at all. Name a method to study integrators.
    """

    body: RigidBody

    def __post_init__(self) -> None:
        _init_body(self, self.body, "auto")

    default_method = "exact"
    free_flow = "auto"

    @property
    def moments(self) -> np.ndarray:
        return self.body.moments

    def potential(self, q: np.ndarray) -> np.ndarray:
        """Potential energy (zero for a free body), shape ``q.shape[:-1]``."""
        return np.zeros(np.shape(q)[:-1])

    def torque_parameters(self) -> tuple[int, tuple[float, float, float]]:
        """Kernel description of the torque: (kind, c). No torque here."""
        return TORQUE_NONE, (0.0, 0.0, 0.0)

    def damping_parameter(self) -> float:
        return 0.0

    def orientation_only_torque(self) -> bool:
        """Whether the torque depends on the orientation (and time) only: its kick is exact."""
        return True

    def torque_callback(self):
        """The C callback the driver calls for user torques (a no-op here)."""
        from liebody._kernels.torque import no_torque

        return no_torque


@dataclass(frozen=True, init=False, eq=False)
class HeavyTop(FreeBody):
    """A rigid body with one point fixed at the origin in uniform gravity ``-g e_z``.

    Reference text, section 1.7 ("The Heavy Symmetric Top"). The potential is
    ``V = mass * g * (R(q) cm) . e_z`` and the body-frame torque ``Gamma x (mass g cm)``
    with ``Gamma = R(q)^T e_z``. A symmetric body with ``cm`` on its symmetry axis is
    the Lagrange top (see :mod:`liebody.lagrange_top`); an asymmetric body or an
    off-axis ``cm`` is a general heavy top and works as well.

    Parameters
    ----------
    body
        The body, its inertia taken **about the fixed point** (use
        :func:`liebody.inertia.parallel_axis` to move it from the centre of mass).
    mass
        Total mass (> 0).
    cm
        Centre of mass in the body (principal) frame, measured from the fixed point.
    g
        Gravitational acceleration (> 0).
    free_flow
        The drift of the splittings for an asymmetric body: ``"auto"``/``"axes"``, the
        5-rotation axis splitting (cheapest), or ``"exact"``, the elliptic exact flow
        (about 4x dearer per step, no splitting error in the free part). A symmetric body
        always gets its exact flow.

    Default method: ``"splitting2"``, kick(h/2) – free flow(h) – kick(h/2): the gravity
    kick is exact (the torque depends on the orientation only) and the free flow is the
    exact symmetric-body flow for a Lagrange top (trig functions only), the cheapest
    (axis) splitting otherwise. Symplectic, time-reversible, energy error bounded,
    ``L_z`` (space) kept to round-off, and for a Lagrange top ``L_3`` (body) too. Known
    failure: step-size resonance when ``h`` times the nutation frequency nears ``2 pi``.
    """

    mass: float
    cm: np.ndarray
    g: float

    default_method = "splitting2"

    def __init__(self, body: RigidBody, mass: float, cm, g: float = 9.81,
                 free_flow: str = "auto") -> None:
        _init_body(self, body, free_flow)
        cm_arr = as_float_array("cm", cm, shape=(3,)).copy()
        cm_arr.flags.writeable = False
        object.__setattr__(self, "mass", as_positive_float("mass", mass))
        object.__setattr__(self, "cm", cm_arr)
        object.__setattr__(self, "g", as_positive_float("g", g))

    @property
    def weight_arm(self) -> np.ndarray:
        """``c = mass * g * cm`` (body frame): ``V = c . Gamma``."""
        return self.mass * self.g * self.cm

    def potential(self, q: np.ndarray) -> np.ndarray:
        """``V = mass g (R(q) cm) . e_z`` for quaternions ``(..., 4)``."""
        q = np.asarray(q, dtype=float)
        w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
        gamma = np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), w * w - x * x - y * y + z * z],
                         axis=-1)
        return gamma @ self.weight_arm

    def torque_parameters(self):
        return TORQUE_GRAVITY, tuple(float(v) for v in self.weight_arm)

    def __repr__(self) -> str:
        return (f"HeavyTop(body={self.body!r}, mass={self.mass:g}, cm={self.cm.tolist()}, "
                f"g={self.g:g})")


@dataclass(frozen=True, init=False, eq=False)
class TorqueBody(FreeBody):
    """A rigid body under a user torque ``torque(t, q, L)`` (body frame).

    Parameters
    ----------
    body
        The body.
    torque
        A numba ``@njit`` function ``torque(t, q, L)`` of the time, the orientation
        (scalar-first unit quaternion, ``(4,)`` array) and the body angular momentum
        (``(3,)`` array), returning the body-frame torque (3 numbers).
    potential
        Optional ``potential(q) -> float`` for a conservative, orientation-only
        torque; energy diagnostics then include it.
    orientation_only
        Promise that the torque does not depend on ``L`` (it may depend on ``t`` and
        ``q``). Then each kick (``q`` fixed, ``L += dt * torque``) is the exact flow of the
        torque, and consecutive kicks are merged. Otherwise (the default) a step closes
        with the adjoint, implicit kick ``L' = L + dt * torque(t, q, L')`` (solved by
        fixed-point iteration), which keeps the splittings symmetric.
    free_flow
        As for :class:`HeavyTop`.

    Guarantees. The splittings (and their compositions) have their declared order
    for any smooth torque. Only for a conservative torque that depends on the
    orientation alone are the splittings and ``rattle`` symplectic with a bounded
    energy error; for a torque that depends on ``L`` (or dissipates) they are
    consistent, symmetric methods with no further geometric guarantee.
    """

    torque: object
    potential_fn: object
    orientation_only: bool

    default_method = "splitting2"

    def __init__(self, body: RigidBody, torque, potential=None,
                 orientation_only: bool = False, free_flow: str = "auto") -> None:
        _init_body(self, body, free_flow)
        if not hasattr(torque, "py_func"):
            raise TypeError("torque must be a numba @njit function torque(t, q, L) returning "
                            f"the body-frame torque, got {type(torque).__name__}")
        try:
            tau = np.asarray(torque(0.0, np.array([1.0, 0.0, 0.0, 0.0]), np.zeros(3)),
                             dtype=float)
        except Exception as exc:
            raise ValueError(f"torque(t, q, L) failed on a test call: {exc}") from exc
        if tau.shape != (3,):
            raise ValueError(f"torque(t, q, L) must return 3 numbers, got shape {tau.shape}")
        if potential is not None and not callable(potential):
            raise TypeError("potential must be a callable potential(q) -> float or None")
        if not isinstance(orientation_only, bool):
            raise TypeError("orientation_only must be True or False")
        object.__setattr__(self, "torque", torque)
        object.__setattr__(self, "potential_fn", potential)
        object.__setattr__(self, "orientation_only", orientation_only)

    def orientation_only_torque(self) -> bool:
        return self.orientation_only

    def potential(self, q: np.ndarray) -> np.ndarray:
        q = np.asarray(q, dtype=float)
        if self.potential_fn is None:
            return np.zeros(q.shape[:-1])
        flat = q.reshape(-1, 4)
        vals = np.fromiter((float(self.potential_fn(row)) for row in flat), float, len(flat))
        return vals.reshape(q.shape[:-1])

    def torque_parameters(self):
        return TORQUE_USER, (0.0, 0.0, 0.0)

    def torque_callback(self):
        return _callback(self.torque)


@dataclass(frozen=True, init=False, eq=False)
class DampedBody(FreeBody):
    """A free body with internal dissipation that keeps ``|L|`` and lowers the energy.

    Double-bracket form (body frame): ``dL/dt = L x omega + eps L x (L x omega)``, i.e.
    the body turns with ``omega + eps L x omega`` while the spatial ``L`` stays fixed.
    ``|L|`` is kept, ``dT/dt = -eps |L x omega|^2 <= 0``, and the body ends up spinning
    about its axis of largest moment, where ``T = |L|^2 / (2 I_max)`` is least: the
    reference text's spin-stabilised spacecraft (end of "Stability of Axes"; Explorer 1
    started about its long axis and tumbled).

    Default method: ``"splitting2"``, D(h/2) – free flow(h) – D(h/2) with a
    second-order Lie-midpoint step D of the dissipative part; ``|L|`` and the spatial
    ``L`` are kept to round-off. ``free_flow`` as for :class:`HeavyTop`.
    """

    eps: float

    default_method = "splitting2"

    def __init__(self, body: RigidBody, eps: float, free_flow: str = "auto") -> None:
        _init_body(self, body, free_flow)
        object.__setattr__(self, "eps", as_positive_float("eps", eps))

    def damping_parameter(self) -> float:
        return self.eps


_FREE_FLOWS = ("auto", "axes", "exact")


def _init_body(scene, body, free_flow: str) -> None:
    """Shared constructor part of the torqued scenes: the body and the drift choice."""
    if not isinstance(body, RigidBody):
        raise TypeError(f"body must be a liebody.RigidBody, got {type(body).__name__}")
    if free_flow not in _FREE_FLOWS:
        raise ValueError(f"free_flow must be one of {_FREE_FLOWS}, got {free_flow!r}")
    object.__setattr__(scene, "body", body)
    object.__setattr__(scene, "free_flow", free_flow)


_CALLBACKS: dict = {}


def _callback(torque):
    """One C callback per user torque function, compiled once per process."""
    key = id(torque)
    entry = _CALLBACKS.get(key)
    if entry is None or entry[0] is not torque:
        from liebody._kernels.torque import adapt_user_torque

        entry = (torque, adapt_user_torque(torque))
        _CALLBACKS[key] = entry
    return entry[1]
