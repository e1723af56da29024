"""Independent reference integrator of the *rolling* tippe top (contact point at rest, v_A = 0).

Written in lab-frame vector form from Newton–Euler alone, without any of mett's METT formulas
(``mett.TippeTop`` is only used as a container of m, R, α, I1, I3, g). Derivation:

* ``3̂̇ = ω × 3̂``; ``a = R(α 3̂ − ẑ)`` (centre of mass → contact point), ``ȧ = R α ω × 3̂``.
* Rolling: ``v_A = ṙ + ω × a = 0`` so the CM velocity is ``ṙ = −ω × a``, and Newton gives the contact
  force ``F = m(g ẑ + r̈) = m(g ẑ − ω̇ × a − ω × ȧ)``.
* ``L = J ω`` with ``J = I1 𝟙 + (I3 − I1) 3̂ 3̂ᵀ``; since ``ω·3̂̇ = 0``,
  ``L̇ = J ω̇ + (I3 − I1)(ω·3̂)(ω × 3̂)``. With ``L̇ = a × F`` and ``a × (ω̇ × a) = |a|² ω̇ − (a·ω̇) a``:

      (J + m(|a|² 𝟙 − a aᵀ)) ω̇ = m a × (g ẑ − ω × ȧ) − (I3 − I1)(ω·3̂)(ω × 3̂).

The state is ``(3̂, ω)`` in lab coordinates, optionally with the precession angle φ of 3̂'s
horizontal projection (``3̂ = (sinθ sinφ, −sinθ cosφ, cosθ)``, Goldstein z-x-z, docs/theory/model.md#conventions)
integrated alongside; φ is singular at the poles, so tops that pass through θ = 0 must run without it.

The right-hand side uses plain Python floats (3-vectors are too small for numpy to pay off) and
Cramer's rule for the 3×3 solve. Conserved quantities — energy E, Jellett λ = −L·a and Routh
D = I3 ω3 √d — are provided so that tests can check the reference itself.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp

__all__ = ["RollingRun", "initial_state", "integrals", "integrate"]


def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _solve3(M, b):
    """Solve the 3×3 system M x = b by Cramer's rule (M symmetric positive definite here)."""
    (a11, a12, a13), (a21, a22, a23), (a31, a32, a33) = M
    c11 = a22 * a33 - a23 * a32
    c12 = a23 * a31 - a21 * a33
    c13 = a21 * a32 - a22 * a31
    det = a11 * c11 + a12 * c12 + a13 * c13
    x1 = b[0] * c11 + b[1] * (a13 * a32 - a12 * a33) + b[2] * (a12 * a23 - a13 * a22)
    x2 = b[0] * c12 + b[1] * (a11 * a33 - a13 * a31) + b[2] * (a13 * a21 - a11 * a23)
    x3 = b[0] * c13 + b[1] * (a12 * a31 - a11 * a32) + b[2] * (a11 * a22 - a12 * a21)
    return (x1 / det, x2 / det, x3 / det)


def _make_rhs(top, track_phi: bool):
    m, R, al, I1, I3, grav = top.m, top.R, top.alpha, top.I1, top.I3, top.g
    dI = I3 - I1
    Ra = R * al

    def rhs(t, y):
        n = (y[0], y[1], y[2])
        w = (y[3], y[4], y[5])
        a = (Ra * n[0], Ra * n[1], Ra * n[2] - R)
        nd = _cross(w, n)
        ad = (Ra * nd[0], Ra * nd[1], Ra * nd[2])
        w3 = _dot(w, n)
        wxad = _cross(w, ad)
        rhs_vec = _cross(a, (-wxad[0], -wxad[1], grav - wxad[2]))
        b = tuple(m * rhs_vec[i] - dI * w3 * nd[i] for i in range(3))
        aa = _dot(a, a)
        diag = I1 + m * aa
        M = tuple(
            tuple((diag if i == j else 0.0) + dI * n[i] * n[j] - m * a[i] * a[j] for j in range(3))
            for i in range(3)
        )
        wd = _solve3(M, b)
        out = [nd[0], nd[1], nd[2], wd[0], wd[1], wd[2]]
        if track_phi:
            # φ = atan2(3̂_x, −3̂_y)  ⇒  φ̇ = (3̂_x 3̂̇_y − 3̂_y 3̂̇_x)/(3̂_x² + 3̂_y²)
            out.append((n[0] * nd[1] - n[1] * nd[0]) / (n[0] ** 2 + n[1] ** 2))
        return out

    return rhs


