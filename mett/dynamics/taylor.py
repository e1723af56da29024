"""Compiled adaptive Taylor-series integrator, generated from a model's own right-hand side.

Every model of :mod:`mett.dynamics` writes its equations once, as plain arithmetic
(``_rhs_into(t, y, p, out)`` and ``_events_into``). This module *traces* those functions with
symbolic stand-ins for ``y`` and ``p``: each ``+ − × ÷``, ``sqrt``, ``sin``/``cos`` becomes a node
of an expression graph (equal sub-expressions are shared, sub-expressions of the parameters alone
are computed once per step). From the graph it writes, for one fixed order p, the recurrences of
automatic differentiation for the Taylor coefficients of every intermediate quantity (Jorba &
Zou 2005, §2):

    (a b)_k = Σ_{j=0}^{k} a_j b_{k−j},     (a/b)_k = (a_k − Σ_{j=1}^{k} b_j (a/b)_{k−j}) / b_0,
    (√a)_k = (a_k − Σ_{j=1}^{k−1} c_j c_{k−j}) / (2 c_0),
    (sin a)_k = (1/k) Σ_{j=1}^{k} j a_j (cos a)_{k−j},   (cos a)_k = −(1/k) Σ_{j=1}^{k} j a_j (sin a)_{k−j},
    y_{k+1} = f_k / (k + 1),

unrolled into straight-line LLVM IR (each sum of products one chain of fused multiply-adds) and
compiled to machine code with llvmlite, which numba already depends on. The machine code is
cached in the user's own cache directory (:func:`cache_dir`), keyed by the IR, llvmlite's version,
the target and the CPU with its features, and loaded only after its owner, permissions and sha256
are checked (:func:`_native`). The integration loop is numba code compiled once for every model
(``cache=True``); it calls the model's jet through a function pointer, as :mod:`.dop853` calls
its right-hand sides.

Why not numba for the jet too: the recurrences written out for the gliding top at order 15 are
~1 800 statements; numba took ~100 s to compile them (LLVM: ~3 s), and the same recurrences as
loops over k ran 2-4x slower than the unrolled code (short loops of varying trip count).

Order and step size follow Jorba & Zou (2005, §3.2–3.3), as in heyoka (Biscani & Izzo 2021): for
a tolerance ε the order is p = ⌈−½ ln ε⌉ + 1 and the step

    h = ρ / e² · exp(−0.7 / (p − 1)),   ρ = min(‖y_{p−1}‖^{−1/(p−1)}, ‖y_p‖^{−1/p}),

where the norm is the maximum over the parts g of the state of |y_g,k| / max(scale_g, |y_g|):
a part is a physical vector of the model (its ``vectors``: the velocity, L, 3̂), measured by its
Euclidean length, or a lone component; ``scale`` is the model's typical magnitude per component
(the one that sets DOP853's absolute tolerance). So the truncation error of a vector is ≈ ε times
its length per step, and the steps do not depend on how the space frame is oriented. No step is
ever rejected: the Taylor polynomial of a step is known before its size is chosen. The
polynomials are kept, so the dense output is the solution itself, of order p. Events are located on the Taylor polynomials of
the event functions: a sign change over a step (tested at the end and at interior points) is
refined by safeguarded Newton iteration on that polynomial.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import math
import os
import stat
import tempfile
import threading
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from .._validate import MettWarning, warn

__all__ = [
    "STATUS_MESSAGES",
    "TaylorBatch",
    "TaylorDense",
    "TaylorKernel",
    "TaylorSolution",
    "UnsafeCacheWarning",
    "cache_dir",
    "kernel",
    "order_for",
    "propagate",
    "solve",
    "trace",
]

# --- tracing ----------------------------------------------------------------------------------


class _Graph:
    """Expression DAG; node = (op, a, b, value). Hash-consing shares equal sub-expressions."""

    def __init__(self, params: np.ndarray | None = None) -> None:
        self.nodes: list[tuple[str, int, int, float]] = []
        self._index: dict[tuple, int] = {}
        self.params = params
        # decisions on the parameters alone (a model may branch on an option, e.g. a Contensou
        # radius > 0): (op, a, b, outcome), re-checked for the parameters of every later run
        self.guards: list[tuple[str, int, int, bool]] = []

    def node(self, op: str, a: int = -1, b: int = -1, value: float = 0.0) -> _Sym:
        if op in ("add", "mul") and a > b:  # commutative: one key
            a, b = b, a
        key = (op, a, b, value)
        i = self._index.get(key)
        if i is None:
            i = len(self.nodes)
            self.nodes.append(key)
            self._index[key] = i
        return _Sym(self, i)

    def const(self, value: float) -> _Sym:
        return self.node("const", value=float(value))


class _Sym:
    """A traced value: arithmetic on it records nodes in its graph."""

    __slots__ = ("g", "i")

    def __init__(self, g: _Graph, i: int) -> None:
        self.g, self.i = g, i

    def _w(self, other: Any) -> _Sym:
        if isinstance(other, _Sym):
            return other
        if isinstance(other, (int, float, np.floating, np.integer)):
            return self.g.const(float(other))
        raise TypeError(f"cannot trace an operation with {type(other).__name__}")

    def __add__(self, o):
        return self.g.node("add", self.i, self._w(o).i)

    __radd__ = __add__

    def __sub__(self, o):
        return self.g.node("sub", self.i, self._w(o).i)

    def __rsub__(self, o):
        return self.g.node("sub", self._w(o).i, self.i)

    def __mul__(self, o):
        return self.g.node("mul", self.i, self._w(o).i)

    __rmul__ = __mul__

    def __truediv__(self, o):
        return self.g.node("div", self.i, self._w(o).i)

    def __rtruediv__(self, o):
        return self.g.node("div", self._w(o).i, self.i)

    def __neg__(self):
        return self.g.node("neg", self.i)

    def __pos__(self):
        return self

    def __pow__(self, e):
        if isinstance(e, (int, float)) and float(e) == 0.5:
            return self.sqrt()
        if isinstance(e, (int, float)) and float(e).is_integer() and 1 <= e <= 8:
            out = self
            for _ in range(int(e) - 1):
                out = out * self
            return out
        if isinstance(e, (int, float)) and float(e) == -0.5:
            return 1.0 / self.sqrt()
        if isinstance(e, (int, float)) and float(e) == 1.5:
            return self * self.sqrt()
        raise TypeError(f"cannot trace the power {e!r} (only 0.5, ±0.5, 1.5 and 1..8)")

    def sqrt(self):
        return self.g.node("sqrt", self.i)

    def _sincos(self) -> tuple[_Sym, _Sym]:
        # a pair: each one's recurrence uses the other's lower coefficients
        s = self.g.node("sin", self.i)
        c = self.g.node("cos", self.i)
        return s, c

    def sin(self):
        return self._sincos()[0]

    def cos(self):
        return self._sincos()[1]

    def __bool__(self):
        vals = _scalar_values(self.g.nodes, self.g.params)
        if vals is None or self.i not in vals:
            raise TypeError("a traced right-hand side cannot branch on state values")
        return self._compare(0.0, "ne")

    def _compare(self, other, op):
        o = self._w(other)
        vals = _scalar_values(self.g.nodes, self.g.params)
        if vals is None or self.i not in vals or o.i not in vals:
            raise TypeError("a traced right-hand side cannot branch on state values (comparison)")
        outcome = bool(_COMPARE[op](vals[self.i], vals[o.i]))
        self.g.guards.append((op, self.i, o.i, outcome))
        return outcome

    def __lt__(self, o):
        return self._compare(o, "lt")

    def __le__(self, o):
        return self._compare(o, "le")

    def __gt__(self, o):
        return self._compare(o, "gt")

    def __ge__(self, o):
        return self._compare(o, "ge")

    def __eq__(self, o):
        return self._compare(o, "eq")

    def __ne__(self, o):
        return self._compare(o, "ne")

    __hash__ = object.__hash__

    # numpy's ufuncs (np.sin, np.sqrt, …) on an object call the method of the same name
    def __array_ufunc__(self, ufunc, method, *inputs, **kwargs):
        if method == "__call__" and len(inputs) == 1 and ufunc.__name__ in ("sin", "cos", "sqrt"):
            return getattr(inputs[0], ufunc.__name__)()
        return NotImplemented


class _Out:
    """Stands in for the ``out`` buffer of a traced ``*_into`` function."""

    def __init__(self, g: _Graph) -> None:
        self.g = g
        self.items: dict[int, _Sym] = {}

    def __setitem__(self, k: int, v: Any) -> None:
        self.items[int(k)] = v if isinstance(v, _Sym) else self.g.const(float(v))


@dataclass(frozen=True)
class _Traced:
    """The graph of one model: state size, outputs (derivatives), event outputs."""

    nodes: tuple[tuple[str, int, int, float], ...]
    n_state: int
    n_params: int
    rhs: tuple[int, ...]
    events: tuple[int, ...]
    time: int
    guards: tuple[tuple[str, int, int, bool], ...] = ()
    lengths: tuple[tuple[int, ...], ...] = ()

    def admits(self, params: ArrayLike) -> bool:
        """Whether ``params`` take the branches of the parameters this graph was traced with."""
        if not self.guards:
            return True
        vals = _scalar_values(self.nodes, np.asarray(params, dtype=float))
        return all(bool(_COMPARE[op](vals[a], vals[b])) == out for op, a, b, out in self.guards)


_COMPARE = {
    "lt": lambda a, b: a < b,
    "le": lambda a, b: a <= b,
    "gt": lambda a, b: a > b,
    "ge": lambda a, b: a >= b,
    "eq": lambda a, b: a == b,
    "ne": lambda a, b: a != b,
}
_SCALAR_OPS = {
    "add": lambda a, b: a + b,
    "sub": lambda a, b: a - b,
    "mul": lambda a, b: a * b,
    "div": lambda a, b: a / b if b != 0.0 else (math.copysign(math.inf, a) if a else math.nan),
    "neg": lambda a, b: -a,
    "sqrt": lambda a, b: math.sqrt(a) if a >= 0.0 else math.nan,
    "sin": lambda a, b: math.sin(a),
    "cos": lambda a, b: math.cos(a),
}


def _scalar_values(nodes: Sequence[tuple], params: np.ndarray | None) -> dict[int, float] | None:
    """Values of the nodes that depend on the parameters alone (None without parameters)."""
    if params is None:
        return None
    vals: dict[int, float] = {}
    for i, (op, a, b, v) in enumerate(nodes):
        if op == "par":
            vals[i] = float(params[a])
        elif op == "const":
            vals[i] = v
        elif op in _SCALAR_OPS and a in vals and (b < 0 or b in vals):
            vals[i] = _SCALAR_OPS[op](vals[a], vals[b] if b >= 0 else 0.0)
    return vals


def trace(
    rhs_into: Callable,
    events: Sequence[Callable],
    n_state: int,
    n_params: int,
    params: ArrayLike | None = None,
    lengths: Sequence[Sequence[int]] = (),
) -> _Traced:
    """Trace a model's ``rhs_into(t, y, p, out)`` and event functions ``fn(t, y, p)`` into one
    graph (shared sub-expressions are computed once). With ``params``, comparisons of the
    parameters alone are decided for those values and kept as the graph's guards.

    ``lengths``: groups of state components whose Euclidean length the equations conserve
    exactly, for every state (the rate of the group is perpendicular to it, e.g. 3̂̇ = ω × 3̂/|3̂|).
    Every √(Σ y_i²) over such a group becomes the length at the start of the step, a number
    rather than a series (:func:`_freeze_lengths`)."""
    g = _Graph(None if params is None else np.asarray(params, dtype=float))
    y = [g.node("var", i) for i in range(n_state)]
    p = tuple(g.node("par", i) for i in range(n_params))
    t = g.node("time")
    out = _Out(g)
    rhs_into(t, y, p, out)
    if sorted(out.items) != list(range(n_state)):
        raise ValueError(
            f"the right-hand side wrote components {sorted(out.items)}, not 0..{n_state - 1}"
        )
    rhs = tuple(out.items[k].i for k in range(n_state))
    ev = []
    for fn in events:
        v = fn(t, y, p)
        ev.append((v if isinstance(v, _Sym) else g.const(float(v))).i)
    groups = tuple(tuple(int(i) for i in grp) for grp in lengths)
    nodes = _freeze_lengths(g.nodes, groups)
    return _Traced(nodes, n_state, n_params, rhs, tuple(ev), t.i, tuple(g.guards), groups)


def _freeze_lengths(
    nodes: list[tuple[str, int, int, float]], groups: tuple[tuple[int, ...], ...]
) -> tuple[tuple[str, int, int, float], ...]:
    """The nodes with every √(Σ_{i ∈ G} y_i²) of a group G of ``groups`` replaced by
    ("len", index of G): the length of G at the start of the step.

    Exact for the Taylor coefficients: if the equations conserve |y_G| for every state, then
    freezing |y_G| at its value n0 at the start of a step gives equations that still conserve
    |y_G| (the rates are unchanged on the sphere |y_G| = n0), so both systems have the same
    solution through the step's initial state, hence the same Taylor polynomial. The length
    then costs one square root a step instead of the series of a square root and of the
    quotients y_i/|y_G| (for the gliding top, 7 of its 32 series products and quotients).
    """
    nodes = list(nodes)
    if not groups:
        return tuple(nodes)
    var_of = {i: a for i, (op, a, _, _) in enumerate(nodes) if op == "var"}

    def squares(i: int) -> list[int] | None:
        """The variables of a sum of squares y_a² + y_b² + ... (None: not one)."""
        op, a, b, _ = nodes[i]
        if op == "add":
            left, right = squares(a), squares(b)
            return None if left is None or right is None else left + right
        if op == "mul" and a == b and a in var_of:
            return [var_of[a]]
        return None

    wanted = {tuple(sorted(grp)): k for k, grp in enumerate(groups)}
    for i, (op, a, _, _) in enumerate(nodes):
        if op == "sqrt":
            found = squares(a)
            k = None if found is None else wanted.get(tuple(sorted(found)))
            if k is not None and len(set(found)) == len(found):
                nodes[i] = ("len", k, -1, 0.0)
    return tuple(nodes)


def _live(tr: _Traced) -> list[int]:
    """Indices of the nodes the outputs need, in creation (= topological) order."""
    need: set[int] = set()
    stack = list(tr.rhs) + list(tr.events)
    while stack:
        i = stack.pop()
        if i in need:
            continue
        need.add(i)
        op, a, b, _ = tr.nodes[i]
        if op in ("sin", "cos"):  # the recurrence of each needs the other
            stack.append(tr.nodes.index(("cos" if op == "sin" else "sin", a, -1, 0.0)))
        if op not in ("var", "par", "const", "time", "len"):
            stack.extend(x for x in (a, b) if x >= 0)
    return sorted(need)


def _classify(tr: _Traced) -> tuple[list[int], dict[int, bool]]:
    """Live nodes (topological order) and which of them depend on the parameters only."""
    live = _live(tr)
    scalar: dict[int, bool] = {}
    for i in live:
        op, a, b, _ = tr.nodes[i]
        if op in ("par", "const", "len"):
            scalar[i] = True
        elif op in ("var", "time"):
            scalar[i] = False
        else:
            scalar[i] = all(scalar[x] for x in (a, b) if x >= 0)
    return live, scalar


def _hex(x: float) -> str:
    """An exact LLVM double literal."""
    return f"0x{int(np.float64(x).view(np.uint64)):016X}"


def _norm_groups(vectors: Sequence[Sequence[int]], n_state: int) -> tuple[tuple[int, ...], ...]:
    """The components of the step-size norm grouped into vectors: each of ``vectors`` (index
    tuples of a model's state that form one physical vector, e.g. L or 3̂) and every other
    component alone. A vector's truncation error is measured against its length, not against
    each component: the components of L or 3̂ along the axes of the space frame can be small only
    because of how the frame happens to be oriented, and holding each of them to ε of itself
    costs steps that no frame-independent quantity needs (Jorba & Zou 2005 and heyoka use the
    norm of the whole state)."""
    seen: set[int] = set()
    groups = []
    for v in vectors:
        v = tuple(int(i) for i in v)
        if not v or seen & set(v) or not all(0 <= i < n_state for i in v):
            raise ValueError(f"vectors must be disjoint index tuples into the state; got {vectors}")
        seen |= set(v)
        groups.append(v)
    return (*groups, *((i,) for i in range(n_state) if i not in seen))


class _IR:
    """Straight-line LLVM IR of the jet of one traced model at one order, for ``lanes`` states.

    The function is ``jet(double* t0, double* y, double* p, double* X)``; with W lanes every value
    is a ``<W x double>`` vector and the arrays are lane-minor: ``y[i W + l]``, ``p[j W + l]``,
    ``X[(r (p+1) + k) W + l]`` (W = 1: plain doubles). Rows r of X: the state, then the events.
    Several trajectories at once (``lanes`` > 1) cost little more than one: the same instructions
    on SIMD registers (the batch mode of heyoka, Biscani & Izzo 2021, does the same).
    """

    FLAGS = "contract"  # lets LLVM fuse a*b + c into an FMA; no reassociation

    def __init__(
        self, tr: _Traced, order: int, name: str, lanes: int = 1, vectors: tuple = ()
    ) -> None:
        self.tr, self.order, self.name, self.W = tr, order, name, lanes
        self.vectors = _norm_groups(vectors, tr.n_state)
        self.T = "double" if lanes == 1 else f"<{lanes} x double>"
        self.suffix = "f64" if lanes == 1 else f"v{lanes}f64"
        self.lines: list[str] = []
        self.n = 0
        self.reciprocals: set[int] = set()
        live, scalar = _classify(tr)
        self.live, self.scalar = live, scalar
        self.series = {i: f"n{i}" for i in live if not scalar[i]}
        self.emit()

    def c(self, x: float) -> str:
        """A constant of the value type (a splat vector for several lanes)."""
        if self.W == 1:
            return _hex(x)
        return "<" + ", ".join([f"double {_hex(x)}"] * self.W) + ">"

    def tmp(self) -> str:
        self.n += 1
        return f"%t{self.n}"

    def op(self, ins: str, a: str, b: str) -> str:
        t = self.tmp()
        self.lines.append(f"{t} = {ins} {self.FLAGS} {self.T} {a}, {b}")
        return t

    def sum(self, terms: list[str]) -> str:
        """Balanced-tree sum: log2(n) dependent additions instead of n."""
        if not terms:
            return self.c(0.0)
        while len(terms) > 1:
            nxt = [self.op("fadd", terms[j], terms[j + 1]) for j in range(0, len(terms) - 1, 2)]
            if len(terms) % 2:
                nxt.append(terms[-1])
            terms = nxt
        return terms[0]

    def dot(self, pairs: list[tuple[str, str]]) -> str:
        """Σ a b over ``pairs`` as one chain of multiply-adds, each fused into an FMA. Measured
        on the gliding top's jet at order 15: 5 % faster than a balanced tree of products (whose
        products mostly stay separate multiplications) or 2-4 interleaved chains; the chains'
        latency hides behind the other nodes' work."""
        if not pairs:
            return self.c(0.0)
        acc = self.op("fmul", *pairs[0])
        for a, b in pairs[1:]:
            acc = self.op("fadd", acc, self.op("fmul", a, b))
        return acc

    def s(self, i: int) -> str:
        return f"%s{i}"

    def v(self, i: int, k: int) -> str:
        """Coefficient k of node i as an operand (scalars: their value at k = 0, else 0)."""
        if self.scalar[i]:
            return self.s(i) if k == 0 else self.c(0.0)
        op, a, _, _ = self.tr.nodes[i]
        if op == "var":
            return f"%y{a}_{k}"
        return f"%{self.series[i]}_{k}"

    def ptr(self, base: str, idx: int) -> str:
        g = self.tmp()
        self.lines.append(
            f"{g} = getelementptr inbounds double, double* {base}, i64 {idx * self.W}"
        )
        if self.W == 1:
            return g
        gv = self.tmp()
        self.lines.append(f"{gv} = bitcast double* {g} to {self.T}*")
        return gv

    def load(self, base: str, idx: int) -> str:
        g = self.ptr(base, idx)
        t = self.tmp()
        self.lines.append(f"{t} = load {self.T}, {self.T}* {g}, align 8")
        return t

    def store(self, value: str, idx: int) -> None:
        g = self.ptr("%X", idx)
        self.lines.append(f"store {self.T} {value}, {self.T}* {g}, align 8")

    def assign(self, name: str, value: str) -> None:
        # SSA has no copy instruction: x + 0 is folded away by LLVM (and exact for x ≠ −0)
        self.lines.append(f"{name} = fadd {self.T} {value}, {self.c(0.0)}")

    def call(self, fn: str, arg: str) -> str:
        return f"call {self.T} @llvm.{fn}.{self.suffix}({self.T} {arg})"

    def emit(self) -> None:
        tr, nodes, L, T = self.tr, self.tr.nodes, self.lines, self.T
        self.t0 = self.load("%t0", 0)
        for r in range(tr.n_state):
            self.assign(f"%y{r}_0", self.load("%y", r))
        for i in self.live:
            if not self.scalar[i]:
                continue
            op, a, b, val = nodes[i]
            if op == "len":  # a conserved length at the start of the step (_freeze_lengths)
                squares = [self.op("fmul", f"%y{r}_0", f"%y{r}_0") for r in tr.lengths[a]]
                L.append(f"{self.s(i)} = {self.call('sqrt', self.sum(squares))}")
            elif op == "par":
                self.assign(self.s(i), self.load("%p", a))
            elif op == "const":
                self.assign(self.s(i), self.c(val))
            elif op in ("add", "sub", "mul", "div"):
                ins = {"add": "fadd", "sub": "fsub", "mul": "fmul", "div": "fdiv"}[op]
                L.append(f"{self.s(i)} = {ins} {T} {self.s(a)}, {self.s(b)}")
            elif op == "neg":
                L.append(f"{self.s(i)} = fneg {T} {self.s(a)}")
            else:
                L.append(f"{self.s(i)} = {self.call(op, self.s(a))}")
        # orders 0 … p−1 of every node: enough for the state's coefficients 0 … p
        for k in range(self.order):
            for i in self.live:
                op, a, b, _ = nodes[i]
                if self.scalar[i] or op == "var":
                    continue
                self.node(i, op, a, b, k)
            # × 1/(k+1), not ÷ (k+1): 150 divisions a step at order 15 cost more than the
            # last bit of these coefficients is worth
            inv = self.c(1.0 / (k + 1))
            for comp, i in enumerate(tr.rhs):
                L.append(f"%y{comp}_{k + 1} = fmul {T} {self.v(i, k)}, {inv}")
        width = self.order + 1
        for e, i in enumerate(tr.events):
            # An event of the state alone (a component, e.g. cos θ = 3̂_z) has its polynomial of
            # degree p; any other is kept to degree p − 1: its coefficient p would need the
            # whole graph once more at the most expensive order (+10 % a step for the contact
            # event of the gliding top), and the term it drops is of the size of the step's
            # truncation error (|c_p| h^p ≈ ε by the step-size rule)
            for k in range(width):
                full = k < self.order or nodes[i][0] == "var"
                self.store(self.v(i, k) if full else self.c(0.0), (tr.n_state + e) * width + k)
        for r in range(tr.n_state):
            for k in range(width):
                self.store(f"%y{r}_{k}", r * width + k)
        self.norms()

    def norms(self) -> None:
        """The step-size norms of every lane (Jorba & Zou 2005, §3.3), with the jet:
        ``nrm[0] = max_g |y_g,p−1| / w_g``, ``nrm[1] = max_g |y_g,p| / w_g``, w_g = max(σ_g, ε|y_g|)
        over the vectors g of :func:`_norm_groups` with Euclidean lengths |·| (a lone component: its
        absolute value), for ``sig = (σ_i ... , ε)`` (σ_i already scaled by the tolerance ε;
        σ_g the largest over g). Computed with squares and one square root per norm."""
        L, T, p = self.lines, self.T, self.order
        eps = self.load("%sig", self.tr.n_state)
        eps2 = self.op("fmul", eps, eps)
        n1 = n2 = self.c(0.0)

        def nanmax(a: str, b: str) -> str:
            """max(a, b), NaN if either is NaN. llvm.maxnum alone ignores a NaN operand, so NaN
            coefficients gave a finite norm and one step to t_end that kept a NaN state; the
            explicit unordered test makes a NaN norm, which the integrator reports as a
            non-finite solution at the last finite step (llvm.maximum does the same, but older
            LLVMs cannot lower it for vectors on x86)."""
            m, nan, either, out = self.tmp(), self.tmp(), self.tmp(), self.tmp()
            B = "i1" if self.W == 1 else f"<{self.W} x i1>"
            L.append(f"{m} = call {T} @llvm.maxnum.{self.suffix}({T} {a}, {T} {b})")
            L.append(f"{nan} = fadd {T} {a}, {b}")  # NaN if either is
            L.append(f"{either} = fcmp uno {T} {a}, {b}")
            L.append(f"{out} = select {B} {either}, {T} {nan}, {T} {m}")
            return out

        def square_length(group: tuple[int, ...], k: int) -> str:
            return self.sum([self.op("fmul", f"%y{i}_{k}", f"%y{i}_{k}") for i in group])

        for group in self.vectors:
            sg = self.load("%sig", group[0])
            for i in group[1:]:
                sg = nanmax(sg, self.load("%sig", i))
            w2 = nanmax(self.op("fmul", sg, sg), self.op("fmul", eps2, square_length(group, 0)))
            inv = self.tmp()
            L.append(f"{inv} = fdiv {T} {self.c(1.0)}, {w2}")
            n1 = nanmax(n1, self.op("fmul", square_length(group, p - 1), inv))
            n2 = nanmax(n2, self.op("fmul", square_length(group, p), inv))
        for idx, val in ((0, n1), (1, n2)):
            r = self.tmp()
            L.append(f"{r} = {self.call('sqrt', val)}")
            g = self.ptr("%nrm", idx)
            L.append(f"store {T} {r}, {T}* {g}, align 8")

    def update(self) -> str:
        """IR of ``update_<name>(X, h, y)``: y_i = Σ_k X[i, k] h^k (Horner) for every lane."""
        T, width = self.T, self.order + 1
        body: list[str] = []
        saved, self.lines = self.lines, body
        h = self.load("%h", 0)
        for i in range(self.tr.n_state):
            acc = self.load("%X", i * width + self.order)
            for k in range(self.order - 1, -1, -1):
                prod = self.op("fmul", acc, h)
                acc = self.op("fadd", prod, self.load("%X", i * width + k))
            g = self.ptr("%yn", i)
            body.append(f"store {T} {acc}, {T}* {g}, align 8")
        self.lines = saved
        return (
            f"define void @{self.name}_update(double* noalias nocapture readonly %X, "
            "double* noalias nocapture readonly %h, double* noalias nocapture %yn) nounwind {\n"
            "entry:\n  " + "\n  ".join(body) + "\n  ret void\n}\n"
        )

    def node(self, i: int, op: str, a: int, b: int, k: int) -> None:
        L, v, lhs, T = self.lines, self.v, self.v(i, k), self.T
        nodes = self.tr.nodes
        if op == "time":
            self.assign(lhs, self.t0 if k == 0 else self.c(1.0 if k == 1 else 0.0))
        elif op in ("add", "sub"):
            ins = "fadd" if op == "add" else "fsub"
            L.append(f"{lhs} = {ins} {T} {v(a, k)}, {v(b, k)}")
        elif op == "neg":
            L.append(f"{lhs} = fneg {T} {v(a, k)}")
        elif op == "mul" and (self.scalar[a] or self.scalar[b]):
            sc, x = (a, b) if self.scalar[a] else (b, a)
            L.append(f"{lhs} = fmul {T} {self.s(sc)}, {v(x, k)}")
        elif op == "mul" and a == b:  # a square: half the products
            half = self.dot([(v(a, j), v(a, k - j)) for j in range((k + 1) // 2)])
            twice = self.op("fadd", half, half) if k > 0 else self.c(0.0)
            mid = self.op("fmul", v(a, k // 2), v(a, k // 2)) if k % 2 == 0 else self.c(0.0)
            L.append(f"{lhs} = fadd {T} {twice}, {mid}")
        elif op == "mul":
            self.assign(lhs, self.dot([(v(a, j), v(b, k - j)) for j in range(k + 1)]))
        elif op == "div" and self.scalar[b]:
            if k == 0:  # the value itself exactly as the model computes it
                L.append(f"{lhs} = fdiv {T} {v(a, 0)}, {self.s(b)}")
            else:  # the higher coefficients × 1/b: one division a step, not one per coefficient
                if b not in self.reciprocals:
                    self.reciprocals.add(b)
                    L.append(f"%q{b} = fdiv {T} {self.c(1.0)}, {self.s(b)}")
                L.append(f"{lhs} = fmul {T} {v(a, k)}, %q{b}")
        elif op == "div":
            if k == 0:
                L.append(f"{lhs} = fdiv {T} {v(a, 0)}, {v(b, 0)}")
                # one division per step, then products
                L.append(f"%r{i} = fdiv {T} {self.c(1.0)}, {v(b, 0)}")
            else:
                acc = self.dot([(v(b, j), v(i, k - j)) for j in range(1, k + 1)])
                num = self.op("fsub", v(a, k), acc)
                L.append(f"{lhs} = fmul {T} {num}, %r{i}")
        elif op == "sqrt":
            if k == 0:
                L.append(f"{lhs} = {self.call('sqrt', v(a, 0))}")
            else:
                if k == 1:
                    L.append(f"%r{i} = fdiv {T} {self.c(0.5)}, {v(i, 0)}")
                acc = self.dot([(v(i, j), v(i, k - j)) for j in range(1, k)])
                num = self.op("fsub", v(a, k), acc)
                L.append(f"{lhs} = fmul {T} {num}, %r{i}")
        elif op in ("sin", "cos"):
            if k == 0:
                L.append(f"{lhs} = {self.call(op, v(a, 0))}")
            else:
                partner = nodes.index(("cos" if op == "sin" else "sin", a, -1, 0.0))
                terms = [
                    self.op("fmul", self.op("fmul", self.c(float(j)), v(a, j)), v(partner, k - j))
                    for j in range(1, k + 1)
                ]
                scale = self.c((1.0 if op == "sin" else -1.0) / k)
                L.append(f"{lhs} = fmul {T} {self.sum(terms)}, {scale}")
        else:  # pragma: no cover - the tracer makes no other node
            raise AssertionError(op)

    def text(self) -> str:
        T, sfx = self.T, self.suffix
        decl = (
            "".join(f"declare {T} @llvm.{f}.{sfx}({T})\n" for f in ("sqrt", "sin", "cos", "fabs"))
            + f"declare {T} @llvm.maxnum.{sfx}({T}, {T})\n"
        )
        body = "\n  ".join(self.lines)
        return (
            f"{decl}define void @{self.name}(double* noalias nocapture readonly %t0, "
            "double* noalias nocapture readonly %y, double* noalias nocapture readonly %p, "
            "double* noalias nocapture %X, double* noalias nocapture readonly %sig, "
            "double* noalias nocapture %nrm) nounwind {\n"
            f"entry:\n  {body}\n  ret void\n}}\n" + self.update()
        )


# --- machine code -----------------------------------------------------------------------------

_LOCK = threading.Lock()
_ENGINES: list[Any] = []  # execution engines must outlive every pointer into their code
_ADDRESSES: dict[str, tuple[int, int]] = {}


class UnsafeCacheWarning(MettWarning):
    """The on-disk cache of compiled Taylor kernels is owned by another user or writable by
    others; mett did not use it (the kernel was compiled in memory) and wrote nothing there."""


# The cache holds machine code that is linked into the process and called, so it is read only
# from the user's own directory, only if that directory and the file belong to the user and
# nobody else can write them, and only after the object's sha256 and the build it was made for
# (IR, llvmlite, target, CPU and its features) match what this process would compile.
_CACHE_FORMAT = 1
_MAX_OBJECT_BYTES = 256 << 20  # far above any kernel (~0.1-2 MB); bounds what a bad file costs
_MAX_META_BYTES = 64 << 10
_UNSAFE_WARNED: set[str] = set()
_SOURCES: dict[str, str] = {}  # kernel name -> "loaded", "written" or "memory" (for tests)


def cache_dir() -> Path:
    """The directory of the on-disk cache of compiled Taylor kernels.

    Returns
    -------
    Path
        ``$METT_CACHE_DIR/taylor`` if ``METT_CACHE_DIR`` is set, else
        ``$XDG_CACHE_HOME/mett/taylor`` (an absolute ``XDG_CACHE_HOME`` only, as the XDG
        specification says), else ``~/.cache/mett/taylor``.

    Notes
    -----
    Never a shared directory: if this one cannot be created or written, kernels are compiled in
    memory for the process and not cached. mett creates it with mode 0700 and reads a kernel
    from it only if the directory and the file belong to the current user, nobody else can
    write them, and the file's sha256 and build record match (docs: reliability, "Caches and
    compiled code"); otherwise it compiles in memory and warns with
    :class:`UnsafeCacheWarning`.
    """
    base = os.environ.get("METT_CACHE_DIR")
    if base:
        return Path(base) / "taylor"
    xdg = os.environ.get("XDG_CACHE_HOME")
    root = Path(xdg) if xdg and os.path.isabs(xdg) else Path.home() / ".cache"
    return root / "mett" / "taylor"


def _unsafe(st: os.stat_result) -> str | None:
    """Why a cache entry with this ``stat`` may not be trusted, or None (POSIX owner and mode;
    on Windows, where neither means this, the user's profile directory is private by its ACL)."""
    if not hasattr(os, "geteuid"):  # pragma: no cover - Windows
        return None
    if st.st_uid != os.geteuid():
        return f"owned by uid {st.st_uid}, not by the current user ({os.geteuid()})"
    if st.st_mode & 0o022:
        return f"writable by group or others (mode {stat.S_IMODE(st.st_mode):04o})"
    return None


def _warn_unsafe(path: Path, why: str) -> None:
    if str(path) in _UNSAFE_WARNED:
        return
    _UNSAFE_WARNED.add(str(path))
    warn(
        f"not using the Taylor kernel cache {path}: it is {why}; compiling in memory instead "
        "(make the directory yours with mode 0700, or set METT_CACHE_DIR to a private one)",
        UnsafeCacheWarning,
    )


def _private_dir(d: Path) -> bool | None:
    """Create the cache directory ``d`` (and its parent ``mett`` directory) with mode 0700 if
    missing. True: ``d`` is safe to use; False: it exists but is unsafe (warned); None: it cannot
    be created (a read-only home: no cache, silently)."""
    try:
        d.parent.parent.mkdir(parents=True, exist_ok=True)
        for part in (d.parent, d):
            part.mkdir(mode=0o700, exist_ok=True)
        st = os.stat(d)
    except OSError:
        return None
    if not stat.S_ISDIR(st.st_mode):
        return None
    why = _unsafe(st)
    if why:
        _warn_unsafe(d, why)
        return False
    return True


def _read_private(path: Path, limit: int) -> bytes | None:
    """The bytes of ``path`` if it is a regular file of the current user that nobody else can
    write (checked on the open descriptor, so the file cannot be swapped between check and read)
    and at most ``limit`` bytes; None if it does not exist or cannot be read. Raises
    ``PermissionError`` with the reason if the file is not trustworthy."""
    try:
        # O_NOFOLLOW: a symbolic link fails (ELOOP); O_NONBLOCK: a FIFO cannot block the open
        flags = os.O_RDONLY | sum(
            getattr(os, f, 0) for f in ("O_NONBLOCK", "O_NOFOLLOW", "O_CLOEXEC")
        )
        fd = os.open(path, flags)
    except OSError:  # missing, a symbolic link (ELOOP), unreadable
        return None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            return None
        why = _unsafe(st)
        if why:
            raise PermissionError(why)
        if st.st_size > limit:
            return None
        with os.fdopen(fd, "rb", closefd=False) as f:
            return f.read(limit + 1)
    except PermissionError:
        raise
    except OSError:
        return None
    finally:
        os.close(fd)


def _write_atomic(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically: a new file of mode 0600 in the same directory
    (``O_EXCL``), fsynced, then renamed over ``path``; a reader sees the old file or the new
    one, never part of one. Raises ``OSError``; leaves no temporary file behind."""
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    with contextlib.suppress(OSError):  # make the rename itself durable (ext4: else an empty file)
        dfd = os.open(path.parent, os.O_RDONLY)
        try:
            os.fsync(dfd)
        finally:
            os.close(dfd)


def _build_id(ir: str, tm: Any) -> dict[str, Any]:
    """What the machine code of ``ir`` depends on besides the IR itself: recorded beside each
    cached object and compared before it is loaded (the CPU features too: virtual machines with
    the same CPU name can mask different instruction sets)."""
    import llvmlite
    import llvmlite.binding as llvm

    return {
        "format": _CACHE_FORMAT,
        "ir_sha256": hashlib.sha256(ir.encode()).hexdigest(),
        "llvmlite": llvmlite.__version__,
        "triple": tm.triple,
        "cpu": llvm.get_host_cpu_name(),
        "features": llvm.get_host_cpu_features().flatten(),
    }


def _cache_paths(name: str, build: dict[str, Any]) -> tuple[Path, Path]:
    """The object file of kernel ``name`` for ``build`` (:func:`_build_id`) and its record."""
    key = hashlib.sha256(json.dumps(build, sort_keys=True).encode()).hexdigest()[:24]
    obj = cache_dir() / f"{name}-{key}.o"
    return obj, obj.with_name(obj.name + ".json")


def _cached_object(obj_path: Path, meta_path: Path, build: dict[str, Any]) -> bytes | None:
    """The cached object if its record matches ``build`` and the object's sha256; None if it is
    missing, damaged or stale (to be rebuilt). Raises ``PermissionError`` if not trustworthy."""
    raw_meta = _read_private(meta_path, _MAX_META_BYTES)
    if raw_meta is None:
        return None
    try:
        meta = json.loads(raw_meta)
    except ValueError:
        return None
    if not isinstance(meta, dict) or any(meta.get(k) != v for k, v in build.items()):
        return None
    obj = _read_private(obj_path, _MAX_OBJECT_BYTES)
    if obj is None or hashlib.sha256(obj).hexdigest() != meta.get("sha256"):
        return None
    return obj


def _target_machine() -> Any:
    import llvmlite.binding as llvm

    llvm.initialize_native_target()
    llvm.initialize_native_asmprinter()
    target = llvm.Target.from_default_triple()
    return target.create_target_machine(
        opt=3,
        cpu=llvm.get_host_cpu_name(),
        features=llvm.get_host_cpu_features().flatten(),
        reloc="pic",
        codemodel="jitdefault",
    )


def _compile(ir: str, tm: Any) -> bytes:
    import llvmlite.binding as llvm

    mod = llvm.parse_assembly(ir)
    mod.verify()
    # llvmlite leaves the SLP vectorizer off; on: no faster here, and 10-100x the compile
    # time (80 s for the rolling top's jet)
    pb = llvm.create_pass_builder(tm, llvm.create_pipeline_tuning_options(speed_level=3))
    pb.getModulePassManager().run(mod, pb)
    return tm.emit_object(mod)


def _native(ir: str, name: str) -> tuple[int, int]:
    """Addresses of ``name`` and ``name_update`` compiled from ``ir`` (machine code cached in the
    user's :func:`cache_dir`, verified before it is loaded)."""
    import llvmlite.binding as llvm

    with _LOCK:
        if name in _ADDRESSES:
            return _ADDRESSES[name]
        tm = _target_machine()
        build = _build_id(ir, tm)
        obj_path, meta_path = _cache_paths(name, build)
        usable = _private_dir(obj_path.parent)
        obj = None
        if usable:
            try:
                obj = _cached_object(obj_path, meta_path, build)
            except PermissionError as exc:  # a planted or foreign file: neither used nor replaced
                _warn_unsafe(obj_path, str(exc))
                usable = False
        source = "loaded"
        if obj is None:
            obj = _compile(ir, tm)
            source = "memory"
            if usable:  # a damaged or stale entry is replaced; a failed write costs nothing
                meta = {**build, "name": name, "sha256": hashlib.sha256(obj).hexdigest()}
                try:
                    _write_atomic(obj_path, obj)  # the object first: its record vouches for it
                    _write_atomic(meta_path, json.dumps(meta, sort_keys=True).encode())
                    source = "written"
                except OSError:
                    pass
        ee = llvm.create_mcjit_compiler(llvm.parse_assembly(""), tm)
        ee.add_object_file(llvm.ObjectFileRef.from_data(obj))
        ee.finalize_object()
        addr = (ee.get_function_address(name), ee.get_function_address(f"{name}_update"))
        if not all(addr):  # pragma: no cover - an object without the kernel's symbols
            raise RuntimeError(f"compiled Taylor kernel {name} has no entry point")
        _ENGINES.append(ee)
        _ADDRESSES[name] = addr
        _SOURCES[name] = source
        return addr


def order_for(tol: float) -> int:
    """Taylor order p = ⌈−½ ln ε⌉ + 1 for a tolerance ε (Jorba & Zou 2005, §3.3), at least 6."""
    return max(math.ceil(-0.5 * math.log(tol)) + 1, 6)


def _kernel_source(
    tr: _Traced, order: int, label: str, lanes: int, vectors: tuple
) -> tuple[str, str]:
    """The symbol name and the LLVM IR of a kernel (``vectors`` normalised by _norm_groups)."""
    digest = hashlib.sha256(repr((tr, order, lanes, vectors)).encode()).hexdigest()[:16]
    name = f"mett_jet_{label}_{order}x{lanes}_{digest}".replace("-", "_")
    return name, _IR(tr, order, name, lanes, vectors).text()


class TaylorKernel:
    """The compiled jet of one model at one order, callable from the numba integration loop."""

    def __init__(
        self, tr: _Traced, order: int, label: str, lanes: int = 1, vectors: tuple = ()
    ) -> None:
        self.traced, self.order, self.lanes = tr, order, lanes
        self.n_state, self.n_events = tr.n_state, len(tr.events)
        self.vectors = _norm_groups(vectors, tr.n_state)
        self.name, ir = _kernel_source(tr, order, label, lanes, self.vectors)
        self.address = _native(ir, self.name)
        self.function = _JetAddress(self.address[0], _JET_SIG)
        self.update = _JetAddress(self.address[1], _UPDATE_SIG)


_KERNELS: dict[tuple, list[TaylorKernel]] = {}

_NO_TIMES = np.empty(0)
_HUGE = 4 << 20  # numpy asks for transparent huge pages for arrays of this many bytes and more


def kernel(
    rhs_into: Callable,
    events: Sequence[Callable],
    n_state: int,
    n_params: int,
    order: int,
    label: str = "model",
    lanes: int = 1,
    params: ArrayLike | None = None,
    vectors: Sequence[Sequence[int]] = (),
    lengths: Sequence[Sequence[int]] = (),
) -> TaylorKernel:
    """The :class:`TaylorKernel` of a model phase (``rhs_into`` and its event functions) at
    ``order`` for ``lanes`` trajectories at once; compiled once per process (and cached on disk).

    A right-hand side that branches on its parameters (an option of the model) is traced with
    ``params``; the kernel serves every parameter set that takes the same branches.
    ``vectors`` (``Model.vectors``) group the step-size norm; ``lengths``
    (``Model.conserved_lengths``) are the vectors whose length the equations conserve (see
    :func:`trace`).
    """
    try:  # a model's own tuples: found without normalising them (a sweep asks once per point)
        raw = (rhs_into, tuple(events), n_state, n_params, order, lanes, vectors, lengths)
        found = _KERNELS.get(raw, ())
    except TypeError:  # lists: unhashable
        raw, found = None, ()
    for k in found:
        if params is None or k.traced.admits(params):
            return k
    vectors = _norm_groups(vectors, n_state)
    lengths = tuple(tuple(int(i) for i in grp) for grp in lengths)
    key = (rhs_into, tuple(events), n_state, n_params, order, lanes, vectors, lengths)
    for k in _KERNELS.get(key, []):
        if params is None or k.traced.admits(params):
            break
    else:
        tr = trace(rhs_into, events, n_state, n_params, params, lengths)
        k = TaylorKernel(tr, order, label, lanes, vectors)
        _KERNELS.setdefault(key, []).append(k)
    if raw is not None and raw != key:
        _KERNELS.setdefault(raw, []).append(k)
    return k


# --- the integration loop (numba, compiled once for all models) -------------------------------

import numba  # noqa: E402  (only the integrator needs numba; tracing does not)
from numba import types  # noqa: E402

from .._numba_cache import install as _check_numba_cache  # noqa: E402
from . import _signals  # noqa: E402

_check_numba_cache()  # a damaged numba cache file of mett is a miss, not an error

_F8P = types.CPointer(types.float64)
_JET_SIG = types.void(_F8P, _F8P, _F8P, _F8P, _F8P, _F8P)
_JET_TYPE = types.FunctionType(_JET_SIG)
_UPDATE_SIG = types.void(_F8P, _F8P, _F8P)
_UPDATE_TYPE = types.FunctionType(_UPDATE_SIG)


class _JetAddress(types.WrapperAddressProtocol):
    """A compiled function (jet or update) as a numba first-class function value."""

    def __init__(self, address: int, sig: Any) -> None:
        self._address, self._sig = address, sig

    def __wrapper_address__(self) -> int:
        return self._address

    def signature(self) -> Any:
        return self._sig


COMPLETED, TERMINAL_EVENT, NON_FINITE, STEP_TOO_SMALL, MAX_STEPS = 0, 1, -1, -2, -3
_INTERRUPTED = -4  # a signal (Ctrl-C) stopped the loop: the caller raises, it is never a result
_POLL_EVERY = 32  # steps between polls for signals (mett.dynamics._signals)
STATUS_MESSAGES = {
    COMPLETED: "the end of the interval was reached",
    TERMINAL_EVENT: "a terminal event occurred",
    NON_FINITE: "the solution or its Taylor coefficients became non-finite",
    STEP_TOO_SMALL: "the step size fell below the resolution of t",
    MAX_STEPS: "the maximum number of steps was reached",
}


@numba.njit(cache=True, error_model="numpy")
def _poly(C, r, order, x):
    acc = C[r, order]
    for k in range(order - 1, -1, -1):
        acc = acc * x + C[r, k]
    return acc


@numba.njit(cache=True, error_model="numpy")
def _dpoly(C, r, order, x):
    acc = order * C[r, order]
    for k in range(order - 1, 0, -1):
        acc = acc * x + k * C[r, k]
    return acc


@numba.njit(cache=True, error_model="numpy")
def _root(C, r, order, a, b, fa, fb):
    """Zero of the polynomial row ``r`` of ``C`` in (a, b], where it changes sign."""
    x = b - fb * (b - a) / (fb - fa)
    for _ in range(100):
        if not (a < x < b):
            x = 0.5 * (a + b)
        fx = _poly(C, r, order, x)
        if fx == 0.0:
            return x
        if (fx < 0.0) == (fa < 0.0):
            a, fa = x, fx
        else:
            b, fb = x, fx
        if b - a <= 2e-16 * max(abs(a), abs(b)):
            break
        d = _dpoly(C, r, order, x)
        x = x - fx / d if d != 0.0 else 0.5 * (a + b)
    return b


_INTEGRATE_SIG = types.void(
    _JET_TYPE,
    _UPDATE_TYPE,
    types.float64[::1],  # t0 (W,)
    types.float64,  # t_end
    types.float64[:, ::1],  # y0 (n, W)
    types.float64[:, ::1],  # p (n_params, W)
    types.float64[:, ::1],  # sig (n + 1, W): ε σ_i, then ε
    types.float64,  # fac
    types.int64,  # order
    types.float64,  # max_step
    types.float64[::1],  # ev_dir
    types.float64[::1],  # ev_terminal: 1 stops the lane, 0 records the first zero
    types.int64,  # n_sub
    types.int64,  # room: steps this call may take
    types.float64[:, ::1],  # T (room + 1, W), or (2, W) without dense output
    types.float64[:, :, ::1],  # Y (room + 1, n, W), or (2, n, W)
    types.float64[:, :, :, ::1],  # C (room, rows, order + 1, W), or (1, ...): no dense output
    types.float64[:, ::1],  # first (W, n_ev): time of the first zero of each recording event
    types.float64[::1],  # tt: sample times, increasing
    types.float64[:, :, ::1],  # S (tt.size, n, W): the states at tt
    types.int64[:, ::1],  # info (W, 3): steps, event index, status
    types.int64[::1],  # stop: the signal flags of _signals.poll
)


@numba.njit(_INTEGRATE_SIG, cache=True, error_model="numpy")
def _integrate(
    jet, update, t0, t_end, y0, p, sig, fac, order, max_step, ev_dir, ev_terminal, n_sub, room,
    T, Y, C, first, tt, S, info, stop,
):  # fmt: skip
    """Taylor steps of W trajectories (lanes) at once, from ``t0`` towards ``t_end``.

    One jet call computes the coefficients and step-size norms of every lane (SIMD when W > 1),
    each lane then chooses its step and looks for events, and one update call advances every lane
    (a lane that is done gets h = 0, which leaves its state exactly as it is). Active lanes have
    all taken the same number of steps, so step m of lane l starts at ``T[m, l]`` in state
    ``Y[m, :, l]`` with coefficients ``C[m, :, :, l]`` (the jet writes them there). With a
    one-step ``C`` (no dense output) the coefficients of every step are written to ``C[0]`` (they
    stay in cache) and ``T[1]``, ``Y[1]`` hold the last state. A terminal event stops its lane at
    its zero; a recording one (``ev_terminal`` 0) notes its first zero in ``first`` (NaN: none).
    The states at the sample times ``tt`` go to ``S`` (left as they are after a lane stops).
    ``info[l]`` = (steps, index of the terminal event or −1, status), status as in
    :data:`STATUS_MESSAGES` (:data:`MAX_STEPS`: out of room, to be resumed). Every
    ``_POLL_EVERY`` steps it polls for signals (``stop``, :func:`._signals.poll`): a Ctrl-C stops
    the active lanes with status ``_INTERRUPTED``, which the caller turns into KeyboardInterrupt.
    """
    n, W = y0.shape
    n_ev = ev_dir.size
    dense = C.shape[0] >= room  # a slot per step; else one slot, reused
    n_tt = tt.size
    y = y0.copy()
    y_new = np.empty((n, W))
    t = t0.copy()
    h = np.zeros(W)
    nrm = np.empty((2, W))
    fa = np.empty(n_sub + 1)
    xs = np.empty(n_sub + 1)
    hit_of = np.full(W, -1)
    last_of = np.zeros(W, dtype=np.bool_)
    active = np.ones(W, dtype=np.bool_)
    next_sample = np.zeros(W, dtype=np.int64)
    sample_from = np.zeros(W, dtype=np.int64)
    bound = np.empty((n_ev, W))
    for lane in range(W):
        T[0, lane] = t0[lane]
        for i in range(n):
            Y[0, i, lane] = y0[i, lane]
        info[lane, 0] = 0
        info[lane, 1] = -1
        info[lane, 2] = COMPLETED
        while next_sample[lane] < n_tt and tt[next_sample[lane]] < t0[lane]:
            next_sample[lane] += 1
    it = 0
    while True:
        for lane in range(W):
            if active[lane] and t[lane] >= t_end:
                active[lane] = False
        if not active.any():
            break
        if it >= room:
            for lane in range(W):
                if active[lane]:
                    info[lane, 2] = MAX_STEPS
            break
        if it % _POLL_EVERY == 0 and _signals.poll(stop):
            for lane in range(W):
                if active[lane]:
                    info[lane, 2] = _INTERRUPTED
            break
        X = C[it] if dense else C[0]
        jet(t.ctypes, y.ctypes, p.ctypes, X.ctypes, sig.ctypes, nrm.ctypes)
        for lane in range(W):  # the steps
            h[lane] = 0.0
            if not active[lane]:
                continue
            n1, n2 = nrm[0, lane], nrm[1, lane]
            if not (n1 < math.inf and n2 < math.inf):
                info[lane, 2] = NON_FINITE
                active[lane] = False
                continue
            # ρ = min(n1^(−1/(p−1)), n2^(−1/p)) as exp of the smaller exponent: two logarithms
            # and one exponential cost less than two powers (which took 4 % of a batch's time)
            ln_rho = math.inf
            if n1 > 0.0:
                ln_rho = -math.log(n1) / (order - 1)
            if n2 > 0.0:
                ln_rho = min(ln_rho, -math.log(n2) / order)
            hl = min(math.exp(ln_rho) * fac, max_step)
            last_of[lane] = False
            if t[lane] + hl >= t_end:
                hl = t_end - t[lane]
                last_of[lane] = True
            elif not (t[lane] + hl > t[lane]):
                info[lane, 2] = STEP_TOO_SMALL
                active[lane] = False
                continue
            h[lane] = hl
        # events that cannot have a zero in [0, h]: |c_0| > Σ_{k≥1} |c_k| h^k, most steps of most
        # events; screened for all lanes at once (the loop over lanes vectorises)
        for e in range(n_ev):
            r = n + e
            for lane in range(W):
                bound[e, lane] = abs(X[r, order, lane])
            for k in range(order - 1, 0, -1):
                for lane in range(W):
                    bound[e, lane] = bound[e, lane] * h[lane] + abs(X[r, k, lane])
            for lane in range(W):
                bound[e, lane] = bound[e, lane] * h[lane] - abs(X[r, 0, lane])
        for lane in range(W):
            if not active[lane]:
                continue
            hl = h[lane]
            last = last_of[lane]
            # events: sign changes of the event polynomials over [0, h] at n_sub sample points
            # (evaluated together: independent Horner chains overlap in the pipeline); the
            # terminal ones first, since the first of their zeros ends the step
            hit = -1
            x_hit = hl
            for recording in range(2):
                for e in range(n_ev):
                    if (ev_terminal[e] == 0.0) != (recording == 1):
                        continue
                    if recording == 1 and first[lane, e] == first[lane, e]:
                        continue  # its first zero is known
                    if bound[e, lane] < 0.0:
                        continue  # screened out above
                    r = n + e
                    for q in range(n_sub + 1):
                        xs[q] = x_hit * q / n_sub
                    for q in range(n_sub + 1):
                        fa[q] = X[r, order, lane]
                    for k in range(order - 1, -1, -1):
                        c = X[r, k, lane]
                        for q in range(n_sub + 1):
                            fa[q] = fa[q] * xs[q] + c
                    for q in range(1, n_sub + 1):
                        f0, f1 = fa[q - 1], fa[q]
                        up = f0 < 0.0 and f1 >= 0.0
                        down = f0 > 0.0 and f1 <= 0.0
                        if (up and ev_dir[e] >= 0.0) or (down and ev_dir[e] <= 0.0):
                            x = xs[q]
                            if f1 != 0.0:
                                x = _root(X[:, :, lane], r, order, xs[q - 1], xs[q], f0, f1)
                            if recording == 1:
                                first[lane, e] = t[lane] + x
                            elif hit < 0 or x < x_hit:
                                x_hit = x
                                hit = e
                            break
            if hit >= 0:
                hl = x_hit
                last = False
            h[lane] = hl
            hit_of[lane] = hit
            last_of[lane] = last
            # the samples in this step, from its polynomial
            sample_from[lane] = next_sample[lane]
            t_stop = t_end if last else t[lane] + hl
            while next_sample[lane] < n_tt and tt[next_sample[lane]] <= t_stop:
                x = tt[next_sample[lane]] - t[lane]
                for i in range(n):
                    S[next_sample[lane], i, lane] = _poly(X[:, :, lane], i, order, x)
                next_sample[lane] += 1
        update(X.ctypes, h.ctypes, y_new.ctypes)
        slot = it + 1 if dense else 1
        for lane in range(W):
            if not active[lane]:
                continue
            finite = True
            for i in range(n):
                v = y_new[i, lane]
                finite = finite and (v - v == 0.0)
            if not finite:
                # the step is not kept: the run ends at its last finite state, and the samples
                # taken from this step's polynomial are dropped (as after any stop)
                info[lane, 2] = NON_FINITE
                active[lane] = False
                while next_sample[lane] > sample_from[lane]:
                    next_sample[lane] -= 1
                    for i in range(n):
                        S[next_sample[lane], i, lane] = math.nan
                continue
            for i in range(n):
                y[i, lane] = y_new[i, lane]
                Y[slot, i, lane] = y_new[i, lane]
            info[lane, 0] = it + 1
            t[lane] = t_end if last_of[lane] else t[lane] + h[lane]
            T[slot, lane] = t[lane]
            if hit_of[lane] >= 0:
                info[lane, 1] = hit_of[lane]
                info[lane, 2] = TERMINAL_EVENT
                active[lane] = False
        it += 1


@numba.njit(cache=True, error_model="numpy")
def _dense_many(T, C, n, tt, out):
    """``out[j]`` = the Taylor polynomial of the step containing ``tt[j]``, evaluated there."""
    m = C.shape[0]
    order = C.shape[2] - 1
    for j in range(tt.size):
        t = tt[j]
        lo, hi = 0, T.size
        while lo < hi:
            mid = (lo + hi) // 2
            if T[mid] <= t:
                lo = mid + 1
            else:
                hi = mid
        i = min(max(lo - 1, 0), m - 1)
        x = t - T[i]
        for c in range(n):
            acc = C[i, c, order]
            for k in range(order - 1, -1, -1):
                acc = acc * x + C[i, c, k]
            out[j, c] = acc


# --- Python side ------------------------------------------------------------------------------


class TaylorDense:
    """The piecewise Taylor-polynomial solution of a run (the interface of the DOP853 one).

    Segment ``i`` covers ``[t[i], t[i+1]]``: ``y(t) = Σ_k C[i, c, k] (t − t[i])^k`` for the state
    components ``c < n``; rows ``n…`` of ``C`` hold the event functions' polynomials. ``y`` holds
    the states at the breakpoints.
    """

    def __init__(self, t: np.ndarray, y: np.ndarray, C: np.ndarray) -> None:
        self.t = np.ascontiguousarray(t, dtype=float)
        self.y = np.ascontiguousarray(y, dtype=float)
        self.C = np.asarray(C, dtype=float)  # may be a strided view of a batch's buffer
        self.n = self.y.shape[1]

    @property
    def h(self) -> np.ndarray:
        """Step sizes."""
        return np.diff(self.t)

    @property
    def ts(self) -> np.ndarray:
        """The breakpoints (step times)."""
        return self.t

    @property
    def t_min(self) -> float:
        return float(self.t[0])

    @property
    def t_max(self) -> float:
        return float(self.t[-1])

    def __call__(self, t: ArrayLike) -> np.ndarray:
        """States at ``t``: shape (n,) for a scalar, (n, k) for k times."""
        tt = np.asarray(t, dtype=float)
        scalar = tt.ndim == 0
        tt = np.ascontiguousarray(np.atleast_1d(tt).ravel())
        if self.C.shape[0] == 0:
            out = np.repeat(self.y[:1], tt.size, axis=0).T
            return out[:, 0] if scalar else out
        out = np.empty((tt.size, self.n))
        _dense_many(self.t, self.C, self.n, tt, out)
        return out[0] if scalar else out.T

    def truncate(self, t_stop: float) -> TaylorDense:
        """The same solution ending at ``t_stop`` (inside its last kept step)."""
        k = max(int(np.searchsorted(self.t, t_stop, side="left")), 1)
        y = np.vstack([self.y[:k], self(t_stop)[None, :]])
        return TaylorDense(np.append(self.t[:k], t_stop), y, self.C[:k])


@dataclass
class TaylorSolution:
    """Result of :func:`solve`: the dense solution, status, and the terminal event if any."""

    dense: TaylorDense
    status: int
    message: str
    event_index: int
    order: int

    @property
    def t_steps(self) -> np.ndarray:
        return self.dense.t

    @property
    def n_steps(self) -> int:
        return self.dense.C.shape[0]


def _step_factor(order: int) -> float:
    """h/ρ of Jorba & Zou's step for order p: exp(−2) exp(−0.7/(p − 1)) (module docstring)."""
    return math.exp(-0.7 / (order - 1)) / math.e**2


def _batch_inputs(k: TaylorKernel, t_span, y0, params, scales, direction) -> tuple:
    """(t0, t_end, y0 (m, n), params (m, n_p), scales (m, n), directions) of a batch, checked."""
    t0, t_end = float(t_span[0]), float(t_span[1])
    Y0 = np.atleast_2d(np.asarray(y0, dtype=float))
    m, n = Y0.shape
    P = np.asarray(params, dtype=float)
    P = np.broadcast_to(P, (m, P.shape[-1]))
    SC = np.broadcast_to(np.ones(n) if scales is None else np.asarray(scales, dtype=float), (m, n))
    ev_dir = np.zeros(k.n_events) if direction is None else np.array(direction, dtype=float)
    if ev_dir.size != k.n_events:
        raise ValueError(f"direction needs one entry per event ({k.n_events}); got {ev_dir.size}")
    bad = [j for j in range(m) if not k.traced.admits(P[j])]
    if bad:
        raise ValueError(
            f"params[{bad[0]}] take other branches of the model than the kernel was traced for; "
            "get a kernel for them with kernel(..., params=...)"
        )
    return t0, t_end, Y0, P, SC, ev_dir


def solve(
    k: TaylorKernel,
    t_span: tuple[float, float],
    y0: ArrayLike,
    params: ArrayLike,
    *,
    scales: ArrayLike | None = None,
    direction: ArrayLike | None = None,
    tol: float | None = None,
    max_step: float = math.inf,
    max_steps: int = 10_000_000,
    n_sub: int = 4,
    safety: float = 0.9,
) -> list[TaylorSolution]:
    """Integrate trajectories ``y0`` (m, n) with parameters ``params`` (m, n_p) or (n_p,) forward
    over ``t_span``, ``k.lanes`` at a time, with the compiled jet ``k`` (from :func:`kernel`).

    ``direction``: per event function of the model, the crossing direction (−1, 0, +1); every
    event is terminal. ``scales``: typical magnitudes per component (default 1), (n,) or (m, n).
    ``tol=None`` takes the step of Jorba & Zou for the kernel's order; a tolerance takes the step
    whose last Taylor term is ``safety · tol`` of the scaled state.
    """
    t0, t_end, Y0, P, SC, ev_dir = _batch_inputs(k, t_span, y0, params, scales, direction)
    m, n = Y0.shape
    if tol is None:
        tol_scale, fac = 1.0, _step_factor(k.order)
    else:
        tol_scale, fac = tol, safety
    W, width, rows = k.lanes, k.order + 1, n + k.n_events
    parts: list[list[tuple]] = [[] for _ in range(m)]
    t_now, y_now = np.full(m, t0), Y0.copy()
    done = np.zeros(m, dtype=np.int64)
    result: list[tuple[int, int] | None] = [None] * m
    # The coefficients are the dense output, written once and kept: the first buffer is at least
    # _HUGE bytes, which numpy backs with transparent huge pages where the system has them (one
    # page fault per 2 MiB instead of per 4 KiB; measured: the thesis run 5.4 → 4.6 ms). Pages
    # are only made resident when written; a short run's coefficients are copied out (below).
    step_bytes = rows * width * W * 8
    pending, room = list(range(m)), max(1024, -(-_HUGE // step_bytes))
    stop = _signals.new_stop()
    while pending:
        resume = []
        for g in range(0, len(pending), W):
            group = pending[g : g + W]
            lanes = group + [group[0]] * (W - len(group))  # pad with a copy of the first
            rm = int(max(1, min(room, max_steps - done[group].min())))
            T, Yb = np.empty((rm + 1, W)), np.empty((rm + 1, n, W))
            C = np.empty((rm, rows, width, W))
            info = np.zeros((W, 3), dtype=np.int64)
            # a Ctrl-C stops the loop within _POLL_EVERY steps and is raised here
            with _signals.deferred_sigint(stop):
                _integrate(
                    k.function, k.update, np.ascontiguousarray(t_now[lanes]), t_end,
                    np.ascontiguousarray(y_now[lanes].T), np.ascontiguousarray(P[lanes].T),
                    np.ascontiguousarray(
                        np.vstack([tol_scale * SC[lanes].T, np.full(W, tol_scale)])
                    ),
                    fac, k.order, float(max_step), ev_dir, np.ones(k.n_events), n_sub, rm, T,
                    Yb, C, np.empty((W, k.n_events)), _NO_TIMES, np.empty((0, n, W)), info, stop,
                )  # fmt: skip
            _signals.raise_pending(stop)
            for lane, j in enumerate(group):
                steps, hit, status = (int(x) for x in info[lane])
                parts[j].append(
                    (T[1 : steps + 1, lane], Yb[1 : steps + 1, :, lane], C[:steps, :, :, lane])
                )
                done[j] += steps
                t_now[j], y_now[j] = T[steps, lane], Yb[steps, :, lane]
                if status == MAX_STEPS and done[j] < max_steps:
                    resume.append(j)
                else:
                    result[j] = (status, hit)
        pending, room = resume, room * 4
    out = []
    for j in range(m):
        status, hit = result[j]
        if len(parts[j]) == 1:  # the common case: views into the group's buffers, no copy
            t = np.concatenate([[t0], parts[j][0][0]])
            y = np.concatenate([Y0[j][None, :], parts[j][0][1]])
            C = parts[j][0][2]
            if C.nbytes * W < _HUGE // 4:  # a short run does not keep a large buffer alive
                C = C.copy()
        else:
            t = np.concatenate([[t0], *(q[0] for q in parts[j])])
            y = np.concatenate([Y0[j][None, :], *(q[1] for q in parts[j])])
            C = np.concatenate([q[2] for q in parts[j]]) if parts[j] else np.empty((0, rows, width))
        out.append(
            TaylorSolution(TaylorDense(t, y, C), status, STATUS_MESSAGES[status], hit, k.order)
        )
    return out


@dataclass
class TaylorBatch:
    """Result of :func:`propagate`, one row per trajectory (m of them).

    Attributes
    ----------
    t, y : ndarray, shapes (m,), (m, n)
        Where each run ended: ``t_end``, a terminal event's zero, or where it failed.
    status : ndarray of int, shape (m,)
        As in :data:`STATUS_MESSAGES`.
    event_index : ndarray of int, shape (m,)
        The terminal event that stopped the run, or −1.
    first : ndarray, shape (m, n_events)
        Time of the first zero of each recording (non-terminal) event; NaN if none, and for the
        terminal events.
    samples : ndarray, shape (m, len(t_eval), n)
        The states at ``t_eval``, from the Taylor polynomials; NaN after a run stopped.
    n_steps : ndarray of int, shape (m,)
    """

    t: np.ndarray
    y: np.ndarray
    status: np.ndarray
    event_index: np.ndarray
    first: np.ndarray
    samples: np.ndarray
    n_steps: np.ndarray


def propagate(
    k: TaylorKernel,
    t_span: tuple[float, float],
    y0: ArrayLike,
    params: ArrayLike,
    *,
    t_eval: ArrayLike = (),
    terminal: ArrayLike | None = None,
    scales: ArrayLike | None = None,
    direction: ArrayLike | None = None,
    max_step: float = math.inf,
    max_steps: int = 10_000_000,
    n_sub: int = 4,
) -> TaylorBatch:
    """Many trajectories, ``k.lanes`` at a time, keeping only what a sweep needs: the end states,
    the states at ``t_eval``, the first zero of every recording event, no dense output.

    The same steps as :func:`solve` (its ``tol=None`` step), but each step's coefficients are
    written over the previous step's, so they stay in the processor's cache: for a batch of many
    short runs this is the faster path (measured: 64 thesis-top runs of 4 s, 4 lanes, 1.6×).
    ``terminal``: per event, True to stop the run at its zero (default: all), False to record
    its first zero in ``first`` and go on. Other arguments as for :func:`solve`.
    """
    ev_term = np.ones(k.n_events) if terminal is None else np.array(terminal, dtype=float)
    if ev_term.size != k.n_events:
        raise ValueError(f"terminal needs one entry per event ({k.n_events}); got {ev_term.size}")
    tt = np.ascontiguousarray(np.asarray(t_eval, dtype=float).ravel())
    if tt.size and (np.any(np.diff(tt) < 0) or not np.all(np.isfinite(tt))):
        raise ValueError("t_eval must be finite and increasing")
    t0, t_end, Y0, P, SC, ev_dir = _batch_inputs(k, t_span, y0, params, scales, direction)
    m, n = Y0.shape
    fac = _step_factor(k.order)
    W, rows = k.lanes, n + k.n_events
    out = TaylorBatch(
        np.empty(m), np.empty((m, n)), np.empty(m, dtype=np.int64), np.empty(m, dtype=np.int64),
        np.full((m, k.n_events), np.nan), np.empty((m, tt.size, n)), np.empty(m, dtype=np.int64),
    )  # fmt: skip
    Y0, P, SC = (np.array(a, dtype=float, order="C") for a in (Y0, P, SC))  # writable copies
    stop = _signals.new_stop()
    with _signals.deferred_sigint(stop):  # a Ctrl-C stops the batch and is raised here
        _propagate_groups(
            k.function, k.update, t0, t_end, Y0, P, SC, fac, k.order, float(max_step), ev_dir,
            ev_term, n_sub, int(max_steps), tt, W, rows, out.t, out.y, out.status,
            out.event_index, out.first, out.samples, out.n_steps, stop,
        )  # fmt: skip
    _signals.raise_pending(stop)
    return out


@numba.njit(
    types.void(
        _JET_TYPE, _UPDATE_TYPE, types.float64, types.float64, types.float64[:, ::1],
        types.float64[:, ::1], types.float64[:, ::1], types.float64, types.int64, types.float64,
        types.float64[::1], types.float64[::1], types.int64, types.int64, types.float64[::1],
        types.int64, types.int64, types.float64[::1], types.float64[:, ::1], types.int64[::1],
        types.int64[::1], types.float64[:, ::1], types.float64[:, :, ::1], types.int64[::1],
        types.int64[::1],
    ),
    cache=True,
    error_model="numpy",
)  # fmt: skip
def _propagate_groups(
    jet, update, t0, t_end, Y0, P, SC, fac, order, max_step, ev_dir, ev_term, n_sub, max_steps,
    tt, W, rows, out_t, out_y, out_status, out_event, out_first, out_samples, out_steps, stop,
):  # fmt: skip
    """:func:`propagate`'s runs (rows of ``Y0``, ``P``, ``SC``), ``W`` lanes at a time (the last
    group padded with its first run), the results in the ``out_`` arrays: one call from Python
    for the whole batch (a call of the integration loop from Python costs ~0.1 ms of argument
    typing, as much as a thousandth of a batch of short runs)."""
    m, n = Y0.shape
    n_par, n_ev = P.shape[1], ev_dir.size
    T, Yb = np.empty((2, W)), np.empty((2, n, W))
    C = np.empty((1, rows, order + 1, W))
    first = np.empty((W, n_ev))
    S = np.empty((tt.size, n, W))
    info = np.zeros((W, 3), dtype=np.int64)
    t0s = np.full(W, t0)
    y0 = np.empty((n, W))
    p = np.empty((n_par, W))
    sig = np.empty((n + 1, W))
    for g in range(0, m, W):
        for lane in range(W):
            j = g + lane if g + lane < m else g
            for i in range(n):
                y0[i, lane] = Y0[j, i]
                sig[i, lane] = SC[j, i]
            sig[n, lane] = 1.0
            for i in range(n_par):
                p[i, lane] = P[j, i]
        first[:] = np.nan
        S[:] = np.nan
        _integrate(
            jet, update, t0s, t_end, y0, p, sig, fac, order, max_step, ev_dir, ev_term, n_sub,
            max_steps, T, Yb, C, first, tt, S, info, stop,
        )  # fmt: skip
        if stop[0] != 0:  # interrupted (a signal): the caller raises
            return
        for lane in range(min(W, m - g)):
            j = g + lane
            steps = info[lane, 0]
            slot = 1 if steps else 0
            out_t[j] = T[slot, lane]
            for i in range(n):
                out_y[j, i] = Yb[slot, i, lane]
            out_status[j], out_event[j], out_steps[j] = info[lane, 2], info[lane, 1], steps
            for e in range(n_ev):
                out_first[j, e] = first[lane, e]
            for q in range(tt.size):
                for i in range(n):
                    out_samples[j, q, i] = S[q, i, lane]
