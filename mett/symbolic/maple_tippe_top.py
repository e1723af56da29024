"""The Maple tippe-top paper: its Routhian model, corrected, and its misprinted equations.

The paper "Utilization of Maple-based Physics Computation in Determining the Dynamics of Tippe Top"
(cited in mett as ``maple-tippe-top``; it names no authors or year in the text we have) derives the
flat-plane tippe top with a Routhian-reduced Poincaré equation. It writes the top in Goldstein
z-x-z angles (θ, φ, ψ) and the horizontal centre-of-mass position (x, y), with the CM offset ``a``
(= αR in Rutstam's notation), ``I`` = I1, and the conserved (frictionless) momentum
β₁ = ∂L/∂ψ̇ = I3(ψ̇ + φ̇ cos θ), its eq. (13). The CM height is R − a cos θ.

What this module derives (each result is on the errata page, docs/maple-tippe-top-errata.md):

* :func:`routhian` — ℛ = L − β₁ψ̇ of the frictionless flat-plane top, with the vertical CM kinetic
  energy ½ m a² sin²θ θ̇² (correct, ℛ_a) or without it (the paper's printed Routhian, ℛ_b);
* :func:`routhian_equations` — their Euler–Lagrange equations (a) and (b);
* :func:`generalized_forces` and :func:`friction_equations` — the correct viscous-friction model
  in the paper's variables, from Lagrange's equations with the generalized forces of
  F = g_n ẑ − μ g_n v_A (this is Rutstam's model, an independent check of
  :func:`mett.symbolic.gliding_euler_equations`);
* ``printed_eq14``, ``printed_eq15``, ``printed_eq17`` — **the equations as printed in the paper.
  They are WRONG** (sign and factor errors, a spurious (1 − csc θ)); they exist only as erratum
  fixtures for the tests and the errata page. Never use them as a model.
"""

from __future__ import annotations

from functools import cache

import sympy as sp

from ._frame import S, trig_reduce

__all__ = [
    "MAPLE",
    "friction_equations",
    "generalized_forces",
    "printed_eq14",
    "printed_eq15",
    "printed_eq17",
    "routhian",
    "routhian_equations",
    "to_thesis",
]


class _MapleSymbols:
    """Symbols of the Maple paper; θ, θ̇, φ̇, m, R, g, μ are shared with :mod:`mett.symbolic._frame`."""

    def __init__(self) -> None:
        self.I = sp.Symbol("I", positive=True)
        self.a = sp.Symbol("a", positive=True)
        self.beta1 = sp.Symbol("beta1", real=True)
        self.phi = sp.Symbol("phi", real=True)
        self.psidot = sp.Symbol("psidot", real=True)
        self.xdot, self.ydot = sp.symbols("xdot ydot", real=True)
        self.xddot, self.yddot, self.psiddot = sp.symbols("xddot yddot psiddot", real=True)
        self.F_N = sp.Symbol("F_N", real=True)  # the paper's |F_N|, the normal force


MAPLE = _MapleSymbols()
"""Namespace of the Maple paper's symbols (``MAPLE.I``, ``MAPLE.a``, ``MAPLE.beta1``, …)."""

_th, _thd, _phd = S.theta, S.thetadot, S.phidot
_sin, _cos = sp.sin(_th), sp.cos(_th)


def to_thesis() -> dict[sp.Symbol, sp.Expr]:
    """Substitution from the Maple paper's notation to Rutstam's: a = αR, I = I1, β₁ = I3 ω3."""
    return {MAPLE.a: S.alpha * S.R, MAPLE.I: S.I1, MAPLE.beta1: S.I3 * S.omega3}


def _lagrangian(vertical_cm: bool) -> sp.Expr:
    """L = T − U with ω = (−φ̇ sin θ, θ̇, ψ̇ + φ̇ cos θ) in the Resal frame, z_CM = R − a cos θ."""
    T_rot = (MAPLE.I * (_phd**2 * _sin**2 + _thd**2) + S.I3 * (MAPLE.psidot + _phd * _cos) ** 2) / 2
    zdot = sp.diff(S.R - MAPLE.a * _cos, _th) * _thd
    T_cm = S.m * (MAPLE.xdot**2 + MAPLE.ydot**2 + (zdot**2 if vertical_cm else 0)) / 2
    U = S.m * S.g * (S.R - MAPLE.a * _cos)
    return T_rot + T_cm - U


