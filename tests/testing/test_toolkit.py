"""liebody.testing on integrators that are not liebody's, and on liebody's own.

The verdicts must come out right for steps written here in plain Python (RK4 and
explicit Euler on the quaternion and Euler's equations: orders 4 and 1, energy drift),
for a deliberately biased step (drift), for liebody's geometric methods (bounded) and
for synthetic errors whose growth law is known by construction.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import liebody
from liebody import quaternion as Q
from liebody import testing


def qdot(q, w):
    """``q' = q (0, omega) / 2``: quaternion kinematics with the body angular velocity."""
    return 0.5 * np.array([
        -q[1] * w[0] - q[2] * w[1] - q[3] * w[2],
        q[0] * w[0] + q[2] * w[2] - q[3] * w[1],
        q[0] * w[1] + q[3] * w[0] - q[1] * w[2],
        q[0] * w[2] + q[1] * w[1] - q[2] * w[0],
    ])


def _rhs(moments):
    """Euler's equations and the kinematics for a free body (Hand & Finch, ch. 8)."""

    def f(q, L):
        w = L / moments
        return qdot(q, w), np.cross(L, w)

    return f


def python_rk4(moments):
    f = _rhs(np.asarray(moments, dtype=float))

    def python_rk4(q, L, h):
        k1 = f(q, L)
        k2 = f(q + 0.5 * h * k1[0], L + 0.5 * h * k1[1])
        k3 = f(q + 0.5 * h * k2[0], L + 0.5 * h * k2[1])
        k4 = f(q + h * k3[0], L + h * k3[1])
        return (q + h / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0]),
                L + h / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1]))

    return python_rk4


def python_euler(moments):
    f = _rhs(np.asarray(moments, dtype=float))

    def step(q, L, h):
        dq, dL = f(q, L)
        return q + h * dq, L + h * dL

    return step


def test_problems_are_consistent():
    table = testing.problems()
    assert set(table) == {"hlw", "asym", "symmetric", "top", "lagrange"}
    for p in table.values():
        q, L = p.reference(0.0)
        np.testing.assert_allclose(q, p.q0, atol=1e-15)
        np.testing.assert_allclose(L, p.L0, atol=1e-15)
        q, L = p.reference(np.linspace(0, p.t_end, 5))
        assert q.shape == (5, 4) and L.shape == (5, 3)
        np.testing.assert_allclose(np.linalg.norm(q, axis=-1), 1.0, atol=1e-14)
        E = p.energy(q, L)
        np.testing.assert_allclose(E, E[0], rtol=1e-11)
        assert p.provenance and p.uncertainty > 0
    with pytest.raises(ValueError, match="unknown problem 'nope'"):
        testing.problem("nope")
    with pytest.raises(ValueError, match="t must be finite and >= 0"):
        table["hlw"].reference(-1.0)


@pytest.mark.parametrize("name", ["hlw", "asym", "symmetric", "lagrange", "top"])
def test_references_agree_with_scipy_dop853(name):
    """Every reference against an independent solution: scipy's DOP853 at rtol 1e-13 on
    Euler's equations (plus gravity) and the quaternion kinematics."""
    p = testing.problem(name)
    scene = p.scene
    I = scene.moments
    weight = np.zeros(3)
    if isinstance(scene, liebody.HeavyTop):
        weight = scene.mass * scene.g * np.asarray(scene.cm, dtype=float)

    def f(t, y):
        q, L = y[:4], y[4:]
        w = L / I
        dq = 0.5 * Q.multiply(q, np.r_[0.0, w])
        gamma = Q.rotate_inverse(q / np.linalg.norm(q), [0.0, 0.0, 1.0])
        return np.r_[dq, np.cross(L, w) + np.cross(gamma, weight)]

    T = p.t_end
    sol = solve_ivp(f, (0, T), np.r_[p.q0, p.L0], method="DOP853", rtol=1e-13, atol=1e-13)
    q_ref, L_ref = p.reference(T)
    err = testing.state_error(sol.y[:4, -1], sol.y[4:, -1], q_ref, L_ref)
    assert err < 1e-9, err


def test_certified_reference_spread_is_within_its_stated_uncertainty():
    p = testing.problem("top")
    for t in (1.0, p.t_end):
        assert p.reference_spread(t) <= p.uncertainty
    assert testing.problem("hlw").reference_spread(1.0) is None


