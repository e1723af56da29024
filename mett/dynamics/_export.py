"""Export of runs and sweep tables: CSV with a commented header, xarray datasets and NetCDF files.

:meth:`mett.Trajectory.to_xarray`, :meth:`mett.Trajectory.to_netcdf`, the sweep table's
``to_xarray``/``to_netcdf`` and :func:`mett.load` are thin wrappers of the functions here.

NetCDF files are written in the classic netCDF-3 format by scipy's writer (``engine="scipy"``:
no binary library beyond scipy, readable by every netCDF tool). They keep the sampled series
exactly (IEEE doubles) with their ``units`` and ``long_name``, and the run's provenance as global
attributes; the dense output of a run (its interpolant between the samples) is *not* stored: use
:meth:`mett.Trajectory.save` (``.npz``) for a run that :meth:`~mett.Trajectory.at` and
:meth:`~mett.Trajectory.crossings` must evaluate again. xarray is the optional extra
``mett[xarray]``.
"""

from __future__ import annotations

import csv
import dataclasses
import os
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, Final

import numpy as np

from .._version import __version__
from ._series import SERIES, SERIES_UNITS

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd
    import xarray as xr

__all__ = [
    "SERIES_UNITS",
    "NetCDFTrajectory",
    "check_nc_path",
    "sweep_to_xarray",
    "to_netcdf",
    "trajectory_to_xarray",
    "write_sweep_csv",
    "write_trajectory_csv",
]

ENGINE: Final = "scipy"  # netCDF-3 classic, written and read by scipy.io (no extra binary)


_TOP_UNITS = {"m": "kg", "R": "m", "alpha": "1", "I1": "kg m^2", "I3": "kg m^2", "mu": "s/m",
              "g": "m/s^2"}  # fmt: skip
_STATE_UNITS = {"theta": "rad", "thetadot": "rad/s", "phidot": "rad/s", "omega3": "rad/s",
                "nu_x": "m/s", "nu_y": "m/s"}  # fmt: skip
# the friction laws' fields: mu is s/m for the viscous law, dimensionless for the dry ones
_LAW_UNITS = {"Viscous": {"mu": "s/m"}, "Coulomb": {"mu": "1", "contensou_radius": "m"},
              "RegularisedCoulomb": {"mu": "1", "eps": "m/s"}}  # fmt: skip
_SWEEP_UNITS = {
    **_TOP_UNITS, "theta0": "rad", "thetadot": "rad/s", "phidot": "rad/s", "omega3": "rad/s",
    "nu_x": "m/s", "nu_y": "m/s", "gamma": "1", "lam_ratio": "1", "contensou_radius": "m",
    "t_invert": "s", "theta_end": "rad", "omega3_end": "rad/s", "omega3_start": "rad/s",
    "lam": "kg m^3/s",
}  # fmt: skip
_SWEEP_NAMES = {
    "gamma": "inertia ratio I1/I3", "lam_ratio": "lambda / lambda_thres",
    "t_invert": "first time theta = pi/2 (NaN: never)", "theta_end": "theta at t_end",
    "omega3_end": "omega3 at t_end", "omega3_start": "omega3 at t = 0",
    "lam": "Jellett integral lambda", "status": "status of the run",
    "predicted": "predicted end state (mett.asymptotic_state)",
    "simulated": "end state read off the run", "agree": "simulated end state agrees with the "
    "prediction", "message": "what happened (empty if nothing to say)", "friction": "friction law",
}  # fmt: skip
_RUN_ATTRS = ("rtol", "atol", "t_end")  # read with getattr: set by simulate where it records them


def require_xarray() -> Any:
    try:
        import xarray as xr
    except ImportError:
        raise ImportError(
            "xarray/NetCDF export needs the optional extra: pip install 'mett[xarray]' "
            "(xarray; NetCDF files are written by scipy)"
        ) from None
    return xr


# --- provenance ---------------------------------------------------------------------------------
def _law_of(traj: Any) -> Any:
    return getattr(traj, "options", {}).get("friction")


