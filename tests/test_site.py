"""The docs-site tooling: the mkdocs hook's plain-text titles, and the headless-browser checker.

``tools/check_site.py`` is run by ``.ci/run`` on the built site. Here it is pointed at a small
synthetic site with one good page and one page per defect it must report (raw TeX, a TeX error,
a request to another host, a broken image, a script error), so a checker that passes everything
fails this test. The browser test needs Chromium, its driver and selenium (``sitecheck`` extra);
it is marked slow; ``.ci/run`` runs this whole file after the site check.
"""

from __future__ import annotations

import importlib.util
import io
import shutil
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _load(name):
    spec = importlib.util.spec_from_file_location(name, ROOT / "tools" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize(
    ("tex", "text"),
    [
        (
            r"The potential $V(\cos\theta, D, \lambda)$: slices",
            "The potential V(cos θ, D, λ): slices",
        ),
        (r"\(\tilde E\) and $D_0$, $\dot\theta$", "E\u0303 and D₀, θ\u0307"),
        (r"$\omega_3$ against $\lambda_\text{thres}$", "ω₃ against λ_thres"),
        (r"$\Omega \le \pi$, $\sigma$, $\Sigma$", "Ω ≤ π, σ, Σ"),
        ("Reliability", "Reliability"),
        ("costs $5", "costs $5"),  # a lone dollar is not maths
        ("from $5 to $6", "from $5 to $6"),
    ],
)
def test_page_titles_without_tex(tex, text):
    pytest.importorskip("mkdocs")
    hooks = _load("mkdocs_hooks")
    html = hooks.on_post_page(f"<head><title>{tex} - mett</title></head>", _Page("a.md"), None)
    assert html == f"<head><title>{text} - mett</title></head>"


def test_notebook_pages_lose_the_nbconvert_mathjax_loader():
    pytest.importorskip("mkdocs")
    hooks = _load("mkdocs_hooks")
    block = '<!-- Load mathjax -->\n<script src="https://cdn/x.js"> </script>\n<!-- End of mathjax configuration -->'
    page = f"<title>t</title><div>{block}<p>$x$</p></div>"
    assert hooks.on_post_page(page, _Page("notebooks/a.ipynb"), None) == (
        "<title>t</title><div><p>$x$</p></div>"
    )
    assert hooks.on_post_page(page, _Page("a.md"), None) == page


class _Page:
    def __init__(self, src_uri):
        self.file = type("F", (), {"src_uri": src_uri})()


_CONFIG = """<script>window.MathJax = {startup: {elements: [".arithmatex"]}};</script>
<script src="mathjax/tex-mml-chtml.js"></script>"""
# a 1x1 PNG
_PNG = bytes.fromhex(
    "89504e470d0a1a0a0000000d4948445200000001000000010806000000"
    "1f15c4890000000d49444154789c6360f8cf00000301010018dd8db40000000049454e44ae426082"
)
_PAGES = {
    "good.html": f'{_CONFIG}<p><span class="arithmatex">\\(x^2 + \\tilde E\\)</span></p>'
    '<img src="dot.png"><pre>$ pip install mett</pre>',
    "raw.html": '<p><span class="arithmatex">\\(x^2\\)</span></p>',  # MathJax never loaded
    "texerror.html": f'{_CONFIG}<p><span class="arithmatex">\\(x^\\)</span></p>',
    "cdn.html": '<script src="https://cdn.example.org/mathjax.js"></script><p>text</p>',
    "image.html": '<p>text</p><img src="missing.png">',
    "script.html": '<script>throw new Error("boom")</script><p>text</p>',
}
_EXPECTED = {
    "raw.html": ["untypeset maths", "no typeset formula"],
    "texerror.html": ["TeX error"],
    "cdn.html": ["request to a non-local host: https://cdn.example.org/mathjax.js"],
    "image.html": ["broken image"],
    "script.html": ["console error", "boom"],
}


@pytest.mark.slow
def test_site_checker_reports_every_defect(tmp_path):
    pytest.importorskip("selenium")
    pytest.importorskip("mkdocs")
    if not (shutil.which("chromium") or shutil.which("chromium-browser")):
        pytest.skip("Chromium is not installed")
    if not shutil.which("chromedriver"):
        pytest.skip("the Chromium driver is not installed")
    hooks = _load("mkdocs_hooks")
    check_site = _load("check_site")
    (tmp_path / "mathjax").symlink_to(hooks.mathjax_root(), target_is_directory=True)
    (tmp_path / "dot.png").write_bytes(_PNG)
    for name, body in _PAGES.items():
        (tmp_path / name).write_text(f"<!doctype html><html><body>{body}</body></html>")
    out = io.StringIO()
    status = check_site.check_site(tmp_path, out=out)
    lines = out.getvalue().splitlines()
    assert status == 1
    assert not [line for line in lines if line.startswith("good.html")], lines
    for page, needles in _EXPECTED.items():
        mine = "\n".join(line for line in lines if line.startswith(page))
        for needle in needles:
            assert needle in mine, (page, needle, lines)
    assert lines[-1].startswith(f"site check: {len(_PAGES)} pages")
    assert "5 page(s) with problems" in lines[-1]