def test_python_rk4_is_order_4_and_drifts():
    p = testing.problem("hlw")
    step = python_rk4(p.scene.moments)
    order = testing.observed_order(step, p)
    assert order.reliable and order.rounded == 4, order
    with pytest.warns(liebody.InvariantWarning, match=r"python_rk4.*\|q\| = .* at the end"):
        traj = testing.run_step(step, p, dt=0.2, steps=20_000, save_every=20)
    verdict = testing.energy_drift(traj)
    assert verdict.kind == "drift", verdict
    assert verdict.rate < 0  # RK4 dissipates energy on the free body
    with pytest.raises(AssertionError, match=r"\| \|q\| - 1 \| reached .* at t = "):
        testing.assert_invariants(traj)


def test_python_euler_is_order_1_and_drifts():
    p = testing.problem("hlw")
    step = python_euler(p.scene.moments)
    order = testing.observed_order(step, p, t_end=1.0)
    assert order.reliable and order.rounded == 1, order
    # over two periods of the orbit the energy's oscillation about its trend could be a
    # slow one: too short to tell (before: "drift", confidence 1.00); over 20, a drift
    with pytest.warns(liebody.InvariantWarning, match=r"\|q\|"):
        short = testing.run_step(step, p, dt=1e-3, steps=10_000, save_every=10)
    assert testing.energy_drift(short).kind == "undetermined"
    with pytest.warns(liebody.InvariantWarning, match=r"\|q\|"):
        traj = testing.run_step(step, p, dt=1e-3, steps=100_000, save_every=100)
    verdict = testing.energy_drift(traj)
    assert verdict.kind == "drift" and verdict.rate > 0, verdict  # Euler gains energy
    assert verdict.cycles >= testing.MIN_CYCLES
    with pytest.raises(AssertionError, match="the energy drifts"):
        testing.assert_invariants(traj, qnorm=None, casimir=None, spatial_L=None)


def test_observed_order_works_for_odd_orders_and_any_order():
    """An error law ``C h^p`` built in: the order comes out for p = 1, 3, 5 and 7, with
    the round-off floor and the large-step regime excluded."""
    p = testing.problem("hlw")
    for order in (1, 3, 5, 7):
        q_ref, L_ref = p.reference(p.t_end)
        n_calls = {}

        def step(q, L, h, order=order, q_ref=q_ref, L_ref=L_ref, n_calls=n_calls):
            n = round(p.t_end / h)
            k = n_calls[h] = n_calls.get(h, 0) + 1
            if k < n:
                return q, L
            err = min(h**order, 1.0) + 1e-13  # saturated large steps + a floor
            return q_ref, L_ref * (1 + err)

        found = testing.observed_order(step, p, h_max=4.0, max_steps=2**16)
        assert found.steps[0] < 1.0  # the saturated regime is left out
        assert found.reliable and abs(found.order - order) < 0.05, found


def python_splitting(moments, bias: float = 0.0):
    """The symmetric splitting T1(h/2) T2(h/2) T3(h) T2(h/2) T1(h/2) of the free-body
    Hamiltonian into exact axis rotations (McLachlan 1993), in plain numpy; with
    ``bias``, |L| is scaled by ``1 + bias`` after every step (a deliberate error)."""
    moments = np.asarray(moments, dtype=float)

    def rotate(q, L, k, tau):
        a = tau * L[k] / moments[k]  # rotation of the body about axis k by angle a
        i, j = (k + 1) % 3, (k + 2) % 3
        c, s = math.cos(a), math.sin(a)
        L = L.copy()
        L[i], L[j] = c * L[i] + s * L[j], -s * L[i] + c * L[j]
        e = np.zeros(4)
        e[0], e[k + 1] = math.cos(a / 2), math.sin(a / 2)
        return Q.multiply(q, e), L

    def step(q, L, h):
        for k, f in ((0, 0.5), (1, 0.5), (2, 1.0), (1, 0.5), (0, 0.5)):
            q, L = rotate(q, L, k, f * h)
        return q, L * (1.0 + bias)

    return step


