"""Benchmark: a hopping run, the default ``mett.simulate`` of the thesis top at high spin.

The thesis top (rutstam2013, θ0 = 0.1, ν(0) = 0, default backend and tolerances) over 8 s:
at ω3 = 155 rad/s it never leaves the table; at 1 550 rad/s it loses contact after ~4.8 s and
makes ~840 hops (flight, touchdown, landing impact, a short contact phase) to t = 8 s; at
15 500 rad/s it hops for most of the run. For each spin the script prints

* the CPU time of the whole run (the least of ``--repeat`` runs: the machine may be shared),
  the number of hops (each followed by a contact phase) and the CPU time per hop;
* the fixed cost of one short call of the Taylor backend (a 5 ms contact phase of 5 steps, as
  between two hops): CPU time per ``taylor.solve`` and per ``mett.simulate`` of it;
* where the time goes, from one more run with timers around the pieces of a hop: the contact
  phases on their backend (a kernel call and a Trajectory per phase), the free flight's dense
  output and samples, the touchdown search, the landing impact, and the rest (the driver's
  bookkeeping and the assembly of the Trajectory); the shares are of that run's total, whose
  timers add their own small cost.

Run ``python benchmarks/bench_flight.py`` (about a minute; ``--high`` adds ω3 = 15 500 rad/s,
``--t-end`` sets the simulated time). It prints numbers and asserts nothing.
"""

from __future__ import annotations

import argparse
import functools
import time
from collections.abc import Callable
from typing import Any

import mett
from mett.dynamics import backends, flight

THETA0 = 0.1


def _run(omega3: float, t_end: float) -> mett.Trajectory:
    top = mett.presets.get("rutstam2013")
    return mett.simulate(top, mett.State(theta=THETA0, omega3=omega3), t_end=t_end)


def _cpu(fn: Callable[[], Any], repeat: int) -> tuple[float, Any]:
    """Least CPU time (s) of ``repeat`` calls, and the last result."""
    best, out = float("inf"), None
    for _ in range(repeat):
        t = time.process_time()
        out = fn()
        best = min(best, time.process_time() - t)
    return best, out


class _Timers:
    """CPU-time accumulators wrapped around functions, undone on exit."""

    def __init__(self) -> None:
        self.total: dict[str, float] = {}
        self._undo: list[tuple[Any, str, Any]] = []

    def wrap(self, owner: Any, attr: str, label: str) -> None:
        fn = getattr(owner, attr)
        self.total.setdefault(label, 0.0)

        @functools.wraps(fn)
        def timed(*args: Any, **kw: Any) -> Any:
            t = time.process_time()
            try:
                return fn(*args, **kw)
            finally:
                self.total[label] += time.process_time() - t

        self._undo.append((owner, attr, owner.__dict__.get(attr, None)))
        setattr(owner, attr, timed)

    def __enter__(self) -> _Timers:
        return self

    def __exit__(self, *exc: Any) -> None:
        for owner, attr, old in reversed(self._undo):
            if old is None:
                delattr(owner, attr)
            else:
                setattr(owner, attr, old)


def per_call(repeat: int = 2000) -> tuple[float, float]:
    """CPU seconds per ``taylor.solve`` and per ``mett.simulate`` of a 5 ms contact phase."""
    from mett.dynamics import taylor

    top, state = mett.presets.get("rutstam2013"), mett.State(theta=THETA0, omega3=1550.0)
    calls: list[tuple[Any, Any]] = []
    solve = taylor.solve
    taylor.solve = lambda *a, **kw: calls.append((a, kw)) or solve(*a, **kw)  # type: ignore[misc]
    try:
        mett.simulate(top, state, t_end=0.005, backend="taylor")
    finally:
        taylor.solve = solve
    a, kw = calls[0]
    t_solve, _ = _cpu(lambda: [solve(*a, **kw) for _ in range(repeat)], 3)
    t_sim, _ = _cpu(
        lambda: [mett.simulate(top, state, t_end=0.005, backend="taylor") for _ in range(200)], 3
    )
    return t_solve / repeat, t_sim / 200


def profile(omega3: float, t_end: float) -> dict[str, float]:
    """CPU seconds per piece of the hops of one run (one instrumented run)."""
    with _Timers() as tm:
        for be in backends.REGISTRY.values():
            if hasattr(be, "solve"):
                tm.wrap(be, "solve", "contact phases (backend solve)")
        tm.wrap(flight.Hop, "dense", "flight dense output")
        tm.wrap(flight.Hop, "gaps", "flight gap samples")
        tm.wrap(flight.Hop, "touchdown", "touchdown search")
        tm.wrap(flight, "land", "landing impact")
        t = time.process_time()
        _run(omega3, t_end)
        total = time.process_time() - t
        out = dict(tm.total)
    out["rest (driver, assembly)"] = total - sum(out.values())
    out["total"] = total
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--t-end", type=float, default=8.0)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--high", action="store_true", help="also ω3 = 15 500 rad/s")
    args = ap.parse_args()
    _run(1550.0, 6.0)  # numba's caches loaded: the Taylor kernel and the flight kernels
    spins = [155.0, 1550.0] + ([15500.0] if args.high else [])
    print(f"thesis top, θ0 = {THETA0}, default simulate, t_end = {args.t_end:g} s")
    print(f"{'ω3 (rad/s)':>11} {'CPU (s)':>9} {'hops':>6} {'ms/hop':>8}  status")
    for w in spins:
        cpu, tr = _cpu(lambda w=w: _run(w, args.t_end), args.repeat)
        hops = sum(1 for s in tr.records.get("switches", []) if s.reason == "lift-off")
        per = f"{1e3 * cpu / hops:8.3f}" if hops else f"{'-':>8}"
        print(f"{w:11.0f} {cpu:9.3f} {hops:6d} {per}  {tr.status}")
    solve_s, sim_s = per_call()
    print(
        f"\none short Taylor call (5 ms): solve {1e6 * solve_s:.0f} µs, simulate {1e6 * sim_s:.0f} µs"
    )
    for w in spins[1:]:
        parts = profile(w, args.t_end)
        total = parts.pop("total")
        print(f"\nwhere the time goes, ω3 = {w:g} rad/s (one instrumented run, {total:.3f} s CPU):")
        for k, v in sorted(parts.items(), key=lambda kv: -kv[1]):
            print(f"  {k:32s} {v:7.3f} s  {100 * v / total:5.1f} %")


if __name__ == "__main__":
    main()
