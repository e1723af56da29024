"""Predict whether and when a tippe top inverts, without resolving the nutation.

:func:`predict_inversion` (re-exported as ``mett.predict_inversion``) combines

* the **initiation**: the linear instability of the upright spin (:func:`mett.escape_time`), which
  gives the size θ_u(0) of the initial state's component in the growing (inversion) mode and its
  growth rate σ; for a large tilt, split after the decaying modes' transient on a short resolved
  run (:func:`mett.inversion._nutation.resolved_start`);
* the **gyroscopic-balance flow** (Moffatt & Shimomura 2002, Nature 416, 385; Ueda, Sasaki &
  Watanabe 2005, SIAM J. Appl. Dyn. Syst. 4, 1159): a one-dimensional slow flow of the mean
  inclination θ̄ obtained from Jellett's integral and the dissipated power, integrated from θ_u(0)
  (:mod:`mett.inversion._gyroscopic`);
* for exact Coulomb friction, whether the initial slip stops before the fast motion turns it
  (then the top rolls, conserves E, D, λ and does not invert);
* for Coulomb–Contensou friction (Leine & Glocker 2003), whose slip never stops while the top
  spins, the balance flow in (θ, λ): the drilling torque lowers Jellett's λ on the way, and may
  make the top fall back before it inverts; a start whose slip is beyond the law's linear range
  is first followed until it is linear (:func:`mett.inversion._gyroscopic.saturated_start`);
* where the nutation is predicted to lift the top off before π/2 (``t_lift``), the hopping top
  after it: the balance flow slowed by the ratio of the gliding power to the hop cycle's,
  measured on short runs of that cycle with flight and landing (:mod:`mett.inversion._hops`);
* with ``method="averaged"``, instead of the balance flow: the flow of the gliding top's integrals
  (ω3, E', and λ under Coulomb–Contensou) averaged over its exact nutation band, the contact
  point's answer to the friction force (centre of mass and rotation) slaved to the precession
  (:mod:`mett.inversion._averaged`); it stops where the band lifts the top off.

The derivation, its assumptions and its verification table are on docs/theory/inversion.md.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from typing import TypedDict

import numpy as np
from numpy.typing import ArrayLike

from .. import _validate
from ..asymptotics import high_spin
from ..classification import asymptotic_state
from ..dynamics.flight import VISCOUS_ARTEFACT
from ..friction import Coulomb, FrictionLaw, RegularisedCoulomb, Viscous, check_law
from ..integrals import jellett
from ..stability import escape_modes
from ..state import State
from ..top import TippeTop
from . import _averaged, _hops, _nutation
from ._gyroscopic import (
    NoBalance,
    balance_D_and_E_mod,
    balance_state,
    contensou_path,
    nutation_period,
    saturated_start,
    slow_path,
)
from ._result import InversionPrediction, Validity

__all__ = ["InversionPrediction", "Validity", "atlas", "predict_inversion"]

METHODS = ("gyroscopic", "averaged")

STARTS = ("auto", "linear")
"""Values of :func:`predict_inversion`'s ``start``: the resolved start where the linear split is
unreliable (``"auto"``), or the linear split always (``"linear"``)."""


# The box of the verification table (docs/theory/inversion.md#verification): outside it the
# prediction is flagged. Set from the table, not the reverse.
class _Verified(TypedDict):
    laws: tuple[str, ...]
    theta0: tuple[float, float]  # rad
    theta0_moving_cm: float  # rad
    spin_ratio: tuple[float, float]  # λ/λ_thres
    epsilon: float  # T_n/t_half
    start: str


VERIFIED: _Verified = {
    "laws": ("viscous", "regularised-coulomb"),
    "theta0": (0.01, 0.25),
    "theta0_moving_cm": 0.03,
    "spin_ratio": (1.5, 20.0),
    "epsilon": 0.05,
    "start": "centre of mass at rest",
}


# Below this initial tilt (rad) the linear split of the start is kept: its second-order error is
# O(θ0²) relative, under 0.5 % of t_half on the thesis top at θ0 = 0.03 (docs/theory/inversion.md#the-initial-tilt).
SMALL_TILT = 0.03

SATURATED_CAP = 0.05
"""Inversion-mode amplitude (rad) at which a Coulomb–Contensou start still saturated hands over to
the balance flow (docs/theory/inversion.md#a-start-beyond-the-laws-linear-range): small enough
for the mode to be linear, large against the slow tilt's rounding."""


# Coulomb–Contensou: where the balance flow reaches π − tol with λ below this many λ_thres the
# answer is None: the top arrives, but its inverted spin is unstable there (λ < λ_thres,
# docs/theory/thresholds.md) and the drilling torque keeps lowering λ. It was 1.5 (an undecided
# band fitted to simulations) while the flow ignored the contact point's response to the
# friction force (mett.inversion._gyroscopic.cm_slip2); with it, the flow's own end decides
# (docs/theory/inversion.md#coulombcontensou: right in 77 of the 78 simulated cases).
CONTENSOU_MARGIN = 1.0


def _check_options(hops: object, start: object) -> None:
    """``hops`` and ``start`` of :func:`predict_inversion` and :func:`atlas`, before any work."""
    if not isinstance(hops, bool):
        raise TypeError(f"hops must be a bool; got {type(hops).__name__}")
    if not isinstance(start, str):
        raise TypeError(f"start must be a str, one of {STARTS}; got {type(start).__name__}")
    if start not in STARTS:
        raise ValueError(f"start must be one of {STARTS}; got {start!r}")


def _law_name(law: Viscous | Coulomb | RegularisedCoulomb) -> str:
    if isinstance(law, Viscous):
        return "viscous"
    if isinstance(law, RegularisedCoulomb):
        return "regularised-coulomb"
    if law.contensou_radius > 0.0:
        return "coulomb-contensou"
    return "coulomb"


def _linear_mu(top: TippeTop, law: Viscous | Coulomb | RegularisedCoulomb, state: State) -> float:
    """Viscous coefficient (s/m) of the law linearised at the upright spin.

    The regularised law is viscous with μ/ε below ε; Contensou's with μ/(r* |ω_n|) (mett.friction).
    Exact Coulomb has no linearisation: its coefficient at the initial slip scale R |ω3| sin θ0
    only splits the state into modes (flagged as unverified).
    """
    if isinstance(law, Viscous):
        return top.mu if law.mu is None else law.mu
    if isinstance(law, RegularisedCoulomb):
        return law.mu / law.eps
    wn = abs(float(state.omega3))
    if law.contensou_radius > 0.0:
        return law.mu / (law.r_star * wn)
    return law.mu / (top.R * wn * max(math.sin(float(state.theta)), 1e-3))


def _empty(inverts, reason, method, validity, t_start=math.inf, theta0=0.0, lam=0.0, tol=0.05):
    # No slow path: empty arrays, the top stays where it is as far as the reduction can tell.
    empty = np.empty(0)
    return InversionPrediction(
        inverts=inverts,
        reason=reason,
        method=method,
        t_start=t_start,
        t_half=math.inf,
        t_inv=math.inf,
        tol=tol,
        t=empty,
        theta=empty,
        D=empty,
        E_mod=empty,
        lam=empty,
        theta_end=theta0,
        validity=validity,
    )


def _coulomb_stick_time(top: TippeTop, state: State) -> float:
    """Time (s) in which exact Coulomb friction stops the initial slip, if it keeps its direction.

    The slip decelerates at μ g κ with κ = 1 + m R² (1 − α cos θ)²/I1 (the ν̇ equations,
    docs/theory/equations.md#euler-form, with θ̇ = 0); returned per unit μ.
    """
    c = math.cos(float(state.theta))
    kappa = 1.0 + top.m * top.R**2 * (1.0 - top.alpha * c) ** 2 / top.I1
    slip = math.hypot(float(state.nu_x), float(state.nu_y))
    return slip / (top.g * kappa)


def predict_inversion(
    top: TippeTop,
    state: State,
    friction: FrictionLaw | None = None,
    *,
    method: str = "gyroscopic",
    tol: float = 0.05,
    hops: bool = True,
    start: str = "auto",
) -> InversionPrediction:
    """Predict whether, when and how a gliding tippe top inverts, without resolving the nutation.

    Parameters
    ----------
    top : TippeTop
        A ball top (a stemmed top is refused: its stem contact is outside the reduction).
    state : State
        Initial state, near the upright spin (θ0 < π/2, ω3 > 0, a positive Jellett integral).
    friction : mett.friction law, optional
        :class:`~mett.friction.Viscous` (default, μ = ``top.mu``), :class:`~mett.friction.RegularisedCoulomb`
        or :class:`~mett.friction.Coulomb`. Without a Contensou radius: whether the slip stops
        (then the top rolls and does not invert). With one: the balance flow in (θ, λ), λ lowered
        by the drilling torque, from the start's saturated phase where its slip exceeds
        r* |ω_n| (method "gyroscopic" only; declared accuracy of ``t_half``: 6 % + one nutation
        period for θ0 ≤ 0.03, and for θ0 ≤ 0.1 with the centre of mass at rest; 12 % + one
        nutation period for θ0 ≤ 0.1 with the contact point at rest; ``inverts=None`` where λ
        arrives below ``CONTENSOU_MARGIN`` λ_thres).
    method : {"gyroscopic", "averaged"}
        The reduction (docs/theory/inversion.md). ``"gyroscopic"``: linear initiation +
        gyroscopic-balance slow flow. ``"averaged"``: the same initiation, then the flow of the
        gliding top's integrals (ω3, E', and λ under Coulomb–Contensou) averaged over its exact
        nutation band, with the contact point's answer to the friction force (centre of mass
        and rotation) as the slow slip (viscous, regularised Coulomb and Coulomb–Contensou
        laws; verified range: the gyroscopic box for the viscous law; ``inverts=None`` with
        ``t_lift`` where the band's normal force vanishes before π/2).
    tol : float, default 0.05
        Tolerance (rad) of ``t_inv``: θ̄ within ``tol`` of its end state; in (0, 0.5).
    hops : bool, default True
        Method "gyroscopic", viscous and regularised Coulomb laws: where the nutation is predicted
        to lift the top off before π/2 (``t_lift < t_half``), follow the hopping top after
        ``t_lift``: its flow runs at the power friction takes over the hop cycle, measured on
        short runs of that cycle with flight and landing (docs/theory/inversion.md#the-hopping-top;
        0.1–1 s per such prediction, against ~1 ms). ``False``: the gliding flow throughout
        (bounded cost).
    start : {"auto", "linear"}, default "auto"
        How the start is split into the upright spin's modes (the growing mode's amplitude θ_u(0)
        the slow flow starts from). ``"auto"``: the linear split (:func:`mett.escape_time`),
        except for a large tilt mostly in the decaying modes (θ0 > 0.03, the linear
        split leaving less than 0.3 θ0 in the growing mode; viscous law, method "gyroscopic"),
        which is split after the decaying modes' transient on a short resolved run of the full
        model (six e-foldings of the slip): accurate there (docs/theory/inversion.md#the-initial-tilt),
        but it costs 3–25 ms more, growing with ω3 and the number of nutations; and for
        Coulomb–Contensou a start whose slip is beyond the law's linear range is followed until
        it is linear (docs/theory/inversion.md#a-start-beyond-the-laws-linear-range, 50–90 ms).
        ``"linear"``: the linear split always; with ``hops=False`` the prediction runs no simulation and costs
        ~1 ms, bounded in ω3 and in the number of nutations, at the linear split's error on such
        starts (−21 % to +7 % of ``t_half`` on the thesis top at θ0 = 0.1–0.3, ω3 = 155 rad/s;
        −23 % at 620 rad/s, μ = 0.05 s/m; docs/theory/inversion.md#speed).

    Returns
    -------
    InversionPrediction
        ``inverts``, ``reason``, ``t_start``, ``t_half``, ``t_inv`` (s), the slow path ``t``,
        ``theta``, ``D``, ``E_mod``, ``lam`` and ``validity``. ``inverts is None`` (with the
        reason) where the reduction cannot decide.

    Raises
    ------
    ValueError
        If ``top`` is stemmed, ``method``, ``start`` or ``tol`` is unknown/out of range, or the
        state is not near the upright spin (θ0 >= π/2, λ <= 0).
    TypeError
        If ``top``, ``state`` or ``friction`` has the wrong type, ``hops`` is not a bool or
        ``start`` not a str.

    Notes
    -----
    The mean inclination θ̄ is that of the growing (inversion) mode; it starts at θ_u(0), the
    initial state's component in that mode, not at θ0 (the rest of θ0 decays first: the dip of
    θ(t) seen before an inversion, Rutstam 2013). For a large tilt (θ0 > 0.03, the linear split
    leaving less than 0.3 θ0 in that mode; viscous law, gyroscopic method) θ_u(0) is taken after
    the decaying modes' transient, from a short resolved run of the full model (a few
    milliseconds more, growing with ω3; docs/theory/inversion.md, "The initial tilt"), unless
    ``start="linear"``. Cost (docs/theory/inversion.md#speed): ~1 ms with ``start="linear",
    hops=False``, whatever ω3 and the number of nutations. Sources: Moffatt & Shimomura (2002); Ueda,
    Sasaki & Watanabe (2005); Rauch-Wojciechowski & Rutstam (2014) for λ_thres.
    """
    if type(top).__name__ == "StemmedTop":
        raise ValueError(
            "top must be a ball top (TippeTop); a stemmed top's second contact is outside the "
            "gyroscopic-balance reduction"
        )
    _validate.instance("top", top, TippeTop)
    _validate.instance("state", state, State)
    if np.ndim(state.theta) != 0:
        raise ValueError(f"state must be a single state; got shape {np.shape(state.theta)}")
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}; got {method!r}")
    tol = _validate.finite_scalar("tol", tol)
    _check_options(hops, start)
    if not 0.0 < tol < 0.5:
        raise ValueError(f"tol must lie in (0, 0.5) rad; got {tol!r}")
    empty = functools.partial(_empty, tol=tol)
    law = Viscous() if friction is None else check_law(friction)
    theta0 = float(state.theta)
    if not theta0 < 0.5 * math.pi:
        raise ValueError(
            f"state.theta must be below pi/2 (a top near the upright spin); got {theta0!r}"
        )
    if not float(state.omega3) > 0.0:
        raise ValueError(
            f"state.omega3 must be positive (a top spun about its axis, near theta = 0); "
            f"got {float(state.omega3)!r}"
        )
    lam = float(jellett(top, state))
    if not lam > 0.0:
        raise ValueError(
            f"the state's Jellett integral must be positive (spin omega3 > 0 near theta = 0); got {lam!r}"
        )
    if not isinstance(law, (Viscous, Coulomb, RegularisedCoulomb)):
        # a registered law the reduction has no power balance for (e.g. rolling resistance)
        return empty(
            None,
            f"the friction law {type(law).__name__} is not covered by the gyroscopic-balance "
            "reduction (it knows the viscous, Coulomb and regularised Coulomb laws)",
            method,
            Validity(math.nan, lam / top.lambda_thres, True, ("law not covered",)),
            theta0=theta0,
            lam=lam,
        )
    name = _law_name(law)
    spin_ratio = lam / top.lambda_thres
    notes: list[str] = []
    if name not in VERIFIED["laws"]:
        notes.append(f"law {name} outside the verified range")
    lo, hi = VERIFIED["theta0"]
    if not lo <= theta0 <= hi:
        notes.append(f"theta0 outside [{lo}, {hi}]")
    lo, hi = VERIFIED["spin_ratio"]
    if not lo <= spin_ratio <= hi:
        notes.append(f"lam/lam_thres outside [{lo}, {hi}]")

    # Horizontal CM velocity of the start: ṙ = ν − (ω × a)_h (docs/theory/model.md#frames); the reduction has it 0.
    c0, s0 = math.cos(theta0), math.sin(theta0)
    rx = float(state.nu_x) + top.R * float(state.thetadot) * (1.0 - top.alpha * c0)
    ry = float(state.nu_y) - top.R * s0 * (
        float(state.omega3) + float(state.phidot) * (top.alpha - c0)
    )
    if (
        math.hypot(rx, ry) > 1e-6 * top.R * abs(float(state.omega3))
        and theta0 > VERIFIED["theta0_moving_cm"]
    ):
        notes.append(
            "start with the centre of mass moving and theta0 > "
            f"{VERIFIED['theta0_moving_cm']} (verified: centre of mass at rest, or theta0 smaller)"
        )

    def validity(eps: float, extra: Sequence[str] = ()) -> Validity:
        n = [*notes, *extra]
        if math.isfinite(eps) and eps > VERIFIED["epsilon"]:
            n.append(f"epsilon = T_n/t_half above {VERIFIED['epsilon']}")
        return Validity(eps, spin_ratio, bool(n), tuple(n))

    T_n = nutation_period(top, float(state.omega3))

    if top.group == "I":
        return empty(
            False,
            "group I top (gamma <= 1 - alpha): never inverts",
            method,
            validity(math.nan),
            theta0=theta0,
            lam=lam,
        )
    contensou = isinstance(law, Coulomb) and law.contensou_radius > 0.0
    if contensou and isinstance(law, Coulomb) and not law.mu > 0.0:
        return empty(
            False,
            "no friction (mu = 0): nothing dissipates, the top keeps its nutation band",
            method,
            validity(math.nan),
            theta0=theta0,
            lam=lam,
        )
    if isinstance(law, Coulomb) and law.mu > 0.0 and not contensou:
        t_stop = _coulomb_stick_time(top, state) / law.mu
        # The slip direction turns with the precession: the slow (gyroscopic) precession of a
        # top spinning about its tilted axis (docs/theory/high-spin.md), or the start's own φ̇ if larger.
        turn = max(
            abs(float(state.phidot)),
            abs(float(high_spin(top, theta0, float(state.omega3)).precession)),
        )
        if t_stop * turn < 1.0:
            # Coulomb friction removes the slip before its direction turns: the contact sticks
            # and the top rolls, conserving E, D and λ, so it stays in its nutation band.
            return empty(
                False,
                f"contact sticks: rolling from t = {t_stop:.3g} s (the slip stops before the "
                "precession turns it; rolling conserves E, D and lam, no inversion)",
                method,
                validity(math.nan),
                t_start=math.inf,
                theta0=theta0,
                lam=lam,
            )
    mu_lin = _linear_mu(top, law, state)
    # the viscous default linearises at the top's own μ: the top itself, not a copy
    top_lin = top if mu_lin == top.mu else top._with_mu(mu_lin)
    try:
        esc, modes = escape_modes(top_lin, state)
    except ValueError as exc:
        if lam <= top.lambda_0:
            return empty(
                False,
                f"below threshold lambda_0 = {top.lambda_0:.4g}: the upright spin is stable",
                method,
                validity(math.nan),
                theta0=theta0,
                lam=lam,
            )
        return empty(
            None, f"no linear initiation: {exc}", method, validity(math.nan), theta0=theta0, lam=lam
        )
    end = asymptotic_state(top, lam)
    if end.kind == "inverted":
        theta_end = math.pi
    elif end.kind == "tumbling":
        theta_end = float(end.theta)
    elif end.kind == "upright":
        return empty(
            False,
            "below threshold: the end state is the upright spin",
            method,
            validity(math.nan),
            theta0=theta0,
            lam=lam,
        )
    else:
        return empty(
            None,
            f"end state is {end.kind}: it depends on the initial state",
            method,
            validity(math.nan),
            theta0=theta0,
            lam=lam,
        )
    amp = esc.amplitude
    if (
        start == "auto"
        and method == "gyroscopic"
        and isinstance(law, Viscous)
        and theta0 > SMALL_TILT
        and amp < _nutation.SPLIT_FRACTION * theta0
    ):
        # A large tilt mostly in the decaying modes: their nonlinear transient sets the growing
        # mode's amplitude, so split the start after it (docs/theory/inversion.md#the-initial-tilt).
        resolved = _nutation.resolved_start(top_lin, state, modes)
        if resolved is not None:
            amp = resolved.amplitude
    if contensou and method != "averaged":
        return _predict_contensou(top, state, law, lam, tol, esc, modes, validity, empty, start)
    if method == "averaged":
        return _predict_averaged(
            top, state, law, lam, theta_end, end.kind, tol, esc, modes, validity, empty
        )
    target = theta_end - tol if theta_end > amp else theta_end + tol
    try:
        t, theta, balance, at = slow_path(
            top, lam, law, amp, target, (theta0, 0.5 * math.pi),
            fixed_point=theta_end if end.kind == "tumbling" else None,
        )  # fmt: skip
    except NoBalance as exc:
        return empty(
            None,
            f"no gyroscopic balance at theta = {exc.theta:.3g} (spin too low for a fast "
            "precession): the reduction does not apply",
            method,
            validity(math.nan),
            theta0=theta0,
            lam=lam,
        )
    except ValueError as exc:
        return empty(None, f"slow flow: {exc}", method, validity(math.nan), theta0=theta0, lam=lam)
    lam_path = np.full_like(theta, lam)
    if isinstance(law, Viscous):
        # The viscous law acts as a dry coefficient μ|v_A|; above 1, which no real contact has,
        # it lifts the top off (an artefact of the law, docs/theory/flight.md) and the balance
        # state's g_n = m g fails. Checked on the way to π/2, the part t_half depends on.
        up = theta <= 0.5 * math.pi
        coef = mu_lin * float(np.max(np.abs(balance[3][up]), initial=0.0))
        if coef > VISCOUS_ARTEFACT:
            notes.append(f"viscous mu |v_A| = {coef:.3g} > {VISCOUS_ARTEFACT:g} before pi/2")

    times = {"start": at[theta0], "half": at[0.5 * math.pi], "end": float(t[-1])}
    D, E_mod = balance_D_and_E_mod(top, lam, theta, balance)
    t_half = times["half"]
    # Does the nutation lift the top off before π/2 (g_n = m g fails)? First-order criterion
    # along the path (mett.inversion._nutation, docs/theory/inversion.md#verification), on every
    # third node up to π/2 (steps <= 0.3 in ln tan(θ/2)) and the last: t_lift moves by <= 1 %
    # from the full path on the verification cases, at a third of the cost. Far from lifting off
    # (a bound over both fast eigenvalues below 1/2) the nutation is not followed at all.
    up = np.flatnonzero(theta <= 0.5 * math.pi)
    if up.size and (len(up) - 1) % 3:  # the last node, unless every third already has it
        up = np.r_[up[::3], up[-1]]
    else:
        up = up[::3]
    try:
        amp0, rate0 = _nutation.upright_nutation(modes)
        t_lift = _nutation.lift_off_time(top, law, lam, t[up], theta[up], amp0, rate0)
    except np.linalg.LinAlgError:  # a defective upright spectrum: no mode split
        t_lift = math.nan
    if t_lift < t_half:
        hop_note = f"predicted to hop before pi/2 (t_lift = {t_lift:.3g} s)"
        if hops:
            # From the lift-off on the top hops and friction takes the hop cycle's power, measured
            # on short runs of that cycle (mett.inversion._hops): the path's times stretch by S.
            try:
                t_new, _, slow = _hops.hopping_times(top, law, lam, t, theta, t_lift)
            except (ValueError, RuntimeError, ArithmeticError) as exc:  # a window's run failed
                t_new, slow = t, np.array([math.nan])
                hop_note += f" (hop cycle not measured: {exc})"
            if np.all(np.isfinite(slow)):
                times = {k: float(np.interp(v, t, t_new)) if math.isfinite(v) else v
                         for k, v in times.items()}  # fmt: skip
                t, t_half = t_new, times["half"]
                hop_note += (
                    f"; the path after it follows the hop cycle (slowdown {slow.min():.3g} to "
                    f"{slow.max():.3g})"
                )
            else:
                hop_note += "; the hop cycle not followed: the gliding path after it"
        notes.append(hop_note)
    eps = T_n / t_half if math.isfinite(t_half) else math.nan
    if end.kind == "inverted":
        inverts, reason = True, "inverts"
    else:
        inverts = False
        if top.group == "III":
            theta_f = math.acos(top.alpha / (1.0 - top.gamma))
            why = f"group III: the tumbling state below theta_f = {theta_f:.4g} rad"
        else:
            why = "lambda_0 < lam < lambda_thres: partial inversion to the tumbling state"
        reason = f"hangs at theta_t = {theta_end:.4g} rad ({why})"
    t_start = 0.0 if amp >= theta0 else times["start"]
    return InversionPrediction(
        inverts=inverts,
        reason=reason,
        method=method,
        t_start=t_start,
        t_half=t_half,
        t_inv=times["end"],
        tol=tol,
        t=np.asarray(t),
        theta=np.asarray(theta),
        D=np.asarray(D),
        E_mod=np.asarray(E_mod),
        lam=np.asarray(lam_path),
        theta_end=theta_end,
        validity=validity(eps),
        t_lift=t_lift,
    )


