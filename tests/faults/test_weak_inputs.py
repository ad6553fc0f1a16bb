"""Inputs whose error was there but did not help: each failed before the fix.

* a heavy top whose weight overflows was accepted and later blamed on its "torque";
* a false ``orientation_only=True`` promise ran at order 1 without a word; complex or
  object-mode torques failed deep inside numba;
* a potential that turns NaN, a torque that drives ``L`` beyond float64's range, a start
  time so large that the clock cannot advance, a control input read out of bounds;
* baselines that let a dissipative scene's energy rise, and the exact flow at a phase
  beyond float64's resolution.

Bad input gets a ``ValueError``/``TypeError`` naming the argument and the rule; nothing
is silent, and no computed trajectory is lost.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from numba import jit, njit

import liebody
from liebody.errors import InvariantWarning, TorqueError

BODY = liebody.RigidBody([1.0, 2.0, 3.0])


def _run(scene, **kw):
    """integrate() recording every warning: (trajectory, [warnings])."""
    kw = {"L0": [1.0, 0.5, 0.5], "dt": 0.01, "steps": 10, **kw}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        tr = liebody.integrate(scene, **kw)
    return tr, caught


# ------------------------------------------------------------------ heavy top


@pytest.mark.parametrize("mass, g, cm", [
    (1e300, 1e300, [0.0, 0.0, 1.0]),
    (1e200, 9.81, [0.0, 1e200, 0.0]),
    (1.0, 1.0, [1e308, 1e308, 0.0]),  # every entry finite, |cm| is not
])
def test_a_heavy_top_whose_weight_overflows_is_refused(mass, g, cm):
    """Before: accepted with an infinite weight arm, and the run blamed "the torque
    torque(t, q, L) raised TypeError ('NoneType' object is not callable)"."""
    with pytest.raises(ValueError, match=r"mass \* g \* \|cm\| must be finite") as info:
        liebody.HeavyTop(BODY, mass=mass, cm=cm, g=g)
    assert "overflow" in str(info.value)


def test_a_batch_of_heavy_tops_names_the_body_whose_weight_overflows():
    with pytest.raises(ValueError, match=r"body 1.*mass \* g \* \|cm\| must be finite"):
        liebody.HeavyTop(BODY, mass=[1.0, 1e300, 2.0], cm=[0.0, 0.0, 1.0], g=1e10)
    top = liebody.HeavyTop(BODY, mass=1e150, cm=[0.0, 0.0, 1.0], g=1e150)  # 1e300: finite
    assert np.isfinite(top.weight_arm).all()


# ------------------------------------------------------------------ user torques


@njit
def _drag(t, q, L):
    return -0.5 * L


@njit
def _drag_controlled(t, q, L, u):
    return u[0] * L


@njit
def _quadratic_drag(t, q, L):  # zero at L = 0, where a check at L0 alone sees nothing
    return -L * np.sqrt(L[0] ** 2 + L[1] ** 2 + L[2] ** 2)


@njit
def _gravity_like(t, q, L):
    return np.array([-q[1], -q[2], math.sin(t) * q[3]])


@njit
def _commanded(t, q, L, u):
    return np.array([u[0], u[1] * q[0], math.cos(t)])


@pytest.mark.parametrize("scene, controls, L0", [
    (liebody.TorqueBody(BODY, _drag, orientation_only=True), None, [1.0, 0.5, 0.5]),
    (liebody.TorqueBody(BODY, _quadratic_drag, orientation_only=True), None, [0.0, 0.0, 0.0]),
    (liebody.ControlledBody(BODY, _drag_controlled, controls=1, orientation_only=True),
     [-0.3], [1.0, 0.5, 0.5]),
])
def test_a_false_orientation_only_promise_is_refused_at_the_start(scene, controls, L0):
    """Before: the run went on at order 1 (explicit kicks of an L-dependent torque)."""
    with pytest.raises(ValueError, match=r"depends on L.*orientation_only=True"):
        liebody.integrate(scene, L0=L0, dt=0.01, steps=10, method="splitting2",
                          controls=controls)


def test_a_false_promise_is_refused_for_an_ensemble_too():
    scene = liebody.TorqueBody(BODY, _drag, orientation_only=True)
    with pytest.raises(ValueError, match=r"depends on L.*orientation_only=True"):
        liebody.integrate(scene, L0=[[1.0, 0.5, 0.5]] * 3, dt=0.01, steps=10)


