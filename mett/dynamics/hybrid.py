"""The phase driver of hybrid models: a run of phases joined at their switches.

A hybrid model (``Model.phases``, e.g. the stick–slip models of :mod:`.stickslip`) runs one phase
at a time on its backend; a "switch" event starts the phase it names at the located time, with
the event's ``jump`` applied (docs/theory/friction.md).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from ._run import Piece, Run, event_end
from .backends import UserEvents
from .dense import ConstantSolution, SegmentedSolution
from .registry import JumpFailed, Phase
from .trajectory import Trajectory

__all__ = ["MAX_SWITCHES", "geometric_tail", "solve_hybrid"]

MAX_SWITCHES = 100_000
"""A hybrid model's run stops with status "failed" after this many phase switches."""


def geometric_tail(
    intervals: Any, lag: int, ratios: int, spread: float, about_mean: bool = False
) -> tuple[float, float] | None:
    """The ratio q and the remaining time Σ of a Zeno sequence: the last ``intervals`` (s)
    between the events of a bouncing motion (impacts, hops) shrink geometrically, or None.

    The test (shared by the impacts of :mod:`.stem` and the hops of :mod:`.flight`): the last
    ``ratios`` ratios q_k = Δ_k/Δ_{k−lag} all lie in (0, 1) and consecutive ones agree to the
    relative ``spread``, |q_k − q_{k−1}| ≤ spread q_k (with ``about_mean``: each lies within
    ``spread`` of their mean q̄, |q_k − q̄| ≤ spread q̄, which also rejects a slow drift such as
    the ratios k/(k + 1) of the non-summable Δ_k ∝ 1/k). ``lag`` is the number of interleaved
    sequences of the same ratio (1 for the hops of one sphere; 2 for the impacts of ball and
    stem, which alternate). Their intervals then continue as Δ_{k+j} = q Δ_{k+j−lag}, q the mean
    ratio, and the remaining ones sum to

        Σ = Σ_{j≥1} Δ_{k+j} = q (Δ_{k−lag+1} + … + Δ_k)/(1 − q),

    the time from the last event to the accumulation point (e.g. a ball bouncing with
    restitution e from speed v0: Δ_k = 2 v0 e^k/g, q = e, Σ = Δ_k e/(1 − e); the sequence's limit
    t_0 + 2 v0/(g (1 − e))).
    """
    n = ratios
    d = np.asarray(intervals, dtype=float)
    if d.size < n + lag:
        return None
    d = d[-(n + lag) :]
    if not np.all(d > 0.0):
        return None
    q = d[lag:] / d[:-lag]
    if not (np.all(q > 0.0) and np.all(q < 1.0)):
        return None
    r = float(np.mean(q))
    if about_mean:
        if np.any(np.abs(q - r) > spread * r):
            return None
    elif np.any(np.abs(np.diff(q)) > spread * q[1:]):
        return None
    return r, float(r * np.sum(d[-lag:]) / (1.0 - r))


def _needs_pull(phase: Phase, t: float, y: np.ndarray, params: tuple) -> bool:
    """True if ``y`` at the start of ``phase`` needs a pulling normal force: its "contact_lost"
    event function (g_n/(m g)) is ≤ 0 there. After an impact the new contact's force jumps, and a
    zero that is already behind the phase's start is no event: without this check the phase
    would run on with g_n < 0 (a contact that pulls the top down, energy rising)."""
    ev = next((ev for ev in phase.events if ev.action == "contact_lost"), None)
    return ev is not None and not float(ev.fn(t, y, params)) > 0.0


