"""The models of mett.dynamics against each other and against the METT layer.

* vector form vs Euler-angle form of the gliding top (docs/theory/equations.md#vector-form, docs/theory/equations.md#euler-form);
* rolling model: E, D, λ conserved, period = mett.nutation_period (docs/theory/mett.md#the-main-equation, docs/theory/mett.md#rational);
* limits: R → 0 with Rα = l fixed gives the gliding heavy symmetric top, the cylinder subspace
  φ̇ = ω3 = ν_y = 0 is invariant, μ = 0 never inverts (docs/theory/reduced.md#reduced-systems);
* every preset runs; maple-tippe-top with α = 0.5724 and λ = 2 λ_thres loses contact.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import mett
from mett.dynamics import MODELS, euler_rhs, gliding_rhs, hst_euler_rhs, simulate
from mett.dynamics.reduced import cylinder_rhs

SERIES = ("theta", "thetadot", "phidot", "omega3", "nu_x", "nu_y")


@pytest.fixture(scope="module")
def top() -> mett.TippeTop:
    return mett.presets.get("rutstam2013")


def _max_rel(a, b) -> float:
    """max |a − b| over the series, relative to max |b| (the series' own scale)."""
    return float(np.max(np.abs(np.asarray(a) - np.asarray(b))) / np.max(np.abs(b)))


def _agreement(tr_a, tr_b, times) -> dict[str, float]:
    a, b = tr_a.at(times), tr_b.at(times)
    out = {k: _max_rel(getattr(a, k), getattr(b, k)) for k in SERIES}
    return out


# --- vector form vs Euler form ---------------------------------------------------------------


def test_vector_and_euler_forms_agree_from_random_gliding_states(top):
    # 12 generic gliding states away from the poles, 0.05 s each (several nutation periods), both
    # forms at rtol = 1e-12. Measured worst agreement ~1e-10 of each series' scale.
    rng = np.random.default_rng(3)
    times = np.linspace(0.0, 0.05, 51)
    worst = 0.0
    for _ in range(12):
        s = mett.State(
            theta=rng.uniform(0.4, math.pi - 0.4),
            thetadot=rng.normal(0, 3),
            phidot=rng.normal(0, 10),
            omega3=rng.normal(0, 120),
            nu_x=rng.normal(0, 0.1),
            nu_y=rng.normal(0, 0.1),
        )
        vec = simulate(top, s, 0.05, rtol=1e-12, stop_on_contact_loss=True)
        eul = simulate(top, s, 0.05, model="gliding-euler", rtol=1e-12)
        if vec.status != "completed":  # a random state may lift off; both forms must agree on it
            assert eul.status == vec.status == "contact_lost"
            assert eul.t_contact_lost == pytest.approx(vec.t_contact_lost, abs=1e-9)
            continue
        assert eul.status == "completed"
        worst = max(worst, *_agreement(vec, eul, times).values())
        for k in ("E", "E_mod", "D", "lam", "gn", "x", "y"):
            assert getattr(eul, k)[-1] == pytest.approx(getattr(vec, k)[-1], rel=1e-8, abs=1e-12), k
    assert worst < 1e-8


def test_vector_and_euler_forms_agree_on_the_first_second_of_the_thesis_run(top):
    s = mett.State(theta=0.1, omega3=155.0)
    vec = simulate(top, s, 1.0, rtol=1e-12)
    eul = simulate(top, s, 1.0, model="gliding-euler", rtol=1e-12)
    agree = _agreement(vec, eul, np.linspace(0.0, 1.0, 1001))
    assert max(agree.values()) < 1e-8, agree


@pytest.mark.slow
@pytest.mark.ci
def test_vector_and_euler_forms_agree_over_the_thesis_run_away_from_the_pole(top):
    """The thesis run passes θ ≈ 2e-4 near t = 3.19 s, where the Euler form is singular.

    What is compared: (A) both forms from the thesis start over [0, 2.5 s] (θ ≥ 0.03 there);
    (B) the Euler form restarted from the vector solution at t = 3.5 s (θ = 0.17), over
    [3.5, 7 s], through the inversion (θ ≤ 3.06 there, so sin θ ≥ 0.08). Both forms at rtol = 1e-13;
    the agreement is max |Δ| relative to the series' scale. Measured: θ 1.2e-10, θ̇ 7e-10,
    φ̇ 5e-10, ω3 1e-13, ν 5e-10 (A); θ 1.5e-12, θ̇ 2.5e-11, ω3 9e-13 (B).
    """
    s = mett.State(theta=0.1, omega3=155.0)
    vec = simulate(top, s, 7.0, rtol=1e-13)
    assert vec.status == "completed"
    eul_a = simulate(top, s, 2.5, model="gliding-euler", rtol=1e-13)
    agree_a = _agreement(vec, eul_a, np.linspace(0.0, 2.5, 2501))
    assert max(agree_a.values()) < 1e-8, agree_a

    t_restart = 3.5
    eul_b = simulate(top, vec.at(t_restart), 7.0 - t_restart, model="gliding-euler", rtol=1e-13)
    assert eul_b.status == "completed"
    tt = np.linspace(0.0, 7.0 - t_restart, 3501)
    a, b = eul_b.at(tt), vec.at(tt + t_restart)
    agree_b = {k: _max_rel(getattr(a, k), getattr(b, k)) for k in SERIES}
    assert max(agree_b.values()) < 1e-8, agree_b
    assert eul_b.theta.max() > 3.0  # segment B covers the inversion


def _textbook_gliding_rhs(y, p, digits=None):
    """The vector form as printed (docs/theory/equations.md#vector-form: W, W0, ω̇ and g_n), with
    none of the simplifications of mett.dynamics.gliding: [ẍ, ÿ, L̇, 3̂̇, g_n], in mpmath at
    ``digits`` digits, or in floats (None)."""
    import mpmath as mp

    if digits:
        mp.mp.dps = digits
    num, sqrt = (mp.mpf, mp.sqrt) if digits else (float, math.sqrt)
    y = [num(float(v)) for v in y]
    m, R, l, I1, I3, mu, g = (num(float(v)) for v in p)
    cross = lambda a, b: [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],  # noqa: E731
                          a[0] * b[1] - a[1] * b[0]]  # fmt: skip
    dot = lambda a, b: a[0] * b[0] + a[1] * b[1] + a[2] * b[2]  # noqa: E731
    v, L, e = [y[2], y[3], num(0)], y[4:7], y[7:10]
    n = sqrt(dot(e, e))
    e = [x / n for x in e]
    c = 1 / I3 - 1 / I1
    w = [Li / I1 + c * dot(L, e) * ei for Li, ei in zip(L, e, strict=True)]
    de = cross(w, e)
    a = [l * e[0], l * e[1], l * e[2] - R]
    nu = [vi + wi for vi, wi in zip(v, cross(w, a), strict=True)]
    K = cross(a, [-mu * nu[0], -mu * nu[1], num(1)])
    W = [Ki / I1 + c * dot(K, e) * ei for Ki, ei in zip(K, e, strict=True)]
    W0 = [c * dot(L, e) * x for x in de]
    q = cross(W0, e)[2] + cross(w, de)[2]
    den = 1 + m * l * cross(W, e)[2]
    gn = m * (g - l * q) / den
    F = [-mu * gn * nu[0], -mu * gn * nu[1], gn]
    # the sizes of the terms that cancel in each part (ν = ṙ + ω × a, ω across 3̂, q)
    norm = lambda x: sqrt(dot(x, x))  # noqa: E731
    slip, turn = norm(v) + norm(w) * norm(a), norm(L) / I1 + abs(c * dot(L, e))
    sizes = [mu * abs(gn) / m * slip, norm(a) * abs(gn) * (1 + mu * slip), turn,
             m * (g + l * norm(de) * (turn + norm(w))) / abs(den)]  # fmt: skip
    values = [F[0] / m, F[1] / m, *cross(a, F), *de, gn]
    return np.array([float(x) for x in values]), np.array([float(x) for x in sizes])


