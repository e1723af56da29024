"""The thesis run (Rutstam 2013, §4/§8) with the gliding vector model, and the simulate/Trajectory API.

The run: preset rutstam2013, θ0 = 0.1, ω3 = 155 rad/s, φ̇ = θ̇ = 0 and ν(0) = 0 (contact point at
rest, the thesis convention), integrated to 9 s once per module with the default tolerances.
Numbers measured when these tests were written (rtol = 1e-10, DOP853, numpy-free float RHS, ~1 s):
first θ = π/2 at 5.87975 s (it moves by 1.4e-8 s at rtol = 1e-11); λ drift 1.4e-10; METT residual
8e-14 of Ẽ; E strictly decreasing; ω3(9 s) = −82.8663 vs the asymptote −82.8659.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import mett
from mett.dynamics import MODELS, Trajectory, simulate

THETA0, OMEGA0, T_END = 0.1, 155.0, 9.0


@pytest.fixture(scope="module")
def top() -> mett.TippeTop:
    return mett.presets.get("rutstam2013")


@pytest.fixture(scope="module")
def start() -> mett.State:
    return mett.State(theta=THETA0, omega3=OMEGA0)


@pytest.fixture(scope="module")
def run(top, start) -> Trajectory:
    """The thesis run with default tolerances (computed once)."""
    return simulate(top, start, T_END)


# --- the thesis run --------------------------------------------------------------------------


def test_thesis_run_completes(run):
    assert run.status == "completed"
    assert run.t[0] == 0.0 and run.t[-1] == T_END
    for name, series in run.as_dict().items():
        assert series.shape == run.t.shape, name
        assert np.all(np.isfinite(series)), name


def test_thesis_run_starts_from_the_given_state(run, top, start):
    s0 = run.at(0.0)
    for k in ("theta", "thetadot", "phidot", "omega3", "nu_x", "nu_y"):
        assert getattr(s0, k) == pytest.approx(getattr(start, k), abs=1e-12), k
    assert run.E[0] == pytest.approx(float(mett.energy(top, start)), rel=1e-14)
    assert run.E_mod[0] == pytest.approx(float(mett.modified_energy(top, start)), rel=1e-14)
    assert run.D[0] == pytest.approx(float(mett.routh(top, start)), rel=1e-14)
    assert run.lam[0] == pytest.approx(float(mett.jellett(top, start)), rel=1e-14)


def test_thesis_run_inverts_between_4_and_6p5_s(run):
    # Thesis §8: "the rapid inversion of TT between 4 and 6.5 seconds". Measured: θ(4 s) = 0.205,
    # θ(6.5 s) = 2.738, θ = π/2 first at 5.8797 s (then twice more within 0.05 s, nutation).
    up = run.crossings(math.pi / 2)
    assert up.size >= 1
    assert np.all((up > 4.0) & (up < 6.5))
    assert up[0] == pytest.approx(5.8797, abs=1e-3)
    before = run.theta_at(np.linspace(0.0, 4.0, 4001))
    after = run.theta_at(np.linspace(6.5, T_END, 2501))
    assert before.max() < math.pi / 8
    assert after.min() > 5 * math.pi / 6
    assert run.theta[-1] > math.pi - 0.01


def test_thesis_run_dips_close_to_the_pole_before_inverting(run):
    # docs/theory/references.md#other-sources: θ first decreases, to below 0.001 rad near t ≈ 3.2 s (measured 2.1e-4 at 3.1886 s).
    tt = np.linspace(3.0, 3.4, 40001)
    th = run.theta_at(tt)
    assert th.min() < 1e-3
    assert tt[np.argmin(th)] == pytest.approx(3.2, abs=0.05)


def test_default_tolerance_is_converged_for_the_inversion_time(top, start, run):
    # Issue 3: the first time θ reaches π/2 must not move by more than 1e-4 s when rtol is
    # tightened tenfold. Measured shift: 1.4e-8 s.
    tight = simulate(top, start, 6.5, rtol=1e-11)
    t_default = run.crossings(math.pi / 2)[0]
    t_tight = tight.crossings(math.pi / 2)[0]
    assert abs(t_default - t_tight) < 1e-4
    assert abs(t_default - t_tight) < 1e-6  # the margin actually measured


def test_omega3_ends_at_the_inverted_spin_value(run, top):
    # docs/theory/thresholds.md#boundary-values, docs/theory/notes.md#omega3-end: ω3 → −λ/(R I3 (1 + α)) = −82.866 rad/s (the thesis' "about −85" is read
    # off a plot).
    lam = run.lam[0]
    target = -lam / (top.R * top.I3 * (1.0 + top.alpha))
    assert round(target, 3) == -82.866
    assert run.omega3[-1] == pytest.approx(target, rel=1e-4)
    assert run.omega3[0] == pytest.approx(OMEGA0, rel=1e-15)


def test_run_ends_at_the_boundary_values_D1_E1(run, top):
    bv = mett.boundary_values(top, run.lam[0])
    assert run.D[-1] == pytest.approx(float(bv.D1), rel=1e-4)
    assert run.E[-1] == pytest.approx(float(bv.E1), rel=1e-4)


def test_jellett_is_conserved(run):
    drift = np.max(np.abs(run.lam / run.lam[0] - 1.0))
    assert drift <= 1e-9  # measured 1.4e-10


def test_energy_is_non_increasing(run):
    # docs/theory/equations.md#dissipation: Ė = −μ g_n |ν|² ≤ 0. Sampled E decreases strictly (measured max step −2.7e-10).
    assert np.all(np.diff(run.E) <= 1e-12 * run.E[0])
    assert run.E[-1] < run.E[0]


def test_energy_rate_is_minus_mu_gn_nu_squared(run, top):
    # dE/dt evaluated as the derivative of E along the model's vector field at every sample
    # (central difference, h = 1e-6 s), against the dissipation law −μ g_n |v_A|² (docs/theory/equations.md#dissipation).
    model = MODELS["gliding"]
    Y = run.states
    F = model.rhs(0.0, Y, run.params)  # the RHS is plain arithmetic: it vectorises over samples
    h = 1e-6
    E = lambda Z: model.derive(Z, run.params)["E"]  # noqa: E731
    dE_num = (E(Y + h * F) - E(Y - h * F)) / (2 * h)
    dE_law = -top.mu * run.gn * (run.nu_x**2 + run.nu_y**2)
    scale = np.max(np.abs(dE_law))
    assert np.max(np.abs(dE_num - dE_law)) < 1e-6 * scale
    assert np.all(dE_law <= 0.0)


def test_energy_lost_equals_friction_work(run, top):
    # E(t1) − E(t0) = −∫ μ g_n |ν|² dt, integrated (Simpson) on the dense output over [0, 6.5 s].
    from scipy.integrate import simpson

    tt = np.linspace(0.0, 6.5, 130001)
    Y = run.states_at(tt)
    s = MODELS["gliding"].derive(Y, run.params)
    work = simpson(-top.mu * s["gn"] * (s["nu_x"] ** 2 + s["nu_y"] ** 2), x=tt)
    assert s["E"][-1] - s["E"][0] == pytest.approx(work, rel=1e-7)


def test_modified_energy_satisfies_the_METT_at_every_sample(run, top):
    # docs/theory/mett.md#the-main-equation: Ẽ = g(z) θ̇² + V(z, D, λ) holds pointwise while gliding, with D(t) and λ.
    z = np.cos(run.theta)
    rhs = mett.g(top, z) * run.thetadot**2 + mett.V(top, z, run.D, run.lam)
    residual = np.abs(run.E_mod - rhs) / run.E_mod
    assert residual.max() < 1e-10  # measured 1e-13
    # ... and with E in place of Ẽ it fails by up to 6.2e-3 J over all samples (docs/theory/notes.md#energy-vs-modified-energy)
    assert np.max(np.abs(run.E - rhs)) > 1e-3


def test_modified_energy_is_not_monotone_while_E_is(run):
    # docs/theory/equations.md#integrals: Ẽ(3 s) = 4.1090e-2 < Ẽ(4 s) = 4.1170e-2, while E decreases strictly.
    idx = [int(np.argmin(np.abs(run.t - t))) for t in (3.0, 4.0)]
    s3, s4 = run.states_at(3.0), run.states_at(4.0)
    em = MODELS["gliding"].derive(np.stack([s3, s4], axis=1), run.params)["E_mod"]
    assert em[0] == pytest.approx(4.1090e-2, abs=1e-6)
    assert em[1] == pytest.approx(4.1170e-2, abs=1e-6)
    assert em[0] < em[1]
    assert run.E[idx[0]] > run.E[idx[1]]


def test_thesis_D0_E0_are_inconsistent_with_its_initial_data(run, top, start):
    # docs/theory/notes.md#thesis-d0-e0: the thesis quotes D0 ≈ 9.381e-4, E0 ≈ 4.912e-2 for this run. The initial data
    # give D(0) = 7.3008e-4 and E(0) = 4.2153e-2 (ν(0) = 0), and the quoted pair is not even an
    # admissible METT state at this λ: min_z V(z, 9.381e-4, λ) = 0.1003 J > 0.04912 J.
    D_thesis, E_thesis = 9.381e-4, 4.912e-2
    assert run.D[0] == pytest.approx(7.3008e-4, rel=1e-4)
    assert run.E[0] == pytest.approx(4.2153e-2, rel=1e-4)
    assert abs(run.D[0] / D_thesis - 1) > 0.2
    assert abs(run.E[0] / E_thesis - 1) > 0.1
    lam = run.lam[0]
    z = np.linspace(-0.999, 0.999, 20001)
    V_min = mett.V(top, z, D_thesis, lam).min()
    assert V_min == pytest.approx(0.1003, abs=2e-4)
    assert V_min > E_thesis
    assert mett.classify_motion(top, E_thesis, D_thesis, lam) == "none"
    # Nor does the run ever reach the pair: D(t) and E(t) stay below it throughout.
    assert run.D.max() < 0.8 * D_thesis
    assert run.E.max() < 0.9 * E_thesis
    # With the CM at rest instead, E(0) = 4.1195e-2: no better.
    alt = mett.State.with_cm_at_rest(top, theta=THETA0, omega3=OMEGA0)
    assert float(mett.energy(top, alt)) == pytest.approx(4.1195e-2, rel=1e-4)


# --- Trajectory API --------------------------------------------------------------------------


def test_dense_output_matches_the_samples(run):
    for k in (0, 100, len(run) // 2, len(run) - 1):
        s = run.at(run.t[k])
        assert s.theta == pytest.approx(run.theta[k], abs=1e-13)
        assert s.omega3 == pytest.approx(run.omega3[k], rel=1e-13)
        assert s.nu_x == pytest.approx(run.nu_x[k], abs=1e-13)
    states = run.at(np.array([1.0, 2.0, 3.0]))
    assert states.shape == (3,)


def test_crossings_are_root_found_on_the_dense_output(run):
    level = 0.3
    tc = run.crossings(level)
    assert tc.size >= 3
    assert np.allclose(run.theta_at(tc), level, atol=1e-12, rtol=0)
    # brute force on a fine grid finds the same number of sign changes
    tt = np.linspace(0.0, T_END, 200001)
    h = run.theta_at(tt) - level
    assert np.count_nonzero(h[:-1] * h[1:] < 0) == tc.size
    up, down = run.crossings(level, direction=1), run.crossings(level, direction=-1)
    assert up.size + down.size == tc.size
    assert np.all(run.at(up).thetadot > 0) and np.all(run.at(down).thetadot < 0)


def test_crossings_validate_their_input(run):
    with pytest.raises(ValueError, match=r"theta_value must lie in \[0, pi\]"):
        run.crossings(4.0)
    with pytest.raises(ValueError, match="direction"):
        run.crossings(1.0, direction=2)
    with pytest.raises(ValueError, match="simulated interval"):
        run.at(T_END + 1.0)


def test_t_eval_and_events(top, start):
    te = np.linspace(0.0, 1.0, 11)

    def half_spin(t, state):
        return state.omega3 - 154.9

    def stop_at_0p8(t, state):
        return t - 0.8

    stop_at_0p8.terminal = True
    tr = simulate(top, start, 1.0, t_eval=te, events=[half_spin, stop_at_0p8])
    assert tr.status == "completed"
    assert "terminal event 1" in tr.message
    assert tr.t[-1] == pytest.approx(0.8, abs=1e-12)
    assert np.array_equal(tr.t[:-1], te[te < 0.8])
    assert len(tr.t_events) == 2 and tr.t_events[1] == pytest.approx([0.8])
    full = simulate(top, start, 1.0)
    assert np.all(full.at(tr.t_events[0]).omega3 == pytest.approx(154.9, abs=1e-8))


def test_vertical_spins_are_handled_without_nan(top):
    # At exactly sin θ = 0, φ and the split of ν are undefined; the convention φ = φ̇ = 0 keeps
    # every series finite. Both vertical spins are equilibria (exactly, with no tilt at all).
    for state in (mett.State(theta=0.0, omega3=155.0), mett.State(theta=math.pi, omega3=-80.0)):
        tr = simulate(top, state, 0.5)
        assert tr.status == "completed"
        for name, series in tr.as_dict().items():
            assert np.all(np.isfinite(series)), name
        assert np.all(tr.theta == state.theta)
        assert np.all(tr.phidot == 0.0)
        assert np.all(tr.psidot == state.omega3)


# --- status handling -------------------------------------------------------------------------


def test_contact_lost_at_the_start(top):
    # θ > π/2 with a large θ̇: the CM would have to accelerate downwards faster than g.
    tr = simulate(top, mett.State(theta=2.0, thetadot=100.0, omega3=10.0), 1.0,
                  stop_on_contact_loss=True)  # fmt: skip
    assert tr.status == "contact_lost"
    assert tr.t_contact_lost == 0.0 and len(tr) == 1
    assert "t = 0" in tr.message and tr.gn[0] < 0


def _broken_model(failure):
    """The gliding model with a Python RHS that misbehaves after t = 0.1 s (no compiled twin)."""
    good = MODELS["gliding"]

    def rhs(t, y, p):
        if t > 0.1:
            return failure()
        return good.rhs(t, y, p)

    return dataclasses.replace(good, rhs=rhs, rhs_into=None)


@pytest.mark.parametrize(
    "failure",
    [lambda: 1.0 / 0.0, lambda: np.full(10, np.nan), lambda: np.full(10, np.inf)],
    ids=["ZeroDivisionError", "nan", "inf"],
)
def test_integrator_failure_is_a_status_not_an_exception(top, start, failure):
    tr = simulate(top, start, 1.0, model=_broken_model(failure))
    assert tr.status == "failed"
    assert "failed at t = 0.1" in tr.message
    assert tr.t[-1] == pytest.approx(0.1, abs=1e-3)
    assert np.all(np.isfinite(tr.theta))


def test_euler_form_stops_at_its_pole_singularity(top):
    # Heading straight for θ = 0: the Euler form (φ̈ ∝ 1/sin θ) must stop, the vector form goes on.
    state = mett.State(theta=1e-5, thetadot=-1.0, omega3=155.0)
    tr = simulate(top, state, 0.1, model="gliding-euler")
    assert tr.status == "failed"
    assert "singular at sin(theta) = 0" in tr.message and "model='gliding'" in tr.message
    assert np.sin(tr.theta[-1]) == pytest.approx(1e-6, rel=1e-6)
    assert simulate(top, state, 0.1).status == "completed"


# --- bad input -------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"t_end": 0.0}, r"t_end must lie in \(0, inf\); got 0.0"),
        ({"t_end": -1.0}, r"t_end must lie in \(0, inf\)"),
        ({"t_end": math.nan}, "t_end must be finite"),
        ({"rtol": 0.0}, r"rtol must lie in \[2.22e-14, 0.01\] .*; got 0.0"),
        ({"rtol": -1e-8}, r"rtol must lie in \[2.22e-14, 0.01\]"),
        ({"atol": -1.0}, r"atol must lie in \(0, inf\)"),
        ({"atol": [1e-10, 1e-10]}, "one entry per model state component"),
        (
            {"model": "sliding"},
            "unknown model 'sliding'; known models: gliding, rolling, gliding-hst",
        ),
        ({"method": "Euler"}, "unknown method 'Euler'; known methods: DOP853"),
        ({"t_eval": [0.0, 2.0]}, r"t_eval must lie in \[0, t_end\]"),
        ({"t_eval": [0.5, 0.2]}, "t_eval must be strictly increasing"),
        ({"l": 0.01}, "applies only to model 'gliding-hst'"),
    ],
)
def test_bad_arguments_raise_value_error(top, start, kwargs, match):
    args = {"t_end": 1.0, **kwargs}
    t_end = args.pop("t_end")
    with pytest.raises(ValueError, match=match):
        simulate(top, start, t_end, **args)


def test_bad_states_raise_value_error(top):
    with pytest.raises(ValueError, match="theta must be finite; got nan"):
        simulate(top, [math.nan, 0, 0, 155, 0, 0], 1.0)
    with pytest.raises(ValueError, match="omega3 must be finite"):
        simulate(top, np.array([0.1, 0, 0, math.inf, 0, 0]), 1.0)
    with pytest.raises(ValueError, match=r"theta must lie in \[0, pi\]; got 3.5"):
        simulate(top, [3.5, 0, 0, 155, 0, 0], 1.0)
    with pytest.raises(ValueError, match=r"theta must lie in \[0, pi\]; got -0.1"):
        simulate(top, mett.State(theta=-0.1, omega3=1.0), 1.0)
    with pytest.raises(ValueError, match="single State"):
        simulate(top, mett.State(theta=[0.1, 0.2], omega3=1.0), 1.0)
    with pytest.raises(ValueError, match="rolling model needs a contact point at rest"):
        simulate(top, mett.State(theta=0.1, omega3=1.0, nu_x=0.1), 1.0, model="rolling")
    with pytest.raises(ValueError, match=r"phidot = omega3 = nu_y = 0; got omega3 = 1\.0"):
        simulate(top, mett.State(theta=0.1, omega3=1.0), 1.0, model="cylinder")
    with pytest.raises(TypeError, match=r"top must be a mett\.TippeTop"):
        simulate("rutstam2013", mett.State(theta=0.1), 1.0)


def test_public_names():
    assert mett.simulate is simulate
    assert mett.Trajectory is Trajectory
    assert set(MODELS) >= {"gliding", "rolling", "gliding-hst", "cylinder"}
    assert "simulate" in mett.__all__ and "Trajectory" in mett.__all__
