"""The double contact of the stemmed top: ball and stem on the plane at once (mett.dynamics.stem,
docs/theory/stem.md#double-contact).

Checked against references that share no code with the model: the two normal forces from a
Lagrange-multiplier (KKT) solve of the Newton–Euler equations with the two contact constraints
at random states, the closed-form forces of the frictionless steady precession, and runs in
which the forces stay non-negative, the gaps zero, the energy non-increasing and each lift-off
drops the force of the contact that opens.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import mett
from mett.dynamics import stem

FRIEDL = mett.TippeTop(m=0.006, R=0.015, alpha=0.2, I1=8e-7, I3=7e-7, mu=0.3)
FRIEDL_STEM = FRIEDL.with_stem(radius=0.005, distance=0.013)
THESIS_STEM = mett.presets.get("rutstam2013").with_stem(radius=0.004, distance=0.026)


def _params(top, mu=None):
    ball = top.ball if mu is None else top.ball.replace(mu=mu)
    return stem.MODEL.parameters(ball, stem_radius=top.radius, stem_distance=top.distance)


def _random_state(top, rng, spin=150.0):
    """A state on the double-contact manifold: θ = θ_t, θ̇ = 0, random azimuth, precession,
    spin and horizontal CM velocity; and its (3̂, ω, V)."""
    th = top.touchdown_angle
    phi = rng.uniform(0.0, 2.0 * math.pi)
    e = np.array([math.sin(th) * math.sin(phi), -math.sin(th) * math.cos(phi), math.cos(th)])
    w = rng.uniform(-30.0, 30.0) * np.array([0.0, 0.0, 1.0]) + rng.uniform(-spin, spin) * e
    b = top.ball
    L = b.I1 * w + (b.I3 - b.I1) * np.dot(w, e) * e
    V = np.array([*rng.uniform(-0.3, 0.3, 2), 0.0])
    y = np.concatenate(([0.0, 0.0], V[:2], L, e, [2.0]))
    return y, e, w, V


def _kkt(top, mu, e, w, V):
    """λ_1, λ_2 and (V̇, ω̇) from the Newton–Euler equations with the two contact constraints
    z_G + a_i·ẑ = 0 differentiated twice, solved as one linear (KKT) system:

        m V̇ = Σ λ_i f_i − m g ẑ,  I ω̇ = Σ λ_i a_i × f_i − ω × I ω,  f_i = ẑ − μ v_i,t,
        V̇_z + l_i [(ω̇ × 3̂)_z + (ω × (ω × 3̂))_z] = 0  (i = 1 ball, 2 stem).
    """
    b = top.ball
    m, g = b.m, b.g
    z = np.array([0.0, 0.0, 1.0])
    I = b.I1 * np.eye(3) + (b.I3 - b.I1) * np.outer(e, e)
    arms = [(b.R * b.alpha, b.R), (b.R * b.alpha + top.distance, top.radius)]
    A = np.zeros((8, 8))
    rhs = np.zeros(8)
    A[0:3, 0:3] = m * np.eye(3)
    A[3:6, 3:6] = I
    rhs[0:3] = -m * g * z
    rhs[3:6] = -np.cross(w, I @ w)
    for i, (l_i, R_i) in enumerate(arms):
        a = l_i * e - R_i * z
        v = V + np.cross(w, a)
        f = z - mu * np.array([v[0], v[1], 0.0])
        A[0:3, 6 + i] = -f
        A[3:6, 6 + i] = -np.cross(a, f)
        # constraint row: V̇_z + l_i (ω̇ × 3̂)_z = −l_i (ω × (ω × 3̂))_z
        A[6 + i, 2] = 1.0
        A[6 + i, 3:6] = l_i * np.cross(e, z)  # (ω̇ × 3̂)·ẑ = ω̇·(3̂ × ẑ)
        rhs[6 + i] = -l_i * np.cross(w, np.cross(w, e))[2]
    x = np.linalg.solve(A, rhs)
    return x[6], x[7], x[0:3], x[3:6]


@pytest.mark.parametrize("top", [FRIEDL_STEM, THESIS_STEM], ids=["friedl", "thesis"])
@pytest.mark.parametrize("mu", [0.0, 0.3, 3.0])
def test_double_contact_forces_match_lagrange_multipliers(top, mu):
    rng = np.random.default_rng(7)
    p = _params(top, mu)
    b = top.ball
    for _ in range(20):
        y, e, w, V = _random_state(top, rng)
        lam1, lam2, Vdot, wdot = _kkt(top, mu, e, w, V)
        rates, l1, l2 = stem.both_rhs(0.0, y, p), *stem.both_core(y, p)[1:3]
        scale = b.m * b.g + abs(lam1) + abs(lam2)
        # the model's normal forces are the multipliers: rounding of an 8x8 solve
        assert abs(l1 - lam1) < 1e-11 * scale and abs(l2 - lam2) < 1e-11 * scale
        # CM acceleration and the torque I ω̇ + ω × I ω
        np.testing.assert_allclose(rates[2:4], Vdot[:2], atol=1e-11 * (scale / b.m))
        I = b.I1 * np.eye(3) + (b.I3 - b.I1) * np.outer(e, e)
        Ldot = I @ wdot + np.cross(w, I @ w)
        tq = np.max(np.abs(Ldot)) + 1e-300
        np.testing.assert_allclose(rates[4:7], Ldot, atol=1e-10 * tq)
        # the axis turns about the vertical only: 3̂̇ = ω × 3̂ with 3̂̇_z = 0
        np.testing.assert_allclose(rates[7:10], np.cross(w, e), atol=1e-12 * np.linalg.norm(w))
        assert rates[9] == 0.0


def test_state_is_read_on_the_manifold():
    # a drifted state (|3̂| ≠ 1, 3̂_z off, a nodal part of L) is read as its projection: the
    # same azimuth, θ = θ_t, L without the nodal component; the projection is idempotent
    rng = np.random.default_rng(3)
    p = _params(FRIEDL_STEM)
    y, e, w, V = _random_state(FRIEDL_STEM, rng)
    n = np.cross([0.0, 0.0, 1.0], e) / np.linalg.norm(np.cross([0.0, 0.0, 1.0], e))
    drifted = y.copy()
    drifted[7:10] = 1.01 * (e + np.array([0.0, 0.0, 1e-3]))
    drifted[4:7] += 1e-4 * n
    back = stem.on_both(drifted, p)
    np.testing.assert_allclose(back[7:10], e, atol=4e-16)
    np.testing.assert_allclose(back[4:7], y[4:7], atol=1e-18)
    again = stem.on_both(back, p)
    np.testing.assert_allclose(again, back, rtol=4 * np.finfo(float).eps, atol=0.0)


def _steady(top, Omega, omega3):
    """State of the frictionless steady precession at θ_t: ω = Ω ẑ + ψ̇ 3̂ with ω·3̂ = ω3."""
    th = top.touchdown_angle
    e = np.array([math.sin(th), 0.0, math.cos(th)])
    psidot = omega3 - Omega * math.cos(th)
    w = Omega * np.array([0.0, 0.0, 1.0]) + psidot * e
    b = top.ball
    L = b.I1 * w + (b.I3 - b.I1) * omega3 * e
    return np.concatenate(([0.0, 0.0, 0.01, -0.02], L, e, [2.0]))


def test_frictionless_double_contact_is_the_steady_precession():
    # μ = 0: the forces are vertical at points on the axis' vertical plane, so L_z, I3 ω3 = L·3̂,
    # the horizontal momentum and E are conserved; with θ fixed the precession Ω is steady and
    # the torque balance Ω ẑ × L = Σ λ_i a_i × ẑ gives (docs/theory/stem.md)
    #   λ_2 = −[Ω (I3 ω3 − I1 Ω cos θ_t) + m g l]/l_s,   λ_1 = m g − λ_2.
    top = FRIEDL_STEM
    b = top.ball
    p = _params(top, 0.0)
    Omega, omega3 = 5.0, -100.0
    y0 = _steady(top, Omega, omega3)
    c = math.cos(top.touchdown_angle)
    lam2 = -(Omega * (b.I3 * omega3 - b.I1 * Omega * c) + b.m * b.g * b.R * b.alpha)
    lam2 /= top.distance
    l1, l2 = stem.both_core(y0, p)[1:3]
    assert lam2 > 0.0 and b.m * b.g - lam2 > 0.0  # a double contact both contacts carry
    assert l2 == pytest.approx(lam2, rel=1e-13)
    assert l1 == pytest.approx(b.m * b.g - lam2, rel=1e-13)
    sol = solve_ivp(stem.both_rhs, (0.0, 0.5), y0, args=(p,), method="DOP853", rtol=1e-12,
                    atol=1e-16, dense_output=True)  # fmt: skip
    Y = sol.y
    l1s, l2s = stem.both_core(Y, p)[1:3]
    np.testing.assert_allclose(l2s, lam2, rtol=1e-9)
    np.testing.assert_allclose(l1s, b.m * b.g - lam2, rtol=1e-9)
    e = Y[7:10] / np.linalg.norm(Y[7:10], axis=0)
    np.testing.assert_allclose(Y[6], y0[6], rtol=1e-10)  # L_z
    np.testing.assert_allclose(np.sum(Y[4:7] * e, axis=0), b.I3 * omega3, rtol=1e-10)  # I3 ω3
    np.testing.assert_allclose(Y[2:4], Y[2:4, :1] * np.ones_like(Y[2:4]), rtol=0, atol=1e-15)
    azimuth = np.unwrap(np.arctan2(Y[8], Y[7]))
    np.testing.assert_allclose(azimuth, azimuth[0] + Omega * sol.t, atol=1e-9)
    assert np.all(Y[9] == y0[9])  # 3̂_z never moves: its rate is exactly 0


@pytest.fixture(scope="module")
def thesis_run():
    """The thesis body with a stem (r_s = 4 mm, l_s = 26 mm), θ0 = 0.1, ω3 = 155: impacts
    accumulate at 6.29 s, double contact until the stem lifts off."""
    return mett.simulate(THESIS_STEM, mett.State(theta=0.1, omega3=155.0), t_end=8.0)


def test_thesis_run_completes_through_a_double_contact(thesis_run):
    tr = thesis_run
    assert tr.status == "completed", tr.message
    reasons = [sw.reason for sw in tr.switches]
    assert "accumulation" in reasons
    assert "both" in set(tr.contact)
    assert len(tr.switches) < 100  # never thousands of impacts
    acc = [sw for sw in tr.switches if sw.reason == "accumulation"]
    for sw in acc:  # the accumulation point lies after the impact that detected it
        assert sw.t < sw.t_event < sw.t + 0.01


def _gaps(tr, idx):
    """Clearances (m) of the ball and the stem of samples ``idx`` from θ and the CM height
    implied by each contact: both zero exactly where both touch."""
    top = THESIS_STEM
    b = top.ball
    c = np.cos(tr.theta[idx])
    z_ball = b.R - b.R * b.alpha * c  # CM height with the ball on the plane
    z_stem = top.radius - (b.R * b.alpha + top.distance) * c
    return z_ball - z_stem


def test_double_contact_samples_have_nonnegative_forces_and_zero_gaps(thesis_run):
    tr = thesis_run
    both = np.flatnonzero(tr.contact == "both")
    assert both.size > 10
    assert np.all(tr.gn_ball[both] >= 0.0) and np.all(tr.gn_stem[both] >= 0.0)
    mg = THESIS_STEM.ball.m * THESIS_STEM.ball.g
    np.testing.assert_allclose(tr.gn_ball[both] + tr.gn_stem[both], mg, rtol=1e-12)
    # the two contacts give the same CM height: the gap of one with the other on the plane
    assert np.max(np.abs(_gaps(tr, both))) <= 8 * np.finfo(float).eps * THESIS_STEM.distance
    # the stored 3̂_z is set at the entry and its rate is exactly 0
    cz = (THESIS_STEM.radius - THESIS_STEM.ball.R) / THESIS_STEM.distance
    assert np.all(tr.states[9, both] == pytest.approx(cz, abs=4e-16))
    assert np.all(np.abs(tr.thetadot[both]) < 1e-9)


def test_lift_off_drops_the_force_of_the_contact_that_opens(thesis_run):
    tr = thesis_run
    p = tr.params
    mg = THESIS_STEM.ball.m * THESIS_STEM.ball.g
    n = 0
    for sw, (y_ev, _) in zip(tr.switches, tr.jumps, strict=True):
        if sw.before != "both":
            continue
        n += 1
        f_ball, f_stem = (float(x) for x in stem.normal_forces(on_both_flag(y_ev), p))
        opened, kept = (f_stem, f_ball) if sw.after == "ball" else (f_ball, f_stem)
        assert sw.reason == ("stem lifts off" if sw.after == "ball" else "ball lifts off")
        assert abs(opened) < 1e-8 * mg and kept == pytest.approx(mg, rel=1e-8)
        # and that contact opens: its clearance grows after the switch
        t1 = min(sw.t + 1e-3, tr.t[-1])
        th = tr.at(t1).theta
        clear = (
            THESIS_STEM.stem_clearance(th)
            if sw.after == "ball"
            else -THESIS_STEM.stem_clearance(th)
        )
        assert clear > 0.0
    assert n >= 1


def on_both_flag(y):
    out = np.array(y, dtype=float)
    out[10] = 2.0
    return out


def test_energy_never_increases_over_the_run_and_at_each_switch(thesis_run):
    tr = thesis_run
    E = tr.E
    # the integration error of a dissipative run at rtol = 1e-10 stays below 1e-12 E
    assert np.all(np.diff(E) <= 1e-12 * E[0])
    p = tr.params
    for sw, (y_ev, y_sw) in zip(tr.switches, tr.jumps, strict=True):
        e_before = float(tr._model.derive(y_ev[:, None], p)["E"][0])
        e_after = float(tr._model.derive(y_sw[:, None], p)["E"][0])
        assert e_after <= e_before + 1e-13 * E[0], sw


# --- accumulation ------------------------------------------------------------------------------


def test_accumulation_point_of_an_exact_geometric_sequence():
    # two alternating geometric sequences of ratio q (stem and ball intervals): the limit is
    # t_k + q (Δ_{k−1} + Δ_k)/(1 − q), the sum of the remaining intervals
    q, d_stem, d_ball = 0.6, 3e-3, 7e-3
    d = [d_stem * q**k if i == 0 else d_ball * q**k for k in range(4) for i in (0, 1)]
    t = np.concatenate(([1.0], 1.0 + np.cumsum(d)))
    acc = stem.accumulation(t)
    assert acc is not None and acc.ratio == pytest.approx(q, rel=1e-13)
    limit = 1.0 + (d_stem + d_ball) / (1.0 - q)
    assert acc.t_limit == pytest.approx(limit, rel=1e-14)
    # not geometric, or not shrinking: no accumulation
    assert stem.accumulation(1.0 + np.cumsum(np.full(8, 1e-3))) is None
    assert stem.accumulation(1.0 + np.cumsum([1e-3 * 1.1**k for k in range(8)])) is None
    assert stem.accumulation(t[:5]) is None


def _single_contact_theta_acc(top, e, w, which):
    """θ̈ (rad/s²) at θ̇ = 0 on one contact: Newton–Euler with that contact's constraint (KKT)."""
    b = top.ball
    m, g = b.m, b.g
    z = np.array([0.0, 0.0, 1.0])
    l_i, R_i = (
        (b.R * b.alpha, b.R) if which == "ball" else (b.R * b.alpha + top.distance, top.radius)
    )
    a = l_i * e - R_i * z
    I = b.I1 * np.eye(3) + (b.I3 - b.I1) * np.outer(e, e)
    A = np.zeros((7, 7))
    rhs = np.zeros(7)
    A[0:3, 0:3], A[3:6, 3:6] = m * np.eye(3), I
    rhs[0:3], rhs[3:6] = -m * g * z, -np.cross(w, I @ w)
    A[0:3, 6], A[3:6, 6] = -z, -np.cross(a, z)
    A[6, 2], A[6, 3:6] = 1.0, l_i * np.cross(e, z)
    rhs[6] = -l_i * np.cross(w, np.cross(w, e))[2]
    wdot = np.linalg.solve(A, rhs)[3:6]
    e_dd = np.cross(wdot, e) + np.cross(w, np.cross(w, e))
    return -e_dd[2] / np.sin(top.touchdown_angle)  # 3̂_z = cos θ, θ̇ = 0


