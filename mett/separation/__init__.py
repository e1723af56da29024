"""The separation equation of the METT: ż² = f(z), turning points, exact nutation periods.

With z = cos θ and ż = −sin θ θ̇, the METT Ẽ = g(z) θ̇² + V(z, D, λ) becomes (docs/theory/mett.md)

    ż² = f(z) = (1 − z²)(Ẽ − V(z, D, λ)) / g(z) = P(z) / g(z),
    P(z) = (1 − z²)(E' − m g R(1 − αz)) − C N(z)²,   C = I3/(2 I1² R²),
    E' = Ẽ − D²/(2 I1) + m λ²/(2 I1 I3).

P is regular on [−1, 1] (no pole), so all work is done with P. For a rolling top (Ẽ = E, D and λ
constant) z oscillates between the two roots z_a < z_b of P that bracket the well of V, with period

    T = 2 ∫_{z_a}^{z_b} √g(z) / √P(z) dz
      = 2 ∫_{−π/2}^{π/2} h cos u √(g(z)/P(z)) du,   z = c + h sin u,

where c, h are the centre and half-width of the band; the substitution removes the inverse square
root singularities at the turning points, and Gauss–Legendre quadrature in u converges exponentially.

Precision. At high spin the band is narrow (width ~ ω3⁻²) and Ẽ − V is a tiny difference of numbers
of size ½ I3 ω3²: in double precision it keeps few digits. The constant D²/(2 I1) − mλ²/(2 I1 I3) that
carries that size is therefore subtracted from Ẽ exactly (error-free products and sums in double,
:func:`_shift`) before anything else is done; what remains, E' − m g R(1 − αz) and C N², are of the size of the well itself. Inside a band
P is then written about the bottom z_r of the well (``_Wells.set_reference``, also at a spinning
pole), and the turning points and quadrature nodes are handled as offsets δ = z − z_r: the node next
to a turning point lies only ~1e-7 band widths from it, closer than one ulp of z at high spin.

Vectorisation. The public functions work on whole arrays of (Ẽ, D, λ) at once (:class:`_Wells`):
the wells are located on one grid for all elements, and every root (minimum of V, turning point,
offset turning point) is refined by :func:`_brentq`, a vectorised transcription of scipy's
``brentq``. There is one implementation of each step: the per-element path (:func:`_band_scalar`,
the ``_reference_*`` functions) runs the same array code on one element as a length-1 array, so an
element gets bit for bit the same numbers on its own as in an array. Only what is genuinely per
element is written for one element: the classification of several wells, a well hugging a pole
and its band (:func:`_pole_band`), and the graded quadrature about a pole
(:func:`_anchored_quadrature`); the array path passes such elements on to it.

Layout: :mod:`._exact` (the exact energy shift), :mod:`._wells` (P, wells, classification, the pole
form), :mod:`._roots` (vectorised root finding, turning points), :mod:`._quadrature` (periods and
means), :mod:`._api` (the public functions and the per-element reference path).
"""

# The private names below are re-exported for the benchmarks and the tests.
# ruff: noqa: F401

from ._api import (
    _band_scalar,
    _reference_band,
    _reference_f,
    _reference_mean_precession,
    _reference_nutation_period,
    _reference_turning_points,
    _start_energy,
    band,
    band_average,
    classify_motion,
    f,
    mean_precession,
    minima,
    nutation_period,
    solve,
    turning_points,
)
from ._exact import _EPS, _shift, _shifted_energy
from ._quadrature import _anchored_quadrature, _quadrature
from ._roots import _brentq
from ._wells import (
    _NEAR_POLE,
    Band,
    _locate_wells,
    _pole_layer,
    _pole_N,
    _PoleForm,
    _steady_tolerance,
    conditioning,
)

__all__ = [
    "Band",
    "band",
    "band_average",
    "classify_motion",
    "f",
    "mean_precession",
    "minima",
    "nutation_period",
    "turning_points",
]
