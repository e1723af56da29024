"""The verification table and figure of mett.predict_inversion against simulations with flight.

    python tools/inversion_table.py                 # run the 72 cases, print the table
    python tools/inversion_table.py --write         # ... and write it into docs/theory/inversion.md
    python tools/inversion_table.py --cache F.json  # keep the runs in F.json (reused if present)
    python tools/inversion_table.py --figure        # ... and draw docs/figures/inversion_verification.png

Each case (mett.inversion._cases.cases: 60 viscous and regularised-Coulomb cases, then 12
Coulomb–Contensou ones) is predicted by both reductions and simulated with flight
and landing to twice the later finite prediction (at most 60 s): the reference is the first
crossing of θ = π/2, in contact or in flight (mett.inversion._cases.reference). The error of a
prediction is |Δt_half| less one nutation period (the phase of θ within the band), relative to
the simulated crossing.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import pathlib
import statistics

from mett.inversion import predict_inversion
from mett.inversion._cases import cases, reference

ROOT = pathlib.Path(__file__).resolve().parents[1]
METHODS = ("gyroscopic", "averaged")
T_CAP = 60.0


def run(cache: pathlib.Path | None = None) -> list[dict]:
    """One row per case: the case's parameters, both predictions and the simulated reference.

    ``cache`` keeps the simulated references (by case name and end time); the predictions are
    always recomputed.
    """
    done = {}
    if cache is not None and cache.exists():
        done = json.loads(cache.read_text(encoding="utf-8"))
    rows = []
    for c in cases():
        preds = {m: predict_inversion(c.top, c.state, c.friction, method=m) for m in METHODS}
        finite = [p.t_half for p in preds.values() if math.isfinite(p.t_half)]
        t_end = min(2.0 * max(finite), T_CAP) if finite else 20.0
        ref = done.get(c.name)
        if ref is None or not _covers(ref, t_end):
            ref = dataclasses.asdict(reference(c, t_end))
            done[c.name] = ref
            if cache is not None:
                cache.write_text(json.dumps(done, indent=1), encoding="utf-8")
        at_rest = float(c.state.nu_x) == 0.0 and float(c.state.nu_y) == 0.0
        g = preds["gyroscopic"]
        rows.append({
            "name": c.name,
            "law": _law_label(c),
            "start": "ν=0" if at_rest else "CM at rest",
            "ratio": g.validity.spin_ratio,
            "theta0": float(c.state.theta),
            "mu": c.top.mu if c.law == "viscous" else c.friction.mu,
            "ref": ref,
            "pred": {
                m: {"t_half": p.t_half, "inverts": p.inverts, "epsilon": p.validity.epsilon,
                    "outside": p.validity.outside_verified_range, "notes": list(p.validity.notes),
                    "t_lift": p.t_lift}
                for m, p in preds.items()
            },
        })  # fmt: skip
    return rows


def _law_label(case) -> str:
    """The law's name; for Coulomb–Contensou with the radius r of its contact disc (the column
    μ gives the friction coefficient, ε the reduction's T_n/t_half, for every law)."""
    if case.law == "coulomb-contensou":
        return f"coulomb-contensou, r = {1e3 * case.friction.contensou_radius:.2g} mm"
    return case.law


def _covers(ref: dict, t_end: float) -> bool:
    """Whether a kept reference answers a run to ``t_end``: one to the same end, or one that
    crossed π/2 by ``t_end`` (the first crossing and what happened before it, the hops and the
    time in the air, are those of any run that goes past it)."""
    return ref["t_end"] == t_end or (math.isfinite(ref["t_half"]) and ref["t_half"] <= t_end)


def _lift_rows(rows: list[dict]):
    """(row, gyroscopic prediction, reference) of the cases the lift-off criterion is judged on:
    a reference that got far enough, and a t_lift that was evaluated."""
    for r in rows:
        p = r["pred"]["gyroscopic"]
        if _kind(r) != "none" and not math.isnan(p["t_lift"]):
            yield r, p, r["ref"]


def _kind(row: dict) -> str:
    """How the case enters: "contact" / "hops" (a crossing, before/after a lift-off), "late" (no
    crossing by twice every finite prediction: their t_half is wrong by more than half), or
    "none" (no reference: the run failed or was cut at T_CAP first)."""
    ref = row["ref"]
    if math.isfinite(ref["t_half"]):
        return "contact" if ref["hops"] == 0 else "hops"
    finite = [p["t_half"] for p in row["pred"].values() if math.isfinite(p["t_half"])]
    if ref["status"] == "completed" and all(2.0 * t <= ref["t_end"] * (1 + 1e-12) for t in finite):
        return "late"
    return "none"


