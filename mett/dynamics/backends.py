"""The backends of :func:`~mett.simulate`: objects with one protocol, in one registry.

A backend integrates one phase of a prepared run (:class:`~._run.Run`) from ``run.t0`` to
``t_end`` or to the first terminal event (docs/theory/simulation.md#numerics):

* :class:`CompiledBackend` (``"compiled"``): the compiled DOP853 of :mod:`.dop853` with the
  model's compiled right-hand side (:mod:`._kernels`); numba is imported on its first run;
* :class:`ScipyBackend` (``"scipy"``): :func:`scipy.integrate.solve_ivp` with the Python
  right-hand side, any of its methods; the reference of the tests;
* :class:`TaylorBackend` (``"taylor"``): the Taylor-series integrator of :mod:`.taylor`.

Every backend has ``name``, ``accepts(model, method) -> bool`` (with the reason of a refusal
from ``refusal``), ``inexact(model, params, options, n_state)`` (why its result would not be exact for
that run, or None: what ``backend="auto"`` asks, :func:`choose`) and ``solve(run, *, t_end,
rtol, atol, max_step, events, t_eval, method)``,
which returns a :class:`~._run.Piece` whose ``sol`` is a dense output that can ``truncate``
itself. :data:`REGISTRY` maps names to backends; adding one is a class with this protocol and
one :func:`register` line. User events (:class:`UserEvents`) follow the same rules on every
backend: after the run on the dense output of the compiled ones, step by step on scipy.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, Protocol

import numpy as np
from scipy.integrate import OdeSolution, solve_ivp

from .._numba_cache import first_use
from ..state import State
from . import _run
from ._run import Piece, PreparedRun, Run, completed_message, event_end, integrator_failure
from .dense import ConstantSolution
from .registry import Model

__all__ = [
    "AUTO",
    "REGISTRY",
    "Backend",
    "CompiledBackend",
    "ScipyBackend",
    "TaylorBackend",
    "UserEvents",
    "choose",
    "register",
]

_MODEL_TERMINAL = 1
"""solve_ivp's ``terminal`` of every model event on the scipy backend: its first zero ends the run."""


class UserEventError(Exception):
    """Carries an exception raised by a user event out of solve_ivp, to re-raise it unchanged."""

    def __init__(self, exc: BaseException) -> None:
        super().__init__(exc)
        self.exc = exc


def user_event(ev: Callable, model: Model, params: tuple) -> Callable:
    """The user event ``ev(t, State)`` as an event ``f(t, y)`` of the model state."""

    def wrapped(t: float, y: np.ndarray) -> float:
        s = model.derive(np.asarray(y, dtype=float).reshape(-1, 1), params)
        state = State.unchecked(
            float(np.clip(s["theta"][0], 0.0, math.pi)),
            *(float(s[k][0]) for k in ("thetadot", "phidot", "omega3", "nu_x", "nu_y")),
        )
        try:
            return float(ev(t, state))
        except Exception as exc:  # the caller's exception, raised again unchanged by simulate
            raise UserEventError(exc) from exc

    return wrapped


class _StepBudget(Exception):
    """Raised by the recording solver class at its step budget (:data:`._run.MAX_STEPS`)."""


def _recording(method: str, pieces: list[Any], states: list[np.ndarray], max_steps: int) -> type:
    """The solver class of ``method``, recording the interpolant and the state at the end of every
    step in ``pieces`` and ``states`` (solve_ivp asks for the interpolant once per accepted step
    with ``dense_output=True``). After ``max_steps`` recorded steps the next one raises
    :class:`_StepBudget` (solve_ivp has no step limit of its own), so a run on the scipy backend has
    the compiled backend's budget."""
    import scipy.integrate

    base = getattr(scipy.integrate, method)

    class Recording(base):  # type: ignore[misc, valid-type]
        def dense_output(self) -> Any:
            if len(pieces) >= max_steps:
                raise _StepBudget
            out = super().dense_output()
            pieces.append(out)
            states.append(np.array(self.y, dtype=float))
            return out

    Recording.__name__ = Recording.__qualname__ = method
    return Recording


