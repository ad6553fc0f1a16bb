"""The satellite part of the work-precision benchmark (``python -m bench.work_precision
--satellite --quick``): it writes its files, every contender runs, and its findings
hold at equal steps (no timing is asserted): on the tumbling spacecraft the default
(kick - exact free flow - kick) is orders of magnitude more accurate than the axis
splitting between the kicks, and the errors of the defaults fall at their orders (those
of SABA_n at their order in the weak torque, ``Method.weak_order``)."""

from __future__ import annotations

import csv
import itertools
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from bench.work_precision import SAT_CONTENDERS

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def rows(tmp_path_factory):
    out = tmp_path_factory.mktemp("satellite")
    proc = subprocess.run([sys.executable, "-m", "bench.work_precision", "--satellite",
                           "--quick", "--out", str(out)], cwd=ROOT, capture_output=True,
                          text=True, timeout=900)
    assert proc.returncode == 0, proc.stderr[-2000:]
    for ext in ("json", "csv", "png"):
        assert (out / f"work_precision_satellite.{ext}").stat().st_size > 0
    summary = json.loads((out / "work_precision_satellite.json").read_text())
    assert set(summary["problems"]) == {"tumble", "libration"}
    with open(out / "work_precision_satellite.csv") as fh:
        return list(csv.DictReader(fh))


def _errors(rows, problem, method):
    return {float(r["setting"]): float(r["error"]) for r in rows
            if r["problem"] == problem and r["method"] == method}


def test_every_contender_runs_on_both_satellites(rows):
    for problem in ("tumble", "libration"):
        names = {r["method"] for r in rows if r["problem"] == problem}
        assert names >= {label for label, _, _ in SAT_CONTENDERS if label != "rattle"}
        assert "scipy DOP853" in names


def test_the_exact_drift_beats_the_axis_splitting_on_the_tumble(rows):
    default = _errors(rows, "tumble", "splitting2")
    axes = _errors(rows, "tumble", "splitting2 axes")
    # the steps at which the default converges (beyond h omega ~ 3 both are resonant)
    common = sorted(h for h in set(default) & set(axes) if default[h] < 1e-2)
    assert len(common) >= 3, default
    for h in common:
        assert default[h] < 1e-3 * axes[h], (h, default[h], axes[h])


@pytest.mark.parametrize(("method", "order"), [("splitting2", 2), ("splitting4", 4),
                                               ("saba2", 4)])
def test_the_defaults_converge_at_their_order_on_the_tumble(rows, method, order):
    errs = _errors(rows, "tumble", method)
    hs = sorted(h for h, e in errs.items() if 1e-9 < e < 1e-2)
    assert len(hs) >= 2
    rates = [np.log2(errs[b] / errs[a]) for a, b in itertools.pairwise(hs)
             if np.isclose(b, 2 * a)]
    assert rates and max(rates) > order - 0.5, rates
