"""The dry contact of a sphere on the plane: the mechanics that the dry-friction models share.

The equations of :mod:`mett.dynamics.stickslip` (its module docstring derives them; Rutstam 2012
§2, Leine & Glocker 2003): the contact kinematics, the Delassus matrix G of the contact, the
sliding phase under a law per unit normal force (Coulomb, Coulomb–Contensou, regularised Coulomb),
the rolling (stick) phase with the force the constraint needs, the switching events and the
impulses at a switch, and the conversions between the ``"gliding"`` state (L_z) and the state
with the Jellett integral λ = −L·a in its place.

Every function takes the contact's geometry from the parameter tuple
``p = (m, R, l, I1, I3, mu, g, r_star, eps, law, delta)`` (named positions in
:mod:`._params`): the sphere's radius R and the distance
l from the centre of mass to its centre along 3̂, so the stem sphere of :mod:`.stemslip` is the
same contact with (R, l) = (r_s, l + l_s). The functions are plain float arithmetic (floats or
equal-shape arrays) where a model's compiled kernels call them (:mod:`._kernels`); a model that
adds a force or torque at the contact (:mod:`.resistance`) builds on :func:`kinematics`,
:func:`delassus` and :func:`derivatives`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
from scipy.optimize import brentq

from . import _params as ix
from .registry import kernel_call

__all__ = [
    "LAW_COULOMB",
    "LAW_REGULARISED",
    "cone_event",
    "cone_jump",
    "contact_quantities",
    "delassus",
    "derivatives",
    "excess_angle",
    "excess_direction",
    "frictionless",
    "from_gliding",
    "gliding_params",
    "kinematics",
    "normal_force",
    "required",
    "restart",
    "reversal_event",
    "reversal_jump",
    "rolling_contact",
    "rolling_guess",
    "set_slip",
    "settle",
    "slide",
    "slide_into",
    "slide_law",
    "slide_rhs",
    "sliding_contact",
    "slip",
    "slip_rate",
    "slip_velocity",
    "spin_term",
    "start_phase",
    "stick",
    "stick_into",
    "stick_rhs",
    "stop_event",
    "stop_jump",
    "stop_time",
    "to_gliding",
]

# law codes of the parameter tuple p = (m, R, l, I1, I3, mu, g, r_star, eps, law, delta)
LAW_COULOMB, LAW_REGULARISED = 0.0, 1.0


_CONE_SIDE = 1e6
"""Weight of the cone term in the stop/reversal events (dimensionless): a margin of −1e-6 m g
delays a "stop" by one band δ, so at the band crossing the event of the cone's side fires first."""


def kinematics(y: Any, p: tuple) -> tuple:
    """(3̂, ω, 3̂̇, a, v_A (horizontal), h, c) of state(s) ``y``; see the module docstring."""
    R, l, I1, I3, g = p[ix.R], p[ix.L], p[ix.I1], p[ix.I3], p[ix.G]
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


def delassus(F: tuple, e: tuple, a: tuple, m: float, I1: float, c: float) -> tuple:
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


def spin_term(e: tuple, a: tuple, I1: float, c: float) -> tuple:
    """(J⁻¹ẑ) × a: the contact acceleration per unit torque about ẑ."""
    jx, jy, jz = c * e[2] * e[0], c * e[2] * e[1], 1.0 / I1 + c * e[2] * e[2]
    ax, ay, az = a
    return (jy * az - jz * ay, jz * ax - jx * az, jx * ay - jy * ax)


def derivatives(y: Any, p: tuple, F: tuple, M: Any, w: tuple, de: tuple, a: tuple) -> tuple:
    m = p[ix.M]
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


def slide(y: Any, p: tuple, fx: Any, fy: Any, fm: Any, kin: tuple | None = None) -> tuple:
    """Sliding with the force per unit normal force (fx, fy, 1) and torque fm ẑ per unit g_n.

    Returns (derivatives, g_n, F, M, v̇_A). ``kin``: :func:`kinematics` of ``y`` if known.
    """
    m, I1 = p[ix.M], p[ix.I1]
    e, w, de, a, nu, h, c = kinematics(y, p) if kin is None else kin
    Gf = delassus((fx, fy, 1.0), e, a, m, I1, c)
    s = spin_term(e, a, I1, c)
    gn = -h[2] / (Gf[2] + fm * s[2])
    F = (gn * fx, gn * fy, gn)
    M = gn * fm
    vdot = (
        gn * (Gf[0] + fm * s[0]) + h[0],
        gn * (Gf[1] + fm * s[1]) + h[1],
        gn * (Gf[2] + fm * s[2]) + h[2],
    )
    return derivatives(y, p, F, M, w, de, a), gn, F, M, vdot


