"""Module layout: no module uses another module's private names.

A name with a leading underscore belongs to its module. Allowed: importing a private *module*
(``from . import _validate``), and imports between the modules of one package whose source
module is itself private (``mett.separation._wells`` → ``mett.separation._api``).
"""

from __future__ import annotations

import ast
import pathlib

import pytest

import mett

ROOT = pathlib.Path(mett.__file__).parent
FILES = sorted(ROOT.rglob("*.py"))
# reworked in parallel changes; each lists its own imports of another module's private names
PENDING: set[str] = set()  # modules still to be reworked (expected to fail until then)


def _module(path: pathlib.Path) -> tuple[str, str]:
    """(dotted module name, dotted package name) of a source file."""
    parts = ("mett", *path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        return ".".join(parts[:-1]), ".".join(parts[:-1])
    return ".".join(parts), ".".join(parts[:-1])


def _is_module(dotted: str) -> bool:
    rel = pathlib.Path(*dotted.split(".")[1:])
    return (ROOT / rel).with_suffix(".py").exists() or (ROOT / rel / "__init__.py").exists()


def _private(name: str) -> bool:
    return name.startswith("_") and not name.startswith("__")


def violations(path: pathlib.Path, text: str | None = None) -> list[str]:
    """The uses of another module's private names in ``path`` (or in ``text`` placed there)."""
    module, package = _module(path)
    tree = ast.parse(path.read_text(encoding="utf-8") if text is None else text)
    found, imported = [], set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                src = ".".join(base + ([node.module] if node.module else []))
            else:
                src = node.module or ""
            for alias in node.names:
                imported.add(alias.asname or alias.name)
                if not _private(alias.name) or _is_module(f"{src}.{alias.name}"):
                    continue
                src_package, _, src_leaf = src.rpartition(".")
                if _private(src_leaf) and (module + ".").startswith(src_package + "."):
                    continue  # between the modules of one package, from a private module
                found.append(f"line {node.lineno}: from {src} import {alias.name}")
        elif isinstance(node, ast.Import):
            imported.update((a.asname or a.name).split(".")[0] for a in node.names)
    for node in ast.walk(tree):
        if (
            isinstance(node, ast.Attribute)
            and _private(node.attr)
            and isinstance(node.value, ast.Name)
            and node.value.id in imported
            and node.value.id not in {"sys"}
        ):
            found.append(f"line {node.lineno}: {node.value.id}.{node.attr}")
    return found


@pytest.mark.parametrize(
    "path",
    [
        pytest.param(
            f,
            id=str(f.relative_to(ROOT)),
            marks=pytest.mark.xfail(reason="reworked in a parallel change", strict=False)
            if str(f.relative_to(ROOT)) in PENDING
            else (),
        )
        for f in FILES
    ],
)
def test_no_private_names_of_other_modules(path):
    assert violations(path) == []


def test_the_checker_catches_private_imports():
    """The checker flags a private function imported from a sibling module and a private
    attribute of an imported class, and lets private modules and their siblings through."""
    text = (
        "from . import _kernels\n"
        "from .gliding import _core\n"
        "from ..state import State\n"
        "x = State._fields_private\n"
    )
    found = violations(ROOT / "dynamics" / "probe.py", text)
    assert found == [
        "line 2: from mett.dynamics.gliding import _core",
        "line 4: State._fields_private",
    ]
    sibling = "from ._wells import _Well\n"
    assert violations(ROOT / "separation" / "_api.py", sibling) == []
    assert violations(ROOT / "estimates.py", "from .separation._wells import _Well\n") != []
