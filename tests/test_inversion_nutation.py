"""The lift-off criterion's compiled evaluation (mett.inversion._nutation.lift_off, numba) against
its numpy reference: the nutation followed node by node with one ``_fast_spectra`` call per split
(``_follow``) and the criterion's ratio written out here from its definition
(docs/theory/inversion.md#verification). Both take the same picks; their eigenvalues come from
two backward-stable algorithms (Hessenberg QR compiled, LAPACK's dgeev), so they agree to
rounding: |δλ| ≲ κ n ε |A| with n = 8, ε = 2.2e-16 and the condition κ of the fast pair (≲ 10
where a pick is clear), i.e. ≲ 2e-14 |λ|; RATE_RTOL leaves a factor 50. t_lift is interpolated
log-linearly between two nodes whose ratios each carry that error: divided by ln(r_j/r_{j-1})
(≥ 0.01 on these paths) it is ≲ 1e-10 relative."""

from __future__ import annotations

import math

import mpmath
import numpy as np
import pytest

import mett
from mett.friction import Coulomb, RegularisedCoulomb, Viscous
from mett.inversion import _nutation, predict_inversion
from mett.inversion._cases import cases
from mett.inversion._gyroscopic import balance_state
from mett.stability import escape_modes

RATE_RTOL = 1e-12
T_LIFT_RTOL = 1e-10


def _nodes(top, state, law):
    """The slow path's nodes the prediction evaluates: every third up to π/2, and the last."""
    p = predict_inversion(top, state, law)
    up = np.flatnonzero(p.theta <= 0.5 * math.pi)
    up = np.unique(np.r_[up[::3], up[-1:]])
    return float(p.lam[0]), p.t[up], p.theta[up]


def _direct(top, law, lam, t, theta, amp0, rate0):
    """t_lift and λ_n at every node, without batching or early stop (module docstring)."""
    phidot0 = float(np.real(balance_state(top, lam, theta[0])[0]))
    start = complex(rate0.real, phidot0 + abs(rate0.imag))
    lam_n = np.array(_nutation._follow(top, law, lam, theta, [(float(theta[0]), start)]))
    l = top.R * top.alpha
    M = top.I1 + top.m * l**2 * np.sin(theta) ** 2
    ratio, log_amp = [], math.log(amp0)
    for k in range(len(t)):
        if k:  # d ln Θ/dt = Re λ_n (trapezoid), times the adiabatic factor √(M0 ω0/(M ω))
            log_amp += 0.5 * (lam_n[k].real + lam_n[k - 1].real) * (t[k] - t[k - 1])
        amp = math.exp(log_amp + 0.5 * math.log(M[0] * lam_n[0].imag / (M[k] * lam_n[k].imag)))
        ratio.append(l * abs(lam_n[k]) ** 2 * amp * math.sin(theta[k]) / top.g)
    ratio = np.array(ratio)
    over = np.flatnonzero(ratio >= 1.0)
    if not len(over):
        return math.inf, lam_n
    j = over[0]
    if j == 0:
        return float(t[0]), lam_n
    a, b = math.log(ratio[j - 1]), math.log(ratio[j])
    return float(t[j - 1] - (t[j] - t[j - 1]) * a / (b - a)), lam_n


def _benchmark_case(mu, omega3=155.0):
    top = mett.presets.get("rutstam2013", mu=mu)
    return top, mett.State.with_cm_at_rest(top, theta=0.1, omega3=omega3), Viscous()


# the thesis top at small μ (splits nested two deep) and table cases with many splits, with a
# lift-off at the first node, in between, and none; at μ = 0.05 s/m and ω3 = 620 rad/s the pick
# after a split depends on extrapolating from the split's last node (not the node before it)
CASES = [("mu0.0125", None), ("mu0.2", None), ("case01", 1), ("case42", 42), ("case04", 4),
         ("case02", 2), ("mu0.05w310", None), ("mu0.05w620", None)]  # fmt: skip


@pytest.mark.parametrize(("name", "index"), CASES)
@pytest.mark.parametrize("scale", [1.0, 1e4])
def test_compiled_lift_off_equals_the_direct_evaluation(name, index, scale):
    if index is None:
        mu, _, omega3 = name[2:].partition("w")
        top, state, law = _benchmark_case(float(mu), float(omega3 or 155.0))
    else:
        case = cases()[index]
        top, state, law = case.top, case.state, case.friction
    lam, t, theta = _nodes(top, state, law)
    amp0, rate0 = _nutation.upright_nutation(escape_modes(top, state)[1])
    amp0 *= scale  # a larger start moves the lift-off earlier: the early stop engages
    got = _nutation.lift_off(top, law, lam, t, theta, amp0, rate0)
    t_lift, lam_n = _direct(top, law, lam, t, theta, amp0, rate0)
    # the prediction's form: inf from the bound over both fast eigenvalues where it is far below
    # 1, else lift_off's
    assert _nutation.lift_off_time(top, law, lam, t, theta, amp0, rate0) == got.t_lift
    n = len(got.t)
    # ratio within rounding of the direct one, so t_lift to rounding of the log-linear
    # interpolation; the nutation's picks the same eigenvalues, to rounding (module docstring)
    assert got.t_lift == pytest.approx(t_lift, rel=T_LIFT_RTOL) or got.t_lift == t_lift
    assert np.all(np.abs(got.rate - lam_n[:n]) <= RATE_RTOL * np.abs(lam_n[:n]))
    assert np.array_equal(got.t, t[:n])
    # the arrays stop at the first node past the criterion, or run to the last
    assert (
        n == len(t)
        if math.isinf(t_lift)
        else got.ratio[-1] >= 1.0 > np.max(got.ratio[:-1], initial=0.0)
    )


