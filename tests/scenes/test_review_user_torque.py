"""Review of the user torques (``TorqueBody``, ``ControlledBody``): per-body parameters,
the SIMD path, the potential and the checks ``integrate()`` makes on a user torque.

References: the energy written out here (kinetic plus the user's potential of each body's
own row), scipy's DOP853 at rtol = atol = 1e-12 on the equations of motion written out
here, and the one-body runs of each body.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from numba import njit
from scipy.integrate import cumulative_simpson, solve_ivp

import liebody
from liebody import quaternion

BODY = liebody.RigidBody([1.0, 2.0, 3.0])


@njit
def _gravity_p(t, q, L, p):
    """Uniform gravity with the weight arm ``p[:3]``: ``Gamma x c``, ``Gamma = R^T e_z``."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    g = np.array([2.0 * (x * z - w * y), 2.0 * (y * z + w * x), w * w - x * x - y * y + z * z])
    return np.cross(g, p[:3])


def _vertical(q):
    """``R(q)^T e_z`` for orientations ``q`` ``(..., 4)``."""
    w, x, y, z = np.moveaxis(np.asarray(q, dtype=float), -1, 0)
    return np.stack([2.0 * (x * z - w * y), 2.0 * (y * z + w * x),
                     w * w - x * x - y * y + z * z], axis=-1)


def _gravity_potential_p(t, q, p):
    """The potential of :func:`_gravity_p`: ``Gamma . c``."""
    return float(_vertical(q) @ p[:3])


def _states(n, seed=0):
    rng = np.random.default_rng(seed)
    return quaternion.normalize(rng.normal(size=(n, 4))), rng.normal(size=(n, 3))


def test_one_shared_row_of_params_gives_every_body_its_energy():
    """params of shape (1, k) in an ensemble of N bodies: every body reads that row, in
    the run and in the energy (it raised IndexError for body 1 in Trajectory.energy, and
    the end-of-run check warned that it failed)."""
    arm = np.array([[0.3, -0.2, 2.0]])
    scene = liebody.TorqueBody(BODY, _gravity_p, potential=_gravity_potential_p, params=arm,
                               orientation_only=True)
    q0, L0 = _states(4)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        traj = liebody.integrate(scene, q0=q0, L0=L0, dt=0.01, steps=200)
    q = traj.q / np.linalg.norm(traj.q, axis=-1, keepdims=True)
    expected = 0.5 * np.sum(traj.L ** 2 / BODY.moments, axis=-1) + _vertical(q) @ arm[0]
    np.testing.assert_allclose(traj.energy, expected, rtol=1e-14, atol=1e-14)
    # and the energy is kept, as the symplectic splitting keeps it
    assert np.abs(traj.energy - traj.energy[:, :1]).max() < 1e-3


@njit
def _writes_p(t, q, L, p):
    p[0] += 1.0
    return np.array([0.0, 0.0, 0.01 * p[0]])


@njit
def _writes_p_controlled(t, q, L, p, u):
    p[1] = u[0]
    return np.zeros(3)


def test_a_torque_that_writes_to_its_params_is_refused_by_name():
    """p is the run's own row, kept by the scene (memoised model): a torque that wrote to it
    changed the parameters for every later step and run (the scene's model held 23.0 after
    one run of 10 steps from 1.0, while scene.params still said 1.0). It is refused at
    construction, the message naming p and the rule."""
    with pytest.raises(TypeError, match=r"writes to p.*read-only.*p\.copy\(\)"):
        liebody.TorqueBody(BODY, _writes_p, params=[1.0, 2.0], orientation_only=True)
    with pytest.raises(TypeError, match=r"writes to p.*read-only.*p\.copy\(\)"):
        liebody.ControlledBody(BODY, _writes_p_controlled, controls=1, params=[[1.0, 2.0]])


@njit
def _copies_p(t, q, L, p):
    c = p.copy()
    c[0] += 1.0
    return np.array([0.0, 0.0, 0.01 * c[0]])


@njit
def _fixed_torque(t, q, L):
    return np.array([0.0, 0.0, 0.01 * 2.0])


