"""``mett.show_versions()``: the versions a bug report needs, without importing the packages."""

from __future__ import annotations

import platform
import sys
from importlib import metadata

from ._version import __version__

# Distribution names as pip knows them; optional ones last. Versions are read from the installed
# metadata, so nothing here is imported (numba, dask or heyoka would take seconds).
PACKAGES = (
    "numpy",
    "scipy",
    "numba",
    "llvmlite",
    "sympy",
    "matplotlib",
    "mpmath",
    "pandas",
    "xarray",
    "dask",
    "heyoka",
)


def show_versions(file=None, *, quiet: bool = False) -> dict[str, str]:
    """Print and return the versions of mett, Python, the platform and mett's dependencies.

    Paste the printed lines into a bug report.

    Parameters
    ----------
    file : file-like, optional
        Where to print (default ``sys.stdout``).
    quiet : bool, optional
        Return the versions without printing them.

    Returns
    -------
    dict of str to str
        ``{"mett": ..., "python": ..., "platform": ..., "numpy": ..., ...}``; a package that is
        not installed has the value ``"not installed"``.

    Notes
    -----
    The package versions come from :func:`importlib.metadata.version`: no package is imported,
    so the call is fast and works even when an optional package is broken.
    """
    info = {
        "mett": __version__,
        "python": sys.version.replace("\n", " "),
        "platform": platform.platform(),
        "machine": platform.machine(),
    }
    for name in PACKAGES:
        try:
            info[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            info[name] = "not installed"
    if not quiet:
        width = max(map(len, info))
        print("\n".join(f"{k:<{width}} : {v}" for k, v in info.items()), file=file or sys.stdout)
    return info
