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
