"""The result object of :func:`mett.predict_inversion`."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class Validity:
    """Small parameters of the reduction and whether the case lies where it was verified.

    Attributes
    ----------
    epsilon : float
        Nutation period at the start over the predicted time to pass π/2,
        ε = T_n/t_half with T_n = 2π I1/(I3 |ω3(0)|) (the gliding nutation period, docs/theory/estimates.md#gliding-periods);
        the reduction is an expansion in ε. ``nan`` when the top does not reach π/2.
    spin_ratio : float
        λ/λ_thres: how far above the inversion threshold the top is.
    outside_verified_range : bool
        True when the case lies outside the parameter box of the verification table
        (docs/theory/inversion.md#verification): another law than the viscous one, θ0 or
        λ/λ_thres outside the table's ranges, ε above its largest verified value, a viscous
        law whose coefficient μ|v_A| on the balance path exceeds 1 before π/2 (a friction no
        real contact has, which lifts the top off: docs/theory/flight.md), or a lift-off
        predicted before π/2 (``InversionPrediction.t_lift``: the reductions assume a top on the
        table, and a hopping top inverts later).
    notes : tuple of str
        Why the flag is set, one phrase per reason.
    """

    epsilon: float
    spin_ratio: float
    outside_verified_range: bool
    notes: tuple[str, ...] = ()


@dataclass(frozen=True)
class InversionPrediction:
    """Prediction of whether and when a tippe top inverts, from the slow (nutation-free) flow.

    Attributes
    ----------
    inverts : bool or None
        True if the top ends in the inverted spin; False if it stays upright, hangs at a
        tumbling angle, or its contact sticks; None if the reduction cannot tell (see ``reason``).
    reason : str
        One sentence: "inverts", "below threshold ...", "contact sticks: rolling from t = ... s",
        "hangs at theta_t = ...", or why no prediction is made.
    method : str
        The reduction used.
    t_start : float
        Initiation time (s): when the growing inversion mode reaches the initial inclination θ0,
        i.e. ln(θ0/θ_u(0))/σ from the linear instability of the upright spin (0 if it starts above).
    t_half : float
        Time (s) at which the mean inclination θ̄ passes π/2; ``math.inf`` if it never does.
    t_inv : float
        Time (s) at which θ̄ comes within ``tol`` of its end state; ``math.inf`` if never.
    tol : float
        That tolerance (rad).
    t, theta, D, E_mod : ndarray
        The slow path: times (s), mean inclination θ̄ (rad), Routh integral D̄ (kg m² s⁻¹) and
        modified energy Ẽ̄ (J): those of the gyroscopic-balance state along it (method
        "gyroscopic"), or the band averages of D, Ẽ and θ over the gliding top's nutation band
        along the averaged flow (method "averaged").
    lam : ndarray
        Jellett's integral along the path (kg m³ s⁻¹): constant except for the Contensou law.
    theta_end : float
        The end inclination of the slow flow (rad).
    validity : Validity
        Small parameters and the verified-range flag.
    t_lift : float
        First time (s) at which the nutation is predicted to lift the top off the table before θ̄
        passes π/2, ``math.inf`` if it is not (method "gyroscopic" with the viscous or
        regularised Coulomb law), ``nan`` where the criterion is not evaluated (the other laws
        and methods). The criterion (docs/theory/inversion.md#verification): the nutation, a
        linear mode about the balance state of amplitude Z in cos θ and rate λ_n, takes the
        normal force g_n = m (g − l d²cos θ/dt²) to zero where l |λ_n|² Z ≥ g (l = Rα); Z from
        the initiation's mode split, carried along the path by the mode's own growth rate and
        its adiabatic invariant. Where ``t_lift < t_half`` the prediction is flagged: the
        reductions assume a top on the table, and a hopping top inverts later. Method
        "averaged": the first time the normal force vanishes somewhere in the flow's own
        nutation band (its path stops there; ``math.inf`` if never).
    """

    inverts: bool | None
    reason: str
    method: str
    t_start: float
    t_half: float
    t_inv: float
    tol: float
    t: np.ndarray = field(repr=False)
    theta: np.ndarray = field(repr=False)
    D: np.ndarray = field(repr=False)
    E_mod: np.ndarray = field(repr=False)
    lam: np.ndarray = field(repr=False)
    theta_end: float
    validity: Validity
    t_lift: float = math.nan

    def theta_at(self, t: float | np.ndarray) -> np.ndarray:
        """Mean inclination θ̄(t) (rad), interpolated on the slow path (held at its ends)."""
        return np.interp(t, self.t, self.theta)
