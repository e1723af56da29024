"""Dry friction integrated exactly: Coulomb and Coulomb–Contensou stick–slip.

The state is that of the ``"gliding"`` model, ``y = [x, y, ẋ, ẏ, L_x, L_y, L_z, 3̂_x, 3̂_y, 3̂_z]``
(:mod:`.gliding`), and the equations are those of the eccentric sphere under a contact force
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

Switching (:func:`simulate_dry`), all by located events:

* rolling → sliding when the cone margin falls through 0. The slip starts opposite to the required
  tangential force (friction at the cone edge equals the required force, so the slip acceleration
  starts from zero and grows as the required force leaves the cone).
* sliding → stop when |v_A| falls through a stopping band δ (10 rtol × the velocity scale): the
  remaining O(δ) of slip is removed by the contact impulse P with G P = −v_A (:func:`_set_slip`;
  it keeps λ exactly and changes E by −½ v_A·G⁻¹v_A ≤ 0). Then the cone decides: rolling if the required force is inside, else sliding
  continues from |v_A| = 2δ in the direction u of the excess force, the solution of
  s u = v̇_A(u), s > 0 (slip acceleration parallel to the slip under the Coulomb force −μ g_n u).
* Coulomb–Contensou: the same phases on the generalised slip γ = (v_A, r* ω_z); stick also holds
  ω̇_z = 0 with the drilling torque M it needs (:func:`_solve_GM`), inside the ellipsoid
  |F_t|² + (M/r*)² ≤ (μ g_n)²; slip restarts opposite to the generalised required force, and the
  impulses at a switch include an angular impulse about ẑ.
* Near v_A = 0 the slip direction is a fast variable (its rate is ~ μ g_n |G| / |v_A|): sliding
  with |v_A| below ρ_s (where that rate reaches 1e4 /s) is integrated with LSODA (stiff-capable;
  7× faster than Radau on the stick–slip tests), above 2 ρ_s with DOP853.

Energy: rolling conserves E, sliding dissipates μ g_n |v_A| ≥ 0, the stopping impulse
½ v_A·G⁻¹v_A = O(m δ²). λ = −L·a is conserved by every force at A without a torque about the
normal: dλ/dt = −(a × F)·a − L·ȧ = 0, since L·(ω × 3̂) = 0 for the symmetric top (Rutstam 2012
§2); so by Coulomb. Contensou's torque M ẑ changes it at the rate dλ/dt = −M (ẑ·a) =
M (R − l cos θ).
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from ..friction import Coulomb, RegularisedCoulomb
from . import gliding
from .registry import Event, Model
from .trajectory import Trajectory

__all__ = [
    "MAX_SWITCHES",
    "PHASES",
    "Switch",
    "contact_quantities",
    "simulate_dry",
    "slide_rhs",
    "stick_rhs",
]

PHASES = ("sliding", "rolling")
MAX_SWITCHES = 20_000
"""A run that switches between sliding and rolling more often than this stops with status
"failed" (a Zeno accumulation of switches must not stall the integrator)."""

# law codes of the parameter tuple p = (m, R, l, I1, I3, g, mu, r_star, eps, law)
_COULOMB, _REGULARISED = 0.0, 1.0


# --- the contact mechanics, plain float arithmetic (floats or equal-shape arrays) -------------


def _kinematics(y: Any, p: tuple) -> tuple:
    """(3̂, ω, 3̂̇, a, v_A (horizontal), h, c) of state(s) ``y``; see the module docstring."""
    m, R, l, I1, I3, g = p[:6]
    Lx, Ly, Lz = y[4], y[5], y[6]
    n = (y[7] * y[7] + y[8] * y[8] + y[9] * y[9]) ** 0.5
    ex, ey, ez = y[7] / n, y[8] / n, y[9] / n
    c = 1.0 / I3 - 1.0 / I1
    Le = Lx * ex + Ly * ey + Lz * ez
    wx, wy, wz = Lx / I1 + c * Le * ex, Ly / I1 + c * Le * ey, Lz / I1 + c * Le * ez
    dex, dey, dez = wy * ez - wz * ey, wz * ex - wx * ez, wx * ey - wy * ex
    ax, ay, az = l * ex, l * ey, l * ez - R
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
        ax * Fy - ay * Fx + M,
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
    vdot = tuple(gn * (Gf[k] + fm * s[k]) + h[k] for k in range(3))
    return _derivatives(y, p, F, M, w, de, a), gn, F, M, vdot


def _law(y: Any, p: tuple, kin: tuple | None = None) -> tuple:
    """(fx, fy, fm): the sliding law per unit normal force at state(s) ``y``."""
    mu, rs, eps, law = p[6], p[7], p[8], p[9]
    e, w, de, a, nu, h, c = _kinematics(y, p) if kin is None else kin
    if law == _REGULARISED:
        k = -mu / (nu[0] * nu[0] + nu[1] * nu[1] + eps * eps) ** 0.5
        return k * nu[0], k * nu[1], 0.0 * k
    k = -mu / (nu[0] * nu[0] + nu[1] * nu[1] + (rs * w[2]) ** 2) ** 0.5
    return k * nu[0], k * nu[1], k * rs * rs * w[2]


def slide_rhs(t: float, y: np.ndarray, p: tuple) -> np.ndarray:
    """Right-hand side of the sliding phase (Coulomb, Coulomb–Contensou or regularised law).

    Parameters
    ----------
    t : float
        Time (s); autonomous.
    y : ndarray, shape (10,)
        Gliding state (:func:`mett.dynamics.gliding_rhs`).
    p : tuple
        ``(m, R, l, I1, I3, g, mu, r_star, eps, law)``: body, friction coefficient (–), effective
        Contensou radius (m), regularisation velocity (m/s) and law code (0 Coulomb, 1 regularised).
    """
    if np.ndim(y) == 1:
        y = y.tolist()  # Python floats: scalar arithmetic several times faster than numpy's
    kin = _kinematics(y, p)
    fx, fy, fm = _law(y, p, kin)
    return np.array(_slide(y, p, fx, fy, fm, kin)[0])


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

    def spin_rate(F: tuple) -> Any:  # (J⁻¹(a × F))_z
        tx, ty, tz = a[1] * F[2] - a[2] * F[1], a[2] * F[0] - a[0] * F[2], a[0] * F[1] - a[1] * F[0]
        return tz / I1 + c * (tx * e[0] + ty * e[1] + tz * e[2]) * e[2]

    jz = 1.0 / I1 + c * e[2] * e[2]
    M = (bz - spin_rate(F0)) / (jz - spin_rate(q))
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


def stick_rhs(t: float, y: np.ndarray, p: tuple) -> np.ndarray:
    """Right-hand side of the rolling (stick) phase: v̇_A = 0, force from the constraint.

    Same state and parameters as :func:`slide_rhs`; equal to :func:`mett.dynamics.rolling_rhs` in
    the rolling model's variables.
    """
    if np.ndim(y) == 1:
        y = y.tolist()
    return np.array(_stick(y, p)[0])


def contact_quantities(Y: np.ndarray, p: tuple, rolling: Any) -> dict[str, np.ndarray]:
    """g_n, F_t, M and the cone margin at states ``Y`` (shape (10, k)) in the given phases.

    ``rolling`` is a boolean per sample. The margin μ g_n − |F_t| is that of the required force in
    rolling samples and of the sliding force (≈ 0 for Coulomb) in sliding ones.
    """
    Y = np.asarray(Y, dtype=float).reshape(10, -1)
    rolling = np.broadcast_to(np.asarray(rolling, dtype=bool), Y.shape[1:])
    with np.errstate(divide="ignore", invalid="ignore"):  # the sliding law at v_A = 0
        fx, fy, fm = _law(Y, p)
        s = _slide(Y, p, fx, fy, fm)
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


def viscous_force(traj: Trajectory) -> None:
    """Add ``F_x``, ``F_y`` = −μ g_n v_A (N, lab frame) and ``M_n`` = 0 to a viscous "gliding" run.

    So that runs under every law report their friction force (:func:`mett.simulate` with
    ``friction=Viscous(...)``); ``traj.params`` is the gliding model's (m, R, l, I1, I3, μ, g).
    """
    m, R, l, I1, I3, mu, g = traj.params
    nu = _kinematics(traj.states, (m, R, l, I1, I3, g))[4]
    traj.F_x = -mu * traj.gn * nu[0]
    traj.F_y = -mu * traj.gn * nu[1]
    traj.M_n = np.zeros_like(traj.gn)
    traj.extra = (*traj.extra, "F_x", "F_y", "M_n")


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
    for i in np.flatnonzero(cr[:-1] * cr[1:] <= 0.0):
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
    out[6] += Q
    out[2] += P[0] / p[0]
    out[3] += P[1] / p[0]
    out[4] += a[1] * P[2] - a[2] * P[1]
    out[5] += a[2] * P[0] - a[0] * P[2]
    out[6] += a[0] * P[1] - a[1] * P[0]
    return out


class Switch(NamedTuple):
    """A change of contact phase of a stick–slip run (``Trajectory.switches``)."""

    t: float
    """Time of the switch (s)."""
    before: str
    """Phase before: "sliding" or "rolling"."""
    after: str
    """Phase after."""
    reason: str
    """"stop" (|v_A| fell to the stopping band, the required force inside the cone), "cone" (the
    required force left the cone) or "reversal" (|v_A| fell to the band with the required force
    outside the cone: sliding restarts in the direction of the excess force)."""
    margin: float
    """Cone margin of the force rolling needs, (μ g_n − |F_t|)/(μ g_n), at the switch state."""
    slip: float
    """|v_A| (m/s) at the event that triggered the switch."""


class _Piecewise:
    """Dense output of a run made of segments (one per phase), as a Trajectory needs it."""

    def __init__(self, segments: list[tuple[float, float, Any]]) -> None:
        self._segs = segments
        self._starts = np.array([s[0] for s in segments])
        ts = [np.asarray(sol.ts, dtype=float) for _, _, sol in segments]
        self.ts = np.unique(np.concatenate(ts))
        self.t_min, self.t_max = segments[0][0], segments[-1][1]

    def __call__(self, t: Any) -> np.ndarray:
        t = np.asarray(t, dtype=float)
        scalar = t.ndim == 0
        tt = np.atleast_1d(t)
        # a switch time belongs to the segment that starts there
        idx = np.clip(np.searchsorted(self._starts, tt, side="right") - 1, 0, len(self._segs) - 1)
        out = np.empty((10, tt.size))
        for k in np.unique(idx):
            sel = idx == k
            out[:, sel] = np.asarray(self._segs[k][2](tt[sel]), dtype=float).reshape(10, -1)
        return out[:, 0] if scalar else out


class _ScipyDense:
    """scipy's OdeSolution with the ``ts`` breakpoints a Trajectory bisects on."""

    def __init__(self, sol: Any, t: np.ndarray) -> None:
        self._sol, self.ts = sol, np.asarray(t, dtype=float)

    def __call__(self, t: Any) -> np.ndarray:
        return self._sol(t)


