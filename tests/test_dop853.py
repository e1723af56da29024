"""The compiled DOP853 integrator: agreement with scipy, order of convergence, events, failures.

Numba compile time counts against the test budget, so the right-hand sides here are few, tiny
and cached; each is reused by several tests.
"""

from __future__ import annotations

import math

import numba
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from mett.dynamics import dop853


@numba.njit(cache=True)
def _lotka_volterra(t, y, p, out):
    out[0] = p[0] * y[0] - p[1] * y[0] * y[1]
    out[1] = -p[2] * y[1] + p[3] * y[0] * y[1]


@numba.njit(cache=True)
def _harmonic(t, y, p, out):
    # x'' = -w^2 x; from (1, 0) the solution is (cos wt, -w sin wt)
    out[0] = y[1]
    out[1] = -p[0] * p[0] * y[0]


@numba.njit(cache=True)
def _harmonic_events(t, y, p, out):
    out[0] = y[0]  # zeros at wt = pi/2 + k pi
    out[1] = y[0] + 0.5  # zeros at wt = 2pi/3 + 2k pi (down), 4pi/3 + 2k pi (up)


@numba.njit(cache=True)
def _square(t, y, p, out):
    out[0] = y[0] * y[0]  # y = 1/(1 - t) from y(0) = 1: blows up at t = 1


@numba.njit(cache=True)
def _sqrt_rhs(t, y, p, out):
    out[0] = math.sqrt(p[0] - t)  # nan for t > p[0]


LV_PARAMS = np.array([1.5, 1.0, 3.0, 1.0])
LV_Y0 = np.array([10.0, 5.0])


def _harmonic_exact(t, w=1.0):
    return np.array([np.cos(w * t), -w * np.sin(w * t)])


def _slope(h, err):
    return np.polyfit(np.log(h), np.log(err), 1)[0]


# --- agreement with scipy ---------------------------------------------------------------------


def test_matches_scipy_dop853_steps_and_solution():
    rtol = atol = 1e-10
    t_end = 15.0
    ours = dop853.solve(_lotka_volterra, (0.0, t_end), LV_Y0, LV_PARAMS, rtol=rtol, atol=atol)

    def fun(t, y):
        out = np.empty(2)
        _lotka_volterra(t, y, LV_PARAMS, out)
        return out

    ref = solve_ivp(
        fun, (0.0, t_end), LV_Y0, method="DOP853", rtol=rtol, atol=atol, dense_output=True
    )
    assert ours.status == dop853.COMPLETED and ours.success
    scale = np.max(np.abs(ref.y))
    assert np.max(np.abs(ours.y[:, -1] - ref.y[:, -1])) < 1e-12 * scale
    n_ref = ref.t.size - 1
    assert abs(ours.n_accepted - n_ref) <= max(1, 0.03 * n_ref)
    assert abs(ours.nfev - ref.nfev) <= 0.03 * ref.nfev
    # the same steps up to rounding: the error estimate is a sum with cancellation, so the
    # summation order (ours vs BLAS) moves step sizes by ~1e-10 relative, and that drifts
    assert ours.t.size == ref.t.size
    assert np.max(np.abs(ours.t - ref.t)) < 1e-6 * t_end
    tt = np.linspace(0.0, t_end, 301)
    assert np.max(np.abs(ours.dense(tt) - ref.sol(tt))) < 1e-11 * scale


