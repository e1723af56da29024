"""Export of runs and sweep tables: CSV with a commented header, xarray datasets, NetCDF files and
mett.load (the reference of every round trip is the run in memory, compared bit for bit)."""

from __future__ import annotations

import math
import sys

import numpy as np
import pandas as pd
import pytest

import mett
from mett.dynamics import _export
from mett.dynamics.trajectory import SERIES
from mett.friction import Coulomb

xr = pytest.importorskip("xarray")

TOP = mett.presets.get("rutstam2013")
START = mett.State(theta=0.1, omega3=155.0)


@pytest.fixture(scope="module")
def run():
    return mett.simulate(TOP, START, 0.05)


@pytest.fixture(scope="module")
def dry_run():
    # a dry-friction run: per-sample phase labels and friction forces besides the series
    return mett.simulate(TOP, START, 0.05, friction=Coulomb(0.3, contensou_radius=1e-3))


@pytest.fixture(scope="module")
def stem_run():
    # a stemmed top: model options (the stem) and which sphere touches, per sample
    return mett.simulate(TOP.with_stem(0.005, 0.02), START, 0.05)


def _series(traj) -> dict[str, np.ndarray]:
    out = {"t": traj.t, **{n: getattr(traj, n) for n in SERIES}}
    if getattr(traj, "psi", None) is not None:  # the spin angle, integrated along the dense output
        out["psi"] = traj.psi
    return out


# --- CSV ------------------------------------------------------------------------------------------
def test_trajectory_csv_reads_back_exactly_with_numpy_and_pandas(run, tmp_path):
    path = _export.write_trajectory_csv(run, tmp_path / "t.csv", rtol=1e-10, t_end=0.05)
    want = _series(run)
    # numpy: the column names on the first line, the # lines are comments (numpy's default)
    data = np.loadtxt(path, delimiter=",", comments="#", skiprows=1)
    assert data.shape == (run.t.size, len(want))
    for k, (name, values) in enumerate(want.items()):
        np.testing.assert_array_equal(data[:, k], values, err_msg=name)
    # pandas: named columns with units
    df = pd.read_csv(path, comment="#")
    units = {"t": "s", "theta": "rad", "omega3": "rad/s", "nu_x": "m/s", "gn": "N", "E": "J",
             "D": "kg m^2/s", "lam": "kg m^3/s"}  # fmt: skip
    for name, unit in units.items():
        np.testing.assert_array_equal(df[f"{name} [{unit}]"].to_numpy(), want[name])
    assert len(df.columns) == len(want)


def test_trajectory_csv_header_says_what_ran(dry_run, tmp_path):
    path = _export.write_trajectory_csv(dry_run, tmp_path / "t.csv", rtol=1e-10, t_end=0.05)
    header = [line[2:] for line in path.read_text().splitlines() if line.startswith("# ")]
    text = "\n".join(header)
    assert f"mett {mett.__version__}" in header[0]
    assert "model: coulomb-contensou" in text
    assert "friction: Coulomb(mu=0.3, contensou_radius=0.001)" in text
    assert f"backend: {dry_run.backend}" in text
    assert "rtol: 1e-10" in text and "t_end: 0.05 s" in text
    assert f"m = {TOP.m!r} kg" in text and f"I1 = {TOP.I1!r} kg m^2" in text
    assert f"mu = {TOP.mu!r} s/m" in text and f"g = {TOP.g!r} m/s^2" in text
    assert "initial state: theta = 0.1 rad" in text and "omega3 = 155.0 rad/s" in text
    assert "status: completed" in text


def test_sweep_csv_reads_back_with_pandas_and_keeps_a_hash_in_text(tmp_path):
    table = mett.sweep(TOP, {"theta0": [0.1, 0.2]}, t_end=0.01, progress=False)
    table.loc[0, "message"] = "a # in a message, and a comma"
    path = _export.write_sweep_csv(table, tmp_path / "s.csv")
    got = pd.read_csv(path, comment="#")
    assert list(got.columns) == list(table.columns)
    for c in table.columns:
        if table[c].dtype.kind == "f":
            np.testing.assert_array_equal(got[c].to_numpy(), table[c].to_numpy(), err_msg=c)
        else:
            assert got[c].tolist() == table[c].tolist(), c
    text = path.read_text()
    assert "# grid axes: theta0" in text and "# t_end: 0.01 s" in text
    assert "theta_end [rad]" in text and "lam [kg m^3/s]" in text and "# model: gliding" in text


