"""mkdocs hooks: the site typesets its maths with a MathJax 3 served from the site itself.

* ``on_files`` adds MathJax 3 (the ``es5`` build vendored by the ``django-static-mathjax``
  package, Apache-2.0, from the ``docs`` extra) to the site under ``javascripts/vendor/mathjax/``:
  the ``tex-mml-chtml`` component, the CHTML fonts and the components it loads on demand
  (TeX extensions, the accessibility and menu modules, speech rule maps). No page refers
  to a content-delivery network, so formulas render offline and from a file server.
* ``on_post_page`` writes the maths of a page title as plain text in ``<title>`` (a browser tab
  cannot typeset: "The potential $V(\\cos\\theta, D)$" becomes "The potential V(cos θ, D)"); the
  title in the navigation and the page header is typeset by MathJax.
* ``on_post_page`` also removes the MathJax 2 loader and configuration that nbconvert writes into
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


_TITLE = re.compile(r"<title>(.*?)</title>", re.DOTALL)
# TeX's $...$ opens and closes next to a non-space: "costs $5 and $6" holds no maths
_MATH = re.compile(r"\$\$(.+?)\$\$|\$(?=\S)(.+?)(?<=\S)\$|\\\((.+?)\\\)|\\\[(.+?)\\\]", re.DOTALL)
_GREEK = (
    "alpha beta gamma delta epsilon zeta eta theta iota kappa lambda mu nu xi omicron pi rho "
    "sigma tau upsilon phi chi psi omega"
).split()
# in Unicode's Greek block, sigma is preceded by a final sigma (lower case) and a gap (capitals)
_SYMBOLS = {rf"\{name}": chr(0x3B1 + i + (i >= 17)) for i, name in enumerate(_GREEK)}
_SYMBOLS.update({rf"\{n.capitalize()}": chr(0x391 + i + (i >= 17)) for i, n in enumerate(_GREEK)})
_SYMBOLS.update({r"\infty": "∞", r"\approx": "≈", r"\le": "≤", r"\ge": "≥", r"\times": "×"})


def tex_to_text(tex: str) -> str:
    """A readable plain-text form of a short TeX formula, for places that cannot typeset it."""
    for name in sorted(_SYMBOLS, key=len, reverse=True):
        tex = re.sub(re.escape(name) + r"(?![A-Za-z])", _SYMBOLS[name], tex)
    accents = {"tilde": "\u0303", "dot": "\u0307", "hat": "\u0302", "bar": "\u0304"}
    tex = re.sub(r"\\(tilde|dot|hat|bar)\s*\{?([^\W\d_])\}?", lambda m: m[2] + accents[m[1]], tex)
    tex = re.sub(
        r"_\{?(\d+)\}?", lambda m: m[1].translate(str.maketrans("0123456789", "₀₁₂₃₄₅₆₇₈₉")), tex
    )
    tex = re.sub(r"\\(?:text|mathrm|mathit|operatorname)\{([^{}]*)\}", r"\1", tex)
    tex = re.sub(r"\\([A-Za-z]+) ?", r"\1 ", tex)  # \cos\theta -> cos θ
    tex = re.sub(r"[{}]|\\[,;! ]", "", tex)
    return re.sub(r"\s+", " ", tex).replace(" )", ")").strip()


def _plain_title(match: re.Match) -> str:
    title = _MATH.sub(lambda m: tex_to_text(next(g for g in m.groups() if g)), match.group(1))
    return f"<title>{title}</title>"


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
    output = _TITLE.sub(_plain_title, output, count=1)
    if page.file.src_uri.endswith(".ipynb"):
        output = _NBCONVERT_MATHJAX.sub("", output)
    return output