def _rocking_ratio(top, e, w, frm, to):
    """θ̇⁺/θ̇⁻ of a frictionless plastic impact of contact ``to`` while rocking on ``frm``
    (Delassus: P = −v_n/W_nn at the new contact, vertical)."""
    b = top.ball
    z = np.array([0.0, 0.0, 1.0])
    n = np.cross(z, e) / np.linalg.norm(np.cross(z, e))  # θ̇ = ω·n̂
    arm = {"ball": (b.R * b.alpha, b.R), "stem": (b.R * b.alpha + top.distance, top.radius)}
    a_f = arm[frm][0] * e - arm[frm][1] * z
    a_t = arm[to][0] * e - arm[to][1] * z
    Iinv = np.linalg.inv(b.I1 * np.eye(3) + (b.I3 - b.I1) * np.outer(e, e))
    w0 = w + (1.0 if to == "stem" else -1.0) * n  # rocking towards the new contact
    v_n = -np.cross(w0, a_f)[2] + np.cross(w0, a_t)[2]  # V_z from the old contact
    t_ = np.cross(a_t, z)
    P = -v_n / (1.0 / b.m + t_ @ Iinv @ t_)
    return float((w0 + Iinv @ t_ * P) @ n / (w0 @ n))


def test_accumulation_point_of_a_bouncing_sequence_matches_the_rocking_limit():
    # μ = 0, near the steady double-contact precession (Ω = 5 rad/s, ω3 = −100 rad/s, both
    # forces > 0): started ε below θ_t on the ball, the top rocks into the stem with θ̇ = v1 and
    # bounces between the contacts. For small rocking each flight has a constant θ̈ (A_s on the
    # stem, A_b on the ball, from KKT solves) and each impact multiplies θ̇ by ρ (Delassus), so
    # the intervals are T1 = 2ρ_s v1/A_s, T2 = ρ_b T1 A_s/A_b, ... with ratio q = ρ_s ρ_b and
    #   t_∞ = t_1 + (T1 + T2)/(1 − q).
    top = FRIEDL.replace(mu=0.0).with_stem(radius=0.005, distance=0.013)
    b = top.ball
    th = top.touchdown_angle
    Omega, omega3 = 5.0, -100.0
    tr = mett.simulate(top, mett.State(theta=th - 1e-6, phidot=Omega, omega3=omega3), 0.01)
    assert tr.status == "completed", tr.message
    reasons = [sw.reason for sw in tr.switches]
    assert reasons[:2] == ["touchdown", "landing"] and "accumulation" in reasons
    assert tr.contact[-1] == "both"
    z = np.array([0.0, 0.0, 1.0])
    e = np.array([np.sin(th), 0.0, np.cos(th)])
    w = Omega * z + (omega3 - Omega * np.cos(th)) * e
    A_s = -_single_contact_theta_acc(top, e, w, "stem")
    A_b = _single_contact_theta_acc(top, e, w, "ball")
    assert A_s > 0.0 and A_b > 0.0  # a V-shaped well at θ_t: the bounces return
    rho_s, rho_b = (
        _rocking_ratio(top, e, w, "ball", "stem"),
        _rocking_ratio(top, e, w, "stem", "ball"),
    )
    q = rho_s * rho_b
    t1 = tr.switches[0].t
    v1 = float(tr._model.derive(tr.jumps[0][0][:, None], tr.params)["thetadot"][0])
    T1 = 2.0 * rho_s * v1 / A_s
    T2 = 2.0 * rho_b * rho_s * v1 / A_b
    limit = t1 + (T1 + T2) / (1.0 - q)
    # neglected: the change of θ̈ within a flight through the gyroscopic coupling of θ̇ to the
    # precession, at most the nutation frequency I3|ω3|/I1 times the flight's duration
    tol = b.I3 * abs(omega3) / b.I1 * max(T1, T2)
    d = np.diff([sw.t for sw in tr.switches])
    assert d[0] == pytest.approx(T1, rel=tol) and d[1] == pytest.approx(T2, rel=tol)
    assert d[2] / d[0] == pytest.approx(q, rel=tol)
    t_limit = next(sw.t_event for sw in tr.switches if sw.reason == "accumulation")
    assert t_limit - t1 == pytest.approx(limit - t1, rel=tol)
    # and the energy of the rocking is gone: the double contact starts with θ̇ = 0
    both = tr.contact == "both"
    assert np.all(np.abs(tr.thetadot[both]) < 1e-9)


