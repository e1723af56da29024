"""The hopping top (docs/theory/inversion.md#the-hopping-top).

Two kinds of checks: the candidate landing-map reduction (mett.inversion._hops, not used by
predict_inversion) against closed forms and an independent integration of its landing impulse,
and the measured facts that decided against the simpler "the flow stands still in the air"
reduction, on a hopping table case simulated with flight and landing.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from mett.dynamics import simulate
from mett.dynamics.flight import ViscousArtefactWarning
from mett.friction import RegularisedCoulomb, Viscous
from mett.inversion import _hops, predict_inversion
from mett.inversion._cases import cases
from mett.inversion._gyroscopic import balance_state


@pytest.fixture(scope="module")
def case30():
    # viscous, λ/λ_thres = 6.7, θ0 = 0.12, centre of mass at rest: lifts off near θ̄ = 0.45
    return cases()[30]


def _gliding_power(top, law, lam, theta):
    """c |v_A|² of the gliding balance flow from the closed forms (independent of cm_slip2):
    viscous |v_A|² = w²/(1 + k²); regularised Coulomb x = |v_A|² the positive root of
    x² + (ε² + k² − w²) x − w² ε² = 0, k = μ g K/φ̇ (docs/theory/inversion.md, the response)."""
    phidot, _, _, w, _ = (float(np.real(x)) for x in balance_state(top, lam, theta))
    K = 1.0 + top.m * top.R**2 * (1.0 - top.alpha * math.cos(theta)) ** 2 / top.I1
    gn = top.m * top.g
    if isinstance(law, Viscous):
        mu = top.mu if law.mu is None else law.mu
        x = w * w / (1.0 + (mu * top.g * K / phidot) ** 2)
        return mu * gn * x, phidot
    k2 = (law.mu * top.g * K / phidot) ** 2
    B = law.eps**2 + k2 - w * w
    x = 2.0 * w * w * law.eps**2 / (B + math.sqrt(B * B + 4.0 * w * w * law.eps**2))
    return law.mu * gn * x / math.sqrt(x + law.eps**2), phidot


@pytest.mark.parametrize("law", [None, RegularisedCoulomb(0.3, 0.01), RegularisedCoulomb(0.3, 1.0)])
@pytest.mark.parametrize("theta", [0.3, 0.9, 1.4])
def test_short_hops_give_the_gliding_flows_power(case30, law, theta):
    # Hops much shorter than a precession turn (φ̇ T = 1e-4) and a small landing impulse: the
    # landing map's fixed point tends to the contact point's continuous answer, with a relative
    # error O(φ̇ T) + O(q), q = K μ g T / (slip scale) the impulse's relative size; 10× both.
    top = case30.top
    law = Viscous() if law is None else law
    lam = float(predict_inversion(top, case30.state).lam[0])
    P_ref, phidot = _gliding_power(top, law, lam, theta)
    T = 1e-4 / phidot
    P, _ = _hops.hop_power(top, law, lam, theta, T)
    mu_lin = top.mu if isinstance(law, Viscous) else law.mu / law.eps
    q = 2.0 * mu_lin * top.g * T  # K ≤ 2 for these tops
    assert float(P[0]) == pytest.approx(P_ref, rel=10.0 * (phidot * T + q))


def test_a_hop_per_precession_turn_lets_the_centre_of_mass_absorb_the_slip(case30):
    # φ̇ T = 2π: between landings v_A − w turns back to itself, so the only fixed point is a
    # landing without slip, and nothing is dissipated (to rounding of cos, sin at 2π).
    top = case30.top
    lam = float(predict_inversion(top, case30.state).lam[0])
    P_ref, phidot = _gliding_power(top, Viscous(), lam, 0.9)
    P, slip = _hops.hop_power(top, Viscous(), lam, 0.9, 2.0 * math.pi / phidot)
    assert abs(float(P[0])) <= 1e-12 * P_ref and float(slip[0]) <= 1e-12


@pytest.mark.parametrize("u0", [1e-4, 0.02, 0.5])
def test_regularised_landing_impulse_matches_a_direct_integration(case30, u0):
    # du/dp = −μ u/√(u² + ε²) over p = K g T (the impulse per unit mass at the contact point's
    # inverse mass): the closed form's bisection against an RK45 run at rtol 1e-11.
    top, law = case30.top, RegularisedCoulomb(0.3, 0.01)
    q_mu = 0.05  # m/s: K g T for T ≈ 4 ms
    sol = solve_ivp(lambda p, u: -law.mu * u / np.sqrt(u * u + law.eps**2), (0.0, q_mu), [u0],
                    rtol=1e-11, atol=1e-14 * u0)  # fmt: skip
    assert _hops._after(law, top, u0, q_mu) == pytest.approx(float(sol.y[0, -1]), rel=1e-8)
    # the viscous law: an exponential
    assert _hops._after(Viscous(0.3), top, u0, q_mu) == pytest.approx(u0 * math.exp(-0.3 * q_mu),
                                                                       rel=1e-15)  # fmt: skip


def test_hopping_times_move_later_after_the_lift_off_only(case30):
    # The sign of the hop correction: nodes before t_lift keep their times bit for bit, the path
    # after it is slower (the landings dissipate less than the gliding contact), and a path with
    # t_lift = inf is returned unchanged.
    pred = predict_inversion(case30.top, case30.state)
    lam = float(pred.lam[0])
    assert pred.t_lift < pred.t_half
    t_hop = _hops.hopping_times(case30.top, Viscous(), lam, pred.t, pred.theta, pred.t_lift)
    before = pred.t <= pred.t_lift
    assert np.array_equal(t_hop[before], pred.t[before])
    assert np.all(t_hop[~before] > pred.t[~before])
    same = _hops.hopping_times(case30.top, Viscous(), lam, pred.t, pred.theta, math.inf)
    assert np.array_equal(same, pred.t)


def test_the_hopping_top_is_slowed_far_less_than_its_time_in_the_air(case30):
    # Case 30 simulated with flight and landing: past its first lift-off it is in the air more
    # than half the time, and its mean inclination goes from 0.9 to 1.5 more slowly than the
    # gliding prediction, but much faster than a flow that stood still in the air (a slowdown of
    # 1/(1 − air fraction)): the landings, which carry the normal impulse m g per unit time, do
    # most of the friction's work (docs/theory/inversion.md#the-hopping-top). Margins: measured
    # slowdown 1.75 against 3.0; the mean over 8 start-nutation periods moves the bin ends by
    # ≤ 8 T_n, 2 % of the 0.33 s span.
    pred = predict_inversion(case30.top, case30.state)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ViscousArtefactWarning)
        traj = simulate(case30.top, case30.state, 1.05 * 8.647, rtol=1e-8,
                        stop_on_contact_loss=False)  # fmt: skip
    assert traj.status == "completed"
    sw = traj.records["switches"]
    lifts = np.array([s.t for s in sw if s.reason == "lift-off"])
    lands = np.array([s.t for s in sw if s.reason == "touchdown"])
    T_n = 2.0 * math.pi * case30.top.I1 / (case30.top.I3 * float(case30.state.omega3))
    t = np.arange(0.0, traj.t_final, T_n / 16.0)
    theta_bar = np.convolve(traj.theta_at(t), np.ones(128) / 128.0, mode="same")
    air = np.zeros(t.shape, dtype=bool)
    for up, down in zip(lifts, np.r_[lands, np.inf][: len(lifts)], strict=True):
        air |= (t >= up) & (t < down)
    i0, i1 = int(np.argmax(theta_bar >= 0.9)), int(np.argmax(theta_bar >= 1.5))
    assert lifts[0] < t[i0] < t[i1]
    air_fraction = float(air[i0:i1].mean())
    slowdown = (t[i1] - t[i0]) / (np.interp(1.5, pred.theta, pred.t)
                                  - np.interp(0.9, pred.theta, pred.t))  # fmt: skip
    assert air_fraction > 0.5
    assert 1.2 < slowdown < 0.8 / (1.0 - air_fraction)
