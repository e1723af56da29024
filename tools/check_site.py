"""Check a built docs site in a real headless browser (Chromium driven by Selenium).

Usage::

    mkdocs build --strict --site-dir SITE
    python tools/check_site.py SITE [--screenshots DIR]

The site is served from ``127.0.0.1`` and every HTML page is loaded in headless Chromium, with
every host name other than ``127.0.0.1`` unresolvable, so the check is the same with or without
network. A page fails when

* the browser console reports an error (a failed request, a script error, a MathJax error);
* a request leaves the local server (a CDN, a web font, a tracker);
* a formula is left untypeset: raw ``\\(``, ``\\[``, ``$$`` or ``$...$`` in the text that MathJax
  should have processed (formula markup, notebook markdown, navigation), or a TeX error box
  (``mjx-merror``);
* a page whose source carries maths has no typeset formula (``mjx-container``);
* an image is missing or broken (``naturalWidth == 0`` after load).

Exit status 0 when every page passes, 1 otherwise (one line per problem), 2 on bad usage.
Needs the ``sitecheck`` extra (selenium) and Chromium with its driver (Debian: ``apt-get install
chromium chromium-driver``); the driver is taken from ``PATH``, never downloaded.
"""

from __future__ import annotations

import argparse
import functools
import http.server
import json
import shutil
import sys
import threading
from pathlib import Path

#: seconds a page may take to load and typeset before it counts as broken (a hang, not a speed test)
PAGE_TIMEOUT = 60.0

#: hosts a page may request; everything else is mapped to an unresolvable name
LOCAL = "127.0.0.1"

# Runs in the page after load: waits for MathJax to finish typesetting (when it is on the page),
# then reports what is left to check. Text in code, pre, script and typeset maths is not looked at.
_INSPECT_JS = r"""
const done = arguments[arguments.length - 1];
const inspect = () => {
  const skip = "code, pre, script, style, mjx-container, textarea, .highlight, "
    + ".jp-CodeCell .jp-InputArea, .jp-OutputArea";
  const scopes = ".arithmatex, .jp-RenderedMarkdown, .md-sidebar, .md-header__topic, .md-content";
  const raw = [];
  const seen = new Set();
  for (const scope of document.querySelectorAll(scopes)) {
    const walker = document.createTreeWalker(scope, NodeFilter.SHOW_TEXT);
    for (let n = walker.nextNode(); n; n = walker.nextNode()) {
      if (seen.has(n) || !n.parentElement || n.parentElement.closest(skip)) continue;
      seen.add(n);
      const t = n.textContent;
      if (/\\\(|\\\[|\$\$|\$[^$\s][^$]*\$/.test(t)) raw.push(t.trim().slice(0, 80));
    }
  }
  const images = Array.from(document.images).map((img) => ({
    src: img.currentSrc || img.src,
    ok: img.complete && img.naturalWidth > 0,
  }));
  done({
    mathjax: typeof window.MathJax === "object" && !!window.MathJax.startup,
    formulas: document.querySelectorAll("mjx-container").length,
    merrors: document.querySelectorAll("mjx-merror").length,
    sourceMaths: document.querySelectorAll(".arithmatex").length
      + Array.from(document.querySelectorAll(".jp-RenderedMarkdown"))
          .filter((e) => /\$[^$]+\$/.test(e.textContent)).length,
    raw: raw,
    images: images,
  });
};
const settle = () => {
  const imgs = Array.from(document.images).filter((img) => !img.complete);
  Promise.all(imgs.map((img) => new Promise((r) => { img.onload = img.onerror = r; })))
    .then(() => {
      if (window.MathJax && window.MathJax.startup && window.MathJax.startup.promise) {
        window.MathJax.startup.promise.then(inspect, inspect);
      } else {
        inspect();
      }
    });
};
if (document.readyState === "complete") settle(); else window.addEventListener("load", settle);
"""


class _QuietHandler(http.server.SimpleHTTPRequestHandler):
    def log_message(self, format, *args):  # the base class logs every request to stderr
        pass


