"""liebody's HeavyTop integrators against the Lagrange-top analysis (Hand & Finch, ch. 8).

The analysis (liebody.lagrange_top) is itself checked against an independent
Euler–Lagrange integration in test_lagrange_top.py; here the quaternion integrators
must reproduce it: the nutation band and period, steady precession, cusps for a
released top, loops when p_phi / p_psi says so.
"""

from __future__ import annotations

import numpy as np
import pytest

import liebody
from liebody import euler
from liebody import lagrange_top as lt

I1, I3, MGL = 5.0, 1.0, 20.0


def top() -> liebody.HeavyTop:
    return liebody.HeavyTop(liebody.RigidBody([I1, I1, I3]), mass=20.0, cm=[0, 0, 1.0], g=1.0)


def model() -> lt.LagrangeTop:
    return lt.LagrangeTop.from_heavy_top(top())


def minima_times(t, theta):
    """Times of the interior minima of theta, refined by a parabola through 3 samples."""
    i = np.flatnonzero((theta[1:-1] < theta[:-2]) & (theta[1:-1] <= theta[2:])) + 1
    a, b, c = theta[i - 1], theta[i], theta[i + 1]
    dt = t[1] - t[0]
    return t[i] + 0.5 * dt * (a - c) / (a - 2 * b + c)


@pytest.mark.parametrize("name", ["splitting2", "splitting4", "rattle"])
def test_released_top_nutation_band_period_and_cusps(name):
    theta0, spin = 0.5, 30.0
    q0 = euler.to_quaternion([0.0, theta0, 0.0])
    L0 = np.array([0.0, 0.0, I3 * spin])  # released: thetadot = phidot = 0
    motion = model().motion_from_state(q0, L0)
    band = motion.turning_points()
    period = motion.nutation_period()
    assert motion.motion_kind() == "cusps"
    assert abs(band.theta1 - theta0) < 1e-12  # released at the upper turning point

    dt = 2e-4
    tr = liebody.integrate(top(), q0=q0, L0=L0, dt=dt, t_end=3.0, method=name)
    angles = tr.euler_angles(unwrap=True)
    theta = angles[:, 1]
    assert abs(theta.min() - band.theta1) < 1e-6
    assert abs(theta.max() - band.theta2) < 1e-6  # sampled maximum, dt^2 close
    tmin = minima_times(tr.t, theta)
    measured = np.mean(np.diff(np.r_[0.0, tmin]))
    assert abs(measured - period) < 1e-5 * period
    # cusps: at each return to theta1 the precession rate phidot vanishes
    phidot = np.gradient(angles[:, 0], tr.t)
    i = np.round(tmin / dt).astype(int)
    assert np.abs(phidot[i]).max() < 2e-3 * np.abs(phidot).max()
    assert np.all(phidot > -1e-6)  # the axis never moves backwards: cusps, not loops


def test_steady_precession_stays_on_theta0():
    for branch in ("slow", "fast"):
        q0, L0 = model().steady_precession_state(0.7, 40.0, branch=branch)
        rates = model().steady_precession(0.7, 40.0)
        tr = liebody.integrate(top(), q0=q0, L0=L0, dt=1e-3, t_end=2.0, method="splitting4",
                               save_every=10)
        angles = tr.euler_angles(unwrap=True)
        assert np.abs(angles[:, 1] - 0.7).max() < 1e-7, branch
        phidot = np.polyfit(tr.t, angles[:, 0], 1)[0]
        expected = rates.phidot_slow if branch == "slow" else rates.phidot_fast
        assert abs(phidot - expected) < 1e-7 * abs(expected), branch


def test_loops_when_phidot_changes_sign():
    """Start with a backward precession: p_phi / p_psi between cos theta2 and cos theta1."""
    angles0 = np.array([0.0, 0.6, 0.0])
    rates0 = np.array([-1.0, 0.0, 30.0])  # phidot < 0 at the start
    q0, L0 = model().state_from_euler(angles0, rates0)
    motion = model().motion_from_state(q0, L0)
    assert motion.motion_kind() == "loops"
    tr = liebody.integrate(top(), q0=q0, L0=L0, dt=5e-4, t_end=3.0)
    angles = tr.euler_angles(unwrap=True)
    phidot = np.gradient(angles[:, 0], tr.t)
    assert phidot.min() < -0.5 and phidot.max() > 0.5  # forwards and backwards: loops
    band = motion.turning_points()
    assert abs(angles[:, 1].min() - band.theta1) < 1e-5
    assert abs(angles[:, 1].max() - band.theta2) < 1e-5


def test_conserved_quantities_of_the_analysis_are_kept():
    q0 = euler.to_quaternion([0.3, 0.9, -0.4])
    L0 = np.array([1.5, -0.7, 25.0])
    m = model()
    tr = liebody.integrate(top(), q0=q0, L0=L0, dt=1e-3, steps=5000, save_every=50)
    c = m.conserved_from_state(tr.orientation, tr.L)
    assert np.abs(c.p_psi - c.p_psi[0]).max() < 1e-12 * abs(c.p_psi[0])
    assert np.abs(c.p_phi - c.p_phi[0]).max() < 1e-12 * np.linalg.norm(L0)
    assert np.abs(c.energy - c.energy[0]).max() < 1e-6 * abs(c.energy[0])
    np.testing.assert_allclose(c.energy, tr.energy, rtol=1e-13)