@cache
def routhian(vertical_cm: bool = True) -> sp.Expr:
    """Routhian ℛ = L − β₁ψ̇ of the frictionless flat-plane top, ψ̇ eliminated (the paper's eq. (13)).

    Derived from the Lagrangian L = ½ m(ẋ² + ẏ² + ż²) + ½ I(θ̇² + sin²θ φ̇²) + ½ I3(ψ̇ + φ̇ cos θ)²
    − m g (R − a cos θ), z = R − a cos θ, with β₁ = ∂L/∂ψ̇ = I3(ψ̇ + φ̇ cos θ)::

        ℛ_a = ½ (I + m a² sin²θ) θ̇² + ½ I sin²θ φ̇² − m g (R − a cos θ) − β₁²/(2 I3)
              + β₁ φ̇ cos θ + ½ m (ẋ² + ẏ²)

    Parameters
    ----------
    vertical_cm : bool, default True
        Keep the vertical CM kinetic energy ½ m ż² = ½ m a² sin²θ θ̇² (correct). ``False`` gives the
        Routhian printed in the paper (ℛ_b, plus the decoupled ½ m(ẋ² + ẏ²) it leaves implicit).
    """
    L = _lagrangian(vertical_cm)
    beta1 = sp.diff(L, MAPLE.psidot)
    psidot = sp.solve(sp.Eq(beta1, MAPLE.beta1), MAPLE.psidot)[0]
    return sp.expand((L - MAPLE.beta1 * MAPLE.psidot).subs(MAPLE.psidot, psidot))


def _ddt(expr: sp.Expr, rates: dict[sp.Symbol, sp.Expr]) -> sp.Expr:
    """Total time derivative by the chain rule, d/dt f = Σ ∂f/∂q q̇."""
    return sum((sp.diff(expr, q) * qd for q, qd in rates.items()), sp.Integer(0))


_RATES_R = {
    _th: _thd,
    _thd: S.thetaddot,
    _phd: S.phiddot,
    MAPLE.xdot: MAPLE.xddot,
    MAPLE.ydot: MAPLE.yddot,
}


@cache
def routhian_equations(vertical_cm: bool = True) -> dict[str, sp.Expr]:
    """Euler–Lagrange equations of :func:`routhian` (β₁ constant; φ, x, y cyclic).

    ``vertical_cm=True`` gives the corrected equations (a) (docs/maple-tippe-top-errata.md#corrected-equations)::

        (I + m a² sin²θ) θ̈ = sin θ (I φ̇² cos θ − β₁ φ̇ − m g a − m a² θ̇² cos θ)
        I sin θ φ̈ = θ̇ (β₁ − 2 I φ̇ cos θ),   ẍ = ÿ = 0

    and ``vertical_cm=False`` the approximation (b), I θ̈ = sin θ (I φ̇² cos θ − β₁ φ̇ − m g a).

    Returns
    -------
    dict
        ``thetaddot, phiddot, xddot, yddot`` in ``theta, thetadot, phidot, beta1, I, I3, m, g, a``.
    """
    Rr = routhian(vertical_cm)
    eqs = []
    for q, qd in ((_th, _thd), (None, _phd), (None, MAPLE.xdot), (None, MAPLE.ydot)):
        lhs = _ddt(sp.diff(Rr, qd), _RATES_R)
        eqs.append(lhs - (sp.diff(Rr, q) if q is not None else 0))
    unknowns = [S.thetaddot, S.phiddot, MAPLE.xddot, MAPLE.yddot]
    sol = sp.solve(eqs, unknowns, dict=True, simplify=False)[0]
    keys = ("thetaddot", "phiddot", "xddot", "yddot")
    return {k: trig_reduce(sol[u]) for k, u in zip(keys, unknowns, strict=True)}


# --- the viscous-friction model in the Maple paper's variables -------------------------------


def _contact_velocity() -> sp.Matrix:
    """Lab velocity of the material point at the contact, v_A = ṡ + ω × (a e3 − R ẑ) (the paper's eq. (7))."""
    ph = MAPLE.phi
    e3 = sp.Matrix([_sin * sp.sin(ph), -_sin * sp.cos(ph), _cos])
    node = sp.Matrix([sp.cos(ph), sp.sin(ph), 0])
    zhat = sp.Matrix([0, 0, 1])
    omega = _phd * zhat + _thd * node + MAPLE.psidot * e3
    sdot = sp.Matrix([MAPLE.xdot, MAPLE.ydot, MAPLE.a * _sin * _thd])
    return sdot + omega.cross(MAPLE.a * e3 - S.R * zhat)


