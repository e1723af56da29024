"""The sympy derivations (mett.symbolic) against the numeric core and the documented formulas.

Each derived expression is checked numerically at random states against the numeric core
(mett.V, mett.g, mett.V_rational, mett.jellett/routh/energy, mett.dynamics.euler.euler_rhs) and,
where the docs state an exact form (the Euler-angle equations of docs/theory/equations.md#euler-form,
typed in below as an independent reference, or the Maple paper's errata), symbolically. The derivations are cached, so each runs once per session.
"""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

sp = pytest.importorskip("sympy")

import mett  # noqa: E402
from mett import symbolic as sym  # noqa: E402
from mett.symbolic import PARAMS, STATE, S, trig_reduce  # noqa: E402
from mett.symbolic import maple_tippe_top as mtt  # noqa: E402

MAPLE = mtt.MAPLE
TH, THD, PHD, W3, NUX, NUY = STATE
sin, cos = sp.sin(TH), sp.cos(TH)

TOPS = {
    "rutstam2013": mett.presets.get("rutstam2013"),
    "rutstam2012": mett.presets.get("rutstam2012"),
    # A generic, non-rational body with a large friction coefficient.
    "generic": mett.TippeTop(m=0.03, R=0.025, alpha=0.4, I1=0.3 * 0.03 * 0.025**2,
                             I3=0.45 * 0.03 * 0.025**2, mu=0.8, g=9.81),
}  # fmt: skip


def params(top: mett.TippeTop) -> tuple[float, ...]:
    return (top.m, top.R, top.alpha, top.I1, top.I3, top.mu, top.g)


def random_states(n: int, seed: int = 0, gliding: bool = True) -> np.ndarray:
    """(6, n) array of states [θ, θ̇, φ̇, ω3, ν_x, ν_y] away from the poles."""
    rng = np.random.default_rng(seed)
    y = np.empty((6, n))
    y[0] = rng.uniform(0.15, np.pi - 0.15, n)
    y[1] = rng.normal(0.0, 5.0, n)
    y[2] = rng.normal(0.0, 8.0, n)
    y[3] = rng.uniform(-150.0, 150.0, n)
    y[4:] = rng.normal(0.0, 0.3, (2, n)) if gliding else 0.0
    return y


def numeric(expr: sp.Expr, args: tuple) -> object:
    return sp.lambdify(args, expr, modules="numpy")


def rel_err(a, b) -> float:
    a, b = np.broadcast_arrays(np.asarray(a, float), np.asarray(b, float))
    return float(np.max(np.abs(a - b) / (np.abs(b) + 1e-300 + np.max(np.abs(b)) * 1e-14)))


# --- Rutstam 2013, eqs (10)–(15), typed in as an independent reference ----------------------------


def sheet_euler(gn: sp.Expr) -> dict[str, sp.Expr]:
    m, R, al, I1, I3, mu, g = PARAMS
    s, c = sin, cos
    return {
        "thetaddot": (s / I1) * (I1 * PHD**2 * c - I3 * W3 * PHD - R * al * gn)
        + (R * mu * gn * NUX / I1) * (1 - al * c),
        "phiddot": (I3 * THD * W3 - 2 * I1 * THD * PHD * c - mu * gn * NUY * R * (al - c))
        / (I1 * s),
        "omega3dot": -mu * gn * NUY * R * s / I3,
        "nuxdot": (R * s / I1)
        * (
            PHD * W3 * (I3 * (1 - al * c) - I1)
            + gn * R * al * (1 - al * c)
            - I1 * al * (THD**2 + PHD**2 * s**2)
        )
        - (mu * gn * NUX / (m * I1)) * (I1 + m * R**2 * (1 - al * c) ** 2)
        + PHD * NUY,
        "nuydot": -(mu * gn * NUY / (m * I1 * I3))
        * (I1 * I3 + m * R**2 * I3 * (al - c) ** 2 + m * R**2 * I1 * s**2)
        + (W3 * THD * R / I1) * (I3 * (al - c) + I1 * c)
        - PHD * NUX,
    }


