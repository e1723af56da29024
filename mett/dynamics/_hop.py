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

__all__ = ["first_root", "gap", "gaps", "touchdown"]

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
def first_root(coeffs: np.ndarray) -> float:
    """The smallest positive real root of the polynomial ``coeffs`` (highest degree first, its
    constant term > 0), Newton-polished and taken from below; NaN if it has none (as
    :func:`mett.dynamics.flight._first_root`, which returns None)."""
    k = 0
    while k < coeffs.size and coeffs[k] == 0.0:
        k += 1
    c = coeffs[k:]
    if c.size <= 1:
        return math.nan
    roots = np.roots(c.astype(np.complex128))  # complex: numba's real eigvals refuses complex roots
    s = math.inf
    for r in roots:
        if abs(r.imag) <= 1e-9 * abs(r) and r.real > 0.0 and r.real < s:
            s = r.real
    if s == math.inf:
        return math.nan
    n = c.size - 1
    dc = np.empty(n)
    for j in range(n):
        dc[j] = c[j] * (n - j)
    for _ in range(3):
        d = _polyval(dc, s)
        if d == 0.0:
            break
        s_new = s - _polyval(c, s) / d
        if not 0.0 < s_new < 2.0 * s:
            break
        s = s_new
    return s * (1.0 - 64.0 * _EPS)  # from below: the bound stays positive on [0, s)


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
        if h <= 0.0:
            return tau
        s = first_root(np.array([-M4 / 24.0, h3 / 6.0, 0.5 * h2, h1, h]))
        if math.isnan(s):  # h > 0 for ever (no gravity and no wobble)
            return math.nan
        if s <= t_res:
            return tau + s
        tau += s
    return -1.0
