"""The top with a stem under the regularised Coulomb law: the registered model
"stemmed-coulomb-regularised" (docs/theory/stem.md#regularised-coulomb-friction).

``mett.simulate(top.with_stem(...), state, t_end, friction=RegularisedCoulomb(mu, eps))`` runs
this hybrid model (the one :meth:`mett.friction.RegularisedCoulomb.model_for` names for
"stemmed"). It is the viscous stemmed top of :mod:`.stem` with one change: at each contact the
tangential force per unit normal force is

    −c(|ν|) ν,   c(|ν|) = μ/√(|ν|² + ε²)   (s/m),

where the viscous law has the constant c = μ: the regularised force −μ g_n ν/√(|ν|² + ε²)
(Ueda, Sasaki & Watanabe 2005; :class:`mett.friction.RegularisedCoulomb`). Everything else is
stem.py's, called with this coefficient: the state (the gliding state plus the contact flag
``y[10]``: 0 ball, 1 stem, 2 both), the phases "ball", "stem" and "both" with their clearances
and lift-off events, the double contact's two normal forces from the constraints
(:func:`mett.dynamics.stem.both_solve`, each contact with its own c(|ν_i|)), the accumulation
of impacts and the closure (:func:`mett.dynamics.stem.transition`). The parameters are those of
"stemmed" with μ the law's (dimensionless) and ε appended (``STEM_EPS``); the viscous model and
its tuple are untouched.

The impact at a new contact (touchdown, landing) is the perfectly inelastic Darboux–Keller
impact of the stem page with this law in impulse form,

    dP = (ẑ − μ v_t/√(|v_t|² + ε²)) dp,   dv = W dP,   until v_z = 0,

(:func:`impact`; :func:`regularised_impulse`), whose energy change
∫ (v_z − μ|v_t|²/√(|v_t|² + ε²)) dp is ≤ 0 during compression. Flights and landings are those
of :mod:`.flight` with the same landing law.

With both spheres on the table when one arrives (a change of contact whose old contact is
closed, a flight landing at the touchdown angle: "double touchdown") the impact acts at both
contacts (:func:`two_contact`, docs/theory/stem.md#two-contact-impact): the active sets of
:func:`mett.dynamics.stem.two_contact_impact` with this law's single impact, the two-contact
Darboux–Keller path of :func:`mett.dynamics.stem.viscous_path` with c(|v_t|) at each contact,
and the closure of both normal velocities with c at the post-impact slip (:func:`closure`,
Moreau's velocity-level form). A state where no set is consistent ends the run with status
"failed" at the impact, the trajectory kept.

Limits (tests/test_stem_regularised.py): for |ν| ≪ ε the law is the viscous one with
μ_visc = μ/ε (s/m); as ε → 0 it tends to Coulomb's sliding force −μ g_n ν̂ while the contact
slips. Stiffness: where |ν| ≲ ε the slip relaxes at a rate ~ μ g |W| m/ε, so a small ε makes
the phases stiff; the law is analytic (``RegularisedCoulomb.analytic``), so ``backend="auto"``
runs it on the Taylor backend, as the ball top's "coulomb-regularised".
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..friction import RegularisedCoulomb
from . import _params as ix
from . import stem
from .gliding import gliding_core, gliding_series
from .registry import Event, Model, Option, Phase, friction_law, register
from .stem import (
    STEM_DISTANCE,
    STEM_RADIUS,
    StemLaw,
    apply_impulse,
    ball_clearance,
    both_kinematics,
    both_solve,
    impact_frame,
    on_both,
    stem_clearance,
    stem_params,
)

__all__ = [
    "LAW",
    "MODEL",
    "both_core",
    "closure",
    "impact",
    "normal_forces",
    "regularised_impulse",
    "slip_coefficient",
    "two_contact",
]

_VISCOUS_LEN = 9
"""Length of the viscous "stemmed" tuple, the prefix of this model's (ε appended)."""


