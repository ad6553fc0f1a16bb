"""liebody.analysis for spacecraft and planets, against independent references.

* gravity_gradient_stability: the eigenvalues of a finite-difference Jacobian of the
  nonlinear attitude equations (Euler's equations with the torque 3 n^2 c x I c, the
  kinematics of the attitude relative to the turning orbital frame, written here with
  scipy's Rotation), the textbook example I = (roll 100, pitch 120, yaw 80) worked by
  hand, and liebody integrations of GravityGradient near the Earth-pointing attitude;
* forced_precession_constant/rate: the torque averaged numerically over a Kepler orbit
  (liebody.orbits positions, the torque written here), the Earth's lunisolar precession
  against the IAU 2006 value, and a liebody integration of a symmetric planet on an
  eccentric orbit.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import liebody
from liebody import analysis, bodies
from liebody import quaternion as Q
from liebody.orbits import Circular, Kepler

# ------------------------------------------------------------------------------------------
# gravity-gradient stability: the nonlinear equations, linearised numerically
# ------------------------------------------------------------------------------------------


def _jr_inverse(d: np.ndarray) -> np.ndarray:
    """Inverse right Jacobian of SO(3): d' = Jr^-1(d) omega for R = exp([d]x),
    R' = R [omega]x (omega in the rotating, body, frame)."""
    th = float(np.linalg.norm(d))
    K = np.array([[0, -d[2], d[1]], [d[2], 0, -d[0]], [-d[1], d[0], 0]])
    coef = (1 / 12 + th**2 / 720 if th < 1e-4
            else 1 / th**2 - (1 + math.cos(th)) / (2 * th * math.sin(th)))
    return np.eye(3) + 0.5 * K + coef * K @ K


def _attitude_rhs(x: np.ndarray, moments: np.ndarray, n: float) -> np.ndarray:
    """State (d, omega): d the rotation vector of the body relative to the orbital frame
    (body -> orbital), omega the body's inertial angular velocity in body axes. The
    orbital frame (x velocity, y negative orbit normal, z nadir) turns at -n e_y."""
    d, w = x[:3], x[3:]
    C = Rotation.from_rotvec(d).as_matrix()  # body -> orbital
    w_rel = w - C.T @ np.array([0.0, -n, 0.0])
    c = C.T @ np.array([0.0, 0.0, 1.0])  # nadir in body axes
    torque = 3 * n**2 * np.cross(c, moments * c)
    dw = (np.cross(moments * w, w) + torque) / moments
    return np.concatenate([_jr_inverse(d) @ w_rel, dw])


def _jacobian(moments, n: float, h: float = 1e-6) -> np.ndarray:
    moments = np.asarray(moments, dtype=float)
    x0 = np.array([0.0, 0.0, 0.0, 0.0, -n, 0.0])
    assert np.abs(_attitude_rhs(x0, moments, n)).max() < 1e-15  # an equilibrium
    J = np.empty((6, 6))
    for k in range(6):
        e = np.zeros(6)
        e[k] = h
        J[:, k] = (_attitude_rhs(x0 + e, moments, n) - _attitude_rhs(x0 - e, moments, n)) / (2 * h)
    return J


def _moments_from_k(k1: float, k3: float) -> np.ndarray:
    """(I_roll, I_pitch, I_yaw) with I_pitch = 1 and the given k1, k3."""
    d = 1 - k1 * k3
    return np.array([(1 - k3) / d, 1.0, (1 - k1) / d])


def _grid():
    pts = [(k1, k3) for k1 in np.linspace(-0.93, 0.97, 11) for k3 in np.linspace(-0.95, 0.91, 11)]
    # the DeBra-Delp sliver: k1 slightly negative, k3 more so
    pts += [(k1, k3) for k1 in (-0.06, -0.03, -0.01) for k3 in (-0.2, -0.5, -0.8)]
    out = []
    for k1, k3 in pts:
        b, c = 1 + 3 * k1 + k1 * k3, 4 * k1 * k3
        if abs(k1) < 1e-3 or abs(k3) < 1e-3 or abs(b * b - 4 * c) < 1e-3 or abs(k1 - k3) < 1e-3:
            continue  # stay off the marginal boundaries, where eigenvalues are degenerate
        out.append((k1, k3))
    return out


