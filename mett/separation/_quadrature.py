"""The period integral T = 2∫√(g/P) dz and ∮ φ̇ dt over a band: Gauss–Legendre in u after
z = c + h sin u about the bottom of the well, and about a pole for bands in its layer.

``scipy.integrate.tanhsinh`` (scipy ≥ 1.15) is not used: after the substitutions the integrands
are smooth (analytic in a strip), so a fixed Gauss rule reaches 1e-13 with 96 nodes per element and
no error estimation or per-element iteration, which keeps the array path one batched evaluation
and bit for bit equal to the per-element path; tanhsinh's adaptivity would only be needed without
the change of variables at a pole (:func:`_anchored_half`), which makes the layer smooth instead.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np
from scipy import optimize

from .._formulas import g
from ..potential import d2V_dz2

if TYPE_CHECKING:
    from ..top import TippeTop
from ._exact import _EPS, _MAXITER
from ._roots import _offset_roots
from ._wells import Band, _interior_u, _pole_layer, _PoleForm, _root_towards, _Wells

# The weight of a band integral ∮ F dt: False (the period only), True (F = φ̇), or a callable
# F(z) -> array of shape (q, *z.shape) for q band integrals at once (the nutation average of a
# slow flow, mett.inversion).
Weight = bool | Callable[[np.ndarray], np.ndarray]


def _weight_at(weight: Weight, z, phidot):
    """F at the nodes z: φ̇ (``phidot()``, evaluated only then) or the callable's values."""
    return weight(z) if callable(weight) else phidot()


_N_QUAD = 96  # Gauss–Legendre nodes in u for periods and means
_U_NODES, _U_WEIGHTS = np.polynomial.legendre.leggauss(_N_QUAD)
_U_NODES = 0.5 * np.pi * _U_NODES
_U_WEIGHTS = 0.5 * np.pi * _U_WEIGHTS
_SIN_U, _COS_U = np.sin(_U_NODES), np.cos(_U_NODES)
_HALF = _N_QUAD // 2  # nodes u <= 0 (lower half of the band) come first


def _gauss_sum(values):
    """Σ weights · values over the last axis (the u nodes).

    Summed the same way for one element and for a row of many (numpy's pairwise sum along a
    contiguous row), so an element gets the same sum on its own as in an array.
    """
    return np.sum(values * _U_WEIGHTS, axis=-1)


_TAU_PANEL = 0.75  # width of the Gauss–Legendre panels in τ (see _anchored_half)
_TAU_NODES = np.polynomial.legendre.leggauss(20)


def _anchored_half(form: _PoleForm, u_t: float, u_s: float, weight: Weight):
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
    if weight is False:
        return T, math.nan
    if callable(weight):
        return T, (f * weight(z)) @ weights
    return T, float(np.dot(weights, f * form.phidot(u)))


def _separatrix(form: _PoleForm, exact: _PoleForm) -> bool:
    """Whether a band ending at the pole sits on the separatrix of that (unstable) pole.

    At the pole (N_p = 0) P(u)/u → 2 A_p, A_p = Ẽ − V(p): with A_p = 0 the end u = 0 is a double
    root of P, the pole an equilibrium reached in infinite time. A_p is correctly rounded
    (:func:`_shift_fraction`), so it is 0 only if Ẽ = V(p) exactly; and N(p) must vanish exactly
    too (``exact``: the pole form with the exact N(p)), or the doubles' own motion turns at a
    wall next to the pole in finite time.
    """
    return form.A == 0.0 and exact.N_p == 0.0


