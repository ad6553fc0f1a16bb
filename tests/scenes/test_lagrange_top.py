"""liebody.lagrange_top against the heavy symmetric top of Hand & Finch, *Analytical
Mechanics*, ch. 8, and independent references.

The references here do not use the module under test: the Euler-Lagrange equations of
the top's Lagrangian written out by hand (general mass-matrix form, no conservation law
built in) and integrated with scipy's DOP853; the effective potential written out again
and differentiated by complex step; finite differences of the Lagrangian; numpy's
polynomial roots; liebody.euler / liebody.quaternion for the (q, L) states.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.polynomial import Polynomial
from scipy import optimize
from scipy.integrate import solve_ivp

from liebody import euler as E
from liebody import quaternion as Q
from liebody.lagrange_top import (
    ConservedQuantities,
    LagrangeTop,
    SteadyPrecession,
    TopMotion,
    TurningPoints,
)
from liebody.rigid_body import RigidBody

TOP = LagrangeTop(1.2, 0.4, 0.9)
RTOL_ODE = 1e-12

# hand-made initial conditions (angles, rates) for TOP
GENERIC = ([0.1, 0.6, 0.2], [0.3, 0.5, 6.0])  # phidot changes sign: loops
REST = ([0.0, 0.8, 0.0], [0.0, 0.0, 5.0])  # released with phidot = thetadot = 0: cusps
LOOPS = ([0.0, 0.8, 0.0], [-0.5, 0.0, 5.0])  # started against the precession: loops
MONOTONE = ([0.0, 0.8, 0.0], [0.2, 0.0, 5.0 - 0.2 * math.cos(0.8)])  # below the slow rate
HANGING = ([0.0, 2.5, 0.0], [0.4, 0.3, 2.0])  # centre of mass below the fixed point


# --------------------------------------------------------------------------------------
# independent references
# --------------------------------------------------------------------------------------


def ref_veff(top, th, p_phi, p_psi):
    """V_eff of Hand & Finch, written again (complex-safe for complex-step derivatives)."""
    return (p_phi - p_psi * np.cos(th)) ** 2 / (2 * top.I1 * np.sin(th) ** 2) + top.mgl * np.cos(
        th)


def ref_dveff(top, th, p_phi, p_psi):
    """dV_eff/dtheta by complex step (exact to round-off, no formula shared)."""
    h = 1e-30
    return np.imag(ref_veff(top, th + 1j * h, p_phi, p_psi)) / h


def el_rhs(top):
    """Euler-Lagrange equations of L = 1/2 I1 (phid^2 s^2 + thd^2) + 1/2 I3 (psid + phid c)^2
    - mgl c in the general form M(q) qdd = dL/dq - Mdot(q) qd (hand-derived mass matrix
    M = [[I1 s^2 + I3 c^2, 0, I3 c], [0, I1, 0], [I3 c, 0, I3]]), no conservation law used."""
    I1, I3, mgl = top.I1, top.I3, top.mgl

    def rhs(t, y):
        _, th, _, phid, thd, psid = y
        s, c = math.sin(th), math.cos(th)
        # theta row: I1 thdd = dL/dtheta
        dLdth = I1 * phid**2 * s * c - I3 * (psid + phid * c) * phid * s + mgl * s
        thdd = dLdth / I1
        # (phi, psi) rows: [[A, C], [C, I3]] (phidd, psidd) = -thd dM/dth (phid, psid)
        A, C = I1 * s * s + I3 * c * c, I3 * c
        r1 = -thd * (2 * (I1 - I3) * s * c * phid - I3 * s * psid)
        r2 = -thd * (-I3 * s * phid)
        det = A * I3 - C * C
        phidd = (r1 * I3 - C * r2) / det
        psidd = (A * r2 - C * r1) / det
        return [phid, thd, psid, phidd, thdd, psidd]

    return rhs


def integrate_el(top, angles, rates, t_end, **kw):
    y0 = np.concatenate([angles, rates]).astype(float)
    return solve_ivp(el_rhs(top), (0.0, t_end), y0, method="DOP853", rtol=RTOL_ODE,
                     atol=RTOL_ODE, dense_output=True, **kw)


def period_1d(top, motion, theta0, thetadot0, n=4):
    """Nutation period from I1 thetadd = -dV_eff/dtheta (complex-step V_eff'), measured
    between successive downward zero crossings of thetadot."""

    def rhs(t, y):
        return [y[1], -ref_dveff(top, y[0], motion.p_phi, motion.p_psi) / top.I1]

    def ev(t, y):
        return y[1]

    ev.direction = -1
    guess = motion.nutation_period()
    sol = solve_ivp(rhs, (0.0, (n + 1.5) * guess), [theta0, thetadot0], method="DOP853",
                    rtol=RTOL_ODE, atol=RTOL_ODE, events=ev)
    te = sol.t_events[0]
    assert len(te) >= n
    return np.diff(te)


def text_beta_roots(top, theta0, p_psi):
    """Hand & Finch's closed form beta = p_psi s^2/(2c) [1 +- sqrt(1 - 4 mgl I1 c / p_psi^2)]."""
    s, c = math.sin(theta0), math.cos(theta0)
    root = math.sqrt(1 - 4 * top.mgl * top.I1 * c / p_psi**2)
    pre = p_psi * s**2 / (2 * c)
    return pre * (1 + root), pre * (1 - root)


# --------------------------------------------------------------------------------------
# Lagrangian and constants of motion
# --------------------------------------------------------------------------------------


def test_lagrangian_momenta_and_energy_are_the_text_formulas():
    rng = np.random.default_rng(1)
    for _ in range(5):
        a = np.array([rng.uniform(-3, 3), rng.uniform(0.2, 2.9), rng.uniform(-3, 3)])
        r = rng.uniform(-4, 4, 3)
        c = TOP.conserved(a, r)
        # T = 1/2 sum I_k omega_k^2 from liebody.euler.omega_body (angular velocity route)
        w = E.omega_body(a, r)
        T = 0.5 * (TOP.I1 * (w[0] ** 2 + w[1] ** 2) + TOP.I3 * w[2] ** 2)
        V = TOP.mgl * math.cos(a[1])
        assert TOP.lagrangian(a, r) == pytest.approx(T - V, rel=1e-13, abs=1e-13)
        assert TOP.energy(a, r) == pytest.approx(T + V, rel=1e-13, abs=1e-13)
        # p = dL/dqdot by central differences; E = sum qdot p - L (Legendre)
        h = 1e-5
        grad = []
        for k in range(3):
            e = np.zeros(3)
            e[k] = h
            grad.append((TOP.lagrangian(a, r + e) - TOP.lagrangian(a, r - e)) / (2 * h))
        assert c.p_phi == pytest.approx(grad[0], rel=1e-9, abs=1e-9)
        assert grad[1] == pytest.approx(TOP.I1 * r[1], rel=1e-9)
        assert c.p_psi == pytest.approx(grad[2], rel=1e-9, abs=1e-9)
        assert c.energy == pytest.approx(np.dot(r, grad) - TOP.lagrangian(a, r), rel=1e-9)
        # E' = E - p_psi^2 / (2 I3) = 1/2 I1 thetadot^2 + V_eff(theta)
        assert c.e_prime == pytest.approx(c.energy - c.p_psi**2 / (2 * TOP.I3), rel=1e-12)
        veff = ref_veff(TOP, a[1], c.p_phi, c.p_psi)
        assert c.e_prime == pytest.approx(0.5 * TOP.I1 * r[1] ** 2 + veff, rel=1e-11)
        # phidot(theta), psidot(theta) from p_phi, p_psi recover the rates
        m = TOP.motion(a, r)
        assert m.precession_rate(a[1]) == pytest.approx(r[0], rel=1e-11, abs=1e-11)
        assert m.spin_rate(a[1]) == pytest.approx(r[2], rel=1e-11, abs=1e-11)
        assert m.energy == pytest.approx(c.energy, rel=1e-13)
        assert m.omega3 == pytest.approx(w[2], rel=1e-13)


def test_conserved_from_angles_and_from_state_agree():
    rng = np.random.default_rng(2)
    n = 50
    angles = np.stack([rng.uniform(-np.pi, np.pi, n), rng.uniform(0.05, 3.1, n),
                       rng.uniform(-np.pi, np.pi, n)], axis=-1)
    rates = rng.uniform(-5, 5, (n, 3))
    q = E.to_quaternion(angles)
    L = E.omega_body(angles, rates) * np.array([TOP.I1, TOP.I1, TOP.I3])
    ca = TOP.conserved(angles, rates)
    cs = TOP.conserved_from_state(q, L)
    cneg = TOP.conserved_from_state(-q, L)  # the same rotation
    for x, y, z in zip(ca, cs, cneg, strict=True):
        assert np.shape(x) == (n,)
        np.testing.assert_allclose(x, y, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(y, z, rtol=1e-14, atol=1e-14)
    # the (q, L) formulas against quaternion.to_matrix: p_phi = (R L)_z, cos th = R[2, 2]
    R = Q.to_matrix(q)
    np.testing.assert_allclose(cs.p_phi, np.einsum("...j,...j", R[..., 2, :], L), rtol=1e-12)
    np.testing.assert_allclose(cs.p_psi, L[:, 2], rtol=0, atol=0)
    e_ref = (0.5 * np.sum(L**2 / np.array([TOP.I1, TOP.I1, TOP.I3]), axis=-1)
             + TOP.mgl * R[..., 2, 2])
    np.testing.assert_allclose(cs.energy, e_ref, rtol=1e-12)
    # state_from_euler is the same construction
    q2, L2 = TOP.state_from_euler(angles, rates)
    np.testing.assert_allclose(q2, q, atol=1e-15, rtol=0)
    np.testing.assert_allclose(L2, L, rtol=1e-15)
    # single states give floats; theta = 0 (gimbal lock) is fine: p_phi = p_psi
    single = TOP.conserved([0.3, 0.0, 0.2], [1.0, 0.0, 2.0])
    assert isinstance(single, ConservedQuantities)
    assert all(isinstance(v, float) for v in single)
    assert single.p_phi == pytest.approx(single.p_psi) == pytest.approx(TOP.I3 * 3.0)


def test_constants_are_conserved_along_euler_lagrange_integration():
    a0, r0 = GENERIC
    sol = integrate_el(TOP, a0, r0, 25.0)
    t = np.linspace(0, 25.0, 400)
    y = sol.sol(t).T
    angles, rates = y[:, :3], y[:, 3:]
    assert np.ptp(angles[:, 1]) > 0.5  # it nutates strongly: a wrong formula would drift
    ca = TOP.conserved(angles, rates)
    q = E.to_quaternion(angles)
    L = E.omega_body(angles, rates) * np.array([TOP.I1, TOP.I1, TOP.I3])
    cs = TOP.conserved_from_state(q, L)
    for name in ConservedQuantities._fields:
        for series in (getattr(ca, name), getattr(cs, name)):
            scale = max(1.0, abs(series[0]))
            assert np.ptp(series) < 1e-9 * scale, name
    # the individual energy terms do vary: the check above is not vacuous
    assert np.ptp(TOP.lagrangian(angles, rates)) > 0.1


# --------------------------------------------------------------------------------------
# effective potential and steady precession
# --------------------------------------------------------------------------------------


def test_effective_potential_and_text_derivative():
    m = TOP.motion(*GENERIC)
    th = np.linspace(0.05, 3.09, 41)
    np.testing.assert_allclose(m.effective_potential(th), ref_veff(TOP, th, m.p_phi, m.p_psi),
                               rtol=1e-14)
    np.testing.assert_allclose(m.effective_potential_derivative(th),
                               ref_dveff(TOP, th, m.p_phi, m.p_psi), rtol=1e-11, atol=1e-12)
    # dV_eff/dth = -Q(beta) / (I1 sin^3 th), Q the steady-precession quadratic in beta
    s, c = np.sin(th), np.cos(th)
    beta = m.p_phi - m.p_psi * c
    quad = c * beta**2 - m.p_psi * s**2 * beta + TOP.mgl * TOP.I1 * s**4
    np.testing.assert_allclose(ref_dveff(TOP, th, m.p_phi, m.p_psi), -quad / (TOP.I1 * s**3),
                               rtol=1e-11, atol=1e-12)
    # singular points: inf unless the numerator vanishes too; the derivative is NaN
    assert TOP.effective_potential(0.0, 1.0, 2.0) == math.inf
    assert TOP.effective_potential(0.0, 2.0, 2.0) == pytest.approx(TOP.mgl)
    assert math.isnan(TOP.effective_potential_derivative(0.0, 1.0, 2.0))
    assert math.isnan(m.precession_rate(0.0))


@pytest.mark.parametrize("theta0", [0.4, 1.2, 2.3])
@pytest.mark.parametrize("branch", ["slow", "fast"])
def test_steady_precession_is_the_minimum_of_veff(theta0, branch):
    omega3 = 7.0
    sp = TOP.steady_precession(theta0, omega3)
    phid = sp.phidot_fast if branch == "fast" else sp.phidot_slow
    p_psi = TOP.I3 * omega3
    beta = sp.beta_fast if branch == "fast" else sp.beta_slow
    assert beta == pytest.approx(TOP.I1 * math.sin(theta0) ** 2 * phid, rel=1e-14)
    p_phi = beta + p_psi * math.cos(theta0)
    # the initial conditions carry these constants
    a, r = TOP.steady_precession_initial_conditions(theta0, omega3, branch, phi=0.3, psi=-1.0)
    c = TOP.conserved(a, r)
    assert (c.p_phi, c.p_psi) == pytest.approx((p_phi, p_psi), rel=1e-13)
    np.testing.assert_array_equal(a, [0.3, theta0, -1.0])
    assert r[1] == 0.0
    # V_eff' = 0 at theta0 (complex step) and theta0 is the minimiser (scipy.optimize)
    d = ref_dveff(TOP, theta0, p_phi, p_psi)
    scale = TOP.mgl + abs(p_phi * p_psi) / TOP.I1
    assert abs(d) < 1e-12 * scale
    root = optimize.brentq(lambda x: ref_dveff(TOP, x, p_phi, p_psi),
                           theta0 - 0.2, min(theta0 + 0.2, 3.1), xtol=1e-15)
    assert root == pytest.approx(theta0, abs=1e-12)
    res = optimize.minimize_scalar(lambda x: ref_veff(TOP, x, p_phi, p_psi),
                                   bounds=(0.02, 3.12), method="bounded",
                                   options={"xatol": 1e-10})
    assert res.x == pytest.approx(theta0, abs=1e-6)
    # the steady-precession quadratic in beta and its closed-form roots
    s, cc = math.sin(theta0), math.cos(theta0)
    for b in (sp.beta_fast, sp.beta_slow):
        terms = [cc * b * b, p_psi * s * s * b, TOP.mgl * TOP.I1 * s**4]
        assert abs(terms[0] - terms[1] + terms[2]) < 1e-14 * max(map(abs, terms))
    plus, minus = text_beta_roots(TOP, theta0, p_psi)
    assert sp.beta_fast == pytest.approx(plus, rel=1e-12)
    assert sp.beta_slow == pytest.approx(minus, rel=1e-12)
    assert abs(sp.phidot_fast) >= abs(sp.phidot_slow)
    assert isinstance(sp, SteadyPrecession)


@pytest.mark.parametrize("theta0", [0.5, 2.3])
@pytest.mark.parametrize("branch", ["slow", "fast"])
def test_steady_precession_initial_conditions_stay_at_theta0(theta0, branch):
    omega3 = 7.0
    a, r = TOP.steady_precession_initial_conditions(theta0, omega3, branch)
    t_end = 12.0
    sol = integrate_el(TOP, a, r, t_end)
    y = sol.sol(np.linspace(0, t_end, 300))
    assert np.max(np.abs(y[1] - theta0)) < 1e-9
    assert np.max(np.abs(y[3] - r[0])) < 1e-8 * max(1.0, abs(r[0]))
    assert abs(y[0, -1] - r[0] * t_end) < 1e-8 * max(1.0, abs(r[0] * t_end))
    # the (q, L) form is the same state
    q, L = TOP.steady_precession_state(theta0, omega3, branch)
    np.testing.assert_allclose(q, E.to_quaternion(a), atol=1e-15, rtol=0)
    np.testing.assert_allclose(L, E.omega_body(a, r) * [TOP.I1, TOP.I1, TOP.I3], rtol=1e-14)
    assert L[2] == pytest.approx(TOP.I3 * omega3, rel=1e-14)
    # the analysis sees steady precession: double root at theta0
    for m in (TOP.motion(a, r), TOP.motion_from_state(q, L)):
        tp = m.turning_points()
        assert tp.degenerate
        assert tp.theta1 == tp.theta2 == pytest.approx(theta0, abs=1e-7)
        assert m.motion_kind() == "steady"
        np.testing.assert_allclose(m.theta_of_time([0.0, 1.0, 5.0]), tp.theta1)


def test_steady_precession_unstarted_perturbation_does_not_stay():
    # a 1e-3 error in the precession rate makes the tilt oscillate: the check above can fail
    a, r = TOP.steady_precession_initial_conditions(0.5, 7.0, "slow")
    r = r + [1e-3, 0.0, 0.0]
    sol = integrate_el(TOP, a, r, 12.0)
    assert np.ptp(sol.sol(np.linspace(0, 12.0, 300))[1]) > 1e-5


def test_fast_top_approximations_converge_like_one_over_omega3_squared():
    for theta0 in (0.6, 2.2):
        errs = []
        omegas = [10.0, 20.0, 40.0, 80.0, 160.0]
        for w3 in omegas:
            sp = TOP.steady_precession(theta0, w3)
            fast, slow = TOP.steady_precession_approx(theta0, w3)
            # the fast-top forms I3 w3 / (I1 cos th0) and M g l / (I3 w3)
            assert fast == pytest.approx(TOP.I3 * w3 / (TOP.I1 * math.cos(theta0)), rel=1e-15)
            assert slow == pytest.approx(TOP.mgl / (TOP.I3 * w3), rel=1e-15)
            errs.append((abs(fast / sp.phidot_fast - 1), abs(slow / sp.phidot_slow - 1)))
        errs = np.array(errs)
        ratios = errs[:-1] / errs[1:]
        # error ratio on doubling omega3 -> 4, the higher orders dying out like 1/omega3^2
        np.testing.assert_allclose(ratios[-2:], 4.0, rtol=0.01)
        assert np.all(np.diff(np.abs(ratios - 4.0), axis=0) < 0)
        # leading coefficient eps / 4 = M g l I1 cos th0 / (I3 omega3)^2
        lead = TOP.mgl * TOP.I1 * abs(math.cos(theta0)) / (TOP.I3 * omegas[-1]) ** 2
        np.testing.assert_allclose(errs[-1], lead, rtol=1e-3)


def test_minimum_spin_just_above_works_just_below_raises():
    theta0 = 0.7
    wmin = 2.0 / TOP.I3 * math.sqrt(TOP.mgl * TOP.I1 * math.cos(theta0))
    assert TOP.minimum_spin(theta0) == pytest.approx(wmin, rel=1e-15)
    at = TOP.steady_precession(theta0, wmin)  # the double root: both rates equal
    assert at.omega3_min == pytest.approx(wmin, rel=1e-15)
    assert at.phidot_fast == pytest.approx(at.phidot_slow, rel=1e-6)
    above = TOP.steady_precession(theta0, wmin * (1 + 1e-9))
    assert above.phidot_fast > above.phidot_slow > 0
    assert above.phidot_fast == pytest.approx(above.phidot_slow, rel=1e-3)
    neg = TOP.steady_precession(theta0, -wmin * (1 + 1e-6))  # reversed spin precesses back
    assert neg.phidot_fast < neg.phidot_slow < 0
    for w in (wmin * (1 - 1e-9), -wmin * (1 - 1e-6), 0.0):
        with pytest.raises(ValueError, match="omega3") as info:
            TOP.steady_precession(theta0, w)
        assert "minimum spin" in str(info.value) and repr(wmin) in str(info.value)
        with pytest.raises(ValueError, match="minimum spin"):
            TOP.steady_precession_initial_conditions(theta0, w, "fast")
    # theta0 > pi/2: no limit
    assert TOP.minimum_spin(2.0) == 0.0
    sp = TOP.steady_precession(2.0, 1e-3)
    assert np.isfinite(sp.phidot_fast) and np.isfinite(sp.phidot_slow)
    # omega3 = 0 hanging: the conical pendulum, phidot^2 = -mgl / (I1 cos th0), both senses
    cp = TOP.steady_precession(2.0, 0.0)
    w_cone = math.sqrt(-TOP.mgl / (TOP.I1 * math.cos(2.0)))
    assert (cp.phidot_fast, cp.phidot_slow) == pytest.approx((-w_cone, w_cone), rel=1e-14)


def test_minimum_spin_at_zero_tilt_is_the_sleeping_top_limit():
    wmin = TOP.minimum_spin(0.0)
    assert wmin == pytest.approx(2.0 * math.sqrt(TOP.mgl * TOP.I1) / TOP.I3, rel=1e-15)
    q = np.array([1.0, 0.0, 0.0, 0.0])  # symmetry axis vertical
    stable = TOP.motion_from_state(q, [0.0, 0.0, TOP.I3 * wmin * 1.01])
    tp = stable.turning_points()
    assert tp.degenerate and tp.theta1 == tp.theta2 == 0.0
    assert stable.motion_kind() == "steady"
    unstable = TOP.motion_from_state(q, [0.0, 0.0, TOP.I3 * wmin * 0.99])
    tp = unstable.turning_points()
    assert not tp.degenerate and tp.theta1 == 0.0 and tp.theta2 > 0.1
    assert unstable.nutation_period() == math.inf  # the separatrix: it takes forever to fall
    # a slightly tilted, slowly spinning top falls through a wide band
    assert TOP.motion([0, 1e-3, 0], [0, 0, 0.99 * wmin]).turning_points().theta2 > 0.1


def test_precession_senses_for_a_hanging_top():
    """theta0 > pi/2. About the space vertical, the slow rate keeps the sign of omega3
    (-> mgl / (I3 omega3)) and the fast one flips with cos(theta0): the two have opposite
    signs. The usual "slow precession has opposite sense" holds relative to the
    symmetry axis (which then points down): sign(phidot cos(theta0) / omega3)."""
    w3 = 7.0
    up, down = TOP.steady_precession(0.5, w3), TOP.steady_precession(2.3, w3)
    assert up.phidot_fast > 0 and up.phidot_slow > 0
    assert down.phidot_fast < 0 < down.phidot_slow
    rel_up = np.sign([up.phidot_fast * math.cos(0.5), up.phidot_slow * math.cos(0.5)])
    rel_down = np.sign([down.phidot_fast * math.cos(2.3), down.phidot_slow * math.cos(2.3)])
    np.testing.assert_array_equal(rel_up, [1, 1])
    np.testing.assert_array_equal(rel_down, [1, -1])
    # the simulation agrees: phi advances at the slow rate for the hanging top
    a, r = TOP.steady_precession_initial_conditions(2.3, w3, "slow")
    sol = integrate_el(TOP, a, r, 5.0)
    assert sol.y[0, -1] == pytest.approx(down.phidot_slow * 5.0, rel=1e-9)
    assert sol.y[0, -1] > 0


# --------------------------------------------------------------------------------------
# turning points, nutation period, theta(t)
# --------------------------------------------------------------------------------------


CASES = {"generic": GENERIC, "rest": REST, "loops": LOOPS, "monotone": MONOTONE,
         "hanging": HANGING}


@pytest.mark.parametrize("name", sorted(CASES))
def test_turning_points_are_zeros_of_e_prime_minus_veff(name):
    a, r = CASES[name]
    m = TOP.motion(a, r)
    tp = m.turning_points()
    assert isinstance(tp, TurningPoints) and not tp.degenerate
    assert 0 < tp.theta1 < a[1] + 1e-12 and a[1] - 1e-12 < tp.theta2 < math.pi
    assert (tp.u1, tp.u2) == pytest.approx((math.cos(tp.theta1), math.cos(tp.theta2)))
    scale = abs(m.e_prime) + TOP.mgl
    for th in (tp.theta1, tp.theta2):
        assert abs(m.e_prime - ref_veff(TOP, th, m.p_phi, m.p_psi)) < 1e-13 * scale
    mid = 0.5 * (tp.theta1 + tp.theta2)
    assert m.e_prime - ref_veff(TOP, mid, m.p_phi, m.p_psi) > 0
    for th in (tp.theta1 - 1e-4, tp.theta2 + 1e-4):
        assert m.e_prime - ref_veff(TOP, th, m.p_phi, m.p_psi) < 0
    # the cubic: f(u) = (2/I1)(E' - V_eff) sin^2 th, and its roots by numpy
    th = np.linspace(0.1, 3.0, 13)
    np.testing.assert_allclose(
        m.cubic(np.cos(th)),
        2 / TOP.I1 * (m.e_prime - ref_veff(TOP, th, m.p_phi, m.p_psi)) * np.sin(th) ** 2,
        rtol=1e-11, atol=1e-12)
    u = Polynomial([0, 1])
    f = ((2 * m.e_prime - 2 * TOP.mgl * u) / TOP.I1 * (1 - u**2)
         - ((m.p_phi - m.p_psi * u) / TOP.I1) ** 2)
    np.testing.assert_allclose(m.cubic_coefficients(), f.coef[::-1], rtol=1e-14, atol=1e-14)
    roots = np.sort(np.real_if_close(f.roots()))
    np.testing.assert_allclose(roots, [tp.u2, tp.u1, tp.u3], rtol=1e-9, atol=1e-12)
    # the Euler-Lagrange trajectory turns at theta1 and theta2
    def ev(t, y):
        return y[4]

    sol = integrate_el(TOP, a, r, 3 * m.nutation_period(), events=ev)
    th_ev = sol.y_events[0][:, 1]
    assert len(th_ev) >= 4
    near = np.minimum(np.abs(th_ev - tp.theta1), np.abs(th_ev - tp.theta2))
    assert np.max(near) < 1e-8


@pytest.mark.parametrize("name", sorted(CASES))
def test_nutation_period_elliptic_vs_quadrature_vs_ode(name):
    a, r = CASES[name]
    m = TOP.motion(a, r)
    T = m.nutation_period()
    assert m.nutation_period("quad_u") == pytest.approx(T, rel=1e-11)
    assert m.nutation_period("quad_theta") == pytest.approx(T, rel=1e-11)
    periods = period_1d(TOP, m, a[1], r[1])
    np.testing.assert_allclose(periods, T, rtol=1e-9)
    # and from the full Euler-Lagrange equations
    def ev(t, y):
        return y[4]

    ev.direction = -1
    sol = integrate_el(TOP, a, r, 4.5 * T, events=ev)
    np.testing.assert_allclose(np.diff(sol.t_events[0]), T, rtol=1e-9)


def test_nutation_period_small_oscillation_limit():
    theta0 = 0.9
    a, r = TOP.steady_precession_initial_conditions(theta0, 6.0, "slow")
    m = TOP.motion(a, r)
    # V_eff''(theta0) by a central difference of the complex-step derivative
    h = 1e-5
    v2 = (ref_dveff(TOP, theta0 + h, m.p_phi, m.p_psi)
          - ref_dveff(TOP, theta0 - h, m.p_phi, m.p_psi)) / (2 * h)
    T0 = 2 * math.pi * math.sqrt(TOP.I1 / v2)
    for method in ("elliptic", "quad_u", "quad_theta"):
        assert m.nutation_period(method) == pytest.approx(T0, rel=1e-8)
    # a small nutation about it converges to T0 (error ~ amplitude^2)
    errs = []
    for kick in (1e-2, 5e-3):
        mk = TOP.motion(a, r + [0.0, kick, 0.0])
        assert not mk.turning_points().degenerate
        errs.append(abs(mk.nutation_period() / T0 - 1))
    assert errs[1] < errs[0] / 3 and errs[0] < 1e-2


def test_theta_of_time_matches_euler_lagrange_integration():
    a, r = GENERIC
    m = TOP.motion(a, r)
    tp = m.turning_points()
    T = m.nutation_period()

    def ev(t, y):
        return y[4]

    ev.direction = 1  # thetadot from - to +: the highest point theta1
    sol = integrate_el(TOP, a, r, 3.2 * T, events=ev)
    t1 = sol.t_events[0][0]
    assert sol.y_events[0][0, 1] == pytest.approx(tp.theta1, abs=1e-9)
    t = np.linspace(0.0, 3.2 * T, 200)
    np.testing.assert_allclose(m.theta_of_time(t - t1), sol.sol(t)[1], atol=1e-8, rtol=0)
    assert m.theta_of_time(0.0) == pytest.approx(tp.theta1, abs=1e-12)
    assert m.theta_of_time(0.5 * T) == pytest.approx(tp.theta2, abs=1e-12)
    assert m.theta_of_time(T) == pytest.approx(tp.theta1, abs=1e-12)


# --------------------------------------------------------------------------------------
# kind of motion
# --------------------------------------------------------------------------------------


def _phidot_series(a, r, t_end):
    sol = integrate_el(TOP, a, r, t_end)
    return sol.sol(np.linspace(0, t_end, 3000))[3]


def test_motion_kind_hand_made_cases():
    # released from rest: cusps, phidot never changes sign and touches 0 at theta1
    m = TOP.motion(*REST)
    tp = m.turning_points()
    assert tp.theta1 == pytest.approx(REST[0][1], abs=1e-12)
    assert m.motion_kind() == "cusps"
    pd = _phidot_series(*REST, 2 * m.nutation_period())
    assert pd.min() > -1e-9 and pd.max() > 0.1
    # p_phi / p_psi strictly between cos theta2 and cos theta1: loops, phidot takes both signs
    for case in (LOOPS, GENERIC):
        m = TOP.motion(*case)
        tp = m.turning_points()
        assert tp.u2 < m.p_phi / m.p_psi < tp.u1
        assert m.motion_kind() == "loops"
        pd = _phidot_series(*case, 2 * m.nutation_period())
        assert pd.min() < -0.05 and pd.max() > 0.05
    # phidot of one sign: monotone (undulating) precession
    for case in (MONOTONE, HANGING):
        m = TOP.motion(*case)
        tp = m.turning_points()
        assert not tp.u2 <= m.p_phi / m.p_psi <= tp.u1
        assert m.motion_kind() == "monotone"
        pd = _phidot_series(*case, 2 * m.nutation_period())
        assert pd.min() > 0.05 or pd.max() < -0.05
    # no spin and no vertical momentum: the axis swings in a vertical plane
    assert TopMotion(TOP, 0.0, 0.0, 0.5 * TOP.mgl).motion_kind() == "planar"


def test_motion_kind_cusp_tolerance():
    a, r = REST
    near = TOP.motion(a, [1e-5, 0.0, r[2]])  # almost released from rest
    assert near.motion_kind() == "monotone"
    assert near.motion_kind(tol=1e-3) == "cusps"
    back = TOP.motion(a, [-1e-5, 0.0, r[2]])
    assert back.motion_kind() == "loops"
    assert back.motion_kind(tol=1e-3) == "cusps"
    assert TOP.motion(a, r).motion_kind(tol=0.0) in ("cusps", "loops", "monotone")


# --------------------------------------------------------------------------------------
# constructors
# --------------------------------------------------------------------------------------


def test_constructors():
    body = RigidBody([2.0, 2.0, 1.0], mass=3.0)
    expect = LagrangeTop(2.0, 1.0, 3.0 * 9.81 * 0.5)
    assert LagrangeTop.from_body(body, cm=[0, 0, 0.5]) == expect
    assert LagrangeTop.from_body(body, l=0.5) == expect
    assert LagrangeTop.from_body(body, mgl=3.0 * 9.81 * 0.5) == expect
    assert LagrangeTop.from_mass(2.0, 1.0, mass=3.0, l=0.5) == expect
    assert LagrangeTop.from_body(body, l=0.5, mass=1.0, g=2.0).mgl == pytest.approx(1.0)
    # I1 = I2 to within rtol: averaged
    nearly = RigidBody([2.0, 2.0 * (1 + 1e-12), 1.0])
    i1 = LagrangeTop.from_body(nearly, mgl=1.0).I1
    assert i1 == pytest.approx(2.0 * (1 + 5e-13), rel=1e-15)
    # a spherical body with an offset centre of mass is a Lagrange top (I3 = I1)
    assert LagrangeTop.from_body(RigidBody([1.0, 1.0, 1.0]), mgl=2.0) == LagrangeTop(1, 1, 2)
    # from a HeavyTop scene
    from liebody.scenes import HeavyTop

    scene = HeavyTop(body, mass=3.0, cm=[0.0, 0.0, 0.5], g=9.81)
    assert LagrangeTop.from_heavy_top(scene) == expect
    # LagrangeTop is frozen
    with pytest.raises(AttributeError):
        expect.I1 = 3.0  # type: ignore[misc]


# --------------------------------------------------------------------------------------
# errors
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("kwargs", "exc", "match"),
    [
        ({"I1": 0.0, "I3": 1.0, "mgl": 1.0}, ValueError, "I1 must be > 0"),
        ({"I1": -1.0, "I3": 1.0, "mgl": 1.0}, ValueError, "I1 must be > 0"),
        ({"I1": 1.0, "I3": 0.0, "mgl": 1.0}, ValueError, "I3 must be > 0"),
        ({"I1": 1.0, "I3": 1.0, "mgl": 0.0}, ValueError, "mgl = M g l must be"),
        ({"I1": 1.0, "I3": 1.0, "mgl": -2.0}, ValueError, "mgl = M g l must be"),
        ({"I1": 1.0, "I3": 1.0, "mgl": math.nan}, ValueError, "mgl = M g l must be"),
        ({"I1": math.inf, "I3": 1.0, "mgl": 1.0}, ValueError, "I1 must be finite"),
        ({"I1": "1", "I3": 1.0, "mgl": 1.0}, TypeError, "I1 must be a real number"),
        ({"I1": 1.0, "I3": 1.0, "mgl": True}, TypeError, "mgl must be a real number"),
    ],
)
def test_constructor_errors(kwargs, exc, match):
    with pytest.raises(exc, match=match):
        LagrangeTop(**kwargs)


def test_from_body_and_from_mass_errors():
    body = RigidBody([2.0, 2.0, 1.0], mass=3.0)
    with pytest.raises(TypeError, match=r"body must be a liebody\.RigidBody"):
        LagrangeTop.from_body([2.0, 2.0, 1.0], mgl=1.0)
    with pytest.raises(ValueError, match=r"symmetric with I1 = I2"):
        LagrangeTop.from_body(RigidBody([1.0, 2.0, 2.5]), mgl=1.0)
    with pytest.raises(ValueError, match=r"symmetric with I1 = I2"):
        LagrangeTop.from_body(RigidBody([2.0, 2.0 * (1 + 1e-8), 1.0]), mgl=1.0)
    with pytest.raises(ValueError, match=r"symmetry axis along body axis 3.*symmetry_axis = 0"):
        LagrangeTop.from_body(RigidBody([1.0, 2.0, 2.0]), mgl=1.0)
    with pytest.raises(ValueError, match="cm must lie on the symmetry axis"):
        LagrangeTop.from_body(body, cm=[1e-3, 0.0, 0.5])
    with pytest.raises(ValueError, match="mgl = M g l must be"):
        LagrangeTop.from_body(body, cm=[0.0, 0.0, -0.5])
    with pytest.raises(ValueError, match="mgl = M g l must be"):
        LagrangeTop.from_body(body, l=0.0)
    with pytest.raises(ValueError, match=r"cm must have shape \(3,\)"):
        LagrangeTop.from_body(body, cm=[0.0, 0.5])
    with pytest.raises(ValueError, match="not both"):
        LagrangeTop.from_body(body, mgl=1.0, l=0.5)
    with pytest.raises(ValueError, match="not both"):
        LagrangeTop.from_body(body, l=0.5, cm=[0, 0, 0.5])
    with pytest.raises(ValueError, match="give mgl"):
        LagrangeTop.from_body(body)
    with pytest.raises(ValueError, match="mass is required"):
        LagrangeTop.from_body(RigidBody([2.0, 2.0, 1.0]), l=0.5)
    with pytest.raises(ValueError, match="g must be > 0"):
        LagrangeTop.from_body(body, l=0.5, g=0.0)
    with pytest.raises(ValueError, match="rtol must be > 0"):
        LagrangeTop.from_body(body, mgl=1.0, rtol=-1.0)
    with pytest.raises(ValueError, match="mass must be > 0"):
        LagrangeTop.from_mass(1.0, 1.0, mass=0.0, l=1.0)
    with pytest.raises(ValueError, match="mgl = M g l must be"):
        LagrangeTop.from_mass(1.0, 1.0, mass=1.0, l=-1.0)
    with pytest.raises(ValueError, match="g must be > 0"):
        LagrangeTop.from_mass(1.0, 1.0, mass=1.0, l=1.0, g=-9.81)
    with pytest.raises(TypeError, match=r"scene must be a liebody\.HeavyTop"):
        LagrangeTop.from_heavy_top(body)
    from liebody.scenes import HeavyTop

    with pytest.raises(ValueError, match="cm must lie on the symmetry axis"):
        LagrangeTop.from_heavy_top(HeavyTop(body, mass=1.0, cm=[0.1, 0.0, 0.5]))


def test_analysis_errors():
    with pytest.raises(ValueError, match=r"theta0 must lie in the open interval \(0, pi\)"):
        TOP.steady_precession(0.0, 10.0)
    with pytest.raises(ValueError, match=r"theta0 must lie in the open interval \(0, pi\)"):
        TOP.steady_precession(math.pi, 10.0)
    with pytest.raises(ValueError, match=r"theta0 must lie in the open interval"):
        TOP.steady_precession_approx(4.0, 10.0)
    with pytest.raises(ValueError, match="theta0 must be finite"):
        TOP.steady_precession(math.nan, 10.0)
    with pytest.raises(TypeError, match="omega3 must be a real number"):
        TOP.steady_precession(1.0, "fast")
    with pytest.raises(ValueError, match=r"theta0 must lie in \[0, pi\]"):
        TOP.minimum_spin(-0.1)
    with pytest.raises(ValueError, match="omega3 must be nonzero"):
        TOP.steady_precession_approx(1.0, 0.0)
    with pytest.raises(ValueError, match="branch must be 'slow' or 'fast'"):
        TOP.steady_precession_initial_conditions(1.0, 10.0, "medium")
    with pytest.raises(ValueError, match="branch must be 'slow' or 'fast'"):
        TOP.steady_precession_state(1.0, 10.0, "Slow")
    m = TOP.motion(*GENERIC)
    with pytest.raises(ValueError, match="method must be"):
        m.nutation_period("simpson")
    with pytest.raises(ValueError, match="tol must be >= 0"):
        m.motion_kind(tol=-1.0)
    with pytest.raises(ValueError, match="rtol must be > 0"):
        m.turning_points(rtol=0.0)
    # constants of no motion: E' below the minimum of V_eff
    bad = TopMotion(TOP, m.p_phi, m.p_psi, m.e_prime - 10.0)
    with pytest.raises(ValueError, match="below the minimum of V_eff"):
        bad.turning_points()
    with pytest.raises(ValueError, match="below the minimum of V_eff"):
        bad.nutation_period()
    with pytest.raises(TypeError, match="top must be a LagrangeTop"):
        TopMotion("top", 1.0, 1.0, 1.0)
    with pytest.raises(ValueError, match="p_phi must be finite"):
        TopMotion(TOP, math.inf, 1.0, 1.0)
    # input shapes and values of the state functions
    with pytest.raises(ValueError, match=r"angles must have shape \(\.\.\., 3\)"):
        TOP.conserved([0.0, 1.0], [0.0, 0.0, 1.0])
    with pytest.raises(ValueError, match="must broadcast"):
        TOP.conserved(np.zeros((2, 3)), np.zeros((3, 3)))
    with pytest.raises(ValueError, match="q must be a unit quaternion"):
        TOP.conserved_from_state([1.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0])
    with pytest.raises(ValueError, match=r"L must have shape \(\.\.\., 3\)"):
        TOP.conserved_from_state([1.0, 0.0, 0.0, 0.0], [0.0, 1.0])
    with pytest.raises(ValueError, match="must broadcast"):
        TOP.conserved_from_state(np.tile([1.0, 0, 0, 0], (2, 1)), np.zeros((3, 3)))
    with pytest.raises(ValueError, match=r"angles must have shape \(3,\)"):
        TOP.motion(np.zeros((2, 3)), np.zeros((2, 3)))
    with pytest.raises(ValueError, match=r"q must have shape \(4,\)"):
        TOP.motion_from_state(np.tile([1.0, 0, 0, 0], (2, 1)), np.zeros((2, 3)))
    with pytest.raises(ValueError, match="theta must be finite"):
        TOP.effective_potential(math.nan, 1.0, 1.0)
    with pytest.raises(TypeError, match="p_psi must be a real number"):
        TOP.effective_potential(1.0, 1.0, None)