def sheet_gn() -> sp.Expr:
    m, R, al, I1, I3, mu, g = PARAMS
    s, c = sin, cos
    num = m * g * I1 + m * R * al * (c * (I1 * PHD**2 * s**2 + I1 * THD**2) - I3 * PHD * W3 * s**2)
    return num / (I1 + m * R**2 * al**2 * s**2 - m * R**2 * al * s * (1 - al * c) * mu * NUX)


KEYS = ("thetaddot", "phiddot", "omega3dot", "nuxdot", "nuydot")


# --- the frame and the Euler equations ----------------------------------------------------------


def test_resal_frame_is_derived_as_in_theory():
    fr = sym.resal_frame()
    assert fr["zhat"] == sp.Matrix([-sin, 0, cos])
    assert fr["xhat"] == sp.Matrix([cos, 0, sin])
    assert fr["yhat"] == sp.Matrix([0, 1, 0])
    assert fr["Omega"] == sp.Matrix([-PHD * sin, THD, PHD * cos])


def test_euler_equations_use_the_documented_symbols():
    eq = sym.gliding_euler_equations()
    assert set(eq) == {*KEYS, "gn"}
    names = {
        "theta", "thetadot", "phidot", "omega3", "nu_x", "nu_y",
        "m", "R", "alpha", "I1", "I3", "mu", "g",
    }  # fmt: skip
    for expr in eq.values():
        assert {s.name for s in expr.free_symbols} <= names


def test_euler_equations_equal_formula_sheet_symbolically():
    """Implicit form (g_n a symbol) and the normal force are identical to docs/theory/equations.md#euler-form."""
    eq = sym.gliding_euler_equations(explicit=False)
    sheet = sheet_euler(S.g_n)
    for k in KEYS:
        assert trig_reduce(eq[k] - sheet[k]) == 0, k
    assert trig_reduce(eq["gn"] - sheet_gn()) == 0


@pytest.mark.parametrize("name", sorted(TOPS))
def test_euler_equations_equal_formula_sheet_numerically(name):
    eq = sym.gliding_euler_equations()
    sheet = {k: v.subs(S.g_n, sheet_gn()) for k, v in sheet_euler(S.g_n).items()}
    y, p = random_states(200, seed=1), params(TOPS[name])
    for k in (*KEYS, "gn"):
        ref = sheet_gn() if k == "gn" else sheet[k]
        got = numeric(eq[k], (*STATE, *PARAMS))(*y, *p)
        want = numeric(ref, (*STATE, *PARAMS))(*y, *p)
        assert rel_err(got, want) < 1e-11, k


def test_euler_equations_match_numeric_rhs():
    """The derived equations against mett.dynamics.euler (written independently, by hand)."""
    from mett.dynamics.euler import euler_normal_force, euler_rhs

    eq = sym.gliding_euler_equations()
    for name, top in TOPS.items():
        y, p = random_states(300, seed=2), params(top)
        rhs = euler_rhs(y, p)
        np.testing.assert_allclose(rhs[0], y[1], rtol=0, atol=0)
        for i, k in enumerate(KEYS, start=1):
            got = numeric(eq[k], (*STATE, *PARAMS))(*y, *p)
            assert rel_err(rhs[i], got) < 1e-10, (name, k)
        gn = numeric(eq["gn"], (*STATE, *PARAMS))(*y, *p)
        assert rel_err(euler_normal_force(y, p), gn) < 1e-12, name


def _time_derivative(expr: sp.Expr, eq: dict[str, sp.Expr]) -> sp.Expr:
    rates = {
        TH: THD, THD: eq["thetaddot"], PHD: eq["phiddot"], W3: eq["omega3dot"],
        NUX: eq["nuxdot"], NUY: eq["nuydot"],
    }  # fmt: skip
    return sum(sp.diff(expr, q) * r for q, r in rates.items())


