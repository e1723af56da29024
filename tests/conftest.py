"""Shared fixtures: the thesis top and random generators of tops and states."""

from __future__ import annotations

import numpy as np
import pytest

import mett


@pytest.fixture
def thesis_top() -> mett.TippeTop:
    return mett.presets.get("rutstam2013")


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(20261121)


def random_top(rng: np.random.Generator) -> mett.TippeTop:
    """A random physical top of toy size (1 ≤ γ·2 guaranteed, I3 ≤ m R²)."""
    m = rng.uniform(0.005, 0.05)
    R = rng.uniform(0.01, 0.04)
    alpha = rng.uniform(0.05, 0.6)
    I3 = rng.uniform(0.25, 0.6) * m * R**2
    I1 = rng.uniform(0.55, 1.5) * I3
    return mett.TippeTop(m=m, R=R, alpha=alpha, I1=I1, I3=I3, mu=rng.uniform(0, 1))


def random_state(rng: np.random.Generator, n: int, *, gliding: bool = True) -> mett.State:
    """n random states with θ away from the poles and spins of toy size."""
    return mett.State(
        theta=rng.uniform(0.05, np.pi - 0.05, n),
        thetadot=rng.normal(0, 5, n),
        phidot=rng.normal(0, 20, n),
        omega3=rng.normal(0, 150, n),
        nu_x=rng.normal(0, 0.3, n) if gliding else 0.0,
        nu_y=rng.normal(0, 0.3, n) if gliding else 0.0,
    )


@pytest.fixture(scope="session")
def thesis_trajectory():
    """The thesis run (rutstam2013, θ0 = 0.1, ω3 = 155 rad/s, ν(0) = 0) over 8 s, computed once."""
    top = mett.presets.get("rutstam2013")
    return mett.simulate(top, mett.State(theta=0.1, omega3=155.0), t_end=8.0)
