"""Compiled hot path of :func:`mett.predict_inversion`: the balance flow's slow path, the fast
spectra of the lift-off criterion, the nutation followed along the path, and the upright spin's
Jacobian.

Each kernel is the arithmetic of its numpy reference, written for one node at a time:

* :func:`slow_path_kernel` — :func:`mett.inversion._gyroscopic.slow_path`'s grid, rates
  (``_flow_rate_and_state``: dE/dθ by a complex step of ``balance_state``) and cumulative
  Simpson quadrature;
* :func:`spectrum` — :func:`mett.inversion._nutation._fast_spectra` at one node: the
  complex-step Jacobian of :func:`mett.dynamics.gliding.gliding_core` (the same source, compiled)
  less the rotation at φ̇, and its eigenvalues by :func:`eigvals_hessenberg_qr`;
* :func:`lift_off_kernel` — :func:`mett.inversion._nutation.lift_off_time`: the bound over both
  fast eigenvalues, then the nutation followed as :func:`mett.inversion._nutation._follow` does
  (same extrapolation, same splits), with the criterion's ratio summed node by node and the walk
  stopped at the first node past it;
* :func:`spin_jacobian_kernel` — :func:`mett.stability.spin_jacobian`'s complex steps.

The results agree with the numpy references to rounding (two backward-stable eigenvalue
algorithms, libm's and numpy's elementary functions): tests/test_inversion_nutation.py checks
the agreement and the references against independent ones (mpmath).

Only :func:`mett.predict_inversion` imports this module, at its first call: ``import mett`` does
not import numba. The machine code is cached on disk (numba's cache, checked by
:mod:`mett._numba_cache`); numba keys it on this file, and the name of every kernel carries a
hash of the model source it inlines (``gliding.py``), so an edit of either compiles it again.
"""

from __future__ import annotations

import hashlib
import math

import numba
import numpy as np

from .._numba_cache import install as _check_numba_cache
from ..dynamics import gliding as _gliding_module
from ..dynamics.gliding import gliding_core

_check_numba_cache()  # a damaged numba cache file of mett is a miss, not an error


def _source_tag() -> str:
    with open(str(_gliding_module.__file__), "rb") as fh:
        return hashlib.sha1(fh.read(), usedforsecurity=False).hexdigest()[:10]


_TAG = _source_tag()


def _njit(fn):
    """``numba.njit(cache=True)``, the cache file named after ``fn`` and the inlined model's hash."""
    fn.__qualname__ = f"{fn.__qualname__}__{_TAG}"
    return numba.njit(cache=True, error_model="numpy")(fn)


_glide = numba.njit(inline="always", error_model="numpy")(gliding_core)


def _inline(fn):
    """``numba.njit(inline="always")``: typed into its caller, no dispatcher and no cache file of
    its own (a small helper; each compiled dispatcher costs a compilation, and its callers'
    machine code is optimised again with every callee linked in)."""
    return numba.njit(inline="always", error_model="numpy")(fn)


# law codes of the kernels (mett.inversion._gyroscopic.drag_form / friction_rates)
VISCOUS, REGULARISED, COULOMB = 0, 1, 2
# the nutation's continuation (mett.inversion._nutation: CLEAR, SPLIT, DEPTH levels below)
_CLEAR, _SPLIT, _DEPTH = 0.3, 8, 3


# --- eigenvalues of a small real matrix ----------------------------------------------------------


@_inline
def balance_matrix(a):
    """Scale ``a`` in place to D⁻¹ a D, D diagonal of powers of 2, until the off-diagonal norms of
    each row and its column are comparable (EISPACK balanc, without permutations); returns D's
    diagonal. Eigenvalues are unchanged; an eigenvector x of the result is D⁻¹ v for v of ``a``."""
    n = a.shape[0]
    d = np.ones(n)
    done = False
    while not done:
        done = True
        for i in range(n):
            r = 0.0
            c = 0.0
            for j in range(n):
                if j != i:
                    c += abs(a[j, i])
                    r += abs(a[i, j])
            if c != 0.0 and r != 0.0:
                g = r / 2.0
                f = 1.0
                s = c + r
                while c < g:
                    f *= 2.0
                    c *= 4.0
                g = r * 2.0
                while c > g:
                    f /= 2.0
                    c /= 4.0
                if (c + r) / f < 0.95 * s:
                    done = False
                    d[i] *= f
                    g = 1.0 / f
                    for j in range(n):
                        a[i, j] *= g
                    for j in range(n):
                        a[j, i] *= f
    return d


