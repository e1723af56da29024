"""Benchmark: ``mett.simulate`` (default and compiled backend) against scipy, sweeps, import and
JIT cost.

1. The thesis trajectory (rutstam2013, θ0 = 0.1, ω3 = 155 rad/s, ν(0) = 0; 8 s at rtol = 1e-10):
   the default ``mett.simulate`` (``backend="auto"``, which runs the Taylor backend here) and
   mett's compiled backend (numba DOP853 + compiled right-hand side, contact event compiled)
   against ``scipy.integrate.solve_ivp(method="DOP853")`` with the numba-compiled right-hand side
   behind a thin Python wrapper, and with the plain numpy right-hand side (mett's scipy backend).
   The DOP853 runs use simulate's tolerances, dense output and the contact event, so they take
   the same steps. Then where the time of a compiled run goes: integration, Trajectory, crossings.
2. A 1000-trajectory sweep (``mett.sweep``, 25 μ × 40 ω3, thesis top, short runs) on a
   ``ProcessPoolExecutor`` with 1 and 2 workers, on the default backend (``"auto"``: the Taylor
   backend, four points per SIMD batch) and on the compiled DOP853 (one point at a time):
   trajectories per second.
3. Fresh interpreters: ``import mett`` against ``import numpy, scipy.integrate``, and the first
   ``simulate`` call (numba import + loading the compiled code from the cache), then the second.

Run ``python benchmarks/bench_simulate.py`` (about a minute); it prints numbers, it asserts
nothing. ``--cold`` also times the first call with an empty numba cache (compiling everything,
tens of seconds). ``--t-end`` sets the simulated time of the sweep runs (default 4 s).
"""

from __future__ import annotations

import argparse
import math
import os
import statistics
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np

import mett
from mett.dynamics import MODELS

THETA0, OMEGA3, T_END, RTOL = 0.1, 155.0, 8.0, 1e-10


_MEDIANS: dict[int, float] = {}


def _best(fn, repeat: int) -> tuple[float, object]:
    """Smallest wall time of ``repeat`` calls (s) and the last result; the median is kept in
    ``_MEDIANS[id(fn)]`` (the machine may be shared: the minimum is the reproducible number)."""
    times, out = [], None
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t)
    _MEDIANS[id(fn)] = statistics.median(times)
    return min(times), out


