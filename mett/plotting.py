"""Figures of the METT and of simulated tops (matplotlib; imported lazily, never by ``import mett``).

Every ``plot_*`` function takes ``ax=None`` (a new figure is made when it is None) and returns the
Figure. The user's style is respected and never changed: sizes, fonts, line widths, marker sizes,
colours (``C0``, ``C1``, … of the property cycle) and the default colour map come from
:data:`matplotlib.rcParams`; the few secondary lines and marks (reference lines, contour lines)
are drawn at fixed fractions of ``lines.linewidth`` and ``lines.markersize`` and the text at
relative sizes ("small", …), so a style sheet scales them too. Angles are plotted in radians,
every energy in mJ (:data:`ENERGY_UNIT`) and the Routh integral D in 10⁻³ kg m²/s.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, cast

import matplotlib.pyplot as plt
import numpy as np
from matplotlib import patheffects
from matplotlib.ticker import MaxNLocator

from . import _validate, classification, potential, separation, thresholds

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure
    from mpl_toolkits.mplot3d import Axes3D
    from numpy.typing import ArrayLike

    from .dynamics import Trajectory
    from .inversion import InversionPrediction
    from .top import TippeTop

__all__ = [
    "D_LABEL",
    "D_SCALE",
    "ENERGY_SCALE",
    "ENERGY_UNIT",
    "SERIES",
    "animate_deforming_potential",
    "default_level",
    "plot_D_E_curve",
    "plot_angular_velocities",
    "plot_axis_trace",
    "plot_deforming_potential",
    "plot_energies",
    "plot_f",
    "plot_gliding_velocities",
    "plot_omega3",
    "plot_phase_diagram",
    "plot_potential",
    "plot_potential_map",
    "plot_potential_slices",
    "plot_potential_surface",
    "plot_subgroups",
    "plot_theta",
    "plot_thetadot",
    "plot_timeseries",
    "plot_tumbling_families",
]


def _figure(width: float = 1.0, height: float = 1.0) -> Figure:
    """A new figure of ``figure.figsize`` (rcParams) scaled by ``width`` and ``height``."""
    w, h = plt.rcParams["figure.figsize"]
    return plt.figure(figsize=(width * w, height * h), layout="constrained")


def _axes(ax: Axes | None) -> tuple[Figure, Axes]:
    if ax is not None:
        # an axes of a SubFigure hands back its SubFigure, which draws like a Figure
        return cast("Figure", ax.figure), ax
    fig = _figure()
    return fig, fig.add_subplot()


def _axes3d(ax: Axes3D | None) -> tuple[Figure, Axes3D]:
    if ax is not None:
        return cast("Figure", ax.figure), ax
    fig = _figure()
    return fig, fig.add_subplot(projection="3d")


def _lw(factor: float) -> float:
    """A secondary line's width: ``factor`` × the user's ``lines.linewidth``.

    The factors are the widths (points) at ``lines.linewidth = 1``, the gallery's style.
    """
    return factor * plt.rcParams["lines.linewidth"]


def _ms(factor: float) -> float:
    """A secondary marker's size: ``factor`` × the user's ``lines.markersize``."""
    return factor * plt.rcParams["lines.markersize"]


def _cmap_name(cmap: str | None) -> str:
    return plt.rcParams["image.cmap"] if cmap is None else cmap


# --- units and shared helpers ----------------------------------------------------------------

ENERGY_SCALE = 1e3
"""Every energy (V, E, Ẽ, E0, E1) is plotted in mJ: J × ENERGY_SCALE."""
ENERGY_UNIT = "mJ"
D_SCALE = 1e3
"""The Routh integral D is plotted in 10⁻³ kg m²/s: D × D_SCALE."""
D_LABEL = "D [10⁻³ kg m²/s]"

_COORDINATE_LABELS = {"z": "z = cos θ", "theta": "θ [rad]"}
_SEQUENTIAL_END = 0.85  # sequential colour maps are cut here: their last colours are pale on white


def _sci(x: float, digits: int = 4) -> str:
    """``x`` as mathtext, in scientific notation (a × 10^b) when far from 1."""
    if x == 0.0 or not np.isfinite(x):
        return f"{x:g}"
    e = int(np.floor(np.log10(abs(x))))
    if -2 <= e <= 3:
        return f"{x:.{digits}g}"
    return rf"{x / 10.0**e:.{digits - 1}f}\times10^{{{e}}}"


def _lam_text(lam: float) -> str:
    return rf"$\lambda = {_sci(lam)}$ kg m³/s"


def _D_text(D: float) -> str:
    return rf"$D = {_sci(D)}$ kg m²/s"


def _coordinate(coordinate: str) -> str:
    if coordinate not in _COORDINATE_LABELS:
        raise ValueError(f"coordinate must be 'z' or 'theta'; got {coordinate!r}")
    return coordinate


def _coordinate_grid(coordinate: str, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Samples u of the plotted coordinate (z or θ) and z = cos θ at them, poles included."""
    if n < 3:
        raise ValueError(f"the number of samples must be >= 3; got {n!r}")
    if coordinate == "z":
        u = np.linspace(-1.0, 1.0, n)
        return u, u
    u = np.linspace(0.0, np.pi, n)
    return u, np.clip(np.cos(u), -1.0, 1.0)


def _sequential_colors(n: int, cmap: str | None = None) -> list:
    """``n`` colours of a sequential map (default ``image.cmap``), stopping before its pale end."""
    cm = plt.get_cmap(_cmap_name(cmap))
    return [cm(x) for x in np.linspace(0.0, _SEQUENTIAL_END, max(n, 1))]


def _truncated_cmap(cmap: str):
    from matplotlib.colors import ListedColormap

    cm = plt.get_cmap(cmap)
    return ListedColormap(cm(np.linspace(0.0, _SEQUENTIAL_END, 256)), name=f"{cm.name}_trunc")


def default_level(top: TippeTop, lam: float) -> float:
    """Default level (J) above which the potential plots leave V out.

    The floor of the travelling well runs from E1 (at D1, θ = π) to E0 (at D0, θ = 0), the energies
    of the spinning states (:func:`mett.boundary_values`); the level lies above the higher of them
    by half their difference (at least m g R α), so the walls of the well show and the poles,
    where V → ∞, do not.
    """
    bv = thresholds.boundary_values(top, lam)
    hi, lo = max(float(bv.E0), float(bv.E1)), min(float(bv.E0), float(bv.E1))
    return hi + max(0.5 * (hi - lo), top.m * top.g * top.R * top.alpha)


def _V_grid(
    top: TippeTop, lam: float, D: np.ndarray, coordinate: str, n: int
) -> tuple[np.ndarray, np.ndarray]:
    """u (z or θ) and V(cos θ(u), D, λ) (J) on the grid D × u; +inf at the poles."""
    u, z = _coordinate_grid(coordinate, n)
    with np.errstate(divide="ignore", invalid="ignore"):
        Vs = potential.V(top, z[None, :], D[:, None], lam)
    return u, Vs


