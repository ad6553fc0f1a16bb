"""The benchmarks (``bench/``, run from the repository root): the smoke test runs
``python -m bench --quick`` and checks that it writes every file, that every method is
in them, and that what they measured agrees with what the tests know; fast tests check
the pieces (peers, children, the interpolation) and that the package carries no
benchmark code.

Timings are never asserted; the checks are on errors, orders and invariants, which
are deterministic.
"""

from __future__ import annotations

import csv
import importlib.util
import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import liebody
from bench import BENCHMARKS
from bench import peers as P
from bench.problems import method_names, problems
from bench.work_precision import ERROR_LEVELS, cost_at

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench")
    log_before = _stat(ROOT / "MUJOCO_LOG.TXT")
    proc = subprocess.run([sys.executable, "-m", "bench", "--quick", "--out", str(out),
                           "--no-progress"], cwd=ROOT, capture_output=True, text=True,
                          check=False)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    # the MuJoCo peer keeps its warnings: nothing written into the working directory
    assert _stat(ROOT / "MUJOCO_LOG.TXT") == log_before
    return out, proc.stdout


def _stat(path: Path):
    return path.stat().st_mtime_ns if path.exists() else None


def _csv(path) -> list[dict]:
    with open(path) as fh:
        return list(csv.DictReader(fh))


def _json(path) -> dict:
    with open(path) as fh:
        return json.load(fh)


def _everything(problem) -> set[str]:
    """The names of every run on a problem: liebody's methods, scipy and MuJoCo."""
    return {P.label(source, name) for source, name in P.contenders(problem)}


def _is_geometric(name: str) -> bool:
    return name in method_names() and liebody.methods()[name].family != "baseline"


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
        assert data["runtime_s"] > 0
        assert f"--- {name}" in stdout


@pytest.mark.long
def test_work_precision_has_every_method_and_peer(quick):
    out, _ = quick
    rows = _csv(out / "work_precision.csv")
    for key, problem in problems().items():
        for T in ("10", "100"):
            names = {r["method"] for r in rows if r["problem"] == key and r["T"] == T}
            assert names == _everything(problem), (key, T)


@pytest.mark.long
def test_work_precision_errors_converge_at_the_declared_order(quick):
    """The benchmark's error measure and reference reproduce the methods' orders (T = 10)."""
    out, _ = quick
    rows = _csv(out / "work_precision.csv")
    summary = _json(out / "work_precision.json")
    for key in problems():
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
        assert entry["best"] in method_names()
        assert set(entry["ratio_peer_over_best"]) >= {"scipy DOP853", "rk4"}
        for kind in ("error", "energy_error"):
            assert set(info["crossover_vs_rk4"][kind]) == {f"{e:.0e}" for e in ERROR_LEVELS}
        assert info["title"] in stdout


@pytest.mark.long
def test_long_horizon_geometric_bounded_baselines_drift(quick):
    out, _ = quick
    summary = _json(out / "long_horizon.json")
    for key, info in summary["problems"].items():
        problem = problems()[key]
        assert set(info["final"]) == _everything(problem)
        for name, f in info["final"].items():
            if _is_geometric(name):
                assert f["qnorm"]["max"] < 1e-12, (key, name, f["qnorm"])
                assert f["momentum"]["max"] < 1e-12, (key, name, f["momentum"])
                assert f["failed_at"] is None
        rk4 = info["final"]["rk4"]["energy"]
        assert rk4["last_decile"] > 3 * rk4["early_decile"], (key, rk4)  # a secular drift
        assert info["final"]["euler"]["failed_at"] is not None, key
    if P.mujoco_available():  # MuJoCo's Euler blows up on the top: its warnings are kept
        assert any(summary["mujoco_warnings"]["top MuJoCo Euler"])


