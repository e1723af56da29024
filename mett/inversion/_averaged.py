"""The averaged flow: the slow evolution of the gliding top's integrals (ω3, E') averaged over its
nutation band, with the centre of mass's horizontal velocity as the slow slip variable
(docs/theory/inversion.md#the-averaged-flow).

Fast motion. Without friction a gliding top keeps its horizontal momentum, ω3 (the normal force
has no torque about 3̂), Jellett's λ and the energy of the rotation and the height,
E_g = ½ I1 (θ̇² + φ̇² sin²θ) + ½ m (R α sin θ θ̇)² + ½ I3 ω3² + m g R (1 − α cos θ). With
φ̇ = N(z)/(R I1 (1 − z²)), N(z) = λ + R I3 ω3 (α − z) (λ's definition) it separates like the heavy
top: with z = cos θ, δ = 1 − z and E' = E_g − ½ I3 ω3²,

    G(z) θ̇² + W'(z) = E',   G = ½ (I1 + m R² α² (1 − z²)),   W' = N²/(2 R² I1 (1 − z²)) + m g R (1 − α z),
    ż² = P(δ)/G,   P(δ) = q δ³ − (2q + e + C k²) δ² + 2 (e − C n1 k) δ − C n1²,

a cubic (q = m g R α, e = E' − m g R (1 − α), k = R I3 ω3, n1 = λ − k (1 − α), C = 1/(2 R² I1)).
δ oscillates between its roots δ_a < δ_b in [0, 2] (the third, δ_3, lies beyond 2) with the exact
period T = 2 ∫ √(G/P) dδ. The substitution δ = c + h sin u turns √(G/P) dδ into
√(G/(q (δ_3 − δ))) du, smooth: Gauss–Legendre in u converges exponentially. This is the band of
the gliding top, not the rolling top's band of the METT V(z, D, λ) (the two differ where the
contact slips: docs page).

Slow motion. Friction F = −c g_n ν at the contact (c = μ viscous, μ/√(|ν|² + ε²) regularised
Coulomb) changes, exactly, I3 ω̇3 = −c g_n R sin θ ν_y and Ė_g = F·(ω × a) = −c g_n ν·w, with
w = (ω × a)_h the slip of the centre of mass at rest and ν = w + ṙ. The centre of mass's velocity
ṙ obeys m r̈ = F; in the frame turning with the band's mean precession Ω = ⟨φ̇⟩ it is U, and the
band's own frame (x̂, ŷ) is turned from it by δφ(t) = ∫ (φ̇ − Ω) dt. Averaged over a period at
frozen (ω3, E', U):

    I3 dω3/dt = −⟨c g_n R sin θ ν_y⟩,   dE'/dt = −⟨c g_n ν·w⟩ − I3 ω3 dω3/dt,
    m dU/dt = −i Ω m U − ⟨K c g_n e^{iδφ} ν⟩,   ν = w + e^{−iδφ} U   (complex, x̂ + iŷ),

with g_n = m g + ½ m R α dP/G/dδ from the band's own vertical motion. U is the contact point's
answer: K = 1 + m R² (1 − α z)²/I1 is its inverse mass in units of 1/m, the centre of mass and
the rotation both giving way (the gyroscopic method's response, docs page "The contact point's
response"); the centre of mass's share U_cm (K = 1) moves the body, the rest offsets the
rotation, on which the force does its work. The fast precession (Ω ≈ λ/(R I1)) turns U far
faster than the integrals change, so U is slaved: dU/dt = 0 is solved at every step (the lag is
O(slow rate/Ω)). Where the band stays at the bottom of its well the flow is the gyroscopic
method's balance flow, reached by another route.

Coulomb–Contensou (Leine & Glocker 2003): c = μ/√(|ν|² + (r* ω_n)²) at each node, and the
drilling torque M = −c g_n r*² ω_n makes λ a third slow variable, dλ/dt = ⟨M R (1 − α cos θ)⟩
(:func:`rates`).
"""

from __future__ import annotations

import math

import numpy as np

from .. import _formulas as fm
from ..friction import Coulomb, RegularisedCoulomb, Viscous
from ..top import TippeTop
from ._gyroscopic import cm_slip2

