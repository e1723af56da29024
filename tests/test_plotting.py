"""Plotting functions on the Agg backend: they run, return a Figure, and their artists hold the data."""

from __future__ import annotations

import warnings

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
    np.testing.assert_allclose(v, mett.V(top, z, D, lam) * 1e3, rtol=1e-14)  # mJ
    marks = next(ln for ln in ax.lines if ln.get_label() == "turning points")
    np.testing.assert_allclose(marks.get_xdata(), mett.turning_points(top, E, D, lam), rtol=1e-14)
    assert ax.get_xlabel() == "z = cos θ" and "[mJ]" in ax.get_ylabel()


def test_f_plot_holds_f_and_its_roots(rolling_case):
    top, E, D, lam = rolling_case
    fig = plotting.plot_f(top, E, D, lam)
    ax = fig.axes[0]
    z, fz = ax.lines[0].get_data()
    np.testing.assert_allclose(fz, mett.f(top, z, E, D, lam), rtol=1e-12)
    roots = next(ln for ln in ax.lines if "roots" in ln.get_label())
    np.testing.assert_allclose(mett.f(top, roots.get_xdata(), E, D, lam), 0, atol=1e-9 * np.max(fz))


THESIS_LAMBDA = 6.8944e-6


def _surface(fig):
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    ax = next(a for a in fig.axes if a.name == "3d")
    return ax, next(c for c in ax.collections if isinstance(c, Poly3DCollection))


def test_surface_spans_D1_to_D0(thesis_top):
    fig = plotting.plot_potential_surface(thesis_top, THESIS_LAMBDA, n=21, n_D=11)
    ax, _ = _surface(fig)
    bv = mett.boundary_values(thesis_top, THESIS_LAMBDA)
    lo, hi = ax.get_ylim()
    assert lo <= bv.D1 * 1e3 and hi >= bv.D0 * 1e3
    assert "V [mJ]" in ax.get_zlabel()


@pytest.mark.parametrize("coordinate", ["z", "theta"])
def test_surface_masks_values_above_the_level_instead_of_clipping(thesis_top, coordinate):
    level = 0.035  # J: below E0 = 40.6 mJ, so the wall at θ = 0 must be cut away
    fig = plotting.plot_potential_surface(
        thesis_top, THESIS_LAMBDA, coordinate=coordinate, level=level, n=31, n_D=15
    )
    _, surf = _surface(fig)
    # every drawn vertex is the true V at its (u, D): nothing was moved down to the level
    # mplot3d keeps the polygons padded to one length; _invalid_vertices flags the padding
    faces = np.asarray(surf._faces)[~np.asarray(surf._invalid_vertices, dtype=bool)]
    u, D, v = faces[:, 0], faces[:, 1] / 1e3, faces[:, 2] / 1e3
    z = u if coordinate == "z" else np.cos(u)
    np.testing.assert_allclose(v, mett.V(thesis_top, z, D, THESIS_LAMBDA), rtol=1e-12)
    assert v.max() <= level * (1 + 1e-12)
    # no plateau: only the trimmed rims reach the level, the rest lies below it
    assert np.mean(v > 0.999 * level) < 0.15
    # the well's floor at D1 (E1 at θ = π) is there, the masked wall at D0 is not
    assert v.min() == pytest.approx(mett.boundary_values(thesis_top, THESIS_LAMBDA).E1, rel=1e-3)
    assert not np.any((D > 0.99 * mett.boundary_values(thesis_top, THESIS_LAMBDA).D0) & (z > 0.99))


def test_surface_clipping_would_be_caught(thesis_top):
    """The masking test's plateau criterion fails for the old clipped surface."""
    u = np.linspace(-1, 1, 31)
    D = np.linspace(-6e-4, 7.2e-4, 15)
    V = mett.V(thesis_top, u[None, :], D[:, None], THESIS_LAMBDA)
    clipped = np.minimum(V, 0.035)
    assert np.mean(clipped > 0.999 * 0.035) > 0.15


@pytest.mark.parametrize(
    ("coordinate", "xlabel", "title_has_cos"),
    [("z", "z = cos θ", True), ("theta", "θ [rad]", False)],
)
def test_surface_labels_title_and_colour_bar_follow_the_coordinate(
    thesis_top, coordinate, xlabel, title_has_cos
):
    fig = plotting.plot_potential_surface(
        thesis_top, THESIS_LAMBDA, coordinate=coordinate, n=21, n_D=11, elev=20, azim=30,
        cmap="plasma",
    )  # fmt: skip
    ax, surf = _surface(fig)
    assert ax.get_xlabel() == xlabel
    assert (r"\cos\theta" in ax.get_title()) is title_has_cos
    assert surf.get_cmap().name == "plasma"
    assert (ax.elev, ax.azim) == (20, 30)
    cbar_axes = [a for a in fig.axes if a is not ax]
    assert len(cbar_axes) == 1 and cbar_axes[0].get_ylabel() == "V [mJ]"


