"""Every published figure, regenerated: the thesis run (Rutstam 2013, figures 4–6), the V(cos θ, D)
surface (Rutstam 2012), the potential map with the run's path, the deforming potential and the
separation equation.

``mett figures --out DIR`` (or :func:`generate`) writes them as PNG, PDF or SVG (:data:`FORMATS`) at
any resolution (and one GIF), with an index :data:`INDEX_NAME`; the checked-in copies (the docs' gallery) live in ``docs/figures/`` and are
regenerated on purpose with ``mett figures --out docs/figures``. Only
files of mett's own names (:func:`file_names`) are written, so ``--out .`` never replaces a file of
the user's such as ``README.md``. ``generate(out, top=...)`` draws the same
figures for any top: the run then starts at θ = 0.1 rad with λ = 2 λ_thres (the thesis run has
λ ≈ 2.005 λ_thres), long enough to invert. Tops that cannot invert (groups I and III) get every
figure but those of the run (:func:`skipped` says which and why).
"""

from __future__ import annotations

import math
import operator
import sys
import warnings
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ._validate import MettWarning

if TYPE_CHECKING:
    from matplotlib.typing import RcKeyType

    from .top import TippeTop

__all__ = [
    "DEFAULT_DPI",
    "FIGURES",
    "FORMATS",
    "INDEX_NAME",
    "STYLE",
    "FigureSkippedWarning",
    "file_names",
    "generate",
    "skipped",
]

INDEX_NAME = "mett-figures.md"
"""The Markdown index ``mett figures`` writes beside the figures (a name no other tool uses)."""

THESIS_LAMBDA = 6.8944e-6
"""λ (kg m³/s) of the thesis run (θ = 0.1 rad, ω3 = 155 rad/s), used for the Rutstam 2012 surface."""

FORMATS = ("png", "pdf", "svg")
"""File formats of the figures: raster PNG, or vector PDF and SVG (fonts embedded, text as paths
in SVG), for print."""

DEFAULT_DPI = 110
"""Resolution (dots per inch) of the PNG figures by default; 300 is print quality. The vector
formats store the dpi only for the few rasterised parts."""

STYLE: dict[RcKeyType, Any] = {
    "figure.figsize": (6.4, 4.4),
    "lines.linewidth": 1.0,
    "svg.hashsalt": "mett",
    "svg.fonttype": "path",
    "pdf.fonttype": 42,
}
"""rcParams the gallery draws under (:func:`matplotlib.rc_context`); :mod:`mett.plotting` itself
takes the user's. Thin lines for the dense oscillating runs, a fixed salt for SVG ids and TrueType
fonts in PDF (editable, accepted by journals)."""

# metadata that would make each save differ (dates): left out, so a file depends only on its figure
_METADATA = {"png": None, "pdf": {"CreationDate": None}, "svg": {"Date": None}}

THETA0 = 0.1
"""Start inclination (rad) of the run of a top other than the thesis preset."""


class FigureSkippedWarning(MettWarning):
    """A gallery figure was not drawn because it makes no sense for the given top."""


@dataclass
class _Context:
    """The top and the runs shared by several figures, computed on first use."""

    top: TippeTop | None = None
    """None: the thesis preset, its run and the Rutstam 2012 surface exactly as published."""
    cache: dict[str, Any] = field(default_factory=dict)

    @cached_property
    def body(self) -> TippeTop:
        import mett

        return mett.presets.get("rutstam2013") if self.top is None else self.top

    @cached_property
    def lam(self) -> float:
        """λ of the run: the thesis value, else 2 λ_thres (2 λ_0 for group III, never flips)."""
        if self.top is None:
            return THESIS_LAMBDA
        top = self.top
        base = top.lambda_thres if math.isfinite(top.lambda_thres) else top.lambda_0
        return 2.0 * max(base, top.lambda_0 if math.isfinite(top.lambda_0) else 0.0)

    @cached_property
    def start(self):
        import mett

        if self.top is None:
            return mett.State(theta=THETA0, omega3=155.0)
        top = self.top
        # λ = R I3 ω3 (cos θ − α) with θ̇ = φ̇ = 0 (Jellett integral)
        omega3 = self.lam / (top.R * top.I3 * (math.cos(THETA0) - top.alpha))
        return mett.State(theta=THETA0, omega3=omega3)

    @cached_property
    def t_end(self) -> float:
        """9 s for the thesis run; else 1.5 × the predicted escape time (9 s ≈ 1.5 × 6.0 s there)."""
        if self.top is None:
            return 9.0
        import mett

        return min(1.5 * mett.escape_time(self.top, self.start).time, 300.0)

    @cached_property
    def thesis(self):
        """The inversion run (for another top: its own start, see :data:`THETA0`)."""
        import mett

        return mett.simulate(self.body, self.start, t_end=self.t_end)

    @cached_property
    def rolling(self):
        """A rolling state in the middle of the sphere: (top, E, D, λ)."""
        import mett

        top = self.body
        if self.top is None:
            s = mett.State(theta=1.0, omega3=100.0, phidot=5.0)
        else:  # the thesis state's spin scaled by the run's
            omega3 = 100.0 / 155.0 * float(self.start.omega3)
            s = mett.State(theta=1.0, omega3=omega3, phidot=omega3 / 20.0)
        return top, mett.energy(top, s), mett.routh(top, s), mett.jellett(top, s)