def serve(site: Path) -> tuple[http.server.ThreadingHTTPServer, str]:
    """Serve ``site`` on a free local port in a daemon thread; return the server and its URL."""
    handler = functools.partial(_QuietHandler, directory=str(site))
    server = http.server.ThreadingHTTPServer((LOCAL, 0), handler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    return server, f"http://{LOCAL}:{server.server_address[1]}/"


def browser(width: int = 1280, height: int = 1600):
    """Headless Chromium with console and network logging, every non-local host unresolvable."""
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    binary = shutil.which("chromium") or shutil.which("chromium-browser")
    driver = shutil.which("chromedriver")
    if not binary or not driver:
        raise RuntimeError(
            "Chromium and its driver are needed on PATH (Debian: apt-get install chromium "
            "chromium-driver)"
        )
    opts = webdriver.ChromeOptions()
    opts.binary_location = binary
    for arg in (
        "--headless=new",
        "--no-sandbox",  # CI runs as root
        "--disable-dev-shm-usage",
        "--disable-gpu",
        f"--window-size={width},{height}",
        f"--host-resolver-rules=MAP * ~NOTFOUND , EXCLUDE {LOCAL}",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
    ):
        opts.add_argument(arg)
    opts.set_capability("goog:loggingPrefs", {"browser": "ALL", "performance": "ALL"})
    drv = webdriver.Chrome(options=opts, service=Service(executable_path=driver))
    drv.set_page_load_timeout(PAGE_TIMEOUT)
    drv.set_script_timeout(PAGE_TIMEOUT)
    return drv


def pages(site: Path) -> list[str]:
    """Site-relative URLs of every HTML page (``index.html`` folders as their folder)."""
    urls = []
    for path in sorted(site.rglob("*.html")):
        rel = path.relative_to(site).as_posix()
        urls.append(rel[: -len("index.html")] if rel.endswith("index.html") else rel)
    return urls


def check_page(drv, base: str, rel: str) -> list[str]:
    """Load one page and return its problems, each a line of text (empty when it passes)."""
    drv.get_log("browser")  # drop what earlier pages left behind
    drv.get_log("performance")
    drv.get(base + rel)
    report = drv.execute_async_script(_INSPECT_JS)
    problems = []
    for entry in drv.get_log("browser"):
        if entry.get("level") == "SEVERE":
            problems.append(f"console error: {entry.get('message', '')[:200]}")
    for entry in drv.get_log("performance"):
        msg = json.loads(entry["message"])["message"]
        if msg.get("method") != "Network.requestWillBeSent":
            continue
        url = msg["params"]["request"]["url"]
        if not url.startswith((base, "data:", "blob:", "about:")):
            problems.append(f"request to a non-local host: {url[:200]}")
    for text in report["raw"]:
        problems.append(f"untypeset maths: {text!r}")
    if report["merrors"]:
        problems.append(f"{report['merrors']} formula(s) with a TeX error (mjx-merror)")
    if report["sourceMaths"] and not report["formulas"]:
        problems.append(f"{report['sourceMaths']} maths element(s) but no typeset formula")
    if report["sourceMaths"] and not report["mathjax"]:
        problems.append("maths on the page but MathJax did not start")
    for img in report["images"]:
        if not img["ok"]:
            problems.append(f"broken image: {img['src'][:200]}")
    return problems


def check_site(site: Path, screenshots: Path | None = None, out=sys.stdout) -> int:
    """Check every page of the built ``site``; print a line per problem and a summary."""
    from selenium.common.exceptions import TimeoutException

    urls = pages(site)
    if not urls:
        print(f"no HTML pages under {site}", file=out)
        return 1
    server, base = serve(site)
    drv = browser()
    failed = n_formulas = n_images = 0
    try:
        for rel in urls:
            try:
                problems = check_page(drv, base, rel)
            except TimeoutException:
                problems = [f"not loaded and typeset within {PAGE_TIMEOUT:g} s"]
            stats = drv.execute_script(
                "return [document.querySelectorAll('mjx-container').length, document.images.length]"
            )
            n_formulas += stats[0]
            n_images += stats[1]
            if screenshots is not None:
                screenshots.mkdir(parents=True, exist_ok=True)
                name = (rel.strip("/").replace("/", "__") or "index").removesuffix(".html")
                drv.save_screenshot(str(screenshots / f"{name}.png"))
            for p in problems:
                print(f"{rel or '/'}: {p}", file=out)
            failed += bool(problems)
    finally:
        drv.quit()
        server.shutdown()
    print(
        f"site check: {len(urls)} pages, {n_formulas} formulas typeset, {n_images} images; "
        f"{failed} page(s) with problems",
        file=out,
    )
    return 1 if failed else 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("site", type=Path, help="the built site (mkdocs build --site-dir)")
    parser.add_argument("--screenshots", type=Path, help="save a PNG of every page here")
    args = parser.parse_args(argv)
    if not (args.site / "index.html").is_file():
        parser.exit(2, f"check_site: {args.site} is not a built site (no index.html)\n")
    return check_site(args.site, args.screenshots)


if __name__ == "__main__":
    sys.exit(main())