@_njit
def eigvals_hessenberg_qr(a):
    """Eigenvalues (wr, wi, ok) of the real square matrix ``a`` (overwritten).

    Balancing by powers of 2, reduction to upper Hessenberg form by stabilised elementary
    similarity transformations, and the Francis double-shift QR iteration (the EISPACK routines
    balanc, elmhes and hqr; Wilkinson & Reinsch 1971, Handbook for Automatic Computation II;
    Press et al. 1992, Numerical Recipes §11.5–11.6). Backward stable like LAPACK's dgeev (which
    adds multishift and aggressive deflation, of no use at n = 8) and without its workspace
    queries and allocations. Complex pairs come out as (x + iy, x − iy). ``ok`` is False if an
    eigenvalue has not converged in 30 iterations.
    """
    n = a.shape[0]
    wr = np.zeros(n)
    wi = np.zeros(n)
    balance_matrix(a)
    # elmhes: Gaussian elimination with pivoting, column by column below the subdiagonal
    for m in range(1, n - 1):
        x = 0.0
        i = m
        for j in range(m, n):
            if abs(a[j, m - 1]) > abs(x):
                x = a[j, m - 1]
                i = j
        if i != m:
            for j in range(m - 1, n):
                a[i, j], a[m, j] = a[m, j], a[i, j]
            for j in range(n):
                a[j, i], a[j, m] = a[j, m], a[j, i]
        if x != 0.0:
            for i in range(m + 1, n):
                y = a[i, m - 1]
                if y != 0.0:
                    y /= x
                    a[i, m - 1] = y
                    for j in range(m, n):
                        a[i, j] -= y * a[m, j]
                    for j in range(n):
                        a[j, m] += y * a[j, i]
    for i in range(2, n):
        for j in range(i - 1):
            a[i, j] = 0.0
    # hqr: shifted QR on the Hessenberg matrix, deflating one or two eigenvalues at a time
    # (0-based transcription: nn is the index of the last active row)
    anorm = 0.0
    for i in range(n):
        for j in range(max(i - 1, 0), n):
            anorm += abs(a[i, j])
    nn = n - 1
    t = 0.0
    x = y = z = w = p = q = r = s = 0.0
    while nn >= 0:
        its = 0
        while True:
            l = nn
            while l >= 1:
                s = abs(a[l - 1, l - 1]) + abs(a[l, l])
                if s == 0.0:
                    s = anorm
                if abs(a[l, l - 1]) + s == s:
                    a[l, l - 1] = 0.0
                    break
                l -= 1
            x = a[nn, nn]
            if l == nn:  # one root
                wr[nn] = x + t
                wi[nn] = 0.0
                nn -= 1
                break
            y = a[nn - 1, nn - 1]
            w = a[nn, nn - 1] * a[nn - 1, nn]
            if l == nn - 1:  # two roots
                p = 0.5 * (y - x)
                q = p * p + w
                z = math.sqrt(abs(q))
                x += t
                if q >= 0.0:
                    z = p + math.copysign(z, p)
                    wr[nn - 1] = wr[nn] = x + z
                    if z != 0.0:
                        wr[nn] = x - w / z
                    wi[nn - 1] = wi[nn] = 0.0
                else:
                    wr[nn - 1] = wr[nn] = x + p
                    wi[nn - 1] = z
                    wi[nn] = -z
                nn -= 2
                break
            if its == 30:
                return wr, wi, False
            if its == 10 or its == 20:  # exceptional shift
                t += x
                for i in range(nn + 1):
                    a[i, i] -= x
                s = abs(a[nn, nn - 1]) + abs(a[nn - 1, nn - 2])
                x = y = 0.75 * s
                w = -0.4375 * s * s
            its += 1
            m = nn - 2
            while m >= l:
                z = a[m, m]
                r = x - z
                s = y - z
                p = (r * s - w) / a[m + 1, m] + a[m, m + 1]
                q = a[m + 1, m + 1] - z - r - s
                r = a[m + 2, m + 1]
                s = abs(p) + abs(q) + abs(r)
                p /= s
                q /= s
                r /= s
                if m == l:
                    break
                u = abs(a[m, m - 1]) * (abs(q) + abs(r))
                v = abs(p) * (abs(a[m - 1, m - 1]) + abs(z) + abs(a[m + 1, m + 1]))
                if u + v == v:
                    break
                m -= 1
            for i in range(m + 2, nn + 1):
                a[i, i - 2] = 0.0
                if i != m + 2:
                    a[i, i - 3] = 0.0
            k = m
            while k <= nn - 1:
                if k != m:
                    p = a[k, k - 1]
                    q = a[k + 1, k - 1]
                    r = 0.0
                    if k != nn - 1:
                        r = a[k + 2, k - 1]
                    x = abs(p) + abs(q) + abs(r)
                    if x != 0.0:
                        p /= x
                        q /= x
                        r /= x
                s = math.copysign(math.sqrt(p * p + q * q + r * r), p)
                if s != 0.0:
                    if k == m:
                        if l != m:
                            a[k, k - 1] = -a[k, k - 1]
                    else:
                        a[k, k - 1] = -s * x
                    p += s
                    x = p / s
                    y = q / s
                    z = r / s
                    q /= p
                    r /= p
                    for j in range(k, nn + 1):
                        p = a[k, j] + q * a[k + 1, j]
                        if k != nn - 1:
                            p += r * a[k + 2, j]
                            a[k + 2, j] -= p * z
                        a[k + 1, j] -= p * y
                        a[k, j] -= p * x
                    mmin = nn if nn < k + 3 else k + 3
                    for i in range(l, mmin + 1):
                        p = x * a[i, k] + y * a[i, k + 1]
                        if k != nn - 1:
                            p += z * a[i, k + 2]
                            a[i, k + 2] -= p * r
                        a[i, k + 1] -= p * q
                        a[i, k] -= p
                k += 1
            if l >= nn - 1:
                break
    return wr, wi, True


