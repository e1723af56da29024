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

unrolled into straight-line LLVM IR (sums as balanced trees, so they do not form one long chain
of dependent additions) and compiled to machine code with llvmlite, which numba already depends
on. The machine code is cached on disk, keyed by the IR, the CPU and llvmlite's version. The
integration loop is numba code compiled once for every model (``cache=True``); it calls the
model's jet through a function pointer, as :mod:`.dop853` calls its right-hand sides.

Why not numba for the jet too: the recurrences written out for the gliding top at order 15 are
~1 800 statements; numba took ~100 s to compile them (LLVM: ~3 s), and the same recurrences as
loops over k ran 2-4x slower than the unrolled code (short loops of varying trip count).

Order and step size follow Jorba & Zou (2005, §3.2–3.3), as in heyoka (Biscani & Izzo 2021): for
a tolerance ε the order is p = ⌈−½ ln ε⌉ + 1 and the step

    h = ρ / e² · exp(−0.7 / (p − 1)),   ρ = min(‖y_{p−1}‖^{−1/(p−1)}, ‖y_p‖^{−1/p}),

where the norm is the maximum over the components scaled by σ_i = max(scale_i, |y_i|); ``scale``
is the model's typical magnitude per component (the one that sets DOP853's absolute tolerance),
so the truncation error of each component is ≈ ε σ_i per step. No step is ever rejected: the
Taylor polynomial of a step is known before its size is chosen. The polynomials are kept, so the
dense output is the solution itself, of order p. Events are located on the Taylor polynomials of
the event functions: a sign change over a step (tested at the end and at interior points) is
refined by safeguarded Newton iteration on that polynomial.
"""

from __future__ import annotations

import hashlib
import math
import os
import tempfile
import threading
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["TaylorDense", "TaylorKernel", "TaylorSolution", "kernel", "order_for", "solve"]

# --- tracing ----------------------------------------------------------------------------------


class _Graph:
    """Expression DAG; node = (op, a, b, value). Hash-consing shares equal sub-expressions."""

    def __init__(self) -> None:
        self.nodes: list[tuple[str, int, int, float]] = []
        self._index: dict[tuple, int] = {}

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
        raise TypeError("a traced right-hand side cannot branch on state values")

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


def trace(rhs_into: Callable, events_into: Callable | None, n_state: int, n_params: int) -> _Traced:
    """Trace a model's ``rhs_into(t, y, p, out)`` (and ``events_into``) into one graph."""
    g = _Graph()
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
    ev: tuple[int, ...] = ()
    if events_into is not None:
        eo = _Out(g)
        events_into(t, y, p, eo)
        ev = tuple(eo.items[k].i for k in sorted(eo.items))
    return _Traced(tuple(g.nodes), n_state, n_params, rhs, ev, t.i)


# --- code generation --------------------------------------------------------------------------


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
        if op not in ("var", "par", "const", "time"):
            stack.extend(x for x in (a, b) if x >= 0)
    return sorted(need)


def _classify(tr: _Traced) -> tuple[list[int], dict[int, bool]]:
    """Live nodes (topological order) and which of them depend on the parameters only."""
    live = _live(tr)
    scalar: dict[int, bool] = {}
    for i in live:
        op, a, b, _ = tr.nodes[i]
        if op in ("par", "const"):
            scalar[i] = True
        elif op in ("var", "time"):
            scalar[i] = False
        else:
            scalar[i] = all(scalar[x] for x in (a, b) if x >= 0)
    return live, scalar


def _hex(x: float) -> str:
    """An exact LLVM double literal."""
    return f"0x{int(np.float64(x).view(np.uint64)):016X}"


