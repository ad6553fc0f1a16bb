"""The ten-line example of docs/testing.md, run as written with a user integrator."""

from __future__ import annotations

import re
import sys
import types
from pathlib import Path

from test_toolkit import python_splitting

import liebody

DOC = Path(__file__).resolve().parents[2] / "docs" / "testing.md"


def test_docs_example_runs(monkeypatch):
    text = DOC.read_text()
    block = re.search(r"```python\n(# test_my_integrator\.py\n.*?)```", text, re.S).group(1)
    assert len([ln for ln in block.splitlines() if ln.strip()]) <= 11  # ten lines + name
    moments = liebody.testing.problem("hlw").scene.moments
    fake = types.ModuleType("my_code")
    fake.my_step = python_splitting(moments)
    monkeypatch.setitem(sys.modules, "my_code", fake)
    namespace: dict = {}
    exec(compile(block, str(DOC), "exec"), namespace)
    namespace["test_order_and_conservation"]()
