"""Linear stability of the steady states of the gliding top (spins and tumbling states), and the
escape time it predicts.

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
from scipy.linalg import null_space

from . import _validate
from .dynamics.gliding import gliding_core, gliding_rhs
from .dynamics.registry import MODELS
from .integrals import jellett
from .thresholds import TumblingState, pole_spins, tumbling_domain
from .top import TippeTop

if TYPE_CHECKING:
    from .state import State

__all__ = [
    "EscapeEstimate",
    "UprightModes",
    "escape_modes",
    "escape_time",
    "spin_eigenvalues",
    "spin_jacobian",
    "tumbling_eigenvalues",
]

_HORIZONTAL = [2, 3, 4, 5, 7, 8]  # ẋ, ẏ, L_x, L_y, 3̂_x, 3̂_y in the gliding model's state
_HORIZONTAL_BLOCK = np.ix_(_HORIZONTAL, _HORIZONTAL)
_HORIZONTAL_ARRAY = np.array(_HORIZONTAL)  # built once: escape_modes runs per prediction
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


def _complex_step(fun, y0: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """Jacobian of ``fun`` at ``y0`` by complex steps, J e_k = Im fun(y0 + i h_k e_k)/h_k with
    h_k = 1e-30 scale[k] (Squire & Trapp 1998): no difference of nearby numbers, so exact to
    rounding for plain arithmetic. Columns in the order of ``y0``."""
    cols = []
    for k in range(len(y0)):
        h = 1e-30 * scale[k]
        yc = y0.astype(complex)
        yc[k] += 1j * h
        cols.append(np.atleast_1d(np.imag(fun(yc))) / h)
    return np.array(cols).T


def spin_jacobian(top: TippeTop, lam: float, pole: str = "inverted") -> np.ndarray:
    """Jacobian (10 × 10) of the gliding vector field at the spinning state with Jellett ``lam``.

    Complex-step differentiation of :func:`mett.dynamics.gliding.gliding_rhs`.
    """
    _validate.instance("top", top, TippeTop)
    lam = _validate.positive_jellett(lam)
    y0, h, p = _spin_steps(top, lam, pole)
    # every column's complex step at once: gliding_core is plain arithmetic on equal-shape
    # arrays, so column k of Y is y0 + i h_k e_k and J = Im f(Y)/h, as _complex_step does it
    # column by column, for a tenth of the calls
    Y = y0.astype(complex)[:, None] + np.diag(1j * h)
    with np.errstate(all="ignore"):  # an overflow shows as a non-finite J, refused below
        J = np.ascontiguousarray(np.imag(np.array(gliding_core(Y, p)[:10])) / h)
    _check_jacobian(J, lam)
    return J


def _spin_steps(top: TippeTop, lam: float, pole: str) -> tuple[np.ndarray, np.ndarray, tuple]:
    """The spin's state, the complex steps of :func:`spin_jacobian`'s columns, the parameters."""
    y0 = _spin_state(top, lam, pole)
    scale = np.maximum(np.abs(y0), [top.R, top.R, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0])
    # velocities ~ R ω3, angular momenta ~ I3 ω3; floored at the gravity scale √(g/R) so that a
    # tiny λ does not give a zero (or underflowing) complex step
    w_floor = math.sqrt(top.g / top.R)
    scale[2:4] = top.R * max(abs(y0[6]) / top.I3, w_floor)
    scale[4:7] = top.I3 * max(abs(y0[6]) / top.I3, w_floor)
    return y0, 1e-30 * scale, _params(top)


def _check_jacobian(J: np.ndarray, lam: float) -> None:
    if not np.all(np.isfinite(J)):
        raise ValueError(
            f"lam = {lam!r} is too large: the linearisation at that spin overflows double precision"
        )


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
    ev = np.linalg.eigvals(J[_HORIZONTAL_BLOCK])
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
    return escape_modes(top, state)[0]


class UprightModes(NamedTuple):
    """The upright spin's horizontal eigenmodes and a start's components in them."""

    eigenvalues: np.ndarray
    """(6,) complex (1/s): of the horizontal block (ẋ, ẏ, L_x, L_y, 3̂_x, 3̂_y) of the Jacobian."""
    vectors: np.ndarray
    """(6, 6) complex: the eigenvectors, as columns."""
    coefficients: np.ndarray
    """(6,) complex: the start's deviation from the spin with its λ, in the eigenvectors."""


def escape_modes(top: TippeTop, state: State) -> tuple[EscapeEstimate, UprightModes]:
    """:func:`escape_time` and the mode decomposition it is computed from.

    For a caller that needs the start's other modes too (:func:`mett.predict_inversion` takes
    the nutation's amplitude from them), without linearising the spin twice.

    Raises
    ------
    ValueError
        As :func:`escape_time`.
    """
    lam = float(jellett(top, state))  # checks the types of top and state
    lam = _validate.positive_jellett(lam)
    # spin_jacobian's complex steps and the eigen-decomposition, compiled
    # (mett.predict_inversion calls this each time; numba, at the first call, not at import mett)
    from .inversion import _compiled

    y0, h, p = _spin_steps(top, lam, "upright")
    model = MODELS["gliding"]
    with np.errstate(over="ignore", invalid="ignore"):
        dy = model.initial(state, model.params(top, {})) - y0  # y0: the upright spin
    J, ev, vecs, coef, ok = _compiled.upright_modes_kernel(y0, h, p, _HORIZONTAL_ARRAY,
                                                           dy[_HORIZONTAL])  # fmt: skip
    _check_jacobian(J, lam)
    if not ok:  # QR not converged or a repeated eigenvalue: LAPACK's eigenvectors
        ev, vecs = np.linalg.eig(J[_HORIZONTAL_BLOCK])
        coef = None
    sigma = float(ev.real.max())
    if sigma <= 0.0:
        raise ValueError(
            f"the upright spin is stable for lam = {lam:.6g} (lam_0 = {top.lambda_0:.6g}): "
            "no escape to predict"
        )
    if not np.all(np.isfinite(dy)):
        raise ValueError(
            "state is not near the upright spin (its deviation overflows double precision): the "
            "linear escape prediction does not apply"
        )
    unstable = ev.real > 0.5 * sigma
    with np.errstate(over="ignore", invalid="ignore"):  # a huge deviation: inf, refused below
        if coef is None:
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
    estimate = EscapeEstimate(math.log(1.0 / amplitude) / sigma, sigma, amplitude)
    return estimate, UprightModes(ev, vecs, coef)


