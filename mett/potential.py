"""The effective potential of the Main Equation for the Tippe Top (METT), z = cos θ.

METT (Rutstam 2012 §3; Rauch-Wojciechowski & Rutstam 2014 §2; docs/theory/mett.md#the-main-equation):

    Ẽ = g(z) θ̇² + V(z, D, λ),

    d(z) = γ + σ(α − z)² + σγ(1 − z²),
    g(z) = ½ I3 [γ + σ(1 + α² − 2αz)] = ½ (I1 + m|a|²),
    V(z, D, λ) = m g R(1 − αz) + I3 N(z)² / (2 I1² R² (1 − z²)) + D²/(2 I1) − m λ²/(2 I1 I3),
    N(z) = λ √d(z) + R D (α − z)   (= R I1 φ̇ (1 − z²) √d(z)).

Under the rational condition σ = (1 − γ)/(γ + α² − 1) (docs/theory/mett.md#rational), √d(z) = β(α − (1 − γ)z) and
N(z) = c1 − c2 z with c1 = α(λβ + RD), c2 = λβ(1 − γ) + RD.

At the poles z = ±1 the kinetic term is N²/(1 − z²): V is +inf there unless N(±1) = 0 (the spinning
solutions D = D0, D1 of docs/theory/thresholds.md#boundary-values), in which case V takes its finite limit. All functions broadcast
over z, D and λ.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from . import _formulas as fm
from . import _validate
from .top import TippeTop

__all__ = [
    "INTEGRAL_MAX",
    "N",
    "V",
    "V_rational",
    "d",
    "d2V_dz2",
    "dN_dz",
    "dV_dz",
    "d_of",
    "dd_dz",
    "g",
]


def d(top: TippeTop, z: ArrayLike) -> np.ndarray:
    """d(z) = γ + σ(α − z)² + σγ(1 − z²) (docs/theory/model.md#conventions); D = I3 ω3 √d(z)."""
    _validate.instance("top", top, TippeTop)
    z = _validate.cos_theta(z)
    return fm.d(top, z)


def d_of(z: ArrayLike, m: float, R: float, l: float, I1: float, I3: float) -> np.ndarray:
    """d(z) of a sphere of radius R whose centre of mass sits l below its centre (no checks).

    I3² d = I1 I3 + m I3 (l − R z)² + m I1 R² (1 − z²) (Rutstam 2012 §3): with l = Rα this is
    γ + σ(α − z)² + σγ(1 − z²); with R = 0 (the heavy symmetric top on its tip) γ + m l²/I3. The one
    implementation of d (in ``mett._formulas``): :func:`d`, the separation layer and the dynamics
    (Routh's integral D = I3 ω3 √d(z)) use it. Plain arithmetic on floats or arrays.
    """
    return fm.d_sphere(z, m, R, l, I1, I3)


def dd_dz(top: TippeTop, z: ArrayLike) -> np.ndarray:
    """d'(z) = −2σ(α − z + γ z)."""
    _validate.instance("top", top, TippeTop)
    z = _validate.cos_theta(z)
    return fm.dd_dz(top, z)


def g(top: TippeTop, z: ArrayLike) -> np.ndarray:
    """g(z) = ½ I3 [γ + σ(1 + α² − 2αz)], the coefficient of θ̇² in the METT (docs/theory/mett.md#the-main-equation)."""
    _validate.instance("top", top, TippeTop)
    z = _validate.cos_theta(z)
    return fm.g(top, z)


INTEGRAL_MAX = fm.INTEGRAL_MAX
"""Largest |D|, |λ| the potential and the separation equation accept, in units of the top's
natural scales I3 √(g/R) (D) and R I3 √(g/R) (λ), and |Ẽ| in units of INTEGRAL_MAX² times
max(m g R, I3 g/R): a spin of 1e30 √(g/R), many decades above any real top, and far enough below
the float range that the squares in V (D², λ², N²) cannot overflow."""


def _inputs(top: TippeTop, z: ArrayLike, D: ArrayLike, lam: ArrayLike) -> tuple[np.ndarray, ...]:
    _validate.instance("top", top, TippeTop)
    z = _validate.cos_theta(z)
    D = _validate.as_finite_array("D", D)
    lam = _validate.as_finite_array("lam", lam)
    fm.check_integrals(top, D=D, lam=lam)
    return z, D, lam


def N(top: TippeTop, z: ArrayLike, D: ArrayLike, lam: ArrayLike) -> np.ndarray:
    """N(z) = λ√d(z) + R D(α − z) = R I1 φ̇ (1 − z²) √d(z) (docs/theory/mett.md#the-main-equation)."""
    z, D, lam = _inputs(top, z, D, lam)
    return fm.N(top, np.sqrt(d(top, z)), z, D, lam)


def dN_dz(top: TippeTop, z: ArrayLike, D: ArrayLike, lam: ArrayLike) -> np.ndarray:
    """N'(z) = λ d'(z)/(2√d(z)) − R D."""
    z, D, lam = _inputs(top, z, D, lam)
    return lam * dd_dz(top, z) / (2.0 * np.sqrt(d(top, z))) - top.R * D


def _constant(top: TippeTop, D: np.ndarray, lam: np.ndarray) -> np.ndarray:
    """D²/(2 I1) − m λ²/(2 I1 I3)."""
    return D**2 / (2.0 * top.I1) - top.m * lam**2 / (2.0 * top.I1 * top.I3)


def _pole_safe_ratio(
    num: np.ndarray, w: np.ndarray, n: np.ndarray, scale: np.ndarray
) -> np.ndarray:
    """num / w where w = 1 − z²; at a pole (w = 0) the limit is 0 if N vanishes there, else +inf."""
    num, w, n, scale = np.broadcast_arrays(num, w, n, scale)
    out = np.empty(num.shape)
    pole = w == 0.0
    np.divide(num, w, out=out, where=~pole)
    vanish = np.abs(n) <= fm.POLE_RTOL * scale
    out[pole & vanish] = 0.0
    out[pole & ~vanish] = np.inf
    return out


def V(top: TippeTop, z: ArrayLike, D: ArrayLike, lam: ArrayLike) -> np.ndarray:
    """Effective potential V(z, D, λ) of the METT, algebraic form (docs/theory/mett.md#the-main-equation; RR14 §2).

    Parameters
    ----------
    top : TippeTop
    z : array_like
        cos θ in [−1, 1].
    D, lam : array_like
        Routh integral D (kg m²/s) and Jellett integral λ (kg m³/s), broadcast against z.

    Returns
    -------
    ndarray
        V in joules. At z = ±1 it is +inf unless N(±1) = 0, where it is the finite limit.

    Raises
    ------
    ValueError
        If |z| > 1 or an input is not finite.
    """
    z, D, lam = _inputs(top, z, D, lam)
    n, scale = fm.N_terms(top, np.sqrt(d(top, z)), z, D, lam)
    kinetic = fm.kinetic_coefficient(top) * _pole_safe_ratio(n * n, 1.0 - z * z, n, scale)
    gravity = top.m * top.g * top.R * (1.0 - top.alpha * z)
    return gravity + kinetic + _constant(top, D, lam)


def V_rational(top: TippeTop, z: ArrayLike, D: ArrayLike, lam: ArrayLike) -> np.ndarray:
    """Rational form of V for a top with σ = (1 − γ)/(γ + α² − 1) (docs/theory/mett.md#rational; R13, RR14).

    V = m g R(1 − αz) + (c1 − c2 z)²/(2 I3 γ² R² (1 − z²)) + D²/(2 I3 γ) − m λ²/(2 I3² γ),
    c1 = α(λβ + R D), c2 = λβ(1 − γ) + R D, β = √(σ/(1 − γ)).

    Raises
    ------
    ValueError
        If the top is not rational (see :attr:`TippeTop.is_rational`), or on bad input.
    """
    z, D, lam = _inputs(top, z, D, lam)
    beta = top.beta  # raises ValueError for a non-rational top
    gam, R, I3 = top.gamma, top.R, top.I3
    c1 = top.alpha * (lam * beta + R * D)
    c2 = lam * beta * (1.0 - gam) + R * D
    n = c1 - c2 * z
    scale = np.abs(c1) + np.abs(c2 * z)
    kinetic = _pole_safe_ratio(n * n, 1.0 - z * z, n, scale) / (2.0 * I3 * gam**2 * R**2)
    gravity = top.m * top.g * R * (1.0 - top.alpha * z)
    return gravity + kinetic + D**2 / (2.0 * I3 * gam) - top.m * lam**2 / (2.0 * I3**2 * gam)


def dV_dz(top: TippeTop, z: ArrayLike, D: ArrayLike, lam: ArrayLike) -> np.ndarray:
    """∂V/∂z (analytic).

    ∂V/∂z = −m g R α + 2C N [N'(1 − z²) + z N]/(1 − z²)², C = I3/(2 I1² R²).
    Infinite at a pole unless N vanishes there.
    """
    z, D, lam = _inputs(top, z, D, lam)
    sqd = np.sqrt(d(top, z))
    n, scale = fm.N_terms(top, sqd, z, D, lam)
    dn = lam * dd_dz(top, z) / (2.0 * sqd) - top.R * D
    w = 1.0 - z * z
    n, dn, z, w, scale = np.broadcast_arrays(n, dn, z, w, scale)
    ratio = np.empty(n.shape)
    inner = w != 0.0
    ratio[inner] = 2.0 * n[inner] * (dn[inner] * w[inner] + z[inner] * n[inner]) / w[inner] ** 2
    pole = ~inner
    ratio[pole] = _pole_derivative(n[pole], dn[pole], z[pole], scale[pole])
    return -top.m * top.g * top.R * top.alpha + fm.kinetic_coefficient(top) * ratio


def _pole_derivative(n, dn, z, scale):
    # At z = ±1 only. With N(±1) = 0, N²/(1 − z²) ≈ N'² (1 ∓ z)/(1 ± z) near the pole: its
    # z-derivative tends to ∓N'(±1)²/2. Otherwise it diverges (the wall rises towards the pole).
    vanish = np.abs(n) <= fm.POLE_RTOL * scale
    out = np.copysign(np.inf, z)
    out[vanish] = -np.sign(z[vanish]) * dn[vanish] ** 2 / 2.0
    return out


def d2V_dz2(top: TippeTop, z: ArrayLike, D: ArrayLike, lam: ArrayLike) -> np.ndarray:
    """∂²V/∂z² (analytic), for z in the open interval (−1, 1).

    With w = 1 − z² and K = C N²/w:  K'' = C[2(N'² + N N'')/w + 8 z N N'/w² + 2N²/w² + 8 z² N²/w³],
    N'' = λ(d''/(2√d) − d'²/(4 d^{3/2})), d'' = 2σ(1 − γ).
    """
    z, D, lam = _inputs(top, z, D, lam)
    if np.any(np.abs(z) == 1.0):
        raise ValueError("d2V_dz2 needs z in the open interval (-1, 1); got a pole")
    dz = d(top, z)
    sqd = np.sqrt(dz)
    dd = dd_dz(top, z)
    d2d = 2.0 * top.sigma * (1.0 - top.gamma)
    n = fm.N(top, sqd, z, D, lam)
    dn = lam * dd / (2.0 * sqd) - top.R * D
    d2n = lam * (d2d / (2.0 * sqd) - dd * dd / (4.0 * dz * sqd))
    w = 1.0 - z * z
    k2 = 2.0 * (dn * dn + n * d2n) / w + (8.0 * z * n * dn + 2.0 * n * n) / w**2
    k2 = k2 + 8.0 * z * z * n * n / w**3
    return fm.kinetic_coefficient(top) * k2