def _thesis(fn_name: str) -> Callable[[_Context], Any]:
    def make(ctx: _Context):
        from . import plotting

        return getattr(plotting, fn_name)(ctx.thesis)

    return make


def _surface(ctx: _Context):
    import mett

    from . import plotting

    if ctx.top is None:  # the published figure: the Rutstam 2012 body at the thesis λ
        return plotting.plot_potential_surface(mett.presets.get("rutstam2012"), THESIS_LAMBDA)
    return plotting.plot_potential_surface(ctx.body, ctx.lam)


def _map(ctx: _Context):
    from . import plotting

    return plotting.plot_potential_map(ctx.body, ctx.lam, trajectory=ctx.thesis)


def _nutation_mean(t, theta):
    """θ averaged over each nutation of a run: ∫θ dt / Δt between successive maxima of θ(t),
    placed at the middle of each cycle."""
    import numpy as np

    t, theta = np.asarray(t), np.asarray(theta)
    peaks = np.flatnonzero((theta[1:-1] > theta[:-2]) & (theta[1:-1] >= theta[2:])) + 1
    if len(peaks) < 2:
        return t[:0], theta[:0]
    area = np.concatenate([[0.0], np.cumsum(0.5 * (theta[1:] + theta[:-1]) * np.diff(t))])
    t0, t1 = t[peaks[:-1]], t[peaks[1:]]
    return 0.5 * (t0 + t1), (area[peaks[1:]] - area[peaks[:-1]]) / (t1 - t0)


def _prediction(ctx: _Context):
    """The run beside mett.predict_inversion's slow path, from the theory alone: the path on the
    potential map, and θ̄(t) against the run's θ(t) and its nutation mean."""
    import math

    import matplotlib.pyplot as plt

    import mett

    from . import plotting

    traj = ctx.thesis
    p = mett.predict_inversion(ctx.body, ctx.start)
    w, h = plt.rcParams["figure.figsize"]
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(2.0 * w, h), layout="constrained")
    plotting.plot_potential_map(ctx.body, ctx.lam, trajectory=traj, prediction=p, ax=a1)
    a2.plot(traj.t, traj.theta, color="C1", lw=0.4 * plt.rcParams["lines.linewidth"],
            label="simulated θ(t)")  # fmt: skip
    tm, thm = _nutation_mean(traj.t, traj.theta)
    a2.plot(tm, thm, color="k", label="simulated, mean over each nutation")
    a2.plot(p.t, p.theta, color="C3", ls="--", label="predicted θ̄(t) (the growing mode)")
    a2.axhline(0.5 * math.pi, color="0.6", ls=":")
    hits = traj.crossings(0.5 * math.pi)
    if len(hits):
        a2.axvline(float(hits[0]), color="C1", ls=":")
    if math.isfinite(p.t_half):
        a2.axvline(p.t_half, color="C3", ls=":")
    a2.set(xlabel="t [s]", ylabel="θ [rad]", ylim=(0.0, math.pi), xlim=(0.0, float(traj.t[-1])))
    sim = f"{float(hits[0]):.2f} s" if len(hits) else "not reached"
    pred = f"{p.t_half:.2f} s" if math.isfinite(p.t_half) else "never"
    a2.set_title(f"θ passes π/2: predicted {pred}, simulated {sim}")
    a2.legend(loc="upper left", fontsize="small")
    return fig