# Gauss–Legendre nodes in u ∈ (−π/2, π/2) and the matrix that integrates a function known at the
# nodes from −π/2 to each node (the interpolating Legendre series, integrated exactly).
_N = 32
_X, _WX = np.polynomial.legendre.leggauss(_N)
_UNODES = 0.5 * math.pi * _X
_WEIGHTS = 0.5 * math.pi * _WX
_L = np.polynomial.legendre
_CUM = (
    0.5 * math.pi * _L.legval(_X, _L.legint(np.linalg.inv(_L.legvander(_X, _N - 1)), lbnd=-1.0)).T
)
_SIN, _COS2 = np.sin(_UNODES), np.cos(_UNODES) ** 2
_ONE = (np.zeros(1), np.ones(1), np.array([math.pi]))
_METHOD = "LSODA"


class AveragingFails(Exception):
    """The band cannot be followed (no motion, a separatrix) or the slip has no steady answer."""


def _law(top: TippeTop, law):
    """(μ, ε, r*): the drag c = μ g_n/√(|ν|² + ε²) (ε None: viscous, c = μ g_n), and for
    Coulomb–Contensou ε = r* |ω_n| at each node (Leine & Glocker 2003's law with the effective
    radius r*, :class:`mett.friction.Coulomb`), r* = 0 otherwise."""
    if isinstance(law, Viscous):
        return (top.mu if law.mu is None else law.mu), None, 0.0
    if isinstance(law, RegularisedCoulomb):
        return law.mu, law.eps, 0.0
    if isinstance(law, Coulomb) and law.contensou_radius > 0.0:
        return law.mu, None, law.r_star
    raise TypeError(f"the averaged flow has no rate for {law!r}")


def _node_eps(nodes, eps, rstar):
    """ε of the drag at each node: the law's own, or r* |ω_n| for Coulomb–Contensou."""
    return eps if rstar == 0.0 else rstar * np.abs(nodes.wn)


def _cubic(top: TippeTop, lam: float, n1: float, e: float) -> np.ndarray:
    """Coefficients of P(δ), highest power first, from n1 = N(1) and e = E' − m g R (1 − α)."""
    m, R, a, I1, g = top.m, top.R, top.alpha, top.I1, top.g
    q = m * g * R * a
    k = (lam - n1) / (1.0 - a)  # R I3 ω3
    C = 0.5 / (R * R * I1)
    return np.array([q, -(2.0 * q + e + C * k * k), 2.0 * (e - C * n1 * k), -C * n1 * n1])


def omega3_of(top: TippeTop, lam: float, n1: float) -> float:
    """ω3 (rad/s) from n1 = λ − R I3 ω3 (1 − α)."""
    return (lam - n1) / (top.R * top.I3 * (1.0 - top.alpha))


def start(top: TippeTop, phidot: float, omega3: float, theta: float) -> tuple[float, float]:
    """(n1, e) of a state with θ̇ = 0 (e.g. a steady precession), without cancellation:
    n1 = R sin²θ (I1 φ̇ − I3 ω3/(1 + cos θ)), e = ½ I1 φ̇² sin²θ + m g R α (1 − cos θ)."""
    m, R, a, I1, I3, g = top.m, top.R, top.alpha, top.I1, top.I3, top.g
    s2 = math.sin(theta) ** 2
    one_minus_z = 2.0 * math.sin(0.5 * theta) ** 2
    n1 = R * s2 * (I1 * phidot - I3 * omega3 / (1.0 + math.cos(theta)))
    e = 0.5 * I1 * phidot * phidot * s2 + m * g * R * a * one_minus_z
    return n1, e


