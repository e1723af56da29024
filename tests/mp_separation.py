"""Independent high-precision reference for the separation layer (mpmath, 50–70 digits).

Written from the METT alone (Rutstam 2013, ch. 3; docs/theory/mett.md), sharing no code with
``mett.separation``: the doubles (E, D, λ) are taken as exact numbers, and

    P(z) = (1 − z²)(E − D²/(2 I1) + m λ²/(2 I1 I3) − m g R (1 − α z)) − I3 N(z)²/(2 I1² R²),
    N(z) = λ √d(z) + R D (α − z),  d(z) = γ + σ(α − z)² + σγ(1 − z²),
    g(z) = ½ (I1 + m R² (1 + α² − 2 α z)),

    T = 2 ∫_a^b √(g/P) dz,   ⟨φ̇⟩ = (2/T) ∫_a^b φ̇ √(g/P) dz,  φ̇ = N/(R I1 (1 − z²) √d).

The turning points a < b are bracketed by geometric steps outwards from a point of the band and
bisected to the working precision. The integrals use z = a + (b − a) sin²(v/2), v ∈ [0, π], which
removes the inverse square roots at both ends, and tanh-sinh quadrature on panels graded
geometrically towards both ends (down to 1e-30 of the band), so that a pole a hair outside the band
(the log layer next to a separatrix) is resolved.
"""

from __future__ import annotations

from typing import NamedTuple

import mpmath

_EXTRA = 8  # panels beyond the pole gap


class MpBand(NamedTuple):
    z_low: float
    z_high: float
    period: float
    precession: float


def _functions(top, E, D, lam, start=None):
    mp = mpmath.mpf
    m, R, al, I1, I3, gr = (mp(v) for v in (top.m, top.R, top.alpha, top.I1, top.I3, top.g))
    E, D, lam = mp(E), mp(D), mp(lam)
    gam, sig = I1 / I3, m * R**2 / I3
    Es = E - D**2 / (2 * I1) + m * lam**2 / (2 * I1 * I3)
    if start is not None:
        # the start z0 is a turning point: E = V(z0) (used where the rounded E lies below V(z0))
        z0 = mp(start)
        n0 = lam * mpmath.sqrt(gam + sig * (al - z0) ** 2 + sig * gam * (1 - z0 * z0))
        n0 += R * D * (al - z0)
        Es = m * gr * R * (1 - al * z0) + I3 * n0 * n0 / (2 * I1**2 * R**2) / (1 - z0 * z0)
    C = I3 / (2 * I1**2 * R**2)

    def sqd(z):
        return mpmath.sqrt(gam + sig * (al - z) ** 2 + sig * gam * (1 - z * z))

    def N(z):
        return lam * sqd(z) + R * D * (al - z)

    def P(z):
        n = N(z)
        return (1 - z * z) * (Es - m * gr * R * (1 - al * z)) - C * n * n

    def g(z):
        return (I1 + m * R**2 * (1 + al**2 - 2 * al * z)) / 2

    def phidot(z):
        return N(z) / (R * I1 * (1 - z * z) * sqd(z))

    return P, g, phidot


def _bisect(P, lo, hi):
    """Root of P in [lo, hi] (P(lo) > 0 >= P(hi) or the reverse) to the working precision."""
    plo = P(lo)
    tol = mpmath.mpf(10) ** (-mpmath.mp.dps + 3)
    for _ in range(4 * mpmath.mp.prec):
        mid = (lo + hi) / 2
        if abs(hi - lo) <= tol * (abs(mid) + tol) or mid in (lo, hi):
            break
        pm = P(mid)
        if (pm > 0) == (plo > 0):
            lo, plo = mid, pm
        else:
            hi = mid
    return (lo + hi) / 2


def _end(P, x, direction, step):
    """The turning point reached from x (P(x) > 0) moving in ``direction`` (±1)."""
    pole = mpmath.mpf(direction)
    s = step
    prev = x
    while True:
        y = x + direction * s
        if (y - pole) * direction >= 0:
            # the pole itself is an end where P vanishes there (N(±1) = 0), else P(±1) < 0
            if P(pole) < 0:
                return _bisect(P, prev, pole)
            # P(±1) = 0, but P/(1 − z²) → E − V(±1), which is negative below the separatrix
            # of an unstable pole: P < 0 just off it, and the band ends at a root before it
            t = abs(pole - prev)
            while t > mpmath.mpf(2) ** (-4 * mpmath.mp.prec):
                y = pole - direction * t
                if P(y) < 0:
                    return _bisect(P, prev, y)
                prev, t = y, t / 2
            return pole
        if P(y) <= 0:
            return _bisect(P, prev, y)
        prev = y
        s *= 2


