"""A candidate reduction of the hopping top, NOT used by predict_inversion (docs/theory/inversion.md#the-hopping-top).

It is kept as the measured dead end it is: on the verification table it stalls the flow of most
hopping tops (median error of t_half after hops 9.8 % → 39 %), because the hop period it
assumes, the linear nutation period, is within 1–5 % of a precession turn, where the map below
absorbs the whole slip; the simulated hop cycles are 0.8–1.15 turns and their landing slip
keeps 0.4–0.8 of w (viscous). What it gets right: the continuous limit (T → 0 gives the
gliding flow's power) and the direction of the effect; given the simulated hop period it puts
the slip after a landing within 0.2 w of the simulated one on cases 3, 8, 16 and 17, but up to
0.5 w off on cases 13, 30 and 36 (the friction of the contact phase between landings, omitted
here, is the likely missing term).

Past the lift-off (``t_lift``, :mod:`mett.inversion._nutation`) a top whose nutation is unstable
under friction hops once per nutation period T = 2π/ω_n and lands perfectly inelastically. The
time-averaged normal force stays m g (the centre of mass does not drift vertically), but most of
it is delivered in the landing impulses, once per hop, and between two landings the friction is
nearly absent. The contact point's slip v_A then does not take the continuous answer of
:func:`mett.inversion._gyroscopic.cm_slip2`; it follows a map from landing to landing. In the
frame that precesses with the balance state (complex notation in the horizontal plane):

* in the air (and, first order, while the force is small) no friction acts, the centre of mass
  keeps its lab velocity ṙ, which turns at −φ̇ in the precessing frame, so v_A − w does:
  v_A(T⁻) = w + (v_A(0⁺) − w) ρ, ρ = exp(−i φ̇ T);
* the landing carries the normal impulse of a whole hop cycle, P_n = m g T, and the friction
  impulse along the slip reduces its size from u⁻ to u⁺ at the contact point's inverse mass K/m
  (K = 1 + m R² (1 − α cos θ)²/I1, as in ``cm_slip2``): du/dP_n = −(K/m) c(u) u/g_n with the
  law's c/g_n. Viscous: u⁺ = u⁻ e^{−q}, q = K μ g T. Regularised Coulomb: G(u⁺) = G(u⁻) − K μ g T
  with G(u) = √(u² + ε²) + ε ln(u/(ε + √(u² + ε²))). The slip keeps its direction.

The periodic landing slip is the fixed point v⁻ = w (1 − ρ)/(1 − s ρ), s = u⁺/u⁻, and each
landing dissipates W = m (u⁻² − u⁺²)/(2K) (the friction impulse removes the slip's share of
kinetic energy; the normal part of the impact removes the vertical motion, the nutation's energy,
which the unstable nutation draws back from the spin: it is the limit cycle's own budget and
does not move θ̄ at first order). Over a cycle the centre of mass's kinetic energy returns
(v_A and ṙ repeat in the precessing frame), so the balance state loses P_hop = W/T and

    dθ̄/dt = −P_hop(θ̄)/E'(θ̄).

For T → 0 (continuous contact) P_hop → c |v_A|² of ``cm_slip2``; a hop per precession turn
(φ̇ T → 2π) lets the centre of mass absorb the slip (v⁻ → 0) and the flow stalls. The
period is the nutation's, T = 2π/ω_n, ω_n the frequency of the fast eigenvalue of the
frictionless balance state other than the drift i φ̇ (:func:`mett.inversion._nutation._fast_spectra`;
it is the Routh-reduced frequency √(U''/M)).
"""

from __future__ import annotations

import math

import numpy as np

from ..friction import RegularisedCoulomb, Viscous
from ..top import TippeTop
from ._gyroscopic import balance_state, flow_rate

__all__ = ["hop_period", "hop_power", "hopping_times", "slowdown"]


def hop_period(top: TippeTop, lam: float, theta) -> np.ndarray:
    """The nutation period T = 2π/ω_n (s) of the frictionless balance state at ``theta``.

    ω_n is the frequency of the fast eigenvalue that is not the centre of mass's drift (exactly
    i φ̇ without friction) in the frame precessing with the state (vectorised over ``theta``).
    """
    from . import _compiled  # numba, at the first prediction only
    from ._gyroscopic import top_array

    theta = np.atleast_1d(np.asarray(theta, dtype=float))
    top_a = top_array(top)
    phidot = np.real(balance_state(top, lam, theta)[0])
    out = np.empty(theta.shape)
    for k, th in enumerate(theta.tolist()):
        a, b = _compiled.spectrum(th, float(lam), top_a, _compiled.VISCOUS, 0.0, 0.0)
        nut = a if abs(a - 1j * phidot[k]) >= abs(b - 1j * phidot[k]) else b
        out[k] = 2.0 * math.pi / abs(nut.imag)
    return out


