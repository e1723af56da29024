"""Input validation shared by every public function, and mett's warning categories.

The rules (docs/reliability.md): bad input is refused before any work or write, with a
``ValueError`` (a value out of range) or ``TypeError`` (not a number at all: a string, a boolean,
``None``, a complex number) whose message names the parameter, its valid range and the offending
value, e.g. ``ValueError: alpha must lie in (0, 1); got 1.5``. Every warning mett emits is a
:class:`MettWarning` subclass reported at the caller's line (:func:`warn`).
"""

from __future__ import annotations

import math
import os
import sys
import warnings
from pathlib import Path
from types import FrameType
from typing import Any, TypeVar

import numpy as np

_T = TypeVar("_T")

__all__ = [
    "AccuracyWarning",
    "MettDeprecationWarning",
    "MettWarning",
    "PhysicalityWarning",
    "ToleranceWarning",
    "as_finite_array",
    "boolean",
    "bounded_scalar",
    "cos_theta",
    "finite_scalar",
    "instance",
    "output_path",
    "positive_int",
    "positive_jellett",
    "positive_scalar",
    "real_array",
    "theta",
    "warn",
]


class MettWarning(UserWarning):
    """Base category of every warning mett emits (filter it with ``warnings``)."""


class PhysicalityWarning(MettWarning):
    """Legal but physically suspicious input (e.g. I3 > m R², as in the Maple-paper table)."""


class MettDeprecationWarning(MettWarning, DeprecationWarning):
    """A deprecated name was used; the message names its replacement."""


class ToleranceWarning(MettWarning):
    """A tolerance was changed to one the integrator can meet (e.g. rtol raised to 100 ε)."""


def _fmt(value: Any) -> str:
    arr = np.asarray(value)
    if arr.ndim == 0:
        return repr(arr.item())
    bad = arr.ravel()
    return f"array of shape {arr.shape} (e.g. {bad[0]!r})"


class AccuracyWarning(MettWarning):
    """A request mett had to adjust or cannot meet to the asked accuracy (e.g. a clamped rtol)."""


# Modules whose frames a warning skips to reach the user's line: mett itself, and the frames that
# dataclasses and functools insert between a public call and mett's code.
_INTERNAL = ("mett", "dataclasses", "functools")


def warn(message: str, category: type[MettWarning] = MettWarning) -> None:
    """Emit ``message`` as ``category``, attributed to the first caller outside mett.

    A fixed ``stacklevel`` is wrong as soon as the same check is reached through two paths (e.g.
    ``TippeTop(...)`` directly and via ``presets.get``); walking the stack is not.
    """
    if not (isinstance(category, type) and issubclass(category, MettWarning)):
        raise TypeError(f"category must be a MettWarning subclass; got {category!r}")
    level = 2
    frame: FrameType | None = sys._getframe(1)
    while frame is not None and frame.f_globals.get("__name__", "").split(".")[0] in _INTERNAL:
        frame = frame.f_back
        level += 1
    warnings.warn(message, category, stacklevel=level)


def instance(name: str, value: _T, cls: type[_T]) -> _T:
    """``TypeError`` unless ``value`` is an instance of ``cls`` (e.g. :class:`mett.TippeTop`).

    The caller passes the class itself: this bottom floor imports nothing of mett.
    """
    if not isinstance(value, cls):
        raise TypeError(f"{name} must be a {cls.__name__}; got {_type_name(value)}")
    return value


def _type_name(value: Any) -> str:
    return type(value).__name__


def _reject_non_real(name: str, value: Any) -> None:
    """TypeError for values that float() would accept but that are not numbers (str, bool, …)."""
    if value is None or isinstance(value, (str, bytes, bool, np.bool_)):
        raise TypeError(f"{name} must be a real number; got {_type_name(value)} {value!r}")
    if isinstance(value, (complex, np.complexfloating)):
        raise TypeError(f"{name} must be a real number; got complex {value!r}")


def finite_scalar(name: str, value: Any) -> float:
    """Return ``value`` as a finite float.

    Raises ``TypeError`` for non-numbers (strings, booleans, None, complex, arrays of several
    values) and ``ValueError`` for NaN or ±inf, naming ``name``.
    """
    if type(value) is float and math.isfinite(value):  # the common case, checked in 0.1 µs
        return value
    _reject_non_real(name, value)
    if isinstance(value, np.ndarray) and value.size != 1:
        raise TypeError(f"{name} must be a single real number; got an array of shape {value.shape}")
    if isinstance(value, np.ndarray) and value.dtype.kind not in "iuf":
        raise TypeError(f"{name} must be a real number; got an array of dtype {value.dtype}")
    try:
        x = float(value)
    except (TypeError, ValueError, OverflowError):
        raise TypeError(
            f"{name} must be a finite real number; got {_type_name(value)} {value!r}"
        ) from None
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


