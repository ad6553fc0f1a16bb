"""Packaging promises: cheap import, nothing compiled at import, the demo runs."""

from __future__ import annotations

import subprocess
import sys

import pytest


def _python(code: str) -> str:
    return subprocess.run([sys.executable, "-c", code], check=True, capture_output=True,
                          text=True).stdout


def test_import_loads_neither_numba_nor_scipy():
    out = _python("import sys, liebody; print('numba' in sys.modules, 'scipy' in sys.modules)")
    assert out.split() == ["False", "False"]


def test_public_names_resolve_lazily():
    out = _python(
        "import liebody\n"
        "for n in liebody.__all__: getattr(liebody, n)\n"
        "print(liebody.integrate.__module__, type(liebody.methods()).__name__)")
    assert out.split() == ["liebody._integrate", "MethodTable"]


def _demo(*args: str) -> str:
    proc = subprocess.run([sys.executable, "-m", "liebody", "demo", *args],
                          capture_output=True, text=True, check=False)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return proc.stdout


def test_demo_runs_and_agrees_with_the_closed_forms():
    """The README's first command: every table row's relative difference is small."""
    import re

    out = _demo()
    for title in ("Chandler wobble", "intermediate axis", "Dzhanibekov", "Lagrange top"):
        assert title in out
    num = r"[-+]?[0-9.]+(?:e[-+][0-9]+)?"
    rows = re.findall(rf"^  \S.* {num} +{num} +([0-9.]+e[-+][0-9]+)$", out, flags=re.M)
    assert len(rows) >= 6 and all(float(r) < 1e-5 for r in rows), out


def test_demo_writes_the_figures(tmp_path):
    pytest.importorskip("matplotlib")
    _demo("--plot", str(tmp_path))
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "chandler_wobble.png", "dzhanibekov_flips.png", "intermediate_axis_growth.png",
        "lagrange_top_cusps.png"]
    assert all(p.stat().st_size > 10_000 for p in tmp_path.iterdir())


def test_methods_doc_is_the_registry():
    """docs/methods.md embeds liebody.methods().to_markdown(): docs and code read one truth."""
    from pathlib import Path

    import liebody

    doc = (Path(__file__).parents[2] / "docs" / "methods.md").read_text()
    start = doc.index("<!-- methods-table -->") + len("<!-- methods-table -->")
    end = doc.index("<!-- /methods-table -->")
    assert doc[start:end].strip() == liebody.methods().to_markdown()


def test_readme_example_runs():
    """The README's 'A first look' code block runs as written."""
    import re
    from pathlib import Path

    readme = (Path(__file__).parents[2] / "README.md").read_text()
    block = re.search(r"## A first look\n\n```python\n(.*?)```", readme, re.S).group(1)
    exec(compile(block, "README.md", "exec"), {})


def _import_graph() -> dict[str, set[str]]:
    """``liebody`` module -> the ``liebody`` modules it imports, at the top or inside a
    function (the package root, whose names resolve lazily, left out)."""
    import ast
    from pathlib import Path

    root = Path(__file__).resolve().parents[2] / "src" / "liebody"
    mods = {}
    for p in root.rglob("*.py"):
        name = ".".join(("liebody", *p.relative_to(root).with_suffix("").parts))
        mods[name.removesuffix(".__init__")] = p
    graph = {}
    for m, p in mods.items():
        deps = set()
        for node in ast.walk(ast.parse(p.read_text())):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("liebody"):
                for a in node.names:
                    full = f"{node.module}.{a.name}"
                    deps.add(full if full in mods else node.module)
            elif isinstance(node, ast.Import):
                deps |= {a.name for a in node.names if a.name.startswith("liebody")}
        graph[m] = {d for d in deps if d in mods and d not in (m, "liebody")}
    return graph


def _cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One import cycle of ``graph`` (depth-first search), or None."""
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(m):
        state[m] = 1
        stack.append(m)
        for d in sorted(graph[m]):
            if state.get(d) == 1:
                return [*stack[stack.index(d):], d]
            if d not in state:
                found = visit(d)
                if found:
                    return found
        stack.pop()
        state[m] = 2
        return None

    for m in sorted(graph):
        if m not in state:
            found = visit(m)
            if found:
                return found
    return None


def test_no_import_cycle_anywhere():
    """No module of the package imports, even inside a function, one that imports it back
    (the run engine's layers: _engine <- _ensemble <- _integrate <- _stepper, distributed)."""
    graph = _import_graph()
    assert "liebody._engine" in graph and graph["liebody._integrate"]
    assert _cycle(graph) is None, " -> ".join(_cycle(graph))
    # the search finds a cycle when there is one
    assert _cycle({**graph, "liebody._engine": {"liebody._integrate"}}) is not None
