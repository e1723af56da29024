"""`mett sweep --grid` forms, options a grid axis makes meaningless (command line and library),
and the CSV/NetCDF outputs of `mett simulate` and `mett sweep` end to end."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pandas as pd
import pytest

import mett
from mett.friction import Coulomb

TOP = mett.presets.get("rutstam2013")
THESIS = ["--preset", "rutstam2013"]
SWEEP = ["sweep", *THESIS, "--t-end", "0.01"]


def call(argv, capsys):
    from mett.cli import main

    try:
        code = main([str(a) for a in argv])
    except SystemExit as exc:
        code = exc.code
    out = capsys.readouterr()
    return code, out.out, out.err


def assert_error(result, needle: str) -> None:
    code, _, err = result
    assert code == 2, err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1, err
    assert needle in err, err


@pytest.fixture
def grids(monkeypatch):
    """The grids (and options) the command line hands to mett.sweep, without running it."""
    import mett.sweeps

    seen = []

    def fake(top, grid, **kw):
        seen.append((grid, kw))
        raise KeyboardInterrupt  # stops the command (exit 130) before anything is written

    monkeypatch.setattr(mett.sweeps, "sweep", fake)
    return seen


# --- the forms of --grid ---------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("spec", "want"),
    [
        ("mu=0.1:0.3:3", [0.1, 0.2, 0.3]),
        ("mu=0.1,0.2,0.5", [0.1, 0.2, 0.5]),
        ("mu=0.25", [0.25]),
        ("theta0=0.3, 0.1", [0.3, 0.1]),  # a list keeps its order
        ("omega3=-1e2,1e2", [-100.0, 100.0]),
    ],
)
def test_linear_and_list_axes(spec, want, grids, capsys):
    code, _, err = call([*SWEEP, "--grid", spec], capsys)
    assert code == 130, err
    ((grid, _),) = grids
    (values,) = grid.values()
    # linspace's interior points are k·(stop − start)/(num − 1) + start: within 2 ulp
    np.testing.assert_allclose(values, want, rtol=4 * np.finfo(float).eps, atol=0)
    assert values[0] == want[0] and values[-1] == want[-1]


def test_log_axis_is_geometric(grids, capsys):
    code, _, err = call([*SWEEP, "--grid", "mu=log:0.01:1:9"], capsys)
    assert code == 130, err
    values = grids[0][0]["mu"]
    # independent reference: 10^(-2 + k/4); both are correctly rounded to a few ulp
    want = 10.0 ** np.linspace(-2.0, 0.0, 9)
    np.testing.assert_allclose(values, want, rtol=8 * np.finfo(float).eps, atol=0)
    assert values[0] == 0.01 and values[-1] == 1.0
    ratios = values[1:] / values[:-1]
    np.testing.assert_allclose(ratios, 10**0.25, rtol=16 * np.finfo(float).eps)


def test_a_friction_axis_names_laws(grids, capsys):
    code, _, err = call([*SWEEP, "--grid", "friction=viscous,coulomb", "--grid", "mu=0.3"], capsys)
    assert code == 130, err
    assert grids[0][0]["friction"] == ["viscous", "coulomb"]


@pytest.mark.parametrize(
    ("spec", "needle"),
    [
        ("mu", "--grid takes NAME=START:STOP:NUM, log:START:STOP:NUM"),
        ("=1,2", "--grid takes NAME="),
        ("mu=0:1", "--grid mu=0:1: not one of the forms; give mu=START:STOP:NUM, log:"),
        ("mu=0:1:2:3", "--grid mu=0:1:2:3: not one of the forms"),
        ("mu=log:0:1:3", "--grid mu=log:0:1:3: log spacing needs START, STOP > 0"),
        ("mu=log:-1:1:3", "log spacing needs START, STOP > 0"),
        ("mu=log:0.1:1", "--grid mu=log:0.1:1: not one of the forms"),
        ("mu=0:1:2.5", "NUM an integer"),
        ("mu=0:1:0", "NUM must lie in [1, 1000000]"),
        ("mu=a:1:3", "START and STOP must be numbers"),
        ("mu=0.1,,0.2", "--grid mu=0.1,,0.2: a list takes numbers; give mu=START:STOP:NUM"),
        ("mu=0.1,x", "a list takes numbers"),
        ("mu=0.1,inf", "--grid mu=0.1,inf: the values must be finite"),
        ("mu=", "a list takes numbers"),
        ("friction=viscous,dry", "--grid friction=... takes a list of viscous, coulomb"),
    ],
)
def test_malformed_axes_are_one_line_naming_the_axis_and_the_forms(spec, needle, grids, capsys):
    assert_error(call([*SWEEP, "--grid", spec], capsys), needle)
    assert grids == []


# --- options an axis makes meaningless: refused, never ignored --------------------------------------
@pytest.mark.parametrize(
    ("argv", "needle"),
    [
        (["--grid", "mu=0.1,0.2", "--mu", "0.3"], "--mu is ignored when --grid varies mu"),
        (["--grid", "m=0.01,0.02", "--m", "0.02"], "--m is ignored when --grid varies m"),
        (["--grid", "gamma=0.9,1", "--I1", "3e-6"], "--I1 is ignored when --grid varies gamma"),
        (["--grid", "theta0=0.1,0.2", "--theta0", "0.1"], "--theta0 is ignored when --grid varies"),
        (["--grid", "omega3=100,200", "--omega3", "155"], "--omega3 is ignored when --grid varies"),
        (["--grid", "lam_ratio=1,2", "--omega3", "155"], "--omega3 is ignored when --grid varies "
                                                         "lam_ratio"),
        (["--grid", "mu=0.1,0.2", "--friction", "coulomb:0.3"], "fixes mu, so the grid axis 'mu'"),
        (["--grid", "friction=viscous,coulomb", "--friction", "coulomb:0.3"],
         "friction= and a grid axis 'friction' both set the friction law"),
        (["--grid", "contensou_radius=0,1e-3", "--friction", "coulomb:0.3"],
         "is a law given whole, with its own contensou_radius"),
        (["--grid", "contensou_radius=0,1e-3"], "a grid axis 'contensou_radius' needs the Coulomb"),
        (["--grid", "omega3=100,200", "--grid", "lam_ratio=1,2"], "lam_ratio or omega3, not both"),
        (["--grid", "I1=3e-6", "--grid", "gamma=0.9"], "gamma or I1, not both"),
        (["--grid", "mu=0.1", "--grid", "mu=0.2"], "--grid 'mu' is given twice"),
        (["--friction", "coulomb:0.3", "--mu", "0.2", "--grid", "theta0=0.1"], "--mu is ignored"),
        (["--grid", "mu=0.1,0.2", "--model", "rolling"], "the grid axis 'mu' has no effect on "
                                                         "model='rolling'"),
    ],
)  # fmt: skip
def test_options_a_grid_axis_overrides_are_refused(argv, needle, capsys, monkeypatch):
    import mett.dynamics

    def no_run(*a, **k):
        raise AssertionError("a run started before the options were refused")

    monkeypatch.setattr(mett.dynamics, "simulate", no_run)
    monkeypatch.setattr(mett.sweeps, "_run_chunk", no_run)
    assert_error(call([*SWEEP, *argv], capsys), needle)


@pytest.mark.parametrize(
    ("grid", "kw", "needle"),
    [
        ({"contensou_radius": [0.0, 1e-3]}, {"friction": Coulomb(0.3)},
         "is a law given whole, with its own contensou_radius"),
        ({"contensou_radius": [0.0, 1e-3]}, {}, "a grid axis 'contensou_radius' needs the Coulomb"),
        ({"contensou_radius": [0.0, 1e-3]}, {"friction": "viscous"}, "needs the Coulomb law"),
        ({"thetadot": [0.0, 1.0]}, {"thetadot": 0.5}, "thetadot=0.5 is ignored"),
        ({"nu_x": [0.0]}, {"nu_x": 0.1}, "nu_x=0.1 is ignored"),
        ({"mu": [0.1, 0.2]}, {"model": "frictionless-routhian"}, "has no effect on model="),
        ({"mu": [0.1, 0.2]}, {"model": "rolling"}, "conserves the energy"),
    ],
)  # fmt: skip
def test_the_library_refuses_the_same_pairs(grid, kw, needle, monkeypatch):
    import mett.sweeps

    monkeypatch.setattr(mett.sweeps, "_run_chunk", lambda *a: pytest.fail("ran"))
    with pytest.raises(ValueError, match=needle):
        mett.sweep(TOP, grid, t_end=0.01, progress=False, **kw)


def test_a_contensou_axis_with_coulomb_by_name_runs_each_radius():
    table = mett.sweep(TOP, {"contensou_radius": [0.0, 1e-3]}, t_end=0.01, friction="coulomb",
                       progress=False)  # fmt: skip
    st = mett.State(theta=0.1, omega3=155.0)
    for r, theta_end in zip(table["contensou_radius"], table["theta_end"], strict=True):
        ref = mett.simulate(TOP, st, 0.01, friction=Coulomb(TOP.mu, contensou_radius=r))
        assert theta_end == ref.theta[-1]


# --- outputs, end to end -------------------------------------------------------------------------
def test_simulate_writes_csv_and_netcdf_as_the_library_does(tmp_path, capsys):
    argv = ["simulate", *THESIS, "--theta0", "0.1", "--omega3", "155", "--t-end", "0.05",
            "--friction", "coulomb:0.3", "--rtol", "1e-9"]  # fmt: skip
    ref = mett.simulate(TOP, mett.State(theta=0.1, omega3=155.0), 0.05, friction=Coulomb(0.3),
                        rtol=1e-9)  # fmt: skip
    code, _, err = call([*argv, "--out", tmp_path / "t.csv"], capsys)
    assert code == 0, err
    df = pd.read_csv(tmp_path / "t.csv", comment="#")
    np.testing.assert_array_equal(df["theta [rad]"], ref.theta)
    data = np.loadtxt(tmp_path / "t.csv", delimiter=",", skiprows=1)
    np.testing.assert_array_equal(data[:, 0], ref.t)
    header = (tmp_path / "t.csv").read_text()
    assert "# rtol: 1e-09" in header and "# t_end: 0.05 s" in header
    assert "# friction: Coulomb(mu=0.3)" in header
    code, _, err = call([*argv, "--out", tmp_path / "t.nc"], capsys)
    assert code == 0, err
    back = mett.load(tmp_path / "t.nc")
    np.testing.assert_array_equal(back.theta, ref.theta)
    assert back.rtol == 1e-9 and back.t_end == 0.05 and back.options == ref.options


def test_a_partial_run_is_written_and_exits_1(tmp_path, capsys):
    argv = ["simulate", *THESIS, "--theta0", "1.5", "--omega3", "0", "--thetadot", "100",
            "--t-end", "1", "--out", tmp_path / "t.nc", "--stop-on-contact-loss"]  # fmt: skip
    code, out, _ = call(argv, capsys)
    assert code == 1 and "contact_lost" in out
    assert mett.load(tmp_path / "t.nc").status == "contact_lost"
    code, out, _ = call(["simulate", "--help"], capsys)
    assert "exit 1" in " ".join(out.split())


def test_netcdf_without_xarray_is_refused_before_the_run(tmp_path, capsys, monkeypatch):
    import mett.dynamics

    monkeypatch.setitem(sys.modules, "xarray", None)
    monkeypatch.setattr(mett.dynamics, "simulate", lambda *a, **k: pytest.fail("ran"))
    argv = ["simulate", *THESIS, "--theta0", "0.1", "--omega3", "155", "--t-end", "0.05"]
    assert_error(call([*argv, "--out", tmp_path / "t.nc"], capsys),
                 "--out .nc needs xarray: pip install 'mett[xarray]'")  # fmt: skip
    assert_error(call([*SWEEP, "--grid", "mu=0.1", "--out", tmp_path / "s.nc"], capsys),
                 "needs xarray")  # fmt: skip
    assert list(tmp_path.iterdir()) == []


def test_sweep_writes_its_table_as_csv_and_netcdf_subprocess(tmp_path):
    """As a user runs it: log and list axes, then the files read back as the library's table."""
    argv = [sys.executable, "-m", "mett", *SWEEP, "--grid", "mu=log:0.1:1:2",
            "--grid", "theta0=0.2,0.1"]  # fmt: skip
    for name in ("s.csv", "s.nc"):
        out = subprocess.run([*argv, "--out", str(tmp_path / name)], capture_output=True,
                             text=True, timeout=1800)  # fmt: skip
        assert out.returncode == 0, out.stderr
    want = mett.sweep(TOP, {"mu": np.geomspace(0.1, 1, 2), "theta0": [0.2, 0.1]}, t_end=0.01,
                      progress=False)  # fmt: skip
    got = pd.read_csv(tmp_path / "s.csv", comment="#")
    np.testing.assert_array_equal(got["theta_end"], want["theta_end"])
    assert got["status"].tolist() == want["status"].tolist()
    xr = pytest.importorskip("xarray")
    ds = xr.load_dataset(tmp_path / "s.nc", engine="scipy")
    assert ds["theta_end"].dims == ("mu", "theta0") and list(ds["theta0"].values) == [0.2, 0.1]
    np.testing.assert_array_equal(ds["theta_end"].values.ravel(), want["theta_end"])


def test_a_model_that_conserves_the_energy_does_not_depend_on_mu():
    """Why a mu axis is refused there: the runs along it are the same run (and not so for the
    gliding top, whose friction dissipates)."""
    start = mett.State(theta=0.5, omega3=100.0)
    for model, same in (("rolling", True), ("frictionless-routhian", True), ("gliding", False)):
        a, b = (mett.simulate(TOP.replace(mu=mu), start, 0.05, model=model) for mu in (0.1, 0.3))
        assert np.array_equal(a.theta, b.theta) == same, model
