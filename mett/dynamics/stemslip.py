"""The top with a stem under dry friction: the registered models "stemmed-coulomb" and
"stemmed-coulomb-contensou" (docs/theory/stem.md#dry-friction).

``mett.simulate(top.with_stem(...), state, t_end, friction=Coulomb(...))`` runs this hybrid model
(the one :meth:`mett.friction.Coulomb.model_for` names for "stemmed", :mod:`.stem`). It is the
stemmed top of :mod:`.stem` (state: that of :mod:`.stickslip`, with the Jellett integral of the
sphere in contact in place of L_z, plus the contact flag ``y[10]``, 0 ball, 1 stem) with the
exact stick–slip of :mod:`.stickslip` on whichever sphere touches: four phases, the contact ×
the friction phase,

    "ball-sliding", "ball-rolling", "stem-sliding", "stem-rolling",

and, with both spheres on the plane (flags 2–5), "both-sliding", "both-ball-rolling",
"both-stem-rolling" and "both-rolling" (:data:`BOTH_FLAGS`).

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
    kernel_call,
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
    "NO_DRY_CLOSURE",
    "both_forces",
    "both_stick_forces",
    "close_both",
    "dry_impulse",
    "impact",
    "impact_both",
    "land_both",
    "moreau_check",
    "moreau_impulse",
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


@kernel_call
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


NEAR_STOP = 1.5
"""k of the near-stop event (1): where sticking is admissible, a slip of the double contact is
stopped when it falls below k δ (docs/theory/stem.md#dry-friction, "The near-stop pass"): above
the band (1), to catch a slip that hovers at a few δ, turning at the integrator's stability
limit, and never reaches it; below the restart (2), so that a slip restarted at 2δ from the
cone's edge (zero acceleration, zero margin) is not stopped again at once. The stop removes at
most k δ of slip, less than the 3δ a "reversal" changes it by."""

_CONE_SIDE = 1e6
"""Weight of the admissibility term of the near-stop events (as the stop/reversal events of one
contact, :mod:`.contact`): a margin of −1e-6 m g keeps the event k δ above its zero."""


def _pos(x: Any) -> Any:
    """max(x, 0) as plain arithmetic, (x + √(x²))/2: no branch on a state value."""
    return 0.5 * (x + (x * x) ** 0.5)


def _near_stop(y: Any, p: Any, s: Any) -> Any:
    """The near-stop event of contact ``s`` (0 ball, 1 stem) while both slide (Coulomb):
    |γ_s| − k δ, kept positive (by k δ × 1e6 per m g of violation) where sticking there is not
    admissible: the sticking force of the mode "s sticks, the other slides" (:func:`_stick_both`)
    outside its cone or a normal force < 0. Under Coulomb–Contensou sticking needs ω_z = 0, i.e.
    both contacts rolling about the contact line: |γ_s| is the generalised slip and the test is
    that mode's (:func:`_drill_margin`, its normal forces, at the state itself); for r_s < R that
    mode is never admissible (λ_2 < 0, docs/theory/stem.md#dry-friction) and, as at μ = 0, the
    event never fires."""
    if p[ix.MU] == 0.0 or (p[ix.RSTAR] > 0.0 and p[ix.DRY_R_S] <= p[ix.R]):
        return 1.0 + 0.0 * y[0]
    mg = p[ix.M] * p[ix.G]
    band = NEAR_STOP * p[ix.BAND]
    if p[ix.RSTAR] > 0.0:
        r = _roll_split(y, p)
        bad = _pos(r[8] - 1.0) * p[ix.MU] + _pos(-r[0] / mg) + _pos(-r[1] / mg)
        kin = both_kinematics(y, p[ix.R], p[ix.L], p[ix.I1], p[ix.I3], p[ix.DRY_R_S], p[ix.DRY_L_S])
        n1, n2, sw = kin[3], kin[4], p[ix.RSTAR] * kin[2][2]
        g1 = (n1[0] * n1[0] + n1[1] * n1[1] + sw * sw) ** 0.5
        g2 = (n2[0] * n2[0] + n2[1] * n2[1] + sw * sw) ** 0.5
        return g1 + s * (g2 - g1) - band + band * _CONE_SIDE * bad
    d = _stick_both(y, p, s)
    F = d[3]
    cone = (p[ix.MU] * F[2] - (F[0] * F[0] + F[1] * F[1]) ** 0.5) / mg
    bad = _pos(-cone) + _pos(-d[1] / mg) + _pos(-d[2] / mg)
    sl = _slips_plain(y, p)
    speed = sl[0] + s * (sl[1] - sl[0])
    return speed - band + band * _CONE_SIDE * bad


def _slips_plain(y: Any, p: Any) -> tuple:
    """|ν_1|, |ν_2| (m/s) of a double-contact state (Coulomb). Plain arithmetic."""
    kin = both_kinematics(y, p[ix.R], p[ix.L], p[ix.I1], p[ix.I3], p[ix.DRY_R_S], p[ix.DRY_L_S])
    n1, n2 = kin[3], kin[4]
    return (n1[0] * n1[0] + n1[1] * n1[1]) ** 0.5, (n2[0] * n2[0] + n2[1] * n2[1]) ** 0.5


def _both_ball_near(t: float, y: Any, p: Any) -> Any:
    """The ball's near-stop event while both contacts slide (:func:`_near_stop`)."""
    return _near_stop(y, p, 0.0)


def _both_stem_near(t: float, y: Any, p: Any) -> Any:
    """The stem's near-stop event while both contacts slide (:func:`_near_stop`)."""
    return _near_stop(y, p, 1.0)


def _solve3(A: tuple, b: tuple) -> tuple:
    """x with A x = b, A = (row0, row1, row2) of a 3×3 matrix: Cramer's rule (plain arithmetic)."""
    (a, b_, c), (d, e, f), (g, h, k) = A
    x, y, z = b
    c1 = e * k - f * h
    c2 = d * k - f * g
    c3 = d * h - e * g
    det = a * c1 - b_ * c2 + c * c3
    return (
        (x * c1 - b_ * (y * k - f * z) + c * (y * h - e * z)) / det,
        (a * (y * k - f * z) - x * c2 + c * (d * z - y * g)) / det,
        (a * (e * z - y * h) - b_ * (d * z - y * g) + x * c3) / det,
    )


@kernel_call
def _stick_both(y: Any, p: Any, s: Any) -> tuple:
    """(rates[0:10], λ_1, λ_2, F_s (3), |γ_k|) of the double contact with contact ``s`` sticking
    (0 ball, 1 stem; Coulomb, r* = 0) and the other, k, sliding: the contact accelerations are
    affine in the forces, ν̇_i = h_i + Σ_j G_ij F_j with h_i = −g ẑ + α_0 × a_i + ω × (ω × l_i 3̂),
    α_0 = −I⁻¹(ω × L), G_ij F = F/m + (I⁻¹(a_j × F)) × a_i; sticking ν̇_s = 0 (3 rows) and the
    sliding contact's normal row ν̇_k,z = 0 with F_k = λ_k (ẑ − μ ν̂_k) give F_s = −G_ss⁻¹(h_s +
    G_sk u λ_k) and λ_k from the Schur complement. Plain arithmetic."""
    m, g, mu = p[ix.M], p[ix.G], p[ix.MU]
    R, l, I1, I3 = p[ix.R], p[ix.L], p[ix.I1], p[ix.I3]
    r_s, l_s = p[ix.DRY_R_S], p[ix.DRY_L_S]
    e, L, w, n1, n2, de = both_kinematics(y, R, l, I1, I3, r_s, l_s)
    ex, ey, ez = e
    Lx, Ly, Lz = L
    wx, wy, wz = w
    c = 1.0 / I3 - 1.0 / I1
    l2 = l + l_s
    # the sticking contact's arm (s) and the sliding one's (k), selected arithmetically
    ls, lk = l + s * l_s, l2 - s * l_s
    Rs, Rk = R + s * (r_s - R), r_s - s * (r_s - R)
    nkx, nky = n2[0] + s * (n1[0] - n2[0]), n2[1] + s * (n1[1] - n2[1])
    asx, asy, asz = ls * ex, ls * ey, ls * ez - Rs
    akx, aky, akz = lk * ex, lk * ey, lk * ez - Rk
    # α_0 = −I⁻¹(ω × L)
    tx, ty, tz = -(wy * Lz - wz * Ly), -(wz * Lx - wx * Lz), -(wx * Ly - wy * Lx)
    te = tx * ex + ty * ey + tz * ez
    ax0, ay0, az0 = tx / I1 + c * te * ex, ty / I1 + c * te * ey, tz / I1 + c * te * ez
    # ω × (ω × l 3̂) = l ((ω·3̂) ω − |ω|² 3̂)
    we, ww = wx * ex + wy * ey + wz * ez, wx * wx + wy * wy + wz * wz
    cx, cy, cz = we * wx - ww * ex, we * wy - ww * ey, we * wz - ww * ez
    hsx = (ay0 * asz - az0 * asy) + ls * cx
    hsy = (az0 * asx - ax0 * asz) + ls * cy
    hsz = -g + (ax0 * asy - ay0 * asx) + ls * cz
    hkz = -g + (ax0 * aky - ay0 * akx) + lk * cz

    def resp(Fx: Any, Fy: Any, Fz: Any, bx: Any, by: Any, bz: Any, ox: Any, oy: Any, oz: Any):
        # F/m + (I⁻¹(b × F)) × o: the acceleration at arm o of the force F at arm b
        qx, qy, qz = by * Fz - bz * Fy, bz * Fx - bx * Fz, bx * Fy - by * Fx
        qe = qx * ex + qy * ey + qz * ez
        jx, jy, jz = qx / I1 + c * qe * ex, qy / I1 + c * qe * ey, qz / I1 + c * qe * ez
        return (
            Fx / m + (jy * oz - jz * oy),
            Fy / m + (jz * ox - jx * oz),
            Fz / m + (jx * oy - jy * ox),
        )

    sk = (nkx * nkx + nky * nky) ** 0.5
    ux, uy = -mu * nkx / sk, -mu * nky / sk
    G0 = resp(1.0, 0.0, 0.0, asx, asy, asz, asx, asy, asz)
    G1 = resp(0.0, 1.0, 0.0, asx, asy, asz, asx, asy, asz)
    G2 = resp(0.0, 0.0, 1.0, asx, asy, asz, asx, asy, asz)
    A = ((G0[0], G1[0], G2[0]), (G0[1], G1[1], G2[1]), (G0[2], G1[2], G2[2]))
    bcol = resp(ux, uy, 1.0, akx, aky, akz, asx, asy, asz)
    r0 = resp(1.0, 0.0, 0.0, asx, asy, asz, akx, aky, akz)[2]
    r1 = resp(0.0, 1.0, 0.0, asx, asy, asz, akx, aky, akz)[2]
    r2 = resp(0.0, 0.0, 1.0, asx, asy, asz, akx, aky, akz)[2]
    d = resp(ux, uy, 1.0, akx, aky, akz, akx, aky, akz)[2]
    Ah = _solve3(A, (hsx, hsy, hsz))
    Ab = _solve3(A, bcol)
    lam_k = -(hkz - (r0 * Ah[0] + r1 * Ah[1] + r2 * Ah[2])) / (
        d - (r0 * Ab[0] + r1 * Ab[1] + r2 * Ab[2])
    )
    Fsx = -(Ah[0] + Ab[0] * lam_k)
    Fsy = -(Ah[1] + Ab[1] * lam_k)
    Fsz = -(Ah[2] + Ab[2] * lam_k)
    Fkx, Fky, Fkz = lam_k * ux, lam_k * uy, lam_k
    rates = (
        y[2],
        y[3],
        (Fsx + Fkx) / m,
        (Fsy + Fky) / m,
        (asy * Fsz - asz * Fsy) + (aky * Fkz - akz * Fky),
        (asz * Fsx - asx * Fsz) + (akz * Fkx - akx * Fkz),
        (asx * Fsy - asy * Fsx) + (akx * Fky - aky * Fkx),
        de[0],
        de[1],
        0.0,
    )
    lam1 = Fsz + s * (lam_k - Fsz)
    lam2 = lam_k + s * (Fsz - lam_k)
    return rates, lam1, lam2, (Fsx, Fsy, Fsz), sk


def _ball_stick_into(t: float, y: Any, p: Any, out: Any) -> None:
    d = _stick_both(y, p, 0.0)[0]
    out[0], out[1], out[2], out[3], out[4] = d[0], d[1], d[2], d[3], d[4]
    out[5], out[6], out[7], out[8], out[9] = d[5], d[6], d[7], d[8], d[9]
    out[10] = 0.0


def _stem_stick_into(t: float, y: Any, p: Any, out: Any) -> None:
    d = _stick_both(y, p, 1.0)[0]
    out[0], out[1], out[2], out[3], out[4] = d[0], d[1], d[2], d[3], d[4]
    out[5], out[6], out[7], out[8], out[9] = d[5], d[6], d[7], d[8], d[9]
    out[10] = 0.0


def _bs_contact(t: float, y: Any, p: Any) -> Any:
    d = _stick_both(y, p, 0.0)
    return (d[1] + d[2]) * (1.0 / (p[ix.M] * p[ix.G]))


def _ss_contact(t: float, y: Any, p: Any) -> Any:
    d = _stick_both(y, p, 1.0)
    return (d[1] + d[2]) * (1.0 / (p[ix.M] * p[ix.G]))


def _bs_ball_lift(t: float, y: Any, p: Any) -> Any:
    return _stick_both(y, p, 0.0)[1] * (1.0 / (p[ix.M] * p[ix.G]))


def _bs_stem_lift(t: float, y: Any, p: Any) -> Any:
    return _stick_both(y, p, 0.0)[2] * (1.0 / (p[ix.M] * p[ix.G]))


def _ss_ball_lift(t: float, y: Any, p: Any) -> Any:
    return _stick_both(y, p, 1.0)[1] * (1.0 / (p[ix.M] * p[ix.G]))


def _ss_stem_lift(t: float, y: Any, p: Any) -> Any:
    return _stick_both(y, p, 1.0)[2] * (1.0 / (p[ix.M] * p[ix.G]))


def _bs_cone(t: float, y: Any, p: Any) -> Any:
    """(μ λ_1 − |F_t,1|)/(m g): the ball's sticking force reaches its cone."""
    d = _stick_both(y, p, 0.0)
    F = d[3]
    return (p[ix.MU] * F[2] - (F[0] * F[0] + F[1] * F[1]) ** 0.5) * (1.0 / (p[ix.M] * p[ix.G]))


def _ss_cone(t: float, y: Any, p: Any) -> Any:
    """(μ λ_2 − |F_t,2|)/(m g): the stem's sticking force reaches its cone."""
    d = _stick_both(y, p, 1.0)
    F = d[3]
    return (p[ix.MU] * F[2] - (F[0] * F[0] + F[1] * F[1]) ** 0.5) * (1.0 / (p[ix.M] * p[ix.G]))


def _bs_stop(t: float, y: Any, p: Any) -> Any:
    """|ν_2| − δ: the sliding stem's slip reaches the band while the ball sticks."""
    return _stick_both(y, p, 0.0)[4] - p[ix.BAND]


def _ss_stop(t: float, y: Any, p: Any) -> Any:
    """|ν_1| − δ: the sliding ball's slip reaches the band while the stem sticks."""
    return _stick_both(y, p, 1.0)[4] - p[ix.BAND]


@kernel_call
def _roll_both(y: Any, p: Any) -> tuple:
    """(rates[0:10], λ_1, λ_2, P_1, P_2, T) of the double contact with both contacts sticking
    (Coulomb, flag 5, "both-rolling"): both contact points at rest, so ω × d = 0 with
    d = a_2 − a_1 = l_s 3̂ − (r_s − R) ẑ (horizontal on the manifold): the body turns about the
    line through the two contact points, as a cone rolls on the plane (ω_z = 0).

    The forces F_1, F_2 are determined but for an internal compression f (d̂, −d̂) along that line
    (no moment, no work: the motion does not depend on it). With n̂ = ẑ × d̂, the particular
    solution F_2 = λ_2 ẑ + P_2 n̂ and F_1 from the ball's three sticking rows
    (F_1 = −G_11⁻¹(h_1 + G_12 F_2), as :func:`_stick_both`) and the stem's rows ν̇_2·ẑ = 0,
    ν̇_2·n̂ = 0 (a 2×2 solve); ν̇_2·d̂ = 0 follows from ω ∥ d. Returned: the normal forces, the
    tangential components across the line P_i = F_i·n̂ (determined) and the total along it,
    T = (F_1 + F_2)·d̂ (its split between the contacts is the indeterminate part). Plain
    arithmetic."""
    m, g = p[ix.M], p[ix.G]
    R, l, I1, I3 = p[ix.R], p[ix.L], p[ix.I1], p[ix.I3]
    r_s, l_s = p[ix.DRY_R_S], p[ix.DRY_L_S]
    e, L, w, n1, n2, de = both_kinematics(y, R, l, I1, I3, r_s, l_s)
    ex, ey, ez = e
    Lx, Ly, Lz = L
    wx, wy, wz = w
    c = 1.0 / I3 - 1.0 / I1
    l2 = l + l_s
    a1x, a1y, a1z = l * ex, l * ey, l * ez - R
    a2x, a2y, a2z = l2 * ex, l2 * ey, l2 * ez - r_s
    hd = (ex * ex + ey * ey) ** 0.5
    dx, dy = ex / hd, ey / hd  # d̂: the horizontal direction of the axis (d_z = 0)
    nx, ny = -dy, dx  # n̂ = ẑ × d̂
    tx, ty, tz = -(wy * Lz - wz * Ly), -(wz * Lx - wx * Lz), -(wx * Ly - wy * Lx)
    te = tx * ex + ty * ey + tz * ez
    ax0, ay0, az0 = tx / I1 + c * te * ex, ty / I1 + c * te * ey, tz / I1 + c * te * ez
    we, ww = wx * ex + wy * ey + wz * ez, wx * wx + wy * wy + wz * wz
    cx, cy, cz = we * wx - ww * ex, we * wy - ww * ey, we * wz - ww * ez
    h1x = (ay0 * a1z - az0 * a1y) + l * cx
    h1y = (az0 * a1x - ax0 * a1z) + l * cy
    h1z = -g + (ax0 * a1y - ay0 * a1x) + l * cz
    h2x = (ay0 * a2z - az0 * a2y) + l2 * cx
    h2y = (az0 * a2x - ax0 * a2z) + l2 * cy
    h2z = -g + (ax0 * a2y - ay0 * a2x) + l2 * cz

    def resp(Fx: Any, Fy: Any, Fz: Any, bx: Any, by: Any, bz: Any, ox: Any, oy: Any, oz: Any):
        # F/m + (I⁻¹(b × F)) × o: the acceleration at arm o of the force F at arm b
        qx, qy, qz = by * Fz - bz * Fy, bz * Fx - bx * Fz, bx * Fy - by * Fx
        qe = qx * ex + qy * ey + qz * ez
        jx, jy, jz = qx / I1 + c * qe * ex, qy / I1 + c * qe * ey, qz / I1 + c * qe * ez
        return (
            Fx / m + (jy * oz - jz * oy),
            Fy / m + (jz * ox - jx * oz),
            Fz / m + (jx * oy - jy * ox),
        )

    G0 = resp(1.0, 0.0, 0.0, a1x, a1y, a1z, a1x, a1y, a1z)
    G1 = resp(0.0, 1.0, 0.0, a1x, a1y, a1z, a1x, a1y, a1z)
    G2 = resp(0.0, 0.0, 1.0, a1x, a1y, a1z, a1x, a1y, a1z)
    A = ((G0[0], G1[0], G2[0]), (G0[1], G1[1], G2[1]), (G0[2], G1[2], G2[2]))
    Ah = _solve3(A, (h1x, h1y, h1z))
    Az = _solve3(A, resp(0.0, 0.0, 1.0, a2x, a2y, a2z, a1x, a1y, a1z))
    An = _solve3(A, resp(nx, ny, 0.0, a2x, a2y, a2z, a1x, a1y, a1z))
    # the stem's rows u·ν̇_2 = 0, u ∈ (ẑ, n̂): u·(h_2 + G_21 F_1 + G_22 F_2) with F_1 = −(Ah +
    # Az λ_2 + An P_2), F_2 = λ_2 ẑ + P_2 n̂
    gh = resp(Ah[0], Ah[1], Ah[2], a1x, a1y, a1z, a2x, a2y, a2z)
    gz = resp(Az[0], Az[1], Az[2], a1x, a1y, a1z, a2x, a2y, a2z)
    gn = resp(An[0], An[1], An[2], a1x, a1y, a1z, a2x, a2y, a2z)
    kz = resp(0.0, 0.0, 1.0, a2x, a2y, a2z, a2x, a2y, a2z)
    kn = resp(nx, ny, 0.0, a2x, a2y, a2z, a2x, a2y, a2z)
    b11 = kz[2] - gz[2]
    b12 = kn[2] - gn[2]
    b21 = nx * (kz[0] - gz[0]) + ny * (kz[1] - gz[1])
    b22 = nx * (kn[0] - gn[0]) + ny * (kn[1] - gn[1])
    r1 = gh[2] - h2z
    r2 = nx * (gh[0] - h2x) + ny * (gh[1] - h2y)
    det = b11 * b22 - b12 * b21
    lam2 = (r1 * b22 - b12 * r2) / det
    P2 = (b11 * r2 - b21 * r1) / det
    F1x = -(Ah[0] + Az[0] * lam2 + An[0] * P2)
    F1y = -(Ah[1] + Az[1] * lam2 + An[1] * P2)
    F1z = -(Ah[2] + Az[2] * lam2 + An[2] * P2)
    F2x, F2y, F2z = P2 * nx, P2 * ny, lam2
    rates = (
        y[2],
        y[3],
        (F1x + F2x) / m,
        (F1y + F2y) / m,
        (a1y * F1z - a1z * F1y) + (a2y * F2z - a2z * F2y),
        (a1z * F1x - a1x * F1z) + (a2z * F2x - a2x * F2z),
        (a1x * F1y - a1y * F1x) + (a2x * F2y - a2y * F2x),
        de[0],
        de[1],
        0.0,
    )
    P1 = F1x * nx + F1y * ny
    T = F1x * dx + F1y * dy
    return rates, F1z, lam2, P1, P2, T


def _roll_margins(y: Any, p: Any) -> tuple:
    """The admissibility of both contacts sticking, (μ λ_1 − |P_1|, μ λ_2 − |P_2|, ρ_1 + ρ_2 − |T|)
    (N) with ρ_i = √((μ λ_i)² − P_i²)₊: some split T = t_1 + t_2 of the force along the contact
    line with each F_i = (P_i n̂ + t_i d̂, λ_i) in its cone exists if and only if all three are
    ≥ 0 (|t_i| ≤ ρ_i for both is possible exactly when |T| ≤ ρ_1 + ρ_2)."""
    _, lam1, lam2, P1, P2, T = _roll_both(y, p)
    mu = p[ix.MU]
    q1 = (mu * lam1) * (mu * lam1) - P1 * P1
    q2 = (mu * lam2) * (mu * lam2) - P2 * P2
    rho1 = (0.5 * (q1 + (q1 * q1) ** 0.5)) ** 0.5
    rho2 = (0.5 * (q2 + (q2 * q2) ** 0.5)) ** 0.5
    return (
        mu * lam1 - (P1 * P1) ** 0.5,
        mu * lam2 - (P2 * P2) ** 0.5,
        rho1 + rho2 - (T * T) ** 0.5,
    )


SPLIT_STEPS = 64
"""Bisection steps of :func:`_drill_split` on the weight q ∈ [0, 1]: q to 2⁻⁶⁴ ≈ 5e-20, below
the rounding of any double."""


def _drill_split(
    lam1: Any, lam2: Any, T: Any, Pt: Any, K: Any, h1: Any, h2: Any, rs: Any, mu: Any
) -> tuple:
    """The split of the contact forces of both contacts sticking under Coulomb–Contensou
    (r* > 0): (t_1, P_1, m_1, t_2, P_2, m_2, s) with g_i = (t_i, P_i, m_i) = (F_i·d̂, F_i·n̂,
    M_i/r*) the generalised tangential force of contact i (N) and s = |g_i|/(μ λ_i), the same
    fraction of both cones, the smallest one any split reaches.

    Only the totals are determined by the motion (docs/theory/stem.md#dry-friction, "Sticking
    under Coulomb–Contensou"): t_1 + t_2 = T along the contact line, P_1 + P_2 = P across it,
    and the moment about the vertical h_1 P_1 + h_2 P_2 + r* (m_1 + m_2) = K (h_i = l_i sin θ_t
    the horizontal arm of contact i along d̂); three directions of internal forces remain (a
    compression along the line, a drilling couple M_1 = −M_2, and drilling traded against a
    couple of forces across the line). The reported split minimises max_i |g_i|/(μ λ_i): it
    lies in both cones exactly when some split does (s ≤ 1). It is found on the curve of the
    weighted minimum-norm splits, g_i = ν_i A_iᵀ w with ν = (1 − q, q) and w from
    (ν_1 A_1A_1ᵀ + ν_2 A_2A_2ᵀ) w = (T, P, K), A_iᵀ w = (w_0, w_1 + h_i w_2, r* w_2): |g_1| falls
    and |g_2| grows with q, and the root of μλ_2 |g_1| − μλ_1 |g_2| (bisection, SPLIT_STEPS) is
    the minimax (a two-objective Pareto front). The optimality conditions make −A_iᵀ w a pair
    of slips the kinematics allows (γ_2 − γ_1 = (0, |d| ω_z, 0)), each force opposite its own
    slip: at s = 1 the split is the sliding law's forces for that slip pair
    (:func:`_roll_cone`). Plain arithmetic (scalars)."""
    c1 = mu * _pos(lam1)
    c2 = mu * _pos(lam2)
    lo, hi = 0.0, 1.0
    for _ in range(SPLIT_STEPS):
        q = 0.5 * (lo + hi)
        g = _weighted_split(q, T, Pt, K, h1, h2, rs)
        n1 = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]) ** 0.5
        n2 = (g[3] * g[3] + g[4] * g[4] + g[5] * g[5]) ** 0.5
        if c2 * n1 - c1 * n2 > 0.0:
            lo = q
        else:
            hi = q
    g = _weighted_split(0.5 * (lo + hi), T, Pt, K, h1, h2, rs)
    n1 = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]) ** 0.5
    n2 = (g[3] * g[3] + g[4] * g[4] + g[5] * g[5]) ** 0.5
    return g[0], g[1], g[2], g[3], g[4], g[5], (n1 + n2) / (c1 + c2), g[6], g[7], g[8]