@pytest.mark.parametrize("n", [1.0, 0.37])
def test_gravity_gradient_stability_matches_the_jacobian_eigenvalues(n):
    regions = {"Lagrange": 0, "DeBra-Delp": 0, "unstable": 0}
    for k1, k3 in _grid():
        I = _moments_from_k(k1, k3)
        res = analysis.gravity_gradient_stability(I)
        assert res.k1 == pytest.approx(k1, abs=1e-14) and res.k3 == pytest.approx(k3, abs=1e-14)
        J = _jacobian(I, n) / n
        # the linearisation decouples pitch (d_y, omega_y) from roll-yaw
        pitch = np.linalg.eigvals(J[np.ix_([1, 4], [1, 4])])
        ry = np.linalg.eigvals(J[np.ix_([0, 2, 3, 5], [0, 2, 3, 5])])
        assert np.abs(J[np.ix_([1, 4], [0, 2, 3, 5])]).max() < 1e-8
        pitch_growth, ry_growth = pitch.real.max(), ry.real.max()
        assert res.pitch_stable == (pitch_growth < 1e-6), (k1, k3, pitch)
        assert res.roll_yaw_stable == (ry_growth < 1e-6), (k1, k3, ry)
        assert res.growth_rate == pytest.approx(max(pitch_growth, ry_growth, 0.0), abs=1e-6)
        if res.pitch_stable:
            assert res.pitch_frequency == pytest.approx(np.abs(pitch.imag).max(), rel=1e-7)
        else:
            assert res.pitch_frequency is None
        if res.roll_yaw_stable:
            freqs = np.sort(np.abs(ry.imag))[::2]  # each frequency appears as +-i f
            np.testing.assert_allclose(res.roll_yaw_frequencies, freqs, rtol=1e-7)
        else:
            assert res.roll_yaw_frequencies is None
        if res.pitch_stable and res.roll_yaw_stable:
            assert res.region == ("Lagrange" if k1 > 0 and k3 > 0 else "DeBra-Delp")
            # the two regions in moments: I_pitch > I_roll > I_yaw, I_roll > I_yaw > I_pitch
            assert (I[1] > I[0] > I[2]) if res.region == "Lagrange" else (I[0] > I[2] > I[1])
        else:
            assert res.region == "unstable"
        regions[res.region] += 1
    assert min(regions.values()) >= 3, regions  # every verdict was exercised


def test_textbook_lagrange_example_worked_by_hand():
    """I = (roll 100, pitch 120, yaw 80), worked out here: k1 = (120 - 80)/100 = 0.4,
    k3 = (120 - 100)/80 = 0.25; pitch frequency sqrt(3 * 20 / 120);
    roll-yaw roots of s^4 + 2.3 s^2 + 0.4 (numpy.roots)."""
    res = analysis.gravity_gradient_stability([100.0, 120.0, 80.0])
    assert (res.k1, res.k3) == (pytest.approx(0.4, abs=1e-15), pytest.approx(0.25, abs=1e-15))
    assert res.region == "Lagrange" and res.pitch_stable and res.roll_yaw_stable
    assert res.pitch_frequency == pytest.approx(math.sqrt(0.5), rel=1e-15)
    roots = np.roots([1.0, 0.0, 1 + 3 * 0.4 + 0.4 * 0.25, 0.0, 4 * 0.4 * 0.25])
    assert np.abs(roots.real).max() < 1e-12
    np.testing.assert_allclose(res.roll_yaw_frequencies, np.sort(np.abs(roots.imag))[::2],
                               rtol=1e-12)
    assert res.growth_rate == 0.0
    # the same body turned wrongly: pitch < roll (roll-yaw unstable, c = 4 k1 k3 < 0),
    # yaw > roll (pitch unstable, growth sqrt(3 (I_yaw - I_roll)/I_pitch))
    bad = analysis.gravity_gradient_stability([120.0, 100.0, 80.0])
    assert bad.pitch_stable and not bad.roll_yaw_stable and bad.region == "unstable"
    assert bad.growth_rate > 0.1
    flipped = analysis.gravity_gradient_stability([80.0, 120.0, 100.0])
    assert not flipped.pitch_stable and flipped.region == "unstable"
    assert flipped.pitch_frequency is None
    assert flipped.growth_rate >= math.sqrt(3 * 20 / 120) * (1 - 1e-15)


