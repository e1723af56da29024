"""The integrals λ, D, E, Ẽ and the Main Equation for the Tippe Top, derived (docs/theory/model.md#conventions, docs/theory/equations.md#integrals, docs/theory/mett.md#the-main-equation, docs/theory/mett.md#rational).

* :func:`integrals` writes Jellett's λ = −L·a, Routh's D = I3 ω3 √d(cos θ), the energy E and the
  modified energy Ẽ = E − ½ m|ν|² + m ν·(ω × a) from the vectors of the model (Resal frame).
* :func:`mett_potential` eliminates φ̇ and ω3 from Ẽ with λ and D (Rutstam 2012 §3; RR14 §2)::

      Ẽ = g(z) θ̇² + V(z, D, λ),   z = cos θ,

  and checks on the way that the θ̇-linear term vanishes.
* :func:`rational_potential` imposes σ = (1 − γ)/(γ + α² − 1), under which d(z) is a perfect
  square and V is rational in z (Rutstam 2013, RCD; RR14; docs/theory/mett.md#rational).
"""

from __future__ import annotations

from functools import cache

import sympy as sp

from ._frame import S, resal_frame, trig_reduce

__all__ = ["d_expr", "integrals", "mett_decomposition", "mett_potential", "rational_potential"]

# √d(z) is carried as a positive symbol so that every expression stays rational; it is replaced by
# sqrt(d(z)) only in the results (d > 0 on [−1, 1] for any physical top).
_sqd = sp.Symbol("sqrt_d", positive=True)


def d_expr(z: sp.Expr | None = None) -> sp.Expr:
    """d(z) = γ + σ(α − z)² + σγ(1 − z²), γ = I1/I3, σ = m R²/I3 (docs/theory/model.md#conventions).

    Equivalently I3² d = I1 I3 + m R² I3 (α − z)² + m R² I1 (1 − z²). D = I3 ω3 √d(cos θ).
    """
    z = S.z if z is None else z
    gam, sig = S.I1 / S.I3, S.m * S.R**2 / S.I3
    return gam + sig * (S.alpha - z) ** 2 + sig * gam * (1 - z**2)


def _vectors() -> dict[str, sp.Matrix]:
    fr = resal_frame()
    e3 = sp.Matrix([0, 0, 1])
    omega = sp.Matrix([-S.phidot * sp.sin(S.theta), S.thetadot, S.omega3])
    L = sp.Matrix([S.I1 * omega[0], S.I1 * omega[1], S.I3 * omega[2]])
    a = S.R * (S.alpha * e3 - fr["zhat"])
    nu = S.nu_x * fr["xhat"] + S.nu_y * fr["yhat"]
    return {"omega": omega, "L": L, "a": a, "nu": nu, "rdot": nu - omega.cross(a), "e3": e3}


@cache
def integrals() -> dict[str, sp.Expr]:
    """λ, D, E and Ẽ as functions of the state (θ, θ̇, φ̇, ω3, ν_x, ν_y) (docs/theory/model.md#conventions, docs/theory/equations.md#integrals).

    Returns
    -------
    dict
        ``lam`` = −L·a (Jellett), ``D`` = I3 ω3 √d(cos θ) (Routh), ``E`` = ½ m|ṙ|² + ½ ω·L +
        m g R(1 − α cos θ) with ṙ = ν − ω × a, and ``E_mod`` = E − ½ m|ν|² + m ν·(ω × a), which
        contains no ν (docs/theory/equations.md#integrals: Ẽ = ½ m|ω × a|² + ½ ω·L + U).
    """
    v = _vectors()
    omega, L, a, nu = v["omega"], v["L"], v["a"], v["nu"]
    c = sp.cos(S.theta)
    U = S.m * S.g * S.R * (1 - S.alpha * c)
    E = S.m * v["rdot"].dot(v["rdot"]) / 2 + omega.dot(L) / 2 + U
    E_mod = E - S.m * nu.dot(nu) / 2 + S.m * nu.dot(omega.cross(a))
    return {
        "lam": trig_reduce(-L.dot(a)),
        "D": S.I3 * S.omega3 * sp.sqrt(d_expr(c)),
        "E": trig_reduce(E),
        "E_mod": trig_reduce(E_mod),
    }