# --- xarray and NetCDF ------------------------------------------------------------------------------
def test_to_xarray_has_every_series_with_units_and_the_run_s_provenance(dry_run):
    ds = dry_run.to_xarray()
    assert list(ds.coords) == ["t"] and ds["t"].attrs["units"] == "s"
    for name in SERIES:
        np.testing.assert_array_equal(ds[name].values, getattr(dry_run, name))
        assert (
            ds[name].attrs["units"] == _export.SERIES_UNITS[name][0] and ds[name].attrs["long_name"]
        )
    assert ds["theta"].attrs["units"] == "rad" and ds["lam"].attrs["units"] == "kg m^3/s"
    assert list(ds["phase"].values) == list(dry_run.phase)
    np.testing.assert_array_equal(ds["F_x"].values, dry_run.F_x)
    a = ds.attrs
    assert a["mett_version"] == mett.__version__ and a["model"] == "coulomb-contensou"
    assert a["backend"] == dry_run.backend and a["status"] == "completed"
    assert a["friction_law"] == "Coulomb" and a["friction_mu"] == 0.3
    assert a["friction_contensou_radius"] == 1e-3 and a["friction_contensou_radius_units"] == "m"
    for k, unit in (("m", "kg"), ("R", "m"), ("I1", "kg m^2"), ("mu", "s/m"), ("g", "m/s^2")):
        assert a[f"top_{k}"] == getattr(TOP, k) and a[f"top_{k}_units"] == unit
    assert a["initial_theta"] == 0.1 and a["initial_omega3_units"] == "rad/s"


def test_run_settings_are_included_when_the_trajectory_records_them(run):
    class Recorded:  # a trajectory that records rtol, atol, t_end (as simulate will)
        def __init__(self, traj):
            self._traj = traj
            self.rtol, self.atol, self.t_end = 1e-9, np.array([1e-12, 2e-12]), 0.05

        def __getattr__(self, name):
            return getattr(self._traj, name)

    a = _export.trajectory_to_xarray(Recorded(run), rtol=1.0).attrs
    assert a["rtol"] == 1e-9 and a["t_end"] == 0.05 and a["t_end_units"] == "s"
    np.testing.assert_array_equal(a["atol"], [1e-12, 2e-12])
    assert "rtol" not in run.to_xarray().attrs or hasattr(run, "rtol")


@pytest.mark.parametrize("which", ["run", "dry_run", "stem_run"])
def test_netcdf_round_trip_keeps_the_samples_bit_for_bit(which, request, tmp_path):
    traj = request.getfixturevalue(which)
    path = traj.to_netcdf(tmp_path / "t.nc")
    back = mett.load(path)
    assert isinstance(back, _export.NetCDFTrajectory)
    for name, values in _series(traj).items():
        got = getattr(back, name)
        assert got.dtype == np.float64 and np.array_equal(got, values), name
    assert list(back.phase) == list(traj.phase)
    if "contact" in traj.__dict__:
        assert list(back.contact) == list(traj.contact)
    assert back.top == traj.top and back.initial_state == traj.initial_state
    assert back.options == traj.options  # the friction law, rebuilt
    assert (back.model, back.status, back.message, back.backend) == (
        traj.model, traj.status, traj.message, traj.backend)  # fmt: skip
    assert back.mett_version == mett.__version__ and len(back) == len(traj)
    pd.testing.assert_frame_equal(back.to_dataframe(), traj.to_dataframe())
    with pytest.raises(NotImplementedError, match="dense output"):
        back.at(0.01)
    # the file is plain netCDF-3 with the units on every variable
    ds = xr.load_dataset(path, engine="scipy")
    assert all("units" in ds[n].attrs for n in SERIES) and ds.attrs["top_m_units"] == "kg"


def test_a_partial_run_keeps_its_status_in_netcdf(tmp_path):
    traj = mett.simulate(TOP, mett.State(theta=1.5, omega3=0.0, thetadot=100.0), 1.0,
                        stop_on_contact_loss=True)  # fmt: skip
    assert traj.status == "contact_lost"
    back = mett.load(traj.to_netcdf(tmp_path / "t.nc"))
    assert back.status == "contact_lost" and back.t_contact_lost == traj.t_contact_lost
    np.testing.assert_array_equal(back.theta, traj.theta)


