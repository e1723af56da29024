"""Figures at print quality: the user's style is respected, ``ax=`` works everywhere, and the
defects of the first gallery (one clipped ψ̇/φ̇ panel, V-surface ticks unlike its colour bar, no
legend for the class boundaries, clipped start/end marks, missing phase-diagram thresholds) stay
fixed. Each test is written so the old behaviour fails it."""

from __future__ import annotations

import inspect
import math

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt
import numpy as np
import pytest
from matplotlib.text import Text

import mett
from mett import plotting

THESIS_LAMBDA = 6.8944e-6


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    plt.close("all")


@pytest.fixture(scope="module")
def run():
    # the thesis start, long enough for the pole pass (t ≈ 3.2 s) and the inversion
    top = mett.presets.get("rutstam2013")
    return mett.simulate(top, mett.State(theta=0.1, omega3=155.0), t_end=7.0)


def _rolling():
    top = mett.presets.get("rutstam2013")
    s = mett.State(theta=1.0, omega3=100.0, phidot=5.0)
    return top, mett.energy(top, s), mett.routh(top, s), mett.jellett(top, s)


def _table():
    import pandas as pd

    return pd.DataFrame(
        {
            "lam_ratio": [0.2, 0.7, 2.0],
            "gamma": [0.9, 0.9, 0.95],
            "alpha": [0.3] * 3,
            "simulated": ["upright", "tumbling", "inverted"],
        }
    )


# name -> (call(fn, run, **kw), kind of axes it draws into: "2d", "3d", "pair" or "six")
def _calls():
    top = mett.presets.get("rutstam2013")
    top12 = mett.presets.get("rutstam2012")
    rt, E, D, lam = _rolling()
    small = {"n": 21, "n_D": 11}
    return {
        "plot_D_E_curve": (lambda f, r, **k: f(r, **k), "2d"),
        "plot_angular_velocities": (lambda f, r, **k: f(r, **k), "2d"),
        "plot_axis_trace": (lambda f, r, **k: f(r, **k), "3d"),
        "plot_deforming_potential": (lambda f, r, **k: f(r, **k), "2d"),
        "plot_energies": (lambda f, r, **k: f(r, **k), "2d"),
        "plot_f": (lambda f, r, **k: f(rt, E, D, lam, **k), "2d"),
        "plot_gliding_velocities": (lambda f, r, **k: f(r, **k), "2d"),
        "plot_omega3": (lambda f, r, **k: f(r, **k), "2d"),
        "plot_phase_diagram": (lambda f, r, **k: f(_table(), **k), "2d"),
        "plot_potential": (lambda f, r, **k: f(rt, D, lam, E=E, **k), "2d"),
        "plot_potential_map": (
            lambda f, r, **k: f(top, float(r.lam[0]), trajectory=r, n=41, **k),
            "2d",
        ),
        "plot_potential_slices": (
            lambda f, r, **k: f(top, np.linspace(D, 0.5 * D, 3), lam, **k),
            "2d",
        ),
        "plot_potential_surface": (lambda f, r, **k: f(top12, THESIS_LAMBDA, **small, **k), "3d"),
        "plot_subgroups": (lambda f, r, **k: f(points={"p": (0.3, 0.93)}, n=20, **k), "2d"),
        "plot_theta": (lambda f, r, **k: f(r, **k), "2d"),
        "plot_thetadot": (lambda f, r, **k: f(r, **k), "2d"),
        "plot_timeseries": (lambda f, r, **k: f(r, "nu_x", "nu_y", **k), "2d"),
        "plot_tumbling_families": (lambda f, r, **k: f(**k), "six"),
    }


CALLS = _calls()
PLOTS = sorted(n for n in plotting.__all__ if n.startswith("plot_"))


def test_every_public_plot_function_is_covered_here():
    # a new plot_* function must be added to CALLS, i.e. accept ax= and honour rcParams
    assert sorted(CALLS) == PLOTS