def _friction_text(law: Any, top: Any) -> str:
    from ..friction import describe

    if law is None:
        mu = getattr(top, "mu", None)
        return f"viscous (the top's mu = {mu!r} s/m)" if mu is not None else "none"
    return describe(law)


def _law_fields(law: Any) -> dict[str, tuple[float, str]]:
    if law is None or not dataclasses.is_dataclass(law) or isinstance(law, type):
        return {}
    units = _LAW_UNITS.get(type(law).__name__, {})
    return {
        k: (float(v), units.get(k, ""))
        for k, v in dataclasses.asdict(law).items()
        if isinstance(v, (int, float)) and not isinstance(v, bool)
    }


def _top_fields(top: Any) -> dict[str, float]:
    if top is None or not dataclasses.is_dataclass(top) or isinstance(top, type):
        return {}
    return {
        k: float(v)
        for k, v in dataclasses.asdict(top).items()
        if isinstance(v, (int, float)) and not isinstance(v, bool)
    }


def _state_fields(state: Any) -> dict[str, float]:
    if state is None:
        return {}
    return {k: float(getattr(state, k)) for k in _STATE_UNITS}


def _run_values(traj: Any, given: dict[str, Any]) -> dict[str, Any]:
    """rtol, atol, t_end of the run: its own where it records them, else those ``given``."""
    out = {k: getattr(traj, k, None) for k in _RUN_ATTRS}
    out.update({k: v for k, v in given.items() if out.get(k) is None and v is not None})
    return {k: v for k, v in out.items() if v is not None}


def _fmt_units(value: Any, unit: str) -> str:
    text = np.array2string(np.asarray(value), separator=" ") if np.ndim(value) else repr(value)
    text = repr(float(value)) if np.ndim(value) == 0 and _is_real(value) else text
    return f"{text} {unit}".rstrip() if unit not in ("", "1") else text


def _is_real(v: Any) -> bool:
    return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool)


def _columns(traj: Any) -> list[str]:
    names = ["t", *SERIES]
    if "psi" not in names and getattr(traj, "psi", None) is not None:
        names.append("psi")
    return names


def trajectory_header(traj: Any, **run: Any) -> list[str]:
    """The ``# `` comment lines of a trajectory CSV (without the ``# ``): what ran and how."""
    lines = [f"mett {__version__} trajectory (docs: Saving and exporting)"]
    lines.append(f"model: {traj.model}")
    lines.append(f"friction: {_friction_text(_law_of(traj), traj.top)}")
    lines.append(f"backend: {traj.backend}")
    run = _run_values(traj, run)
    for k, unit in (("rtol", "1"), ("atol", "(model units)"), ("t_end", "s")):
        if k in run:
            lines.append(f"{k}: {_fmt_units(run[k], unit)}")
    lines.append(f"status: {traj.status}" + (f" ({traj.message})" if traj.message else ""))
    top = ", ".join(
        f"{k} = {_fmt_units(v, _TOP_UNITS.get(k, ''))}" for k, v in _top_fields(traj.top).items()
    )
    lines.append(f"top: {type(traj.top).__name__}({top})")
    options = {k: v for k, v in getattr(traj, "options", {}).items() if k != "friction"}
    if options:
        lines.append("options: " + ", ".join(f"{k} = {v!r}" for k, v in options.items()))
    state = ", ".join(
        f"{k} = {_fmt_units(v, _STATE_UNITS[k])}"
        for k, v in _state_fields(traj.initial_state).items()
    )
    lines.append(f"initial state: {state}")
    return [" ".join(line.split()) for line in lines]  # one line each, whatever a message holds


def _column_label(name: str) -> str:
    unit = SERIES_UNITS.get(name, ("", ""))[0]
    return f"{name} [{unit}]" if unit else name