def _weighted_split(q: Any, T: Any, Pt: Any, K: Any, h1: Any, h2: Any, rs: Any) -> tuple:
    """(g_1, g_2, w) = (t_1, P_1, m_1, t_2, P_2, m_2, w_0, w_1, w_2) minimising
    |g_1|²/(1 − q) + |g_2|²/q under the three totals of :func:`_drill_split`: g_i = ν_i A_iᵀ w,
    w_0 = T and a 2×2 solve for (w_1, w_2) (its determinant Σν_i h_i² − (Σν_i h_i)² + r*² ≥
    r*² > 0). Plain arithmetic."""
    v1, v2 = 1.0 - q, q
    m12 = v1 * h1 + v2 * h2
    m22 = v1 * h1 * h1 + v2 * h2 * h2 + rs * rs
    det = m22 - m12 * m12
    w1 = (m22 * Pt - m12 * K) / det
    w2 = (K - m12 * Pt) / det
    return (
        v1 * T,
        v1 * (w1 + h1 * w2),
        v1 * rs * w2,
        v2 * T,
        v2 * (w1 + h2 * w2),
        v2 * rs * w2,
        T,
        w1,
        w2,
    )


@kernel_call
def _roll_split(y: Any, p: Any) -> tuple:
    """(λ_1, λ_2, t_1, P_1, m_1, t_2, P_2, m_2, s, w_0, w_1, w_2) of the both-rolling state ``y`` under
    Coulomb–Contensou: the motion and the normal forces of :func:`_roll_both` (the Coulomb
    solution, M_i = 0, is one split of the same totals), split by :func:`_drill_split`. Plain
    arithmetic (scalars)."""
    _, lam1, lam2, P1, P2, T = _roll_both(y, p)
    ez = (p[ix.DRY_R_S] - p[ix.R]) / p[ix.DRY_L_S]
    st = (1.0 - ez * ez) ** 0.5  # sin θ_t: the horizontal part of 3̂ on the manifold
    h1, h2 = p[ix.L] * st, (p[ix.L] + p[ix.DRY_L_S]) * st
    d = _drill_split(lam1, lam2, T, P1 + P2, h1 * P1 + h2 * P2, h1, h2, p[ix.RSTAR], p[ix.MU])
    return lam1, lam2, d[0], d[1], d[2], d[3], d[4], d[5], d[6], d[7], d[8], d[9]


