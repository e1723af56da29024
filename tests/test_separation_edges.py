"""The separation layer at its edges, against an independent mpmath reference (tests/mp_separation.py).

Regimes (issue 12): starts ε = 1e-3 … 1e-9 from either pole with vanishing spins, the separatrix of
the unstable inverted pole (log-divergent period, κ from the curvature of V and g there), spins up
to 1e6 rad/s with and without the start z0, and the spinning-pole families D = D0, D1. The doubles
(E, D, λ) are the exact inputs of the reference; where they determine the answer to less than 1e-8
(high spin: the depth of the band is below the rounding of E) the bound used is stated.
"""

from __future__ import annotations

import math
import warnings

import mp_separation as mps
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import mett
from mett import separation as sep

TOP = mett.presets.get("rutstam2013")


def _integrals(top, s):
    return [float(f(top, s)) for f in (mett.energy, mett.routh, mett.jellett)]


def _all(top, E, D, lam, z0):
    kw = {} if z0 is None else {"z0": z0}
    zl, zh = mett.turning_points(top, E, D, lam, **kw)
    T = float(mett.nutation_period(top, E, D, lam, **kw))
    prec = float(mett.mean_precession(top, E, D, lam, **kw))
    return zl, zh, T, prec


# --- starts next to a pole with vanishing spin ---------------------------------------------------

# cos θ0 must differ from ±1 in double: from the inverted pole that holds down to ε ≈ 2e-8 (ulp
# 1.1e-16 next to −1), from the upright one down to ε ≈ 1.5e-8 (cos ε = 1 − ε²/2).
_NEAR_POLE = [
    (pole, eps, w3)
    for pole in ("inverted", "upright")
    for eps in (1e-3, 1e-4, 1e-5, 1e-6, 1e-7)
    for w3 in (0.0, 1e-3, 1e-2)
]
_CI = {("inverted", 1e-6, 0.0), ("inverted", 1e-6, 1e-3), ("upright", 1e-5, 1e-2)}


def _near_pole_params():
    for case in _NEAR_POLE:
        marks = [pytest.mark.slow] + ([pytest.mark.ci] if case in _CI else [])
        yield pytest.param(*case, marks=marks)


@pytest.mark.parametrize(("pole", "eps", "omega3"), list(_near_pole_params()))
def test_start_next_to_a_pole_against_mpmath(pole, eps, omega3):
    theta = math.pi - eps if pole == "inverted" else eps
    z0 = math.cos(theta)
    E, D, lam = _integrals(TOP, mett.State(theta=theta, omega3=omega3))
    zl, zh, T, prec = _all(TOP, E, D, lam, z0)
    ref = mps.reference(TOP, E, D, lam, z0, dps=40)
    if pole == "upright" and eps <= 1e-7:
        # z0 is 45 ulps from the pole, N(1) within 64 ulps of its terms and Ẽ − V(1) within the
        # well's rounding: steady at the spinning pole, whose small-oscillation period is the
        # band's to ~1e-12; ⟨φ̇⟩ jumps by π/T with the sign of N(1), which the inputs do not fix
        assert zl == zh == 1.0
        assert T == pytest.approx(ref.period, rel=1e-8)
        return
    assert zl == pytest.approx(ref.z_low, abs=4e-16)
    assert zh == pytest.approx(ref.z_high, abs=4e-16)
    assert T == pytest.approx(ref.period, rel=1e-10)
    assert prec == pytest.approx(ref.precession, rel=1e-8, abs=1e-10)