def test_the_simplified_vector_rhs_equals_the_printed_formulas_in_mpmath(top):
    # gliding_core uses |3̂| = 1 to drop products (ω × 3̂ = (L × 3̂)/I1, the z-parts of W × 3̂ and
    # of the gyroscopic terms). Against the printed formulas at 50 digits, at random states, on
    # and off |3̂| = 1, at the poles, for a huge spin and with R = 0 (the heavy top): its error is
    # within that of the printed formulas in floats, relative to the size of the terms that
    # cancel in each part (at a huge spin the small part of ω across 3̂ limits both to 1e-12)
    from mett.dynamics.gliding import gliding_core

    rng = np.random.default_rng(5)
    mdl = MODELS["gliding"]
    cases = [(top, mett.State(theta=th, omega3=w3, thetadot=rng.normal(0, 3),
                              phidot=rng.normal(0, 10), nu_x=rng.normal(0, 0.1),
                              nu_y=rng.normal(0, 0.1)))
             for th, w3 in zip(rng.uniform(0, np.pi, 12), rng.normal(0, 150, 12), strict=True)]  # fmt: skip
    cases += [(top, mett.State(theta=0.0, omega3=155.0)), (top, mett.State(theta=math.pi)),
              (top, mett.State(theta=2.0, omega3=1e5, phidot=3.0)),
              (top.replace(mu=0.0), mett.State(theta=1.0, omega3=50.0, nu_x=0.2))]  # fmt: skip
    parts = (slice(0, 2), slice(2, 5), slice(5, 8), slice(8, 9))  # ν̇-part, L̇, 3̂̇, g_n
    worst = 0.0
    for t_, state in cases:
        for p in (mdl.params(t_, {}), (t_.m, 0.0, t_.R * t_.alpha, t_.I1, t_.I3, t_.mu, t_.g)):
            y = np.asarray(mdl.initial(state, p), dtype=float)
            for stretch in (1.0, 1.0 + 1e-6):
                y[7:10] *= stretch
                exact, sizes = _textbook_gliding_rhs(y, p, digits=50)
                printed = _textbook_gliding_rhs(y, p)[0]
                d = gliding_core(y, p)
                got = np.array([*d[2:10], d[10]], dtype=float)
                for part, size in zip(parts, sizes, strict=True):
                    size = max(size, 1e-300)  # μ = 0: no friction force at all
                    err = np.abs(got[part] - exact[part]).max() / size
                    ref = np.abs(printed[part] - exact[part]).max() / size
                    assert err <= max(4.0 * ref, 1e-14), (state, part, err, ref)
                    worst = max(worst, err)
    assert worst > 0.0  # the comparison is not vacuous


