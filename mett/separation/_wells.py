"""P(z) and the wells of V for one element or many (:class:`_Wells`), the pole form of P
(:class:`_PoleForm`) and the classification of a well as nutation, steady or none.
"""

from __future__ import annotations

import functools
import math
from fractions import Fraction
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np
from scipy import optimize

from .. import _formulas as fm

if TYPE_CHECKING:
    from ..top import TippeTop
from ._exact import _EPS, _MAXITER, _shift, _shift_fraction
from ._roots import _brentq

_TINY = float(np.finfo(float).tiny)  # the smallest normal double
_N_GRID = 401  # samples of the critical-point numerator when locating the wells of V
_Z_GRID = np.cos(np.linspace(np.pi, 0.0, _N_GRID))  # denser near the poles
_Z_GRID[0], _Z_GRID[-1] = -1.0, 1.0


class _Wells:
    """P(z) and friends for n elements (E, D, λ), all in double after the exact energy shift.

    Per-element quantities are 1-d arrays, or floats for one element on its own (the per-element
    path); every method is elementwise arithmetic, the same operations for both, and the array
    algorithms (turning points, quadrature, classification) run on either: :meth:`sub` selects
    elements and :meth:`col` turns the per-element arrays into columns that broadcast against
    (n, k) arrays of z (grid, nodes), while one element on its own broadcasts as it is. Squares are
    written as products (a float power may round differently from numpy's square), so an element
    gets the same bits on its own as in an array.

    Once a band is known, :meth:`set_reference` switches P to the form P(z) = w(z)(depth − ΔV(z))
    around the bottom z_r of the well, where depth = Ẽ − V(z_r) is computed once and
    ΔV(z) = V(z) − V(z_r) is assembled from exact differences (U is linear, d quadratic): near the
    bottom of the well, where Ẽ − V is tiny, no large terms cancel any more. A reference is interior
    for all elements of an instance or at a pole for all.
    """

    _PER_ELEMENT = ("E", "D", "lam", "Es", "zr", "sqd_r", "dd_r", "w_r", "N_r", "depth_r", "A_r")

    def __init__(self, top: TippeTop, E, D, lam, Es=None) -> None:
        self.top, self.E, self.D, self.lam = top, E, D, lam
        self.single = np.ndim(E) == 0  # one element on its own (float attributes)
        self.Es = _shift(top, E, D, lam) if Es is None else Es
        if self.single:
            self.Es = float(self.Es)
        self.C = fm.kinetic_coefficient(top)
        self.mgR = top.m * top.g * top.R
        self.pole_ref = False
        # the reference of set_reference (None until then): per element, floats or arrays as E
        self.zr: Any = None
        self.sqd_r: Any = None
        self.dd_r: Any = None
        self.w_r: Any = None
        self.N_r: Any = None
        self.depth_r: Any = None
        self.A_r: Any = None

    def _derive(self, fn) -> _Wells:
        new = object.__new__(_Wells)
        new.__dict__.update(self.__dict__)
        for name in self._PER_ELEMENT:
            v = getattr(self, name)
            if v is not None:
                setattr(new, name, fn(v))
        return new

    def sub(self, idx) -> _Wells:
        """The elements ``idx`` (one element on its own broadcasts: any selection is itself)."""
        return self if self.single else self._derive(lambda v: v[idx])

    def col(self) -> _Wells:
        return self if self.single else self._derive(lambda v: v[:, None])

    def element(self, i: int | np.integer) -> _Wells:
        """Element ``i`` on its own, with float attributes."""
        if self.single:
            return self
        new = self._derive(lambda v: float(v[i]))
        new.single = True
        return new

    def N(self, z):
        return fm.N(self.top, np.sqrt(fm.d(self.top, z)), z, self.D, self.lam)

    def gravity(self, z):
        return self.mgR * (1.0 - self.top.alpha * z)

    def P_direct(self, z):
        n = self.N(z)
        return (1.0 - z * z) * (self.Es - self.gravity(z)) - self.C * n * n

    def critical(self, z):
        """(1 − z²)² ∂V/∂z: regular on [−1, 1]; its sign changes − → + are the minima of V."""
        top = self.top
        sqd = np.sqrt(fm.d(top, z))
        n = fm.N(top, sqd, z, self.D, self.lam)
        dn = self.lam * fm.dd_dz(top, z) / (2.0 * sqd) - top.R * self.D
        w = 1.0 - z * z
        return -self.mgR * top.alpha * w * w + 2.0 * self.C * n * (dn * w + z * n)

    def scale(self, z):
        """Size of the terms of P at z, for rounding-error tolerances."""
        n = self.N(z)
        return (1.0 - z * z) * (np.abs(self.Es) + self.gravity(z)) + self.C * n * n

    def n_vanishes(self, z):
        """Whether N(z) is zero to rounding (at a pole: the spinning solutions D = D0, D1)."""
        top = self.top
        scale = np.abs(self.lam) * np.sqrt(fm.d(top, z)) + np.abs(top.R * self.D * (top.alpha - z))
        return np.abs(self.N(z)) <= fm.POLE_RTOL * scale

    def excess(self, z):
        """Ẽ − V(z) (finite limit at a pole where N vanishes, −inf at one where it does not)."""
        w = 1.0 - z * z
        n = self.N(z)
        with np.errstate(divide="ignore", invalid="ignore"):
            inside = self.Es - self.gravity(z) - self.C * n * n / w
        at_pole = np.where(self.n_vanishes(z), self.Es - self.gravity(z), -np.inf)
        return np.where(w == 0.0, at_pole, inside)[()]

    def set_reference(self, zr, pole_ref: bool) -> None:
        """Expand P about the bottom z_r of the band's well (interior, or ``pole_ref``).

        ``pole_ref``: z_r = ±1 where N vanishes (a well at a spinning pole, D = D0 or D1). There
        P(z_r + δ) = w(δ)(A + m g R α δ) − C ΔN(δ)² with A = Ẽ − V(z_r) = E' − m g R(1 ∓ α)
        computed exactly (:func:`_shift`), so a narrow band next to the pole keeps its digits.
        """
        top = self.top
        self.zr, self.pole_ref = zr, pole_ref
        self.sqd_r = np.sqrt(fm.d(top, zr))
        self.dd_r = fm.dd_dz(top, zr)
        if pole_ref:
            self.A_r = _shift(top, self.E, self.D, self.lam, zr)
            if self.single:
                self.A_r = float(self.A_r)
            return
        self.w_r = 1.0 - zr * zr
        self.N_r = self.N(zr)
        self.depth_r = self.Es - self.gravity(zr) - self.C * (self.N_r * self.N_r) / self.w_r

    def delta_N(self, delta):
        """N(z_r + δ) − N(z_r) without cancellation (needs a reference)."""
        top = self.top
        z = np.clip(self.zr + delta, -1.0, 1.0)
        # d is quadratic: d(z) − d(z_r) = d'(z_r) δ + σ(1 − γ) δ² exactly.
        dd = self.dd_r * delta + top.sigma * (1.0 - top.gamma) * delta * delta
        return self.lam * dd / (np.sqrt(fm.d(top, z)) + self.sqd_r) - top.R * self.D * delta

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
        kin = (
            dn * (n + self.N_r) * self.w_r + (self.N_r * self.N_r) * (2.0 * self.zr + delta) * delta
        ) / (w * self.w_r)
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
        sqd_sum = np.sqrt(fm.d(top, za)) + np.sqrt(fm.d(top, zx))
        n_div = self.lam * d_div / sqd_sum - top.R * self.D
        n_a, n_x = self.N_r + self.delta_N(a), self.N_r + self.delta_N(x)
        w_a = self.w_r - (2.0 * self.zr + a) * a
        w_x = self.w_r - (2.0 * self.zr + x) * x
        k_div = (n_div * (n_x + n_a) * w_a + n_a * n_a * zsum) / (w_a * w_x)
        return -self.mgR * top.alpha + self.C * k_div

    def P(self, z):
        """P(z), about the reference if one is set."""
        if self.zr is None:
            return self.P_direct(z)
        if self.pole_ref:
            # 1 − z² from z itself: P_offset's −(2 z_r + δ)δ is only accurate near z_r.
            delta = z - self.zr
            dn = self.delta_N(delta)
            A = self.A_r + self.mgR * self.top.alpha * delta
            return (1.0 - z) * (1.0 + z) * A - self.C * dn * dn
        with np.errstate(divide="ignore", invalid="ignore"):
            out = (1.0 - z * z) * (self.depth_r - self.delta_V_offset(z - self.zr))
        pole = np.abs(z) == 1.0
        if np.any(pole):
            out = np.where(pole, self.P_direct(z), out)[()]
        return out

    def P_offset(self, delta):
        """P(z_r + δ) in terms of the offset δ (needs a reference)."""
        if self.pole_ref:
            w = -(2.0 * self.zr + delta) * delta
            dn = self.delta_N(delta)
            return w * (self.A_r + self.mgR * self.top.alpha * delta) - self.C * dn * dn
        w = self.w_r - (2.0 * self.zr + delta) * delta
        return w * (self.depth_r - self.delta_V_offset(delta))

    def phidot(self, z):
        """φ̇(z) = N(z)/(R I1 (1 − z²) √d(z)) (docs/theory/mett.md#the-main-equation)."""
        top = self.top
        return self.N(z) / (top.R * top.I1 * (1.0 - z * z) * np.sqrt(fm.d(top, z)))