@pytest.mark.parametrize("omega3", [0.0, 1e-3, 1e-2, 5.0])
def test_start_on_the_inverted_pole_is_the_separatrix(omega3):
    # ε = 1e-8: cos θ0 rounds to −1, the start is the (unstable) pole itself. With the start z0
    # given, Ẽ = V(−1) within the rounding of the inputs is taken as a start at rest there.
    sqd = math.sqrt(float(mett.d(TOP, -1.0)))
    for theta in (math.pi, math.pi - 1e-8):
        E, D, lam = _integrals(TOP, mett.State(theta=theta, omega3=omega3))
        b = mett.band(TOP, E, D, lam)
        assert b.kind == "nutation" and b.z_low == -1.0
        assert math.isinf(mett.nutation_period(TOP, E, D, lam, z0=-1.0))
        # ⟨φ̇⟩ → φ̇ at the pole: −p N'(p)/(2 R I1 √d(p)), p = −1, N' = λ d'/(2√d) − R D
        n1 = lam * float(mett.potential.dd_dz(TOP, -1.0)) / (2 * sqd) - TOP.R * D
        limit = n1 / (2 * TOP.R * TOP.I1 * sqd)
        prec = mett.mean_precession(TOP, E, D, lam, z0=-1.0)
        assert prec == pytest.approx(limit, rel=1e-12, abs=1e-300)


@pytest.mark.slow
@pytest.mark.ci
def test_energy_of_a_state_on_the_inverted_pole_without_the_start_is_taken_as_exact():
    # Without z0 the doubles (Ẽ, D, λ) are exact: Ẽ − V(−1) of the rounded energy is a few ulps,
    # not 0, and the period is the finite one of those doubles (the mpmath reference's)
    E, D, lam = _integrals(TOP, mett.State(theta=math.pi, omega3=0.0))
    b = mett.band(TOP, E, D, lam)
    T = float(mett.nutation_period(TOP, E, D, lam))
    ref = mps.reference(TOP, E, D, lam, 0.5 * (b.z_low + b.z_high), dps=50)
    assert math.isfinite(ref.period) and T == pytest.approx(ref.period, rel=1e-12)


# --- the separatrix: log divergence with the closed-form κ --------------------------------------


def _kappa(top, D, lam):
    """κ = √(−V'(−1)/(2 g(−1))) at the inverted pole with N(−1) = 0 (docs/theory/mett.md).

    Near z = −1, with u = 1 + z, P(u) ≈ 2 A u + b u², A = Ẽ − V(−1), b = 2 m g R α − C N'(−1)²
    = −2 V'(−1), so T ≈ 2 √(g/b) ln(1/|u_t|) with u_t = 2|A|/b: T ≈ −(1/κ) ln|A|, κ = ½ √(b/g).
    """
    m, R, a, I1, I3, grav = top.m, top.R, top.alpha, top.I1, top.I3, top.g
    gam, sig = I1 / I3, m * R**2 / I3
    dm1 = gam + sig * (a + 1.0) ** 2
    ddm1 = -2.0 * sig * (a + 1.0 - gam)  # d'(−1) = −2σ(α − z + γz) at z = −1
    n1 = lam * ddm1 / (2.0 * math.sqrt(dm1)) - R * D
    C = I3 / (2.0 * I1**2 * R**2)
    b = 2.0 * m * grav * R * a - C * n1 * n1
    g1 = 0.5 * (I1 + m * R**2 * (1.0 + a) ** 2)
    return 0.5 * math.sqrt(b / g1)


@pytest.mark.parametrize("lam", [0.0, 1e-6, -1.5e-6])
@pytest.mark.parametrize("side", [-1.0, 1.0])
def test_period_diverges_logarithmically_at_the_separatrix_with_closed_form_kappa(lam, side):
    # D = D1(λ): N(−1) = 0, the inverted pole unstable for |λ| below ~2e-6 (b > 0). Below E1
    # (side −1) the band stops short of the pole; above (side +1) it passes over it. Either way T ~ −(1/κ) ln|E − E1|.
    bv = mett.boundary_values(TOP, lam)
    D, E1 = float(bv.D1), float(bv.E1)
    kappa = _kappa(TOP, D, lam)
    assert kappa > 0.0
    deltas = [1e-6, 1e-8, 1e-10]
    T = [float(mett.nutation_period(TOP, E1 * (1.0 + side * dl), D, lam)) for dl in deltas]
    slopes = [(T[i + 1] - T[i]) / math.log(deltas[i] / deltas[i + 1]) for i in range(2)]
    # slope of T against −ln|E − E1|: 1/κ up to O(δ ln δ). One z-period (turning point → far
    # wall → turning point) passes the pole once, so there is one log term, not two.
    assert slopes[-1] == pytest.approx(1.0 / kappa, rel=1e-4)
    assert abs(slopes[-1] - 1.0 / kappa) < abs(slopes[0] - 1.0 / kappa) + 1e-9
    # E1 rounded to a double lies ~1e-18 J off the separatrix: longer still (or inf if exact)
    assert float(mett.nutation_period(TOP, E1, D, lam)) > T[-1]


