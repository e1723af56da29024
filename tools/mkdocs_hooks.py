"""mkdocs hooks: the site typesets its maths with a MathJax 3 served from the site itself.

* ``on_files`` adds MathJax 3 (the ``es5`` build vendored by the ``django-static-mathjax``
  package, Apache-2.0, from the ``docs`` extra) to the site under ``javascripts/vendor/mathjax/``:
  the ``tex-mml-chtml`` component, the CHTML fonts and the components it loads on demand
  (TeX extensions, the accessibility and menu modules, speech rule maps). No page refers
  to a content-delivery network, so formulas render offline and from a file server.
* ``on_post_page`` removes the MathJax 2 loader and configuration that nbconvert writes into
  every notebook page (mkdocs-jupyter): it would fetch MathJax from a CDN and fight the site's
  MathJax 3 over ``window.MathJax``. The notebook's markdown cells are typeset by the site's
  MathJax 3 instead (``docs/javascripts/mathjax.js`` processes ``jp-RenderedMarkdown``).
"""

from __future__ import annotations

import importlib.resources
import re
from pathlib import Path

from mkdocs.structure.files import File, Files

#: where MathJax lands in the built site (``extra_javascript`` in mkdocs.yml names the loader)
SITE_DIR = "javascripts/vendor/mathjax"
#: the combined component the pages load, and the folders it loads from at run time
COMPONENT = "tex-mml-chtml.js"
ON_DEMAND = ("input/tex/extensions", "output/chtml/fonts/woff-v2", "a11y", "ui", "sre")
LICENSE = "LICENSE"

_NBCONVERT_MATHJAX = re.compile(
    r"<!-- Load mathjax -->.*?<!-- End of mathjax configuration -->", re.DOTALL
)


def mathjax_root() -> Path:
    """The ``es5`` folder of the MathJax 3 distribution installed with the ``docs`` extra."""
    try:
        root = importlib.resources.files("mathjax") / "static" / "mathjax" / "es5"
    except ModuleNotFoundError as exc:  # pragma: no cover - a missing docs extra
        raise RuntimeError(
            "the docs build needs MathJax 3 from the 'docs' extra: pip install -e '.[docs]'"
        ) from exc
    root = Path(str(root))
    if not (root / COMPONENT).is_file():
        raise RuntimeError(f"MathJax component {COMPONENT} not found in {root}")
    return root


def on_files(files: Files, config) -> Files:
    root = mathjax_root()
    sources = [root / COMPONENT, root.parent / LICENSE]
    for sub in ON_DEMAND:
        sources += sorted(p for p in (root / sub).rglob("*") if p.is_file())
    for src in sources:
        rel = (
            LICENSE if src.name == LICENSE and src.parent == root.parent else src.relative_to(root)
        )
        files.append(
            File.generated(config, f"{SITE_DIR}/{Path(rel).as_posix()}", abs_src_path=str(src))
        )
    return files


def on_post_page(output: str, page, config) -> str:
    if page.file.src_uri.endswith(".ipynb"):
        output = _NBCONVERT_MATHJAX.sub("", output)
    return output