def test_a_torque_that_copies_its_params_runs_and_keeps_them():
    scene = liebody.TorqueBody(BODY, _copies_p, params=[1.0, 2.0], orientation_only=True)
    a = liebody.integrate(scene, L0=[1.0, 0.0, 0.0], dt=0.01, steps=10)
    b = liebody.integrate(scene, L0=[1.0, 0.0, 0.0], dt=0.01, steps=10)
    np.testing.assert_array_equal(a.L, b.L)
    np.testing.assert_array_equal(scene.torque_model().params, [[1.0, 2.0]])
    # the torque read p[0] = 1 at every kick: the run of its constant compiled in
    fixed = liebody.integrate(liebody.TorqueBody(BODY, _fixed_torque, orientation_only=True),
                              L0=[1.0, 0.0, 0.0], dt=0.01, steps=10)
    np.testing.assert_array_equal(a.L, fixed.L)
    np.testing.assert_array_equal(a.q, fixed.q)


@njit
def _pulsing_gravity(t, q, L, p):
    """Gravity whose strength pulses: ``(1 + p[3] sin t) Gamma x c``."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    g = np.array([2.0 * (x * z - w * y), 2.0 * (y * z + w * x), w * w - x * x - y * y + z * z])
    return (1.0 + p[3] * np.sin(t)) * np.cross(g, p[:3])


def _pulsing_potential(t, q, p):
    return float((1.0 + p[3] * np.sin(t)) * (_vertical(q) @ p[:3]))


def test_a_time_dependent_potential_is_not_checked_as_a_kept_energy():
    """potential(t, q, p) that depends on t: the energy changes by the integral of dV/dt
    (checked here along the run), so the scene is not conservative and no energy is
    checked or reported. It was declared conservative, and the end-of-run check compared
    T + V(0, q) at both ends: 'the energy went from 2.06 to 3.41' warned on a run whose
    true energies went from 3.24 to 2.87, as the integral of dV/dt says."""
    params = np.array([0.3, -0.2, 2.0, 0.8])
    scene = liebody.TorqueBody(BODY, _pulsing_gravity, potential=_pulsing_potential,
                               params=params, orientation_only=True)
    q0 = quaternion.exp([0.3, 0.2, 0.0])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        traj = liebody.integrate(scene, q0=q0, L0=[0.5, 0.2, 1.0], dt=1e-3, t_end=3.0, t0=1.0,
                                 method="splitting4", diagnostics=True)
    assert np.isnan(traj.diagnostics["max_energy_error"])
    assert scene.time_dependent_potential
    assert not scene.capabilities.conservative
    q = traj.q / np.linalg.norm(traj.q, axis=-1, keepdims=True)
    V = np.array([scene.potential(qk, tk) for qk, tk in zip(q, traj.t, strict=True)])
    E = 0.5 * np.sum(traj.L ** 2 / BODY.moments, axis=-1) + V
    dVdt = params[3] * np.cos(traj.t) * (_vertical(q) @ params[:3])
    work = cumulative_simpson(dVdt, x=traj.t, initial=0.0)
    assert abs(E[-1] - E[0]) > 0.1  # (the energy does change)
    # E(t) - E(t0) = int dV/dt: Simpson's error (dt^4) and the method's (dt^4)
    np.testing.assert_allclose(E - E[0], work, atol=1e-9)


def test_a_potential_of_params_without_time_stays_conservative():
    scene = liebody.TorqueBody(BODY, _gravity_p, potential=_gravity_potential_p,
                               params=np.array([[0.3, -0.2, 2.0], [0.0, 1.0, 0.5]]),
                               orientation_only=True)
    assert not scene.time_dependent_potential
    assert scene.capabilities.conservative


@njit
def _drag_p(t, q, L, p):
    return -p[0] * L


@pytest.mark.parametrize("simd", [False, True])
def test_a_false_orientation_only_promise_of_another_body_is_refused(simd):
    """integrate() checks the promise on body 0's torque at its initial state: a torque
    whose L term is scaled by each body's row, zero in body 0's, ran bodies 1..3 (drag
    -0.5 L) with explicit kicks, at order 1, without a word. Refused, naming the body."""
    scene = liebody.TorqueBody(BODY, _drag_p, params=[[0.0], [0.5], [0.5], [0.5]],
                               orientation_only=True)
    with pytest.raises(ValueError, match=r"depends on L for body 1 \(row 1 of params\).*"
                                         r"orientation_only=False"):
        liebody.integrate(scene, L0=[1.0, 0.2, 0.1], dt=0.01, steps=10, simd=simd)
    honest = liebody.TorqueBody(BODY, _drag_p, params=[[0.0], [0.5], [0.5], [0.5]])
    traj = liebody.integrate(honest, L0=[1.0, 0.2, 0.1], dt=0.01, steps=10, simd=simd)
    assert np.all(traj.status == "complete")


@njit
def _boolean_torque(t, q, L):
    return np.array([True, False, q[0] > 0.5])


def test_a_boolean_torque_is_refused_at_construction():
    """Booleans are no torque: accepted before, they ran as 0 and 1 one body at a time and
    failed to compile (numba TypingError) in the SIMD ensemble path."""
    with pytest.raises(TypeError, match=r"real float64 numbers.*dtype bool"):
        liebody.TorqueBody(BODY, _boolean_torque, orientation_only=True)


def test_params_without_rows_are_refused_in_words():
    """It said 'the body describes None bodies' for a single body."""
    with pytest.raises(ValueError, match=r"params of shape \(0, 2\) have no rows") as info:
        liebody.TorqueBody(BODY, _gravity_p, params=np.ones((0, 2)))
    assert "None" not in str(info.value)


@njit
def _gravity_in_space_frame(t, q, L, p):
    """The body torque of :func:`_gravity_p` turned to the space frame: a frame mistake."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    R = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                  [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                  [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])
    return R @ _gravity_p(t, q, L, p)


