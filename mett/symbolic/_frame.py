"""Symbols and the Resal frame shared by the symbolic derivations (docs/theory/model.md#conventions).

Vectors are sympy column matrices of their components in the Resal frame (1̂, 2̂, 3̂): 3̂ is the
symmetry axis, 2̂ = ẑ × 3̂ / sin θ the line of nodes, 1̂ = 2̂ × 3̂. The frame itself is *derived* here
from the Goldstein z-x-z lab coordinates of docs/theory/model.md#conventions (:func:`resal_frame`), so that the
components of ẑ, x̂, ŷ and the frame's angular velocity Ω = φ̇ ẑ + θ̇ 2̂ are computed, not assumed.
"""

from __future__ import annotations

from functools import cache

import sympy as sp

__all__ = ["PARAMS", "STATE", "S", "inertial_derivative", "resal_frame"]


class _Symbols:
    """The library's symbols, named as in the numeric core (docs/theory/model.md#conventions)."""

    def __init__(self) -> None:
        # θ ∈ (0, π) inside the derivations: sin θ > 0 lets sympy cancel √(sin²θ).
        self.theta = sp.Symbol("theta", positive=True)
        self.thetadot, self.phidot, self.omega3 = sp.symbols("thetadot phidot omega3", real=True)
        self.nu_x, self.nu_y = sp.symbols("nu_x nu_y", real=True)
        self.m, self.R, self.alpha = sp.symbols("m R alpha", positive=True)
        self.I1, self.I3, self.g = sp.symbols("I1 I3 g", positive=True)
        self.mu = sp.Symbol("mu", nonnegative=True)
        # Unknowns of the Newton–Euler system.
        self.thetaddot, self.phiddot, self.omega3dot = sp.symbols(
            "thetaddot phiddot omega3dot", real=True
        )
        self.nuxdot, self.nuydot = sp.symbols("nuxdot nuydot", real=True)
        self.g_n = sp.Symbol("g_n", real=True)
        # METT variables: z = cos θ, Routh D, Jellett λ, (modified) energy E.
        self.z = sp.Symbol("z", real=True)
        self.D, self.lam, self.E = sp.symbols("D lam E", real=True)


S = _Symbols()
"""Namespace of the symbols (``S.theta``, ``S.I1``, …)."""

STATE = (S.theta, S.thetadot, S.phidot, S.omega3, S.nu_x, S.nu_y)
"""The reduced state (θ, θ̇, φ̇, ω3, ν_x, ν_y), in the order of :meth:`mett.State.as_array`."""

PARAMS = (S.m, S.R, S.alpha, S.I1, S.I3, S.mu, S.g)
"""The parameters, in the order of the numeric ``params`` tuple (m, R, α, I1, I3, μ, g)."""

# Time derivative of each state variable: d/dt of a Resal component is Σ ∂/∂q · q̇.
_RATES = {
    S.theta: S.thetadot,
    S.thetadot: S.thetaddot,
    S.phidot: S.phiddot,
    S.omega3: S.omega3dot,
    S.nu_x: S.nuxdot,
    S.nu_y: S.nuydot,
}


