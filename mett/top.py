"""The tippe top's parameters: an eccentric sphere rolling and gliding on a plane.

Model and notation of Rutstam (2012, SIGMA 8, 019, §2) and the thesis (Rutstam 2013): a sphere of
radius ``R`` whose centre of mass lies ``alpha * R`` below the geometric centre on the symmetry axis,
principal moments ``I1 = I2`` and ``I3`` about the centre of mass, viscous-type gliding friction
``F = g_n z - mu g_n v_A`` (``mu`` in s/m). See docs/theory/model.md#conventions.
"""

from __future__ import annotations

import copy
import dataclasses
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

from . import _formulas, _validate

if TYPE_CHECKING:
    from .stem import StemmedTop

__all__ = ["TippeTop"]

# Relative tolerance of the rational condition sigma = (1-gamma)/(gamma+alpha^2-1): inertias typed
# as decimals (e.g. 131/350 m R^2 rounded) should still count as rational.
_RATIONAL_RTOL = 1e-9

FIELD_RANGE = (1e-50, 1e50)
"""Valid magnitudes of m, R, I1, I3, g (μ: [0, 1e50]), in their SI units: wide enough for any
unit system, narrow enough that every product of a few of them (m g R, m R², λ², …) stays finite."""

FIELD_UNITS = {"m": "kg", "R": "m", "I1": "kg m^2", "I3": "kg m^2", "g": "m/s^2"}

# The class TippeTop.with_stem builds. mett.stem builds on this floor (its stem-contact top is a
# TippeTop), so this floor cannot import it: mett.stem registers its StemmedTop here when it is
# imported, which `import mett` always does (as the dynamics models register in their registry).
_STEMMED: list[type[StemmedTop]] = []


def register_stemmed(cls: type[StemmedTop]) -> type[StemmedTop]:
    """Class decorator: make ``cls`` the class :meth:`TippeTop.with_stem` returns (used once, by
    :class:`mett.stem.StemmedTop`)."""
    _STEMMED[:] = [cls]
    return cls


