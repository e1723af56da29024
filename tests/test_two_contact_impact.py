"""The impact of the stemmed top at both contacts (mett.dynamics.stem.two_contact_impact,
docs/theory/stem.md#two-contact-impact): both spheres on the table when one of them arrives.

References independent of the code under test: the contact kinematics, the Delassus matrix and
the kinetic energy assembled here from the rigid-body definitions; the frictionless impact as
the linear complementarity problem v⁺ = v⁻ + W_nn P ≥ 0, P ≥ 0, P ⊥ v⁺, solved by enumerating
its four active sets and, separately, as the bound-constrained quadratic programme
min ½ PᵀW_nn P + v⁻ᵀP over P ≥ 0 (scipy.optimize.nnls of its Cholesky form); the flight that
lands on both spheres at once built from the closed-form torque-free top written here.
"""

from __future__ import annotations

import dataclasses
import itertools
import math

import numpy as np
import pytest
from scipy.optimize import nnls

import mett
from mett.dynamics import stem, stemslip
from mett.dynamics.registry import JumpFailed
from mett.friction import Coulomb

TOP = mett.presets.stemmed("friedl1997")
B = TOP.ball
Z = np.array([0.0, 0.0, 1.0])
L_BALL = B.R * B.alpha
SPHERES = ((B.R, L_BALL), (TOP.radius, L_BALL + TOP.distance))  # (radius, G → centre)
ROUND = 1e-12  # relative rounding allowance of the impulse arithmetic (a few ulps of sums)


def _viscous(mu):
    top = dataclasses.replace(B, mu=mu)
    return stem.MODEL.parameters(top, stem_radius=TOP.radius, stem_distance=TOP.distance)


def _dry(law):
    return stemslip.MODEL.parameters(
        B, friction=law, stem_radius=TOP.radius, stem_distance=TOP.distance
    )


def _skew(a):
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


def _body(g, vz):
    """3̂, the inertia tensor I, ω, V and the contact arms a_i of a gliding-layout state ``g``
    with the vertical CM velocity ``vz`` (definitions: I = I1 𝟙 + (I3 − I1) 3̂3̂ᵀ, ω = I⁻¹L)."""
    e = np.asarray(g[7:10], dtype=float) / np.linalg.norm(g[7:10])
    I = B.I1 * np.eye(3) + (B.I3 - B.I1) * np.outer(e, e)
    w = np.linalg.solve(I, np.asarray(g[4:7], dtype=float))
    V = np.array([g[2], g[3], vz])
    arms = [l_i * e - R_i * Z for R_i, l_i in SPHERES]
    return e, I, w, V, arms


def _kinetic(I, w, V):
    return 0.5 * B.m * V @ V + 0.5 * w @ I @ w


def _state(rng, rock=20.0, vz=(-0.3, 0.1)):
    """A gliding-layout state at the touchdown angle (both gaps 0) with random azimuth,
    precession, spin, rocking rate θ̇, horizontal and vertical CM velocity (a flight's)."""
    th = TOP.touchdown_angle
    phi = rng.uniform(0.0, 2.0 * math.pi)
    e = np.array([math.sin(th) * math.sin(phi), -math.sin(th) * math.cos(phi), math.cos(th)])
    nodal = np.cross(Z, e) / math.sin(th)
    w = rng.uniform(-30, 30) * Z + rng.uniform(-150, 150) * e + rng.uniform(-rock, rock) * nodal
    L = (B.I1 * np.eye(3) + (B.I3 - B.I1) * np.outer(e, e)) @ w
    return np.concatenate(([0.0, 0.0], rng.uniform(-0.3, 0.3, 2), L, e)), rng.uniform(*vz)


def _lcp_enumeration(Wnn, v):
    """The solutions of v⁺ = v + W P ≥ 0, P ≥ 0, P ⊥ v⁺ among the four active sets."""
    out = []
    for active in itertools.product((False, True), repeat=2):
        idx = [i for i in range(2) if active[i]]
        P = np.zeros(2)
        if idx:
            P[idx] = np.linalg.solve(Wnn[np.ix_(idx, idx)], -v[idx])
        vp = v + Wnn @ P
        tol = 1e-14 * np.abs(v).max()
        if np.all(P >= -tol) and np.all(vp >= -tol):
            out.append((active, P))
    return out


def test_frictionless_impact_is_the_unique_lcp_solution():
    """μ = 0: the impulses are vertical and solve the LCP; exactly one of its four active sets
    is consistent (W_nn positive definite: a P-matrix), and the bound-constrained QP agrees."""
    p = _viscous(0.0)
    rng = np.random.default_rng(5)
    seen = set()
    for n in range(60):
        g, vz = _state(rng)
        e, I, w, V, arms = _body(g, vz)
        Iinv = np.linalg.inv(I)
        t = [np.cross(a, Z) for a in arms]
        Wnn = np.array([[1.0 / B.m + t[i] @ Iinv @ t[j] for j in range(2)] for i in range(2)])
        assert np.all(np.linalg.eigvalsh(Wnn) > 0.0)
        v = np.array([V[2] + np.cross(w, a)[2] for a in arms])
        sols = _lcp_enumeration(Wnn, v)
        assert len(sols) == 1, sols
        active, P_ref = sols[0]
        C = np.linalg.cholesky(Wnn).T  # Wnn = CᵀC: ½PᵀWP + vᵀP = ½|CP + C⁻ᵀv|² + const
        P_qp = nnls(C, -np.linalg.solve(C.T, v))[0]
        scale = np.abs(P_ref).max()
        np.testing.assert_allclose(P_qp, P_ref, rtol=0.0, atol=1e-10 * scale)
        if not any(active):
            continue
        _, imp = stem.land_both(g, vz, p, n % 2)
        # the single impacts' end of compression is located to solve_ivp's root tolerance
        np.testing.assert_allclose(imp.P[:, 2], P_ref, rtol=0.0, atol=1e-10 * scale)
        assert np.all(imp.P[:, :2] == 0.0)
        assert imp.closed == tuple(P_ref > 1e-10 * scale) or imp.closed == active
        seen.add(imp.closed)
    assert seen == {(True, False), (False, True), (True, True)}, seen


LAWS = {
    "viscous": _viscous(0.3),
    "viscous-mu3": _viscous(3.0),
    "coulomb": _dry(Coulomb(0.3)),
    "contensou": _dry(Coulomb(0.3, contensou_radius=5e-4)),
    "coulomb-mu3": _dry(Coulomb(3.0)),
}