def test_derived_equations_conserve_jellett_and_dissipate_energy():
    """λ̇ = 0 (for any g_n) and Ė = −μ g_n |ν|² along the derived equations (docs/theory/equations.md#dissipation, docs/theory/equations.md#integrals)."""
    eq = sym.gliding_euler_equations(explicit=False)
    ints = sym.integrals()
    assert trig_reduce(_time_derivative(ints["lam"], eq)) == 0
    # Ė involves the vertical CM motion, so g_n must take its value (vertical Newton) here.
    Edot = _time_derivative(ints["E"], eq).subs(S.g_n, eq["gn"])
    assert trig_reduce(Edot + S.mu * eq["gn"] * (NUX**2 + NUY**2)) == 0


def test_routh_rate_matches_theory():
    """Ḋ = −μ g_n R ν_y sin θ √d + σ ω3 θ̇ sin θ [I3(α − z) + I1 z]/√d (docs/theory/equations.md#integrals)."""
    eq = sym.gliding_euler_equations(explicit=False)
    ints = sym.integrals()
    m, R, al, I1, I3, mu, g = PARAMS
    d = sym.d_expr(cos)
    sigma = m * R**2 / I3
    want = -mu * S.g_n * R * NUY * sin * sp.sqrt(d) + sigma * W3 * THD * sin * (
        I3 * (al - cos) + I1 * cos
    ) / sp.sqrt(d)
    f = numeric(_time_derivative(ints["D"], eq) - want, (*STATE, *PARAMS, S.g_n))
    y = random_states(100, seed=3)
    for top in TOPS.values():
        scale = top.I3 * 150 * 10
        assert np.max(np.abs(f(*y, *params(top), 0.3))) < 1e-12 * scale


# --- integrals and the METT ---------------------------------------------------------------------


@pytest.mark.parametrize("name", sorted(TOPS))
def test_integrals_match_numeric_core(name):
    top, ints = TOPS[name], sym.integrals()
    y = random_states(200, seed=4)
    state = mett.State(*y)
    ref = {
        "lam": mett.jellett(top, state),
        "D": mett.routh(top, state),
        "E": mett.energy(top, state),
        "E_mod": mett.modified_energy(top, state),
    }
    for k, want in ref.items():
        got = numeric(ints[k], (*STATE, *PARAMS))(*y, *params(top))
        assert rel_err(got, want) < 1e-12, k


def test_modified_energy_does_not_depend_on_slip():
    assert not sym.integrals()["E_mod"].has(NUX, NUY)


def test_mett_has_no_linear_term_and_g_is_half_I1_plus_m_a_squared():
    dec = sym.mett_decomposition()
    m, R, al, I1 = S.m, S.R, S.alpha, S.I1
    assert dec["linear"] == 0
    assert sp.expand(dec["g"] - (I1 + m * R**2 * (1 + al**2 - 2 * al * S.z)) / 2) == 0


def _sheet_V() -> sp.Expr:
    """Completed-square V of docs/theory/mett.md#the-main-equation."""
    m, R, al, I1, I3, g = S.m, S.R, S.alpha, S.I1, S.I3, S.g
    z, D, lam = S.z, S.D, S.lam
    N = lam * sp.sqrt(sym.d_expr()) + R * D * (al - z)
    return (
        m * g * R * (1 - al * z)
        + I3 * N**2 / (2 * I1**2 * R**2 * (1 - z**2))
        + D**2 / (2 * I1)
        - m * lam**2 / (2 * I1 * I3)
    )


def test_V_equals_completed_square_form_symbolically():
    _, V = sym.mett_potential()
    q = sp.Symbol("q", positive=True)  # √d(z)
    diff = sp.expand((V - _sheet_V()).subs(sp.sqrt(sym.d_expr()), q))
    num = sp.numer(sp.together(diff))
    rem = sp.reduced(sp.expand(num), [q**2 - sym.d_expr()], q)[1]
    assert sp.expand(rem) == 0


