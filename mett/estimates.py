"""Estimates of the inverting top's METT (Rauch-Wojciechowski & Rutstam 2014, §3–4; docs/theory/estimates.md#estimates).

While the top inverts, D(t) travels from near D0 to near D1 (docs/theory/thresholds.md#boundary-values) and the minimum of
V(z, D, λ) travels with it from z ≈ 1 to z ≈ −1. The small-oscillation period about that minimum,
with D and Ẽ frozen, is bounded by its values at the two ends:

    T(D0) = 2π d(1) / (ω3,0 (1 + σ(1 − α))),    ω3,0 = λ/(R I3 (1 − α)),
    T(D1) = 2π d(−1) / (|ω3,1| (1 + σ(1 + α))), ω3,1 = −λ/(R I3 (1 + α)),

the high-spin nutation frequencies at the poles (docs/theory/high-spin.md#high-spin). For a rational top they reduce to
RR14's T(D0) = 2π R I3 (1 − α)(α + γ − 1)/(α λ) and T(D1) = 2π R I3 (1 + α)(1 + α − γ)/(α λ).
Caveat (docs/theory/estimates.md#estimates): the *gliding* top oscillates faster than these rolling estimates.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from . import _validate
from .potential import V, d, d2V_dz2, g
from .separation import minima
from .thresholds import pole_spins
from .top import TippeTop

__all__ = [
    "Convexity",
    "PeriodEstimates",
    "convexity",
    "oscillation_ratio",
    "period_estimates",
    "potential_minimum",
    "small_oscillation_period",
]


def potential_minimum(top: TippeTop, D: float, lam: float) -> float:
    """z = cos θ of the global minimum of V(·, D, λ) on [−1, 1] (scalar D and λ).

    Found from the sign changes of the regular numerator (1 − z²)² ∂V/∂z, so a pole is returned
    when V decreases towards it (possible only when N vanishes there, D = D0 or D1).
    """
    mins = minima(top, D, lam)  # validates top, D, lam
    return min(mins, key=lambda z: float(V(top, z, D, lam)))  # the deepest well


class Convexity(NamedTuple):
    """Shape of V(·, D, λ) on (−1, 1) (RR14's convexity theorem; docs/theory/estimates.md#estimates)."""

    convex: bool
    """V'' > 0 at every sample of (−1, 1)."""
    n_minima: int
    """Number of local minima of V on [−1, 1]."""
    min_curvature: float
    """Smallest sampled V'' (J)."""


def convexity(top: TippeTop, D: float, lam: float, *, samples: int = 2001) -> Convexity:
    """Check that V(·, D, λ) is convex on (−1, 1) with a single minimum (scalar D, λ; RR14 §3).

    V'' is sampled at ``samples`` Chebyshev points inside (−1, 1), denser towards the poles.
    """
    _validate.instance("top", top, TippeTop)
    D = _validate.finite_scalar("D", D)
    lam = _validate.finite_scalar("lam", lam)
    z = np.cos(np.pi * (np.arange(samples) + 0.5) / samples)
    curv = d2V_dz2(top, z, D, lam)
    return Convexity(bool(np.all(curv > 0.0)), len(minima(top, D, lam)), float(curv.min()))


def small_oscillation_period(top: TippeTop, D: float, lam: float) -> float:
    """Period 2π/ω_θ of small θ-oscillations about the minimum of V (scalar D, λ; docs/theory/estimates.md#estimates).

    ω_θ² = (1 − z_m²) V''(z_m)/(2 g(z_m)) with z_m = :func:`potential_minimum`; at a spinning pole
    (z_m = ±1) ω_θ² = 2|V'(±1)|/g(±1).
    """
    _validate.instance("top", top, TippeTop)
    from .potential import dV_dz

    zm = potential_minimum(top, D, lam)
    if abs(zm) == 1.0:
        omega2 = 2.0 * abs(float(dV_dz(top, zm, D, lam))) / float(g(top, zm))
    else:
        omega2 = (1 - zm * zm) * float(d2V_dz2(top, zm, D, lam)) / (2.0 * float(g(top, zm)))
    return 2.0 * math.pi / math.sqrt(omega2)


class PeriodEstimates(NamedTuple):
    """Rolling-METT oscillation periods at the two ends of the inversion (docs/theory/estimates.md#estimates)."""

    T_D0: float
    """Period near the start (D = D0, minimum at z = 1), s."""
    T_D1: float
    """Period near the end (D = D1, minimum at z = −1), s: the largest, T_max."""


def period_estimates(top: TippeTop, lam: float) -> PeriodEstimates:
    """(T(D0), T(D1)) of RR14 for the Jellett integral ``lam`` > 0 (module docstring).

    For the thesis run (λ = 6.8944e-6) T(D0) = 0.03208 s and T(D1) = 0.09207 s. The periods are
    ∝ 1/λ, so any positive λ up to the float maximum gives finite, positive periods, except a λ so
    small (below 3.5e-315 kg m³/s for the thesis body) that they would exceed the float range.

    Raises
    ------
    TypeError
        If ``top`` is not a :class:`~mett.TippeTop` or ``lam`` not a real number.
    ValueError
        If ``lam`` is not positive and finite, or so small that the periods overflow.
    """
    _validate.instance("top", top, TippeTop)
    lam = _validate.positive_jellett(lam)
    a, sig = top.alpha, top.sigma
    # the spins per unit λ, so that a subnormal λ does not make ω3 subnormal first
    w0, w1 = pole_spins(top, 1.0)
    w1 = -w1  # the size of the inverted spin
    T0 = 2.0 * math.pi * float(d(top, 1.0)) / (w0 * (1.0 + sig * (1.0 - a)))
    T1 = 2.0 * math.pi * float(d(top, -1.0)) / (w1 * (1.0 + sig * (1.0 + a)))
    if lam < max(T0, T1) / _FLOAT_MAX:  # T/λ would overflow
        raise ValueError(
            f"lam must be at least {max(T0, T1) / _FLOAT_MAX:.3g} kg m^3/s for this top (below it "
            f"the periods exceed the floating-point range); got {lam!r}"
        )
    return PeriodEstimates(T0 / lam, T1 / lam)


_FLOAT_MAX = float(np.finfo(float).max)


def oscillation_ratio(top: TippeTop, lam: float, t_inversion: float) -> float:
    """Inversion time over the largest estimated period, t_inv / max(T(D0), T(D1)).

    RR14's oscillation criterion: θ(t) oscillates during the inversion when this ratio is ≫ 1.
    """
    _validate.instance("top", top, TippeTop)
    t_inversion = _validate.positive_scalar("t_inversion", t_inversion)
    return t_inversion / max(period_estimates(top, lam))
