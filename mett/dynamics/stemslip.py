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
from .stem import (
    BOTH_FORCE_MIN,
    apply_impulse,
    ball_clearance,
    both_kinematics,
    both_solve,
    impact_frame,
    on_both,
    stem_clearance,
)

__all__ = [
    "CONTENSOU",
    "MODEL",
    "both_forces",
    "both_stick_forces",
    "close_both",
    "dry_impulse",
    "impact",
    "transition",
]

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


# --- both spheres on the plane: the dry double contact ("both-sliding", flag 2) ----------------
#
# The state of the double contact is that of the viscous stemmed model (:mod:`.stem`: L_z in
# row 6, flag 2), read on the double-contact manifold by :func:`mett.dynamics.stem.both_kinematics`;
# the dry law enters through the force per unit normal force of each contact (both_solve).


def _slide_both(y: Any, p: Any) -> tuple:
    """(rates[0:10], λ_1, λ_2, |γ_1|, |γ_2|) of the double contact with both contacts sliding:
    F_i = λ_i (ẑ − μ ν_i/|γ_i|) and the drilling torque −μ λ_i r*² ω_z/|γ_i| ẑ at each contact,
    γ_i = (ν_i, r* ω_z) its generalised slip (r* = 0: Coulomb). Plain arithmetic."""
    r_s, l_s = p[ix.DRY_R_S], p[ix.DRY_L_S]
    mu, rs = p[ix.MU], p[ix.RSTAR]
    e, L, w, n1, n2, de = both_kinematics(y, p[ix.R], p[ix.L], p[ix.I1], p[ix.I3], r_s, l_s)
    sw = rs * w[2]
    s1 = (n1[0] * n1[0] + n1[1] * n1[1] + sw * sw) ** 0.5
    s2 = (n2[0] * n2[0] + n2[1] * n2[1] + sw * sw) ** 0.5
    if mu == 0.0:  # frictionless: no force, also at zero slip
        k1 = 0.0 * s1
        k2 = 0.0 * s2
    else:
        k1 = -mu / s1
        k2 = -mu / s2
    rates, lam1, lam2 = both_solve(
        y, p[ix.M], p[ix.G], p[ix.R], p[ix.L], r_s, l_s, e, L, de,
        (k1 * n1[0], k1 * n1[1], k1 * rs * sw), (k2 * n2[0], k2 * n2[1], k2 * rs * sw),
    )  # fmt: skip
    return rates, lam1, lam2, s1, s2


def _both_sliding_into(t: float, y: Any, p: Any, out: Any) -> None:
    d = _slide_both(y, p)[0]
    out[0], out[1], out[2], out[3], out[4] = d[0], d[1], d[2], d[3], d[4]
    out[5], out[6], out[7], out[8], out[9] = d[5], d[6], d[7], d[8], d[9]
    out[10] = 0.0


def _both_contact(t: float, y: Any, p: Any) -> Any:
    """(λ_1 + λ_2)/(m g) = 1: the double contact cannot lose both contacts at once (v̇_z = 0);
    each lift-off is a switch."""
    d = _slide_both(y, p)
    return (d[1] + d[2]) * (1.0 / (p[ix.M] * p[ix.G]))


def _both_ball_lift(t: float, y: Any, p: Any) -> Any:
    """λ_1/(m g), the ball's normal force in the double contact: the ball lifts off at 0."""
    return _slide_both(y, p)[1] * (1.0 / (p[ix.M] * p[ix.G]))


def _both_stem_lift(t: float, y: Any, p: Any) -> Any:
    """λ_2/(m g), the stem's normal force in the double contact: the stem lifts off at 0."""
    return _slide_both(y, p)[2] * (1.0 / (p[ix.M] * p[ix.G]))


def _both_ball_stop(t: float, y: Any, p: Any) -> Any:
    """|γ_1| − δ: the ball's slip reaches the stopping band."""
    if p[ix.MU] == 0.0:
        return 1.0 + 0.0 * y[0]
    return _slide_both(y, p)[3] - p[ix.BAND]


def _both_stem_stop(t: float, y: Any, p: Any) -> Any:
    """|γ_2| − δ: the stem's slip reaches the stopping band."""
    if p[ix.MU] == 0.0:
        return 1.0 + 0.0 * y[0]
    return _slide_both(y, p)[4] - p[ix.BAND]


