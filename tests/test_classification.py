"""Steady states, tumbling-state stability and the six classes of tops (mett.classification).

Independent references: the energy of explicit states (amended potential), a 40-digit mpmath
derivative of the tumbling family (fold indicator), the monotonicity of λ(θ_t) sampled on a grid
(classes), a central-difference linearisation of the Euler-angle form (eigenvalues) and simulations
started next to tumbling states (growth and decay rates).
"""

from __future__ import annotations

import math

import mpmath
import numpy as np
import pytest

import mett
from mett import classification as C
from mett import plotting
from mett import stability as S
from mett.dynamics.euler import euler_rhs
from mett.thresholds import tumbling_lambda

BASE = dict(m=0.02, R=0.02, alpha=0.3, I3=3.2e-6, mu=0.3)


def top_with(gamma: float, alpha: float = 0.3) -> mett.TippeTop:
    return mett.TippeTop(I1=gamma * 3.2e-6, **{**BASE, "alpha": alpha})


# one top per class at the diagram's sample points (the Ia/IIc wedges need a small α)
CLASS_TOPS = {name: top_with(g, alpha=a) for name, (a, g) in C.SAMPLE_POINTS.items()}


# --- amended potential ------------------------------------------------------------------------


def test_amended_potential_is_the_least_energy_at_fixed_lambda(rng):
    top = mett.presets.get("rutstam2013")
    for _ in range(200):
        s = mett.State(
            theta=rng.uniform(0.0, math.pi), thetadot=rng.normal(0, 5), phidot=rng.normal(0, 20),
            omega3=rng.normal(0, 150), nu_x=rng.normal(0, 0.3), nu_y=rng.normal(0, 0.3),
        )  # fmt: skip
        lam = float(mett.jellett(top, s))
        if lam <= 0:
            continue
        U = float(C.amended_potential(top, lam, s.theta))
        assert float(mett.energy(top, s)) >= U * (1 - 1e-13)


def test_amended_potential_ends_and_tumbling_states():
    top = mett.presets.get("rutstam2013")
    lam = 2.3e-6
    bv = mett.boundary_values(top, lam)
    U = C.amended_potential(top, lam, [0.0, math.pi])
    assert U[0] == pytest.approx(float(bv.E0), rel=1e-14)
    assert U[1] == pytest.approx(float(bv.E1), rel=1e-14)
    (st,) = C.tumbling_states(top, lam)
    # the tumbling state has exactly that energy (CM at rest, ω ∥ a) and is a critical point
    E = mett.energy(top, mett.State(theta=st.theta, phidot=st.phidot, omega3=st.omega3))
    assert float(C.amended_potential(top, lam, st.theta)) == pytest.approx(float(E), rel=1e-13)
    h = 1e-5
    dU = C.amended_potential(top, lam, st.theta + h) - C.amended_potential(top, lam, st.theta - h)
    assert abs(dU) / (2 * h) < 1e-8 * float(E)


# --- fold indicator and classes ---------------------------------------------------------------


def _dlam_dtheta_mp(alpha, gamma, theta):
    """dλ/dθ_t of the tumbling family at 40 digits (units m g R³ I3 = 1)."""
    mpmath.mp.dps = 40
    a, g = mpmath.mpf(alpha), mpmath.mpf(gamma)

    def lam(t):
        c, s = mpmath.cos(t), mpmath.sin(t)
        return mpmath.sqrt(a / (a - (1 - g) * c)) * (g * s**2 + (c - a) ** 2)

    return mpmath.diff(lam, mpmath.mpf(theta))


def test_fold_indicator_is_minus_the_slope_of_the_family(rng):
    n = 0
    while n < 300:
        alpha, gamma, theta = rng.uniform(0.01, 0.9), rng.uniform(0.5, 2.0), rng.uniform(0.01, 3.13)
        if alpha - (1 - gamma) * math.cos(theta) <= 0:
            continue
        slope = _dlam_dtheta_mp(alpha, gamma, theta)
        if abs(slope) < 1e-12:
            continue
        n += 1
        top = top_with(gamma, alpha)
        assert bool(C.tumbling_is_stable(top, theta)) == (slope > 0), (alpha, gamma, theta)


