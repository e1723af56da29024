"""TippeTop: validation, derived parameters, thresholds, groups, the rational constructor."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from conftest import random_top

import mett
from mett.thresholds import lambda_E, lambda_roll


def test_thesis_top_is_the_rational_case(thesis_top):
    # docs/theory/mett.md#rational: I3 = 2/5 m R² gives σ = 5/2 and γ = 1 − 2.5·0.09/3.5 = 131/140.
    assert thesis_top.gamma == pytest.approx(131 / 140, rel=1e-14)
    assert thesis_top.sigma == pytest.approx(2.5, rel=1e-14)
    assert thesis_top.is_rational
    assert thesis_top.is_admissible
    assert thesis_top.group == "II"
    assert thesis_top.beta == pytest.approx(6.236096, abs=1e-6)


def test_thesis_thresholds_closed_form(thesis_top):
    t = thesis_top
    scale = math.sqrt(t.m * t.g * t.R**3 * t.I3 * t.alpha)
    assert t.lambda_thres == pytest.approx(scale * 1.3**2 / math.sqrt(1.3 - 131 / 140), rel=1e-14)
    assert t.lambda_0 == pytest.approx(scale * 0.7**2 / math.sqrt(0.3 + 131 / 140 - 1), rel=1e-14)
    # docs/theory/references.md#other-sources: minimal spin for inversion from θ0 = 0.1 is 77.3 rad/s.
    n_c = t.lambda_thres / (t.R * t.I3 * (math.cos(0.1) - t.alpha))
    assert n_c == pytest.approx(77.3, abs=0.05)


def test_thesis_start_is_twice_the_threshold(thesis_top):
    lam = mett.jellett(thesis_top, mett.State(theta=0.1, omega3=155.0))
    assert lam / thesis_top.lambda_thres == pytest.approx(2.005, abs=5e-4)


def _tumbling_lambda(top, theta_t):
    """λ on the tumbling family (docs/theory/thresholds.md#thresholds), an independent route to the thresholds."""
    c = math.cos(theta_t)
    phidot = math.sqrt(
        top.m * top.g * top.R * top.alpha / (top.I3 * (top.alpha - (1 - top.gamma) * c))
    )
    return top.R * phidot * (top.I1 * math.sin(theta_t) ** 2 + top.I3 * (c - top.alpha) ** 2)


@pytest.mark.parametrize("seed", range(5))
def test_thresholds_are_the_ends_of_the_tumbling_family(seed):
    rng = np.random.default_rng(seed)
    for _ in range(20):
        top = random_top(rng)
        if top.is_admissible:
            break
    assert top.is_admissible
    assert _tumbling_lambda(top, math.pi) == pytest.approx(top.lambda_thres, rel=1e-12)
    assert _tumbling_lambda(top, 0.0) == pytest.approx(top.lambda_0, rel=1e-12)


def test_thresholds_infinite_outside_their_groups():
    base = dict(m=0.02, R=0.02, alpha=0.3, I3=3.2e-6, mu=0.3)
    group1 = mett.TippeTop(I1=0.6 * 3.2e-6, **base)
    group3 = mett.TippeTop(I1=1.4 * 3.2e-6, **base)
    assert group1.group == "I" and math.isinf(group1.lambda_0)
    assert math.isfinite(group1.lambda_thres)
    assert group3.group == "III" and math.isinf(group3.lambda_thres)
    assert math.isfinite(group3.lambda_0)
    assert not group1.is_admissible and not group3.is_admissible


def test_lambda_roll_never_exceeds_lambda_thres(rng):
    # docs/theory/thresholds.md#thresholds: AM–GM gives λ_roll ≤ λ_thres (friction destabilises the inverted spin).
    for _ in range(200):
        top = random_top(rng)
        if math.isfinite(top.lambda_thres):
            assert lambda_roll(top) <= top.lambda_thres * (1 + 1e-12)


def test_lambda_E_separates_energies_of_the_spins(thesis_top):
    for factor, sign in ((0.9, 1), (1.1, -1)):
        bv = mett.boundary_values(thesis_top, factor * lambda_E(thesis_top))
        assert np.sign(bv.E0 - bv.E1) == -sign


def test_boundary_values_thesis(thesis_top):
    # docs/theory/notes.md#notes: RR14-style boundary values for the thesis start.
    lam = mett.jellett(thesis_top, mett.State(theta=0.1, omega3=155.0))
    bv = mett.boundary_values(thesis_top, lam)
    assert bv.D0 == pytest.approx(7.2389e-4, rel=2e-5)
    assert bv.E0 == pytest.approx(4.0643e-2, rel=2e-5)
    assert bv.omega3_1 == pytest.approx(-82.866, abs=1e-3)
    # They are the integrals of the vertical spins.
    up = mett.State(theta=0.0, omega3=bv.omega3_0)
    down = mett.State(theta=math.pi, omega3=bv.omega3_1)
    assert mett.jellett(thesis_top, up) == pytest.approx(lam, rel=1e-13)
    assert mett.jellett(thesis_top, down) == pytest.approx(lam, rel=1e-13)
    assert mett.routh(thesis_top, up) == pytest.approx(bv.D0, rel=1e-13)
    assert mett.routh(thesis_top, down) == pytest.approx(bv.D1, rel=1e-13)
    assert mett.energy(thesis_top, up) == pytest.approx(bv.E0, rel=1e-13)
    assert mett.energy(thesis_top, down) == pytest.approx(bv.E1, rel=1e-13)


@pytest.mark.parametrize(
    ("gamma", "group"),
    [(0.6, "I"), (0.7, "I"), (0.71, "II"), (1.0, "II"), (1.29, "II"), (1.3, "III")],
)
def test_groups_follow_gamma(gamma, group):
    top = mett.TippeTop(m=0.02, R=0.02, alpha=0.3, I1=gamma * 3.2e-6, I3=3.2e-6)
    assert top.group == group


def test_rational_constructor_gives_rational_tops(rng):
    for _ in range(50):
        m, R = rng.uniform(0.005, 0.05), rng.uniform(0.01, 0.04)
        top = mett.TippeTop.rational(
            m=m, R=R, alpha=rng.uniform(0.05, 0.6), I3=rng.uniform(0.3, 0.8) * m * R**2
        )
        assert top.is_rational
        assert 1 - top.alpha**2 < top.gamma < 1
        z = np.linspace(-1, 1, 11)
        # √d(z) = β(α − (1 − γ) z): d is a perfect square (docs/theory/mett.md#rational).
        np.testing.assert_allclose(
            np.sqrt(mett.d(top, z)), top.beta * (top.alpha - (1 - top.gamma) * z), rtol=1e-13
        )


def test_rational_constructor_refuses_impossible_inertia():
    # σ = 2.5, α = 0.95 would need γ = 1 − 2.5·0.9025/3.5 < 1/2, i.e. I3 > 2 I1.
    with pytest.raises(ValueError, match=r"gamma = .* must lie in \[0.5, 1\)"):
        mett.TippeTop.rational(m=0.02, R=0.02, alpha=0.95, I3=0.4 * 0.02 * 0.02**2)


def test_non_rational_top_has_no_beta():
    top = mett.presets.get("rutstam2012")
    assert not top.is_rational
    with pytest.raises(ValueError, match="rational"):
        top.beta


def test_replace_validates_and_rejects_unknown_fields(thesis_top):
    assert thesis_top.replace(mu=0.1).mu == 0.1
    assert thesis_top.replace(mu=0.1).I1 == thesis_top.I1
    with pytest.raises(ValueError, match="unknown TippeTop field"):
        thesis_top.replace(nu=1.0)
    with pytest.raises(ValueError, match="alpha"):
        thesis_top.replace(alpha=1.2)


def test_top_is_frozen(thesis_top):
    with pytest.raises(AttributeError):
        thesis_top.m = 1.0


GOOD = dict(m=0.02, R=0.02, alpha=0.3, I1=3.0e-6, I3=3.2e-6, mu=0.3, g=9.82)


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [
        ("m", 0.0, r"m must lie in \[1e-50, 1e\+50\]"),
        ("m", -1.0, r"m must lie in \[1e-50, 1e\+50\]"),
        ("R", 0.0, r"R must lie in \[1e-50, 1e\+50\]"),
        ("I1", -3e-6, r"I1 must lie in \[1e-50, 1e\+50\]"),
        ("I3", 0.0, r"I3 must lie in \[1e-50, 1e\+50\]"),
        ("alpha", 0.0, r"alpha must lie in \(0, 1\)"),
        ("alpha", 1.0, r"alpha must lie in \(0, 1\)"),
        ("alpha", 1.5, r"alpha must lie in \(0, 1\); got 1.5"),
        ("I3", 6.1e-6, r"I3 must lie in \(0, 2\*I1\]"),
        ("mu", -0.1, r"mu must lie in \[0, 1e\+50\]"),
        ("g", 0.0, r"g must lie in \[1e-50, 1e\+50\]"),
        ("m", math.nan, "m must be finite"),
        ("R", math.inf, "R must be finite"),
        ("alpha", math.nan, "alpha must be finite"),
        ("R", 1e300, r"R must lie in \[1e-50, 1e\+50\] m; got 1e\+300"),
        ("m", 1e-60, r"m must lie in \[1e-50, 1e\+50\] kg"),
    ],
)
def test_nonphysical_parameters_raise(field, value, message):
    with pytest.raises(ValueError, match=message):
        mett.TippeTop(**{**GOOD, field: value})


def test_spin_inertia_above_m_R2_warns():
    with pytest.warns(mett.PhysicalityWarning, match="exceeds m R"):
        mett.TippeTop(**{**GOOD, "I1": 9e-6, "I3": 9e-6})
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        mett.TippeTop(**GOOD)  # no warning for a physical top