@pytest.mark.parametrize("name", PLOTS)
def test_every_plot_function_accepts_ax_and_draws_into_it(name, run):
    fn = getattr(plotting, name)
    assert "ax" in inspect.signature(fn).parameters
    call, kind = CALLS[name]
    fig = plt.figure()
    if kind == "six":
        ax = np.array([[fig.add_subplot(2, 3, i + 3 * j + 1) for i in range(3)] for j in range(2)])
        given = list(ax.flat)
    else:
        ax = fig.add_subplot(projection="3d" if kind == "3d" else None)
        given = [ax]
    figures_before = plt.get_fignums()
    assert call(fn, run, ax=ax) is fig
    assert plt.get_fignums() == figures_before  # no figure of its own
    for a in given:
        assert a.lines or a.collections, f"{name} drew nothing into {a}"


def _texts_and_lines(fig):
    sizes = {round(t.get_fontsize(), 6) for t in fig.findobj(Text) if t.get_text().strip()}
    widths, marks = set(), set()
    for a in fig.axes:
        for ln in a.lines:
            widths.add(round(ln.get_linewidth(), 6))
            if ln.get_marker() not in ("None", None, "", " "):
                marks.add(round(ln.get_markersize(), 6))
    return sizes, widths, marks


@pytest.mark.parametrize("name", PLOTS)
def test_every_size_follows_the_user_s_rcparams(name, run):
    # drawn under a style and under the same style with every size doubled: every text size, line
    # width and marker size of the figure doubles. A hard-coded fontsize=7, lw=0.8 or ms=4 would
    # stay put and fail; so would a function that sets rcParams itself (checked too).
    call, _ = CALLS[name]
    fn = getattr(plotting, name)
    found = []
    for k in (1.0, 2.0):
        style = {"font.size": 7.0 * k, "lines.linewidth": 0.75 * k, "lines.markersize": 3.0 * k}
        with plt.rc_context(style):
            before = dict(matplotlib.rcParams)
            fig = call(fn, run)
            fig.canvas.draw()  # tick labels and legends exist only once drawn
            assert dict(matplotlib.rcParams) == before, f"{name} changed rcParams"
            found.append(_texts_and_lines(fig))
        plt.close(fig)
    (s1, w1, m1), (s2, w2, m2) = found
    assert s1 and w1
    assert {round(2 * s, 6) for s in s1} == s2
    assert {round(2 * w, 6) for w in w1} == w2
    assert {round(2 * m, 6) for m in m1} == m2


def test_the_main_artists_take_the_user_s_values(run):
    style = {"font.size": 13.0, "lines.linewidth": 2.5, "axes.labelsize": "medium"}
    with plt.rc_context(style):
        fig = plotting.plot_theta(run)
        ax = fig.axes[0]
        assert ax.lines[0].get_linewidth() == 2.5
        assert ax.xaxis.label.get_fontsize() == 13.0
        assert tuple(fig.get_size_inches()) == tuple(matplotlib.rcParams["figure.figsize"])
    with plt.rc_context({"image.cmap": "magma"}):
        top = mett.presets.get("rutstam2012")
        fig = plotting.plot_potential_surface(top, THESIS_LAMBDA, n=21, n_D=11)
        surf = next(c for c in fig.axes[0].collections if c.get_array() is not None)
        assert surf.get_cmap().name == "magma"


# --- ψ̇ and φ̇ (thesis fig. 4b-c): each on its own axis ------------------------------------------


def _inside(y, ax):
    lo, hi = ax.get_ylim()
    return np.mean((y >= lo) & (y <= hi))


