"""The deforming potential: the METT along a simulated (gliding) trajectory (docs/theory/equations.md#integrals, docs/theory/mett.md#the-main-equation, docs/theory/estimates.md#estimates).

While the top glides, the METT Ẽ(t) = g(cos θ) θ̇² + V(cos θ, D(t), λ) still holds at every instant,
but D(t) and Ẽ(t) drift: θ moves in a potential that deforms as the top inverts (RR14 §3). This
module evaluates that picture on a :class:`~mett.Trajectory`: the residual of the METT, the potential
V(z, D(t), λ) and its minimum z_min(t), the turning points of θ(t), and the observed θ-oscillation
periods set against the rolling-METT periods with D and Ẽ frozen. Caveat
(docs/theory/estimates.md#gliding-periods): the rolling periods are estimates, not predictions of the
gliding top, whose contact point glides on the time scale of one nutation. The gliding period is
closer to the fast-top value 2π I1/(I3 |ω3|) and may be longer or shorter than the rolling one: in
the thesis run it is longer at the start (0.037 s against 0.032 s, the top oscillates more slowly)
and shorter at the end (0.076 s against 0.092 s); :func:`period_comparison` sets them side by side.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from . import _validate, estimates, potential, separation
from .dynamics import Trajectory

__all__ = [
    "MAX_SUBDIVISION",
    "PeriodComparison",
    "TurningPoints",
    "deforming_potential",
    "mett_residual",
    "minimum_track",
    "period_comparison",
    "theta_extrema",
    "turning_points",
]


def mett_residual(traj: Trajectory, *, relative: bool = True) -> np.ndarray:
    """Ẽ(t) − [g(z) θ̇² + V(z, D(t), λ(t))] at the trajectory's samples.

    Relative to Ẽ(t) by default. ~1e-13 for the thesis run; feeding E instead of Ẽ would give up to
    ~1e-1 (docs/theory/notes.md#energy-vs-modified-energy).
    """
    _validate.instance("traj", traj, Trajectory)
    z = np.cos(traj.theta)
    rhs = potential.g(traj.top, z) * traj.thetadot**2 + potential.V(traj.top, z, traj.D, traj.lam)
    res = traj.E_mod - rhs
    return res / np.abs(traj.E_mod) if relative else res


def deforming_potential(
    traj: Trajectory, times: ArrayLike, z: ArrayLike | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """V(z, D(t), λ) at the given times: the potential θ rides in, and θ(t) itself.

    Returns
    -------
    z : ndarray, shape (nz,)
        Grid of cos θ (default 801 points in (−1, 1)).
    V : ndarray, shape (nt, nz)
        V(z, D(t_i), λ(t_i)) (J).
    theta : ndarray, shape (nt,)
        θ(t_i) from the dense output.

    Raises
    ------
    TypeError
        If ``traj`` is not a :class:`~mett.Trajectory`, or ``times`` or ``z`` are not real numbers.
    ValueError
        If ``times`` or ``z`` have more than one dimension, or ``z`` leaves [−1, 1] (a scalar is a
        grid of one point).
    """
    _validate.instance("traj", traj, Trajectory)
    times = np.atleast_1d(_validate.as_finite_array("times", times))
    if z is None:
        z = np.linspace(-0.9995, 0.9995, 801)
    else:
        z = np.atleast_1d(_validate.cos_theta(z, "z"))
    for name, arr in (("times", times), ("z", z)):
        if arr.ndim != 1:
            raise ValueError(f"{name} must be a scalar or 1-D array; got shape {arr.shape}")
    s = traj.at(times)
    D, lam = _integrals_at(traj, s)
    V = potential.V(traj.top, z[None, :], D[:, None], lam[:, None])
    return z, V, np.asarray(s.theta)


def _integrals_at(traj: Trajectory, s) -> tuple[np.ndarray, np.ndarray]:
    from .integrals import jellett, routh

    return np.atleast_1d(routh(traj.top, s)), np.atleast_1d(jellett(traj.top, s))


def minimum_track(traj: Trajectory, times: ArrayLike | None = None) -> np.ndarray:
    """z_min(t): position (cos θ) of the minimum of V(·, D(t), λ) at the given times.

    Default: 200 times spread over the run. Moves from near 1 to near −1 during an inversion
    (RR14 §3; docs/theory/estimates.md#estimates).
    """
    _validate.instance("traj", traj, Trajectory)
    if times is None:
        times = np.linspace(traj.t[0], traj.t[-1], 200)
    else:
        times = _validate.as_finite_array("times", times)
    s = traj.at(np.atleast_1d(times))
    D, lam = _integrals_at(traj, s)
    return np.array(
        [estimates.potential_minimum(traj.top, d, la) for d, la in zip(D, lam, strict=True)]
    )


class _TurningPointFields(NamedTuple):
    t: np.ndarray
    """Times of θ̇ = 0 (s)."""
    theta: np.ndarray
    """θ at those times (rad)."""
    kind: np.ndarray
    """+1 (``TurningPoints.MAX``) at a maximum of θ, −1 (``TurningPoints.MIN``) at a minimum."""


class TurningPoints(_TurningPointFields):
    """Times and angles at which θ̇ = 0 along a trajectory (the extrema of θ(t)).

    ``kind`` is ``MAX`` (+1) where θ has a maximum (θ̇ goes from + to −) and ``MIN`` (−1) where
    it has a minimum, so ``tp.t[tp.kind == TurningPoints.MAX]`` are the times of the maxima.
    A named tuple ``(t, theta, kind)``; the class constants live on this subclass because a
    ``NamedTuple`` body may hold fields only.
    """

    __slots__ = ()
    MAX = 1
    MIN = -1


def _illinois(fn, lo: np.ndarray, hi: np.ndarray, f_lo: np.ndarray, f_hi: np.ndarray, tol: float):
    """Vectorised Illinois (modified regula falsi): roots of ``fn`` in every bracket at once.

    One call of ``fn`` per iteration for all brackets, so the dense output is evaluated in bulk.
    """
    lo, hi, f_lo, f_hi = (np.array(x, dtype=float) for x in (lo, hi, f_lo, f_hi))
    x = 0.5 * (lo + hi)
    for _ in range(100):
        x_prev = x
        x = hi - f_hi * (hi - lo) / (f_hi - f_lo)
        fx = fn(x)
        left = np.sign(fx) == np.sign(f_lo)
        # Illinois: halve the retained end's value when the same end is kept twice
        f_hi = np.where(left, f_hi * 0.5, fx)
        hi_new = np.where(left, hi, x)
        f_lo = np.where(left, fx, f_lo)
        lo = np.where(left, x, lo)
        hi = hi_new
        # Illinois keeps one end fixed, so the bracket need not shrink: stop on the iterate
        if np.all(np.abs(x - x_prev) <= tol):
            break
    return x


def theta_extrema(traj: Trajectory, *, subdivision: int = 4) -> TurningPoints:
    """Extrema of θ(t) along a simulated trajectory: zeros of θ̇ located on the dense output.

    Not to be confused with :func:`mett.turning_points`, the roots z_a < z_b of the rolling
    separation equation for given (Ẽ, D, λ); these are the times at which the simulated θ turns.

    Each interval between output samples is cut into ``subdivision`` pieces to bracket the sign
    changes of θ̇ (with the solver's own steps as samples, the default of :func:`mett.simulate`,
    that resolves every nutation); all brackets are then refined together to ~1e-13 s.

    Parameters
    ----------
    traj : Trajectory
        A simulated run.
    subdivision : int, default 4
        Pieces per output interval, 1 to :data:`MAX_SUBDIVISION` (10 000). The dense output is
        evaluated in blocks of at most a million points, so memory does not grow with it (the
        time does, linearly).

    Raises
    ------
    TypeError
        If ``traj`` is not a :class:`~mett.Trajectory` or ``subdivision`` not an integer.
    ValueError
        If ``subdivision`` is outside [1, 10 000].
    """
    _validate.instance("traj", traj, Trajectory)
    subdivision = _validate.positive_int("subdivision", subdivision)
    if subdivision > MAX_SUBDIVISION:
        raise ValueError(
            f"subdivision must be an integer in [1, {MAX_SUBDIVISION}]; got {subdivision!r}"
        )
    return _theta_extrema(traj, subdivision)


MAX_SUBDIVISION = 10_000
"""Largest ``subdivision`` of :func:`theta_extrema`: 10 000 pieces per output interval is far
below any nutation the solver's steps could miss; more would only cost time."""
_BLOCK_POINTS = 1_000_000  # dense-output points evaluated at once (memory bound)


def _theta_extrema(traj: Trajectory, subdivision: int) -> TurningPoints:
    """:func:`theta_extrema` without the checks (``subdivision`` may exceed the public bound)."""
    t = np.asarray(traj.t, dtype=float)
    frac = np.arange(subdivision) / subdivision
    per_block = max(1, _BLOCK_POINTS // subdivision)  # output intervals per block
    lo_l: list[np.ndarray] = []
    hi_l: list[np.ndarray] = []
    f_lo_l: list[np.ndarray] = []
    f_hi_l: list[np.ndarray] = []
    for i0 in range(0, max(t.size - 1, 1), per_block):
        i1 = min(i0 + per_block, t.size - 1)
        tb = t[i0 : i1 + 1]
        # each block ends on the sample the next one starts at, so no sign change is missed
        grid = np.append((tb[:-1, None] + np.diff(tb)[:, None] * frac).ravel(), tb[-1])
        thd = np.asarray(traj.at(grid).thetadot)
        idx = np.flatnonzero(thd[:-1] * thd[1:] < 0.0)
        lo_l.append(grid[idx])
        hi_l.append(grid[idx + 1])
        f_lo_l.append(thd[idx])
        f_hi_l.append(thd[idx + 1])
    lo, hi, f_lo, f_hi = (np.concatenate(x) for x in (lo_l, hi_l, f_lo_l, f_hi_l))
    if lo.size == 0:
        return TurningPoints(np.empty(0), np.empty(0), np.empty(0, dtype=int))
    times = _illinois(lambda tt: np.asarray(traj.at(tt).thetadot), lo, hi, f_lo, f_hi, tol=1e-13)
    kinds = np.where(f_lo > 0, 1, -1)
    return TurningPoints(times, traj.theta_at(times), kinds)


def turning_points(traj: Trajectory, *, subdivision: int = 4) -> TurningPoints:
    """Deprecated name of :func:`theta_extrema` (warns with ``MettDeprecationWarning``)."""
    import warnings

    from ._validate import MettDeprecationWarning

    warnings.warn(
        "mett.analysis.turning_points is deprecated: use mett.analysis.theta_extrema (the extrema "
        "of a simulated θ(t)); mett.turning_points is the rolling separation equation's roots",
        MettDeprecationWarning,
        stacklevel=2,
    )
    return theta_extrema(traj, subdivision=subdivision)


class PeriodComparison(NamedTuple):
    """Observed θ-oscillation periods against rolling-METT periods (docs/theory/estimates.md#estimates)."""

    t: np.ndarray
    """Mid-times of the observed periods (s)."""
    observed: np.ndarray
    """Time between successive maxima of θ (s)."""
    rolling: np.ndarray
    """Exact rolling-METT period with Ẽ, D, λ frozen at that time (s); NaN if inadmissible."""
    fast_top: np.ndarray
    """Gliding fast-top period 2π I1/(I3 |ω3|) (s)."""
    estimates: estimates.PeriodEstimates
    """RR14's bounds (T(D0), T(D1)) for the run's λ."""


def period_comparison(traj: Trajectory) -> PeriodComparison:
    """Observed periods of θ(t) set against the rolling METT and the gliding fast-top value.

    The observed period is the time between successive maxima of θ; the rolling period is
    :func:`mett.nutation_period` at (Ẽ(t), D(t), λ) at the mid-time, the period the top would have
    if it stopped gliding there; the fast-top period 2π I1/(I3|ω3|) is the nutation of a gliding top
    at high spin. For the thesis run the observed periods lie between T(D0) and T(D1) and close to
    the fast-top value; the gliding top is slower than the rolling estimate at the start and faster
    at the end (tests/test_analysis.py has the numbers). A nutation whose θ̇ does not reach zero
    (a shoulder in θ instead of a maximum) merges two periods into one observed interval.

    The maxima are searched on the dense output at a step of at most 1/8 of the shortest fast-top
    period, so a run saved at a few ``t_eval`` times is analysed like one saved at every step. The
    mirror-image top (ω3 < 0, λ < 0) has the same periods as its image (D, λ → −D, −λ); a run
    with fewer than two maxima of θ gives empty arrays.

    Raises
    ------
    TypeError
        If ``traj`` is not a :class:`~mett.Trajectory`.
    ValueError
        If the run's Jellett integral is 0 (no spin: the estimates do not apply).
    """
    from .dynamics import Trajectory
    from .integrals import modified_energy

    if not isinstance(traj, Trajectory):
        raise TypeError(f"traj must be a mett.Trajectory; got {type(traj).__name__}")
    lam_run = float(np.median(traj.lam))
    if lam_run == 0.0:
        raise ValueError(
            "traj: the run's Jellett integral is 0 (no spin), so the period estimates do not apply"
        )
    # the mirror image ω3 → −ω3 maps (D, λ) → (−D, −λ) and leaves V and every period unchanged
    sign = 1.0 if lam_run > 0 else -1.0
    est = estimates.period_estimates(traj.top, abs(lam_run))
    tp = _theta_extrema(traj, _subdivision(traj))
    tmax = tp.t[tp.kind == TurningPoints.MAX]
    if tmax.size < 2:
        empty = np.empty(0)
        return PeriodComparison(empty, empty, empty, empty, est)
    mids = 0.5 * (tmax[1:] + tmax[:-1])
    observed = np.diff(tmax)
    s = traj.at(mids)
    D, lam = _integrals_at(traj, s)
    E = np.atleast_1d(modified_energy(traj.top, s))
    theta_mid = np.atleast_1d(s.theta)
    rolling = np.full(mids.shape, np.nan)
    for i in range(mids.size):
        try:
            rolling[i] = separation.nutation_period(
                traj.top, E[i], sign * D[i], sign * lam[i], z0=float(np.cos(theta_mid[i]))
            )
        except ValueError:
            pass
    with np.errstate(divide="ignore"):  # ω3 = 0 at an instant: an infinite fast-top period
        fast = 2 * np.pi * traj.top.I1 / (traj.top.I3 * np.abs(np.atleast_1d(s.omega3)))
    return PeriodComparison(mids, observed, rolling, fast, est)


# Bracketing the maxima of θ needs a few samples per nutation; at most this many in all.
_SAMPLES_PER_PERIOD = 8
_MAX_SEARCH_SAMPLES = 2_000_000


def _subdivision(traj: Trajectory) -> int:
    """Subdivision of the output intervals giving ≥ 8 samples per fast-top period (at least 4)."""
    t = np.asarray(traj.t, dtype=float)
    w3 = float(np.max(np.abs(traj.omega3)))
    if t.size < 2 or w3 == 0.0:
        return 4
    period = 2 * np.pi * traj.top.I1 / (traj.top.I3 * w3)
    need = int(np.ceil(_SAMPLES_PER_PERIOD * float(np.max(np.diff(t))) / period))
    cap = max(4, _MAX_SEARCH_SAMPLES // (t.size - 1))
    return int(min(max(4, need), cap))
