"""Speed of mett.predict_inversion against the compiled simulation it replaces.

    python benchmarks/bench_inversion.py speed [repeat]   # default and fast options vs simulation, growth with ω3
    python benchmarks/bench_inversion.py speed-averaged   # the same for method="averaged"
    python benchmarks/bench_inversion.py first-call   # the first prediction of a process: cold, warm
    python benchmarks/bench_inversion.py atlas   # the atlas figure
    python benchmarks/bench_inversion.py contensou-check [out.jsonl]   # Coulomb–Contensou vs simulation
    python benchmarks/bench_inversion.py atlas-check   # Contensou atlas points vs simulation

The 72-case verification table is made by ``python tools/inversion_table.py``.
"""

from __future__ import annotations

import functools
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


# The options whose costs speed() compares: the defaults (the resolved start of a large tilt,
# the hop cycle after a predicted lift-off) and the fast ones (the linear split, the gliding
# flow throughout: bounded cost).
OPTIONS = {"default": {}, "fast": {"start": "linear", "hops": False}}


def speed(repeat: str = "30") -> None:
    """Prediction vs the compiled simulation to t_half, in one run, with the default and the fast
    options (``start="linear", hops=False``), as ω3 (155 to 2480 rad/s, doubling) and as the
    number of nutations (μ smaller: a slower inversion) grow.

    Best of ``repeat`` for a fast prediction, of 5 for a default one (a hopping prediction takes
    a tenth of a second or more) and of 3 for the simulation: the best of several is the cost
    without the other processes of a shared machine. The simulation (rtol 1e-9, flights and
    landings resolved where it hops) runs to the default prediction's t_half, the more accurate
    one; both t_half are printed.
    """
    import os

    n_fast = int(repeat)
    print(f"load average {os.getloadavg()[0]:.1f} at the start")
    print(
        "| μ (s/m) | ω3 (rad/s) | nutations to π/2 | t_half default / fast (s) "
        "| default (ms) | fast (ms) | compiled simulation (ms) | ratio default | ratio fast |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    cases = [(0.05, w) for w in (155.0, 310.0, 620.0, 1240.0, 2480.0)]
    for mu, omega3 in [*cases, (0.2, 155.0), (0.0125, 155.0)]:
        top = mett.presets.get("rutstam2013", mu=mu)
        state = mett.State.with_cm_at_rest(top, theta=0.1, omega3=omega3)
        p = {k: predict_inversion(top, state, **kw) for k, kw in OPTIONS.items()}
        mett.simulate(top, state, 0.01, backend="compiled")  # compile outside the timing
        tp = {}
        for k, kw in OPTIONS.items():
            call = functools.partial(predict_inversion, top, state, **kw)
            tp[k] = _best(call, 5 if k == "default" else n_fast)
        t_half = p["default"].t_half
        ts = _best(
            lambda top=top, state=state, t=t_half: mett.simulate(
                top, state, t, rtol=1e-9, backend="compiled"
            ),
            3,
        )
        n = t_half / (2 * math.pi * top.I1 / (top.I3 * omega3))
        print(
            f"| {mu:g} | {omega3:.0f} | {n:.0f} | {t_half:.2f} / {p['fast'].t_half:.2f} "
            f"| {1e3 * tp['default']:.1f} | {1e3 * tp['fast']:.1f} | {1e3 * ts:.1f} "
            f"| {tp['default'] / ts:.2g} | {tp['fast'] / ts:.2g} |",
            flush=True,
        )
    print(f"load average {os.getloadavg()[0]:.1f} at the end")


_FIRST_CALL = """
import time
t0 = time.perf_counter()
import mett
top = mett.presets.get("rutstam2013", mu=0.2)
state = mett.State.with_cm_at_rest(top, theta=0.1, omega3=155.0)
t1 = time.perf_counter()
mett.predict_inversion(top, state)
t2 = time.perf_counter()
mett.predict_inversion(top, state)
t3 = time.perf_counter()
print(f"{t1 - t0:.3f} {t2 - t1:.3f} {1e3 * (t3 - t2):.2f}")
"""


def first_call() -> None:
    """The first prediction of a fresh process: the compiled kernels of mett.inversion._compiled
    built from scratch (an empty numba cache directory: cold) and then loaded from it (warm),
    each in its own process."""
    import os
    import subprocess
    import tempfile

    print("| numba cache | import mett (s) | first prediction (s) | second (ms) |")
    print("|---|---|---|---|")
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache)
        for label in ("cold (empty)", "warm", "warm"):
            out = subprocess.run([sys.executable, "-c", _FIRST_CALL], env=env, check=True,
                                 capture_output=True, text=True).stdout.split()  # fmt: skip
            print(f"| {label} | {out[0]} | {out[1]} | {out[2]} |")


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


