"""Gyroscopic-balance reduction of the gliding tippe top (Moffatt & Shimomura 2002; Ueda, Sasaki &
Watanabe 2005) with the Jellett integral, as a one-dimensional slow flow of the mean inclination.

The derivation is on docs/theory/inversion.md. In short: on the slow time scale the axis
precesses steadily at the fast rate, so the state at each inclination θ is the fast steady
precession of the frictionless top with the given λ:

    R I1 (1 − α cos θ) φ̇² − λ φ̇ + m g R² α (α − cos θ) = 0   (fast root),
    I3 ω3 = I1 φ̇ cos θ − m g R α / φ̇,

(the θ̈ = 0 condition of the Euler-angle equations with θ̇ = 0, g_n = m g, and λ = −L·a). With
the centre of mass at rest its contact point slips with w = R sin θ (ω3 + φ̇ (α − cos θ)) ŷ. The
friction force turns with the precession, and the contact point answers it with the steady slip
v_A of :func:`cm_slip2` (|v_A|² = w²/(1 + (κ K)²) for the viscous law; the root of a quadratic
for the regularised Coulomb and Coulomb–Contensou laws). Friction dissipates the energy E(θ) of
the balance state at the rate P = −F_t·v_A while λ is conserved (any force at the contact
point), so

    dθ/dt = −P(θ) / E'(θ).

Its fixed points are the tumbling states (v_A = 0); near θ = 0 it grows like e^{σ t} with σ the
linear growth rate of the upright spin (checked in tests/test_inversion.py).
"""

from __future__ import annotations

import itertools
import math
from typing import NamedTuple

import numpy as np

from .. import _formulas
from ..friction import Coulomb, RegularisedCoulomb, Viscous
from ..top import TippeTop


class NoBalance(Exception):
    """The fast steady precession does not exist at this inclination (spin too low)."""

    def __init__(self, theta: float) -> None:
        super().__init__(theta)
        self.theta = theta


def nutation_period(top: TippeTop, omega3: float) -> float:
    """The fast nutation period 2π I1/(I3 |ω3|) (s) of a top spinning at ω3 (rad/s): the
    ratio first, so that a subnormal spin gives ``inf``, not a division by an underflowed zero."""
    w = abs(float(omega3))
    return 2.0 * math.pi * (top.I1 / top.I3) / w if w > 0.0 else math.inf


def balance_state(top: TippeTop, lam, theta):
    """Fast steady precession (φ̇, ω3, E, v_A, ω_n) at inclination θ with Jellett integral λ.

    Complex-safe (used with a complex step for dE/dθ). Returns NaN where the discriminant of the
    precession quadratic is negative.
    """
    m, R, a, I1, I3, g = top.m, top.R, top.alpha, top.I1, top.I3, top.g
    c = np.cos(theta)
    s = np.sin(theta)
    A = R * I1 * (1.0 - a * c)
    C = m * g * R * R * a * (a - c)
    disc = lam * lam - 4.0 * A * C
    # The fast root, written without cancellation: 2C/(λ − √disc) = (λ + √disc)/(2A).
    phidot = (lam + np.sqrt(disc)) / (2.0 * A)
    omega3 = (I1 * phidot * c - m * g * R * a / phidot) / I3
    E = 0.5 * I1 * phidot**2 * s**2 + 0.5 * I3 * omega3**2 + m * g * R * (1.0 - a * c)
    nu = R * s * (omega3 + phidot * (a - c))
    omega_n = phidot * s**2 + omega3 * c
    return phidot, omega3, E, nu, omega_n


def friction_rates(law, top: TippeTop, nu, omega_n):
    """Power lost P ≥ 0 (W) and drilling torque M about ẑ (N m) of ``law`` at slip ``nu``.

    Vectorised over ``nu``. g_n = m g in the balance state (the CM height is constant).
    """
    gn = top.m * top.g
    nu = np.asarray(nu, dtype=float)
    zero = np.zeros_like(nu)
    if isinstance(law, Viscous):
        mu = top.mu if law.mu is None else law.mu
        return mu * gn * nu * nu, zero
    if isinstance(law, RegularisedCoulomb):
        return law.mu * gn * nu * nu / np.sqrt(nu * nu + law.eps**2), zero
    if isinstance(law, Coulomb) and law.contensou_radius == 0.0:
        return law.mu * gn * np.abs(nu), zero
    raise TypeError(f"friction law {law!r} is not covered by the gyroscopic-balance flow")