@pytest.mark.long
def test_step_cost_times_every_method(quick):
    out, stdout = quick
    rows = _csv(out / "step_cost.csv")
    names = {r["method"] for r in rows}
    assert names - {"C splitting2"} == set(method_names())
    summary = _json(out / "step_cost.json")
    # the axis ordering is the one integrate() chose, and C computes the same thing
    assert sorted(summary["problems"]["free"]["axis_ordering"]) == [0, 1, 2]
    if summary["c_reference"]["ns"] is not None:
        assert "C splitting2" in names and summary["c_reference"]["agree"]
    assert "target: splitting2 within 1.25x of C" in stdout
    for phase in ("empty", "cached"):
        assert set(summary["compile"][phase]["methods"]) == set(method_names())
    assert summary["import"]["in_process_s"]["import_liebody"] > 0
    assert "errors" not in summary["import"]
    # fixed costs and first calls measured (as multiples of a step: never asserted)
    fixed = summary["fixed_costs"]
    assert {"integrate_free", "integrate_user_torque", "stepper_free"} <= set(fixed)
    assert all(row["s"] > 0 and row["steps"] > 0 for row in fixed.values())
    # the spacecraft scenes timed, each on the free flow it asked for
    scenes = summary["scenes"]
    from bench.step_cost import scene_problems
    assert set(scenes) == set(scene_problems())
    assert all(row["ns"]["median"] > 0 and row["ratio_to_free"] > 0 for row in scenes.values())
    assert scenes["gg_circular_exact"]["info"]["free_flow"] == "elliptic"
    assert scenes["gg_circular_axes"]["info"]["free_flow"].startswith("axes")
    first = summary["first_calls"]
    assert first["calls"] and not any("error" in row for row in first["calls"].values())
    assert first["demo_first_run_s"] > 0 and "demo_error" not in first


@pytest.mark.long
def test_stability_finds_the_known_failure_points(quick):
    """Every method swept; each failure is where the method's formula predicts it.

    RK4's quaternion amplification exceeds 1 beyond h|omega| = 4 sqrt 2 and explicit
    Euler raises the energy every step (docs/references.md, "Facts derived here"); a
    kick-drift splitting resonates where the nutation turns by 2 pi per step.
    """
    out, _ = quick
    data = _json(out / "stability.json")
    free, top = data["free_body"]["methods"], data["heavy_top"]["methods"]
    assert set(free) == set(problems()["asym"].methods())
    assert set(top) == set(problems()["top"].methods())
    # RK4's quaternion amplification exceeds 1 beyond h|omega| = 4 sqrt 2 = 5.66
    assert 5.0 < free["rk4"]["qnorm_failure"]["x_refined"] < 6.5
    # explicit Euler fails at once; the splittings keep |q| at every step
    assert free["euler"]["energy_failure"]["x"] == free["euler"]["sweep"]["x"][0]
    for name in ("splitting6", "splitting8", "splitting2"):
        assert free[name]["qnorm_failure"]["x"] is None, name
    # the kick-drift splitting's resonance at h omega_nut = 2 pi
    peak = top["splitting2"]["resonance_peak"]
    assert abs(peak["offset_from_2pi"]) < 0.3 and peak["ratio_to_x4"] > 100
    # Euler angles lose accuracy near gimbal lock; quaternions do not care
    run = data["gimbal_lock"]["runs"][0]
    assert run["euler_angles_rk4"][0] < 1e-6 < max(run["euler_angles_rk4"])
    assert max(run["quaternion_rk4"]) < 2 * min(run["quaternion_rk4"])


@pytest.mark.long
def test_ensemble_times_every_path_and_the_paths_agree(quick):
    """Every case has every path at every N (MuJoCo where installed, Dask for the headline
    case), the SIMD and the scalar batch drivers computed the same states, and the
    targets are reported."""
    from bench.ensemble import CASES, PATHS

    out, stdout = quick
    data = _json(out / "ensemble.json")
    ns = data["settings"]["n"]
    for key, *_ in CASES:
        case = data["cases"][key]
        assert case["agree"] and case["single_body_ns"] > 0
        rows = [r for r in data["rows"] if r["case"] == key]
        for path in PATHS:
            assert {r["n"] for r in rows if r["path"] == path} == set(ns), (key, path)
        assert {r["threads"] for r in rows if r["path"] == "batched SIMD"} == {1, 2}
        if P.mujoco_available() and key not in ("free-rattle", "gg-splitting2"):
            assert any(r["path"].startswith("MuJoCo") for r in rows)
        assert all(r["ns"] > 0 for r in rows)
    dask = [r for r in data["rows"] if r["path"] == "Dask LocalCluster"]
    assert {r["threads"] for r in dask} == {1, 2}
    assert all(r["overhead_ms_per_task"] == r["overhead_ms_per_task"] for r in dask)
    assert "single/SIMD >= 7x" in stdout and "targets:" in stdout
    assert "Dask LocalCluster" in stdout


# ------------------------------------------------------------------------- fast tests


