"""Gyroscopic-balance reduction of the gliding tippe top (Moffatt & Shimomura 2002; Ueda, Sasaki &
Watanabe 2005) with the Jellett integral, as a one-dimensional slow flow of the mean inclination.

The derivation is on docs/theory/inversion.md. In short: on the slow time scale the centre of mass
is horizontally at rest and the axis precesses steadily at the fast rate, so the state at each
inclination θ is the fast steady precession of the frictionless top with the given λ:

    R I1 (1 − α cos θ) φ̇² − λ φ̇ + m g R² α (α − cos θ) = 0   (fast root),
    I3 ω3 = I1 φ̇ cos θ − m g R α / φ̇,

(the θ̈ = 0 condition of the Euler-angle equations with θ̇ = 0, g_n = m g, and λ = −L·a). Friction
dissipates the energy E(θ) of that state at the rate P = −F_t·v_A, v_A = R sin θ (ω3 + φ̇ (α −
cos θ)) ŷ, while λ is conserved (any force at the contact point), so

    dθ/dt = −P(θ) / E'(θ).

Its fixed points are the tumbling states (v_A = 0); near θ = 0 it grows like e^{σ t} with σ the
linear growth rate of the upright spin (checked in tests/test_inversion.py).
"""

from __future__ import annotations

import math

import numpy as np

from ..friction import Coulomb, RegularisedCoulomb, Viscous
from ..potential import d as _d_of_z
from ..top import TippeTop


class NoBalance(Exception):
    """The fast steady precession does not exist at this inclination (spin too low)."""

    def __init__(self, theta: float) -> None:
        super().__init__(theta)
        self.theta = theta


def balance_state(top: TippeTop, lam, theta):
    """Fast steady precession (φ̇, ω3, E, v_A, ω_n) at inclination θ with Jellett integral λ.

    Complex-safe (used with a complex step for dE/dθ). Returns NaN where the discriminant of the
    precession quadratic is negative.
    """
    m, R, a, I1, I3, g = top.m, top.R, top.alpha, top.I1, top.I3, top.g
    c = np.cos(theta)
    s = np.sin(theta)
    A = R * I1 * (1.0 - a * c)
    C = m * g * R * R * a * (a - c)
    disc = lam * lam - 4.0 * A * C
    # The fast root, written without cancellation: 2C/(λ − √disc) = (λ + √disc)/(2A).
    phidot = (lam + np.sqrt(disc)) / (2.0 * A)
    omega3 = (I1 * phidot * c - m * g * R * a / phidot) / I3
    E = 0.5 * I1 * phidot**2 * s**2 + 0.5 * I3 * omega3**2 + m * g * R * (1.0 - a * c)
    nu = R * s * (omega3 + phidot * (a - c))
    omega_n = phidot * s**2 + omega3 * c
    return phidot, omega3, E, nu, omega_n


def friction_rates(law, top: TippeTop, nu, omega_n):
    """Power lost P ≥ 0 (W) and drilling torque M about ẑ (N m) of ``law`` at slip ``nu``.

    Vectorised over ``nu``. g_n = m g in the balance state (the CM height is constant).
    """
    gn = top.m * top.g
    nu = np.asarray(nu, dtype=float)
    zero = np.zeros_like(nu)
    if isinstance(law, Viscous):
        mu = top.mu if law.mu is None else law.mu
        return mu * gn * nu * nu, zero
    if isinstance(law, RegularisedCoulomb):
        return law.mu * gn * nu * nu / np.sqrt(nu * nu + law.eps**2), zero
    if isinstance(law, Coulomb) and law.contensou_radius == 0.0:
        return law.mu * gn * np.abs(nu), zero
    raise TypeError(f"friction law {law!r} is not covered by the gyroscopic-balance flow")


def flow_rate(top: TippeTop, lam: float, law, theta):
    """dθ/dt = −P(θ)/E'(θ) of the balance flow (1/s), vectorised; NaN where no balance exists."""
    return _flow_rate_and_state(top, lam, law, np.asarray(theta, dtype=float))[0]


def _flow_rate_and_state(top: TippeTop, lam: float, law, theta: np.ndarray):
    """(dθ/dt, the balance state at θ): the state is reused for D and Ẽ along the path."""
    h = 1e-30
    # Complex step: E'(θ) to machine precision, no cancellation near θ = 0 or π.
    E_th = balance_state(top, lam, theta + 1j * h)[2].imag / h
    state = balance_state(top, lam, theta)
    P, _ = friction_rates(law, top, state[3], 0.0)
    return -P / E_th, state


def slow_path(top: TippeTop, lam: float, law, theta_from: float, theta_to: float, n: int = 1025):
    """Times t(θ) along the balance flow from ``theta_from`` to ``theta_to`` (quadrature).

    With λ conserved the flow is autonomous in θ alone, so t(θ) = ∫ dθ / θ̇(θ), written in
    s = ln tan(θ/2) (dθ = sin θ ds), where the integrand sin θ / θ̇ stays bounded at both the
    upright (θ̇ ∝ θ) and the inverted or tumbling end (θ̇ ∝ θ_end − θ). Cumulative Simpson on a
    uniform grid in s: relative error O(h⁴), h = Δs/(n − 1) (1e-12 at the end point for the
    thesis top with n = 1025; reading t at π/2 by linear interpolation adds O(h²), 5e-7 there).
    Returns (t, θ, the balance state along θ: see :func:`balance_state`); raises NoBalance
    at the first θ where the fast precession does not exist, ValueError if the flow runs
    backwards (the top does not move towards ``theta_to``).
    """
    from scipy.integrate import cumulative_simpson

    s = np.linspace(math.log(math.tan(0.5 * theta_from)), math.log(math.tan(0.5 * theta_to)), n)
    theta = 2.0 * np.arctan(np.exp(s))
    rate, state = _flow_rate_and_state(top, lam, law, theta)
    bad = ~np.isfinite(rate)
    if bad.any():
        raise NoBalance(float(theta[np.argmax(bad)]))
    if np.any(rate * np.sign(theta_to - theta_from) <= 0.0):
        raise ValueError("the balance flow does not move towards the end state")
    t = cumulative_simpson(np.sin(theta) / rate, x=s, initial=0.0)
    return t, theta, state


def balance_D_and_E_mod(top: TippeTop, lam, theta: np.ndarray, state=None):
    """Routh integral D = I3 ω3 √d(z) and modified energy Ẽ = E + ½ m v_A² of the balance state.

    With the centre of mass at rest v_A = ω × a, and Ẽ = E + ½ m |ν|² − m ν·ṙ (docs/theory/equations.md#integrals).
    ``state``: :func:`balance_state` at (λ, θ) if already computed.
    """
    _, omega3, E, nu, _ = balance_state(top, lam, theta) if state is None else state
    z = np.cos(theta)
    D = top.I3 * omega3 * np.sqrt(_d_of_z(top, z))
    return D, E + 0.5 * top.m * nu**2
