"""A tippe top with a stem, simulated through the change of contact (docs/theory/stem.md).

The body is one rigid body whichever sphere touches the plane; only the contact vector differs
(mett's convention: 3̂ points from the CM G towards the ball's centre, θ = angle(3̂, ẑ)):

    ball:  a   = l 3̂ − R ẑ,                 l = αR,
    stem:  a_s = (l + l_s) 3̂ − r_s ẑ       (stem centre at G + (l + l_s) 3̂).

So each phase is the gliding vector form (:mod:`mett.dynamics.gliding`) with (R, l) or
(r_s, l + l_s). The state is the gliding state plus a phase flag ``y[10]`` (0: ball, 1: stem; its
rate is 0), so that every sample says which constraint fixes the CM height and vertical velocity
(the two agree in position at the switch, not in velocity).

Switches (hybrid model, :mod:`mett.dynamics.registry`):

* touchdown, ball → stem: the stem clearance R + l_s 3̂_z − r_s falls through 0;
* landing, stem → ball: the ball clearance r_s − l_s 3̂_z − R falls through 0.

The new contact arrives with a downward normal velocity, so the switch is an impact. Impact law
(Darboux–Keller, perfectly inelastic): the normal impulse p grows from 0 and the tangential
impulse follows the viscous law in impulse form, dP = (ẑ − μ v_t) dp, v_t the horizontal velocity
of the new contact point; the contact-point velocity then obeys the linear ODE
dv/dp = W (ẑ − μ v_t), W = 𝟙/m − [a×] I⁻¹ [a×], integrated until the normal velocity v_z reaches 0
(restitution e = 0: the end of compression). Energy changes by ∫ (v_z − μ|v_t|²) dp ≤ 0 (v_z < 0
during compression). Momentum and angular momentum about G change by P and a × P.

Under dry friction (``friction=Coulomb(...)``) the model "stemmed-coulomb" of :mod:`.stemslip`
runs instead: the same geometry, clearances and impact frame, with stick–slip phases and the
Coulomb law in the impulse equations.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

from ..friction import Coulomb, Viscous
from . import _params as ix
from ._model import lab_vectors, scales_from_state, unit_axis
from .gliding import gliding_core, gliding_series
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

__all__ = [
    "MODEL",
    "ImpactFrame",
    "apply_impulse",
    "ball_clearance",
    "darboux_keller",
    "impact",
    "impact_frame",
    "stem_clearance",
    "stem_params",
]

N_STATE = 11

SWITCH_OFFSET = 1e-11
"""A switch fires when the other sphere's clearance reaches −SWITCH_OFFSET·R (0.15 pm for
R = 15 mm; θ moves by about 1e-11 rad). A phase thus starts with its switch function at
+2·SWITCH_OFFSET, not at a rounding-level 0 of either sign: a zero at a phase's start is no event,
so a contact that bounces back within the first step would otherwise be missed."""


def stem_params(top: Any, options: dict) -> tuple:
    """(m, R, l, I1, I3, mu, g, r_s, l_s): the ball's gliding parameters and the stem geometry."""
    r_s, l_s = options["stem_radius"], options["stem_distance"]
    if r_s is None or l_s is None:
        raise ValueError("model 'stemmed' needs stem_radius and stem_distance (m), e.g. "
                         "simulate(top.with_stem(radius, distance), ...)")  # fmt: skip
    if not abs(top.R - r_s) < l_s:
        raise ValueError(
            f"stem_distance must exceed |R - stem_radius| = {abs(top.R - r_s)!r} m; got {l_s!r}"
        )
    return (top.m, top.R, top.R * top.alpha, top.I1, top.I3, top.mu, top.g, r_s, l_s)


def _ball(p: Any) -> tuple:
    return (p[ix.M], p[ix.R], p[ix.L], p[ix.I1], p[ix.I3], p[ix.MU], p[ix.G])