def _well(top: TippeTop, E: float, D: float, lam: float) -> _Wells:
    """The wells of one element (float attributes)."""
    return _Wells(top, float(E), float(D), float(lam))


def _set_reference_one(w: _Wells, zr: float) -> None:
    """Reference one element's P to z_r where an expansion helps, else leave P direct.

    A pole where N vanishes is a pole reference; a pole where it does not, or a well within a few
    ulps of a pole (a vanishing spin's wall), gets none: an expansion about it is meaningless, and
    P needs none (nothing large cancels when N is that small).
    """
    if abs(zr) == 1.0 and w.n_vanishes(zr):
        w.set_reference(zr, True)
    elif 1.0 - zr * zr > 64.0 * _EPS:
        w.set_reference(zr, False)
        if 1.0 - abs(zr) < _NEAR_POLE:
            # next to a pole the z form's depth Ẽ − V(z_r) keeps only ~ε of the energy terms
            # (1e-18 J for the thesis body), more than a band's whole depth at low spin; the
            # pole form (exact A_p, N_p) has terms of the size of the well itself
            p = math.copysign(1.0, zr)
            u = 1.0 - p * zr  # exact (Sterbenz)
            w.depth_r = float(_PoleForm(w, p, at_pole=False).P(u)) / (u * (2.0 - u))
    else:
        w.zr, w.pole_ref = None, False


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


