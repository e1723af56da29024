"""Shared machinery of the dynamical models: frame conversions and the integrals of a run.

Every model of :mod:`mett.dynamics` is described by a :class:`~mett.dynamics.registry.Model`
(re-exported here): a pure right-hand side ``rhs(t, y, p)`` on a flat float array ``y`` and a
parameter tuple ``p``, plus the conversions between the library's reduced :class:`~mett.State`
(θ, θ̇, φ̇, ω3, ν_x, ν_y) and the model's own state vector. The conversions and derived series are vectorised numpy, evaluated once after a
run (never per step in Python).

Frames (docs/theory/model.md#conventions): with 3̂ = (sinθ sinφ, −sinθ cosφ, cosθ) the horizontal frame is
x̂ = (sinφ, −cosφ, 0), ŷ = ẑ × 3̂ / sinθ = (cosφ, sinφ, 0), the Resal frame 2̂ = ŷ, 1̂ = 2̂ × 3̂, and
ω = −φ̇ sinθ 1̂ + θ̇ 2̂ + ω3 3̂. The vector models use the contact vector a = l 3̂ − R ẑ with
l = Rα (the tippe top), which also covers the gliding heavy symmetric top (R = 0, docs/theory/reduced.md#reduced-systems).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from ..integrals import integrals_of
from .registry import Model, Params

if TYPE_CHECKING:
    from ..state import State
    from ..top import TippeTop

__all__ = [
    "Model",
    "add_integrals",
    "axis_theta",
    "cross3",
    "dot3",
    "euler_from_vectors",
    "euler_params",
    "lab_vectors",
    "scales_from_state",
    "tippe_params",
    "unit_axis",
]


def tippe_params(top: TippeTop, options: dict) -> Params:
    """(m, R, l, I1, I3, mu, g) with l = Rα: the parameter tuple of the vector models."""
    return (top.m, top.R, top.R * top.alpha, top.I1, top.I3, top.mu, top.g)


def euler_params(top: TippeTop, options: dict) -> Params:
    """(m, R, alpha, I1, I3, mu, g): the parameter tuple of the Euler-angle forms."""
    return (top.m, top.R, top.alpha, top.I1, top.I3, top.mu, top.g)


# --- State -> lab-frame vectors --------------------------------------------------------------


def unit_axis(Y: np.ndarray, start: int) -> np.ndarray:
    """The normalised axis 3̂/|3̂| stored at rows ``start:start+3`` of vector states ``Y``.

    No integrator keeps |3̂| = 1 exactly; derived quantities use the normalised axis.
    """
    e = np.asarray(Y[start : start + 3], dtype=float)
    return e / np.sqrt(dot3(e, e))


def dot3(a: Any, b: Any) -> Any:
    """a·b over the first axis of two 3-vectors (or arrays of shape (3, k)).

    Written out: np.sum(a * b, axis=0) adds in the same order but costs a reduction call (and
    np.cross several moveaxis calls) per use, which made up much of the fixed cost of a Trajectory.
    """
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def cross3(a: Any, b: Any) -> np.ndarray:
    """a × b over the first axis of two 3-vectors (or arrays of shape (3, k)), as np.cross."""
    return np.array(
        [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
    )


def axis_theta(Y: np.ndarray, start: int) -> np.ndarray:
    """θ from the axis rows of vector states, via atan2 (accurate at the poles, unlike arccos)."""
    e = unit_axis(Y, start)
    return np.arctan2(np.hypot(e[0], e[1]), e[2])


def lab_vectors(state: State, R: float, l: float) -> dict[str, np.ndarray]:
    """Lab-frame 3̂, ω, ν and CM velocity of a scalar State, with φ = 0 and the CM over the origin.

    With φ = 0: 3̂ = (0, −sinθ, cosθ), ŷ = 2̂ = (1, 0, 0), x̂ = (0, −1, 0), 1̂ = 2̂ × 3̂ = (0, −cosθ, −sinθ).
    The CM velocity is ṙ = ν − ω × a (a = l 3̂ − R ẑ); its vertical part is then automatically the
    rate of change of the CM height R − l cosθ.
    """
    th = float(state.theta)
    # exact poles: sin(pi) is 1.2e-16 in floating point, which would tilt the axis by that much
    s = 0.0 if th in (0.0, math.pi) else math.sin(th)
    c = math.cos(th)
    phd, thd, w3 = float(state.phidot), float(state.thetadot), float(state.omega3)
    # written out in floats (a start is one state; numpy on 3-vectors cost 20 µs a run):
    # e1 = 2̂ × 3̂ = (0, −c, −s), ω = −φ̇ s e1 + θ̇ 2̂ + ω3 3̂, ν = ν_x x̂ + ν_y 2̂, a = l 3̂ − R ẑ
    w = (thd, phd * s * c - w3 * s, phd * s * s + w3 * c)
    nu = (float(state.nu_y), -float(state.nu_x), 0.0)
    a = (0.0, -l * s, l * c - R)
    wa = (w[1] * a[2] - w[2] * a[1], w[2] * a[0] - w[0] * a[2], w[0] * a[1] - w[1] * a[0])
    v = (nu[0] - wa[0], nu[1] - wa[1], nu[2] - wa[2])
    return {
        "e3": np.array([0.0, -s, c]),
        "omega": np.array(w),
        "nu": np.array(nu),
        "v": np.array(v),
    }


# --- lab-frame vectors -> reduced (Euler) variables, vectorised -------------------------------


def euler_from_vectors(e: np.ndarray, omega: np.ndarray, nu: np.ndarray) -> dict[str, np.ndarray]:
    """θ, φ, θ̇, φ̇, ω3, ψ̇, ν_x, ν_y from the unit axis 3̂, ω and the slip ν (arrays of shape (3, k)).

    θ = atan2(|3̂ × ẑ|, 3̂·ẑ) (accurate near both poles, unlike arccos), φ from the horizontal
    projection of 3̂, ω3 = ω·3̂, θ̇ = ω·ŷ, φ̇ = −ω·1̂ / sinθ, ψ̇ = ω3 − φ̇ cosθ, ν_x = ν·x̂, ν_y = ν·ŷ.

    At exactly sinθ = 0 the angles φ, ψ and the split of ν into (ν_x, ν_y) are undefined. We then take
    φ = 0 (x̂ = (0, −1, 0), ŷ = (1, 0, 0)), φ̇ = 0 (all rotation about the axis is spin, ψ̇ = ω3) and
    θ̇ = ±|3̂̇| (+ at θ = 0, − at θ = π: a polar angle can only leave its pole). Everything stays finite.
    """
    ex, ey, ez = e
    s = np.hypot(ex, ey)
    pole = s == 0.0
    safe = np.where(pole, 1.0, s)
    theta = np.arctan2(s, ez)
    cth = ez
    xhx = np.where(pole, 0.0, ex / safe)
    xhy = np.where(pole, -1.0, ey / safe)
    # ŷ = ẑ × x̂ = (−x̂_y, x̂_x, 0)
    yhx, yhy = -xhy, xhx
    phi = np.arctan2(xhx, -xhy)
    wx, wy, wz = omega
    omega3 = wx * ex + wy * ey + wz * ez
    thetadot = wx * yhx + wy * yhy
    # 1̂ = ŷ × 3̂ = (ŷ_y e_z, −ŷ_x e_z, ŷ_x e_y − ŷ_y e_x)
    w1 = wx * (yhy * ez) - wy * (yhx * ez) + wz * (yhx * ey - yhy * ex)
    with np.errstate(divide="ignore", invalid="ignore"):
        phidot = np.where(pole, 0.0, -w1 / safe)
    edot = cross3(omega, e)
    speed = np.sqrt(dot3(edot, edot))
    thetadot = np.where(pole, np.where(ez > 0, speed, -speed), thetadot)
    nu_x = nu[0] * xhx + nu[1] * xhy
    nu_y = nu[0] * yhx + nu[1] * yhy
    return {
        "theta": theta,
        "phi": phi,
        "thetadot": thetadot,
        "phidot": phidot,
        "omega3": omega3,
        "psidot": omega3 - phidot * cth,
        "nu_x": nu_x,
        "nu_y": nu_y,
    }


def add_integrals(
    out: dict[str, Any], m: float, R: float, l: float, I1: float, I3: float, g: float
) -> dict[str, Any]:
    """Add E, Ẽ ("E_mod"), D and λ ("lam") of the reduced series in ``out`` (and return it).

    ``out`` holds θ, θ̇, φ̇, ω3, ν_x, ν_y (as :func:`euler_from_vectors` returns them); the
    integrals are those of :mod:`mett.integrals` with the contact vector a = l 3̂ − R ẑ.
    """
    th, thd, phd, w3 = out["theta"], out["thetadot"], out["phidot"], out["omega3"]
    out.update(integrals_of(th, thd, phd, w3, out["nu_x"], out["nu_y"], m, R, l, I1, I3, g))
    return out


def scales_from_state(
    omega: np.ndarray, v: np.ndarray, R: float, l: float, I1: float, I3: float, g: float
) -> dict[str, float]:
    """Typical magnitudes (length, velocity, angular velocity, angular momentum) for atol.

    The angular-momentum scale is 1 % of I|ω|: the horizontal components of L are small and the
    Jellett integral λ = −L·a depends on them. With I|ω| itself, λ drifted by 1.7e-9 (relative)
    over the thesis run at rtol = 1e-10; with 1 % it drifts by 2e-10 for 10 % more work.
    """
    length = max(R, abs(l))
    w = max(math.hypot(*map(float, omega)), math.sqrt(g / length))
    return {
        "length": length,
        "velocity": length * w + math.hypot(*map(float, v)),
        "omega": w,
        "momentum": 0.01 * max(I1, I3) * w,
    }
