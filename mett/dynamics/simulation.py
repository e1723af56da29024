"""``simulate``: integrate a model of the tippe top from a :class:`~mett.State`.

Two backends run the same models (docs/theory/simulation.md#numerics):

* ``backend="compiled"`` (default): the compiled DOP853 of :mod:`.dop853` with the model's compiled
  right-hand side (:mod:`._kernels`, compiled from the same source as ``Model.rhs``). The contact
  event g_n = 0 and the model's guards are located inside the compiled loop. User ``events``
  (Python callables of a :class:`~mett.State`) cannot run there: they are evaluated after the run
  on the solver's steps and dense output (a change of class over a step, located by Brent's
  method on the interpolant, :class:`_UserEvents`), and a terminal user event truncates the
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
from scipy.integrate import OdeSolution, solve_ivp

from .. import _validate
from .. import friction as _friction
from ..state import State
from ..stem import StemmedTop
from ..top import TippeTop
from .gliding import viscous_force
from .registry import (
    MODELS,
    JumpFailed,
    Model,
    Phase,
    check_friction,
    lookup,
    validate_options,
)
from .trajectory import ConstantSolution, SegmentedSolution, Trajectory

__all__ = [
    "BACKENDS",
    "MAX_STEPS",
    "MODELS",
    "RATE_MAX",
    "SIMULATE_DEFAULTS",
    "check_run",
    "simulate",
]

_METHODS = ("DOP853", "RK45", "RK23", "Radau", "BDF", "LSODA")
MAX_STEPS = 1_000_000
"""Every backend stops with status "failed" after this many accepted steps (per phase of a hybrid
run), the steps taken kept. The compiled backend keeps every step in memory: 8 (12 + 8n) bytes per step for an n-component state, 656 MB for the gliding model (n = 10),
plus the Trajectory's series, about 140 MB more. Measured on the thesis top (rtol = 1e-10; 1e6
steps reach t = 74 000 s once the top has settled, about 3000 s while it still nutates fast): the
process peaks at 0.96 GB RSS, of which 0.19 GB is the interpreter with numpy, scipy and numba."""
BACKENDS = ("auto", "compiled", "scipy", "taylor")
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


class _UserEventError(Exception):
    """Carries an exception raised by a user event out of solve_ivp, to re-raise it unchanged."""

    def __init__(self, exc: BaseException) -> None:
        super().__init__(exc)
        self.exc = exc


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
            raise _UserEventError(exc) from exc

    return wrapped


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
    **options: Any,
) -> Trajectory:
    """Integrate the motion of a tippe top from ``state`` over ``[0, t_end]``.

    Parameters
    ----------
    top : TippeTop or StemmedTop
        Body and friction parameters. A :class:`~mett.stem.StemmedTop` (``top.with_stem(...)``)
        runs the ``"stemmed"`` model: ball and stem contacts with inelastic impacts at each change
        of contact (``docs/theory/stem.md``); its Trajectory also has ``contact`` ("ball" or
        "stem" per sample) and ``touchdowns`` (s). With ``friction=Coulomb(...)`` it runs
        ``"stemmed-coulomb"`` (``"stemmed-coulomb-contensou"``): stick–slip on either contact,
        ``phase`` per sample as for the dry models below (docs/theory/stem.md#dry-friction).
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
        steps and agree to rounding. ``"auto"``: compiled for DOP853 (every model has a compiled
        twin), scipy for other methods. ``Trajectory.backend`` says which ran. Every backend
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
        ``status`` is ``"completed"``, ``"contact_lost"`` (the normal force reached 0; the run ends
        there and ``t_contact_lost`` holds the time) or ``"failed"`` (the integrator could not
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
                           max_step=max_step, friction=friction, **options)  # fmt: skip
    prep = prepare_run(top, state, t_end, model=model, rtol=rtol, atol=atol, t_eval=t_eval,
                    events=events, method=method, backend=backend, max_step=max_step,
                    friction=friction, **options)  # fmt: skip
    # a run decided before the first step is returned as it is
    traj = run_prepared(prep) if isinstance(prep, PreparedRun) else prep
    if friction is not None:
        viscous_top, law = friction.applied(top)
        if law is None:  # the top's viscous law, given explicitly: its force series
            viscous_force(traj, viscous_top.mu)
    return traj


SIMULATE_DEFAULTS = {
    k: v.default
    for k, v in inspect.signature(simulate).parameters.items()
    if v.kind is inspect.Parameter.KEYWORD_ONLY
}
"""The keyword arguments of :func:`simulate` and their defaults."""


def check_run(top: TippeTop, state: Any, t_end: float, **simulate_kw: Any) -> None:
    """Every check ``simulate(top, state, t_end, **simulate_kw)`` makes before its first step,
    without integrating: bad input raises the ``ValueError``/``TypeError`` simulate would."""
    prepare_run(top, state, t_end, **{**SIMULATE_DEFAULTS, **simulate_kw})


def completed_message(t_end: float) -> str:
    """The message of a run that reached ``t_end``."""
    return f"reached t_end = {t_end:g} s"


def event_end(action: str, message: str, t_ev: float) -> tuple[str, str]:
    """Status and message of a run stopped at ``t_ev`` by a model event (not a switch) with this
    ``action`` and ``message``."""
    if action == "contact_lost":
        return "contact_lost", f"contact lost: the normal force g_n reached 0 at t = {t_ev:.9g} s"
    return "failed", f"{message} (t = {t_ev:.9g} s)"


def taylor_failure(status: int, t_stop: float) -> str:
    """The message of a Taylor run that failed with ``status`` (< 0) at ``t_stop``."""
    from . import taylor

    base = taylor.STATUS_MESSAGES[status]
    if status == taylor.MAX_STEPS:
        base = f"maximum number of steps ({MAX_STEPS}) reached"
    return f"integrator failed at t = {t_stop:.9g} s: {base}"


class PreparedRun(NamedTuple):
    """A validated run, ready for its solver (:func:`_prepare`)."""

    run: _Run
    table: dict[str, Phase]
    t_end: float
    rtol: float
    atol_arr: np.ndarray
    t_eval_arr: np.ndarray | None
    max_step: float
    method: str
    user: list


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
    **options: Any,
) -> PreparedRun | Trajectory:
    """Everything :func:`simulate` does before integrating: validation, the model that runs (its
    friction law and variant), the backend, parameters and start; a run decided at t = 0 (contact
    lost, a guard) is returned as its Trajectory; a law is applied first (never run here)."""  # fmt: skip
    mdl = lookup(model)
    if not isinstance(top, TippeTop):
        raise TypeError(f"top must be a mett.TippeTop; got {type(top).__name__}")
    state = _check_state(state)
    _check_magnitudes(top, state)
    t_end = _validate.positive_scalar("t_end", t_end)
    rtol = _check_rtol(rtol)
    t_eval_arr = _check_t_eval(t_eval, t_end)
    if isinstance(max_step, (bool, np.bool_, str, bytes)) or max_step is None:
        raise TypeError(f"max_step must be a real number; got {max_step!r}")
    max_step = float(max_step)
    if not max_step > 0.0:
        raise ValueError(f"max_step must lie in (0, inf]; got {max_step!r}")
    if t_end / max_step > MAX_STEPS:  # refused up front rather than run into the step budget
        raise ValueError(
            f"max_step must be at least t_end / MAX_STEPS = {t_end / MAX_STEPS:.3g} s (the run "
            f"would need more than {MAX_STEPS} steps); got {max_step!r}"
        )
    if method not in _METHODS:
        raise ValueError(f"unknown method {method!r}; known methods: {', '.join(_METHODS)}")
    if backend not in BACKENDS:
        raise ValueError(f"unknown backend {backend!r}; known backends: {', '.join(BACKENDS)}")
    if friction is not None:  # the law decides the top and the model, before anything runs
        friction = _friction.check_law(friction)
        check_friction(mdl, friction)  # a law the model does not run (None: validate_options)
        top, law = friction.applied(top)  # Viscous(mu): the top with that mu, no law left
        if law is not None:
            runs = law.model_for(mdl.name)  # the model given (also an unregistered one), or
            mdl = mdl if runs == mdl.name else lookup(runs)  # the registered one the law names
            options = {**options, "friction": law}
    model_options = validate_options(mdl, options)
    if mdl.variant is not None:  # an option may select another model (e.g. a friction law)
        alt = mdl.variant(model_options)
        if alt is not None and alt is not mdl:
            mdl, model_options = alt, validate_options(alt, options)
    if _declares(mdl, "stopping_band") and model_options["stopping_band"] is None:
        from .stickslip import stopping_band  # tied to rtol, as the integration error is

        model_options["stopping_band"] = stopping_band(top, state, rtol)
    phases = mdl.phase_table()
    compilable = all(ph.rhs_into is not None for ph in phases)
    if backend == "auto":
        backend = "compiled" if method == "DOP853" and compilable else "scipy"
    elif backend in ("compiled", "taylor"):
        if backend == "taylor" and method != "DOP853":
            raise ValueError(
                f"method {method!r} is for the DOP853 and scipy backends; the taylor backend "
                "chooses its own order from rtol"
            )
        if method != "DOP853":
            raise ValueError(
                f"the compiled backend implements method 'DOP853' only; got method {method!r} "
                "(use backend='scipy' for the other methods of scipy.integrate.solve_ivp)"
            )
        if not compilable:
            raise ValueError(
                f"model {mdl.name!r} has no compiled right-hand side; use backend='scipy'"
            )
    events = list(events or [])
    for k, ev in enumerate(events):
        if not callable(ev):
            raise TypeError(f"events[{k}] must be a callable event(t, state) -> float; got {ev!r}")
    user = [(ev, _event_terminal(k, ev), _event_direction(k, ev)) for k, ev in enumerate(events)]

    params = mdl.params(top, model_options)
    y0 = np.asarray(mdl.initial(state, params), dtype=float)
    scales = np.asarray(mdl.scales(y0, params), dtype=float)
    atol_arr = _check_atol(atol, y0.size, scales)
    if atol_arr is None:
        atol_arr = rtol * scales

    table = {ph.name: ph for ph in phases}
    phase = phases[0]
    if mdl.start_phase is not None:
        name = mdl.start_phase(y0, params)
        if name not in table:
            raise ValueError(f"model {mdl.name!r}: start_phase gave unknown phase {name!r}")
        phase = table[name]
    run = _Run(mdl, top, params, y0, backend, phase, state=state, options=model_options)
    gn0 = float(mdl.normal_force(y0, params))
    if not math.isfinite(gn0):
        return run.at_start("failed", f"normal force at t = 0 is {gn0!r}")
    for ev in phase.events:  # a start already past a guard (e.g. a pole)
        if ev.action == "fail" and float(ev.fn(0.0, y0, params)) <= 0.0:
            return run.at_start("failed", ev.message)
    if gn0 <= 0.0:
        msg = f"contact lost at t = 0: the initial normal force g_n = {gn0:.6g} N is not positive"
        return run.at_start("contact_lost", msg, t_contact_lost=0.0)
    return PreparedRun(run, table, t_end, rtol, atol_arr, t_eval_arr, max_step, method, user)


