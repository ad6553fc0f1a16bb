"""Smoke test of the benchmarks: ``python -m liebody bench --quick`` writes every file,
every method is in them, and what they measured agrees with what the tests know.

Timings are never asserted; the checks are on errors, orders and invariants, which
are deterministic.
"""

from __future__ import annotations

import csv
import json
import math
import subprocess
import sys

import numpy as np
import pytest

import liebody
from bench import BENCHMARKS
from bench import core as C
from bench import peers as P

pytest.importorskip("matplotlib")

@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench")
    proc = subprocess.run([sys.executable, "-m", "bench", "--quick", "--out", str(out),
                           "--no-progress"], capture_output=True, text=True, check=False)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    return out, proc.stdout


def _csv(path) -> list[dict]:
    with open(path) as fh:
        return list(csv.DictReader(fh))


def _json(path) -> dict:
    with open(path) as fh:
        return json.load(fh)


def _peers(problem) -> set[str]:
    peers = {f"scipy {m}" for m in P.SCIPY_METHODS}
    if P.mujoco_available() and problem.physical:
        peers |= {f"MuJoCo {m}" for m in P.MUJOCO_INTEGRATORS}
    return peers


@pytest.mark.long
def test_every_benchmark_writes_its_files(quick):
    out, stdout = quick
    for name in BENCHMARKS:
        for ext in ("json", "csv", "png"):
            path = out / f"{name}.{ext}"
            assert path.is_file() and path.stat().st_size > 200, path
        assert (out / f"{name}.png").stat().st_size > 20_000  # a chart, not an empty canvas
        data = _json(out / f"{name}.json")  # strict JSON (no NaN)
        assert data["machine"]["cpu"] and data["machine"]["numba"]
        assert f"--- {name}" in stdout


@pytest.mark.long
def test_work_precision_has_every_method_and_peer(quick):
    out, _ = quick
    rows = _csv(out / "work_precision.csv")
    for key, problem in C.problems().items():
        for T in ("10", "100"):
            names = {r["method"] for r in rows if r["problem"] == key and r["T"] == T}
            assert names == set(problem.methods()) | _peers(problem), (key, T)


@pytest.mark.long
def test_work_precision_errors_converge_at_the_declared_order(quick):
    """The benchmark's error measure and reference reproduce the methods' orders (T = 10)."""
    out, _ = quick
    rows = _csv(out / "work_precision.csv")
    summary = _json(out / "work_precision.json")
    for key in C.problems():
        floor = summary["problems"][key]["reference"]["uncertainty"]
        assert floor < 1e-10
        for name in ("splitting2", "splitting4", "rk4"):
            pts = sorted((float(r["setting"]), float(r["error"])) for r in rows
                         if r["problem"] == key and r["T"] == "10" and r["method"] == name
                         and r["error"] not in ("", "inf"))
            pts = [(h, e) for h, e in pts if 10 * floor < e < 1e-2]
            assert len(pts) >= 2, (key, name, pts)
            (h0, e0), (h1, e1) = pts[0], pts[1]
            order = math.log(e1 / e0) / math.log(h1 / h0)
            assert abs(order - liebody.methods()[name].order) < 0.5, (key, name, order)


@pytest.mark.long
def test_work_precision_reports_ratios_and_crossovers(quick):
    out, stdout = quick
    summary = _json(out / "work_precision.json")
    for info in summary["problems"].values():
        entry = info["ratios"]["T=10"]["1e-04"]
        assert entry["best"] in liebody.methods().names()
        assert set(entry["ratio_peer_over_best"]) >= {"scipy DOP853", "rk4"}
        for kind in ("error", "energy_error"):
            assert set(info["crossover_vs_rk4"][kind]) == {f"{e:.0e}" for e in C.ERROR_LEVELS}
        assert info["title"] in stdout


@pytest.mark.long
def test_long_horizon_geometric_bounded_baselines_drift(quick):
    out, _ = quick
    summary = _json(out / "long_horizon.json")
    for key, info in summary["problems"].items():
        problem = C.problems()[key]
        assert set(info["final"]) == set(problem.methods()) | _peers(problem)
        for name, f in info["final"].items():
            if name in liebody.methods().names() and liebody.methods()[name].family != "baseline":
                assert f["qnorm"]["max"] < 1e-12, (key, name, f["qnorm"])
                assert f["momentum"]["max"] < 1e-12, (key, name, f["momentum"])
                assert f["failed_at"] is None
        rk4 = info["final"]["rk4"]["energy"]
        assert rk4["last_decile"] > 3 * rk4["early_decile"], (key, rk4)  # a secular drift
        assert info["final"]["euler"]["failed_at"] is not None, key


@pytest.mark.long
def test_step_cost_times_every_method(quick):
    out, _ = quick
    text = (out / "step_cost.csv").read_text()
    for name in liebody.methods().names():
        assert name in text


@pytest.mark.long
def test_stability_finds_the_known_failure_points(quick):
    """Every method swept; the failures the literature predicts are where it says."""
    out, _ = quick
    data = _json(out / "stability.json")
    free, top = data["free_body"]["methods"], data["heavy_top"]["methods"]
    assert set(free) == set(C.problems()["asym"].methods())
    assert set(top) == set(C.problems()["top"].methods())
    # RK4's quaternion amplification exceeds 1 beyond h|omega| = 4 sqrt 2 = 5.66
    assert 5.0 < free["rk4"]["qnorm_failure"]["x_refined"] < 6.5
    # explicit Euler fails at once; splitting6/8 and the DMV family keep |q| at every step
    assert free["euler"]["energy_failure"]["x"] == data["free_body"]["methods"]["euler"][
        "sweep"]["x"][0]
    for name in ("splitting6", "splitting8", "splitting2"):
        assert free[name]["qnorm_failure"]["x"] is None, name
    # the kick-drift splitting's resonance at h omega_nut = 2 pi
    peak = top["splitting2"]["resonance_peak"]
    assert abs(peak["offset_from_2pi"]) < 0.3 and peak["ratio_to_x4"] > 100
    # Euler angles lose accuracy near gimbal lock; quaternions do not care
    run = data["gimbal_lock"]["runs"][0]
    assert run["euler_angles_rk4"][0] < 1e-6 < max(run["euler_angles_rk4"])
    assert max(run["quaternion_rk4"]) < 2 * min(run["quaternion_rk4"])


def test_cost_at_interpolates_log_log():
    from bench.work_precision import cost_at

    pts = [(1.0, 1e-2), (10.0, 1e-6), (100.0, 1e-10)]
    assert cost_at(pts, 1e-4) == pytest.approx(10 ** 0.5)
    assert cost_at(pts, 1e-6) == pytest.approx(10.0)
    assert cost_at(pts, 1e-12) is None
    assert cost_at([(5.0, 1e-9)], 1e-4) == 5.0  # already below at the cheapest point
    # a noisy line is made monotone: a worse point after a better one does not count
    assert cost_at([(1.0, 1e-3), (2.0, 1e-2), (4.0, 1e-5)], 1e-4) == pytest.approx(
        np.exp(np.log(2.0) + 0.5 * np.log(2.0)))