def _slices(ctx: _Context):
    import numpy as np

    import mett

    from . import plotting

    bv = mett.boundary_values(ctx.body, ctx.lam)
    Ds = np.linspace(float(bv.D0), float(bv.D1), 7)[1:-1]
    return plotting.plot_potential_slices(ctx.body, Ds, ctx.lam)


def _slice(ctx: _Context):
    from . import plotting

    top, E, D, lam = ctx.rolling
    return plotting.plot_potential(top, D, lam, E=E)


def _f(ctx: _Context):
    from . import plotting

    return plotting.plot_f(*ctx.rolling)


def _subgroups(ctx: _Context):
    import mett

    from .classification import SAMPLE_POINTS
    from .plotting import plot_subgroups

    presets = {n: mett.presets.get(n) for n in ("rutstam2013", "cohen1977", "ueda2005")}
    points = {n: (t.alpha, t.gamma) for n, t in presets.items()}
    return plot_subgroups(points=points, samples=list(SAMPLE_POINTS.values()))


def _families(ctx: _Context):
    from .plotting import plot_tumbling_families

    return plot_tumbling_families()


_CONTACT_COLOURS = {"ball": "tab:blue", "stem": "tab:orange", "both": "tab:red"}


def _contact_bands(ax, traj, lo, hi):
    """Shade each stretch of a stemmed run by the contact it is on (ball, stem or both)."""
    for name, c in _CONTACT_COLOURS.items():
        on = traj.contact == name
        ax.fill_between(traj.t, lo, hi, where=on, color=c, alpha=0.15, lw=0, label=name)


def _stem_life(ctx: _Context):
    """Two stemmed tops under the viscous law: friedl1997 with its stem (CM at rest, θ0 = 0.1,
    ω3 = 180 rad/s), θ(t) with the contact of each stretch and its normal forces at the
    touchdown; and the thesis body with a stem (r_s = 4 mm, l_s = 26 mm; θ0 = 0.1, ω3 = 155),
    whose impacts accumulate into a double contact."""
    import matplotlib.pyplot as plt
    import numpy as np

    import mett

    friedl = mett.presets.stemmed("friedl1997")
    s = mett.State.with_cm_at_rest(friedl.ball, theta=0.1, omega3=180.0)
    run_f = mett.simulate(friedl, s, t_end=8.0)
    thesis = mett.presets.get("rutstam2013").with_stem(radius=0.004, distance=0.026)
    run_t = mett.simulate(thesis, mett.State(theta=0.1, omega3=155.0), t_end=8.0)
    colours = _CONTACT_COLOURS
    bands = _contact_bands
    fig, (a1, a2, a3) = plt.subplots(3, 1, figsize=(6.4, 7.2))

    a1.plot(run_f.t, run_f.theta, color="k", label="θ")
    a1.axhline(friedl.touchdown_angle, color="0.6", ls=":", lw=0.8)
    bands(a1, run_f, 0.0, np.pi)
    a1.set(ylabel="θ (rad)", ylim=(0, np.pi), xlim=(0, 8.0), xlabel="t (s)")
    a1.legend(loc="upper left", fontsize="small", ncol=4)
    a1.set_title("friedl1997 with its stem (viscous law): θ(t) and the contact", fontsize="medium")
    for ax, traj, title in (
        (a2, run_f, "friedl1997: impacts, then the stem"),
        (a3, run_t, "thesis body with a stem: impacts accumulate, double contact, lift-off"),
    ):
        t0 = traj.touchdowns[0]
        w = (traj.t > t0 - 0.03) & (traj.t < t0 + 0.8)
        ax.plot(traj.t[w], 1e3 * traj.gn_ball[w], color=colours["ball"], label="g_n ball")
        ax.plot(traj.t[w], 1e3 * traj.gn_stem[w], color=colours["stem"], label="g_n stem")
        top_ = 1e3 * max(traj.gn_ball[w].max(), traj.gn_stem[w].max()) * 1.1
        bands(ax, traj, 0.0, top_)
        ax.set(ylabel="normal force (mN)", xlabel="t (s)", ylim=(0, top_))
        ax.set_xlim(traj.t[w][0], traj.t[w][-1])
        ax.set_title(title, fontsize="medium")
    a2.legend(loc="upper right", fontsize="small", ncol=2)
    fig.tight_layout()
    return fig


