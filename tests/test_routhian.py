"""The corrected Maple-paper frictionless Routhian model (issue 7) against the gliding model at μ = 0."""

from __future__ import annotations

import numpy as np
import pytest

import mett

TOP0 = mett.presets.get("rutstam2013", mu=0.0)


@pytest.mark.parametrize(
    "state",
    [
        mett.State(theta=1.0, omega3=100.0, phidot=3.0),
        mett.State(theta=0.5, omega3=155.0, nu_x=0.1, nu_y=-0.2),  # gliding start
        mett.State(theta=2.0, thetadot=1.5, omega3=-60.0),
    ],
)
def test_corrected_routhian_equals_gliding_at_zero_friction(state):
    times = np.linspace(0, 1.5, 31)
    a = mett.simulate(TOP0, state, 1.5, model="frictionless-routhian", t_eval=times, rtol=1e-12)
    b = mett.simulate(TOP0, state, 1.5, model="gliding", t_eval=times, rtol=1e-12)
    assert a.status == b.status == "completed"
    for name in ("theta", "thetadot", "phidot", "omega3", "nu_x", "nu_y", "gn", "E", "D", "lam"):
        x, y = getattr(a, name), getattr(b, name)
        scale = np.abs(y).max() + 1e-12
        assert np.abs(x - y).max() < 1e-8 * scale, name
    np.testing.assert_allclose(a.x, b.x, atol=1e-9)
    # frictionless: energy, spin and Jellett conserved
    assert np.ptp(a.E) < 1e-10 * a.E[0]
    assert np.ptp(a.omega3) == 0.0


def test_approximation_without_vertical_cm_term_differs_by_order_m_a2_over_I():
    state = mett.State(theta=1.0, omega3=30.0)
    full = mett.simulate(TOP0, state, 1.0, model="frictionless-routhian")
    approx = mett.simulate(TOP0, state, 1.0, model="frictionless-routhian", vertical_cm=False)
    assert approx.status == "completed"
    ta, tb = full.at(np.linspace(0, 1, 201)).theta, approx.at(np.linspace(0, 1, 201)).theta
    dev = np.abs(ta - tb).max()
    ratio = TOP0.m * (TOP0.R * TOP0.alpha) ** 2 / TOP0.I1  # m a²/I = 0.048 here
    assert 0.1 * ratio * np.ptp(ta) < dev < 10 * ratio * np.ptp(ta)


def test_no_friction_no_inversion():
    # docs/maple-tippe-top-errata.md: with θ̇0 = φ̇0 = 0 and no friction θ never exceeds θ0 (exact).
    with pytest.warns(mett.PhysicalityWarning):
        top = mett.presets.get("maple-tippe-top", alpha=0.3, mu=0.0)
    lam = 2 * top.lambda_thres
    w3 = lam / (top.R * top.I3 * (np.cos(0.1) - top.alpha))
    traj = mett.simulate(top, mett.State(theta=0.1, omega3=w3), 3.0, model="frictionless-routhian")
    assert traj.status == "completed"
    assert traj.theta.max() <= 0.1 + 1e-9


def test_vertical_cm_option_belongs_to_the_routhian_model():
    with pytest.raises(
        ValueError, match="vertical_cm applies only to model 'frictionless-routhian'"
    ):
        mett.simulate(TOP0, mett.State(theta=1.0), 1.0, vertical_cm=False)


def test_routhian_model_stops_at_the_pole_with_a_status():
    traj = mett.simulate(TOP0, mett.State(theta=0.3), 2.0, model="frictionless-routhian")
    assert traj.status == "failed" and "singular" in traj.message


def test_euler_form_stops_when_a_step_jumps_across_the_pole():
    # planar rocking through θ = 0: a step can jump over the tiny |sin θ| < 1e-6 window, so the
    # guard must be signed (regression test: the Euler form used to integrate on through the pole)
    traj = mett.simulate(TOP0, mett.State(theta=0.3), 2.0, model="gliding-euler")
    assert traj.status == "failed" and "singular" in traj.message
    assert np.all(traj.theta >= 0)


@pytest.mark.parametrize("model", ["gliding-euler", "frictionless-routhian"])
@pytest.mark.parametrize("theta", [1e-8, np.pi - 1e-8, np.pi])
def test_euler_angle_forms_refuse_a_start_inside_their_pole_guard(model, theta):
    traj = mett.simulate(TOP0, mett.State(theta=theta, thetadot=0.5, omega3=50.0), 0.3, model=model)
    assert traj.status == "failed" and "singular" in traj.message and traj.t[-1] == 0.0