# --- the full life cycle -----------------------------------------------------------------------


def test_friedl_top_completes_8_s_under_the_viscous_law():
    top = mett.presets.stemmed("friedl1997")
    s = mett.State.with_cm_at_rest(top.ball, theta=0.1, omega3=180.0)
    tr = mett.simulate(top, s, 8.0)
    assert tr.status == "completed", tr.message
    assert tr.touchdowns.size >= 1 and len(tr.switches) < 100
    assert np.all(np.diff(tr.E) <= 1e-12 * tr.E[0])


@pytest.mark.slow
def test_friedl_top_under_coulomb_contensou_completes_through_the_dry_double_contact():
    # the dry models continue the double contact (tests/test_dry_double_contact.py checks it):
    # the accumulating impacts lead onto both spheres, never "completed" over chattering impacts
    from mett.friction import Coulomb

    top = mett.presets.stemmed("friedl1997")
    s = mett.State.with_cm_at_rest(top.ball, theta=0.1, omega3=180.0)
    tr = mett.simulate(top, s, 8.0, friction=Coulomb(0.3, contensou_radius=5e-4))
    assert tr.status == "completed", tr.message
    assert tr.touchdowns.size >= 2 and len(tr.switches) < 100
    assert {"ball", "stem", "both"} <= set(tr.contact)
    assert "accumulation" in [sw.reason for sw in tr.switches]