def _drill_margin(y: Any, p: Any) -> Any:
    """μ(λ_1 + λ_2) − |g_1| − |g_2| = μ m g (1 − s) (N) of both contacts sticking under
    Coulomb–Contensou (:func:`_roll_split`): ≥ 0 exactly when some split fits both cones."""
    d = _roll_split(y, p)
    return p[ix.MU] * p[ix.M] * p[ix.G] * (1.0 - d[8])


def _both_rolling_into(t: float, y: Any, p: Any, out: Any) -> None:
    d = _roll_both(y, p)[0]
    out[0], out[1], out[2], out[3], out[4] = d[0], d[1], d[2], d[3], d[4]
    out[5], out[6], out[7], out[8], out[9] = d[5], d[6], d[7], d[8], d[9]
    out[10] = 0.0


def _br_contact(t: float, y: Any, p: Any) -> Any:
    d = _roll_both(y, p)
    return (d[1] + d[2]) * (1.0 / (p[ix.M] * p[ix.G]))


def _br_ball_lift(t: float, y: Any, p: Any) -> Any:
    return _roll_both(y, p)[1] * (1.0 / (p[ix.M] * p[ix.G]))


def _br_stem_lift(t: float, y: Any, p: Any) -> Any:
    return _roll_both(y, p)[2] * (1.0 / (p[ix.M] * p[ix.G]))


def _br_ball_cone(t: float, y: Any, p: Any) -> Any:
    """(μ λ_1 − |P_1|)/(m g): the ball's force across the contact line reaches its cone.
    Coulomb only: under Coulomb–Contensou one contact cannot stick alone (:func:`_br_line_cone`)."""
    if p[ix.RSTAR] > 0.0:
        return 1.0 + 0.0 * y[0]
    return _roll_margins(y, p)[0] * (1.0 / (p[ix.M] * p[ix.G]))