@pytest.mark.parametrize("name", sorted(TOPS))
def test_g_and_V_match_numeric_core(name):
    top = TOPS[name]
    g, V = sym.mett_potential()
    args = (S.z, S.D, S.lam, S.m, S.R, S.alpha, S.I1, S.I3, S.g)
    p = (top.m, top.R, top.alpha, top.I1, top.I3, top.g)
    # (z, D, λ) of random physical states, so that V is of the size it has in practice.
    y = random_states(300, seed=5)
    st = mett.State(*y)
    z, D, lam = np.cos(y[0]), mett.routh(top, st), mett.jellett(top, st)
    got_V = numeric(V, args)(z, D, lam, *p)
    assert rel_err(got_V, mett.V(top, z, D, lam)) < 1e-11
    got_g = numeric(g, args)(z, D, lam, *p) * np.ones_like(z)
    assert rel_err(got_g, mett.g(top, z)) < 1e-13
    # The METT identity itself: Ẽ = g θ̇² + V with the state's own D and λ (any ν).
    assert rel_err(got_g * y[1] ** 2 + got_V, mett.modified_energy(top, st)) < 1e-11


def test_rational_condition_makes_d_a_perfect_square():
    rat = sym.rational_potential()
    d_rat = sym.d_expr().subs(S.I1, rat["I1"])
    assert sp.cancel(d_rat - rat["sqrt_d"] ** 2) == 0
    assert not rat["V"].has(S.I1)
    assert sp.Poly(rat["Q"], S.z).degree() == 3
    assert sp.Poly(rat["g"], S.z).degree() == 1


def test_rational_condition_reproduces_thesis_inertia_exactly():
    """σ = 5/2, α = 3/10 gives I1 = 131/350 m R² (docs/theory/mett.md#rational) in exact arithmetic."""
    m, R = sp.Rational(1, 50), sp.Rational(1, 50)
    vals = {S.m: m, S.R: R, S.alpha: sp.Rational(3, 10), S.I3: sp.Rational(2, 5) * m * R**2}
    rat = sym.rational_potential()
    assert rat["I1"].subs(vals) == sp.Rational(131, 350) * m * R**2
    assert rat["gamma"].subs(vals) == sp.Rational(131, 140)


def test_rational_V_matches_numeric_core():
    top = TOPS["rutstam2013"]
    rat = sym.rational_potential()
    assert top.I1 == pytest.approx(float(rat["I1"].subs({S.m: top.m, S.R: top.R, S.alpha: top.alpha, S.I3: top.I3})), rel=1e-14)  # fmt: skip
    args = (S.z, S.D, S.lam, S.m, S.R, S.alpha, S.I3, S.g)
    y = random_states(300, seed=6)
    st = mett.State(*y)
    z, D, lam = np.cos(y[0]), mett.routh(top, st), mett.jellett(top, st)
    p = (top.m, top.R, top.alpha, top.I3, top.g)
    got = numeric(rat["V"], args)(z, D, lam, *p)
    assert rel_err(got, mett.V_rational(top, z, D, lam)) < 1e-11
    assert rel_err(got, mett.V(top, z, D, lam)) < 1e-11
    # ż² = Q/g with the METT's f (separation equation), at the states' own E.
    E = mett.modified_energy(top, st)
    Q = numeric(rat["Q"], (*args, S.E))(z, D, lam, *p, E)
    g = numeric(rat["g"], args)(z, D, lam, *p)
    # Ẽ − V cancels: measure the error on the scale (1 − z²) Ẽ/g of the terms that cancel.
    scale = (1 - z**2) * E / g
    assert np.max(np.abs(Q / g - mett.f(top, z, E, D, lam)) / scale) < 1e-12
    assert np.max(np.abs(Q / g - (np.sin(y[0]) * y[1]) ** 2) / scale) < 1e-12


# --- the Maple paper: the Routhian model, its corrected equations and the printed errors ----------------

I_, A_, B1 = MAPLE.I, MAPLE.a, MAPLE.beta1