@pytest.mark.slow  # CI runs the separatrix one ulp away (test_period_within_ulps_...)
def test_separatrix_periods_against_mpmath():
    lam = 1e-6  # the inverted pole unstable (λ below ~2e-6 for this body)
    bv = mett.boundary_values(TOP, lam)
    D, E1 = float(bv.D1), float(bv.E1)
    for dl in (-1e-9, 1e-9):
        E = E1 * (1.0 + dl)
        b = mett.band(TOP, E, D, lam)
        ref = mps.reference(TOP, E, D, lam, 0.5 * (b.z_low + b.z_high), dps=40)
        assert float(mett.nutation_period(TOP, E, D, lam)) == pytest.approx(ref.period, rel=1e-9)


# --- very high spin -------------------------------------------------------------------------------

_PRESETS = ("rutstam2013", "cohen1977", "ueda2005")
_HIGH = [(0.1, 1e4), (0.5, 1e5), (1.0, 3e4), (2.0, 1e5), (2.5, 1e6), (3.0, 3e5)]


def _high_params():
    for preset in _PRESETS:
        for theta, w3 in _HIGH:
            ci = preset == "rutstam2013" and (theta, w3) in {(0.5, 1e5), (2.5, 1e6)}
            marks = [pytest.mark.slow] + ([pytest.mark.ci] if ci else [])
            yield pytest.param(preset, theta, w3, marks=marks)


@pytest.mark.parametrize(("preset", "theta", "omega3"), list(_high_params()))
def test_high_spin_against_mpmath_with_and_without_z0(preset, theta, omega3):
    top = mett.presets.get(preset)
    z0 = math.cos(theta)
    E, D, lam = _integrals(top, mett.State(theta=theta, omega3=omega3))
    ref = mps.reference(top, E, D, lam, z0, dps=70, start=True)
    h = 0.5 * (ref.z_high - ref.z_low)
    for kw in (z0, None):
        zl, zh, T, prec = _all(top, E, D, lam, kw)
        # the period does not depend on where the narrow band lies: fully determined
        assert T == pytest.approx(ref.period, rel=1e-8)
        # the band is determined by (E, D, λ) to the rounding of E against its depth (~εS per h)
        S = abs(E) + D * D / (2 * top.I1) + top.m * lam * lam / (2 * top.I1 * top.I3)
        b = sep.band(top, E, D, lam, z0=z0)
        # (where E had to be raised onto V(z0), by up to one ulp of E, the band is known to ~h)
        h_max = max(h, 0.5 * float(b.z_high - b.z_low))
        slack = h_max * min(1.0, 1e4 * 2.2e-16 * S / max(float(b.depth), 1e-300))
        assert abs(zl - ref.z_low) <= slack + 4e-16
        assert abs(zh - ref.z_high) <= slack + 4e-16
        # ⟨φ̇⟩ = φ̇ of a band of width ~1/ω3², N a tiny difference of terms ~ I3 ω3 R: its relative
        # condition is ε(|λ√d| + |R D (α − z)|)/|N|, ~1e-7 at 1e6 rad/s
        sqd = math.sqrt(float(mett.d(top, z0)))
        n0 = abs(lam) * sqd + abs(top.R * D * (top.alpha - z0))
        n = abs(top.R * top.I1 * ref.precession * (1 - z0 * z0) * sqd)
        assert prec == pytest.approx(ref.precession, rel=max(1e-8, 1e3 * 2.2e-16 * n0 / n))