@pytest.mark.parametrize("law", list(LAWS))
def test_impact_obeys_complementarity_the_balances_and_never_gains_energy(law):
    """Every law: P_1, P_2 ≥ 0; normal velocities after ≥ 0 and complementary (0 at a closed
    contact, no impulse at an open one); Δ(m V) = P_1 + P_2 and ΔL = a_1 × P_1 + a_2 × P_2 +
    Q ẑ; the kinetic energy (here, from its definition) never rises. The viscous closure obeys
    its law at the post-impact slip, P_t,i = −μ P_n,i v⁺_t,i; a dry contact's impulse lies in
    its cone. A state with no consistent active set ends with JumpFailed, never silently."""
    p = LAWS[law]
    dry = not law.startswith("viscous")
    mu = p[5]
    rng = np.random.default_rng(17)
    seen, failed = set(), 0
    for n in range(40):
        g, vz = _state(rng, vz=(-0.1, 0.05))
        e, I, w, V, arms = _body(g, vz)
        if min(V[2] + np.cross(w, a)[2] for a in arms) >= 0.0:
            continue  # no contact approaches the table: no impact
        T0 = _kinetic(I, w, V)
        try:
            _, imp = (stemslip.land_both(g, vz, p, n % 2) if dry
                      else stem.land_both(g, vz, p, n % 2))  # fmt: skip
        except JumpFailed:
            failed += 1
            continue
        seen.add(imp.closed)
        P, Q = imp.P, imp.Q
        Pscale = np.abs(P).max()
        V1 = V + P.sum(axis=0) / B.m
        L1 = I @ w + np.cross(arms[0], P[0]) + np.cross(arms[1], P[1]) + Q.sum() * Z
        # the state after carries the same L and horizontal momentum (on the manifold if both)
        np.testing.assert_allclose(imp.state[4:7], L1, rtol=0.0, atol=ROUND * np.abs(L1).max())
        np.testing.assert_allclose(imp.state[2:4], V1[:2], rtol=0.0, atol=ROUND * 0.3)
        w1 = np.linalg.solve(I, L1)
        v1 = [V1 + np.cross(w1, a) for a in arms]
        vscale = max(np.abs(V + np.cross(w, a)).max() for a in arms)
        for i in range(2):
            assert P[i, 2] >= -ROUND * Pscale
            assert v1[i][2] >= -1e-9 * vscale  # the impulse ODE's end located to ~1e-13
            if imp.closed[i]:
                assert abs(v1[i][2]) <= 1e-9 * vscale
            else:
                assert np.all(P[i] == 0.0)
            if dry and imp.closed[i]:
                rs = p[7]
                Pt = math.hypot(P[i, 0], P[i, 1], Q[i] / rs) if rs > 0.0 else math.hypot(*P[i, :2])
                assert Pt <= mu * P[i, 2] * (1.0 + 1e-9)
        if not dry and all(imp.closed):
            for i in range(2):
                want = -mu * P[i, 2] * v1[i][:2]
                np.testing.assert_allclose(P[i, :2], want, rtol=0.0, atol=1e-10 * Pscale)
        assert _kinetic(I, w1, V1) <= T0 * (1.0 + ROUND)
    assert (True, True) in seen and len(seen) >= 2, seen
    assert failed <= (0 if dry else 5)  # dry: Moreau's law where no active set fits


RUN_LAWS = {
    "viscous": {},
    "coulomb": {"friction": Coulomb(0.3)},
    "contensou": {"friction": Coulomb(0.3, contensou_radius=5e-4)},
}


def _assert_landing_jump(yb, ya, td, drilling=False):
    """The jump of a landing from flight, from the rigid-body definitions: the normal velocities
    after it ≥ 0 and 0 at the contact(s) closed; impulses at the closed contacts (and a drilling
    impulse Q ẑ where ``drilling``) that give both momentum balances, with vertical parts ≥ 0; the
    phase after it that of the contact(s) closed; the kinetic energy not raised. ``yb``, ``ya``:
    the states (L_z form) before and after; ``td``: its switch."""
    on = round(yb[10])  # the sphere the flight left
    e, I, w, _, arms = _body(yb, 0.0)
    Vb = np.array([yb[2], yb[3], -np.cross(w, arms[on])[2]])  # the lift-off: its contact's
    w_a = np.linalg.solve(I, ya[4:7])
    flag = round(ya[10])
    closed = {0: (0,), 1: (1,)}.get(flag, (0, 1))
    Va = np.array([ya[2], ya[3], -np.cross(w_a, arms[closed[0]])[2]])
    vn = [Va[2] + np.cross(w_a, a)[2] for a in arms]
    vscale = np.abs(Vb).max() + np.abs(w).max() * arms[1].max()
    for i in range(2):
        assert vn[i] >= -1e-9 * vscale and (i not in closed or abs(vn[i]) <= 1e-9 * vscale)
    # the impulses: Σ P_i = m ΔV and Σ a_i × P_i + Q ẑ = ΔL (Q only under Contensou)
    dP, dL = B.m * (Va - Vb), ya[4:7] - yb[4:7]
    rows = [np.hstack([np.eye(3)] * len(closed)),
            np.hstack([_skew(arms[i]) for i in closed])]  # fmt: skip
    A = np.vstack(rows)
    if drilling:
        A = np.hstack([A, np.concatenate([np.zeros(5), [1.0]])[:, None]])
    x, *_ = np.linalg.lstsq(A, np.concatenate([dP, dL]), rcond=None)
    resid = A @ x - np.concatenate([dP, dL])
    assert np.abs(resid[:3]).max() <= 1e-9 * np.abs(dP).max()
    assert np.abs(resid[3:]).max() <= 1e-9 * np.abs(dL).max()
    for j in range(len(closed)):  # the vertical parts are determined (the null space is ⊥ ẑ)
        assert x[3 * j + 2] >= -1e-9 * np.abs(dP).max()
    # the phase after it is that of the contact(s) closed (which may fly again at once)
    assert td.after.split("-")[0] == ("both" if flag >= 2 else ("ball", "stem")[flag])
    T_b = 0.5 * B.m * Vb @ Vb + 0.5 * w @ yb[4:7]
    T_a = 0.5 * B.m * Va @ Va + 0.5 * w_a @ ya[4:7]
    assert T_a <= T_b * (1.0 + ROUND)  # no configuration change: the kinetic energy