def _params(top: Any, options: dict) -> tuple:
    """(m, R, l, I1, I3, μ, g, r_s, l_s, ε): "stemmed"'s tuple, μ and ε of the law."""
    law = options["friction"]
    m, R, l, I1, I3, _, g, r_s, l_s = stem_params(top, options)
    return (m, R, l, I1, I3, law.mu, g, r_s, l_s, law.eps)


def _viscous(p: tuple) -> tuple:
    """The "stemmed" tuple of ``p`` (its geometry; μ is not read where it is used)."""
    return tuple(p[:_VISCOUS_LEN])


# --- the coefficient c(|ν|) and the phases: plain arithmetic, compiled ---------------------------


def slip_coefficient(y: Any, R: Any, l: Any, I1: Any, I3: Any, mu: Any, eps: Any) -> Any:
    """c = μ/√(|ν|² + ε²) (s/m) of the sphere (R, l) in contact: ν the horizontal velocity of
    its contact point, ν = ṙ + l 3̂̇ − R ω × ẑ (the arithmetic of
    :func:`mett.dynamics.gliding.gliding_core`). Plain arithmetic (floats or equal-shape arrays)."""
    n = (y[7] * y[7] + y[8] * y[8] + y[9] * y[9]) ** 0.5
    ex, ey, ez = y[7] / n, y[8] / n, y[9] / n
    Lx, Ly, Lz = y[4], y[5], y[6]
    cLe = (1.0 / I3 - 1.0 / I1) * (Lx * ex + Ly * ey + Lz * ez)
    wx = Lx / I1 + cLe * ex
    wy = Ly / I1 + cLe * ey
    dex = (Ly * ez - Lz * ey) / I1
    dey = (Lz * ex - Lx * ez) / I1
    nux = y[2] + l * dex - R * wy
    nuy = y[3] + l * dey + R * wx
    return mu / (nux * nux + nuy * nuy + eps * eps) ** 0.5


def _ball_q(y: Any, p: Any) -> tuple:
    """The gliding parameters of the ball contact with μ → c(|ν|) of state(s) ``y``."""
    c = slip_coefficient(y, p[ix.R], p[ix.L], p[ix.I1], p[ix.I3], p[ix.MU], p[ix.STEM_EPS])
    return (p[ix.M], p[ix.R], p[ix.L], p[ix.I1], p[ix.I3], c, p[ix.G])


def _stem_q(y: Any, p: Any) -> tuple:
    """The gliding parameters of the stem contact (r_s, l + l_s) with μ → c(|ν|)."""
    l2 = p[ix.L] + p[ix.L_S]
    c = slip_coefficient(y, p[ix.R_S], l2, p[ix.I1], p[ix.I3], p[ix.MU], p[ix.STEM_EPS])
    return (p[ix.M], p[ix.R_S], l2, p[ix.I1], p[ix.I3], c, p[ix.G])


def ball_rhs(t: float, y: np.ndarray, p: tuple) -> np.ndarray:
    """Gliding on the ball under the regularised law; the phase flag stays constant."""
    return np.array((*gliding_core(y, _ball_q(y, p))[:10], 0.0))


def _ball_into(t: float, y: Any, p: Any, out: Any) -> None:
    c = slip_coefficient(y, p[ix.R], p[ix.L], p[ix.I1], p[ix.I3], p[ix.MU], p[ix.STEM_EPS])
    d = gliding_core(y, (p[ix.M], p[ix.R], p[ix.L], p[ix.I1], p[ix.I3], c, p[ix.G]))
    out[0], out[1], out[2], out[3], out[4] = d[0], d[1], d[2], d[3], d[4]
    out[5], out[6], out[7], out[8], out[9] = d[5], d[6], d[7], d[8], d[9]
    out[10] = 0.0


