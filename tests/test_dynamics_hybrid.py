"""Hybrid (several-phase) models: simulate switches the right-hand side at located events.

The test model is the gliding top whose friction is switched off at t = 0.3 s and on again at
t = 0.6 s (time events; a "switch" event may be any function of the state). Independent checks:
before the first switch the run is the plain gliding run, step for step; while frictionless the
energy is conserved (it decreases under friction); Jellett's λ is conserved throughout; the phases
and switch times are reported; both backends agree. The phase functions call the gliding model's
public functions, so this also checks that a model module can build on another one's physics (the
compiled kernels inline callees from other mett modules).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import mett
from mett.dynamics import MODELS, Event, Phase, simulate
from mett.dynamics.gliding import gliding_normal_force, gliding_rhs

TOP = mett.presets.get("rutstam2013")
START = mett.State(theta=0.1, omega3=155.0)


def _frictionless(p):
    return (p[0], p[1], p[2], p[3], p[4], 0.0, p[6])


def _rhs_frictionless(t, y, p):
    return gliding_rhs(t, y, _frictionless(p))


def _rhs_frictionless_into(t, y, p, out):
    d = gliding_rhs(t, y, _frictionless(p))
    for i in range(10):
        out[i] = d[i]


def _contact(t, y, p):
    return gliding_normal_force(y, p) * (1.0 / (p[0] * p[6]))


def _contact_frictionless(t, y, p):
    return gliding_normal_force(y, _frictionless(p)) * (1.0 / (p[0] * p[6]))


def _at_0p3(t, y, p):
    return t - 0.3


def _at_0p6(t, y, p):
    return t - 0.6


GLIDING = MODELS["gliding"]
SWITCHED = dataclasses.replace(
    GLIDING,
    name="gliding-switched",
    phase="friction",
    events=(
        Event(_contact, -1.0, "contact_lost"),
        Event(_at_0p3, 1.0, "switch", target="frictionless"),
    ),
    phases=(
        Phase(
            "frictionless",
            _rhs_frictionless,
            _rhs_frictionless_into,
            (
                Event(_contact_frictionless, -1.0, "contact_lost"),
                Event(_at_0p6, 1.0, "switch", target="friction"),
            ),
        ),
    ),
)


@pytest.fixture(scope="module", params=["compiled", "scipy"])
def runs(request):
    backend = request.param
    plain = simulate(TOP, START, 1.0, backend=backend)
    hybrid = simulate(TOP, START, 1.0, model=SWITCHED, backend=backend)
    return plain, hybrid


def test_phases_and_switches_are_reported(runs):
    _, tr = runs
    assert tr.status == "completed"
    assert [(round(t, 12), a, b) for t, a, b in tr.switches] == [
        (0.3, "friction", "frictionless"),
        (0.6, "frictionless", "friction"),
    ]
    assert tr.phase.shape == tr.t.shape
    np.testing.assert_array_equal(tr.phase == "frictionless", (tr.t >= 0.3) & (tr.t < 0.6))
    assert np.all(np.diff(tr.t) > 0)


def test_before_the_first_switch_it_is_the_plain_run(runs):
    plain, tr = runs
    k = int(np.searchsorted(plain.t, 0.3))
    np.testing.assert_array_equal(tr.t[:k], plain.t[:k])
    np.testing.assert_array_equal(tr.states[:, :k], plain.states[:, :k])


def test_energy_is_conserved_only_while_frictionless_and_lambda_throughout(runs):
    _, tr = runs
    free = tr.phase == "frictionless"
    E = tr.E
    drift_free = np.ptp(E[free]) / E[0]
    assert drift_free < 1e-9
    # under friction the energy falls (the contact point slips from the start)
    assert E[tr.t < 0.3][-1] < E[0] * (1 - 1e-6)
    assert np.ptp(tr.lam) / abs(tr.lam[0]) < 1e-8
    # the dense output follows the phases: at every sample it gives that sample's state
    np.testing.assert_allclose(tr.states_at(tr.t), tr.states, rtol=1e-12, atol=1e-15)


def test_backends_agree_on_the_hybrid_run():
    comp = simulate(TOP, START, 1.0, model=SWITCHED, backend="compiled")
    ref = simulate(TOP, START, 1.0, model=SWITCHED, backend="scipy")
    assert comp.backend == "compiled" and ref.backend == "scipy"
    # Tolerances from the error analysis: the backends run the same DOP853 on the same functions
    # and agree to rounding while they take the same steps; were an accept/reject decision within
    # rounding of the limit on some machine, they would differ by up to the sum of their errors,
    # each estimated by the run at rtol/100 (the default rtol is 1e-10), plus rtol × the
    # quantity's scale (π for θ, E for E) lest that estimate fall on a zero of the error.
    fine = simulate(TOP, START, 1.0, model=SWITCHED, rtol=1e-12, backend="compiled")
    theta_tol = 2.0 * (abs(comp.theta_at(1.0) - fine.theta_at(1.0)) + 1e-10 * np.pi)
    assert comp.theta_at(1.0) == pytest.approx(ref.theta_at(1.0), abs=theta_tol)
    e_tol = 2.0 * (abs(comp.E[-1] - fine.E[-1]) + 1e-10 * abs(comp.E[-1]))
    assert comp.E[-1] == pytest.approx(ref.E[-1], abs=e_tol)


def test_user_events_count_across_phases():
    def turning(t, state):
        return state.thetadot

    free = simulate(TOP, START, 1.0, model=SWITCHED, events=[turning])
    zeros = free.t_events[0]
    k = int(np.searchsorted(zeros, 0.45))  # the k-th zero lies in the frictionless phase
    turning.terminal = k + 1
    tr = simulate(TOP, START, 1.0, model=SWITCHED, events=[turning])
    assert tr.t_final == pytest.approx(zeros[k], abs=1e-12)
    assert tr.phase[-1] == "frictionless" and "terminal event 0" in tr.message


def test_a_switch_to_an_unknown_phase_is_refused_at_declaration():
    with pytest.raises(ValueError, match="unknown phase 'nowhere'"):
        dataclasses.replace(
            GLIDING, events=(*GLIDING.events, Event(_at_0p3, 1.0, "switch", target="nowhere"))
        )


def test_an_option_can_select_a_variant_model():
    # the declaration a friction law needs: an option of "gliding" that hands over to a hybrid
    from mett.dynamics.registry import Option, boolean

    def variant(options):
        return switched if options["switch_friction"] else None

    opt = (Option("switch_friction", boolean, False),)
    switched = dataclasses.replace(SWITCHED, options=opt)
    base = dataclasses.replace(GLIDING, name="gliding-with-variant", options=opt, variant=variant)
    plain = simulate(TOP, START, 0.5, model=base)
    assert plain.model == "gliding-with-variant" and not hasattr(plain, "switches")
    tr = simulate(TOP, START, 0.5, model=base, switch_friction=True)
    assert tr.model == "gliding-switched" and len(tr.switches) == 1
    with pytest.raises(TypeError, match="switch_friction must be a bool"):
        simulate(TOP, START, 0.5, model=base, switch_friction="yes")


def _back_at_once(t, y, p):
    return t - 0.3  # exactly 0 where the frictionless phase of PINGPONG starts


PINGPONG = dataclasses.replace(
    SWITCHED,
    name="gliding-pingpong",
    phases=(
        Phase(
            "frictionless",
            _rhs_frictionless,
            _rhs_frictionless_into,
            (
                Event(_contact_frictionless, -1.0, "contact_lost"),
                Event(_back_at_once, 0.0, "switch", target="friction"),
            ),
        ),
    ),
)


@pytest.mark.parametrize("backend", ["compiled", "scipy"])
def test_a_switch_event_that_is_zero_where_its_phase_starts_does_not_fire(backend):
    tr = simulate(TOP, START, 0.5, model=PINGPONG, backend=backend)
    assert tr.status == "completed"
    assert [(round(t, 12), a, b) for t, a, b in tr.switches] == [(0.3, "friction", "frictionless")]


# --- user events: one meaning of a zero on every backend --------------------------------------
# A zero of a user event is a change of its class (sign −1, 0, +1); a stretch of exact zeros is a
# class of its own (docs/theory/simulation.md#user-events). The references are the roots of θ − L
# on the dense output of a run without events (scipy's brentq), on the same backend: the event
# code and the reference share only the integration, so they agree to the root tolerance (4 ulps
# of t, plus the interpolant's rounding: 1e-12 s at |θ̇| ≥ 0.1 rad/s).

NUTATING = mett.State(theta=0.3, thetadot=1.0, omega3=155.0)  # θ ∈ [0.289, 0.305]: 0.03 s
LEVEL = 0.302


def _level_crossings(tr, level):
    """Roots of θ − level on the run's dense output, bracketed on a fine grid (independent)."""
    from scipy.optimize import brentq

    tt = np.linspace(0.0, tr.t_final, 4001)
    f = tr.theta_at(tt) - level
    idx = np.flatnonzero(np.sign(f[:-1]) * np.sign(f[1:]) < 0)
    return np.array([brentq(lambda t: tr.theta_at(t) - level, tt[i], tt[i + 1], xtol=1e-15)
                     for i in idx])  # fmt: skip


