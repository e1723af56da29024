"""The result of :func:`mett.simulate`: sampled series, dense output and a status.

A :class:`Trajectory` never raises for numerical trouble: a run that loses contact (g_n reaches 0)
ends with ``status == "contact_lost"``, an integrator failure with ``status == "failed"``
(:class:`~mett.dynamics._status.Status`), and the ``message`` says when and why (results as
objects with a status, as in diffrax/scipy). All series are computed once, vectorised, from the
model's state after the run.

A Trajectory is made once, complete: what a model adds beyond its states (the phase and contact
of each sample, the friction force, a hybrid run's switches, ...) is returned by the model's
``finish`` hook (:class:`~mett.dynamics.registry.Model`) as two mappings, per-sample
:attr:`Trajectory.extras` and whole-run :attr:`Trajectory.records`, and read as attributes
(``traj.F_x``, ``traj.switches``). The container knows no model's names.

:meth:`Trajectory.save` / :meth:`Trajectory.load` keep a run in a versioned ``.npz`` file
(:mod:`mett.dynamics._format`); the dense outputs are those of :mod:`mett.dynamics.dense`.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike
from scipy import optimize

from .. import _validate
from ..state import State
from . import _format
from ._series import SERIES
from ._status import SUCCESSFUL, Status
from .dense import ConstantSolution, DenseSolution, HermiteSolution, SegmentedSolution

if TYPE_CHECKING:
    import pandas as pd

    from ..top import TippeTop
    from ._model import Model

__all__ = [
    "FORMAT_VERSION",
    "SERIES",
    "STATUSES",
    "ConstantSolution",
    "DenseSolution",
    "HermiteSolution",
    "SegmentedSolution",
    "Status",
    "Trajectory",
]

STATUSES = tuple(s.value for s in Status)
"""The values of :class:`~mett.dynamics._status.Status`: "completed", "contact_lost", "failed"."""


FORMAT_VERSION = _format.FORMAT_VERSION
"""Version of the file layout written by :meth:`Trajectory.save` (:mod:`mett.dynamics._format`);
:meth:`Trajectory.load` reads this and every older version and refuses newer ones."""

_STATE_FIELDS = ("theta", "thetadot", "phidot", "omega3", "nu_x", "nu_y")

# Sub-steps per solver step when bracketing crossings on the dense output: a crossing pair inside
# one step (a shallow extremum) is still found unless it lies within a quarter step.
_CROSSING_SUBDIVISION = 4

# Gauss–Legendre nodes per solver step for ψ = ∫ψ̇ dt: exact for polynomials of degree 15, the
# DOP853 interpolant is of degree 7 in t (ψ̇ a smooth function of it), Taylor's of the order.
_PSI_NODES = 8


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
    psi : ndarray
        Spin angle ψ (rad, unwrapped, ψ(t[0]) = 0): with φ and θ the Euler angles (z-x-z) of the
        body, so its orientation can be rebuilt (:attr:`psi`).
    E, E_mod, D, lam : ndarray
        Energy E, modified energy Ẽ (the energy of the METT while gliding, docs/theory/equations.md#integrals), Routh D
        and Jellett λ along the run, from the normalised axis.
    status : Status
        ``"completed"``, ``"contact_lost"`` or ``"failed"`` (a ``str``; :attr:`success`).
    message : str
        What happened, with the time.
    t_contact_lost : float or None
        Time at which g_n reached 0 (status ``"contact_lost"``).
    t_events : list of ndarray
        Times of the user ``events`` passed to :func:`~mett.simulate` (empty list if none).
    model : str
        Name of the model; ``top``, ``options`` and ``params`` hold its parameters.
    top : TippeTop
        The simulated top.
    options : dict
        The model's options as passed to :func:`~mett.simulate` (e.g. ``{"l": 0.006}`` for
        ``"gliding-hst"``); empty when there are none.
    params : tuple
        The parameter tuple of the model's right-hand side (from ``top`` and ``options``).
    initial_state : State
        The state the run started from.
    states : ndarray
        The model's own state vectors at ``t``, shape (n_state, len(t)).
    nfev : int
        Right-hand-side evaluations.
    backend : str
        ``"compiled"``, ``"taylor"`` or ``"scipy"``: which integrator ran (see :func:`~mett.simulate`).
    rtol : float or None
        Relative tolerance of the run (None: loaded from a file of format version < 3).
    atol : ndarray or None
        Absolute tolerance of each component of the model state (the unit of the component;
        by default ``rtol`` × its scale); None as ``rtol``.
    t_end : float or None
        The requested end time (s); the run may have ended earlier (:attr:`t_final`). None as
        ``rtol``.
    extras : dict of str to ndarray
        Per-sample series the model sets beyond the :data:`SERIES`, each also an attribute:
        ``phase`` always (``"sliding"`` or ``"rolling"``: the ``"rolling"`` model rolls
        throughout, the other models glide; a Coulomb run switches,
        :mod:`mett.dynamics.stickslip`), and e.g. ``F_x``, ``F_y``, ``M_n``, ``margin`` (the
        contact force of a dry-friction or viscous-law run, N, N m) or ``contact`` (``"ball"`` /
        ``"stem"`` of a stemmed top). A model's series named as one of the :data:`SERIES`
        replaces the derived one instead (e.g. g_n of a rolling phase).
    records : dict
        Whole-run results the model sets, each also an attribute: e.g. ``switches`` (the phase
        switches of a hybrid run: ``(t, before, after)`` or
        :class:`~mett.dynamics.stickslip.Switch` records), ``jumps`` (the model states before
        and after each switch), ``touchdowns`` (the times the stem touched down, s),
        ``stopping_band`` (m/s).
    extra : tuple of str
        The names of :attr:`extras`.

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
        initial_state: State | None = None,
        options: Mapping[str, Any] | None = None,
        extras: Mapping[str, ArrayLike] | None = None,
        records: Mapping[str, Any] | None = None,
        rtol: float | None = None,
        atol: ArrayLike | None = None,
        t_end: float | None = None,
        series: Mapping[str, np.ndarray] | None = None,
        finish: bool = True,
    ) -> None:
        if status not in STATUSES:
            raise ValueError(f"status must be one of {STATUSES}; got {status!r}")
        self.t = np.asarray(t, dtype=float)
        self.states = np.asarray(states, dtype=float).reshape(-1, self.t.size)
        self.model = model.name
        self.top = top
        self.params = params
        self.options = dict(options or {})
        self.status = Status(status)
        self.message = message
        self.t_contact_lost = t_contact_lost
        self.t_events = [] if t_events is None else list(t_events)
        self.nfev = int(nfev)
        self.backend = backend
        self.rtol = None if rtol is None else float(rtol)
        self.atol = None if atol is None else np.array(atol, dtype=float).reshape(-1)
        self.t_end = None if t_end is None else float(t_end)
        self._model = model
        self._sol = solution
        # the series (θ, E, D, λ, ...) are derived from the states on first access (__getattr__):
        # a run whose caller reads only a few of them, or none, does not pay for all of them;
        # ``series`` (a loaded file's) are kept as given
        for key, values in (series or {}).items():
            self.__dict__[key] = values
        if initial_state is None:
            # not given (a Trajectory built outside simulate): the start of the dense output
            t0 = float(np.asarray(solution.ts, dtype=float)[0])
            initial_state = self._state(np.asarray(solution(t0), dtype=float).reshape(-1, 1), ())
        self.initial_state = initial_state
        default = "rolling" if model.name == "rolling" else "sliding"
        self.extras: dict[str, np.ndarray] = {"phase": np.full(self.t.shape, default)}
        self.records: dict[str, Any] = {}
        self._add(extras, records)
        if finish and model.finish is not None:
            # the model's own series and records, from the run as it stands (its phases, ...)
            self._add(*model.finish(self))

    def _add(
        self, extras: Mapping[str, ArrayLike] | None, records: Mapping[str, Any] | None
    ) -> None:
        for name, values in (extras or {}).items():
            if name in SERIES:  # the model's own value replaces the derived one (e.g. g_n)
                self.__dict__[name] = np.asarray(values, dtype=float).reshape(self.t.shape)
                continue
            if name in type(self).__dict__ or name in self.__dict__:
                raise ValueError(f"extra series {name!r} would hide an attribute of Trajectory")
            self.extras[name] = np.asarray(values).reshape(self.t.shape)
        for name, value in (records or {}).items():
            if name in SERIES or name in type(self).__dict__ or name in self.__dict__:
                raise ValueError(f"record {name!r} would hide an attribute of Trajectory")
            self.records[name] = value

    def with_extras(self, extras: Mapping[str, ArrayLike]) -> Trajectory:
        """A copy with further per-sample series (the arrays and dense output shared).

        Parameters
        ----------
        extras : mapping of str to array_like
            Series of one value per sample, by name (not one of :data:`SERIES` or another
            attribute).

        Returns
        -------
        Trajectory
            This run with :attr:`extras` updated.
        """
        new = object.__new__(type(self))
        new.__dict__.update(self.__dict__)
        new.extras, new.records = dict(self.extras), dict(self.records)
        new._add(extras, None)
        return new

    def __getattr__(self, name: str) -> Any:
        # called only for attributes not set: the model's extras and records, and the derived
        # series, computed once, all together
        d = self.__dict__
        if name in d.get("extras", ()):
            return d["extras"][name]
        if name in d.get("records", ()):
            return d["records"][name]
        if name in SERIES and "_model" in d:
            series = self._model.derive(self.states, self.params)
            for key in SERIES:
                if key not in d:
                    d[key] = np.asarray(series[key], dtype=float).reshape(self.t.shape)
            return d[name]
        raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")

    @property
    def extra(self) -> tuple[str, ...]:
        """The names of :attr:`extras` (per-sample series the model sets)."""
        return tuple(self.extras)

    @property
    def success(self) -> bool:
        """True if the run completed: it reached ``t_end`` or stopped at a terminal user event
        (status ``"completed"``). A run that lost contact (``"contact_lost"``) or failed is not
        a success (:data:`~mett.dynamics._status.SUCCESSFUL`)."""
        return self.status in SUCCESSFUL

    @property
    def psi(self) -> np.ndarray:
        """Spin angle ψ at the samples (rad), unwrapped, with ψ(t[0]) = 0.

        No model integrates ψ (the equations do not depend on it): it is ψ(t) = ∫ψ̇ dt along
        the dense output, with ψ̇ = ω3 − φ̇ cos θ, by Gauss–Legendre quadrature of
        ``_PSI_NODES`` = 8 nodes on every solver step and every piece between samples. The
        quadrature error is far below the interpolant's (8 nodes integrate degree 15 exactly),
        so ψ is as accurate as the dense output: the run's global error in ψ̇ times the time
        span. ψ̇ is singular at θ = 0 and π (the Euler angles' poles; φ + ψ stays regular
        there), so ψ loses accuracy where the axis passes very near a pole. A loaded file keeps
        the saved ψ (format 3); for older files it is computed so from their dense output.
        """
        if "psi" not in self.__dict__:
            self.__dict__["psi"] = self._psi()
        return self.__dict__["psi"]

    def _psi(self) -> np.ndarray:
        t = self.t
        if t.size < 2:
            return np.zeros(t.shape)
        ts = np.asarray(self._sol.ts, dtype=float)
        # the solver's steps and the samples: each piece lies inside one step of one phase
        grid = np.union1d(ts[(ts > t[0]) & (ts < t[-1])], t)
        x, w = np.polynomial.legendre.leggauss(_PSI_NODES)
        a, h = grid[:-1], np.diff(grid)
        nodes = (a[:, None] + 0.5 * h[:, None] * (x + 1.0)).ravel()
        psidot = self._model.derive(self._dense(nodes), self.params)["psidot"]
        pieces = 0.5 * h * (np.asarray(psidot, dtype=float).reshape(-1, _PSI_NODES) @ w)
        psi = np.concatenate([[0.0], np.cumsum(pieces)])
        return psi[np.searchsorted(grid, t)]

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

    def to_dataframe(self) -> pd.DataFrame:
        """The sampled series as a :class:`pandas.DataFrame`, one row per sample.

        Returns
        -------
        pandas.DataFrame
            Columns ``t`` (s) and the :data:`SERIES` in the units of the attributes (rad, rad/s,
            m/s, N, m, J, kg m²/s, kg m³/s); ``DataFrame.attrs`` holds ``model``, ``status`` and
            ``message``. The columns are copies: editing them leaves the trajectory unchanged.
        """
        import pandas as pd

        df = pd.DataFrame({k: np.array(v, copy=True) for k, v in self.as_dict().items()})
        df.attrs.update(model=self.model, status=self.status, message=self.message)
        return df

    def to_xarray(self) -> Any:
        """The sampled series as an :class:`xarray.Dataset` (optional extra ``mett[xarray]``).

        Returns
        -------
        xarray.Dataset
            Coordinate ``t`` (s); every series of :data:`SERIES` (and the per-sample labels and
            forces a run sets, ``t_events_<k>`` per user event) a variable with ``units`` (SI) and
            ``long_name``; attributes: ``mett_version``, ``model``, ``backend``, ``status``,
            ``message``, ``friction`` (with ``friction_law`` and its fields), ``rtol``, ``atol``,
            ``t_end`` where the run records them, the top's fields ``top_<name>`` and the initial
            state ``initial_<name>``, each with a ``<name>_units`` attribute.
        """
        from ._export import trajectory_to_xarray

        return trajectory_to_xarray(self)

    def to_netcdf(self, path: str | os.PathLike) -> Path:
        """Write :meth:`to_xarray` to a NetCDF file (netCDF-3, scipy's writer), for
        :func:`mett.load`.

        The samples round-trip bit for bit with their units and the run's provenance; the dense
        output does not (use :meth:`save` for it). ``path`` must end in ``.nc``, in an existing
        directory (``ValueError`` otherwise, before anything is written).
        """
        from ._export import check_nc_path, to_netcdf

        check_nc_path(path)
        return to_netcdf(self.to_xarray(), path)

    # --- dense output ------------------------------------------------------------------------
    def _check_times(self, t: ArrayLike) -> np.ndarray:
        t = _validate.as_finite_array("t", t)
        lo, hi = float(self.t[0]), float(self.t[-1])
        slack = 4 * np.finfo(float).eps * max(abs(lo), abs(hi), 1.0)
        if np.any((t < lo - slack) | (t > hi + slack)):
            bad = t[(t < lo - slack) | (t > hi + slack)].ravel()[0]
            raise ValueError(f"t must lie in the simulated interval [{lo!r}, {hi!r}]; got {bad!r}")
        return np.clip(t, lo, hi)

    def _dense(self, t: np.ndarray) -> np.ndarray:
        """Model states at the (checked) times ``t``, shape (n_state, t.size); empty in, empty out."""
        if t.size == 0:
            return np.empty((self.states.shape[0], 0))
        return np.asarray(self._sol(t.ravel()), dtype=float).reshape(-1, t.size)

    def states_at(self, t: ArrayLike) -> np.ndarray:
        """The model's state vector(s) at time(s) ``t`` from the dense output, shape (n_state, ...)."""
        t = self._check_times(t)
        return self._dense(t).reshape((self.states.shape[0], *t.shape))

    def at(self, t: ArrayLike) -> State:
        """The reduced :class:`~mett.State` at time(s) ``t`` from the dense output.

        Parameters
        ----------
        t : float or array_like
            Time(s) inside ``[t[0], t[-1]]``.

        Returns
        -------
        State
            Scalar fields for scalar ``t``, arrays of the shape of ``t`` otherwise (an empty ``t``
            gives empty fields, as numpy's functions do).

        Raises
        ------
        ValueError
            If a time lies outside the simulated interval or is not finite.
        """
        t = self._check_times(t)
        return self._state(self._dense(t), t.shape)

    def _state(self, Y: np.ndarray, shape: tuple[int, ...]) -> State:
        """The State of model states ``Y`` (n_state, k), with fields of ``shape``."""
        if Y.shape[1] == 0:
            return State(**{k: np.empty(shape) for k in _STATE_FIELDS})
        s = self._model.derive(Y, self.params)
        fields = {k: np.asarray(s[k], dtype=float).reshape(shape) for k in _STATE_FIELDS}
        # atan2 gives θ in [0, π]; clip only guards the last ulp.
        fields["theta"] = np.clip(fields["theta"], 0.0, np.pi)
        return State(**fields)

    def theta_at(self, t: ArrayLike) -> np.ndarray:
        """θ(t) from the dense output (cheaper than :meth:`at`)."""
        t = self._check_times(t)
        if t.size == 0:
            return np.empty(t.shape)
        Y = self._dense(t)
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

    # --- files -------------------------------------------------------------------------------
    def save(self, path: str | os.PathLike) -> Path:
        """Write the trajectory to a ``.npz`` file that :meth:`load` reads back exactly.

        Parameters
        ----------
        path : str or path-like
            Target file; must end in ``.npz`` and its directory must exist and be writable. An
            existing file is replaced atomically (the new file is written next to it and renamed),
            so a failed save never leaves a damaged file behind; it keeps its permission bits. A
            symbolic link is followed: the file it points to is replaced, the link stays.

        Returns
        -------
        pathlib.Path
            The path written (as given, not the link's target).

        Raises
        ------
        ValueError
            If the path does not end in ``.npz``, is a directory, its directory does not exist or
            is not writable, or the file exists and is not writable (checked before anything is
            written).
        TypeError
            If a model option is not a plain value (number, string, bool, None, list, dict or a
            friction law of :mod:`mett.friction`), so that it cannot be stored as JSON.

        Notes
        -----
        The layout (format version :data:`FORMAT_VERSION`) is described in
        :mod:`mett.dynamics._format`: numpy's ``.npz`` (readable without mett and without
        pickle) with a JSON metadata entry. The dense output of a DOP853 run (either backend, the
        default) is stored as the solver's own per-step interpolant coefficients, so :meth:`at`
        and :meth:`crossings` of the loaded trajectory equal the original's bit for bit; a run
        of the Taylor backend is stored as its steps' Taylor polynomials, with the same effect.
        Other scipy methods (RK45, Radau, …) are stored as their step states and right-hand-side
        values, and the loaded trajectory interpolates between the steps with cubic Hermite
        polynomials: equal at the steps (to rounding), and between them within the
        interpolation error O(h⁴) of the step size h (at most 7e-8 rad in θ for the thesis run
        with RK45 at rtol = 1e-10).

        The file is first written to a temporary file ``.mett-<random>.tmp`` in the same directory
        (a short name, so any legal target name works), flushed to disk and renamed over the
        target; on any error the temporary file is removed. Only a process killed outright
        (SIGKILL, power loss) during a save can leave such a ``.tmp`` file behind, never a
        damaged target; it is safe to delete once no save is running.
        """
        return _format.save(self, path, SERIES)

    @classmethod
    def load(cls, path: str | os.PathLike) -> Trajectory:
        """Read a trajectory written by :meth:`save`.

        The file may come from anywhere: it is checked in full before anything is built from it,
        it never names code to run, and a damaged or crafted file is a ``ValueError``
        (docs/reliability.md#saved-files).

        Parameters
        ----------
        path : str or path-like
            A ``.npz`` file written by :meth:`save` (of this or an older format version).

        Returns
        -------
        Trajectory
            Arrays bit-identical to the saved ones; ``top``, ``initial_state``, ``model``,
            ``options``, ``status``, ``message``, :attr:`extras` and :attr:`records` equal;
            :meth:`at`, :meth:`crossings` work (see :meth:`save` for the accuracy of the dense
            output). A file of format version < 3 has ``rtol``, ``atol`` and ``t_end`` None
            (not recorded then); its ``psi`` is computed from its dense output.

        Raises
        ------
        ValueError
            Naming the file, if it does not exist, is not a mett trajectory, is damaged or
            inconsistent (an array of the wrong shape, type or length, non-finite numbers, times
            out of order, a field of the wrong type, a class that is not one of mett's saved
            types, an entry the format does not define, arrays that would take far more memory
            than the file's size explains), was written by a newer mett (a ``format_version``
            above :data:`FORMAT_VERSION`), or names a model this mett does not know.
        """
        return _format.load(cls, path, SERIES)
