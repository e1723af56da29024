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
  removes the remaining O(δ) of slip by the contact impulse P with G P = −v_A (:func:`_set_slip`;
  it keeps λ exactly and changes E by −½ v_A·G⁻¹v_A ≤ 0). The slip falls linearly at a finite
  rate there, so the stop itself, recorded as the switch time, is extrapolated δ/a beyond the
  band crossing (:func:`stop_time`); the impulse matches the sliding up to it to O(δ²).
* sliding → sliding ("reversal") when |γ| falls through δ with the required force outside the
  cone: the ``jump`` removes the slip as above and restarts it with |v_A| = 2δ in the direction u
  of the excess force, the solution of s u = v̇_A(u), s > 0 (slip acceleration parallel to the
  slip under the Coulomb force −μ g_n u; a root search, :func:`_excess_direction`, in plain
  Python: jumps run between phases). The cone decides between "stop" and "reversal" inside the
  two event functions (:func:`_stop_event`, :func:`_reversal_event`): each is |γ| − δ plus a
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
(:func:`_frictionless`), the same motion as the "gliding" model with μ = 0.

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
from scipy.optimize import brentq

from ..friction import Coulomb, RegularisedCoulomb
from . import gliding
from .registry import Event, Model, Option, Phase, friction_law, register

__all__ = [
    "CONTENSOU",
    "MODEL",
    "PHASES",
    "REGULARISED",
    "Switch",
    "cone_event",
    "cone_jump",
    "contact_quantities",
    "from_gliding",
    "required",
    "reversal_event",
    "reversal_jump",
    "rolling_contact",
    "rolling_guess",
    "set_slip",
    "settle",
    "slide_law",
    "slide_rhs",
    "sliding_contact",
    "slip",
    "start_phase",
    "stick",
    "stick_rhs",
    "stop_event",
    "stop_jump",
    "stop_time",
    "stopping_band",
    "to_gliding",
]

PHASES = ("sliding", "rolling")

# law codes of the parameter tuple p = (m, R, l, I1, I3, g, mu, r_star, eps, law, delta)
_COULOMB, _REGULARISED = 0.0, 1.0

_CONE_SIDE = 1e6
"""Weight of the cone term in the stop/reversal events (dimensionless): a margin of −1e-6 m g
delays a "stop" by one band δ, so at the band crossing the event of the cone's side fires first."""


# --- the contact mechanics, plain float arithmetic (floats or equal-shape arrays) -------------


def _kinematics(y: Any, p: tuple) -> tuple:
    """(3̂, ω, 3̂̇, a, v_A (horizontal), h, c) of state(s) ``y``; see the module docstring."""
    m, R, l, I1, I3, g = p[:6]
    n = (y[7] * y[7] + y[8] * y[8] + y[9] * y[9]) ** 0.5
    ex, ey, ez = y[7] / n, y[8] / n, y[9] / n
    ax, ay, az = l * ex, l * ey, l * ez - R
    Lx, Ly = y[4], y[5]
    Lz = -(y[6] + Lx * ax + Ly * ay) / az  # from λ = −L·a
    c = 1.0 / I3 - 1.0 / I1
    Le = Lx * ex + Ly * ey + Lz * ez
    wx, wy, wz = Lx / I1 + c * Le * ex, Ly / I1 + c * Le * ey, Lz / I1 + c * Le * ez
    dex, dey, dez = wy * ez - wz * ey, wz * ex - wx * ez, wx * ey - wy * ex
    nux = y[2] + (wy * az - wz * ay)
    nuy = y[3] + (wz * ax - wx * az)
    # h = −g ẑ + W0 × a + ω × ȧ, W0 = c (L·3̂) 3̂̇, ȧ = l 3̂̇
    W0x, W0y, W0z = c * Le * dex, c * Le * dey, c * Le * dez
    adx, ady, adz = l * dex, l * dey, l * dez
    hx = (W0y * az - W0z * ay) + (wy * adz - wz * ady)
    hy = (W0z * ax - W0x * az) + (wz * adx - wx * adz)
    hz = -g + (W0x * ay - W0y * ax) + (wx * ady - wy * adx)
    return (ex, ey, ez), (wx, wy, wz), (dex, dey, dez), (ax, ay, az), (nux, nuy), (hx, hy, hz), c


def _G(F: tuple, e: tuple, a: tuple, m: float, I1: float, c: float) -> tuple:
    """G F = F/m + (J⁻¹(a × F)) × a."""
    Fx, Fy, Fz = F
    ax, ay, az = a
    tx, ty, tz = ay * Fz - az * Fy, az * Fx - ax * Fz, ax * Fy - ay * Fx
    te = tx * e[0] + ty * e[1] + tz * e[2]
    jx, jy, jz = tx / I1 + c * te * e[0], ty / I1 + c * te * e[1], tz / I1 + c * te * e[2]
    return (
        Fx / m + (jy * az - jz * ay),
        Fy / m + (jz * ax - jx * az),
        Fz / m + (jx * ay - jy * ax),
    )