def _grid_minima(cr):
    """Minima of V seen in (k, grid) samples of :meth:`_Wells.critical` on ``_Z_GRID``.

    Returns (change, hi, lo): ``change[:, i]`` a sign change − → + (a minimum in
    (zs[i], zs[i + 1]]), ``hi``/``lo`` V decreasing into the pole z = 1/−1 (possible only where N
    vanishes there: a stable spin).
    """
    neg = cr < 0.0
    change = neg[:, :-1] & (cr[:, 1:] >= 0.0)
    hi = (cr[:, -1] <= 0.0) & neg[:, -2]
    lo = (cr[:, 0] >= 0.0) & (cr[:, 1] > 0.0)
    return change, hi, lo


def _refine_minima(critical, i, cr_next) -> tuple[np.ndarray, np.ndarray]:
    """(z, ok): the minimum in (zs[i], zs[i + 1]] of each interval ``i``.

    The grid point zs[i + 1] where the sampled value ``cr_next`` there is 0, else the root of
    ``critical(x, j)`` (intervals j) by :func:`_brentq`; ok False where it has no sign change.
    """
    zs = _Z_GRID
    z, ok = np.full(i.size, np.nan), np.ones(i.size, dtype=bool)
    grid = cr_next == 0.0
    z[grid] = zs[i[grid] + 1]
    k = np.flatnonzero(~grid)
    z[k], ok[k] = _brentq(lambda x, j: critical(x, k[j]), zs[i[k]], zs[i[k] + 1])
    return z, ok


