"""The Taylor-series backend (mett.dynamics.taylor): recurrences, accuracy, events, batches.

Independent checks: the jet's coefficients against closed-form series (exp, 1/(1 − t), the
pendulum's energy) and against the model's own right-hand side and its derivative along the flow
(finite differences); every registered model against the compiled DOP853 at a much tighter
tolerance; the thesis inversion time against its converged value; event times against DOP853's;
several trajectories in one SIMD batch against the same trajectories one at a time.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
import stop_bounds

import mett
from mett.dynamics import MODELS, simulate, taylor
from mett.dynamics.flight import ViscousArtefactWarning
from mett.dynamics.taylor import _trace

TOP = mett.presets.get("rutstam2013")
THESIS = mett.State(theta=0.1, omega3=155.0)
T_HALF = 5.879749518045809  # first θ = π/2 of the thesis run, converged (DOP853 and Taylor, 1e-14)


def _exp_into(t, y, p, out):
    out[0] = p[0] * y[0]


def _blowup_into(t, y, p, out):
    out[0] = y[0] * y[0]


def _pendulum_into(t, y, p, out):
    out[0] = y[1]
    out[1] = -p[0] * np.sin(y[0])


def _jet(rhs_into, y0, p, order, events=()):
    k = taylor.kernel(rhs_into, list(events), len(y0), len(p), order, "test")
    sol = taylor.solve(k, (0.0, 1e-300), y0, p)[0]  # one (tiny) step: its coefficients
    return sol.dense.C[0]


def test_jet_of_exp_is_the_exponential_series():
    C = _jet(_exp_into, [2.0], [0.5], 12)
    k = np.arange(13)
    expected = 2.0 * 0.5**k / np.array([math.factorial(j) for j in k], dtype=float)
    np.testing.assert_allclose(C[0], expected, rtol=1e-15, atol=0)


def _product_into(t, y, p, out):
    out[0] = y[0] * y[1]
    out[1] = p[0]


def test_the_jet_copies_values_exactly_negative_zero_included():
    # Values are copied in the IR as x + (−0), an identity for every double (x + 0 would turn
    # −0 into +0): the state's coefficient 0 and a product's coefficients keep their sign
    C = _jet(_product_into, [-0.0, 1.0], [2.0], 6)
    assert math.copysign(1.0, C[0, 0]) == -1.0  # y0(0) = −0, as given
    assert math.copysign(1.0, C[0, 1]) == -1.0  # ẏ0 = y0 y1 = −0 · 1 = −0
    np.testing.assert_array_equal(C[1, :2], [1.0, 2.0])


def test_jet_of_a_square_is_the_geometric_series():
    # y' = y², y(0) = 1: y = 1/(1 − t) = Σ t^k
    C = _jet(_blowup_into, [1.0], [], 14)
    np.testing.assert_allclose(C[0], np.ones(15), rtol=1e-14)


def test_sin_cos_recurrences_conserve_the_pendulum_energy():
    k = taylor.kernel(_pendulum_into, [], 2, 1, 20, "pendulum")
    sol = taylor.solve(k, (0.0, 50.0), [2.5, 0.0], [9.81])[0]
    tt = np.linspace(0.0, 50.0, 2001)
    th, om = sol.dense(tt)
    energy = 0.5 * om**2 - 9.81 * np.cos(th)
    assert np.ptp(energy) < 1e-11 * abs(energy[0])
    assert sol.status == taylor.COMPLETED


def test_first_coefficients_are_the_rhs_and_its_flow_derivative():
    mdl = MODELS["gliding"]
    p = mdl.params(TOP, {})
    y0 = np.asarray(mdl.initial(mett.State(theta=1.0, omega3=100.0, phidot=5.0, nu_x=0.1), p))
    C = _jet(mdl.rhs_into, y0, np.array(p), 8)
    f0 = mdl.rhs(0.0, y0, p)
    np.testing.assert_allclose(C[:10, 1], f0, rtol=1e-13, atol=1e-13 * np.abs(f0).max())
    # y_2 = ½ (d/dt) f(y(t)) = ½ J f, by a central difference along f
    eps = 1e-6
    df = (mdl.rhs(0.0, y0 + eps * f0, p) - mdl.rhs(0.0, y0 - eps * f0, p)) / (2 * eps)
    np.testing.assert_allclose(C[:10, 2], 0.5 * df, rtol=1e-6, atol=1e-8 * np.abs(df).max())


def _gliding_jet(y0, p, order, lengths):
    mdl = MODELS["gliding"]
    k = taylor.kernel(mdl.rhs_into, [], 10, 7, order, "frozen", lengths=lengths)
    return taylor.solve(k, (0.0, 1e-300), y0, np.array(p))[0].dense.C[0]


@pytest.mark.parametrize("stretch", [1.0, 1.3, 0.6])
def test_a_frozen_conserved_length_leaves_the_taylor_coefficients_as_they_are(stretch):
    # The jet with |3̂| taken as a number at the start of the step (Model.conserved_lengths)
    # against the jet of the series of √(Σ 3̂_i²) and the quotients: the same coefficients, also
    # off |3̂| = 1 (there the length is still conserved, so the argument of _freeze_lengths holds)
    mdl = MODELS["gliding"]
    p = mdl.params(TOP, {})
    y0 = np.asarray(mdl.initial(mett.State(theta=1.0, omega3=100.0, phidot=5.0, nu_x=0.1), p))
    y0[7:10] *= stretch
    frozen = _gliding_jet(y0, p, 16, mdl.conserved_lengths)
    series = _gliding_jet(y0, p, 16, ())
    scale = np.abs(series).max(axis=1, keepdims=True)  # per component, over the orders
    np.testing.assert_allclose(frozen / scale, series / scale, rtol=0, atol=1e-13)
    # and the coefficients of |3̂|² vanish beyond the first, to rounding: the length is constant
    e = frozen[7:10]
    for k in range(17):
        terms = [e[i, j] * e[i, k - j] for i in range(3) for j in range(k + 1)]
        limit = 1e-15 if k == 0 else 1e-13 * sum(abs(x) for x in terms)
        assert abs(sum(terms) - (stretch**2 if k == 0 else 0.0)) <= limit, k


def test_only_the_declared_lengths_are_frozen():
    mdl = MODELS["gliding"]
    frozen = taylor.trace(mdl.rhs_into, [], 10, 7, lengths=mdl.conserved_lengths)
    ops = [frozen.nodes[i][0] for i in _trace._live(frozen)]
    assert ops.count("len") == 1 and "sqrt" not in ops
    # L is a vector but its length is not conserved: declaring the wrong group changes nothing
    # in the graph (no √|L|² is computed), and a partial group of the axis is no match either
    for lengths in [((4, 5, 6),), ((7, 8),)]:
        tr = taylor.trace(mdl.rhs_into, [], 10, 7, lengths=lengths)
        ops = [tr.nodes[i][0] for i in _trace._live(tr)]
        assert "len" not in ops and ops.count("sqrt") == 1


def test_a_branch_on_the_state_cannot_be_traced():
    def branchy(t, y, p, out):
        out[0] = y[0] if y[0] > 0 else -y[0]

    with pytest.raises(TypeError, match="branch"):
        taylor.trace(branchy, [], 1, 0)


def test_finite_time_blowup_is_a_status_not_a_crash():
    k = taylor.kernel(_blowup_into, [], 1, 0, 16, "blowup")
    sol = taylor.solve(k, (0.0, 2.0), [1.0], [])[0]
    assert sol.status in (taylor.STEP_TOO_SMALL, taylor.NON_FINITE)
    assert 0.99 < sol.dense.t_max < 1.0 + 1e-12  # y = 1/(1 − t) ends at t = 1


def test_thesis_inversion_time_within_1e_10_at_rtol_1e_12():
    traj = simulate(TOP, THESIS, 8.0, backend="taylor", rtol=1e-12)
    assert traj.status == "completed"
    assert traj.backend == "taylor"
    assert abs(traj.crossings(math.pi / 2)[0] - T_HALF) < 1e-10
    assert abs(traj.lam[-1] / traj.lam[0] - 1.0) < 1e-11
    # the end state: ω3 → −λ/(R I3 (1 + α)) (inverted spin)
    w_end = -traj.lam[0] / (TOP.R * TOP.I3 * (1 + TOP.alpha))
    assert abs(traj.omega3[-1] / w_end - 1.0) < 1e-4


STARTS = {
    "gliding": mett.State(theta=0.5, omega3=155.0, phidot=3.0, nu_x=0.05),
    "rolling": mett.State(theta=1.0, omega3=100.0, phidot=5.0),
    "gliding-hst": mett.State(theta=0.5, omega3=155.0),
    "cylinder": mett.State(theta=0.5, thetadot=2.0, nu_x=0.01),
    "gliding-euler": mett.State(theta=0.5, omega3=155.0, thetadot=1.0),
    "frictionless-routhian": mett.State(theta=0.5, omega3=155.0, thetadot=1.0),
}


# models that need options of their own are checked separately (stem, dry friction: below)
_OWN_TEST = {"stemmed", "coulomb", "coulomb-contensou", "coulomb-regularised", "stemmed-coulomb",
             "stemmed-coulomb-contensou", "stemmed-coulomb-regularised",
             "rolling-resistance"}  # fmt: skip


@pytest.mark.parametrize("name", sorted(STARTS))
def test_every_model_agrees_with_dop853(name):
    compiled = {n for n, m in MODELS.items() if m.rhs_into is not None}
    assert set(STARTS) | _OWN_TEST >= compiled
    mdl = MODELS[name]
    a = simulate(TOP, STARTS[name], 1.0, model=name, backend="taylor", rtol=1e-12)
    b = simulate(TOP, STARTS[name], 1.0, model=name, backend="compiled", rtol=3e-14)
    assert a.status == b.status == "completed"
    tt = np.linspace(0.0, 1.0, 101)
    p = mdl.params(TOP, {})
    scale = mdl.scales(a.states_at(0.0), p)
    err = np.abs((a.states_at(tt) - b.states_at(tt)) / scale[:, None]).max()
    assert err < 1e-9, err


def test_dense_output_is_continuous_at_the_steps():
    mdl = MODELS["gliding"]
    k = taylor.kernel(mdl.rhs_into, [ev.fn for ev in mdl.events], 10, 7, 15, "gliding")
    p = mdl.params(TOP, {})
    dense = taylor.solve(k, (0.0, 2.0), mdl.initial(THESIS, p), p, direction=[-1.0])[0].dense
    ends = dense(dense.t[1:] * (1 - 1e-16))  # each step's polynomial at its end ...
    starts = dense.y[1:].T  # ... and the next step's start
    scale = mdl.scales(dense.y[0], p)
    assert np.abs((ends - starts) / scale[:, None]).max() < 1e-12


def test_contact_loss_located_like_dop853():
    top = TOP.replace(mu=0.1)
    start = mett.State(theta=0.1, omega3=250.0)
    a = simulate(top, start, 20.0, backend="taylor", rtol=1e-12, stop_on_contact_loss=True)
    b = simulate(top, start, 20.0, backend="compiled", rtol=1e-13, stop_on_contact_loss=True)
    assert a.status == b.status == "contact_lost"
    assert abs(a.t_contact_lost - b.t_contact_lost) < 1e-7
    assert a.gn[-1] == pytest.approx(0.0, abs=1e-9 * top.m * top.g)


def test_pole_guard_of_the_euler_form_stops_the_run():
    start = mett.State(theta=0.02, omega3=0.0, thetadot=-1.0)
    a = simulate(TOP, start, 1.0, model="gliding-euler", backend="taylor", rtol=1e-12)
    b = simulate(TOP, start, 1.0, model="gliding-euler", backend="compiled", rtol=1e-13)
    assert a.status == b.status == "failed"
    assert abs(a.t[-1] - b.t[-1]) < 1e-9


def test_user_events_and_t_eval_work_as_on_dop853():
    def half(t, s):
        return s.theta - math.pi / 2

    half.terminal = True
    t_eval = np.linspace(0.0, 8.0, 81)
    a = simulate(TOP, THESIS, 8.0, backend="taylor", rtol=1e-12, events=[half], t_eval=t_eval)
    assert a.t_events[0][0] == pytest.approx(T_HALF, abs=1e-9)
    assert a.t[-1] == pytest.approx(T_HALF, abs=1e-9)
    np.testing.assert_array_equal(a.t[:-1], t_eval[t_eval < a.t[-1]])


def test_a_batch_of_lanes_equals_one_trajectory_at_a_time():
    mdl = MODELS["gliding"]
    p = np.array(mdl.params(TOP, {}))
    y0 = np.asarray(mdl.initial(THESIS, tuple(p)))
    P = np.tile(p, (6, 1))
    P[:, 5] = np.linspace(0.1, 0.6, 6)  # six friction coefficients; 6 = one full batch of 4 + 2
    events = [ev.fn for ev in mdl.events]
    k1 = taylor.kernel(mdl.rhs_into, events, 10, 7, 15, "gliding", lanes=1)
    k4 = taylor.kernel(mdl.rhs_into, events, 10, 7, 15, "gliding", lanes=4)
    one = [taylor.solve(k1, (0.0, 1.0), y0, P[j], direction=[-1.0])[0] for j in range(6)]
    many = taylor.solve(k4, (0.0, 1.0), np.tile(y0, (6, 1)), P, direction=[-1.0])
    for a, b in zip(one, many, strict=True):
        assert a.n_steps == b.n_steps
        np.testing.assert_allclose(b.dense.y, a.dense.y, rtol=1e-14, atol=1e-300)


def test_taylor_backend_refuses_another_method():
    with pytest.raises(ValueError, match="taylor backend"):
        simulate(TOP, THESIS, 1.0, backend="taylor", method="RK45")


def test_order_follows_the_tolerance():
    assert taylor.order_for(1e-10) == 13
    assert taylor.order_for(1e-12) == 15
    assert taylor.order_for(1e-16) == 20


def test_save_and_load_keep_the_taylor_dense_output(tmp_path):
    traj = simulate(TOP, THESIS, 2.0, backend="taylor", rtol=1e-12)
    path = tmp_path / "run.npz"
    traj.save(path)
    back = mett.Trajectory.load(path)
    tt = np.linspace(0.0, 2.0, 501)
    np.testing.assert_array_equal(back.states_at(tt), traj.states_at(tt))
    np.testing.assert_array_equal(back.theta, traj.theta)
    assert back.backend == "taylor"


def test_each_step_polynomial_ends_on_the_stored_state_at_the_stored_time(tmp_path):
    # The dense output evaluates step i's polynomial at t − T[i]; the loop must take the step to
    # the very T[i+1] it stores, not to the unrounded t + h (a jump of ~|ẏ| ε t per step, 230 ulps
    # of the axis late in the thesis run, which the file format rightly refused as a dense
    # output that does not join). Reference: Horner in numpy at diff(T); the rounding of a
    # polynomial evaluation is a few ulps of its terms (≤ the component's scale here).
    traj = simulate(TOP, THESIS, 7.0, backend="taylor")
    dense = traj._sol
    C = dense.C[:, : dense.n]
    h = np.diff(dense.t)[:, None]
    end = C[:, :, -1]
    for k in range(C.shape[2] - 2, -1, -1):
        end = end * h + C[:, :, k]
    scale = np.abs(dense.y).max(axis=0)
    eps = np.finfo(float).eps
    assert np.all(np.abs(end - dense.y[1:]) <= 8 * eps * scale)
    path = traj.save(tmp_path / "thesis.npz")  # the format's own check
    assert np.array_equal(mett.load(path).states_at(traj.t), traj.states_at(traj.t))


def test_stemmed_top_touches_down_as_on_dop853():
    # a hybrid model (ball and stem phases, impacts as jumps): a Leine–Glocker-like body just
    # before touchdown (the stem tests' start)
    ball = mett.TippeTop(m=0.006, R=0.015, alpha=0.2, I1=8e-7, I3=7e-7, mu=0.3)
    top = ball.with_stem(radius=0.005, distance=0.016)
    start = mett.State(theta=2.15, thetadot=2.0, phidot=110.0, omega3=-76.0, nu_y=0.16)
    a = simulate(top, start, 0.5, backend="taylor", rtol=1e-12)
    b = simulate(top, start, 0.5, backend="compiled", rtol=1e-13)
    assert a.status == b.status
    assert len(a.touchdowns) == len(b.touchdowns) >= 1
    np.testing.assert_allclose(a.touchdowns, b.touchdowns, rtol=0, atol=1e-9)
    assert a.contact[-1] == b.contact[-1]


def test_dry_friction_models_run_on_the_taylor_backend():
    # hybrid models that branch on their parameters (Contensou radius > 0): the kernel is traced
    # for the run's parameters and serves every parameter set that takes the same branches
    from mett.friction import Coulomb

    start = mett.State.with_cm_at_rest(TOP, theta=0.1, omega3=155.0)
    a = simulate(TOP, start, 0.8, friction=Coulomb(0.02), backend="taylor", rtol=1e-10)
    b = simulate(TOP, start, 0.8, friction=Coulomb(0.02), backend="compiled", rtol=1e-10)
    assert a.model == b.model == "coulomb"
    # the first stop (sliding → rolling) and the first cone switch agree; near a cone switch the
    # Taylor polynomials of max(x, 0) = (x + √x²)/2 can add zero-length switch pairs
    # Tolerances from the error analysis: two integrators at rtol = 1e-10 differ by up to the
    # sum of their errors. The first stop fires when |v_A|, falling at the rate a (m/s²), is in
    # the stopping band [0, δ], δ = 10 rtol × the velocity scale: up to δ/a early; the error of
    # v_A there is at most the local error allowed per step, δ/10, over the N steps of the slide
    # (N of DOP853; Taylor's order 13 takes fewer): N δ/(10 a). The cone switch after it inherits
    # the shift; the integration error elsewhere is estimated by the DOP853 run at rtol/100.
    fine = simulate(TOP, start, 0.8, friction=Coulomb(0.02), backend="compiled", rtol=1e-12)
    stop = b.switches[0]
    assert stop.reason == fine.switches[0].reason == "stop"
    stop_shift = stop_bounds.stop_shift(b, n=1)
    t_err = max(abs(x.t - y.t) for x, y in zip(b.switches[:2], fine.switches[:2], strict=True))
    t_tol = 2.0 * (t_err + stop_shift)
    np.testing.assert_allclose([s.t for s in a.switches[:2]], [s.t for s in b.switches[:2]],
                               rtol=0, atol=t_tol)  # fmt: skip
    theta_tol = 2.0 * abs(b.theta[-1] - fine.theta[-1]) + np.abs(b.thetadot).max() * t_tol
    assert abs(a.theta[-1] - b.theta[-1]) < theta_tol
    assert abs(a.lam[-1] / a.lam[0] - 1.0) < 1e-9
    c = simulate(TOP, start, 0.2, friction=Coulomb(0.3, contensou_radius=3e-3), backend="taylor")
    d = simulate(TOP, start, 0.2, friction=Coulomb(0.3, contensou_radius=3e-3))
    assert c.model == d.model == "coulomb-contensou"
    assert abs(c.theta[-1] - d.theta[-1]) < 1e-7


def test_the_stemmed_top_under_dry_friction_runs_on_the_taylor_backend():
    # ball and stem, sliding and rolling, touchdowns and landings with the dry impact law
    from mett.friction import Coulomb

    ball = mett.TippeTop(m=0.006, R=0.015, alpha=0.2, I1=8e-7, I3=7e-7, mu=0.3)
    top = ball.with_stem(radius=0.005, distance=0.016)
    start = mett.State(theta=2.15, thetadot=2.0, phidot=110.0, omega3=-76.0, nu_y=0.16)
    a = simulate(top, start, 0.5, friction=Coulomb(0.3), backend="taylor", rtol=1e-10)
    b = simulate(top, start, 0.5, friction=Coulomb(0.3), backend="compiled", rtol=1e-10)
    assert a.model == b.model == "stemmed-coulomb" and a.status == b.status == "completed"
    assert a.touchdowns.size == b.touchdowns.size >= 2
    np.testing.assert_allclose(a.touchdowns, b.touchdowns, rtol=0, atol=1e-8)
    assert a.contact[-1] == b.contact[-1]
    assert abs(a.theta[-1] - b.theta[-1]) < 1e-6


def test_a_kernel_refuses_parameters_that_take_other_branches():
    def branchy(t, y, p, out):
        out[0] = y[0] * p[0] if p[1] > 0.0 else -y[0] * p[0]

    k = taylor.kernel(branchy, [], 1, 2, 10, "branchy", params=[1.0, 1.0])
    up = taylor.solve(k, (0.0, 1.0), [1.0], [1.0, 2.0])[0]
    assert up.dense(1.0)[0] == pytest.approx(math.e, rel=1e-8)  # order 10: ε ≈ e^-18
    with pytest.raises(ValueError, match="other branches"):
        taylor.solve(k, (0.0, 1.0), [1.0], [1.0, -1.0])
    k2 = taylor.kernel(branchy, [], 1, 2, 10, "branchy", params=[1.0, -1.0])
    assert k2 is not k
    down = taylor.solve(k2, (0.0, 1.0), [1.0], [1.0, -1.0])[0]
    assert down.dense(1.0)[0] == pytest.approx(math.exp(-1.0), rel=1e-8)


def _rotated_about_z(y: np.ndarray, beta: float) -> np.ndarray:
    """A gliding-model state turned by ``beta`` about the vertical: the same motion, seen from a
    space frame turned by −beta (x, y; ẋ, ẏ; L; 3̂ are horizontal pairs + vertical parts)."""
    c, s = math.cos(beta), math.sin(beta)
    out = y.copy()
    for i, j in ((0, 1), (2, 3), (4, 5), (7, 8)):
        out[i], out[j] = c * y[i] - s * y[j], s * y[i] + c * y[j]
    return out


def test_steps_do_not_depend_on_the_orientation_of_the_space_frame():
    # The step-size norm measures each vector of the state (velocity, L, 3̂) by its length: the
    # same motion started in a frame turned about ẑ takes the same steps. (A component-wise norm
    # takes ~25 % more steps in the thesis frame, where L_x = 0 and 3̂_x = 0 at the start.)
    mdl = MODELS["gliding"]
    p = np.array(mdl.params(TOP, {}))
    y0 = np.asarray(mdl.initial(THESIS, tuple(p)))
    scales = mdl.scales(y0, tuple(p))
    k = taylor.kernel(mdl.rhs_into, [], 10, 7, 17, "gliding", vectors=mdl.vectors)
    runs = [
        taylor.solve(k, (0.0, 3.0), _rotated_about_z(y0, b), p, scales=scales)[0]
        for b in (0.0, 0.7, 2.0)
    ]
    h = [r.dense.h for r in runs]
    for other in h[1:]:
        assert other.size == h[0].size
        np.testing.assert_allclose(other, h[0], rtol=1e-9)
    # and the states agree once turned back
    end = [_rotated_about_z(r.dense.y[-1], -b) for r, b in zip(runs, (0.0, 0.7, 2.0), strict=True)]
    for e in end[1:]:
        np.testing.assert_allclose(e, end[0], rtol=1e-9, atol=1e-12 * np.abs(end[0]).max())
    # the component-wise norm, for contrast, depends on the frame
    kc = taylor.kernel(mdl.rhs_into, [], 10, 7, 17, "gliding")
    n = [taylor.solve(kc, (0.0, 3.0), _rotated_about_z(y0, b), p, scales=scales)[0].n_steps
         for b in (0.0, 0.7)]  # fmt: skip
    assert n[0] != n[1]
    assert h[0].size < min(n)


@pytest.mark.parametrize("bad", [((0, 1), (1, 2)), ((0, 10),), ((),)])
def test_vectors_of_the_norm_are_checked(bad):
    mdl = MODELS["gliding"]
    with pytest.raises(ValueError, match="vectors"):
        taylor.kernel(mdl.rhs_into, [], 10, 7, 12, "gliding", vectors=bad)


def _ez(t, y, p):
    return y[9]


def test_propagate_gives_the_end_states_samples_and_crossings_of_solve():
    # propagate keeps no dense output; its end states, samples and the first zero of a
    # recording event must be those of solve's dense solution, lane by lane
    mdl = MODELS["gliding"]
    p = np.array(mdl.params(TOP, {}))
    y0 = np.asarray(mdl.initial(THESIS, tuple(p)))
    scales = mdl.scales(y0, tuple(p))
    P = np.tile(p, (6, 1))
    P[:, 5] = [0.3, 0.05, 0.25, 0.35, 0.3, 0.45]
    Y = np.tile(y0, (6, 1))
    contact = [ev.fn for ev in mdl.events]
    k = taylor.kernel(mdl.rhs_into, [*contact, _ez], 10, 7, 17, "gliding", lanes=4,
                      vectors=mdl.vectors)  # fmt: skip
    tt = np.linspace(6.0, 7.0, 11)
    b = taylor.propagate(k, (0.0, 7.0), Y, P, scales=scales, direction=[-1.0, 0.0],
                         terminal=[True, False], t_eval=tt)  # fmt: skip
    # the crossing as a terminal event: solve stops where propagate recorded it
    stop = taylor.solve(k, (0.0, 7.0), Y, P, scales=scales, direction=[-1.0, 0.0])
    # without the crossing event: the very same steps as propagate
    k0 = taylor.kernel(mdl.rhs_into, contact, 10, 7, 17, "gliding", lanes=4, vectors=mdl.vectors)
    ref = taylor.solve(k0, (0.0, 7.0), Y, P, scales=scales, direction=[-1.0])
    assert np.isfinite(b.first[:, 1]).sum() >= 3 and (b.status == taylor.TERMINAL_EVENT).any()
    for j in range(6):
        if np.isfinite(b.first[j, 1]):
            assert stop[j].status == taylor.TERMINAL_EVENT and stop[j].event_index == 1
            assert b.first[j, 1] == stop[j].dense.t[-1]
        assert (b.status[j], b.event_index[j]) == (ref[j].status, ref[j].event_index)
        assert b.status[j] in (taylor.COMPLETED, taylor.TERMINAL_EVENT)
        assert b.n_steps[j] == ref[j].n_steps and b.t[j] == ref[j].dense.t[-1]
        np.testing.assert_array_equal(b.y[j], ref[j].dense.y[-1])
        inside = tt <= b.t[j]
        np.testing.assert_allclose(b.samples[j][inside], ref[j].dense(tt[inside]).T, atol=1e-15)
        assert np.isnan(b.samples[j][~inside]).all()
    # the thesis top (μ = 0.3, lanes 0 and 4: one batch each) crosses at the converged time
    assert abs(b.first[0, 1] - T_HALF) < 1e-10 and b.first[4, 1] == b.first[0, 1]


def test_propagate_checks_its_arguments():
    k = taylor.kernel(_exp_into, [], 1, 1, 8, "test")
    with pytest.raises(ValueError, match="t_eval"):
        taylor.propagate(k, (0.0, 1.0), [1.0], [1.0], t_eval=[0.5, 0.2])
    with pytest.raises(ValueError, match="entry per event"):
        taylor.propagate(k, (0.0, 1.0), [1.0], [1.0], terminal=[True])


# --- a NaN in the jet ends the run at its last finite step (reliability: Caches and compiled code)

DBL_MAX = float(np.finfo(float).max)
_BIG = 1e154


def _overflow_into(t, y, p, out):
    # y0 = t and y1' = a² − a² with a = p y0: exactly 0 while the coefficients of a² are finite.
    # (a²)_1 = 2 p² t overflows for t > t* = DBL_MAX / (2 p²), and inf − inf makes the jet NaN
    # while the state stays finite: the case a max that ignores NaN turned into a step to t_end
    a = p[0] * y[0]
    out[0] = 1.0
    out[1] = a * a - a * a


def _check_stopped_after_overflow(t, y, p, max_step):
    t_star = DBL_MAX / p / p / 2.0  # (2 p² itself overflows)
    # the last kept state is the first step start beyond t* (its jet is the first non-finite)
    assert t_star < t[-1] <= t_star + max_step * (1 + 1e-12)
    assert np.isfinite(y).all()
    np.testing.assert_array_equal(y[:, 0], t)  # y0 = t: y0 + 1·h is the same sum as t + h
    assert (y[:, 1] == 0.0).all()


def test_a_nan_jet_stops_solve_at_the_last_finite_step():
    k = taylor.kernel(_overflow_into, [], 2, 1, 8, "overflow")
    sol = taylor.solve(k, (0.0, 2.0), [0.0, 0.0], [_BIG], max_step=0.1)[0]
    assert sol.status == taylor.NON_FINITE
    _check_stopped_after_overflow(sol.dense.t, sol.dense.y, _BIG, 0.1)
    assert np.isfinite(sol.dense.C).all()  # the failed step's polynomial is not kept


def test_a_nan_jet_stops_propagate_at_the_last_finite_step():
    # the batch path (SIMD lanes, no dense output): one lane overflows, the other completes
    k = taylor.kernel(_overflow_into, [], 2, 1, 8, "overflow", lanes=2)
    tt = np.array([0.5, 0.95, 1.5])
    b = taylor.propagate(k, (0.0, 2.0), np.zeros((2, 2)), [[_BIG], [1.0]], t_eval=tt,
                         max_step=0.1)  # fmt: skip
    assert b.status.tolist() == [taylor.NON_FINITE, taylor.COMPLETED]
    _check_stopped_after_overflow(b.t[:1], b.y[:1], _BIG, 0.1)
    np.testing.assert_allclose(b.samples[0, 0], [0.5, 0.0], rtol=1e-15)
    assert np.isnan(b.samples[0, 1:]).all()  # after the stop: no samples
    np.testing.assert_allclose(b.samples[1], np.column_stack([tt, 0 * tt]), rtol=1e-15)
    assert b.t[1] == 2.0


@pytest.mark.parametrize(
    "case",
    ["mu=1e50", "omega3", "thetadot", "phidot"],
)
def test_non_finite_taylor_runs_keep_only_finite_states(case):
    # μ = 1e50 or a rate at 0.999 RATE_MAX overflow the jet's high-order coefficients: a failure
    # before t_end with only finite samples, as the compiled backend stops early with finite ones
    from mett.dynamics.simulation import RATE_MAX

    top, kw = TOP, {"theta": 0.1, "omega3": 155.0}
    if case == "mu=1e50":
        top = TOP.replace(mu=1e50)
    else:
        kw[case] = 0.999 * RATE_MAX
    t_end = 0.5
    for backend in ("taylor", "compiled"):
        with warnings.catch_warnings():  # such rates lose contact at once: the law's artefact
            warnings.simplefilter("ignore", ViscousArtefactWarning)
            tr = simulate(top, mett.State(**kw), t_end, backend=backend)
        assert tr.status in ("failed", "contact_lost"), (backend, tr.message)
        assert tr.t[-1] < t_end and np.isfinite(tr.states).all(), (backend, tr.message)
        if backend == "taylor":
            assert tr.status == "failed" and "non-finite" in tr.message
            assert f"t = {tr.t[-1]:.9g} s" in tr.message  # the failure where the run stopped


def test_non_finite_taylor_runs_in_a_batch_stop_before_t_end():
    from mett.dynamics.batch import run_ends

    ends = run_ends([(TOP.replace(mu=1e50), THESIS), (TOP, THESIS)], 0.5, backend="taylor")
    bad, good = ends
    assert bad.status == "failed" and bad.t_stop < 0.5 and math.isfinite(bad.theta_end)
    assert good.status == "completed" and good.t_stop == 0.5


def test_output_buffers_reused_across_calls_never_alias_a_result():
    # solve() lends its output buffers to the next call of the same shape (a hopping run's
    # short contact phases): a reused buffer must give the same run bit for bit, and a buffer a
    # result still views (a long run's coefficients) must never be written by a later call.
    k = taylor.kernel(_pendulum_into, [], 2, 1, 20, "pendulum")
    cap = 9973  # a step budget of its own: the buffers' shape, fresh for the first call
    runs = [taylor.solve(k, (0.0, 0.5), [2.5, 0.0], [9.81], max_steps=cap)[0] for _ in range(2)]
    a, b = (r.dense for r in runs)
    for x, y in ((a.t, b.t), (a.y, b.y), (a.C, b.C)):
        np.testing.assert_array_equal(x, y)
        assert not np.shares_memory(x, y)
    long = taylor.solve(k, (0.0, 1e6), [2.5, 0.0], [9.81], max_steps=cap)[0]
    assert long.status == taylor.MAX_STEPS and long.n_steps == cap
    before = long.dense.C.copy()
    taylor.solve(k, (0.0, 0.5), [0.3, 1.0], [9.81], max_steps=cap)
    np.testing.assert_array_equal(long.dense.C, before)