def _spin_term(e: tuple, a: tuple, I1: float, c: float) -> tuple:
    """(J⁻¹ẑ) × a: the contact acceleration per unit torque about ẑ."""
    jx, jy, jz = c * e[2] * e[0], c * e[2] * e[1], 1.0 / I1 + c * e[2] * e[2]
    ax, ay, az = a
    return (jy * az - jz * ay, jz * ax - jx * az, jx * ay - jy * ax)


def _derivatives(y: Any, p: tuple, F: tuple, M: Any, w: tuple, de: tuple, a: tuple) -> tuple:
    m = p[0]
    Fx, Fy, Fz = F
    ax, ay, az = a
    return (
        y[2],
        y[3],
        Fx / m,
        Fy / m,
        ay * Fz - az * Fy,
        az * Fx - ax * Fz,
        -M * az,  # dλ/dt = −(a × F + M ẑ)·a − L·ȧ = −M a_z (L·ȧ = 0, module docstring)
        de[0],
        de[1],
        de[2],
    )


def _slide(y: Any, p: tuple, fx: Any, fy: Any, fm: Any, kin: tuple | None = None) -> tuple:
    """Sliding with the force per unit normal force (fx, fy, 1) and torque fm ẑ per unit g_n.

    Returns (derivatives, g_n, F, M, v̇_A). ``kin``: :func:`_kinematics` of ``y`` if known.
    """
    m, R, l, I1, I3, g = p[:6]
    e, w, de, a, nu, h, c = _kinematics(y, p) if kin is None else kin
    Gf = _G((fx, fy, 1.0), e, a, m, I1, c)
    s = _spin_term(e, a, I1, c)
    gn = -h[2] / (Gf[2] + fm * s[2])
    F = (gn * fx, gn * fy, gn)
    M = gn * fm
    vdot = (
        gn * (Gf[0] + fm * s[0]) + h[0],
        gn * (Gf[1] + fm * s[1]) + h[1],
        gn * (Gf[2] + fm * s[2]) + h[2],
    )
    return _derivatives(y, p, F, M, w, de, a), gn, F, M, vdot


def _law(y: Any, p: tuple, kin: tuple | None = None) -> tuple:
    """(fx, fy, fm): the sliding law per unit normal force at state(s) ``y``."""
    mu, rs, eps, law = p[6], p[7], p[8], p[9]
    e, w, de, a, nu, h, c = _kinematics(y, p) if kin is None else kin
    if mu == 0.0:  # frictionless: no force, also at zero slip (where −μ v̂_A would be 0/0)
        zero = 0.0 * nu[0]
        return zero, zero, zero
    if law == _REGULARISED:
        k = -mu / (nu[0] * nu[0] + nu[1] * nu[1] + eps * eps) ** 0.5
        return k * nu[0], k * nu[1], 0.0 * k
    k = -mu / (nu[0] * nu[0] + nu[1] * nu[1] + (rs * w[2]) ** 2) ** 0.5
    return k * nu[0], k * nu[1], k * rs * rs * w[2]


def _spin_rate(F: tuple, e: tuple, a: tuple, I1: Any, c: Any) -> Any:
    """(J⁻¹(a × F))_z: the spin acceleration about ẑ per unit contact force."""
    tx, ty, tz = a[1] * F[2] - a[2] * F[1], a[2] * F[0] - a[0] * F[2], a[0] * F[1] - a[1] * F[0]
    return tz / I1 + c * (tx * e[0] + ty * e[1] + tz * e[2]) * e[2]


def _solve_G(y: Any, p: tuple, b: tuple, kin: tuple | None = None) -> tuple:
    """The force F with G F = b at state(s) ``y`` (3×3, Cramer's rule), and the kinematics."""
    m, R, l, I1, I3, g = p[:6]
    kin = _kinematics(y, p) if kin is None else kin
    e, a, c = kin[0], kin[3], kin[6]
    m11, m21, m31 = _G((1.0, 0.0, 0.0), e, a, m, I1, c)
    m12, m22, m32 = _G((0.0, 1.0, 0.0), e, a, m, I1, c)
    m13, m23, m33 = _G((0.0, 0.0, 1.0), e, a, m, I1, c)
    bx, by, bz = b
    c1 = m22 * m33 - m23 * m32
    c2 = m21 * m33 - m23 * m31
    c3 = m21 * m32 - m22 * m31
    det = m11 * c1 - m12 * c2 + m13 * c3
    Fx = (bx * c1 - m12 * (by * m33 - m23 * bz) + m13 * (by * m32 - m22 * bz)) / det
    Fy = (m11 * (by * m33 - m23 * bz) - bx * c2 + m13 * (m21 * bz - by * m31)) / det
    Fz = (m11 * (m22 * bz - by * m32) - m12 * (m21 * bz - by * m31) + bx * c3) / det
    return (Fx, Fy, Fz), kin