def _settle_at_poles(zm, vanishes):
    """Minima found at or next to a pole, put where they are (in place; NaN entries are skipped).

    A root at a pole where N does not vanish is really a hair inside (V = +inf there); one within
    a few ulps of a pole where N vanishes is the pole itself. ``vanishes(k, z)``: whether N of the
    elements ``k`` vanishes at z.
    """
    k = np.flatnonzero(np.abs(zm) == 1.0)
    if k.size:
        hair = ~vanishes(k, zm[k])
        zm[k[hair]] = np.nextafter(zm[k[hair]], 0.0)
    k = np.flatnonzero((np.abs(zm) < 1.0) & (1.0 - np.abs(zm) <= 64.0 * _EPS))
    if k.size:
        poles = np.copysign(1.0, zm[k])
        snap = vanishes(k, poles)
        zm[k[snap]] = poles[snap]
    return zm


def _wells(w: _Wells) -> list[float]:
    """Positions of the local minima of V on [−1, 1] for one element (float attributes)."""
    cr = w.critical(_Z_GRID)[None, :]
    change, hi, lo = _grid_minima(cr)
    i = np.flatnonzero(change[0])
    z, _ = _refine_minima(lambda x, j: w.critical(x), i, cr[0, i + 1])
    mins = [*z, *([1.0] if hi[0] else []), *([-1.0] if lo[0] else [])]
    mins = _settle_at_poles(np.array(mins), lambda k, z: w.n_vanishes(z))
    return sorted({float(z) for z in mins})


def conditioning(top: TippeTop, E, D, lam, depth):
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


_NEAR_POLE = 1e-6  # wells closer than this to a pole (in z) are classified in the pole form


def _near_pole_well(w: _Wells, zm: float) -> bool:
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
    return optimize.brentq(P, lo, hi, xtol=1e-300, rtol=4 * _EPS, maxiter=_MAXITER)


def _interior_u(form: _PoleForm, u_hint: float) -> tuple[float, float]:
    """(u, P(u)/(u(2 − u))): the largest excess Ẽ − V on a log grid of u up to 1e-7 and at u_hint."""
    u = np.concatenate([np.logspace(-320, -7, 628), [u_hint] if 0.0 < u_hint < 2.0 else []])
    u = u[u > 0.0]
    with np.errstate(all="ignore"):
        e = form.P(u) / (u * (2.0 - u))
    e[~np.isfinite(e)] = -np.inf
    k = int(np.argmax(e))
    return float(u[k]), float(e[k])


def _pole_band(w: _Wells, zm: float) -> Band:
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
        z_far = p * (
            1.0 - optimize.brentq(form.P, lo, hi, xtol=1e-300, rtol=4 * _EPS, maxiter=_MAXITER)
        )
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


# A band with an end closer than this fraction of its half-width to a pole (or at the pole) is
# integrated about that pole (:func:`_anchored_quadrature`).
_POLE_LAYER = 1e-3
_POLE_ABS = 1e-8  # ... or closer than this in z (a few ulps of z would be ≳1e-8 of the gap)


def _pole_layer(b: Band) -> tuple[bool, bool]:
    """Whether each end of the band lies in the layer of a pole (see :func:`_layer_ends`)."""
    if b.kind != "nutation":  # steady (or no) motion: no band, no layer
        return False, False
    low, high = _layer_ends(np.float64(b.z_low), np.float64(b.z_high))
    return bool(low), bool(high)


def _layer_ends(z_low, z_high):
    """Whether each end of nutation bands [z_low, z_high] lies in the layer of a pole: its gap to
    the nearer pole is below ``_POLE_LAYER`` of the band's half-width (0 included: an end at the
    pole), or below ``_POLE_ABS``.

    Next to a pole where N does not vanish the end sits against a steep wall of V (R changes by
    O(1) over the gap, which a Gauss rule over the whole band cannot resolve); an end at or a hair
    off an unstable pole is the logarithmic layer of the separatrix; and in z the gap itself may be
    below one ulp of z. All such bands are integrated in the distance u = 1 ∓ z from that pole.
    """
    h = 0.5 * (z_high - z_low)
    gap = np.maximum(_POLE_LAYER * h, _POLE_ABS)
    band = h >= 0.0
    return band & (1.0 - np.abs(z_low) < gap), band & (1.0 - np.abs(z_high) < gap)


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