def test_scipy_and_compiled_backends_agree_through_the_double_contact():
    # the double contact's compiled kernel against its Python reference (the same DOP853 steps):
    # same transitions, the times to the event location's tolerance (rtol = 1e-10 on a 6 s run:
    # 1e-9 s). The default backend may be Taylor, whose steps differ: both are pinned.
    start = mett.State(theta=0.1, omega3=155.0)
    ref = mett.simulate(THESIS_STEM, start, 8.0, backend="scipy")
    comp = mett.simulate(THESIS_STEM, start, 8.0, backend="compiled")
    assert ref.status == comp.status == "completed", (ref.message, comp.message)
    got = [(sw.before, sw.after, sw.reason) for sw in comp.switches]
    assert [(sw.before, sw.after, sw.reason) for sw in ref.switches] == got
    for a, b in zip(ref.switches, comp.switches, strict=True):
        assert abs(a.t - b.t) < 1e-9 and abs(a.t_event - b.t_event) < 1e-9


def test_closing_both_contacts_loses_the_kinetic_energy_of_the_normal_velocities():
    # the limit of an accumulation: both normal velocities stopped by vertical impulses at the
    # two contacts, P = −W_nn⁻¹ v_n, losing exactly ½ v_nᵀ W_nn⁻¹ v_n (Delassus matrix built here)
    top = THESIS_STEM
    b = top.ball
    p = _params(top)
    rng = np.random.default_rng(11)
    z = np.array([0.0, 0.0, 1.0])
    for _ in range(10):
        y, e, w, V = _random_state(top, rng)
        n = np.cross(z, e) / np.linalg.norm(np.cross(z, e))
        w = w + rng.uniform(-3.0, 3.0) * n  # rocking on the ball: θ̇ ≠ 0
        L = b.I1 * w + (b.I3 - b.I1) * np.dot(w, e) * e
        y = np.concatenate((y[:4], L, e, [0.0]))
        a = [b.R * b.alpha * e - b.R * z, (b.R * b.alpha + top.distance) * e - top.radius * z]
        Vz = -np.cross(w, a[0])[2]  # the ball's constraint
        v_n = np.array([Vz + np.cross(w, a_i)[2] for a_i in a])
        Iinv = np.linalg.inv(b.I1 * np.eye(3) + (b.I3 - b.I1) * np.outer(e, e))
        t_ = [np.cross(a_i, z) for a_i in a]
        Wnn = np.array([[1.0 / b.m + t_[i] @ Iinv @ t_[j] for j in range(2)] for i in range(2)])
        loss = 0.5 * v_n @ np.linalg.solve(Wnn, v_n)
        closed, P = stem.close_both(y, p, "ball")
        np.testing.assert_allclose(P, -np.linalg.solve(Wnn, v_n), rtol=1e-12)
        E0 = float(stem.MODEL.derive(y[:, None], p)["E"][0])
        E1 = float(stem.MODEL.derive(closed[:, None], p)["E"][0])
        assert E0 - E1 == pytest.approx(loss, rel=1e-9, abs=1e-15 * E0)
        assert abs(float(stem.MODEL.derive(closed[:, None], p)["thetadot"][0])) < 1e-12
