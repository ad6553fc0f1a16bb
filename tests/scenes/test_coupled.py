"""Coupled bodies: N rotors under a potential of all orientations (liebody.coupled)."""

from __future__ import annotations

from contextlib import nullcontext

import numpy as np
import pytest
from numba import njit
from scipy.integrate import solve_ivp

import liebody
from liebody import quaternion as Q
from liebody.coupled import (
    CoupledBodies,
    DipoleLattice,
    kinetic_temperature,
    neighbours,
    thermal_momenta,
    uniform_orientations,
)
from liebody.testing import energy_drift
from support import rotation_distance


# -------------------------------------------------------------- a rotation-invariant coupling
@njit(cache=True)
def _rot(q, v):
    w, x, y, z = q[0], q[1], q[2], q[3]
    tx, ty, tz = 2 * (y * v[2] - z * v[1]), 2 * (z * v[0] - x * v[2]), 2 * (x * v[1] - y * v[0])
    return np.array([v[0] + w * tx + (y * tz - z * ty), v[1] + w * ty + (z * tx - x * tz),
                     v[2] + w * tz + (x * ty - y * tx)])


@njit(cache=True)
def heisenberg_torque(t, q, L, p, out):
    """V = -sum_{i<j} mu_i . mu_j, mu_i = R(q_i) p_i: invariant under a common rotation."""
    n = q.shape[0]
    mus = np.empty((n, 3))
    for i in range(n):
        mus[i] = _rot(q[i], p[i, :3])
    tot = mus.sum(axis=0)
    for i in range(n):
        qi = np.array([q[i, 0], -q[i, 1], -q[i, 2], -q[i, 3]])
        c = _rot(qi, tot - mus[i])  # the field in body i's frame
        d = p[i, :3]
        out[i, 0] = d[1] * c[2] - d[2] * c[1]
        out[i, 1] = d[2] * c[0] - d[0] * c[2]
        out[i, 2] = d[0] * c[1] - d[1] * c[0]


@njit(cache=True)
def heisenberg_potential(t, q, p):
    n = q.shape[0]
    V = 0.0
    mus = np.empty((n, 3))
    for i in range(n):
        mus[i] = _rot(q[i], p[i, :3])
    for i in range(n):
        for j in range(i + 1, n):
            V -= mus[i, 0] * mus[j, 0] + mus[i, 1] * mus[j, 1] + mus[i, 2] * mus[j, 2]
    return V


def _system(n=3, seed=1):
    rng = np.random.default_rng(seed)
    I = 1.0 + rng.random((n, 3))
    scene = CoupledBodies(liebody.RigidBody.batch(I, check_triangle=False), heisenberg_torque,
                          heisenberg_potential, params=rng.normal(size=(n, 3)))
    return scene, uniform_orientations(n, rng=seed + 1), rng.normal(size=(n, 3))


def _reference(scene, q0, L0, T):
    """DOP853 at rtol = atol = 1e-13 on Euler's equations with the collective torque and
    the quaternion kinematics, every body at once."""
    n, I = scene.n_bodies, scene.moments

    def rhs(t, y):
        q, L = y[:4 * n].reshape(n, 4), y[4 * n:].reshape(n, 3)
        tau = scene.evaluate_torque(q, L, t)
        om = L / I
        dq = np.stack([Q.multiply(q[i], np.concatenate([[0.0], om[i]])) * 0.5
                       for i in range(n)])
        return np.concatenate([dq.ravel(), (np.cross(L, om) + tau).ravel()])

    y = solve_ivp(rhs, (0.0, T), np.concatenate([q0.ravel(), L0.ravel()]), method="DOP853",
                  rtol=1e-13, atol=1e-13).y[:, -1]
    return y[:4 * n].reshape(n, 4), y[4 * n:].reshape(n, 3)


@pytest.mark.parametrize(("method", "order", "steps"), [
    ("splitting2", 2, (50, 100, 200)), ("no_squish", 2, (50, 100, 200)),
    ("exact", 2, (50, 100, 200)), ("rattle", 2, (50, 100, 200)),
    ("splitting4", 4, (25, 50, 100)),
    ("splitting6", 6, (8, 16, 32))])
def test_the_coupled_splittings_have_their_order(method, order, steps):
    scene, q0, L0 = _system()
    T = 2.0
    qr, Lr = _reference(scene, q0, L0, T)
    errs = []
    for n in steps:
        tr = liebody.integrate(scene, q0=q0, L0=L0, dt=T / n, steps=n, method=method,
                               save_every=None)
        errs.append(max(np.abs(tr.L[:, -1] - Lr).max(),
                        rotation_distance(tr.q[:, -1], qr).max()))
    slopes = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all(np.abs(slopes - order) < 0.25), (errs, slopes)


