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

from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any, NamedTuple

import numpy as np

from . import _validate

__all__ = [
    "CONTENSOU_UNIFORM",
    "LAWS",
    "LAW_NAMES",
    "Coulomb",
    "FrictionLaw",
    "LawForm",
    "RegularisedCoulomb",
    "Viscous",
    "check_law",
    "describe",
    "from_name",
]

CONTENSOU_UNIFORM = 2.0 / 3.0
"""r*/r of a uniform-pressure contact disc: pure spin gives |M| = (2/3) μ g_n r (Leine & Glocker
2003)."""


def _mu(value: Any, name: str = "mu") -> float:
    return _validate.positive_scalar(name, value, allow_zero=True)


@dataclass(frozen=True)
class Viscous:
    """Viscous-type gliding friction F_t = −μ g_n v_A (Rutstam 2013, thesis eq. (3)).

    Parameters
    ----------
    mu : float, optional
        Coefficient (s/m), ≥ 0. ``None`` (the default) takes ``top.mu`` at simulation time.
    """

    mu: float | None = None

    def __post_init__(self) -> None:
        if self.mu is not None:
            object.__setattr__(self, "mu", _mu(self.mu))

    def force(self, v_A: Any, gn: Any, omega_n: Any = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """Tangential force (N, shape (2, ...)) and torque about ẑ (N m, zero) of slip ``v_A``."""
        if self.mu is None:
            raise ValueError("Viscous(mu=None) takes mu from the top; give mu to evaluate force")
        v = np.asarray(v_A, dtype=float)
        gn = np.asarray(gn, dtype=float)
        return -self.mu * gn * v, np.zeros(np.broadcast(gn, v[0]).shape)


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
        effective radius r* = (2/3) r of a uniform-pressure disc (module docstring).
    """

    mu: float
    contensou_radius: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "mu", _mu(self.mu))
        r = _validate.positive_scalar("contensou_radius", self.contensou_radius, allow_zero=True)
        object.__setattr__(self, "contensou_radius", r)

    @property
    def r_star(self) -> float:
        """Effective Contensou radius r* = (2/3) r (m)."""
        return CONTENSOU_UNIFORM * self.contensou_radius

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

    def __post_init__(self) -> None:
        object.__setattr__(self, "mu", _mu(self.mu))
        object.__setattr__(self, "eps", _validate.positive_scalar("eps", self.eps))

    def force(self, v_A: Any, gn: Any, omega_n: Any = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """Tangential force (N, shape (2, ...)) and zero torque."""
        v = np.asarray(v_A, dtype=float)
        gn = np.asarray(gn, dtype=float)
        k = -self.mu * gn / np.sqrt(v[0] ** 2 + v[1] ** 2 + self.eps**2)
        return k * v, np.zeros(np.broadcast(gn, v[0]).shape)


FrictionLaw = Viscous | Coulomb | RegularisedCoulomb
"""Any friction law :func:`mett.simulate` accepts."""


def check_law(friction: Any) -> FrictionLaw:
    """``friction`` itself if it is a friction law, else ``TypeError`` naming the argument."""
    if not isinstance(friction, Viscous | Coulomb | RegularisedCoulomb):
        raise TypeError(
            "friction must be mett.friction.Viscous, Coulomb or RegularisedCoulomb; "
            f"got {type(friction).__name__}"
        )
    return friction


LAW_NAMES = ("viscous", "coulomb")
"""Names of the laws for :func:`from_name` (and the ``friction`` dimension of :func:`mett.sweep`)."""


def from_name(name: str, mu: float, contensou_radius: float = 0.0) -> FrictionLaw:
    """The law called ``name`` with coefficient ``mu``: ``"viscous"`` (s/m) or ``"coulomb"`` (–).

    ``contensou_radius`` (m) applies to ``"coulomb"`` only. For parameter sweeps, where a grid
    point carries the law as a name and its μ as the top's ``mu``.
    """
    if name == "viscous":
        if contensou_radius:
            raise ValueError("contensou_radius applies to the 'coulomb' law only")
        return Viscous(mu)
    if name == "coulomb":
        return Coulomb(mu, contensou_radius=contensou_radius)
    raise ValueError(f"friction must be one of {', '.join(LAW_NAMES)}; got {name!r}")


class LawForm(NamedTuple):
    """How a law is written by name (:data:`LAWS`): its constructor and its positional arguments."""

    law: type
    """The law's class (a constructor of :mod:`mett.friction`)."""
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


LAWS: Mapping[str, LawForm] = MappingProxyType(
    {
        "viscous": LawForm(Viscous, ("mu",), ("s/m",)),
        "coulomb": LawForm(Coulomb, ("mu",), ("1",)),
        "coulomb-contensou": LawForm(Coulomb, ("mu", "contensou_radius"), ("1", "m")),
        "regularised": LawForm(RegularisedCoulomb, ("mu", "eps"), ("1", "m/s")),
    }
)
"""Every law by name, with its arguments: the one table of the command line's ``--friction
NAME:ARGS`` (``coulomb-contensou:0.3,5e-4`` is ``Coulomb(0.3, contensou_radius=5e-4)``). A law
added to this module is added here, and the command line accepts it by this name."""


def describe(friction: FrictionLaw) -> str:
    """A short label, e.g. ``"Coulomb(mu=0.3)"``, for tables and sweeps."""
    if isinstance(friction, Viscous):
        return "viscous" if friction.mu is None else f"Viscous(mu={friction.mu:g})"
    if isinstance(friction, Coulomb):
        extra = (
            f", contensou_radius={friction.contensou_radius:g}" if friction.contensou_radius else ""
        )
        return f"Coulomb(mu={friction.mu:g}{extra})"
    return f"RegularisedCoulomb(mu={friction.mu:g}, eps={friction.eps:g})"