def _signed_potential(t, q, p):
    """``p[3] Gamma . c``: the potential of :func:`_gravity_p` where ``p[3] = 1``."""
    return p[3] * _gravity_potential_p(t, q, p)


@njit
def _stiff(t, q, L, p):
    """``V = cos(p[0] Gamma_z)``: ``N = -p[0] sin(p[0] Gamma_z) Gamma x e_z``."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    g = np.array([2.0 * (x * z - w * y), 2.0 * (y * z + w * x), w * w - x * x - y * y + z * z])
    return -p[0] * np.sin(p[0] * g[2]) * np.array([g[1], -g[0], 0.0])


def _stiff_potential(t, q, p):
    return float(np.cos(p[0] * _vertical(q)[2]))


@pytest.mark.parametrize("torque, potential, params, words", [
    (_gravity_in_space_frame, _gravity_potential_p, [0.3, -0.2, 2.0], ""),
    (_gravity_p, _signed_potential, [0.3, -0.2, 2.0, -1.0], ""),
    (_gravity_p, _signed_potential, [[0.3, -0.2, 2.0, 1.0], [0.3, -0.2, 2.0, 1.0],
                                     [0.3, -0.2, 2.0, -1.0]], r" \(body 2, row 2 of params\)"),
])
def test_a_potential_that_is_not_the_torques_is_refused(torque, potential, params, words):
    """A torque in the space frame, or a potential of the wrong sign (for one body of an
    ensemble), ran and warned at the end that 'the energy went from -1.46 to 0.079, more
    than 1% ... (the step may be too large for this scene ...)', blaming the step; the
    energy it reports is another system's. Refused, naming the rule N = -dV/d(eps)."""
    scene = liebody.TorqueBody(BODY, torque, potential=potential, params=params,
                               orientation_only=True)
    with pytest.raises(ValueError, match=r"not minus the derivative of the potential"
                                         + words + r".*N = -dV/d\(eps\)"):
        liebody.integrate(scene, q0=quaternion.exp([0.3, 0.2, 0.1]), L0=[0.5, 0.2, 1.0],
                          dt=0.01, steps=10)


def test_a_stiff_potential_that_is_the_torques_runs():
    """The check's differences do not refuse a potential that turns fast (cos(40 Gamma_z)),
    and its energy is kept as the method keeps it."""
    scene = liebody.TorqueBody(BODY, _stiff, potential=_stiff_potential, params=[40.0],
                               orientation_only=True)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        traj = liebody.integrate(scene, q0=quaternion.exp([0.3, 0.2, 0.1]),
                                 L0=[0.5, 0.2, 1.0], dt=1e-4, steps=2000, method="splitting4")
    assert np.ptp(traj.energy) < 1e-6 * np.abs(traj.energy).max()


