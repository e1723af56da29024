"""``mett.load``: read a run saved by mett, whichever of its formats (``.npz`` or NetCDF)."""

from __future__ import annotations

import os
from pathlib import Path

from .dynamics._export import ENGINE, NetCDFTrajectory, require_xarray
from .dynamics.trajectory import Trajectory

__all__ = ["load"]


def load(path: str | os.PathLike) -> Trajectory | NetCDFTrajectory:
    """Read a run saved by mett: a ``.npz`` of :meth:`mett.Trajectory.save` or a ``.nc`` of
    :meth:`mett.Trajectory.to_netcdf`.

    Parameters
    ----------
    path : str or path-like
        The file; its suffix (``.npz`` or ``.nc``) says which format.

    Returns
    -------
    Trajectory or NetCDFTrajectory
        A :class:`mett.Trajectory` from ``.npz`` (everything, the dense output included: see
        :meth:`mett.Trajectory.load`); from ``.nc`` a :class:`NetCDFTrajectory` with the samples
        bit for bit, the top, the initial state, the friction law and the run's settings, but no
        dense output.

    Raises
    ------
    TypeError
        If ``path`` is not a str or path-like.
    ValueError
        If the suffix is neither, the file does not exist, or is not a file mett wrote.
    ImportError
        For ``.nc`` without xarray (``pip install 'mett[xarray]'``).
    """
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"path must be a str or path-like (.npz or .nc); got {type(path).__name__}")
    p = Path(os.fspath(path))
    suffix = p.suffix.lower()
    if suffix == ".npz":
        return Trajectory.load(p)
    if suffix != ".nc":
        raise ValueError(
            f"path must end in .npz (Trajectory.save) or .nc (to_netcdf); got {str(p)!r}"
        )
    if not p.is_file():
        raise ValueError(f"path must be an existing NetCDF file (.nc); got {str(p)!r}")
    xr = require_xarray()
    try:
        ds = xr.load_dataset(p, engine=ENGINE)
    except (OSError, ValueError, TypeError, KeyError, IndexError) as exc:
        raise ValueError(f"{p} is not a readable NetCDF file: {exc}") from None
    if not str(ds.attrs.get("title", "")).startswith("mett trajectory") or "t" not in ds:
        raise ValueError(f"{p} is not a mett trajectory (no 'mett trajectory' title or no t)")
    try:
        return NetCDFTrajectory(ds, p)
    except (ValueError, TypeError, KeyError) as exc:
        raise ValueError(f"{p} is a damaged mett trajectory file: {exc}") from None