def test_total_angular_momentum_is_kept_to_round_off_whatever_the_step():
    """A potential invariant under a common rotation exerts no net torque in space: the
    kicks keep the total spatial angular momentum, the free flows each body's."""
    scene, q0, L0 = _system(5, seed=3)
    for dt in (0.01, 0.3):  # 0.3: far too large for accuracy, still kept
        ctx = pytest.warns(liebody.InvariantWarning) if dt == 0.3 else nullcontext()
        with ctx:
            tr = liebody.integrate(scene, q0=q0, L0=L0, dt=dt, steps=20000,
                                   method="splitting2", save_every=100)
        Ls = tr.total_L_space
        # a random walk of rounding (a bias of 1e-16 a step, as a torque evaluated at a
        # non-unit q gave, reaches 1e-11 here)
        bound = 4 * np.finfo(float).eps * np.sqrt(20000) * np.abs(L0).sum()
        assert np.abs(Ls - Ls[0]).max() < bound, dt
        assert not np.allclose(tr.L[:, -1], tr.L[:, 0])  # the bodies did exchange spin


def test_energy_is_bounded_and_does_not_drift():
    scene, q0, L0 = _system(4, seed=5)
    tr = liebody.integrate(scene, q0=q0, L0=L0, dt=0.005, steps=100000, method="splitting2",
                           save_every=100)
    E = tr.energy
    assert np.abs(E - E[0]).max() < 1e-3 * np.abs(E[0])
    assert energy_drift(tr).kind == "bounded"


def test_the_step_is_reversible():
    """(q, L) -> (q, -L) reverses the flow of a potential of the orientations; a symmetric
    step of a fixed structure (no_squish: its axis ordering does not depend on the state)
    reverses exactly, up to rounding."""
    scene, q0, L0 = _system(3, seed=7)
    a = liebody.integrate(scene, q0=q0, L0=L0, dt=0.05, steps=400, method="no_squish",
                          save_every=None)
    b = liebody.integrate(scene, q0=a.q[:, -1], L0=-a.L[:, -1], dt=0.05, steps=400,
                          method="no_squish", save_every=None)
    assert rotation_distance(b.q[:, -1], q0).max() < 1e-11
    np.testing.assert_allclose(-b.L[:, -1], L0, atol=1e-11)


@pytest.mark.kernel
def test_the_stepper_equals_integrate_bit_for_bit():
    scene, q0, L0 = _system(3, seed=9)
    tr = liebody.integrate(scene, q0=q0, L0=L0, dt=0.05, steps=30, method="splitting4")
    st = liebody.Stepper(scene, q0=q0, L0=L0, dt=0.05, method="splitting4")
    st.step(10)
    st.step()
    for _ in range(19):
        st.step()
    assert np.array_equal(st.q, tr.q[:, -1]) and np.array_equal(st.L, tr.L[:, -1])
    assert st.t == pytest.approx(1.5)
    st.L = tr.L[:, 0]
    st.q = tr.q[:, 0]
    st.t = 0.0
    st.step(30)
    assert np.array_equal(st.q, tr.q[:, -1])


def test_many_bodies_in_several_blocks_and_groups_equal_a_reordering():
    """Bodies spread over SIMD blocks and ordering groups: a permutation of the bodies
    gives the permuted trajectory (the sums in the torque reordered: to round-off)."""
    n = 300
    rng = np.random.default_rng(11)
    sites = rng.random((n, 3)) * 10
    I = 1.0 + rng.random((n, 3))
    d = rng.normal(size=(n, 3))
    q0, L0 = uniform_orientations(n, rng=12), thermal_momenta(I, 0.5, rng=13)
    perm = rng.permutation(n)
    a = liebody.integrate(DipoleLattice(liebody.RigidBody.batch(I, check_triangle=False),
                                        sites, d, cutoff=3.0),
                          q0=q0, L0=L0, dt=0.01, steps=50, method="splitting2",
                          save_every=None)
    b = liebody.integrate(DipoleLattice(liebody.RigidBody.batch(I[perm], check_triangle=False),
                                        sites[perm], d[perm], cutoff=3.0),
                          q0=q0[perm], L0=L0[perm], dt=0.01, steps=50, method="splitting2",
                          save_every=None)
    assert a.info["groups"] > 1
    np.testing.assert_allclose(b.L[:, -1], a.L[perm, -1], atol=1e-11)


