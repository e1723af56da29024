"""Geometry of a tippe top with a stem, and the METT analysis of the phase spent on the stem.

A real tippe top is a ball with a stem. Model the stem's end as a second sphere (Leine & Glocker
2003 use two spheres): radius r_s, centre S on the symmetry axis at distance l_s from the ball's
centre O, on the side away from the centre of mass G. With mett's conventions (3̂ points from G
towards O, θ is the angle between 3̂ and the vertical ẑ, θ = 0 is the top resting on its ball with
the stem up):

    O − G = αR 3̂,    S − O = l_s 3̂,    S − G = (αR + l_s) 3̂.

While the ball touches the plane O is at height R, so S is at R + l_s cos θ and the stem touches
down when

    R + l_s cos θ = r_s,    θ_touch = arccos((r_s − R)/l_s).

For θ < θ_touch the ball is the lower sphere, for θ > θ_touch the stem. On the stem the body is
again an eccentric sphere — radius r_s, centre S, CM at distance αR + l_s from it on the axis — so
the whole gliding/METT layer applies to the *equivalent top* :attr:`StemmedTop.stem_top` with

    R' = r_s,    α' = (αR + l_s)/r_s    (usually > 1: G lies outside the small stem sphere),

the same m, I1, I3, μ, g and the same θ. Its Jellett integral λ_s = −L·a_s, a_s = (αR + l_s)3̂ − r_s ẑ,
is conserved on the stem (contact forces without a torque about the normal) and gives thresholds
and end state on the stem; a predicted stem state with θ < θ_touch is not realisable (the ball
would touch first).

Simulating through the change of contact is the job of the simulator, not of this module.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from . import _validate
from .classification import AsymptoticState, asymptotic_state
from .integrals import jellett
from .top import FIELD_RANGE, FIELD_UNITS, TippeTop, register_stemmed

if TYPE_CHECKING:
    from .state import State

__all__ = ["StemContactTop", "StemmedTop"]


@dataclass(frozen=True)
class StemContactTop(TippeTop):
    """The eccentric sphere a stemmed top rests on during the stem phase.

    A :class:`~mett.TippeTop` whose ``R`` is the stem radius and ``alpha`` the CM offset in units
    of it; unlike a ball, ``alpha`` may exceed 1 (the CM lies outside the stem sphere), and no
    PhysicalityWarning is raised for I3 > m R² (the body is the whole top, not a ball of radius R).
    The equations of motion, integrals, thresholds and classes of mett do not assume α < 1.

    The fields obey the bounds of :class:`~mett.TippeTop` (``FIELD_RANGE`` = [1e-50, 1e50] for m,
    R, I1, I3, g; μ in [0, 1e50]); α > 0, unbounded above by geometry, must keep α and the CM's
    distance αR from the sphere's centre at most 1e50, so that the products of the formulas
    (m g R³ I3 α in λ_thres, (1 + α)², …) stay finite as they do for a ball.
    """

    def __post_init__(self) -> None:
        lo, hi = FIELD_RANGE
        for name in ("m", "R", "I1", "I3", "g"):
            value = _validate.bounded_scalar(
                name, getattr(self, name), lo, hi, unit=FIELD_UNITS[name]
            )
            object.__setattr__(self, name, value)
        # α > 0 as for a ball; α and αR at most FIELD_RANGE's top
        a_hi = min(hi, hi / self.R)
        alpha = _validate.finite_scalar("alpha", self.alpha)
        if not 0.0 < alpha <= a_hi:
            raise ValueError(
                f"alpha must lie in (0, {a_hi:g}] (alpha and alpha*R = {self.R:g} alpha m at most "
                f"{hi:g}); got {alpha!r}"
            )
        object.__setattr__(self, "alpha", alpha)
        mu = _validate.bounded_scalar("mu", self.mu, 0.0, hi, unit="s/m")
        object.__setattr__(self, "mu", mu)
        if self.I3 > 2.0 * self.I1:
            raise ValueError(
                f"I3 must lie in (0, 2*I1] = (0, {2.0 * self.I1!r}] for a rigid body; got {self.I3!r}"
            )


@register_stemmed
@dataclass(frozen=True)
class StemmedTop:
    """A tippe top (the ball) with a spherical stem end.

    Parameters
    ----------
    ball : TippeTop
        The top resting on its ball.
    radius : float
        Stem sphere radius r_s (m), in ``FIELD_RANGE`` = [1e-50, 1e50] as the ball's R.
    distance : float
        Distance l_s (m) from the ball's centre to the stem sphere's centre, along the symmetry axis
        away from the CM, in [1e-50, 1e50]. The stem must stick out of the ball without containing
        it: |R − r_s| < l_s; and the top on its stem (:attr:`stem_top`) must be one mett can
        compute with: α' = (αR + l_s)/r_s and α'r_s = αR + l_s at most 1e50.

    Examples
    --------
    >>> import mett
    >>> top = mett.presets.get("rutstam2013").with_stem(radius=0.005, distance=0.02)
    >>> round(top.touchdown_angle, 6)   # arccos((0.005 − 0.02)/0.02)
    2.418858
    """

    ball: TippeTop
    radius: float
    distance: float

    def __post_init__(self) -> None:
        if not isinstance(self.ball, TippeTop):
            raise TypeError(f"ball must be a TippeTop; got {type(self.ball).__name__}")
        lo, hi = FIELD_RANGE
        r = _validate.bounded_scalar("radius", self.radius, lo, hi, unit="m")
        ls = _validate.bounded_scalar("distance", self.distance, lo, hi, unit="m")
        R = self.ball.R
        if not abs(R - r) < ls:
            raise ValueError(
                f"distance must exceed |R - radius| = {abs(R - r)!r} m, or the stem sphere lies inside "
                f"the ball (or contains it) and never touches the plane first; got {ls!r}"
            )
        offset = self.ball.alpha * R + ls  # the CM's distance from the stem sphere's centre
        if not (offset <= hi and offset / r <= hi):
            raise ValueError(
                f"radius and distance must keep the top on its stem within mett's range: "
                f"alpha*R + distance = {offset:g} m and (alpha*R + distance)/radius = "
                f"{offset / r:g} at most {hi:g}; got radius = {r!r}, distance = {ls!r}"
            )
        object.__setattr__(self, "radius", r)
        object.__setattr__(self, "distance", ls)

    @property
    def touchdown_angle(self) -> float:
        """θ (rad) at which the stem touches the plane while the ball does: arccos((r_s − R)/l_s)."""
        return math.acos((self.radius - self.ball.R) / self.distance)

    def stem_clearance(self, theta: ArrayLike) -> np.ndarray:
        """Height (m) of the stem sphere's lowest point while the ball touches: R + l_s cos θ − r_s.

        Negative where the stem would be below the plane, i.e. θ > θ_touch, where the stem is the
        contact and the ball is lifted by the same amount.
        """
        th = _validate.theta(theta)
        return self.ball.R + self.distance * np.cos(th) - self.radius

    def contact(self, theta: ArrayLike) -> np.ndarray | str:
        """Which sphere is the lower one at inclination θ: "ball" for θ <= θ_touch, else "stem"."""
        th = _validate.theta(theta)
        out = np.where(self.stem_clearance(th) >= 0.0, "ball", "stem")
        return out if out.ndim else str(out)

    @property
    def stem_top(self) -> StemContactTop:
        """The equivalent eccentric sphere of the stem phase: R' = r_s, α' = (αR + l_s)/r_s."""
        b = self.ball
        return StemContactTop(
            m=b.m,
            R=self.radius,
            alpha=(b.alpha * b.R + self.distance) / self.radius,
            I1=b.I1,
            I3=b.I3,
            mu=b.mu,
            g=b.g,
        )

    def stem_jellett(self, state: State) -> np.ndarray:
        """Jellett integral of the stem contact, λ_s = r_s L·ẑ − (αR + l_s) I3 ω3 (kg m² s⁻¹).

        λ_s = −L·a_s with a_s = (αR + l_s)3̂ − r_s ẑ the vector from the CM to the stem's contact
        point; it depends on θ, φ̇, ω3 only, so it is :func:`mett.jellett` of :attr:`stem_top`.
        """
        return jellett(self.stem_top, state)

    def stem_end_state(self, lam: float) -> AsymptoticState:
        """End state on the stem for the stem Jellett integral ``lam`` (:func:`mett.asymptotic_state`
        of :attr:`stem_top`). Candidates with θ < :attr:`touchdown_angle` are not realisable on the
        stem: there the ball touches the plane again.
        """
        return asymptotic_state(self.stem_top, lam)
