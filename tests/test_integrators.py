"""Free-body integrators, by tier: registry, verification (orders), geometry, failure.

Every registered method is exercised by the generic tests, so a new method is
tested the moment it is registered. References are independent: the exact flow
(itself checked against DOP853 at rtol 1e-13 in test_exact_flow.py), invariants,
and closed forms.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

import liebody
from conftest import HLW_L0, PHYSICAL_L0, hlw_body, physical_body, rotation_distance
from liebody import registry

STEPPERS = [m.name for m in liebody.methods() if m.family != "exact"]
GEOMETRIC = [m.name for m in liebody.methods() if m.symplectic or m.family == "rattle"]
BASELINES = [m.name for m in liebody.methods() if m.family == "baseline"]


def _drive(run, plan, h, n, state, q_out, m_out, torque_fn=None):
    """Call the driver kernel directly (t0 = 0, save every step)."""
    from liebody._kernels.torque import no_torque

    return run(plan.kinds, plan.axes, plan.coefs, plan.clock, plan.params, h, 0.0, n, 1,
               plan.merge_ends, state, q_out, m_out, torque_fn or no_torque)


# ------------------------------------------------------------------------------ registry


def test_registry_public_names():
    names = set(liebody.methods().names())
    assert {"splitting2", "sr2", "rattle", "splitting4", "splitting6", "splitting8", "exact",
            "euler", "rk4", "lie_euler", "rkmk4"} <= names


@pytest.mark.parametrize("name", sorted(registry.COMPOSITIONS))
def test_composition_tables_palindromic_consistent(name):
    g = np.array(registry.COMPOSITIONS[name])
    np.testing.assert_array_equal(g, g[::-1])
    assert abs(g.sum() - 1.0) < 1e-15
    if len(g) > 1:  # order >= 4 needs the cubic condition
        assert abs(np.sum(g**3)) < 1e-15


def test_methods_table_reads_the_registry():
    table = liebody.methods()
    text = str(table)
    for m in table:
        assert m.name in text
        assert m.order >= 1
        if m.family == "composition":
            assert m.coefficients in registry.COMPOSITIONS.values()
            assert m.symplectic and m.reversible
    assert table["rattle"].keeps_energy and not table["rk4"].keeps_casimir
    with pytest.raises(KeyError):
        table["nope"]


def test_splitting2_stage_table_has_merged_ends(hlw):
    scene, L0 = hlw
    plan = registry.plan(registry.get("splitting2"), scene, L0, 0.1)
    assert plan.n_stages == 5 and plan.merge_ends
    np.testing.assert_allclose(plan.coefs, [0.5, 0.5, 1.0, 0.5, 0.5])
    # compositions merge adjacent half rotations: 4 s + 1 stages
    for name, s in (("splitting4", 5), ("splitting6", 9), ("splitting8", 17)):
        p = registry.plan(registry.get(name), scene, L0, 0.1)
        assert p.n_stages == 4 * s + 1 and abs(p.coefs.sum() - 3.0) < 1e-12


def test_ordering_choice_matches_literature_and_is_recorded(hlw):
    """HLW body: 2-1-3-1-2 has the smallest energy error constant.

    The leading modified-Hamiltonian term H3 varies least over the orbit for this
    ordering (about 30x less than for the worst one); that the ordering matters is
    Fassò's observation (J. Comput. Phys. 189 (2003) 527).
    """
    scene, L0 = hlw
    tr = liebody.integrate(scene, L0=L0, dt=0.1, steps=10, method="splitting2")
    assert tr.info["axis_ordering"] == (1, 0, 2)


def test_modified_hamiltonian_closed_form():
    """The generic nested-BCH H3 equals its closed form for seq 1-2-3-2-1.

    The closed form was derived symbolically (symmetric BCH formula, bracket
    {F, G}(m) = -m . (grad F x grad G)), independently of liebody._modified.
    """
    from liebody._modified import h3

    I1, I2, I3 = 0.6, 0.8, 1.0
    m = np.random.default_rng(0).normal(size=(20, 3))
    pieces = [np.eye(3)[k] / (I1, I2, I3)[k] for k in range(3)]
    c12 = -I3 * (I1**2 - 2 * I1 * I2 + 2 * I1 * I3 + I2**2 - I2 * I3)
    c13 = I2 * (2 * I1**2 - 2 * I1 * I2 + 2 * I1 * I3 + I2 * I3 - I3**2)
    c23 = -I1 * (2 * I1 * I2 - I1 * I3 - 2 * I2**2 + 4 * I2 * I3 - 2 * I3**2)
    m1, m2, m3 = (m**2).T
    ref = (c12 * m1 * m2 + c13 * m1 * m3 + c23 * m2 * m3) / (24 * I1**2 * I2**2 * I3**2)
    np.testing.assert_allclose(h3(pieces, m), ref, rtol=1e-12)


@pytest.mark.parametrize("moments", [(2.0, 1.0, 2.0 / 3.0), (0.345, 0.653, 1.0), (1.0, 1.0, 2.0)])
def test_energy_error_constant_is_the_exact_range_on_the_orbit(moments):
    """The 3-point quadratic range equals dense sampling of H3 over the orbit's segment."""
    from liebody._modified import energy_error_constant, h3, orbit_samples

    m0 = np.array([1.8, 0.4, -0.9])
    for order in registry._ORDERINGS:
        pieces = registry._axis_pieces(np.array(moments), order)
        dense = h3(pieces, orbit_samples(moments, m0, 4001))
        assert abs(energy_error_constant(pieces, moments, m0) - np.ptp(dense)) < (
            1e-6 * np.ptp(dense) + 1e-15)


