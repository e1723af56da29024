"""Jellett λ, Routh D, energy E and modified energy Ẽ of a state (docs/theory/model.md#conventions, docs/theory/equations.md#integrals).

The ``*_of`` functions are the one implementation of each integral: plain arithmetic on floats or
equal-shape arrays of the reduced variables (θ, θ̇, φ̇, ω3, ν_x, ν_y), for a sphere of radius R whose
centre of mass lies at l = Rα from its centre (R = 0: the heavy symmetric top on a tip at distance
l), so that the contact vector is a = l 3̂ − R ẑ. :func:`jellett`, :func:`routh`, :func:`energy`
and :func:`modified_energy` evaluate them for a :class:`~mett.State` (fields may be arrays) of a
:class:`~mett.TippeTop`; the dynamical models evaluate them on their trajectories.

In the horizontal frame (x̂, ŷ, ẑ) of docs/theory/model.md#conventions, ω × a = (θ̇(l c − R), s(R ω3 + φ̇(l − R c)),
−l s θ̇) with s = sin θ, c = cos θ, and the centre-of-mass velocity is ṙ = ν − ω × a.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from .potential import d_of
from .state import State
from .top import TippeTop

__all__ = [
    "energy",
    "energy_of",
    "integrals_of",
    "jellett",
    "jellett_of",
    "modified_energy",
    "modified_energy_of",
    "routh",
    "routh_of",
]


def jellett_of(
    theta: ArrayLike, phidot: ArrayLike, omega3: ArrayLike, R: float, l: float, I1: float, I3: float
) -> Any:
    """Jellett's integral λ = −L·a = R I1 φ̇ sin²θ − I3 ω3 (l − R cos θ) (kg m³/s).

    Conserved for any contact force applied at the contact point (Rutstam 2012 §3).
    """
    return _jellett(np.sin(theta), np.cos(theta), phidot, omega3, R, l, I1, I3)


def routh_of(
    theta: ArrayLike, omega3: ArrayLike, m: float, R: float, l: float, I1: float, I3: float
) -> Any:
    """Routh's integral D = I3 ω3 √d(cos θ) (kg m²/s); conserved only while rolling."""
    return _routh(np.cos(theta), omega3, m, R, l, I1, I3)


def energy_of(
    theta: ArrayLike,
    thetadot: ArrayLike,
    phidot: ArrayLike,
    omega3: ArrayLike,
    nu_x: ArrayLike,
    nu_y: ArrayLike,
    m: float,
    R: float,
    l: float,
    I1: float,
    I3: float,
    g: float,
) -> Any:
    """Total energy E = ½ m|ṙ|² + ½ ω·L + m g (R − l cos θ) (J), with ṙ = ν − ω × a."""
    s, c = np.sin(theta), np.cos(theta)
    w = _omega_cross_a(s, c, thetadot, phidot, omega3, R, l)
    return _energy(m, nu_x, nu_y, w, _rot_pot(s, c, thetadot, phidot, omega3, m, R, l, I1, I3, g))


def modified_energy_of(
    theta: ArrayLike,
    thetadot: ArrayLike,
    phidot: ArrayLike,
    omega3: ArrayLike,
    m: float,
    R: float,
    l: float,
    I1: float,
    I3: float,
    g: float,
) -> Any:
    """Modified energy Ẽ = ½ m|ω × a|² + ½ ω·L + m g (R − l cos θ) (J) (docs/theory/equations.md#integrals).

    Ẽ = E − ½ m|ν|² + m ν·(ω × a): the energy of the Main Equation Ẽ = g(z) θ̇² + V(z, D, λ) while
    the top glides, equal to E when ν = 0; evaluated in this form (no cancellation).
    """
    s, c = np.sin(theta), np.cos(theta)
    w = _omega_cross_a(s, c, thetadot, phidot, omega3, R, l)
    return _modified_energy(m, w, _rot_pot(s, c, thetadot, phidot, omega3, m, R, l, I1, I3, g))


def integrals_of(
    theta: ArrayLike,
    thetadot: ArrayLike,
    phidot: ArrayLike,
    omega3: ArrayLike,
    nu_x: ArrayLike,
    nu_y: ArrayLike,
    m: float,
    R: float,
    l: float,
    I1: float,
    I3: float,
    g: float,
) -> dict[str, Any]:
    """E, Ẽ ("E_mod"), D and λ ("lam") together (sharing sin θ, cos θ and ω × a), as above."""
    s, c = np.sin(theta), np.cos(theta)
    w = _omega_cross_a(s, c, thetadot, phidot, omega3, R, l)
    rot_pot = _rot_pot(s, c, thetadot, phidot, omega3, m, R, l, I1, I3, g)
    return {
        "E": _energy(m, nu_x, nu_y, w, rot_pot),
        "E_mod": _modified_energy(m, w, rot_pot),
        "D": _routh(c, omega3, m, R, l, I1, I3),
        "lam": _jellett(s, c, phidot, omega3, R, l, I1, I3),
    }


def _energy(m, nu_x, nu_y, w, rot_pot):
    # ½ m |ν − ω × a|² + rotational + potential
    return 0.5 * m * ((nu_x - w[0]) ** 2 + (nu_y - w[1]) ** 2 + w[2] ** 2) + rot_pot


