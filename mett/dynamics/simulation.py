"""``simulate``: integrate a model of the tippe top from a :class:`~mett.State`.

This module checks the arguments and orchestrates a run: :func:`prepare_run` validates it and
chooses the model and the backend, :func:`run_prepared` hands it to the backend
(:mod:`.backends`), or phase by phase to the hybrid driver (:mod:`.hybrid`); the run record is
:mod:`._run`. The backends run the same models (docs/theory/simulation.md#numerics):

* ``backend="auto"`` (default): the fastest backend that is exact for the run
  (:func:`.backends.choose`): Taylor for an analytic run, the compiled DOP853 where the Taylor
  polynomials cannot represent the law (Coulomb's slip direction at a switch, a grazing event),
  scipy for the other methods of solve_ivp.
* ``backend="compiled"``: the compiled DOP853 of :mod:`.dop853` with the model's compiled
  right-hand side (:mod:`._kernels`, compiled from the same source as ``Model.rhs``). The contact
  event g_n = 0 and the model's guards are located inside the compiled loop. User ``events``
  (Python callables of a :class:`~mett.State`) cannot run there: they are evaluated after the run
  on the solver's steps and dense output (a change of class over a step, located by Brent's
  method on the interpolant, :class:`.backends.UserEvents`), and a terminal user event truncates the
  trajectory there.
  numba is imported on the first compiled run, not by ``import mett``.
* ``backend="scipy"``: :func:`scipy.integrate.solve_ivp` with the pure-Python right-hand side, any of
  its methods; the reference path of the tests.
* ``backend="taylor"``: the adaptive Taylor-series integrator of :mod:`.taylor`, whose recurrences
  are generated from the same ``rhs_into`` source and compiled with LLVM; its dense output is the
  Taylor polynomial of each step, and events are located on those polynomials.

The compiled DOP853 takes the same steps as scipy's (same tableau, error norm and controller), so
both backends agree to rounding: the thesis run's first θ = π/2 time to ~1e-12 s (tests/
test_dynamics_compiled.py).
"""

from __future__ import annotations

import functools
import inspect
import math
from collections.abc import Callable, Sequence
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from .. import _validate
from .. import friction as _friction
from ..state import State
from ..stem import StemmedTop
from ..top import TippeTop
from . import _params, _run, backends, flight
from ._run import PreparedRun, Run
from .gliding import viscous_force
from .hybrid import MAX_SWITCHES, solve_hybrid
from .registry import MODELS, Model, boolean, check_friction, lookup, validate_options
from .trajectory import Trajectory

__all__ = [
    "BACKENDS",
    "MAX_STEPS",
    "MAX_SWITCHES",
    "MODELS",
    "RATE_MAX",
    "SIMULATE_DEFAULTS",
    "RunPlan",
    "check_run",
    "plan_runs",
    "prepare_planned",
    "simulate",
]

_METHODS = backends.ScipyBackend.METHODS
MAX_STEPS = _run.MAX_STEPS
"""Every backend stops with status "failed" after this many accepted steps (per phase of a hybrid
run), the steps taken kept (:data:`mett.dynamics._run.MAX_STEPS`, where the memory it costs is
measured)."""
BACKENDS = ("auto", *backends.REGISTRY)
"""The values of ``simulate(..., backend=...)``."""


def _check_state(state: Any) -> State:
    if not isinstance(state, State):
        # State validates finiteness and θ ∈ [0, π] with messages that name the field
        state = State.from_array(state, name="state")
    if state.shape != ():
        raise ValueError(f"simulate needs a single State; got fields of shape {state.shape}")
    return state


RATE_MAX = 1e30
"""Largest |θ̇|, |φ̇|, |ω3| of a start state, in units of the top's natural rate √(g/R), and of
|ν_x|, |ν_y| in units of √(g R). The runs stay clean (a status) up to 1e80 of them for the thesis
top; beyond about 1e100 rad/s the integrator's own arithmetic overflows. No top spins within
many decades of the bound (the thesis run starts at 8 √(g/R))."""


