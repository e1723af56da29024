"""Speed of mett.predict_inversion against the compiled simulation it replaces.

    python benchmarks/bench_inversion.py speed   # prediction vs simulation cost, growth with ω3
    python benchmarks/bench_inversion.py speed-averaged   # the same for method="averaged"
    python benchmarks/bench_inversion.py atlas   # the atlas figure

The 60-case verification table is made by ``python tools/inversion_table.py``.
"""

from __future__ import annotations

import math
import sys
import time

import mett
from mett.inversion import predict_inversion


def _best(fn, repeat: int = 3) -> float:
    best = math.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def speed() -> None:
    """Prediction vs the compiled simulation to t_half, in one run (best of 30 and of 5: the
    best of many is the cost without the other processes of a shared machine), as ω3 and as the
    number of nutations (μ smaller: a slower inversion) grow."""
    print(
        "| μ (s/m) | ω3 (rad/s) | nutations to π/2 | prediction (ms) | compiled simulation (ms) | ratio |"
    )
    print("|---|---|---|---|---|---|")
    for mu, omega3 in ((0.05, 155.0), (0.05, 310.0), (0.05, 620.0), (0.2, 155.0), (0.0125, 155.0)):
        top = mett.presets.get("rutstam2013", mu=mu)
        state = mett.State.with_cm_at_rest(top, theta=0.1, omega3=omega3)
        p = predict_inversion(top, state)
        mett.simulate(top, state, 0.01, backend="compiled")  # compile outside the timing
        tp = _best(lambda top=top, state=state: predict_inversion(top, state), 30)
        ts = _best(
            lambda top=top, state=state, p=p: mett.simulate(
                top, state, p.t_half, rtol=1e-9, backend="compiled"
            ),
            5,
        )
        n = p.t_half / (2 * math.pi * top.I1 / (top.I3 * omega3))
        print(
            f"| {mu:g} | {omega3:.0f} | {n:.0f} | {1e3 * tp:.1f} | {1e3 * ts:.1f} | {tp / ts:.3f} |"
        )


def speed_averaged() -> None:
    """The averaged method's cost (one run each: it takes seconds) against the same simulation."""
    print("| μ (s/m) | ω3 (rad/s) | averaged prediction (ms) | compiled simulation (ms) | ratio |")
    print("|---|---|---|---|---|")
    for mu, omega3 in ((0.05, 155.0), (0.2, 155.0)):
        top = mett.presets.get("rutstam2013", mu=mu)
        state = mett.State.with_cm_at_rest(top, theta=0.1, omega3=omega3)
        p = predict_inversion(top, state)
        mett.simulate(top, state, 0.01, backend="compiled")
        tp = _best(lambda top=top, state=state: predict_inversion(top, state, method="averaged"), 1)
        ts = _best(
            lambda top=top, state=state, p=p: mett.simulate(
                top, state, p.t_half, rtol=1e-9, backend="compiled"
            )
        )
        print(f"| {mu:g} | {omega3:.0f} | {1e3 * tp:.0f} | {1e3 * ts:.1f} | {tp / ts:.0f} |")


def atlas_figure() -> None:
    """docs/figures/inversion_atlas.png (predicted t_half over (μ, ω3) per law, thesis top). The
    predicted slow path beside a simulated run is the gallery's inversion_prediction (mett figures)."""
    import pathlib

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from mett.inversion import atlas

    top = mett.presets.get("rutstam2013")
    spins = np.geomspace(100.0, 1000.0, 19)
    grids = {"viscous": np.geomspace(0.03, 3.0, 21), "regularised-coulomb": np.geomspace(0.03, 1.0, 21),
             "coulomb": np.geomspace(0.03, 1.0, 21)}  # fmt: skip
    fig, axes = plt.subplots(1, 4, figsize=(17, 4.2), constrained_layout=True)
    for ax, (law, mus) in zip(axes[:3], grids.items(), strict=True):
        res = atlas(top, mus, spins, laws=(law,))[law]
        T = np.where(res["inverts"] == 1, res["t_half"], np.nan)
        if np.isfinite(T).any():
            im = ax.pcolormesh(spins, mus, np.log10(T), shading="nearest", cmap="viridis")
            fig.colorbar(im, ax=ax, label="log10 t_half [s]")
        stick = res["inverts"] == 0
        if stick.any():
            ax.contourf(spins, mus, stick.astype(float), levels=[0.5, 1.5], colors="none",
                        hatches=["//"])  # fmt: skip
            ax.text(0.5, 0.5, "contact sticks:\nrolls, no inversion", transform=ax.transAxes,
                    ha="center", va="center", fontsize=11,
                    bbox={"facecolor": "white", "alpha": 0.8})  # fmt: skip
        unit = "s/m" if law == "viscous" else "1"
        ax.set(xscale="log", yscale="log", xlabel="ω3(0) [rad/s]", ylabel=f"μ [{unit}]",
               title=law + (" (ε = 0.01 m/s)" if law.startswith("reg") else ""))  # fmt: skip
    from matplotlib.ticker import NullFormatter

    for a in axes[:3]:
        a.xaxis.set_minor_formatter(NullFormatter())
    ax = axes[3]
    for w in (155.0, 400.0, 1000.0):
        res = atlas(top, grids["viscous"], [w], laws=("viscous",))["viscous"]
        ax.plot(grids["viscous"], grids["viscous"] * res["t_half"][:, 0], label=f"ω3 = {w:.0f}")
    ax.set(xscale="log", xlabel="μ [s/m]", ylabel="μ · t_half [s²/m]",
           title="viscous law: μ · t_half", ylim=(0, None))  # fmt: skip
    ax.legend()
    out = pathlib.Path(__file__).resolve().parents[1] / "docs" / "figures" / "inversion_atlas.png"
    fig.savefig(out, dpi=110)
    print(out.name)


if __name__ == "__main__":
    {"speed": speed, "speed-averaged": speed_averaged, "atlas": atlas_figure}[
        sys.argv[1] if len(sys.argv) > 1 else "speed"
    ]()
