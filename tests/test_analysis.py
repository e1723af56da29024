"""The deforming potential along the thesis run (docs/theory/estimates.md#estimates) and the METT residual."""

from __future__ import annotations

import numpy as np
import pytest

import mett
from mett import analysis


def test_mett_residual_is_tiny_with_modified_energy(thesis_trajectory):
    res = analysis.mett_residual(thesis_trajectory)
    assert np.abs(res).max() < 1e-10
    # the same identity with E instead of Ẽ fails by percents (docs/theory/notes.md#energy-vs-modified-energy)
    traj = thesis_trajectory
    z = np.cos(traj.theta)
    with_E = traj.E - (
        mett.g(traj.top, z) * traj.thetadot**2 + mett.V(traj.top, z, traj.D, traj.lam)
    )
    assert np.abs(with_E / traj.E).max() > 0.05


def test_minimum_of_V_travels_from_top_to_bottom(thesis_trajectory):
    times = np.linspace(0, 8, 33)
    zmin = analysis.minimum_track(thesis_trajectory, times)
    assert zmin[0] > 0.99 and zmin[-1] < -0.99
    # monotone up to the wobble of D(t) while the top still spins upright (< 1e-2 there)
    assert np.all(np.diff(zmin) < 1e-2)
    assert np.all(np.diff(zmin[times > 4.5]) < 0)


def test_theta_rides_in_the_deforming_potential(thesis_trajectory):
    times = np.array([1.0, 4.5, 5.5, 6.0, 7.5])
    z, V, theta = analysis.deforming_potential(thesis_trajectory, times)
    s = thesis_trajectory.at(times)
    E_mod = mett.modified_energy(thesis_trajectory.top, s)
    # θ sits inside the well: V(cos θ(t)) ≤ Ẽ(t), and the well's floor lies below Ẽ(t)
    D, lam = mett.routh(thesis_trajectory.top, s), mett.jellett(thesis_trajectory.top, s)
    top = thesis_trajectory.top
    assert np.all(mett.V(top, np.cos(theta), D, lam) <= E_mod * (1 + 1e-12))
    zmin = analysis.minimum_track(thesis_trajectory, times)
    assert np.all(mett.V(top, zmin, D, lam) <= E_mod)
    assert V.shape == (5, z.size)
    np.testing.assert_allclose(V[2], mett.V(top, z, D[2], lam[2]), rtol=1e-14)


def test_turning_points_are_zeros_of_thetadot(thesis_trajectory):
    tp = analysis.theta_extrema(thesis_trajectory)
    assert tp.t.size > 200
    thd = thesis_trajectory.at(tp.t[::25]).thetadot
    scale = np.abs(thesis_trajectory.thetadot).max()
    assert np.abs(thd).max() < 1e-9 * scale
    assert set(np.unique(tp.kind)) == {-1, 1}
    assert np.all(np.diff(tp.kind) != 0)  # maxima and minima alternate


def test_old_turning_points_name_warns_and_kind_constants_name_the_extrema(thesis_trajectory):
    with pytest.warns(mett.MettDeprecationWarning, match="theta_extrema"):
        old = analysis.turning_points(thesis_trajectory)
    new = analysis.theta_extrema(thesis_trajectory)
    np.testing.assert_array_equal(old.t, new.t)
    tmax = new.t[new.kind == analysis.TurningPoints.MAX]
    tmin = new.t[new.kind == analysis.TurningPoints.MIN]
    assert tmax.size + tmin.size == new.t.size
    # a maximum of θ is where θ̇ goes from + to −
    eps = 1e-6
    assert np.all(thesis_trajectory.at(tmax[:20] - eps).thetadot > 0)
    assert np.all(thesis_trajectory.at(tmax[:20] + eps).thetadot < 0)


def test_observed_periods_against_the_rolling_estimates(thesis_trajectory):
    # What the numbers say (thesis run; docs/theory/estimates.md#estimates measured 0.0372 s and ≈ 0.077 s):
    # * start: observed 0.0372 s > T(D0) = 0.0321 s and > the frozen rolling period 0.0316 s
    #   (the gliding top is *slower* than the rolling estimate here), close to the gliding
    #   fast-top value 2π I1/(I3 ω3) = 0.0379 s;
    # * end: observed ≈ 0.076 s < T(D1) = 0.0921 s and < the frozen rolling period 0.095 s
    #   (faster than rolling), close to the fast-top value 0.0710 s.
    pc = analysis.period_comparison(thesis_trajectory)
    T0, T1 = pc.estimates
    start, end = pc.t < 2.0, pc.t > 7.0
    assert np.all(pc.observed[start] > T0)
    assert np.all(pc.observed[end] < T1)
    # T_max bounds every observed period but one: near t = 6.5 s one nutation of θ̇ does not
    # reach zero (θ̇ dips to ≈ +0.09 rad/s: a shoulder in θ, not a maximum), so the time between
    # "successive maxima" spans two oscillations there.
    long = np.flatnonzero(pc.observed >= T1)
    assert long.size == 1 and 6.3 < pc.t[long[0]] < 6.7
    t_a, t_b = pc.t[long[0]] - pc.observed[long[0]] / 2, pc.t[long[0]] + pc.observed[long[0]] / 2
    t_min = analysis.theta_extrema(thesis_trajectory).t
    t_min = t_min[(t_min > t_a + 1e-9) & (t_min < t_b - 1e-9)]
    assert t_min.size == 1  # one minimum of θ in between, then the shoulder
    after = np.linspace(t_min[0], t_b, 400)[5:-5]
    thd = thesis_trajectory.at(after).thetadot
    k = np.argmin(thd[50:]) + 50
    assert 0 < thd[k] < 0.2 and 50 < k < after.size - 5  # an interior positive dip
    assert np.median(pc.observed[start]) == pytest.approx(0.0372, abs=3e-4)
    assert np.median(pc.observed[end]) == pytest.approx(0.076, abs=2e-3)
    ratio_start = np.median(pc.observed[start] / pc.rolling[start])
    ratio_end = np.median(pc.observed[end] / pc.rolling[end])
    assert 1.1 < ratio_start < 1.25 and 0.75 < ratio_end < 0.85
    np.testing.assert_allclose(pc.observed[start], pc.fast_top[start], rtol=0.03)
    np.testing.assert_allclose(pc.observed[end], pc.fast_top[end], rtol=0.10)
