"""The model registry: every dynamical model declares itself here, once.

Design
------
A model is one :class:`Model` record, built in its own module and passed to :func:`register` at
import time; :data:`MODELS` (what :func:`mett.simulate` accepts), the compiled twins
(:mod:`._kernels`) and the option validation of :func:`mett.simulate` are all derived from these
records. Adding a model is one module that ends in ``register(MODEL)`` plus one import line in
:mod:`mett.dynamics` (the import order is the order of :data:`MODELS`).

A record holds

* the physics: ``rhs(t, y, p)`` (the Python reference, used by the scipy backend) and
  ``rhs_into(t, y, p, out)``, the same equations in plain float arithmetic written into ``out``,
  which :mod:`._kernels` compiles with numba for the compiled backend (``None``: scipy only);
* its **events** (:class:`Event`): functions ``fn(t, y, p)`` of plain arithmetic, located by the
  integrator (compiled from the same source on the compiled backend), each with a direction and an
  action: ``"contact_lost"`` (the normal force g_n reached 0: status "contact_lost"), ``"fail"``
  (the model left its domain, e.g. an Euler-angle form at its pole: status "failed" with the
  event's message) or ``"switch"`` (a hybrid model changes phase, see below). Their order is the
  order of the declaration; nothing else lists them. A start with an event function ≤ 0 is
  refused with that event's status;
* its **options** (:class:`Option`): keyword arguments of :func:`mett.simulate` that only this
  model accepts (``l=`` of "gliding-hst", ``vertical_cm=`` of "frictionless-routhian"), each with a
  validator that returns the normalised value or raises ``TypeError``/``ValueError`` naming the
  option; ``params(top, options)`` turns the top and the validated options (defaults filled in)
  into the parameter tuple ``p``. An option name several models declare (e.g. a friction law) is
  one keyword for all of them;
* the quantities it **conserves** (names of :class:`~mett.Trajectory` series: ``"lam"``, ``"D"``,
  ``"E"``, ``"E_mod"``, ``"omega3"``), which the contract tests (tests/test_model_contract.py)
  check on every registered model, with the compiled-equals-Python check, the State round trip
  and a positive normal force at rest;
* the conversions ``initial`` (State → y), ``derive`` (states → Trajectory series), ``theta`` and
  ``scales`` (typical magnitudes for the default ``atol``).

**Phases.** A hybrid model (e.g. dry friction: sliding, then rolling when the slip velocity
vanishes) declares its first phase as above, named by ``phase``, and its other phases in
``phases`` (:class:`Phase`: name, rhs, rhs_into, events); all phases share the state vector and
parameters. A ``"switch"`` event names the phase it leads to (``target``) and may map the state
across the switch (``jump(y, p) -> y``, e.g. a projection onto the constraint) and choose the
phase it continues in from the jumped state (``select(y, p)``, e.g. rolling or sliding after an
impact); ``start_phase(y0, p)`` chooses the phase at t = 0. :meth:`Model.phase_table` lists all phases. :func:`mett.simulate`
runs a hybrid model phase by phase: each phase until one of its events is located; a "switch"
event restarts the integration (same tolerances, same backend) in the target phase from the
located time and the (jumped) state; ``Trajectory.phase`` gives the phase of every sample and
``Trajectory.switches`` the (time, from, to) of every switch (``Trajectory.jumps`` the states
before and after its jump). As for any event, a zero at the start
of a phase is not an event: a phase's switch functions must start away from 0 on the side they
leave (e.g. a slip speed that must fall through a small positive level, not through 0 itself),
or the phase would never end. A run stops with status "failed" after
:data:`mett.dynamics.simulation.MAX_SWITCHES` switches.

The compiled kernels of a phase may call functions of other mett modules imported by name (a
friction model can call ``gliding_normal_force``): :mod:`._kernels` inlines them and keys its cache
on their source files too.

**Friction laws.** ``friction`` lists the law types (:mod:`mett.friction`, or ``type(None)``
for "no law given") that ``simulate(..., model=name, friction=law)`` accepts for the model; the
default, ``(type(None), Viscous)``, is that of a model whose contact has no law of its own (the
viscous law's μ replaces the top's). :func:`check_friction` refuses any other pairing, before
any work, with one ``ValueError`` naming the model and what it needs, e.g. ``model 'coulomb'
needs friction=mett.friction.Coulomb(mu); got None``. Which model runs a law is the law's
(``law.model_for(name)``, :mod:`mett.friction`): a law accepted by the model it names (e.g.
"gliding" asked with ``Coulomb(...)`` names "coulomb") passes here too.

**Variants.** An option can change which equations run, not only their parameters:
``variant(options)`` returns the model that runs instead, and :func:`mett.simulate` validates
the options again against it.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

import numpy as np

from ..friction import Viscous, check_law, registered, spelling

__all__ = [
    "ACTIONS",
    "MODELS",
    "Event",
    "JumpFailed",
    "Model",
    "Option",
    "Phase",
    "boolean",
    "check_friction",
    "friction_law",
    "kernel_call",
    "lookup",
    "positive_length",
    "register",
    "validate_options",
]

Params = tuple[float, ...]


def kernel_call(fn: Callable) -> Callable:
    """Mark a plain-arithmetic function that the compiled kernels call instead of inlining.

    The compiled backend (:mod:`mett.dynamics._kernels`) inlines the functions a right-hand side
    or an event calls. A large one (a contact force solved from a 3×3 or 4×4 system) that many
    events of one phase call was then compiled once per call site: the dry-friction event
    kernels took tens of seconds of CPU each. A marked function is compiled once and called;
    the arithmetic, and so the result, is the same. It is compiled without numba's runtime, so
    it must not create arrays (plain float arithmetic on its arguments, returning floats and
    tuples). Returns ``fn`` itself (only an attribute set).
    """
    fn.kernel_call = True  # type: ignore[attr-defined]
    return fn


ACTIONS = ("contact_lost", "fail", "switch")
"""What a model event does when the integrator locates it (see the module docstring)."""


class JumpFailed(Exception):
    """Raised by an :attr:`Event.jump` that cannot map the state across its switch (e.g. an impact
    without a solution): the run ends there with status "failed" and this message, the samples up
    to the switch kept."""


@dataclass(frozen=True)
class Event:
    """A terminal event of a model, located by the integrator.

    Attributes
    ----------
    fn : callable
        ``fn(t, y, p) -> float`` in plain float arithmetic (compiled with numba for the compiled
        backend from this very function; it may call functions of its own module only).
    direction : float
        As in :func:`scipy.integrate.solve_ivp`: −1 (positive to negative), +1 or 0 (either way).
    action : {"contact_lost", "fail", "switch"}
        What the zero means: the contact is lost (status "contact_lost"), the model fails (status
        "failed" with ``message``), or a hybrid model switches to phase ``target``.
    message : str
        Why a "fail" event stops the run (the time of the zero is appended).
    target : str
        The phase a "switch" event leads to.
    jump : callable, optional
        ``jump(y, p) -> y`` applied to the state at a switch (identity if None); it may raise
        :class:`JumpFailed` to end the run with status "failed".
    select : callable, optional
        ``select(y, p) -> str``: the phase the run continues in, chosen from the state after the
        jump (e.g. after an impact, sliding or rolling by the slip it leaves); default ``target``.
        A name that is no phase of the model ends the run with status "failed".
    grazing : bool
        The event function can dip through zero and back within one step (a grazing excursion,
        e.g. a cone margin that a smooth motion brushes twice per nutation): the compiled DOP853
        backend then also looks for an interior minimum (maximum) of the event over each step
        and locates the zero before it (:func:`mett.dynamics.dop853.solve`, ``grazing``); the
        other backends check the ends of steps (scipy) or sample points (Taylor) only. Needs a
        direction of −1 or +1.
    history : bool
        ``jump`` also takes the run's switches so far, this one last: ``jump(y, p, switches)``
        with ``switches`` a list of (time, from, to), so that it can see a sequence of switches
        (e.g. impacts that accumulate, :mod:`.stem`).
    """

    fn: Callable[[float, Any, Any], float]
    direction: float = -1.0
    action: str = "fail"
    message: str = ""
    target: str = ""
    jump: Callable[[np.ndarray, Params], np.ndarray] | None = None
    select: Callable[[np.ndarray, Params], str] | None = None
    grazing: bool = False
    history: bool = False

    def __post_init__(self) -> None:
        if self.grazing and self.direction == 0.0:
            raise ValueError("a grazing event needs a direction (-1 or +1)")
        if not callable(self.fn):
            raise TypeError(f"Event.fn must be callable; got {self.fn!r}")
        if self.action not in ACTIONS:
            raise ValueError(f"Event.action must be one of {ACTIONS}; got {self.action!r}")
        if self.direction not in (-1.0, 0.0, 1.0):
            raise ValueError(f"Event.direction must be -1, 0 or 1; got {self.direction!r}")
        if self.action == "switch" and not self.target:
            raise ValueError("a 'switch' event must name its target phase")
        if self.action == "fail" and not self.message:
            raise ValueError("a 'fail' event must say why the run stops (message)")


@dataclass(frozen=True)
class Option:
    """A keyword argument of :func:`mett.simulate` that a model accepts.

    Attributes
    ----------
    name : str
        The keyword.
    check : callable
        ``check(name, value) -> value``: the validated, normalised value; raises ``TypeError``
        (wrong type) or ``ValueError`` (out of range) naming the option.
    default : object
        The value ``params`` sees when the option is not given (or given as None).
    doc : str
        One line for the error messages and the docs.
    required : bool
        The model cannot run without it: :func:`validate_options` refuses a run that does not
        give it, naming the model and the option (``doc`` says what it is).
    """

    name: str
    check: Callable[[str, Any], Any]
    default: Any = None
    doc: str = ""
    required: bool = False


@dataclass(frozen=True)
class Phase:
    """A further phase of a hybrid model: its own right-hand side and events, same state vector."""

    name: str
    rhs: Callable[[float, np.ndarray, Params], np.ndarray]
    rhs_into: Callable[[float, Any, Any, Any], None] | None = None
    events: tuple[Event, ...] = ()


@dataclass(frozen=True)
class Model:
    """A dynamical model: right-hand side, events, options, conversions to/from :class:`State`.

    Attributes
    ----------
    name : str
        Registry name (``simulate(..., model=name)``).
    summary : str
        One line: what the model is and where its equations come from.
    rhs : callable
        ``rhs(t, y, p) -> dy``: pure function of a flat float array and a parameter tuple.
    normal_force : callable
        ``normal_force(y, p) -> g_n`` (N); ``y`` may be one state or an array of shape (n, k).
    params : callable
        ``params(top, options) -> p``: the parameter tuple, from the top and the validated
        options (every declared option present, defaults filled in).
    initial : callable
        ``initial(state, p) -> y0``: the model state of a scalar :class:`State`; raises
        ``ValueError`` for a state the model cannot represent.
    derive : callable
        ``derive(Y, p) -> dict`` of the Trajectory series for states ``Y`` of shape (n, k). A
        model with ``cos_theta`` (run in batches) also takes parameters of one value per column
        (each entry of ``p`` an array of shape (k,)), with the same result as column by column.
    theta : callable
        ``theta(Y, p) -> θ``, cheap, for crossings.
    scales : callable
        ``scales(y0, p) -> array``: a typical magnitude per component; ``atol = rtol * scales``.
    rhs_into : callable, optional
        ``rhs_into(t, y, p, out)``: ``rhs`` written into ``out`` in plain float arithmetic, the
        source of the compiled twin (None: the model runs on the scipy backend only).
    events : tuple of Event
        Located by the integrator, in this order (the first phase's, for a hybrid model).
    options : tuple of Option
        The model's keyword arguments of :func:`mett.simulate`.
    conserves : tuple of str
        Trajectory series the model conserves exactly (checked by the contract tests).
    phase : str
        Name of the first phase of a hybrid model ("" for a single-phase model).
    phases : tuple of Phase
        The further phases of a hybrid model.
    start_phase : callable, optional
        ``start_phase(y0, p) -> str``: the phase at t = 0 (default: the first).
    variant : callable, optional
        ``variant(options) -> Model or None``: the model that actually runs for these validated
        options (None: this one); the variant must accept the same options. (A friction law
        names its model itself, ``law.model_for``.)
    vectors : tuple of tuple of int
        Index tuples of state components that form one physical vector (a position, velocity,
        angular momentum, unit axis): the Taylor backend measures a vector's truncation error
        against its length (:func:`mett.dynamics.taylor.kernel`). Default: none.
    friction : tuple of type
        The friction-law types (:mod:`mett.friction`; ``type(None)``: no law given) the model runs
        with, checked by :func:`check_friction` before any work. Default: none or
        :class:`~mett.friction.Viscous` (its μ replaces the top's), as for a model without a law
        of its own. A model that declares the option ``friction`` receives the law there.
    conserved_lengths : tuple of tuple of int
        Index tuples of state vectors whose Euclidean length the equations conserve for every
        state, not only |3̂| = 1: the rate of the vector is perpendicular to it (3̂̇ = ω × 3̂/|3̂|,
        whatever ω). The Taylor backend then takes the length at the start of each step as a
        number (an exact simplification, :func:`mett.dynamics.taylor.trace`); the contract
        tests check the perpendicularity. Default: none.
    cos_theta : callable, optional
        ``cos_theta(t, y, p)``: cos θ of one state in plain arithmetic (no branches; traceable
        by :mod:`.taylor`), so that many runs at once (:func:`mett.dynamics.batch.run_ends`) can
        locate the crossings of θ on the Taylor polynomials. None: those runs go one by one.
    mu_free_start : bool
        True if ``initial`` and ``scales`` never read the friction coefficient ``p[MU]``
        (:mod:`._params`): runs that differ in μ alone then share their start and tolerance
        scales (:func:`mett.dynamics.simulation.prepare_planned`, what a sweep over friction
        prepares). The contract tests check it. Default False.
    finish : callable, optional
        ``finish(traj) -> (extras, records)``: what a run carries beyond its states, returned
        as two mappings: per-sample series (one value per sample, floats or text, e.g. the
        contact force of each sample's phase of a stick–slip run, which needs ``traj.phase``)
        and whole-run records (numbers, float arrays, lists of records, e.g. the switches).
        Called once as the :class:`~mett.Trajectory` of every run is made, with the run's
        states, ``phase``, and a hybrid run's ``switches`` and ``jumps``; the Trajectory
        stores the mappings (``extras``, ``records``, each entry also an attribute) and saves
        them without knowing their names.
    """

    name: str
    summary: str
    rhs: Callable[[float, np.ndarray, Params], np.ndarray]
    normal_force: Callable[[np.ndarray, Params], Any]
    params: Callable[[Any, dict], Params]
    initial: Callable[[Any, Params], np.ndarray]
    derive: Callable[[np.ndarray, Params], dict[str, np.ndarray]]
    theta: Callable[[np.ndarray, Params], np.ndarray]
    scales: Callable[[np.ndarray, Params], np.ndarray]
    rhs_into: Callable[[float, Any, Any, Any], None] | None = None
    events: tuple[Event, ...] = ()
    options: tuple[Option, ...] = ()
    conserves: tuple[str, ...] = ()
    phase: str = ""
    phases: tuple[Phase, ...] = field(default=())
    start_phase: Callable[[np.ndarray, Params], str] | None = None
    variant: Callable[[dict], Model | None] | None = None
    finish: Callable[[Any], tuple[Mapping[str, Any], Mapping[str, Any]]] | None = None
    vectors: tuple[tuple[int, ...], ...] = ()
    cos_theta: Callable[[float, Any, Any], Any] | None = None
    conserved_lengths: tuple[tuple[int, ...], ...] = ()
    friction: tuple[type, ...] = (type(None), Viscous)
    mu_free_start: bool = False

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise ValueError(f"Model.name must be a non-empty str; got {self.name!r}")
        object.__setattr__(self, "friction", tuple(self.friction))
        for law in self.friction:
            if law is not type(None) and law not in registered():
                raise ValueError(
                    f"model {self.name!r}: friction must list None or registered law types "
                    f"({', '.join(c.__name__ for c in registered())}); got {law!r}"
                )
        if not getattr(self.derive, "chunked", False):
            object.__setattr__(self, "derive", _chunked(self.derive))
        for attr in ("events", "options", "conserves", "phases"):
            object.__setattr__(self, attr, tuple(getattr(self, attr)))
        names = [o.name for o in self.options]
        if len(set(names)) != len(names):
            raise ValueError(f"model {self.name!r} declares an option twice: {names}")
        table = self.phase_table()
        phase_names = [ph.name for ph in table]
        if len(set(phase_names)) != len(phase_names):
            raise ValueError(f"model {self.name!r} has duplicate phase names: {phase_names}")
        for ph in table:
            for ev in ph.events:
                if ev.action == "switch" and ev.target not in phase_names:
                    raise ValueError(
                        f"model {self.name!r}: a switch event of phase {ph.name!r} leads to "
                        f"unknown phase {ev.target!r}; phases: {phase_names}"
                    )
        for ph in table:
            if [ev.action for ev in ph.events].count("contact_lost") != 1:
                raise ValueError(
                    f"model {self.name!r}, phase {ph.name!r}: needs exactly one 'contact_lost' "
                    "event (the normal force reaching 0), as every model of a top on a plane"
                )

    def phase_table(self) -> tuple[Phase, ...]:
        """All phases: the first (``rhs``, ``rhs_into``, ``events``) and then ``phases``."""
        first = Phase(self.phase, self.rhs, self.rhs_into, self.events)
        return (first, *self.phases)

    def parameters(self, top: Any, **options: Any) -> Params:
        """The parameter tuple for ``top`` and keyword ``options`` (validated, defaults filled)."""
        return self.params(top, validate_options(self, options))

    @property
    def hybrid(self) -> bool:
        """True for a model with several phases."""
        return bool(self.phases)


DERIVE_CHUNK = 65_536
"""Samples per call of a model's ``derive``: a long run's series are derived in chunks of this many
samples, so that its temporaries (dozens of arrays per sample) stay small next to the results."""


def _chunked(derive: Callable) -> Callable:
    """``derive`` evaluated on at most :data:`DERIVE_CHUNK` samples at a time (elementwise, so the
    result is that of one call); without this, deriving the series of a million-step run took
    more memory than the run itself."""

    def chunked(Y: np.ndarray, p: Params) -> dict[str, np.ndarray]:
        Y = np.asarray(Y, dtype=float)
        if Y.ndim != 2 or Y.shape[1] <= DERIVE_CHUNK:
            return derive(Y, p)
        n = Y.shape[1]
        out: dict[str, np.ndarray] = {}
        for i in range(0, n, DERIVE_CHUNK):
            part = derive(Y[:, i : i + DERIVE_CHUNK], p)
            k = min(DERIVE_CHUNK, n - i)
            for key, value in part.items():
                if key not in out:
                    out[key] = np.empty(n, dtype=np.result_type(value, float))
                out[key][i : i + k] = np.broadcast_to(value, (k,))
        return out

    chunked.chunked = True  # type: ignore[attr-defined]
    chunked.__wrapped__ = derive  # type: ignore[attr-defined]
    chunked.__doc__ = derive.__doc__
    return chunked


_REGISTRY: dict[str, Model] = {}

MODELS: Mapping[str, Model] = MappingProxyType(_REGISTRY)
"""The registered models, by name, in registration order (read-only view)."""


def register(model: Model) -> Model:
    """Add ``model`` to :data:`MODELS` (once per name) and return it.

    Raises
    ------
    TypeError
        If ``model`` is not a :class:`Model`.
    ValueError
        If another model of that name is registered.
    """
    if not isinstance(model, Model):
        raise TypeError(f"register needs a mett.dynamics.Model; got {type(model).__name__}")
    old = _REGISTRY.get(model.name)
    if old is not None and old is not model:
        raise ValueError(f"a model named {model.name!r} is already registered")
    _REGISTRY[model.name] = model
    return model


def lookup(model: str | Model) -> Model:
    """The :class:`Model` of a registered name, or ``model`` itself if it is a Model."""
    if isinstance(model, Model):
        return model
    if not isinstance(model, str) or model not in _REGISTRY:
        raise ValueError(f"unknown model {model!r}; known models: {', '.join(_REGISTRY)}")
    return _REGISTRY[model]


def _spelled(law: type) -> str:
    """How ``law`` (a registered law class, or ``type(None)``) is written in messages."""
    return "None (the top's mu)" if law is type(None) else spelling(law)


def check_friction(model: Model, law: Any) -> Any:
    """``law`` itself if ``model`` runs with it (:attr:`Model.friction`), else ``ValueError``.

    The one place where a model and a friction law are matched: ``simulate(model="coulomb")``
    without a law, or with ``Viscous(mu)``, is refused here before any work, naming the
    argument, the model and what it needs. ``law`` must already be a law or None
    (:func:`mett.friction.check_law`, a ``TypeError`` otherwise).
    """
    if isinstance(law, model.friction):
        return law
    if law is not None:  # a law that hands the run over to another model (its model_for)
        target = _REGISTRY.get(law.model_for(model.name))
        if target is not None and target is not model and isinstance(law, target.friction):
            return law
    spelled = [_spelled(c) for c in model.friction]
    needs = spelled[0] if len(spelled) == 1 else ", ".join(spelled[:-1]) + " or " + spelled[-1]
    verb = "takes" if type(None) in model.friction else "needs"
    owners = [m.name for m in _REGISTRY.values() if law is not None and isinstance(law, m.friction)]
    more = ", ..." if len(owners) > 3 else ""
    hint = f" (it runs with model {', '.join(map(repr, owners[:3]))}{more})" if owners else ""
    raise ValueError(f"model {model.name!r} {verb} friction={needs}; got {law!r}{hint}")


def validate_options(model: Model, given: Mapping[str, Any]) -> dict[str, Any]:
    """The model's options from keyword arguments ``given``, validated, defaults filled in.

    A value of None means "not given". A keyword the model does not declare is a ``ValueError``
    if another registered model declares it (naming those models), else a ``TypeError`` (an
    unexpected keyword argument, as Python would say). A required option not given, or a
    friction law the model does not run with (:func:`check_friction`), is a ``ValueError``
    naming the model.
    """
    declared = {o.name: o for o in model.options}
    out: dict[str, Any] = {}
    for key, value in given.items():
        opt = declared.get(key)
        if opt is None:
            owners = [m.name for m in _REGISTRY.values() if any(o.name == key for o in m.options)]
            if not owners:
                raise TypeError(f"simulate() got an unexpected keyword argument {key!r}")
            which = "model " if len(owners) == 1 else "models "
            raise ValueError(
                f"{key} applies only to {which}{', '.join(map(repr, owners))}; "
                f"got model {model.name!r}"
            )
        if value is not None:
            out[key] = opt.check(key, value)
    for opt in model.options:
        out.setdefault(opt.name, opt.default)
    if "friction" in declared:
        check_friction(model, out["friction"])
    required = [o for o in model.options if o.required]
    missing = [o.name for o in required if out.get(o.name) is None]
    if missing:
        what = "; ".join(f"{o.name}: {o.doc}" for o in required)
        raise ValueError(
            f"model {model.name!r} needs {' and '.join(o.name for o in required)} ({what}); "
            f"{' and '.join(missing)} not given"
        )
    return out


def friction_law(name: str, value: Any) -> Any:
    """:attr:`Option.check` of an option ``friction``: a law of :mod:`mett.friction`
    (``TypeError`` otherwise); which laws the model runs with is :func:`check_friction`'s."""
    return check_law(value)


# --- validators for Option.check ---------------------------------------------------------------


def boolean(name: str, value: Any) -> bool:
    """A real bool (``True``/``False``, numpy bools included); anything else is a TypeError.

    ``bool("no")`` is True: accepting strings or numbers would silently invert a user's intent.
    """
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    raise TypeError(f"{name} must be a bool (True or False); got {value!r}")


def positive_length(name: str, value: Any) -> float:
    """A finite real number > 0 (a length in m); bools and strings are a TypeError."""
    if isinstance(value, (bool, np.bool_, str, bytes)) or not isinstance(
        value, (int, float, np.integer, np.floating)
    ):
        raise TypeError(f"{name} must be a real number (m); got {value!r}")
    x = float(value)
    if not (math.isfinite(x) and x > 0.0):
        raise ValueError(f"{name} must lie in (0, inf) (m); got {x!r}")
    return x