def drag_form(law, top: TippeTop, omega_n=0.0):
    """(μ_c, a, b) with the law's drag c = μ_c g_n/√(a |v_A|² + b): F_t = −c v_A (SI units).

    Viscous: (μ, 0, 1) (μ in s/m); regularised Coulomb: (μ, 1, ε²); Coulomb–Contensou:
    (μ, 1, (r* ω_n)²), whose b is zero for exact Coulomb (r* = 0). Vectorised over ``omega_n``.
    """
    if isinstance(law, Viscous):
        return (top.mu if law.mu is None else law.mu), 0.0, 1.0
    if isinstance(law, RegularisedCoulomb):
        return law.mu, 1.0, law.eps**2
    if isinstance(law, Coulomb):
        return law.mu, 1.0, (law.r_star * np.asarray(omega_n, dtype=float)) ** 2
    raise TypeError(f"friction law {law!r} is not covered by the gyroscopic-balance flow")


def contact_slip2(top: TippeTop, law, theta, state):
    """Squared slip |v_A|² (m²/s²) of the contact point answering the law's force (:func:`cm_slip2`).

    ``state`` is :func:`balance_state` at ``theta``: its slip w (centre of mass at rest), fast
    precession φ̇ and spin ω_n. Vectorised.
    """
    phidot, nu, omega_n = state[0], state[3], state[4]
    mu_c, a, b = drag_form(law, top, omega_n)
    K = 1.0 + top.m * top.R**2 * (1.0 - top.alpha * np.cos(theta)) ** 2 / top.I1
    return cm_slip2(nu * nu, b, (mu_c * top.g * K / phidot) ** 2, a)


def flow_rate(top: TippeTop, lam: float, law, theta, cm_response: bool = True):
    """dθ/dt = −P(θ)/E'(θ) of the balance flow (1/s), vectorised; NaN where no balance exists.

    ``cm_response``: the slip is the contact point's steady answer to the friction force
    (:func:`contact_slip2`, the default) or, if False, the balance state's own (centre of mass at
    rest). Exact Coulomb sliding always takes the balance state's slip (see :func:`cm_slip2`).
    """
    return _flow_rate_and_state(top, lam, law, np.asarray(theta, dtype=float), cm_response)[0]


def _flow_rate_and_state(top: TippeTop, lam: float, law, theta: np.ndarray,
                         cm_response: bool = True):  # fmt: skip
    """(dθ/dt, the balance state at θ): the state is reused for D and Ẽ along the path."""
    h = 1e-30
    # Complex step: E'(θ) to machine precision, no cancellation near θ = 0 or π. The real parts
    # are the state at θ itself: its O(h²) = 1e-60 terms are far below rounding.
    cstate = balance_state(top, lam, theta + 1j * h)
    E_th = cstate[2].imag / h
    state = tuple(np.real(x) for x in cstate)
    nu = state[3]
    if cm_response and isinstance(law, Viscous | RegularisedCoulomb):
        # The power the rotation loses is c |v_A|² at the answering slip: the force is ⟂ ṙ, so
        # the centre of mass's kinetic energy is constant (cm_slip2).
        nu = np.sqrt(contact_slip2(top, law, theta, state))
    P, _ = friction_rates(law, top, nu, 0.0)
    return -P / E_th, state


# Largest step of the slow path's quadrature in s = ln tan(θ/2). Composite Simpson's error is
# O(h⁴): 1e-12 of t at h = 0.0117 (1 025 points, the thesis top), so (0.1/0.0117)⁴ · 1e-12 ≈ 5e-9
# here, far below the reduction's own error (≥ 1e-3); checked against a 16× finer grid in
# tests/test_inversion.py.
PATH_STEP = 0.1


def law_code(top: TippeTop, law) -> tuple[int, float, float]:
    """(code, μ, ε) of ``law`` for the compiled kernels (:mod:`mett.inversion._compiled`):
    viscous 0 (μ in s/m, ``top.mu`` if the law has none), regularised Coulomb 1, exact Coulomb 2
    (the laws of :func:`friction_rates`)."""
    if isinstance(law, Viscous):
        return 0, float(top.mu if law.mu is None else law.mu), 0.0
    if isinstance(law, RegularisedCoulomb):
        return 1, float(law.mu), float(law.eps)
    if isinstance(law, Coulomb) and law.contensou_radius == 0.0:
        return 2, float(law.mu), 0.0
    raise TypeError(f"friction law {law!r} is not covered by the gyroscopic-balance flow")