def _predict_contensou(top, state, law, lam, tol, esc, modes, validity, empty, start="auto"):
    """Coulomb–Contensou: the balance flow in (θ, λ), the drilling torque lowering λ
    (docs/theory/inversion.md#coulombcontensou)."""
    theta0 = float(state.theta)
    # Spin-down time of the upright spin under the full drilling torque μ m g r*; |M| <= μ g_n r*
    # at any slip, so the spin lasts at least this long: ten of them bound the slow flow.
    t_spin = top.I3 * float(state.omega3) / (law.mu * top.m * top.g * law.r_star)
    target = math.pi - tol
    amp = esc.amplitude
    # A start whose slip is beyond the law's linear range: its saturated phase sets the inversion
    # mode's amplitude and λ where the slip becomes linear (docs/theory/inversion.md#a-start-beyond-the-laws-linear-range)
    t_sat, lam_flow = 0.0, lam
    # (start="linear": the linear split of the start always, as for the other laws)
    sat = saturated_start(top, law, state, t_max=10.0 * t_spin) if start == "auto" else None
    if sat is not None:
        t_sat, amp, lam_flow = float(sat.t[-1]), sat.amplitude, float(sat.lam[-1])
        # The mode may outgrow the linear regime before the slip is linear (a slow law, μ small):
        # the flow, which has the law's full |γ|, takes over where the mode reaches SATURATED_CAP.
        log_amp = (
            math.log(sat.amplitude0)
            + np.r_[0.0, np.cumsum(0.5 * (sat.rate[1:] + sat.rate[:-1]) * np.diff(sat.t))]
        )
        k = int(np.argmax(log_amp >= math.log(SATURATED_CAP)))
        if sat.amplitude0 < SATURATED_CAP and log_amp[k] >= math.log(SATURATED_CAP):
            # log-amplitude is piecewise quadratic (trapezoid on a linear rate): linear in t is
            # within the rule's own error on the interval
            f = (math.log(SATURATED_CAP) - log_amp[k - 1]) / (log_amp[k] - log_amp[k - 1])
            t_sat = float(sat.t[k - 1] + f * (sat.t[k] - sat.t[k - 1]))
            lam_flow = float(sat.lam[k - 1] + f * (sat.lam[k] - sat.lam[k - 1]))
            amp = SATURATED_CAP
        if not 0.0 < amp < 0.5:  # the flow starts from a small inversion mode
            return empty(None, f"saturated start: inversion-mode amplitude {amp:.3g} rad at "
                         f"t = {t_sat:.3g} s is outside (0, 0.5)", "gyroscopic",
                         validity(math.nan), theta0=theta0, lam=lam)  # fmt: skip
    try:
        path = contensou_path(top, law, lam_flow, amp, target, 10.0 * t_spin)
        if t_sat > 0.0:
            path = path._replace(t=path.t + t_sat, t_half=path.t_half + t_sat,
                                 t_end=path.t_end + t_sat)  # fmt: skip
    except ValueError as exc:
        return empty(None, f"slow flow: {exc}", "gyroscopic", validity(math.nan), theta0=theta0,
                     lam=lam)  # fmt: skip
    if len(path.t) < 2:
        no_balance = path.stop == "no balance"
        return empty(
            None if no_balance else False,
            f"no gyroscopic balance at theta = {amp:.3g} (spin too low for a fast precession): "
            "the reduction does not apply"
            if no_balance
            else "the balance flow does not climb from the upright spin: the drilling torque "
            "holds the top up",
            "gyroscopic",
            validity(math.nan),
            theta0=theta0,
            lam=lam,
        )
    drop = 1.0 - float(path.lam[-1]) / lam
    where = f"theta = {float(path.theta[-1]):.3g} rad, t = {float(path.t[-1]):.3g} s"
    margin = float(path.lam[-1]) / top.lambda_thres
    if path.stop == "end" and margin < CONTENSOU_MARGIN:
        inverts, reason = (
            None,
            (
                f"undecided: the mean inclination reaches pi - tol, but the drilling torque has "
                f"lowered lam to {margin:.3g} lam_thres (below {CONTENSOU_MARGIN} lam_thres the "
                "inverted spin is unstable: the top may leave it again)"
            ),
        )
    elif path.stop == "end":
        inverts, reason = (
            True,
            (
                f"inverts (the drilling torque lowers lam by {drop:.1%} on the way; the inverted "
                "spin then decays too)"
            ),
        )
    elif path.stop == "turns back":
        inverts, reason = (
            False,
            (
                f"falls back from {where}: the drilling torque has lowered lam by {drop:.1%}, "
                f"to {float(path.lam[-1]) / top.lambda_thres:.3g} lam_thres, and the top no longer "
                "climbs"
            ),
        )
    elif path.stop == "no balance":
        inverts, reason = (
            False,
            (
                f"the spin is consumed at {where} (lam down by {drop:.1%}): the gyroscopic balance "
                "ends before the top inverts"
            ),
        )
    else:
        inverts, reason = None, f"the slow flow has not ended by t = {float(path.t[-1]):.3g} s"
    T_n = nutation_period(top, float(state.omega3))
    eps = T_n / path.t_half if math.isfinite(path.t_half) else math.nan
    t_lift = _contensou_lift_off(top, law, lam_flow, path, modes, sat)
    extra = (
        [f"predicted to hop before pi/2 (t_lift = {t_lift:.3g} s)"] if t_lift < path.t_half else []
    )
    D, E_mod = balance_D_and_E_mod(top, path.lam, path.theta, path.state)
    if amp >= theta0:
        t_start = 0.0
    else:
        t_start = (
            float(np.interp(theta0, path.theta, path.t)) if path.theta[-1] >= theta0 else math.inf
        )
    return InversionPrediction(
        inverts=inverts,
        reason=reason,
        method="gyroscopic",
        t_start=t_start,
        t_half=path.t_half,
        t_inv=path.t_end,
        tol=tol,
        t=np.asarray(path.t),
        theta=np.asarray(path.theta),
        D=np.asarray(D),
        E_mod=np.asarray(E_mod),
        lam=np.asarray(path.lam),
        theta_end=math.pi if inverts else float(path.theta[-1]),
        validity=validity(eps, extra),
        t_lift=t_lift,
    )


