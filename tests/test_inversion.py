"""mett.predict_inversion: the gyroscopic-balance reduction against its independent references.

References: the linear growth rate of the upright spin (eigenvalues of the full gliding model's
Jacobian, mett.spin_eigenvalues) for the flow's small-θ limit; full compiled simulations for the
time θ passes π/2 (the verification table: test_inversion_verify.py and test_inversion_verify_slow.py).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import mett
from mett.friction import Coulomb, RegularisedCoulomb, Viscous
from mett.inversion import predict_inversion
from mett.inversion._cases import cases, simulated_t_half
from mett.inversion._gyroscopic import balance_state, friction_rates


@pytest.fixture(scope="module")
def thesis():
    return mett.presets.get("rutstam2013")


def test_balance_state_is_a_steady_precession(thesis):
    # θ̈ = 0 of the Euler-angle equations (docs/theory/equations.md#euler-form) with θ̇ = 0, g_n = m g, no friction, and
    # λ = −L·a recomputed from (θ, φ̇, ω3): both are independent of the quadratic's algebra.
    lam = 6.8944e-6
    t = thesis
    for th in (0.2, 1.0, 2.0, 3.0):
        phidot, omega3, _, _, _ = balance_state(t, lam, th)
        s, c = math.sin(th), math.cos(th)
        thdd = (s / t.I1) * (
            t.I1 * phidot**2 * c - t.I3 * omega3 * phidot - t.R * t.alpha * t.m * t.g
        )
        assert abs(thdd) <= 1e-9 * t.I3 * omega3**2 / t.I1
        lam_back = t.R * t.I1 * phidot * s * s - t.R * t.I3 * omega3 * (t.alpha - c)
        assert lam_back == pytest.approx(lam, rel=1e-12)


def test_flow_growth_rate_matches_spin_eigenvalue(thesis):
    # Near θ = 0 the slow flow dθ/dt = −P/E' is linear, θ̇ = σ_b θ; σ_b must equal the largest
    # real eigenvalue of the full gliding model at the upright spin up to the reduction's error,
    # O(g/(R ω3²)) relative (gravity in the balance, ~1e-2 here).
    state = mett.State.with_cm_at_rest(thesis, theta=0.1, omega3=155.0)
    lam = float(mett.jellett(thesis, state))
    sigma = max(mett.spin_eigenvalues(thesis, lam, "upright").real)
    th = 1e-4
    h = 1e-30
    E_th = balance_state(thesis, lam, complex(th, h))[2].imag / h
    nu = balance_state(thesis, lam, th)[3]
    P, _ = friction_rates(Viscous(), thesis, nu, 0.0)
    sigma_b = -P / E_th / th  # E decreases as the balance state tilts: E_th < 0
    assert sigma_b == pytest.approx(sigma, rel=0.01)


def test_thesis_cm_at_rest_t_half_matches_simulation(thesis):
    # Declared error target of the viscous law in the verified range: 5 % of t_half (the table's
    # worst case, docs/theory/inversion.md#verification) plus one nutation period of slack.
    state = mett.State.with_cm_at_rest(thesis, theta=0.1, omega3=155.0)
    pred = predict_inversion(thesis, state)
    traj = mett.simulate(thesis, state, 7.0, rtol=1e-9)
    t_sim = traj.crossings(0.5 * math.pi)[0]
    T_n = 2 * math.pi * thesis.I1 / (thesis.I3 * 155.0)
    assert pred.inverts is True and pred.reason == "inverts"
    assert abs(pred.t_half - t_sim) <= 0.05 * t_sim + T_n
    assert pred.t_start < pred.t_half < pred.t_inv
    assert not pred.validity.outside_verified_range


@pytest.mark.parametrize("start", ["contact at rest", "cm at rest"])
def test_small_tilt_starts_match_simulation(thesis, start):
    # θ0 = 0.03: the initial transient that the reduction omits is O(θ0) (measured: 7 % for the
    # ν = 0 start at θ0 = 0.1, 0.2 % at 0.03), so both starts are inside the verified range here.
    if start == "cm at rest":
        state = mett.State.with_cm_at_rest(thesis, theta=0.03, omega3=155.0)
    else:
        state = mett.State(theta=0.03, omega3=155.0)
    pred = predict_inversion(thesis, state)
    assert not pred.validity.outside_verified_range
    traj = mett.simulate(thesis, state, 1.2 * pred.t_half, rtol=1e-9)
    t_sim = traj.crossings(0.5 * math.pi)[0]
    T_n = 2 * math.pi * thesis.I1 / (thesis.I3 * 155.0)
    assert abs(pred.t_half - t_sim) <= 0.10 * t_sim + T_n


def test_slow_path_is_monotone_and_consistent(thesis):
    state = mett.State.with_cm_at_rest(thesis, theta=0.1, omega3=155.0)
    p = predict_inversion(thesis, state)
    assert np.all(np.diff(p.t) > 0) and np.all(np.diff(p.theta) > 0)
    # D̄ passes from near D0 to near D1 (docs/theory/thresholds.md#boundary-values) and λ stays Jellett's.
    assert np.allclose(p.lam, float(mett.jellett(thesis, state)), rtol=1e-9)
    assert p.D[0] > 0 > p.D[-1]
    # linear interpolation between solver steps: error ~ h² θ̈/8, below 2e-3 rad at these steps
    assert p.theta_at(p.t_half) == pytest.approx(0.5 * math.pi, abs=2e-3)


def test_below_lambda_0_does_not_invert(thesis):
    # λ < λ_0: the upright spin is stable (docs/theory/thresholds.md#thresholds).
    omega3 = 0.5 * thesis.lambda_0 / (thesis.R * thesis.I3 * (math.cos(0.1) - thesis.alpha))
    p = predict_inversion(thesis, mett.State(theta=0.1, omega3=omega3))
    assert p.inverts is False and "lambda_0" in p.reason and p.t_half == math.inf


def test_between_thresholds_hangs_at_tumbling_angle(thesis):
    lam = 0.5 * (thesis.lambda_0 + thesis.lambda_thres)
    omega3 = lam / (thesis.R * thesis.I3 * (math.cos(0.1) - thesis.alpha))
    p = predict_inversion(thesis, mett.State(theta=0.1, omega3=omega3))
    theta_t = mett.tumbling_state(thesis, lam)[0]
    assert p.inverts is False and "hangs" in p.reason
    assert p.theta_end == pytest.approx(theta_t, rel=1e-9)


def test_exact_coulomb_cohen_top_sticks():
    # The example: Cohen's top, CM at rest, ω3 = 100, θ0 = 0.1, μ = 0.3: the simulated
    # slip stops at t ≈ 0.03 s. The constant-deceleration model ignores the turning of the slip
    # direction during the stop, a relative error of order t_stop/T_n ≈ 0.5 (T_n = 0.063 s); the
    # tolerance 30 % is below that bound.
    top = mett.presets.get("cohen1977")
    state = mett.State.with_cm_at_rest(top, theta=0.1, omega3=100.0)
    p = predict_inversion(top, state, Coulomb(0.3))
    assert p.inverts is False and p.reason.startswith("contact sticks")
    traj = mett.simulate(top, state, 0.05, friction=Coulomb(0.3))
    t_stick = traj.t[np.argmax(traj.phase == "rolling")]
    t_pred = float(p.reason.split("t = ")[1].split(" s")[0])
    assert t_pred == pytest.approx(t_stick, rel=0.3)


def test_the_verified_box_names_its_laws(thesis):
    # The box of the verification table holds the viscous and the regularised Coulomb laws
    # (docs/theory/inversion.md#verification); Coulomb–Contensou is flagged by its law, and a
    # regularised top predicted to hop by its lift-off, not by its law.
    state = mett.State.with_cm_at_rest(thesis, theta=0.1, omega3=155.0)
    p = predict_inversion(thesis, state, Coulomb(0.3, contensou_radius=1e-3))
    assert p.validity.outside_verified_range
    assert any("coulomb-contensou outside" in n for n in p.validity.notes)
    p = predict_inversion(thesis, state, RegularisedCoulomb(0.3, 0.05))
    assert p.validity.outside_verified_range and p.t_lift < p.t_half
    assert not any("law" in n for n in p.validity.notes)
    assert any("hop" in n for n in p.validity.notes)


def test_bad_input_is_refused(thesis):
    state = mett.State(theta=0.1, omega3=155.0)
    with pytest.raises(ValueError, match="method"):
        predict_inversion(thesis, state, method="averaged-nope")
    with pytest.raises(ValueError, match="tol"):
        predict_inversion(thesis, state, tol=0.0)
    with pytest.raises(ValueError, match=r"state\.theta"):
        predict_inversion(thesis, mett.State(theta=2.0, omega3=155.0))
    with pytest.raises(ValueError, match="omega3"):
        predict_inversion(thesis, mett.State(theta=0.1, omega3=-155.0))
    with pytest.raises(ValueError, match="Jellett"):
        predict_inversion(thesis, mett.State(theta=1.4, omega3=1.0, phidot=-50.0))
    with pytest.raises(ValueError, match="stemmed"):
        predict_inversion(thesis.with_stem(0.004, 0.02), state)
    with pytest.raises(TypeError):
        predict_inversion(thesis, state, friction="viscous")
    with pytest.raises(TypeError, match="hops"):
        predict_inversion(thesis, state, hops=1)


def test_a_subnormal_spin_is_an_answer_not_a_division_by_zero():
    # I3 * 5e-324 underflows to 0: the nutation period is computed as a ratio first (inf); the
    # body spins far below any threshold, so the answer is "no inversion" with its reason
    top = mett.TippeTop(0.0625, 0.03125, 0.5, 6.103515625e-05, 6.103515625e-05, 0.0)
    p = predict_inversion(top, mett.State(theta=1.0, phidot=1.0, omega3=5e-324))
    assert p.inverts is not True and p.reason
    assert mett.inversion._gyroscopic.nutation_period(top, 5e-324) == math.inf
    assert mett.inversion._gyroscopic.nutation_period(top, 0.0) == math.inf


def test_cli_predict_prints_the_prediction(capsys):
    import json

    from mett.cli import main

    argv = ["predict", "--preset", "rutstam2013", "--theta0", "0.1", "--omega3", "155"]
    assert main([*argv, "--cm-at-rest", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    top = mett.presets.get("rutstam2013")
    state = mett.State.with_cm_at_rest(top, theta=0.1, omega3=155.0)
    assert out["inverts"] is True
    assert out["t_half"] == pytest.approx(predict_inversion(top, state).t_half, rel=1e-12)
    assert main([*argv[:-1], "-155"]) == 2
    assert "omega3" in capsys.readouterr().err


def test_atlas_is_the_prediction_on_a_grid(thesis):
    from mett.inversion import atlas

    res = atlas(thesis, [0.1, 0.3], [155.0, 300.0], laws=("viscous", "coulomb"))
    state = mett.State.with_cm_at_rest(thesis, theta=0.1, omega3=300.0)
    p = predict_inversion(thesis, state, Viscous(0.3))
    assert res["viscous"]["t_half"][1, 1] == p.t_half
    assert np.all(res["viscous"]["inverts"] == 1)
    assert np.all(res["coulomb"]["inverts"] == 0) and np.all(np.isinf(res["coulomb"]["t_half"]))
    with pytest.raises(ValueError, match="laws"):
        atlas(thesis, [0.1], [155.0], laws=("dry",))


def test_potential_map_draws_the_predicted_slow_path(thesis):
    pytest.importorskip("matplotlib")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from mett.plotting import D_SCALE, plot_potential_map

    state = mett.State.with_cm_at_rest(thesis, theta=0.1, omega3=155.0)
    p = predict_inversion(thesis, state)
    fig = plot_potential_map(thesis, float(p.lam[0]), prediction=p, n=41)
    (line,) = [ln for ln in fig.axes[0].lines if ln.get_label() == "predicted slow path"]
    np.testing.assert_allclose(line.get_xdata(), p.D * D_SCALE)
    np.testing.assert_allclose(line.get_ydata(), np.cos(p.theta))
    plt.close(fig)


def test_group_III_top_hangs_below_theta_f(thesis):
    # γ = 1.4 > 1 + α: tumbling states exist only for cos θ > α/(1 − γ) (docs/theory/thresholds.md#thresholds).
    top = thesis.replace(I1=1.4 * thesis.I3)
    p = predict_inversion(top, mett.State.with_cm_at_rest(top, theta=0.1, omega3=300.0))
    assert p.inverts is False and "group III" in p.reason
    assert p.theta_end < math.acos(top.alpha / (1.0 - top.gamma))


def test_a_registered_law_without_a_reduction_is_no_prediction_not_an_error(thesis):
    # rolling resistance is a registered law the gyroscopic-balance reduction has no power
    # balance for: the answer is "no prediction" with the reason, never an AttributeError
    from mett.dynamics.resistance import RollingResistance

    p = mett.predict_inversion(thesis, mett.State(theta=0.1, omega3=155.0),
                               friction=RollingResistance(1e-4))  # fmt: skip
    assert p.inverts is None and "RollingResistance" in p.reason
    assert p.validity.outside_verified_range


# --- the averaged flow (method="averaged") ------------------------------------------------------


def test_band_average_matches_an_independent_quadrature(thesis):
    # ⟨F⟩ = ∫ F dz/√f / ∫ dz/√f over a rolling band (thesis body, θ0 = 1, ω3 = 100, φ̇0 = 5: band
    # z in [0.5403, 0.6138]). Reference: QUADPACK's adaptive Gauss–Kronrod (scipy.integrate.quad,
    # its own error control) in u after z = c + h sin u, with f from mett.separation.f (P/g formed
    # directly, not in the offset form of the period's quadrature). Both are accurate to ~1e-13
    # here; 1e-10 relative leaves margin for the rounding of f near the turning points.
    from scipy.integrate import quad

    from mett.separation import band_average, f

    st = mett.State(theta=1.0, omega3=100.0, phidot=5.0)
    E, D, lam = (float(q(thesis, st)) for q in (mett.modified_energy, mett.routh, mett.jellett))
    b, T, avg = band_average(thesis, E, D, lam, lambda z: np.stack([np.ones_like(z), z, z**3]))
    c, h = 0.5 * (b.z_low + b.z_high), 0.5 * (b.z_high - b.z_low)

    def weighted(k):
        def integrand(u):
            z = c + h * math.sin(u)
            return z**k * h * math.cos(u) / math.sqrt(f(thesis, z, E, D, lam))

        return quad(integrand, -0.5 * math.pi, 0.5 * math.pi, epsabs=0.0, epsrel=1e-13)[0]

    norm = weighted(0)
    assert 2.0 * norm == pytest.approx(T, rel=1e-10)  # the period itself
    assert avg[0] == pytest.approx(1.0, rel=1e-13)
    assert avg[1] == pytest.approx(weighted(1) / norm, rel=1e-10)
    assert avg[2] == pytest.approx(weighted(3) / norm, rel=1e-10)
    with pytest.raises(TypeError, match="weight"):
        band_average(thesis, E, D, lam, "z")


def test_both_starts_share_the_mett_integrals_so_no_flow_of_them_alone_tells_them_apart(thesis):
    # Ẽ = E + ½ m |ν|² − m ν·ṙ (docs/theory/equations.md#integrals) is the same for the start with the contact
    # point at rest (ν = 0, ṙ = −ω × a) and the one with the centre of mass at rest (ν = ω × a):
    # both equal the rotational energy + ½ m |ω × a|² (E itself differs by that term); D and λ do
    # not involve ν. Any flow of (D, Ẽ, λ) alone predicts one t_half for both, while the simulated
    # crossings differ (5.88 s and 5.07 s, docs/theory/inversion.md#the-averaged-flow): the
    # averaged flow therefore starts from the initiation's mode split, as the gyroscopic one does.
    a = mett.State(theta=0.1, omega3=155.0)
    b = mett.State.with_cm_at_rest(thesis, theta=0.1, omega3=155.0)
    for q in (mett.modified_energy, mett.routh, mett.jellett):
        assert float(q(thesis, a)) == pytest.approx(float(q(thesis, b)), rel=1e-13)
    assert float(mett.energy(thesis, a)) > float(mett.energy(thesis, b))


def _gliding_integrals(top, state):
    """(λ, n1, e) of a state: n1 = λ − R I3 ω3 (1 − α), e = E' − m g R (1 − α), E' the energy
    of the rotation and the height without ½ I3 ω3² (mett.inversion._averaged)."""
    m, R, a, I1, I3, g = top.m, top.R, top.alpha, top.I1, top.I3, top.g
    th, thd, phd, w3 = (float(getattr(state, k)) for k in ("theta", "thetadot", "phidot", "omega3"))
    lam = float(mett.jellett(top, state))
    s, z = math.sin(th), math.cos(th)
    Ep = (
        0.5 * I1 * (thd**2 + phd**2 * s**2)
        + 0.5 * m * (R * a * s * thd) ** 2
        + m * g * R * (1 - a * z)
    )
    return lam, lam - R * I3 * w3 * (1 - a), Ep - m * g * R * (1 - a)


def test_gliding_band_is_the_frictionless_gliding_motion(thesis):
    # The averaged flow's fast motion is the frictionless gliding top's band (a cubic in
    # δ = 1 − cos θ). Independent reference: the full vector-form model integrated without
    # friction (rtol 1e-11) from a nutating state: its extreme inclinations, its nutation period
    # (between upward crossings of the band's middle, root-found on the dense output) and its
    # mean precession (the azimuth of 3̂ over whole periods). Tolerances: the turning points are
    # sampled every 1e-4 T (error ½ θ̈ (1e-4 T)² ≈ 1e-8 of the band), the rest is rtol-sized.
    from mett.inversion import _averaged

    top = thesis._with_mu(0.0)
    state = mett.State.with_cm_at_rest(top, theta=0.4, omega3=120.0, thetadot=3.0, phidot=25.0)
    lam, n1, e = _gliding_integrals(top, state)
    nodes = _averaged._Nodes(top, lam, n1, e)
    da, db, _, empty = _averaged.gliding_band(top, lam, n1, e)
    assert not empty
    lo, hi = math.acos(1 - da), math.acos(1 - db)
    lo, hi = min(lo, hi), max(lo, hi)
    T = nodes.T
    traj = mett.simulate(top, state, 12 * T, rtol=1e-11)
    ts = np.linspace(0.0, 12 * T, 120001)
    th = traj.theta_at(ts)
    assert th.min() == pytest.approx(lo, abs=1e-6 * (hi - lo))
    assert th.max() == pytest.approx(hi, abs=1e-6 * (hi - lo))
    up = traj.crossings(0.5 * (lo + hi), direction=1)
    assert len(up) >= 10
    assert np.diff(up).mean() == pytest.approx(T, rel=1e-7)
    Y = traj.states_at(up)
    phi = np.unwrap(np.arctan2(Y[7], -Y[8]))
    assert (phi[-1] - phi[0]) / (up[-1] - up[0]) == pytest.approx(nodes.Omega, rel=1e-7)


@pytest.mark.parametrize("law", [Viscous(0.0), RegularisedCoulomb(0.0, 0.01)])
def test_averaged_flow_stands_still_without_friction(thesis, law):
    # Without friction ω3, E' and λ of the gliding top are integrals: the flow's rates vanish
    # identically, in a wide band and in the steady precession at the bottom of a well.
    from mett.inversion import _averaged

    state = mett.State.with_cm_at_rest(thesis, theta=0.4, omega3=120.0, thetadot=3.0, phidot=25.0)
    lam, n1, e = _gliding_integrals(thesis, state)
    ph, w3, _, _, _ = balance_state(thesis, lam, 0.3)
    for y in ((n1, e), _averaged.start(thesis, float(ph), float(w3), 0.3)):
        r = _averaged.rates(thesis, law, lam, *y)
        assert r[0] == 0.0 and r[1] == 0.0


@pytest.mark.parametrize("rotation", [True, False])
@pytest.mark.parametrize("law", [Viscous(0.3), Viscous(3.0), RegularisedCoulomb(0.3, 0.01)])
def test_slip_of_a_steady_precession_is_the_closed_form_answer(thesis, law, rotation):
    # In a collapsed band (the fast steady precession at θ) the slaved slip solves
    # i Ω m (ν − w) = −K c g_n ν: ν = w/(1 − i κ K), κ = c g_n/(m Ω), |ν|² the root of the
    # quadratic of the gyroscopic method (mett.inversion._gyroscopic.cm_slip2), with the contact
    # point's inverse mass K = 1 + m R² (1 − α cos θ)²/I1 (the centre of mass and the rotation
    # give way, docs/theory/inversion.md#the-contact-points-response) or, without the rotation's
    # share, K = 1. The torque on ω3 is then −c g_n R sin θ Re(ν along w) = −c g_n R sin θ |ν|²/w:
    # checked against the flow's dn1/dt. The regularised law's slip is the safeguarded Newton
    # solve's; the reference is the closed-form root.
    from mett.inversion import _averaged
    from mett.inversion._gyroscopic import cm_slip2, drag_form

    lam = float(mett.jellett(thesis, mett.State(theta=0.1, omega3=155.0)))
    for theta in (0.05, 0.5, 1.2, 2.5):
        ph, w3, _, w, _ = (float(x) for x in balance_state(thesis, lam, theta))
        n1, e = _averaged.start(thesis, ph, w3, theta)
        nodes = _averaged._Nodes(thesis, lam, n1, e)
        assert nodes.empty and nodes.Omega == pytest.approx(ph, rel=1e-9)
        mu_c, a, b = drag_form(law, thesis)
        gn = thesis.m * thesis.g
        K = 1 + thesis.m * thesis.R**2 * (1 - thesis.alpha * math.cos(theta)) ** 2 / thesis.I1
        K = K if rotation else 1.0
        x = float(cm_slip2(w * w, b, (mu_c * gn * K / (thesis.m * ph)) ** 2, a))
        c = mu_c * gn / math.sqrt(a * x + b)
        r = _averaged.rates(thesis, law, lam, n1, e, rotation)
        dw3 = -r[0] / (thesis.R * thesis.I3 * (1 - thesis.alpha))
        nu = 1j * w + r[6]  # complex x̂ + iŷ: w lies along ŷ; the band frame is the mean frame
        assert abs(nu) ** 2 == pytest.approx(x, rel=1e-9)
        assert dw3 == pytest.approx(-c * thesis.R * math.sin(theta) * x / w / thesis.I3, rel=1e-9)


@pytest.mark.slow
def test_averaged_flow_on_the_thesis_start(thesis):
    # The averaged flow against the full simulation (an independent integration) on both starts
    # of the thesis top: the same declared target as the gyroscopic method in its range (5 % of
    # t_half plus one nutation period, docs/theory/inversion.md#verification). Measured: 5.074 s
    # against 5.067 s (centre of mass at rest), 6.31 s against 5.88 s (contact point at rest,
    # θ0 = 0.1: outside the range, the initiation's O(θ0) transient, as for the gyroscopic method).
    state = mett.State.with_cm_at_rest(thesis, theta=0.1, omega3=155.0)
    p = predict_inversion(thesis, state, method="averaged")
    assert p.inverts is True and p.method == "averaged"
    traj = mett.simulate(thesis, state, 7.0, rtol=1e-9)
    t_sim = traj.crossings(0.5 * math.pi)[0]
    T_n = 2 * math.pi * thesis.I1 / (thesis.I3 * 155.0)
    assert abs(p.t_half - t_sim) <= 0.05 * t_sim + T_n
    assert not p.validity.outside_verified_range
    # the path: D̄ runs down, Ẽ̄ of the steady precession rises with θ̄ (the energy of the balance
    # state at fixed λ), λ constant; θ̄ passes π/2 at t_half
    assert np.all(np.diff(p.D) < 0) and np.all(np.diff(p.theta) > 0)
    assert p.theta_at(p.t_half) == pytest.approx(0.5 * math.pi, abs=0.05)
    # the start with the contact point at rest has the same METT integrals but a smaller
    # growing mode: it inverts later, as simulated (5.88 s)
    other = predict_inversion(thesis, mett.State(theta=0.1, omega3=155.0), method="averaged")
    assert other.t_half > p.t_half + 0.5


def test_averaged_flow_refuses_laws_it_has_no_rate_for(thesis):
    # rolling resistance: a registered law without a power balance in either reduction (the
    # Coulomb–Contensou law is covered since λ became a slow variable of the averaged flow)
    from mett.dynamics.resistance import RollingResistance

    state = mett.State.with_cm_at_rest(thesis, theta=0.1, omega3=155.0)
    p = predict_inversion(thesis, state, RollingResistance(1e-4), method="averaged")
    assert p.inverts is None
    # below λ_0 the averaged method answers from the thresholds like the gyroscopic one
    omega3 = 0.5 * thesis.lambda_0 / (thesis.R * thesis.I3 * (math.cos(0.1) - thesis.alpha))
    p = predict_inversion(thesis, mett.State(theta=0.1, omega3=omega3), method="averaged")
    assert p.inverts is False and "lambda_0" in p.reason


# --- n_c of the gyroscopic-balance reduction vs lambda_thres -------------------------------------

_ALPHA_GAMMA = [(0.1, 1.0), (0.2, 0.9), (0.3, 1.15), (0.4, 0.7), (0.1, 0.95)]


# (0.4, 0.7) is left out here: γ = (1 + α)/2 puts λ_b = λ_thres (below), where E'(θ) of the balance
# state vanishes with the slip at θ_t and the flow is 0/0 there.
@pytest.mark.parametrize(("alpha", "gamma"), [ag for ag in _ALPHA_GAMMA if ag != (0.4, 0.7)])
def test_balance_flow_stops_exactly_at_the_tumbling_states(alpha, gamma):
    # The fixed points of dθ/dt = −P/E' are where the balance state's slip vanishes; they must be
    # the tumbling states of the full gliding model (mett.tumbling_state, an independent
    # equilibrium computation), so the flow's critical λ is λ_thres (its end) — n_c ↔ λ_thres.
    from mett.inversion._cases import _top
    from mett.inversion._gyroscopic import balance_state, flow_rate

    top = _top(alpha, gamma, 2.5, 0.3)
    lo, hi = sorted((top.lambda_0, top.lambda_thres))
    for lam in (lo + 0.3 * (hi - lo), lo + 0.7 * (hi - lo)):
        th = mett.tumbling_state(top, lam)[0]
        nu = balance_state(top, lam, th)[3]
        scale = top.R * abs(balance_state(top, lam, th)[1])  # R |ω3|: the size of the slip terms
        assert abs(nu) <= 1e-12 * scale
        assert abs(flow_rate(top, lam, Viscous(0.3), th)) <= 1e-10 * float(
            abs(flow_rate(top, lam, Viscous(0.3), 0.5 * th))
        )


@pytest.mark.parametrize(("alpha", "gamma"), _ALPHA_GAMMA)
def test_critical_spin_of_the_balance_flow_is_lambda_c(alpha, gamma):
    # n_c: complete inversion iff λ > λ_c = max(λ_0, λ_thres); checked against the full model's
    # linear stability of the inverted spin (eigenvalues, independent of the reduction).
    from mett.inversion._cases import _top

    top = _top(alpha, gamma, 2.5, 0.3)
    lt = top.lambda_thres
    assert max(mett.spin_eigenvalues(top, 0.99 * lt, "inverted").real) > 0.0
    assert max(mett.spin_eigenvalues(top, 1.01 * lt, "inverted").real) < 0.0
    lc = max(top.lambda_0, lt)
    got = []
    for f in (0.99, 1.01):
        omega3 = f * lc / (top.R * top.I3 * (math.cos(0.05) - alpha))
        state = mett.State.with_cm_at_rest(top, theta=0.05, omega3=omega3)
        got.append(predict_inversion(top, state).inverts)
    assert got == [False, True]


def test_balance_exists_wherever_the_top_can_invert():
    # The fast steady precession exists at every θ iff λ ≥ λ_b = 2 (1 + α) √(m g R³ α I1) (the
    # discriminant λ² − 4 R I1 (1 − α cos θ) m g R² α (α − cos θ) is smallest at θ = π).
    # λ_thres/λ_b = (1 + α)/(2 √(γ (1 + α − γ))) ≥ 1 (AM–GM), equal iff γ = (1 + α)/2: the
    # balance never fails above λ_thres, and the two agree in that closed-form limit.
    from mett.inversion._cases import _top
    from mett.inversion._gyroscopic import balance_state

    th = np.linspace(0.0, math.pi, 2001)
    for alpha, gamma in [*_ALPHA_GAMMA, (0.4, 0.7), (0.35, 0.675)]:
        top = _top(alpha, gamma, 2.5, 0.3)
        lb = 2 * (1 + alpha) * math.sqrt(top.m * top.g * top.R**3 * alpha * top.I1)
        with np.errstate(invalid="ignore"):  # NaN where the balance does not exist: the point
            assert np.all(np.isfinite(balance_state(top, 1.0001 * lb, th)[0]))
            assert not np.all(np.isfinite(balance_state(top, 0.9999 * lb, th)[0]))
        ratio = top.lambda_thres / lb
        assert ratio >= 1.0 - 1e-12
        if gamma == pytest.approx((1 + alpha) / 2, rel=1e-12):
            assert ratio == pytest.approx(1.0, rel=1e-12)


def test_averaged_method_answers_inverts_right_on_a_fast_table_case():
    # Table case 22 (viscous, μ = 2.5 s/m, the simulated top passes π/2 at 0.49 s): the averaged
    # flow must say that the top inverts, flagged (μ |ν| > 1 on the way: the viscous law's
    # artefact, docs/theory/inversion.md#the-averaged-flow); the full table is in
    # test_inversion_verify_slow.py.
    case = cases()[22]
    pred = predict_inversion(case.top, case.state, case.friction, method="averaged")
    assert pred.inverts is True and pred.validity.outside_verified_range
    assert math.isfinite(pred.t_half) and pred.t_start < pred.t_half <= pred.t_inv
    t_sim, _, status = simulated_t_half(case, 2.0, rtol=1e-8)
    assert status == "completed" and math.isfinite(t_sim)


def test_averaged_method_meets_the_target_on_a_fast_table_case_in_its_range():
    # Table case 0 (viscous, μ = 1.14 s/m, CM at rest, θ0 = 0.04; simulated crossing 1.56 s, in
    # contact): inside the averaged flow's validity range, so within the worst-case
    # target, 10 % of t_half plus one nutation period (the table's slack), of the simulation.
    case = cases()[0]
    pred = predict_inversion(case.top, case.state, case.friction, method="averaged")
    assert pred.inverts is True and not pred.validity.outside_verified_range
    assert pred.t_lift == math.inf
    t_sim, T_n, status = simulated_t_half(case, 2.0 * pred.t_half, rtol=1e-8)
    assert status == "completed"
    assert abs(pred.t_half - t_sim) <= 0.10 * t_sim + T_n


# --- Coulomb–Contensou: the balance flow in (θ, λ) ------------------------------------------------


@pytest.mark.parametrize("cm_response", [False, True])
def test_contensou_rates_are_the_laws_power_and_drilling_torque(thesis, cm_response):
    # References independent of the reduction's algebra: the law's own force and torque
    # (Coulomb.force, Leine & Glocker 2003) at the flow's slip and the balance state's spin,
    # Jellett's λ = −L·a under a pure couple M ẑ (dλ/dt = M R (1 − α cos θ)), and the energy
    # balance dE/dt = −P checked by central differences of E(θ, λ) along the flow (h = 1e-5 of
    # each rate over 1 s: O(h²) truncation, far below the 1e-6 asked). The slip is the balance
    # state's own (centre of mass at rest) or, with cm_response, the contact point's response
    # √x of cm_slip2; the power the rotation loses is then −F·w = −F·v_A (F ⟂ ṙ).
    from mett.inversion._gyroscopic import cm_slip2, contensou_rates

    law = Coulomb(0.3, contensou_radius=2e-3)
    lam = 6.8944e-6
    gn = thesis.m * thesis.g
    for th in (0.05, 0.5, 1.5, 2.5):
        thdot, lamdot, st = contensou_rates(thesis, law, lam, th, cm_response)
        phidot, nu, omega_n = float(st[0]), float(st[3]), float(st[4])
        if cm_response:
            K = 1 + thesis.m * thesis.R**2 * (1 - thesis.alpha * math.cos(th)) ** 2 / thesis.I1
            k2 = (law.mu * thesis.g * K / phidot) ** 2
            nu = math.sqrt(float(cm_slip2(nu * nu, (law.r_star * omega_n) ** 2, k2)))
        (fx, fy), M = law.force([0.0, nu], gn, omega_n)
        arm = thesis.R * (1.0 - thesis.alpha * math.cos(th))
        assert float(lamdot) == pytest.approx(float(M) * arm, rel=1e-12)
        P = -(float(fy) * nu + float(M) * omega_n)
        dt = 1e-5
        E = [balance_state(thesis, lam + k * dt * float(lamdot), th + k * dt * float(thdot))[2]
             for k in (-1, 1)]  # fmt: skip
        assert (E[1] - E[0]) / (2 * dt) == pytest.approx(-P, rel=1e-6)


@pytest.mark.parametrize("a", [0.0, 1.0])
def test_contact_point_response_solves_its_slip_equation(a):
    # cm_slip2 against the equation it solves, written independently: the steady slip of
    # v̇ + i φ̇ v = K F/m + i φ̇ w with F = −μ g_n v/√(a |v|² + b) is v = w/(1 − i κ K),
    # κ = μ g/(φ̇ √(a |v|² + b)); checked as a complex residual at the returned |v|. a = 1: the
    # dry laws; a = 0: the viscous law (c = μ g_n/√b, constant). At b = 0 (exact Coulomb) the
    # slip stops where |w| φ̇ < μ g K, else |v|² = w² − (μ g K/φ̇)².
    from mett.inversion._gyroscopic import cm_slip2

    rng = np.random.default_rng(3)
    for _ in range(200):
        w, b, k = rng.uniform(0.01, 1.0), rng.uniform(0.0, 0.5) ** 2, rng.uniform(0.0, 2.0)
        if a == 0.0:
            b += 1e-3
        x = float(cm_slip2(w * w, b, k * k, a))
        kappa_K = k / math.sqrt(a * x + b) if a * x + b > 0 else math.inf
        v = w / (1 - 1j * kappa_K)
        assert abs(v) ** 2 == pytest.approx(x, rel=1e-10, abs=1e-14)
    if a == 1.0:
        assert float(cm_slip2(0.25, 0.0, 0.09)) == pytest.approx(0.16, rel=1e-14)
        assert float(cm_slip2(0.09, 0.0, 0.25)) == 0.0
    else:
        assert float(cm_slip2(0.25, 1.0, 3.0, a)) == pytest.approx(0.0625, rel=1e-14)


# The laws of the growth-rate check: viscous μ (s/m) over two decades, regularised Coulomb with
# ε from 1e-3 to 1e-1 m/s (a viscous law μ/ε = 5–300 s/m at the upright spin).
GROWTH_LAWS = [Viscous(0.03), Viscous(0.3), Viscous(3.0), RegularisedCoulomb(0.5, 0.1),
               RegularisedCoulomb(0.3, 0.01), RegularisedCoulomb(0.3, 0.001)]  # fmt: skip


@pytest.mark.parametrize("preset", ["rutstam2013", "friedl1997", "cohen1977", "ueda2005"])
@pytest.mark.parametrize("law", GROWTH_LAWS, ids=repr)
def test_contact_point_response_gives_the_linear_growth_rate_of_strong_friction(preset, law):
    # Reference: the growth rate of the full gliding model linearised at the upright spin (its
    # Jacobian's eigenvalues, mett.spin_eigenvalues, with the law's viscous coefficient at small
    # slip), which keeps the centre of mass and the rotation free. The balance flow's rate
    # (mett.inversion._gyroscopic.flow_rate) takes the contact point's steady answer to the
    # friction force, which scales |v_A|² by 1/(1 + (κ K)²), κ = μ g/φ̇. Declared accuracy
    # (docs/theory/inversion.md#two-stages): the response neglects v̇_A, which is σ v_A against
    # φ̇ v_A, so 2 σ/φ̇ for κ K ≤ 1; where κ K > 1 the contact point nearly rolls and the
    # first-order response leaves the flow up to 20 % slow. The flow without the response is
    # outside these bounds wherever κ K > 0.5 (1.5× to 6000× too fast here).
    from mett.inversion._gyroscopic import flow_rate

    mu_lin = law.mu if isinstance(law, Viscous) else law.mu / law.eps
    top = mett.presets.get(preset, mu=mu_lin)
    lam = 2.0 * top.lambda_thres
    th = 1e-5
    phidot = float(balance_state(top, lam, th)[0])
    K = 1 + top.m * top.R**2 * (1 - top.alpha * math.cos(th)) ** 2 / top.I1
    kK = mu_lin * top.g * K / phidot
    sigma = max(np.real(mett.spin_eigenvalues(top, lam, pole="upright")))
    tol = 2.0 * sigma / phidot if kK <= 1.0 else 0.2
    assert tol <= 0.2
    sigma_flow = float(flow_rate(top, lam, law, th)) / th
    assert sigma_flow == pytest.approx(sigma, rel=tol)
    if kK > 0.5:
        sigma_alone = float(flow_rate(top, lam, law, th, cm_response=False)) / th
        assert abs(sigma_alone / sigma - 1.0) > tol


# Two tops of the verification table (docs/theory/inversion.md#verification, cases 22 and 44,
# rounded) that stay on the table under strong friction: a viscous one (μ = 2.5 s/m, κ K ≈ 0.3 at
# the upright spin) and a regularised one (μ/ε = 4.2 s/m). (α, γ, σ, μ of the top, law, θ0, ω3).
STRONG = [
    (0.307, 1.051, 2.319, 2.54, Viscous(), 0.0398, 177.9),
    (0.199, 0.972, 3.012, 0.3, RegularisedCoulomb(0.379, 0.0899), 0.0157, 150.9),
]


@pytest.mark.parametrize("alpha, gamma, sigma, mu, law, theta0, omega3", STRONG)
def test_strong_friction_predictions_follow_the_contact_points_response(
    alpha, gamma, sigma, mu, law, theta0, omega3, monkeypatch
):
    # Reference: the compiled simulation's first crossing of π/2 (the top stays on the table).
    # Declared accuracy of the viscous law: 5 % of t_half plus one nutation period
    # (test_thesis_cm_at_rest_t_half_matches_simulation). Without the contact point's response
    # the predictions were 15 % and 21 % early (7.8 % and 15.9 % after the slack).
    import functools

    import mett.inversion as inversion
    from mett.inversion._gyroscopic import slow_path

    m, R = 0.02, 0.02
    I3 = m * R * R / sigma
    top = mett.TippeTop(m=m, R=R, alpha=alpha, I1=gamma * I3, I3=I3, mu=mu, g=9.82)
    state = mett.State.with_cm_at_rest(top, theta=theta0, omega3=omega3)
    pred = predict_inversion(top, state, law)
    assert pred.inverts is True
    traj = mett.simulate(top, state, 1.5 * pred.t_half, friction=law, rtol=1e-9)
    assert traj.t_contact_lost is None
    t_sim = traj.crossings(0.5 * math.pi)[0]
    T_n = 2 * math.pi * top.I1 / (top.I3 * omega3)
    assert abs(pred.t_half - t_sim) <= 0.05 * t_sim + T_n
    monkeypatch.setattr(inversion, "slow_path", functools.partial(slow_path, cm_response=False))
    alone = predict_inversion(top, state, law)
    assert abs(alone.t_half - t_sim) > 0.05 * t_sim + T_n


# Cases of the Contensou check (docs/theory/inversion.md#coulombcontensou), both outcomes:
# (preset, μ, ω3, contact radius r, θ0, centre of mass at rest). The declared accuracy of t_half
# is 6 % + one nutation period for θ0 <= 0.03 and 12 % + one period for θ0 <= 0.1 (the start's
# slip R θ0 ω3 then exceeds r* ω3, beyond the law's linear range); ε = T_n/t_half up to 0.07.
CONTENSOU = [
    ("rutstam2013", 0.3, 155.0, 3e-3, 0.1, False),
    ("rutstam2013", 0.3, 155.0, 3e-3, 0.03, False),
    ("friedl1997", 0.3, 180.0, 3e-3, 0.1, True),
    ("friedl1997", 0.15, 180.0, 5e-4, 0.03, False),
    ("rutstam2013", 0.15, 155.0, 1.5e-3, 0.03, True),
    ("friedl1997", 0.3, 288.0, 1.5e-3, 0.03, True),
    ("rutstam2013", 0.3, 155.0, 5e-4, 0.03, True),
    ("friedl1997", 0.5, 180.0, 5e-4, 0.03, True),
]


@pytest.mark.parametrize(("preset", "mu", "omega3", "r", "theta0", "cm"), CONTENSOU)
def test_contensou_prediction_matches_simulation(preset, mu, omega3, r, theta0, cm):
    # Reference: the full Coulomb–Contensou simulation (compiled DOP853, exact law). Tolerance:
    # the declared accuracy above. `inverts` False must mean the simulated θ never comes within
    # tol of π (it falls back when the drilling torque has consumed the spin), True that it does.
    top = mett.presets.get(preset)
    state = mett.State.with_cm_at_rest(top, theta=theta0, omega3=omega3) if cm else (
        mett.State(theta=theta0, omega3=omega3))  # fmt: skip
    law = Coulomb(mu, contensou_radius=r)
    p = predict_inversion(top, state, law)
    assert p.validity.outside_verified_range and p.inverts is not None
    assert np.all(np.diff(p.lam) < 0)  # the drilling torque lowers λ all the way
    traj = mett.simulate(top, state, 1.5 * (p.t_inv if math.isfinite(p.t_inv) else 2 * p.t_half),
                         friction=law, rtol=1e-8, stop_on_contact_loss=True)  # fmt: skip
    assert traj.status == "completed"
    t_sim = traj.crossings(0.5 * math.pi)[0]
    T_n = 2 * math.pi * top.I1 / (top.I3 * omega3)
    accuracy = 0.06 if theta0 <= 0.03 else 0.12
    assert abs(p.t_half - t_sim) <= accuracy * t_sim + T_n
    reached = float(np.max(traj.theta)) >= math.pi - p.tol
    assert reached is p.inverts, p.reason


@pytest.mark.parametrize("hang", [False, True])
def test_slow_path_quadrature_converges(thesis, hang):
    # The path's composite Simpson (step PATH_STEP in s = ln tan(θ/2), θ0 and π/2 as nodes)
    # against the same flow on a 16× finer grid: O(h⁴) gives ~1e-9 relative at the times of
    # the marks and at the end; 1e-7 leaves margin for the constant. The tumbling end (hang) is
    # graded towards θ_t, where the flow slows like θ_t − θ; tol = 1e-3 there is 50× finer than
    # the default and still converges: each graded segment spans a doubling of θ_t − θ with 16
    # steps, and Simpson on the integrand ~1/(θ_t − θ) there errs by (1/16)⁴ · 24/180 ≈ 2e-6 of
    # that segment's time (the segments near θ_t a small part of the total): 1e-6.
    from mett.inversion._gyroscopic import PATH_STEP, slow_path

    if hang:
        lam = 0.5 * (thesis.lambda_0 + thesis.lambda_thres)
        end = float(mett.tumbling_state(thesis, lam)[0])
        target, fixed = end - 1e-3, end
    else:
        lam = float(
            mett.jellett(thesis, mett.State.with_cm_at_rest(thesis, theta=0.1, omega3=155.0))
        )
        target, fixed = math.pi - 0.05, None
    marks = (0.1, 0.5 * math.pi)
    coarse = slow_path(thesis, lam, Viscous(), 1e-3, target, marks, fixed_point=fixed)
    fine = slow_path(thesis, lam, Viscous(), 1e-3, target, marks, PATH_STEP / 16, fixed)
    rel = 1e-6 if hang else 1e-7
    assert coarse[0][-1] == pytest.approx(fine[0][-1], rel=rel)
    for m in marks:
        assert coarse[3][m] == pytest.approx(fine[3][m], rel=rel)
    assert all(math.isfinite(coarse[3][m]) for m in marks)  # both marks lie on these paths


# --- the gallery figure: the run beside the predicted slow path -----------------------------------


def test_nutation_mean_of_a_drifting_oscillation():
    # θ = a + c t + b sin(2π t/T): the mean over each cycle between maxima is a + c t_mid exactly;
    # the trapezoid rule with 4 000 samples a period errs by ~b (2π/4000)²/12 = 2e-7 b, and the
    # sampled maxima sit within half a sample of the true ones (the drift moves them by c T/(2π b)).
    from mett.gallery import _nutation_mean

    a, b, c, T = 0.3, 0.05, 0.02, 0.04
    t = np.linspace(0.0, 1.0, 100_001)
    tm, m = _nutation_mean(t, a + c * t + b * np.sin(2 * np.pi * t / T))
    assert len(tm) == 24
    np.testing.assert_allclose(m, a + c * tm, atol=1e-6)


def test_gallery_prediction_figure_draws_both_paths():
    pytest.importorskip("matplotlib")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from mett import gallery
    from mett.plotting import D_SCALE

    ctx = gallery._Context()
    fig = gallery.FIGURES["inversion_prediction"][1](ctx)
    p = predict_inversion(ctx.body, ctx.start)
    a1 = fig.axes[0]  # the map
    (a2,) = [a for a in fig.axes if a.get_xlabel() == "t [s]"]  # the θ(t) panel
    labels = {ln.get_label(): ln for ln in a1.lines}
    assert {"trajectory", "predicted slow path"} <= set(labels)
    np.testing.assert_allclose(labels["predicted slow path"].get_xdata(), p.D * D_SCALE)
    lines = {ln.get_label(): ln for ln in a2.lines}
    np.testing.assert_allclose(lines["predicted θ̄(t) (the growing mode)"].get_ydata(), p.theta)
    np.testing.assert_allclose(lines["simulated θ(t)"].get_ydata(), ctx.thesis.theta)
    mean = lines["simulated, mean over each nutation"].get_ydata()
    assert len(mean) > 100 and np.all((0.0 < mean) & (mean < math.pi))
    plt.close(fig)