def _solve_GM(y: Any, p: tuple, b: tuple, bz: Any, kin: tuple) -> tuple:
    """(F, M) with G F + M (J⁻¹ẑ) × a = b and (J⁻¹(a × F + M ẑ))_z = bz (Contensou stick).

    Eliminating F = G⁻¹b − M G⁻¹((J⁻¹ẑ) × a) leaves one equation for M (a Schur complement of
    the positive definite contact matrix of force and drilling torque).
    """
    I1 = p[3]
    e, a, c = kin[0], kin[3], kin[6]
    s = _spin_term(e, a, I1, c)
    F0 = _solve_G(y, p, b, kin)[0]
    q = _solve_G(y, p, s, kin)[0]

    jz = 1.0 / I1 + c * e[2] * e[2]
    M = (bz - _spin_rate(F0, e, a, I1, c)) / (jz - _spin_rate(q, e, a, I1, c))
    return (F0[0] - M * q[0], F0[1] - M * q[1], F0[2] - M * q[2]), M


def _stick(y: Any, p: tuple) -> tuple:
    """Rolling: the contact force from G F = −h. Returns like :func:`_slide`.

    With Contensou friction (r* > 0) stick also holds the spin about the normal, ω̇_z = 0, with
    the drilling torque M the constraint needs.
    """
    kin = _kinematics(y, p)
    e, w, de, a, nu, h, c = kin
    if p[7] > 0.0:
        # W0_z = c (L·3̂) 3̂̇_z with L·3̂ = I3 ω·3̂
        W0z = c * p[4] * (w[0] * e[0] + w[1] * e[1] + w[2] * e[2]) * de[2]
        F, M = _solve_GM(y, p, (-h[0], -h[1], -h[2]), -W0z, kin)
    else:
        F = _solve_G(y, p, (-h[0], -h[1], -h[2]), kin)[0]
        M = 0.0 * F[2]
    zero = 0.0 * F[2]
    return _derivatives(y, p, F, M, w, de, a), F[2], F, M, (zero, zero, zero)


def _required(y: Any, p: tuple) -> tuple:
    """(g_n, generalised force (F_x, F_y, M/r*), cone margin μ g_n − |·|) that stick needs."""
    _, gn, F, M, _ = _stick(y, p)
    rs = p[7]
    fm = M / rs if rs > 0.0 else 0.0 * M
    return gn, (F[0], F[1], fm), p[6] * gn - (F[0] ** 2 + F[1] ** 2 + fm**2) ** 0.5


def _slip_speed(y: Any, p: Any) -> Any:
    """|γ| = √(|v_A|² + (r* ω_z)²) (m/s), plain arithmetic."""
    kin = _kinematics(y, p)
    nu, w = kin[4], kin[1]
    rs = p[7]
    return (nu[0] * nu[0] + nu[1] * nu[1] + (rs * w[2]) * (rs * w[2])) ** 0.5


def _margin(y: Any, p: Any) -> Any:
    """Cone margin of the force rolling needs, (μ g_n − |(F_t, M/r*)|)/(m g), plain arithmetic."""
    return _required(y, p)[2] * (1.0 / (p[0] * p[5]))


# --- the phases: right-hand sides and events (compiled from this source) -----------------------


def slide_rhs(t: float, y: np.ndarray, p: tuple) -> np.ndarray:
    """Right-hand side of the sliding phase (Coulomb or Coulomb–Contensou).

    Parameters
    ----------
    t : float
        Time (s); autonomous.
    y : ndarray, shape (10,)
        Gliding state (:func:`mett.dynamics.gliding_rhs`).
    p : tuple
        ``(m, R, l, I1, I3, g, mu, r_star, eps, law, delta)``: body, friction coefficient (–),
        effective Contensou radius (m), regularisation velocity (m/s), law code (0 Coulomb,
        1 regularised) and stopping band (m/s).
    """
    if np.ndim(y) == 1:
        y = y.tolist()  # Python floats: scalar arithmetic several times faster than numpy's
    return np.array(_slide_law(y, p)[0])


def _slide_law(y: Any, p: Any) -> tuple:
    kin = _kinematics(y, p)
    f = _law(y, p, kin)
    return _slide(y, p, f[0], f[1], f[2], kin)