# --- the balance state and the slow path ---------------------------------------------------------


@_njit
def balance(th, lam, m, R, a, I1, I3, g):
    """:func:`mett.inversion._gyroscopic.balance_state` at one θ (float or complex)."""
    c = np.cos(th)
    s = np.sin(th)
    A = R * I1 * (1.0 - a * c)
    C = m * g * R * R * a * (a - c)
    disc = lam * lam - 4.0 * A * C
    phidot = (lam + np.sqrt(disc)) / (2.0 * A)
    omega3 = (I1 * phidot * c - m * g * R * a / phidot) / I3
    E = (
        0.5 * I1 * (phidot * phidot) * (s * s)
        + 0.5 * I3 * (omega3 * omega3)
        + m * g * R * (1.0 - a * c)
    )
    nu = R * s * (omega3 + phidot * (a - c))
    omega_n = phidot * (s * s) + omega3 * c
    return phidot, omega3, E, nu, omega_n


@_inline
def _cm_slip2(w2, b, k2, a):
    """:func:`mett.inversion._gyroscopic.cm_slip2` for one node."""
    B = b + k2 - a * w2
    root = math.sqrt(B * B + 4.0 * a * w2 * b)
    if B > 0.0:
        return 2.0 * w2 * b / (B + root)
    return (root - B) / (2.0 * a)


@_inline
def flow_rate(th, lam, top, law, mu, eps, cm_response):
    """(dθ/dt, φ̇, ω3, E, ν, ω_n) of the balance flow at one θ
    (:func:`mett.inversion._gyroscopic._flow_rate_and_state`)."""
    m, R, alpha, I1, I3, g = top[0], top[1], top[2], top[3], top[4], top[5]
    h = 1e-30
    cphi, com, cE, cnu, cwn = balance(complex(th, h), lam, m, R, alpha, I1, I3, g)
    E_th = cE.imag / h
    nu = cnu.real
    if cm_response and law != COULOMB:
        # contact_slip2 with the law's drag form (viscous: a = 0, b = 1; regularised: 1, ε²)
        ca = 0.0 if law == VISCOUS else 1.0
        cb = 1.0 if law == VISCOUS else eps * eps
        K = 1.0 + m * R**2 * (1.0 - alpha * np.cos(th)) ** 2 / I1
        k = mu * g * K / cphi.real
        nu = math.sqrt(_cm_slip2(nu * nu, cb, k * k, ca))
    gn = m * g
    if law == VISCOUS:
        P = mu * gn * nu * nu
    elif law == REGULARISED:
        P = mu * gn * nu * nu / math.sqrt(nu * nu + eps**2)
    else:
        P = mu * gn * abs(nu)
    return -P / E_th, cphi.real, com.real, cE.real, cnu.real, cwn.real