def _ball_contact(t: float, y: Any, p: Any) -> Any:
    """g_n/(m g) of the ball contact."""
    c = slip_coefficient(y, p[ix.R], p[ix.L], p[ix.I1], p[ix.I3], p[ix.MU], p[ix.STEM_EPS])
    d = gliding_core(y, (p[ix.M], p[ix.R], p[ix.L], p[ix.I1], p[ix.I3], c, p[ix.G]))
    return d[10] * (1.0 / (p[ix.M] * p[ix.G]))


def _touchdown(t: float, y: Any, p: Any) -> Any:
    """Stem clearance while the ball touches (:func:`mett.dynamics.stem.stem_clearance`)."""
    return stem_clearance(y, p[ix.R], p[ix.R_S], p[ix.L_S])


def stem_rhs(t: float, y: np.ndarray, p: tuple) -> np.ndarray:
    """Gliding on the stem sphere under the regularised law; the phase flag stays constant."""
    return np.array((*gliding_core(y, _stem_q(y, p))[:10], 0.0))


def _stem_into(t: float, y: Any, p: Any, out: Any) -> None:
    l2 = p[ix.L] + p[ix.L_S]
    c = slip_coefficient(y, p[ix.R_S], l2, p[ix.I1], p[ix.I3], p[ix.MU], p[ix.STEM_EPS])
    d = gliding_core(y, (p[ix.M], p[ix.R_S], l2, p[ix.I1], p[ix.I3], c, p[ix.G]))
    out[0], out[1], out[2], out[3], out[4] = d[0], d[1], d[2], d[3], d[4]
    out[5], out[6], out[7], out[8], out[9] = d[5], d[6], d[7], d[8], d[9]
    out[10] = 0.0


def _stem_contact(t: float, y: Any, p: Any) -> Any:
    """g_n/(m g) of the stem contact."""
    l2 = p[ix.L] + p[ix.L_S]
    c = slip_coefficient(y, p[ix.R_S], l2, p[ix.I1], p[ix.I3], p[ix.MU], p[ix.STEM_EPS])
    d = gliding_core(y, (p[ix.M], p[ix.R_S], l2, p[ix.I1], p[ix.I3], c, p[ix.G]))
    return d[10] * (1.0 / (p[ix.M] * p[ix.G]))


def _landing(t: float, y: Any, p: Any) -> Any:
    """Ball clearance while the stem touches (:func:`mett.dynamics.stem.ball_clearance`)."""
    return ball_clearance(y, p[ix.R], p[ix.R_S], p[ix.L_S])


def both_core(y: Any, p: Any) -> tuple:
    """Rates and normal forces of the double contact under the regularised law; plain arithmetic.

    :func:`mett.dynamics.stem.both_core` with the force per unit normal force −c_i ν_i at each
    contact, c_i = μ/√(|ν_i|² + ε²) of its own slip ν_i (ball i = 1, stem i = 2), read on the
    double-contact manifold. Returns ``(rates[0:10], λ_1, λ_2)``.
    """
    mu, eps = p[ix.MU], p[ix.STEM_EPS]
    e, L, w, n1, n2, de = both_kinematics(
        y, p[ix.R], p[ix.L], p[ix.I1], p[ix.I3], p[ix.R_S], p[ix.L_S]
    )
    n1x, n1y = n1
    n2x, n2y = n2
    c1 = mu / (n1x * n1x + n1y * n1y + eps * eps) ** 0.5
    c2 = mu / (n2x * n2x + n2y * n2y + eps * eps) ** 0.5
    zero = 0.0 * n1x
    rates, lam1, lam2 = both_solve(
        y, p[ix.M], p[ix.G], p[ix.R], p[ix.L], p[ix.R_S], p[ix.L_S], e, L, de,
        (-c1 * n1x, -c1 * n1y, zero), (-c2 * n2x, -c2 * n2y, zero),
    )  # fmt: skip
    return (rates, lam1, lam2)


def both_rhs(t: float, y: np.ndarray, p: tuple) -> np.ndarray:
    """Right-hand side of the double contact (:func:`both_core`); the flag stays constant."""
    return np.array((*both_core(y, p)[0], 0.0))


