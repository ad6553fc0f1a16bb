"""liebody: geometric integrators for rigid-body rotation on SO(3).

Conventions (every function follows them)
-----------------------------------------
* Quaternions are scalar-first ``(w, x, y, z)``, unit, and rotate body to space:
  ``r_space = R(q) r_body``. scipy's ``Rotation`` is scalar-last; use
  :func:`liebody.quaternion.to_scipy` / :func:`~liebody.quaternion.from_scipy`.
* The body frame is the principal-axis frame of the :class:`RigidBody`; ``L`` and
  ``omega`` are body-frame unless the name says ``_space``.
* Euler angles are z-x-z ``(phi, theta, psi)`` with
  ``V = V1(phi) V2(theta) V3(psi)`` mapping body to space coordinates (Hand & Finch,
  *Analytical Mechanics*, ch. 8).
* float64 throughout.

Sources (Hand & Finch for the theory; the papers behind each algorithm and test
problem): docs/references.md; longer derivations: docs/derivations.md.

Importing the package is cheap: submodules (and numba) are loaded on first
attribute access, and numba kernels compile on first use (cached on disk).
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

__version__ = "0.1.0"

# public name -> (module, attribute or None for the module itself)
_LAZY: dict[str, tuple[str, str | None]] = {
    "quaternion": ("liebody.quaternion", None),
    "euler": ("liebody.euler", None),
    "inertia": ("liebody.inertia", None),
    "RigidBody": ("liebody.rigid_body", "RigidBody"),
    "Scene": ("liebody.scenes", "Scene"),
    "Capabilities": ("liebody.scenes", "Capabilities"),
    "FreeBody": ("liebody.scenes", "FreeBody"),
    "HeavyTop": ("liebody.scenes", "HeavyTop"),
    "TorqueBody": ("liebody.scenes", "TorqueBody"),
    "DampedBody": ("liebody.scenes", "DampedBody"),
    "ControlledBody": ("liebody.scenes", "ControlledBody"),
    "GravityGradient": ("liebody.scenes", "GravityGradient"),
    "Gyrostat": ("liebody.gyrostat", "Gyrostat"),
    "ReactionWheels": ("liebody.wheels", "ReactionWheels"),
    "wheels": ("liebody.wheels", None),
    "coupled": ("liebody.coupled", None),
    "CoupledBodies": ("liebody.coupled", "CoupledBodies"),
    "DipoleLattice": ("liebody.coupled", "DipoleLattice"),
    "orbits": ("liebody.orbits", None),
    "attitude": ("liebody.attitude", None),
    "Stepper": ("liebody._stepper", "Stepper"),
    "lagrange_top": ("liebody.lagrange_top", None),
    "analysis": ("liebody.analysis", None),
    "bodies": ("liebody.bodies", None),
    "distributed": ("liebody.distributed", None),
    "integrate": ("liebody._integrate", "integrate"),
    "errors": ("liebody.errors", None),
    "ConvergenceError": ("liebody.errors", "ConvergenceError"),
    "IntegrationError": ("liebody.errors", "IntegrationError"),
    "IntegrationInterrupted": ("liebody.errors", "IntegrationInterrupted"),
    "InvariantWarning": ("liebody.errors", "InvariantWarning"),
    "TorqueError": ("liebody.errors", "TorqueError"),
    "CacheWarning": ("liebody.errors", "CacheWarning"),
    "Trajectory": ("liebody.trajectory", "Trajectory"),
    "methods": ("liebody._methods", "methods"),
    "Method": ("liebody._methods", "Method"),
    "Handles": ("liebody._methods", "Handles"),
    "register": ("liebody._methods", "register"),
    "register_composition": ("liebody._methods", "register_composition"),
    "register_splitting": ("liebody._methods", "register_splitting"),
    "composition_report": ("liebody._methods", "composition_report"),
    "CoefficientReport": ("liebody._methods", "CoefficientReport"),
    "testing": ("liebody.testing", None),
}

__all__ = sorted(_LAZY) + ["__version__"]

if TYPE_CHECKING:  # pragma: no cover
    from liebody import (  # noqa: F401
        analysis,
        attitude,
        bodies,
        coupled,
        distributed,
        errors,
        euler,
        inertia,
        lagrange_top,
        orbits,
        quaternion,
        testing,
        wheels,
    )
    from liebody._integrate import integrate  # noqa: F401
    from liebody._methods import (  # noqa: F401
        CoefficientReport,
        Handles,
        Method,
        composition_report,
        methods,
        register,
        register_composition,
        register_splitting,
    )
    from liebody._stepper import Stepper  # noqa: F401
    from liebody.coupled import CoupledBodies, DipoleLattice  # noqa: F401
    from liebody.errors import (  # noqa: F401
        CacheWarning,
        ConvergenceError,
        IntegrationError,
        IntegrationInterrupted,
        InvariantWarning,
        TorqueError,
    )
    from liebody.gyrostat import Gyrostat  # noqa: F401
    from liebody.rigid_body import RigidBody  # noqa: F401
    from liebody.scenes import (  # noqa: F401
        Capabilities,
        ControlledBody,
        DampedBody,
        FreeBody,
        GravityGradient,
        HeavyTop,
        Scene,
        TorqueBody,
    )
    from liebody.trajectory import Trajectory  # noqa: F401
    from liebody.wheels import ReactionWheels  # noqa: F401


def __getattr__(name: str):
    try:
        module_name, attr = _LAZY[name]
    except KeyError:
        raise AttributeError(f"module 'liebody' has no attribute {name!r}") from None
    module = importlib.import_module(module_name)
    value = module if attr is None else getattr(module, attr)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))
