"""Whether the nutation lifts the top off before π/2: a first-order criterion along the balance path.

The reductions assume a top on the table, g_n = m g. The contact force is g_n = m (g + ḧ) with
the centre of mass at height h = R − l cos θ (l = Rα, the sphere on the plane), so

    g_n/m = g − l d²(cos θ)/dt² = g + l (θ̈ sin θ + θ̇² cos θ),

and a nutation z = cos θ = z̄ + Z cos(ω t) (a linear mode of complex rate λ_n = ρ + iω) takes it to
g − l |λ_n|² Z at its crest: the top lifts off where

    l |λ_n|² Z ≥ g.                                                                (lift-off)

Z, ω and ρ come from the linearisation of the gliding model (mett.dynamics.gliding) about the
gyroscopic-balance state at the mean inclination θ̄, in the frame that precesses with it (there
the balance state is steady): the 8 × 8 Jacobian of (ṙ, L, 3̂) by complex steps, less the
generator of the rotation at φ̇. It has two fast pairs, of frequency ≈ φ̇: the nutation, and the
drift of the centre of mass (a constant velocity seen from the precessing frame: exactly i φ̇
without friction, damped at ≈ μ g κ with it). The nutation is followed by continuity from the
upright spin, the step split where the two come close (where their frequencies cross); there
the initiation's linear mode split (:func:`mett.escape_time`) gives its amplitude Θ(0): the
component of the start in the decaying mode whose real part is nearest zero (the axis spinning
about its own tilted direction with L tilted too). Along the slow path its amplitude changes by

* its own growth or decay, Re λ_n (friction), and
* adiabatically: the action J = E_n/ω = ½ M ω Θ² of the θ-oscillation is invariant while ω
  changes slowly, M = I1 + m l² sin²θ̄ (the inertia of θ with the centre of mass vertical),

so Θ(t)² M ω = Θ(0)² M0 ω0 exp(2 ∫ Re λ_n dt), and Z = Θ sin θ̄. Near the upright spin, where
Θ > θ̄, the same Z holds: the axis then circles its mean direction and cos θ oscillates with
amplitude θ̄ Θ (small angles). All of this is first order in the nutation: the θ̇² term of g_n
is O(Θ²) and omitted. The derivation and its check against the 60 verification cases are on
docs/theory/inversion.md#verification.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from ..dynamics.gliding import gliding_core
from ..friction import RegularisedCoulomb, Viscous
from ..stability import UprightModes
from ..top import TippeTop
from ._gyroscopic import balance_state, law_code, top_array


class LiftOff(NamedTuple):
    """The criterion along the slow path (nodes with θ̄ ≤ π/2, up to the first past it)."""

    t_lift: float
    """First time (s) with l |λ_n|² Z ≥ g before π/2; ``inf`` if none."""
    t: np.ndarray
    """Times of the nodes (s)."""
    ratio: np.ndarray
    """l |λ_n|² Z / g at the nodes: the nutation's peak vertical acceleration over g."""
    amplitude: np.ndarray
    """Θ (rad), the nutation's amplitude in θ."""
    rate: np.ndarray
    """λ_n (1/s), the nutation's eigenvalue in the precessing frame."""


def upright_nutation(modes: UprightModes) -> tuple[float, complex]:
    """Amplitude Θ(0) (rad) of the start in the upright spin's nutation mode, and its eigenvalue.

    ``modes``: the start split into the eigenmodes of the gliding model linearised at the upright
    spin with the same λ, with the viscous coefficient of the law linearised there, as
    :func:`mett.escape_time` computes it (:func:`mett.stability.escape_modes`):
    the growing pair (largest real part) is the inversion mode; of the other two pairs, the one
    with the real part nearest zero is the nutation (the other is the slip, damped at ≈ μ g κ).
    Its size is that of its 3̂_x, 3̂_y components (the radius of the axis's circle).
    """
    ev, vecs, coef = modes
    order = np.argsort(-ev.real, kind="stable")
    rest = order[2:]  # without the growing pair
    nut = rest[np.argsort(np.abs(ev.real[rest]), kind="stable")[:2]]
    u = vecs[4:6][:, nut] * coef[nut]
    return float(np.sqrt(np.sum(np.abs(u) ** 2))), complex(ev[nut[0]])


