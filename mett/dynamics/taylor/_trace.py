"""The tracer of :mod:`mett.dynamics.taylor`: a model's plain-arithmetic ``rhs_into`` and event
functions, run on symbolic stand-ins, become one expression graph (:func:`trace`).

Pure Python and numpy: tracing imports neither numba nor llvmlite.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, overload

import numpy as np
from numpy.typing import ArrayLike

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


@overload
def _scalar_values(nodes: Sequence[tuple], params: np.ndarray) -> dict[int, float]: ...
@overload
def _scalar_values(nodes: Sequence[tuple], params: None) -> None: ...
@overload
def _scalar_values(
    nodes: Sequence[tuple], params: np.ndarray | None
) -> dict[int, float] | None: ...
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
            if found is None:
                continue
            k = wanted.get(tuple(sorted(found)))
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
