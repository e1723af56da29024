"""``simulate``: integrate a model of the tippe top from a :class:`~mett.State` (reference path).

This is the scipy ``solve_ivp`` path (DOP853 by default, with dense output and event location). The
right-hand sides are pure functions of ``(t, y, params)`` on flat float arrays, so a compiled fast
path can later replace the integrator without changing this API.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from types import MappingProxyType
from typing import Any

import numpy as np
from numpy.typing import ArrayLike
from scipy.integrate import solve_ivp

from .. import _validate
from ..state import State
from ..top import TippeTop
from . import euler, gliding, reduced, rolling
from ._model import Model
from .trajectory import Trajectory, _Constant

__all__ = ["MODELS", "simulate"]

MODELS: Mapping[str, Model] = MappingProxyType(
    {m.name: m for m in (gliding.MODEL, rolling.MODEL, reduced.HST, reduced.CYLINDER, euler.MODEL)}
)
"""The models :func:`simulate` knows, by name (read-only)."""

_METHODS = ("DOP853", "RK45", "RK23", "Radau", "BDF", "LSODA")


def _check_state(state: Any) -> State:
    if not isinstance(state, State):
        # State validates finiteness and θ ∈ [0, π] with messages that name the field
        state = State.from_array(state)
    if state.shape != ():
        raise ValueError(f"simulate needs a single State; got fields of shape {state.shape}")
    return state


def _check_rtol(rtol: Any) -> float:
    rtol = _validate.finite_scalar("rtol", rtol)
    if not 0.0 < rtol < 1.0:
        raise ValueError(f"rtol must lie in (0, 1); got {rtol!r}")
    return rtol


def _check_atol(atol: Any, n: int) -> np.ndarray | None:
    if atol is None:
        return None
    arr = _validate.as_finite_array("atol", atol)
    if arr.ndim > 1 or (arr.ndim == 1 and arr.size != n):
        raise ValueError(
            f"atol must be a scalar or have one entry per model state component ({n}); "
            f"got shape {arr.shape}"
        )
    if np.any(arr <= 0.0):
        raise ValueError(f"atol must lie in (0, inf); got {arr.ravel()[arr.ravel() <= 0][0]!r}")
    return arr


def _check_t_eval(t_eval: Any, t_end: float) -> np.ndarray | None:
    if t_eval is None:
        return None
    te = _validate.as_finite_array("t_eval", t_eval)
    if te.ndim != 1 or te.size == 0:
        raise ValueError(f"t_eval must be a non-empty 1-D array; got shape {te.shape}")
    if te[0] < 0.0 or te[-1] > t_end:
        raise ValueError(
            f"t_eval must lie in [0, t_end] = [0, {t_end!r}]; got [{te[0]!r}, {te[-1]!r}]"
        )
    if np.any(np.diff(te) <= 0.0):
        raise ValueError("t_eval must be strictly increasing")
    return te


def _user_event(ev: Callable, model: Model, params: tuple) -> Callable:
    def wrapped(t: float, y: np.ndarray) -> float:
        s = model.derive(np.asarray(y, dtype=float).reshape(-1, 1), params)
        state = State(
            theta=float(np.clip(s["theta"][0], 0.0, math.pi)),
            thetadot=float(s["thetadot"][0]),
            phidot=float(s["phidot"][0]),
            omega3=float(s["omega3"][0]),
            nu_x=float(s["nu_x"][0]),
            nu_y=float(s["nu_y"][0]),
        )
        return float(ev(t, state))

    wrapped.terminal = getattr(ev, "terminal", False)  # type: ignore[attr-defined]
    wrapped.direction = getattr(ev, "direction", 0.0)  # type: ignore[attr-defined]
    return wrapped


def simulate(
    top: TippeTop,
    state: State | ArrayLike,
    t_end: float,
    *,
    model: str = "gliding",
    rtol: float = 1e-10,
    atol: float | ArrayLike | None = None,
    t_eval: ArrayLike | None = None,
    events: Sequence[Callable[[float, State], float]] | None = None,
    method: str = "DOP853",
    max_step: float = math.inf,
    l: float | None = None,
) -> Trajectory:
    """Integrate the motion of a tippe top from ``state`` over ``[0, t_end]``.

    Parameters
    ----------
    top : TippeTop
        Body and friction parameters.
    state : State or array_like
        Initial state (θ, θ̇, φ̇, ω3, ν_x, ν_y); the default ν = 0 of :class:`~mett.State` is the
        thesis start (contact point at rest). The CM starts over the origin with φ(0) = 0.
    t_end : float
        End time (s), > 0.
    model : str, default "gliding"
        One of :data:`MODELS`:

        * ``"gliding"``: the rolling-and-gliding eccentric sphere, F = g_n ẑ − μ g_n v_A, in vector
          form (theory.md §2.1); regular at θ = 0 and π.
        * ``"rolling"``: the rolling ball, v_A ≡ 0 (E, D, λ conserved); needs ν = 0.
        * ``"gliding-hst"``: the gliding heavy symmetric top, the limit R → 0 with Rα = l
          (theory.md §10); ``l = top.R * top.alpha`` unless ``l`` is given.
        * ``"cylinder"``: the gliding eccentric cylinder, the invariant subspace φ̇ = ω3 = ν_y = 0
          (theory.md §10); needs such a state.
        * ``"gliding-euler"``: the gliding top in Euler angles (thesis eqs (10)–(15)), a cross-check
          of "gliding"; stops with status "failed" near sin θ = 0 where it is singular.
    rtol : float, default 1e-10
        Relative tolerance, in (0, 1). The default is converged for the thesis run: the first time
        θ reaches π/2 moves by less than 1e-4 s when rtol is tightened tenfold (see the tests).
    atol : float or array_like, optional
        Absolute tolerance (scalar or one per model state component). By default
        ``rtol * scale`` with a typical magnitude per component (R for lengths, R|ω| for velocities,
        I|ω| for angular momenta, 1 for the axis and angles).
    t_eval : array_like, optional
        Sample times, increasing, in [0, t_end]. By default the solver's own steps are returned.
        Dense output (:meth:`Trajectory.at`) is available either way.
    events : sequence of callables, optional
        ``event(t, state) -> float`` with a scalar :class:`~mett.State`; optional attributes
        ``terminal`` and ``direction`` as in :func:`scipy.integrate.solve_ivp`. Their times are
        in ``Trajectory.t_events``. A terminal user event ends the run with status "completed".
    method : str, default "DOP853"
        Integrator of :func:`scipy.integrate.solve_ivp`.
    max_step : float, default inf
        Largest step (s).
    l : float, optional
        Tip distance of the ``"gliding-hst"`` model (m), > 0; not allowed for other models.

    Returns
    -------
    Trajectory
        ``status`` is ``"completed"``, ``"contact_lost"`` (the normal force reached 0; the run ends
        there and ``t_contact_lost`` holds the time) or ``"failed"`` (the integrator could not
        continue; ``message`` gives the reason). Numerical trouble never raises.

    Raises
    ------
    ValueError
        Bad input: non-finite state or θ outside [0, π], ``t_end <= 0``, ``rtol`` outside (0, 1),
        bad ``atol``/``t_eval``, an unknown model or method, or a state the model cannot represent.
    TypeError
        If ``top`` is not a :class:`~mett.TippeTop`.

    Examples
    --------
    The thesis run (Rutstam 2013, §4/§8):

    >>> import math, mett
    >>> top = mett.presets.get("rutstam2013")
    >>> traj = mett.simulate(top, mett.State(theta=0.1, omega3=155.0), t_end=9.0)
    >>> traj.status, round(float(traj.crossings(math.pi / 2)[0]), 4), round(float(traj.omega3[-1]), 3)
    ('completed', 5.8797, -82.866)
    """
    if not isinstance(model, str) or model not in MODELS:
        raise ValueError(f"unknown model {model!r}; known models: {', '.join(MODELS)}")
    if not isinstance(top, TippeTop):
        raise TypeError(f"top must be a mett.TippeTop; got {type(top).__name__}")
    state = _check_state(state)
    t_end = _validate.positive_scalar("t_end", t_end)
    rtol = _check_rtol(rtol)
    t_eval_arr = _check_t_eval(t_eval, t_end)
    if method not in _METHODS:
        raise ValueError(f"unknown method {method!r}; known methods: {', '.join(_METHODS)}")
    max_step = float(max_step)
    if not max_step > 0.0:
        raise ValueError(f"max_step must lie in (0, inf]; got {max_step!r}")
    options: dict[str, Any] = {}
    if l is not None:
        if model != "gliding-hst":
            raise ValueError(
                f"l (the tip distance) applies only to model 'gliding-hst'; got model {model!r}"
            )
        options["l"] = _validate.positive_scalar("l", l)
    events = list(events or [])
    for ev in events:
        if not callable(ev):
            raise ValueError(f"events must be callables event(t, state) -> float; got {ev!r}")

    mdl = MODELS[model]
    params = mdl.params(top, options)
    y0 = np.asarray(mdl.initial(state, params), dtype=float)
    atol_arr = _check_atol(atol, y0.size)
    if atol_arr is None:
        atol_arr = rtol * np.asarray(mdl.scales(y0, params), dtype=float)

    def result(t, Y, sol, status, message, **kw) -> Trajectory:
        return Trajectory(
            t=t,
            states=Y,
            model=mdl,
            top=top,
            params=params,
            solution=sol,
            status=status,
            message=message,
            **kw,
        )

    gn0 = float(mdl.normal_force(y0, params))
    if not math.isfinite(gn0):
        return result([0.0], y0, _Constant(0.0, y0), "failed", f"normal force at t = 0 is {gn0!r}")
    if gn0 <= 0.0:
        return result(
            [0.0],
            y0,
            _Constant(0.0, y0),
            "contact_lost",
            f"contact lost at t = 0: the initial normal force g_n = {gn0:.6g} N is not positive",
            t_contact_lost=0.0,
        )

    rhs, nan = mdl.rhs, np.full(y0.size, np.nan)

    def fun(t: float, y: np.ndarray) -> np.ndarray:
        # a ZeroDivisionError/OverflowError of plain float math becomes NaN: the step is rejected
        # and solve_ivp ends with status -1 ("failed") instead of raising
        try:
            return rhs(t, y, params)
        except ArithmeticError:
            return nan

    weight = 1.0 / (top.m * top.g)

    def contact(t: float, y: np.ndarray) -> float:
        try:
            return float(mdl.normal_force(y, params)) * weight
        except ArithmeticError:
            return math.nan

    contact.terminal = True  # type: ignore[attr-defined]
    contact.direction = -1.0  # type: ignore[attr-defined]
    all_events: list[Callable] = [contact]
    for fn, direction, _ in mdl.guards:

        def guard(t: float, y: np.ndarray, fn: Callable = fn) -> float:
            return float(fn(t, y, params))

        guard.terminal = True  # type: ignore[attr-defined]
        guard.direction = direction  # type: ignore[attr-defined]
        all_events.append(guard)
    n_internal = len(all_events)
    all_events.extend(_user_event(ev, mdl, params) for ev in events)

    try:
        with np.errstate(all="ignore"):
            res = solve_ivp(
                fun,
                (0.0, t_end),
                y0,
                method=method,
                t_eval=t_eval_arr,
                dense_output=True,
                events=all_events,
                rtol=rtol,
                atol=atol_arr,
                max_step=max_step,
            )
    except (ArithmeticError, ValueError, np.linalg.LinAlgError) as exc:
        return result([0.0], y0, _Constant(0.0, y0), "failed", f"integration failed: {exc}")

    sol = res.sol
    if sol is None or sol.n_segments == 0:
        sol = _Constant(0.0, y0)
    t_stop = float(sol.t_max)
    t_out = np.asarray(res.t, dtype=float)
    Y = np.asarray(res.y, dtype=float).reshape(y0.size, -1)
    if t_out.size == 0 or t_out[-1] < t_stop:
        # with t_eval, end the samples where the run ended (event or failure time)
        keep = t_out < t_stop
        t_out = np.append(t_out[keep], t_stop)
        Y = np.hstack([Y[:, keep], np.asarray(sol(t_stop), dtype=float).reshape(-1, 1)])
    t_events = [np.asarray(te, dtype=float) for te in (res.t_events or [])]
    user_events = t_events[n_internal:]

    kw: dict[str, Any] = {"t_events": user_events, "nfev": res.nfev}
    if not np.all(np.isfinite(Y)):
        # solve_ivp rejects steps with non-finite errors, so this is a last line of defence:
        # keep the finite prefix (the initial state is finite, so it is never empty)
        bad = int(np.argmax(~np.all(np.isfinite(Y), axis=0)))
        t_bad = float(t_out[bad])
        t_out, Y = t_out[: max(bad, 1)], Y[:, : max(bad, 1)]
        return result(t_out, Y, sol, "failed", f"non-finite state at t = {t_bad:.9g} s", **kw)
    if res.status == -1:
        return result(
            t_out, Y, sol, "failed", f"integrator failed at t = {t_stop:.9g} s: {res.message}", **kw
        )
    if res.status == 1:
        # the terminating event is the terminal event with the latest recorded time
        last = [
            (te[-1], i)
            for i, (te, ev) in enumerate(zip(t_events, all_events, strict=True))
            if te.size and getattr(ev, "terminal", False)
        ]
        t_ev, idx = max(last)
        if idx == 0:
            kw["t_contact_lost"] = float(t_ev)
            msg = f"contact lost: the normal force g_n reached 0 at t = {t_ev:.9g} s"
            return result(t_out, Y, sol, "contact_lost", msg, **kw)
        if idx < n_internal:
            msg = f"{mdl.guards[idx - 1][2]} (t = {t_ev:.9g} s)"
            return result(t_out, Y, sol, "failed", msg, **kw)
        msg = f"stopped by terminal event {idx - n_internal} at t = {t_ev:.9g} s"
        return result(t_out, Y, sol, "completed", msg, **kw)
    return result(t_out, Y, sol, "completed", f"reached t_end = {t_end:g} s", **kw)