# -------------------------------------------------------------- the dipole lattice
def _direct_potential(q, sites, d):
    """The dipole-dipole energy summed over pairs in plain numpy (an independent route)."""
    mu = Q.rotate(q, d)
    V = 0.0
    for i in range(len(q)):
        for j in range(i + 1, len(q)):
            r = sites[i] - sites[j]
            rn = np.linalg.norm(r)
            e = r / rn
            V += (mu[i] @ mu[j] - 3 * (mu[i] @ e) * (mu[j] @ e)) / rn**3
    return V


def _lattice(n=6, seed=21, cutoff=None, cubic=False):
    rng = np.random.default_rng(seed)
    if cubic:  # a simple cubic lattice of spacing 1
        k = round(n ** (1 / 3))
        sites = np.stack(np.meshgrid(*[np.arange(k)] * 3, indexing="ij"), -1).reshape(-1, 3)
        sites = sites.astype(float)
    else:
        sites = rng.random((n, 3)) * 3
    d = rng.normal(size=(n, 3))
    I = 1.0 + rng.random((n, 3))
    return DipoleLattice(liebody.RigidBody.batch(I, check_triangle=False), sites, d,
                         cutoff=cutoff), uniform_orientations(n, rng=seed + 1), sites, d


@pytest.mark.kernel
def test_dipole_potential_against_the_pair_sum_and_the_cutoff():
    lat, q, sites, d = _lattice()
    assert lat.potential(q) == pytest.approx(_direct_potential(q, sites, d), rel=1e-13)
    wide, *_ = _lattice(cutoff=100.0)  # every pair inside: the same energy
    assert wide.potential(q) == pytest.approx(lat.potential(q), rel=1e-13)
    narrow, *_ = _lattice(cutoff=1.0)
    nb = neighbours(sites, 1.0)
    inside = [(i, j) for i in range(6) for j in range(i + 1, 6)
              if np.linalg.norm(sites[i] - sites[j]) < 1.0]
    mu = Q.rotate(q, d)
    want = 0.0
    for i, j in inside:
        r = sites[i] - sites[j]
        rn = np.linalg.norm(r)
        want += (mu[i] @ mu[j] - 3 * (mu[i] @ (r / rn)) * (mu[j] @ (r / rn))) / rn**3
    assert narrow.potential(q) == pytest.approx(want, rel=1e-12, abs=1e-14)
    assert {(i, int(j)) for i in range(6) for j in nb[i] if j >= 0 and j > i} == set(inside)


@pytest.mark.kernel
def test_dipole_torque_is_minus_the_derivative_of_the_potential():
    """N_i,a = -dV/d eps for q_i -> q_i exp(eps e_a / 2) (body frame), by central
    differences of the potential."""
    lat, q, *_ = _lattice(seed=23)
    tau = lat.evaluate_torque(q, np.zeros((6, 3)))
    h = 1e-6
    for i in range(6):
        for a in range(3):
            e = np.zeros(3)
            e[a] = h
            qp, qm = q.copy(), q.copy()
            qp[i] = Q.multiply(q[i], Q.exp(e))
            qm[i] = Q.multiply(q[i], Q.exp(-e))
            fd = -(lat.potential(qp) - lat.potential(qm)) / (2 * h)
            assert tau[i, a] == pytest.approx(fd, rel=1e-6, abs=1e-8), (i, a)


def test_a_dipole_lattice_relaxes_with_its_energy_bounded():
    lat, q, *_ = _lattice(n=27, seed=25, cubic=True, cutoff=1.8)
    L0 = thermal_momenta(lat.moments, 0.1, rng=26)
    tr = liebody.integrate(lat, q0=q, L0=L0, dt=0.002, steps=20000, method="splitting2",
                           save_every=20)
    E = tr.energy
    assert np.abs(E - E[0]).max() < 1e-3 * (np.abs(E[0]) + tr.kinetic_energy[:, 0].sum())
    assert np.ptp(tr.temperature) > 0.0  # energy flows between kinetic and potential


# -------------------------------------------------------------- thermal helpers
def test_thermal_momenta_and_temperature():
    I = np.array([1.0, 2.0, 5.0])
    L = thermal_momenta(np.broadcast_to(I, (200000, 3)), 0.7, rng=1)
    ratio = np.mean(L**2, axis=0) / (I * 0.7)
    assert np.all(np.abs(ratio - 1.0) < 5 * np.sqrt(2 / 200000))  # 5 sigma
    q = uniform_orientations(200000, rng=2)
    R = Q.to_matrix(q)
    assert np.abs(R.mean(axis=0)).max() < 5 / np.sqrt(200000) * 0.6  # Haar: E[R] = 0
    scene, q0, _ = _system(4)
    Ls = thermal_momenta(scene.moments, 2.0, rng=3)
    tr = liebody.integrate(scene, q0=q0, L0=Ls, dt=0.01, steps=2, method="splitting2")
    want = np.sum(Ls**2 / scene.moments) / (3 * 4)  # 2 K / (3 N), K = sum L^2 / 2I
    assert kinetic_temperature(tr)[0] == pytest.approx(want, rel=1e-14)


