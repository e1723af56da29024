"""Compiled adaptive Taylor-series integrator, generated from a model's own right-hand side.

Every model of :mod:`mett.dynamics` writes its equations once, as plain arithmetic
(``_rhs_into(t, y, p, out)`` and ``_events_into``). This package *traces* those functions with
symbolic stand-ins for ``y`` and ``p``: each ``+ − × ÷``, ``sqrt``, ``sin``/``cos`` becomes a node
of an expression graph (equal sub-expressions are shared, sub-expressions of the parameters alone
are computed once per step). From the graph it writes, for one fixed order p, the recurrences of
automatic differentiation for the Taylor coefficients of every intermediate quantity (Jorba &
Zou 2005, §2):

    (a b)_k = Σ_{j=0}^{k} a_j b_{k−j},     (a/b)_k = (a_k − Σ_{j=1}^{k} b_j (a/b)_{k−j}) / b_0,
    (√a)_k = (a_k − Σ_{j=1}^{k−1} c_j c_{k−j}) / (2 c_0),
    (sin a)_k = (1/k) Σ_{j=1}^{k} j a_j (cos a)_{k−j},   (cos a)_k = −(1/k) Σ_{j=1}^{k} j a_j (sin a)_{k−j},
    y_{k+1} = f_k / (k + 1),

unrolled into straight-line LLVM IR (each sum of products one chain of fused multiply-adds; the
chains of products that share a factor interleaved, term by term, so it is read once) and
compiled to machine code with llvmlite, which numba already depends on. The machine code is
cached in the user's own cache directory (:func:`cache_dir`), keyed by the IR, llvmlite's version,
the target and the CPU with its features, and loaded only after its owner, permissions and sha256
are checked (:mod:`._llvm`). The integration loop is numba code compiled once for every model
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

The package, one concept a module: :mod:`._trace` (the tracer: plain Python and numpy, no
numba), :mod:`._codegen` (the LLVM IR of the recurrences), :mod:`._llvm` (machine code and its
disk cache), :mod:`._loop` (the numba integration loop) and this module, the API: the kernels
(:func:`kernel`, :func:`kernel_for`, the one call of single runs and batches), :func:`solve`,
:func:`propagate` and their results. The status codes are those of DOP853 (:mod:`.._codes`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from .. import _codes, _signals
from ._codegen import _kernel_source, _norm_groups
from ._llvm import UnsafeCacheWarning, _native, cache_dir
from ._loop import _JET_SIG, _UPDATE_SIG, _dense_many, _integrate, _JetAddress, _propagate_groups
from ._trace import _Traced, trace

if TYPE_CHECKING:  # the registry sits above the integrators
    from ..registry import Model, Phase

__all__ = [
    "STATUS_MESSAGES",
    "TaylorBatch",
    "TaylorDense",
    "TaylorKernel",
    "TaylorSolution",
    "UnsafeCacheWarning",
    "cache_dir",
    "kernel",
    "kernel_for",
    "order_for",
    "propagate",
    "solve",
    "trace",
]


# the codes shared with DOP853 (:mod:`.._codes`)
COMPLETED, TERMINAL_EVENT = _codes.COMPLETED, _codes.TERMINAL_EVENT
STEP_TOO_SMALL, NON_FINITE, MAX_STEPS = _codes.STEP_TOO_SMALL, _codes.NON_FINITE, _codes.MAX_STEPS
STATUS_MESSAGES = {
    COMPLETED: "the end of the interval was reached",
    TERMINAL_EVENT: "a terminal event occurred",
    NON_FINITE: "the solution or its Taylor coefficients became non-finite",
    STEP_TOO_SMALL: "the step size fell below the resolution of t",
    MAX_STEPS: "the maximum number of steps was reached",
}


def order_for(tol: float) -> int:
    """Taylor order p = ⌈−½ ln ε⌉ + 1 for a tolerance ε (Jorba & Zou 2005, §3.3), at least 6."""
    return max(math.ceil(-0.5 * math.log(tol)) + 1, 6)


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
        # every event terminal, for :func:`solve` (the loop only reads it)
        self.all_terminal = np.ones(self.n_events)


_KERNELS: dict[tuple, list[TaylorKernel]] = {}

_NO_TIMES = np.empty(0)
# Spare output buffers of :func:`solve` by shape, (T, Y, C) taken and given back: a short run
# (the contact phase between two hops) would otherwise ask the system for a fresh multi-MiB
# buffer per call and give it back, its pages faulted in anew each time. A buffer a result still
# views (a long run's coefficients) is not given back. pop/setdefault keep it safe across threads.
_SPARE: dict[tuple, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
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


def kernel_for(
    model: Model,
    phase: Phase,
    rtol: float,
    params: Sequence[float] | np.ndarray,
    lanes: int = 1,
    *,
    n_state: int,
    record: Sequence[Callable] = (),
) -> TaylorKernel:
    """The :class:`TaylorKernel` that integrates ``phase`` of ``model`` at the order of ``rtol``
    (:func:`order_for`), for ``lanes`` trajectories at once: the one call of :func:`kernel` that
    single runs (``simulate(..., backend="taylor")``) and batches (:mod:`mett.dynamics.batch`)
    share.

    Parameters
    ----------
    model : Model
        The model (its ``name``, ``vectors`` and ``conserved_lengths`` shape the kernel).
    phase : Phase
        The phase integrated: its ``rhs_into`` and the ``fn`` of its events, in that order.
    rtol : float
        Relative tolerance; sets the order p = ⌈−½ ln rtol⌉ + 1 (Jorba & Zou 2005, §3.3).
    params : sequence of float or ndarray
        The run's parameters: a right-hand side that branches on them is traced for them.
    lanes : int, default 1
        Trajectories per SIMD batch.
    n_state : int
        Components of the model's state.
    record : sequence of callables, optional
        Event functions ``fn(t, y, p)`` after the phase's own (a batch records the first zero
        of cos θ with them).
    """
    if phase.rhs_into is None:
        raise ValueError(f"phase {phase.name!r} of model {model.name!r} has no rhs_into")
    events = [ev.fn for ev in phase.events]
    events.extend(record)
    return kernel(
        phase.rhs_into, events, n_state, len(params), order_for(rtol),
        f"{model.name}_{phase.name}", lanes=lanes, params=params, vectors=model.vectors,
        lengths=model.conserved_lengths,
    )  # fmt: skip


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
    SC = np.ones(n) if scales is None else np.asarray(scales, dtype=float)
    # one run with vectors (the short contact phases of a hopping run): a reshape, not the
    # slower broadcast_to, for the same values
    P = P.reshape(1, -1) if m == 1 and P.ndim == 1 else np.broadcast_to(P, (m, P.shape[-1]))
    SC = SC.reshape(1, n) if m == 1 and SC.shape == (n,) else np.broadcast_to(SC, (m, n))
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
    max_step = float(max_step)
    if tol is None:
        tol_scale, fac = 1.0, _step_factor(k.order)
    else:
        tol_scale, fac = tol, safety
    W, width, rows = k.lanes, k.order + 1, n + k.n_events
    parts: list[list[tuple]] = [[] for _ in range(m)]
    t_now, y_now = np.full(m, t0), Y0.copy()
    done = [0] * m
    result: list[tuple[int, int] | None] = [None] * m
    # The coefficients are the dense output, written once and kept: the first buffer is at least
    # _HUGE bytes, which numpy backs with transparent huge pages where the system has them (one
    # page fault per 2 MiB instead of per 4 KiB; measured: the thesis run 5.4 → 4.6 ms). Pages
    # are only made resident when written; a short run's coefficients are copied out (below).
    step_bytes = rows * width * W * 8
    pending, room = list(range(m)), max(1024, -(-_HUGE // step_bytes))
    stop = _signals.new_stop()
    buffers: list[tuple] = []  # (shape, T, Y, C) of each group, for _SPARE
    while pending:
        resume = []
        for g in range(0, len(pending), W):
            group = pending[g : g + W]
            lanes = group + [group[0]] * (W - len(group))  # pad with a copy of the first
            rm = int(max(1, min(room, max_steps - min(done[j] for j in group))))
            shape = (rm, n, rows, width, W)
            spare = _SPARE.pop(shape, None)
            if spare is None:
                T, Yb = np.empty((rm + 1, W)), np.empty((rm + 1, n, W))
                C = np.empty((rm, rows, width, W))
            else:
                T, Yb, C = spare
            buffers.append((shape, T, Yb, C))
            info = np.zeros((W, 3), dtype=np.int64)
            sig = np.empty((n + 1, W))  # the scales of the norm, then the events' (tol_scale)
            np.multiply(tol_scale, SC[lanes].T, out=sig[:n])
            sig[n] = tol_scale
            # a Ctrl-C stops the loop within _POLL_EVERY steps and is raised here
            with _signals.deferred_sigint(stop):
                _integrate(
                    k.function, k.update, t_now[lanes], t_end, y_now[lanes].T.copy(),
                    P[lanes].T.copy(), sig, fac, k.order, max_step, ev_dir, k.all_terminal,
                    n_sub, rm, T, Yb, C, np.empty((W, k.n_events)), _NO_TIMES,
                    np.empty((0, n, W)), info, stop,
                )  # fmt: skip
            _signals.raise_pending(stop)
            rows_info = info.tolist()[: len(group)]  # Python ints; the padding lanes dropped
            for lane, (j, (steps, hit, status)) in enumerate(zip(group, rows_info, strict=True)):
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
    kept = False  # a result views a buffer's coefficients
    for j in range(m):
        done_j = result[j]
        assert done_j is not None  # every run left the loop with a status
        status, hit = done_j
        if len(parts[j]) == 1:  # the common case: views into the group's buffers, no copy
            t = np.concatenate([[t0], parts[j][0][0]])
            y = np.concatenate([Y0[j][None, :], parts[j][0][1]])
            C = parts[j][0][2]
            if C.nbytes * W < _HUGE // 4:  # a short run does not keep a large buffer alive
                C = C.copy()
            else:
                kept = True
        else:
            t = np.concatenate([[t0], *(q[0] for q in parts[j])])
            y = np.concatenate([Y0[j][None, :], *(q[1] for q in parts[j])])
            C = np.concatenate([q[2] for q in parts[j]]) if parts[j] else np.empty((0, rows, width))
        out.append(
            TaylorSolution(TaylorDense(t, y, C), status, STATUS_MESSAGES[status], hit, k.order)
        )
    if not kept:  # t and y above are copies: every buffer is free again
        for shape, T, Yb, C in buffers:
            # only first-size buffers are kept for the next call: a long run's grown ones (×4 per
            # resume) would stay allocated for the life of the process
            if C.nbytes <= 2 * _HUGE:
                _SPARE.setdefault(shape, (T, Yb, C))
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
