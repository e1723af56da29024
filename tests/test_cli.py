"""The `mett` command, run as a user would (subprocess)."""

from __future__ import annotations

import subprocess
import sys

import pytest


def run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "mett", *args], capture_output=True, text=True, timeout=120
    )


def assert_one_line_error(out: subprocess.CompletedProcess, needle: str) -> None:
    """Bad arguments: exit status 2, one line on stderr naming the problem, no traceback."""
    assert out.returncode == 2
    assert "Traceback" not in out.stderr
    assert len(out.stderr.strip().splitlines()) == 1, out.stderr
    assert needle in out.stderr


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
    assert_one_line_error(run(*args), needle)


def test_simulate_prints_inversion_time_and_writes_outputs(tmp_path):
    csv, png = tmp_path / "traj.csv", tmp_path / "theta.png"
    out = run(
        "simulate", "--preset", "rutstam2013", "--theta0", "0.1", "--omega3", "155",
        "--t-end", "7", "--out", str(csv), "--plot", str(png),
    )  # fmt: skip
    assert out.returncode == 0, out.stderr
    lines = dict(line.split(None, 1) for line in out.stdout.splitlines() if "  " in line)
    assert float(out.stdout.split("first theta = pi/2 [s]")[1].split()[0]) == pytest.approx(
        5.88, abs=0.01
    )
    assert "inverted" in lines["predicted"]
    import numpy as np

    data = np.genfromtxt(csv, delimiter=",", names=True)
    assert data["theta"][0] == pytest.approx(0.1) and data["t"][-1] == pytest.approx(7.0)
    assert png.stat().st_size > 10_000


def test_period_from_a_state_and_from_integrals():
    out = run(
        "period", "--preset", "rutstam2013", "--theta0", "1", "--omega3", "100", "--phidot", "5"
    )
    assert out.returncode == 0, out.stderr
    assert "0.05501395" in out.stdout  # theory.md §5
    line = next(ln for ln in out.stdout.splitlines() if ln.startswith("E [J]"))
    E, D, lam = (float(x.strip(",")) for x in line.split()[-3:])
    out2 = run(
        "period", "--preset", "rutstam2013", "--E", repr(E), "--D", repr(D), "--lam", repr(lam)
    )
    assert out2.returncode == 0, out2.stderr
    assert "0.05501395" in out2.stdout


def test_figures_command_writes_every_figure(tmp_path):
    from mett.gallery import FIGURES

    out = run("figures", "--out", str(tmp_path), "--no-animation", "--quiet")
    assert out.returncode == 0, out.stderr
    for name in FIGURES:
        assert (tmp_path / f"{name}.png").stat().st_size > 5_000
    assert "thesis fig. 4a" in (tmp_path / "README.md").read_text()


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["simulate", "--preset", "rutstam2013", "--theta0", "0.1", "--omega3", "155"], "--t-end"),
        (["simulate", "--preset", "rutstam2013", "--theta0", "4", "--omega3", "1", "--t-end", "1"],
         "theta must lie in [0, pi]"),
        (["simulate", "--preset", "rutstam2013", "--theta0", "0.1", "--omega3", "1", "--t-end", "-1"],
         "t_end"),
        (["simulate", "--preset", "rutstam2013", "--theta0", "0.1", "--omega3", "1", "--t-end", "1",
          "--model", "magic"], "invalid choice"),
        (["simulate", "--preset", "rutstam2013", "--theta0", "0.1", "--omega3", "1", "--t-end", "1",
          "--out", "x.txt"], "--out must end in .csv or .npz"),
        (["period", "--preset", "rutstam2013", "--E", "0.001", "--D", "1e-3", "--lam", "1e-6"],
         "no admissible motion"),
        (["period", "--preset", "rutstam2013", "--E", "0.01"], "give all of --E --D --lam"),
        (["period", "--preset", "rutstam2013"], "give --E --D --lam"),
    ],
)  # fmt: skip
def test_bad_arguments_of_the_other_commands(args, needle):
    assert_one_line_error(run(*args), needle)
