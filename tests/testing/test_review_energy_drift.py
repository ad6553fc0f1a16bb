"""energy_drift on errors whose law is known by construction, and on real integrators.

Before: the classifier judged 256 and 20 block means of the error, and a pure sinusoid's
block means alias into a slow wander or a smooth line: ``1 + 1e-6 sin(2 pi f t + 0.3)``
on 20,000 samples of ``[0, 1]`` was a random walk at f = 5, 50, 100 and a drift at
f = 300 and 1000 (confidence 1.00, rate 1.5e-11: its own least-squares slope, 1e-5 of its
range, "significant" against the near-zero scatter of aliased block means).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from liebody import testing


def sine(t, periods, phase, amplitude=1e-6):
    """``1 + A sin(2 pi N t / T + phase)``: bounded by construction, ``N`` periods."""
    span = t[-1] - t[0]
    return 1.0 + amplitude * np.sin(2.0 * np.pi * periods * (t - t[0]) / span + phase)


def own_slope_bound(periods, amplitude, span):
    """The largest least-squares slope of ``A sin(2 pi N t / T + phi)`` over ``[0, T]``
    (any phase): ``12 / T^3 |int (t - T/2) sin dt| <= (12 / (2 pi N) + 24 / (2 pi N)^2)
    A / T``, integrating by parts."""
    w = 2.0 * np.pi * periods
    return (12.0 / w + 24.0 / w**2) * amplitude / span


def test_the_reproducer_sines_are_bounded():
    t = np.linspace(0.0, 1.0, 20_000)
    for f in (5, 10, 50, 100, 300, 1000):
        found = testing.energy_drift(t=t, energy=sine(t, f, 0.3))
        assert found.kind == "bounded", (f, found)
        assert 0.0 <= found.confidence <= 1.0 and found.exponent < 0.15, (f, found)
        assert abs(found.cycles - f) <= max(0.6, 0.07 * f), (f, found.cycles)


@pytest.mark.parametrize("n", [2000, 20_000])
def test_sines_of_any_frequency_and_phase_are_bounded(n):
    """Log-uniform numbers of periods from 3.2 to n/3 (3 samples a period), not integers,
    random phases; their cycle count is their number of periods."""
    t = np.linspace(0.0, 1.0, n)
    rng = np.random.default_rng(n)
    for _ in range(60):
        periods = math.exp(rng.uniform(math.log(3.2), math.log(n / 3)))
        found = testing.energy_drift(t=t, energy=sine(t, periods, rng.uniform(0, 2 * np.pi)))
        assert found.kind == "bounded", (periods, found)
        assert abs(found.cycles - periods) <= max(0.6, 0.07 * periods), (periods, found)


@pytest.mark.parametrize("periods", [3.2, 3.5, 4.0, 4.5, 5.5, 7.0, 12.5])
def test_a_few_periods_are_enough_for_a_pure_oscillation(periods):
    t = np.linspace(0.0, 3.0, 5000)
    for phase in np.linspace(0.0, 2 * np.pi, 7, endpoint=False):
        found = testing.energy_drift(t=t, energy=sine(t, periods, phase))
        assert found.kind == "bounded", (periods, phase, found)


def test_sines_that_beat_with_256_blocks_are_bounded():
    """25,600 samples, 256 blocks of 100: one period a block and a little more or less,
    the block means' alias completing a period or half a period over the run."""
    t = np.linspace(0.0, 1.0, 25_600)
    for periods in (255.5, 256.0, 257.0, 512.5, 513.0, 1025.0, 2049.0):
        found = testing.energy_drift(t=t, energy=sine(t, periods, 0.3))
        assert found.kind == "bounded", (periods, found)
        assert found.cycles >= testing.MIN_CYCLES


def test_quasi_periodic_errors_are_bounded():
    """Six sinusoids of random amplitudes, phases and frequencies (5 to 5,000 periods):
    the energy error of a symplectic splitting is such a sum (before: 13 of 50 were
    called a random walk)."""
    t = np.linspace(0.0, 1.0, 20_000)
    for seed in range(30):
        g = np.random.default_rng(100 + seed)
        freq = np.exp(g.uniform(np.log(5.0), np.log(5000.0), 6))
        amp, phase = g.uniform(0.0, 1.0, 6), g.uniform(0.0, 2 * np.pi, 6)
        e = 1e-6 * (amp[:, None] * np.sin(2 * np.pi * freq[:, None] * t + phase[:, None]))
        found = testing.energy_drift(t=t, energy=1.0 + e.sum(axis=0))
        assert found.kind == "bounded", (seed, found)


