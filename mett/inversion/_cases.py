"""The verification cases of :func:`mett.predict_inversion` and their simulated reference.

A deterministic generator (seeded) of group-II tops, friction laws and starts spanning the ranges
of docs/theory/inversion.md#verification, and the reference: the first crossing of θ = π/2 by a
full compiled simulation of the gliding top (no reduction). Used by tests/test_inversion*.py and
by benchmarks/bench_inversion.py, which writes the table on the docs page.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..friction import FrictionLaw, RegularisedCoulomb, Viscous
from ..state import State
from ..top import TippeTop


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


def cases(n: int = 60, seed: int = 2026) -> list[Case]:
    """``n`` cases: 2/3 viscous (μ log-uniform in [0.03, 3] s/m), the rest regularised Coulomb
    (μ in [0.1, 0.5], ε in [0.01, 0.1] m/s); α in
    [0.1, 0.4], γ inside the group-II range, σ in [1.5, 3.5]; λ/λ_thres in [1.5, 20]
    (log-uniform), θ0 in [0.01, 0.5] (log-uniform); half the starts with the centre of mass at
    rest, half with the contact point at rest (ν = 0)."""
    rng = np.random.default_rng(seed)
    out = []
    for i in range(n):
        alpha = rng.uniform(0.1, 0.4)
        # γ strictly inside (1 − α, 1 + α), kept in the physical range γ ≥ 1/2.
        gamma = rng.uniform(max(1.0 - 0.8 * alpha, 0.55), 1.0 + 0.8 * alpha)
        sigma = rng.uniform(1.5, 3.5)
        ratio = math.exp(rng.uniform(math.log(1.5), math.log(20.0)))
        theta0 = math.exp(rng.uniform(math.log(0.01), math.log(0.5)))
        kind = i % 3
        law: FrictionLaw
        if kind in (0, 1):
            mu = math.exp(rng.uniform(math.log(0.03), math.log(3.0)))
            top = _top(alpha, gamma, sigma, mu)
            law, name = Viscous(), "viscous"
        else:
            mu = rng.uniform(0.1, 0.5)
            top = _top(alpha, gamma, sigma, 0.3)
            law, name = RegularisedCoulomb(mu, rng.uniform(0.01, 0.1)), "regularised-coulomb"
        omega3 = _spin_for(top, theta0, ratio)
        if i % 2:
            state = State(theta=theta0, omega3=omega3)
        else:
            state = State.with_cm_at_rest(top, theta=theta0, omega3=omega3)
        out.append(Case(f"case{i:02d}", top, law, state, name))
    return out


def simulated_t_half(case: Case, t_end: float, rtol: float = 1e-9) -> tuple[float, float, str]:
    """First time θ crosses π/2 in the full simulation (``inf`` if not by ``t_end``), the
    nutation period at the start (s) for the slack, and the simulation's status."""
    from ..dynamics import simulate

    # a run that loses contact ends there: both reductions assume a top on the table, and a
    # top that hops is not the motion they describe (docs/theory/inversion.md#verification)
    traj = simulate(case.top, case.state, t_end, friction=case.friction, rtol=rtol,
                    backend="auto", stop_on_contact_loss=True)  # fmt: skip
    hits = traj.crossings(0.5 * math.pi)
    T_n = 2.0 * math.pi * case.top.I1 / (case.top.I3 * abs(float(case.state.omega3)))
    return (float(hits[0]) if len(hits) else math.inf), T_n, traj.status
