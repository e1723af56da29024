"""Steady states of the gliding top, their stability, and the six classes of tops in the (α, γ) plane.

For a Jellett integral λ the gliding top (viscous friction, :mod:`mett.dynamics.gliding`) has three
kinds of steady motion: the upright spin (θ = 0), the inverted spin (θ = π) and the *tumbling* states
of :func:`mett.thresholds.tumbling_state` (θ = θ_t fixed, contact point at rest, the body precessing
steadily about the vertical). Friction dissipates the energy E while λ is conserved, so the states
that can be approached are the minima of the *amended potential*

    U_λ(θ) = λ² / (2 R² [I1 sin²θ + I3 (cos θ − α)²]) + m g R (1 − α cos θ),

the least energy a top with Jellett integral λ and inclination θ can have (minimising E over the
velocities at fixed λ gives a CM at rest and ω ∥ a; Ebenfeld & Scheck 1995, Ciocci & Langerock 2007
use the same reduction). Its interior critical points are exactly the tumbling family, and its end
points the two spins. A tumbling state is a minimum of U_λ iff λ(θ_t) increases with θ_t there, which
(with z = cos θ_t, u = 1 − γ, w = α − u z > 0) is the sign of

    S(z) = u [γ (1 − z²) + (z − α)²] − 4 w²:   stable iff S < 0.

The same answer comes from linearising the equations of motion: :func:`mett.stability.tumbling_eigenvalues`
linearises the vector form in the frame that precesses with the state and reduces it by the symmetry
and the two integrals (|3̂| and λ), leaving five eigenvalues whose largest real part changes sign
exactly where λ'(θ_t) does (checked in ``tests/test_classification.py`` against an independent
linearisation of the Euler-angle form and against simulations started next to tumbling states).

S is a concave quadratic in z whose vertex z = α/u lies outside [−1, 1] for group II, so the
tumbling family is monotone or has a single fold. That gives six classes, as many as the "six
groups according to the existence and stability type of the steady states" of Ciocci & Langerock
(2007, abstract; arXiv:0704.1221), a classification that one version of their abstract says was
"proposed in [1]", i.e. it predates the paper. What has been checked against the literature is
the Roman numeral only: group I tops "never flip over however large a spin they are given",
group II tops "show a complete inversion",
group III tops "tend to turn over up to a certain inclination angle θf such that θf < π" (Ueda,
Sasaki & Watanabe 2005, abstract) -- the "nontipping", "tipping" and "hanging" tops of Ciocci,
Malengier, Langerock & Grimonprez (2012, abstract); ``tests/test_classification.py`` pins this at
sample points. The boundaries below are derived here, and the letters a, b, c are mett's own
labels: the section of Ciocci & Langerock that defines the subgroups was not available to the
review, so whether e.g. their IIb is mett's IIb is UNVERIFIED. Their model also differs: a sliding
friction with the translational dynamics ignored, reduced by Routh to a two-degree-of-freedom
system, where mett keeps the gliding CM with viscous friction (:mod:`mett.dynamics.gliding`), and
Ueda et al. use "a modified Coulomb law for the sliding friction". mett's amended potential is the
energy minimised with the CM at rest, so it does not involve the translational terms they drop,
but their Routhian and stability conditions were not compared with it.

| class | where | tumbling family λ(θ_t) and stable states |
| --- | --- | --- |
| Ia | γ ≤ 1 − α, S(−1) ≥ 0 | falls from ∞ (θ_f) to λ_thres (π), every tumbling state unstable; upright always stable, inverted too for λ ≥ λ_thres (bistable) |
| Ib | γ ≤ 1 − α, S(−1) < 0 | falls from ∞ to a fold λ_min < λ_thres, then rises to λ_thres: stable tumbling near π for λ_min < λ < λ_thres next to the upright spin (bistable for every λ > λ_min) |
| IIa | group II, S(1) ≤ 0 | rises from λ_0 to λ_thres: upright, tumbling, inverted in turn |
| IIb | group II, S(1) > 0 > S(−1) | falls from λ_0 to λ_min, rises to λ_thres; bistable for λ_min < λ < λ_0 (upright with tumbling, and with inverted where λ_0 > λ_thres, i.e. γ < (1 − α²)(1 + 3α²)/(1 + 6α² + α⁴)) |
| IIc | group II, S(−1) ≥ 0 | falls from λ_0 to λ_thres, every tumbling state unstable; both spins stable for λ_thres ≤ λ ≤ λ_0 |
| III | γ ≥ 1 + α | rises from λ_0 to ∞ at θ_f: upright, then tumbling below θ_f |

(group II is 1 − α < γ < 1 + α; θ_f = arccos(α/(1 − γ)).) Ia and IIc exist only for
α < 7 − 4√3 ≈ 0.0718, in wedges either side of γ = 1 − α; for γ ≥ 1 every group-II top is IIa.
"""