def both_forces(y: Any, p: tuple) -> tuple:
    """(λ_1, λ_2, |γ_1|, |γ_2|) of state(s) ``y`` of the double contact, both contacts sliding:
    the normal forces (N) of the ball and the stem and their generalised slip speeds (m/s)."""
    d = _slide_both(y, p)
    return d[1], d[2], d[3], d[4]


def _arms(e: np.ndarray, p: tuple) -> list[np.ndarray]:
    z = np.array([0.0, 0.0, 1.0])
    return [p[ix.L] * e - p[ix.R] * z, (p[ix.L] + p[ix.DRY_L_S]) * e - p[ix.DRY_R_S] * z]


def _both_body(y: np.ndarray, p: tuple) -> tuple:
    """(3̂, L, ω, V, I⁻¹) of a double-contact state (flag 2), on the manifold (V_z = 0)."""
    e, L, w, _, _, _ = both_kinematics(
        np.asarray(y, dtype=float), p[ix.R], p[ix.L], p[ix.I1], p[ix.I3], p[ix.DRY_R_S],
        p[ix.DRY_L_S],
    )  # fmt: skip
    e, L, w = np.array(e, dtype=float), np.array(L, dtype=float), np.array(w, dtype=float)
    I1, I3 = p[ix.I1], p[ix.I3]
    Iinv = np.eye(3) / I1 + (1.0 / I3 - 1.0 / I1) * np.outer(e, e)
    return e, L, w, np.array([y[2], y[3], 0.0]), Iinv


def both_stick_forces(y: np.ndarray, p: tuple, sticking: tuple[bool, bool]) -> dict:
    """The contact forces of the double contact in the mode ``sticking`` (ball, stem): a
    sticking contact keeps its generalised slip at 0 (v̇_i,t = 0, and ω̇_z = 0 with Contensou),
    a sliding one carries −μ λ_i γ̂_i. The Newton–Euler equations with the two normal rows
    (g̈_i = 0) and the sticking rows, solved as one linear system (least squares where both
    stick under Coulomb: the compression between the two contacts along their line is
    indeterminate, the minimum-norm force taken).

    Returns ``{"lam": (λ_1, λ_2), "Ft": [(F_x, F_y, M/r*) per contact], "margin": [μ λ_i − |F_t,i|]}``
    (N); a sliding contact's margin is 0.
    """
    m, g, mu, rs = p[ix.M], p[ix.G], p[ix.MU], p[ix.RSTAR]
    I1, I3 = p[ix.I1], p[ix.I3]
    e, L, w, V, Iinv = _both_body(y, p)
    Iten = I1 * np.eye(3) + (I3 - I1) * np.outer(e, e)
    arms = _arms(e, p)
    z = np.array([0.0, 0.0, 1.0])
    n_t = 3 if rs > 0.0 else 2
    cols = ["V0", "V1", "V2", "w0", "w1", "w2", "l1", "l2"]
    for i in (0, 1):
        if sticking[i]:
            cols += [f"t{i}{k}" for k in range(n_t)]
    n = len(cols)
    A = np.zeros((n, n))
    b = np.zeros(n)
    c = {name: j for j, name in enumerate(cols)}

    def skew(a: np.ndarray) -> np.ndarray:
        return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])

    # Newton: m V̇ − Σ F_i = −m g ẑ; Euler: I ω̇ − Σ (a_i × F_i + M_i ẑ) = −ω × I ω
    A[0:3, 0:3] = m * np.eye(3)
    A[3:6, 3:6] = Iten
    b[0:3] = -m * g * z
    b[3:6] = -np.cross(w, Iten @ w)
    for i, a in enumerate(arms):
        v_i = V + np.cross(w, a)
        gam = np.array([v_i[0], v_i[1], rs * w[2]])
        if sticking[i]:
            dirs = np.zeros((3, n_t))  # force per unit tangential unknown
            dirs[0, 0] = dirs[1, 1] = 1.0
            for k in range(2):
                A[0:3, c[f"t{i}{k}"]] -= dirs[:, k]
                A[3:6, c[f"t{i}{k}"]] -= np.cross(a, dirs[:, k])
            if n_t == 3:  # the drilling torque r* × unknown
                A[5, c[f"t{i}2"]] -= rs
            unit = z
        else:
            s = float(np.linalg.norm(gam))
            k = -mu / s if (mu > 0.0 and s > 0.0) else 0.0
            unit = z + k * np.array([gam[0], gam[1], 0.0])
            A[5, c[f"l{i + 1}"]] -= k * rs * gam[2]
        A[0:3, c[f"l{i + 1}"]] -= unit
        A[3:6, c[f"l{i + 1}"]] -= np.cross(a, unit)
    rows = 6
    # contact point acceleration: V̇ + ω̇ × a_i + ω × (ω × l_i 3̂)
    for i, a in enumerate(arms):
        li = p[ix.L] + (p[ix.DRY_L_S] if i else 0.0)
        cen = np.cross(w, np.cross(w, li * e))
        acc_rows = [2] + ([0, 1] if sticking[i] else [])
        for comp in acc_rows:
            unit = np.eye(3)[comp]
            A[rows, 0:3] = unit  # V̇_comp
            A[rows, 3:6] = np.cross(a, unit)  # (ω̇ × a)·u = ω̇·(a × u)
            b[rows] = -cen[comp]
            rows += 1
        if sticking[i] and n_t == 3:
            A[rows, 5] = 1.0  # ω̇_z = 0
            rows += 1
    # equilibrated (rows, then columns, to unit max-norm; m and I differ by 1e4): the solve's
    # rounding is then that of a well-scaled system
    dr = 1.0 / np.max(np.abs(A), axis=1)
    dc = 1.0 / np.max(np.abs(A * dr[:, None]), axis=0)
    x = dc * np.linalg.lstsq(A * dr[:, None] * dc[None, :], b * dr, rcond=None)[0]
    lam = (float(x[c["l1"]]), float(x[c["l2"]]))
    Ft, margin = [], []
    for i in (0, 1):
        if sticking[i]:
            f = np.array([x[c[f"t{i}{k}"]] for k in range(n_t)] + [0.0] * (3 - n_t))
            Ft.append(f)
            margin.append(mu * lam[i] - float(np.linalg.norm(f)))
        else:
            Ft.append(None)
            margin.append(0.0)
    return {"lam": lam, "Ft": Ft, "margin": margin}


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


