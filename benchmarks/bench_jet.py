"""Benchmark: the Taylor jet alone, and what its instructions are.

For the gliding top (the thesis top's parameters) at one order and lane count: the operations of
the unrolled IR, how many of them repeat an earlier one (what common-subexpression elimination
over the whole jet could still remove), and the CPU time of one call of the jet emitted product
by product against the same jet with the products that share a factor interleaved (the default),
both compiled in this process and called alternately through ctypes, the minimum over each
batch of calls. The two must write the same bits; the script checks that first.

Run ``python benchmarks/bench_jet.py [--order 15] [--lanes 4] [--reps 600]``; it prints numbers
and asserts only that both emissions agree bit for bit.
"""

from __future__ import annotations

import argparse
import collections
import ctypes
import re
import time

import numpy as np

import mett
from mett.dynamics import MODELS, taylor
from mett.dynamics.taylor import _codegen, _llvm


def repeats(lines: list[str]) -> tuple[collections.Counter, int]:
    """Operations of the jet's IR and how many repeat an earlier one (operands renamed to their
    first occurrence; the −0 additions that stand for copies followed through)."""
    canon: dict[str, str] = {}
    seen: set[str] = set()
    ops: collections.Counter = collections.Counter()
    dup = 0
    for line in lines:
        new = re.sub(r"%[\w.]+", lambda m: canon.get(m.group(0), m.group(0)), line)
        m = re.match(r"(%[\w.]+) = (.*)$", new)
        if not m:
            continue
        lhs, rhs = m.groups()
        op = rhs.split()[0]
        copy = re.match(r"fadd (<[^>]*>|double) (%[\w.]+), .*0x8000000000000000", rhs)
        if copy:
            canon[lhs] = copy.group(2)
            continue
        ops[op] += 1
        mm = re.match(r"(fadd|fmul) (contract )?(<[^>]*>|double) (\S+), (.+)$", rhs)
        key = f"{mm.group(1)} {' '.join(sorted(mm.group(4, 5)))}" if mm else rhs
        if key in seen and op in ("fadd", "fmul", "fsub", "fdiv", "fneg"):
            dup += 1
        seen.add(key)
    return ops, dup


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--order", type=int, default=15)
    ap.add_argument("--lanes", type=int, default=4)
    ap.add_argument("--reps", type=int, default=600, help="alternating batches of 200 calls")
    args = ap.parse_args()
    order, W = args.order, args.lanes
    mdl = MODELS["gliding"]
    p = np.array(mdl.params(mett.presets.get("rutstam2013"), {}))
    y0 = np.asarray(mdl.initial(mett.State(theta=0.1, omega3=155.0), tuple(p)))
    tr = taylor.trace(mdl.rhs_into, [ev.fn for ev in mdl.events], 10, 7, p, mdl.conserved_lengths)
    vectors = _codegen._norm_groups(mdl.vectors, 10)
    fns = {}
    for inter in (False, True):
        name = f"bench_jet_{order}x{W}_{int(inter)}"
        ir = _codegen._IR(tr, order, name, W, vectors, interleave=inter)
        if inter:
            ops, dup = repeats(ir.lines)
            print(f"gliding top, order {order}, {W} lane(s): IR operations {dict(ops)}")
            print(f"  repeating an earlier one: {dup}; products emitted together: "
                  f"{list(ir.product_groups().values())}")  # fmt: skip
        addr = _llvm._native(ir.text(), name)[0]
        fns[inter] = ctypes.CFUNCTYPE(None, *[ctypes.c_void_p] * 6)(addr)
    t0, y = np.zeros(W), np.repeat(y0, W)
    pp, sig, nrm = np.repeat(p, W), np.full(11 * W, 1e-12), np.zeros(2 * W)
    X = {f: np.zeros((10 + len(tr.events)) * (order + 1) * W) for f in fns}
    ptrs = [a.ctypes.data for a in (t0, y, pp)]
    for f, fn in fns.items():
        fn(*ptrs, X[f].ctypes.data, sig.ctypes.data, nrm.ctypes.data)
    assert np.array_equal(X[False].view(np.uint64), X[True].view(np.uint64)), "bits differ"
    n, per = 200, {False: [], True: []}
    for rep in range(args.reps):
        for f in (False, True) if rep % 2 else (True, False):
            fn, args6 = fns[f], (*ptrs, X[f].ctypes.data, sig.ctypes.data, nrm.ctypes.data)
            t = time.thread_time_ns()
            for _ in range(n):
                fn(*args6)
            per[f].append((time.thread_time_ns() - t) / n)
    for f, label in ((False, "product by product"), (True, "interleaved (default)")):
        v = np.array(per[f])
        print(f"  {label:22s} µs a call: min {v.min() / 1e3:.3f}, 10th percentile "
              f"{np.percentile(v, 10) / 1e3:.3f}, median {np.median(v) / 1e3:.3f}")  # fmt: skip
    print(f"  load average {open('/proc/loadavg').read().split()[0]}")


if __name__ == "__main__":
    main()