from __future__ import annotations

import itertools
import math
from typing import NamedTuple, cast

import numpy as np
from numpy.typing import ArrayLike

from . import _formulas as fm
from . import _validate
from .thresholds import TumblingState, tumbling_domain, tumbling_lambda
from .top import TippeTop

__all__ = [
    "CLASSIFY_MAX",
    "SAMPLE_POINTS",
    "SUBGROUPS",
    "AsymptoticState",
    "SubgroupBoundaries",
    "amended_potential",
    "asymptotic_state",
    "bistable_range",
    "classify",
    "fold_lambda",
    "stable_states",
    "subgroup",
    "subgroup_boundaries",
    "tumbling_is_stable",
    "tumbling_states",
]

SUBGROUPS = ("Ia", "Ib", "IIa", "IIb", "IIc", "III")
"""The six classes, in the order of the module table."""

SAMPLE_POINTS = {
    "Ia": (0.02, 0.8),
    "Ib": (0.3, 0.6),
    "IIa": (0.3, 0.9357),
    "IIb": (0.3, 0.75),
    "IIc": (0.02, 0.981),
    "III": (0.3, 1.4),
}
"""One (α, γ) per class, simulated in ``tests/test_classification.py`` and marked on the diagram."""

ALPHA_WEDGE = 7.0 - 4.0 * math.sqrt(3.0)
"""α below which the classes Ia and IIc exist: S(−1) = 0 has real roots iff 1 − 6α + α² >= 8α."""


# --- the amended potential and the fold indicator -------------------------------------------


def amended_potential(top: TippeTop, lam: float, theta: ArrayLike) -> np.ndarray:
    """Least energy (J) of a gliding top with Jellett integral ``lam`` and inclination ``theta``.

    U_λ(θ) = λ²/(2 R² [I1 sin²θ + I3 (cos θ − α)²]) + m g R (1 − α cos θ): the energy minimised over
    the velocities at fixed θ and λ (CM at rest, ω ∥ a). Friction lowers E at fixed λ, so the
    attainable end states are its minima; its interior critical points are the tumbling states and
    U_λ(0), U_λ(π) are the energies E0, E1 of the two spins (:func:`mett.boundary_values`).

    Parameters
    ----------
    top : TippeTop
    lam : float
        Jellett integral λ > 0 (kg m² s⁻¹).
    theta : array_like
        Inclination(s) in [0, π] (rad).
    """
    lam = _validate.positive_jellett(lam)
    th = _validate.theta(theta)
    c, s = np.cos(th), np.sin(th)
    Q = top.I1 * s * s + top.I3 * (c - top.alpha) ** 2
    with np.errstate(over="ignore"):  # λ ≳ 1e154: the energy overflows to inf, correctly rounded
        kinetic = np.square(np.float64(lam) / top.R) / (2.0 * Q)
    return kinetic + top.m * top.g * top.R * (1.0 - top.alpha * c)