# The atlas figure's grids (thesis top, θ0 = 0.1, centre of mass at rest): μ per law, ω3 shared.
ATLAS_SPINS = (100.0, 1000.0, 19)
ATLAS_MU = {"viscous": (0.03, 3.0), "regularised-coulomb": (0.03, 1.0), "coulomb": (0.003, 1.0),
            "coulomb-contensou": (0.03, 1.0)}  # fmt: skip
ATLAS_RADII = (5e-4, 3e-3)  # m, the two Contensou panels (uniform pressure, r* = 2/3 r)


def atlas_figure() -> None:
    """docs/figures/inversion_atlas.png: predicted t_half over (μ, ω3) per law (thesis top), the
    undecided and non-inverting regions hatched, the line where exact Coulomb's slip stops, and
    μ·t_half. The predicted slow path beside a simulated run is the gallery's
    inversion_prediction (mett figures)."""
    import pathlib

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np
    from matplotlib.colors import LogNorm
    from matplotlib.patches import Patch
    from matplotlib.ticker import NullFormatter

    from mett.inversion import atlas

    top = mett.presets.get("rutstam2013")
    spins = np.geomspace(*ATLAS_SPINS)
    mus = {law: np.geomspace(lo, hi, 21) for law, (lo, hi) in ATLAS_MU.items()}
    panels = [("viscous", None), ("regularised-coulomb", None), ("coulomb", None),
              *(("coulomb-contensou", r) for r in ATLAS_RADII)]  # fmt: skip
    maps = {}
    for law, r in panels:
        kw = {} if r is None else {"contensou_radius": r}
        maps[law, r] = atlas(top, mus[law], spins, laws=(law,), **kw)[law]
    norm = LogNorm(0.1, 300.0)
    fig, axes = plt.subplots(2, 3, figsize=(15, 9), constrained_layout=True)
    flat = axes.ravel()
    for ax, (law, r) in zip(flat[:5], panels, strict=True):
        res, mu = maps[law, r], mus[law]
        T = np.where(res["inverts"] == 1, res["t_half"], np.nan)
        im = ax.pcolormesh(spins, mu, T, shading="nearest", cmap="viridis", norm=norm)
        for code, hatch, face in ((0, "//", "0.85"), (-1, "..", "0.55")):
            mask = res["inverts"] == code
            if mask.any():
                # the same cells as the map (no interpolated edge), hatched
                ax.pcolor(spins, mu, np.ma.masked_where(~mask, mask.astype(float)),
                          shading="nearest", cmap=matplotlib.colors.ListedColormap([face]),
                          hatch=hatch, edgecolor="0.35", linewidth=0.0)  # fmt: skip
        if law == "coulomb":
            # where exact Coulomb's initial slip stops (above: it rolls and never inverts)
            cs = ax.contour(spins, mu, (res["inverts"] == 0).astype(float), levels=[0.5],
                            colors="red", linewidths=2)  # fmt: skip
            ax.clabel(cs, fmt={0.5: "slip stops above"}, fontsize=9)
        unit = "s/m" if law == "viscous" else "1"
        title = {"viscous": "viscous", "regularised-coulomb": "regularised Coulomb (ε = 0.01 m/s)",
                 "coulomb": "exact Coulomb"}.get(law, f"Coulomb–Contensou, r = {1e3 * (r or 0):g} mm")  # fmt: skip
        ax.set(xscale="log", yscale="log", xlabel="ω3(0) [rad/s]", ylabel=f"μ [{unit}]", title=title,
               ylim=(mus["coulomb"][0] if law == "coulomb" else mu[0], mu[-1]))  # fmt: skip
        ax.xaxis.set_minor_formatter(NullFormatter())
    fig.colorbar(im, ax=flat[:5].tolist(), label="predicted t_half [s] (mean θ passes π/2)",
                 shrink=0.8, pad=0.01)  # fmt: skip
    legend = [Patch(facecolor="0.85", hatch="//", label="no inversion (sticks / falls back / spin consumed)"),
              Patch(facecolor="0.6", hatch="..", label="undecided (arrives with λ < λ_thres)"),
              plt.Line2D([], [], color="red", lw=2, label="exact Coulomb: slip stops above")]  # fmt: skip
    flat[2].legend(handles=legend, loc="upper right", fontsize=8, framealpha=0.9)
    ax = flat[5]
    for w in (155.0, 400.0, 1000.0):
        res = atlas(top, mus["viscous"], [w], laws=("viscous",))["viscous"]
        ax.plot(
            mus["viscous"], mus["viscous"] * res["t_half"][:, 0], label=f"viscous, ω3 = {w:.0f}"
        )
    ax.set(xscale="log", xlabel="μ [s/m viscous; 1 Contensou]", ylabel="viscous: μ · t_half [s²/m]",
           title="μ · t_half (ω3 = 400 rad/s for Contensou)", ylim=(0, None))  # fmt: skip
    twin = ax.twinx()
    j = int(np.argmin(abs(spins - 400.0)))
    for r, style in zip(ATLAS_RADII, ("--", ":"), strict=True):
        res = maps["coulomb-contensou", r]
        ok = res["inverts"][:, j] == 1
        twin.plot(mus["coulomb-contensou"][ok], (mus["coulomb-contensou"] * res["t_half"][:, j])[ok],
                  "k" + style, label=f"Contensou r = {1e3 * r:g} mm (right axis)")  # fmt: skip
    twin.set(ylabel="Contensou: μ · t_half [s]", ylim=(0, None))
    lines = ax.get_legend_handles_labels()
    more = twin.get_legend_handles_labels()
    ax.legend(lines[0] + more[0], lines[1] + more[1], fontsize=8, loc="lower left")
    fig.suptitle(
        "Predicted inversion over (μ, ω3): thesis top (rutstam2013), θ0 = 0.1, centre of mass at rest"
    )
    out = pathlib.Path(__file__).resolve().parents[1] / "docs" / "figures" / "inversion_atlas.png"
    fig.savefig(out, dpi=100)
    print(out.name)