def test_the_potential_takes_a_time_per_orientation():
    """potential(q, t) broadcasts t against q's leading axes, as GravityGradient's does, so
    that the energy of a time-dependent potential along a run is one call (float(t) raised
    TypeError for an array)."""
    params = np.array([[0.3, -0.2, 2.0, 0.8], [1.0, 0.5, -0.4, 0.3]])
    scene = liebody.TorqueBody(BODY, _pulsing_gravity, potential=_pulsing_potential,
                               params=params, orientation_only=True)
    q0, L0 = _states(2, seed=3)
    traj = liebody.integrate(scene, q0=q0, L0=L0, dt=0.01, steps=50, t0=0.4)
    q = traj.q / np.linalg.norm(traj.q, axis=-1, keepdims=True)
    V = scene.potential(q, traj.t)
    expected = [[_pulsing_potential(t, qk, params[i]) for qk, t in zip(q[i], traj.t,
                                                                        strict=True)]
                for i in range(2)]
    np.testing.assert_array_equal(V, expected)
    np.testing.assert_array_equal(scene.potential(q[:, 7], 1.5),
                                  [_pulsing_potential(1.5, q[i, 7], params[i]) for i in range(2)])
    with pytest.raises(ValueError, match=r"t of shape \(3,\) does not broadcast"):
        scene.potential(q, [0.0, 1.0, 2.0])
    with pytest.raises(ValueError, match=r"body axis first.*N = 2"):
        scene.potential(q[0])


@njit
def _gravity_and_command(t, q, L, p, u):
    return _gravity_p(t, q, L, p) + u


def test_a_controlled_body_with_a_potential_is_not_checked_as_conservative():
    """The controls do work: the energy changes by the integral of u . omega (checked here
    along the run). The scene was declared conservative when given a potential, and the
    end-of-run check warned 'the energy went from 2.06 to 9.07, more than 1% ... (the step
    may be too large ...)' on a correct run."""
    arm, u = np.array([0.3, -0.2, 2.0]), np.array([0.5, 0.0, 0.3])
    scene = liebody.ControlledBody(BODY, _gravity_and_command, controls=3,
                                   potential=_gravity_potential_p, params=arm,
                                   orientation_only=True)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        traj = liebody.integrate(scene, q0=quaternion.exp([0.3, 0.2, 0.1]),
                                 L0=[0.5, 0.2, 1.0], dt=1e-3, steps=3000, controls=u,
                                 method="splitting4", diagnostics=True)
    assert not scene.capabilities.conservative
    assert np.isnan(traj.diagnostics["max_energy_error"])
    power = (traj.L / BODY.moments) @ u
    work = cumulative_simpson(power, x=traj.t, initial=0.0)
    E = traj.energy
    assert abs(E[-1] - E[0]) > 1.0  # (the controls do work)
    np.testing.assert_allclose(E - E[0], work, atol=1e-9)


@njit
def _everything(t, q, L, p, u):
    """Gravity of arm p[:3], drag p[3] L, and the controls modulated by p[4] sin 2t."""
    return _gravity_p(t, q, L, p) - p[3] * L + p[4] * np.sin(2.0 * t) * u


@njit
def _everything_but_L(t, q, L, p, u):
    return _gravity_p(t, q, L, p) + p[4] * np.sin(2.0 * t) * u


def _dop853(moments, q0, L0, t0, t1, torque):
    def rhs(t, y):
        q, L = y[:4], y[4:]
        omega = L / moments
        dq = 0.5 * quaternion.multiply(q, np.r_[0.0, omega])
        return np.concatenate([dq, np.cross(L, omega) + torque(t, q / np.linalg.norm(q), L)])

    sol = solve_ivp(rhs, (t0, t1), np.r_[q0, L0], method="DOP853", rtol=1e-12, atol=1e-12)
    return sol.y[:4, -1], sol.y[4:, -1]


@pytest.mark.parametrize("torque, orientation_only, simd", [
    (_everything, False, None), (_everything_but_L, True, True),
    (_everything_but_L, True, False)])