def gliding_band(
    top: TippeTop, lam: float, n1: float, e: float
) -> tuple[float, float, float, bool]:
    """(δ_a, δ_b, δ_3, empty): the turning points of the gliding band in δ = 1 − cos θ.

    ``empty``: E' is at or below the bottom of the well (steady precession); then δ_a = δ_b is
    the bottom, the maximum of P on (0, 2).
    """
    p = _cubic(top, lam, n1, e)
    # P' = 3q δ² + 2 p1 δ + p2; P has its maximum in (0, 2) at the smaller root (q > 0).
    A, B, Cc = 3.0 * p[0], 2.0 * p[1], p[2]
    disc = B * B - 4.0 * A * Cc
    if not disc > 0.0:
        raise AveragingFails("no well: P has no maximum")
    sq = math.sqrt(disc)
    dm = (-B - sq) / (2.0 * A) if B > 0.0 else 2.0 * Cc / (-B + sq)  # the smaller root, stably
    # at a spinning pole the maximum sits at δ = 0 or 2 (rounding may put it just outside): a
    # steady spin there, whose band is the pole itself
    dm = min(max(dm, 1e-300), 2.0 * (1.0 - 2.0**-52))
    pm = float(np.polyval(p, dm))
    if not pm > 0.0:
        # the third root lies beyond the well (q > 0); guard it against rounding at a pole
        return dm, dm, max(-p[1] / p[0] - 2.0 * dm, dm + 1.0), True
    # The two roots about the maximum: Newton from the quadratic estimate on either side (it is
    # monotone there, P being concave between them), then the third root from Vieta's sum.
    dp, ddp = np.polyder(p), np.polyder(p, 2)
    x0 = math.sqrt(2.0 * pm / abs(float(np.polyval(ddp, dm))))
    ends = []
    for side in (-1.0, 1.0):
        x = dm + side * x0
        for _ in range(60):
            d = float(np.polyval(dp, x))
            step = float(np.polyval(p, x)) / d if d != 0.0 else 0.0
            x_new = x - step
            if side * (x_new - dm) <= 0.0:  # stay on this side of the maximum
                x_new = 0.5 * (x + dm)
            if abs(x_new - x) <= 4e-16 * max(abs(x), 1e-300):
                x = x_new
                break
            x = x_new
        ends.append(x)
    # a band reaching a pole (N = 0 there: a spinning pole) has a turning point at δ = 0 or 2,
    # which rounding may put just outside
    da, db = max(ends[0], 0.0), min(ends[1], 2.0)
    d3 = -p[1] / p[0] - ends[0] - ends[1]
    if not (da <= dm <= db < d3):
        raise AveragingFails("the band's turning points are not bracketed")
    return da, db, d3, False


class _Nodes:
    """The band at the quadrature nodes: everything that does not depend on the slip U."""

    __slots__ = (
        "Delta",
        "K",
        "Omega",
        "T",
        "dm",
        "empty",
        "gn",
        "half_w2",
        "phid",
        "s",
        "theta",
        "wn",
        "wt",
        "wx",
        "wy",
        "z",
    )

    def __init__(self, top: TippeTop, lam: float, n1: float, e: float) -> None:
        m, R, a, I1, I3, g = top.m, top.R, top.alpha, top.I1, top.I3, top.g
        w3 = omega3_of(top, lam, n1)
        da, db, d3, empty = gliding_band(top, lam, n1, e)
        self.empty, self.dm = empty, da
        q = m * g * R * a
        c, h = 0.5 * (da + db), 0.5 * (db - da)
        # an empty band is one point, the steady precession (the quadrature's ∑ weights = π
        # gives its small-oscillation period)
        sin_u, cos2_u, weights = (_SIN, _COS2, _WEIGHTS) if not empty else _ONE
        dl = c + h * sin_u
        s2 = dl * (2.0 - dl)
        G = 0.5 * (I1 + m * R * R * a * a * s2)
        P = q * h * h * cos2_u * (d3 - dl)
        dtdu = np.sqrt(G / (q * (d3 - dl)))
        w = weights * dtdu
        half = float(w.sum())
        self.T = 2.0 * half
        self.wt = w / half
        dP = np.polyval(np.polyder(_cubic(top, lam, n1, e)), dl)
        dG = m * R * R * a * a * (1.0 - dl)
        self.gn = m * g + 0.5 * m * R * a * (dP * G - P * dG) / (G * G)
        self.z = 1.0 - dl
        self.s = np.sqrt(s2)
        self.theta = 2.0 * np.arcsin(np.sqrt(0.5 * dl))
        self.phid = (n1 + R * I3 * w3 * dl) / (R * I1 * s2)
        self.wy = R * self.s * (w3 + self.phid * (a - self.z))
        # the spin about the vertical, ω·ẑ = φ̇ sin²θ + ω3 cos θ (Contensou's drilling)
        self.wn = self.phid * s2 + w3 * self.z
        # |θ̇|: P/(G s²); the half u: −π/2 → π/2 has δ rising (θ rising, θ̇ > 0)
        self.wx = -R * np.sqrt(P / (G * s2)) * (1.0 - a * self.z)
        self.Omega = float(self.wt @ self.phid)
        # δφ on the rising half: ∫ (φ̇ − Ω) dt from the turning point δ_a; −δφ on the other half
        self.Delta = _CUM @ (dtdu * (self.phid - self.Omega)) if not empty else np.zeros(1)
        self.half_w2 = 0.5 * m * (self.wx**2 + self.wy**2)
        # The contact point's inverse mass in units of 1/m, K = 1 + m R² (1 − α z)²/I1, at each
        # node: the centre of mass and the rotation both give way to the friction force (the
        # gyroscopic method's K, docs page "The contact point's response"). A scalar: the
        # answering slip is taken along the force, as in that response.
        self.K = 1.0 + m * R * R * (1.0 - a * self.z) ** 2 / I1


