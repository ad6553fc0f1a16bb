"""A fast rotator under a weak torque: a spacecraft tumbling in the gravity gradient.

References: scipy's DOP853 at rtol 1e-12 on the 7-dimensional equations with the
gravity-gradient torque written here in numpy (``3 GM / r^5 (r x I r)``, ``r`` the
Earth's position in the body frame), and liebody's exact free flow for the free body.

* A composition keeps its base when the torque is added: ``splitting4`` errs on the
  torqued spacecraft as on the free one at the same step (with the axis splitting
  between the kicks it erred 1500 times more).
* The rule for the default: on a GravityGradient scene the splittings' drift between
  the kicks is the exact free flow for a fast rotator (``free_flow="auto"``), which wins
  on the work-precision chart; a body turning with its orbit and other scenes keep the
  axis splitting.
"""

from __future__ import annotations

import numpy as np
import pytest
from numba import njit
from scipy.integrate import solve_ivp

import liebody
from liebody import quaternion
from liebody.orbits import Circular

GM, RADIUS = 3.986004418e14, 6778.0e3
N = np.sqrt(GM / RADIUS**3)
MOMENTS = np.array([100.0, 120.0, 80.0])
Q0 = np.array([1.0, 0.0, 0.0, 0.0])
L0 = MOMENTS * np.array([0.5, 0.01, 0.01])  # near the intermediate axis, 0.5 rad/s
T = 300.0


def _scene(free_flow="auto", body=None):
    return liebody.GravityGradient(body if body is not None else liebody.RigidBody(MOMENTS),
                                   [(GM, Circular(N, RADIUS))], free_flow=free_flow)


def _rhs(t, y, torque=None):
    q, L = y[:4], y[4:]
    omega = L / MOMENTS
    w, x, yy, z = q
    dq = 0.5 * np.array([-x * omega[0] - yy * omega[1] - z * omega[2],
                         w * omega[0] + yy * omega[2] - z * omega[1],
                         w * omega[1] + z * omega[0] - x * omega[2],
                         w * omega[2] + x * omega[1] - yy * omega[0]])
    if torque is None:  # the gravity gradient
        r = RADIUS * np.array([np.cos(N * t), np.sin(N * t), 0.0])
        rb = quaternion.rotate_inverse(q / np.linalg.norm(q), r)
        tau = 3.0 * GM / np.linalg.norm(rb) ** 5 * np.cross(rb, MOMENTS * rb)
    else:
        tau = torque(t)
    return np.concatenate([dq, np.cross(L, omega) + tau])


def _dop853(torque, t_end):
    sol = solve_ivp(_rhs, (0.0, t_end), np.concatenate([Q0, L0]), method="DOP853",
                    rtol=1e-12, args=(torque,),
                    atol=np.r_[np.full(4, 1e-13), np.full(3, 1e-13 * np.linalg.norm(L0))])
    assert sol.success
    q = sol.y[:4, -1]
    return q / np.linalg.norm(q)


@pytest.fixture(scope="module")
def reference():
    return _dop853(None, T)


def _end(scene, method, dt):
    steps = round(T / dt)
    tr = liebody.integrate(scene, q0=Q0, L0=L0, dt=dt, steps=steps, method=method,
                           save_every=steps)
    return tr.q[-1], tr.info


#: a torque of 1e-9 |L| per unit time, of the time only
WEAK = 1e-9 * float(np.linalg.norm(L0))


@njit
def _weak_torque(t, q, L):
    return (WEAK * np.cos(0.3 * t), -WEAK, 0.5 * WEAK)


def _angle(a, b):
    return float(quaternion.angle_between(a, b))


@pytest.mark.parametrize("free_flow", ["auto", "axes"])
def test_splitting4_keeps_its_base_when_a_weak_torque_is_added(reference, free_flow):
    """The composition on the torqued scene errs as on the free body at the same step:
    its base is the free body's (SR2 or the exact flow), not the axis splitting."""
    dt = 1.0
    free = liebody.FreeBody(liebody.RigidBody(MOMENTS))
    q_exact = liebody.integrate(free, q0=Q0, L0=L0, dt=T, steps=1, method="exact").q[-1]
    q_free, info_free = _end(free, "splitting4", dt)
    err_free = _angle(q_free, q_exact)
    assert info_free["base"] == "sr2"  # SR2 is the better base on this orbit
    if free_flow == "axes":  # asked for: the axis splitting between the kicks
        q_torqued, info = _end(_scene("axes"), "splitting4", dt)
        assert info["free_flow"].startswith("axes")
        assert _angle(q_torqued, reference) > 100.0 * err_free
        return
    q_torqued, info = _end(_scene(), "splitting4", dt)
    err_torqued = _angle(q_torqued, reference)
    assert info["free_flow"] == "elliptic"
    assert err_torqued <= 2.0 * err_free, (err_torqued, err_free)