def test_printed_routhian_is_the_one_without_vertical_cm_energy():
    printed = (
        (I_ * THD**2 + I_ * sin**2 * PHD**2) / 2
        - S.m * S.g * (S.R - A_ * cos)
        - B1**2 / (2 * S.I3)
        + B1 * PHD * cos
    )
    cm = S.m * (MAPLE.xdot**2 + MAPLE.ydot**2) / 2
    assert sp.expand(mtt.routhian(vertical_cm=False) - printed - cm) == 0
    extra = mtt.routhian(vertical_cm=True) - mtt.routhian(vertical_cm=False)
    assert sp.expand(extra - S.m * A_**2 * sin**2 * THD**2 / 2) == 0


def corrected_a() -> dict[str, sp.Expr]:
    """Equations (a) of docs/maple-tippe-top-errata.md#corrected-equations."""
    m, g = S.m, S.g
    thdd = sin * (I_ * PHD**2 * cos - B1 * PHD - m * g * A_ - m * A_**2 * THD**2 * cos)
    return {
        "thetaddot": thdd / (I_ + m * A_**2 * sin**2),
        "phiddot": THD * (B1 - 2 * I_ * PHD * cos) / (I_ * sin),
    }


def approximation_b() -> dict[str, sp.Expr]:
    """Equations (b): the printed Routhian's Euler–Lagrange equations."""
    return {
        "thetaddot": sin * (I_ * PHD**2 * cos - B1 * PHD - S.m * S.g * A_) / I_,
        "phiddot": THD * (B1 - 2 * I_ * PHD * cos) / (I_ * sin),
    }


@pytest.mark.parametrize(("vertical_cm", "ref"), [(True, corrected_a), (False, approximation_b)])
def test_routhian_equations_equal_errata_forms(vertical_cm, ref):
    eq = mtt.routhian_equations(vertical_cm)
    for k, v in ref().items():
        assert trig_reduce(eq[k] - v) == 0, k
    assert eq["xddot"] == 0 and eq["yddot"] == 0


def test_printed_eq14_differs_from_b_as_errata_state():
    b = mtt.routhian_equations(vertical_cm=False)["thetaddot"]
    want = sin * (3 * B1 * PHD + 2 * S.m * S.g * A_) / I_
    assert trig_reduce(mtt.printed_eq14() - b - want) == 0


def test_printed_eq15_differs_from_b_as_errata_state():
    b = mtt.routhian_equations(vertical_cm=False)["phiddot"]
    assert trig_reduce(mtt.printed_eq15() - b + B1 * THD / (I_ * sin**2)) == 0


def test_printed_eq17_errors():
    p17 = mtt.printed_eq17()
    at_rest = {S.mu: 0}
    # (17, θ) without friction repeats the errors of (14).
    assert trig_reduce(p17["thetaddot"].subs(at_rest) - mtt.printed_eq14()) == 0
    # (17, φ) without friction contradicts (15): erratum 9.
    diff = p17["phiddot"].subs(at_rest) - mtt.printed_eq15()
    assert trig_reduce(diff - 2 * B1 * THD * (1 - sin) / (I_ * sin**2)) == 0
    # The φ friction torque: printed lever a − R sin θ, correct a − R cos θ (erratum 8).
    printed_lever = sp.diff(p17["phiddot"], S.mu) / (-MAPLE.F_N * MAPLE.ydot) * I_ * sin
    assert trig_reduce(printed_lever - (A_ - S.R * sin)) == 0
    fe = mtt.friction_equations()
    forces = mtt.generalized_forces()
    _, nu_y = mtt.slip_components()
    assert trig_reduce(forces["phi"] + S.mu * S.g_n * A_ * sin * nu_y, MAPLE.phi) == 0
    assert trig_reduce(forces["psi"] + S.mu * S.g_n * S.R * sin * nu_y, MAPLE.phi) == 0
    assert fe["beta1dot"] != 0  # β₁ is not a constant with friction (erratum 11)


