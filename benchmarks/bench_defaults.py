"""Benchmark: what a user gets without options, against heyoka, side by side in one run.

Every mett call here is the default one (no ``backend`` option: ``backend="auto"`` picks the
backend, which ``Trajectory.backend`` reports); heyoka 7 (a Taylor integrator compiled with
LLVM, the optional ``bench`` extra) integrates the very same equations (the gliding model's
``rhs_into`` traced with heyoka's variables, as in ``bench_taylor.py``) with the same contact
event that the default run watches.

1. The thesis run (rutstam2013, θ0 = 0.1, ω3 = 155 rad/s, 8 s), ``mett.simulate(top, start,
   t_end=8, rtol=tol)`` at tol 1e-10 and 1e-12, the whole call, against heyoka's
   ``taylor_adaptive`` with dense output (needed for the crossing) at *matched accuracy*: the
   error of the first θ = π/2 time against its converged value (5.879749518045809 s, DOP853 and
   Taylor at 1e-14, tests/test_taylor.py) is measured for both, and heyoka's tolerance is the
   loosest of a scan (tol · 10^(k/2), k = 2 … −4) whose error is no larger than mett's. That
   choice favours heyoka (a loose tolerance that lands close by luck counts), so a ratio below 1
   is not an artefact of the matching. heyoka at mett's own tolerance is printed too.
2. ``mett.sweep(top, {"mu": 64 values}, t_end=4, rtol=1e-12)`` (serial, one core) against
   heyoka's batch mode doing the same sweep as a user would write it
   (``bench_taylor.heyoka_sweep``: 4 lanes, the contact event, the crossing as a non-terminal
   event, end values, a table; less work than mett.sweep, which also tests whether the run
   settled and predicts the end state). Runs per second and their ratio.
3. Growth at rtol 1e-10: ω3 = 155, 1 550, 15 500 rad/s over 2 s (θ0 = 0.1; all three stay in
   contact over 2 s. Over 8 s the ω3 = 1 550 run loses contact after ~4.5 s and hops hundreds
   of times, which is the flight code's cost, not the integrator's), and t_end = 2, 8, 32 s at
   ω3 = 155 rad/s; both codes at the same tolerance, with the steps each took.

Times are CPU times of this thread (``time.thread_time``), the best of several calls, with
Python's garbage collector held off during each call; the calls of mett and heyoka alternate
(:func:`alternating_best`); every section is repeated ``--rounds`` times, and the ratios are
printed per round and as a range (on a shared machine the absolute times move with the load, the
ratios much less). Targets of the issue:
default trajectory <= 0.8x heyoka's time, default sweep >= 1.2x heyoka's throughput per core.

Run ``python benchmarks/bench_defaults.py [--rounds N] [--quick] [--sections 2]
[--sweep-calls N]`` (``--sections``: which of the sections above, e.g. ``2`` for the sweep
alone; ``--sweep-calls``: calls of each side per round of section 2); it prints and asserts
nothing.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np

import mett
from mett.dynamics import MODELS

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_taylor import T_HALF, alternating_best, heyoka_sweep, heyoka_system, t_half


def _setup(omega3: float = 155.0):
    top = mett.presets.get("rutstam2013")
    start = mett.State(theta=0.1, omega3=omega3)
    mdl = MODELS["gliding"]
    p = np.array(mdl.params(top, {}))
    y0 = np.asarray(mdl.initial(start, tuple(p)))
    return top, start, mdl, p, y0


def heyoka_run(mdl, p, y0, tol: float):
    """heyoka's adaptive integrator of the gliding model with the contact-loss event (terminal,
    as the default mett run stops its contact phase there): ``run(t_end)`` integrates from the
    start with dense output and returns (outcome, dense output (t ↦ state), steps)."""
    import heyoka as hy

    y = hy.make_vars(*[f"y{i}" for i in range(10)])
    contact = mdl.events[0].fn(0.0, list(y), tuple(p))  # g_n/(m g), traced
    ta = hy.taylor_adaptive(
        heyoka_system(mdl, p), y0, tol=tol,
        t_events=[hy.t_event(contact, direction=hy.event_direction.negative)],
    )  # fmt: skip

    def run(t_end: float):
        ta.time = 0.0
        ta.state[:] = y0
        out = ta.propagate_until(t_end, c_output=True)
        return out[0], out[4], out[3]  # outcome, min_h, max_h, steps, dense output, callback

    return run


def trajectory(tol: float, repeat: int) -> dict:
    """Section 1 at one tolerance: times, errors and steps of mett's default and of heyoka."""
    top, start, mdl, p, y0 = _setup()

    def default():
        return mett.simulate(top, start, 8.0, rtol=tol)

    tr = default()
    m_err = float(tr.crossings(math.pi / 2)[0]) - T_HALF
    row = {}
    scan = []
    for k in range(2, -5, -1):
        tol_h = tol * 10 ** (k / 2)
        run = heyoka_run(mdl, p, y0, tol_h)
        _, c, steps = run(8.0)
        err = t_half(lambda t, c=c: c(t).T) - T_HALF
        scan.append((tol_h, err, steps, run))
    same = next(s for s in scan if s[0] == tol)
    matched = next((s for s in scan if abs(s[1]) <= abs(m_err)), scan[-1])
    runs = [same] if matched is same else [same, matched]
    secs = alternating_best([default, *(lambda r=r: r[3](8.0) for r in runs)], repeat)
    row["mett"] = (secs[0], m_err, tr.backend)
    labels = ("heyoka, same tol", "heyoka, matched")[: len(runs)]
    for label, r, sec in zip(labels, runs, secs[1:], strict=True):
        row[label] = (sec, r[1], f"tol {r[0]:.1e}, {r[2]} steps")
    row.setdefault("heyoka, matched", row["heyoka, same tol"])
    return row