def _forces(nodes: _Nodes, mu: float, eps: float | None, U: complex):
    """Per half (θ̇ > 0, θ̇ < 0): (c g_n, ν in the band frame, e^{iδφ}, the sign of θ̇)."""
    out = []
    for sign in (1.0, -1.0):
        e = np.exp(1j * sign * nodes.Delta)
        nu = (sign * nodes.wx + 1j * nodes.wy) + U / e
        cg = mu * nodes.gn
        if eps is not None:
            cg = cg / np.sqrt(nu.real**2 + nu.imag**2 + eps * eps)
        out.append((cg, nu, e, sign))
    return out


def _slaved_slip(nodes: _Nodes, m: float, mu: float, eps: float | None, rotation: bool = True
                 ) -> complex:  # fmt: skip
    """The contact point's steady answer U (mean frame): i Ω m U = ⟨e^{iδφ} K F⟩, F = −c g_n ν.

    K is the contact point's inverse mass in units of 1/m at each node (:class:`_Nodes`; 1, the
    centre of mass's alone, if not ``rotation``). The viscous law's equation is linear in U and
    solved in closed form. The regularised law's is i Ω m U + ∇Φ(U) = 0 with the convex
    Φ = ⟨K μ g_n √(|ν|² + ε²)⟩: a rotation plus a convex gradient, so its Jacobian (skew part
    i Ω m, symmetric part ∇²Φ ⪰ 0) is never singular, its root is unique, and every stationary
    point of |residual|² is that root. Newton's method with the exact Jacobian and an Armijo
    backtracking on |residual|² (the Newton step is always a descent direction for it) therefore
    converges from any start; it starts from a collapsed band's closed form
    (:func:`mett.inversion._gyroscopic.cm_slip2` at the band's mean slip and inverse mass).
    """
    wt = nodes.wt
    K = nodes.K if rotation else np.ones_like(nodes.K)
    iOm = 1j * nodes.Omega * m
    base = [(np.exp(1j * sign * nodes.Delta), sign * nodes.wx + 1j * nodes.wy)
            for sign in (1.0, -1.0)]  # fmt: skip
    if eps is None:
        # c constant: (i Ω m + ⟨K c g_n⟩) U = −⟨K c g_n e^{iδφ} w⟩
        kc = 0.5 * mu * K * nodes.gn * wt
        num = sum(kc @ (e * w) for e, w in base)
        return -num / (iOm + 2.0 * float(kc.sum()))
    kg = 0.5 * mu * K * nodes.gn * wt
    # the answer of a collapsed band: ν = i w/(1 − i κ K), κ K = μ g_n K/(m Ω √(|ν|² + ε²))
    w = float(wt @ nodes.wy)
    Kb = float(wt @ K)
    k2 = (mu * float(wt @ nodes.gn) * Kb / (m * nodes.Omega)) ** 2
    eps2 = float(wt @ np.broadcast_to(eps * eps, wt.shape))
    x = float(cm_slip2(w * w, eps2, k2, 1.0))
    kK = mu * float(wt @ nodes.gn) * Kb / (m * nodes.Omega * math.sqrt(x + eps2))
    U = 1j * w * (1.0 / (1.0 - 1j * kK) - 1.0)

    def residual(U: complex):
        """(residual, its Jacobian in (Re U, Im U), the sum of its terms' sizes)."""
        r, size = iOm * U, abs(iOm * U)
        A, Bxx, Bxy, Byy = 0.0, 0.0, 0.0, 0.0
        for e, w in base:
            nt = e * w + U  # the slip turned into the mean frame, e^{iδφ} ν
            s = np.sqrt(nt.real**2 + nt.imag**2 + eps * eps)
            f = kg / s
            r += f @ nt
            size += float(f @ np.abs(nt))
            g3 = f / (s * s)
            A += float(f.sum())
            Bxx += float(g3 @ (nt.real * nt.real))
            Bxy += float(g3 @ (nt.real * nt.imag))
            Byy += float(g3 @ (nt.imag * nt.imag))
        J = np.array([[A - Bxx, -nodes.Omega * m - Bxy], [nodes.Omega * m - Bxy, A - Byy]])
        return r, J, size

    r, J, size = residual(U)
    for _ in range(100):
        if not math.isfinite(abs(r)) or not np.all(np.isfinite(J)):
            # a node at zero slip with ε = 0 (Contensou's ω_n = 0 there): no drag direction
            raise AveragingFails("the slip's equation is singular here")
        if abs(r) <= 1e-13 * size:
            return U
        dx = np.linalg.solve(J, [-r.real, -r.imag])
        step = complex(dx[0], dx[1])
        t = 1.0
        while True:  # Armijo on |r|²: the Newton step lowers it at the rate 2 |r|² t
            r_new, J_new, size_new = residual(U + t * step)
            if abs(r_new) ** 2 <= (1.0 - 1e-4 * t) * abs(r) ** 2:
                break
            t *= 0.5
            if t < 1e-12:
                # no decrease is left to find: the root to working precision, if the residual
                # is down to the rounding of its terms' sums
                if abs(r) <= 1e-9 * size:
                    return U
                raise AveragingFails("the slip's steady answer does not converge")
        U, r, J, size = U + t * step, r_new, J_new, size_new
    raise AveragingFails("the slip's steady answer does not converge")


