"""The stemmed top under the regularised Coulomb law, "stemmed-coulomb-regularised"
(mett.dynamics.stemreg; docs/theory/stem.md#regularised-coulomb-friction).

References independent of the model's code: the ball-top regularised contact of
mett.dynamics.contact (a Delassus-matrix formulation, not the gliding vector form) for the single
contacts; Newton–Euler with both contact constraints at acceleration level, written out here,
for the double contact; the energy written out here for the impacts; and the two limits of the
law, Coulomb's sliding force as ε → 0 (the stemmed-coulomb model) and the viscous law
μ_visc = μ/ε for |ν| ≪ ε (the stemmed model), each with its measured order of convergence.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

import mett
from mett.dynamics import MODELS, contact, stemreg
from mett.dynamics import _params as ix
from mett.dynamics.stem import on_both
from mett.friction import Coulomb, RegularisedCoulomb, Viscous

NAME = "stemmed-coulomb-regularised"
MODEL = MODELS[NAME]
FRIEDL = mett.presets.stemmed("friedl1997")
THESIS_STEM = mett.presets.get("rutstam2013").with_stem(radius=0.004, distance=0.026)
RTOL = 1e-10  # simulate's default
EPS = np.finfo(float).eps


def _params(top, law):
    return MODEL.parameters(
        top.ball, friction=law, stem_radius=top.radius, stem_distance=top.distance
    )


def _states(top, p, flag, rng, n=6):
    """Random states of the model on contact ``flag`` (0 ball, 1 stem), slipping."""
    out = []
    for _ in range(n):
        th = rng.uniform(0.2, 2.2) if flag == 0 else rng.uniform(2.6, 3.0)
        s = mett.State(theta=th, thetadot=rng.normal(0, 3), phidot=rng.normal(0, 10),
                       omega3=rng.normal(0, 100), nu_x=rng.normal(0, 0.1),
                       nu_y=rng.normal(0, 0.1))  # fmt: skip
        y = np.asarray(MODEL.initial(s, p), dtype=float)
        y[10] = float(flag)  # the rates of that contact, whatever the clearance
        out.append(y)
    return out


@pytest.mark.parametrize("flag", [0, 1], ids=["ball", "stem"])
@pytest.mark.parametrize("eps", [1e-2, 1e-4])
def test_a_single_contact_is_the_regularised_contact_of_that_sphere(flag, eps):
    """The ball and stem phases equal mett.dynamics.contact's regularised sliding law for the
    sphere (R, l) or (r_s, l + l_s), an independent formulation (Delassus matrix, Jellett
    integral in the state), to rounding: both are ~100 flops from the same inputs, so they
    agree to ~1e3 ε of the rates' scale."""
    top, law = FRIEDL, RegularisedCoulomb(0.3, eps)
    p = _params(top, law)
    R_c, l_c = (p[ix.R], p[ix.L]) if flag == 0 else (p[ix.R_S], p[ix.L] + p[ix.L_S])
    # contact.py's tuple (m, R, l, I1, I3, mu, g, r*, eps, law, band) of that sphere
    q = (p[ix.M], R_c, l_c, p[ix.I1], p[ix.I3], law.mu, p[ix.G], 0.0, eps,
         contact.LAW_REGULARISED, 1e-9)  # fmt: skip
    rhs = MODEL.phase_table()[flag].rhs
    for y in _states(top, p, flag, np.random.default_rng(5 + flag)):
        mine = np.asarray(rhs(0.0, y, p), dtype=float)
        yd = contact.from_gliding(y[:10], q)
        ref = np.asarray(contact.slide_rhs(0.0, yd, q), dtype=float)
        # row 6 differs: L_z here, the Jellett integral λ there
        for group in ([0, 1], [2, 3], [4, 5], [7, 8, 9]):
            scale = np.max(np.abs(ref[group])) + np.max(np.abs(mine[group]))
            np.testing.assert_allclose(mine[group], ref[group], rtol=0, atol=1e3 * EPS * scale)
        gn = float(MODEL.normal_force(y, p))
        gn_ref = float(contact.normal_force(yd, q))
        assert gn == pytest.approx(gn_ref, rel=1e3 * EPS)
        assert mine[10] == 0.0