def _check_magnitudes(top: TippeTop, state: State) -> None:
    """ValueError naming the state field whose magnitude is beyond :data:`RATE_MAX`."""
    rate = math.sqrt(top.g / top.R)  # FIELD_RANGE keeps both factors finite and nonzero
    for name, unit, scale in (
        ("thetadot", "rad/s", rate), ("phidot", "rad/s", rate), ("omega3", "rad/s", rate),
        ("nu_x", "m/s", rate * top.R), ("nu_y", "m/s", rate * top.R),
    ):  # fmt: skip
        value = float(getattr(state, name))
        if abs(value) > RATE_MAX * scale:
            what = "sqrt(g/R)" if unit == "rad/s" else "sqrt(g R)"
            raise ValueError(
                f"state.{name} must lie in [-{RATE_MAX * scale:.3g}, {RATE_MAX * scale:.3g}] {unit} "
                f"({RATE_MAX:g} times the top's {what}); got {value!r}"
            )


RTOL_MIN = 100.0 * float(np.finfo(float).eps)
"""Smallest relative tolerance (100 machine epsilons, 2.2e-14): below it the error estimate is
rounding noise and the step size collapses (scipy clamps to the same bound)."""


RTOL_MAX = 1e-2
"""Largest relative tolerance. Above it a run is no accuracy request: the default absolute
tolerances (rtol times each component's typical magnitude) allow errors of a percent of the state
per step, the dry-friction stopping band (10 rtol times the velocity scale) reaches a tenth of the
slip it is to detect, and runs near rtol = 1 ended in overflow, numpy RuntimeWarnings or a raw
RuntimeError of scipy's event location instead of a status."""


def _check_rtol(rtol: Any) -> float:
    rtol = _real_scalar("rtol", rtol)
    if not RTOL_MIN <= rtol <= RTOL_MAX:
        raise ValueError(
            f"rtol must lie in [{RTOL_MIN:.3g}, {RTOL_MAX:g}] (at least 100 machine epsilons, at "
            f"most a percent); got {rtol!r}"
        )
    return rtol


def _real_scalar(name: str, value: Any) -> float:
    """A finite real number; strings and bools are a TypeError (``float("1e-8")`` would pass)."""
    if isinstance(value, (bool, np.bool_, str, bytes)):
        raise TypeError(f"{name} must be a real number; got {value!r}")
    return _validate.finite_scalar(name, value)


def _check_atol(atol: Any, n: int, scales: np.ndarray) -> np.ndarray | None:
    """``atol`` as one float per state component, ≥ the rounding of the component's size.

    The floor is ε × the component's typical magnitude (``Model.scales``): an absolute error
    smaller than one rounding of the values the component is computed from cannot be met; asked
    for anyway, the step size collapses wherever the component passes through zero (atol = 1e-30
    made the thesis run take a million steps in its first microsecond).
    """
    if atol is None:
        return None
    if isinstance(atol, (bool, np.bool_, str, bytes)):
        raise TypeError(f"atol must be a real number or an array of them; got {atol!r}")
    arr = _validate.as_finite_array("atol", atol)
    if arr.ndim > 1 or (arr.ndim == 1 and arr.size != n):
        raise ValueError(
            f"atol must be a scalar or have one entry per model state component ({n}); "
            f"got shape {arr.shape}"
        )
    if np.any(arr <= 0.0):
        raise ValueError(f"atol must lie in (0, inf); got {arr.ravel()[arr.ravel() <= 0][0]!r}")
    full = np.broadcast_to(arr, (n,)).astype(float)
    floor = float(np.finfo(float).eps) * np.abs(scales)
    low = np.flatnonzero(full < floor)
    if low.size:
        i = int(low[0])
        raise ValueError(
            f"atol must be at least machine epsilon times the typical magnitude of each state "
            f"component (below that it cannot be met); component {i} needs atol >= "
            f"{floor[i]:.3g}; got {full[i]!r}"
        )
    return full


def _event_terminal(k: int, ev: Callable) -> int:
    """How many zeros of user event ``k`` end the run (0: none), as solve_ivp's ``terminal``."""
    terminal = getattr(ev, "terminal", False)
    if terminal is None or isinstance(terminal, (bool, np.bool_)):
        return int(bool(terminal))
    if isinstance(terminal, (int, np.integer)):
        if terminal < 0:
            raise ValueError(f"events[{k}].terminal must lie in [0, inf); got {terminal!r}")
        return int(terminal)
    raise TypeError(
        f"events[{k}].terminal must be a bool or an int (stop at that many zeros); got {terminal!r}"
    )


