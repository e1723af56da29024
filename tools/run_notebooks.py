"""Execute the tutorial notebooks and store them with their outputs.

Usage (from the repository root, with the ``test`` or ``dev`` extra installed)::

    python tools/run_notebooks.py            # refresh every notebook in notebooks/
    python tools/run_notebooks.py notebooks/02_potential.ipynb

The notebooks are committed with their outputs, so the docs site (mkdocs-jupyter,
``execute: false``) and the repository page show figures and numbers without a kernel.
``tests/test_notebooks.py`` executes them again with the same functions and compares the fresh
text outputs with the committed ones (:func:`compare_text`), so stale outputs fail the tests: run
this script after changing a notebook or anything its outputs depend on, and commit the result.

Each notebook runs top to bottom in a fresh ``python3`` kernel, in a temporary working directory,
importing the ``mett`` of this repository, with matplotlib's inline backend. The stored file is
normalised so that it depends on the notebook and the library only, not on the machine or the run:
no timings, no widget state, the generic ``language_info``, and no outputs for cells tagged
``live-only`` (interactive widgets, which need a live kernel and would otherwise store widget state
that the site could only render with scripts from a CDN).
"""

from __future__ import annotations

import argparse
import math
import os
import re
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = ROOT / "notebooks"
#: cells with this tag keep no output (they need a live kernel: widgets)
LIVE_ONLY = "live-only"
#: seconds one cell may run before the execution counts as hung
CELL_TIMEOUT = 600

# A number as printed: a decimal with a fraction or an exponent (compared within one unit in its
# last printed digit), or an integer (compared exactly: counts, labels, group numbers).
_NUMBER = re.compile(r"(?<![\w.])[-+]?(?:\d+\.\d+(?:[eE][-+]?\d+)?|\d+[eE][-+]?\d+|\d+)(?!\w|\.\d)")
# an absolute path of this machine (a home, a temporary or a work directory, an installation)
MACHINE_PATH = re.compile(r"(?<![\w.])(?:/(?:home|tmp|work|root|usr|opt|Users)/|[A-Za-z]:\\)")


def execute(path: Path, timeout: int = CELL_TIMEOUT):
    """Run the notebook at ``path`` in a fresh kernel; return it, executed and normalised."""
    import nbclient
    import nbformat

    nb = nbformat.read(path, as_version=4)
    env = dict(os.environ)
    env.pop("MPLBACKEND", None)  # the kernel draws with the inline backend
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), env.get("PYTHONPATH")]))
    from jupyter_client.manager import KernelManager

    with tempfile.TemporaryDirectory() as cwd:
        # The kernel talks over Unix sockets in this private directory, not TCP ports: a port is
        # chosen by binding and releasing it, and another process of a parallel test run (a Dask
        # cluster, another kernel) can take it in between, leaving the client waiting for ever.
        km = KernelManager(kernel_name="python3", transport="ipc", ip=os.path.join(cwd, "kernel"))
        client = nbclient.NotebookClient(
            nb,
            km=km,
            timeout=timeout,
            kernel_name="python3",
            resources={"metadata": {"path": cwd}},
            record_timing=False,
        )
        # the kernel is a subprocess: it takes the environment at start
        saved = dict(os.environ)
        os.environ.clear()
        os.environ.update(env)
        try:
            client.execute()
        finally:
            os.environ.clear()
            os.environ.update(saved)
    return normalise(nb)


def normalise(nb):
    """Strip what depends on the machine or the run (in place); return ``nb``."""
    nb.metadata.pop("widgets", None)
    nb.metadata["language_info"] = {"name": "python"}
    for cell in nb.cells:
        cell.metadata.pop("execution", None)
        if cell.cell_type == "code" and LIVE_ONLY in cell.metadata.get("tags", []):
            cell.outputs = []
    return nb


def text_outputs(cell) -> list[tuple[str, str]]:
    """The outputs of a code cell as (kind, text) pairs; a figure is ("image", mime types)."""
    out = []
    for o in cell.get("outputs", []):
        if o.output_type == "stream":
            out.append((o.name, o.text))
        elif o.output_type == "error":
            out.append(("error", f"{o.ename}: {o.evalue}"))
        else:
            data = o.get("data", {})
            images = sorted(k for k in data if k.startswith("image/"))
            if images:
                out.append(("image", " ".join(images)))
            elif "text/plain" in data:
                out.append((o.output_type, data["text/plain"]))
    # consecutive stream chunks are one text (the split depends on buffering)
    merged: list[tuple[str, str]] = []
    for kind, text in out:
        if merged and kind in ("stdout", "stderr") and merged[-1][0] == kind:
            merged[-1] = (kind, merged[-1][1] + text)
        else:
            merged.append((kind, text))
    return merged


def _last_digit(s: str) -> float:
    """One unit in the last printed digit of the decimal ``s`` ("1.25e-03" -> 1e-5)."""
    mantissa, _, exponent = s.lower().partition("e")
    decimals = len(mantissa.partition(".")[2])
    return 10.0 ** (int(exponent or 0) - decimals)


def compare_text(expected: str, actual: str) -> str | None:
    """``None`` when ``actual`` prints the same as ``expected``, else what differs.

    The words must be identical. Integers must be identical. A decimal may differ by one unit in
    its last printed digit: two runs whose results differ by less than that unit (rounding
    differences of the platform's maths library) can round to neighbouring printed values, and a
    real change (a sign, a factor, a wrong branch) moves the value by far more.
    """
    e_words, a_words = _NUMBER.split(expected), _NUMBER.split(actual)
    e_nums, a_nums = _NUMBER.findall(expected), _NUMBER.findall(actual)
    if e_words != a_words or len(e_nums) != len(a_nums):
        return f"text differs:\n--- committed\n{expected}\n--- now\n{actual}"
    for e, a in zip(e_nums, a_nums, strict=True):
        decimal = any(c in e for c in ".eE")
        if not decimal:
            if e != a:
                return f"integer {e} is now {a} in:\n{actual}"
            continue
        unit = max(_last_digit(e), _last_digit(a))
        # a tiny relative slack so that the decimal conversion itself cannot fail the comparison
        if not math.isclose(float(e), float(a), rel_tol=0, abs_tol=unit * (1 + 1e-9)):
            return f"{e} is now {a} (more than one unit in the last digit) in:\n{actual}"
    return None


def main(argv: list[str] | None = None) -> int:
    import nbformat

    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("paths", nargs="*", type=Path, help="notebooks (default: all)")
    args = parser.parse_args(argv)
    paths = args.paths or sorted(NOTEBOOKS.glob("*.ipynb"))
    for path in paths:
        if path.suffix != ".ipynb" or not path.is_file():
            parser.exit(2, f"run_notebooks: {path} is not a notebook file\n")
    for path in paths:
        nb = execute(path)
        leaks = [
            text
            for cell in nb.cells
            if cell.cell_type == "code"
            for _, text in text_outputs(cell)
            if MACHINE_PATH.search(text)
        ]
        if leaks:
            print(f"{path.name}: an output shows a machine path: {leaks[0][:200]!r}")
            return 1
        nbformat.write(nb, path)
        print(f"{path.name}: executed and stored with its outputs")
    return 0


if __name__ == "__main__":
    sys.exit(main())