def _contensou_lift_off(top, law, lam, path, modes, sat) -> float:
    """t_lift (s) of the Coulomb–Contensou path: the lift-off criterion of mett.inversion._nutation
    with the law's force as the regularised Coulomb law it is at a fixed spin, ε = r* |ω_n|
    (F_t = −μ g_n v_A/√(v_A² + (r* ω_n)²)), ε and λ those of the flow's first node. The drilling
    torque is left out of the nutation's linearisation, and λ falls along the path (by the
    fraction ``1 − lam[-1]/lam[0]``), so the criterion is approximate beyond the first order
    of the viscous one (docs/theory/inversion.md#coulombcontensou)."""
    up = np.flatnonzero(path.theta <= 0.5 * math.pi)
    if up.size < 2:
        return math.inf
    if up[-1] + 1 < len(path.theta):  # and the first node past π/2
        up = np.r_[up, up[-1] + 1]
    omega_n = float(balance_state(top, lam, float(path.theta[0]))[4])
    lin = RegularisedCoulomb(law.mu, law.r_star * abs(omega_n))
    try:
        amp0, rate0 = _nutation.upright_nutation(modes)
    except np.linalg.LinAlgError:
        return math.nan
    if sat is not None:
        # after a saturated start the slow tilt is what is left of the start's inclination
        amp0 = float(sat.theta[-1])
    return _nutation.lift_off_time(top, lin, lam, path.t[up], path.theta[up], amp0, rate0)


