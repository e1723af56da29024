"""d, g, V (algebraic and rational), their derivatives, poles and bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import random_top

import mett
from mett.potential import N


def test_g_is_half_of_I1_plus_m_a_squared(rng):
    # g(z) = ½ (I1 + m|a|²), |a|² = R²(1 + α² − 2αz) (docs/theory/mett.md#the-main-equation).
    top = random_top(rng)
    z = np.linspace(-1, 1, 21)
    a2 = top.R**2 * (1 + top.alpha**2 - 2 * top.alpha * z)
    np.testing.assert_allclose(mett.g(top, z), 0.5 * (top.I1 + top.m * a2), rtol=1e-14)


def test_d_matches_inertia_form(rng):
    # I3² d = I1 I3 + m R² I3 (α − z)² + m R² I1 (1 − z²) (docs/theory/model.md#conventions).
    top = random_top(rng)
    z = np.linspace(-1, 1, 21)
    rhs = top.I1 * top.I3 + top.m * top.R**2 * (top.I3 * (top.alpha - z) ** 2 + top.I1 * (1 - z**2))
    np.testing.assert_allclose(top.I3**2 * mett.d(top, z), rhs, rtol=1e-14)


def test_potential_gives_back_the_precession_rate(rng):
    # V's kinetic part is ½ I1 φ̇² sin²θ + ... : rebuilding φ̇ from (z, D, λ) recovers the state's φ̇.
    top = random_top(rng)
    th = rng.uniform(0.1, 3.0, 30)
    s = mett.State(theta=th, phidot=rng.normal(0, 20, 30), omega3=rng.normal(0, 200, 30))
    z = np.cos(th)
    D, lam = mett.routh(top, s), mett.jellett(top, s)
    phidot = N(top, z, D, lam) / (top.R * top.I1 * (1 - z**2) * np.sqrt(mett.d(top, z)))
    np.testing.assert_allclose(phidot, s.phidot, rtol=1e-10, atol=1e-10)
    np.testing.assert_allclose(D / (top.I3 * np.sqrt(mett.d(top, z))), s.omega3, rtol=1e-13)


def test_rational_potential_equals_algebraic(rng):
    for _ in range(20):
        m, R = rng.uniform(0.005, 0.05), rng.uniform(0.01, 0.04)
        top = mett.TippeTop.rational(m=m, R=R, alpha=rng.uniform(0.05, 0.6), I3=0.4 * m * R**2)
        z = rng.uniform(-0.999, 0.999, 50)
        lam = rng.uniform(0.1, 5) * top.lambda_thres
        bv = mett.boundary_values(top, lam)
        D = rng.uniform(bv.D1, bv.D0, 50)
        np.testing.assert_allclose(
            mett.V_rational(top, z, D, lam), mett.V(top, z, D, lam), rtol=1e-12
        )


def test_rational_potential_refuses_non_rational_top():
    top = mett.presets.get("rutstam2012")
    with pytest.raises(ValueError, match=r"rational top: sigma must equal"):
        mett.V_rational(top, 0.3, 1e-4, 1e-6)


def _central_difference(fn, z, h=1e-5):
    """Fourth-order central difference of fn at z (an independent check of analytic derivatives)."""
    return (-fn(z + 2 * h) + 8 * fn(z + h) - 8 * fn(z - h) + fn(z - 2 * h)) / (12 * h)


def _thesis_integrals(top):
    lam = mett.jellett(top, mett.State(theta=0.1, omega3=155.0))
    bv = mett.boundary_values(top, lam)
    return lam, bv


def test_dV_dz_matches_finite_differences(thesis_top, rng):
    top = thesis_top
    lam, bv = _thesis_integrals(top)
    z = rng.uniform(-0.95, 0.95, 40)
    D = rng.uniform(1.5 * bv.D1, 1.5 * bv.D0, 40)
    fd = _central_difference(lambda x: mett.V(top, x, D, lam), z)
    np.testing.assert_allclose(mett.dV_dz(top, z, D, lam), fd, rtol=1e-6, atol=1e-9)


def test_d2V_dz2_matches_finite_differences_on_a_generic_top(rng):
    top = mett.presets.get("rutstam2012")  # algebraic, so d'' and the √d terms all matter
    lam, bv = _thesis_integrals(top)
    z = rng.uniform(-0.9, 0.9, 40)
    D = rng.uniform(bv.D1, bv.D0, 40)
    fd = _central_difference(lambda x: mett.dV_dz(top, x, D, lam), z)
    np.testing.assert_allclose(mett.d2V_dz2(top, z, D, lam), fd, rtol=1e-6)
    with pytest.raises(ValueError, match="open interval"):
        mett.d2V_dz2(top, 1.0, bv.D0, lam)


def test_potential_at_the_poles(thesis_top):
    # V(1, D0) = E0 and V(−1, D1) = E1 (docs/theory/thresholds.md#boundary-values); V = +inf at a pole where N ≠ 0.
    top = thesis_top
    lam, bv = _thesis_integrals(top)
    assert mett.V(top, 1.0, bv.D0, lam) == pytest.approx(bv.E0, rel=1e-12)
    assert mett.V(top, -1.0, bv.D1, lam) == pytest.approx(bv.E1, rel=1e-12)
    assert mett.V_rational(top, 1.0, bv.D0, lam) == pytest.approx(bv.E0, rel=1e-12)
    assert mett.V(top, 1.0, bv.D1, lam) == math.inf
    assert mett.V(top, -1.0, bv.D0, lam) == math.inf
    # The pole values are the limits of the interior values.
    assert mett.V(top, 1 - 1e-11, bv.D0, lam) == pytest.approx(bv.E0, rel=1e-9)
    assert mett.V(top, -1 + 1e-11, bv.D1, lam) == pytest.approx(bv.E1, rel=1e-9)


def test_slope_at_a_spinning_pole(thesis_top):
    # docs/theory/thresholds.md#thresholds: in u = 1 − z, V(z, D0) rises with slope m g R α + I3 N'(1)²/(4 I1² R²) > 0.
    top = thesis_top
    lam, bv = _thesis_integrals(top)
    dn = mett.potential.dN_dz(top, 1.0, bv.D0, lam)
    expected = -(top.m * top.g * top.R * top.alpha + top.I3 * dn**2 / (4 * top.I1**2 * top.R**2))
    assert mett.dV_dz(top, 1.0, bv.D0, lam) == pytest.approx(expected, rel=1e-10)
    one_sided = (mett.V(top, 1.0, bv.D0, lam) - mett.V(top, 1 - 1e-7, bv.D0, lam)) / 1e-7
    assert one_sided == pytest.approx(expected, rel=1e-5)
    assert mett.dV_dz(top, 1.0, bv.D1, lam) == math.inf
    assert mett.dV_dz(top, -1.0, bv.D0, lam) == -math.inf


def test_potential_broadcasts(thesis_top):
    lam, bv = _thesis_integrals(thesis_top)
    z = np.linspace(-0.9, 0.9, 7)[:, None]
    D = np.linspace(bv.D1, bv.D0, 5)[None, :]
    out = mett.V(thesis_top, z, D, lam)
    assert out.shape == (7, 5)
    assert out[3, 2] == mett.V(thesis_top, z[3, 0], D[0, 2], lam)
    lams = lam * np.array([1.0, 2.0])
    assert mett.V(thesis_top, 0.2, bv.D0, lams).shape == (2,)


def test_potential_has_a_single_minimum_that_travels_with_D(thesis_top):
    # docs/theory/estimates.md#estimates: for the thesis body V is convex with one minimum moving from z ≈ 1 (D0) to z ≈ −1 (D1).
    lam, bv = _thesis_integrals(thesis_top)
    z = np.linspace(-0.999, 0.999, 4001)
    zmins = []
    for D in np.linspace(bv.D0, bv.D1, 9):
        v = mett.V(thesis_top, z, D, lam)
        assert np.all(np.diff(v, 2) > 0)  # convex on the grid
        zmins.append(z[np.argmin(v)])
    assert zmins[0] > 0.99 and zmins[-1] < -0.99
    assert np.all(np.diff(zmins) < 0)


@pytest.mark.parametrize("fn", [mett.V, mett.dV_dz, mett.d2V_dz2, mett.V_rational])
def test_bad_z_and_integrals_raise(fn, thesis_top):
    with pytest.raises(ValueError, match=r"z = cos\(theta\) must lie in \[-1, 1\]; got 1.5"):
        fn(thesis_top, 1.5, 1e-4, 1e-6)
    with pytest.raises(ValueError, match="z must be finite"):
        fn(thesis_top, np.nan, 1e-4, 1e-6)
    with pytest.raises(ValueError, match="D must be finite"):
        fn(thesis_top, 0.2, np.inf, 1e-6)
    with pytest.raises(ValueError, match="lam must be finite"):
        fn(thesis_top, 0.2, 1e-4, np.nan)


@pytest.mark.parametrize("fn", [mett.d, mett.g])
def test_bad_z_raises_for_d_and_g(fn, thesis_top):
    with pytest.raises(ValueError, match=r"must lie in \[-1, 1\]"):
        fn(thesis_top, np.array([0.0, -1.01]))