def _class_from_samples(alpha, gamma):
    top = top_with(gamma, alpha)
    lo, hi = C._domain(top)
    th = np.linspace(lo, hi, 20001)[1:-1]
    d = np.sign(np.diff(tumbling_lambda(top, th)))
    turns = np.count_nonzero(np.diff(d[d != 0]))
    assert turns <= 1
    if top.group == "I":
        return "Ia" if turns == 0 else "Ib"
    if top.group == "III":
        assert turns == 0 and d[0] > 0
        return "III"
    if turns:
        return "IIb"
    return "IIa" if d[0] > 0 else "IIc"


@pytest.mark.parametrize(
    ("alpha", "gamma"),
    [(0.3, g) for g in (0.55, 0.65, 0.69, 0.72, 0.75, 0.8, 0.83, 0.85, 0.9357, 1.0, 1.2, 1.29, 1.4)]
    + [(0.02, g) for g in (0.76, 0.8, 0.95, 0.979, 0.982, 0.99, 1.01)]
    + [(0.05, g) for g in (0.8, 0.9, 0.94, 0.96, 0.97, 0.99)]
    + [(0.6, g) for g in (0.5, 0.9, 1.5, 1.7)],
)
def test_classes_match_the_sampled_shape_of_the_family(alpha, gamma):
    assert C.subgroup(top_with(gamma, alpha)) == _class_from_samples(alpha, gamma)


def test_each_class_is_represented():
    for name, top in CLASS_TOPS.items():
        assert C.subgroup(top) == name == _class_from_samples(top.alpha, top.gamma)
        assert top.subgroup == name


@pytest.mark.parametrize(
    ("alpha", "gamma"),
    [(0.3, g) for g in (0.55, 0.69, 0.72, 0.75, 0.9357, 1.0, 1.29, 1.31, 1.6)]
    + [(0.02, g) for g in (0.8, 0.979, 0.982, 1.01, 1.03)]
    + [(0.45, 0.54), (0.45, 0.56)]
    + [(0.6, g) for g in (0.9, 1.59, 1.61)],
)
def test_groups_have_the_published_large_spin_behaviour(alpha, gamma):
    """The Roman numeral is the group of Ueda, Sasaki & Watanabe (2005, abstract), which Ciocci &
    Langerock (2007) refine into six: "Group I never flip over however large a spin they are
    given", "Group II show a complete inversion", "Group III tend to turn over up to a certain
    inclination angle θf such that θf < π, when they are spun sufficiently rapidly" (the
    nontipping, tipping and hanging tops of Ciocci et al. 2012, abstract). Checked on the stable
    steady states at large λ; the letters a, b, c are not covered by this test."""
    top = top_with(gamma, alpha)
    group = str(C.classify(alpha, gamma)).rstrip("abc")
    assert group == top.group
    finite = [x for x in (top.lambda_0, top.lambda_thres) if math.isfinite(x)]
    assert len(finite) == (2 if group == "II" else 1)
    gaps = []
    for factor in (3.0, 30.0, 1e3):
        states = C.stable_states(top, factor * max(finite))
        kinds = [s.kind for s in states]
        if group == "I":  # the upright spin stays stable: a top spun upright never flips
            assert "upright" in kinds
            assert "tumbling" not in kinds
        elif group == "II":  # the inverted spin is the only end state
            assert kinds == ["inverted"]
        else:  # one tumbling state, below θ_f = arccos(α/(1 − γ)) < π and tending to it
            theta_f = math.acos(alpha / (1.0 - gamma))
            assert kinds == ["tumbling"]
            assert 0.0 < states[0].theta < theta_f < math.pi
            gaps.append(theta_f - states[0].theta)
    if group == "III":
        assert gaps[0] > gaps[1] > gaps[2]
        assert gaps[2] < 0.01