def test_regularised_coulomb_compiled_equals_direct():
    top = mett.presets.get("rutstam2013")
    state = mett.State.with_cm_at_rest(top, theta=0.1, omega3=155.0)
    law = RegularisedCoulomb(0.3, 0.05)
    lam, t, theta = _nodes(top, state, law)
    amp0, rate0 = _nutation.upright_nutation(escape_modes(top, state)[1])
    got = _nutation.lift_off(top, law, lam, t, theta, amp0, rate0)
    t_lift, lam_n = _direct(top, law, lam, t, theta, amp0, rate0)
    assert got.t_lift == pytest.approx(t_lift, rel=T_LIFT_RTOL) or got.t_lift == t_lift
    n = len(got.t)
    assert np.all(np.abs(got.rate - lam_n[:n]) <= RATE_RTOL * np.abs(lam_n[:n]))
    assert _nutation.lift_off_time(top, law, lam, t, theta, amp0, rate0) == got.t_lift


@pytest.mark.parametrize(("scale", "lifts"), [(1.0, False), (8.0, False), (12.0, False),
                                             (15.0, True), (30.0, True)])  # fmt: skip
def test_the_bound_decides_only_where_the_ratio_stays_below_one(scale, lifts):
    # The thesis top at mu = 0.2 s/m: the ratio peaks at ~0.07 from its own start (the bound
    # answers: no lift-off); starts 8 and 12 times larger bring it to 0.55 and 0.83, past the
    # bound's threshold 1/2 but not to 1 (the exact criterion answers: none), 15 and 30 times
    # past 1 (a finite t_lift).
    top, state, law = _benchmark_case(0.2)
    lam, t, theta = _nodes(top, state, law)
    amp0, rate0 = _nutation.upright_nutation(escape_modes(top, state)[1])
    exact = _direct(top, law, lam, t, theta, scale * amp0, rate0)[0]
    got = _nutation.lift_off_time(top, law, lam, t, theta, scale * amp0, rate0)
    assert math.isfinite(exact) == lifts
    assert got == pytest.approx(exact, rel=T_LIFT_RTOL)


# --- the compiled kernels against independent references -----------------------------------------


def _mp_eigvals(A):
    """Eigenvalues of the float matrix ``A`` at 40 digits (mpmath), as complex floats."""
    with mpmath.workdps(40):
        ev = mpmath.eig(mpmath.matrix(A.tolist()), left=False, right=False)
        return np.array([complex(z) for z in ev])


def _matrices():
    rng = np.random.default_rng(20261126)
    out = [rng.standard_normal((n, n)) for n in (2, 3, 6, 8)]
    # rows and columns scaled over ten decades (balancing), as the Jacobians' are
    D = np.diag(10.0 ** rng.uniform(-5, 5, 8))
    out.append(D @ rng.standard_normal((8, 8)) @ np.linalg.inv(D))
    # the fast Jacobian's structure: a rotation at 1e5 rad/s on three pairs, weakly damped
    R = np.zeros((8, 8))
    for i in (0, 2, 5):
        R[i, i + 1], R[i + 1, i] = 1e5, -1e5
    out.append(R + 1e2 * rng.standard_normal((8, 8)))
    out.append(np.triu(rng.standard_normal((8, 8))))  # already triangular: real eigenvalues
    return out


@pytest.mark.parametrize("k", range(7))
def test_hessenberg_qr_eigenvalues_against_mpmath(k):
    # Backward stable: the computed eigenvalues are exact for A + E, |E| ≲ n ε |A|, so each moves
    # by ≲ κ n ε |A| (κ its condition, ≲ 1e2 for these matrices): 1e-11 |A| is far above it and
    # far below any wrong eigenvalue (a transposed index, a wrong shift give O(|A|) errors).
    from mett.inversion import _compiled

    A = _matrices()[k]
    wr, wi, ok = _compiled.eigvals_hessenberg_qr(A.copy())
    assert ok
    got = wr + 1j * wi
    ref = _mp_eigvals(A)
    scale = np.linalg.norm(A)
    for z in ref:  # a one-to-one match: each reference eigenvalue has its own computed one
        j = int(np.argmin(np.abs(got - z)))
        assert abs(got[j] - z) <= 1e-11 * scale
        got = np.delete(got, j)
    assert not len(got)