def _event_direction(k: int, ev: Callable) -> float:
    """The sign of user event ``k``'s ``direction`` (0: zeros in both directions)."""
    direction = getattr(ev, "direction", 0.0)
    if isinstance(direction, (bool, np.bool_, str, bytes)):
        raise TypeError(f"events[{k}].direction must be a real number; got {direction!r}")
    return float(np.sign(_validate.finite_scalar(f"events[{k}].direction", direction)))


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


def simulate(
    top: TippeTop | StemmedTop,
    state: State | ArrayLike,
    t_end: float,
    *,
    model: str | Model = "gliding",
    rtol: float = 1e-10,
    atol: float | ArrayLike | None = None,
    t_eval: ArrayLike | None = None,
    events: Sequence[Callable[[float, State], float]] | None = None,
    method: str = "DOP853",
    backend: str = "auto",
    max_step: float = math.inf,
    friction: _friction.FrictionLaw | None = None,
    stop_on_contact_loss: bool = False,
    **options: Any,
) -> Trajectory:
    """Integrate the motion of a tippe top from ``state`` over ``[0, t_end]``.

    Parameters
    ----------
    top : TippeTop or StemmedTop
        Body and friction parameters. A :class:`~mett.stem.StemmedTop` (``top.with_stem(...)``)
        runs the ``"stemmed"`` model: ball and stem contacts with inelastic impacts at each change
        of contact (``docs/theory/stem.md``); its Trajectory also has ``contact`` ("ball",
        "stem" or "both" per sample) and ``touchdowns`` (s). With ``friction=Coulomb(...)`` it runs
        ``"stemmed-coulomb"`` (``"stemmed-coulomb-contensou"``): stick–slip on either contact,
        ``phase`` per sample as for the dry models below (docs/theory/stem.md#dry-friction);
        with ``friction=RegularisedCoulomb(...)`` ``"stemmed-coulomb-regularised"``
        (docs/theory/stem.md#regularised-coulomb-friction).
    state : State or array_like
        Initial state (θ, θ̇, φ̇, ω3, ν_x, ν_y); the default ν = 0 of :class:`~mett.State` is the
        thesis start (contact point at rest). The CM starts over the origin with φ(0) = 0.
    t_end : float
        End time (s), > 0.
    model : str or Model, default "gliding"
        One of :data:`MODELS` (or an unregistered :class:`~mett.dynamics.registry.Model`):

        * ``"gliding"``: the rolling-and-gliding eccentric sphere, F = g_n ẑ − μ g_n v_A, in vector
          form (docs/theory/equations.md#vector-form); regular at θ = 0 and π.
        * ``"rolling"``: the rolling ball, v_A ≡ 0 (E, D, λ conserved); needs ν = 0.
        * ``"gliding-hst"``: the gliding heavy symmetric top, the limit R → 0 with Rα = l
          (docs/theory/reduced.md#reduced-systems); ``l = top.R * top.alpha`` unless ``l`` is given.
        * ``"cylinder"``: the gliding eccentric cylinder, the invariant subspace φ̇ = ω3 = ν_y = 0
          (docs/theory/reduced.md#reduced-systems); needs such a state.
        * ``"gliding-euler"``: the gliding top in Euler angles (thesis eqs (10)–(15)), a cross-check
          of "gliding"; stops with status "failed" near sin θ = 0 where it is singular.
        * ``"frictionless-routhian"``: the corrected Maple-paper Routhian equations (no friction;
          ``vertical_cm=False`` for the printed approximation); equals "gliding" at μ = 0.
        * ``"coulomb"``, ``"coulomb-contensou"``, ``"coulomb-regularised"``: dry friction, chosen
          by ``friction=`` (below).
    rtol : float, default 1e-10
        Relative tolerance, in [100 ε, 1e-2] = [2.2e-14, 0.01] (:data:`RTOL_MIN`,
        :data:`RTOL_MAX`). The default is converged for the thesis run: the first time
        θ reaches π/2 moves by less than 1e-4 s when rtol is tightened tenfold (see the tests).
    atol : float or array_like, optional
        Absolute tolerance (scalar or one per model state component). By default
        ``rtol * scale`` with a typical magnitude per component (R for lengths, R|ω| for velocities,
        I|ω| for angular momenta, 1 for the axis and angles); at least ``eps * scale`` (smaller
        absolute errors are below the rounding of the component and cannot be met).
    t_eval : array_like, optional
        Sample times, increasing, in [0, t_end]. By default the solver's own steps are returned.
        Dense output (:meth:`Trajectory.at`) is available either way.
    events : sequence of callables, optional
        ``event(t, state) -> float`` with a scalar :class:`~mett.State`; optional attributes
        ``terminal`` and ``direction`` as in :func:`scipy.integrate.solve_ivp`: ``terminal`` a bool
        or an int n ≥ 0 (stop at the n-th zero; True = 1), ``direction`` a real number (its sign
        selects the crossings). A zero is a change of sign of the value, with an exact 0 a sign
        of its own: ``max(θ − 1, 0)`` fires where θ crosses 1, a bool-valued event where it
        changes, an event identically 0 never; a stretch of zeros between opposite signs is one
        crossing, where it begins (docs/reliability.md). A zero at t = 0 is not an event. Their
        times are in ``Trajectory.t_events``. A terminal user event ends the run with status
        "completed". Every backend follows the same rules, with the same code: the compiled
        and Taylor backends evaluate the events after the run on their steps and dense output
        and cut the trajectory at the first terminal one; scipy's steps are taken as they come.
    method : str, default "DOP853"
        Integration method: DOP853 on either backend, or another method of
        :func:`scipy.integrate.solve_ivp` ("RK45", "Radau", …) on the scipy backend.
    backend : {"auto", "compiled", "scipy", "taylor"}, default "auto"
        ``"compiled"``: mett's numba DOP853 with the model's compiled right-hand side (the first
        call in a process loads it from numba's cache, about 0.5 s, or compiles it, a few seconds
        once per installation); DOP853 only. ``"scipy"``: :func:`scipy.integrate.solve_ivp` with
        the Python right-hand side, the reference; 30-50× slower. With DOP853 both take the same
        steps and agree to rounding. ``"auto"``: the fastest backend that is exact for the run,
        decided by what the model and its friction law declare (never by their names): Taylor
        when the law is analytic (``analytic = True`` of :mod:`mett.friction`: viscous,
        regularised, rolling resistance, no law) and no event is ``grazing``, which covers the
        viscous gliding and rolling tops, the gliding HST, the cylinder, the Euler and
        Routhian forms and the viscous stemmed top between its impacts; the compiled DOP853 for
        dry Coulomb friction (its slip direction is not analytic where its phases switch) and
        for a right-hand side the Taylor tracer cannot represent or a run with ``events`` (a
        user's event may have two zeros within one long Taylor step); scipy for the methods other
        than DOP853 (:func:`mett.dynamics.backends.choose`). ``Trajectory.backend`` says which
        ran. Every backend
        keeps every step in memory and stops with status "failed" after :data:`MAX_STEPS`
        steps. ``"taylor"``: the adaptive Taylor-series integrator
        (:mod:`mett.dynamics.taylor`; order p = ⌈−½ ln rtol⌉ + 1, the step of Jorba & Zou 2005),
        generated from the same equations and compiled with LLVM (a few seconds per model and
        order, once per installation: the machine code is cached on disk); its dense output is
        each step's Taylor polynomial. DOP853 only in ``method`` (it is not used).
    max_step : float, default inf
        Largest step (s); at least ``t_end / MAX_STEPS`` (a smaller one could not reach ``t_end``
        within the step budget, and is refused on every backend).
    friction : mett.friction law, optional
        The contact's friction law (:mod:`mett.friction`, ``docs/theory/friction.md``). Default:
        :class:`~mett.friction.Viscous` with ``top.mu``, today's runs unchanged
        (``Viscous(mu)`` is the same run with ``top.mu = mu``; given explicitly, the run also
        carries the force ``F_x``, ``F_y``, ``M_n`` as below). Any other law names the registered
        model that runs it (``law.model_for(model)``, :mod:`mett.friction`; e.g.
        :mod:`mett.dynamics.stickslip`): :class:`~mett.friction.Coulomb` the hybrid
        ``"coulomb"`` (exact stick–slip, phases "sliding"/"rolling"; ``"coulomb-contensou"`` with
        a contact radius), :class:`~mett.friction.RegularisedCoulomb` ``"coulomb-regularised"``
        (stiff: ``method="LSODA"`` or ``"Radau"``). They run on either backend, with user events;
        their trajectories carry ``phase`` ("sliding"/"rolling" per sample), the tangential force
        ``F_x``, ``F_y`` (N, lab frame), the torque ``M_n`` about the normal (N m), the cone
        ``margin`` (N) and ``switches`` (:class:`mett.dynamics.stickslip.Switch`). Their option
        ``stopping_band`` (m/s) defaults to 10 rtol × the start's velocity scale.
        :class:`~mett.dynamics.resistance.RollingResistance` runs ``"rolling-resistance"``.
    stop_on_contact_loss : bool, default False
        What happens where the normal force reaches 0. False: a model that flies
        (:func:`mett.dynamics.flight.flies`: ``"gliding"`` and the dry laws it hands over to,
        the stemmed top's models)
        follows the exact free flight, the touchdown and the landing impact, and goes on in
        contact (:func:`mett.dynamics.flight.run_with_flight`, docs/theory/flight.md); its
        Trajectory then has ``contact`` ("ball"/"stem"/"both"/"none"), ``gap``, ``gap_rate`` (m, m/s) and the
        lift-offs and touchdowns in ``switches``; a run that never loses contact is unchanged.
        True, and every other model: the run ends there with status "contact_lost".
    **options
        The options of the model (``Model.options``), validated by the model's validators; None
        means the default. Built in:

        * ``l`` (float, m, > 0): tip distance of ``"gliding-hst"`` (default ``top.R * top.alpha``);
        * ``vertical_cm`` (bool): ``"frictionless-routhian"`` only: keep the vertical kinetic
          energy of the centre of mass (True, the default: the corrected Maple-paper equations,
          equal to ``"gliding"`` at μ = 0) or drop it as the printed Routhian does (False, an
          approximation).

        An option of another model is a ValueError, an unknown keyword a TypeError.

    Returns
    -------
    Trajectory
        ``status`` is ``"completed"``, ``"contact_lost"`` (the normal force reached 0 and the run
        ended there, see ``stop_on_contact_loss``; ``t_contact_lost`` holds the time, also the
        first lift-off of a run that flew) or ``"failed"`` (the integrator could not
        continue; ``message`` gives the reason). Numerical trouble never raises.

    Raises
    ------
    ValueError
        Bad input, before any work: non-finite state or θ outside [0, π], a state rate beyond
        :data:`RATE_MAX` times the top's natural scale, ``t_end <= 0``, ``t_end / max_step``
        above :data:`MAX_STEPS`,
        ``rtol`` outside [100 ε, 1e-2] (:data:`RTOL_MIN`, :data:`RTOL_MAX`), ``atol`` ≤ 0 or below ε times a state
        component's typical magnitude, bad ``t_eval``, an unknown model, method or backend,
        ``backend="compiled"`` with a method other than DOP853, an option of another model or out
        of its range, a required option missing, a friction law the model does not run (e.g.
        ``model="coulomb"`` without ``friction=Coulomb(mu)``: the message names the model and the
        law it needs), an event ``terminal`` < 0, or a state the model cannot represent.
    TypeError
        If ``top`` is not a :class:`~mett.TippeTop`, a tolerance is not a real number, an option
        has the wrong type (``vertical_cm="no"``), an event is not callable or its ``terminal`` is
        not a bool or an int, or a keyword is unknown.
    Exception
        Whatever a user event raises propagates unchanged (as in :func:`scipy.integrate.solve_ivp`);
        failures of the integration itself are a status, never an exception.
    KeyboardInterrupt
        Ctrl-C (SIGINT) during the run, on every backend: the compiled loops stop within 32 steps
        (docs/reliability.md, "Interrupts and step budgets"). The run is discarded.

    Examples
    --------
    The thesis run (Rutstam 2013, §4/§8):

    >>> import math, mett
    >>> top = mett.presets.get("rutstam2013")
    >>> traj = mett.simulate(top, mett.State(theta=0.1, omega3=155.0), t_end=9.0)
    >>> traj.status, round(float(traj.crossings(math.pi / 2)[0]), 4), round(float(traj.omega3[-1]), 3)
    ('completed', 5.8797, -82.866)
    """
    if isinstance(top, StemmedTop):  # the ball and its stem: the "stemmed" model
        from .stem import stemmed_run

        return stemmed_run(simulate, top, state, t_end, model=model, rtol=rtol, atol=atol,
                           t_eval=t_eval, events=events, method=method, backend=backend,
                           max_step=max_step, friction=friction,
                           stop_on_contact_loss=stop_on_contact_loss, **options)  # fmt: skip
    prep = prepare_run(top, state, t_end, model=model, rtol=rtol, atol=atol, t_eval=t_eval,
                    events=events, method=method, backend=backend, max_step=max_step,
                    friction=friction, stop_on_contact_loss=stop_on_contact_loss,
                    **options)  # fmt: skip
    # a run decided before the first step is returned as it is
    if not isinstance(prep, PreparedRun):
        traj = prep
    elif not stop_on_contact_loss and flight.flies(prep.model):  # lift-off, flight, landing
        traj = flight.run_with_flight(prep)
    else:
        traj = run_prepared(prep)
    flight.warn_if_artefact(traj)
    if friction is not None:
        viscous_top, law = friction.applied(top)
        if law is None:  # the top's viscous law, given explicitly: its force series
            traj = traj.with_extras(viscous_force(traj, viscous_top.mu))
    return traj