def _solve_scipy(run: Run, *, t_end, rtol, atol_arr, t_eval_arr, max_step, events, method) -> Piece:
    """The reference backend: :func:`scipy.integrate.solve_ivp` with the Python right-hand side.

    Integrates ``run.phase`` from ``run.t0``; returns the :class:`~._run.Piece`.
    """
    params, y0, t0 = run.params, run.y0, run.t0
    run.collect = True
    max_steps = _run.MAX_STEPS  # read at the start of each run (a test may lower it)
    rhs, nan = run.phase.rhs, np.full(y0.size, np.nan)

    def fun(t: float, y: np.ndarray) -> np.ndarray:
        # a ZeroDivisionError/OverflowError of plain float math becomes NaN: the step is rejected
        # and solve_ivp ends with status -1 ("failed") instead of raising
        try:
            return rhs(t, y, params)
        except ArithmeticError:
            return nan

    all_events: list[Callable] = []
    for ev in run.phase.events:

        def model_event(t: float, y: np.ndarray, fn: Callable = ev.fn) -> float:
            try:
                value = float(fn(t, y, params))
            except ArithmeticError:
                return math.nan
            # a zero at the start of a phase is no event, as on the compiled backend (a switch
            # event that vanishes where its phase begins must not switch straight back)
            return math.nan if value == 0.0 and t == t0 else value

        model_event.terminal = _MODEL_TERMINAL  # type: ignore[attr-defined]
        model_event.direction = ev.direction  # type: ignore[attr-defined]
        all_events.append(model_event)
    n_internal = len(all_events)
    if t_eval_arr is not None:
        t_eval_arr = t_eval_arr[t_eval_arr >= t0]

    # the steps' interpolants and end states, to keep the run if the solver raises
    pieces: list[Any] = []
    states: list[np.ndarray] = []
    taken, snap, flip = [-1], [None], [math.inf]
    if events:

        def user_watch(t: float, y: np.ndarray) -> float:
            """The user events, taken step by step (:class:`UserEvents`); solve_ivp calls this
            at the start and at the end of every step, after ``_recording`` kept the step. It
            changes sign at the end of the step in which a terminal one reached its count, so
            that solve_ivp stops there; the zeros themselves are the tracker's."""
            if taken[0] < 0:
                taken[0] = 0
                events.advance([t0], events.values([t0], y0.reshape(-1, 1)), None)
            while taken[0] < len(pieces):
                j = taken[0]
                taken[0] += 1
                snap[0] = events.snapshot()
                t_j = float(pieces[j].t)
                events.advance([t_j], events.values([t_j], states[j].reshape(-1, 1)), pieces[j])
                if events.stop is not None and flip[0] == math.inf:
                    flip[0] = t_j
            return -1.0 if t >= flip[0] else 1.0

        user_watch.terminal = 1  # type: ignore[attr-defined]
        all_events.append(user_watch)
    try:
        with np.errstate(all="ignore"):
            res = solve_ivp(
                fun,
                (t0, t_end),
                y0,
                method=_recording(method, pieces, states, max_steps),
                t_eval=t_eval_arr,
                dense_output=True,
                events=all_events,
                rtol=rtol,
                atol=atol_arr,
                max_step=max_step,
            )
    except UserEventError as err:
        raise err.exc from None  # a user event's exception, unchanged (as solve_ivp lets it go)
    except (ArithmeticError, ValueError, np.linalg.LinAlgError, _StepBudget) as exc:
        # raised inside the solver (e.g. an LU factorisation of a non-finite Jacobian), or the
        # step budget: keep the steps taken so far, as for any other failure
        failed, reason = "integration failed", str(exc)
        if isinstance(exc, _StepBudget):  # worded as on the compiled backend
            failed, reason = "integrator failed", f"maximum number of steps ({max_steps}) reached"
        if not pieces:
            return run.at_start("failed", f"{failed} at t = {t0:.9g} s: {reason}")
        sol = OdeSolution(
            [t0] + [pc.t for pc in pieces], pieces, alt_segment=method in ("BDF", "LSODA")
        )
        if t_eval_arr is None:
            t_out = np.asarray(sol.ts, dtype=float)
            Y = np.column_stack([y0, *states])
        else:
            t_out = np.append(t_eval_arr[t_eval_arr < sol.t_max], sol.t_max)
            Y = np.asarray(sol(t_out), dtype=float).reshape(y0.size, -1)
        msg = f"{failed} at t = {sol.t_max:.9g} s: {reason}"
        kw: dict[str, Any] = {"t_events": events.result(sol.t_max) if events else [], "nfev": 0}
        return run.result(t_out, Y, sol, "failed", msg, **kw)

    sol = res.sol
    if sol is None or sol.n_segments == 0:
        sol = ConstantSolution(t0, y0)
    elif method in ("BDF", "LSODA"):  # solve_ivp sets this only for its own classes
        sol = OdeSolution(sol.ts, sol.interpolants, alt_segment=True)
    t_stop = float(sol.t_max)
    t_out = np.asarray(res.t, dtype=float)
    Y = np.asarray(res.y, dtype=float).reshape(y0.size, -1)
    if t_out.size == 0 or t_out[-1] < t_stop:
        # with t_eval, end the samples where the run ended (event or failure time)
        keep = t_out < t_stop
        t_out = np.append(t_out[keep], t_stop)
        Y = np.hstack([Y[:, keep], np.asarray(sol(t_stop), dtype=float).reshape(-1, 1)])
    t_events = [np.asarray(te, dtype=float) for te in (res.t_events or [])][:n_internal]
    by_model = [
        (te[_MODEL_TERMINAL - 1], i)
        for i, te in enumerate(t_events)
        if res.status == 1 and te.size >= _MODEL_TERMINAL
    ]
    user_stop = None
    if events:
        if by_model and snap[0] is not None and events.t_last > t_stop:
            # a model event ended the run inside the last step: take that step up to it only
            events.restore(snap[0])
            y_stop = np.asarray(sol(t_stop), dtype=float).reshape(-1, 1)
            events.advance([t_stop], events.values([t_stop], y_stop), pieces[taken[0] - 1])
        if events.stop is not None and (events.stop[0] <= t_stop or not by_model):
            # a terminal user event: the run ends there (solve_ivp stopped at the end of its step)
            t_u, user_stop = min(events.stop[0], t_stop), events.stop[1]
            if t_u < t_stop:
                sol = _cut_ode_solution(sol, t_u)
                keep = t_out < t_u
                t_out = np.append(t_out[keep], t_u)
                Y = np.hstack([Y[:, keep], np.asarray(sol(t_u), dtype=float).reshape(-1, 1)])
            t_stop = t_u

    kw = {"t_events": events.result(t_stop) if events else [], "nfev": res.nfev}
    if user_stop is not None:
        msg = f"stopped by terminal event {user_stop} at t = {t_stop:.9g} s"
        return run.result(t_out, Y, sol, "completed", msg, **kw)
    if not np.all(np.isfinite(Y)):
        # solve_ivp rejects steps with non-finite errors, so this is a last line of defence:
        # keep the finite prefix (the initial state is finite, so it is never empty)
        bad = int(np.argmax(~np.all(np.isfinite(Y), axis=0)))
        t_bad = float(t_out[bad])
        t_out, Y = t_out[: max(bad, 1)], Y[:, : max(bad, 1)]
        return run.result(t_out, Y, sol, "failed", f"non-finite state at t = {t_bad:.9g} s", **kw)
    if res.status == -1:
        msg = f"integrator failed at t = {t_stop:.9g} s: {res.message}"
        return run.result(t_out, Y, sol, "failed", msg, **kw)
    if by_model:  # the model event that ended the run (the latest, if several)
        t_ev, idx = max(by_model)
        return run.stopped(t_out, Y, sol, idx, t_ev, **kw)
    return run.result(t_out, Y, sol, "completed", completed_message(t_end), **kw)


