"""Scenes: what is being integrated (a body and the forces on it).

A scene is modelled with no more than it needs: a :class:`FreeBody` has no torque
kicks, and its default method is the exact flow evaluated at the output times.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from liebody.body import RigidBody


@dataclass(frozen=True)
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
        if not isinstance(self.body, RigidBody):
            raise TypeError(
                f"body must be a liebody.RigidBody, got {type(self.body).__name__}")

    default_method = "exact"

    @property
    def moments(self) -> np.ndarray:
        return self.body.moments

    def potential(self, q: np.ndarray) -> np.ndarray:
        """Potential energy (zero for a free body), shape ``q.shape[:-1]``."""
        return np.zeros(np.shape(q)[:-1])
