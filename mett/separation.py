"""The separation equation of the METT: ż² = f(z), turning points, exact nutation periods.

With z = cos θ and ż = −sin θ θ̇, the METT Ẽ = g(z) θ̇² + V(z, D, λ) becomes (theory.md §4)

    ż² = f(z) = (1 − z²)(Ẽ − V(z, D, λ)) / g(z) = P(z) / g(z),
    P(z) = (1 − z²)(E' − m g R(1 − αz)) − C N(z)²,   C = I3/(2 I1² R²),
    E' = Ẽ − D²/(2 I1) + m λ²/(2 I1 I3).

P is regular on [−1, 1] (no pole), so all work is done with P. For a rolling top (Ẽ = E, D and λ
constant) z oscillates between the two roots z_a < z_b of P that bracket the well of V, with period

    T = 2 ∫_{z_a}^{z_b} √g(z) / √P(z) dz
      = 2 ∫_{−π/2}^{π/2} h cos u √(g(z)/P(z)) du,   z = c + h sin u,

where c, h are the centre and half-width of the band; the substitution removes the inverse square
root singularities at the turning points, and Gauss–Legendre quadrature in u converges exponentially.

Precision. At high spin the band is narrow (width ~ ω3⁻²) and Ẽ − V is a tiny difference of numbers
of size ½ I3 ω3²: in double precision it keeps few digits. The constant D²/(2 I1) − mλ²/(2 I1 I3) that
carries that size is therefore subtracted from Ẽ exactly (error-free products and sums in double,
:func:`_shift`) before anything else is done; what remains, E' − m g R(1 − αz) and C N², are of the size of the well itself. Inside a band
P is then written about the bottom z_r of the well (``_Well.set_reference``, also at a spinning
pole), and the turning points and quadrature nodes are handled as offsets δ = z − z_r: the node next
to a turning point lies only ~1e-7 band widths from it, closer than one ulp of z at high spin.

Vectorisation. The public functions work on whole arrays of (Ẽ, D, λ) at once (:class:`_Wells`):
the wells are located on one grid for all elements, and every root (minimum of V, turning point,
offset turning point) is refined by :func:`_brentq`, a vectorised transcription of scipy's
``brentq``. The array helpers repeat the scalar helpers of :class:`_Well` operation for operation,
so an element gets bit for bit the numbers the scalar reference path (:func:`_band_scalar` and the
``_reference_*`` functions) gives it; only the final quadrature sum may differ in the last bit. Rare
elements the array path does not handle (V with several wells, a failed bracket) are passed to the
scalar reference path.
"""

from __future__ import annotations

import math
from fractions import Fraction
from typing import TYPE_CHECKING, NamedTuple

import numpy as np
from numpy.typing import ArrayLike
from scipy import optimize

from . import _validate
from .potential import _N, _POLE_RTOL, _kinetic_coefficient, d, d2V_dz2, dd_dz, dV_dz, g

if TYPE_CHECKING:
    from .top import TippeTop

__all__ = [
    "Band",
    "band",
    "classify_motion",
    "f",
    "mean_precession",
    "nutation_period",
    "turning_points",
]

_EPS = np.finfo(float).eps
_N_GRID = 401  # samples of the critical-point numerator when locating the wells of V
_N_QUAD = 96  # Gauss–Legendre nodes in u for periods and means
_U_NODES, _U_WEIGHTS = np.polynomial.legendre.leggauss(_N_QUAD)
_U_NODES = 0.5 * np.pi * _U_NODES
_U_WEIGHTS = 0.5 * np.pi * _U_WEIGHTS
_Z_GRID = np.cos(np.linspace(np.pi, 0.0, _N_GRID))  # denser near the poles
_Z_GRID[0], _Z_GRID[-1] = -1.0, 1.0
_OFFSET_STEP = 4.0 * float(np.spacing(1.0))  # first half-width of an offset turning point's bracket
_OFFSET_TRIES = 40  # ... widened 4× per try


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


class _Well:
    """P(z) and friends for one (E, D, λ), all in double after the exact energy shift.

    Once a band is known, :meth:`set_reference` switches P to the form P(z) = w(z)(depth − ΔV(z))
    around the bottom z_r of the well, where depth = Ẽ − V(z_r) is computed once and
    ΔV(z) = V(z) − V(z_r) is assembled from exact differences (U is linear, d quadratic): near the
    bottom of the well, where Ẽ − V is tiny, no large terms cancel any more.
    """

    def __init__(self, top: TippeTop, E: float, D: float, lam: float) -> None:
        self.top, self.E, self.D, self.lam = top, E, D, lam
        self.Es = _shifted_energy(top, E, D, lam)
        self.C = _kinetic_coefficient(top)
        self.mgR = top.m * top.g * top.R
        self.zr: float | None = None

    def N(self, z):
        return _N(self.top, np.sqrt(d(self.top, z)), z, self.D, self.lam)

    def gravity(self, z):
        return self.mgR * (1.0 - self.top.alpha * z)

    def P_direct(self, z):
        n = self.N(z)
        return (1.0 - z * z) * (self.Es - self.gravity(z)) - self.C * n * n

    def set_reference(self, zr: float) -> None:
        """Expand P about an interior point z_r (the bottom of the band's well).

        A pole z_r = ±1 where N vanishes (a well at a spinning pole, D = D0 or D1) is allowed too:
        there P(z_r + δ) = w(δ)(A + m g R α δ) − C ΔN(δ)² with A = Ẽ − V(z_r) = E' − m g R(1 ∓ α)
        computed exactly (:func:`_shift`), so a narrow band next to the pole keeps its digits.
        """
        self.pole_ref = abs(zr) == 1.0
        if abs(zr) >= 1.0 and not (self.pole_ref and self.n_vanishes(zr)):
            self.zr = None
            return
        self.zr = zr
        if self.pole_ref:
            top = self.top
            self.sqd_r = float(np.sqrt(d(top, zr)))
            self.dd_r = float(dd_dz(top, zr))
            self.A_r = float(_shift(top, self.E, self.D, self.lam, zr))
            return
        self.w_r = 1.0 - zr * zr
        if self.w_r <= 64.0 * _EPS:
            # A well within a few ulps of a pole (a vanishing spin's wall): an expansion about it
            # is meaningless, and P needs none (nothing large cancels when N is that small).
            self.zr = None
            return
        self.sqd_r = float(np.sqrt(d(self.top, zr)))
        self.dd_r = float(dd_dz(self.top, zr))
        self.N_r = float(self.N(zr))
        self.depth_r = self.Es - float(self.gravity(zr)) - self.C * self.N_r**2 / self.w_r

    def delta_V(self, z):
        """V(z) − V(z_r) without cancellation of the large terms (needs set_reference)."""
        return self.delta_V_offset(z - self.zr)

    def delta_V_offset(self, delta):
        """V(z_r + δ) − V(z_r), with the offset δ itself as the argument.

        In a narrow band δ is known far better than z_r + δ rounded to a double (whose ulp can be
        a sizeable fraction of the distance from a quadrature node to a turning point).
        """
        top = self.top
        dn = self.delta_N(delta)
        n = self.N_r + dn
        w = self.w_r - (2.0 * self.zr + delta) * delta
        # N²/w − N_r²/w_r = [ΔN (N + N_r) w_r + N_r² (w_r − w)] / (w w_r), w_r − w = 2 z_r δ + δ².
        kin = (dn * (n + self.N_r) * self.w_r + self.N_r**2 * (2.0 * self.zr + delta) * delta) / (
            w * self.w_r
        )
        return -self.mgR * top.alpha * delta + self.C * kin

    def delta_V_divided(self, a, x):
        """Divided difference ΔV[a, x] = (V(z_r + x) − V(z_r + a))/(x − a), for offsets a, x.

        Written without any division by x − a: d is quadratic and w = 1 − z², U linear, so
        d[a, x] = −2σα + σ(1 − γ)(z_a + z_x) and w_a − w_x = (x − a)(z_a + z_x) exactly, and
        K[a, x] for K = N²/w follows from N_x² w_a − N_a² w_x = (x − a)[N[a,x](N_x + N_a) w_a
        + N_a² (z_a + z_x)]. Hence accurate even for a = x (it is then V'). Interior reference only.
        """
        top = self.top
        zsum = 2.0 * self.zr + a + x
        d_div = -2.0 * top.sigma * top.alpha + top.sigma * (1.0 - top.gamma) * zsum
        za, zx = np.clip(self.zr + a, -1.0, 1.0), np.clip(self.zr + x, -1.0, 1.0)
        n_div = self.lam * d_div / (np.sqrt(d(top, za)) + np.sqrt(d(top, zx))) - top.R * self.D
        n_a, n_x = self.N_r + self.delta_N(a), self.N_r + self.delta_N(x)
        w_a = self.w_r - (2.0 * self.zr + a) * a
        w_x = self.w_r - (2.0 * self.zr + x) * x
        k_div = (n_div * (n_x + n_a) * w_a + n_a * n_a * zsum) / (w_a * w_x)
        return -self.mgR * top.alpha + self.C * k_div

    def P(self, z):
        if self.zr is None:
            return self.P_direct(z)
        if self.pole_ref:
            # 1 − z² from z itself: P_offset's −(2 z_r + δ)δ is only accurate near z_r.
            z = np.asarray(z, dtype=float)
            delta = z - self.zr
            dn = self.delta_N(delta)
            A = self.A_r + self.mgR * self.top.alpha * delta
            return (1.0 - z) * (1.0 + z) * A - self.C * dn * dn
        z = np.asarray(z, dtype=float)
        pole = np.abs(z) == 1.0
        with np.errstate(divide="ignore", invalid="ignore"):
            out = (1.0 - z * z) * (self.depth_r - self.delta_V(z))
        if np.any(pole):
            out = np.where(pole, self.P_direct(z), out)
        return out if out.ndim else float(out)

    def delta_N(self, delta):
        """N(z_r + δ) − N(z_r) without cancellation (needs set_reference)."""
        top = self.top
        z = np.clip(self.zr + delta, -1.0, 1.0)
        # d is quadratic: d(z) − d(z_r) = d'(z_r) δ + σ(1 − γ) δ² exactly.
        dd = self.dd_r * delta + top.sigma * (1.0 - top.gamma) * delta * delta
        return self.lam * dd / (np.sqrt(d(top, z)) + self.sqd_r) - top.R * self.D * delta

    def P_offset(self, delta):
        """P(z_r + δ) in terms of the offset δ (needs set_reference)."""
        if self.pole_ref:
            w = -(2.0 * self.zr + delta) * delta
            dn = self.delta_N(delta)
            return w * (self.A_r + self.mgR * self.top.alpha * delta) - self.C * dn * dn
        w = self.w_r - (2.0 * self.zr + delta) * delta
        return w * (self.depth_r - self.delta_V_offset(delta))

    def scale(self, z):
        """Size of the terms of P at z, for rounding-error tolerances."""
        n = self.N(z)
        return (1.0 - z * z) * (abs(self.Es) + self.gravity(z)) + self.C * n * n

    def critical(self, z):
        """(1 − z²)² ∂V/∂z: regular on [−1, 1]; its sign changes − → + are the minima of V."""
        top = self.top
        sqd = np.sqrt(d(top, z))
        n = _N(top, sqd, z, self.D, self.lam)
        dn = self.lam * dd_dz(top, z) / (2.0 * sqd) - top.R * self.D
        w = 1.0 - z * z
        return -self.mgR * top.alpha * w * w + 2.0 * self.C * n * (dn * w + z * n)

    def n_vanishes(self, z: float) -> bool:
        """Whether N(z) is zero to rounding (at a pole: the spinning solutions D = D0, D1)."""
        top = self.top
        scale = abs(self.lam) * float(np.sqrt(d(top, z))) + abs(top.R * self.D * (top.alpha - z))
        return abs(float(self.N(z))) <= _POLE_RTOL * scale

    def excess(self, z):
        """Ẽ − V(z) (finite limit at a pole where N vanishes)."""
        w = 1.0 - z * z
        if w == 0.0:
            return self.Es - self.gravity(z) if self.n_vanishes(z) else -np.inf
        n = self.N(z)
        return self.Es - self.gravity(z) - self.C * n * n / w