def test_every_body_of_a_controlled_ensemble_follows_its_own_row(torque, orientation_only,
                                                                  simd):
    """Per-body inertia, params and controls, each body against DOP853 on its own equations
    (rows mixed between bodies would be off by O(1)); the ensemble permuted gives the same
    bodies permuted, bit for bit."""
    n = 5
    rng = np.random.default_rng(11)
    moments = rng.uniform(1.0, 3.0, size=(n, 3))
    params = np.column_stack([rng.normal(size=(n, 3)), rng.uniform(0.05, 0.3, n),
                              rng.uniform(0.5, 1.5, n)])
    u = rng.normal(size=(n, 3))
    q0, L0 = _states(n, seed=12)

    def scene(order):
        bodies = liebody.RigidBody.batch(moments[order], check_triangle=False)
        return liebody.ControlledBody(bodies, torque, controls=3, params=params[order],
                                      orientation_only=orientation_only)

    kw = {"dt": 0.005, "t_end": 2.0, "t0": 0.3, "method": "splitting4", "simd": simd}
    traj = liebody.integrate(scene(np.arange(n)), q0=q0, L0=L0, controls=u, **kw)
    groups = traj.info.get("groups", [traj.info])
    assert {g["simd"] for g in groups} == {bool(simd)}  # (the path the case is for)
    for i in range(n):
        py = getattr(torque, "py_func", torque)  # (the function itself uncompiled)
        q1, L1 = _dop853(moments[i], q0[i], L0[i], 0.3, 2.3,
                         lambda t, q, L, i=i, py=py: py(t, q, L, params[i], u[i]))
        np.testing.assert_allclose(traj.q[i, -1], q1, rtol=0, atol=1e-10)
        np.testing.assert_allclose(traj.L[i, -1], L1, rtol=0, atol=1e-10)
    order = rng.permutation(n)
    permuted = liebody.integrate(scene(order), q0=q0[order], L0=L0[order], controls=u[order],
                                 **kw)
    np.testing.assert_array_equal(permuted.q, traj.q[order])
    np.testing.assert_array_equal(permuted.L, traj.L[order])


def test_bodies_taken_from_a_scene_keep_its_time_dependence():
    """A part of an ensemble is as conservative as the whole: body 1's own potential does
    not change in time (amplitude 0), the scene's does."""
    params = np.array([[0.3, -0.2, 2.0, 0.8], [1.0, 0.5, -0.4, 0.0], [0.0, 0.2, 1.0, 0.8]])
    scene = liebody.TorqueBody(BODY, _pulsing_gravity, potential=_pulsing_potential,
                               params=params, orientation_only=True)
    assert scene.time_dependent_potential
    for part in (scene.take(1), scene.take(slice(1, 2))):
        assert part.time_dependent_potential
        assert not part.capabilities.conservative
        assert part.torque_model().time_dependent


@pytest.mark.parametrize("simd", [False, True])
def test_params_of_any_dtype_and_layout_give_the_same_run(simd):
    """Integers, Fortran order, strided views and float32 are converted to the same float64
    rows: the same numbers bit for bit."""
    ref = np.array([[1, 2, 3], [0, 1, 0], [2, 0, 1], [-1, 1, 1]])
    q0, L0 = _states(4, seed=4)

    def run(params):
        scene = liebody.TorqueBody(BODY, _gravity_p, params=params, orientation_only=True)
        return liebody.integrate(scene, q0=q0, L0=L0, dt=0.01, steps=100, simd=simd)

    base = run(ref.astype(float))
    for params in (ref, np.asfortranarray(ref.astype(float)),
                   np.repeat(ref.astype(float), 2, axis=1)[:, ::2],
                   np.hstack([ref.astype(float), np.ones((4, 2))])[:, :3],
                   ref.astype(np.float32)):
        traj = run(params)
        np.testing.assert_array_equal(traj.q, base.q)
        np.testing.assert_array_equal(traj.L, base.L)


@njit
def _scribbles(t, q, L, u):
    """The commanded torque of u, after writing over its inputs q, L and u."""
    tau = np.array([u[0] + 0.1 * q[1], u[1] - 0.05 * q[2], 0.2 * q[3]])
    q[0], q[2], L[0], u[1] = 7.0, 1.0, -3.0, 5.0
    return tau


@njit
def _clean(t, q, L, u):
    return np.array([u[0] + 0.1 * q[1], u[1] - 0.05 * q[2], 0.2 * q[3]])