def test_python_splitting_is_order_2_and_bounded():
    p = testing.problem("asym")
    step = python_splitting(p.scene.moments)
    assert testing.observed_order(step, p).rounded == 2
    traj = testing.run_step(step, p, dt=0.05, steps=60_000, save_every=10)
    assert testing.energy_drift(traj).kind == "bounded"
    testing.assert_invariants(traj, qnorm=1e-13)


def test_biased_step_is_caught():
    """The splitting above with a bias of 1e-8 in |L| per step: a drift, caught by
    energy_drift and by assert_invariants (which names the invariants and the time)."""
    p = testing.problem("asym")
    dt = 0.02
    traj = testing.run_step(python_splitting(p.scene.moments, bias=1e-8), p, dt=dt,
                            steps=20_000, save_every=10)
    verdict = testing.energy_drift(traj)
    assert verdict.kind == "drift", verdict
    assert abs(verdict.rate - 2e-8 / dt) < 0.05 * 2e-8 / dt  # dE/E = 2 * bias per step
    with pytest.raises(AssertionError) as info:
        testing.assert_invariants(traj)
    msg = str(info.value)
    assert "|L| changed by" in msg and "the energy drifts" in msg and "L_space" in msg
    assert "| |q| - 1 |" not in msg  # the orientation is still unit


@pytest.mark.parametrize("name", ["hlw", "top", "lagrange"])
@pytest.mark.parametrize("method", ["splitting2", "rattle", "splitting4"])
def test_geometric_methods_are_bounded(name, method):
    p = testing.problem(name)
    dt = 20 * p.h_max / 100
    traj = liebody.integrate(p.scene, q0=p.q0, L0=p.L0, dt=dt, steps=200_000, method=method,
                             save_every=20)
    verdict = testing.energy_drift(traj)
    assert verdict.kind in ("bounded", "random walk"), verdict
    testing.assert_invariants(traj, qnorm=1e-12)


def test_rk4_drift_is_detected_on_the_fast_top():
    p = testing.problem("top")
    with pytest.warns(liebody.InvariantWarning, match="rk4"):
        traj = liebody.integrate(p.scene, q0=p.q0, L0=p.L0, dt=4e-3, steps=250_000,
                                 method="rk4", save_every=25)
    assert testing.energy_drift(traj).kind == "drift"


def test_energy_drift_on_errors_of_known_law():
    rng = np.random.default_rng(7)
    t = np.linspace(0.0, 20_000.0, 200_001)
    bounded = 1.0 + 1e-6 * np.sin(3.1 * t) + 1e-7 * rng.normal(size=t.size)
    walk = 1.0 + 1e-15 * np.cumsum(rng.normal(size=t.size))
    drift = 1.0 + 1e-10 * t + 1e-7 * np.sin(2.0 * t)
    assert testing.energy_drift(t=t, energy=bounded).kind == "bounded"
    assert testing.energy_drift(t=t, energy=walk).kind == "random walk"
    found = testing.energy_drift(t=t, energy=drift)
    assert found.kind == "drift" and abs(found.rate - 1e-10) < 1e-12, found
    assert found.confidence > 0.5
    # non-uniform samples are resampled
    ts = np.sort(rng.uniform(0, 1000, 20_000))
    assert testing.energy_drift(t=ts, energy=1 + 1e-9 * ts).kind == "drift"
    with pytest.raises(ValueError, match="at least 64 samples"):
        testing.energy_drift(t=t[:10], energy=drift[:10])
    with pytest.raises(ValueError, match="strictly increasing"):
        testing.energy_drift(t=t[::-1], energy=drift)


def test_assert_invariants_messages_name_invariant_size_and_time():
    p = testing.problem("hlw")
    with pytest.warns(liebody.InvariantWarning, match="euler"):
        traj = liebody.integrate(p.scene, q0=p.q0, L0=p.L0, dt=0.01, steps=1000,
                                 method="euler")
    with pytest.raises(AssertionError) as info:
        testing.assert_invariants(traj, energy=1e-6)
    msg = str(info.value)
    assert "| |q| - 1 | reached" in msg and "tolerance 1e-10" in msg
    assert "the energy changed by" in msg and "t = 10" in msg
    # an ensemble names the body
    L0 = np.stack([p.L0, p.L0 * 2.0])
    with pytest.warns(liebody.InvariantWarning, match="euler"):
        traj = liebody.integrate(p.scene, q0=p.q0, L0=L0, dt=0.01, steps=1000,
                                 method="euler")
    with pytest.raises(AssertionError, match="of body 1"):
        testing.assert_invariants(traj, energy=None)
    # liebody's exact flow passes everything
    traj = liebody.integrate(p.scene, q0=p.q0, L0=p.L0, dt=0.1, steps=1000)
    testing.assert_invariants(traj, qnorm=1e-14, casimir=1e-14, spatial_L=1e-13, energy=1e-14)