def _end_reason(top: TippeTop, theta_end: float) -> str:
    if top.group == "III":
        theta_f = math.acos(top.alpha / (1.0 - top.gamma))
        why = f"group III: the tumbling state below theta_f = {theta_f:.4g} rad"
    else:
        why = "lambda_0 < lam < lambda_thres: partial inversion to the tumbling state"
    return f"hangs at theta_t = {theta_end:.4g} rad ({why})"


def _averaged_lift_off(top, law, lam, t, theta, modes) -> float:
    """The first-order lift-off time (s) along the averaged flow's path (t, θ̄) up to π/2."""
    up = theta <= 0.5 * math.pi
    if np.count_nonzero(up) < 2 or np.any(np.diff(theta[up]) <= 0.0):
        return math.nan  # no rising path to follow
    s = np.log(np.tan(0.5 * theta[up]))
    nodes = np.linspace(s[0], s[-1], max(2, math.ceil((s[-1] - s[0]) / 0.3) + 1))
    t_nodes = np.interp(nodes, s, t[up])
    th_nodes = 2.0 * np.arctan(np.exp(nodes))
    try:
        amp0, rate0 = _nutation.upright_nutation(modes)
        return _nutation.lift_off_time(top, law, lam, t_nodes, th_nodes, amp0, rate0)
    except np.linalg.LinAlgError:  # a defective upright spectrum: no mode split
        return math.nan


