"""mett.predict_inversion against full simulations with flight and landing: the fast subset.

The reference of a case is the first crossing of θ = π/2 by the full compiled simulation
(mett.inversion._cases.reference), continued through flights and landings where the top hops; a
crossing in the air counts. The full 60-case table is tests/test_inversion_verify_slow.py and
docs/theory/inversion.md#verification.
"""

from __future__ import annotations

import warnings

import pytest

from mett.dynamics import simulate
from mett.dynamics.flight import VISCOUS_ARTEFACT, ViscousArtefactWarning
from mett.inversion import predict_inversion
from mett.inversion._cases import cases, reference

# The reduction's declared accuracy inside its validity range (docs/theory/inversion.md#verification):
# 10 % of t_half, the worst-case target, plus one nutation period of phase slack.
TARGET = 0.10

# Table cases inside the validity range whose simulations are short and never leave the table
# (viscous law, centre of mass at rest, ε = T_n/t_half <= 0.05).
FAST = [0, 4, 10, 12, 18, 24]


@pytest.fixture(scope="module")
def table():
    return cases()


@pytest.mark.parametrize("index", FAST)
def test_table_subset_matches_simulation(table, index):
    case = table[index]
    pred = predict_inversion(case.top, case.state, case.friction)
    ref = reference(case, min(2 * pred.t_half, 60.0))
    assert ref.status == "completed" and ref.has_crossing
    assert pred.inverts is True
    assert not pred.validity.outside_verified_range
    assert abs(pred.t_half - ref.t_half) <= TARGET * ref.t_half + ref.T_n


def test_a_hopping_top_inside_the_validity_range_matches_simulation(table):
    # Case 16 (viscous, centre of mass at rest, λ/λ_thres = 11): the simulated top hops from
    # about θ = 1 on and crosses π/2 after ~100 flights; the balance flow knows nothing of the
    # flights (in the air no friction acts), and its t_half must still meet the declared target.
    case = table[16]
    pred = predict_inversion(case.top, case.state, case.friction)
    assert pred.inverts is True and not pred.validity.outside_verified_range
    ref = reference(case, 1.2 * pred.t_half)
    assert ref.has_crossing and ref.hops > 0 and ref.airborne > 0.0
    assert abs(pred.t_half - ref.t_half) <= TARGET * ref.t_half + ref.T_n


def test_reference_counts_a_crossing_in_flight(table):
    # Case 7 passes π/2 in the air. The reference says so, and the simulation run to exactly that
    # instant ends in flight: the sphere's lowest point is above the table (the gap, computed from
    # the geometry of the free motion, independently of the switch bookkeeping).
    case = table[7]
    ref = reference(case, 6.0)
    assert ref.has_crossing and ref.in_flight and ref.hops > 0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ViscousArtefactWarning)
        traj = simulate(case.top, case.state, ref.t_half, friction=case.friction, rtol=1e-8)
    assert traj.contact[-1] == "none" and traj.gap[-1] > 0.0


def test_viscous_artefact_is_flagged(table):
    # Case 6: on the balance path the viscous law's coefficient μ|v_A| exceeds 1 before π/2, a
    # friction no real contact has (docs/theory/flight.md#when-a-loss-of-contact-is-an-artefact):
    # the prediction is flagged, and the simulated top indeed lifts off with μ|v_A| > 1.
    case = table[6]
    pred = predict_inversion(case.top, case.state, case.friction)
    assert pred.validity.outside_verified_range
    assert any("mu |v_A|" in n for n in pred.validity.notes)
    ref = reference(case, 2.0)
    assert ref.hops > 0 and ref.artefact > VISCOUS_ARTEFACT