class Band(NamedTuple):
    """The θ-motion of a rolling top with integrals (Ẽ, D, λ), in z = cos θ."""

    kind: str
    """"nutation" (z oscillates in [z_low, z_high]), "steady" (Ẽ at the bottom of the well: steady
    precession, z_low = z_high = z_min) or "none" (Ẽ below the well: no motion has these integrals)."""
    z_low: float
    z_high: float
    z_min: float
    """Position of the minimum of V in the band."""
    depth: float
    """Ẽ − V(z_min) (J); negative for kind "none"."""


def _wells(w: _Well) -> list[float]:
    """Positions of the local minima of V on [−1, 1]."""
    zs = _Z_GRID
    cr = w.critical(zs)
    mins = []
    for i in range(len(zs) - 1):
        if cr[i] < 0.0 <= cr[i + 1] or (cr[i] < 0.0 and cr[i + 1] > 0.0):
            if cr[i + 1] == 0.0:
                mins.append(float(zs[i + 1]))
            else:
                mins.append(
                    optimize.brentq(w.critical, zs[i], zs[i + 1], xtol=1e-300, rtol=4 * _EPS)
                )
    # A pole where N vanishes and V decreases towards it is a minimum too (a stable spin).
    if cr[-1] <= 0.0 and cr[-2] < 0.0:
        mins.append(1.0)
    if cr[0] >= 0.0 and cr[1] > 0.0 and not mins[:1] == [-1.0]:
        mins.insert(0, -1.0)
    # A root found at a pole where N does not vanish is really a hair inside (V = +inf at the pole).
    mins = [z if abs(z) < 1.0 or w.n_vanishes(z) else float(np.nextafter(z, 0.0)) for z in mins]
    return sorted({_snap_to_pole(w, z) for z in mins})


def _turning_point(w: _Well, pole: float, zm: float) -> float:
    """The root of P between the bottom z_m of the well (P > 0) and the pole ``pole`` (±1).

    P(±1) = −C N(±1)² < 0 unless N vanishes at the pole. Then P(pole) = 0 through its factor
    1 − z², and the pole is a turning point only if Ẽ ≥ V(pole) (the axis passes through the
    vertical); otherwise the root lies inside and is bracketed from the first float off the pole.
    """
    if abs(zm) == 1.0:  # a well at the other pole: P vanishes there too, step inside
        zm = float(np.nextafter(zm, pole))
    p_pole = w.P(pole)
    if p_pole >= 0.0:
        if w.excess(pole) >= 0.0:
            return pole
        pole = float(np.nextafter(pole, zm))
        if pole == zm or w.P(pole) >= 0.0:
            return pole  # the wall (N ≈ 0, a vanishing spin) is within one ulp of the pole
    lo, hi = (pole, zm) if pole < zm else (zm, pole)
    root = optimize.brentq(w.P, lo, hi, xtol=1e-300, rtol=4 * _EPS)
    return _polish_near_pole(w, root, pole, zm)


def _polish_near_pole(w, root: float, pole: float, zm: float) -> float:
    """Re-solve a turning point that lies next to a pole with the direct P.

    The expansion about the bottom of the well is accurate to ~ε·max P in absolute terms, while
    next to a pole both terms of P = (1 − z²)(E' − U) − C N² are tiny, so that is not enough there
    (e.g. an unstable inverted start θ0 = π − 1e-4 has its turning point 5e-9 from the pole). The
    direct form is accurate to ~ε of its small terms there. Used for a root in the quarter of
    [pole, z_m] next to the pole, when the direct form brackets it.
    """
    if w.zr is None or getattr(w, "pole_ref", False) or abs(root - pole) > 0.25 * abs(zm - pole):
        return root
    mid = pole + 0.5 * (zm - pole)
    if not (w.P_direct(pole) < 0.0 < w.P_direct(mid)):
        return root
    lo, hi = (pole, mid) if pole < mid else (mid, pole)
    return optimize.brentq(w.P_direct, lo, hi, xtol=1e-300, rtol=4 * _EPS)


def _conditioning(top: TippeTop, E, D, lam, depth):
    """Relative uncertainty of a band's width caused by rounding (E, D, λ) to doubles.

    The depth Ẽ − V_min is a difference of terms of size S = |Ẽ| + D²/(2 I1) + m λ²/(2 I1 I3);
    rounding each input by ε changes it by ~4εS, and the turning points move by about that fraction
    of the depth times the width.
    """
    S = np.abs(E) + D * D / (2.0 * top.I1) + top.m * lam * lam / (2.0 * top.I1 * top.I3)
    return 64.0 * _EPS * S / np.maximum(depth, 1e-300)


def _steady_tolerance(top: TippeTop, E, D, lam, Es, gravity, kinetic):
    """(computed, inputs): how far from the bottom of the well Ẽ may lie and count as "steady".

    ``computed`` bounds the rounding of the depth Ẽ − V(z_m) as computed from the doubles (E, D, λ):
    a sum of terms of size |E'|, m g R(1 ∓ αz), C N²/(1 − z²) after the exact shift (at a pole where
    N vanishes the last one is its finite limit 0). Within it the band is steady; above it the
    doubles (E, D, λ), taken as exact, admit a nutation band, which is resolved.

    ``inputs`` bounds what rounding the inputs themselves moves the depth by: ~4εS with
    S = |Ẽ| + D²/(2 I1) + m λ²/(2 I1 I3). Ẽ below the well by less than ``computed + inputs`` is
    within the error of its inputs: steady, not inadmissible.
    """
    S = np.abs(E) + D * D / (2.0 * top.I1) + top.m * lam * lam / (2.0 * top.I1 * top.I3)
    computed = 64.0 * _EPS * np.maximum.reduce([np.abs(Es), gravity, kinetic])
    return computed, 8.0 * _EPS * S


def _kinetic_at(w, zm):
    """C N(z_m)²/(1 − z_m²), with the limit 0 at a pole."""
    zm = np.asarray(zm, dtype=float)
    n = w.N(zm)
    wz = 1.0 - zm * zm
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(wz > 0.0, w.C * n * n / np.where(wz > 0.0, wz, 1.0), 0.0)


def _snap_to_pole(w, z: float) -> float:
    """A minimum found within a few ulps of a pole where N vanishes is the pole itself."""
    if 1.0 - abs(z) <= 64.0 * _EPS and abs(z) < 1.0 and w.n_vanishes(math.copysign(1.0, z)):
        return math.copysign(1.0, z)
    return z


_NEAR_POLE = 1e-6  # wells closer than this to a pole (in z) are classified in the pole form


def _near_pole_well(w: _Well, zm: float) -> bool:
    """A well hugging a pole where N does not vanish (a vanishing spin's wall): see _pole_band."""
    return 1.0 - abs(zm) < _NEAR_POLE and not (abs(zm) == 1.0 and w.n_vanishes(zm))


def _root_towards(P, lo: float, hi: float) -> float:
    """Root of P in [lo, hi] with P(lo) <= 0 < P(hi) (or the reverse), lo possibly 0 or tiny.

    The bracket is first shrunk geometrically towards lo (by 16× per step) so that brentq starts
    within a factor 16 of a root that may lie many decades below hi (a wall at u ~ 1e-25).
    """
    s_hi = float(P(hi)) > 0.0
    while hi - lo > 16.0 * lo:
        mid = hi / 16.0 if lo == 0.0 else math.sqrt(lo * hi) if lo > 0.0 else 0.5 * (lo + hi)
        if not lo < mid < hi:
            break
        if (float(P(mid)) > 0.0) != s_hi:
            lo = mid
            break
        hi = mid
    return optimize.brentq(P, lo, hi, xtol=1e-300, rtol=4 * _EPS, maxiter=400)


def _interior_u(form: _PoleForm, u_hint: float) -> tuple[float, float]:
    """(u, P(u)/(u(2 − u))): the largest excess Ẽ − V on a log grid of u up to 1e-7 and at u_hint."""
    u = np.concatenate([np.logspace(-320, -7, 628), [u_hint] if 0.0 < u_hint < 2.0 else []])
    u = u[u > 0.0]
    with np.errstate(all="ignore"):
        e = form.P(u) / (u * (2.0 - u))
    e[~np.isfinite(e)] = -np.inf
    k = int(np.argmax(e))
    return float(u[k]), float(e[k])