def _slide_into(t: float, y: Any, p: Any, out: Any) -> None:
    """:func:`slide_rhs` written into ``out`` (the source of the compiled twin)."""
    d = _slide_law(y, p)[0]
    out[0], out[1], out[2], out[3], out[4] = d[0], d[1], d[2], d[3], d[4]
    out[5], out[6], out[7], out[8], out[9] = d[5], d[6], d[7], d[8], d[9]


def stick_rhs(t: float, y: np.ndarray, p: tuple) -> np.ndarray:
    """Right-hand side of the rolling (stick) phase: v̇_A = 0, force from the constraint.

    Same state and parameters as :func:`slide_rhs`; equal to :func:`mett.dynamics.rolling_rhs` in
    the rolling model's variables.
    """
    if np.ndim(y) == 1:
        y = y.tolist()
    return np.array(_stick(y, p)[0])


def _stick_into(t: float, y: Any, p: Any, out: Any) -> None:
    """:func:`stick_rhs` written into ``out``."""
    d = _stick(y, p)[0]
    out[0], out[1], out[2], out[3], out[4] = d[0], d[1], d[2], d[3], d[4]
    out[5], out[6], out[7], out[8], out[9] = d[5], d[6], d[7], d[8], d[9]


def _contact_sliding(t: float, y: Any, p: Any) -> Any:
    """g_n/(m g) while sliding: contact lost when it falls through 0."""
    return _slide_law(y, p)[1] * (1.0 / (p[0] * p[5]))


def _contact_rolling(t: float, y: Any, p: Any) -> Any:
    """g_n/(m g) while rolling."""
    return _stick(y, p)[1] * (1.0 / (p[0] * p[5]))


def _positive_part(x: Any) -> Any:
    """max(x, 0) as plain arithmetic, (x + √(x²))/2: no branch on a state value."""
    return 0.5 * (x + (x * x) ** 0.5)


def _stop_event(t: float, y: Any, p: Any) -> Any:
    """|γ| − δ, kept positive while the required force is outside the cone: "stop" → rolling."""
    if p[6] == 0.0:  # μ = 0: a cone of radius 0, no stop (see _frictionless)
        return 1.0 + 0.0 * y[0]  # never 0 (a constant: no series of |γ| near 0)
    return _slip_speed(y, p) - p[10] + p[10] * _CONE_SIDE * _positive_part(-_margin(y, p))


def _reversal_event(t: float, y: Any, p: Any) -> Any:
    """|γ| − δ, kept positive while the required force is inside the cone: "reversal"."""
    if p[6] == 0.0:  # μ = 0: no friction to reverse the slip (see _frictionless)
        return 1.0 + 0.0 * y[0]  # never 0 (a constant: no series of |γ| near 0)
    return _slip_speed(y, p) - p[10] + p[10] * _CONE_SIDE * _positive_part(_margin(y, p))


def _cone_event(t: float, y: Any, p: Any) -> Any:
    """The cone margin of rolling: "cone" → sliding when it falls through 0."""
    return _margin(y, p)


# --- the jumps at the switches (plain Python, between phases) ---------------------------------


def _nu(y: np.ndarray, p: tuple) -> np.ndarray:
    k = _kinematics(y, p)
    return np.array(k[4])


def _slip(y: np.ndarray, p: tuple) -> np.ndarray:
    """The generalised slip γ = (v_A, r* ω_z) (m/s); r* = 0 for Coulomb."""
    k = _kinematics(y, p)
    return np.array([k[4][0], k[4][1], p[7] * k[1][2]])


def _excess_direction(y: np.ndarray, p: tuple, fallback: np.ndarray) -> np.ndarray:
    """Unit u with v̇_A(u) = s u, s > 0, under the sliding force −μ g_n u (slip start at v_A = 0).

    Scans the angle of u and refines the sign changes of (u × v̇_A(u))_z by Brent's method; among
    the solutions with s > 0 the one of largest s. ``fallback`` if there is none (stick feasible).
    Returned as the generalised direction (u_x, u_y, 0). With Contensou friction, the direction
    opposite to the generalised force stick needs (``fallback``; exact at the cone's edge).
    """
    mu = p[6]
    if p[7] > 0.0:
        return np.asarray(fallback, dtype=float) / np.linalg.norm(fallback)

    def vdot(phi: float) -> tuple[float, float, float]:
        ux, uy = math.cos(phi), math.sin(phi)
        v = _slide(y, p, -mu * ux, -mu * uy, 0.0)[4]
        return ux * v[1] - uy * v[0], ux * v[0] + uy * v[1], 0.0

    grid = np.linspace(0.0, 2.0 * math.pi, 73)
    cr = np.array([vdot(ph)[0] for ph in grid])
    best, best_s = None, 0.0
    sign = np.sign(cr)  # not cr[:-1] * cr[1:]: that product underflows to 0 near a pole
    for i in np.flatnonzero(sign[:-1] * sign[1:] <= 0.0):
        if cr[i] == 0.0:
            phi = grid[i]
        elif cr[i + 1] == 0.0:
            continue
        else:
            phi = brentq(lambda ph: vdot(ph)[0], grid[i], grid[i + 1], xtol=1e-15)
        s = vdot(phi)[1]
        if s > best_s:
            best, best_s = phi, s
    if best is None:
        return np.asarray(fallback, dtype=float) / np.linalg.norm(fallback)
    return np.array([math.cos(best), math.sin(best), 0.0])