def _masked(Vs: np.ndarray, level: float) -> np.ma.MaskedArray:
    """V with every value above ``level`` (and the infinite poles) masked: left out, not clipped."""
    return np.ma.masked_where(~(Vs <= level), Vs)


def _trimmed_grid(
    top: TippeTop, lam: float, D: np.ndarray, coordinate: str, n: int, level: float
) -> tuple[np.ndarray, np.ndarray]:
    """Per D, n samples of u spanning exactly the part of the axis where V <= level.

    The ends of each row are the level crossings (bisection to machine precision, kept on the
    V <= level side), so the surface ends on the curve V = level instead of in a grid-sized
    staircase. Samples between them that still exceed the level (a hump between two wells) are
    masked. Returns U (n_D, n) and V (J, NaN where masked); rows without any V <= level are NaN.
    """
    u, Vs = _V_grid(top, lam, D, coordinate, max(4 * n, 801))
    below = Vs <= level
    has = np.asarray(below.any(axis=1))
    j0 = np.argmax(below, axis=1)
    j1 = below.shape[1] - 1 - np.argmax(below[:, ::-1], axis=1)

    def V_of(uu, dd):
        zz = uu if coordinate == "z" else np.clip(np.cos(uu), -1.0, 1.0)
        with np.errstate(divide="ignore", invalid="ignore"):
            return potential.V(top, zz, dd, lam)

    def crossing(inside, outside):
        # bisection between a sample with V <= level and its neighbour above it
        for _ in range(60):
            mid = 0.5 * (inside + outside)
            ok = V_of(mid, D) <= level
            inside, outside = np.where(ok, mid, inside), np.where(ok, outside, mid)
        return inside

    last = u.size - 1
    a = np.where(j0 > 0, crossing(u[j0], u[np.maximum(j0 - 1, 0)]), u[j0])
    b = np.where(j1 < last, crossing(u[j1], u[np.minimum(j1 + 1, last)]), u[j1])
    U = a[:, None] + (b - a)[:, None] * np.linspace(0.0, 1.0, n)[None, :]
    Vt = V_of(U, D[:, None])
    Vt = np.where((Vt <= level) & has[:, None], Vt, np.nan)
    U = np.where(has[:, None], U, np.nan)
    return U, Vt


def _D_range(top: TippeTop, lam: float, D_range) -> tuple[float, float]:
    if D_range is None:
        bv = thresholds.boundary_values(top, lam)
        return float(bv.D1), float(bv.D0)
    lo, hi = (_validate.finite_scalar("D_range", x) for x in D_range)
    if not lo < hi:
        raise ValueError(f"D_range must be (low, high) with low < high; got {D_range!r}")
    return lo, hi


def _level(top: TippeTop, lam: float, level: float | None) -> float:
    return default_level(top, lam) if level is None else _validate.finite_scalar("level", level)


# --- the potential -----------------------------------------------------------------------------


def plot_potential_surface(
    top: TippeTop,
    lam: float,
    *,
    D_range: tuple[float, float] | None = None,
    coordinate: str = "z",
    level: float | None = None,
    cmap: str | None = None,
    elev: float = 30.0,
    azim: float | None = None,
    n: int = 161,
    n_D: int = 81,
    colorbar: bool = True,
    minimum: bool = True,
    ax: Axes3D | None = None,
) -> Figure:
    """The surface V(cos θ, D, λ) over the poles' interval and D ∈ [D1, D0] (Rutstam 2012).

    At fixed λ the potential has one well; as D runs from D0 to D1 its floor travels from
    (z = 1, E0) to (z = −1, E1), the spinning states of :func:`mett.boundary_values`. Values above
    ``level`` are masked (left out, not clipped to a plateau), so the walls end where V passes it.

    Parameters
    ----------
    top : TippeTop
    lam : float
        Jellett integral λ (kg m³/s), > 0.
    D_range : (float, float), optional
        Range of the Routh integral D (kg m²/s); default [D1, D0].
    coordinate : {"z", "theta"}, default "z"
        Horizontal axis: z = cos θ ∈ [−1, 1], or θ ∈ [0, π] (rad). The title and labels follow.
    level : float, optional
        V (J) above which the surface is left out; default :func:`default_level`.
    cmap : str, optional
        Colour map of V (default ``image.cmap`` of rcParams); the colour bar spans
        [min V, level] and carries the same ticks (mJ) as the V axis.
    elev, azim : float
        View of the 3-D axes (degrees, as :meth:`mpl_toolkits.mplot3d.axes3d.Axes3D.view_init`).
        The default looks up the well from its low D1 end, 10° off its track in the box of the
        axes (azimuth −125° for z, −55° for θ, the mirror view): both walls, and the floor
        rising from E1 to E0 along the track.
    n, n_D : int
        Samples along the z (or θ) axis and along D.
    colorbar : bool, default True
        Draw a colour bar of V (mJ).
    minimum : bool, default True
        Draw the floor of the well, (z_min(D), D, V(z_min(D), D)) (:func:`mett.potential_minimum`),
        labelled "well minimum", over the surface.
    ax : Axes3D, optional
        A 3-D axes to draw into.

    Returns
    -------
    Figure
        Its 3-D axes holds the surface (a ``Poly3DCollection``; cells with a vertex above ``level``
        lose that vertex, cells with all four above it are dropped).
    """
    from .estimates import potential_minimum

    lam = _validate.positive_jellett(lam)
    coordinate = _coordinate(coordinate)
    D_lo, D_hi = _D_range(top, lam, D_range)
    level = _level(top, lam, level)
    D = np.linspace(D_lo, D_hi, n_D)
    U, Vt = _trimmed_grid(top, lam, D, coordinate, n, level)
    if not np.isfinite(Vt).any():
        raise ValueError(f"level = {level!r} J lies below V everywhere on the plotted range")
    DD = np.broadcast_to(D[:, None], U.shape)
    fig, ax = _axes3d(ax)
    vmin = float(np.nanmin(Vt)) * ENERGY_SCALE
    vmax = level * ENERGY_SCALE
    surf = ax.plot_surface(
        U, DD * D_SCALE, Vt * ENERGY_SCALE, rstride=1, cstride=1, cmap=_cmap_name(cmap),
        vmin=vmin, vmax=vmax, linewidth=0, antialiased=False,
    )  # fmt: skip
    if minimum:
        zmin = np.array([potential_minimum(top, float(d), lam) for d in D])
        vfloor = potential.V(top, zmin, D, lam) * ENERGY_SCALE
        track = zmin if coordinate == "z" else np.arccos(np.clip(zmin, -1.0, 1.0))
        keep = vfloor <= vmax
        # drawn last and above the surface (mplot3d sorts whole artists, not their parts)
        ax.plot(track[keep], D[keep] * D_SCALE, vfloor[keep], color="w", ls="--", lw=_lw(1.4),
                label="well minimum", zorder=5,
                path_effects=[patheffects.withStroke(linewidth=_lw(2.6), foreground="k")])  # fmt: skip
    u = _coordinate_grid(coordinate, 3)[0]
    ax.set_zlim(vmin, vmax)
    ax.set_xlim(u[0], u[-1])
    ax.set_ylim(D_lo * D_SCALE, D_hi * D_SCALE)
    if azim is None:
        azim = -125.0 if coordinate == "z" else -55.0
    ax.view_init(elev=elev, azim=azim)
    ax.set_xticks(np.linspace(-1.0, 1.0, 5) if coordinate == "z" else np.arange(0.0, 3.5, 0.5))
    ax.yaxis.set_major_locator(MaxNLocator(5))
    # one set of V ticks for the V axis and the colour bar, so a colour reads off as a height
    vticks = np.asarray(MaxNLocator(5).tick_values(vmin, vmax))
    vticks = vticks[(vticks >= vmin) & (vticks <= vmax)]
    ax.set_zticks(vticks)
    ax.set_xlabel(_COORDINATE_LABELS[coordinate])
    ax.set_ylabel(D_LABEL, labelpad=12)  # clear of the tick labels in the default views
    ax.set_zlabel(f"V [{ENERGY_UNIT}]", labelpad=6)
    if coordinate == "z":
        ax.set_title(rf"$V(\cos\theta, D, \lambda)$, {_lam_text(lam)}")
    else:
        ax.set_title(rf"$V$ against $\theta$ and $D$, {_lam_text(lam)}")
    if colorbar:
        cb = fig.colorbar(surf, ax=ax, shrink=0.6, pad=0.1, label=f"V [{ENERGY_UNIT}]")
        cb.set_ticks(vticks.tolist())
    return fig