def _anchored_quadrature(top: TippeTop, b: Band, w: _Wells, weight: Weight) -> tuple[float, Any]:
    """(T, ∮ φ̇ dt) for a band with an end in the layer of a pole (:func:`_pole_layer`).

    Each end is written as its distance u_t from its nearer pole and re-solved there
    (:meth:`_PoleForm.root`); the band is split at its middle and each half integrated from its
    turning point by :func:`_anchored_half`. On the separatrix (an end at an unstable pole with
    Ẽ = V there) the period is infinite and ⟨φ̇⟩ is the pole's limit of φ̇ (the motion spends all
    but a vanishing fraction of its time there): (inf, that limit) is returned.

    An end at a pole where N is zero to rounding is integrated with N(±1) = 0: the ±π jump of the
    precession angle there, whose sign is that of N(±1), is left out (see
    :func:`mean_precession`); an end at a wall off the pole is integrated with the exact N(±1)
    and carries its part of the angle itself.
    """
    za, zb = b.z_low, b.z_high
    pa = 1.0 if za >= 0.0 else -1.0
    pb = 1.0 if zb >= 0.0 else -1.0
    fa = _PoleForm(w, pa, abs(za) == 1.0)
    fb = _PoleForm(w, pb, abs(zb) == 1.0)
    ua0, ub0 = 1.0 - pa * za, 1.0 - pb * zb  # exact (Sterbenz) for |z| ≥ ½
    if pa == pb:
        # both ends next to one pole: the roots about a point inside, found in u (in z the ends
        # may be a few ulps apart or even equal), both in one form of P (N_p = 0 if an end is at
        # the pole: with the exact N_p the far end's root would belong to another P, and the
        # half-band between them could hold P < 0)
        fa = fb = _PoleForm(w, pa, abs(za) == 1.0 or abs(zb) == 1.0)
        u_in = _interior_u(fa, 1.0 - pa * b.z_min)[0]
        u_lo = _root_towards(fa.P, 0.0, u_in) if float(fa.P(0.0)) < 0.0 else 0.0
        lo, hi = u_in, 2.0 * u_in
        while hi < 1.0 and float(fa.P(hi)) > 0.0:
            lo, hi = hi, 2.0 * hi
        u_hi = optimize.brentq(fa.P, lo, hi, xtol=1e-300, rtol=4 * _EPS, maxiter=_MAXITER)
        ua0, ub0 = (u_hi, u_lo) if pa > 0.0 else (u_lo, u_hi)
        us_a = us_b = 0.5 * (ua0 + ub0)
    else:
        zs = 0.5 * (za + zb)
        us_a, us_b = 1.0 - pa * zs, 1.0 - pb * zs
    T = integral = 0.0
    for form, u0, us in ((fa, ua0, us_a), (fb, ub0, us_b)):
        # an end exactly at the pole in this form of P (a band at z = ±1 whose P < 0 just off
        # the pole turns at the root u_lo > 0 found above, not at the pole)
        at_end = u0 == 0.0
        u_t, jump = (0.0, 0.0) if at_end else (form.root(u0, us), 0.0)
        if at_end:
            exact = _PoleForm(w, form.p, at_pole=False)
            if _separatrix(form, exact):
                if callable(weight):  # all the time at the pole: F there
                    return math.inf, weight(np.array([form.p]))[..., 0]
                return math.inf, form.phidot_limit()
            if exact.N_p != 0.0 and float(exact.P(us)) > 0.0:
                # N(p) zero only to rounding: the doubles' own motion turns at the root of P
                # next to the pole (P(0) = −C N_p² < 0). Its period is the exact one even within
                # a few ulps of Ẽ = V(p), where the cross term 2 C p N_p N[p, p] u of P shifts
                # the separatrix by C p N_p N[p, p] (~ulps of Ẽ, a 1/δ error of T if left out);
                # the angle it sweeps past the pole, sign(N_p) π in the limit, is the jump left
                # out of ⟨φ̇⟩ (mean_precession)
                form, u_t = exact, _root_towards(exact.P, 0.0, us)
                jump = math.copysign(math.pi, exact.N_p) if weight is True else 0.0
        t_half, i_half = _anchored_half(form, u_t, us, weight)
        T += 2.0 * t_half
        integral += 2.0 * i_half - jump
    return T, integral


def _quadrature(top: TippeTop, b: Band, w: _Wells, precession: Weight) -> tuple[float, Any]:
    """(T, ∮ φ̇ dt) over one period of one element's band (NaN without ``precession``; with a
    callable F, ∮ F dt, an array of F's q components).

    Bands in the layer of a pole: :func:`_anchored_quadrature`; with P about the bottom of the
    well: :func:`_gauss_quadrature`; without a reference (a well within a few
    ulps of a pole): the same Gauss rule in z.
    """
    if any(_pole_layer(b)):
        return _anchored_quadrature(top, b, w, precession)
    if w.zr is not None:
        T, integral = _gauss_quadrature(
            w, np.array([b.z_low]), np.array([b.z_high]), np.array([b.z_min]), precession
        )
        if integral is None:
            return float(T[0]), math.nan
        return float(T[0]), integral[..., 0] if callable(precession) else float(integral[0])
    c, h = 0.5 * (b.z_low + b.z_high), 0.5 * (b.z_high - b.z_low)
    z = c + h * _SIN_U
    integrand = h * _COS_U * np.sqrt(g(top, z) / w.P(z))
    T = 2.0 * float(_gauss_sum(integrand))
    if not precession:
        return T, math.nan
    if callable(precession):
        return T, 2.0 * _gauss_sum(integrand * precession(z))
    return T, 2.0 * float(_gauss_sum(integrand * w.phidot(z)))


# Steady wells this close to a pole (in z) are done in the pole form: V'' in z loses ~ε/(1 − |z|)
# to the cancellation in 1 − z² and in N next to a pole (2e-11 at 1 − |z| = 1e-6), the pole form
# none; its grid of u covers the whole half of [−1, 1] on that side.
_STEADY_POLE_FORM = 0.25


