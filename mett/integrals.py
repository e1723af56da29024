"""Jellett λ, Routh D, energy E and modified energy Ẽ of a state (theory.md §1, §3).

All functions accept a :class:`~mett.State` whose fields may be arrays and return arrays of that
shape. Vectors are written in the Resal frame (1̂, 2̂, 3̂), in which (theory.md §1)

* ω = (−φ̇ sin θ, θ̇, ω3),
* a = R(α 3̂ − ẑ) = R (sin θ, 0, α − cos θ)  (centre of mass → contact point),
* ν = ν_x x̂ + ν_y ŷ = (ν_x cos θ, ν_y, ν_x sin θ).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .potential import d

if TYPE_CHECKING:
    from .state import State
    from .top import TippeTop

__all__ = ["energy", "jellett", "modified_energy", "routh"]


def _arrays(top: TippeTop, state: State) -> _Fields:
    """The state with float64 array fields, after checking both arguments' types.

    A scalar State holds Python floats, whose ``**`` raises OverflowError; numpy float64 overflows
    to inf instead, which :func:`_finite` turns into a ValueError naming the state.
    """
    from .state import State
    from .top import TippeTop

    if not isinstance(top, TippeTop):
        raise TypeError(f"top must be a TippeTop; got {type(top).__name__}")
    if not isinstance(state, State):
        raise TypeError(f"state must be a State; got {type(state).__name__}")
    return _Fields(*(np.asarray(getattr(state, n), dtype=float) for n in _FIELDS))


_FIELDS = ("theta", "thetadot", "phidot", "omega3", "nu_x", "nu_y")


class _Fields:
    __slots__ = _FIELDS

    def __init__(self, *values: np.ndarray) -> None:
        for name, v in zip(_FIELDS, values, strict=True):
            setattr(self, name, v)


def _finite(what: str, value: np.ndarray, state: _Fields) -> np.ndarray:
    if not np.all(np.isfinite(value)):
        big = max(_FIELDS[1:], key=lambda n: float(np.max(np.abs(getattr(state, n)))))
        raise ValueError(
            f"state: {what} overflows double precision (|value| > 1.8e308) for this state; "
            f"its largest field is {big} = {float(np.max(np.abs(getattr(state, big)))):g}"
        )
    return value


def _omega_cross_a(top: TippeTop, s: State) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """ω × a in the Resal frame."""
    c, sn = np.cos(s.theta), np.sin(s.theta)
    w1, w2, w3 = -s.phidot * sn, s.thetadot, s.omega3
    a1, a3 = top.R * sn, top.R * (top.alpha - c)
    return w2 * a3, w3 * a1 - w1 * a3, -w2 * a1


def jellett(top: TippeTop, state: State) -> np.ndarray:
    """Jellett integral λ = −L·a = R I1 φ̇ sin²θ − R I3 ω3 (α − cos θ) (theory.md §1).

    Conserved for any contact force applied at the contact point. Positive for a top spun with
    ω3 > 0 near θ = 0.
    """
    state = _arrays(top, state)
    c, sn = np.cos(state.theta), np.sin(state.theta)
    with np.errstate(over="ignore", invalid="ignore"):
        lam = top.R * top.I1 * state.phidot * sn**2 - top.R * top.I3 * state.omega3 * (
            top.alpha - c
        )
    return _finite("the Jellett integral", lam, state)


def routh(top: TippeTop, state: State) -> np.ndarray:
    """Routh integral D = I3 ω3 √d(cos θ) (theory.md §1); conserved only while rolling."""
    state = _arrays(top, state)
    with np.errstate(over="ignore", invalid="ignore"):
        D = top.I3 * state.omega3 * np.sqrt(d(top, np.cos(state.theta)))
    return _finite("the Routh integral", D, state)


def _rotational_and_potential(top: TippeTop, s: State) -> np.ndarray:
    c, sn = np.cos(s.theta), np.sin(s.theta)
    rot = 0.5 * (top.I1 * (s.phidot**2 * sn**2 + s.thetadot**2) + top.I3 * s.omega3**2)
    return rot + top.m * top.g * top.R * (1.0 - top.alpha * c)


def energy(top: TippeTop, state: State) -> np.ndarray:
    """Total energy E = ½ m|ṙ|² + ½ ω·L + m g R (1 − α cos θ) (theory.md §1).

    The centre-of-mass velocity is ṙ = ν − ω × a.
    """
    state = _arrays(top, state)
    c, sn = np.cos(state.theta), np.sin(state.theta)
    with np.errstate(over="ignore", invalid="ignore"):
        wa1, wa2, wa3 = _omega_cross_a(top, state)
        v1 = state.nu_x * c - wa1
        v2 = state.nu_y - wa2
        v3 = state.nu_x * sn - wa3
        E = 0.5 * top.m * (v1**2 + v2**2 + v3**2) + _rotational_and_potential(top, state)
    return _finite("the energy", E, state)


def modified_energy(top: TippeTop, state: State) -> np.ndarray:
    """Modified energy Ẽ = E − ½ m|ν|² + m ν·(ω × a) (theory.md §3).

    This, not E, is the energy of the Main Equation Ẽ = g(z) θ̇² + V(z, D, λ) while the top glides;
    Ẽ = E when ν = 0. Algebraically Ẽ = ½ m|ω × a|² + ½ ω·L + m g R(1 − α cos θ), which is how it is
    evaluated here (no cancellation between E and the ν terms).
    """
    state = _arrays(top, state)
    with np.errstate(over="ignore", invalid="ignore"):
        wa1, wa2, wa3 = _omega_cross_a(top, state)
        E = 0.5 * top.m * (wa1**2 + wa2**2 + wa3**2) + _rotational_and_potential(top, state)
    return _finite("the modified energy", E, state)