def top_array(top: TippeTop) -> np.ndarray:
    """(m, R, α, I1, I3, g) of ``top`` for the compiled kernels."""
    return np.array([top.m, top.R, top.alpha, top.I1, top.I3, top.g], dtype=float)


def _cumulative_simpson(f: np.ndarray, h: float) -> np.ndarray:
    """∫ f ds from the first node to each node of a uniform grid with an even number of intervals.

    Even nodes: composite Simpson (O(h⁴)); odd nodes: the previous even node plus the one-interval
    rule h/12 (5 f₀ + 8 f₁ − f₂), exact for quadratics (local O(h⁴)).
    """
    out = np.empty_like(f)
    out[0] = 0.0
    pairs = (h / 3.0) * (f[0:-2:2] + 4.0 * f[1:-1:2] + f[2::2])
    out[2::2] = np.cumsum(pairs)
    out[1::2] = out[0:-2:2] + (h / 12.0) * (5.0 * f[0:-2:2] + 8.0 * f[1:-1:2] - f[2::2])
    return out


def slow_path(top: TippeTop, lam: float, law, theta_from: float, theta_to: float,
              marks: tuple[float, ...] = (), h: float = PATH_STEP,
              fixed_point: float | None = None, cm_response: bool = True):  # fmt: skip
    """Times t(θ) along the balance flow from ``theta_from`` to ``theta_to`` (quadrature).

    With λ conserved the flow is autonomous in θ alone, so t(θ) = ∫ dθ / θ̇(θ), written in
    s = ln tan(θ/2) (dθ = sin θ ds), where the integrand sin θ / θ̇ stays bounded at both the
    upright (θ̇ ∝ θ) and the inverted or tumbling end (θ̇ ∝ θ_end − θ). The inclinations
    ``marks`` (e.g. θ0 and π/2) that lie between the ends are nodes: the path is split there into
    segments, each a uniform grid in s with an even number of steps ≤ ``h``, integrated by
    cumulative Simpson (relative error O(h⁴), see :data:`PATH_STEP`), so the times at the marks
    are quadrature values, not interpolations. With ``fixed_point`` (a tumbling angle θ_t
    beyond ``theta_to``: the flow slows like θ_t − θ there, on the scale |θ_t − theta_to| that
    s does not stretch) the grid is graded towards it: nodes at θ_t ∓ |θ_t − theta_to| 2^k, and
    at least 16 steps (at the default ``h``) between two of them. ``cm_response``: as for
    :func:`flow_rate`.
    Returns (t, θ, the balance state along θ: see :func:`balance_state`, {mark: t or inf});
    raises NoBalance at the first θ where the fast precession does not exist, ValueError if the
    flow runs backwards (the top does not move towards ``theta_to``).
    """

    def s_of(th):
        return math.log(math.tan(0.5 * th))

    lo, hi = min(theta_from, theta_to), max(theta_from, theta_to)
    inside = sorted({m for m in marks if lo < m < hi}, reverse=theta_to < theta_from)
    grading: list[float] = []
    if fixed_point is not None:
        gap = fixed_point - theta_to
        k = 1
        while lo < fixed_point - gap * 2**k < hi:
            grading.append(fixed_point - gap * 2**k)
            k += 1
    nodes = sorted({*inside, *grading}, reverse=theta_to < theta_from)
    ends = [s_of(theta_from), *(s_of(m) for m in nodes), s_of(theta_to)]
    # 16 steps per graded segment at the default step, more in proportion on a finer grid
    min_steps = 2 * math.ceil(8.0 * PATH_STEP / h) if fixed_point is not None else 2
    steps = [
        2 * max(min_steps // 2, math.ceil(abs(b - a) / (2.0 * h)))
        for a, b in itertools.pairwise(ends)
    ]
    # the nodes (each segment's np.linspace), their rates and the cumulative Simpson sums,
    # compiled: the same arithmetic as flow_rate and _cumulative_simpson, one node at a time
    from . import _compiled  # numba, at the first prediction only (not at import mett)

    code, mu, eps = law_code(top, law)
    status, index, t, theta, st = _compiled.slow_path_kernel(
        np.array(ends), np.array(steps), float(lam), top_array(top), code, mu, eps,
        bool(cm_response),
    )  # fmt: skip
    if status == 1:
        raise NoBalance(float(theta[index]))
    if status == 2:
        raise ValueError("the balance flow does not move towards the end state")
    state = tuple(st)
    sizes = [k + 1 for k in steps]
    at = {m: math.inf for m in marks}
    idx = np.cumsum([n - 1 for n in sizes])[:-1]
    for m, i in zip(nodes, idx, strict=True):
        if m in at:
            at[m] = float(t[i])
    return t, theta, state, at


def balance_D_and_E_mod(top: TippeTop, lam, theta: np.ndarray, state=None):
    """Routh integral D = I3 ω3 √d(z) and modified energy Ẽ = E + ½ m v_A² of the balance state.

    With the centre of mass at rest v_A = ω × a, and Ẽ = E + ½ m |ν|² − m ν·ṙ (docs/theory/equations.md#integrals).
    ``state``: :func:`balance_state` at (λ, θ) if already computed.
    """
    _, omega3, E, nu, _ = balance_state(top, lam, theta) if state is None else state
    z = np.cos(theta)
    D = top.I3 * omega3 * np.sqrt(_formulas.d(top, z))  # z = cos θ: in range, no checks
    return D, E + 0.5 * top.m * nu**2


# --- Coulomb–Contensou: the drilling torque makes λ a slow variable ------------------------------
#
# Leine & Glocker (2003): F_t = −μ g_n v_A/|γ|, M = −μ g_n r*² ω_n/|γ|, |γ| = √(v_A² + r*² ω_n²).
# In the balance state the power lost is P = −F_t·v_A − M ω_n = μ g_n |γ|, and the couple M ẑ (a
# force at the contact point leaves λ = −L·a unchanged) gives dλ/dt = −M ẑ·a = M R (1 − α cos θ)
# (docs/theory/friction.md#coulombcontensou). With E = E(θ, λ) of the balance state,
#
#     dθ/dt = (−P − E_λ dλ/dt)/E_θ
#           = −(μ g_n/(|γ| E_θ)) [v_A² + r*² ω_n (ω_n − R (1 − α cos θ) E_λ)],
#
# the second form of docs/theory/inversion.md#coulombcontensou. At θ = 0 both terms of the bracket
# vanish (v_A = 0 and E_λ = ω3/(R (1 − α)) = ω_n/(R (1 − α))): the flow stays linear in θ there.


def cm_slip2(w2, b, k2, a=1.0):
    """Squared slip |v_A|² (m²/s²) of the gliding top whose centre of mass follows the friction.

    In the balance state the slip w of the contact point (CM at rest) rotates with the fast
    precession φ̇, and so does the friction force F = −c v_A, c = μ g_n/√(a |v_A|² + b). The
    contact point answers with the steady solution of its slip equation in the precessing frame,
    v̇_A + i φ̇ v_A = K F/m + i φ̇ w, where K = 1 + m R² (1 − α cos θ)²/I1 is the contact point's
    inverse mass in units of 1/m (the centre of mass and the rotation both give way; the κ of the
    exact-Coulomb stop time, docs/theory/equations.md): v_A = w/(1 − i κ K), κ = c/(m φ̇) (complex
    notation in the horizontal plane), and |v_A|² = w²/(1 + (κ K)²). With k = μ g_n K/(m φ̇) and
    x = |v_A|²: x (a x + b) = w² (a x + b) − k² x, the non-negative root of

        a x² + (b + k² − a w²) x − w² b = 0.

    The laws (:func:`drag_form`): viscous a = 0, b = 1, μ in s/m, so x = w²/(1 + k²), linear in
    w²; regularised Coulomb a = 1, b = ε²; Coulomb–Contensou a = 1, b = (r* ω_n)². At a = 1,
    b = 0 (exact Coulomb) x = max(w² − k², 0): the slip stops where |w| φ̇ < μ g K, the
    exact-Coulomb stick criterion of :func:`mett.predict_inversion` (the sliding flow does not use
    it: near the upright spin w → 0 and it would stick). The power lost is c x, and the force is
    ⟂ ṙ = i κ K v_A, so the centre of mass's kinetic energy is constant. The neglected term is
    v̇_A: w grows at the flow's rate σ while the slip relaxes at φ̇ |1 − i κ K|, so the relative
    error is O(σ/φ̇) (docs/theory/inversion.md#two-stages).
    """
    B = b + k2 - a * w2
    root = np.sqrt(B * B + 4.0 * a * w2 * b)
    # the two forms of the root, each without cancellation on its side of B = 0 (B > 0 at a = 0)
    big = np.where(B > 0.0, B + root, 1.0)
    small = np.where(B > 0.0, 1.0, 2.0 * a)
    return np.where(B > 0.0, 2.0 * w2 * b / big, (root - B) / small)


def contensou_rates(top: TippeTop, law, lam, theta, cm_response: bool = True):
    """(dθ/dt, dλ/dt, the balance state) of the balance flow under Coulomb–Contensou friction.

    Vectorised over ``lam`` and ``theta``; NaN where the fast precession does not exist.
    E_θ and E_λ by complex steps (exact to rounding). The bracket ω_n − R (1 − α cos θ) E_λ
    cancels to O(θ²) near the upright spin: its rounding error is 1e-16 ω_n, a relative error
    1e-16/θ² of the rate (1e-6 at θ = 1e-5). With ``cm_response`` (default) the slip is that of
    :func:`cm_slip2`: the centre of mass follows the rotating friction force, which matters where
    the law is stiff at small slip (μ g/(r* ω_n φ̇) not small, near the end of the inversion);
    without it the slip is the balance state's own (the centre of mass at rest).
    """
    h = 1e-30
    lam = np.asarray(lam, dtype=float)
    theta = np.asarray(theta, dtype=float)
    cstate = balance_state(top, lam, theta + 1j * h)
    E_th = cstate[2].imag / h
    E_lam = balance_state(top, lam + 1j * h * lam, theta)[2].imag / (h * lam)
    state = tuple(np.real(x) for x in cstate)  # O(h²) = 1e-60 from the state at θ
    nu, omega_n = state[3], state[4]
    rs = law.r_star
    gn = top.m * top.g
    b = (rs * omega_n) ** 2
    nu2 = contact_slip2(top, law, theta, state) if cm_response else nu * nu
    gam = np.sqrt(nu2 + b)
    arm = top.R * (1.0 - top.alpha * np.cos(theta))
    k = law.mu * gn / gam
    bracket = nu2 + rs * rs * omega_n * (omega_n - arm * E_lam)
    return -k * bracket / E_th, -k * rs * rs * omega_n * arm, state


class ContensouPath(NamedTuple):
    """The balance flow in (θ, λ) under Coulomb–Contensou friction, sampled on the solver's steps."""

    t: np.ndarray
    theta: np.ndarray
    lam: np.ndarray
    state: tuple
    t_half: float
    t_end: float
    stop: str  # "end", "turns back", "no balance", "t_max"


# The smallest inclination (rad) at which the Contensou flow's rate is evaluated (contensou_path).
THETA_LINEAR = 1e-4


def contensou_path(top: TippeTop, law, lam0: float, theta_from: float, theta_to: float,
                   t_max: float, rtol: float = 1e-8, cm_response: bool = True) -> ContensouPath:  # fmt: skip
    """Integrate the Contensou balance flow from (θ_u(0), λ0) until θ reaches ``theta_to``.

    The state is (s, λ) with s = ln tan(θ/2), whose rate θ̇/sin θ stays bounded at both poles
    (the flow is linear in θ near the upright spin). Explicit Runge–Kutta 5(4) (scipy's RK45,
    ``rtol``): the flow is smooth and not stiff (its rates are O(μ g/(R ω)) and O(μ g r*/(R ω))
    relative). It stops where θ reaches ``theta_to``, where the flow turns back (θ̇ = 0: the
    drilling torque has lowered λ until the top no longer climbs), where the fast precession
    ceases to exist (the spin is consumed), or at ``t_max``.
    """
    from scipy.integrate import solve_ivp

    sign = 1.0 if theta_to > theta_from else -1.0

    def theta_of(s):
        return 2.0 * math.atan(math.exp(min(s, 700.0)))  # π to rounding beyond s = 40

    cache: dict[tuple[float, float], tuple[float, float]] = {}

    def rates(y):
        # the turning event asks at the step ends, where RK45 (FSAL) has the rates already
        key = (float(y[0]), float(y[1]))
        if key not in cache:
            # below THETA_LINEAR the flow is linear in θ to O(θ²) = 1e-8, and its bracket's
            # rounding (1e-16/θ² relative, contensou_rates) would be larger: the rate per unit
            # θ there (a saturated start leaves the inversion mode at 1e-10 rad)
            th = max(theta_of(key[0]), THETA_LINEAR)
            thd, lamd, _ = contensou_rates(top, law, key[1], th, cm_response)
            cache[key] = (float(thd) / math.sin(th), float(lamd))
        return cache[key]

    def rhs(t, y):
        r = rates(y)
        if not math.isfinite(r[0]):
            return [0.0, 0.0]  # the no-balance event ends the run here
        return list(r)

    def half(t, y):
        return theta_of(y[0]) - 0.5 * math.pi

    def end(t, y):
        return theta_of(y[0]) - theta_to

    def turns(t, y):
        r = rates(y)[0]
        return sign * r if math.isfinite(r) else -1.0

    def balance(t, y):
        # the discriminant of the precession quadratic (balance_state): < 0, no fast precession
        c = math.cos(theta_of(y[0]))
        A = top.R * top.I1 * (1.0 - top.alpha * c)
        C = top.m * top.g * top.R**2 * top.alpha * (top.alpha - c)
        return (y[1] * y[1] - 4.0 * A * C) / (y[1] * y[1])

    for ev in (end, turns, balance):
        ev.terminal = True  # type: ignore[attr-defined]
    turns.direction = -1.0  # type: ignore[attr-defined]
    balance.direction = -1.0  # type: ignore[attr-defined]
    y0 = [math.log(math.tan(0.5 * theta_from)), lam0]
    if not sign * rates(y0)[0] > 0.0:  # no climb at all (or no balance at the start)
        t0 = np.zeros(1)
        th0, l0 = np.full(1, theta_from), np.full(1, lam0)
        stop = "no balance" if balance(0.0, y0) < 0.0 else "turns back"
        return ContensouPath(t0, th0, l0, balance_state(top, l0, th0), math.inf, math.inf, stop)
    sol = solve_ivp(rhs, (0.0, t_max), y0, method="RK45", rtol=rtol,
                    atol=[1e-10, 1e-12 * lam0], events=(half, end, turns, balance))  # fmt: skip
    if sol.status < 0:
        raise ValueError(sol.message)
    theta = 2.0 * np.arctan(np.exp(sol.y[0]))
    lam = sol.y[1]
    stop = "t_max"
    for name, ev in zip(("end", "turns back", "no balance"), sol.t_events[1:], strict=True):
        if len(ev):
            stop = name
    t_half = float(sol.t_events[0][0]) if len(sol.t_events[0]) else math.inf
    t_end = float(sol.t[-1]) if stop == "end" else math.inf
    return ContensouPath(sol.t, theta, lam, balance_state(top, lam, theta), t_half, t_end, stop)


# --- Coulomb–Contensou: a start beyond the law's linear range -------------------------------------
#
# Where the start's slip |v_A| exceeds r* |ω_n| the law is Coulomb-like, not viscous: the force
# has the fixed size μ g_n while the slip falls at about μ g K, and the upright spin's linear modes
# (split with the law's small-slip coefficient μ/(r* ω_n)) do not describe the start
# (docs/theory/inversion.md#a-start-beyond-the-laws-linear-range). Two things happen there:
#
# * the inversion (fast, nutation-like) mode is not the linear split's: the start's departure from
#   the slow motion of its axis is I1 |ω_⊥ − 3̂ × τ_⊥/|L||/(I3 ω3), the cone between the axis
#   and L that the slow motion does not have (a gyroscope's axis follows L, lagging it by
#   I1 3̂̇/(I3 ω3)); the linear split instead reads an O(θ0³) mismatch of the reference spin's
#   ω3 (the same λ) as a component of the fast mode;
# * while the slip is large, friction damps that mode: its magnitude μ g_n follows the normal
#   force, which the nutation modulates at its own frequency by m l Ω² sin θ δθ when the axis is
#   tilted, in phase with the nutation's slip along v_A. The damping is the real part of the fast
#   eigenvalue of the sliding field linearised at the slow state (frozen: the slow state changes
#   at O(μ g/(R ω)) against the fast frequency Ω ≈ I3 ω3/I1).
#
# The slow state is the gyroscopic one (3̂ = L/|L|, g_n = m g): m r̈ = F, L̇ = a × (F + g_n ẑ) + M ẑ.


class SaturatedStart(NamedTuple):
    """The saturated start of a Coulomb–Contensou top, followed until its slip is linear."""

    t: np.ndarray
    """Times (s) of the slow state's samples."""
    theta: np.ndarray
    """Inclination of L (rad) at the samples: the slow tilt."""
    lam: np.ndarray
    """Jellett's λ (kg m³/s) at the samples (the drilling torque lowers it)."""
    slip: np.ndarray
    """|v_A| / (r* |ω_n|) at the samples."""
    rate: np.ndarray
    """Real part (1/s) of the fast eigenvalue of the sliding field at the samples."""
    amplitude0: float
    """The fast mode's amplitude (rad) at the start."""
    amplitude: float
    """Its amplitude (rad) at the end, t[-1]: exp(∫ rate dt) times ``amplitude0``."""


def _cross(u, v) -> np.ndarray:
    # 3-vectors in plain float arithmetic: np.cross costs ~0.3 ms a call here
    return np.array(
        [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]]
    )