def _pole_band(w: _Well, zm: float) -> Band:
    """Classify and bound the band of a well hugging the pole p, in the distance u = 1 − p z.

    With a vanishing spin the bottom of the well lies at u ~ |N(p)|, far below one ulp of z, and
    the depth Ẽ − V there is below the rounding of the z-form: in the pole form
    (:class:`_PoleForm`, exact A_p and N_p) the excess e(u) = P(u)/(u(2 − u)) keeps its digits. Its
    maximum over a logarithmic grid of u decides the kind; the turning points are the roots of
    P(u) on either side of it (the one at the pole side a hair off it, or the pole itself if N(p)
    is 0 to the last bit).
    """
    p = math.copysign(1.0, zm)
    form = _PoleForm(w, p, at_pole=False)
    u_m, depth = _interior_u(form, 1.0 - p * zm)
    top = w.top
    tol = 64.0 * _EPS * (abs(form.A) + w.mgR * top.alpha * u_m + abs(form.A - depth))
    z_m = p * (1.0 - u_m)
    if depth <= tol:
        kind = "steady" if depth >= -(tol + 8.0 * _EPS * abs(w.E)) else "none"
        z = zm if kind == "steady" else math.nan
        return Band(kind, z, z, zm, max(depth, 0.0) if kind == "steady" else depth)
    # pole side: a root in (0, u_m) if P(0) = −C N_p² < 0, else the pole itself
    u_near = 0.0
    if float(form.P(0.0)) < 0.0:
        u_near = _root_towards(form.P, 0.0, u_m)
    # far side: the first sign change of P beyond u_m, bracketed by doubling up to z = 0; past
    # it, in the form of the other pole (its distance v = 1 + p z keeps the digits near it)
    lo, hi = u_m, min(2.0 * u_m, 1.0)
    while hi < 1.0 and float(form.P(hi)) > 0.0:
        lo, hi = hi, min(2.0 * hi, 1.0)
    z_near = p * (1.0 - u_near)
    if u_near > 0.0 and z_near == p:  # a wall closer to the pole than one ulp of z: not the pole
        z_near = math.nextafter(p, 0.0)
    if float(form.P(hi)) <= 0.0:
        z_far = p * (1.0 - optimize.brentq(form.P, lo, hi, xtol=1e-300, rtol=4 * _EPS))
    else:
        other = _PoleForm(w, -p, at_pole=False)
        v_lo = 0.0
        if float(other.P(0.0)) >= 0.0:  # N(−p) negligible: the far pole is reached if A ≥ 0
            v_lo = 1.0
            while v_lo > 1e-300 and float(other.P(v_lo)) > 0.0:
                v_lo *= 0.5
            v_lo = 0.0 if float(other.P(v_lo)) > 0.0 else v_lo
        if v_lo == 0.0 and float(other.P(0.0)) >= 0.0:
            v_far = 0.0
        else:
            v_far = _root_towards(other.P, v_lo, 1.0)
        z_far = -p * (1.0 - v_far)
        if v_far > 0.0 and z_far == -p:
            z_far = math.nextafter(-p, 0.0)
    z_lo, z_hi = min(z_near, z_far), max(z_near, z_far)
    return Band("nutation", z_lo, z_hi, z_m if abs(z_m) < 1.0 else zm, depth)


def _refine_layer_ends(w: _Well, b: Band) -> Band:
    """Turning points in the layer of a pole re-solved in the pole form (:meth:`_PoleForm.root`).

    The z-form P is accurate to ~ε of its largest terms, a few ulps of z next to a pole; the
    distance u = 1 − p z from the pole is solved to full relative precision instead.
    """
    ends = [b.z_low, b.z_high]
    mid = 0.5 * (b.z_low + b.z_high)
    for i, layer in enumerate(_pole_layer(b)):
        z = ends[i]
        if layer and abs(z) < 1.0:
            p = 1.0 if z >= 0.0 else -1.0
            form = _PoleForm(w, p, at_pole=False)
            u_in = 1.0 - p * mid
            if not float(form.P(u_in)) > 0.0:
                continue
            zt = p * (1.0 - form.root(1.0 - p * z, u_in))
            ends[i] = zt if abs(zt) < 1.0 else math.nextafter(p, 0.0)
    return b._replace(z_low=ends[0], z_high=ends[1])


def _band_scalar(top: TippeTop, E: float, D: float, lam: float, z0: float | None) -> Band:
    w = _Well(top, E, D, lam)
    mins = _wells(w)
    candidates = []
    for zm in mins:
        if _near_pole_well(w, zm):
            candidates.append(_pole_band(w, zm))
            continue
        depth = w.excess(zm)
        tol, tol_in = (
            float(t)
            for t in _steady_tolerance(
                top, E, D, lam, w.Es, float(w.gravity(zm)), float(_kinetic_at(w, zm))
            )
        )
        if depth < -(tol + tol_in):
            candidates.append(Band("none", math.nan, math.nan, zm, depth))
        elif depth <= tol:
            candidates.append(Band("steady", zm, zm, zm, max(depth, 0.0)))
        else:
            w.set_reference(zm)
            try:
                z_low = _turning_point(w, -1.0, zm) if zm > -1.0 else -1.0
                z_high = _turning_point(w, 1.0, zm) if zm < 1.0 else 1.0
            except ValueError:
                # no sign change between the bottom and a pole: the band is below rounding
                candidates.append(Band("steady", zm, zm, zm, depth))
                continue
            candidates.append(_refine_layer_ends(w, Band("nutation", z_low, z_high, zm, depth)))
    live = [b for b in candidates if b.kind != "none"]
    if z0 is not None:
        for b in live:
            # Only selects the well: allow for the rounding of (E, D, λ) themselves, which moves
            # the turning points by ~ (rounding of the energy terms / depth) of the band width.
            slack = (b.z_high - b.z_low) * (1e-6 + _conditioning(top, E, D, lam, b.depth)) + 1e-12
            if b.z_low - slack <= z0 <= b.z_high + slack:
                return b
        raise ValueError(_z0_message(z0, E, D, lam))
    if len(live) > 1:
        # Several disjoint wells: the one the motion is in depends on the start.
        bands = ", ".join(f"[{b.z_low:.6g}, {b.z_high:.6g}]" for b in live)
        raise ValueError(f"V has several admissible bands {bands}; pass z0 to choose one")
    if live:
        return live[0]
    best = max(candidates, key=lambda b: b.depth)
    return best


def _start_energy(top: TippeTop, E: float, D: float, lam: float, z0: float) -> float | None:
    """Ẽ raised onto V(z0) when the start z0 lies outside the band only by the inputs' rounding.

    A start at rest in θ (a state) is a turning point: V(z0) = Ẽ exactly. Rounding E, D, λ to
    doubles moves Ẽ − V by up to ~8εS (:func:`_steady_tolerance`); at high spin that is more
    than the depth of the band, so the rounded triple can put z0 just outside its band, or leave
    no band at all. Within that bound the double nearest V(z0) (stepped up by ulps until the
    band holds z0) is returned, so that z0 is a turning point to one ulp of Ẽ; beyond it, None
    (inadmissible).
    """
    w = _Well(top, E, D, lam)
    excess = float(w.excess(z0))
    if not math.isfinite(excess) or excess >= 0.0:
        return None
    kin = float(_kinetic_at(w, z0))
    tol, tol_in = _steady_tolerance(top, E, D, lam, w.Es, float(w.gravity(z0)), kin)
    if -excess > float(tol + tol_in):
        return None
    raised = E - excess
    for _ in range(64):
        try:
            _band_scalar(top, raised, D, lam, z0)
            return raised
        except ValueError:
            raised = max(math.nextafter(raised, math.inf), raised + float(tol))
    return None


def _broadcast(E, D, lam, z0=None):
    E = _validate.as_finite_array("E", E)
    D = _validate.as_finite_array("D", D)
    lam = _validate.as_finite_array("lam", lam)
    if z0 is None:
        return [*np.broadcast_arrays(E, D, lam), None]
    z0 = _validate.cos_theta(z0, "z0")
    return np.broadcast_arrays(E, D, lam, z0)


# --- the scalar reference implementation --------------------------------------------------
# One element at a time with scipy's brentq: the public functions below use the array path and
# come here only for elements it passes on (see _solve); the tests compare the two paths.


def _admissible(top: TippeTop, E, D, lam, z0) -> tuple[Band, _Well]:
    try:
        b = _band_scalar(top, E, D, lam, z0)
    except ValueError:
        e_start = None if z0 is None else _start_energy(top, E, D, lam, z0)
        if e_start is None:
            raise
        E = e_start
        b = _band_scalar(top, E, D, lam, z0)
    if b.kind == "none":
        raise ValueError(_no_motion_message(E, D, lam, b.depth, b.z_min))
    w = _Well(top, E, D, lam)
    w.set_reference(b.z_min)
    return b, w


def _near_pole_root(z_t, z_m):
    """Turning points in the quarter of [pole, z_m] next to a pole (see _polish_near_pole)."""
    pole = np.copysign(1.0, z_t)
    return np.abs(z_t - pole) <= 0.25 * np.abs(z_m - pole)


def _offset_root(w: _Well, z_t: float, z_m: float) -> tuple[float, bool]:
    """Turning point z_t as the offset z_t − z_r from the reference, refined on P_offset.

    Returns the offset and whether it is a root of P (False for a wall next to a pole).

    z_t is a correctly rounded root of P, but at high spin ulp(z_t) is not small against the band:
    the Gauss–Legendre node next to a turning point is only ~1e-7 band widths from it, so an
    endpoint off by one ulp of z puts a relative error of ulp/(1e-7 h) into P there. (Before this,
    periods at ω3 = 3000 rad/s were off by ~1e-7 and at 3e4 rad/s by ~1e-5.)
    """
    x0 = z_t - w.zr
    if abs(z_t) == 1.0:
        return x0, True  # a pole reached by the band (N vanishes there): a turning point exactly
    if not w.pole_ref and _near_pole_root(z_t, z_m):
        return (
            x0,
            True,
        )  # solved with the direct P (_polish_near_pole); the expansion is worse there
    inward = 1.0 if z_m > z_t else -1.0
    step = _OFFSET_STEP
    for _ in range(_OFFSET_TRIES):
        a, b = x0 - inward * step, x0 + inward * step  # a outside the band (P < 0), b inside
        if abs(w.zr + a) < 1.0 and (b - x0) * inward < abs(z_m - z_t):
            pa, pb = w.P_offset(a), w.P_offset(b)
            if pa <= 0.0 <= pb:
                lo, hi = min(a, b), max(a, b)
                return optimize.brentq(w.P_offset, lo, hi, xtol=1e-300, rtol=4 * _EPS), True
        step *= 4.0
    # No sign change next to z_t: a wall within one ulp of a pole (N ≈ 0, a vanishing spin; see
    # _turning_point), not a root of P.
    return x0, False