def _trailing_impacts(switches: Any) -> list[float]:
    """Times (s) of the trailing run of impacts (ball ↔ stem changes of contact) among the
    run's switches (time, from, to); a double contact ends the run of impacts."""
    out: list[float] = []
    for t, a, b in reversed(list(switches)):
        ca, cb = a.split("-")[0], b.split("-")[0]
        if {ca, cb} != {"ball", "stem"}:
            break
        out.append(t)
    return out[::-1]


# --- impulses on both contacts ---------------------------------------------------------------


def _gen(rs: float) -> int:
    """Components per contact of the generalised impulse / velocity: (x, y, z[, r* ω_z])."""
    return 4 if rs > 0.0 else 3


def _delassus2(e: np.ndarray, Iinv: np.ndarray, m: float, arms: list, rs: float) -> np.ndarray:
    """The generalised Delassus matrix of the two contacts: Δg = W Π with Π = (Π_1, Π_2),
    Π_i = (P_x, P_y, P_z[, Q_i/r*]) at a_i, g_i = (v_x, v_y, v_z[, r* ω_z]) of contact i."""
    k = _gen(rs)
    W = np.zeros((2 * k, 2 * k))
    for j in range(2 * k):
        Pi = np.zeros(2 * k)
        Pi[j] = 1.0
        dV = (Pi[0:3] + Pi[k : k + 3]) / m
        dL = np.cross(arms[0], Pi[0:3]) + np.cross(arms[1], Pi[k : k + 3])
        if k == 4:
            dL[2] += rs * (Pi[3] + Pi[7])
        dw = Iinv @ dL
        for i in range(2):
            W[i * k : i * k + 3, j] = dV + np.cross(dw, arms[i])
            if k == 4:
                W[i * k + 3, j] = rs * dw[2]
    return W


def _gvel(V: np.ndarray, w: np.ndarray, arms: list, rs: float) -> np.ndarray:
    """The generalised velocities (g_1, g_2) of the two contact points."""
    out = []
    for a in arms:
        v = V + np.cross(w, a)
        out.extend([v[0], v[1], v[2]] + ([rs * w[2]] if rs > 0.0 else []))
    return np.array(out)


