"""Root finding: a vectorised transcription of scipy's brentq (:func:`_brentq`) and the turning
points of P, in z and as offsets from the bottom of the well, for arrays of elements (one element
is a length-1 array: :meth:`_Wells.row`).

scipy ≥ 1.15 has ``scipy.optimize.elementwise.find_root``, but it is a different algorithm
(Chandrupatla): the roots must be the ones scipy's scalar ``brentq`` gives, which the per-element
pole forms (:class:`_PoleForm`) still use, so that an element gets the same numbers whichever
path it takes; :func:`_brentq` transcribes brentq for arrays instead and is as fast.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from scipy import optimize

from ._exact import _EPS, _MAXITER

if TYPE_CHECKING:
    from ._wells import _Wells

_OFFSET_STEP = 4.0 * float(np.spacing(1.0))  # first half-width of an offset turning point's bracket
_OFFSET_TRIES = 40  # ... widened 4× per try


def _brentq(fun, a, b, *, xtol: float = 1e-300, rtol: float = 4 * _EPS, maxiter: int = _MAXITER):
    """scipy.optimize.brentq for arrays of brackets [a, b], iterate for iterate.

    ``fun(x, k)`` evaluates the function of the elements with indices ``k`` (into ``a``) at ``x``
    (an array, or a float for a single element).
    The arithmetic and the branches are those of scipy's C implementation, so each element gets
    the root scipy would return for it; converged elements drop out of the evaluations. A single
    element is handed to scipy's brentq itself (the same root, without the array overhead).

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
    if n == 1:  # one element: scipy's brentq itself, on floats, without the array bookkeeping
        ids = np.zeros(1, dtype=np.intp)
        try:
            root[0] = optimize.brentq(
                lambda x: fun(x, ids).item(),
                float(a[0]),
                float(b[0]),
                xtol=xtol,
                rtol=rtol,
                maxiter=maxiter,
                full_output=True,
                disp=False,
            )[0]
        except ValueError:  # f(a) and f(b) of the same sign
            ok[0] = False
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


def _turning_points(W: _Wells, pole: float, zm) -> tuple[np.ndarray, np.ndarray]:
    """(z, ok): the root of P between the bottom z_m of the well (P > 0) and ``pole`` (±1).

    P(±1) = −C N(±1)² < 0 unless N vanishes at the pole. Then P(pole) = 0 through its factor
    1 − z², and the pole is a turning point only if Ẽ ≥ V(pole) (the axis passes through the
    vertical); otherwise the root lies inside and is bracketed from the first float off the pole
    (or is that float: a wall within one ulp of the pole, N ≈ 0, a vanishing spin). A well at the
    other pole is stepped inside first (P vanishes there too). ok is False where P has no sign
    change between z_m and the pole.

    A root in the quarter of [pole, z_m] next to the pole is re-solved with the direct P where that
    brackets it: the expansion about the bottom of the well is accurate to ~ε·max P in absolute
    terms, while next to a pole both terms of P = (1 − z²)(E' − U) − C N² are tiny (e.g. an
    unstable inverted start θ0 = π − 1e-4 has its turning point 5e-9 from the pole); the direct
    form is accurate to ~ε of its small terms there.
    """
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
    if W.zr is not None and not W.pole_ref:
        k = k[good & _near_pole_root(root, zm[k])]
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


def _near_pole_root(z_t, z_m):
    """Turning points in the quarter of [pole, z_m] next to a pole (see :func:`_turning_points`)."""
    pole = np.copysign(1.0, z_t)
    return np.abs(z_t - pole) <= 0.25 * np.abs(z_m - pole)


def _offset_roots(W: _Wells, z_t, z_m) -> tuple[np.ndarray, np.ndarray]:
    """(offsets, is_root): turning points z_t as offsets z_t − z_r from the reference, refined on
    P_offset; is_root False for a wall next to a pole.

    z_t is a correctly rounded root of P, but at high spin ulp(z_t) is not small against the band:
    the Gauss–Legendre node next to a turning point is only ~1e-7 band widths from it, so an
    endpoint off by one ulp of z puts a relative error of ulp/(1e-7 h) into P there. (Before this,
    periods at ω3 = 3000 rad/s were off by ~1e-7 and at 3e4 rad/s by ~1e-5.) A pole reached by the
    band (N vanishes there) is a turning point exactly, and a root next to a pole solved with the
    direct P (:func:`_turning_points`) is kept: the expansion is worse there. Where no sign change
    lies next to z_t, z_t is a wall within one ulp of a pole (N ≈ 0, a vanishing spin), not a root.
    """
    x0 = z_t - W.zr
    zr = np.broadcast_to(W.zr, x0.shape)
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
        c = (np.abs(zr[k] + a) < 1.0) & ((b - x0[k]) * inward[k] < room[k])
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