def _dop853(rhs, ev_fn, run: Run, params, t_end, rtol, atol_arr, max_step, max_steps) -> Any:
    """The compiled DOP853 of :mod:`.dop853` on ``run.phase`` (the model's compiled kernels)."""
    from . import dop853

    directions = [ev.direction for ev in run.phase.events]
    return dop853.solve(
        rhs,
        (run.t0, t_end),
        run.y0,
        params,
        rtol=rtol,
        atol=atol_arr,
        events=ev_fn,
        direction=directions,
        terminal=[True] * len(directions),
        grazing=[ev.grazing for ev in run.phase.events],
        max_step=max_step,
        max_steps=max_steps,
    )


def _solve_compiled(
    run: Run, *, t_end, rtol, atol_arr, t_eval_arr, max_step, events, method
) -> Piece:
    """The default backend: compiled DOP853 (:mod:`.dop853`) with the model's compiled kernel.

    Integrates ``run.phase`` from ``run.t0``; returns the :class:`~._run.Piece`. ``method`` is
    DOP853 (checked by :meth:`CompiledBackend.refusal`).
    """
    # imported here: numba (and the compiled code) only when a compiled run is asked for
    from . import _kernels, dop853

    mdl, params = run.mdl, run.params
    run.collect = True
    max_steps = _run.MAX_STEPS
    with first_use(f"compiled:{mdl.name}", f"the compiled DOP853 of model {mdl.name!r}"):
        rhs, ev_fn = _kernels.compiled(mdl, run.phase.name)
        sol = _dop853(rhs, ev_fn, run, params, t_end, rtol, atol_arr, max_step, max_steps)
    dense = sol.dense
    assert dense is not None  # dop853.solve stores the dense output unless told not to
    t_stop = float(sol.t_steps[-1])
    failure = None
    if sol.status < 0:
        failure = integrator_failure(dop853.STATUS_MESSAGES, sol.status, t_stop)
        if dense.h.size == 0:  # not a single step: nothing to interpolate
            return run.at_start("failed", failure, nfev=sol.nfev)
    stopped_by = None
    if sol.status == dop853.TERMINAL_EVENT:
        stopped_by = (int(sol.event_index[-1]), float(sol.event_t[-1]))
    return _finish(run, dense, t_stop, sol.nfev, stopped_by, failure, t_end, t_eval_arr, events)


