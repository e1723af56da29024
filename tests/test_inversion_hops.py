"""The hopping top (docs/theory/inversion.md#the-hopping-top): after a predicted lift-off the
gyroscopic method's flow runs at the hop cycle's power, measured on short runs of that cycle
(mett.inversion._hops). Checked against full simulations with flight and landing of the
verification table's hopping tops (their first crossing of π/2), which the reduction does not use.
"""

from __future__ import annotations

import math
import statistics
import warnings

import numpy as np
import pytest

import mett
from mett.dynamics import simulate
from mett.dynamics.flight import ViscousArtefactWarning
from mett.inversion import predict_inversion
from mett.inversion._cases import cases, reference

# The target for t_half (relative, after one nutation period of slack), as for the table.
TARGET = 0.10
MEDIAN_TARGET = 0.03
# The tops the lift-off criterion alone flags (docs/theory/inversion.md#verification): inside the
# verified box but for the hop.
HOP_ONLY = [3, 16, 30, 34, 43, 46, 54, 55]


@pytest.fixture(scope="module")
def table():
    return cases()


def _error(pred_t_half: float, ref) -> float:
    return max(abs(pred_t_half - ref.t_half) - ref.T_n, 0.0) / ref.t_half


def test_hops_must_be_a_bool():
    top = mett.presets.get("rutstam2013")
    state = mett.State.with_cm_at_rest(top, theta=0.1, omega3=155.0)
    with pytest.raises(TypeError, match="hops"):
        predict_inversion(top, state, hops="yes")


def test_a_top_predicted_to_stay_on_the_table_is_unchanged_bit_for_bit():
    # t_lift = inf: the hop flow is never entered, the prediction is the gliding one exactly.
    top = mett.presets.get("rutstam2013")
    state = mett.State.with_cm_at_rest(top, theta=0.1, omega3=155.0)
    a, b = predict_inversion(top, state), predict_inversion(top, state, hops=False)
    assert math.isinf(a.t_lift)
    assert (a.t_start, a.t_half, a.t_inv, a.inverts, a.reason) == (
        b.t_start, b.t_half, b.t_inv, b.inverts, b.reason)  # fmt: skip
    for name in ("t", "theta", "D", "E_mod", "lam"):
        assert np.array_equal(getattr(a, name), getattr(b, name))
    assert a.validity == b.validity


def test_the_hops_move_the_path_later_after_the_lift_off_only(table):
    # Case 30 (viscous, CM at rest, lifts off near θ̄ = 0.45): the path up to t_lift is the gliding
    # one bit for bit; after it every node comes later (the hop cycle takes less power than the
    # gliding contact, S > 1), and so do t_half and t_inv. A sign error of the correction, or a
    # correction applied before the lift-off, fails here.
    case = table[30]
    hop = predict_inversion(case.top, case.state, case.friction)
    glide = predict_inversion(case.top, case.state, case.friction, hops=False)
    assert glide.t_lift < glide.t_half and hop.t_lift == glide.t_lift
    before = glide.t <= glide.t_lift
    assert np.array_equal(hop.t[before], glide.t[before])
    assert np.array_equal(hop.theta, glide.theta)
    assert np.all(hop.t[~before] > glide.t[~before])
    assert hop.t_half > glide.t_half and hop.t_inv > glide.t_inv
    assert hop.t_start == glide.t_start
    assert any(
        n.startswith("predicted to hop before pi/2") and "follows the hop cycle" in n
        for n in hop.validity.notes
    )
    # still flagged: the hopping prediction is outside the verified range
    assert hop.validity.outside_verified_range


@pytest.mark.parametrize("index", [16, 34])
def test_hopping_tops_cross_when_the_hop_flow_says(table, index):
    # Cases 16 (100 hops) and 34 (72 hops) before their simulated crossing, both in flight: the
    # hop flow's t_half within the target of the simulated first crossing of π/2, and nearer to it
    # than the gliding flow's (which is early: 4.7 % and 2.6 %).
    case = table[index]
    hop = predict_inversion(case.top, case.state, case.friction)
    glide = predict_inversion(case.top, case.state, case.friction, hops=False)
    ref = reference(case, min(2.0 * hop.t_half, 60.0))
    assert ref.has_crossing and ref.hops > 0
    assert _error(hop.t_half, ref) <= TARGET
    assert abs(hop.t_half - ref.t_half) < abs(glide.t_half - ref.t_half)


