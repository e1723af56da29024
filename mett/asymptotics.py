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
and the mean precession keeps an ω3-independent relative error c(θ0) φ̇0², because the formula is
leading order in φ̇0 too; c depends on θ0 in sign and size (thesis body: −5.6e-5 s² at θ0 = 1,
+1.0e-4 s² at θ0 = 2.2; docs/theory/high-spin.md#validity). With φ̇0 = 0, z increases: gravity pulls
the axis towards the vertical (θ decreases) because the centre of mass is below the geometric centre.

Validity. Outside its range the leading order is far off (thesis body, θ0 = 1, φ̇0 = 0: width 69 %
off at ω3 = 20 rad/s, 324× at 1 rad/s; φ̇0 = 10 % of ω3 at 1000 rad/s: precession 217 % off).
:func:`high_spin` therefore compares its result with the exact rolling values of the same start
(:mod:`mett.separation`: band, depth, period and mean precession, a few milliseconds) and emits
an :class:`AsymptoticWarning` with the relative error of each quantity when the largest exceeds
:data:`WARN_ABOVE` (10 %).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from . import _validate
from .potential import d
from .top import TippeTop

WARN_ABOVE = 0.1
_EPS = float(np.finfo(float).eps)
"""Relative error of the leading order (largest of width, depth, frequency, precession) above which
:func:`high_spin` warns."""


__all__ = ["WARN_ABOVE", "AsymptoticWarning", "HighSpin", "high_spin"]


class AsymptoticWarning(_validate.AccuracyWarning):
    """The leading-order high-spin values are used outside their validity: the message gives their
    relative errors against the exact rolling values (:func:`high_spin`)."""


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


def high_spin(
    top: TippeTop, theta0: float, omega3: float, phidot0: float = 0.0, *, check: bool = True
) -> HighSpin:
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
    check : bool, default True
        Compare the result with the exact rolling values of the same start (mett.separation) and
        warn (:class:`AsymptoticWarning`, with the relative error of each quantity) if the largest
        relative error exceeds :data:`WARN_ABOVE`. ``False`` skips the comparison.

    Warns
    -----
    AsymptoticWarning
        If the leading order is more than 10 % off (low spin, or φ̇0 not small compared with
        ω3); also if the exact values cannot be computed for this start.

    Raises
    ------
    ValueError
        If θ0 is a pole or outside [0, π], ω3 = 0, an input is not finite, or |ω3| is so small
        (or φ̇0 so large) that the expansion leaves double precision.
    """
    _validate.instance("top", top, TippeTop)
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
            "expansion outside double precision: it holds for |omega3| large, to about 10 % above "
            f"3 sqrt(m g R alpha / I3) = {3.0 * math.sqrt(mgRa / I3):.3g} rad/s"
        )
    out = HighSpin(*(float(v) for v in result))
    if check:
        _check(top, th, float(w3), phidot0, out)
    return out


def _check(top: TippeTop, theta0: float, omega3: float, phidot0: float, hs: HighSpin) -> None:
    """Warn if ``hs`` is more than :data:`WARN_ABOVE` off the exact rolling values of the start."""
    from . import integrals
    from .separation import _api, _wells
    from .state import State

    s = State(theta=theta0, omega3=omega3, phidot=phidot0)
    E, D, lam = (float(f(top, s)) for f in (integrals.energy, integrals.routh, integrals.jellett))
    z0 = math.cos(theta0)
    # what mett.band, nutation_period and mean_precession return, in two passes (numpy's
    # overflow at extreme spins gives non-finite values, left out below, not RuntimeWarnings)
    try:
        with np.errstate(all="ignore"):
            per = _api.solve(top, E, D, lam, z0, "period")
            _api.raise_first(per)
            pre = _api.solve(top, E, D, lam, z0, "precession")
            _api.raise_first(pre)
    except ValueError as exc:
        _validate.warn(
            f"high_spin(theta0={theta0!r}, omega3={omega3!r}, phidot0={phidot0!r}): the "
            f"leading order could not be checked against the exact rolling values ({exc})",
            AsymptoticWarning,
        )
        return
    # the band runs from z0 to its other end: the signed width is that end minus z0
    z_low, z_high = float(per.z_low[0]), float(per.z_high[0])
    far = z_high if z_high - z0 >= z0 - z_low else z_low
    exact = {
        "width": far - z0,
        "depth": float(per.depth[0]),
        "frequency": 2.0 * math.pi / float(per.value[0]),
        "precession": float(pre.value[0]),
    }
    # a band a few ulps of z wide (next to a pole, or at very high spin) or a depth within the
    # rounding of the energy terms has no exact value in double to compare with: left out
    if z_high - z_low <= 2.0**22 * math.ulp(max(abs(z_low), abs(z_high))):
        del exact["width"]
    if _wells.conditioning(top, E, D, lam, exact["depth"]) > 1e-6:
        del exact["depth"]
    # ⟨φ̇⟩ ~ m g R α/(I3 ω3) is a remainder of N, whose terms are ~ω3: rounding ~ε|ω3|/(1 − z0²)
    if abs(exact["precession"]) * math.sin(theta0) ** 2 <= 2.0**20 * _EPS * abs(omega3):
        del exact["precession"]
    exact = {k: v for k, v in exact.items() if math.isfinite(v)}
    errors = {k: _relative_error(getattr(hs, k), v) for k, v in exact.items()}
    worst = max(errors.values(), default=0.0)
    if worst > WARN_ABOVE:
        detail = ", ".join(f"{k} {v:.2g}" for k, v in errors.items())
        _validate.warn(
            f"high_spin(theta0={theta0!r}, omega3={omega3!r}, phidot0={phidot0!r}) is outside "
            f"the validity of the leading order: relative errors against the exact rolling "
            f"values {detail} (above {WARN_ABOVE:g}); use mett.band, mett.nutation_period and "
            "mett.mean_precession for the exact values",
            AsymptoticWarning,
        )


def _relative_error(approx: float, exact: float) -> float:
    if exact == 0.0:
        return 0.0 if approx == 0.0 else math.inf
    return abs(approx / exact - 1.0)