@pytest.mark.parametrize("scene, controls", [
    (liebody.TorqueBody(BODY, _gravity_like, orientation_only=True), None),
    (liebody.ControlledBody(BODY, _commanded, controls=2, orientation_only=True), [0.1, 0.2]),
])
def test_a_true_orientation_only_promise_runs_without_a_word(scene, controls):
    tr, caught = _run(scene, t0=3.0, controls=controls, method="splitting4")
    assert tr.status == "complete" and not caught, [str(w.message) for w in caught]


def test_a_complex_torque_is_refused_at_construction():
    """Before: accepted, then a numba TypingError about asarray(complex128) at the run."""
    @njit
    def spin(t, q, L):
        return np.array([1j, 0.0, 0.0]) * q[0]

    with pytest.raises(TypeError, match=r"torque\(t, q, L\) must return real float64 "
                                        r"numbers.*complex128"):
        liebody.TorqueBody(BODY, spin)


def test_an_object_mode_torque_is_refused_at_construction():
    """Before: accepted, then a numba TypingError ("Invalid use of type(CPUDispatcher")."""
    @jit(forceobj=True)
    def spin(t, q, L):
        return [0.0, 0.0, 0.0]

    with pytest.raises(TypeError, match=r"object mode.*real float64 numbers"):
        liebody.TorqueBody(BODY, spin)


def test_an_integer_torque_is_still_accepted():
    @njit
    def kick(t, q, L):
        return np.array([1, 0, 0])

    tr, _ = _run(liebody.TorqueBody(BODY, kick, orientation_only=True))
    assert tr.status == "complete"


@njit
def _reads_u2(t, q, L, u):
    return np.array([u[0], u[1], u[2]])


def test_a_control_input_read_out_of_bounds_is_refused():
    """numba does not check bounds: before, u[2] of a 2-entry u read other memory and the
    run completed without a word."""
    with pytest.raises(ValueError, match=r"IndexError.*u has 2 entries \(controls=2\)"):
        liebody.ControlledBody(BODY, _reads_u2, controls=2)


def test_a_parameter_read_out_of_bounds_is_refused():
    @njit
    def spring(t, q, L, p):
        return np.array([-p[0] * q[1], -p[1] * q[2], -p[2] * q[3]])

    with pytest.raises(ValueError, match=r"IndexError.*p has 2 entries"):
        liebody.TorqueBody(BODY, spring, params=[1.0, 2.0])


@njit(boundscheck=True)
def _reads_u_by_value(t, q, L, u):
    return np.array([u[int(u[0])], 0.0, 0.0])


def test_an_index_error_at_the_start_says_how_many_controls_there_are():
    scene = liebody.ControlledBody(BODY, _reads_u_by_value, controls=2)  # u = 0: fine
    with pytest.raises(TorqueError, match=r"IndexError.*u has 2 entries"):
        liebody.integrate(scene, L0=[1.0, 0.5, 0.5], dt=0.01, steps=10, controls=[5.0, 0.0])


# ------------------------------------------------------------------ integrate()


def test_a_potential_that_turns_nan_is_reported_at_the_end_as_the_potential():
    """The end-of-run check says the potential is not finite, not that the step may be
    too large."""
    @njit
    def still(t, q, L):
        return np.zeros(3)

    def potential(q):
        return math.nan if q[1] > 0.05 else 0.0

    scene = liebody.TorqueBody(BODY, still, potential=potential, orientation_only=True)
    tr, caught = _run(scene, L0=[1.0, 0.1, 0.1], steps=100, method="splitting2")
    assert tr.status == "complete" and len(tr.t) == 101
    (w,) = [w for w in caught if w.category is InvariantWarning]
    text = str(w.message)
    assert "potential" in text and "nan" in text and "could not be checked" in text, text
    assert "step may be too large" not in text, text
    # an ensemble of such bodies says the same
    tr, caught = _run(scene, L0=[[1.0, 0.1, 0.1]] * 2, steps=100, method="splitting2",
                      simd=False)
    (w,) = [w for w in caught if w.category is InvariantWarning]
    text = str(w.message)
    assert "2 of 2 bodies" in text and "potential" in text and "not finite" in text, text
    assert "\0" not in text and "step may be too large" not in text, text


@njit
def _huge_kick(t, q, L):
    return np.array([1e300, 0.0, 0.0])