def _finish(
    run: Run,
    dense: Any,
    t_stop: float,
    nfev: int,
    stopped_by: tuple[int, float] | None,
    failure: str | None,
    t_end: float,
    t_eval_arr: np.ndarray | None,
    events: UserEvents | None,
) -> Piece:
    """The piece of a compiled (DOP853 or Taylor) run that ended at ``t_stop``: user events
    located on the dense output (a terminal one cuts the run there: ``dense.truncate``), the
    samples (the steps, or ``t_eval``), and the status: stopped by a model event ``stopped_by`` =
    (index, time), failed (``failure``), or completed."""
    kw: dict[str, Any] = {"nfev": nfev, "t_events": []}
    user_stop = None
    if events:
        try:
            events.advance(dense.t, events.values(dense.t, dense.y.T), dense)
        except UserEventError as err:
            raise err.exc from None  # a user event's exception, unchanged (as on scipy)
        if events.stop is not None and events.stop[0] <= t_stop:
            # the run would have stopped here: cut it, and its dense output, at the event
            t_term, user_stop = events.stop
            dense, t_stop = dense.truncate(t_term), t_term
        kw["t_events"] = events.result(t_stop)

    if t_eval_arr is None:
        t_out, Y = dense.t, dense.y.T
    else:
        t_out = t_eval_arr[(t_eval_arr >= run.t0) & (t_eval_arr <= t_stop)]
        if t_out.size == 0 or t_out[-1] < t_stop:
            t_out = np.append(t_out[t_out < t_stop], t_stop)
        Y = dense(t_out).reshape(run.y0.size, -1)

    if user_stop is not None:
        msg = f"stopped by terminal event {user_stop} at t = {t_stop:.9g} s"
        return run.result(t_out, Y, dense, "completed", msg, **kw)
    if stopped_by is not None:
        return run.stopped(t_out, Y, dense, stopped_by[0], stopped_by[1], **kw)
    if failure is not None:
        return run.result(t_out, Y, dense, "failed", failure, **kw)
    return run.result(t_out, Y, dense, "completed", completed_message(t_end), **kw)


def _solve_taylor(
    run: Run, *, t_end, rtol, atol_arr, t_eval_arr, max_step, events, method
) -> Piece:
    """The Taylor-series backend (:mod:`.taylor`): ``run.phase``'s jet at the order of ``rtol``.

    The per-step truncation error of component i is held at ≈ max(atol_i, rtol |y|_g) (the
    step-size norm of Jorba & Zou scaled by σ_i = atol_i/rtol), |y|_g the size of the model's
    vector that holds component i (``Model.vectors``; the component itself if none). Model events are located on the
    Taylor polynomials; user events after the run on the dense output, as for DOP853.
    """
    from . import taylor

    params = run.params
    run.collect = True
    ph = run.phase
    with first_use("taylor", "the Taylor integrator"):  # the numba loop, on its first run
        kernel = taylor.kernel_for(run.mdl, ph, rtol, params, n_state=run.y0.size)
        sol = taylor.solve(
            kernel, (run.t0, t_end), run.y0, params, scales=atol_arr / rtol,
            direction=[ev.direction for ev in ph.events], max_step=max_step,
            max_steps=_run.MAX_STEPS,
        )[0]  # fmt: skip
    dense = sol.dense
    t_stop = float(dense.t[-1])
    nfev = sol.n_steps  # one jet per step (a jet of order p costs about p²/4 right-hand sides)
    failure = None
    if sol.status < 0:
        failure = integrator_failure(taylor.STATUS_MESSAGES, sol.status, t_stop)
        if sol.n_steps == 0:
            return run.at_start("failed", failure, nfev=nfev)
    stopped_by = None
    if sol.status == taylor.TERMINAL_EVENT:
        stopped_by = (sol.event_index, t_stop)
    return _finish(run, dense, t_stop, nfev, stopped_by, failure, t_end, t_eval_arr, events)