def test_bad_input_is_named():
    p = testing.problem("hlw")
    with pytest.raises(ValueError, match="unknown method 'nope'"):
        testing.observed_order("nope", p)
    with pytest.raises(ValueError, match="cannot integrate"):
        testing.observed_order("dmv6", "top")
    with pytest.raises(ValueError, match="no step and no order"):
        testing.observed_order("exact", p)
    with pytest.raises(ValueError, match="dt must be finite and > 0"):
        testing.run_step(python_rk4(p.scene.moments), p, dt=0.0, steps=3)
    with pytest.raises(TypeError, match="step function must return"):
        testing.run_step(lambda q, L, h: q, p, dt=0.1, steps=3)
    with pytest.raises(ValueError, match="exact on this problem"):
        testing.observed_order("splitting4", "symmetric")
    with pytest.raises(TypeError, match="problem must be"):
        testing.observed_order("splitting2", 3)


def test_a_step_that_blows_up_ends_the_run():
    p = testing.problem("hlw")

    def bad(q, L, h):
        return q, L + math.inf

    with pytest.warns(RuntimeWarning, match=r"bad: the state became non-finite in the step "
                                            r"from t = 0 to t = 0\.1 \(after 0 steps\); "
                                            r"returning the 1 samples"):
        traj = testing.run_step(bad, p, dt=0.1, steps=5)
    assert traj.status == "failed" and traj.failed_at == pytest.approx(0.1) and len(traj) == 1


def test_a_numba_compiled_step_function():
    """A user's step compiled with numba: the midpoint rule (order 2) on Euler's equations
    and the quaternion kinematics, normalising q."""
    import numba

    p = testing.problem("asym")
    inv = 1.0 / p.scene.moments
    kinematics = numba.njit(qdot)

    @numba.njit
    def f(q, L):
        w = L * inv
        return kinematics(q, w), np.cross(L, w)

    @numba.njit
    def midpoint(q, L, h):
        dq, dL = f(q, L)
        dq, dL = f(q + 0.5 * h * dq, L + 0.5 * h * dL)
        q = q + h * dq
        return q / np.sqrt(np.sum(q * q)), L + h * dL

    found = testing.assert_order(midpoint, p, 2)
    assert found.reliable


def test_assert_invariants_fails_runs_that_did_not_complete():
    """A run that failed is not a pass, whatever its samples before the failure (before:
    a failed body of an ensemble was skipped, and a failed one-body run passed)."""
    p = testing.problem("hlw")

    def dies(q, L, h, n=[0]):  # noqa: B006 - a counter kept between calls
        n[0] += 1
        return (q, L) if n[0] < 500 else (q * np.nan, L)

    with pytest.warns(RuntimeWarning, match=r"non-finite in the step from t = 4\.99 to "
                                            r"t = 5 \(after 499 steps\)"):
        traj = testing.run_step(dies, "hlw", dt=0.01, steps=1000)
    assert traj.status == "failed"
    with pytest.raises(AssertionError, match=r"the run did not complete: failed at t = "):
        testing.assert_invariants(traj, energy=None)
    scene = liebody.FreeBody(liebody.RigidBody([1.0, 2.0, 3.0]))
    with pytest.warns(RuntimeWarning):
        ens = liebody.integrate(scene, L0=[[0, 0.1, 0.05], [0, 50, 3], [0, 0.2, 0.01]],
                                dt=0.1, steps=200, method="rattle")
    for energy in ("auto", 1e-12, None):
        with pytest.raises(AssertionError, match=r"1 of 3 bodies did not complete "
                                                 r"\(e\.g\. body 1"):
            testing.assert_invariants(ens, energy=energy)
    assert repr(traj).startswith("Trajectory(method='dies'")
    assert p.L0.flags.writeable is False and p.q0.flags.writeable is False


