"""The top with a stem under dry friction (mett.dynamics.stemslip): stick–slip on the ball or the
stem, Darboux–Keller impacts with Coulomb friction at the change of contact.

The body is the Leine–Glocker-like top of tests/test_stem_dynamics.py (m = 6 g, R = 15 mm,
αR = 3 mm, I1 = 8e-7, I3 = 7e-7 kg m²) with a stem sphere of radius 5 mm 16 mm from the ball's
centre (touchdown at arccos(−10/16) = 2.2459 rad), under Coulomb friction μ = 0.3.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import stop_bounds
from scipy.integrate import solve_ivp

import mett
from mett import friction
from mett.dynamics import _params as ix
from mett.dynamics import contact, simulate, stemslip
from mett.dynamics.stem import impact_frame
from mett.friction import Coulomb

BALL = mett.TippeTop(m=0.006, R=0.015, alpha=0.2, I1=8e-7, I3=7e-7, mu=0.3)
TOP = BALL.with_stem(radius=0.005, distance=0.016)
# near the state of the viscous run from θ0 = 0.1 just before touchdown (tests/test_stem_dynamics.py)
NEAR = mett.State(theta=2.15, thetadot=2.0, phidot=110.0, omega3=-76.0, nu_y=0.16)
LAW = Coulomb(0.3)


@pytest.fixture(scope="module")
def run():
    return simulate(TOP, NEAR, 0.5, friction=LAW)


def _stretches(tr):
    """(start, end) sample indices of each stretch on one contact and one friction phase."""
    key = np.char.add(tr.contact.astype(str), tr.phase.astype(str))
    edges = np.flatnonzero(key[1:] != key[:-1]) + 1
    return list(zip(np.concatenate(([0], edges)), np.concatenate((edges, [key.size])), strict=True))


def _geometry(tr, on_stem):
    return stemslip._stem(tr.params) if on_stem else stemslip._ball(tr.params)


def _lam(y, q, p):
    """Jellett integral −L·a of the contact with stickslip parameters q (a = l 3̂ − R ẑ) of the
    model state y (row 6: λ of its own contact; L_z recovered with the model's conversion)."""
    y = stemslip._lz(y, p)
    e = np.asarray(y[7:10]) / np.linalg.norm(y[7:10])
    a = q[2] * e - np.array([0.0, 0.0, q[1]])
    return -float(np.dot(y[4:7], a))


def test_both_contacts_and_both_phases_are_visited(run):
    assert run.model == "stemmed-coulomb" and run.status == "completed", run.message
    pairs = set(zip(run.contact.tolist(), run.phase.tolist(), strict=True))
    assert {("ball", "sliding"), ("stem", "sliding"), ("stem", "rolling")} <= pairs
    reasons = [s.reason for s in run.switches]
    assert {"touchdown", "landing", "stop"} <= set(reasons)
    assert run.touchdowns.size == reasons.count("touchdown") >= 2
    for sw in run.switches:  # the sample at a switch's event is the state after it
        k = np.searchsorted(run.t, sw.t_event, side="left")
        assert f"{run.contact[k]}-{run.phase[k]}" == sw.after
        contacts = (sw.before.split("-")[0], sw.after.split("-")[0])
        want = {"touchdown": ("ball", "stem"), "landing": ("stem", "ball")}
        assert contacts == want.get(sw.reason, (contacts[0], contacts[0]))


def test_touchdown_angle_is_arccos_to_1e_9(run):
    theta_td = math.acos((TOP.radius - BALL.R) / TOP.distance)
    for t in run.touchdowns:
        assert abs(run.at(t - 1e-12).theta - theta_td) < 1e-9
        assert abs(run.at(t).theta - theta_td) < 1e-9
    for sw in run.switches:
        if sw.reason == "landing":
            assert abs(run.at(sw.t).theta - theta_td) < 1e-9


def test_jellett_of_the_contact_sphere_is_conserved_within_each_contact(run):
    # one contact, stick and slip alike: Coulomb has no torque about the normal (≤ 1e-9)
    worst = {"ball": 0.0, "stem": 0.0}
    edges = np.flatnonzero(run.contact[1:] != run.contact[:-1]) + 1
    for i, j in zip(np.concatenate(([0], edges)), np.concatenate((edges, [run.t.size])),
                    strict=True):  # fmt: skip
        lam = run.lam[i:j]
        c = str(run.contact[i])
        worst[c] = max(worst[c], float(np.ptp(lam) / abs(lam[0])))
        if c == "stem":
            assert lam[0] == pytest.approx(float(TOP.stem_jellett(run.at(run.t[i]))), rel=1e-12)
    assert worst["stem"] < 1e-9 and worst["ball"] < 1e-9, worst


def test_energy_never_increases(run):
    # sliding dissipates, rolling keeps E, impacts and stopping impulses lose energy; a restart
    # of slip adds O(m δ²) ≈ 1e-20 J; within a rolling stretch E may move by the integration
    # error only (measured ≤ 2.4e-12 of E per step at rtol = 1e-10)
    _energy_never_increases(run)
    assert run.E[-1] < run.E[0]


def test_rolling_phases_keep_the_contact_at_rest_inside_the_cone(run):
    rolling = run.phase == "rolling"
    assert rolling.sum() > 10
    for on_stem in (False, True):
        sel = rolling & ((run.contact == "stem") == on_stem)
        if not sel.any():
            continue
        q = _geometry(run, on_stem)
        slip = np.linalg.norm(contact.slip(run.states[:, sel], q), axis=0)
        assert np.all(slip <= 2e-9), slip.max()  # the stopping band is 1.9e-9 m/s
        gn = run.gn[sel]
        assert np.all(gn > 0.0)
        # the force rolling needs, inside the cone μ g_n
        ft = np.hypot(run.F_x[sel], run.F_y[sel])
        assert np.all(ft <= LAW.mu * gn * (1 + 1e-9))
        assert np.all(run.margin[sel] >= -1e-9 * LAW.mu * gn)


def test_each_impact_keeps_the_new_contacts_jellett_and_stops_its_normal_velocity(run):
    p = run.params
    n = 0
    for sw, (y_ev, y_sw) in zip(run.switches, run.jumps, strict=True):
        if sw.reason not in ("touchdown", "landing"):
            continue
        n += 1
        to = "stem" if sw.reason == "touchdown" else "ball"
        q_new = _geometry(run, to == "stem")
        y_imp, P, Q = stemslip.impact(y_ev, p, to)
        assert Q == 0.0
        # λ of the new contact: unchanged by the impulse at it, and by the settling after it
        assert _lam(y_imp, q_new, p) == pytest.approx(_lam(y_ev, q_new, p), rel=1e-12)
        assert _lam(y_sw, q_new, p) == pytest.approx(_lam(y_ev, q_new, p), rel=1e-12)
        assert y_imp[6] == pytest.approx(_lam(y_ev, q_new, p), rel=1e-12)  # the new layout
        # the new contact point: no normal velocity afterwards (impact_frame of the landed state
        # from the new contact itself gives the velocity of that point)
        f_before = impact_frame(stemslip._lz(y_ev, p), stemslip._viscous(p), to)
        assert f_before.v[2] < 0.0
        v_after = f_before.v + f_before.W @ P
        assert abs(v_after[2]) < 1e-12 * np.abs(f_before.v).max()
        # the impulse lies in the cone and pushes
        assert P[2] > 0.0 and math.hypot(P[0], P[1]) <= LAW.mu * P[2] * (1 + 1e-12)
        # energy: lost, by the Darboux–Keller integral
        E = [_energy(y, p) for y in (y_ev, y_imp)]
        assert E[1] < E[0]
        # the sample after the switch is the settled state on the new contact
        k = np.searchsorted(run.t, sw.t, side="left")
        assert run.contact[k] == to
    assert n >= 3


def _energy(y, p):
    """E of the state y on its own contact (flag y[10]), from the trajectory series."""
    return float(mett.dynamics.MODELS["stemmed-coulomb"].derive(np.reshape(y, (-1, 1)), p)["E"][0])


def _reference_sliding_impulse(f, m, mu):
    """The Darboux–Keller impulse of a contact that slides throughout, integrated independently
    (LSODA on the velocity alone, P recovered as W⁻¹ Δv, and the energy integral ∫(v_z − μ|v_t|)dp)."""

    def rate(_, z):
        v = z[:3]
        d = np.array([*(-mu * v[:2] / np.linalg.norm(v[:2])), 1.0])
        return np.append(f.W @ d, v[2] - mu * np.linalg.norm(v[:2]))

    def end(_, z):
        return z[2]

    end.terminal, end.direction = True, 1.0
    sol = solve_ivp(rate, (0.0, 100.0 * -f.v[2] / f.W[2, 2]), np.append(f.v, 0.0),
                    method="LSODA", events=end, rtol=1e-12, atol=1e-14)  # fmt: skip
    z = sol.y_events[0][0]
    return np.linalg.solve(f.W, z[:3] - f.v), z[3]


def test_sliding_impacts_agree_with_an_independent_solution(run):
    p = run.params
    n = 0
    for sw, (y_ev, _) in zip(run.switches, run.jumps, strict=True):
        if sw.reason not in ("touchdown", "landing"):
            continue
        to = "stem" if sw.reason == "touchdown" else "ball"
        f = impact_frame(stemslip._lz(y_ev, p), stemslip._viscous(p), to)
        P, Q, stuck = stemslip.dry_impulse(f, p[ix.M], p[ix.MU], 0.0)
        if stuck:
            continue
        n += 1
        P_ref, dE_ref = _reference_sliding_impulse(f, p[ix.M], p[ix.MU])
        np.testing.assert_allclose(P, P_ref, rtol=1e-8, atol=1e-8 * abs(P_ref[2]))
        y_imp = stemslip.impact(y_ev, p, to)[0]
        dE = _energy(y_imp, p) - _energy(y_ev, p)
        assert dE == pytest.approx(dE_ref, rel=1e-6)
        # inside the cone's edge by as much as the slip direction turns during the impact
        assert 0.0 <= sw.margin < 1e-3
    assert n >= 2


def _frame_at_touchdown(thetadot, nu_x, phidot=0.0):
    p = mett.dynamics.MODELS["stemmed"].parameters(
        BALL, stem_radius=TOP.radius, stem_distance=TOP.distance
    )
    s = mett.State(theta=TOP.touchdown_angle - 1e-9, thetadot=thetadot, phidot=phidot, nu_x=nu_x)
    y = mett.dynamics.MODELS["stemmed"].initial(s, p)
    return impact_frame(y, p, "stem")


def test_sticking_impact_is_the_plastic_impact():
    # stuck at the end of the impact: all of v is removed, P = −W⁻¹ v, the energy lost ½ v·W⁻¹v
    f = _frame_at_touchdown(thetadot=3.0, nu_x=0.0)
    P_stick = np.linalg.solve(f.W, -f.v)
    # a rough contact: the slip stops during the impact, and the contact sticks; whatever the
    # path, the total impulse is then the plastic one (and it lies in the cone, being a sum of
    # impulses in the cone)
    mu = 10.0 * math.hypot(P_stick[0], P_stick[1]) / P_stick[2]
    P, Q, stuck = stemslip.dry_impulse(f, BALL.m, mu, 0.0)
    assert stuck and Q == 0.0
    np.testing.assert_allclose(f.v + f.W @ P, 0.0, atol=1e-12 * np.abs(f.v).max())
    np.testing.assert_allclose(P, P_stick, rtol=1e-9)
    lost = -(P @ (f.v + 0.5 * f.W @ P))  # −ΔE = −(P·v + ½ P·W P)
    assert lost == pytest.approx(0.5 * f.v @ np.linalg.solve(f.W, f.v), rel=1e-12)
    # with the plastic impulse outside the cone the contact cannot end stuck: slip is left
    P, _, stuck = stemslip.dry_impulse(f, BALL.m, 0.05 * mu, 0.0)
    assert not stuck
    assert math.hypot(P[0], P[1]) <= 0.05 * mu * P[2] * (1 + 1e-12)
    assert np.linalg.norm((f.v + f.W @ P)[:2]) > 1e-3 * np.abs(f.v).max()
    assert abs((f.v + f.W @ P)[2]) < 1e-12 * np.abs(f.v).max()


def test_frictionless_limit_is_the_closed_form():
    f = _frame_at_touchdown(thetadot=3.0, nu_x=0.05, phidot=40.0)
    P, _, stuck = stemslip.dry_impulse(f, BALL.m, 0.0, 0.0)
    assert not stuck
    np.testing.assert_allclose(P, [0.0, 0.0, -f.v[2] / f.W[2, 2]], rtol=1e-12, atol=1e-18)


def test_a_sticking_touchdown_starts_rolling_on_the_stem():
    # a slow touchdown with the stem point nearly at rest: stem-rolling after the impact
    tr = simulate(TOP, mett.State(theta=TOP.touchdown_angle - 1e-4, thetadot=1.0), 0.05,
                  friction=Coulomb(1.0))  # fmt: skip
    first = tr.switches[0]
    assert first.reason == "touchdown" and first.after == "stem-rolling", tr.switches[:2]
    assert first.margin > 0.0 and first.slip < tr.stopping_band


def test_compiled_equals_python(run):
    ref = simulate(TOP, NEAR, 0.5, friction=LAW, backend="scipy")
    assert [s[1:4] for s in ref.switches] == [s[1:4] for s in run.switches]
    # Tolerances from the error analysis (rtol = 1e-10, the default): the backends run the same
    # DOP853 on the same functions and agree to rounding while they take the same steps, but a
    # rounding difference (another CPU's libm or BLAS, NUMBA_OPT=0) may send them down other step
    # sequences (seen: the last stop 2.3e-9 s later): they then differ by up to the sum of their
    # errors. A stop fires when |v_A|, falling at the rate a (m/s²), is in the stopping band
    # [0, δ]: up to δ/a early; the error of v_A there is at most the local error allowed per step,
    # rtol × the velocity scale = δ/10, over the N steps of that slide: N δ/(10 a). Later switches
    # inherit the shift; the integration error elsewhere is estimated by the run at rtol/100.
    fine = simulate(TOP, NEAR, 0.5, friction=LAW, rtol=1e-12)
    assert [s[1:4] for s in fine.switches] == [s[1:4] for s in run.switches]
    stop_shift = stop_bounds.stop_shift(run)
    t_err = max(abs(a.t - b.t) for a, b in zip(run.switches, fine.switches, strict=True))
    t_tol = 2.0 * (t_err + stop_shift)
    np.testing.assert_allclose([s.t for s in ref.switches], [s.t for s in run.switches],
                               rtol=0, atol=t_tol)  # fmt: skip
    # θ: each run's error (as above) plus the switch shifts times the fastest |θ̇|
    theta_tol = 2.0 * abs(run.theta[-1] - fine.theta[-1]) + np.abs(run.thetadot).max() * t_tol
    assert abs(ref.theta[-1] - run.theta[-1]) < theta_tol


def test_bad_laws_on_a_stemmed_top():
    s = mett.State(theta=0.1, omega3=180.0)
    from mett.dynamics.resistance import RollingResistance

    with pytest.raises(ValueError, match="model 'stemmed' takes friction="):
        simulate(TOP, s, 1.0, friction=RollingResistance(1e-4))  # no stemmed model
    with pytest.raises(ValueError, match="stopping_band"):
        simulate(TOP, s, 1.0, friction=LAW, stopping_band=-1.0)


def test_contensou_on_the_stem_loses_energy_and_breaks_jellett():
    tr = simulate(TOP, NEAR, 0.3, friction=Coulomb(0.3, contensou_radius=3e-3))
    assert tr.model == "stemmed-coulomb-contensou" and tr.status == "completed", tr.message
    assert tr.touchdowns.size >= 1 and "stem" in set(tr.contact)
    assert np.all(np.diff(tr.E) <= 1e-12 * tr.E[0])
    on = tr.contact == "stem"
    i = int(np.argmax(on))
    j = i + int(np.argmax(~on[i:])) if not on[i:].all() else on.size
    assert np.ptp(tr.lam[i:j]) > 1e-6 * abs(tr.lam[i])  # the drilling torque changes λ_s
    assert np.any(tr.M_n[on] != 0.0)


# --- the long runs (fast once the kernels are compiled) ---------------------------------------------------------------------------------

UPRIGHT = mett.State(theta=0.1, omega3=180.0)  # the Leine–Glocker start, contact point at rest


def _stem_stretches(tr):
    edges = np.flatnonzero(tr.contact[1:] != tr.contact[:-1]) + 1
    bounds = zip(np.concatenate(([0], edges)), np.concatenate((edges, [tr.t.size])), strict=True)
    return [(i, j) for i, j in bounds if tr.contact[i] == "stem"]


def _energy_never_increases(tr):
    """E never increases: to rounding while sliding and at the switches; while rolling (E
    conserved) by no more than the integration error at rtol = 1e-10."""
    dE = np.diff(tr.E) / tr.E[0]
    rolling = (tr.phase[1:] == "rolling") & (tr.phase[:-1] == "rolling")
    assert np.all(dE[~rolling] <= 1e-12), dE[~rolling].max()
    assert np.all(dE[rolling] <= 1e-10), dE[rolling].max()


def test_near_touchdown_start_ends_rolling_on_the_stem():
    tr = simulate(TOP, NEAR, 20.0, friction=LAW)
    assert tr.status == "completed", tr.message
    assert tr.touchdowns.size == 3 and tr.contact[-1] == "stem" and tr.phase[-1] == "rolling"
    i, _ = _stem_stretches(tr)[-1]
    assert tr.t[i] == pytest.approx(0.41738502, abs=1e-6)
    lam = tr.lam[i:]
    # λ of the stem is a state variable (mett.dynamics.stickslip): kept to rounding (measured
    # 1e-15; 7e-11 when L_z was integrated instead)
    assert float(np.ptp(lam) / abs(lam[0])) < 1e-13
    # rolling from the last stop on: E constant to the integration error (measured 1.2e-9 over
    # 19.6 s at rtol = 1e-10, the axis length drifting 5e-9; 6.6e-11 with L_z in the state)
    last_stop = [s.t for s in tr.switches if s.reason == "stop"][-1]
    k = tr.t >= last_stop
    assert float(np.ptp(tr.E[k]) / tr.E[-1]) < 3e-9
    assert np.all(tr.phase[k] == "rolling")
    _energy_never_increases(tr)  # rolling steps measured up to 1.4e-10
    assert tr.theta[-1] == pytest.approx(2.483, abs=2e-3)  # measured 2.48281
    assert tr.omega3[-1] == pytest.approx(-93.50, abs=2e-2)  # measured −93.498


def test_leine_glocker_start_rolls_on_its_ball_under_coulomb():
    # μ = 0.3: the force rolling needs stays inside the cone, nothing dissipates, no inversion
    tr = simulate(TOP, UPRIGHT, 20.0, friction=LAW)
    assert tr.status == "completed", tr.message
    assert tr.touchdowns.size == 0 and tr.switches == []
    assert set(tr.contact) == {"ball"} and set(tr.phase) == {"rolling"}
    assert float(np.ptp(tr.E) / tr.E[0]) < 1e-9
    assert float(np.ptp(tr.lam) / tr.lam[0]) < 1e-9
    assert np.all(tr.theta < 0.101)  # measured 0.0994 at 20 s
    assert np.all(tr.margin > 0.0)


def test_leine_glocker_start_touches_down_under_coulomb_contensou():
    tr = simulate(TOP, UPRIGHT, 20.0, friction=Coulomb(0.3, contensou_radius=3e-3))
    assert tr.status == "completed", tr.message
    assert tr.touchdowns[0] == pytest.approx(2.277, abs=1e-3)  # measured 2.27704
    for t in tr.touchdowns:
        assert abs(tr.at(t).theta - TOP.touchdown_angle) < 1e-9
    _energy_never_increases(tr)
    # the spin consumed, it ends rolling on its ball just short of the stem
    assert tr.contact[-1] == "ball" and tr.phase[-1] == "rolling"
    assert TOP.touchdown_angle - 0.05 < tr.theta[-1] < TOP.touchdown_angle  # measured 2.219
    assert abs(tr.omega3[-1]) < 10.0  # measured −4.1 rad/s (from 180)


@pytest.mark.slow
@pytest.mark.ci
def test_leine_glocker_start_inverts_under_weak_coulomb_friction():
    # μ = 0.01: it slides until it inverts; the stem touches down at θ_touch, then the impacts
    # accumulate into the dry double contact (tests/test_dry_double_contact.py), which ends when
    # the ball lifts off: the top carries on on its stem (before: "failed" at the accumulation,
    # and before that "completed" over 592 touchdowns)
    tr = simulate(TOP, UPRIGHT, 40.0, friction=Coulomb(0.01))
    assert tr.status == "completed", tr.message
    reasons = [sw.reason for sw in tr.switches]
    assert "accumulation" in reasons and "ball lifts off" in reasons
    assert tr.contact[-1] == "stem"
    assert tr.touchdowns[0] == pytest.approx(35.8169, abs=1e-3)  # measured 35.81692
    for t in tr.touchdowns[:20]:
        assert abs(tr.at(t).theta - TOP.touchdown_angle) < 1e-9
    assert 3 <= tr.touchdowns.size < 100
    gaps = np.diff(tr.touchdowns[:10])
    assert np.all(gaps[1:] < gaps[:-1])  # shrinking: an accumulation
    for i, j in _stem_stretches(tr)[:50]:
        lam = tr.lam[i:j]
        assert float(np.ptp(lam) / abs(lam[0])) < 1e-9
    _energy_never_increases(tr)


def test_a_switch_to_an_unknown_phase_ends_the_run_failed():
    # the registry's Event.select: a phase name the model does not have is a status, not a crash
    import dataclasses

    mdl = mett.dynamics.MODELS["stemmed-coulomb"]
    events = tuple(
        dataclasses.replace(ev, select=lambda y, p: "nowhere") if ev.select is not None else ev
        for ev in mdl.events
    )
    model = dataclasses.replace(mdl, name="stemmed-coulomb-broken", events=events, variant=None)
    tr = simulate(BALL, NEAR, 0.1, model=model, friction=LAW, backend="scipy",
                  stem_radius=TOP.radius, stem_distance=TOP.distance)  # fmt: skip
    assert tr.status == "failed" and "unknown phase 'nowhere'" in tr.message
    assert tr.t[-1] == pytest.approx(0.0198558, abs=1e-6)  # the first touchdown, kept


@pytest.mark.parametrize(
    ("ratio", "pressure"),
    [
        (friction.CONTENSOU_UNIFORM, lambda u: np.ones_like(u)),
        (friction.CONTENSOU_HERTZ, lambda u: np.sqrt(1.0 - u * u)),
    ],
    ids=["uniform", "hertz"],
)
def test_contensou_ratio_is_the_drilling_torque_of_its_pressure(ratio, pressure):
    # pure spin: |M| = μ ∫ρ p dA = μ g_n r* with g_n = ∫p dA, integrated here over the disc
    from scipy.integrate import quad

    r, mu, gn = 5e-4, 0.3, 0.06
    num = quad(lambda u: u * u * pressure(u), 0.0, 1.0)[0]  # ∫ρ p 2πρ dρ / (2π r³)
    den = quad(lambda u: u * pressure(u), 0.0, 1.0)[0]  # ∫p 2πρ dρ / (2π r²)
    law = friction.Coulomb(mu, contensou_radius=r, contensou_ratio=ratio)
    assert law.r_star == pytest.approx(r * num / den, rel=1e-12)
    _, M = law.force(np.zeros(2), gn, omega_n=-40.0)
    assert float(M) == pytest.approx(mu * gn * r * num / den, rel=1e-12)
    # the default is the uniform disc, with the numbers of before
    assert friction.Coulomb(mu, contensou_radius=r).r_star == 2.0 / 3.0 * r
