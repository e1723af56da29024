"""The rolling-and-gliding tippe top in vector form (Rutstam 2012 §2; docs/theory/equations.md#vector-form).

Equations of motion, in lab coordinates, for an eccentric sphere touching the plane at A::

    m r̈ = F − m g ẑ,    L̇ = a × F,    3̂̇ = ω × 3̂,
    F = g_n ẑ − μ g_n ν,    ν = v_A = ṙ + ω × a   (horizontal),    a = l 3̂ − R ẑ,  l = Rα.

The state is ``y = [x, y, ẋ, ẏ, L_x, L_y, L_z, 3̂_x, 3̂_y, 3̂_z]``: horizontal position and velocity of
the centre of mass, the angular momentum about the CM and the symmetry axis. The CM height
R − l 3̂_z and its rate are fixed by the contact constraint (r + a)·ẑ = 0, so they are not stored.
Unlike the Euler-angle form (thesis eqs (10)–(15)), this has no singularity at θ = 0 or π.

Normal force (docs/theory/equations.md#vector-form), from m (g + d²/dt² of the CM height) = g_n::

    c = 1/I3 − 1/I1,  K = a × (ẑ − μν),  W = K/I1 + c (K·3̂) 3̂,  W0 = c (L·3̂) 3̂̇,
    ω̇ = g_n W + W0,
    g_n = m [g − l ((W0 × 3̂ + ω × 3̂̇)·ẑ)] / [1 + m l (W × 3̂)·ẑ].

The axis is used normalised, 3̂/|3̂|, everywhere: no integrator keeps |3̂| = 1 exactly,
and 3̂̇ = ω × 3̂/|3̂| still leaves |3̂| invariant in exact arithmetic.

The same right-hand side with R = 0 is the gliding heavy symmetric top (docs/theory/reduced.md#reduced-systems), see
:mod:`mett.dynamics.reduced`.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..friction import Coulomb, RegularisedCoulomb, Viscous
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

__all__ = [
    "MODEL",
    "gliding_core",
    "gliding_normal_force",
    "gliding_rhs",
    "gliding_series",
    "viscous_force",
]

N_STATE = 10


def gliding_core(y: Any, p: tuple) -> tuple:
    """Time derivatives and g_n; plain arithmetic, so ``y`` may hold floats or equal-shape arrays.

    Returns ``(ẋ, ẏ, ẍ, ÿ, L̇_x, L̇_y, L̇_z, 3̂̇_x, 3̂̇_y, 3̂̇_z, g_n, ω, ν)``.

    The formulas of the module docstring, simplified with |3̂| = 1 (each step saves products,
    which is most of the cost of a Taylor step): ω × 3̂ = (L × 3̂)/I1, since the part of ω along
    3̂ drops out; (W × 3̂)·ẑ = ((K × 3̂)·ẑ)/I1 for the same reason; and
    ((W0 × 3̂) + (ω × 3̂̇))·ẑ = ((L × 3̂̇)·ẑ)/I1, because W0 × 3̂ = c (L·3̂)(3̂̇ × 3̂) cancels the
    part c (L·3̂) 3̂ of ω. With a = l 3̂ − R ẑ, ω × a = l 3̂̇ − R ω × ẑ.
    """
    m, R, l, I1, I3, mu, g = p
    vx, vy = y[2], y[3]
    Lx, Ly, Lz = y[4], y[5], y[6]
    n = (y[7] * y[7] + y[8] * y[8] + y[9] * y[9]) ** 0.5
    ex, ey, ez = y[7] / n, y[8] / n, y[9] / n
    cLe = (1.0 / I3 - 1.0 / I1) * (Lx * ex + Ly * ey + Lz * ez)  # (1/I3 − 1/I1) I3 ω3
    # ω = L/I1 + (1/I3 − 1/I1)(L·3̂) 3̂: the inverse of the inertia tensor I1 𝟙 + (I3 − I1) 3̂3̂ᵀ
    wx = Lx / I1 + cLe * ex
    wy = Ly / I1 + cLe * ey
    wz = Lz / I1 + cLe * ez
    dex = (Ly * ez - Lz * ey) / I1  # 3̂̇ = ω × 3̂ = (L × 3̂)/I1
    dey = (Lz * ex - Lx * ez) / I1
    dez = (Lx * ey - Ly * ex) / I1
    # ν = ṙ + ω × a = ṙ + l 3̂̇ − R ω × ẑ; its vertical part vanishes by the contact constraint
    nux = vx + l * dex - R * wy
    nuy = vy + l * dey + R * wx
    ux, uy = -mu * nux, -mu * nuy  # ẑ − μν = (ux, uy, 1)
    ax, ay, az = l * ex, l * ey, l * ez - R
    Kx = ay - az * uy  # K = a × (ẑ − μν)
    Ky = az * ux - ax
    Kz = ax * uy - ay * ux
    # g_n = m [g − l ((W0 × 3̂ + ω × 3̂̇)·ẑ)] / [1 + m l (W × 3̂)·ẑ], simplified as above
    q = (Lx * dey - Ly * dex) / I1
    gn = m * (g - l * q) / (1.0 + (m * l / I1) * (Kx * ey - Ky * ex))
    f = -mu * gn / m
    return (
        vx,
        vy,
        f * nux,
        f * nuy,
        gn * Kx,
        gn * Ky,
        gn * Kz,
        dex,
        dey,
        dez,
        gn,
        (wx, wy, wz),
        (nux, nuy),
    )


def gliding_rhs(t: float, y: np.ndarray, p: tuple) -> np.ndarray:
    """Right-hand side of the gliding tippe top in vector form (docs/theory/equations.md#vector-form).

    Parameters
    ----------
    t : float
        Time (s); the system is autonomous.
    y : ndarray, shape (10,)
        ``[x, y, ẋ, ẏ, L_x, L_y, L_z, 3̂_x, 3̂_y, 3̂_z]`` (lab frame; L about the CM).
    p : tuple
        ``(m, R, l, I1, I3, mu, g)`` with ``l = R alpha``; ``R = 0`` gives the gliding heavy
        symmetric top.

    Returns
    -------
    ndarray, shape (10,)
    """
    d = gliding_core(y, p)
    return np.array(d[:10])


def gliding_normal_force(y: np.ndarray, p: tuple) -> Any:
    """Normal force g_n (N) of state(s) ``y`` (shape (10,) or (10, k)), docs/theory/equations.md#vector-form."""
    return gliding_core(y, p)[10]


def _normal_force(y: Any, p: tuple) -> Any:
    """:func:`gliding_normal_force`, the model's ``normal_force`` (called from Python only, at
    the start of each run): one state in float arithmetic, the same IEEE operations at a third
    of the cost of numpy scalars'. :func:`gliding_normal_force` itself stays plain arithmetic, so
    compiled code may call it."""
    if isinstance(y, np.ndarray) and y.ndim == 1:
        try:
            return gliding_core(y.tolist(), p)[10]
        except ArithmeticError:  # a division by zero: numpy's inf or NaN, as for arrays
            pass
    return gliding_core(y, p)[10]


def _rhs_into(t: float, y: Any, p: Any, out: Any) -> None:
    """:func:`gliding_rhs` written into ``out``: the form the compiled integrator calls.

    Plain Python on purpose: :mod:`mett.dynamics._kernels` compiles this function and :func:`gliding_core`
    with numba, so the physics is written once (and ``import mett`` does not import numba).
    """
    d = gliding_core(y, p)
    out[0], out[1], out[2], out[3], out[4] = d[0], d[1], d[2], d[3], d[4]
    out[5], out[6], out[7], out[8], out[9] = d[5], d[6], d[7], d[8], d[9]


def _contact(t: float, y: Any, p: Any) -> Any:
    """The contact event g_n/(m g): terminal when it falls through 0 (compiled like _rhs_into)."""
    return gliding_core(y, p)[10] * (1.0 / (p[ix.M] * p[ix.G]))


def _initial(state: Any, p: tuple) -> np.ndarray:
    m, R, l, I1, I3, mu, g = p
    v = lab_vectors(state, R, l)
    e, w, vel = v["e3"].tolist(), v["omega"].tolist(), v["v"].tolist()
    c = (I3 - I1) * (w[0] * e[0] + w[1] * e[1] + w[2] * e[2])  # L = I1 ω + (I3 − I1)(ω·3̂) 3̂
    L = [I1 * w[i] + c * e[i] for i in range(3)]
    return np.array([0.0, 0.0, vel[0], vel[1], *L, *e])


def _theta(Y: np.ndarray, p: tuple) -> np.ndarray:
    return axis_theta(Y, 7)


def gliding_series(Y: np.ndarray, p: tuple) -> dict[str, np.ndarray]:
    """θ, φ, θ̇, φ̇, ψ̇, ω3, ν, E, Ẽ, D, λ and g_n of vector states ``Y`` (shape (10, k)) of a
    sphere with parameters ``p`` = (m, R, l, I1, I3, mu, g); integrals straight from the vectors
    (pole-safe). Also the series of each contact of the stemmed top."""
    m, R, l, I1, I3, mu, g = p
    Y = np.asarray(Y, dtype=float)
    d = gliding_core(Y, p)
    e = unit_axis(Y, 7)
    w = np.array(d[11])
    nu = np.array([d[12][0], d[12][1], np.zeros_like(d[12][0])])
    out = euler_from_vectors(e, w, nu)
    add_integrals(out, m, R, l, I1, I3, g)
    out["gn"] = np.asarray(d[10], dtype=float)
    return out


def _derive(Y: np.ndarray, p: tuple) -> dict[str, np.ndarray]:
    """Trajectory series from vector states (:func:`gliding_series`) and the CM position."""
    out = gliding_series(Y, p)
    out["x"], out["y"] = Y[0], Y[1]
    return out


def _scales(y0: np.ndarray, p: tuple) -> np.ndarray:
    m, R, l, I1, I3, mu, g = p
    # one state as a list of floats: plain arithmetic on floats is 3x faster than on numpy scalars
    w = gliding_core(np.asarray(y0, dtype=float).tolist(), p)[11]
    sc = scales_from_state(w, y0[2:4], R, l, I1, I3, g)
    # Axis scale 0.1, not 1: near the upright start the horizontal components of 3̂ are O(θ) ≪ 1.
    # Measured on the thesis run at rtol = 1e-10: pointwise θ error 1.3e-6 → 1.7e-7 for 15 % more
    # work (0.01 gains another factor 3 for 25 % more).
    return np.array([sc["length"]] * 2 + [sc["velocity"]] * 2 + [sc["momentum"]] * 3 + [0.1] * 3)


def _cos_theta(t: float, y: Any, p: Any) -> Any:
    return y[9]  # 3̂_z (its sign and zeros are those of cos θ, whatever |3̂| drifts to)


VECTORS = ((0, 1), (2, 3), (4, 5, 6), (7, 8, 9))
"""The state's vectors: horizontal position and velocity of the centre of mass, L, 3̂."""

MODEL = register(
    Model(
        name="gliding",
        summary="rolling-and-gliding tippe top, vector form (docs/theory/equations.md#vector-form; Rutstam 2012 §2)",
        rhs=gliding_rhs,
        rhs_into=_rhs_into,
        normal_force=_normal_force,
        params=tippe_params,
        initial=_initial,
        derive=_derive,
        theta=_theta,
        scales=_scales,
        events=(Event(_contact, -1.0, "contact_lost"),),
        conserves=("lam",),
        vectors=VECTORS,
        cos_theta=_cos_theta,
        conserved_lengths=((7, 8, 9),),
        # a dry law hands the run over to the model that runs it (mett.simulate)
        friction=(type(None), Viscous, Coulomb, RegularisedCoulomb),
        mu_free_start=True,  # _initial and _scales read m, R, l, I1, I3, g
    )
)


def viscous_force(traj: Any, mu: float) -> dict[str, np.ndarray]:
    """``F_x``, ``F_y`` = −μ g_n v_A (N, lab frame) and ``M_n`` = 0 of a viscous run.

    So that a run with ``friction=Viscous(...)`` reports its friction force as the dry laws' runs
    do (Rutstam 2013, thesis eq. (3)); v_A = (ν_x, ν_y) and g_n are the run's derived series.

    Parameters
    ----------
    traj : mett.Trajectory
        The finished run (not changed).
    mu : float
        The viscous coefficient μ (s/m) the run used (``top.mu``).

    Returns
    -------
    dict
        The three series by name, for :meth:`mett.Trajectory.with_extras`; empty for a model
        without those series (no contact slip velocity).
    """
    try:
        nu = np.stack([np.asarray(traj.nu_x, dtype=float), np.asarray(traj.nu_y, dtype=float)])
        gn = np.asarray(traj.gn, dtype=float)
    except AttributeError:
        return {}
    F, M = Viscous(mu).force(nu, gn)
    return {"F_x": F[0], "F_y": F[1], "M_n": M}
