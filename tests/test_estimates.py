"""The 2014 estimates: minimum of V, convexity, period bounds (docs/theory/estimates.md#estimates)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import mett
from mett.estimates import (
    convexity,
    oscillation_ratio,
    period_estimates,
    potential_minimum,
    small_oscillation_period,
)

LAM = 6.8944e-6  # thesis run, docs/theory/references.md#other-sources


def _D_for_zstar(top, lam, zstar):
    """D at which the gravity-free kinetic minimum z* = c2/c1 equals ``zstar`` (rational top)."""
    b, R, gam, a = top.beta, top.R, top.gamma, top.alpha
    return lam * b * (zstar * a - (1 - gam)) / (R * (1 - zstar * a))


@pytest.mark.parametrize(
    ("zstar", "zmin"), [(0.85714, 0.85845), (0.30000, 0.30679), (-0.58065, -0.57218)]
)
def test_minimum_matches_theory_table(thesis_top, zstar, zmin):
    # docs/theory/estimates.md#estimates: gravity shifts the minimum from z* slightly towards z = 1.
    D = _D_for_zstar(thesis_top, LAM, zstar)
    z = potential_minimum(thesis_top, D, LAM)
    assert z == pytest.approx(zmin, abs=1e-5)
    assert z > zstar


def test_minimum_against_brute_force_grid(rng):
    top = mett.presets.get("rutstam2012")
    bv = mett.boundary_values(top, LAM)
    zgrid = np.linspace(-0.99999, 0.99999, 400001)
    for D in rng.uniform(bv.D1, bv.D0, 5):
        zg = zgrid[np.argmin(mett.V(top, zgrid, D, LAM))]
        assert potential_minimum(top, D, LAM) == pytest.approx(zg, abs=1e-5)
        assert mett.dV_dz(top, potential_minimum(top, D, LAM), D, LAM) == pytest.approx(
            0, abs=1e-12
        )


def test_minimum_travels_monotonically_from_pole_to_pole(thesis_top):
    bv = mett.boundary_values(thesis_top, LAM)
    Ds = np.linspace(bv.D0, bv.D1, 41)
    zs = np.array([potential_minimum(thesis_top, D, LAM) for D in Ds])
    assert zs[0] == 1.0 and zs[-1] == -1.0  # the spinning poles themselves
    assert zs[1] > 0.9 and zs[-2] < -0.9
    assert np.all(np.diff(zs) < 0)


@pytest.mark.parametrize("ratio", [0.3, 0.6, 1.0, 2.0, 5.0])
def test_thesis_potential_convex_with_one_minimum(thesis_top, ratio):
    # docs/theory/estimates.md#estimates: convex, one local minimum, for D in [2 D1, 2 D0] and these λ/λ_thres.
    lam = ratio * thesis_top.lambda_thres
    bv = mett.boundary_values(thesis_top, lam)
    for D in np.linspace(2 * bv.D1, 2 * bv.D0, 9):
        c = convexity(thesis_top, D, lam)
        assert c.convex and c.n_minima == 1


def test_convexity_detects_a_non_convex_potential():
    # Found by a random search over bodies (group III, γ = 1.78): V'' < 0 somewhere on (−1, 1) but
    # still a single minimum. The check must report it rather than assume RR14's theorem.
    top = mett.TippeTop(
        m=0.010868215717,
        R=0.030195632725,
        alpha=0.629187437543,
        I1=1.85032978954e-06,
        I3=1.040219001727e-06,
    )
    c = convexity(top, 1.4400049967e-04, 1.1149752083e-06)
    assert not c.convex and c.min_curvature < 0
    assert c.n_minima == 1


def test_period_estimates_thesis_values(thesis_top):
    T0, T1 = period_estimates(thesis_top, LAM)
    assert T0 == pytest.approx(0.03208, abs=1e-5)
    assert T1 == pytest.approx(0.09207, abs=1e-5)
    # rational closed forms of RR14
    R, I3, a, gam = thesis_top.R, thesis_top.I3, thesis_top.alpha, thesis_top.gamma
    assert T0 == pytest.approx(
        2 * math.pi * R * I3 * (1 - a) * (a + gam - 1) / (a * LAM), rel=1e-13
    )
    assert T1 == pytest.approx(
        2 * math.pi * R * I3 * (1 + a) * (1 + a - gam) / (a * LAM), rel=1e-13
    )


def test_period_estimates_are_the_gravity_free_limit_of_the_exact_small_oscillations(thesis_top):
    # Near the poles the exact small-oscillation period (gravity included) approaches T(D0), T(D1);
    # gravity is O(m g R α / (I3 ω3²)) relative, so raising λ tenfold shrinks the gap ~100-fold.
    # Measured at the thesis λ: 0.9 % at the D0 end, 3.2 % at the D1 end (slowest spin).
    gaps = []
    for lam in (LAM, 10 * LAM):
        T0, T1 = period_estimates(thesis_top, lam)
        bv = mett.boundary_values(thesis_top, lam)
        near0 = bv.D0 - 1e-6 * (bv.D0 - bv.D1)
        near1 = bv.D1 + 1e-6 * (bv.D0 - bv.D1)
        gaps.append(
            (
                abs(small_oscillation_period(thesis_top, near0, lam) / T0 - 1),
                abs(small_oscillation_period(thesis_top, near1, lam) / T1 - 1),
            )
        )
    assert gaps[0][0] < 0.01 and gaps[0][1] < 0.035
    assert gaps[1][0] < gaps[0][0] / 50 and gaps[1][1] < gaps[0][1] / 50


def test_period_increases_from_D0_to_D1(thesis_top):
    bv = mett.boundary_values(thesis_top, LAM)
    Ds = np.linspace(bv.D0, bv.D1, 12)[1:-1]
    T = [small_oscillation_period(thesis_top, D, LAM) for D in Ds]
    assert np.all(np.diff(T) > 0)
    T0, T1 = period_estimates(thesis_top, LAM)
    assert T0 * 0.98 < T[0] and T[-1] < T1 * 1.02


def test_small_oscillation_period_matches_exact_period_at_the_well_bottom(thesis_top):
    bv = mett.boundary_values(thesis_top, LAM)
    D = 0.3 * bv.D0
    zm = potential_minimum(thesis_top, D, LAM)
    E = float(mett.V(thesis_top, zm, D, LAM)) * (1 + 1e-9)
    assert mett.nutation_period(thesis_top, E, D, LAM) == pytest.approx(
        small_oscillation_period(thesis_top, D, LAM), rel=1e-5
    )


def test_oscillation_ratio(thesis_top):
    assert oscillation_ratio(thesis_top, LAM, 2.5) == pytest.approx(2.5 / 0.0920720, rel=1e-5)


@pytest.mark.parametrize("lam", [0.0, -1e-6, math.nan])
def test_estimates_need_a_positive_jellett_integral(thesis_top, lam):
    with pytest.raises(ValueError, match="lam must"):
        period_estimates(thesis_top, lam)
