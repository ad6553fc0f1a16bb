"""Ensembles: N bodies in one integrate() call.

The reference for every body is the one-body call with that body's state and
parameters: the ensemble's numbers must be the same, bit for bit (each body runs the
same one-body loop). Failures are per body, memory is the saved samples only, and the
running diagnostics equal the same measures taken over every saved step.
"""

from __future__ import annotations

import textwrap
import warnings

import numpy as np
import pytest
from numba import njit

import liebody
from liebody import quaternion as Q
from support import interrupt_child

N = 40
RNG = np.random.default_rng(12)
MOMENTS = RNG.uniform(1.0, 3.0, size=(N, 3))
MOMENTS[:8, 1] = MOMENTS[:8, 0]  # a few symmetric bodies: another plan group
L0 = RNG.normal(size=(N, 3))
Q0 = Q.random(N, rng=13)
MASS = RNG.uniform(1.0, 3.0, N)
CM = np.column_stack([RNG.normal(scale=0.1, size=(N, 2)), RNG.uniform(0.5, 1.0, N)])
SPIN = np.column_stack([np.zeros((N, 2)), RNG.uniform(20.0, 40.0, N)])
EPS = RNG.uniform(0.05, 2.0, N)


@njit
def _drag(t, q, L):
    return -0.2 * L + np.array([0.0, 0.0, 0.05 * np.sin(t)])


def _scenes():
    bodies = liebody.RigidBody.batch(MOMENTS, check_triangle=False)
    top_body = liebody.RigidBody([5.0, 5.0, 1.0])
    return {
        "free": (liebody.FreeBody(bodies), lambda i: liebody.FreeBody(bodies[i]),
                 {"L0": L0, "q0": Q0}, lambda i: {"L0": L0[i], "q0": Q0[i]}),
        "top": (liebody.HeavyTop(top_body, mass=MASS, cm=CM, g=9.81),
                lambda i: liebody.HeavyTop(top_body, MASS[i], CM[i], 9.81),
                {"omega0": SPIN, "q0": Q.exp([0.3, 0.0, 0.0])},
                lambda i: {"omega0": SPIN[i], "q0": Q.exp([0.3, 0.0, 0.0])}),
        "torque": (liebody.TorqueBody(bodies, _drag),
                   lambda i: liebody.TorqueBody(bodies[i], _drag),
                   {"L0": L0, "q0": Q0}, lambda i: {"L0": L0[i], "q0": Q0[i]}),
        "damped": (liebody.DampedBody(liebody.RigidBody([1.0, 2.0, 2.5]), EPS),
                   lambda i: liebody.DampedBody(liebody.RigidBody([1.0, 2.0, 2.5]), EPS[i]),
                   {"L0": L0, "q0": Q0}, lambda i: {"L0": L0[i], "q0": Q0[i]}),
    }


CASES = [(scene, m.name) for scene, (ens, *_) in _scenes().items()
         for m in liebody.methods() if m.supports(ens)]


@pytest.mark.filterwarnings("ignore::liebody.InvariantWarning")  # baselines drift
@pytest.mark.filterwarnings("ignore::RuntimeWarning")  # explicit Euler may blow up per body
@pytest.mark.parametrize(("scene", "method"), CASES)
def test_every_body_equals_its_one_body_run(scene, method):
    """Every method and scene: body i of the ensemble is the one-body call, bit for bit
    (``simd=False``: the one-body loop for every body)."""
    ens, one, kw, kw_one = _scenes()[scene]
    dt = 1e-3 if scene == "top" else 0.01
    tr = liebody.integrate(ens, dt=dt, steps=300, method=method, save_every=37, simd=False,
                           **kw)
    assert not tr.info.get("simd", False) and not any(
        g["simd"] for g in tr.info.get("groups", []))
    assert tr.n_bodies == N and tr.q.shape == (N, len(tr), 4) and tr.t.shape == (len(tr),)
    for i in (0, 3, 9, 17, N - 1):
        ref = liebody.integrate(one(i), dt=dt, steps=300, method=method, save_every=37,
                                **kw_one(i))
        if ref.status == "failed":
            assert tr.status[i] == "failed: non-finite state"
            k = len(ref)
            np.testing.assert_array_equal(tr.q[i, :k], ref.q)
            assert np.isnan(tr.q[i, k:]).all() and tr.failed_at[i] == ref.failed_at
            continue
        np.testing.assert_array_equal(tr.q[i], ref.q)
        np.testing.assert_array_equal(tr.L[i], ref.L)
        np.testing.assert_array_equal(tr.t, ref.t)
        np.testing.assert_allclose(tr.energy[i], ref.energy, rtol=1e-14, atol=1e-14)