def solve_hybrid(
    run: Run,
    solve: Callable[..., Piece],
    table: dict[str, Phase],
    events: UserEvents | None,
) -> Trajectory:
    """Run a hybrid model phase by phase: each phase until one of its events; a "switch" event
    starts the phase it names at the located time (with the event's ``jump`` applied), any other
    end (t_end, contact lost, a failure, a terminal user event) ends the run. ``solve(run,
    events=...)`` is the backend's, with the run's other arguments bound.

    The samples of a phase end just before the switch time; the next phase's first sample is the
    state after the switch. ``Trajectory.phase`` holds the phase of each sample and
    ``Trajectory.switches`` the (time, from, to) of each switch. User events count their zeros
    over the whole run (``terminal`` = n stops at the n-th zero, whichever phase it falls in):
    ``events`` carries their state from phase to phase.
    """
    mdl, params = run.mdl, run.params
    t_parts, y_parts, phases, sols = [], [], [], []
    seg_phases: list[str] = []
    switches: list[tuple[float, str, str]] = []
    jumps: list[tuple[np.ndarray, np.ndarray]] = []
    nfev = 0
    jump_failed: str | None = None
    lost_at: float | None = None
    while True:
        seg = solve(run, events=events)
        nfev += seg.kw.get("nfev", 0)
        sols.append(seg.sol)
        seg_phases.append(run.phase.name)
        switch = run.switch
        last = switch is None or len(switches) >= MAX_SWITCHES
        if switch is not None and not last:
            index, t_sw = switch
            ev = run.phase.events[index]
            y_ev = np.asarray(seg.sol(t_sw), dtype=float)
            y_sw, target = y_ev, ev.target
            if ev.jump is not None:
                try:
                    seen = [*switches, (t_sw, run.phase.name, ev.target)]
                    args = (seen,) if ev.history else ()
                    y_sw = np.asarray(ev.jump(y_ev, params, *args), dtype=float)
                except JumpFailed as exc:  # the run ends at the switch, state before it kept
                    jump_failed, last = f"{exc} (t = {t_sw:.9g} s)", True
            if ev.select is not None and not last:
                target = ev.select(y_sw, params)
                if target not in table:
                    jump_failed = f"switch to unknown phase {target!r} (t = {t_sw:.9g} s)"
                    last = True
            if not last and _needs_pull(table[target], t_sw, y_sw, params):
                lost_at = t_sw  # the new contact lifts off at once: the run ends after the switch
        t_seg, y_seg = np.asarray(seg.t, dtype=float), np.asarray(seg.Y, dtype=float)
        if not last:
            t_seg, y_seg = t_seg[:-1], y_seg[:, :-1]  # the state at the switch starts the next
        t_parts.append(t_seg)
        y_parts.append(y_seg.reshape(run.y0.size, -1))
        phases.extend([run.phase.name] * t_seg.size)
        if last:
            break
        switches.append((t_sw, run.phase.name, target))
        jumps.append((y_ev, y_sw))
        if lost_at is not None:  # one sample, the state after the switch, in the new phase
            t_parts.append(np.array([t_sw]))
            y_parts.append(np.asarray(y_sw, dtype=float).reshape(-1, 1))
            phases.append(target)
            sols.append(ConstantSolution(t_sw, np.asarray(y_sw, dtype=float)))
            seg_phases.append(target)
            break
        tolerances = run.tolerances
        run = Run(mdl, run.top, params, y_sw, run.backend, table[target], t0=t_sw,
                   state=run.state, options=run.options)  # fmt: skip
        run.tolerances = tolerances
    kw = dict(seg.kw)
    kw["nfev"] = nfev
    status, message = seg.status, seg.message
    if lost_at is not None:
        status, message = event_end("contact_lost", "", lost_at)
        kw["t_contact_lost"] = lost_at
    elif jump_failed is not None:
        status, message = "failed", jump_failed
    elif run.switch is not None:  # stopped for switching too often
        status, message = "failed", f"more than {MAX_SWITCHES} phase switches"
    t_all = np.concatenate(t_parts)
    Y_all = np.hstack(y_parts)
    run.collect = False
    kw.update(extras={"phase": np.array(phases)}, records={"switches": switches, "jumps": jumps})
    return run.result(t_all, Y_all, SegmentedSolution(sols, seg_phases), status, message, **kw)