def tumbling_is_stable(top: TippeTop, theta: ArrayLike) -> np.ndarray:
    """Whether the tumbling state at θ_t = ``theta`` is asymptotically stable (bool array).

    Stable iff it is a minimum of the amended potential, iff λ(θ_t) increases with θ_t, iff
    S(cos θ_t) < 0 (module docstring). False where the family does not exist.
    """
    th = _validate.theta(theta)
    z = np.cos(th)
    exists = top.alpha - (1.0 - top.gamma) * z > 0.0
    return exists & (fm.fold_indicator(top.alpha, top.gamma, z) < 0.0)


# --- classes in the (α, γ) plane ------------------------------------------------------------


def _span(x: np.ndarray) -> str:
    return repr(float(x)) if x.ndim == 0 else f"values in [{x.min():g}, {x.max():g}]"


CLASSIFY_MAX = 1e100
"""Largest α and γ :func:`classify` takes: the criteria are quadratic in them, so every term stays
below ~1e201, finite; wider than any top's (α <= 1e50 on a stem, γ = I1/I3 <= 1e100 with I1, I3 in
:data:`mett.top.FIELD_RANGE`)."""


def classify(alpha: ArrayLike, gamma: ArrayLike) -> np.ndarray:
    """Class (``"Ia"`` … ``"III"``) of tops with eccentricity ``alpha`` and γ = I1/I3 = ``gamma``.

    Vectorised over broadcast ``alpha``, ``gamma``; the criteria are those of the module table,
    which do not need α < 1 (a top resting on its stem has its CM outside the stem sphere, α > 1:
    :mod:`mett.stem`). Returns a str array (0-d for scalar input).

    Raises
    ------
    ValueError
        If alpha or gamma is not in (0, :data:`CLASSIFY_MAX`].
    """
    a = _validate.as_finite_array("alpha", alpha)
    g = _validate.as_finite_array("gamma", gamma)
    if np.any((a <= 0.0) | (a > CLASSIFY_MAX)):
        raise ValueError(f"alpha must lie in (0, {CLASSIFY_MAX:g}]; got {_span(a)}")
    if np.any((g <= 0.0) | (g > CLASSIFY_MAX)):
        raise ValueError(f"gamma must lie in (0, {CLASSIFY_MAX:g}]; got {_span(g)}")
    a, g = np.broadcast_arrays(a, g)
    return fm.classes(a, g)


def subgroup(top: TippeTop) -> str:
    """Class of ``top`` among Ia, Ib, IIa, IIb, IIc, III (module table).

    The Roman numeral is the group of Ueda, Sasaki & Watanabe (2005); the letters are mett's labels
    for the six cases of the module table, not verified to match Ciocci & Langerock's (2007)
    subgroups (module docstring).

    All presets shipped with mett are IIa (e.g. the thesis body, α = 0.3, γ = 0.936).
    """
    _validate.instance("top", top, TippeTop)
    return str(classify(top.alpha, top.gamma))


class SubgroupBoundaries(NamedTuple):
    """The curves γ(α) separating the classes (NaN where a curve does not exist)."""

    group_I: np.ndarray
    """γ = 1 − α (groups I | II)."""
    group_III: np.ndarray
    """γ = 1 + α (groups II | III)."""
    IIa: np.ndarray
    """Lower edge of IIa: S(1) = 0, γ = 1 − u₁ with u₁ = [b₊ − √(b₊² − 64α²)]/8, b₊ = 1 + 6α + α²."""
    IIc: np.ndarray
    """Upper edge of IIc: S(−1) = 0, γ = 1 − u₋, u₋ = [b₋ − √(b₋² − 64α²)]/8, b₋ = 1 − 6α + α²."""
    Ia: np.ndarray
    """Lower edge of Ia: S(−1) = 0, γ = 1 − u₊, u₊ = [b₋ + √(b₋² − 64α²)]/8."""
    spins_equal: np.ndarray
    """λ_0 = λ_thres: γ = (1 − α²)(1 + 3α²)/(1 + 6α² + α⁴); below it (in group II) both spins
    are stable for λ_thres < λ < λ_0."""