def _apply2(y: np.ndarray, p: tuple, L: np.ndarray, arms: list, Pi: np.ndarray) -> np.ndarray:
    """State ``y`` (L_z form) with angular momentum ``L`` after the impulses Π of both contacts,
    on the double-contact manifold (flag 2)."""
    k = _gen(p[ix.RSTAR])
    out = np.array(y, dtype=float)
    P1, P2 = Pi[0:3], Pi[k : k + 3]
    out[2:4] += (P1[:2] + P2[:2]) / p[ix.M]
    dL = np.cross(arms[0], P1) + np.cross(arms[1], P2)
    if k == 4:
        dL[2] += p[ix.RSTAR] * (Pi[3] + Pi[7])
    out[4:7] = L + dL
    out[10] = 2.0
    return on_both(out, _viscous(p))


def _kinetic(y: np.ndarray, p: tuple, V_z: float = 0.0) -> float:
    """Kinetic energy (J) of an L_z-form state with the vertical CM velocity ``V_z``."""
    e = np.asarray(y[7:10], dtype=float) / np.linalg.norm(y[7:10])
    L = np.asarray(y[4:7], dtype=float)
    w = L / p[ix.I1] + (1.0 / p[ix.I3] - 1.0 / p[ix.I1]) * np.dot(L, e) * e
    return 0.5 * p[ix.M] * (y[2] ** 2 + y[3] ** 2 + V_z**2) + 0.5 * float(L @ w)


def close_both(
    y: np.ndarray, p: tuple, on: str, tail: bool = False
) -> tuple[np.ndarray, np.ndarray, tuple]:
    """The dry closure: the impulse that stops both normal velocities of state ``y`` (on the
    contact ``on``, this model's λ-form state) with the dry law at each contact in impulse form.

    A sliding contact's impulse is P_n,i (ẑ − μ d_i), d_i the direction of its generalised slip
    before (with Contensou, −μ P_n,i d_i in the (P_x, P_y, Q/r*) slots); a sticking one's
    tangential impulse is what brings its generalised slip to 0 and must lie in its cone,
    |Π_t,i| ≤ μ P_n,i. Candidate modes in the order slide–slide, stick–slide, slide–stick,
    stick–stick: the first with each normal impulse ≥ 0, each sticking impulse inside its cone,
    no sliding slip reversed by the impulse (γ_i⁺·d_i ≥ 0, else friction would have stopped it
    during the impulse) and the kinetic energy not increased.

    ``tail``: the limit of accumulating impacts (:func:`mett.dynamics.stem.accumulation`). The
    impulse then removes the rocking velocity left at the detecting impact; the double contact
    runs on from there, its forces standing for the non-impulsive forces over the vanishing
    tail. A negative normal "impulse" at a contact is that share (gravity and the gyroscopic
    torque pulling the separating sphere back over the tail), not a contact impulse: it carries
    no friction and no cone (that contact's column is frictionless, a projection in the
    metric of the kinetic energy, which loses energy), and the tail's total contact impulse
    there, P_n,i + λ_i (t_∞ − t_k), is checked ≥ 0 by the caller's reason.

    Returns the state on both contacts (flag 2, L_z form), the impulses Π = (Π_1, Π_2) (N s per
    contact: (P_x, P_y, P_z[, Q/r*])) and the mode (ball sticks, stem sticks). Raises
    :class:`JumpFailed` when no mode is consistent (a Painlevé-type inconsistency of the dry
    impulse law).
    """
    m, mu, rs = p[ix.M], p[ix.MU], p[ix.RSTAR]
    pv = _viscous(p)
    yl = _lz(y, p)
    f = impact_frame(yl, pv, "stem" if on == "ball" else "ball")
    arms = _arms(f.e, p)
    W = _delassus2(f.e, f.Iinv, m, arms, rs)
    g0 = _gvel(f.V, f.w, arms, rs)
    k = _gen(rs)
    t = np.array([0, 1, 3] if k == 4 else [0, 1])
    E0 = _kinetic(yl, p, float(f.V[2]))
    tol = 1e-9 * max(float(np.max(np.abs(g0))), 1e-300)
    slow = [float(np.linalg.norm(g0[i * k + t])) <= p[ix.BAND] for i in range(2)]
    for mode in ((False, False), (True, False), (False, True), (True, True)):
        if any(slow[i] and not mode[i] and not tail for i in range(2)):
            continue  # a contact at rest that does not stick must be pulled (tail only)
        # a tail contact pulled back (or at rest and not sticking): frictionless column
        free = [slow[i] and not mode[i] for i in range(2)]
        for _ in range(3):
            cols, rows = [], []
            for i in range(2):
                col = np.zeros(2 * k)
                col[i * k + 2] = 1.0
                if not mode[i] and mu > 0.0 and not free[i]:
                    gt = g0[i * k + t]
                    col[i * k + t] = -mu * gt / np.linalg.norm(gt)
                cols.append(col)
                rows.append(i * k + 2)
                if mode[i]:
                    for j in t:
                        c = np.zeros(2 * k)
                        c[i * k + j] = 1.0
                        cols.append(c)
                        rows.append(i * k + j)
            U = np.column_stack(cols)
            Pi = U @ np.linalg.lstsq((W @ U)[rows], -g0[rows], rcond=None)[0]
            pulled = [tail and not mode[i] and Pi[i * k + 2] < 0.0 for i in range(2)]
            if pulled == free or not any(pulled):
                break
            free = [a or b for a, b in zip(free, pulled, strict=True)]
        gp = g0 + W @ Pi
        if np.max(np.abs(gp[rows])) > tol:  # singular and inconsistent: no such impulse
            continue
        ok = True
        for i in range(2):
            sl = i * k + t
            if mode[i]:
                ok &= Pi[i * k + 2] >= 0.0
                ok &= float(np.linalg.norm(Pi[sl])) <= mu * Pi[i * k + 2] * (1.0 + 1e-12)
            elif free[i]:  # frictionless: only as the tail's pull
                ok &= Pi[i * k + 2] <= 0.0
            else:
                ok &= Pi[i * k + 2] >= 0.0
                if mu > 0.0:
                    ok &= float(gp[sl] @ g0[sl]) >= 0.0
        if not ok:
            continue
        after = _apply2(yl, p, f.L, arms, Pi)
        if _kinetic(after, p) > E0 * (1.0 + 1e-12):
            continue
        return after, Pi, mode
    raise JumpFailed(
        "both contacts close, but no impulse satisfies the dry law at both (a Painlevé-type "
        "inconsistency of the impulse law): the run ends there"
    )


