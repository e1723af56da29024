"""Tumbling family, asymptotic states, minimal spin (analytic side; simulations in test_endstates)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import mett
from mett.classification import asymptotic_state
from mett.thresholds import min_spin_for_inversion, tumbling_lambda, tumbling_state


def _euler_rhs_residual(top, th, phidot, omega3):
    """θ̈ and ν̇ of docs/theory/equations.md#euler-form at (θ, θ̇ = 0, φ̇, ω3, ν = 0): zero for a tumbling state."""
    s, c = math.sin(th), math.cos(th)
    m, R, a, I1, I3, g = top.m, top.R, top.alpha, top.I1, top.I3, top.g
    gn = (m * g * I1 + m * R * a * (c * I1 * phidot**2 * s * s - I3 * phidot * omega3 * s * s)) / (
        I1 + m * R**2 * a**2 * s * s
    )
    thdd = (s / I1) * (I1 * phidot**2 * c - I3 * omega3 * phidot - R * a * gn)
    nuxd = (R * s / I1) * (
        phidot * omega3 * (I3 * (1 - a * c) - I1)
        + gn * R * a * (1 - a * c)
        - I1 * a * phidot**2 * s * s
    )
    return thdd, nuxd, gn


@pytest.mark.parametrize("ratio", [1.05, 1.5, 2.0, 2.5])
def test_tumbling_state_is_an_equilibrium(thesis_top, ratio):
    lam = ratio * thesis_top.lambda_0
    st = tumbling_state(thesis_top, lam)
    assert 0 < st.theta < math.pi
    assert float(tumbling_lambda(thesis_top, st.theta)) == pytest.approx(lam, rel=1e-12)
    thdd, nuxd, gn = _euler_rhs_residual(thesis_top, st.theta, st.phidot, st.omega3)
    assert abs(thdd) < 1e-10 * st.phidot**2 and abs(nuxd) < 1e-12 * thesis_top.R * st.phidot**2
    assert gn == pytest.approx(thesis_top.m * thesis_top.g, rel=1e-12)  # CM at rest
    # and its Jellett integral, computed from the state, is λ
    s = mett.State(theta=st.theta, phidot=st.phidot, omega3=st.omega3)
    assert mett.jellett(thesis_top, s) == pytest.approx(lam, rel=1e-12)


def test_tumbling_family_spans_lambda0_to_lambda_thres(thesis_top):
    th = np.linspace(1e-6, math.pi - 1e-6, 500)
    lam = tumbling_lambda(thesis_top, th)
    assert np.all(np.diff(lam) > 0)
    assert lam[0] == pytest.approx(thesis_top.lambda_0, rel=1e-9)
    assert lam[-1] == pytest.approx(thesis_top.lambda_thres, rel=1e-9)
    assert tumbling_state(thesis_top, 0.99 * thesis_top.lambda_0) is None
    assert tumbling_state(thesis_top, 1.01 * thesis_top.lambda_thres) is None


def test_group_three_tumbles_below_theta_f():
    top = mett.TippeTop(m=0.02, R=0.02, alpha=0.3, I1=1.4 * 3.2e-6, I3=3.2e-6)
    theta_f = math.acos(top.alpha / (1 - top.gamma))
    for ratio in (1.5, 5, 50):
        st = asymptotic_state(top, ratio * top.lambda_0)
        assert st.kind == "tumbling" and 0 < st.theta < theta_f
    assert asymptotic_state(top, 0.5 * top.lambda_0).kind == "upright"


def test_asymptotic_state_regimes(thesis_top):
    t = thesis_top
    up = asymptotic_state(t, 0.5 * t.lambda_0)
    assert up.kind == "upright" and up.theta == 0
    assert up.omega3 == pytest.approx(0.5 * t.lambda_0 / (t.R * t.I3 * (1 - t.alpha)))
    mid = asymptotic_state(t, 0.5 * (t.lambda_0 + t.lambda_thres))
    assert mid.kind == "tumbling" and 0 < mid.theta < math.pi
    inv = asymptotic_state(t, 2.005 * t.lambda_thres)
    assert inv.kind == "inverted" and inv.theta == math.pi
    lam = mett.jellett(t, mett.State(theta=0.1, omega3=155.0))
    assert asymptotic_state(t, lam).omega3 == pytest.approx(-82.866, abs=1e-3)


def test_group_one_never_inverts():
    top = mett.TippeTop(m=0.02, R=0.02, alpha=0.3, I1=0.6 * 3.2e-6, I3=3.2e-6)
    # the upright spin is stable for every λ; above λ_thres the inverted one is stable too, so
    # the end state depends on the start (a top started near θ = 0 stays upright)
    st = asymptotic_state(top, 100 * top.lambda_thres)
    assert st.kind == "bistable"
    assert [c.kind for c in st.candidates] == ["upright", "inverted"]
    assert asymptotic_state(top, 0.5 * top.lambda_thres).kind == "upright"
    assert min_spin_for_inversion(top, 0.1) == math.inf


def test_min_spin_for_inversion(thesis_top):
    w = min_spin_for_inversion(thesis_top, 0.1)
    assert w == pytest.approx(77.3, abs=0.05)
    lam_at = mett.jellett(thesis_top, mett.State(theta=0.1, omega3=w))
    assert lam_at == pytest.approx(thesis_top.lambda_thres, rel=1e-12)
    # a precession in the spin's sense lowers the spin needed
    assert min_spin_for_inversion(thesis_top, 0.5, phidot0=5.0) < min_spin_for_inversion(
        thesis_top, 0.5
    )
    with pytest.raises(ValueError, match=r"theta0 must lie in \[0, arccos\(alpha\)\)"):
        min_spin_for_inversion(thesis_top, 1.4)


@pytest.mark.parametrize("lam", [0.0, -1e-6, math.inf])
def test_end_state_needs_positive_jellett(thesis_top, lam):
    with pytest.raises(ValueError, match="lam must"):
        asymptotic_state(thesis_top, lam)
    with pytest.raises(ValueError, match="lam must"):
        tumbling_state(thesis_top, lam)


@pytest.mark.parametrize("gamma", [0.75, 0.85])
def test_asymptotic_state_at_lambda_thres_of_a_folded_family(thesis_top, gamma):
    # regression: the sweeps example asked for γ = 0.75, 0.85 at λ = λ_thres and got a RuntimeError
    top = thesis_top.replace(I1=gamma * thesis_top.I3)
    st = asymptotic_state(top, top.lambda_thres)
    assert st.kind == "inverted" and st.theta == math.pi
    assert st.omega3 == pytest.approx(-top.lambda_thres / (top.R * top.I3 * (1 + top.alpha)))
