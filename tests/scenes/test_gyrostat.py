"""Gyrostats: the kinetic part H = (L - l)^T I^-1 (L - l) / 2, against DOP853 on
L' = L x I^-1 (L - l), the invariants, the rounding of one axis turn against exact rational
arithmetic, the linear stability of a dual-spin satellite, and the refusals of the rigid
body's flows."""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import liebody
from liebody import analysis, quaternion

I = np.array([1.0, 2.0, 3.0])
ROTOR = np.array([0.3, 1.5, -0.2])
Q0 = quaternion.exp([0.1, 0.2, 0.3])
L0 = np.array([0.4, 2.0, 0.3])


def _reference(t_end, moments=I, rotor=ROTOR, q0=Q0, L0=L0):
    def rhs(t, y):
        q, L = y[:4], y[4:]
        w = (L - rotor) / moments
        return np.concatenate([0.5 * quaternion.multiply(q, [0.0, *w]), np.cross(L, w)])

    y = solve_ivp(rhs, (0.0, t_end), np.concatenate([q0, L0]), method="DOP853", rtol=1e-13,
                  atol=1e-14).y[:, -1]
    return y[:4], y[4:]


@pytest.mark.parametrize(("method", "order"), [("splitting2", 2), ("no_squish", 2),
                                               ("splitting4", 4), ("rk4", 4), ("rkmk4", 4)])
def test_orders_against_dop853(method, order):
    scene = liebody.Gyrostat(liebody.RigidBody(I), ROTOR)
    q_ref, L_ref = _reference(5.0)
    errs = []
    for h in (0.05, 0.025):
        tr = liebody.integrate(scene, q0=Q0, L0=L0, dt=h, t_end=5.0, method=method)
        dq = quaternion.multiply(quaternion.conjugate(q_ref), tr.q[-1])[1:]
        errs.append(max(np.abs(tr.L[-1] - L_ref).max(), np.abs(dq).max()))
    assert abs(math.log2(errs[0] / errs[1]) - order) < 0.15, errs


def test_the_splitting_keeps_the_invariants():
    """|L| and the spatial L to round-off (the axis flows are rotations), the gyrostat's
    energy bounded (not the rigid body's: it changes by l . I^-1 L)."""
    scene = liebody.Gyrostat(liebody.RigidBody(I), ROTOR)
    tr = liebody.integrate(scene, q0=Q0, L0=L0, dt=0.05, steps=20_000, save_every=100,
                           diagnostics=True)
    H = scene.kinetic_energy(tr.L)
    assert np.abs(H - H[0]).max() < 1e-3 * H[0]
    half = len(H) // 2
    assert np.abs(H[half:] - H[0]).max() < 1.5 * np.abs(H[:half] - H[0]).max()  # bounded
    assert tr.diagnostics["max_energy_error"] == pytest.approx(
        np.abs(H - H[0]).max() / H[0], rel=0.5)  # the kernel's energy is the gyrostat's
    # (rounding only: a random walk of ~1e-16 per rotation, 8e4 rotations)
    np.testing.assert_allclose(np.linalg.norm(tr.L, axis=1), np.linalg.norm(L0), rtol=2e-13)
    Ls = quaternion.rotate(tr.q, tr.L)
    np.testing.assert_allclose(Ls, np.broadcast_to(Ls[0], Ls.shape), rtol=0, atol=1e-12)
    rigid = 0.5 * np.sum(tr.L**2 / I, axis=1)
    assert np.ptp(rigid) > 100 * np.ptp(H)  # the rigid body's energy is not the invariant


def _spatial_exact(q, m):
    """``R(q / |q|) m`` in exact rational arithmetic."""
    w, x, y, z = (Fraction(float(c)) for c in q)
    v = [Fraction(float(c)) for c in m]
    rows = [(w * w + x * x - y * y - z * z, 2 * (x * y - w * z), 2 * (x * z + w * y)),
            (2 * (x * y + w * z), w * w - x * x + y * y - z * z, 2 * (y * z - w * x)),
            (2 * (x * z - w * y), 2 * (y * z + w * x), w * w - x * x - y * y + z * z)]
    n2 = w * w + x * x + y * y + z * z
    return [sum(r * c for r, c in zip(row, v, strict=True)) / n2 for row in rows]