def _normal_velocities(y: np.ndarray, p: tuple) -> tuple[float, float]:
    """The normal velocities (m/s) of the ball's and the stem's contact points of the λ-form
    state ``y`` on one contact (V_z from its constraint)."""
    on_stem = y[10] > 0.5
    f = impact_frame(_lz(y, p), _viscous(p), "ball" if on_stem else "stem")
    arms = _arms(f.e, p)
    v = [float(f.V[2] + np.cross(f.w, a)[2]) for a in arms]
    return v[0], v[1]


def _enter_both(y2: np.ndarray, p: tuple) -> np.ndarray:
    """The run's state after both contacts closed (``y2`` on the manifold, flag 2): the double
    contact if both normal forces exceed BOTH_FORCE_MIN m g (a slip within the band settled,
    :func:`_settle_both`), else the contact with the larger force alone (the other lifts off with
    zero normal velocity), its slip settled."""
    lam1, lam2 = (float(v) for v in both_forces(y2, p)[:2])
    if min(lam1, lam2) > BOTH_FORCE_MIN * p[ix.M] * p[ix.G]:
        return _settle_both(y2, p)
    return _lift(y2, p, "ball" if lam1 >= lam2 else "stem")


def transition(
    y: np.ndarray, p: tuple, to: str, switches: Any = ()
) -> tuple[np.ndarray, str, float]:
    """The state after the contact ``to`` ("ball" or "stem") closes on state ``y`` (the other
    contact, λ form), and the reason:

    * the single dry impact (:func:`impact`), its slip settled, if the old contact then
      separates (normal velocity > 0) and the impacts do not accumulate: "touchdown"/"landing";
    * else both contacts closed by the dry closure impulse (:func:`close_both`): "accumulation"
      (the impact times form a geometric sequence, :func:`mett.dynamics.stem.accumulation`) or
      "closure" (the old contact would not separate); the double contact starts if both normal
      forces are positive (:func:`_enter_both`).

    The third value is the accumulation point t_∞ (s; NaN if none).
    """
    old = "ball" if to == "stem" else "stem"
    acc = stem.accumulation(_trailing_impacts(switches)) if len(switches) else None
    after = impact(y, p, to)[0]
    v_ball, v_stem = _normal_velocities(after, p)
    v_old = v_ball if old == "ball" else v_stem
    if acc is None and v_old > 0.0:
        single = "touchdown" if to == "stem" else "landing"
        return dry.settle(after, _contact(p, to == "stem")), single, math.nan
    closed, Pi, _ = close_both(y, p, old, tail=acc is not None)
    if acc is not None:  # the tail's contact impulses, P_n,i + λ_i (t_∞ − t_k), are ≥ 0
        k = _gen(p[ix.RSTAR])
        span = acc.t_limit - _trailing_impacts(switches)[-1]
        lam = both_forces(closed, p)[:2]
        if min(Pi[2] + lam[0] * span, Pi[k + 2] + lam[1] * span) < 0.0:
            raise JumpFailed(
                f"impacts accumulate (ratio {acc.ratio:.3g}, limit t = {acc.t_limit:.9g} s) "
                "into a double contact that one contact cannot carry (its tail impulse < 0)"
            )
    if acc is None:
        return _enter_both(closed, p), "closure", math.nan
    return _enter_both(closed, p), "accumulation", acc.t_limit