_MAP_MARGIN = 0.04
"""Margin (fraction of each range) of the potential map around its data when a run is drawn."""


def plot_potential_map(
    top: TippeTop,
    lam: float,
    *,
    D: ArrayLike | None = None,
    coordinate: str = "z",
    trajectory: Trajectory | None = None,
    level: float | None = None,
    cmap: str | None = None,
    n: int = 241,
    n_levels: int = 25,
    minimum: bool = True,
    colorbar: bool = True,
    ax: Axes | None = None,
    prediction: InversionPrediction | None = None,
) -> Figure:
    """V(cos θ, D, λ) as a filled-contour map over (D, z), with the well's track and a run's path.

    The minimum of V(·, D, λ) sits at z_min(D) (:func:`mett.potential_minimum`); it moves from
    z = 1 at D0 to z = −1 at D1. A gliding top keeps λ and drifts from D0 towards D1 while z
    oscillates in the well (RR14 §3), so its path (D(t), cos θ(t)) follows the track.

    Parameters
    ----------
    top : TippeTop
    lam : float
        Jellett integral λ (kg m³/s), > 0.
    D : array_like, optional
        Increasing grid of the Routh integral D (kg m²/s). Default: 161 values over [D1, D0]
        (:func:`mett.boundary_values`), widened to the trajectory's D(t) if one is given.
    coordinate : {"z", "theta"}, default "z"
        Vertical axis: z = cos θ or θ (rad).
    trajectory : Trajectory, optional
        A simulated run with this λ; its (D(t), cos θ(t)) (or (D(t), θ(t))) is drawn on top.
    level : float, optional
        V (J) above which the map is left blank (masked); default :func:`default_level`.
    cmap : str, optional
        Colour map of V (default ``image.cmap`` of rcParams).
    n : int
        Samples along z (or θ).
    n_levels : int
        Number of filled-contour levels between min V and ``level``.
    minimum : bool, default True
        Draw the track z_min(D) of the well's minimum.
    colorbar : bool, default True
        Draw a colour bar of V (mJ).
    ax : Axes, optional
    prediction : InversionPrediction, optional
        A :func:`mett.predict_inversion` result with this λ: its slow path (D̄(t), cos θ̄(t)),
        from the theory alone, is drawn as the line "predicted slow path".

    Returns
    -------
    Figure
        Lines carry the labels "well minimum", "trajectory", "start", "end" and "predicted slow
        path" (data in the plotted units: D in 10⁻³ kg m²/s, z or θ in rad). With a trajectory
        the limits leave a margin of 4 % of each range around the map, so the start and end
        marks, which sit on its edges (the run starts and ends next to a pole), are drawn whole.
    """
    from .estimates import potential_minimum

    lam = _validate.positive_jellett(lam)
    coordinate = _coordinate(coordinate)
    level = _level(top, lam, level)
    if D is None:
        lo, hi = _D_range(top, lam, None)
        if trajectory is not None:
            lo, hi = min(lo, float(np.min(trajectory.D))), max(hi, float(np.max(trajectory.D)))
        Dg = np.linspace(lo, hi, 161)
    else:
        Dg = _validate.as_finite_array("D", D).ravel()
        if Dg.size < 2 or np.any(np.diff(Dg) <= 0):
            raise ValueError("D must be an increasing grid of at least 2 values (kg m²/s)")
    u, Vs = _V_grid(top, lam, Dg, coordinate, n)
    if not (Vs <= level).any():
        raise ValueError(f"level = {level!r} J lies below V everywhere on the plotted range")
    # Values above the top contour level are left unfilled (contourf draws no band above it),
    # which cuts the map along the smooth curve V = level; only the infinite poles are masked.
    data = np.ma.masked_invalid(Vs.T) * ENERGY_SCALE
    fig, ax = _axes(ax)
    vmin = float(np.min(Vs[np.isfinite(Vs)])) * ENERGY_SCALE
    levels = np.linspace(vmin, level * ENERGY_SCALE, n_levels)
    cs = ax.contourf(Dg * D_SCALE, u, data, levels=levels, cmap=_cmap_name(cmap), extend="neither")
    ax.contour(Dg * D_SCALE, u, data, levels=levels[::4], colors="w", linewidths=_lw(0.4),
               alpha=0.6)  # fmt: skip
    if minimum:
        zmin = np.array([potential_minimum(top, float(d), lam) for d in Dg])
        track = zmin if coordinate == "z" else np.arccos(np.clip(zmin, -1.0, 1.0))
        ax.plot(
            Dg * D_SCALE, track, color="w", ls="--", lw=_lw(1.4), label="well minimum",
            path_effects=[patheffects.withStroke(linewidth=_lw(2.6), foreground="k")],
        )  # fmt: skip
    if trajectory is not None:
        y = np.cos(trajectory.theta) if coordinate == "z" else np.asarray(trajectory.theta)
        x = np.asarray(trajectory.D) * D_SCALE
        ax.plot(x, y, color="C1", lw=_lw(0.8), label="trajectory")
        ax.plot([x[0]], [y[0]], "o", color="C1", mec="k", label="start")
        ax.plot([x[-1]], [y[-1]], "s", color="C1", mec="k", label="end")
    if prediction is not None and len(prediction.t):
        th = np.asarray(prediction.theta)
        y = np.cos(th) if coordinate == "z" else th
        # thinner than the run's nutation and outlined, so a trajectory drawn under it stays
        # visible on both sides of it
        ax.plot(np.asarray(prediction.D) * D_SCALE, y, color="C3", lw=_lw(1.2),
                label="predicted slow path", zorder=3,
                path_effects=[patheffects.withStroke(linewidth=_lw(2.4), foreground="w")])  # fmt: skip
    x0, x1, y0, y1 = Dg[0] * D_SCALE, Dg[-1] * D_SCALE, u[0], u[-1]
    if trajectory is not None:  # room for the marks on the edges
        px, py = _MAP_MARGIN * (x1 - x0), _MAP_MARGIN * (y1 - y0)
        x0, x1, y0, y1 = x0 - px, x1 + px, y0 - py, y1 + py
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_xlabel(D_LABEL)
    ax.set_ylabel(_COORDINATE_LABELS[coordinate])
    if coordinate == "z":
        ax.set_title(rf"$V(\cos\theta, D, \lambda)$, {_lam_text(lam)}")
    else:
        ax.set_title(rf"$V$ over $(D, \theta)$, {_lam_text(lam)}")
    if colorbar:
        fig.colorbar(cs, ax=ax, label=f"V [{ENERGY_UNIT}]", ticks=MaxNLocator(6))
    if minimum or trajectory is not None or prediction is not None:
        ax.legend(loc="best", fontsize="small", framealpha=0.85)
    return fig