DRY_WINDOW = (4.10, 5.15)
"""The stretch (s) of figure ``stem_dry_friction`` shown in detail: the re-landing on the ball,
the impacts that accumulate, the double contact and the stem's lift-off."""


def _stem_dry(ctx: _Context):
    """friedl1997 with its stem under Leine & Glocker's law, Coulomb–Contensou friction (μ = 0.3,
    contact radius 0.5 mm; CM at rest, θ0 = 0.1, ω3 = 180 rad/s): θ(t) with the contact of each
    stretch; over :data:`DRY_WINDOW` the two normal forces; the energy, which never rises."""
    import matplotlib.pyplot as plt
    import numpy as np

    import mett
    from mett.friction import Coulomb

    top = mett.presets.stemmed("friedl1997")
    s = mett.State.with_cm_at_rest(top.ball, theta=0.1, omega3=180.0)
    t0, t1 = DRY_WINDOW
    t_eval = np.union1d(np.linspace(0.0, 8.0, 3201), np.linspace(t0, t1, 2101))
    run = mett.simulate(top, s, t_end=8.0, friction=Coulomb(0.3, contensou_radius=5e-4),
                        t_eval=t_eval)  # fmt: skip
    colours = _CONTACT_COLOURS
    fig, (a1, a2, a3) = plt.subplots(3, 1, figsize=(6.4, 7.2))
    a1.plot(run.t, run.theta, color="k", label="θ")
    a1.axhline(top.touchdown_angle, color="0.6", ls=":", lw=0.8)
    _contact_bands(a1, run, 0.0, np.pi)
    a1.axvspan(t0, t1, color="0.5", alpha=0.25, lw=0, label="detail below")
    a1.set(ylabel="θ (rad)", ylim=(0, np.pi), xlim=(0, 8.0), xlabel="t (s)")
    a1.legend(loc="lower center", bbox_to_anchor=(0.42, 0.04), fontsize="small", ncol=2)
    a1.set_title(
        "friedl1997 with its stem, Coulomb–Contensou (μ = 0.3, r = 0.5 mm): θ(t), contact",
        fontsize="medium",
    )
    w = (run.t >= t0) & (run.t <= t1)
    a2.plot(run.t[w], 1e3 * run.gn_ball[w], color=colours["ball"], label="g_n ball")
    a2.plot(run.t[w], 1e3 * run.gn_stem[w], color=colours["stem"], label="g_n stem")
    a2.axhline(1e3 * top.ball.m * top.ball.g, color="0.3", ls=":", lw=0.8, label="m g")
    hi = 1e3 * max(run.gn_ball[w].max(), run.gn_stem[w].max()) * 1.5  # room for the legend
    _contact_bands(a2, run, 0.0, hi)
    a2.set(ylabel="normal force (mN)", xlabel="t (s)", xlim=(t0, t1), ylim=(0, hi))
    a2.legend(loc="upper center", fontsize="small", ncol=3)
    a2.set_title("re-landing, impacts accumulating, double contact, stem lifts off",
                 fontsize="medium")  # fmt: skip
    a3.plot(run.t, 1e3 * run.E, color="k")
    _contact_bands(a3, run, 0.0, 1e3 * run.E.max() * 1.05)
    a3.set(ylabel="E (mJ)", xlabel="t (s)", xlim=(0, 8.0), ylim=(0, 1e3 * run.E.max() * 1.05))
    a3.set_title("energy: never rises", fontsize="medium")
    fig.tight_layout()
    return fig


FLIGHT_START = (0.1, 250.0)
"""(θ0 rad, ω3 rad/s) of the hopping run of figure ``ball_flights``: the thesis body under its
viscous law hops about 100 times between 5.0 and 7.9 s, inverts and lands for good."""

FLIGHT_WINDOW = (6.40, 6.52)
"""The stretch of that run (s) shown in detail: a few hops, each followed by contact."""