def _law(y: Any, p: tuple, kin: tuple | None = None) -> tuple:
    """(fx, fy, fm): the sliding law per unit normal force at state(s) ``y``."""
    mu, rs, eps, law = p[ix.MU], p[ix.RSTAR], p[ix.EPS], p[ix.LAW]
    e, w, de, a, nu, h, c = kinematics(y, p) if kin is None else kin
    if mu == 0.0:  # frictionless: no force, also at zero slip (where −μ v̂_A would be 0/0)
        zero = 0.0 * nu[0]
        return zero, zero, zero
    if law == LAW_REGULARISED:
        k = -mu / (nu[0] * nu[0] + nu[1] * nu[1] + eps * eps) ** 0.5
        return k * nu[0], k * nu[1], 0.0 * k
    k = -mu / (nu[0] * nu[0] + nu[1] * nu[1] + (rs * w[2]) ** 2) ** 0.5
    return k * nu[0], k * nu[1], k * rs * rs * w[2]


def _spin_rate(F: tuple, e: tuple, a: tuple, I1: Any, c: Any) -> Any:
    """(J⁻¹(a × F))_z: the spin acceleration about ẑ per unit contact force."""
    tx, ty, tz = a[1] * F[2] - a[2] * F[1], a[2] * F[0] - a[0] * F[2], a[0] * F[1] - a[1] * F[0]
    return tz / I1 + c * (tx * e[0] + ty * e[1] + tz * e[2]) * e[2]


@kernel_call
def _solve_G(y: Any, p: tuple, b: tuple, kin: tuple | None = None) -> tuple:
    """The force F with G F = b at state(s) ``y`` (3×3, Cramer's rule), and the kinematics."""
    m, I1 = p[ix.M], p[ix.I1]
    kin = kinematics(y, p) if kin is None else kin
    e, a, c = kin[0], kin[3], kin[6]
    m11, m21, m31 = delassus((1.0, 0.0, 0.0), e, a, m, I1, c)
    m12, m22, m32 = delassus((0.0, 1.0, 0.0), e, a, m, I1, c)
    m13, m23, m33 = delassus((0.0, 0.0, 1.0), e, a, m, I1, c)
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
    I1 = p[ix.I1]
    e, a, c = kin[0], kin[3], kin[6]
    s = spin_term(e, a, I1, c)
    F0 = _solve_G(y, p, b, kin)[0]
    q = _solve_G(y, p, s, kin)[0]

    jz = 1.0 / I1 + c * e[2] * e[2]
    M = (bz - _spin_rate(F0, e, a, I1, c)) / (jz - _spin_rate(q, e, a, I1, c))
    return (F0[0] - M * q[0], F0[1] - M * q[1], F0[2] - M * q[2]), M


@kernel_call
def stick(y: Any, p: tuple) -> tuple:
    """Rolling: the contact force from G F = −h. Returns like :func:`slide`.

    With Contensou friction (r* > 0) stick also holds the spin about the normal, ω̇_z = 0, with
    the drilling torque M the constraint needs.
    """
    kin = kinematics(y, p)
    e, w, de, a, nu, h, c = kin
    if p[ix.RSTAR] > 0.0:
        # W0_z = c (L·3̂) 3̂̇_z with L·3̂ = I3 ω·3̂
        W0z = c * p[ix.I3] * (w[0] * e[0] + w[1] * e[1] + w[2] * e[2]) * de[2]
        F, M = _solve_GM(y, p, (-h[0], -h[1], -h[2]), -W0z, kin)
    else:
        F = _solve_G(y, p, (-h[0], -h[1], -h[2]), kin)[0]
        M = 0.0 * F[2]
    zero = 0.0 * F[2]
    return derivatives(y, p, F, M, w, de, a), F[2], F, M, (zero, zero, zero)