class UserEvents:
    """The user events of a run and the state of their zeros, carried across its phases.

    One meaning on every backend (docs/reliability.md#stick-slip-stops-and-user-events). The class of g is its
    sign, −1, 0 or +1; a zero is a change of class, seen at the solver's steps and located on the
    dense output (Brent's method, to 4 ulps). Going from one sign to the other is one zero, where
    g leaves its first sign (for a continuous g, its root). A stretch where g is exactly 0 is a
    class of its own: g reaching it is a zero, and g leaving it is one too, unless it leaves to
    the sign opposite to the one it came from (the stretch was then one crossing, counted where
    it began). So ``max(θ − 1, 0)`` has a zero at every crossing of θ = 1, a bool-valued g one at
    every change of value, and a g identically 0 none. A zero at the start is no event, nor is g
    leaving a zero at the start within 8 ulps of it (a run started on a crossing), nor a change
    of class across the jump of a phase switch (the next change counts). Direction
    +1 keeps the zeros where the class rises, −1 those where it falls. NaN has no class: no zero
    next to it. DOP853 and Taylor runs are processed after the run, scipy's step by step (so that
    a terminal event stops it).
    """

    def __init__(self, events: list[tuple[Callable, int, float]], run: Run) -> None:
        self.events = events
        self.fns = [user_event(ev, run.mdl, run.params) for ev, _, _ in events]
        self.mdl, self.params, self.t0 = run.mdl, run.params, run.t0
        n = len(events)
        self.g: list[float] = [math.nan] * n  # value at the last point (NaN: none yet)
        self.before = [0.0] * n  # the sign g had before its current zero stretch
        self.from_start = [False] * n  # the current zero stretch began at the start
        self.times: list[list[float]] = [[] for _ in range(n)]
        self.t_last: float | None = None
        self.stop: tuple[float, int] | None = None  # (time, index) of the terminal zero

    def __len__(self) -> int:
        return len(self.events)

    def result(self, t_stop: float) -> list[np.ndarray]:
        """The zeros of each event up to ``t_stop`` (``Trajectory.t_events``)."""
        return [np.array([t for t in times if t <= t_stop]) for times in self.times]

    def snapshot(self) -> tuple:
        counts = [len(t) for t in self.times]
        return ([*self.g], [*self.before], [*self.from_start], counts, self.t_last, self.stop)

    def restore(self, snap: tuple) -> None:
        g, before, from_start, counts, self.t_last, self.stop = snap
        self.g, self.before, self.from_start = [*g], [*before], [*from_start]
        self.times = [t[:c] for t, c in zip(self.times, counts, strict=True)]

    def values(self, ts: Any, Y: np.ndarray) -> np.ndarray:
        """g of every event at times ``ts``, states ``Y`` (columns): shape (events, times)."""
        Y = np.asarray(Y, dtype=float)
        series = self.mdl.derive(Y.reshape(Y.shape[0], -1), self.params)
        theta = np.clip(series["theta"], 0.0, math.pi).tolist()
        cols = (series[k].tolist() for k in ("thetadot", "phidot", "omega3", "nu_x", "nu_y"))
        states = [State.unchecked(*s) for s in zip(theta, *cols, strict=True)]
        times = np.atleast_1d(np.asarray(ts, dtype=float)).tolist()
        g = np.empty((len(self.events), len(states)))
        for k, (ev, _, _) in enumerate(self.events):
            for j, (t, st) in enumerate(zip(times, states, strict=True)):
                try:
                    g[k, j] = float(ev(t, st))
                except Exception as exc:  # the caller's, raised again unchanged by simulate
                    raise UserEventError(exc) from exc
        return g

    def advance(self, ts: Any, g: np.ndarray, y_at: Callable[[float], Any]) -> None:
        """Take the points ``ts`` (increasing; the first may repeat the last one taken: the two
        sides of a jump) with their values ``g`` (events × points); a zero between two points
        is located on ``y_at``, the dense output between them."""
        for j, t in enumerate(np.atleast_1d(np.asarray(ts, dtype=float)).tolist()):
            for k in range(len(self.events)):
                self._point(k, self.t_last, t, float(g[k, j]), y_at)
            self.t_last = t

    def _point(self, k: int, t_a: float | None, t_b: float, g_b: float, y_at: Callable) -> None:
        g_a, self.g[k] = self.g[k], g_b
        if math.isnan(g_b):
            return
        if t_a is None or math.isnan(g_a):  # the start, or the first value after a NaN
            if g_b == 0.0:
                self.before[k], self.from_start[k] = 0.0, t_a is None
            return
        c_a, c_b = math.copysign(1.0, g_a) if g_a else 0.0, math.copysign(1.0, g_b) if g_b else 0.0
        if c_a == c_b:
            return
        if t_b <= t_a:  # across the jump of a phase switch: no zero, the new class holds
            if c_b == 0.0:
                self.before[k], self.from_start[k] = c_a, False
            return
        if c_a != 0.0:  # g leaves its sign: a zero where it does
            rise = -c_a
            if c_b == 0.0:
                self.before[k], self.from_start[k] = c_a, False
        elif self.before[k] == -c_b:
            return  # a zero stretch between opposite signs: one crossing, counted at its start
        else:  # g leaves a zero stretch to the side it came from (or the start's)
            rise = c_b
        t_z = self._locate(k, t_a, t_b, g_a, g_b, y_at)
        eps = np.finfo(float).eps
        if c_a == 0.0 and self.from_start[k] and t_z <= self.t0 + 8 * eps * max(1.0, abs(self.t0)):
            return  # g left a zero at the start at once: the run started on a crossing
        _, terminal, direction = self.events[k]
        if direction * rise < 0.0:
            return
        self.times[k].append(t_z)
        if (
            terminal
            and len(self.times[k]) == terminal
            and (self.stop is None or t_z < self.stop[0])
        ):
            self.stop = (t_z, k)

    def _locate(self, k: int, t_a: float, t_b: float, g_a: float, g_b: float, y_at) -> float:
        """Where g leaves the class of g_a in [t_a, t_b] (towards g_b's if g_a = 0)."""
        from scipy.optimize import brentq

        # h > 0 on the class g leaves (g_a ≠ 0) or reaches (g_a = 0: g_b's sign), < 0 off it
        s = math.copysign(1.0, g_a if g_a else g_b)
        fn, neg = self.fns[k], -math.ulp(0.0)

        raw = g_a * g_b < 0.0  # from one sign to the other: a root of g itself, as solve_ivp's

        def h(t: float) -> float:
            # the step values at the ends: the interpolant's end value may differ in the last
            # ulp and must not lose the bracket
            v = s * (g_a if t == t_a else g_b if t == t_b else fn(t, y_at(t)))
            return v if raw or v > 0.0 else neg

        eps = np.finfo(float).eps
        return float(brentq(h, t_a, t_b, xtol=4 * eps, rtol=4 * eps))