def _flights(ctx: _Context):
    """The thesis body from θ0 = 0.1 rad, ω3 = 250 rad/s (viscous law, μ = 0.3 s/m): θ(t) with
    its stretches of flight; over :data:`FLIGHT_WINDOW`, the height of the ball's lowest point
    (the gap, 0 in contact) and the normal force g_n (0 in flight)."""
    import matplotlib.pyplot as plt
    import numpy as np

    import mett

    top = mett.presets.get("rutstam2013")
    theta0, omega3 = FLIGHT_START
    t0, t1 = FLIGHT_WINDOW
    # samples of the dense output: every 2.5 ms, every 0.1 ms in the detail (a contact lasts ~10 ms)
    t_eval = np.union1d(np.linspace(0.0, 10.0, 4001), np.linspace(t0, t1, 1201))
    run = mett.simulate(top, mett.State(theta=theta0, omega3=omega3), t_end=10.0, t_eval=t_eval)
    air = np.asarray(run.contact) == "none"
    lifts = [s.t for s in run.switches if s.reason == "lift-off"]
    lands = [s.t for s in run.switches if s.reason == "touchdown"]
    fig, (a1, a2, a3) = plt.subplots(3, 1, figsize=(6.4, 7.2))

    def bands(ax, lo, hi, label=None):
        ax.fill_between(run.t, lo, hi, where=air, color="tab:orange", alpha=0.25, lw=0,
                        label=label)  # fmt: skip

    a1.plot(run.t, run.theta, color="k", label="θ")
    bands(a1, 0.0, np.pi, 'in flight (contact "none")')
    a1.axvspan(t0, t1, color="0.5", alpha=0.3, lw=0, label="detail below")
    a1.set(ylabel="θ (rad)", xlabel="t (s)", xlim=(0.0, run.t[-1]), ylim=(0.0, np.pi))
    a1.legend(loc="upper left", fontsize="small")
    a1.set_title(
        f"thesis body, θ0 = {theta0:g} rad, ω3 = {omega3:g} rad/s (viscous law): "
        f"{len(lifts)} hops, {lifts[0]:.2f}–{lands[-1]:.2f} s",
        fontsize="medium",
    )
    w = (run.t >= t0) & (run.t <= t1)
    gap = 1e3 * np.asarray(run.gap)
    a2.plot(run.t[w], gap[w], color="tab:blue")
    top_ = 1.15 * float(gap[w].max())
    bands(a2, 0.0, top_)
    a2.set(ylabel="height of the lowest\npoint (mm)", xlim=(t0, t1), ylim=(0.0, top_))
    a2.set_title("the gap: the ball's lowest point above the table", fontsize="medium")
    gn = 1e3 * np.asarray(run.gn)
    mg = 1e3 * top.m * top.g
    a3.plot(run.t[w], gn[w], color="tab:green", label="g_n")
    a3.axhline(mg, color="0.4", ls=":", lw=0.8, label="m g")
    top_ = 1.1 * max(float(gn[w].max()), mg)
    bands(a3, 0.0, top_)
    a3.set(ylabel="normal force (mN)", xlabel="t (s)", xlim=(t0, t1), ylim=(0.0, top_))
    a3.legend(loc="upper right", fontsize="small")
    a3.set_title("the normal force: 0 in flight", fontsize="medium")
    fig.tight_layout()
    return fig


FIGURES: dict[str, tuple[str, Callable[[_Context], Any]]] = {
    "thesis_fig4a_theta": ("θ(t) of the thesis run (thesis fig. 4a)", _thesis("plot_theta")),
    "thesis_fig4bc_psidot_phidot": (
        "ψ̇(t), φ̇(t) (thesis fig. 4b, c)",
        _thesis("plot_angular_velocities"),
    ),
    "thesis_fig5a_omega3": ("ω3(t) and its Jellett limit (thesis fig. 5a)", _thesis("plot_omega3")),
    "thesis_fig5b_gliding_velocity": (
        "ν_x(t), ν_y(t) (thesis fig. 5b)",
        _thesis("plot_gliding_velocities"),
    ),
    "thesis_fig6a_D_E_curve": (
        "the (D(t), Ẽ(t)) curve (thesis fig. 6a)",
        _thesis("plot_D_E_curve"),
    ),
    "thesis_fig6b_thetadot": ("θ̇(t) (thesis fig. 6b)", _thesis("plot_thetadot")),
    "energies": ("E(t) decreasing and Ẽ(t) of the METT", _thesis("plot_energies")),
    "deforming_potential": (
        "V(cos θ, D(t), λ) with θ(t) riding in it",
        _thesis("plot_deforming_potential"),
    ),
    "axis_trace": ("the symmetry axis on the unit sphere", _thesis("plot_axis_trace")),
    "paper1_V_surface": ("V(cos θ, D, λ) over D ∈ [D1, D0] (Rutstam 2012)", _surface),
    "potential_map": ("V over (D, cos θ) with the well's minimum and the run's path", _map),
    "inversion_prediction": (
        "the run beside the predicted slow path (mett.predict_inversion): map and θ̄(t)",
        _prediction,
    ),
    "potential_slices": ("V(z, D, λ) at five D between D0 and D1", _slices),
    "potential_slice": ("V(z) of a rolling top with Ẽ and the turning points", _slice),
    "separation_f": ("f(z) of ż² = f(z) with its roots", _f),
    "subgroups": ("the classes Ia–III of tops in the (α, γ) plane", _subgroups),
    "tumbling_families": (
        "steady states of each class in the (θ, λ) plane, stable and unstable",
        _families,
    ),
    "stem_double_contact": (
        "the real top with its stem: θ(t), the contact and the normal forces",
        _stem_life,
    ),
    "ball_flights": (
        "a hopping ball top: θ(t), the height of its lowest point and the normal force",
        _flights,
    ),
    "stem_dry_friction": (
        "the real top with its stem under Coulomb–Contensou friction: θ(t), the contact, the "
        "normal forces through the double contact and the energy",
        _stem_dry,
    ),
}
"""Name → (description, maker). Each maker returns a matplotlib Figure."""

