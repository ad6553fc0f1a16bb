"""The Python blocks of the documentation pages and of the README run as written (each
page's blocks in order, in one namespace). The ensembles page's Dask blocks need a
cluster and are checked by tests/distributed; its local blocks run here. The testing
page's blocks import the user's module and register methods: they have their own test
below (and tests/testing/test_docs_example.py)."""

from __future__ import annotations

import re
from pathlib import Path

import matplotlib
import pytest

DOCS = Path(__file__).resolve().parents[2] / "docs"
PAGES = ["index.md", "getting_started.md", "control.md", "ensembles.md",
         "guide/reaction_wheels.md", "../README.md"]


def _blocks(page: str) -> list[str]:
    text = (DOCS / page).read_text()
    return re.findall(r"^```python\n(.*?)^```", text, flags=re.S | re.M)


@pytest.mark.filterwarnings("ignore::liebody.InvariantWarning")
@pytest.mark.parametrize("page", PAGES)
def test_the_python_blocks_of_a_page_run(page, monkeypatch, tmp_path):
    matplotlib.use("Agg", force=True)
    monkeypatch.chdir(tmp_path)  # blocks that save a figure write here
    blocks = [b for b in _blocks(page) if "distributed" not in b and "Client(" not in b]
    assert blocks or page == "ensembles.md", f"{page} has no Python block"
    namespace: dict = {}
    for block in blocks:
        exec(compile(block, page, "exec"), namespace)


def test_the_testing_page_blocks_run_and_give_the_values_it_states():
    """docs/testing.md: the observed-order session (as a doctest) and the two registered
    methods, whose stated orders and symmetry are checked; the ten-line example of the
    page is run by tests/testing/test_docs_example.py."""
    import doctest

    import liebody
    from liebody import _methods

    blocks = _blocks("testing.md")
    session = [b for b in blocks if b.startswith(">>>")]
    assert len(session) == 1
    test = doctest.DocTestParser().get_doctest(session[0], {}, "testing.md", "testing.md", 0)
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS)
    runner.run(test)
    assert runner.failures == 0
    registering = [b for b in blocks if "liebody.register_" in b]
    assert len(registering) == 2
    namespace: dict = {}
    try:
        for block in registering:
            exec(compile(block, "testing.md", "exec"), namespace)
        assert liebody.methods()["triple_jump"].order == 4  # "m.order  # 4"
        m = namespace["m"]
        assert (m.name, m.order, m.reversible) == ("my_strang", 2, True)  # "(2, True)"
    finally:  # the registry is global, and the generic tests iterate over it
        for name in ("triple_jump", "my_strang"):
            _methods._REGISTRY.pop(name, None)
        _methods._PLANS.clear()