def _gauss_sum(values):
    """Σ weights · values over the last axis (the u nodes).

    Summed the same way for one element and for a row of many (numpy's pairwise sum along a
    contiguous row), so the array path and the scalar path agree to the last bit.
    """
    return np.sum(values * _U_WEIGHTS, axis=-1)


# A band with an end closer than this fraction of its half-width to a pole (or at the pole) is
# integrated about that pole (:func:`_anchored_quadrature`).
_POLE_LAYER = 1e-3
_POLE_ABS = 1e-8  # ... or closer than this in z (a few ulps of z would be ≳1e-8 of the gap)
_TAU_PANEL = 0.75  # width of the Gauss–Legendre panels in τ (see _anchored_half)
_TAU_NODES = np.polynomial.legendre.leggauss(20)


def _pole_layer(b: Band) -> tuple[bool, bool]:
    """Whether each end of the band lies in the layer of a pole: its gap to the nearer pole is
    below ``_POLE_LAYER`` of the band's half-width (0 included: an end at the pole).

    Next to a pole where N does not vanish the end sits against a steep wall of V (R changes by
    O(1) over the gap, which a Gauss rule over the whole band cannot resolve); an end at or a hair
    off an unstable pole is the logarithmic layer of the separatrix; and in z the gap itself may be
    below one ulp of z. All such bands are integrated in the distance u = 1 ∓ z from that pole.
    """
    h = 0.5 * (b.z_high - b.z_low)
    if b.kind != "nutation" or not h >= 0.0:  # steady (or no) motion: no band, no layer
        return False, False
    gap = max(_POLE_LAYER * h, _POLE_ABS)
    return (1.0 - abs(b.z_low) < gap), (1.0 - abs(b.z_high) < gap)


def _pole_N(top: TippeTop, D: float, lam: float, pole: float) -> float:
    """N(±1) = λ√d(±1) + R D(α ∓ 1), correctly rounded (exact rationals, √d to ~ε²).

    Next to a pole N(±1) is often a tiny remainder of its two terms (a start a hair off the pole
    with φ̇0 = 0 has N(z0) = 0), and its rounding in double would be a large relative error.
    """
    F = Fraction
    # γ = I1/I3, σ = m R²/I3 from the top's parameters themselves, not their rounded ratios
    gam, sig = F(top.I1) / F(top.I3), F(top.m) * F(top.R) ** 2 / F(top.I3)
    dp = gam + sig * (F(top.alpha) - F(pole)) ** 2
    s = math.sqrt(float(dp))
    r = (dp - F(s) ** 2) / (2 * F(s))  # one Newton step: √dp = s + r to ~ε²
    return float(F(lam) * (F(s) + r) + F(top.R) * F(D) * (F(top.alpha) - F(pole)))


class _PoleForm:
    """P and φ̇ in the distance u = 1 − p z from the pole p = ±1, without cancellation near it.

    1 − z² = u(2 − u), E' − m g R(1 − αz) = A_p − m g R α p u with A_p = E' − m g R(1 − αp)
    formed exactly (:func:`_shift`), and N(z) = N_p + (z − p) N[p, z] with the divided difference
    N[p, z] = λ(d'(p) + σ(1 − γ)(z − p))/(√d(z) + √d(p)) − R D (d is quadratic), z − p = −p u:

        P(u) = u(2 − u)(A_p − m g R α p u) − C (N_p − p u N[p, z])².

    With ``at_pole`` (a band ending at the pole, a steady spin there) ``N_p`` is set to 0 where N
    vanishes at the pole to rounding.
    """

    def __init__(self, w: _Well, pole: float, at_pole: bool = True) -> None:
        top = w.top
        self.w, self.p = w, pole
        self.A = float(_shift(top, w.E, w.D, w.lam, pole))
        self.sqd_p = math.sqrt(float(d(top, pole)))
        self.dd_p = float(dd_dz(top, pole))
        # N_p is 0 for a band ending at the pole (it vanishes there to rounding); a turning point
        # a hair off the pole needs its exact small value
        self.N_p = 0.0 if at_pole and w.n_vanishes(pole) else _pole_N(top, w.D, w.lam, pole)

    def z(self, u):
        return self.p * (1.0 - u)

    def n_div(self, u):
        """N[p, z] (see the class docstring)."""
        top, w = self.w.top, self.w
        zp = -self.p * u
        sqd = np.sqrt(d(top, np.clip(self.z(u), -1.0, 1.0)))
        num = self.dd_p + top.sigma * (1.0 - top.gamma) * zp
        return w.lam * num / (sqd + self.sqd_p) - top.R * w.D

    def P(self, u):
        w = self.w
        n = self.N_p - self.p * u * self.n_div(u)
        return u * (2.0 - u) * (self.A - w.mgR * w.top.alpha * self.p * u) - w.C * n * n

    def phidot(self, u):
        """φ̇ = N/(R I1 (1 − z²)√d(z)) = N_p/(R I1 u(2 − u)√d) − p N[p, z]/(R I1 (2 − u)√d)."""
        top = self.w.top
        sqd = np.sqrt(d(top, np.clip(self.z(u), -1.0, 1.0)))
        k = top.R * top.I1 * (2.0 - u) * sqd
        return self.N_p / (k * u) - self.p * self.n_div(u) / k

    def phidot_limit(self) -> float:
        """lim φ̇ at the pole where N vanishes: −p N'(p)/(2 R I1 √d(p)) (N'(p) = N[p, p])."""
        top = self.w.top
        n1 = float(self.n_div(0.0))
        return -self.p * n1 / (2.0 * top.R * top.I1 * self.sqd_p)

    def root(self, u_guess: float, u_in: float) -> float:
        """The turning point u_t near ``u_guess`` (P(u_in) > 0), solved in u to full relative precision."""
        if u_guess <= 0.0:
            return 0.0
        inward = 1.0 if u_in > u_guess else -1.0
        step = 4.0 * _EPS * (1.0 + u_guess) + 1e-6 * u_guess
        for _ in range(60):
            a = u_guess - inward * step
            b = u_guess + inward * step
            if inward > 0.0:
                a = max(a, 0.0)
                b = min(b, u_in)
            else:
                a, b = min(a, 2.0), max(b, u_in)
            pa, pb = float(self.P(a)), float(self.P(b))
            if pa <= 0.0 < pb:
                lo, hi = min(a, b), max(a, b)
                return optimize.brentq(self.P, lo, hi, xtol=1e-300, rtol=4 * _EPS)
            step *= 4.0
        return u_guess


def _anchored_half(form: _PoleForm, u_t: float, u_s: float, weight: bool):
    """∫ √(g/P) dz (and ∫ φ̇ √(g/P) dz) from the turning point u_t to the interior point u_s.

    With u = u_t + s c sinh²τ (s = ±1 towards u_s, W = |u_s − u_t|, c the scale of the layer at
    u_t: its distance u_t from the pole, or 2|A_p|/|b| for an end at the pole; at most W) the integrand becomes 2√c cosh τ √(g/R), R = P/|u − u_t|, which is smooth: the inverse square
    root at u_t is gone, and when the pole lies a distance u_t ≪ W beyond the turning point (the
    separatrix layer, P ≈ b u (u − u_t)) the near-singularity 1/√u is mapped onto τ = O(1) as well,
    so that T ≈ −(1/κ) ln u_t is integrated, not approximated. Gauss–Legendre on panels of fixed
    width in τ (τ runs up to ~½ ln(4W/u_t) ≤ 40).
    """
    W = abs(u_s - u_t)
    sgn = 1.0 if u_s > u_t else -1.0
    if sgn < 0.0:  # the pole lies beyond u_s, not beyond this end: no layer here
        c = W
    elif u_t > 0.0:  # the pole a distance u_t beyond the end: the layer has that scale
        c = min(u_t, W)
    else:
        # an end at the pole (N_p = 0): P/u ≈ 2 A_p + b u, b = −2 m g R α p − C N'(p)², varies on
        # the scale 2|A_p|/|b| (→ 0 on the separatrix)
        w = form.w
        b = abs(2.0 * w.mgR * w.top.alpha * form.p + w.C * float(form.n_div(0.0)) ** 2)
        c = W if b == 0.0 else min(W, max(2.0 * abs(form.A) / b, 1e-300 * W))
    tau_max = math.asinh(math.sqrt(W / c))
    n_pan = max(2, math.ceil(tau_max / _TAU_PANEL))
    x, wt = _TAU_NODES
    edges = np.linspace(0.0, tau_max, n_pan + 1)
    half = 0.5 * np.diff(edges)
    tau = (0.5 * (edges[:-1] + edges[1:]))[:, None] + half[:, None] * x
    weights = (half[:, None] * wt).ravel()
    tau = tau.ravel()
    sh = np.sinh(tau)
    dist = c * sh * sh
    u = u_t + sgn * dist
    z = np.clip(form.z(u), -1.0, 1.0)
    R = form.P(u) / dist
    f = 2.0 * math.sqrt(c) * np.cosh(tau) * np.sqrt(g(form.w.top, z) / R)
    T = float(np.dot(weights, f))
    if not weight:
        return T, math.nan
    return T, float(np.dot(weights, f * form.phidot(u)))


def _separatrix(form: _PoleForm, tol: float) -> bool:
    """Whether a band ending at the pole sits on the separatrix of that (unstable) pole.

    At the pole (N_p = 0) P(u)/u → 2 A_p, A_p = Ẽ − V(p): with A_p = 0 (to the rounding ``tol``)
    the end u = 0 is a double root of P, the pole an equilibrium reached in infinite time.
    """
    return form.N_p == 0.0 and abs(form.A) <= tol


