"""The top with a stem under dry friction: the registered models "stemmed-coulomb" and
"stemmed-coulomb-contensou" (docs/theory/stem.md#dry-friction).

``mett.simulate(top.with_stem(...), state, t_end, friction=Coulomb(...))`` runs this hybrid model
(the one :meth:`mett.friction.Coulomb.model_for` names for "stemmed", :mod:`.stem`). It is the
stemmed top of :mod:`.stem` (state: that of :mod:`.stickslip`, with the Jellett integral of the
sphere in contact in place of L_z, plus the contact flag ``y[10]``, 0 ball, 1 stem) with the
exact stick–slip of :mod:`.stickslip` on whichever sphere touches: four phases, the contact ×
the friction phase,

    "ball-sliding", "ball-rolling", "stem-sliding", "stem-rolling".

Every equation of a phase is stickslip's, called through its public contact interface with the
geometry of the sphere in contact: stickslip's parameter tuple ``(m, R, l, I1, I3, mu, g, r*,
eps, law, δ)`` with (R, l) for the ball and (r_s, l + l_s) for the stem sphere (a = l 3̂ − R ẑ in
both). So within a contact everything of stickslip holds: sliding F_t = −μ g_n v̂_A, rolling while
the required force is inside the cone, the "stop", "reversal" and "cone" switches with their
impulses, λ of the contact sphere conserved by Coulomb (not by Contensou's torque).

The change of contact (touchdown, ball → stem; landing, stem → ball; the clearances of
:mod:`.stem`) is an impact, here with the dry law: **perfectly inelastic Darboux–Keller impact
with Coulomb (Coulomb–Contensou) friction in impulse form** (:func:`dry_impulse`). With the
normal impulse p as the time-like variable of the collision, the generalised impulse
Π = (P_x, P_y, P_z, Q/r*) follows

    dΠ_t = −μ γ̂ dp  while γ ≠ 0,   dΠ_z = dp,   dg = W_g dΠ,

g = (v_x, v_y, v_z, r* ω_z) the generalised velocity of the new contact point (without Contensou
the 3-vectors v, P), W_g the generalised Delassus matrix (positive definite), until v_z = 0 (no
restitution). If the slip γ vanishes during the impact the contact sticks for the rest of it when
the impulse that sticking needs lies in the cone (|Π_t| ≤ μ Π_z), else slip restarts opposite to
the tangential part of that impulse. The energy changes by ∫ (v_z − μ|γ|) dp ≤ 0 (v_z < 0 during
compression); the new contact's Jellett integral −L·a is unchanged (an impulse at the contact
point has no moment about it: (a × P)·a = 0; Contensou's Q changes it as its torque does); the
normal velocity of the new contact is 0 afterwards. The friction phase after the impact is
chosen by the slip it leaves (:func:`mett.dynamics.contact.settle`): a slip within the stopping
band (a sticking impact) starts rolling if the cone holds, else sliding.

The trajectory (``Model.finish``) carries ``contact`` ("ball"/"stem") and ``phase``
("sliding"/"rolling") per sample, the contact force ``F_x``, ``F_y``, ``M_n``, ``margin`` and
``gn`` of each sample's contact and phase, ``touchdowns`` and ``switches``
(:class:`mett.dynamics.stickslip.Switch` records; reason "stop", "cone", "reversal",
"touchdown" or "landing"; for an impact ``margin`` is that of the impulse, (μ P_n − |Π_t|)/(μ P_n),
≥ 0, 0 for an impact that slides in one direction throughout, and ``slip`` the new contact's |γ|
just after it).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np
from scipy.integrate import solve_ivp

from ..friction import Coulomb
from . import _params as ix
from . import contact as dry
from . import stem, stickslip
from .contact import (
    cone_event,
    cone_jump,
    reversal_event,
    reversal_jump,
    rolling_contact,
    slide_law,
    sliding_contact,
    stick,
    stop_event,
    stop_jump,
)
from .registry import (
    Event,
    JumpFailed,
    Model,
    Option,
    Phase,
    friction_law,
    positive_length,
    register,
)
from .stem import apply_impulse, ball_clearance, impact_frame, stem_clearance

__all__ = ["CONTENSOU", "MODEL", "dry_impulse", "impact"]

# p = (m, R, l, I1, I3, mu, g, r_star, eps, law, delta, r_s, l_s): stickslip's tuple of the ball,
# then the stem geometry


def _ball(p: Any) -> tuple:
    """stickslip's parameters of the ball contact: (R, l)."""
    return (p[ix.M], p[ix.R], p[ix.L], p[ix.I1], p[ix.I3], p[ix.MU], p[ix.G],
            p[ix.RSTAR], p[ix.EPS], p[ix.LAW], p[ix.BAND])  # fmt: skip


