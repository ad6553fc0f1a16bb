"""Sampled orbits (``liebody.orbits.Table``) against the Kepler orbits they sample.

References: the Kepler orbit's own position (Kepler's equation solved to round-off,
checked in test_gravity_gradient.py); runs of the gravity-gradient scene with the Kepler
orbit itself; the interpolation error measured on a dense grid of times.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import liebody
from liebody.errors import TorqueError
from liebody.orbits import Circular, Kepler, Table
from liebody.testing import observed_order

KEPLER = Kepler(a=3.0, e=0.3, GM=1.0, i=0.4, raan=0.3, argp=1.0, M0=0.2)
CIRCLE = Circular(n=0.05, radius=10.0, inclination=0.2, raan=0.1, phase=0.3)
MOMENTS = [1.0, 1.7, 2.6]
L0 = [0.4, -1.1, 2.0]


def _table(orbit, t0, t1, m, points=4, uneven=0.0, seed=0):
    """``orbit`` sampled at ``m + 1`` times over ``[t0, t1]`` (moved by up to ``uneven``
    of the spacing at random, the ends kept)."""
    t = np.linspace(t0, t1, m + 1)
    if uneven:
        rng = np.random.default_rng(seed)
        t[1:-1] += rng.uniform(-uneven, uneven, m - 1) * (t[1] - t[0])
    return Table(t, orbit.position(t), points=points)


def _true_error(table, orbit, n=200_001):
    lo, hi = table.span
    td = np.linspace(lo, hi, n)
    return float(np.max(np.linalg.norm(table.position(td) - orbit.position(td), axis=1)))


# ------------------------------------------------------------------ interpolation
@pytest.mark.parametrize("points", [4, 6])
def test_observed_order_of_the_interpolation(points):
    """The error falls as ``h^points`` when the spacing is halved (observed order)."""
    T = 2.0 * KEPLER.period

    def error(n):
        return _true_error(_table(KEPLER, 0.0, T, n, points), KEPLER, 20_001)

    order = observed_order(error=error, t_end=T, h_max=T / 40, floor=1e-12, ceiling=1e-2,
                           levels=6)
    assert order.order >= points - 0.2, (order.order, order.errors)
    assert order.order <= points + 0.6  # an interpolant of degree points - 1


def test_interpolant_passes_through_the_samples_and_is_continuous():
    tab = _table(KEPLER, 0.0, 20.0, 60, uneven=0.3)
    np.testing.assert_array_equal(tab.position(tab.t), tab.r)
    # across a sample, from either side, the value tends to the sample
    for i in (1, 30, 59):
        ti = tab.t[i]
        left = tab.position(np.nextafter(ti, -np.inf))
        right = tab.position(np.nextafter(ti, np.inf))
        np.testing.assert_allclose(left, tab.r[i], rtol=1e-12)
        np.testing.assert_allclose(right, tab.r[i], rtol=1e-12)


@pytest.mark.parametrize("e", [0.0, 0.3, 0.6])
@pytest.mark.parametrize("points", [4, 6])
@pytest.mark.parametrize("uneven", [0.0, 0.3])
def test_error_estimate_bounds_the_error_and_is_not_pessimistic(e, points, uneven):
    orbit = Kepler(a=2.0, e=e, GM=1.0, i=0.5, raan=0.2, argp=0.9, M0=0.4)
    ratios = []
    for m in (120, 480):
        tab = _table(orbit, -1.0, 2.0 * orbit.period, m, points, uneven)
        err = _true_error(tab, orbit)
        assert err <= tab.error_estimate, (m, err, tab.error_estimate)
        assert tab.error_estimate <= 100.0 * err, (m, err, tab.error_estimate)
        ratios.append(tab.error_estimate / err)
    assert max(ratios) < 10.0  # measured: 1.3 .. 2.7


def test_error_estimate_counts_rounding_when_the_samples_are_exact_enough():
    """A straight line is interpolated exactly up to rounding: the estimate is the rounding
    term (a few ulps of |r|), not zero, and not more."""
    t = np.linspace(0.0, 10.0, 41)
    r = np.column_stack([1.0 + 0.5 * t, 2.0 - t, 3.0 + 0.0 * t])
    tab = Table(t, r)
    scale = np.max(np.abs(r))
    assert 0.0 < tab.error_estimate <= 1e-13 * scale
    td = np.linspace(0.0, 10.0, 1001)
    exact = np.column_stack([1.0 + 0.5 * td, 2.0 - td, 3.0 + 0.0 * td])
    assert np.max(np.linalg.norm(tab.position(td) - exact, axis=1)) <= tab.error_estimate


def test_min_distance_is_a_tight_lower_bound():
    tab = _table(KEPLER, 0.0, 2.0 * KEPLER.period, 200)
    lo, hi = tab.span
    d = np.linalg.norm(tab.position(np.linspace(lo, hi, 400_001)), axis=1)
    assert tab.min_distance <= d.min()
    assert tab.min_distance >= 0.95 * KEPLER.a * (1.0 - KEPLER.e)


def test_python_position_agrees_with_the_kernel_and_keeps_shapes():
    from liebody._models import orbit

    tab = _table(KEPLER, 0.0, 10.0, 50)
    t = np.array([[0.0, 3.3], [7.25, 10.0]])
    out = tab.position(t)
    assert out.shape == (2, 2, 3)
    for idx in np.ndindex(t.shape):
        assert tuple(out[idx]) == orbit.position(tab.row, 0, float(t[idx]))
    assert tab.position(4.0).shape == (3,)


def test_times_outside_the_table_are_errors_naming_the_time():
    tab = _table(KEPLER, 0.0, 10.0, 50)
    with pytest.raises(ValueError, match=r"t = 10\.5 is outside the table's times \[0\.0, "
                                         r"10\.0\]"):
        tab.position(10.5)
    with pytest.raises(ValueError, match=r"t = -0\.25 is outside"):
        tab.position([1.0, -0.25, 2.0])
    with pytest.raises(ValueError, match=r"t = nan is outside"):
        tab.position(math.nan)
    from liebody._models import orbit

    for t in (-1e-9, 10.0 + 1e-9, math.nan, math.inf):
        assert all(math.isnan(v) for v in orbit.position(tab.row, 0, t))
    assert tab.span == (0.0, 10.0)


def test_bisection_on_uneven_times_finds_every_interval():
    """Times bunched at one end: the guessed interval is far off, the bisection finds it."""
    t = np.concatenate([np.linspace(0.0, 1.0, 200), np.linspace(1.5, 100.0, 20)])
    r = np.column_stack([np.cos(t / 50.0), np.sin(t / 50.0), 1.0 + 0.0 * t]) * 5.0
    tab = Table(t, r)
    from liebody._models import orbit

    for k in range(t.size - 1):
        mid = 0.5 * (t[k] + t[k + 1])
        assert orbit.table_interval(tab.row, 0, mid) == k
        assert orbit.table_interval(tab.row, 0, t[k]) in (k - 1, k)
    np.testing.assert_allclose(tab.position(50.0), 5.0 * np.array(
        [math.cos(1.0), math.sin(1.0), 1.0]), rtol=1e-3)


# ------------------------------------------------------------------ bad input
@pytest.mark.parametrize("make, error, match", [
    (lambda: Table([0.0, 1.0, 1.0, 2.0, 3.0, 4.0], np.ones((6, 3))), ValueError,
     r"t must be strictly increasing: t\[2\] = 1\.0 does not exceed t\[1\] = 1\.0"),
    (lambda: Table([0.0, 2.0, 1.0, 3.0, 4.0, 5.0], np.ones((6, 3))), ValueError,
     r"strictly increasing: t\[2\]"),
    (lambda: Table([0.0, 1.0, math.nan, 3.0, 4.0], np.ones((5, 3))), ValueError,
     r"t must be finite"),
    (lambda: Table(np.arange(6.0), np.ones((6, 2))), ValueError,
     r"r must have shape \(m, 3\) = \(6, 3\)"),
    (lambda: Table(np.arange(6.0), np.ones((5, 3))), ValueError,
     r"r must have shape \(m, 3\) = \(6, 3\), one position per time, got \(5, 3\)"),
    (lambda: Table(np.arange(6.0).reshape(2, 3), np.ones((6, 3))), ValueError,
     r"t must be one-dimensional"),
    (lambda: Table(np.arange(6.0), np.where(np.eye(6, 3) > 0, np.inf, 1.0)), ValueError,
     r"r must be finite \(no NaN or inf\): r\[0\] = \[inf, 1\.0, 1\.0\] at t = 0\.0"),
    (lambda: Table(np.arange(4.0), np.ones((4, 3))), ValueError,
     r"at least points \+ 1 = 5 samples .* got 4"),
    (lambda: Table(np.arange(6.0), np.ones((6, 3)), points=6), ValueError,
     r"at least points \+ 1 = 7 samples"),
    (lambda: Table(np.arange(6.0), np.ones((6, 3)), points=5), ValueError,
     r"points must be 4, 6 or 8"),
    (lambda: Table(np.arange(6.0), np.ones((6, 3)), points=4.0), TypeError,
     r"points must be an integer"),
    (lambda: Table(np.arange(6.0), np.ones((6, 3)), points=True), TypeError,
     r"points must be an integer"),
    (lambda: Table(np.arange(6.0) + 0j, np.ones((6, 3))), TypeError, r"t must contain real"),
    (lambda: Table(np.arange(6.0), np.full((6, 3), "a")), TypeError, r"r must contain real"),
    (lambda: Table(np.arange(6.0), np.vstack([np.ones((3, 3)), np.zeros(3), np.ones((2, 3))])),
     ValueError, r"r must not vanish .* r\[3\] = 0 at t = 3\.0"),
])
def test_bad_tables_are_refused_by_name(make, error, match):
    with pytest.raises(error, match=match):
        make()


def test_a_table_is_no_conic():
    tab = _table(KEPLER, 0.0, 10.0, 20)
    for name in ("mean_motion", "period", "normal"):
        with pytest.raises(AttributeError, match="a Table has no"):
            getattr(tab, name)
    assert "21 samples" in repr(tab) and "points=4" in repr(tab)
    assert tab == _table(KEPLER, 0.0, 10.0, 20) and hash(tab) == hash(_table(KEPLER, 0.0,
                                                                           10.0, 20))
    assert tab != _table(KEPLER, 0.0, 10.0, 21)
    with pytest.raises(ValueError):
        tab.t[0] = 1.0  # read-only: the kernels' row is built from them


# ------------------------------------------------------------------ in the scene
def _run(sources, moments=MOMENTS, L=L0, free_flow="auto", **kw):
    body = (liebody.RigidBody.batch(moments) if np.ndim(moments) == 2
            else liebody.RigidBody(moments))
    kw = {"dt": 0.02, "steps": 1500, "save_every": 100, "method": "splitting4", **kw}
    return liebody.integrate(liebody.GravityGradient(body, sources, free_flow=free_flow),
                             L0=L, **kw)


def test_run_with_a_table_matches_the_kepler_run_to_the_interpolation_error():
    """The difference from the run with the Kepler orbit itself is the interpolation's:
    it falls 16-fold when the table's spacing is halved (order 4) and is bounded by the
    torque error that the estimate allows, integrated over the run."""
    ref = _run([(1.0, KEPLER), (0.5, CIRCLE)])
    diffs = []
    for m in (150, 300):
        tab = _table(KEPLER, -0.5, 31.0, m)
        run = _run([(1.0, tab), (0.5, CIRCLE)])
        diff = max(np.abs(run.L - ref.L).max(), np.abs(run.q - ref.q).max())
        # |delta tau| <= 5 |delta r| / r_min * |tau|_max, over the run of 30 time units
        bound = 5.0 * tab.error_estimate / tab.min_distance * 3.0 * 1.6 / tab.min_distance**3
        assert 0.0 < diff <= 30.0 * bound * max(1.0, np.abs(ref.L).max()), (m, diff, bound)
        diffs.append(diff)
    assert 10.0 < diffs[0] / diffs[1] < 24.0, diffs


def test_table_and_conic_sources_mix_in_any_order():
    tab = _table(KEPLER, -0.5, 31.0, 300)
    a = _run([(1.0, tab), (0.5, CIRCLE)])
    b = _run([(0.5, CIRCLE), (1.0, tab)])
    np.testing.assert_allclose(a.L, b.L, rtol=0, atol=1e-12)
    np.testing.assert_allclose(a.q, b.q, rtol=0, atol=1e-12)
    c = _run([(0.5, CIRCLE), (1.0, tab), (0.3, _table(CIRCLE, -0.5, 31.0, 200))])
    assert np.abs(c.L - b.L).max() > 1e-6  # the third source acts


def test_ensembles_with_tables_equal_one_body_runs_on_both_paths():
    """Per-body inertia (one parameter row per body, each with the table): the scalar
    ensemble gives each body's one-body numbers bit for bit, the SIMD kernels the same to
    round-off."""
    tab = _table(KEPLER, -0.5, 31.0, 300)
    sources = [(0.5, CIRCLE), (1.0, tab)]
    moments = np.array([[1.0, 1.7, 2.6], [2.0, 2.0, 1.0], [1.5, 0.7, 2.0]])
    L = np.array([[0.4, -1.1, 2.0], [0.1, 0.2, 1.0], [1.0, 0.0, -0.5]])
    # the axis splitting between the kicks, the drift the SIMD kernels run (the default,
    # the elliptic exact flow, runs in the one-body loop)
    scalar = _run(sources, moments, L, "axes", threads=1, simd=False)
    simd = _run(sources, moments, L, "axes", threads=1, simd=True)
    groups = simd.info.get("groups", [simd.info])
    assert all(g["simd"] for g in groups)
    # (the SIMD kernels' polynomial sine and cosine round otherwise: 1500 steps of it)
    np.testing.assert_allclose(simd.q, scalar.q, rtol=0, atol=1e-11)
    np.testing.assert_allclose(simd.L, scalar.L, rtol=0, atol=1e-11)
    for i in range(3):
        one = _run(sources, moments[i], L[i], "axes")
        np.testing.assert_array_equal(scalar.q[i], one.q)
        np.testing.assert_array_equal(scalar.L[i], one.L)
    # a shared body (one row for the ensemble), SIMD against scalar
    s1 = _run(sources, MOMENTS, L, threads=1, simd=False)
    s2 = _run(sources, MOMENTS, L, threads=1, simd=True)
    np.testing.assert_allclose(s2.L, s1.L, rtol=0, atol=1e-11)


def test_torque_bound_holds_for_tables():
    from liebody._models import gravity_gradient

    tab = _table(KEPLER, -0.5, 2.0 * KEPLER.period, 600)  # through the pericentre
    scene = liebody.GravityGradient(liebody.RigidBody(MOMENTS), [(1.0, tab), (0.5, CIRCLE)])
    row, shared = scene.torque_model().row(), scene.torque_model().shared
    bound = gravity_gradient.torque_bound(row, shared)
    kepler_scene = liebody.GravityGradient(liebody.RigidBody(MOMENTS),
                                           [(1.0, KEPLER), (0.5, CIRCLE)])
    kepler_bound = gravity_gradient.torque_bound(kepler_scene.torque_model().row(),
                                                 kepler_scene.torque_model().shared)
    assert kepler_bound <= bound <= 1.2 * kepler_bound  # a table's r_min: a little lower
    rng = np.random.default_rng(3)
    worst = 0.0
    for t in np.linspace(-0.5, 2.0 * KEPLER.period, 300):
        for q in liebody.quaternion.random(8, rng=rng):
            tau = gravity_gradient.torque(t, *q, row, shared)
            worst = max(worst, math.hypot(*tau))
    assert worst <= bound


def test_potential_with_a_table_matches_the_kepler_potential():
    tab = _table(KEPLER, -0.5, 31.0, 300)
    body = liebody.RigidBody(MOMENTS)
    a = liebody.GravityGradient(body, [(1.0, tab)])
    b = liebody.GravityGradient(body, [(1.0, KEPLER)])
    q = liebody.quaternion.random(20, rng=1)
    t = np.linspace(0.0, 30.0, 20)
    Va, Vb = a.potential(q, t), b.potential(q, t)
    r = KEPLER.a * (1 - KEPLER.e)
    np.testing.assert_allclose(Va, Vb, rtol=0, atol=10 * tab.error_estimate / r**4 * 2.6)
    assert np.isnan(a.potential(q[:1], 40.0)).all()


def test_a_run_that_leaves_the_table_stops_there_naming_the_time():
    tab = _table(KEPLER, 0.0, 10.0, 100)
    scene = liebody.GravityGradient(liebody.RigidBody(MOMENTS), [(1.0, tab), (0.5, CIRCLE)])
    assert scene.time_span == (0.0, 10.0)
    assert liebody.GravityGradient(liebody.RigidBody(MOMENTS), [(0.5, CIRCLE)]).time_span == (
        -math.inf, math.inf)
    # the step from t = 10 reaches past the table (the message names the step's times)
    with pytest.raises(TorqueError, match=r"the time t = 10\.0\d* is outside the times "
                       r"\[0, 10\] that the scene's sampled orbits .* in the step from "
                       r"t = 10 to t = 10\.02 \(after 500 steps\)") as info:
        liebody.integrate(scene, L0=L0, dt=0.02, steps=1000, save_every=50,
                          method="splitting2")
    traj = info.value.trajectory
    assert traj.t[-1] <= 10.0 and traj.t[-1] >= 10.0 - 0.02 * 50
    # an ensemble records the failure per body, at the first step that left the table
    with pytest.warns(RuntimeWarning, match="torque failed"):
        ens = liebody.integrate(scene, L0=[L0, L0], dt=0.02, steps=1000, save_every=50,
                                method="splitting2", threads=1)
    assert [f.body for f in ens.failures] == [0, 1]
    for f in ens.failures:
        assert f.reason == "torque failed"
        assert 10.0 < f.t <= 10.0 + 0.02 + 1e-12
    # a run that starts outside it is refused at its first step
    with pytest.raises(TorqueError, match=r"t = 11\b"):
        liebody.integrate(scene, L0=L0, dt=0.02, steps=10, method="splitting2", t0=11.0)


def test_bad_sources_name_table_among_the_orbits():
    with pytest.raises(TypeError, match=r"\(Circular, Kepler, Table\)"):
        liebody.GravityGradient(liebody.RigidBody(MOMENTS), [(1.0, "moon")])