def plot_potential(
    top: TippeTop,
    D: float,
    lam: float,
    *,
    E: float | None = None,
    color: str | None = None,
    label: str | None = None,
    ax: Axes | None = None,
) -> Figure:
    """V(z, D, λ) against z = cos θ (mJ); with the level Ẽ = E and its turning points if E is given.

    The view is zoomed on the well: with ``E`` the range shows the band between the turning
    points, without it the well from its floor up to the lower of the curve's values at the edges
    of the zoom. Several calls on one axes add curves: each takes the axes' next colour (or
    ``color``), is labelled by its D, and widens the limits; the title (λ) is set by the first.

    Parameters
    ----------
    top : TippeTop
    D, lam : float
        Routh integral D (kg m²/s) and Jellett integral λ (kg m³/s).
    E : float, optional
        Modified energy Ẽ (J) of a state; draws the level and the turning points.
    color : str, optional
        Colour of the curve (default: the axes' next colour).
    label : str, optional
        Legend entry of the curve (default "D = …").
    ax : Axes, optional
    """
    D = _validate.finite_scalar("D", D)
    lam = _validate.finite_scalar("lam", lam)
    fresh = ax is None or not ax.has_data()
    fig, ax = _axes(ax)
    z = np.linspace(-0.999, 0.999, 1201)
    v = potential.V(top, z, D, lam)
    if E is not None:
        E = _validate.finite_scalar("E", E)
        b = separation.band(top, E, D, lam)
        zm = b.z_min
    else:
        from .estimates import potential_minimum

        zm = potential_minimum(top, D, lam)
    vmin = float(potential.V(top, zm, D, lam))
    if E is not None and E > vmin:
        top_level = vmin + 4.0 * (E - vmin)
    else:
        # from the curve: the well up to 2 m g R α above its floor, or to the higher end of the
        # curve if the whole curve is shallower than that
        depth = 2.0 * top.m * top.g * top.R * top.alpha
        top_level = min(vmin + depth, float(max(v[0], v[-1])))
    span = top_level - vmin
    inside = z[v <= top_level]
    margin = 0.1 * (inside[-1] - inside[0]) + 1e-3 if inside.size else 0.0
    xlim = (
        (max(-1.0, inside[0] - margin), min(1.0, inside[-1] + margin)) if inside.size else (-1, 1)
    )
    ylim = ((vmin - 0.08 * span) * ENERGY_SCALE, (vmin + 1.05 * span) * ENERGY_SCALE)
    (curve,) = ax.plot(
        z, v * ENERGY_SCALE, color=color, label=label if label is not None else _D_text(D)
    )
    c = curve.get_color()
    if E is not None:
        ax.axhline(E * ENERGY_SCALE, color=c, ls="--", lw=_lw(0.9), label=r"$\tilde E$")
        if b.kind != "none":
            ax.plot([b.z_low, b.z_high], [E * ENERGY_SCALE] * 2, "o", color=c, mec="k",
                    label="turning points", clip_on=False)  # fmt: skip
    if fresh:
        ax.set_xlim(*xlim)
        ax.set_ylim(*ylim)
        ax.set_title(rf"$V(z, D, \lambda)$, {_lam_text(lam)}")
    else:  # widen to the union of the old and the new view
        (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
        ax.set_xlim(min(x0, xlim[0]), max(x1, xlim[1]))
        ax.set_ylim(min(y0, ylim[0]), max(y1, ylim[1]))
        if not ax.get_title():
            ax.set_title(rf"$V(z, D, \lambda)$, {_lam_text(lam)}")
    ax.set_xlabel(_COORDINATE_LABELS["z"])
    ax.set_ylabel(f"V [{ENERGY_UNIT}]")
    ax.legend(loc="best", fontsize="small")
    return fig


def plot_potential_slices(
    top: TippeTop,
    Ds: ArrayLike,
    lam: float,
    *,
    cmap: str | None = None,
    ax: Axes | None = None,
) -> Figure:
    """Several slices V(z, D, λ) at the Routh values ``Ds`` (kg m²/s), one colour each.

    Colours run along a sequential map (``cmap``, default ``image.cmap``, cut before its pale end) in the order of ``Ds``;
    each curve is labelled with its D. Built on :func:`plot_potential`.
    """
    Ds = _validate.as_finite_array("Ds", Ds).ravel()
    if Ds.size == 0:
        raise ValueError("Ds must hold at least one value of D (kg m²/s)")
    fig, ax = _axes(ax)
    lines = []
    for D, color in zip(Ds, _sequential_colors(Ds.size, cmap), strict=True):
        plot_potential(top, float(D), lam, color=color, ax=ax)
        lines.append(ax.lines[-1])
    # one view for all: every floor, and the walls of the highest well
    floors = [float(np.min(ln.get_ydata())) for ln in lines]
    lo = min(floors)
    depth = 2.0 * top.m * top.g * top.R * top.alpha * ENERGY_SCALE
    hi = max(floors) + max(depth, 0.3 * (max(floors) - lo))
    z_in = np.concatenate(
        [np.asarray(ln.get_xdata())[np.asarray(ln.get_ydata()) <= hi] for ln in lines]
    )
    pad = 0.03 * (z_in.max() - z_in.min()) + 1e-3
    ax.set_xlim(max(-1.0, z_in.min() - pad), min(1.0, z_in.max() + pad))
    ax.set_ylim(lo - 0.05 * (hi - lo), hi)
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize="small")
    return fig