@pytest.mark.parametrize("law", list(RUN_LAWS))
def test_a_flight_that_lands_at_the_touchdown_angle_lands_on_both_spheres(law):
    """friedl1997 started exactly at the touchdown angle with θ̇ = 300 rad/s: the ball's contact
    would need a pulling force, so the top flies at once (h_ball = ḣ_ball = 0), while the stem,
    at zero gap too, moves down (ḣ_stem = −l_s sin θ_t θ̇ < 0): both spheres are on the table
    when the stem lands. The run names it "double touchdown" and goes on in the contact(s) the
    impact closed. Checked from the jump's states with the rigid-body balances written here:
    the impulse P = m ΔV with ΔL = Σ a_i × P_i (and Q ẑ under Contensou), P_i,z ≥ 0, the
    closed contacts' normal velocities 0 and the open one's ≥ 0, the energy not raised."""
    state = mett.State(theta=TOP.touchdown_angle, thetadot=300.0)
    traj = mett.simulate(TOP, state, t_end=0.005, **RUN_LAWS[law])
    assert traj.status == "completed"
    sw = traj.records["switches"]
    assert sw[0].reason == "lift-off" and sw[0].t == 0.0
    td = sw[1]
    assert td.reason == "double touchdown" and td.before == "flight" and td.t == 0.0
    before, after = traj.records["jumps"][1]
    lam_form = law != "viscous"

    def lz(y):  # the L_z of a λ-form state (λ = −L·a of the sphere of its flag)
        y = np.array(y, dtype=float)
        if lam_form and y[10] < 1.5:
            e = y[7:10] / np.linalg.norm(y[7:10])
            R_i, l_i = SPHERES[round(y[10])]
            a = l_i * e - R_i * Z
            y[6] = -(y[6] + y[4] * a[0] + y[5] * a[1]) / a[2]
        return y

    yb, ya = lz(before), lz(after)
    _assert_landing_jump(yb, ya, td, drilling=law == "contensou")


@pytest.mark.parametrize("mu", [0.0, 0.3])
def test_a_change_of_contact_closes_both_only_if_the_old_contact_would_not_open(mu):
    """The ball landing while the stem's contact is closed (v_stem = 0): the single impact at the
    ball if the stem then opens (reason "landing"), else the two-contact path, the stem in the
    active set while pushed: both closed at its end ("closure") or the stem open ("landing",
    its normal velocity ≥ 0, checked here from the state). The stem's
    normal velocity after the single impact is computed here from its impulse (the active-set
    test, independent of the selection); μ = 0: the stem always opens, since its normal
    velocity grows by P (1/m + l (l + l_s) sin²θ/I1) > 0. Fast slips (up to 3 m/s) make the
    ball's friction press the stem down. Energy never rises; a state where no active set
    satisfies the law ends with JumpFailed (a clear status in a run), never silently."""
    p = _viscous(mu)
    rng = np.random.default_rng(23)
    reasons, failed = set(), 0
    for _ in range(30):
        g, _ = _state(rng, rock=0.0)
        g[2:4] *= 10.0
        e, I, w, _, arms = _body(g, 0.0)
        nodal = np.cross(Z, e) / np.linalg.norm(np.cross(Z, e))
        w = w - rng.uniform(0.5, 20.0) * nodal  # θ̇ < 0: the ball moves down
        y = np.concatenate((g[:4], I @ w, g[7:10], [1.0]))
        V = np.array([y[2], y[3], -np.cross(w, arms[1])[2]])  # the stem's constraint
        assert (V + np.cross(w, arms[0]))[2] < 0.0
        try:
            out, reason, _ = stem.transition(y, p, "ball")
        except JumpFailed:
            failed += 1
            continue
        reasons.add(reason)
        # the single impact at the ball: its impulse, the stem's normal velocity after it
        _, P = stem.impact(y, p, "ball")
        w1 = np.linalg.solve(I, I @ w + np.cross(arms[0], P))
        v_stem = V[2] + P[2] / B.m + np.cross(w1, arms[1])[2]
        if v_stem >= 0.0:  # the stem opens after the ball's impact alone
            assert reason == "landing" and out[10] == 0.0
        elif reason == "landing":  # pushed during the impact (two-contact path), open at its end
            e1, I1, w_o, _, arms1 = _body(out, 0.0)
            V_o = -np.cross(w_o, arms1[0])[2]
            assert V_o + np.cross(w_o, arms1[1])[2] >= -1e-9 * np.abs(V).max()
        else:
            assert reason == "closure"
        E0 = float(stem.MODEL.derive(y[:, None], p)["E"][0])
        E1 = float(stem.MODEL.derive(out[:, None], p)["E"][0])
        assert E1 <= E0 * (1.0 + ROUND)
        if reason == "closure" and out[10] > 1.5:  # on both: no rocking left
            assert abs(float(stem.MODEL.derive(out[:, None], p)["thetadot"][0])) < 1e-9
    assert failed == 0  # the path is consistent by construction
    assert reasons == ({"landing"} if mu == 0.0 else {"landing", "closure"}), reasons


def test_a_dry_impact_arriving_without_slip_slides_in_its_invariant_direction():
    """The stem of friedl1997 started at θ_t with θ̇ = 100 rad/s arrives with a slip of a few
    nm/s, and sticking would need an impulse outside the cone (Coulomb, μ = 0.3): the slip starts
    along the direction u whose sliding keeps it along u, dv_t/dp = W_tz − μ W_tt u = s u,
    s > 0, and the impulse is P = p (−μ u, 1) with v_z = 0 at its end, p = −v_z/(W_zz −
    μ W_zt·u). (The band's stop event, located a rounding error above the band, restarted the
    integration on the same root until the loop gave up.)"""
    p = _dry(Coulomb(0.3))
    y0 = stemslip.MODEL.initial(mett.State(theta=TOP.touchdown_angle, thetadot=100.0), p)
    g = np.asarray(stemslip._lz(y0, p), dtype=float)[:10]
    e, I, w, _, arms = _body(g, 0.0)
    vz = -np.cross(w, arms[0])[2]  # the ball's contact at the lift-off
    V = np.array([g[2], g[3], vz])
    Iinv = np.linalg.inv(I)
    W = np.eye(3) / B.m - _skew(arms[1]) @ Iinv @ _skew(arms[1])
    v = V + np.cross(w, arms[1])
    assert np.hypot(v[0], v[1]) < 1e-8 and v[2] < 0.0
    P_stick = np.linalg.solve(W, -v)
    assert np.hypot(*P_stick[:2]) > 0.3 * P_stick[2]  # sticking is not admissible
    # the arm and the axis lie in the y–z plane (no precession, no spin): x decouples from
    # (y, z), so a sliding direction that stays put is ±ŷ
    assert abs(W[0, 1]) <= 1e-12 * np.abs(W).max() and abs(W[0, 2]) <= 1e-12 * np.abs(W).max()
    best = None
    for u in (np.array([0.0, 1.0]), np.array([0.0, -1.0])):
        if (W[:2, 2] - 0.3 * W[:2, :2] @ u) @ u > 0.0:
            best = u
    assert best is not None
    pz = -v[2] / (W[2, 2] - 0.3 * W[2, :2] @ best)
    want = pz * np.array([*(-0.3 * best), 1.0])
    f = stem.impact_frame(np.append(g, 0.0), stemslip._viscous(p), "stem", vz)
    P, Q, stuck = stemslip.dry_impulse(f, B.m, 0.3, 0.0)
    assert not stuck and Q == 0.0
    # the nm/s slip before and the 2δ restart change P by ~1e-9 of itself
    np.testing.assert_allclose(P, want, rtol=0.0, atol=1e-7 * np.abs(want).max())