def subgroup_boundaries(alpha: ArrayLike) -> SubgroupBoundaries:
    """Boundaries of the classes in the (α, γ) plane as functions of α (module table).

    S(±1) = −4u² + u b_± − 4α² with u = 1 − γ and b_± = 1 ± 6α + α²; each boundary is a root u of
    one of these quadratics.
    """
    a = _validate.as_finite_array("alpha", alpha)
    if np.any((a <= 0.0) | (a >= 1.0)):
        raise ValueError(f"alpha must lie in (0, 1); got {_span(a)}")
    bp = 1.0 + 6.0 * a + a * a
    bm = 1.0 - 6.0 * a + a * a
    # bp² − 64α² = (bp − 8α)(bp + 8α) = (1 − α)² (bp + 8α) >= 0: factored to keep it exact.
    u1 = (bp - np.sqrt((1.0 - a) ** 2 * (bp + 8.0 * a))) / 8.0
    disc = bm * bm - 64.0 * a * a
    with np.errstate(invalid="ignore"):
        root = np.where((disc >= 0.0) & (bm > 0.0), np.sqrt(np.maximum(disc, 0.0)), np.nan)
    spins = (1.0 - a * a) * (1.0 + 3.0 * a * a) / (1.0 + 6.0 * a * a + a**4)
    return SubgroupBoundaries(
        1.0 - a, 1.0 + a, 1.0 - u1, 1.0 - (bm - root) / 8.0, 1.0 - (bm + root) / 8.0, spins
    )


# --- tumbling states with a given λ ------------------------------------------------------------


def _domain(top: TippeTop) -> tuple[float, float]:
    return tumbling_domain(top)


def _fold_theta(top: TippeTop) -> float | None:
    """θ_t where λ(θ_t) turns (S = 0 inside the family's domain), or None if it is monotone."""
    a, u = top.alpha, 1.0 - top.gamma
    if u == 0.0:
        return None
    X = (
        u * (top.gamma + a * a) - a * a
    )  # S(z) = −3u²(z − α/u)² + X, so S = 0 at z = α/u ∓ √(X/3)/|u|
    if X <= 0.0:
        return None
    z = (a - math.copysign(math.sqrt(X / 3.0), u)) / u
    lo, hi = _domain(top)
    if math.cos(hi) < z < math.cos(lo):
        return math.acos(z)
    return None


def fold_lambda(top: TippeTop) -> float | None:
    """λ_min (kg m² s⁻¹) at the fold of the tumbling family (classes Ib, IIb), or None if monotone."""
    th = _fold_theta(top)
    return None if th is None else float(tumbling_lambda(top, th))


def _state_from_lambda(top: TippeTop, th: float, lam: float) -> TumblingState:
    """The tumbling state at θ_t = ``th`` with its precession from λ = R φ̇ [I1 sin²θ + I3 (cos θ − α)²],
    so that its Jellett integral is ``lam`` to rounding even where λ(θ_t) is steep (near θ_f the
    closed form of φ̇ at the rounded θ_t is off by λ'(θ_t)·ulp(θ_t))."""
    c, s = math.cos(th), math.sin(th)
    phidot = lam / (top.R * (top.I1 * s * s + top.I3 * (c - top.alpha) ** 2))
    return TumblingState(float(th), phidot, phidot * (c - top.alpha))


def tumbling_states(top: TippeTop, lam: float) -> list[TumblingState]:
    """Every tumbling state with Jellett integral ``lam``, by increasing θ_t (0, 1 or 2 of them).

    The family is cut at its fold (if any) into monotone pieces and λ(θ_t) = lam is solved on each
    with Brent's method; the spins themselves (θ_t = 0, π) are not included, nor a root within
    the rounding of λ at a pole (there the family joins the spin, see :func:`stable_states`).

    Raises
    ------
    ValueError
        If ``lam`` is not positive and finite.
    """
    return _tumbling_roots(top, lam)[0]