def _tidy(expr: sp.Expr) -> sp.Expr:
    expr = sp.expand(expr)
    return sp.collect(expr, [S.lam**2, S.lam * S.D, S.D**2, S.lam, S.D], sp.factor)


@cache
def _decomposition_sqd() -> dict[str, sp.Expr]:
    ints = integrals()
    z = S.z
    # λ and D are linear in (φ̇, ω3). With u = 1/√d as a symbol the solution is polynomial in u:
    # ω3 = D u/I3, φ̇ = [λ + R D (α − z) u]/(R I1 (1 − z²)).
    u = sp.Symbol("_u", positive=True)
    w3, phd = sp.symbols("_w3 _phd", real=True)
    lam_eq = ints["lam"].subs({S.phidot: phd, S.omega3: w3}) - S.lam
    D_eq = S.I3 * w3 - S.D * u
    sol = sp.solve([lam_eq, D_eq], [phd, w3], dict=True, simplify=False)[0]
    # Ẽ contains sin θ only as sin²θ (a leftover square root would make the Poly below fail).
    to_z = {sp.sin(S.theta): sp.sqrt(1 - z**2), sp.cos(S.theta): z}
    vel = {S.phidot: sp.factor(sol[phd].subs(to_z)), S.omega3: sol[w3]}
    E = sp.expand(ints["E_mod"].subs(to_z).subs(vel))
    poly = sp.Poly(E, S.thetadot, u)
    if poly.degree(S.thetadot) != 2:  # pragma: no cover
        raise RuntimeError(f"Ẽ is not quadratic in thetadot: {poly}")
    d = d_expr(z)

    def coefficient(k: int) -> sp.Expr:
        # Σ_j A_kj u^j with u = √d/d, u² = 1/d: each power is cancelled on its own (fast).
        terms = [poly.coeff_monomial(S.thetadot**k * u**j) for j in range(3)]
        return (
            sp.cancel(sp.together(terms[0] + terms[2] / d))
            + sp.cancel(sp.together(terms[1] / d)) * _sqd
        )

    V = coefficient(0)
    gravity = S.m * S.g * S.R * (1 - S.alpha * z)
    return {
        "linear": coefficient(1),
        "g": sp.factor(coefficient(2)),
        # Gravity is kept apart so that the kinetic part collects into λ², λD, D² terms.
        "V": gravity + _tidy(V - gravity),
        "omega3": vel[S.omega3].subs(u, 1 / _sqd),
        "phidot": vel[S.phidot].subs(u, 1 / _sqd),
    }


@cache
def mett_decomposition() -> dict[str, sp.Expr]:
    """Ẽ written in (z, θ̇, D, λ): the coefficients of θ̇⁰, θ̇¹, θ̇² (Rutstam 2012 §3).

    D = I3 ω3 √d(z) and λ = R I1 φ̇ (1 − z²) − R I3 ω3 (α − z) are solved for ω3 and φ̇::

        ω3 = D/(I3 √d),   φ̇ = [λ √d + R D (α − z)] / (R I1 (1 − z²) √d),

    and substituted into Ẽ(θ, θ̇, φ̇, ω3) with cos θ = z, sin²θ = 1 − z². √d(z) is carried as a
    symbol and reduced with √d² = d(z), so that each coefficient is A + B√d with A, B rational.

    Returns
    -------
    dict
        ``linear`` (the θ̇¹ coefficient; 0), ``g`` (θ̇²; g(z)), ``V`` (θ̇⁰; V(z, D, λ)) and
        ``omega3``, ``phidot`` (the solved velocities), in ``z, D, lam`` and the parameters, with
        √d(z) written out as ``sqrt(d(z))``.
    """
    back = {_sqd: sp.sqrt(d_expr(S.z))}
    return {k: v.subs(back) for k, v in _decomposition_sqd().items()}


