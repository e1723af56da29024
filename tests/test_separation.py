"""The separation equation ż² = f(z) (mett.separation) against an independent rolling integration.

The reference (tests/reference_rolling.py) integrates the rolling top in lab-frame vector form from
Newton–Euler alone and measures turning points, periods and the mean precession directly; it shares
no formula with mett.potential or mett.separation. Where the reference cannot reach (ω3 = 10⁴ and
3·10⁴ rad/s, quadrature convergence) an mpmath evaluation of docs/theory/mett.md#the-main-equation at 40 digits is used.

Measured agreement with the reference (rutstam2013 / rutstam2012 / generic body, θ0 ∈ {0.5, 1, 2.2},
φ̇0 ∈ {0, 5}, ω3 = 20 … 3000 rad/s): turning points ≤ 1.5e-11 in z, periods ≤ 1.5e-11 relative,
mean precession ≤ 1.4e-10 relative; against mpmath at 3e4 rad/s, periods ≤ 2e-12.
"""

from __future__ import annotations

import functools
import math

import mpmath
import numpy as np
import pytest
import reference_rolling as rr
from scipy import integrate as sint
from scipy import optimize

import mett

# --- bodies and cases -----------------------------------------------------------------------

_M, _R = 0.02, 0.02
BODIES = {
    "rutstam2013": mett.presets.get("rutstam2013"),  # the thesis body: rational METT
    "rutstam2012": mett.presets.get("rutstam2012"),  # algebraic (non-rational) V
    # docs/theory/high-spin.md#high-spin generic body σ = 1.2, γ = 0.8, α = 0.4 (non-rational, far from it)
    "generic": mett.TippeTop(m=_M, R=_R, alpha=0.4, I1=0.8 * _M * _R**2 / 1.2, I3=_M * _R**2 / 1.2),
}
SPINS = (20.0, 100.0, 300.0, 1000.0, 3000.0)
THETAS = (0.5, 1.0, 2.2)
PHIDOTS = (0.0, 5.0)


def _integrals(top, theta, omega3, phidot=0.0, thetadot=0.0):
    """(E, D, λ) from mett's definitions for a rolling state (ν = 0)."""
    s = mett.State(theta=theta, thetadot=thetadot, phidot=phidot, omega3=omega3)
    return float(mett.energy(top, s)), float(mett.routh(top, s)), float(mett.jellett(top, s))


@functools.cache
def _run(body: str, theta: float, phidot: float, omega3: float, thetadot: float = 0.0):
    """Reference rolling integration over 4 nutation periods (cached: several tests share runs)."""
    y0 = rr.initial_state(theta, thetadot, phidot, omega3)
    return rr.integrate(BODIES[body], y0, periods=4, track_phi=theta > 0.0)


CASES = [
    pytest.param(body, th, pd, w3, id=f"{body}-th{th}-pd{pd:g}-w{w3:g}")
    for body in BODIES
    for th in THETAS
    for pd in PHIDOTS
    for w3 in SPINS
]


# --- the reference integrator itself --------------------------------------------------------


@pytest.mark.parametrize("body", list(BODIES))
@pytest.mark.parametrize("omega3", [20.0, 3000.0])
def test_reference_integration_conserves_energy_jellett_and_routh(body, omega3):
    run = _run(body, 1.0, 5.0, omega3)
    # DOP853 at rtol 1e-12 over 4 periods: measured ≤ 3e-14 (E), ≤ 2e-13 (λ, D).
    assert run.drift["E"] < 1e-12
    assert run.drift["lam"] < 1e-11
    assert run.drift["D"] < 1e-11