def _state_at(top: TippeTop, th: float) -> TumblingState:
    """The tumbling state at θ_t = ``th``, φ̇ from its closed form (:class:`mett.TumblingState`)."""
    a = top.alpha
    phidot = math.sqrt(
        top.m * top.g * top.R * a / (top.I3 * (a - (1.0 - top.gamma) * math.cos(th)))
    )
    return TumblingState(float(th), phidot, phidot * (math.cos(th) - a))


# --- linear stability of a tumbling state -----------------------------------------------------


def _rotating_system(top: TippeTop, theta: float):
    """Tumbling state y* = [ẋ, ẏ, L, 3̂] (3̂ in the xz plane), its precession rate Ω and F(y).

    F(y) = f(y) − Ω ẑ × y (applied to each horizontal/3-vector part) is the gliding vector field
    in the frame turning with the precession; y* is an equilibrium of it.
    """
    st = _state_at(top, theta)
    a, I1, I3 = top.alpha, top.I1, top.I3
    e = np.array([math.sin(theta), 0.0, math.cos(theta)])
    w = st.phidot * (np.array([0.0, 0.0, 1.0]) - a * e)  # ω ∥ a = R(α3̂ − ẑ), ω·3̂ = ω3
    L = I1 * w + (I3 - I1) * float(w @ e) * e
    y = np.concatenate(([0.0, 0.0], L, e))
    p = _params(top)
    Om = st.phidot

    def turn(v):
        out = np.zeros_like(v)
        for k in (0, 2, 5):  # ẑ × (vx, vy, ·) on the velocity, L and 3̂ parts
            out[k], out[k + 1] = -v[k + 1], v[k]
        return out

    def F(v):
        full = np.concatenate((np.zeros(2, dtype=v.dtype), v))
        return gliding_rhs(0.0, full, p)[2:] - Om * turn(v)

    def lam_of(v):
        n = (v[5] * v[5] + v[6] * v[6] + v[7] * v[7]) ** 0.5
        return -(v[2] * (top.R * a * v[5] / n) + v[3] * (top.R * a * v[6] / n)
                 + v[4] * (top.R * a * v[7] / n - top.R))  # fmt: skip

    return y, st, F, lam_of, turn


def tumbling_eigenvalues(top: TippeTop, theta: float) -> np.ndarray:
    """Eigenvalues (1/s) of the gliding top linearised at the tumbling state θ_t = ``theta``.

    The vector form of :mod:`mett.dynamics.gliding` is written in the frame precessing with the
    state (where the state is an equilibrium; the CM position is cyclic and dropped), linearised
    with a complex-step Jacobian, restricted to the subspace where the integrals |3̂| and λ keep
    their values (their gradients are left null vectors, so it is invariant) and divided by the
    rotation about ẑ (a right null vector). Five eigenvalues remain.

    Parameters
    ----------
    top : TippeTop
    theta : float
        θ_t inside the family's domain, 0 < θ_t < π (rad); the spins at 0 and π are
        :func:`mett.spin_eigenvalues`' business.

    Returns
    -------
    ndarray of complex, shape (5,)
        Largest real part first. The state is asymptotically stable (up to drift along the family
        and the symmetry) if all real parts are negative; the largest is real and changes sign
        with λ'(θ_t) (:func:`mett.classification.tumbling_is_stable`).

    Raises
    ------
    ValueError
        If ``theta`` is not inside (0, π) or the family does not exist there.
    """
    _validate.instance("top", top, TippeTop)
    th = float(_validate.theta(theta))
    lo, hi = tumbling_domain(top)
    exists = top.alpha - (1.0 - top.gamma) * math.cos(th) > 0.0
    if not (0.0 < th < math.pi and exists):
        raise ValueError(
            f"theta must lie inside the tumbling family's domain ({lo:.6g}, {hi:.6g}) without the "
            f"poles 0 and pi; got {theta!r}"
        )
    if math.sin(th) < 1e-8:
        raise ValueError(
            f"theta must be at least 1e-8 rad from the poles 0 and pi (the tumbling state merges into "
            f"the spin there: use mett.spin_eigenvalues); got {theta!r}"
        )
    y, st, F, lam_of, turn = _rotating_system(top, th)
    Lmag = float(np.linalg.norm(y[2:5]))
    scale = np.array([top.R * st.phidot] * 2 + [Lmag] * 3 + [1.0] * 3)
    J = _complex_step(F, y, scale)
    grad_lam = _complex_step(lam_of, y, scale)[0]
    grad_norm = np.concatenate((np.zeros(5), 2.0 * y[5:]))
    W = null_space(np.vstack([grad_lam / np.linalg.norm(grad_lam), grad_norm]))  # 8 × 6
    A = W.T @ J @ W
    u = W.T @ turn(y)
    P = null_space(u[None, :] / np.linalg.norm(u))  # 6 × 5, quotient by the rotation
    ev = np.linalg.eigvals(P.T @ A @ P)
    return ev[np.argsort(-ev.real, kind="stable")]
