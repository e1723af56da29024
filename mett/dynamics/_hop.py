"""Compiled kernels of a flight (:mod:`.flight`): the gap of the lowest point of the sphere and
the touchdown march, as numba functions.

A run with hundreds of hops spent most of its time in the Python of these few lines (a
polynomial root per march step, a gap per sample). The arithmetic is that of
:meth:`mett.dynamics.flight.Hop.gap` and :meth:`~mett.dynamics.flight.Hop.touchdown` (their
docstrings derive it, docs/theory/flight.md), which stay the Python reference the tests compare
these kernels with. Imported by :mod:`.flight` at the first flight only: ``import mett`` does
not import numba.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from .._numba_cache import install as _check_numba_cache

_check_numba_cache()  # a damaged numba cache file of mett is a miss, not an error

__all__ = ["first_root", "flight_steps", "gap", "gaps", "touchdown", "viscous_impulse"]

_EPS = float(np.finfo(float).eps)


@numba.njit(cache=True, inline="always")
def _sin_minus(x: float) -> float:
    """sin x − x without cancellation for small |x| (as :func:`mett.dynamics.flight._sin_minus`)."""
    if abs(x) > 0.1:
        return math.sin(x) - x
    x2 = x * x
    return (
        -x
        * x2
        / 6.0
        * (1.0 - x2 / 20.0 * (1.0 - x2 / 42.0 * (1.0 - x2 / 72.0 * (1.0 - x2 / 110.0))))
    )


@numba.njit(cache=True)
def gap(
    h0: float, hd0: float, g: float, l: float, W: float, uz: float, vz: float, tau: float
) -> tuple[float, float, float, float]:
    """(h, ḣ, ḧ, h⃛) of the gap at ``tau`` (s): m, m/s, m/s², m/s³ (:meth:`Hop.gap`'s formula;
    ``W`` = Ω the axis' rotation rate about L, ``uz``, ``vz`` the z-parts of u and L̂ × u)."""
    w = W * tau
    c, s = math.cos(w), math.sin(w)
    sh = math.sin(0.5 * w)
    h = h0 + hd0 * tau - 0.5 * g * tau * tau + l * (-2.0 * uz * sh**2 + vz * _sin_minus(w))
    h1 = hd0 - g * tau + l * W * (-uz * s - 2.0 * vz * sh**2)
    h2 = -g - l * W * W * (uz * c + vz * s)
    h3 = l * W**3 * (uz * s - vz * c)
    return h, h1, h2, h3


@numba.njit(cache=True)
def gaps(
    h0: float, hd0: float, g: float, l: float, W: float, uz: float, vz: float, taus: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(h, ḣ) at each of ``taus`` (s)."""
    n = taus.size
    h, h1 = np.empty(n), np.empty(n)
    for i in range(n):
        h[i], h1[i], _, _ = gap(h0, hd0, g, l, W, uz, vz, taus[i])
    return h, h1


@numba.njit(cache=True)
def _polyval(c: np.ndarray, x: float) -> float:
    y = 0.0
    for ci in c:
        y = y * x + ci
    return y


@numba.njit(cache=True)
def _bisect(c: np.ndarray, a: float, b: float) -> float:
    """The root of the polynomial ``c`` in (a, b], where it is monotone with c(a) ≠ 0 and
    c(b) of the other sign or 0: bisection to the last bit."""
    fa = _polyval(c, a)
    if _polyval(c, b) == 0.0:
        return b
    for _ in range(2100):
        m = 0.5 * (a + b)
        if not a < m < b:
            break
        fm = _polyval(c, m)
        if fm == 0.0:
            return m
        if (fm > 0.0) == (fa > 0.0):
            a, fa = m, fm
        else:
            b = m
    return b


@numba.njit(cache=True)
def _roots_in(c: np.ndarray, hi: float) -> np.ndarray:
    """The real roots of the polynomial ``c`` (highest degree first, c[0] ≠ 0) in (0, hi],
    ascending: those of its derivatives first, lowest degree up (each derivative's roots split
    (0, hi] into pieces where the polynomial above it is monotone: one bisection per piece whose
    ends differ in sign). No eigenvalues: a few µs, and quick to compile."""
    n = c.size - 1
    roots = np.empty(0)
    for deg in range(1, n + 1):  # the (n − deg)-th derivative of c, of degree deg
        d = np.empty(deg + 1)
        for i in range(deg + 1):
            f = 1.0
            for r in range(n - deg):
                f *= n - i - r
            d[i] = c[i] * f
        ends = np.empty(roots.size + 2)
        ends[0] = 0.0
        ends[1 : roots.size + 1] = roots
        ends[-1] = hi
        found = np.empty(roots.size + 1)
        k = 0
        for j in range(ends.size - 1):
            a, b = ends[j], ends[j + 1]
            if not b > a:
                continue
            fa, fb = _polyval(d, a), _polyval(d, b)
            if fb == 0.0 or (fa != 0.0 and (fa > 0.0) != (fb > 0.0)):
                x = _bisect(d, a, b) if fa != 0.0 else b
                if x > 0.0 and (k == 0 or x > found[k - 1]):
                    found[k] = x
                    k += 1
        roots = found[:k].copy()
    return roots


@numba.njit(cache=True)
def first_root(coeffs: np.ndarray) -> float:
    """The smallest positive real root of the polynomial ``coeffs`` (highest degree first, its
    constant term > 0), taken from below; NaN if it has none (as
    :func:`mett.dynamics.flight._first_root`, which returns None and finds it with np.roots:
    here the roots are isolated between those of the derivatives, :func:`_roots_in`)."""
    k = 0
    while k < coeffs.size and coeffs[k] == 0.0:
        k += 1
    c = coeffs[k:]
    if c.size <= 1:
        return math.nan
    # Cauchy's bound: every root has |x| < 1 + max |c_i / c_0|
    bound = 0.0
    for i in range(1, c.size):
        bound = max(bound, abs(c[i] / c[0]))
    roots = _roots_in(c, 1.0 + bound)
    if roots.size == 0:
        return math.nan
    return roots[0] * (1.0 - 64.0 * _EPS)  # from below: the bound stays positive on [0, s)


@numba.njit(cache=True)
def touchdown(
    h0: float,
    hd0: float,
    g: float,
    l: float,
    W: float,
    uz: float,
    vz: float,
    M4: float,
    t0: float,
    tau_max: float,
) -> float:
    """The first root τ ∈ (0, tau_max] of the gap (s after ``t0``): 0.0 for a hop of zero
    length, NaN if there is none, −1.0 if the march did not converge (:meth:`Hop.touchdown`)."""
    h, h1, h2, h3 = gap(h0, hd0, g, l, W, uz, vz, 0.0)
    tau = 0.0
    if h <= 0.0:  # on the table: h(s) ≥ s (ḣ + ḧ s/2 + h⃛ s²/6 − M4 s³/24)
        s = math.nan
        if h1 > 0.0:
            s = first_root(np.array([-M4 / 24.0, h3 / 6.0, 0.5 * h2, h1]))
        elif h1 < 0.0:
            return 0.0
        else:  # a lift-off: h = ḣ = 0, h ≥ s² (c2 + c3 s − M4 s²/24)
            c2, c3 = 0.5 * h2, h3 / 6.0
            if c2 <= 0.0 and c3 <= 0.0:
                return 0.0
            if c3 > 0.0 and c2 < 0.0:
                tau = -2.0 * c2 / c3
            s = first_root(np.array([-M4 / 24.0, c3, max(c2, 0.0)])) if tau == 0.0 else 0.0
        tau = tau + (tau_max if math.isnan(s) else s)
    t_res = 4.0 * _EPS * max(abs(t0), 1.0)
    for _ in range(1_000_000):
        if tau >= tau_max:
            return math.nan
        h, h1, h2, h3 = gap(h0, hd0, g, l, W, uz, vz, tau)
        if h <= 0.0 and h1 > 0.0:  # a rounding-level zero of a rising gap (the end of a
            # lift-off's dip): not a touchdown; step on h ≥ s (ḣ + ḧ s/2 + h⃛ s²/6 − M4 s³/24)
            s = first_root(np.array([-M4 / 24.0, h3 / 6.0, 0.5 * h2, h1]))
        elif h <= 0.0:
            return tau
        else:
            s = first_root(np.array([-M4 / 24.0, h3 / 6.0, 0.5 * h2, h1, h]))
        if math.isnan(s):  # h > 0 for ever (no gravity and no wobble)
            return math.nan
        if s <= t_res:
            return tau + s
        tau += s
    return -1.0


@numba.njit(cache=True)
def _phi_psi(x: float) -> tuple[float, float]:
    """φ(x) = (1 − e^{−x})/x and ψ(x) = (x − 1 + e^{−x})/x² for x ≥ 0 (φ(0) = 1, ψ(0) = 1/2):
    their series Σ (−x)ⁿ/(n+1)!, Σ (−x)ⁿ/(n+2)! below x = 1/2 (22 terms: truncation below
    (1/2)²²/22! ≈ 2e-28), where the closed forms cancel."""
    if x < 0.5:
        phi, psi, term = 0.0, 0.0, 1.0
        for n in range(22):  # term = (−x)ⁿ/n!
            phi += term / (n + 1)
            psi += term / ((n + 1) * (n + 2))
            term = term * -x / (n + 1)
        return phi, psi
    em = -math.expm1(-x)  # 1 − e^{−x}
    return em / x, (x - em) / (x * x)


@numba.njit(cache=True)
def _impulse_at(p: float, mu: float, k0: float, k1: float, a0: float, a1: float, b0: float,
                b1: float) -> tuple[float, float]:  # fmt: skip
    """P_t(p) in the eigenbasis of W_tt (:func:`viscous_impulse`)."""
    f0, s0 = _phi_psi(k0 * p)
    f1, s1 = _phi_psi(k1 * p)
    return -mu * (p * f0 * a0 + p * p * s0 * b0), -mu * (p * f1 * a1 + p * p * s1 * b1)


@numba.njit(cache=True)
def viscous_impulse(v0: np.ndarray, W: np.ndarray, mu: float, scan_points: int) -> np.ndarray:
    """The closed-form Darboux–Keller impulse of the viscous law (the formulas and the scan are
    :func:`mett.dynamics.flight.viscous_impulse`'s docstring): P (N s), or NaNs if no end of
    compression is found."""
    # eigenbasis of the symmetric 2×2 W_tt: Q = [[c, −s], [s, c]]
    A, B, C = W[0, 0], W[0, 1], W[1, 1]
    th = 0.5 * math.atan2(2.0 * B, A - C)
    c, s = math.cos(th), math.sin(th)
    l0 = c * c * A + 2.0 * c * s * B + s * s * C
    l1 = s * s * A - 2.0 * c * s * B + c * c * C
    k0, k1 = mu * max(l0, 0.0), mu * max(l1, 0.0)
    a0, a1 = c * v0[0] + s * v0[1], -s * v0[0] + c * v0[1]
    b0, b1 = c * W[0, 2] + s * W[1, 2], -s * W[0, 2] + c * W[1, 2]
    w0, w1 = W[2, 0] * c + W[2, 1] * s, -W[2, 0] * s + W[2, 1] * c
    out = np.full(3, math.nan)

    def vz(p: float) -> float:  # a closure: numba inlines it
        q0, q1 = _impulse_at(p, mu, k0, k1, a0, a1, b0, b1)
        return v0[2] + w0 * q0 + w1 * q1 + W[2, 2] * p

    p_hi = 10.0 * -v0[2] / W[2, 2]
    found = False
    for _ in range(40):  # v_z grows once the slip has relaxed: an upper end where v_z > 0
        if vz(p_hi) > 0.0:
            found = True
            break
        p_hi *= 10.0
    if not found:
        return out
    k_max, k_min = max(k0, k1), min(k0, k1)
    p_relax = min(p_hi, 40.0 / k_min) if k_min > 0.0 else p_hi
    n = 2
    if k_max > 0.0:
        n = int(min(scan_points, max(2.0, math.ceil(4.0 * k_max * p_relax))))
    lo, hi = p_relax, p_hi
    prev = 0.0
    for j in range(1, n + 1):  # the first step of the scan where v_z is > 0
        pj = p_relax * j / n
        if vz(pj) > 0.0:
            lo, hi = prev, pj
            break
        prev = pj
    # bisection to the last bit: v_z(lo) ≤ 0 < v_z(hi)
    for _ in range(2000):
        mid = 0.5 * (lo + hi)
        if not lo < mid < hi:
            break
        if vz(mid) > 0.0:
            hi = mid
        else:
            lo = mid
    q0, q1 = _impulse_at(hi, mu, k0, k1, a0, a1, b0, b1)
    out[0], out[1], out[2] = c * q0 - s * q1, s * q0 + c * q1, hi
    return out


@numba.njit(cache=True)
def flight_steps(
    taus: np.ndarray,
    r0: np.ndarray,
    V: np.ndarray,
    L: np.ndarray,
    e_par: np.ndarray,
    u: np.ndarray,
    v: np.ndarray,
    Omega: float,
    cos_c: np.ndarray,
    sin_c: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """The gliding-layout states G (10, n + 1) of a flight at the breakpoints ``taus`` (s after
    its start) and the Taylor coefficients of degree ≥ 1 of its axis on each step, A (n, 3, K−1):
    3̂(τ_i + s) = e∥ + u_i cos Ωs + v_i sin Ωs with u_i = u cos Ωτ_i + v sin Ωτ_i and v_i its
    quarter turn, whose coefficients are u_i cos_c[k] + v_i sin_c[k] (:meth:`Hop.dense`)."""
    n = taus.size - 1
    K = cos_c.size
    G = np.empty((10, n + 1))
    A = np.empty((max(n, 0), 3, K - 1))
    for i in range(n + 1):
        tau = taus[i]
        w = Omega * tau
        c, s = math.cos(w), math.sin(w)
        G[0, i] = r0[0] + V[0] * tau
        G[1, i] = r0[1] + V[1] * tau
        G[2, i], G[3, i] = V[0], V[1]
        for j in range(3):
            G[4 + j, i] = L[j]
            G[7 + j, i] = e_par[j] * 1.0 + u[j] * c + v[j] * s
        if i < n:
            for j in range(3):
                ui = u[j] * c + v[j] * s
                vi = -u[j] * s + v[j] * c
                for k in range(1, K):
                    A[i, j, k - 1] = ui * cos_c[k] + vi * sin_c[k]
    return G, A