def _tumbling_roots(top: TippeTop, lam: float) -> tuple[list[TumblingState], list[float]]:
    """(:func:`tumbling_states`, the poles 0 or π where a root was taken for the spin itself)."""
    from scipy import optimize

    lam = _validate.positive_jellett(lam)
    lo, hi = _domain(top)
    cuts = [lo, hi]
    fold = _fold_theta(top)
    if fold is not None:
        cuts.insert(1, fold)

    def resid(t: float) -> float:
        return float(tumbling_lambda(top, t)) - lam

    def end_value(t: float) -> float:
        v = resid(t)
        return math.inf if math.isnan(v) else v  # λ → ∞ at θ_f, the family's open end

    out, at_poles = [], []
    for a, b in itertools.pairwise(cuts):
        ra, rb = end_value(a), end_value(b)
        if math.isinf(ra) or math.isinf(rb):
            # step in from θ_f until λ is finite and above lam
            t_inf, t_fin = (a, b) if math.isinf(ra) else (b, a)
            r_fin = ra if t_fin == a else rb
            if r_fin >= 0.0:
                continue
            t = t_fin
            for k in range(1, 1100):
                t_next = t_inf + (t_fin - t_inf) * 2.0**-k
                if t_next == t_inf:
                    break
                t = t_next
                if resid(t) > 0.0:
                    break
            else:  # pragma: no cover - 2⁻¹¹⁰⁰ underflows: the loop always breaks above
                pass
            if not resid(t) > 0.0:
                # θ_t(lam) lies closer to θ_f than the spacing of doubles: the nearest θ it is
                out.append(_state_from_lambda(top, t, lam))
                continue
            a, b = (t, t_fin) if t_inf == a else (t_fin, t)
            ra, rb = resid(a), resid(b)
        # a root at a pole is the spin itself (λ = λ_0 or λ_thres exactly), not a tumbling state
        tol = 1e-12 * lam
        if (a == 0.0 and abs(ra) <= tol) or (b == math.pi and abs(rb) <= tol):
            at_poles.append(0.0 if a == 0.0 and abs(ra) <= tol else math.pi)
            continue
        if ra * rb < 0.0:
            th = optimize.brentq(resid, a, b, xtol=1e-15, rtol=4 * np.finfo(float).eps)
            if 0.0 < th < math.pi:
                out.append(_state_from_lambda(top, th, lam))
    return sorted(out, key=lambda s: s.theta), at_poles


def stable_states(top: TippeTop, lam: float) -> list[AsymptoticState]:
    """All asymptotically stable steady states with Jellett integral ``lam``, by increasing θ.

    The upright spin counts for λ <= λ_0, the inverted one for λ >= λ_thres (the tumbling branch
    that ends there joins it), and the tumbling states with λ'(θ_t) > 0 (:func:`tumbling_is_stable`).
    There is always at least one; two means the end state depends on the start (bistable).

    Within the rounding of λ at a pole (|λ(θ_t) − λ| <= 1e-12 λ at θ_t = 0 or π) a tumbling state
    is not told from the spin it joins: a stable branch's root there stands for that spin. So one
    or two ulps of λ below λ_thres (above λ_0), where the stable branch ends in a tumbling state
    within ~1e-8 rad of the pole, the answer is that pole's spin, the limit of the branch, rather
    than no state at all.
    """
    lam = _validate.positive_jellett(lam)
    R, I3, a = top.R, top.I3, top.alpha
    tumbling, at_poles = _tumbling_roots(top, lam)
    # a stable branch ending at a pole within rounding: its state is that spin
    joins = {pole for pole in at_poles if bool(tumbling_is_stable(top, _off_pole(pole)))}
    out = []
    if lam <= top.lambda_0 or 0.0 in joins:
        out.append(AsymptoticState("upright", 0.0, lam / (R * I3 * (1.0 - a))))
    for st in tumbling:
        if tumbling_is_stable(top, st.theta):
            out.append(AsymptoticState("tumbling", st.theta, st.omega3))
    if lam >= top.lambda_thres or math.pi in joins:
        out.append(AsymptoticState("inverted", math.pi, -lam / (R * I3 * (1.0 + a))))
    return out