@pytest.mark.parametrize("save_every", [1, 3, None])
def test_a_torque_that_drives_L_beyond_float64_range_stops_the_run(save_every):
    """Before: the run completed with |L| ~ 5e298 (its energy inf), no warning."""
    scene = liebody.TorqueBody(BODY, _huge_kick, orientation_only=True)
    tr, caught = _run(scene, save_every=save_every, method="splitting2")
    assert tr.status == "failed" and tr.failed_at is not None
    assert np.all(np.abs(tr.L) <= 1e150) and np.isfinite(tr.q).all()
    assert len(tr.t) >= 1 and tr.t[0] == 0.0
    texts = [str(w.message) for w in caught if issubclass(w.category, RuntimeWarning)]
    assert any("|L|" in s and "overflow" in s for s in texts), texts


def test_an_ensemble_whose_L_leaves_float64_range_warns():
    """Ensembles keep every body's samples; the end-of-run check says which overflowed."""
    scene = liebody.TorqueBody(BODY, _huge_kick, orientation_only=True)
    _, caught = _run(scene, L0=[[1.0, 0.5, 0.5]] * 2, method="splitting2", simd=False)
    texts = [str(w.message) for w in caught if w.category is InvariantWarning]
    assert any("2 of 2 bodies" in s and "|L| reached" in s and "float64" in s
               and "\0" not in s and "step may be too large" not in s for s in texts), texts


def test_a_clock_that_cannot_advance_is_refused():
    """Before: t0 = 1e18 with dt = 0.01 ran with every sample at the same time."""
    scene = liebody.FreeBody(BODY)
    with pytest.raises(ValueError, match=r"t0 .* dt .*t0 \+ dt == t0"):
        liebody.integrate(scene, L0=[1.0, 0.5, 0.5], dt=0.01, steps=10, t0=1e18,
                          method="splitting2")
    tr = liebody.integrate(scene, L0=[1.0, 0.5, 0.5], dt=1e3, steps=3, t0=1e18)
    assert len(set(tr.t.tolist())) == 4


# ------------------------------------------------------------------ invariants


@pytest.mark.parametrize("method, eps, dt", [
    ("lie_euler", 5.0, 0.5),
    ("rkmk4", 10.0, 0.5),
    ("lie_euler", 10.0, 0.25),
])
def test_a_baseline_that_lets_a_dissipative_energy_rise_warns(method, eps, dt):
    """The energy of a DampedBody can only fall. Before: these runs ended below their
    initial energy but off the major axis, after rising on the way, with no warning."""
    _, caught = _run(liebody.DampedBody(BODY, eps), dt=dt, steps=400, method=method)
    texts = [str(w.message) for w in caught if w.category is InvariantWarning]
    assert any("rose" in s and "dissipative" in s for s in texts), texts


def test_euler_on_a_dissipative_scene_is_checked_too():
    """euler does not keep |L|: its energy rise was never checked (only |q| warned)."""
    tr, caught = _run(liebody.DampedBody(BODY, 0.1), dt=0.5, steps=4, method="euler")
    T = 0.5 * np.sum(tr.L ** 2 / BODY.moments, axis=1)
    assert T[-1] > T[0]
    texts = [str(w.message) for w in caught if w.category is InvariantWarning]
    assert any("dissipative" in s for s in texts), texts


@pytest.mark.parametrize("method, eps, dt", [
    ("splitting2", 0.3, 0.05), ("no_squish", 0.3, 0.05), ("splitting2", 1e-3, 0.5),
    ("rkmk4", 0.3, 0.05), ("lie_euler", 0.3, 0.05), ("rk4", 0.3, 0.05),
])
def test_a_good_run_on_a_dissipative_scene_does_not_warn(method, eps, dt):
    _, caught = _run(liebody.DampedBody(BODY, eps), dt=dt, steps=400, method=method)
    assert not [w for w in caught if w.category is InvariantWarning], \
        [str(w.message) for w in caught]


def test_the_exact_flow_beyond_float64_phase_resolution_warns():
    """Before: t = 1e18 returned an orientation whose phase was lost, silently."""
    scene = liebody.FreeBody(BODY)
    _, caught = _run(scene, L0=[0.1, 0.0, 1.0], dt=1e17, steps=10)
    texts = [str(w.message) for w in caught if issubclass(w.category, RuntimeWarning)]
    assert any("phase" in s and "|omega|" in s for s in texts), texts
    _, caught = _run(scene, L0=[[0.1, 0.0, 1.0]] * 2, dt=1e17, steps=10)
    assert any("phase" in str(w.message) for w in caught)
    _, caught = _run(scene, L0=[0.1, 0.0, 1.0], dt=1e6, steps=10)
    assert not caught