def test_energy_error_matches_modified_hamiltonian_prediction(hlw):
    """max |dT| over a run ~ h^2 * (range of H3 on the orbit) for every ordering."""
    scene, L0 = hlw
    h = 0.02
    for order in [(0, 1, 2), (1, 0, 2), (2, 1, 0)]:
        pieces = registry._axis_pieces(scene.moments, order)
        from liebody._modified import energy_error_constant

        predicted = h * h * energy_error_constant(pieces, scene.moments, L0)
        plan = registry._table(registry._axis_stages(scene.moments, order))
        from liebody._kernels.driver import run

        n = 20000
        q_out, m_out = np.empty((n, 4)), np.empty((n, 3))
        state = np.concatenate([[1.0, 0, 0, 0], L0])
        _drive(run, plan, h, n, state, q_out, m_out)
        T = 0.5 * np.sum(m_out**2 / scene.moments, axis=1)
        observed = T.max() - T.min()
        # the O(h^4) remainder of the modified Hamiltonian is ~h^2 smaller: 2 % is ample
        assert abs(observed - predicted) < 0.02 * predicted


# -------------------------------------------------------------------------- verification


def _final_error(scene, L0, method, h, t_end):
    ref = liebody.integrate(scene, L0=L0, dt=t_end, steps=1)  # exact flow
    tr = liebody.integrate(scene, L0=L0, dt=h, t_end=t_end, method=method, save_every=10**9)
    scale = np.linalg.norm(L0)
    return max(np.abs(tr.L[-1] - ref.L[-1]).max() / scale,
               rotation_distance(tr.q[-1], ref.q[-1]))