def mett_potential() -> tuple[sp.Expr, sp.Expr]:
    """(g(z), V(z, D, λ)) of the METT Ẽ = g(z) θ̇² + V(z, D, λ), derived (docs/theory/mett.md#the-main-equation; R12 §3).

    Expected (and tested)::

        g(z) = ½ (I1 + m R² (1 + α² − 2αz)) = ½ (I1 + m|a|²)
        V    = m g R(1 − αz) + I3 [λ√d(z) + R D(α − z)]² / (2 I1² R² (1 − z²))
               + D²/(2 I1) − m λ²/(2 I1 I3)

    Returns
    -------
    g, V : sympy.Expr
        In the symbols ``z, D, lam, m, R, alpha, I1, I3, g``.
    """
    dec = mett_decomposition()
    return dec["g"], dec["V"]


@cache
def rational_potential() -> dict[str, sp.Expr]:
    """The METT under the rational condition σ = (1 − γ)/(γ + α² − 1) (docs/theory/mett.md#rational; R13; RR14).

    The condition is solved for I1 (γ = 1 − σα²/(1 + σ), σ = m R²/I3). Then
    d(z) = σ(1 − γ)(z − α/(1 − γ))², and since α/(1 − γ) > 1 the root is outside [−1, 1], so
    √d = β(α − (1 − γ) z) with β = √(σ/(1 − γ)) > 0. Substituted into :func:`mett_potential`::

        V = m g R(1 − αz) + (c1 − c2 z)²/(2 I3 γ² R² (1 − z²)) + D²/(2 I3 γ) − m λ²/(2 I3² γ),
        c1 = α(λβ + R D),   c2 = λβ(1 − γ) + R D.

    Returns
    -------
    dict
        ``I1`` (the condition, in m, R, α, I3), ``gamma``, ``beta``, ``sqrt_d`` (linear in z),
        ``V`` (rational in z), ``g`` (linear in z) and ``Q`` = (1 − z²)(E − V), a cubic polynomial
        in z such that ż² = Q/g (the simplified separation equation). No ``I1`` symbol remains.

    Raises
    ------
    RuntimeError
        If d(z) is not the announced perfect square (a derivation error).
    """
    z = S.z
    sig = S.m * S.R**2 / S.I3
    gam = 1 - sig * S.alpha**2 / (1 + sig)
    I1 = sp.factor(gam * S.I3)
    d_rat = d_expr(z).subs(S.I1, I1)
    square = sig * (1 - gam) * (z - S.alpha / (1 - gam)) ** 2
    if sp.cancel(d_rat - square) != 0:  # pragma: no cover
        raise RuntimeError("d(z) is not a perfect square under the rational condition")
    beta = sp.sqrt(sp.factor(sig / (1 - gam)))
    # β stays a symbol during the algebra: cancelling with the nested square root is very slow.
    b = sp.Symbol("_beta", positive=True)
    sqrt_d = b * (S.alpha - sp.factor(1 - gam) * z)
    dec = _decomposition_sqd()
    gravity = S.m * S.g * S.R * (1 - S.alpha * z)
    kinetic = sp.Poly(sp.expand(dec["V"] - gravity), S.lam, S.D, _sqd)
    V = gravity
    for (i, j, k), coef in kinetic.terms():
        term = sp.factor(sp.cancel(coef.subs(S.I1, I1) * sqrt_d**k))
        V += term * S.lam**i * S.D**j
    g = sp.factor(dec["g"].subs(S.I1, I1))
    Q = sp.expand(sp.cancel(sp.together((1 - z**2) * (S.E - V))))
    if not sp.Poly(Q, z).degree() == 3:  # pragma: no cover
        raise RuntimeError(f"(1 - z^2)(E - V) is not a cubic in z: {Q}")
    Q = sp.collect(Q, z, sp.factor)
    V, Q, sqrt_d = (x.subs(b, beta) for x in (V, Q, sqrt_d))
    return {
        "I1": I1,
        "gamma": sp.factor(gam),
        "beta": beta,
        "sqrt_d": sqrt_d,
        "V": V,
        "g": g,
        "Q": Q,
    }