# --- dry friction: the impact at both contacts always has a solution (issue 23) ----------------
#
# References written here from the definitions: the generalised Delassus matrix of the two
# contacts (Π_i = (P_x, P_y, P_z[, Q_i/r*]) at a_i, g_i = (v_x, v_y, v_z[, r* ω_z])) assembled
# column by column from Newton–Euler, Δ(mV) = Σ P_i, ΔL = Σ a_i × P_i + Σ Q_i ẑ; the law
# checked component by component; and, as an independent solver of the same velocity-level
# law, its modes enumerated (each contact open, sticking, or sliding along a unit direction u
# with g⁺_t = s u, s > 0, Π_t = −μ Π_n u) and each mode's square system solved by
# scipy.optimize.least_squares from a grid of directions.

DRY_MU3 = {
    "coulomb-mu3": Coulomb(3.0),
    "contensou-mu3": Coulomb(3.0, contensou_radius=5e-4),
}


def _generalised(g, vz, rs):
    """(W, g⁻, k) of a gliding-layout state with the vertical CM velocity ``vz``: the
    generalised Delassus matrix from Newton–Euler applied to unit impulses, and the
    generalised contact-point velocities before."""
    e, I, w, V, arms = _body(g, vz)
    k = 4 if rs > 0.0 else 3
    Iinv = np.linalg.inv(I)
    W = np.zeros((2 * k, 2 * k))
    for j in range(2 * k):
        Pi = np.zeros(2 * k)
        Pi[j] = 1.0
        P = [Pi[0:3], Pi[k : k + 3]]
        dL = np.cross(arms[0], P[0]) + np.cross(arms[1], P[1])
        if k == 4:
            dL = dL + rs * (Pi[3] + Pi[7]) * Z
        dw = Iinv @ dL
        dV = (P[0] + P[1]) / B.m
        for i in range(2):
            dv = dV + np.cross(dw, arms[i])
            W[i * k : i * k + 3, j] = dv
            if k == 4:
                W[i * k + 3, j] = rs * dw[2]
    g0 = []
    for a in arms:
        v = V + np.cross(w, a)
        g0 += [*v] + ([rs * w[2]] if k == 4 else [])
    return W, np.array(g0), k


def _tangential(k, i):
    return [i * k + j for j in ((0, 1, 3) if k == 4 else (0, 1))]


def _law_violation(W, g0, mu, k, x):
    """The largest violation of the velocity-level impact law by the impulse ``x``, relative to
    the impulse scale (impulses) and the largest speed before (velocities): P_n ≥ 0, g⁺_n ≥ 0,
    P_n g⁺_n = 0, |Π_t| ≤ μ P_n, Π_t = −μ P_n ĝ⁺_t where g⁺_t ≠ 0; and the energy change
    ΔT = Π·g⁺ − ½ΠᵀWΠ (≤ 0 wanted), relative to the kinetic scale."""
    g = g0 + W @ x
    vs = np.abs(g0).max()
    ps = vs / min(W[2, 2], W[k + 2, k + 2])
    worst = 0.0
    for i in range(2):
        r, t = i * k + 2, _tangential(k, i)
        Pn, gn = x[r], g[r]
        worst = max(worst, -Pn / ps, -gn / vs, min(Pn / ps, gn / vs))
        worst = max(worst, (np.linalg.norm(x[t]) - mu * Pn) / ps)
        slip = np.linalg.norm(g[t])
        if slip > 1e-9 * vs:
            worst = max(worst, np.abs(x[t] + mu * Pn * g[t] / slip).max() / ps)
    dT = x @ g - 0.5 * x @ W @ x
    return worst, dT / (ps * vs)


def _failing_states():
    """Random landings on both spheres at the touchdown angle with a contact approaching: all 29
    of seed 17's 40 states, and the 3 states of seeds 1 and 2 (its 17th; its 6th and 29th) whose
    landing ended with JumpFailed before at μ = 3."""
    for seed, keep in ((17, None), (1, (17,)), (2, (6, 29))):
        rng = np.random.default_rng(seed)
        for n in range(40):
            g, vz = _state(rng, vz=(-0.1, 0.05))
            e, I, w, V, arms = _body(g, vz)
            if (keep is None or n in keep) and min(V[2] + np.cross(w, a)[2] for a in arms) < 0.0:
                yield n % 2, g, vz


@pytest.mark.parametrize("law", list(DRY_MU3))
def test_dry_impact_at_both_contacts_always_finds_its_solution(law):
    """μ = 3, Coulomb and Coulomb–Contensou: every one of 32 random landings on both spheres
    gets an impact (before, 3 of them under Coulomb and 5 under Contensou had no consistent
    active set, JumpFailed "Painlevé-type inconsistency"): P_n ≥ 0, normal velocities after ≥ 0 and complementary, each
    closed contact's generalised impulse in its cone, Δ(mV) and ΔL (with Q ẑ) the impulses'
    sums, the kinetic energy not raised (all from the definitions here). And the solver of the
    velocity-level law alone (stemslip.moreau_impulse) on the same states, from the Delassus
    matrix assembled here: the whole law at both contacts (sliding opposite the slip after with
    |Π_t| = μ P_n, sticking inside the cone), to 1e-9 of the impulse."""
    fr = DRY_MU3[law]
    p = _dry(fr)
    rs = p[7]
    count, kinds = 0, set()
    for first, g, vz in _failing_states():
        count += 1
        e, I, w, V, arms = _body(g, vz)
        T0 = _kinetic(I, w, V)
        imp = stemslip.impact_both(g, vz, p, first)  # never raises
        P, Q = imp.P, imp.Q
        Pscale = np.abs(P).max()
        V1 = V + P.sum(axis=0) / B.m
        L1 = I @ w + np.cross(arms[0], P[0]) + np.cross(arms[1], P[1]) + Q.sum() * Z
        np.testing.assert_allclose(imp.state[4:7], L1, rtol=0.0, atol=ROUND * np.abs(L1).max())
        np.testing.assert_allclose(imp.state[2:4], V1[:2], rtol=0.0, atol=ROUND * 0.3)
        w1 = np.linalg.solve(I, L1)
        vscale = max(np.abs(V + np.cross(w, a)).max() for a in arms)
        for i in range(2):
            vn = (V1 + np.cross(w1, arms[i]))[2]
            assert P[i, 2] >= -1e-9 * Pscale
            assert vn >= -1e-9 * vscale
            assert min(P[i, 2] / Pscale, vn / vscale) <= 1e-9  # complementary
            Pt = math.hypot(P[i, 0], P[i, 1], Q[i] / rs) if rs > 0.0 else math.hypot(*P[i, :2])
            assert Pt <= fr.mu * P[i, 2] + 1e-9 * Pscale
        assert _kinetic(I, w1, V1) <= T0 * (1.0 + ROUND)
        kinds.add(imp.closed)
        # the velocity-level law by itself
        W, g0, k = _generalised(g, vz, rs)
        x = stemslip.moreau_impulse(W, g0, fr.mu, k)
        assert x is not None
        worst, dT = _law_violation(W, g0, fr.mu, k, x)
        assert worst <= 1e-9 and dT <= 1e-12
    assert count == 32
    assert {(True, False), (False, True), (True, True)} <= kinds, kinds