RUN_FIGURES = frozenset(
    [
        "thesis_fig4a_theta",
        "thesis_fig4bc_psidot_phidot",
        "thesis_fig5a_omega3",
        "thesis_fig5b_gliding_velocity",
        "thesis_fig6a_D_E_curve",
        "thesis_fig6b_thetadot",
        "energies",
        "deforming_potential",
        "axis_trace",
        "potential_map",
        "inversion_prediction",
    ]
)
"""Figures drawn from the inversion run (and the GIF): only for tops that can invert."""

ANIMATIONS = {"deforming_potential": "GIF of the deforming potential with θ(t) moving in it"}


def skipped(top: TippeTop | None = None) -> dict[str, str]:
    """Figures (and the GIF) :func:`generate` leaves out for ``top``, with the reason.

    Only tops of group II (1 − α < γ < 1 + α) invert; for the others the run's figures are left
    out. The thesis preset (``top=None``) skips nothing.
    """
    if top is None:
        return {}
    stem = {
        "stem_double_contact": "the figure shows the friedl1997 preset with its stem, "
        "not the given top",
        "ball_flights": "the figure shows the hops of the thesis body (rutstam2013), "
        "not the given top",
        "stem_dry_friction": "the figure shows the friedl1997 preset with its stem, "
        "not the given top",
    }
    if top.group == "II":
        return stem
    reason = (
        f"the top is in group {top.group} (γ = {top.gamma:.4g}, α = {top.alpha:.4g}): it cannot "
        "invert (inversion needs 1 − α < γ < 1 + α), so the inversion run is not drawn"
    )
    names = [*sorted(RUN_FIGURES), "deforming_potential.gif"]
    return {**dict.fromkeys(names, reason), **stem}


def _progress(items: list, enabled: bool) -> Iterable:
    if not enabled:
        return items
    try:
        from tqdm import tqdm

        return tqdm(items, desc="figures", unit="fig", file=sys.stderr)
    except ImportError:  # tqdm is an optional extra: fall back to a plain counter
        return _plain_progress(items)


def _plain_progress(items: list) -> Iterable:
    for i, item in enumerate(items, 1):
        print(f"\rfigures: {i}/{len(items)} {item}", end="", file=sys.stderr, flush=True)
        yield item
    print(file=sys.stderr)


