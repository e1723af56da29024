"""Project metadata: one version, one licence, and ``mett.show_versions()``.

CITATION.cff and pyproject.toml are read as text (PyYAML is not a test dependency; ``tomllib``
is in the standard library only from Python 3.11), so the checks look at their key lines.
"""

import importlib.metadata
import io
import pathlib
import re
import subprocess
import sys

import pytest

import mett
from mett import _versions

ROOT = pathlib.Path(__file__).resolve().parents[1]


def _top_level(text: str, key: str) -> str:
    """The value of a top-level ``key: value`` line of a YAML file (quotes stripped)."""
    found = re.findall(rf"^{re.escape(key)}:[ \t]*(.+?)[ \t]*$", text, flags=re.M)
    assert len(found) == 1, f"{key!r} must appear once at the top level, found {found}"
    return found[0].strip("'\"")


def _pyproject() -> str:
    return (ROOT / "pyproject.toml").read_text(encoding="utf-8")


def test_version_from_one_source():
    """pyproject takes its version from mett/_version.py (hatchling's dynamic version), so
    the wheel, ``mett.__version__`` and ``mett --version`` cannot disagree."""
    text = _pyproject()
    assert not re.search(r"^version\s*=", text, flags=re.M), "a static version in pyproject"
    assert re.search(r'^dynamic\s*=\s*\[[^\]]*"version"', text, flags=re.M)
    assert re.search(r'^\[tool\.hatch\.version\]\s*\npath\s*=\s*"mett/_version\.py"', text, re.M)
    source = (ROOT / "mett" / "_version.py").read_text(encoding="utf-8")
    assert re.findall(r'^__version__ = "([^"]+)"$', source, flags=re.M) == [mett.__version__]


def test_cli_version_is_the_package_version():
    out = subprocess.run(
        [sys.executable, "-m", "mett", "--version"], capture_output=True, text=True, check=True
    )
    assert out.stdout.strip() == f"mett {mett.__version__}"


def test_citation_version_and_license():
    cff = (ROOT / "CITATION.cff").read_text(encoding="utf-8")
    assert _top_level(cff, "cff-version") == "1.2.0"
    assert _top_level(cff, "version") == mett.__version__
    license_ = re.search(r'^license\s*=\s*\{\s*text\s*=\s*"([^"]+)"', _pyproject(), re.M)
    assert license_ is not None
    assert _top_level(cff, "license") == license_.group(1) == "BSD-3-Clause"
    assert re.search(r"^authors:\s*\n\s+- name: \"mett developers\"$", cff, flags=re.M)


def test_license_file_is_bsd3():
    text = (ROOT / "LICENSE").read_text(encoding="utf-8")
    assert text.startswith("BSD 3-Clause License")
    assert "Copyright (c) 2026, mett developers" in text
    assert "Neither the name of the copyright holder" in text  # clause 3, absent from BSD-2


def test_show_versions_prints_and_returns():
    buf = io.StringIO()
    info = mett.show_versions(file=buf)
    import numpy
    import scipy

    # independent of importlib.metadata: the imported modules' own attributes
    assert info["numpy"] == numpy.__version__
    assert info["scipy"] == scipy.__version__
    assert info["mett"] == mett.__version__
    assert info["python"].startswith(".".join(map(str, sys.version_info[:3])))
    for key in ("platform", "numba", "llvmlite", "sympy", "matplotlib", "mpmath", "pandas"):
        assert info[key] and info[key] != "not installed", key
    assert {"xarray", "dask", "heyoka"} <= info.keys()
    lines = buf.getvalue().splitlines()
    assert len(lines) == len(info)
    for line, (key, value) in zip(lines, info.items(), strict=True):
        assert re.fullmatch(rf"{re.escape(key)} +: {re.escape(value)}", line)
    assert mett.show_versions(file=buf, quiet=True) == info


def test_show_versions_missing_package(monkeypatch):
    name = "mett-no-such-distribution"
    with pytest.raises(importlib.metadata.PackageNotFoundError):
        importlib.metadata.version(name)
    monkeypatch.setattr(_versions, "PACKAGES", (*_versions.PACKAGES, name))
    assert mett.show_versions(quiet=True)[name] == "not installed"


def test_show_versions_imports_nothing_heavy():
    """A fresh process: the call reads metadata only, it does not import numba or the extras."""
    code = (
        "import sys, mett; before = set(sys.modules); mett.show_versions(quiet=True); "
        "new = {m.split('.')[0] for m in set(sys.modules) - before}; "
        "print(sorted(new & {'numba', 'llvmlite', 'sympy', 'matplotlib', 'pandas', "
        "'xarray', 'dask', 'heyoka'}))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