def test_boundaries_separate_the_classes():
    alphas = np.array([0.01, 0.03, 0.06, 0.1, 0.3, 0.5])
    b = C.subgroup_boundaries(alphas)
    eps = 1e-7
    for i, a in enumerate(alphas):
        assert C.classify(a, b.IIa[i] + eps) == "IIa"
        assert C.classify(a, b.IIa[i] - eps) in ("IIb",)
        assert C.classify(a, b.group_III[i] + eps) == "III"
        assert C.classify(a, b.group_III[i] - eps) == "IIa"
        if a < C.ALPHA_WEDGE:
            assert C.classify(a, b.IIc[i] - eps) == "IIc"
            assert C.classify(a, b.IIc[i] + eps) == "IIb"
            assert C.classify(a, b.Ia[i] + eps) == "Ia"
            assert C.classify(a, b.Ia[i] - eps) == "Ib"
        else:
            assert np.isnan(b.IIc[i]) and np.isnan(b.Ia[i])
            assert C.classify(a, b.group_I[i] - eps) == "Ib"
            assert C.classify(a, b.group_I[i] + eps) == "IIb"
        # λ_0 = λ_thres on the last curve, and it lies inside IIb (or IIc for small α)
        top = top_with(b.spins_equal[i], a)
        assert top.lambda_0 == pytest.approx(top.lambda_thres, rel=1e-12)
        assert C.subgroup(top) in ("IIb", "IIc")


def test_classify_refuses_bad_input():
    with pytest.raises(ValueError, match="alpha must lie in"):
        C.classify(-0.2, 0.9)
    with pytest.raises(ValueError, match="gamma must lie in"):
        C.classify(0.3, -1.0)
    with pytest.raises(ValueError, match="alpha"):
        C.subgroup_boundaries(np.nan)


def test_presets_are_class_IIa():
    for name in mett.presets.names():
        if (
            name == "maple-tippe-top"
        ):  # no eccentricity in the source; I3 > m R² (PhysicalityWarning)
            with pytest.warns(mett.PhysicalityWarning):
                top = mett.presets.get(name, alpha=0.3)
        else:
            top = mett.presets.get(name)
        assert C.subgroup(top) == "IIa", name
        assert C.bistable_range(top) is None


# --- tumbling states with a given λ and the end states --------------------------------------


@pytest.mark.parametrize("name", list(CLASS_TOPS))
def test_tumbling_states_solve_the_family_and_are_all_found(name):
    top = CLASS_TOPS[name]
    lo, hi = C._domain(top)
    th = np.linspace(lo, hi, 4001)[1:-1]
    lam_curve = tumbling_lambda(top, th)
    finite = lam_curve[np.isfinite(lam_curve)]
    for lam in np.quantile(finite, [0.05, 0.3, 0.5, 0.7, 0.95]) * (1 + 1e-7):
        states = C.tumbling_states(top, float(lam))
        crossings = np.count_nonzero(np.diff(np.sign(lam_curve - lam)))
        assert len(states) == crossings
        for st in states:
            assert float(tumbling_lambda(top, st.theta)) == pytest.approx(lam, rel=1e-12)
            s = mett.State(theta=st.theta, phidot=st.phidot, omega3=st.omega3)
            assert float(mett.jellett(top, s)) == pytest.approx(lam, rel=1e-12)