@_njit
def slow_path_kernel(ends, steps, lam, top, law, mu, eps, cm_response):
    """The nodes, times and balance states of :func:`mett.inversion._gyroscopic.slow_path`.

    ``ends``: the segment ends in s = ln tan(θ/2); ``steps``: each segment's (even) number of
    steps. Returns (status, index, t, θ, state (5, N)): status 0, or 1 with the index of the first
    node without a balance (a non-finite rate), else 2 if the flow runs backwards at any node.
    The repeated node of each joint is dropped; the joints are at the cumulative step counts.
    """
    nseg = len(steps)
    total = 1
    for k in range(nseg):
        total += steps[k]
    t = np.empty(total)
    theta = np.empty(total)
    state = np.empty((5, total))
    g = np.empty(total)
    sign = 1.0 if ends[nseg] > ends[0] else -1.0
    bad = -1
    backwards = False
    j = 0
    for seg in range(nseg):
        a, b, n = ends[seg], ends[seg + 1], steps[seg]
        step = (b - a) / n
        first = 0 if seg == 0 else 1
        for i in range(first, n + 1):
            s = i * step + a if i < n else b  # np.linspace's arithmetic
            th = 2.0 * math.atan(math.exp(s))
            rate, phidot, omega3, E, nu, omega_n = flow_rate(
                th, lam, top, law, mu, eps, cm_response
            )
            if bad < 0 and not math.isfinite(rate):
                bad = j
            backwards = backwards or rate * sign <= 0.0
            theta[j] = th
            state[0, j], state[1, j], state[2, j] = phidot, omega3, E
            state[3, j], state[4, j] = nu, omega_n
            g[j] = math.sin(th) / rate
            j += 1
    if bad >= 0:
        return 1, bad, t, theta, state
    if backwards:
        return 2, 0, t, theta, state
    # cumulative Simpson per segment (mett.inversion._gyroscopic._cumulative_simpson)
    t[0] = 0.0
    start = 0
    for seg in range(nseg):
        n = steps[seg]
        hk = (ends[seg + 1] - ends[seg]) / n
        t0 = t[start]
        acc = 0.0
        for i in range(2, n + 1, 2):
            f0, f1, f2 = g[start + i - 2], g[start + i - 1], g[start + i]
            before = acc
            acc += (hk / 3.0) * (f0 + 4.0 * f1 + f2)
            t[start + i] = t0 + acc
            t[start + i - 1] = t0 + (before + (hk / 12.0) * (5.0 * f0 + 8.0 * f1 - f2))
        start += n
    return 0, j, t, theta, state


# --- the fast spectra and the nutation -----------------------------------------------------------