def _both_into(t: float, y: Any, p: Any, out: Any) -> None:
    d = both_core(y, p)[0]
    out[0], out[1], out[2], out[3], out[4] = d[0], d[1], d[2], d[3], d[4]
    out[5], out[6], out[7], out[8], out[9] = d[5], d[6], d[7], d[8], d[9]
    out[10] = 0.0


def _both_contact(t: float, y: Any, p: Any) -> Any:
    """(λ_1 + λ_2)/(m g) = 1 (v̇_z = 0): each lift-off is its own switch."""
    d = both_core(y, p)
    return (d[1] + d[2]) * (1.0 / (p[ix.M] * p[ix.G]))


def _ball_lift(t: float, y: Any, p: Any) -> Any:
    """λ_1/(m g): the ball lifts off at 0."""
    return both_core(y, p)[1] * (1.0 / (p[ix.M] * p[ix.G]))


def _stem_lift(t: float, y: Any, p: Any) -> Any:
    """λ_2/(m g): the stem lifts off at 0."""
    return both_core(y, p)[2] * (1.0 / (p[ix.M] * p[ix.G]))


# --- the impact, the forces and the jumps (plain Python, between phases) ------------------------


def regularised_impulse(v0: np.ndarray, W: np.ndarray, mu: float, eps: float) -> np.ndarray:
    """The impulse P (N s) of the perfectly inelastic Darboux–Keller impact under the
    regularised Coulomb law, dP = (ẑ − μ v_t/√(|v_t|² + ε²)) dp, dv = W dP, from the contact
    velocity ``v0`` (v0_z < 0) until v_z = 0: :func:`mett.dynamics.stem.darboux_keller` with
    this law's tangential force per unit normal impulse
    (:func:`mett.dynamics.stem.compression_impulse`). Every single-contact impact under this
    law uses it: the landings of the ball top and the stemmed top
    (:func:`mett.dynamics.flight.land`; :mod:`.flight` re-exports it) and this model's changes
    of contact. Stiff where |v_t| ≲ ε only if the impulse is large (its stiffness is μ|W|/ε per
    unit p, over p ≲ m|v_z|): LSODA, which switches
    between Adams and BDF steps, takes ~10 steps where Radau took ~140 at the same tolerance
    (a thesis body's landing: 3 ms instead of 0.1 s).

    Energy: dE = v·dP = (v_z − μ|v_t|²/√(|v_t|² + ε²)) dp ≤ 0 during compression.
    """
    return stem.compression_impulse(
        v0, W, _tangential(mu, eps), "LSODA", 1e-10, 1e-14 * (1.0 + abs(v0[2]))
    )


def impact(y: np.ndarray, p: tuple, to: str) -> tuple[np.ndarray, np.ndarray]:
    """State after the impact of the contact ``to`` ("ball" or "stem") and the impulse P (N s):
    the perfectly inelastic Darboux–Keller impact with the regularised law in impulse form
    (module docstring; :func:`regularised_impulse`), the new contact's normal velocity 0
    afterwards."""
    f = impact_frame(y, _viscous(p), to)
    if f.v[2] < 0.0:
        P = regularised_impulse(f.v, f.W, p[ix.MU], p[ix.STEM_EPS])
    else:
        P = np.zeros(3)
    return apply_impulse(y, f, p[ix.M], P, to), P


def _skew(a: np.ndarray) -> np.ndarray:
    """[a×], the matrix of a × x."""
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


# --- the impact at both contacts ----------------------------------------------------------------

_PATH_METHOD = ("LSODA", 1e-10, 1e-14)
"""The two-contact path's integration (:func:`mett.dynamics.stem.viscous_path`): that of the
single impact (:func:`regularised_impulse`), whose stiffness, μ|W|/ε per unit normal impulse
where |v_t| ≲ ε, LSODA follows with its BDF steps."""


