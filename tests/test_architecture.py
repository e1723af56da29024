"""Floors that run one way: no import cycle among mett's modules.

Every import of a mett module counts, at module top or inside a function (a function-level import
that only dodges a cycle at import time is still a dependency running the other way); imports under
``if TYPE_CHECKING:`` are type-only and do not count. A package's ``__init__`` is transparent: a
name taken from a package counts as an import of the submodule the package re-exports it from.
The cycles are the strongly connected components of that graph (Tarjan 1972).
"""

from __future__ import annotations

import ast
import pathlib

import mett

ROOT = pathlib.Path(mett.__file__).parent


def _name(path: pathlib.Path, root: pathlib.Path) -> str:
    parts = (root.name, *path.relative_to(root).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _type_only(tree: ast.AST) -> set[int]:
    """ids of the nodes under ``if TYPE_CHECKING:`` (or ``if typing.TYPE_CHECKING:``)."""
    out: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            out.update(id(n) for sub in node.body for n in ast.walk(sub))
    return out


def _imports(module: str, is_package: bool, tree: ast.AST) -> list[tuple[str, str | None]]:
    """(module, name or None) of every import in ``tree`` at any depth, relative ones resolved."""
    base = module.split(".") if is_package else module.split(".")[:-1]
    skip = _type_only(tree)
    out: list[tuple[str, str | None]] = []
    for node in ast.walk(tree):
        if id(node) in skip:
            continue
        if isinstance(node, ast.Import):
            out += [(alias.name, None) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            src = node.module or ""
            if node.level:
                src = ".".join(base[: len(base) - node.level + 1] + ([src] if src else []))
            out += [(src, alias.name) for alias in node.names]
    return out


def import_graph(sources: dict[str, tuple[bool, str]]) -> dict[str, set[str]]:
    """Edges module → modules it imports, from ``{module: (is_package, source text)}``."""
    trees = {m: ast.parse(text) for m, (_, text) in sources.items()}
    imports = {m: _imports(m, sources[m][0], trees[m]) for m in sources}
    packages = {m for m, (is_pkg, _) in sources.items() if is_pkg}
    face = {  # package -> {name it re-exports: the submodule it comes from}
        p: {name: src for src, name in imports[p] if name and src in sources and src != p}
        for p in packages
    }

    def target(src: str, name: str | None, depth: int = 0) -> str | None:
        if name and f"{src}.{name}" in sources:
            src, name = f"{src}.{name}", None
        if src in packages:
            if name in face[src] and depth < 20:
                return target(face[src][name], name, depth + 1)
            return None  # the package face itself: transparent
        while src and src not in sources:
            src = src.rpartition(".")[0]
        return src or None

    edges: dict[str, set[str]] = {m: set() for m in sources if m not in packages}
    for m in edges:
        for src, name in imports[m]:
            t = target(src, name)
            if t in edges and t != m:
                edges[m].add(t)
    return edges


def cycles(edges: dict[str, set[str]]) -> list[frozenset[str]]:
    """The strongly connected components with more than one module (Tarjan), iteratively."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[frozenset[str]] = []
    for start in sorted(edges):
        if start in index:
            continue
        work = [(start, iter(sorted(edges[start])))]
        index[start] = low[start] = len(index)
        stack.append(start)
        on_stack.add(start)
        while work:
            v, children = work[-1]
            w = next(children, None)
            if w is not None:
                if w not in index:
                    index[w] = low[w] = len(index)
                    stack.append(w)
                    on_stack.add(w)
                    work.append((w, iter(sorted(edges[w]))))
                elif w in on_stack:
                    low[v] = min(low[v], index[w])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[v])
            if low[v] == index[v]:
                comp = set()
                while True:
                    w = stack.pop()
                    on_stack.discard(w)
                    comp.add(w)
                    if w == v:
                        break
                if len(comp) > 1:
                    found.append(frozenset(comp))
    return found


def _package_sources(root: pathlib.Path) -> dict[str, tuple[bool, str]]:
    return {
        _name(p, root): (p.name == "__init__.py", p.read_text(encoding="utf-8"))
        for p in sorted(root.rglob("*.py"))
    }


def test_no_import_cycles():
    found = [sorted(c) for c in cycles(import_graph(_package_sources(ROOT)))]
    assert found == []


def test_the_ground_floor_imports_nothing_above_it():
    """``TippeTop`` (mett.top) and the modules it uses import only each other."""
    edges = import_graph(_package_sources(ROOT))
    assert edges["mett._validate"] == set()
    assert edges["mett._formulas"] == set()
    assert edges["mett.top"] <= {"mett._validate", "mett._formulas"}


def test_with_stem_builds_the_stem_module_class_without_importing_it():
    top = mett.presets.get("rutstam2013")
    assert type(top.with_stem(radius=0.005, distance=0.02)) is mett.stem.StemmedTop
    assert "mett.stem" not in import_graph(_package_sources(ROOT))["mett.top"]


def _probe(**modules: str) -> dict[str, tuple[bool, str]]:
    return {f"pkg.{m}": (False, text) for m, text in modules.items()} | {"pkg": (True, "")}


def test_the_checker_finds_a_cycle_through_a_function_level_import():
    sources = _probe(
        a="from . import b\n",
        b="def f():\n    from .c import x\n    return x\n",
        c="from .a import y\n",
        d="from .a import y\n",
    )
    assert cycles(import_graph(sources)) == [frozenset({"pkg.a", "pkg.b", "pkg.c"})]


def test_the_checker_skips_type_only_imports():
    sources = _probe(
        a="from .b import x\n",
        b="from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from .a import y\n",
    )
    assert cycles(import_graph(sources)) == []


def test_the_checker_follows_a_package_face_to_the_submodule():
    """``from . import name`` through a package's ``__init__`` is an import of the submodule that
    defines ``name``, not of the package: a cycle through the face is found."""
    sources = {
        "pkg": (True, ""),
        "pkg.a": (False, "from .sub import thing\n"),
        "pkg.sub": (True, "from .impl import thing\n"),
        "pkg.sub.impl": (False, "from ..a import other\n"),
        "pkg.sub.free": (False, "from ..a import other\n"),
    }
    assert cycles(import_graph(sources)) == [frozenset({"pkg.a", "pkg.sub.impl"})]


def test_the_checker_fails_on_the_cycles_this_change_removed():
    """The import of classification in TippeTop.subgroup, put back, closes a cycle again."""
    sources = _package_sources(ROOT)
    is_pkg, text = sources["mett.top"]
    sources["mett.top"] = (
        is_pkg,
        text + "\n\ndef _probe():\n    from .classification import subgroup\n",
    )
    found = cycles(import_graph(sources))
    assert any({"mett.top", "mett.classification"} <= c for c in found)