def test_debra_delp_point():
    """A body in the DeBra-Delp region (DeBra & Delp 1961): I_roll > I_yaw > I_pitch with
    k1 slightly negative; pitch and roll-yaw stable although the least moment is not
    along the vertical. Moving k1 further negative (k1 = -0.3) leaves the region."""
    I = _moments_from_k(-0.02, -0.5)
    assert I[0] > I[2] > I[1]
    res = analysis.gravity_gradient_stability(I)
    assert res.region == "DeBra-Delp" and res.growth_rate == 0.0
    eig = np.linalg.eigvals(_jacobian(I, 1.0))
    assert np.abs(eig.real).max() < 1e-6
    out = analysis.gravity_gradient_stability(_moments_from_k(-0.3, -0.5))
    assert out.region == "unstable" and not out.roll_yaw_stable
    assert np.linalg.eigvals(_jacobian(_moments_from_k(-0.3, -0.5), 1.0)).real.max() > 1e-3


def test_marginal_and_bad_inputs():
    # I_pitch = I_yaw: k1 = 0, a zero root, not (asymptotically or oscillation-) stable
    res = analysis.gravity_gradient_stability([1.0, 2.0, 2.0])
    assert res.k1 == 0.0 and not res.roll_yaw_stable and res.region == "unstable"
    res = analysis.gravity_gradient_stability([1.5, 2.0, 1.5])  # I_roll = I_yaw
    assert not res.pitch_stable and res.pitch_frequency is None
    with pytest.raises(ValueError, match="moments"):
        analysis.gravity_gradient_stability([1.0, -2.0, 1.0])
    with pytest.raises(ValueError, match=r"moments.*finite"):
        analysis.gravity_gradient_stability([1.0, np.nan, 1.0])
    with pytest.raises(ValueError, match=r"moments must have shape \(3,\)"):
        analysis.gravity_gradient_stability([1.0, 2.0])
    with pytest.raises(TypeError, match="moments"):
        analysis.gravity_gradient_stability(["a", "b", "c"])


# ------------------------------------------------------------------------------------------
# gravity-gradient stability: liebody integrations near the Earth-pointing attitude
# ------------------------------------------------------------------------------------------


def _pointing_run(moments, d0, dw0, n=1.0, orbits=5, per_orbit=600):
    """Start near the orbital frame (rotation vector d0 from it, angular velocity
    -n e_pitch + dw0) and integrate GravityGradient; return the times, the angle
    between the body and the orbital frame and the trajectory."""
    orbit = Circular(n)
    scene = liebody.GravityGradient(liebody.RigidBody(moments, check_triangle=False),
                                    [(n**2, orbit)])

    def frame(t):  # orbital axes as columns: x = y x z, y = -orbit normal, z = nadir
        z = orbit.position(t)  # the Earth seen from the satellite: the nadir
        z = z / np.linalg.norm(z, axis=-1, keepdims=True)
        y = np.broadcast_to(-orbit.normal, z.shape)
        return np.stack([np.cross(y, z), y, z], axis=-1)

    R0 = frame(0.0) @ Rotation.from_rotvec(d0).as_matrix()
    q0 = Q.from_rotation(Rotation.from_matrix(R0))
    w0 = np.array([0.0, -n, 0.0]) + np.asarray(dw0)
    dt = 2 * math.pi / n / per_orbit
    tr = liebody.integrate(scene, q0=q0, omega0=w0, dt=dt, steps=orbits * per_orbit,
                           method="splitting4", save_every=5)
    rel = np.swapaxes(frame(tr.t), -1, -2) @ Q.to_matrix(tr.q)
    angle = np.arccos(np.clip((np.trace(rel, axis1=-2, axis2=-1) - 1) / 2, -1, 1))
    return tr, angle, orbit


def test_integration_stays_near_the_orbital_frame_when_stable_and_leaves_it_when_not():
    d0, dw0 = [2e-3, -1e-3, 1.5e-3], [1e-3, 0.0, -1e-3]
    _, stable, _ = _pointing_run([100.0, 120.0, 80.0], d0, dw0)
    _, pitch_bad, _ = _pointing_run([80.0, 120.0, 100.0], d0, dw0)
    _, ry_bad, _ = _pointing_run([120.0, 100.0, 80.0], d0, dw0)
    start = np.linalg.norm(d0)
    assert stable.max() < 5 * start, stable.max()
    assert pitch_bad.max() > 0.3, pitch_bad.max()
    assert ry_bad.max() > 0.3, ry_bad.max()
    # the DeBra-Delp body stays close as well (linearly stable)
    _, dd, _ = _pointing_run(_moments_from_k(-0.02, -0.5), d0, dw0)
    assert dd.max() < 10 * start, dd.max()


