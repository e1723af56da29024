"""High-spin asymptotics of the rolling ball against direct rolling integrations (docs/theory/high-spin.md#high-spin).

Order-of-convergence tests in the style of diffrax: the relative error of each leading-order formula
is measured at ω3 ∈ {300, 600, 1200, 3000} rad/s and the slope of log(error) against log(ω3) is fitted.
Measured (thesis body, θ0 = 1): with φ̇0 = 0 every error falls like ω3⁻² (the O(1/ω3) terms vanish);
with φ̇0 ≠ 0 the band width and frequency errors fall like ω3⁻¹, and the mean precession keeps an
ω3-independent relative error ∝ φ̇0² (the formula is leading order in φ̇0 as well as in 1/ω3).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import reference_rolling as rr

import mett

SPINS = np.array([300.0, 600.0, 1200.0, 3000.0])


def _generic_top():
    # σ = 1.2, γ = 0.8, α = 0.4 (docs/theory/high-spin.md#high-spin second body)
    m, R = 0.02, 0.02
    I3 = m * R**2 / 1.2
    return mett.TippeTop(m=m, R=R, alpha=0.4, I1=0.8 * I3, I3=I3)


def _errors(top, theta0, phidot0):
    """Relative errors of (width, depth, frequency, precession) at each spin."""
    out = []
    for w3 in SPINS:
        hs = mett.high_spin(top, theta0, w3, phidot0)
        run = rr.integrate(top, rr.initial_state(theta0, 0.0, phidot0, w3), periods=4, t_max=5.0)
        width = np.mean(run.z_high) - np.mean(run.z_low)
        s = mett.State(theta=theta0, omega3=w3, phidot=phidot0)
        band = mett.band(top, mett.energy(top, s), mett.routh(top, s), mett.jellett(top, s))
        out.append(
            [
                width / hs.width - 1,
                band.depth / hs.depth - 1,
                (2 * np.pi / run.period) / hs.frequency - 1,
                run.mean_phidot / hs.precession - 1,
            ]
        )
    return np.abs(np.array(out))


def _slopes(errors):
    return np.array([np.polyfit(np.log(SPINS), np.log(errors[:, k]), 1)[0] for k in range(4)])


@pytest.mark.parametrize("body", ["thesis", "generic"])
@pytest.mark.parametrize("theta0", [1.0, 2.2])
def test_high_spin_errors_fall_like_inverse_square_spin_without_precession(body, theta0):
    top = mett.presets.get("rutstam2013") if body == "thesis" else _generic_top()
    err = _errors(top, theta0, 0.0)
    slopes = _slopes(err)
    # width, depth, frequency, precession: all second order
    assert np.all(slopes < -1.7) and np.all(slopes > -2.5), slopes
    assert err[-1].max() < 1e-4  # at ω3 = 3000 rad/s
    assert err[0].max() < 1e-2  # and already at 300 rad/s


def test_high_spin_with_initial_precession_is_first_order():
    top = mett.presets.get("rutstam2013")
    err = _errors(top, 1.0, 2.0)
    slopes = _slopes(err)
    assert -1.3 < slopes[0] < -0.7, slopes  # width
    assert -1.3 < slopes[2] < -0.7, slopes  # frequency
    assert slopes[1] < -1.7, slopes  # the depth stays second order
    assert err[-1, [0, 1, 2]].max() < 1e-3


def test_precession_formula_is_leading_order_in_initial_precession():
    # ⟨φ̇⟩ = −m g R α/(I3 K0 ω3) drops the φ̇0² term: the relative error tends to a constant ∝ φ̇0².
    top = mett.presets.get("rutstam2013")

    def rel_err(phidot0, w3):
        s = mett.State(theta=1.0, omega3=w3, phidot=phidot0)
        mp = mett.mean_precession(
            top, mett.energy(top, s), mett.routh(top, s), mett.jellett(top, s)
        )
        return mp / mett.high_spin(top, 1.0, w3, phidot0).precession - 1

    plateau = {p: rel_err(p, 6000.0) for p in (1.0, 2.0, 4.0)}
    assert plateau[2.0] / plateau[1.0] == pytest.approx(4, rel=0.1)
    assert plateau[4.0] / plateau[2.0] == pytest.approx(4, rel=0.1)
    assert abs(rel_err(2.0, 3000.0) - plateau[2.0]) < 0.15 * abs(plateau[2.0])  # ω3-independent
    assert abs(plateau[2.0]) < 5e-4  # small for φ̇0 ≪ ω3


def test_axis_rises_and_precession_opposes_spin():
    # docs/theory/high-spin.md#high-spin: with φ̇0 = 0, z increases (θ decreases) and ⟨φ̇⟩ has the opposite sign to ω3.
    top = mett.presets.get("rutstam2013")
    for w3 in (500.0, -500.0):
        hs = mett.high_spin(top, 1.0, w3)
        assert hs.width > 0 and hs.depth > 0 and hs.frequency > 0
        assert np.sign(hs.precession) == -np.sign(w3)
        assert hs.depth == pytest.approx(
            top.m * top.g * top.R * top.alpha * hs.width / 4, rel=1e-12
        )


def test_pole_frequencies_match_the_period_estimates():
    # docs/theory/high-spin.md#high-spin: ω_n(z0 → ±1) are RR14's T(D0), T(D1) frequencies.
    top = mett.presets.get("rutstam2013")
    a, gam = top.alpha, top.gamma
    w3 = 1000.0
    assert mett.high_spin(top, 1e-6, w3).frequency == pytest.approx(
        a * w3 / (a + gam - 1), rel=1e-9
    )
    assert mett.high_spin(top, np.pi - 1e-6, w3).frequency == pytest.approx(
        a * w3 / (1 + a - gam), rel=1e-9
    )


@pytest.mark.parametrize(
    ("args", "message"),
    [
        ((0.0, 100.0), r"theta0 must lie in the open interval \(0, pi\)"),
        ((np.pi, 100.0), r"theta0 must lie in the open interval"),
        ((4.0, 100.0), r"theta0 must lie in \[0, pi\]"),
        ((1.0, 0.0), "omega3 must be nonzero"),
        ((1.0, np.nan), "omega3 must be finite"),
    ],
)
def test_high_spin_bad_input(args, message):
    with pytest.raises(ValueError, match=message):
        mett.high_spin(mett.presets.get("rutstam2013"), *args)


# --- validity: warn where the leading order is off --------------------------------------------


def _measured_errors(top, theta0, omega3, phidot0):
    """Relative errors of high_spin's width, frequency and precession against the independent
    rolling integrator (rtol 1e-12: its own errors are ~1e-9, far below the 10 % threshold)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mett.asymptotics.AsymptoticWarning)
        hs = mett.high_spin(top, theta0, omega3, phidot0)
    run = rr.integrate(top, rr.initial_state(theta0, 0.0, phidot0, omega3), periods=3, t_max=20.0)
    z0 = np.cos(theta0)
    lo, hi = np.mean(run.z_low), np.mean(run.z_high)
    width = (hi - z0) if hi - z0 >= z0 - lo else (lo - z0)
    return [
        abs(hs.width / width - 1),
        abs(hs.frequency / (2 * np.pi / run.period) - 1),
        abs(hs.precession / run.mean_phidot - 1),
    ]