def _anchored_quadrature(top: TippeTop, b: Band, w: _Well, weight: bool) -> tuple[float, float]:
    """(T, ∮ φ̇ dt) for a band with an end in the layer of a pole (:func:`_pole_layer`).

    Each end is written as its distance u_t from its nearer pole and re-solved there
    (:meth:`_PoleForm.root`); the band is split at its middle and each half integrated from its
    turning point by :func:`_anchored_half`. On the separatrix (an end at an unstable pole with
    Ẽ = V there) the period is infinite and ⟨φ̇⟩ is the pole's limit of φ̇ (the motion spends all
    but a vanishing fraction of its time there): (inf, that limit) is returned.
    """
    za, zb = b.z_low, b.z_high
    pa = 1.0 if za >= 0.0 else -1.0
    pb = 1.0 if zb >= 0.0 else -1.0
    fa = _PoleForm(w, pa, abs(za) == 1.0)
    fb = _PoleForm(w, pb, abs(zb) == 1.0)
    ua0, ub0 = 1.0 - pa * za, 1.0 - pb * zb  # exact (Sterbenz) for |z| ≥ ½
    if pa == pb:
        # both ends next to one pole: the roots about a point inside, found in u (in z the ends
        # may be a few ulps apart or even equal)
        u_in = _interior_u(fa, 1.0 - pa * b.z_min)[0]
        u_lo = _root_towards(fa.P, 0.0, u_in) if float(fa.P(0.0)) < 0.0 else 0.0
        lo, hi = u_in, 2.0 * u_in
        while hi < 1.0 and float(fa.P(hi)) > 0.0:
            lo, hi = hi, 2.0 * hi
        u_hi = optimize.brentq(fa.P, lo, hi, xtol=1e-300, rtol=4 * _EPS)
        ua0, ub0 = (u_hi, u_lo) if pa > 0.0 else (u_lo, u_hi)
        us_a = us_b = 0.5 * (ua0 + ub0)
    else:
        zs = 0.5 * (za + zb)
        us_a, us_b = 1.0 - pa * zs, 1.0 - pb * zs
    tol = 64.0 * _EPS * max(abs(w.Es), float(w.gravity(pa)), float(w.gravity(pb)))
    T = integral = 0.0
    for form, u0, us, at_end in ((fa, ua0, us_a, abs(za) == 1.0), (fb, ub0, us_b, abs(zb) == 1.0)):
        if at_end and _separatrix(form, tol):
            return math.inf, form.phidot_limit()
        u_t = 0.0 if at_end else form.root(u0, us)
        t_half, i_half = _anchored_half(form, u_t, us, weight)
        T += 2.0 * t_half
        integral += 2.0 * i_half
    return T, integral


def _quadrature(top: TippeTop, b: Band, w: _Well, weight_fn=None) -> tuple[float, float]:
    """(T, ∮ weight dt) over one period, by Gauss–Legendre in u after z = c + h sin u.

    T = 2∫ √(g/P) dz = 2∫ √(g/R) du with R = P/((z − z_a)(z_b − z)). With an interior reference
    point the nodes are placed as offsets x = z − z_r (see :func:`_offset_root`) and R is formed from
    divided differences: since Ẽ = V at both turning points, P(x) = w(x)(ΔV(x_a) − ΔV(x)), so
    R = −w ΔV[x_a, x]/(x_b − x) = w ΔV[x_b, x]/(x − x_a), each node using the farther turning point.
    No node then divides two tiny numbers, which otherwise costs digits next to the turning points
    (worst at the bottom of the well, where the whole band is tiny). ``weight_fn`` gets z.
    """
    nodes = _U_NODES
    if any(_pole_layer(b)):
        return _anchored_quadrature(top, b, w, weight_fn is not None)
    if w.zr is None:
        c, h = 0.5 * (b.z_low + b.z_high), 0.5 * (b.z_high - b.z_low)
        z = c + h * np.sin(nodes)
        integrand = h * np.cos(nodes) * np.sqrt(g(top, z) / w.P(z))
    else:
        (x_a, root_a), (x_b, root_b) = (_offset_root(w, zt, b.z_min) for zt in (b.z_low, b.z_high))
        # The divided differences need Ẽ = V at both ends: not at a wall next to a pole.
        interior = not w.pole_ref and abs(b.z_low) < 1.0 and abs(b.z_high) < 1.0
        interior = interior and root_a and root_b
        c, h = 0.5 * (x_a + x_b), 0.5 * (x_b - x_a)
        x = c + h * np.sin(nodes)
        z = np.clip(w.zr + x, -1.0, 1.0)
        integrand = None
        if interior:
            wx = w.w_r - (2.0 * w.zr + x) * x
            lower = nodes <= 0.0
            with np.errstate(divide="ignore", invalid="ignore"):
                R = np.where(
                    lower,
                    -wx * w.delta_V_divided(x_a, x) / (x_b - x),
                    wx * w.delta_V_divided(x_b, x) / (x - x_a),
                )
            if np.all(np.isfinite(R) & (R > 0.0)):
                integrand = np.sqrt(g(top, z) / R)
        if integrand is None:  # degenerate geometry (e.g. a wall one ulp from a pole)
            integrand = h * np.cos(nodes) * np.sqrt(g(top, z) / w.P_offset(x))
    T = 2.0 * float(_gauss_sum(integrand))
    if weight_fn is None:
        return T, math.nan
    return T, 2.0 * float(_gauss_sum(integrand * weight_fn(z)))


def _small_oscillation_omega(top: TippeTop, b: Band, w: _Well) -> float:
    zm = b.z_min
    if abs(zm) == 1.0:
        # At a spinning pole z oscillates as ü = (ε − 2|V'| u)/g in u = 1 ∓ z: ω² = 2|V'(±1)|/g.
        slope = abs(float(dV_dz(top, zm, w.D, w.lam)))
        return math.sqrt(2.0 * slope / float(g(top, zm)))
    curv = float(d2V_dz2(top, zm, w.D, w.lam))
    return math.sqrt((1.0 - zm * zm) * curv / (2.0 * float(g(top, zm))))


def _phidot(top: TippeTop, w: _Well, z):
    """φ̇(z) = N(z)/(R I1 (1 − z²) √d(z)) (theory.md §4)."""
    return w.N(z) / (top.R * top.I1 * (1.0 - z * z) * np.sqrt(d(top, z)))


def _map(fn, E, D, lam, z0):
    E, D, lam, z0 = _broadcast(E, D, lam, z0)
    zz = [None] * E.size if z0 is None else z0.ravel()
    res = [
        fn(float(e), float(dd), float(la), None if z is None else float(z))
        for e, dd, la, z in zip(E.ravel(), D.ravel(), lam.ravel(), zz, strict=True)
    ]
    arr = np.array(res, dtype=float)
    if E.ndim == 0:
        return float(arr[0]) if arr.ndim == 1 else arr[0]
    return arr.reshape(E.shape + arr.shape[1:])


def _reference_band(top: TippeTop, E, D, lam, *, z0=None) -> Band:
    """:func:`band`, one element at a time (scalar reference implementation)."""
    E, D, lam, z0 = _broadcast(E, D, lam, z0)
    out = [
        _band_scalar(top, float(e), float(dd), float(la), None if z0 is None else float(zz))
        for e, dd, la, zz in zip(
            E.ravel(),
            D.ravel(),
            lam.ravel(),
            [None] * E.size if z0 is None else z0.ravel(),
            strict=True,
        )
    ]
    if E.ndim == 0:
        return out[0]
    fields = list(zip(*out, strict=True))
    return Band(
        np.array(fields[0], dtype=object).reshape(E.shape),
        *(np.array(col, dtype=float).reshape(E.shape) for col in fields[1:]),
    )


def _reference_f(top: TippeTop, z, E, D, lam) -> np.ndarray:
    """:func:`f`, one element at a time (scalar reference implementation)."""
    z = _validate.cos_theta(z)
    E, D, lam, _ = _broadcast(E, D, lam)
    z, E, D, lam = np.broadcast_arrays(z, E, D, lam)
    out = np.empty(z.shape)
    for idx in np.ndindex(z.shape):
        w = _Well(top, float(E[idx]), float(D[idx]), float(lam[idx]))
        out[idx] = w.P(float(z[idx]))
    return out / g(top, z)


def _reference_turning_points(top: TippeTop, E, D, lam, *, z0=None) -> np.ndarray:
    """:func:`turning_points`, one element at a time (scalar reference implementation)."""
    return _map(lambda *args: _turning_points_one(top, *args), E, D, lam, z0)


def _reference_nutation_period(top: TippeTop, E, D, lam, *, z0=None) -> np.ndarray:
    """:func:`nutation_period`, one element at a time (scalar reference implementation)."""
    return _map(lambda *args: _period_one(top, *args), E, D, lam, z0)


def _reference_mean_precession(top: TippeTop, E, D, lam, *, z0=None) -> np.ndarray:
    """:func:`mean_precession`, one element at a time (scalar reference implementation)."""
    return _map(lambda *args: _precession_one(top, *args), E, D, lam, z0)


def _turning_points_one(top: TippeTop, E, D, lam, z0) -> tuple[float, float]:
    b, _ = _admissible(top, E, D, lam, z0)
    return (b.z_low, b.z_high)


def _period_one(top: TippeTop, E, D, lam, z0, b: Band | None = None) -> float:
    if b is None:
        b, w = _admissible(top, E, D, lam, z0)
    else:
        w = _Well(top, E, D, lam)
        w.set_reference(b.z_min)
    if b.kind == "steady":
        return 2.0 * math.pi / _small_oscillation_omega(top, b, w)
    return _quadrature(top, b, w)[0]


def _precession_one(top: TippeTop, E, D, lam, z0, b: Band | None = None) -> float:
    if b is None:
        b, w = _admissible(top, E, D, lam, z0)
    else:
        w = _Well(top, E, D, lam)
        w.set_reference(b.z_min)
    if b.kind == "steady":
        if abs(b.z_min) == 1.0:
            return _PoleForm(w, b.z_min).phidot_limit()  # the limit of a band shrinking onto it
        return float(_phidot(top, w, b.z_min))
    T, integral = _quadrature(top, b, w, lambda z: _phidot(top, w, z))
    if math.isinf(T):
        return integral  # on the separatrix: the limit at the pole (_anchored_quadrature)
    return integral / T


# --- the array path ---------------------------------------------------------------------------

_CHUNK = 512  # elements per block of the well search: keeps the (block × 401) grid in cache
_NONE, _STEADY, _NUTATION = 0, 1, 2
_KINDS = np.array(["none", "steady", "nutation"], dtype=object)
_SIN_U, _COS_U = np.sin(_U_NODES), np.cos(_U_NODES)
_HALF = _N_QUAD // 2  # nodes u <= 0 (lower half of the band) come first