def _set_slip(y: np.ndarray, p: tuple, target: np.ndarray) -> np.ndarray:
    """``y`` after the contact impulse P that changes γ to ``target`` (G P = Δv_A, vertical 0).

    ``target`` is the generalised slip (v_A, r* ω_z); with Contensou friction an angular impulse
    Q ẑ about the normal at A changes ω_z too (it changes λ by −Q (ẑ·a), as the torque would).

    An impulse at A: Δṙ = P/m, ΔL = a × P. It keeps λ = −L·a (exactly, (a × P)·a = 0) and changes
    the energy by Δv_A·G⁻¹(v_A + target)/2 — for target 0 by −½ v_A·G⁻¹v_A ≤ 0 (a plastic tangential
    impact: the last O(δ) of slip is removed dissipatively, as the sliding it replaces would).
    """
    d = np.asarray(target, dtype=float) - _slip(y, p)
    kin = _kinematics(y, p)
    if p[7] > 0.0:  # and the angular impulse Q ẑ that changes ω_z by d[2]/r*
        P, Q = _solve_GM(y, p, (d[0], d[1], 0.0), d[2] / p[7], kin)
    else:
        P, Q = _solve_G(y, p, (d[0], d[1], 0.0), kin)[0], 0.0
    a = kin[3]
    out = np.array(y, dtype=float)
    out[2] += P[0] / p[0]
    out[3] += P[1] / p[0]
    out[4] += a[1] * P[2] - a[2] * P[1]
    out[5] += a[2] * P[0] - a[0] * P[2]
    out[6] -= Q * a[2]  # Δλ = −(a × P + Q ẑ)·a = −Q a_z: the impulse P keeps λ exactly
    return out


def _slip_rate(y: np.ndarray, p: tuple) -> float:
    """a = −d|γ|/dt (m/s²) of the sliding law at ``y``: the rate at which the slip falls.

    Coulomb: −γ̂·v̇_A of :func:`_slide`, exactly. With Contensou's r* the spin part r* ω̇_z is the
    central difference of r* ω_z along the sliding rates over a step that moves γ by 1e-3 |γ|
    (γ is smooth in the state, and along a straight line in state space linear to O(h²)).
    """
    y = np.asarray(y, dtype=float)
    g = _slip(y, p)
    speed = float(np.linalg.norm(g))
    d, _, _, _, vdot = _slide_law(y.tolist(), p)
    rate = np.array([vdot[0], vdot[1], 0.0])
    if p[7] > 0.0:
        h = 1e-3 * speed / max(math.hypot(vdot[0], vdot[1]), p[6] * p[5])
        step = np.zeros_like(y)
        step[:10] = h * np.asarray(d)
        rate[2] = (_slip(y + step, p)[2] - _slip(y - step, p)[2]) / (2.0 * h)
    return float(-(g @ rate) / speed) if speed > 0.0 else math.nan


def stop_time(t: float, y: np.ndarray, p: tuple) -> float:
    """The instant the slip reaches 0, extrapolated from the band crossing ``(t, y)``.

    Under Coulomb friction the slip falls to 0 in finite time at a finite rate a = −d|γ|/dt
    (:func:`_slip_rate`; μ g_n times the contact's inverse effective mass along the slip, less
    the pull of the required force), so |γ| is linear in t near the stop and the stop is at
    t + |γ|/a, to O(|γ|²): the band crossing precedes it by |γ|/a = δ/a. The state needs no
    advancing: the stopping impulse at the band equals the integral of the friction force
    beyond the required one up to the stop (both bring v_A from γ to 0 through the same G), so
    the rolling state after it is that of the exact stop to O(δ²). ``t`` if a ≤ 0 (no finite
    extrapolation).
    """
    speed = float(np.linalg.norm(_slip(y, p)))
    a = _slip_rate(y, p)
    return t + speed / a if a > 0.0 else t


