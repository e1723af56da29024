"""The rolling tippe top: the eccentric sphere with its contact point at rest (v_A ≡ 0).

This is the integrable case of the METT (docs/theory/equations.md#integrals, docs/theory/mett.md#the-main-equation; Glad, Petersson & Rauch-Wojciechowski
2007): E, the Routh integral D and the Jellett integral λ are all conserved, and θ oscillates with the
period given by the separation equation (:func:`mett.nutation_period`).

Vector form, lab coordinates, a = l 3̂ − R ẑ, l = Rα, ȧ = l 3̂̇ (derivation as in docs/theory/equations.md#vector-form
with the rolling constraint replacing friction):

* ν = ṙ + ω × a = 0, so ṙ = −ω × a and the contact force is F = m(g ẑ + r̈) = m(g ẑ − ω̇ × a − ω × ȧ);
* L = J ω, J = I1 𝟙 + (I3 − I1) 3̂3̂ᵀ, L̇ = J ω̇ + (I3 − I1) ω3 3̂̇ (because ω·3̂̇ = 0), and L̇ = a × F give

      [J + m(|a|² 𝟙 − a aᵀ)] ω̇ = m a × (g ẑ − ω × ȧ) − (I3 − I1) ω3 3̂̇,

  a symmetric positive definite 3×3 system, solved here by Cramer's rule in plain float arithmetic;
* g_n = F·ẑ.

State ``y = [x, y, ω_x, ω_y, ω_z, 3̂_x, 3̂_y, 3̂_z]`` (CM position, angular velocity, axis).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from . import _params as ix
from ._model import (
    add_integrals,
    axis_theta,
    euler_from_vectors,
    lab_vectors,
    scales_from_state,
    tippe_params,
    unit_axis,
)
from .registry import Event, Model, register

__all__ = ["MODEL", "rolling_normal_force", "rolling_rhs"]


def _core(y: Any, p: tuple) -> tuple:
    """(ẋ, ẏ, ω̇_x, ω̇_y, ω̇_z, 3̂̇_x, 3̂̇_y, 3̂̇_z, g_n, ω × a); floats or equal-shape arrays."""
    m, R, l, I1, I3, mu, g = p
    wx, wy, wz = y[2], y[3], y[4]
    n = (y[5] * y[5] + y[6] * y[6] + y[7] * y[7]) ** 0.5
    ex, ey, ez = y[5] / n, y[6] / n, y[7] / n
    w3 = wx * ex + wy * ey + wz * ez
    dex = wy * ez - wz * ey
    dey = wz * ex - wx * ez
    dez = wx * ey - wy * ex
    ax, ay, az = l * ex, l * ey, l * ez - R
    adx, ady, adz = l * dex, l * dey, l * dez  # ȧ
    # u = g ẑ − ω × ȧ
    ux = -(wy * adz - wz * ady)
    uy = -(wz * adx - wx * adz)
    uz = g - (wx * ady - wy * adx)
    dI = I3 - I1
    bx = m * (ay * uz - az * uy) - dI * w3 * dex
    by = m * (az * ux - ax * uz) - dI * w3 * dey
    bz = m * (ax * uy - ay * ux) - dI * w3 * dez
    a2 = ax * ax + ay * ay + az * az
    d0 = I1 + m * a2
    # M = (I1 + m|a|²) 𝟙 + (I3 − I1) 3̂3̂ᵀ − m a aᵀ (symmetric)
    m11 = d0 + dI * ex * ex - m * ax * ax
    m22 = d0 + dI * ey * ey - m * ay * ay
    m33 = d0 + dI * ez * ez - m * az * az
    m12 = dI * ex * ey - m * ax * ay
    m13 = dI * ex * ez - m * ax * az
    m23 = dI * ey * ez - m * ay * az
    c11 = m22 * m33 - m23 * m23
    c12 = m23 * m13 - m12 * m33
    c13 = m12 * m23 - m22 * m13
    c22 = m11 * m33 - m13 * m13
    c23 = m13 * m12 - m11 * m23
    c33 = m11 * m22 - m12 * m12
    det = m11 * c11 + m12 * c12 + m13 * c13
    wdx = (c11 * bx + c12 * by + c13 * bz) / det
    wdy = (c12 * bx + c22 * by + c23 * bz) / det
    wdz = (c13 * bx + c23 * by + c33 * bz) / det
    # g_n = m(g − (ω̇ × a)_z − (ω × ȧ)_z) = m(uz − (ω̇ × a)_z)
    gn = m * (uz - (wdx * ay - wdy * ax))
    wax = wy * az - wz * ay
    way = wz * ax - wx * az
    waz = wx * ay - wy * ax
    return (-wax, -way, wdx, wdy, wdz, dex, dey, dez, gn, (wax, way, waz))


def rolling_rhs(t: float, y: np.ndarray, p: tuple) -> np.ndarray:
    """Right-hand side of the rolling tippe top (v_A ≡ 0), vector form.

    Parameters
    ----------
    t : float
        Time (s); autonomous.
    y : ndarray, shape (8,)
        ``[x, y, ω_x, ω_y, ω_z, 3̂_x, 3̂_y, 3̂_z]`` (CM position, lab-frame ω and symmetry axis).
    p : tuple
        ``(m, R, l, I1, I3, mu, g)`` with ``l = R alpha`` (``mu`` unused).
    """
    return np.array(_core(y, p)[:8])


def rolling_normal_force(y: np.ndarray, p: tuple) -> Any:
    """Normal force g_n = F·ẑ of the rolling top."""
    return _core(y, p)[8]


def _rhs_into(t: float, y: Any, p: Any, out: Any) -> None:
    """:func:`rolling_rhs` written into ``out``, for the compiled integrator (see
    :func:`mett.dynamics.gliding._rhs_into`)."""
    d = _core(y, p)
    out[0], out[1], out[2], out[3] = d[0], d[1], d[2], d[3]
    out[4], out[5], out[6], out[7] = d[4], d[5], d[6], d[7]


def _contact(t: float, y: Any, p: Any) -> Any:
    """The contact event g_n/(m g), for both backends."""
    return _core(y, p)[8] * (1.0 / (p[ix.M] * p[ix.G]))


def _initial(state: Any, p: tuple) -> np.ndarray:
    m, R, l, I1, I3, mu, g = p
    if state.nu_x != 0.0 or state.nu_y != 0.0:
        raise ValueError(
            "the rolling model needs a contact point at rest: nu_x = nu_y = 0; "
            f"got nu_x = {state.nu_x!r}, nu_y = {state.nu_y!r}"
        )
    v = lab_vectors(state, R, l)
    return np.concatenate(([0.0, 0.0], v["omega"], v["e3"]))


def _theta(Y: np.ndarray, p: tuple) -> np.ndarray:
    return axis_theta(Y, 5)


def _derive(Y: np.ndarray, p: tuple) -> dict[str, np.ndarray]:
    m, R, l, I1, I3, mu, g = p
    Y = np.asarray(Y, dtype=float)
    d = _core(Y, p)
    e = unit_axis(Y, 5)
    w = Y[2:5]
    out = euler_from_vectors(e, w, np.zeros_like(w))
    add_integrals(out, m, R, l, I1, I3, g)
    out["gn"] = np.asarray(d[8], dtype=float)
    out["x"], out["y"] = Y[0], Y[1]
    return out


def _scales(y0: np.ndarray, p: tuple) -> np.ndarray:
    m, R, l, I1, I3, mu, g = p
    w = y0[2:5]
    sc = scales_from_state(w, np.zeros(3), R, l, I1, I3, g)
    return np.array([sc["length"]] * 2 + [sc["omega"]] * 3 + [1.0] * 3)


def _cos_theta(t: float, y: Any, p: Any) -> Any:
    return y[7]  # 3̂_z


MODEL = register(
    Model(
        name="rolling",
        summary="rolling tippe top (v_A = 0; E, D, λ conserved), vector form (docs/theory/equations.md#integrals, docs/theory/mett.md#the-main-equation)",
        rhs=rolling_rhs,
        rhs_into=_rhs_into,
        normal_force=rolling_normal_force,
        params=tippe_params,
        initial=_initial,
        derive=_derive,
        theta=_theta,
        scales=_scales,
        conserved_lengths=((5, 6, 7),),
        events=(Event(_contact, -1.0, "contact_lost"),),
        conserves=("lam", "D", "E"),
        vectors=((0, 1), (2, 3, 4), (5, 6, 7)),
        cos_theta=_cos_theta,
    )
)
