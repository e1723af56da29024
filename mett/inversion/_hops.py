"""The hopping top: the balance flow after the nutation lifts it off (docs/theory/inversion.md#the-hopping-top).

Past the lift-off (``t_lift``, :mod:`mett.inversion._nutation`) a top whose nutation is unstable
under friction hops about once per precession turn, spends 53–77 % of its time in the air and
lands perfectly inelastically. Measured on the verification table's hopping tops, its mean
inclination still follows its energy through the balance state, E ≈ E_bal(θ̄) (the nutation's
share stays within 2.7 mJ against 6–46 mJ spent over a span), and λ is conserved (any force or impulse at the
contact point, and the free flight, keep it). What changes is the power friction takes:

    dθ̄/dt = −⟨P⟩_hop(θ̄)/E'(θ̄) = (dθ̄/dt)_gliding / S(θ̄),   S = P_gliding/⟨P⟩_hop,

with S between 1.0 and 2.8 on those tops. S is not the time in the air: the time-averaged normal
force stays m g (the centre of mass does not drift vertically), the landings and the short
contact phases carry it, and the friction acts there with a slip that the hop cycle's phase
makes smaller than the gliding one (its square 0.33–0.9 of w², g_n-weighted). That cycle is strongly
nonlinear (the top flies most of the time, g_n reaches 2.8 m g in contact), so ⟨P⟩_hop is not
written in closed form here: it is **measured on the cycle itself**, by short simulations of the
full model with flight and landing at a few inclinations (the heterogeneous multiscale method:
Engquist & E, Commun. Math. Sci. 1 (2003) 87; E et al., Commun. Comput. Phys. 2 (2007) 367):

* start: the balance state at θ (λ, the fast precession φ̇ and ω3 of
  :func:`mett.inversion._gyroscopic.balance_state`, the centre of mass at rest) with a nutation
  at the lift-off threshold of the linear criterion, a kick θ̇ = Θ ω_n with l ω_n² Θ sin θ = g
  (ω_n the frictionless nutation frequency, the fast eigenvalue other than the drift i φ̇);
* run :data:`TURNS` precession turns; the hop cycle forgets its start within a few (checked on
  40-turn runs: starts at once and twice the threshold give ratios within 0.04 on cases 13, 16,
  30 and 36);
* ⟨P⟩_hop: the slope of a straight-line fit of the energy at the lift-offs of the second half of
  the window (a lift-off is the same phase of every cycle; the energy is continuous there), and
  P_gliding at the mean θ of that span, where the flow has moved to.

S is interpolated linearly in θ between :data:`NODES` such windows spread from the lift-off to
π/2 (held constant beyond), and the path's times after ``t_lift`` become t_lift + ∫ S dt. A
window with fewer than 4 lift-offs (the nutation decays: no hop cycle there) has S = 1.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from .._validate import MettWarning
from ..friction import RegularisedCoulomb, Viscous
from ..integrals import energy_of
from ..state import State
from ..top import TippeTop
from ._gyroscopic import balance_state, flow_rate, top_array

__all__ = ["NODES", "RTOL", "TURNS", "cycle_power_ratio", "hopping_times"]

TURNS = 12
"""Precession turns per window: a few to forget the start, the second half for the fit (6 hops)."""

NODES = 4
"""Windows between the lift-off and π/2."""

RTOL = 1e-6
"""Relative tolerance of the windows' runs: the fit needs the energy to 1e-3 of its change per
window (a few per cent of E), far above this."""


def _nutation_frequency(top: TippeTop, lam: float, theta: float, phidot: float) -> float:
    """ω_n (rad/s): the frictionless fast eigenvalue at the balance state other than i φ̇."""
    from . import _compiled  # numba, at the first prediction only

    a, b = _compiled.spectrum(theta, float(lam), top_array(top), _compiled.VISCOUS, 0.0, 0.0)
    return abs((a if abs(a - 1j * phidot) >= abs(b - 1j * phidot) else b).imag)


def cycle_power_ratio(top: TippeTop, law, lam: float, theta: float, turns: int = TURNS,
                      rtol: float = RTOL) -> tuple[float, float, int]:  # fmt: skip
    """⟨P⟩_hop/P_gliding of the hop cycle started at the balance state at ``theta`` (module doc).

    Returns (ratio, the mean θ of the fitted span (rad), the number of lift-offs in the window);
    (1, θ, n) where the window has fewer than 4 lift-offs.
    """
    from ..dynamics import simulate

    if not isinstance(law, (Viscous, RegularisedCoulomb)):
        raise TypeError(f"friction law {law!r} is not covered by the hopping flow")
    phidot, omega3 = (float(np.real(x)) for x in balance_state(top, lam, theta)[:2])
    w_n = _nutation_frequency(top, lam, theta, phidot)
    l = top.R * top.alpha
    amp = top.g / (l * w_n * w_n * math.sin(theta))  # the linear lift-off threshold
    start = State.with_cm_at_rest(top, theta=theta, omega3=omega3, thetadot=amp * w_n,
                                  phidot=phidot)  # fmt: skip
    with warnings.catch_warnings():
        # an internal run: its trouble shows in its result (too few lift-offs, no energy lost),
        # and the viscous law's artefact is flagged by the prediction on its own path
        warnings.simplefilter("ignore", MettWarning)
        traj = simulate(top, start, turns * 2.0 * math.pi / phidot, friction=law, rtol=rtol,
                        stop_on_contact_loss=False)  # fmt: skip
    lifts = np.array([s.t for s in traj.records.get("switches", []) if s.reason == "lift-off"])
    if len(lifts) < 4:
        return 1.0, float(theta), len(lifts)
    fit = lifts[len(lifts) // 2 :]
    s = traj.at(fit)
    E = energy_of(s.theta, s.thetadot, s.phidot, s.omega3, s.nu_x, s.nu_y, top.m, top.R, l,
                  top.I1, top.I3, top.g)  # fmt: skip
    slope = float(np.polyfit(fit, E, 1)[0])
    mean_theta = float(np.mean(traj.theta_at(np.linspace(fit[0], fit[-1], 64))))
    h = 1e-30  # complex step: E'(θ) to rounding, as in the balance flow
    E_th = float(balance_state(top, lam, mean_theta + 1j * h)[2].imag / h)
    P_gliding = -float(flow_rate(top, lam, law, np.array([mean_theta]))[0]) * E_th
    return -slope / P_gliding, mean_theta, len(lifts)


def hopping_times(top: TippeTop, law, lam: float, t, theta, t_lift: float,
                  nodes: int = NODES) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
    """The slow path's times with the hops from ``t_lift`` on, t → t_lift + ∫ S dt.

    ``t``, ``theta``: the gliding balance path (increasing t, θ moving towards its end); nodes
    at or before ``t_lift`` keep their times bit for bit. Returns (new times, the windows' θ,
    their S); the times unchanged and S nan where a window does not lose energy. The trapezoid rule on the path's nodes (steps ≤ 0.1 in ln tan(θ/2)) integrates the
    piecewise-linear S with an error far below the windows' own (a few per cent).
    """
    t = np.asarray(t, dtype=float)
    theta = np.asarray(theta, dtype=float)
    out = t.copy()
    if not t_lift < t[-1]:
        return out, np.empty(0), np.empty(0)
    th_lift = float(np.interp(t_lift, t, theta)) if t_lift > t[0] else float(theta[0])
    th_to = 0.5 * math.pi if theta[-1] > 0.5 * math.pi else float(theta[-1])
    starts = [th_lift + k * (th_to - th_lift) / nodes for k in range(nodes)]
    windows = [cycle_power_ratio(top, law, lam, th) for th in starts]
    where = np.array([w[1] for w in windows])
    ratio = np.array([w[0] for w in windows])
    if not np.all(ratio > 0.0):  # energy gained over a window, or nan: no hop flow to follow
        return out, where, np.full(len(ratio), math.nan)
    S = 1.0 / ratio
    order = np.argsort(where)
    where, S = where[order], S[order]
    after = np.flatnonzero(t > t_lift)
    tt = np.r_[max(t_lift, t[0]), t[after]]
    s_path = np.asarray(np.interp(np.r_[th_lift, theta[after]], where, S))
    out[after] = tt[0] + np.cumsum(0.5 * (s_path[1:] + s_path[:-1]) * np.diff(tt))
    return out, where, S
