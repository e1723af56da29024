"""The result of :func:`mett.simulate`: sampled series, dense output and a status.

A :class:`Trajectory` never raises for numerical trouble: a run that loses contact (g_n reaches 0)
ends with ``status == "contact_lost"``, an integrator failure with ``status == "failed"``, and the
``message`` says when and why (results as objects with a status, as in diffrax/scipy).
All series are computed once, vectorised, from the model's state after the run.

:meth:`Trajectory.save` / :meth:`Trajectory.load` keep a run in a versioned ``.npz`` file (numpy's
zip of ``.npy`` arrays, readable without mett) with a JSON metadata entry; see :meth:`Trajectory.save`
for the layout.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import reprlib
import secrets
import stat
import typing
import warnings
import zipfile
import zlib
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np
from numpy.typing import ArrayLike
from scipy import optimize

from .. import _validate
from ..state import State

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
    "SegmentedSolution",
    "Trajectory",
]

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

FORMAT_VERSION = 2
"""Version of the file layout written by :meth:`Trajectory.save`; :meth:`Trajectory.load` reads
this and every older version and refuses newer ones. Version 2 added what a run sets beyond its
states (a hybrid run's phases, contact series, switches and touchdowns) and the dense output of
a hybrid run phase by phase."""

_FORMAT_NAME = "mett.Trajectory"
_META_KEY = "mett_trajectory"  # the JSON metadata entry of the .npz

_STATE_FIELDS = ("theta", "thetadot", "phidot", "omega3", "nu_x", "nu_y")

# Sub-steps per solver step when bracketing crossings on the dense output: a crossing pair inside
# one step (a shallow extremum) is still found unless it lies within a quarter step.
_CROSSING_SUBDIVISION = 4


class DenseSolution(Protocol):
    """What a :class:`Trajectory` needs of the integrator's continuous solution.

    Both backends provide one: scipy's ``OdeSolution`` and the compiled integrator's
    :class:`mett.dynamics.dop853.DenseOutput` (and ``ConstantSolution`` for a run that never left t = 0).
    """

    ts: np.ndarray
    """Breakpoints of the piecewise interpolant (the solver's steps), increasing."""

    def __call__(self, t: Any) -> np.ndarray:
        """State(s) at ``t``: shape (n,) for a scalar time, (n, k) for k times."""
        ...


class SegmentedSolution:
    """Dense output of a hybrid run: one solution per phase, switched at their start times.

    Made by :func:`mett.simulate` for a model with several phases (dry friction, the stem), and
    by :meth:`Trajectory.load` for such a run.

    Parameters
    ----------
    sols : list of DenseSolution
        The solution of each phase, in time order (each with ``t_min``, ``t_max``).
    phases : list of str
        The phase of each.
    """

    def __init__(self, sols: list[Any], phases: list[str]) -> None:
        self.sols, self.phases = list(sols), list(phases)
        self._starts = np.array([float(s.t_min) for s in sols])
        self.ts = np.concatenate([np.asarray(s.ts, dtype=float)[:-1] for s in sols[:-1]]
                                 + [np.asarray(sols[-1].ts, dtype=float)])  # fmt: skip
        self.t_min, self.t_max = float(sols[0].t_min), float(sols[-1].t_max)

    def __call__(self, t: Any) -> np.ndarray:
        t = np.asarray(t, dtype=float)
        # at a switch time the later phase (the state after the switch) holds
        k = np.clip(np.searchsorted(self._starts, t, side="right") - 1, 0, len(self.sols) - 1)
        if t.ndim == 0:
            return np.asarray(self.sols[int(k)](t), dtype=float)
        out = np.empty((self.sols[0](self.t_min).size, t.size))
        for j in np.unique(k):
            sel = k == j
            out[:, sel] = np.asarray(self.sols[j](t[sel]), dtype=float).reshape(-1, sel.sum())
        return out


class ConstantSolution:
    """Dense output of a run that never left its start (contact lost or failure at t0).

    The :class:`DenseSolution` of such a run: its state ``y0`` at every time. Made by
    :func:`mett.simulate` and by :meth:`Trajectory.load` for a saved run with one dense time.

    Parameters
    ----------
    t0 : float
        The start time (s), the only time of the run.
    y0 : ndarray, shape (n,)
        The model state there.
    """

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
        Energy E, modified energy Ẽ (the energy of the METT while gliding, docs/theory/equations.md#integrals), Routh D
        and Jellett λ along the run, from the normalised axis.
    status : str
        ``"completed"``, ``"contact_lost"`` or ``"failed"``.
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
        initial_state: State | None = None,
        options: Mapping[str, Any] | None = None,
        extra: dict[str, np.ndarray] | None = None,
    ) -> None:
        if status not in STATUSES:
            raise ValueError(f"status must be one of {STATUSES}; got {status!r}")
        self.t = np.asarray(t, dtype=float)
        self.states = np.asarray(states, dtype=float).reshape(-1, self.t.size)
        self.model = model.name
        self.top = top
        self.params = params
        self.options = dict(options or {})
        self.status = status
        self.message = message
        self.t_contact_lost = t_contact_lost
        self.t_events = [] if t_events is None else list(t_events)
        self.nfev = int(nfev)
        self.backend = backend
        self._model = model
        self._sol = solution
        # the series (θ, E, D, λ, ...) are derived from the states on first access (__getattr__):
        # a run whose caller reads only a few of them, or none, does not pay for all of them
        if initial_state is None:
            # not given (a Trajectory built outside simulate): the start of the dense output
            t0 = float(np.asarray(solution.ts, dtype=float)[0])
            initial_state = self._state(np.asarray(solution(t0), dtype=float).reshape(-1, 1), ())
        self.initial_state = initial_state
        # per-sample series of the contact that the states alone do not fix (e.g. the phase of a
        # stick–slip run, mett.dynamics.stickslip); they replace derived ones of the same name
        self.extra = tuple(extra or ())
        self.phase = np.full(self.t.shape, "rolling" if model.name == "rolling" else "sliding")
        for name, values in (extra or {}).items():
            setattr(self, name, np.asarray(values).reshape(self.t.shape))

    def __getattr__(self, name: str) -> Any:
        # called only for attributes not set: the derived series, computed once, all together
        # (an "extra" series of the same name, set in __init__, is found before and kept)
        if name in SERIES and "_model" in self.__dict__:
            series = self._model.derive(self.states, self.params)
            for key in SERIES:
                if key not in self.__dict__:
                    value = np.asarray(series[key], dtype=float).reshape(self.t.shape)
                    self.__dict__[key] = value
            return self.__dict__[name]
        raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")

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
        The file is numpy's ``.npz`` (a zip of ``.npy`` arrays, ``numpy.load`` reads it without mett
        and without pickle). Arrays: ``t``, ``states`` (the model's state vectors), every series of
        :data:`SERIES`, ``t_events_<k>`` per user event, and the dense output as ``dense_*``. The
        entry ``mett_trajectory`` is a JSON string with ``format`` (``"mett.Trajectory"``),
        ``format_version`` (:data:`FORMAT_VERSION`), ``mett_version``, ``model``, ``options``,
        ``params``, ``top`` (its class and all its fields), ``initial_state``, ``status``, ``message``,
        ``t_contact_lost``, ``nfev``, ``backend`` and ``dense`` (how the dense output is stored).
        What a run sets beyond its states is kept too: the per-sample series ``extra_<name>`` (the
        phase and contact of each sample, the friction force of a dry-friction run), and for a
        hybrid run its ``switches`` (in the JSON), ``jumps_before``/``jumps_after`` and
        ``touchdowns``; its dense output is stored phase by phase.

        The dense output of a DOP853 run (either backend, the default) is stored as the solver's own
        per-step interpolant coefficients, so :meth:`at` and :meth:`crossings` of the loaded
        trajectory equal the original's bit for bit; a run of the Taylor backend is stored as its
        steps' Taylor polynomials, with the same effect. Other scipy methods (RK45, Radau, …) are
        stored as their step states and right-hand-side values, and the loaded trajectory
        interpolates between the steps with cubic Hermite polynomials: equal at the steps (to
        rounding), and between them within the interpolation error O(h⁴) of the step size h
        (at most 7e-8 rad in θ for the thesis run with RK45 at rtol = 1e-10).

        The file is first written to a temporary file ``.mett-<random>.tmp`` in the same directory
        (a short name, so any legal target name works), flushed to disk and renamed over the
        target; on any error the temporary file is removed. Only a process killed outright
        (SIGKILL, power loss) during a save can leave such a ``.tmp`` file behind, never a
        damaged target; it is safe to delete once no save is running.
        """
        given, target = _check_save_path(path)
        meta = {
            "format": _FORMAT_NAME,
            "format_version": FORMAT_VERSION,
            "mett_version": _mett_version(),
            "model": self.model,
            "options": {k: _encode_option(k, v) for k, v in self.options.items()},
            "params": [_encode_param(i, v) for i, v in enumerate(self.params)],
            "top": {"type": _class_name(type(self.top), "top"), **dataclasses.asdict(self.top)},
            "initial_state": (
                None
                if self.initial_state is None
                else {k: float(getattr(self.initial_state, k)) for k in _STATE_FIELDS}
            ),
            "status": self.status,
            "message": self.message,
            "t_contact_lost": None if self.t_contact_lost is None else float(self.t_contact_lost),
            "nfev": self.nfev,
            "backend": self.backend,
            "series": list(SERIES),
            "n_events": len(self.t_events),
        }
        arrays: dict[str, np.ndarray] = {"t": self.t, "states": self.states}
        arrays.update({name: getattr(self, name) for name in SERIES})
        arrays.update({f"t_events_{k}": np.asarray(te) for k, te in enumerate(self.t_events)})
        meta["dense"], dense = _encode_dense(self._sol, self._model, self.params)
        arrays.update({f"dense_{k}": v for k, v in dense.items()})
        # what the run set beyond its states: per-sample contact series (the phase of each
        # sample, the contact of a stemmed top, the friction force, ...), a hybrid run's switches,
        # the states before and after each, and the stem's touchdowns
        per_sample = [n for n in dict.fromkeys(("phase", "contact", *self.extra))
                      if n in self.__dict__ and n not in SERIES]  # fmt: skip
        arrays.update({f"extra_{n}": np.asarray(getattr(self, n)) for n in per_sample})
        meta["extra"], meta["per_sample"] = list(self.extra), per_sample
        if "switches" in self.__dict__:
            meta["switches"] = [_encode_switch(sw) for sw in self.switches]
        if "jumps" in self.__dict__:
            meta["n_jumps"] = len(self.jumps)
            for k, name in enumerate(("before", "after")):
                arrays[f"jumps_{name}"] = np.array(
                    [np.asarray(j[k], dtype=float) for j in self.jumps]
                ).reshape(len(self.jumps), self.states.shape[0])
        if "touchdowns" in self.__dict__:
            arrays["touchdowns"] = np.asarray(self.touchdowns, dtype=float)
        if "stopping_band" in self.__dict__:
            meta["stopping_band"] = float(self.stopping_band)
        text = json.dumps(meta)
        entries = {_META_KEY: np.array(text), **arrays}
        _write_atomically(target, lambda fh: np.savez_compressed(fh, **entries))
        return given

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
            ``options``, ``status`` and ``message`` equal; :meth:`at`, :meth:`crossings` work
            (see :meth:`save` for the accuracy of the dense output).

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
        p = Path(os.fspath(path))
        if not p.is_file():
            raise ValueError(f"path must be an existing trajectory file (.npz); got {str(p)!r}")
        try:
            with _Archive(p) as archive:
                meta = archive.meta()
                _check_meta(meta, p)
                return cls._from_saved(meta, archive)
        except _Refused as exc:
            raise ValueError(f"{p} is a damaged mett trajectory file: {exc}") from None
        except _Named:
            raise
        except (OSError, EOFError, zipfile.BadZipFile, zlib.error) as exc:
            raise ValueError(f"{p} is not a readable mett trajectory file: {exc}") from None
        except (ValueError, TypeError, ArithmeticError, LookupError, AttributeError,
                RecursionError) as exc:  # fmt: skip
            # not expected after the checks; still an error about the file, never a raw one
            raise ValueError(f"{p} is a damaged mett trajectory file: {exc!r}") from None

    @classmethod
    def _from_saved(cls, meta: dict, archive: _Archive) -> Trajectory:
        """The trajectory of a file's checked metadata ``meta`` and its entries. Every field and
        array is checked against the format and against each other before it is used (raising
        :class:`_Refused`): nothing unchecked reaches compiled code."""
        from .simulation import BACKENDS, MAX_SWITCHES
        from .simulation import MODELS as models

        model = models[meta["model"]]
        status = _choice(meta.get("status"), "status", STATUSES)
        message = _text(meta.get("message"), "message")
        backend = _choice(meta.get("backend"), "backend", tuple(b for b in BACKENDS if b != "auto"))
        nfev = _integer(meta.get("nfev"), "nfev", 0, 2**62)
        if "mett_version" in meta:
            _text(meta["mett_version"], "mett_version", 100)
        t_lost = meta.get("t_contact_lost")
        t_lost = None if t_lost is None else _number(t_lost, "t_contact_lost")
        series = _names(meta.get("series", []), "series", SERIES)
        per_sample = _names(meta.get("per_sample", []), "per_sample", tuple(_PER_SAMPLE))
        extra = _names(meta.get("extra", []), "extra", (*per_sample, *SERIES))
        n_events = _integer(meta.get("n_events"), "n_events", 0, 10_000)
        switches_meta = meta.get("switches")
        if switches_meta is not None and (
            not isinstance(switches_meta, list) or len(switches_meta) > MAX_SWITCHES
        ):
            raise _Refused(f"switches must be a list of at most {MAX_SWITCHES} records")
        n_jumps = None
        if "n_jumps" in meta:
            n_jumps = _integer(meta["n_jumps"], "n_jumps", 0, MAX_SWITCHES)
            if switches_meta is not None and n_jumps != len(switches_meta):
                raise _Refused(f"{n_jumps} jumps for {len(switches_meta)} switches")
        band = None
        if "stopping_band" in meta:
            band = _number(meta["stopping_band"], "stopping_band")
            if band < 0.0:
                raise _Refused(f"stopping_band must be >= 0; got {band!r}")

        # the top, the options and the parameters: mett's own classes, validated as on creation,
        # and the parameters those of the top and options (to rounding)
        with warnings.catch_warnings():  # the top was accepted (and warned about) when it was made
            warnings.simplefilter("ignore", _validate.MettWarning)
            top = _decode_top(meta.get("top"))
            options = _decode_options(meta.get("options"))
            try:
                expected = tuple(model.parameters(top, **options))
            except (TypeError, ValueError, ArithmeticError) as exc:
                raise _Refused(f"the options do not fit model {model.name!r}: {exc}") from None
            params = _decode_params(meta.get("params"), expected)
            init = _decode_state(meta.get("initial_state"))
            try:
                n_state = int(np.asarray(model.initial(init, params), dtype=float).size)
            except (TypeError, ValueError, ArithmeticError) as exc:
                raise _Refused(f"initial_state does not fit model {model.name!r}: {exc}") from None

        # the entries: exactly those this metadata implies (others are refused unread)
        phase_names = tuple(ph.name for ph in model.phase_table())
        dense_meta = meta.get("dense")
        dense_entries = _dense_entries(dense_meta, phase_names, MAX_SWITCHES)
        required = {"t", "states", *series, *(f"t_events_{k}" for k in range(n_events))}
        required |= {f"extra_{name}" for name in per_sample} | set(dense_entries)
        if n_jumps is not None:
            required |= {"jumps_before", "jumps_after"}
        archive.expect(required, optional={"touchdowns"})

        # the samples: times first (their count fixes the other arrays' shapes)
        t = archive.array("t", (None,))
        if t.size == 0:
            raise _Refused("t must hold at least one sample")
        _check_times(t, "t", strict=True)
        states = archive.array("states", (n_state, t.size))
        trajectory_series = {name: archive.array(name, (t.size,)) for name in series}
        extras = {name: archive.array(f"extra_{name}", (t.size,), kind=_PER_SAMPLE[name][0],
                                      labels=_PER_SAMPLE[name][1]) for name in per_sample}  # fmt: skip
        t_events = [archive.array(f"t_events_{k}", (None,)) for k in range(n_events)]
        t0, t1 = float(t[0]), float(t[-1])
        solution = _decode_dense(dense_meta, archive, n_state)
        if not (solution.t_min <= t0 and t1 <= solution.t_max):
            raise _Refused(
                f"the dense output covers [{solution.t_min!r}, {solution.t_max!r}] s, not the "
                f"samples' [{t0!r}, {t1!r}] s"
            )
        _check_dense_values(solution, t, states)
        if t_lost is not None and not t0 <= t_lost <= t1:
            raise _Refused(f"t_contact_lost = {t_lost!r} s lies outside the run")
        lo, hi = solution.t_min, solution.t_max
        switches = None
        if switches_meta is not None:
            switches = [_decode_switch(item, phase_names, (lo, hi)) for item in switches_meta]
            times = [float(sw[0]) for sw in switches]
            if times != sorted(times):
                raise _Refused("the switch times must be in order")
        jumps = None
        if n_jumps is not None:
            before = archive.array("jumps_before", (n_jumps, n_state))
            after = archive.array("jumps_after", (n_jumps, n_state))
            jumps = [(before[k], after[k]) for k in range(n_jumps)]
        touchdowns = None
        if archive.has("touchdowns"):
            touchdowns = archive.array("touchdowns", (None,))
            # the times the stem touched down: those of the switches from ball to stem
            down = [sw[0] for sw in switches or () if sw[1][:4] == "ball" and sw[2][:4] == "stem"]
            if not np.array_equal(touchdowns, down):
                raise _Refused("the touchdowns are not the switches from ball to stem")

        traj = cls(
            t=t,
            states=states,
            model=model,
            top=top,
            params=params,
            solution=solution,
            status=status,
            message=message,
            t_contact_lost=t_lost,
            t_events=t_events,
            nfev=nfev,
            backend=backend,
            initial_state=init,
            options=options,
        )
        # the series exactly as saved (a later mett may derive them in other rounding)
        for key, values in trajectory_series.items():
            setattr(traj, key, values)
        # what the run set beyond its states (format 2; absent from files of format 1)
        for key, values in extras.items():
            setattr(traj, key, values)
        if "extra" in meta:
            traj.extra = tuple(extra)
        if switches is not None:
            traj.switches = switches
        if jumps is not None:
            traj.jumps = jumps
        if touchdowns is not None:
            traj.touchdowns = touchdowns
        if band is not None:
            traj.stopping_band = band
        return traj


# --- file helpers ----------------------------------------------------------------------------
def _mett_version() -> str:
    from .. import __version__

    return __version__


def _check_save_path(path: Any) -> tuple[Path, Path]:
    """The path as given and the file to write (a symbolic link resolved to the file it points
    to), checked before any work."""
    if not isinstance(path, (str, os.PathLike)) or isinstance(path, bytes):
        raise TypeError(f"path must be a str or path-like; got {type(path).__name__}")
    p = Path(os.fspath(path))
    if p.suffix != ".npz":
        raise ValueError(f"path must end in .npz; got {str(p)!r}")
    if p.is_dir():
        raise ValueError(f"path must be a file, not a directory; got {str(p)!r}")
    # a link is written through: the file it points to is replaced, the link stays a link
    real = Path(os.path.realpath(p)) if p.is_symlink() else p
    if real.is_dir():
        raise ValueError(f"path must be a file, not a directory; got {str(p)!r} -> {str(real)!r}")
    parent = real.parent if str(real.parent) else Path(".")
    if not parent.is_dir():
        raise ValueError(f"the directory of path must exist; got {str(p)!r}")
    if not os.access(parent, os.W_OK | os.X_OK) or (real.exists() and not os.access(real, os.W_OK)):
        raise ValueError(f"path must be writable; got {str(p)!r}")
    return p, real


def _write_atomically(target: Path, write: Any) -> None:
    """``write(file)`` into a fresh temporary file next to ``target``, then renamed over it.

    The temporary name is short (``.mett-<12 hex>.tmp``), so that any legal target name works.
    It is created exclusively with the permissions of the file it replaces (or those of a new
    file under the umask), never wider; it is removed on any error.
    """
    parent = target.parent if str(target.parent) else Path(".")
    try:
        mode = stat.S_IMODE(target.stat().st_mode) & 0o777
    except FileNotFoundError:
        mode = None
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_BINARY", 0)
    for _ in range(100):
        tmp = parent / f".mett-{secrets.token_hex(6)}.tmp"
        try:
            # created with the target's bits (or 0o666) under the umask: never wider than either
            fd = os.open(tmp, flags, 0o666 if mode is None else mode)
            break
        except FileExistsError:
            continue
    else:  # pragma: no cover - 100 collisions of 48 random bits
        raise FileExistsError(f"cannot create a temporary file in {str(parent)!r}")
    try:
        with os.fdopen(fd, "wb") as fh:
            if mode is not None and hasattr(os, "fchmod"):
                os.fchmod(fh.fileno(), mode)  # exactly the replaced file's bits (umask aside)
            write(fh)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, target)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def _encode_param(i: int, v: Any) -> float:
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, float, np.integer, np.floating)):
        raise TypeError(f"model parameter {i} must be a number to be saved; got {v!r}")
    return float(v)


def _encode_option(name: str, v: Any) -> Any:
    if v is None or isinstance(v, (bool, str)):
        return v
    if isinstance(v, (int, float, np.integer, np.floating)):
        return v.item() if isinstance(v, np.generic) else v
    if isinstance(v, (list, tuple)):
        return [_encode_option(name, x) for x in v]
    if isinstance(v, Mapping):
        return {str(k): _encode_option(name, x) for k, x in v.items()}
    if type(v) in _saved_classes()["option"].values():
        fields = {f.name: _encode_option(name, getattr(v, f.name)) for f in dataclasses.fields(v)}
        return {"__dataclass__": _qualified_name(type(v)), "fields": fields}
    raise TypeError(
        f"option {name!r} must be a plain value (number, string, bool, None, list, dict or a "
        f"registered friction law) to be saved; got {type(v).__name__}"
    )


def _qualified_name(cls: type) -> str:
    return f"{cls.__module__}:{cls.__qualname__}"


def _saved_classes() -> dict[str, dict[str, type]]:
    """The only classes a trajectory file can name, by the name it uses: a file never chooses
    code to import or to call (no import by name, no attribute walk)."""
    from ..friction import registered
    from ..stem import StemContactTop
    from ..top import TippeTop
    from .stickslip import Switch

    def table(*classes: type) -> dict[str, type]:
        return {_qualified_name(c): c for c in classes}

    return {
        "top": table(TippeTop, StemContactTop),
        "option": table(*registered()),  # the registered friction laws
        "record": table(Switch),
    }


def _class_name(cls: type, what: str) -> str:
    """The saved name of ``cls``, one of the classes a file may name as a ``what``."""
    name = _qualified_name(cls)
    if _saved_classes()[what].get(name) is not cls:
        raise TypeError(
            f"a {what} of type {cls.__name__} cannot be saved (not one of mett's types)"
        )
    return name


def _saved_class(name: Any, what: str) -> type:
    table = _saved_classes()[what]
    if not isinstance(name, str) or name not in table:
        raise _Refused(
            f"refusing to rebuild {_short(name)} as {'an' if what[0] in 'aeiou' else 'a'} {what}: not one of the types a trajectory "
            f"file may name ({', '.join(table)})"
        )
    return table[name]


def _encode_switch(sw: Any) -> dict:
    """A switch of a hybrid run (a (t, before, after) tuple or a mett record) as JSON."""
    if hasattr(sw, "_asdict"):
        fields = {k: (v if isinstance(v, str) else float(v)) for k, v in sw._asdict().items()}
        return {"type": _class_name(type(sw), "record"), "fields": fields}
    return {"type": None, "values": [v if isinstance(v, str) else float(v) for v in sw]}


def _check_meta(meta: Any, p: Path) -> None:
    from .simulation import MODELS

    if not isinstance(meta, dict) or meta.get("format") != _FORMAT_NAME:
        raise _Named(f"{p} is not a mett trajectory file")
    version = meta.get("format_version")
    if not isinstance(version, int) or isinstance(version, bool) or version < 1:
        raise _Named(f"{p} has an invalid format_version {_short(version)}")
    if version > FORMAT_VERSION:
        raise _Named(
            f"{p} was written in trajectory format version {version} (by mett "
            f"{_short(meta.get('mett_version', '?'))}); this mett reads versions up to "
            f"{FORMAT_VERSION}: upgrade mett to read it"
        )
    name = meta.get("model")
    if not isinstance(name, str) or name not in MODELS:
        raise _Named(
            f"{p} holds a run of model {_short(name)}, which this mett does not know "
            f"(known models: {', '.join(MODELS)})"
        )


# --- reading a file: every entry and field checked before use ----------------------------------
class _Refused(Exception):
    """Why a trajectory file is refused (:meth:`Trajectory.load` raises it as a ValueError
    naming the file)."""


class _Named(ValueError):
    """A ValueError whose message already names the file."""


_LOAD_FLOOR = 64 * 2**20
_LOAD_RATIO = 256
"""A file whose entries declare more than ``max(_LOAD_FLOOR, _LOAD_RATIO × its size)`` bytes
uncompressed is refused before anything is decompressed (a zip bomb). The arrays of a real run
compress by 1.1–3 (floats of a motion); the most compressible real file, a motionless run sampled
at integer ``t_eval``, by about 200. Deflate can reach 1032."""

_META_MAX_CHARS = 2**24
"""Longest metadata text (characters): 10⁵ switch records (MAX_SWITCHES) of ~150 characters."""

_MAX_DEPTH = 16
"""Deepest nesting of an option value (a friction law in a dict in a list ...)."""

_MAX_TEXT = 100_000
"""Longest message or other text field (characters)."""

_MAX_TAYLOR_TERMS = 64
"""Most Taylor coefficients per component and step (the Taylor backend's order is at most ~20)."""

_PER_SAMPLE = {
    "phase": ("U", ("sliding", "rolling", "ball", "stem")),
    "contact": ("U", ("ball", "stem")),
    "F_x": ("f", ()),
    "F_y": ("f", ()),
    "M_n": ("f", ()),
    "margin": ("f", ()),
}
"""The per-sample series a run may set beyond :data:`SERIES` (name: dtype kind, allowed labels)."""

_DENSE_ARRAYS = {
    "dop853": ("t", "y", "h", "F"),
    "taylor": ("t", "y", "C"),
    "hermite": ("t", "y", "dy"),
    "constant": ("t", "y"),
}


class _Archive:
    """The entries of a ``.npz`` file, read one by one with their sizes checked first.

    Only the entries the format defines are ever decompressed; each ``.npy`` header (dtype,
    shape) is checked against the shape the metadata and the other entries fix, and against
    the entry's declared size, before its data is read, and the data is read to exactly that
    size (a CRC error or a short entry is refused).
    """

    def __init__(self, path: Path) -> None:
        self.path = path
        self.zf = zipfile.ZipFile(path)
        try:
            infos = self.zf.infolist()
            names = [info.filename for info in infos]
            if len(set(names)) != len(names):
                raise _Refused("two entries have the same name")
            total = sum(info.file_size for info in infos)
            budget = max(_LOAD_FLOOR, _LOAD_RATIO * path.stat().st_size)
            if total > budget:
                raise _Refused(
                    f"its entries declare {total} bytes uncompressed, more than {budget} for a "
                    f"file of {path.stat().st_size} bytes (refused unread as a zip bomb)"
                )
            self.infos: dict[str, zipfile.ZipInfo] = {}
            for info in infos:
                name = info.filename
                if not name.endswith(".npy") or info.is_dir():
                    raise _Refused(f"entry {_short(name)} is not part of the format")
                if info.flag_bits & 0x1 or info.compress_type not in (
                    zipfile.ZIP_STORED,
                    zipfile.ZIP_DEFLATED,
                ):
                    raise _Refused(f"entry {_short(name)} is encrypted or compressed unusually")
                self.infos[name[: -len(".npy")]] = info
        except BaseException:
            self.zf.close()
            raise

    def __enter__(self) -> _Archive:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.zf.close()

    def has(self, key: str) -> bool:
        return key in self.infos

    def expect(self, required: set[str], optional: set[str]) -> None:
        """Refuse a file without one of ``required`` or with an entry not in either set."""
        keys = set(self.infos) - {_META_KEY}
        if missing := sorted(required - keys):
            raise _Refused(f"entry {missing[0]!r} is missing")
        if unknown := sorted(keys - required - optional):
            raise _Refused(f"entry {_short(unknown[0])} is not part of this file's format")

    def meta(self) -> Any:
        """The JSON metadata (a bounded text; deep nesting refused)."""
        if _META_KEY not in self.infos:
            raise _Named(f"{self.path} is not a mett trajectory file (no {_META_KEY!r} entry)")
        arr = self.array(_META_KEY, (), kind="U", max_chars=_META_MAX_CHARS)
        try:
            return json.loads(str(arr[()]))
        except RecursionError:
            raise _Refused("its metadata is nested too deeply") from None
        except ValueError as exc:  # json.JSONDecodeError; an integer of too many digits
            raise _Refused(f"its metadata is not JSON: {exc}") from None

    def array(
        self,
        key: str,
        shape: tuple[int | None, ...],
        *,
        kind: str = "f",
        labels: tuple[str, ...] = (),
        max_chars: int = 64,
    ) -> np.ndarray:
        """Entry ``key`` as a native array of ``shape`` (None: any length) and dtype ``kind``
        ("f": float64, finite; "U": text of at most ``max_chars`` characters, in ``labels`` if
        given)."""
        info = self.infos.get(key)
        if info is None:
            raise _Refused(f"entry {key!r} is missing")
        with self.zf.open(info) as fp:
            try:
                version = np.lib.format.read_magic(fp)
                if version == (1, 0):
                    found, fortran, dtype = np.lib.format.read_array_header_1_0(fp)
                elif version == (2, 0):
                    found, fortran, dtype = np.lib.format.read_array_header_2_0(fp)
                else:
                    raise _Refused(f"entry {key!r} has .npy version {version}")
            except _Refused:
                raise
            except Exception as exc:  # numpy parses the header's text: any failure is a bad one
                raise _Refused(f"entry {key!r} has no valid .npy header: {exc!r}") from None
            if not (isinstance(dtype, np.dtype) and dtype.names is None and dtype.shape == ()):
                raise _Refused(f"entry {key!r} has dtype {dtype}")
            if kind == "f" and not (dtype.kind == "f" and dtype.itemsize == 8):
                raise _Refused(f"entry {key!r} must hold float64; got {dtype}")
            if kind == "U" and not (dtype.kind == "U" and dtype.itemsize <= 4 * max_chars):
                raise _Refused(
                    f"entry {key!r} must hold text of <= {max_chars} characters; got {dtype}"
                )
            if (
                len(found) != len(shape)
                or any(d < 0 for d in found)
                or any(
                    want is not None and got != want for got, want in zip(found, shape, strict=True)
                )
            ):
                want_text = "(" + ", ".join("n" if s is None else str(s) for s in shape) + ")"
                raise _Refused(f"entry {key!r} has shape {found}, not {want_text}")
            count = math.prod(found)
            nbytes = count * dtype.itemsize
            if info.file_size != fp.tell() + nbytes:
                raise _Refused(
                    f"entry {key!r} declares {info.file_size} bytes for {nbytes} of data"
                )
            flat = np.empty(count, dtype=dtype)
            view = memoryview(flat.view(np.uint8))
            pos = 0
            while pos < nbytes:
                chunk = fp.read(min(2**20, nbytes - pos))
                if not chunk:
                    raise _Refused(f"entry {key!r} is truncated")
                view[pos : pos + len(chunk)] = chunk
                pos += len(chunk)
            if fp.read(1):  # (and at its end the entry's CRC is checked)
                raise _Refused(f"entry {key!r} is longer than its header says")
        arr = flat.reshape(found, order="F" if fortran else "C")
        arr = arr.astype(dtype.newbyteorder("="), order="C", copy=False)
        if kind == "f" and not np.all(np.isfinite(arr)):
            raise _Refused(f"entry {key!r} holds non-finite numbers")
        if labels and arr.size and not set(np.unique(arr).tolist()) <= set(labels):
            bad = sorted(set(np.unique(arr).tolist()) - set(labels))[0]
            raise _Refused(f"entry {key!r} holds {_short(bad)}, not one of {labels}")
        return arr


_REPR = reprlib.Repr()
_REPR.maxlevel, _REPR.maxlist, _REPR.maxdict, _REPR.maxstring, _REPR.maxother = 3, 4, 4, 60, 60


def _short(value: Any) -> str:
    """``repr(value)`` of bounded length and cost (a crafted field may be huge or deep)."""
    text = _REPR.repr(value)
    return text if len(text) <= 100 else text[:97] + "..."


def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _number(v: Any, what: str, *, finite: bool = True) -> float:
    if not _is_number(v):
        raise _Refused(f"{what} must be a number; got {_short(v)}")
    try:
        x = float(v)
    except OverflowError:
        raise _Refused(f"{what} must be a float; got an integer of {len(str(v))} digits") from None
    if finite and not math.isfinite(x):
        raise _Refused(f"{what} must be finite; got {x!r}")
    return x


def _integer(v: Any, what: str, lo: int, hi: int) -> int:
    if not isinstance(v, int) or isinstance(v, bool) or not lo <= v <= hi:
        raise _Refused(f"{what} must be an integer in [{lo}, {hi}]; got {_short(v)}")
    return v


def _text(v: Any, what: str, max_len: int = _MAX_TEXT) -> str:
    if not isinstance(v, str) or len(v) > max_len:
        raise _Refused(f"{what} must be a str of at most {max_len} characters; got {_short(v)}")
    return v


def _choice(v: Any, what: str, allowed: tuple[str, ...]) -> str:
    if not isinstance(v, str) or v not in allowed:
        raise _Refused(f"{what} must be one of {allowed}; got {_short(v)}")
    return v


def _names(v: Any, what: str, allowed: tuple[str, ...]) -> list[str]:
    """A list of distinct names from ``allowed``."""
    if not isinstance(v, list) or len(v) > len(allowed):
        raise _Refused(f"{what} must be a list of names from {allowed}; got {_short(v)}")
    for name in v:
        _choice(name, f"an entry of {what}", allowed)
    if len(set(v)) != len(v):
        raise _Refused(f"{what} names a series twice: {_short(v)}")
    return list(v)


def _fields(v: Any, what: str, cls: type) -> dict[str, float]:
    """Keyword arguments of the dataclass ``cls`` from a JSON object of numbers."""
    names = {f.name for f in dataclasses.fields(cls) if f.init}
    if not isinstance(v, dict) or not set(v) <= names:
        raise _Refused(
            f"{what} must be an object with fields from {sorted(names)}; got {_short(v)}"
        )
    return {k: _number(x, f"{what} field {k!r}", finite=False) for k, x in v.items()}


def _build(cls: type, kwargs: dict, what: str) -> Any:
    try:
        return cls(**kwargs)
    except (TypeError, ValueError, ArithmeticError) as exc:
        raise _Refused(f"{what}: {exc}") from None


def _decode_top(v: Any) -> Any:
    if not isinstance(v, dict):
        raise _Refused(f"top must be an object; got {_short(v)}")
    fields = dict(v)
    cls = _saved_class(fields.pop("type", "mett.top:TippeTop"), "top")
    return _build(cls, _fields(fields, "top", cls), "top")


def _decode_options(v: Any) -> dict[str, Any]:
    if not isinstance(v, dict):
        raise _Refused(f"options must be an object; got {_short(v)}")
    return {k: _decode_option(x, f"option {k!r}", 0) for k, x in v.items()}


def _decode_option(v: Any, what: str, depth: int) -> Any:
    if depth > _MAX_DEPTH:
        raise _Refused(f"{what} is nested more than {_MAX_DEPTH} levels deep")
    if v is None or isinstance(v, (bool, int, float)):
        return v
    if isinstance(v, str):
        return _text(v, what)
    if isinstance(v, list):
        return [_decode_option(x, what, depth + 1) for x in v]
    if isinstance(v, dict):
        if "__dataclass__" in v:
            if set(v) != {"__dataclass__", "fields"}:
                raise _Refused(f"{what} must be {{'__dataclass__': name, 'fields': {{...}}}}")
            cls = _saved_class(v["__dataclass__"], "option")
            return _build(cls, _fields(v["fields"], what, cls), what)
        return {k: _decode_option(x, what, depth + 1) for k, x in v.items()}
    raise _Refused(f"{what} has a value of type {type(v).__name__}")  # pragma: no cover


def _decode_params(v: Any, expected: tuple) -> tuple:
    """The saved parameters, which must be those of the saved top and options (to rounding)."""
    if not isinstance(v, list) or len(v) != len(expected):
        raise _Refused(f"params must be a list of {len(expected)} numbers; got {_short(v)}")
    params = tuple(_number(x, f"params[{i}]") for i, x in enumerate(v))
    for i, (got, want) in enumerate(zip(params, expected, strict=True)):
        want = float(want)
        if not abs(got - want) <= 1e-12 * abs(want):  # (a later mett may round differently)
            raise _Refused(f"params[{i}] = {got!r} is not that of the top and options ({want!r})")
    return params


def _decode_state(v: Any) -> State:
    if not isinstance(v, dict) or set(v) != set(_STATE_FIELDS):
        raise _Refused(
            f"initial_state must be an object with fields {_STATE_FIELDS}; got {_short(v)}"
        )
    values = {k: _number(v[k], f"initial_state field {k!r}") for k in _STATE_FIELDS}
    return _build(State, values, "initial_state")


def _decode_switch(item: Any, phases: tuple[str, ...], span: tuple[float, float]) -> Any:
    """A switch record: a (t, before, after) tuple or a :class:`~mett.dynamics.stickslip.Switch`."""
    if not isinstance(item, dict) or "type" not in item:
        raise _Refused(f"a switch must be an object with a type; got {_short(item)}")
    if item["type"] is None:
        values = item.get("values")
        if not isinstance(values, list) or len(values) != 3 or set(item) != {"type", "values"}:
            raise _Refused(f"a switch must be [t, before, after]; got {_short(item)}")
        record: tuple = (_number(values[0], "a switch time"), values[1], values[2])
    else:
        cls = _saved_class(item["type"], "record")
        fields = item.get("fields")
        if not isinstance(fields, dict) or set(fields) != set(cls._fields):
            raise _Refused(
                f"a switch record must have the fields {cls._fields}; got {_short(item)}"
            )
        hints = typing.get_type_hints(cls)
        kwargs = {
            k: _text(x, f"switch field {k!r}", 64) if hints[k] is str
            else _number(x, f"switch field {k!r}", finite=k == "t")
            for k, x in fields.items()
        }  # fmt: skip
        record = cls(**kwargs)
    t, before, after = record[0], record[1], record[2]
    for name in (before, after):
        _choice(name, "a switch's phase", phases)
    if not span[0] <= t <= span[1]:
        raise _Refused(f"a switch at t = {t!r} s lies outside the run")
    return record


def _check_times(t: np.ndarray, what: str, *, strict: bool = False) -> None:
    """Finite (checked on reading) and in order, as the dense output's search needs."""
    steps = np.diff(t)
    if np.any(steps <= 0.0) if strict else np.any(steps < 0.0):
        raise _Refused(f"the times {what} must be {'increasing' if strict else 'in order'}")


def _dense_entries(desc: Any, phases: tuple[str, ...], max_parts: int) -> list[str]:
    """The entry names of a dense-output description (checked: known kinds, one level of
    segments, their phases those of the model)."""
    if not isinstance(desc, dict):
        raise _Refused(f"dense must be an object; got {_short(desc)}")
    kind = desc.get("kind")
    if kind == "segments":
        parts, names = desc.get("parts"), desc.get("phases")
        if not (isinstance(parts, list) and isinstance(names, list)
                and 1 <= len(parts) == len(names) <= max_parts + 1):  # fmt: skip
            raise _Refused("dense segments must be lists of parts and phases of one length")
        for name in names:
            _choice(name, "a dense segment's phase", phases)
        out = []
        for k, part in enumerate(parts):
            if not isinstance(part, dict) or part.get("kind") not in _DENSE_ARRAYS:
                raise _Refused(f"dense segment {k} must be one of {tuple(_DENSE_ARRAYS)}")
            out += [f"dense_s{k}_{a}" for a in _DENSE_ARRAYS[part["kind"]]]
        return out
    if kind not in _DENSE_ARRAYS:
        raise _Refused(
            f"dense kind must be one of {(*_DENSE_ARRAYS, 'segments')}; got {_short(kind)}"
        )
    return [f"dense_{a}" for a in _DENSE_ARRAYS[kind]]


def _decode_dense(desc: dict, archive: _Archive, n: int) -> Any:
    """The dense output (checked by :func:`_dense_entries`) with every array's shape fixed by
    its times and the state size ``n``, its times in order and its steps positive."""
    if desc["kind"] != "segments":
        return _decode_part(desc["kind"], archive, "dense_", n)
    parts = [
        _decode_part(d["kind"], archive, f"dense_s{k}_", n) for k, d in enumerate(desc["parts"])
    ]
    for k in range(1, len(parts)):
        if parts[k].t_min != parts[k - 1].t_max:
            raise _Refused(f"dense segment {k} does not start where segment {k - 1} ends")
    return SegmentedSolution(parts, list(desc["phases"]))


def _decode_part(kind: str, archive: _Archive, prefix: str, n: int) -> Any:
    from .dop853 import DenseOutput
    from .taylor import TaylorDense

    if kind == "constant":
        t = archive.array(prefix + "t", (1,))
        return ConstantSolution(float(t[0]), archive.array(prefix + "y", (n,)))
    t = archive.array(prefix + "t", (None,))
    if t.size == 0:
        raise _Refused(f"entry {prefix + 't'!r} is empty")
    m = t.size - 1
    y = archive.array(prefix + "y", (m + 1, n))
    if kind == "hermite":
        _check_times(t, prefix + "t", strict=True)
        return _Hermite(t, y, archive.array(prefix + "dy", (m + 1, n)))
    _check_times(t, prefix + "t")
    if kind == "taylor":
        C = archive.array(prefix + "C", (m, n, None))
        if not 1 <= C.shape[2] <= _MAX_TAYLOR_TERMS:
            raise _Refused(f"entry {prefix + 'C'!r} has {C.shape[2]} Taylor coefficients")
        return TaylorDense(t, y, C)
    h = archive.array(prefix + "h", (m,))
    F = archive.array(prefix + "F", (m, 7, n))
    # each step's interpolant spans its segment: t[i+1] = t[i] + h[i] to rounding, the last
    # step possibly cut short by a terminal event
    steps = np.diff(t)
    slack = 4.0 * np.finfo(float).eps * np.maximum(np.abs(t[:-1]), np.abs(t[1:]))
    if np.any(h <= 0.0) or np.any(steps > h + slack) or np.any(np.abs(steps - h)[:-1] > slack[:-1]):
        raise _Refused(f"the step sizes {prefix + 'h'!r} do not match the times {prefix + 't'!r}")
    return DenseOutput(t, y, h, F)


_EXACT = 16 * np.finfo(float).eps
"""Agreement (relative to each component's magnitude) of the states a dense output stores at
its steps with the samples there and with its own polynomials at the step ends: a run stores
the very numbers (measured: 0 for DOP853 and constants, 1 ulp for Hermite data, 6 ulps for the
Taylor polynomials summed at a step's end)."""

_BOUNDED = 1e6
"""Largest sum of a step's polynomial terms over the component's magnitude (+ 1): a run's are
below ~1 (its dense output moves a component by at most its range within a step); far larger
ones could overflow what :meth:`Trajectory.at` derives from them."""


def _check_dense_values(solution: Any, t: np.ndarray, states: np.ndarray) -> None:
    """The dense output's polynomials join at their steps with bounded terms, and pass through
    the stored samples: what :meth:`Trajectory.at` gives agrees with the samples and stays
    finite."""
    from .dop853 import DenseOutput
    from .taylor import TaylorDense

    parts = solution.sols if isinstance(solution, SegmentedSolution) else [solution]
    ys = [np.atleast_2d(p._y0 if isinstance(p, ConstantSolution) else p.y) for p in parts]
    scale = np.max(np.abs(np.vstack([states.T, *ys])), axis=0)
    tol = _EXACT * scale
    with np.errstate(over="ignore", invalid="ignore"):  # (what overflows is refused)
        for k, part in enumerate(parts):
            if isinstance(part, DenseOutput):  # each step ends where the next starts
                inner = np.abs(part.y[:-2] + part.F[:-1, 0] - part.y[1:-1]) > tol
                terms = np.abs(part.F).sum(axis=1)
            elif isinstance(part, TaylorDense):  # (the sum at a step's end: a few ulps)
                powers = np.diff(part.t)[:, None] ** np.arange(part.C.shape[2])
                ends = np.einsum("ick,ik->ic", part.C, powers)
                inner = np.vstack(
                    [np.abs(part.C[:, :, 0] - part.y[:-1]) > tol,
                     np.abs(ends[:-1] - part.y[1:-1]) > 4 * tol]
                )  # fmt: skip
                terms = np.einsum("ick,ik->ic", np.abs(part.C[:, :, 1:]), powers[:, 1:])
            elif isinstance(part, _Hermite):
                inner = np.zeros(0, dtype=bool)
                terms = np.abs(part.dy[:-1]) * np.diff(part.ts)[:, None]
            else:
                continue
            if np.any(inner):
                raise _Refused(f"the dense output (part {k}) does not join at its steps")
            if np.any(~np.isfinite(terms) | (terms > _BOUNDED * (scale + 1.0))):
                raise _Refused(f"the dense output (part {k}) has coefficients out of scale")
        Y = np.asarray(solution(t), dtype=float).reshape(states.shape)
        off = np.any(~(np.abs(Y - states).T <= tol), axis=1)
    # Hermite data (other scipy methods) interpolate between their steps: compared there only
    for part in parts:
        if isinstance(part, _Hermite):
            off &= ~((t >= part.t_min) & (t <= part.t_max) & ~np.isin(t, part.ts))
    if off.any():
        k = int(np.flatnonzero(off)[0])
        raise _Refused(f"the dense output does not pass through sample {k} (t = {t[k]!r} s)")


def _encode_dense(
    sol: Any, model: Model, params: tuple, phase: str | None = None
) -> tuple[dict, dict[str, np.ndarray]]:
    """(description, arrays) of a dense output, for :meth:`Trajectory.save`. The equations it
    solves (those of ``phase`` of a hybrid ``model``) are needed only for a solution of another
    scipy method, which is stored as states and slopes."""
    from .dop853 import DenseOutput

    if isinstance(sol, SegmentedSolution):  # a hybrid run: each phase's own
        parts, arrays = [], {}
        for k, (part, name) in enumerate(zip(sol.sols, sol.phases, strict=True)):
            desc, arr = _encode_dense(part, model, params, name)
            parts.append(desc)
            arrays.update({f"s{k}_{key}": v for key, v in arr.items()})
        return {"kind": "segments", "phases": sol.phases, "parts": parts}, arrays
    if (
        isinstance(sol, ConstantSolution) or np.asarray(sol.ts).size == 1
    ):  # a run that never left t0
        ts = np.asarray(sol.ts, dtype=float)[:1]
        return {"kind": "constant"}, {"t": ts, "y": np.asarray(sol(ts[0]), dtype=float)}
    if isinstance(sol, DenseOutput):
        return {"kind": "dop853"}, {"t": sol.t, "y": sol.y, "h": sol.h, "F": sol.F}
    if type(sol).__name__ == "TaylorDense":  # the Taylor backend: each step's polynomial
        return {"kind": "taylor"}, {"t": sol.t, "y": sol.y, "C": sol.C[:, : sol.n]}
    if isinstance(sol, _Hermite):  # loaded from a file: as it was saved
        return {"kind": "hermite"}, {"t": sol.ts, "y": sol.y, "dy": sol.dy}
    ts = np.asarray(sol.ts, dtype=float)
    interpolants = list(getattr(sol, "interpolants", []))
    if interpolants and all(type(i).__name__ == "Dop853DenseOutput" for i in interpolants):
        # scipy's DOP853 interpolant is the same polynomial as DenseOutput's (same coefficients)
        y = np.vstack([[i.y_old for i in interpolants], np.asarray(sol(ts[-1]))[None, :]])
        h = np.array([i.h for i in interpolants], dtype=float)
        F = np.array([i.F for i in interpolants], dtype=float)
        return {"kind": "dop853"}, {"t": ts, "y": y, "h": h, "F": F}
    # any other continuous solution: its states and slopes at the steps (cubic Hermite on load)
    rhs = {ph.name: ph.rhs for ph in model.phase_table()}.get(phase, model.rhs)
    Y = np.asarray(sol(ts), dtype=float).reshape(-1, ts.size)
    dY = np.column_stack([np.asarray(rhs(t, Y[:, k], params)) for k, t in enumerate(ts)])
    return {"kind": "hermite"}, {"t": ts, "y": Y.T, "dy": dY.T}


class _Hermite:
    """Piecewise cubic Hermite dense output through stored step states and slopes."""

    def __init__(self, t: np.ndarray, y: np.ndarray, dy: np.ndarray) -> None:
        from scipy.interpolate import CubicHermiteSpline

        self.ts, self.y, self.dy = t, y, dy
        self.t_min, self.t_max = float(t[0]), float(t[-1])
        self._spline = CubicHermiteSpline(t, y, dy, axis=0)

    def __call__(self, t: Any) -> np.ndarray:
        return np.asarray(self._spline(t)).T
