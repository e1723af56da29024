"""Flight and landing of the ball top: a run that loses contact goes on (docs/theory/flight.md).

When the normal force g_n of a ball-top run reaches 0 the top leaves the table. It then moves
as a free rigid body, exactly in closed form (Goldstein, *Classical Mechanics*, §5.6, the
torque-free symmetric top):

    centre of mass:  r_G(τ) = r_G0 + V0 τ − ½ g τ² ẑ,
    angular momentum about G:  L(τ) = L0,
    axis:  3̂(τ) = 3̂∥ + u cos Ωτ + (L̂ × u) sin Ωτ,   Ω = |L|/I1,  3̂∥ = (L̂·3̂0) L̂,  u = 3̂0 − 3̂∥,

(3̂ precesses about L at the rate |L|/I1; ω3 = L·3̂/I3 stays constant). The gap of the lowest
point of the sphere above the table, h = z_G + l 3̂_z − R, is written without cancellation as

    h(τ) = h0 + ḣ0 τ − ½ g τ² + l [u_z (cos Ωτ − 1) + v_z (sin Ωτ − Ωτ)],   v = L̂ × u,

(h0 = ḣ0 = 0 at a lift-off: the contact constraint held up to it). Touchdown is the first root
τ > 0 of h. It is located by a march that cannot step over a root: from τ with h(τ) > 0 the
next point is the first positive zero of the Taylor lower bound

    p(s) = h + ḣ s + ḧ s²/2 + h⃛ s³/6 − M4 s⁴/24,   M4 = l Ω⁴ √(u_z² + v_z²) ≥ |h⁗|,

so h > 0 between the points; the march converges to the first root (quadratically where it is
simple) and stops when its step falls below the time resolution.

The landing is the impact of the stem page (docs/theory/stem.md): perfectly inelastic in the
normal direction, the friction law in impulse form: the viscous law's Darboux–Keller impulse
(:func:`mett.dynamics.stem.darboux_keller`'s equations, solved in closed form by
:func:`viscous_impulse`), Coulomb's and Coulomb–Contensou's
:func:`mett.dynamics.stemslip.dry_impulse`, the regularised law's :func:`regularised_impulse`
(the same Darboux–Keller integration with its force). After it the contact model resumes; if
the force it needs is again ≤ 0 the top flies again at once.

The top with a stem (models "stemmed", "stemmed-coulomb", "stemmed-coulomb-contensou",
"stemmed-coulomb-regularised") flies
the same way from the sphere in contact, (R, l) or (r_s, l + l_s): the other sphere's gap
z_G + l_o 3̂_z − R_o is the same formula with its own (h, ḣ) at the lift-off (:func:`_other_hop`)
and the touchdown is the earlier of the two first roots; the landing impact is that sphere's
(docs/theory/flight.md#the-stemmed-top), or, if the other sphere's gap is then within the
switches' event tolerance, the impact at both contacts (:func:`mett.dynamics.stem.land_both`:
viscous and regularised laws; :func:`mett.dynamics.stemslip.land_both`; reason
"double touchdown").

A flight piece is stored in the contact model's own state layout (``traj.states`` keeps its
shape) with a dense output made of exact Taylor polynomials of the closed form (degree
:data:`ORDER` on steps of Ω h ≤ 1/8: truncation below 1e-30), so that a trajectory with flights
saves and reloads as any other (:class:`mett.dynamics.taylor.TaylorDense`).

A run at high spin makes hundreds of hops, so the per-hop work is compiled or vectorised: the
touchdown march and the gap samples (:mod:`._hop`, numba; :meth:`Hop.touchdown_reference` and
:meth:`Hop.gaps_reference` keep the Python they replace), the viscous landing impulse in closed
form (:func:`viscous_impulse`), the dense output for all steps of a flight at once.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import _validate
from . import _params as ix
from . import backends, contact, stem, stemreg, stemslip
from ._run import PreparedRun, Run, completed_message
from ._series import SERIES
from .dense import SegmentedSolution
from .gliding import gliding_core
from .hybrid import geometric_tail, solve_hybrid
from .registry import JumpFailed
from .stemreg import regularised_impulse  # the regularised law's impulse, re-exported
from .stickslip import Switch
from .trajectory import Trajectory

__all__ = [
    "MAX_FLIGHT_STEPS",
    "MAX_HOPS",
    "ORDER",
    "VISCOUS_ARTEFACT",
    "Hop",
    "ViscousArtefactWarning",
    "accumulation",
    "flies",
    "land",
    "regularised_impulse",
    "run_with_flight",
    "viscous_impulse",
    "warm_kernels",
    "warn_if_artefact",
]

ORDER = 16
"""Degree of the Taylor polynomials of a flight's dense output, on steps of Ω h ≤ 1/8 (the
truncation (1/8)^17/17! < 1e-30); the steps are fine enough for the crossings and user events
located on them, as on an integrator's steps."""

MAX_HOPS = 10_000
"""A run stops with status "failed" after this many flights (hops)."""

MAX_FLIGHT_STEPS = 1_000_000
"""A flight's dense output has 8 steps per radian of the axis' rotation (:meth:`Hop.dense`); a
flight that would need more (a spin near the rate bound) ends the run with status "failed"."""


def _beyond_double(hop: Hop, g: np.ndarray) -> str | None:
    """Why a flight from this state cannot be followed in double precision, None if it can: a
    non-finite state, or a rotation rate whose powers up to :data:`ORDER` (the dense output's
    Taylor coefficients) or whose touchdown bound M4 = l Ω⁴ |…| overflow."""
    if not np.isfinite(g).all():
        return "the state at the lift-off is not finite"
    if not (hop.Omega < _OMEGA_MAX and math.isfinite(hop.M4)):
        return (
            f"the rotation rate Ω = {hop.Omega:.3g} rad/s is beyond what the flight's "
            "double-precision Taylor coefficients can hold"
        )
    return None


_OMEGA_MAX = float(np.finfo(float).max ** (1.0 / ORDER))
"""The rotation rate whose powers up to :data:`ORDER` still fit in a double."""


VISCOUS_ARTEFACT = 1.0
"""μ |v_A| above which a viscous run's loss of contact is an artefact of the law (see
:class:`ViscousArtefactWarning`)."""

_ACCUMULATION_HOPS = 8
"""Consecutive hops, each landing followed at once by the next lift-off, with durations in a
geometric sequence, that count as an accumulation (a Zeno sequence)."""


class ViscousArtefactWarning(_validate.MettWarning):
    """A viscous-law run lost contact where the law's friction coefficient μ|v_A| exceeds
    :data:`VISCOUS_ARTEFACT` = 1.

    The viscous law F_t = −μ g_n v_A acts as a dry law of coefficient μ|v_A| (μ in s/m). No dry
    contact of the materials of a top on a table has a coefficient above about 1, so a loss of
    contact at μ|v_A| > 1 is driven by a friction force that no real contact transmits: an
    artefact of the law, not physics (docs/theory/flight.md#when-a-loss-of-contact-is-an-artefact).
    """


