"""Benchmark of the METT separation layer: array path vs the scalar reference path (issue 5).

Run: ``python benchmarks/bench_mett.py [n]``. Prints, from one run, the wall time of n (default
10 000) exact nutation periods and turning points of random rolling states of the thesis body
(θ0 ∈ (0.05, π − 0.05), spins 20–3000 rad/s, φ̇0 ∈ N(0, 20) rad/s), the scalar reference path's
time extrapolated from 200 calls, their ratio, and the largest difference between the two paths
on those 200 elements. Numbers only: nothing is asserted.
"""

from __future__ import annotations

import sys

import numpy as np
from _timing import best_of

import mett
from mett import separation


def _states(n: int, seed: int = 5):
    rng = np.random.default_rng(seed)
    top = mett.presets.get("rutstam2013")
    s = mett.State(
        theta=rng.uniform(0.05, np.pi - 0.05, n),
        phidot=rng.normal(0.0, 20.0, n),
        omega3=np.exp(rng.uniform(np.log(20.0), np.log(3000.0), n)),
    )
    return top, mett.energy(top, s), mett.routh(top, s), mett.jellett(top, s)


def main(n: int = 10_000, n_scalar: int = 200) -> None:
    top, E, D, lam = _states(n)
    separation.nutation_period(top, E[:10], D[:10], lam[:10])  # warm-up (imports, caches)
    rows = []
    for name in ("nutation_period", "turning_points"):
        vec = getattr(separation, name)
        ref = getattr(separation, f"_reference_{name}")
        t_vec, out = best_of(lambda vec=vec: vec(top, E, D, lam))
        k = slice(0, n_scalar)
        sub = (top, E[k], D[k], lam[k])
        t_ref, out_ref = best_of(lambda ref=ref, sub=sub: ref(*sub), repeat=1)
        t_ref_n = t_ref * n / n_scalar
        diff = np.max(np.abs(np.asarray(out)[k] - out_ref) / np.abs(out_ref))
        rows.append((name, t_vec, t_ref_n, t_ref_n / t_vec, diff))
    sol = separation.solve(top, E, D, lam, None)
    print(f"{n} random rolling states of the thesis body, spins 20-3000 rad/s")
    print(
        f"{'':18s} {'array path':>12s} {'scalar (extrap.)':>17s} {'ratio':>8s} {'max rel diff':>13s}"
    )
    for name, t_vec, t_ref, ratio, diff in rows:
        print(f"{name:18s} {t_vec:10.3f} s {t_ref:15.2f} s {ratio:7.0f}x {diff:13.1e}")
    print(f"elements passed to the scalar path: {int(sol.scalar.sum())} of {n}")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 10_000)