def test_compositions_keep_the_sr2_base_on_torqued_scenes_with_the_axis_default():
    """On a scene whose drift is the axis splitting (a torque from TorqueBody), a
    composition still runs SR2 between its kicks where SR2 is its base on the free body,
    and errs as on the free body (the torque weak)."""
    body = liebody.RigidBody(MOMENTS)
    scene = liebody.TorqueBody(body, _weak_torque, orientation_only=True)
    free = liebody.FreeBody(body)
    dt, steps = 1.0, 300
    q_free = liebody.integrate(free, q0=Q0, L0=L0, dt=dt, steps=steps, method="splitting4")
    q_tq = liebody.integrate(scene, q0=Q0, L0=L0, dt=dt, steps=steps, method="splitting4")
    assert q_tq.info["base"] == "sr2" and q_tq.info["free_flow"].startswith("sr2")
    exact = liebody.integrate(free, q0=Q0, L0=L0, dt=dt * steps, steps=1, method="exact")
    err_free = _angle(q_free.q[-1], exact.q[-1])
    ref = _dop853(lambda t: WEAK * np.array([np.cos(0.3 * t), -1.0, 0.5]), dt * steps)
    assert _angle(q_tq.q[-1], ref) <= 1.5 * err_free
    # and splitting2 stays the axis splitting there (its own base)
    s2 = liebody.integrate(scene, q0=Q0, L0=L0, dt=dt, steps=10, method="splitting2")
    assert s2.info["free_flow"].startswith("axes")


def test_the_default_on_a_gravity_gradient_scene_is_the_exact_free_flow(reference):
    scene = _scene()
    assert liebody.GravityGradient.default_method == "splitting2"
    steps = round(T / 1.0)
    tr = liebody.integrate(scene, q0=Q0, L0=L0, dt=1.0, steps=steps, save_every=steps)
    assert tr.method.name == "splitting2"
    assert tr.info["free_flow"] == "elliptic"
    # kick - exact free flow - kick against the axis splitting, at the same step
    err_default = _angle(tr.q[-1], reference)
    q_axes, _ = _end(_scene("axes"), "splitting2", 1.0)
    assert err_default < 1e-3 * _angle(q_axes, reference)
    # free_flow="exact" is the same plan; "axes" stays available
    q_exact, info = _end(_scene("exact"), "splitting2", 1.0)
    assert info["free_flow"] == "elliptic"
    assert np.array_equal(q_exact, tr.q[-1])


def test_the_rule_is_the_scenes_own():
    """Other torqued scenes keep the axis splitting as the automatic drift; a symmetric
    body keeps its symmetric flow (trig functions only)."""
    top = liebody.HeavyTop(liebody.RigidBody(MOMENTS), mass=1.0, cm=[0.0, 0.0, 0.1])
    tr = liebody.integrate(top, q0=Q0, L0=L0, dt=0.01, steps=3, method="splitting2")
    assert tr.info["free_flow"].startswith("axes")
    sym = _scene(body=liebody.RigidBody([100.0, 100.0, 80.0]))
    tr = liebody.integrate(sym, q0=Q0, L0=L0, dt=1.0, steps=3)
    assert tr.info["free_flow"] == "symmetric"