@pytest.mark.parametrize("body", ["hlw", "physical"])
@pytest.mark.parametrize("name", STEPPERS)
def test_observed_order_matches_declared(name, body):
    """Log-log slope of the final error against the exact flow equals the declared order.

    A ladder of halved steps; the slope is read from the two smallest steps whose
    error is still well above round-off (1e-11) and below 1e-2 (asymptotic range).
    """
    scene = liebody.FreeBody(hlw_body() if body == "hlw" else physical_body())
    L0 = HLW_L0 if body == "hlw" else PHYSICAL_L0
    method = liebody.methods()[name]
    t_end = 4.0
    h0 = {1: 0.02, 2: 0.2, 4: 0.4, 6: 0.8, 8: 1.0, 10: 1.0}[int(method.order)]
    if method.family == "rattle":  # DMV's implicit equation needs h|omega| below ~1
        h0 = min(h0, 0.7 / np.abs(L0 / scene.moments).max())
    h0 = t_end / np.ceil(t_end / h0)  # a whole number of steps
    hs = h0 / 2.0 ** np.arange(6)
    errs = np.array([_final_error(scene, L0, name, h, t_end) for h in hs])
    floor = 1e-12 if method.order >= 10 else 1e-11  # the exact-flow reference: ~1e-15
    ok = np.flatnonzero((errs > floor) & (errs < 1e-2))
    assert len(ok) >= 2 and ok[-1] - ok[-2] == 1, errs
    i, j = ok[-2], ok[-1]
    slope = np.log(errs[i] / errs[j]) / np.log(hs[i] / hs[j])
    assert abs(slope - method.order) < 0.3, (errs, slope)


# ------------------------------------------------------------------------------ geometry


def _kernel_run(name, scene, L0, h, n, q0=(1.0, 0.0, 0.0, 0.0)):
    from liebody._kernels.driver import run

    plan = registry.plan(registry.get(name), scene, L0, abs(h))
    q_out, m_out = np.empty((n, 4)), np.empty((n, 3))
    state = np.concatenate([q0, L0]).astype(float)
    _drive(run, plan, h, n, state, q_out, m_out)
    return state, q_out, m_out


@pytest.mark.kernel
@pytest.mark.parametrize("name", [m.name for m in liebody.methods()
                                  if m.reversible and m.family != "exact"])
def test_symmetric_methods_are_time_reversible(name, hlw):
    scene, L0 = hlw
    q0 = liebody.quaternion.random(rng=3)
    fwd, _, _ = _kernel_run(name, scene, L0, 0.1, 7, q0=q0)
    back, _, _ = _kernel_run(name, scene, fwd[4:], -0.1, 7, q0=fwd[:4])
    np.testing.assert_allclose(back[4:], L0, atol=1e-14, rtol=0)
    assert rotation_distance(back[:4], q0) < 1e-14


@pytest.mark.kernel
@pytest.mark.parametrize("name", ["rk4", "euler", "lie_euler", "rkmk4"])
def test_baselines_are_not_reversible(name, hlw):
    scene, L0 = hlw
    fwd, _, _ = _kernel_run(name, scene, L0, 0.1, 7)
    back, _, _ = _kernel_run(name, scene, fwd[4:], -0.1, 7, q0=fwd[:4])
    assert np.abs(back[4:] - L0).max() > 1e-9


def _poisson_defect(name, scene, L, h):
    """max |J B(L) J^T - B(L')| for the map L -> L' of one step (central differences)."""

    def step(Lv):
        return _kernel_run(name, scene, Lv, h, 1)[0][4:]

    eps = 1e-6
    J = np.empty((3, 3))
    for k in range(3):
        d = np.zeros(3)
        d[k] = eps
        J[:, k] = (step(L + d) - step(L - d)) / (2 * eps)

    def hat(v):
        return np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])

    return np.abs(J @ hat(L) @ J.T - hat(step(L))).max()


@pytest.mark.parametrize("name", [m.name for m in liebody.methods() if m.symplectic
                                  and m.family != "exact"] + ["dmv4", "dmv6", "lie_euler", "rkmk4"])
def test_lie_poisson_property(name, hlw):
    """Lie–Poisson maps keep B(L) = hat(L): J B(L) J^T = B(L'). The coadjoint baselines stay on
    the sphere |L| = const but are not Poisson maps."""
    scene, L0 = hlw
    defect = _poisson_defect(name, scene, L0, 0.5)  # finite differences resolve ~1e-10
    if name in ("lie_euler", "rkmk4"):
        assert defect > 1e-6  # on the coadjoint orbit, but not Poisson maps
    else:
        assert defect < 1e-9


def test_rk4_is_not_lie_poisson(hlw):
    scene, L0 = hlw
    assert _poisson_defect("rk4", scene, L0, 0.5) > 1e-6