def test_the_double_contact_obeys_newton_euler_and_both_constraints():
    """At states on the double-contact manifold: with the normal forces λ_1, λ_2 the model gives,
    the forces F_i = λ_i ẑ − μ λ_i ν_i/√(|ν_i|² + ε²) (ν_i the slip of contact i, computed here)
    give m (ẍ, ÿ) = Σ F_t, L̇ = Σ a_i × F_i, and the constraints hold at acceleration level:
    λ_1 + λ_2 = m g (z̈_G = 0) and (L̇ × 3̂ + L × 3̂̇)·ẑ = 0 (3̂̈_z = 0). A wrong sign of a friction
    force or a force at the wrong contact fails here."""
    top, law = THESIS_STEM, RegularisedCoulomb(0.3, 2e-2)
    p = _params(top, law)
    m, g, R, l, I1, I3 = p[ix.M], p[ix.G], p[ix.R], p[ix.L], p[ix.I1], p[ix.I3]
    r_s, l2 = p[ix.R_S], p[ix.L] + p[ix.L_S]
    rng = np.random.default_rng(23)
    z = np.array([0.0, 0.0, 1.0])
    for y in _states(top, p, 0, rng, n=8):
        y = on_both(y, p[:9])  # the manifold's geometry (the stemmed tuple)
        rates, lam1, lam2 = stemreg.both_core(y, p)
        rates = np.asarray(rates, dtype=float)
        e, L = y[7:10] / np.linalg.norm(y[7:10]), y[4:7]
        w = L / I1 + (1.0 / I3 - 1.0 / I1) * (L @ e) * e
        V = np.array([y[2], y[3], 0.0])
        F_total, torque = np.zeros(3), np.zeros(3)
        for lam, a in ((lam1, l * e - R * z), (lam2, l2 * e - r_s * z)):
            nu = V + np.cross(w, a)
            assert abs(nu[2]) <= 1e3 * EPS * (np.linalg.norm(nu) + np.linalg.norm(w) * l2)
            F = lam * (z - law.mu * nu / math.sqrt(nu[0] ** 2 + nu[1] ** 2 + law.eps**2))
            F[2] = lam
            F_total += F
            torque += np.cross(a, F)
        scale_f = m * g * (1.0 + law.mu)
        assert lam1 + lam2 == pytest.approx(m * g, rel=1e3 * EPS)
        np.testing.assert_allclose(m * rates[2:4], F_total[:2], rtol=0, atol=1e3 * EPS * scale_f)
        np.testing.assert_allclose(rates[4:7], torque, rtol=0, atol=1e3 * EPS * scale_f * l2)
        de = np.cross(L, e) / I1
        np.testing.assert_allclose(rates[7:10], de, rtol=0, atol=1e3 * EPS * np.linalg.norm(de))
        acc = (np.cross(rates[4:7], e) + np.cross(L, de))[2]
        assert abs(acc) <= 1e4 * EPS * (scale_f * l2 + np.linalg.norm(L) * np.linalg.norm(de))


def _energy(y, p):
    """E (J) of a state on its contact (flag 0 ball, 1 stem, 2 both): ½ m |V|² + ½ L·ω + m g z_G,
    z_G = R_i − l_i 3̂_z and V_z = −(ω × a_i)_z of the sphere i in contact (the ball in "both")."""
    m, g, R, l, I1, I3 = p[ix.M], p[ix.G], p[ix.R], p[ix.L], p[ix.I1], p[ix.I3]
    R_i, l_i = (p[ix.R_S], l + p[ix.L_S]) if round(y[10]) == 1 else (R, l)
    e, L = y[7:10] / np.linalg.norm(y[7:10]), np.asarray(y[4:7])
    w = L / I1 + (1.0 / I3 - 1.0 / I1) * (L @ e) * e
    a = l_i * e - R_i * np.array([0.0, 0.0, 1.0])
    Vz = -np.cross(w, a)[2]
    return 0.5 * m * (y[2] ** 2 + y[3] ** 2 + Vz**2) + 0.5 * L @ w + m * g * (R_i - l_i * e[2])


# the thesis body with a stem from θ0 = 0.1, ω3 = 116 rad/s (1.5 × the least spin that inverts
# the ball top), contact point at rest: touchdown, bounces between ball and stem that accumulate,
# a double contact, the stem's lift-off, and back on the ball (docs/theory/stem.md#long-runs)
_LIFE = (THESIS_STEM, mett.State(theta=0.1, omega3=116.0), 8.0)


@pytest.fixture(scope="module")
def life():
    top, state, t_end = _LIFE
    return mett.simulate(top, state, t_end, friction=RegularisedCoulomb(0.3, 1e-2))


