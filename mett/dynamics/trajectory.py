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
import uuid
import warnings
import zipfile
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
            Target file; must end in ``.npz`` and its directory must exist. An existing file is
            replaced atomically (the new file is written next to it and renamed), so a failed save
            never leaves a damaged file behind.

        Returns
        -------
        pathlib.Path
            The path written.

        Raises
        ------
        ValueError
            If the path does not end in ``.npz``, is a directory, or its directory does not exist
            (checked before anything is written).
        TypeError
            If a model option is not a plain value (number, string, bool, None, list, dict or a
            dataclass of :mod:`mett`), so that it cannot be stored as JSON.

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
        """
        target = _check_save_path(path)
        meta = {
            "format": _FORMAT_NAME,
            "format_version": FORMAT_VERSION,
            "mett_version": _mett_version(),
            "model": self.model,
            "options": {k: _encode_option(k, v) for k, v in self.options.items()},
            "params": [_encode_param(i, v) for i, v in enumerate(self.params)],
            "top": {"type": _qualified_name(type(self.top)), **dataclasses.asdict(self.top)},
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
        # a fresh name next to the target (same file system, so the rename is atomic), opened
        # exclusively with the ordinary permissions of a new file
        tmp = target.with_name(f".{target.name}.{os.getpid()}.{uuid.uuid4().hex[:12]}.tmp")
        try:
            with open(tmp, "xb") as fh:
                np.savez_compressed(fh, **{_META_KEY: np.array(text)}, **arrays)
            os.replace(tmp, target)
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise
        return target

    @classmethod
    def load(cls, path: str | os.PathLike) -> Trajectory:
        """Read a trajectory written by :meth:`save`.

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
            If the file does not exist, is not a mett trajectory, is damaged, was written by a
            newer mett (a ``format_version`` above :data:`FORMAT_VERSION`), or names a model this
            mett does not know.
        """
        p = Path(os.fspath(path))
        if not p.is_file():
            raise ValueError(f"path must be an existing trajectory file (.npz); got {str(p)!r}")
        try:
            with np.load(p, allow_pickle=False) as data:
                files = {k: np.array(data[k]) for k in data.files}
            text = str(files.pop(_META_KEY))
            meta = json.loads(text)
        except KeyError:
            raise ValueError(
                f"{p} is not a mett trajectory file (no {_META_KEY!r} entry)"
            ) from None
        except (OSError, EOFError, ValueError, zipfile.BadZipFile) as exc:
            # (json.JSONDecodeError is a ValueError)
            raise ValueError(f"{p} is not a readable mett trajectory file: {exc}") from None
        _check_meta(meta, p)
        arrays = files
        from .simulation import MODELS

        name = meta.get("model")
        if name not in MODELS:
            raise ValueError(
                f"{p} holds a run of model {name!r}, which this mett does not know "
                f"(known models: {', '.join(MODELS)})"
            )
        try:
            return cls._from_saved(meta, arrays)
        except (KeyError, TypeError, IndexError, ValueError) as exc:
            raise ValueError(f"{p} is a damaged mett trajectory file: {exc!r}") from None

    @classmethod
    def _from_saved(cls, meta: dict, arrays: dict[str, np.ndarray]) -> Trajectory:
        from .simulation import MODELS

        name = meta["model"]
        top_fields = {k: v for k, v in meta["top"].items() if k != "type"}
        top_cls = _mett_class(meta["top"].get("type", "mett.top:TippeTop"))
        with warnings.catch_warnings():  # the top was accepted (and warned about) when it was made
            warnings.simplefilter("ignore", _validate.MettWarning)
            top = top_cls(**top_fields)
        init = meta["initial_state"]
        traj = cls(
            t=arrays["t"],
            states=arrays["states"],
            model=MODELS[name],
            top=top,
            params=tuple(meta["params"]),
            solution=_decode_dense(meta["dense"], arrays),
            status=meta["status"],
            message=meta["message"],
            t_contact_lost=meta["t_contact_lost"],
            t_events=[arrays[f"t_events_{k}"] for k in range(int(meta["n_events"]))],
            nfev=int(meta["nfev"]),
            backend=meta["backend"],
            initial_state=None if init is None else State(**init),
            options={k: _decode_option(v) for k, v in meta["options"].items()},
        )
        # the series exactly as saved (a later mett may derive them in other rounding)
        for key in meta["series"]:
            if key in arrays:
                if arrays[key].shape != traj.t.shape:
                    raise ValueError(f"series {key!r} has shape {arrays[key].shape}")
                setattr(traj, key, arrays[key])
        # what the run set beyond its states (format 2; absent from files of format 1)
        for key in meta.get("per_sample", []):
            values = arrays[f"extra_{key}"]
            if values.shape != traj.t.shape:
                raise ValueError(f"series {key!r} has shape {values.shape}")
            setattr(traj, key, values)
        traj.extra = tuple(meta.get("extra", traj.extra))
        if "switches" in meta:
            traj.switches = [_decode_switch(item) for item in meta["switches"]]
        if "n_jumps" in meta:
            before, after = arrays["jumps_before"], arrays["jumps_after"]
            traj.jumps = [(before[k], after[k]) for k in range(int(meta["n_jumps"]))]
        if "touchdowns" in arrays:
            traj.touchdowns = arrays["touchdowns"]
        if "stopping_band" in meta:
            traj.stopping_band = float(meta["stopping_band"])
        return traj


# --- file helpers ----------------------------------------------------------------------------
def _mett_version() -> str:
    from .. import __version__

    return __version__


def _check_save_path(path: Any) -> Path:
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"path must be a str or path-like; got {type(path).__name__}")
    p = Path(os.fspath(path))
    if p.suffix != ".npz":
        raise ValueError(f"path must end in .npz; got {str(p)!r}")
    if p.is_dir():
        raise ValueError(f"path must be a file, not a directory; got {str(p)!r}")
    parent = p.parent if str(p.parent) else Path(".")
    if not parent.is_dir():
        raise ValueError(f"the directory of path must exist; got {str(p)!r}")
    return p


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
    if dataclasses.is_dataclass(v) and not isinstance(v, type):
        cls = type(v)
        if cls.__module__.split(".")[0] == "mett":
            fields = {
                f.name: _encode_option(name, getattr(v, f.name)) for f in dataclasses.fields(v)
            }
            return {"__dataclass__": _qualified_name(cls), "fields": fields}
    raise TypeError(
        f"option {name!r} must be a plain value (number, string, bool, None, list, dict or a mett "
        f"dataclass) to be saved; got {type(v).__name__}"
    )


def _decode_option(v: Any) -> Any:
    if isinstance(v, list):
        return [_decode_option(x) for x in v]
    if isinstance(v, dict):
        if "__dataclass__" in v:
            cls = _mett_class(v["__dataclass__"])
            return cls(**{k: _decode_option(x) for k, x in v["fields"].items()})
        return {k: _decode_option(x) for k, x in v.items()}
    return v


def _qualified_name(cls: type) -> str:
    return f"{cls.__module__}:{cls.__qualname__}"


def _mett_class(name: str, *, record: bool = False) -> type:
    """The mett dataclass ``"module:QualName"`` (only mett's own: a file never names code to run);
    with ``record``, a mett NamedTuple (e.g. the switch records of a stick–slip run)."""
    import importlib

    module, _, qualname = str(name).partition(":")
    if module.split(".")[0] != "mett" or not qualname:
        raise ValueError(f"refusing to rebuild {name!r}: not a mett class")
    try:
        obj: Any = importlib.import_module(module)
        for part in qualname.split("."):
            obj = getattr(obj, part)
    except (ImportError, AttributeError):
        raise ValueError(f"{name!r} does not exist in this mett") from None
    if record and isinstance(obj, type) and issubclass(obj, tuple) and hasattr(obj, "_fields"):
        return obj
    if not (isinstance(obj, type) and dataclasses.is_dataclass(obj)):
        raise ValueError(f"{name!r} is not a mett dataclass")
    return obj


def _encode_switch(sw: Any) -> dict:
    """A switch of a hybrid run (a (t, before, after) tuple or a mett record) as JSON."""
    if hasattr(sw, "_asdict"):
        fields = {k: (v if isinstance(v, str) else float(v)) for k, v in sw._asdict().items()}
        return {"type": _qualified_name(type(sw)), "fields": fields}
    return {"type": None, "values": [v if isinstance(v, str) else float(v) for v in sw]}


def _decode_switch(item: dict) -> Any:
    if item["type"] is None:
        return tuple(item["values"])
    return _mett_class(item["type"], record=True)(**item["fields"])


def _check_meta(meta: Any, p: Path) -> None:
    if not isinstance(meta, dict) or meta.get("format") != _FORMAT_NAME:
        raise ValueError(f"{p} is not a mett trajectory file")
    version = meta.get("format_version")
    if not isinstance(version, int) or isinstance(version, bool) or version < 1:
        raise ValueError(f"{p} has an invalid format_version {version!r}")
    if version > FORMAT_VERSION:
        raise ValueError(
            f"{p} was written in trajectory format version {version} (by mett "
            f"{meta.get('mett_version', '?')}); this mett reads versions up to {FORMAT_VERSION}: "
            "upgrade mett to read it"
        )


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


def _decode_dense(desc: dict, arrays: dict[str, np.ndarray], prefix: str = "dense_") -> Any:
    from .dop853 import DenseOutput

    kind = desc["kind"]

    def arr(name: str) -> np.ndarray:
        return arrays[prefix + name]

    if kind == "segments":
        parts = [_decode_dense(d, arrays, f"{prefix}s{k}_") for k, d in enumerate(desc["parts"])]
        return SegmentedSolution(parts, [str(p) for p in desc["phases"]])
    if kind == "constant":
        return ConstantSolution(float(arr("t")[0]), arr("y"))
    if kind == "dop853":
        return DenseOutput(arr("t"), arr("y"), arr("h"), arr("F"))
    if kind == "hermite":
        return _Hermite(arr("t"), arr("y"), arr("dy"))
    if kind == "taylor":
        from .taylor import TaylorDense

        return TaylorDense(arr("t"), arr("y"), arr("C"))
    raise ValueError(f"unknown dense output kind {kind!r}")
