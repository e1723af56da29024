"""Figures of the METT and of simulated tops (matplotlib; imported lazily, never by ``import mett``).

Every function takes ``ax=None`` (a new figure is made when it is None) and returns the Figure; no
global style (rcParams) is changed. Angles are plotted in radians, energies in J (or mJ where said).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import matplotlib.pyplot as plt
import numpy as np

from . import potential, separation, thresholds

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from .dynamics import Trajectory
    from .top import TippeTop

__all__ = [
    "SERIES",
    "animate_deforming_potential",
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
    "plot_potential_surface",
    "plot_theta",
    "plot_thetadot",
    "plot_timeseries",
]


def _axes(ax: Axes | None, projection: str | None = None) -> tuple[Figure, Axes]:
    if ax is not None:
        return ax.figure, ax
    fig = plt.figure(figsize=(6.4, 4.4), layout="constrained")
    return fig, fig.add_subplot(projection=projection)


def plot_potential_surface(
    top: TippeTop,
    lam: float,
    *,
    D_range: tuple[float, float] | None = None,
    n_theta: int = 121,
    n_D: int = 61,
    ax: Axes | None = None,
) -> Figure:
    """The surface V(cos θ, D, λ) over θ ∈ (0, π) and D ∈ [D1, D0] (Rutstam 2012, the surface figure).

    Parameters
    ----------
    top : TippeTop
    lam : float
        Jellett integral λ (> 0).
    D_range : (float, float), optional
        Range of D; default [D1, D0], the boundary values of :func:`mett.boundary_values`.
    ax : Axes3D, optional
        A 3-D axes to draw into.
    """
    bv = thresholds.boundary_values(top, lam)
    D_lo, D_hi = D_range if D_range is not None else (float(bv.D1), float(bv.D0))
    theta = np.linspace(0.02, np.pi - 0.02, n_theta)
    D = np.linspace(D_lo, D_hi, n_D)
    TH, DD = np.meshgrid(theta, D)
    Vs = potential.V(top, np.cos(TH), DD, lam)
    # Clip the walls at the poles so the travelling well stays visible: the spinning states'
    # energies E0, E1 bound the bottom of the valley.
    cap = 1.5 * max(float(bv.E0), float(bv.E1))
    fig, ax = _axes(ax, projection="3d")
    ax.plot_surface(TH, DD * 1e3, np.minimum(Vs, cap) * 1e3, cmap="viridis", linewidth=0)
    ax.set_zlim(None, cap * 1e3)
    ax.set_xlabel("θ [rad]")
    ax.set_ylabel("D [10⁻³ kg m²/s]")
    ax.set_zlabel("V [mJ]")
    ax.set_title(f"V(cos θ, D, λ), λ = {lam:.4g} kg m³/s")
    return fig


def plot_potential(
    top: TippeTop,
    D: float,
    lam: float,
    *,
    E: float | None = None,
    ax: Axes | None = None,
) -> Figure:
    """V(z, D, λ) against z = cos θ, with the energy level and the turning points when E is given."""
    fig, ax = _axes(ax)
    z = np.linspace(-0.999, 0.999, 1201)
    v = potential.V(top, z, D, lam)
    zm = separation.band(top, 0.0, D, lam).z_min if E is None else None
    if E is not None:
        b = separation.band(top, E, D, lam)
        zm = b.z_min
    vmin = float(potential.V(top, zm, D, lam))
    top_level = E if E is not None else vmin
    span = max(top_level - vmin, 1e-12 * abs(vmin)) * 4 + 1e-9
    ax.plot(z, v, color="C0", label="V(z, D, λ)")
    ax.set_ylim(vmin - 0.1 * span, vmin + span)
    inside = z[v <= vmin + span]
    if inside.size:  # zoom on the well
        margin = 0.15 * (inside[-1] - inside[0]) + 1e-3
        ax.set_xlim(max(-1.0, inside[0] - margin), min(1.0, inside[-1] + margin))
    if E is not None:
        ax.axhline(E, color="C1", ls="--", label="Ẽ")
        if b.kind != "none":
            ax.plot([b.z_low, b.z_high], [E, E], "o", color="C3", label="turning points")
    ax.set_xlabel("z = cos θ")
    ax.set_ylabel("V [J]")
    ax.set_title(f"D = {D:.4g} kg m²/s, λ = {lam:.4g} kg m³/s")
    ax.legend(loc="best")
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
    ax.axhline(0.0, color="0.5", lw=0.8)
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
    "E": (r"$E$", "mJ", 1e3),
    "E_mod": (r"$\tilde E$", "mJ", 1e3),
    "D": (r"$D$", "10⁻³ kg m²/s", 1e3),
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
        ax.plot(traj.t, np.asarray(getattr(traj, n)) * scale, label=label, lw=1.0)
    ax.set_xlabel("t [s]")
    ax.set_ylabel(", ".join(SERIES[n][0] for n in names) + f" [{units.pop()}]")
    if len(names) > 1:
        ax.legend(loc="best")
    return fig


def plot_theta(traj: Trajectory, *, ax: Axes | None = None) -> Figure:
    """θ(t), with π/2 marked (thesis figure 4a)."""
    fig = plot_timeseries(traj, "theta", ax=ax)
    ax = ax or fig.axes[0]
    ax.axhline(np.pi / 2, color="0.6", lw=0.8, ls=":")
    ax.set_ylim(0, np.pi)
    return fig


def plot_angular_velocities(traj: Trajectory, *, ax: Axes | None = None) -> Figure:
    """ψ̇(t) and φ̇(t) (thesis figures 4b, 4c).

    Each is singular where θ → 0 (only ω3 = ψ̇ + φ̇ cos θ stays finite), so the y-range is set
    from the 1st–99th percentiles; the spikes near the pole pass are cut, not the data.
    """
    fig = plot_timeseries(traj, "psidot", "phidot", ax=ax)
    ax = ax or fig.axes[0]
    both = np.concatenate([traj.psidot, traj.phidot])
    lo, hi = np.percentile(both, [1, 99])
    pad = 0.3 * (hi - lo)
    ax.set_ylim(lo - pad, hi + pad)
    return fig


def plot_omega3(traj: Trajectory, *, ax: Axes | None = None) -> Figure:
    """ω₃(t) with its Jellett asymptote −λ/(R I3 (1 + α)) (thesis figure 5a; theory.md §12)."""
    fig = plot_timeseries(traj, "omega3", ax=ax)
    ax = ax or fig.axes[0]
    top = traj.top
    lam = float(np.median(traj.lam))
    w_end = thresholds.pole_spins(top, lam)[1]
    ax.axhline(w_end, color="C3", ls="--", lw=0.8, label=f"−λ/(R I₃(1+α)) = {w_end:.3f} rad/s")
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
    ax.plot(traj.D * 1e3, traj.E_mod * 1e3, lw=0.8, label="(D(t), Ẽ(t))")
    ax.plot([bv.D0 * 1e3], [bv.E0 * 1e3], "o", color="C2", label="(D0, E0): upright spin")
    ax.plot([bv.D1 * 1e3], [bv.E1 * 1e3], "s", color="C3", label="(D1, E1): inverted spin")
    ax.set_xlabel("D [10⁻³ kg m²/s]")
    ax.set_ylabel("Ẽ [mJ]")
    ax.legend(loc="best")
    return fig


def plot_deforming_potential(
    traj: Trajectory, times: np.ndarray | None = None, *, ax: Axes | None = None
) -> Figure:
    """V(cos θ, D(t), λ) at several times, with θ(t) riding in it (dots at (θ(t), V)).

    The potential is drawn against θ; its well moves from θ ≈ 0 to θ ≈ π as D(t) goes from D0 to
    D1 (RR14 §3; theory.md §8).
    """
    from . import analysis

    if times is None:
        # the start, the first passages of θ through a few levels (the inversion), the end
        passes = [traj.crossings(level) for level in (0.5, 1.0, np.pi / 2, 2.2, 2.8)]
        times = np.array([traj.t[0], *(c[0] for c in passes if c.size), traj.t[-1]])
    z, Vs, theta = analysis.deforming_potential(traj, times)
    fig, ax = _axes(ax)
    th = np.arccos(z)
    cmap = plt.get_cmap("viridis")
    vmin = Vs.min()
    s = traj.at(np.asarray(times))
    E_mod = np.atleast_1d(_modified_energy(traj, s))
    for i, t in enumerate(times):
        color = cmap(i / max(len(times) - 1, 1))
        ax.plot(th, Vs[i] * 1e3, color=color, lw=1.0, label=f"t = {t:.2f} s")
        ax.plot(theta[i], float(potential.V(traj.top, np.cos(theta[i]), *_DL(traj, s, i))) * 1e3,
                "o", color=color)  # fmt: skip
    top_level = max(E_mod.max(), vmin) * 1e3
    ax.set_ylim(
        vmin * 1e3 - 0.05 * (top_level - vmin * 1e3), top_level + 0.6 * (top_level - vmin * 1e3)
    )
    ax.set_xlim(0, np.pi)
    ax.set_xlabel("θ [rad]")
    ax.set_ylabel("V(cos θ, D(t), λ) [mJ]")
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
    (curve,) = ax.plot(th, Vs[0] * 1e3, color="C0")
    (dot,) = ax.plot([], [], "o", color="C3")
    s = traj.at(times)
    vdot = np.array(
        [float(potential.V(traj.top, np.cos(theta[i]), *_DL(traj, s, i))) for i in range(frames)]
    )
    lo, hi = Vs.min() * 1e3, np.max(np.atleast_1d(_modified_energy(traj, s))) * 1e3
    ax.set_ylim(lo - 0.05 * (hi - lo), hi + 0.5 * (hi - lo))
    ax.set_xlim(0, np.pi)
    ax.set_xlabel("θ [rad]")
    ax.set_ylabel("V [mJ]")
    title = ax.set_title("")

    def update(i):
        curve.set_ydata(Vs[i] * 1e3)
        dot.set_data([theta[i]], [vdot[i] * 1e3])
        title.set_text(f"t = {times[i]:.2f} s")
        return curve, dot, title

    FuncAnimation(fig, update, frames=frames, blit=False).save(path, writer=PillowWriter(fps=fps))
    plt.close(fig)
    return path


def plot_axis_trace(traj: Trajectory, *, ax: Axes | None = None) -> Figure:
    """Trace of the symmetry axis 3̂(t) = (sin θ sin φ, −sin θ cos φ, cos θ) on the unit sphere."""
    fig, ax = _axes(ax, projection="3d")
    u, v = np.meshgrid(np.linspace(0, 2 * np.pi, 37), np.linspace(0, np.pi, 19))
    ax.plot_wireframe(
        np.cos(u) * np.sin(v), np.sin(u) * np.sin(v), np.cos(v), color="0.8", lw=0.3, alpha=0.4
    )
    st, sp, ct = np.sin(traj.theta), np.sin(traj.phi), np.cos(traj.theta)
    x, y, zz = st * sp, -st * np.cos(traj.phi), ct
    ax.plot(x, y, zz, lw=0.7, color="C1", label="axis 3̂(t)")
    ax.plot([x[0]], [y[0]], [zz[0]], "o", color="C2", label="start")
    ax.plot([x[-1]], [y[-1]], [zz[-1]], "s", color="C3", label="end")
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
    "contact_lost": ("x", "k"),
    "failed": ("x", "0.5"),
    "invalid": ("x", "0.7"),
}


def plot_phase_diagram(
    table, *, x: str = "lam_ratio", y: str = "gamma", alpha: float | None = None,
    ax: Axes | None = None,
) -> Figure:  # fmt: skip
    """End states of a sweep (:func:`mett.sweeps.sweep`) in the plane of two of its columns.

    Points are drawn by their simulated end state (upright / tumbling / inverted; contact loss and
    failures as crosses). In the default (λ/λ_thres, γ) plane the thresholds are drawn over them for
    the eccentricity ``alpha`` (default: the sweep's, if it did not vary): λ = λ_thres is the line
    λ/λ_thres = 1 and λ = λ_0 the curve λ_0/λ_thres = ((1 − α)/(1 + α))² √((1 + α − γ)/(α + γ − 1))
    (theory.md §7); between them the top ends tumbling.
    """
    fig, ax = _axes(ax)
    for kind, (marker, color) in _KIND_STYLE.items():
        sel = table[table["simulated"] == kind]
        if len(sel):
            ax.scatter(sel[x], sel[y], marker=marker, color=color, label=kind, s=28)
    if x == "lam_ratio" and y == "gamma":
        if alpha is None and "alpha" in table and table["alpha"].nunique() == 1:
            alpha = float(table["alpha"].iloc[0])
        if alpha is not None:
            g = np.linspace(1 - alpha + 1e-3, 1 + alpha - 1e-3, 400)
            ratio0 = ((1 - alpha) / (1 + alpha)) ** 2 * np.sqrt((1 + alpha - g) / (alpha + g - 1))
            ax.plot(ratio0, g, color="C0", lw=1.2, label="λ = λ₀")
            ax.axvline(1.0, color="C3", lw=1.2, label="λ = λ_thres")
            ax.set_xlim(0, max(float(table[x].max()) * 1.1, 1.2))
        ax.set_xlabel("λ / λ_thres")
        ax.set_ylabel("γ = I1/I3")
    else:
        ax.set_xlabel(x)
        ax.set_ylabel(y)
    ax.legend(loc="best", fontsize="small")
    return fig