SIMD_METHODS = {"free": {"splitting2", "no_squish", "sr2", "rattle", "splitting4",
                         "splitting6", "splitting8", "dmv4", "dmv6", "dmv8", "dmv10"},
                "top": {"splitting2", "no_squish", "rattle", "splitting4", "splitting6",
                        "splitting8"},
                "torque": set(), "damped": set()}


@pytest.mark.filterwarnings("ignore::liebody.InvariantWarning")
@pytest.mark.filterwarnings("ignore::RuntimeWarning")
@pytest.mark.parametrize(("scene", "method"), CASES)
def test_simd_kernels_agree_with_the_one_body_run_to_round_off(scene, method):
    """The default for an ensemble: the SIMD kernels where they apply (the splittings,
    sr2, rattle and dmv on free bodies and heavy tops; not user torques, dissipation,
    baselines or the exact flow), agreeing with the one-body call to round-off; the
    others bit for bit."""
    ens, one, kw, kw_one = _scenes()[scene]
    dt = 1e-3 if scene == "top" else 0.01
    tr = liebody.integrate(ens, dt=dt, steps=300, method=method, save_every=37, **kw)
    infos = tr.info.get("groups", [tr.info])
    used = {bool(g.get("simd", False)) for g in infos}
    assert used == {method in SIMD_METHODS[scene]}, (used, infos)
    for i in (0, 3, 9, 17, N - 1):
        ref = liebody.integrate(one(i), dt=dt, steps=300, method=method, save_every=37,
                                **kw_one(i))
        if ref.status == "failed":
            continue
        scale = np.abs(ref.L).max()
        if True in used and method not in ("rattle",) and not method.startswith("dmv"):
            np.testing.assert_allclose(tr.q[i], ref.q, rtol=0, atol=1e-12)
            np.testing.assert_allclose(tr.L[i], ref.L, rtol=0, atol=1e-12 * scale)
        else:  # the DMV kernels and the scalar path: the one-body numbers
            np.testing.assert_array_equal(tr.q[i], ref.q)
            np.testing.assert_array_equal(tr.L[i], ref.L)


def test_simd_switch():
    ens, _, kw, _ = _scenes()["free"]
    on = liebody.integrate(ens, dt=0.01, steps=10, method="splitting2", simd=True, **kw)
    off = liebody.integrate(ens, dt=0.01, steps=10, method="splitting2", simd=False, **kw)
    assert any(g["simd"] for g in on.info.get("groups", [on.info]))
    assert not any(g["simd"] for g in off.info.get("groups", [off.info]))
    two = liebody.integrate(ens.take(slice(0, 2)), dt=0.01, steps=10, method="splitting2",
                            q0=Q0[:2], L0=L0[:2])
    assert not any(g["simd"] for g in two.info.get("groups", [two.info]))  # N < 3
    with pytest.raises(TypeError, match="simd must be True, False or None"):
        liebody.integrate(ens, dt=0.01, steps=10, method="splitting2", simd="yes", **kw)