SIMULATE_DEFAULTS = {
    k: v.default
    for k, v in inspect.signature(simulate).parameters.items()
    if v.kind is inspect.Parameter.KEYWORD_ONLY
}
"""The keyword arguments of :func:`simulate` and their defaults."""


def check_run(top: TippeTop, state: Any, t_end: float, **simulate_kw: Any) -> str:
    """Every check ``simulate(top, state, t_end, **simulate_kw)`` makes before its first step,
    without integrating: bad input raises the ``ValueError``/``TypeError`` simulate would.
    Returns the backend that would run (``"auto"`` resolved)."""
    prep = prepare_run(top, state, t_end, **{**SIMULATE_DEFAULTS, **simulate_kw})
    return prep.run.backend if isinstance(prep, PreparedRun) else prep.backend


def prepare_run(
    top: TippeTop,
    state: Any,
    t_end: float,
    *,
    model: str | Model,
    rtol: float,
    atol: Any,
    t_eval: Any,
    events: Any,
    method: str,
    backend: str,
    max_step: float,
    friction: Any,
    stop_on_contact_loss: bool = True,
    **options: Any,
) -> PreparedRun | Trajectory:
    """Everything :func:`simulate` does before integrating: validation, the model that runs (its
    friction law and variant), the backend, parameters and start; a run decided at t = 0 (contact
    lost, a guard) is returned as its Trajectory; a law is applied first (never run here).
    With ``stop_on_contact_loss=False`` a model that flies (:func:`.flight.flies`) is prepared
    even from a start without contact force (its run begins with a flight)."""  # fmt: skip
    mdl = lookup(model)
    stop_on_contact_loss = boolean("stop_on_contact_loss", stop_on_contact_loss)
    top, state = _check_point(top, state)
    t_end, rtol, t_eval_arr, max_step = _check_times(t_end, rtol, t_eval, max_step, method, backend)
    if friction is not None:  # the law decides the top and the model, before anything runs
        friction = _friction.check_law(friction)
        check_friction(mdl, friction)  # a law the model does not run (None: validate_options)
        top, law = friction.applied(top)  # Viscous(mu): the top with that mu, no law left
        if law is not None:
            runs = law.model_for(mdl.name)  # the model given (also an unregistered one), or
            mdl = mdl if runs == mdl.name else lookup(runs)  # the registered one the law names
            options = {**options, "friction": law}
    plan = _plan(mdl, options, events, method, backend, stop_on_contact_loss, t_end, rtol, atol,
                 t_eval_arr, max_step)  # fmt: skip
    return _prepare_checked(plan, top, state)