def test_the_sweep_table_has_the_grid_axes_as_dimensions(tmp_path):
    grid = {"mu": [0.3, 0.1], "theta0": [0.1, 0.2, 0.3]}  # mu out of order: kept as given
    table = mett.sweep(TOP, grid, t_end=0.01, progress=False)
    ds = table.to_xarray()
    assert dict(ds.sizes) == {"mu": 2, "theta0": 3}
    assert list(ds["mu"].values) == [0.3, 0.1] and list(ds["theta0"].values) == [0.1, 0.2, 0.3]
    for _, row in table.iterrows():
        point = ds.sel(mu=row["mu"], theta0=row["theta0"])
        assert point["theta_end"].item() == row["theta_end"]
        assert point["status"].item() == row["status"]
    assert ds["theta_end"].attrs["units"] == "rad" and ds["mu"].attrs["units"] == "s/m"
    assert ds.attrs["t_end"] == 0.01 and ds.attrs["top_m"] == TOP.m
    assert ds.attrs["model"] == "gliding" and ds.attrs["mett_version"] == mett.__version__
    back = xr.load_dataset(table.to_netcdf(tmp_path / "s.nc"), engine="scipy")
    np.testing.assert_array_equal(back["theta_end"].values, ds["theta_end"].values)
    assert back["simulated"].values.tolist() == ds["simulated"].values.tolist()
    # a table read from CSV no longer knows its axes: they are asked for
    plain = pd.DataFrame(table.to_dict("list"))  # no attrs, as read from a file
    with pytest.raises(ValueError, match="dims must name the grid axes"):
        _export.sweep_to_xarray(plain)
    assert dict(_export.sweep_to_xarray(plain, ["mu", "theta0"]).sizes) == {"mu": 2, "theta0": 3}


# --- mett.load, bad input, a missing xarray -------------------------------------------------------
def test_load_dispatches_on_the_suffix_and_refuses_the_rest(run, tmp_path):
    traj = mett.load(run.save(tmp_path / "t.npz"))
    assert isinstance(traj, mett.Trajectory) and np.array_equal(traj.theta, run.theta)
    with pytest.raises(ValueError, match=r"path must end in \.npz"):
        mett.load(tmp_path / "t.txt")
    with pytest.raises(ValueError, match="existing NetCDF file"):
        mett.load(tmp_path / "missing.nc")
    with pytest.raises(TypeError, match="path must be a str"):
        mett.load(3)
    (tmp_path / "junk.nc").write_bytes(b"not netcdf")
    with pytest.raises(ValueError, match="not a readable NetCDF file"):
        mett.load(tmp_path / "junk.nc")
    xr.Dataset({"a": ("x", [1.0])}).to_netcdf(tmp_path / "other.nc", engine="scipy")
    with pytest.raises(ValueError, match="not a mett trajectory"):
        mett.load(tmp_path / "other.nc")
    with pytest.raises(ValueError, match=r"must end in \.nc"):
        run.to_netcdf(tmp_path / "t.cdf")
    with pytest.raises(ValueError, match="does not exist"):
        run.to_netcdf(tmp_path / "no" / "t.nc")


def test_without_xarray_the_message_names_the_extra(run, tmp_path, monkeypatch):
    path = run.to_netcdf(tmp_path / "t.nc")
    monkeypatch.setitem(sys.modules, "xarray", None)  # import xarray now raises ImportError
    for call in (run.to_xarray, lambda: run.to_netcdf(tmp_path / "u.nc"),
                 lambda: mett.load(path)):  # fmt: skip
        with pytest.raises(ImportError, match=r"pip install 'mett\[xarray\]'"):
            call()
    assert not (tmp_path / "u.nc").exists()
    assert math.isfinite(run.theta[-1])


def test_user_event_times_round_trip_an_empty_one_too(tmp_path):
    events = [lambda t, s: s.theta - 0.099, lambda t, s: s.theta - 3.0]  # the second never fires
    traj = mett.simulate(TOP, START, 0.05, events=events)
    assert traj.t_events[0].size > 0 and traj.t_events[1].size == 0
    back = mett.load(traj.to_netcdf(tmp_path / "t.nc"))
    assert len(back.t_events) == 2
    for got, want in zip(back.t_events, traj.t_events, strict=True):
        np.testing.assert_array_equal(got, want)