def plot_f(top: TippeTop, E: float, D: float, lam: float, *, ax: Axes | None = None) -> Figure:
    """f(z) of the separation equation ż² = f(z), with its roots (the turning points) marked."""
    fig, ax = _axes(ax)
    b = separation.band(top, E, D, lam)
    if b.kind == "nutation":
        pad = 0.5 * (b.z_high - b.z_low)
        z = np.linspace(max(-1.0, b.z_low - pad), min(1.0, b.z_high + pad), 801)
    else:
        z = np.linspace(-1.0, 1.0, 801)
    ax.plot(z, separation.f(top, z, E, D, lam), color="C0", label="f(z)")
    ax.axhline(0.0, color="0.5", lw=_lw(0.8))
    if b.kind == "nutation":
        ax.plot([b.z_low, b.z_high], [0.0, 0.0], "o", color="C3", label="roots (turning points)")
    ax.set_xlabel("z = cos θ")
    ax.set_ylabel("f(z) = ż² [1/s²]")
    ax.set_title("separation equation ż² = f(z)")
    ax.legend(loc="best")
    return fig


# --- trajectories ----------------------------------------------------------------------------

SERIES: dict[str, tuple[str, str, float]] = {
    # name: (label, unit, scale applied before plotting)
    # mathtext labels: combining accents (θ̇) do not render in the default font
    "theta": (r"$\theta$", "rad", 1.0),
    "thetadot": (r"$\dot\theta$", "rad/s", 1.0),
    "phidot": (r"$\dot\varphi$", "rad/s", 1.0),
    "psidot": (r"$\dot\psi$", "rad/s", 1.0),
    "omega3": (r"$\omega_3$", "rad/s", 1.0),
    "nu_x": (r"$\nu_x$", "m/s", 1.0),
    "nu_y": (r"$\nu_y$", "m/s", 1.0),
    "gn": (r"$g_n$", "N", 1.0),
    "E": (r"$E$", ENERGY_UNIT, ENERGY_SCALE),
    "E_mod": (r"$\tilde E$", ENERGY_UNIT, ENERGY_SCALE),
    "D": (r"$D$", "10⁻³ kg m²/s", D_SCALE),
    "lam": (r"$\lambda$", "kg m³/s", 1.0),
    "x": ("x", "m", 1.0),
    "y": ("y", "m", 1.0),
}
"""Trajectory series :func:`plot_timeseries` knows: label, unit and plotting scale."""


def plot_timeseries(traj: Trajectory, *names: str, ax: Axes | None = None) -> Figure:
    """Series of a trajectory against time, e.g. ``plot_timeseries(traj, "nu_x", "nu_y")``.

    All series on one axes must share a unit. Names and units are listed in :data:`SERIES`.
    """
    unknown = [n for n in names if n not in SERIES]
    if unknown or not names:
        raise ValueError(f"unknown series {unknown}; known: {', '.join(SERIES)}")
    units = {SERIES[n][1] for n in names}
    if len(units) > 1:
        raise ValueError(f"series {names} have different units {sorted(units)}; plot them apart")
    fig, ax = _axes(ax)
    for n in names:
        label, unit, scale = SERIES[n]
        ax.plot(traj.t, np.asarray(getattr(traj, n)) * scale, label=label)
    ax.set_xlabel("t [s]")
    ax.set_ylabel(", ".join(SERIES[n][0] for n in names) + f" [{units.pop()}]")
    if len(names) > 1:
        ax.legend(loc="best")
    return fig


def plot_theta(traj: Trajectory, *, ax: Axes | None = None) -> Figure:
    """θ(t), with π/2 marked (thesis figure 4a)."""
    fig = plot_timeseries(traj, "theta", ax=ax)
    ax = ax or fig.axes[0]
    ax.axhline(np.pi / 2, color="0.6", lw=_lw(0.8), ls=":")
    ax.set_ylim(0, np.pi)
    return fig


def plot_angular_velocities(
    traj: Trajectory, *, ax: Axes | tuple[Axes, Axes] | None = None
) -> Figure:
    """ψ̇(t) and φ̇(t) (thesis figures 4b, 4c), each on its own y-axis.

    Each is singular where θ → 0 (only ω3 = ψ̇ + φ̇ cos θ stays finite) and the two are of
    opposite sign there, so one shared y-range would squash both. Each gets its own range, from
    its own 1st–99th percentiles padded by 30 %: the spikes near the pole pass are cut, not the
    data.

    Parameters
    ----------
    traj : Trajectory
    ax : Axes or pair of Axes, optional
        Two axes: ψ̇ is drawn in the first, φ̇ in the second. One axes: ψ̇ in it and φ̇ on a
        twin y-axis on its right (:meth:`~matplotlib.axes.Axes.twinx`). Default: a new figure
        with two panels, one above the other, sharing t.

    Returns
    -------
    Figure
    """
    twin = False
    if ax is None:
        w, h = plt.rcParams["figure.figsize"]
        fig, (a_psi, a_phi) = plt.subplots(
            2, 1, sharex=True, figsize=(w, 1.35 * h), layout="constrained"
        )
    elif isinstance(ax, (tuple, list, np.ndarray)):
        a_psi, a_phi = np.asarray(ax, dtype=object).ravel()
        fig = a_psi.figure
    else:
        fig, a_psi, a_phi, twin = cast("Figure", ax.figure), ax, ax.twinx(), True
    for a_, name, color in ((a_psi, "psidot", "C0"), (a_phi, "phidot", "C1")):
        label, unit, _ = SERIES[name]
        y = np.asarray(getattr(traj, name))
        a_.plot(traj.t, y, color=color, label=label)
        lo, hi = np.percentile(y, [1, 99])
        pad = 0.3 * (hi - lo) if hi > lo else 1.0
        a_.set_ylim(lo - pad, hi + pad)
        a_.set_ylabel(f"{label} [{unit}]")
        if twin:  # which axis is whose
            a_.yaxis.label.set_color(color)
    a_phi.set_xlabel("t [s]")
    if a_psi.get_shared_x_axes().joined(a_psi, a_phi) and not twin:
        a_psi.tick_params(labelbottom=False)
    else:
        a_psi.set_xlabel("t [s]")
    return fig


def plot_omega3(traj: Trajectory, *, ax: Axes | None = None) -> Figure:
    """ω₃(t) with its Jellett asymptote −λ/(R I3 (1 + α)) (thesis figure 5a; docs/theory/notes.md#notes)."""
    fig = plot_timeseries(traj, "omega3", ax=ax)
    ax = ax or fig.axes[0]
    top = traj.top
    lam = float(np.median(traj.lam))
    w_end = thresholds.pole_spins(top, lam)[1]
    ax.axhline(w_end, color="C3", ls="--", lw=_lw(0.8), label=f"−λ/(R I₃(1+α)) = {w_end:.3f} rad/s")
    ax.legend(loc="best")
    return fig


def plot_gliding_velocities(traj: Trajectory, *, ax: Axes | None = None) -> Figure:
    """ν_x(t) and ν_y(t), the gliding velocity of the contact point (thesis figure 5b)."""
    return plot_timeseries(traj, "nu_x", "nu_y", ax=ax)


def plot_energies(traj: Trajectory, *, ax: Axes | None = None) -> Figure:
    """E(t), which only decreases, and the modified energy Ẽ(t) of the METT, which need not."""
    return plot_timeseries(traj, "E", "E_mod", ax=ax)