def _directions(n_t, phi):
    if n_t == 2:
        return np.array([math.cos(phi[0]), math.sin(phi[0])])
    return np.array([math.cos(phi[0]) * math.cos(phi[1]), math.sin(phi[0]) * math.cos(phi[1]),
                     math.sin(phi[1])])  # fmt: skip


def _enumerated_solutions(W, g0, mu, k):
    """All solutions of the velocity-level law found by enumerating the modes of both contacts
    (open, stick, slide) and solving each mode's square system with scipy's least_squares from
    a grid of sliding directions: the velocities after of those that satisfy the law."""
    from scipy.optimize import least_squares

    n_t = k - 1
    out = []
    vs = np.abs(g0).max()
    ps = vs / min(W[2, 2], W[k + 2, k + 2])
    grid = [np.array(v) for v in itertools.product(np.linspace(-3.0, 3.0, 5), repeat=n_t - 1)]
    for modes in itertools.product(("open", "stick", "slide"), repeat=2):

        def unpack(z, modes=modes):
            x, j, dirs = np.zeros(2 * k), 0, {}
            for i in range(2):
                r, t = i * k + 2, _tangential(k, i)
                if modes[i] == "stick":
                    x[r], x[t] = z[j], z[j + 1 : j + 1 + n_t]
                    j += 1 + n_t
                elif modes[i] == "slide":
                    u = _directions(n_t, z[j + 1 : j + n_t])
                    x[r] = z[j]
                    x[t] = -mu * z[j] * u
                    dirs[i] = (u, z[j + n_t])
                    j += 1 + n_t
            return x, dirs

        def resid(z, modes=modes):
            x, dirs = unpack(z)
            g = g0 + W @ x
            res = []
            for i in range(2):
                r, t = i * k + 2, _tangential(k, i)
                if modes[i] == "stick":
                    res += [g[r] / vs, *(g[t] / vs)]
                elif modes[i] == "slide":
                    u, s = dirs[i]
                    res += [g[r] / vs, *((g[t] - s * vs * u) / vs)]
            return np.array(res)

        size = sum(1 + n_t for m_ in modes if m_ != "open")
        starts = [None] if size == 0 else []
        if size:
            for ang in itertools.product(np.linspace(-3.0, 3.0, 5), *([grid] if n_t == 3 else [])):
                z = []
                for i in range(2):
                    if modes[i] == "stick":
                        z += [ps, *np.zeros(n_t)]
                    elif modes[i] == "slide":
                        z += [ps, *np.atleast_1d(ang[0] if n_t == 2 else
                                                 (ang[0], float(ang[1][0]))), 1.0]  # fmt: skip
                starts.append(np.array(z, dtype=float))
        for z0 in starts:
            if z0 is None:
                x = np.zeros(2 * k)
            else:
                sol = least_squares(resid, z0, xtol=1e-14, ftol=1e-14, gtol=1e-14)
                if np.abs(sol.fun).max() > 1e-11:
                    continue
                x, dirs = unpack(sol.x)
                if any(s <= 0.0 for _, s in dirs.values()):
                    continue
            worst, dT = _law_violation(W, g0, mu, k, x)
            if worst <= 1e-9:
                out.append(g0 + W @ x)
    return out


@pytest.mark.parametrize(
    "law",
    [Coulomb(0.3), pytest.param(Coulomb(0.3, contensou_radius=5e-4), marks=pytest.mark.slow)],
    ids=["coulomb", "contensou"],
)
def test_velocity_level_solver_against_an_enumeration_of_its_modes(law):
    """μ = 0.3: the velocities after the impact of stemslip.moreau_impulse equal those of the
    independent solver (the modes enumerated, scipy's least_squares on each), which finds one
    solution in velocity (the impulse along the line between the contacts is not determined: W
    is singular there) for each of 8 random landings on both spheres, to 1e-8 of the speeds."""
    p = _dry(law)
    rs = p[7]
    rng = np.random.default_rng(41)
    done = 0
    while done < 8:
        g, vz = _state(rng, vz=(-0.1, 0.05))
        W, g0, k = _generalised(g, vz, rs)
        if min(g0[2], g0[k + 2]) >= 0.0:
            continue
        done += 1
        x = stemslip.moreau_impulse(W, g0, law.mu, k)
        assert x is not None
        ref = _enumerated_solutions(W, g0, law.mu, k)
        assert ref
        vs = np.abs(g0).max()
        distinct = [v for j, v in enumerate(ref)
                    if all(np.abs(v - u).max() > 1e-8 * vs for u in ref[:j])]  # fmt: skip
        assert len(distinct) == 1
        np.testing.assert_allclose(g0 + W @ x, distinct[0], rtol=0.0, atol=1e-8 * vs)


def test_velocity_level_solver_without_friction_is_the_lcp():
    """μ = 0: the impulse of stemslip.moreau_impulse is normal and is the unique solution of
    the normal LCP (its four active sets enumerated here), to 1e-10 of the impulse."""
    rng = np.random.default_rng(7)
    for _ in range(20):
        g, vz = _state(rng)
        W, g0, k = _generalised(g, vz, 0.0)
        if min(g0[2], g0[5]) >= 0.0:
            continue
        x = stemslip.moreau_impulse(W, g0, 0.0, k)
        ((_, P_ref),) = _lcp_enumeration(W[np.ix_([2, 5], [2, 5])], g0[[2, 5]])
        scale = np.abs(P_ref).max()
        np.testing.assert_allclose(x[[2, 5]], P_ref, rtol=0.0, atol=1e-10 * scale)
        assert np.abs(x[[0, 1, 3, 4]]).max() <= 1e-12 * scale