@pytest.mark.parametrize(("kwargs", "error", "words"), [
    ({"casimir": "x"}, TypeError, "casimir must be a number"),
    ({"qnorm": -1.0}, ValueError, "qnorm must be finite and > 0"),
    ({"spatial_L": 0.0}, ValueError, "spatial_L must be finite and > 0"),
    ({"energy": "drift"}, TypeError, "energy must be a number"),
])
def test_assert_invariants_checks_its_tolerances(kwargs, error, words):
    p = testing.problem("hlw")
    traj = liebody.integrate(p.scene, q0=p.q0, L0=p.L0, dt=0.1, steps=100, method="rattle")
    with pytest.raises(error, match=words):
        testing.assert_invariants(traj, **kwargs)


def test_bounded_oscillations_are_not_called_random_walks():
    """A bounded error whose period beats with the block length leaves block means that
    wander like a random walk over short lags (before: 16 of 40 sines of random
    frequency were called "random walk", and so was splitting2 on the HLW body). They
    wander far less than the error spreads within a block; a random walk's wander far
    more. Sines, symplectic runs and random walks of known law, each told apart."""
    t = np.arange(200_000.0)
    rng = np.random.default_rng(0)
    for f in rng.uniform(0.01, 3.0, 40):
        verdict = testing.energy_drift(t=t, energy=1 + 1e-6 * np.sin(f * t))
        assert verdict.kind == "bounded" and 0.0 <= verdict.confidence <= 1.0, (f, verdict)
    walks = [testing.energy_drift(t=t, energy=1 + 1e-9 * np.cumsum(
        np.random.default_rng(seed).normal(size=t.size))).kind for seed in range(20)]
    assert walks.count("bounded") == 0 and walks.count("random walk") >= 16, walks
    p = testing.problem("hlw")
    traj = liebody.integrate(p.scene, q0=p.q0, L0=p.L0, dt=0.013, steps=600_000,
                             method="splitting2", save_every=10)
    assert testing.energy_drift(traj).kind == "bounded"


def test_a_run_step_that_keeps_q_warns_nothing():
    """run_step warns as integrate does: nothing for a healthy run (the splitting keeps
    |q| to round-off); an InvariantWarning (|q|) and a failure warning are tested above."""
    import warnings

    p = testing.problem("asym")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        testing.run_step(python_splitting(p.scene.moments), p, dt=0.05, steps=200)


def test_a_failed_run_with_few_samples_is_reported_as_failed():
    """A one-body run that failed before the 64 samples the energy verdict needs: the
    assertion says the run failed, and when (before: a ValueError about 64 samples)."""

    def dies(q, L, h, n=[0]):  # noqa: B006 - a counter kept between calls
        n[0] += 1
        return (q, L) if n[0] < 30 else (q, L * np.nan)

    with pytest.warns(RuntimeWarning, match=r"non-finite in the step from t = 0\.29 to "
                                            r"t = 0\.3 \(after 29 steps\)"):
        traj = testing.run_step(dies, "hlw", dt=0.01, steps=1000)
    assert len(traj) == 30
    with pytest.raises(AssertionError, match=r"the run did not complete: failed at "
                                             r"t = 0\.3\b"):
        testing.assert_invariants(traj)  # energy="auto": "bounded" for the free body
    # a complete run that short is bad input, as before
    short = testing.run_step(python_splitting(testing.problem("hlw").scene.moments), "hlw",
                             dt=0.01, steps=30)
    with pytest.raises(ValueError, match="at least 64 samples"):
        testing.assert_invariants(short)