def reference(top, E, D, lam, z_in, *, dps=40, precession=True, start=False) -> MpBand:
    """Band, period and mean precession of the rolling motion through (or starting at) z_in.

    ``z_in`` is a point of the band or one of its turning points (a start at rest in θ): the side
    of it where P > 0 is searched for within 1e-3 of it. With ``start``, E is replaced by V(z_in)
    (z_in is the turning point of a start at rest in θ) where the given E lies below V(z_in).
    """
    with mpmath.workdps(dps):
        mp = mpmath.mpf
        P, g, phidot = _functions(top, E, D, lam)
        if start and not P(mp(z_in)) > 0:
            P, g, phidot = _functions(top, E, D, lam, start=z_in)
        x = mp(z_in)
        tiny = mp(10) ** (-dps + 8)
        if not P(x) > 0:
            for k in range(400):
                s = tiny * mp(2) ** k
                if s > mp("1e-3"):
                    raise ValueError("no band next to z_in")
                cands = [c for c in (x + s, x - s) if -1 < c < 1 and P(c) > 0]
                if cands:
                    x = cands[0]
                    break
        step = max(abs(x) * tiny, tiny)
        a, b = _end(P, x, -1, step), _end(P, x, 1, step)
        width = b - a

        def with_weight(fn):
            def integrand(v):
                z = a + width * mpmath.sin(v / 2) ** 2
                s = mpmath.sin(v)
                if s == 0:
                    return mp(0)
                denom = (z - a) * (b - z)
                if denom <= 0:
                    return mp(0)
                R = P(z) / denom
                if R <= 0:  # a node within the ends' last digits (negligible weight)
                    return mp(0)
                return fn(z) * mpmath.sqrt(g(z) / R)

            return integrand

        cuts = {mp(0), mpmath.pi / 2, mpmath.pi}
        for end, gap in ((0, a + 1), (1, 1 - b)):
            # grade towards an end down to the distance of the pole beyond it (the log layer)
            rel = gap / width
            if 0 < rel < mp("0.1"):
                for k in range(1, int(-mpmath.log10(rel)) + _EXTRA):
                    v = 2 * mpmath.asin(mpmath.sqrt(mp(10) ** (-k)))
                    cuts.add(mpmath.pi - v if end else v)
        cuts = sorted(cuts)
        T = 2 * mpmath.quad(with_weight(lambda z: 1), cuts)
        prec = mpmath.nan
        if precession:
            prec = 2 * mpmath.quad(with_weight(phidot), cuts) / T
        return MpBand(float(a), float(b), float(T), float(prec))


def excess_at(top, E, D, lam, z, *, dps=60) -> float:
    """E − V(z) = P(z)/(1 − z²) at 'dps' digits (J), for an interior z."""
    with mpmath.workdps(dps):
        P, _, _ = _functions(top, E, D, lam)
        z = mpmath.mpf(z)
        return float(P(z) / (1 - z * z))


class MpSteady(NamedTuple):
    z_min: float
    u_min: float
    """Distance 1 − p z_min from the pole p (0 for a well in the interior)."""
    period: float
    precession: float


def steady(top, D, lam, z_hint, *, pole=None, u_hint=None, dps=50) -> MpSteady:
    """Steady precession at the bottom of the well of V(·, D, λ) next to ``z_hint``: the
    small-oscillation period 2π/ω, ω² = (1 − z²) V''(z)/(2 g(z)), and φ̇ there.

    Independent of mett: V = m g R(1 − α z) + C N²/(1 − z²) written out at ``dps`` digits (plus the
    decades of the distance to the pole), its stationary point solved for by a bracketed root of
    the numerical derivative. With ``pole`` (±1) the well is parametrised by x = ln u, u = 1 − p z,
    so that a bottom far below one ulp of z (u ~ 1e-20) is resolved: dV/dx = u V'(u), and at the
    bottom V'' = (d²V/dx²)/u². ``u_hint`` (default 1 − p z_hint) starts the search in u.
    """
    if pole is None:
        extra = 0
    else:
        u_hint = max(1.0 - pole * z_hint, 1e-300) if u_hint is None else u_hint
        extra = int(-mpmath.log10(u_hint)) + 10
    with mpmath.workdps(dps + extra):
        mp = mpmath.mpf
        m, R, al, I1, I3, gr = (mp(v) for v in (top.m, top.R, top.alpha, top.I1, top.I3, top.g))
        D, lam = mp(D), mp(lam)
        gam, sig = I1 / I3, m * R**2 / I3
        C = I3 / (2 * I1**2 * R**2)

        def sqd(z):
            return mpmath.sqrt(gam + sig * (al - z) ** 2 + sig * gam * (1 - z * z))

        def V_of(z, w):  # w = 1 − z², passed separately (it is u(2 − u) next to a pole)
            n = lam * sqd(z) + R * D * (al - z)
            return m * gr * R * (1 - al * z) + C * n * n / w

        def g(z):
            return (I1 + m * R**2 * (1 + al**2 - 2 * al * z)) / 2

        def phidot(z, w):
            return (lam * sqd(z) + R * D * (al - z)) / (R * I1 * w * sqd(z))

        if pole is None:

            def F(x):
                return V_of(x, 1 - x * x)

            x0 = mp(z_hint)
            h = mp("1e-3") * (1 - abs(x0))
        else:
            p = mp(pole)

            def F(x):
                u = mpmath.exp(x)
                return V_of(p * (1 - u), u * (2 - u))

            x0 = mpmath.log(mp(u_hint))
            h = mp(1)

        def dF(x):
            return mpmath.diff(F, x)

        lo, hi = x0 - h, x0 + h
        for _ in range(200):
            if dF(lo) < 0 < dF(hi):
                break
            lo, hi = lo - h, hi + h
            h *= 1.5
        else:
            raise ValueError("no minimum of V bracketed")
        x = mpmath.findroot(dF, (lo, hi), solver="anderson")
        if pole is None:
            z, w = x, 1 - x * x
            omega2 = w * mpmath.diff(F, x, 2) / (2 * g(z))
            u = mp(0)
        else:
            u = mpmath.exp(x)
            z, w = p * (1 - u), u * (2 - u)
            omega2 = w * mpmath.diff(F, x, 2) / (u * u) / (2 * g(z))
        return MpSteady(
            float(z), float(u), float(2 * mpmath.pi / mpmath.sqrt(omega2)), float(phidot(z, w))
        )