def _phase_model(params: tuple) -> Model:
    """The Model record of a dry-friction trajectory: gliding's conversions, this module's g_n."""

    def derive(Y: np.ndarray, p: tuple) -> dict[str, np.ndarray]:
        base = (p[0], p[1], p[2], p[3], p[4], 0.0, p[5])
        out = gliding.MODEL.derive(Y, base)
        Y = np.asarray(Y, dtype=float)
        nu = np.hypot(out["nu_x"], out["nu_y"])
        # outside a run's own samples the phase is not stored: rolling where v_A vanishes to
        # the stopping band and the cone holds
        q = contact_quantities(Y, p, rolling=False)
        r = contact_quantities(Y, p, rolling=True)
        slip = np.hypot(nu, p[7] * _kinematics(Y, p)[1][2])
        roll = (slip <= p[10]) & (r["margin"] >= 0.0) & (p[9] == _COULOMB)
        out["gn"] = np.where(roll, r["gn"], q["gn"])
        return out

    return Model(
        name="gliding",
        summary="tippe top under dry friction (exact stick–slip), gliding state",
        rhs=slide_rhs,
        normal_force=lambda y, p: _slide(y, p, *_law(y, p))[1],
        params=lambda top, options: params,
        initial=gliding.MODEL.initial,
        derive=derive,
        theta=gliding.MODEL.theta,
        scales=lambda y0, p: gliding.MODEL.scales(y0, (*p[:5], 0.0, p[5])),
        events=(Event(lambda t, y, p: _slide(y, p, *_law(y, p))[1], -1.0, "contact_lost"),),
    )


