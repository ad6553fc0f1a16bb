"""Packaging promises: cheap import, nothing compiled at import, the demo runs."""

from __future__ import annotations

import subprocess
import sys


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


def test_demo_runs():
    proc = subprocess.run([sys.executable, "-m", "liebody", "demo"], capture_output=True,
                          text=True, check=False)
    assert proc.returncode == 0, proc.stderr
    assert "Thin disk" in proc.stdout and "Euler angles" in proc.stdout


def test_methods_doc_is_the_registry():
    """docs/methods.md embeds liebody.methods().to_markdown(): docs and code read one truth."""
    from pathlib import Path

    import liebody

    doc = (Path(__file__).parents[1] / "docs" / "methods.md").read_text()
    start = doc.index("<!-- methods-table -->") + len("<!-- methods-table -->")
    end = doc.index("<!-- /methods-table -->")
    assert doc[start:end].strip() == liebody.methods().to_markdown()