def test_energy_drift_finds_a_drift_under_a_fast_oscillation():
    """A trend of 3e-10 per unit time (160 standard errors) under an oscillation of
    amplitude 1e-6 and period 2 pi, slower than the 256 blocks (T / 256 = 3.9): the
    structure function sees the oscillation, the 20 blocks of the trend's fit average
    it out (before: "bounded", confidence 1.00)."""
    t = np.linspace(0.0, 1000.0, 20_001)
    found = testing.energy_drift(t=t, energy=1.0 + 3e-10 * t + 1e-6 * np.sin(t))
    assert found.kind == "drift", found
    expected = 3e-10 + np.polyfit(t, 1e-6 * np.sin(t), 1)[0]  # the sine's own slope
    assert abs(found.rate - expected) < 5 * found.rate_stderr < 0.05 * 3e-10, found
    assert found.confidence > 0.9, found
    # the oscillation alone, and with a trend 100 times smaller (1.6 sigma), is bounded
    for rate in (0.0, 3e-12):
        found = testing.energy_drift(t=t, energy=1.0 + rate * t + 1e-6 * np.sin(t))
        assert found.kind == "bounded", (rate, found)


@pytest.mark.parametrize("periods", [0.1, 1 / 3, 1.0, 2.0, 2.5])
def test_energy_drift_says_when_a_run_is_too_short(periods):
    """An oscillation seen for fewer than 3 periods cannot be told from a drift or a
    random walk (before: a third of a period was "drift", confidence 1.00; two periods a
    "random walk", confidence 1.00): "undetermined", and assert_invariants fails."""
    t = np.linspace(0.0, 1.0, 1000)
    energy = 1.0 + 1e-6 * np.sin(2 * np.pi * periods * t + 0.3)
    found = testing.energy_drift(t=t, energy=energy)
    assert found.kind == "undetermined" and found.confidence == 0.0, found
    assert found.cycles < testing.MIN_CYCLES
    assert "too short to tell" in str(found)
    # an oscillation over a thousand periods is bounded; a clean ramp is a drift
    long_t = np.linspace(0.0, 2000.0, 20_000)
    assert testing.energy_drift(t=long_t, energy=1.0 + 1e-6 * np.sin(
        3.1 * long_t + 0.3)).kind == "bounded"
    ramp = testing.energy_drift(t=t, energy=1.0 + 1e-9 * t)
    assert ramp.kind == "drift" and ramp.cycles == math.inf, ramp


def test_assert_invariants_fails_a_run_too_short_to_tell():
    p = testing.problem("hlw")
    traj = liebody.integrate(p.scene, q0=p.q0, L0=p.L0, dt=0.01, steps=200,
                             method="splitting2")  # a fifth of the orbit's period or so
    assert testing.energy_drift(traj).kind == "undetermined"
    with pytest.raises(AssertionError, match="the energy could not be shown bounded: "
                                             "undetermined: the run is too short"):
        testing.assert_invariants(traj)
    testing.assert_invariants(traj, energy=1e-4)  # a tolerance decides


def test_observed_order_names_the_step_whose_result_was_not_finite():
    """A step that returns NaN: the error names the step sizes (before: "no asymptotic
    range ... inf", never NaN); one that breaks only at small steps no longer hands back
    the order read from the larger ones."""
    p = testing.problem("asym")
    with pytest.raises(ValueError, match=r"not finite .* at h = 0\.25, 0\.125"):
        testing.observed_order(lambda q, L, h: (q * np.nan, L), p)
    good = python_splitting(p.scene.moments)

    def breaks_small(q, L, h):
        return good(q, L, h) if h > 0.05 else (q, L * np.nan)

    with pytest.raises(ValueError, match=r"not finite .* at h = 0\.03125\b"):
        testing.observed_order(breaks_small, p)
    with pytest.raises(ValueError, match=r"not finite .* at h = 0\.0625, 0\.03125"):
        testing.observed_order(error=lambda n: math.nan if n >= 16 else 0.05 / n**2,
                               t_end=1.0, h_max=0.5)


def test_observed_order_of_an_error_function():
    """error(n) against one's own reference: a known law C h^3 with a large-step regime
    refused (inf) and a round-off floor."""
    def error(n):
        h = 1.0 / n
        return math.inf if h > 0.3 else max(0.7 * h**3, 3e-13)

    found = testing.observed_order(error=error, t_end=1.0)
    assert abs(found.order - 3.0) < 1e-9 and found.reliable and found.steps[0] <= 0.3
    with pytest.raises(ValueError, match="not both"):
        testing.observed_order("splitting2", "hlw", error=error)
    with pytest.raises(ValueError, match="needs t_end"):
        testing.observed_order(error=error)
    with pytest.raises(ValueError, match="give a method and a problem"):
        testing.observed_order("splitting2")