def _tangential(mu: float, eps: float) -> Any:
    """The law's tangential impulse per unit normal impulse, (v_x, v_y) → −c(|v_t|) v_t."""

    def law(vx: float, vy: float) -> tuple[float, float]:
        k = -mu / math.sqrt(vx * vx + vy * vy + eps * eps)
        return k * vx, k * vy

    return law


def _moreau(
    frames: Any, m: float, mu: float, w: np.ndarray, eps: float, u: np.ndarray, d: float
) -> tuple:
    """For normal impulses ``w`` (N s, ≥ 0) as the weights of the law: the velocity u⁺ = (V, ω)
    after the impact and the normal impulses λ (N s) that bring both normal velocities to 0
    with the tangential impulses P_t,i = −w_i c(|v⁺_t,i|) v⁺_t,i (:func:`closure`).

    u⁺ minimises ½ (u − u⁻)ᵀ M (u − u⁻) + Σ_i w_i μ √(|v_t,i(u)|² + ε²) over the u with
    v_n,1 = v_n,2 = 0 (M = diag(m 𝟙, I), v_i = V + ω × a_i): stationarity is
    M(u⁺ − u⁻) = Σ_i (λ_i ẑ + P_t,i) at a_i with λ the constraints' multipliers. The function is
    smooth and strictly convex, so the minimum is unique: Newton's method on its KKT system with
    a backtracking line search, started from ``u`` (feasible) with ε replaced by δ = ``d``,
    then d/10, … down to ε (each minimum the next start: the law's curvature μ/δ grows
    gradually). Returns (u⁺, λ, P_t (2, 2))."""
    f0 = frames[0]
    I = np.linalg.inv(f0.Iinv)
    M = np.zeros((6, 6))
    M[:3, :3], M[3:, 3:] = m * np.eye(3), I
    u0 = np.concatenate((f0.V, f0.w))
    J = [np.hstack((np.eye(3), -_skew(f.a))) for f in frames]  # v_i = J_i u
    C = np.array([Ji[2] for Ji in J])
    Jt = [Ji[:2] for Ji in J]
    scale = float(u0 @ M @ u0)

    def parts(u: np.ndarray, d: float) -> tuple:
        F = 0.5 * (u - u0) @ M @ (u - u0)
        g, H = M @ (u - u0), M.copy()
        for wi, Ji in zip(w, Jt, strict=True):
            if wi <= 0.0:
                continue
            v = Ji @ u
            s = math.sqrt(v @ v + d * d)
            F += wi * mu * s
            g = g + wi * mu * (Ji.T @ v) / s
            H = H + wi * mu * Ji.T @ ((np.eye(2) - np.outer(v, v) / (s * s)) / s) @ Ji
        return F, g, H

    d = max(eps, d)
    lam = np.zeros(2)
    while True:
        for _ in range(60):
            F, g, H = parts(u, d)
            K = np.zeros((8, 8))
            K[:6, :6], K[:6, 6:], K[6:, :6] = H, -C.T, C
            sol = np.linalg.solve(K, np.concatenate((-g, -C @ u)))
            du, lam = sol[:6], sol[6:]
            dec = float(du @ H @ du)  # twice the decrease of the quadratic model
            if dec <= 1e-28 * scale:  # |du| ~ 1e-14 of |u| in the energy norm
                break
            t = 1.0
            # far from the minimum: a backtracking line search (Armijo); near it, where F's
            # decrease ~ dec would drown in its rounding (1e-16 F), Newton's full step
            while (
                dec > 1e-14 * scale and t > 1e-12 and parts(u + t * du, d)[0] > F - 0.25 * t * dec
            ):
                t *= 0.5
            u = u + t * du
        if d == eps:
            break
        d = max(eps, 0.1 * d)
    Pt = np.array([-wi * mu * (Ji @ u) / math.sqrt((Ji @ u) @ (Ji @ u) + eps * eps)
                   if wi > 0.0 else np.zeros(2) for wi, Ji in zip(w, Jt, strict=True)])  # fmt: skip
    return u, lam, Pt