def test_integrated_pitch_libration_has_the_closed_form_frequency():
    """A pure pitch perturbation of the Lagrange body: the pitch angle relative to the
    orbital frame (liebody.attitude) oscillates at sqrt(3 (I_roll - I_yaw)/I_pitch) n."""
    from liebody import attitude

    n = 0.8
    I = [100.0, 120.0, 80.0]
    tr, _, orbit = _pointing_run(I, [0.0, 1e-3, 0.0], [0.0, 0.0, 0.0], n=n, orbits=6)
    r_sat = -orbit.position(tr.t)  # the satellite seen from the Earth
    v_sat = np.cross(orbit.normal, r_sat) * n  # circular, counter-clockwise
    _, ang = attitude.attitude_in_lvlh(tr.q, r_sat, v_sat, rpy=True)
    pitch = ang[:, 1]
    assert np.abs(ang[:, [0, 2]]).max() < 1e-8  # roll and yaw stay unexcited
    crossings = analysis.zero_crossings(tr.t, pitch)
    period = 2 * np.mean(np.diff(crossings))
    expected = analysis.gravity_gradient_stability(I).pitch_frequency * n
    assert 2 * math.pi / period == pytest.approx(expected, rel=2e-4)


# ------------------------------------------------------------------------------------------
# forced precession
# ------------------------------------------------------------------------------------------


@pytest.mark.parametrize("e", [0.0, 0.3, 0.7])
def test_precession_constant_is_the_orbit_averaged_torque(e):
    """The torque 3 GM / r^5 r x I r averaged over one Kepler period (liebody.orbits
    positions, trapezoidal rule on the periodic integrand: spectral accuracy) equals
    C spin ds/dt = -k cos(eps) C spin (n x s)."""
    A, C, spin, GM, a, eps = 0.9, 1.0, 40.0, 2.5, 1.7, 0.5
    orbit = Kepler(a, e, 3.0, i=0.2, raan=0.4)
    nrm = orbit.normal
    # a spin axis at angle eps from the orbit normal
    perp = np.cross(nrm, [1.0, 0.0, 0.0])
    perp /= np.linalg.norm(perp)
    s = math.cos(eps) * nrm + math.sin(eps) * perp
    t = np.linspace(0.0, orbit.period, 4001)[:-1]
    r = orbit.position(t)
    Ir = A * r + (C - A) * (r @ s)[:, None] * s
    tau = np.mean(3 * GM * np.cross(r, Ir) / np.linalg.norm(r, axis=1)[:, None] ** 5, axis=0)
    k = analysis.forced_precession_constant([A, A, C], spin, GM, a, e)
    np.testing.assert_allclose(tau, -k * math.cos(eps) * C * spin * np.cross(nrm, s),
                               rtol=1e-9, atol=1e-12 * np.abs(tau).max())
    rate = analysis.forced_precession_rate([A, A, C], spin, GM, a, eps, e)
    assert rate == pytest.approx(-k * math.cos(eps), rel=1e-15)
    # the axis argument and a triaxial planet (A, B averaged)
    k_axis = analysis.forced_precession_constant([C, A + 0.05, A - 0.05], spin, GM, a, e, axis=0)
    assert k_axis == pytest.approx(k, rel=1e-12)