def run_prepared(prep: PreparedRun) -> Trajectory:
    """Integrate a prepared run (:func:`_prepare`) with its backend."""
    run, table, t_end, rtol, atol_arr, t_eval_arr, max_step, method, user = prep
    mdl = run.mdl
    solvers = {"compiled": _solve_compiled, "scipy": _solve_scipy, "taylor": _solve_taylor}
    solve = functools.partial(
        solvers[run.backend],
        t_end=t_end,
        rtol=rtol,
        atol_arr=atol_arr,
        max_step=max_step,
        method=method,
    )
    events = _UserEvents(user, run) if user else None
    if not mdl.hybrid:
        return solve(run, t_eval_arr=t_eval_arr, events=events)
    return _solve_hybrid(run, solve, table, t_eval_arr, events)


MAX_SWITCHES = 100_000
"""A hybrid model's run stops with status "failed" after this many phase switches."""


def _solve_hybrid(
    run: _Run,
    solve: Callable,
    table: dict[str, Phase],
    t_eval_arr: np.ndarray | None,
    events: _UserEvents | None,
) -> Trajectory:
    """Run a hybrid model phase by phase: each phase until one of its events; a "switch" event
    starts the phase it names at the located time (with the event's ``jump`` applied), any other
    end (t_end, contact lost, a failure, a terminal user event) ends the run.

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
    while True:
        seg = solve(run, t_eval_arr=t_eval_arr, events=events, collect=True)
        nfev += seg.kw.get("nfev", 0)
        sols.append(seg.sol)
        seg_phases.append(run.phase.name)
        last = run.switch is None or len(switches) >= MAX_SWITCHES
        if not last:
            index, t_sw = run.switch
            ev = run.phase.events[index]
            y_ev = np.asarray(seg.sol(t_sw), dtype=float)
            y_sw, target = y_ev, ev.target
            if ev.jump is not None:
                try:
                    y_sw = np.asarray(ev.jump(y_ev, params), dtype=float)
                except JumpFailed as exc:  # the run ends at the switch, state before it kept
                    jump_failed, last = f"{exc} (t = {t_sw:.9g} s)", True
            if ev.select is not None and not last:
                target = ev.select(y_sw, params)
                if target not in table:
                    jump_failed = f"switch to unknown phase {target!r} (t = {t_sw:.9g} s)"
                    last = True
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
        run = _Run(mdl, run.top, params, y_sw, run.backend, table[target], t0=t_sw,
                   state=run.state, options=run.options)  # fmt: skip
    kw = dict(seg.kw)
    kw["nfev"] = nfev
    status, message = seg.status, seg.message
    if jump_failed is not None:
        status, message = "failed", jump_failed
    elif run.switch is not None:  # stopped for switching too often
        status, message = "failed", f"more than {MAX_SWITCHES} phase switches"
    t_all = np.concatenate(t_parts)
    Y_all = np.hstack(y_parts)
    run.collect, run.joining = False, True
    traj = run.result(t_all, Y_all, SegmentedSolution(sols, seg_phases), status, message, **kw)
    traj.phase = np.array(phases)
    traj.switches = switches
    traj.jumps = jumps
    if mdl.finish is not None:
        mdl.finish(traj)
    return traj


class _Piece(NamedTuple):
    """One phase of a hybrid run (what :meth:`_Run.result` returns while collecting)."""

    t: Any
    Y: Any
    sol: Any
    status: str
    message: str
    kw: dict


class _Run:
    """What both backends share: the model, its parameters, and how to build the Trajectory."""

    def __init__(
        self,
        mdl: Model,
        top: TippeTop,
        params: tuple,
        y0: np.ndarray,
        backend: str,
        phase: Phase,
        t0: float = 0.0,
        *,
        state: State | None = None,
        options: dict | None = None,
    ) -> None:
        self.mdl, self.top, self.params, self.y0, self.backend = mdl, top, params, y0, backend
        self.phase, self.t0 = phase, t0
        self.state, self.options = state, options  # kept on the Trajectory (saved with it)
        self.collect = False  # True: result() returns the pieces, for a hybrid run to join
        self.joining = False  # True: result() builds the joined hybrid run (finished by the caller)
        self.switch: tuple[int, float] | None = None  # (event index, time) of a "switch" stop

    def result(self, t, Y, sol, status: str, message: str, **kw: Any) -> Any:
        if self.collect:
            return _Piece(t, Y, sol, status, message, kw)
        traj = Trajectory(
            t=t,
            states=Y,
            model=self.mdl,
            top=self.top,
            params=self.params,
            solution=sol,
            status=status,
            message=message,
            backend=self.backend,
            initial_state=self.state,
            options=self.options,
            **kw,
        )
        if self.mdl.hybrid:  # one phase throughout (a hybrid run joins its phases itself)
            traj.phase = np.full(traj.t.shape, self.phase.name)
            traj.switches, traj.jumps = [], []
        if self.mdl.finish is not None and not self.joining:
            self.mdl.finish(traj)
        return traj

    def at_start(self, status: str, message: str, **kw: Any) -> Trajectory:
        """A run that ends at t = 0 (contact lost or failure before the first step)."""
        sol = ConstantSolution(self.t0, self.y0)
        return self.result([self.t0], self.y0, sol, status, message, **kw)

    def contact_lost(self, t_out, Y, sol, t_ev: float, **kw: Any) -> Trajectory:
        msg = event_end("contact_lost", "", t_ev)[1]
        return self.result(t_out, Y, sol, "contact_lost", msg, t_contact_lost=float(t_ev), **kw)

    def stopped(self, t_out, Y, sol, index: int, t_ev: float, **kw: Any) -> Trajectory:
        """The run stopped at the model's event ``index``, located at ``t_ev``."""
        ev = self.phase.events[index]
        if ev.action == "contact_lost":
            return self.contact_lost(t_out, Y, sol, t_ev, **kw)
        if ev.action == "switch":
            self.switch = (index, float(t_ev))
            msg = f"switch to phase {ev.target!r} at t = {t_ev:.9g} s"
            return self.result(t_out, Y, sol, "completed", msg, **kw)
        return self.result(t_out, Y, sol, *event_end(ev.action, ev.message, t_ev), **kw)