def _impact_to(to: str) -> Any:
    """The jump of a change of contact (:func:`transition`)."""

    def jump(y: np.ndarray, p: tuple, switches: Any = ()) -> np.ndarray:
        return transition(y, p, to, switches)[0]

    return jump


def _lift(y2: np.ndarray, p: tuple, to: str) -> np.ndarray:
    """The double-contact state ``y2`` on the contact ``to`` alone (the other lifts off: its
    normal force 0, its normal velocity 0): λ form, its slip settled."""
    out = on_both(y2, _viscous(p))
    out[10] = 1.0 if to == "stem" else 0.0
    q = _contact(p, to == "stem")
    return dry.settle(dry.from_gliding(out, q), q)


def _ball_lifts(y: np.ndarray, p: tuple) -> np.ndarray:
    """λ_1 = 0: the ball lifts off, the top on its stem."""
    return _lift(y, p, "stem")


def _stem_lifts(y: np.ndarray, p: tuple) -> np.ndarray:
    """λ_2 = 0: the stem lifts off, the top on its ball."""
    return _lift(y, p, "ball")


def _restart_both(y2: np.ndarray, p: tuple, i: int, direction: np.ndarray) -> np.ndarray:
    """``y2`` after the impulse at contact ``i`` that sets its generalised slip to 2δ along
    ``direction`` while both normal velocities stay 0 (impulses at both normals)."""
    m, rs = p[ix.M], p[ix.RSTAR]
    e, L, w, V, Iinv = _both_body(y2, p)
    arms = _arms(e, p)
    W = _delassus2(e, Iinv, m, arms, rs)
    g0 = _gvel(V, w, arms, rs)
    k = _gen(rs)
    t = [0, 1, 3] if k == 4 else [0, 1]
    rows = [2, k + 2] + [i * k + j for j in t]
    target = np.zeros(len(rows))
    target[2:] = 2.0 * p[ix.BAND] * np.asarray(direction, dtype=float)[: len(t)]
    Wr = W[np.ix_(rows, rows)]
    x = np.linalg.solve(Wr, target - g0[rows])
    Pi = np.zeros(2 * k)
    Pi[rows] = x
    return _apply2(y2, p, L, arms, Pi)


def _settle_both(y2: np.ndarray, p: tuple) -> np.ndarray:
    """A double-contact state with a contact's slip within the band: the mode of that contact
    chosen by consistency (Leine & Glocker 2003 §4: a mode is admissible when its normal forces
    are ≥ 0 and a sticking contact's force lies in its cone). Sticking admissible: not continued
    yet (:class:`JumpFailed` naming the mode); else the slip restarts (2δ) opposite to the force
    sticking would need, where the excess force drives it (exact at the cone's edge)."""
    if dry.frictionless(p) or p[ix.LAW] != dry.LAW_COULOMB:
        return y2
    for _ in range(2):
        _, _, s1, s2 = (float(v) for v in both_forces(y2, p))
        slow = [i for i, s in enumerate((s1, s2)) if s <= p[ix.BAND]]
        if not slow:
            return y2
        i = slow[0]
        mode = (i == 0, i == 1)
        sol = both_stick_forces(y2, p, mode)
        if min(sol["lam"]) >= 0.0 and sol["margin"][i] >= 0.0:
            raise JumpFailed(
                f"the {('ball', 'stem')[i]} contact sticks in the double contact (its force "
                "inside the cone, both normal forces ≥ 0): a sticking mode of the dry double "
                "contact, which is not continued yet"
            )
        Ft = sol["Ft"][i]
        gen = np.array([Ft[0], Ft[1], Ft[2]]) if p[ix.RSTAR] > 0.0 else Ft[:2]
        y2 = _restart_both(y2, p, i, -gen / np.linalg.norm(gen))
    return y2


