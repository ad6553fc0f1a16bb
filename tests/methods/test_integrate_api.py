"""integrate() as a template: arguments, sampling, progress, the Trajectory it returns."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

import liebody

STEPPERS = [m.name for m in liebody.methods() if not m.sampled]


def test_save_every_memory_and_times(hlw):
    scene, L0 = hlw
    tr = liebody.integrate(scene, L0=L0, dt=0.01, steps=1003, save_every=100,
                           method="splitting2")
    assert tr.q.shape == (12, 4) and tr.L.shape == (12, 3)
    np.testing.assert_allclose(tr.t, np.r_[np.arange(11) * 1.0, 10.03])
    full = liebody.integrate(scene, L0=L0, dt=0.01, steps=1003, method="splitting2")
    # merged end stages are undone at save points: the same samples as saving every step,
    # up to the rounding of merged angles accumulated over 1000 steps (an error in the
    # bookkeeping would show at the size of the h^2 splitting error, ~1e-5)
    np.testing.assert_allclose(tr.L, full.L[np.r_[np.arange(11) * 100, 1003]], atol=1e-13,
                               rtol=0)


def test_progress_runs_in_chunks_with_identical_result(hlw):
    scene, L0 = hlw
    a = liebody.integrate(scene, L0=L0, dt=0.01, steps=5000, save_every=7, method="sr2")
    b = liebody.integrate(scene, L0=L0, dt=0.01, steps=5000, save_every=7, method="sr2",
                          progress=True)
    np.testing.assert_allclose(a.L, b.L, atol=1e-15, rtol=0)
    np.testing.assert_allclose(a.q, b.q, atol=1e-15, rtol=0)


def test_omega0_and_L0_agree(physical):
    scene, L0 = physical
    a = liebody.integrate(scene, L0=L0, dt=0.1, steps=10, method="splitting2")
    b = liebody.integrate(scene, omega0=L0 / scene.moments, dt=0.1, steps=10,
                          method="splitting2")
    np.testing.assert_allclose(a.L, b.L, atol=1e-15, rtol=0)
    np.testing.assert_allclose(a.omega * scene.moments, a.L, atol=1e-15, rtol=0)


def test_exact_flow_with_progress_bar_gives_the_same_samples(hlw):
    scene, L0 = hlw
    a = liebody.integrate(scene, L0=L0, dt=0.1, steps=500)
    b = liebody.integrate(scene, L0=L0, dt=0.1, steps=500, progress=True)
    np.testing.assert_array_equal(a.q, b.q)
    np.testing.assert_array_equal(a.L, b.L)


def test_default_method_is_exact_for_free_body(hlw):
    scene, L0 = hlw
    tr = liebody.integrate(scene, L0=L0, dt=0.5, t_end=100.0)
    assert tr.method.name == "exact"
    assert np.abs(tr.energy - tr.energy[0]).max() < 1e-14
    assert np.abs(tr.L_space - tr.L_space[0]).max() < 1e-13


def test_a_one_body_runs_trajectory_is_the_dataclasss_own(hlw):
    """The one-body run builds its trajectory without the dataclass constructor (its fixed
    cost): the same fields and values as the constructor gives, read-only, and a new
    field of Trajectory would fail this test until the fast path sets it."""
    scene, L0 = hlw
    tr = liebody.integrate(scene, L0=L0, dt=0.1, steps=3, method="splitting2",
                           diagnostics=True)
    ref = liebody.Trajectory(tr.t.copy(), tr.q, tr.L, tr.scene, tr.method, tr.dt,
                             info=tr.info, diagnostics=tr.diagnostics)
    assert vars(tr).keys() == vars(ref).keys()
    for k, v in vars(ref).items():
        got = getattr(tr, k)
        assert np.array_equal(got, v) if isinstance(v, np.ndarray) else got == v, k
    for a in (tr.t, tr.q, tr.L):
        assert not a.flags.writeable
    with pytest.raises(AttributeError):
        tr.dt = 1.0


def test_trajectory_derived_quantities(hlw):
    """Derived quantities against independent routes: rotation matrices and scipy."""
    from scipy.spatial.transform import Rotation

    scene, L0 = hlw
    q0 = liebody.quaternion.random(rng=4)
    tr = liebody.integrate(scene, q0=q0, L0=L0, dt=0.1, steps=20, method="splitting2")
    R = Rotation.from_quat(liebody.quaternion.to_scipy(tr.q)).as_matrix()
    np.testing.assert_allclose(tr.L_space, np.einsum("nij,nj->ni", R, tr.L), atol=1e-14,
                               rtol=0)
    np.testing.assert_allclose(tr.omega_space, np.einsum("nij,nj->ni", R, tr.L / scene.moments),
                               atol=1e-14, rtol=0)
    np.testing.assert_allclose(tr.energy, 0.5 * np.sum(tr.L * tr.omega, axis=1), rtol=1e-15)
    angles = tr.euler_angles()
    ref = Rotation.from_quat(liebody.quaternion.to_scipy(tr.q)).as_euler("ZXZ")
    # scipy's ZXZ angles: theta in [0, pi]; compare the rotations they stand for
    assert np.all((angles[:, 1] >= 0) & (angles[:, 1] <= np.pi))
    np.testing.assert_allclose(Rotation.from_euler("ZXZ", angles).as_matrix(),
                               Rotation.from_euler("ZXZ", ref).as_matrix(), atol=1e-14, rtol=0)
    np.testing.assert_allclose(angles, ref, atol=1e-12, rtol=0)
    assert "splitting2" in repr(tr)


@pytest.mark.parametrize(
    ("kwargs", "exc", "match"),
    [
        ({"q0": (1.0, 0.1, 0.0, 0.0)}, ValueError, "q0 must be a unit quaternion.*normalize"),
        ({"L0": None}, ValueError, "exactly one of L0"),
        ({"omega0": (1.0, 0.0, 0.0)}, ValueError, "exactly one of L0"),
        ({"dt": 0.0}, ValueError, "dt must be > 0"),
        ({"dt": -0.1}, ValueError, "dt must be > 0"),
        ({"dt": math.nan}, ValueError, "dt must be finite"),
        ({"L0": (1.0, math.inf, 0.0)}, ValueError, "L0 must be finite"),
        # a NaN after a finite entry (max() of the sizes would skip it), list and array
        ({"L0": [1.0, math.nan, 2.0]}, ValueError, "L0 must be finite"),
        ({"L0": np.array([1.0, math.nan, 2.0])}, ValueError, "L0 must be finite"),
        ({"L0": np.array([1.0, 2.0, 1e151])}, ValueError, "L0 is too large"),
        ({"q0": np.array([1.0, 0.1, 0.0, 0.0])}, ValueError, "q0 must be a unit quaternion"),
        ({"q0": np.array([1.0, math.nan, 0.0, 0.0])}, ValueError, "q0 must be finite"),
        ({"q0": np.array([1.0, 0.0, 0.0])}, ValueError, r"q0 must have shape \(\.\.\., 4\)"),
        ({"L0": (1.0, 0.0)}, ValueError, r"L0 must have shape \(\.\.\., 3\)"),
        ({"steps": 0}, ValueError, "steps must be a positive integer"),
        ({"steps": 2.5}, ValueError, "steps must be a positive integer"),
        ({"steps": None, "t_end": 1.05}, ValueError, "t_end must be a whole number of steps"),
        ({"steps": None}, ValueError, "exactly one of steps and t_end"),
        ({"t_end": 1.0}, ValueError, "exactly one of steps and t_end"),
        ({"method": "leapfrog"}, ValueError,
         r"unknown method 'leapfrog'; known methods: .*rattle"),
        ({"method": 3}, TypeError, "method must be a method name"),
        ({"save_every": 0}, ValueError, "save_every must be a positive integer"),
        ({"dt": 1e-300, "steps": None, "t_end": 1.0}, ValueError, r"more than 2\^53"),
        ({"progress": "no"}, TypeError, "progress must be True or False"),
    ],
)
def test_bad_input(kwargs, exc, match, hlw):
    scene, L0 = hlw
    args = {"L0": L0, "dt": 0.1, "steps": 10}
    args.update(kwargs)
    with pytest.raises(exc, match=match):
        liebody.integrate(scene, **args)


def test_bad_scene():
    with pytest.raises(TypeError, match="scene must be"):
        liebody.integrate("body", L0=(1, 0, 0), dt=0.1, steps=1)
    with pytest.raises(TypeError, match=r"body must be a liebody\.RigidBody"):
        liebody.FreeBody([1.0, 2.0, 3.0])


def test_no_warning_for_healthy_runs(hlw):
    """A short run at a moderate step warns for nothing, except explicit Euler, whose
    |q| grows by sqrt(1 + (h|omega|/2)^2) every step (5 % here)."""
    scene, L0 = hlw
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for name in STEPPERS:
            if name != "euler":
                liebody.integrate(scene, L0=L0, dt=0.05, steps=100, method=name)
    with pytest.warns(liebody.InvariantWarning, match=r"\|q\| = 1\.05"):
        liebody.integrate(scene, L0=L0, dt=0.05, steps=100, method="euler")


def test_a_billion_steps_keep_only_the_saved_samples(hlw):
    """1e9 steps saved every 1e6 hold 1001 samples (the exact flow needs no stepping)."""
    scene, L0 = hlw
    tr = liebody.integrate(scene, L0=L0, dt=1e-3, steps=10**9, save_every=10**6)
    assert tr.q.shape == (1001, 4) and tr.L.shape == (1001, 3) and tr.t.shape == (1001,)
    assert tr.t[-1] == 1e6
    assert np.abs(tr.energy - tr.energy[0]).max() < 1e-13
    assert np.abs(tr.L_space - tr.L_space[0]).max() < 1e-12
