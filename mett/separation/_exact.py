"""The exact energy shift E' = Ẽ − D²/(2 I1) + m λ²/(2 I1 I3) (and A_p = E' − m g R(1 ∓ α)).

At high spin Ẽ and D²/(2 I1) are ~½ I3 ω3² while the well is ~ω3⁻² shallow: the shift is formed
from error-free products and sums (Dekker, Knuth) and rounded once, or in exact rationals for
inputs near the limits of the exponent range (docs/theory/mett.md, "Precision").
"""

from __future__ import annotations

from fractions import Fraction
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from ..top import TippeTop

_EPS = np.finfo(float).eps
# brentq iterations: a root within a few ulps of a pole, bracketed from the other end of [−1, 1],
# can need more than scipy's default 100 (Brent falls back to ~1 bisection per 2 iterations)
_MAXITER = 400


# --- the exact energy shift ------------------------------------------------------------------

_SPLITTER = 134217729.0  # 2**27 + 1: Veltkamp's splitting constant for doubles
_DISTIL_PASSES = 8
_SAFE_MAX, _SAFE_MIN = 1e150, 1e-250  # outside these, fall back to exact rationals


def _two_sum(a, b):
    """s + e = a + b exactly, s = fl(a + b) (Knuth)."""
    s = a + b
    bb = s - a
    return s, (a - (s - bb)) + (b - bb)


def _two_prod(a, b):
    """p + e = a b exactly, p = fl(a b) (Dekker, with Veltkamp's splitting)."""
    p = a * b
    c = _SPLITTER * a
    ah = c - (c - a)
    al = a - ah
    c = _SPLITTER * b
    bh = c - (c - b)
    bl = b - bh
    return p, ((ah * bh - p) + ah * bl + al * bh) + al * bl


def _distil(terms: list) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(hi, lo, ok): hi + lo equals the exact sum of ``terms`` to ~ε² of itself where ok.

    Repeated error-free cascades (TwoSum from the first term to the last) move the sum into the
    last term and leave rounding errors, which shrink by a factor ~ε per pass, in the others.
    """
    t = list(terms)
    for _ in range(_DISTIL_PASSES):
        for i in range(1, len(t)):
            t[i], t[i - 1] = _two_sum(t[i], t[i - 1])
        rest = sum(np.abs(x) for x in t[:-1])
        ok = rest <= _EPS * np.abs(t[-1])
        if np.all(ok):
            break
    return t[-1], sum(t[:-1]), ok


def _shift_fraction(top: TippeTop, E: float, D: float, lam: float, pole: float | None) -> float:
    """The exact shift in rational arithmetic, correctly rounded (slow; for extreme inputs)."""
    F = Fraction
    I1, I3, m = F(top.I1), F(top.I3), F(top.m)
    val = F(E) - F(D) ** 2 / (2 * I1) + m * F(lam) ** 2 / (2 * I1 * I3)
    if pole is not None:
        val -= m * F(top.g) * F(top.R) * (1 - F(top.alpha) * F(pole))
    return float(val)


def _pole_constant(top: TippeTop, pole: float) -> tuple[float, float, float]:
    """2 I1 I3 · m g R (1 ∓ α) as a sum of three doubles (exact to ~ε³)."""
    F = Fraction
    k = 2 * F(top.I1) * F(top.I3) * F(top.m) * F(top.g) * F(top.R) * (1 - F(top.alpha) * F(pole))
    k1 = float(k)
    k2 = float(k - F(k1))
    return k1, k2, float(k - F(k1) - F(k2))


def _shift(top: TippeTop, E, D, lam, pole=None) -> np.ndarray:
    """E' = Ẽ − D²/(2 I1) + m λ²/(2 I1 I3) for arrays, within one ulp (almost always correctly rounded).

    With ``pole`` (an array of ±1): the pole reference's A = E' − m g R (1 ∓ α), likewise exact.

    Multiplied through by 2 I1 I3 the numerator 2 I1 I3 Ẽ − I3 D² + m λ² is a sum of products of
    doubles; each product is split exactly into two doubles (:func:`_two_prod`), the sum is distilled
    into a double-double (:func:`_distil`), and the quotient by 2 I1 I3 (itself an exact
    double-double) is formed with a correction from the exact remainder. The large terms of size
    ½ I3 ω3² thus cancel without any rounding. Inputs near the limits of the exponent range (or an
    unconverged distillation) go through :func:`_shift_fraction` instead.
    """
    E, D, lam = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (E, D, lam)))
    shape = E.shape
    E, D, lam = E.ravel(), D.ravel(), lam.ravel()
    dh, dl = _two_prod(top.I1, top.I3)
    dh, dl = 2.0 * dh, 2.0 * dl  # 2 I1 I3 = dh + dl exactly
    terms = [*_two_prod(E, dh), *_two_prod(E, dl)]
    d1, d2 = _two_prod(D, D)
    for part in (d1, d2):
        p, e = _two_prod(top.I3, part)
        terms += [-p, -e]
    l1, l2 = _two_prod(lam, lam)
    for part in (l1, l2):
        terms += [*_two_prod(top.m, part)]
    poles = None
    if pole is not None:
        poles = np.broadcast_to(np.asarray(pole, dtype=float), shape).ravel()
        ks = {p: _pole_constant(top, p) for p in (-1.0, 1.0)}
        for j in range(3):
            terms.append(-np.where(poles > 0.0, ks[1.0][j], ks[-1.0][j]))
    hi, lo, ok = _distil(terms)
    with np.errstate(all="ignore"):
        q0 = hi / dh
        ph, pl = _two_prod(q0, dh)
        qh, ql = _two_prod(q0, dl)
        r = ((((hi - ph) - pl) + lo) - qh) - ql
        out = q0 + r / dh
    big = np.maximum(np.maximum(np.abs(E), np.abs(D)), np.abs(lam))
    slow = ~ok | ~np.isfinite(out) | (big > _SAFE_MAX) | ((np.abs(hi) < _SAFE_MIN) & (big > 0.0))
    for i in np.flatnonzero(slow):
        pl_i = None if poles is None else float(poles[i])
        out[i] = _shift_fraction(top, float(E[i]), float(D[i]), float(lam[i]), pl_i)
    return out.reshape(shape)


def _shifted_energy(top: TippeTop, E: float, D: float, lam: float) -> float:
    """E' = E − D²/(2 I1) + m λ²/(2 I1 I3) for one element (see :func:`_shift`)."""
    return float(_shift(top, E, D, lam))
