"""Every published figure, regenerated: the thesis run (Rutstam 2013, figures 4–6), the V(cos θ, D)
surface (Rutstam 2012), the deforming potential and the separation equation.

``mett figures --out DIR`` (or :func:`generate`) writes them as PNG (and one GIF); the checked-in
copies live in ``figures/`` at the top of the repository.
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

__all__ = ["FIGURES", "generate"]

THESIS_LAMBDA = 6.8944e-6  # λ of the thesis run (theory.md §11), used for the surface figure


@dataclass
class _Context:
    """Runs shared by several figures, computed on first use."""

    cache: dict[str, Any] = field(default_factory=dict)

    @cached_property
    def thesis(self):
        import mett

        top = mett.presets.get("rutstam2013")
        return mett.simulate(top, mett.State(theta=0.1, omega3=155.0), t_end=9.0)

    @cached_property
    def rolling(self):
        import mett

        top = mett.presets.get("rutstam2013")
        s = mett.State(theta=1.0, omega3=100.0, phidot=5.0)
        return top, mett.energy(top, s), mett.routh(top, s), mett.jellett(top, s)


def _thesis(fn_name: str) -> Callable[[_Context], Any]:
    def make(ctx: _Context):
        from . import plotting

        return getattr(plotting, fn_name)(ctx.thesis)

    return make


def _surface(ctx: _Context):
    import mett

    from . import plotting

    return plotting.plot_potential_surface(mett.presets.get("rutstam2012"), THESIS_LAMBDA)


def _slice(ctx: _Context):
    from . import plotting

    top, E, D, lam = ctx.rolling
    return plotting.plot_potential(top, D, lam, E=E)


def _f(ctx: _Context):
    from . import plotting

    return plotting.plot_f(*ctx.rolling)


def _subgroups(ctx: _Context):
    import mett

    from .classification import SAMPLE_POINTS, plot_subgroups

    presets = {n: mett.presets.get(n) for n in ("rutstam2013", "cohen1977", "ueda2005")}
    points = {n: (t.alpha, t.gamma) for n, t in presets.items()}
    return plot_subgroups(points=points, samples=list(SAMPLE_POINTS.values()))


def _families(ctx: _Context):
    from .classification import plot_tumbling_families

    return plot_tumbling_families()


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
    "potential_slice": ("V(z) of a rolling top with Ẽ and the turning points", _slice),
    "separation_f": ("f(z) of ż² = f(z) with its roots", _f),
    "subgroups": ("the classes Ia–III of tops in the (α, γ) plane", _subgroups),
    "tumbling_families": (
        "steady states of each class in the (θ, λ) plane, stable and unstable",
        _families,
    ),
}
"""Name → (description, maker). Each maker returns a matplotlib Figure."""

ANIMATIONS = {"deforming_potential": "GIF of the deforming potential with θ(t) moving in it"}


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
    names: Iterable[str] | None = None,
    animation: bool = True,
    progress: bool = False,
    dpi: int = 110,
) -> list[Path]:
    """Write the figures (PNG) and the animation (GIF) into ``out_dir``; return the paths.

    Parameters
    ----------
    names : iterable of str, optional
        A subset of :data:`FIGURES` (default: all).
    animation : bool, default True
        Also write ``deforming_potential.gif`` (the slowest item, ~10 s).
    progress : bool, default False
        Show a progress bar on stderr (tqdm if installed).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from . import plotting

    names = list(FIGURES) if names is None else list(names)
    unknown = [n for n in names if n not in FIGURES]
    if unknown:
        raise ValueError(f"unknown figure(s) {unknown}; known: {', '.join(FIGURES)}")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    ctx = _Context()
    items = names + (["deforming_potential.gif"] if animation else [])
    written = []
    for name in _progress(items, progress):
        if name.endswith(".gif"):
            path = out / name
            plotting.animate_deforming_potential(ctx.thesis, str(path), frames=60, fps=12)
        else:
            fig = FIGURES[name][1](ctx)
            path = out / f"{name}.png"
            fig.savefig(path, dpi=dpi)
            plt.close(fig)
        written.append(path)
    return written


def index_markdown(paths: Iterable[Path]) -> str:
    """A Markdown gallery of the written figures (for ``figures/README.md`` and the docs)."""
    lines = ["# Figures", "", "Regenerate with `mett figures --out figures`.", ""]
    for p in paths:
        key = p.stem
        desc = FIGURES[key][0] if p.suffix == ".png" else ANIMATIONS.get(key, key)
        lines += [f"## {desc}", "", f"![{desc}]({p.name})", ""]
    return "\n".join(lines)
