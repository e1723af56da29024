"""Benchmark: compiled DOP853 (:mod:`mett.dynamics.dop853`) vs ``scipy.integrate.solve_ivp``.

The test problem is 12-dimensional: a ring of six pendula coupled by springs,
q_i'' = −sin q_i + k (q_{i+1} − 2 q_i + q_{i−1}), integrated at rtol = atol = 1e-10 over a span
chosen so that scipy needs about 35 000 right-hand-side evaluations (the size of a thesis
tippe-top trajectory).  Both integrators call the same numba-compiled right-hand side;
scipy gets it through a thin Python wrapper, as a user would pass it.

Run ``python benchmarks/bench_dop853.py``; it prints numbers, it asserts nothing.  ``--cold`` also
measures compilation from an empty numba cache (about 10-20 s).
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numba
import numpy as np
from _timing import best_of

N_PENDULA = 6
RTOL = ATOL = 1e-10
T_END = 650.0


@numba.njit(cache=True)
def ring_rhs(t, y, p, out):
    """Six pendula on a ring, coupled by springs of stiffness p[0]; y = (q_1..q_6, p_1..p_6)."""
    n = y.size // 2
    k = p[0]
    for i in range(n):
        left = y[(i - 1) % n]
        right = y[(i + 1) % n]
        out[i] = y[n + i]
        out[n + i] = -np.sin(y[i]) + k * (left - 2.0 * y[i] + right)


PARAMS = np.array([0.7])
Y0 = np.concatenate([np.linspace(0.3, 1.2, N_PENDULA), np.zeros(N_PENDULA)])


def _fresh_process_first_call(env: dict[str, str] | None = None) -> float:
    """Seconds for import + first solve in a new interpreter (cache as found)."""
    here = str(Path(__file__).parent)
    code = (
        f"import sys, time; sys.path.insert(0, {here!r}); t = time.perf_counter();"
        "import bench_dop853 as b; from mett.dynamics import dop853;"
        "dop853.solve(b.ring_rhs, (0.0, 1.0), b.Y0, b.PARAMS, rtol=1e-6, atol=1e-6);"
        "print(time.perf_counter() - t)"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, env=env
    )
    return float(out.stdout.strip().splitlines()[-1])


def main() -> None:
    from scipy.integrate import solve_ivp

    from mett.dynamics import dop853

    out = np.empty(Y0.size)

    def scipy_fun(t, y):
        ring_rhs(t, y, PARAMS, out)
        return out.copy()

    def ours(dense: bool):
        return dop853.solve(
            ring_rhs, (0.0, T_END), Y0, PARAMS, rtol=RTOL, atol=ATOL, dense_output=dense
        )

    def theirs(dense: bool):
        return solve_ivp(
            scipy_fun, (0.0, T_END), Y0, method="DOP853", rtol=RTOL, atol=ATOL, dense_output=dense
        )

    ours(True)  # compile the RHS for the integrator's signature (or load it from the cache)
    t_sp, r_sp = best_of(lambda: theirs(False), 3)
    t_spd, r_spd = best_of(lambda: theirs(True), 3)
    t_us, r_us = best_of(lambda: ours(False), 20)
    t_usd, r_usd = best_of(lambda: ours(True), 20)
    t_tiny, _ = best_of(
        lambda: dop853.solve(ring_rhs, (0.0, 1e-6), Y0, PARAMS, dense_output=False), 50
    )
    n_rhs = 200_000
    y = Y0.copy()

    @numba.njit
    def rhs_loop(y, p, out, n):
        for _ in range(n):
            ring_rhs(0.0, y, p, out)

    rhs_loop(y, PARAMS, out, 1)
    t_rhs, _ = best_of(lambda: rhs_loop(y, PARAMS, out, n_rhs), 5)

    print(f"problem: ring of {N_PENDULA} pendula (n = {Y0.size}), t in [0, {T_END}], "
          f"rtol = atol = {RTOL:g}")  # fmt: skip
    print(f"compiled RHS alone: {t_rhs / n_rhs * 1e9:.0f} ns per call")
    rows = [
        ("scipy DOP853", t_sp, r_sp.nfev, r_sp.t.size - 1),
        ("scipy DOP853, dense_output", t_spd, r_spd.nfev, r_spd.t.size - 1),
        ("mett dop853", t_us, r_us.nfev, r_us.n_accepted),
        ("mett dop853, dense_output", t_usd, r_usd.nfev, r_usd.n_accepted),
    ]
    print(f"{'':32s}{'time [ms]':>12s}{'nfev':>8s}{'steps':>7s}{'ns/nfev':>9s}")
    for name, t, nfev, steps in rows:
        print(f"{name:32s}{t * 1e3:12.2f}{nfev:8d}{steps:7d}{t / nfev * 1e9:9.0f}")
    print(f"speed-up without dense output: {t_sp / t_us:.0f}x; with dense output: "
          f"{t_spd / t_usd:.0f}x")  # fmt: skip
    dy = np.max(np.abs(r_us.y[:, -1] - r_sp.y[:, -1])) / np.max(np.abs(r_sp.y))
    print(f"final states differ by {dy:.1e} (relative to max |y|)")
    print(f"fixed cost of one solve() call (tiny span): {t_tiny * 1e6:.0f} us")

    _fresh_process_first_call()  # make sure the cache is warm
    warm = min(_fresh_process_first_call() for _ in range(3))
    print(f"fresh process, warm numba cache: import + first solve = {warm:.2f} s")
    base = subprocess.run(
        [sys.executable, "-c", "import time; t = time.perf_counter(); import numba, scipy.integrate;"
         "import mett.dynamics; print(time.perf_counter() - t)"],
        capture_output=True, text=True, check=True,
    )  # fmt: skip
    print(f"  (of which importing numba, scipy and mett.dynamics: "
          f"{float(base.stdout.split()[-1]):.2f} s)")  # fmt: skip
    if "--cold" in sys.argv:
        with tempfile.TemporaryDirectory() as tmp:
            env = dict(os.environ, NUMBA_CACHE_DIR=tmp)
            cold = _fresh_process_first_call(env)
        print(f"fresh process, empty numba cache: import + compile + first solve = {cold:.2f} s")


if __name__ == "__main__":
    main()
