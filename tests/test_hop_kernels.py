"""The compiled flight kernels (mett.dynamics._hop) against the Python they replace.

The touchdown march and the gap of a flight run as numba code; ``Hop.touchdown_reference`` and
``Hop.gaps_reference`` keep the Python (itself tested against solve_ivp in test_flight.py). The
two evaluate the same closed form, so they agree to the rounding of that formula: a gap differs
by a few ulps of the sum of the magnitudes of its terms S (libm's sin/cos and pow against numba's
inlined ones), and a touchdown time, the root of h, by that error over |ḣ| at the root, plus the
march's stopping resolution t_res = 4 eps max(|t0|, 1) (flight.py) on each side.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import mett
from mett.dynamics import flight

TOP = mett.presets.get("rutstam2013")
M, R, L, I1, I3, G = TOP.m, TOP.R, TOP.R * TOP.alpha, TOP.I1, TOP.I3, TOP.g
BODY = (M, R, L, I1, I3, G)
EPS = np.finfo(float).eps


def _random_hops(n: int) -> list[flight.Hop]:
    """Hops of random tilt, spin, wobble, start time, gap and gap rate (lift-offs among them:
    h = ḣ = 0, whose march starts from the Taylor bound of the lift-off branch)."""
    rng = np.random.default_rng(20261126)
    hops = []
    for k in range(n):
        th, ph = rng.uniform(0.05, 3.0), rng.uniform(0.0, 2 * math.pi)
        e = np.array([math.sin(th) * math.cos(ph), math.sin(th) * math.sin(ph), math.cos(th)])
        w = rng.uniform(50.0, 3000.0) * e + rng.normal(0.0, 20.0, 3)
        Lvec = I1 * w + (I3 - I1) * float(w @ e) * e
        y = np.array([0.0, 0.0, *rng.normal(0.0, 0.3, 2), *Lvec, *e])
        gap, rate = (0.0, 0.0) if k % 2 else (rng.uniform(0.0, 1e-4), rng.normal(0.0, 0.05))
        hops.append(flight.Hop(y, rng.uniform(0.0, 10.0), BODY, gap=gap, gap_rate=rate))
    return hops


def _term_scale(hop: flight.Hop, tau: np.ndarray) -> np.ndarray:
    """S(τ): the sum of the magnitudes of the terms of h (and of ḣ, for the rate)."""
    W, uz, vz = hop.Omega, abs(hop.u[2]), abs(hop.v[2])
    w = np.abs(W * tau)
    return (abs(hop.h0) + abs(hop.hd0) * tau + 0.5 * hop.g * tau * tau + hop.g * tau
            + hop.l * (uz + vz) * (2.0 + w) * (1.0 + W))  # fmt: skip


@pytest.mark.parametrize("hop", _random_hops(40))
def test_compiled_gap_equals_the_python_gap(hop):
    """h and ḣ at 200 times of the hop, compiled and in Python: within 16 eps S (a few roundings
    of each of the formula's terms)."""
    tau = np.linspace(0.0, 0.05, 200)
    h, h1 = hop.gaps(tau)
    h_ref, h1_ref = hop.gaps_reference(tau)
    tol = 16.0 * EPS * _term_scale(hop, tau)
    assert np.all(np.abs(h - h_ref) <= tol)
    assert np.all(np.abs(h1 - h1_ref) <= tol)


@pytest.mark.parametrize("hop", _random_hops(40))
def test_compiled_touchdown_equals_the_python_march(hop):
    """The first root of the gap, compiled and in Python: the same outcome (None, a hop of zero
    length, or a root), roots within the error analysis of the module docstring."""
    tau_max = 1.0
    got, ref = hop.touchdown(tau_max), hop.touchdown_reference(tau_max)
    assert (got is None) == (ref is None)
    if ref is None:
        return
    assert (got == 0.0) == (ref == 0.0)
    rate = abs(hop.gap(ref)[1])
    t_res = 4.0 * EPS * max(abs(hop.t0), 1.0)
    S = float(_term_scale(hop, np.array([ref]))[0])
    tol = 2.0 * t_res + (2.0 * 16.0 * EPS * S / rate if rate > 0.0 else math.inf)
    assert abs(got - ref) <= max(tol, 4.0 * t_res)
    assert hop.gap(got)[0] <= 16.0 * EPS * S  # at (or just past) the root: not above the table


def test_the_touchdown_kernel_catches_a_sign_error():
    """The comparison can fail: a hop whose gap rate is reversed lands at another time."""
    hop = _random_hops(2)[0]
    flipped = flight.Hop(
        hop.state(0.0), hop.t0, BODY, gap=hop.h0, gap_rate=-hop.hd0 if hop.hd0 else 0.01
    )
    assert flipped.touchdown(1.0) != pytest.approx(hop.touchdown_reference(1.0), rel=1e-6)


def _impact_cases(n: int) -> list[tuple[np.ndarray, np.ndarray, float]]:
    """Random impacts: W symmetric positive definite over three decades, v_z from −1 to −1e-4
    m/s, μ from 1e-3 to 30 s/m (darboux_keller's explicit and its stiff, expm, paths)."""
    rng = np.random.default_rng(7)
    cases = []
    for _ in range(n):
        A = rng.normal(size=(3, 3))
        W = (A @ A.T + 0.1 * np.eye(3)) * 10 ** rng.uniform(0.0, 3.0)
        v0 = rng.normal(size=3)
        v0[2] = -abs(v0[2]) * 10 ** rng.uniform(-4.0, 0.0)
        cases.append((v0, W, 10 ** rng.uniform(-3.0, 1.5)))
    return cases


@pytest.mark.parametrize(("v0", "W", "mu"), _impact_cases(30))
def test_closed_form_viscous_impulse_matches_the_integrated_one(v0, W, mu):
    """flight.viscous_impulse (closed form, compiled) against stem.darboux_keller (solve_ivp
    DOP853 at rtol 1e-13, atol 1e-15 (1 + |v_z0|) on the velocities, or expm + brentq): an error
    δv of the reference maps to δP = W⁻¹ δv, so |ΔP| ≤ 100 (1e-13 |P| + ‖W⁻¹‖ atol); and the
    end of compression: v_z = 0 after the impulse, to rounding of v0 + W P."""
    from mett.dynamics import stem

    P = flight.viscous_impulse(v0, W, mu)
    ref = stem.darboux_keller(v0, W, mu)
    atol = 1e-15 * (1.0 + abs(v0[2]))
    tol = 100.0 * (1e-13 * np.linalg.norm(ref) + np.linalg.norm(np.linalg.inv(W), 2) * atol)
    assert np.linalg.norm(P - ref) <= tol
    v = v0 + W @ P
    assert abs(v[2]) <= 64.0 * EPS * (abs(v0[2]) + np.abs(W[2]) @ np.abs(P))
    assert P[2] > 0.0


def test_frictionless_and_sticking_limits_of_the_viscous_impulse():
    """μ = 0: P = (0, 0, −v_z0/W_zz), exactly the frictionless impact. μ → ∞: the slip stops
    at once, v = 0 after the impact, P = −W⁻¹ v0 (the sticking plastic impact)."""
    v0, W, _ = _impact_cases(1)[0]
    P = flight.viscous_impulse(v0, W, 0.0)
    assert P[0] == 0.0 and P[1] == 0.0
    assert P[2] == pytest.approx(-v0[2] / W[2, 2], rel=4 * EPS)
    stick = flight.viscous_impulse(v0, W, 1e12)
    ref = np.linalg.solve(W, -v0)
    # residual slip ~ |W_tz|/(μ λ_min) relative: the relaxation 1/(μ|W|) of the slip
    assert stick == pytest.approx(ref, rel=1e-6)


def test_first_root_of_the_bound_equals_numpys():
    """The compiled first positive root (isolated between the derivatives' roots) against
    np.roots' (flight._first_root, the Python reference): the same root to its conditioning,
    |Δs| ≤ 256 eps (s + Σ|c_i| s^i / |p'(s)|) (rounding of p near s over its slope), and the
    same "no root" answers. Polynomials of degree 1 to 4 with p(0) > 0, as the march builds."""
    from mett.dynamics import _hop

    rng = np.random.default_rng(3)
    for _ in range(2000):
        c = rng.normal(size=rng.integers(2, 6)) * 10.0 ** rng.uniform(-3, 3, 1)
        c[-1] = abs(c[-1])
        got, ref = _hop.first_root(c), flight._first_root(list(c))
        assert math.isnan(got) == (ref is None)
        if ref is None:
            continue
        slope = abs(np.polyval(np.polyder(c), ref))
        scale = np.polyval(np.abs(c), ref)
        assert abs(got - ref) <= 256.0 * EPS * (ref + scale / slope)