@pytest.mark.slow
@pytest.mark.ci
def test_high_spin_vectorised_call_is_not_aborted_by_one_element():
    theta = np.array([0.1, 0.5, 1.0, 2.0, 2.5, 3.0, 0.5])
    w3 = np.array([1e4, 1e5, 3e4, 1e5, 1e6, 3e5, 100.0])
    s = mett.State(theta=theta, omega3=w3)
    E, D, lam = (
        np.asarray(f(TOP, s), dtype=float) for f in (mett.energy, mett.routh, mett.jellett)
    )
    z0 = np.cos(theta)
    T = mett.nutation_period(TOP, E, D, lam, z0=z0)
    T_free = mett.nutation_period(TOP, E, D, lam)
    assert np.all(np.isfinite(T)) and np.all(np.isfinite(T_free))
    for i in range(theta.size):  # scalar calls: the same numbers, bit for bit
        assert float(mett.nutation_period(TOP, E[i], D[i], lam[i], z0=z0[i])) == T[i]
    assert np.all(np.isfinite(mett.mean_precession(TOP, E, D, lam, z0=z0)))


def test_genuinely_inadmissible_start_still_raises():
    E, D, lam = _integrals(TOP, mett.State(theta=0.5, omega3=1e5))
    z0 = math.cos(0.5)
    with pytest.raises(ValueError, match="z0"):
        mett.nutation_period(TOP, E, D, lam, z0=z0 + 1e-4)  # 1e4 band widths away
    with pytest.raises(ValueError, match="z0"):
        mett.nutation_period(TOP, E * (1 - 1e-7), D, lam, z0=z0)  # 1e8 × the inputs' rounding


def test_cli_period_at_high_spin_exits_zero(capsys):
    from mett import cli

    assert cli.main(
        ["period", "--preset", "rutstam2013", "--theta0", "0.5", "--omega3", "1e5"]
    ) in (0, None)
    assert "nutation period" in capsys.readouterr().out


# --- spinning poles and the mean precession -------------------------------------------------------


@pytest.mark.parametrize("branch", ["D0", "D1"])
def test_mean_precession_finite_next_to_a_spinning_pole_without_warning(branch):
    bv = mett.boundary_values(TOP, 0.005)
    D, E = (bv.D0, bv.E0) if branch == "D0" else (bv.D1, bv.E1)
    values = []
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for f in (1.0, 1 + 1e-12, 1 + 1e-9, 1 + 1e-6):
            values.append(float(mett.mean_precession(TOP, E * f, D, 0.005)))
    assert np.all(np.isfinite(values))
    # steady at the pole: the pole limit, which the bands shrinking onto it tend to
    assert values[2] == pytest.approx(values[0], rel=1e-6)
    assert values[3] == pytest.approx(values[0], rel=1e-3)


@pytest.mark.slow
@pytest.mark.ci
def test_band_next_to_a_spinning_pole_against_mpmath():
    bv = mett.boundary_values(TOP, 0.005)
    E = bv.E1 * (1 + 1e-6)
    b = mett.band(TOP, E, bv.D1, 0.005)
    ref = mps.reference(TOP, E, bv.D1, 0.005, 0.5 * (b.z_low + b.z_high), dps=40)
    # N(−1) of the rounded D1 is 1e-18 (snapped to 0): a shift of ~C N'·N(−1) in the energy,
    # relative 2e-10 of E − E1 here
    assert float(mett.nutation_period(TOP, E, bv.D1, 0.005)) == pytest.approx(ref.period, rel=1e-8)


_theta = st.floats(0.0, math.pi)
_spin = st.one_of(st.just(0.0), st.floats(-7.0, 5.0).map(lambda x: 10.0**x))


