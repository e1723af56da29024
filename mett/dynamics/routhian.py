"""The frictionless flat-plane top from the Routhian of the Maple/Poincaré paper, corrected.

With no friction the contact force is vertical, the horizontal motion of the centre of mass
decouples (ẍ = ÿ = 0) and the spin β₁ = I3 ω3 is an integral. Eliminating ψ with the Routhian
ℛ = L − β₁ψ̇ leaves θ and φ (the Maple paper's eqs (13)–(16); docs/maple-tippe-top-errata.md). With a = αR the CM offset,
I = I1 and the CM height R − a cos θ, the corrected equations are

    (a)  (I + m a² sin²θ) θ̈ = sin θ (I φ̇² cos θ − β₁ φ̇ − m g a − m a² θ̇² cos θ),
         I sin θ φ̈ = θ̇ (β₁ − 2 I φ̇ cos θ),

the vertical kinetic energy ½ m a² sin²θ θ̇² of the CM included; they are the gliding model at μ = 0
(:mod:`mett.dynamics.gliding`). The printed Routhian drops that term, which gives the approximation

    (b)  I θ̈ = sin θ (I φ̇² cos θ − β₁ φ̇ − m g a),

off by a relative O(m a²/I) in θ̈ (4.4 % for the Maple-paper table at α = 0.3). The paper's printed
(14)–(15) are wrong further (signs, a factor 2, a spurious 1 − csc θ): they are kept only as erratum
fixtures in :mod:`mett.symbolic.maple_tippe_top`. Like the Euler form, φ̈ is singular at sin θ = 0: the run
stops with status "failed" there.

State ``y = [θ, θ̇, φ̇, ω3, φ, x, y, ẋ, ẏ]`` (x, y the CM position); parameters
``(m, R, alpha, I1, I3, mu, g, vertical_cm)`` in the shared order of :mod:`._params`, with mu = 0
(no friction) and ``vertical_cm`` 1.0 for (a), 0.0 for (b).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from . import _params as ix
from ._model import add_integrals, lab_vectors, scales_from_state
from .euler import POLE_GUARD, cm_velocity_horizontal
from .registry import Event, Model, Option, boolean, register

__all__ = ["MODEL", "POLE_GUARD", "routhian_normal_force", "routhian_rhs"]


def _thetaddot(y: Any, p: tuple) -> Any:
    m, R, al, I1, I3, _mu, g, vertical = p
    th, thd, phd, w3 = y[0], y[1], y[2], y[3]
    s, c = np.sin(th), np.cos(th)
    a = R * al
    beta1 = I3 * w3
    lhs = I1 + vertical * m * a * a * s * s
    return (
        s
        * (I1 * phd * phd * c - beta1 * phd - m * g * a - vertical * m * a * a * thd * thd * c)
        / lhs
    )


def routhian_normal_force(y: Any, p: tuple) -> Any:
    """g_n = m g + m a (θ̈ sin θ + θ̇² cos θ): m times (g + the CM's vertical acceleration)."""
    m, R, al, I1, I3, _mu, g, vertical = p
    th, thd = y[0], y[1]
    return m * g + m * R * al * (_thetaddot(y, p) * np.sin(th) + thd * thd * np.cos(th))


def _phiddot(y: Any, p: tuple) -> Any:
    m, R, al, I1, I3, _mu, g, vertical = p
    th, thd, phd, w3 = y[0], y[1], y[2], y[3]
    return thd * (I3 * w3 - 2.0 * I1 * phd * np.cos(th)) / (I1 * np.sin(th))


def routhian_rhs(t: float, y: np.ndarray, p: tuple) -> np.ndarray:
    """Right-hand side of the corrected Routhian equations (module docstring)."""
    return np.array([y[1], _thetaddot(y, p), _phiddot(y, p), 0.0, y[2], y[7], y[8], 0.0, 0.0])


def _rhs_into(t: float, y: Any, p: Any, out: Any) -> None:
    """:func:`routhian_rhs` written into ``out``, for the compiled integrator."""
    out[0], out[1], out[2], out[3] = y[1], _thetaddot(y, p), _phiddot(y, p), 0.0
    out[4], out[5], out[6], out[7], out[8] = y[2], y[7], y[8], 0.0, 0.0


def _contact(t: float, y: Any, p: Any) -> Any:
    """The contact event g_n/(m g), for both backends."""
    return routhian_normal_force(y, p) * (1.0 / (p[ix.M] * p[ix.G]))


def _params(top: Any, options: dict) -> tuple:
    vertical = 1.0 if options.get("vertical_cm", True) else 0.0
    return (top.m, top.R, top.alpha, top.I1, top.I3, 0.0, top.g, vertical)


def _euler_params(p: tuple) -> tuple:
    m, R, al, I1, I3, _mu, g, vertical = p
    return (m, R, al, I1, I3, 0.0, g)


def _initial(state: Any, p: tuple) -> np.ndarray:
    # CM velocity along x̂, ŷ at φ = 0, where x̂ = (0, −1, 0) and ŷ = (1, 0, 0)
    v_x, v_y = cm_velocity_horizontal(state.as_array(), _euler_params(p))
    return np.array([state.theta, state.thetadot, state.phidot, state.omega3, 0.0, 0.0, 0.0,
                     float(v_y), -float(v_x)])  # fmt: skip


def _theta(Y: np.ndarray, p: tuple) -> np.ndarray:
    return np.asarray(Y[0], dtype=float)


def _derive(Y: np.ndarray, p: tuple) -> dict[str, np.ndarray]:
    m, R, al, I1, I3, _mu, g, vertical = p
    Y = np.asarray(Y, dtype=float)
    th, thd, phd, w3, phi, x, y, xd, yd = Y
    s, c = np.sin(th), np.cos(th)
    psd = w3 - phd * c
    # slip velocity ν = ṙ + ω × a on x̂ = (sin φ, −cos φ, 0), ŷ = (cos φ, sin φ, 0) (docs/theory/model.md#conventions)
    nux = -R * thd * (1.0 - al * c) + xd * np.sin(phi) - yd * np.cos(phi)
    nuy = R * (psd + al * phd) * s + xd * np.cos(phi) + yd * np.sin(phi)
    out = {
        "theta": th,
        "thetadot": thd,
        "phidot": phd,
        "omega3": w3,
        "psidot": psd,
        "nu_x": nux,
        "nu_y": nuy,
        "phi": phi,
        "x": x,
        "y": y,
        "gn": np.asarray(routhian_normal_force(Y, p), dtype=float),
    }
    return add_integrals(out, m, R, R * al, I1, I3, g)


def _scales(y0: np.ndarray, p: tuple) -> np.ndarray:
    from ..state import State

    m, R, al, I1, I3, _mu, g, vertical = p
    st = State(theta=y0[0], thetadot=y0[1], phidot=y0[2], omega3=y0[3])
    v = lab_vectors(st, R, R * al)
    sc = scales_from_state(v["omega"], v["v"], R, R * al, I1, I3, g)
    w, vel, length = sc["omega"], sc["velocity"], sc["length"]
    return np.array([1.0, w, w, w, 1.0, length, length, vel, vel])


def _pole(t: float, y: Any, p: Any) -> Any:
    # as mett.dynamics.euler.pole_guard; here because a model's compiled events live in its module
    return np.sin(y[0]) - POLE_GUARD


MODEL = register(
    Model(
        name="frictionless-routhian",
        summary="frictionless top from the corrected Maple-paper Routhian (vertical CM term optional)",
        rhs=routhian_rhs,
        rhs_into=_rhs_into,
        normal_force=routhian_normal_force,
        params=_params,
        initial=_initial,
        derive=_derive,
        theta=_theta,
        scales=_scales,
        events=(
            Event(_contact, -1.0, "contact_lost"),
            Event(
                _pole,
                -1.0,
                "fail",
                f"the Routhian (Euler-angle) form is singular at sin(theta) = 0 and stopped at "
                f"sin(theta) = {POLE_GUARD:g}; use model='gliding' with mu = 0 through the poles",
            ),
        ),
        options=(
            Option(
                "vertical_cm",
                boolean,
                True,
                "keep the vertical kinetic energy of the centre of mass (False: the printed "
                "approximation)",
            ),
        ),
        conserves=("E", "lam", "omega3"),
    )
)