def plot_thetadot(traj: Trajectory, *, ax: Axes | None = None) -> Figure:
    """θ̇(t): the oscillation of θ during the inversion (thesis figure 6b)."""
    return plot_timeseries(traj, "thetadot", ax=ax)


def plot_D_E_curve(traj: Trajectory, *, ax: Axes | None = None) -> Figure:
    """The curve (D(t), Ẽ(t)) with the spinning states (D0, E0) and (D1, E1) (thesis figure 6a)."""
    fig, ax = _axes(ax)
    lam = float(np.median(traj.lam))
    bv = thresholds.boundary_values(traj.top, lam)
    eS, dS = ENERGY_SCALE, D_SCALE
    ax.plot(traj.D * dS, traj.E_mod * eS, label="(D(t), Ẽ(t))")
    ax.plot([bv.D0 * dS], [bv.E0 * eS], "o", color="C2", label="(D0, E0): upright spin")
    ax.plot([bv.D1 * dS], [bv.E1 * eS], "s", color="C3", label="(D1, E1): inverted spin")
    ax.set_xlabel("D [10⁻³ kg m²/s]")
    ax.set_ylabel(f"Ẽ [{ENERGY_UNIT}]")
    ax.legend(loc="best")
    return fig


def plot_deforming_potential(
    traj: Trajectory, times: np.ndarray | None = None, *, ax: Axes | None = None
) -> Figure:
    """V(cos θ, D(t), λ) at several times, with θ(t) riding in it (dots at (θ(t), V)).

    The potential is drawn against θ; its well moves from θ ≈ 0 to θ ≈ π as D(t) goes from D0 to
    D1 (RR14 §3; docs/theory/estimates.md#estimates).
    """
    from . import analysis

    if times is None:
        # the start, the first passages of θ through a few levels (the inversion), the end
        passes = [traj.crossings(level) for level in (0.5, 1.0, np.pi / 2, 2.2, 2.8)]
        times = np.array([traj.t[0], *(c[0] for c in passes if c.size), traj.t[-1]])
    z, Vs, theta = analysis.deforming_potential(traj, times)
    fig, ax = _axes(ax)
    th = np.arccos(z)
    vmin = Vs.min() * ENERGY_SCALE
    s = traj.at(np.asarray(times))
    E_mod = np.atleast_1d(_modified_energy(traj, s))
    for i, (t, color) in enumerate(zip(times, _sequential_colors(len(times)), strict=True)):
        ax.plot(th, Vs[i] * ENERGY_SCALE, color=color, label=f"t = {t:.2f} s")
        v_dot = float(potential.V(traj.top, np.cos(theta[i]), *_DL(traj, s, i)))
        # clip_on=False: the last dot sits on the θ = π edge of the axes
        ax.plot(theta[i], v_dot * ENERGY_SCALE, "o", color=color, mec="k", mew=0.6,
                clip_on=False, zorder=3)  # fmt: skip
    top_level = max(E_mod.max() * ENERGY_SCALE, vmin)
    ax.set_ylim(vmin - 0.05 * (top_level - vmin), top_level + 0.6 * (top_level - vmin))
    ax.set_xlim(0, np.pi)
    ax.set_xlabel("θ [rad]")
    ax.set_ylabel(f"V(cos θ, D(t), λ) [{ENERGY_UNIT}]")
    ax.set_title("the deforming potential; dots: θ(t)")
    ax.legend(loc="center left", bbox_to_anchor=(1.01, 0.5), fontsize="small")
    return fig


def _modified_energy(traj, s):
    from .integrals import modified_energy

    return modified_energy(traj.top, s)


def _DL(traj, s, i):
    from .integrals import jellett, routh

    return float(np.atleast_1d(routh(traj.top, s))[i]), float(
        np.atleast_1d(jellett(traj.top, s))[i]
    )


def animate_deforming_potential(
    traj: Trajectory, path: str, *, frames: int = 80, fps: int = 15
) -> str:
    """Write a GIF (Pillow) of V(cos θ, D(t), λ) with θ(t) moving in it; returns the path."""
    from matplotlib.animation import FuncAnimation, PillowWriter

    from . import analysis

    times = np.linspace(traj.t[0], traj.t[-1], frames)
    z, Vs, theta = analysis.deforming_potential(traj, times)
    th = np.arccos(z)
    fig, ax = _axes(None)
    (curve,) = ax.plot(th, Vs[0] * ENERGY_SCALE, color="C0")
    (dot,) = ax.plot([], [], "o", color="C3", clip_on=False, zorder=3)
    s = traj.at(times)
    vdot = np.array(
        [float(potential.V(traj.top, np.cos(theta[i]), *_DL(traj, s, i))) for i in range(frames)]
    )
    lo = Vs.min() * ENERGY_SCALE
    hi = np.max(np.atleast_1d(_modified_energy(traj, s))) * ENERGY_SCALE
    ax.set_ylim(lo - 0.05 * (hi - lo), hi + 0.5 * (hi - lo))
    ax.set_xlim(0, np.pi)
    ax.set_xlabel("θ [rad]")
    ax.set_ylabel(f"V(cos θ, D(t), λ) [{ENERGY_UNIT}]")
    title = ax.set_title("")

    def update(i):
        curve.set_ydata(Vs[i] * ENERGY_SCALE)
        dot.set_data([theta[i]], [vdot[i] * ENERGY_SCALE])
        title.set_text(f"t = {times[i]:.2f} s")
        return curve, dot, title

    FuncAnimation(fig, update, frames=frames, blit=False).save(path, writer=PillowWriter(fps=fps))
    plt.close(fig)
    return path


def plot_axis_trace(traj: Trajectory, *, ax: Axes3D | None = None) -> Figure:
    """Trace of the symmetry axis 3̂(t) = (sin θ sin φ, −sin θ cos φ, cos θ) on the unit sphere."""
    fig, ax = _axes3d(ax)
    u, v = np.meshgrid(np.linspace(0, 2 * np.pi, 37), np.linspace(0, np.pi, 19))
    ax.plot_wireframe(
        np.cos(u) * np.sin(v), np.sin(u) * np.sin(v), np.cos(v), color="0.8", lw=_lw(0.3), alpha=0.4
    )
    st, sp, ct = np.sin(traj.theta), np.sin(traj.phi), np.cos(traj.theta)
    x, y, zz = st * sp, -st * np.cos(traj.phi), ct
    ax.plot(x, y, zz, lw=_lw(0.7), color="C1", label="axis 3̂(t)")
    ax.plot([x[0]], [y[0]], [zz[0]], "o", color="C2", label="start")
    ax.plot([x[-1]], [y[-1]], [zz[-1]], "s", color="C3", label="end")
    for axis in (ax.xaxis, ax.yaxis, ax.zaxis):  # three ticks each: the default ones overlap
        axis.set_ticks([-1.0, 0.0, 1.0])
    ax.set_xlabel("x")
    ax.set_ylabel("y")
    ax.set_zlabel("z")
    ax.set_box_aspect((1, 1, 1))
    ax.legend(loc="upper left")
    return fig


