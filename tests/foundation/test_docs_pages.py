"""The Python blocks of the documentation pages run as written (each page's blocks in
order, in one namespace). The ensembles page's Dask blocks need a cluster and are
checked by tests/distributed; its local blocks run here."""

from __future__ import annotations

import re
from pathlib import Path

import matplotlib
import pytest

DOCS = Path(__file__).resolve().parents[2] / "docs"
PAGES = ["index.md", "getting_started.md", "control.md", "ensembles.md"]


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