def test_bistable_spins_at_gamma_072():
    top = top_with(0.72)
    assert top.lambda_0 > top.lambda_thres
    lam = math.sqrt(top.lambda_0 * top.lambda_thres)
    st = mett.asymptotic_state(top, lam)
    assert st.kind == "bistable" and math.isnan(st.theta) and math.isnan(st.omega3)
    assert [c.kind for c in st.candidates] == ["upright", "inverted"]
    assert st.candidates[1].omega3 == pytest.approx(-lam / (top.R * top.I3 * 1.3), rel=1e-14)
    lo, hi = C.bistable_range(top)
    assert lo == pytest.approx(C.fold_lambda(top)) and hi == top.lambda_0
    # below λ_thres the second candidate is the stable tumbling state on the fold's rising part
    st2 = mett.asymptotic_state(top, 0.5 * (lo + top.lambda_thres))
    assert [c.kind for c in st2.candidates] == ["upright", "tumbling"]
    assert C.tumbling_is_stable(top, st2.candidates[1].theta)


@pytest.mark.parametrize("gamma", [0.6, 0.72, 0.75, 0.8, 0.85, 0.9357, 1.0, 1.4])
def test_asymptotic_state_answers_for_every_lambda(gamma):
    top = top_with(gamma)
    ends = [x for x in (top.lambda_0, top.lambda_thres, C.fold_lambda(top)) if x and x < math.inf]
    scale = min(top.lambda_0, top.lambda_thres)
    lams = sorted(set(np.geomspace(0.05, 20, 120) * scale) | set(ends))
    for lam in lams:
        st = mett.asymptotic_state(top, float(lam))
        assert st.candidates, lam
        if st.kind == "bistable":
            assert len(st.candidates) == 2
            rng_ = C.bistable_range(top)
            assert rng_ is not None and rng_[0] < lam <= rng_[1] * (1 + 1e-15)
        else:
            assert st.candidates == (st._replace(candidates=()),)
            assert math.isfinite(st.theta) and math.isfinite(st.omega3)


def test_asymptotic_state_is_unchanged_for_class_IIa(thesis_top):
    t = thesis_top
    assert mett.asymptotic_state(t, t.lambda_thres).kind == "inverted"
    assert mett.asymptotic_state(t, t.lambda_0).kind == "upright"
    mid = mett.asymptotic_state(t, 2e-6)
    assert mid.kind == "tumbling"
    assert mid.theta == pytest.approx(mett.tumbling_state(t, 2e-6).theta, abs=1e-12)


# --- linear stability of tumbling states ------------------------------------------------------


def _euler_jacobian(top, theta):
    """Central-difference Jacobian of the Euler-angle form at the tumbling state (6 × 6)."""
    st = S._state_at(top, theta)
    y0 = np.array([theta, 0.0, st.phidot, st.omega3, 0.0, 0.0])
    p = (top.m, top.R, top.alpha, top.I1, top.I3, top.mu, top.g)
    assert np.abs(euler_rhs(y0, p)).max() < 1e-9 * st.phidot**2
    sc = [
        1.0,
        st.phidot,
        st.phidot,
        abs(st.omega3) + st.phidot,
        top.R * st.phidot,
        top.R * st.phidot,
    ]
    J = np.empty((6, 6))
    for k in range(6):
        e = np.zeros(6)
        e[k] = 1e-6 * sc[k]
        J[:, k] = (euler_rhs(y0 + e, p) - euler_rhs(y0 - e, p)) / (2 * e[k])
    return y0, J


@pytest.mark.parametrize("name", list(CLASS_TOPS))
@pytest.mark.parametrize("frac", [0.1, 0.35, 0.65, 0.9])
def test_tumbling_eigenvalues_match_the_euler_form(name, frac):
    top = CLASS_TOPS[name]
    lo, hi = C._domain(top)
    theta = lo + frac * (hi - lo)
    ev = S.tumbling_eigenvalues(top, theta)
    assert ev.shape == (5,)
    _, J = _euler_jacobian(top, theta)
    ref = np.linalg.eigvals(J)
    scale = np.abs(ref).max()
    ref = ref[np.argsort(np.abs(ref))][1:]  # drop the zero of the conserved λ
    for x in ev:
        assert np.min(np.abs(ref - x)) < 1e-5 * scale, (ev, ref)
    # the largest real part is real and its sign is the amended-potential criterion
    stable = bool(C.tumbling_is_stable(top, theta))
    assert (ev[0].real < 0) == stable