@pytest.mark.parametrize(
    ("theta0", "omega3", "phidot0"),
    [
        (1.0, 20.0, 0.0),  # just above √(m g R α/I3): width ~70 % off
        (1.0, 1.0, 0.0),  # width ~300× off
        (3.0, 20.0, 0.0),
        (1.0, 1000.0, 100.0),  # φ̇0 = 10 % of ω3: precession ~2× off
    ],
)
def test_high_spin_warns_outside_its_validity(theta0, omega3, phidot0):
    top = mett.presets.get("rutstam2013")
    assert max(_measured_errors(top, theta0, omega3, phidot0)) > 0.2
    with pytest.warns(mett.asymptotics.AsymptoticWarning, match="outside the validity") as rec:
        mett.high_spin(top, theta0, omega3, phidot0)
    assert rec[0].filename == __file__  # reported at the caller's line
    assert issubclass(mett.asymptotics.AsymptoticWarning, mett.MettWarning)


@pytest.mark.parametrize(
    ("theta0", "omega3", "phidot0"),
    [(1.0, 300.0, 0.0), (2.2, 1000.0, 2.0), (0.3, 3000.0, 0.0), (1.0, 1000.0, 1.0)],
)
def test_high_spin_is_silent_where_it_holds(theta0, omega3, phidot0):
    top = mett.presets.get("rutstam2013")
    assert max(_measured_errors(top, theta0, omega3, phidot0)) < 0.05
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        mett.high_spin(top, theta0, omega3, phidot0)


def test_high_spin_check_can_be_skipped():
    top = mett.presets.get("rutstam2013")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        hs = mett.high_spin(top, 1.0, 1.0, check=False)
    assert hs.width > 0


@pytest.mark.parametrize(
    ("theta0", "coefficient"), [(0.6, -5.1e-5), (1.0, -5.5e-5), (2.0, 1.0e-4), (2.5, 6.8e-5)]
)
def test_precession_error_coefficient_depends_on_theta0(theta0, coefficient):
    # docs/theory/high-spin.md#validity: rel. error of ⟨φ̇⟩ → c(θ0) φ̇0² at high spin; c changes sign
    # between θ0 = 1 and 1.5. The exact ⟨φ̇⟩ (mpmath-checked quadrature) at ω3 = 6000, φ̇0 = 4.
    top = mett.presets.get("rutstam2013")
    s = mett.State(theta=theta0, omega3=6000.0, phidot=4.0)
    E, D, lam = (float(f(top, s)) for f in (mett.energy, mett.routh, mett.jellett))
    mp = float(mett.mean_precession(top, E, D, lam, z0=np.cos(theta0)))
    rel = mp / mett.high_spin(top, theta0, 6000.0, 4.0).precession - 1
    # the plateau is reached to a few % at this spin (an O(1/(ω3 φ̇0)) remainder)
    assert rel / 16.0 == pytest.approx(coefficient, rel=0.05)