def _brentq(fun, a, b, *, xtol: float = 1e-300, rtol: float = 4 * _EPS, maxiter: int = 100):
    """scipy.optimize.brentq for arrays of brackets [a, b], iterate for iterate.

    ``fun(x, k)`` evaluates the function of the elements with indices ``k`` (into ``a``) at ``x``.
    The arithmetic and the branches are those of scipy's C implementation, so each element gets
    the root scipy would return for it; converged elements drop out of the evaluations.

    Returns
    -------
    root, ok : ndarray
        ``ok`` is False (root NaN) where f(a) and f(b) have the same sign (scipy raises there).
    """
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    n = a.size
    root, ok = np.full(n, np.nan), np.ones(n, dtype=bool)
    if n == 0:
        return root, ok
    ids = np.arange(n)
    xp, xc = a.copy(), b.copy()
    fp, fc = fun(xp, ids), fun(xc, ids)
    at_a = fp == 0.0
    at_b = (fc == 0.0) & ~at_a
    root[at_a], root[at_b] = xp[at_a], xc[at_b]
    same = ~(at_a | at_b) & (np.signbit(fp) == np.signbit(fc))
    ok[same] = False
    keep = ~(at_a | at_b | same)
    ids, xp, xc, fp, fc = ids[keep], xp[keep], xc[keep], fp[keep], fc[keep]
    xb, fb, sp, sc = (np.zeros(ids.size) for _ in range(4))
    for _ in range(maxiter):
        if ids.size == 0:
            break
        new = (fp != 0.0) & (fc != 0.0) & (np.signbit(fp) != np.signbit(fc))
        xb, fb = np.where(new, xp, xb), np.where(new, fp, fb)
        s = xc - xp
        sp, sc = np.where(new, s, sp), np.where(new, s, sc)
        swap = np.abs(fb) < np.abs(fc)
        xp, xc, xb = np.where(swap, xc, xp), np.where(swap, xb, xc), np.where(swap, xc, xb)
        fp, fc, fb = np.where(swap, fc, fp), np.where(swap, fb, fc), np.where(swap, fc, fb)
        delta = (xtol + rtol * np.abs(xc)) / 2
        sbis = (xb - xc) / 2
        done = (fc == 0.0) | (np.abs(sbis) < delta)
        if np.any(done):
            root[ids[done]] = xc[done]
            keep = ~done
            ids, xp, xc, xb, fp, fc, fb, sp, sc, delta, sbis = (
                v[keep] for v in (ids, xp, xc, xb, fp, fc, fb, sp, sc, delta, sbis)
            )
            if ids.size == 0:
                break
        with np.errstate(all="ignore"):  # only the branch each element takes is used
            interpolate = -fc * (xc - xp) / (fc - fp)
            dpre = (fp - fc) / (xp - xc)
            dblk = (fb - fc) / (xb - xc)
            extrapolate = -fc * (fb * dblk - fp * dpre) / (dblk * dpre * (fb - fp))
            stry = np.where(xp == xb, interpolate, extrapolate)
            short = (np.abs(sp) > delta) & (np.abs(fc) < np.abs(fp))
            short &= 2 * np.abs(stry) < np.minimum(np.abs(sp), 3 * np.abs(sbis) - delta)
        sp, sc = np.where(short, sc, sbis), np.where(short, stry, sbis)
        xp, fp = xc, fc
        xc = np.where(np.abs(sc) > delta, xc + sc, xc + np.where(sbis > 0, delta, -delta))
        fc = fun(xc, ids)
    root[ids] = xc  # not converged in maxiter (scipy raises): the last iterate
    return root, ok


class _Wells:
    """:class:`_Well` for n elements at once: the same arithmetic, operation for operation.

    Per-element quantities are 1-d arrays. :meth:`sub` selects elements, :meth:`col` turns the
    per-element arrays into columns that broadcast against (n, k) arrays of z (grid, nodes). A
    reference (:meth:`set_reference`) is interior for all elements of an instance or at a pole
    for all.
    """

    _PER_ELEMENT = ("E", "D", "lam", "Es", "zr", "sqd_r", "dd_r", "w_r", "N_r", "depth_r", "A_r")

    def __init__(self, top: TippeTop, E, D, lam, Es=None) -> None:
        self.top, self.E, self.D, self.lam = top, E, D, lam
        self.Es = _shift(top, E, D, lam) if Es is None else Es
        self.C = _kinetic_coefficient(top)
        self.mgR = top.m * top.g * top.R
        self.pole_ref = False
        self.zr = self.sqd_r = self.dd_r = self.w_r = self.N_r = self.depth_r = self.A_r = None

    def _derive(self, fn) -> _Wells:
        new = object.__new__(_Wells)
        new.__dict__.update(self.__dict__)
        for name in self._PER_ELEMENT:
            v = getattr(self, name)
            if v is not None:
                setattr(new, name, fn(v))
        return new

    def sub(self, idx) -> _Wells:
        return self._derive(lambda v: v[idx])

    def col(self) -> _Wells:
        return self._derive(lambda v: v[:, None])

    def N(self, z):
        return _N(self.top, np.sqrt(d(self.top, z)), z, self.D, self.lam)

    def gravity(self, z):
        return self.mgR * (1.0 - self.top.alpha * z)

    def P_direct(self, z):
        n = self.N(z)
        return (1.0 - z * z) * (self.Es - self.gravity(z)) - self.C * n * n

    def critical(self, z):
        top = self.top
        sqd = np.sqrt(d(top, z))
        n = _N(top, sqd, z, self.D, self.lam)
        dn = self.lam * dd_dz(top, z) / (2.0 * sqd) - top.R * self.D
        w = 1.0 - z * z
        return -self.mgR * top.alpha * w * w + 2.0 * self.C * n * (dn * w + z * n)

    def scale(self, z):
        n = self.N(z)
        return (1.0 - z * z) * (np.abs(self.Es) + self.gravity(z)) + self.C * n * n

    def n_vanishes(self, z):
        top = self.top
        scale = np.abs(self.lam) * np.sqrt(d(top, z)) + np.abs(top.R * self.D * (top.alpha - z))
        return np.abs(self.N(z)) <= _POLE_RTOL * scale

    def excess(self, z):
        w = 1.0 - z * z
        n = self.N(z)
        with np.errstate(divide="ignore", invalid="ignore"):
            inside = self.Es - self.gravity(z) - self.C * n * n / w
        at_pole = np.where(self.n_vanishes(z), self.Es - self.gravity(z), -np.inf)
        return np.where(w == 0.0, at_pole, inside)

    def set_reference(self, zr, pole_ref: bool) -> None:
        """As :meth:`_Well.set_reference`; ``pole_ref`` for zr = ±1 where N vanishes."""
        top = self.top
        self.zr, self.pole_ref = zr, pole_ref
        self.sqd_r = np.sqrt(d(top, zr))
        self.dd_r = dd_dz(top, zr)
        if pole_ref:
            self.A_r = _shift(top, self.E, self.D, self.lam, zr)
            return
        self.w_r = 1.0 - zr * zr
        self.N_r = self.N(zr)
        self.depth_r = self.Es - self.gravity(zr) - self.C * self.N_r**2 / self.w_r

    def delta_N(self, delta):
        top = self.top
        z = np.clip(self.zr + delta, -1.0, 1.0)
        dd = self.dd_r * delta + top.sigma * (1.0 - top.gamma) * delta * delta
        return self.lam * dd / (np.sqrt(d(top, z)) + self.sqd_r) - top.R * self.D * delta

    def delta_V_offset(self, delta):
        top = self.top
        dn = self.delta_N(delta)
        n = self.N_r + dn
        w = self.w_r - (2.0 * self.zr + delta) * delta
        kin = (dn * (n + self.N_r) * self.w_r + self.N_r**2 * (2.0 * self.zr + delta) * delta) / (
            w * self.w_r
        )
        return -self.mgR * top.alpha * delta + self.C * kin

    def delta_V_divided(self, a, x):
        top = self.top
        zsum = 2.0 * self.zr + a + x
        d_div = -2.0 * top.sigma * top.alpha + top.sigma * (1.0 - top.gamma) * zsum
        za, zx = np.clip(self.zr + a, -1.0, 1.0), np.clip(self.zr + x, -1.0, 1.0)
        n_div = self.lam * d_div / (np.sqrt(d(top, za)) + np.sqrt(d(top, zx))) - top.R * self.D
        n_a, n_x = self.N_r + self.delta_N(a), self.N_r + self.delta_N(x)
        w_a = self.w_r - (2.0 * self.zr + a) * a
        w_x = self.w_r - (2.0 * self.zr + x) * x
        k_div = (n_div * (n_x + n_a) * w_a + n_a * n_a * zsum) / (w_a * w_x)
        return -self.mgR * top.alpha + self.C * k_div

    def P(self, z):
        if self.pole_ref:
            delta = z - self.zr
            dn = self.delta_N(delta)
            A = self.A_r + self.mgR * self.top.alpha * delta
            return (1.0 - z) * (1.0 + z) * A - self.C * dn * dn
        with np.errstate(divide="ignore", invalid="ignore"):
            out = (1.0 - z * z) * (self.depth_r - self.delta_V_offset(z - self.zr))
        pole = np.abs(z) == 1.0
        if np.any(pole):
            out = np.where(pole, self.P_direct(z), out)
        return out

    def P_offset(self, delta):
        if self.pole_ref:
            w = -(2.0 * self.zr + delta) * delta
            dn = self.delta_N(delta)
            return w * (self.A_r + self.mgR * self.top.alpha * delta) - self.C * dn * dn
        w = self.w_r - (2.0 * self.zr + delta) * delta
        return w * (self.depth_r - self.delta_V_offset(delta))

    def phidot(self, z):
        top = self.top
        return self.N(z) / (top.R * top.I1 * (1.0 - z * z) * np.sqrt(d(top, z)))


