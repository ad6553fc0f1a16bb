"""The Monte Carlo example (examples/plot_monte_carlo_flips.py), run small and headless.

The example integrates an ensemble of T-handles spun near their intermediate axis and
measures each one's full flip period ``T_m`` (the time between upward zero crossings of
``L_2``) against Landau & Lifshitz's ``4 K(k) / nu`` (``analysis.flip_period``). Here it
runs with ``LIEBODY_EXAMPLE_BODIES`` bodies; the measured periods of the exact flow must
agree with the formula within the interpolation error bound that follows from the
sampling interval, and the example's functions are checked on their own.
"""

from __future__ import annotations

import math
import runpy
from pathlib import Path

import numpy as np
import pytest
from scipy.special import ellipk

import liebody
from liebody import analysis

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "plot_monte_carlo_flips.py"
BODIES = 400


@pytest.fixture(scope="module")
def example():
    """The example's globals after a run with ``BODIES`` bodies (Agg backend)."""
    matplotlib = pytest.importorskip("matplotlib")
    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("LIEBODY_EXAMPLE_BODIES", str(BODIES))
        mp.setenv("MPLBACKEND", "Agg")
        g = runpy.run_path(str(EXAMPLE), run_name="__main__")
    plt.close("all")
    return g


def sn_fourth_derivative_max() -> float:
    """``max |d^4 sn(u|m) / du^4|`` over ``u`` and ``0 <= m <= 1``, from
    ``sn'' = -(1 + m) s + 2 m s^3`` and ``sn'^2 = (1 - s^2)(1 - m s^2)``."""
    s = np.linspace(-1.0, 1.0, 4001)[:, None]
    m = np.linspace(0.0, 1.0, 401)[None, :]
    s1sq = (1 - s**2) * (1 - m * s**2)
    s2 = -(1 + m) * s + 2 * m * s**3
    return float(np.max(np.abs(12 * m * s * s1sq + (-(1 + m) + 6 * m * s**2) * s2)))


def test_every_body_is_measured(example):
    g = example
    assert g["N"] == BODIES
    assert g["T_exact"].shape == g["T_s2"].shape == (BODIES,)
    assert np.all(np.isfinite(g["T_exact"])) and np.all(np.isfinite(g["T_s2"]))
    assert np.all(g["cyc_exact"] >= 1)
    # the window is long enough for two upward crossings of the slowest body
    assert g["t"][-1] >= 2 * g["T_formula"].max()


def test_exact_flow_periods_agree_within_the_sampling_bound(example):
    """Each crossing, located on the cubic through 4 samples ``ds`` apart, is off by at
    most ``max|L_2''''| ds^4 / 24 / |L_2'|``; with ``L_2 = A sn(nu t + c)`` that is
    ``C4 nu^3 ds^4 / 24`` (``C4 = max|sn''''|``), doubled for higher-order terms, and
    the period over ``n`` cycles is off by twice that over ``n``."""
    g = example
    ds = float(g["t"][1] - g["t"][0])
    assert ds == pytest.approx(g["DS"])
    c4 = sn_fourth_derivative_max()
    assert c4 <= g["C4"] < c4 + 1e-3          # the example's constant is that maximum
    nu, cycles = g["nu"], g["cyc_exact"]
    tol = 2 * (2 * c4 * nu**3 * ds**4 / 24) / cycles
    err = np.abs(g["T_exact"] - g["T_formula"])
    assert np.all(err <= tol + 1e-12 * g["T_formula"]), np.max(err / tol)
    # the bound is far tighter than what bracketing by the samples alone guarantees
    # (each crossing within ds: 2 ds / n), so it tests the interpolation
    assert np.all(tol < 0.05 * 2 * ds / cycles)
    # and the example's own tolerance is this one
    np.testing.assert_allclose(g["period_tolerance"](nu, ds, cycles), tol, rtol=1e-3)


def test_interpolation_error_shrinks_like_ds_to_the_fourth(example):
    """Half the sampling interval, ~16x smaller errors (the exact flow: no stepping
    error), and within the bound at both."""
    g = example
    L0 = g["L0"][:128]
    T = g["T_formula"][:128]
    nu = g["nu"][:128]
    n_samples = g["n_samples"]
    errs = {}
    for k, ds in ((1, g["DS"]), (2, g["DS"] / 2)):
        _, periods, cycles, _, _ = g["run_ensemble"](
            L0, method="exact", dt=ds, steps=k * n_samples, save_every=1)
        err = np.abs(periods - T)
        assert np.all(err <= g["period_tolerance"](nu, ds, cycles) + 1e-12 * T)
        errs[ds] = np.median(err)
    ratio = errs[g["DS"]] / errs[g["DS"] / 2]
    assert 8 < ratio < 32, ratio