def _fast_spectra(top: TippeTop, law, lam: float, theta) -> np.ndarray:
    """The two fast eigenvalues (N, 2) of positive frequency (≈ φ̇) of the gliding model at the
    balance states of inclinations ``theta``, in the frame that precesses with them.

    State [ẋ, ẏ, L, 3̂] (the position drops out: the field does not depend on it). The balance
    state at φ = 0: 3̂ = (0, −sin θ, cos θ), ω = φ̇ ẑ + (ω3 − φ̇ cos θ) 3̂, L = I1 ω + (I3 − I1) ω3 3̂,
    the centre of mass at rest. Complex-step Jacobian of every node and column in one call of
    :func:`mett.dynamics.gliding.gliding_core`, less the generator of the rotation at φ̇; the
    regularised Coulomb law enters as the viscous field with the coefficient μ/√(|ν|² + ε²) of
    the state's own slip (differentiated through, so the Jacobian is the law's).
    """
    theta = np.asarray(theta, dtype=float)
    phidot, omega3 = (np.real(x) for x in balance_state(top, lam, theta)[:2])
    m, R, I1, I3, g = top.m, top.R, top.I1, top.I3, top.g
    l = R * top.alpha
    s, c = np.sin(theta), np.cos(theta)
    n = len(theta)
    k = (I3 - I1) * omega3
    y0 = np.zeros((10, n))
    y0[5] = I1 * s * (phidot * c - omega3) - k * s
    y0[6] = I1 * (phidot * s * s + omega3 * c) + k * c
    y0[8], y0[9] = -s, c
    scale = np.empty((8, n))
    scale[0:2] = R * np.maximum(np.abs(phidot), np.abs(omega3))
    scale[2:5] = np.sqrt(y0[5] ** 2 + y0[6] ** 2)
    scale[5:8] = 1.0
    h = 1e-30 * scale  # (8, n): the step of column k at node j
    Y = np.repeat(y0[:, :, None], 8, axis=2).astype(complex)
    for col in range(8):
        Y[2 + col, :, col] += 1j * h[col]
    Y = Y.reshape(10, n * 8)
    if isinstance(law, RegularisedCoulomb):
        nux, nuy = gliding_core(Y, (m, R, l, I1, I3, 0.0, g))[12]  # ν does not depend on μ
        mu = law.mu / np.sqrt(nux * nux + nuy * nuy + law.eps**2)
    else:
        mu = top.mu if law.mu is None else law.mu
    d = gliding_core(Y, (m, R, l, I1, I3, mu, g))
    J = np.imag(np.array(d[2:10])).reshape(8, n, 8) / h.T[None, :, :]
    A = np.ascontiguousarray(J.transpose(1, 0, 2))
    for i in (0, 2, 5):  # the rotation at φ̇ about ẑ: d/dt (u_x, u_y) = φ̇ (−u_y, u_x)
        A[:, i, i + 1] += phidot
        A[:, i + 1, i] -= phidot
    ev = np.linalg.eigvals(A)
    return ev[np.arange(n)[:, None], np.argsort(-ev.imag, axis=1)[:, :2]]


# A choice between the two fast eigenvalues is taken when the nearer is within this fraction of
# the other's distance from the extrapolated value; otherwise the step is split (SPLIT parts,
# at most DEPTH times): where the nutation's frequency crosses the slip's, the two come close.
# The compiled walk (mett.inversion._compiled) has its own copy of CLEAR, SPLIT and DEPTH
# (the recursion written with an explicit stack): a test checks that they agree.
CLEAR, SPLIT, DEPTH = 0.3, 8, 3


def _follow(top, law, lam, theta, history, depth=0) -> list[complex]:
    """The nutation's eigenvalue at ``theta`` by continuity from ``history`` [(θ, λ_n), ...].

    The numpy form, one :func:`_fast_spectra` call per split: :func:`lift_off` takes the same
    picks compiled (:func:`mett.inversion._compiled.lift_off_kernel`); kept as the reference that
    it is checked against (tests/test_inversion_nutation.py).
    """
    fast = _fast_spectra(top, law, lam, theta).tolist()
    out = []
    for th, (a, b) in zip(theta.tolist(), fast, strict=True):
        (t1, l1), (t0, l0) = history[-1], history[-2] if len(history) > 1 else history[-1]
        guess = l1 + (l1 - l0) * (th - t1) / (t1 - t0) if t1 != t0 else l1
        da, db = abs(a - guess), abs(b - guess)
        if min(da, db) > CLEAR * max(da, db) and depth < DEPTH and len(history) > 1:
            sub = np.linspace(t1, th, SPLIT + 1)[1:-1]
            inner = _follow(top, law, lam, sub, history[-2:], depth + 1)
            history = history + list(zip(sub.tolist(), inner, strict=True))
            (t1, l1), (t0, l0) = history[-1], history[-2]
            guess = l1 + (l1 - l0) * (th - t1) / (t1 - t0)
            da, db = abs(a - guess), abs(b - guess)
        pick = a if da <= db else b
        history = [*history[-1:], (th, pick)]
        out.append(pick)
    return out


