"""Friction laws of the contact between the tippe top and the plane, as immutable objects.

Pass one to :func:`mett.simulate` as ``friction=...`` (see ``docs/theory/friction.md``):

* :class:`Viscous` — today's law F_t = −μ g_n v_A, μ in s/m (Rutstam 2013, thesis eq. (3)); the
  default, with μ = ``top.mu``. It runs the ``"gliding"`` model unchanged.
* :class:`Coulomb` — dry friction with a dimensionless μ, integrated as **exact stick–slip**:
  sliding phases with F_t = −μ g_n v_A/|v_A|, rolling (stick) phases with v_A = 0 while the force
  that rolling needs stays inside the cone |F_t| ≤ μ g_n, switching at located events
  (:mod:`mett.dynamics.stickslip`). With ``contensou_radius > 0`` the contact is a disc and the
  spin about the normal is resisted too: the Coulomb–Contensou law of Leine & Glocker (2003).
* :class:`RegularisedCoulomb` — F_t = −μ g_n v_A/√(|v_A|² + ε²) (the "modified Coulomb" law of
  Ueda, Sasaki & Watanabe 2005 and of Or 1994 is of this smoothed kind), for comparison with the
  exact law as ε → 0.

Every law also evaluates its force as a function (:meth:`force`), vectorised over samples.

**The protocol and the registry.** A law is any object of the :class:`FrictionLaw` protocol whose
class is registered with :func:`register`: it declares its parameters (:class:`Param`: name, unit,
range), the names it is written by (:data:`LAWS`, the command line's ``--friction NAME:ARGS``),
``applied(top)`` (the top and the law the model receives: :class:`Viscous` puts its μ on the top
and leaves no law) and ``model_for(base)`` (the registered model that runs it when ``base`` is
asked). :func:`mett.simulate` asks these two and nothing else, so a law defined in another module
(:mod:`mett.dynamics.resistance`, rolling resistance) is added by that module alone.

Coulomb–Contensou (Leine & Glocker 2003, Eur. J. Mech. A/Solids 22, 193–216). For a contact disc
of radius r with uniform pressure, the force and the drilling torque M (about the normal ẑ) of
combined slip v_A and spin ω_n = ω·ẑ are integrals over the disc; in pure slip the force is
Coulomb's, −μ g_n v̂_A, and in pure spin |M| = (2/3) μ g_n r. Leine & Glocker approximate the
exact force set by the ellipsoid |F_t|² + (M/r*)² ≤ (μ g_n)² with r* = (2/3) r, which gives the
sliding law on the generalised slip velocity γ = (v_A, r* ω_n):

    F_t = −μ g_n v_A / |γ|,    M = −μ g_n r*² ω_n / |γ|,    |γ| = √(|v_A|² + r*² ω_n²),

exact in both limits (pure slip, pure spin) and the one used here. Its consequence for the top:
while it spins (ω_n ≠ 0) the force is a smooth function of v_A and vanishes at v_A = 0, so there is
no stick phase, and at small slip it is a viscous law with μ_eff = μ/(r* |ω_n|) (s/m). Only when
γ = 0 (no slip, no spin about the normal) does the contact stick, with force and torque inside
the ellipsoid.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any, ClassVar, NamedTuple, Protocol, cast, runtime_checkable

import numpy as np

from . import _validate

__all__ = [
    "CONTENSOU_HERTZ",
    "CONTENSOU_UNIFORM",
    "LAWS",
    "LAW_NAMES",
    "Coulomb",
    "FrictionLaw",
    "LawForm",
    "Param",
    "RegularisedCoulomb",
    "Viscous",
    "check_law",
    "check_params",
    "describe",
    "from_args",
    "from_name",
    "label",
    "register",
    "registered",
    "spelling",
]

CONTENSOU_UNIFORM = 2.0 / 3.0
"""r*/r of a uniform-pressure contact disc: pure spin gives |M| = (2/3) μ g_n r (Leine & Glocker
2003). The default of :attr:`Coulomb.contensou_ratio`."""

CONTENSOU_HERTZ = 3.0 * np.pi / 16.0
"""r*/r of a Hertzian contact disc, pressure p ∝ √(1 − ρ²/r²): pure spin gives
|M| = μ ∫ρ p dA = (3π/16) μ g_n r, against (2/3) μ g_n r for uniform pressure."""


class Param(NamedTuple):
    """One parameter of a friction law: its name, unit and range (checked by :meth:`check`)."""

    name: str
    """The constructor's argument (and the law's attribute)."""
    unit: str
    """Its unit ("1": dimensionless)."""
    positive: bool = False
    """True: the range is (0, ∞); False: [0, ∞)."""
    doc: str = ""
    """What it is, for help texts."""

    @property
    def range(self) -> str:
        """The valid range, as error messages print it."""
        return "(0, inf)" if self.positive else "[0, inf)"

    def check(self, value: Any) -> float:
        """``value`` as a float, or ``ValueError``/``TypeError`` naming the parameter and range."""
        return _validate.positive_scalar(self.name, value, allow_zero=not self.positive)


@runtime_checkable
class FrictionLaw(Protocol):
    """What :func:`mett.simulate` needs of a friction law (a frozen dataclass, :func:`register`).

    ``params`` declares the coefficients; ``force`` evaluates the law; ``applied(top)`` is the top
    and the law the model receives (a viscous μ goes onto the top and no law is left);
    ``model_for(base)`` names the registered model that runs the law when model ``base`` is asked
    (``base`` itself when the law runs there as it is); ``describe()`` is a short label.
    An optional class attribute ``analytic`` (bool) declares whether the law's force is an
    analytic function of the state in every phase that runs it; ``backend="auto"`` runs the
    Taylor backend only for a law that declares ``analytic = True``.
    """

    params: ClassVar[tuple[Param, ...]]

    def force(self, v_A: Any, gn: Any, omega_n: Any = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """Tangential force (N, shape (2, ...)) and torque about ẑ (N m) of slip ``v_A`` (m/s)."""
        ...

    def applied(self, top: Any) -> tuple[Any, FrictionLaw | None]:
        """The top and the law (None: none) that the model runs with."""
        ...

    def model_for(self, base: str) -> str:
        """The registered model that runs this law when model ``base`` is asked."""
        ...

    def describe(self) -> str:
        """A short label, e.g. ``"Coulomb(mu=0.3)"``."""
        ...


def check_params(law: Any) -> None:
    """Every declared parameter of ``law`` checked in place (None kept where it is the default)."""
    for par in law.params:
        value = getattr(law, par.name)
        default = {f.name: f.default for f in dataclasses.fields(law)}.get(par.name)
        if value is None and default is None:
            continue
        object.__setattr__(law, par.name, par.check(value))


def label(law: Any) -> str:
    """``Name(a=1, b=2)`` of the parameters that differ from their defaults (and the required)."""
    parts = []
    for f in dataclasses.fields(law):
        value = getattr(law, f.name)
        if f.default is dataclasses.MISSING or value != f.default:
            parts.append(f"{f.name}={value:g}" if isinstance(value, float) else f"{f.name}={value}")
    return f"{type(law).__name__}({', '.join(parts)})"


@dataclass(frozen=True)
class Viscous:
    """Viscous-type gliding friction F_t = −μ g_n v_A (Rutstam 2013, thesis eq. (3)).

    Parameters
    ----------
    mu : float, optional
        Coefficient (s/m), ≥ 0. ``None`` (the default) takes ``top.mu`` at simulation time.
    """

    mu: float | None = None

    params: ClassVar[tuple[Param, ...]] = (Param("mu", "s/m", doc="viscous coefficient"),)
    analytic: ClassVar[bool] = True
    """The force is an analytic function of the state (linear in v_A): its Taylor series
    represent it, so ``backend="auto"`` runs it on the Taylor backend."""

    def __post_init__(self) -> None:
        check_params(self)

    def force(self, v_A: Any, gn: Any, omega_n: Any = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """Tangential force (N, shape (2, ...)) and torque about ẑ (N m, zero) of slip ``v_A``."""
        if self.mu is None:
            raise ValueError("Viscous(mu=None) takes mu from the top; give mu to evaluate force")
        v = np.asarray(v_A, dtype=float)
        gn = np.asarray(gn, dtype=float)
        return -self.mu * gn * v, np.zeros(np.broadcast(gn, v[0]).shape)

    def applied(self, top: Any) -> tuple[Any, None]:
        """The top with this μ (``top.mu`` is the viscous coefficient of every model), no law."""
        return (top if self.mu is None else dataclasses.replace(top, mu=self.mu)), None

    def model_for(self, base: str) -> str:
        """``base``: every model with a viscous contact runs it through ``top.mu``."""
        return base

    def describe(self) -> str:
        """``"viscous"`` (μ from the top) or ``"Viscous(mu=…)"``."""
        return "viscous" if self.mu is None else f"Viscous(mu={self.mu:g})"


# the dry models of mett.dynamics.stickslip and .stemslip, by the model asked for
_COULOMB_MODELS = {"gliding": "coulomb", "stemmed": "stemmed-coulomb"}
_CONTENSOU_MODELS = {
    "gliding": "coulomb-contensou",
    "coulomb": "coulomb-contensou",
    "stemmed": "stemmed-coulomb-contensou",
    "stemmed-coulomb": "stemmed-coulomb-contensou",
}


@dataclass(frozen=True)
class Coulomb:
    """Coulomb dry friction, optionally with Contensou spin friction (Leine & Glocker 2003).

    Sliding: F_t = −μ g_n v_A/|v_A|. Rolling (stick, v_A = 0): any F_t with |F_t| ≤ μ g_n — the
    force that the rolling constraint needs. :func:`mett.simulate` integrates it exactly, phase by
    phase (:mod:`mett.dynamics.stickslip`).

    Parameters
    ----------
    mu : float
        Friction coefficient (dimensionless), ≥ 0.
    contensou_radius : float, default 0.0
        Radius r of the contact disc (m), ≥ 0. With r > 0 the Coulomb–Contensou law with the
        effective radius r* = ``contensou_ratio`` · r (module docstring).
    contensou_ratio : float, default 2/3
        r*/r, the pressure distribution over the disc that sets the drilling torque of pure spin,
        |M| = μ g_n r*, > 0: :data:`CONTENSOU_UNIFORM` = 2/3 (uniform pressure; the default,
        the convention of Leine & Glocker 2003) or :data:`CONTENSOU_HERTZ` = 3π/16 ≈ 0.589
        (Hertzian pressure). The same r gives a 12 % smaller drilling torque with Hertz.
    """

    mu: float
    contensou_radius: float = 0.0
    contensou_ratio: float = CONTENSOU_UNIFORM

    params: ClassVar[tuple[Param, ...]] = (
        Param("mu", "1", doc="friction coefficient"),
        Param("contensou_radius", "m", doc="radius of the contact disc"),
        Param(
            "contensou_ratio",
            "1",
            positive=True,
            doc="r*/r of the contact disc: 2/3 uniform pressure, 3π/16 Hertz",
        ),
    )
    analytic: ClassVar[bool] = False
    """The slip direction v_A/|v_A| is not analytic at v_A = 0, where the stick–slip phases
    switch (the Taylor radius of convergence shrinks with |v_A|): ``backend="auto"`` runs the
    law on compiled DOP853."""

    def __post_init__(self) -> None:
        check_params(self)

    @property
    def r_star(self) -> float:
        """Effective Contensou radius r* = ``contensou_ratio`` · r (m); (2/3) r by default."""
        return self.contensou_ratio * self.contensou_radius

    def force(self, v_A: Any, gn: Any, omega_n: Any = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """Sliding force (N, shape (2, ...)) and torque about ẑ (N m) for γ = (v_A, r* ω_n) ≠ 0.

        At γ = 0 the law is set-valued (stick); this returns zero there.
        """
        v = np.asarray(v_A, dtype=float)
        gn = np.asarray(gn, dtype=float)
        wn = np.asarray(omega_n, dtype=float)
        rs = self.r_star
        norm = np.sqrt(v[0] ** 2 + v[1] ** 2 + (rs * wn) ** 2)
        k = np.where(norm > 0.0, -self.mu * gn / np.where(norm > 0.0, norm, 1.0), 0.0)
        return k * v, k * rs * rs * wn

    def applied(self, top: Any) -> tuple[Any, Coulomb]:
        """The top unchanged and this law (the dry models take μ from the law)."""
        return top, self

    def model_for(self, base: str) -> str:
        """The stick–slip model: "coulomb" or "coulomb-contensou" (r > 0) for "gliding", their
        stemmed forms for "stemmed"; ``base`` for any other model."""
        table = _CONTENSOU_MODELS if self.contensou_radius > 0 else _COULOMB_MODELS
        return table.get(base, base)

    def describe(self) -> str:
        """E.g. ``"Coulomb(mu=0.3)"`` or ``"Coulomb(mu=0.3, contensou_radius=0.0005)"``."""
        return label(self)


# the regularised models of mett.dynamics.stickslip and .stemreg, by the model asked for
_REGULARISED_MODELS = {"gliding": "coulomb-regularised", "stemmed": "stemmed-coulomb-regularised"}


@dataclass(frozen=True)
class RegularisedCoulomb:
    """Smoothed Coulomb friction F_t = −μ g_n v_A/√(|v_A|² + ε²) (Ueda et al. 2005; Or 1994).

    A single-valued, Lipschitz law: |F_t| → μ g_n for |v_A| ≫ ε and F_t ≈ −(μ/ε) g_n v_A, a stiff
    viscous law, for |v_A| ≪ ε. Integrated as one smooth right-hand side (no phases).

    Parameters
    ----------
    mu : float
        Friction coefficient (dimensionless), ≥ 0.
    eps : float
        Regularisation velocity ε (m/s), > 0.
    """

    mu: float
    eps: float

    params: ClassVar[tuple[Param, ...]] = (
        Param("mu", "1", doc="friction coefficient"),
        Param("eps", "m/s", positive=True, doc="regularisation velocity"),
    )
    analytic: ClassVar[bool] = True
    """Smooth in v_A (|v_A|² + ε² > 0): ``backend="auto"`` runs it on the Taylor backend."""

    def __post_init__(self) -> None:
        check_params(self)

    def force(self, v_A: Any, gn: Any, omega_n: Any = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """Tangential force (N, shape (2, ...)) and zero torque."""
        v = np.asarray(v_A, dtype=float)
        gn = np.asarray(gn, dtype=float)
        k = -self.mu * gn / np.sqrt(v[0] ** 2 + v[1] ** 2 + self.eps**2)
        return k * v, np.zeros(np.broadcast(gn, v[0]).shape)

    def applied(self, top: Any) -> tuple[Any, RegularisedCoulomb]:
        """The top unchanged and this law."""
        return top, self

    def model_for(self, base: str) -> str:
        """ "coulomb-regularised" for "gliding", "stemmed-coulomb-regularised" for "stemmed",
        ``base`` for any other model."""
        return _REGULARISED_MODELS.get(base, base)

    def describe(self) -> str:
        """E.g. ``"RegularisedCoulomb(mu=0.3, eps=0.001)"``."""
        return f"RegularisedCoulomb(mu={self.mu:g}, eps={self.eps:g})"


class LawForm(NamedTuple):
    """How a law is written by name (:data:`LAWS`): its constructor and its positional arguments."""

    law: type[FrictionLaw]
    """The law's class (registered with :func:`register`)."""
    args: tuple[str, ...]
    """Names of the constructor's arguments, in the order they are written."""
    units: tuple[str, ...]
    """Unit of each argument ("1": dimensionless)."""

    def build(self, *values: float) -> FrictionLaw:
        """The law with ``values`` as its arguments (``TypeError`` for a wrong count)."""
        if len(values) != len(self.args):
            raise TypeError(f"{self.law.__name__} takes {', '.join(self.args)}; got {values!r}")
        return self.law(**dict(zip(self.args, values, strict=True)))

    def spelled(self, name: str) -> str:
        """``name:ARG,ARG``, e.g. ``"coulomb-contensou:MU,CONTENSOU_RADIUS"``."""
        return f"{name}:{','.join(a.upper() for a in self.args)}"