@pytest.mark.parametrize("body", list(BODIES))
def test_reference_initial_integrals_equal_mett_definitions(body):
    # Same physical state built two ways (lab vectors vs the Resal-frame formulas of mett.integrals):
    # checks the Euler-angle conventions the comparisons below rely on.
    top = BODIES[body]
    for th, thd, pd, w3 in [
        (1.0, 0.7, 5.0, 100.0),
        (2.2, -3.0, -2.0, 300.0),
        (0.0, 1.0, 0.0, 150.0),
    ]:
        E_ref, lam_ref, D_ref = rr.integrals(top, rr.initial_state(th, thd, pd, w3))
        E, D, lam = _integrals(top, th, w3, pd, thd)
        assert E_ref == pytest.approx(E, rel=1e-14)
        assert lam_ref == pytest.approx(lam, rel=1e-14)
        assert D_ref == pytest.approx(D, rel=1e-14)


# --- turning points, period, precession vs the reference ------------------------------------


@pytest.mark.parametrize(("body", "theta", "phidot", "omega3"), CASES)
def test_turning_points_and_period_match_rolling_integration(body, theta, phidot, omega3):
    top = BODIES[body]
    E, D, lam = _integrals(top, theta, omega3, phidot)
    run = _run(body, theta, phidot, omega3)
    z_low, z_high = mett.turning_points(top, E, D, lam)
    T = mett.nutation_period(top, E, D, lam)

    # Every minimum/maximum of z along the run is a turning point. Measured |Δz| ≤ 1.5e-11 (at
    # 3000 rad/s; ≤ 3e-12 below): the reference's energy error over the slope of V, see below.
    np.testing.assert_allclose(run.z_low, z_low, rtol=0, atol=2e-10)
    np.testing.assert_allclose(run.z_high, z_high, rtol=0, atol=2e-10)

    # Two independent estimates of the reference period (minima, maxima of z) agree to ≤ 5e-12;
    # mett agrees with them to ≤ 1.5e-11 (≥ 10 significant digits; asked for ≥ 7).
    assert run.period == pytest.approx(run.period_high, rel=1e-10)
    assert T == pytest.approx(run.period, rel=2e-10)


@pytest.mark.parametrize("body", list(BODIES))
@pytest.mark.parametrize("theta", THETAS)
@pytest.mark.parametrize("omega3", [1000.0, 3000.0])
def test_band_width_matches_rolling_integration_at_high_spin(body, theta, omega3):
    top = BODIES[body]
    E, D, lam = _integrals(top, theta, omega3)
    run = _run(body, theta, 0.0, omega3)
    z_low, z_high = mett.turning_points(top, E, D, lam)
    width = z_high - z_low
    width_ref = np.mean(run.z_high) - np.mean(run.z_low)
    # The band is ~1e-5 wide at 3000 rad/s. A turning point moves by δE/|V'(z)| when the energy
    # changes by δE, so the comparison is limited by the reference's own energy error (measured
    # drift, ~4e-14 J of E ≈ 14 J) plus the rounding of E to a double (mett's input), both divided
    # by the slope of V at the turning points; a factor 4 for the two ends and margin.
    slope = np.min(np.abs(mett.dV_dz(top, np.array([z_low, z_high]), D, lam)))
    dE = run.drift["E_abs"] + 4 * np.spacing(E)
    tol = 4 * dE / slope
    assert tol < 1e-3 * width  # the check is meaningful: ≥ 3 digits of the width at 3000 rad/s
    assert abs(width - width_ref) <= tol


@pytest.mark.parametrize(("body", "theta", "phidot", "omega3"), CASES)
def test_mean_precession_matches_rolling_integration(body, theta, phidot, omega3):
    top = BODIES[body]
    E, D, lam = _integrals(top, theta, omega3, phidot)
    run = _run(body, theta, phidot, omega3)
    mean = mett.mean_precession(top, E, D, lam)
    # The reference measures Δφ/Δt over 4 whole periods; at 3000 rad/s Δφ is only ~3e-4 rad, so
    # the integration error of φ shows most there. Measured ≤ 1.4e-10 (3000 rad/s), ≤ 2e-11 below.
    assert mean == pytest.approx(run.mean_phidot, rel=2e-9)