# lift_off_time answers "no lift-off" from the bound when it stays below this: far from 1, so
# that no rounding of the ratio (1e-13 relative) can reach 1 where the bound does not
BOUND = 0.5


def _kernel_args(top: TippeTop, law, lam: float, t, theta) -> tuple:
    if not isinstance(law, (Viscous, RegularisedCoulomb)):
        raise TypeError(f"friction law {law!r} is not covered by the lift-off criterion")
    code, mu, eps = law_code(top, law)
    t = np.ascontiguousarray(t, dtype=float)
    theta = np.ascontiguousarray(theta, dtype=float)
    return t, theta, float(lam), top_array(top), code, mu, eps


def lift_off(top: TippeTop, law, lam: float, t, theta, amp0: float, rate0: complex) -> LiftOff:
    """The lift-off criterion along the balance path (module docstring).

    ``t``, ``theta``: the slow path's nodes with θ̄ ≤ π/2 (Jellett integral ``lam``); ``amp0``,
    ``rate0``: :func:`upright_nutation`. The nutation is the fast eigenvalue continued from the
    upright spin's (where the precessing frame adds φ̇ to its small frequency, and friction
    damps the slip at ≈ μ g κ, far from it): by linear extrapolation from node to node, the
    step split where the two fast eigenvalues are not clearly apart (:data:`CLEAR`), as
    :func:`_follow` does it (the numpy reference), compiled
    (:func:`mett.inversion._compiled.lift_off_kernel`): node by node, so the walk stops at the
    first node past the criterion.

    The arrays stop at the first node past the criterion (t_lift is decided there).
    """
    from . import _compiled  # numba, at the first prediction only (not at import mett)

    t, theta, lam, top_a, code, mu, eps = _kernel_args(top, law, lam, t, theta)
    t_lift, n, ratio, amp, lam_n = _compiled.lift_off_kernel(
        t, theta, float(amp0), complex(rate0), lam, top_a, code, mu, eps, BOUND, True
    )
    return LiftOff(float(t_lift), t[:n], ratio[:n], amp[:n], lam_n[:n])


def lift_off_time(top: TippeTop, law, lam: float, t, theta, amp0: float, rate0: complex) -> float:
    """:func:`lift_off`'s t_lift, the nutation followed only where it may lift the top off.

    The ratio at a node takes one of the two fast eigenvalues (a, b) there, so it is at most the
    ratio with the larger |λ|² and Re λ of the two at every node, the larger frequency at the
    first node and the smaller at the node (both positive). Where that bound stays below
    :data:`BOUND` at every node, t_lift is ``inf`` whichever the picks are, and neither the splits
    nor the walk are needed (the common case: a top far from hopping); otherwise :func:`lift_off`
    decides, from the spectra already computed (both in one compiled call).
    """
    from . import _compiled  # numba, at the first prediction only (not at import mett)

    t, theta, lam, top_a, code, mu, eps = _kernel_args(top, law, lam, t, theta)
    return float(
        _compiled.lift_off_kernel(
            t, theta, float(amp0), complex(rate0), lam, top_a, code, mu, eps, BOUND, False
        )[0]
    )


# --- the resolved start: the nonlinear split of a large tilt -------------------------------------
#
# The linear split (mett.stability.escape_modes) is first order in the start's deviation from the
# upright spin. Where the start lies mostly in the decaying modes (a tilt θ0 whose growing part
# θ_u(0) is a small fraction of it), their nonlinear interaction during the slip's transient sets
# the growing mode's amplitude: measured on the thesis top, the amplitude the growing mode carries
# once the transient is over, θ_u(t1) e^{−σ t1}, is 1.9× the linear split's with the contact point
# at rest (θ0 = 0.1, μ = 0.3 s/m) and 0.38× with the centre of mass at rest (θ0 = 0.3), and 0.13×
# at ω3 = 620 rad/s (μ = 0.05 s/m, θ0 = 0.1): docs/theory/inversion.md#the-initial-tilt.
# The resolved start integrates that transient with the full model and splits the state there.