def _locate_wells(W: _Wells) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_wells` for every element: (z_min, single), single False where V has not one well.

    Elements with several minima (or none) are left to the scalar path.
    """
    n = W.E.size
    zs = _Z_GRID
    first = np.zeros(n, dtype=np.intp)
    count = np.zeros(n, dtype=np.intp)
    on_grid, pole_hi, pole_lo = (np.zeros(n, dtype=bool) for _ in range(3))
    for start in range(0, n, _CHUNK):
        blk = slice(start, min(start + _CHUNK, n))
        cr = W.sub(blk).col().critical(zs)
        neg = cr < 0.0
        change = neg[:, :-1] & (cr[:, 1:] >= 0.0)  # − → +: a minimum in (zs[i], zs[i + 1]]
        i = np.argmax(change, axis=1)
        hi = (cr[:, -1] <= 0.0) & neg[:, -2]  # V decreasing into a pole where N vanishes
        lo = (cr[:, 0] >= 0.0) & (cr[:, 1] > 0.0)
        # a root exactly at z = 1 and the pole minimum there are one minimum (the set in _wells)
        twice = hi & change[:, -1] & (cr[:, -1] == 0.0)
        count[blk] = change.sum(axis=1) + hi + lo - twice
        first[blk] = i
        on_grid[blk] = cr[np.arange(cr.shape[0]), i + 1] == 0.0
        pole_hi[blk], pole_lo[blk] = hi, lo
    single = count == 1
    zm = np.full(n, np.nan)
    zm[single & pole_hi] = 1.0
    zm[single & pole_lo] = -1.0
    inner = single & ~pole_hi & ~pole_lo
    grid = inner & on_grid
    zm[grid] = zs[first[grid] + 1]
    k = np.flatnonzero(inner & ~on_grid)
    root, ok = _brentq(lambda x, j: W.sub(k[j]).critical(x), zs[first[k]], zs[first[k] + 1])
    zm[k] = root
    single[k[~ok]] = False
    # A root found at a pole where N does not vanish is really a hair inside (V = +inf there).
    k = np.flatnonzero(single & (np.abs(zm) == 1.0))
    if k.size:
        hair = ~W.sub(k).n_vanishes(zm[k])
        zm[k[hair]] = np.nextafter(zm[k[hair]], 0.0)
    # ... and one found within a few ulps of a pole where N vanishes is the pole itself
    k = np.flatnonzero(single & (np.abs(zm) < 1.0) & (1.0 - np.abs(zm) <= 64.0 * _EPS))
    if k.size:
        poles = np.copysign(1.0, zm[k])
        snap = W.sub(k).n_vanishes(poles)
        zm[k[snap]] = poles[snap]
    return zm, single


def _turning_points_vec(W: _Wells, pole: float, zm) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_turning_point` for every element of W (reference set): (z, ok)."""
    zm = np.where(np.abs(zm) == 1.0, np.nextafter(zm, pole), zm)
    n = zm.size
    out, ok = np.full(n, np.nan), np.ones(n, dtype=bool)
    end = np.full(n, pole)
    todo = np.ones(n, dtype=bool)
    k = np.flatnonzero(W.P(end) >= 0.0)  # N vanishes at the pole
    if k.size:
        Wk = W.sub(k)
        reach = Wk.excess(end[k]) >= 0.0
        out[k[reach]] = pole
        inner = np.nextafter(end[k], zm[k])
        wall = ~reach
        wall[wall] = (inner[wall] == zm[k][wall]) | (Wk.sub(wall).P(inner[wall]) >= 0.0)
        out[k[wall]] = inner[wall]
        todo[k[reach | wall]] = False
        end[k] = inner
    k = np.flatnonzero(todo)
    root, good = _brentq(
        lambda x, j: W.sub(k[j]).P(x), np.minimum(end[k], zm[k]), np.maximum(end[k], zm[k])
    )
    out[k], ok[k] = root, good
    # polish roots next to the pole with the direct P (see _polish_near_pole)
    if not W.pole_ref:
        k = np.flatnonzero(ok & ~np.isnan(out) & (np.abs(out - pole) <= 0.25 * np.abs(zm - pole)))
        if k.size:
            Wk = W.sub(k)
            mid = pole + 0.5 * (zm[k] - pole)
            brk = (Wk.P_direct(np.full(k.size, pole)) < 0.0) & (Wk.P_direct(mid) > 0.0)
            j = np.flatnonzero(brk)
            if j.size:
                lo, hi = np.minimum(pole, mid[j]), np.maximum(pole, mid[j])
                r, g_ok = _brentq(lambda x, i: Wk.sub(j[i]).P_direct(x), lo, hi)
                out[k[j[g_ok]]] = r[g_ok]
    return out, ok


def _offset_roots(W: _Wells, z_t, z_m) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_offset_root` for every element of W: (offsets, is_root)."""
    x0 = z_t - W.zr
    out = x0.copy()
    found = (np.abs(z_t) == 1.0) | (_near_pole_root(z_t, z_m) & (not W.pole_ref))
    inward = np.where(z_m > z_t, 1.0, -1.0)
    room = np.abs(z_m - z_t)
    lo, hi = np.zeros_like(x0), np.zeros_like(x0)
    bracketed = np.zeros(x0.shape, dtype=bool)
    pending = ~found
    step = _OFFSET_STEP
    for _ in range(_OFFSET_TRIES):
        k = np.flatnonzero(pending)
        if k.size == 0:
            break
        a, b = x0[k] - inward[k] * step, x0[k] + inward[k] * step
        c = (np.abs(W.zr[k] + a) < 1.0) & ((b - x0[k]) * inward[k] < room[k])
        kc, a, b = k[c], a[c], b[c]
        if kc.size:
            Wk = W.sub(kc)
            pa, pb = Wk.P_offset(a), Wk.P_offset(b)
            good = (pa <= 0.0) & (0.0 <= pb)
            kg = kc[good]
            lo[kg], hi[kg] = np.minimum(a[good], b[good]), np.maximum(a[good], b[good])
            bracketed[kg] = True
            pending[kg] = False
        step *= 4.0
    k = np.flatnonzero(bracketed)
    out[k] = _brentq(lambda x, j: W.sub(k[j]).P_offset(x), lo[k], hi[k])[0]
    return out, found | bracketed


def _quadrature_vec(W: _Wells, z_low, z_high, z_min, precession: bool):
    """:func:`_quadrature` for every element of W (reference set): (T, ∮ φ̇ dt or None)."""
    top = W.top
    x_a, root_a = _offset_roots(W, z_low, z_min)
    x_b, root_b = _offset_roots(W, z_high, z_min)
    c, h = 0.5 * (x_a + x_b), 0.5 * (x_b - x_a)
    divided = (np.abs(z_low) < 1.0) & (np.abs(z_high) < 1.0) & root_a & root_b
    divided &= not W.pole_ref
    T = np.full(z_low.shape, np.nan)
    integral = np.full(z_low.shape, np.nan) if precession else None
    for mask, use_divided in ((divided, True), (~divided, False)):
        k = np.flatnonzero(mask)
        if k.size == 0:
            continue
        Wk = W.sub(k).col()
        xa, xb, hk = x_a[k, None], x_b[k, None], h[k, None]
        x = c[k, None] + hk * _SIN_U
        z = np.clip(Wk.zr + x, -1.0, 1.0)
        if use_divided:
            wx = Wk.w_r - (2.0 * Wk.zr + x) * x
            xl, xu = x[:, :_HALF], x[:, _HALF:]
            R = np.empty_like(x)
            R[:, :_HALF] = -wx[:, :_HALF] * Wk.delta_V_divided(xa, xl) / (xb - xl)
            R[:, _HALF:] = wx[:, _HALF:] * Wk.delta_V_divided(xb, xu) / (xu - xa)
            integrand = np.sqrt(g(top, z) / R)
        else:
            integrand = hk * _COS_U * np.sqrt(g(top, z) / Wk.P_offset(x))
        T[k] = 2.0 * _gauss_sum(integrand)
        if precession:
            integral[k] = 2.0 * _gauss_sum(integrand * Wk.phidot(z))
    return T, integral


def _z0_message(z0, E, D, lam) -> str:
    return (
        f"no admissible motion through z0 = {z0!r} for (E, D, lam) = ({E!r}, {D!r}, {lam!r}): "
        "E is below V(z0)"
    )


def _no_motion_message(E, D, lam, depth, z_min) -> str:
    return (
        f"(E, D, lam) = ({E!r}, {D!r}, {lam!r}) admits no motion: E lies "
        f"{-depth:.3g} J below the minimum of V (at z = {z_min:.6g}); need E >= min V"
    )


class _Solution(NamedTuple):
    """Flat results of :func:`_solve` (broadcast shape ``shape``)."""

    shape: tuple
    kind: np.ndarray  # _NONE, _STEADY, _NUTATION
    z_low: np.ndarray
    z_high: np.ndarray
    z_min: np.ndarray
    depth: np.ndarray
    value: np.ndarray  # period or mean precession (NaN if not asked for)
    errors: dict  # flat index -> (message, raised by band() too)
    scalar: np.ndarray  # elements computed by the scalar reference path


