"""mett — dynamics of the tippe top around the Main Equation for the Tippe Top (METT).

The numeric core (this package minus :mod:`mett.symbolic` and :mod:`mett.plotting`) depends only on
numpy, scipy and mpmath.
"""

from . import presets
from ._validate import MettWarning, PhysicalityWarning
from .integrals import energy, jellett, modified_energy, routh
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
from .state import State
from .thresholds import boundary_values
from .top import TippeTop

__version__ = "0.1.0.dev0"

__all__ = [
    "Band",
    "MettWarning",
    "PhysicalityWarning",
    "State",
    "TippeTop",
    "V",
    "V_rational",
    "band",
    "boundary_values",
    "classify_motion",
    "d",
    "d2V_dz2",
    "dV_dz",
    "energy",
    "f",
    "g",
    "jellett",
    "mean_precession",
    "modified_energy",
    "nutation_period",
    "presets",
    "routh",
    "turning_points",
]