def test_tumbling_eigenvalue_crosses_zero_at_the_fold():
    top = CLASS_TOPS["IIb"]
    fold = C._fold_theta(top)
    assert S.tumbling_eigenvalues(top, fold - 1e-3)[0].real > 0  # falling part: unstable
    assert S.tumbling_eigenvalues(top, fold + 1e-3)[0].real < 0
    assert abs(S.tumbling_eigenvalues(top, fold)[0].real) < 1e-6 * abs(
        S.tumbling_eigenvalues(top, fold)[1]
    )


@pytest.mark.parametrize("theta", [0.0, math.pi, -0.1, math.nan])
def test_tumbling_eigenvalues_refuse_points_off_the_family(theta):
    with pytest.raises(ValueError, match="theta"):
        S.tumbling_eigenvalues(mett.presets.get("rutstam2013"), theta)


def test_tumbling_eigenvalues_refuse_beyond_theta_f():
    top = CLASS_TOPS["III"]
    with pytest.raises(ValueError, match="tumbling family's domain"):
        S.tumbling_eigenvalues(top, 3.0)


# --- against simulations ----------------------------------------------------------------------


def _measured_rate(top, theta, t_end):
    """Start next to the tumbling state along its slowest (or unstable) mode of the Euler form,
    simulate the vector form, and fit the rate of θ − θ_t(λ) (peaks for an oscillating mode)."""
    y0, J = _euler_jacobian(top, theta)
    ev, V = np.linalg.eig(J)
    nz = np.abs(ev) > 1e-6 * np.abs(ev).max()
    i = np.flatnonzero(nz)[np.argmax(ev.real[nz])]
    v = V[:, i] / V[np.argmax(np.abs(V[:, i])), i]
    eps = 1e-5 if ev[i].real > 0 else 1e-3
    y = y0 + eps * np.real(v)
    s = mett.State(theta=y[0], thetadot=y[1], phidot=y[2], omega3=y[3], nu_x=y[4], nu_y=y[5])
    lam = float(mett.jellett(top, s))
    (target,) = [x for x in C.tumbling_states(top, lam) if abs(x.theta - theta) < 0.05]
    traj = mett.simulate(top, s, t_end, t_eval=np.linspace(0.0, t_end, 4001))
    assert traj.status == "completed"
    d = traj.theta - target.theta
    if abs(ev[i].imag) < 1e-9 * abs(ev[i]):
        sel = (np.abs(d) > 1e-8) & (np.abs(d) < 1e-2)
        return np.polyfit(traj.t[sel], np.log(np.abs(d[sel])), 1)[0], 0.0
    a = np.abs(d)
    pk = np.flatnonzero((a[1:-1] >= a[:-2]) & (a[1:-1] >= a[2:])) + 1
    rate = np.polyfit(traj.t[pk], np.log(a[pk]), 1)[0]
    return rate, math.pi / np.mean(np.diff(traj.t[pk]))


@pytest.mark.slow
@pytest.mark.ci
@pytest.mark.parametrize(
    ("name", "theta", "t_end"),
    [("IIa", 1.0, 4.0), ("IIb", 1.0, 25.0), ("IIb", 2.2, 4.0), ("Ib", 2.8, 3.0), ("III", 0.6, 4.0)],
)
def test_tumbling_eigenvalues_against_simulation(name, theta, t_end):
    top = CLASS_TOPS[name]
    ev = S.tumbling_eigenvalues(top, theta)
    rate, freq = _measured_rate(top, theta, t_end)
    assert rate == pytest.approx(ev[0].real, rel=5e-3)
    assert freq == pytest.approx(abs(ev[0].imag), rel=5e-3, abs=1e-9)