# -------------------------------------------------------------- bad input
def test_bad_input_is_named():
    scene, q0, L0 = _system()
    body = liebody.RigidBody.batch(scene.moments, check_triangle=False)

    def plain(t, q, L, p, out):  # not compiled
        out[:] = 0.0

    with pytest.raises(TypeError, match="compiled with numba"):
        CoupledBodies(body, plain)
    with pytest.raises(ValueError, match=r"params must have shape \(N, k\) with N = 3"):
        CoupledBodies(body, heisenberg_torque, params=np.zeros((4, 3)))

    @njit
    def wrong(t, q, L):
        return 0.0

    with pytest.raises(liebody.TorqueError, match=r"torque.t, q, L, params, out."):
        liebody.integrate(CoupledBodies(body, wrong), q0=q0, L0=L0, dt=0.1, steps=2)
    with pytest.raises(ValueError, match=r"rk4 does not run coupled bodies \(rk4's step holds "
                                         r"stages other than kicks and free flows"):
        liebody.integrate(scene, q0=q0, L0=L0, dt=0.1, steps=2, method="rk4")
    # SABA_n is kicks between exact free flows, but its step begins with a free flow (the
    # words said it was not kicks between free flows)
    with pytest.raises(ValueError, match=r"saba2 does not run coupled bodies \(saba2's step "
                                         r"begins or ends with a free flow, not a kick"):
        liebody.integrate(scene, q0=q0, L0=L0, dt=0.1, steps=2, method="saba2")
    with pytest.raises(ValueError, match=r"sr2 does not run coupled bodies \(SR2 has no "):
        liebody.integrate(scene, q0=q0, L0=L0, dt=0.1, steps=2, method="sr2")  # (named once)
    with pytest.raises(ValueError, match="sites must be distinct: sites 0 and 1"):
        DipoleLattice(body, [[0, 0, 0], [0, 0, 0], [1, 0, 0]], [0, 0, 1])
    with pytest.raises(ValueError, match=r"sites must have shape \(N, 3\)"):
        DipoleLattice(body, [[0, 0, 0]], [0, 0, 1])
    with pytest.raises(ValueError, match=r"q0 must have shape \(4,\) or \(N, 4\)"):
        liebody.integrate(scene, q0=q0[:2], L0=L0, dt=0.1, steps=2)


@njit
def _blows_up(t, q, L, p, out):
    for i in range(q.shape[0]):
        out[i, 0] = out[i, 1] = out[i, 2] = 0.0
    if t > 0.5:
        out[2, 1] = np.nan


@pytest.mark.kernel
def test_a_torque_that_fails_stops_the_run_naming_the_body_and_keeping_the_samples():
    scene, q0, L0 = _system()
    bad = CoupledBodies(liebody.RigidBody.batch(scene.moments, check_triangle=False),
                        _blows_up)
    with pytest.raises(liebody.TorqueError, match=r"for body 2 in the step from t = 0\.5 to "
                                                  r"t = 0\.6 \(after 5 steps\)") as info:
        liebody.integrate(bad, q0=q0, L0=L0, dt=0.1, steps=20, method="splitting2")
    # the words are the fields: 5 good steps, the failing one from t0 + 5 dt to t0 + 6 dt
    assert info.value.step == 5 and info.value.t == 5 * 0.1
    assert info.value.trajectory.failed_at == 6 * 0.1
    tr = info.value.trajectory
    assert tr.t[-1] <= 0.5 + 1e-12 and len(tr.t) >= 5 and np.isfinite(tr.q).all()


def test_scenes_that_share_a_torque_share_its_callback():
    """The C callback of a user's collective torque is compiled once per torque, not once
    per scene (a Monte Carlo that builds a scene per case would compile and keep one
    each), and the runs of the scenes are the same."""
    a, q0, L0 = _system(seed=3)
    b = CoupledBodies(liebody.RigidBody.batch(a.moments, check_triangle=False),
                      heisenberg_torque, heisenberg_potential, params=a.params)
    assert a.address == b.address
    ra = liebody.integrate(a, q0=q0, L0=L0, dt=0.05, steps=20)
    rb = liebody.integrate(b, q0=q0, L0=L0, dt=0.05, steps=20)
    np.testing.assert_array_equal(ra.q, rb.q)
    np.testing.assert_array_equal(ra.L, rb.L)