def _stem(p: Any) -> tuple:
    """stickslip's parameters of the stem contact: (r_s, l + l_s)."""
    return (p[ix.M], p[ix.DRY_R_S], p[ix.L] + p[ix.DRY_L_S], p[ix.I1], p[ix.I3], p[ix.MU], p[ix.G],
            p[ix.RSTAR], p[ix.EPS], p[ix.LAW], p[ix.BAND])  # fmt: skip


def _contact(p: tuple, on_stem: bool) -> tuple:
    return _stem(p) if on_stem else _ball(p)


def _viscous(p: tuple) -> tuple:
    """The "stemmed" model's parameters (m, R, l, I1, I3, μ = 0, g, r_s, l_s): its geometry."""
    return (
        p[ix.M],
        p[ix.R],
        p[ix.L],
        p[ix.I1],
        p[ix.I3],
        0.0,
        p[ix.G],
        p[ix.DRY_R_S],
        p[ix.DRY_L_S],
    )


# --- the phases: stickslip's equations on each contact (compiled from this source) -------------


def _write(d: Any, out: Any) -> None:
    out[0], out[1], out[2], out[3], out[4] = d[0], d[1], d[2], d[3], d[4]
    out[5], out[6], out[7], out[8], out[9] = d[5], d[6], d[7], d[8], d[9]
    out[10] = 0.0  # the contact flag changes only at an impact


def _ball_sliding_into(t: float, y: Any, p: Any, out: Any) -> None:
    _write(slide_law(y, _ball(p))[0], out)


def _ball_rolling_into(t: float, y: Any, p: Any, out: Any) -> None:
    _write(stick(y, _ball(p))[0], out)


def _stem_sliding_into(t: float, y: Any, p: Any, out: Any) -> None:
    _write(slide_law(y, _stem(p))[0], out)


def _stem_rolling_into(t: float, y: Any, p: Any, out: Any) -> None:
    _write(stick(y, _stem(p))[0], out)


def _python(into: Any) -> Any:
    """The reference right-hand side ``rhs(t, y, p)`` of a phase: ``into`` on Python floats."""

    def rhs(t: float, y: np.ndarray, p: tuple) -> np.ndarray:
        out = np.empty(len(y))
        into(t, y.tolist() if np.ndim(y) == 1 else y, p, out)
        return out

    rhs.__name__ = rhs.__qualname__ = into.__name__.strip("_").replace("_into", "_rhs")
    rhs.__doc__ = f"Right-hand side of phase {rhs.__name__[:-4].replace('_', '-')!r}."
    return rhs


def _ball_sliding_contact(t: float, y: Any, p: Any) -> Any:
    return sliding_contact(t, y, _ball(p))


def _ball_rolling_contact(t: float, y: Any, p: Any) -> Any:
    return rolling_contact(t, y, _ball(p))


def _stem_sliding_contact(t: float, y: Any, p: Any) -> Any:
    return sliding_contact(t, y, _stem(p))


def _stem_rolling_contact(t: float, y: Any, p: Any) -> Any:
    return rolling_contact(t, y, _stem(p))


def _ball_stop(t: float, y: Any, p: Any) -> Any:
    return stop_event(t, y, _ball(p))


def _stem_stop(t: float, y: Any, p: Any) -> Any:
    return stop_event(t, y, _stem(p))


def _ball_reversal(t: float, y: Any, p: Any) -> Any:
    return reversal_event(t, y, _ball(p))


def _stem_reversal(t: float, y: Any, p: Any) -> Any:
    return reversal_event(t, y, _stem(p))


def _ball_cone(t: float, y: Any, p: Any) -> Any:
    return cone_event(t, y, _ball(p))


def _stem_cone(t: float, y: Any, p: Any) -> Any:
    return cone_event(t, y, _stem(p))


def _touchdown(t: float, y: Any, p: Any) -> Any:
    """Stem clearance while the ball touches (:func:`mett.dynamics.stem.stem_clearance`)."""
    return stem_clearance(y, p[ix.R], p[ix.DRY_R_S], p[ix.DRY_L_S])