# the transient is over after this many e-foldings of the slowest decaying mode other than the
# nutation (the slip of the contact point, at ≈ μ g κ)
SLIP_FOLDS = 6.0
# the split is taken where the growing part is below this (rad): it must still be linear in the
# growing mode (its own nonlinearity is O(θ_u²), 0.25 % relative here)
GROWING_CAP = 0.05
# times tried for the split, from the window's end back to a quarter of it
SPLIT_TRIES = 7
# the resolved start is used where the linear split leaves less than this fraction of the
# start's tilt in the growing mode (docs/theory/inversion.md#the-initial-tilt)
SPLIT_FRACTION = 0.3
# the resolved integration's relative tolerance: its global error on the horizontal state, about
# 1e-7 of the spin's scale over the window, is below 1e-3 of the growing part's size there
RESOLVED_RTOL = 1e-9
# the nutation's resonant effect on the growing mode is integrated while that climbs to this
# (rad): the thesis starts move by at most 1.2 % of t_half between 0.3 rad and no limit, and a nutation
# that barely decays (Re λ_n → 0) acts for that time, not for ever
HORIZON_THETA = 1.0
# the nutation's drift of the growing part is measured from this fraction of the split time on
# (4 of the window's 6 e-foldings of the slip)
DRIFT_FROM = 2.0 / 3.0
# ... where the growing part there is at least this (rad): below it the drift is the
# integration's own error (rtol 1e-9 of states of size θ0, over some 1e4 steps), as at
# ω3 = 2480 rad/s on the thesis top, where the growing part is ~1e-9 rad
DRIFT_FLOOR = 1e-6
# the drift is used where its rates on the two halves of the measured interval agree to this
# factor, or where its integral is below DRIFT_NEGLIGIBLE (log) anyway
DRIFT_AGREE, DRIFT_NEGLIGIBLE = 3.0, 0.05
# samples of the growing mode's last period at the end of the window
AVERAGE_SAMPLES = 16


class ResolvedStart(NamedTuple):
    """The start split after its transient (:func:`resolved_start`)."""

    amplitude: float
    """θ_u(0) (rad): the growing mode's amplitude at t1 carried back at its rate, θ_u(t1) e^{−σ t1}."""
    nutation: float
    """Θ(0) (rad): the nutation's amplitude at t1 carried back at its rate."""
    t1: float
    """Time of the split (s): the end of the resolved window, or earlier (:data:`GROWING_CAP`)."""
    linear: float
    """θ_u(0) of the linear split (rad), for comparison."""


