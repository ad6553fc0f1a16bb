"""Shared fixtures. Tests are arranged by tier, one folder each:

* ``kernels/`` — the numba kernels called directly (also run uncompiled in CI);
* ``foundation/`` — quaternions, Euler angles, inertia, bodies, packaging;
* ``methods/`` — the method catalogue, observed orders, invariants and failure modes,
  generic over every registered method;
* ``scenes/`` — torqued and damped scenes, and the rigid-body phenomena against their
  closed forms (Hand & Finch, *Analytical Mechanics*, ch. 8);
* ``faults/`` — faults at the edges: read-only installs, bad or extreme input, stiff
  dissipation;
* ``benchmarks/`` — the benchmark suite's smoke test.

Helpers shared by several tiers live in ``support.py``.
"""

from __future__ import annotations

import contextlib

import pytest
from hypothesis import settings

import liebody
from support import HLW_L0, PHYSICAL_L0, hlw_body, physical_body


def pytest_addoption(parser):
    """pyproject.toml's addopts name two options of pytest-xdist (``--dist loadfile``,
    ``--maxprocesses``, which only matter with ``-n``); without the plugin (a plain
    ``pip install pytest``) they are accepted here and do nothing, instead of stopping
    pytest with "unrecognized arguments"."""
    for name, kw in (("--dist", {"default": "no"}), ("--maxprocesses", {"default": None})):
        with contextlib.suppress(ValueError):  # (pytest-xdist installed: its own option)
            parser.addoption(name, **kw, help="pytest-xdist's option (pytest-xdist is not "
                             "installed: ignored)")


# The first example of a property test may include compiling numba kernels (or
# loading them from the cache): no per-example deadline.
settings.register_profile("liebody", deadline=None)
settings.load_profile("liebody")


@pytest.fixture
def hlw():
    """Hairer, Lubich & Wanner's free body ``I = (2, 1, 2/3)``, ``L0 = (cos 1.1, 0, sin 1.1)``."""
    return liebody.FreeBody(hlw_body()), HLW_L0.copy()


@pytest.fixture
def physical():
    """A uniform 3 x 2 x 1 box and an arbitrary ``L0``."""
    return liebody.FreeBody(physical_body()), PHYSICAL_L0.copy()


@pytest.fixture
def registered():
    """Names registered by a test are removed afterwards (the registry is global, and the
    generic tests iterate over it)."""
    from liebody import _methods

    names: list[str] = []
    yield names
    for name in names:
        _methods._REGISTRY.pop(name, None)
    _methods._PLANS.clear()


@pytest.fixture
def triple_jump(registered):
    """The name of Yoshida's triple jump on ``splitting2``, registered for the test."""
    from support import TRIPLE_JUMP

    name = "test_triple_jump"
    liebody.register_composition(name, TRIPLE_JUMP, base="splitting2")
    registered.append(name)
    return name
