"""Shared fixtures: standard test bodies of geometric integration.

The Hairer–Lubich–Wanner body (Geometric Numerical Integration, 2nd ed., Springer 2006)
and the Hairer–Vilmart body (J. Phys. A 39 (2006) 13225); see docs/references.md.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import settings

import liebody

# The first example of a property test may include compiling numba kernels (or
# loading them from the cache): no per-example deadline.
settings.register_profile("liebody", deadline=None)
settings.load_profile("liebody")


def hlw_body() -> liebody.RigidBody:
    """Hairer–Lubich–Wanner body ``I = (2, 1, 2/3)`` (breaks the triangle inequality)."""
    return liebody.RigidBody([2.0, 1.0, 2.0 / 3.0], check_triangle=False)


HLW_L0 = np.array([np.cos(1.1), 0.0, np.sin(1.1)])


def physical_body() -> liebody.RigidBody:
    """A real asymmetric body: a uniform 3 x 2 x 1 box of mass 1, axes in no special order."""
    from liebody import inertia

    return liebody.RigidBody(inertia.box(1.0, 3.0, 2.0, 1.0), mass=1.0)


PHYSICAL_L0 = np.array([0.3, -0.2, 0.9])


@pytest.fixture
def hlw():
    return liebody.FreeBody(hlw_body()), HLW_L0.copy()


@pytest.fixture
def physical():
    return liebody.FreeBody(physical_body()), PHYSICAL_L0.copy()


def rotation_distance(q1: np.ndarray, q2: np.ndarray) -> np.ndarray:
    """Max-norm distance between orientations, modulo the sign of the quaternion."""
    return np.minimum(np.abs(q1 - q2).max(axis=-1), np.abs(q1 + q2).max(axis=-1))