def slip_components() -> tuple[sp.Expr, sp.Expr]:
    """(ν_x, ν_y) = (v_A·x̂, v_A·ŷ), x̂ = (sin φ, −cos φ, 0), ŷ = (cos φ, sin φ, 0) (docs/theory/model.md#conventions).

    ν_x = ẋ sin φ − ẏ cos φ − (R − a cos θ) θ̇,  ν_y = ẋ cos φ + ẏ sin φ + sin θ (R ψ̇ + a φ̇).
    """
    v = _contact_velocity()
    ph = MAPLE.phi
    nx = v[0] * sp.sin(ph) - v[1] * sp.cos(ph)
    ny = v[0] * sp.cos(ph) + v[1] * sp.sin(ph)
    return sp.simplify(sp.expand(nx)), sp.simplify(sp.expand(ny))


_QDOTS = (MAPLE.xdot, MAPLE.ydot, _thd, _phd, MAPLE.psidot)


@cache
def generalized_forces() -> dict[str, sp.Expr]:
    """Generalized forces S_q = F·∂v_A/∂q̇ of F = g_n ẑ − μ g_n v_A (the paper's eq. (6), corrected).

    The normal force does no virtual work (v_A·ẑ ≡ 0). Written with the slip components
    (ν_x, ν_y) where the result is simple (docs/maple-tippe-top-errata.md#generalized-forces)::

        S_x = −μ g_n v_Ax,  S_y = −μ g_n v_Ay,
        S_θ = +μ g_n (R − a cos θ) ν_x,  S_φ = −μ g_n a sin θ ν_y,  S_ψ = −μ g_n R sin θ ν_y

    Returns
    -------
    dict
        ``x, y, theta, phi, psi`` in ``theta, phi, thetadot, phidot, psidot, xdot, ydot, mu, g_n, a,
        R`` (ν not substituted; compare with :func:`slip_components`).
    """
    v = _contact_velocity()
    if sp.simplify(v[2]) != 0:  # pragma: no cover
        raise RuntimeError(f"contact velocity is not horizontal: {v[2]}")
    F = S.g_n * sp.Matrix([0, 0, 1]) - S.mu * S.g_n * v
    keys = ("x", "y", "theta", "phi", "psi")
    return {
        k: trig_reduce(F.dot(v.diff(qd)), MAPLE.phi) for k, qd in zip(keys, _QDOTS, strict=True)
    }


@cache
def friction_equations() -> dict[str, sp.Expr]:
    """Correct equations of the gliding top in the Maple paper's variables (Lagrange with friction).

    d/dt ∂L/∂q̇ − ∂L/∂q = S_q for q = x, y, θ, φ, ψ, with the full Lagrangian (vertical CM kinetic
    energy included) and g_n = m g + m z̈_CM = m g + m a (θ̇² cos θ + θ̈ sin θ) (the paper's eq. (21),
    correct). Solved for ẍ, ÿ, θ̈, φ̈, ψ̈ and g_n; the expected form (docs/maple-tippe-top-errata.md#friction-equations) is::

        I θ̈ = sin θ (I φ̇² cos θ − β₁ φ̇ − a g_n) + μ g_n (R − a cos θ) ν_x
        I sin θ φ̈ = θ̇ (β₁ − 2 I φ̇ cos θ) − μ g_n (a − R cos θ) ν_y
        β̇₁ = −μ g_n R sin θ ν_y,   m ẍ = −μ g_n v_Ax,   m ÿ = −μ g_n v_Ay

    Returns
    -------
    dict
        ``xddot, yddot, thetaddot, phiddot, psiddot, beta1dot`` in ``theta, phi, thetadot, phidot,
        psidot, xdot, ydot``, the parameters ``m, R, a, I, I3, mu, g`` and the normal force
        ``g_n`` (a symbol, as in the formulas above); ``gn`` is the explicit normal force.
        β₁ = I3(ψ̇ + φ̇ cos θ).
    """
    L = _lagrangian(vertical_cm=True)
    rates = {
        _th: _thd,
        _thd: S.thetaddot,
        _phd: S.phiddot,
        MAPLE.psidot: MAPLE.psiddot,
        MAPLE.xdot: MAPLE.xddot,
        MAPLE.ydot: MAPLE.yddot,
    }
    Q = generalized_forces()
    eq = {}
    for k, q, qd in (
        ("x", None, MAPLE.xdot),
        ("y", None, MAPLE.ydot),
        ("theta", _th, _thd),
        ("phi", None, _phd),
        ("psi", None, MAPLE.psidot),
    ):
        dLdq = sp.diff(L, q) if q is not None else 0
        eq[k] = sp.expand(_ddt(sp.diff(L, qd), rates) - dLdq - Q[k])
    # For a given g_n the five Lagrange equations fix the accelerations (g_n enters only through
    # the friction forces); the vertical CM equation then fixes g_n. Solving in this order, and
    # returning the accelerations with g_n as a symbol, keeps the expressions small.
    unknowns = [MAPLE.xddot, MAPLE.yddot, S.thetaddot, S.phiddot, MAPLE.psiddot]
    sol = sp.solve(list(eq.values()), unknowns, dict=True, simplify=False)[0]
    keys = ("xddot", "yddot", "thetaddot", "phiddot", "psiddot")
    out = {k: trig_reduce(sol[u], MAPLE.phi) for k, u in zip(keys, unknowns, strict=True)}
    zddot = _ddt(MAPLE.a * _sin * _thd, rates).subs(S.thetaddot, out["thetaddot"])
    vertical = sp.expand(S.g_n - S.m * S.g - S.m * zddot)
    slope = vertical.coeff(S.g_n)
    out["gn"] = trig_reduce(-vertical.subs(S.g_n, 0) / slope, MAPLE.phi)
    beta1 = sp.diff(L, MAPLE.psidot)
    acc = {S.thetaddot: out["thetaddot"], S.phiddot: out["phiddot"], MAPLE.psiddot: out["psiddot"]}
    out["beta1dot"] = trig_reduce(_ddt(beta1, rates).subs(acc), MAPLE.phi)
    return out