def test_surface_refuses_a_bad_coordinate(thesis_top):
    with pytest.raises(ValueError, match="coordinate"):
        plotting.plot_potential_surface(thesis_top, THESIS_LAMBDA, coordinate="phi")


def test_potential_without_E_takes_its_y_range_from_the_curve(rolling_case):
    top, _, D, lam = rolling_case
    ax = plotting.plot_potential(top, D, lam).axes[0]
    z, v = ax.lines[0].get_data()
    lo, hi = ax.get_ylim()
    assert hi - lo > 1.0  # mJ; the old plot collapsed to ~1e-6 mJ
    vmin = v.min()
    assert lo < vmin < hi
    visible = (v >= lo) & (v <= hi) & (z >= ax.get_xlim()[0]) & (z <= ax.get_xlim()[1])
    assert visible.sum() > 100  # the curve fills the axes


def test_repeated_slices_keep_colours_legend_title_and_limits(thesis_top):
    bv = mett.boundary_values(thesis_top, THESIS_LAMBDA)
    Ds = [0.5 * bv.D0, 0.0, 0.5 * bv.D1]
    fig, ax = plt.subplots()
    plotting.plot_potential(thesis_top, Ds[0], THESIS_LAMBDA, ax=ax)
    title, (x0, x1), (y0, y1) = ax.get_title(), ax.get_xlim(), ax.get_ylim()
    for D in Ds[1:]:
        plotting.plot_potential(thesis_top, D, THESIS_LAMBDA, ax=ax)
    assert ax.get_title() == title
    colours = [ln.get_color() for ln in ax.lines]
    assert len(set(colours)) == 3
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert len(labels) == 3 and len(set(labels)) == 3
    X0, X1 = ax.get_xlim()
    Y0, Y1 = ax.get_ylim()
    assert X0 <= x0 and X1 >= x1 and Y0 <= y0 and Y1 >= y1
    for line, D in zip(ax.lines, Ds, strict=True):  # every well's floor is in view
        z, v = line.get_data()
        assert X0 <= z[np.argmin(v)] <= X1 and Y0 <= v.min() <= Y1
        np.testing.assert_allclose(v, mett.V(thesis_top, z, D, THESIS_LAMBDA) * 1e3, rtol=1e-14)


def test_slices_helper_gives_distinct_colours_and_D_in_the_legend(thesis_top):
    bv = mett.boundary_values(thesis_top, THESIS_LAMBDA)
    Ds = np.linspace(bv.D1, bv.D0, 6)[1:-1]
    ax = plotting.plot_potential_slices(thesis_top, Ds, THESIS_LAMBDA).axes[0]
    assert len(ax.lines) == 4
    assert (
        len({tuple(np.round(matplotlib.colors.to_rgba(ln.get_color()), 6)) for ln in ax.lines}) == 4
    )
    texts = [t.get_text() for t in ax.get_legend().get_texts()]
    assert all("D =" in t for t in texts) and len(set(texts)) == 4
    # no colour is near white (legible on a white background)
    assert all(sum(matplotlib.colors.to_rgb(ln.get_color())) < 2.6 for ln in ax.lines)