def test_a_life_through_impacts_and_the_double_contact(life):
    top = _LIFE[0]
    tr = life
    assert (tr.model, tr.status) == (NAME, "completed"), tr.message
    reasons = [sw.reason for sw in tr.switches]
    assert {"touchdown", "landing", "accumulation", "stem lifts off"} <= set(reasons), reasons
    contact_ = np.asarray(tr.contact)
    both = contact_ == "both"
    assert both.any()
    b, mg = top.ball, top.ball.m * top.ball.g
    # both normal forces ≥ 0 at every double-contact sample (0 to the event tolerance, rtol m g,
    # at the lift-off) and both gaps zero: the ball touches by construction, the stem's clearance
    # R + l_s cos θ − r_s is 0 to the rounding of cos(arccos(c_t)) (a few ε of l_s)
    assert np.min(tr.gn_ball[both]) >= -RTOL * mg
    assert np.min(tr.gn_stem[both]) >= -RTOL * mg
    np.testing.assert_allclose(tr.gn_ball[both] + tr.gn_stem[both], mg, rtol=1e3 * EPS)
    clear = b.R + top.distance * np.cos(tr.theta[both]) - top.radius
    assert np.max(np.abs(clear)) <= 16 * EPS * (top.distance + b.R)
    # the lift-off: the force that vanishes is that of the contact that opens (the stem)
    k = reasons.index("stem lifts off")
    t_lift = tr.switches[k].t
    before = np.flatnonzero(both & (tr.t <= t_lift))[-1]
    assert tr.gn_stem[before] <= 1e-3 * mg < tr.gn_ball[before]
    assert contact_[np.searchsorted(tr.t, t_lift, side="right")] == "ball"
    # energy never rises: along the run, by the integration error (100 rtol |E|, the budget of
    # tests/test_life_cycle.py), and across each impact (E written out here)
    E = np.asarray(tr.E)
    assert np.all(np.diff(E) <= 100 * RTOL * np.max(np.abs(E)))
    p = tr.params
    n_impacts = 0
    for sw, (y0, y1) in zip(tr.switches, tr.records["jumps"], strict=True):
        if sw.reason in ("touchdown", "landing", "accumulation", "closure"):
            n_impacts += 1
            # the two contacts' heights of G agree to the switch offset (1e-11 R)
            dE = _energy(y1, p) - _energy(y0, p)
            assert dE <= 1e-10 * mg * b.R, (sw, dE)
    assert n_impacts >= 3


def _order(errors, ratio):
    return [math.log(a / b) / math.log(ratio) for a, b in itertools.pairwise(errors)]


def _distance(a, b, w3):
    """Largest difference of θ, ω3/|ω3(0)| and ν/(0.3 m/s) at the end of two runs."""
    return max(abs(a.theta[-1] - b.theta[-1]), abs(a.omega3[-1] - b.omega3[-1]) / w3,
               abs(a.nu_x[-1] - b.nu_x[-1]) / 0.3, abs(a.nu_y[-1] - b.nu_y[-1]) / 0.3)  # fmt: skip


@pytest.mark.parametrize(
    "state",
    [mett.State(theta=0.6, thetadot=1.0, omega3=150.0, nu_x=0.3),
     mett.State(theta=2.9, thetadot=1.0, omega3=-150.0, nu_x=0.3)],
    ids=["ball", "stem"],
)  # fmt: skip
def test_eps_to_zero_is_coulomb_sliding_at_second_order(state):
    """While the contact slips (|ν| ≥ ν_min ≫ ε), μ/√(|ν|² + ε²) = (μ/|ν|)(1 − ε²/(2|ν|²) + …):
    the regularised run differs from the exact Coulomb run ("stemmed-coulomb", which slides
    throughout here) by O(ε²). Measured order 1.996-2.000 for ε = 2e-3 … 5e-4; the next term
    shifts it by O((ε/ν_min)²) ≤ 6e-3 (ν_min = 0.026 m/s on the ball), the integration error
    (rtol 1e-12) is 1e-6 of the smallest difference: |order − 2| ≤ 0.05."""
    top, T = FRIEDL, 0.05
    kw = {"rtol": 1e-12, "backend": "compiled"}
    ref = mett.simulate(top, state, T, friction=Coulomb(0.3), **kw)
    assert ref.model == "stemmed-coulomb" and set(ref.phase) == {"sliding"}
    assert len(set(ref.contact)) == 1
    nu_min = float(np.min(np.hypot(ref.nu_x, ref.nu_y)))
    eps = [2e-3, 1e-3, 5e-4]
    assert eps[0] < 0.1 * nu_min
    errors = []
    for e in eps:
        tr = mett.simulate(top, state, T, friction=RegularisedCoulomb(0.3, e), **kw)
        assert tr.status == "completed" and set(tr.contact) == set(ref.contact)
        errors.append(_distance(tr, ref, abs(state.omega3)))
    for order in _order(errors, 2.0):
        assert abs(order - 2.0) <= 0.05, errors


