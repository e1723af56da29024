"""Bands at and next to the poles, with (E, D, λ) taken from real states (review findings).

At a pole N(±1) computed from a state is a rounding leftover, not exactly 0, and next to a pole P is
a tiny difference of its terms: these tests pin the classification, the turning points and the
periods there against the independent rolling-ball integrator (tests/reference_rolling.py).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import reference_rolling as rr

import mett

TOP = mett.presets.get("rutstam2013")


def _integrals(s):
    return [float(f(TOP, s)) for f in (mett.energy, mett.routh, mett.jellett)]


def _reference(theta, thetadot, omega3, periods=2, t_max=20.0):
    return rr.integrate(
        TOP, rr.initial_state(theta, thetadot, 0.0, omega3), periods=periods, t_max=t_max,
        track_phi=False,
    )  # fmt: skip


@pytest.mark.parametrize(("thetadot", "omega3"), [(5.0, 50.0), (20.0, 155.0)])
def test_start_exactly_upright_with_a_kick_is_a_band_not_steady(thetadot, omega3):
    s = mett.State(theta=0.0, thetadot=thetadot, omega3=omega3)
    E, D, lam = _integrals(s)
    b = mett.band(TOP, E, D, lam)
    assert b.kind == "nutation" and b.z_high == 1.0
    run = _reference(0.0, thetadot, omega3)
    assert b.z_low == pytest.approx(run.z_low.min(), abs=1e-10)
    assert mett.nutation_period(TOP, E, D, lam) == pytest.approx(run.period, rel=1e-9)


@pytest.mark.parametrize("omega3", [155.0, 100.0, -155.0])
def test_exact_inverted_spin_is_steady_with_the_pole_limit(omega3):
    E, D, lam = _integrals(mett.State(theta=math.pi, omega3=omega3))
    b = mett.band(TOP, E, D, lam)
    assert b.kind == "steady" and b.z_min == -1.0
    slope = abs(float(mett.dV_dz(TOP, -1.0, D, lam)))
    limit = 2 * math.pi / math.sqrt(2 * slope / float(mett.g(TOP, -1.0)))
    assert mett.nutation_period(TOP, E, D, lam) == pytest.approx(limit, rel=1e-12)
    # ⟨φ̇⟩: the limit of φ̇ = N/(R I1 (1 − z²)√d) at the pole, N'(−1)/(2 R I1 √d(−1)) (N(−1) = 0),
    # not NaN (the precession angle of a vertical axis itself is undefined)
    sqd = math.sqrt(float(mett.d(TOP, -1.0)))
    n1 = float(mett.potential.dN_dz(TOP, -1.0, D, lam))
    limit = n1 / (2 * TOP.R * TOP.I1 * sqd)
    assert mett.mean_precession(TOP, E, D, lam) == pytest.approx(limit, rel=1e-12)


def test_slightly_tilted_inverted_spin_tends_to_the_pole_limit():
    E, D, lam = _integrals(mett.State(theta=math.pi, omega3=155.0))
    T_pole = mett.nutation_period(TOP, E, D, lam)
    run = _reference(math.pi - 1e-3, 0.0, 155.0, periods=3, t_max=2.0)
    assert run.period == pytest.approx(T_pole, rel=1e-4)


@pytest.mark.parametrize(
    ("theta", "omega3"), [(0.0, 1e4), (math.pi - 1e-6, 155.0), (math.pi - 1e-4, 1e4)]
)
def test_real_states_next_to_a_pole_are_admissible(theta, omega3):
    s = mett.State(theta=theta, omega3=omega3)
    E, D, lam = _integrals(s)
    zl, zh = mett.turning_points(TOP, E, D, lam, z0=math.cos(theta))  # no ValueError
    assert zl - 1e-9 <= math.cos(theta) <= zh + 1e-9
    assert np.isfinite(mett.nutation_period(TOP, E, D, lam, z0=math.cos(theta)))


@pytest.mark.parametrize(
    ("theta0", "omega3", "rel"),
    [(math.pi - 1e-4, 10.0, 2e-6), (math.pi - 1e-3, 3.0, 1e-7)],
)
def test_unstable_inverted_start_falls_with_the_right_period(theta0, omega3, rel):
    # the turning point next to the pole is 5e-9 (5e-7) from it, behind a steep wall of V
    E, D, lam = _integrals(mett.State(theta=theta0, omega3=omega3))
    zl, zh = mett.turning_points(TOP, E, D, lam)
    assert zl == pytest.approx(math.cos(theta0), abs=1e-13)
    run = _reference(theta0, 0.0, omega3)
    assert zh == pytest.approx(run.z_high.max(), abs=1e-9)
    assert mett.nutation_period(TOP, E, D, lam) == pytest.approx(run.period, rel=rel)