def _slow_rhs(top: TippeTop, law, u: np.ndarray) -> tuple:
    """(du/dt, ν, ω_n, e, a, L) of the gyroscopic slow state u = (ẋ, ẏ, L_x, L_y, L_z)."""
    m, R, l, I3, g = top.m, top.R, top.R * top.alpha, top.I3, top.g
    L = u[2:5]
    Ln = math.sqrt(float(L[0] * L[0] + L[1] * L[1] + L[2] * L[2]))
    e = L / Ln
    w3 = Ln / I3  # L·3̂ = I3 ω3 with 3̂ = L/|L|
    a = np.array([l * e[0], l * e[1], l * e[2] - R])
    wa = w3 * _cross(e, a)  # ω × a, ω = ω3 3̂ (the transverse part is O(slow/fast))
    nu = np.array([u[0] + wa[0], u[1] + wa[1]])
    wn = w3 * e[2]
    gn = m * g
    gam = math.sqrt(float(nu[0] * nu[0] + nu[1] * nu[1]) + (law.r_star * wn) ** 2)
    F = np.array([-law.mu * gn * nu[0] / gam, -law.mu * gn * nu[1] / gam, gn])
    M = -law.mu * gn * law.r_star**2 * wn / gam
    dL = _cross(a, F)
    dL[2] += M
    return np.r_[F[:2] / m, dL], nu, wn, e, a, L


