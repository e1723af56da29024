"""Input validation shared by every public function.

Messages name the parameter, its valid range and the offending value, e.g.
``ValueError: alpha must lie in (0, 1); got 1.5``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = [
    "MettWarning",
    "PhysicalityWarning",
    "ToleranceWarning",
    "as_finite_array",
    "cos_theta",
    "finite_scalar",
    "positive_jellett",
    "positive_scalar",
    "theta",
]


class MettWarning(UserWarning):
    """Base category of every warning mett emits (filter it with ``warnings``)."""


class PhysicalityWarning(MettWarning):
    """Legal but physically suspicious input (e.g. I3 > m R², as in the seed-000 table)."""


class ToleranceWarning(MettWarning):
    """A tolerance was changed to one the integrator can meet (e.g. rtol raised to 100 ε)."""


def _fmt(value: Any) -> str:
    arr = np.asarray(value)
    if arr.ndim == 0:
        return repr(arr.item())
    bad = arr.ravel()
    return f"array of shape {arr.shape} (e.g. {bad[0]!r})"


def finite_scalar(name: str, value: Any) -> float:
    """Return ``value`` as a finite float or raise ``ValueError`` naming ``name``."""
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a finite real number; got {value!r}") from None
    if not math.isfinite(x):
        raise ValueError(f"{name} must be finite; got {x!r}")
    return x


def positive_scalar(name: str, value: Any, *, allow_zero: bool = False) -> float:
    """A finite float that is > 0 (or ≥ 0 with ``allow_zero``)."""
    x = finite_scalar(name, value)
    if x < 0 or (x == 0 and not allow_zero):
        rng = "[0, inf)" if allow_zero else "(0, inf)"
        raise ValueError(f"{name} must lie in {rng}; got {x!r}")
    return x


def positive_jellett(value: Any, name: str = "lam") -> float:
    """A Jellett integral λ that must be positive (top spun with ω3 > 0 near θ = 0)."""
    x = finite_scalar(name, value)
    if x <= 0.0:
        raise ValueError(
            f"{name} must lie in (0, inf) (a positive Jellett integral; flip the sign of the spin "
            f"for the mirror-image top); got {x!r}"
        )
    return x


def as_finite_array(name: str, value: Any) -> np.ndarray:
    """Convert to a float array and reject NaN/inf, naming ``name`` in the error."""
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be real numbers; got {value!r}") from None
    if not np.all(np.isfinite(arr)):
        bad = arr[~np.isfinite(arr)].ravel()[0].item()
        raise ValueError(f"{name} must be finite; got {bad!r}")
    return arr


def cos_theta(value: Any, name: str = "z") -> np.ndarray:
    """z = cos θ: finite and within [-1, 1]."""
    z = as_finite_array(name, value)
    if np.any(np.abs(z) > 1.0):
        bad = z[np.abs(z) > 1.0].ravel()[0].item()
        raise ValueError(f"{name} = cos(theta) must lie in [-1, 1]; got {bad!r}")
    return z


def theta(value: Any, name: str = "theta") -> np.ndarray:
    """Inclination angle θ: finite and within [0, π]."""
    th = as_finite_array(name, value)
    if np.any((th < 0.0) | (th > np.pi)):
        bad = th[(th < 0.0) | (th > np.pi)].ravel()[0].item()
        raise ValueError(f"{name} must lie in [0, pi]; got {bad!r}")
    return th
