"""Dry friction integrated exactly: the registered models "coulomb" and "coulomb-regularised".

``mett.simulate(top, state, t_end, friction=Coulomb(...))`` runs the hybrid model ``"coulomb"``
(Coulomb and Coulomb–Contensou stick–slip, phases "sliding" and "rolling"), and
``friction=RegularisedCoulomb(...)`` the single-phase model ``"coulomb-regularised"``; both are
ordinary registered models (:mod:`.registry`): compiled DOP853 by default (the phase right-hand
sides and event functions below are plain float arithmetic, compiled by :mod:`._kernels`), scipy
on request, user events allowed.

The state is that of the ``"gliding"`` model (:mod:`.gliding`) with the Jellett integral in place
of L_z, ``y = [x, y, ẋ, ẏ, L_x, L_y, λ, 3̂_x, 3̂_y, 3̂_z]``, λ = −L·a, L_z = −(λ + L_x a_x + L_y a_y)/a_z
(a_z = l cos θ − R < 0), and the equations are those of the eccentric sphere under a contact force
F = (F_t, g_n) and a torque M ẑ about the normal at the contact point A (Rutstam 2012 §2):

    m r̈ = F − m g ẑ,    L̇ = a × F + M ẑ,    3̂̇ = ω × 3̂,    a = l 3̂ − R ẑ.

The acceleration of the material contact point v_A = ṙ + ω × a is affine in the contact wrench,

    v̇_A = G F + M (J⁻¹ẑ) × a + h,    G F = F/m + (J⁻¹(a × F)) × a,
    h = −g ẑ + (c (L·3̂) 3̂̇) × a + ω × ȧ,    J⁻¹x = x/I1 + c (x·3̂) 3̂,  c = 1/I3 − 1/I1,

with G the symmetric positive definite inverse effective mass of the contact (the Delassus
matrix). The vertical component of v̇_A vanishes (contact), which fixes g_n; then

* **sliding** (:func:`slide_rhs`): F = g_n (f_t, 1), M = g_n f_M with the law per unit normal
  force (Coulomb f_t = −μ v̂_A; Contensou, :mod:`mett.friction`), so g_n = −h_z / (G(f_t, 1) +
  f_M (J⁻¹ẑ) × a)_z;
* **rolling** (stick, :func:`stick_rhs`): v̇_A = 0 in all three components, the linear system
  G F = −h (3×3, Cramer's rule) for the force the rolling constraint needs; it is admissible while
  it lies inside the friction cone, margin μ g_n − |F_t| ≥ 0.

Switching, all by events located by the integrator (:func:`mett.simulate` runs the phases, see
:mod:`.registry`):

* rolling → sliding ("cone") when the cone margin (μ g_n − |F_t|)/(m g) of the required force
  falls through 0. The slip starts opposite to the required tangential force (friction at the
  cone edge equals the required force, so the slip acceleration starts from zero and grows as the
  required force leaves the cone); the switch's ``jump`` gives it the speed 2δ in the excess-force
  direction below.
* sliding → rolling ("stop") when |γ| falls through a stopping band δ (10 rtol × the velocity
  scale, the option ``stopping_band``) with the required force inside the cone: the ``jump``
  removes the remaining O(δ) of slip by the contact impulse P with G P = −v_A (:func:`set_slip`;
  it keeps λ exactly and changes E by −½ v_A·G⁻¹v_A ≤ 0). The slip falls linearly at a finite
  rate there, so the stop itself, recorded as the switch time, is extrapolated δ/a beyond the
  band crossing (:func:`stop_time`); the impulse matches the sliding up to it to O(δ²).
* sliding → sliding ("reversal") when |γ| falls through δ with the required force outside the
  cone: the ``jump`` removes the slip as above and restarts it with |v_A| = 2δ in the direction u
  of the excess force, the solution of s u = v̇_A(u), s > 0 (slip acceleration parallel to the
  slip under the Coulomb force −μ g_n u; a root search, :func:`excess_direction`, in plain
  Python: jumps run between phases). The cone decides between "stop" and "reversal" inside the
  two event functions (:func:`stop_event`, :func:`reversal_event`): each is |γ| − δ plus a
  term that keeps it positive on the wrong side of the cone.
* Coulomb–Contensou: the same phases on the generalised slip γ = (v_A, r* ω_z); stick also holds
  ω̇_z = 0 with the drilling torque M it needs (:func:`_solve_GM`), inside the ellipsoid
  |F_t|² + (M/r*)² ≤ (μ g_n)²; slip restarts opposite to the generalised required force, and the
  impulses at a switch include an angular impulse about ẑ.
* Near v_A = 0 the slip direction is a fast variable (its rate is ~ μ g_n |G| / |v_A|) and the
  explicit integrator's steps shrink with |v_A|: the approach to a stop costs a number of steps
  logarithmic in (initial slip)/δ; a slip that starts at the cone's edge (zero acceleration,
  |v_A| − 2δ ∝ t²) costs ∝ δ^(−1/2) steps (docs/theory/friction.md, "Frequent switching").

μ = 0 (``Coulomb(0.0)``) is a cone of radius 0: frictionless sliding throughout, no switch
(:func:`frictionless`), the same motion as the "gliding" model with μ = 0.

The start (:func:`_initial`, ``start_phase``): a state whose slip is within the band starts
rolling (after the stopping impulse) if the cone holds, else sliding from 2δ in the excess-force
direction. After a run (``Model.finish``, :func:`_finish`) the trajectory carries ``phase``, the
contact force ``F_x``, ``F_y``, ``M_n``, the normal force and the cone ``margin`` of each sample's
phase, and ``switches`` as :class:`Switch` records.

Energy: rolling conserves E, sliding dissipates μ g_n |v_A| ≥ 0, the stopping impulse
½ v_A·G⁻¹v_A = O(m δ²). λ = −L·a is conserved by every force at A without a torque about the
normal: dλ/dt = −(a × F)·a − L·ȧ = 0, since L·(ω × 3̂) = 0 for the symmetric top (Rutstam 2012
§2); so by Coulomb. Contensou's torque M ẑ changes it at the rate dλ/dt = −M (ẑ·a) =
M (R − l cos θ).

Why λ is a state variable: λ is quadratic in (L, 3̂), and a Runge–Kutta method keeps only linear
invariants; integrating L_z instead let λ drift by 2.6e-9 (relative) over 20 s of Coulomb
sliding at rtol = 1e-10 (thesis body, μ = 0.01), through the error of 3̂. With λ in the state its
rate is exactly 0 under Coulomb (M = 0), in sliding, rolling and at the contact impulses, so λ is
kept to the last bit for any length of run; under Contensou it is integrated from its rate.
Nothing is projected: L_z is the same function of the state that λ = −L·a defines.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, NamedTuple

import numpy as np

from ..friction import Coulomb, RegularisedCoulomb
from . import _params as ix
from . import gliding
from .contact import (
    LAW_COULOMB,
    LAW_REGULARISED,
    cone_event,
    cone_jump,
    contact_quantities,
    from_gliding,
    gliding_params,
    normal_force,
    required,
    reversal_event,
    reversal_jump,
    rolling_contact,
    set_slip,
    settle,
    slide_into,
    slide_law,
    slide_rhs,
    sliding_contact,
    slip,
    start_phase,
    stick_into,
    stick_rhs,
    stop_event,
    stop_jump,
    stop_time,
    to_gliding,
)
from .registry import Event, Model, Option, Phase, friction_law, register

__all__ = ["CONTENSOU", "MODEL", "PHASES", "REGULARISED", "Switch", "stopping_band"]

PHASES = ("sliding", "rolling")


# --- the contact mechanics, plain float arithmetic (floats or equal-shape arrays) -------------


# --- the phases: right-hand sides and events (compiled from this source) -----------------------


# --- the jumps at the switches (plain Python, between phases) ---------------------------------


# --- conversions and the trajectory's contact series -------------------------------------------


def _params(top: Any, options: dict) -> tuple:
    law = options["friction"]  # a law of the model's kind (registry.check_friction)
    band = options.get("stopping_band")
    if band is None:  # without an rtol to tie it to: 1e-9 of the velocity scale √(g R)
        band = 1e-9 * math.sqrt(top.g * top.R)
    regularised = isinstance(law, RegularisedCoulomb)
    r_star = 0.0 if regularised else law.r_star
    eps = law.eps if regularised else 0.0
    code = LAW_REGULARISED if regularised else LAW_COULOMB
    l = top.R * top.alpha
    return (top.m, top.R, l, top.I1, top.I3, law.mu, top.g, r_star, eps, code, band)


def _initial(state: Any, p: tuple) -> np.ndarray:
    """The state; a slip within the band is removed (rolling) or restarted (cone)."""
    return settle(from_gliding(gliding.MODEL.initial(state, gliding_params(p)), p), p)


def _derive(Y: np.ndarray, p: tuple) -> dict[str, np.ndarray]:
    Y = np.asarray(Y, dtype=float)
    out = gliding.MODEL.derive(to_gliding(Y, p), gliding_params(p))
    out["gn"] = normal_force(Y, p)
    return out


def _scales(y0: np.ndarray, p: tuple) -> np.ndarray:
    sc = np.array(gliding.MODEL.scales(to_gliding(y0, p), gliding_params(p)), dtype=float)
    sc[6] *= p[ix.R]  # λ = −L·a: the momentum scale times R
    return sc


class Switch(NamedTuple):
    """A change of contact phase of a stick–slip run (``Trajectory.switches``)."""

    t: float
    """Time of the switch (s); for "stop" and "reversal" the instant the slip reaches 0,
    extrapolated from the band crossing ``t_event`` (:func:`stop_time`)."""
    before: str
    """Phase before: "sliding" or "rolling"."""
    after: str
    """Phase after."""
    reason: str
    """"stop" (|v_A| fell to the stopping band, the required force inside the cone), "cone" (the
    required force left the cone) or "reversal" (|v_A| fell to the band with the required force
    outside the cone: sliding restarts in the direction of the excess force)."""
    margin: float
    """Cone margin of the force rolling needs, (μ g_n − |F_t|)/(μ g_n), at the switch state
    (NaN where there is no cone: μ = 0, or an impact without a normal impulse)."""
    slip: float
    """|v_A| (m/s) at the event that triggered the switch."""
    t_event: float = math.nan
    """Time (s) of the located event: the band crossing |γ| = δ of a "stop" or "reversal"
    (``t`` is then the extrapolated instant |γ| = 0, :func:`stop_time`), else ``t``."""


_REASONS = {
    ("sliding", "rolling"): "stop",
    ("rolling", "sliding"): "cone",
    ("sliding", "sliding"): "reversal",
}


def _finish(traj: Any) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """The contact series of a run (``Model.finish``): force and margin of each sample's phase,
    and the switches as :class:`Switch` records (margin after the stopping impulse, slip at the
    event), with the stopping band."""
    p = traj.params
    rolling = np.asarray(traj.phase) == "rolling"
    series = contact_quantities(traj.states, p, rolling)
    records = []
    for (t, before, after), (y_ev, _) in zip(traj.switches, traj.jumps, strict=True):
        why = _REASONS[(before, after)]
        # the cone decision is made at v_A = 0: after the stopping impulse, before a restart
        y_dec = y_ev if why == "cone" else set_slip(y_ev, p, np.zeros(3))
        gn, _, m = required(y_dec, p)
        speed = float(np.linalg.norm(slip(y_ev, p)))
        t_sw = t if why == "cone" else stop_time(t, y_ev, p)
        margin = float(m / (p[ix.MU] * gn)) if p[ix.MU] > 0.0 else math.nan  # no cone at μ = 0
        records.append(Switch(t_sw, before, after, why, margin, speed, t))
    return series, {"switches": records, "stopping_band": p[ix.BAND]}


def stopping_band(top: Any, state: Any, rtol: float) -> float:
    """The stopping band δ (m/s) of a run at ``rtol``: 10 rtol × the velocity scale of the start.

    Below δ the slip is removed by an impulse (module docstring); δ ≫ the integration error of
    v_A, so a located stop is a real one.
    """
    pg = gliding.MODEL.params(top, {})
    y0 = np.asarray(gliding.MODEL.initial(state, pg), dtype=float)
    vscale = float(gliding.MODEL.scales(y0, pg)[2])
    return max(10.0 * rtol, 1e-13) * vscale


def _check_band(name: str, value: Any) -> float:
    from .registry import positive_length

    return positive_length(name, value)


_BAND = Option(
    "stopping_band",
    _check_band,
    None,
    "slip speed (m/s) below which the slip is removed by an impulse; default 10 rtol × R|ω|",
)

MODEL = register(
    Model(
        name="coulomb",
        summary=(
            "tippe top under Coulomb (or Coulomb–Contensou) dry friction, exact stick–slip: "
            "phases sliding and rolling (Rutstam 2012 §2; Leine & Glocker 2003)"
        ),
        rhs=slide_rhs,
        rhs_into=slide_into,
        normal_force=normal_force,
        params=_params,
        initial=_initial,
        derive=_derive,
        theta=gliding.MODEL.theta,
        scales=_scales,
        conserved_lengths=((7, 8, 9),),
        events=(
            Event(sliding_contact, -1.0, "contact_lost"),
            Event(stop_event, -1.0, "switch", target="rolling", jump=stop_jump),
            Event(reversal_event, -1.0, "switch", target="sliding", jump=reversal_jump),
        ),
        options=(Option("friction", friction_law, None, "the Coulomb law"), _BAND),
        friction=(Coulomb,),
        phase="sliding",
        phases=(
            Phase(
                "rolling",
                stick_rhs,
                stick_into,
                (
                    Event(rolling_contact, -1.0, "contact_lost"),
                    Event(
                        cone_event, -1.0, "switch", target="sliding", jump=cone_jump, grazing=True
                    ),
                ),
            ),
        ),
        conserves=("lam",),
        start_phase=start_phase,
        finish=_finish,
    )
)
"""Exact Coulomb stick–slip (``friction=Coulomb(mu)``): λ conserved (no torque about ẑ)."""

CONTENSOU = register(
    dataclasses.replace(
        MODEL,
        name="coulomb-contensou",
        summary=(
            "tippe top under Coulomb–Contensou dry friction (a contact disc), exact stick–slip: "
            "phases sliding and rolling (Leine & Glocker 2003)"
        ),
        conserves=(),
    )
)
"""Coulomb–Contensou stick–slip (``friction=Coulomb(mu, contensou_radius=r)``, r > 0): the same
equations as :data:`MODEL` with the drilling torque, which changes λ (module docstring)."""


def _finish_regularised(traj: Any) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """Force series of a regularised run (one phase, "sliding"; ``Model.finish``)."""
    return contact_quantities(traj.states, traj.params, False), {"switches": []}


REGULARISED = register(
    Model(
        name="coulomb-regularised",
        summary="tippe top under regularised Coulomb friction μ g_n v_A/√(|v_A|² + ε²) (stiff)",
        rhs=slide_rhs,
        rhs_into=slide_into,
        normal_force=lambda y, p: slide_law(y, p)[1],
        params=_params,
        initial=lambda state, p: from_gliding(gliding.MODEL.initial(state, gliding_params(p)), p),
        derive=_derive,
        theta=gliding.MODEL.theta,
        scales=_scales,
        conserved_lengths=((7, 8, 9),),
        events=(Event(sliding_contact, -1.0, "contact_lost"),),
        options=(Option("friction", friction_law, None, "the regularised law"),),
        friction=(RegularisedCoulomb,),
        conserves=("lam",),
        finish=_finish_regularised,
    )
)
"""The regularised law (``friction=RegularisedCoulomb(...)``), one smooth stiff right-hand side."""
