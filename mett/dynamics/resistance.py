"""Rolling resistance on top of viscous sliding: the law :class:`RollingResistance` and its model.

``mett.simulate(top, state, t_end, friction=RollingResistance(mu_r))`` runs the registered model
``"rolling-resistance"``: the eccentric sphere of ``"gliding"`` (viscous sliding friction
F_t = −μ g_n v_A, μ = ``top.mu`` in s/m; Rutstam 2013, thesis eq. (3)) with, in addition, a
resisting couple about the horizontal part ω_h = ω − (ω·ẑ) ẑ of the angular velocity,

    M_r = −μ_r g_n ω_h / √(|ω_h|² + ω_ε²),

μ_r (m) the coefficient of rolling resistance, a length: the offset ahead of the contact at which
an inelastic (hysteretic) contact carries the normal force, so |M_r| = μ_r g_n in steady rolling
(Johnson, *Contact Mechanics*, Cambridge University Press 1985, ch. 9, rolling resistance). The
law is of the dry, Coulomb kind in the rolling velocity: its direction opposes ω_h and its
magnitude does not depend on |ω_h|, the simplest, uncoupled member of the combined
sliding–rolling friction models of Kireenkov (Mechanics of Solids 43, 2008). The set-valued law
at ω_h = 0 is regularised here (our choice, derived, not taken from those sources): below the
rate ω_ε the couple falls linearly to zero, a viscous rolling damping −(μ_r g_n/ω_ε) ω_h, which
keeps the right-hand side Lipschitz, as :class:`mett.friction.RegularisedCoulomb` does for
sliding. The exact law would need a rolling-stick phase, as Coulomb's sliding has.

The equations are those of :mod:`.contact` with the horizontal couple added (the state of
:mod:`.stickslip`, λ = −L·a in place of L_z): with the force per unit normal force
f = (−μ v_A, 1) and the couple per unit normal force t = −μ_r ω_h/√(|ω_h|² + ω_ε²),

    v̇_A = g_n (G f + (J⁻¹t) × a) + h,    g_n = −h_z / (G f + (J⁻¹t) × a)_z,
    L̇ = a × F + M_r,    λ̇ = −M_r·a,

and the energy falls at the rate dE/dt = F_t·v_A + M_r·ω = −μ g_n |v_A|² − μ_r g_n |ω_h|²/
√(|ω_h|² + ω_ε²) ≤ 0. With μ_r = 0 it is the ``"gliding"`` model.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from .. import friction
from ..friction import Param
from . import _params as ix
from . import gliding
from .contact import delassus, from_gliding, kinematics, to_gliding
from .registry import Event, Model, Option, friction_law, register

__all__ = ["MODEL", "RollingResistance", "rolling_resistance_rhs", "wrench"]


@dataclass(frozen=True)
class RollingResistance:
    """Viscous sliding plus a rolling-resistance couple M_r = −μ_r g_n ω_h/√(|ω_h|² + ω_ε²).

    Parameters
    ----------
    mu_r : float
        Coefficient of rolling resistance μ_r (m), ≥ 0: the couple's magnitude per unit normal
        force while the top rolls (|ω_h| ≫ ω_ε).
    mu : float, optional
        Viscous sliding coefficient μ (s/m), ≥ 0; ``None`` (the default) takes ``top.mu``.
    omega_eps : float, default 0.1
        Regularisation rate ω_ε (rad/s), > 0: below it the couple falls linearly to zero.
    """

    mu_r: float
    mu: float | None = None
    omega_eps: float = 0.1

    params: ClassVar[tuple[Param, ...]] = (
        Param("mu_r", "m", doc="coefficient of rolling resistance"),
        Param("mu", "s/m", doc="viscous sliding coefficient"),
        Param("omega_eps", "rad/s", positive=True, doc="regularisation rate"),
    )
    analytic: ClassVar[bool] = True
    """Smooth in ω_h (|ω_h|² + ω_ε² > 0): ``backend="auto"`` runs it on the Taylor backend."""

    def __post_init__(self) -> None:
        friction.check_params(self)

    def force(self, v_A: Any, gn: Any, omega_n: Any = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """The viscous sliding force (N, shape (2, ...)) and zero torque about ẑ."""
        return friction.Viscous(self.mu).force(v_A, gn, omega_n)

    def torque(self, omega_h: Any, gn: Any) -> np.ndarray:
        """The rolling-resistance couple M_r (N m, shape (2, ...)) of the horizontal ω_h (rad/s)."""
        w = np.asarray(omega_h, dtype=float)
        k = (
            -self.mu_r
            * np.asarray(gn, dtype=float)
            / np.sqrt(w[0] ** 2 + w[1] ** 2 + self.omega_eps**2)
        )
        return k * w

    def applied(self, top: Any) -> tuple[Any, RollingResistance]:
        """The top with this μ (if given) and this law."""
        return (top if self.mu is None else dataclasses.replace(top, mu=self.mu)), self

    def model_for(self, base: str) -> str:
        """``"rolling-resistance"`` for ``"gliding"``, else ``base``."""
        return MODEL.name if base == "gliding" else base

    def describe(self) -> str:
        """E.g. ``"RollingResistance(mu_r=0.0001)"``."""
        return friction.label(self)


friction.register(RollingResistance, {"rolling-resistance": ("mu_r", "mu")})


def wrench(y: Any, p: Any) -> tuple:
    """(derivatives, g_n, F, M_r) at state(s) ``y``; plain arithmetic (module docstring).

    ``p = (m, R, l, I1, I3, mu, g, mu_r, omega_eps)``; F = (F_x, F_y, g_n) (N), M_r = (M_x, M_y)
    (N m).
    """
    m, I1, mu, mu_r, w_eps = p[ix.M], p[ix.I1], p[ix.MU], p[ix.MU_R], p[ix.W_EPS]
    e, w, de, a, nu, h, c = kinematics(y, p)
    fx, fy = -mu * nu[0], -mu * nu[1]
    k = -mu_r / (w[0] * w[0] + w[1] * w[1] + w_eps * w_eps) ** 0.5
    tx, ty = k * w[0], k * w[1]
    Gf = delassus((fx, fy, 1.0), e, a, m, I1, c)
    # J⁻¹t = t/I1 + c (t·3̂) 3̂ (t horizontal); its contact acceleration (J⁻¹t) × a, z part
    te = tx * e[0] + ty * e[1]
    jx, jy = tx / I1 + c * te * e[0], ty / I1 + c * te * e[1]
    sz = jx * a[1] - jy * a[0]
    gn = -h[2] / (Gf[2] + sz)
    Fx, Fy, Mx, My = gn * fx, gn * fy, gn * tx, gn * ty
    ax, ay, az = a
    d = (
        y[2],
        y[3],
        Fx / m,
        Fy / m,
        ay * gn - az * Fy + Mx,
        az * Fx - ax * gn + My,
        -(Mx * ax + My * ay),  # λ̇ = −M_r·a (M_r horizontal)
        de[0],
        de[1],
        de[2],
    )
    return d, gn, (Fx, Fy, gn), (Mx, My)


def rolling_resistance_rhs(t: float, y: np.ndarray, p: tuple) -> np.ndarray:
    """Right-hand side (state of :mod:`.stickslip`: λ in place of L_z; SI units)."""
    if np.ndim(y) == 1:
        y = y.tolist()  # Python floats: scalar arithmetic several times faster than numpy's
    return np.array(wrench(y, p)[0])


def _rhs_into(t: float, y: Any, p: Any, out: Any) -> None:
    d = wrench(y, p)[0]
    out[0], out[1], out[2], out[3], out[4] = d[0], d[1], d[2], d[3], d[4]
    out[5], out[6], out[7], out[8], out[9] = d[5], d[6], d[7], d[8], d[9]


def _contact(t: float, y: Any, p: Any) -> Any:
    return wrench(y, p)[1] * (1.0 / (p[ix.M] * p[ix.G]))


def _gliding(p: tuple) -> tuple:
    """The "gliding" model's (m, R, l, I1, I3, μ, g)."""
    return (p[ix.M], p[ix.R], p[ix.L], p[ix.I1], p[ix.I3], p[ix.MU], p[ix.G])