_FORMS: dict[str, LawForm] = {}
_CLASSES: list[type[FrictionLaw]] = []

LAWS: Mapping[str, LawForm] = MappingProxyType(_FORMS)
"""Every law by name, with its arguments: the registry (:func:`register`) and the one table of the
command line's ``--friction NAME:ARGS`` (``coulomb-contensou:0.3,5e-4`` is ``Coulomb(0.3,
contensou_radius=5e-4)``). A read-only view: a law registered later appears here."""


def register(law: type, forms: Mapping[str, tuple[str, ...]]) -> type:
    """Register the friction-law class ``law`` under the names of ``forms`` and return it.

    Parameters
    ----------
    law : type
        A frozen dataclass following :class:`FrictionLaw`, with ``params`` declaring every
        constructor argument (name, unit, range).
    forms : mapping of str to tuple of str
        Each name the law is written by (``--friction NAME:ARGS``, :func:`from_args`) and the
        arguments, in order, that the name takes (the others keep their defaults).

    Raises
    ------
    ValueError
        A name already taken, an argument the law does not declare, or a class without the
        protocol's methods.
    """
    missing = [m for m in ("force", "applied", "model_for", "describe") if not hasattr(law, m)]
    declared = {par.name: par for par in getattr(law, "params", ())}
    if missing or not declared:
        raise ValueError(f"{law!r} is not a friction law: it lacks {missing or ['params']}")
    for name, args in forms.items():
        if name in _FORMS and _FORMS[name].law is not law:
            raise ValueError(f"friction law name {name!r} is taken by {_FORMS[name].law.__name__}")
        unknown = [a for a in args if a not in declared]
        if unknown:
            raise ValueError(f"{law.__name__} does not declare parameters {unknown}")
    for name, args in forms.items():
        _FORMS[name] = LawForm(law, tuple(args), tuple(declared[a].unit for a in args))
    if law not in _CLASSES:
        _CLASSES.append(law)
    return law