def _predict_averaged(top, state, law, lam, theta_end, kind, tol, esc, modes, validity, empty):
    """method="averaged": the band-averaged flow of (ω3, E') from the growing mode's start."""
    theta0 = float(state.theta)
    contensou = isinstance(law, Coulomb) and law.contensou_radius > 0.0
    if not (isinstance(law, (Viscous, RegularisedCoulomb)) or contensou):
        return empty(
            None,
            "the averaged flow covers the viscous, regularised Coulomb and Coulomb-Contensou "
            "laws only",
            "averaged",
            validity(math.nan),
            theta0=theta0,
            lam=lam,
        )
    # The flow starts where the gyroscopic one does: on the growing mode's amplitude θ_u(0) (the
    # linear initiation), in the fast steady precession there (an empty band of the gliding top).
    amp = esc.amplitude
    phidot_0, w3_0, _, _, _ = balance_state(top, lam, amp)
    if not math.isfinite(w3_0):
        return empty(None, "no fast precession at the start's growing mode", "averaged",
                     validity(math.nan), theta0=theta0, lam=lam)  # fmt: skip
    target = theta_end - tol if theta_end > amp else theta_end + tol
    mu_lin = _linear_mu(top, law, state)
    t_max = _averaged.time_cap(top, law, float(w3_0), float(phidot_0))
    try:
        n1, e = _averaged.start(top, float(phidot_0), float(w3_0), amp)
        t, theta, D, E_mod, t_half, t_end, t_lift, slip, lams = _averaged.slow_path(
            top, law, lam, n1, e, target, t_max
        )
    except _averaged.AveragingFails as exc:
        return empty(
            None,
            f"the averaged flow cannot follow the band: {exc}",
            "averaged",
            validity(math.nan),
            theta0=theta0,
            lam=lam,
        )
    extra = []
    if isinstance(law, Viscous):
        # the viscous law's dry coefficient μ|ν| before π/2, as for the gyroscopic method
        coef = mu_lin * float(np.max(slip[theta <= 0.5 * math.pi], initial=0.0))
        if coef > VISCOUS_ARTEFACT:
            extra.append(f"viscous mu |v_A| = {coef:.3g} > {VISCOUS_ARTEFACT:g} before pi/2")
    band_lifts = t_lift < t_half
    if band_lifts:
        extra.append(f"the nutation band lifts the top off before pi/2 (t_lift = {t_lift:.3g} s)")
    else:
        # The contact point's response keeps the flow's band near its floor, where it has no
        # nutation to lift off with; the nutation the initiation leaves grows at the rate of
        # the fast pair linearised along the path (mett.inversion._nutation), as for the
        # gyroscopic method: its first-order criterion on the flow's own path up to π/2, on
        # nodes 0.3 apart in ln tan(θ/2) (the gyroscopic method's spacing).
        # (not evaluated under Coulomb–Contensou, as for the gyroscopic method: λ moves)
        t_nut = math.nan if contensou else _averaged_lift_off(top, law, lam, t, theta, modes)
        if t_nut < t_half:
            extra.append(f"predicted to hop before pi/2 (t_lift = {t_nut:.3g} s)")
        t_lift = min(t_lift, t_nut)
    T_n = nutation_period(top, float(state.omega3))
    eps = T_n / t_half if math.isfinite(t_half) else math.nan
    if band_lifts:
        # the band's own normal force vanishes: the nutation lifts the top off and the flow,
        # which assumes contact, stops there
        inverts, reason = (
            None,
            (
                f"the nutation band lifts the top off at t = {t_lift:.3g} s (mean theta = "
                f"{theta[-1]:.3g}), before pi/2: the averaged flow assumes contact"
            ),
        )
    elif contensou:
        # λ is slow: the drilling torque decides, as for the gyroscopic method's flow in (θ, λ)
        drop = 1.0 - float(lams[-1]) / lam
        margin = float(lams[-1]) / top.lambda_thres
        if math.isfinite(t_end) and margin >= CONTENSOU_MARGIN:
            inverts, reason = True, (f"inverts (the drilling torque lowers lam by {drop:.1%} on "
                                     "the way; the inverted spin then decays too)")  # fmt: skip
        elif math.isfinite(t_end):
            inverts, reason = (
                None,
                (
                    f"undecided: the mean inclination reaches pi - tol, but the drilling torque has "
                    f"lowered lam to {margin:.3g} lam_thres (below {CONTENSOU_MARGIN} lam_thres the "
                    "inverted spin is unstable: the top may leave it again)"
                ),
            )
        elif len(theta) and theta[-1] < float(np.max(theta)) - 0.01:
            inverts, reason = (
                False,
                (
                    f"falls back from theta = {float(np.max(theta)):.3g} rad: the drilling torque "
                    f"has lowered lam by {drop:.1%}, to {margin:.3g} lam_thres, and the top no "
                    "longer climbs"
                ),
            )
        else:
            inverts, reason = None, f"the averaged flow has not ended by t = {t[-1]:.3g} s"
    elif kind == "inverted":
        inverts, reason = (True, "inverts") if math.isfinite(t_half) else (None, "")
        if inverts is None:
            reason = f"the averaged flow does not reach pi/2 by t = {t[-1]:.3g} s"
    else:
        inverts, reason = False, _end_reason(top, theta_end)
    t_start = 0.0 if esc.amplitude >= theta0 else math.log(theta0 / esc.amplitude) / esc.growth_rate
    return InversionPrediction(
        inverts=inverts,
        reason=reason,
        method="averaged",
        t_start=t_start,
        t_half=t_half,
        t_inv=t_end,
        tol=tol,
        t=np.asarray(t),
        theta=np.asarray(theta),
        D=np.asarray(D),
        E_mod=np.asarray(E_mod),
        lam=np.asarray(lams),
        theta_end=theta_end,
        validity=validity(eps, extra),
        t_lift=t_lift,
    )