@_njit
def spectrum(th, lam, top, law, mu, eps):
    """The two fast eigenvalues (largest imaginary part first) of the gliding model at the
    balance state of inclination θ, in the precessing frame
    (:func:`mett.inversion._nutation._fast_spectra` at one node)."""
    m, R, alpha, I1, I3, g = top[0], top[1], top[2], top[3], top[4], top[5]
    phidot, omega3, _, _, _ = balance(th, lam, m, R, alpha, I1, I3, g)
    l = R * alpha
    s, c = math.sin(th), math.cos(th)
    k = (I3 - I1) * omega3
    y0 = np.zeros(10)
    y0[5] = I1 * s * (phidot * c - omega3) - k * s
    y0[6] = I1 * (phidot * s * s + omega3 * c) + k * c
    y0[8], y0[9] = -s, c
    h = np.empty(8)
    h[0] = h[1] = 1e-30 * (R * max(abs(phidot), abs(omega3)))
    h[2] = h[3] = h[4] = 1e-30 * math.sqrt(y0[5] ** 2 + y0[6] ** 2)
    h[5] = h[6] = h[7] = 1e-30
    A = np.empty((8, 8))
    Y = np.empty(10, dtype=np.complex128)
    for col in range(8):
        for i in range(10):
            Y[i] = y0[i]
        Y[2 + col] += 1j * h[col]
        # one call site of the inlined field (each is a copy of its code to compile): under the
        # regularised law a first pass for ν, which does not depend on μ, then μ(ν)
        mu_c = complex(mu)
        for k in range(2 if law == REGULARISED else 1):
            d = _glide(Y, (m, R, l, I1, I3, mu_c, g))
            if law == REGULARISED and k == 0:
                nux, nuy = d[12]
                mu_c = mu / np.sqrt(nux * nux + nuy * nuy + eps**2)
        hc = h[col]
        A[0, col] = d[2].imag / hc
        A[1, col] = d[3].imag / hc
        A[2, col] = d[4].imag / hc
        A[3, col] = d[5].imag / hc
        A[4, col] = d[6].imag / hc
        A[5, col] = d[7].imag / hc
        A[6, col] = d[8].imag / hc
        A[7, col] = d[9].imag / hc
    for i in (0, 2, 5):  # the rotation at φ̇ about ẑ
        A[i, i + 1] += phidot
        A[i + 1, i] -= phidot
    wr, wi, ok = eigvals_hessenberg_qr(A)
    if not ok:  # not converged (never seen on these Jacobians): NaN, the caller's t_lift is NaN
        nan = complex(math.nan, math.nan)
        return nan, nan
    # the two of largest imaginary part, the earlier first on a tie (a stable sort's order)
    i1 = 0
    for i in range(1, 8):
        if wi[i] > wi[i1]:
            i1 = i
    i2 = 1 if i1 == 0 else 0
    for i in range(8):
        if i != i1 and wi[i] > wi[i2]:
            i2 = i
    return complex(wr[i1], wi[i1]), complex(wr[i2], wi[i2])


@_inline
def _distances(th, a, b, t0, l0, t1, l1):
    """Distances of (a, b) from the value extrapolated linearly from (t0, l0), (t1, l1) to θ."""
    guess = l1 + (l1 - l0) * (th - t1) / (t1 - t0) if t1 != t0 else l1
    return abs(a - guess), abs(b - guess)


@_inline
def _unclear(da, db):
    return min(da, db) > _CLEAR * max(da, db)