def _change_of_contact(rng, rs):
    """A state on the stem (flag 1, L_z form) whose ball arrives (θ̇ < 0), slips up to 3 m/s."""
    g, _ = _state(rng, rock=0.0)
    g[2:4] *= 10.0
    e, I, w, _, arms = _body(g, 0.0)
    nodal = np.cross(Z, e) / np.linalg.norm(np.cross(Z, e))
    w = w - rng.uniform(0.5, 20.0) * nodal
    return np.concatenate((g[:4], I @ w, g[7:10])), I, w, arms


@pytest.mark.parametrize(
    "law",
    [Coulomb(0.0), Coulomb(1.0), Coulomb(1.0, contensou_radius=5e-4)],
    ids=["mu0", "coulomb-mu1", "contensou-mu1"],
)
def test_dry_landing_on_the_ball_while_the_stem_is_closed(law):
    """The ball landing while the stem's contact is closed, dry law: the single impact if the
    stem then opens, else the dry two-contact Darboux–Keller path (stem.contact_path: the stem
    in the active set while pushed, stick–slip at both contacts), else the velocity-level law.
    At μ = 1 (slips up to 3 m/s) 8 of the 30 take the path and end with both closed. Always
    an impact: P_n ≥ 0 at both, the stem's normal velocity after ≥ 0 and complementary,
    both impulses in their cones, the balances, the energy not raised; μ = 0: the normal LCP's
    solution (enumerated here), to 1e-9 of the impulse."""
    p = _dry(law)
    rs = p[7]
    rng = np.random.default_rng(29)
    closed = set()
    for _ in range(30):
        g, I, w, arms = _change_of_contact(rng, rs)
        V = np.array([g[2], g[3], -np.cross(w, arms[1])[2]])  # the stem's constraint
        T0 = _kinetic(I, w, V)
        imp = stemslip.impact_both(g, None, p, 0)
        closed.add(imp.closed)
        P, Q = imp.P, imp.Q
        Pscale = np.abs(P).max()
        V1 = V + P.sum(axis=0) / B.m
        L1 = I @ w + np.cross(arms[0], P[0]) + np.cross(arms[1], P[1]) + Q.sum() * Z
        np.testing.assert_allclose(imp.state[4:7], L1, rtol=0.0, atol=ROUND * np.abs(L1).max())
        w1 = np.linalg.solve(I, L1)
        vscale = max(np.abs(V + np.cross(w, a)).max() for a in arms)
        for i in range(2):
            vn = (V1 + np.cross(w1, arms[i]))[2]
            assert P[i, 2] >= -1e-9 * Pscale and vn >= -1e-9 * vscale
            assert min(P[i, 2] / Pscale, vn / vscale) <= 1e-9
            Pt = math.hypot(P[i, 0], P[i, 1], Q[i] / rs) if rs > 0.0 else math.hypot(*P[i, :2])
            assert Pt <= law.mu * P[i, 2] + 1e-9 * Pscale
        assert _kinetic(I, w1, V1) <= T0 * (1.0 + ROUND)
        if law.mu == 0.0:
            W, g0, k = _generalised(g, V[2], rs)
            ((_, P_ref),) = _lcp_enumeration(W[np.ix_([2, 5], [2, 5])], g0[[2, 5]])
            np.testing.assert_allclose(P[:, 2], P_ref, rtol=0.0, atol=1e-9 * Pscale)
    assert (True, True) in closed or law.mu == 0.0, closed


def test_dry_path_of_a_contact_arriving_without_slip_is_the_plastic_impact():
    """The dry path (stem.contact_path) when the ball arrives straight down without slip while
    the stem's contact is closed and at rest, μ = 1 and 10: the ball sticks throughout (its
    plastic impulse is well inside the cone, |P_t|/P_n ≈ 0.08 here) and the stem opens, so the
    impulse is the closed form P_1 = −W_11⁻¹ v_1⁻ (the 3×3 block of the Delassus matrix
    assembled here), P_2 = 0, the stem's normal velocity after > 0, to 1e-9 of the impulse."""
    rng = np.random.default_rng(3)
    for mu in (1.0, 10.0):
        for _ in range(4):
            g, _ = _state(rng, rock=0.0)
            e, I, w, V, arms = _body(g, 0.0)
            # V + ω × a_i = (0, 0, v_i): the ball's contact down at v_1 < 0, the stem's at rest
            rows = [np.hstack([np.eye(3), -_skew(a)]) for a in arms]
            v1 = -rng.uniform(0.01, 0.2)
            x = np.linalg.lstsq(np.vstack(rows), [0, 0, v1, 0, 0, 0], rcond=None)[0]
            g = np.concatenate(([0.0, 0.0], x[:2], I @ x[3:], g[7:10]))
            W, g0, k = _generalised(g, x[2], 0.0)
            Pi, closed = stem.contact_path(W, g0, 0, stemslip._dry_law(mu), k, mu)
            want = np.linalg.solve(W[:3, :3], -g0[:3])
            assert math.hypot(*want[:2]) < 0.1 * want[2]
            assert not closed
            np.testing.assert_allclose(Pi[:3], want, rtol=0.0, atol=1e-9 * np.abs(want).max())
            np.testing.assert_allclose(Pi[3:], 0.0, rtol=0.0, atol=1e-9 * np.abs(want).max())
            assert (g0 + W @ Pi)[5] > 0.0


# --- the regularised Coulomb law, c(|v|) = μ/√(|v|² + ε²) (mett.dynamics.stemreg) ---------------


def _regularised(mu, eps):
    from mett.dynamics import MODELS
    from mett.friction import RegularisedCoulomb

    return MODELS["stemmed-coulomb-regularised"].parameters(
        B, friction=RegularisedCoulomb(mu, eps), stem_radius=TOP.radius, stem_distance=TOP.distance
    )


def _delassus(I, arms):
    """W_ij = 𝟙/m − [a_i×] I⁻¹ [a_j×] (6×6), from the rigid-body definitions."""
    Iinv = np.linalg.inv(I)
    return np.block([[np.eye(3) / B.m - _skew(ai) @ Iinv @ _skew(aj) for aj in arms]
                     for ai in arms])  # fmt: skip