def test_euler_rhs_matches_the_vector_rhs_pointwise(top):
    # d/dt of (θ, ω3, |ν|²) computed from the vector RHS equals the Euler RHS at random states.
    rng = np.random.default_rng(7)
    vec, p_vec = MODELS["gliding"], MODELS["gliding"].params(top, {})
    p_eul = MODELS["gliding-euler"].params(top, {})
    for _ in range(20):
        s = mett.State(
            theta=rng.uniform(0.2, 2.9),
            thetadot=rng.normal(0, 3),
            phidot=rng.normal(0, 10),
            omega3=rng.normal(0, 120),
            nu_x=rng.normal(0, 0.1),
            nu_y=rng.normal(0, 0.1),
        )
        y = vec.initial(s, p_vec)
        f = gliding_rhs(0.0, y, p_vec)
        h = 1e-7

        def reduced(Y):
            d = vec.derive(Y[:, None], p_vec)
            return np.array([d[k][0] for k in SERIES])

        num = (reduced(y + h * f) - reduced(y - h * f)) / (2 * h)
        exact = euler_rhs(s.as_array(), p_eul)  # [θ̇, θ̈, φ̈, ω̇3, ν̇_x, ν̇_y]
        # the ν-components of the vector state are in the rotating frame x̂, ŷ, as in the Euler form
        assert num[0] == pytest.approx(exact[0], rel=1e-7, abs=1e-9)
        for i in range(1, 6):
            assert num[i] == pytest.approx(exact[i], rel=1e-6, abs=1e-6 * np.max(np.abs(exact))), i