def test_theory_example_period_and_band_from_mett_and_from_reference():
    # docs/theory/mett.md#rational: thesis body, θ0 = 1, ω3 = 100, φ̇0 = 5 → T = 0.055014 s, band [0.540302, 0.613785].
    top = BODIES["rutstam2013"]
    E, D, lam = _integrals(top, 1.0, 100.0, 5.0)
    run = _run("rutstam2013", 1.0, 5.0, 100.0)
    for T, zl, zh in [
        (mett.nutation_period(top, E, D, lam), *mett.turning_points(top, E, D, lam)),
        (run.period, run.z_low.min(), run.z_high.max()),
    ]:
        assert round(T, 6) == 0.055014
        assert (round(zl, 6), round(zh, 6)) == (0.540302, 0.613785)


# --- the high-spin precision problem ---------------------------------------------------------


def _mp_P(top, E, D, lam):
    """P(z) = (1 − z²)(E − D²/(2I1) + mλ²/(2I1I3) − mgR(1 − αz)) − I3 N²/(2 I1² R²) in mpmath.

    Call inside ``mpmath.workdps``: the parameters are converted at the working precision.
    """
    mp = mpmath.mpf
    m, R, al, I1, I3, gr = (mp(v) for v in (top.m, top.R, top.alpha, top.I1, top.I3, top.g))
    E, D, lam = mp(E), mp(D), mp(lam)
    gam, sig = I1 / I3, m * R**2 / I3
    Es = E - D**2 / (2 * I1) + m * lam**2 / (2 * I1 * I3)

    def P(z):
        n = lam * mpmath.sqrt(gam + sig * (al - z) ** 2 + sig * gam * (1 - z * z))
        n += R * D * (al - z)
        return (1 - z * z) * (Es - m * gr * R * (1 - al * z)) - I3 * n * n / (2 * I1**2 * R**2)

    return P


def _mp_band_and_period(top, E, D, lam, z_guess, dps=40):
    """Turning points and period from docs/theory/mett.md#the-main-equation in mpmath (independent of mett's code).

    P(z) = (1 − z²)(E − D²/(2I1) + mλ²/(2I1I3) − mgR(1 − αz)) − I3 N²/(2 I1² R²),
    T = 2 ∫ √(g/P) dz over the band, with z = c + h sin u (tanh-sinh quadrature in u).
    """
    with mpmath.workdps(dps):
        mp = mpmath.mpf
        m, R, al, I1 = (mp(v) for v in (top.m, top.R, top.alpha, top.I1))
        P = _mp_P(top, E, D, lam)

        def gfun(z):
            return (I1 + m * R**2 * (1 + al**2 - 2 * al * z)) / 2

        # Roots to full working precision from a bracket around the guesses (tanh-sinh puts nodes
        # ~1e-40 from the ends, so a root that is only good to 1e-20 would spoil the period).
        delta = mp(1e-6) * (mp(z_guess[1]) - mp(z_guess[0]))
        a, b = (
            mpmath.findroot(P, (mp(zg) - delta, mp(zg) + delta), solver="anderson")
            for zg in z_guess
        )
        c, h = (a + b) / 2, (b - a) / 2

        def integrand(u):
            z = c + h * mpmath.sin(u)
            return h * mpmath.cos(u) * mpmath.sqrt(gfun(z) / P(z))

        T = 2 * mpmath.quad(integrand, [-mpmath.pi / 2, 0, mpmath.pi / 2])
        return float(a), float(b), float(mpmath.re(T))


def _naive_f(top, z, E, D, lam):
    """(1 − z²)(E − V(z))/g(z) straight from mett.V in double precision."""
    return (1 - z * z) * (E - mett.V(top, z, D, lam)) / mett.g(top, z)