def _landing(t: float, y: Any, p: Any) -> Any:
    """Ball clearance while the stem touches (:func:`mett.dynamics.stem.ball_clearance`)."""
    return ball_clearance(y, p[ix.R], p[ix.DRY_R_S], p[ix.DRY_L_S])


# --- the jumps ---------------------------------------------------------------------------------


def _on_ball(jump: Any) -> Any:
    return lambda y, p: jump(y, _ball(p))


def _on_stem(jump: Any) -> Any:
    return lambda y, p: jump(y, _stem(p))


def dry_impulse(f: stem.ImpactFrame, m: float, mu: float, r_star: float) -> tuple:
    """(P, Q, stuck): the impulse P (N s) and drilling impulse Q (N m s) of the perfectly inelastic
    Darboux–Keller impact with Coulomb (r* = 0) or Coulomb–Contensou (r* > 0) friction, and
    whether the contact stuck during it (module docstring).

    Raises :class:`~mett.dynamics.registry.JumpFailed` if the impulse equations cannot be solved.
    """
    if mu == 0.0:  # frictionless: the normal impulse that ends the compression, nothing else
        return np.array([0.0, 0.0, -f.v[2] / f.W[2, 2]]), 0.0, False
    k = 4 if r_star > 0.0 else 3
    tang = [0, 1, 3] if k == 4 else [0, 1]

    def response(Pi: np.ndarray) -> np.ndarray:
        """Δg of the generalised impulse Π (Δv = P/m + Δω × a, Δω = I⁻¹(a × P + Q ẑ))."""
        Q = r_star * Pi[3] if k == 4 else 0.0
        dw = f.Iinv @ (np.cross(f.a, Pi[:3]) + np.array([0.0, 0.0, Q]))
        dv = Pi[:3] / m + np.cross(dw, f.a)
        return np.append(dv, r_star * dw[2]) if k == 4 else dv

    Wg = np.column_stack([response(col) for col in np.eye(k)])
    g0 = np.append(f.v, r_star * f.w[2]) if k == 4 else np.array(f.v, dtype=float)
    scale = max(float(np.max(np.abs(g0))), 1e-300)
    eta = 1e-9 * scale  # the slip below which the contact counts as stuck

    def rate(_: float, z: np.ndarray) -> np.ndarray:
        gt = z[tang]
        dPi = np.zeros(k)
        dPi[2] = 1.0
        dPi[tang] = -mu * gt / np.linalg.norm(gt)
        return np.concatenate((Wg @ dPi, dPi))

    def normal(_: float, z: np.ndarray) -> float:
        return z[2]

    def stops(_: float, z: np.ndarray) -> float:
        return float(np.linalg.norm(z[tang])) - eta

    normal.terminal, normal.direction = True, 1.0  # type: ignore[attr-defined]
    stops.terminal, stops.direction = True, -1.0  # type: ignore[attr-defined]
    z = np.concatenate((g0, np.zeros(k)))
    stuck = False
    p0, p1 = 0.0, 10.0 * -g0[2] / Wg[2, 2]
    for _ in range(60):
        if np.linalg.norm(z[tang]) <= eta:  # sticking: the impulse that ends the impact stuck
            Pi_rest = np.linalg.solve(Wg, -z[:k])
            if Pi_rest[2] >= 0.0 and np.linalg.norm(Pi_rest[tang]) <= mu * Pi_rest[2]:
                z = np.concatenate((np.zeros(k), z[k:] + Pi_rest))
                stuck = True
                break
            # outside the cone: the slip restarts (2η) opposite to that impulse's tangential part
            u = np.zeros(k)
            u[tang] = -Pi_rest[tang] / np.linalg.norm(Pi_rest[tang])
            dPi = np.linalg.solve(Wg, 2.0 * eta * u - np.where(np.isin(range(k), tang), z[:k], 0))
            z = np.concatenate((z[:k] + Wg @ dPi, z[k:] + dPi))
        sol = solve_ivp(
            rate,
            (p0, p1),
            z,
            method="DOP853",
            events=(normal, stops),
            rtol=1e-13,
            atol=1e-15 * (1.0 + scale),
        )
        if sol.status == -1:
            raise JumpFailed(f"impact: the impulse equations could not be solved ({sol.message})")
        if sol.status == 1 and sol.t_events[0].size:
            z = sol.y_events[0][0]
            break
        if sol.status == 1:  # the slip reached the band: stick or restart (above)
            z, p0 = sol.y_events[1][0], float(sol.t_events[1][0])
        else:  # the impact goes on (friction can drive the contact down first)
            z, p0, p1 = sol.y[:, -1], p1, 10.0 * p1
    else:
        raise JumpFailed("impact: the impulse equations did not reach the end of compression")
    Pi = z[k:]
    return Pi[:3], (r_star * Pi[3] if k == 4 else 0.0), stuck


