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
from scipy.integrate import solve_ivp

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


def _dE(top: TippeTop, lam: float, theta: float) -> tuple[float, float]:
    # Complex step: dE/dθ and dE/dλ to machine precision, no cancellation near θ = 0.
    h = 1e-30
    dth = balance_state(top, lam, complex(theta, h))[2].imag / h
    dlam = balance_state(top, complex(lam, h * max(lam, 1e-300)), theta)[2].imag / (
        h * max(lam, 1e-300)
    )
    return float(dth), float(dlam)


def friction_rates(law, top: TippeTop, nu: float, omega_n: float) -> tuple[float, float]:
    """Power lost P ≥ 0 (W) and drilling torque M about ẑ (N m) of ``law`` at slip ``nu``.

    g_n = m g in the balance state (the centre of mass neither rises nor falls on average).
    """
    gn = top.m * top.g
    if isinstance(law, Viscous):
        mu = top.mu if law.mu is None else law.mu
        return mu * gn * nu * nu, 0.0
    if isinstance(law, RegularisedCoulomb):
        return law.mu * gn * nu * nu / math.sqrt(nu * nu + law.eps**2), 0.0
    if isinstance(law, Coulomb):
        rs = law.r_star
        norm = math.sqrt(nu * nu + (rs * omega_n) ** 2)
        if norm == 0.0:
            return 0.0, 0.0
        return law.mu * gn * norm, -law.mu * gn * rs * rs * omega_n / norm
    raise TypeError(f"friction must be a mett.friction law; got {type(law).__name__}")


def slow_flow(
    top: TippeTop,
    lam: float,
    law,
    theta0: float,
    t_end: float,
    events_at: dict[str, float],
):
    """Integrate the balance flow from θ(0) = theta0 over [0, t_end].

    ``events_at`` maps names to inclinations; returns (solution, {name: first time or inf}).
    Raises NoBalance where the fast precession ceases to exist.
    """
    R, a = top.R, top.alpha

    def rhs(t, y):
        th, la = float(y[0]), float(y[1])
        _, _, _, nu, wn = balance_state(top, la, th)
        if not math.isfinite(nu):
            raise NoBalance(th)
        P, M = friction_rates(law, top, float(nu), float(wn))
        # λ̇ = −(M ẑ)·a = M R (1 − α cos θ): only a drilling torque changes Jellett's integral.
        lamdot = M * R * (1.0 - a * math.cos(th))
        dth, dla = _dE(top, la, th)
        return [(-P - dla * lamdot) / dth, lamdot]

    evs = []
    names = list(events_at)
    for name in names:
        target = events_at[name]

        def ev(t, y, target=target):
            return y[0] - target

        evs.append(ev)
    sol = solve_ivp(
        rhs,
        (0.0, t_end),
        [theta0, lam],
        method="LSODA",
        rtol=1e-9,
        atol=[1e-12 * max(theta0, 1e-300), 1e-14 * lam],
        events=evs,
        dense_output=False,
    )
    times = {}
    for name, te in zip(names, sol.t_events, strict=True):
        times[name] = float(te[0]) if len(te) else math.inf
    return sol, times


def balance_D_and_E_mod(top: TippeTop, lam: np.ndarray, theta: np.ndarray):
    """Routh integral D = I3 ω3 √d(z) and modified energy Ẽ = E + ½ m v_A² of the balance state.

    With the centre of mass at rest v_A = ω × a, and Ẽ = E + ½ m |ν|² − m ν·ṙ (theory §3).
    """
    _, omega3, E, nu, _ = balance_state(top, lam, theta)
    z = np.cos(theta)
    D = top.I3 * omega3 * np.sqrt(_d_of_z(top, z))
    return D, E + 0.5 * top.m * nu**2
