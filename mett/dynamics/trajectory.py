"""The result of :func:`mett.simulate`: sampled series, dense output and a status.

A :class:`Trajectory` never raises for numerical trouble: a run that loses contact (g_n reaches 0)
ends with ``status == "contact_lost"``, an integrator failure with ``status == "failed"``, and the
``message`` says when and why (design.md: results as objects with a status, as in diffrax/scipy).
All series are computed once, vectorised, from the model's state after the run.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np
from numpy.typing import ArrayLike
from scipy import optimize

from .. import _validate
from ..state import State

if TYPE_CHECKING:
    from ..top import TippeTop
    from ._model import Model

__all__ = ["SERIES", "STATUSES", "DenseSolution", "Trajectory"]

STATUSES = ("completed", "contact_lost", "failed")

SERIES = (
    "theta",
    "thetadot",
    "phidot",
    "psidot",
    "omega3",
    "nu_x",
    "nu_y",
    "gn",
    "x",
    "y",
    "phi",
    "E",
    "E_mod",
    "D",
    "lam",
)
"""Names of the sampled series of a :class:`Trajectory` (besides ``t``)."""

# Sub-steps per solver step when bracketing crossings on the dense output: a crossing pair inside
# one step (a shallow extremum) is still found unless it lies within a quarter step.
_CROSSING_SUBDIVISION = 4


class DenseSolution(Protocol):
    """What a :class:`Trajectory` needs of the integrator's continuous solution.

    Both backends provide one: scipy's ``OdeSolution`` and the compiled integrator's
    :class:`mett.dynamics.dop853.DenseOutput` (and ``_Constant`` for a run that never left t = 0).
    """

    ts: np.ndarray
    """Breakpoints of the piecewise interpolant (the solver's steps), increasing."""

    def __call__(self, t: Any) -> np.ndarray:
        """State(s) at ``t``: shape (n,) for a scalar time, (n, k) for k times."""
        ...


class _Constant:
    """Dense output of a run that never left its start (contact lost or failure at t0)."""

    def __init__(self, t0: float, y0: np.ndarray) -> None:
        self.ts = np.array([t0])
        self.t_min = self.t_max = t0
        self._y0 = y0

    def __call__(self, t: Any) -> np.ndarray:
        t = np.asarray(t, dtype=float)
        if t.ndim == 0:
            return self._y0.copy()
        return np.repeat(self._y0[:, None], t.size, axis=1)


class Trajectory:
    """A simulated motion of the tippe top (or of a reduced model).

    Attributes
    ----------
    t : ndarray
        Sample times (s): the solver's steps, or ``t_eval`` if given; the last sample is where the run
        ended (``t_end``, the contact-loss time, or the failure time).
    theta, thetadot, phidot, psidot, omega3 : ndarray
        θ (rad, in [0, π]), θ̇, φ̇, ψ̇ = ω3 − φ̇ cos θ, ω3 (rad/s).
    nu_x, nu_y : ndarray
        Gliding velocity of the contact point on x̂, ŷ (m/s); zero for the rolling model.
    gn : ndarray
        Normal force (N).
    x, y : ndarray
        Horizontal position of the centre of mass (m); it starts at the origin, with φ(0) = 0.
    phi : ndarray
        Precession angle of the axis, in (−π, π] (rad).
    E, E_mod, D, lam : ndarray
        Energy E, modified energy Ẽ (the energy of the METT while gliding, theory.md §3), Routh D
        and Jellett λ along the run, from the normalised axis (design.md).
    status : str
        ``"completed"``, ``"contact_lost"`` or ``"failed"``.
    message : str
        What happened, with the time.
    t_contact_lost : float or None
        Time at which g_n reached 0 (status ``"contact_lost"``).
    t_events : list of ndarray
        Times of the user ``events`` passed to :func:`~mett.simulate` (empty list if none).
    model : str
        Name of the model; ``top`` and ``params`` hold its parameters.
    states : ndarray
        The model's own state vectors at ``t``, shape (n_state, len(t)).
    nfev : int
        Right-hand-side evaluations.
    backend : str
        ``"compiled"`` or ``"scipy"``: which integrator ran (see :func:`~mett.simulate`).
    phase : ndarray of str
        Contact phase per sample: ``"sliding"`` or ``"rolling"`` (the ``"rolling"`` model rolls
        throughout, the other models glide; a Coulomb run switches, :mod:`mett.dynamics.stickslip`).
    extra : tuple of str
        Names of further per-sample series set by the run (e.g. ``phase``, ``F_x``, ``F_y`` of a
        dry-friction run).

    Notes
    -----
    Near θ = 0 and π the Euler-angle series φ, φ̇, ψ̇ and the split of ν into (ν_x, ν_y) are
    ill-conditioned (they are coordinates of a polar singularity); θ, ω3, |ν|, E, Ẽ, D, λ are not.
    At exactly sin θ = 0, φ = 0 and φ̇ = 0 are used (see :func:`mett.dynamics._model.euler_from_vectors`).
    """

    t: np.ndarray
    theta: np.ndarray
    thetadot: np.ndarray
    phidot: np.ndarray
    psidot: np.ndarray
    omega3: np.ndarray
    nu_x: np.ndarray
    nu_y: np.ndarray
    gn: np.ndarray
    x: np.ndarray
    y: np.ndarray
    phi: np.ndarray
    E: np.ndarray
    E_mod: np.ndarray
    D: np.ndarray
    lam: np.ndarray

    def __init__(
        self,
        *,
        t: np.ndarray,
        states: np.ndarray,
        model: Model,
        top: TippeTop,
        params: tuple,
        solution: DenseSolution,
        status: str,
        message: str,
        t_contact_lost: float | None = None,
        t_events: list[np.ndarray] | None = None,
        nfev: int = 0,
        backend: str = "scipy",
        extra: dict[str, np.ndarray] | None = None,
    ) -> None:
        if status not in STATUSES:
            raise ValueError(f"status must be one of {STATUSES}; got {status!r}")
        self.t = np.asarray(t, dtype=float)
        self.states = np.asarray(states, dtype=float).reshape(-1, self.t.size)
        self.model = model.name
        self.top = top
        self.params = params
        self.status = status
        self.message = message
        self.t_contact_lost = t_contact_lost
        self.t_events = [] if t_events is None else list(t_events)
        self.nfev = int(nfev)
        self.backend = backend
        self._model = model
        self._sol = solution
        series = model.derive(self.states, params)
        for name in SERIES:
            setattr(self, name, np.asarray(series[name], dtype=float).reshape(self.t.shape))
        # per-sample series of the contact that the states alone do not fix (e.g. the phase of a
        # stick–slip run, mett.dynamics.stickslip); they replace derived ones of the same name
        self.extra = tuple(extra or ())
        self.phase = np.full(self.t.shape, "rolling" if model.name == "rolling" else "sliding")
        for name, values in (extra or {}).items():
            setattr(self, name, np.asarray(values).reshape(self.t.shape))

    # --- summary -----------------------------------------------------------------------------
    def __len__(self) -> int:
        return self.t.size

    def __repr__(self) -> str:
        return (
            f"Trajectory(model={self.model!r}, status={self.status!r}, "
            f"t=[{self.t[0]:g}, {self.t[-1]:g}] s, {self.t.size} samples)"
        )

    @property
    def t_final(self) -> float:
        """Time at which the run ended (s)."""
        return float(self.t[-1])

    def as_dict(self) -> dict[str, np.ndarray]:
        """``{"t": ..., "theta": ..., ...}``: every sampled series (e.g. for ``pandas.DataFrame``)."""
        return {"t": self.t, **{name: getattr(self, name) for name in SERIES}}

    # --- dense output ------------------------------------------------------------------------
    def _check_times(self, t: ArrayLike) -> np.ndarray:
        t = _validate.as_finite_array("t", t)
        lo, hi = float(self.t[0]), float(self.t[-1])
        slack = 4 * np.finfo(float).eps * max(abs(lo), abs(hi), 1.0)
        if np.any((t < lo - slack) | (t > hi + slack)):
            bad = t[(t < lo - slack) | (t > hi + slack)].ravel()[0]
            raise ValueError(f"t must lie in the simulated interval [{lo!r}, {hi!r}]; got {bad!r}")
        return np.clip(t, lo, hi)

    def states_at(self, t: ArrayLike) -> np.ndarray:
        """The model's state vector(s) at time(s) ``t`` from the dense output, shape (n_state, ...)."""
        t = self._check_times(t)
        Y = np.asarray(self._sol(t.ravel()), dtype=float).reshape(-1, t.size)
        return Y.reshape((-1, *t.shape))

    def at(self, t: ArrayLike) -> State:
        """The reduced :class:`~mett.State` at time(s) ``t`` from the dense output.

        Parameters
        ----------
        t : float or array_like
            Time(s) inside ``[t[0], t[-1]]``.

        Returns
        -------
        State
            Scalar fields for scalar ``t``, arrays of the shape of ``t`` otherwise.

        Raises
        ------
        ValueError
            If a time lies outside the simulated interval or is not finite.
        """
        t = self._check_times(t)
        Y = np.asarray(self._sol(t.ravel()), dtype=float).reshape(-1, t.size)
        s = self._model.derive(Y, self.params)
        fields = {
            k: np.asarray(s[k], dtype=float).reshape(t.shape)
            for k in ("theta", "thetadot", "phidot", "omega3", "nu_x", "nu_y")
        }
        # atan2 gives θ in [0, π]; clip only guards the last ulp.
        fields["theta"] = np.clip(fields["theta"], 0.0, np.pi)
        return State(**fields)

    def theta_at(self, t: ArrayLike) -> np.ndarray:
        """θ(t) from the dense output (cheaper than :meth:`at`)."""
        t = self._check_times(t)
        Y = np.asarray(self._sol(t.ravel()), dtype=float).reshape(-1, t.size)
        return np.asarray(self._model.theta(Y, self.params), dtype=float).reshape(t.shape)

    def crossings(self, theta_value: float, direction: int = 0) -> np.ndarray:
        """Times at which θ(t) crosses ``theta_value``, root-found on the dense output.

        Parameters
        ----------
        theta_value : float
            Level in [0, π] (rad).
        direction : {0, 1, -1}, default 0
            0: all crossings; 1: θ increasing through the level; −1: decreasing.

        Returns
        -------
        ndarray
            Increasing crossing times (s); empty if there are none.

        Notes
        -----
        θ − θ_value is bracketed on the solver's steps, each cut into
        ``_CROSSING_SUBDIVISION`` pieces, and each sign change is refined by Brent's method on the
        interpolant to ~1e-14 s. A tangency without a sign change is not a crossing.
        """
        level = _validate.finite_scalar("theta_value", theta_value)
        if not 0.0 <= level <= math.pi:
            raise ValueError(f"theta_value must lie in [0, pi]; got {level!r}")
        if direction not in (0, 1, -1):
            raise ValueError(f"direction must be 0, 1 or -1; got {direction!r}")
        ts = np.asarray(self._sol.ts, dtype=float)
        if ts.size < 2:
            return np.empty(0)
        frac = np.arange(_CROSSING_SUBDIVISION) / _CROSSING_SUBDIVISION
        grid = np.append((ts[:-1, None] + np.diff(ts)[:, None] * frac).ravel(), ts[-1])
        grid = grid[grid <= self.t[-1]]
        if grid[-1] < self.t[-1]:
            grid = np.append(grid, self.t[-1])
        h = np.asarray(self._model.theta(self._sol(grid), self.params), dtype=float) - level

        def fn(tt: float) -> float:
            y = np.asarray(self._sol(tt), dtype=float).reshape(-1, 1)
            return float(self._model.theta(y, self.params)[0]) - level

        out = []
        for i in np.flatnonzero(h[:-1] * h[1:] < 0.0):
            rising = h[i] < 0.0
            if direction and (direction > 0) != rising:
                continue
            out.append(
                optimize.brentq(fn, grid[i], grid[i + 1], xtol=1e-14, rtol=4 * np.finfo(float).eps)
            )
        # exact hits on the grid: count them when the sign changes across them
        for i in np.flatnonzero(h[1:-1] == 0.0) + 1:
            before, after = h[i - 1], h[i + 1]
            if before * after < 0.0 and (not direction or (direction > 0) == (before < 0.0)):
                out.append(float(grid[i]))
        return np.array(sorted(out))