def _off_pole(pole: float) -> float:
    """A θ_t just off ``pole`` (0 or π) on the tumbling family, where its stability is that of the
    branch ending at the pole (S(cos θ_t) is continuous; at the pole itself S(±1) may be 0)."""
    return 1e-6 if pole == 0.0 else math.pi - 1e-6


class AsymptoticState(NamedTuple):
    """Predicted end state of a gliding top with a given Jellett integral (docs/theory/thresholds.md#thresholds).

    When two steady states are stable for that λ (the classes Ia, Ib, IIb, IIc of
    module table), ``kind`` is "bistable", ``theta`` and ``omega3`` are NaN (no single
    answer) and ``candidates`` lists both; a top started close enough to θ = 0 then stays upright
    whenever "upright" is among them.
    """

    kind: str
    """"upright", "tumbling", "inverted" or "bistable"."""
    theta: float
    """θ∞ (rad): 0, θ_t(λ) or π; NaN if bistable."""
    omega3: float
    """ω3∞ (rad/s) from the Jellett integral: λ/(R I3 (1 − α)), the tumbling ω3, or −λ/(R I3 (1 + α));
    NaN if bistable."""
    candidates: tuple[AsymptoticState, ...] = ()
    """Every stable steady state with this λ, by increasing θ (one entry, equal to this state, unless
    bistable)."""


def asymptotic_state(top: TippeTop, lam: float) -> AsymptoticState:
    """End state of a gliding top with Jellett integral ``lam`` > 0, for every λ.

    The candidates are the asymptotically stable steady states with this λ
    (:func:`stable_states`): the upright spin for λ <= λ_0, the inverted spin
    for λ >= λ_thres, and the tumbling states θ_t(λ) on a rising part of the tumbling family. For
    the classic tops (class IIa, e.g. the thesis body) exactly one exists: upright up to λ_0,
    tumbling between λ_0 and λ_thres, inverted above (docs/theory/thresholds.md#thresholds; Ueda–Sasaki–Watanabe's groups).
    Where two exist the answer is kind "bistable" with both in ``candidates`` instead of a guess:
    the end state then depends on the initial state, not on λ alone.

    Raises
    ------
    ValueError
        If ``lam`` is not a positive finite number, or so large that the end state's spin ω3
        overflows.
    """
    _validate.instance("top", top, TippeTop)
    lam = _validate.positive_jellett(lam)
    with np.errstate(over="ignore"):  # a spin ω3 ∝ λ beyond the float range: checked here
        found = stable_states(top, lam)
    if not all(math.isfinite(st.omega3) for st in found):
        lam_max = float(np.finfo(float).max) * top.R * top.I3 * (1.0 - top.alpha)
        raise ValueError(
            f"lam must be at most {lam_max:.3g} kg m^3/s for this top (beyond it the end state's "
            f"spin omega3 overflows); got {lam!r}"
        )
    if len(found) == 1:
        st = found[0]
        return st._replace(candidates=(st,))
    return AsymptoticState("bistable", math.nan, math.nan, tuple(found))


def bistable_range(top: TippeTop) -> tuple[float, float] | None:
    """The open interval of λ (kg m² s⁻¹) with two stable steady states, or None (IIa, III).

    Ia: (λ_thres, ∞) (both spins); Ib: (λ_min, ∞); IIb: (λ_min, λ_0); IIc: (λ_thres, λ_0), where
    λ_min is the fold value (:func:`fold_lambda`). The spins alone are both stable on
    [λ_thres, λ_0] whenever λ_thres < λ_0.
    """
    cls = subgroup(top)
    if cls in ("IIa", "III"):
        return None
    if cls in ("Ia", "IIc"):
        return (top.lambda_thres, top.lambda_0)
    return (cast(float, fold_lambda(top)), top.lambda_0)  # Ib, IIb: the family has a fold