class RunPlan(NamedTuple):
    """The options of runs, checked once (:func:`plan_runs`): what :func:`prepare_run` decides
    before it looks at the top and the state."""

    mdl: Model
    model_options: dict
    phases: Sequence[Any]
    user: list
    stop_on_contact_loss: bool
    t_end: float
    rtol: float
    atol: Any
    t_eval_arr: np.ndarray | None
    max_step: float
    method: str
    backend: str


def plan_runs(t_end: float, **simulate_kw: Any) -> RunPlan:
    """Every check of :func:`prepare_run` that does not involve the top or the state, made once
    for many runs with the same options (``simulate_kw``: simulate's keywords, its defaults
    where missing; no ``friction`` law, which is applied to each top). Bad options raise what
    ``prepare_run`` would raise, but in another order when the top or state is bad too: a
    caller that must report an option's error exactly as ``prepare_run`` does calls that on an
    error here. Runs from it: :func:`prepare_planned`."""
    kw = {**SIMULATE_DEFAULTS, **simulate_kw}
    if kw.pop("friction") is not None:
        raise ValueError("plan_runs takes no friction law (prepare_run applies it to the top)")
    model, rtol, atol, t_eval, events = (kw.pop(k) for k in ("model", "rtol", "atol", "t_eval",
                                                              "events"))  # fmt: skip
    method, backend, max_step = kw.pop("method"), kw.pop("backend"), kw.pop("max_step")
    mdl = lookup(model)
    stop = boolean("stop_on_contact_loss", kw.pop("stop_on_contact_loss"))
    t_end, rtol, t_eval_arr, max_step = _check_times(t_end, rtol, t_eval, max_step, method, backend)
    return _plan(mdl, kw, events, method, backend, stop, t_end, rtol, atol, t_eval_arr, max_step)