def generate(
    out_dir: str | Path,
    *,
    top: TippeTop | None = None,
    names: Iterable[str] | None = None,
    animation: bool = True,
    progress: bool = False,
    dpi: int = DEFAULT_DPI,
    format: str = "png",
) -> list[Path]:
    """Write the figures (PNG, PDF or SVG) and the animation (GIF) into ``out_dir``; return the paths.

    Parameters
    ----------
    out_dir : str or Path
        Directory (created if missing).
    top : TippeTop, optional
        The top to draw. Default: the thesis preset ``rutstam2013`` with the thesis run
        (θ(0) = 0.1 rad, ω3(0) = 155 rad/s, 9 s) and the Rutstam 2012 surface, as published.
        Another top is started at θ = 0.1 rad with λ = 2 λ_thres and run for 1.5 × the predicted
        escape time (:func:`mett.escape_time`); see :func:`skipped` for tops that cannot invert.
    names : iterable of str, optional
        A subset of :data:`FIGURES` (default: all).
    animation : bool, default True
        Also write ``deforming_potential.gif`` (the slowest item, ~10 s).
    progress : bool, default False
        Show a progress bar on stderr (tqdm if installed).
    dpi : int, default :data:`DEFAULT_DPI`
        Resolution in dots per inch, 10 to 2400 (300 for print): the PNGs' pixels per inch (and
        their ``pHYs`` metadata), the rasterised parts of PDF and SVG. The GIF keeps its own.
    format : {"png", "pdf", "svg"}, default "png"
        File format of the figures (:data:`FORMATS`); the file names end in it.

    Raises
    ------
    ValueError
        An unknown figure name or format, or a dpi outside [10, 2400], before anything is
        written.
    TypeError
        ``top`` that is not a :class:`mett.TippeTop`, or a dpi that is not an integer.

    Warns
    -----
    FigureSkippedWarning
        When figures are left out for ``top`` (the reason is in the message).
    """
    from .top import TippeTop

    if top is not None and not isinstance(top, TippeTop):
        raise TypeError(f"top must be a mett.TippeTop or None; got {type(top).__name__}")
    names = list(FIGURES) if names is None else list(names)
    unknown = [n for n in names if n not in FIGURES]
    if unknown:
        raise ValueError(f"unknown figure(s) {unknown}; known: {', '.join(FIGURES)}")
    dpi = _check_dpi(dpi)
    if format not in FORMATS:
        raise ValueError(f"format must be one of {', '.join(FORMATS)}; got {format!r}")

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from . import plotting

    skip = skipped(top)
    items = names + (["deforming_potential.gif"] if animation else [])
    left_out = [n for n in items if n in skip]
    if left_out:
        warnings.warn(
            f"figures not drawn: {', '.join(left_out)}: {skip[left_out[0]]}",
            FigureSkippedWarning,
            stacklevel=2,
        )
    items = [n for n in items if n not in skip]
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    ctx = _Context(top)
    written = []
    with plt.rc_context(STYLE):
        for name in _progress(items, progress):
            if name.endswith(".gif"):
                path = out / name
                plotting.animate_deforming_potential(ctx.thesis, str(path), frames=60, fps=12)
            else:
                fig = FIGURES[name][1](ctx)
                path = out / f"{name}.{format}"
                fig.savefig(path, dpi=dpi, format=format, metadata=_METADATA[format])
                plt.close(fig)
            written.append(path)
    return written


def _check_dpi(dpi: Any) -> int:
    """``dpi`` as an int in [10, 2400], or a TypeError/ValueError naming it."""
    if isinstance(dpi, bool):
        raise TypeError(f"dpi must be an integer (dots per inch, 10 to 2400); got {dpi!r}")
    try:
        value = operator.index(dpi)
    except TypeError:
        raise TypeError(
            f"dpi must be an integer (dots per inch, 10 to 2400); got {dpi!r}"
        ) from None
    if not 10 <= value <= 2400:
        raise ValueError(f"dpi must be between 10 and 2400 (dots per inch); got {dpi!r}")
    return value


def file_names() -> list[str]:
    """Every file name :func:`generate` and ``mett figures`` may write (nothing else is touched)."""
    figures = [f"{n}.{fmt}" for fmt in FORMATS for n in FIGURES]
    return [*figures, *(f"{n}.gif" for n in ANIMATIONS), INDEX_NAME]


def index_markdown(paths: Iterable[Path], *, left_out: dict[str, str] | None = None) -> str:
    """A Markdown gallery of the written figures (:data:`INDEX_NAME`), with the skipped."""
    lines = ["# Figures", "", "Regenerate with `mett figures --out figures`.", ""]
    for p in paths:
        key = p.stem
        desc = ANIMATIONS.get(key, key) if p.suffix == ".gif" else FIGURES[key][0]
        # Markdown shows PNG, SVG and GIF inline; a PDF is linked
        shown = f"[{desc} (PDF)]({p.name})" if p.suffix == ".pdf" else f"![{desc}]({p.name})"
        lines += [f"## {desc}", "", shown, ""]
    if left_out:
        lines += ["## Not drawn for this top", ""]
        lines += [f"- `{name}`: {why}" for name, why in left_out.items()]
        lines.append("")
    return "\n".join(lines)