def thesis(repeat: int) -> None:
    from scipy.integrate import solve_ivp

    from mett.dynamics import _kernels, dop853

    top = mett.presets.get("rutstam2013")
    start = mett.State(theta=THETA0, omega3=OMEGA3)
    model = MODELS["gliding"]
    p = model.params(top, {})
    pa = np.array(p)
    y0 = np.asarray(model.initial(start, p), dtype=float)
    atol = RTOL * np.asarray(model.scales(y0, p), dtype=float)
    rhs_c, events_c = _kernels.get("gliding")
    mett.simulate(top, start, T_END)  # load the compiled code

    out, g = np.empty(y0.size), np.empty(1)

    def fun_compiled(t, y):
        rhs_c(t, y, pa, out)
        return out.copy()

    def contact_compiled(t, y):
        events_c(t, y, pa, g)
        return g[0]

    def fun_numpy(t, y):
        return model.rhs(t, y, p)

    weight = 1.0 / (top.m * top.g)

    def contact_numpy(t, y):
        return float(model.normal_force(y, p)) * weight

    for ev in (contact_compiled, contact_numpy):
        ev.terminal, ev.direction = True, -1.0

    def scipy_run(fun, ev):
        return solve_ivp(fun, (0.0, T_END), y0, method="DOP853", rtol=RTOL, atol=atol,
                         dense_output=True, events=[ev])  # fmt: skip

    run_default = lambda: mett.simulate(top, start, T_END)  # noqa: E731
    t_default, tr_default = _best(run_default, repeat)
    t_default_median = _MEDIANS[id(run_default)]
    run_mett = lambda: mett.simulate(top, start, T_END, backend="compiled")  # noqa: E731
    t_mett, tr = _best(run_mett, repeat)

    def solve_compiled(t_end):
        return dop853.solve(
            rhs_c, (0.0, t_end), y0, pa, rtol=RTOL, atol=atol, events=events_c,
            direction=[-1.0], terminal=[True],
        )  # fmt: skip

    t_solve, sol = _best(lambda: solve_compiled(T_END), repeat)
    t_sc, res_c = _best(lambda: scipy_run(fun_compiled, contact_compiled), 3)
    t_sn, res_n = _best(lambda: scipy_run(fun_numpy, contact_numpy), 3)
    t_sim_scipy, _ = _best(lambda: mett.simulate(top, start, T_END, backend="scipy"), 3)

    n_steps = len(tr) - 1
    print(f"(1) thesis run: rutstam2013, theta0 = {THETA0}, omega3 = {OMEGA3}, nu(0) = 0, "
          f"{T_END:g} s, rtol = {RTOL:g}; DOP853: {n_steps} steps, {tr.nfev} RHS calls")  # fmt: skip
    print("                                                 time [ms]   ratio to the default")
    rows = [
        (f"mett.simulate (default: {tr_default.backend})", t_default),
        ('mett.simulate(backend="compiled")', t_mett),
        ("  of which dop853.solve (integration + event)", t_solve),
        ("scipy DOP853 + numba RHS (Python wrapper)", t_sc),
        ("scipy DOP853 + numpy RHS", t_sn),
        ('mett.simulate(backend="scipy")', t_sim_scipy),
    ]
    for name, t in rows:
        print(f"  {name:<46} {1e3 * t:9.2f}   {t / t_default:8.1f}x")
    print(f"  RHS calls: mett {tr.nfev}, scipy+numba {res_c.nfev}, scipy+numpy {res_n.nfev}")
    print(f"  thesis run: default mett.simulate {1e3 * t_default:.2f} ms (best of {repeat}; "
          f"median {1e3 * t_default_median:.2f} ms), {t_sc / t_default:.0f}x faster than scipy "
          "DOP853 with the compiled RHS")  # fmt: skip

    # where a compiled run's time goes (the rest of simulate is setup and the Trajectory)
    t_derive, _ = _best(lambda: model.derive(tr.states, tr.params), repeat)
    t_cross, _ = _best(lambda: tr.crossings(math.pi / 2), repeat)
    t_tiny_sim, _ = _best(lambda: mett.simulate(top, start, 1e-4, backend="compiled"), repeat * 5)
    t_tiny_solve, _ = _best(lambda: solve_compiled(1e-4), repeat * 5)
    per_step = t_solve / max(sol.n_accepted + sol.n_rejected, 1)
    print('  profile of the compiled run (backend="compiled"):')
    print(f"    integration (dop853.solve)                  {1e3 * t_solve:7.2f} ms "
          f"({1e6 * per_step:.2f} us per step, {1e9 * t_solve / sol.nfev:.0f} ns per RHS call)")  # fmt: skip
    print(f"    Trajectory series (model.derive, vectorised) {1e3 * t_derive:7.2f} ms")
    print(f"    rest of simulate (setup, checks)            "
          f"{1e3 * max(t_mett - t_solve - t_derive, 0.0):7.2f} ms")  # fmt: skip
    print(f"    traj.crossings(pi/2) (not part of simulate)  {1e3 * t_cross:7.2f} ms")
    print(f"    fixed cost of a tiny run: simulate {1e3 * t_tiny_sim:.2f} ms, "
          f"of which solve {1e3 * t_tiny_solve:.2f} ms")  # fmt: skip


def _warm(_: int) -> int:
    mett.simulate(mett.presets.get("rutstam2013"), mett.State(theta=0.1, omega3=155.0), 0.01)
    time.sleep(0.2)  # keep this worker busy so that the next warm-up task goes to another one
    return os.getpid()


