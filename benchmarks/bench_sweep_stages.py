"""Benchmark: where the time of the default 64-point ``mett.sweep`` goes, stage by stage.

The sweep of ``bench_defaults.py`` section 2 (the thesis top, ``{"mu": 64 values}``, 4 s runs,
rtol 1e-12, serial, one core), run ``--repeat`` times with a timer (CPU time of the thread)
around each stage: the functions below are wrapped by name for this process only. Each line is
a stage's inclusive time per sweep and per point; stages nest (the indentation), so a parent's
time includes its children's, and the timers add ~1 µs per call of their own. The Taylor kernel
(``taylor.propagate``: the integration of every lane, the crossings and the window samples) is the
part the other stages are measured against: what is not kernel is the work per point around it.

Run ``python benchmarks/bench_sweep_stages.py [--repeat N]``; it prints and asserts nothing.
"""

from __future__ import annotations

import argparse
import gc
import importlib
import time
from collections.abc import Callable
from typing import Any

import numpy as np

import mett
from mett.dynamics import MODELS
from mett.dynamics.backends import REGISTRY

# (depth, label, owner, attribute): the owner is a module path, or an object given directly
STAGES: list[tuple[int, str, Any, str]] = [
    (0, "sweep: validation, probe, grid, table", "mett.sweeps", "sweep"),
    (1, "probe of the options (check_run)", "mett.sweeps", "_probe_options"),
    (1, "a chunk of points", "mett.sweeps", "_run_chunk"),
    (2, "start of each point (top, state, λ)", "mett.sweeps", "_start"),
    (2, "run_ends", "mett.dynamics.batch", "run_ends"),
    (3, "prepare each run (checks, y0, scales, backend)", "mett.dynamics.batch", "prepare_planned"),
    (4, "backend choice", "mett.dynamics.backends", "choose"),
    (3, "kernel lookup", REGISTRY["taylor"], "batch_kernel"),
    (3, "the batch and its ends", "mett.dynamics.batch", "_propagate_group"),
    (4, "the batch's call of the kernel", REGISTRY["taylor"], "propagate"),
    (5, "Taylor kernel (all lanes)", "mett.dynamics.taylor", "propagate"),
    (4, "derive (θ, ω3, E of the ends)", MODELS["gliding"], "derive"),
    (4, "θ over the windows", MODELS["gliding"], "theta"),
    (2, "row of each point", "mett.sweeps", "_row"),
    (1, "the table (SweepTable)", "mett.sweeps", "SweepTable"),
]


def _owner(owner: Any) -> Any:
    return importlib.import_module(owner) if isinstance(owner, str) else owner


def _timed(fn: Callable, label: str, acc: dict[str, int]) -> Callable:
    def timed(*args: Any, **kwargs: Any) -> Any:
        t0 = time.thread_time_ns()
        try:
            return fn(*args, **kwargs)
        finally:
            acc[label] = acc.get(label, 0) + time.thread_time_ns() - t0

    return timed


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=40, help="sweeps timed (default 40)")
    args = ap.parse_args()
    top = mett.presets.get("rutstam2013")
    mus = np.linspace(0.05, 0.5, 64)
    n = mus.size

    def sweep() -> Any:
        return mett.sweep(top, {"mu": mus}, t_end=4.0, rtol=1e-12, progress=False)

    sweep()  # compiled and cached kernels, the prediction's cache
    acc: dict[str, int] = {}
    for _, label, owner, attr in STAGES:
        obj = _owner(owner)
        fn = getattr(obj, attr, None)
        if fn is None:  # a stage the code no longer has
            continue
        object.__setattr__(obj, attr, _timed(fn, label, acc))
    # the sweep is looked up through the package: time mett.sweep itself
    mett.sweep = importlib.import_module("mett.sweeps").sweep
    total = 0
    for _ in range(args.repeat):
        gc.collect()
        gc.disable()
        t0 = time.thread_time_ns()
        sweep()
        total += time.thread_time_ns() - t0
        gc.enable()
    per = 1e6 * args.repeat
    kernel = acc.get("Taylor kernel (all lanes)", 0)
    print(f"default mett.sweep of {n} points: {total / per:.2f} ms a sweep (CPU), "
          f"{n * args.repeat / total * 1e9:.0f} runs/s")  # fmt: skip
    print(f"{'stage':52s} {'ms/sweep':>9s} {'µs/point':>9s} {'share':>6s}")
    for depth, label, _, _ in STAGES:
        if label in acc:
            ms = acc[label] / per
            print(f"{'  ' * depth + label:52s} {ms:9.2f} {ms * 1e3 / n:9.1f} "
                  f"{acc[label] / total:6.1%}")  # fmt: skip
    rest = total - kernel
    print(f"{'outside the kernel':52s} {rest / per:9.2f} {rest / per * 1e3 / n:9.1f} "
          f"{rest / total:6.1%}")  # fmt: skip


if __name__ == "__main__":
    main()