_KIND_STYLE = {
    "upright": ("o", "C0"),
    "tumbling": ("^", "C2"),
    "inverted": ("s", "C3"),
    "not settled": ("D", "C1"),
    "contact_lost": ("x", "k"),
    "failed": ("x", "0.5"),
    "invalid": ("x", "0.7"),
    "error": ("x", "C3"),
}


def _sweep_alpha(table) -> float | None:
    """α of every point of a sweep table: its ``alpha`` column if constant, else the base top's
    (``table.attrs["top"]``, written by :func:`mett.sweeps.sweep`) if α is not a column; None if
    α varies or is unknown."""
    if "alpha" in table:
        values = table["alpha"].unique()
        return float(values[0]) if len(values) == 1 else None
    top = table.attrs.get("top") if hasattr(table, "attrs") else None
    if isinstance(top, dict) and "alpha" in top:
        return float(top["alpha"])
    return None


def plot_phase_diagram(
    table, *, x: str = "lam_ratio", y: str = "gamma", alpha: float | None = None,
    ax: Axes | None = None,
) -> Figure:  # fmt: skip
    """End states of a sweep (:func:`mett.sweeps.sweep`) in the plane of two of its columns.

    Points are drawn by their simulated end state (upright / tumbling / inverted, "not settled"
    for runs too short to tell; contact loss and failures as crosses). In the (λ/λ_thres, γ) plane
    (either way round) the thresholds are drawn over them for the eccentricity α: λ = λ_thres is
    the line λ/λ_thres = 1 and λ = λ_0 the curve

        λ_0/λ_thres = ((1 − α)/(1 + α))² √((1 + α − γ)/(α + γ − 1)),   1 − α < γ < 1 + α

    (docs/theory/thresholds.md#thresholds); between them the top ends tumbling.

    Parameters
    ----------
    table : pandas.DataFrame
        A sweep's table; needs the columns ``x``, ``y`` and ``simulated``.
    x, y : str
        Columns on the horizontal and vertical axes.
    alpha : float, optional
        α of the thresholds. Default: the table's ``alpha`` column if it is constant, else the
        swept top's α, which :func:`mett.sweeps.sweep` keeps in ``table.attrs["top"]``; no
        threshold lines if α varies over the table or is unknown.
    ax : Axes, optional

    Returns
    -------
    Figure
        The threshold lines carry the labels "λ = λ₀" and "λ = λ_thres".
    """
    fig, ax = _axes(ax)
    for kind, (marker, color) in _KIND_STYLE.items():
        sel = table[table["simulated"] == kind]
        if len(sel):
            ax.scatter(sel[x], sel[y], marker=marker, color=color, label=kind, s=_ms(0.88) ** 2)
    axes_pair = {x, y} == {"lam_ratio", "gamma"}
    if axes_pair:
        if alpha is None:
            alpha = _sweep_alpha(table)
        else:
            alpha = _validate.finite_scalar("alpha", alpha)
        if alpha is not None and 0.0 < alpha < 1.0:
            g = np.linspace(1 - alpha, 1 + alpha, 402)[1:-1]
            ratio0 = ((1 - alpha) / (1 + alpha)) ** 2 * np.sqrt((1 + alpha - g) / (alpha + g - 1))
            lr_max = max(float(table["lam_ratio"].max()) * 1.1, 1.2)
            if x == "lam_ratio":
                ax.plot(ratio0, g, color="C0", lw=_lw(1.2), label="λ = λ₀")
                ax.axvline(1.0, color="C3", lw=_lw(1.2), label="λ = λ_thres")
                ax.set_xlim(0, lr_max)
            else:
                ax.plot(g, ratio0, color="C0", lw=_lw(1.2), label="λ = λ₀")
                ax.axhline(1.0, color="C3", lw=_lw(1.2), label="λ = λ_thres")
                ax.set_ylim(0, lr_max)
    labels = {"lam_ratio": "λ / λ_thres", "gamma": "γ = I1/I3"}
    ax.set_xlabel(labels.get(x, x))
    ax.set_ylabel(labels.get(y, y))
    ax.legend(loc="best", fontsize="small")
    return fig


# --- the classes of tops (mett.classification) -----------------------------------------------

_CLASS_COLORS = {
    "Ia": "#c6dbef",
    "Ib": "#6baed6",
    "IIa": "#fdd49e",
    "IIb": "#fc8d59",
    "IIc": "#d7301f",
    "III": "#a1d99b",
}

# boundary curves of the classes: field of SubgroupBoundaries, line style, legend entry
_BOUNDARY_STYLE = (
    ("group_I", "-", "γ = 1 ∓ α: groups I | II | III"),
    ("group_III", "-", None),
    ("IIa", "--", "S(1) = 0: lower edge of IIa"),
    ("IIc", ":", "S(−1) = 0: edges of Ia, IIc"),
    ("Ia", ":", None),
)


def _draw_classes(ax, alpha, gamma, n, labels, legend: bool) -> None:
    from matplotlib.colors import ListedColormap

    C = classification

    def centres(lo: float, hi: float) -> np.ndarray:
        edges = np.linspace(lo, hi, n + 1)
        return 0.5 * (edges[1:] + edges[:-1])

    A, G = np.meshgrid(centres(*alpha), centres(*gamma))
    names = C.classify(A, G)
    code = np.zeros(A.shape)
    for i, name in enumerate(C.SUBGROUPS):
        code[names == name] = i
    cmap = ListedColormap([_CLASS_COLORS[c] for c in C.SUBGROUPS])
    # rasterised: as vectors the n² cells would make a PDF or SVG of ~100 MB; the lines stay vectors
    ax.pcolormesh(A, G, code, cmap=cmap, vmin=-0.5, vmax=len(C.SUBGROUPS) - 0.5, shading="auto",
                  rasterized=True)  # fmt: skip
    a = np.linspace(max(alpha[0], 1e-4), alpha[1], 2000)
    b = C.subgroup_boundaries(a)
    for field, style, label in _BOUNDARY_STYLE:
        ax.plot(a, getattr(b, field), color="k", ls=style, lw=_lw(1.0),
                label=label if legend and label else "_nolegend_")  # fmt: skip
    ax.plot(a, b.spins_equal, color="0.25", lw=_lw(1.0), ls="-.",
            label="λ₀ = λ_thres" if legend else "_nolegend_")  # fmt: skip
    for name, (x, y) in labels.items():
        ax.text(x, y, name, ha="center", va="center", fontsize="medium", weight="bold")
    ax.set_xlim(*alpha)
    ax.set_ylim(*gamma)


