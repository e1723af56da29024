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