@pytest.fixture(scope="module", params=["compiled", "scipy", "taylor"])
def level_run(request):
    tr = simulate(TOP, NUTATING, 0.1, backend=request.param, rtol=1e-10)
    roots = _level_crossings(tr, LEVEL)
    assert roots.size >= 4 and np.all(np.abs(tr.at(roots).thetadot) > 0.1)
    return request.param, roots


def test_a_clipped_event_stops_at_the_first_true_crossing(level_run):
    """max(θ − L, 0) is 0 until θ first reaches L: it fires there (rising), on every backend —
    scipy used to stop at the end of its first step (0 at both ends counted as a zero), DOP853
    and Taylor at the first fall back through L."""
    backend, roots = level_run

    def clipped(t, s):
        return max(s.theta - LEVEL, 0.0)

    tr = simulate(TOP, NUTATING, 0.1, backend=backend, rtol=1e-10, events=[clipped])
    np.testing.assert_allclose(tr.t_events[0], roots, rtol=0, atol=1e-12)  # every crossing
    clipped.direction = 1.0
    up = simulate(TOP, NUTATING, 0.1, backend=backend, rtol=1e-10, events=[clipped])
    rising = roots[tr.at(roots).thetadot > 0]
    np.testing.assert_allclose(up.t_events[0], rising, rtol=0, atol=1e-12)
    clipped.terminal = True
    cut = simulate(TOP, NUTATING, 0.1, backend=backend, rtol=1e-10, events=[clipped])
    assert cut.status == "completed" and "terminal event 0" in cut.message
    assert cut.t_final == pytest.approx(roots[0], abs=1e-12)
    assert cut.t_events[0] == pytest.approx([roots[0]], abs=1e-12)


def test_a_bool_event_fires_at_every_change_and_a_zero_event_never(level_run):
    backend, roots = level_run

    def above(t, s):
        return s.theta > LEVEL

    def nothing(t, s):
        return 0.0

    nothing.terminal = True
    tr = simulate(TOP, NUTATING, 0.1, backend=backend, rtol=1e-10, events=[above, nothing])
    assert tr.status == "completed" and tr.t_final == 0.1
    np.testing.assert_allclose(tr.t_events[0], roots, rtol=0, atol=1e-12)
    assert tr.t_events[1].size == 0
    # the negated clipped event: the same zeros (the classes 0 and −1)
    neg = simulate(TOP, NUTATING, 0.1, backend=backend, rtol=1e-10,
                   events=[lambda t, s: -max(s.theta - LEVEL, 0.0)])  # fmt: skip
    np.testing.assert_allclose(neg.t_events[0], roots, rtol=0, atol=1e-12)