# --- the models that fly: their state in the gliding layout and their landing law ----------


@dataclass(frozen=True)
class _Flier:
    """How a contact model flies: its state ↔ the gliding layout, its landing impulse."""

    to_body: Callable[[np.ndarray, tuple], np.ndarray]
    from_body: Callable[[np.ndarray, tuple], np.ndarray]
    dry: bool
    stem: tuple[int, int] | None = None
    """The stemmed top's: the indices of (r_s, l_s) in its parameters; None for the ball top."""
    eps: int | None = None
    """The index of ε in the parameters of a model in the viscous layout whose landing is the
    regularised law's (:func:`regularised_impulse`); None: the layout's own law."""

    @property
    def stemmed(self) -> bool:
        return self.stem is not None


def _same(y: np.ndarray, p: tuple) -> np.ndarray:
    return np.array(y, dtype=float)


def _dry_from_body(y: np.ndarray, p: tuple) -> np.ndarray:
    return contact.settle(contact.from_gliding(y, p), p)


def _first_ten(y: np.ndarray, p: tuple) -> np.ndarray:
    """The gliding part of a stemmed state (its phase flag y[10] dropped)."""
    return np.array(y[:10], dtype=float)


def _flagged(y: np.ndarray, p: tuple, flag: float = 0.0) -> np.ndarray:
    """A gliding-layout state (10,) or (10, k) with the stemmed model's phase flag appended."""
    y = np.asarray(y, dtype=float)
    return np.concatenate((y, np.full((1, *y.shape[1:]), float(flag))))


def _dry_stem_params(p: tuple, on: int) -> tuple:
    """The dry stemmed top's contact parameters (stickslip's tuple) of the ball (``on`` 0) or
    the stem sphere (1): (R, l) replaced by (r_s, l + l_s) on the stem (as :mod:`.stemslip`)."""
    if on != 1:
        return tuple(p)
    q = list(p)
    q[ix.R], q[ix.L] = p[ix.DRY_R_S], p[ix.L] + p[ix.DRY_L_S]
    return tuple(q)


def _dry_stem_body(y: np.ndarray, p: tuple) -> np.ndarray:
    """The gliding state of a dry stemmed state (λ of its contact → L_z, the flag dropped)."""
    return contact.to_gliding(np.asarray(y, dtype=float)[:10], _dry_stem_params(p, round(y[10])))


def _stem_layout(flier: _Flier, G: np.ndarray, p: tuple, flag: int) -> np.ndarray:
    """Gliding states ``G`` (10,) or (10, k) in the stemmed model's layout, on sphere ``flag``
    (the dry models: row 6 the Jellett integral λ of that sphere; no settling)."""
    if flier.dry:
        G = contact.from_gliding(G, _dry_stem_params(p, flag))
    return _flagged(G, p, flag)


_FLIERS = {
    "gliding": _Flier(_same, _same, False),
    "coulomb": _Flier(contact.to_gliding, _dry_from_body, True),
    "coulomb-contensou": _Flier(contact.to_gliding, _dry_from_body, True),
    "coulomb-regularised": _Flier(contact.to_gliding, _dry_from_body, True),
    "stemmed": _Flier(_first_ten, _flagged, False, (ix.R_S, ix.L_S)),
    "stemmed-coulomb": _Flier(_dry_stem_body, _flagged, True, (ix.DRY_R_S, ix.DRY_L_S)),
    "stemmed-coulomb-contensou": _Flier(_dry_stem_body, _flagged, True, (ix.DRY_R_S, ix.DRY_L_S)),
    "stemmed-coulomb-regularised": _Flier(
        _first_ten, _flagged, False, (ix.R_S, ix.L_S), ix.STEM_EPS
    ),
}


_VISCOUS = frozenset(n for n, f in _FLIERS.items() if not f.dry and f.eps is None)
"""The viscous models that fly, whose losses of contact :func:`warn_if_artefact` judges."""


def warm_kernels() -> str:
    """Compile (or load from numba's cache) the flight kernels of :mod:`._hop`: the touchdown
    march, the gap samples and the viscous landing impulse, by one call of each. Called by the
    first flight of a process (a notice on a terminal if it compiles) and by
    :func:`mett.dynamics.warmup.warmup`; returns "numba"."""
    _hop_kernels()
    return "numba"


_HOP: list[Any] = []


def _hop_kernels() -> Any:
    """The module :mod:`._hop`, its kernels compiled or loaded on the first call of a process."""
    if _HOP:
        return _HOP[0]
    from .._numba_cache import first_use
    from . import _hop  # numba's: not imported by ``import mett``

    with first_use("flight", "the flight and landing kernels"):
        _hop.touchdown(0.0, 0.0, 9.81, 0.01, 10.0, 0.1, 0.1, 1.0, 0.0, 1.0)
        _hop.gaps(0.0, 0.0, 9.81, 0.01, 10.0, 0.1, 0.1, np.zeros(1))
        _hop.viscous_impulse(np.array([0.1, 0.0, -0.1]), np.eye(3), 0.3, _SCAN_POINTS)
        x, c = np.ones(3), np.ones(ORDER + 1)
        _hop.flight_steps(np.zeros(2), x, x, x, x, x, x, 1.0, c, c)
    _HOP.append(_hop)
    return _hop


def flies(model: Any) -> bool:
    """True if runs of ``model`` (a registered :class:`~mett.dynamics.registry.Model`) continue
    through a loss of contact by flight and landing; the others stop with "contact_lost"."""
    return getattr(model, "name", None) in _FLIERS


# --- the free flight -----------------------------------------------------------------------


def _sin_minus(x: float) -> float:
    """sin x − x without cancellation for small |x|."""
    if abs(x) > 0.1:
        return math.sin(x) - x
    x2 = x * x
    return (
        -x
        * x2
        / 6.0
        * (1.0 - x2 / 20.0 * (1.0 - x2 / 42.0 * (1.0 - x2 / 72.0 * (1.0 - x2 / 110.0))))
    )