register(Viscous, {"viscous": ("mu",)})
register(Coulomb, {"coulomb": ("mu",), "coulomb-contensou": ("mu", "contensou_radius")})
register(RegularisedCoulomb, {"regularised": ("mu", "eps")})


def registered() -> tuple[type, ...]:
    """The registered law classes, in the order of registration."""
    return tuple(_CLASSES)


def spelling(law: type) -> str:
    """How the law is written in Python, e.g. ``"mett.friction.Coulomb(mu)"``: the arguments of its
    first name in :data:`LAWS`."""
    args = next((f.args for f in LAWS.values() if f.law is law), ())
    return f"{law.__module__}.{law.__qualname__}({', '.join(args)})"


def check_law(friction: Any) -> FrictionLaw:
    """``friction`` itself if it is a registered friction law, else ``TypeError`` naming it."""
    if not isinstance(friction, tuple(_CLASSES)):
        names = [c.__name__ for c in _CLASSES]
        raise TypeError(
            f"friction must be a registered friction law ({', '.join(names)}; "
            f"mett.friction.LAWS); got {type(friction).__name__}"
        )
    return cast(FrictionLaw, friction)


LAW_NAMES = ("viscous", "coulomb")
"""Names of the laws for :func:`from_name` (and the ``friction`` dimension of :func:`mett.sweep`):
those of :data:`LAWS` whose one coefficient is ``mu``."""


