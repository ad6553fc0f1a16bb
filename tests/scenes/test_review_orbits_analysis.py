"""Review of the orbits and the spacecraft analysis against independent references.

* Orbits: equal orbits hash equal (the ``__eq__``/``__hash__`` contract), also when an
  angle or a coordinate is a signed zero.
* gravity_gradient_stability: the textbook inequalities (Hughes 1986, ch. 9) at extreme
  moment ratios, and a ValueError where float64 cannot hold the coefficients.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from liebody import analysis
from liebody.orbits import Circular, Kepler, Table


def test_equal_orbits_hash_equal_with_signed_zeros():
    """``-0.0 == 0.0``: orbits built from either are equal, so their hashes must agree
    (a set or dict key holds them once)."""
    pairs = [
        (Kepler(2.0, 0.5, 1.0, i=0.0, raan=0.0), Kepler(2.0, 0.5, 1.0, i=-0.0, raan=-0.0)),
        (Kepler(2.0, 0.0, 1.0), Kepler(2.0, -0.0, 1.0, M0=-0.0)),
        (Circular(1.0, inclination=0.0), Circular(1.0, inclination=-0.0, phase=-0.0)),
    ]
    t = np.linspace(0.0, 1.0, 9)
    r = np.stack([1.0 + t, np.zeros_like(t), np.zeros_like(t)], axis=1)
    pairs.append((Table(t, r), Table(t, np.where(r == 0.0, -0.0, r))))
    for a, b in pairs:
        assert a == b
        assert hash(a) == hash(b), (a, b)
        assert len({a, b}) == 1


def test_gravity_gradient_stability_refuses_overflowing_moments():
    """Moments whose ratios overflow the coefficients of the linearised motion gave
    verdicts from inf and NaN (``growth_rate=inf`` or ``0.0``, the roll-yaw verdict
    wrong): they are refused naming the moments. Just inside the range the verdicts
    follow the textbook inequalities."""
    for moments in ([1.0, 2e160, 1e160], [1e-100, 1e100, 1e-100], [1e-200, 1e200, 1e-200],
                    [1e200, 1e-200, 1.0]):
        with pytest.raises(ValueError, match=r"moments .* span too many orders"):
            analysis.gravity_gradient_stability(moments)
    s = analysis.gravity_gradient_stability([1.0, 2e150, 1e150])
    k1, k3 = 1e150, 2.0  # (I2 - I3)/I1, (I2 - I1)/I3
    b = 1 + 3 * k1 + k1 * k3
    assert (s.k1, s.k3) == (k1, k3)
    assert not s.pitch_stable and s.roll_yaw_stable  # I1 < I3; b, c > 0, b^2 > 16 k1 k3
    assert s.growth_rate == pytest.approx(math.sqrt(3 * (1e150 - 1.0) / 2e150), rel=1e-15)
    # the roots s^2 of s^4 + b s^2 + 4 k1 k3: about b and 4 k1 k3 / b
    assert s.roll_yaw_frequencies == pytest.approx((math.sqrt(4 * k1 * k3 / b), math.sqrt(b)),
                                                   rel=1e-14)


@pytest.mark.parametrize("scale", [2.0**-700, 1e-200, 1.0, 1e200, 2.0**700])
def test_stability_verdicts_do_not_depend_on_the_unit_of_the_moments(scale):
    """``kappa`` of stability() and dual_spin_stable() is unchanged when the moments (and
    the rotor momentum) are scaled together: moments of 1e200 gave NaN (``stable=False``
    about the stable smallest axis) and a dual-spin 'overflow' error. Reference: the
    closed forms at unit scale (Hand & Finch ch. 8; Hughes 1986, ch. 7)."""
    I = np.array([1.0, 2.0, 2.5])
    for axis, stable, kappa in ((0, True, (2 - 1) * (2.5 - 1) / (2 * 2.5)),
                                (1, False, (2 - 2.5) * (1 - 2) / (2.5 * 1)),
                                (2, True, (2.5 - 1) * (2.5 - 2) / (1 * 2))):
        s = analysis.stability(I * scale, 3.0, axis)
        assert s.stable is stable
        assert s.rate == pytest.approx(3.0 * math.sqrt(kappa), rel=1e-15)
    # intermediate axis with a rotor: kappa = ((2 - 2.5) w + h)((2 - 1) w + h) / (2.5 * 1)
    for h, stable in ((0.4, False), (0.6, True), (-1.2, True)):
        s = analysis.dual_spin_stable(I * scale, 1.0, 1, h * scale)
        kappa = ((2 - 2.5) + h) * ((2 - 1) + h) / 2.5
        assert s.stable is stable and (kappa > 0) is stable
        assert s.rate == pytest.approx(math.sqrt(abs(kappa)), rel=1e-14)