def test_printed_eq14_topples_a_nonspinning_top():
    """Erratum 2: with β₁ = 0 the printed (14) makes θ = 0 a maximum of the potential."""
    from scipy.integrate import solve_ivp

    vals = {I_: 45.0, S.I3: 50.0, S.m: 13.0, S.g: 981.0, A_: 0.39, B1: 0.0}  # CGS, α = 0.3
    rhs = {}
    for name, expr in (("printed", mtt.printed_eq14()), ("b", approximation_b()["thetaddot"])):
        f = sp.lambdify((TH, THD, PHD), expr.subs(vals), "math")
        rhs[name] = lambda t, u, f=f: [u[1], f(u[0], u[1], 0.0)]
    th = {
        k: solve_ivp(f, (0, 0.5), [0.1, 0.0], rtol=1e-10, atol=1e-12).y[0, -1]
        for k, f in rhs.items()
    }
    assert th["printed"] > np.pi / 2  # toppled (4.70 rad in the errata)
    assert abs(th["b"]) <= 0.1 + 1e-9  # pendulum about θ = 0
    assert th["b"] == pytest.approx(0.0515, abs=5e-4)


def _maple_from_thesis(y: np.ndarray, phi: np.ndarray, top: mett.TippeTop) -> dict:
    """The Maple paper's velocities (ψ̇, ẋ, ẏ) of a thesis state, for a given φ (ν inverted, docs/theory/model.md#conventions)."""
    th, thd, phd, w3, nux, nuy = y
    a, R = top.alpha * top.R, top.R
    psidot = w3 - phd * np.cos(th)
    along_y = nuy - np.sin(th) * (R * psidot + a * phd)  # ẋ cos φ + ẏ sin φ
    along_x = nux + (R - a * np.cos(th)) * thd  # ẋ sin φ − ẏ cos φ
    xdot = along_x * np.sin(phi) + along_y * np.cos(phi)
    ydot = -along_x * np.cos(phi) + along_y * np.sin(phi)
    return {"psidot": psidot, "xdot": xdot, "ydot": ydot}


@pytest.mark.parametrize("name", sorted(TOPS))
def test_maple_lagrangian_with_friction_equals_gliding_euler(name):
    """Lagrange + generalized forces (the Maple paper's variables) ≡ Newton–Euler (thesis variables)."""
    top = TOPS[name]
    fe, eq = mtt.friction_equations(), sym.gliding_euler_equations()
    y = random_states(200, seed=7)
    phi = np.random.default_rng(8).uniform(0, 2 * np.pi, y.shape[1])
    v = _maple_from_thesis(y, phi, top)
    maple_args = (TH, MAPLE.phi, THD, PHD, MAPLE.psidot, MAPLE.xdot, MAPLE.ydot)
    maple_par = (S.m, S.R, A_, I_, S.I3, S.mu, S.g)
    sv = (y[0], phi, y[1], y[2], v["psidot"], v["xdot"], v["ydot"])
    sp_ = (top.m, top.R, top.alpha * top.R, top.I1, top.I3, top.mu, top.g)
    ev = {k: numeric(eq[k], (*STATE, *PARAMS))(*y, *params(top)) for k in eq}
    gn = numeric(fe["gn"], (*maple_args, *maple_par))(*sv, *sp_)
    sd = {k: numeric(fe[k], (*maple_args, *maple_par, S.g_n))(*sv, *sp_, gn) for k in fe}
    assert rel_err(sd["thetaddot"], ev["thetaddot"]) < 1e-10
    assert rel_err(sd["phiddot"], ev["phiddot"]) < 1e-10
    assert rel_err(sd["gn"], ev["gn"]) < 1e-12
    assert rel_err(sd["beta1dot"] / top.I3, ev["omega3dot"]) < 1e-10