def atlas(
    top: TippeTop,
    mu: ArrayLike,
    omega3: ArrayLike,
    laws: Sequence[str] = ("viscous",),
    *,
    theta0: float = 0.1,
    cm_at_rest: bool = True,
    eps: float = 0.01,
    contensou_radius: float = 5e-4,
    hops: bool = True,
    start: str = "auto",
) -> dict[str, dict[str, np.ndarray]]:
    """Predicted inversion times over a grid of friction coefficients and spins, per law.

    Parameters
    ----------
    top : TippeTop
    mu, omega3 : array_like
        1-D grids: friction coefficients (s/m for "viscous", dimensionless for the Coulomb laws)
        and initial spins (rad/s, > 0).
    laws : sequence of {"viscous", "regularised-coulomb", "coulomb", "coulomb-contensou"}
        The laws; "regularised-coulomb" uses the regularisation velocity ``eps`` (m/s),
        "coulomb-contensou" the contact-disc radius ``contensou_radius`` (m) with uniform pressure
        (r* = 2/3 r, :class:`~mett.friction.Coulomb`).
    theta0 : float, default 0.1
        Initial inclination (rad).
    cm_at_rest : bool, default True
        Start with the centre of mass at rest (else the contact point at rest).
    eps : float, default 0.01
        Regularisation velocity (m/s) of "regularised-coulomb", > 0.
    contensou_radius : float, default 5e-4
        Contact-disc radius r (m) of "coulomb-contensou", > 0.
    hops : bool, default True
        Passed to :func:`predict_inversion`: follow the hopping top after a predicted lift-off
        (0.1–1 s per such point).
    start : {"auto", "linear"}, default "auto"
        Passed to :func:`predict_inversion`: the resolved start of a large tilt (viscous law,
        3–25 ms more per point, growing with ω3) or the linear split always. With
        ``start="linear", hops=False`` every point costs ~1 ms (Coulomb–Contensou: 20–100 ms).

    Returns
    -------
    dict
        law → {"t_half", "t_inv" (s, inf where it does not invert), "inverts" (1, 0, or -1 where
        the reduction cannot tell, e.g. Contensou arriving below λ_thres), "outside" (the
        verified-range flag), "lam_end" (λ at the end of the slow path over λ(0): below 1 only
        under Coulomb–Contensou, whose drilling torque lowers λ; nan without a path)}, arrays of
        shape (len(mu), len(omega3)).

    Notes
    -----
    Each point is one :func:`predict_inversion` (about 1 ms for the viscous law, a few to 25 ms
    more where ``start="auto"`` resolves a large tilt's start, 20–100 ms for Coulomb–Contensou,
    whose slow flow is an ODE in (θ, λ), 0.1–1 s where the top is predicted to hop before π/2
    and ``hops`` is True). docs/theory/inversion.md#the-friction-law-atlas-which-law-inverts-which-top-and-when
    reads the atlas of the thesis top.
    """
    mus = np.atleast_1d(np.asarray(mu, dtype=float))
    spins = np.atleast_1d(np.asarray(omega3, dtype=float))
    if mus.ndim != 1 or spins.ndim != 1 or not (mus.size and spins.size):
        raise ValueError("mu and omega3 must be non-empty 1-D grids")
    known = ("viscous", "regularised-coulomb", "coulomb", "coulomb-contensou")
    for name in laws:
        if name not in known:
            raise ValueError(f"laws must be among {known}; got {name!r}")
    _check_options(hops, start)
    if "regularised-coulomb" in laws:
        eps = _validate.positive_scalar("eps", eps)
    if "coulomb-contensou" in laws:
        contensou_radius = _validate.positive_scalar("contensou_radius", contensou_radius)
    out = {}
    for name in laws:
        shape = (mus.size, spins.size)
        res = {k: np.full(shape, np.inf) for k in ("t_half", "t_inv")}
        res["inverts"] = np.zeros(shape)
        res["outside"] = np.zeros(shape, dtype=bool)
        res["lam_end"] = np.full(shape, np.nan)
        for i, m in enumerate(mus):
            law: FrictionLaw
            if name == "viscous":
                law = Viscous(m)
            elif name == "regularised-coulomb":
                law = RegularisedCoulomb(m, eps)
            elif name == "coulomb":
                law = Coulomb(m)
            else:
                law = Coulomb(m, contensou_radius=contensou_radius)
            for j, w in enumerate(spins):
                if cm_at_rest:
                    st = State.with_cm_at_rest(top, theta=theta0, omega3=w)
                else:
                    st = State(theta=theta0, omega3=w)
                p = predict_inversion(top, st, law, hops=hops, start=start)
                res["t_half"][i, j] = p.t_half
                res["t_inv"][i, j] = p.t_inv if p.inverts else math.inf
                res["inverts"][i, j] = -1 if p.inverts is None else float(p.inverts)
                res["outside"][i, j] = p.validity.outside_verified_range
                if len(p.lam):
                    res["lam_end"][i, j] = float(p.lam[-1]) / float(p.lam[0])
        out[name] = res
    return out