def impact(y: np.ndarray, p: tuple, to: str) -> tuple[np.ndarray, np.ndarray, float]:
    """State after the dry-friction impact of the contact ``to`` ("ball" or "stem"), the impulse
    P (N s) and the drilling impulse Q (N m s); ``y`` the state just before, ``p`` this model's
    parameters."""
    y = _lz(y, p)  # λ of the old contact → L (the impact changes L, and with it λ of the old one)
    f = impact_frame(y, _viscous(p), to)
    if f.v[2] >= 0.0:  # arrives without a downward velocity: nothing to stop
        P, Q = np.zeros(3), 0.0
    else:
        P, Q, _ = dry_impulse(f, p[ix.M], p[ix.MU], p[ix.RSTAR])
    after = apply_impulse(y, f, p[ix.M], P, to, Q)  # on the new contact (its flag set)
    return _converted(after, p, dry.from_gliding), P, Q


def _contact_changes(switches: Any) -> list[float]:
    """Times (s) of the changes of contact (impacts) among the run's switches (time, from, to)."""
    return [t for t, a, b in switches if a.split("-")[0] != b.split("-")[0]]


def _impact_to(to: str) -> Any:
    """The jump of a change of contact: the impact, then the slip settled on the new contact.

    Impacts that accumulate (:func:`mett.dynamics.stem.accumulation`) would settle the top onto
    both spheres at once, a double contact that this dry-friction model does not continue: the
    run ends there with status "failed" and that reason, the trajectory up to it kept (never a
    "completed" over thousands of chattering impacts).
    """

    def jump(y: np.ndarray, p: tuple, switches: Any = ()) -> np.ndarray:
        acc = stem.accumulation(_contact_changes(switches))
        if acc is not None:
            raise JumpFailed(
                f"impacts accumulate (ratio {acc.ratio:.3g}, limit t = {acc.t_limit:.9g} s): the "
                "top settles onto ball and stem at once, a double contact that the dry-friction "
                "stemmed model does not continue"
            )
        return dry.settle(impact(y, p, to)[0], _contact(p, to == "stem"))

    return jump


def _select(y: np.ndarray, p: tuple) -> str:
    """The phase after an impact: the new contact, rolling if its slip was settled."""
    on_stem = y[10] > 0.5
    return ("stem-" if on_stem else "ball-") + dry.start_phase(y, _contact(p, on_stem))


# --- conversions and the trajectory's series ---------------------------------------------------


def _converted(Y: Any, p: tuple, convert: Any) -> np.ndarray:
    """``convert`` (:func:`~mett.dynamics.contact.to_gliding` or ``from_gliding``) applied to
    each state of ``Y`` (shape (11,) or (11, k)) with the geometry of its own contact."""
    Y = np.asarray(Y, dtype=float)
    if Y.ndim == 1:
        return convert(Y, _contact(p, Y[10] > 0.5))
    out = Y.copy()
    on = Y[10] > 0.5
    for mask, q in ((~on, _ball(p)), (on, _stem(p))):
        if mask.any():
            out[:, mask] = convert(Y[:, mask], q)
    return out


def _lz(Y: Any, p: tuple) -> np.ndarray:
    """The states of the viscous stemmed model (:mod:`.stem`: L_z in row 6) of states ``Y``."""
    return _converted(Y, p, dry.to_gliding)


def _params(top: Any, options: dict) -> tuple:
    pv = stem.stem_params(top, options)  # validates the stem geometry
    return (*stickslip.MODEL.params(top, options), pv[ix.R_S], pv[ix.L_S])


def _initial(state: Any, p: tuple) -> np.ndarray:
    """The stemmed state on the lower sphere; a slip within the band settled there."""
    y = _converted(stem.MODEL.initial(state, _viscous(p)), p, dry.from_gliding)
    return dry.settle(y, _contact(p, y[10] > 0.5))