def initial_state(theta: float, thetadot: float, phidot: float, omega3: float) -> np.ndarray:
    """Lab-frame ``(3̂, ω)`` for Euler-angle data with φ = 0 (docs/theory/model.md#conventions, Goldstein z-x-z).

    ``3̂ = (0, −sinθ, cosθ)``, ``2̂ = (1, 0, 0)`` (line of nodes), ``1̂ = 2̂ × 3̂ = (0, −cosθ, −sinθ)``,
    ``ω = −φ̇ sinθ 1̂ + θ̇ 2̂ + ω3 3̂``. At θ = 0 this is still well defined (2̂ = x̂ by continuity).
    """
    s, c = math.sin(theta), math.cos(theta)
    e1 = np.array([0.0, -c, -s])
    e2 = np.array([1.0, 0.0, 0.0])
    e3 = np.array([0.0, -s, c])
    w = -phidot * s * e1 + thetadot * e2 + omega3 * e3
    return np.concatenate([e3, w])


def integrals(top, y) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(E, λ, D) of lab-frame states ``y`` (shape (6,) or (≥6, n)), from their definitions.

    E = ½ ω·L + ½ m|ω × a|² + m g R(1 − α 3̂·ẑ),  λ = −L·a,  D = I3 ω3 √d(3̂·ẑ)
    with d(z) = γ + σ(α − z)² + σγ(1 − z²) (docs/theory/model.md#conventions).
    """
    y = np.asarray(y, dtype=float)
    n, w = y[0:3], y[3:6]
    m, R, al, I1, I3 = top.m, top.R, top.alpha, top.I1, top.I3
    zhat = np.zeros_like(n)
    zhat[2] = 1.0
    a = R * (al * n - zhat)
    w3 = np.sum(w * n, axis=0)
    L = I1 * w + (I3 - I1) * w3 * n
    wxa = np.cross(w, a, axis=0)
    z = n[2]
    E = (
        0.5 * np.sum(w * L, axis=0)
        + 0.5 * m * np.sum(wxa**2, axis=0)
        + m * top.g * R * (1 - al * z)
    )
    lam = -np.sum(L * a, axis=0)
    gam, sig = I1 / I3, m * R**2 / I3
    D = I3 * w3 * np.sqrt(gam + sig * (al - z) ** 2 + sig * gam * (1 - z * z))
    return E, lam, D


@dataclass
class RollingRun:
    """Result of :func:`integrate`: turning points and derived measurements."""

    t_low: np.ndarray
    """Times of the minima of z = cos θ (ż crosses 0 upwards)."""
    z_low: np.ndarray
    t_high: np.ndarray
    """Times of the maxima of z (ż crosses 0 downwards)."""
    z_high: np.ndarray
    phi_low: np.ndarray | None
    """Precession angle φ at the minima of z (None without φ tracking)."""
    y0: np.ndarray
    y_end: np.ndarray
    drift: dict
    """Largest relative change of E, λ and D at the turning points and the end."""
    nfev: int
    t_samples: np.ndarray
    """The requested sample times (``t_eval``) that were reached."""
    y_samples: np.ndarray
    """Lab states ``(3̂, ω)`` at ``t_samples``, shape (6, n)."""

    @property
    def period(self) -> float:
        """Nutation period from the first and last minimum of z (whole periods only)."""
        return float((self.t_low[-1] - self.t_low[0]) / (len(self.t_low) - 1))

    @property
    def period_high(self) -> float:
        """The same from the maxima of z (an independent second estimate)."""
        return float((self.t_high[-1] - self.t_high[0]) / (len(self.t_high) - 1))

    @property
    def mean_phidot(self) -> float:
        """Mean precession rate over the whole periods between the first and last minimum of z."""
        return float((self.phi_low[-1] - self.phi_low[0]) / (self.t_low[-1] - self.t_low[0]))


def integrate(
    top,
    y0,
    *,
    periods: int = 3,
    t_max: float = 10.0,
    rtol: float = 1e-12,
    track_phi: bool = True,
    t_eval=None,
) -> RollingRun:
    """Integrate the rolling top from lab state ``y0`` until z has had ``periods + 1`` minima.

    ``solve_ivp`` (DOP853) with events on ż = (ω × 3̂)·ẑ = 0; the period is then measured between
    same-direction events, and the mean precession rate from φ at the minima of z. ``t_eval``
    (optional) adds states at those times, from the dense output.
    """
    y0 = np.asarray(y0, dtype=float)
    w_scale = float(np.linalg.norm(y0[3:6])) or 1.0
    # atol far below rtol·|y| so that rtol controls the error of every component group.
    atol = [1e-16] * 3 + [1e-16 * w_scale] * 3
    if track_phi:
        x, yy = y0[0], y0[1]
        y0 = np.append(y0, math.atan2(x, -yy))
        atol.append(1e-14)

    def zdot(t, y):
        return y[3] * y[1] - y[4] * y[0]

    def z_min(t, y):
        return zdot(t, y)

    z_min.direction = 1.0
    z_min.terminal = periods + 2  # one more: a minimum at t = 0 is dropped below

    def z_max(t, y):
        return zdot(t, y)

    z_max.direction = -1.0

    sol = solve_ivp(
        _make_rhs(top, track_phi),
        (0.0, t_max),
        y0,
        method="DOP853",
        rtol=rtol,
        atol=atol,
        events=(z_min, z_max),
        t_eval=t_eval,
    )
    if sol.status < 0:
        raise RuntimeError(sol.message)
    # An event reported at t = 0 comes from the start (θ̇0 = 0 makes it a turning point), not from
    # root finding on the dense output like all later events; keep like with like.
    t_lo, t_hi = sol.t_events
    ylo, yhi = sol.y_events
    ylo, t_lo = ylo[t_lo > 0.0], t_lo[t_lo > 0.0]
    yhi, t_hi = yhi[t_hi > 0.0], t_hi[t_hi > 0.0]
    if len(ylo) < 2 or len(yhi) < 1:
        raise RuntimeError(f"too few turning points before t_max = {t_max}: {sol.t_events}")
    E0, lam0, D0 = integrals(top, y0[:6])
    ys = np.concatenate([ylo[:, :6], yhi[:, :6], sol.y[:6, -1:].T]).T
    E, lam, D = integrals(top, ys)
    # Relative changes (absolute ones where the integral is zero, e.g. λ = D = 0 without spin).
    drift = {
        "E": float(np.max(np.abs(E - E0)) / (abs(E0) or 1.0)),
        "lam": float(np.max(np.abs(lam - lam0)) / (abs(lam0) or 1.0)),
        "D": float(np.max(np.abs(D - D0)) / (abs(D0) or 1.0)),
        "E_abs": float(np.max(np.abs(E - E0))),
    }
    return RollingRun(
        t_low=t_lo,
        z_low=ylo[:, 2],
        t_high=t_hi,
        z_high=yhi[:, 2],
        phi_low=ylo[:, 6] if track_phi else None,
        y0=y0[:6],
        y_end=sol.y[:6, -1],
        drift=drift,
        nfev=sol.nfev,
        t_samples=sol.t if t_eval is not None else np.empty(0),
        y_samples=sol.y[:6] if t_eval is not None else np.empty((6, 0)),
    )
