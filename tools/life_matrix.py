"""Long lives of real tops under every friction law: a stress matrix of mett.simulate.

    python tools/life_matrix.py                      # the full matrix (288 runs), printed as a table
    python tools/life_matrix.py --jsonl runs.jsonl   # ... and one JSON line per run (appended as it goes)
    python tools/life_matrix.py --tops friedl --laws contensou --theta0 0.1 --spins 1.5

Tops: friedl1997 with its stem (Friedl 1997 as used by Leine & Glocker 2003), the thesis body
(Rutstam 2013) with a stem r_s = 4 mm, l_s = 26 mm, the thesis ball top, cohen1977 (Cohen 1977).
Laws: viscous μ = 0.3 s/m, Coulomb(0.3), Coulomb-Contensou(0.3, r = 0.5 mm), RegularisedCoulomb(0.3,
ε = 1e-2 m/s). Starts: θ0 ∈ {0.05, 0.1, 0.5} rad, ω3 = {1.5, 5, 20} × the smallest spin that inverts
the ball top from θ0 (mett.thresholds.min_spin_for_inversion), the centre of mass at rest or the
contact point at rest. Each run goes to ``--t-end`` (8 s) on the default backend; a run whose CPU
time exceeds ``--cpu-limit`` is stopped (a SIGPROF timer raising at the compiled loops' signal
poll) and reported as "STALL".

Recorded per run: status, message, the switches by reason, CPU time, the final contact, the
number of flights, the largest rise of the energy between samples (relative to the start's
energy scale) and the smallest normal force. One process, one run at a time: the machine is shared.
"""

from __future__ import annotations

import argparse
import collections
import json
import math
import signal
import sys
import time
import warnings

import numpy as np

import mett
from mett.friction import Coulomb, RegularisedCoulomb, Viscous
from mett.stem import StemmedTop
from mett.thresholds import min_spin_for_inversion

THETA0 = (0.05, 0.1, 0.5)
SPIN_FACTORS = (1.5, 5.0, 20.0)
STARTS = ("cm", "nu0")


def tops() -> dict[str, mett.TippeTop | StemmedTop]:
    """The four bodies, by short name."""
    return {
        "friedl": mett.presets.stemmed("friedl1997"),
        "thesis-stem": mett.presets.get("rutstam2013").with_stem(radius=0.004, distance=0.026),
        "thesis": mett.presets.get("rutstam2013"),
        "cohen": mett.presets.get("cohen1977"),
    }


def laws() -> dict[str, object]:
    """The four friction laws, by short name."""
    return {
        "viscous": Viscous(0.3),
        "coulomb": Coulomb(0.3),
        "contensou": Coulomb(0.3, contensou_radius=5e-4),
        "regularised": RegularisedCoulomb(0.3, eps=1e-2),
    }


class Stall(Exception):
    """The run used more CPU than the limit."""


def _on_prof(signum, frame):
    raise Stall


def ball_of(top):
    return top.ball if isinstance(top, StemmedTop) else top


def start_state(top, theta0: float, omega3: float, start: str) -> mett.State:
    if start == "cm":
        return mett.State.with_cm_at_rest(ball_of(top), theta=theta0, omega3=omega3)
    return mett.State(theta=theta0, omega3=omega3)


def energy_scale(traj) -> float:
    E = np.asarray(traj.E, dtype=float)
    return float(np.nanmax(np.abs(E))) if E.size else 1.0


def penetration(top, traj) -> float:
    """The deepest penetration of a sphere into the table over the samples, relative to the
    ball's radius (0 if none): the other sphere's clearance on one contact, the gap in flight."""
    if not isinstance(top, StemmedTop) or getattr(traj, "contact", None) is None:
        gap = getattr(traj, "gap", None)
        return float(max(0.0, -np.min(gap))) / ball_of(top).R if gap is not None else 0.0
    R, r_s, l_s = top.ball.R, top.radius, top.distance
    c = np.cos(np.asarray(traj.theta, dtype=float))
    contact = np.asarray(traj.contact)
    clear = np.where(contact == "ball", R + l_s * c - r_s, np.inf)
    clear = np.where(contact == "stem", r_s - l_s * c - R, clear)
    gap = getattr(traj, "gap", None)
    if gap is not None:
        clear = np.where(contact == "none", np.asarray(gap, dtype=float), clear)
    return float(max(0.0, -np.min(clear))) / R