def _fast_rates(top: TippeTop, law, states: list) -> np.ndarray:
    """Re of the fast eigenvalue (1/s) of the sliding Coulomb–Contensou field
    (mett.dynamics.contact) at each slow state (e, a, L, ṙ) of ``states`` (3̂ = e along L):
    complex-step Jacobians of the 10 states, every column of every state in one call."""
    from ..dynamics.contact import slide_law
    from ..dynamics.registry import MODELS

    p = MODELS["coulomb-contensou"].params(top, {"friction": law})
    n = len(states)
    y = np.zeros((10, n))
    scale = np.ones((10, n))
    for j, (e, a, L, rdot) in enumerate(states):
        lam = -float(L @ a)
        y[:, j] = (0.0, 0.0, rdot[0], rdot[1], L[0], L[1], lam, e[0], e[1], e[2])
        Ln = math.sqrt(float(L @ L))
        scale[0:2, j] = top.R
        scale[2:4, j] = top.R * Ln / top.I3
        scale[4:6, j] = Ln
        scale[6, j] = abs(lam)
    h = 1e-30
    Y = np.repeat(y[:, :, None], 10, axis=2).astype(complex)  # (state, node, column)
    for k in range(10):
        Y[k, :, k] += 1j * h * scale[k]
    d = slide_law([Y[i].ravel() for i in range(10)], p)[0]
    J = np.imag(np.array([np.broadcast_to(x, (n * 10,)) for x in d])).reshape(10, n, 10)
    J = J.transpose(1, 0, 2) / (h * scale.T[:, None, :])  # (node, row, column)
    ev = np.linalg.eigvals(J)
    pick = np.argmax(np.abs(ev.imag), axis=1)
    return ev[np.arange(n), pick].real