def _both_stop(y: np.ndarray, p: tuple) -> np.ndarray:
    """A slip of the double contact reaches the band: the mode selection of :func:`_settle_both`."""
    return _settle_both(on_both(y, _viscous(p)), p)


def _select(y: np.ndarray, p: tuple) -> str:
    """The phase after a jump: the contact by the flag, rolling if its slip was settled."""
    if y[10] > 1.5:
        return "both-sliding"
    on_stem = y[10] > 0.5
    return ("stem-" if on_stem else "ball-") + dry.start_phase(y, _contact(p, on_stem))


# --- conversions and the trajectory's series ---------------------------------------------------


def _converted(Y: Any, p: tuple, convert: Any) -> np.ndarray:
    """``convert`` (:func:`~mett.dynamics.contact.to_gliding` or ``from_gliding``) applied to
    each state of ``Y`` (shape (11,) or (11, k)) with the geometry of its own contact."""
    Y = np.asarray(Y, dtype=float)
    if Y.ndim == 1:
        if Y[10] > 1.5:  # the double contact's state is already in the L_z form
            return Y.copy()
        return convert(Y, _contact(p, Y[10] > 0.5))
    out = Y.copy()
    on = (Y[10] > 0.5) & (Y[10] < 1.5)
    for mask, q in ((Y[10] < 0.5, _ball(p)), (on, _stem(p))):
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
    single = Y[10] < 1.5  # the double contact slides
    for mask, q in ((~on_stem & single, _ball(p)), (on_stem & single, _stem(p))):
        if mask.any():
            out[mask] = dry.rolling_guess(Y[:, mask], q)
    return out


def _quantities(Y: np.ndarray, p: tuple, rolling: np.ndarray) -> dict[str, np.ndarray]:
    """stickslip's contact series of each sample's contact and phase (each with the geometry of
    its own contact: row 6 is that contact's λ)."""
    Y = np.asarray(Y, dtype=float).reshape(11, -1)
    rolling = np.broadcast_to(np.asarray(rolling, dtype=bool), Y.shape[1:])
    flag = np.round(Y[10])
    n = Y.shape[1]
    out: dict[str, np.ndarray] = {
        k: np.zeros(n) for k in ("gn", "F_x", "F_y", "M_n", "margin", "gn_ball", "gn_stem")
    }
    for value, q, name in ((0, _ball(p), "gn_ball"), (1, _stem(p), "gn_stem")):
        mask = flag == value
        if mask.any():
            part = dry.contact_quantities(Y[:, mask], q, rolling[mask])
            for k, v in part.items():
                out[k][mask] = v
            out[name][mask] = part["gn"]
    both = flag == 2
    if both.any():  # both contacts sliding: the sums of their forces, margin 0
        with np.errstate(divide="ignore", invalid="ignore"):
            f = _both_contact_forces(Y[:, both], p)
        out["gn_ball"][both], out["gn_stem"][both] = f["lam"]
        out["gn"][both] = f["lam"][0] + f["lam"][1]
        out["F_x"][both] = f["F"][0][0] + f["F"][1][0]
        out["F_y"][both] = f["F"][0][1] + f["F"][1][1]
        out["M_n"][both] = f["M"][0] + f["M"][1]
    return out