def _mode_groups(ev: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Index arrays of the growing pair, the nutation pair and the slip pair of the upright
    spin's horizontal eigenvalues (as :func:`upright_nutation` and :func:`mett.escape_time`)."""
    order = np.argsort(-ev.real, kind="stable")
    grow, rest = order[:2], order[2:]
    by_rate = rest[np.argsort(np.abs(ev.real[rest]), kind="stable")]
    return grow, by_rate[:2], by_rate[2:]


def _size(vecs: np.ndarray, coef: np.ndarray, sel: np.ndarray) -> float:
    # the radius of the axis's circle in these modes: their 3̂_x, 3̂_y rows
    u = vecs[4:6][:, sel] * coef[sel]
    return float(np.sqrt(np.sum(np.abs(u) ** 2)))


def resolved_start(top: TippeTop, state, modes: UprightModes) -> ResolvedStart | None:
    """The nonlinear split of a start: the full model over the transient, then the linear split.

    ``top`` carries the viscous coefficient (s/m) the start is integrated with; ``modes`` is the
    start's linear split at the upright spin with the same λ (:func:`mett.stability.escape_modes`).
    The gliding model (:func:`mett.simulate`, rtol :data:`RESOLVED_RTOL`) runs from the start for
    t1 = :data:`SLIP_FOLDS` e-foldings of the slip (the decaying pair farther from the imaginary
    axis). Its state there (or earlier, where the growing part is still below
    :data:`GROWING_CAP`) is split into the same eigenvectors; its growing part θ_u(t1), averaged
    over the growing mode's period, and its nutation Θ(t1)
    carried back at their rates give the amplitudes the slow flow and the lift-off criterion
    start from at t = 0 (the modes evolve linearly after t1: the growing one is still small, the
    decaying ones have decayed). ``None`` where the run does not complete (the top lifts off in
    the window) or the split fails: the linear split stands.

    Cost: the resolved run over t1, about (μ g κ)⁻¹ ω3 I3/I1 nutation periods (6 e-foldings):
    it grows with ω3 and is spent only where the linear split is not enough (:data:`SPLIT_FRACTION`).
    """
    from ..dynamics.simulation import simulate

    ev, vecs, coef = modes
    grow, nut, slip = _mode_groups(ev)
    sigma = float(ev.real[grow[0]])
    linear = _size(vecs, coef, grow)
    if not (sigma > 0.0 and linear > 0.0):
        return None
    t1 = SLIP_FOLDS / abs(float(ev.real[slip[0]]))
    w = abs(float(ev.imag[grow[0]]))
    period = 2.0 * math.pi / w if w > 0.0 else math.inf
    if not t1 > period:
        return None
    traj = simulate(top, state, t1, rtol=RESOLVED_RTOL, stop_on_contact_loss=True)
    if traj.status != "completed":
        return None

    def growing_part(t_split: float) -> tuple[float, np.ndarray] | None:
        # The growing part over the growing mode's period before t_split, each sample carried
        # back at its eigenvalue and averaged: the decaying modes' nonlinear (cubic) share of
        # the horizontal state projects onto the growing eigenvector too, but at their own slow
        # frequencies, so carried back at λ_u it turns at ≈ Im λ_u and averages out over the
        # period (uniform samples: exact for its harmonics below AVERAGE_SAMPLES).
        ts = t_split - period * np.arange(AVERAGE_SAMPLES) / AVERAGE_SAMPLES
        ys = traj.states_at(ts)[[2, 3, 4, 5, 7, 8]]  # ẋ, ẏ, L_x, L_y, 3̂_x, 3̂_y
        try:
            c = np.linalg.solve(vecs, ys)
        except np.linalg.LinAlgError:
            return None
        back = np.mean(c[grow] * np.exp(-np.outer(ev[grow], ts)), axis=1)
        return _size(vecs[:, grow], back, np.arange(2)), c[:, 0]

    # The split is taken at the end of the window, or earlier where the growing part has
    # already passed GROWING_CAP there (a large start whose growing part is large too): the
    # latest of SPLIT_TRIES times back to a quarter of the window with it below the cap.
    t_end = float(traj.t[-1])
    for k in range(SPLIT_TRIES):
        t_split = t_end * (1.0 - 0.75 * k / (SPLIT_TRIES - 1))
        if t_split - period < 0.0:
            return None
        part = growing_part(t_split)
        if part is None:
            return None
        amp, c = part
        if math.isfinite(amp) and amp * math.exp(sigma * t_split) <= GROWING_CAP:
            break
    else:
        return None
    rate_n = float(ev.real[nut[0]])
    theta_n = _size(vecs, c, nut) * math.exp(-rate_n * t_split)
    if not (math.isfinite(amp) and amp > 0.0 and math.isfinite(theta_n)):
        return None
    # After the split the nutation is still there (it decays at Re λ_n, slowly), and it slows
    # (or speeds) the growing mode: the resonant cubic term of the normal form,
    # d ln θ_u/dt = σ + β |z_n|², |z_n|² ∝ e^{2 Re λ_n t}. Its rate is measured on the run, as
    # the drift of the carried-back growing part between DRIFT_FROM of the split time and the
    # split (past the slip's transient: its own share has decayed like e^{2 Re λ_slip t}), and
    # integrated from the split while the growing mode climbs to HORIZON_THETA (after which the
    # balance flow is no longer its linear growth).
    t_a = DRIFT_FROM * t_split
    t_m = 0.5 * (t_a + t_split)
    early = growing_part(t_a) if t_a - period >= 0.0 else None
    mid = growing_part(t_m) if early is not None else None
    if (
        early is not None
        and mid is not None
        and early[0] * math.exp(sigma * t_a) >= DRIFT_FLOOR
        and mid[0] > 0.0
    ):
        # the drift on each half of [t_a, t_split]: the growing part must drift steadily (the
        # same sign, rates within DRIFT_AGREE of each other) for the drift to be the nutation's
        # resonant term; where it jumps about (a nutation far beyond the linear range, e.g.
        # 0.5 rad) the split keeps the value at t_split
        d1 = math.log(mid[0] / early[0]) / (t_m - t_a)
        d2 = math.log(amp / mid[0]) / (t_split - t_m)
        drift = 0.5 * (d1 + d2)  # at t_m
        drift *= math.exp(rate_n * (t_split - t_a))  # e^{2 Re λ_n (t_split − t_m)}
        horizon = max(math.log(HORIZON_THETA / (amp * math.exp(sigma * t_split))) / sigma, 0.0)
        # (1 − e^{2 Re λ_n H})/(−2 Re λ_n), → H as Re λ_n → 0
        span = horizon if rate_n == 0.0 else math.expm1(2.0 * rate_n * horizon) / (2.0 * rate_n)
        steady = d1 * d2 > 0.0 and max(abs(d1), abs(d2)) <= DRIFT_AGREE * min(abs(d1), abs(d2))
        if steady or abs(drift * span) <= DRIFT_NEGLIGIBLE:
            amp *= math.exp(drift * span)
    if not amp < float(state.theta):
        return None  # a growing part larger than the start's tilt: not a split of this start
    return ResolvedStart(amp, theta_n, t_split, linear)