def test_a_single_state_broadcasts_and_shapes_are_checked(hlw):
    scene, L = hlw
    tr = liebody.integrate(scene, q0=Q0, L0=L, dt=0.1, steps=10, method="splitting2")
    assert tr.q.shape == (N, 11, 4)
    np.testing.assert_array_equal(tr.L, np.broadcast_to(tr.L[0], tr.L.shape))  # same L path
    with pytest.raises(ValueError, match=r"numbers of bodies do not match: q0 40, L0/omega0 7"):
        liebody.integrate(scene, q0=Q0, L0=L0[:7], dt=0.1, steps=10)
    with pytest.raises(ValueError, match=r"q0 must be one state .* or one per body"):
        liebody.integrate(scene, q0=Q0.reshape(4, 10, 4), L0=L, dt=0.1, steps=10)
    bodies = liebody.RigidBody.batch(MOMENTS, check_triangle=False)
    with pytest.raises(ValueError, match="numbers of bodies do not match"):
        liebody.integrate(liebody.FreeBody(bodies), L0=L0[:5], dt=0.1, steps=10)


def test_trajectory_diagnostics_work_per_body():
    ens, one, kw, kw_one = _scenes()["top"]
    tr = liebody.integrate(ens, dt=1e-3, steps=200, save_every=20, **kw)
    ref = liebody.integrate(one(5), dt=1e-3, steps=200, save_every=20, **kw_one(5))
    for name in ("energy", "kinetic_energy", "potential_energy", "L_space", "omega_space",
                 "omega", "casimir", "quaternion_norm"):
        got = np.broadcast_to(getattr(tr, name), getattr(tr, name).shape)
        assert got.shape[:2] == (N, len(tr)), name
        np.testing.assert_allclose(got[5], getattr(ref, name), rtol=1e-13, atol=1e-13)
    np.testing.assert_allclose(tr.euler_angles(unwrap=True)[5], ref.euler_angles(unwrap=True),
                               atol=1e-12)
    assert repr(tr).startswith("Trajectory(method='splitting2', dt=0.001, bodies=40")