def _stem(p: Any) -> tuple:
    return (p[ix.M], p[ix.R_S], p[ix.L] + p[ix.L_S], p[ix.I1], p[ix.I3], p[ix.MU], p[ix.G])


def _ez(y: Any) -> Any:
    return y[9] / (y[7] * y[7] + y[8] * y[8] + y[9] * y[9]) ** 0.5


# --- ball phase ----------------------------------------------------------------------------------


def ball_rhs(t: float, y: np.ndarray, p: tuple) -> np.ndarray:
    """Gliding right-hand side on the ball (R, l); the phase flag stays constant."""
    return np.array((*gliding_core(y, _ball(p))[:10], 0.0))


def _ball_into(t: float, y: Any, p: Any, out: Any) -> None:
    d = gliding_core(y, (p[ix.M], p[ix.R], p[ix.L], p[ix.I1], p[ix.I3], p[ix.MU], p[ix.G]))
    out[0], out[1], out[2], out[3], out[4] = d[0], d[1], d[2], d[3], d[4]
    out[5], out[6], out[7], out[8], out[9] = d[5], d[6], d[7], d[8], d[9]
    out[10] = 0.0


def _ball_contact(t: float, y: Any, p: Any) -> Any:
    """g_n/(m g) of the ball contact."""
    d = gliding_core(y, (p[ix.M], p[ix.R], p[ix.L], p[ix.I1], p[ix.I3], p[ix.MU], p[ix.G]))
    return d[10] * (1.0 / (p[ix.M] * p[ix.G]))


def stem_clearance(y: Any, R: Any, r_s: Any, l_s: Any) -> Any:
    """Touchdown event: stem clearance (R + l_s 3̂_z − r_s)/R while the ball touches
    (+ :data:`SWITCH_OFFSET`); plain arithmetic, for every model of the stemmed top."""
    n = (y[7] * y[7] + y[8] * y[8] + y[9] * y[9]) ** 0.5
    return (R + l_s * (y[9] / n) - r_s) / R + SWITCH_OFFSET


def ball_clearance(y: Any, R: Any, r_s: Any, l_s: Any) -> Any:
    """Landing event: ball clearance (r_s − l_s 3̂_z − R)/R while the stem touches
    (+ :data:`SWITCH_OFFSET`)."""
    n = (y[7] * y[7] + y[8] * y[8] + y[9] * y[9]) ** 0.5
    return (r_s - l_s * (y[9] / n) - R) / R + SWITCH_OFFSET


def _touchdown(t: float, y: Any, p: Any) -> Any:
    """Stem clearance while the ball touches (:func:`stem_clearance`)."""
    return stem_clearance(y, p[ix.R], p[ix.R_S], p[ix.L_S])


# --- stem phase ----------------------------------------------------------------------------------


def stem_rhs(t: float, y: np.ndarray, p: tuple) -> np.ndarray:
    """Gliding right-hand side on the stem sphere (r_s, l + l_s); the phase flag stays constant."""
    return np.array((*gliding_core(y, _stem(p))[:10], 0.0))


def _stem_into(t: float, y: Any, p: Any, out: Any) -> None:
    d = gliding_core(
        y, (p[ix.M], p[ix.R_S], p[ix.L] + p[ix.L_S], p[ix.I1], p[ix.I3], p[ix.MU], p[ix.G])
    )
    out[0], out[1], out[2], out[3], out[4] = d[0], d[1], d[2], d[3], d[4]
    out[5], out[6], out[7], out[8], out[9] = d[5], d[6], d[7], d[8], d[9]
    out[10] = 0.0


def _stem_contact(t: float, y: Any, p: Any) -> Any:
    """g_n/(m g) of the stem contact."""
    d = gliding_core(
        y, (p[ix.M], p[ix.R_S], p[ix.L] + p[ix.L_S], p[ix.I1], p[ix.I3], p[ix.MU], p[ix.G])
    )
    return d[10] * (1.0 / (p[ix.M] * p[ix.G]))