@pytest.mark.long
@pytest.mark.parametrize("name", GEOMETRIC)
def test_long_run_invariants_geometric(name, hlw):
    """1e6 steps, no renormalisation: |L|, L_space, |q| to 1e-12; energy bounded."""
    scene, L0 = hlw
    n = 1_000_000
    method = liebody.methods()[name]
    # a step whose energy error is well above round-off, so boundedness is a method property
    h = 0.05 if method.keeps_energy else {2: 0.05, 4: 0.2, 6: 0.4, 8: 0.6}[method.order]
    tr = liebody.integrate(scene, L0=L0, dt=h, steps=n, method=name, save_every=1000)
    np.testing.assert_allclose(tr.casimir, 1.0, atol=1e-12, rtol=0)
    np.testing.assert_allclose(tr.quaternion_norm, 1.0, atol=1e-12, rtol=0)
    Ls = tr.L_space
    assert np.abs(Ls - Ls[0]).max() < 1e-12
    dE = np.abs(tr.energy - tr.energy[0])
    tenth = len(dE) // 10
    first, last = dE[1:tenth].max(), dE[-tenth:].max()
    if tr.method.keeps_energy:
        assert dE.max() < 1e-12
    else:
        assert first > 1e-10  # truncation error, not round-off, is being measured
        # bounded: no secular growth (1e-12 allows the round-off random walk of 1e6 steps)
        assert last <= 1.5 * first + 1e-12, (first, last)


@pytest.mark.long
def test_long_run_baselines_drift(hlw):
    scene, L0 = hlw
    h = 0.05
    n = 100_000
    for name in ("rk4", "rkmk4"):
        tr = liebody.integrate(scene, L0=L0, dt=h, steps=n, method=name, save_every=100)
        dE = np.abs(tr.energy - tr.energy[0])
        tenth = len(dE) // 10
        assert dE[-tenth:].max() > 5 * dE[1:tenth].max(), name  # secular drift
    # Lie-Euler drives L to the maximum-energy (smallest-moment) axis: T -> |L|^2 / (2 I_min)
    tr = liebody.integrate(scene, L0=L0, dt=h, steps=n, method="lie_euler", save_every=100)
    T_max = 0.5 * (L0 @ L0) / scene.moments.min()
    assert abs(tr.energy[-1] - T_max) < 1e-6 * T_max
    assert abs(tr.energy[0] - T_max) > 0.1
    tr = liebody.integrate(scene, L0=L0, dt=h, steps=n, method="rk4", save_every=100)
    assert abs(tr.casimir[-1] - 1.0) > 1e-9 and abs(tr.quaternion_norm[-1] - 1.0) > 1e-9


# -------------------------------------------------------------------------- failure modes


def test_explicit_euler_blow_up_returns_partial_trajectory(hlw):
    scene, L0 = hlw
    with pytest.warns(RuntimeWarning, match="non-finite"):
        tr = liebody.integrate(scene, L0=L0 * 1e3, dt=0.5, steps=10_000, method="euler")
    assert tr.failed_at is not None and 0 < tr.failed_at <= 0.5 * 10_000
    assert np.all(np.isfinite(tr.q)) and np.all(np.isfinite(tr.L))
    assert len(tr) == round(tr.failed_at / 0.5)  # every sample before the failing step
    assert tr.t[-1] < tr.failed_at


def test_euler_energy_grows_monotonically(hlw):
    scene, L0 = hlw
    tr = liebody.integrate(scene, L0=L0, dt=0.1, steps=100, method="euler")
    assert np.all(np.diff(tr.energy) > 0) and np.all(np.diff(tr.casimir) > 0)
    assert np.all(np.diff(tr.quaternion_norm) > 0)


def test_rattle_nonconvergence_raises(hlw):
    scene, L0 = hlw
    with pytest.raises(liebody.ConvergenceError, match="reduce dt"):
        liebody.integrate(scene, L0=L0 * 1e4, dt=10.0, steps=50, method="rattle")


# ----------------------------------------------------------------------- API and sampling


