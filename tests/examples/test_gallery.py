"""Every gallery example runs as a script and passes the physics checks written in it.

The documentation build executes them too (sphinx-gallery); this runs them in the test
suite so that a broken example fails without building the site. The Monte Carlo
example has its own test (tests/scenes/test_monte_carlo_example.py), which runs it with
fewer bodies.
"""

from __future__ import annotations

import os
import runpy
import warnings
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
OWN_TESTS = {"plot_monte_carlo_flips.py"}
SCRIPTS = sorted(p.name for p in EXAMPLES.glob("plot_*.py") if p.name not in OWN_TESTS)


def test_the_gallery_has_at_least_ten_examples():
    assert len(list(EXAMPLES.glob("plot_*.py"))) >= 10
    assert (EXAMPLES / "README.txt").exists()


@pytest.mark.parametrize("script", SCRIPTS)
def test_example_runs_and_checks_its_physics(script, monkeypatch):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    monkeypatch.setenv("MPLBACKEND", "Agg")
    monkeypatch.chdir(EXAMPLES)
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="Animation was deleted")
        runpy.run_path(os.fspath(EXAMPLES / script), run_name="__main__")
    plt.close("all")