def closure(frames: Any, m: float, mu: float, eps: float) -> np.ndarray | None:
    """The impulses (2, 3) (N s) that bring both normal velocities to 0 under the regularised
    law, or None if no solution is found: the two-contact impact with both contacts closed
    (:func:`mett.dynamics.stem.two_contact_impact`).

    Moreau's velocity-level form, as :func:`mett.dynamics.stem.viscous_closure`, with the
    coefficient at the post-impact slip: v⁺ = v⁻ + W P, v⁺_n,1 = v⁺_n,2 = 0,

        P_t,i = −P_n,i c(|v⁺_t,i|) v⁺_t,i,   c(|v|) = μ/√(|v|² + ε²).

    For given normal impulses the tangential ones are unique: they are those of the minimum of
    a strictly convex function (:func:`_moreau`), whose multipliers λ(P_n) are the normal
    impulses that close both contacts with them. The closure is the fixed point P_n = λ(P_n),
    solved by Powell's hybrid method from the frictionless P_n (the solution at μ = 0). It
    exists wherever k = μ max_j Σ_i ‖(W_nn⁻¹ W_nt)_j,i‖ < 1 (row j, the 1×2 block of contact
    i): the law's impulse lies inside the Coulomb cone, |P_t,i| < μ P_n,i, so
    ‖λ(P_n) − λ(0)‖_∞ ≤ k ‖P_n‖_∞ and λ maps the box ‖P_n‖_∞ ≤ ‖λ(0)‖_∞/(1 − k) into itself
    (Brouwer; k = 0.69 for the thesis body with a stem at μ = 0.3, 1.25 for friedl1997, where
    the bound does not decide). It is unique where λ is a contraction (small k, large ε: the
    viscous limit), which is not proven in general — the result is checked against the law,
    and None (the set inconsistent: JumpFailed, status "failed") if the solve fails.
    The kinetic energy changes by ΔT = −Σ P_n,i c_i |v⁺_t,i|² − ½ PᵀWP ≤ 0 when P_n ≥ 0.
    """
    from scipy.optimize import root

    f0 = frames[0]
    M = np.zeros((6, 6))
    M[:3, :3], M[3:, 3:] = m * np.eye(3), np.linalg.inv(f0.Iinv)
    C = np.array([np.hstack((np.eye(3), -_skew(f.a)))[2] for f in frames])
    u0 = np.concatenate((f0.V, f0.w))
    # the frictionless closure: the projection of u⁻ onto v_n = 0 in the metric M
    MinvCt = np.linalg.solve(M, C.T)
    lam0 = -np.linalg.solve(C @ MinvCt, C @ u0)
    start = [u0 + MinvCt @ lam0]  # the last minimum: the next evaluation's start
    if mu == 0.0:
        return np.array([[0.0, 0.0, lam0[0]], [0.0, 0.0, lam0[1]]])

    d = [max(float(np.max(np.abs(f.v))) for f in frames)]  # the first continuation's start

    def fixed(w: np.ndarray) -> np.ndarray:
        u, lam, _ = _moreau(frames, m, mu, np.maximum(w, 0.0), eps, start[0], d[0])
        start[0], d[0] = u, eps  # the next from this minimum, at ε
        return lam - w

    sol = root(fixed, lam0, method="hybr", options={"xtol": 1e-13})
    Pn_scale = float(np.max(np.abs(lam0)))
    w = sol.x
    if not np.all(np.isfinite(w)) or np.max(np.abs(fixed(w))) > 1e-10 * Pn_scale:
        return None
    _, lam, Pt = _moreau(frames, m, mu, np.maximum(w, 0.0), eps, start[0], d[0])
    return np.column_stack((Pt, lam))


