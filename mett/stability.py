"""Linear stability of the spinning states of the gliding top, and the escape time it predicts.

The spinning solutions (docs/theory/thresholds.md#boundary-values) are equilibria of the vector form of the gliding model
(docs/theory/equations.md#vector-form; :mod:`mett.dynamics.gliding`): 3̂ = ±ẑ, L = I3 ω3 3̂, CM at rest, with
ω3 = λ/(R I3 (1 − α)) upright and ω3 = −λ/(R I3 (1 + α)) inverted. They are linearised in the
10-dimensional state [x, y, ẋ, ẏ, L, 3̂] with a complex-step Jacobian, J e_k = Im f(y + i h e_k)/h,
which is exact to rounding because the right-hand side is plain arithmetic (no differences of
nearby numbers). By the symmetry about ẑ the horizontal perturbations (ẋ, ẏ, L_x, L_y, 3̂_x, 3̂_y)
decouple from the rest (x, y, L_z, 3̂_z: neutral directions along the family of spins), so the six
eigenvalues of that block decide stability (docs/theory/thresholds.md#thresholds: the inverted spin is asymptotically stable
iff λ > λ_thres, the upright spin is unstable iff λ > λ_0).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from . import _validate
from .thresholds import pole_spins
from .top import TippeTop

if TYPE_CHECKING:
    from .state import State

__all__ = ["EscapeEstimate", "escape_time", "spin_eigenvalues", "spin_jacobian"]

_HORIZONTAL = [2, 3, 4, 5, 7, 8]  # ẋ, ẏ, L_x, L_y, 3̂_x, 3̂_y in the gliding model's state
_POLES = ("upright", "inverted")


def _spin_state(top: TippeTop, lam: float, pole: str) -> np.ndarray:
    if pole not in _POLES:
        raise ValueError(f"pole must be one of {_POLES}; got {pole!r}")
    upright, inverted = pole_spins(top, lam)
    sign, omega3 = (1.0, upright) if pole == "upright" else (-1.0, inverted)
    y = np.zeros(10)
    y[6] = top.I3 * omega3 * sign  # L = I3 ω3 3̂
    y[9] = sign
    return y


def _params(top: TippeTop) -> tuple:
    return (top.m, top.R, top.R * top.alpha, top.I1, top.I3, top.mu, top.g)


def spin_jacobian(top: TippeTop, lam: float, pole: str = "inverted") -> np.ndarray:
    """Jacobian (10 × 10) of the gliding vector field at the spinning state with Jellett ``lam``.

    Complex-step differentiation of :func:`mett.dynamics.gliding.gliding_rhs`.
    """
    from .dynamics.gliding import gliding_rhs

    _validate.instance("top", top, TippeTop)
    lam = _validate.positive_jellett(lam)
    y0 = _spin_state(top, lam, pole)
    p = _params(top)
    scale = np.maximum(np.abs(y0), [top.R, top.R, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0])
    # velocities ~ R ω3, angular momenta ~ I3 ω3; floored at the gravity scale √(g/R) so that a
    # tiny λ does not give a zero (or underflowing) complex step
    w_floor = math.sqrt(top.g / top.R)
    scale[2:4] = top.R * max(abs(y0[6]) / top.I3, w_floor)
    scale[4:7] = top.I3 * max(abs(y0[6]) / top.I3, w_floor)
    J = np.empty((10, 10))
    with np.errstate(all="ignore"):  # an overflow shows as a non-finite J, refused below
        for k in range(10):
            h = 1e-30 * scale[k]
            yc = y0.astype(complex)
            yc[k] += 1j * h
            J[:, k] = np.imag(gliding_rhs(0.0, yc, p)) / h
    if not np.all(np.isfinite(J)):
        raise ValueError(
            f"lam = {lam!r} is too large: the linearisation at that spin overflows double precision"
        )
    return J


def spin_eigenvalues(top: TippeTop, lam: float, pole: str = "inverted") -> np.ndarray:
    """Eigenvalues (1/s) of the gliding model linearised at a spinning state, largest real part first.

    Parameters
    ----------
    top : TippeTop
    lam : float
        Jellett integral λ > 0 of the spin.
    pole : {"inverted", "upright"}
        θ = π (spinning on the peg side) or θ = 0.

    Returns
    -------
    ndarray of complex, shape (6,)
        The eigenvalues of the horizontal perturbations (the other four directions are neutral).
        The spin is asymptotically stable if all real parts are negative, unstable if one is
        positive.

    Raises
    ------
    ValueError
        If ``lam`` is not positive and finite (or so large that the linearisation overflows), or
        ``pole`` is not one of the two names.
    """
    J = spin_jacobian(top, lam, pole)
    ev = np.linalg.eigvals(J[np.ix_(_HORIZONTAL, _HORIZONTAL)])
    return ev[np.argsort(-ev.real, kind="stable")]


class EscapeEstimate(NamedTuple):
    """Linear prediction of the time a near-upright top takes to reach θ = π/2."""

    time: float
    """Predicted time (s): ln(1/θ_u(0))/σ."""
    growth_rate: float
    """σ = largest real part of the upright spin's eigenvalues (1/s)."""
    amplitude: float
    """θ_u(0): size of the initial perturbation's component in the unstable modes (rad)."""


