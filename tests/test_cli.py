"""The `mett` command, run as a user would (subprocess)."""

from __future__ import annotations

import subprocess
import sys

import pytest


def run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "mett", *args], capture_output=True, text=True, timeout=120
    )


def test_info_prints_thesis_thresholds():
    out = run("info", "--preset", "rutstam2013")
    assert out.returncode == 0, out.stderr
    lines = dict(line.rsplit(None, 1) for line in out.stdout.strip().splitlines())
    assert float(lines["gamma = I1/I3"]) == pytest.approx(131 / 140, rel=1e-6)
    assert float(lines["sigma = m R^2/I3"]) == pytest.approx(2.5)
    assert float(lines["lambda_thres [kg m^3/s]"]) == pytest.approx(3.43888e-06, rel=1e-5)
    assert lines["rational METT"] == "True"
    assert lines["group"] == "II"
    assert float(lines["min omega3 to invert from theta0=0.1 [rad/s]"]) == pytest.approx(
        77.31, abs=0.01
    )


def test_info_with_explicit_parameters():
    out = run(
        "info", "--m", "0.02", "--R", "0.02", "--alpha", "0.3", "--I1", "3e-6", "--I3", "3.2e-6"
    )
    assert out.returncode == 0, out.stderr
    assert "group" in out.stdout


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["info", "--preset", "nope"], "unknown preset 'nope'"),
        (["info", "--preset", "rutstam2013", "--alpha", "1.5"], "alpha must lie in (0, 1)"),
        (["info", "--preset", "rutstam2013", "--m", "abc"], "invalid float value"),
        (["info", "--preset", "seed000"], "pass alpha"),
        (["info", "--m", "0.02"], "without --preset"),
        (["frobnicate"], "invalid choice"),
        ([], "required"),
    ],
)
def test_bad_arguments_give_one_line_and_exit_2(args, needle):
    out = run(*args)
    assert out.returncode == 2
    assert "Traceback" not in out.stderr
    assert len(out.stderr.strip().splitlines()) == 1, out.stderr
    assert needle in out.stderr
