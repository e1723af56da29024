"""Plotting functions on the Agg backend: they run, return a Figure, and their artists hold the data."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt
import numpy as np
import pytest

import mett
from mett import plotting


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    plt.close("all")


@pytest.fixture
def rolling_case(thesis_top):
    s = mett.State(theta=1.0, omega3=100.0, phidot=5.0)
    return (
        thesis_top,
        mett.energy(thesis_top, s),
        mett.routh(thesis_top, s),
        mett.jellett(thesis_top, s),
    )


def test_potential_slice_holds_V_and_turning_points(rolling_case):
    top, E, D, lam = rolling_case
    fig = plotting.plot_potential(top, D, lam, E=E)
    ax = fig.axes[0]
    line = ax.lines[0]
    z, v = line.get_data()
    np.testing.assert_allclose(v, mett.V(top, z, D, lam), rtol=1e-14)
    marks = next(ln for ln in ax.lines if ln.get_label() == "turning points")
    np.testing.assert_allclose(marks.get_xdata(), mett.turning_points(top, E, D, lam), rtol=1e-14)
    assert ax.get_xlabel() == "z = cos θ" and "[J]" in ax.get_ylabel()


def test_f_plot_holds_f_and_its_roots(rolling_case):
    top, E, D, lam = rolling_case
    fig = plotting.plot_f(top, E, D, lam)
    ax = fig.axes[0]
    z, fz = ax.lines[0].get_data()
    np.testing.assert_allclose(fz, mett.f(top, z, E, D, lam), rtol=1e-12)
    roots = next(ln for ln in ax.lines if "roots" in ln.get_label())
    np.testing.assert_allclose(mett.f(top, roots.get_xdata(), E, D, lam), 0, atol=1e-9 * np.max(fz))


def test_surface_spans_D1_to_D0(thesis_top):
    lam = 6.8944e-6
    fig = plotting.plot_potential_surface(thesis_top, lam, n_theta=21, n_D=11)
    ax = fig.axes[0]
    bv = mett.boundary_values(thesis_top, lam)
    lo, hi = ax.get_ylim()
    assert lo <= bv.D1 * 1e3 and hi >= bv.D0 * 1e3
    assert "V [mJ]" in ax.get_zlabel()


def test_plots_draw_into_given_axes(rolling_case):
    top, E, D, lam = rolling_case
    fig, (a1, a2) = plt.subplots(1, 2)
    assert plotting.plot_potential(top, D, lam, E=E, ax=a1) is fig
    assert plotting.plot_f(top, E, D, lam, ax=a2) is fig
    assert len(a1.lines) >= 2 and len(a2.lines) >= 2


def test_plotting_leaves_global_style_alone(rolling_case):
    top, E, D, lam = rolling_case
    before = dict(matplotlib.rcParams)
    plotting.plot_f(top, E, D, lam)
    assert dict(matplotlib.rcParams) == before


def test_import_mett_does_not_import_matplotlib():
    import subprocess
    import sys

    code = "import mett, sys; assert 'matplotlib' not in sys.modules, 'matplotlib imported'"
    subprocess.run([sys.executable, "-c", code], check=True)


@pytest.fixture(scope="module")
def short_run():
    top = mett.presets.get("rutstam2013")
    return mett.simulate(top, mett.State(theta=0.1, omega3=155.0), t_end=7.0)


@pytest.mark.parametrize(
    ("fn", "names"),
    [
        (plotting.plot_theta, ["theta"]),
        (plotting.plot_thetadot, ["thetadot"]),
        (plotting.plot_angular_velocities, ["psidot", "phidot"]),
        (plotting.plot_omega3, ["omega3"]),
        (plotting.plot_gliding_velocities, ["nu_x", "nu_y"]),
        (plotting.plot_energies, ["E", "E_mod"]),
    ],
)
def test_timeseries_lines_hold_the_trajectory(short_run, fn, names):
    fig = fn(short_run)
    ax = fig.axes[0]
    for line, name in zip(ax.lines, names, strict=False):
        t, y = line.get_data()
        np.testing.assert_array_equal(t, short_run.t)
        np.testing.assert_allclose(y, getattr(short_run, name) * plotting.SERIES[name][2])
    assert ax.get_xlabel() == "t [s]" and "[" in ax.get_ylabel()


def test_omega3_plot_marks_the_jellett_limit(short_run):
    ax = plotting.plot_omega3(short_run).axes[0]
    limit = ax.lines[1].get_ydata()[0]
    assert limit == pytest.approx(-82.866, abs=1e-3)


def test_D_E_curve_holds_the_integrals_and_the_spins(short_run):
    ax = plotting.plot_D_E_curve(short_run).axes[0]
    D, E = ax.lines[0].get_data()
    np.testing.assert_allclose(D, short_run.D * 1e3)
    np.testing.assert_allclose(E, short_run.E_mod * 1e3)
    bv = mett.boundary_values(short_run.top, float(np.median(short_run.lam)))
    assert ax.lines[1].get_xdata()[0] == pytest.approx(bv.D0 * 1e3)
    assert ax.lines[2].get_ydata()[0] == pytest.approx(bv.E1 * 1e3)


def test_deforming_potential_dots_sit_on_their_curves(short_run):
    times = np.array([0.5, 5.0, 6.0])
    ax = plotting.plot_deforming_potential(short_run, times).axes[0]
    curves, dots = ax.lines[0::2], ax.lines[1::2]
    assert len(curves) == 3
    for t, dot in zip(times, dots, strict=True):
        assert dot.get_xdata()[0] == pytest.approx(float(short_run.at(t).theta))


def test_axis_trace_lies_on_the_unit_sphere(short_run):
    ax = plotting.plot_axis_trace(short_run).axes[0]
    x, y, z = ax.lines[0].get_data_3d()
    np.testing.assert_allclose(x**2 + y**2 + z**2, 1.0, rtol=1e-12)
    np.testing.assert_allclose(z, np.cos(short_run.theta), rtol=1e-12, atol=1e-15)


def test_animation_writes_a_gif(short_run, tmp_path):
    path = plotting.animate_deforming_potential(short_run, str(tmp_path / "a.gif"), frames=4, fps=4)
    from PIL import Image

    with Image.open(path) as im:
        assert im.format == "GIF" and im.n_frames == 4


def test_unknown_series_is_refused(short_run):
    with pytest.raises(ValueError, match="unknown series"):
        plotting.plot_timeseries(short_run, "spin")
    with pytest.raises(ValueError, match="different units"):
        plotting.plot_timeseries(short_run, "theta", "E")


def test_phase_diagram_draws_points_by_end_state_and_the_thresholds():
    import pandas as pd

    table = pd.DataFrame(
        {
            "lam_ratio": [0.2, 0.7, 2.0, 2.5],
            "gamma": [0.9, 0.9, 0.9, 1.1],
            "alpha": [0.3] * 4,
            "simulated": ["upright", "tumbling", "inverted", "contact_lost"],
        }
    )
    ax = plotting.plot_phase_diagram(table).axes[0]
    offsets = {c.get_label(): c.get_offsets() for c in ax.collections}
    np.testing.assert_allclose(offsets["tumbling"], [[0.7, 0.9]])
    np.testing.assert_allclose(offsets["inverted"], [[2.0, 0.9]])
    assert "contact_lost" in offsets
    lam0 = next(ln for ln in ax.lines if ln.get_label() == "λ = λ₀")
    x, g = lam0.get_data()
    top = mett.TippeTop(m=0.02, R=0.02, alpha=0.3, I1=g[200] * 3.2e-6, I3=3.2e-6)
    assert x[200] == pytest.approx(top.lambda_0 / top.lambda_thres, rel=1e-12)
    assert any(ln.get_label() == "λ = λ_thres" for ln in ax.lines)


def test_docs_example_reaches_plotting_through_the_package():
    import subprocess
    import sys

    code = "import mett, sys; mett.plotting.plot_phase_diagram; assert 'matplotlib' in sys.modules"
    subprocess.run([sys.executable, "-c", code], check=True)