def sweep(t_end: float) -> None:
    top = mett.presets.get("rutstam2013")
    grid = {"mu": np.linspace(0.05, 0.5, 25), "omega3": np.linspace(60.0, 250.0, 40)}
    n = 25 * 40
    print(f"(2) sweep: {n} trajectories (rutstam2013, 25 mu x 40 omega3, t_end = {t_end:g} s, "
          f"rtol = {RTOL:g}), mett.sweep on a ProcessPoolExecutor")  # fmt: skip
    for backend in ("auto", "compiled"):  # the default (Taylor batches), then DOP853 one by one
        for workers in (1, 2):
            t0 = time.perf_counter()
            with ProcessPoolExecutor(max_workers=workers) as pool:
                list(pool.map(_warm, range(2 * workers)))
                mett.sweep(top, {"mu": [0.3]}, t_end=0.01, executor=pool, backend=backend)
                t1 = time.perf_counter()
                table = mett.sweep(top, grid, t_end=t_end, executor=pool, backend=backend)
                t2 = time.perf_counter()
            kinds = table["simulated"].value_counts().to_dict()
            print(f"  backend {backend!r}, {workers} worker(s): {n / (t2 - t1):7.1f} trajectories/s "
                  f"({t2 - t1:.2f} s; pool start + warm-up {t1 - t0:.2f} s); end states {kinds}")  # fmt: skip


def _fresh(code: str, env: dict[str, str] | None = None) -> list[float]:
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, env=env)  # fmt: skip
    return [float(v) for v in out.stdout.split()]


_FIRST_CALL = (
    "import time; t0 = time.perf_counter(); import mett, sys; t1 = time.perf_counter();"
    "assert 'numba' not in sys.modules;"
    "top = mett.presets.get('rutstam2013'); s = mett.State(theta=0.1, omega3=155.0);"
    "mett.simulate(top, s, 8.0); t2 = time.perf_counter();"
    "mett.simulate(top, s, 8.0); t3 = time.perf_counter();"
    "print(t1 - t0, t2 - t1, t3 - t2)"
)


def fresh_process(cold: bool, repeat: int = 5) -> None:
    base = [_fresh("import time; t = time.perf_counter(); import numpy, scipy.integrate;"
                   "print(time.perf_counter() - t)")[0] for _ in range(repeat)]  # fmt: skip
    runs = [_fresh(_FIRST_CALL) for _ in range(repeat)]
    imp, first, second = (statistics.median(r[i] for r in runs) for i in range(3))
    print(f"(3) fresh interpreters (median of {repeat}; numba cache warm)")
    print(f"  import numpy, scipy.integrate   {1e3 * statistics.median(base):7.0f} ms")
    print(f"  import mett (numba not loaded)  {1e3 * imp:7.0f} ms")
    print(
        f"  first simulate (thesis, 8 s)    {1e3 * first:7.0f} ms  "
        "(numba import + compiled code from the cache + the run)"
    )
    print(f"  second simulate                 {1e3 * second:7.1f} ms")
    if cold:
        with tempfile.TemporaryDirectory() as cache:
            env = {**os.environ, "NUMBA_CACHE_DIR": cache}
            imp, first, second = _fresh(_FIRST_CALL, env)
        print(
            f"  first simulate, empty numba cache {first:6.1f} s  (compiles the integrator "
            "and the gliding kernels; once per installation)"
        )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cold", action="store_true", help="also time compiling from scratch")
    ap.add_argument("--t-end", type=float, default=4.0, help="simulated time of the sweep runs")
    ap.add_argument("--repeat", type=int, default=20, help="repeats of the fast measurements")
    args = ap.parse_args()
    print(f"machine: {os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.2f}; "
          f"python {sys.version.split()[0]}, numpy {np.__version__}")  # fmt: skip
    thesis(args.repeat)
    sweep(args.t_end)
    fresh_process(args.cold)


if __name__ == "__main__":
    main()
