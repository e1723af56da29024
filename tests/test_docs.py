"""The documentation is tested: every Python block runs, every docs link and anchor exists.

* Each ``python`` fenced block of README.md and docs/**/*.md runs; the blocks of one file run in
  sequence in one namespace (later blocks use earlier names), with matplotlib's Agg backend and the
  working directory in a temporary directory (files the examples write land there). A block
  preceded by an HTML comment starting with ``<!-- no-test`` (the comment says why) is skipped;
  use it only for blocks that cannot run in a test (a cluster, minutes of CPU).
* Every reference to a docs page (with or without an anchor) in the code, the tests, README.md and the notebooks, and
  every relative link between docs pages, points at a page that ships and an anchor it defines
  (explicit ``{#id}`` or a heading's slug).
* Nothing a user sees cites the engineers' private notes or a machine path.
"""

from __future__ import annotations

import re
import unicodedata
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"

FENCE = re.compile(r"^```python[^\n]*\n(.*?)^```[ \t]*$", re.M | re.S)
NO_TEST = re.compile(r"<!--\s*no-test\b[^>]*-->\s*$")


def _markdown_files() -> list[Path]:
    files = [ROOT / "README.md"]
    files += sorted(p for p in DOCS.rglob("*.md") if "figures" not in p.relative_to(DOCS).parts)
    return files


def python_blocks(text: str) -> list[tuple[int, str, bool]]:
    """(line number, code, skipped) of every ```python block, in order."""
    out = []
    for m in FENCE.finditer(text):
        before = text[: m.start()].rstrip("\n").splitlines()
        skipped = bool(before) and bool(NO_TEST.search(before[-1]))
        out.append((text.count("\n", 0, m.start()) + 1, m.group(1), skipped))
    return out


DOC_FILES = [p for p in _markdown_files() if python_blocks(p.read_text(encoding="utf-8"))]


def test_block_parser_finds_blocks_and_honours_the_opt_out():
    text = "x\n```python\na = 1\n```\n\n<!-- no-test: why -->\n```python\nb = 2\n```\n"
    blocks = python_blocks(text)
    assert [(code, skipped) for _, code, skipped in blocks] == [
        ("a = 1\n", False),
        ("b = 2\n", True),
    ]
    assert len(DOC_FILES) >= 8  # README, index, own-top and the theory pages carry examples


@pytest.mark.parametrize("path", DOC_FILES, ids=lambda p: str(p.relative_to(ROOT)))
def test_python_blocks_run(path, tmp_path, monkeypatch):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    monkeypatch.chdir(tmp_path)
    namespace: dict = {"__name__": "__docs__"}
    blocks = python_blocks(path.read_text(encoding="utf-8"))
    ran = 0
    try:
        for line, code, skipped in blocks:
            if skipped:
                continue
            exec(compile(code, f"{path.relative_to(ROOT)}:{line}", "exec"), namespace)
            ran += 1
            # a page's figures are independent; pyplot keeps each open until closed (and warns
            # past 20), and a closed figure can still be saved from the page's namespace
            plt.close("all")
    finally:
        plt.close("all")
    assert ran > 0


# --- links and anchors -----------------------------------------------------------------------


def slugify(text: str) -> str:
    """Python-Markdown's toc slug (the default of mkdocs): NFKD, ASCII, lower, '-' for spaces."""
    text = unicodedata.normalize("NFKD", text).encode("ascii", "ignore").decode("ascii")
    text = re.sub(r"[^\w\s-]", "", text).strip().lower()
    return re.sub(r"[-\s]+", "-", text)


def anchors(page: Path) -> set[str]:
    """Anchors a docs page defines: explicit {#id} attributes and the slugs of other headings."""
    found: set[str] = set()
    in_code = False
    for line in page.read_text(encoding="utf-8").splitlines():
        if line.startswith("```"):
            in_code = not in_code
        if in_code:
            continue
        found.update(re.findall(r"\{\s*#([\w-]+)[^}]*\}", line))
        m = re.match(r"#{1,6}\s+(.*?)\s*(\{[^}]*\})?\s*$", line)
        if m and not (m.group(2) and "#" in m.group(2)):
            found.add(slugify(re.sub(r"[`*$\\]", "", m.group(1))))
    return found


DOCS_REF = re.compile(r"(?<![\w/.-])docs/([\w/.-]+\.md)(?:#([\w-]+))?")


def _sources() -> list[Path]:
    files = sorted((ROOT / "mett").rglob("*.py")) + sorted((ROOT / "tests").rglob("*.py"))
    files += [ROOT / "README.md", *sorted((ROOT / "notebooks").glob("*.ipynb"))]
    return files


def test_docs_references_in_code_and_readme_resolve():
    missing = []
    for src in _sources():
        for m in DOCS_REF.finditer(src.read_text(encoding="utf-8")):
            page = DOCS / m.group(1)
            if not page.is_file():
                missing.append(f"{src.relative_to(ROOT)}: docs/{m.group(1)} does not exist")
            elif m.group(2) and m.group(2) not in anchors(page):
                missing.append(f"{src.relative_to(ROOT)}: no #{m.group(2)} in docs/{m.group(1)}")
    assert not missing, "\n".join(missing)


MD_LINK = re.compile(r"\]\(([^)\s]+?\.(?:md|ipynb))(?:#([\w-]+))?\)")


def test_links_between_docs_pages_resolve():
    missing = []
    for page in _markdown_files():
        base = page.parent
        for m in MD_LINK.finditer(page.read_text(encoding="utf-8")):
            if "://" in m.group(1):
                continue
            target = (base / m.group(1)).resolve()
            where = f"{page.relative_to(ROOT)} -> {m.group(1)}"
            if not target.is_file():
                missing.append(f"{where}: no such file")
            elif m.group(2) and target.suffix == ".md" and m.group(2) not in anchors(target):
                missing.append(f"{where}: no anchor #{m.group(2)}")
    assert not missing, "\n".join(missing)


def test_anchor_helpers():
    assert slugify("The METT and the separation equation") == "the-mett-and-the-separation-equation"
    assert {"the-main-equation", "rational", "separation"} <= anchors(DOCS / "theory" / "mett.md")


# --- nothing user-visible cites private notes or machine paths -------------------------------

_PRIVATE = ["theory" + ".md", "design" + ".md", "style" + ".md", "seed" + "000", "seed" + " 000",
            "seed" + "-000", "/wo" + "rk/"]  # fmt: skip


def _hits(files: list[Path]) -> list[str]:
    out = []
    for f in files:
        for n, line in enumerate(f.read_text(encoding="utf-8").splitlines(), 1):
            low = line.lower()
            out += [f"{f.relative_to(ROOT)}:{n}: {w}" for w in _PRIVATE if w in low]
    return out


def test_docs_readme_and_notebooks_cite_only_what_ships():
    files = _markdown_files() + sorted((ROOT / "notebooks").glob("*.ipynb")) + [ROOT / "mkdocs.yml"]
    assert not _hits(files), "\n".join(_hits(files))


def test_code_and_tests_cite_only_what_ships():
    files = sorted((ROOT / "mett").rglob("*.py")) + sorted((ROOT / "tests").rglob("*.py"))
    files = [f for f in files if f.name != "test_docs.py"]
    assert not _hits(files), "\n".join(_hits(files))
