"""Predicted end states (asymptotic_state) against long simulations of the gliding top."""

from __future__ import annotations

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