# --- rolling ---------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def rolling_run(top):
    # docs/theory/mett.md#rational: thesis body rolling from θ0 = 1, ω3 = 100, φ̇0 = 5; T = 0.055014 s.
    return simulate(top, mett.State(theta=1.0, omega3=100.0, phidot=5.0), 2.0, model="rolling")


def test_rolling_conserves_E_D_lambda(rolling_run):
    tr = rolling_run
    assert tr.status == "completed"
    for k in ("E", "D", "lam"):
        v = getattr(tr, k)
        assert np.max(np.abs(v / v[0] - 1.0)) < 1e-9, k  # measured E 3e-12, D and λ 7e-11
    assert np.all(tr.nu_x == 0.0) and np.all(tr.nu_y == 0.0)
    assert np.array_equal(tr.E_mod, tr.E)


def test_rolling_period_equals_the_METT_nutation_period(rolling_run, top):
    tr = rolling_run
    E, D, lam = tr.E[0], tr.D[0], tr.lam[0]
    T = float(mett.nutation_period(top, E, D, lam))
    z_low, z_high = mett.turning_points(top, E, D, lam)
    # θ oscillates between the turning points of the METT ...
    assert tr.theta.max() == pytest.approx(math.acos(z_low), abs=1e-9)
    assert tr.theta.min() == pytest.approx(math.acos(z_high), abs=1e-6)  # sampled, not root-found
    # ... with the METT period: upward crossings of the mid-level, averaged over the whole run.
    up = tr.crossings(math.acos(0.5 * (z_low + z_high)), direction=1)
    assert up.size >= 30
    T_sim = (up[-1] - up[0]) / (up.size - 1)
    assert T_sim == pytest.approx(T, rel=1e-7)  # measured 5e-10
    assert np.diff(up) == pytest.approx(np.full(up.size - 1, T), rel=1e-6)


def test_rolling_model_agrees_with_the_METT_equation_of_motion(rolling_run, top):
    # θ̈ from the METT (docs/theory/mett.md#the-main-equation) at the samples vs the derivative of θ̇ on the dense output.
    tr = rolling_run
    h = 1e-6
    t = tr.t[(tr.t > h) & (tr.t < tr.t[-1] - h)][::10]
    thdd = (tr.at(t + h).thetadot - tr.at(t - h).thetadot) / (2 * h)
    s = tr.at(t)
    z = np.cos(s.theta)
    gz = mett.g(top, z)
    theory = (
        np.sin(s.theta)
        * (
            mett.dV_dz(top, z, tr.D[0], tr.lam[0])
            + (-top.sigma * top.alpha * top.I3) * s.thetadot**2
        )
        / (2 * gz)
    )
    assert np.max(np.abs(thdd - theory)) < 1e-5 * np.max(np.abs(theory))


# --- limits and reduced systems --------------------------------------------------------------


