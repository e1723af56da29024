"""The closed forms that several floors of mett share, unvalidated.

One place per formula (docs/theory/mett.md#the-main-equation, docs/theory/thresholds.md#thresholds):
the public functions of :mod:`mett.potential`, :mod:`mett.thresholds` and
:mod:`mett.classification` validate their arguments and call these; the separation layer calls them
in its inner loops on arguments it has already checked, and :class:`mett.TippeTop`'s derived
properties (``lambda_thres``, ``lambda_0``, ``subgroup``) call them on its own validated fields, so
the ground floor needs none of the analyses built on it. Plain arithmetic on floats or arrays.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from .top import TippeTop

# |N| below this fraction of its scale (|λ√d| + |R D (α − z)|) counts as zero at a pole: the
# rounding of its two terms (a state at θ = 0 or π leaves a few ulps), not more — a vanishing spin's
# N(±1) of 1e-12 of its terms is a real wall next to the pole.
POLE_RTOL = 64.0 * float(np.finfo(float).eps)

INTEGRAL_MAX = 1e30  # documented as mett.potential.INTEGRAL_MAX


def d_sphere(z, m: float, R: float, l: float, I1: float, I3: float):
    """d(z) of a sphere of radius R whose centre of mass sits l below its centre.

    I3² d = I1 I3 + m I3 (l − R z)² + m I1 R² (1 − z²) (Rutstam 2012 §3); see
    :func:`mett.potential.d_of`. Squares of z-dependent terms are products, not powers: Python's
    float power may round differently from numpy's square, and floats and arrays must agree.
    """
    t = l - R * z
    return (I1 * I3 + m * I3 * (t * t) + m * I1 * R * R * (1.0 - z * z)) / (I3 * I3)


def d(top: TippeTop, z):
    """d(z) = γ + σ(α − z)² + σγ(1 − z²) of ``top`` (z in [−1, 1], not checked)."""
    return d_sphere(z, top.m, top.R, top.R * top.alpha, top.I1, top.I3)


def dd_dz(top: TippeTop, z):
    """d'(z) = −2σ(α − z + γ z)."""
    return -2.0 * top.sigma * (top.alpha - z + top.gamma * z)


def g(top: TippeTop, z):
    """g(z) = ½ I3 [γ + σ(1 + α² − 2αz)], the coefficient of θ̇² in the METT."""
    return 0.5 * top.I3 * (top.gamma + top.sigma * (1.0 + top.alpha**2 - 2.0 * top.alpha * z))


def N_terms(top: TippeTop, sqd, z, D, lam):
    """(N, |λ√d| + |R D(α − z)|): N(z) = λ√d(z) + R D(α − z) from √d(z), and the size of its terms.

    The second value scales its rounding error (:data:`POLE_RTOL`).
    """
    a = lam * sqd
    b = top.R * D * (top.alpha - z)
    return a + b, np.abs(a) + np.abs(b)


def N(top: TippeTop, sqd, z, D, lam):
    """N(z) = λ√d(z) + R D(α − z) = R I1 φ̇ (1 − z²) √d(z), from √d(z)."""
    return lam * sqd + top.R * D * (top.alpha - z)


def kinetic_coefficient(top: TippeTop) -> float:
    """C = I3/(2 I1² R²): the kinetic part of V is C N²/(1 − z²)."""
    return top.I3 / (2.0 * top.I1**2 * top.R**2)


def check_integrals(top: TippeTop, **values: np.ndarray) -> None:
    """ValueError naming the first of ``E``, ``D``, ``lam`` beyond :data:`INTEGRAL_MAX` (arrays).

    Called by every public function of the potential, the separation equation and the estimates
    after their inputs are validated as finite arrays, so no overflow reaches their arithmetic.
    """
    rate = np.sqrt(top.g / top.R)  # FIELD_RANGE keeps it finite and nonzero
    scales = {
        "E": (INTEGRAL_MAX**2 * max(top.m * top.g * top.R, top.I3 * top.g / top.R), "J"),
        "D": (INTEGRAL_MAX * top.I3 * rate, "kg m^2/s"),
        "lam": (INTEGRAL_MAX * top.R * top.I3 * rate, "kg m^3/s"),
    }
    for name, value in values.items():
        bound, unit = scales[name]
        big = np.abs(value) > bound
        if np.any(big):
            raise ValueError(
                f"{name} must lie in [-{bound:.3g}, {bound:.3g}] {unit} for this top (the "
                f"integrals of a spin up to {INTEGRAL_MAX:g} sqrt(g/R)); "
                f"got {np.asarray(value)[big].ravel()[0].item()!r}"
            )


# --- thresholds and classes (docs/theory/thresholds.md#thresholds) ---------------------------------


def jellett_scale(top: TippeTop) -> float:
    """√(m g R³ I3 α) (kg m³/s), the unit of the thresholds λ_thres, λ_0, λ_roll."""
    return math.sqrt(top.m * top.g * top.R**3 * top.I3 * top.alpha)


def lambda_thres(top: TippeTop) -> float:
    """λ_thres = √(m g R³ I3 α) (1 + α)²/√(1 + α − γ); ``inf`` for γ >= 1 + α (Rauch-Wojciechowski
    & Rutstam 2014, abstract)."""
    den = 1.0 + top.alpha - top.gamma
    if den <= 0.0:
        return math.inf
    return jellett_scale(top) * (1.0 + top.alpha) ** 2 / math.sqrt(den)


def lambda_0(top: TippeTop) -> float:
    """λ_0 = √(m g R³ I3 α) (1 − α)²/√(α + γ − 1); ``inf`` for γ <= 1 − α."""
    den = top.alpha + top.gamma - 1.0
    if den <= 0.0:
        return math.inf
    return jellett_scale(top) * (1.0 - top.alpha) ** 2 / math.sqrt(den)


def fold_indicator(alpha, gamma, z):
    """S(z) = u [γ (1 − z²) + (z − α)²] − 4 (α − u z)², u = 1 − γ: sign(S) = −sign(dλ/dθ_t) on the
    tumbling family (:mod:`mett.classification`)."""
    u = 1.0 - np.asarray(gamma, dtype=float)
    a = np.asarray(alpha, dtype=float)
    z = np.asarray(z, dtype=float)
    q = (1.0 - u) * (1.0 - z * z) + (z - a) ** 2
    return u * q - 4.0 * (a - u * z) ** 2


def classes(a: np.ndarray, g: np.ndarray) -> np.ndarray:
    """Class ("Ia" … "III", a str array) of tops with eccentricity ``a`` and γ = ``g``, float arrays
    of one shape (the table of :mod:`mett.classification`)."""
    s_up, s_inv = fold_indicator(a, g, 1.0), fold_indicator(a, g, -1.0)
    out = np.where(
        g <= 1.0 - a,
        np.where(s_inv >= 0.0, "Ia", "Ib"),
        np.where(
            g >= 1.0 + a,
            "III",
            np.where(s_up <= 0.0, "IIa", np.where(s_inv >= 0.0, "IIc", "IIb")),
        ),
    )
    return out.astype("<U3")


def subgroup(top: TippeTop) -> str:
    """Class of ``top`` (:func:`classes` at its α and γ)."""
    a, g = np.broadcast_arrays(
        np.asarray(top.alpha, dtype=float), np.asarray(top.gamma, dtype=float)
    )
    return str(classes(a, g))