def test_maple_friction_equations_equal_errata_forms():
    """The corrected friction model of the errata page, in the Maple paper's variables, exactly."""
    fe = mtt.friction_equations()
    nu_x, nu_y = mtt.slip_components()
    b1 = S.I3 * (MAPLE.psidot + PHD * cos)
    mu, gn, R = S.mu, S.g_n, S.R
    want_th = (
        sin * (I_ * PHD**2 * cos - b1 * PHD - A_ * gn) + mu * gn * (R - A_ * cos) * nu_x
    ) / I_
    want_ph = (THD * (b1 - 2 * I_ * PHD * cos) - mu * gn * (A_ - R * cos) * nu_y) / (I_ * sin)
    # The Lagrangian θ̈ carries m g a and the vertical-CM term where the errata form has a g_n:
    # the two agree once g_n has its value.
    on_shell = {gn: fe["gn"]}
    assert trig_reduce((fe["thetaddot"] - want_th).subs(on_shell), MAPLE.phi) == 0
    assert trig_reduce(fe["phiddot"] - want_ph, MAPLE.phi) == 0
    assert trig_reduce(fe["beta1dot"] + mu * gn * R * sin * nu_y, MAPLE.phi) == 0
    # g_n = m g + m a (θ̇² cos θ + θ̈ sin θ), the paper's eq. (21), is satisfied by the explicit g_n.
    implicit = S.m * S.g + S.m * A_ * (THD**2 * cos + fe["thetaddot"] * sin)
    assert trig_reduce(implicit.subs(gn, fe["gn"]) - fe["gn"], MAPLE.phi) == 0


def test_corrected_routhian_equations_equal_gliding_euler_without_friction():
    """Equations (a) ≡ the gliding model at μ = 0, for every slip ν (valid for all states).

    At μ = 0 the contact force is vertical, θ̈, φ̈, ω̇3 and g_n do not depend on ν, and the
    horizontal CM motion decouples (ẍ = ÿ = 0): the ν̇ equations are then the kinematics of the
    contact point, ν = v_A with ẋ, ẏ constant, which is checked too (φ drops out).
    """
    eq = {k: v.subs(S.mu, 0) for k, v in sym.gliding_euler_equations().items()}
    a = {k: v.subs(mtt.to_thesis()) for k, v in mtt.routhian_equations(True).items()}
    assert trig_reduce(eq["thetaddot"] - a["thetaddot"]) == 0
    assert trig_reduce(eq["phiddot"] - a["phiddot"]) == 0
    assert eq["omega3dot"] == 0
    assert not eq["gn"].has(NUX, NUY)
    # ν from its lab definition, differentiated with (a), β₁ constant and ẍ = ÿ = 0.
    nu_x, nu_y = (v.subs(mtt.to_thesis()) for v in mtt.slip_components())
    psiddot = -a["phiddot"] * cos + PHD * sin * THD  # d/dt (ω3 − φ̇ cos θ), ω3 constant
    rates = {
        TH: THD, THD: a["thetaddot"], PHD: a["phiddot"], MAPLE.psidot: psiddot, MAPLE.phi: PHD,
    }  # fmt: skip
    xy = sp.solve([nu_x - NUX, nu_y - NUY], [MAPLE.xdot, MAPLE.ydot], dict=True)[0]
    back = {MAPLE.psidot: W3 - PHD * cos}
    for lab, key in ((nu_x, "nuxdot"), (nu_y, "nuydot")):
        rate = sum(sp.diff(lab, q) * r for q, r in rates.items()).subs(xy).subs(back)
        assert trig_reduce(rate - eq[key], MAPLE.phi) == 0, key


# --- packaging ----------------------------------------------------------------------------------


def test_import_mett_does_not_import_sympy():
    code = "import mett, sys; assert 'sympy' not in sys.modules, 'sympy imported'"
    subprocess.run([sys.executable, "-c", code], check=True)


def test_derivations_are_cached():
    calls = (
        sym.gliding_euler_equations,
        sym.integrals,
        sym.mett_potential,
        sym.rational_potential,
        lambda: mtt.routhian_equations(True),
        mtt.friction_equations,
    )

    def parts(x):
        return list(x.values()) if isinstance(x, dict) else list(x) if isinstance(x, tuple) else [x]

    for f in calls:
        a, b = f(), f()
        # cached: the second call hands back the very expressions of the first (no re-derivation;
        # a container around them may be new, so that callers cannot modify the cache)
        assert a == b
        assert all(p is q for p, q in zip(parts(a), parts(b), strict=True))
