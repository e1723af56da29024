"""The gliding tippe top's Euler-angle equations, derived from the vector form (docs/theory/equations.md#equations-of-motion).

Newton–Euler with the contact constraint (Rutstam 2012 §2; docs/theory/equations.md#vector-form)::

    m r̈ = F − m g ẑ,   L̇ = a × F,   F = g_n ẑ − μ g_n v_A,
    (r + a)·ẑ = 0,     v_A = ṙ + ω × a = ν_x x̂ + ν_y ŷ,

with a = R(α 3̂ − ẑ) (centre of mass → contact point) and L = I1 ω + (I3 − I1) ω3 3̂.

The derivative of the contact constraint is v_A·ẑ = 0 (because ȧ·ẑ = (ω × a)·ẑ + R(ω × ẑ)·ẑ), so
writing v_A = ν_x x̂ + ν_y ŷ imposes it, and ṙ = ν − ω × a. Everything is written in the Resal frame
(:mod:`mett.symbolic._frame`), where ω = (−φ̇ sin θ, θ̇, ω3), and the six scalar equations (three of
Newton, three of Euler) are linear in the six unknowns θ̈, φ̈, ω̇3, ν̇_x, ν̇_y, g_n.
The result is docs/theory/equations.md#euler-form (Rutstam 2012 §2; thesis eqs (10)–(15)).
"""

from __future__ import annotations

from functools import cache

import sympy as sp

from ._frame import S, inertial_derivative, resal_frame, trig_reduce

__all__ = ["gliding_euler_equations", "newton_euler_residuals"]

_KEYS = ("thetaddot", "phiddot", "omega3dot", "nuxdot", "nuydot")


@cache
def newton_euler_residuals() -> tuple[sp.Matrix, sp.Matrix]:
    """Residuals of Newton's and Euler's laws in Resal components.

    Returns
    -------
    newton, euler : sympy.Matrix
        ``m r̈ − F + m g ẑ`` and ``L̇ − a × F`` (3×1 each), linear in the symbols
        ``thetaddot, phiddot, omega3dot, nuxdot, nuydot, g_n``. Setting both to zero is the model.
    """
    fr = resal_frame()
    zhat, xhat, yhat = fr["zhat"], fr["xhat"], fr["yhat"]
    e3 = sp.Matrix([0, 0, 1])
    omega = sp.Matrix([-S.phidot * sp.sin(S.theta), S.thetadot, S.omega3])
    L = sp.Matrix([S.I1 * omega[0], S.I1 * omega[1], S.I3 * omega[2]])
    a = S.R * (S.alpha * e3 - zhat)
    nu = S.nu_x * xhat + S.nu_y * yhat
    F = S.g_n * zhat - S.mu * S.g_n * nu
    rdot = nu - omega.cross(a)
    newton = S.m * inertial_derivative(rdot) - F + S.m * S.g * zhat
    euler = inertial_derivative(L) - a.cross(F)
    return newton.expand(), euler.expand()


def _unknowns() -> list[sp.Symbol]:
    return [S.thetaddot, S.phiddot, S.omega3dot, S.nuxdot, S.nuydot]


@cache
def _implicit() -> tuple[dict[str, sp.Expr], sp.Expr]:
    """Accelerations with g_n kept as a symbol, and the explicit g_n."""
    newton, euler = newton_euler_residuals()
    zhat = resal_frame()["zhat"]
    # The vertical part of Newton's law fixes g_n; the other five equations fix the accelerations
    # for a given g_n (the torque and the friction force are both proportional to g_n).
    vertical = sp.expand(sum(newton[i] * zhat[i] for i in range(3)))
    horizontal = [newton[1], sp.expand(newton[0] * zhat[2] - newton[2] * zhat[0])]
    sol = sp.solve([*euler, *horizontal], _unknowns(), dict=True, simplify=False)
    if len(sol) != 1:  # pragma: no cover
        raise RuntimeError(f"Newton–Euler system is not uniquely solvable: {sol}")
    acc = {k: trig_reduce(sol[0][u]) for k, u in zip(_KEYS, _unknowns(), strict=True)}
    gn_eq = vertical.subs({u: acc[k] for k, u in zip(_KEYS, _unknowns(), strict=True)})
    gn_eq = sp.expand(gn_eq * S.I1)
    slope = gn_eq.coeff(S.g_n)
    if slope == 0 or sp.expand(gn_eq - slope * S.g_n).has(S.g_n):  # pragma: no cover
        raise RuntimeError(f"vertical Newton equation is not linear in g_n: {gn_eq}")
    return acc, trig_reduce(-gn_eq.subs(S.g_n, 0) / slope)


@cache
def _explicit() -> dict[str, sp.Expr]:
    acc, gn = _implicit()
    out = {k: trig_reduce(v.subs(S.g_n, gn)) for k, v in acc.items()}
    out["gn"] = gn
    return out


def gliding_euler_equations(explicit: bool = True) -> dict[str, sp.Expr]:
    """Euler-angle equations of the rolling-and-gliding tippe top, derived (docs/theory/equations.md#euler-form).

    State (θ, θ̇, φ̇, ω3, ν_x, ν_y); parameters (m, R, α, I1, I3, μ, g). Derived from the vector form
    (:func:`newton_euler_residuals`), reproducing Rutstam (2012) §2 / thesis eqs (10)–(15)::

        θ̈   = (s/I1)(I1 φ̇² c − I3 ω3 φ̇ − Rα g_n) + (Rμ g_n ν_x/I1)(1 − α c)
        φ̈   = [I3 θ̇ ω3 − 2 I1 θ̇ φ̇ c − μ g_n ν_y R(α − c)] / (I1 s)
        ω̇3  = −μ g_n ν_y R s / I3
        ν̇_x = …,  ν̇_y = …  (docs/theory/equations.md#euler-form)
        g_n = [m g I1 + m R α (c (I1 φ̇² s² + I1 θ̇²) − I3 φ̇ ω3 s²)]
              / [I1 + m R² α² s² − m R² α s (1 − α c) μ ν_x]

    Parameters
    ----------
    explicit : bool, default True
        If True the normal force is substituted everywhere. If False the accelerations contain the
        symbol ``g_n`` (the form in which the formula sheet prints them); ``"gn"`` is explicit in
        both cases.

    Returns
    -------
    dict
        Keys ``thetaddot, phiddot, omega3dot, nuxdot, nuydot, gn``; sympy expressions in the
        symbols ``theta, thetadot, phidot, omega3, nu_x, nu_y, m, R, alpha, I1, I3, mu, g``
        (and ``g_n`` when ``explicit=False``). ``theta`` is declared positive (0 < θ < π, where
        sin θ > 0); the φ̈ equation is singular at sin θ = 0.

    Notes
    -----
    Cached: the first call takes a few seconds, later calls are instant. The returned dict is a
    fresh copy; the expressions are immutable.
    """
    if explicit:
        return dict(_explicit())
    acc, gn = _implicit()
    return {**acc, "gn": gn}