def _rolling(Y: np.ndarray, p: tuple, on_stem: np.ndarray) -> np.ndarray:
    """Where the phase is not stored: rolling where the slip is within the band and the cone holds."""
    out = np.zeros(on_stem.shape, dtype=bool)
    for mask, q in ((~on_stem, _ball(p)), (on_stem, _stem(p))):
        if mask.any():
            out[mask] = dry.rolling_guess(Y[:, mask], q)
    return out


def _quantities(Y: np.ndarray, p: tuple, rolling: np.ndarray) -> dict[str, np.ndarray]:
    """stickslip's contact series of each sample's contact and phase (each with the geometry of
    its own contact: row 6 is that contact's λ)."""
    Y = np.asarray(Y, dtype=float).reshape(11, -1)
    rolling = np.broadcast_to(np.asarray(rolling, dtype=bool), Y.shape[1:])
    on = Y[10] > 0.5
    out: dict[str, np.ndarray] = {}
    for mask, q in ((~on, _ball(p)), (on, _stem(p))):
        if mask.any():
            part = dry.contact_quantities(Y[:, mask], q, rolling[mask])
            for k, v in part.items():
                out.setdefault(k, np.empty(Y.shape[1], dtype=np.asarray(v).dtype))[mask] = v
    return out


def _normal_force(y: np.ndarray, p: tuple) -> Any:
    Y = np.asarray(y, dtype=float)
    Y2 = Y.reshape(11, -1)
    gn = _quantities(Y2, p, _rolling(Y2, p, Y2[10] > 0.5))["gn"]
    return gn.reshape(Y.shape[1:])


def _derive(Y: np.ndarray, p: tuple) -> dict[str, np.ndarray]:
    """The stemmed model's series of each sample's contact (E, λ, ν, …), with the dry g_n."""
    out = stem.MODEL.derive(_lz(Y, p), _viscous(p))
    out["gn"] = _normal_force(np.asarray(Y, dtype=float), p)
    return out


def _scales(y0: np.ndarray, p: tuple) -> np.ndarray:
    sc = np.array(stem.MODEL.scales(_lz(y0, p), _viscous(p)), dtype=float)
    sc[6] *= p[ix.R]  # λ = −L·a: the momentum scale times R
    return sc


def _start_phase(y0: np.ndarray, p: tuple) -> str:
    return _select(y0, p)


_REASONS = {
    ("sliding", "rolling"): "stop",
    ("rolling", "sliding"): "cone",
    ("sliding", "sliding"): "reversal",
}


def _finish(traj: Any) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """``contact``, ``phase``, the force series, ``touchdowns`` and the switch records
    (``Model.finish``)."""
    p = traj.params
    names = np.asarray(traj.phase).astype(str)
    contact = np.array([n.split("-")[0] for n in names.tolist()], dtype=object).astype(str)
    phase = np.array([n.split("-")[1] for n in names.tolist()], dtype=object).astype(str)
    series = {"contact": contact, "phase": phase}
    series.update(_quantities(traj.states, p, phase == "rolling"))
    records = []
    for (t, before, after), (y_ev, _) in zip(traj.switches, traj.jumps, strict=True):
        c0, f0 = before.split("-")
        c1, f1 = after.split("-")
        q = _contact(p, c1 == "stem")
        if c0 != c1:
            why = "touchdown" if c1 == "stem" else "landing"
            y_imp, P, Q = impact(y_ev, p, c1)
            Pt = (
                math.hypot(P[0], P[1], Q / p[ix.RSTAR])
                if p[ix.RSTAR] > 0.0
                else math.hypot(P[0], P[1])
            )
            mu_pn = p[ix.MU] * P[2]  # no cone (NaN) without a normal impulse or at μ = 0
            margin = (mu_pn - Pt) / mu_pn if mu_pn > 0.0 else math.nan
            speed = float(np.linalg.norm(dry.slip(y_imp, q)))
        else:
            why = _REASONS[(f0, f1)]
            y_dec = y_ev if why == "cone" else dry.set_slip(y_ev, q, np.zeros(3))
            gn, _, m = dry.required(y_dec, q)
            margin = float(m / (p[ix.MU] * gn)) if p[ix.MU] > 0.0 else math.nan
            speed = float(np.linalg.norm(dry.slip(y_ev, q)))
        t_sw = dry.stop_time(t, y_ev, q) if why in ("stop", "reversal") else t
        records.append(stickslip.Switch(t_sw, before, after, why, float(margin), speed, t))
    touchdowns = np.array([s.t for s in records if s.reason == "touchdown"])
    return series, {"switches": records, "touchdowns": touchdowns, "stopping_band": p[ix.BAND]}