def _naive_band_and_period(top, E, D, lam, z_min, z_guess):
    fn = functools.partial(_naive_f, top, E=E, D=D, lam=lam)
    lo = 2 * z_guess[0] - z_min
    hi = 2 * z_guess[1] - z_min
    za, zb = optimize.brentq(fn, lo, z_min), optimize.brentq(fn, z_min, hi)
    u, w = np.polynomial.legendre.leggauss(96)
    u, w = 0.5 * np.pi * u, 0.5 * np.pi * w
    c, h = 0.5 * (za + zb), 0.5 * (zb - za)
    with np.errstate(invalid="ignore", divide="ignore"):
        T = 2 * np.dot(w, h * np.cos(u) / np.sqrt(fn(c + h * np.sin(u))))
    return za, zb, T


def _mp_f(top, z, E, D, lam, dps=40):
    """f(z) = P(z)/g(z) of docs/theory/mett.md#the-main-equation evaluated in mpmath, at each z of an array."""
    out = []
    with mpmath.workdps(dps):
        mp = mpmath.mpf
        m, R, al, I1 = (mp(v) for v in (top.m, top.R, top.alpha, top.I1))
        P = _mp_P(top, E, D, lam)
        for zz in np.asarray(z, dtype=float):
            zz = mp(zz)
            out.append(float(P(zz) / ((I1 + m * R**2 * (1 + al**2 - 2 * al * zz)) / 2)))
    return np.array(out)


@pytest.mark.parametrize("omega3", [3000.0, 1e4])
def test_naive_double_precision_potential_fails_at_high_spin_while_mett_stays_exact(omega3):
    top = BODIES["rutstam2013"]
    E, D, lam = _integrals(top, 1.0, omega3)
    b = mett.band(top, E, D, lam)
    T = mett.nutation_period(top, E, D, lam)
    za, zb, T_mp = _mp_band_and_period(top, E, D, lam, (b.z_low, b.z_high))
    width = zb - za  # 1.7e-5 (3000 rad/s), 1.5e-6 (1e4): E − V in the band is ≲ 1e-8 J of E ≈ 14 J

    # f = (1 − z²)(E − V)/g straight from mett.V in double: E − V keeps only ~5 (3000 rad/s) or
    # ~3 (1e4) of its digits (measured relative errors 1.4e-6, 6e-5) ...
    z = np.linspace(za, zb, 21)[1:-1]
    f_exact = _mp_f(top, z, E, D, lam)
    naive_err = np.max(np.abs(_naive_f(top, z, E, D, lam) - f_exact)) / f_exact.max()
    assert naive_err > 1e-7
    # ... so near the turning points it is pure rounding noise: its roots are off by ≥ 1e-7 of the
    # width (vs ≤ 4e-16 absolute for mett) and the quadrature mett uses, fed with it, returns a
    # non-finite period (f ≤ 0 at a node next to an end).
    na, nb, T_naive = _naive_band_and_period(top, E, D, lam, b.z_min, (b.z_low, b.z_high))
    naive_edge = max(abs(na - za), abs(nb - zb))
    if omega3 >= 1e4:  # at 3000 rad/s whether the noisy roots land near the true ones is luck
        assert naive_edge > 1e-7 * width
        assert not np.isfinite(T_naive) or abs(T_naive - T_mp) > 1e-4 * T_mp
        assert naive_edge > 1000 * 4e-16

    # mett: f, the band and the period stay right.
    f_err = np.max(np.abs(mett.f(top, z, E, D, lam) - f_exact)) / f_exact.max()
    assert f_err < 1e-8  # measured 1.2e-10 (3000), 1.2e-9 (1e4)
    assert max(abs(b.z_low - za), abs(b.z_high - zb)) <= 4e-16
    assert (b.z_high - b.z_low) == pytest.approx(width, rel=1e-8)
    assert T == pytest.approx(T_mp, rel=1e-10)  # measured ≤ 2e-12


@pytest.mark.parametrize("omega3", [3000.0, 3e4])
def test_period_exact_at_high_spin_against_mpmath(omega3):
    # mett places its quadrature nodes as offsets from the bottom of the well: with nodes in
    # absolute z the period was off by ~1e-7 at 3000 rad/s and ~1e-5 at 3e4 rad/s.
    top = BODIES["rutstam2012"]
    E, D, lam = _integrals(top, 0.5, omega3)
    zl, zh = mett.turning_points(top, E, D, lam)
    _, _, T_mp = _mp_band_and_period(top, E, D, lam, (zl, zh))
    assert mett.nutation_period(top, E, D, lam) == pytest.approx(T_mp, rel=1e-10)