def one_run(top, law, theta0, omega3, start, t_end, cpu_limit) -> dict:
    """Run one case and summarise it (never raises for a failing run)."""
    state = start_state(top, theta0, omega3, start)
    row: dict = {}
    signal.signal(signal.SIGPROF, _on_prof)
    if math.isfinite(cpu_limit):
        signal.setitimer(signal.ITIMER_PROF, cpu_limit)
    c0 = time.process_time()
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            traj = mett.simulate(top, state, t_end=t_end, friction=law)
    except Stall:
        signal.setitimer(signal.ITIMER_PROF, 0)
        row.update(status="STALL", message=f"stopped after {cpu_limit:g} s of CPU")
        row["cpu"] = time.process_time() - c0
        return row
    except (ValueError, TypeError) as exc:
        signal.setitimer(signal.ITIMER_PROF, 0)
        row.update(status="refused", message=str(exc)[:200], cpu=time.process_time() - c0)
        return row
    finally:
        signal.setitimer(signal.ITIMER_PROF, 0)
    row["cpu"] = time.process_time() - c0
    row["status"] = traj.status
    row["message"] = (traj.message or "")[:300]
    row["model"] = traj.model
    row["t_last"] = float(traj.t[-1])
    sw = getattr(traj, "switches", None) or []
    row["switches"] = dict(collections.Counter(s.reason for s in sw))
    contact = getattr(traj, "contact", None)
    row["contact"] = str(contact[-1]) if contact is not None and len(contact) else "ball"
    phase = getattr(traj, "phase", None)
    row["phase"] = str(phase[-1]) if phase is not None and len(phase) else ""
    row["theta_end"] = float(traj.theta[-1])
    row["omega3_end"] = float(traj.omega3[-1])
    E = np.asarray(traj.E, dtype=float)
    scale = energy_scale(traj)
    row["dE_max"] = float(np.nanmax(np.diff(E)) / scale) if E.size > 1 else 0.0
    # the normal force of the contact sample (0 in flight); in the double contact both of them
    gn = np.asarray(traj.gn, dtype=float)
    mins = [float(np.nanmin(gn))] if gn.size else []
    if contact is not None and getattr(traj, "gn_ball", None) is not None:
        both = np.asarray(contact) == "both"
        if both.any():
            mins += [float(np.min(np.asarray(traj.gn_ball)[both])),
                     float(np.min(np.asarray(traj.gn_stem)[both]))]  # fmt: skip
    row["gn_min"] = min(mins) / (ball_of(top).m * ball_of(top).g) if mins else math.nan
    row["pen"] = penetration(top, traj)
    row["warnings"] = sorted({type(w.message).__name__ for w in caught})
    return row


def fmt_switches(sw: dict) -> str:
    return " ".join(f"{k}:{v}" for k, v in sorted(sw.items())) if sw else "-"


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--tops", nargs="*", default=list(tops()))
    p.add_argument("--laws", nargs="*", default=list(laws()))
    p.add_argument("--theta0", nargs="*", type=float, default=list(THETA0))
    p.add_argument("--spins", nargs="*", type=float, default=list(SPIN_FACTORS))
    p.add_argument("--starts", nargs="*", default=list(STARTS), choices=STARTS)
    p.add_argument("--t-end", type=float, default=8.0)
    p.add_argument("--cpu-limit", type=float, default=120.0)
    p.add_argument("--jsonl", default=None)
    args = p.parse_args(argv)
    all_tops, all_laws = tops(), laws()
    out = open(args.jsonl, "a", encoding="utf-8") if args.jsonl else None
    head = (
        f"{'top':12} {'law':11} {'θ0':>5} {'ω3':>7} {'start':5} {'status':12} {'CPU s':>7} "
        f"{'t_last':>7} {'end':5} {'dE/E':>9} {'gn/mg':>9} {'pen/R':>8}  switches | message"
    )
    for tname in args.tops:  # compile or load every model's kernels outside the CPU limit
        for lname in args.laws:
            top = all_tops[tname]
            w3 = min_spin_for_inversion(ball_of(top), 0.1)  # a life through every phase kind
            one_run(top, all_laws[lname], 0.1, 1.5 * w3, "cm", args.t_end, math.inf)
            one_run(top, all_laws[lname], 0.1, 5.0 * w3, "cm", 0.5, math.inf)  # and hops
    print(head, flush=True)
    for tname in args.tops:
        top = all_tops[tname]
        for lname in args.laws:
            law = all_laws[lname]
            for th in args.theta0:
                w_min = min_spin_for_inversion(ball_of(top), th)
                for f in args.spins:
                    w3 = round(f * w_min, 1)
                    for start in args.starts:
                        row = one_run(top, law, th, w3, start, args.t_end, args.cpu_limit)
                        row.update(top=tname, law=lname, theta0=th, omega3=w3, factor=f,
                                   start=start, t_end=args.t_end)  # fmt: skip
                        if out is not None:
                            out.write(json.dumps(row) + "\n")
                            out.flush()
                        print(
                            f"{tname:12} {lname:11} {th:5.2f} {w3:7.1f} {start:5} "
                            f"{row['status']:12} {row['cpu']:7.2f} {row.get('t_last', math.nan):7.3f} "
                            f"{row.get('contact', ''):5} {row.get('dE_max', math.nan):9.1e} "
                            f"{row.get('gn_min', math.nan):9.1e} {row.get('pen', math.nan):8.1e}  "
                            f"{fmt_switches(row.get('switches', {}))} | {row.get('message', '')[:120]}"
                            f"{' ' + ','.join(row['warnings']) if row.get('warnings') else ''}",
                            flush=True,
                        )
    if out is not None:
        out.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