def write_trajectory_csv(traj: Any, path: str | os.PathLike, **run: Any) -> Path:
    """Write the sampled series of ``traj`` as CSV: the column names with units (``t [s]``,
    ``theta [rad]``, …) on the first line, then ``# `` lines of provenance (mett version,
    model, friction law, backend, rtol/atol/t_end where recorded, status, the top's parameters and
    the initial state with units), then one row per sample, every number in the shortest digits
    that read back exactly.

    ``pandas.read_csv(path, comment="#")`` reads it with named columns, and
    ``numpy.loadtxt(path, delimiter=",", skiprows=1)`` (comments ``#`` by default) as an array.
    ``run`` (``rtol=``, ``atol=``, ``t_end=``) are recorded where the trajectory does not carry
    its own (the command line passes what it asked simulate for).
    """
    names = [n for n in _columns(traj) if np.asarray(getattr(traj, n)).dtype.kind == "f"]
    data = np.column_stack([np.asarray(getattr(traj, n), dtype=float) for n in names])
    p = Path(path)
    with open(p, "w", encoding="utf-8", newline="") as fh:
        fh.write(",".join(_column_label(n) for n in names) + "\n")
        fh.writelines(f"# {line}\n" for line in trajectory_header(traj, **run))
        # the shortest digits that read back exactly (Python's float repr)
        fh.writelines(",".join(map(repr, row)) + "\n" for row in data.tolist())
    return p


def _sweep_meta(table: Any) -> dict[str, Any]:
    return dict(getattr(table, "attrs", {}).get("mett_sweep", {}))


def write_sweep_csv(table: pd.DataFrame, path: str | os.PathLike) -> Path:
    """Write a sweep table (:func:`mett.sweep`) as CSV: the column names on the first line (as in
    the table, so ``pandas.read_csv(path, comment="#")`` gives it back), then ``# `` lines with the
    mett version, what the sweep ran (model, friction, backend, rtol, t_end, the grid axes, the
    base top with units, the base initial state) and the unit of every column, then the rows.
    Text fields are quoted, so a ``#`` inside a message is no comment; numbers are written with
    the shortest digits that read back exactly (NaN as ``nan``)."""
    meta = _sweep_meta(table)
    lines = [
        f"mett {meta.get('mett_version', __version__)} sweep table (docs: Saving and exporting)"
    ]
    for key in ("model", "friction", "backend", "rtol", "atol", "t_end"):
        if meta.get(key) is not None:
            unit = " s" if key == "t_end" else ""
            lines.append(f"{key}: {meta[key]}{unit}")
    if meta.get("grid"):
        lines.append("grid axes: " + ", ".join(meta["grid"]))
    if meta.get("top"):
        top = ", ".join(
            f"{k} = {_fmt_units(v, _TOP_UNITS.get(k, ''))}" for k, v in meta["top"].items()
        )
        lines.append(f"base top: {top}")
    if meta.get("initial_state"):
        start = ", ".join(
            f"{k} = {_fmt_units(v, _SWEEP_UNITS.get(k, ''))}"
            for k, v in meta["initial_state"].items()
        )
        lines.append(f"base initial state: {start}")
    units = [f"{c} [{_SWEEP_UNITS[c]}]" for c in table.columns if c in _SWEEP_UNITS]
    lines.append("units: " + ", ".join(units))
    p = Path(path)
    with open(p, "w", encoding="utf-8", newline="") as fh:
        fh.write(",".join(map(str, table.columns)) + "\n")
        fh.writelines(f"# {' '.join(line.split())}\n" for line in lines)
        # numbers as Python writes them (the shortest digits that read back exactly), text quoted
        writer = csv.writer(fh, quoting=csv.QUOTE_NONNUMERIC, lineterminator="\n")
        writer.writerows(zip(*(table[c].tolist() for c in table.columns), strict=True))
    return p


# --- xarray ---------------------------------------------------------------------------------------
def _attr(value: Any) -> Any:
    """A value netCDF-3 can store as an attribute: str, float, int32 or an array of floats."""
    if isinstance(value, (bool, np.bool_)):
        return int(value)
    if isinstance(value, (int, np.integer)):
        return int(value) if -(2**31) <= int(value) < 2**31 else float(value)
    if isinstance(value, (float, np.floating)):
        return float(value)
    if np.ndim(value):
        return np.asarray(value, dtype=float)
    return str(value)