@pytest.mark.parametrize("turn", [(0.0, 0.1), (0.1, 1.5)])  # the half angle, both forms
def test_one_axis_turn_rounds_the_spatial_momentum_about_once(turn):
    """One gyrostat axis turn moves R(q) m (q normalised: the orientation) by its rounding
    only. Exact rational arithmetic measures the move over 400 random states: its RMS is
    0.30 eps |m| (a turn rounded about once per component; the plain form
    c m_i + s m_j with q * (c, s e_k) gave 0.44 eps for small turns and 0.59 eps for
    large ones), and |q| stays within a few ulps of 1."""
    from liebody._kernels.flows import axis_flow_shifted

    rng = np.random.default_rng(5)
    rate, tau = 0.125, 0.1
    moves = []
    for _ in range(400):
        q = rng.normal(size=4)
        q /= np.linalg.norm(q)
        m = rng.normal(size=3)
        axis = int(rng.integers(3))
        half = rng.uniform(*turn) * rng.choice([-1.0, 1.0])
        shift = float(m[axis] - half / (0.5 * tau * rate))
        out = axis_flow_shifted(*q, *m, axis, rate, shift, tau)
        assert abs(math.hypot(*out[:4]) - 1.0) < 2e-15
        before, after = _spatial_exact(q, m), _spatial_exact(out[:4], out[4:])
        moves.append(math.sqrt(float(sum((a - b) ** 2 for a, b in zip(after, before,
                                                                       strict=True))))
                     / float(np.linalg.norm(m)))
    assert math.sqrt(np.mean(np.square(moves))) < 0.36 * np.finfo(float).eps


def test_a_rotor_stabilises_the_intermediate_axis():
    """Spin about the intermediate axis: the rigid body flips (analysis.stability); with
    rotor momentum above (I_3 - I_2) omega along it (analysis.dual_spin_stable) it stays."""
    omega, eps = 1.0, 1e-3
    assert not analysis.dual_spin_stable(I, omega, 1, 0.0).stable
    assert not analysis.stability(I, omega, 1).stable
    assert analysis.dual_spin_stable(I, omega, 1, 0.9).stable is False  # below the bound
    assert analysis.dual_spin_stable(I, omega, 1, 1.5).stable
    for h, stays in ((0.0, False), (0.5, False), (1.5, True), (3.0, True)):
        scene = liebody.Gyrostat(liebody.RigidBody(I), [0.0, h, 0.0])
        L0 = np.array([eps, I[1] * omega + h, eps])
        tr = liebody.integrate(scene, L0=L0, dt=0.02, steps=20_000, save_every=10)
        off = np.hypot(tr.L[:, 0], tr.L[:, 2]).max() / np.linalg.norm(L0)
        assert bool(off < 0.05) == stays, (h, off)
        if stays:  # the nutation frequency of the linear theory
            rate = analysis.dual_spin_stable(I, omega, 1, h).rate
            crossings = np.flatnonzero(np.diff(np.sign(tr.L[:, 0])) != 0)
            period = 2 * np.mean(np.diff(tr.t[crossings]))
            assert period == pytest.approx(2 * math.pi / rate, rel=0.02)


def test_a_zero_rotor_is_the_rigid_body():
    body = liebody.RigidBody(I)
    g = liebody.integrate(liebody.Gyrostat(body, [0.0, 0.0, 0.0]), q0=Q0, L0=L0, dt=0.05,
                          steps=50)
    f = liebody.integrate(liebody.FreeBody(body), q0=Q0, L0=L0, dt=0.05, steps=50,
                          method="splitting2")
    np.testing.assert_array_equal(g.q, f.q)
    np.testing.assert_array_equal(g.L, f.L)


