"""The integration loop of :mod:`mett.dynamics.taylor`: numba code compiled once for all models
(``cache=True``), calling a model's compiled jet through a function pointer.
"""

from __future__ import annotations

import math
from typing import Any

import numba
import numpy as np
from numba import types
from numba.extending import typeof_impl

from ..._numba_cache import install as _check_numba_cache
from .. import _codes, _signals

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


@typeof_impl.register(_JetAddress)
def _typeof_jet_address(val: _JetAddress, c: Any) -> types.FunctionType:
    """The numba type of a jet or update: the module's own instance, not a new FunctionType per
    call (numba's generic typing of a WrapperAddressProtocol rebuilds and re-hashes it on every
    call of the loop, a fixed cost that dominated short runs)."""
    sig = val._sig
    if sig is _JET_SIG:
        return _JET_TYPE
    if sig is _UPDATE_SIG:
        return _UPDATE_TYPE
    return types.FunctionType(sig)


# the codes shared with DOP853 (:mod:`._codes`)
COMPLETED, TERMINAL_EVENT = _codes.COMPLETED, _codes.TERMINAL_EVENT
STEP_TOO_SMALL, NON_FINITE, MAX_STEPS = _codes.STEP_TOO_SMALL, _codes.NON_FINITE, _codes.MAX_STEPS
_INTERRUPTED = _codes.INTERRUPTED  # a signal (Ctrl-C) stopped the loop: the caller raises
_POLL_EVERY = _codes.POLL_EVERY  # steps between polls for signals (mett.dynamics._signals)


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
            else:
                # the step the stored times hold: t + h is rounded, and the dense output is
                # evaluated at diff(T); taking the polynomial to anything else left a jump of
                # ~|ẏ| ε t at every step (hundreds of ulps of the axis late in the thesis run)
                hl = (t[lane] + hl) - t[lane]
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
                hl = (t[lane] + x_hit) - t[lane]  # as stored (above)
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
