"""Property-based tests (hypothesis) of the METT layer over random tops and states."""

from __future__ import annotations

import math
import warnings

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import mett
from mett.separation import conditioning

# derandomize: CI must be reproducible; explore more locally with --hypothesis-seed and a profile.
SETTINGS = settings(
    max_examples=60, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow]
)


@st.composite
def tops(draw, admissible=False):
    m = draw(st.floats(0.005, 0.1))
    R = draw(st.floats(0.005, 0.05))
    I3 = draw(st.floats(0.2, 1.0)) * m * R**2
    alpha = draw(st.floats(0.02, 0.95))
    lo, hi = (1 - alpha, 1 + alpha) if admissible else (0.5, 2.5)
    gamma = draw(st.floats(max(lo, 0.5) + 1e-3, hi - 1e-3))
    return mett.TippeTop(m=m, R=R, alpha=alpha, I1=gamma * I3, I3=I3, mu=draw(st.floats(0, 5)))


@st.composite
def rational_tops(draw):
    m = draw(st.floats(0.005, 0.1))
    R = draw(st.floats(0.005, 0.05))
    I3 = draw(st.floats(0.2, 1.0)) * m * R**2
    alpha = draw(st.floats(0.02, 0.6))
    return mett.TippeTop.rational(m=m, R=R, alpha=alpha, I3=I3)


def states(gliding=True):
    spin = st.floats(-2000, 2000)
    return st.builds(
        mett.State,
        theta=st.floats(0.01, math.pi - 0.01),
        thetadot=st.floats(-30, 30),
        phidot=st.floats(-100, 100),
        omega3=spin,
        nu_x=st.floats(-1, 1) if gliding else st.just(0.0),
        nu_y=st.floats(-1, 1) if gliding else st.just(0.0),
    )


@SETTINGS
@given(tops(), states())
def test_mett_identity_with_modified_energy(top, s):
    z = math.cos(s.theta)
    D, lam = mett.routh(top, s), mett.jellett(top, s)
    E_mod = mett.modified_energy(top, s)
    rhs = mett.g(top, z) * s.thetadot**2 + mett.V(top, z, D, lam)
    # The terms of V can be much larger than their sum; measure against their size.
    scale = E_mod + abs(D) ** 2 / top.I1 + top.m * lam**2 / (top.I1 * top.I3)
    assert abs(rhs - E_mod) <= 1e-12 * scale


@SETTINGS
@given(tops(), st.floats(-1, 1), st.floats(-1, 1), st.floats(-0.999999, 0.999999))
def test_potential_finite_inside_and_bounded_below_by_gravity_part(top, dfrac, lfrac, z):
    lam = lfrac * 10 * top.lambda_0 if math.isfinite(top.lambda_0) else lfrac * 1e-5
    D = dfrac * 1e-3
    v = float(mett.V(top, z, D, lam))
    assert math.isfinite(v)
    # V − (gravity + constant) is the kinetic part I3 N²/(2 I1² R² (1 − z²)) ≥ 0.
    const = D**2 / (2 * top.I1) - top.m * lam**2 / (2 * top.I1 * top.I3)
    assert v - top.m * top.g * top.R * (1 - top.alpha * z) - const >= -1e-12 * (abs(v) + abs(const))


@SETTINGS
@given(rational_tops(), st.floats(-0.999, 0.999), st.floats(-2, 2), st.floats(0.1, 10))
def test_rational_potential_equals_algebraic(top, z, dfrac, lratio):
    lam = lratio * top.lambda_thres
    D = dfrac * float(mett.boundary_values(top, lam).D0)
    a, b = float(mett.V_rational(top, z, D, lam)), float(mett.V(top, z, D, lam))
    const = D**2 / (2 * top.I1) + top.m * lam**2 / (2 * top.I1 * top.I3)
    assert abs(a - b) <= 1e-12 * (abs(b) + const)


@SETTINGS
@given(tops(admissible=True), states(gliding=False))
def test_turning_points_bracket_the_start(top, s):
    z0 = math.cos(s.theta)
    E, D, lam = mett.energy(top, s), mett.routh(top, s), mett.jellett(top, s)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no overflow/invalid-value warnings either
        zl, zh = mett.turning_points(top, E, D, lam, z0=z0)
        band = mett.band(top, E, D, lam, z0=z0)
    width = max(zh - zl, 1e-300)
    # The inputs' own rounding limits how well the band is defined (conditioning, not error).
    tol = width * (1e-7 + conditioning(top, E, D, lam, band.depth)) + 1e-13
    assert zl - tol <= z0 <= zh + tol
    assert -1 <= zl <= zh <= 1
    if s.thetadot == 0:  # the start is itself a turning point
        assert min(abs(z0 - zl), abs(z0 - zh)) <= tol
    T = mett.nutation_period(top, E, D, lam, z0=z0)
    assert np.isfinite(T) and T > 0


@SETTINGS
@given(tops(), states(gliding=False))
def test_f_is_nonnegative_at_the_start(top, s):
    # ż² = f(z0) ≥ 0 and equals (sin θ θ̇)² at the state itself.
    z0 = math.cos(s.theta)
    E, D, lam = mett.energy(top, s), mett.routh(top, s), mett.jellett(top, s)
    fz = float(mett.f(top, z0, E, D, lam))
    expected = (math.sin(s.theta) * s.thetadot) ** 2
    g0 = float(mett.g(top, z0))
    scale = (E + D**2 / top.I1 + top.m * lam**2 / (top.I1 * top.I3)) / g0
    assert abs(fz - expected) <= 1e-11 * scale