def _pressing(rng):
    """A state on the stem (flag 1) at the touchdown angle whose ball comes down (θ̇ < 0), with
    fast slips (up to 3 m/s), and its CM velocity (the stem's constraint): the ball's landing
    while the stem's contact is closed, where the ball's friction can press the stem down."""
    g, _ = _state(rng, rock=0.0)
    g[2:4] *= 10.0
    e, I, w, _, arms = _body(g, 0.0)
    nodal = np.cross(Z, e) / np.linalg.norm(np.cross(Z, e))
    w = w - rng.uniform(0.5, 20.0) * nodal
    y = np.concatenate((g[:4], I @ w, g[7:10], [1.0]))
    return y, np.array([y[2], y[3], -np.cross(w, arms[1])[2]])


def _impacts(kind, n, seed):
    """``n`` impacts at both contacts: (state, CM velocity before, first sphere, vz or None):
    flights that land with both gaps 0 (``kind`` "flight") or the ball landing while the
    stem's contact is closed ("closed")."""
    rng = np.random.default_rng(seed)
    out = []
    for k in range(n):
        if kind == "flight":
            g, vz = _state(rng, vz=(-0.1, 0.05))
            out.append((np.append(g, float(k % 2)), np.array([g[2], g[3], vz]), k % 2, vz))
        else:
            y, V = _pressing(rng)
            out.append((y, V, 0, None))
    return out


@pytest.mark.parametrize("eps", [1e-2, 1e-5])
def test_regularised_impact_obeys_complementarity_the_balances_and_its_law(eps):
    """Regularised law (μ = 0.3): at random flights landing on both spheres and at the ball
    landing while the stem's contact is closed: P_1,z, P_2,z ≥ 0; normal velocities after ≥ 0
    and complementary; Δ(m V) = P_1 + P_2 and ΔL = a_1 × P_1 + a_2 × P_2; the kinetic energy
    (from its definition) never rises; every impulse inside the Coulomb cone, |P_t,i| < μ P_n,i
    (the law's |c(|v|) v| < μ); with both closed, the law at the post-impact slip,
    P_t,i = −μ P_n,i v⁺_t,i/√(|v⁺_t,i|² + ε²) (Moreau's form). Its tolerance: the closure's
    fixed point is solved to 1e-10 of P_n and its velocities to ~1e-14 of |v|, which the law's
    slope μ P_n/ε turns into ~1e-14 |v|/ε of μ P_n. Every impact has a consistent set here."""
    from mett.dynamics import stemreg

    mu = 0.3
    p = _regularised(mu, eps)
    seen = set()
    for kind, n, seed in (("flight", 40, 17), ("closed", 30, 23)):
        for y, V, first, vz in _impacts(kind, n, seed):
            e, I, w, _, arms = _body(y, 0.0)
            if min(V[2] + np.cross(w, a)[2] for a in arms) >= 0.0:
                continue  # no contact approaches the table: no impact
            imp = stemreg.LAW.two_contact(y, p, first, vz)
            seen.add((kind, imp.closed))
            P = imp.P
            Pscale = np.abs(P).max()
            V1 = V + P.sum(axis=0) / B.m
            L1 = I @ w + np.cross(arms[0], P[0]) + np.cross(arms[1], P[1])
            np.testing.assert_allclose(imp.state[4:7], L1, rtol=0.0,
                                       atol=ROUND * np.abs(L1).max())  # fmt: skip
            np.testing.assert_allclose(imp.state[2:4], V1[:2], rtol=0.0,
                                       atol=ROUND * np.abs(V1).max())  # fmt: skip
            w1 = np.linalg.solve(I, L1)
            v1 = [V1 + np.cross(w1, a) for a in arms]
            vscale = max(np.abs(V + np.cross(w, a)).max() for a in arms)
            for i in range(2):
                assert P[i, 2] >= -ROUND * Pscale
                assert v1[i][2] >= -1e-9 * vscale  # the impulse ODEs' ends located to ~1e-10
                if imp.closed[i]:
                    assert abs(v1[i][2]) <= 1e-9 * vscale
                else:
                    assert np.all(P[i] == 0.0)
                assert math.hypot(*P[i, :2]) <= mu * P[i, 2] * (1.0 + ROUND)
            if all(imp.closed) and kind == "flight":  # the closure (not the path's end)
                tol = (1e-10 + 1e-13 * vscale / eps) * mu * Pscale
                for i in range(2):
                    vt = v1[i][:2]
                    want = -mu * P[i, 2] * vt / math.sqrt(vt @ vt + eps * eps)
                    np.testing.assert_allclose(P[i, :2], want, rtol=0.0, atol=tol)
            T0, T1 = _kinetic(I, w, V), _kinetic(I, w1, V1)
            assert T1 <= T0 * (1.0 + ROUND)
    assert {("flight", (True, True)), ("flight", (True, False)), ("flight", (False, True)),
            ("closed", (True, False))} <= seen, seen  # fmt: skip


def _order(errors, ratio):
    return [math.log(a / b) / math.log(ratio) for a, b in itertools.pairwise(errors)]


def test_regularised_impact_tends_to_the_viscous_impact_as_eps_grows():
    """For |v_t| ≪ ε, c = μ/√(|v_t|² + ε²) = (μ/ε)(1 − |v_t|²/(2ε²) + …): with μ = 0.3 ε the
    regularised impact at both contacts tends to the viscous one of μ = 0.3 s/m, same active
    set, at the rate (|v_t|/ε)²: single impacts and closures of flights landing on both
    spheres (|v_t| ≲ 1 m/s; ε = 10, 20, 40 m/s) and the two-contact path of the ball landing
    while the stem is closed and pushed (slips up to 3 m/s; ε = 40, 80, 160). Measured orders of
    the largest relative error of the impulses over the states: 1.981, 1.995 and 1.988, 1.997
    (the next term shifts them by O((|v_t|/ε)²) ≤ 0.01-0.02); the viscous and regularised
    integrations (rtol 1e-13, 1e-10) agree far below the smallest error (3e-4, asserted
    > 1e-5): |order − 2| ≤ 0.05."""
    from mett.dynamics import stemreg

    cases = [("flight", 40, 17, (10.0, 20.0, 40.0)), ("closed", 100, 29, (40.0, 80.0, 160.0))]
    for kind, n, seed, epss in cases:
        impacts = []
        for y, _, first, vz in _impacts(kind, n, seed):
            ref = stem.VISCOUS_LAW.two_contact(y, _viscous(0.3), first, vz)
            if not np.any(ref.P) or (kind == "closed" and ref.P[1, 2] == 0.0):
                continue  # no impact; or the stem not pushed: not the path
            impacts.append((y, first, vz, ref))
        assert len(impacts) >= 5
        errors = []
        for eps in epss:
            p = _regularised(0.3 * eps, eps)
            err = 0.0
            for y, first, vz, ref in impacts:
                imp = stemreg.LAW.two_contact(y, p, first, vz)
                assert imp.closed == ref.closed
                err = max(err, np.abs(imp.P - ref.P).max() / np.abs(ref.P).max())
            errors.append(err)
        assert errors[-1] > 1e-5, errors
        for order in _order(errors, 2.0):
            assert abs(order - 2.0) <= 0.05, (kind, errors)