def _G(u, eps):
    """∫ √(u² + ε²)/u du: the regularised law's slip against the normal impulse (module doc)."""
    r = np.sqrt(u * u + eps * eps)
    return r + eps * np.log(u / (eps + r))


def _after(law, top: TippeTop, u, q_mu):
    """|v_A| after the landing impulse from ``u`` before it; ``q_mu`` = K g T (m/s)."""
    if isinstance(law, Viscous):
        mu = top.mu if law.mu is None else law.mu
        return u * math.exp(-mu * q_mu)
    # regularised Coulomb: G(u⁺) = G(u⁻) − μ K g T, G increasing from −∞: bisection in ln u
    target = _G(u, law.eps) - law.mu * q_mu
    lo, hi = math.log(u) - 50.0, math.log(u)
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        if _G(math.exp(mid), law.eps) < target:
            lo = mid
        else:
            hi = mid
    return math.exp(0.5 * (lo + hi))


def hop_power(top: TippeTop, law, lam: float, theta, T=None):
    """(P_hop, |v⁻|) at ``theta``: the power (W) the landings take from the balance state and the
    slip (m/s) at touchdown of the periodic hop cycle (module doc); vectorised over ``theta``.

    ``T``: the hop period (s) at ``theta``, :func:`hop_period` if None.
    """
    if not isinstance(law, (Viscous, RegularisedCoulomb)):
        raise TypeError(f"friction law {law!r} is not covered by the hopping flow")
    theta = np.atleast_1d(np.asarray(theta, dtype=float))
    T = hop_period(top, lam, theta) if T is None else np.atleast_1d(np.asarray(T, dtype=float))
    phidot, _, _, w, _ = (np.real(x) for x in balance_state(top, lam, theta))
    K = 1.0 + top.m * top.R**2 * (1.0 - top.alpha * np.cos(theta)) ** 2 / top.I1
    P = np.empty(theta.shape)
    slip = np.empty(theta.shape)
    for k in range(theta.size):
        rho = complex(math.cos(phidot[k] * T[k]), -math.sin(phidot[k] * T[k]))
        wk = abs(w[k])
        q_mu = K[k] * top.g * T[k]
        # fixed point u = |w| |1 − ρ|/|1 − s(u) ρ|; s(u) = u⁺/u rises with u (viscous: constant)
        u = wk
        for _ in range(200):
            s = _after(law, top, u, q_mu) / u if u > 0.0 else 0.0
            new = wk * abs(1.0 - rho) / abs(1.0 - s * rho)
            if abs(new - u) <= 1e-13 * max(wk, 1e-300):
                u = new
                break
            u = new
        up = _after(law, top, u, q_mu) if u > 0.0 else 0.0
        slip[k] = u
        P[k] = top.m * (u * u - up * up) / (2.0 * K[k] * T[k])
    return P, slip


def slowdown(top: TippeTop, law, lam: float, theta) -> np.ndarray:
    """S = θ̇_contact/θ̇_hop = P_contact/P_hop ≥ 0 at ``theta``: how much slower the hopping
    top's balance flow runs than the gliding one's (inf where the landings dissipate nothing)."""
    theta = np.atleast_1d(np.asarray(theta, dtype=float))
    h = 1e-30  # complex step: E'(θ) to rounding, as in the balance flow
    E_th = balance_state(top, lam, theta + 1j * h)[2].imag / h
    P_c = -flow_rate(top, lam, law, theta) * E_th
    P_h, _ = hop_power(top, law, lam, theta)
    with np.errstate(divide="ignore"):
        return P_c / P_h


def hopping_times(top: TippeTop, law, lam: float, t, theta, t_lift: float) -> np.ndarray:
    """The slow path's times with the hops from ``t_lift`` on: t → t_lift + ∫ S dt.

    ``t``, ``theta``: the gliding balance path (nodes, increasing t); ``t_lift``: the predicted
    first lift-off. Nodes before it keep their times exactly; after it dt_hop = S dt
    (:func:`slowdown`), integrated by the trapezoid rule on the nodes (O(h²) in the node spacing,
    h ≤ 0.1 in ln tan(θ/2): well below the reduction's own error).
    """
    t = np.asarray(t, dtype=float)
    theta = np.asarray(theta, dtype=float)
    out = t.copy()
    if not math.isfinite(t_lift) or t_lift >= t[-1]:
        return out
    after = np.flatnonzero(t > t_lift)
    th_lift = float(np.interp(t_lift, t, theta))
    tt = np.r_[t_lift, t[after]]
    S = slowdown(top, law, lam, np.r_[th_lift, theta[after]])
    out[after] = t_lift + np.cumsum(0.5 * (S[1:] + S[:-1]) * np.diff(tt))
    return out