@functools.lru_cache(maxsize=1024)
def _pole_constants(top: TippeTop, E: float, D: float, lam: float, pole: float):
    """(A_p, N(p), √d(p), d'(p)) for one element, A_p and N(p) correctly rounded (exact rationals;
    cached: the pole form of one element is built several times on the per-element path)."""
    A = _shift_fraction(top, E, D, lam, pole)
    return (
        A,
        _pole_N(top, D, lam, pole),
        math.sqrt(float(fm.d(top, pole))),
        float(fm.dd_dz(top, pole)),
    )


class _PoleForm:
    """P and φ̇ in the distance u = 1 − p z from the pole p = ±1, without cancellation near it.

    1 − z² = u(2 − u), E' − m g R(1 − αz) = A_p − m g R α p u with A_p = E' − m g R(1 − αp)
    formed exactly (:func:`_shift`), and N(z) = N_p + (z − p) N[p, z] with the divided difference
    N[p, z] = λ(d'(p) + σ(1 − γ)(z − p))/(√d(z) + √d(p)) − R D (d is quadratic), z − p = −p u:

        P(u) = u(2 − u)(A_p − m g R α p u) − C (N_p − p u N[p, z])².

    With ``at_pole`` (a band ending at the pole, a steady spin there) ``N_p`` is set to 0 where N
    vanishes at the pole to rounding.
    """

    def __init__(self, w: _Wells, pole: float, at_pole: bool = True) -> None:
        top = w.top
        self.w, self.p = w, pole
        self.A, n_p, self.sqd_p, self.dd_p = _pole_constants(top, w.E, w.D, w.lam, pole)
        # N_p is 0 for a band ending at the pole (it vanishes there to rounding); a turning point
        # a hair off the pole needs its exact small value, unless C N_p² is within 52 bits of
        # underflow (|N_p| below ~1e-150): P next to the wall is then not resolved in double
        self.N_p = n_p
        if (at_pole and w.n_vanishes(pole)) or w.C * n_p * n_p < _TINY / _EPS:
            self.N_p = 0.0

    def z(self, u):
        return self.p * (1.0 - u)

    def n_div(self, u):
        """N[p, z] (see the class docstring)."""
        top, w = self.w.top, self.w
        zp = -self.p * u
        sqd = np.sqrt(fm.d(top, np.clip(self.z(u), -1.0, 1.0)))
        num = self.dd_p + top.sigma * (1.0 - top.gamma) * zp
        return w.lam * num / (sqd + self.sqd_p) - top.R * w.D

    def P(self, u):
        w = self.w
        n = self.N_p - self.p * u * self.n_div(u)
        return u * (2.0 - u) * (self.A - w.mgR * w.top.alpha * self.p * u) - w.C * n * n

    def phidot(self, u):
        """φ̇ = N/(R I1 (1 − z²)√d(z)) = N_p/(R I1 u(2 − u)√d) − p N[p, z]/(R I1 (2 − u)√d)."""
        top = self.w.top
        sqd = np.sqrt(fm.d(top, np.clip(self.z(u), -1.0, 1.0)))
        k = top.R * top.I1 * (2.0 - u) * sqd
        return self.N_p / (k * u) - self.p * self.n_div(u) / k

    def phidot_limit(self) -> float:
        """lim φ̇ at the pole where N vanishes: −p N'(p)/(2 R I1 √d(p)) (N'(p) = N[p, p])."""
        top = self.w.top
        n1 = float(self.n_div(0.0))
        return -self.p * n1 / (2.0 * top.R * top.I1 * self.sqd_p)

    def _nu_derivatives(self, u):
        """(ν, dν/dz, d²ν/dz²) of ν = N[p, z] = λ L/S − R D at z = p(1 − u), with
        L = d'(p) + σ(1 − γ)(z − p) (d is quadratic) and S = √d(z) + √d(p)."""
        top, w = self.w.top, self.w
        z = np.clip(self.p * (1.0 - u), -1.0, 1.0)
        dz = fm.d(top, z)
        sq = np.sqrt(dz)
        d1 = fm.dd_dz(top, z)
        d2 = 2.0 * top.sigma * (1.0 - top.gamma)
        L = self.dd_p + top.sigma * (1.0 - top.gamma) * (-self.p * u)
        L1 = 0.5 * d2
        S = sq + self.sqd_p
        S1 = d1 / (2.0 * sq)
        S2 = (2.0 * d2 * dz - d1 * d1) / (4.0 * dz * sq)
        nu = w.lam * L / S - top.R * w.D
        nu1 = w.lam * (L1 * S - L * S1) / (S * S)
        nu2 = w.lam * (
            -2.0 * L1 * S1 / (S * S) - L * S2 / (S * S) + 2.0 * L * S1 * S1 / (S * S * S)
        )
        return nu, nu1, nu2

    def _dV(self, u, second: bool = False):
        """dV/du (or d²V/du²) at u, in the pole form (u = 1 − p z, so d²V/du² = d²V/dz²).

        V = m g R(1 − αp(1 − u)) + K + const, K/C = N_p²/q + 2 N_p m r + m² u r with q = u(2 − u),
        r = 1/(2 − u) and m(u) = −p ν (N = N_p + u m): the three parts are differentiated apart,
        so the large 1/u² terms of N_p never cancel against the others (exact when N_p = 0).
        """
        nu, nu1, nu2 = self._nu_derivatives(u)
        m, m1, m2 = -self.p * nu, nu1, -self.p * nu2  # d/du = −p d/dz
        r = 1.0 / (2.0 - u)
        s = u * r
        q1 = 2.0 - 2.0 * u
        with np.errstate(all="ignore"):
            return self._dV_terms(u, second, m, m1, m2, r, s, q1)

    def _dV_terms(self, u, second, m, m1, m2, r, s, q1):
        """The sums of :meth:`_dV` (K differentiated term by term)."""
        w = self.w
        ratio = 0.0 if self.N_p == 0.0 else self.N_p / (u * (2.0 - u))  # N_p/q
        if not second:
            k = -ratio * ratio * q1 + 2.0 * self.N_p * (m1 * r + m * r * r)
            k += 2.0 * m * m1 * s + 2.0 * m * m * r * r
            return w.mgR * w.top.alpha * self.p + w.C * k
        q = u * (2.0 - u)
        k = 0.0 if self.N_p == 0.0 else ratio * ratio * (2.0 * q1 * q1 + 2.0 * q) / q
        k += 2.0 * self.N_p * (m2 * r + 2.0 * m1 * r * r + 2.0 * m * r * r * r)
        k += (2.0 * m1 * m1 + 2.0 * m * m2) * s + 8.0 * m * m1 * r * r + 4.0 * m * m * r * r * r
        return w.C * k

    def steady(self, u_hint: float) -> tuple[float, float, float]:
        """(u_m, ω², φ̇) of steady precession at the bottom u_m of the well next to the pole.

        u_m is the root of dV/du (solved in u to full relative precision, also far below one ulp
        of z); the small-oscillation limit of the period is 2π/ω with ω² = (1 − z²) V''/(2 g)
        there. At the pole itself (N_p = 0, V rising away from it with slope s = dV/du(0) > 0)
        u̇² ≈ 2u(ε − s u)/g, so u = x² with x harmonic at √(s/(2g)) and u at twice that:
        ω² = 2 s/g(p). That is the limit of the interior formula as N_p → 0 (u_m ∝ |N_p|,
        V'' ≈ 2 s/u_m, 1 − z² ≈ 2 u_m), so both are one continuous branch.
        φ̇ is φ̇(u_m), at the pole the limit :meth:`phidot_limit` (the mean of its two sides).
        """
        top = self.w.top
        g_p = float(fm.g(top, self.p))
        if self.N_p == 0.0:
            s = float(self._dV(0.0))
            if s > 0.0:
                return 0.0, 2.0 * s / g_p, self.phidot_limit()
        # a sign change − → + of dV/du: bracket it on a log grid of u, nearest the hint
        grid = np.logspace(-320, -0.5, 960)
        vals = self._dV(grid)
        up = np.flatnonzero((vals[:-1] < 0.0) & (vals[1:] >= 0.0))
        if up.size == 0:
            return math.nan, math.nan, math.nan
        i = up[0]
        if u_hint > 0.0:
            i = up[np.argmin(np.abs(np.log(grid[up]) - math.log(u_hint)))]
        u_m = optimize.brentq(
            lambda x: float(self._dV(x)),
            float(grid[i]),
            float(grid[i + 1]),
            xtol=1e-300,
            rtol=4 * _EPS,
        )
        z = self.p * (1.0 - u_m)
        curv = float(self._dV(u_m, second=True))
        omega2 = u_m * (2.0 - u_m) * curv / (2.0 * float(fm.g(top, z)))
        return u_m, omega2, float(self.phidot(u_m))

    def root(self, u_guess: float, u_in: float) -> float:
        """The turning point u_t near ``u_guess`` (P(u_in) > 0), solved in u to full relative precision."""
        if u_guess <= 0.0:
            return 0.0
        inward = 1.0 if u_in > u_guess else -1.0
        step: float = 4.0 * _EPS * (1.0 + u_guess) + 1e-6 * u_guess
        for _ in range(60):
            a = u_guess - inward * step
            b = u_guess + inward * step
            if inward > 0.0:
                a = max(a, 0.0)
                b = min(b, u_in)
            else:
                a, b = min(a, 2.0), max(b, u_in)
            pa, pb = float(self.P(a)), float(self.P(b))
            if a == 0.0 and pa == 0.0 < pb:
                # P(0) = 0 (N_p = 0): the pole is a root too; the turning point is the root
                # between (P < 0 just off the pole, A_p < 0) or the pole itself (P > 0 down to it)
                x = b
                while x > 1e-300 and float(self.P(x)) > 0.0:
                    x /= 16.0
                if not float(self.P(x)) < 0.0:
                    return 0.0
                a, pa = x, float(self.P(x))
            if pa <= 0.0 < pb:
                lo, hi = min(a, b), max(a, b)
                return optimize.brentq(self.P, lo, hi, xtol=1e-300, rtol=4 * _EPS, maxiter=_MAXITER)
            step *= 4.0
        return u_guess


