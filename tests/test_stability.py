"""Spin stability of the gliding model (docs/theory/thresholds.md#thresholds) and the linear escape-time prediction."""

from __future__ import annotations

import numpy as np
import pytest

import mett
from mett.dynamics.gliding import gliding_rhs
from mett.stability import escape_time, spin_eigenvalues, spin_jacobian

ADMISSIBLE = ["rutstam2013", "rutstam2012", "cohen1977", "ueda2005"]


def _max_real(top, lam, pole):
    return spin_eigenvalues(top, lam, pole)[0].real


@pytest.mark.parametrize("name", ADMISSIBLE)
def test_inverted_spin_stable_above_lambda_thres(name):
    top = mett.presets.get(name)
    assert _max_real(top, 0.99 * top.lambda_thres, "inverted") > 0
    assert _max_real(top, 1.01 * top.lambda_thres, "inverted") < 0
    assert _max_real(top, 3.0 * top.lambda_thres, "inverted") < 0


@pytest.mark.parametrize("name", ADMISSIBLE)
def test_upright_spin_unstable_above_lambda_0(name):
    top = mett.presets.get(name)
    assert _max_real(top, 0.99 * top.lambda_0, "upright") < 0
    assert _max_real(top, 1.01 * top.lambda_0, "upright") > 0
    assert _max_real(top, 3.0 * top.lambda_0, "upright") > 0


def test_outside_the_admissible_range():
    # docs/theory/thresholds.md#thresholds: γ = 0.6 < 1 − α keeps the upright spin stable, γ = 1.4 > 1 + α never
    # stabilises the inverted one, for every λ tested.
    base = dict(m=0.02, R=0.02, alpha=0.3, I3=3.2e-6, mu=0.3)
    group1 = mett.TippeTop(I1=0.6 * 3.2e-6, **base)
    group3 = mett.TippeTop(I1=1.4 * 3.2e-6, **base)
    for lam in np.geomspace(1e-6, 3e-5, 8):
        assert _max_real(group1, lam, "upright") < 0
        assert _max_real(group3, lam, "inverted") > 0


def test_jacobian_decouples_and_matches_finite_differences(thesis_top):
    lam = 2.0 * thesis_top.lambda_thres
    J = spin_jacobian(thesis_top, lam, "inverted")
    full = np.linalg.eigvals(J)
    block = spin_eigenvalues(thesis_top, lam, "inverted")
    # the four neutral directions (x, y, L_z, 3̂_z) and the six horizontal ones
    assert np.sum(np.abs(full) < 1e-9 * np.abs(block).max()) == 4
    for ev in block:
        assert np.min(np.abs(full - ev)) < 1e-9 * np.abs(block).max()
    # independent check of the complex-step Jacobian: central differences
    p = (thesis_top.m, thesis_top.R, thesis_top.R * thesis_top.alpha, thesis_top.I1,
         thesis_top.I3, thesis_top.mu, thesis_top.g)  # fmt: skip
    y0 = np.zeros(10)
    omega3 = -lam / (thesis_top.R * thesis_top.I3 * 1.3)
    y0[6], y0[9] = -thesis_top.I3 * omega3, -1.0
    for k in range(10):
        h = 1e-7 * max(abs(y0[k]), 1e-2 if k in (0, 1, 2, 3) else 1.0)
        if k in (4, 5, 6):
            h = 1e-6 * abs(y0[6])
        e = np.zeros(10)
        e[k] = h
        fd = (gliding_rhs(0, y0 + e, p) - gliding_rhs(0, y0 - e, p)) / (2 * h)
        np.testing.assert_allclose(J[:, k], fd, rtol=1e-5, atol=1e-6 * np.abs(J).max())


@pytest.mark.parametrize(
    ("lam", "pole"), [(0.0, "inverted"), (-1e-6, "upright"), (np.nan, "upright")]
)
def test_stability_needs_positive_lambda(thesis_top, lam, pole):
    with pytest.raises(ValueError, match="lam must"):
        spin_eigenvalues(thesis_top, lam, pole)


def test_unknown_pole_is_refused(thesis_top):
    with pytest.raises(
        ValueError, match=r"pole must be one of \('upright', 'inverted'\); got 'top'"
    ):
        spin_eigenvalues(thesis_top, 1e-5, "top")


# Measured (rutstam2013, θ0 = 0.1, ν(0) = 0): predicted / simulated time of the first θ = π/2:
#   μ = 0.1: ω3 = 120 −0.5 %, 155 +4.3 %;   μ = 0.3: 120 −0.9 %, 155 +2.6 %;   μ = 1: 120 −2.3 %.
# (ω3 = 250 at μ = 0.1 and 0.3, and ω3 >= 155 at μ = 1, lose contact before inverting.)
ESCAPES = [
    pytest.param(0.3, 120.0, id="mu0.3-w120"),
    pytest.param(0.3, 155.0, id="mu0.3-w155"),
    pytest.param(1.0, 120.0, id="mu1-w120"),
    pytest.param(0.1, 120.0, id="mu0.1-w120", marks=pytest.mark.slow),
    pytest.param(0.1, 155.0, id="mu0.1-w155", marks=pytest.mark.slow),
]


@pytest.mark.parametrize(("mu", "omega3"), ESCAPES)
def test_escape_time_prediction_against_simulation(thesis_top, mu, omega3):
    top = thesis_top.replace(mu=mu)
    state = mett.State(theta=0.1, omega3=omega3)
    est = escape_time(top, state)
    traj = mett.simulate(top, state, t_end=1.5 * est.time)
    t_sim = traj.crossings(np.pi / 2)[0]
    assert abs(est.time / t_sim - 1) < 0.05
    assert est.growth_rate == pytest.approx(_max_real(top, mett.jellett(top, state), "upright"))


def test_no_escape_predicted_for_a_stable_upright_spin(thesis_top):
    slow = mett.State(theta=0.1, omega3=0.5 * mett.min_spin_for_inversion(thesis_top, 0.1) * 0.3)
    with pytest.raises(ValueError, match="upright spin is stable"):
        escape_time(thesis_top, slow)


@pytest.mark.parametrize(
    ("state", "message"),
    [
        (mett.State(theta=0.0, omega3=155.0), "no component in the unstable modes"),
        (mett.State(theta=2.0, omega3=-155.0), "not near the upright spin"),
    ],
)
def test_escape_time_refuses_states_outside_the_linear_regime(thesis_top, state, message):
    with pytest.raises(ValueError, match=message):
        escape_time(thesis_top, state)