def test_potential_map_holds_the_track_the_path_and_the_level(short_run):
    top, lam = short_run.top, float(short_run.lam[0])
    level = 0.05
    fig = plotting.plot_potential_map(top, lam, trajectory=short_run, level=level, n=81)
    ax = fig.axes[0]
    path = next(ln for ln in ax.lines if ln.get_label() == "trajectory")
    D, z = path.get_data()
    np.testing.assert_array_equal(D, short_run.D * 1e3)
    np.testing.assert_array_equal(z, np.cos(short_run.theta))
    track = next(ln for ln in ax.lines if ln.get_label() == "well minimum")
    Dt, zt = track.get_data()
    for i in (0, len(Dt) // 3, len(Dt) // 2, -1):
        assert zt[i] == mett.potential_minimum(top, Dt[i] / 1e3, lam)
    bv = mett.boundary_values(top, lam)  # the D range covers [D1, D0] and the run's D(t)
    assert Dt[0] <= min(bv.D1, short_run.D.min()) * 1e3
    assert Dt[-1] >= max(bv.D0, short_run.D.max()) * 1e3
    cs = next(c for c in ax.collections if hasattr(c, "levels") and c.filled)
    assert cs.levels[-1] == pytest.approx(level * 1e3) and cs.extend == "neither"
    assert len(fig.axes) == 2 and fig.axes[1].get_ylabel() == "V [mJ]"  # the colour bar


def test_potential_map_default_range_runs_from_pole_to_pole(thesis_top):
    ax = plotting.plot_potential_map(thesis_top, THESIS_LAMBDA, n=41).axes[0]
    Dt, zt = next(ln for ln in ax.lines if ln.get_label() == "well minimum").get_data()
    bv = mett.boundary_values(thesis_top, THESIS_LAMBDA)
    assert Dt[0] == pytest.approx(bv.D1 * 1e3) and Dt[-1] == pytest.approx(bv.D0 * 1e3)
    # the well sits at the inverted pole at D1 and at the upright one at D0
    assert zt[0] == pytest.approx(-1, abs=1e-6) and zt[-1] == pytest.approx(1, abs=1e-6)
    assert not any(ln.get_label() == "trajectory" for ln in ax.lines)


def test_potential_map_in_theta(short_run):
    top, lam = short_run.top, float(short_run.lam[0])
    ax = plotting.plot_potential_map(top, lam, trajectory=short_run, coordinate="theta", n=41).axes[
        0
    ]
    _, th = next(ln for ln in ax.lines if ln.get_label() == "trajectory").get_data()
    np.testing.assert_array_equal(th, short_run.theta)
    assert ax.get_ylabel() == "θ [rad]" and r"\cos\theta" not in ax.get_title()


def test_potential_map_refuses_a_bad_D_grid(thesis_top):
    with pytest.raises(ValueError, match="increasing"):
        plotting.plot_potential_map(thesis_top, THESIS_LAMBDA, D=[1e-4, 0.0])


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
        assert dot.get_clip_on() is False  # a dot at θ = π is not cut in half
    # a sequential map without its pale end: every curve is legible on white
    assert all(sum(matplotlib.colors.to_rgb(c.get_color())) < 2.6 for c in curves)
    assert "[mJ]" in ax.get_ylabel()


def test_axis_trace_lies_on_the_unit_sphere(short_run):
    ax = plotting.plot_axis_trace(short_run).axes[0]
    x, y, z = ax.lines[0].get_data_3d()
    np.testing.assert_allclose(x**2 + y**2 + z**2, 1.0, rtol=1e-12)
    np.testing.assert_allclose(z, np.cos(short_run.theta), rtol=1e-12, atol=1e-15)
    for axis in (ax.xaxis, ax.yaxis, ax.zaxis):  # few ticks: the default ones overlapped
        assert len(axis.get_ticklocs()) == 3


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


def test_gallery_generate_draws_another_preset(tmp_path):
    from mett import gallery

    top = mett.presets.get("cohen1977")
    names = ["potential_map", "potential_slice"]
    with warnings.catch_warnings():
        warnings.simplefilter("error", mett.MettWarning)  # nothing is skipped for a group-II top
        paths = gallery.generate(tmp_path, top=top, names=names, animation=False, dpi=40)
    assert [p.name for p in paths] == [f"{n}.png" for n in names]
    assert all(p.stat().st_size > 1000 for p in paths)
    # the run behind the map is this top's: λ = 2 λ_thres and it inverts
    ctx = gallery._Context(top)
    assert ctx.lam == pytest.approx(2 * top.lambda_thres, rel=1e-12)
    assert float(mett.jellett(top, ctx.start)) == pytest.approx(ctx.lam, rel=1e-12)
    assert ctx.thesis.theta[-1] > 2.8


def test_gallery_skips_the_run_for_a_top_that_cannot_invert(tmp_path):
    from mett import gallery

    top = mett.TippeTop(m=0.02, R=0.02, alpha=0.3, I1=0.6 * 3.2e-6, I3=3.2e-6)  # γ = 0.6: group I
    assert top.group == "I"
    with pytest.warns(gallery.FigureSkippedWarning, match="group I"):
        paths = gallery.generate(
            tmp_path, top=top, names=["axis_trace", "potential_slice"], animation=True, dpi=40
        )
    assert [p.name for p in paths] == ["potential_slice.png"]
    assert "axis_trace" in gallery.skipped(top) and gallery.skipped(None) == {}


def test_gallery_refuses_a_top_that_is_not_a_top(tmp_path):
    from mett import gallery

    with pytest.raises(TypeError, match="top"):
        gallery.generate(tmp_path, top="rutstam2013", names=["potential_slice"])
