"""Ready-made bodies: the rigid Earth of the Chandler wobble, and test bodies.

The Earth model is the force-free symmetric top of Hand & Finch, *Analytical
Mechanics* (Cambridge University Press, 1998), ch. 8, with the dynamical flattening of
the IERS Conventions (2010) (G. Petit & B. Luzum (eds.), IERS Technical Note 36). The
test bodies are the standard ones of the geometric-integration papers listed in
docs/references.md.
"""

from __future__ import annotations

import math

from liebody._validate import as_positive_float
from liebody.rigid_body import RigidBody

__all__ = ["EARTH_C", "EARTH_H", "SIDEREAL_DAY", "book", "earth", "earth_spin", "hlw"]

#: Sidereal day in SI seconds: the Earth's rotation period relative to the fixed stars
#: (23 h 56 min 4.0905 s).
SIDEREAL_DAY = 86164.0905

#: Dynamical ellipticity (dynamical flattening) ``H = (C - A) / C`` of the Earth: the IERS
#: value, as given by the ``ahrs`` package's constants (``DYNAMIC_ELLIPTICITY``); the
#: numerical standards of the IERS Conventions (2010) (IERS Technical Note 36, ch. 1)
#: give ``H = 3273795e-9``.
EARTH_H = 0.0032737949

#: Polar moment of inertia of the Earth, ``C ≈ 0.3307 M a^2 ≈ 8.034e37 kg m^2``
#: (``M = 5.972e24 kg``, ``a = 6378137 m``); only needed for physical units.
EARTH_C = 8.034e37


def earth(C: float = 1.0) -> RigidBody:
    """The rigid Earth as a symmetric top: moments ``(A, A, C)``, ``A = C (1 - H)``.

    Hand & Finch, *Analytical Mechanics*, ch. 8, the force-free symmetric top, whose
    example is the Earth; ``H = EARTH_H`` is the dynamical ellipticity ``(C - A)/C``
    (IERS Conventions 2010, IERS Technical Note 36).
    The figure (symmetry) axis is body axis 3 (index 2). Spinning once per
    :data:`SIDEREAL_DAY` (:func:`earth_spin`), its free wobble has the period
    ``A / (C - A) = (1 - H)/H = 304.456`` sidereal days
    (:func:`liebody.analysis.chandler_period`).

    Parameters
    ----------
    C : float, default 1.0
        Polar moment. The dynamics of a free body depend only on the ratios of the
        moments, so the default normalises ``C = 1``; pass :data:`EARTH_C`
        (``8.034e37 kg m^2``) for ``L`` and energies in SI units.

    Returns
    -------
    RigidBody
    """
    C = as_positive_float("C", C)
    A = C * (1.0 - EARTH_H)
    return RigidBody([A, A, C])


def earth_spin() -> float:
    """The Earth's spin rate ``2 pi / SIDEREAL_DAY = 7.292115e-5`` rad/s."""
    return 2.0 * math.pi / SIDEREAL_DAY


def hlw() -> RigidBody:
    """The Hairer–Lubich–Wanner test body ``I = (2, 1, 2/3)``.

    The free-rigid-body test problem of E. Hairer, C. Lubich & G. Wanner, *Geometric
    Numerical Integration*, 2nd ed. (Springer, 2006).

    Its moments violate the triangle inequality (``1 + 2/3 < 2``), so it is built with
    ``check_triangle=False``; the standard initial momentum is
    ``L0 = (cos 1.1, 0, sin 1.1)``.
    """
    return RigidBody([2.0, 1.0, 2.0 / 3.0], check_triangle=False)


def book(mass: float = 1.0, a: float = 0.24, b: float = 0.17, c: float = 0.03) -> RigidBody:
    """A uniform book-shaped box (edges ``a > b > c`` along body x, y, z), asymmetric.

    Moments ``M (b^2 + c^2)/12 < M (a^2 + c^2)/12 < M (a^2 + b^2)/12``
    (:func:`liebody.inertia.box`): spun about its middle axis ``y`` (index 1) it shows
    the instability of rotation about the intermediate axis (Hand & Finch, *Analytical
    Mechanics*, ch. 8, stability of rotation about the principal axes; tennis racket /
    Dzhanibekov effect); about ``x`` or ``z`` it is stable.

    Parameters
    ----------
    mass : float
        Mass in kg (> 0).
    a, b, c : float
        Edge lengths in m (> 0), default a 24 x 17 x 3 cm paperback.
    """
    from liebody import inertia

    return RigidBody(inertia.box(mass, a, b, c), mass=mass)