PHASES = ("ball-sliding", "ball-rolling", "stem-sliding", "stem-rolling")

_TOUCHDOWN = Event(
    _touchdown,
    -1.0,
    "switch",
    target="stem-sliding",
    jump=_impact_to("stem"),
    select=_select,
    history=True,
)
_LANDING = Event(
    _landing,
    -1.0,
    "switch",
    target="ball-sliding",
    jump=_impact_to("ball"),
    select=_select,
    history=True,
)

MODEL = register(
    Model(
        name="stemmed-coulomb",
        summary=(
            "tippe top with a spherical stem under Coulomb dry friction, exact stick–slip on the "
            "ball or the stem, Darboux–Keller impacts with Coulomb friction at the change of "
            "contact (docs/theory/stem.md#dry-friction; Leine & Glocker 2003)"
        ),
        rhs=_python(_ball_sliding_into),
        rhs_into=_ball_sliding_into,
        normal_force=_normal_force,
        params=_params,
        initial=_initial,
        derive=_derive,
        theta=stem.MODEL.theta,
        scales=_scales,
        conserved_lengths=((7, 8, 9),),
        events=(
            Event(_ball_sliding_contact, -1.0, "contact_lost"),
            Event(_ball_stop, -1.0, "switch", target="ball-rolling", jump=_on_ball(stop_jump)),
            Event(
                _ball_reversal, -1.0, "switch", target="ball-sliding", jump=_on_ball(reversal_jump)
            ),
            _TOUCHDOWN,
        ),
        options=(
            Option("friction", friction_law, None, "the Coulomb law"),
            Option("stopping_band", positive_length, None, "slip speed (m/s) of the stop"),
            stem.STEM_RADIUS,
            stem.STEM_DISTANCE,
        ),
        friction=(Coulomb,),
        phase="ball-sliding",
        phases=(
            Phase(
                "ball-rolling",
                _python(_ball_rolling_into),
                _ball_rolling_into,
                (
                    Event(_ball_rolling_contact, -1.0, "contact_lost"),
                    Event(
                        _ball_cone,
                        -1.0,
                        "switch",
                        target="ball-sliding",
                        jump=_on_ball(cone_jump),
                        grazing=True,
                    ),
                    _TOUCHDOWN,
                ),
            ),
            Phase(
                "stem-sliding",
                _python(_stem_sliding_into),
                _stem_sliding_into,
                (
                    Event(_stem_sliding_contact, -1.0, "contact_lost"),
                    Event(
                        _stem_stop, -1.0, "switch", target="stem-rolling", jump=_on_stem(stop_jump)
                    ),
                    Event(
                        _stem_reversal,
                        -1.0,
                        "switch",
                        target="stem-sliding",
                        jump=_on_stem(reversal_jump),
                    ),
                    _LANDING,
                ),
            ),
            Phase(
                "stem-rolling",
                _python(_stem_rolling_into),
                _stem_rolling_into,
                (
                    Event(_stem_rolling_contact, -1.0, "contact_lost"),
                    Event(
                        _stem_cone,
                        -1.0,
                        "switch",
                        target="stem-sliding",
                        jump=_on_stem(cone_jump),
                        grazing=True,
                    ),
                    _LANDING,
                ),
            ),
        ),
        start_phase=_start_phase,
        finish=_finish,
    )
)
"""The stemmed top under Coulomb friction (``friction=Coulomb(mu)``): λ of the contact sphere
conserved within each contact (no torque about the normal), changed by nothing at an impact."""

CONTENSOU = register(
    dataclasses.replace(
        MODEL,
        name="stemmed-coulomb-contensou",
        summary=(
            "tippe top with a spherical stem under Coulomb–Contensou dry friction (a contact "
            "disc), exact stick–slip on the ball or the stem, Darboux–Keller impacts "
            "(docs/theory/stem.md#dry-friction; Leine & Glocker 2003)"
        ),
    )
)
"""The stemmed top under Coulomb–Contensou friction (``friction=Coulomb(mu, contensou_radius=r)``,
r > 0): the same equations with the drilling torque and impulse."""