class Hop:
    """The exact free flight of the eccentric sphere from a state (module docstring).

    Parameters
    ----------
    y : ndarray, shape (10,)
        State in the gliding layout ``[x, y, ẋ, ẏ, L_x, L_y, L_z, 3̂_x, 3̂_y, 3̂_z]`` at ``t0``.
    t0 : float
        Start time (s).
    body : tuple
        ``(m, R, l, I1, I3, g)`` (kg, m, m, kg m², kg m², m/s²).
    gap, gap_rate : float
        Gap h of the lowest point of the sphere (m) and its rate ḣ (m/s) at ``t0``; 0 at a
        lift-off.
    """

    def __init__(
        self, y: np.ndarray, t0: float, body: tuple, gap: float = 0.0, gap_rate: float = 0.0
    ) -> None:
        self.m, self.R, self.l, self.I1, self.I3, self.g = body
        y = np.asarray(y, dtype=float)
        self.t0, self.h0, self.hd0 = float(t0), float(gap), float(gap_rate)
        self.r0, self.V = y[0:2].copy(), y[2:4].copy()
        self.L = y[4:7].copy()
        e = y[7:10] / np.linalg.norm(y[7:10])
        Lm = float(np.linalg.norm(self.L))
        self.Omega = Lm / self.I1
        Lh = self.L / Lm if Lm > 0.0 else np.array([0.0, 0.0, 1.0])
        self.e_par = float(Lh @ e) * Lh
        self.u = u = e - self.e_par
        self.v = _cross(Lh, u)
        # vertical CM velocity: the contact value −l 3̂̇_z plus the gap rate (3̂̇ = Ω v at τ = 0)
        self.vz0 = -self.l * self.Omega * self.v[2] + self.hd0
        self.M4 = self.l * self.Omega**4 * math.hypot(self.u[2], self.v[2])

    def axis(self, tau: Any) -> np.ndarray:
        """3̂ at ``tau`` (s after t0), shape (3,) or (3, k)."""
        w = self.Omega * np.asarray(tau, dtype=float)
        return (np.multiply.outer(self.e_par, np.ones_like(w)) + np.multiply.outer(self.u, np.cos(w))
                + np.multiply.outer(self.v, np.sin(w)))  # fmt: skip

    def state(self, tau: Any) -> np.ndarray:
        """Gliding-layout state(s) at ``tau``, shape (10,) or (10, k)."""
        tau = np.asarray(tau, dtype=float)
        out = np.empty((10, *tau.shape))
        out[0] = self.r0[0] + self.V[0] * tau
        out[1] = self.r0[1] + self.V[1] * tau
        out[2], out[3] = self.V[0], self.V[1]
        for i in range(3):
            out[4 + i] = self.L[i]
        out[7:10] = self.axis(tau)
        return out

    def gap(self, tau: float) -> tuple[float, float, float, float]:
        """(h, ḣ, ḧ, h⃛) at ``tau``: the gap of the lowest point of the sphere (m) and its rates."""
        W, l, uz, vz = self.Omega, self.l, self.u[2], self.v[2]
        w = W * tau
        c, s = math.cos(w), math.sin(w)
        h = (self.h0 + self.hd0 * tau - 0.5 * self.g * tau * tau
             + l * (-2.0 * uz * math.sin(0.5 * w) ** 2 + vz * _sin_minus(w)))  # fmt: skip
        h1 = self.hd0 - self.g * tau + l * W * (-uz * s - 2.0 * vz * math.sin(0.5 * w) ** 2)
        h2 = -self.g - l * W * W * (uz * c + vz * s)
        h3 = l * W**3 * (uz * s - vz * c)
        return h, h1, h2, h3

    def _gap_args(self) -> tuple[float, ...]:
        """The gap's constants, as the compiled kernels of :mod:`._hop` take them."""
        return (self.h0, self.hd0, self.g, self.l, self.Omega, float(self.u[2]), float(self.v[2]))

    def gaps(self, tau: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(h, ḣ) at the times ``tau`` (arrays, flattened): :meth:`gap` compiled."""
        _hop = _hop_kernels()
        taus = np.ascontiguousarray(np.ravel(tau), dtype=float)
        return _hop.gaps(*self._gap_args(), taus)

    def gaps_reference(self, tau: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`gaps` in Python, one :meth:`gap` per time (the reference of the kernel)."""
        out = np.array([self.gap(float(x))[:2] for x in np.ravel(tau)]).reshape(-1, 2)
        return out[:, 0], out[:, 1]

    def vz(self, tau: Any) -> Any:
        """Vertical velocity of the centre of mass (m/s) at ``tau``."""
        return self.vz0 - self.g * np.asarray(tau, dtype=float)

    def touchdown(self, tau_max: float) -> float | None:
        """The first root τ ∈ (0, tau_max] of the gap h (s after t0), None if there is none:
        :meth:`touchdown_reference`'s march, compiled (:mod:`._hop`)."""
        _hop = _hop_kernels()
        tau = _hop.touchdown(*self._gap_args(), self.M4, self.t0, float(tau_max))
        if tau < 0.0:
            raise RuntimeError("touchdown search did not converge")  # pragma: no cover
        return None if math.isnan(tau) else float(tau)

    def touchdown_reference(self, tau_max: float) -> float | None:
        """The first root τ ∈ (0, tau_max] of the gap h (s after t0), None if there is none.

        0.0 if the gap cannot open (ḧ ≤ 0 and h⃛ ≤ 0 at a lift-off: a hop of zero length). At a
        lift-off located slightly early (ḧ(0) = −g_n/m < 0 by the event tolerance) the gap dips
        below 0 until τ = −2ḧ(0)/h⃛(0), a time of the order of the event's location error; the
        march starts there. A zero of h reached with ḣ > 0 (there, the gap computed as 0 or
        below by rounding while it rises) is not a touchdown: the march steps on from it.
        """
        h, h1, h2, h3 = self.gap(0.0)
        eps = np.finfo(float).eps
        tau = 0.0
        if h <= 0.0:  # on the table: h(s) ≥ s (ḣ + ḧ s/2 + h⃛ s²/6 − M4 s³/24)
            if h1 > 0.0:
                s = _first_root([-self.M4 / 24.0, h3 / 6.0, 0.5 * h2, h1])
            elif h1 < 0.0:
                return 0.0
            else:  # a lift-off: h = ḣ = 0, h ≥ s² (c2 + c3 s − M4 s²/24)
                c2, c3 = 0.5 * h2, h3 / 6.0
                if c2 <= 0.0 and c3 <= 0.0:
                    return 0.0
                if c3 > 0.0 and c2 < 0.0:
                    tau = -2.0 * c2 / c3
                s = _first_root([-self.M4 / 24.0, c3, max(c2, 0.0)]) if tau == 0.0 else 0.0
            tau = tau + (s if s is not None else tau_max)
        t_res = 4.0 * eps * max(abs(self.t0), 1.0)
        for _ in range(1_000_000):
            if tau >= tau_max:
                return None
            h, h1, h2, h3 = self.gap(tau)
            if h <= 0.0 and h1 > 0.0:  # a rounding-level zero of a rising gap: no touchdown
                s = _first_root([-self.M4 / 24.0, h3 / 6.0, 0.5 * h2, h1])
            elif h <= 0.0:
                return tau
            else:
                s = _first_root([-self.M4 / 24.0, h3 / 6.0, 0.5 * h2, h1, h])
            if s is None:  # h > 0 for ever (no gravity and no wobble: never happens with g > 0)
                return None
            if s <= t_res:
                return tau + s
            tau += s
        raise RuntimeError("touchdown search did not converge")  # pragma: no cover

    def dense(self, tau_end: float, convert: Callable[[np.ndarray], np.ndarray]) -> Any:
        """The flight over [0, tau_end] as Taylor polynomials of degree :data:`ORDER` in the
        layout ``convert`` (of gliding-layout states, shape (10, k)) gives; ``convert`` must be
        affine in 3̂ with L fixed (true of the gliding and the λ layouts: λ = −L·a is constant)."""
        from .taylor import TaylorDense  # numba's: not imported by ``import mett``

        n_steps = max(1, math.ceil(8.0 * self.Omega * tau_end))
        taus = np.linspace(0.0, tau_end, n_steps + 1)
        pw = self.Omega**_K / _FACT
        cos_c = np.where(_EVEN, pw * _COS_SIGN, 0.0)
        sin_c = np.where(_EVEN, 0.0, pw * _SIN_SIGN)
        # the breakpoint states and the axis' coefficients on every step, in one compiled loop
        # (numpy's outer products per flight cost more than the rest of a hop)
        G, A = _hop_kernels().flight_steps(taus, self.r0, self.V, self.L, self.e_par, self.u,
                                           self.v, self.Omega, cos_c, sin_c)  # fmt: skip
        Y = convert(G)  # breakpoint states in the model layout
        C = np.zeros((n_steps, Y.shape[0], ORDER + 1))
        C[:, :, 0] = Y[:, :-1].T
        C[:, 0, 1], C[:, 1, 1] = self.V[0], self.V[1]
        C[:, 7:10, 1:] = A
        return TaylorDense(self.t0 + taus, Y.T, C)


# the Taylor coefficients of cos and sin of :meth:`Hop.dense`: Ωᵏ/k! with the signs of the
# derivatives of cos (k even) and sin (k odd)
_K = np.arange(ORDER + 1)
_FACT = np.array([math.factorial(j) for j in _K], dtype=float)
_EVEN = _K % 2 == 0
_COS_SIGN = (-1.0) ** (_K // 2)
_SIN_SIGN = (-1.0) ** ((_K - 1) // 2)


def _first_root(coeffs: list[float]) -> float | None:
    """The smallest positive real root of the polynomial (highest degree first) whose constant
    term is > 0, polished by Newton's method from below; None if it has none."""
    c = np.trim_zeros(np.asarray(coeffs, dtype=float), "f")
    if c.size <= 1:
        return None
    roots = np.roots(c)
    real = roots[np.abs(roots.imag) <= 1e-9 * np.abs(roots)].real
    pos = real[real > 0.0]
    if pos.size == 0:
        return None
    s = float(pos.min())
    dc = np.polyder(c)
    for _ in range(3):
        d = float(np.polyval(dc, s))
        if d == 0.0:
            break
        s_new = s - float(np.polyval(c, s)) / d
        if not 0.0 < s_new < 2.0 * s:
            break
        s = s_new
    # from below: the bound must stay positive on [0, s)
    return s * (1.0 - 64.0 * np.finfo(float).eps)


# --- the landing ---------------------------------------------------------------------------


def land(
    y: np.ndarray, vz: float, p: tuple, dry: bool, sphere: tuple[float, float] | None = None,
    eps: float | None = None,
) -> tuple[np.ndarray, np.ndarray, float, float]:  # fmt: skip
    """The landing impact of the sphere: state after it (gliding layout), P (N s), Q (N m s)
    and the cone margin of the impulse ((μP_n − |Π_t|)/(μP_n), NaN for the viscous law).

    ``y`` is the gliding-layout state at touchdown and ``vz`` the vertical velocity of the
    centre of mass (m/s); ``p`` the contact model's parameters (m, R, l, I1, I3, mu, g, ...).
    Perfectly inelastic Darboux–Keller impact (docs/theory/stem.md): viscous law
    (:func:`viscous_impulse`, :func:`mett.dynamics.stem.darboux_keller` in closed form) or
    Coulomb (–Contensou)
    (:func:`mett.dynamics.stemslip.dry_impulse`) in impulse form. ``sphere`` = (radius, distance
    from G to its centre) of the sphere that lands (m); default the ball's (R, l). ``eps``
    (m/s): the regularised law's ε, for a model in the viscous layout with that law (the
    stemmed top's "stemmed-coulomb-regularised").
    """
    m, R, l, I1, I3, mu = p[ix.M], p[ix.R], p[ix.L], p[ix.I1], p[ix.I3], p[ix.MU]
    if sphere is not None:
        R, l = sphere
    e = y[7:10] / np.linalg.norm(y[7:10])
    L = np.asarray(y[4:7], dtype=float)
    w = L / I1 + (1.0 / I3 - 1.0 / I1) * float(L @ e) * e
    a = l * e - np.array([0.0, 0.0, R])
    V = np.array([y[2], y[3], vz])
    Iinv = np.eye(3) / I1 + (1.0 / I3 - 1.0 / I1) * np.outer(e, e)
    A = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
    W = np.eye(3) / m - A @ Iinv @ A
    f = stem.ImpactFrame(e, L, w, V, a, Iinv, W, V + _cross(w, a))
    P, Q, margin = np.zeros(3), 0.0, math.nan
    if f.v[2] < 0.0:
        if eps is not None:
            P = regularised_impulse(f.v, f.W, mu, eps)
        elif dry and p[ix.LAW] == contact.LAW_REGULARISED:
            P = regularised_impulse(f.v, f.W, mu, p[ix.EPS])
        elif dry:
            r_star = p[ix.RSTAR]
            P, Q, _ = stemslip.dry_impulse(f, m, mu, r_star)
            Pt = math.hypot(P[0], P[1], Q / r_star) if r_star > 0.0 else math.hypot(P[0], P[1])
            if mu * P[2] > 0.0:
                margin = (mu * P[2] - Pt) / (mu * P[2])
        else:
            P = viscous_impulse(f.v, f.W, mu)
    # Δ(m ṙ) = P, ΔL = a × P + Q ẑ (stem.apply_impulse's arithmetic, on this state's ten
    # components)
    after = np.array(y, dtype=float)
    after[2:4] = f.V[:2] + np.asarray(P[:2]) / m
    after[4:7] = f.L + _cross(f.a, P) + np.array([0.0, 0.0, Q])
    return after, P, float(Q), margin


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a × b of two 3-vectors: np.cross's arithmetic without its set-up (a few µs a call)."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                     a[0] * b[1] - a[1] * b[0]])  # fmt: skip


_SCAN_POINTS = 4096
"""Most points of the scan for the first end of compression in :func:`viscous_impulse`."""


def viscous_impulse(v0: np.ndarray, W: np.ndarray, mu: float) -> np.ndarray:
    """The impulse P (N s) of the perfectly inelastic Darboux–Keller impact under the viscous
    law, in closed form: the equations of :func:`mett.dynamics.stem.darboux_keller` (which
    integrates them with solve_ivp, ~3 ms a landing) solved exactly.

    With the normal impulse p as the variable, dP = (−μ v_t, 1) dp and dv = W dP are linear
    with constant coefficients (Keller 1986, *J. Appl. Mech.* 53, 1): the slip obeys
    dv_t/dp = −μ W_tt v_t + W_tz, so in the eigenbasis W_tt = Q diag(λ) Qᵀ, with k = μλ,

        ∫₀ᵖ v_t = Q [p φ(kp) ∘ Qᵀv_t0 + p² ψ(kp) ∘ QᵀW_tz],   φ(x) = (1 − e^{−x})/x,
                                                             ψ(x) = (x − 1 + e^{−x})/x²,

    P_t = −μ ∫₀ᵖ v_t, P_z = p, and v_z(p) = v_z0 + W_zt P_t + W_zz p. Compression ends at the
    first zero of v_z (v_z0 < 0), found by a scan of v_z on steps ≤ 1/(4 k_max) over the
    relaxation of the slip (p ≤ 40/k_min; beyond it v_z grows at the rate (W⁻¹)_zz⁻¹ > 0, the
    argument of darboux_keller) and bisection of the first bracket to the last bit; compiled
    (numba, :mod:`._hop`), some 10 µs a landing. Agrees with darboux_keller to its tolerance.

    ``v0`` the contact velocity before the impact (m/s, v0_z < 0), ``W`` the 3×3 inverse mass
    matrix at the contact (1/kg), ``mu`` the viscous coefficient (s/m). Raises
    :class:`JumpFailed` if no end of compression is found.
    """
    _hop = _hop_kernels()
    v0 = np.ascontiguousarray(v0, dtype=float)
    W = np.ascontiguousarray(W, dtype=float)
    P = _hop.viscous_impulse(v0, W, float(mu), _SCAN_POINTS)
    if not np.isfinite(P).all():
        raise JumpFailed("impact: the impulse equations could not be solved (no end of "
                         "compression)")  # fmt: skip
    return P


# --- the driver ----------------------------------------------------------------------------


def accumulation(durations: list[float], gaps: list[float]) -> tuple[float, float] | None:
    """(ratio r, remaining time Σ) if the last hops accumulate: their durations d_k in a
    geometric sequence of ratio r < 1 and no contact time between them (``gaps``: the contact
    phase before each hop, s). The sequence's limit lies Σ = d_last r/(1 − r) after the last one
    ends. None otherwise. The geometric test is :func:`mett.dynamics.hybrid.geometric_tail`
    (that of the stemmed top's impacts) on the last :data:`_ACCUMULATION_HOPS` hops, each
    ratio within 5 % of their mean.

    Under mett's perfectly inelastic landing this cannot happen to leading order in the hop
    duration (docs/theory/flight.md#hops-do-not-accumulate); the test guards the run anyway.
    """
    n = _ACCUMULATION_HOPS
    if len(durations) < n or np.any(np.asarray(gaps[-n + 1 :], dtype=float) > 0.0):
        return None
    return geometric_tail(durations[-n:], 1, n - 1, 0.05, about_mean=True)


def _contact_force(phase: Any, y: np.ndarray, t: float, p: tuple) -> float:
    """g_n/(m g) of ``y`` in ``phase`` (its "contact_lost" event function)."""
    ev = next(ev for ev in phase.events if ev.action == "contact_lost")
    return float(ev.fn(t, y, p))


def _start_phase(run: Run, table: dict, y: np.ndarray) -> Any:
    mdl = run.mdl
    if mdl.start_phase is None:
        return mdl.phase_table()[0]
    return table[mdl.start_phase(y, run.params)]


@dataclass
class _Piece:
    t: np.ndarray
    states: np.ndarray
    sol: Any
    phase_name: str
    extras: dict
    flight: bool
    gap: np.ndarray
    gap_rate: np.ndarray
    egap: np.ndarray | None = None
    """The gap (m) and its rate (m/s) of the sphere whose contact the flight's states are derived
    on (the stemmed top's, whose ``gap`` is the lower of its two spheres'); None: ``gap``."""
    egap_rate: np.ndarray | None = None


def warn_if_artefact(traj: Trajectory) -> None:
    """Warn (:class:`ViscousArtefactWarning`) if a viscous run (the ball top's ``"gliding"``,
    the stemmed top's ``"stemmed"``) lost contact with the law's coefficient μ|v_A| above
    :data:`VISCOUS_ARTEFACT` (at any lift-off; v_A the slip of the sphere that lifts off)."""
    if traj.model not in _VISCOUS or traj.t_contact_lost is None:
        return
    mu = traj.params[ix.MU]
    lifts = [(s.t, s.slip) for s in traj.records.get("switches", []) if s.reason == "lift-off"]
    if not lifts:  # stopped at the loss of contact: its state is the last sample
        lifts = [(traj.t_contact_lost, math.hypot(traj.nu_x[-1], traj.nu_y[-1]))]
    t, slip = max(lifts, key=lambda ts: ts[1])
    if mu * slip > VISCOUS_ARTEFACT:
        _validate.warn(
            f"contact lost at t = {t:.9g} s with mu |v_A| = {mu * slip:.3g} > "
            f"{VISCOUS_ARTEFACT:g}: the viscous law then acts as a dry friction coefficient no "
            "real contact has, so this loss of contact is an artefact of the law "
            "(docs/theory/flight.md)",
            ViscousArtefactWarning,
        )


def run_with_flight(prep: PreparedRun) -> Trajectory:
    """Integrate a prepared run of a model that flies (:func:`flies`): contact phases on
    the run's backend, exact flights between them, landing impacts at the touchdowns (the
    stemmed top's on whichever sphere touches first; ``contact`` then "ball", "stem", "both"
    or "none", ``gap`` the lower sphere's).

    A run that never loses contact is the contact model's Trajectory unchanged (bit for bit).
    Otherwise the Trajectory has, per sample, ``contact`` ("ball" or "none"), ``gap`` (m: the
    height of the lowest point of the sphere above the table) and ``gap_rate`` (m/s), ``phase``
    "flight" in flight; g_n = 0 and the energy E (Ẽ) with the CM's true height and vertical
    velocity there; ``switches`` (:class:`~mett.dynamics.stickslip.Switch` records, reason
    "lift-off" or "touchdown" for the flights, the model's own for its switches) and ``jumps``;
    ``t_contact_lost`` is the first lift-off. It ends "completed" at t_end, "failed" if hops
    accumulate (a geometric sequence of hops with no contact between them, whose limit is
    reported), if a hop has zero length (no contact force and no flight satisfies the law:
    a Painlevé-type inconsistency), or after :data:`MAX_HOPS` hops; the partial run is kept.
    """
    run, table, t_end, rtol, atol_arr, t_eval_arr, max_step, method, user = prep
    solve = functools.partial(backends.REGISTRY[run.backend].solve, t_end=t_end, rtol=rtol,
                              atol=atol_arr, max_step=max_step, t_eval=t_eval_arr,
                              method=method)  # fmt: skip
    events = backends.UserEvents(user, run) if user else None
    mdl, p = run.mdl, run.params
    flier = _FLIERS[mdl.name]
    body = (p[ix.M], p[ix.R], p[ix.L], p[ix.I1], p[ix.I3], p[ix.G])
    pieces: list[_Piece] = []
    switches: list[Any] = []
    jumps: list[tuple[np.ndarray, np.ndarray]] = []
    records: dict[str, Any] = {}
    durations: list[float] = []
    contact_times: list[float] = []
    nfev, t_lost, t_events = 0, None, None
    status, message = "completed", completed_message(t_end)
    y, t, phase = np.asarray(run.y0, dtype=float), run.t0, run.phase
    in_contact = _contact_force(phase, y, t, p) > 0.0
    last = None
    while True:
        if in_contact:
            r = Run(mdl, run.top, p, y, run.backend, phase, t0=t, state=run.state,
                    options=run.options)  # fmt: skip
            r.tolerances = run.tolerances
            traj = (solve_hybrid(r, solve, table, events) if mdl.hybrid
                    else r.trajectory(solve(r, events=events)))  # fmt: skip
            if not pieces and traj.status != "contact_lost":
                return traj  # never lost contact: the contact model's run, unchanged
            nfev += traj.nfev
            t_events = traj.t_events
            lost = traj.status == "contact_lost"
            t_lo = float(traj.t_contact_lost or 0.0) if lost else float(traj.t[-1])
            keep = traj.t < t_lo if lost else np.ones(traj.t.size, dtype=bool)
            n = int(keep.sum())
            # the series are derived from the states once for all contact pieces (_assemble)
            pieces.append(_Piece(traj.t[keep], traj.states[:, keep], traj._sol, mdl.phase,
                                 {k: v[keep] for k, v in traj.extras.items()}, False,
                                 np.zeros(n), np.zeros(n)))  # fmt: skip
            for name, value in traj.records.items():
                if name in ("switches", "jumps"):
                    (switches if name == "switches" else jumps).extend(value)
                elif flier.stemmed and name in records and np.ndim(value) == 1:
                    # touchdowns, accumulations: those of every contact piece
                    records[name] = np.concatenate((records[name], value))
                else:
                    records.setdefault(name, value)
            contact_times.append(t_lo - t)
            if not lost:
                status, message = traj.status, traj.message
                break
            y_lo = np.asarray(traj._sol(t_lo), dtype=float)
            last = str(traj.phase[-1]) if len(traj.t) else ""
            if flier.stemmed and flier.dry and len(traj.t):  # its phase: contact-friction phase
                last = f"{traj.contact[-1]}-{last}"
            t, y = t_lo, y_lo
        else:
            contact_times.append(0.0)
            last = last if last is not None else str(phase.name or "sliding")
        # --- a flight from (t, y): lift-off
        if t_lost is None:
            t_lost = t
        g = flier.to_body(y, p)
        on = round(float(y[10])) if flier.stemmed else 0  # the sphere that lifts off
        if on == 2:  # both forces at 0 at once: not reached from the double contact's events
            status = "failed"
            message = (f"both contacts lift off at once at t = {t:.9g} s: a flight from the "
                       "double contact is not implemented")  # fmt: skip
            pieces.append(_contact_end(y, t, phase, p, mdl))
            break
        body_c = _sphere_body(p, on, flier.stem) if flier.stemmed else body
        hop = Hop(g, t, body_c)
        beyond = _beyond_double(hop, g)
        if beyond is not None:  # rates no double-precision flight can follow: stop, run kept
            status, message = "failed", f"lift-off at t = {t:.9g} s: {beyond}"
            pieces.append(_contact_end(y, t, phase, p, mdl))
            break
        other = _other_hop(hop, g, t, p, on, flier.stem) if flier.stemmed else None
        nu = gliding_core(g.tolist(), (*body_c[:5], 0.0, body_c[5]))[12]
        switches.append(Switch(t, last or "sliding", "flight", "lift-off", math.nan,
                               math.hypot(nu[0], nu[1]), t))  # fmt: skip
        jumps.append((y.copy(), y.copy()))
        tau = hop.touchdown(t_end - t)
        lands_on = on
        if other is not None and tau != 0.0:  # the other sphere first? (stemmed top)
            tau_o = other.touchdown(t_end - t if tau is None else tau)
            if tau_o is not None and (tau is None or tau_o < tau):
                tau, lands_on = tau_o, 1 - on
        tau_end = t_end - t if tau is None else tau
        if 8.0 * hop.Omega * tau_end > MAX_FLIGHT_STEPS:
            status = "failed"
            message = (f"a flight from t = {t:.9g} s of {hop.Omega * tau_end / (2 * math.pi):.3g} "
                       f"turns at Ω = {hop.Omega:.3g} rad/s: more than the {MAX_FLIGHT_STEPS} "
                       "steps of dense output a flight may store")  # fmt: skip
            pieces.append(_contact_end(y, t, phase, p, mdl))
            break
        if tau == 0.0 and lands_on == on:
            status = "failed"
            message = (f"contact cannot be continued at t = {t:.9g} s: the normal force the "
                       "contact needs is negative and the free motion enters the table (a hop of "
                       "zero length; Painlevé-type inconsistency of the contact law)")  # fmt: skip
            pieces.append(_flight_piece(hop, 0.0, flier, p, t_eval_arr, last=True, flag=on,
                                        other=other))  # fmt: skip
            break
        g_td = hop.state(tau_end)
        sphere = _sphere_body(p, lands_on, flier.stem)[1:3] if flier.stemmed else None
        on_both = None  # a landing on both spheres: (the state after it, its impact)
        landed: tuple[np.ndarray, np.ndarray, float, float] | None
        try:
            # a landing on both spheres at once: the two-contact impact of the law
            if tau is not None and flier.stemmed and _both_land(hop, other, tau, on, lands_on, p):
                landed = None
                vz_td = float(hop.vz(tau))
                if flier.dry:
                    on_both = stemslip.land_both(g_td, vz_td, p, lands_on)
                elif flier.eps is not None:  # the regularised law
                    on_both = stem.land_both(g_td, vz_td, p, lands_on, law=stemreg.LAW)
                else:
                    on_both = stem.land_both(g_td, vz_td, p, lands_on, viscous_impulse)
            else:
                landed = (None if tau is None
                          else land(g_td, float(hop.vz(tau)), p, flier.dry, sphere,
                                    None if flier.eps is None else p[flier.eps]))  # fmt: skip
        except JumpFailed as exc:  # the run ends at the touchdown, the flight kept
            status, message = "failed", f"landing at t = {t + tau_end:.9g} s: {exc}"
            pieces.append(_flight_piece(hop, tau_end, flier, p, t_eval_arr, last=True, flag=on,
                                        other=other))  # fmt: skip
            break
        ends = landed is None and on_both is None
        piece = _flight_piece(hop, tau_end, flier, p, t_eval_arr, last=ends, flag=on,
                              other=other)  # fmt: skip
        if events:  # the user events on the flight's dense output, as on a compiled run's
            stop = _user_events(events, piece.sol)
            t_events = events.result(t + tau_end if stop is None else stop[0])
            if stop is not None and stop[0] <= t + tau_end:
                t_term = stop[0]
                piece = _flight_piece(hop, t_term - t, flier, p, t_eval_arr, last=True, flag=on,
                                      other=other)  # fmt: skip
                status = "completed"
                message = f"stopped by terminal event {stop[1]} at t = {t_term:.9g} s"
                pieces.append(piece)
                durations.append(t_term - t)
                break
        pieces.append(piece)
        durations.append(tau_end)
        if ends:
            break
        t_td = float(t + tau_end)
        reason = "touchdown"
        if on_both is not None:  # both spheres on the table: the two-contact impact
            y, imp = on_both
            g_after, margin, reason = imp.state[:10], math.nan, "double touchdown"
            y_before = _stem_layout(flier, g_td, p, on)
            body_l = _sphere_body(p, 1 if not imp.closed[0] else 0, flier.stem)
        elif landed is None:  # pragma: no cover - `ends` broke out of the loop above
            break
        elif flier.stemmed:  # on the sphere that landed
            g_after, P, Q, margin = landed
            y = _stem_layout(flier, g_after, p, lands_on)
            if flier.dry:
                y = contact.settle(y, _dry_stem_params(p, lands_on))
            y_before = _stem_layout(flier, g_td, p, on)
            body_l = _sphere_body(p, lands_on, flier.stem)
        else:
            g_after, P, Q, margin = landed
            y = flier.from_body(g_after, p)
            y_before = flier.from_body(g_td, p) if not flier.dry else contact.from_gliding(g_td, p)
            body_l = body
        phase = _start_phase(run, table, y)
        nu = gliding_core(g_after.tolist(), (*body_l[:5], 0.0, body_l[5]))[12]
        switches.append(Switch(t_td, "flight", phase.name or "sliding", reason, margin,
                               math.hypot(nu[0], nu[1]), t_td))  # fmt: skip
        jumps.append((y_before, y.copy()))
        t = t_td
        in_contact = _contact_force(phase, y, t, p) > 0.0
        # contact_times[k]: the contact before hop k; a landing that flies on at once may continue
        # an accumulating sequence
        acc = None if in_contact else accumulation(durations, contact_times)
        if acc is not None:
            ratio, rest = acc
            status = "failed"
            message = (f"hops accumulate at t = {t:.9g} s: their durations fall geometrically "
                       f"(ratio {ratio:.4g}) with no contact between them, towards t = "
                       f"{t + rest:.9g} s (a Zeno sequence); every landing needed a pulling "
                       "force, so at their limit no contact force satisfies the law (a "
                       "Painlevé-type point): the run stops at this landing")  # fmt: skip
            pieces.append(_contact_end(y, t, phase, p, mdl))
            break
        if len(durations) >= MAX_HOPS:
            status, message = "failed", f"more than {MAX_HOPS} flights (t = {t:.9g} s)"
            pieces.append(_contact_end(y, t, phase, p, mdl))
            break
        last = phase.name or "sliding"
    n_flights = len(durations)
    if status == "completed" and "terminal event" not in message:
        message = f"{message}; {n_flights} flight{'s' if n_flights != 1 else ''}"
    return _assemble(run, pieces, switches, jumps, records, status, message, t_lost, nfev,
                     t_events)  # fmt: skip


def _both_land(hop: Hop, other: Hop | None, tau: float, on: int, lands_on: int, p: tuple) -> bool:
    """True if the stemmed top's sphere that does not land at ``tau`` (s after the lift-off)
    has its gap within the switches' event tolerance then, |h| ≤ SWITCH_OFFSET·R (as a contact
    phase's switch sees the other sphere: :data:`mett.dynamics.stem.SWITCH_OFFSET`): both
    spheres reach the table together and the landing is the impact at both contacts."""
    if other is None:
        return False
    h = (other if lands_on == on else hop).gap(tau)[0]
    return abs(h) <= stem.SWITCH_OFFSET * p[ix.R]


def _sphere_body(p: tuple, on: int, stem_ix: Any = (ix.R_S, ix.L_S)) -> tuple:
    """(m, radius, distance G → centre, I1, I3, g) of the stemmed top's ball (``on`` 0) or stem
    sphere (1): the body :class:`Hop` flies on that sphere's contact (``stem_ix``: the indices
    of r_s and l_s in the model's parameters)."""
    if on == 1:
        r_s, l_s = p[stem_ix[0]], p[stem_ix[1]]
        return (p[ix.M], r_s, p[ix.L] + l_s, p[ix.I1], p[ix.I3], p[ix.G])
    return (p[ix.M], p[ix.R], p[ix.L], p[ix.I1], p[ix.I3], p[ix.G])


def _other_hop(hop: Hop, g: np.ndarray, t: float, p: tuple, on: int, stem_ix: Any) -> Hop:
    """The same flight as ``hop`` (lift-off from sphere ``on``) seen by the other sphere of the
    stemmed top: its gap h_o = z_G + l_o 3̂_z − R_o, at lift-off R_c − R_o + (l_o − l_c) 3̂_z (the
    stem's or the ball's clearance of stem.py, ≥ 0 up to its switch offset: clipped at 0), and
    its rate ż_G + l_o 3̂̇_z. :class:`Hop` with (R_o, l_o) and these (h, ḣ) is then the exact gap
    of that sphere (its ż_G = −l_o 3̂̇_z + ḣ is the flight's)."""
    c, o = _sphere_body(p, on, stem_ix), _sphere_body(p, 1 - on, stem_ix)
    ez = float(g[9] / np.linalg.norm(g[7:10]))
    clear = max(c[1] - o[1] + (o[2] - c[2]) * ez, 0.0)
    return Hop(g, t, o, gap=clear, gap_rate=hop.vz0 + o[2] * hop.Omega * float(hop.v[2]))


def _user_events(events: backends.UserEvents, sol: Any) -> tuple[float, int] | None:
    """Advance the user events over a flight's dense output; the terminal stop, if any."""
    ts = np.asarray(sol.ts, dtype=float)
    Y = np.asarray(sol(ts), dtype=float).reshape(-1, ts.size)
    try:
        events.advance(ts, events.values(ts, Y), sol)
    except backends.UserEventError as err:
        raise err.exc from None  # a user event's exception, unchanged (as on every backend)
    return events.stop


def _flight_piece(hop: Hop, tau_end: float, flier: _Flier, p: tuple, t_eval: Any,
                  last: bool, flag: int = 0, other: Hop | None = None) -> _Piece:  # fmt: skip
    """The samples and dense output of a flight over [0, tau_end] (its end kept if ``last``).

    A stemmed top's flight keeps the flag ``flag`` of the sphere it left (its series and energy
    are taken on that sphere's contact, corrected by ``hop``'s gap); its samples' ``gap`` is the
    lower of the two spheres' gaps (``other`` the other sphere's :class:`Hop`)."""
    if tau_end == 0.0:  # a hop of zero length: its one state
        from .dense import ConstantSolution

        y0 = _layout(flier, hop.state(0.0).reshape(10, 1), p, flag)[:, 0]
        return _Piece(np.array([hop.t0]), y0.reshape(-1, 1), ConstantSolution(hop.t0, y0),
                      "flight", {}, True, np.zeros(1), np.zeros(1))  # fmt: skip
    sol = hop.dense(tau_end, lambda G: _layout(flier, G, p, flag))
    if t_eval is None:
        t = sol.t if last else sol.t[:-1]
    else:
        inside = t_eval[(t_eval > hop.t0) & (t_eval < hop.t0 + tau_end)]
        t = np.concatenate(([hop.t0], inside, [hop.t0 + tau_end] if last else []))
    if t.size == 0:
        t = np.array([hop.t0])
    states = np.asarray(sol(t), dtype=float).reshape(-1, t.size)
    gap, rate = hop.gaps(t - hop.t0)
    if other is None:
        return _Piece(t, states, sol, "flight", {}, True, gap, rate)
    gap_o, rate_o = other.gaps(t - hop.t0)
    lower = gap_o < gap
    return _Piece(t, states, sol, "flight", {}, True, np.where(lower, gap_o, gap),
                  np.where(lower, rate_o, rate), gap, rate)  # fmt: skip


def _layout(flier: _Flier, G: np.ndarray, p: tuple, flag: int = 0) -> np.ndarray:
    """Gliding-layout states ``G`` (10, k) in the model's layout (no settling in flight; the
    stemmed top's phase flag ``flag``)."""
    if flier.stemmed:
        return _stem_layout(flier, G, p, flag)
    return G if not flier.dry else contact.from_gliding(G, p)


def _contact_end(y: np.ndarray, t: float, phase: Any, p: tuple, mdl: Any) -> _Piece:
    """A one-sample contact piece: the state a stopped run ends in."""
    from .dense import ConstantSolution

    return _Piece(np.array([t]), y.reshape(-1, 1), ConstantSolution(t, y), phase.name, {},
                  False, np.zeros(1), np.zeros(1))  # fmt: skip


def _assemble(run: Run, pieces: list[_Piece], switches: list, jumps: list, records: dict,
              status: str, message: str, t_lost: Any, nfev: int, t_events: Any) -> Trajectory:  # fmt: skip
    """One Trajectory of the contact and flight pieces."""
    mdl, p = run.mdl, run.params
    m, g = p[ix.M], p[ix.G]
    t = np.concatenate([pc.t for pc in pieces])
    states = np.hstack([pc.states for pc in pieces])
    flight = np.concatenate([np.full(pc.t.size, pc.flight) for pc in pieces])
    # the contact samples' series, derived in one call (the model's derive is per sample: the
    # same numbers as one call per contact piece, without its fixed cost at every landing)
    series: dict[str, np.ndarray] = {k: np.full(t.size, np.nan) for k in SERIES}
    if not flight.all():
        d_c = mdl.derive(states[:, ~flight], p)
        for k in SERIES:
            series[k][~flight] = np.asarray(d_c[k], dtype=float)
    if flight.any():  # flight samples: derived from the states, g_n = 0, E with the true height
        Yf = states[:, flight]
        d = mdl.derive(Yf, p)
        flier = _FLIERS[mdl.name]
        if flier.stem is not None:
            on = np.round(Yf[10]) == 1
            G = np.array(Yf[:10], dtype=float)
            for mask, which in ((~on, 0), (on, 1)):
                if flier.dry and mask.any():
                    G[:, mask] = contact.to_gliding(Yf[:10, mask], _dry_stem_params(p, which))
            lc = p[ix.L] + p[flier.stem[1]] * on
        else:
            G = Yf if mdl.name == "gliding" else contact.to_gliding(Yf, p)
            lc = p[ix.L]
        e = G[7:10] / np.linalg.norm(G[7:10], axis=0)
        L = G[4:7]
        vz_c = -lc * np.cross(L, e, axis=0)[2] / p[ix.I1]  # the contact value −l 3̂̇_z
        egap = [pc.gap if pc.egap is None else pc.egap for pc in pieces]
        erate = [pc.gap_rate if pc.egap_rate is None else pc.egap_rate for pc in pieces]
        gap = np.concatenate(egap)[flight]
        rate = np.concatenate(erate)[flight]
        vz = vz_c + rate
        dE = 0.5 * m * (vz * vz - vz_c * vz_c) + m * g * gap
        for k in SERIES:
            series[k][flight] = np.asarray(d[k], dtype=float)
        series["gn"][flight] = 0.0
        series["E"][flight] += dE
        series["E_mod"][flight] += dE
    names: dict[str, Any] = {}
    for pc in pieces:
        for k, v in pc.extras.items():
            names.setdefault(k, np.asarray(v).dtype)
    extras: dict[str, np.ndarray] = {}
    for k, dt in names.items():
        parts = []
        for pc in pieces:
            if k in pc.extras:
                parts.append(np.asarray(pc.extras[k]))
            elif dt.kind == "U":
                parts.append(np.full(pc.t.size, "flight" if k == "phase" else ""))
            else:
                parts.append(np.zeros(pc.t.size))
        extras[k] = np.concatenate(parts)
    extras["phase"] = np.where(flight, "flight", extras.get("phase", np.full(t.size, "sliding")))
    extras["contact"] = np.where(flight, "none", extras.get("contact", "ball"))
    extras["gap"] = np.concatenate([pc.gap for pc in pieces])
    extras["gap_rate"] = np.concatenate([pc.gap_rate for pc in pieces])
    # pieces that end where the next begins: drop repeated times (the later state holds)
    keep = np.append(np.diff(t) > 0.0, True)
    sols = [pc.sol for pc in pieces]
    phases = [pc.phase_name if not pc.flight else "flight" for pc in pieces]
    flat_sols, flat_phases = [], []
    for s, name in zip(sols, phases, strict=True):
        if isinstance(s, SegmentedSolution):
            flat_sols.extend(s.sols)
            flat_phases.extend(s.phases)
        else:
            flat_sols.append(s)
            flat_phases.append(name)
    sol = SegmentedSolution(flat_sols, flat_phases)
    order = sorted(range(len(switches)), key=lambda i: float(switches[i][0]))  # stable
    switches = [switches[i] for i in order]
    if len(jumps) == len(order):  # each jump stays with its switch
        jumps = [jumps[i] for i in order]
    records = {**records, "switches": switches, "jumps": jumps}
    return Trajectory(
        t=t[keep], states=states[:, keep], model=mdl, top=run.top, params=p, solution=sol,
        status=status, message=message, t_contact_lost=t_lost, t_events=t_events, nfev=nfev,
        backend=run.backend, initial_state=run.state, options=run.options,
        extras={k: v[keep] for k, v in extras.items()}, records=records,
        series={k: v[keep] for k, v in series.items()}, finish=False, **run.tolerances,
    )  # fmt: skip
