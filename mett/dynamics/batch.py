"""Many runs at once, keeping only how each ended: the fast path of :func:`mett.sweep`.

A sweep needs from each run its status, where it ended (θ, ω3), the first time θ crosses π/2 and
whether it had settled (θ and the energy over the last part of the run). :func:`run_ends` gets
these for many (top, state) pairs: runs on the Taylor backend of a single-phase model that
declares ``cos_theta`` go through :func:`mett.dynamics.taylor.propagate` ``LANES`` at a time (SIMD
lanes, no dense output: each step's coefficients are overwritten by the next, so they stay in
cache; the crossing of θ = π/2 is a recording event located on the Taylor polynomial of cos θ, the
window's states come from the step polynomials); every other run is an ordinary
:func:`mett.simulate`, summarised the same way (:func:`end_of`). Both give a :class:`RunEnd`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np

from ._run import PreparedRun
from .backends import REGISTRY, TaylorBackend
from .registry import lookup
from .simulation import SIMULATE_DEFAULTS, plan_runs, prepare_planned, prepare_run, run_prepared
from .trajectory import Trajectory

__all__ = ["LANES", "RunEnd", "end_of", "run_ends"]

_NOT_A_POINT = (MemoryError, RecursionError, SystemError)
"""Failures of the process, not of a run's input: they propagate (like KeyboardInterrupt, which
is no ``Exception``) instead of being recorded as the point's outcome, so a sweep never keeps them
as a row and a resumed sweep runs the point again."""

LANES = 4
"""Trajectories per SIMD batch: four doubles fill an AVX2 register (measured on the thesis top:
0.45 µs per trajectory-step with 4 lanes, 1.6 µs with 1; 8 lanes were slower than 4)."""


class RunEnd(NamedTuple):
    """How a run ended (:func:`run_ends`).

    Attributes
    ----------
    status, message : str
        As :attr:`mett.Trajectory.status` and ``message``.
    t_stop : float
        Where the run ended (s).
    theta_end, omega3_end : float
        θ (rad) and ω3 (rad/s) there.
    t_cross : float
        First time θ crosses π/2 (s); NaN if never.
    window : ndarray
        Times (s) spread over the last ``window`` fraction of a completed run (empty for the
        others).
    theta_window : ndarray
        θ (rad) at those times.
    E_window : ndarray
        The energy E (J) at the first and the last of those times (all that the settled test of
        :func:`mett.sweep` compares; empty without a window).
    E0 : float
        The energy at the start (J).
    """

    status: str
    message: str
    t_stop: float
    theta_end: float
    omega3_end: float
    t_cross: float
    window: np.ndarray
    theta_window: np.ndarray
    E_window: np.ndarray
    E0: float


def _window(t0: float, t1: float, window: float, n: int) -> np.ndarray:
    return np.linspace(t1 - window * (t1 - t0), t1, n)


def end_of(traj: Any, *, window: float = 0.25, n_window: int = 101) -> RunEnd:
    """The :class:`RunEnd` of a finished :class:`~mett.Trajectory`."""
    t0, t1 = float(traj.t[0]), float(traj.t[-1])
    # only a completed run has a window (whether it settled means nothing for the others)
    tw = _window(t0, t1, window, n_window if traj.status == "completed" else 0)
    late = lookup(traj.model).derive(traj.states_at(tw), traj.params)
    energy = np.asarray(late["E"], dtype=float)
    cross = traj.crossings(math.pi / 2)
    return RunEnd(
        traj.status, traj.message, t1, float(traj.theta[-1]), float(traj.omega3[-1]),
        float(cross[0]) if cross.size else math.nan, tw, np.asarray(late["theta"], dtype=float),
        energy[[0, -1]] if energy.size else energy, float(traj.E[0]),
    )  # fmt: skip


_TAYLOR: TaylorBackend = REGISTRY["taylor"]  # type: ignore[assignment]


def run_ends(
    jobs: Sequence[tuple[Any, Any] | tuple[Any, Any, dict]],
    t_end: float,
    *,
    window: float = 0.25,
    n_window: int = 101,
    **simulate_kw: Any,
) -> list[RunEnd | BaseException]:
    """How each of the runs ``simulate(top, state, t_end, **simulate_kw, **options)`` ends, for
    ``jobs`` = [(top, state) or (top, state, options), ...]: a :class:`RunEnd`, or the exception
    the run raised (bad input). An interrupt (KeyboardInterrupt) and a failure of the process
    (MemoryError, RecursionError, SystemError) are raised, never returned as a run's outcome.

    Runs of the Taylor backend (``backend="taylor"``) of a single-phase model with ``cos_theta``
    and no user events go ``LANES`` at a time through :func:`mett.dynamics.taylor.propagate`;
    their steps, end states and crossing times are those of ``simulate`` with the same
    arguments (the same jet, step rule and event location), up to the rounding of SIMD lanes.
    The others run one by one. ``window``: the fraction of each run over which ``n_window``
    samples of θ are returned, with E at the first and last of them (for judging whether it
    settled).
    """
    # sweeps stop where contact is lost (status "contact_lost"): flight is simulate's alone
    kw = {**SIMULATE_DEFAULTS, **simulate_kw, "stop_on_contact_loss": True}
    out: list[Any] = [None] * len(jobs)
    fast: dict[Any, list[tuple[int, PreparedRun]]] = {}
    kernels: dict[tuple, Any] = {}
    starts: dict[tuple, Any] = {}  # the starts of the runs, shared by those differing in μ alone
    # The options common to the jobs are checked once (a job's own friction law is applied to
    # its top, so such a job is prepared whole); options simulate would refuse are left to
    # prepare_run, which reports them for each job as simulate does
    try:
        plan = plan_runs(t_end, **kw) if kw.get("friction") is None else None
    except _NOT_A_POINT:
        raise
    except Exception:
        plan = None
    for j, (top, state, *own) in enumerate(jobs):
        try:
            if plan is not None and not (own and own[0]):
                prep = prepare_planned(plan, top, state, starts)
            else:
                prep = prepare_run(top, state, t_end, **{**kw, **(own[0] if own else {})})
            if isinstance(prep, Trajectory):  # decided at t = 0
                out[j] = end_of(prep, window=window, n_window=n_window)
            elif _TAYLOR.batchable(prep):
                # the kernel of the previous run of this model, phase and order, if its branches
                # are this run's (the lookup by value costs more than the check; the runs hold
                # the model and phase, so their ids are theirs through this call)
                key = (id(prep.model), id(prep.phase), prep.rtol, prep.y0.size)
                k = kernels.get(key)
                if k is None or not k.traced.admits(prep.params):
                    k = kernels[key] = _TAYLOR.batch_kernel(prep, LANES)
                fast.setdefault((k, prep.max_step), []).append((j, prep))
            else:
                out[j] = end_of(run_prepared(prep), window=window, n_window=n_window)
        except _NOT_A_POINT:
            raise
        except Exception as exc:  # the caller records it with the point
            out[j] = exc
    for (k, max_step), items in fast.items():
        try:
            _propagate_group(k, max_step, items, t_end, window, n_window, out)
        except _NOT_A_POINT:
            raise
        except Exception as exc:  # each run of the group records it
            for j, _ in items:
                out[j] = exc
    return out


def _propagate_group(
    k: Any,
    max_step: float,
    items: list[tuple[int, PreparedRun]],
    t_end: float,
    window: float,
    n_window: int,
    out: list[Any],
) -> None:
    preps = [prep for _, prep in items]
    tw = _window(0.0, t_end, window, n_window)
    P = np.array([prep.params for prep in preps], dtype=float)
    status, message, t_stop, y_stop, S, t_cross = _TAYLOR.propagate(k, preps, t_end, max_step, tw)
    m, n, n_w = len(preps), preps[0].y0.size, tw.size
    # a run that stopped early has no window (only a completed run is judged settled)
    judged = np.array([s == "completed" for s in status]) & (n_w > 0)
    # One derive for the whole group (Model.derive takes one parameter set per column): of each
    # run's start, its end and the two ends of its window (E there is all the settled test
    # compares), run after run; θ over the windows from the model's cheap theta, also in one
    # call. Built for all runs at once, in the columns (and memory order) of one run at a time.
    blocks = np.empty((m, 4, n))
    blocks[:, 0] = [prep.y0 for prep in preps]
    blocks[:, 1] = y_stop
    if n_w:
        blocks[:, 2], blocks[:, 3] = S[:, 0], S[:, -1]
    keep = np.ones((m, 4), dtype=bool)
    keep[:, 2:] = judged[:, None]
    width = keep.sum(axis=1)
    mdl = preps[0].model
    series = mdl.derive(np.ascontiguousarray(blocks[keep].T), _column_params(P, width))
    windows = np.ascontiguousarray(S[judged].transpose(2, 0, 1).reshape(n, -1))
    theta_w = np.asarray(mdl.theta(windows, _column_params(P, judged * n_w)), dtype=float)
    at = np.concatenate(([0], np.cumsum(width)[:-1]))  # each run's first column
    theta_end = np.asarray(series["theta"], dtype=float)[at + 1].tolist()
    omega3_end = np.asarray(series["omega3"], dtype=float)[at + 1].tolist()
    energy = np.asarray(series["E"], dtype=float)
    e0 = energy[at].tolist()
    # the first crossing, where it came before the run's end
    cross = np.where(t_cross <= t_stop, t_cross, math.nan).tolist()
    stops = t_stop.tolist()
    # each judged run's window: θ and E as views of the group's arrays, in run order
    theta_rows = theta_w.reshape(-1, n_w) if n_w else theta_w.reshape(0, 0)
    e_rows = energy[(at[judged] + 2)[:, None] + np.arange(2)]
    none_tw, none_th, none_e = tw[:0], theta_w[:0], energy[:0]
    w = 0
    for row, (j, _) in enumerate(items):
        if judged[row]:
            tw_r, th_r, e_r = tw, theta_rows[w], e_rows[w]
            w += 1
        else:
            tw_r, th_r, e_r = none_tw, none_th, none_e
        out[j] = RunEnd(
            status[row], message[row], stops[row], theta_end[row], omega3_end[row], cross[row],
            tw_r, th_r, e_r, e0[row],
        )  # fmt: skip


def _column_params(P: np.ndarray, sizes: Any) -> tuple:
    """The parameters of runs (rows of ``P``) for their columns (``sizes[i]`` of run i): one
    tuple if all runs share them, else one array per parameter, a value per column."""
    if bool(np.all(P == P[0])):
        return tuple(P[0])
    return tuple(np.repeat(P, sizes, axis=0).T)
