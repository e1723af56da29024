"""Dense outputs: the continuous solution of a run, and how it is kept in a file.

Every dense output of a :class:`~mett.Trajectory` follows one protocol, :class:`DenseSolution`:
``ts`` (the solver's steps), ``t_min``/``t_max``, evaluation ``sol(t)`` and ``truncate(t)``.
The integrators make their own (the compiled DOP853's :class:`mett.dynamics.dop853.DenseOutput`,
the Taylor backend's ``TaylorDense``, scipy's ``OdeSolution``); this module adds those of a
hybrid run (:class:`SegmentedSolution`, one per phase), of a run that never left its start
(:class:`ConstantSolution`) and of a loaded run of another scipy method
(:class:`HermiteSolution`).

:func:`to_arrays` and :func:`from_arrays` turn any of them into a description (a JSON object)
and named float arrays and back, bit for bit: the file format (:mod:`mett.dynamics._format`)
stores what they give without knowing the classes.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any, Protocol, runtime_checkable

import numpy as np

__all__ = [
    "ARRAYS",
    "ConstantSolution",
    "DenseSolution",
    "HermiteSolution",
    "SegmentedSolution",
    "from_arrays",
    "to_arrays",
    "truncate",
]


@runtime_checkable
class DenseSolution(Protocol):
    """What a :class:`~mett.Trajectory` needs of the integrator's continuous solution.

    Evaluation is ``sol(t)``; cutting at a time is :func:`truncate` and storage
    :func:`to_arrays` / :func:`from_arrays`, functions of this module that cover every kind
    (they call the method ``truncate`` of the classes that have one, and know the arrays of the
    integrators' own classes, which live with their integrators).
    """

    ts: np.ndarray
    """Breakpoints of the piecewise interpolant (the solver's steps), increasing."""
    t_min: float
    """First time covered (s)."""
    t_max: float
    """Last time covered (s)."""

    def __call__(self, t: Any) -> np.ndarray:
        """Evaluate: the state(s) at ``t``, shape (n,) for a scalar time, (n, k) for k times."""
        ...


class SegmentedSolution:
    """Dense output of a hybrid run: one solution per phase, switched at their start times.

    Made by :func:`mett.simulate` for a model with several phases (dry friction, the stem), and
    by :meth:`mett.Trajectory.load` for such a run.

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

    def truncate(self, t_stop: float) -> SegmentedSolution:
        """The solution up to ``t_stop`` (the phases before it, the last one cut there)."""
        k = int(np.clip(np.searchsorted(self._starts, t_stop, side="right") - 1, 0, None))
        return SegmentedSolution(
            [*self.sols[:k], truncate(self.sols[k], t_stop)], self.phases[: k + 1]
        )


class ConstantSolution:
    """Dense output of a run that never left its start (contact lost or failure at t0).

    Its state ``y0`` at every time. Made by :func:`mett.simulate` and by
    :meth:`mett.Trajectory.load` for a saved run with one dense time.

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

    @property
    def y(self) -> np.ndarray:
        """The state (shape (n,))."""
        return self._y0

    def __call__(self, t: Any) -> np.ndarray:
        t = np.asarray(t, dtype=float)
        if t.ndim == 0:
            return self._y0.copy()
        return np.repeat(self._y0[:, None], t.size, axis=1)

    def truncate(self, t_stop: float) -> ConstantSolution:
        """Itself (it covers one time)."""
        return self


class HermiteSolution:
    """Piecewise cubic Hermite dense output through stored step states ``y`` and slopes ``dy``.

    How a run of a scipy method other than DOP853 (RK45, Radau, ...) is kept in a file: exact at
    the steps, between them within the interpolation error O(h⁴) of the step size h.

    Parameters
    ----------
    t : ndarray, shape (m+1,)
        Step times (s), increasing.
    y, dy : ndarray, shape (m+1, n)
        States and their time derivatives at the steps.
    """

    def __init__(self, t: np.ndarray, y: np.ndarray, dy: np.ndarray) -> None:
        from scipy.interpolate import CubicHermiteSpline

        self.ts, self.y, self.dy = t, y, dy
        self.t_min, self.t_max = float(t[0]), float(t[-1])
        self._spline = CubicHermiteSpline(t, y, dy, axis=0)

    def __call__(self, t: Any) -> np.ndarray:
        return np.asarray(self._spline(t)).T

    def truncate(self, t_stop: float) -> HermiteSolution:
        """The interpolant up to ``t_stop`` (its last step cut there; the cubic of that step is
        re-expressed through its state and slope at ``t_stop``, the same polynomial)."""
        k = max(int(np.searchsorted(self.ts, t_stop, side="left")), 1)
        t = np.append(self.ts[:k], t_stop)
        y = np.vstack([self.y[:k], self(t_stop)[None, :]])
        dy = np.vstack([self.dy[:k], np.asarray(self._spline(t_stop, 1))[None, :]])
        return HermiteSolution(t, y, dy)


def truncate(sol: Any, t_stop: float) -> Any:
    """``sol`` cut at ``t_stop`` (inside its last kept step): its own ``truncate``, or for the
    compiled DOP853 output its steps up to ``t_stop`` with the last one's interpolant kept."""
    from .dop853 import DenseOutput

    if not isinstance(sol, DenseOutput):
        if not hasattr(sol, "truncate"):
            raise TypeError(
                f"sol must be a dense output that can be truncated; got {type(sol).__name__}"
            )
        return sol.truncate(t_stop)
    k = max(int(np.searchsorted(sol.t, t_stop, side="left")), 1)  # t[k-1] < t_stop <= t[k]
    t = np.append(sol.t[:k], t_stop)
    y = np.vstack([sol.y[:k], sol(t_stop)[None, :]])
    return DenseOutput(t, y, sol.h[:k], sol.F[:k])


ARRAYS = {
    "dop853": ("t", "y", "h", "F"),
    "taylor": ("t", "y", "C"),
    "hermite": ("t", "y", "dy"),
    "constant": ("t", "y"),
}
"""The arrays of each kind of dense output (besides ``"segments"``, a list of parts)."""

Slopes = Callable[[str | None, np.ndarray, np.ndarray], np.ndarray]
"""``slopes(phase, ts, Y)``: the right-hand side of the equations of ``phase`` (None: the only
one) at the states ``Y`` (n, k) at times ``ts``, shape (n, k)."""


def to_arrays(
    sol: Any, slopes: Slopes, phase: str | None = None
) -> tuple[dict, dict[str, np.ndarray]]:
    """(description, arrays) of a dense output, exact for every kind mett makes.

    Parameters
    ----------
    sol : DenseSolution
        The dense output.
    slopes : callable
        See :data:`Slopes`; needed only for a solution of another scipy method than DOP853,
        which is stored as its step states and slopes (a :class:`HermiteSolution` on reading).
    phase : str, optional
        The phase ``sol`` solves (of a hybrid model).

    Returns
    -------
    desc : dict
        ``{"kind": k}`` with k a key of :data:`ARRAYS`, or ``{"kind": "segments", "phases":
        [...], "parts": [desc, ...]}`` for a hybrid run.
    arrays : dict of str to ndarray
        The arrays of :data:`ARRAYS` ``[k]``; those of segment ``j`` prefixed ``s<j>_``.
    """
    from .dop853 import DenseOutput

    if isinstance(sol, SegmentedSolution):  # a hybrid run: each phase's own
        parts, arrays = [], {}
        for k, (part, name) in enumerate(zip(sol.sols, sol.phases, strict=True)):
            desc, arr = to_arrays(part, slopes, name)
            parts.append(desc)
            arrays.update({f"s{k}_{key}": v for key, v in arr.items()})
        return {"kind": "segments", "phases": list(sol.phases), "parts": parts}, arrays
    if isinstance(sol, ConstantSolution) or np.asarray(sol.ts).size == 1:  # never left t0
        ts = np.asarray(sol.ts, dtype=float)[:1]
        return {"kind": "constant"}, {"t": ts, "y": np.asarray(sol(ts[0]), dtype=float)}
    if isinstance(sol, DenseOutput):
        return {"kind": "dop853"}, {"t": sol.t, "y": sol.y, "h": sol.h, "F": sol.F}
    if type(sol).__name__ == "TaylorDense":  # the Taylor backend: each step's polynomial
        return {"kind": "taylor"}, {"t": sol.t, "y": sol.y, "C": sol.C[:, : sol.n]}
    if isinstance(sol, HermiteSolution):  # loaded from a file: as it was saved
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
    Y = np.asarray(sol(ts), dtype=float).reshape(-1, ts.size)
    dY = slopes(phase, ts, Y)
    return {"kind": "hermite"}, {"t": ts, "y": Y.T, "dy": dY.T}


def from_arrays(desc: Mapping[str, Any], arrays: Mapping[str, np.ndarray]) -> Any:
    """The dense output of :func:`to_arrays`'s ``(desc, arrays)``.

    The arrays are used as given (the file format checks their shapes, order and values first,
    :mod:`mett.dynamics._format`).
    """
    from .dop853 import DenseOutput
    from .taylor import TaylorDense

    kind = desc["kind"]
    if kind == "segments":
        parts = []
        for j, d in enumerate(desc["parts"]):
            prefix = f"s{j}_"
            own = {k[len(prefix) :]: v for k, v in arrays.items() if k.startswith(prefix)}
            parts.append(from_arrays(d, own))
        return SegmentedSolution(parts, list(desc["phases"]))
    a = arrays
    if kind == "constant":
        return ConstantSolution(float(a["t"][0]), a["y"])
    if kind == "hermite":
        return HermiteSolution(a["t"], a["y"], a["dy"])
    if kind == "taylor":
        return TaylorDense(a["t"], a["y"], a["C"])
    if kind == "dop853":
        return DenseOutput(a["t"], a["y"], a["h"], a["F"])
    raise ValueError(f"dense kind must be one of {(*ARRAYS, 'segments')}; got {kind!r}")