def test_vectorised_crossings_match_analysis_zero_crossings(example):
    """measure_periods equals analysis.zero_crossings (upward, cubic) body by body."""
    g = example
    t, _, _, _, L2 = g["run_ensemble"](g["L0"][:64], method="exact", dt=g["DS"],
                                       steps=g["n_samples"], save_every=1,
                                       keep=np.arange(64))
    periods, cycles = g["measure_periods"](t, L2)
    np.testing.assert_array_equal(periods, g["T_exact"][:64])
    for i in range(L2.shape[0]):
        up = analysis.zero_crossings(t, L2[i], direction=1)
        assert cycles[i] == up.size - 1
        expected = (up[-1] - up[0]) / (up.size - 1)
        assert periods[i] == pytest.approx(expected, rel=1e-12, abs=1e-12)


def test_measure_periods_on_a_known_signal(example):
    """A sampled sine of period P: the period comes back; too short a window: NaN."""
    measure = example["measure_periods"]
    P = 1.7
    t = np.arange(0.0, 10.0, 0.05)
    y = np.stack([np.sin(2 * np.pi * (t / P) + 0.3), np.cos(2 * np.pi * t / 40.0)])
    periods, cycles = measure(t, y)
    # upward crossings at (k - 0.3 / 2 pi) P, k = 1 .. 5: four cycles between them
    assert cycles[0] == 4 and periods[0] == pytest.approx(P, rel=1e-5)
    assert cycles[1] == 0 and np.isnan(periods[1])


def test_sn_frequency_is_landau_lifshitz_nu(example):
    """``flip_period = 4 K(k) / nu``: with ``k^2`` from Landau & Lifshitz §37 and the
    example's ``nu``, on both sides of the separatrix."""
    g = example
    I1, I2, I3 = g["body"].moments
    L = g["L0"][:50]
    nu = g["sn_frequency"](g["body"].moments, L)
    G2 = np.sum(L**2, axis=1)
    E2 = np.sum(L**2 / np.array([I1, I2, I3]), axis=1)
    above = G2 > E2 * I2
    m = np.where(above, (I2 - I1) * (E2 * I3 - G2) / ((I3 - I2) * (G2 - E2 * I1)),
                 (I3 - I2) * (G2 - E2 * I1) / ((I2 - I1) * (E2 * I3 - G2)))
    assert above.any() and (~above).any()
    np.testing.assert_allclose(4 * ellipk(m) / nu, g["T_formula"][:50], rtol=1e-9)
    # near the separatrix nu is the instability's growth rate lambda
    lam = analysis.stability(g["body"].moments, g["OMEGA2"], axis=1).rate
    near = g["sn_frequency"](g["body"].moments, np.array([[1e-9, g["G"], 0.0]]))
    assert near[0] == pytest.approx(lam, rel=1e-9)


def test_splitting2_period_error_is_second_order(example):
    """splitting2's periods differ from the exact flow's by its own O(h^2) error: half
    the step, a quarter of the (median) difference."""
    g = example
    L0 = g["L0"][:128]
    n_samples, save = g["n_samples"], g["SAVE"]
    _, T_ref, _, _, _ = g["run_ensemble"](L0, method="exact", dt=g["DS"], steps=n_samples,
                                          save_every=1)
    diffs = {}
    for k in (1, 2):
        _, T_h, _, _, _ = g["run_ensemble"](L0, method="splitting2", dt=g["DT"] / k,
                                            steps=k * n_samples * save, save_every=k * save)
        diffs[k] = np.median(np.abs(T_h - T_ref) / T_ref)
    assert diffs[1] < (g["DT"] * g["OMEGA2"]) ** 2          # measured ~1e-1 of it
    assert diffs[1] / diffs[2] == pytest.approx(4.0, rel=0.1)


def test_example_matches_the_one_body_calls(example):
    """The ensemble call's trajectory is the one-body call's (a spot check)."""
    g = example
    kw = dict(dt=g["DS"], steps=g["n_samples"], method="exact", save_every=1)
    i = g["shown"][-1]  # the longest period, plotted
    one = liebody.integrate(g["scene"], L0=g["L0"][i], **kw)
    np.testing.assert_array_equal(one.L[:, 1], g["L2_shown"][-1])
    assert math.isclose(g["T_exact"][i], g["measure_periods"](one.t, one.L[None, :, 1])[0][0])