def _landing(t: float, y: Any, p: Any) -> Any:
    """Ball clearance while the stem touches (:func:`ball_clearance`)."""
    return ball_clearance(y, p[ix.R], p[ix.R_S], p[ix.L_S])


# --- the impact ----------------------------------------------------------------------------------


def _body(y: np.ndarray, q: tuple) -> tuple:
    """3̂, L, ω and the full CM velocity of state ``y`` on the contact with parameters ``q``."""
    m, R, l, I1, I3, mu, g = q
    e = np.asarray(y[7:10], dtype=float)
    e = e / np.linalg.norm(e)
    L = np.asarray(y[4:7], dtype=float)
    w = L / I1 + (1.0 / I3 - 1.0 / I1) * np.dot(L, e) * e
    a = l * e - np.array([0.0, 0.0, R])
    V = np.array([y[2], y[3], -np.cross(w, a)[2]])  # the contact constraint fixes V_z
    return e, L, w, V


class ImpactFrame(NamedTuple):
    """The body at the instant of an impact at a new contact (configuration fixed during it)."""

    e: np.ndarray
    """Symmetry axis 3̂."""
    L: np.ndarray
    """Angular momentum about the CM before the impact (kg m² s⁻¹)."""
    w: np.ndarray
    """Angular velocity before the impact (rad/s)."""
    V: np.ndarray
    """CM velocity before the impact (m/s), V_z from the old contact's constraint."""
    a: np.ndarray
    """CM → new contact point (m)."""
    Iinv: np.ndarray
    """Inverse inertia tensor (kg⁻¹ m⁻²)."""
    W: np.ndarray
    """Δv = W P at the new contact: W = 𝟙/m − [a×] I⁻¹ [a×] (kg⁻¹)."""
    v: np.ndarray
    """Velocity of the new contact point before the impact (m/s)."""


def impact_frame(y: np.ndarray, p: tuple, to: str) -> ImpactFrame:
    """:class:`ImpactFrame` of state ``y`` (on the other sphere) for an impact of contact ``to``
    ("ball" or "stem"); ``p`` the parameters of the "stemmed" model (μ unused)."""
    old, new = (_stem(p), _ball(p)) if to == "ball" else (_ball(p), _stem(p))
    m, I1, I3 = p[ix.M], p[ix.I1], p[ix.I3]
    e, L, w, V = _body(y, old)
    a = new[2] * e - np.array([0.0, 0.0, new[1]])
    Iinv = np.eye(3) / I1 + (1.0 / I3 - 1.0 / I1) * np.outer(e, e)
    A = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])  # a × x = A x
    W = np.eye(3) / m - A @ Iinv @ A
    return ImpactFrame(e, L, w, V, a, Iinv, W, V + np.cross(w, a))


def apply_impulse(
    y: np.ndarray, f: ImpactFrame, m: float, P: np.ndarray, to: str, Q: float = 0.0
) -> np.ndarray:
    """The state after the impulse ``P`` (N s) and the torque impulse ``Q`` ẑ (N m s) at the new
    contact ``to``: Δ(m ṙ) = P, ΔL = a × P + Q ẑ, phase flag set to the new contact.

    Any impulse at the new contact keeps its Jellett integral −L·a: −(a × P)·a = 0 (Q changes
    it by −Q ẑ·a, the Contensou torque's share).
    """
    out = np.array(y, dtype=float)
    out[2:4] = f.V[:2] + np.asarray(P[:2]) / m
    out[4:7] = f.L + np.cross(f.a, P) + np.array([0.0, 0.0, Q])
    out[10] = 1.0 if to == "stem" else 0.0
    return out


def impact(y: np.ndarray, p: tuple, to: str) -> tuple[np.ndarray, np.ndarray]:
    """State after the impact of the contact ``to`` ("ball" or "stem"), and the impulse P (N s).

    ``y`` is the state just before (on the other sphere). Perfectly inelastic Darboux–Keller
    impact with the viscous law in impulse form (module docstring, :func:`darboux_keller`): the
    new contact's normal velocity is 0 afterwards and the energy does not increase.
    """
    f = impact_frame(y, p, to)
    P = darboux_keller(f.v, f.W, p[ix.MU]) if f.v[2] < 0.0 else np.zeros(3)
    return apply_impulse(y, f, p[ix.M], P, to), P