def test_the_hopping_top_is_slowed_far_less_than_its_time_in_the_air(table):
    # Why the reduction is not "the flow stands still in the air": case 30 simulated with flight
    # and landing is in the air more than half the time past its first lift-off, and its mean
    # inclination goes from 0.9 to 1.5 more slowly than the gliding flow says, but much faster
    # than 1/(1 − air fraction) times it (measured 1.75 against 3.0). The running mean over
    # 8 start-nutation periods moves the span's ends by ≤ 8 T_n, 2 % of its 0.33 s.
    case = table[30]
    glide = predict_inversion(case.top, case.state, case.friction, hops=False)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ViscousArtefactWarning)
        traj = simulate(case.top, case.state, 1.05 * 8.647, rtol=1e-8,
                        stop_on_contact_loss=False)  # fmt: skip
    assert traj.status == "completed"
    sw = traj.records["switches"]
    lifts = np.array([s.t for s in sw if s.reason == "lift-off"])
    lands = np.array([s.t for s in sw if s.reason == "touchdown"])
    T_n = 2.0 * math.pi * case.top.I1 / (case.top.I3 * float(case.state.omega3))
    t = np.arange(0.0, traj.t_final, T_n / 16.0)
    theta_bar = np.convolve(traj.theta_at(t), np.ones(128) / 128.0, mode="same")
    air = np.zeros(t.shape, dtype=bool)
    for up, down in zip(lifts, np.r_[lands, np.inf][: len(lifts)], strict=True):
        air |= (t >= up) & (t < down)
    i0, i1 = int(np.argmax(theta_bar >= 0.9)), int(np.argmax(theta_bar >= 1.5))
    assert lifts[0] < t[i0] < t[i1]
    air_fraction = float(air[i0:i1].mean())
    slowdown = (t[i1] - t[i0]) / (np.interp(1.5, glide.theta, glide.t)
                                  - np.interp(0.9, glide.theta, glide.t))  # fmt: skip
    assert air_fraction > 0.5
    assert 1.2 < slowdown < 0.8 / (1.0 - air_fraction)


@pytest.mark.slow
def test_hop_flow_on_the_tops_flagged_for_the_hop_alone(table):
    # The eight table tops inside the verified box but for the predicted hop: with the hop flow
    # every t_half moves later (towards the simulated crossing: the gliding one is early in all
    # eight), the median error meets the 3 %, and the worst is no worse than the gliding
    # flow's. (Case 46 keeps most of its error: it is made before its first lift-off, in contact.)
    hop_err, glide_err = [], []
    for i in HOP_ONLY:
        case = table[i]
        hop = predict_inversion(case.top, case.state, case.friction)
        glide = predict_inversion(case.top, case.state, case.friction, hops=False)
        ref = reference(case, min(2.0 * hop.t_half, 60.0))
        assert ref.has_crossing and ref.hops > 0
        assert glide.t_half < hop.t_half
        hop_err.append(_error(hop.t_half, ref))
        glide_err.append(_error(glide.t_half, ref))
    assert statistics.median(hop_err) <= MEDIAN_TARGET
    assert max(hop_err) <= max(glide_err)


def test_a_window_that_gains_energy_leaves_the_gliding_path(table, monkeypatch):
    # A window whose hop cycle loses no energy (here forced) gives no slowdown to follow: the
    # prediction keeps the gliding path bit for bit and says so in its (single) hop note.
    from mett.inversion import _hops

    case = table[30]
    glide = predict_inversion(case.top, case.state, case.friction, hops=False)
    monkeypatch.setattr(_hops, "cycle_power_ratio", lambda top, law, lam, th: (-1.0, th, 10))
    hop = predict_inversion(case.top, case.state, case.friction)
    assert np.array_equal(hop.t, glide.t) and hop.t_half == glide.t_half
    notes = [n for n in hop.validity.notes if n.startswith("predicted to hop before pi/2")]
    assert len(notes) == 1 and "not followed" in notes[0]