# --- equations as printed in the Maple paper: WRONG, erratum fixtures only -------------------


def printed_eq14() -> sp.Expr:
    """θ̈ **as printed** in the Maple paper, eq. (14). WRONG — erratum fixture for tests only.

    θ̈ = (sin θ/I)(I φ̇² cos θ + 2β₁φ̇ + m g a). Errors (docs/maple-tippe-top-errata.md#eq14, errors 1–3): +2β₁φ̇ should be
    −β₁φ̇, +m g a should be −m g a, and the vertical-CM term of (a) is missing.
    """
    I, b1 = MAPLE.I, MAPLE.beta1
    return _sin / I * (_cos * (I * _phd**2) + (2 * b1 * _phd + S.m * S.g * MAPLE.a))


def printed_eq15() -> sp.Expr:
    """φ̈ **as printed** in the Maple paper, eq. (15). WRONG — erratum fixture for tests only.

    φ̈ = (β₁/I) θ̇ csc θ (1 − csc θ) − (2I/I) θ̇ φ̇ cot θ. Error (docs/maple-tippe-top-errata.md#eq15, error 4): the factor
    (1 − csc θ) should be 1.
    """
    I, b1 = MAPLE.I, MAPLE.beta1
    csc, cot = 1 / _sin, _cos / _sin
    return b1 / I * _thd * csc * (1 - csc) - (2 * I / I) * _thd * _phd * cot


def printed_eq17() -> dict[str, sp.Expr]:
    """θ̈ and φ̈ with friction **as printed** in the Maple paper, eq. (17). WRONG — test fixture only.

    θ̈ = (sin θ/I)(2φ̇β₁ + cos θ I φ̇² + m g a) − μ|F_N| ẋ (R − a cos θ)/I
    φ̈ = [−μ|F_N| ẏ (a − R sin θ) − β₁ θ̇ (1 − csc θ) − 2 I θ̇ φ̇ cos θ]/(I sin θ)

    Errors (docs/maple-tippe-top-errata.md#eq17, errors 6–9): the gyroscopic and gravity signs of (14); m g a instead of
    a g_n; ẋ, ẏ instead of the slip components ν_x, ν_y (and the wrong sign of the θ friction
    torque); a − R sin θ instead of a − R cos θ; −β₁θ̇(1 − csc θ) instead of +β₁θ̇. ``F_N`` is the
    symbol of the paper's |F_N|.
    """
    I, b1, a, FN = MAPLE.I, MAPLE.beta1, MAPLE.a, MAPLE.F_N
    mu, R = S.mu, S.R
    thdd = (
        _sin / I * (2 * _phd * b1 + _cos * I * _phd**2 + S.m * S.g * a)
        - mu * FN * MAPLE.xdot * (R - a * _cos) / I
    )
    phdd = (
        -mu * FN * MAPLE.ydot * (a - R * _sin)
        - b1 * _thd * (1 - 1 / _sin)
        - 2 * I * _thd * _phd * _cos
    ) / (I * _sin)
    return {"thetaddot": thdd, "phiddot": phdd}