def rates(top: TippeTop, law, lam: float, n1: float, e: float, rotation: bool = True):
    """(dn1/dt, de/dt, ⟨θ⟩, ⟨D⟩, ⟨Ẽ⟩, T, U, min g_n, de/dt before the floor, max |ν|, dλ/dt)
    of the averaged flow at (n1, e) and λ.

    n1 = λ − R I3 ω3 (1 − α) and e = E' − m g R (1 − α) carry the state near the upright spin
    without cancellation (both vanish there like θ²). Where the band is empty (e at or below the
    bottom of the well: steady precession) the flow slides along the bottom (Filippov):
    de/dt = max(−⟨c g_n ν·w⟩ − I3 ω3 ω̇3, ∂W'/∂ω3 ω̇3), the envelope theorem giving
    d min W'/dω3 = ∂W'/∂ω3 at the bottom; the band opens where the dissipation falls behind the
    well.

    Coulomb–Contensou: the drilling torque M ẑ, M = −c r*² ω_n, changes λ = −L·a at the rate
    M R (1 − α cos θ) (a couple about ẑ), ω3 by M cos θ/I3 and E_g by M ω_n; the bottom of the
    well then moves by ∂W'/∂ω3 ω̇3 + ∂W'/∂λ λ̇ (∂W'/∂λ = N/(R² I1 sin²θ)). dλ/dt is 0 for the
    other laws.
    """
    m, R, a, I1, I3 = top.m, top.R, top.alpha, top.I1, top.I3
    mu, eps, rstar = _law(top, law)
    w3 = omega3_of(top, lam, n1)
    nodes = _Nodes(top, lam, n1, e)
    wt = nodes.wt
    eps = _node_eps(nodes, eps, rstar)
    U = _slaved_slip(nodes, m, mu, eps, rotation)
    forces = _forces(nodes, mu, eps, U)
    # the centre of mass's share of the answer, i Ω m U_cm = ⟨e^{iδφ} F⟩; the rest, U − U_cm, is
    # the rotation's, and ω × a = w + e^{−iδφ} (U − U_cm) is what the force does work on
    U_cm = sum(-0.5 * (wt @ (ph * cg * nu)) for cg, nu, ph, _ in forces) / (1j * nodes.Omega * m)
    torque, power, slip = 0.0, 0.0, 0.0
    drill_3, drill_power, dlam = 0.0, 0.0, 0.0
    for cg, nu, ph, sign in forces:
        slip = max(slip, float(np.max(np.abs(nu))))
        oxa = (sign * nodes.wx + 1j * nodes.wy) + (U - U_cm) / ph
        torque += 0.5 * float(wt @ (cg * R * nodes.s * nu.imag))
        power += 0.5 * float(wt @ (cg * (nu.real * oxa.real + nu.imag * oxa.imag)))
        if rstar > 0.0:
            M = -cg * rstar * rstar * nodes.wn  # −c r*² ω_n, cg = c (g_n included)
            drill_3 += 0.5 * float(wt @ (M * nodes.z))
            drill_power += 0.5 * float(wt @ (M * nodes.wn))
            dlam += 0.5 * float(wt @ (M * R * (1.0 - a * nodes.z)))
    dw3 = (drill_3 - torque) / I3
    de = de_power = drill_power - power - I3 * w3 * dw3
    e_floor = e
    if nodes.empty:
        d = nodes.dm
        N = n1 + R * I3 * w3 * d
        dW = N * R * I3 * (a - 1.0 + d) / (R * R * I1 * d * (2.0 - d))
        dW_lam = N / (R * R * I1 * d * (2.0 - d))
        de = max(de, dW * dw3 + dW_lam * dlam)
        e_floor = N * N / (2.0 * R * R * I1 * d * (2.0 - d)) + top.m * top.g * R * a * d
    theta = float(wt @ nodes.theta)
    D = float(wt @ (I3 * w3 * np.sqrt(fm.d(top, nodes.z))))
    Et = e_floor + m * top.g * R * (1.0 - a) + 0.5 * I3 * w3 * w3 + float(wt @ nodes.half_w2)
    dn1 = dlam - R * I3 * (1.0 - a) * dw3
    return dn1, de, theta, D, Et, nodes.T, U, float(nodes.gn.min()), de_power, slip, dlam