def required(y: Any, p: tuple) -> tuple:
    """(g_n, generalised force (F_x, F_y, M/r*), cone margin μ g_n − |·|) that stick needs."""
    _, gn, F, M, _ = stick(y, p)
    rs = p[ix.RSTAR]
    fm = M / rs if rs > 0.0 else 0.0 * M
    return gn, (F[0], F[1], fm), p[ix.MU] * gn - (F[0] ** 2 + F[1] ** 2 + fm**2) ** 0.5


def _slip_speed(y: Any, p: Any) -> Any:
    """|γ| = √(|v_A|² + (r* ω_z)²) (m/s), plain arithmetic."""
    kin = kinematics(y, p)
    nu, w = kin[4], kin[1]
    rs = p[ix.RSTAR]
    return (nu[0] * nu[0] + nu[1] * nu[1] + (rs * w[2]) * (rs * w[2])) ** 0.5


def _margin(y: Any, p: Any) -> Any:
    """Cone margin of the force rolling needs, (μ g_n − |(F_t, M/r*)|)/(m g), plain arithmetic."""
    return required(y, p)[2] * (1.0 / (p[ix.M] * p[ix.G]))


def slide_rhs(t: float, y: np.ndarray, p: tuple) -> np.ndarray:
    """Right-hand side of the sliding phase (Coulomb or Coulomb–Contensou).

    Parameters
    ----------
    t : float
        Time (s); autonomous.
    y : ndarray, shape (10,)
        Gliding state (:func:`mett.dynamics.gliding_rhs`).
    p : tuple
        ``(m, R, l, I1, I3, mu, g, r_star, eps, law, delta)``: body, friction coefficient (–),
        effective Contensou radius (m), regularisation velocity (m/s), law code (0 Coulomb,
        1 regularised) and stopping band (m/s).
    """
    if np.ndim(y) == 1:
        y = y.tolist()  # Python floats: scalar arithmetic several times faster than numpy's
    return np.array(slide_law(y, p)[0])


@kernel_call
def slide_law(y: Any, p: Any) -> tuple:
    kin = kinematics(y, p)
    f = _law(y, p, kin)
    return slide(y, p, f[0], f[1], f[2], kin)


def slide_into(t: float, y: Any, p: Any, out: Any) -> None:
    """:func:`slide_rhs` written into ``out`` (the source of the compiled twin)."""
    d = slide_law(y, p)[0]
    out[0], out[1], out[2], out[3], out[4] = d[0], d[1], d[2], d[3], d[4]
    out[5], out[6], out[7], out[8], out[9] = d[5], d[6], d[7], d[8], d[9]


def stick_rhs(t: float, y: np.ndarray, p: tuple) -> np.ndarray:
    """Right-hand side of the rolling (stick) phase: v̇_A = 0, force from the constraint.

    Same state and parameters as :func:`slide_rhs`; equal to :func:`mett.dynamics.rolling_rhs` in
    the rolling model's variables.
    """
    if np.ndim(y) == 1:
        y = y.tolist()
    return np.array(stick(y, p)[0])


def stick_into(t: float, y: Any, p: Any, out: Any) -> None:
    """:func:`stick_rhs` written into ``out``."""
    d = stick(y, p)[0]
    out[0], out[1], out[2], out[3], out[4] = d[0], d[1], d[2], d[3], d[4]
    out[5], out[6], out[7], out[8], out[9] = d[5], d[6], d[7], d[8], d[9]


def sliding_contact(t: float, y: Any, p: Any) -> Any:
    """g_n/(m g) while sliding: contact lost when it falls through 0."""
    return slide_law(y, p)[1] * (1.0 / (p[ix.M] * p[ix.G]))


def rolling_contact(t: float, y: Any, p: Any) -> Any:
    """g_n/(m g) while rolling."""
    return stick(y, p)[1] * (1.0 / (p[ix.M] * p[ix.G]))


def _positive_part(x: Any) -> Any:
    """max(x, 0) as plain arithmetic, (x + √(x²))/2: no branch on a state value."""
    return 0.5 * (x + (x * x) ** 0.5)


