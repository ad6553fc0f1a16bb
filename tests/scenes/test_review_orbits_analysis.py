"""Review of the orbits and the spacecraft analysis against independent references.

* Orbits: equal orbits hash equal (the ``__eq__``/``__hash__`` contract), also when an
  angle or a coordinate is a signed zero.
"""

from __future__ import annotations

import numpy as np

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
