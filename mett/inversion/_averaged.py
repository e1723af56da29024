"""The averaged METT flow: the slow evolution of (D, Ẽ) averaged over the nutation band of
V(z, D, λ) (docs/theory/inversion.md#the-averaged-mett-flow).

Between two slow steps the top is taken to move in the band of the METT, Ẽ = g(z) θ̇² + V(z, D, λ),
with (Ẽ, D, λ) frozen, and its centre of mass horizontally at rest on average, so that the contact
point slips with ν = (ω × a)_h: ν_x = −R θ̇ (1 − α z), ν_y = R sin θ (ω3 + φ̇ (α − z)). Friction
F_t = −c(|ν|) g_n ν (c = μ for the viscous law, μ/√(|ν|² + ε²) for the regularised Coulomb law) then
changes the integrals at the rates (docs/theory/equations.md#integrals)

    dẼ/dt = m ν̇·(ω × a) = −c g_n |ν|² + d/dt(½ m |ω × a|²),
    dD/dt = I3 ω̇3 √d + I3 ω3 d√d/dt = −c g_n R ν_y sin θ √d(z) + D d(ln √d)/dt,

whose last terms are derivatives of functions of the band's phase: they vanish on averaging over
one nutation period at frozen (Ẽ, D). The slow flow is therefore

    dD̄/dt = −⟨c g_n R ν_y sin θ √d⟩,   dẼ̄/dt = −⟨c g_n |ν|²⟩,   λ constant,

with ⟨·⟩ the time average over the band (:func:`mett.separation.band_average`, the exact period's
quadrature), g_n = m g + m R α (θ̈ sin θ + θ̇² cos θ) from the METT's θ̈. Where the band collapses
(Ẽ reaches min V) the flow slides along steady precession at the bottom of the well (:func:`rates`).
"""

from __future__ import annotations

import math

import numpy as np

from .. import _formulas as fm
from ..friction import RegularisedCoulomb, Viscous
from ..potential import V, dV_dz
from ..separation import band_average, minima
from ..top import TippeTop


def _band_functions(top: TippeTop, law, D: float, Et: float, lam: float):
    """F(z) for :func:`band_average`: rows (c g_n |ν|², c g_n R ν_y sin θ √d, θ, z)."""
    m, R, a, I1, I3, g = top.m, top.R, top.alpha, top.I1, top.I3, top.g
    if isinstance(law, Viscous):
        mu, eps = (top.mu if law.mu is None else law.mu), None
    elif isinstance(law, RegularisedCoulomb):
        mu, eps = law.mu, law.eps
    else:  # pragma: no cover - predict_inversion refuses other laws first
        raise TypeError(f"the averaged flow has no rate for {law!r}")
    gp = -top.sigma * a * I3  # g'(z)

    def F(z):
        z = np.clip(z, -1.0, 1.0)
        s2 = (1.0 - z) * (1.0 + z)
        s = np.sqrt(s2)
        sqd = np.sqrt(fm.d(top, z))
        gz = fm.g(top, z)
        omega3 = D / (I3 * sqd)
        n = lam * sqd + R * D * (a - z)
        with np.errstate(divide="ignore", invalid="ignore"):
            # φ̇ sin θ = N/(R I1 sin θ √d): 0 at a pole (N vanishes there on a band reaching it)
            phis = np.where(s > 0.0, n / (R * I1 * s * sqd), 0.0)
        th2 = np.maximum(Et - V(top, z, D, lam), 0.0) / gz
        nu_y = R * (s * omega3 + phis * (a - z))
        nu2 = R * R * (1.0 - a * z) ** 2 * th2 + nu_y * nu_y
        thdd_s = s2 * (dV_dz(top, z, D, lam) + gp * th2) / (2.0 * gz)  # θ̈ sin θ
        gn = m * g + m * R * a * (thdd_s + th2 * z)
        c = mu if eps is None else mu / np.sqrt(nu2 + eps * eps)
        return np.stack([c * gn * nu2, c * gn * R * nu_y * s * sqd, np.arccos(z), z], axis=0)

    return F