def _br_stem_cone(t: float, y: Any, p: Any) -> Any:
    """(μ λ_2 − |P_2|)/(m g): the stem's force across the contact line reaches its cone
    (Coulomb only, as :func:`_br_ball_cone`)."""
    if p[ix.RSTAR] > 0.0:
        return 1.0 + 0.0 * y[0]
    return _roll_margins(y, p)[1] * (1.0 / (p[ix.M] * p[ix.G]))


def _br_line_cone(t: float, y: Any, p: Any) -> Any:
    """(ρ_1 + ρ_2 − |T|)/(m g): no split of the force along the contact line fits both cones.
    Under Coulomb–Contensou μ(1 − s) (:func:`_drill_margin`): no split of the forces and the
    drilling torques fits both cones."""
    if p[ix.RSTAR] > 0.0:
        return _drill_margin(y, p) * (1.0 / (p[ix.M] * p[ix.G]))
    return _roll_margins(y, p)[2] * (1.0 / (p[ix.M] * p[ix.G]))


def both_forces(y: Any, p: tuple) -> tuple:
    """(λ_1, λ_2, |γ_1|, |γ_2|) of a state ``y`` of the double contact in the mode of its flag
    (:data:`BOTH_FLAGS`; both sliding for an array of states): the normal forces (N) of the
    ball and the stem and their generalised slip speeds (m/s)."""
    if np.ndim(y) == 1 and round(float(y[10])) == 5:
        d = _roll_both(y, p)
        slips = _slips(y, p)
        return d[1], d[2], slips[0], slips[1]
    if np.ndim(y) == 1 and round(float(y[10])) in (3, 4):
        s = round(float(y[10])) - 3
        d = _stick_both(y, p, float(s))
        slips = _slips(y, p)
        return d[1], d[2], slips[0], slips[1]
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
    indeterminate; its total is split by :func:`_split_line`, which fits both cones whenever
    any split does).

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
            kq = -mu / s if (mu > 0.0 and s > 0.0) else 0.0
            unit = z + kq * np.array([gam[0], gam[1], 0.0])
            A[5, c[f"l{i + 1}"]] -= kq * rs * gam[2]
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
    Ft: list[np.ndarray | None] = []
    for i in (0, 1):
        if sticking[i]:
            Ft.append(np.array([x[c[f"t{i}{k}"]] for k in range(n_t)] + [0.0] * (3 - n_t)))
        else:
            Ft.append(None)
    if all(sticking) and n_t == 2:
        Ft = _split_line(Ft, e, lam, mu)
    elif all(sticking):
        Ft = _split_drill(Ft, e, lam, p)
    margin = [
        mu * lam[i] - float(np.linalg.norm(f)) if sticking[i] and (f := Ft[i]) is not None else 0.0
        for i in (0, 1)
    ]
    return {"lam": lam, "Ft": Ft, "margin": margin}


def _split_drill(Ft: list, e: np.ndarray, lam: tuple, p: tuple) -> list:
    """The generalised tangential forces (F_x, F_y, M/r*) of both contacts sticking under
    Coulomb–Contensou, any particular solution ``Ft`` re-split by :func:`_drill_split` (the
    totals T, P and the moment about the vertical K are what the motion determines)."""
    d = np.array([e[0], e[1], 0.0]) / math.hypot(e[0], e[1])
    n = np.array([-d[1], d[0], 0.0])
    st = math.hypot(e[0], e[1])
    rs = p[ix.RSTAR]
    h = (p[ix.L] * st, (p[ix.L] + p[ix.DRY_L_S]) * st)
    F = [np.array([f[0], f[1], 0.0]) for f in Ft]
    T = float(F[0] @ d + F[1] @ d)
    P = [float(F[i] @ n) for i in (0, 1)]
    K = h[0] * P[0] + h[1] * P[1] + rs * float(Ft[0][2] + Ft[1][2])
    g = _drill_split(lam[0], lam[1], T, P[0] + P[1], K, h[0], h[1], rs, p[ix.MU])
    return [g[3 * i] * d + g[3 * i + 1] * n + np.array([0.0, 0.0, g[3 * i + 2]]) for i in (0, 1)]


def _split_line(Ft: list, e: np.ndarray, lam: tuple, mu: float) -> list:
    """The tangential forces of both contacts sticking (Coulomb) with the force along the contact
    line d̂ (the horizontal direction of 3̂) split in proportion to what each cone leaves for it,
    t_i = T ρ_i/(ρ_1 + ρ_2), ρ_i = √((μ λ_i)² − P_i²)₊, P_i = F_i·n̂ (n̂ = ẑ × d̂): only the total
    T is determined (an internal compression along the line has no moment and does no work),
    and this split puts both forces inside their cones whenever any split does
    (docs/theory/stem.md#dry-friction, "Both contacts sticking")."""
    d = np.array([e[0], e[1], 0.0]) / math.hypot(e[0], e[1])
    n = np.array([-d[1], d[0], 0.0])
    P = [float(Ft[i] @ n) for i in (0, 1)]
    T = float(Ft[0] @ d + Ft[1] @ d)
    rho = [math.sqrt(max((mu * lam[i]) ** 2 - P[i] ** 2, 0.0)) for i in (0, 1)]
    share = [r / (rho[0] + rho[1]) for r in rho] if rho[0] + rho[1] > 0.0 else [0.5, 0.5]
    return [P[i] * n + T * share[i] * d for i in (0, 1)]


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
    stuck = at_band = False
    p0, p1 = 0.0, 10.0 * -g0[2] / Wg[2, 2]
    for _ in range(60):
        # at the band: located by the event (possibly an ulp above η: its root from above, which
        # would restart the integration on the same root, again and again) or started within it
        if at_band or np.linalg.norm(z[tang]) <= eta:  # stick if the cone holds, else restart
            at_band = False
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
            z, p0, at_band = sol.y_events[1][0], float(sol.t_events[1][0]), True
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


NO_DRY_CLOSURE = (
    "both contacts close, but no impulse satisfies the dry law at both (a Painlevé-type "
    "inconsistency of the impulse law): the run ends there"
)
"""The message of a dry closure of both contacts where no mode is consistent."""


def _both_frame(y: np.ndarray, p: tuple, on: str, vz: float | None) -> tuple:
    """(state in L_z form, the :class:`ImpactFrame` of the contact other than ``on``, the arms,
    the generalised Delassus matrix W of both contacts, their generalised velocities g⁻, k) of a
    state ``y`` on the contact ``on`` with the vertical CM velocity ``vz``: what every impact at
    both contacts starts from."""
    rs = p[ix.RSTAR]
    yl = _lz(y, p)
    f = impact_frame(yl, _viscous(p), "stem" if on == "ball" else "ball", vz)
    arms = _arms(f.e, p)
    W = _delassus2(f.e, f.Iinv, p[ix.M], arms, rs)
    return yl, f, arms, W, _gvel(f.V, f.w, arms, rs), _gen(rs)


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
    y: np.ndarray, p: tuple, on: str, tail: bool = False, vz: float | None = None
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

    ``vz``: the vertical CM velocity (m/s) of a state in flight (a landing on both spheres,
    :func:`land_both`); None: that of the contact ``on``'s constraint.

    Returns the state on both contacts (flag 2, L_z form), the impulses Π = (Π_1, Π_2) (N s per
    contact: (P_x, P_y, P_z[, Q/r*])) and the mode (ball sticks, stem sticks). Raises
    :class:`JumpFailed` when no mode is consistent (a Painlevé-type inconsistency of the dry
    impulse law).
    """
    mu = p[ix.MU]
    yl, f, arms, W, g0, k = _both_frame(y, p, on, vz)
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
        after = _apply2(yl, p, f.L, arms, Pi) if ok else None
        if after is not None and _kinetic(after, p) <= E0 * (1.0 + 1e-12):
            return after, Pi, mode  # consistent, and the energy not raised (to rounding)
    raise JumpFailed(NO_DRY_CLOSURE)


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

    * the impacts do not accumulate: the impact at both contacts
      (:func:`mett.dynamics.stem.two_contact_impact`, the old contact closed with zero normal
      velocity): the single dry impact (:func:`impact`), its slip settled, if the old contact
      then separates, "touchdown"/"landing"; else both closed by the dry closure impulse
      (:func:`close_both`, normal impulses ≥ 0), "closure";
    * the impact times form a geometric sequence (:func:`mett.dynamics.stem.accumulation`):
      both closed by the closure impulse of the tail, "accumulation";

    after both closed the double contact starts if both normal forces are positive
    (:func:`_enter_both`).

    The third value is the accumulation point t_∞ (s; NaN if none).
    """
    old = "ball" if to == "stem" else "stem"
    acc = stem.accumulation(_trailing_impacts(switches)) if len(switches) else None
    if acc is None:
        out, imp = _two_contact(y, p, stem.PHASE_NAMES.index(to))
        if not all(imp.closed):
            return out, "touchdown" if to == "stem" else "landing", math.nan
        return out, "closure", math.nan
    closed, Pi, _ = close_both(y, p, old, tail=True)
    # the tail's contact impulses, P_n,i + λ_i (t_∞ − t_k), are ≥ 0
    k = _gen(p[ix.RSTAR])
    span = acc.t_limit - _trailing_impacts(switches)[-1]
    lam = both_forces(closed, p)[:2]
    if min(Pi[2] + lam[0] * span, Pi[k + 2] + lam[1] * span) < 0.0:
        raise JumpFailed(
            f"impacts accumulate (ratio {acc.ratio:.3g}, limit t = {acc.t_limit:.9g} s) "
            "into a double contact that one contact cannot carry (its tail impulse < 0)"
        )
    return _enter_both(closed, p), "accumulation", acc.t_limit


def _two_contact(
    y: np.ndarray, p: tuple, first: int, vz: float | None = None
) -> tuple[np.ndarray, stem.TwoContactImpact]:
    """The impact at both contacts of the λ-form state ``y`` with the dry law
    (:func:`_impact_both`). Returns the state to continue from (this model's layout: a single
    contact's slip settled; both closed: the double contact if both normal forces are positive,
    :func:`_enter_both`) and the impact."""
    imp = _impact_both(y, p, first, vz)
    if all(imp.closed):
        return _enter_both(imp.state, p), imp
    q = _contact(p, imp.closed[1])
    return dry.settle(_converted(imp.state, p, dry.from_gliding), q), imp