def trajectory_to_xarray(traj: Any, **run: Any) -> xr.Dataset:
    """The sampled series of a run as an :class:`xarray.Dataset` (see
    :meth:`mett.Trajectory.to_xarray`); ``run`` as in :func:`write_trajectory_csv`."""
    xr = require_xarray()
    t = np.asarray(traj.t, dtype=float)
    data_vars = {}
    extra = [n for n in getattr(traj, "extra", ()) if n not in _columns(traj)]
    for name in [*_columns(traj)[1:], *("phase", "contact"), *extra]:
        values = getattr(traj, name, None)
        if values is None or name in data_vars:
            continue
        values = np.asarray(values)
        if values.shape != t.shape:
            continue
        unit, long_name = SERIES_UNITS.get(name, ("", name))
        var_attrs = {"long_name": long_name}
        if values.dtype.kind in "fi":
            var_attrs["units"] = unit or "1"
            values = values.astype(float)
        else:
            values = values.astype(str)
        data_vars[name] = ("t", values, var_attrs)
    for n, te in enumerate(getattr(traj, "t_events", [])):
        data_vars[f"t_events_{n}"] = (f"event_{n}", np.asarray(te, dtype=float),
                                      {"units": "s", "long_name": f"times of user event {n}"})  # fmt: skip
    attrs: dict[str, Any] = {
        "title": f"mett trajectory ({traj.model})",
        "source": f"mett {__version__}",
        "mett_version": __version__,
        "model": traj.model,
        "backend": traj.backend,
        "status": traj.status,
        "message": traj.message or "",
        "nfev": int(getattr(traj, "nfev", 0)),
        "top_type": type(traj.top).__name__,
    }
    law = _law_of(traj)
    attrs["friction"] = _friction_text(law, traj.top)
    attrs["friction_law"] = "none" if law is None else type(law).__name__
    for k, (v, unit) in _law_fields(law).items():
        attrs[f"friction_{k}"], attrs[f"friction_{k}_units"] = v, unit
    for k, v in _run_values(traj, run).items():
        attrs[k] = _attr(v)
        attrs[f"{k}_units"] = {"rtol": "1", "atol": "model units", "t_end": "s"}[k]
    if traj.t_contact_lost is not None:
        attrs["t_contact_lost"], attrs["t_contact_lost_units"] = float(traj.t_contact_lost), "s"
    for k, v in _top_fields(traj.top).items():
        attrs[f"top_{k}"], attrs[f"top_{k}_units"] = v, _TOP_UNITS.get(k, "")
    options = getattr(traj, "options", {})
    attrs["option_names"] = ",".join(options)  # those set, a law or None included
    for k, v in options.items():
        if k != "friction" and (_is_real(v) or isinstance(v, str)):
            attrs[f"option_{k}"] = v
    for k, v in _state_fields(traj.initial_state).items():
        attrs[f"initial_{k}"], attrs[f"initial_{k}_units"] = v, _STATE_UNITS[k]
    coords = {"t": ("t", t, {"units": "s", "long_name": "time"})}
    return xr.Dataset(data_vars, coords=coords, attrs={k: _attr(v) for k, v in attrs.items()})


def check_nc_path(path: Any, what: str = "path") -> Path:
    """``path`` as a Path if it can take a NetCDF file (``.nc``, in an existing directory)."""
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(
            f"{what} must be a str or path-like ending in .nc; got {type(path).__name__}"
        )
    p = Path(os.fspath(path))
    if p.suffix.lower() != ".nc":
        raise ValueError(f"{what} must end in .nc; got {str(p)!r}")
    if p.is_dir():
        raise ValueError(f"{what} must be a file, not a directory; got {str(p)!r}")
    if not p.parent.is_dir():
        raise ValueError(f"{what}: the directory {str(p.parent)!r} does not exist")
    return p


def to_netcdf(dataset: xr.Dataset, path: str | os.PathLike) -> Path:
    """Write ``dataset`` to ``path`` (netCDF-3 classic, scipy's writer), replacing a file there."""
    p = check_nc_path(path)
    dataset.to_netcdf(p, engine=ENGINE, format="NETCDF3_64BIT")
    return p


