"""The dry double contact of the stemmed top: ball and stem on the plane at once under Coulomb
and Coulomb–Contensou friction (mett.dynamics.stemslip, docs/theory/stem.md#dry-friction).

References that share no code with the model: the contact forces from a Lagrange-multiplier
(KKT) solve of the Newton–Euler equations with the two normal constraint rows, the friction of
each sliding contact (−μ λ_i γ̂_i and Contensou's drilling torque) and the rows of a sticking
contact, assembled here from the rigid-body equations; the two gaps and the slips from the
geometry; the energy from its definition, over the run and across every jump.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import mett
from mett.dynamics import _params as ix
from mett.dynamics import contact, stem, stemslip
from mett.friction import Coulomb

TOP = mett.presets.stemmed("friedl1997")
START = mett.State.with_cm_at_rest(TOP.ball, theta=0.1, omega3=180.0)
CONTENSOU = Coulomb(0.3, contensou_radius=5e-4)
Z = np.array([0.0, 0.0, 1.0])
VISCOUS = stem.MODEL.parameters(TOP.ball, stem_radius=TOP.radius, stem_distance=TOP.distance)


@pytest.fixture(scope="module")
def run():
    """friedl1997 with its stem under Coulomb–Contensou (the dataset of Leine & Glocker 2003)."""
    return mett.simulate(TOP, START, 8.0, friction=CONTENSOU)


def _params(law, top=TOP):
    return stemslip.MODEL.parameters(
        top.ball, friction=law, stem_radius=top.radius, stem_distance=top.distance
    )


def _body(top, y):
    """3̂, ω, L of an L_z-form state (y[4:7] = L, y[7:10] = 3̂), with the inertia tensor."""
    b = top.ball
    e = np.asarray(y[7:10], dtype=float) / np.linalg.norm(y[7:10])
    I = b.I1 * np.eye(3) + (b.I3 - b.I1) * np.outer(e, e)
    L = np.asarray(y[4:7], dtype=float)
    return e, np.linalg.solve(I, L), L, I


def _arms(top, e):
    b = top.ball
    l = b.R * b.alpha
    return [(l, l * e - b.R * Z), (l + top.distance, (l + top.distance) * e - top.radius * Z)]


def _lz(top, y):
    """The L_z form of a λ-form state on one contact (y[6] = −L·a of that contact)."""
    y = np.array(y, dtype=float)
    if y[10] > 1.5:
        return y
    e = y[7:10] / np.linalg.norm(y[7:10])
    a = _arms(top, e)[round(y[10])][1]
    y[6] = -(y[6] + y[4] * a[0] + y[5] * a[1]) / a[2]
    return y


def _energy(top, y):
    """E = ½ m |V|² + ½ L·ω + m g z_G of a state, V_z and z_G from its contact (definitions)."""
    b = top.ball
    y = _lz(top, y)
    e, w, L, _ = _body(top, y)
    (l_i, a) = _arms(top, e)[1 if round(y[10]) == 1 else 0]
    Vz = -np.cross(w, a)[2]
    z_G = -a[2]
    return 0.5 * b.m * (y[2] ** 2 + y[3] ** 2 + Vz**2) + 0.5 * L @ w + b.m * b.g * z_G


def _kkt(top, law, y, sticking=(False, False)):
    """The double contact's forces and accelerations in a friction mode, from the Newton–Euler
    equations (unknowns V̇, ω̇, λ_1, λ_2 and each sticking contact's tangential force and torque)

        m V̇ = Σ F_i − m g ẑ,   I ω̇ + ω × I ω = Σ (a_i × F_i + M_i ẑ),
        normal rows    V̇_z + (ω̇ × a_i + ω × (ω × l_i 3̂))_z = 0,
        sticking rows  (V̇ + ω̇ × a_i + ω × (ω × l_i 3̂))_{x,y} = 0, ω̇_z = 0 (Contensou),
        sliding        F_i = λ_i (ẑ − μ ν_i/|γ_i|), M_i = −μ λ_i r*² ω_z/|γ_i|,

    solved with numpy (least squares: both sticking under Coulomb leave one force
    indeterminate). Returns λ, (F_i), (M_i), V̇, ω̇."""
    b = top.ball
    mu, rs = law.mu, law.contensou_ratio * law.contensou_radius
    e, w, L, I = _body(top, y)
    V = np.array([y[2], y[3], 0.0])
    arms = _arms(top, e)
    nt = 3 if rs > 0 else 2
    nvar = 8 + sum(nt for s in sticking if s)
    A = np.zeros((nvar, nvar))
    r = np.zeros(nvar)
    A[0:3, 0:3] = b.m * np.eye(3)
    A[3:6, 3:6] = I
    r[0:3] = -b.m * b.g * Z
    r[3:6] = -np.cross(w, I @ w)
    col, row = 8, 6
    slide = {}
    tcols = {}
    for i, (l_i, a) in enumerate(arms):
        nu = V + np.cross(w, a)
        gam = math.sqrt(nu[0] ** 2 + nu[1] ** 2 + (rs * w[2]) ** 2)
        if sticking[i]:
            tcols[i] = col
            for k, d in enumerate(np.eye(3)[:2]):
                A[0:3, col + k] = -d
                A[3:6, col + k] = -np.cross(a, d)
            if nt == 3:
                A[5, col + 2] = -rs  # M = r* × unknown
            col += nt
            f, m_i = Z, 0.0
        else:
            f = Z - mu * np.array([nu[0], nu[1], 0.0]) / gam
            m_i = -mu * rs * rs * w[2] / gam
            slide[i] = (f, m_i)
        A[0:3, 6 + i] = -f
        A[3:6, 6 + i] = -np.cross(a, f)
        A[5, 6 + i] -= m_i
        cen = np.cross(w, np.cross(w, l_i * e))
        for k in [2] + ([0, 1] if sticking[i] else []):
            u = np.eye(3)[k]
            A[row, 0:3] = u
            A[row, 3:6] = np.cross(a, u)
            r[row] = -cen[k]
            row += 1
        if sticking[i] and nt == 3:
            A[row, 5] = 1.0
            row += 1
    # equilibrated (rows, then columns, to unit max-norm: the mass and the inertia differ by
    # 1e4), so that the solve's rounding is that of a well-scaled system
    dr = 1.0 / np.max(np.abs(A), axis=1)
    As = A * dr[:, None]
    dc = 1.0 / np.max(np.abs(As), axis=0)
    x = dc * np.linalg.lstsq(As * dc[None, :], r * dr, rcond=None)[0]
    lam = x[6:8]
    F, M = [], []
    for i in range(2):
        if sticking[i]:
            c = tcols[i]
            F.append(np.array([x[c], x[c + 1], 0.0]) + lam[i] * Z)
            M.append(rs * x[c + 2] if nt == 3 else 0.0)
        else:
            F.append(lam[i] * slide[i][0])
            M.append(lam[i] * slide[i][1])
    return lam, F, M, x[0:3], x[3:6]


def _random_state(top, rng, spin=150.0):
    """A state on the double-contact manifold (θ = θ_t, θ̇ = 0) with random azimuth, precession,
    spin and horizontal CM velocity (L_z form, flag 2)."""
    th = top.touchdown_angle
    phi = rng.uniform(0.0, 2.0 * math.pi)
    e = np.array([math.sin(th) * math.sin(phi), -math.sin(th) * math.cos(phi), math.cos(th)])
    w = rng.uniform(-30.0, 30.0) * Z + rng.uniform(-spin, spin) * e
    b = top.ball
    L = b.I1 * w + (b.I3 - b.I1) * np.dot(w, e) * e
    return np.concatenate(([0.0, 0.0], rng.uniform(-0.3, 0.3, 2), L, e, [2.0]))


LAWS = [Coulomb(0.3), CONTENSOU, Coulomb(3.0, contensou_radius=3e-3)]


@pytest.mark.parametrize("law", LAWS, ids=["coulomb", "contensou", "contensou-mu3"])
def test_sliding_double_contact_matches_an_independent_kkt_solve(law):
    rng = np.random.default_rng(11)
    p = _params(law)
    phase = {ph.name: ph for ph in stemslip.MODEL.phases}["both-sliding"]
    b = TOP.ball
    for _ in range(20):
        y = _random_state(TOP, rng)
        lam, F, M, Vdot, wdot = _kkt(TOP, law, y)
        l1, l2, _, _ = stemslip.both_forces(y, p)
        rates = phase.rhs(0.0, y, p)
        scale = b.m * b.g + abs(lam[0]) + abs(lam[1])
        # rounding of an 8x8 solve against the closed form
        assert abs(l1 - lam[0]) < 1e-11 * scale and abs(l2 - lam[1]) < 1e-11 * scale
        np.testing.assert_allclose(rates[2:4], Vdot[:2], atol=1e-11 * scale / b.m)
        e, w, L, I = _body(TOP, y)
        Ldot = I @ wdot + np.cross(w, I @ w)
        np.testing.assert_allclose(rates[4:7], Ldot, atol=1e-10 * np.max(np.abs(Ldot)))


@pytest.mark.parametrize("law", [Coulomb(0.3), CONTENSOU], ids=["coulomb", "contensou"])
@pytest.mark.parametrize("mode", [(True, False), (False, True), (True, True)])
def test_sticking_modes_match_an_independent_kkt_solve(law, mode):
    # the forces the mode selection checks: the model's solve of a sticking mode against this
    # file's assembly (normal forces always; tangential forces unless both stick under
    # Coulomb, where the compression along the contact line is indeterminate)
    rng = np.random.default_rng(5)
    p = _params(law)
    b = TOP.ball
    for _ in range(10):
        y = _random_state(TOP, rng, spin=20.0)
        lam, F, M, _, _ = _kkt(TOP, law, y, mode)
        got = stemslip.both_stick_forces(y, p, mode)
        scale = b.m * b.g + float(np.sum(np.abs(lam)))
        if mode == (True, True):
            # indeterminate (the split: test_contensou_both_sticking_forces_match_an_
            # independent_minimax): the normal forces, the total force and, with Contensou,
            # the total moment about the vertical are determined
            np.testing.assert_allclose(got["lam"], lam, atol=1e-10 * scale)
            tot = sum(F)
            tot_got = sum(np.array([*got["Ft"][i][:2], got["lam"][i]]) for i in range(2))
            np.testing.assert_allclose(tot_got, tot, atol=1e-10 * scale)
            rs = law.contensou_ratio * law.contensou_radius
            if rs > 0.0:
                e = _body(TOP, y)[0]
                arms = [a for _, a in _arms(TOP, e)]
                Kz = sum(np.cross(arms[i], F[i])[2] + M[i] for i in range(2))
                Kz_got = sum(
                    np.cross(arms[i], [*got["Ft"][i][:2], got["lam"][i]])[2] + rs * got["Ft"][i][2]
                    for i in range(2)
                )
                assert abs(Kz_got - Kz) < 1e-10 * scale * TOP.distance
            continue
        np.testing.assert_allclose(got["lam"], lam, atol=1e-10 * scale)
        rs = law.contensou_ratio * law.contensou_radius
        for i in range(2):
            if mode[i]:
                want = [F[i][0], F[i][1]] + ([M[i] / rs] if rs > 0 else [])
                np.testing.assert_allclose(got["Ft"][i][: len(want)], want, atol=1e-10 * scale)


@pytest.mark.parametrize("stuck", [0, 1], ids=["ball-rolling", "stem-rolling"])
def test_mixed_modes_match_an_independent_kkt_solve(stuck):
    # one contact sticking, the other sliding (Coulomb): the phase's closed form (a 3×3 solve and
    # a Schur complement) against this file's KKT assembly
    law = Coulomb(0.3)
    rng = np.random.default_rng(8)
    p = _params(law)
    name = ("both-ball-rolling", "both-stem-rolling")[stuck]
    phase = {ph.name: ph for ph in stemslip.MODEL.phases}[name]
    mode = (stuck == 0, stuck == 1)
    b = TOP.ball
    for _ in range(20):
        y = _random_state(TOP, rng, spin=60.0)
        y[10] = 3.0 + stuck
        lam, F, M, Vdot, wdot = _kkt(TOP, law, y, mode)
        l1, l2, _, _ = stemslip.both_forces(y, p)
        rates = phase.rhs(0.0, y, p)
        scale = b.m * b.g + float(np.sum(np.abs(lam)))
        assert abs(l1 - lam[0]) < 1e-11 * scale and abs(l2 - lam[1]) < 1e-11 * scale
        np.testing.assert_allclose(rates[2:4], Vdot[:2], atol=1e-11 * scale / b.m)
        e, w, L, I = _body(TOP, y)
        Ldot = I @ wdot + np.cross(w, I @ w)
        np.testing.assert_allclose(rates[4:7], Ldot, atol=1e-10 * np.max(np.abs(Ldot)))


def _gaps(top, theta):
    b = top.ball
    c = np.cos(theta)
    return (b.R - b.R * b.alpha * c) - (top.radius - (b.R * b.alpha + top.distance) * c)


def test_friedl_top_completes_its_life_cycle_under_coulomb_contensou(run):
    # touchdown, the stem phase (re-inverted past π/2), re-landing on the ball, bounces that
    # accumulate into the double contact, the stem lifts off, the top falls back on its ball
    assert run.status == "completed", run.message
    reasons = [sw.reason for sw in run.switches]
    assert reasons[0] == "touchdown" and "landing" in reasons
    assert "accumulation" in reasons and "stem lifts off" in reasons
    assert len(run.switches) < 100  # no chattering
    on_stem = run.contact == "stem"
    assert np.max(run.theta[on_stem]) > 2.9  # near the inverted spin on the stem
    assert run.contact[-1] == "ball" and run.theta[-1] < run.theta[np.flatnonzero(on_stem)[-1]]
    acc = next(sw for sw in run.switches if sw.reason == "accumulation")
    assert acc.after == "both-sliding" and acc.t_event > acc.t


def test_double_contact_samples_keep_both_contacts_with_the_dry_law(run):
    p = run.params
    both = np.flatnonzero(run.contact == "both")
    assert both.size > 10
    mg = TOP.ball.m * TOP.ball.g
    assert np.all(run.gn_ball[both] >= 0.0) and np.all(run.gn_stem[both] >= 0.0)
    np.testing.assert_allclose(run.gn_ball[both] + run.gn_stem[both], mg, rtol=1e-12)
    assert np.max(np.abs(_gaps(TOP, run.theta[both]))) <= 8 * np.finfo(float).eps * TOP.distance
    law = CONTENSOU
    rs = law.contensou_ratio * law.contensou_radius
    for j in both[:: max(1, both.size // 40)]:
        y = stem.on_both(run.states[:, j], VISCOUS)
        e, w, L, _ = _body(TOP, y)
        V = np.array([y[2], y[3], 0.0])
        lam = (run.gn_ball[j], run.gn_stem[j])
        Ft, Mt = np.zeros(2), 0.0
        for i, (_, a) in enumerate(_arms(TOP, e)):
            nu = V + np.cross(w, a)
            assert abs(nu[2]) < 1e-12 * (np.linalg.norm(w) * TOP.distance)  # gap rate 0
            gam = np.array([nu[0], nu[1], rs * w[2]])
            assert np.linalg.norm(gam) > p[ix.BAND]  # sliding: outside the stopping band
            # the sliding force: opposite the slip, magnitude μ λ_i (generalised)
            Ft += -law.mu * lam[i] * gam[:2] / np.linalg.norm(gam)
            Mt += -law.mu * lam[i] * rs * gam[2] / np.linalg.norm(gam)
        scale = law.mu * mg
        assert abs(run.F_x[j] - Ft[0]) < 1e-9 * scale and abs(run.F_y[j] - Ft[1]) < 1e-9 * scale
        assert abs(run.M_n[j] - Mt) < 1e-9 * scale * rs


def test_energy_never_increases_over_the_run_and_at_each_jump(run):
    E = np.array([_energy(TOP, run.states[:, j]) for j in range(run.t.size)])
    # the model's E is this definition
    np.testing.assert_allclose(run.E, E, rtol=1e-12, atol=1e-12 * E[0])  # rounding of E0 terms
    # each step's local error is rtol relative (DOP853 error control); dissipative otherwise
    assert np.all(np.diff(E) <= 10 * run.rtol * E[0])
    for sw, (y_ev, y_sw) in zip(run.switches, run.jumps, strict=True):
        assert _energy(TOP, y_sw) <= _energy(TOP, y_ev) + 1e-13 * E[0], sw


def test_lift_off_drops_the_force_of_the_contact_that_opens(run):
    p = run.params
    mg = TOP.ball.m * TOP.ball.g
    lifts = [
        (sw, y_ev)
        for sw, (y_ev, _) in zip(run.switches, run.jumps, strict=True)
        if sw.before.startswith("both") and not sw.after.startswith("both")
    ]
    assert lifts
    for sw, y_ev in lifts:
        y = np.array(y_ev, dtype=float)
        f_ball, f_stem = (float(v) for v in stemslip.both_forces(y, p)[:2])
        opened, kept = (f_stem, f_ball) if sw.after.startswith("ball") else (f_ball, f_stem)
        assert sw.reason == ("stem lifts off" if sw.after.startswith("ball") else "ball lifts off")
        assert abs(opened) < 1e-8 * mg and kept == pytest.approx(mg, rel=1e-8)
        # that contact opens: its clearance grows after the switch
        th = run.at(min(sw.t + 1e-3, run.t[-1])).theta
        clear = TOP.stem_clearance(th) if sw.after.startswith("ball") else -TOP.stem_clearance(th)
        assert clear > 0.0


@pytest.mark.parametrize(
    "law",
    [Coulomb(0.3), CONTENSOU, Coulomb(3.0), Coulomb(3.0, contensou_radius=5e-4)],
    ids=["coulomb", "contensou", "coulomb-mu3", "contensou-mu3"],
)
def test_closure_impulse_obeys_the_dry_law_and_loses_energy(law):
    # the limit of accumulating impacts: a top on its ball rocking onto the stem (a small normal
    # velocity there). Both normal velocities stopped; a contact with a compressive impulse
    # obeys the law (sliding: opposite its slip, magnitude μ P_n; sticking: inside its cone, its
    # slip stopped), one pulled back (P_n < 0, the tail's non-impulsive share) carries no
    # friction; the energy does not rise
    rng = np.random.default_rng(2)
    p = _params(law)
    rs = law.contensou_ratio * law.contensou_radius
    k = 4 if rs > 0 else 3
    t = [0, 1, 3] if k == 4 else [0, 1]
    seen = set()
    for n in range(40):
        y = _random_state(TOP, rng)
        e, w, L, I = _body(TOP, y)
        nodal = np.cross(Z, e) / np.linalg.norm(np.cross(Z, e))
        y1 = y.copy()
        y1[4:7] = I @ (w + rng.uniform(-0.2, 0.2) * nodal)
        if n % 4 == 0:  # both contact points moving straight down (stem) or at rest (ball):
            # no slip, only the sticking (plastic) impulse is admissible
            rows = []
            for _, a in _arms(TOP, e):
                rows.append(np.hstack([np.eye(3), -np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]],
                                                              [-a[1], a[0], 0]])]))  # fmt: skip
            x = np.linalg.lstsq(np.vstack(rows), [0, 0, 0, 0, 0, -1e-3], rcond=None)[0]
            y1[2:4] = x[:2]
            y1[4:7] = I @ x[3:]
        y1[10] = 0.0
        e1, w1, L1, _ = _body(TOP, y1)
        arms = _arms(TOP, e1)
        V = np.array([y1[2], y1[3], -np.cross(w1, arms[0][1])[2]])
        try:
            after, Pi, mode = stemslip.close_both(
                contact.from_gliding(y1, (*p[:11],)), p, "ball", tail=True
            )
        except mett.dynamics.registry.JumpFailed:
            continue
        seen.add(mode)
        ea, wa, La, _ = _body(TOP, after)
        Va = np.array([after[2], after[3], 0.0])
        E0 = 0.5 * TOP.ball.m * V @ V + 0.5 * L1 @ w1
        E1 = 0.5 * TOP.ball.m * Va @ Va + 0.5 * La @ wa
        assert E1 <= E0 * (1 + 1e-12)
        for i, (_, a) in enumerate(_arms(TOP, ea)):
            va = Va + np.cross(wa, a)
            assert abs(va[2]) < 1e-9 * max(1e-3, np.linalg.norm(V))
            Pn = Pi[i * k + 2]
            Pt = Pi[[i * k + j for j in t]]
            vb = V + np.cross(w1, arms[i][1])
            g_before = np.array([vb[0], vb[1]] + ([rs * w1[2]] if rs else []))
            if mode[i]:
                assert Pn >= 0.0 and np.linalg.norm(Pt) <= law.mu * Pn * (1 + 1e-9)
                g_after = np.array([va[0], va[1]] + ([rs * wa[2]] if rs else []))
                assert np.linalg.norm(g_after) < 1e-9 * max(1e-3, np.linalg.norm(g_before))
            elif Pn < 0.0:
                assert np.all(Pt == 0.0)
            else:
                want = -law.mu * Pn * g_before / np.linalg.norm(g_before)
                np.testing.assert_allclose(Pt, want, atol=1e-12 * law.mu * Pn)
    assert (False, False) in seen, seen
    if law.mu > 1.0:  # a large cone admits the plastic stick of the stem at rest
        assert (False, True) in seen or (True, True) in seen, seen


def test_coulomb_start_rolls_on_its_ball_for_8_s():
    tr = mett.simulate(TOP, START, 8.0, friction=Coulomb(0.3))
    assert tr.status == "completed" and set(tr.contact) == {"ball"}


@pytest.mark.slow
def test_scipy_and_compiled_backends_agree_on_the_switches(run):
    # the same DOP853 on both backends with the same event functions: each located time to the
    # event tolerance of rtol = 1e-10 over the run's 8 s (1e-9 s), the same sequence
    ref = mett.simulate(TOP, START, 8.0, friction=CONTENSOU, backend="scipy")
    comp = mett.simulate(TOP, START, 8.0, friction=CONTENSOU, backend="compiled")
    assert ref.status == comp.status == "completed"
    got = [(sw.before, sw.after, sw.reason) for sw in comp.switches]
    assert [(sw.before, sw.after, sw.reason) for sw in ref.switches] == got
    for a, b in zip(ref.switches, comp.switches, strict=True):
        assert abs(a.t - b.t) < 1e-9 and abs(a.t_event - b.t_event) < 1e-9


def test_the_gallery_figure_of_the_dry_life_cycle_shows_what_its_caption_says(tmp_path):
    """`mett figures` draws stem_dry_friction (a PNG), skips it for another top (it shows
    friedl1997), and its detail window holds what the caption names: the re-landing on the
    ball, the accumulation into the double contact and the stem's lift-off."""
    from mett import gallery
    from mett.friction import Coulomb

    (path,) = gallery.generate(tmp_path, names=["stem_dry_friction"], animation=False, dpi=30)
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "stem_dry_friction" in gallery.skipped(mett.presets.get("cohen1977"))
    top = mett.presets.stemmed("friedl1997")
    s = mett.State.with_cm_at_rest(top.ball, theta=0.1, omega3=180.0)
    run = mett.simulate(top, s, 8.0, friction=Coulomb(0.3, contensou_radius=5e-4))
    t0, t1 = gallery.DRY_WINDOW
    inside = [sw.reason for sw in run.switches if t0 < sw.t < t1]
    assert inside[0] == "landing" and "accumulation" in inside
    assert inside[-1] == "stem lifts off" and set(run.contact) == {"ball", "stem", "both"}


# --- both contacts sticking under Coulomb: the body rolls about the contact line ---------------

# a top whose stem sphere is larger than its ball (r_s > R: θ_t < π/2), the only geometry where
# both contacts can stick (below); and the friedl1997 top (r_s < R)
BIG_STEM = mett.TippeTop(m=0.006, R=0.015, alpha=0.2, I1=8e-7, I3=7e-7, mu=0.3).with_stem(
    radius=0.02, distance=0.013
)


def _rolling_state(top, phi, Om):
    """Both contact points at rest: ω = Ω d̂ about the contact line (d̂ the horizontal direction
    of the axis), V = −ω × a_1; θ = θ_t (L_z form, flag 5)."""
    th = top.touchdown_angle
    e = np.array([math.sin(th) * math.sin(phi), -math.sin(th) * math.cos(phi), math.cos(th)])
    d = np.array([e[0], e[1], 0.0]) / math.hypot(e[0], e[1])
    w = Om * d
    b = top.ball
    L = b.I1 * w + (b.I3 - b.I1) * np.dot(w, e) * e
    V = -np.cross(w, _arms(top, e)[0][1])
    return np.concatenate(([0.0, 0.0], V[:2], L, e, [5.0]))


def _rolling_cone(top, Om):
    """The closed form of the rolling about the contact line (the theory page): the line turns
    about the vertical at −Ω cot θ_t, the centre of mass (at height z_G above the line) on a
    circle, T = −m Ω² z_G cot θ_t along the line; the moment about the line's normal n̂ gives
    λ_2 = (−m g l sin²θ_t + Ω² J cos θ_t)/(l_s sin²θ_t), J = m z_G² + I1 cos²θ_t + I3 sin²θ_t
    the moment of inertia about the contact line; λ_1 = m g − λ_2."""
    b = top.ball
    th = top.touchdown_angle
    l = b.R * b.alpha
    zG = b.R - l * math.cos(th)
    J = b.m * zG**2 + b.I1 * math.cos(th) ** 2 + b.I3 * math.sin(th) ** 2
    s2 = math.sin(th) ** 2
    lam2 = (-b.m * b.g * l * s2 + Om**2 * J * math.cos(th)) / (top.distance * s2)
    return b.m * b.g - lam2, lam2, -b.m * Om**2 * zG / math.tan(th)


@pytest.mark.parametrize("top", [TOP, BIG_STEM], ids=["friedl", "big-stem"])
def test_both_rolling_forces_match_the_rolling_cone_and_the_kkt_solve(top):
    law = Coulomb(0.3)
    p = _params(law, top)
    phase = {ph.name: ph for ph in stemslip.MODEL.phases}["both-rolling"]
    b = top.ball
    mg = b.m * b.g
    rng = np.random.default_rng(3)
    for Om in (0.0, 5.0, 20.0, -20.0, 60.0, 300.0):
        y = _rolling_state(top, rng.uniform(0.0, 2.0 * math.pi), Om)
        lam1, lam2, T = _rolling_cone(top, Om)
        scale = mg + abs(lam1) + abs(lam2)
        got = stemslip.both_stick_forces(y, p, (True, True))
        assert (
            abs(got["lam"][0] - lam1) < 1e-10 * scale and abs(got["lam"][1] - lam2) < 1e-10 * scale
        )
        e = y[7:10]
        d = np.array([e[0], e[1], 0.0]) / math.hypot(e[0], e[1])
        n = np.cross(Z, d)
        Fsum = got["Ft"][0] + got["Ft"][1]
        assert abs(Fsum @ d - T) < 1e-10 * scale and abs(Fsum @ n) < 1e-10 * scale
        # the phase's closed form against the KKT solve (the motion is determined)
        lam, F, M, Vdot, wdot = _kkt(top, law, y, (True, True))
        np.testing.assert_allclose(stemslip.both_forces(y, p)[:2], lam, atol=1e-10 * scale)
        rates = phase.rhs(0.0, y, p)
        np.testing.assert_allclose(rates[2:4], Vdot[:2], atol=1e-10 * scale / b.m)
        e_, w, L, I = _body(top, y)
        Ldot = I @ wdot + np.cross(w, I @ w)
        np.testing.assert_allclose(rates[4:7], Ldot, atol=1e-10 * scale * top.distance)
        if top is TOP:  # r_s < R, cos θ_t < 0: the stem is pulled up at every Ω
            assert lam2 < 0.0


def test_both_contacts_stick_where_some_split_along_the_line_fits_both_cones():
    # the mode selection with both slips within the band: both-rolling exactly where the normal
    # forces are ≥ 0 and some split t_1 + t_2 = T of the force along the contact line puts both
    # forces in their cones (scanned here over the split), never for the friedl1997 top
    law = Coulomb(0.3)
    rng = np.random.default_rng(4)
    seen = set()
    for top, oms in ((BIG_STEM, np.linspace(0.0, 60.0, 25)), (TOP, (0.0, 30.0, 200.0))):
        p = _params(law, top)
        for Om in oms:
            y = _rolling_state(top, rng.uniform(0.0, 2.0 * math.pi), Om)
            y[10] = 2.0
            y[2] += 0.3 * p[ix.BAND]  # both slips within the band
            lam, F, _, _, _ = _kkt(top, law, y, (True, True))
            e = y[7:10]
            d = np.array([e[0], e[1], 0.0]) / math.hypot(e[0], e[1])
            T = (F[0] + F[1]) @ d
            fits = min(lam) >= 0.0 and any(
                np.hypot(F[0] @ np.cross(Z, d), t) <= law.mu * lam[0]
                and np.hypot(F[1] @ np.cross(Z, d), T - t) <= law.mu * lam[1]
                for t in np.linspace(-abs(T) - 1.0, abs(T) + 1.0, 20001)
            )
            try:
                out = stemslip._settle_both(y, p)
                rolls = round(out[10]) == 5
            except mett.dynamics.registry.JumpFailed:
                rolls = False
            assert rolls == fits, (Om, lam, T)
            if rolls:  # both slips stopped, both normal velocities 0
                assert max(stemslip._slips(out, p)) < 1e-12
            seen.add((top is BIG_STEM, rolls))
    # the big stem: a window of Ω that rolls, and Ω outside it; friedl1997: never
    assert seen == {(True, True), (True, False), (False, False)}


def test_both_rolling_is_a_steady_rolling_without_loss():
    # the phase integrated by itself: Ω constant (E = ½ J Ω² + const, no work by sticking
    # forces), so the forces are constant and no exit event can fire; both slips stay at the
    # integration error
    from scipy.integrate import solve_ivp

    law = Coulomb(0.3)
    p = _params(law, BIG_STEM)
    phase = {ph.name: ph for ph in stemslip.MODEL.phases}["both-rolling"]
    y0 = _rolling_state(BIG_STEM, 0.3, 20.0)
    rtol = 1e-10
    sol = solve_ivp(phase.rhs, (0.0, 1.0), y0, args=(p,), method="DOP853", rtol=rtol, atol=1e-14)
    E = np.array([_energy(BIG_STEM, sol.y[:, j]) for j in range(sol.t.size)])
    # DOP853 error control: rtol per step, the steps' errors add up over ≤ 10³ steps
    assert np.max(np.abs(E - E[0])) < 1e3 * rtol * E[0]
    lam0 = _rolling_cone(BIG_STEM, 20.0)
    mg = BIG_STEM.ball.m * BIG_STEM.ball.g
    for j in range(0, sol.t.size, max(1, sol.t.size // 20)):
        f = stemslip.both_forces(sol.y[:, j], p)
        assert abs(f[0] - lam0[0]) < 1e-6 * mg and abs(f[1] - lam0[1]) < 1e-6 * mg
        assert max(f[2], f[3]) < 1e3 * rtol * 20.0 * BIG_STEM.distance  # slips: rtol × |v|
        assert min(stemslip._roll_margins(sol.y[:, j], p)) > 0.0


@pytest.mark.parametrize("which", [0, 1, 2], ids=["ball-cone", "stem-cone", "line-cone"])
def test_leaving_both_rolling_restarts_the_slip_the_failing_cone_names(which):
    # the exit jumps: across the line at the ball (stem) — that contact slips 2δ opposite its
    # force across the line, the other keeps sticking; along the line — both slip together,
    # 2δ opposite the total; both normal velocities stay 0 and the energy changes by O(m v δ)
    law = Coulomb(0.3)
    p = _params(law, BIG_STEM)
    ev = {0: "both-stem-rolling", 1: "both-ball-rolling", 2: "both-sliding"}[which]
    y = _rolling_state(BIG_STEM, 0.3, 20.0)
    y[2] += 1e-4  # a force across the line (P_i ≠ 0): no longer exactly the symmetric cone
    y = stemslip._stop_pair(y, p)
    phase = {ph.name: ph for ph in stemslip.MODEL.phases}["both-rolling"]
    jump = next(e for e in phase.events if e.target == ev).jump
    out = jump(y, p)
    assert stemslip.BOTH_FLAGS[float(round(out[10]))] == ev
    e, w, L, _ = _body(BIG_STEM, out)
    V = np.array([out[2], out[3], 0.0])
    nus = [V + np.cross(w, a) for _, a in _arms(BIG_STEM, e)]
    d = np.array([e[0], e[1], 0.0]) / math.hypot(e[0], e[1])
    band = p[ix.BAND]
    for nu in nus:
        assert abs(nu[2]) < 1e-12
    _, _, _, P1, P2, T = stemslip._roll_both(y, p)
    if which == 2:
        for nu in nus:
            np.testing.assert_allclose(nu[:2], -2 * band * np.sign(T) * d[:2], atol=1e-3 * band)
    else:
        P = (P1, P2)[which]
        n = np.cross(Z, d)
        np.testing.assert_allclose(nus[which][:2], -2 * band * np.sign(P) * n[:2], atol=1e-3 * band)
        assert np.linalg.norm(nus[1 - which][:2]) < 1e-3 * band


# --- the near-stop pass (the thesis body's double contact under Coulomb(0.01)) ---------------

THESIS_STEM = mett.presets.get("rutstam2013").with_stem(radius=0.004, distance=0.026)
# a state of its run from θ0 = 0.1, ω3 = 155 (60 s) at t = 55.620000108 s: both contacts sliding
# (flag 2, L_z form), the ball's slip 8.6 δ and falling; once per half nutation it swings down
# to 1.0–1.3 δ and up again without reaching the band δ
NEAR_STOP_T0 = 55.620000108017976
NEAR_STOP_Y0 = [
    -0.38653592500861905, 0.3165689977011036, 0.0002505732621477875, 0.0030093098556673178,
    -2.804761986782444e-05, 2.335140432733643e-06, 0.00011867848574785954, 0.7855092623401435,
    -0.06539857739880163, -0.6153846153846154, 2.0,
]  # fmt: skip


def _continue(top, law, y0, t0, t_end, backend="auto"):
    """A run of the stemmed dry model from the raw state ``y0`` at ``t0`` (its phase by flag)."""
    from mett.dynamics import simulation

    prep = simulation.prepare_run(
        top.ball, mett.State(theta=0.1, omega3=155.0), t_end, model=stem.MODEL,
        stem_radius=top.radius, stem_distance=top.distance, rtol=1e-10, atol=None,
        t_eval=None, events=None, method="DOP853", backend=backend, max_step=math.inf,
        friction=law,
    )  # fmt: skip
    prep.run.y0 = np.array(y0, dtype=float)
    prep.run.t0 = t0
    prep.run.phase = prep[1][stemslip.BOTH_FLAGS[float(y0[10])]]
    return simulation.run_prepared(prep)


def test_a_near_stop_pass_is_stopped_inside_the_cone():
    # the pass that stalled the run: the ball's slip falls to ~1.3 δ and hovers there (steps of
    # 6e-8 s, the slip zigzagging from step to step at the integrator's stability limit) without
    # reaching the band δ; the near-stop event stops it at 1.5 δ, where sticking is admissible;
    # the ball then rolls, the stem slides
    law = Coulomb(0.01)
    tr = _continue(THESIS_STEM, law, NEAR_STOP_Y0, NEAR_STOP_T0, NEAR_STOP_T0 + 0.003)
    assert tr.status == "completed", tr.message
    p = tr.params
    band = p[ix.BAND]
    sw = tr.switches[0]
    assert (sw.before, sw.after, sw.reason) == ("both-sliding", "both-ball-rolling", "stop")
    y_ev, y_sw = tr.jumps[0]
    s_ev = stemslip._slips(np.asarray(y_ev), p)[0]
    # at the gate k δ (to the event location's tolerance: the slip moves by ≤ 1e-6 δ there)
    assert abs(s_ev - stemslip.NEAR_STOP * band) < 1e-3 * band
    # the slip fell to it from above: every sample before has a larger slip
    before = np.flatnonzero(tr.t < sw.t)
    assert min(stemslip._slips(tr.states[:, j], p)[0] for j in before) > s_ev
    # the jump: the ball's slip removed, the stem's kept, both normal velocities 0, the state
    # changed by at most that slip, the energy not raised
    y_sw = np.asarray(y_sw)
    assert stemslip._slips(y_sw, p)[0] < 1e-6 * band
    assert abs(stemslip._slips(y_sw, p)[1] - stemslip._slips(np.asarray(y_ev), p)[1]) < 2 * s_ev
    e, w, L, _ = _body(THESIS_STEM, y_sw)
    V = np.array([y_sw[2], y_sw[3], 0.0])
    for _, a in _arms(THESIS_STEM, e):
        assert abs((V + np.cross(w, a))[2]) < 1e-12
    assert np.max(np.abs(y_sw[2:4] - np.asarray(y_ev)[2:4])) <= s_ev
    # the loss, ½ m (1.5 δ)² ~ 1e-19 J, lies below the rounding of E (~1e-18 J): not raised
    E_ev = _energy(THESIS_STEM, y_ev)
    assert _energy(THESIS_STEM, y_sw) <= E_ev * (1 + 8 * np.finfo(float).eps)
    # sticking admissible there, by this file's KKT solve: both normal forces ≥ 0, the ball's
    # sticking force inside its cone
    lam, F, _, _, _ = _kkt(THESIS_STEM, law, y_sw, (True, False))
    assert min(lam) >= 0.0 and math.hypot(F[0][0], F[0][1]) <= law.mu * lam[0]
    # every sample: forces ≥ 0 summing to m g; the energy never rises beyond the step error
    both = np.flatnonzero(tr.contact == "both")
    mg = THESIS_STEM.ball.m * THESIS_STEM.ball.g
    assert np.all(tr.gn_ball[both] >= 0.0) and np.all(tr.gn_stem[both] >= 0.0)
    np.testing.assert_allclose(tr.gn_ball[both] + tr.gn_stem[both], mg, rtol=1e-12)
    E = np.array([_energy(THESIS_STEM, tr.states[:, j]) for j in range(tr.t.size)])
    assert np.all(np.diff(E) <= 10 * tr.rtol * E[0])
    # the scipy backend runs the same event functions: the same stop, its time to the event
    # tolerance (1e-9 s, as for the Friedl run's switches)
    ref = _continue(THESIS_STEM, law, NEAR_STOP_Y0, NEAR_STOP_T0, NEAR_STOP_T0 + 0.003, "scipy")
    assert [(w.before, w.after, w.reason) for w in ref.switches] == [
        (w.before, w.after, w.reason) for w in tr.switches
    ]
    assert abs(ref.switches[0].t - sw.t) < 1e-9


# --- both contacts sticking under Coulomb–Contensou (r_s > R): the same rolling ---------------

CONTENSOU_BIG = Coulomb(0.3, contensou_radius=5e-4)


def _minimax_reference(c, Aeq, beq, x0):
    """min s subject to |g_i| ≤ s c_i (g_1 = x[0:3], g_2 = x[3:6]) and Aeq x = beq, by SLSQP on
    (z, s), x = x_0 + N z over the null space N of Aeq (x_0 a particular solution), forces in
    units of max c_i, the cone constraints squared (smooth): an independent convex solve."""
    from scipy.linalg import null_space
    from scipy.optimize import minimize

    unit = max(c)
    cs = np.asarray(c, dtype=float) / unit
    xp = np.linalg.lstsq(Aeq, beq, rcond=None)[0] / unit
    N = null_space(Aeq)

    def cons(v):
        x, s = xp + N @ v[:-1], v[-1]
        return np.array([(s * cs[0]) ** 2 - x[0:3] @ x[0:3], (s * cs[1]) ** 2 - x[3:6] @ x[3:6]])

    z0 = N.T @ (np.asarray(x0, dtype=float) / unit - xp)
    x = xp + N @ z0
    s0 = max(np.linalg.norm(x[0:3]) / cs[0], np.linalg.norm(x[3:6]) / cs[1]) * 1.01 + 1e-3
    res = minimize(
        lambda v: v[-1],
        np.append(z0, s0),
        method="SLSQP",
        constraints=[{"type": "ineq", "fun": cons}],
        bounds=[(None, None)] * N.shape[1] + [(0.0, None)],
        options={"ftol": 1e-15, "maxiter": 1000},
    )
    # 8: no descent direction left at the precision asked for (ftol below rounding): accepted
    # with the constraints checked
    assert res.status in (0, 8), res.message
    assert np.min(cons(res.x)) > -1e-10 * (1.0 + res.x[-1] ** 2)  # squared: s² scale
    return res.x[-1], unit * (xp + N @ res.x[:-1])


def test_contensou_split_is_the_minimax_of_an_independent_convex_solve():
    # the split rule by itself on random totals (T along the line, P across it, K the moment
    # about the vertical) and normal forces: both contacts at the same fraction s of their
    # cones, that fraction the smallest any split reaches (SLSQP on the six unknowns)
    rng = np.random.default_rng(21)
    b = BIG_STEM.ball
    mu, rs = 0.3, CONTENSOU_BIG.contensou_ratio * CONTENSOU_BIG.contensou_radius
    st = math.sqrt(1.0 - ((BIG_STEM.radius - b.R) / BIG_STEM.distance) ** 2)
    h1, h2 = b.R * b.alpha * st, (b.R * b.alpha + BIG_STEM.distance) * st
    mg = b.m * b.g
    # rows: t_1 + t_2 = T, P_1 + P_2 = P, h_1 P_1 + h_2 P_2 + r*(m_1 + m_2) = K
    Aeq = np.array([[1, 0, 0, 1, 0, 0], [0, 1, 0, 0, 1, 0], [0, h1, rs, 0, h2, rs]], dtype=float)
    for _ in range(12):
        lam1 = rng.uniform(0.05, 0.95) * mg
        lam = (lam1, mg - lam1)
        T, P = rng.uniform(-0.3, 0.3, 2) * mg
        K = rng.uniform(-0.3, 0.3) * mg * BIG_STEM.distance
        got = stemslip._drill_split(lam[0], lam[1], T, P, K, h1, h2, rs, mu)
        g = np.array(got[:6])
        # the totals to rounding (scale: the forces, the moment's arm)
        np.testing.assert_allclose(Aeq[:2] @ g, [T, P], atol=1e-13 * mg)
        assert abs(Aeq[2] @ g - K) < 1e-13 * mg * BIG_STEM.distance
        c = (mu * lam[0], mu * lam[1])
        s = got[6]
        # the same fraction of both cones (the bisection resolves the weight to 2^-64)
        assert abs(np.linalg.norm(g[0:3]) / c[0] - s) < 1e-9 * s
        assert abs(np.linalg.norm(g[3:6]) / c[1] - s) < 1e-9 * s
        x0 = np.linalg.lstsq(Aeq, [T, P, K], rcond=None)[0]
        s_ref, _ = _minimax_reference(c, Aeq, np.array([T, P, K]), x0)
        # the model's split is feasible, so s ≥ the optimum; SLSQP's optimum is approached to
        # its tolerance (1e-15 in s, the constraint rows to ~1e-8 relative after squaring)
        assert s <= s_ref * (1.0 + 1e-6)
        assert s >= s_ref * (1.0 - 1e-6)


def _newton_euler_rows(top, law, y, Vdot, wdot):
    """The six Newton–Euler rows for the contact forces (F_1, m_1, F_2, m_2), m_i = M_i/r*,
    given the motion: Σ F_i = m V̇ + m g ẑ, Σ (a_i × F_i + r* m_i ẑ) = I ω̇ + ω × I ω."""
    b = top.ball
    rs = law.contensou_ratio * law.contensou_radius
    e, w, L, I = _body(top, y)
    A = np.zeros((6, 8))
    for i, (_, a) in enumerate(_arms(top, e)):
        for k in range(3):
            u = np.eye(3)[k]
            A[0:3, 4 * i + k] = u
            A[3:6, 4 * i + k] = np.cross(a, u)
        A[5, 4 * i + 3] = rs
    rhs = np.concatenate((b.m * Vdot + b.m * b.g * Z, I @ wdot + np.cross(w, I @ w)))
    return A, rhs


@pytest.mark.parametrize("Om", [0.0, 10.0, 18.0, 20.0, 25.0, 40.0])
def test_contensou_both_sticking_forces_match_an_independent_minimax(Om):
    # on the rolling about the contact line: the motion from this file's KKT solve, the force
    # systems consistent with it (a 3-dimensional family: compression along the line, a
    # drilling couple, drilling against a couple across the line) from the Newton–Euler rows,
    # the smallest common fraction of the cones over that family by SLSQP; the model's forces
    # obey the same rows, reach that fraction at both contacts, and the mode selection enters
    # "both-rolling" exactly where it is ≤ 1 with both normal forces ≥ 0
    from scipy.linalg import null_space

    law = CONTENSOU_BIG
    p = _params(law, BIG_STEM)
    b = BIG_STEM.ball
    mg = b.m * b.g
    y = _rolling_state(BIG_STEM, 1.1, Om)
    lam, F, M, Vdot, wdot = _kkt(BIG_STEM, law, y, (True, True))
    A, rhs = _newton_euler_rows(BIG_STEM, law, y, Vdot, wdot)
    got = stemslip.both_stick_forces(y, p, (True, True))
    x = np.concatenate(
        [np.append(got["Ft"][i][:2], [got["lam"][i], got["Ft"][i][2]]) for i in (0, 1)]
    )
    scale = mg + abs(lam[0]) + abs(lam[1])
    np.testing.assert_allclose(A[0:3] @ x, rhs[0:3], atol=1e-10 * scale)
    np.testing.assert_allclose(A[3:6] @ x, rhs[3:6], atol=1e-10 * scale * BIG_STEM.distance)
    np.testing.assert_allclose(got["lam"], lam, atol=1e-10 * scale)
    # the rolling's closed form: no force across the line, none about the vertical, so no
    # drilling torque; T split in proportion to the normal forces
    lam1, lam2, T = _rolling_cone(BIG_STEM, Om)
    assert abs(got["Ft"][0][2]) < 1e-9 * mg and abs(got["Ft"][1][2]) < 1e-9 * mg
    e = y[7:10]
    d = np.array([e[0], e[1], 0.0]) / math.hypot(e[0], e[1])
    if min(lam1, lam2) > 0.0:
        for i, lam_i in enumerate((lam1, lam2)):
            assert abs(got["Ft"][i][:2] @ d[:2] - T * lam_i / mg) < 1e-9 * scale
    # the family of force systems, reduced to (F_t,1, m_1, F_t,2, m_2) with λ fixed
    N = null_space(A)
    assert N.shape[1] == 3 and np.max(np.abs(N[[2, 6]])) < 1e-9  # λ_i determined
    keep = [0, 1, 3, 4, 5, 7]
    if min(lam) <= 0.0:
        assert round(stemslip._settle_both(_nudged(y, p), p)[10]) != 5
        return
    c = (law.mu * lam[0], law.mu * lam[1])
    # the free rows of the family: the totals of F_x, F_y and the moment about the vertical
    Aeq = A[[0, 1, 5]][:, keep]
    beq = Aeq @ x[keep]
    s_ref, _ = _minimax_reference(c, Aeq, beq, x[keep])
    s = max(np.linalg.norm(x[[0, 1, 3]]) / c[0], np.linalg.norm(x[[4, 5, 7]]) / c[1])
    assert abs(s - s_ref) < 1e-6 * s_ref
    assert abs(stemslip._roll_split(y, p)[8] - s) < 1e-9 * s
    rolls = round(stemslip._settle_both(_nudged(y, p), p)[10]) == 5
    assert rolls == (s_ref < 1.0), (Om, s_ref)


def _nudged(y, p):
    """A rolling state given a uniform slip of a third of the band, both contacts (flag 2)."""
    y = np.array(y, dtype=float)
    y[10] = 2.0
    y[2] += 0.3 * p[ix.BAND]
    return y


def test_contensou_mode_selection_window_and_friedl_never():
    # both sticking under Contensou is entered on the big-stem top in a window of Ω (its normal
    # forces ≥ 0, |T| ≤ μ m g), never on friedl1997 (r_s < R: λ_2 < 0)
    seen = set()
    for top, oms in ((BIG_STEM, np.linspace(0.0, 40.0, 9)), (TOP, (0.0, 30.0, 200.0))):
        p = _params(CONTENSOU_BIG, top)
        for Om in oms:
            y = _rolling_state(top, 0.7, Om)
            l1, l2, T = _rolling_cone(top, Om)
            fits = min(l1, l2) >= 0.0 and abs(T) <= CONTENSOU_BIG.mu * (l1 + l2)
            try:
                rolls = round(stemslip._settle_both(_nudged(y, p), p)[10]) == 5
            except mett.dynamics.registry.JumpFailed:
                rolls = False
            # away from the window's edges (the nudge moves the forces by O(δ))
            assert rolls == fits, (Om, l1, l2, T)
            seen.add((top is BIG_STEM, rolls))
    assert seen == {(True, True), (True, False), (False, False)}


def test_contensou_both_rolling_is_a_steady_rolling_without_loss():
    # the phase integrated by itself under Contensou: Ω constant, the closed-form forces, no
    # drilling torque, both slips at the integration error, the margin μ m g − |T| > 0
    from scipy.integrate import solve_ivp

    law = CONTENSOU_BIG
    p = _params(law, BIG_STEM)
    phase = {ph.name: ph for ph in stemslip.CONTENSOU.phases}["both-rolling"]
    y0 = _rolling_state(BIG_STEM, 0.3, 20.0)
    rtol = 1e-10
    sol = solve_ivp(phase.rhs, (0.0, 1.0), y0, args=(p,), method="DOP853", rtol=rtol, atol=1e-14)
    E = np.array([_energy(BIG_STEM, sol.y[:, j]) for j in range(sol.t.size)])
    assert np.max(np.abs(E - E[0])) < 1e3 * rtol * E[0]  # rtol per step, ≤ 10³ steps
    lam1, lam2, T = _rolling_cone(BIG_STEM, 20.0)
    mg = BIG_STEM.ball.m * BIG_STEM.ball.g
    for j in range(0, sol.t.size, max(1, sol.t.size // 20)):
        y = sol.y[:, j]
        d = stemslip._roll_split(y, p)
        assert abs(d[0] - lam1) < 1e-6 * mg and abs(d[1] - lam2) < 1e-6 * mg
        assert abs(d[8] - abs(T) / (law.mu * mg)) < 1e-6
        assert abs(d[4]) < 1e-6 * mg and abs(d[7]) < 1e-6 * mg  # drilling torques / r*
        e, w, L, _ = _body(BIG_STEM, y)
        assert abs(np.linalg.norm(w) - 20.0) < 1e3 * rtol * 20.0
        assert max(stemslip._slips(y, p)) < 1e3 * rtol * 20.0 * BIG_STEM.distance
        assert stemslip._br_line_cone(0.0, y, p) > 0.0
    assert stemslip._br_ball_cone(0.0, y0, p) == stemslip._br_stem_cone(0.0, y0, p) == 1.0


def test_contensou_cone_exit_slides_both_contacts_opposite_their_forces():
    # the exit jump at s = 1: both slip, each opposite its force of the split (on the rolling,
    # along the line opposite T, equal slips, ω_z = 0), the larger 2δ, normal velocities 0
    law = CONTENSOU_BIG
    p = _params(law, BIG_STEM)
    y = _rolling_state(BIG_STEM, 0.3, 30.0)  # s > 1: past the edge
    phase = {ph.name: ph for ph in stemslip.CONTENSOU.phases}["both-rolling"]
    ev = next(e for e in phase.events if e.fn is stemslip._br_line_cone)
    out = ev.jump(y, p)
    assert round(out[10]) == 2
    e, w, L, _ = _body(BIG_STEM, out)
    V = np.array([out[2], out[3], 0.0])
    d = np.array([e[0], e[1], 0.0]) / math.hypot(e[0], e[1])
    T = _rolling_cone(BIG_STEM, 30.0)[2]
    band = p[ix.BAND]
    for _, a in _arms(BIG_STEM, e):
        nu = V + np.cross(w, a)
        assert abs(nu[2]) < 1e-12
        np.testing.assert_allclose(nu[:2], -2 * band * np.sign(T) * d[:2], atol=1e-3 * band)
    assert abs(w[2]) * law.contensou_ratio * law.contensou_radius < 1e-3 * band


def _run_band(top, law):
    """The stopping band δ (m/s) of a run of :func:`_continue` (it scales with the state)."""
    from mett.dynamics import simulation

    prep = simulation.prepare_run(
        top.ball, mett.State(theta=0.1, omega3=155.0), 1.0, model=stem.MODEL,
        stem_radius=top.radius, stem_distance=top.distance, rtol=1e-10, atol=None,
        t_eval=None, events=None, method="DOP853", backend="scipy", max_step=math.inf,
        friction=law,
    )  # fmt: skip
    return prep.run.params[ix.BAND]


def test_a_contensou_double_contact_that_sticks_rolls_on_instead_of_failing():
    # both contacts sliding at 5 δ on the big-stem top at Ω = 20 rad/s (inside the window):
    # the slip stops, both stick, and the run completes rolling about the contact line (it
    # ended "failed" before); every sample of the rolling: θ at θ_t, forces ≥ 0 summing to
    # m g, Ω and E constant to the integration error, no drilling torque, margin > 0
    law = CONTENSOU_BIG
    band = _run_band(BIG_STEM, law)
    y0 = _rolling_state(BIG_STEM, 0.3, 20.0)
    y0[10] = 2.0
    y0[2] += 5 * band
    tr = _continue(BIG_STEM, law, y0, 0.0, 1.0, backend="scipy")
    assert tr.status == "completed", tr.message
    (sw,) = tr.switches
    assert (sw.before, sw.after, sw.reason) == ("both-sliding", "both-rolling", "stop")
    roll = np.flatnonzero(tr.phase == "rolling")
    assert roll.size > 5 and set(tr.contact[roll]) == {"both"}
    assert tr.t[roll[-1]] == 1.0
    mg = BIG_STEM.ball.m * BIG_STEM.ball.g
    assert np.all(tr.gn_ball[roll] > 0.0) and np.all(tr.gn_stem[roll] > 0.0)
    np.testing.assert_allclose(tr.gn_ball[roll] + tr.gn_stem[roll], mg, rtol=1e-12)
    assert np.max(np.abs(_gaps(BIG_STEM, tr.theta[roll]))) <= 8 * np.finfo(float).eps * 0.02
    Om = [np.linalg.norm(_body(BIG_STEM, tr.states[:, j])[1]) for j in roll]
    E = [_energy(BIG_STEM, tr.states[:, j]) for j in roll]
    # ≤ 10³ steps of rtol each
    assert np.ptp(Om) < 1e3 * tr.rtol * Om[0] and np.ptp(E) < 1e3 * tr.rtol * E[0]
    assert np.max(np.abs(tr.M_n[roll])) < 1e-6 * mg * law.contensou_radius
    assert np.all(tr.margin[roll] > 0.0)
    # the jump removed the slip (≤ 5δ) and raised no energy
    y_ev, y_sw = tr.jumps[0]
    assert max(stemslip._slips(np.asarray(y_sw), tr.params)) < 1e-6 * band
    assert _energy(BIG_STEM, y_sw) <= _energy(BIG_STEM, y_ev) * (1 + 8 * np.finfo(float).eps)
    # the compiled backend runs the same event functions: the same stop, its time to the event
    # tolerance (1e-9 s, as for the Friedl run's switches)
    comp = _continue(BIG_STEM, law, y0, 0.0, 1.0, backend="compiled")
    assert comp.status == "completed"
    assert [(w.before, w.after, w.reason) for w in comp.switches] == [
        (sw.before, sw.after, sw.reason)
    ]
    assert abs(comp.switches[0].t - sw.t) < 1e-9