def test_psidot_and_phidot_each_get_a_panel_and_a_range_of_their_own(run):
    fig = plotting.plot_angular_velocities(run)
    assert len(fig.axes) == 2
    a_psi, a_phi = fig.axes
    for a, name in ((a_psi, "psidot"), (a_phi, "phidot")):
        assert len(a.lines) == 1
        t, y = a.lines[0].get_data()
        np.testing.assert_array_equal(t, run.t)
        np.testing.assert_array_equal(y, getattr(run, name))
        lo, hi = np.percentile(y, [1, 99])
        assert a.get_ylim()[0] < lo and a.get_ylim()[1] > hi  # its own 1st-99th percentiles
        assert _inside(y, a) >= 0.98
        assert name[:-3] in a.get_ylabel() and "[rad/s]" in a.get_ylabel()
    assert a_psi.get_ylim() != a_phi.get_ylim()
    assert a_psi.get_shared_x_axes().joined(a_psi, a_phi)
    assert a_phi.get_xlabel() == "t [s]"


def test_angular_velocities_on_one_given_axes_use_a_twin_axis(run):
    fig, ax = plt.subplots()
    plotting.plot_angular_velocities(run, ax=ax)
    assert len(fig.axes) == 2  # ax and its twin
    twin = fig.axes[1]
    np.testing.assert_array_equal(ax.lines[0].get_ydata(), run.psidot)
    np.testing.assert_array_equal(twin.lines[0].get_ydata(), run.phidot)
    assert twin.get_shared_x_axes().joined(ax, twin)
    fig2, pair = plt.subplots(1, 2)
    plotting.plot_angular_velocities(run, ax=pair)
    assert [len(a.lines) for a in pair] == [1, 1] and len(fig2.axes) == 2


# --- the V surface: the colour bar's ticks are the V axis's; the view looks along the well -------


def test_surface_colour_bar_ticks_are_the_V_axis_ticks():
    top = mett.presets.get("rutstam2012")
    fig = plotting.plot_potential_surface(top, THESIS_LAMBDA, n=41, n_D=21)
    fig.canvas.draw()
    ax = next(a for a in fig.axes if a.name == "3d")
    cbar_ax = next(a for a in fig.axes if a is not ax)
    zmin, zmax = ax.get_zlim()
    zticks = [t for t in ax.get_zticks() if zmin <= t <= zmax]
    cticks = list(cbar_ax.get_yticks())
    assert len(zticks) >= 3
    np.testing.assert_array_equal(cticks, zticks)
    zlabels = [
        t.get_text()
        for t, v in zip(ax.zaxis.get_ticklabels(), ax.get_zticks(), strict=True)
        if zmin <= v <= zmax
    ]
    assert [t.get_text() for t in cbar_ax.get_yticklabels()] == zlabels
    # the colours run over exactly the heights of the V axis
    surf = next(c for c in ax.collections if c.get_array() is not None)
    assert (surf.norm.vmin, surf.norm.vmax) == pytest.approx((zmin, zmax), rel=1e-12)