def sweep_to_xarray(table: pd.DataFrame, dims: Sequence[str] | None = None) -> xr.Dataset:
    """A sweep table as an :class:`xarray.Dataset` with the grid axes as dimensions.

    Parameters
    ----------
    table : pandas.DataFrame
        A table of :func:`mett.sweep` (or a part of one, or one read back from its CSV).
    dims : sequence of str, optional
        The grid axes (default: those the sweep recorded in ``table.attrs``); needed for a table
        read from a CSV file.

    Returns
    -------
    xarray.Dataset
        One variable per result column over the grid's dimensions (points missing from the
        table, e.g. after filtering, are NaN), with ``units`` and ``long_name``; the sweep's
        settings (mett version, model, friction, rtol, t_end, the base top and start) as
        attributes.
    """
    xr = require_xarray()
    meta = _sweep_meta(table)
    if dims is None:
        dims = meta.get("grid")
        if not dims:
            raise ValueError(
                "dims must name the grid axes (the table does not record them: it was not made "
                "by mett.sweep, or was read back from a file)"
            )
    dims = list(dims)
    missing = [d for d in dims if d not in table.columns]
    if missing:
        raise ValueError(
            f"dims {missing} are not columns of the table; columns: {list(table.columns)}"
        )
    frame = table.set_index(dims)
    if not frame.index.is_unique:
        raise ValueError(
            f"the grid axes {dims} repeat a point (an axis with a value twice): no array can "
            "hold it; drop the duplicates first"
        )
    # the grid's own order along each axis (from_dataframe sorts the labels)
    order = {d: list(dict.fromkeys(table[d].tolist())) for d in dims}
    ds = xr.Dataset.from_dataframe(frame).reindex(order)
    for name in ds.variables:
        var_attrs = {"long_name": _SWEEP_NAMES.get(str(name), str(name))}
        if str(name) in _SWEEP_UNITS and ds[name].dtype.kind in "fiu":
            var_attrs["units"] = _SWEEP_UNITS[str(name)]
        ds[name].attrs.update(var_attrs)
    attrs: dict[str, Any] = {
        "title": "mett sweep",
        "mett_version": meta.get("mett_version", __version__),
    }
    for key in ("model", "friction", "backend", "rtol", "atol", "t_end"):
        if meta.get(key) is not None:
            attrs[key] = _attr(meta[key])
    if "t_end" in attrs:
        attrs["t_end_units"] = "s"
    for k, v in meta.get("top", {}).items():
        attrs[f"top_{k}"], attrs[f"top_{k}_units"] = float(v), _TOP_UNITS.get(k, "")
    for k, v in meta.get("initial_state", {}).items():
        attrs[f"initial_{k}"], attrs[f"initial_{k}_units"] = float(v), _SWEEP_UNITS.get(k, "")
    ds.attrs.update({k: _attr(v) for k, v in attrs.items()})
    return ds