@pytest.mark.slow
@pytest.mark.parametrize(
    ("gamma", "ratio", "theta0", "kind"),
    [
        # IIb with λ_0 > λ_thres: both spins stable between them; each start stays where it is
        (0.72, "mid", 0.1, "upright"),
        (0.72, "mid", math.pi - 0.1, "inverted"),
        # IIb with λ_0 < λ_thres, λ_min < λ < λ_0: upright, or the stable tumbling state
        (0.75, "fold", 0.1, "upright"),
        (0.75, "fold", math.pi - 0.1, "tumbling"),
        # Ib: the upright spin is always stable, a stable tumbling state near π below λ_thres
        (0.6, "fold", math.pi - 0.1, "tumbling"),
    ],
)
def test_bistable_candidates_are_reached_from_their_own_side(gamma, ratio, theta0, kind):
    top = top_with(gamma)
    if ratio == "mid":
        lam = math.sqrt(top.lambda_0 * top.lambda_thres)
    else:
        lam = 0.5 * (C.fold_lambda(top) + min(top.lambda_0, top.lambda_thres))
    pred = mett.asymptotic_state(top, lam)
    assert pred.kind == "bistable"
    (target,) = [c for c in pred.candidates if c.kind == kind]
    # φ̇0 = 0: λ = R I3 ω3 (cos θ0 − α) fixes the spin (negative when cos θ0 < α)
    omega3 = lam / (top.R * top.I3 * (math.cos(theta0) - top.alpha))
    traj = mett.simulate(top, mett.State(theta=theta0, omega3=omega3), t_end=30.0)
    assert traj.status == "completed"
    end = traj.at(30.0)
    assert abs(end.theta - target.theta) < 2e-3
    assert end.omega3 == pytest.approx(target.omega3, rel=2e-3)


# sample points of the (α, γ) diagram: (class, λ in units of min(λ_0, λ_thres), θ0, t_end, end kind)
SAMPLES = [
    ("Ia", 0.7, 0.1, 300.0, "upright"),
    ("Ia", 1.5, 0.1, 300.0, "upright"),
    ("Ia", 1.5, math.pi - 0.1, 300.0, "inverted"),
    ("Ib", 0.7, math.pi - 0.1, 30.0, "tumbling"),
    ("Ib", 1.5, math.pi - 0.1, 30.0, "inverted"),
    ("IIa", 1.5, 0.1, 30.0, "tumbling"),
    ("IIa", 3.0, 0.1, 30.0, "inverted"),
    ("IIb", 0.7, 0.1, 30.0, "upright"),
    ("IIb", 0.7, math.pi - 0.1, 200.0, "tumbling"),
    ("IIb", 1.5, 0.1, 100.0, "inverted"),
    ("IIc", 1.5, 0.1, 1500.0, "upright"),
    ("IIc", 1.5, math.pi - 0.1, 1500.0, "inverted"),
    ("III", 0.7, 0.1, 30.0, "upright"),
    ("III", 3.0, 0.1, 30.0, "tumbling"),
]


@pytest.mark.slow
@pytest.mark.parametrize(
    ("name", "ratio", "theta0", "t_end", "kind"),
    [pytest.param(*s, marks=[pytest.mark.ci] if s[0] == "IIb" else []) for s in SAMPLES],
)
def test_sample_points_end_in_a_predicted_state(name, ratio, theta0, t_end, kind):
    top = CLASS_TOPS[name]
    lam = ratio * min(top.lambda_0, top.lambda_thres)
    pred = mett.asymptotic_state(top, lam)
    (target,) = [c for c in pred.candidates if c.kind == kind]
    omega3 = lam / (top.R * top.I3 * (math.cos(theta0) - top.alpha))
    traj = mett.simulate(top, mett.State(theta=theta0, omega3=omega3), t_end=t_end)
    assert traj.status == "completed"
    end = traj.at(t_end)
    assert abs(end.theta - target.theta) < 2e-3
    assert end.omega3 == pytest.approx(target.omega3, rel=2e-3)
    assert traj.lam[-1] == pytest.approx(lam, rel=1e-7)