def _cut_ode_solution(sol: Any, t_stop: float) -> Any:
    """A scipy dense output (``OdeSolution``) cut at ``t_stop`` (inside its last kept step)."""
    ts = np.asarray(sol.ts, dtype=float)
    k = max(int(np.searchsorted(ts, t_stop, side="left")), 1)
    return OdeSolution(np.append(ts[:k], t_stop), sol.interpolants[:k], sol.side == "right")


class Backend(Protocol):
    """The protocol of a backend (see the module docstring)."""

    name: str

    def accepts(self, model: Model, method: str) -> bool:
        """Whether this backend runs ``model`` with ``method``."""
        ...

    def refusal(self, model: Model, method: str) -> str | None:
        """Why this backend does not run ``model`` with ``method`` (None: it does)."""
        ...

    def inexact(self, model: Model, params: tuple, options: dict, n_state: int) -> str | None:
        """Why this backend, though it runs ``model``, would not integrate it exactly (to the
        tolerance) with these parameters, validated options and ``n_state`` state components;
        None: it would."""
        ...

    def solve(
        self,
        run: Run,
        *,
        t_end: float,
        rtol: float,
        atol: np.ndarray,
        max_step: float,
        events: UserEvents | None,
        t_eval: np.ndarray | None = None,
        method: str = "DOP853",
    ) -> Piece:
        """Integrate ``run.phase`` from ``run.t0``: the piece of the run (samples, dense output
        ``sol`` with ``truncate``, status); a "switch" stop is left in ``run.switch``."""
        ...


def _not_compilable(model: Model) -> str | None:
    """Why ``model`` cannot run compiled (a phase without ``rhs_into``), or None."""
    if all(ph.rhs_into is not None for ph in model.phase_table()):
        return None
    return f"model {model.name!r} has no compiled right-hand side; use backend='scipy'"


class _Adapter:
    """A backend built on one solve function (``_solve``, the module functions above)."""

    name = ""

    def accepts(self, model: Model, method: str) -> bool:
        return self.refusal(model, method) is None

    def refusal(self, model: Model, method: str) -> str | None:  # pragma: no cover - abstract
        raise NotImplementedError

    def inexact(self, model: Model, params: tuple, options: dict, n_state: int) -> str | None:
        """None: a DOP853 (compiled or scipy) run is exact for every model it accepts."""
        return None

    def solve(
        self,
        run: Run,
        *,
        t_end: float,
        rtol: float,
        atol: np.ndarray,
        max_step: float,
        events: UserEvents | None,
        t_eval: np.ndarray | None = None,
        method: str = "DOP853",
    ) -> Piece:
        return self._solve(
            run, t_end=t_end, rtol=rtol, atol_arr=atol, t_eval_arr=t_eval, max_step=max_step,
            events=events, method=method,
        )  # fmt: skip

    @staticmethod
    def _solve(
        run: Run,
        *,
        t_end: float,
        rtol: float,
        atol_arr: np.ndarray,
        t_eval_arr: np.ndarray | None,
        max_step: float,
        events: UserEvents | None,
        method: str,
    ) -> Piece:  # pragma: no cover - abstract
        raise NotImplementedError


class ScipyBackend(_Adapter):
    """:func:`scipy.integrate.solve_ivp` with the Python right-hand side, any of its methods."""

    name = "scipy"
    METHODS = ("DOP853", "RK45", "RK23", "Radau", "BDF", "LSODA")
    """The methods of :func:`scipy.integrate.solve_ivp` it runs."""

    def refusal(self, model: Model, method: str) -> str | None:
        if method not in self.METHODS:
            return f"unknown method {method!r}; known methods: {', '.join(self.METHODS)}"
        return None

    _solve = staticmethod(_solve_scipy)


class CompiledBackend(_Adapter):
    """mett's compiled DOP853 with the model's compiled right-hand side (DOP853 only)."""

    name = "compiled"

    def refusal(self, model: Model, method: str) -> str | None:
        if method != "DOP853":
            return (
                f"the compiled backend implements method 'DOP853' only; got method {method!r} "
                "(use backend='scipy' for the other methods of scipy.integrate.solve_ivp)"
            )
        return _not_compilable(model)

    _solve = staticmethod(_solve_compiled)