def impact_both(g: np.ndarray, vz: float | None, p: tuple, first: int) -> stem.TwoContactImpact:
    """The dry impact at both contacts (:func:`mett.dynamics.stem.two_contact_impact`) of the
    gliding-layout state ``g`` (L_z in row 6) whose sphere ``first`` (0 ball, 1 stem) arrives
    while the other's gap is 0: its vertical CM velocity ``vz`` (m/s; None: the other contact is
    closed, its constraint's). The impact only, before the slip is settled or the double contact
    entered (:func:`land_both` continues from it)."""
    y = np.append(np.asarray(g, dtype=float)[:10], float(first))
    if vz is None:  # the state is on the other contact
        y[10] = float(1 - first)
    return _impact_both(_converted(y, p, dry.from_gliding), p, first, vz)


def _impact_both(
    y: np.ndarray, p: tuple, first: int, vz: float | None = None
) -> stem.TwoContactImpact:
    """The impact at both contacts (:func:`mett.dynamics.stem.two_contact_impact`) of the
    λ-form state ``y`` with the dry law: one contact by :func:`dry_impulse`; the other contact
    closed before, the dry two-contact Darboux–Keller path (:func:`mett.dynamics.stem.
    contact_path` with stick–slip); both by :func:`close_both` (else :func:`_moreau_closure`).
    Where no active set is consistent, Moreau's velocity-level law (:func:`_moreau_two_contact`),
    which always has a solution."""
    m, mu, rs = p[ix.M], p[ix.MU], p[ix.RSTAR]
    on = ("ball", "stem")[round(float(y[10]))]
    yl = _lz(y, p)
    k = _gen(rs)

    def single(f: stem.ImpactFrame) -> tuple:
        P, Q, _ = dry_impulse(f, m, mu, rs)
        return P, Q

    def both(frames: Any) -> tuple | None:
        try:
            after, Pi, _ = close_both(y, p, on, vz=vz)
        except JumpFailed:  # no sliding direction of the slips before fits: those after
            try:
                after, Pi, _ = _moreau_closure(y, p, on, vz)
            except JumpFailed:
                return None
        Q = rs * np.array([Pi[3], Pi[7]]) if k == 4 else np.zeros(2)
        return after, np.array([Pi[0:3], Pi[k : k + 3]]), Q

    def path(frames: Any, first: int) -> tuple | None:
        arms = [f.a for f in frames]
        f = frames[0]
        W = _delassus2(f.e, f.Iinv, m, arms, rs)
        g0 = _gvel(f.V, f.w, arms, rs)
        res = stem.contact_path(W, g0, first, _dry_law(mu), k, mu if mu > 0.0 else None)
        if res is None:  # the closed contact jams: not this set
            return None
        Pi, closed = res
        Q = rs * np.array([Pi[3], Pi[7]]) if k == 4 else np.zeros(2)
        return np.array([Pi[0:3], Pi[k : k + 3]]), closed, Q

    try:
        return stem.two_contact_impact(yl, _viscous(p), first, single, both, vz, path)
    except JumpFailed:  # no active set fits: the velocity-level law, which has a solution
        return _moreau_two_contact(y, p, first, vz)


def _dry_law(mu: float) -> Any:
    """The dry law's tangential impulse per unit normal impulse of a sliding contact, −μ ĝ_t
    (g_t its tangential generalised velocity; :func:`mett.dynamics.stem.contact_path`)."""

    def law(*gt: float) -> tuple:
        s = math.sqrt(sum(c * c for c in gt))
        return tuple(-mu * c / s if s > 0.0 else 0.0 for c in gt)

    return law


def _moreau_closure(
    y: np.ndarray, p: tuple, on: str, vz: float | None = None
) -> tuple[np.ndarray, np.ndarray, tuple]:
    """The impulse at both contacts that stops both normal velocities with the dry law at the
    velocity level (Moreau; Leine & Glocker 2003): a sliding contact's tangential impulse is
    −μ P_n,i γ̂⁺_i, opposite to its generalised slip **after** the impulse, a sticking one
    stops it inside its cone. Where :func:`close_both`'s sliding directions (those before) admit
    no consistent mode — a contact at rest before, whose direction the impulse itself sets —
    this one is taken (:func:`_two_contact`). The kinetic energy changes by
    ΔT = Π·g⁺ − ½ ΠᵀWΠ = −μ Σ P_n,i |γ⁺_i| − ½ ΠᵀWΠ ≤ 0 (P_n,i ≥ 0, g⁺_n = 0), checked.

    Modes in :func:`close_both`'s order, each a root of its 2k equations (normal rows g⁺_n,i =
    0; sliding Π_t,i |γ⁺_i| + μ P_n,i γ⁺_i = 0; sticking γ⁺_i = 0) by Powell's hybrid method
    from the frictionless impulse. Returns as :func:`close_both`; raises :class:`JumpFailed` if
    no mode is consistent."""
    from scipy.optimize import root

    mu = p[ix.MU]
    yl, f, arms, W, g0, k = _both_frame(y, p, on, vz)
    t = [0, 1, 3] if k == 4 else [0, 1]
    nr = [2, k + 2]
    E0 = _kinetic(yl, p, float(f.V[2]))
    scale = max(float(np.max(np.abs(g0))), 1e-300)
    guess = np.zeros(2 * k)
    guess[nr] = np.linalg.lstsq(W[np.ix_(nr, nr)], -g0[nr], rcond=None)[0]
    for mode in ((False, False), (True, False), (False, True), (True, True)):

        def eqs(Pi: np.ndarray, mode: tuple = mode) -> np.ndarray:
            gp = g0 + W @ Pi
            out = [gp[2], gp[k + 2]]
            for i in range(2):
                ti = [i * k + j for j in t]
                if mode[i]:
                    out.extend(gp[ti])
                else:
                    out.extend(Pi[ti] * np.linalg.norm(gp[ti]) + mu * Pi[i * k + 2] * gp[ti])
            return np.array(out)

        Pi = root(eqs, guess, method="hybr", options={"xtol": 1e-14}).x
        gp = g0 + W @ Pi
        Pn = Pi[nr]
        if not np.all(np.isfinite(Pi)) or np.max(np.abs(gp[nr])) > 1e-9 * scale:
            continue
        ok = bool(np.min(Pn) >= -1e-12 * np.max(np.abs(Pi)))
        for i in range(2):
            ti = [i * k + j for j in t]
            slip = float(np.linalg.norm(gp[ti]))
            if mode[i]:
                ok &= slip <= 1e-9 * scale
                ok &= float(np.linalg.norm(Pi[ti])) <= mu * Pn[i] * (1.0 + 1e-12)
            else:  # sliding: a slip left, the impulse −μ P_n γ̂⁺ (to the root's tolerance)
                ok &= slip > 1e-9 * scale
                want = -mu * Pn[i] * gp[ti] / max(slip, 1e-300)
                ok &= float(np.max(np.abs(Pi[ti] - want))) <= 1e-9 * np.max(np.abs(Pi))
        after = _apply2(yl, p, f.L, arms, Pi) if ok else None
        if after is not None and _kinetic(after, p) <= E0 * (1.0 + 1e-12):
            return after, Pi, mode  # consistent, and the energy not raised (to rounding)
    raise JumpFailed(NO_DRY_CLOSURE)


# --- the velocity-level impact law at both contacts (Moreau), solved where no active set fits -


MOREAU_RTOL = 1e-12
"""Residual of :func:`moreau_impulse`'s Alart–Curnier equations at which Newton's iteration
stops, relative to the impulse scale max|g⁻| / min W_ii,nn (a few hundred ulps of the impulse:
the equations are solved to rounding, quadratically convergent near the root)."""

MOREAU_CHECK = 1e-9
"""Allowance of :func:`moreau_check`, relative to the impulse scale (impulses) or to the largest
generalised contact-point speed before the impact (velocities): the law is checked far above
the solve's residual (:data:`MOREAU_RTOL`) and far below any physical effect."""


MOREAU_RHO = (1.0, 0.1, 10.0, 0.3, 3.0, 0.01, 100.0)
"""Factors of the Alart–Curnier parameters ρ_i = 1/W_ii,nn tried in turn by
:func:`moreau_impulse`: every ρ > 0 has the same roots, but Newton's basin of convergence
depends on it (at μ = 3 one start can stall on a local minimum of ½|Φ|² at one ρ and converge
at another)."""


def _tangent_rows(k: int, i: int) -> list[int]:
    """Rows of contact ``i``'s tangential components (x, y[, r* ω_z]) in a generalised vector."""
    return [i * k + j for j in ((0, 1, 3) if k == 4 else (0, 1))]


