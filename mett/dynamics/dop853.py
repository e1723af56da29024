"""Compiled Dormand–Prince 8(5,3) integrator with dense output and event location.

This is the method of Hairer's DOP853 (Hairer, Nørsett & Wanner, *Solving Ordinary Differential
Equations I*, 2nd ed., §II.5 and §II.10) as implemented by ``scipy.integrate.solve_ivp(method=
"DOP853")``: the same Butcher tableau, the same error estimate (the 5th-order estimate damped by the
3rd-order one, ``|h| e5² / sqrt((e5² + 0.01 e3²) n)``), the same step-size controller (safety 0.9,
factors clipped to [0.2, 10], exponent −1/8, no growth right after a rejection), the same initial
step selection and the same 7th-order continuous extension.  With equal tolerances it therefore
takes the same steps as scipy, but compiled with numba, so one step costs the twelve right-hand-side
calls and a few hundred flops instead of tens of microseconds of Python (docs/theory/simulation.md#numerics).

Right-hand sides and event functions are numba-jitted functions with the signature::

    rhs(t: float, y: float64[::1], params: float64[::1], out: float64[::1]) -> None
    events(t: float, y: float64[::1], params: float64[::1], out: float64[::1]) -> None

``rhs`` writes dy/dt into ``out``; ``events`` writes the values of all event functions into ``out``
(one entry per event).  Writing into a buffer rather than returning a new array avoids 13–16 heap
allocations per step, which would cost about as much as the arithmetic of a small right-hand side.

One compiled integrator serves every model: the integrator takes ``rhs`` and ``events`` as numba
*first-class function* values (``numba.types.FunctionType``) and is compiled once, with an explicit
signature and ``cache=True``, so a new process loads it from the cache instead of compiling it
(about 8 s of CPU).  Passing them as ordinary dispatcher arguments would specialise (and inline) per
model, but numba 0.68 keys the on-disk cache of such specialisations on the identity of the
dispatcher object: every new process recompiled and appended another entry to the cache, and a
module-level wrapper that passes a global dispatcher on is refused ("uses dynamic globals").  The
function-pointer call itself costs nothing measurable here (a dispatcher-specialised build of the
same kernel was not faster); converting a dispatcher to a function pointer costs about 0.1 ms per
:func:`solve` call.  Right-hand sides should be ``@numba.njit(cache=True)`` at module level, so that
a new process loads them from the cache too.

The compiled kernel never raises for numerical trouble: it returns a status code (see
:data:`STATUS_MESSAGES`).  :func:`solve` is the Python entry point; :class:`DenseOutput` evaluates
the piecewise 7th-order interpolant at any number of times (compiled too: evaluating it at ten
thousand times is part of every crossing search).

The coefficients (:mod:`._dop853_coefficients`) are those of Hairer's Fortran DOP853 as tabulated
in scipy's ``scipy/integrate/_ivp/dop853_coefficients.py`` (BSD-3-Clause).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numba
import numpy as np
from numba import types
from numpy.typing import ArrayLike

from .._numba_cache import install as _check_numba_cache
from .._validate import ToleranceWarning
from . import _codes, _signals
from ._dop853_coefficients import (
    _A,
    _C,
    _D,
    _E3,
    _E5,
    INTERPOLATOR_POWER,
    N_STAGES,
    N_STAGES_EXTENDED,
)

_check_numba_cache()  # a damaged numba cache file of mett is a miss, not an error

__all__ = [
    "COMPLETED",
    "MAX_STEPS",
    "NON_FINITE",
    "STATUS_MESSAGES",
    "STEP_TOO_SMALL",
    "TERMINAL_EVENT",
    "DenseOutput",
    "Solution",
    "solve",
]

# Step-size control (scipy.integrate._ivp.rk): the error estimator is of order 7, so the error
# of a step scales like h^8 and the step factor like err^(-1/8).
SAFETY = 0.9
MIN_FACTOR = 0.2
MAX_FACTOR = 10.0
_ERROR_EXPONENT = -1.0 / 8.0
_EPS = float(np.finfo(float).eps)
# Root finding on the interpolant, as solve_ivp's brentq call: x tolerance 4 eps (abs and rel).
_ROOT_XTOL = 4.0 * _EPS
_ROOT_RTOL = 4.0 * _EPS
_ROOT_MAXITER = 100

# --- status codes -------------------------------------------------------------------------------

# the codes shared with the Taylor integrator (:mod:`._codes`), re-exported under the names
# this module has always had
COMPLETED, TERMINAL_EVENT = _codes.COMPLETED, _codes.TERMINAL_EVENT
STEP_TOO_SMALL, NON_FINITE, MAX_STEPS = _codes.STEP_TOO_SMALL, _codes.NON_FINITE, _codes.MAX_STEPS
_INTERRUPTED = _codes.INTERRUPTED  # a signal (Ctrl-C) stopped the loop: solve raises
_POLL_EVERY = _codes.POLL_EVERY

STATUS_MESSAGES = {
    COMPLETED: "The solver successfully reached the end of the integration interval.",
    TERMINAL_EVENT: "A termination event occurred.",
    STEP_TOO_SMALL: "Required step size is less than spacing between numbers.",
    NON_FINITE: "The state or the right-hand side became non-finite (inf or nan).",
    MAX_STEPS: "Maximum number of steps reached.",
}
"""Message per status code; :func:`solve` appends the time of a failure."""

# --- numba types of the kernel -----------------------------------------------------------------

_f8 = types.float64
_i8 = types.int64
_vec = types.Array(types.float64, 1, "C")
_mat = types.Array(types.float64, 2, "C")
_cube = types.Array(types.float64, 3, "C")
_ivec = types.Array(types.int64, 1, "C")

FUNCTION_SIGNATURE = types.void(_f8, _vec, _vec, _vec)
"""Signature of ``rhs`` and ``events``: ``(t, y, params, out) -> None``, all arrays C-contiguous."""
_fn = types.FunctionType(FUNCTION_SIGNATURE)


# Helpers that only read and write existing arrays are compiled without the numba runtime (NRT):
# with it, every call boundary and array view costs an atomic incref/decref pair, which made up
# about a third of the time of a step (2.1 -> 1.5 us per step for a 12-dimensional linear ODE).
_njit_nort = numba.njit(cache=True, _nrt=False)  # type: ignore[call-overload]  # numba's stub omits _nrt


@_njit_nort
def _pymax(a: float, b: float) -> float:
    # Python's max(a, b) (keep a unless b > a), so nan handling matches scipy's controller
    return b if b > a else a


@_njit_nort
def _pymin(a: float, b: float) -> float:
    return b if b < a else a


@_njit_nort
def _all_finite(x: np.ndarray) -> bool:
    for v in x:
        if not math.isfinite(v):
            return False
    return True


@_njit_nort
def _all_row_finite(K: np.ndarray, row: int) -> bool:
    for i in range(K.shape[1]):
        if not math.isfinite(K[row, i]):
            return False
    return True


# The stage sums are written out term by term over the non-zeros of the tables (70 % of the tableau
# is zeros), as in Hairer's Fortran: with constant indices numba folds the coefficients into the
# code and LLVM keeps the sums in registers. A loop over a sparse (CSR) copy of the tables took
# twice as long per step, and a step's arithmetic (~1500 multiply-adds for n = 10) was then as
# costly as its twelve right-hand-side calls. The sums run over increasing j, as the CSR loop did
# (and 0 + x = x, so they equal the dense dot products up to summation order);
# tests/test_dop853.py checks every sum against the full tables.


# fmt: off
@_njit_nort
def _rk_stages(rhs, params, t, y, h, K, ytmp, y_new):
    """Stages 1..12 of a step from (t, y) with K[0] = f(t, y): y_new and K[12] = f(t + h, y_new).

    Stage 12 has c = 1 and a = b, so its state is y_new and K[12] the first stage of the next step.
    """
    n = y.size
    for i in range(n):
        ytmp[i] = y[i] + (_A[1, 0] * K[0, i]) * h
    rhs(t + _C[1] * h, ytmp, params, K[1])
    for i in range(n):
        ytmp[i] = y[i] + (_A[2, 0] * K[0, i] + _A[2, 1] * K[1, i]) * h
    rhs(t + _C[2] * h, ytmp, params, K[2])
    for i in range(n):
        ytmp[i] = y[i] + (_A[3, 0] * K[0, i] + _A[3, 2] * K[2, i]) * h
    rhs(t + _C[3] * h, ytmp, params, K[3])
    for i in range(n):
        ytmp[i] = y[i] + (_A[4, 0] * K[0, i] + _A[4, 2] * K[2, i] + _A[4, 3] * K[3, i]) * h
    rhs(t + _C[4] * h, ytmp, params, K[4])
    for i in range(n):
        ytmp[i] = y[i] + (_A[5, 0] * K[0, i] + _A[5, 3] * K[3, i] + _A[5, 4] * K[4, i]) * h
    rhs(t + _C[5] * h, ytmp, params, K[5])
    for i in range(n):
        ytmp[i] = y[i] + (_A[6, 0] * K[0, i] + _A[6, 3] * K[3, i] + _A[6, 4] * K[4, i] + _A[6, 5] * K[5, i]) * h
    rhs(t + _C[6] * h, ytmp, params, K[6])
    for i in range(n):
        ytmp[i] = y[i] + (_A[7, 0] * K[0, i] + _A[7, 3] * K[3, i] + _A[7, 4] * K[4, i] + _A[7, 5] * K[5, i] + _A[7, 6] * K[6, i]) * h
    rhs(t + _C[7] * h, ytmp, params, K[7])
    for i in range(n):
        ytmp[i] = y[i] + (_A[8, 0] * K[0, i] + _A[8, 3] * K[3, i] + _A[8, 4] * K[4, i] + _A[8, 5] * K[5, i] + _A[8, 6] * K[6, i] + _A[8, 7] * K[7, i]) * h
    rhs(t + _C[8] * h, ytmp, params, K[8])
    for i in range(n):
        ytmp[i] = y[i] + (_A[9, 0] * K[0, i] + _A[9, 3] * K[3, i] + _A[9, 4] * K[4, i] + _A[9, 5] * K[5, i] + _A[9, 6] * K[6, i] + _A[9, 7] * K[7, i] + _A[9, 8] * K[8, i]) * h
    rhs(t + _C[9] * h, ytmp, params, K[9])
    for i in range(n):
        ytmp[i] = y[i] + (_A[10, 0] * K[0, i] + _A[10, 3] * K[3, i] + _A[10, 4] * K[4, i] + _A[10, 5] * K[5, i] + _A[10, 6] * K[6, i] + _A[10, 7] * K[7, i] + _A[10, 8] * K[8, i] + _A[10, 9] * K[9, i]) * h
    rhs(t + _C[10] * h, ytmp, params, K[10])
    for i in range(n):
        ytmp[i] = y[i] + (_A[11, 0] * K[0, i] + _A[11, 3] * K[3, i] + _A[11, 4] * K[4, i] + _A[11, 5] * K[5, i] + _A[11, 6] * K[6, i] + _A[11, 7] * K[7, i] + _A[11, 8] * K[8, i] + _A[11, 9] * K[9, i] + _A[11, 10] * K[10, i]) * h
    rhs(t + _C[11] * h, ytmp, params, K[11])
    for i in range(n):
        y_new[i] = y[i] + (_A[12, 0] * K[0, i] + _A[12, 5] * K[5, i] + _A[12, 6] * K[6, i] + _A[12, 7] * K[7, i] + _A[12, 8] * K[8, i] + _A[12, 9] * K[9, i] + _A[12, 10] * K[10, i] + _A[12, 11] * K[11, i]) * h
    rhs(t + _C[12] * h, y_new, params, K[12])


@_njit_nort
def _error_norm(K, y, y_new, rtol, atol, h_abs):
    """scipy's DOP853 error norm |h| e5² / sqrt((e5² + 0.01 e3²) n), or nan if the trial step is not
    finite (a finite norm does not exclude y_new = inf, where the scale is inf, so check all)."""
    n = y.size
    e5 = 0.0
    e3 = 0.0
    for i in range(n):
        scale = atol[i] + max(abs(y[i]), abs(y_new[i])) * rtol[i]
        a5 = (_E5[0] * K[0, i] + _E5[5] * K[5, i] + _E5[6] * K[6, i] + _E5[7] * K[7, i] + _E5[8] * K[8, i] + _E5[9] * K[9, i] + _E5[10] * K[10, i] + _E5[11] * K[11, i]) / scale
        a3 = (_E3[0] * K[0, i] + _E3[5] * K[5, i] + _E3[6] * K[6, i] + _E3[7] * K[7, i] + _E3[8] * K[8, i] + _E3[9] * K[9, i] + _E3[10] * K[10, i] + _E3[11] * K[11, i]) / scale
        e5 += a5 * a5
        e3 += a3 * a3
    if e5 == 0.0 and e3 == 0.0:
        error_norm = 0.0
    else:
        error_norm = h_abs * e5 / math.sqrt((e5 + 0.01 * e3) * n)
    if not (math.isfinite(error_norm) and _all_finite(y_new) and _all_row_finite(K, N_STAGES)):
        return math.nan
    return error_norm


@_njit_nort
def _dense_coefficients(rhs, params, t, y, y_new, h, K, ytmp, Fc):
    """The three extra stages and the coefficients Fc (7, n) of the continuous extension of the
    accepted step from (t, y) to (t + h, y_new) (scipy's ``Dop853DenseOutput``)."""
    n = y.size
    for i in range(n):
        ytmp[i] = y[i] + (_A[13, 0] * K[0, i] + _A[13, 6] * K[6, i] + _A[13, 7] * K[7, i] + _A[13, 8] * K[8, i] + _A[13, 9] * K[9, i] + _A[13, 10] * K[10, i] + _A[13, 11] * K[11, i] + _A[13, 12] * K[12, i]) * h
    rhs(t + _C[13] * h, ytmp, params, K[13])
    for i in range(n):
        ytmp[i] = y[i] + (_A[14, 0] * K[0, i] + _A[14, 5] * K[5, i] + _A[14, 6] * K[6, i] + _A[14, 7] * K[7, i] + _A[14, 10] * K[10, i] + _A[14, 11] * K[11, i] + _A[14, 12] * K[12, i] + _A[14, 13] * K[13, i]) * h
    rhs(t + _C[14] * h, ytmp, params, K[14])
    for i in range(n):
        ytmp[i] = y[i] + (_A[15, 0] * K[0, i] + _A[15, 5] * K[5, i] + _A[15, 6] * K[6, i] + _A[15, 7] * K[7, i] + _A[15, 8] * K[8, i] + _A[15, 12] * K[12, i] + _A[15, 13] * K[13, i] + _A[15, 14] * K[14, i]) * h
    rhs(t + _C[15] * h, ytmp, params, K[15])
    for i in range(n):
        dy = y_new[i] - y[i]
        Fc[0, i] = dy
        Fc[1, i] = h * K[0, i] - dy
        Fc[2, i] = 2 * dy - h * (K[N_STAGES, i] + K[0, i])
        Fc[3, i] = h * (_D[0, 0] * K[0, i] + _D[0, 5] * K[5, i] + _D[0, 6] * K[6, i] + _D[0, 7] * K[7, i] + _D[0, 8] * K[8, i] + _D[0, 9] * K[9, i] + _D[0, 10] * K[10, i] + _D[0, 11] * K[11, i] + _D[0, 12] * K[12, i] + _D[0, 13] * K[13, i] + _D[0, 14] * K[14, i] + _D[0, 15] * K[15, i])
        Fc[4, i] = h * (_D[1, 0] * K[0, i] + _D[1, 5] * K[5, i] + _D[1, 6] * K[6, i] + _D[1, 7] * K[7, i] + _D[1, 8] * K[8, i] + _D[1, 9] * K[9, i] + _D[1, 10] * K[10, i] + _D[1, 11] * K[11, i] + _D[1, 12] * K[12, i] + _D[1, 13] * K[13, i] + _D[1, 14] * K[14, i] + _D[1, 15] * K[15, i])
        Fc[5, i] = h * (_D[2, 0] * K[0, i] + _D[2, 5] * K[5, i] + _D[2, 6] * K[6, i] + _D[2, 7] * K[7, i] + _D[2, 8] * K[8, i] + _D[2, 9] * K[9, i] + _D[2, 10] * K[10, i] + _D[2, 11] * K[11, i] + _D[2, 12] * K[12, i] + _D[2, 13] * K[13, i] + _D[2, 14] * K[14, i] + _D[2, 15] * K[15, i])
        Fc[6, i] = h * (_D[3, 0] * K[0, i] + _D[3, 5] * K[5, i] + _D[3, 6] * K[6, i] + _D[3, 7] * K[7, i] + _D[3, 8] * K[8, i] + _D[3, 9] * K[9, i] + _D[3, 10] * K[10, i] + _D[3, 11] * K[11, i] + _D[3, 12] * K[12, i] + _D[3, 13] * K[13, i] + _D[3, 14] * K[14, i] + _D[3, 15] * K[15, i])
# fmt: on


@_njit_nort
def _rms_scaled(x, scale):
    s = 0.0
    for i in range(x.size):
        v = x[i] / scale[i]
        s += v * v
    return math.sqrt(s / x.size)


@numba.njit(cache=True)
def _initial_step(rhs, params, t0, y0, f0, t_bound, max_step, direction, rtol, atol, y1, f1):
    """scipy's ``select_initial_step`` (Hairer, Nørsett & Wanner, §II.4) for order 7 + 1."""
    interval_length = abs(t_bound - t0)
    n = y0.size
    scale = np.empty(n)
    for i in range(n):
        scale[i] = atol[i] + abs(y0[i]) * rtol[i]
    d0 = _rms_scaled(y0, scale)
    d1 = _rms_scaled(f0, scale)
    if d0 < 1e-5 or d1 < 1e-5:
        h0 = 1e-6
    else:
        h0 = 0.01 * d0 / d1
    h0 = _pymin(h0, interval_length)
    for i in range(n):
        y1[i] = y0[i] + h0 * direction * f0[i]
    rhs(t0 + h0 * direction, y1, params, f1)
    for i in range(n):
        y1[i] = f1[i] - f0[i]
    d2 = _rms_scaled(y1, scale) / h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = _pymax(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / _pymax(d1, d2)) ** (1.0 / 8.0)
    return _pymin(_pymin(_pymin(100 * h0, h1), interval_length), max_step)


@_njit_nort
def _dense_eval(Fc, y_old, t_old, h, t, out):
    """The continuous extension of one step at time t (scipy's ``Dop853DenseOutput``).

    y = y_old + x(F0 + (1−x)(F1 + x(F2 + (1−x)(F3 + x(F4 + (1−x)(F5 + x F6)))))), x = (t − t_old)/h.
    """
    x = (t - t_old) / h
    xm = 1.0 - x
    for i in range(out.size):
        acc = Fc[6, i] * x
        acc = (acc + Fc[5, i]) * xm
        acc = (acc + Fc[4, i]) * x
        acc = (acc + Fc[3, i]) * xm
        acc = (acc + Fc[2, i]) * x
        acc = (acc + Fc[1, i]) * xm
        acc = (acc + Fc[0, i]) * x
        out[i] = y_old[i] + acc


@_njit_nort
def _event_value(events, params, k, Fc, y_old, t_old, h, t, ytmp, gtmp):
    _dense_eval(Fc, y_old, t_old, h, t, ytmp)
    events(t, ytmp, params, gtmp)
    return gtmp[k]


@_njit_nort
def _graze(events, params, k, Fc, y_old, t_old, h, ga, gb, s, ytmp, gtmp):
    """The time and value at which event k, of sign s (±1) at both ends of the step, reaches
    its interior extremum if that lies beyond zero (a grazing excursion); (NaN, NaN) if none.

    A parabola through the ends and the midpoint of the interpolant predicts the extremum of
    s g; when it lies inside the step and comes within half the smaller end value of zero (or
    beyond), golden-section search on the interpolant finds it to ~1e-9 of the step. So an
    excursion shorter than the step is found whenever its extremum is, and the zero before it
    is then located by :func:`_event_root` like any other.
    """
    gm = _event_value(events, params, k, Fc, y_old, t_old, h, t_old + 0.5 * h, ytmp, gtmp)
    fa, fm, fb = s * ga, s * gm, s * gb
    A = 2.0 * (fa + fb - 2.0 * fm)  # f(x) ≈ fa + B x + A x², x ∈ [0, 1]
    B = fb - fa - A
    if not A > 0.0:
        return math.nan, math.nan
    x = -B / (2.0 * A)
    if not 0.0 < x < 1.0 or fa + x * (B + A * x) > 0.5 * min(fa, fb):
        return math.nan, math.nan
    lo, hi = 0.0, 1.0
    r = 0.5 * (math.sqrt(5.0) - 1.0)
    x1, x2 = hi - r * (hi - lo), lo + r * (hi - lo)
    f1 = s * _event_value(events, params, k, Fc, y_old, t_old, h, t_old + x1 * h, ytmp, gtmp)
    f2 = s * _event_value(events, params, k, Fc, y_old, t_old, h, t_old + x2 * h, ytmp, gtmp)
    for _ in range(45):  # (0.618)^45 ≈ 4e-10 of the step
        if f1 <= 0.0 or f2 <= 0.0:
            break
        if f1 < f2:
            hi, x2, f2 = x2, x1, f1
            x1 = hi - r * (hi - lo)
            f1 = s * _event_value(
                events, params, k, Fc, y_old, t_old, h, t_old + x1 * h, ytmp, gtmp
            )
        else:
            lo, x1, f1 = x1, x2, f2
            x2 = lo + r * (hi - lo)
            f2 = s * _event_value(
                events, params, k, Fc, y_old, t_old, h, t_old + x2 * h, ytmp, gtmp
            )
    if f1 <= 0.0:
        return t_old + x1 * h, s * f1
    if f2 <= 0.0:
        return t_old + x2 * h, s * f2
    return math.nan, math.nan


@_njit_nort
def _event_root(events, params, k, Fc, y_old, t_old, h, xa, xb, fa, fb, ytmp, gtmp):
    """Zero of event k on the interpolant in [xa, xb] by Brent's method (scipy's brentq.c).

    ``fa`` and ``fb`` have opposite signs (or ``fb`` is 0); they are the event values at the step
    ends, not re-evaluated on the interpolant, whose end value can differ from y_new by an ulp and
    would otherwise risk losing the bracket.  Inverse quadratic interpolation with bisection
    safeguards: the bracket shrinks at least geometrically, so the tolerance below is always met.
    """
    if fb == 0.0:
        return xb
    xpre, xcur = xa, xb
    fpre, fcur = fa, fb
    xblk, fblk = 0.0, 0.0
    spre, scur = 0.0, 0.0
    for _ in range(_ROOT_MAXITER):
        if fpre != 0.0 and fcur != 0.0 and (fpre < 0.0) != (fcur < 0.0):
            xblk, fblk = xpre, fpre
            spre = scur = xcur - xpre
        if abs(fblk) < abs(fcur):
            xpre, xcur, xblk = xcur, xblk, xcur
            fpre, fcur, fblk = fcur, fblk, fcur
        delta = (_ROOT_XTOL + _ROOT_RTOL * abs(xcur)) / 2
        sbis = (xblk - xcur) / 2
        if fcur == 0.0 or abs(sbis) < delta:
            return xcur
        if abs(spre) > delta and abs(fcur) < abs(fpre):
            if xpre == xblk:
                stry = -fcur * (xcur - xpre) / (fcur - fpre)  # secant
            else:
                dpre = (fpre - fcur) / (xpre - xcur)
                dblk = (fblk - fcur) / (xblk - xcur)
                stry = -fcur * (fblk * dblk - fpre * dpre) / (dblk * dpre * (fblk - fpre))
            if 2 * abs(stry) < min(abs(spre), 3 * abs(sbis) - delta):
                spre, scur = scur, stry
            else:
                spre, scur = sbis, sbis
        else:
            spre, scur = sbis, sbis
        xpre, fpre = xcur, fcur
        if abs(scur) > delta:
            xcur += scur
        else:
            xcur += delta if sbis > 0 else -delta
        fcur = _event_value(events, params, k, Fc, y_old, t_old, h, xcur, ytmp, gtmp)
    return xcur


@_njit_nort
def _copy(src, dst):
    # explicit loops instead of slice assignment: numba's broadcasting assignment compiles an
    # error-message formatter that alone costs seconds of compile time
    for i in range(src.size):
        dst[i] = src[i]


@_njit_nort
def _copy_row(K, src, dst):
    """K[dst] = K[src] (indices, not row views: a view in NRT code costs an atomic incref/decref)."""
    for i in range(K.shape[1]):
        K[dst, i] = K[src, i]


@_njit_nort
def _put(src, dst, offset):
    """dst[offset : offset + src.size] = src (1-D arrays; no slice views, see :func:`_copy_row`)."""
    for i in range(src.size):
        dst[offset + i] = src[i]


@_njit_nort
def _put_rows(src, dst, offset):
    """The 2-D ``src`` row by row into the 1-D ``dst`` from ``offset``."""
    n = src.shape[1]
    for r in range(src.shape[0]):
        for i in range(n):
            dst[offset + r * n + i] = src[r, i]


@numba.njit(cache=True)
def _grow(a, size, limit):
    """A copy of the 1-D array ``a`` with room for at least ``size`` entries: doubling, but never
    beyond ``limit`` entries (all that ``max_steps`` steps can need)."""
    out = np.empty(max(size, min(2 * a.size, limit)), dtype=a.dtype)
    _copy(a, out)
    return out


@numba.njit(cache=True)
def _trimmed(a, k):
    """``a[:k]``: a view if it fills at least 3/4 of ``a`` (copying would double the memory of a
    run that used its whole buffer, e.g. one that reached ``max_steps``), else a copy."""
    if 4 * k >= 3 * a.size:
        return a[:k]
    return a[:k].copy()


# Slots of the scalar state that _advance carries between calls (it returns to _integrate whenever
# an output buffer is full, so that the buffers can grow).
_T, _H_ABS = 0, 1  # float state: time, size of the next step
_STATUS, _M, _N_REJ, _NFEV, _N_EV = 0, 1, 2, 3, 4  # int state
_RUNNING = -99


@_njit_nort
def _advance(
    rhs, events, n_events, ev_dir, ev_term, t_bound, params, rtol, atol, max_step, fixed_step,
    max_steps, store_dense, K, Fc, y, y_new, ytmp, yev, g_old, g_new, gtmp, act_k, act_t,
    ts, ys, hs, F, ev_idx, ev_t, ev_y, fstate, istate, stop,
):  # fmt: skip
    """Take accepted steps until the run ends or an output buffer has no room for another step.

    The whole step loop runs here, without the numba runtime: it only indexes preallocated arrays.
    In the NRT-compiled caller every array reassigned inside the loop (the growing buffers) cost
    an atomic incref/decref pair per step; together about 10 % of the thesis run.  The state
    between calls is in ``fstate`` (t, h_abs) and ``istate`` (status, m, n_rej, nfev, n_ev);
    K[0] holds f(t, y) and g_old the event values at t. Every ``_POLL_EVERY`` steps it polls for
    signals (:func:`._signals.poll`, ``stop``): a Ctrl-C ends the loop with status ``_INTERRUPTED``.
    """
    n = y.size
    nF = INTERPOLATOR_POWER * n
    direction = 1.0 if t_bound >= ts[0] else -1.0
    need_dense = store_dense or n_events > 0
    t, h_abs = fstate[_T], fstate[_H_ABS]
    status, m, n_rej, nfev, n_ev = istate[0], istate[1], istate[2], istate[3], istate[4]

    while status == _RUNNING:
        if m % _POLL_EVERY == 0 and _signals.poll(stop):
            status = _INTERRUPTED
            break
        # room for one more step and all the events it can report
        if m + 2 > ts.size or m + 1 > hs.size or (m + 2) * n > ys.size:
            break
        if store_dense and (m + 1) * nF > F.size:
            break
        if n_ev + n_events > ev_t.size:
            break

        # ---- one accepted step (scipy RungeKutta._step_impl) ----
        min_step = 10.0 * abs(np.nextafter(t, direction * np.inf) - t)
        if fixed_step > 0.0:
            h_abs = fixed_step
        if h_abs > max_step:
            h_abs = max_step
        elif h_abs < min_step:
            h_abs = min_step
        rejected = False
        last_nonfinite = False
        failed = False
        h = 0.0
        t_new = t
        while True:
            if h_abs < min_step:
                failed = True
                break
            h = h_abs * direction
            t_new = t + h
            if direction * (t_new - t_bound) > 0:
                t_new = t_bound
            h = t_new - t
            h_abs = abs(h)

            _rk_stages(rhs, params, t, y, h, K, ytmp, y_new)
            nfev += N_STAGES
            error_norm = _error_norm(K, y, y_new, rtol, atol, h_abs)  # nan: not finite
            finite = math.isfinite(error_norm)

            if fixed_step > 0.0:
                last_nonfinite = not finite
                failed = not finite
                break
            if finite and error_norm < 1.0:
                if error_norm == 0.0:
                    factor = MAX_FACTOR
                else:
                    factor = _pymin(MAX_FACTOR, SAFETY * error_norm**_ERROR_EXPONENT)
                if rejected:
                    factor = _pymin(1.0, factor)
                h_abs *= factor
                break
            # rejected; a non-finite trial counts as a huge error: shrink by MIN_FACTOR, as
            # scipy's max(MIN_FACTOR, nan) does
            if finite:
                h_abs *= _pymax(MIN_FACTOR, SAFETY * error_norm**_ERROR_EXPONENT)
            else:
                h_abs *= MIN_FACTOR
            last_nonfinite = not finite
            rejected = True
            n_rej += 1

        if failed:
            status = NON_FINITE if last_nonfinite else STEP_TOO_SMALL
            break

        # ---- continuous extension of the accepted step (3 extra stages) ----
        if need_dense:
            _dense_coefficients(rhs, params, t, y, y_new, h, K, ytmp, Fc)
            nfev += N_STAGES_EXTENDED - N_STAGES - 1

        # ---- events: sign changes over the step, located on the interpolant ----
        t_stop = t_new
        terminate = False
        if n_events > 0:
            events(t_new, y_new, params, g_new)
            n_act = 0
            for k in range(n_events):
                ga, gb = g_old[k], g_new[k]
                # a zero at the start of the step was reported with the previous step (or is the
                # initial point), so it does not count again
                up = ga < 0.0 and gb >= 0.0
                down = ga > 0.0 and gb <= 0.0
                d = ev_dir[k]
                hit = (up and d >= 0.0) or (down and d <= 0.0)
                xb, fb = t_new, gb
                if not hit and abs(d) > 1.5 and (-d) * ga > 0.0 and (-d) * gb > 0.0:
                    # a grazing event (|direction| 2): a zero pair inside the step?
                    xb, fb = _graze(events, params, k, Fc, y, t, h, ga, gb, -0.5 * d, yev, gtmp)
                    hit = xb == xb
                if hit:
                    root = _event_root(events, params, k, Fc, y, t, h, t, xb, ga, fb, yev, gtmp)
                    # insertion sort by time along the direction of integration
                    j = n_act
                    while j > 0 and direction * act_t[j - 1] > direction * root:
                        act_t[j] = act_t[j - 1]
                        act_k[j] = act_k[j - 1]
                        j -= 1
                    act_t[j] = root
                    act_k[j] = k
                    n_act += 1
            for j in range(n_act):
                ev_idx[n_ev] = act_k[j]
                ev_t[n_ev] = act_t[j]
                _dense_eval(Fc, y, t, h, act_t[j], yev)
                _put(yev, ev_y, n_ev * n)
                n_ev += 1
                if ev_term[act_k[j]] != 0.0:
                    terminate = True
                    t_stop = act_t[j]
                    break
            _copy(g_new, g_old)

        # ---- store the step ----
        m += 1
        hs[m - 1] = h
        if store_dense:
            _put_rows(Fc, F, (m - 1) * nF)
        if terminate:
            ts[m] = t_stop
            _dense_eval(Fc, y, t, h, t_stop, yev)
            _put(yev, ys, m * n)
            t = t_stop
            status = TERMINAL_EVENT
            break
        ts[m] = t_new
        _put(y_new, ys, m * n)
        t = t_new
        _copy(y_new, y)
        _copy_row(K, N_STAGES, 0)
        if direction * (t - t_bound) >= 0:
            status = COMPLETED
        elif m >= max_steps:
            status = MAX_STEPS

    fstate[_T], fstate[_H_ABS] = t, h_abs
    istate[0], istate[1], istate[2], istate[3], istate[4] = status, m, n_rej, nfev, n_ev


# Results come back as flat 1-D arrays (reshaped in Python): growing only 1-D buffers keeps the
# number of compiled specialisations, and so the cold compile time, down.
_KERNEL_RESULT = types.Tuple((_i8, _f8, _i8, _i8, _i8, _vec, _vec, _vec, _vec, _ivec, _vec, _vec))
_KERNEL_SIGNATURE = _KERNEL_RESULT(
    _fn,  # rhs
    _fn,  # events
    _i8,  # n_events
    _vec,  # event directions (+1, -1, 0)
    _vec,  # event terminal flags (1.0 / 0.0)
    _f8,  # t0
    _f8,  # t_bound
    _vec,  # y0
    _vec,  # params
    _vec,  # rtol per component
    _vec,  # atol per component
    _f8,  # first step (0: automatic)
    _f8,  # max step
    _f8,  # fixed step (0: adaptive)
    _i8,  # max steps
    types.boolean,  # store the dense output
    _ivec,  # stop: the signal flags of _signals.poll
)


def _integrate(
    rhs,
    events,
    n_events,
    ev_dir,
    ev_term,
    t0,
    t_bound,
    y0,
    params,
    rtol,
    atol,
    first_step,
    max_step,
    fixed_step,
    max_steps,
    store_dense,
    stop,
):
    """The compiled DOP853 loop; see :func:`solve` for the meaning of the arguments.

    Returns ``(status, t_last, nfev, n_accepted, n_rejected, ts, ys, hs, F, ev_index, ev_t,
    ev_y)`` with m accepted steps: the breakpoints ``ts`` (m+1,), the states ``ys`` ((m+1)·n,),
    the step of each interpolant ``hs`` (m,), its coefficients ``F`` (m·7·n,; empty unless
    ``store_dense``), and the events in the order they occurred (``ev_y`` flat, n per event).

    This function allocates (and grows) the arrays; :func:`_advance` takes the steps.
    """
    n = y0.size
    nF = INTERPOLATOR_POWER * n
    direction = 1.0 if t_bound >= t0 else -1.0

    # work arrays, allocated once
    K = np.empty((N_STAGES_EXTENDED, n))  # K[0] is f(t, y) of the current step (FSAL)
    Fc = np.empty((INTERPOLATOR_POWER, n))
    y = y0.copy()
    y_new = np.empty(n)
    ytmp = np.empty(n)
    yev = np.empty(n)
    g_old = np.empty(n_events)
    g_new = np.empty(n_events)
    gtmp = np.empty(n_events)
    act_k = np.empty(n_events, dtype=np.int64)
    act_t = np.empty(n_events)
    fstate = np.zeros(2)
    istate = np.zeros(5, dtype=np.int64)

    # output buffers, grown by doubling when _advance reports them full
    cap = min(1024, max_steps + 2)
    ts = np.empty(cap)
    ys = np.empty(cap * n)
    hs = np.empty(cap)
    F = np.empty(cap * nF if store_dense else 0)
    ev_idx = np.empty(max(8, n_events), dtype=np.int64)
    ev_t = np.empty(ev_idx.size)
    ev_y = np.empty(ev_idx.size * n)

    ts[0] = t0
    _put(y, ys, 0)
    rhs(t0, y, params, K[0])
    nfev = 1
    h_abs = 0.0
    if not _all_row_finite(K, 0):
        status = NON_FINITE
    elif t_bound == t0:
        status = COMPLETED
    else:
        status = _RUNNING
        if n_events > 0:
            events(t0, y, params, g_old)
        if fixed_step > 0.0:
            h_abs = fixed_step
        elif first_step > 0.0:
            h_abs = first_step
        else:
            h_abs = _initial_step(
                rhs, params, t0, y, K[0], t_bound, max_step, direction, rtol, atol, ytmp, K[1]
            )
            nfev += 1
    fstate[_T], fstate[_H_ABS] = t0, h_abs
    istate[_STATUS], istate[_NFEV] = status, nfev

    while istate[_STATUS] == _RUNNING:
        _advance(
            rhs, events, n_events, ev_dir, ev_term, t_bound, params, rtol, atol, max_step,
            fixed_step, max_steps, store_dense, K, Fc, y, y_new, ytmp, yev, g_old, g_new, gtmp,
            act_k, act_t, ts, ys, hs, F, ev_idx, ev_t, ev_y, fstate, istate, stop,
        )  # fmt: skip
        m, n_ev = istate[_M], istate[_N_EV]
        if m + 2 > ts.size:
            ts = _grow(ts, m + 2, max_steps + 2)
        if m + 1 > hs.size:
            hs = _grow(hs, m + 1, max_steps + 1)
        if (m + 2) * n > ys.size:
            ys = _grow(ys, (m + 2) * n, (max_steps + 2) * n)
        if store_dense and (m + 1) * nF > F.size:
            F = _grow(F, (m + 1) * nF, (max_steps + 1) * nF)
        if n_ev + n_events > ev_t.size:
            n_big = 2 * ev_t.size + n_events
            ev_idx = _grow(ev_idx, n_ev + n_events, n_big)
            ev_t = _grow(ev_t, n_ev + n_events, n_big)
            ev_y = _grow(ev_y, (n_ev + n_events) * n, n_big * n)

    status, m, n_rej, nfev, n_ev = istate[0], istate[1], istate[2], istate[3], istate[4]
    n_dense = m * nF if store_dense else 0
    return (
        status,
        fstate[_T],
        nfev,
        m,
        n_rej,
        _trimmed(ts, m + 1),
        _trimmed(ys, (m + 1) * n),
        _trimmed(hs, m),
        _trimmed(F, n_dense),
        ev_idx[:n_ev].copy(),
        ev_t[:n_ev].copy(),
        ev_y[: n_ev * n].copy(),
    )


# Compiled here, at import (the signature is explicit). Passing rhs and events on from the loop
# that grows the buffers to _advance makes numba unify their function types, which it reports as
# an experimental feature on every cold compile; first-class functions are what this module is
# built on (see the module docstring), so the warning is noise.
with warnings.catch_warnings():
    warnings.simplefilter("ignore", numba.NumbaExperimentalFeatureWarning)
    _integrate = numba.njit(_KERNEL_SIGNATURE, cache=True)(_integrate)


@_njit_nort
def _dense_many(ts, ys, hs, F, sign, tt, out):
    """``out[j]`` = the interpolant at ``tt[j]``, as :func:`_dense_eval` (the same operations).

    Segment i holds sign·ts[i] <= sign·t < sign·ts[i+1]; the end segments extrapolate.
    """
    m = hs.size
    n = out.shape[1]
    for j in range(tt.size):
        t = tt[j]
        lo, hi = 0, ts.size  # binary search: numpy's searchsorted(side="right") on sign·ts
        while lo < hi:
            mid = (lo + hi) // 2
            if sign * ts[mid] <= sign * t:
                lo = mid + 1
            else:
                hi = mid
        i = min(max(lo - 1, 0), m - 1)
        x = (t - ts[i]) / hs[i]
        xm = 1.0 - x
        for c in range(n):
            acc = F[i, 6, c] * x
            acc = (acc + F[i, 5, c]) * xm
            acc = (acc + F[i, 4, c]) * x
            acc = (acc + F[i, 3, c]) * xm
            acc = (acc + F[i, 2, c]) * x
            acc = (acc + F[i, 1, c]) * xm
            acc = (acc + F[i, 0, c]) * x
            out[j, c] = ys[i, c] + acc


@numba.njit(cache=True)
def _no_events(t, y, params, out):
    # stands in for ``events`` when there are none (n_events = 0: never called)
    pass


# --- Python side ----------------------------------------------------------------------------------


class DenseOutput:
    """The piecewise 7th-order continuous extension of a DOP853 run (evaluated compiled).

    Segment ``i`` covers ``[t[i], t[i+1]]`` with the interpolant of the step that started at
    ``t[i]`` with size ``h[i]`` (after a terminal event the last segment ends before ``t[i] + h[i]``).
    Between steps the interpolant is continuous and matches the solution to the order of the
    method; outside ``[t_min, t_max]`` the end segments are extrapolated (not accurate).

    Parameters
    ----------
    t : ndarray, shape (m+1,)
        Breakpoints (step times), monotonic in the direction of integration.
    y : ndarray, shape (m+1, n)
        States at the breakpoints.
    h : ndarray, shape (m,)
        Step size of each segment's interpolant (signed).
    F : ndarray, shape (m, 7, n)
        Interpolant coefficients of each segment (scipy's ``Dop853DenseOutput.F``).
    """

    def __init__(self, t: np.ndarray, y: np.ndarray, h: np.ndarray, F: np.ndarray) -> None:
        self.t = np.ascontiguousarray(t, dtype=float)
        self.y = np.ascontiguousarray(y, dtype=float)
        self.h = np.ascontiguousarray(h, dtype=float)
        self.F = np.ascontiguousarray(F, dtype=float)
        self._sign = 1.0 if t.size < 2 or t[-1] >= t[0] else -1.0

    @property
    def ts(self) -> np.ndarray:
        """The breakpoints ``t`` (the name of scipy's ``OdeSolution.ts``)."""
        return self.t

    @property
    def t_min(self) -> float:
        """Smallest time covered."""
        return float(min(self.t[0], self.t[-1]))

    @property
    def t_max(self) -> float:
        """Largest time covered."""
        return float(max(self.t[0], self.t[-1]))

    def __call__(self, t: ArrayLike) -> np.ndarray:
        """States at times ``t``: shape (n,) for a scalar, (n, k) for k times (scipy's layout)."""
        tt = np.asarray(t, dtype=float)
        scalar = tt.ndim == 0
        tt = np.atleast_1d(tt).ravel()
        if self.h.size == 0:  # no step taken: only the initial state is known
            out = np.repeat(self.y[:1], tt.size, axis=0).T
            return out[:, 0] if scalar else out
        # compiled: the numpy form of this loop (a (k, 7, n) gather and Horner's scheme on arrays)
        # took 4 ms for the 10 000 times of a crossing search on the thesis run, this 0.2 ms
        out = np.empty((tt.size, self.y.shape[1]))
        _dense_many(self.t, self.y, self.h, self.F, self._sign, tt, out)
        return out[0] if scalar else out.T

    def truncate(self, t_stop: float) -> DenseOutput:
        """The same solution ending at ``t_stop`` (inside its last kept step), as a terminal
        event that ends the run there leaves it (the steps after it dropped)."""
        k = int(np.searchsorted(self.t, t_stop, side="left"))  # t[k-1] < t_stop <= t[k]
        k = max(k, 1)
        t = np.append(self.t[:k], t_stop)
        y = np.vstack([self.y[:k], self(t_stop)[None, :]])
        return DenseOutput(t, y, self.h[:k], self.F[:k])


@dataclass
class Solution:
    """Result of :func:`solve`.

    Attributes
    ----------
    t : ndarray, shape (k,)
        Step times, or the requested ``t_eval`` up to where the run ended.
    y : ndarray, shape (n, k)
        States at ``t`` (scipy's layout: one row per component).
    dense : DenseOutput or None
        The continuous solution (``dense_output=True``).
    t_events, y_events : list of ndarray
        Per event function: the times (k_i,) and states (k_i, n) of its zeros, in order.
    event_index, event_t, event_y : ndarray
        All events in the order they occurred: which event, when, and the state (·, n).
    status : int
        :data:`COMPLETED`, :data:`TERMINAL_EVENT` or a failure (< 0): :data:`STEP_TOO_SMALL`,
        :data:`NON_FINITE`, :data:`MAX_STEPS`.
    message : str
        Human-readable status, with the time of a failure.
    nfev : int
        Number of right-hand-side evaluations.
    n_accepted, n_rejected : int
        Accepted and rejected steps.
    t_steps : ndarray, shape (m+1,)
        Step times (the breakpoints of the dense output), even when ``t_eval`` was given.
    """

    t: np.ndarray
    y: np.ndarray
    dense: DenseOutput | None
    t_events: list[np.ndarray]
    y_events: list[np.ndarray]
    event_index: np.ndarray
    event_t: np.ndarray
    event_y: np.ndarray
    status: int
    message: str
    nfev: int
    n_accepted: int
    n_rejected: int
    t_steps: np.ndarray = field(repr=False)

    @property
    def success(self) -> bool:
        """True if the run completed or stopped at a terminal event."""
        return self.status >= 0


def _per_component(name: str, value: ArrayLike, n: int) -> np.ndarray:
    arr = np.asarray(value, dtype=float)
    if arr.ndim > 1 or (arr.ndim == 1 and arr.size != n):
        raise ValueError(f"{name} must be a scalar or have one entry per component ({n}); got "
                         f"shape {arr.shape}")  # fmt: skip
    if not np.all(np.isfinite(arr)) or np.any(arr < 0):
        raise ValueError(f"{name} must be finite and non-negative; got {value!r}")
    # a fresh writeable array: numba types read-only arrays differently from the kernel signature
    return np.array(np.broadcast_to(arr, (n,)), dtype=float)


def _check_function(name: str, fn: Any) -> None:
    if not isinstance(fn, numba.core.dispatcher.Dispatcher):
        raise TypeError(
            f"{name} must be a numba.njit function {name}(t, y, params, out) -> None; got "
            f"{type(fn).__name__}"
        )


def solve(
    rhs: Callable[..., None],
    t_span: tuple[float, float],
    y0: ArrayLike,
    params: ArrayLike = (),
    *,
    rtol: ArrayLike = 1e-3,
    atol: ArrayLike = 1e-6,
    events: Callable[..., None] | None = None,
    direction: Sequence[float] | None = None,
    terminal: Sequence[bool] | None = None,
    grazing: Sequence[bool] | None = None,
    t_eval: ArrayLike | None = None,
    dense_output: bool = True,
    first_step: float | None = None,
    max_step: float = np.inf,
    max_steps: int = 1_000_000,
    fixed_step: float | None = None,
) -> Solution:
    """Integrate ``dy/dt = rhs(t, y)`` with the compiled DOP853 method.

    Same method, defaults and step-size control as ``scipy.integrate.solve_ivp(method="DOP853")``,
    so with equal tolerances it takes the same steps; numerical failure is reported in
    ``status``/``message``, never raised.

    Parameters
    ----------
    rhs : numba dispatcher
        ``@numba.njit`` function ``rhs(t, y, params, out) -> None`` writing dy/dt into ``out``.
        Define it at module level with ``cache=True`` so new processes load it from the cache.
    t_span : (float, float)
        Start and end time; integration may run backwards (end < start).
    y0 : array_like, shape (n,)
        Initial state.
    params : array_like
        Parameters handed to ``rhs`` and ``events`` as a float64 array.
    rtol, atol : float or array_like, shape (n,)
        Relative and absolute tolerances, as in scipy (rtol is raised to 100 ε with a warning).
    events : numba dispatcher, optional
        ``@numba.njit`` function ``events(t, y, params, out) -> None`` writing the values of all
        event functions into ``out`` (length ``len(direction)``).  An event is a sign change of
        one entry over a step; its time is found on the dense output by Brent's method to a few ε
        relative, so its accuracy is that of the interpolant (about the tolerance).  A zero at
        ``t_span[0]`` is not an event.
    direction : sequence of float, optional
        Per event: +1 counts only crossings from negative to positive, −1 only from positive to
        negative, 0 both.  Required with ``events``; its length is the number of events.
    terminal : sequence of bool, optional
        Per event: stop at its first occurrence (default all False).
    grazing : sequence of bool, optional
        Per event (with a direction): also look for a zero pair inside each step, where the
        event dips through zero and back between two step ends (an interior extremum beyond
        zero, found by a parabola through the ends and the midpoint and refined by golden-section
        search on the interpolant; one extra event evaluation per step, more only near such an
        extremum). The zero before the extremum is then reported as any other.
    t_eval : array_like, optional
        Times at which to report the solution (from the dense output) instead of the steps; they
        must lie in ``t_span`` and be sorted along the direction of integration.
    dense_output : bool
        Keep the interpolant (``Solution.dense``); costs 3 extra right-hand-side calls per step.
    first_step : float, optional
        Initial step size; default: scipy's automatic choice.
    max_step : float
        Largest allowed step size.
    max_steps : int
        Give up (status :data:`MAX_STEPS`) after this many accepted steps.
    fixed_step : float, optional
        Take steps of exactly this size (the last one shortened to end at ``t_span[1]``) with no
        error control: the plain 8th-order Runge–Kutta method, for convergence studies.

    Returns
    -------
    Solution

    Raises
    ------
    TypeError
        If ``rhs`` or ``events`` is not a numba-jitted function.
    ValueError
        For inconsistent or non-finite input.
    """
    _check_function("rhs", rhs)
    t0, t1 = (float(v) for v in t_span)
    if not (math.isfinite(t0) and math.isfinite(t1)):
        raise ValueError(f"t_span must be finite; got {t_span!r}")
    y0 = np.array(y0, dtype=float)
    if y0.ndim != 1 or y0.size == 0:
        raise ValueError(f"y0 must be a non-empty 1-D array; got shape {y0.shape}")
    if not np.all(np.isfinite(y0)):
        raise ValueError("y0 must be finite")
    n = y0.size
    p = np.array(params, dtype=float).ravel()
    if p.size == 0:
        p = np.zeros(1)  # numba needs a float64[::1]; an unused placeholder
    rtol_arr = _per_component("rtol", rtol, n)
    if np.any(rtol_arr < 100 * _EPS):
        warnings.warn(
            f"At least one element of `rtol` is too small. Setting `rtol = max(rtol, {100 * _EPS})`.",
            ToleranceWarning,
            stacklevel=2,  # the caller of solve
        )
        rtol_arr = np.maximum(rtol_arr, 100 * _EPS)
    atol_arr = _per_component("atol", atol, n)

    ev_fn: Callable[..., Any]
    if events is None:
        n_events = 0
        ev_fn = _no_events
        ev_dir = np.zeros(0)
        ev_term = np.zeros(0)
    else:
        _check_function("events", events)
        if direction is None:
            raise ValueError("direction is required with events (one entry per event function)")
        ev_fn = events
        ev_dir = np.sign(np.array(direction, dtype=float)).ravel()
        n_events = ev_dir.size
        if terminal is None:
            ev_term = np.zeros(n_events)
        else:
            ev_term = np.array(terminal, dtype=bool).ravel().astype(float)
            if ev_term.size != n_events:
                raise ValueError(
                    f"terminal must have one entry per event ({n_events}); got {ev_term.size}"
                )
        if grazing is not None:
            graze = np.array(grazing, dtype=bool).ravel()
            if graze.size != n_events:
                raise ValueError(
                    f"grazing must have one entry per event ({n_events}); got {graze.size}"
                )
            if np.any(graze & (ev_dir == 0.0)):
                raise ValueError("a grazing event needs a direction (-1 or +1)")
            ev_dir = np.where(graze, 2.0 * ev_dir, ev_dir)  # |direction| 2 marks it for _advance

    sign = 1.0 if t1 >= t0 else -1.0
    te = None
    if t_eval is not None:
        te = np.asarray(t_eval, dtype=float).ravel()
        lo, hi = min(t0, t1), max(t0, t1)
        if np.any(te < lo) or np.any(te > hi):
            raise ValueError(f"t_eval must lie within t_span {t_span!r}")
        if np.any(sign * np.diff(te) < 0):
            raise ValueError("t_eval must be sorted in the direction of integration")
    fs = 0.0
    if first_step is not None:
        fs = float(first_step)
        if not 0.0 < fs <= abs(t1 - t0):
            raise ValueError(f"first_step must lie in (0, |t1 - t0|]; got {first_step!r}")
    ms = float(max_step)
    if not ms > 0.0:
        raise ValueError(f"max_step must be positive; got {max_step!r}")
    hf = 0.0
    if fixed_step is not None:
        hf = float(fixed_step)
        if not (math.isfinite(hf) and hf > 0.0):
            raise ValueError(f"fixed_step must be positive and finite; got {fixed_step!r}")
    store = bool(dense_output or te is not None)

    # A Ctrl-C during the run stops the loop within _POLL_EVERY steps and is raised here as
    # KeyboardInterrupt (see mett.dynamics._signals: raised inside numba's call wrapper it
    # crashed the process)
    stop = _signals.new_stop()
    with _signals.deferred_sigint(stop):
        (status, t_last, nfev, n_acc, n_rej, ts, ys, hs, F, ev_idx, ev_t, ev_y) = _integrate(
            rhs, ev_fn, n_events, ev_dir, ev_term, t0, t1, y0, p, rtol_arr, atol_arr,
            fs, ms, hf, int(max_steps), store, stop,
        )  # fmt: skip
    _signals.raise_pending(stop)
    ys = ys.reshape(-1, n)
    ev_y = ev_y.reshape(-1, n)
    dense = DenseOutput(ts, ys, hs, F.reshape(-1, INTERPOLATOR_POWER, n)) if store else None

    message = STATUS_MESSAGES[status]
    if status < 0:
        message = f"{message} (at t = {t_last!r})"
        if status == MAX_STEPS:
            message = f"Maximum number of steps ({max_steps}) reached (at t = {t_last!r})."
    if te is not None:
        assert dense is not None  # stored whenever there are event times
        te = te[sign * te <= sign * t_last]
        t_out, y_out = te, dense(te)
    else:
        t_out, y_out = ts, ys.T
    return Solution(
        t=t_out,
        y=y_out,
        dense=dense if dense_output else None,
        t_events=[ev_t[ev_idx == k] for k in range(n_events)],
        y_events=[ev_y[ev_idx == k] for k in range(n_events)],
        event_index=ev_idx,
        event_t=ev_t,
        event_y=ev_y,
        status=int(status),
        message=message,
        nfev=int(nfev),
        n_accepted=int(n_acc),
        n_rejected=int(n_rej),
        t_steps=ts,
    )
