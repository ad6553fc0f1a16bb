"""Gyrostats: rigid bodies carrying rotors of constant momentum (dual-spin satellites).

A gyrostat is a rigid body with rotors (wheels, flywheels) spinning inside it at a
constant momentum ``l`` relative to the body, given in the body frame (Hughes,
*Spacecraft Attitude Dynamics*, 1986, ch. 7; Wittenburg, *Dynamics of Systems of Rigid
Bodies*, 1977). ``L`` is the total angular momentum (body and rotors) in the body frame,
the body turns at ``omega = I^-1 (L - l)``, and

* ``dL/dt = L x omega`` (body frame) plus any external torque;
* ``H = (L - l)^T I^-1 (L - l) / 2``, ``|L|`` and the spatial ``L`` are conserved by the
  free gyrostat.

``I`` is the inertia of the whole (body and rotors) about its centre of mass, in the
principal frame of the :class:`~liebody.RigidBody`. The same equations hold for rotors
spinning freely (no motor torque), whose *absolute* axial momenta are constant: then ``l``
is that absolute momentum and ``I`` the inertia without the rotors' axial inertia (a
:class:`~liebody.ReactionWheels` scene with its motors off gives these numbers).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from liebody._validate import as_float_array
from liebody.rigid_body import RigidBody
from liebody.scenes import Capabilities, Scene, _init_body, _per_body

__all__ = ["Gyrostat"]

_GYROSTAT = Capabilities()


@dataclass(frozen=True, init=False, eq=False)
class Gyrostat(Scene):
    """A free gyrostat: a rigid body with rotors of constant momentum ``l`` (body frame).

    Parameters
    ----------
    body
        The body, its inertia that of body and rotors together (the rotors' axial inertia
        included), about the centre of mass; :meth:`liebody.RigidBody.batch` makes an ensemble.
    rotor_momentum
        ``l``, the rotors' angular momentum relative to the body, in the body frame:
        ``(3,)``, or ``(N, 3)`` one per body (finite).
    free_flow
        ``"auto"`` or ``"axes"`` (the axis splitting); the exact and symmetric-body flows
        are the rigid body's, and are refused.

    The kinetic energy is ``H = (L - l)^T I^-1 (L - l) / 2`` with ``L`` the total angular
    momentum in the body frame. Default method: ``"splitting2"``, the 5-rotation axis
    splitting of ``H`` into ``(L_k - l_k)^2 / (2 I_k)``, whose exact flows turn the body
    at ``(L_k - l_k) / I_k`` about ``e_k`` (``L_k`` constant): symplectic, symmetric,
    order 2, ``|L|`` and the spatial ``L`` kept to round-off, ``H`` bounded. Its
    compositions (``splitting4/6/8``), ``no_squish``, user splittings of ``T1, T2, T3``
    and the baselines also integrate a gyrostat; ``sr2``, ``rattle``, ``dmv*``, the exact
    flow and ``free_flow="exact"`` are the rigid body's and refuse it with a message. The
    axis ordering is ``(0, 1, 2)`` (the per-orbit choice of the rigid body's splitting
    does not apply). A dual-spin satellite spinning about its axis of intermediate moment
    is stabilised by a large enough rotor momentum along that axis
    (:func:`liebody.analysis.dual_spin_stable`).
    """

    body: RigidBody
    rotor_momentum: np.ndarray
    free_flow: str

    per_body: ClassVar[dict[str, int]] = {"rotor_momentum": 1}

    def __init__(self, body: RigidBody, rotor_momentum, free_flow: str = "auto") -> None:
        if free_flow == "exact":
            raise ValueError("free_flow='exact' is the rigid body's elliptic flow; a gyrostat "
                             "is integrated by the axis splitting: free_flow='auto' or 'axes'")
        _init_body(self, body, free_flow)
        l = np.array(as_float_array("rotor_momentum", rotor_momentum, last_dim=3))
        if l.ndim > 2:
            raise ValueError(f"rotor_momentum must be (3,) or one row per body (N, 3), got "
                             f"shape {l.shape}")
        try:
            np.broadcast_shapes(body.shape, l.shape[:-1])
        except ValueError:
            raise ValueError(f"rotor_momentum of shape {l.shape} gives {l.shape[0]} bodies, but "
                             f"the body describes {body.shape[0]}") from None
        l.flags.writeable = False
        object.__setattr__(self, "rotor_momentum", l)

    @property
    def capabilities(self) -> Capabilities:
        return _GYROSTAT

    @property
    def batch_shape(self) -> tuple[int, ...]:
        return np.broadcast_shapes(self.body.shape, self.rotor_momentum.shape[:-1])

    def kinetic_energy(self, L) -> np.ndarray:
        """``H = (L - l)^T I^-1 (L - l) / 2`` at total body-frame momenta ``L`` ``(..., 3)``
        (a batch: the body axis first)."""
        L = as_float_array("L", L, last_dim=3)
        d = L - _per_body(self.rotor_momentum, L)
        return 0.5 * np.sum(d * d / _per_body(self.moments, L), axis=-1)

    def omega(self, L) -> np.ndarray:
        """The body's angular velocity ``I^-1 (L - l)`` (body frame) at momenta ``L``."""
        L = as_float_array("L", L, last_dim=3)
        return (L - _per_body(self.rotor_momentum, L)) / _per_body(self.moments, L)

    def __repr__(self) -> str:
        if self.batch_shape:
            return f"Gyrostat(<batch of {self.batch_shape[0]} gyrostats>)"
        return f"Gyrostat(body={self.body!r}, rotor_momentum={self.rotor_momentum.tolist()})"
