"""Simulating a tippe top with a stem through the change of contact (mett.dynamics.stem).

The body is Leine & Glocker's (2003) top (m = 6 g, R = 15 mm, αR = 3 mm, I1 = 8e-7, I3 = 7e-7 kg m²)
with μ = 0.3 s/m in the viscous law and a stem sphere of radius 5 mm whose centre lies 16 mm from the
ball's centre: the top is 15 + 16 + 5 = 36 mm tall and the stem touches down at
θ = arccos(−10/16) = 128.7°, both plausible for a toy tippe top.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg
from scipy.optimize import brentq

import mett
from mett.dynamics import simulate
from mett.dynamics.stem import SWITCH_OFFSET, _ball, _body, _stem, impact

BALL = mett.TippeTop(m=0.006, R=0.015, alpha=0.2, I1=8e-7, I3=7e-7, mu=0.3)
TOP = BALL.with_stem(radius=0.005, distance=0.016)
# close to the state of the full run from θ0 = 0.1 just before touchdown (see the slow test)
NEAR = mett.State(theta=2.15, thetadot=2.0, phidot=110.0, omega3=-76.0, nu_y=0.16)


@pytest.fixture(scope="module")
def near():
    return simulate(TOP, NEAR, 1.0)


def _segments(tr):
    """(start, end) sample indices of each stretch on one contact."""
    edges = np.flatnonzero(tr.contact[1:] != tr.contact[:-1]) + 1
    starts = np.concatenate(([0], edges))
    ends = np.concatenate((edges, [tr.t.size]))
    return list(zip(starts, ends, strict=True))


def test_touchdown_angle_is_arccos_to_1e_9(near):
    theta_td = math.acos((TOP.radius - BALL.R) / TOP.distance)
    assert TOP.touchdown_angle == theta_td
    assert near.status == "completed", near.message
    assert near.touchdowns.size >= 1
    for t in near.touchdowns:
        # the located event, on the dense output of the ball phase just before the switch
        before = near.at(t - 1e-12 * max(t, 1.0))
        assert abs(before.theta - theta_td) < 1e-9
        # and the stem phase starts there
        assert abs(near.at(t).theta - theta_td) < 1e-9
    # the offset keeps the located touchdown within 1e-10 rad of the angle
    assert SWITCH_OFFSET * BALL.R / (TOP.distance * math.sin(theta_td)) < 1e-10


def test_contact_labels_follow_the_geometry(near):
    assert set(near.contact) == {"ball", "stem"}
    assert near.contact[0] == "ball" and near.contact[-1] == "stem"
    td = TOP.touchdown_angle
    on_ball = near.contact == "ball"
    assert np.all(near.theta[on_ball] <= td + 1e-9)
    assert np.all(near.theta[~on_ball] >= td - 1e-9)
    assert [sw.after for sw in near.switches] == ["stem", "ball"] * (len(near.switches) // 2) + (
        ["stem"] if len(near.switches) % 2 else []
    )
    # the ball phase's normal force is the ball's, the stem's the stem's: both positive
    assert np.all(near.gn > 0.0)


def test_jellett_of_the_contact_sphere_is_conserved_on_the_stem(near):
    worst = 0.0
    n_stem = 0
    for i, j in _segments(near):
        lam = near.lam[i:j]
        if near.contact[i] == "stem":
            n_stem += 1
            worst = max(worst, float(np.ptp(lam) / abs(lam[0])))
            # it is the stem sphere's integral (mett.stem.StemmedTop.stem_jellett)
            assert lam[0] == pytest.approx(TOP.stem_jellett(near.at(near.t[i])), rel=1e-12)
        else:
            # the ball's Jellett integral, conserved on the ball too
            assert float(np.ptp(lam) / abs(lam[0])) < 1e-9
    assert n_stem >= 2
    assert worst < 1e-9  # measured 1e-11


def test_energy_never_increases(near):
    E = near.E
    assert np.all(np.diff(E) <= 1e-12 * E[0])
    # and each impact dissipates: the state after the switch has less energy than before it
    for t in (sw.t for sw in near.switches):
        before = near.at(t - 1e-12)
        after = near.at(t)
        assert before.theta == pytest.approx(after.theta, abs=1e-9)
    drops = [near.E[i - 1] - near.E[i] for i, _ in _segments(near)[1:]]
    assert all(d > 0 for d in drops)


def _contact_velocity(y, p, which):
    q = _stem(p) if which == "stem" else _ball(p)
    e, _, w, V = _body(y, _stem(p) if y[10] > 0.5 else _ball(p))
    a = q[2] * e - np.array([0.0, 0.0, q[1]])
    return V + np.cross(w, a)


def _energy(y, p):
    q = _stem(p) if y[10] > 0.5 else _ball(p)
    m, g = q[0], q[6]
    e, L, w, V = _body(y, q)
    return 0.5 * m * V @ V + 0.5 * L @ w + m * g * (q[1] - q[2] * e[2])


def _reference_impulse(y, p, to):
    """The Darboux-Keller impulse solved independently: dv/dp = M v + b (M = −μ W Π, b = W ẑ) as
    a 4×4 matrix exponential, v_z(p) = 0 by brentq, P = W⁻¹ Δv."""
    q = _stem(p) if to == "stem" else _ball(p)
    m, I1, I3, mu = p[0], p[3], p[4], p[5]
    e, L, w, V = _body(y, _ball(p) if to == "stem" else _stem(p))
    a = q[2] * e - np.array([0.0, 0.0, q[1]])
    Iinv = np.eye(3) / I1 + (1 / I3 - 1 / I1) * np.outer(e, e)
    cross = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    W = np.eye(3) / m - cross @ Iinv @ cross
    M = np.zeros((4, 4))
    M[:3, :3] = -mu * W @ np.diag([1.0, 1.0, 0.0])
    M[:3, 3] = W @ np.array([0.0, 0.0, 1.0])
    v0 = np.append(V + np.cross(w, a), 1.0)

    def vz(s):
        return (scipy.linalg.expm(M * s) @ v0)[2]

    hi = -v0[2] / W[2, 2]
    while vz(hi) < 0.0:
        hi *= 2.0
    s_end = brentq(vz, 0.0, hi, xtol=1e-18, rtol=1e-14)
    v_end = (scipy.linalg.expm(M * s_end) @ v0)[:3]
    return np.linalg.solve(W, v_end - v0[:3]), V, L, a


@pytest.mark.parametrize("to", ["stem", "ball"])
def test_impact_law(near, to):
    # every impact of the run: the new contact's normal velocity is 0 after it, the old contact
    # separates, the energy does not increase, and the impulse is the Darboux-Keller one, which
    # is computed here independently (matrix exponential of the linear impulse ODE and a root)
    p = near.params
    n = 0
    for t, frm, dst in ((sw.t, sw.before, sw.after) for sw in near.switches):
        if dst != to:
            continue
        n += 1
        y = np.asarray(near._sol(t - 1e-12), dtype=float)
        y_after, P = impact(y, p, to)
        v_new = _contact_velocity(y_after, p, to)
        assert abs(v_new[2]) < 1e-12
        assert _contact_velocity(y, p, to)[2] < 0.0  # it came down
        assert _contact_velocity(y_after, p, frm)[2] > 0.0  # the other sphere lifts off
        assert _energy(y_after, p) < _energy(y, p)
        P_ref, V, L, a = _reference_impulse(y, p, to)
        np.testing.assert_allclose(P, P_ref, rtol=1e-9, atol=1e-9 * abs(P_ref[2]))
        # momentum and angular momentum balance with the impulse at the new contact
        np.testing.assert_allclose(y_after[2:4] - V[:2], P[:2] / p[0], rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(y_after[4:7] - L, np.cross(a, P), rtol=1e-12, atol=1e-18)
    assert n >= 1


@pytest.mark.parametrize("mu", [3.0, 300.0])
def test_impact_with_strong_friction_ends(mu):
    # fast tangential slip: friction first drives the contact down and the normal impulse grows
    # to hundreds of times the frictionless one before v_z reaches 0 (W positive definite)
    top = mett.TippeTop(m=0.006, R=0.015, alpha=0.2, I1=8e-7, I3=7e-7, mu=mu).with_stem(
        radius=0.005, distance=0.016
    )
    model = mett.dynamics.MODELS["stemmed"]
    p = model.parameters(top.ball, stem_radius=top.radius, stem_distance=top.distance)
    s = mett.State(theta=top.touchdown_angle - 1e-9, thetadot=3.0, nu_x=20.0)
    y = model.initial(s, p)
    y_after, P = impact(y, p, "stem")
    v = _contact_velocity(y, p, "stem")
    assert P[2] > 100.0 * -v[2] / (1.0 / p[0])  # far beyond any frictionless impulse
    assert abs(_contact_velocity(y_after, p, "stem")[2]) < 1e-12 * abs(v).max()
    assert _energy(y_after, p) < _energy(y, p)
    P_ref = _reference_impulse(y, p, "stem")[0]
    np.testing.assert_allclose(P, P_ref, rtol=1e-8, atol=1e-9 * abs(P_ref).max())


def test_frictionless_impact_is_the_closed_form():
    # μ = 0: P = −v_z/W_zz ẑ, and the energy lost is ½ v_z²/W_zz
    top = mett.TippeTop(m=0.006, R=0.015, alpha=0.2, I1=8e-7, I3=7e-7, mu=0.0).with_stem(
        radius=0.005, distance=0.016
    )
    p = mett.dynamics.MODELS["stemmed"].parameters(
        top.ball, stem_radius=top.radius, stem_distance=top.distance
    )
    s = mett.State(theta=top.touchdown_angle - 1e-12, thetadot=3.0, phidot=50.0, omega3=-70.0)
    y = mett.dynamics.MODELS["stemmed"].initial(s, p)
    assert y[10] == 0.0  # on the ball, the stem about to touch
    v = _contact_velocity(y, p, "stem")
    y_after, P = impact(y, p, "stem")
    e, _, _, _ = _body(y, _ball(p))
    a = (p[2] + p[8]) * e - np.array([0.0, 0.0, p[7]])
    # W_zz = 1/m + |a × ẑ|²/I1 (a × ẑ ⟂ 3̂)
    Wzz = 1.0 / p[0] + np.sum(np.cross(a, [0.0, 0.0, 1.0]) ** 2) / p[3]
    np.testing.assert_allclose(P, [0.0, 0.0, -v[2] / Wzz], rtol=1e-12, atol=1e-18)
    lost = _energy(y, p) - _energy(y_after, p)
    assert lost == pytest.approx(0.5 * v[2] ** 2 / Wzz, rel=1e-9)


def test_start_on_the_stem():
    s = mett.State(theta=2.6, phidot=20.0, omega3=-90.0)
    tr = simulate(TOP, s, 0.2)
    assert tr.contact[0] == "stem"
    assert tr.lam[0] == pytest.approx(float(TOP.stem_jellett(s)), rel=1e-12)
    assert tr.E[0] == pytest.approx(float(mett.energy(TOP.stem_top, s)), rel=1e-12)


def test_bad_input():
    s = mett.State(theta=0.1, omega3=180.0)
    with pytest.raises(ValueError, match="stemmed"):
        simulate(TOP, s, 1.0, model="rolling")
    with pytest.raises(ValueError, match="stem_radius"):
        simulate(TOP, s, 1.0, stem_radius=0.004)
    # dry friction runs (tests/test_stem_friction.py), so does the regularised law
    # (tests/test_stem_regularised.py); a law without a stemmed model is refused
    from mett.dynamics.resistance import RollingResistance

    with pytest.raises(ValueError, match="model 'stemmed' takes friction="):
        simulate(TOP, s, 1.0, friction=RollingResistance(1e-4))
    with pytest.raises(ValueError, match="stem_radius and stem_distance"):
        simulate(BALL, s, 1.0, model="stemmed")


def test_viscous_law_object_is_accepted(near):
    tr = simulate(TOP, NEAR, 1.0, friction=mett.friction.Viscous())
    np.testing.assert_array_equal(tr.touchdowns, near.touchdowns)


@pytest.mark.parametrize(
    ("distance", "kind"),
    [
        (0.016, "tumbling"),  # λ_s between λ_0' and λ_thres' of the stem sphere
        (0.013, "inverted"),  # a shorter stem: λ_s = 1.16 λ_thres', the inverted spin on the stem
    ],
)
def test_leine_glocker_top_from_upright_to_its_end_state_on_the_stem(distance, kind):
    top = BALL.with_stem(radius=0.005, distance=distance)
    tr = simulate(top, mett.State(theta=0.1, omega3=180.0), 20.0)
    assert tr.status == "completed", tr.message
    assert tr.touchdowns.size >= 1 and tr.touchdowns[0] > 7.0
    assert tr.contact[-1] == "stem"
    i = _segments(tr)[-1][0]
    lam = tr.lam[i:]
    assert float(np.ptp(lam) / abs(lam[0])) < 1e-9  # measured 8e-11, 6e-12
    end = top.stem_end_state(float(lam[0]))
    assert end.kind == kind and end.theta > top.touchdown_angle
    assert tr.theta[-1] == pytest.approx(end.theta, abs=1e-6)  # measured 4e-8 rad, 6e-9 rad
    assert tr.omega3[-1] == pytest.approx(end.omega3, rel=1e-7)  # measured 4e-9, 4e-12
    assert np.all(np.diff(tr.E) <= 1e-12 * tr.E[0])


def test_contact_lost_on_the_stem_is_a_status():
    # a hard touchdown: the stem takes the impact and then leaves the plane (g_n reaches 0)
    # (stop_on_contact_loss=True: by default the top flies on, tests/test_stem_flight.py)
    tr = simulate(TOP, mett.State(theta=2.2, thetadot=20.0, omega3=-90.0), 0.5,
                  stop_on_contact_loss=True)  # fmt: skip
    assert tr.status == "contact_lost", tr.message
    assert tr.touchdowns.size == 1 and tr.contact[-1] == "stem"
    assert tr.t_contact_lost == pytest.approx(tr.t[-1])
    assert tr.touchdowns[0] < tr.t_contact_lost < 0.01
    assert abs(tr.gn[-1]) < 1e-9 * BALL.m * BALL.g
    # a start on the stem whose normal force is already negative ends at t = 0
    at0 = simulate(TOP, mett.State(theta=2.6, thetadot=-40.0, omega3=-90.0), 0.5,
                   stop_on_contact_loss=True)  # fmt: skip
    assert at0.status == "contact_lost" and at0.t_contact_lost == 0.0
    assert list(at0.contact) == ["stem"] and at0.touchdowns.size == 0


@pytest.mark.parametrize("mu", [1e3, 1e6, 1e12, 1e50])
def test_stiff_darboux_keller_impact_against_an_implicit_integration(mu):
    # huge μ (or speeds) make the impulse equations stiff: the exact linear solution (and its
    # μ → ∞ limit v = 0) against an independent Radau integration with the exact Jacobian, and
    # continuous with the explicit path at the switch between them
    from scipy.integrate import solve_ivp

    from mett.dynamics.stem import darboux_keller

    rng = np.random.default_rng(7)
    A = rng.normal(size=(3, 3))
    W = A @ A.T + 0.5 * np.eye(3)  # a Delassus matrix: symmetric positive definite
    v0 = np.array([0.3, -0.2, -1.0])
    J = np.zeros((6, 6))
    J[:3, :2] = -mu * W[:, :2]
    J[3:5, :2] = -mu * np.eye(2)

    def rate(_, z):
        dP = np.array([-mu * z[0], -mu * z[1], 1.0])
        return np.concatenate((W @ dP, dP))

    def stop(_, z):
        return z[2]

    stop.terminal, stop.direction = True, 1.0
    ref = solve_ivp(rate, (0.0, 100.0), np.append(v0, np.zeros(3)), method="Radau", jac=J,
                    events=stop, rtol=1e-12, atol=1e-14)  # fmt: skip
    P_ref = ref.y_events[0][0][3:]
    P = darboux_keller(v0, W, mu)
    # both solve to ~1e-12 relative; the limit branch (μ|W|p > 1e15) errs by O(1/(μ|W|p))
    assert np.allclose(P, P_ref, rtol=1e-9, atol=1e-9 * np.abs(P_ref).max())
    v = v0 + W @ P
    assert abs(v[2]) < 1e-12  # the end of compression
    Wi = np.linalg.inv(W)
    assert v @ Wi @ v <= v0 @ Wi @ v0  # energy never rises


def test_darboux_keller_is_continuous_across_its_stiff_switch():
    from mett.dynamics.stem import darboux_keller

    W = np.array([[2.0, 0.3, 0.1], [0.3, 1.5, -0.2], [0.1, -0.2, 1.0]])
    v0 = np.array([0.4, 0.1, -1.0])
    p1 = 10.0 * -v0[2] / W[2, 2]
    mu_switch = 1e3 / (np.linalg.norm(W, 2) * p1)
    below = darboux_keller(v0, W, mu_switch * (1 - 1e-6))
    above = darboux_keller(v0, W, mu_switch * (1 + 1e-6))
    # the two paths (DOP853 at rtol 1e-13, the exact linear solution) agree to ~1e-11, the
    # change of μ moves P by ~1e-6 × dP/dlog μ, small here (the slip has relaxed)
    assert np.allclose(below, above, rtol=1e-6)