def rates(top: TippeTop, law, lam: float, D: float, Et: float, z0: float | None = None):
    """(dD̄/dt, dẼ̄/dt, ⟨θ⟩, ⟨z⟩, band, T) of the averaged flow at (D, Ẽ).

    Where friction has emptied the band (Ẽ at or below min V(·, D, λ), a single well) the top
    precesses steadily at the bottom z_m of the well and slides along that branch (Filippov):
    Ẽ = V(z_m, D, λ), dẼ/dt = max(−⟨c g_n |ν|²⟩, ∂V/∂D (z_m) dD/dt) (the envelope theorem gives
    d min V/dD = ∂V/∂D at z_m); the band reopens where dissipation falls behind the well.
    """
    try:
        b, T, avg = band_average(top, Et, D, lam, _band_functions(top, law, D, Et, lam), z0)
        return -avg[1], -avg[0], avg[2], avg[3], b, T
    except ValueError as exc:
        if "admits no motion" not in str(exc):
            raise
        zs = minima(top, D, lam)
        if len(zs) != 1:
            raise
    zm = float(zs[0])
    Em = float(V(top, zm, D, lam))
    b, T, avg = band_average(top, Em, D, lam, _band_functions(top, law, D, Em, lam), zm)
    dD = -avg[1]
    R, I1, I3, a = top.R, top.I1, top.I3, top.alpha
    n = lam * math.sqrt(float(fm.d(top, zm))) + R * D * (a - zm)
    dV_dD = n * (a - zm) * I3 / (I1 * I1 * R * (1.0 - zm * zm)) + D / I1
    return dD, max(-avg[0], dV_dD * dD), avg[2], avg[3], b, T


class AveragingFails(Exception):
    """The band of V(z, D̄, λ) cannot be followed (several wells, a separatrix, no motion)."""


def slow_path(top: TippeTop, law, lam: float, D0: float, E0: float, z0: float, theta_to: float,
              t_max: float, rtol: float = 1e-6):  # fmt: skip
    """Integrate the averaged flow from (D0, Ẽ0) (the band holding z0) until ⟨θ⟩ = ``theta_to``.

    Returns (t, ⟨θ⟩, D̄, Ẽ̄, t_half, t_end, T_band at the start): arrays at the solver's steps, the
    times ⟨θ⟩ passes π/2 and ``theta_to`` (inf if not by ``t_max``). Explicit Runge–Kutta 4(5)
    (scipy's RK45) with relative tolerance ``rtol`` on (D̄, Ẽ̄): the flow is smooth and non-stiff
    (its rates are O(μ g) relative), so its error is rtol-sized. Raises AveragingFails where the
    band cannot be followed.
    """
    from scipy.integrate import solve_ivp

    last = [z0]
    # The events and the returned ⟨θ⟩ ask for the rates at the step ends, where RK45 (FSAL) has
    # already evaluated them: each band quadrature is done once per point (a third of the cost).
    cache: dict[tuple[float, float], tuple] = {}

    def evaluate(y):
        key = (float(y[0]), float(y[1]))
        if key not in cache:
            cache[key] = _evaluate(y)
        return cache[key]

    def _evaluate(y):
        try:
            out = rates(top, law, lam, float(y[0]), float(y[1]))
        except ValueError as exc:
            if "several" not in str(exc):
                raise AveragingFails(str(exc)) from None
            try:  # V has several wells: the one holding the last mean inclination
                out = rates(top, law, lam, float(y[0]), float(y[1]), last[0])
            except ValueError as exc2:
                raise AveragingFails(str(exc2)) from None
        if not math.isfinite(out[5]):
            raise AveragingFails("the band reaches a separatrix (infinite period)")
        last[0] = float(out[3])
        return out

    def rhs(t, y):
        r = evaluate(y)
        return [r[0], r[1]]

    def half(t, y):
        return evaluate(y)[2] - 0.5 * math.pi

    def end(t, y):
        return evaluate(y)[2] - theta_to

    end.terminal = True  # type: ignore[attr-defined]
    T0 = evaluate([D0, E0])[5]
    scale = [abs(D0), abs(E0)]
    sol = solve_ivp(rhs, (0.0, t_max), [D0, E0], method="RK45", rtol=rtol,
                    atol=[1e-9 * scale[0], 1e-9 * scale[1]], events=(half, end))  # fmt: skip
    if sol.status < 0:
        raise AveragingFails(sol.message)
    theta = np.array([evaluate(y)[2] for y in sol.y.T])
    t_half = float(sol.t_events[0][0]) if len(sol.t_events[0]) else math.inf
    t_end = float(sol.t_events[1][0]) if len(sol.t_events[1]) else math.inf
    return sol.t, theta, sol.y[0], sol.y[1], t_half, t_end, T0