def test_save_every_memory_and_times(hlw):
    scene, L0 = hlw
    tr = liebody.integrate(scene, L0=L0, dt=0.01, steps=1003, save_every=100,
                           method="splitting2")
    assert tr.q.shape == (12, 4) and tr.L.shape == (12, 3)
    np.testing.assert_allclose(tr.t, np.r_[np.arange(11) * 1.0, 10.03])
    full = liebody.integrate(scene, L0=L0, dt=0.01, steps=1003, method="splitting2")
    # merged end stages are undone at save points: the same samples as saving every step,
    # up to the rounding of merged angles accumulated over 1000 steps (an error in the
    # bookkeeping would show at the size of the h^2 splitting error, ~1e-5)
    np.testing.assert_allclose(tr.L, full.L[np.r_[np.arange(11) * 100, 1003]], atol=1e-13,
                               rtol=0)


def test_progress_runs_in_chunks_with_identical_result(hlw):
    scene, L0 = hlw
    a = liebody.integrate(scene, L0=L0, dt=0.01, steps=5000, save_every=7, method="sr2")
    b = liebody.integrate(scene, L0=L0, dt=0.01, steps=5000, save_every=7, method="sr2",
                          progress=True)
    np.testing.assert_allclose(a.L, b.L, atol=1e-15, rtol=0)
    np.testing.assert_allclose(a.q, b.q, atol=1e-15, rtol=0)


def test_omega0_and_L0_agree(physical):
    scene, L0 = physical
    a = liebody.integrate(scene, L0=L0, dt=0.1, steps=10, method="splitting2")
    b = liebody.integrate(scene, omega0=L0 / scene.moments, dt=0.1, steps=10,
                          method="splitting2")
    np.testing.assert_allclose(a.L, b.L, atol=1e-15, rtol=0)
    np.testing.assert_allclose(a.omega * scene.moments, a.L, atol=1e-15, rtol=0)


def test_exact_flow_with_progress_bar_gives_the_same_samples(hlw):
    scene, L0 = hlw
    a = liebody.integrate(scene, L0=L0, dt=0.1, steps=500)
    b = liebody.integrate(scene, L0=L0, dt=0.1, steps=500, progress=True)
    np.testing.assert_array_equal(a.q, b.q)
    np.testing.assert_array_equal(a.L, b.L)


def test_default_method_is_exact_for_free_body(hlw):
    scene, L0 = hlw
    tr = liebody.integrate(scene, L0=L0, dt=0.5, t_end=100.0)
    assert tr.method.name == "exact"
    assert np.abs(tr.energy - tr.energy[0]).max() < 1e-14
    assert np.abs(tr.L_space - tr.L_space[0]).max() < 1e-13


def test_trajectory_derived_quantities(hlw):
    """Derived quantities against independent routes: rotation matrices and scipy."""
    from scipy.spatial.transform import Rotation

    scene, L0 = hlw
    q0 = liebody.quaternion.random(rng=4)
    tr = liebody.integrate(scene, q0=q0, L0=L0, dt=0.1, steps=20, method="splitting2")
    R = Rotation.from_quat(liebody.quaternion.to_scipy(tr.q)).as_matrix()
    np.testing.assert_allclose(tr.L_space, np.einsum("nij,nj->ni", R, tr.L), atol=1e-14,
                               rtol=0)
    np.testing.assert_allclose(tr.omega_space, np.einsum("nij,nj->ni", R, tr.L / scene.moments),
                               atol=1e-14, rtol=0)
    np.testing.assert_allclose(tr.energy, 0.5 * np.sum(tr.L * tr.omega, axis=1), rtol=1e-15)
    angles = tr.euler_angles()
    ref = Rotation.from_quat(liebody.quaternion.to_scipy(tr.q)).as_euler("ZXZ")
    # scipy's ZXZ angles: theta in [0, pi]; compare the rotations they stand for
    assert np.all((angles[:, 1] >= 0) & (angles[:, 1] <= np.pi))
    np.testing.assert_allclose(Rotation.from_euler("ZXZ", angles).as_matrix(),
                               Rotation.from_euler("ZXZ", ref).as_matrix(), atol=1e-14, rtol=0)
    np.testing.assert_allclose(angles, ref, atol=1e-12, rtol=0)
    assert "splitting2" in repr(tr)