def _params(top: Any, options: dict) -> tuple:
    law = options["friction"]  # the top carries the law's μ (RollingResistance.applied)
    l = top.R * top.alpha
    return (top.m, top.R, l, top.I1, top.I3, top.mu, top.g, law.mu_r, law.omega_eps)


def _normal_force(y: Any, p: tuple) -> Any:
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        return wrench(np.asarray(y, dtype=float), p)[1]


def _derive(Y: np.ndarray, p: tuple) -> dict[str, np.ndarray]:
    Y = np.asarray(Y, dtype=float)
    out = gliding.MODEL.derive(to_gliding(Y, p), _gliding(p))
    out["gn"] = _normal_force(Y, p)
    return out


def _scales(y0: np.ndarray, p: tuple) -> np.ndarray:
    sc = np.array(gliding.MODEL.scales(to_gliding(y0, p), _gliding(p)), dtype=float)
    sc[6] *= p[ix.R]  # λ = −L·a: the momentum scale times R
    return sc


def _finish(traj: Any) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """``Model.finish``: the contact force per sample, as every law reports it: ``F_x``, ``F_y``
    (N, lab frame) and ``M_n`` = 0 (N m); the couple is :meth:`RollingResistance.torque` of the
    run's ω_h."""
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        F = wrench(np.asarray(traj.states, dtype=float), traj.params)[2]
    return {"F_x": F[0], "F_y": F[1], "M_n": np.zeros_like(F[0])}, {}


MODEL = register(
    Model(
        name="rolling-resistance",
        summary="gliding tippe top with viscous sliding and a rolling-resistance couple "
        "−μ_r g_n ω_h/|ω_h| (regularised; Johnson 1985, ch. 9)",
        rhs=rolling_resistance_rhs,
        rhs_into=_rhs_into,
        normal_force=_normal_force,
        params=_params,
        initial=lambda state, p: from_gliding(gliding.MODEL.initial(state, _gliding(p)), p),
        derive=_derive,
        theta=gliding.MODEL.theta,
        scales=_scales,
        conserved_lengths=((7, 8, 9),),
        events=(Event(_contact, -1.0, "contact_lost"),),
        options=(Option("friction", friction_law, None, "the rolling-resistance law"),),
        friction=(RollingResistance,),
        finish=_finish,
    )
)
"""Viscous sliding with rolling resistance (``friction=RollingResistance(mu_r)``)."""
