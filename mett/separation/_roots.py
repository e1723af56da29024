"""Root finding: a vectorised transcription of scipy's brentq (:func:`_brentq`) and the turning
points of P, in z and as offsets from the bottom of the well.

scipy ≥ 1.15 has ``scipy.optimize.elementwise.find_root``, but it is a different algorithm (Chandrupatla):
the array path must give each element the root scipy's scalar ``brentq`` gives it, bit for bit, so
that the vectorised and the scalar calls agree; the transcription keeps that and is as fast.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from scipy import optimize

from ._exact import _EPS, _MAXITER

if TYPE_CHECKING:
    from ._wells import _Well, _Wells

_OFFSET_STEP = 4.0 * float(np.spacing(1.0))  # first half-width of an offset turning point's bracket
_OFFSET_TRIES = 40  # ... widened 4× per try


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
    root = optimize.brentq(w.P, lo, hi, xtol=1e-300, rtol=4 * _EPS, maxiter=_MAXITER)
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
    return optimize.brentq(w.P_direct, lo, hi, xtol=1e-300, rtol=4 * _EPS, maxiter=_MAXITER)


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
                return optimize.brentq(
                    w.P_offset, lo, hi, xtol=1e-300, rtol=4 * _EPS, maxiter=_MAXITER
                ), True
        step *= 4.0
    # No sign change next to z_t: a wall within one ulp of a pole (N ≈ 0, a vanishing spin; see
    # _turning_point), not a root of P.
    return x0, False


def _brentq(fun, a, b, *, xtol: float = 1e-300, rtol: float = 4 * _EPS, maxiter: int = _MAXITER):
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