def error(row: dict, method: str) -> float:
    """(|Δt_half| − T_n)⁺ / t_sim; inf where the simulated top had not crossed by 2 t_half."""
    ref, p = row["ref"], row["pred"][method]
    if not math.isfinite(p["t_half"]):
        return math.nan
    if not math.isfinite(ref["t_half"]):
        return math.inf if _kind(row) == "late" else math.nan
    return max(abs(p["t_half"] - ref["t_half"]) - ref["T_n"], 0.0) / ref["t_half"]


def _status(row: dict) -> str:
    ref, kind = row["ref"], _kind(row)
    if kind == "contact":
        return "in contact"
    if kind == "hops":
        where = "in flight" if ref["in_flight"] else "in contact"
        art = ", artefact" if ref["artefact"] > 1.0 else ""
        return f"{ref['hops']} hops{art}; crosses {where}"
    if kind == "late":
        return f"no crossing by {ref['t_end']:.3g} s ({ref['hops']} hops)"
    if ref["status"] == "failed":
        return f"failed at t = {_failed_at(ref):.3g} s: no reference"
    return f"run cut at {ref['t_end']:.3g} s: no reference"


def _failed_at(ref: dict) -> float:
    # "... at t = X s ..." in the message; the end of the run otherwise
    import re

    m = re.search(r"t = ([0-9.eE+-]+)", ref["message"])
    return float(m.group(1)) if m else math.nan


def _fmt_err(e: float) -> str:
    if math.isnan(e):
        return ""
    return "> 50%" if math.isinf(e) else f"{e:.1%}"


def _fmt_t(t: float | None) -> str:
    if t is None or math.isinf(t):
        return "–"
    return "" if math.isnan(t) else f"{t:.3g}"


def lift_offs(rows: list[dict]) -> dict:
    """The lift-off criterion (gyroscopic ``t_lift`` before its ``t_half``) against the simulated
    lift-offs before the first crossing of π/2 (before the end of the run without one).

    Counts over the cases with a simulation that got that far (a crossing, or a completed run):
    ``hit`` (predicted and simulated), ``quiet`` (neither), ``false`` (predicted, not simulated),
    ``miss`` (simulated, not predicted); each also for the cases inside the validity range
    before the criterion, i.e. whose only flag is the hop. ``dt`` lists |t_lift − t_sim|/t_sim
    of the hits; ``artefact`` the hits and misses whose simulated lift-off is the viscous law's
    artefact (μ|v_A| > 1)."""
    out: dict = {k: [] for k in ("hit", "quiet", "false", "miss", "dt", "artefact")}
    for r, p, ref in _lift_rows(rows):
        pred = p["t_lift"] < p["t_half"]
        sim = ref["hops"] > 0
        key = {(True, True): "hit", (False, False): "quiet", (True, False): "false",
               (False, True): "miss"}[(pred, sim)]  # fmt: skip
        out[key].append(r["name"])
        if key == "hit":
            out["dt"].append(abs(p["t_lift"] - ref["t_contact_lost"]) / ref["t_contact_lost"])
        if sim and ref["artefact"] > 1.0:
            out["artefact"].append(r["name"])
    return out


def _only_hop_flag(row: dict) -> bool:
    notes = row["pred"]["gyroscopic"]["notes"]
    return bool(notes) and all(n.startswith("predicted to hop") for n in notes)


def summary(rows: list[dict], method: str, inside: bool) -> dict:
    """Counts and t_half errors of ``method`` within (``inside``) or outside its validity flag."""
    sel = [r for r in rows if r["pred"][method]["outside"] != inside]
    kinds = [_kind(r) for r in sel]
    crossing = [r for r, k in zip(sel, kinds, strict=True) if k in ("contact", "hops")]
    errs = [error(r, method) for r in sel if _kind(r) in ("contact", "hops", "late")]
    errs = [e for e in errs if not math.isnan(e)]
    return {
        "cases": len(sel),
        "crossings": len(crossing),
        "hopping": sum(k == "hops" for k in kinds),
        "late": sum(k == "late" for k in kinds),
        "no_reference": sum(k == "none" for k in kinds),
        "inverts_right": sum(r["pred"][method]["inverts"] is True for r in crossing),
        "errors": errs,
        "median": statistics.median(errs) if errs else math.nan,
        "worst": max(errs) if errs else math.nan,
    }