@pytest.mark.filterwarnings("ignore::liebody.InvariantWarning")  # euler's |q| grows
def test_failures_are_per_body(hlw):
    """A body that blows up is marked and its later samples are NaN; the others finish."""
    scene, L = hlw
    Ls = np.tile(L, (6, 1))
    Ls[2] *= 1e3  # explicit Euler at h|omega| ~ 14: non-finite within a few hundred steps
    with pytest.warns(RuntimeWarning, match=r"euler: 1 of 6 bodies failed: 1 non-finite "
                                            r"state \(e.g. body 2 at t = "):
        tr = liebody.integrate(scene, L0=Ls, dt=0.01, steps=2000, method="euler",
                               save_every=10)
    assert np.isnan(tr.failed_at[[0, 1, 3, 4, 5]]).all() and tr.failed_at[2] > 0
    assert list(tr.status).count("complete") == 5 and tr.status[2].startswith("failed")
    k = int(tr.failed_at[2] // 0.1)  # samples every 0.1 time units
    assert np.isfinite(tr.q[2, :k]).all() and np.isnan(tr.q[2, k + 1:]).all()
    assert np.isfinite(tr.q[[0, 1, 3, 4, 5]]).all()
    assert np.isnan(tr.energy[2, -1]) and np.isfinite(tr.energy[0]).all()


def test_dmv_non_convergence_is_per_body_too(hlw):
    scene, L = hlw
    Ls = np.tile(L, (4, 1))
    Ls[1] *= 1e4
    with pytest.warns(RuntimeWarning, match="1 DMV equation not solved"):
        tr = liebody.integrate(scene, L0=Ls, dt=0.1, steps=20, method="rattle")
    assert tr.status[1] == "failed: DMV equation not solved"
    assert np.isfinite(tr.q[[0, 2, 3]]).all()


def test_final_state_only_with_running_diagnostics_needs_little_memory():
    """10 000 bodies, no samples kept but the start and the end: kilobytes per body, and
    the in-kernel diagnostics equal the same measures over every step of a saved run."""
    n = 10_000
    bodies = liebody.RigidBody.batch(np.tile([1.0, 2.0, 2.5], (n, 1)) * RNG.uniform(
        0.9, 1.1, size=(n, 1)))
    L = RNG.normal(size=(n, 3))
    tr = liebody.integrate(liebody.FreeBody(bodies), L0=L, dt=0.01, steps=2000,
                           method="splitting2", save_every=None, diagnostics=True)
    assert tr.q.shape == (n, 2, 4) and tr.q.nbytes + tr.L.nbytes == n * 2 * 56
    d = tr.diagnostics
    assert all(v.shape == (n,) for v in d.values())
    assert d["max_qnorm_error"].max() < 1e-13 and d["max_casimir_error"].max() < 1e-13
    few = slice(0, 20)
    full = liebody.integrate(liebody.FreeBody(liebody.RigidBody.batch(bodies.moments[few])),
                             L0=L[few], dt=0.01, steps=2000, method="splitting2",
                             save_every=1)
    E = full.energy
    dE = np.max(np.abs(E - E[:, :1]) / full.kinetic_energy[:, :1], axis=1)
    np.testing.assert_allclose(d["max_energy_error"][few], dE, rtol=1e-9)
    assert dE.min() > 1e-9  # the splitting's energy error, not round-off, is compared


def test_threads_do_not_change_a_bit(hlw):
    scene, L = hlw
    Ls = L * RNG.uniform(0.5, 2.0, size=(500, 1))
    a = liebody.integrate(scene, L0=Ls, dt=0.01, steps=1000, method="splitting4", threads=1,
                          save_every=100)
    b = liebody.integrate(scene, L0=Ls, dt=0.01, steps=1000, method="splitting4", threads=2,
                          save_every=100)
    np.testing.assert_array_equal(a.q, b.q)
    with pytest.raises(ValueError, match="threads must be a positive integer or None"):
        liebody.integrate(scene, L0=Ls, dt=0.01, steps=10, threads=0)


_CHILD = textwrap.dedent("""
    import json, signal, numpy as np, liebody
    # a job started in the background without job control inherits SIGINT ignored
    signal.signal(signal.SIGINT, signal.default_int_handler)
    scene = liebody.FreeBody(liebody.RigidBody([1.0, 2.0, 2.5]))
    L = np.random.default_rng(0).normal(size=(200, 3))
    liebody.integrate(scene, L0=L[:3], dt=1e-3, steps=10, method="splitting2")
    print("ready", flush=True)
    try:
        liebody.integrate(scene, L0=L, dt=1e-3, steps=10**7, method="splitting2",
                          save_every=10**4)
    except KeyboardInterrupt as exc:
        tr = exc.trajectory
        print(json.dumps({"shape": list(tr.q.shape), "status": sorted(set(tr.status)),
                          "finite": bool(np.isfinite(tr.q).all())}), flush=True)
""")


def test_ctrl_c_keeps_an_ensembles_samples():
    (out,), _ = interrupt_child(_CHILD, [], 2.0)
    assert out["shape"][0] == 200 and out["shape"][1] >= 2 and out["finite"]
    assert out["status"] == ["interrupted"]


def test_batch_bodies_validate_and_index():
    with pytest.raises(ValueError, match=r"body 3: principal moment I1 = -1.0 is negative"):
        liebody.RigidBody.batch([[1, 2, 2.5]] * 3 + [[-1, 2, 2.5]])
    with pytest.raises(ValueError, match=r"body 1: I1 \+ I2 = 3.0 < I3 = 9.0"):
        liebody.RigidBody.batch([[1, 2, 2.5], [1, 2, 9.0]])
    with pytest.raises(ValueError, match=r"a batch of bodies: RigidBody.batch"):
        liebody.RigidBody(MOMENTS)
    b = liebody.RigidBody.batch(MOMENTS, mass=MASS, check_triangle=False)
    assert len(b) == N and b.moments.shape == (N, 3) and b.axes.shape == (N, 3, 3)
    one = b[4]
    assert isinstance(one, liebody.RigidBody) and one.mass == MASS[4]
    np.testing.assert_array_equal(one.moments, b.moments[4])
    assert list(b.symmetry_axis[:8]) == [2] * 8 and b.is_symmetric[:8].all()
    tensors = np.einsum("nij,nj,nkj->nik", Q.to_matrix(Q0), MOMENTS, Q.to_matrix(Q0))
    bt = liebody.RigidBody.batch(tensors, check_triangle=False)
    for i in (0, 11):
        ref = liebody.RigidBody(tensors[i], check_triangle=False)
        np.testing.assert_array_equal(bt[i].moments, ref.moments)
        np.testing.assert_array_equal(bt[i].axes, ref.axes)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        np.testing.assert_allclose(b.kinetic_energy(L0 / MOMENTS),
                                   0.5 * np.sum(L0 * L0 / MOMENTS, axis=1), rtol=1e-15)


def test_failed_at_means_the_same_for_one_body_and_an_ensemble():
    """The time the failing step was to reach, whatever failed (a non-converging implicit
    step here), for a one-body call's exception and for the body of an ensemble."""
    scene = liebody.FreeBody(liebody.RigidBody([1.0, 2.0, 2.5]))
    L_bad = [0.0, 500.0, 3.0]  # h |omega| = 25: RATTLE's equation has no root at once
    with pytest.raises(liebody.ConvergenceError) as info:
        liebody.integrate(scene, L0=L_bad, dt=0.1, steps=10, method="rattle")
    one = info.value.trajectory.failed_at
    with pytest.warns(RuntimeWarning):
        ens = liebody.integrate(scene, L0=[[0.1, 0.2, 0.3], L_bad], dt=0.1, steps=10,
                                method="rattle", simd=False)
    assert one == pytest.approx(0.1) and ens.failed_at[1] == pytest.approx(one)
    assert np.isnan(ens.failed_at[0])


def test_unwrapped_euler_angles_of_an_ensemble_with_a_failed_body():
    """Before: ValueError 'angles must be finite'. The failed body's samples before the
    failure are unwrapped, NaN after; the others equal their one-body runs."""
    scene = liebody.FreeBody(liebody.RigidBody([1.0, 2.0, 3.0]))
    Ls = [[0.0, 0.1, 0.05], [0.0, 50.0, 3.0], [0.0, 0.2, 0.01]]
    with pytest.warns(RuntimeWarning):
        tr = liebody.integrate(scene, L0=Ls, dt=0.1, steps=200, method="rattle", simd=False)
    assert tr.status[1] != "complete"
    angles = tr.euler_angles(unwrap=True)
    n = int(np.isfinite(tr.q[1]).all(axis=-1).sum())
    assert np.isfinite(angles[1, :n]).all() and np.isnan(angles[1, n:]).all()
    for i in (0, 2):
        one = liebody.integrate(scene, L0=Ls[i], dt=0.1, steps=200, method="rattle")
        np.testing.assert_array_equal(angles[i], one.euler_angles(unwrap=True))


ONE = liebody.RigidBody([1.0, 2.0, 3.0])


@pytest.mark.filterwarnings("ignore::liebody.InvariantWarning")  # baselines drift
@pytest.mark.parametrize("method", [m.name for m in liebody.methods()
                                    if m.supports(liebody.FreeBody(ONE))])
def test_every_ensembles_info_says_whether_simd_ran(method):
    """integrate() promises Trajectory.info["simd"] for an ensemble (or per group): for
    every method, the exact flow's included (it had no key), and a Stepper's info alike."""
    scene = liebody.FreeBody(ONE)
    L0 = np.random.default_rng(0).normal(size=(4, 3))
    tr = liebody.integrate(scene, L0=L0, dt=0.01, steps=5, method=method)
    st = liebody.Stepper(scene, L0=L0, dt=0.01, method=method)
    for info in (tr.info, st.info):
        groups = info.get("groups", [info])
        assert all(isinstance(g["simd"], bool) for g in groups)
    if method == "exact":
        assert tr.info["simd"] is False and st.info["simd"] is False
