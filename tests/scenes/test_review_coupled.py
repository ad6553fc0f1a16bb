"""Review of the coupled bodies (liebody.coupled): each test of a bug failed on the code
before its fix. The references are independent: the same physics written another way, closed
forms, pair sums in numpy."""

from __future__ import annotations

import warnings

import numba
import numpy as np
import pytest
from numba import njit
from test_coupled import _system, heisenberg_potential, heisenberg_torque

import liebody
from liebody import quaternion as Q
from liebody.coupled import CoupledBodies, DipoleLattice, uniform_orientations
from support import rotation_distance


# ------------------------------------------------------------ a torque that accumulates
@njit(cache=True)
def _rotate(q, v):
    """``R(q) v`` by the matrix of the unit quaternion ``q`` (another route than the
    test module's cross-product form)."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    return np.array([
        (1 - 2 * (y * y + z * z)) * v[0] + 2 * (x * y - w * z) * v[1] + 2 * (x * z + w * y) * v[2],
        2 * (x * y + w * z) * v[0] + (1 - 2 * (x * x + z * z)) * v[1] + 2 * (y * z - w * x) * v[2],
        2 * (x * z - w * y) * v[0] + 2 * (y * z + w * x) * v[1] + (1 - 2 * (x * x + y * y)) * v[2]])


@njit(cache=True)
def pairwise_heisenberg_torque(t, q, L, p, out):
    """The torque of ``V = -sum_{i<j} mu_i . mu_j`` summed pair by pair into ``out`` with
    ``+=``, as molecular-dynamics force loops do (each pair visited once, both bodies'
    torques accumulated): ``N_i = d_i x R(q_i)^T mu_j`` for every partner ``j``."""
    n = q.shape[0]
    mus = np.empty((n, 3))
    for i in range(n):
        mus[i] = _rotate(q[i], p[i, :3])
    for i in range(n):
        qi = np.array([q[i, 0], -q[i, 1], -q[i, 2], -q[i, 3]])
        for j in range(i + 1, n):
            qj = np.array([q[j, 0], -q[j, 1], -q[j, 2], -q[j, 3]])
            a = _rotate(qi, mus[j])  # mu_j in i's frame
            b = _rotate(qj, mus[i])  # mu_i in j's frame
            di, dj = p[i, :3], p[j, :3]
            out[i, 0] += di[1] * a[2] - di[2] * a[1]
            out[i, 1] += di[2] * a[0] - di[0] * a[2]
            out[i, 2] += di[0] * a[1] - di[1] * a[0]
            out[j, 0] += dj[1] * b[2] - dj[2] * b[1]
            out[j, 1] += dj[2] * b[0] - dj[0] * b[2]
            out[j, 2] += dj[0] * b[1] - dj[1] * b[0]


def test_a_torque_that_accumulates_into_out_starts_from_zero_at_every_kick():
    """A torque written as ``out[i] += ...`` (pair loops) saw the previous kick's torques
    in the driver's work array (``np.empty``, never cleared), while ``evaluate_torque``
    and the set-up check hand it zeros: the run integrated the sum of all past torques
    (L off by 42 after 100 steps). It must run as the same physics written with ``=``."""
    scene, q0, L0 = _system(4, seed=31)
    pairwise = CoupledBodies(liebody.RigidBody.batch(scene.moments, check_triangle=False),
                             pairwise_heisenberg_torque, heisenberg_potential,
                             params=scene.params)
    np.testing.assert_allclose(pairwise.evaluate_torque(q0, L0),
                               scene.evaluate_torque(q0, L0), rtol=0, atol=1e-14)
    for method in ("splitting2", "splitting4", "rattle"):
        a = liebody.integrate(scene, q0=q0, L0=L0, dt=0.01, steps=200, method=method,
                              save_every=50)
        b = liebody.integrate(pairwise, q0=q0, L0=L0, dt=0.01, steps=200, method=method,
                              save_every=50)
        np.testing.assert_allclose(b.L, a.L, rtol=0, atol=1e-12, err_msg=method)
        st = liebody.Stepper(pairwise, q0=q0, L0=L0, dt=0.01, method=method)
        st.step(200)
        np.testing.assert_allclose(st.L, a.L[:, -1], rtol=0, atol=1e-12, err_msg=method)


# ------------------------------------------------------------ the sites of a lattice
def test_sites_closer_than_the_rule_are_refused_wherever_they_sort():
    """The rule (no two sites closer than 1e-9 of the lattice's size) was checked only
    between neighbours in lexicographic order: sites 0 and 2 below, 1e-12 apart, have
    (0, 1, 0) between them in that order and were accepted (V = 1.4e36); three sites in
    one place (the lattice's size 0) were accepted too (V = NaN)."""
    bodies = liebody.RigidBody.batch(np.tile([1.0, 2.0, 3.0], (3, 1)))
    with pytest.raises(ValueError, match="sites must be distinct: sites 0 and 2"):
        DipoleLattice(bodies, [[0, 0, 0], [0, 1, 0], [1e-12, 0, 0]], [0, 0, 1])
    with pytest.raises(ValueError, match="sites must be distinct: sites 0 and 1"):
        DipoleLattice(bodies, [[1, 1, 1]] * 3, [0, 0, 1])
    # far apart by the rule: accepted, and the energy is the pair sum
    sites = np.array([[0, 0, 0], [0, 1, 0], [2e-9, 0, 0]]) * 1.0
    lat = DipoleLattice(bodies, sites, [0, 0, 1])
    q = uniform_orientations(3, rng=1)
    mu = Q.rotate(q, np.array([0.0, 0.0, 1.0]))
    want = 0.0
    for i in range(3):
        for j in range(i + 1, 3):
            r = sites[i] - sites[j]
            rn = np.linalg.norm(r)
            e = r / rn
            want += (mu[i] @ mu[j] - 3 * (mu[i] @ e) * (mu[j] @ e)) / rn**3
    assert lat.potential(q) == pytest.approx(want, rel=1e-12)


# ------------------------------------------------------------ failures in the Stepper
@njit(cache=True)
def _nan_after(t, q, L, p, out):
    for i in range(q.shape[0]):
        out[i, 0] = out[i, 1] = out[i, 2] = 0.0
    if t > 0.55:
        out[1, 0] = np.nan


@njit(cache=True)
def _raises_after(t, q, L, p, out):
    for i in range(q.shape[0]):
        out[i, 0] = out[i, 1] = out[i, 2] = 0.0
    if t > 0.55:
        raise ValueError("the torque's own words")


def _failing(torque):
    scene, q0, L0 = _system(3, seed=33)
    return CoupledBodies(liebody.RigidBody.batch(scene.moments, check_triangle=False),
                         torque), q0, L0


@pytest.mark.kernel
def test_a_failing_stepper_call_leaves_the_state_before_the_call():
    """liebody.Stepper promises the stepper as before a failing call; the coupled one
    was left with the failing kick's NaN momentum (and the other bodies half kicked)."""
    scene, q0, L0 = _failing(_nan_after)
    st = liebody.Stepper(scene, q0=q0, L0=L0, dt=0.1)
    st.step(4)
    q, L, t = st.q, st.L, st.t
    with pytest.raises(liebody.TorqueError, match=r"for body 1 in the step from t = 0\.5 to "
                                                  r"t = 0\.6 \(after 1 step of this "
                                                  r"call\)") as info:
        st.step(3)  # its second step's last kick, at t = 0.6, fails
    assert info.value.step == 1 and info.value.t == 5 * 0.1  # (the words' fields)
    assert np.array_equal(st.q, q) and np.array_equal(st.L, L) and st.t == t
    free = liebody.integrate(scene, q0=q0, L0=L0, dt=0.1, steps=4, save_every=1)
    assert np.array_equal(st.L, free.L[:, -1])  # (zero torque so far: free bodies)


@pytest.mark.kernel
@pytest.mark.parametrize("use_stepper", [False, True])
def test_a_torque_that_raises_at_a_later_kick_of_the_step_is_named_as_the_cause(
        use_stepper):
    """The torque raised at the step's last kick (t = 0.6); the run looked for the cause
    at the step's start (t = 0.5), where the torque works, and reported none (the
    Stepper never looked)."""
    scene, q0, L0 = _failing(_raises_after)
    with pytest.raises(liebody.TorqueError, match="the torque's own words") as info:
        if use_stepper:
            liebody.Stepper(scene, q0=q0, L0=L0, dt=0.1).step(20)
        else:
            liebody.integrate(scene, q0=q0, L0=L0, dt=0.1, steps=20)
    assert isinstance(info.value.__cause__, ValueError)
    if not use_stepper:
        assert np.allclose(info.value.trajectory.t, np.arange(6) * 0.1)


# ------------------------------------------------------------ the Stepper's arguments
def test_the_stepper_names_its_bad_arguments():
    scene, q0, L0 = _system(3, seed=35)
    with pytest.raises(ValueError, match="t0 must be finite"):
        liebody.Stepper(scene, q0=q0, L0=L0, dt=0.1, t0=float("nan"))
    with pytest.raises(TypeError, match="t0"):  # (was a TorqueError from inside the torque)
        liebody.Stepper(scene, q0=q0, L0=L0, dt=0.1, t0="soon")
    with pytest.raises(ValueError, match=r"t0 \+ dt == t0"):  # the clock could not advance
        liebody.Stepper(scene, q0=q0, L0=L0, dt=1e-3, t0=1e20)
    st = liebody.Stepper(scene, q0=q0, L0=L0, dt=0.1)
    q = st.q
    with pytest.raises(ValueError, match=r"q must have shape \(4,\) or \(N, 4\) = \(3, 4\)"):
        st.q = q0[:2]  # (numpy's broadcasting error, which named no argument)
    assert np.array_equal(st.q, q)
    with pytest.raises(ValueError, match="t must be finite"):
        st.t = float("inf")


# ------------------------------------------------------------ a torque that reads L
@njit(cache=True)
def _drag(t, q, L, p, out):
    heisenberg_torque(t, q, L, p, out)
    for i in range(q.shape[0]):
        for a in range(3):
            out[i, a] -= 0.5 * L[i, a]


def test_a_torque_that_depends_on_the_momenta_is_refused():
    """The kicks are the exact flow of a potential, ``L += tau N(t, q)``: a torque that
    reads ``L`` (a drag) ran as an explicit, first-order, irreversible kick without a
    word. Refused, naming the rule, as a one-body orientation-only torque is."""
    scene, q0, L0 = _system(3, seed=37)
    drag = CoupledBodies(liebody.RigidBody.batch(scene.moments, check_triangle=False),
                         _drag, params=scene.params)
    for run in (lambda: liebody.integrate(drag, q0=q0, L0=L0, dt=0.01, steps=10),
                lambda: liebody.Stepper(drag, q0=q0, L0=L0, dt=0.01)):
        with pytest.raises(ValueError, match=r"the coupled torque depends on L: .* at "
                                             r"L = 2 L0 \+ 1"):
            run()


# ------------------------------------------------------------ the energy check
@njit(cache=True)
def _pulsed_torque(t, q, L, p, out):
    heisenberg_torque(t, q, L, p, out)
    for i in range(q.shape[0]):
        for a in range(3):
            out[i, a] *= 2.0 + np.sin(t)


@njit(cache=True)
def _pulsed_potential(t, q, p):
    return (2.0 + np.sin(t)) * heisenberg_potential(t, q, p)


def test_a_time_dependent_potential_gets_no_energy_warning_and_warnings_point_at_the_caller():
    """``V(t, q)`` that depends on the time does not keep ``T + V``: the end-of-run check
    warned that the energy 'went from -4.06 to -5.57 ... the step may be too large' at a
    step where the run is accurate. The change is the work of the time dependence,
    ``int dV/dt dt`` along the run (Simpson's rule over the samples; the kicks at their
    times make it so to 1e-9 here). A potential of the orientations alone is still
    checked, and its warning now points at the caller's line (it pointed into
    liebody._integrate)."""
    from scipy.integrate import simpson

    rng = np.random.default_rng(4)
    I = 1.0 + rng.random((4, 3))
    scene = CoupledBodies(liebody.RigidBody.batch(I, check_triangle=False), _pulsed_torque,
                          _pulsed_potential, params=2.0 * rng.normal(size=(4, 3)))
    q0, L0 = uniform_orientations(4, rng=1), 0.1 * rng.normal(size=(4, 3))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        tr = liebody.integrate(scene, q0=q0, L0=L0, dt=1e-3, steps=3000, save_every=1,
                               method="splitting4")
    E = tr.energy
    assert abs(E[-1] - E[0]) > 0.2 * abs(E[0])  # the energy does change, physically
    # dE/dt = dV/dt at fixed q: V(t, q) cos(t) / (2 + sin t)
    dVdt = np.array([scene.potential(tr.q[:, k], t) * np.cos(t) / (2.0 + np.sin(t))
                     for k, t in enumerate(tr.t)])
    assert E[-1] - E[0] == pytest.approx(simpson(dVdt, x=tr.t), rel=1e-8)
    fixed, q0, L0 = _system(5, seed=3)
    with pytest.warns(liebody.InvariantWarning, match="energy of the coupled system") as rec:
        liebody.integrate(fixed, q0=q0, L0=L0, dt=0.3, steps=2000, save_every=100)
    assert rec[0].filename == __file__


# ------------------------------------------------------------ reversibility
def test_the_stepper_reverses_a_composition_exactly():
    """Each body's free flow (its axis ordering, the base of a composition) is chosen
    from its own orbit at set-up; a coupled body's orbit changes, so a second
    integrate() from the reversed final state may choose another step (splitting4 came
    back 2e-6 off after 150 steps). The Stepper keeps its step: (q, L) -> (q, -L)
    through it reverses the run to round-off (1e-13 measured; round-off grows about
    tenfold every 50 steps in this chaotic system), as a symmetric composition must.
    (What docs/coupled.md now says; no code changed.)"""
    rng = np.random.default_rng(4)
    I = np.array([[1.0, 1.5, 2.0], [2.0, 2.0, 3.0], [1.5, 1.5, 1.5], [3.0, 2.0, 1.2],
                  [1.0, 1.0, 0.5]])
    scene = CoupledBodies(liebody.RigidBody.batch(I, check_triangle=False), heisenberg_torque,
                          heisenberg_potential, params=rng.normal(size=(5, 3)))
    q0, L0 = uniform_orientations(5, rng=1), rng.normal(size=(5, 3))
    for method in ("splitting2", "splitting4", "exact", "rattle"):
        st = liebody.Stepper(scene, q0=q0, L0=L0, dt=0.05, method=method)
        st.step(150)
        assert not np.allclose(st.L, L0, atol=0.1)
        st.L = -st.L
        st.step(150)
        assert rotation_distance(st.q, q0).max() < 1e-11, method
        np.testing.assert_allclose(-st.L, L0, rtol=0, atol=1e-11, err_msg=method)


# ------------------------------------------------------------ one body of the system
def test_trajectory_body_picks_one_body_of_a_coupled_run():
    """``CoupledBodies.take`` exists for ``Trajectory.body(i)``, which raised IndexError
    on every coupled trajectory (it indexed the system's one ``status`` string per
    body)."""
    scene, q0, L0 = _system(3, seed=39)
    tr = liebody.integrate(scene, q0=q0, L0=L0, dt=0.05, steps=20, save_every=5)
    one = tr.body(1)
    assert np.array_equal(one.q, tr.q[1]) and np.array_equal(one.L, tr.L[1])
    assert np.array_equal(one.t, tr.t) and one.status == "complete" and one.failed_at is None
    np.testing.assert_allclose(one.kinetic_energy,
                               0.5 * np.sum(tr.L[1] ** 2 / scene.moments[1], axis=-1),
                               rtol=1e-15)
    bad, q0, L0 = _failing(_nan_after)
    with pytest.raises(liebody.TorqueError) as info:
        liebody.integrate(bad, q0=q0, L0=L0, dt=0.1, steps=20)
    failed = info.value.trajectory
    for i in (0, 1, -1):
        b = failed.body(i)
        assert b.status == "failed" and b.failed_at == pytest.approx(0.6)
        assert np.array_equal(b.L, failed.L[i])


def test_a_coupled_trajectory_is_shown_in_one_line():
    """The dataclass decorator of CoupledTrajectory wrote a repr of every field (every
    sample of q and L, the method's record: 3,000 characters for 3 bodies and 4 samples)
    over Trajectory's one line."""
    scene, q0, L0 = _system(3, seed=41)
    tr = liebody.integrate(scene, q0=q0, L0=L0, dt=0.1, steps=3)
    assert repr(tr) == ("CoupledTrajectory(method='splitting2', dt=0.1, bodies=3, samples=4, "
                        "t=[0, 0.3], complete)")
    bad, q0, L0 = _failing(_nan_after)
    with pytest.raises(liebody.TorqueError) as info:
        liebody.integrate(bad, q0=q0, L0=L0, dt=0.1, steps=20)
    assert repr(info.value.trajectory).endswith("samples=6, t=[0, 0.5], failed at t=0.6)")


@pytest.mark.kernel
def test_the_potential_and_the_torque_check_the_orientations_they_are_given():
    """The compiled model reads every body's row without bounds checks: the potential of
    4 orientations for a lattice of 6 bodies read past the array (V = -5.3e276), the
    torque likewise, and momenta of the wrong shape went through."""
    from test_coupled import _lattice

    lat, q, sites, d = _lattice(n=6, cutoff=100.0)
    L = np.zeros((6, 3))
    with pytest.raises(ValueError, match=r"q must have shape \(N, 4\) = \(6, 4\)"):
        lat.potential(q[:4])
    with pytest.raises(ValueError, match=r"q must have shape \(N, 4\) = \(6, 4\)"):
        lat.potential(q[:, :3])
    with pytest.raises(ValueError, match=r"q must have shape \(N, 4\) = \(6, 4\)"):
        lat.evaluate_torque(q[:4], L)
    with pytest.raises(ValueError, match=r"L must have shape \(3,\) or \(N, 3\) = \(6, 3\)"):
        lat.evaluate_torque(q, L[:2])
    with pytest.raises(ValueError, match="q must be finite"):
        lat.potential(np.full((6, 4), np.nan))
    with pytest.raises(ValueError, match="t must be finite"):
        lat.potential(q, t=np.nan)
    # the right shapes give the pair sum, and L broadcast from (3,) the same torque
    from test_coupled import _direct_potential

    assert lat.potential(q) == pytest.approx(_direct_potential(q, sites, d), rel=1e-13)
    assert np.array_equal(lat.evaluate_torque(q, L[0]), lat.evaluate_torque(q, L))


def test_a_potential_that_fails_at_the_energy_check_does_not_lose_the_run():
    """The end-of-run energy check calls the potential; a (plain Python) potential that
    raised there made integrate() raise it, the computed trajectory lost. It is a
    warning now, the run returned; a potential that turns NaN is still warned about as
    not finite."""
    scene, q0, L0 = _system(3, seed=43)
    calls = []

    def fragile(t, q, p):
        calls.append(t)
        if len(calls) > 1:
            raise RuntimeError("no more energy")
        return heisenberg_potential(t, q, p)

    def nan_later(t, q, p):  # (finite at the start, checked there)
        calls.append(t)
        return heisenberg_potential(t, q, p) if len(calls) < 3 else float("nan")

    body = liebody.RigidBody.batch(scene.moments, check_triangle=False)
    with pytest.warns(liebody.InvariantWarning, match="not checked: the potential raised "
                                                      "RuntimeError: no more energy"):
        tr = liebody.integrate(CoupledBodies(body, heisenberg_torque, fragile,
                                             params=scene.params),
                               q0=q0, L0=L0, dt=0.01, steps=50)
    ref = liebody.integrate(scene, q0=q0, L0=L0, dt=0.01, steps=50)
    assert np.array_equal(tr.L, ref.L) and tr.status == "complete"
    calls.clear()
    with pytest.warns(liebody.InvariantWarning, match="not finite at the ends"):
        liebody.integrate(CoupledBodies(body, heisenberg_torque, nan_later,
                                        params=scene.params),
                          q0=q0, L0=L0, dt=0.01, steps=50)


@pytest.mark.kernel
def test_ctrl_c_in_a_stepper_call_keeps_the_steps_done():
    """Ctrl-C as a step's call returns (simulated: the call runs, then raises
    KeyboardInterrupt, as Python delivers a pending SIGINT): the coupled Stepper let a
    bare KeyboardInterrupt through with the state one step ahead of its clock. Now it
    raises IntegrationInterrupted, as liebody.Stepper does, and is the stepper that took
    exc.step steps, bit for bit, clock included."""
    scene, q0, L0 = _system(3, seed=45)
    st = liebody.Stepper(scene, q0=q0, L0=L0, dt=0.05)
    inner, calls = st._run.run, []

    def interrupted(*args):
        out = inner(*args)
        calls.append(1)
        if len(calls) == 4:
            raise KeyboardInterrupt
        return out

    st._run.run = interrupted
    with pytest.raises(liebody.IntegrationInterrupted) as info:
        st.step(10)
    st._run.run = inner
    twin = liebody.Stepper(scene, q0=q0, L0=L0, dt=0.05)
    twin.step(4)
    assert info.value.step == 4 and st.t == twin.t == pytest.approx(0.2)
    assert np.array_equal(st.q, twin.q) and np.array_equal(st.L, twin.L)
    st.step(5)
    twin.step(5)
    assert np.array_equal(st.L, twin.L) and st.t == twin.t


@njit(cache=True)
def _noisy(t, q, L, p, out):
    heisenberg_torque(t, q, L, p, out)
    for i in range(q.shape[0]):
        for a in range(3):
            out[i, a] += 1e-3 * np.random.standard_normal()  # noqa: NPY002 (numba's)


def test_a_torque_that_draws_noise_is_not_taken_for_one_that_reads_L():
    """The check of L-independence compares two calls; a random torque (a thermostat's
    kicks) differs between any two calls and runs as before."""
    scene, q0, L0 = _system(3, seed=47)
    noisy = CoupledBodies(liebody.RigidBody.batch(scene.moments, check_triangle=False),
                          _noisy, params=scene.params)
    tr = liebody.integrate(noisy, q0=q0, L0=L0, dt=0.01, steps=10)
    assert tr.status == "complete" and np.isfinite(tr.L).all()


@njit  # (not cached: numba.get_num_threads reads a dynamic global)
def _counting_threads(t, q, L, p, out):
    for i in range(q.shape[0]):
        out[i, 0] = out[i, 1] = 0.0
        out[i, 2] = 1e-3 * numba.get_num_threads()


def test_integrate_runs_a_coupled_system_on_the_threads_it_is_given():
    """integrate(threads=...) was ignored for a coupled system (its torque ran on all of
    numba's threads whatever was asked), and simd=False accepted though no body runs
    alone. A torque that reads numba's thread count (a constant spin-up about axis 3 of
    1e-3 per thread) shows the count it ran on; numba's setting is restored after."""
    body = liebody.RigidBody.batch([[1.0, 2.0, 3.0]] * 2)
    scene = CoupledBodies(body, _counting_threads)
    before = numba.get_num_threads()
    for threads in (1, 2):
        tr = liebody.integrate(scene, q0=[1, 0, 0, 0], L0=[0, 0, 1.0], dt=0.1, steps=10,
                               threads=threads)
        used = min(threads, numba.config.NUMBA_NUM_THREADS)
        np.testing.assert_allclose(tr.L[:, -1, 2] - 1.0, 1e-3 * used * 1.0, rtol=0,
                                   atol=1e-14)  # (20 roundings of numbers near 1)
        assert numba.get_num_threads() == before
    with pytest.raises(ValueError, match="threads must be a positive integer"):
        liebody.integrate(scene, q0=[1, 0, 0, 0], L0=[0, 0, 1.0], dt=0.1, steps=10,
                          threads=0)
    with pytest.raises(ValueError, match=r"simd=False .* no one-body run"):
        liebody.integrate(scene, q0=[1, 0, 0, 0], L0=[0, 0, 1.0], dt=0.1, steps=10,
                          simd=False)


def test_a_potential_that_cannot_give_the_energy_is_named_before_the_run():
    """A potential of the wrong signature, or one that gives no single finite number,
    ran the whole integration and failed only at the end (the energy check), the run
    lost; it is named at the start, as a one-body scene's potential is."""
    scene, q0, L0 = _system(3, seed=49)
    body = liebody.RigidBody.batch(scene.moments, check_triangle=False)

    def two_arguments(t, q):
        return 0.0

    def per_body(t, q, p):
        return np.zeros(q.shape[0])

    def infinite(t, q, p):
        return float("inf")

    for potential, words in ((two_arguments, "the coupled potential raised TypeError at "
                                             "the initial state"),
                             (per_body, r"one real number V, got list of shape \(3,\)"),
                             (infinite, r"not finite at the initial state \(V = inf\)")):
        scene2 = CoupledBodies(body, heisenberg_torque, potential, params=scene.params)
        with pytest.raises(ValueError, match=words):
            liebody.integrate(scene2, q0=q0, L0=L0, dt=0.01, steps=10)


@njit(cache=True)
def _flipped_torque(t, q, L, p, out):
    heisenberg_torque(t, q, L, p, out)
    for i in range(q.shape[0]):
        for a in range(3):
            out[i, a] = -out[i, a]


@njit(cache=True)
def _space_frame_torque(t, q, L, p, out):
    heisenberg_torque(t, q, L, p, out)
    for i in range(q.shape[0]):
        out[i] = _rotate(q[i], out[i].copy())


def test_a_torque_that_does_not_derive_from_the_given_potential_is_refused():
    """The docs define the torque as minus the potential's derivative under a rotation of
    each body in its own frame. A sign error, or the torque in the space frame, ran
    (only the end-of-run energy check could hint at it); both are refused at the start,
    from central differences of V along one rotation of all bodies. The right torque,
    the dipole lattice's, and a torque without a potential run."""
    scene, q0, L0 = _system(4, seed=51)
    body = liebody.RigidBody.batch(scene.moments, check_triangle=False)
    for wrong in (_flipped_torque, _space_frame_torque):
        bad = CoupledBodies(body, wrong, heisenberg_potential, params=scene.params)
        with pytest.raises(ValueError, match="does not derive from the potential"):
            liebody.integrate(bad, q0=q0, L0=L0, dt=0.01, steps=10)
        liebody.integrate(CoupledBodies(body, wrong, params=scene.params), q0=q0, L0=L0,
                          dt=0.01, steps=10)  # (no potential: nothing to check against)
    liebody.integrate(scene, q0=q0, L0=L0, dt=0.01, steps=10)
    from test_coupled import _lattice

    lat, q, *_ = _lattice(n=8, cutoff=1.5)
    liebody.integrate(lat, q0=q, L0=np.zeros(3), dt=0.01, steps=10)
