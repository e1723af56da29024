"""Bad input across the public API: ValueError naming the parameter and its valid range."""

from __future__ import annotations

import math

import numpy as np
import pytest

import mett
from mett import estimates

TOP = mett.presets.get("rutstam2013")
S = mett.State(theta=1.0, omega3=100.0, phidot=5.0)
E, D, LAM = (float(f(TOP, S)) for f in (mett.energy, mett.routh, mett.jellett))

CASES = [
    # (call, message fragment)
    (lambda: mett.f(TOP, 1.2, E, D, LAM), r"z = cos\(theta\) must lie in \[-1, 1\]; got 1.2"),
    (lambda: mett.f(TOP, 0.5, math.nan, D, LAM), "E must be finite"),
    (lambda: mett.turning_points(TOP, E, math.inf, LAM), "D must be finite"),
    (
        lambda: mett.turning_points(TOP, 0.0, D, LAM),
        r"admits no motion: E lies .* below the minimum of V",
    ),
    (lambda: mett.nutation_period(TOP, 0.0, D, LAM), "admits no motion"),
    (lambda: mett.mean_precession(TOP, 0.0, D, LAM), "admits no motion"),
    (lambda: mett.turning_points(TOP, E, D, LAM, z0=-0.9), "no admissible motion through z0"),
    (
        lambda: mett.turning_points(TOP, E, D, LAM, z0=2.0),
        r"z0 = cos\(theta\) must lie in \[-1, 1\]",
    ),
    (lambda: mett.boundary_values(TOP, math.nan), "lam must be finite"),
    (lambda: mett.high_spin(TOP, 0.0, 100.0), r"theta0 must lie in the open interval \(0, pi\)"),
    (lambda: mett.period_estimates(TOP, -1e-6), r"lam must lie in \(0, inf\)"),
    (lambda: estimates.potential_minimum(TOP, math.nan, LAM), "D must be finite"),
    (lambda: estimates.convexity(TOP, D, math.inf), "lam must be finite"),
    (lambda: estimates.oscillation_ratio(TOP, LAM, 0.0), r"t_inversion must lie in \(0, inf\)"),
    (lambda: mett.asymptotic_state(TOP, 0.0), r"lam must lie in \(0, inf\)"),
    (lambda: mett.tumbling_state(TOP, -1.0), r"lam must lie in \(0, inf\)"),
    (lambda: mett.min_spin_for_inversion(TOP, -0.1), r"theta0 must lie in \[0, pi\]"),
    (lambda: mett.spin_eigenvalues(TOP, LAM, "sideways"), "pole must be one of"),
    (lambda: mett.spin_eigenvalues(TOP, 0.0), r"lam must lie in \(0, inf\)"),
    (lambda: mett.State(theta=math.pi + 0.1), r"theta must lie in \[0, pi\]"),
    (lambda: mett.State(theta=0.1, phidot=math.nan), "phidot must be finite"),
    (lambda: mett.simulate(TOP, S, 0.0), "t_end"),
    (lambda: mett.simulate(TOP, S, 1.0, rtol=0.0), "rtol must lie in"),
    (lambda: mett.simulate(TOP, S, 1.0, model="chaos"), "model"),
    (lambda: mett.presets.get("rutstam2099"), "unknown preset 'rutstam2099'; known presets"),
    (
        lambda: mett.TippeTop(m=0.02, R=0.02, alpha=0.3, I1=1e-6, I3=3e-6),
        r"I3 must lie in \(0, 2\*I1\]",
    ),
    (
        lambda: mett.TippeTop.rational(m=0.02, R=0.02, alpha=1.0, I3=3e-6),
        r"alpha must lie in \(0, 1\)",
    ),
]


@pytest.mark.parametrize(("call", "message"), CASES, ids=[c[1][:40] for c in CASES])
def test_bad_input_raises_a_named_value_error(call, message):
    with pytest.raises(ValueError, match=message):
        call()


def test_array_inputs_are_checked_element_wise():
    with pytest.raises(ValueError, match=r"must lie in \[-1, 1\]; got -1.5"):
        mett.V(TOP, np.array([0.1, -1.5, 0.3]), D, LAM)
    with pytest.raises(ValueError, match="E must be finite; got nan"):
        mett.nutation_period(TOP, np.array([E, np.nan]), D, LAM)


def test_suspicious_but_legal_input_warns_with_a_filterable_category():
    import warnings

    with pytest.warns(mett.PhysicalityWarning):
        mett.presets.get("maple-tippe-top", alpha=0.3)
    assert issubclass(mett.PhysicalityWarning, mett.MettWarning)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        warnings.simplefilter("ignore", mett.MettWarning)  # inserted first: takes precedence
        mett.presets.get("maple-tippe-top", alpha=0.3)  # filtered by its category: no error