def bounded_scalar(
    name: str, value: Any, lo: float, hi: float, *, unit: str = "", allow_zero: bool = False
) -> float:
    """A finite float in [lo, hi] (or exactly 0 with ``allow_zero``); the message gives the range."""
    x = finite_scalar(name, value)
    if allow_zero and x == 0.0:
        return x
    if not lo <= x <= hi:
        zero = "be 0 or " if allow_zero else ""
        suffix = f" {unit}" if unit else ""
        raise ValueError(f"{name} must {zero}lie in [{lo:g}, {hi:g}]{suffix}; got {x!r}")
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


def positive_int(name: str, value: Any, *, minimum: int = 1) -> int:
    """An integer ≥ ``minimum`` (booleans and floats are refused with ``TypeError``)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise TypeError(
            f"{name} must be an integer >= {minimum}; got {_type_name(value)} {value!r}"
        )
    if value < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}; got {int(value)!r}")
    return int(value)


def boolean(name: str, value: Any) -> bool:
    """``True`` or ``False`` exactly: ``"no"``, ``0`` or ``None`` are refused with ``TypeError``.

    (``bool("no")`` is True, so a truthiness test would silently invert such an option.)
    """
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    raise TypeError(f"{name} must be True or False; got {_type_name(value)} {value!r}")


_PLAIN_REALS = (float, np.float64)


def as_finite_array(name: str, value: Any) -> np.ndarray:
    """A new float array (never a view of the caller's) with every element finite.

    ``TypeError`` for strings, booleans, None or complex values; ``ValueError`` for NaN/inf or a
    ragged nesting, naming ``name``.
    """
    if type(value) in _PLAIN_REALS or (type(value) is int and abs(value) < 2**53):
        # the common scalar case, without numpy's machinery
        if not math.isfinite(value):
            raise ValueError(f"{name} must be finite; got {float(value)!r}")
        return np.array(float(value))
    arr = real_array(name, value)
    if not np.all(np.isfinite(arr)):
        bad = arr[~np.isfinite(arr)].ravel()[0].item()
        raise ValueError(f"{name} must be finite; got {bad!r}")
    return arr


def real_array(name: str, value: Any) -> np.ndarray:
    """A new float array of real numbers (NaN and ±inf allowed: the caller checks them).

    The type rules of :func:`finite_scalar`, element by element: ``TypeError`` naming ``name``
    for strings, bytes, booleans, None or complex values (``np.asarray(..., dtype=float)`` would
    parse the strings, read booleans as 0/1 and drop imaginary parts), ``ValueError`` for a
    ragged nesting.
    """
    _reject_non_real(name, value)
    try:
        raw = np.asarray(value)
    except ValueError:  # ragged nested sequences
        raise ValueError(f"{name} must be a rectangular array of real numbers") from None
    kind = raw.dtype.kind
    if kind in "USbcVMm" or (kind == "O" and any(_is_non_real(v) for v in raw.ravel())):
        bad: Any = raw.ravel()
        if kind == "O":
            bad = [v for v in bad if _is_non_real(v)]
        example = bad[0] if len(bad) else raw
        raise TypeError(f"{name} must be real numbers; got dtype {raw.dtype} (e.g. {example!r})")
    if isinstance(value, (list, tuple)) and kind in "iuf":  # numpy made [0.1, True] floats
        example = _first_non_real(value)
        if example is not None:
            raise TypeError(f"{name} must be real numbers; got {_type_name(example)} {example!r}")
    try:
        return np.array(raw, dtype=float, copy=True)
    except (TypeError, ValueError, OverflowError):
        raise TypeError(f"{name} must be real numbers; got {value!r}") from None


def _first_non_real(seq: Any) -> Any:
    """The first boolean (or other non-number) in nested lists/tuples, else None."""
    for v in seq:
        if isinstance(v, (list, tuple)):
            found = _first_non_real(v)
            if found is not None:
                return found
        elif isinstance(v, np.ndarray):
            if v.dtype.kind not in "iuf":
                return v.ravel()[0]
        elif _is_non_real(v):
            return v
    return None


def _is_non_real(v: Any) -> bool:
    return v is None or isinstance(v, (str, bytes, bool, np.bool_, complex, np.complexfloating))


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
    if th.ndim == 0 and 0.0 <= th <= np.pi:
        return th
    if np.any((th < 0.0) | (th > np.pi)):
        bad = th[(th < 0.0) | (th > np.pi)].ravel()[0].item()
        raise ValueError(f"{name} must lie in [0, pi]; got {bad!r}")
    return th


def output_path(name: str, value: Any) -> Path:
    """A path a file can be written to: its directory exists and it is not itself a directory.

    Checked before any work, so a long computation does not end in a failed write.
    """
    if not isinstance(value, (str, os.PathLike)) or isinstance(value, bytes):
        raise TypeError(f"{name} must be a path (str or os.PathLike); got {_type_name(value)}")
    if os.fspath(value) == "":
        raise ValueError(f"{name} must be a file path; got an empty string")
    path = Path(value)
    if path.is_dir():
        raise ValueError(f"{name} must be a file, not a directory; got {str(path)!r}")
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise ValueError(f"{name}: directory {str(parent)!r} does not exist; got {str(path)!r}")
    if not os.access(parent, os.W_OK) or (path.exists() and not os.access(path, os.W_OK)):
        raise ValueError(f"{name}: {str(path)!r} is not writable")
    return path