def plot_subgroups(
    *,
    points: dict[str, tuple[float, float]] | None = None,
    samples: list[tuple[float, float]] | None = None,
    n: int = 500,
    ax: Axes | None = None,
) -> Figure:
    """The (α, γ) plane coloured by class (Ia … III, :mod:`mett.classification`), with its boundaries.

    Solid: γ = 1 ∓ α (groups I | II | III); dashed: lower edge of IIa (S(1) = 0); dotted: the
    S(−1) = 0 edges of the wedges Ia and IIc (α < 7 − 4√3, magnified in the inset); dash-dotted:
    λ_0 = λ_thres, below which (in group II) both spins are stable for λ_thres < λ < λ_0. The grey
    line γ = 1/2 is the rigid-body bound I3 <= 2 I1. One legend names the classes' colours, a
    second the lines and the marks.

    Parameters
    ----------
    points : dict, optional
        Labelled (α, γ) points to mark, e.g. the presets (legend entry "presets").
    samples : list of (float, float), optional
        (α, γ) of simulated sample points, drawn as triangles ("simulated samples").
    n : int
        Grid size per axis of the colour map.
    ax : Axes, optional

    Returns
    -------
    Figure
        The main axes first, its inset last.
    """
    n = _validate.positive_int("n", n)
    if ax is None:
        fig = _figure(1.2, 1.2)
        ax = fig.add_subplot()
    fig = cast("Figure", ax.figure)
    labels = {"Ib": (0.4, 0.56), "IIa": (0.32, 1.02), "IIb": (0.5, 0.62), "III": (0.15, 1.45)}
    _draw_classes(ax, (0.0, 0.6), (0.45, 1.7), n, labels, legend=True)
    ax.axhline(0.5, color="0.45", lw=_lw(0.8), label="γ = 1/2 (I3 = 2 I1)")
    mark: dict[str, Any] = dict(ls="none", marker="o", ms=_ms(0.67), mfc="white", mec="black")
    sample_mark: dict[str, Any] = dict(ls="none", marker="^", ms=_ms(0.83), color="black")
    for i, (name, (x, y)) in enumerate((points or {}).items()):
        ax.plot(x, y, **mark, label="presets" if i == 0 else "_nolegend_")
        ax.annotate(name, (x, y), xytext=(4, 2), textcoords="offset points", fontsize="x-small")
    if samples:
        sa, sg = np.asarray(samples, dtype=float).T
        ax.plot(sa, sg, **sample_mark, label="simulated samples")
    lines = fig.legend(
        *ax.get_legend_handles_labels(), loc="outside right lower", fontsize="small",
        title="lines and marks",
    )  # fmt: skip
    lines.set_label("lines and marks")
    handles = [
        plt.Rectangle((0, 0), 1, 1, color=_CLASS_COLORS[c]) for c in classification.SUBGROUPS
    ]
    classes = fig.legend(handles, classification.SUBGROUPS, loc="outside right upper",
                         fontsize="small", title="class")  # fmt: skip
    classes.set_label("class")
    ins = ax.inset_axes((0.56, 0.5, 0.42, 0.46))
    _draw_classes(ins, (0.0, 0.08), (0.88, 1.01), n, {"Ia": (0.012, 0.95), "IIc": (0.025, 0.983),
                                                        "IIb": (0.071, 0.966), "Ib": (0.06, 0.905),
                                                        "IIa": (0.02, 1.004)}, legend=False)  # fmt: skip
    for x, y in (points or {}).values():
        if x <= 0.08 and 0.88 <= y <= 1.01:
            ins.plot(x, y, **mark)
    for x, y in samples or ():
        if x <= 0.08 and 0.88 <= y <= 1.01:
            ins.plot(x, y, **sample_mark)
    ins.tick_params(labelsize="x-small")
    ins.set_title("α < 0.08", fontsize="small")
    ax.indicate_inset_zoom(ins, edgecolor="0.3")
    ax.set_xlabel("α (CM offset / R)")
    ax.set_ylabel("γ = I1/I3")
    ax.set_title("Classes of tippe tops by their steady states (gliding model)")
    return fig


def plot_tumbling_families(*, ax: ArrayLike | None = None) -> Figure:
    """Bifurcation diagrams of the six classes: the steady states in the (θ, λ) plane.

    One panel per class at its :data:`mett.classification.SAMPLE_POINTS` (α, γ): the tumbling
    family λ(θ_t), solid where stable (λ'(θ_t) > 0) and dashed where unstable, and the spins on
    the edges θ = 0 (stable for λ <= λ_0) and θ = π (stable for λ >= λ_thres). λ is in units of
    min(λ_0, λ_thres). A horizontal line λ = const meets the solid lines in the candidates of
    :func:`mett.asymptotic_state`.

    Parameters
    ----------
    ax : array of 6 Axes, optional
        One per class, in the order of :data:`mett.classification.SUBGROUPS`; a 2 × 3 array gets
        the axis labels on its outer edges. Default: a new figure with 2 × 3 panels.
    """
    import math

    from .thresholds import tumbling_domain, tumbling_lambda
    from .top import TippeTop

    if ax is None:
        w, h = plt.rcParams["figure.figsize"]
        fig, axes = plt.subplots(
            2, 3, figsize=(1.5 * w, 1.3 * h), layout="constrained", sharex=True
        )
    else:
        axes = np.asarray(ax, dtype=object)
        if axes.size != len(classification.SUBGROUPS):
            raise ValueError(f"ax must hold 6 axes (one per class); got {axes.size}")
        fig = axes.flat[0].figure
    grid = axes if axes.ndim == 2 else axes.reshape(1, -1)
    ymax = 3.0
    thick, thin = _lw(5.0), _lw(2.0)
    for a_, (name, (alpha, gamma)) in zip(
        axes.flat, classification.SAMPLE_POINTS.items(), strict=True
    ):
        top = TippeTop(m=0.02, R=0.02, alpha=alpha, I1=gamma * 3.2e-6, I3=3.2e-6)
        scale = min(top.lambda_0, top.lambda_thres)
        lo, hi = tumbling_domain(top)
        th = np.linspace(lo, hi, 3001)[1:-1]
        lam = tumbling_lambda(top, th) / scale
        stable = classification.tumbling_is_stable(top, th)
        a_.plot(th, np.where(stable, lam, np.nan), "C0-", lw=_lw(1.8), label="stable")
        a_.plot(th, np.where(stable, np.nan, lam), "C3--", lw=_lw(1.2), label="unstable")
        lam0, lamt = top.lambda_0 / scale, top.lambda_thres / scale
        a_.plot([0, 0], [0, min(lam0, ymax)], "C0-", lw=thick, solid_capstyle="butt")
        a_.plot([0, 0], [min(lam0, ymax), ymax], "C3-", lw=thin)
        a_.plot([math.pi, math.pi], [min(lamt, ymax), ymax], "C0-", lw=thick, solid_capstyle="butt")
        a_.plot([math.pi, math.pi], [0, min(lamt, ymax)], "C3-", lw=thin)
        a_.set_ylim(0, ymax)
        a_.set_xlim(-0.08, math.pi + 0.08)
        a_.set_title(f"{name}: α = {alpha:g}, γ = {gamma:g}", fontsize="medium")
        a_.tick_params(labelsize="small")
    for a_ in grid[-1]:
        a_.set_xlabel("θ (rad)")
    for a_ in grid[:, 0]:
        a_.set_ylabel("λ / min(λ₀, λ_thres)")
    axes.flat[0].legend(fontsize="x-small", loc="upper center")
    fig.suptitle("Steady states of the gliding top: tumbling family and spins (thick: stable)")
    return fig