def table(rows: list[dict]) -> str:
    out = [
        "| case | law | start | λ/λ_thres | θ0 | μ | ε | t_half gyroscopic (s) | averaged (s) "
        "| sim (s) | error gyr. | error avg. | lift-off pred. / sim. (s) | simulation |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        g, a = r["pred"]["gyroscopic"], r["pred"]["averaged"]
        mark = "" if g["outside"] else " **(valid)**"
        out.append(
            f"| {r['name']}{mark} | {r['law']} | {r['start']} | {r['ratio']:.1f} | {r['theta0']:.3f} "
            f"| {r['mu']:.3g} | {g['epsilon']:.3g} | {g['t_half']:.3f} | {a['t_half']:.3f} "
            f"| {r['ref']['t_half']:.3f} | {_fmt_err(error(r, 'gyroscopic'))} "
            f"| {_fmt_err(error(r, 'averaged'))} | {_fmt_lift(r)} | {_status(r)} |"
        )
    out.append("")
    for m in METHODS:
        for inside in (True, False):
            s = summary(rows, m, inside)
            if not s["cases"]:
                out.append(f"{m}, {'within' if inside else 'outside'} its validity range: no case")
                continue
            line = (
                f"{m}, {'within' if inside else 'outside'} its validity range: {s['cases']} cases, "
                f"{s['crossings']} simulated crossings ({s['hopping']} after hops), `inverts` right in "
                f"{s['inverts_right']} of {s['crossings']}; {s['late']} without a crossing by twice "
                f"the prediction, {s['no_reference']} without a reference"
            )
            finite = [e for e in s["errors"] if math.isfinite(e)]
            if finite:
                line += (
                    f"; t_half error over the {len(finite)} crossings: median "
                    f"{_fmt_err(statistics.median(finite))}, worst {_fmt_err(max(finite))}"
                )
            for kind, label in (("contact", "in contact"), ("hops", "after hops")):
                e = [error(r, m) for r in rows if r["pred"][m]["outside"] != inside
                     and _kind(r) == kind and math.isfinite(r["pred"][m]["t_half"])]  # fmt: skip
                if e:
                    line += (f"; {label}: {len(e)}, median {_fmt_err(statistics.median(e))}, "
                             f"worst {_fmt_err(max(e))}")  # fmt: skip
            out.append(line)
    lo = lift_offs(rows)
    n = sum(len(lo[k]) for k in ("hit", "quiet", "false", "miss"))
    line = (
        f"lift-off before pi/2 (gyroscopic t_lift < t_half) against the simulation, {n} cases: "
        f"{len(lo['hit'])} predicted and simulated, {len(lo['quiet'])} neither, "
        f"{len(lo['false'])} false alarms ({', '.join(lo['false']) or 'none'}), {len(lo['miss'])} "
        f"missed ({', '.join(lo['miss']) or 'none'})"
    )
    if lo["dt"]:
        line += (f"; |t_lift - simulated first lift-off| over the hits: median "
                 f"{_fmt_err(statistics.median(lo['dt']))}, worst {_fmt_err(max(lo['dt']))}")  # fmt: skip
    if lo["artefact"]:
        line += f"; viscous artefact (mu |v_A| > 1) at the simulated lift-off: {', '.join(lo['artefact'])}"
    out.append(line)
    only = [r for r in rows if _only_hop_flag(r)]
    if only:
        out.append(
            "flagged by the lift-off criterion alone: "
            + ", ".join(f"{r['name']} ({_status(r)})" for r in only)
        )
    return "\n".join(out) + "\n"


def _fmt_lift(row: dict) -> str:
    """Predicted t_lift (if before t_half) / simulated first lift-off (if before the crossing)."""
    p, ref = row["pred"]["gyroscopic"], row["ref"]
    pred = p["t_lift"] if p["t_lift"] < p["t_half"] else math.inf
    sim = ref["t_contact_lost"] if ref["hops"] > 0 else math.inf
    return f"{_fmt_t(pred)} / {_fmt_t(sim)}"


def write_docs(text: str) -> None:
    page = ROOT / "docs" / "theory" / "inversion.md"
    doc = page.read_text(encoding="utf-8")
    start, end = "<!-- table:start -->\n", "<!-- table:end -->"
    i, j = doc.index(start) + len(start), doc.index(end)
    page.write_text(doc[:i] + text + doc[j:], encoding="utf-8")


def figure(rows: list[dict]) -> pathlib.Path:
    """Predicted against simulated t_half, per method: filled inside the validity range."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(16, 4.8), constrained_layout=True)
    colours = {"contact": "tab:blue", "hops": "tab:orange", "artefact": "tab:red"}
    axes[1].sharey(axes[0])
    for ax, m in zip(axes, METHODS, strict=False):
        lo, hi = 0.1, 200.0
        for r in rows:
            kind = _kind(r)
            p = r["pred"][m]
            if kind not in ("contact", "hops", "late") or not math.isfinite(p["t_half"]):
                continue
            key = (
                "artefact"
                if r["ref"]["artefact"] > 1.0
                else ("hops" if kind != "contact" else "contact")
            )
            ts = r["ref"]["t_half"] if kind != "late" else r["ref"]["t_end"]
            face = colours[key] if not p["outside"] else "none"
            marker = "^" if kind == "late" else "o"
            ax.scatter(p["t_half"], ts, s=36, marker=marker, facecolors=face,
                       edgecolors=colours[key], linewidths=1.2)  # fmt: skip
        ax.plot([lo, hi], [lo, hi], "k-", lw=0.8)
        for f in (0.9, 1.1):
            ax.plot([lo, hi], [lo / f, hi / f], "k:", lw=0.6)
        ax.set(xscale="log", yscale="log", xlim=(lo, hi), ylim=(lo, hi),
               xlabel=f"predicted t_half, {m} (s)", title=f"method {m!r}")  # fmt: skip
    axes[0].set_ylabel("simulated first crossing of π/2 (s)")
    from matplotlib.lines import Line2D

    handles = [
        Line2D([], [], ls="", marker="o", color=colours["contact"], label="stays in contact"),
        Line2D([], [], ls="", marker="o", color=colours["hops"], label="hops before crossing"),
        Line2D([], [], ls="", marker="o", color=colours["artefact"], label="hops, viscous artefact (μ|v_A| > 1)"),
        Line2D([], [], ls="", marker="^", color="grey", label="no crossing by 2 t_half (at t_end)"),
        Line2D([], [], ls="", marker="o", mfc="grey", color="grey", label="filled: within validity range"),
        Line2D([], [], ls="", marker="o", mfc="none", color="grey", label="open: flagged outside"),
    ]  # fmt: skip
    axes[1].legend(handles=handles, loc="upper left", fontsize=8)
    # the lift-off criterion: predicted t_lift against the simulated first lift-off, where both
    # come before π/2 (hits); misses and false alarms on the frame's edges
    ax = axes[2]
    lo, hi = 0.01, 200.0
    for r, p, ref in _lift_rows(rows):
        pred = p["t_lift"] if p["t_lift"] < p["t_half"] else math.inf
        sim = ref["t_contact_lost"] if ref["hops"] > 0 else math.inf
        if math.isinf(pred) and math.isinf(sim):
            continue
        key = "artefact" if ref["artefact"] > 1.0 else "hops"
        x = min(max(pred, lo), hi) if math.isfinite(pred) else hi
        y = min(max(sim, lo), hi) if math.isfinite(sim) else hi
        face = colours[key] if not p["outside"] or _only_hop_flag(r) else "none"
        ax.scatter(x, y, s=36, marker="o" if math.isfinite(pred) and math.isfinite(sim) else "s",
                   facecolors=face, edgecolors=colours[key], linewidths=1.2, clip_on=False)  # fmt: skip
    ax.plot([lo, hi], [lo, hi], "k-", lw=0.8)
    for f in (0.9, 1.1):
        ax.plot([lo, hi], [lo / f, hi / f], "k:", lw=0.6)
    ax.set(xscale="log", yscale="log", xlim=(lo, hi), ylim=(lo, hi),
           xlabel="predicted lift-off t_lift (s; right edge: none before π/2)",
           ylabel="simulated first lift-off (s; top edge: none before π/2)",
           title="lift-off criterion (gyroscopic)")  # fmt: skip
    ax.legend(handles=[
        Line2D([], [], ls="", marker="o", color="grey", label="both before π/2"),
        Line2D([], [], ls="", marker="s", color="grey", label="false alarm / miss (edge)"),
        Line2D([], [], ls="", marker="o", mfc="grey", color="grey",
               label="filled: no other flag than the hop"),
        Line2D([], [], ls="", marker="o", color=colours["artefact"], label="viscous artefact"),
    ], loc="upper left", fontsize=8)  # fmt: skip
    out = ROOT / "docs" / "figures" / "inversion_verification.png"
    fig.savefig(out, dpi=100)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--write", action="store_true", help="write the table into the docs page")
    ap.add_argument("--figure", action="store_true", help="draw the figure")
    ap.add_argument("--cache", type=pathlib.Path, help="JSON file keeping the runs")
    args = ap.parse_args()
    rows = run(args.cache)
    text = table(rows)
    print(text)
    if args.write:
        write_docs(text)
    if args.figure:
        print(figure(rows))


if __name__ == "__main__":
    main()
