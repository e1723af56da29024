// MathJax 3 configuration. MathJax itself is served by this site (javascripts/vendor/mathjax/,
// copied at build time by tools/mkdocs_hooks.py), never from a CDN, so the maths renders offline.
//
// Only these containers are typeset (startup.elements), each with everything inside it:
// - .arithmatex: the maths of the markdown pages, wrapped by pymdownx.arithmatex (generic mode)
//   with \( \) inline and \[ \] display delimiters;
// - .jp-RenderedMarkdown: a notebook markdown cell (mkdocs-jupyter), with $...$ and $$...$$ as
//   written in the notebook;
// - .md-sidebar, .md-header__topic: the navigation, the table of contents and the page title,
//   which repeat a heading's maths as plain text.
// Everything else (code, console output, the page text outside these) is left alone, so a "$" in
// a shell example stays a "$".
const MATH_CONTAINERS = [".arithmatex", ".jp-RenderedMarkdown", ".md-sidebar", ".md-header__topic"];

window.MathJax = {
  tex: {
    inlineMath: [
      ["\\(", "\\)"],
      ["$", "$"],
    ],
    displayMath: [
      ["\\[", "\\]"],
      ["$$", "$$"],
    ],
    processEscapes: true,
    processEnvironments: true,
  },
  startup: {
    elements: MATH_CONTAINERS,
  },
};

// MathJax typesets the first page itself (startup.elements); when mkdocs-material swaps in another
// page's content (instant loading), typeset that again, queued after any typesetting under way
// (two passes over the same nodes at once corrupt the page).
let firstPage = true;
document$.subscribe(() => {
  if (firstPage) {
    firstPage = false;
    return;
  }
  MathJax.startup.promise = MathJax.startup.promise.then(() => {
    MathJax.typesetClear();
    return MathJax.typesetPromise(MATH_CONTAINERS.flatMap((s) => [...document.querySelectorAll(s)]));
  });
});