@pytest.mark.slow
@pytest.mark.ci
@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    theta=st.one_of(_theta, st.floats(-9.0, -1.0).map(lambda x: math.pi - 10.0**x),
                    st.floats(-9.0, -1.0).map(lambda x: 10.0**x)),
    omega3=_spin,
    phidot=st.floats(-30.0, 30.0),
    thetadot=st.one_of(st.just(0.0), st.floats(-10.0, 10.0)),
)  # fmt: skip
def test_mean_precession_finite_on_every_band(theta, omega3, phidot, thetadot):
    s = mett.State(theta=theta, omega3=omega3, phidot=phidot, thetadot=thetadot)
    E, D, lam = _integrals(TOP, s)
    z0 = math.cos(theta)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        prec = float(mett.mean_precession(TOP, E, D, lam, z0=z0))
        T = float(mett.nutation_period(TOP, E, D, lam, z0=z0))
    assert math.isfinite(prec)
    assert T > 0.0  # inf only on the separatrix


# --- within a few ulps of the separatrix ------------------------------------------------------

_ULPS = [1, 4, 16, 64, 1000]


def _separatrix_params():
    for lam in (0.0, 1e-6):
        for side in (-1, 1):
            for k in [*_ULPS, "1e-12"]:
                # in CI: one ulp on each side of the separatrix (64 ulps and the rest: -m slow)
                ci = k == 1 and lam == 1e-6
                marks = [pytest.mark.slow] + ([pytest.mark.ci] if ci else [])
                yield pytest.param(lam, side, k, marks=marks, id=f"{lam}-{side}-{k}")


@pytest.mark.parametrize(("lam", "side", "k"), list(_separatrix_params()))
def test_period_within_ulps_of_the_separatrix_against_mpmath(lam, side, k):
    # Ẽ = E1 ± k ulps (or ± 1e-12 relative), D = D1(λ) rounded. Below E1 the band stops a hair
    # short of the inverted pole; above it passes over it. The doubles are exact inputs: A = Ẽ −
    # V(−1) is formed exactly, and with N(−1) zero only to rounding (λ = 1e-6) its cross term
    # shifts the separatrix by ~ulps of Ẽ (a 1/δ error of T if it were dropped). Was: inf within
    # 64 ulps above E1, and a 1e-5 error at 100 ulps.
    bv = mett.boundary_values(TOP, lam)
    D, E1 = float(bv.D1), float(bv.E1)
    E = E1 * (1.0 + side * 1e-12) if k == "1e-12" else E1 + side * k * math.ulp(E1)
    b = mett.band(TOP, E, D, lam)
    T = float(mett.nutation_period(TOP, E, D, lam))
    prec = float(mett.mean_precession(TOP, E, D, lam))
    ref = mps.reference(TOP, E, D, lam, 0.5 * (b.z_low + b.z_high), dps=50)
    assert math.isfinite(T)
    # the Gauss rules reach ~1e-14 of T (the log layer resolved by the sinh map)
    assert T == pytest.approx(ref.period, rel=1e-12)
    n = mps_N(D, lam)
    jump = 0.0
    if b.z_low == -1.0 and n != 0:  # over the pole: the ±π of the exact N(−1) left out
        jump = math.copysign(math.pi, n) / T
    assert prec + jump == pytest.approx(ref.precession, rel=1e-10, abs=1e-12)


def mps_N(D, lam, dps=60):
    """N(−1) = λ√d(−1) + R D(α + 1) at ``dps`` digits, the doubles taken as exact."""
    import mpmath

    with mpmath.workdps(dps):
        mp = mpmath.mpf
        m, R, a, I1, I3 = (mp(v) for v in (TOP.m, TOP.R, TOP.alpha, TOP.I1, TOP.I3))
        d = I1 / I3 + m * R**2 / I3 * (a + 1) ** 2
        return float(mp(lam) * mpmath.sqrt(d) + R * mp(D) * (a + 1))