def time_cap(top: TippeTop, law, omega3: float, phidot: float) -> float:
    """A bound (s) on any inversion the flow can describe: 300 of its slowest time scales.

    The rates are those of a drag c at the answering slip, c/(1 + (c g K/φ̇)²) per unit mass
    (the contact point's response, :func:`_slaved_slip`), which is slowest for the stiffest c:
    the viscous coefficient at small slip (μ, or μ/ε for the regularised law) with the largest
    inverse mass K(π) = 1 + m R² (1 + α)²/I1 and the start's precession ``phidot`` (rad/s). A
    regularised law far above ε acts as Coulomb's, whose time scale is the slip R |ω3| over μ g.
    Coulomb–Contensou is the regularised law with ε = r* |ω3| at the start.
    """
    mu, eps, rstar = _law(top, law)
    g = top.g
    if rstar > 0.0:
        eps = rstar * abs(omega3)
    c = mu if eps is None else mu / eps
    K = 1.0 + top.m * top.R**2 * (1.0 + top.alpha) ** 2 / top.I1
    ph = abs(phidot) or math.inf  # a start without precession: the response does not slow it
    t = (1.0 + (c * g * K / ph) ** 2) / (c * g)
    if eps is not None:
        t = max(t, top.R * abs(omega3) / (mu * g))
    return 300.0 * t