class _IR:
    """Straight-line LLVM IR of the jet of one traced model at one order."""

    FLAGS = "contract"  # lets LLVM fuse a*b + c into an FMA; no reassociation

    def __init__(self, tr: _Traced, order: int, name: str) -> None:
        self.tr, self.order, self.name = tr, order, name
        self.lines: list[str] = []
        self.n = 0
        live, scalar = _classify(tr)
        self.live, self.scalar = live, scalar
        self.series = {i: f"n{i}" for i in live if not scalar[i]}
        self.emit()

    def tmp(self) -> str:
        self.n += 1
        return f"%t{self.n}"

    def op(self, ins: str, a: str, b: str) -> str:
        t = self.tmp()
        self.lines.append(f"{t} = {ins} {self.FLAGS} double {a}, {b}")
        return t

    def sum(self, terms: list[str]) -> str:
        """Balanced-tree sum: log2(n) dependent additions instead of n."""
        if not terms:
            return "0.0"
        while len(terms) > 1:
            nxt = [self.op("fadd", terms[j], terms[j + 1]) for j in range(0, len(terms) - 1, 2)]
            if len(terms) % 2:
                nxt.append(terms[-1])
            terms = nxt
        return terms[0]

    def s(self, i: int) -> str:
        return f"%s{i}"

    def v(self, i: int, k: int) -> str:
        """Coefficient k of node i as an operand (scalars: their value at k = 0, else 0)."""
        if self.scalar[i]:
            return self.s(i) if k == 0 else "0.0"
        op, a, _, _ = self.tr.nodes[i]
        if op == "var":
            return f"%y{a}_{k}"
        return f"%{self.series[i]}_{k}"

    def load(self, ptr: str, idx: int) -> str:
        g, t = self.tmp(), self.tmp()
        self.lines.append(f"{g} = getelementptr inbounds double, double* {ptr}, i64 {idx}")
        self.lines.append(f"{t} = load double, double* {g}, align 8")
        return t

    def assign(self, name: str, value: str) -> None:
        # SSA has no copy instruction: x + 0.0 is folded away by LLVM (and exact for x ≠ −0)
        self.lines.append(f"{name} = fadd double {value}, 0.0")

    def emit(self) -> None:
        tr, nodes, L = self.tr, self.tr.nodes, self.lines
        unary = {"sqrt": "llvm.sqrt.f64", "sin": "llvm.sin.f64", "cos": "llvm.cos.f64"}
        for i in self.live:
            if not self.scalar[i]:
                continue
            op, a, b, val = nodes[i]
            if op == "par":
                self.assign(self.s(i), self.load("%p", a))
            elif op == "const":
                self.assign(self.s(i), _hex(val))
            elif op in ("add", "sub", "mul", "div"):
                ins = {"add": "fadd", "sub": "fsub", "mul": "fmul", "div": "fdiv"}[op]
                L.append(f"{self.s(i)} = {ins} double {self.s(a)}, {self.s(b)}")
            elif op == "neg":
                L.append(f"{self.s(i)} = fneg double {self.s(a)}")
            else:
                L.append(f"{self.s(i)} = call double @{unary[op]}(double {self.s(a)})")
        for r in range(tr.n_state):
            self.assign(f"%y{r}_0", self.load("%y", r))
        for k in range(self.order + 1):
            for i in self.live:
                op, a, b, _ = nodes[i]
                if self.scalar[i] or op == "var":
                    continue
                self.node(i, op, a, b, k)
            if k < self.order:
                for comp, i in enumerate(tr.rhs):
                    # × 1/(k+1), not ÷ (k+1): 150 divisions a step at order 15 cost more than
                    # the last bit of these coefficients is worth
                    L.append(
                        f"%y{comp}_{k + 1} = fmul double {self.v(i, k)}, {_hex(1.0 / (k + 1))}"
                    )
        width = self.order + 1
        for e, i in enumerate(tr.events):
            for k in range(width):
                self.store(self.v(i, k), (tr.n_state + e) * width + k)
        for r in range(tr.n_state):
            for k in range(width):
                self.store(f"%y{r}_{k}", r * width + k)

    def store(self, value: str, idx: int) -> None:
        g = self.tmp()
        self.lines.append(f"{g} = getelementptr inbounds double, double* %X, i64 {idx}")
        self.lines.append(f"store double {value}, double* {g}, align 8")

    def node(self, i: int, op: str, a: int, b: int, k: int) -> None:
        L, v, lhs = self.lines, self.v, self.v(i, k)
        nodes = self.tr.nodes
        if op == "time":
            self.assign(lhs, "%t0" if k == 0 else ("1.0" if k == 1 else "0.0"))
        elif op in ("add", "sub"):
            ins = "fadd" if op == "add" else "fsub"
            L.append(f"{lhs} = {ins} double {v(a, k)}, {v(b, k)}")
        elif op == "neg":
            L.append(f"{lhs} = fneg double {v(a, k)}")
        elif op == "mul" and (self.scalar[a] or self.scalar[b]):
            sc, x = (a, b) if self.scalar[a] else (b, a)
            L.append(f"{lhs} = fmul double {self.s(sc)}, {v(x, k)}")
        elif op == "mul" and a == b:  # a square: half the products
            half = self.sum([self.op("fmul", v(a, j), v(a, k - j)) for j in range((k + 1) // 2)])
            twice = self.op("fadd", half, half) if k > 0 else "0.0"
            mid = self.op("fmul", v(a, k // 2), v(a, k // 2)) if k % 2 == 0 else "0.0"
            L.append(f"{lhs} = fadd double {twice}, {mid}")
        elif op == "mul":
            self.assign(
                lhs, self.sum([self.op("fmul", v(a, j), v(b, k - j)) for j in range(k + 1)])
            )
        elif op == "div" and self.scalar[b]:
            L.append(f"{lhs} = fdiv double {v(a, k)}, {self.s(b)}")
        elif op == "div":
            if k == 0:
                L.append(f"{lhs} = fdiv double {v(a, 0)}, {v(b, 0)}")
                L.append(f"%r{i} = fdiv double 1.0, {v(b, 0)}")  # one division, then products
            else:
                acc = self.sum([self.op("fmul", v(b, j), v(i, k - j)) for j in range(1, k + 1)])
                num = self.op("fsub", v(a, k), acc)
                L.append(f"{lhs} = fmul double {num}, %r{i}")
        elif op == "sqrt":
            if k == 0:
                L.append(f"{lhs} = call double @llvm.sqrt.f64(double {v(a, 0)})")
            else:
                if k == 1:
                    L.append(f"%r{i} = fdiv double 0.5, {v(i, 0)}")
                acc = self.sum([self.op("fmul", v(i, j), v(i, k - j)) for j in range(1, k)])
                num = self.op("fsub", v(a, k), acc)
                L.append(f"{lhs} = fmul double {num}, %r{i}")
        elif op in ("sin", "cos"):
            if k == 0:
                L.append(f"{lhs} = call double @llvm.{op}.f64(double {v(a, 0)})")
            else:
                partner = nodes.index(("cos" if op == "sin" else "sin", a, -1, 0.0))
                terms = [
                    self.op("fmul", self.op("fmul", _hex(float(j)), v(a, j)), v(partner, k - j))
                    for j in range(1, k + 1)
                ]
                acc = self.sum(terms)
                scale = _hex((1.0 if op == "sin" else -1.0) / k)
                L.append(f"{lhs} = fmul double {acc}, {scale}")
        else:  # pragma: no cover - the tracer makes no other node
            raise AssertionError(op)

    def text(self) -> str:
        body = "\n  ".join(self.lines)
        return (
            "declare double @llvm.sqrt.f64(double)\n"
            "declare double @llvm.sin.f64(double)\n"
            "declare double @llvm.cos.f64(double)\n"
            f"define void @{self.name}(double %t0, double* noalias nocapture readonly %y, "
            "double* noalias nocapture readonly %p, double* noalias nocapture %X) nounwind {\n"
            f"entry:\n  {body}\n  ret void\n}}\n"
        )


# --- machine code -----------------------------------------------------------------------------

_LOCK = threading.Lock()
_ENGINES: list[Any] = []  # execution engines must outlive every pointer into their code
_ADDRESSES: dict[str, int] = {}


def _cache_dir() -> Path:
    base = os.environ.get("METT_CACHE_DIR")
    if base:
        return Path(base) / "taylor"
    xdg = os.environ.get("XDG_CACHE_HOME")
    return (Path(xdg) if xdg else Path.home() / ".cache") / "mett" / "taylor"


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


def _native(ir: str, name: str) -> int:
    """Address of function ``name`` compiled from ``ir`` (machine code cached on disk)."""
    import llvmlite
    import llvmlite.binding as llvm

    with _LOCK:
        if name in _ADDRESSES:
            return _ADDRESSES[name]
        tm = _target_machine()
        key = hashlib.sha256(
            "\0".join([ir, llvm.get_host_cpu_name(), tm.triple, llvmlite.__version__]).encode()
        ).hexdigest()[:24]
        obj = None
        dirs = [_cache_dir(), Path(tempfile.gettempdir()) / "mett-cache" / "taylor"]
        for d in dirs:
            path = d / f"{name}-{key}.o"
            if path.exists():
                obj = path.read_bytes()
                break
        if obj is None:
            mod = llvm.parse_assembly(ir)
            mod.verify()
            # llvmlite leaves the SLP vectorizer off; on: no faster here, and 10-100x the compile
            # time (80 s for the rolling top's jet)
            pb = llvm.create_pass_builder(tm, llvm.create_pipeline_tuning_options(speed_level=3))
            pb.getModulePassManager().run(mod, pb)
            obj = tm.emit_object(mod)
            for d in dirs:  # best effort: a read-only home only costs a recompile
                try:
                    d.mkdir(parents=True, exist_ok=True)
                    tmp = d / f"{name}-{key}.{os.getpid()}.tmp"
                    tmp.write_bytes(obj)
                    os.replace(tmp, d / f"{name}-{key}.o")
                    break
                except OSError:
                    continue
        ee = llvm.create_mcjit_compiler(llvm.parse_assembly(""), tm)
        ee.add_object_file(llvm.ObjectFileRef.from_data(obj))
        ee.finalize_object()
        addr = ee.get_function_address(name)
        if not addr:  # pragma: no cover - a broken object file
            raise RuntimeError(f"compiled Taylor kernel {name} has no entry point")
        _ENGINES.append(ee)
        _ADDRESSES[name] = addr
        return addr


def order_for(tol: float) -> int:
    """Taylor order p = ⌈−½ ln ε⌉ + 1 for a tolerance ε (Jorba & Zou 2005, §3.3), at least 6."""
    return max(math.ceil(-0.5 * math.log(tol)) + 1, 6)


class TaylorKernel:
    """The compiled jet of one model at one order, callable from the numba integration loop."""

    def __init__(self, tr: _Traced, order: int, label: str) -> None:
        self.traced, self.order = tr, order
        self.n_state, self.n_events = tr.n_state, len(tr.events)
        digest = hashlib.sha256(repr((tr, order)).encode()).hexdigest()[:16]
        self.name = f"mett_jet_{label}_{order}_{digest}".replace("-", "_")
        ir = _IR(tr, order, self.name).text()
        self.address = _native(ir, self.name)
        self.function = _function_value(self.address)


_KERNELS: dict[tuple, TaylorKernel] = {}


def kernel(
    rhs_into: Callable,
    events_into: Callable | None,
    n_state: int,
    n_params: int,
    order: int,
    label: str = "model",
) -> TaylorKernel:
    """The :class:`TaylorKernel` of a model's ``rhs_into``/``events_into`` at ``order`` (cached)."""
    key = (rhs_into, events_into, n_state, n_params, order)
    if key not in _KERNELS:
        tr = trace(rhs_into, events_into, n_state, n_params)
        _KERNELS[key] = TaylorKernel(tr, order, label)
    return _KERNELS[key]


# --- the integration loop (numba, compiled once for all models) -------------------------------

import numba  # noqa: E402  (only the integrator needs numba; tracing does not)
from numba import types  # noqa: E402

_F8P = types.CPointer(types.float64)
_JET_SIG = types.void(types.float64, _F8P, _F8P, _F8P)
_JET_TYPE = types.FunctionType(_JET_SIG)


class _JetAddress(types.WrapperAddressProtocol):
    """A compiled jet as a numba first-class function value."""

    def __init__(self, address: int) -> None:
        self._address = address

    def __wrapper_address__(self) -> int:
        return self._address

    def signature(self) -> Any:
        return _JET_SIG


def _function_value(address: int) -> _JetAddress:
    return _JetAddress(address)


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


_INTEGRATE_SIG = types.int64(
    _JET_TYPE,
    types.float64,  # t0
    types.float64,  # t_end
    types.float64[::1],  # y0
    types.float64[::1],  # p
    types.float64[::1],  # sigma
    types.float64,  # tol_scale
    types.float64,  # fac
    types.int64,  # order
    types.float64,  # max_step
    types.int64,  # max_steps (room in T, H, C)
    types.float64[::1],  # ev_dir
    types.int64,  # n_sub
    types.float64[::1],  # T
    types.float64[::1],  # H
    types.float64[:, :, ::1],  # C
    types.float64[::1],  # y_out
    types.int64[::1],  # info: steps, event index
    types.float64[::1],  # t_out
)


@numba.njit(_INTEGRATE_SIG, cache=True, error_model="numpy")
def _integrate(
    jet, t0, t_end, y0, p, sigma, tol_scale, fac, order, max_step, max_steps, ev_dir, n_sub, T, H, C, y_out, info,
    t_out,
):  # fmt: skip
    """Taylor steps from t0 towards t_end; returns the status (see :data:`STATUS_MESSAGES`).

    Step i starts at T[i] with size H[i] and coefficients C[i] (state rows, then event rows);
    ``info`` receives the number of steps and the index of a terminal event, ``y_out``/``t_out``
    the state and time reached.
    """
    n = y0.size
    n_ev = ev_dir.size
    y = y0.copy()
    acc = np.empty(n)
    fa = np.empty(n_sub + 1)
    t = t0
    T[0] = t0
    steps = 0
    info[1] = -1
    status = 0
    while True:
        if t >= t_end:
            status = 0
            break
        if steps >= max_steps:
            status = -3
            break
        X = C[steps]  # the jet writes the step's coefficients where they are kept
        jet(t, y.ctypes, p.ctypes, X.ctypes)
        n1 = 0.0
        n2 = 0.0
        for i in range(n):
            s = tol_scale * max(sigma[i], abs(y[i]))
            n1 = max(n1, abs(X[i, order - 1]) / s)
            n2 = max(n2, abs(X[i, order]) / s)
        if not (n1 < math.inf and n2 < math.inf):
            status = -1
            break
        rho = math.inf
        if n1 > 0.0:
            rho = n1 ** (-1.0 / (order - 1))
        if n2 > 0.0:
            rho = min(rho, n2 ** (-1.0 / order))
        h = min(rho * fac, max_step)
        last = False
        if t + h >= t_end:
            h = t_end - t
            last = True
        elif not (t + h > t):
            status = -2
            break
        # events: sign changes of the event polynomials over [0, h], sampled at n_sub points
        # (evaluated together: independent Horner chains overlap in the pipeline)
        hit = -1
        x_hit = h
        for e in range(n_ev):
            r = n + e
            for q in range(n_sub + 1):
                fa[q] = X[r, order]
            for k in range(order - 1, -1, -1):
                for q in range(n_sub + 1):
                    fa[q] = fa[q] * (h * q / n_sub) + X[r, k]
            for q in range(1, n_sub + 1):
                f0, f1 = fa[q - 1], fa[q]
                up = f0 < 0.0 and f1 >= 0.0
                down = f0 > 0.0 and f1 <= 0.0
                if (up and ev_dir[e] >= 0.0) or (down and ev_dir[e] <= 0.0):
                    xa, xb = h * (q - 1) / n_sub, h * q / n_sub
                    x = xb if f1 == 0.0 else _root(X, r, order, xa, xb, f0, f1)
                    if hit < 0 or x < x_hit:
                        x_hit = x
                        hit = e
                    break
        if hit >= 0:
            h = x_hit
            last = False
        for i in range(n):
            acc[i] = X[i, order]
        for k in range(order - 1, -1, -1):
            for i in range(n):
                acc[i] = acc[i] * h + X[i, k]
        finite = True
        for i in range(n):
            finite = finite and (acc[i] - acc[i] == 0.0)
            y[i] = acc[i]
        H[steps] = h
        steps += 1
        t = t_end if last else t + h
        T[steps] = t
        if not finite:
            status = -1
            break
        if hit >= 0:
            info[1] = hit
            status = 1
            break
    info[0] = steps
    t_out[0] = t
    for i in range(n):
        y_out[i] = y[i]
    return status


@numba.njit(cache=True, error_model="numpy")
def _dense_many(T, H, C, n, tt, out):
    """``out[j]`` = the Taylor polynomial of the step containing ``tt[j]``, evaluated there."""
    m = H.size
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
    components ``c < n``; rows ``n…`` hold the event functions' polynomials.
    """

    def __init__(self, t: np.ndarray, h: np.ndarray, C: np.ndarray, n: int) -> None:
        self.t = np.ascontiguousarray(t, dtype=float)
        self.h = np.ascontiguousarray(h, dtype=float)
        self.C = np.ascontiguousarray(C, dtype=float)
        self.n = int(n)
        if self.h.size:
            self.y = np.vstack([self.C[0, :n, 0][None, :], self(self.t[1:]).reshape(n, -1).T])
        else:
            self.y = np.empty((1, n))

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
        if self.h.size == 0:
            out = np.repeat(self.y[:1], tt.size, axis=0).T
            return out[:, 0] if scalar else out
        out = np.empty((tt.size, self.n))
        _dense_many(self.t, self.h, self.C, self.n, tt, out)
        return out[0] if scalar else out.T

    def truncate(self, t_stop: float) -> TaylorDense:
        """The same solution ending at ``t_stop`` (inside its last kept step)."""
        k = max(int(np.searchsorted(self.t, t_stop, side="left")), 1)
        h = self.h[:k].copy()
        h[-1] = t_stop - self.t[k - 1]
        return TaylorDense(np.append(self.t[:k], t_stop), h, self.C[:k], self.n)


@dataclass
class TaylorSolution:
    """Result of :func:`solve`."""

    dense: TaylorDense
    status: int
    message: str
    t_steps: np.ndarray
    event_index: np.ndarray
    event_t: np.ndarray
    n_steps: int
    order: int


COMPLETED, TERMINAL_EVENT, NON_FINITE, STEP_TOO_SMALL, MAX_STEPS = 0, 1, -1, -2, -3
STATUS_MESSAGES = {
    COMPLETED: "the end of the interval was reached",
    TERMINAL_EVENT: "a terminal event occurred",
    NON_FINITE: "the solution became non-finite",
    STEP_TOO_SMALL: "the step size fell below the resolution of t",
    MAX_STEPS: "the maximum number of steps was reached",
}


def solve(
    k: TaylorKernel,
    t_span: tuple[float, float],
    y0: ArrayLike,
    params: ArrayLike,
    *,
    scales: ArrayLike | None = None,
    direction: ArrayLike | None = None,
    max_step: float = math.inf,
    max_steps: int = 10_000_000,
    n_sub: int = 4,
    tol: float | None = None,
    safety: float = 0.9,
) -> TaylorSolution:
    """Integrate with the compiled jet ``k`` (from :func:`kernel`) over ``t_span`` (forward).

    ``direction`` gives, per event function of the model, the crossing direction (−1, 0, +1);
    every event is terminal. ``scales`` are typical magnitudes per component (default 1).
    """
    t0, t_end = float(t_span[0]), float(t_span[1])
    y = np.array(y0, dtype=float)
    p = np.ascontiguousarray(params, dtype=float)
    n, width = y.size, k.order + 1
    sigma = np.ones(n) if scales is None else np.array(np.broadcast_to(scales, (n,)), dtype=float)
    ev_dir = np.zeros(k.n_events) if direction is None else np.array(direction, dtype=float)
    if ev_dir.size != k.n_events:
        raise ValueError(f"direction needs one entry per event ({k.n_events}); got {ev_dir.size}")
    if tol is None:
        tol_scale, fac = 1.0, math.exp(-0.7 / (k.order - 1)) / math.e**2
    else:
        tol_scale, fac = tol, safety
    Ts, Hs, Cs = [np.array([t0])], [], []
    t, steps, room = t0, 0, 2048
    info, t_out, y_out = np.zeros(2, dtype=np.int64), np.zeros(1), np.empty(n)
    while True:
        room = min(room, max_steps - steps)
        T, H = np.empty(room + 1), np.empty(room)
        C = np.empty((room, n + k.n_events, width))
        status = _integrate(
            k.function, t, t_end, y, p, sigma, tol_scale, fac, k.order, float(max_step), room, ev_dir, n_sub,
            T, H, C, y_out, info, t_out,
        )  # fmt: skip
        m = int(info[0])
        Ts.append(T[1 : m + 1])
        Hs.append(H[:m])
        Cs.append(C[:m])
        steps += m
        if status == MAX_STEPS and steps < max_steps:
            t, y, room = float(t_out[0]), y_out.copy(), room * 4  # resume with more room
            continue
        break
    dense = TaylorDense(np.concatenate(Ts), np.concatenate(Hs), np.concatenate(Cs), n)
    hit = status == TERMINAL_EVENT
    return TaylorSolution(
        dense=dense,
        status=int(status),
        message=STATUS_MESSAGES[int(status)],
        t_steps=dense.t,
        event_index=np.array([info[1]] if hit else [], dtype=np.int64),
        event_t=np.array([t_out[0]] if hit else []),
        n_steps=steps,
        order=k.order,
    )