def _stop_jump(y: np.ndarray, p: tuple) -> np.ndarray:
    """Sliding → rolling: the contact impulse that removes the last slip (|γ| = δ → 0)."""
    return _set_slip(y, p, np.zeros(3))


def _restart(y: np.ndarray, p: tuple) -> np.ndarray:
    """Slip restarted with |γ| = 2δ in the excess-force direction (from v_A = 0)."""
    return _set_slip(y, p, 2.0 * p[10] * _excess_direction(y, p, -np.array(_required(y, p)[1])))


def _reversal_jump(y: np.ndarray, p: tuple) -> np.ndarray:
    """Sliding → sliding at the band, outside the cone: stop, then restart along the excess force."""
    return _restart(_set_slip(y, p, np.zeros(3)), p)


def _cone_jump(y: np.ndarray, p: tuple) -> np.ndarray:
    """Rolling → sliding: the slip starts along the excess-force direction."""
    return _restart(y, p)


# --- conversions and the trajectory's contact series -------------------------------------------


def _gliding_params(p: tuple) -> tuple:
    """The "gliding" model's (m, R, l, I1, I3, mu, g) with μ = 0 (its conversions only)."""
    return (p[0], p[1], p[2], p[3], p[4], 0.0, p[5])


def _a(Y: np.ndarray, p: tuple) -> tuple:
    """a = l 3̂ − R ẑ of state(s) ``Y`` (3̂ normalised), as in :func:`_kinematics`."""
    R, l = p[1], p[2]
    n = np.sqrt(Y[7] ** 2 + Y[8] ** 2 + Y[9] ** 2)
    return l * Y[7] / n, l * Y[8] / n, l * Y[9] / n - R


def from_gliding(Y: Any, p: tuple) -> np.ndarray:
    """This model's state(s) from the ``"gliding"`` model's: L_z replaced by λ = −L·a.

    Parameters
    ----------
    Y : array_like, shape (10,) or (10, k)
        Gliding states ``[x, y, ẋ, ẏ, L_x, L_y, L_z, 3̂_x, 3̂_y, 3̂_z]`` (SI units).
    p : tuple
        This model's parameters (:func:`slide_rhs`); only R and l = αR are used.
    """
    out = np.array(Y, dtype=float)
    ax, ay, az = _a(out, p)
    out[6] = -(out[4] * ax + out[5] * ay + out[6] * az)
    return out


def to_gliding(Y: Any, p: tuple) -> np.ndarray:
    """The ``"gliding"`` model's state(s) from this model's: L_z = −(λ + L_x a_x + L_y a_y)/a_z.

    The inverse of :func:`from_gliding` (to rounding); the L_z that the phases use.
    """
    out = np.array(Y, dtype=float)
    ax, ay, az = _a(out, p)
    out[6] = -(out[6] + out[4] * ax + out[5] * ay) / az
    return out


def _params(top: Any, options: dict) -> tuple:
    law = options["friction"]  # a law of the model's kind (registry.check_friction)
    band = options.get("stopping_band")
    if band is None:  # without an rtol to tie it to: 1e-9 of the velocity scale √(g R)
        band = 1e-9 * math.sqrt(top.g * top.R)
    regularised = isinstance(law, RegularisedCoulomb)
    r_star = 0.0 if regularised else law.r_star
    eps = law.eps if regularised else 0.0
    code = _REGULARISED if regularised else _COULOMB
    l = top.R * top.alpha
    return (top.m, top.R, l, top.I1, top.I3, top.g, law.mu, r_star, eps, code, band)


def _frictionless(p: tuple) -> bool:
    """μ = 0: the friction cone has radius 0, so the motion is frictionless sliding throughout.

    Rolling would need a tangential force of exactly 0; where it does (a spin exactly at a pole)
    rolling and frictionless sliding are the same motion. So no phase switch ever happens: the
    start is not settled (a stopping impulse would be a tangential impulse, which the zero cone
    cannot transmit), the run starts sliding, and the stop and reversal events never fire. The
    law itself is 0 (:func:`_law`); without this, a spin at a pole started rolling, crossed the
    zero cone at once, and its restart direction was 0/0.
    """
    return p[6] == 0.0


def settle(y: np.ndarray, p: tuple) -> np.ndarray:
    """``y`` with a slip within the stopping band settled (``y`` itself if the slip is larger).

    The stopping impulse removes the slip; if the force rolling then needs lies outside the cone,
    slip restarts with |γ| = 2δ in the excess-force direction. :func:`start_phase` of the result
    is the phase it starts. Used at the start of a run and after an impact (the stemmed top,
    :mod:`.stemslip`). ``y`` may carry components beyond the ten of the state (kept).
    """
    if _frictionless(p):
        return y
    if p[9] == _COULOMB and float(np.linalg.norm(_slip(y, p))) <= p[10]:
        y = _set_slip(y, p, np.zeros(3))
        if _required(y, p)[2] < 0.0:
            y = _restart(y, p)
    return y


