"""The gliding tippe top in Euler angles (Rutstam 2012 §2; thesis eqs (10)–(15); docs/theory/equations.md#euler-form).

State ``(θ, θ̇, φ̇, ω3, ν_x, ν_y)``, with s = sin θ, c = cos θ::

    θ̈   = (s/I1)(I1 φ̇² c − I3 ω3 φ̇ − Rα g_n) + (Rμ g_n ν_x/I1)(1 − αc)
    φ̈   = [I3 θ̇ ω3 − 2 I1 θ̇ φ̇ c − μ g_n ν_y R(α − c)] / (I1 s)
    ω̇3  = −μ g_n ν_y R s / I3
    ν̇_x = (R s/I1)[φ̇ ω3 (I3(1 − αc) − I1) + g_n Rα(1 − αc) − I1 α(θ̇² + φ̇² s²)]
           − (μ g_n ν_x/(m I1))[I1 + mR²(1 − αc)²] + φ̇ ν_y
    ν̇_y = −(μ g_n ν_y/(m I1 I3))[I1 I3 + mR² I3(α − c)² + mR² I1 s²]
           + (ω3 θ̇ R/I1)[I3(α − c) + I1 c] − φ̇ ν_x
    g_n = [m g I1 + mRα(c(I1 φ̇² s² + I1 θ̇²) − I3 φ̇ ω3 s²)] / [I1 + mR²α² s² − mR²α s(1 − αc) μ ν_x]

The φ̈ equation is singular at sin θ = 0: this form is a cross-check of the vector form
(:mod:`mett.dynamics.gliding`) away from the poles, and the model "gliding-euler" stops with status
"failed" if sin θ falls below :data:`POLE_GUARD`.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from . import _params as ix
from ._model import add_integrals, euler_params, lab_vectors, scales_from_state
from .registry import Event, Model, register

__all__ = [
    "MODEL",
    "POLE_GUARD",
    "cm_velocity_horizontal",
    "euler_normal_force",
    "euler_rhs",
    "pole_guard",
]

POLE_GUARD = 1e-6
"""The "gliding-euler" model stops (status "failed") when sin θ drops below this."""


def euler_normal_force(y: Any, params: tuple) -> Any:
    """Normal force g_n of the Euler form (thesis eq. (15); docs/theory/equations.md#euler-form).

    ``y = [θ, θ̇, φ̇, ω3, ν_x, ν_y, ...]`` (floats or equal-shape arrays), ``params = (m, R, alpha,
    I1, I3, mu, g)``.
    """
    m, R, al, I1, I3, mu, g = params
    th, thd, phd, w3, nux = y[0], y[1], y[2], y[3], y[4]
    s, c = np.sin(th), np.cos(th)
    num = m * g * I1 + m * R * al * (
        c * (I1 * phd * phd * s * s + I1 * thd * thd) - I3 * phd * w3 * s * s
    )
    den = I1 + m * R * R * al * al * s * s - m * R * R * al * s * (1.0 - al * c) * mu * nux
    return num / den


def _euler_core(y: Any, params: tuple) -> tuple:
    m, R, al, I1, I3, mu, g = params
    th, thd, phd, w3, nux, nuy = y[0], y[1], y[2], y[3], y[4], y[5]
    s, c = np.sin(th), np.cos(th)
    gn = euler_normal_force(y, params)
    thdd = (s / I1) * (I1 * phd * phd * c - I3 * w3 * phd - R * al * gn) + (
        R * mu * gn * nux / I1
    ) * (1.0 - al * c)
    phdd = (I3 * thd * w3 - 2.0 * I1 * thd * phd * c - mu * gn * nuy * R * (al - c)) / (I1 * s)
    w3d = -mu * gn * nuy * R * s / I3
    nuxd = (
        (R * s / I1)
        * (
            phd * w3 * (I3 * (1.0 - al * c) - I1)
            + gn * R * al * (1.0 - al * c)
            - I1 * al * (thd * thd + phd * phd * s * s)
        )
        - (mu * gn * nux / (m * I1)) * (I1 + m * R * R * (1.0 - al * c) ** 2)
        + phd * nuy
    )
    # I1 I3 + mR² I3 (α − c)² + mR² I1 s² = I3² d(c)
    nuyd = (
        -(mu * gn * nuy / (m * I1 * I3))
        * (I1 * I3 + m * R * R * I3 * (al - c) ** 2 + m * R * R * I1 * s * s)
        + (w3 * thd * R / I1) * (I3 * (al - c) + I1 * c)
        - phd * nux
    )
    return thd, thdd, phdd, w3d, nuxd, nuyd, gn


def euler_rhs(y: np.ndarray, params: tuple) -> np.ndarray:
    """Right-hand side of the Euler-angle form (thesis eqs (10)–(15); docs/theory/equations.md#euler-form).

    Parameters
    ----------
    y : array_like, shape (6,) or (6, k)
        ``[θ, θ̇, φ̇, ω3, ν_x, ν_y]``.
    params : tuple
        ``(m, R, alpha, I1, I3, mu, g)``.

    Returns
    -------
    ndarray
        ``[θ̇, θ̈, φ̈, ω̇3, ν̇_x, ν̇_y]``, same trailing shape as ``y``. Singular (division by
        sin θ) at θ = 0 and π.
    """
    return np.array(_euler_core(y, params)[:6])


def cm_velocity_horizontal(y: Any, params: tuple) -> tuple:
    """CM velocity along x̂ and ŷ: ṙ = ν − ω × a (docs/theory/model.md#conventions, horizontal frame)."""
    m, R, al, I1, I3, mu, g = params
    th, thd, phd, w3, nux, nuy = y[0], y[1], y[2], y[3], y[4], y[5]
    s, c = np.sin(th), np.cos(th)
    return nux + R * thd * (1.0 - al * c), nuy - R * s * (w3 + phd * (al - c))


def _rhs(t: float, y: np.ndarray, params: tuple) -> np.ndarray:
    """Euler form extended by φ and the CM position: y = [θ, θ̇, φ̇, ω3, ν_x, ν_y, φ, x, y]."""
    return np.array(_extended_core(y, params))


def _extended_core(y: Any, params: Any) -> tuple:
    d = _euler_core(y, params)
    vxh, vyh = cm_velocity_horizontal(y, params)
    sp, cp = np.sin(y[6]), np.cos(y[6])
    # x̂ = (sinφ, −cosφ, 0), ŷ = (cosφ, sinφ, 0)
    return (d[0], d[1], d[2], d[3], d[4], d[5], y[2], vxh * sp + vyh * cp, -vxh * cp + vyh * sp)


def _rhs_into(t: float, y: Any, params: Any, out: Any) -> None:
    """:func:`_rhs` written into ``out``, for the compiled integrator (see
    :func:`mett.dynamics.gliding._rhs_into`)."""
    d = _extended_core(y, params)
    out[0], out[1], out[2], out[3], out[4] = d[0], d[1], d[2], d[3], d[4]
    out[5], out[6], out[7], out[8] = d[5], d[6], d[7], d[8]


def _contact(t: float, y: Any, params: Any) -> Any:
    """The contact event g_n/(m g), for both backends."""
    return euler_normal_force(y, params) * (1.0 / (params[ix.M] * params[ix.G]))


def _initial(state: Any, p: tuple) -> np.ndarray:
    return np.array([*state.as_array(), 0.0, 0.0, 0.0])


def _theta(Y: np.ndarray, p: tuple) -> np.ndarray:
    return np.asarray(Y[0], dtype=float)


def _derive(Y: np.ndarray, p: tuple) -> dict[str, np.ndarray]:
    m, R, al, I1, I3, mu, g = p
    Y = np.asarray(Y, dtype=float)
    th, thd, phd, w3, nux, nuy = Y[:6]
    out = {
        "theta": th,
        "thetadot": thd,
        "phidot": phd,
        "omega3": w3,
        "psidot": w3 - phd * np.cos(th),
        "nu_x": nux,
        "nu_y": nuy,
        "phi": Y[6],
        "x": Y[7],
        "y": Y[8],
        "gn": np.asarray(euler_normal_force(Y, p), dtype=float),
    }
    return add_integrals(out, m, R, R * al, I1, I3, g)


def _scales(y0: np.ndarray, p: tuple) -> np.ndarray:
    from ..state import State

    m, R, al, I1, I3, mu, g = p
    v = lab_vectors(State.from_array(y0[:6]), R, R * al)
    sc = scales_from_state(v["omega"], v["v"], R, R * al, I1, I3, g)
    w, vel = sc["omega"], sc["velocity"]
    return np.array([1.0, w, w, w, vel, vel, 1.0, sc["length"], sc["length"]])


def pole_guard(t: float, y: Any, p: Any) -> Any:
    """sin θ − :data:`POLE_GUARD` of a state whose first entry is θ: the guard of the Euler-angle
    forms (this one and the Routhian's). Signed, so a step that jumps across θ = 0 or π changes
    its sign (|sin θ| would not)."""
    return np.sin(y[0]) - POLE_GUARD


MODEL = register(
    Model(
        name="gliding-euler",
        summary="gliding tippe top in Euler angles, thesis eqs (10)–(15) "
        "(cross-check; singular at the poles)",
        rhs=_rhs,
        rhs_into=_rhs_into,
        normal_force=euler_normal_force,
        params=euler_params,
        initial=_initial,
        derive=_derive,
        theta=_theta,
        scales=_scales,
        events=(
            Event(_contact, -1.0, "contact_lost"),
            Event(
                pole_guard,
                -1.0,
                "fail",
                f"the Euler-angle form is singular at sin(theta) = 0 and stopped at "
                f"sin(theta) = {POLE_GUARD:g}; use model='gliding' (vector form) through the poles",
            ),
        ),
        conserves=("lam",),
    )
)