def _simulated(top, state, law, t_end, tol=0.05, stop_on_contact_loss=True):
    """First simulated crossing of π/2 (s, inf if none), the largest θ, and the run's status
    (with the number of lift-offs before the crossing if the run goes on through flights)."""
    import numpy as np

    traj = mett.simulate(top, state, t_end, friction=law, rtol=1e-8, backend="compiled",
                         stop_on_contact_loss=stop_on_contact_loss)  # fmt: skip
    c = traj.crossings(0.5 * math.pi)
    t_cross = float(c[0]) if len(c) else math.inf
    status = traj.status
    if not stop_on_contact_loss:
        n = sum(1 for sw in traj.records.get("switches", [])
                if sw.reason == "lift-off" and sw.t <= t_cross)  # fmt: skip
        status = f"{status}, {n} hops before π/2" if n else status
    return t_cross, float(np.max(traj.theta)), status


def contensou_cases():
    """The Coulomb–Contensou check of docs/theory/inversion.md: 144 starts (preset, μ, ω3, r, θ0,
    centre of mass at rest)."""
    import itertools

    spin = {"rutstam2013": 155.0, "friedl1997": 180.0}
    return [
        (preset, mu, k * spin[preset], r, th0, cm)
        for preset, mu, k, r, th0, cm in itertools.product(
            spin, (0.15, 0.3, 0.5), (1.0, 1.6), (5e-4, 1.5e-3, 3e-3), (0.03, 0.1), (False, True)
        )
    ]