def test_euler_rhs_tends_to_the_heavy_top_linearly_in_R(top):
    # docs/theory/reduced.md#reduced-systems: the TT right-hand sides with R → 0, Rα = l fixed converge linearly to the GHST.
    l = top.R * top.alpha
    p_h = (top.m, l, top.I1, top.I3, top.mu, top.g)
    rng = np.random.default_rng(11)
    for _ in range(5):
        y = np.array(
            [
                rng.uniform(1.8, 3.0),
                rng.normal(0, 2),
                rng.normal(0, 5),
                rng.normal(0, 200),
                *rng.normal(0, 0.05, 2),
            ]
        )
        ref = hst_euler_rhs(y, p_h)
        errs = []
        for R in (1e-4, 1e-5, 1e-6):
            p_tt = (top.m, R, l / R, top.I1, top.I3, top.mu, top.g)
            errs.append(np.max(np.abs(euler_rhs(y, p_tt) - ref)))
        assert errs[0] < 1e-2 * np.max(np.abs(ref))
        assert errs[0] / errs[1] == pytest.approx(10.0, rel=0.05)
        assert errs[1] / errs[2] == pytest.approx(10.0, rel=0.05)


def test_gliding_top_tends_to_the_gliding_heavy_top_as_R_to_0(top):
    # Trajectory level: the vector RHS with a = l 3̂ − R ẑ, R = 1e-3, 1e-4, 1e-5 at fixed l, against R = 0
    # (the "gliding-hst" model), over 0.2 s from a top standing on its tip (θ = 2.6). The gap
    # shrinks linearly in R.
    l = top.R * top.alpha
    s = mett.State(theta=2.6, thetadot=0.5, phidot=2.0, omega3=250.0, nu_x=0.02, nu_y=-0.01)
    hst = simulate(top, s, 0.2, model="gliding-hst", rtol=1e-12)
    assert hst.status == "completed"
    model = MODELS["gliding-hst"]
    gaps = []
    for R in (1e-3, 1e-4, 1e-5):
        p = (top.m, R, l, top.I1, top.I3, top.mu, top.g)
        y0 = model.initial(s, p)
        sol = solve_ivp(
            gliding_rhs, (0.0, 0.2), y0, method="DOP853", rtol=1e-12, atol=1e-14, args=(p,)
        )
        th = np.arctan2(np.hypot(sol.y[7, -1], sol.y[8, -1]), sol.y[9, -1])
        gaps.append(abs(th - hst.theta[-1]))
    assert gaps[0] > gaps[1] > gaps[2]
    assert gaps[0] / gaps[1] == pytest.approx(10.0, rel=0.1)
    assert gaps[1] / gaps[2] == pytest.approx(10.0, rel=0.1)


def test_gliding_hst_model(top):
    # ω3 is an integral of the GHST and λ = −l I3 ω3 (docs/theory/reduced.md#reduced-systems); the vector form with R = 0
    # agrees with the Euler form of docs/theory/reduced.md#reduced-systems.
    l = 0.01
    s = mett.State(theta=2.6, thetadot=0.5, phidot=2.0, omega3=250.0, nu_x=0.02, nu_y=-0.01)
    tr = simulate(top, s, 1.0, model="gliding-hst", l=l, rtol=1e-12)
    assert tr.status == "completed"
    assert np.max(np.abs(tr.omega3 / 250.0 - 1.0)) < 1e-10
    assert np.max(np.abs(tr.lam / (-l * top.I3 * 250.0) - 1.0)) < 1e-10
    assert np.all(np.diff(tr.E) <= 1e-14)
    p_h = (top.m, l, top.I1, top.I3, top.mu, top.g)
    sol = solve_ivp(
        lambda t, y: hst_euler_rhs(y, p_h),
        (0.0, 1.0),
        s.as_array(),
        method="DOP853",
        rtol=1e-12,
        atol=1e-14,
        dense_output=True,
    )
    tt = np.linspace(0.0, 1.0, 201)
    ref = sol.sol(tt)
    got = tr.at(tt)
    for i, k in enumerate(SERIES):
        assert _max_rel(getattr(got, k), ref[i]) < 1e-8, k
    # default l is R α
    assert simulate(top, s, 0.01, model="gliding-hst").params[2] == top.R * top.alpha