class TaylorBackend(_Adapter):
    """The adaptive Taylor-series integrator of :mod:`.taylor` (its own order, from rtol)."""

    name = "taylor"

    def refusal(self, model: Model, method: str) -> str | None:
        if method != "DOP853":
            return (
                f"method {method!r} is for the DOP853 and scipy backends; the taylor backend "
                "chooses its own order from rtol"
            )
        return _not_compilable(model)

    _solve = staticmethod(_solve_taylor)

    def inexact(self, model: Model, params: tuple, options: dict, n_state: int) -> str | None:
        """Why the Taylor polynomials would not represent this run, from what the model and its
        friction law declare (never from their names):

        * a friction law that does not declare ``analytic = True`` (:mod:`mett.friction`): e.g.
          Coulomb's slip direction v_A/|v_A|, not analytic at v_A = 0 where its phases switch;
        * a ``grazing`` event (:class:`~.registry.Event`): a zero that can come and go within one
          step, which only the compiled DOP853 looks for inside a step;
        * a phase whose right-hand side or events cannot be traced (a branch on the state, an
          operation the tracer does not know: :func:`mett.dynamics.taylor.trace`).
        """
        why = self.static_inexact(model, options)
        if why is not None:
            return why
        for ph in model.phase_table():
            why = _untraceable(model, ph, params, n_state)
            if why is not None:
                return why
        return None

    @staticmethod
    def static_inexact(model: Model, options: dict) -> str | None:
        """The part of :meth:`inexact` that does not depend on the parameters (the law, the
        grazing events)."""
        law = options.get("friction")
        if law is not None and getattr(law, "analytic", False) is not True:
            return f"the friction law {type(law).__name__} is not analytic in the state"
        for ph in model.phase_table():
            if any(ev.grazing for ev in ph.events):
                return f"phase {ph.name!r} of model {model.name!r} has a grazing event"
        return None

    # --- many runs at once (mett.dynamics.batch) ---

    @staticmethod
    def batchable(prep: PreparedRun) -> bool:
        """Whether ``prep`` can run in a SIMD batch (:meth:`propagate`): a Taylor run of a
        single-phase model that declares ``cos_theta``, without user events."""
        mdl = prep.model
        return (
            prep.backend == "taylor"
            and not mdl.hybrid
            and not prep.user
            and mdl.cos_theta is not None
            and prep.phase.rhs_into is not None
        )

    @staticmethod
    def batch_kernel(prep: PreparedRun, lanes: int) -> Any:
        """The kernel of a batchable run for ``lanes`` runs at once: the phase's events, then
        cos θ as a recording event (its first zero is the first crossing of θ = π/2)."""
        from . import taylor

        mdl = prep.model
        if mdl.cos_theta is None:
            raise ValueError(f"model {mdl.name!r} declares no cos_theta: not batchable")
        return taylor.kernel_for(
            mdl, prep.phase, prep.rtol, prep.params, lanes, n_state=prep.y0.size,
            record=[mdl.cos_theta],
        )  # fmt: skip

    @staticmethod
    def propagate(
        kernel: Any, preps: list[PreparedRun], t_end: float, max_step: float, t_eval: np.ndarray
    ) -> tuple[list[str], list[str], np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Runs ``preps`` (of one :meth:`batch_kernel`) from t = 0 to ``t_end``, ``kernel.lanes``
        at a time, keeping only their ends, as columns (a row per run): (statuses, messages,
        t_stop (m,), y_stop (m, n), the states at ``t_eval`` (m, len(t_eval), n; NaN after the
        run stopped), the first zero of cos θ (m,; NaN: none))."""
        from . import taylor

        events = preps[0].phase.events
        with first_use("taylor-batch", "the batched Taylor integrator"):
            res = taylor.propagate(
                kernel, (0.0, t_end), np.array([p.y0 for p in preps]),
                np.array([p.params for p in preps], dtype=float),
                t_eval=t_eval, terminal=[True] * len(events) + [False],
                scales=np.array([p.scales for p in preps]),
                direction=[ev.direction for ev in events] + [0.0], max_step=max_step,
                max_steps=_run.MAX_STEPS,
            )  # fmt: skip
        done = completed_message(t_end)
        statuses, messages = [], []
        for code, t_stop, index in zip(
            res.status.tolist(), res.t.tolist(), res.event_index.tolist(), strict=True
        ):
            if code == taylor.COMPLETED:
                status, message = "completed", done
            elif code == taylor.TERMINAL_EVENT:
                ev = events[index]
                status, message = event_end(ev.action, ev.message, t_stop)
            else:
                status, message = "failed", integrator_failure(taylor.STATUS_MESSAGES, code, t_stop)
            statuses.append(status)
            messages.append(message)
        return statuses, messages, res.t, res.y, res.samples, res.first[:, -1]


REGISTRY: dict[str, Backend] = {}
"""The backends by name, in the order :func:`~mett.simulate` lists them."""


def register(backend: Backend) -> Backend:
    """Add ``backend`` to :data:`REGISTRY` under its ``name`` (a name is registered once)."""
    if backend.name in REGISTRY or backend.name == "auto":
        raise ValueError(f"a backend named {backend.name!r} is already registered")
    REGISTRY[backend.name] = backend
    return backend


register(CompiledBackend())
register(ScipyBackend())
register(TaylorBackend())

AUTO = ("taylor", "compiled", "scipy")
"""``backend="auto"``: the backends, fastest first (the Taylor backend takes 2-3x fewer
nanoseconds per run than the compiled DOP853 at rtol 1e-10, which is 30-50x faster than scipy);
:func:`choose` takes the first that accepts the run and is exact for it."""


def choose(
    model: Model, method: str, params: tuple, options: dict, n_state: int,
    user_events: bool = False,
) -> str:  # fmt: skip
    """The backend of ``backend="auto"``: the first of :data:`AUTO` that accepts ``model`` with
    ``method`` and is exact for it (``inexact`` is None): Taylor for an analytic run with
    ``method="DOP853"``, the compiled DOP853 where the Taylor polynomials cannot represent the law
    (:meth:`TaylorBackend.inexact`), scipy for the other methods of solve_ivp.

    A run with ``user_events`` does not go to Taylor: a user's event is any function, whose zeros
    may come in pairs within one of Taylor's long steps (it looks for sign changes at a few points
    per step), e.g. θ̇ = 0 of a top next to its pole; the DOP853's short steps find them."""
    law = options.get("friction")
    # the verdicts that do not depend on the parameters, once per model, method and kind of law
    # (what TaylorBackend.static_inexact reads of it): a sweep asks for every point
    kind = None if law is None else (type(law), getattr(law, "analytic", False) is True)
    key = (id(model), method, kind, user_events, n_state)
    memo = _CHOICES.get(key)
    if memo is None or memo[0] is not model:
        first, fallback = _static_choice(model, method, options, n_state, user_events)
        phases = [(ph, _traced_of(ph)) for ph in model.phase_table()]
        memo = (model, first, fallback, phases)
        if len(_CHOICES) >= 256:  # bounded: a long-lived process runs many models and laws
            _CHOICES.clear()
        _CHOICES[key] = memo
    _, first, fallback, phases = memo
    if first != "taylor":
        return first
    for ph, seen in phases:  # the tracer's verdict for these parameters, as in inexact
        known = seen and not isinstance(seen[0], str) and any(tr.admits(params) for tr in seen)
        if not known and _untraceable(model, ph, params, n_state) is not None:
            return fallback
    return first


