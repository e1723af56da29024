"""Benchmark: mett's Taylor-series backend against its DOP853 and against heyoka, in one run.

1. One thesis trajectory (rutstam2013, θ0 = 0.1, ω3 = 155 rad/s; 8 s, the vector-form gliding
   model) at tolerances 1e-10 and 1e-12: mett's Taylor backend (the integrator alone and the whole
   ``simulate`` call), mett's compiled DOP853, and heyoka's ``taylor_adaptive`` (if installed: the
   ``bench`` extra) on the very same equations (the model's ``rhs_into`` traced with heyoka's
   variables). Each prints the error of the first θ = π/2 time against its converged value.
2. A sweep of 64 friction coefficients (4 s runs; the 16 with the most friction lose contact
   before 4 s) on one core: mett's Taylor integrator with 4 SIMD lanes (``taylor.propagate``: end
   states only, as heyoka's ``propagate_until``; ``taylor.solve`` keeps the dense output) against
   heyoka's batch mode (4 lanes), both with the model's contact-loss event and both without
   events, runs per second. (A terminal event in one lane stops every lane of a heyoka batch, so
   its rate with the event counts runs left unfinished; mett runs each lane to its own end.
   Section 3 finishes them.)
3. The same grid through ``mett.sweep`` end to end (per point: validation, the run with its
   contact event, the θ = π/2 crossing, the settled test, the predicted end state, the table) on
   the Taylor and on the compiled DOP853 backend; its ratio to heyoka's raw batch rates of 2; and
   heyoka doing the same sweep as a user would write it (:func:`heyoka_sweep`: the crossing as a
   non-terminal event, end values, a table; without the settled test).

Times are CPU times of this thread (``time.thread_time``), best of several repeats: on a shared
machine they are less disturbed than wall-clock times, and both codes are timed the same way; in
sections 2 and 3 the calls of the codes compared alternate (:func:`alternating_best`).
Run ``python benchmarks/bench_taylor.py``; it prints numbers and ratios and asserts nothing. The
first run on a machine compiles the Taylor kernels (a few seconds each; cached on disk).
"""

from __future__ import annotations

import gc
import math
import time
from collections.abc import Callable

import numpy as np
from scipy.optimize import brentq

import mett
from mett.dynamics import MODELS, dop853, taylor

T_HALF = 5.879749518045809  # converged first θ = π/2 of the thesis run (tests/test_taylor.py)


def cpu_best(fn: Callable[[], object], repeat: int) -> float:
    """Best CPU time of ``repeat`` calls, with Python's garbage collector held off during each
    (a collection of the many objects a benchmark process holds costs milliseconds and would
    land on whichever call happens to trigger it)."""
    best = math.inf
    for _ in range(repeat):
        gc.collect()
        gc.disable()
        try:
            t0 = time.thread_time()
            fn()
            best = min(best, time.thread_time() - t0)
        finally:
            gc.enable()
    return best


def alternating_best(fns, repeat: int) -> list[float]:
    """Best CPU time of each of ``fns`` over ``repeat`` rounds that call each once in turn
    (mett, heyoka, mett, …): a change of the machine's load hits both, not one of them. The
    garbage collector is held off during each call."""
    best = [math.inf] * len(fns)
    for _ in range(repeat):
        for i, fn in enumerate(fns):
            gc.collect()
            gc.disable()
            try:
                t0 = time.thread_time()
                fn()
                best[i] = min(best[i], time.thread_time() - t0)
            finally:
                gc.enable()
    return best


def t_half(dense: Callable, ez_row: int = 9) -> float:
    tt = np.linspace(5.5, 6.5, 2001)
    ez = dense(tt)[ez_row]
    i = int(np.flatnonzero(np.diff(np.sign(ez)))[0])
    return brentq(lambda t: float(dense(t)[ez_row]), tt[i], tt[i + 1], xtol=1e-15)


def heyoka_system(mdl, p):
    """The model's equations as heyoka expressions: ``rhs_into`` traced with heyoka variables."""
    import heyoka as hy

    y = hy.make_vars(*[f"y{i}" for i in range(10)])
    out: dict[int, object] = {}
    mdl.rhs_into(0.0, list(y), tuple(p), out)
    return [(y[i], out[i]) for i in range(10)]