def two_contact(
    y: np.ndarray, p: tuple, first: int, vz: float | None = None
) -> stem.TwoContactImpact:
    """The impact at both contacts (:func:`mett.dynamics.stem.two_contact_impact`) of state
    ``y`` under the regularised law, the sphere ``first`` (0 ball, 1 stem) arriving, ``vz`` the
    vertical CM velocity (m/s; None: that of the contact of its flag): one contact by the
    Darboux–Keller impact of :func:`impact`; the other closed before and pushed by the
    two-contact path of :func:`mett.dynamics.stem.viscous_path` with the coefficient
    c(|v_t|) of each contact's slip; both by :func:`closure`."""
    m, mu, eps = p[ix.M], p[ix.MU], p[ix.STEM_EPS]
    q = _viscous(p)
    law = _tangential(mu, eps)

    def single(f: stem.ImpactFrame) -> tuple:
        return regularised_impulse(f.v, f.W, mu, eps), 0.0

    def both(frames: Any) -> tuple | None:
        P = closure(frames, m, mu, eps)
        return None if P is None else (stem.closed_on_both(y, frames, m, P, q), P, np.zeros(2))

    def path(frames: Any, a: int) -> tuple | None:
        # c ≤ μ/ε sets the stiffness; LSODA integrates it wherever it is stiff
        return stem.viscous_path(frames, m, mu / eps, a, law, _PATH_METHOD)

    return stem.two_contact_impact(y, q, first, single, both, vz, path)


def _both_forces(y: np.ndarray, p: tuple) -> tuple[float, float]:
    d = both_core(np.asarray(y, dtype=float), p)
    return float(d[1]), float(d[2])


def normal_forces(Y: np.ndarray, p: tuple) -> tuple[np.ndarray, np.ndarray]:
    """The normal forces (N) of the ball and of the stem of states ``Y`` (11, k) or (11,): the
    single contact's g_n and 0, or λ_1, λ_2 of the double contact (:func:`both_core`)."""
    Y = np.asarray(Y, dtype=float)
    flag = np.round(Y[10])
    gb = np.asarray(gliding_core(Y, _ball_q(Y, p))[10], dtype=float)
    gs = np.asarray(gliding_core(Y, _stem_q(Y, p))[10], dtype=float)
    with np.errstate(invalid="ignore", divide="ignore"):
        d = both_core(Y, p)
    l1, l2 = np.asarray(d[1], dtype=float), np.asarray(d[2], dtype=float)
    ball = np.where(flag == 0, gb, np.where(flag == 2, l1, 0.0))
    stem_ = np.where(flag == 1, gs, np.where(flag == 2, l2, 0.0))
    return ball, stem_


LAW = StemLaw(impact, _both_forces, normal_forces, two_contact)
"""The regularised law's :class:`mett.dynamics.stem.StemLaw` (impacts and forces)."""


def _to_stem(y: np.ndarray, p: tuple, switches: Any = ()) -> np.ndarray:
    return stem.transition(y, p, "stem", switches, LAW)[0]


def _to_ball(y: np.ndarray, p: tuple, switches: Any = ()) -> np.ndarray:
    return stem.transition(y, p, "ball", switches, LAW)[0]


def _lift(y: np.ndarray, p: tuple, to: float) -> np.ndarray:
    out = on_both(y, _viscous(p))  # the manifold's geometry: no friction read
    out[10] = to
    return out


def _ball_lifts(y: np.ndarray, p: tuple) -> np.ndarray:
    """Lift-off of the ball (λ_1 = 0): the state of the double contact, on the stem."""
    return _lift(y, p, 1.0)


def _stem_lifts(y: np.ndarray, p: tuple) -> np.ndarray:
    """Lift-off of the stem (λ_2 = 0): the state of the double contact, on the ball."""
    return _lift(y, p, 0.0)


def _select(y: np.ndarray, p: tuple) -> str:
    """The phase of a state by its flag: 0 ball, 1 stem, 2 both."""
    return stem.PHASE_NAMES[round(float(y[10]))]