def _check_point(top: Any, state: Any) -> tuple[TippeTop, State]:
    if not isinstance(top, TippeTop):
        raise TypeError(f"top must be a mett.TippeTop; got {type(top).__name__}")
    state = _check_state(state)
    _check_magnitudes(top, state)
    return top, state


def _check_times(
    t_end: Any, rtol: Any, t_eval: Any, max_step: Any, method: Any, backend: Any
) -> tuple[float, float, np.ndarray | None, float]:
    t_end = _validate.positive_scalar("t_end", t_end)
    rtol = _check_rtol(rtol)
    t_eval_arr = _check_t_eval(t_eval, t_end)
    if isinstance(max_step, (bool, np.bool_, str, bytes)) or max_step is None:
        raise TypeError(f"max_step must be a real number; got {max_step!r}")
    max_step = float(max_step)
    if not max_step > 0.0:
        raise ValueError(f"max_step must lie in (0, inf]; got {max_step!r}")
    max_steps = _run.MAX_STEPS
    if t_end / max_step > max_steps:  # refused up front rather than run into the step budget
        raise ValueError(
            f"max_step must be at least t_end / MAX_STEPS = {t_end / max_steps:.3g} s (the run "
            f"would need more than {max_steps} steps); got {max_step!r}"
        )
    if method not in _METHODS:
        raise ValueError(f"unknown method {method!r}; known methods: {', '.join(_METHODS)}")
    known = ("auto", *backends.REGISTRY)  # BACKENDS, and any backend registered since
    if backend not in known:
        raise ValueError(f"unknown backend {backend!r}; known backends: {', '.join(known)}")
    return t_end, rtol, t_eval_arr, max_step


