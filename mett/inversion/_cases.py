"""The verification cases of :func:`mett.predict_inversion` and their simulated reference.

A deterministic generator (seeded) of group-II tops, friction laws and starts spanning the ranges
of docs/theory/inversion.md#verification, and the reference: the first crossing of θ = π/2 by a
full compiled simulation of the gliding top (no reduction), continued through flight and landing
where the top hops. Used by tests/test_inversion*.py and by tools/inversion_table.py, which writes
the table on the docs page.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..friction import Coulomb, FrictionLaw, RegularisedCoulomb, Viscous
from ..state import State
from ..top import TippeTop
from ._gyroscopic import nutation_period


@dataclass(frozen=True)
class Case:
    """One verification case: a top, a friction law and an initial state."""

    name: str
    top: TippeTop
    friction: FrictionLaw
    state: State
    law: str


def _top(alpha: float, gamma: float, sigma: float, mu: float) -> TippeTop:
    m, R = 0.02, 0.02
    I3 = m * R * R / sigma
    return TippeTop(m=m, R=R, alpha=alpha, I1=gamma * I3, I3=I3, mu=mu, g=9.82)


def _spin_for(top: TippeTop, theta0: float, ratio: float) -> float:
    # ω3 with λ = ratio · λ_thres for a start with φ̇ = 0 (λ = R I3 ω3 (cos θ0 − α)).
    return ratio * top.lambda_thres / (top.R * top.I3 * (math.cos(theta0) - top.alpha))


def _draw_common(rng: np.random.Generator) -> tuple[float, float, float, float, float]:
    # α, γ, σ, λ/λ_thres, θ0, drawn in this order (the seed stream of cases 0–59)
    alpha = rng.uniform(0.1, 0.4)
    # γ strictly inside (1 − α, 1 + α), kept in the physical range γ ≥ 1/2.
    gamma = rng.uniform(max(1.0 - 0.8 * alpha, 0.55), 1.0 + 0.8 * alpha)
    sigma = rng.uniform(1.5, 3.5)
    ratio = math.exp(rng.uniform(math.log(1.5), math.log(20.0)))
    theta0 = math.exp(rng.uniform(math.log(0.01), math.log(0.5)))
    return alpha, gamma, sigma, ratio, theta0


def _case(i: int, top: TippeTop, law: FrictionLaw, name: str, theta0: float, ratio: float) -> Case:
    omega3 = _spin_for(top, theta0, ratio)
    if i % 2:
        state = State(theta=theta0, omega3=omega3)
    else:
        state = State.with_cm_at_rest(top, theta=theta0, omega3=omega3)
    return Case(f"case{i:02d}", top, law, state, name)


def cases(n: int = 60, seed: int = 2026, n_contensou: int = 12) -> list[Case]:
    """``n`` cases: 2/3 viscous (μ log-uniform in [0.03, 3] s/m), the rest regularised Coulomb
    (μ in [0.1, 0.5], ε in [0.01, 0.1] m/s); then ``n_contensou`` Coulomb–Contensou cases
    (μ in [0.1, 0.5], contact-disc radius r in [0.5, 3] mm). For all: α in
    [0.1, 0.4], γ inside the group-II range, σ in [1.5, 3.5]; λ/λ_thres in [1.5, 20]
    (log-uniform), θ0 in [0.01, 0.5] (log-uniform); half the starts with the centre of mass at
    rest, half with the contact point at rest (ν = 0), alternating with the case's number.

    The Coulomb–Contensou cases (named from ``case{n}`` on) come from a second generator seeded
    with ``(seed, 1)``, so the first ``n`` cases are those of the stream seeded with ``seed``
    alone, whatever ``n_contensou``.
    """
    rng = np.random.default_rng(seed)
    out = []
    for i in range(n):
        alpha, gamma, sigma, ratio, theta0 = _draw_common(rng)
        law: FrictionLaw
        if i % 3 in (0, 1):
            mu = math.exp(rng.uniform(math.log(0.03), math.log(3.0)))
            top = _top(alpha, gamma, sigma, mu)
            law, name = Viscous(), "viscous"
        else:
            mu = rng.uniform(0.1, 0.5)
            top = _top(alpha, gamma, sigma, 0.3)
            law, name = RegularisedCoulomb(mu, rng.uniform(0.01, 0.1)), "regularised-coulomb"
        out.append(_case(i, top, law, name, theta0, ratio))
    rng = np.random.default_rng((seed, 1))
    for i in range(n, n + n_contensou):
        alpha, gamma, sigma, ratio, theta0 = _draw_common(rng)
        mu = rng.uniform(0.1, 0.5)
        r = rng.uniform(0.5e-3, 3e-3)
        top = _top(alpha, gamma, sigma, 0.3)
        out.append(
            _case(i, top, Coulomb(mu, contensou_radius=r), "coulomb-contensou", theta0, ratio)
        )
    return out


@dataclass(frozen=True)
class Reference:
    """The simulated reference of a case: the first crossing of θ = π/2 with flight and landing.

    Attributes
    ----------
    t_half : float
        First time (s) θ crosses π/2 in the full simulation, in contact or in flight; ``inf`` if
        not by the end of the run.
    T_n : float
        Nutation period at the start, 2π I1/(I3 ω3(0)) (s): the slack of the comparison.
    status, message : str
        The simulation's.
    t_end : float
        The requested end of the run (s).
    t_contact_lost : float or None
        First lift-off (s).
    hops : int
        Lift-offs before the crossing (before the end of the run if there is none).
    in_flight : bool
        The crossing happened during a flight.
    airborne : float
        Time (s) spent in flight before the crossing (before the end of the run if there is none):
        no friction acts then, so the slow flow stands still.
    artefact : float
        Largest viscous-law coefficient μ|v_A| at those lift-offs (0 for other laws or without
        lift-off): above 1 the lift-off is an artefact of the law
        (docs/theory/flight.md#when-a-loss-of-contact-is-an-artefact).
    """

    t_half: float
    T_n: float
    status: str
    message: str
    t_end: float
    t_contact_lost: float | None
    hops: int
    in_flight: bool
    airborne: float
    artefact: float

    @property
    def has_crossing(self) -> bool:
        return math.isfinite(self.t_half)


def reference(case: Case, t_end: float, rtol: float = 1e-8) -> Reference:
    """Simulate ``case`` to ``t_end`` with flight and landing (``stop_on_contact_loss=False``)
    and return its :class:`Reference`.

    A crossing of π/2 during a flight counts: the inclination is measured the same way in the
    air (the exact torque-free motion, docs/theory/flight.md). A run that ends "failed" (hops
    accumulating, no consistent contact) before crossing has no crossing.
    """
    import warnings

    from ..dynamics import simulate
    from ..dynamics.flight import ViscousArtefactWarning

    T_n = nutation_period(case.top, float(case.state.omega3))
    # Coulomb–Contensou: DOP853's steps are bounded by a tenth of the nutation period. Left free
    # at rtol 1e-8 they grow to ~0.9 of it while the nutation is far below rtol of the state
    # (after a saturated start, 1e-8 rad), and damp it: case 60 then creeps at θ ≈ 0.09 instead
    # of growing its nutation (the same run as at rtol 1e-12, to plotting accuracy, with the bound).
    max_step = 0.1 * T_n if case.law == "coulomb-contensou" else math.inf
    with warnings.catch_warnings():
        # the artefact is recorded in the Reference instead (field ``artefact``)
        warnings.simplefilter("ignore", ViscousArtefactWarning)
        traj = simulate(case.top, case.state, t_end, friction=case.friction, rtol=rtol,
                        backend="auto", stop_on_contact_loss=False,
                        max_step=max_step)  # fmt: skip
    hits = traj.crossings(0.5 * math.pi)
    t_half = float(hits[0]) if len(hits) else math.inf
    switches = [s for s in traj.records.get("switches", []) if s.t <= t_half]
    lifts = [s for s in switches if s.reason == "lift-off"]
    lands = [s for s in switches if s.reason == "touchdown"]
    # in flight at the crossing: more lift-offs than touchdowns before it
    in_flight = math.isfinite(t_half) and len(lifts) > len(lands)
    t_stop = min(t_half, traj.t_final)
    airborne = sum(min(d.t, t_stop) - u.t for u, d in zip(lifts, lands, strict=False))
    if len(lifts) > len(lands):  # still in the air at the crossing or at the end
        airborne += t_stop - lifts[-1].t
    artefact = 0.0
    if case.law == "viscous" and lifts:
        artefact = case.top.mu * max(s.slip for s in lifts)
    return Reference(t_half, T_n, traj.status, traj.message, t_end, traj.t_contact_lost,
                     len(lifts), in_flight, airborne, artefact)  # fmt: skip


def simulated_t_half(case: Case, t_end: float, rtol: float = 1e-9) -> tuple[float, float, str]:
    """First time θ crosses π/2 in the full simulation with flight and landing (``inf`` if not
    by ``t_end``), the nutation period at the start (s) for the slack, and the simulation's
    status (:func:`reference`)."""
    ref = reference(case, t_end, rtol)
    return ref.t_half, ref.T_n, ref.status