# --- reading back -------------------------------------------------------------------------------
class NetCDFTrajectory:
    """A run read back from a NetCDF file of :meth:`mett.Trajectory.to_netcdf` (by
    :func:`mett.load`).

    It holds what the file holds: ``t`` and every sampled series (bit for bit), the per-sample
    labels (``phase``, ``contact``), user event times ``t_events``, and ``model``, ``status``,
    ``message``, ``backend``, ``top`` (a :class:`~mett.TippeTop`), ``initial_state`` (a
    :class:`~mett.State`), ``options`` (the friction law rebuilt), ``rtol``, ``atol``, ``t_end``
    where recorded, ``mett_version`` and ``attrs`` (every attribute as stored). The dense output
    is not in NetCDF, so :meth:`at` and :meth:`crossings` are not available (they raise,
    saying so): save with :meth:`mett.Trajectory.save` (``.npz``) to keep them.
    """

    def __init__(self, dataset: Any, path: Path) -> None:
        from ..state import State
        from ..stem import StemContactTop
        from ..top import TippeTop

        a = dict(dataset.attrs)
        self.path, self.attrs = path, a
        self.t = np.asarray(dataset["t"].values, dtype=float)
        self.series: tuple[str, ...] = tuple(
            str(n) for n in dataset.data_vars if dataset[n].dims == ("t",)
        )
        for name in self.series:
            values = dataset[name].values
            setattr(self, name, values.astype(str) if values.dtype.kind in "OSU" else values)
        self.t_events = [
            np.asarray(dataset[f"t_events_{k}"].values, dtype=float)
            for k in range(len(dataset.data_vars))
            if f"t_events_{k}" in dataset
        ]
        self.model = str(a.get("model", ""))
        self.status = str(a.get("status", ""))
        self.message = str(a.get("message", ""))
        self.backend = str(a.get("backend", ""))
        self.mett_version = str(a.get("mett_version", ""))
        for k in _RUN_ATTRS:
            v = a.get(k)
            setattr(
                self, k, None if v is None else (float(v) if np.ndim(v) == 0 else np.asarray(v))
            )
        t_lost = a.get("t_contact_lost")
        self.t_contact_lost = None if t_lost is None else float(t_lost)
        top = {k[4:]: float(v) for k, v in a.items()
               if k.startswith("top_") and not k.endswith("_units") and k != "top_type"}  # fmt: skip
        top_class = StemContactTop if a.get("top_type") == "StemContactTop" else TippeTop
        self.top = top_class(**top) if set(top) >= {"m", "R", "alpha", "I1", "I3"} else None
        start = {k: float(a[f"initial_{k}"]) for k in _STATE_UNITS if f"initial_{k}" in a}
        self.initial_state = State(**start) if "theta" in start else None
        names = [n for n in str(a.get("option_names", "")).split(",") if n]
        self.options: dict[str, Any] = {}
        for name in names:
            value = self._law(a) if name == "friction" else a.get(f"option_{name}")
            self.options[name] = value.item() if isinstance(value, np.generic) else value

    @staticmethod
    def _law(a: dict) -> Any:
        from .. import friction

        name = str(a.get("friction_law", "none"))
        if name not in _LAW_UNITS:
            return None
        fields = {k[9:]: float(v) for k, v in a.items()
                  if k.startswith("friction_") and k != "friction_law" and not k.endswith("_units")}  # fmt: skip
        return getattr(friction, name)(**fields)

    def __len__(self) -> int:
        return self.t.size

    def __repr__(self) -> str:
        return (
            f"NetCDFTrajectory(model={self.model!r}, status={self.status!r}, "
            f"t=[{self.t[0]:g}, {self.t[-1]:g}] s, {self.t.size} samples, from {str(self.path)!r})"
        )

    @property
    def t_final(self) -> float:
        """Time at which the run ended (s)."""
        return float(self.t[-1])

    def as_dict(self) -> dict[str, np.ndarray]:
        """``{"t": ..., "theta": ..., ...}``: the series of :data:`mett.dynamics.trajectory.SERIES` read (as
        :meth:`mett.Trajectory.as_dict`; the per-sample extras stay attributes)."""

        return {"t": self.t, **{n: getattr(self, n) for n in SERIES if n in self.series}}

    def to_dataframe(self) -> pd.DataFrame:
        """The numeric series as a :class:`pandas.DataFrame`, one row per sample."""
        import pandas as pd

        df = pd.DataFrame({k: np.array(v, copy=True) for k, v in self.as_dict().items()})
        df.attrs.update(model=self.model, status=self.status, message=self.message)
        return df

    def to_xarray(self) -> xr.Dataset:
        """The dataset as read (series, units, attributes)."""
        xr = require_xarray()
        return xr.load_dataset(self.path, engine=ENGINE)

    def _no_dense(self, *args: Any, **kwargs: Any) -> Any:
        raise NotImplementedError(
            "a NetCDF file keeps the samples, not the dense output: save the run with "
            "Trajectory.save (.npz) and read it with mett.load to evaluate between samples"
        )

    at = states_at = theta_at = crossings = _no_dense