def _plan(
    mdl: Model, options: dict, events: Any, method: str, backend: str, stop: bool,
    t_end: float, rtol: float, atol: Any, t_eval_arr: np.ndarray | None, max_step: float,
) -> RunPlan:  # fmt: skip
    model_options = validate_options(mdl, options)
    if mdl.variant is not None:  # an option may select another model (e.g. a friction law)
        alt = mdl.variant(model_options)
        if alt is not None and alt is not mdl:
            mdl, model_options = alt, validate_options(alt, options)
    phases = mdl.phase_table()
    if backend != "auto":
        refused = backends.REGISTRY[backend].refusal(mdl, method)
        if refused is not None:
            raise ValueError(refused)
    events = list(events or [])
    for k, ev in enumerate(events):
        if not callable(ev):
            raise TypeError(f"events[{k}] must be a callable event(t, state) -> float; got {ev!r}")
    user = [(ev, _event_terminal(k, ev), _event_direction(k, ev)) for k, ev in enumerate(events)]
    return RunPlan(mdl, model_options, phases, user, stop, t_end, rtol, atol, t_eval_arr,
                   max_step, method, backend)  # fmt: skip


def prepare_planned(
    plan: RunPlan, top: Any, state: Any, starts: dict | None = None
) -> PreparedRun | Trajectory:
    """:func:`prepare_run` of ``top`` and ``state`` with the options of ``plan``
    (:func:`plan_runs`): the top and state checks, then the same run, bit for bit.

    ``starts``: a dict the caller passes to every run it prepares from ``plan`` (empty at
    first). A run of a model whose start does not read μ (``Model.mu_free_start``) takes the
    start and tolerance scales of an earlier run with the same state object and the same
    parameters but μ from there, instead of computing them again (a sweep over friction)."""
    top, state = _check_point(top, state)
    return _prepare_checked(plan, top, state, starts)