def main() -> None:
    try:
        import heyoka as hy
    except ImportError:  # the bench extra is not installed
        hy = None
    top = mett.presets.get("rutstam2013")
    start = mett.State(theta=0.1, omega3=155.0)
    mdl = MODELS["gliding"]
    p = np.array(mdl.params(top, {}))
    y0 = np.asarray(mdl.initial(start, tuple(p)))
    scales = mdl.scales(y0, tuple(p))
    events = [ev.fn for ev in mdl.events]
    rhs, ev = dop853_kernels(mdl)
    print("1. thesis trajectory, 8 s (CPU ms, best of 15; error of t(θ = π/2) in s)")
    for tol in (1e-10, 1e-12):
        k = taylor.kernel(mdl.rhs_into, events, 10, 7, taylor.order_for(tol), "gliding",
                          vectors=mdl.vectors, lengths=mdl.conserved_lengths)  # fmt: skip

        def mett_taylor(k=k, tol=tol):
            return taylor.solve(k, (0.0, 8.0), y0, p, scales=scales, direction=[-1.0])[0]

        def mett_dop853(tol=tol):
            return dop853.solve(rhs, (0.0, 8.0), y0, p, rtol=tol, atol=tol * scales, events=ev,
                                direction=[-1.0], terminal=[True])  # fmt: skip

        def mett_simulate(tol=tol):
            return mett.simulate(top, start, 8.0, backend="taylor", rtol=tol)

        sol = mett_taylor()
        row = {
            "taylor": (cpu_best(mett_taylor, 15), t_half(sol.dense) - T_HALF, sol.n_steps),
            "simulate(taylor)": (
                cpu_best(mett_simulate, 15),
                float(mett_simulate().crossings(math.pi / 2)[0]) - T_HALF,
                sol.n_steps,
            ),
        }
        d = mett_dop853()
        row["dop853"] = (cpu_best(mett_dop853, 15), t_half(d.dense) - T_HALF, d.n_accepted)
        if hy is not None:
            ta = hy.taylor_adaptive(heyoka_system(mdl, p), y0, tol=tol)

            def hey(ta=ta):
                ta.time = 0.0
                ta.state[:] = y0
                return ta.propagate_until(8.0, c_output=True)

            out = hey()
            c = out[-1] if callable(out[-1]) else out[4]
            row["heyoka"] = (cpu_best(hey, 15), t_half(lambda t, c=c: c(t).T) - T_HALF, out[3])
        base = row.get("heyoka", row["dop853"])[0]
        for name, (sec, err, steps) in row.items():
            print(f"   tol {tol:g}  {name:17s} {sec * 1e3:7.2f} ms  ({steps} steps, error "
                  f"{err:+.1e})  ×{sec / base:.2f} of {'heyoka' if hy else 'dop853'}")  # fmt: skip
    print("2. sweep: 64 friction coefficients, 4 s runs, one core (runs/s, best of 5)")
    mus = np.linspace(0.05, 0.5, 64)
    P = np.tile(p, (64, 1))
    P[:, 5] = mus
    Y = np.tile(y0, (64, 1))
    heyoka_rate: dict[str, float] = {}
    for tol in (1e-12, 2.220446049250313e-16):
        kernels = {}
        for label, evs in (("with the contact event", events), ("without events", [])):
            kernels[label] = taylor.kernel(mdl.rhs_into, evs, 10, 7, taylor.order_for(tol),
                                           "gliding", lanes=4, vectors=mdl.vectors,
                                           lengths=mdl.conserved_lengths)  # fmt: skip
        kws = {"with the contact event": {"direction": [-1.0]}, "without events": {}}
        k4 = kernels["with the contact event"]
        dsec = cpu_best(lambda k4=k4: taylor.solve(k4, (0, 4.0), Y, P, scales=scales), 3)
        print(f"   tol {tol:.1e}  mett, 4 lanes, with dense output (taylor.solve): "
              f"{64 / dsec:5.0f} runs/s")  # fmt: skip
        hb_of = {}
        if hy is not None:
            pp = [*p[:5], hy.par[0], p[6]]
            y = hy.make_vars(*[f"y{i}" for i in range(10)])
            contact = mdl.events[0].fn(0.0, list(y), tuple(pp))  # g_n/(m g), traced
            for label, kw in (
                ("with the contact event", {"t_events": [hy.t_event_batch(
                    contact, direction=hy.event_direction.negative)]}),
                ("without events", {}),
            ):  # fmt: skip
                ta = hy.taylor_adaptive_batch(heyoka_system(mdl, pp), np.tile(y0[:, None], (1, 4)),
                                              tol=tol, pars=np.zeros((1, 4)), **kw)  # fmt: skip

                def hb(ta=ta):
                    for g in range(16):
                        ta.set_time(0.0)
                        ta.state[:] = y0[:, None]
                        ta.pars[0, :] = mus[4 * g : 4 * g + 4]
                        ta.propagate_until(4.0)

                hb_of[label] = hb
        rates, hey = {}, {}
        for label, k4 in kernels.items():

            def mp(k4=k4, kw=kws[label]):
                return taylor.propagate(k4, (0, 4.0), Y, P, scales=scales, **kw)

            secs = alternating_best([mp] + ([hb_of[label]] if label in hb_of else []), 5)
            rates[label] = 64 / secs[0]
            if label in hb_of:
                hey[label] = 64 / secs[1]
        for label, rate in rates.items():
            line = f"      {label:23s} mett (taylor.propagate) {rate:5.0f} runs/s"
            if label in hey:
                line += f" | heyoka batch {hey[label]:5.0f} | mett / heyoka {rate / hey[label]:.2f}"
            print(line)
        if tol == 1e-12:
            heyoka_rate = hey
    print(
        "3. mett.sweep over the same grid at rtol 1e-12, end to end (validation, the run with its"
    )
    print("   contact event, the θ = π/2 crossing, settled test, prediction, the table)")

    def run(backend):
        return mett.sweep(top, {"mu": mus}, t_end=4.0, backend=backend, rtol=1e-12,
                          progress=False)  # fmt: skip

    # mett and heyoka alternate; the compiled sweep (ten times longer, and it would leave the
    # caches cold for whichever code runs after it) is timed on its own
    fns = [lambda: run("taylor")]
    if hy is not None:
        fns.append(heyoka_sweep(top, mdl, p, y0, mus))
    for fn in fns:
        fn()
    secs = alternating_best(fns, 8)
    run("compiled")
    row = {"taylor": secs[0], "compiled": cpu_best(lambda: run("compiled"), 3)}
    print(
        f"   backend taylor {64 / row['taylor']:5.0f} runs/s | compiled (DOP853) "
        f"{64 / row['compiled']:5.0f} runs/s | ratio {row['compiled'] / row['taylor']:.1f}"
    )
    for label, rate in heyoka_rate.items():
        print(f"   mett.sweep(backend='taylor') / heyoka batch {label}: "
              f"{64 / row['taylor'] / rate:.2f}")  # fmt: skip
    if hy is not None:
        sec = secs[1]
        print(f"   heyoka doing the same sweep (batch mode, the contact event, the crossing as a "
              f"non-terminal event, end values, the table; no settled test): {64 / sec:5.0f} "
              f"runs/s; mett.sweep / heyoka {sec / row['taylor']:.2f}")  # fmt: skip