# --- quadrature convergence -------------------------------------------------------------------


def _numpy_P(top, z, E, D, lam):
    """P(z) = (1 − z²)(E − V(z)) from the expanded form of docs/theory/mett.md#the-main-equation, written out here."""
    m, R, a, I1, I3, gr = top.m, top.R, top.alpha, top.I1, top.I3, top.g
    dz = top.gamma + top.sigma * (a - z) ** 2 + top.sigma * top.gamma * (1 - z * z)
    kin = (
        lam**2 * (I1 + m * R**2 * (a - z) ** 2)
        + 2 * R * I3 * lam * D * (a - z) * np.sqrt(dz)
        + R**2 * D**2 * (I1 * (1 - z * z) + I3 * (a - z) ** 2)
    ) / (2 * I1**2 * R**2)
    return (1 - z * z) * (E - m * gr * R * (1 - a * z)) - kin


@pytest.mark.parametrize("body", list(BODIES))
@pytest.mark.parametrize(("theta", "phidot"), [(1.0, 5.0), (2.2, -20.0), (0.5, 40.0)])
def test_period_converged_with_default_nodes_against_adaptive_quad(body, theta, phidot):
    # Moderate spin and a wide band (φ̇0 ≠ 0), where the double-precision P above is accurate to
    # ~1e-13 of its maximum: scipy's adaptive quad of the same sin-substituted integral, with the
    # turning points re-found from this independent P. (Narrow bands, where a double P is not
    # good enough for an adaptive rule, are checked against mpmath above.)
    top = BODIES[body]
    E, D, lam = _integrals(top, theta, 100.0, phidot)
    zl, zh = mett.turning_points(top, E, D, lam)
    P = functools.partial(_numpy_P, top, E=E, D=D, lam=lam)
    zm = mett.band(top, E, D, lam).z_min
    a = optimize.brentq(P, max(-1.0, zl - 1e-9), zm, xtol=1e-16, rtol=1e-15)
    b = optimize.brentq(P, zm, min(1.0, zh + 1e-9), xtol=1e-16, rtol=1e-15)
    c, h = (a + b) / 2, (b - a) / 2

    def integrand(u):
        z = c + h * math.sin(u)
        p = P(z)
        return h * math.cos(u) * math.sqrt(float(mett.g(top, z)) / p) if p > 0 else 0.0

    half, err = sint.quad(integrand, -math.pi / 2, math.pi / 2, epsabs=0, epsrel=1e-12, limit=200)
    T_quad = 2 * half
    assert err < 1e-11 * half  # measured ≤ 4e-13
    # Measured agreement ≤ 7e-12: the 96-node Gauss–Legendre rule is converged.
    assert mett.nutation_period(top, E, D, lam) == pytest.approx(T_quad, rel=3e-11)


# --- the bottom of the well: steady precession and inadmissible energies ---------------------


@pytest.mark.parametrize("body", list(BODIES))
def test_period_tends_to_small_oscillation_limit_at_bottom_of_well(body):
    top = BODIES[body]
    _, D, lam = _integrals(top, 1.0, 100.0, 5.0)
    zm = float(mett.band(top, 1.0, D, lam).z_min)  # the well's position does not depend on E
    V_min = float(mett.V(top, zm, D, lam))
    omega = math.sqrt((1 - zm**2) * float(mett.d2V_dz2(top, zm, D, lam)) / (2 * mett.g(top, zm)))
    T_small = 2 * math.pi / omega  # docs/theory/estimates.md#estimates
    errors = []
    for eps in (1e-4, 1e-6, 1e-8):
        T = mett.nutation_period(top, V_min + eps * V_min, D, lam)
        errors.append(abs(T / T_small - 1))
    # Anharmonic correction ∝ depth: the error falls 100× per 100× in depth.
    assert errors[0] < 1e-2
    assert errors[1] == pytest.approx(errors[0] * 1e-2, rel=0.05)
    assert errors[2] == pytest.approx(errors[0] * 1e-4, rel=0.1)  # still exact at depth 1e-8 V
    # At the bottom itself: steady precession, with the small-oscillation period.
    assert mett.classify_motion(top, V_min, D, lam) == "steady"
    assert mett.nutation_period(top, V_min, D, lam) == pytest.approx(T_small, rel=1e-9)
    np.testing.assert_allclose(mett.turning_points(top, V_min, D, lam), [zm, zm], atol=1e-9)


