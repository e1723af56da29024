"""Bands with an end at or next to a pole, against the mpmath reference (tests/mp_separation.py).

- A band reaching a pole where N(±1) is zero only to rounding: the value returned leaves out the
  ±π jump of the precession angle at the pole (documented in mett.mean_precession); the exact
  inputs, as the reference takes them, add sign(N(±1)) π/T, with the sign from N(±1) at 60 digits.
- Starts at or a hair off a pole that used to give NaN (found by hypothesis in
  test_separation_edges.py): walls a few ulps off the pole, both ends next to one pole, N(±1)
  whose square underflows.
"""

from __future__ import annotations

import math
import warnings

import mp_separation as mps
import mpmath
import pytest

import mett

TOP = mett.presets.get("rutstam2013")


def _integrals(s):
    return [float(f(TOP, s)) for f in (mett.energy, mett.routh, mett.jellett)]


def _N_exact(D, lam, pole, dps=60):
    """N(±1) = λ√d(±1) + R D(α ∓ 1) at ``dps`` digits, the doubles taken as exact."""
    with mpmath.workdps(dps):
        mp = mpmath.mpf
        m, R, a, I1, I3 = (mp(v) for v in (TOP.m, TOP.R, TOP.alpha, TOP.I1, TOP.I3))
        d = I1 / I3 + m * R**2 / I3 * (a - pole) ** 2
        return lam * mpmath.sqrt(d) + R * mp(D) * (a - pole)


@pytest.mark.slow
@pytest.mark.parametrize("lam", [pytest.param(1e-6, marks=pytest.mark.ci), -1.5e-6, 5e-6], ids=str)
def test_band_over_the_inverted_pole_omits_the_jump_of_the_exact_inputs(lam):
    # D = D1(λ) rounded: N(−1) is a few ulps of its terms; above E1 the band passes over z = −1
    bv = mett.boundary_values(TOP, lam)
    D, E = float(bv.D1), float(bv.E1) * (1.0 + 1e-3)
    b = mett.band(TOP, E, D, lam)
    assert b.kind == "nutation" and b.z_low == -1.0
    n = _N_exact(D, lam, -1.0)
    assert n != 0 and abs(n) < 1e-20  # zero to rounding, not exactly
    T = float(mett.nutation_period(TOP, E, D, lam))
    prec = float(mett.mean_precession(TOP, E, D, lam))
    ref = mps.reference(TOP, E, D, lam, 0.5 * (b.z_low + b.z_high), dps=60)
    assert T == pytest.approx(ref.period, rel=1e-10)
    jump = math.copysign(math.pi, float(n)) / T
    assert abs(ref.precession - prec) == pytest.approx(math.pi / T, rel=1e-9)  # the jump itself
    assert prec + jump == pytest.approx(ref.precession, rel=1e-9, abs=1e-9 * abs(jump))


# hypothesis's failing examples: (θ0, ω3, φ̇0) of a start at rest in θ
_NAN_CASES = [
    (3.1415925535897933, 1000.0, 0.0),  # both ends next to the inverted pole, one at it
    (3.141592643589793, 1e-3, 1.0),  # z0 = −1: a wall 4 ulps off the pole, not the pole
    (3.141592643589793, 0.0, 4.5692083816187965e-139),  # C N(±1)² underflows
    (3.141592652589793, 0.0, 4.5692083816187965e-139),
    (1e-4, 0.0, 1.0614918320424776e-144),
    (0.00031622776601683794, 0.0, 1.0614918320424776e-144),
]


@pytest.mark.parametrize(("theta", "omega3", "phidot"), _NAN_CASES)
def test_starts_at_a_pole_give_finite_means_without_warning(theta, omega3, phidot):
    E, D, lam = _integrals(mett.State(theta=theta, omega3=omega3, phidot=phidot))
    z0 = math.cos(theta)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        T = float(mett.nutation_period(TOP, E, D, lam, z0=z0))
        prec = float(mett.mean_precession(TOP, E, D, lam, z0=z0))
    assert T > 0.0 and math.isfinite(prec)
    if z0 == -1.0 and omega3 == 0.0:  # at rest on the inverted pole: the separatrix
        assert math.isinf(T)


@pytest.mark.slow  # CI's pole case: test_band_over_the_inverted_pole_omits_the_jump_...[1e-06]
def test_wall_a_few_ulps_off_the_pole_against_mpmath():
    E, D, lam = _integrals(mett.State(theta=3.141592643589793, omega3=1e-3, phidot=1.0))
    zl, zh = mett.turning_points(TOP, E, D, lam, z0=-1.0)
    assert -1.0 < zl < -1.0 + 4e-16  # the wall, not the pole (N(−1) is 10 × its rounding)
    ref = mps.reference(TOP, E, D, lam, 0.5 * (zl + zh), dps=60)
    assert zl == ref.z_low and zh == pytest.approx(ref.z_high, abs=4e-16)
    T = float(mett.nutation_period(TOP, E, D, lam, z0=-1.0))
    assert T == pytest.approx(ref.period, rel=1e-10)
    prec = float(mett.mean_precession(TOP, E, D, lam, z0=-1.0))
    assert prec == pytest.approx(ref.precession, rel=1e-9)


@pytest.mark.slow
def test_band_of_a_few_ulps_next_to_the_inverted_pole_period_against_mpmath():
    theta = 3.1415925535897933  # 1e-7 rad off the inverted pole, ω3 = 1000 rad/s
    E, D, lam = _integrals(mett.State(theta=theta, omega3=1000.0))
    z0 = math.cos(theta)
    ref = mps.reference(TOP, E, D, lam, z0, dps=60, start=True)
    assert float(mett.nutation_period(TOP, E, D, lam, z0=z0)) == pytest.approx(
        ref.period, rel=1e-10
    )


@pytest.mark.parametrize("omega3, phidot", [(1e-4, 1.0), (1e-4, -30.0), (1e-2, 1.0)])
def test_band_ending_at_the_upright_pole_with_p_negative_next_to_it(omega3, phidot):
    # θ0 = 1e-8: the band runs from one ulp below z = 1 to z = 1 itself, but with the exact N(1)
    # (≈ 1e-23) P < 0 within ~1e-19 of the pole, so that end turns at the root of P, not at the
    # pole (was: integrated from the pole, the square root of a negative P, NaN; found by
    # hypothesis). The period is the small-amplitude limit, continuous with θ0 = 1e-7, which the
    # mpmath reference resolves (it cannot at 1e-8: its bracket is below its working precision).
    E, D, lam = _integrals(mett.State(theta=1e-8, omega3=omega3, phidot=phidot))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        T = float(mett.nutation_period(TOP, E, D, lam, z0=math.cos(1e-8)))
        prec = float(mett.mean_precession(TOP, E, D, lam, z0=math.cos(1e-8)))
    assert math.isfinite(prec)
    E7, D7, lam7 = _integrals(mett.State(theta=1e-7, omega3=omega3, phidot=phidot))
    ref = mps.reference(TOP, E7, D7, lam7, math.cos(1e-7), dps=60, start=True)
    assert T == pytest.approx(float(ref.period), rel=1e-10)
