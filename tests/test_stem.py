"""Stem geometry (touchdown angle, contact sphere) and the METT analysis of the stem phase."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import optimize

import mett
from mett.dynamics._model import lab_vectors
from mett.stability import spin_eigenvalues
from mett.stem import StemContactTop, StemmedTop

# Leine–Glocker-like body (two spheres; illustrative values of that size): ball R = 15 mm, CM 3 mm
# below its centre, stem sphere r_s = 5 mm whose centre is 16 mm from the CM.
LG_BALL = mett.TippeTop(m=6.6e-3, R=0.015, alpha=0.2, I1=8e-7, I3=7e-7, mu=0.3)
LG = LG_BALL.with_stem(radius=0.005, distance=0.013)


def _touchdown_by_geometry(top: StemmedTop) -> float:
    """θ where the stem sphere's lowest point reaches the plane, the ball touching it (lab frame)."""
    R, rs, ls = top.ball.R, top.radius, top.distance

    def clearance(th):
        e3 = lab_vectors(mett.State(theta=th), R, top.ball.alpha * R)["e3"]
        centre = (
            np.array([0.0, 0.0, R]) + ls * e3
        )  # ball centre at height R, stem centre on the axis
        return centre[2] - rs

    return optimize.brentq(clearance, 1e-9, math.pi, xtol=1e-15, rtol=4 * np.finfo(float).eps)


@pytest.mark.parametrize(
    ("R", "rs", "ls"),
    [(0.015, 0.005, 0.013), (0.02, 0.005, 0.02), (0.02, 0.004, 0.0165), (0.01, 0.009, 0.012)],
)
def test_touchdown_angle_matches_the_geometry(R, rs, ls):
    top = mett.presets.get("rutstam2013", R=R).with_stem(radius=rs, distance=ls)
    assert abs(top.touchdown_angle - _touchdown_by_geometry(top)) < 1e-9
    assert top.touchdown_angle == pytest.approx(math.acos((rs - R) / ls), abs=1e-15)
    th = top.touchdown_angle
    assert top.contact(th - 1e-6) == "ball" and top.contact(th + 1e-6) == "stem"
    assert list(top.contact([0.0, math.pi])) == ["ball", "stem"]
    assert float(top.stem_clearance(0.0)) == pytest.approx(R + ls - rs)


def test_stem_top_is_the_stem_sphere_with_the_cm_offset():
    s = LG.stem_top
    assert isinstance(s, StemContactTop) and isinstance(s, mett.TippeTop)
    assert s.R == LG.radius
    assert s.alpha * s.R == pytest.approx(LG_BALL.alpha * LG_BALL.R + LG.distance, rel=1e-15)
    assert s.alpha > 1  # the CM lies outside the stem sphere
    assert (s.m, s.I1, s.I3, s.mu, s.g) == (
        LG_BALL.m,
        LG_BALL.I1,
        LG_BALL.I3,
        LG_BALL.mu,
        LG_BALL.g,
    )
    assert s.replace(mu=0.1).alpha == s.alpha  # replace keeps the relaxed validation


def test_stem_jellett_is_minus_L_dot_a_stem(rng):
    b = LG_BALL
    lp = b.alpha * b.R + LG.distance
    for _ in range(50):
        st = mett.State(
            theta=rng.uniform(0, math.pi), thetadot=rng.normal(0, 5), phidot=rng.normal(0, 20),
            omega3=rng.normal(0, 150),
        )  # fmt: skip
        v = lab_vectors(st, b.R, b.alpha * b.R)
        e, w = v["e3"], v["omega"]
        L = b.I1 * w + (b.I3 - b.I1) * np.dot(w, e) * e
        a_s = lp * e - np.array([0.0, 0.0, LG.radius])  # CM → stem contact point
        assert float(LG.stem_jellett(st)) == pytest.approx(-np.dot(L, a_s), rel=1e-12, abs=1e-18)


def test_stem_thresholds_agree_with_the_linearisation():
    s = LG.stem_top
    assert s.subgroup == "IIa"
    for pole, lam_x, below, above in (
        ("inverted", s.lambda_thres, 1, -1),
        ("upright", s.lambda_0, -1, 1),
    ):
        assert np.sign(spin_eigenvalues(s, 0.99 * lam_x, pole)[0].real) == below
        assert np.sign(spin_eigenvalues(s, 1.01 * lam_x, pole)[0].real) == above


def _stem_start(ratio: float, dtheta: float = 0.15):
    """A start on the stem, θ0 = θ_touch + dtheta, φ̇ = 0, with λ_s = ratio · λ_thres of the stem."""
    s = LG.stem_top
    th0 = LG.touchdown_angle + dtheta
    # λ_s = r_s L·ẑ − l' I3 ω3 with L·ẑ = I3 ω3 cos θ at φ̇ = 0
    omega3 = ratio * s.lambda_thres / (s.I3 * (s.R * math.cos(th0) - s.alpha * s.R))
    return mett.State(theta=th0, omega3=omega3)


@pytest.mark.slow
@pytest.mark.ci
def test_stem_phase_ends_in_the_predicted_state_with_jellett_conserved():
    s = LG.stem_top
    state = _stem_start(2.0)
    lam = float(LG.stem_jellett(state))
    assert lam == pytest.approx(2.0 * s.lambda_thres, rel=1e-13)
    pred = LG.stem_end_state(lam)
    assert pred.kind == "inverted"
    traj = mett.simulate(s, state, t_end=10.0)
    assert traj.status == "completed"
    assert traj.theta.min() > LG.touchdown_angle  # the ball never lands: a genuine stem phase
    assert np.max(np.abs(traj.lam - lam)) < 1e-9 * lam
    assert abs(traj.theta[-1] - math.pi) < 1e-6
    assert traj.omega3[-1] == pytest.approx(pred.omega3, rel=1e-8)
    # the METT holds on the stem: Ẽ = g(z) θ̇² + V(z, D, λ_s) with the stem sphere's geometry
    z = np.cos(traj.theta)
    res = traj.E_mod - (mett.g(s, z) * traj.thetadot**2 + mett.V(s, z, traj.D, traj.lam))
    assert np.max(np.abs(res)) < 1e-9 * np.max(np.abs(traj.E_mod))


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        (dict(radius=0.0, distance=0.01), "radius"),
        (dict(radius=0.005, distance=-1.0), "distance"),
        (dict(radius=0.005, distance=0.009), r"distance must exceed \|R - radius\|"),
        (dict(radius=0.03, distance=0.01), r"distance must exceed \|R - radius\|"),
        (dict(radius=math.nan, distance=0.01), "radius"),
    ],
)
def test_bad_stems_are_refused(kwargs, match):
    with pytest.raises(ValueError, match=match):
        LG_BALL.with_stem(**kwargs)
    with pytest.raises(TypeError, match="ball must be a TippeTop"):
        StemmedTop("ball", 0.005, 0.013)
    with pytest.raises(ValueError, match="alpha"):
        StemContactTop(m=1.0, R=1.0, alpha=0.0, I1=1.0, I3=1.0)