def test_eps_to_zero_is_the_coulomb_impact_at_second_order():
    """An impact that slips throughout: the regularised impulse (the law in impulse form,
    dP = (ẑ − μ v_t/√(|v_t|² + ε²)) dp) tends to the Coulomb impulse of stemslip.dry_impulse at
    the rate ε²/|v_t|² (measured: ×100 per decade of ε, 3.1e-4 … 3.1e-8 for ε = 1e-2 … 1e-4)."""
    from mett.dynamics import stem, stemslip

    state = mett.State(theta=2.40, thetadot=8.0, phidot=-30.0, omega3=-40.0, nu_x=0.2)
    errors = []
    for e in (1e-2, 1e-3, 1e-4):
        p = _params(FRIEDL, RegularisedCoulomb(0.3, e))
        y = np.asarray(MODEL.initial(state, p), dtype=float)
        after, P = stemreg.impact(y, p, "stem")
        f = stem.impact_frame(y, p[:9], "stem")
        assert f.v[2] < 0.0 and round(after[10]) == 1
        Pc, _, _ = stemslip.dry_impulse(f, p[ix.M], 0.3, 0.0)
        errors.append(float(np.linalg.norm(P - Pc) / np.linalg.norm(Pc)))
        # perfectly inelastic: the stem's contact point stops moving vertically
        assert abs((f.v + f.W @ P)[2]) <= 1e-8 * abs(f.v[2])
    for order in _order(errors, 10.0):
        assert abs(order - 2.0) <= 0.05, errors


@pytest.mark.parametrize(
    ("state", "reasons"),
    [(mett.State(theta=2.4, thetadot=2.0, phidot=10.0, omega3=-150.0, nu_x=0.05),
      ["touchdown", "landing"]),
     (mett.State(theta=2.44, thetadot=13.0, phidot=-50.0, omega3=-45.0),
      ["touchdown", "lift-off", "touchdown"])],
    ids=["impacts", "flight"],
)  # fmt: skip
def test_large_eps_is_the_viscous_law_through_impacts_and_landings(state, reasons):
    """For |ν| ≪ ε the law is viscous with μ_visc = μ/ε: the regularised runs with μ = 0.3 ε
    (s/m × m/s) approach the viscous stemmed run of μ = 0.3 s/m as ε grows, through a touchdown
    and a landing (impacts with the law in impulse form), or a touchdown, a hop and the landing
    from the flight, at the rate (ν/ε)² of μ/√(ν² + ε²) = (μ/ε)(1 − ν²/(2ε²) + …): measured
    orders 1.982, 1.995, 1.999 for ε = 5 … 40 m/s (|ν| ≤ 0.92 m/s; with the hop 2.000, 2.000);
    the next term shifts them by O((ν/ε)²) ≤ 0.04 at ε = 5: |order − 2| ≤ 0.05 from ε = 10."""
    top, T = FRIEDL, 0.04
    kw = {"rtol": 1e-12, "backend": "compiled"}
    ref = mett.simulate(top, state, T, friction=Viscous(0.3), **kw)
    assert [sw.reason for sw in ref.switches] == reasons
    errors = []
    for e in (10.0, 20.0, 40.0):
        tr = mett.simulate(top, state, T, friction=RegularisedCoulomb(0.3 * e, e), **kw)
        assert [sw.reason for sw in tr.switches] == reasons
        errors.append(_distance(tr, ref, abs(state.omega3)))
    for order in _order(errors, 2.0):
        assert abs(order - 2.0) <= 0.05, errors


def test_the_cli_runs_the_stemmed_top_with_the_regularised_law(tmp_path, capsys):
    from mett.cli import main

    argv = ["simulate", "--preset", "friedl1997", "--friction", "regularised:0.3,0.01",
            "--theta0", "0.1", "--omega3", "180", "--t-end", "0.01",
            "--out", str(tmp_path / "run.npz")]  # fmt: skip
    assert main(argv) == 0, capsys.readouterr().err
    tr = mett.Trajectory.load(tmp_path / "run.npz")
    assert tr.model == NAME and tr.status == "completed"
    assert tr.options["friction"] == RegularisedCoulomb(0.3, 0.01)