def _solve(top: TippeTop, E, D, lam, z0, quantity: str | None = None) -> _Solution:
    """Bands of all elements (and ``quantity``: "period" or "precession"), array path first."""
    E, D, lam, z0 = _broadcast(E, D, lam, z0)
    shape = E.shape
    E, D, lam = (np.array(v, dtype=float).ravel() for v in (E, D, lam))
    z0 = None if z0 is None else np.array(z0, dtype=float).ravel()
    n = E.size
    kind = np.full(n, _NONE, dtype=np.int8)
    z_low, z_high, z_min, depth, value = (np.full(n, np.nan) for _ in range(5))
    errors: dict[int, tuple[str, bool]] = {}

    W = _Wells(top, E, D, lam)
    zm, vec = _locate_wells(W)
    near = vec & (1.0 - np.abs(zm) < _NEAR_POLE)
    k = np.flatnonzero(near)
    if k.size:  # wells hugging a pole: classified in the pole form (scalar path, _pole_band)
        vec[k] = (np.abs(zm[k]) == 1.0) & W.sub(k).n_vanishes(zm[k])
    v = np.flatnonzero(vec)
    Wv = W.sub(v)
    zmv = zm[v]
    dep = Wv.excess(zmv)
    tol, tol_in = _steady_tolerance(
        top, E[v], D[v], lam[v], Wv.Es, Wv.gravity(zmv), _kinetic_at(Wv, zmv)
    )
    kv = np.where(dep < -(tol + tol_in), _NONE, np.where(dep <= tol, _STEADY, _NUTATION))
    kind[v], z_min[v], depth[v] = kv, zmv, dep
    steady = v[kv == _STEADY]
    z_low[steady] = z_high[steady] = zm[steady]
    depth[steady] = np.maximum(depth[steady], 0.0)

    # Nutation: turning points (and the quadrature) for interior and pole references apart.
    nut = v[kv == _NUTATION]
    at_pole = np.abs(zm[nut]) == 1.0
    at_pole[at_pole] = W.sub(nut[at_pole]).n_vanishes(zm[nut[at_pole]])
    vec[nut[(np.abs(zm[nut]) == 1.0) & ~at_pole]] = False  # no reference: scalar path
    for k, pole_ref in ((nut[np.abs(zm[nut]) < 1.0], False), (nut[at_pole], True)):
        if k.size == 0:
            continue
        Wk = W.sub(k)
        Wk.set_reference(zm[k], pole_ref)
        zl, zh = np.full(k.size, -1.0), np.full(k.size, 1.0)
        good = np.ones(k.size, dtype=bool)
        for pole, zt in ((-1.0, zl), (1.0, zh)):
            j = np.flatnonzero(zm[k] != pole)
            zt[j], ok = _turning_points_vec(Wk.sub(j), pole, zm[k][j])
            good[j[~ok]] = False
        # bands ending in a boundary layer next to a pole go to the graded quadrature (scalar)
        half = 0.5 * (zh - zl)
        gap = np.maximum(_POLE_LAYER * half, _POLE_ABS)
        layer = (half >= 0.0) & ((1.0 - np.abs(zl) < gap) | (1.0 - np.abs(zh) < gap))
        good &= ~layer
        vec[k[~good]] = False
        z_low[k], z_high[k] = zl, zh
        if quantity is not None and np.any(good):
            j = np.flatnonzero(good)
            T, integral = _quadrature_vec(
                Wk.sub(j), zl[j], zh[j], zm[k[j]], precession=quantity == "precession"
            )
            value[k[j]] = T if integral is None else integral / T
    if quantity is not None:
        s = steady[vec[steady]]
        zs, Ds, lams = zm[s], D[s], lam[s]
        pole = np.abs(zs) == 1.0
        if quantity == "period":
            omega = np.empty(s.size)
            zi = zs[~pole]
            curv = d2V_dz2(top, zi, Ds[~pole], lams[~pole])
            omega[~pole] = np.sqrt((1.0 - zi * zi) * curv / (2.0 * g(top, zi)))
            slope = np.abs(dV_dz(top, zs[pole], Ds[pole], lams[pole]))
            omega[pole] = np.sqrt(2.0 * slope / g(top, zs[pole]))
            value[s] = 2.0 * math.pi / omega
        else:
            value[s[~pole]] = W.sub(s[~pole]).phidot(zs[~pole])
            # at a spinning pole: the limit of ⟨φ̇⟩ for a band shrinking onto it
            for i in s[pole]:
                w1 = _Well(top, float(E[i]), float(D[i]), float(lam[i]))
                value[i] = _PoleForm(w1, float(zm[i])).phidot_limit()

    # The start z0 must lie in the band (up to the conditioning of the band).
    if z0 is not None:
        live = v[(kind[v] != _NONE) & vec[v]]
        width = z_high[live] - z_low[live]
        slack = width * (1e-6 + _conditioning(top, E[live], D[live], lam[live], depth[live]))
        slack = slack + 1e-12
        inside = (z_low[live] - slack <= z0[live]) & (z0[live] <= z_high[live] + slack)
        bad = np.concatenate([v[(kind[v] == _NONE) & vec[v]], live[~inside]])
        for i in bad:
            vec[i] = False  # to the scalar path, which takes z0 as a turning point if it can
    else:
        for i in v[(kind[v] == _NONE) & vec[v]]:
            msg = _no_motion_message(float(E[i]), float(D[i]), float(lam[i]), depth[i], z_min[i])
            errors[i] = (msg, False)

    # Everything else: the scalar reference path, element by element.
    scalar = np.flatnonzero(~vec)
    for i in scalar:
        e, dd, la = float(E[i]), float(D[i]), float(lam[i])
        zz = None if z0 is None else float(z0[i])
        try:
            b = _band_scalar(top, e, dd, la, zz)
        except ValueError as exc:
            e_start = None if zz is None else _start_energy(top, e, dd, la, zz)
            if e_start is None:
                errors[i] = (str(exc), True)
                continue
            e = e_start
            b = _band_scalar(top, e, dd, la, zz)
        kind[i] = _KINDS.tolist().index(b.kind)
        z_low[i], z_high[i], z_min[i], depth[i] = b.z_low, b.z_high, b.z_min, b.depth
        if b.kind == "none":
            errors[i] = (_no_motion_message(e, dd, la, b.depth, b.z_min), False)
        elif quantity == "period":
            value[i] = _period_one(top, e, dd, la, zz, b)
        elif quantity == "precession":
            value[i] = _precession_one(top, e, dd, la, zz, b)
    return _Solution(shape, kind, z_low, z_high, z_min, depth, value, errors, ~vec)


def _raise_first(sol: _Solution, *, band_only: bool = False) -> None:
    """Raise the error of the first failing element (C order), as the element loop did."""
    bad = [i for i, (_, in_band) in sol.errors.items() if in_band or not band_only]
    if bad:
        raise ValueError(sol.errors[min(bad)][0])


def _shaped(sol: _Solution, arr: np.ndarray):
    return float(arr[0]) if sol.shape == () else arr.reshape(sol.shape)


# --- the public functions ---------------------------------------------------------------------


def band(
    top: TippeTop, E: ArrayLike, D: ArrayLike, lam: ArrayLike, *, z0: ArrayLike | None = None
) -> Band:
    """Classify the rolling θ-motion with integrals (Ẽ, D, λ) and find its band.

    Parameters
    ----------
    top : TippeTop
    E, D, lam : array_like
        Modified energy Ẽ (= E when rolling), Routh and Jellett integrals; broadcast together.
    z0 : array_like, optional
        A value of cos θ the motion passes through (e.g. the start), to pick the band when V has
        several wells. Without it, several admissible wells raise ``ValueError``.

    Returns
    -------
    Band
        Fields are arrays of the broadcast shape (floats for scalar input).
    """
    sol = _solve(top, E, D, lam, z0)
    _raise_first(sol, band_only=True)
    kinds = _KINDS[sol.kind]
    if sol.shape == ():
        return Band(str(kinds[0]), *(float(a[0]) for a in sol[2:6]))
    return Band(kinds.reshape(sol.shape), *(a.reshape(sol.shape) for a in sol[2:6]))


def classify_motion(top: TippeTop, E: ArrayLike, D: ArrayLike, lam: ArrayLike) -> np.ndarray | str:
    """ "nutation", "steady" (bottom of the well) or "none" (no admissible motion); see :func:`band`."""
    return band(top, E, D, lam).kind


def f(top: TippeTop, z: ArrayLike, E: ArrayLike, D: ArrayLike, lam: ArrayLike) -> np.ndarray:
    """Right-hand side of ż² = f(z) = (1 − z²)(Ẽ − V(z, D, λ))/g(z) (theory.md §4).

    Evaluated as P(z)/g(z) with the exact energy shift (module docstring), so it is finite at the
    poles and accurate where Ẽ − V is a small difference of large numbers.
    """
    z = _validate.cos_theta(z)
    E, D, lam, _ = _broadcast(E, D, lam)
    Es = _shift(top, E, D, lam)
    z, E, D, lam, Es = np.broadcast_arrays(z, E, D, lam, Es)
    return _Wells(top, E, D, lam, Es).P_direct(z) / g(top, z)


def turning_points(
    top: TippeTop, E: ArrayLike, D: ArrayLike, lam: ArrayLike, *, z0: ArrayLike | None = None
) -> np.ndarray:
    """Turning points (z_low, z_high) of the rolling θ-motion: the roots of Ẽ = V(z, D, λ).

    Returns
    -------
    ndarray
        Shape ``broadcast_shape + (2,)``: ``[..., 0] = z_low <= [..., 1] = z_high``. For steady
        precession both equal the minimum of V. A pole is returned when the band reaches it (only
        possible when N vanishes there, i.e. D = D0 or D1).

    Raises
    ------
    ValueError
        If (E, D, λ) admits no motion (E below the minimum of V), or on bad input.

    Examples
    --------
    >>> import mett
    >>> top = mett.presets.get("rutstam2013")
    >>> s = mett.State(theta=1.0, omega3=100.0, phidot=5.0)
    >>> E, D, lam = mett.energy(top, s), mett.routh(top, s), mett.jellett(top, s)
    >>> mett.turning_points(top, E, D, lam).round(6)
    array([0.540302, 0.613785])
    """
    sol = _solve(top, E, D, lam, z0)
    _raise_first(sol)
    return np.stack([sol.z_low, sol.z_high], axis=-1).reshape((*sol.shape, 2))


def nutation_period(
    top: TippeTop, E: ArrayLike, D: ArrayLike, lam: ArrayLike, *, z0: ArrayLike | None = None
) -> np.ndarray:
    """Exact period (s) of the θ-oscillation of the rolling top, T = 2∫ √(g/P) dz over the band.

    For steady precession (Ẽ at the bottom of the well) the small-oscillation limit
    2π/ω_θ, ω_θ² = (1 − z_m²) V''(z_m)/(2 g(z_m)), is returned (theory.md §8).

    Raises
    ------
    ValueError
        If (E, D, λ) admits no motion, or on bad input.

    Examples
    --------
    The thesis body rolling from θ0 = 1 rad, ω3 = 100 rad/s, φ̇0 = 5 rad/s (theory.md §5):

    >>> import mett
    >>> top = mett.presets.get("rutstam2013")
    >>> s = mett.State(theta=1.0, omega3=100.0, phidot=5.0)
    >>> T = mett.nutation_period(top, mett.energy(top, s), mett.routh(top, s), mett.jellett(top, s))
    >>> round(float(T), 6)
    0.055014
    """
    sol = _solve(top, E, D, lam, z0, "period")
    _raise_first(sol)
    return _shaped(sol, sol.value)


def mean_precession(
    top: TippeTop, E: ArrayLike, D: ArrayLike, lam: ArrayLike, *, z0: ArrayLike | None = None
) -> np.ndarray:
    """Mean precession rate ⟨φ̇⟩ (rad/s) over one nutation period of the rolling top.

    ⟨φ̇⟩ = (2/T) ∫ φ̇(z) √(g/P) dz with φ̇(z) = N(z)/(R I1 (1 − z²)√d(z)); for steady precession
    the rate φ̇(z_min) itself.
    """
    sol = _solve(top, E, D, lam, z0, "precession")
    _raise_first(sol)
    return _shaped(sol, sol.value)
