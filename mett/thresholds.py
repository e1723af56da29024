"""Thresholds of the Jellett integral and the spinning (boundary) states (theory.md §6–§7).

References: Rauch-Wojciechowski & Rutstam (2014, SIGMA 10, 017) for λ_thres and the boundary values
(D0, E0), (D1, E1); the λ_0 end of the tumbling family and the rolling-stability bound λ_roll are
derived in theory.md §7.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from . import _validate

if TYPE_CHECKING:
    from .top import TippeTop

__all__ = [
    "BoundaryValues",
    "boundary_values",
    "lambda_0",
    "lambda_E",
    "lambda_roll",
    "lambda_thres",
]


def _scale(top: TippeTop) -> float:
    return math.sqrt(top.m * top.g * top.R**3 * top.I3 * top.alpha)


def lambda_thres(top: TippeTop) -> float:
    """λ_thres = √(m g R³ I3 α) (1 + α)² / √(1 + α − γ) (RR14 abstract; theory.md §7).

    The inverted spin (θ = π) of the gliding top is asymptotically stable iff λ > λ_thres. For
    γ >= 1 + α (group III) it is never stable and ``inf`` is returned.
    """
    den = 1.0 + top.alpha - top.gamma
    if den <= 0.0:
        return math.inf
    return _scale(top) * (1.0 + top.alpha) ** 2 / math.sqrt(den)


def lambda_0(top: TippeTop) -> float:
    """λ_0 = √(m g R³ I3 α) (1 − α)² / √(α + γ − 1), the θ_t → 0 end of the tumbling family.

    The non-inverted spin (θ = 0) is unstable iff λ > λ_0. For γ <= 1 − α (group I) it is stable for
    every λ and ``inf`` is returned (theory.md §7).
    """
    den = top.alpha + top.gamma - 1.0
    if den <= 0.0:
        return math.inf
    return _scale(top) * (1.0 - top.alpha) ** 2 / math.sqrt(den)


def lambda_E(top: TippeTop) -> float:
    """λ_E = √(m g R³ I3) (1 − α²): the inverted spin has less energy (E1 < E0) iff λ > λ_E (§6)."""
    return math.sqrt(top.m * top.g * top.R**3 * top.I3) * (1.0 - top.alpha**2)


def lambda_roll(top: TippeTop) -> float:
    """Rolling (frictionless) stability bound of the inverted spin (theory.md §7).

    λ_roll = 2√(m g R³ I3 α)(1 + α)√(γ + σ(1+α)²)/(1 + σ(1 + α)); λ_roll <= λ_thres always.
    """
    a, gam, sig = top.alpha, top.gamma, top.sigma
    return (
        2.0 * _scale(top) * (1.0 + a) * math.sqrt(gam + sig * (1 + a) ** 2) / (1.0 + sig * (1 + a))
    )


class BoundaryValues(NamedTuple):
    """Integrals of the two spinning solutions with Jellett integral λ (theory.md §6)."""

    D0: np.ndarray
    """Routh integral of the spin at θ = 0."""
    E0: np.ndarray
    """Energy of the spin at θ = 0."""
    D1: np.ndarray
    """Routh integral of the spin at θ = π."""
    E1: np.ndarray
    """Energy of the spin at θ = π."""
    omega3_0: np.ndarray
    """Spin ω3 = λ/(R I3 (1 − α)) at θ = 0."""
    omega3_1: np.ndarray
    """Spin ω3 = −λ/(R I3 (1 + α)) at θ = π."""


def boundary_values(top: TippeTop, lam: ArrayLike) -> BoundaryValues:
    """Spinning solutions at θ = 0 and θ = π for the Jellett integral ``lam`` (RR14 §3; theory.md §6).

    ``D0 = λ√d(1)/(R(1 − α))``, ``E0 = λ²/(2 I3 R²(1 − α)²) + m g R(1 − α)``,
    ``D1 = −λ√d(−1)/(R(1 + α))``, ``E1 = λ²/(2 I3 R²(1 + α)²) + m g R(1 + α)``.
    """
    from .potential import d

    lam = _validate.as_finite_array("lam", lam)
    R, a, I3 = top.R, top.alpha, top.I3
    mgR = top.m * top.g * R
    D0 = lam * math.sqrt(float(d(top, 1.0))) / (R * (1.0 - a))
    D1 = -lam * math.sqrt(float(d(top, -1.0))) / (R * (1.0 + a))
    E0 = lam**2 / (2.0 * I3 * R**2 * (1.0 - a) ** 2) + mgR * (1.0 - a)
    E1 = lam**2 / (2.0 * I3 * R**2 * (1.0 + a) ** 2) + mgR * (1.0 + a)
    return BoundaryValues(D0, E0, D1, E1, lam / (R * I3 * (1.0 - a)), -lam / (R * I3 * (1.0 + a)))