def test_one_step_equals_the_full_tables():
    # the kernel writes the stage sums out over the non-zeros of the tables: one fixed step of the
    # Lotka-Volterra system must equal the plain dense-table formulas (scipy's rk_step and
    # Dop853DenseOutput), stages 1..12 through y_new and the three extra stages through F
    h = 0.05
    sol = dop853.solve(_lotka_volterra, (0.0, h), LV_Y0, LV_PARAMS, fixed_step=h)

    def f(t, y):
        out = np.empty(2)
        _lotka_volterra(t, y, LV_PARAMS, out)
        return out

    A, C, D = dop853._A, dop853._C, dop853._D
    K = np.zeros((dop853.N_STAGES_EXTENDED, 2))
    K[0] = f(0.0, LV_Y0)
    for s in range(1, dop853.N_STAGES_EXTENDED):  # row 12 of A is b: K[12] = f(t + h, y_new)
        K[s] = f(C[s] * h, LV_Y0 + h * (A[s, :s] @ K[:s]))
    y_new = LV_Y0 + h * (A[dop853.N_STAGES, : dop853.N_STAGES] @ K[: dop853.N_STAGES])
    dy = y_new - LV_Y0
    F = np.vstack([dy, h * K[0] - dy, 2 * dy - h * (K[dop853.N_STAGES] + K[0]), h * (D @ K)])
    np.testing.assert_allclose(sol.y[:, -1], y_new, rtol=1e-14)
    # the dense rows are sums of terms ~1e5 times larger than the result: compare to the rounding
    # bound of the terms (a wrong coefficient or a missing term errs by the size of a term)
    dy_, k0, k12 = np.abs(dy), h * np.abs(K[0]), h * np.abs(K[dop853.N_STAGES])
    terms = np.vstack([dy_, k0 + dy_, 2 * dy_ + k12 + k0, h * (np.abs(D) @ np.abs(K))])
    assert np.all(np.abs(sol.dense.F[0] - F) <= 1e-14 * terms)
    assert sol.nfev == 1 + dop853.N_STAGES_EXTENDED - 1


def test_t_eval_is_the_dense_output():
    tt = np.linspace(0.0, 3.0, 7)
    sol = dop853.solve(_harmonic, (0.0, 3.0), [1.0, 0.0], [1.0], rtol=1e-10, atol=1e-12, t_eval=tt)
    assert np.array_equal(sol.t, tt)
    assert sol.y.shape == (2, 7)
    np.testing.assert_allclose(sol.y, sol.dense(tt), rtol=0, atol=0)
    np.testing.assert_allclose(sol.y, _harmonic_exact(tt), atol=1e-9)
    assert sol.dense(1.0).shape == (2,)


def test_backward_integration_returns_to_start():
    fwd = dop853.solve(_lotka_volterra, (0.0, 2.0), LV_Y0, LV_PARAMS, rtol=1e-12, atol=1e-12)
    back = dop853.solve(
        _lotka_volterra, (2.0, 0.0), fwd.y[:, -1], LV_PARAMS, rtol=1e-12, atol=1e-12
    )
    assert back.status == dop853.COMPLETED
    np.testing.assert_allclose(back.y[:, -1], LV_Y0, rtol=1e-9)
    np.testing.assert_allclose(back.dense(1.0), fwd.dense(1.0), rtol=1e-9)


# --- order of convergence ----------------------------------------------------------------------


def test_fixed_step_global_error_is_eighth_order():
    t_end = 10.0
    steps = np.array([20, 28, 40, 56])
    h = t_end / steps
    err = []
    for hk in h:
        sol = dop853.solve(_harmonic, (0.0, t_end), [1.0, 0.0], [1.0], fixed_step=hk)
        assert sol.n_rejected == 0
        err.append(np.max(np.abs(sol.y[:, -1] - _harmonic_exact(t_end))))
    assert 7.6 < _slope(h, np.array(err)) < 8.6


def test_dense_output_local_error_is_eighth_order():
    # one step of size h; the interpolant inside it errs by O(h^8) (a 7th-order method)
    h = np.array([0.8, 0.56, 0.4, 0.28])
    err = []
    for hk in h:
        sol = dop853.solve(_harmonic, (0.0, hk), [1.0, 0.0], [1.0], fixed_step=hk)
        tt = hk * np.linspace(0.05, 0.95, 19)
        err.append(np.max(np.abs(sol.dense(tt) - _harmonic_exact(tt))))
    assert 7.5 < _slope(h, np.array(err)) < 8.7


def test_error_follows_tolerance():
    # adaptive runs: the global error should scale roughly like the tolerance
    errs = []
    tols = np.array([1e-6, 1e-8, 1e-10])
    for tol in tols:
        sol = dop853.solve(_harmonic, (0.0, 10.0), [1.0, 0.0], [1.0], rtol=tol, atol=tol)
        errs.append(np.max(np.abs(sol.y[:, -1] - _harmonic_exact(10.0))))
    assert 0.6 < _slope(tols, np.array(errs)) < 1.4


# --- events --------------------------------------------------------------------------------------


def _harmonic_run(direction, terminal=None, t_end=20.0, **kw):
    return dop853.solve(
        _harmonic,
        (0.0, t_end),
        [1.0, 0.0],
        [1.0],
        rtol=1e-13,
        atol=1e-13,
        events=_harmonic_events,
        direction=direction,
        terminal=terminal,
        **kw,
    )