def simulate_dry(
    top: Any,
    state: Any,
    t_end: float,
    friction: Coulomb | RegularisedCoulomb,
    *,
    rtol: float = 1e-10,
    atol: np.ndarray | None = None,
    t_eval: np.ndarray | None = None,
    max_step: float = math.inf,
    max_switches: int = MAX_SWITCHES,
    method: str = "DOP853",
) -> Trajectory:
    """Integrate the tippe top under :class:`~mett.friction.Coulomb` (exact stick–slip) or
    :class:`~mett.friction.RegularisedCoulomb`; called by :func:`mett.simulate`.

    Inputs are validated by :func:`mett.simulate`. Returns a :class:`Trajectory` whose extra
    series ``phase`` ("sliding"/"rolling" per sample), ``F_x``, ``F_y`` (tangential force, N),
    ``M_n`` (Contensou torque about ẑ, N m), ``margin`` (μ g_n − |F_t|, N) and ``switches``
    (a list of :class:`Switch`) describe the contact; ``stopping_band`` is δ (m/s). ``method`` is the integrator of the regularised law and of fast sliding.
    """
    R, l = top.R, top.R * top.alpha
    coulomb = isinstance(friction, Coulomb)
    r_star = friction.r_star if coulomb else 0.0
    eps = 0.0 if coulomb else friction.eps
    law = _COULOMB if coulomb else _REGULARISED
    p0 = (top.m, R, l, top.I1, top.I3, top.g, friction.mu, r_star, eps, law)
    y0 = np.asarray(gliding.MODEL.initial(state, (top.m, R, l, top.I1, top.I3, 0.0, top.g)))
    scales = np.asarray(gliding.MODEL.scales(y0, (top.m, R, l, top.I1, top.I3, 0.0, top.g)))
    if atol is None:
        atol = rtol * scales
    vscale = float(scales[2])
    delta = max(10.0 * rtol, 1e-13) * vscale  # stopping band (m/s)
    # Below ρ_s the slip direction is stiff: its rate μ g_n |G|/|v_A| exceeds 1e4 /s, with
    # |G| ≤ (1 + m |a|²/I1)/m; there LSODA integrates. A fixed ρ_s = 1e-3 × the velocity scale
    # sent long stretches of slow slip to LSODA, whose global error is looser than DOP853's: λ
    # drifted 1e-11 per second instead of 5e-13.
    amax = R + abs(l)
    rho_s = max(100.0 * delta, friction.mu * top.g * (1.0 + top.m * amax**2 / top.I1) * 1e-4)
    p = (*p0, delta)
    exact = coulomb
    weight = 1.0 / (top.m * top.g)

    def ev(fn: Any, direction: float) -> Any:
        fn.terminal, fn.direction = True, direction
        return fn

    def slide_f(t: float, y: np.ndarray) -> np.ndarray:
        if y.ndim == 2 and y.shape[1] == 1:  # a vectorized solver asks for one state as a column
            return slide_rhs(t, y[:, 0], p)[:, None]
        return slide_rhs(t, y, p)

    def stick_f(t: float, y: np.ndarray) -> np.ndarray:
        return stick_rhs(t, y, p)

    contact_slide = ev(lambda t, y: _slide(y, p, *_law(y, p))[1] * weight, -1.0)
    contact_stick = ev(lambda t, y: _stick(y, p)[1] * weight, -1.0)

    def margin(t: float, y: np.ndarray) -> float:
        return _required(y, p)[2] * weight

    def record(t: float, y_ev: np.ndarray, y_new: np.ndarray, before: str, after: str, why: str):
        gn, _, m = _required(y_new, p)
        switches.append(Switch(t, before, after, why, m / (friction.mu * gn), speed(t, y_ev)))

    def speed(t: float, y: np.ndarray) -> float:
        return float(np.linalg.norm(_slip(y, p)))

    def excess(y: np.ndarray) -> np.ndarray:
        return _excess_direction(y, p, -np.array(_required(y, p)[1]))

    ev_margin = ev(margin, -1.0)
    ev_stop = ev(lambda t, y: speed(t, y) - delta, -1.0)
    ev_slow = ev(lambda t, y: speed(t, y) - rho_s, -1.0)
    ev_fast = ev(lambda t, y: speed(t, y) - 2.0 * rho_s, 1.0)

    segments: list[tuple[float, float, Any]] = []
    samples_t: list[np.ndarray] = []
    samples_y: list[np.ndarray] = []
    samples_roll: list[np.ndarray] = []
    switches: list[Switch] = []
    nfev = 0
    t, y = 0.0, y0.copy()
    status, message, t_lost = "completed", f"reached t_end = {t_end:g} s", None

    # the starting phase
    if exact and speed(0.0, y) <= delta:
        y = _set_slip(y, p, np.zeros(3))
        if margin(0.0, y) >= 0.0:
            phase = "rolling"
        else:
            y = _set_slip(y, p, 2.0 * delta * excess(y))
            phase = "slow"
    elif exact:
        phase = "slow" if speed(0.0, y) < rho_s else "fast"
    else:
        phase = "smooth"

    while True:
        if len(switches) > max_switches:
            status = "failed"
            message = (
                f"more than {max_switches} stick–slip switches by t = {t:.9g} s "
                "(Zeno accumulation); the run is kept up to there"
            )
            break
        if phase == "rolling":
            fun, events, meth = stick_f, [contact_stick, ev_margin], "DOP853"
        elif phase == "fast":
            fun, events, meth = slide_f, [contact_slide, ev_slow], method
        elif phase == "slow":
            fun, events, meth = slide_f, [contact_slide, ev_stop, ev_fast], "LSODA"
        else:
            fun, events, meth = slide_f, [contact_slide], method
        te = None if t_eval is None else t_eval[(t_eval >= t) & (t_eval <= t_end)]
        with np.errstate(all="ignore"):
            res = solve_ivp(
                fun, (t, t_end), y, method=meth, dense_output=True,
                rtol=rtol, atol=atol,
                events=events, t_eval=te, max_step=max_step, vectorized=meth == "Radau",
            )  # fmt: skip
        nfev += res.nfev
        sol = res.sol
        t_stop = float(sol.t_max) if sol is not None else t
        tt, YY = np.asarray(res.t, dtype=float), np.asarray(res.y, dtype=float).reshape(10, -1)
        if tt.size == 0 or tt[-1] < t_stop:
            keep = tt < t_stop
            tt = np.append(tt[keep], t_stop)
            end = sol(t_stop) if sol is not None else y
            YY = np.hstack([YY[:, keep], np.asarray(end, dtype=float).reshape(10, 1)])
        if sol is not None:
            segments.append((t, t_stop, _ScipyDense(sol, sol.ts)))
        if samples_t and tt.size > 1 and tt[0] == t:
            # the switch time is already the last sample of the previous segment
            tt, YY = tt[1:], YY[:, 1:]
        samples_t.append(tt)
        samples_y.append(YY)
        samples_roll.append(np.full(tt.size, phase == "rolling"))
        if res.status == -1 or not np.all(np.isfinite(YY)):
            status, message = "failed", f"integrator failed at t = {t_stop:.9g} s: {res.message}"
            break
        if res.status == 0:
            break
        # which terminal event: the one with an event at t_stop
        k = next(i for i, te_ in enumerate(res.t_events) if te_.size)
        y_ev = np.asarray(res.y_events[k][0], dtype=float)
        t = float(res.t_events[k][0])
        if k == 0:
            status, t_lost = "contact_lost", t
            message = f"contact lost: the normal force g_n reached 0 at t = {t:.9g} s"
            break
        if phase == "rolling":  # the required force left the cone
            y = _set_slip(y_ev, p, 2.0 * delta * excess(y_ev))
            record(t, y_ev, y_ev, "rolling", "sliding", "cone")
            phase = "slow"
        elif phase == "fast":
            y, phase = y_ev, "slow"
        elif k == 2:  # slow sliding, |v_A| rose above 2 ρ_s
            y, phase = y_ev, "fast"
        else:  # slow sliding, |v_A| fell to δ: stop, then the cone decides
            y = _set_slip(y_ev, p, np.zeros(3))
            if margin(t, y) >= 0.0:
                record(t, y_ev, y, "sliding", "rolling", "stop")
                phase = "rolling"
            else:
                record(t, y_ev, y, "sliding", "sliding", "reversal")
                y = _set_slip(y, p, 2.0 * delta * excess(y))
                phase = "slow"

    t_all = np.concatenate(samples_t)
    Y_all = np.hstack(samples_y)
    roll = np.concatenate(samples_roll)
    if not segments:
        from .trajectory import _Constant

        dense: Any = _Constant(0.0, y0)
    else:
        dense = _Piecewise(segments)
    cq = contact_quantities(Y_all, p, roll)
    extra = {
        "phase": np.where(roll, "rolling", "sliding"),
        "gn": cq["gn"],
        "F_x": cq["F_x"],
        "F_y": cq["F_y"],
        "M_n": cq["M_n"],
        "margin": cq["margin"],
    }
    traj = Trajectory(
        t=t_all,
        states=Y_all,
        model=_phase_model(p),
        top=top,
        params=p,
        solution=dense,
        status=status,
        message=message,
        t_contact_lost=t_lost,
        nfev=nfev,
        backend="scipy",
        extra=extra,
    )
    traj.switches = switches
    traj.friction = friction
    traj.stopping_band = delta
    return traj