@pytest.mark.parametrize(
    ("kwargs", "exc", "match"),
    [
        ({"q0": (1.0, 0.1, 0.0, 0.0)}, ValueError, "q0 must be a unit quaternion.*normalize"),
        ({"L0": None}, ValueError, "exactly one of L0"),
        ({"omega0": (1.0, 0.0, 0.0)}, ValueError, "exactly one of L0"),
        ({"dt": 0.0}, ValueError, "dt must be > 0"),
        ({"dt": -0.1}, ValueError, "dt must be > 0"),
        ({"dt": math.nan}, ValueError, "dt must be finite"),
        ({"L0": (1.0, math.inf, 0.0)}, ValueError, "L0 must be finite"),
        ({"L0": (1.0, 0.0)}, ValueError, r"L0 must have shape \(3,\)"),
        ({"steps": 0}, ValueError, "steps must be a positive integer"),
        ({"steps": 2.5}, ValueError, "steps must be a positive integer"),
        ({"steps": None, "t_end": 1.05}, ValueError, "t_end must be a whole number of steps"),
        ({"steps": None}, ValueError, "exactly one of steps and t_end"),
        ({"t_end": 1.0}, ValueError, "exactly one of steps and t_end"),
        ({"method": "leapfrog"}, ValueError,
         r"unknown method 'leapfrog'; known methods: .*rattle"),
        ({"method": 3}, TypeError, "method must be a method name"),
        ({"save_every": 0}, ValueError, "save_every must be a positive integer"),
        ({"dt": 1e-300, "steps": None, "t_end": 1.0}, ValueError, "raise save_every"),
        ({"progress": "no"}, TypeError, "progress must be True or False"),
    ],
)
def test_bad_input(kwargs, exc, match, hlw):
    scene, L0 = hlw
    args = {"L0": L0, "dt": 0.1, "steps": 10}
    args.update(kwargs)
    with pytest.raises(exc, match=match):
        liebody.integrate(scene, **args)


def test_bad_scene():
    with pytest.raises(TypeError, match="scene must be"):
        liebody.integrate("body", L0=(1, 0, 0), dt=0.1, steps=1)
    with pytest.raises(TypeError, match=r"body must be a liebody\.RigidBody"):
        liebody.FreeBody([1.0, 2.0, 3.0])


def test_no_warning_for_healthy_runs(hlw):
    scene, L0 = hlw
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for name in STEPPERS:
            liebody.integrate(scene, L0=L0, dt=0.05, steps=100, method=name)


def test_driver_loop_allocates_nothing(hlw):
    """The compiled driver contains no heap allocation (NRT_MemInfo_alloc*/NRT_Allocate).

    The driver is recompiled without the disk cache (cached code cannot be inspected),
    and a function that does allocate shows the pattern is found when present.
    """
    import os
    import re

    import numba

    if os.environ.get("NUMBA_DISABLE_JIT") == "1":
        pytest.skip("needs the compiled kernel")
    from liebody._kernels.driver import run

    pattern = re.compile(r"NRT_MemInfo_alloc\w*|NRT_Allocate\w*")

    @numba.njit
    def allocates(n):
        return np.empty(n).sum()

    allocates(3)
    assert all(pattern.search(ir) for ir in allocates.inspect_llvm().values())

    fresh = numba.njit(run.py_func)
    scene, L0 = hlw
    for name in ("splitting2", "sr2", "rattle", "rk4"):
        plan = registry.plan(registry.get(name), scene, L0, 0.1)
        state = np.concatenate([[1.0, 0.0, 0.0, 0.0], L0])
        _drive(fresh, plan, 0.1, 3, state, np.empty((3, 4)), np.empty((3, 3)))
    irs = fresh.inspect_llvm()
    assert irs
    for ir in irs.values():
        assert "define" in ir and not pattern.search(ir)


