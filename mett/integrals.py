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
    c, sn = np.cos(state.theta), np.sin(state.theta)
    return top.R * top.I1 * state.phidot * sn**2 - top.R * top.I3 * state.omega3 * (top.alpha - c)


def routh(top: TippeTop, state: State) -> np.ndarray:
    """Routh integral D = I3 ω3 √d(cos θ) (theory.md §1); conserved only while rolling."""
    return top.I3 * state.omega3 * np.sqrt(d(top, np.cos(state.theta)))


def _rotational_and_potential(top: TippeTop, s: State) -> np.ndarray:
    c, sn = np.cos(s.theta), np.sin(s.theta)
    rot = 0.5 * (top.I1 * (s.phidot**2 * sn**2 + s.thetadot**2) + top.I3 * s.omega3**2)
    return rot + top.m * top.g * top.R * (1.0 - top.alpha * c)


def energy(top: TippeTop, state: State) -> np.ndarray:
    """Total energy E = ½ m|ṙ|² + ½ ω·L + m g R (1 − α cos θ) (theory.md §1).

    The centre-of-mass velocity is ṙ = ν − ω × a.
    """
    c, sn = np.cos(state.theta), np.sin(state.theta)
    wa1, wa2, wa3 = _omega_cross_a(top, state)
    v1 = state.nu_x * c - wa1
    v2 = state.nu_y - wa2
    v3 = state.nu_x * sn - wa3
    return 0.5 * top.m * (v1**2 + v2**2 + v3**2) + _rotational_and_potential(top, state)


def modified_energy(top: TippeTop, state: State) -> np.ndarray:
    """Modified energy Ẽ = E − ½ m|ν|² + m ν·(ω × a) (theory.md §3).

    This, not E, is the energy of the Main Equation Ẽ = g(z) θ̇² + V(z, D, λ) while the top glides;
    Ẽ = E when ν = 0. Algebraically Ẽ = ½ m|ω × a|² + ½ ω·L + m g R(1 − α cos θ), which is how it is
    evaluated here (no cancellation between E and the ν terms).
    """
    wa1, wa2, wa3 = _omega_cross_a(top, state)
    return 0.5 * top.m * (wa1**2 + wa2**2 + wa3**2) + _rotational_and_potential(top, state)