def _initial(state: Any, p: tuple) -> np.ndarray:
    """The state; a slip within the band is removed (rolling) or restarted (cone)."""
    return settle(from_gliding(gliding.MODEL.initial(state, _gliding_params(p)), p), p)


def _start_phase(y0: np.ndarray, p: tuple) -> str:
    if _frictionless(p):
        return "sliding"
    return "rolling" if float(np.linalg.norm(_slip(y0, p))) <= p[10] else "sliding"


def _rolling_guess(Y: np.ndarray, p: tuple) -> np.ndarray:
    """Where the phase is not stored (dense output between samples): rolling where the slip is
    within the band and the cone holds."""
    slip = np.sqrt(np.sum(_slip(Y, p) ** 2, axis=0))
    with np.errstate(divide="ignore", invalid="ignore"):
        margin = _required(Y, p)[2]
    return (slip <= p[10]) & (margin >= 0.0) & (p[9] == _COULOMB) & (not _frictionless(p))


def _normal_force(y: np.ndarray, p: tuple) -> Any:
    """g_n (N) of state(s) ``y``: rolling's where the slip is within the band, else sliding's."""
    Y = np.asarray(y, dtype=float)
    return contact_quantities(Y.reshape(10, -1), p, _rolling_guess(Y.reshape(10, -1), p))[
        "gn"
    ].reshape(Y.shape[1:])


def _derive(Y: np.ndarray, p: tuple) -> dict[str, np.ndarray]:
    Y = np.asarray(Y, dtype=float)
    out = gliding.MODEL.derive(to_gliding(Y, p), _gliding_params(p))
    out["gn"] = _normal_force(Y, p)
    return out


def _scales(y0: np.ndarray, p: tuple) -> np.ndarray:
    sc = np.array(gliding.MODEL.scales(to_gliding(y0, p), _gliding_params(p)), dtype=float)
    sc[6] *= p[1]  # λ = −L·a: the momentum scale times R
    return sc


def contact_quantities(Y: np.ndarray, p: tuple, rolling: Any) -> dict[str, np.ndarray]:
    """g_n, F_t, M and the cone margin at states ``Y`` (shape (10, k)) in the given phases.

    ``rolling`` is a boolean per sample. The margin μ g_n − |F_t| (N) is that of the required force
    in rolling samples and of the sliding force (≈ 0 for Coulomb) in sliding ones. ``Y`` may carry
    components beyond the ten of the state (the stemmed top's contact flag).
    """
    Y = np.asarray(Y, dtype=float)
    Y = Y.reshape(Y.shape[0], -1)
    rolling = np.broadcast_to(np.asarray(rolling, dtype=bool), Y.shape[1:])
    # the sliding law at v_A = 0; the states of a run that blew up (its status says so)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        s = _slide_law(Y, p)
        r = _stick(Y, p)
    gn = np.where(rolling, r[1], s[1])
    Fx = np.where(rolling, r[2][0], s[2][0])
    Fy = np.where(rolling, r[2][1], s[2][1])
    M = np.where(rolling, r[3], s[3])
    fm = M / p[7] if p[7] > 0.0 else 0.0 * M
    return {
        "gn": gn,
        "F_x": Fx,
        "F_y": Fy,
        "M_n": M,
        "margin": p[6] * gn - np.sqrt(Fx**2 + Fy**2 + fm**2),
    }


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