def test_a_billion_steps_keep_only_the_saved_samples(hlw):
    """1e9 steps saved every 1e6 hold 1001 samples (the exact flow needs no stepping)."""
    scene, L0 = hlw
    tr = liebody.integrate(scene, L0=L0, dt=1e-3, steps=10**9, save_every=10**6)
    assert tr.q.shape == (1001, 4) and tr.L.shape == (1001, 3) and tr.t.shape == (1001,)
    assert tr.t[-1] == 1e6
    assert np.abs(tr.energy - tr.energy[0]).max() < 1e-13
    assert np.abs(tr.L_space - tr.L_space[0]).max() < 1e-12


@pytest.mark.parametrize("moments", [(1.0, 1.0, 2.0), (3.0, 2.0, 3.0), (1.5, 1.5, 1.5)])
def test_sr2_is_exact_for_symmetric_bodies(moments):
    """For a symmetric (or spherical) body SR2's correction rotation vanishes: at any step,
    even h|omega| ~ 1, it reproduces the exact flow to round-off."""
    scene = liebody.FreeBody(liebody.RigidBody(moments))
    L0 = np.array([0.7, -0.4, 1.1])
    q0 = liebody.quaternion.random(rng=11)
    tr = liebody.integrate(scene, q0=q0, L0=L0, dt=0.8, steps=50, method="sr2")
    ref = liebody.integrate(scene, q0=q0, L0=L0, dt=0.8, steps=50)
    assert np.abs(tr.L - ref.L).max() < 1e-13
    assert rotation_distance(tr.q, ref.q).max() < 1e-13
    axis_split = liebody.integrate(scene, q0=q0, L0=L0, dt=0.8, steps=50, method="splitting2")
    if len(set(moments)) > 1:
        assert np.abs(axis_split.L - ref.L).max() > 1e-4  # the 5-rotation splitting is not


@pytest.mark.parametrize(("name", "scale", "dt"), [("rattle", 1.0, 0.6), ("rattle", 2.0, 0.35),
                                                   ("dmv4", 1.0, 0.7), ("dmv6", 1.0, 0.6)])
def test_implicit_methods_converge_at_large_moderate_steps(name, scale, dt, hlw):
    """h|omega| up to ~0.95: the DMV equation has its physical root and it is found (the
    fixed point alone stalls or diverges there); energy stays exact."""
    scene, L0 = hlw
    tr = liebody.integrate(scene, L0=scale * L0, dt=dt, steps=3000, method=name)
    assert dt * np.linalg.norm(scale * L0 / scene.moments) > 0.8
    assert np.abs(tr.energy - tr.energy[0]).max() < 1e-13 * tr.energy[0] * scale


def test_dmv_kernel_finds_roots_the_fixed_point_misses():
    """A case where Gauss-Seidel diverges: the root found solves the equation to rounding."""
    from liebody._kernels.flows import _dmv_residual, dmv_step

    I = np.array([0.5302758, 2.84320303, 1.15931761])
    m = np.array([0.10168855, -0.62317829, -1.65738965])
    h = 0.8207302663804338
    out = dmv_step(1.0, 0.0, 0.0, 0.0, *m, *I, h)
    assert out[7] > 0
    # recover c from the increment q = (1, c)/sqrt(1 + |c|^2) and check the equation
    c = np.array(out[1:4]) / out[0]
    a = 0.5 * h * m / I
    f = ((I[1] - I[2]) / I[0], (I[2] - I[0]) / I[1], (I[0] - I[1]) / I[2])
    assert np.abs(_dmv_residual(*c, *a, *f)).max() < 1e-14
    assert abs(np.linalg.norm(out[4:7]) - np.linalg.norm(m)) < 1e-15


def test_dmv4_rejects_steps_that_make_its_moments_negative(hlw):
    scene, L0 = hlw
    with pytest.raises(ValueError, match="dt = 2 is too large for dmv4"):
        liebody.integrate(scene, L0=L0, dt=2.0, steps=3, method="dmv4")
