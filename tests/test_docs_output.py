"""Printed output in the docs is what the code prints, so drift fails.

Every ``console`` fenced block of README.md and docs/**/*.md is a sequence of ``$ mett ...``
commands, each followed by the output it prints. Each command is run in a fresh process (``python
-m mett``) and its standard output compared with the block line by line. A block preceded by an
HTML comment starting with ``<!-- no-test`` (saying why) is skipped. A block may end its output
with a line ``...`` to show only the first lines.
"""

from __future__ import annotations

import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
FENCE = re.compile(r"^```console[^\n]*\n(.*?)^```[ \t]*$", re.M | re.S)
NO_TEST = re.compile(r"<!--\s*no-test\b[^>]*-->\s*$")


def console_commands(text: str) -> list[tuple[int, str, list[str]]]:
    """(line number, command, printed lines) of every ``$ mett`` command of the console blocks."""
    out = []
    for m in FENCE.finditer(text):
        before = text[: m.start()].rstrip("\n").splitlines()
        if before and NO_TEST.search(before[-1]):
            continue
        first = text.count("\n", 0, m.start()) + 2
        current = None  # lines before the block's first command are not output
        for i, line in enumerate(m.group(1).splitlines()):
            if line.startswith("$ "):
                current = (first + i, line[2:], [])
                out.append(current)
            elif current is not None:
                current[2].append(line)
    return out


def _cases():
    files = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
    for path in files:
        for line, command, printed in console_commands(path.read_text(encoding="utf-8")):
            yield pytest.param(command, printed, id=f"{path.relative_to(ROOT)}:{line}")


CASES = list(_cases())


def test_parser_reads_commands_outputs_and_the_opt_out():
    text = (
        "```console\n$ mett a\nx  1\ny  2\n$ mett b\n```\n\n"
        "<!-- no-test: why -->\n```console\n$ mett c\nz\n```\n"
    )
    assert [(c, p) for _, c, p in console_commands(text)] == [
        ("mett a", ["x  1", "y  2"]),
        ("mett b", []),
    ]
    assert CASES, "the docs show no console output any more: drop this test or the claim"


@pytest.mark.parametrize(("command", "printed"), CASES)
def test_printed_output_matches(command, printed):
    argv = shlex.split(command)
    assert argv[0] == "mett", f"only mett commands are run: {command!r}"
    run = subprocess.run(
        [sys.executable, "-m", "mett", *argv[1:]], capture_output=True, text=True, check=True
    )
    actual = run.stdout.rstrip("\n").splitlines()
    if printed and printed[-1] == "...":
        printed = printed[:-1]
        actual = actual[: len(printed)]
    assert actual == printed, f"{command!r} now prints:\n{run.stdout}"