def test_ensembles_with_per_body_rotors():
    rotors = np.array([[0.3, 1.5, -0.2], [0.0, 0.0, 0.0], [1.0, -1.0, 0.5]])
    scene = liebody.Gyrostat(liebody.RigidBody(I), rotors)
    ens = liebody.integrate(scene, q0=Q0, L0=L0, dt=0.05, steps=40, save_every=10)
    for i in range(3):
        one = liebody.integrate(liebody.Gyrostat(liebody.RigidBody(I), rotors[i]), q0=Q0,
                                L0=L0, dt=0.05, steps=40, save_every=10)
        np.testing.assert_array_equal(ens.q[i], one.q)
        np.testing.assert_array_equal(ens.L[i], one.L)


@pytest.mark.parametrize(("method", "match"), [
    ("sr2", "SR2's symmetric-body flow is the rigid body's"),
    ("rattle", "RATTLE.*rigid body's"),
    ("dmv4", "RATTLE.*rigid body's"),
    ("exact", "evaluates the rigid body's exact flow"),
])
def test_the_rigid_bodys_flows_refuse_a_gyrostat(method, match):
    scene = liebody.Gyrostat(liebody.RigidBody(I), ROTOR)
    with pytest.raises(ValueError, match=match):
        liebody.integrate(scene, q0=Q0, L0=L0, dt=0.05, steps=5, method=method)


def test_bad_gyrostats_are_refused_by_name():
    with pytest.raises(ValueError, match="rotor_momentum"):
        liebody.Gyrostat(liebody.RigidBody(I), [1.0, 2.0])
    with pytest.raises(ValueError, match="rotor_momentum"):
        liebody.Gyrostat(liebody.RigidBody(I), [1.0, np.nan, 0.0])
    with pytest.raises(ValueError, match="rotor_momentum of shape \\(3, 3\\) gives 3 bodies"):
        liebody.Gyrostat(liebody.RigidBody.batch([I, I]), np.zeros((3, 3)))
    with pytest.raises(ValueError, match="free_flow='exact'"):
        liebody.Gyrostat(liebody.RigidBody(I), ROTOR, free_flow="exact")


def test_omega_is_the_bodys_and_the_energy_is_the_gyrostats():
    """omega0 is the body's angular velocity: L = I omega + l; the trajectory's and the
    stepper's omega are (L - l) / I and the kinetic energy (L - l)^T I^-1 (L - l) / 2,
    which the splitting keeps bounded (sum L^2 / 2I, the rigid body's, is not kept)."""
    I = np.array([80.0, 100.0, 120.0])
    l = np.array([0.0, 30.0, 5.0])
    scene = liebody.Gyrostat(liebody.RigidBody(I), l)
    w0 = np.array([0.01, 1.0, 0.02])
    tr = liebody.integrate(scene, omega0=w0, dt=0.01, t_end=100.0, method="splitting2")
    np.testing.assert_allclose(tr.L[0], I * w0 + l, rtol=1e-15)
    np.testing.assert_allclose(tr.omega[0], w0, rtol=1e-13)
    H = 0.5 * np.sum((tr.L - l) ** 2 / I, axis=1)
    np.testing.assert_allclose(tr.kinetic_energy, H, rtol=1e-15)
    assert np.ptp(tr.energy) < 1e-4 * tr.energy[0]
    assert np.ptp(0.5 * np.sum(tr.L**2 / I, axis=1)) > 1e3 * np.ptp(tr.energy)
    st = liebody.Stepper(scene, omega0=w0, dt=0.01, method="splitting2")
    np.testing.assert_allclose(st.omega, w0, rtol=1e-13)
    st.omega = [0.0, 0.5, 0.0]
    np.testing.assert_allclose(st.L, I * [0.0, 0.5, 0.0] + l, rtol=1e-15)
    ens = liebody.Gyrostat(liebody.RigidBody(I), np.stack([l, 2 * l]))
    te = liebody.integrate(ens, omega0=w0, dt=0.01, steps=10, method="splitting2")
    np.testing.assert_allclose(te.omega[:, 0], [w0, w0], rtol=1e-13)