def _coulomb_moreau(W, v, P0, mu):
    """The impact with both contacts closed and sliding under Coulomb's law at the velocity
    level (Moreau): v⁺ = v + W P, v⁺_n,i = 0, P_t,i = −μ P_n,i v⁺_t,i/|v⁺_t,i|, solved by
    scipy's fsolve from ``P0``; returns P (6,) and the slips |v⁺_t,i|."""
    from scipy.optimize import fsolve

    def F(P):
        vp = v + W @ P
        out = [vp[2], vp[5]]
        for i in range(2):
            vt = vp[3 * i : 3 * i + 2]
            out += list(P[3 * i : 3 * i + 2] + mu * P[3 * i + 2] * vt / np.linalg.norm(vt))
        return out

    P = fsolve(F, P0, xtol=1e-13)
    vp = v + W @ P
    assert np.abs(F(P)).max() <= 1e-12 * np.abs(v).max()
    return P, [np.linalg.norm(vp[3 * i : 3 * i + 2]) for i in range(2)]


def test_regularised_impact_tends_to_the_coulomb_impact_as_eps_falls():
    """While the contacts slip (|v_t| ≫ ε), c(|v_t|) v_t = μ v̂_t (1 − ε²/(2|v_t|²) + …): the
    regularised impact at both contacts of flights landing on both spheres tends, as ε → 0, to
    Coulomb's. Where one contact impacts alone, to the dry model's impact
    (stemslip.land_both, same active set); where both close, to Coulomb's law at the velocity
    level with the slip after the impact (Moreau), solved here (the ε → 0 limit of the
    regularised closure; the dry model's closure first tries the slip before). Measured orders
    of the largest relative error over the states: 2.00, 2.00 (ε = 1e-3, 1e-4, 1e-5 m/s;
    errors 4e-4 … 4e-8, the integrations' floor ~1e-9): |order − 2| ≤ 0.05."""
    from mett.dynamics import stemreg

    mu = 0.3
    pd = _dry(Coulomb(mu))
    impacts = []
    for y, V, first, vz in _impacts("flight", 60, 17):
        e, I, w, _, arms = _body(y, 0.0)
        v = np.concatenate([V + np.cross(w, a) for a in arms])
        if min(v[2], v[5]) >= 0.0:
            continue
        imp0 = stemreg.LAW.two_contact(y, _regularised(mu, 1e-3), first, vz)
        if all(imp0.closed):
            P, slips = _coulomb_moreau(_delassus(I, arms), v, imp0.P.ravel(), mu)
            assert min(slips) > 100 * 1e-3 and min(P[2], P[5]) > 0.0  # sliding, consistent
            impacts.append((y, first, vz, P.reshape(2, 3), imp0.closed))
        else:
            _, ref = stemslip.land_both(y[:10], vz, pd, first)
            impacts.append((y, first, vz, ref.P, ref.closed))
    kinds = {all(c) for *_, c in impacts}
    assert kinds == {True, False}, kinds
    for both in (False, True):
        errors = []
        for eps in (1e-3, 1e-4, 1e-5):
            p = _regularised(mu, eps)
            err = 0.0
            for y, first, vz, P_ref, closed in impacts:
                if all(closed) != both:
                    continue
                imp = stemreg.LAW.two_contact(y, p, first, vz)
                assert imp.closed == closed
                err = max(err, np.abs(imp.P - P_ref).max() / np.abs(P_ref).max())
            errors.append(err)
        for order in _order(errors, 10.0):
            assert abs(order - 2.0) <= 0.05, (both, errors)


def test_a_regularised_flight_that_lands_at_the_touchdown_angle_lands_on_both_spheres():
    """friedl1997 under RegularisedCoulomb(0.3, 1e-2) started exactly at the touchdown angle with
    θ̇ = 300 rad/s flies at once and lands on both spheres at the same instant (as the other
    laws above): "double touchdown", the jump checked with the rigid-body balances written
    here — one impulse per closed contact explains Δ(m V) and ΔL, its normal part ≥ 0, the
    closed contacts' normal velocities 0 and the open one's ≥ 0, the energy not raised."""
    from mett.friction import RegularisedCoulomb

    state = mett.State(theta=TOP.touchdown_angle, thetadot=300.0)
    traj = mett.simulate(TOP, state, t_end=0.005, friction=RegularisedCoulomb(0.3, 1e-2))
    assert traj.model == "stemmed-coulomb-regularised" and traj.status == "completed"
    sw = traj.records["switches"]
    assert sw[0].reason == "lift-off" and sw[0].t == 0.0
    td = sw[1]
    assert td.reason == "double touchdown" and td.before == "flight" and td.t == 0.0
    yb, ya = (np.array(y, dtype=float) for y in traj.records["jumps"][1])
    _assert_landing_jump(yb, ya, td)


def test_a_regularised_impact_with_no_consistent_set_ends_the_run_failed(monkeypatch):
    """No silent fallback: where no active set satisfies the regularised law (forced here: every
    single impact fails to end its compression, the closure finds no solution, the path is not
    available) the impact raises JumpFailed — no frictionless projection any more — and a run
    whose flight lands on both spheres then ends with status "failed" at that landing, the
    trajectory before it kept."""
    from mett.dynamics import stemreg
    from mett.friction import RegularisedCoulomb

    def no_end(*args):
        raise JumpFailed("impact: the impulse equations could not be solved (forced)")

    monkeypatch.setattr(stemreg, "regularised_impulse", no_end)
    monkeypatch.setattr(stemreg, "closure", lambda *args: None)
    monkeypatch.setattr(stem, "viscous_path", lambda *args, **kw: None)
    p = _regularised(0.3, 1e-2)
    y, _ = _pressing(np.random.default_rng(23))
    with pytest.raises(JumpFailed, match="Painlevé"):
        stem.transition(y, p, "ball", law=stemreg.LAW)
    state = mett.State(theta=TOP.touchdown_angle, thetadot=300.0)
    traj = mett.simulate(TOP, state, t_end=0.005, friction=RegularisedCoulomb(0.3, 1e-2))
    assert traj.status == "failed" and "landing at t = 0 s" in traj.message, traj.message
    assert "Painlevé" in traj.message
    assert [sw.reason for sw in traj.switches] == ["lift-off"]
    assert traj.t.size >= 1 and np.all(np.isfinite(traj.theta))
