"""Failure modes: where methods fail, and that every failure is reported, never silent."""

from __future__ import annotations

import numpy as np
import pytest

import liebody


def test_explicit_euler_blow_up_returns_partial_trajectory(hlw):
    scene, L0 = hlw
    with pytest.warns(RuntimeWarning, match="non-finite"):
        tr = liebody.integrate(scene, L0=L0 * 1e3, dt=0.5, steps=10_000, method="euler")
    assert tr.failed_at is not None and 0 < tr.failed_at <= 0.5 * 10_000
    assert np.all(np.isfinite(tr.q)) and np.all(np.isfinite(tr.L))
    assert len(tr) == round(tr.failed_at / 0.5)  # every sample before the failing step
    assert tr.t[-1] < tr.failed_at


def test_euler_energy_grows_monotonically(hlw):
    """Explicit Euler raises T and |L| every step: T' - T = (h^2/2) m'^T I^-1 m' > 0."""
    scene, L0 = hlw
    with pytest.warns(liebody.InvariantWarning, match=r"euler: \|q\| = 1\.2"):
        tr = liebody.integrate(scene, L0=L0, dt=0.1, steps=100, method="euler")
    assert np.all(np.diff(tr.energy) > 0) and np.all(np.diff(tr.casimir) > 0)
    assert np.all(np.diff(tr.quaternion_norm) > 0)


def test_rattle_nonconvergence_raises(hlw):
    scene, L0 = hlw
    with pytest.raises(liebody.ConvergenceError, match="reduce dt"):
        liebody.integrate(scene, L0=L0 * 1e4, dt=10.0, steps=50, method="rattle")


@pytest.mark.parametrize(("name", "scale", "dt"), [("rattle", 1.0, 0.6), ("rattle", 2.0, 0.35),
                                                   ("dmv4", 1.0, 0.7), ("dmv6", 1.0, 0.6)])
def test_implicit_methods_converge_at_large_moderate_steps(name, scale, dt, hlw):
    """h|omega| up to ~0.95: the DMV equation has its physical root and it is found (the
    fixed point alone stalls or diverges there); energy stays exact."""
    scene, L0 = hlw
    tr = liebody.integrate(scene, L0=scale * L0, dt=dt, steps=3000, method=name)
    assert dt * np.linalg.norm(scale * L0 / scene.moments) > 0.8
    assert np.abs(tr.energy - tr.energy[0]).max() < 1e-13 * tr.energy[0] * scale


def test_dmv4_rejects_steps_that_make_its_moments_negative(hlw):
    scene, L0 = hlw
    with pytest.raises(ValueError, match="dmv4: dt = 2 is too large"):
        liebody.integrate(scene, L0=L0, dt=2.0, steps=3, method="dmv4")