@_inline
def _follow(th, a, b, t0, l0, t1, l1, has2, lam, top, law, mu, eps):
    """The nutation's step (:func:`mett.inversion._nutation._follow`): the eigenvalue at θ of the
    fast pair (a, b) nearest the one extrapolated from the last two (θ, λ_n) of the history (one
    if not ``has2``), the step split in _SPLIT where the pick is unclear, at most _DEPTH times.

    The reference's recursion written with an explicit stack (frame d: the node at depth d, its
    pair and its history; a split's base, step and counter), one function instead of a copy
    per depth. Returns the pick and the history's last entry before it: after a split, the
    split's last node (the next step extrapolates from there, as _follow's history does); NaN
    if a split's spectrum failed.
    """
    n = _DEPTH + 1
    fth = np.empty(n)
    fa = np.empty(n, dtype=np.complex128)
    fb = np.empty(n, dtype=np.complex128)
    ft0 = np.empty(n)
    fl0 = np.empty(n, dtype=np.complex128)
    ft1 = np.empty(n)
    fl1 = np.empty(n, dtype=np.complex128)
    base = np.empty(n)
    step = np.empty(n)
    count = np.zeros(n, dtype=np.int64)
    fth[0], fa[0], fb[0] = th, a, b
    ft0[0], fl0[0], ft1[0], fl1[0] = t0, l0, t1, l1
    d = 0
    while True:
        # enter frame d: pick, or split its step and enter the split's first node
        da, db = _distances(fth[d], fa[d], fb[d], ft0[d], fl0[d], ft1[d], fl1[d])
        if d < _DEPTH and (has2 or d > 0) and _unclear(da, db):
            base[d] = ft1[d]
            step[d] = (fth[d] - ft1[d]) / _SPLIT
            count[d] = 1
            x = step[d] + base[d]
            sa, sb = spectrum(x, lam, top, law, mu, eps)
            fth[d + 1], fa[d + 1], fb[d + 1] = x, sa, sb
            ft0[d + 1], fl0[d + 1], ft1[d + 1], fl1[d + 1] = ft0[d], fl0[d], ft1[d], fl1[d]
            d += 1
            continue
        pick = fa[d] if da <= db else fb[d]
        # return the pick to the frames below until one has a node of its split left
        while True:
            if d == 0:
                return pick, ft1[0], fl1[0]
            if pick != pick:  # a spectrum failed (NaN): so does the walk
                return pick, t1, l1
            d -= 1
            # the child's history entry before its pick, then the pick at the child's node
            ft0[d], fl0[d] = ft1[d + 1], fl1[d + 1]
            ft1[d], fl1[d] = fth[d + 1], pick
            count[d] += 1
            if count[d] < _SPLIT:
                x = count[d] * step[d] + base[d]
                sa, sb = spectrum(x, lam, top, law, mu, eps)
                fth[d + 1], fa[d + 1], fb[d + 1] = x, sa, sb
                ft0[d + 1], fl0[d + 1], ft1[d + 1], fl1[d + 1] = ft0[d], fl0[d], ft1[d], fl1[d]
                d += 1
                break
            # the split done: pick with the history it left
            da, db = _distances(fth[d], fa[d], fb[d], ft0[d], fl0[d], ft1[d], fl1[d])
            pick = fa[d] if da <= db else fb[d]


@_njit
def lift_off_kernel(t, theta, amp0, rate0, lam, top, law, mu, eps, bound_limit, exact):
    """The lift-off criterion along the nodes (:func:`mett.inversion._nutation.lift_off`).

    ``amp0``, ``rate0``: the upright spin's nutation (:func:`mett.inversion._nutation.upright_nutation`);
    in the frame precessing at the first node's φ̇ its eigenvalue is Re rate0 + i (φ̇ + |Im rate0|).

    Returns (t_lift, n, ratio, amplitude, λ_n) with the arrays valid up to ``n`` (the first node
    past the criterion, or all); t_lift is NaN if an eigenvalue iteration failed. Unless ``exact``, the bound over both fast eigenvalues is
    evaluated first and the walk skipped (n = 0, t_lift = inf) where it stays below
    ``bound_limit`` at every node.
    """
    N = len(theta)
    m, R, alpha, I1, g = top[0], top[1], top[2], top[3], top[5]
    l = R * alpha
    fa = np.empty(N, dtype=np.complex128)
    fb = np.empty(N, dtype=np.complex128)
    M = np.empty(N)
    for j in range(N):
        fa[j], fb[j] = spectrum(theta[j], lam, top, law, mu, eps)
        if fa[j] != fa[j]:  # the QR iteration failed: no decision
            return math.nan, 0, np.zeros(N), np.zeros(N), np.zeros(N, dtype=np.complex128)
        M[j] = I1 + m * l**2 * math.sin(theta[j]) ** 2
    ratio = np.zeros(N)
    amp = np.zeros(N)
    lam_n = np.zeros(N, dtype=np.complex128)
    if not exact:
        # the bound: at each node the larger |λ|² and Re λ of the two, the larger frequency at
        # the first node and the smaller at the node (mett.inversion._nutation.lift_off_time)
        w0 = max(fa[0].imag, fb[0].imag)
        growth = 0.0
        below = True
        for j in range(N):
            re = max(fa[j].real, fb[j].real)
            if j:
                growth += 0.5 * (re + max(fa[j - 1].real, fb[j - 1].real)) * (t[j] - t[j - 1])
            wj = min(fa[j].imag, fb[j].imag)
            bj = amp0 * math.exp(0.5 * math.log(M[0] * w0 / (M[j] * wj)) + growth)
            bound = l * max(abs(fa[j]) ** 2, abs(fb[j]) ** 2) * bj * math.sin(theta[j]) / g
            if not bound < bound_limit:  # NaN too: the exact criterion decides
                below = False
                break
        if below:
            return math.inf, 0, ratio, amp, lam_n
    phidot0 = balance(theta[0], lam, m, R, alpha, I1, top[4], g)[0]
    start = complex(rate0.real, phidot0 + abs(rate0.imag))
    t0, l0 = theta[0], start
    t1, l1 = theta[0], start
    has2 = False
    growth = 0.0
    for j in range(N):
        pick, t0, l0 = _follow(theta[j], fa[j], fb[j], t0, l0, t1, l1, has2, lam, top, law, mu, eps)
        if pick != pick:  # a split's spectrum failed: no decision
            return math.nan, j, ratio, amp, lam_n
        t1, l1, has2 = theta[j], pick, True
        lam_n[j] = pick
        if j:
            growth += 0.5 * (pick.real + lam_n[j - 1].real) * (t[j] - t[j - 1])
        a = amp0 * math.exp(0.5 * math.log(M[0] * lam_n[0].imag / (M[j] * pick.imag)) + growth)
        amp[j] = a
        ratio[j] = l * abs(pick) ** 2 * a * math.sin(theta[j]) / g
        if ratio[j] >= 1.0:
            if j == 0:
                return t[0], 1, ratio, amp, lam_n
            # log-linear between the nodes: the ratio grows about exponentially with θ̄
            ra, rb = math.log(ratio[j - 1]), math.log(ratio[j])
            return t[j - 1] + (t[j] - t[j - 1]) * (0.0 - ra) / (rb - ra), j + 1, ratio, amp, lam_n
    return math.inf, N, ratio, amp, lam_n


