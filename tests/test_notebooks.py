"""The tutorial notebooks: committed with their outputs, and those outputs are what the code prints.

The notebooks are stored executed (figures and numbers visible on the docs site, which shows
them with mkdocs-jupyter ``execute: false``, and on the repository page). ``test_notebook_outputs_
are_current`` runs each in a fresh ``python3`` kernel (nbclient, ipykernel from the ``notebooks``
extra) with the same functions as ``tools/run_notebooks.py``, the script that refreshes them, and
compares every cell's fresh text output with the committed one: same words, same integers,
decimals within one unit in their last printed digit (rounding differences between machines; a
real change moves a value by much more), figures by presence. A cell that raises fails with its
traceback. The notebooks also assert their own checks (e.g. the simulated end state against the
prediction).
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = sorted((ROOT / "notebooks").glob("*.ipynb"))

_spec = importlib.util.spec_from_file_location("run_notebooks", ROOT / "tools" / "run_notebooks.py")
run_notebooks = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(run_notebooks)


def _read(path):
    nbformat = pytest.importorskip("nbformat")
    nb = nbformat.read(path, as_version=4)
    nbformat.validate(nb)
    return nb


def test_the_three_user_stories_have_notebooks():
    assert [p.stem for p in NOTEBOOKS] == [
        "01_your_own_top",
        "02_potential",
        "03_simulate_and_check",
    ]


def test_the_docs_show_the_same_notebooks():
    # one source of truth: docs/notebooks is a link to notebooks/, not a copy
    docs = ROOT / "docs" / "notebooks"
    assert docs.is_symlink() and docs.resolve() == (ROOT / "notebooks").resolve()


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_notebook_is_stored_with_outputs(path):
    nb = _read(path)
    code = [c for c in nb.cells if c.cell_type == "code"]
    assert code
    # executed top to bottom, in one run
    assert [c.execution_count for c in code] == list(range(1, len(code) + 1))
    outputs = [o for c in code for o in c.outputs]
    assert not [o for o in outputs if o.output_type == "error"]
    assert not [o for o in outputs if o.output_type == "stream" and o.name == "stderr"], (
        "a warning or log line in a stored output"
    )
    assert any(kind == "image" for c in code for kind, _ in run_notebooks.text_outputs(c)), (
        "every tutorial draws at least one figure"
    )
    # stored as tools/run_notebooks.py writes it: nothing of the machine or the run
    assert "widgets" not in nb.metadata
    assert nb.metadata.language_info == {"name": "python"}
    assert not [c for c in code if "execution" in c.metadata]
    live = [c for c in code if run_notebooks.LIVE_ONLY in c.metadata.get("tags", [])]
    assert all(c.outputs == [] for c in live)
    for c in code:
        for _, text in run_notebooks.text_outputs(c):
            assert not run_notebooks.MACHINE_PATH.search(text), text


def test_machine_path_pattern():
    for leak in ("/home/alice/mett/x.py", "at /tmp/tmpab12/out.csv", "C:\\Users\\bob"):
        assert run_notebooks.MACHINE_PATH.search(leak), leak
    for fine in ("lambda / lambda_thres = 2.0049", "kg m^3/s", "T(D0)/T(D1)", "m/s"):
        assert not run_notebooks.MACHINE_PATH.search(fine), fine


@pytest.mark.parametrize(
    ("committed", "now", "same"),
    [
        ("theta = 3.137882, n = 3", "theta = 3.137882, n = 3", True),
        ("theta = 3.137882", "theta = 3.137883", True),  # one unit in the last digit: rounding
        ("theta = 3.137882", "theta = 3.137884", False),  # two units: a real change
        ("T = 0.02558 s", "T = -0.02558 s", False),  # a sign error
        ("diff: 4.1e-05", "diff: 4.2e-05", True),
        ("diff: 4.1e-05", "diff: 4.1e-04", False),  # a factor 10 in the exponent
        ("group II, 400 points", "group II, 401 points", False),  # integers are exact
        ("inverted at 5.880 s", "tumbling at 5.880 s", False),  # the words are exact
        ("lambda = 2.0049", "lambda = 2.0049 (bistable)", False),
        ("1.5", "1.50", True),  # the coarser of the two printed precisions
    ],
)
def test_compare_text(committed, now, same):
    assert (run_notebooks.compare_text(committed, now) is None) is same


@pytest.mark.slow
@pytest.mark.parametrize(
    "path",
    # CI runs all three: the docs site shows their committed outputs without executing them
    [pytest.param(p, marks=pytest.mark.ci) for p in NOTEBOOKS],
    ids=lambda p: p.stem,
)
def test_notebook_outputs_are_current(path):
    pytest.importorskip("nbclient")
    pytest.importorskip("ipykernel")
    committed = _read(path)
    fresh = run_notebooks.execute(path)
    code_then = [c for c in committed.cells if c.cell_type == "code"]
    code_now = [c for c in fresh.cells if c.cell_type == "code"]
    assert [c.source for c in code_now] == [c.source for c in code_then]
    stale = []
    for i, (then, now) in enumerate(zip(code_then, code_now, strict=True), start=1):
        out_then, out_now = run_notebooks.text_outputs(then), run_notebooks.text_outputs(now)
        if [k for k, _ in out_then] != [k for k, _ in out_now]:
            stale.append(f"cell {i}: outputs {out_then} are now {out_now}")
            continue
        for (kind, text_then), (_, text_now) in zip(out_then, out_now, strict=True):
            if kind == "image":
                continue  # figures: by presence and type, not bytes
            diff = run_notebooks.compare_text(text_then, text_now)
            if diff:
                stale.append(f"cell {i}: {diff}")
    assert not stale, (
        "the committed outputs are stale; refresh with `python tools/run_notebooks.py` and "
        "commit:\n" + "\n".join(stale)
    )