def stop_event(t: float, y: Any, p: Any) -> Any:
    """|γ| − δ, kept positive while the required force is outside the cone: "stop" → rolling."""
    if p[ix.MU] == 0.0:  # μ = 0: a cone of radius 0, no stop (see frictionless)
        return 1.0 + 0.0 * y[0]  # never 0 (a constant: no series of |γ| near 0)
    return _slip_speed(y, p) - p[ix.BAND] + p[ix.BAND] * _CONE_SIDE * _positive_part(-_margin(y, p))


def reversal_event(t: float, y: Any, p: Any) -> Any:
    """|γ| − δ, kept positive while the required force is inside the cone: "reversal"."""
    if p[ix.MU] == 0.0:  # μ = 0: no friction to reverse the slip (see frictionless)
        return 1.0 + 0.0 * y[0]  # never 0 (a constant: no series of |γ| near 0)
    return _slip_speed(y, p) - p[ix.BAND] + p[ix.BAND] * _CONE_SIDE * _positive_part(_margin(y, p))


def cone_event(t: float, y: Any, p: Any) -> Any:
    """The cone margin of rolling: "cone" → sliding when it falls through 0."""
    return _margin(y, p)


def slip_velocity(y: np.ndarray, p: tuple) -> np.ndarray:
    k = kinematics(y, p)
    return np.array(k[4])


def slip(y: np.ndarray, p: tuple) -> np.ndarray:
    """The generalised slip γ = (v_A, r* ω_z) (m/s); r* = 0 for Coulomb."""
    k = kinematics(y, p)
    return np.array([k[4][0], k[4][1], p[ix.RSTAR] * k[1][2]])


def excess_angle(accel: Callable[[float, float], Any]) -> tuple[float, float] | None:
    """Unit (u_x, u_y) with v̇(u) = s u, s > 0, largest s; None if there is none.

    ``accel(u_x, u_y)`` is the slip acceleration (v̇_x, v̇_y) under the sliding force along −u.
    Scans the angle of u on 72 intervals and refines the sign changes of (u × v̇(u))_z by Brent's
    method (one implementation for one contact, :func:`excess_direction`, and for a contact of
    the stemmed top's double contact).
    """

    def cross(phi: float) -> float:
        ux, uy = math.cos(phi), math.sin(phi)
        v = accel(ux, uy)
        return ux * v[1] - uy * v[0]

    grid = np.linspace(0.0, 2.0 * math.pi, 73)
    cr = np.array([cross(ph) for ph in grid])
    best, best_s = None, 0.0
    sign = np.sign(cr)  # not cr[:-1] * cr[1:]: that product underflows to 0 near a pole
    for i in np.flatnonzero(sign[:-1] * sign[1:] <= 0.0):
        if cr[i] == 0.0:
            phi = grid[i]
        elif cr[i + 1] == 0.0:
            continue
        else:
            phi = brentq(cross, grid[i], grid[i + 1], xtol=1e-15)
        ux, uy = math.cos(phi), math.sin(phi)
        v = accel(ux, uy)
        s = ux * v[0] + uy * v[1]
        if s > best_s:
            best, best_s = (ux, uy), s
    return best


def excess_direction(y: np.ndarray, p: tuple, fallback: np.ndarray) -> np.ndarray:
    """Unit u with v̇_A(u) = s u, s > 0, under the sliding force −μ g_n u (slip start at v_A = 0).

    Among the solutions with s > 0 the one of largest s (:func:`excess_angle`). ``fallback`` if
    there is none (stick feasible). Returned as the generalised direction (u_x, u_y, 0). With
    Contensou friction, the direction opposite to the generalised force stick needs
    (``fallback``; exact at the cone's edge).
    """
    mu = p[ix.MU]
    if p[ix.RSTAR] > 0.0:
        return np.asarray(fallback, dtype=float) / np.linalg.norm(fallback)
    best = excess_angle(lambda ux, uy: slide(y, p, -mu * ux, -mu * uy, 0.0)[4])
    if best is None:
        return np.asarray(fallback, dtype=float) / np.linalg.norm(fallback)
    return np.array([best[0], best[1], 0.0])