# --- the upright spin's Jacobian -----------------------------------------------------------------


@_njit
def spin_jacobian_kernel(y0, h, p):
    """Jacobian (10 × 10) of the gliding field at ``y0`` by complex steps ``h`` (per column),
    parameters ``p`` = (m, R, l, I1, I3, μ, g): :func:`mett.stability.spin_jacobian`'s arithmetic."""
    m, R, l, I1, I3, mu, g = p
    J = np.empty((10, 10))
    Y = np.empty(10, dtype=np.complex128)
    for col in range(10):
        for i in range(10):
            Y[i] = y0[i]
        Y[col] += 1j * h[col]
        d = _glide(Y, (m, R, l, I1, I3, mu, g))
        hc = h[col]
        J[0, col] = d[0].imag / hc
        J[1, col] = d[1].imag / hc
        J[2, col] = d[2].imag / hc
        J[3, col] = d[3].imag / hc
        J[4, col] = d[4].imag / hc
        J[5, col] = d[5].imag / hc
        J[6, col] = d[6].imag / hc
        J[7, col] = d[7].imag / hc
        J[8, col] = d[8].imag / hc
        J[9, col] = d[9].imag / hc
    return J


# --- the upright spin's modes --------------------------------------------------------------------


@_njit
def _lu_solve(M, b, floor):
    """x with M x = b (complex, M overwritten) by Gaussian elimination with partial pivoting; a
    pivot below ``floor`` is replaced by it (inverse iteration solves with a singular M)."""
    n = M.shape[0]
    x = b.copy()
    for k in range(n):
        p = k
        for i in range(k + 1, n):
            if abs(M[i, k]) > abs(M[p, k]):
                p = i
        if p != k:
            for j in range(n):
                M[k, j], M[p, j] = M[p, j], M[k, j]
            x[k], x[p] = x[p], x[k]
        if abs(M[k, k]) < floor:
            M[k, k] = floor
        for i in range(k + 1, n):
            f = M[i, k] / M[k, k]
            if f != 0.0:
                for j in range(k + 1, n):
                    M[i, j] -= f * M[k, j]
                x[i] -= f * x[k]
    for k in range(n - 1, -1, -1):
        s = x[k]
        for j in range(k + 1, n):
            s -= M[k, j] * x[j]
        x[k] = s / M[k, k]
    return x


