"""Every public name has an entry in the API reference of the documentation site.

The top-level classes and functions are listed in ``docs/api/index.rst`` (autosummary);
each public module has a page ``docs/api/<module>.rst`` with ``automodule :members:``,
which documents exactly the module's ``__all__``. A new public name without an entry
fails here, before the site is built.
"""

from __future__ import annotations

import re
import types
from pathlib import Path

import liebody

API = Path(__file__).resolve().parents[2] / "docs" / "api"


def _listed() -> set[str]:
    text = (API / "index.rst").read_text()
    names = set()
    for block in re.findall(r"\.\. autosummary::\n((?:[ ]{3}.*\n|\n)+)", text):
        names |= {ln.strip() for ln in block.splitlines()
                  if ln.strip() and not ln.strip().startswith(":")}
    return names


def test_every_public_name_has_an_api_entry():
    listed = _listed()
    missing = []
    for name in liebody.__all__:
        if name == "__version__":
            continue
        obj = getattr(liebody, name)
        if isinstance(obj, types.ModuleType):
            page = API / f"{name}.rst"
            if not (page.exists() and f".. automodule:: liebody.{name}" in page.read_text()
                    and ":members:" in page.read_text()):
                missing.append(f"module {name}: docs/api/{name}.rst with automodule :members:")
            elif f"\n   {name}\n" not in (API / "index.rst").read_text():
                missing.append(f"module {name}: not in the toctree of docs/api/index.rst")
        elif name not in listed:
            missing.append(f"{name}: not in an autosummary list of docs/api/index.rst")
    assert not missing, "API entries missing:\n" + "\n".join(missing)


def test_public_modules_declare_what_they_export():
    """automodule :members: documents a module's __all__; every public module has one and
    every name in it exists."""
    for name in liebody.__all__:
        obj = getattr(liebody, name, None)
        if isinstance(obj, types.ModuleType):
            assert hasattr(obj, "__all__"), f"liebody.{name} has no __all__"
            for member in obj.__all__:
                assert hasattr(obj, member), f"liebody.{name}.__all__ names {member!r}"


def test_no_entry_for_a_name_that_is_not_public():
    listed = _listed()
    assert listed <= set(liebody.__all__), listed - set(liebody.__all__)