def _steady_values(top: TippeTop, W: _Wells, zm, quantity: str) -> np.ndarray:
    """Period or mean precession of steady precession at the bottoms z_m of the elements' wells.

    Period: the small-oscillation limit 2π/ω_θ, ω_θ² = (1 − z_m²) V''(z_m)/(2 g(z_m))
    (docs/theory/estimates.md#estimates), with V'' at the true bottom of the well. Precession:
    φ̇(z_m). A well within ``_STEADY_POLE_FORM`` of a pole is done in the pole form
    (:meth:`_PoleForm.steady`): its bottom u_m = 1 ∓ z_m is solved in u, where it may lie far below
    one ulp of z (a vanishing spin: u_m ∝ |N(±1)|), and at a spinning pole where N vanishes the
    limit ω² = 2|V'(±1)|/g(±1) and :meth:`_PoleForm.phidot_limit` are taken.
    """
    near = 1.0 - np.abs(zm) < _STEADY_POLE_FORM
    out = np.empty(zm.size)
    D, lam = np.broadcast_to(W.D, zm.shape), np.broadcast_to(W.lam, zm.shape)
    inner = ~near
    if quantity == "period":
        zi = zm[inner]
        curv = d2V_dz2(top, zi, D[inner], lam[inner])
        out[inner] = 2.0 * math.pi / np.sqrt((1.0 - zi * zi) * curv / (2.0 * g(top, zi)))
    else:
        out[inner] = W.sub(inner).phidot(zm[inner])
    for i in np.flatnonzero(near):
        w = W.element(i)
        z = float(zm[i])
        p = math.copysign(1.0, z)
        form = _PoleForm(w, p, at_pole=abs(z) == 1.0 and bool(w.n_vanishes(z)))
        _, omega2, phidot = form.steady(1.0 - p * z)
        out[i] = 2.0 * math.pi / math.sqrt(omega2) if quantity == "period" else phidot
    return out


def _gauss_quadrature(W: _Wells, z_low, z_high, z_min, precession: Weight):
    """(T, ∮ φ̇ dt or None) for every element of W (reference set), by Gauss–Legendre in u after
    z = c + h sin u.

    T = 2∫ √(g/P) dz = 2∫ √(g/R) du with R = P/((z − z_a)(z_b − z)). The nodes are placed as
    offsets x = z − z_r (see :func:`_offset_roots`) and R is formed from divided differences: since
    Ẽ = V at both turning points, P(x) = w(x)(ΔV(x_a) − ΔV(x)), so
    R = −w ΔV[x_a, x]/(x_b − x) = w ΔV[x_b, x]/(x − x_a), each node using the farther turning point.
    No node then divides two tiny numbers, which otherwise costs digits next to the turning points
    (worst at the bottom of the well, where the whole band is tiny). The divided differences need
    Ẽ = V at both ends: not at a wall next to a pole, nor where they come out non-positive
    (degenerate geometry, e.g. a wall one ulp from a pole); there h cos u √(g/P) is summed instead.
    """
    top = W.top
    x_a, root_a = _offset_roots(W, z_low, z_min)
    x_b, root_b = _offset_roots(W, z_high, z_min)
    c, h = 0.5 * (x_a + x_b), 0.5 * (x_b - x_a)
    divided = (np.abs(z_low) < 1.0) & (np.abs(z_high) < 1.0) & root_a & root_b
    divided &= not W.pole_ref
    T = np.full(z_low.shape, np.nan)
    integral = None if precession is False else [None]
    k = np.flatnonzero(divided)
    if k.size:
        Wk = W.sub(k).col()
        xa, xb = x_a[k, None], x_b[k, None]
        x = c[k, None] + h[k, None] * _SIN_U
        z = np.clip(Wk.zr + x, -1.0, 1.0)
        wx = Wk.w_r - (2.0 * Wk.zr + x) * x
        xl, xu = x[:, :_HALF], x[:, _HALF:]
        R = np.empty_like(x)
        with np.errstate(divide="ignore", invalid="ignore"):
            R[:, :_HALF] = -wx[:, :_HALF] * Wk.delta_V_divided(xa, xl) / (xb - xl)
            R[:, _HALF:] = wx[:, _HALF:] * Wk.delta_V_divided(xb, xu) / (xu - xa)
        fine = np.all(np.isfinite(R) & (R > 0.0), axis=1)
        if not fine.all():
            divided[k[~fine]] = False
            k, Wk, z, R = k[fine], Wk.sub(fine), z[fine], R[fine]
        _gauss_sums(Wk, np.sqrt(g(top, z) / R), z, k, T, integral, precession)
    k = np.flatnonzero(~divided)
    if k.size:
        Wk = W.sub(k).col()
        x = c[k, None] + h[k, None] * _SIN_U
        z = np.clip(Wk.zr + x, -1.0, 1.0)
        integrand = h[k, None] * _COS_U * np.sqrt(g(top, z) / Wk.P_offset(x))
        _gauss_sums(Wk, integrand, z, k, T, integral, precession)
    return T, None if integral is None else integral[0]


def _gauss_sums(Wk: _Wells, integrand, z, k, T, integral, weight: Weight = True) -> None:
    """T[k] = 2 Σ integrand (and integral[0][..., k] = 2 Σ integrand · F(z) unless None, F = φ̇ or
    the callable ``weight``; integral[0] is allocated on first use), in place."""
    T[k] = 2.0 * _gauss_sum(integrand)
    if integral is not None:
        sums = 2.0 * _gauss_sum(integrand * _weight_at(weight, z, lambda: Wk.phidot(z)))
        if integral[0] is None:
            integral[0] = np.full((*sums.shape[:-1], T.size), np.nan)
        integral[0][..., k] = sums