@pytest.mark.long
def test_coupled_times_the_paths_and_they_agree(quick):
    """The coupled benchmark times liebody, its free part and the plain numba loop, and the
    loop computes liebody's map (the same splitting written by hand)."""
    out, _ = quick
    rows = _json(out / "coupled.json")["rows"]
    assert rows and all(r["liebody_ns"] > 0 and r["plain_ns"] > 0 and r["free_part_ns"] > 0
                        for r in rows)
    assert all(r["agreement"] < 1e-9 for r in rows)


def test_ensemble_recording_times_the_drivers_and_restores_them():
    """bench.ensemble.recording wraps every batch driver for one call only; integrate's
    own switch chooses the scalar or the SIMD driver."""
    from bench.ensemble import Stepping, recording
    from liebody._kernels import batch, batch_drivers

    before = dict(batch_drivers.BATCH_RUNNERS), dict(batch.SIMD_RUNNERS)
    scene = liebody.FreeBody(liebody.RigidBody([0.6, 0.8, 1.0]))
    q0 = np.tile([1.0, 0.0, 0.0, 0.0], (3, 1))
    L0 = np.array([[1.8, 0.4, -0.9], [1.7, 0.5, -0.9], [1.8, 0.4, -1.0]])
    out = {}
    for simd in (False, True):
        rec = Stepping()
        with recording(rec):
            assert batch_drivers.BATCH_RUNNERS[0] is not before[0][0]
            out[simd] = liebody.integrate(scene, q0=q0, L0=L0, dt=0.05, steps=50,
                                          method="splitting2", save_every=None, simd=simd)
        assert rec.spans and rec.seconds > 0
        assert out[simd].info.get("simd", False) == simd or any(
            g["simd"] == simd for g in out[simd].info.get("groups", []))
    assert batch_drivers.BATCH_RUNNERS == before[0] and batch.SIMD_RUNNERS == before[1]
    assert 0.0 < np.abs(out[True].q - out[False].q).max() < 1e-13




def test_cost_at_interpolates_log_log():
    pts = [(1.0, 1e-2), (10.0, 1e-6), (100.0, 1e-10)]
    assert cost_at(pts, 1e-4) == pytest.approx(10 ** 0.5)
    assert cost_at(pts, 1e-6) == pytest.approx(10.0)
    assert cost_at(pts, 1e-12) is None
    assert cost_at([(5.0, 1e-9)], 1e-4) == 5.0  # already below at the cheapest point
    # a noisy line is made monotone: a worse point after a better one does not count
    assert cost_at([(1.0, 1e-3), (2.0, 1e-2), (4.0, 1e-5)], 1e-4) == pytest.approx(
        np.exp(np.log(2.0) + 0.5 * np.log(2.0)))


def test_scipy_peer_integrates_the_same_heavy_top():
    """The scipy RHS (liebody's gravity direction inside numba) agrees with splitting8."""
    top = problems()["top"]
    res = P.scipy_solve(top, 1.0, "DOP853", 1e-12)
    ref = top.integrate("splitting8", 1e-3, 1000, save_every=1000)
    assert np.abs(res["L"][-1] - ref.L[-1]).max() < 1e-7 * np.linalg.norm(top.L0)
    assert np.abs(res["q"][-1] - ref.q[-1]).max() < 1e-7


def test_mujoco_warnings_are_kept_not_written(tmp_path, monkeypatch):
    pytest.importorskip("mujoco")
    monkeypatch.chdir(tmp_path)
    P.MUJOCO_WARNINGS.take()
    run = P.MujocoRun(problems()["asym"], "Euler", 1.0)  # far too large: blows up
    q, _ = run.run(20)
    assert run.unstable and not np.all(np.isfinite(q))
    assert any("unstable" in message for message in P.MUJOCO_WARNINGS.take())
    assert list(tmp_path.iterdir()) == []  # no MUJOCO_LOG.TXT


def test_child_times_the_import_in_a_fresh_process():
    proc = subprocess.run([sys.executable, "-m", "bench.child", "import"], cwd=ROOT,
                          capture_output=True, text=True, check=True)
    assert 0 < float(proc.stdout.split()[-1]) < 60


def test_the_package_carries_no_benchmarks(capsys):
    from liebody.__main__ import main

    assert importlib.util.find_spec("liebody.benchmarks") is None
    assert main(["bench", "--quick"]) == 2
    assert "python -m bench" in capsys.readouterr().err
