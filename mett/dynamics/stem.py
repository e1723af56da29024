"""A tippe top with a stem, simulated through the change of contact (docs/theory/stem.md).

The body is one rigid body whichever sphere touches the plane; only the contact vector differs
(mett's convention: 3̂ points from the CM G towards the ball's centre, θ = angle(3̂, ẑ)):

    ball:  a   = l 3̂ − R ẑ,                 l = αR,
    stem:  a_s = (l + l_s) 3̂ − r_s ẑ       (stem centre at G + (l + l_s) 3̂).

So each phase is the gliding vector form (:mod:`mett.dynamics.gliding`) with (R, l) or
(r_s, l + l_s). The state is the gliding state plus a phase flag ``y[10]`` (0: ball, 1: stem,
2: both; its rate is 0), so that every sample says which constraint fixes the CM height and
vertical velocity (the two agree in position at the switch, not in velocity).

Phase "both" (:func:`both_core`, docs/theory/stem.md#double-contact): both spheres on the plane,
θ held at the touchdown angle, two normal forces λ_1 (ball), λ_2 (stem) from the two
constraints. It starts when impacts accumulate (:func:`accumulation`: a geometric sequence of
impact times, jumped to its limit by :func:`close_both`) or when an impact would leave the old
contact closing, if both forces are positive (:func:`transition`); it ends when either force
reaches 0 (the lift-off of that contact, located as an event).

Switches (hybrid model, :mod:`mett.dynamics.registry`):

* touchdown, ball → stem (or both): the stem clearance R + l_s 3̂_z − r_s falls through 0;
* landing, stem → ball (or both): the ball clearance r_s − l_s 3̂_z − R falls through 0;
* lift-off, both → stem or ball: λ_1 or λ_2 falls through 0.

The new contact arrives with a downward normal velocity, so the switch is an impact. Impact law
(Darboux–Keller, perfectly inelastic): the normal impulse p grows from 0 and the tangential
impulse follows the viscous law in impulse form, dP = (ẑ − μ v_t) dp, v_t the horizontal velocity
of the new contact point; the contact-point velocity then obeys the linear ODE
dv/dp = W (ẑ − μ v_t), W = 𝟙/m − [a×] I⁻¹ [a×], integrated until the normal velocity v_z reaches 0
(restitution e = 0: the end of compression). Energy changes by ∫ (v_z − μ|v_t|²) dp ≤ 0 (v_z < 0
during compression). Momentum and angular momentum about G change by P and a × P.

With both spheres on the table when one arrives (the other contact closed, or a flight landing
at the touchdown angle) the impact acts at both contacts (:func:`two_contact_impact`,
docs/theory/stem.md#two-contact-impact): normal impulses ≥ 0, normal velocities after ≥ 0 and
complementary, solved by its active sets — one contact by the impact above; with the other
contact closed before, the two-contact Darboux–Keller path (:func:`viscous_path`); both by
:func:`viscous_closure` — unique without friction (the 2×2 normal Delassus block is positive
definite). The regularised Coulomb law's (:func:`mett.dynamics.stemreg.two_contact`) is the
same with its coefficient c(|v_t|) (:class:`StemLaw`'s ``two_contact``).

Under dry friction (``friction=Coulomb(...)``) the model "stemmed-coulomb" of :mod:`.stemslip`
runs instead: the same geometry, clearances and impact frame, with stick–slip phases and the
Coulomb law in the impulse equations.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np

from ..friction import Coulomb, Viscous
from . import _params as ix
from ._model import lab_vectors, scales_from_state, unit_axis
from .gliding import gliding_core, gliding_series
from .hybrid import geometric_tail  # the Zeno test, shared with the hops of flight.py
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
    "ACCUMULATION_RATIOS",
    "ACCUMULATION_SPREAD",
    "BOTH_FORCE_MIN",
    "MODEL",
    "PHASE_NAMES",
    "TWO_CONTACT_RTOL",
    "VISCOUS_LAW",
    "Accumulation",
    "ImpactFrame",
    "StemLaw",
    "TwoContactImpact",
    "accumulation",
    "apply_impulse",
    "ball_clearance",
    "both_core",
    "both_kinematics",
    "both_rhs",
    "both_solve",
    "close_both",
    "closed_on_both",
    "compression_impulse",
    "darboux_keller",
    "finish",
    "impact",
    "impact_frame",
    "land_both",
    "normal_forces",
    "on_both",
    "stem_clearance",
    "stem_params",
    "transition",
    "two_contact_delassus",
    "two_contact_impact",
    "viscous_closure",
    "viscous_path",
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


# --- both spheres on the plane ("both", flag 2) -------------------------------------------------


def both_core(y: Any, p: Any) -> tuple:
    """Rates and normal forces of the double contact; plain arithmetic (docs/theory/stem.md).

    Both contact constraints hold: the CM height is fixed and 3̂_z = c_t = (r_s − R)/l_s (θ at the
    touchdown angle), so v_z = 0 and θ̇ = 0. The axis is that of the state turned to θ_t about
    the vertical (its azimuth is the state's; its length and 3̂_z are not read), and L loses its
    component along the line of nodes n̂ = ẑ × 3̂/sin θ_t (the θ̇ the constraint forbids): the
    state represents a point of the double-contact manifold exactly, whatever the integrator's
    drift (:func:`both_kinematics`). With F_i = λ_i(ẑ − μ ν_i) at the ball (i = 1;
    a_1 = l 3̂ − R ẑ) and the stem (i = 2; a_2 = (l + l_s) 3̂ − r_s ẑ), the two normal forces
    follow from the constraints at acceleration level (:func:`both_solve`). Returns
    ``(rates[0:10], λ_1, λ_2, 3̂, L, ω, ν_1, ν_2)``.
    """
    mu = p[ix.MU]
    e, L, w, n1, n2, de = both_kinematics(
        y, p[ix.R], p[ix.L], p[ix.I1], p[ix.I3], p[ix.R_S], p[ix.L_S]
    )
    n1x, n1y = n1
    n2x, n2y = n2
    u1x, u1y, u2x, u2y = -mu * n1x, -mu * n1y, -mu * n2x, -mu * n2y
    zero = 0.0 * u1x
    rates, lam1, lam2 = both_solve(
        y, p[ix.M], p[ix.G], p[ix.R], p[ix.L], p[ix.R_S], p[ix.L_S], e, L, de,
        (u1x, u1y, zero), (u2x, u2y, zero),
    )  # fmt: skip
    return (rates, lam1, lam2, e, L, w, n1, n2)


def both_kinematics(y: Any, R: Any, l: Any, I1: Any, I3: Any, r_s: Any, l_s: Any) -> tuple:
    """(3̂, L, ω, ν_1, ν_2, 3̂̇) of state(s) ``y`` read on the double-contact manifold (3̂ turned to
    θ_t about the vertical, L without its nodal part; :func:`both_core`): the horizontal slip
    velocities ν_1 of the ball's and ν_2 of the stem's contact point. Plain arithmetic, shared by
    the viscous and the dry double contact (:mod:`.stemslip`)."""
    l2 = l + l_s
    ez = (r_s - R) / l_s
    st = (1.0 - ez * ez) ** 0.5
    nh = (y[7] * y[7] + y[8] * y[8]) ** 0.5
    ex, ey = st * y[7] / nh, st * y[8] / nh
    Lx, Ly, Lz = y[4], y[5], y[6]
    Ln = (Ly * ex - Lx * ey) / st  # L·n̂, n̂ = (−3̂_y, 3̂_x, 0)/sin θ_t
    Lx = Lx + Ln * ey / st
    Ly = Ly - Ln * ex / st
    cLe = (1.0 / I3 - 1.0 / I1) * (Lx * ex + Ly * ey + Lz * ez)
    wx, wy, wz = Lx / I1 + cLe * ex, Ly / I1 + cLe * ey, Lz / I1 + cLe * ez
    dex = (Ly * ez - Lz * ey) / I1  # 3̂̇ = (L × 3̂)/I1, its vertical part 0 by the projection
    dey = (Lz * ex - Lx * ez) / I1
    vx, vy = y[2], y[3]
    n1x, n1y = vx + l * dex - R * wy, vy + l * dey + R * wx  # slip of the ball's contact point
    n2x, n2y = vx + l2 * dex - r_s * wy, vy + l2 * dey + r_s * wx  # and of the stem's
    return (ex, ey, ez), (Lx, Ly, Lz), (wx, wy, wz), (n1x, n1y), (n2x, n2y), (dex, dey)


def both_solve(
    y: Any, m: Any, g: Any, R: Any, l: Any, r_s: Any, l_s: Any,
    e: tuple, L: tuple, de: tuple, f1: tuple, f2: tuple,
) -> tuple:  # fmt: skip
    """(rates[0:10], λ_1, λ_2) of the double contact whose contact forces per unit normal force
    are F_i/λ_i = (f_ix, f_iy, 1) at a_i with the torque f_iz ẑ per unit normal force (the
    friction law of contact i: viscous −μ ν_i, Coulomb −μ ν̂_i, Contensou's drilling torque).

    With K_i = a_i × (ẑ + f_i) + f_iz ẑ and k_i = (K_i × 3̂)·ẑ, the constraints at acceleration
    level are

        v̇_z = 0:  λ_1 + λ_2 = m g,
        3̂̈_z = 0:  λ_1 k_1 + λ_2 k_2 = −(L × 3̂̇)·ẑ      (I1 3̂̈_z = (L̇ × 3̂ + L × 3̂̇)·ẑ),

    solved in closed form; the drilling torques do not enter k_i (only L̇_z). Plain arithmetic.
    """
    l2 = l + l_s
    ex, ey, ez = e
    Lx, Ly, Lz = L
    dex, dey = de
    u1x, u1y, t1 = f1
    u2x, u2y, t2 = f2
    vx, vy = y[2], y[3]
    a1x, a1y, a1z = l * ex, l * ey, l * ez - R
    a2x, a2y, a2z = l2 * ex, l2 * ey, l2 * ez - r_s
    K1x, K1y, K1z = a1y - a1z * u1y, a1z * u1x - a1x, a1x * u1y - a1y * u1x + t1
    K2x, K2y, K2z = a2y - a2z * u2y, a2z * u2x - a2x, a2x * u2y - a2y * u2x + t2
    k1 = K1x * ey - K1y * ex
    k2 = K2x * ey - K2y * ex
    q = Lx * dey - Ly * dex  # (L × 3̂̇)·ẑ
    det = k1 - k2  # = −l_s sin²θ_t at μ = 0
    lam1 = (-q - m * g * k2) / det
    lam2 = (q + m * g * k1) / det
    rates = (
        vx,
        vy,
        (lam1 * u1x + lam2 * u2x) / m,
        (lam1 * u1y + lam2 * u2y) / m,
        lam1 * K1x + lam2 * K2x,
        lam1 * K1y + lam2 * K2y,
        lam1 * K1z + lam2 * K2z,
        dex,
        dey,
        0.0,
    )
    return rates, lam1, lam2


def both_rhs(t: float, y: np.ndarray, p: tuple) -> np.ndarray:
    """Right-hand side of the double contact (:func:`both_core`); the phase flag stays constant."""
    return np.array((*both_core(y, p)[0], 0.0))


def _both_into(t: float, y: Any, p: Any, out: Any) -> None:
    d = both_core(y, p)[0]
    out[0], out[1], out[2], out[3], out[4] = d[0], d[1], d[2], d[3], d[4]
    out[5], out[6], out[7], out[8], out[9] = d[5], d[6], d[7], d[8], d[9]
    out[10] = 0.0


def _both_contact(t: float, y: Any, p: Any) -> Any:
    """(λ_1 + λ_2)/(m g) = 1: the double contact cannot lose both contacts at once (v̇_z = 0);
    each lift-off is a switch (:func:`_ball_lift`, :func:`_stem_lift`)."""
    d = both_core(y, p)
    return (d[1] + d[2]) * (1.0 / (p[ix.M] * p[ix.G]))


def _ball_lift(t: float, y: Any, p: Any) -> Any:
    """λ_1/(m g), the ball's normal force in the double contact: the ball lifts off at 0."""
    return both_core(y, p)[1] * (1.0 / (p[ix.M] * p[ix.G]))


def _stem_lift(t: float, y: Any, p: Any) -> Any:
    """λ_2/(m g), the stem's normal force in the double contact: the stem lifts off at 0."""
    return both_core(y, p)[2] * (1.0 / (p[ix.M] * p[ix.G]))


def on_both(y: np.ndarray, p: tuple) -> np.ndarray:
    """The state ``y`` on the double-contact manifold, as :func:`both_core` reads it: 3̂ turned
    to θ_t about the vertical (unit length), L without its nodal part; flag 2."""
    d = both_core(np.asarray(y, dtype=float), p)
    out = np.array(y, dtype=float)
    for i in range(3):  # 3̂_z and L_z are scalars where the rest are arrays
        out[4 + i] = d[4][i]
        out[7 + i] = d[3][i]
    out[10] = 2.0
    return out


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


def impact_frame(y: np.ndarray, p: tuple, to: str, vz: float | None = None) -> ImpactFrame:
    """:class:`ImpactFrame` of state ``y`` (on the other sphere) for an impact of contact ``to``
    ("ball" or "stem"); ``p`` the parameters of the "stemmed" model (μ unused). ``vz``: the
    vertical CM velocity (m/s) of a state in flight; None: that of the other sphere's contact
    constraint."""
    old, new = (_stem(p), _ball(p)) if to == "ball" else (_ball(p), _stem(p))
    m, I1, I3 = p[ix.M], p[ix.I1], p[ix.I3]
    e, L, w, V = _body(y, old)
    if vz is not None:
        V = np.array([V[0], V[1], float(vz)])
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
    p1 = 10.0 * -v0[2] / W[2, 2]
    if mu * np.linalg.norm(W, 2) * p1 > 1e3:  # stiff: see _darboux_keller_stiff
        return _darboux_keller_stiff(v0, W, mu, p1)
    return compression_impulse(
        v0, W, lambda vx, vy: (-mu * vx, -mu * vy), "DOP853", 1e-13, 1e-15 * (1.0 + abs(v0[2]))
    )


def compression_impulse(
    v0: np.ndarray,
    W: np.ndarray,
    tangential: Any,
    method: str,
    rtol: float,
    atol: float,
) -> np.ndarray:
    """The impulse P (N s) of a perfectly inelastic Darboux–Keller impact whose tangential
    impulse per unit normal impulse is ``tangential(v_x, v_y)`` (a friction law in impulse form):
    dP = (tangential(v_t), 1) dp, dv = W dP from the contact velocity ``v0`` (v0_z < 0) until
    v_z = 0, the end of compression, integrated with ``solve_ivp(method, rtol, atol)``. Raises
    :class:`JumpFailed` if the impulse equations cannot be solved.
    """
    from scipy.integrate import solve_ivp

    def rate(_: float, z: np.ndarray) -> np.ndarray:
        tx, ty = tangential(z[0], z[1])
        dP = np.array([tx, ty, 1.0])
        return np.concatenate((W @ dP, dP))

    def stop(_: float, z: np.ndarray) -> float:
        return z[2]

    stop.terminal, stop.direction = True, 1.0  # type: ignore[attr-defined]
    # The impact always ends: v_t relaxes to W_tt⁻¹W_tz/μ and then v_z grows at the rate
    # 1/(W⁻¹)_zz > 0 (W positive definite). Friction can make p much larger than the
    # frictionless −v_z/W_zz, so the interval is extended until v_z reaches 0.
    z, p0, p1 = np.concatenate((v0, np.zeros(3))), 0.0, 10.0 * -v0[2] / W[2, 2]
    for _ in range(12):
        sol = solve_ivp(rate, (p0, p1), z, method=method, events=stop, rtol=rtol, atol=atol)
        if sol.status != 0:
            break
        z, p0, p1 = sol.y[:, -1], p1, 10.0 * p1
    if sol.status != 1:
        raise JumpFailed(f"impact: the impulse equations could not be solved ({sol.message})")
    return np.asarray(sol.y_events[0][0][3:], dtype=float)


def _darboux_keller_stiff(v0: np.ndarray, W: np.ndarray, mu: float, p1: float) -> np.ndarray:
    """:func:`darboux_keller` where friction relaxes the slip over an impulse ~ 1/(μ|W|) far
    below the impact's (huge μ or speeds): an explicit method would need ~ μ|W| p1 steps.

    The impulse equations are linear with constant coefficients, dv/dp = W ẑ − μ W S v
    (S = diag(1, 1, 0)), so v(p) = expm(M p) applied to (v0, 1) with M = [[−μ W S, W ẑ], [0, 0]],
    exactly; the end of compression v_z(p) = 0 is bracketed and found by Brent's method, and
    P = W⁻¹ (v − v0) since dv = W dP.
    """
    from scipy.linalg import expm
    from scipy.optimize import brentq

    if mu * np.linalg.norm(W, 2) * p1 > 1e15:
        # the slip stops at once and stays O(1/(μ|W|)) below rounding: the contact point stops,
        # v = 0 (the limit μ → ∞, a sticking plastic impact)
        return np.linalg.solve(W, -v0)

    M = np.zeros((4, 4))
    M[:3, :2] = -mu * W[:, :2]
    M[:3, 3] = W[:, 2]
    x0 = np.append(v0, 1.0)

    def v_at(p: float) -> np.ndarray:
        return (expm(M * p) @ x0)[:3]

    hi = p1
    for _ in range(12):  # v_z grows once the slip has relaxed (darboux_keller): bracket its zero
        if v_at(hi)[2] > 0.0:
            break
        hi *= 10.0
    else:
        raise JumpFailed(
            "impact: the impulse equations could not be solved (no end of compression)"
        )
    p_end = brentq(lambda p: v_at(p)[2], 0.0, hi, xtol=1e-15 * hi, rtol=4 * np.finfo(float).eps)
    return np.linalg.solve(W, v_at(p_end) - v0)


# --- entering and leaving the double contact -------------------------------------------------

ACCUMULATION_RATIOS = 3
"""Impacts accumulate when this many consecutive two-impact ratios q_k = Δ_k/Δ_{k−2} of the
intervals Δ between impacts agree to :data:`ACCUMULATION_SPREAD` and lie in (0, 1): the bounces
(ball, stem, ball, …: two alternating geometric sequences) then form a geometric series with a
finite limit (Zeno), which the run jumps to instead of resolving its infinitely many impacts."""

ACCUMULATION_SPREAD = 0.1
"""Relative spread allowed between consecutive ratios q_k (see :data:`ACCUMULATION_RATIOS`)."""

BOTH_FORCE_MIN = 1e-9
"""A double contact starts only if both normal forces exceed this fraction of m g: a force that
starts at 0 would fall through it unseen (a zero at a phase's start is no event); the other
contact then carries the top alone."""


class Accumulation(NamedTuple):
    """A geometric sequence of impacts detected at the last impact (:func:`accumulation`)."""

    ratio: float
    """q = Δ_k/Δ_{k−2}, the geometric ratio of every second interval (the mean of the last
    :data:`ACCUMULATION_RATIOS`)."""
    t_limit: float
    """t_∞ = t_k + q (Δ_{k−1} + Δ_k)/(1 − q) (s): the accumulation point, the sum of the
    remaining intervals of both alternating sequences."""


def accumulation(times: Any) -> Accumulation | None:
    """The accumulation point of the impact times ``times`` (s, increasing, the last the impact
    just located), or None if their intervals are not (yet) a geometric sequence.

    With ball and stem alternating, the intervals Δ_k on the stem and on the ball form two
    geometric sequences of the same ratio q (each bounce loses the same fraction of its normal
    speed at each contact and its duration is proportional to that speed): the test is on
    q_k = Δ_k/Δ_{k−2}, and t_∞ = t_k + Σ_{j≥1} Δ_{k+j} = t_k + q (Δ_{k−1} + Δ_k)/(1 − q).
    """
    t = np.asarray(times, dtype=float)
    tail = geometric_tail(np.diff(t), 2, ACCUMULATION_RATIOS, ACCUMULATION_SPREAD)
    if tail is None:
        return None
    return Accumulation(tail[0], float(t[-1] + tail[1]))


def _impact_times(switches: Any) -> list[float]:
    """Times of the trailing run of impacts (ball ↔ stem switches) in ``switches``."""
    out: list[float] = []
    for t, before, after in reversed(switches):
        if {before, after} != {"ball", "stem"}:
            break
        out.append(t)
    return out[::-1]


def close_both(y: np.ndarray, p: tuple, on: str) -> tuple[np.ndarray, np.ndarray]:
    """The state on both contacts after the perfectly plastic impact that stops both normal
    velocities, and the normal impulses (P_1, P_2) (N s) of the ball and the stem.

    ``y`` is a state on the contact ``on``. The impulses are vertical: P = −W_nn⁻¹ v_n, W_nn the
    2×2 normal block of the Delassus matrix of the two contacts, W_ij = 𝟙/m − [a_i×] I⁻¹ [a_j×].
    This is the projection of the velocity onto the double-contact constraints in the metric of
    the kinetic energy, which therefore falls by ½ v_nᵀ W_nn⁻¹ v_n ≥ 0 whatever the signs of the
    impulses: the limit of an accumulating sequence of impacts (docs/theory/stem.md).
    """
    e, L, w, V = _body(y, _ball(p) if on == "ball" else _stem(p))
    m, I1, I3 = p[ix.M], p[ix.I1], p[ix.I3]
    Iinv = np.eye(3) / I1 + (1.0 / I3 - 1.0 / I1) * np.outer(e, e)
    z = np.array([0.0, 0.0, 1.0])
    arms = [p[ix.L] * e - p[ix.R] * z, (p[ix.L] + p[ix.L_S]) * e - p[ix.R_S] * z]
    v_n = np.array([V[2] + np.cross(w, a)[2] for a in arms])
    # W_ij,zz = 1/m + (a_i × ẑ)·I⁻¹(a_j × ẑ)
    t_ = [np.cross(a, z) for a in arms]
    Wnn = np.array([[1.0 / m + t_[i] @ Iinv @ t_[j] for j in range(2)] for i in range(2)])
    P = -np.linalg.solve(Wnn, v_n)
    out = np.array(y, dtype=float)  # the horizontal CM velocity keeps (vertical impulses)
    out[4:7] = L + P[0] * t_[0] + P[1] * t_[1]
    return on_both(out, p), P


# --- the impact at both contacts -----------------------------------------------------------------

TWO_CONTACT_RTOL = 1e-12
"""Rounding allowance of the two-contact impact (:func:`two_contact_impact`), relative to the
largest contact-point speed before it (velocities) or the largest impulse (impulses): an opening
contact's normal velocity ≥ −allowance, a closed contact's normal impulse ≥ −allowance."""


class TwoContactImpact(NamedTuple):
    """The perfectly inelastic impact of the stemmed top at both contacts
    (:func:`two_contact_impact`)."""

    closed: tuple[bool, bool]
    """The contacts (ball, stem) closed after it: the active set."""
    P: np.ndarray
    """Impulses (N s) at the ball's and the stem's contact points, shape (2, 3)."""
    Q: np.ndarray
    """Drilling impulses about ẑ (N m s) at the ball and the stem, shape (2,): the
    Coulomb–Contensou law's (0 for the other laws)."""
    v_n: np.ndarray
    """Normal velocities (m/s) of the ball's and the stem's contact points after it."""
    state: np.ndarray
    """The state after it (L_z in row 6; flag 0/1 on one contact, 2 on both: on the
    double-contact manifold, :func:`on_both`)."""


def _after_velocities(
    f: ImpactFrame, m: float, I1: float, I3: float, arms: Any, P: Any, Q: Any
) -> np.ndarray:
    """The normal velocities of the contact points ``arms`` after the impulses ``P`` (one (3,) per
    arm, at that arm) and the drilling impulse ``Q`` ẑ, from the frame ``f``."""
    V = f.V + sum(P) / m
    L = f.L + sum(np.cross(a, Pi) for a, Pi in zip(arms, P, strict=True))
    L[2] += float(np.sum(Q))
    w = L / I1 + (1.0 / I3 - 1.0 / I1) * float(L @ f.e) * f.e
    return np.array([V[2] + np.cross(w, a)[2] for a in arms])


def two_contact_impact(
    y: np.ndarray,
    p: tuple,
    first: int,
    single: Any,
    both: Any,
    vz: float | None = None,
    path: Any = None,
) -> TwoContactImpact:
    """The perfectly inelastic impact of a state ``y`` whose two spheres are both on the table
    (gap 0 to the event tolerance): normal impulses P_1, P_2 ≥ 0, normal velocities after
    v_1⁺, v_2⁺ ≥ 0 and complementary to them (P_i v_i⁺ = 0), the friction law in impulse form
    at each contact (docs/theory/stem.md#two-contact-impact).

    ``y``: a state of the "stemmed" layout (L_z in row 6; ``p`` that model's parameters), its
    vertical CM velocity ``vz`` (m/s; None: that of the contact of its flag). The active sets
    are tried in the order: the sphere ``first`` (0 ball, 1 stem; the one whose contact arrives
    first) alone, the other alone, both:

    * one contact i: ``single(frame_i)`` → (P, Q), the single-contact Darboux–Keller impact of
      the run's law (the one every change of contact uses); consistent if the other contact's
      normal velocity after it is ≥ 0 (it then opens) and the impulse equations end (no
      :class:`JumpFailed`);
    * the other contact closed before (normal velocity 0) and ``path`` given (the viscous law:
      :func:`viscous_path`; the dry laws: :func:`contact_path`): ``path(frames, first)`` →
      (P (2, 3), closed[, Q (2,)]) or None, the two-contact Darboux–Keller impact driven by the
      arriving contact, the other in the active set while it is pushed; consistent by
      construction;
    * both: ``both(frames)`` → (state, P (2, 3), Q (2,)) or None: the run's law with both normal
      velocities brought to 0 (:func:`viscous_closure`,
      :func:`mett.dynamics.stemslip.close_both`); consistent if both normal impulses are ≥ 0.

    Without friction this is the linear complementarity problem v⁺ = v⁻ + W_nn P ≥ 0, P ≥ 0,
    P ⊥ v⁺, with W_nn the 2×2 normal block of the Delassus matrix: positive definite, so the
    problem has exactly one solution (a P-matrix; Cottle, Pang & Stone 1992, Thm 3.3.7) and
    exactly one active set is consistent, whatever the order. With friction the order is the
    rule (the arriving contact impacts alone when the other then opens, as every change of
    contact does). Raises :class:`JumpFailed` if no active set is consistent (a Painlevé-type
    inconsistency of the impulse law).
    """
    m, I1, I3 = p[ix.M], p[ix.I1], p[ix.I3]
    names = ("ball", "stem")
    if vz is None:  # the constraint of the contact the state is on
        vz = float(impact_frame(y, p, names[1 - round(float(y[10]))]).V[2])
    frames = tuple(impact_frame(y, p, to, vz) for to in names)
    arms = [f.a for f in frames]
    v0 = np.array([f.v[2] for f in frames])
    tol = TWO_CONTACT_RTOL * max(float(np.max(np.abs(f.v))) for f in frames)
    if np.all(v0 >= -tol):  # nothing approaches: no impulse; closed where v_n = 0 (flag: first)
        out = np.array(y, dtype=float)
        out[10] = float(first)
        closed = (bool(v0[0] <= tol), bool(v0[1] <= tol))
        return TwoContactImpact(closed, np.zeros((2, 3)), np.zeros(2), v0, out)
    for i in (first, 1 - first):
        if i != first and path is not None and abs(v0[i]) <= tol:
            # the other contact closed: the path of the two-contact Darboux–Keller impact
            res = path(frames, first)
            if res is None:
                continue
            Ps, closed_b = np.asarray(res[0], dtype=float), res[1]
            Qs = np.asarray(res[2], dtype=float) if len(res) > 2 else np.zeros(2)
            v = _after_velocities(frames[first], m, I1, I3, arms, list(Ps), Qs)
            closed = (True, True) if closed_b else (first == 0, first == 1)
            state = _impulses_applied(y, frames, m, Ps, 2.0 if closed_b else float(first))
            if np.any(Qs):  # Contensou's drilling impulses
                state[6] += float(np.sum(Qs))
            if closed_b:
                state = on_both(state, p)
            return TwoContactImpact(closed, Ps, Qs, v, state)
        if v0[i] >= -tol:  # no impulse at i: the other contact still approaches
            continue
        try:
            P, Q = single(frames[i])
        except JumpFailed:  # this contact alone cannot end its compression: not this set
            continue
        Pi = [np.zeros(3), np.zeros(3)]
        Qs = np.zeros(2)
        Pi[i], Qs[i] = np.asarray(P, dtype=float), Q
        v = _after_velocities(frames[i], m, I1, I3, arms, Pi, Q)
        if v[1 - i] >= -tol:
            state = apply_impulse(y, frames[i], m, Pi[i], names[i], Q)
            return TwoContactImpact((i == 0, i == 1), np.array(Pi), Qs, v, state)
    closed = both(frames)
    if closed is not None:
        state, P, Q = closed
        P, Q = np.asarray(P, dtype=float), np.asarray(Q, dtype=float)
        if np.min(P[:, 2]) >= -TWO_CONTACT_RTOL * float(np.max(np.abs(P))):
            v = _after_velocities(frames[0], m, I1, I3, arms, list(P), Q)
            return TwoContactImpact((True, True), P, Q, v, state)
    raise JumpFailed(
        "both contacts are closed at an impact, but no active set satisfies the impulse law "
        "(a Painlevé-type inconsistency): the run ends there"
    )


def two_contact_delassus(frames: Any, m: float) -> np.ndarray:
    """The Delassus matrix of the two contacts (6×6, kg⁻¹): Δv = W P with P = (P_1, P_2),
    v = (v_1, v_2) the ball's and the stem's contact-point velocities, W_ij = 𝟙/m − [a_i×] I⁻¹
    [a_j×] (``frames``: the :class:`ImpactFrame` of each contact, one configuration)."""
    Iinv = frames[0].Iinv
    A = [np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
         for a in (f.a for f in frames)]  # fmt: skip
    W = np.empty((6, 6))
    for i in range(2):
        for j in range(2):
            W[3 * i : 3 * i + 3, 3 * j : 3 * j + 3] = np.eye(3) / m - A[i] @ Iinv @ A[j]
    return W


def viscous_closure(frames: Any, m: float, mu: float) -> np.ndarray | None:
    """The impulses (2, 3) (N s) that bring both normal velocities to 0 under the viscous law,
    or None if the equations have no solution found: the two-contact impact with both contacts
    closed (:func:`two_contact_impact`).

    With the Delassus matrix W of both contacts (:func:`two_contact_delassus`) and the
    velocities v⁻ before, v⁺ = v⁻ + W P with v⁺_n = 0 and the viscous law in impulse form at the
    post-impact slip (Moreau's velocity-level form of the impact law), P_t,i = −μ P_n,i v⁺_t,i.
    For given P_n the tangential impulses are linear, (𝟙 + μ D W_tt) P_t = −μ D (v⁻_t + W_tn P_n),
    D = diag(P_n,1, P_n,1, P_n,2, P_n,2); the two normal rows are then solved for P_n (Powell's
    hybrid method from the frictionless P_n = −W_nn⁻¹ v⁻_n, the solution at μ = 0). The kinetic
    energy changes by ΔT = P·v⁺ − ½ PᵀWP = −μ Σ P_n,i |v⁺_t,i|² − ½ PᵀWP ≤ 0 when P_n ≥ 0.
    """
    from scipy.optimize import root

    W = two_contact_delassus(frames, m)
    v = np.concatenate([f.v for f in frames])
    n, t = [2, 5], [0, 1, 3, 4]
    Wnn, Wnt, Wtn, Wtt = W[np.ix_(n, n)], W[np.ix_(n, t)], W[np.ix_(t, n)], W[np.ix_(t, t)]
    Pn0 = -np.linalg.solve(Wnn, v[n])
    P = np.zeros(6)
    if mu == 0.0:
        P[n] = Pn0
        return P.reshape(2, 3)

    def tangential(Pn: np.ndarray) -> np.ndarray:
        D = np.diag([Pn[0], Pn[0], Pn[1], Pn[1]])
        return -mu * np.linalg.solve(np.eye(4) + mu * D @ Wtt, D @ (v[t] + Wtn @ Pn))

    def normal(Pn: np.ndarray) -> np.ndarray:
        return v[n] + Wnn @ Pn + Wnt @ tangential(Pn)

    sol = root(normal, Pn0, method="hybr", options={"xtol": 1e-15})
    scale = float(np.max(np.abs(v)))
    if not np.all(np.isfinite(sol.x)) or np.max(np.abs(normal(sol.x))) > 1e-12 * scale:
        return None
    P[n], P[t] = sol.x, tangential(sol.x)
    return P.reshape(2, 3)


def viscous_path(
    frames: Any,
    m: float,
    mu: float,
    first: int,
    tangential: Any = None,
    method: tuple[str, float, float] | None = None,
) -> tuple[np.ndarray, bool] | None:
    """The two-contact Darboux–Keller impact of the viscous law when the contact ``first``
    arrives and the other is closed (normal velocity 0): the impulses (2, 3) (N s) and whether
    the other contact is closed at the end (:func:`two_contact_impact`; the path of
    :func:`contact_path` with the law dP_t = −μ v_t dp).

    The arriving contact a compresses with its normal impulse p as the time-like variable,
    dP_a = (−μ v_a,t, 1) dp, as in :func:`darboux_keller`. The other contact b is in the active
    set while its normal velocity would otherwise turn negative: then dP_b = q (−μ v_b,t, 1) dp
    with q ≥ 0 from dv_b,z = 0, q = −(W_ba dP_a)_z / (W_bb (−μ v_b,t, 1))_z; it joins when v_b,z
    falls to 0 and leaves when q falls to 0 (it stops being pushed). The impact ends when
    v_a,z reaches 0. So P_b,z ≥ 0, v_b,z ≥ 0 and P_b,z v_b,z = 0 by construction, and
    dE = (v_a,z − μ|v_a,t|²) dp − μ q |v_b,t|² dp ≤ 0 during compression. None where the
    friction is stiff (μ |W| p ≫ 1, :func:`darboux_keller`'s stiff case): the caller then tries
    the velocity-level closure. ``tangential(v_x, v_y)``: another law's tangential impulse per
    unit normal impulse in place of the viscous (−μ v_x, −μ v_y) (as
    :func:`compression_impulse` takes it; ``mu`` then only sets the stiffness test), e.g. the
    regularised law's −c(|v_t|) v_t (:func:`mett.dynamics.stemreg.two_contact`).
    ``method``: (solve_ivp method, rtol, atol per unit speed) for a law whose impulse equations
    may be stiff, integrated with it wherever they are (an implicit or switching method, as
    LSODA: never None); None: DOP853 at rtol 1e-13, None where stiff (the viscous law).
    """
    W = two_contact_delassus(frames, m)
    v0 = np.concatenate([f.v for f in frames])
    p1 = 10.0 * -v0[3 * first + 2] / W[3 * first + 2, 3 * first + 2]
    if method is None and mu * np.linalg.norm(W, 2) * p1 > 1e3:
        # the slips relax over an impulse ~ 1/(μ|W|) far below the impact's (darboux_keller's
        # stiff case): an explicit method would need ~ μ|W| p1 steps; not this path
        return None
    law = (lambda vx, vy: (-mu * vx, -mu * vy)) if tangential is None else tangential
    res = contact_path(W, v0, first, law, method=method)
    return None if res is None else (res[0].reshape(2, 3), res[1])


PATH_SLIP = 1e-9
"""The slip (relative to the largest contact-point speed before the impact) below which a
contact of the dry :func:`contact_path` counts as stopped: it sticks if its cone holds, else
its slip restarts at twice this (as :func:`mett.dynamics.stemslip.dry_impulse`)."""


def contact_path(
    W: np.ndarray,
    v0: np.ndarray,
    first: int,
    law: Any,
    k: int = 3,
    mu: float | None = None,
    method: tuple[str, float, float] | None = None,
) -> tuple[np.ndarray, bool] | None:
    """The two-contact Darboux–Keller impact when the contact ``first`` arrives and the other is
    closed: the generalised impulses Π (2k,) (N s per component) and whether the other contact
    is closed at the end. One algorithm for every friction law (:func:`viscous_path`, the dry
    laws' path of :mod:`.stemslip`; docs/theory/stem.md#two-contact-impact).

    ``W`` (kg⁻¹): the generalised Delassus matrix of the two contacts, Δg = W Π, ``v0`` the
    generalised velocities g = (v_x, v_y, v_z[, r* ω_z]) of both contact points before (k = 3,
    or 4 with a drilling component). ``law(*g_t)``: the tangential impulse per unit normal
    impulse of a sliding contact, a function of its tangential velocity g_t (viscous −μ g_t,
    dry −μ ĝ_t). The arriving contact a compresses with its normal impulse p as the time-like
    variable, dΠ_a = (law(g_a,t), 1) dp; the other, b, is in the active set while it is pushed,
    dΠ_b = q (law(g_b,t), 1) dp with q ≥ 0 from dg_b,z = 0; it joins when g_b,z falls to 0 and
    leaves when q falls to 0; the impact ends when g_a,z reaches 0.

    ``mu``: the dry law's coefficient (None: a law without stick). A sliding contact whose slip
    falls to :data:`PATH_SLIP` sticks for as long as the tangential impulse that keeps its slip
    at 0 lies in its cone (|dΠ_a,t| ≤ μ dp, |dΠ_b,t| ≤ μ q dp; with b sticking q comes from the
    same linear system); else, or when that impulse reaches the cone's edge, its slip restarts
    opposite to that impulse (the friction then pushes as far as it can the way sticking
    needs). None where the dry law cannot hold the closed contact with a compressive impulse
    (the determinant of the equations for the rates falls to 0: q → ∞, a Painlevé-type
    inconsistency of the path; the caller tries the other sets). Raises :class:`JumpFailed` if
    the impulse equations do not reach the end of compression.
    """
    from scipy.integrate import solve_ivp

    a, b = first, 1 - first
    n = 2 * k
    tl = [0, 1, 3] if k == 4 else [0, 1]
    sa, sb = slice(k * a, k * a + k), slice(k * b, k * b + k)
    ta, tb = [k * a + j for j in tl], [k * b + j for j in tl]
    na, nb = k * a + 2, k * b + 2
    Wba, Wbb = W[sb, sa], W[sb, sb]
    eye = np.eye(n)

    def unit(v: np.ndarray) -> np.ndarray:
        """(law(g_t), 1) in a contact's generalised slots."""
        if k == 3:
            return np.array([*law(v[0], v[1]), 1.0])
        tx, ty, tw = law(v[0], v[1], v[3])
        return np.array([tx, ty, 1.0, tw])

    def rates(z: np.ndarray, active: bool, stick: tuple = (False, False)) -> tuple:
        va, vb = z[sa], z[sb]
        dP = np.zeros(n)
        q = 0.0
        if not any(stick):
            dP[sa] = unit(va)
            if active:
                ub = unit(vb)
                q = -float((Wba @ dP[sa])[2]) / float((Wbb @ ub)[2])
                dP[sb] = q * ub
            return np.concatenate((W @ dP, dP)), q, dP
        return stuck(z, active, stick)

    def stuck(z: np.ndarray, active: bool, stick: tuple) -> tuple:
        va, vb = z[sa], z[sb]
        # a sticking contact: its tangential rates (and q) keep its slip at 0 (dg_t = 0)
        base, cols, rows = np.zeros(n), [], []
        if stick[0]:
            base[na] = 1.0
            cols += [eye[j] for j in ta]
            rows += ta
        else:
            base[sa] = unit(va)
        if active:
            if stick[1]:
                cols += [eye[nb]] + [eye[j] for j in tb]
                rows += [nb, *tb]
            else:
                ub = np.zeros(n)
                ub[sb] = unit(vb)
                cols.append(ub)
                rows.append(nb)
        U = np.column_stack(cols)
        # least squares: with both sticking the impulse along the line between the contacts is
        # not determined (W's null space); the minimum-norm split is taken
        x = np.linalg.lstsq((W @ U)[rows], -(W @ base)[rows], rcond=None)[0]
        dP = base + U @ x
        q = float(dP[nb])
        return np.concatenate((W @ dP, dP)), q, dP

    def jam(z: np.ndarray, active: bool, stick: tuple) -> float:
        """The determinant of the equations for the impulse rates of the active contacts,
        relative to that of their frictionless part (1 at μ = 0): at 0 the closed contact b
        cannot be held by a compressive impulse that obeys the dry law (q → ∞, Painlevé)."""
        if not active or all(stick):  # both sticking: singular by the line's internal impulse
            return 1.0
        rows = ([*ta] if stick[0] else []) + [nb] + ([*tb] if stick[1] else [])
        cols = [W[:, j] for j in ta] if stick[0] else []
        if stick[1]:
            cols += [W[:, j] for j in (nb, *tb)]
        else:
            ub = np.zeros(n)
            ub[sb] = unit(z[sb])
            cols.append(W @ ub)
        M = np.column_stack(cols)[rows]
        return float(np.linalg.det(M) / np.linalg.det(W[np.ix_(rows, rows)]))

    def end(_: float, z: np.ndarray) -> float:
        return z[na]

    end.terminal, end.direction = True, 1.0  # type: ignore[attr-defined]
    z = np.concatenate((v0, np.zeros(n)))
    z[nb] = 0.0  # closed: its constraint's velocity (rounding removed)
    active = bool(rates(z, False)[0][nb] < 0.0)  # pushed down from the start: joins
    p0, p1 = 0.0, 10.0 * -v0[na] / W[na, na]
    # method: (solve_ivp method, rtol, atol per unit speed) of a law whose impulse equations may
    # be stiff (:func:`viscous_path`); DOP853 at rtol 1e-13 otherwise
    solver, rtol, atol1 = ("DOP853", 1e-13, 1e-15) if method is None else method
    atol = atol1 * (1.0 + float(np.max(np.abs(v0))))
    eta = PATH_SLIP * float(np.max(np.abs(v0)))
    stick = [False, False]

    def kick(z: np.ndarray, i: int, target: np.ndarray) -> np.ndarray:
        """z after the impulse at contact i's tangential slots (and b's normal one while b is
        active, keeping g_b,z) that sets i's slip to ``target``: rounding-level (~η)."""
        rows = (ta if i == 0 else tb) + ([nb] if active else [])
        want = np.concatenate((target, [z[nb]] if active else []))
        x = np.linalg.solve(W[np.ix_(rows, rows)], want - z[rows])
        out = np.array(z)
        out[:n] += W[:, rows] @ x
        out[n:][rows] += x
        return out

    def decide(z: np.ndarray, i: int, slide: bool = False) -> np.ndarray:
        """Contact i (0: a, 1: b) stopped: it sticks if its cone holds (and not ``slide``: its
        sticking impulse at the cone's edge), else its slip restarts (2η) opposite to the
        tangential impulse that sticking needs."""
        want = [stick[0], stick[1]]
        want[i] = True
        _, q, dP = rates(z, active, tuple(want))
        t = dP[ta if i == 0 else tb]
        normal = 1.0 if i == 0 else q
        assert mu is not None  # a contact stops under the dry laws only
        if not slide and normal >= 0.0 and float(np.linalg.norm(t)) <= mu * normal:
            stick[i] = True
            return kick(z, i, np.zeros(len(tl)))
        stick[i] = False
        return kick(z, i, -2.0 * eta * t / max(float(np.linalg.norm(t)), 1e-300))

    def pushed(z: np.ndarray, active: bool) -> bool:
        """Whether b is (still) in the active set in the current modes: pushed down if it is
        not, its rate q ≥ 0 if it is (a mode change can turn either at once)."""
        if active:
            return rates(z, True, tuple(stick))[1] >= 0.0
        return bool(z[nb] <= 0.0 and rates(z, False, tuple(stick))[0][nb] < 0.0)

    if mu is not None:  # the dry law: the modes at the start
        if float(np.linalg.norm(z[ta])) <= eta:
            z = decide(z, 0)
        active = pushed(z, False)
        if active and float(np.linalg.norm(z[tb])) <= eta:
            z = decide(z, 1)
        active = active and pushed(z, True)
        stick[1] = stick[1] and active
        if jam(z, active, tuple(stick)) <= 0.0:
            return None
    for _ in range(200):
        mode = (stick[0], stick[1])

        def switch(_: float, z: np.ndarray, active: bool = active, mode: tuple = mode) -> float:
            return rates(z, True, mode)[1] if active else z[nb]

        switch.terminal, switch.direction = True, -1.0  # type: ignore[attr-defined]
        events: list = [end, switch]
        if mu is not None:

            def slip_a(_: float, z: np.ndarray, act: bool = active, mode: tuple = mode) -> float:
                if mode[0]:  # the cone's margin of the sticking impulse, per unit dp
                    return mu - float(np.linalg.norm(rates(z, act, mode)[2][ta]))
                return float(np.linalg.norm(z[ta])) - eta

            def slip_b(_: float, z: np.ndarray, act: bool = active, mode: tuple = mode) -> float:
                if not act:
                    return 1.0
                if mode[1]:
                    _, q, dP = rates(z, act, mode)
                    return mu * q - float(np.linalg.norm(dP[tb]))
                return float(np.linalg.norm(z[tb])) - eta

            def jammed(_: float, z: np.ndarray, act: bool = active, mode: tuple = mode) -> float:
                return jam(z, act, mode)

            slip_a.terminal = slip_b.terminal = jammed.terminal = True  # type: ignore[attr-defined]
            slip_a.direction = slip_b.direction = jammed.direction = -1.0  # type: ignore[attr-defined]
            events += [slip_a, slip_b, jammed]
        sol = solve_ivp(lambda _, z, act=active, mode=mode: rates(z, act, mode)[0], (p0, p1), z,
                        method=solver, events=events, rtol=rtol, atol=atol)  # fmt: skip
        if sol.status == -1:
            raise JumpFailed(f"impact: the impulse equations could not be solved ({sol.message})")
        if sol.t_events[0].size:
            return sol.y_events[0][0][n:], active
        hit = [j for j in range(1, len(events)) if sol.t_events[j].size]
        if not hit:  # the impact goes on (friction can drive the contact down first)
            z, p0, p1 = sol.y[:, -1], p1, 10.0 * p1
            continue
        j = hit[0]
        z, p0 = np.array(sol.y_events[j][0]), float(sol.t_events[j][0])
        if j == 1:  # b joins or leaves the active set
            active = not active
            if not active:
                z[nb] = max(z[nb], 0.0)
                stick[1] = False
            elif mu is not None and float(np.linalg.norm(z[tb])) <= eta:
                z = decide(z, 1)
            if mu is not None and jam(z, active, tuple(stick)) <= 0.0:
                return None
        elif j == 4:  # the closed contact can no longer be held (Painlevé): not this set
            return None
        else:  # a slip stopped (stick or restart) or a sticking impulse reached its cone
            i = j - 2
            z = decide(z, i, slide=mode[i])
            if active and not pushed(z, True):  # b no longer pushed in the new mode: leaves
                active, stick[1] = False, False
            if jam(z, active, tuple(stick)) <= 0.0:
                return None
    raise JumpFailed("impact: the impulse equations did not reach the end of compression")


def closed_on_both(y: np.ndarray, frames: Any, m: float, P: np.ndarray, p: tuple) -> np.ndarray:
    """State ``y`` after the impulses ``P`` (2, 3) at the two contacts: Δ(m ṙ) = P_1 + P_2,
    ΔL = a_1 × P_1 + a_2 × P_2, on the double-contact manifold (flag 2, :func:`on_both`; L_z
    form)."""
    return on_both(_impulses_applied(y, frames, m, P, 2.0), p)


def _impulses_applied(y: np.ndarray, frames: Any, m: float, P: Any, flag: float) -> np.ndarray:
    """State ``y`` after the impulses ``P`` (2, 3) at both contacts, its phase flag ``flag``."""
    f = frames[0]
    out = np.array(y, dtype=float)
    out[2:4] = f.V[:2] + (P[0][:2] + P[1][:2]) / m
    out[4:7] = f.L + np.cross(frames[0].a, P[0]) + np.cross(frames[1].a, P[1])
    out[10] = flag
    return out


def land_both(
    g: np.ndarray, vz: float, p: tuple, first: int, single: Any = None,
    law: StemLaw | None = None,
) -> tuple[np.ndarray, TwoContactImpact]:  # fmt: skip
    """The landing from a flight of both spheres at once (the other sphere's gap within the
    event tolerance when the sphere ``first`` touches): the two-contact impact
    (:func:`two_contact_impact`) of the gliding-layout state ``g`` with the vertical CM velocity
    ``vz`` (m/s), viscous law. Returns the state to continue from (the contact(s) closed, a
    double contact entered only if both normal forces are positive, :func:`_settle_both`) and
    the impact. ``single``: the single-contact impulse P(v, W, μ) (default
    :func:`darboux_keller`). ``law``: another law's :class:`StemLaw` (its ``two_contact``;
    ``p`` that model's parameters, ``single`` unused), e.g. the regularised law's
    (:data:`mett.dynamics.stemreg.LAW`)."""
    y = np.append(np.asarray(g, dtype=float)[:10], float(first))
    if law is None:
        imp = _viscous_two_contact(y, p, first, vz, single)
    else:
        imp = law.two_contact(y, p, first, vz)
    out = _settle_both(imp.state, p, law) if all(imp.closed) else imp.state
    return out, imp


def _viscous_two_contact(
    y: np.ndarray, p: tuple, first: int, vz: float | None = None, single: Any = None
) -> TwoContactImpact:
    """The impact at both contacts (:func:`two_contact_impact`) of state ``y`` under the viscous
    law: one contact by ``single`` (the impulse P(v, W, μ); default :func:`darboux_keller`),
    the other closed and pushed by :func:`viscous_path`, both by :func:`viscous_closure`."""
    m, mu = p[ix.M], p[ix.MU]
    law = darboux_keller if single is None else single

    def both(frames: Any) -> tuple | None:
        P = viscous_closure(frames, m, mu)
        return None if P is None else (closed_on_both(y, frames, m, P, p), P, np.zeros(2))

    return two_contact_impact(y, p, first, lambda f: (law(f.v, f.W, mu), 0.0), both, vz,
                              lambda frames, a: viscous_path(frames, m, mu, a))  # fmt: skip


def _both_forces(y: np.ndarray, p: tuple) -> tuple[float, float]:
    d = both_core(np.asarray(y, dtype=float), p)
    return float(d[1]), float(d[2])


class StemLaw(NamedTuple):
    """What the jumps and the records of a stemmed model need of its friction law, beyond its
    compiled phases: the impact at a new contact and the normal forces. The viscous law's is
    :data:`VISCOUS_LAW`; :mod:`.stemreg` gives the regularised Coulomb law's."""

    impact: Callable[[np.ndarray, tuple, str], tuple[np.ndarray, np.ndarray]]
    """``impact(y, p, to)``: the state after the impact of contact ``to`` and the impulse P."""
    both_forces: Callable[[np.ndarray, tuple], tuple[float, float]]
    """``both_forces(y, p)``: (λ_1, λ_2) (N) of a state of the double contact."""
    normal_forces: Callable[[np.ndarray, tuple], tuple[np.ndarray, np.ndarray]]
    """``normal_forces(Y, p)``: the ball's and the stem's normal forces of states ``Y`` (N)."""
    two_contact: Callable[[np.ndarray, tuple, int, float | None], TwoContactImpact]
    """``two_contact(y, p, first, vz)``: the impact at both contacts of state ``y`` whose
    sphere ``first`` (0 ball, 1 stem) arrives, ``vz`` its vertical CM velocity (m/s; None:
    that of its contact) (:func:`two_contact_impact` with this law's single impact, path and
    closure)."""


def _settle_both(y: np.ndarray, p: tuple, law: StemLaw | None = None) -> np.ndarray:
    """A state on both contacts (flag 2) if both normal forces exceed :data:`BOTH_FORCE_MIN` m g;
    else the same state on the contact whose force is larger (the other lifts off with zero
    normal velocity). ``law``: the model's (:class:`StemLaw`; default the viscous law's)."""
    f1, f2 = (VISCOUS_LAW if law is None else law).both_forces(y, p)
    mg = p[ix.M] * p[ix.G]
    if min(f1, f2) > BOTH_FORCE_MIN * mg:
        return y
    out = np.array(y, dtype=float)
    out[10] = 0.0 if f1 >= f2 else 1.0
    return out


def transition(
    y: np.ndarray, p: tuple, to: str, switches: Any = (), law: StemLaw | None = None
) -> tuple[np.ndarray, str, float]:
    """The state after the contact ``to`` ("ball" or "stem") closes on state ``y`` (on the other
    contact), the reason and the accumulation point (s; NaN if none).

    * the impacts do not accumulate: the impact at both contacts under the law
      (``law.two_contact``: :func:`two_contact_impact`, the old contact closed with zero normal
      velocity): the single impact at the new contact if the old contact then separates, or
      the two-contact path that ends with it open, reason "touchdown"/"landing"; else both
      closed with the law at each (viscous: :func:`viscous_path`, :func:`viscous_closure`;
      regularised: :func:`mett.dynamics.stemreg.closure`), reason "closure";
    * the impact times of ``switches``, the run's (time, from, to) so far, form a geometric
      sequence (:func:`accumulation`): both contacts closed by the projection of
      :func:`close_both`, reason "accumulation".

    After both closed the double contact starts if both normal forces are positive
    (:func:`_settle_both`). ``law`` is the model's friction law where the impact and the forces
    need it (:class:`StemLaw`; default :data:`VISCOUS_LAW`).
    """
    law = VISCOUS_LAW if law is None else law
    old = "ball" if to == "stem" else "stem"
    acc = accumulation(_impact_times(switches)) if len(switches) else None
    if acc is None:
        imp = law.two_contact(y, p, PHASE_NAMES.index(to), None)
        if not all(imp.closed):
            return imp.state, "touchdown" if to == "stem" else "landing", math.nan
        return _settle_both(imp.state, p, law), "closure", math.nan
    closed, _ = close_both(y, p, old)
    return _settle_both(closed, p, law), "accumulation", acc.t_limit


def _to_stem(y: np.ndarray, p: tuple, switches: Any = ()) -> np.ndarray:
    return transition(y, p, "stem", switches)[0]


def _to_ball(y: np.ndarray, p: tuple, switches: Any = ()) -> np.ndarray:
    return transition(y, p, "ball", switches)[0]


def _lift(y: np.ndarray, p: tuple, to: float) -> np.ndarray:
    out = on_both(y, p)
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
    return PHASE_NAMES[round(float(y[10]))]


PHASE_NAMES = ("ball", "stem", "both")


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
    return _select(y0, p)


def _projected(Y: np.ndarray, p: tuple) -> np.ndarray:
    """States ``Y`` (11, k) with the double-contact samples (flag 2) on their manifold
    (:func:`on_both`)."""
    Y = np.array(Y, dtype=float)
    both = Y[10] > 1.5
    if np.any(both):
        Y[:, both] = on_both(Y[:, both], p)
    return Y


def normal_forces(Y: np.ndarray, p: tuple) -> tuple[np.ndarray, np.ndarray]:
    """The normal forces (N) of the ball and of the stem of states ``Y`` (11, k) or (11,): the
    single contact's g_n and 0, or λ_1, λ_2 of the double contact (:func:`both_core`)."""
    Y = np.asarray(Y, dtype=float)
    flag = np.round(Y[10])
    gb = np.asarray(gliding_core(Y, _ball(p))[10], dtype=float)
    gs = np.asarray(gliding_core(Y, _stem(p))[10], dtype=float)
    with np.errstate(invalid="ignore", divide="ignore"):
        d = both_core(Y, p)
    l1, l2 = np.asarray(d[1], dtype=float), np.asarray(d[2], dtype=float)
    ball = np.where(flag == 0, gb, np.where(flag == 2, l1, 0.0))
    stem = np.where(flag == 1, gs, np.where(flag == 2, l2, 0.0))
    return ball, stem


def _normal_force(y: np.ndarray, p: tuple) -> Any:
    """The total normal force (N): that of the contact, or λ_1 + λ_2 = m g in the double contact."""
    ball, stem = normal_forces(y, p)
    return ball + stem


VISCOUS_LAW = StemLaw(impact, _both_forces, normal_forces, _viscous_two_contact)
"""The viscous law's :class:`StemLaw`: :func:`impact`, the forces of :func:`both_core`, the
impact at both contacts of :func:`two_contact_impact` with :func:`darboux_keller`,
:func:`viscous_path` and :func:`viscous_closure`."""


def _derive(Y: np.ndarray, p: tuple) -> dict[str, np.ndarray]:
    """Series of each sample on its own contact: ν, g_n, E, λ of the sphere in contact; in the
    double contact those of the ball (ν, λ) with g_n = λ_1 + λ_2."""
    Y = _projected(Y, p)
    ball, stem = gliding_series(Y, _ball(p)), gliding_series(Y, _stem(p))
    on = np.round(Y[10]) == 1
    out = {k: np.where(on, stem[k], np.asarray(ball[k], dtype=float)) for k in ball}
    out["gn"] = np.asarray(_normal_force(Y, p), dtype=float)
    out["x"], out["y"] = Y[0], Y[1]
    return out


def _theta(Y: np.ndarray, p: tuple) -> np.ndarray:
    e = unit_axis(_projected(Y, p), 7)
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


_LIFT_REASONS = {"ball": "stem lifts off", "stem": "ball lifts off"}


def _finish(traj: Any) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    return finish(traj, VISCOUS_LAW)


def finish(traj: Any, law: StemLaw) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """``Model.finish`` of a stemmed model whose law is ``law`` (:class:`StemLaw`): the
    contact of each sample ("ball", "stem" or "both", also for a run
    that ended at t = 0, before any phase ran), the normal forces ``gn_ball`` and ``gn_stem``
    (N) of each sample, ``touchdowns`` (the times the stem touched down, s), ``switches``
    (:class:`mett.dynamics.stickslip.Switch` records with their reasons: "touchdown",
    "landing", "accumulation", "closure", "ball lifts off", "stem lifts off"; ``t_event`` of
    an "accumulation" is the accumulation point t_∞ it jumped to) and ``accumulations``
    (the times of the impacts where a geometric sequence was detected, s)."""
    from .stickslip import Switch

    p = traj.params
    flag = np.round(traj.states[10]).astype(int)
    contact = np.array(PHASE_NAMES)[np.clip(flag, 0, 2)]
    gb, gs = law.normal_forces(traj.states, p)
    records = []
    seen: list[tuple[float, str, str]] = []
    for (t, before, after), (y_ev, _) in zip(traj.switches, traj.jumps, strict=True):
        t_event = t
        if before == "both":
            reason = _LIFT_REASONS[after]
        else:  # the jump saw the switches so far and this one with its event's target
            to = "stem" if before == "ball" else "ball"
            _, reason, t_limit = transition(y_ev, p, to, [*seen, (t, before, to)], law)
            if reason == "accumulation":
                t_event = t_limit
        records.append(Switch(t, before, after, reason, math.nan, math.nan, t_event))
        seen.append((t, before, after))
    touchdowns = np.array(
        [sw.t for sw in records if sw.before == "ball" and sw.after in ("stem", "both")]
    )
    acc = np.array([sw.t for sw in records if sw.reason == "accumulation"])
    return (
        {"contact": contact, "gn_ball": gb, "gn_stem": gs},
        {"touchdowns": touchdowns, "switches": records, "accumulations": acc},
    )


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