def darboux_keller(v0: np.ndarray, W: np.ndarray, mu: float) -> np.ndarray:
    """The impulse P (N s) of the perfectly inelastic Darboux–Keller impact, viscous law.

    dP = (ẑ − μ v_t) dp, dv = W dP from the contact velocity ``v0`` (v0_z < 0) until v_z = 0
    (module docstring); μ in s/m. Raises :class:`JumpFailed` if the impulse equations cannot be
    solved.
    """
    from scipy.integrate import solve_ivp

    def rate(_: float, z: np.ndarray) -> np.ndarray:
        dP = np.array([-mu * z[0], -mu * z[1], 1.0])
        return np.concatenate((W @ dP, dP))

    def stop(_: float, z: np.ndarray) -> float:
        return z[2]

    stop.terminal, stop.direction = True, 1.0  # type: ignore[attr-defined]
    # The impact always ends: v_t relaxes to W_tt⁻¹W_tz/μ and then v_z grows at the rate
    # 1/(W⁻¹)_zz > 0 (W positive definite). Friction can make p much larger than the
    # frictionless −v_z/W_zz, so the interval is extended until v_z reaches 0.
    z, p0, p1 = np.concatenate((v0, np.zeros(3))), 0.0, 10.0 * -v0[2] / W[2, 2]
    for _ in range(12):
        sol = solve_ivp(rate, (p0, p1), z, method="DOP853", events=stop, rtol=1e-13,
                        atol=1e-15 * (1.0 + abs(v0[2])))  # fmt: skip
        if sol.status != 0:
            break
        z, p0, p1 = sol.y[:, -1], p1, 10.0 * p1
    if sol.status != 1:
        raise JumpFailed(f"impact: the impulse equations could not be solved ({sol.message})")
    return sol.y_events[0][0][3:]


def _to_stem(y: np.ndarray, p: tuple) -> np.ndarray:
    return impact(y, p, "stem")[0]


def _to_ball(y: np.ndarray, p: tuple) -> np.ndarray:
    return impact(y, p, "ball")[0]


# --- conversions and series ----------------------------------------------------------------------


def _initial(state: Any, p: tuple) -> np.ndarray:
    m, R, l, I1, I3, mu, g, r_s, l_s = p
    on_stem = R + l_s * np.cos(float(state.theta)) - r_s < 0.0
    q = _stem(p) if on_stem else _ball(p)
    v = lab_vectors(state, q[1], q[2])
    e, w = v["e3"], v["omega"]
    L = I1 * w + (I3 - I1) * np.dot(w, e) * e
    return np.concatenate(([0.0, 0.0], v["v"][:2], L, e, [1.0 if on_stem else 0.0]))


def _start_phase(y0: np.ndarray, p: tuple) -> str:
    return "stem" if y0[10] > 0.5 else "ball"


def _normal_force(y: np.ndarray, p: tuple) -> Any:
    y = np.asarray(y, dtype=float)
    return np.where(y[10] > 0.5, gliding_core(y, _stem(p))[10], gliding_core(y, _ball(p))[10])


def _derive(Y: np.ndarray, p: tuple) -> dict[str, np.ndarray]:
    """Series of each sample on its own contact: ν, g_n, E, λ of the sphere in contact."""
    Y = np.asarray(Y, dtype=float)
    ball, stem = gliding_series(Y, _ball(p)), gliding_series(Y, _stem(p))
    on = Y[10] > 0.5
    out = {k: np.where(on, stem[k], np.asarray(ball[k], dtype=float)) for k in ball}
    out["x"], out["y"] = Y[0], Y[1]
    return out