def _alart_curnier(
    x: np.ndarray, W: np.ndarray, g0: np.ndarray, mu: float, k: int, rho: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The Alart–Curnier function Φ(Π) of the velocity-level impact law and a member of its
    generalised Jacobian (:func:`moreau_impulse`). Per contact i, with g = g⁻ + W Π, ρ_i > 0,
    a_i = Π_n,i − ρ_i g_n,i and b_i = Π_t,i − ρ_i g_t,i:

        Φ_n,i = Π_n,i − max(a_i, 0),   Φ_t,i = Π_t,i − proj(b_i; |·| ≤ μ max(a_i, 0)).

    Φ = 0 exactly when Π_n,i ≥ 0, g_n,i ≥ 0, Π_n,i g_n,i = 0, |Π_t,i| ≤ μ Π_n,i and Π_t,i is
    −μ Π_n,i ĝ_t,i wherever g_t,i ≠ 0 (Alart & Curnier 1991)."""
    n = W.shape[0]
    g = g0 + W @ x
    eye = np.eye(n)
    F = np.empty(n)
    J = np.empty((n, n))
    for i in range(n // k):
        r, t, h = i * k + 2, _tangent_rows(k, i), rho[i]
        a = x[r] - h * g[r]
        if a > 0.0:
            F[r], J[r] = h * g[r], h * W[r]
        else:
            F[r], J[r] = x[r], eye[r]
        b = x[t] - h * g[t]
        nb = float(np.linalg.norm(b))
        rad = mu * max(a, 0.0)
        if nb <= rad:  # inside the disc: sticking, g_t = 0
            F[t], J[t] = h * g[t], h * W[t]
        else:  # on its rim: Π_t = rad b̂
            u = b / nb
            db = eye[t] - h * W[t]
            dr = mu * (eye[r] - h * W[r]) if a > 0.0 else np.zeros(n)
            F[t] = x[t] - rad * u
            J[t] = eye[t] - np.outer(u, dr) - (rad / nb) * (db - np.outer(u, u @ db))
    return F, J


def moreau_impulse(
    W: np.ndarray, g0: np.ndarray, mu: float, k: int, starts: Any = ()
) -> np.ndarray | None:
    """The generalised impulse Π (N s per component) of the perfectly inelastic impact at
    several contacts under Moreau's velocity-level law with Coulomb (k = 3) or Coulomb–Contensou
    (k = 4) friction, or None if Newton's iteration finds none.

    ``W`` (kg⁻¹): the generalised Delassus matrix, Δg = W Π (:func:`_delassus2`); ``g0``: the
    generalised velocities g = (v_x, v_y, v_z[, r* ω_z]) of the contact points before (m/s).
    The law at each contact i, with g⁺ = g⁻ + W Π:

        Π_n,i ≥ 0,  g⁺_n,i ≥ 0,  Π_n,i g⁺_n,i = 0;
        |Π_t,i| ≤ μ Π_n,i,  and Π_t,i = −μ Π_n,i ĝ⁺_t,i where g⁺_t,i ≠ 0

    (Moreau 1988; Glocker 2001; Acary & Brogliato 2008, ch. 13): a contact opens or closes, and
    a closed one sticks inside its cone or slides with the impulse opposite to its slip after
    the impact. It is solved as Φ(Π) = 0 with the Alart–Curnier function
    (:func:`_alart_curnier`, ρ_i = 1/W_ii,nn) by a semismooth Newton method (least-squares steps,
    as W is only semidefinite for two contacts on a plane; Armijo backtracking on ½|Φ|²), from
    each of ``starts`` and then from the frictionless solution (the normal LCP by its active
    sets), the all-sticking impulse and 0. A solution exists for every μ ≥ 0 and every g⁻
    (docs/theory/stem.md#two-contact-impact); Newton's iteration is not guaranteed to find it,
    and the answer is checked (:func:`moreau_check`)."""
    n = W.shape[0]
    nc = n // k
    nr = [i * k + 2 for i in range(nc)]
    rho = np.array([1.0 / W[r, r] for r in nr])
    scale = max(float(np.max(np.abs(g0))), 1e-300) * float(np.max(rho))
    tol = MOREAU_RTOL * scale
    guesses = [np.asarray(s, dtype=float) for s in starts]
    Wnn = W[np.ix_(nr, nr)]
    for active in range(1, 2**nc):  # the frictionless LCP: its consistent active set
        idx = [nr[i] for i in range(nc) if active >> i & 1]
        x = np.zeros(n)
        x[idx] = np.linalg.solve(W[np.ix_(idx, idx)], -g0[idx])
        gn = g0[nr] + Wnn @ x[nr]
        if np.min(x[nr]) >= -tol and np.min(gn) >= -MOREAU_RTOL * scale / np.max(rho):
            guesses.append(x)
            break
    guesses.append(np.linalg.lstsq(W, -g0, rcond=None)[0])
    guesses.append(np.zeros(n))
    # ρ sets the basin of Newton's convergence, not the root: the same starts with ρ scaled
    tries = [(x, f) for f in MOREAU_RHO for x in guesses]
    for x, f in tries:
        x = np.array(x, dtype=float)
        F, J = _alart_curnier(x, W, g0, mu, k, f * rho)
        theta = 0.5 * float(F @ F)
        for _ in range(200):
            if theta <= 0.5 * tol * tol:
                if moreau_check(W, g0, mu, k, x):
                    return x
                break
            d = np.linalg.lstsq(J, -F, rcond=None)[0]
            step = 1.0
            while step > 1e-12:  # Armijo on ½|Φ|² along the Newton direction (slope −|Φ|²)
                xn = x + step * d
                Fn, Jn = _alart_curnier(xn, W, g0, mu, k, f * rho)
                thn = 0.5 * float(Fn @ Fn)
                if thn <= (1.0 - 2e-4 * step) * theta:
                    break
                step *= 0.5
            else:
                break  # no descent: a local minimum of the merit, not a root
            x, F, J, theta = xn, Fn, Jn, thn
    return None


def moreau_check(W: np.ndarray, g0: np.ndarray, mu: float, k: int, x: np.ndarray) -> bool:
    """Whether the generalised impulse ``x`` satisfies the velocity-level impact law of
    :func:`moreau_impulse` to :data:`MOREAU_CHECK`: normal impulses ≥ 0, normal velocities after
    ≥ 0 and complementary; each tangential impulse in its cone, opposite to the slip after
    with magnitude μ Π_n where that slip is not 0; the kinetic energy not raised,
    ΔT = Π·g⁺ − ½ ΠᵀWΠ ≤ 0 (generalised velocities and impulses are work-conjugate)."""
    n = W.shape[0]
    g = g0 + W @ x
    vs = max(float(np.max(np.abs(g0))), 1e-300)
    ps = vs * max(1.0 / W[i * k + 2, i * k + 2] for i in range(n // k))
    if not np.all(np.isfinite(x)):
        return False
    for i in range(n // k):
        r, t = i * k + 2, _tangent_rows(k, i)
        Pn, gn = float(x[r]), float(g[r])
        if Pn < -MOREAU_CHECK * ps or gn < -MOREAU_CHECK * vs:
            return False
        if min(Pn / ps, gn / vs) > MOREAU_CHECK:  # complementarity
            return False
        Pt, gt = x[t], g[t]
        if np.linalg.norm(Pt) > mu * max(Pn, 0.0) + MOREAU_CHECK * ps:
            return False
        slip = float(np.linalg.norm(gt))
        if slip > MOREAU_CHECK * vs:  # sliding: −μ Π_n ĝ_t
            want = -mu * max(Pn, 0.0) * gt / slip
            if np.max(np.abs(Pt - want)) > MOREAU_CHECK * ps:
                return False
    return float(x @ g - 0.5 * x @ W @ x) <= MOREAU_CHECK * ps * vs


def _moreau_two_contact(
    y: np.ndarray, p: tuple, first: int, vz: float | None = None
) -> stem.TwoContactImpact:
    """The impact at both contacts by Moreau's velocity-level law (:func:`moreau_impulse`) of
    the λ-form state ``y``: where no active set of :func:`mett.dynamics.stem.two_contact_impact`
    is consistent (a single Darboux–Keller impact that drives the other contact into the table,
    and no dry closure). Its state is on both contacts (flag 2, :func:`_apply2`) if both close,
    else on the one that closes (flag 0/1; the other's impulse is 0). Raises
    :class:`JumpFailed` naming the state if Newton's iteration finds no solution."""
    m, mu, rs = p[ix.M], p[ix.MU], p[ix.RSTAR]
    on = ("ball", "stem")[round(float(y[10]))]
    yl, f, arms, W, g0, k = _both_frame(y, p, on, vz)
    x = moreau_impulse(W, g0, mu, k)
    if x is None:
        raise JumpFailed(
            "both contacts at an impact: no active set fits and Newton's iteration found no "
            f"solution of the velocity-level impact law (theta = {math.acos(f.e[2]):.9g} rad, "
            f"contact-point velocities {np.array2string(g0, precision=6)} m/s): the run ends "
            "there"
        )
    g = g0 + W @ x
    vs = float(np.max(np.abs(g0)))
    closed = (bool(g[2] <= MOREAU_CHECK * vs), bool(g[k + 2] <= MOREAU_CHECK * vs))
    P = np.array([x[0:3], x[k : k + 3]])
    Q = rs * np.array([x[3], x[7]]) if k == 4 else np.zeros(2)
    if all(closed):
        state = _apply2(yl, p, f.L, arms, x)
    else:  # one contact closes: the other's impulse is 0 (complementarity, to rounding)
        i = 0 if closed[0] else 1
        P[1 - i], Q[1 - i] = 0.0, 0.0
        fi = impact_frame(yl, _viscous(p), ("ball", "stem")[i], float(f.V[2]))
        state = apply_impulse(yl, fi, m, P[i], ("ball", "stem")[i], float(Q[i]))
    return stem.TwoContactImpact(closed, P, Q, g[[2, k + 2]], state)


def land_both(
    g: np.ndarray, vz: float, p: tuple, first: int
) -> tuple[np.ndarray, stem.TwoContactImpact]:
    """The landing from a flight of both spheres at once (the other sphere's gap within the
    event tolerance when the sphere ``first`` touches): the two-contact impact of the
    gliding-layout state ``g`` (L_z in row 6) with the vertical CM velocity ``vz`` (m/s), the
    dry law (:func:`_two_contact`). Returns the state to continue from and the impact."""
    y = _converted(np.append(np.asarray(g, dtype=float)[:10], float(first)), p, dry.from_gliding)
    return _two_contact(y, p, first, vz)


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


def _restart_both(
    y2: np.ndarray, p: tuple, i: int, direction: np.ndarray, size: float = 2.0
) -> np.ndarray:
    """``y2`` after the impulse at contact ``i`` that sets its generalised slip to ``size`` δ
    along ``direction`` (0: stopped) while both normal velocities stay 0 (impulses at both
    normals); the flag kept."""
    m, rs = p[ix.M], p[ix.RSTAR]
    e, L, w, V, Iinv = _both_body(y2, p)
    arms = _arms(e, p)
    W = _delassus2(e, Iinv, m, arms, rs)
    g0 = _gvel(V, w, arms, rs)
    k = _gen(rs)
    t = [0, 1, 3] if k == 4 else [0, 1]
    rows = [2, k + 2] + [i * k + j for j in t]
    target = np.zeros(len(rows))
    target[2:] = size * p[ix.BAND] * np.asarray(direction, dtype=float)[: len(t)]
    Wr = W[np.ix_(rows, rows)]
    x = np.linalg.solve(Wr, target - g0[rows])
    Pi = np.zeros(2 * k)
    Pi[rows] = x
    out = _apply2(y2, p, L, arms, Pi)
    out[10] = y2[10]
    return out


def _stop_pair(y2: np.ndarray, p: tuple, targets: np.ndarray | None = None) -> np.ndarray:
    """``y2`` after the impulse at both contacts (Coulomb) that sets both normal velocities to 0
    and the horizontal slips to ``targets`` (ν_1x, ν_1y, ν_2x, ν_2y; default 0: both stopped).
    The Delassus matrix of the two contacts is singular (an impulse pair ±f d̂ along the
    contact line moves nothing), and the targets are consistent with it when ν_2 − ν_1 has no
    part along d̂ (ν_2 − ν_1 = (ω × d) is always ⊥ d): least squares is then exact; the
    minimum-norm impulse is taken. The flag kept. Under Coulomb–Contensou the same impulse
    (no drilling impulse): forces at two points of the contact line already span every impulse
    with no moment about that line, the drilling ones included, and both slips 0 make ω_z = 0."""
    e, L, w, V, Iinv = _both_body(y2, p)
    arms = _arms(e, p)
    W = _delassus2(e, Iinv, p[ix.M], arms, 0.0)
    g0 = _gvel(V, w, arms, 0.0)
    want = np.zeros(6)
    if targets is not None:
        want[[0, 1, 3, 4]] = targets
    Pi = np.linalg.lstsq(W, want - g0, rcond=None)[0]
    if p[ix.RSTAR] > 0.0:  # _apply2's layout with Contensou: (P_1, Q_1/r*, P_2, Q_2/r*)
        Pi = np.concatenate((Pi[0:3], [0.0], Pi[3:6], [0.0]))
    out = _apply2(y2, p, L, arms, Pi)
    out[10] = y2[10]
    return out


def _slips(y2: np.ndarray, p: tuple) -> tuple[float, float]:
    """|γ_1|, |γ_2| (m/s) of a double-contact state (any mode)."""
    e, L, w, n1, n2, _ = both_kinematics(
        np.asarray(y2, dtype=float), p[ix.R], p[ix.L], p[ix.I1], p[ix.I3], p[ix.DRY_R_S],
        p[ix.DRY_L_S],
    )  # fmt: skip
    sw = p[ix.RSTAR] * w[2]
    return math.hypot(n1[0], n1[1], sw), math.hypot(n2[0], n2[1], sw)


BOTH_FLAGS = {
    2.0: "both-sliding",
    3.0: "both-ball-rolling",
    4.0: "both-stem-rolling",
    5.0: "both-rolling",
}
"""The double contact's modes by the state's flag: both contacts sliding, the ball rolling
(sticking) with the stem sliding, the stem rolling with the ball sliding, both rolling (the
body turning about the line through the two contact points; Coulomb, and Coulomb–Contensou
for r_s > R, where it is the only sticking mode)."""


def _slip_acceleration(y2: np.ndarray, p: tuple, i: int, u: np.ndarray) -> np.ndarray:
    """ν̇_i (m/s², horizontal) of contact ``i`` of the double contact at rest there, sliding
    with the friction −μ λ_i u (u a horizontal unit vector; Coulomb), the other contact sliding
    with its own slip: the rates of :func:`both_solve` turned into the contact acceleration
    V̇ + ω̇ × a_i + ω × (ω × l_i 3̂), ω̇ = I⁻¹(L̇ − ω × L)."""
    mu = p[ix.MU]
    R, l, I1, I3 = p[ix.R], p[ix.L], p[ix.I1], p[ix.I3]
    r_s, l_s = p[ix.DRY_R_S], p[ix.DRY_L_S]
    e, L, w, n1, n2, de = both_kinematics(y2, R, l, I1, I3, r_s, l_s)
    nu = (n1, n2)
    f = []
    for j in range(2):
        if j == i:
            f.append((-mu * u[0], -mu * u[1], 0.0))
        else:
            sj = math.hypot(nu[j][0], nu[j][1])
            f.append((-mu * nu[j][0] / sj, -mu * nu[j][1] / sj, 0.0))
    rates, _, _ = both_solve(y2, p[ix.M], p[ix.G], R, l, r_s, l_s, e, L, de, f[0], f[1])
    e, L, w = np.array(e), np.array(L), np.array(w)
    Iinv = np.eye(3) / I1 + (1.0 / I3 - 1.0 / I1) * np.outer(e, e)
    wdot = Iinv @ (np.array(rates[4:7]) - np.cross(w, L))
    li = l + (l_s if i else 0.0)
    a = li * e - np.array([0.0, 0.0, (R, r_s)[i]])
    acc = np.array([rates[2], rates[3], 0.0]) + np.cross(wdot, a)
    acc += np.cross(w, np.cross(w, li * e))
    return acc[:2]


def _excess_both(y2: np.ndarray, p: tuple, i: int) -> np.ndarray | None:
    """The direction u in which the slip of contact ``i`` (at rest) starts under sliding
    friction −μ λ_i u: ν̇_i = s u with s > 0, the largest such s
    (:func:`mett.dynamics.contact.excess_angle`); None if there is none (Coulomb)."""
    best = dry.excess_angle(lambda ux, uy: _slip_acceleration(y2, p, i, np.array([ux, uy])))
    return None if best is None else np.array(best)


def _settle_both(y2: np.ndarray, p: tuple, at: int | None = None) -> np.ndarray:
    """A double-contact state with a contact's slip within the band: the mode of that contact
    chosen by consistency (Pfeiffer & Glocker 1996; Leine & Glocker 2003: a mode is admissible
    when its normal forces are ≥ 0 and each sticking contact's force lies in its cone).

    Both slips within the band (or the other contact already sticking): both sticking is tried
    first; admissible (normal forces ≥ 0, some split of the force along the contact line in both
    cones, :func:`_split_line`), both slips are stopped (:func:`_stop_pair`) and the rolling
    about the contact line runs ("both-rolling", flag 5; never admissible when r_s < R, the
    stem's normal force is then negative: docs/theory/stem.md#dry-friction). One contact
    sticking admissible: under Coulomb the slip is stopped (an impulse at that contact keeping
    both normal velocities 0) and the mode "both-ball-rolling" / "both-stem-rolling" runs (flag
    3 / 4). Under Coulomb–Contensou sticking needs ω_z = 0, which makes both contacts rest: a
    slip within the band at either contact tries that rolling, both slips stopped (the other's
    is at most (1 + l_s sin θ_t/r*) δ) and admissible when both normal forces are ≥ 0 and
    the minimax split of the forces and drilling torques fits both cones
    (:func:`_drill_split`), checked at the stopped state it would run from; if it is not
    admissible but the force of "that contact sticks, the other slides" (a mode the
    kinematics does not allow under Contensou) lies in its cone, the run ends with
    :class:`JumpFailed` naming it. Not admissible: the slip restarts (2δ) opposite to the
    force sticking would need (where the excess force drives it; exact at the cone's edge)."""
    if dry.frictionless(p) or p[ix.LAW] != dry.LAW_COULOMB:
        return y2
    flag = float(round(y2[10]))
    for _ in range(3):
        slow = [i for i, v in enumerate(_slips(y2, p)) if v <= p[ix.BAND]]
        if at is not None:  # the stop event's contact: at the band (to rounding), once
            slow, at = sorted({*slow, at}), None
        if flag > 2.5:  # the sticking contact is not in question
            slow = [i for i in slow if i != round(flag) - 3]
        if not slow:
            return y2
        i = slow[0]
        if p[ix.RSTAR] > 0.0:  # Contensou: sticking anywhere is the rolling about the line
            ys = _stop_pair(y2, p)
            ys[10] = 5.0
            d = _roll_split(ys, p)
            if min(d[0], d[1]) >= 0.0 and d[8] <= 1.0:
                return ys
        if len(slow) == 2 and p[ix.RSTAR] == 0.0:  # both at rest: both sticking first
            sol = both_stick_forces(y2, p, (True, True))
            if min(sol["lam"]) >= 0.0 and min(sol["margin"]) >= 0.0:
                y2 = _stop_pair(y2, p)
                y2[10] = 5.0
                return y2
        stuck = (i == 0 or flag == 3.0, i == 1 or flag == 4.0)
        sol = both_stick_forces(y2, p, stuck)
        if min(sol["lam"]) >= 0.0 and all(sol["margin"][j] >= 0.0 for j in range(2) if stuck[j]):
            if p[ix.RSTAR] > 0.0:
                raise JumpFailed(
                    f"the {('ball', 'stem')[i]} contact of the double contact could stick with "
                    "the other sliding, but under Coulomb–Contensou friction sticking needs "
                    "ω_z = 0, which stops both contacts, and both sticking is not admissible "
                    "(a normal force < 0 or no split of the forces in both cones): no "
                    "consistent mode"
                )
            if all(stuck):  # both at rest: the body rolls about the contact line
                y2 = _stop_pair(y2, p)
                y2[10] = 5.0
                return y2
            y2 = _restart_both(y2, p, i, np.zeros(3), 0.0)
            y2[10] = flag = 3.0 + i
            continue  # the other contact's slip may be within the band too
        Ft = sol["Ft"][i]
        if p[ix.RSTAR] > 0.0:  # Contensou: opposite the force sticking needs (the cone's edge)
            u = -Ft / np.linalg.norm(Ft)
        else:
            u = _excess_both(y2, p, i) if flag == 2.0 else -Ft[:2] / np.linalg.norm(Ft[:2])
            if u is None:
                raise JumpFailed(
                    f"the {('ball', 'stem')[i]} contact of the double contact can neither stick "
                    "(its force outside the cone or a normal force < 0) nor slide (no direction "
                    "in which its slip grows): a Painlevé-type inconsistency of the dry law"
                )
        y2 = _restart_both(y2, p, i, u)
    return y2


def _both_stop(y: np.ndarray, p: tuple) -> np.ndarray:
    """A slip of the double contact reaches the band: the mode selection of :func:`_settle_both`."""
    y2 = on_both(y, _viscous(p))
    y2[10] = y[10]
    slips = _slips(y2, p)
    if y2[10] > 2.5:  # the sliding contact's stop
        at = 4 - round(float(y2[10]))
    else:
        at = 0 if slips[0] <= slips[1] else 1
    return _settle_both(y2, p, at)


def _both_near(i: int) -> Any:
    """The jump of contact ``i``'s near-stop event: the mode selection of :func:`_settle_both` at
    that contact, its slip (below k δ) treated as at the band: stopped where sticking is
    admissible, else restarted (2δ) along the excess force."""

    def jump(y: np.ndarray, p: tuple) -> np.ndarray:
        y2 = on_both(y, _viscous(p))
        y2[10] = y[10]
        return _settle_both(y2, p, i)

    jump.__name__ = f"_both_{('ball', 'stem')[i]}_near_jump"
    return jump


def _both_cone(y: np.ndarray, p: tuple) -> np.ndarray:
    """The sticking contact's force reaches its cone: its slip starts (2δ) opposite to the
    tangential force sticking needs, both contacts sliding (flag 2)."""
    y2 = on_both(y, _viscous(p))
    i = round(float(y[10])) - 3
    y2[10] = y[10]
    F = both_stick_forces(y2, p, (i == 0, i == 1))["Ft"][i]
    y2[10] = 2.0
    u = _excess_both(y2, p, i)  # where the slip grows (−F/|F| exactly at the cone's edge)
    return _restart_both(y2, p, i, -F[:2] / np.linalg.norm(F[:2]) if u is None else u)


def _roll_cone(which: int) -> Any:
    """The jump where both contacts stick and a cone condition of :func:`_roll_margins` fails:
    0 (1), the ball's (stem's) force across the line: that contact's slip starts (2δ) across
    the line opposite to it, the other keeps sticking (flag 4, 3); 2, no split along the line
    fits: both slip together along the line (ν_2 − ν_1 ⊥ d̂ forces equal slips along it),
    opposite to the total T (flag 2)."""

    def jump(y: np.ndarray, p: tuple) -> np.ndarray:
        y2 = on_both(y, _viscous(p))
        y2[10] = 5.0
        _, _, _, P1, P2, T = _roll_both(y2, p)
        e = y2[7:10] / np.linalg.norm(y2[7:10])
        d = np.array([e[0], e[1]]) / math.hypot(e[0], e[1])
        n = np.array([-d[1], d[0]])
        band = 2.0 * p[ix.BAND]
        if which == 2 and p[ix.RSTAR] > 0.0:
            return _drill_restart(y2, p)
        if which == 2:
            u = -math.copysign(1.0, T) * d
            out = _stop_pair(y2, p, np.concatenate((band * u, band * u)))
            out[10] = 2.0
            return out
        P = (P1, P2)[which]
        u = -math.copysign(1.0, P) * n
        t = np.zeros(4)
        t[2 * which : 2 * which + 2] = band * u
        out = _stop_pair(y2, p, t)
        out[10] = 4.0 - which
        return out

    jump.__name__ = f"_roll_cone_{which}"
    return jump


def _drill_restart(y2: np.ndarray, p: tuple) -> np.ndarray:
    """Both contacts sticking under Coulomb–Contensou at the edge of admissibility (s = 1 in
    :func:`_drill_split`): both start to slide (flag 2) with the slip pair γ_i ∝ −A_iᵀ w of the
    minimax split, each opposite its contact's force there (so the sliding law's forces at
    that instant are the sticking ones), the larger slip 2δ; set at that contact by
    :func:`_restart_both` (both normal velocities 0), the other follows from the kinematics
    (γ_2 − γ_1 = (|d| ω_z n̂, 0))."""
    d = _roll_split(y2, p)
    w0, w1, w2 = d[9], d[10], d[11]
    e = y2[7:10] / np.linalg.norm(y2[7:10])
    dh = np.array([e[0], e[1]]) / math.hypot(e[0], e[1])
    nh = np.array([-dh[1], dh[0]])
    st = math.hypot(e[0], e[1])
    slips = []
    for li in (p[ix.L], p[ix.L] + p[ix.DRY_L_S]):  # −A_iᵀ w in the world frame
        a, b = -w0, -(w1 + li * st * w2)
        slips.append(np.array([a * dh[0] + b * nh[0], a * dh[1] + b * nh[1], -p[ix.RSTAR] * w2]))
    n = [float(np.linalg.norm(g)) for g in slips]
    i = 0 if n[0] >= n[1] else 1
    if not n[i] > 0.0:
        raise JumpFailed(
            "both contacts stick under Coulomb–Contensou and leave the cone without a force "
            "to slide against: the run ends there"
        )
    out = _restart_both(y2, p, i, slips[i] / n[i])
    out[10] = 2.0
    return out


def _select(y: np.ndarray, p: tuple) -> str:
    """The phase after a jump: the contact by the flag, rolling if its slip was settled."""
    if y[10] > 1.5:
        return BOTH_FLAGS[float(round(y[10]))]
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
    for value in (3, 4):  # one contact sticking: its force from the constraint, its margin
        mask = flag == value
        if mask.any():
            Ym = Y[:, mask]
            with np.errstate(divide="ignore", invalid="ignore"):
                d = _stick_both(Ym, p, float(value - 3))
            kin = both_kinematics(
                Ym, p[ix.R], p[ix.L], p[ix.I1], p[ix.I3], p[ix.DRY_R_S], p[ix.DRY_L_S]
            )
            ks = 4 - value  # the sliding contact: −μ λ_k ν̂_k
            nu = np.asarray(kin[3 + ks], dtype=float)
            lam = (np.asarray(d[1], dtype=float), np.asarray(d[2], dtype=float))
            fk = -p[ix.MU] * lam[ks] / np.hypot(nu[0], nu[1])
            out["gn_ball"][mask], out["gn_stem"][mask] = lam
            out["gn"][mask] = lam[0] + lam[1]
            out["F_x"][mask] = d[3][0] + fk * nu[0]
            out["F_y"][mask] = d[3][1] + fk * nu[1]
            out["margin"][mask] = p[ix.MU] * d[3][2] - np.hypot(d[3][0], d[3][1])
    roll = flag == 5
    if roll.any():  # both sticking: the normal forces, the total tangential force, the margin
        Yr = Y[:, roll]
        with np.errstate(divide="ignore", invalid="ignore"):
            _, l1, l2, P1, P2, T = _roll_both(Yr, p)
            m3 = _roll_margins(Yr, p)
        e = Yr[7:10] / np.linalg.norm(Yr[7:10], axis=0)
        hd = np.hypot(e[0], e[1])
        dx, dy = e[0] / hd, e[1] / hd
        out["gn_ball"][roll], out["gn_stem"][roll] = l1, l2
        out["gn"][roll] = l1 + l2
        out["F_x"][roll] = T * dx - (P1 + P2) * dy
        out["F_y"][roll] = T * dy + (P1 + P2) * dx
        out["margin"][roll] = np.minimum(np.minimum(m3[0], m3[1]), m3[2])
        if p[ix.RSTAR] > 0.0:  # the drilling torques of the split, its margin μ m g (1 − s)
            split = np.array([_roll_split(Yr[:, j], p) for j in range(Yr.shape[1])]).T
            out["M_n"][roll] = p[ix.RSTAR] * (split[4] + split[7])
            out["margin"][roll] = p[ix.MU] * (split[0] + split[1]) * (1.0 - split[8])
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
    contact = np.array([n.split("-", 1)[0] for n in names.tolist()], dtype=object).astype(str)
    phase = np.array([n.split("-", 1)[1] for n in names.tolist()], dtype=object).astype(str)
    series = {"contact": contact, "phase": phase}
    series.update(_quantities(traj.states, p, phase == "rolling"))
    records = []
    seen: list[tuple[float, str, str]] = []
    for (t, before, after), (y_ev, _) in zip(traj.switches, traj.jumps, strict=True):
        c0, f0 = before.split("-", 1)
        c1, f1 = after.split("-", 1)
        margin, speed, t_sw, t_event = math.nan, math.nan, t, t
        if c0 == "both" and c1 == "both":  # a mode of the double contact changes
            n0, n1 = _STUCK[f0], _STUCK[f1]  # sticking contacts before and after
            why = "stop" if n1 > n0 else "cone" if n1 < n0 else "reversal"
        elif c0 == "both":
            why = _LIFT_REASONS[c1]
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
_STUCK = {"sliding": 0, "ball-rolling": 1, "stem-rolling": 1, "rolling": 2}


PHASES = (
    "ball-sliding",
    "ball-rolling",
    "stem-sliding",
    "stem-rolling",
    "both-sliding",
    "both-ball-rolling",
    "both-stem-rolling",
    "both-rolling",
)

_TOUCHDOWN = Event(
    _touchdown,
    -1.0,
    "switch",
    target="stem-sliding",
    jump=_impact_to("stem"),
    select=_select,
    history=True,
)


def _both_switch(fn: Any, target: str, jump: Any, grazing: bool = False) -> Event:
    """A switch out of a double-contact phase (lift-off, stop, cone): the phase after the jump is
    picked by :func:`_select` from the state it leaves."""
    return Event(fn, -1.0, "switch", target=target, jump=jump, select=_select, grazing=grazing)


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
            Event(_ball_sliding_contact, -1.0, "contact_lost", grazing=True),
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
                    Event(_ball_rolling_contact, -1.0, "contact_lost", grazing=True),
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
                    Event(_stem_sliding_contact, -1.0, "contact_lost", grazing=True),
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
                    Event(_stem_rolling_contact, -1.0, "contact_lost", grazing=True),
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
                    _both_switch(_both_ball_lift, "stem-sliding", _ball_lifts),
                    _both_switch(_both_stem_lift, "ball-sliding", _stem_lifts),
                    _both_switch(_both_ball_stop, "both-sliding", _both_stop),
                    _both_switch(_both_stem_stop, "both-sliding", _both_stop),
                    _both_switch(_both_ball_near, "both-sliding", _both_near(0)),
                    _both_switch(_both_stem_near, "both-sliding", _both_near(1)),
                ),
            ),
            Phase(
                "both-ball-rolling",
                _python(_ball_stick_into),
                _ball_stick_into,
                (
                    Event(_bs_contact, -1.0, "contact_lost"),
                    _both_switch(_bs_ball_lift, "stem-sliding", _ball_lifts),
                    _both_switch(_bs_stem_lift, "ball-rolling", _stem_lifts),
                    _both_switch(_bs_cone, "both-sliding", _both_cone, grazing=True),
                    _both_switch(_bs_stop, "both-ball-rolling", _both_stop),
                ),
            ),
            Phase(
                "both-stem-rolling",
                _python(_stem_stick_into),
                _stem_stick_into,
                (
                    Event(_ss_contact, -1.0, "contact_lost"),
                    _both_switch(_ss_ball_lift, "stem-rolling", _ball_lifts),
                    _both_switch(_ss_stem_lift, "ball-sliding", _stem_lifts),
                    _both_switch(_ss_cone, "both-sliding", _both_cone, grazing=True),
                    _both_switch(_ss_stop, "both-stem-rolling", _both_stop),
                ),
            ),
            Phase(
                "both-rolling",
                _python(_both_rolling_into),
                _both_rolling_into,
                (
                    Event(_br_contact, -1.0, "contact_lost"),
                    _both_switch(_br_ball_lift, "stem-rolling", _ball_lifts),
                    _both_switch(_br_stem_lift, "ball-rolling", _stem_lifts),
                    _both_switch(_br_ball_cone, "both-stem-rolling", _roll_cone(0), grazing=True),
                    _both_switch(_br_stem_cone, "both-ball-rolling", _roll_cone(1), grazing=True),
                    _both_switch(_br_line_cone, "both-sliding", _roll_cone(2), grazing=True),
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