@pytest.mark.parametrize("body", list(BODIES))
def test_energy_below_the_well_is_rejected(body):
    top = BODIES[body]
    _, D, lam = _integrals(top, 1.0, 100.0, 5.0)
    zm = float(mett.band(top, 1.0, D, lam).z_min)
    E = float(mett.V(top, zm, D, lam)) * (1 - 1e-9)
    assert mett.classify_motion(top, E, D, lam) == "none"
    with pytest.raises(ValueError, match="admits no motion"):
        mett.turning_points(top, E, D, lam)
    with pytest.raises(ValueError, match="admits no motion"):
        mett.nutation_period(top, E, D, lam)


# --- a band that reaches the pole (D = D0) ----------------------------------------------------


@pytest.mark.parametrize("body", list(BODIES))
@pytest.mark.parametrize("thetadot", [0.3, 3.0])
def test_band_reaching_the_pole_matches_top_started_upright(body, thetadot):
    # A top started exactly at θ = 0 has D = D0(λ) (docs/theory/thresholds.md#boundary-values) and E = E0 + g(1) θ̇²; its axis
    # swings out to z_low and back through the vertical, so z oscillates in [z_low, 1].
    top = BODIES[body]
    omega3 = 150.0
    _, _, lam = _integrals(top, 0.0, omega3, 0.0, thetadot)
    bv = mett.boundary_values(top, lam)
    D = float(bv.D0)
    E = float(bv.E0) + float(mett.g(top, 1.0)) * thetadot**2
    run = _run(body, 0.0, 0.0, omega3, thetadot)
    E_ref, lam_ref, D_ref = rr.integrals(top, run.y0)
    assert (E_ref, D_ref, lam_ref) == pytest.approx((E, D, lam), rel=1e-14)

    b = mett.band(top, E, D, lam)
    assert b.kind == "nutation"
    assert b.z_high == 1.0
    assert b.z_low == pytest.approx(run.z_low.mean(), abs=2e-10)
    assert run.z_high.min() > 1 - 1e-12  # the reference really passes through the vertical
    assert mett.nutation_period(top, E, D, lam) == pytest.approx(run.period, rel=2e-10)


def test_band_at_the_pole_tends_to_spinning_small_oscillation_limit():
    # Kicks of decreasing size: z oscillates in [1 − O(θ̇²), 1] with ω² → 2|V'(1)|/g(1).
    top = BODIES["rutstam2013"]
    lam = float(mett.jellett(top, mett.State(theta=0.0, omega3=150.0)))
    bv = mett.boundary_values(top, lam)
    D, E0 = float(bv.D0), float(bv.E0)
    T0 = mett.nutation_period(top, E0, D, lam)  # steady spin: the limit itself
    assert mett.classify_motion(top, E0, D, lam) == "steady"
    slope = abs(float(mett.dV_dz(top, 1.0, D, lam)))
    assert T0 == pytest.approx(2 * math.pi / math.sqrt(2 * slope / float(mett.g(top, 1.0))))
    errs = [abs(mett.nutation_period(top, E0 + eps * E0, D, lam) / T0 - 1) for eps in (1e-3, 1e-5)]
    assert errs[1] < 0.02 * errs[0]


# --- array inputs and f ------------------------------------------------------------------------