@_inline
def _div_real(z, r):
    """z / r for complex z and real r ≥ 0, as numpy's array division does it (r as r + 0i,
    Smith's algorithm: the reciprocal's multiple), so the loops round as the array expressions
    they replace did."""
    if r == 0.0:
        return complex(z.real / r, z.imag / r)
    rat = 0.0 / r
    scl = 1.0 / (r + 0.0 * rat)
    return complex((z.real + z.imag * rat) * scl, (z.imag - z.real * rat) * scl)


@_njit
def eig_small(A):
    """Eigenvalues and unit right eigenvectors (columns) of the small real matrix ``A``, and ok.

    The matrix balanced first (:func:`balance_matrix`: the Jacobians mix velocities, angular
    momenta and directions, entries over ten decades, and inverse iteration on the raw matrix
    loses the small components' digits); the eigenvalues by :func:`eigvals_hessenberg_qr`; each
    eigenvector by two steps of inverse iteration with the computed eigenvalue (Wilkinson 1965, The Algebraic Eigenvalue Problem,
    §9.47): the shift is exact to rounding, so the solve amplifies the eigenvector's component
    by ~1/(ε |A|) over the others, and the second step removes what the start vector lacked.
    Scaled to unit 2-norm with the largest component real and positive. ``ok`` is False if the
    QR iteration does not converge or two eigenvalues coincide to rounding (a defective or
    derogatory matrix, whose eigenvectors inverse iteration cannot separate).
    """
    n = A.shape[0]
    A = A.copy()
    scale = balance_matrix(A)  # the eigenvectors of the balanced matrix, accurate relative to it
    wr, wi, ok = eigvals_hessenberg_qr(A.copy())
    ev = np.empty(n, dtype=np.complex128)
    V = np.zeros((n, n), dtype=np.complex128)
    if not ok:
        return ev, V, False
    norm = 0.0
    for i in range(n):
        for j in range(n):
            norm = max(norm, abs(A[i, j]))
    if norm == 0.0:
        return ev, V, False
    for k in range(n):
        ev[k] = complex(wr[k], wi[k])
    floor = 2.2e-16 * norm
    for k in range(n):
        for j in range(k):
            if abs(ev[k] - ev[j]) <= 1e3 * floor:
                return ev, V, False
    M = np.empty((n, n), dtype=np.complex128)
    for k in range(n):
        x = np.empty(n, dtype=np.complex128)
        for i in range(n):
            x[i] = 1.0
        for _ in range(2):
            for i in range(n):
                for j in range(n):
                    M[i, j] = A[i, j]
                M[i, i] -= ev[k]
            x = _lu_solve(M, x, floor)
            s = 0.0
            for i in range(n):
                s += x[i].real ** 2 + x[i].imag ** 2
            r = math.sqrt(s)
            for i in range(n):  # loops, not array expressions: each of those compiles a kernel
                x[i] = _div_real(x[i], r)
        s = 0.0
        for i in range(n):
            x[i] *= scale[i]  # back to the eigenvector of A
            s += x[i].real ** 2 + x[i].imag ** 2
        r = math.sqrt(s)
        big = 0
        for i in range(n):
            x[i] = _div_real(x[i], r)
            if abs(x[i]) > abs(x[big]):
                big = i
        f = abs(x[big]) / x[big]
        for i in range(n):
            V[i, k] = x[i] * f
    return ev, V, True


@_njit
def upright_modes_kernel(y0, h, p, horizontal, dy):
    """(J, eigenvalues, eigenvectors, the start's coefficients, ok) of the upright spin's
    horizontal block (:func:`mett.stability.escape_modes`): the complex-step Jacobian, its
    eigen-decomposition (:func:`eig_small`) and the deviation ``dy`` in the eigenvectors."""
    J = spin_jacobian_kernel(y0, h, p)
    n = len(horizontal)
    A = np.empty((n, n))
    finite = True
    for i in range(n):
        for j in range(n):
            A[i, j] = J[horizontal[i], horizontal[j]]
            finite = finite and math.isfinite(A[i, j])
    ev, V, ok = eig_small(A)
    coef = np.zeros(n, dtype=np.complex128)
    if ok and finite:
        b = np.empty(n, dtype=np.complex128)
        for i in range(n):
            b[i] = dy[i]
        coef = _lu_solve(V.copy(), b, 0.0)
    return J, ev, V, coef, ok