def set_slip(y: np.ndarray, p: tuple, target: np.ndarray) -> np.ndarray:
    """``y`` after the contact impulse P that changes γ to ``target`` (G P = Δv_A, vertical 0).

    ``target`` is the generalised slip (v_A, r* ω_z); with Contensou friction an angular impulse
    Q ẑ about the normal at A changes ω_z too (it changes λ by −Q (ẑ·a), as the torque would).

    An impulse at A: Δṙ = P/m, ΔL = a × P. It keeps λ = −L·a (exactly, (a × P)·a = 0) and changes
    the energy by Δv_A·G⁻¹(v_A + target)/2 — for target 0 by −½ v_A·G⁻¹v_A ≤ 0 (a plastic tangential
    impact: the last O(δ) of slip is removed dissipatively, as the sliding it replaces would).
    """
    d = np.asarray(target, dtype=float) - slip(y, p)
    kin = kinematics(y, p)
    if p[ix.RSTAR] > 0.0:  # and the angular impulse Q ẑ that changes ω_z by d[2]/r*
        P, Q = _solve_GM(y, p, (d[0], d[1], 0.0), d[2] / p[ix.RSTAR], kin)
    else:
        P, Q = _solve_G(y, p, (d[0], d[1], 0.0), kin)[0], 0.0
    a = kin[3]
    out = np.array(y, dtype=float)
    out[2] += P[0] / p[ix.M]
    out[3] += P[1] / p[ix.M]
    out[4] += a[1] * P[2] - a[2] * P[1]
    out[5] += a[2] * P[0] - a[0] * P[2]
    out[6] -= Q * a[2]  # Δλ = −(a × P + Q ẑ)·a = −Q a_z: the impulse P keeps λ exactly
    return out


def slip_rate(y: np.ndarray, p: tuple) -> float:
    """a = −d|γ|/dt (m/s²) of the sliding law at ``y``: the rate at which the slip falls.

    Coulomb: −γ̂·v̇_A of :func:`slide`, exactly. With Contensou's r* the spin part r* ω̇_z is the
    central difference of r* ω_z along the sliding rates over a step that moves γ by 1e-3 |γ|
    (γ is smooth in the state, and along a straight line in state space linear to O(h²)).
    """
    y = np.asarray(y, dtype=float)
    g = slip(y, p)
    speed = float(np.linalg.norm(g))
    d, _, _, _, vdot = slide_law(y.tolist(), p)
    rate = np.array([vdot[0], vdot[1], 0.0])
    if p[ix.RSTAR] > 0.0:
        h = 1e-3 * speed / max(math.hypot(vdot[0], vdot[1]), p[ix.MU] * p[ix.G])
        step = np.zeros_like(y)
        step[:10] = h * np.asarray(d)
        rate[2] = (slip(y + step, p)[2] - slip(y - step, p)[2]) / (2.0 * h)
    return float(-(g @ rate) / speed) if speed > 0.0 else math.nan


def stop_time(t: float, y: np.ndarray, p: tuple) -> float:
    """The instant the slip reaches 0, extrapolated from the band crossing ``(t, y)``.

    Under Coulomb friction the slip falls to 0 in finite time at a finite rate a = −d|γ|/dt
    (:func:`slip_rate`; μ g_n times the contact's inverse effective mass along the slip, less
    the pull of the required force), so |γ| is linear in t near the stop and the stop is at
    t + |γ|/a, to O(|γ|²): the band crossing precedes it by |γ|/a = δ/a. The state needs no
    advancing: the stopping impulse at the band equals the integral of the friction force
    beyond the required one up to the stop (both bring v_A from γ to 0 through the same G), so
    the rolling state after it is that of the exact stop to O(δ²). ``t`` if a ≤ 0 (no finite
    extrapolation).
    """
    speed = float(np.linalg.norm(slip(y, p)))
    a = slip_rate(y, p)
    return t + speed / a if a > 0.0 else t


def stop_jump(y: np.ndarray, p: tuple) -> np.ndarray:
    """Sliding → rolling: the contact impulse that removes the last slip (|γ| = δ → 0)."""
    return set_slip(y, p, np.zeros(3))


def restart(y: np.ndarray, p: tuple) -> np.ndarray:
    """Slip restarted with |γ| = 2δ in the excess-force direction (from v_A = 0)."""
    return set_slip(y, p, 2.0 * p[ix.BAND] * excess_direction(y, p, -np.array(required(y, p)[1])))