def contensou_check(out: str | None = None) -> None:
    """Each case of :func:`contensou_cases`: the prediction against the compiled simulation
    (rtol 1e-8, stopped where contact is lost), one JSON line a case."""
    import json

    from mett.friction import Coulomb

    sink = open(out, "w") if out else sys.stdout
    for preset, mu, w, r, th0, cm in contensou_cases():
        top = mett.presets.get(preset)
        st = (mett.State.with_cm_at_rest(top, theta=th0, omega3=w) if cm
              else mett.State(theta=th0, omega3=w))  # fmt: skip
        law = Coulomb(mu, contensou_radius=r)
        p = predict_inversion(top, st, law)
        t_end = 1.5 * (p.t_inv if math.isfinite(p.t_inv) else 2 * p.t_half)
        if not math.isfinite(t_end):
            t_end = 10.0
        t_sim, th_max, status = _simulated(top, st, law, t_end, p.tol)
        T_n = 2 * math.pi * top.I1 / (top.I3 * w)
        row = {"preset": preset, "mu": mu, "omega3": w, "r": r, "theta0": th0, "cm": cm,
               "inverts": p.inverts, "reason": p.reason, "t_half": p.t_half, "t_inv": p.t_inv,
               "eps": p.validity.epsilon, "lam_end": float(p.lam[-1] / top.lambda_thres)
               if len(p.lam) else None, "theta_end": float(p.theta[-1]) if len(p.theta) else None,
               "t_sim": t_sim, "theta_max": th_max, "status": status, "T_n": T_n}  # fmt: skip
        print(json.dumps(row), file=sink, flush=True)


def atlas_check() -> None:
    """Coulomb–Contensou points of the atlas figure against the compiled simulation (θ0 = 0.1,
    centre of mass at rest, rtol 1e-8, through flight and landing): a markdown table."""

    from mett.friction import Coulomb
    from mett.inversion import atlas

    top = mett.presets.get("rutstam2013")
    mus, spins = [0.1, 0.3, 1.0], [155.0, 400.0, 1000.0]
    print(
        "| r (mm) | μ | ω3 (rad/s) | predicted | t_half pred (s) | simulated t_half (s) | error | max θ simulated | run |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for r in ATLAS_RADII:
        res = atlas(top, mus, spins, laws=("coulomb-contensou",), contensou_radius=r)
        res = res["coulomb-contensou"]
        for i, mu in enumerate(mus):
            for j, w in enumerate(spins):
                st = mett.State.with_cm_at_rest(top, theta=0.1, omega3=w)
                t_pred = float(res["t_half"][i, j])
                code = {1: "inverts", 0: "no", -1: "undecided"}[int(res["inverts"][i, j])]
                t_end = 1.5 * float(res["t_inv"][i, j]) if code == "inverts" else (
                    2.0 * t_pred if math.isfinite(t_pred) else 20.0)  # fmt: skip
                t_sim, th_max, status = _simulated(
                    top, st, Coulomb(mu, contensou_radius=r), t_end, stop_on_contact_loss=False
                )
                err = (t_pred - t_sim) / t_sim if math.isfinite(t_sim * t_pred) else math.nan
                print(f"| {1e3 * r:g} | {mu:g} | {w:.0f} | {code} | {t_pred:.3f} | {t_sim:.3f} | "
                      f"{100 * err:+.1f} % | {th_max:.2f} | {status} |")  # fmt: skip


if __name__ == "__main__":
    {
        "speed": speed,
        "speed-averaged": speed_averaged,
        "first-call": first_call,
        "atlas": atlas_figure,
        "contensou-check": contensou_check,
        "atlas-check": atlas_check,
    }[sys.argv[1] if len(sys.argv) > 1 else "speed"](*sys.argv[2:])