def test_array_energies_broadcast_against_scalar_D_and_lambda():
    top = BODIES["rutstam2012"]
    E1, D, lam = _integrals(top, 1.0, 100.0, 5.0)
    zm = float(mett.band(top, E1, D, lam).z_min)
    V_min = float(mett.V(top, zm, D, lam))
    E = V_min + (E1 - V_min) * np.array([[0.25, 0.5], [1.0, 2.0], [4.0, 8.0]])
    T = mett.nutation_period(top, E, D, lam)
    tp = mett.turning_points(top, E, D, lam)
    mean = mett.mean_precession(top, E, D, lam)
    kinds = mett.classify_motion(top, E, D, lam)
    assert T.shape == mean.shape == kinds.shape == (3, 2)
    assert tp.shape == (3, 2, 2)
    for idx in np.ndindex(E.shape):
        e = float(E[idx])
        assert T[idx] == mett.nutation_period(top, e, D, lam)
        assert mean[idx] == mett.mean_precession(top, e, D, lam)
        np.testing.assert_array_equal(tp[idx], mett.turning_points(top, e, D, lam))
        assert kinds[idx] == "nutation"
    assert np.all(np.diff(tp[..., 1].ravel()) > 0)  # more energy, wider band
    assert np.all(np.diff(tp[..., 0].ravel()) < 0)


@pytest.mark.parametrize("body", list(BODIES))
def test_f_equals_naive_formula_at_moderate_spin(body):
    top = BODIES[body]
    E, D, lam = _integrals(top, 1.0, 50.0, 5.0)
    zl, zh = mett.turning_points(top, E, D, lam)
    z = np.linspace(zl - 0.1, zh + 0.1, 41)
    naive = _naive_f(top, z, E, D, lam)
    np.testing.assert_allclose(mett.f(top, z, E, D, lam), naive, rtol=0, atol=1e-10 * naive.max())


@pytest.mark.parametrize("body", list(BODIES))
@pytest.mark.parametrize(("theta", "phidot", "omega3"), [(1.0, 5.0, 50.0), (2.2, 0.0, 300.0)])
def test_f_equals_zdot_squared_along_rolling_integration(body, theta, phidot, omega3):
    top = BODIES[body]
    E, D, lam = _integrals(top, theta, omega3, phidot)
    T = mett.nutation_period(top, E, D, lam)
    times = np.linspace(0.0, 1.3 * T, 23)
    run = rr.integrate(top, rr.initial_state(theta, 0.0, phidot, omega3), periods=2, t_eval=times)
    n, w = run.y_samples[:3], run.y_samples[3:]
    zdot = w[0] * n[1] - w[1] * n[0]  # (ω × 3̂)·ẑ
    f = mett.f(top, np.clip(n[2], -1, 1), E, D, lam)
    scale = float(np.max(zdot**2))
    np.testing.assert_allclose(f, zdot**2, rtol=0, atol=1e-9 * scale)


@pytest.mark.parametrize("body", list(BODIES))
def test_planar_rocking_band_runs_from_the_start_to_the_pole(body):
    # ω3 = φ̇ = 0: λ = D = 0, N ≡ 0 and V = m g R(1 − αz) has its minimum at the pole z = 1; the
    # sphere rocks in a vertical plane through the vertical, so z runs over [cos θ0, 1].
    top = BODIES[body]
    theta0 = 1.0
    E, D, lam = _integrals(top, theta0, 0.0)
    assert D == lam == 0.0
    run = rr.integrate(top, rr.initial_state(theta0, 0.0, 0.0, 0.0), periods=3, track_phi=False)
    zl, zh = mett.turning_points(top, E, D, lam)
    assert zh == 1.0
    assert zl == pytest.approx(math.cos(theta0), abs=1e-15)
    np.testing.assert_allclose(run.z_low, zl, rtol=0, atol=2e-10)
    assert mett.nutation_period(top, E, D, lam) == pytest.approx(run.period, rel=2e-10)