def _theta(Y: np.ndarray, p: tuple) -> np.ndarray:
    e = unit_axis(np.asarray(Y, dtype=float), 7)
    return np.arccos(np.clip(e[2], -1.0, 1.0))


def _scales(y0: np.ndarray, p: tuple) -> np.ndarray:
    q = _stem(p) if y0[10] > 0.5 else _ball(p)
    w = np.array(gliding_core(y0, q)[11])
    sc = scales_from_state(
        w, y0[2:4], p[ix.R], max(p[ix.L] + p[ix.L_S], p[ix.R]), p[ix.I1], p[ix.I3], p[ix.G]
    )
    return np.array(
        [sc["length"]] * 2 + [sc["velocity"]] * 2 + [sc["momentum"]] * 3 + [0.1] * 3 + [1.0]
    )


STEM_RADIUS = Option(
    "stem_radius", positive_length, None, "stem sphere radius r_s (m), from top.with_stem", True
)
STEM_DISTANCE = Option(
    "stem_distance", positive_length, None, "ball centre to stem centre l_s (m)", True
)


def _finish(traj: Any) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """``Model.finish``: the contact of each sample ("ball"/"stem", also for a run that ended
    at t = 0, before any phase ran) and ``touchdowns``, the times the stem touched down (s)."""
    contact = np.where(traj.states[10] > 0.5, "stem", "ball")
    touchdowns = np.array(
        [sw[0] for sw in traj.switches if sw[1].startswith("ball") and sw[2].startswith("stem")]
    )
    return {"contact": contact}, {"touchdowns": touchdowns}


MODEL = register(
    Model(
        name="stemmed",
        summary="tippe top with a spherical stem: gliding on the ball or the stem, inelastic "
        "impacts at the change of contact (docs/theory/stem.md; Leine & Glocker 2003)",
        rhs=ball_rhs,
        rhs_into=_ball_into,
        normal_force=_normal_force,
        params=stem_params,
        initial=_initial,
        derive=_derive,
        theta=_theta,
        scales=_scales,
        conserved_lengths=((7, 8, 9),),
        events=(
            Event(_ball_contact, -1.0, "contact_lost"),
            Event(_touchdown, -1.0, "switch", target="stem", jump=_to_stem),
        ),
        options=(
            STEM_RADIUS,
            STEM_DISTANCE,
            Option("friction", friction_law, None, "a dry law: runs 'stemmed-coulomb'"),
        ),
        friction=(type(None), Viscous, Coulomb),
        phase="ball",
        phases=(
            Phase(
                "stem",
                stem_rhs,
                _stem_into,
                (
                    Event(_stem_contact, -1.0, "contact_lost"),
                    Event(_landing, -1.0, "switch", target="ball", jump=_to_ball),
                ),
            ),
        ),
        start_phase=_start_phase,
        finish=_finish,
    )
)


def stemmed_run(simulate: Any, top: Any, state: Any, t_end: float, **kw: Any) -> Any:
    """:func:`mett.simulate` of a :class:`~mett.stem.StemmedTop`: the "stemmed" model on its ball
    with its stem (with ``friction=Coulomb(...)`` the dry-friction model "stemmed-coulomb",
    :mod:`.stemslip`); the Trajectory also gets ``contact`` ("ball"/"stem" per sample) and
    ``touchdowns`` (the times the stem touched down, s; the models' ``finish``)."""
    model = kw.pop("model")
    if model not in ("gliding", "stemmed", MODEL):
        raise ValueError(f"a top with a stem runs the 'stemmed' model only; got model {model!r}")
    for name in ("stem_radius", "stem_distance"):
        if kw.get(name) is not None:
            raise ValueError(f"{name} is given by the StemmedTop; do not pass it to simulate")
    kw.update(stem_radius=top.radius, stem_distance=top.distance)
    # friction=Viscous runs this model with its μ; a dry law "stemmed-coulomb" (its model_for)
    return simulate(top.ball, state, t_end, model=MODEL, **kw)