@pytest.mark.parametrize("law", [Viscous(0.05), RegularisedCoulomb(0.3, 0.05)])
@pytest.mark.parametrize("theta", [0.02, 0.3, 1.0, 1.5])
def test_compiled_spectrum_equals_the_numpy_one(law, theta):
    # The same Jacobian (the same complex-step arithmetic of gliding_core), its eigenvalues by
    # two backward-stable algorithms: equal to RATE_RTOL of their size (module docstring).
    from mett.inversion import _compiled
    from mett.inversion._gyroscopic import law_code, top_array

    top = mett.presets.get("rutstam2013")
    lam = float(mett.jellett(top, mett.State.with_cm_at_rest(top, theta=0.1, omega3=155.0)))
    ref = _nutation._fast_spectra(top, law, lam, np.array([theta]))[0]
    code, mu, eps = law_code(top, law)
    got = np.array(_compiled.spectrum(theta, lam, top_array(top), code, mu, eps))
    assert np.all(np.abs(got - ref) <= RATE_RTOL * np.abs(ref))


@pytest.mark.parametrize("law", [Viscous(0.05), RegularisedCoulomb(0.3, 0.01), Coulomb(0.3)])
def test_compiled_slow_path_equals_the_numpy_quadrature(law):
    # The compiled path against numpy's evaluation of the same flow (flow_rate) and the same
    # cumulative Simpson rule on the same grid: every rate to a few ulps (libm's and numpy's
    # elementary functions), so t, a sum of ~100 positive terms, to ≲ 100 ε ≈ 2e-14 relative.
    from mett.inversion._gyroscopic import _cumulative_simpson, flow_rate, slow_path

    top = mett.presets.get("rutstam2013")
    lam = float(mett.jellett(top, mett.State.with_cm_at_rest(top, theta=0.1, omega3=155.0)))
    a, b = 1e-3, math.pi - 0.05
    t, theta, state, _ = slow_path(top, lam, law, a, b)
    s0, s1 = math.log(math.tan(0.5 * a)), math.log(math.tan(0.5 * b))
    s = np.linspace(s0, s1, len(t))
    th = 2.0 * np.arctan(np.exp(s))
    assert np.allclose(theta, th, rtol=1e-14, atol=0.0)
    g = np.sin(th) / flow_rate(top, lam, law, th)
    ref = _cumulative_simpson(g, (s1 - s0) / (len(t) - 1))
    assert np.allclose(t, ref, rtol=1e-12, atol=0.0)
    phidot = np.real(balance_state(top, lam, th)[0])
    assert np.allclose(state[0], phidot, rtol=1e-14, atol=0.0)


@pytest.mark.parametrize(("theta0", "omega3"), [(0.1, 155.0), (0.01, 300.0), (0.3, 100.0)])
def test_upright_modes_against_mpmath(theta0, omega3):
    # escape_modes' compiled eigen-decomposition (balanced Hessenberg QR + inverse iteration)
    # against mpmath's at 50 digits of the same Jacobian: the growth rate σ and the start's
    # amplitude in the unstable pair (a product of eigenvector and coefficient, independent of
    # the eigenvectors' scaling). Backward stable on the balanced matrix: ≲ κ n ε, κ ≲ 1e2.
    from mett.inversion import _compiled
    from mett.stability import _HORIZONTAL, _spin_steps

    top = mett.presets.get("rutstam2013", mu=0.2)
    state = mett.State.with_cm_at_rest(top, theta=theta0, omega3=omega3)
    est, modes = escape_modes(top, state)
    lam = float(mett.jellett(top, state))
    y0, h, p = _spin_steps(top, lam, "upright")
    A = _compiled.spin_jacobian_kernel(y0, h, p)[np.ix_(_HORIZONTAL, _HORIZONTAL)]
    model = mett.dynamics.registry.MODELS["gliding"]
    dy = (model.initial(state, model.params(top, {})) - y0)[_HORIZONTAL]
    with mpmath.workdps(50):
        E, ER = mpmath.eig(mpmath.matrix(A.tolist()))
        c = mpmath.lu_solve(ER, mpmath.matrix(dy.tolist()))
        sigma = max(mpmath.re(z) for z in E)
        amp = mpmath.sqrt(
            sum(abs(ER[r, k] * c[k]) ** 2 for k in range(6) if mpmath.re(E[k]) > sigma / 2
                for r in (4, 5))
        )  # fmt: skip
    assert est.growth_rate == pytest.approx(float(sigma), rel=1e-12)
    assert est.amplitude == pytest.approx(float(amp), rel=1e-12)
    assert np.allclose(np.linalg.norm(modes.vectors, axis=0), 1.0, rtol=1e-14)


def test_the_compiled_walk_uses_the_reference_s_constants():
    from mett.inversion import _compiled

    assert (_compiled._CLEAR, _compiled._SPLIT, _compiled._DEPTH) == (
        _nutation.CLEAR,
        _nutation.SPLIT,
        _nutation.DEPTH,
    )