def _modified_energy(m, w, rot_pot):
    # ½ m |ω × a|² + rotational + potential
    return 0.5 * m * (w[0] ** 2 + w[1] ** 2 + w[2] ** 2) + rot_pot


def _jellett(s, c, phidot, omega3, R, l, I1, I3):
    return R * I1 * phidot * s**2 - I3 * omega3 * (l - R * c)


def _routh(c, omega3, m, R, l, I1, I3):
    return I3 * omega3 * np.sqrt(d_of(c, m, R, l, I1, I3))


def _omega_cross_a(s, c, thetadot, phidot, omega3, R, l):
    return thetadot * (l * c - R), s * (R * omega3 + phidot * (l - R * c)), -l * s * thetadot


def _rot_pot(s, c, thetadot, phidot, omega3, m, R, l, I1, I3, g):
    rot = 0.5 * (I1 * (phidot**2 * s**2 + thetadot**2) + I3 * omega3**2)
    return rot + m * g * (R - l * c)


def _arrays(top: TippeTop, state: State) -> _Fields:
    """The state with float64 array fields, after checking both arguments' types.

    A scalar State holds Python floats, whose ``**`` raises OverflowError; numpy float64 overflows
    to inf instead, which :func:`_finite` turns into a ValueError naming the state.
    """
    _check_types(top, state)
    return _Fields(*(np.asarray(getattr(state, n), dtype=float) for n in _FIELDS))


def _check_types(top: TippeTop, state: State) -> None:
    if not isinstance(top, TippeTop):
        raise TypeError(f"top must be a TippeTop; got {type(top).__name__}")
    if not isinstance(state, State):
        raise TypeError(f"state must be a State; got {type(state).__name__}")


_FIELDS = ("theta", "thetadot", "phidot", "omega3", "nu_x", "nu_y")


class _Fields:
    __slots__ = _FIELDS
    theta: np.ndarray
    thetadot: np.ndarray
    phidot: np.ndarray
    omega3: np.ndarray
    nu_x: np.ndarray
    nu_y: np.ndarray

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


def jellett(top: TippeTop, state: State) -> np.ndarray:
    """Jellett integral λ = −L·a = R I1 φ̇ sin²θ − R I3 ω3 (α − cos θ) (docs/theory/model.md#conventions).

    Conserved for any contact force applied at the contact point. Positive for a top spun with
    ω3 > 0 near θ = 0.
    """
    _check_types(top, state)
    if type(state.theta) is float:  # one state: float arithmetic, no numpy error state to switch
        th, phd, w3 = state.theta, float(state.phidot), float(state.omega3)
        lam = _jellett(
            math.sin(th), math.cos(th), phd, w3, top.R, top.R * top.alpha, top.I1, top.I3
        )
        if math.isfinite(lam):
            return np.float64(lam)
    s = _arrays(top, state)
    with np.errstate(over="ignore", invalid="ignore"):
        lam = jellett_of(s.theta, s.phidot, s.omega3, top.R, top.R * top.alpha, top.I1, top.I3)
    return _finite("the Jellett integral", lam, s)


def routh(top: TippeTop, state: State) -> np.ndarray:
    """Routh integral D = I3 ω3 √d(cos θ) (docs/theory/model.md#conventions); conserved only while rolling."""
    s = _arrays(top, state)
    with np.errstate(over="ignore", invalid="ignore"):
        D = routh_of(s.theta, s.omega3, top.m, top.R, top.R * top.alpha, top.I1, top.I3)
    return _finite("the Routh integral", D, s)


def energy(top: TippeTop, state: State) -> np.ndarray:
    """Total energy E = ½ m|ṙ|² + ½ ω·L + m g R (1 − α cos θ) (docs/theory/model.md#conventions).

    The centre-of-mass velocity is ṙ = ν − ω × a.
    """
    s = _arrays(top, state)
    with np.errstate(over="ignore", invalid="ignore"):
        E = energy_of(s.theta, s.thetadot, s.phidot, s.omega3, s.nu_x, s.nu_y,
                      top.m, top.R, top.R * top.alpha, top.I1, top.I3, top.g)  # fmt: skip
    return _finite("the energy", E, s)


def modified_energy(top: TippeTop, state: State) -> np.ndarray:
    """Modified energy Ẽ = E − ½ m|ν|² + m ν·(ω × a) (docs/theory/equations.md#integrals).

    This, not E, is the energy of the Main Equation Ẽ = g(z) θ̇² + V(z, D, λ) while the top glides;
    Ẽ = E when ν = 0. Algebraically Ẽ = ½ m|ω × a|² + ½ ω·L + m g R(1 − α cos θ), which is how it is
    evaluated here (no cancellation between E and the ν terms).
    """
    s = _arrays(top, state)
    with np.errstate(over="ignore", invalid="ignore"):
        E = modified_energy_of(s.theta, s.thetadot, s.phidot, s.omega3,
                               top.m, top.R, top.R * top.alpha, top.I1, top.I3, top.g)  # fmt: skip
    return _finite("the modified energy", E, s)