def test_event_times_match_exact_crossings():
    sol = _harmonic_run([0, 0])
    assert sol.status == dop853.COMPLETED
    exact = np.pi / 2 + np.pi * np.arange(6)  # zeros of cos t in [0, 20]
    assert sol.t_events[0].shape == exact.shape
    np.testing.assert_allclose(sol.t_events[0], exact, rtol=1e-12, atol=0)
    # the reported state is the state at the event
    np.testing.assert_allclose(sol.y_events[0][:, 0], 0.0, atol=1e-12)
    np.testing.assert_allclose(np.abs(sol.y_events[0][:, 1]), 1.0, atol=1e-12)


def test_event_direction_filters_crossings():
    down = _harmonic_run([-1, -1])
    up = _harmonic_run([1, 1])
    k = np.arange(3)
    np.testing.assert_allclose(down.t_events[0], np.pi / 2 + 2 * np.pi * k, rtol=1e-12)
    np.testing.assert_allclose(up.t_events[0], 3 * np.pi / 2 + 2 * np.pi * k, rtol=1e-12)
    np.testing.assert_allclose(down.t_events[1], 2 * np.pi / 3 + 2 * np.pi * k, rtol=1e-12)
    np.testing.assert_allclose(up.t_events[1], 4 * np.pi / 3 + 2 * np.pi * k, rtol=1e-12)


def test_terminal_event_stops_with_both_events_reported_in_order():
    tt = np.linspace(0.0, 5.0, 11)
    sol = _harmonic_run([0, -1], terminal=[False, True], t_eval=tt)
    assert sol.status == dop853.TERMINAL_EVENT and sol.success
    t_stop = 2 * np.pi / 3
    np.testing.assert_array_equal(sol.event_index, [0, 1])
    np.testing.assert_allclose(sol.event_t, [np.pi / 2, t_stop], rtol=1e-12)
    assert sol.t_steps[-1] == sol.event_t[-1]
    np.testing.assert_allclose(sol.dense(sol.t_steps[-1]), _harmonic_exact(t_stop), atol=1e-12)
    assert np.all(sol.t <= t_stop) and sol.t.size == np.sum(tt <= t_stop)


# --- failures are statuses, not exceptions ------------------------------------------------------


def test_blow_up_fails_with_message():
    sol = dop853.solve(_square, (0.0, 2.0), [1.0], [0.0], rtol=1e-8, atol=1e-8)
    assert not sol.success
    assert sol.status in (dop853.STEP_TOO_SMALL, dop853.NON_FINITE)
    assert "t = " in sol.message
    # like scipy, it creeps up to the pole (here to 1 + 2e-9) until the step underflows
    assert 0.999 < sol.t[-1] < 1.001
    # what was integrated before is still usable
    np.testing.assert_allclose(sol.dense(0.9), 10.0, rtol=1e-6)


def test_nan_right_hand_side_fails_with_message():
    sol = dop853.solve(_sqrt_rhs, (0.0, 2.0), [0.0], [1.0], rtol=1e-8, atol=1e-8)
    assert sol.status == dop853.NON_FINITE
    assert "non-finite" in sol.message
    assert sol.t[-1] <= 1.0
    assert np.all(np.isfinite(sol.y))


def test_nan_at_the_start_and_max_steps():
    sol = dop853.solve(_sqrt_rhs, (2.0, 3.0), [0.0], [1.0])
    assert sol.status == dop853.NON_FINITE and sol.t.size == 1
    sol = dop853.solve(_harmonic, (0.0, 10.0), [1.0, 0.0], [1.0], rtol=1e-10, max_steps=5)
    assert sol.status == dop853.MAX_STEPS and sol.n_accepted == 5
    assert "Maximum number of steps (5)" in sol.message


def test_bad_input_raises():
    with pytest.raises(TypeError, match=r"numba\.njit"):
        dop853.solve(lambda t, y, p, out: None, (0.0, 1.0), [1.0])
    with pytest.raises(ValueError, match="direction"):
        dop853.solve(_harmonic, (0.0, 1.0), [1.0, 0.0], [1.0], events=_harmonic_events)
    with pytest.raises(ValueError, match="atol"):
        dop853.solve(_harmonic, (0.0, 1.0), [1.0, 0.0], [1.0], atol=[1e-6, 1e-6, 1e-6])
