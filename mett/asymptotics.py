"""High-ω3 asymptotics of the rolling ball (topic of Rutstam 2013, RCD; formulas of docs/theory/high-spin.md#high-spin).

Setting: the rolling top (ν ≡ 0) started at θ(0) = θ0 with θ̇(0) = 0, φ̇(0) = φ̇0 and a large spin
ω3. With z0 = cos θ0, d0 = d(z0), K0 = 1 + σ(1 − α z0), G0 = γ + σ(1 + α² − 2α z0) = 2 g(z0)/I3 and
the effective force F0 = m g R α + I3 K0 φ̇0 ω3, to leading order in 1/ω3

* band width (in z):  Δ = 2 d0 (1 − z0²) F0 / (I3 K0² ω3²)   (z moves from z0 to z0 + Δ),
* depth of the well:  Ẽ − V_min = F0² d0 (1 − z0²) / (2 I3 K0² ω3²),
* nutation angular frequency (rad/s): ω_n = |ω3| K0 / √(d0 G0), period 2π/ω_n,
* mean precession:    ⟨φ̇⟩ = −m g R α / (I3 K0 ω3)   (independent of φ̇0).

Accuracy, measured against direct rolling integrations (tests/test_asymptotics.py): with φ̇0 = 0
every relative error falls like ω3⁻²; with φ̇0 ≠ 0 the width and frequency errors fall like ω3⁻¹
and the mean precession keeps an ω3-independent relative error ∝ φ̇0² (about −5.6e-5 s² · φ̇0² for
the thesis body at θ0 = 1), because the formula is leading order in φ̇0 too. With φ̇0 = 0, z increases: gravity pulls the axis towards the vertical
(θ decreases) because the centre of mass is below the geometric centre.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from . import _validate
from .potential import d

if TYPE_CHECKING:
    from .top import TippeTop

__all__ = ["HighSpin", "high_spin"]


class HighSpin(NamedTuple):
    """Leading-order high-spin characteristics of the rolling top's nutation (docs/theory/high-spin.md#high-spin)."""

    width: float
    """Band width Δ in z = cos θ (signed: z runs between z0 and z0 + Δ)."""
    depth: float
    """Depth of the potential well below the energy, Ẽ − min V (J)."""
    frequency: float
    """Nutation angular frequency ω_n (rad/s); the period is 2π/ω_n."""
    precession: float
    """Mean precession rate ⟨φ̇⟩ (rad/s)."""

    @property
    def period(self) -> float:
        """Nutation period 2π/ω_n (s)."""
        return 2.0 * math.pi / self.frequency


def high_spin(top: TippeTop, theta0: float, omega3: float, phidot0: float = 0.0) -> HighSpin:
    """Leading-order high-ω3 band width, well depth, nutation frequency and precession (docs/theory/high-spin.md#high-spin).

    Parameters
    ----------
    top : TippeTop
    theta0 : float
        Initial inclination θ0 in (0, π) (a turning point of the nutation).
    omega3 : float
        Spin (rad/s), nonzero; the formulas are asymptotic in 1/|ω3|.
    phidot0 : float, default 0
        Initial precession rate, assumed small compared with ω3.

    Raises
    ------
    ValueError
        If θ0 is a pole or outside [0, π], ω3 = 0, an input is not finite, or |ω3| is so small
        (or φ̇0 so large) that the expansion leaves double precision.
    """
    _validate.instance("top", top, "TippeTop")
    th = float(_validate.theta(theta0, "theta0"))
    if th in (0.0, math.pi):
        raise ValueError(f"theta0 must lie in the open interval (0, pi); got {th!r}")
    w3 = _validate.finite_scalar("omega3", omega3)
    if w3 == 0.0:
        raise ValueError("omega3 must be nonzero (the expansion is in 1/omega3); got 0.0")
    phidot0 = _validate.finite_scalar("phidot0", phidot0)
    z0 = math.cos(th)
    d0 = float(d(top, z0))
    sig, a, I3 = top.sigma, top.alpha, top.I3
    K0 = 1.0 + sig * (1.0 - a * z0)
    G0 = top.gamma + sig * (1.0 + a * a - 2.0 * a * z0)
    mgRa = top.m * top.g * top.R * a
    force = mgRa + I3 * K0 * phidot0 * w3
    s2 = 1.0 - z0 * z0
    # numpy float64: overflow and underflow become inf/0 instead of OverflowError/ZeroDivisionError
    w3, force = np.float64(w3), np.float64(force)
    with np.errstate(all="ignore"):
        result = HighSpin(
            width=2.0 * d0 * s2 * force / (I3 * K0**2 * w3**2),
            depth=force**2 * d0 * s2 / (2.0 * I3 * K0**2 * w3**2),
            frequency=abs(w3) * K0 / math.sqrt(d0 * G0),
            precession=-mgRa / (I3 * K0 * w3),
        )
    if not all(math.isfinite(v) for v in result):
        raise ValueError(
            f"omega3 = {float(w3)!r} rad/s (with phidot0 = {phidot0!r}) puts the high-spin "
            "expansion outside double precision: it holds for |omega3| large, e.g. above "
            f"sqrt(m g R alpha / I3) = {math.sqrt(mgRa / I3):.3g} rad/s"
        )
    return HighSpin(*(float(v) for v in result))