def saturated_start(top: TippeTop, law, state, linear: float = 0.01, samples: int = 24,
                    t_max: float = math.inf) -> SaturatedStart | None:  # fmt: skip
    """Follow a Coulomb–Contensou start whose slip is beyond the law's linear range.

    ``None`` if the start's slip |v_A| is within r* |ω_n| (the linear split applies). Otherwise
    the gyroscopic slow state (module comment above) is integrated (RK45, rtol 1e-8) until the
    slip ratio |v_A|/(r* |ω_n|) is below 1 and within 1 % of its floor (its logarithmic rate
    above a hundredth of the linear law's relaxation rate μ g/(r* |ω_n|): the floor of a nearly
    rolling top, whose remaining tilt is the neutral, slow mode, and where the fast mode's rate
    is the linear one), or has fallen to ``linear``, or ``t_max``. The fast eigenvalue's real
    part at ``samples`` + 1 equally spaced times gives the fast mode's amplitude by the
    trapezoidal rule (its rate is smooth on the slip's scale, 1/(μ g K)).

    Parameters
    ----------
    top : TippeTop
    law : Coulomb
        With a Contensou radius (r* > 0) and μ > 0.
    state : State
        The start (ω3 > 0, θ < π/2).
    linear : float, default 0.01
        Slip ratio |v_A|/(r* |ω_n|) at which the phase ends at the latest.
    samples : int, default 24
        Intervals of the trapezoidal rule.
    t_max : float, optional
        Longest phase (s); by default ten Coulomb stop times of the slip, 10 |v_A|/(μ g).

    Returns
    -------
    SaturatedStart or None
    """
    from scipy.integrate import solve_ivp

    from ..dynamics.registry import MODELS

    gl = MODELS["gliding"]
    y0 = gl.initial(state, gl.params(top, {}))
    rdot0, L0, e0 = y0[2:4], y0[4:7], y0[7:10]
    u0 = np.r_[rdot0, L0]
    _, nu0, wn0, e, a, _ = _slow_rhs(top, law, u0)
    if math.hypot(*nu0) <= law.r_star * abs(wn0):
        return None
    # the start's cone (axis against L) less the slow motion's: I1 |ω_⊥ − 3̂ × τ_⊥/|L|| / |L|
    du, *_ = _slow_rhs(top, law, u0)
    Ln = math.sqrt(float(L0 @ L0))
    w = L0 / top.I1 + (1.0 / top.I3 - 1.0 / top.I1) * float(L0 @ e0) * e0
    w_perp = w - float(w @ e0) * e0
    tau = du[2:5]
    tau_perp = tau - float(tau @ e0) * e0
    amp0 = top.I1 * float(np.linalg.norm(w_perp - _cross(e0, tau_perp) / Ln)) / Ln

    def rhs(t, u):
        return _slow_rhs(top, law, u)[0]

    def ratio(u):
        _, nu, wn, *_ = _slow_rhs(top, law, u)
        return math.hypot(*nu) / (law.r_star * abs(wn))

    def linear_event(t, u):
        return ratio(u) - linear

    h_stall = 1e-5 / (law.mu * top.g)  # 1e-5 of the slip's time scale
    # the linear law relaxes the slip at μ g K/(r* |ω_n|) (K >= 1, taken as 1)
    k_lin = law.mu * top.g / (law.r_star * abs(wn0))

    def settles(t, u):
        # the slip is linear and has settled on its floor (the slow, neutral mode's own slip):
        # d ln(ratio)/dt above −k_lin/100, i.e. within 1 % of its floor. Not fired while saturated.
        r = ratio(u)
        if r > 1.0:
            return -1.0
        return (ratio(u + h_stall * _slow_rhs(top, law, u)[0]) - r) / (h_stall * r) + 0.01 * k_lin

    linear_event.terminal = True  # type: ignore[attr-defined]
    settles.terminal = True  # type: ignore[attr-defined]
    settles.direction = 1.0  # type: ignore[attr-defined]
    if not math.isfinite(t_max):
        # the slip falls at ≈ μ g K, K ≥ 1: ten times its Coulomb stop time bounds the phase
        t_max = 10.0 * math.hypot(*nu0) / (law.mu * top.g)
    sol = solve_ivp(rhs, (0.0, t_max), u0, method="RK45", rtol=1e-8, dense_output=True,
                    events=(linear_event, settles))  # fmt: skip
    t1 = float(sol.t[-1])
    ts = np.linspace(0.0, t1, samples + 1)
    th, lam, slip = (np.empty(samples + 1) for _ in range(3))
    states = []
    for i, t in enumerate(ts):
        u = sol.sol(t)
        _, nu, wn, e, a, L = _slow_rhs(top, law, u)
        th[i] = math.acos(min(1.0, e[2]))
        lam[i] = -float(L @ a)
        slip[i] = math.hypot(*nu) / (law.r_star * abs(wn))
        states.append((e, a, L, u[0:2]))
    rate = _fast_rates(top, law, states)
    log_gain = float(np.sum(0.5 * (rate[1:] + rate[:-1]) * np.diff(ts)))
    # a gain beyond e^700 is a mode far past any small amplitude (the caller refuses > 0.5 rad)
    return SaturatedStart(ts, th, lam, slip, rate, amp0, amp0 * math.exp(min(log_gain, 700.0)))