def _finish(traj: Any) -> None:
    """The contact series of a finished run: force and margin of each sample's phase, switches
    as :class:`Switch` records (margin after the stopping impulse, slip at the event)."""
    p = traj.params
    rolling = np.asarray(traj.phase) == "rolling"
    cq = contact_quantities(traj.states, p, rolling)
    for name, values in cq.items():
        setattr(traj, name, values)
    traj.extra = (*traj.extra, "phase", "F_x", "F_y", "M_n", "margin")
    records = []
    for (t, before, after), (y_ev, _) in zip(traj.switches, traj.jumps, strict=True):
        why = _REASONS[(before, after)]
        # the cone decision is made at v_A = 0: after the stopping impulse, before a restart
        y_dec = y_ev if why == "cone" else _set_slip(y_ev, p, np.zeros(3))
        gn, _, m = _required(y_dec, p)
        speed = float(np.linalg.norm(_slip(y_ev, p)))
        t_sw = t if why == "cone" else stop_time(t, y_ev, p)
        margin = float(m / (p[6] * gn)) if p[6] > 0.0 else math.nan  # no cone at μ = 0
        records.append(Switch(t_sw, before, after, why, margin, speed, t))
    traj.switches = records
    traj.stopping_band = p[10]


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
        rhs_into=_slide_into,
        normal_force=_normal_force,
        params=_params,
        initial=_initial,
        derive=_derive,
        theta=gliding.MODEL.theta,
        scales=_scales,
        conserved_lengths=((7, 8, 9),),
        events=(
            Event(_contact_sliding, -1.0, "contact_lost"),
            Event(_stop_event, -1.0, "switch", target="rolling", jump=_stop_jump),
            Event(_reversal_event, -1.0, "switch", target="sliding", jump=_reversal_jump),
        ),
        options=(Option("friction", friction_law, None, "the Coulomb law"), _BAND),
        friction=(Coulomb,),
        phase="sliding",
        phases=(
            Phase(
                "rolling",
                stick_rhs,
                _stick_into,
                (
                    Event(_contact_rolling, -1.0, "contact_lost"),
                    Event(
                        _cone_event, -1.0, "switch", target="sliding", jump=_cone_jump, grazing=True
                    ),
                ),
            ),
        ),
        conserves=("lam",),
        start_phase=_start_phase,
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


def _finish_regularised(traj: Any) -> None:
    """Force series of a regularised run (one phase, "sliding")."""
    cq = contact_quantities(traj.states, traj.params, False)
    for name, values in cq.items():
        setattr(traj, name, values)
    traj.extra = (*traj.extra, "phase", "F_x", "F_y", "M_n", "margin")
    traj.switches = []


REGULARISED = register(
    Model(
        name="coulomb-regularised",
        summary="tippe top under regularised Coulomb friction μ g_n v_A/√(|v_A|² + ε²) (stiff)",
        rhs=slide_rhs,
        rhs_into=_slide_into,
        normal_force=lambda y, p: _slide_law(y, p)[1],
        params=_params,
        initial=lambda state, p: from_gliding(gliding.MODEL.initial(state, _gliding_params(p)), p),
        derive=_derive,
        theta=gliding.MODEL.theta,
        scales=_scales,
        conserved_lengths=((7, 8, 9),),
        events=(Event(_contact_sliding, -1.0, "contact_lost"),),
        options=(Option("friction", friction_law, None, "the regularised law"),),
        friction=(RegularisedCoulomb,),
        conserves=("lam",),
        finish=_finish_regularised,
    )
)
"""The regularised law (``friction=RegularisedCoulomb(...)``), one smooth stiff right-hand side."""


# --- the contact interface for other models (the stemmed top, :mod:`.stemslip`) ----------------
# Every function above takes the contact's geometry from p = (m, R, l, ...): the sphere's radius R
# and the distance l from the CM to its centre along 3̂, so the stem sphere is the same contact
# with (R, l) = (r_s, l + l_s); the state carries that contact's Jellett integral λ = −L·a in
# place of L_z (from_gliding, to_gliding with the same p). These public names are the interface;
# the equations stay above.

slide_law = _slide_law
"""(derivatives, g_n, F, M, v̇_A) of the sliding phase at state(s) ``y`` (plain arithmetic)."""
stick = _stick
"""(derivatives, g_n, F, M, v̇_A) of the rolling phase at state(s) ``y`` (plain arithmetic)."""
sliding_contact = _contact_sliding
"""Event g_n/(m g) of the sliding phase ("contact_lost")."""
rolling_contact = _contact_rolling
"""Event g_n/(m g) of the rolling phase ("contact_lost")."""
stop_event = _stop_event
"""Event sliding → rolling (|γ| at the band, the cone holding)."""
reversal_event = _reversal_event
"""Event sliding → sliding (|γ| at the band outside the cone)."""
cone_event = _cone_event
"""Event rolling → sliding (the cone margin of the required force)."""
stop_jump = _stop_jump
"""Jump of the "stop" switch: the impulse that removes the last slip."""
reversal_jump = _reversal_jump
"""Jump of the "reversal" switch: stop, then restart along the excess force."""
cone_jump = _cone_jump
"""Jump of the "cone" switch: slip restarts along the excess force."""
slip = _slip
"""The generalised slip γ = (v_A, r* ω_z) (m/s) of state(s) ``y``."""
set_slip = _set_slip
"""``y`` after the contact impulse that sets the generalised slip to ``target``."""
required = _required
"""(g_n, generalised force, cone margin (N)) that rolling needs at state(s) ``y``."""
start_phase = _start_phase
""""rolling" if the slip of ``y`` is within the band, else "sliding"."""
rolling_guess = _rolling_guess
"""Per sample of states ``Y``: rolling where the slip is within the band and the cone holds."""