def from_args(name: str, values: Any) -> FrictionLaw:
    """The law written ``name`` in :data:`LAWS` with the positional ``values``.

    ``from_args("coulomb-contensou", (0.3, 5e-4))`` is ``Coulomb(0.3, contensou_radius=5e-4)``.
    ``ValueError`` for an unknown name, ``TypeError`` for a wrong number of values.
    """
    form = LAWS.get(name) if isinstance(name, str) else None
    if form is None:
        raise ValueError(f"friction must be one of {', '.join(LAWS)}; got {name!r}")
    return form.build(*values)


def from_name(name: str, mu: float, contensou_radius: float = 0.0, **coefficients: float) -> Any:
    """The law called ``name`` (:data:`LAWS`) with coefficient ``mu`` and the other ``coefficients``.

    ``"viscous"``: μ in s/m; ``"coulomb"``: μ dimensionless, ``contensou_radius`` (m) > 0 giving
    the Coulomb–Contensou law. For parameter sweeps, where a grid point carries the law as a name
    and its μ as the top's ``mu``. A nonzero coefficient the law does not take is a ValueError.
    """
    form = LAWS.get(name) if isinstance(name, str) else None
    if form is None:
        raise ValueError(f"friction must be one of {', '.join(LAWS)}; got {name!r}")
    given = {"contensou_radius": contensou_radius, **coefficients}
    declared = {par.name for par in form.law.params}
    for key, value in given.items():
        if key not in declared and value:
            names = [(f.law, n) for n, f in LAWS.items() if key in {q.name for q in f.law.params}]
            owners = dict(names[::-1])  # each law by its first name
            raise ValueError(
                f"{key} applies to the {' / '.join(map(repr, owners.values()))} law only"
            )
    kw = {k: v for k, v in given.items() if k in declared}
    return form.law(mu, **kw)  # type: ignore[call-arg]  # each law its constructor (its params)


def describe(friction: FrictionLaw) -> str:
    """A short label, e.g. ``"Coulomb(mu=0.3)"``, for tables and sweeps."""
    return check_law(friction).describe()