def test_subgroup_figure_colours_each_cell_by_its_class():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig = plotting.plot_subgroups(points={"thesis": (0.3, 0.9357)}, samples=[(0.3, 0.75)], n=40)
    try:
        ax = fig.axes[0]
        mesh = ax.collections[0]
        codes = np.asarray(mesh.get_array()).reshape(40, 40)
        edges_a, edges_g = np.linspace(0.0, 0.6, 41), np.linspace(0.45, 1.7, 41)
        a = 0.5 * (edges_a[1:] + edges_a[:-1])
        g = 0.5 * (edges_g[1:] + edges_g[:-1])
        for i, j in [(0, 5), (10, 20), (25, 30), (39, 39), (5, 1)]:
            assert C.SUBGROUPS[int(codes[i, j])] == C.classify(a[j], g[i])
    finally:
        plt.close(fig)


@pytest.mark.parametrize("name", list(CLASS_TOPS))
@pytest.mark.parametrize("lam", [1e-300, 1e-20, 1.0, 1e30, 1e300])
def test_extreme_lambdas_give_a_clean_answer(name, lam):
    import warnings

    top = CLASS_TOPS[name]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        st = mett.asymptotic_state(top, lam)
        U = C.amended_potential(top, lam, [0.0, 1.5, math.pi])
    assert st.candidates
    assert not np.any(np.isnan(U))
    if st.kind != "bistable":
        assert math.isfinite(st.theta) and not math.isnan(st.omega3)
    if name == "III" and lam >= 1.0:  # θ_t within rounding of θ_f; ω3 from λ, not from 1/0
        assert st.kind == "tumbling"
        assert st.theta == pytest.approx(math.acos(top.alpha / (1 - top.gamma)), abs=1e-9)
        s = mett.State(
            theta=st.theta, omega3=st.omega3, phidot=st.omega3 / (math.cos(st.theta) - top.alpha)
        )
        assert float(mett.jellett(top, s)) == pytest.approx(lam, rel=1e-9)


def test_tumbling_eigenvalues_refuse_the_immediate_neighbourhood_of_a_pole():
    with pytest.raises(ValueError, match="1e-8 rad from the poles"):
        S.tumbling_eigenvalues(mett.presets.get("rutstam2013"), 1e-12)


def test_tumbling_family_figure_draws_each_class():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig = plotting.plot_tumbling_families()
    try:
        titles = [a.get_title().split(":")[0] for a in fig.axes]
        assert titles == list(C.SUBGROUPS)
        # first panel's solid (stable) family line is all NaN for Ia: no stable tumbling state
        stable_line = fig.axes[0].lines[0]
        assert np.all(np.isnan(stable_line.get_ydata()))
        assert np.any(np.isfinite(fig.axes[2].lines[0].get_ydata()))  # IIa: all stable
    finally:
        plt.close(fig)


@pytest.mark.parametrize("name", list(CLASS_TOPS))
def test_spin_candidates_follow_the_spin_linearisation(name):
    # stable_states counts the upright spin for λ <= λ_0 and the inverted one for λ >= λ_thres:
    # the linearisation at the poles (mett.spin_eigenvalues) agrees in every class
    from mett.stability import spin_eigenvalues

    top = CLASS_TOPS[name]
    for pole, lam_x in (("upright", top.lambda_0), ("inverted", top.lambda_thres)):
        if math.isinf(lam_x):
            lam_probe = [0.3 * min(top.lambda_0, top.lambda_thres), 5 * max(top.lambda_0, 1e-9)]
            lam_probe = [x for x in lam_probe if math.isfinite(x)]
        else:
            lam_probe = [0.97 * lam_x, 1.03 * lam_x]
        for lam in lam_probe:
            kinds = [c.kind for c in C.stable_states(top, lam)]
            growth = spin_eigenvalues(top, lam, pole)[0].real
            assert (pole in kinds) == (growth < 0), (pole, lam, kinds, growth)