class _StepBudget(Exception):
    """Raised by the recording solver class at its step budget (:data:`MAX_STEPS`)."""


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


def _solve_scipy(
    run: _Run, *, t_end, rtol, atol_arr, t_eval_arr, max_step, events, method, collect=False
) -> Any:
    """The reference backend: :func:`scipy.integrate.solve_ivp` with the Python right-hand side.

    Integrates ``run.phase`` from ``run.t0``; returns the Trajectory (with ``collect``, the
    :class:`_Piece` for a hybrid run to join).
    """
    params, y0, t0 = run.params, run.y0, run.t0
    run.collect = collect
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

        model_event.terminal = 1  # type: ignore[attr-defined]
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
            """The user events, taken step by step (:class:`_UserEvents`); solve_ivp calls this
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
                method=_recording(method, pieces, states, MAX_STEPS),
                t_eval=t_eval_arr,
                dense_output=True,
                events=all_events,
                rtol=rtol,
                atol=atol_arr,
                max_step=max_step,
            )
    except _UserEventError as err:
        raise err.exc from None  # a user event's exception, unchanged (as solve_ivp lets it go)
    except (ArithmeticError, ValueError, np.linalg.LinAlgError, _StepBudget) as exc:
        # raised inside the solver (e.g. an LU factorisation of a non-finite Jacobian), or the
        # step budget: keep the steps taken so far, as for any other failure
        failed, reason = "integration failed", str(exc)
        if isinstance(exc, _StepBudget):  # worded as on the compiled backend
            failed, reason = "integrator failed", f"maximum number of steps ({MAX_STEPS}) reached"
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
        kw = {"t_events": events.result(sol.t_max) if events else [], "nfev": 0}
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
        (te[ev.terminal - 1], i)
        for i, (te, ev) in enumerate(zip(t_events, all_events, strict=False))
        if res.status == 1 and te.size >= ev.terminal
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

    kw: dict[str, Any] = {"t_events": events.result(t_stop) if events else [], "nfev": res.nfev}
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


def _solve_compiled(
    run: _Run, *, t_end, rtol, atol_arr, t_eval_arr, max_step, events, method, collect=False
) -> Any:
    """The default backend: compiled DOP853 (:mod:`.dop853`) with the model's compiled kernel.

    Integrates ``run.phase`` from ``run.t0``; returns the Trajectory (with ``collect``, the
    :class:`_Piece` for a hybrid run to join). ``method`` is DOP853 (checked by simulate).
    """
    # imported here: numba (and the compiled code) only when a compiled run is asked for
    from . import _kernels, dop853

    mdl, params = run.mdl, run.params
    run.collect = collect
    rhs, ev_fn = _kernels.compiled(mdl, run.phase.name)
    directions = [ev.direction for ev in run.phase.events]
    sol = dop853.solve(
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
        max_steps=MAX_STEPS,
    )
    dense = sol.dense
    t_stop = float(sol.t_steps[-1])
    failure = None
    if sol.status < 0:
        base = dop853.STATUS_MESSAGES[sol.status]
        if sol.status == dop853.MAX_STEPS:
            base = f"maximum number of steps ({MAX_STEPS}) reached"
        failure = f"integrator failed at t = {t_stop:.9g} s: {base}"
        if dense.h.size == 0:  # not a single step: nothing to interpolate
            return run.at_start("failed", failure, nfev=sol.nfev)
    stopped_by = None
    if sol.status == dop853.TERMINAL_EVENT:
        stopped_by = (int(sol.event_index[-1]), float(sol.event_t[-1]))
    return _finish(run, dense, t_stop, _truncate, sol.nfev, stopped_by,
                   failure, t_end, t_eval_arr, events)  # fmt: skip


def _finish(
    run: _Run,
    dense: Any,
    t_stop: float,
    truncate: Callable[[Any, float], Any],
    nfev: int,
    stopped_by: tuple[int, float] | None,
    failure: str | None,
    t_end: float,
    t_eval_arr: np.ndarray | None,
    events: _UserEvents | None,
) -> Any:
    """The Trajectory of a compiled (DOP853 or Taylor) run that ended at ``t_stop``: user events
    located on the dense output (a terminal one cuts the run there), the samples (the steps, or
    ``t_eval``), and the status: stopped by a model event ``stopped_by`` = (index, time), failed
    (``failure``), or completed."""
    kw: dict[str, Any] = {"nfev": nfev, "t_events": []}
    user_stop = None
    if events:
        try:
            events.advance(dense.t, events.values(dense.t, dense.y.T), dense)
        except _UserEventError as err:
            raise err.exc from None  # a user event's exception, unchanged (as on scipy)
        if events.stop is not None and events.stop[0] <= t_stop:
            # the run would have stopped here: cut it, and its dense output, at the event
            t_term, user_stop = events.stop
            dense, t_stop = truncate(dense, t_term), t_term
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
    run: _Run, *, t_end, rtol, atol_arr, t_eval_arr, max_step, events, method, collect=False
) -> Any:
    """The Taylor-series backend (:mod:`.taylor`): ``run.phase``'s jet at the order of ``rtol``.

    The per-step truncation error of component i is held at ≈ max(atol_i, rtol |y|_g) (the
    step-size norm of Jorba & Zou scaled by σ_i = atol_i/rtol), |y|_g the size of the model's
    vector that holds component i (``Model.vectors``; the component itself if none). Model events are located on the
    Taylor polynomials; user events after the run on the dense output, as for DOP853.
    """
    from . import taylor

    mdl, params = run.mdl, run.params
    run.collect = collect
    ph = run.phase
    kernel = taylor.kernel(
        ph.rhs_into, [ev.fn for ev in ph.events], run.y0.size, len(params),
        taylor.order_for(rtol), f"{mdl.name}_{ph.name}", params=params, vectors=mdl.vectors,
        lengths=mdl.conserved_lengths,
    )  # fmt: skip
    sol = taylor.solve(
        kernel, (run.t0, t_end), run.y0, params, scales=atol_arr / rtol,
        direction=[ev.direction for ev in ph.events], max_step=max_step, max_steps=MAX_STEPS,
    )[0]  # fmt: skip
    dense = sol.dense
    t_stop = float(dense.t[-1])
    nfev = sol.n_steps  # one jet per step (a jet of order p costs about p²/4 right-hand sides)
    failure = None
    if sol.status < 0:
        failure = taylor_failure(sol.status, t_stop)
        if sol.n_steps == 0:
            return run.at_start("failed", failure, nfev=nfev)
    stopped_by = None
    if sol.status == taylor.TERMINAL_EVENT:
        stopped_by = (sol.event_index, t_stop)
    return _finish(run, dense, t_stop, lambda d, t: d.truncate(t), nfev, stopped_by,
                   failure, t_end, t_eval_arr, events)  # fmt: skip


class _UserEvents:
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

    def __init__(self, events: list[tuple[Callable, int, float]], run: _Run) -> None:
        self.events = events
        self.fns = [_user_event(ev, run.mdl, run.params) for ev, _, _ in events]
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
                    raise _UserEventError(exc) from exc
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


def _truncate(dense: Any, t_stop: float) -> Any:
    """The dense output of a compiled run cut at ``t_stop`` (inside its last kept step)."""
    from .dop853 import DenseOutput

    k = int(np.searchsorted(dense.t, t_stop, side="left"))  # dense.t[k-1] < t_stop <= dense.t[k]
    k = max(k, 1)
    t = np.append(dense.t[:k], t_stop)
    y = np.vstack([dense.y[:k], dense(t_stop)[None, :]])
    return DenseOutput(t, y, dense.h[:k], dense.F[:k])


def _declares(mdl: Model, option: str) -> bool:
    return any(o.name == option for o in mdl.options)