def escape_time(top: TippeTop, state: State) -> EscapeEstimate:
    """Predict when a top started near θ = 0 reaches θ = π/2, from the linearisation at the spin.

    The initial state's deviation from the upright spin with the same λ is projected on the
    eigenvectors; its component θ_u(0) in the unstable modes grows like e^{σt}, and the escape is
    predicted when that reaches sin θ = 1: t = ln(1/θ_u(0))/σ. This ignores the nonlinear last
    stage of the inversion and the transient of the stable modes; its error against simulations is
    measured in tests/test_stability.py (a few percent for the thesis-like starts checked there).

    Raises
    ------
    ValueError
        If the state's Jellett integral is not positive, the upright spin is not unstable
        (λ <= λ_0), or the state is not near it (no unstable component, or one of size >= 1).
    """
    from .dynamics import MODELS
    from .integrals import jellett

    lam = float(jellett(top, state))  # checks the types of top and state
    J = spin_jacobian(top, lam, "upright")
    A = J[np.ix_(_HORIZONTAL, _HORIZONTAL)]
    ev, vecs = np.linalg.eig(A)
    sigma = float(ev.real.max())
    if sigma <= 0.0:
        raise ValueError(
            f"the upright spin is stable for lam = {lam:.6g} (lam_0 = {top.lambda_0:.6g}): "
            "no escape to predict"
        )
    model = MODELS["gliding"]
    p = model.params(top, {})
    with np.errstate(over="ignore", invalid="ignore"):
        dy = model.initial(state, p) - _spin_state(top, lam, "upright")
    if not np.all(np.isfinite(dy)):
        raise ValueError(
            "state is not near the upright spin (its deviation overflows double precision): the "
            "linear escape prediction does not apply"
        )
    unstable = ev.real > 0.5 * sigma
    with np.errstate(over="ignore", invalid="ignore"):  # a huge deviation: inf, refused below
        coef = np.linalg.solve(vecs, dy[_HORIZONTAL])
        # 3̂_x, 3̂_y rows of the unstable part: its size is sin θ of the unstable component.
        u = vecs[4:6][:, unstable] * coef[unstable]
        amplitude = float(np.sqrt(np.sum(np.abs(u) ** 2)))
    if amplitude == 0.0:
        raise ValueError(
            "the state has no component in the unstable modes (e.g. exactly upright): "
            "the linear prediction never leaves the spin"
        )
    if not amplitude < 1.0:  # NaN from an overflowing deviation too
        raise ValueError(
            f"the state is not near the upright spin (unstable-mode amplitude {amplitude:.3g} "
            ">= 1): the linear escape prediction does not apply"
        )
    return EscapeEstimate(math.log(1.0 / amplitude) / sigma, sigma, amplitude)