@dataclass(frozen=True)
class TippeTop:
    """Parameters of a tippe top, in SI units.

    Parameters
    ----------
    m : float
        Mass (kg). Like R, I1, I3 and g it must lie in ``FIELD_RANGE`` = [1e-50, 1e50].
    R : float
        Radius of the spherical part (m), > 0.
    alpha : float
        Eccentricity: the centre of mass sits ``alpha * R`` from the geometric centre, 0 < alpha < 1.
    I1 : float
        Moment of inertia about a horizontal principal axis through the centre of mass (kg m²).
    I3 : float
        Moment of inertia about the symmetry axis (kg m²); ``0 < I3 <= 2 I1`` (triangle inequality).
    mu : float, default 0.3
        Coefficient of the viscous-type friction law ``F_f = -mu g_n v_A`` (s/m), in
        [0, 1e50].
    g : float, default 9.82
        Gravitational acceleration (m/s²), > 0.

    Raises
    ------
    TypeError
        A field that is not a real number (a string, a boolean, None).
    ValueError
        A field outside its range.

    Warns
    -----
    PhysicalityWarning
        I3 > m R², or I1 > (4 − α²) m R² − I3/2 (no body within 2R of the sphere's centre has
        that much inertia): legal, but not a top shaped like the model.

    Notes
    -----
    Derived dimensionless parameters (docs/theory/model.md#conventions): ``gamma = I1/I3`` and ``sigma = m R²/I3``.

    Examples
    --------
    >>> top = TippeTop(m=0.02, R=0.02, alpha=0.3, I1=131/350 * 0.02 * 0.02**2,
    ...                I3=0.4 * 0.02 * 0.02**2)
    >>> round(top.gamma, 6), top.group, top.is_rational
    (0.935714, 'II', True)
    """

    m: float
    R: float
    alpha: float
    I1: float
    I3: float
    mu: float = 0.3
    g: float = 9.82

    def __post_init__(self) -> None:
        for name in ("m", "R", "I1", "I3", "g"):
            value = _validate.bounded_scalar(
                name, getattr(self, name), *FIELD_RANGE, unit=FIELD_UNITS[name]
            )
            object.__setattr__(self, name, value)
        alpha = _validate.finite_scalar("alpha", self.alpha)
        if not 0.0 < alpha < 1.0:
            raise ValueError(f"alpha must lie in (0, 1); got {alpha!r}")
        object.__setattr__(self, "alpha", alpha)
        mu = _validate.bounded_scalar("mu", self.mu, 0.0, FIELD_RANGE[1], unit="s/m")
        object.__setattr__(self, "mu", mu)
        if self.I3 > 2.0 * self.I1:
            raise ValueError(
                f"I3 must lie in (0, 2*I1] = (0, {2.0 * self.I1!r}] for a rigid body; got {self.I3!r}"
            )
        mR2 = self.m * self.R * self.R  # no overflow: each factor is within FIELD_RANGE
        # Second moments about the CM: 2 I1 + I3 = 2 ∫|r|² dm = 2 (∫|r_c|² dm − m α² R²), r_c from
        # the geometric centre. A body inside the sphere (|r_c| <= R) has I3 <= m R²; with a peg
        # reaching at most 2R from the centre, 2 I1 + I3 <= 2 (4 − α²) m R².
        if self.I3 > mR2:
            _validate.warn(
                f"I3 = {self.I3:g} kg m^2 exceeds m R^2 = {mR2:g} kg m^2: no axisymmetric body "
                "inside the sphere of radius R has that much spin inertia",
                _validate.PhysicalityWarning,
            )
        i1_max = (4.0 - alpha * alpha) * mR2 - 0.5 * self.I3
        if self.I1 > i1_max:
            _validate.warn(
                f"I1 = {self.I1:g} kg m^2 exceeds (4 - alpha^2) m R^2 - I3/2 = {i1_max:g} kg m^2: "
                "no body within 2R of the sphere's centre (the sphere and a peg no longer than R) "
                "has that much inertia about a horizontal axis",
                _validate.PhysicalityWarning,
            )

    # --- derived dimensionless parameters -------------------------------------------------
    @property
    def gamma(self) -> float:
        """γ = I1/I3."""
        return self.I1 / self.I3

    @property
    def sigma(self) -> float:
        """σ = m R²/I3."""
        return self.m * self.R**2 / self.I3

    @property
    def is_admissible(self) -> bool:
        """True if 1 − α < γ < 1 + α: the tumbling family spans [0, π], so the top can invert."""
        return 1.0 - self.alpha < self.gamma < 1.0 + self.alpha

    @property
    def is_rational(self) -> bool:
        """True if σ = (1 − γ)/(γ + α² − 1), so that √d(z) is linear and V rational in z (docs/theory/mett.md#rational)."""
        gam, a = self.gamma, self.alpha
        if not 1.0 - a * a < gam < 1.0:
            return False
        return math.isclose(self.sigma, (1.0 - gam) / (gam + a * a - 1.0), rel_tol=_RATIONAL_RTOL)

    @property
    def group(self) -> str:
        """Ueda–Sasaki–Watanabe group: "I" (γ ≤ 1 − α, never flips), "II" (inverts), "III" (γ ≥ 1 + α)."""
        if self.gamma <= 1.0 - self.alpha:
            return "I"
        if self.gamma >= 1.0 + self.alpha:
            return "III"
        return "II"

    @property
    def subgroup(self) -> str:
        """Class by the stability of the steady states: Ia, Ib, IIa, IIb, IIc or III
        (:func:`mett.classification.subgroup`; Ciocci & Langerock 2007)."""
        return _formulas.subgroup(self)

    @property
    def lambda_thres(self) -> float:
        """Jellett threshold above which the inverted spin is asymptotically stable (docs/theory/thresholds.md#thresholds)."""
        return _formulas.lambda_thres(self)

    @property
    def lambda_0(self) -> float:
        """Jellett value above which the non-inverted spin is unstable (docs/theory/thresholds.md#thresholds)."""
        return _formulas.lambda_0(self)

    @property
    def beta(self) -> float:
        """β = √(σ/(1 − γ)) of the rational METT, √d(z) = β(α − (1 − γ)z); only for rational tops."""
        if not self.is_rational:
            raise ValueError(
                "beta is defined only for a rational top: sigma must equal "
                f"(1-gamma)/(gamma+alpha^2-1) = {self._sigma_rational():g}; got sigma = {self.sigma:g}"
            )
        return math.sqrt(self.sigma / (1.0 - self.gamma))

    def _sigma_rational(self) -> float:
        gam, a = self.gamma, self.alpha
        den = gam + a * a - 1.0
        return (1.0 - gam) / den if den != 0 else math.inf

    def with_stem(self, radius: float, distance: float) -> StemmedTop:
        """This top with a stem: a sphere of radius ``radius`` (m) whose centre lies on the symmetry
        axis ``distance`` (m) from the ball's centre, on the side away from the centre of mass.

        See :class:`mett.stem.StemmedTop` (touchdown angle, the equivalent top on the stem).
        """
        return _STEMMED[0](self, radius, distance)

    # --- constructors -------------------------------------------------------------------
    def replace(self, **fields: float) -> TippeTop:
        """Return a copy with some fields changed (validated again)."""
        unknown = set(fields) - {f.name for f in dataclasses.fields(self)}
        if unknown:
            known = ", ".join(f.name for f in dataclasses.fields(self))
            raise ValueError(f"unknown TippeTop field(s) {sorted(unknown)}; known fields: {known}")
        return dataclasses.replace(self, **fields)

    def _with_mu(self, mu: float) -> TippeTop:
        """:meth:`replace` for ``mu`` (s/m) alone: only ``mu`` is validated again; the other
        fields were checked (and warned about) when this top was built, so they are copied as
        they are. The same top as ``replace(mu=mu)``, at a fraction of the cost
        (:func:`mett.predict_inversion` linearises the law at its own coefficient each call)."""
        mu = _validate.bounded_scalar("mu", mu, 0.0, FIELD_RANGE[1], unit="s/m")
        new = copy.copy(self)
        object.__setattr__(new, "mu", mu)
        return new

    @classmethod
    def rational(
        cls, m: float, R: float, alpha: float, I3: float, mu: float = 0.3, g: float = 9.82
    ) -> TippeTop:
        """A top whose I1 makes V rational: γ = 1 − σα²/(1 + σ), σ = m R²/I3 (docs/theory/mett.md#rational).

        Raises
        ------
        ValueError
            If the resulting I1 violates I3 <= 2 I1 (γ < 1/2), or any input is nonphysical.
        """
        m = _validate.bounded_scalar("m", m, *FIELD_RANGE, unit="kg")
        R = _validate.bounded_scalar("R", R, *FIELD_RANGE, unit="m")
        I3 = _validate.bounded_scalar("I3", I3, *FIELD_RANGE, unit="kg m^2")
        alpha = _validate.finite_scalar("alpha", alpha)
        if not 0.0 < alpha < 1.0:
            raise ValueError(f"alpha must lie in (0, 1); got {alpha!r}")
        sigma = m * R**2 / I3
        gamma = 1.0 - sigma * alpha**2 / (1.0 + sigma)
        if gamma < 0.5:
            raise ValueError(
                f"no rational top with I3 <= 2*I1 for alpha = {alpha!r}, sigma = m R^2/I3 = {sigma:g}: "
                f"gamma = 1 - sigma*alpha^2/(1+sigma) = {gamma:g} must lie in [0.5, 1); "
                "lower alpha or raise I3"
            )
        return cls(m=m, R=R, alpha=alpha, I1=gamma * I3, I3=I3, mu=mu, g=g)
