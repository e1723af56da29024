"""Thresholds of the Jellett integral and the spinning (boundary) states (docs/theory/thresholds.md#boundary-values, docs/theory/thresholds.md#thresholds).

References: Rauch-Wojciechowski & Rutstam (2014, SIGMA 10, 017) for λ_thres and the boundary values
(D0, E0), (D1, E1); the λ_0 end of the tumbling family and the rolling-stability bound λ_roll are
derived in docs/theory/thresholds.md#thresholds.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple, overload

import numpy as np
from numpy.typing import ArrayLike

from . import _formulas as fm
from . import _validate
from .top import TippeTop

__all__ = [
    "BoundaryValues",
    "TumblingState",
    "boundary_values",
    "lambda_0",
    "lambda_E",
    "lambda_roll",
    "lambda_thres",
    "min_spin_for_inversion",
    "pole_spins",
    "tumbling_domain",
    "tumbling_lambda",
    "tumbling_state",
]


def lambda_thres(top: TippeTop) -> float:
    """λ_thres = √(m g R³ I3 α) (1 + α)² / √(1 + α − γ) (RR14 abstract; docs/theory/thresholds.md#thresholds).

    The inverted spin (θ = π) of the gliding top is asymptotically stable iff λ > λ_thres. For
    γ >= 1 + α (group III) it is never stable and ``inf`` is returned.
    """
    _validate.instance("top", top, TippeTop)
    return fm.lambda_thres(top)


def lambda_0(top: TippeTop) -> float:
    """λ_0 = √(m g R³ I3 α) (1 − α)² / √(α + γ − 1), the θ_t → 0 end of the tumbling family.

    The non-inverted spin (θ = 0) is unstable iff λ > λ_0. For γ <= 1 − α (group I) it is stable for
    every λ and ``inf`` is returned (docs/theory/thresholds.md#thresholds).
    """
    _validate.instance("top", top, TippeTop)
    return fm.lambda_0(top)


def lambda_E(top: TippeTop) -> float:
    """λ_E = √(m g R³ I3) (1 − α²): the inverted spin has less energy (E1 < E0) iff λ > λ_E (§6)."""
    _validate.instance("top", top, TippeTop)
    return math.sqrt(top.m * top.g * top.R**3 * top.I3) * (1.0 - top.alpha**2)


def lambda_roll(top: TippeTop) -> float:
    """Rolling (frictionless) stability bound of the inverted spin (docs/theory/thresholds.md#thresholds).

    λ_roll = 2√(m g R³ I3 α)(1 + α)√(γ + σ(1+α)²)/(1 + σ(1 + α)); λ_roll <= λ_thres always.
    """
    _validate.instance("top", top, TippeTop)
    a, gam, sig = top.alpha, top.gamma, top.sigma
    return (
        2.0
        * fm.jellett_scale(top)
        * (1.0 + a)
        * math.sqrt(gam + sig * (1 + a) ** 2)
        / (1.0 + sig * (1 + a))
    )


class BoundaryValues(NamedTuple):
    """Integrals of the two spinning solutions with Jellett integral λ (docs/theory/thresholds.md#boundary-values)."""

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


@overload
def pole_spins(top: TippeTop, lam: float) -> tuple[float, float]: ...
@overload
def pole_spins(top: TippeTop, lam: np.ndarray) -> tuple[np.ndarray, np.ndarray]: ...
def pole_spins(top: TippeTop, lam: float | np.ndarray) -> tuple[Any, Any]:
    """Spins ω3 (rad/s) of the steady spinning solutions at the poles with Jellett integral λ.

    ω3 = λ/(R I3 (1 − α)) upright (θ = 0) and ω3 = −λ/(R I3 (1 + α)) inverted (θ = π): Jellett's
    λ = R I1 φ̇ sin²θ − R I3 ω3 (α − cos θ) (docs/theory/model.md#conventions) at sin θ = 0. The one place of these
    formulas; plain arithmetic, so ``lam`` may be a float or an array (only ``top`` is checked).
    """
    _validate.instance("top", top, TippeTop)
    R, I3, a = top.R, top.I3, top.alpha
    return lam / (R * I3 * (1.0 - a)), -lam / (R * I3 * (1.0 + a))


def boundary_values(top: TippeTop, lam: ArrayLike) -> BoundaryValues:
    """Spinning solutions at θ = 0 and θ = π for the Jellett integral ``lam`` (RR14 §3; docs/theory/thresholds.md#boundary-values).

    ``D0 = λ√d(1)/(R(1 − α))``, ``E0 = λ²/(2 I3 R²(1 − α)²) + m g R(1 − α)``,
    ``D1 = −λ√d(−1)/(R(1 + α))``, ``E1 = λ²/(2 I3 R²(1 + α)²) + m g R(1 + α)``.
    """
    _validate.instance("top", top, TippeTop)
    from .potential import d

    lam = _validate.as_finite_array("lam", lam)
    R, a, I3 = top.R, top.alpha, top.I3
    mgR = top.m * top.g * R
    with np.errstate(over="ignore", invalid="ignore"):  # checked below
        D0 = lam * math.sqrt(float(d(top, 1.0))) / (R * (1.0 - a))
        D1 = -lam * math.sqrt(float(d(top, -1.0))) / (R * (1.0 + a))
        E0 = lam**2 / (2.0 * I3 * R**2 * (1.0 - a) ** 2) + mgR * (1.0 - a)
        E1 = lam**2 / (2.0 * I3 * R**2 * (1.0 + a) ** 2) + mgR * (1.0 + a)
        out = BoundaryValues(D0, E0, D1, E1, *pole_spins(top, lam))
    if not all(np.all(np.isfinite(v)) for v in out):
        # the largest |λ| for which E0 (∝ λ²) and D0, D1 (∝ λ) stay finite, in logarithms
        big = math.log(0.25 * float(np.finfo(float).max))
        log_lam = min(
            0.5 * (big + math.log(2.0 * I3) + 2.0 * math.log(R * (1.0 - a))),
            big + math.log(R * (1.0 - a)) - 0.5 * math.log(float(d(top, 1.0))),
            big + math.log(R * (1.0 + a)) - 0.5 * math.log(float(d(top, -1.0))),
            big,
        )
        lam_max = math.exp(log_lam)
        bad = lam[~np.isfinite(E0) | ~np.isfinite(D0) | ~np.isfinite(D1)].ravel()
        raise ValueError(
            f"|lam| must be at most {lam_max:.3g} kg m^3/s for this top (beyond it the spinning "
            f"states' energy overflows); got {(bad[0] if bad.size else lam.ravel()[0]).item()!r}"
        )
    return out


# --- the tumbling family ----------------------------------------------------------


class TumblingState(NamedTuple):
    """A tumbling solution of the gliding model: ν = 0, θ̇ = 0, θ = θ_t (docs/theory/thresholds.md#thresholds)."""

    theta: float
    """Tumbling angle θ_t (rad)."""
    phidot: float
    """Precession rate φ̇ (rad/s), φ̇² = m g R α/(I3(α − (1 − γ) cos θ_t))."""
    omega3: float
    """Spin ω3 = φ̇ (cos θ_t − α) (so ψ̇ = −α φ̇ and ω ∥ a)."""


def tumbling_lambda(top: TippeTop, theta: ArrayLike) -> np.ndarray:
    """λ along the tumbling family, λ(θ_t) = R φ̇ [I1 sin²θ_t + I3 (cos θ_t − α)²] (docs/theory/thresholds.md#thresholds).

    NaN where the family does not exist (α − (1 − γ) cos θ_t <= 0: beyond θ_f for groups I, III).
    """
    _validate.instance("top", top, TippeTop)
    th = _validate.theta(theta)
    c, s = np.cos(th), np.sin(th)
    den = top.alpha - (1.0 - top.gamma) * c
    with np.errstate(divide="ignore", invalid="ignore"):
        phidot = np.sqrt(top.m * top.g * top.R * top.alpha / (top.I3 * den))
    lam = top.R * phidot * (top.I1 * s * s + top.I3 * (c - top.alpha) ** 2)
    return np.where(den > 0.0, lam, np.nan)


def tumbling_domain(top: TippeTop) -> tuple[float, float]:
    """Interval (rad) of the tumbling angle θ_t on which the tumbling family exists.

    The family λ(θ_t) of :func:`tumbling_lambda` is real where α − (1 − γ) cos θ_t > 0
    (docs/theory/thresholds.md#thresholds): all of (0, π) if |α/(1 − γ)| ≥ 1, else
    (θ_f, π) for γ < 1 and (0, θ_f) for γ > 1, with θ_f = arccos(α/(1 − γ)).

    Parameters
    ----------
    top : TippeTop
        The body.

    Returns
    -------
    (lo, hi) : tuple of float
        Ends of the interval (rad); the family is a limit at both.
    """
    _validate.instance("top", top, TippeTop)
    a, gam = top.alpha, top.gamma
    if gam == 1.0 or abs(a / (1.0 - gam)) >= 1.0:
        return 0.0, math.pi
    theta_f = math.acos(a / (1.0 - gam))
    return (theta_f, math.pi) if gam < 1.0 else (0.0, theta_f)


def tumbling_state(top: TippeTop, lam: float) -> TumblingState | None:
    """The tumbling solution with Jellett integral ``lam`` (docs/theory/thresholds.md#thresholds), or ``None`` if none exists.

    Solves λ(θ_t) = lam on the family's domain. For an admissible top (1 − α < γ < 1 + α) the
    family joins λ_0 (θ_t → 0) to λ_thres (θ_t → π); for group III it runs from λ_0 to ∞ as θ_t
    approaches θ_f = arccos(α/(1 − γ)). Where several θ_t share the same λ (a folded family,
    classes Ib and IIb of :mod:`mett.classification`), the one closest to the upright end is
    returned, stable or not; :func:`mett.classification.tumbling_states` lists them all and
    :func:`mett.classification.tumbling_is_stable` tells which are stable.

    Raises
    ------
    ValueError
        If ``lam`` is not a positive finite number.
    """
    _validate.instance("top", top, TippeTop)
    from scipy import optimize

    lam = _validate.positive_jellett(lam)
    lo, hi = tumbling_domain(top)
    # Stay a hair inside the domain: λ is infinite at θ_f and the family's ends are limits.
    pad = 1e-12 * (hi - lo)
    grid = np.linspace(lo + pad, hi - pad, 2001)
    resid = tumbling_lambda(top, grid) - lam
    for i in range(len(grid) - 1):
        r0, r1 = resid[i], resid[i + 1]
        # a sign test, not r0 * r1 (which overflows for λ ~ 1e155)
        if np.isfinite(r0) and np.isfinite(r1) and min(r0, r1) <= 0.0 <= max(r0, r1):
            if r0 == 0.0:
                th = grid[i]
            else:
                th = optimize.brentq(
                    lambda t: float(tumbling_lambda(top, t)) - lam, grid[i], grid[i + 1], xtol=1e-15
                )
            phidot = math.sqrt(
                top.m
                * top.g
                * top.R
                * top.alpha
                / (top.I3 * (top.alpha - (1 - top.gamma) * math.cos(th)))
            )
            return TumblingState(float(th), phidot, phidot * (math.cos(th) - top.alpha))
    return None


def min_spin_for_inversion(top: TippeTop, theta0: float, phidot0: float = 0.0) -> float:
    """Smallest initial spin ω3 (rad/s) for complete inversion from θ0 with θ̇ = 0, precession φ̇0.

    Complete inversion needs λ > max(λ_0, λ_thres) (docs/theory/thresholds.md#thresholds); with λ = R I1 φ̇0 sin²θ0 +
    R I3 ω3 (cos θ0 − α) this is ω3 > (max(λ_0, λ_thres) − R I1 φ̇0 sin²θ0)/(R I3 (cos θ0 − α)),
    about 77.3 rad/s for the thesis body at θ0 = 0.1 (USW05's critical spin n_c, docs/theory/references.md#other-sources).
    Returns ``inf`` for tops that never invert (groups I and III).

    Raises
    ------
    ValueError
        If θ0 is outside [0, arccos α) (there the spin must point the other way, or λ does not
        depend on it), or on bad input.
    """
    _validate.instance("top", top, TippeTop)
    th = float(_validate.theta(theta0, "theta0"))
    phidot0 = _validate.finite_scalar("phidot0", phidot0)
    c = math.cos(th)
    if c <= top.alpha:
        raise ValueError(
            f"theta0 must lie in [0, arccos(alpha)) = [0, {math.acos(top.alpha):.6g}) for a positive "
            f"spin to give a positive Jellett integral; got {th!r}"
        )
    needed = max(top.lambda_0, top.lambda_thres)
    if math.isinf(needed):
        return math.inf
    return (needed - top.R * top.I1 * phidot0 * math.sin(th) ** 2) / (
        top.R * top.I3 * (c - top.alpha)
    )