def test_cylinder_subspace_is_invariant(top):
    # φ̈ = ω̇3 = ν̇_y = 0 exactly on φ̇ = ω3 = ν_y = 0 (Euler RHS) ...
    rng = np.random.default_rng(5)
    p = MODELS["gliding-euler"].params(top, {})
    for th in rng.uniform(0.1, 3.0, 10):
        y = np.array([th, rng.normal(0, 5), 0.0, 0.0, rng.normal(0, 0.2), 0.0])
        d = euler_rhs(y, p)
        assert d[2] == 0.0 and d[3] == 0.0 and d[5] == 0.0
    # ... and the full vector-form motion stays in it, rocking through θ = 0, as the cylinder model.
    s = mett.State(theta=0.5, thetadot=0.0, nu_x=0.05)
    full = simulate(top, s, 2.0, rtol=1e-12)
    cyl = simulate(top, s, 2.0, model="cylinder", rtol=1e-12)
    assert full.status == cyl.status == "completed"
    for k in ("phidot", "omega3", "nu_y", "lam", "D"):
        assert np.max(np.abs(getattr(full, k))) < 1e-12, k
    assert full.theta.min() < 1e-3  # it does rock through the pole
    tt = np.linspace(0.0, 2.0, 2001)
    a, b = full.at(tt), cyl.at(tt)
    assert np.max(np.abs(a.theta - b.theta)) < 1e-9
    assert np.max(np.abs(a.thetadot - b.thetadot)) < 1e-8
    assert np.max(np.abs(a.nu_x - b.nu_x)) < 1e-9
    assert cyl.crossings(0.2) == pytest.approx(full.crossings(0.2), abs=1e-9)
    assert full.y[-1] == pytest.approx(cyl.y[-1], abs=1e-10) and np.all(cyl.x == 0.0)


def test_cylinder_energy_rate(top):
    # docs/theory/reduced.md#reduced-systems: Ė = −μ g_n ν_x² on the cylinder subspace.
    s = mett.State(theta=1.0, thetadot=2.0, nu_x=-0.05)
    cyl = simulate(top, s, 1.0, model="cylinder")
    p = cyl.params
    model = MODELS["cylinder"]
    Y = cyl.states
    F = np.array([cylinder_rhs(0.0, Y[:, i], p) for i in range(Y.shape[1])]).T
    h = 1e-6
    E = lambda Z: model.derive(Z, p)["E"]  # noqa: E731
    dE = (E(Y + h * F) - E(Y - h * F)) / (2 * h)
    law = -top.mu * cyl.gn * cyl.nu_x**2
    assert np.max(np.abs(dE - law)) < 1e-6 * np.max(np.abs(law))


def test_frictionless_top_never_inverts(top):
    # μ = 0: the contact force is vertical, E is conserved and there is no inversion mechanism.
    tr = simulate(top.replace(mu=0.0), mett.State(theta=0.1, omega3=155.0), 9.0)
    assert tr.status == "completed"
    assert tr.theta.max() < 0.11
    assert tr.crossings(math.pi / 2).size == 0
    assert np.max(np.abs(tr.E / tr.E[0] - 1.0)) < 1e-9
    assert np.max(np.abs(tr.lam / tr.lam[0] - 1.0)) < 1e-9


# --- presets ---------------------------------------------------------------------------------


def _preset(name: str, **kw) -> mett.TippeTop:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mett.PhysicalityWarning)  # maple-tippe-top: I3 > m R²
        return mett.presets.get(name, **kw)


def _spin_for(top: mett.TippeTop, lam: float, theta0: float = 0.1) -> float:
    """ω3 with λ = R I3 ω3 (cos θ0 − α) at φ̇ = 0."""
    return lam / (top.R * top.I3 * (math.cos(theta0) - top.alpha))