def slow_path(top: TippeTop, law, lam: float, n1: float, e: float, theta_to: float, t_max: float,
              rtol: float = 1e-6, rotation: bool = True):  # fmt: skip
    """Integrate the averaged flow from (n1, e) (see :func:`rates`) until ⟨θ⟩ = ``theta_to``.

    Returns (t, ⟨θ⟩, ⟨D⟩, ⟨Ẽ⟩, t_half, t_end, t_lift, max |ν|, λ): arrays at the solver's steps,
    the times ⟨θ⟩ passes π/2 and ``theta_to`` (inf if not by ``t_max``), the time the band's
    normal force first vanishes (the nutation lifts the top off; the path stops there, inf if
    never) and the largest slip in the band at each step (m/s). LSODA (scipy's, Adams or BDF as
    the flow needs) with relative tolerance ``rtol`` (the absolute tolerance 1e-3 rtol of the
    start's values: n1 and e grow like θ² from a start that may be θ ~ 1e-5). The slow drift
    along the well's bottom is smooth, at rates O(μ g); the band's width is stiff under strong
    friction (the nutation damps at ~ μ g K, 1000/s at μ/ε = 100 s/m, where the explicit RK45
    took 10× the steps), hence the switching method. Raises AveragingFails where the band cannot
    be followed before π/2; past π/2 a failure keeps the path (t_end inf). Under
    Coulomb–Contensou λ is a third slow variable (the drilling torque, :func:`rates`); it is
    constant otherwise.
    """
    from scipy.integrate import solve_ivp

    cache: dict[tuple[float, ...], tuple] = {}
    failed = (math.nan,) * 11
    drilling = _law(top, law)[2] > 0.0

    def evaluate(y):
        key = tuple(float(v) for v in y)
        if key not in cache:
            # A trial step may leave the bands (past a separatrix, onto a pole: near the inverted
            # pole θ moves far for a small change of (n1, e)). Its rates are NaN, so the step's
            # error norm is NaN and the solver rejects it and shrinks the step; the band that
            # cannot be followed at an accepted step ends the path (below).
            try:
                out = rates(top, law, key[2] if drilling else lam, key[0], key[1], rotation)
            except AveragingFails:
                out = failed
            if not math.isfinite(out[5]) or not all(math.isfinite(v) for v in out[:5]):
                out = failed
            cache[key] = out
        return cache[key]

    def rhs(t, y):
        r = evaluate(y)
        return [r[0], r[1], r[10]] if drilling else [r[0], r[1]]

    def half(t, y):
        return evaluate(y)[2] - 0.5 * math.pi

    def end(t, y):
        return evaluate(y)[2] - theta_to

    def lift(t, y):
        return evaluate(y)[7]

    peak = [-math.inf]

    def turns(t, y):
        # Coulomb–Contensou only: the drilling torque lowers λ, and the top may fall back; the
        # path stops once ⟨θ⟩ has fallen 0.02 rad below its highest value so far (where the
        # drilling torque's sign flips with ω_n the flow would chatter)
        th = evaluate(y)[2]
        if math.isfinite(th):
            peak[0] = max(peak[0], th)
        return th - (peak[0] - 0.02) if drilling else 1.0

    end.terminal = True  # type: ignore[attr-defined]
    lift.terminal = True  # type: ignore[attr-defined]
    turns.terminal = True  # type: ignore[attr-defined]
    turns.direction = -1.0  # type: ignore[attr-defined]
    y0 = [n1, e, lam] if drilling else [n1, e]
    atol = [1e-3 * rtol * abs(v) for v in y0]
    # The state spans many decades (n1, e grow like θ² from θ ~ 1e-5): a trial step may
    # overflow the error norm or reach a pole; such values are rejected (the step shrinks) or
    # caught by evaluate(), so numpy's warnings are silenced here, not passed on to the caller.
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        sol = solve_ivp(rhs, (0.0, t_max), y0, method=_METHOD, rtol=rtol, atol=atol,
                        events=(half, end, lift, turns))  # fmt: skip
    out = np.array([[*evaluate(y)[2:5], evaluate(y)[9]] for y in sol.y.T])
    t_half, t_end, t_lift, _ = (float(te[0]) if len(te) else math.inf for te in sol.t_events)
    if sol.status < 0 and not math.isfinite(t_half):
        raise AveragingFails(sol.message)
    # past π/2 a failure (the step shrinking to nothing near the inverted pole) keeps the path
    # and t_half; t_end stays inf (not reached)
    lams = sol.y[2] if drilling else np.full(len(sol.t), lam)
    return sol.t, out[:, 0], out[:, 1], out[:, 2], t_half, t_end, t_lift, out[:, 3], lams