def _both_contact_forces(Y: np.ndarray, p: tuple) -> dict:
    """λ_i (N), the tangential forces F_i (N) and drilling torques M_i (N m) of both contacts of
    double-contact states ``Y`` (both sliding: −μ λ_i ν_i/|γ_i|, −μ λ_i r*² ω_z/|γ_i|)."""
    mu, rs = p[ix.MU], p[ix.RSTAR]
    e, L, w, n1, n2, de = both_kinematics(
        Y, p[ix.R], p[ix.L], p[ix.I1], p[ix.I3], p[ix.DRY_R_S], p[ix.DRY_L_S]
    )
    _, lam1, lam2, s1, s2 = _slide_both(Y, p)
    F, M = [], []
    for lam, nu, s in ((lam1, n1, s1), (lam2, n2, s2)):
        k = -mu * lam / s if mu > 0.0 else 0.0 * s
        F.append((k * nu[0], k * nu[1]))
        M.append(k * rs * rs * w[2])
    return {"lam": (np.asarray(lam1), np.asarray(lam2)), "F": F, "M": M, "slip": (s1, s2)}


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
    """``contact`` ("ball"/"stem"/"both"), ``phase``, the force series (with ``gn_ball`` and
    ``gn_stem``), ``touchdowns`` and the switch records (``Model.finish``): reasons "stop",
    "cone", "reversal" (also a slip restarted in the double contact), "touchdown", "landing",
    "accumulation", "closure", "ball lifts off", "stem lifts off"."""
    p = traj.params
    names = np.asarray(traj.phase).astype(str)
    contact = np.array([n.split("-")[0] for n in names.tolist()], dtype=object).astype(str)
    phase = np.array([n.split("-")[1] for n in names.tolist()], dtype=object).astype(str)
    series = {"contact": contact, "phase": phase}
    series.update(_quantities(traj.states, p, phase == "rolling"))
    records = []
    seen: list[tuple[float, str, str]] = []
    for (t, before, after), (y_ev, _) in zip(traj.switches, traj.jumps, strict=True):
        c0, f0 = before.split("-")
        c1, f1 = after.split("-")
        margin, speed, t_sw, t_event = math.nan, math.nan, t, t
        if c0 == "both":
            why = "reversal" if c1 == "both" else _LIFT_REASONS[c1]
        elif c0 != c1:
            to = "stem" if c0 == "ball" else "ball"
            _, why, t_limit = transition(y_ev, p, to, [*seen, (t, before, f"{to}-sliding")])
            t_event = t_limit if why == "accumulation" else t
            if why in ("touchdown", "landing"):
                q = _contact(p, c1 == "stem")
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
            q = _contact(p, c1 == "stem")
            why = _REASONS[(f0, f1)]
            y_dec = y_ev if why == "cone" else dry.set_slip(y_ev, q, np.zeros(3))
            gn, _, m = dry.required(y_dec, q)
            margin = float(m / (p[ix.MU] * gn)) if p[ix.MU] > 0.0 else math.nan
            speed = float(np.linalg.norm(dry.slip(y_ev, q)))
            t_sw = dry.stop_time(t, y_ev, q) if why in ("stop", "reversal") else t
        records.append(stickslip.Switch(t_sw, before, after, why, float(margin), speed, t_event))
        seen.append((t, before, after))
    touchdowns = np.array(
        [s.t for s in records if s.before.startswith("ball") and s.after.split("-")[0] != "ball"]
    )
    acc = np.array([s.t for s in records if s.reason == "accumulation"])
    return series, {
        "switches": records,
        "touchdowns": touchdowns,
        "accumulations": acc,
        "stopping_band": p[ix.BAND],
    }


_LIFT_REASONS = {"ball": "stem lifts off", "stem": "ball lifts off"}


PHASES = ("ball-sliding", "ball-rolling", "stem-sliding", "stem-rolling", "both-sliding")

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
            Phase(
                "both-sliding",
                _python(_both_sliding_into),
                _both_sliding_into,
                (
                    Event(_both_contact, -1.0, "contact_lost"),
                    Event(
                        _both_ball_lift,
                        -1.0,
                        "switch",
                        target="stem-sliding",
                        jump=_ball_lifts,
                        select=_select,
                    ),
                    Event(
                        _both_stem_lift,
                        -1.0,
                        "switch",
                        target="ball-sliding",
                        jump=_stem_lifts,
                        select=_select,
                    ),
                    Event(
                        _both_ball_stop,
                        -1.0,
                        "switch",
                        target="both-sliding",
                        jump=_both_stop,
                        select=_select,
                    ),
                    Event(
                        _both_stem_stop,
                        -1.0,
                        "switch",
                        target="both-sliding",
                        jump=_both_stop,
                        select=_select,
                    ),
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