_CHUNK = 512  # elements per block of the well search: keeps the (block × 401) grid in cache


def _locate_wells(W: _Wells) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_wells` for every element: (z_min, single), single False where V has not one well.

    Elements with several minima (or none) are left to the per-element path.
    """
    n = W.E.size
    first = np.zeros(n, dtype=np.intp)
    count = np.zeros(n, dtype=np.intp)
    cr_next = np.zeros(n)
    pole_hi, pole_lo = np.zeros(n, dtype=bool), np.zeros(n, dtype=bool)
    for start in range(0, n, _CHUNK):
        blk = slice(start, min(start + _CHUNK, n))
        cr = W.sub(blk).col().critical(_Z_GRID)
        change, hi, lo = _grid_minima(cr)
        i = np.argmax(change, axis=1)
        # a root exactly at z = 1 and the pole minimum there are one minimum (the set in _wells)
        twice = hi & change[:, -1] & (cr[:, -1] == 0.0)
        count[blk] = change.sum(axis=1) + hi + lo - twice
        first[blk] = i
        cr_next[blk] = cr[np.arange(cr.shape[0]), i + 1]
        pole_hi[blk], pole_lo[blk] = hi, lo
    single = count == 1
    zm = np.full(n, np.nan)
    zm[single & pole_hi] = 1.0
    zm[single & pole_lo] = -1.0
    k = np.flatnonzero(single & ~pole_hi & ~pole_lo)
    zm[k], ok = _refine_minima(lambda x, j: W.sub(k[j]).critical(x), first[k], cr_next[k])
    single[k[~ok]] = False
    zm[k[~ok]] = np.nan
    _settle_at_poles(zm, lambda j, z: W.sub(j).n_vanishes(z))
    return zm, single
