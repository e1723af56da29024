"""mett — dynamics of the tippe top around the Main Equation for the Tippe Top (METT).

The numeric core (this package minus :mod:`mett.symbolic` and :mod:`mett.plotting`) depends only on
numpy and scipy (numba for the compiled integrator, loaded on first use).
"""

from . import analysis, friction, presets
from . import stem as stem  # registers the class TippeTop.with_stem builds (top.register_stemmed)
from ._validate import AccuracyWarning, MettDeprecationWarning, MettWarning, PhysicalityWarning
from ._version import __version__ as __version__
from ._versions import show_versions
from .asymptotics import HighSpin, high_spin
from .classification import AsymptoticState, asymptotic_state, subgroup
from .dynamics import Trajectory, simulate
from .estimates import period_estimates, potential_minimum
from .integrals import energy, jellett, modified_energy, routh
from .inversion import predict_inversion
from .potential import V, V_rational, d, d2V_dz2, dV_dz, g
from .separation import (
    Band,
    band,
    classify_motion,
    f,
    mean_precession,
    nutation_period,
    turning_points,
)
from .stability import escape_time, spin_eigenvalues, tumbling_eigenvalues
from .state import State
from .thresholds import TumblingState, boundary_values, min_spin_for_inversion, tumbling_state
from .top import TippeTop

_LAZY_MODULES = ("plotting", "gallery", "symbolic", "sweeps", "cli")


def __getattr__(name: str):
    # Lazy: sweeps need pandas, plotting matplotlib, symbolic sympy; `import mett` pays for none.
    if name == "sweep":
        from .sweeps import sweep

        return sweep
    if name == "load":  # a .npz (Trajectory.save) or a .nc (Trajectory.to_netcdf)
        from ._load import load

        return load
    if name in _LAZY_MODULES:
        import importlib

        return importlib.import_module(f".{name}", __name__)
    raise AttributeError(f"module 'mett' has no attribute {name!r}")


__all__ = [
    "AccuracyWarning",
    "AsymptoticState",
    "Band",
    "HighSpin",
    "MettDeprecationWarning",
    "MettWarning",
    "PhysicalityWarning",
    "State",
    "TippeTop",
    "Trajectory",
    "TumblingState",
    "V",
    "V_rational",
    "analysis",
    "asymptotic_state",
    "band",
    "boundary_values",
    "classify_motion",
    "d",
    "d2V_dz2",
    "dV_dz",
    "energy",
    "escape_time",
    "f",
    "friction",
    "g",
    "high_spin",
    "jellett",
    "load",
    "mean_precession",
    "min_spin_for_inversion",
    "modified_energy",
    "nutation_period",
    "period_estimates",
    "potential_minimum",
    "predict_inversion",
    "presets",
    "routh",
    "show_versions",
    "simulate",
    "spin_eigenvalues",
    "subgroup",
    "sweep",
    "tumbling_eigenvalues",
    "tumbling_state",
    "turning_points",
]