def test_a_slow_rotator_keeps_the_axis_splitting_and_each_body_its_own_plan():
    """The exact drift is the fast rotators' (a spin at least FAST_ROTATOR times the
    sources' rate); a satellite turning with its orbit keeps the axis splitting (cheaper
    there, and on the SIMD kernels in an ensemble); in an ensemble of both each body gets
    its one-body plan, so a scalar ensemble equals the one-body calls bit for bit."""
    from liebody._plan import FAST_ROTATOR

    scene = _scene()
    assert scene.orbit_rate == pytest.approx(N, rel=1e-15)
    slow = MOMENTS * np.array([0.0, N, 0.0]) * (1.0 + 1e-3)  # resting in the orbital frame
    edge = MOMENTS * np.array([FAST_ROTATOR * N, 0.0, 0.0])  # just a fast rotator
    kw = {"q0": Q0, "dt": 10.0, "steps": 20, "method": "splitting2"}
    assert liebody.integrate(scene, L0=L0, **kw).info["free_flow"] == "elliptic"
    assert liebody.integrate(scene, L0=edge, **kw).info["free_flow"] == "elliptic"
    assert liebody.integrate(scene, L0=edge * 0.999, **kw).info["free_flow"].startswith("axes")
    one = [liebody.integrate(scene, L0=m, **kw) for m in (L0, slow)]
    assert one[1].info["free_flow"].startswith("axes")
    both = liebody.integrate(scene, L0=[L0, slow], simd=False, **kw)
    for i in range(2):
        assert np.array_equal(both.q[i], one[i].q) and np.array_equal(both.L[i], one[i].L)
    many = liebody.integrate(scene, q0=quaternion.random(8, rng=3), L0=slow,
                             **{k: v for k, v in kw.items() if k != "q0"})
    assert many.info["simd"] is True


# ------------------------------------------------------- SABA_n: kicks at the Gauss nodes

SABA = [m.name for m in liebody.methods() if m.weak_order is not None]


def _weak_final(method, gm, h, t_end=40.0):
    """Final state ``(q, L)`` (``q`` with ``w >= 0``) of a body turning at about 1 rad/s
    under the gravity gradient of a source of strength ``gm`` on an orbit ten times
    slower: a torque of relative strength about ``gm``."""
    scene = liebody.GravityGradient(liebody.RigidBody([1.0, 1.3, 0.7]),
                                    [(gm, Circular(0.1, 1.0))], free_flow="exact")
    n = round(t_end / h)
    tr = liebody.integrate(scene, q0=quaternion.random(rng=3), L0=[1.0, 0.2, -0.3],
                           dt=t_end / n, steps=n, method=method, save_every=None)
    q = tr.q[-1] * np.sign(tr.q[-1][0])
    return np.concatenate([q, tr.L[-1]])


@pytest.mark.parametrize("name", [*SABA, "splitting2"])
def test_the_error_linear_in_a_weak_torque_has_the_weak_order(name):
    """Laskar & Robutel's SABA_n (2001): for a torque of relative strength ``eps`` the
    error is ``O(eps h^(2n) + eps^2 h^2)``, so on a fast rotator under a weak torque it
    falls as ``h^(2n)`` while its classical order is 2 (measured on the heavy tops,
    tests/scenes/test_torques.py). Measured without a reference: ``D(eps, h)``, the
    difference of the final states at ``h`` and ``h/2``, loses its ``eps^2`` part by
    Richardson extrapolation in ``eps``, ``(4 D(eps) - D(2 eps)) / 2``, and the slope of
    what remains against ``h`` is the order of the error's part linear in ``eps``. The
    kick - exact flow - kick ``splitting2`` shows 2: the test tells the orders apart."""
    method = liebody.methods()[name]
    expected = method.weak_order if method.weak_order is not None else method.order
    hs = np.array([1.0, 0.8, 0.64])
    linear = []
    for h in hs:
        d1 = _weak_final(name, 1e-4, h) - _weak_final(name, 1e-4, h / 2)
        d2 = _weak_final(name, 2e-4, h) - _weak_final(name, 2e-4, h / 2)
        linear.append(float(np.abs(4.0 * d1 - d2).max()) / 2.0)
    assert linear[-1] > 1e-12, linear  # far above round-off
    slope = np.polyfit(np.log(hs), np.log(linear), 1)[0]
    assert abs(slope - expected) < 0.35, (linear, slope)


@pytest.mark.parametrize("name", SABA)
def test_saba_on_the_tumbling_spacecraft_against_dop853(reference, name):
    """On the spacecraft of this file, SABA_n at a step of 1 s errs against DOP853 a
    thousand times less than the kick - exact flow - kick splitting at the same step
    (3e-7 rad; it costs half of SABA_2 per step). SABA_3 and SABA_4 reach the
    reference's own error there (about 1.4e-11 rad); their orders: the test above."""
    err = {m: _angle(_end(_scene(), m, 1.0)[0], reference) for m in ("splitting2", name)}
    assert err[name] < 1e-3 * err["splitting2"], err
