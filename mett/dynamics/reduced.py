"""Reduced systems of the tippe top (Rutstam 2012 §5–6; docs/theory/reduced.md#reduced-systems).

**Gliding heavy symmetric top (GHST), model "gliding-hst".** The tippe-top equations in the limit
R → 0, α → ∞ with Rα = l fixed: a symmetric top (mass m, inertias I1, I3 about its CM) whose
symmetry axis ends in a sharp tip at distance l from the CM, gliding with the same viscous-type
friction F = g_n ẑ − μ g_n ν. The contact vector becomes a = l 3̂, the CM height −l cos θ, the
potential −m g l cos θ. In :func:`mett.simulate` the tip distance is ``l = top.R * top.alpha``
unless ``l=`` is passed, and R is set to 0; m, I1, I3, μ, g are the top's. The state keeps the
tippe-top meaning (θ is the angle of 3̂ from ẑ, ν the velocity of the tip), so the top stands on its
tip with the CM above it when cos θ < 0, i.e. near θ = π. The vector right-hand side is the
tippe-top one (:func:`mett.dynamics.gliding.gliding_rhs`) with R = 0; the Euler-angle form of
docs/theory/reduced.md#reduced-systems is :func:`hst_euler_rhs`, used as a cross-check. Jellett's integral reduces to
λ = −l I3 ω3 and ω3 is itself conserved.

**Gliding eccentric cylinder, model "cylinder".** The subspace φ̇ = ω3 = ν_y = 0 of the tippe top is
invariant; on it the sphere rocks in a vertical plane like an eccentric cylinder with moment of
inertia I1 about its axis::

    θ̈   = −(Rα g_n/I1) sin θ + (Rμ g_n ν_x/I1)(1 − α cos θ)
    ν̇_x = (R sin θ/I1)(g_n Rα(1 − α cos θ) − I1 α θ̇²) − (μ g_n ν_x/(m I1))(I1 + mR²(1 − α cos θ)²)
    g_n = (m g I1 + mRα I1 θ̇² cos θ) / (I1 + mR²α² sin²θ − mR²α sin θ(1 − α cos θ) μ ν_x)

State ``[θ_s, θ̇_s, ν_x,s, X]``: θ_s is a *signed* rocking angle in the fixed plane of the start
(φ = 0), so the rocking passes through θ = 0 without a singularity (the equations are invariant
under (θ, θ̇, ν_x) → −(θ, θ̇, ν_x)), and X is the CM position along the fixed x̂ = (0, −1, 0). The
Trajectory reports θ = |θ_s| ∈ [0, π] in the library's convention: when θ_s < 0, φ = π and the
signs of θ̇ and ν_x flip.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from ..friction import Viscous
from . import _params as ix
from . import gliding
from ._model import add_integrals, euler_params, lab_vectors, scales_from_state
from .registry import Event, Model, Option, positive_length, register

__all__ = [
    "CYLINDER",
    "HST",
    "cylinder_normal_force",
    "cylinder_rhs",
    "hst_euler_normal_force",
    "hst_euler_rhs",
]


# --- gliding heavy symmetric top -------------------------------------------------------------


def hst_params(top: Any, options: dict) -> tuple:
    """(m, 0, l, I1, I3, mu, g): the vector right-hand side with R = 0 and l = Rα (or ``l=``)."""
    l = options.get("l")
    if l is None:
        l = top.R * top.alpha
    return (top.m, 0.0, float(l), top.I1, top.I3, top.mu, top.g)


def hst_euler_normal_force(y: Any, params: tuple) -> Any:
    """g_n of the gliding heavy symmetric top, Euler form (docs/theory/reduced.md#reduced-systems); params (m, l, I1, I3, mu, g)."""
    m, l, I1, I3, mu, g = params
    th, thd, phd, w3, nux = y[0], y[1], y[2], y[3], y[4]
    s, c = np.sin(th), np.cos(th)
    num = m * g * I1 + m * l * (
        c * (I1 * phd * phd * s * s + I1 * thd * thd) - I3 * phd * w3 * s * s
    )
    return num / (I1 + m * l * l * s * s + m * l * l * s * c * mu * nux)


def hst_euler_rhs(y: np.ndarray, params: tuple) -> np.ndarray:
    """Euler-angle form of the gliding heavy symmetric top (docs/theory/reduced.md#reduced-systems; Rutstam 2012 §5).

    Parameters
    ----------
    y : array_like, shape (6,) or (6, k)
        ``[θ, θ̇, φ̇, ω3, ν_x, ν_y]`` (ν: velocity of the tip).
    params : tuple
        ``(m, l, I1, I3, mu, g)``.

    Returns
    -------
    ndarray
        ``[θ̇, θ̈, φ̈, ω̇3 (= 0), ν̇_x, ν̇_y]``.
    """
    m, l, I1, I3, mu, g = params
    th, thd, phd, w3, nux, nuy = y[0], y[1], y[2], y[3], y[4], y[5]
    s, c = np.sin(th), np.cos(th)
    gn = hst_euler_normal_force(y, params)
    thdd = (s / I1) * (I1 * phd * phd * c - I3 * w3 * phd - l * gn) - mu * gn * nux * l * c / I1
    phdd = (I3 * thd * w3 - 2.0 * I1 * thd * phd * c - mu * gn * nuy * l) / (I1 * s)
    nuxd = (
        (s / I1)
        * (-l * I3 * phd * w3 * c - gn * l * l * c - I1 * l * (thd * thd + phd * phd * s * s))
        - (mu * gn * nux / (m * I1)) * (I1 + m * l * l * c * c)
        + phd * nuy
    )
    nuyd = -(mu * gn * nuy / (m * I1)) * (I1 + m * l * l) + l * I3 * w3 * thd / I1 - phd * nux
    return np.array([thd, thdd, phdd, 0.0 * w3, nuxd, nuyd])


HST = register(
    dataclasses.replace(
        gliding.MODEL,
        name="gliding-hst",
        summary="gliding heavy symmetric top: the tippe top with R → 0, Rα = l (docs/theory/reduced.md#reduced-systems)",
        params=hst_params,
        options=(Option("l", positive_length, None, "tip distance (m); default R alpha"),),
        conserves=("lam", "omega3"),
        friction=(type(None), Viscous),  # no dry-law handover, unlike "gliding"
    )
)


# --- gliding eccentric cylinder --------------------------------------------------------------


def cylinder_normal_force(y: Any, params: tuple) -> Any:
    """g_n of the eccentric cylinder (docs/theory/reduced.md#reduced-systems); ``y = [θ, θ̇, ν_x, ...]``."""
    m, R, al, I1, I3, mu, g = params
    th, thd, nux = y[0], y[1], y[2]
    s, c = np.sin(th), np.cos(th)
    num = m * g * I1 + m * R * al * I1 * thd * thd * c
    return num / (I1 + m * R * R * al * al * s * s - m * R * R * al * s * (1.0 - al * c) * mu * nux)


def cylinder_rhs(t: float, y: np.ndarray, params: tuple) -> np.ndarray:
    """Right-hand side of the gliding eccentric cylinder (docs/theory/reduced.md#reduced-systems).

    Parameters
    ----------
    t : float
        Time (s); autonomous.
    y : ndarray, shape (4,)
        ``[θ_s, θ̇_s, ν_x, X]``: signed rocking angle and its rate, slip velocity along the fixed
        x̂, CM position along x̂.
    params : tuple
        ``(m, R, alpha, I1, I3, mu, g)`` (I3 unused).
    """
    return np.array(_cylinder_core(y, params))


def _cylinder_core(y: Any, params: Any) -> tuple:
    """(θ̇, θ̈, ν̇_x, Ẋ) of the cylinder; plain arithmetic on floats or equal-shape arrays."""
    m, R, al, I1, I3, mu, g = params
    th, thd, nux = y[0], y[1], y[2]
    s, c = np.sin(th), np.cos(th)
    gn = cylinder_normal_force(y, params)
    thdd = -(R * al * gn / I1) * s + (R * mu * gn * nux / I1) * (1.0 - al * c)
    nuxd = (R * s / I1) * (gn * R * al * (1.0 - al * c) - I1 * al * thd * thd) - (
        mu * gn * nux / (m * I1)
    ) * (I1 + m * R * R * (1.0 - al * c) ** 2)
    # CM velocity along x̂: ν_x − (ω × a)·x̂ = ν_x + R θ̇ (1 − α cos θ)
    return thd, thdd, nuxd, nux + R * thd * (1.0 - al * c)


def _cylinder_rhs_into(t: float, y: Any, params: Any, out: Any) -> None:
    """:func:`cylinder_rhs` written into ``out``, for the compiled integrator (see
    :func:`mett.dynamics.gliding._rhs_into`)."""
    out[0], out[1], out[2], out[3] = _cylinder_core(y, params)


def _cylinder_contact(t: float, y: Any, params: Any) -> Any:
    """The contact event g_n/(m g), for both backends."""
    return cylinder_normal_force(y, params) * (1.0 / (params[ix.M] * params[ix.G]))


def _cyl_initial(state: Any, p: tuple) -> np.ndarray:
    bad = {k: getattr(state, k) for k in ("phidot", "omega3", "nu_y") if getattr(state, k) != 0.0}
    if bad:
        raise ValueError(
            "the cylinder model lives on the subspace phidot = omega3 = nu_y = 0; got "
            + ", ".join(f"{k} = {v!r}" for k, v in bad.items())
        )
    return np.array([state.theta, state.thetadot, state.nu_x, 0.0])


def _wrapped(Y: np.ndarray) -> np.ndarray:
    return (np.asarray(Y[0], dtype=float) + np.pi) % (2.0 * np.pi) - np.pi


def _cyl_theta(Y: np.ndarray, p: tuple) -> np.ndarray:
    return np.abs(_wrapped(Y))


def _cyl_derive(Y: np.ndarray, p: tuple) -> dict[str, np.ndarray]:
    m, R, al, I1, I3, mu, g = p
    Y = np.asarray(Y, dtype=float)
    thw = _wrapped(Y)
    sign = np.where(thw < 0.0, -1.0, 1.0)
    zero = np.zeros_like(thw)
    out = {
        "theta": np.abs(thw),
        "phi": np.where(thw < 0.0, np.pi, 0.0),
        "thetadot": sign * Y[1],
        "phidot": zero,
        "omega3": zero,
        "psidot": zero,
        "nu_x": sign * Y[2],
        "nu_y": zero,
        "gn": np.asarray(cylinder_normal_force(Y, p), dtype=float),
        "x": zero,
        "y": -Y[3],  # x̂ = (0, −1, 0) for φ = 0
    }
    return add_integrals(out, m, R, R * al, I1, I3, g)


def _cyl_scales(y0: np.ndarray, p: tuple) -> np.ndarray:
    from ..state import State

    m, R, al, I1, I3, mu, g = p
    st = State(theta=abs(float(_wrapped(y0))), thetadot=y0[1], nu_x=y0[2])
    v = lab_vectors(st, R, R * al)
    sc = scales_from_state(v["omega"], v["v"], R, R * al, I1, I3, g)
    return np.array([1.0, sc["omega"], sc["velocity"], sc["length"]])


CYLINDER = register(
    Model(
        name="cylinder",
        summary="gliding eccentric cylinder: the invariant subspace phidot = omega3 = nu_y = 0 "
        "(docs/theory/reduced.md#reduced-systems)",
        rhs=cylinder_rhs,
        rhs_into=_cylinder_rhs_into,
        normal_force=cylinder_normal_force,
        params=euler_params,
        initial=_cyl_initial,
        derive=_cyl_derive,
        theta=_cyl_theta,
        scales=_cyl_scales,
        events=(Event(_cylinder_contact, -1.0, "contact_lost"),),
    )
)