@pytest.mark.parametrize(
    ("name", "kw"),
    [
        ("cohen1977", {}),
        ("ueda2005", {}),
        ("rutstam2012", {}),
        ("rutstam2013", {}),
        ("maple-tippe-top", {"alpha": 0.3}),
    ],
)
def test_presets_run(name, kw):
    top = _preset(name, **kw)
    s = mett.State(theta=0.1, omega3=_spin_for(top, 2.0 * top.lambda_thres))
    tr = simulate(top, s, 2.0)
    assert tr.status == "completed", tr.message
    assert np.max(np.abs(tr.lam / tr.lam[0] - 1.0)) < 1e-9
    assert np.all(np.diff(tr.E) <= 1e-12 * tr.E[0])
    z = np.cos(tr.theta)
    res = tr.E_mod - mett.g(top, z) * tr.thetadot**2 - mett.V(top, z, tr.D, tr.lam)
    assert np.max(np.abs(res)) < 1e-10 * tr.E_mod.max()


@pytest.mark.slow
@pytest.mark.parametrize(("name", "t_invert"), [("cohen1977", 6.662), ("rutstam2012", 5.810)])
def test_presets_invert_at_twice_the_threshold(name, t_invert):
    # Measured first θ = π/2 crossing (θ0 = 0.1, λ = 2 λ_thres, ν(0) = 0).
    top = _preset(name)
    s = mett.State(theta=0.1, omega3=_spin_for(top, 2.0 * top.lambda_thres))
    tr = simulate(top, s, 10.0)
    assert tr.status == "completed"
    assert tr.crossings(math.pi / 2)[0] == pytest.approx(t_invert, abs=2e-3)
    assert tr.theta[-1] > 3.0


def test_thrown_top_loses_contact_mid_run(top):
    # A violent flip (θ̇ = 80 rad/s at θ = 0.5) lifts the sphere off after ~0.02 s: g_n reaches 0
    # mid-run, the run ends there, and both forms locate the same instant.
    s = mett.State(theta=0.5, thetadot=80.0)
    vec = simulate(top, s, 1.0, stop_on_contact_loss=True)
    eul = simulate(top, s, 1.0, model="gliding-euler")
    assert vec.status == eul.status == "contact_lost"
    assert vec.gn[0] > 0.0 and abs(vec.gn[-1]) < 1e-9 * top.m * top.g
    assert vec.t[-1] == vec.t_contact_lost == pytest.approx(0.01967, abs=1e-5)
    assert eul.t_contact_lost == pytest.approx(vec.t_contact_lost, abs=1e-10)
    assert f"{vec.t_contact_lost:.9g}" in vec.message


@pytest.mark.slow
@pytest.mark.ci
def test_maple_tippe_top_with_alpha_0p5724_loses_contact():
    # maple-tippe-top (I3 > m R², which mett flags with a PhysicalityWarning), α = 0.5724, λ = 2 λ_thres,
    # θ0 = 0.1: the nutation grows until g_n reaches 0 (measured at t = 25.44 s, θ = 0.643).
    with pytest.warns(mett.PhysicalityWarning, match="exceeds m R"):
        top = mett.presets.get("maple-tippe-top", alpha=0.5724)
    s = mett.State(theta=0.1, omega3=_spin_for(top, 2.0 * top.lambda_thres))
    tr = simulate(top, s, 40.0, stop_on_contact_loss=True)
    assert tr.status == "contact_lost", tr.message
    assert 20.0 < tr.t_contact_lost < 30.0
    assert tr.t[-1] == tr.t_contact_lost
    assert "contact lost" in tr.message and f"{tr.t_contact_lost:.6g}"[:5] in tr.message
    assert abs(tr.gn[-1]) < 1e-9 * top.m * top.g
    assert np.all(tr.gn[:-1] > 0.0)
    assert np.all(np.isfinite(tr.theta))
