"""Predicted end states (asymptotic_state) against long simulations of the gliding top."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import mett

THESIS = mett.presets.get("rutstam2013")
GROUP3 = mett.TippeTop(m=0.02, R=0.02, alpha=0.3, I1=1.4 * 3.2e-6, I3=3.2e-6, mu=0.3)


@pytest.mark.parametrize(
    ("top", "ratio_of", "ratio", "kind"),
    [
        pytest.param(THESIS, "lambda_0", 0.8, "upright", id="below-lambda0-upright"),
        pytest.param(THESIS, "mid", None, "tumbling", id="between-tumbling"),
        pytest.param(THESIS, "lambda_thres", 2.0, "inverted", id="above-thres-inverted"),
        pytest.param(GROUP3, "lambda_0", 3.0, "tumbling", id="group3-tumbling"),
    ],
)
def test_simulation_ends_in_the_predicted_state(top, ratio_of, ratio, kind):
    if ratio_of == "mid":
        lam = 0.5 * (top.lambda_0 + top.lambda_thres)
    else:
        lam = ratio * getattr(top, ratio_of)
    theta0 = 0.1
    omega3 = lam / (
        top.R * top.I3 * (np.cos(theta0) - top.alpha)
    )  # φ̇0 = 0: λ = R I3 ω3 (cos θ0 − α)
    pred = mett.asymptotic_state(top, lam)
    assert pred.kind == kind
    traj = mett.simulate(top, mett.State(theta=theta0, omega3=omega3), t_end=25.0)
    assert traj.status == "completed"
    end = traj.at(25.0)
    assert abs(end.theta - pred.theta) < 1e-3
    assert end.omega3 == pytest.approx(pred.omega3, rel=1e-3, abs=1e-3)
    assert abs(end.thetadot) < 1e-2 and np.hypot(end.nu_x, end.nu_y) < 1e-4  # settled, rolling
    assert traj.lam[-1] == pytest.approx(lam, rel=1e-8)


def test_thesis_run_ends_inverted_with_the_jellett_spin(thesis_trajectory):
    traj = thesis_trajectory
    pred = mett.asymptotic_state(traj.top, float(traj.lam[0]))
    assert pred.kind == "inverted"
    # not "about −85" (docs/theory/notes.md#notes)
    assert pred.omega3 == pytest.approx(-82.866, abs=1e-3)
    assert traj.omega3[-1] == pytest.approx(pred.omega3, rel=1e-4)


def _tops_for_threshold_ulps() -> dict[str, mett.TippeTop]:
    """Every preset (maple-tippe-top with α = 0.3, its source gives none) and one top per class."""
    from mett.classification import SAMPLE_POINTS

    tops = {}
    for name in mett.presets.names():
        extra = {"alpha": 0.3} if name == "maple-tippe-top" else {}
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", mett.PhysicalityWarning)  # maple's I3 > m R²
            tops[name] = mett.presets.get(name, **extra)
    for cls, (alpha, gamma) in SAMPLE_POINTS.items():
        tops[cls] = mett.TippeTop(m=0.02, R=0.02, alpha=alpha, I1=gamma * 3.2e-6, I3=3.2e-6)
    return tops


def _ulps(x: float, k: int) -> float:
    for _ in range(abs(k)):
        x = float(np.nextafter(x, np.inf if k > 0 else -np.inf))
    return x


@pytest.mark.parametrize(("name", "top"), list(_tops_for_threshold_ulps().items()))
@pytest.mark.parametrize("threshold", ["lambda_thres", "lambda_0"])
def test_the_end_state_next_to_a_threshold_is_the_limit_of_its_branch(name, top, threshold):
    """±1, ±2 ulps of λ_thres and λ_0: "bistable" only with two candidates, never none.

    Reference: the stable states at λ (1 ± 1e-8), on the same side but outside the rounding
    band: the stable branches are continuous in λ, and a tumbling branch that ends at a pole
    with λ(θ_t) ≈ λ_pole − c (θ_t − θ_pole)² is within √(1e-8) ~ 1e-4 rad of it there, so every
    candidate at the ulps lies within 1e-3 rad of one there, and their number is the same.
    """
    L = getattr(top, threshold)
    if not np.isfinite(L):
        pytest.skip(f"{threshold} is infinite for class {mett.classification.subgroup(top)}")
    for k in (-2, -1, 1, 2):
        st = mett.asymptotic_state(top, _ulps(L, k))
        assert len(st.candidates) in (1, 2), (k, st)
        assert (st.kind == "bistable") == (len(st.candidates) == 2), (k, st)
        if st.kind != "bistable":
            only = st.candidates[0]
            assert (only.kind, only.theta) == (st.kind, st.theta) and np.isfinite(st.theta)
        ref = mett.asymptotic_state(top, L * (1.0 + np.sign(k) * 1e-8))
        assert len(ref.candidates) == len(st.candidates), (k, st, ref)
        for got, want in zip(st.candidates, ref.candidates, strict=True):
            assert abs(got.theta - want.theta) < 1e-3, (k, got, want)