def test_earth_lunisolar_precession_against_the_iau_value():
    """The Sun's part (about 15.9 arcsec/yr) plus the Moon's (about 2.16 times the Sun's,
    its orbit's inclination of 5.145 deg averaged over the 18.6-year nodal cycle:
    factor 1 - (3/2) sin^2 i) give the luni-solar precession of the IAU 2006 model,
    5038.481507 arcsec per Julian century (N. Capitaine, P. T. Wallace & J. Chapront,
    A&A 412 (2003) 567), for the rigid Earth of liebody.bodies (IERS dynamical
    ellipticity H, which was itself fitted to the observed precession)."""
    I, spin = bodies.earth().moments, bodies.earth_spin()
    arcsec_per_year = 86400 * 365.25 * 180 / math.pi * 3600
    eps = math.radians(84381.406 / 3600)  # IAU 2006 obliquity at J2000
    au = 1.495978707e11
    sun = analysis.forced_precession_rate(I, spin, 1.32712440041e20, 1.00000102 * au, eps,
                                          0.0167086) * arcsec_per_year
    i_moon = math.radians(5.145)
    moon = (analysis.forced_precession_rate(I, spin, 4.9028000661e12, 3.84399e8, eps, 0.0549)
            * (1 - 1.5 * math.sin(i_moon) ** 2) * arcsec_per_year)
    assert sun < 0 and moon < 0  # retrograde: the precession of the equinoxes
    assert -sun == pytest.approx(15.95, abs=0.05)
    assert moon / sun == pytest.approx(2.16, abs=0.02)
    assert -(sun + moon) == pytest.approx(5038.481507 / 100, rel=1e-3)


def test_integrated_precession_on_an_eccentric_orbit():
    """A symmetric planet (H = 0.05, spin 1000 n) on a Kepler orbit with e = 0.3: the mean
    precession rate of its figure axis over 20 whole orbits matches -k cos(eps) with the
    (1 - e^2)^(-3/2) factor (relative deviation O(k/n) ~ 1e-4, the next order of the
    averaging) and not the circular-orbit value (15% off)."""
    A, C, spin, e, eps = 0.95, 1.0, 1000.0, 0.3, 0.4
    orbit = Kepler(1.0, e, 1.0)
    scene = liebody.GravityGradient(liebody.RigidBody([A, A, C]), [(1.0, orbit)])
    per = 2000
    tr = liebody.integrate(scene, q0=Q.exp([eps, 0.0, 0.0]), L0=[0.0, 0.0, C * spin],
                           dt=orbit.period / per, steps=20 * per, save_every=per,
                           method="splitting4")
    s = Q.rotate(tr.q, [0.0, 0.0, 1.0])  # the figure axis in space
    azimuth = np.unwrap(np.arctan2(s[:, 1], s[:, 0]))  # about the orbit normal +z
    rate = (azimuth[-1] - azimuth[0]) / (tr.t[-1] - tr.t[0])
    expected = analysis.forced_precession_rate([A, A, C], spin, 1.0, 1.0, eps, e)
    assert rate == pytest.approx(expected, rel=1e-3)
    circular = analysis.forced_precession_rate([A, A, C], spin, 1.0, 1.0, eps, 0.0)
    assert abs(rate / circular - 1) > 0.1
    # the obliquity stays put
    assert np.abs(np.arccos(s[:, 2]) - eps).max() < 1e-3


def test_forced_precession_bad_inputs():
    I = [0.9, 0.9, 1.0]
    with pytest.raises(ValueError, match=r"e \(the eccentricity\) must be in \[0, 1\)"):
        analysis.forced_precession_constant(I, 1.0, 1.0, 1.0, 1.0)
    with pytest.raises(ValueError, match="spin must be > 0"):
        analysis.forced_precession_constant(I, 0.0, 1.0, 1.0)
    with pytest.raises(ValueError, match="GM must be finite"):
        analysis.forced_precession_constant(I, 1.0, math.inf, 1.0)
    with pytest.raises(ValueError, match="a must be > 0"):
        analysis.forced_precession_constant(I, 1.0, 1.0, -2.0)
    with pytest.raises(ValueError, match="axis must be an axis index"):
        analysis.forced_precession_constant(I, 1.0, 1.0, 1.0, axis=3)
    with pytest.raises(ValueError, match="obliquity must be finite"):
        analysis.forced_precession_rate(I, 1.0, 1.0, 1.0, math.nan)
    with pytest.raises(TypeError, match="obliquity must be a real number"):
        analysis.forced_precession_rate(I, 1.0, 1.0, 1.0, "0.4")
    with pytest.raises(ValueError, match="rescale"):
        analysis.forced_precession_constant(I, 1e-300, 1e300, 1e-100)
    # a spherical planet does not precess; a prolate one precesses the other way
    assert analysis.forced_precession_constant([1.0, 1.0, 1.0], 1.0, 1.0, 1.0) == 0.0
    assert analysis.forced_precession_constant([1.0, 1.0, 0.9], 1.0, 1.0, 1.0) < 0.0