@cache
def resal_frame() -> dict[str, sp.Matrix]:
    """Resal-frame components of ẑ, x̂, ŷ and of the frame's angular velocity Ω.

    Derived from the lab coordinates of docs/theory/model.md#conventions: 3̂ = (sin θ sin φ, −sin θ cos φ, cos θ),
    2̂ = ẑ × 3̂ / sin θ, 1̂ = 2̂ × 3̂, x̂ = (sin φ, −cos φ, 0), ŷ = (cos φ, sin φ, 0). With Q the matrix
    whose columns are 1̂, 2̂, 3̂, a lab vector u has Resal components Qᵀu, and Ω is read off the
    skew matrix Qᵀ Q̇.

    Returns
    -------
    dict
        ``zhat, xhat, yhat, Omega`` as 3×1 matrices in θ, θ̇, φ̇ (φ drops out, as it must).
        Expected: ẑ = (−sin θ, 0, cos θ), x̂ = (cos θ, 0, sin θ), ŷ = (0, 1, 0),
        Ω = (−φ̇ sin θ, θ̇, φ̇ cos θ).
    """
    t = sp.Symbol("t")
    th_t, ph_t = sp.Function("theta_t")(t), sp.Function("phi_t")(t)
    phi = sp.Symbol("phi", real=True)
    e3 = sp.Matrix([sp.sin(th_t) * sp.sin(ph_t), -sp.sin(th_t) * sp.cos(ph_t), sp.cos(th_t)])
    ez = sp.Matrix([0, 0, 1])
    e2 = sp.simplify(ez.cross(e3) / sp.sin(th_t))
    e1 = sp.simplify(e2.cross(e3))
    Q = sp.Matrix.hstack(e1, e2, e3)
    W = sp.simplify(Q.T * Q.diff(t))  # skew: W[2,1] = Ω1, W[0,2] = Ω2, W[1,0] = Ω3
    back = {
        sp.Derivative(th_t, t): S.thetadot,
        sp.Derivative(ph_t, t): S.phidot,
    }
    Omega = sp.Matrix([W[2, 1], W[0, 2], W[1, 0]]).subs(back).subs({th_t: S.theta, ph_t: phi})
    lab = {
        "zhat": ez,
        "xhat": sp.Matrix([sp.sin(ph_t), -sp.cos(ph_t), 0]),
        "yhat": sp.Matrix([sp.cos(ph_t), sp.sin(ph_t), 0]),
    }
    out = {k: sp.simplify(Q.T * v).subs({th_t: S.theta, ph_t: phi}) for k, v in lab.items()}
    out["Omega"] = sp.simplify(Omega)
    for k, v in out.items():
        if v.has(phi):  # pragma: no cover - a wrong frame would show up here
            raise RuntimeError(f"Resal component of {k} depends on phi: {v.T}")
    return out


def inertial_derivative(vec: sp.Matrix) -> sp.Matrix:
    """Inertial time derivative of a vector given by Resal components in the reduced state.

    d u/dt = (Σ_q ∂u/∂q q̇) + Ω × u, the second term because the Resal frame rotates with Ω.
    Accelerations appear as the symbols ``thetaddot, phiddot, omega3dot, nuxdot, nuydot``.
    """
    comp = sp.zeros(3, 1)
    for q, qdot in _RATES.items():
        comp += vec.diff(q) * qdot
    return comp + resal_frame()["Omega"].cross(vec)


def trig_reduce(expr: sp.Expr, *angles: sp.Symbol) -> sp.Expr:
    """Canonical form of a rational function of sin and cos of θ (and other angles).

    sympy's ``simplify`` is slow on these expressions and rewrites them with sin 2θ; reducing the
    numerator and the denominator modulo sin² + cos² − 1 (sin² → 1 − cos²) is fast and keeps the
    form of the formula sheet.
    """
    angles = (S.theta, *angles)
    pairs = [sp.symbols(f"_s{i} _c{i}", real=True) for i in range(len(angles))]
    sub, back = {}, {}
    for ang, (s, c) in zip(angles, pairs, strict=True):
        sub.update({sp.sin(ang): s, sp.cos(ang): c})
        back.update({s: sp.sin(ang), c: sp.cos(ang)})
    rel = [s**2 + c**2 - 1 for s, c in pairs]
    gens = [x for pair in pairs for x in pair]
    num, den = sp.fraction(sp.together(sp.sympify(expr).subs(sub)))

    def red(p: sp.Expr) -> sp.Expr:
        p = sp.expand(p)
        if not p.has(*gens):
            return p
        return sp.reduced(p, rel, *gens)[1]

    return sp.factor_terms(sp.cancel(red(num) / red(den))).subs(back)