# --- conversions and series ----------------------------------------------------------------------


def _initial(state: Any, p: tuple) -> np.ndarray:
    return stem.MODEL.initial(state, _viscous(p))


def _start_phase(y0: np.ndarray, p: tuple) -> str:
    return _select(y0, p)


def _scales(y0: np.ndarray, p: tuple) -> np.ndarray:
    return stem.MODEL.scales(y0, _viscous(p))


def _theta(Y: np.ndarray, p: tuple) -> np.ndarray:
    return stem.MODEL.theta(Y, _viscous(p))


def _normal_force(y: np.ndarray, p: tuple) -> Any:
    """The total normal force (N): that of the contact, or λ_1 + λ_2 = m g in the double contact."""
    ball, stem_ = normal_forces(y, p)
    return ball + stem_


def _derive(Y: np.ndarray, p: tuple) -> dict[str, np.ndarray]:
    """Series of each sample on its own contact (as "stemmed"): ν, g_n, E, λ of the sphere in
    contact; in the double contact those of the ball with g_n = λ_1 + λ_2."""
    Y = np.array(Y, dtype=float)
    both = Y[10] > 1.5
    if np.any(both):  # the double-contact samples on their manifold, as both_core reads them
        Y[:, both] = on_both(Y[:, both], _viscous(p))
    ball, stem_ = gliding_series(Y, _ball_q(Y, p)), gliding_series(Y, _stem_q(Y, p))
    on = np.round(Y[10]) == 1
    out = {k: np.where(on, stem_[k], np.asarray(ball[k], dtype=float)) for k in ball}
    out["gn"] = np.asarray(_normal_force(Y, p), dtype=float)
    out["x"], out["y"] = Y[0], Y[1]
    return out


def _finish(traj: Any) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """``Model.finish``: that of "stemmed" (:func:`mett.dynamics.stem.finish`) with this law."""
    return stem.finish(traj, LAW)


MODEL = register(
    Model(
        name="stemmed-coulomb-regularised",
        summary="tippe top with a spherical stem under regularised Coulomb friction "
        "μ g_n ν/√(|ν|² + ε²): ball, stem and double contact, inelastic impacts "
        "(docs/theory/stem.md; Leine & Glocker 2003; Ueda et al. 2005)",
        rhs=ball_rhs,
        rhs_into=_ball_into,
        normal_force=_normal_force,
        params=_params,
        initial=_initial,
        derive=_derive,
        theta=_theta,
        scales=_scales,
        conserved_lengths=((7, 8, 9),),
        events=(
            Event(_ball_contact, -1.0, "contact_lost"),
            Event(
                _touchdown,
                -1.0,
                "switch",
                target="stem",
                jump=_to_stem,
                select=_select,
                history=True,
            ),
        ),
        options=(
            STEM_RADIUS,
            STEM_DISTANCE,
            Option("friction", friction_law, None, "the regularised Coulomb law"),
        ),
        friction=(RegularisedCoulomb,),
        phase="ball",
        phases=(
            Phase(
                "stem",
                stem_rhs,
                _stem_into,
                (
                    Event(_stem_contact, -1.0, "contact_lost"),
                    Event(
                        _landing,
                        -1.0,
                        "switch",
                        target="ball",
                        jump=_to_ball,
                        select=_select,
                        history=True,
                    ),
                ),
            ),
            Phase(
                "both",
                both_rhs,
                _both_into,
                (
                    Event(_both_contact, -1.0, "contact_lost"),
                    Event(_ball_lift, -1.0, "switch", target="stem", jump=_ball_lifts),
                    Event(_stem_lift, -1.0, "switch", target="ball", jump=_stem_lifts),
                ),
            ),
        ),
        start_phase=_start_phase,
        finish=_finish,
    )
)
"""The stemmed top under ``friction=RegularisedCoulomb(mu, eps)`` (module docstring)."""