@pytest.mark.parametrize("n, simd", [(None, False), (4, False), (4, True)])
def test_a_torque_that_writes_over_its_state_and_controls_changes_nothing(n, simd):
    """q, L and u are the torque's own copies: a torque that writes to them gives the run of
    one that does not, bit for bit."""
    u = np.array([0.3, -0.2])
    q0, L0 = _states(n or 1, seed=8)
    if n is None:
        q0, L0 = q0[0], L0[0]
    runs = []
    for torque in (_scribbles, _clean):
        for oo in (True, False):
            scene = liebody.ControlledBody(BODY, torque, controls=2, orientation_only=oo)
            runs.append(liebody.integrate(scene, q0=q0, L0=L0, dt=0.01, steps=50, controls=u,
                                          simd=simd))
    for a, b in ((runs[0], runs[2]), (runs[1], runs[3])):
        np.testing.assert_array_equal(a.q, b.q)
        np.testing.assert_array_equal(a.L, b.L)


@njit
def _pulsing_gravity_fails(t, q, L, p):
    """:func:`_pulsing_gravity`, NaN for the body whose ``p[4]`` is set once ``t > 1.5``."""
    if p[4] > 0.0 and t > 1.5:
        return np.array([np.nan, 0.0, 0.0])
    w, x, y, z = q[0], q[1], q[2], q[3]
    g = np.array([2.0 * (x * z - w * y), 2.0 * (y * z + w * x), w * w - x * x - y * y + z * z])
    return (1.0 + p[3] * np.sin(t)) * np.cross(g, p[:3])


def test_the_trajectorys_potential_energy_is_at_the_samples_times():
    """Trajectory.potential_energy and .energy evaluate a time-dependent potential at each
    sample's time (they called potential(q), i.e. at t = 0), for one body and for an
    ensemble of per-body params one of whose bodies failed (its later samples NaN, the
    other bodies each at their own row: the flattened finite samples lost the body
    axis)."""
    one = np.array([0.3, -0.2, 2.0, 0.8, 0.0])
    scene = liebody.TorqueBody(BODY, _pulsing_gravity_fails,
                               potential=lambda t, q, p: _pulsing_potential(t, q, p),
                               params=one, orientation_only=True)
    traj = liebody.integrate(scene, q0=quaternion.exp([0.3, 0.2, 0.0]), L0=[0.5, 0.2, 1.0],
                             dt=0.01, steps=300, t0=1.0)
    q = traj.q / np.linalg.norm(traj.q, axis=-1, keepdims=True)
    V = np.array([_pulsing_potential(tk, qk, one) for qk, tk in zip(q, traj.t, strict=True)])
    np.testing.assert_allclose(traj.potential_energy, V, rtol=1e-14, atol=1e-14)
    np.testing.assert_allclose(traj.energy, traj.kinetic_energy + V, rtol=1e-14, atol=1e-14)

    rows = np.array([one, [0.0, 1.0, 0.5, -0.4, 0.0], [0.2, 0.1, 1.0, 0.3, 1.0]])
    ens = liebody.TorqueBody(BODY, _pulsing_gravity_fails,
                             potential=lambda t, q, p: _pulsing_potential(t, q, p),
                             params=rows, orientation_only=True)
    q0, L0 = _states(3, seed=3)
    with pytest.warns(RuntimeWarning, match="1 of 3 bodies"):
        tr = liebody.integrate(ens, q0=q0, L0=L0, dt=0.01, steps=100, t0=1.0, simd=False)
    assert list(tr.status[:2]) == ["complete", "complete"] and tr.failed_at[2] > 1.5
    Vs = tr.potential_energy
    assert Vs.shape == (3, len(tr))
    qn = tr.q / np.linalg.norm(tr.q, axis=-1, keepdims=True)
    for i in range(3):
        good = np.isfinite(tr.q[i]).all(axis=-1)
        want = [_pulsing_potential(tk, qk, rows[i])
                for qk, tk in zip(qn[i, good], tr.t[good], strict=True)]
        np.testing.assert_allclose(Vs[i, good], want, rtol=1e-14, atol=1e-14)
        assert np.isnan(Vs[i, ~good]).all()
    assert (~np.isfinite(tr.q[2])).any()