@pytest.mark.parametrize("coordinate", ["z", "theta"])
def test_surface_shows_the_floor_of_the_well_and_looks_along_it(coordinate):
    top = mett.presets.get("rutstam2012")
    fig = plotting.plot_potential_surface(
        top, THESIS_LAMBDA, coordinate=coordinate, n=41, n_D=21, colorbar=False
    )
    ax = fig.axes[0]
    floor = next(ln for ln in ax.lines if ln.get_label() == "well minimum")
    u, D, V = (np.asarray(c) for c in floor.get_data_3d())
    z = u if coordinate == "z" else np.cos(u)
    for i in (0, len(D) // 2, -1):
        zm = mett.potential_minimum(top, D[i] / 1e3, THESIS_LAMBDA)
        assert z[i] == pytest.approx(zm, abs=1e-12)
        assert V[i] == pytest.approx(float(mett.V(top, zm, D[i] / 1e3, THESIS_LAMBDA)) * 1e3)
    # the well's track in the (normalised) box of the axes, and the horizontal view direction
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    track = np.array([(u[-1] - u[0]) / (x1 - x0), (D[-1] - D[0]) / (y1 - y0)])
    track /= np.linalg.norm(track)
    view = np.array([math.cos(math.radians(ax.azim)), math.sin(math.radians(ax.azim))])
    assert abs(track @ view) > math.cos(math.radians(30))  # within 30° of looking along it
    assert 15 <= ax.elev <= 50  # from above, but low enough to see the walls rise


# --- the subgroup diagram: legends for the boundary lines and the marks -------------------------


def test_subgroup_legends_name_every_boundary_line_and_mark():
    from mett import classification as C

    fig = plotting.plot_subgroups(
        points={"rutstam2013": (0.3, 0.9357), "x": (0.2, 1.0)}, samples=[(0.3, 0.75)], n=30
    )
    legends = {lg.get_label(): lg for lg in fig.legends}
    assert [t.get_text() for t in legends["class"].get_texts()] == list(C.SUBGROUPS)
    entries = [t.get_text() for t in legends["lines and marks"].get_texts()]
    assert entries == [
        "γ = 1 ∓ α: groups I | II | III",
        "S(1) = 0: lower edge of IIa",
        "S(−1) = 0: edges of Ia, IIc",
        "λ₀ = λ_thres",
        "γ = 1/2 (I3 = 2 I1)",
        "presets",
        "simulated samples",
    ]
    ax = fig.axes[0]
    lines = {ln.get_label(): ln for ln in ax.lines}
    a = lines["S(1) = 0: lower edge of IIa"].get_xdata()
    b = C.subgroup_boundaries(a)
    # each legend entry labels the curve it describes, in its style
    np.testing.assert_array_equal(lines["S(1) = 0: lower edge of IIa"].get_ydata(), b.IIa)
    assert lines["S(1) = 0: lower edge of IIa"].get_linestyle() == "--"
    np.testing.assert_array_equal(lines["λ₀ = λ_thres"].get_ydata(), b.spins_equal)
    assert lines["λ₀ = λ_thres"].get_linestyle() == "-."
    np.testing.assert_array_equal(lines["γ = 1 ∓ α: groups I | II | III"].get_ydata(), b.group_I)
    handles = legends["lines and marks"].legend_handles
    assert [h.get_linestyle() for h in handles[:4]] == ["-", "--", ":", "-."]
    assert handles[5].get_marker() == "o" and handles[6].get_marker() == "^"
    # only one preset legend entry for several presets
    assert sum(ln.get_label() == "presets" for ln in ax.lines) == 1
    # the class map is an image in PDF/SVG (its n² cells as vectors made a 92 MB SVG)
    assert all(
        c.get_rasterized() for a_ in fig.axes for c in a_.collections if c.get_array() is not None
    )


def test_vector_subgroup_figure_stays_small(tmp_path):
    fig = plotting.plot_subgroups(n=500)
    fig.savefig(tmp_path / "s.svg", dpi=100)
    # a 500 × 500 class map: as vectors 250 000 paths (~90 MB); rasterised, one image each
    assert (tmp_path / "s.svg").stat().st_size < 5e6


def test_the_classification_figures_live_in_plotting_only():
    # the analysis floor must not reach up to the figures (no import cycle): the old names are gone
    import mett.classification as C

    assert not hasattr(C, "plot_subgroups")
    assert not hasattr(C, "plot_tumbling_families")
    assert callable(plotting.plot_subgroups) and callable(plotting.plot_tumbling_families)


# --- the potential map: the start and end marks lie wholly inside the axes ----------------------


@pytest.mark.parametrize("coordinate", ["z", "theta"])
def test_potential_map_marks_are_not_clipped(run, coordinate):
    top, lam = run.top, float(run.lam[0])
    fig = plotting.plot_potential_map(top, lam, trajectory=run, coordinate=coordinate, n=41)
    fig.canvas.draw()
    ax = fig.axes[0]
    box = ax.get_window_extent()
    px_per_pt = fig.dpi / 72.0
    for label in ("start", "end"):
        mark = next(ln for ln in ax.lines if ln.get_label() == label)
        x, y = ax.transData.transform((mark.get_xdata()[0], mark.get_ydata()[0]))
        r = (0.5 * mark.get_markersize() + mark.get_markeredgewidth()) * px_per_pt
        assert box.x0 <= x - r and x + r <= box.x1, label
        assert box.y0 <= y - r and y + r <= box.y1, label
    # the marks really sit on an edge of the map's data (so limits at the data would cut them)
    Dt, _ = next(ln for ln in ax.lines if ln.get_label() == "well minimum").get_data()
    edges = []
    for label in ("start", "end"):
        mark = next(ln for ln in ax.lines if ln.get_label() == label)
        edges.append(min(abs(mark.get_xdata()[0] - Dt[0]), abs(mark.get_xdata()[0] - Dt[-1])))
    assert min(edges) <= 1e-3 * (Dt[-1] - Dt[0])  # closer than a marker radius


# --- the phase diagram: the thresholds for the swept top --------------------------------------


def test_sweep_table_carries_the_top_and_the_phase_diagram_draws_its_thresholds():
    import dataclasses

    top = mett.presets.get("rutstam2013")
    # a tiny sweep: its end states are beside the point, its table's attrs are not
    table = mett.sweep(top, {"lam_ratio": [0.5, 2.0], "gamma": [0.9, 0.95]}, t_end=0.02)
    assert "alpha" not in table
    assert table.attrs["top"] == dataclasses.asdict(top)
    ax = plotting.plot_phase_diagram(table).axes[0]
    lam0 = next(ln for ln in ax.lines if ln.get_label() == "λ = λ₀")
    x, g = lam0.get_data()
    assert g.min() > 1 - top.alpha and g.max() < 1 + top.alpha
    for i in (5, len(g) // 2, -5):  # λ_0/λ_thres of the top with I1 = γ I3 (TippeTop's formulas)
        t_g = top.replace(I1=g[i] * top.I3)
        assert x[i] == pytest.approx(t_g.lambda_0 / t_g.lambda_thres, rel=1e-12)
    thres = next(ln for ln in ax.lines if ln.get_label() == "λ = λ_thres")
    np.testing.assert_array_equal(thres.get_xdata(), [1.0, 1.0])
    lo, hi = ax.get_xlim()
    assert lo <= 1.0 <= hi and lo <= x.min()


def test_phase_diagram_draws_the_thresholds_the_other_way_round_too():
    ax = plotting.plot_phase_diagram(_table(), x="gamma", y="lam_ratio").axes[0]
    thres = next(ln for ln in ax.lines if ln.get_label() == "λ = λ_thres")
    np.testing.assert_array_equal(thres.get_ydata(), [1.0, 1.0])  # a line at λ/λ_thres = 1
    g, r0 = next(ln for ln in ax.lines if ln.get_label() == "λ = λ₀").get_data()
    top = mett.TippeTop(m=0.02, R=0.02, alpha=0.3, I1=g[100] * 3.2e-6, I3=3.2e-6)
    assert r0[100] == pytest.approx(top.lambda_0 / top.lambda_thres, rel=1e-12)
    assert ax.get_xlabel() == "γ = I1/I3" and ax.get_ylabel() == "λ / λ_thres"


def test_phase_diagram_leaves_the_thresholds_out_when_alpha_varies():
    table = _table()
    table["alpha"] = [0.2, 0.3, 0.4]
    ax = plotting.plot_phase_diagram(table).axes[0]
    assert not any(ln.get_label().startswith("λ = ") for ln in ax.lines)
    ax = plotting.plot_phase_diagram(table, alpha=0.3).axes[0]  # unless it is given
    assert any(ln.get_label() == "λ = λ_thres" for ln in ax.lines)