def _start_of(mdl: Model, state: State, params: tuple, starts: dict | None) -> tuple:
    """(y0, scales) of a run: the model's ``initial`` and ``scales``, or, if ``mdl`` declares
    ``mu_free_start``, those of an earlier run in ``starts`` that differs in μ alone (a copy:
    each run owns its start)."""
    if starts is None or not mdl.mu_free_start:
        y0 = np.asarray(mdl.initial(state, params), dtype=float)
        return y0, np.asarray(mdl.scales(y0, params), dtype=float)
    # the state by identity (0.0 == -0.0, but a start with −0 is its own), held in the value
    key = (id(state), id(mdl), params[: _params.MU], params[_params.MU + 1 :])
    got = starts.get(key)
    if got is None or got[0] is not state:
        y0 = np.asarray(mdl.initial(state, params), dtype=float)
        got = starts[key] = (state, y0, np.asarray(mdl.scales(y0, params), dtype=float))
    return got[1].copy(), got[2]


def _prepare_checked(
    plan: RunPlan, top: TippeTop, state: State, starts: dict | None = None
) -> PreparedRun | Trajectory:
    # each run its own options dict (a run's options are its own, as with prepare_run)
    mdl, model_options, phases, user = plan.mdl, dict(plan.model_options), plan.phases, plan.user
    rtol, backend = plan.rtol, plan.backend
    if _declares(mdl, "stopping_band") and model_options["stopping_band"] is None:
        from .stickslip import stopping_band  # tied to rtol, as the integration error is

        model_options["stopping_band"] = stopping_band(top, state, rtol)

    params = mdl.params(top, model_options)
    y0, scales = _start_of(mdl, state, params, starts)
    if backend == "auto":  # the fastest exact backend for this model, law and method
        backend = backends.choose(mdl, plan.method, params, model_options, y0.size, bool(user))
    atol_arr = _check_atol(plan.atol, y0.size, scales)
    if atol_arr is None:
        atol_arr = rtol * scales

    table = {ph.name: ph for ph in phases}
    phase = phases[0]
    if mdl.start_phase is not None:
        name = mdl.start_phase(y0, params)
        if name not in table:
            raise ValueError(f"model {mdl.name!r}: start_phase gave unknown phase {name!r}")
        phase = table[name]
    run = Run(mdl, top, params, y0, backend, phase, state=state, options=model_options)
    run.tolerances = {"rtol": rtol, "atol": atol_arr, "t_end": plan.t_end}  # on the Trajectory
    gn0 = float(mdl.normal_force(y0, params))
    if not math.isfinite(gn0):
        return run.at_start("failed", f"normal force at t = 0 is {gn0!r}")
    for ev in phase.events:  # a start already past a guard (e.g. a pole)
        if ev.action == "fail" and float(ev.fn(0.0, y0, params)) <= 0.0:
            return run.at_start("failed", ev.message)
    if gn0 <= 0.0 and (plan.stop_on_contact_loss or not flight.flies(mdl)):
        msg = f"contact lost at t = 0: the initial normal force g_n = {gn0:.6g} N is not positive"
        return run.at_start("contact_lost", msg, t_contact_lost=0.0)
    return PreparedRun(run, table, plan.t_end, rtol, atol_arr, plan.t_eval_arr, plan.max_step,
                       plan.method, user)  # fmt: skip


def run_prepared(prep: PreparedRun) -> Trajectory:
    """Integrate a prepared run (:func:`prepare_run`) with its backend: a single-phase model in
    one call, a hybrid one phase by phase (:func:`.hybrid.solve_hybrid`)."""
    run, table, t_end, rtol, atol_arr, t_eval_arr, max_step, method, user = prep
    solve = functools.partial(
        backends.REGISTRY[run.backend].solve,
        t_end=t_end,
        rtol=rtol,
        atol=atol_arr,
        max_step=max_step,
        t_eval=t_eval_arr,
        method=method,
    )
    events = backends.UserEvents(user, run) if user else None
    if not run.mdl.hybrid:
        return run.trajectory(solve(run, events=events))
    return solve_hybrid(run, solve, table, events)


def _declares(mdl: Model, option: str) -> bool:
    return any(o.name == option for o in mdl.options)
