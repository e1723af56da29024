"""The LLVM IR writer of :mod:`mett.dynamics.taylor`: the recurrences of automatic differentiation
for the Taylor coefficients of a traced graph, unrolled into straight-line IR (Jorba & Zou 2005,
§2), with the step-size norm of §3.2–3.3.
"""

from __future__ import annotations

import hashlib
from collections.abc import Sequence

import numpy as np

from ._trace import _classify, _Traced


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
        self,
        tr: _Traced,
        order: int,
        name: str,
        lanes: int = 1,
        vectors: tuple = (),
        interleave: bool = True,
    ) -> None:
        self.tr, self.order, self.name, self.W = tr, order, name, lanes
        self.interleave = interleave
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
        # SSA has no copy instruction: x + (−0) = x exactly for every x (−0 too), so LLVM folds
        # it away (x + 0 it may not: −0 + 0 = +0; those additions sat in the jet's dependency
        # chains, one after every product's sum)
        self.lines.append(f"{name} = fadd {self.T} {value}, {self.c(-0.0)}")

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
        groups = self.product_groups() if self.interleave else None
        for k in range(self.order):
            done: set[int] = set()
            for i in self.live:
                op, a, b, _ = nodes[i]
                if self.scalar[i] or op == "var" or i in done:
                    continue
                if groups and i in groups and k > 0:
                    self.products(groups[i], k)
                    done.update(groups[i])
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

    def product_groups(self) -> dict[int, list[int]]:
        """Series products a·b of the graph that share a factor, each group to be emitted together
        (:meth:`products`): led by its first node in topological order, with every later product
        that shares a factor with the group and whose own factors come before the leader (so it
        may move up to it)."""
        nodes, pos = self.tr.nodes, {i: n for n, i in enumerate(self.live)}

        def is_product(i: int) -> bool:
            op, a, b, _ = nodes[i]
            return op == "mul" and a != b and not self.scalar[a] and not self.scalar[b]

        prods = [i for i in self.live if not self.scalar[i] and is_product(i)]
        groups: dict[int, list[int]] = {}
        taken: set[int] = set()
        for i in prods:
            if i in taken:
                continue
            grp, factors = [i], set(nodes[i][1:3])
            for j in prods:
                if j <= i or j in taken:
                    continue
                fa, fb = nodes[j][1], nodes[j][2]
                if {fa, fb} & factors and pos[fa] < pos[i] and pos[fb] < pos[i]:
                    grp.append(j)
                    factors |= {fa, fb}
            if len(grp) > 1:
                groups[i] = grp
                taken.update(grp)
        return groups

    def products(self, group: list[int], k: int) -> None:
        """Coefficient k of the products of ``group`` (:meth:`product_groups`): the same chains of
        multiply-adds as :meth:`dot`, term by term in the same order (so the same results, bit for
        bit), interleaved: term j of every product, then term j + 1, so a factor they share is
        read once per j."""
        nodes = self.tr.nodes
        accs: list[str | None] = [None] * len(group)
        for j in range(k + 1):
            for n, i in enumerate(group):
                _, a, b, _ = nodes[i]
                prod = self.op("fmul", self.v(a, j), self.v(b, k - j))
                acc = accs[n]
                accs[n] = prod if acc is None else self.op("fadd", acc, prod)
        for n, i in enumerate(group):
            acc = accs[n]
            assert acc is not None  # k + 1 >= 1 terms were summed
            self.assign(self.v(i, k), acc)

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


def _kernel_source(
    tr: _Traced, order: int, label: str, lanes: int, vectors: tuple
) -> tuple[str, str]:
    """The symbol name and the LLVM IR of a kernel (``vectors`` normalised by _norm_groups)."""
    digest = hashlib.sha256(repr((tr, order, lanes, vectors)).encode()).hexdigest()[:16]
    name = f"mett_jet_{label}_{order}x{lanes}_{digest}".replace("-", "_")
    return name, _IR(tr, order, name, lanes, vectors).text()
