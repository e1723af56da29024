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

    from .top import TippeTop

__all__ = ["plot_f", "plot_potential", "plot_potential_surface"]


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