def reversal_jump(y: np.ndarray, p: tuple) -> np.ndarray:
    """Sliding → sliding at the band, outside the cone: stop, then restart along the excess force."""
    return restart(set_slip(y, p, np.zeros(3)), p)


def cone_jump(y: np.ndarray, p: tuple) -> np.ndarray:
    """Rolling → sliding: the slip starts along the excess-force direction."""
    return restart(y, p)


def gliding_params(p: tuple) -> tuple:
    """The "gliding" model's (m, R, l, I1, I3, mu, g) with μ = 0 (its conversions only)."""
    return (p[ix.M], p[ix.R], p[ix.L], p[ix.I1], p[ix.I3], 0.0, p[ix.G])


def _a(Y: np.ndarray, p: tuple) -> tuple:
    """a = l 3̂ − R ẑ of state(s) ``Y`` (3̂ normalised), as in :func:`kinematics`."""
    R, l = p[ix.R], p[ix.L]
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


def frictionless(p: tuple) -> bool:
    """μ = 0: the friction cone has radius 0, so the motion is frictionless sliding throughout.

    Rolling would need a tangential force of exactly 0; where it does (a spin exactly at a pole)
    rolling and frictionless sliding are the same motion. So no phase switch ever happens: the
    start is not settled (a stopping impulse would be a tangential impulse, which the zero cone
    cannot transmit), the run starts sliding, and the stop and reversal events never fire. The
    law itself is 0 (:func:`_law`); without this, a spin at a pole started rolling, crossed the
    zero cone at once, and its restart direction was 0/0.
    """
    return p[ix.MU] == 0.0


def settle(y: np.ndarray, p: tuple) -> np.ndarray:
    """``y`` with a slip within the stopping band settled (``y`` itself if the slip is larger).

    The stopping impulse removes the slip; if the force rolling then needs lies outside the cone,
    slip restarts with |γ| = 2δ in the excess-force direction. :func:`start_phase` of the result
    is the phase it starts. Used at the start of a run and after an impact (the stemmed top,
    :mod:`.stemslip`). ``y`` may carry components beyond the ten of the state (kept).
    """
    if frictionless(p):
        return y
    if p[ix.LAW] == LAW_COULOMB and float(np.linalg.norm(slip(y, p))) <= p[ix.BAND]:
        y = set_slip(y, p, np.zeros(3))
        if required(y, p)[2] < 0.0:
            y = restart(y, p)
    return y


def start_phase(y0: np.ndarray, p: tuple) -> str:
    if frictionless(p):
        return "sliding"
    return "rolling" if float(np.linalg.norm(slip(y0, p))) <= p[ix.BAND] else "sliding"


def rolling_guess(Y: np.ndarray, p: tuple) -> np.ndarray:
    """Where the phase is not stored (dense output between samples): rolling where the slip is
    within the band and the cone holds."""
    speed = np.sqrt(np.sum(slip(Y, p) ** 2, axis=0))
    with np.errstate(divide="ignore", invalid="ignore"):
        margin = required(Y, p)[2]
    return (
        (speed <= p[ix.BAND]) & (margin >= 0.0) & (p[ix.LAW] == LAW_COULOMB) & (not frictionless(p))
    )


def normal_force(y: np.ndarray, p: tuple) -> Any:
    """g_n (N) of state(s) ``y``: rolling's where the slip is within the band, else sliding's."""
    Y = np.asarray(y, dtype=float)
    return contact_quantities(Y.reshape(10, -1), p, rolling_guess(Y.reshape(10, -1), p))[
        "gn"
    ].reshape(Y.shape[1:])


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
        s = slide_law(Y, p)
        r = stick(Y, p)
    gn = np.where(rolling, r[1], s[1])
    Fx = np.where(rolling, r[2][0], s[2][0])
    Fy = np.where(rolling, r[2][1], s[2][1])
    M = np.where(rolling, r[3], s[3])
    fm = M / p[ix.RSTAR] if p[ix.RSTAR] > 0.0 else 0.0 * M
    return {
        "gn": gn,
        "F_x": Fx,
        "F_y": Fy,
        "M_n": M,
        "margin": p[ix.MU] * gn - np.sqrt(Fx**2 + Fy**2 + fm**2),
    }