def growth(omega3: float, t_end: float, repeat: int, tol: float = 1e-10) -> dict:
    top, start, mdl, p, y0 = _setup(omega3)

    def default():
        return mett.simulate(top, start, t_end, rtol=tol)

    tr = default()
    run = heyoka_run(mdl, p, y0, tol)
    outcome, _, steps = run(t_end)
    m_sec, h_sec = alternating_best([default, lambda: run(t_end)], repeat)
    return {
        "mett": m_sec, "heyoka": h_sec,
        "what": f"mett {tr.backend}, {tr.status}, {len(tr.t) - 1} steps; heyoka {outcome.name}, "
        f"{steps} steps",
    }  # fmt: skip


def sweep_round(calls: int, note: Callable[[str, float], str]) -> None:
    """Section 2, once: the default mett.sweep against heyoka's batch sweep, alternating."""
    print("2. sweep of 64 friction values, 4 s runs, rtol 1e-12, one core (runs/s)")
    top, start, mdl, p, y0 = _setup()
    mus = np.linspace(0.05, 0.5, 64)

    def sweep(top=top, mus=mus):
        return mett.sweep(top, {"mu": mus}, t_end=4.0, rtol=1e-12, progress=False)

    sweep()
    hsweep = heyoka_sweep(top, mdl, p, y0, mus)
    hsweep()
    m_sec, h_sec = alternating_best([sweep, hsweep], calls)
    print(f"   default mett.sweep {64 / m_sec:5.0f} | heyoka batch sweep {64 / h_sec:5.0f} | "
          f"throughput ratio {note('sweep', h_sec / m_sec)} (target >= 1.2)")  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=3, help="repeat every row this many times")
    ap.add_argument("--quick", action="store_true", help="fewer calls per timing (noisier)")
    ap.add_argument("--sections", default="123", help="the sections to run, e.g. 2 (default 123)")
    ap.add_argument("--sweep-calls", type=int, default=None,
                    help="calls of each sweep per round in section 2, best taken (default 7, "
                    "--quick 3; more on a loaded machine)")  # fmt: skip
    args = ap.parse_args()
    if not args.sections or set(args.sections) - set("123"):
        ap.error(f"--sections takes digits of 123; got {args.sections!r}")
    try:
        import heyoka  # noqa: F401
    except ImportError:
        sys.exit("heyoka is not installed: pip install -e '.[bench]'")
    rep = 5 if args.quick else 15
    ratios: dict[str, list[float]] = {}

    def note(key: str, r: float) -> str:
        ratios.setdefault(key, []).append(r)
        return f"{r:.2f}"

    for rnd in range(args.rounds):
        print(f"--- round {rnd + 1} of {args.rounds}")
        if "1" in args.sections:
            print(
                "1. thesis run, 8 s, default mett.simulate vs heyoka "
                "(CPU ms; error of t(θ = π/2), s)"
            )
        for tol in (1e-10, 1e-12) if "1" in args.sections else ():
            row = trajectory(tol, rep)
            base = row["heyoka, matched"][0]
            for name, (sec, err, what) in row.items():
                print(f"   tol {tol:g}  {name:17s} {sec * 1e3:6.2f} ms  error {err:+.1e}  ({what})")
            print(f"   tol {tol:g}  mett / heyoka at matched accuracy: "
                  f"{note(f'trajectory {tol:g}', row['mett'][0] / base)} (target <= 0.8)")  # fmt: skip
        if "2" in args.sections:
            sweep_round(args.sweep_calls or max(rep // 2, 3), note)
        if "3" not in args.sections:
            continue
        print("3. growth, rtol 1e-10, default mett.simulate vs heyoka (CPU ms)")
        for omega3, t_end in ((155.0, 2.0), (1550.0, 2.0), (15500.0, 2.0), (155.0, 8.0),
                              (155.0, 32.0)):  # fmt: skip
            g = growth(omega3, t_end, rep if omega3 < 1e4 else max(rep // 5, 2))
            key = f"ω3 {omega3:g}, t_end {t_end:g}"
            print(f"   {key:22s} mett {g['mett'] * 1e3:8.2f} | heyoka {g['heyoka'] * 1e3:8.2f} | "
                  f"ratio {note(key, g['mett'] / g['heyoka'])}  ({g['what']})")  # fmt: skip
    print("--- ranges over the rounds (mett / heyoka: time ratio; sweep: throughput ratio)")
    for key, rs in ratios.items():
        print(f"   {key:26s} {min(rs):.2f}–{max(rs):.2f}")


if __name__ == "__main__":
    main()