_CHOICES: dict[tuple, tuple[Any, str, str, list]] = {}
""":func:`choose`'s verdicts per (model by identity, method, the law's type and whether it is
analytic, user events, n_state), with the model held (so that its id stays its own): the first
backend of :data:`AUTO` that accepts the run and is exact for it whatever its parameters (the
Taylor backend's tracer may still refuse them: checked per call), the backend after it, and the
model's phases with their lists of traced graphs (:data:`_TRACED`)."""


def _static_choice(
    model: Model, method: str, options: dict, n_state: int, user_events: bool
) -> tuple[str, str]:
    """(the first of :data:`AUTO` that accepts ``model`` and is exact for it, the Taylor
    backend's tracing left to each call; the first after it that is exact)."""
    names = []
    for name in AUTO:
        if user_events and name == "taylor":
            continue
        b = REGISTRY[name]
        if not b.accepts(model, method):
            continue
        if name == "taylor":  # exact unless the law or an event is not (or the tracer refuses)
            if TaylorBackend.static_inexact(model, options) is None:
                names.append(name)
        elif b.inexact(model, (), options, n_state) is None:  # the DOP853s: exact for any p
            names.append(name)
    names.append("scipy")  # accepts every model with every method of solve_ivp
    first = names[0]
    fallback = next((n for n in names[1:] if n != "taylor"), "scipy")
    return first, fallback


_TRACED: dict[tuple, list[Any]] = {}
"""Per (rhs_into, event functions): the graphs traced so far (``admits`` says for which
parameters), or the reason tracing failed (the same for all parameters)."""


def _traced_of(phase: Any) -> list[Any]:
    """The list of :data:`_TRACED` for ``phase`` (made empty if none)."""
    return _TRACED.setdefault((phase.rhs_into, tuple(ev.fn for ev in phase.events)), [])


def _untraceable(model: Model, phase: Any, params: tuple, n_state: int) -> str | None:
    """Why the Taylor tracer cannot represent ``phase`` of ``model`` with ``params``, or None."""
    from . import taylor

    if phase.rhs_into is None:
        return f"phase {phase.name!r} of model {model.name!r} has no rhs_into"
    seen = _traced_of(phase)
    if seen and isinstance(seen[0], str):
        return seen[0]
    if any(tr.admits(params) for tr in seen):
        return None
    try:
        tr = taylor.trace(phase.rhs_into, [ev.fn for ev in phase.events], n_state, len(params),
                          params, model.conserved_lengths)  # fmt: skip
    except Exception as exc:  # the model's own code run on stand-ins: any failure is a "no"
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        why = f"phase {phase.name!r} of model {model.name!r} cannot be traced: {first}"
        seen[:] = [why]
        return why
    seen.append(tr)
    return None