def heyoka_sweep(top, mdl, p, y0, mus, t_end=4.0, tol=1e-12):
    """The sweep of section 3 written with heyoka, as a user would: batches of 4 points, the
    terminal contact event, the first θ = π/2 crossing from a non-terminal event on 3̂_z, θ and ω3
    at the end from the final states, a pandas table. (No settled test: less work than
    mett.sweep does.)"""
    import heyoka as hy
    import pandas as pd

    pp = [*p[:5], hy.par[0], p[6]]
    y = hy.make_vars(*[f"y{i}" for i in range(10)])
    contact = mdl.events[0].fn(0.0, list(y), tuple(pp))
    first = np.full(4, np.nan)

    def crossed(ta, t, d_sgn, lane):
        if np.isnan(first[lane]):
            first[lane] = t

    ta = hy.taylor_adaptive_batch(
        heyoka_system(mdl, pp), np.tile(y0[:, None], (1, 4)), tol=tol, pars=np.zeros((1, 4)),
        t_events=[hy.t_event_batch(contact, direction=hy.event_direction.negative)],
        nt_events=[hy.nt_event_batch(y[9], crossed)],
    )  # fmt: skip

    time_limit = hy.taylor_outcome.time_limit
    contact_lost = int(hy.taylor_outcome(-1))  # the outcome "terminal event 0"

    def run():
        rows = []
        for g in range(0, len(mus), 4):
            first[:] = np.nan
            ta.set_time(0.0)
            ta.state[:] = y0[:, None]
            ta.pars[0, :] = mus[g : g + 4]
            # A terminal event in one lane stops every lane of a heyoka batch: go on until each
            # lane has reached t_end or its own event (a finished lane is integrated on, unused)
            end, t_stop, status = np.empty((10, 4)), np.full(4, np.nan), [""] * 4
            for _ in range(100):
                ta.propagate_until(t_end)
                for lane, (outcome, *_) in enumerate(ta.propagate_res):
                    if status[lane]:
                        continue
                    if outcome == time_limit or int(outcome) == contact_lost:
                        status[lane] = "completed" if outcome == time_limit else "contact_lost"
                        end[:, lane], t_stop[lane] = ta.state[:, lane], ta.time[lane]
                if all(status):
                    break
            L, e = end[4:7], end[7:10] / np.linalg.norm(end[7:10], axis=0)
            theta = np.arctan2(np.hypot(e[0], e[1]), e[2])
            omega3 = np.sum(L * e, axis=0) / top.I3
            for lane in range(4):
                t_cross = first[lane] if first[lane] <= t_stop[lane] else np.nan
                rows.append({
                    "mu": mus[g + lane], "t_invert": t_cross, "status": status[lane],
                    "t_stop": t_stop[lane], "theta_end": theta[lane], "omega3_end": omega3[lane],
                })  # fmt: skip
        return pd.DataFrame(rows)

    return run


def dop853_kernels(mdl):
    from mett.dynamics import _kernels

    return _kernels.compiled(mdl, mdl.phase)


if __name__ == "__main__":
    main()