@pytest.mark.parametrize("n", [2000, 20_000, 200_000])
def test_noise_alone_is_bounded(n):
    t = np.arange(float(n))
    for seed in range(10):
        noise = 1e-9 * np.random.default_rng(seed).normal(size=n)
        found = testing.energy_drift(t=t, energy=1.0 + noise)
        assert found.kind == "bounded", (seed, found)


def test_a_sine_with_noise_is_bounded():
    t = np.linspace(0.0, 1.0, 20_000)
    for periods in (6.5, 10.0, 100.0, 1000.0):
        for seed in range(5):
            noise = 3e-7 * np.random.default_rng(seed).normal(size=t.size)
            found = testing.energy_drift(t=t, energy=sine(t, periods, seed) + noise)
            assert found.kind == "bounded", (periods, seed, found)


@pytest.mark.parametrize(("periods", "ratios"), [
    (5, (4.0, 10.0)), (20, (0.3, 1.0, 2.0, 4.0, 10.0)), (100, (0.1, 1.0, 4.0, 10.0)),
    (1000, (0.01, 0.1, 1.0, 4.0, 10.0))])
def test_a_drift_under_a_sine_is_found_once_it_exceeds_the_sines_own_slope(periods, ratios):
    """``A sin + r t`` with ``r T = ratio A``: a drift, of the rate built in to within the
    sine's own slope; 100 times smaller than that slope can show (not a real trend),
    bounded. Before: a random walk at 5 and 100 periods whatever the drift below 4 A."""
    t = np.linspace(0.0, 1.0, 20_000)
    amplitude = 1e-6
    leak = own_slope_bound(periods, amplitude, 1.0)
    for phase in np.linspace(0.0, 6.0, 5):
        for ratio in ratios:
            rate = ratio * amplitude
            found = testing.energy_drift(t=t, energy=sine(t, periods, phase) + rate * t)
            assert found.kind == "drift", (periods, ratio, phase, found)
            assert abs(found.rate - rate) <= 1.1 * leak + 5 * found.rate_stderr, found
        small = testing.energy_drift(t=t, energy=sine(t, periods, phase) + 0.01 * leak * t)
        assert small.kind == "bounded", (periods, phase, small)


def test_random_walks_stay_random_walks():
    """Cumulative sums of white noise. One walk can look like a drift or, rarely, stop
    growing; most must be random walks, and few bounded."""
    for n in (2000, 20_000):
        t = np.arange(float(n))
        kinds = [testing.energy_drift(t=t, energy=1.0 + 1e-9 * np.cumsum(
            np.random.default_rng(seed).normal(size=n))).kind for seed in range(40)]
        assert kinds.count("random walk") >= 34 and kinds.count("bounded") <= 1, (n, kinds)
        assert "undetermined" not in kinds


def test_a_pure_trend_is_a_drift_and_slow_oscillations_are_undetermined():
    t = np.linspace(0.0, 1.0, 20_000)
    ramp = testing.energy_drift(t=t, energy=1.0 + 1e-9 * t)
    assert ramp.kind == "drift" and ramp.cycles == math.inf and ramp.exponent == 1.0
    for periods in (0.3, 1.0, 2.0, 2.7):
        found = testing.energy_drift(t=t, energy=sine(t, periods, 0.3))
        assert found.kind == "undetermined", (periods, found)


@pytest.mark.parametrize(("method", "dt"), [("rk4", 0.1), ("rkmk4", 0.1), ("rkmk4", 0.2)])
def test_non_symplectic_methods_drift_on_the_hlw_body(method, dt):
    """rk4 and rkmk4 lose energy on the free HLW body (bench/problems.py): a linear drift
    of a thousandth of the error's oscillation per orbit or more."""
    import warnings

    from bench.problems import problems

    p = problems()["hlw"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # rk4's |q| drifts: InvariantWarning
        traj = p.integrate(method, dt, round(10_000 / dt), save_every=round(1 / dt))
    found = testing.energy_drift(traj)
    assert found.kind == "drift" and found.rate < 0, found
    e = (traj.energy - traj.energy[0]) / abs(traj.energy[0])
    assert abs(found.rate * (traj.t[-1] - traj.t[0]) - e[-1]) < 0.1 * abs(e[-1])  # linear


@pytest.mark.parametrize("method", ["splitting2", "splitting4"])
def test_symplectic_splittings_are_bounded_on_the_hlw_body(method):
    from bench.problems import problems

    p = problems()["hlw"]
    traj = p.integrate(method, 0.05, 200_000, save_every=20)
    found = testing.energy_drift(traj)
    assert found.kind == "bounded", found
