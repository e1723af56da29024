"""Parameter sweeps: many simulations over a Cartesian grid, on any executor, with checkpoints.

``sweep(top, {"mu": [...], "omega3": [...]}, t_end=20)`` runs :func:`mett.simulate` at every point
of the product grid and returns one table row per point (pandas DataFrame). Work is sent to a
``concurrent.futures.Executor`` in chunks (only ``submit`` is used), so a ``ProcessPoolExecutor``
or a Dask ``Client.get_executor()`` scale it out; the result does not depend on which executor ran
it. With ``checkpoint=path`` every finished point is appended to a JSON-lines file and flushed at
once; a rerun with the same arguments skips what is done, so a sweep killed at any moment (even
with SIGKILL) and rerun loses and duplicates nothing.
"""

from __future__ import annotations

import dataclasses
import hashlib
import importlib.util
import itertools
import json
import math
import os
import sys
import warnings
from collections.abc import Iterable, Mapping
from concurrent.futures import Executor, Future, as_completed
from pathlib import Path
from typing import IO, TYPE_CHECKING, Any, cast

import numpy as np
import pandas as pd

from . import _validate
from ._validate import MettWarning
from .dynamics import MODELS
from .friction import Viscous
from .integrals import jellett
from .state import State
from .top import TippeTop

if TYPE_CHECKING:
    from .friction import FrictionLaw

__all__ = ["GRID_NAMES", "MAX_POINTS", "CheckpointWarning", "SweepTable", "classify_end", "sweep"]

_TOP_FIELDS = tuple(f.name for f in dataclasses.fields(TippeTop))
_STATE_FIELDS = ("theta0", "thetadot", "phidot", "omega3", "nu_x", "nu_y")
_DERIVED = ("gamma", "lam_ratio")
_FRICTION = ("friction", "contensou_radius")
GRID_NAMES = (*_TOP_FIELDS, *_STATE_FIELDS, *_DERIVED, *_FRICTION)
"""Names a grid may vary: TippeTop fields, initial conditions, two derived coordinates:
``gamma`` (sets I1 = γ I3) and ``lam_ratio`` (sets ω3 so that λ = lam_ratio · λ_thres), and the
friction law: ``friction`` (names of :data:`mett.friction.LAW_NAMES`; its coefficient is ``mu``)
and ``contensou_radius`` (m, Coulomb only)."""

_CHECKPOINT_VERSION = 3
# Version 1 (mett before the checkpoint recorded its version) hashed the list of every point;
# version 2 hashes the axes; version 3 also the backend that runs the points ("auto" resolved).
# All are read: versions 1 and 2 were written by backend="auto" when it meant the compiled DOP853
# (scipy for the other methods), and resume on that backend (_legacy_auto).
_CHECKPOINT_VERSIONS = (1, 2, 3)

MAX_POINTS = 1_000_000
"""Most points a grid may have (the product of its axes' lengths), checked before any point is
built: the table holds a row per point in memory (about 1 kB each)."""


class CheckpointWarning(MettWarning):
    """A checkpoint is resumed whose rows mett cannot vouch for (written before it recorded its
    version), or on the backend that wrote it rather than the one asked for (written before it
    recorded its backend)."""


# θ within this of a pole counts as that pole when classifying a simulated end state
_POLE_TOL = 0.05
# A run has settled when, over its last _SETTLE_WINDOW (a fraction of the run), θ moved less than
# _SETTLE_THETA (rad) and the top lost less than _SETTLE_ENERGY of all the energy it lost in the
# run: the end states (spins, tumbling) are steady and dissipate nothing, while a top still
# inverting or climbing keeps losing energy at a comparable rate (measured on the thesis top:
# settled runs lose < 0.1 % of their loss in the last quarter, unsettled ones 29-74 %).
_SETTLE_WINDOW = 0.25
_SETTLE_THETA = 0.05
_SETTLE_ENERGY = 0.01

_SERIAL_CHUNK = 64  # points per step of a serial Taylor sweep: 16 SIMD batches, ~40 ms of work

NOT_SETTLED = "not settled"
"""End label of a completed run whose θ was still moving at ``t_end``: run it longer."""


def classify_end(theta_end: float, status: str, *, settled: bool = True) -> str:
    """ "upright", "inverted" or "tumbling" from the final θ.

    The run's status instead if it did not complete, and :data:`NOT_SETTLED` if it completed
    before θ settled (``settled=False``), since θ at ``t_end`` is then not an end state.

    Raises
    ------
    TypeError
        If ``status`` is not a str, or ``theta_end`` of a completed run is not a real number.
    ValueError
        If ``theta_end`` of a completed, settled run is not in [0, π] (NaN included: a completed
        run has a finite θ, so NaN is no end state to label).
    """
    if not isinstance(status, str):
        raise TypeError(f"status must be a str (a Trajectory status); got {status!r}")
    if status != "completed":
        return status
    if not settled:
        return NOT_SETTLED
    theta_end = float(_validate.theta(theta_end, "theta_end"))
    if theta_end < _POLE_TOL:
        return "upright"
    if theta_end > math.pi - _POLE_TOL:
        return "inverted"
    return "tumbling"


def _settled(end: Any) -> bool:
    """Whether θ and the energy were steady over the last quarter of the run (see above), from
    its :class:`~mett.dynamics.batch.RunEnd`."""
    if end.window.size == 0 or not end.window[-1] > end.window[0]:
        return False
    lost = abs(end.E0 - end.E_window[-1])
    late = abs(end.E_window[0] - end.E_window[-1])
    # a conservative run (nothing lost, to rounding) is judged by θ alone
    share = late / lost if lost > 1e-9 * abs(end.E0) else 0.0
    th = end.theta_window  # its range max − min (np.ptp, without its per-call overhead)
    return bool(th.max() - th.min() < _SETTLE_THETA and share < _SETTLE_ENERGY)


def _point_state(ic: dict) -> State:
    """The initial :class:`~mett.state.State` of a point's initial conditions ``ic``."""
    return State(
        theta=ic["theta0"], thetadot=ic["thetadot"], phidot=ic["phidot"],
        omega3=ic["omega3"], nu_x=ic["nu_x"], nu_y=ic["nu_y"],
    )  # fmt: skip


def _point_setup(base: dict, point: dict) -> tuple[TippeTop, dict]:
    """The top and the initial-condition values of one grid point."""
    fields = {k: base["top"][k] for k in _TOP_FIELDS}
    fields.update({k: v for k, v in point.items() if k in _TOP_FIELDS})
    if "gamma" in point:
        fields["I1"] = point["gamma"] * fields["I3"]
    top = TippeTop(**fields)
    ic = {k: base[k] for k in _STATE_FIELDS}
    ic.update({k: v for k, v in point.items() if k in _STATE_FIELDS})
    if "lam_ratio" in point:
        # λ = R I1 φ̇ sin²θ0 + R I3 ω3 (cos θ0 − α)  →  ω3 for the requested λ
        lam = point["lam_ratio"] * top.lambda_thres
        c, s = math.cos(ic["theta0"]), math.sin(ic["theta0"])
        if c == top.alpha or not math.isfinite(lam):
            raise ValueError("lam_ratio needs cos(theta0) != alpha and a finite lambda_thres")
        ic["omega3"] = (lam - top.R * top.I1 * ic["phidot"] * s * s) / (
            top.R * top.I3 * (c - top.alpha)
        )
    return top, ic


_NAN_RESULT = dict(
    t_invert=math.nan, theta_end=math.nan, omega3_end=math.nan, omega3_start=math.nan,
    lam=math.nan, lam_ratio=math.nan, gamma=math.nan, predicted="n/a", agree=False,
)  # fmt: skip
# The types of a row's result columns (checked when a checkpoint is resumed).
_ROW_TYPES: dict[str, type] = {
    **{k: float for k in _NAN_RESULT if k not in ("predicted", "agree")},
    "predicted": str, "agree": bool, "status": str, "message": str, "simulated": str,
}  # fmt: skip

# The models whose spins (θ = 0 and θ = π on the ball) are those linearised by
# mett.stability.spin_eigenvalues (the gliding ball; docs/theory/thresholds.md#thresholds: their
# stability is decided by λ alone, for any friction that dissipates gliding). A stemmed top spins
# on its stem near θ = π, so only its upright spin is checked. The other models (rolling,
# frictionless, the cylinder, the heavy symmetric top) have no such analysis in mett.
_SPIN_MODELS = {
    "gliding": ("upright", "inverted"), "gliding-euler": ("upright", "inverted"),
    "coulomb": ("upright", "inverted"), "coulomb-contensou": ("upright", "inverted"),
    "coulomb-regularised": ("upright", "inverted"), "stemmed": ("upright",),
    "stemmed-coulomb": ("upright",), "stemmed-coulomb-contensou": ("upright",),
}  # fmt: skip
# A spin counts as unstable when its largest growth rate exceeds this fraction of the largest
# eigenvalue's modulus: the eigenvalues of the 6 × 6 block are exact to a few ulps of its norm
# (complex-step Jacobian, LAPACK), so a frictionless (neutral) spin is not called unstable.
_UNSTABLE_REL = 1e-12


def _describe(exc: BaseException) -> str:
    return f"{type(exc).__name__}: {exc}"


def _law(base: dict, point: dict, top: TippeTop) -> Any:
    """The friction law of a point (None: simulate's default), from the grid's ``friction`` name
    or the sweep's ``friction=`` (a name, whose coefficient is the point's ``mu``, or a law)."""
    fixed = base["simulate_kw"].get("friction")
    law = point.get("friction", fixed)
    if law is None:
        return None
    from . import friction

    if isinstance(law, dict):  # a law given whole: friction=Coulomb(0.3), …
        fields = {k: v for k, v in law.items() if k != "law"}
        classes = {cls.__name__: cls for cls in friction.registered()}  # also laws of other modules
        return classes[law["law"]](**fields)
    r = point.get("contensou_radius", base["simulate_kw"].get("contensou_radius", 0.0))
    return friction.from_name(law, top.mu, contensou_radius=r)


def _start(base: dict, point: dict, like: tuple | None = None) -> tuple[dict, Any]:
    """The row of a grid point so far, and (top, state, simulate options, start values, model) to
    run, or None if the point's parameters are refused (the row then says why).

    ``like``: the job of an earlier point that differs from this one in ``mu`` alone. Its state and
    start values are this point's too (λ, λ_thres and γ do not depend on μ), and its top, which
    passed every check, is this one with another μ (:meth:`TippeTop._with_mu` checks μ alone,
    with the message the full check gives).
    """
    row: dict[str, Any] = dict(point)
    try:
        if like is not None:
            top, state, start = like[0]._with_mu(point["mu"]), like[1], like[3]
        else:
            top, ic = _point_setup(base, point)
            state = _point_state(ic)
            lam = float(jellett(top, state))
            start = dict(
                omega3_start=float(ic["omega3"]), lam=lam, lam_ratio=lam / top.lambda_thres,
                gamma=top.gamma,
            )  # fmt: skip
    except (ValueError, TypeError, ArithmeticError) as exc:  # an inadmissible point
        result = dict(status="invalid", message=str(exc), simulated="invalid")
        return _finish(row, point, result), None
    kw: dict[str, Any] = {}
    try:
        law = _law(base, point, top)
    except (ValueError, TypeError) as exc:  # e.g. a Contensou radius with the viscous law
        result = {**start, "status": "invalid", "message": str(exc), "simulated": "invalid"}
        return _finish(row, point, result), None
    if law is not None:
        kw["friction"] = law
    model = base["simulate_kw"].get("model", "gliding")
    return row, (top, state, kw, start, model)


def _finish(row: dict, point: dict, result: dict) -> dict:
    # the grid's own values stay exact (λ/λ_thres recomputed would differ in the last bit)
    row.update({k: v for k, v in {**_NAN_RESULT, **result}.items() if k not in point})
    return row


_PREDICTED: dict[tuple, tuple[str, tuple[str, ...]]] = {}
_PREDICTION_KEY = tuple(f for f in _TOP_FIELDS if f != "mu")


def _prediction(top: TippeTop, lam: float) -> tuple[str, tuple[str, ...]]:
    """The predicted end state's kind and, for "bistable", its candidates' kinds.

    Remembered for every (top, λ) of the process: the points of a sweep over friction, time or
    tolerance share them. The friction coefficient is left out of the key, since the end states
    and their stability do not depend on it (docs/theory/thresholds.md#thresholds: λ and the
    top's m, R, α, I1, I3, g decide them; a test checks this).
    """
    key = (*(getattr(top, f) for f in _PREDICTION_KEY), lam)
    found = _PREDICTED.get(key)
    if found is None:
        from .classification import asymptotic_state

        pred = asymptotic_state(top, lam)
        found = (pred.kind, tuple(c.kind for c in pred.candidates))
        if len(_PREDICTED) >= 4096:  # bounded: a long-lived process sweeps many grids
            _PREDICTED.clear()
        _PREDICTED[key] = found
    return found


def _unstable_spin(top: TippeTop, model: str, kw: dict, lam: float, pole: str, end: Any) -> str:
    """Why a run ending within the pole band of ``pole`` has not reached an end state ("" if the
    spin there is not unstable, or mett has no stability analysis for the model).

    A spin whose linearisation has a growing mode (:func:`mett.stability.spin_eigenvalues`) is
    left by every nearby top, slowly when the growth rate σ is small: a top seen near it at
    ``t_end`` is still escaping (e.g. θ = 0.035 rad at 4 s, tumbling by 30 s), never an end state.
    """
    if pole not in _SPIN_MODELS.get(model, ()):
        return ""
    if "lam" not in MODELS[model].conserves:  # λ changes (Contensou torque, stem impacts): at
        # the end, next to the pole, λ ≈ R I3 ω3 (cos θ − α) (the R I1 φ̇ sin²θ term is O(θ²))
        lam = top.R * top.I3 * end.omega3_end * (math.cos(end.theta_end) - top.alpha)
    # a mirror image (ω → −ω) spins with −λ and has the same stability
    lam = abs(lam)
    law = kw.get("friction")
    viscous = law is None or isinstance(law, Viscous)
    if viscous:  # the run's own linearisation
        mu = top.mu if law is None or law.mu is None else law.mu
    else:  # dry friction: the same thresholds decide; the viscous linearisation gives the sign
        mu = 1.0 if law is not None and law.mu > 0 else 0.0
    eig_top = top if mu == top.mu else dataclasses.replace(top, mu=mu)
    if not lam > 0.0:  # no spin: upright rests on the ball's bottom (stable), inverted falls
        return "" if pole == "upright" else f"θ ends near the {pole} pole without spin (unstable)"
    # Whether the spin is unstable, remembered per (top without mu, mu > 0, λ, pole): with
    # friction, the thresholds λ_0, λ_thres that decide it do not depend on mu
    # (docs/theory/thresholds.md#thresholds; a test checks the eigenvalues' signs), so a sweep over
    # friction computes the eigenvalues once.
    key = (*(getattr(top, f) for f in _PREDICTION_KEY), mu > 0.0, lam, pole)
    unstable = _UNSTABLE.get(key)
    try:
        if unstable is None:
            unstable = _growth_rate(eig_top, lam, pole) > 0.0
            if len(_UNSTABLE) >= 4096:  # bounded, as _PREDICTED
                _UNSTABLE.clear()
            _UNSTABLE[key] = unstable
        if not unstable:
            return ""
        rate = f" (growth rate {_growth_rate(eig_top, lam, pole):.3g} 1/s)" if viscous else ""
    except (ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:
        return f"the stability of the {pole} spin could not be decided ({exc})"
    return (
        f"θ ends near the {pole} spin, which is unstable at this λ{rate}: the top is still "
        "escaping from it; run longer"
    )


_UNSTABLE: dict[tuple, bool] = {}


def _growth_rate(top: TippeTop, lam: float, pole: str) -> float:
    """The largest real part σ (1/s) of the spin's eigenvalues, or 0 where it is 0 to rounding
    (a frictionless, neutral spin)."""
    from .stability import spin_eigenvalues

    ev = spin_eigenvalues(top, lam, pole)
    sigma = float(ev.real.max())
    return sigma if sigma > _UNSTABLE_REL * float(np.abs(ev).max()) else 0.0


def _row(row: dict, point: dict, job: tuple, end: Any) -> dict:
    """The row of a point from how its run ended (a RunEnd, or the exception it raised)."""
    top, _, kw, start, model = job
    if isinstance(end, (ValueError, TypeError)):  # simulate refused the point's values
        return _finish(row, point, dict(start, status="invalid", message=str(end),
                                        simulated="invalid"))  # fmt: skip
    if isinstance(end, BaseException):  # a sweep records a failing point and goes on
        return _finish(row, point, dict(start, status="error", message=_describe(end),
                                        simulated="error"))  # fmt: skip
    notes = [end.message]
    candidates: tuple[str, ...] = ()
    lam = start["lam"]
    try:
        if lam > 0:
            predicted, candidates = _prediction(top, lam)
        else:
            predicted = "n/a"
            notes.append(f"no predicted end state: lam = {lam:.6g} <= 0 (spin the other way)")
    except Exception as exc:  # the simulated result is kept
        predicted = "error"
        notes.append(f"asymptotic_state: {_describe(exc)}")
    settled = end.status != "completed" or _settled(end)
    simulated = classify_end(end.theta_end, end.status, settled=settled)
    if simulated in ("upright", "inverted"):
        why = _unstable_spin(top, model, kw, lam, simulated, end)
        if why:
            simulated = NOT_SETTLED
            notes.append(why)
    return _finish(
        row,
        point,
        dict(
            start,
            t_invert=end.t_cross,
            status=end.status,
            message="; ".join(filter(None, notes)),
            theta_end=end.theta_end,
            omega3_end=end.omega3_end,
            predicted=predicted,
            simulated=simulated,
            agree=bool(
                predicted == simulated or (predicted == "bistable" and simulated in candidates)
            ),
        ),
    )


def _run_point(base: dict, point: dict) -> dict:
    """One grid point's row. Never raises: a failure is the row's status and message.

    ``status`` is "invalid" (the point's parameters are refused: ValueError/TypeError while building
    the top or the state, or from simulate's checks), "error" (the simulation raised), or the
    simulation's own status; an exception of the prediction only sets ``predicted`` = "error" and
    keeps the simulated result.
    """
    return _run_chunk(base, [(0, point)])[0][1]


def _run_chunk(base: dict, chunk: list[tuple[int, dict]]) -> list[tuple[int, dict]]:
    """The rows of a chunk of points; runs on the Taylor backend go several at a time
    (:func:`mett.dynamics.batch.run_ends`)."""
    from .dynamics.batch import run_ends

    kw = {k: v for k, v in base["simulate_kw"].items() if k not in _FRICTION}
    started = _starts(base, chunk)
    todo = [(i, p, row, job) for i, p, row, job in started if job is not None]
    jobs = [(job[0], job[1], job[2]) for *_, job in todo]
    ends = run_ends(jobs, base["t_end"], window=_SETTLE_WINDOW, **kw)
    rows = {i: row for i, _, row, job in started if job is None}
    for (i, p, row, job), end in zip(todo, ends, strict=True):
        rows[i] = _row(row, p, job, end)
    return [(i, rows[i]) for i, _ in chunk]


def _starts(base: dict, chunk: list[tuple[int, dict]]) -> list[tuple[int, dict, dict, Any]]:
    """(index, point, row so far, job) of each point of a chunk (:func:`_start`). A point that
    differs from an earlier point of the chunk in ``mu`` alone (a sweep over friction) reuses
    that point's job: no top, state and λ built and checked again for every μ."""
    out = []
    jobs: dict[tuple, Any] = {}  # the job of each point's values other than mu
    for i, p in chunk:
        # the values as they are: 0.0 == -0.0, but a state with −0 is its own run
        key = (
            tuple((k, v, math.copysign(1.0, v) if type(v) is float else 0.0)
                  for k, v in p.items() if k != "mu")
            if "mu" in p else None
        )  # fmt: skip
        row, job = _start(base, p, jobs.get(key) if key is not None else None)
        if key is not None and job is not None:
            jobs.setdefault(key, job)
        out.append((i, p, row, job))
    return out


class _Grid:
    """The Cartesian product of the axes, point by point, never held whole (in the order of
    ``itertools.product``: the last axis varies fastest)."""

    def __init__(self, names: list[str], axes: list[list]) -> None:
        self.names, self.axes = names, axes
        self.size = math.prod(len(a) for a in axes)

    def __len__(self) -> int:
        return self.size

    def __iter__(self):
        return (dict(zip(self.names, c, strict=True)) for c in itertools.product(*self.axes))

    def point(self, index: int) -> dict:
        values = []
        for axis in reversed(self.axes):
            index, k = divmod(index, len(axis))
            values.append(axis[k])
        return dict(zip(self.names, reversed(values), strict=True))


def _grid(grid: Mapping[str, Any]) -> _Grid:
    if not isinstance(grid, Mapping) or not grid:
        raise ValueError("grid must be a non-empty mapping of name -> 1-D array of values")
    names = list(grid)
    unknown = [n for n in names if n not in GRID_NAMES]
    if unknown:
        raise ValueError(f"unknown grid name(s) {unknown}; known: {', '.join(GRID_NAMES)}")
    if "gamma" in names and "I1" in names:
        raise ValueError("grid may vary gamma or I1, not both")
    if "lam_ratio" in names and "omega3" in names:
        raise ValueError("grid may vary lam_ratio or omega3, not both")
    axes = []
    for n in names:
        if n == "friction":
            from .friction import LAW_NAMES

            laws = list(grid[n]) if not isinstance(grid[n], str) else [grid[n]]
            bad = [v for v in laws if not isinstance(v, str) or v not in LAW_NAMES]
            if bad or not laws:
                raise ValueError(f"grid['friction'] must name laws of {LAW_NAMES}; got {bad!r}")
            axes.append(laws)
            continue
        arr = _validate.as_finite_array(n, grid[n])
        if arr.ndim != 1 or arr.size == 0:
            raise ValueError(f"grid[{n!r}] must be a non-empty 1-D array; got shape {arr.shape}")
        axes.append([float(v) for v in arr])
    size = math.prod(len(a) for a in axes)  # before any point is built
    if size > MAX_POINTS:
        shape = " x ".join(str(len(a)) for a in axes)
        raise ValueError(
            f"grid has {shape} = {size} points; at most MAX_POINTS = {MAX_POINTS} (split the "
            "sweep into several)"
        )
    return _Grid(names, axes)


def _signature(
    base: dict, grid: _Grid, version: int = _CHECKPOINT_VERSION, backend: str | None = None
) -> str:
    """The hash of a sweep's arguments: of the axes and the backend that runs the points
    (version 3), of the axes (version 2), or of the list of every point (version 1, as large as
    the grid); versions 1 and 2 for checkpoints written before."""
    if version == 1:
        doc: dict[str, Any] = {"base": base, "names": grid.names, "points": list(grid)}
    else:
        doc = {"base": base, "names": grid.names, "axes": grid.axes, "version": version}
        if version >= 3:  # the backend that runs, whether asked for by name or by "auto"
            kw = {k: v for k, v in base["simulate_kw"].items() if k != "backend"}
            doc.update(base={**base, "simulate_kw": kw}, backend=backend)
    return hashlib.sha256(json.dumps(doc, sort_keys=True).encode()).hexdigest()


def _legacy_auto(simulate_kw: dict) -> str:
    """The backend ``backend="auto"`` ran before checkpoints recorded it (formats 1 and 2): the
    compiled DOP853, or scipy for the other methods of solve_ivp."""
    return "compiled" if simulate_kw.get("method", "DOP853") == "DOP853" else "scipy"


def _checkpoint_path(value: Any) -> Path:
    """A checkpoint path: writable, and a regular file if it exists (a FIFO would block the
    open, a device or /dev/stdout cannot be read back)."""
    import stat

    if isinstance(value, (str, os.PathLike)) and not isinstance(value, bytes) and os.fspath(value):
        path = Path(value)
        for p in (os.path.abspath(path), os.path.realpath(path)):
            if p == "/dev" or p.startswith(("/dev/", "/proc/")):
                raise ValueError(f"checkpoint must be a regular file; got {str(path)!r}")
        try:
            mode = path.stat().st_mode
        except OSError:  # missing (or unreadable: output_path says so)
            mode = None
        if mode is not None and not stat.S_ISREG(mode) and not stat.S_ISDIR(mode):
            kind = "a FIFO" if stat.S_ISFIFO(mode) else "not a regular file"
            raise ValueError(f"checkpoint must be a regular file; {str(path)!r} is {kind}")
    return _validate.output_path("checkpoint", value)


def _append(fh: IO[str], line: str) -> None:
    """Write one line and make it durable before the next (a crash leaves whole lines)."""
    fh.write(line)
    fh.flush()
    os.fsync(fh.fileno())


class _Checkpoint:
    """JSON-lines file: a header with the format version, mett's version and the arguments'
    signature, then one finished point a line.

    An existing file is read and checked (header, signature, every record against its point)
    before anything is written to it, so a file that is not this sweep's checkpoint is never
    modified, and a record that is not what this sweep would have written is never resumed.
    """

    def __init__(self, path: Path, base: dict, grid: _Grid, summary: dict, backend: str) -> None:
        from . import __version__

        self.path = path
        self.done: dict[int, dict] = {}
        self._failed = False
        self.backend: str | None = None  # the backend an older checkpoint makes the sweep use
        if path.exists() and path.stat().st_size > 0:
            self._load(base, grid, __version__, backend)
        else:
            header = {
                "mett_sweep": _CHECKPOINT_VERSION, "mett": __version__,
                "signature": _signature(base, grid, backend=backend), "backend": backend,
                "args": summary,
            }  # fmt: skip
            # "x": a file created by someone else since the check is not overwritten
            fh = open(path, "w" if path.exists() else "x", encoding="utf-8")
            try:
                self._guard(lambda: _append(fh, json.dumps(header) + "\n"))
            finally:
                self._fh = fh
                self.close()
        self._fh = open(path, "a", encoding="utf-8")

    def _damaged(self, lineno: int, line: bytes, why: str) -> ValueError:
        return ValueError(
            f"{self.path}, line {lineno}: damaged checkpoint record ({why}): {line[:80]!r}; "
            "delete that line (the point will be rerun) or the file"
        )

    def _load(self, base: dict, grid: _Grid, version: str, backend: str) -> None:
        raw = self.path.read_bytes()
        lines = raw.split(b"\n")
        complete, tail = lines[:-1], lines[-1]
        not_ours = (
            f"{self.path} exists and is not a mett sweep checkpoint; it was left untouched "
            "(choose another checkpoint path)"
        )
        try:
            header = json.loads(complete[0])
        except (IndexError, UnicodeDecodeError, json.JSONDecodeError, RecursionError):
            raise ValueError(not_ours) from None
        if not isinstance(header, dict) or "mett_sweep" not in header:
            raise ValueError(not_ours)
        fmt = header["mett_sweep"]
        if type(fmt) is not int or fmt not in _CHECKPOINT_VERSIONS:
            raise ValueError(
                f"checkpoint {self.path} has format version {fmt!r}, which this mett does not "
                f"read (it reads {', '.join(map(str, _CHECKPOINT_VERSIONS))}); it was left "
                "untouched"
            )
        written_by = header.get("mett")
        if fmt >= 2 and written_by != version:
            raise ValueError(
                f"checkpoint {self.path} was written by mett {written_by!r}, this is mett "
                f"{version}: its rows may differ from what this version computes; resume with "
                "that version, or use another path (or delete it) to run the sweep afresh"
            )
        self._check_signature(header, base, grid, fmt, backend)
        if fmt == 1:
            _validate.warn(
                f"checkpoint {self.path} was written by a mett that did not record its version; "
                "its rows are resumed as they are (delete the file to recompute them)",
                CheckpointWarning,
            )
        done: dict[int, dict] = {}
        first_line: dict[int, int] = {}
        for lineno, line in enumerate(complete[1:], start=2):
            if not line.strip():
                continue
            try:
                rec = json.loads(line)
            except (UnicodeDecodeError, json.JSONDecodeError):
                raise self._damaged(lineno, line, "not JSON") from None
            except RecursionError:
                raise self._damaged(lineno, line, "nested too deeply") from None
            index, row = self._check_record(rec, grid, lineno, line)
            if index in done:
                if _canonical(row) != _canonical(done[index]):
                    raise ValueError(
                        f"{self.path}, lines {first_line[index]} and {lineno}: two different "
                        f"records of point {index}; delete one (or both: the point is rerun)"
                    )
                continue
            done[index], first_line[index] = row, lineno
        # Only now, with the file known to be ours: a kill in the middle of a write leaves a
        # partial last line; cut it off (its point is rerun).
        if tail:
            with open(self.path, "r+b") as fh:
                fh.truncate(len(raw) - len(tail))
        self.done = done

    def _check_signature(
        self, header: dict, base: dict, grid: _Grid, fmt: int, backend: str
    ) -> None:
        """The header's signature against this sweep's: the same arguments, and the same
        backend, or a clear refusal; never a silent mix of backends in one table. A checkpoint
        of format 1 or 2 recorded no backend: with ``backend="auto"`` (or none) it was written
        by :func:`_legacy_auto`'s backend, which then runs the rest (``self.backend``)."""
        signature = header.get("signature")
        other = (
            f"checkpoint {self.path} was written for different sweep arguments "
            f"({header.get('args')}); use another path or delete it"
        )
        kw = base["simulate_kw"]
        if fmt >= 3:
            if signature == _signature(base, grid, fmt, backend):
                return
            written = header.get("backend")
            if isinstance(written, str) and signature == _signature(base, grid, fmt, written):
                raise ValueError(
                    f"checkpoint {self.path} was written by backend {written!r}, and this sweep "
                    f"would run backend {backend!r}: resume it with backend={written!r} (the "
                    "option of mett.sweep, --backend of the CLI), or use another path"
                )
            raise ValueError(other)
        asked = kw.get("backend", "auto")
        if signature == _signature(base, grid, fmt):
            if asked == "auto":  # written by what "auto" meant then: go on with that
                self.backend = _legacy_auto(kw)
                _validate.warn(
                    f"checkpoint {self.path} was written before mett recorded the backend, by "
                    f"backend={self.backend!r} (what backend='auto' ran then); its remaining "
                    f"points run on that backend too (a new path runs the sweep with 'auto')",
                    CheckpointWarning,
                )
            return  # an explicit backend: the one that wrote it
        bare = {**base, "simulate_kw": {k: v for k, v in kw.items() if k != "backend"}}
        if signature == _signature(bare, grid, fmt):  # written with backend="auto" (or none)
            legacy = _legacy_auto(kw)
            if asked == legacy:
                return
            raise ValueError(
                f"checkpoint {self.path} was written by backend {legacy!r} (backend='auto' "
                f"before mett recorded the backend), and this sweep asks backend={asked!r}: "
                f"resume it with backend={legacy!r} or without the backend option, or use "
                "another path"
            )
        raise ValueError(other)

    def _check_record(self, rec: Any, grid: _Grid, lineno: int, line: bytes) -> tuple[int, dict]:
        """(index, row) of a record, if it is exactly what this sweep writes for that point."""
        if not isinstance(rec, dict) or set(rec) != {"index", "row"}:
            raise self._damaged(lineno, line, 'not {"index": ..., "row": {...}}')
        index, row = rec["index"], rec["row"]
        if type(index) is not int or not 0 <= index < len(grid):
            raise self._damaged(lineno, line, f"index must be an integer in [0, {len(grid)})")
        if not isinstance(row, dict):
            raise self._damaged(lineno, line, "row is not an object")
        point = grid.point(index)
        expected = set(point) | set(_ROW_TYPES)
        if set(row) != expected:
            extra, missing = sorted(set(row) - expected), sorted(expected - set(row))
            raise self._damaged(lineno, line, f"columns missing {missing}, unexpected {extra}")
        for key, value in point.items():
            if type(row[key]) is not type(value) or row[key] != value:
                raise self._damaged(
                    lineno, line, f"{key} = {row[key]!r}, but point {index} has {value!r}"
                )
        for key, kind in _ROW_TYPES.items():
            if key not in point and type(row[key]) is not kind:
                raise self._damaged(lineno, line, f"{key} must be a {kind.__name__}")
        return index, row

    def _guard(self, write: Any) -> None:
        """Run ``write``; an OSError (a full disk, …) names the checkpoint, and later errors of
        the same file (its close) are not allowed to hide it."""
        try:
            write()
        except OSError as exc:
            self._failed = True
            raise OSError(
                exc.errno, f"cannot write the checkpoint: {exc.strerror or exc}", str(self.path)
            ) from exc

    def write(self, index: int, row: dict) -> None:
        line = json.dumps({"index": index, "row": row}) + "\n"
        self._guard(lambda: _append(self._fh, line))
        self.done[index] = row

    def close(self) -> None:
        try:
            self._fh.close()
        except OSError:
            if not self._failed:  # else the first error is the one to report
                raise


def _canonical(row: dict) -> str:
    return json.dumps(row, sort_keys=True)


def _want_progress(progress: bool | None) -> bool:
    """Resolve ``progress`` before any work: None means "if stderr is a terminal and tqdm exists"."""
    # tqdm is looked for only where a bar is wanted (the search of sys.path costs ~60 µs)
    if progress is None:
        try:
            interactive = sys.stderr is not None and sys.stderr.isatty()
        except (AttributeError, ValueError):  # a closed or replaced stderr
            interactive = False
        return interactive and importlib.util.find_spec("tqdm") is not None
    if progress and importlib.util.find_spec("tqdm") is None:
        raise ValueError("progress=True needs tqdm: pip install 'mett[progress]'")
    return progress


def _progress_bar(total: int, initial: int):
    from tqdm import tqdm

    return tqdm(total=total, initial=initial, desc="sweep", unit="run")


def _plain(value: Any) -> Any:
    """numpy scalars and arrays as Python numbers and lists (for the checkpoint's JSON)."""
    import numpy as np

    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    return value


def _friction_option(friction: Any, contensou_radius: Any, names: list[str]) -> dict:
    """The sweep's fixed friction (``friction=``, ``contensou_radius=``) as plain values for the
    checkpoint, refused where a grid axis sets it instead."""
    from . import friction as laws

    out: dict[str, Any] = {}
    if friction is not None:
        if "friction" in names:
            raise ValueError(
                "friction= and a grid axis 'friction' both set the friction law; give one"
            )
        if isinstance(friction, str):
            if friction not in laws.LAW_NAMES:
                raise ValueError(
                    f"friction must be one of {laws.LAW_NAMES} or a law; got {friction!r}"
                )
            out["friction"] = friction
        else:
            law = laws.check_law(friction)
            fields = dataclasses.asdict(cast(Any, law))  # every registered law is a dataclass
            if fields.get("mu") is not None and "mu" in names:
                raise ValueError(
                    f"friction={laws.describe(law)} fixes mu, so the grid axis 'mu' would be "
                    "ignored; give friction='viscous' or 'coulomb' (mu from the grid) instead"
                )
            out["friction"] = {"law": type(law).__name__, **fields}
            if "contensou_radius" in names:
                raise ValueError(
                    f"friction={laws.describe(law)} is a law given whole, with its own "
                    "contensou_radius, so the grid axis 'contensou_radius' would be ignored; give "
                    "friction='coulomb' (the radius from the grid) instead"
                )
    by_name = out.get("friction") == "coulomb" or "friction" in names
    if "contensou_radius" in names and not by_name:
        raise ValueError(
            "a grid axis 'contensou_radius' needs the Coulomb law by name: give "
            f"friction='coulomb' (or a grid axis 'friction'); got friction={friction!r}"
        )
    if contensou_radius is not None:
        if "contensou_radius" in names:
            raise ValueError(
                "contensou_radius= and a grid axis 'contensou_radius' both set the radius; give one"
            )
        if isinstance(out.get("friction"), dict):
            raise ValueError(
                "contensou_radius= is for a law given by name; a Coulomb law given whole carries "
                "its own contensou_radius"
            )
        if out.get("friction") != "coulomb" and "friction" not in names:
            raise ValueError(
                "contensou_radius= applies to the Coulomb law: give friction='coulomb' (or a "
                f"grid axis 'friction'); got friction={friction!r}"
            )
        out["contensou_radius"] = _validate.positive_scalar(
            "contensou_radius", contensou_radius, allow_zero=True
        )
    return out


def _probe_options(base: dict, grid: _Grid) -> str:
    """Let :func:`mett.simulate` check the options (model, rtol, atol, backend, …) before any run,
    and return the backend that runs the points (``"auto"`` resolved; for a ``friction`` axis,
    ``"law:backend"`` per law, joined by ``+``, when they differ).

    Makes simulate's own checks, without integrating (:func:`mett.dynamics.simulation.check_run`),
    at the first grid point whose values simulate accepts, so ``rtol=2.0`` or ``model="nope"``
    is refused once, with simulate's own message, instead of making every row "invalid". A point
    refused by the same checks with simulate's default options is the point's fault, whatever its
    place in the grid: its row is "invalid". ``t_eval`` (which must fit the full ``t_end``) is
    checked here.
    """
    import numpy as np

    from .dynamics.simulation import check_run

    kw = {k: v for k, v in base["simulate_kw"].items() if k not in _FRICTION}
    if "events" in kw:
        raise ValueError("a sweep cannot pass events to simulate (they cannot be checkpointed)")
    t_eval = kw.pop("t_eval", None)
    if t_eval is not None:
        te = _validate.as_finite_array("t_eval", t_eval)
        if te.ndim != 1 or te.size == 0 or te[0] < 0 or te[-1] > base["t_end"]:
            raise ValueError(
                f"t_eval must be a non-empty 1-D array within [0, t_end] = [0, {base['t_end']!r}]"
            )
        if np.any(np.diff(te) <= 0):
            raise ValueError("t_eval must be strictly increasing")
    asked = str(kw.get("backend", "auto"))

    def setup(point: dict) -> tuple[Any, Any, dict] | None:
        try:
            top, ic = _point_setup(base, point)
            state = _point_state(ic)
            law = _law(base, point, top)
        except (ValueError, TypeError, ArithmeticError):
            return None  # an invalid point: it becomes an "invalid" row
        return top, state, ({} if law is None else {"friction": law})

    for point in grid:
        got = setup(point)
        if got is None:
            continue  # probe the next one
        top, state, own = got
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # each run reports its own warnings
            try:  # what simulate checks before its first step, without integrating
                backend = check_run(top, state, base["t_end"], **kw, **own)
            except (ValueError, TypeError) as exc:
                try:  # the point's own values, or the options?
                    check_run(top, state, base["t_end"])
                except (ValueError, TypeError):
                    continue  # the point: an "invalid" row
                except Exception:
                    pass
                raise type(exc)(f"invalid simulate option for the sweep: {exc}") from None
            except Exception:  # a run-time failure is the rows' business
                return asked
            if "friction" not in grid.names:
                return backend
            # "auto" may choose per law: record each law's backend
            chosen = {}
            for name in grid.axes[grid.names.index("friction")]:
                other = setup({**point, "friction": name})
                try:
                    chosen[name] = (
                        asked
                        if other is None
                        else check_run(other[0], other[1], base["t_end"], **kw, **other[2])
                    )
                except Exception:  # that law's points report it in their rows
                    chosen[name] = asked
        if len(set(chosen.values())) == 1:
            return next(iter(chosen.values()))
        return "+".join(f"{name}:{b}" for name, b in sorted(chosen.items()))
    return asked


_STATE_DEFAULTS = dict(theta0=0.1, thetadot=0.0, phidot=0.0, omega3=155.0, nu_x=0.0, nu_y=0.0)


def sweep(
    top: TippeTop,
    grid: Mapping[str, Iterable[float]],
    *,
    t_end: float,
    theta0: float | None = None,
    thetadot: float | None = None,
    phidot: float | None = None,
    omega3: float | None = None,
    nu_x: float | None = None,
    nu_y: float | None = None,
    executor: Executor | None = None,
    progress: bool | None = None,
    checkpoint: str | os.PathLike | None = None,
    chunksize: int | None = None,
    friction: str | FrictionLaw | None = None,
    contensou_radius: float | None = None,
    **simulate_kw: Any,
) -> pd.DataFrame:
    """Simulate every point of a Cartesian grid of parameters and initial conditions.

    Parameters
    ----------
    top : TippeTop
        The base top; grid entries override its fields.
    grid : mapping of str to 1-D array
        Names from :data:`GRID_NAMES` (TippeTop fields, initial conditions, ``gamma``,
        ``lam_ratio``, ``friction``, ``contensou_radius``) to the values to run; the Cartesian
        product is swept. At most :data:`MAX_POINTS` points (checked before any is built).
    t_end : float
        Simulated time of every run (s).
    theta0, thetadot, phidot, omega3, nu_x, nu_y : float, optional
        Initial conditions where the grid does not set them (default: the thesis start, θ0 = 0.1
        rad, ω3 = 155 rad/s, the rest 0). One the grid sets (``omega3`` with a ``lam_ratio`` axis,
        which sets ω3; ``theta0`` with a ``theta0`` axis, …) is refused: it would be ignored.
    executor : concurrent.futures.Executor, optional
        Where to run: a ``ProcessPoolExecutor``, a Dask ``Client.get_executor()``, …; serial when
        None. Only ``submit`` is used (it must return a ``concurrent.futures.Future``); points
        travel in chunks of ``chunksize``.
    progress : bool or None, default None
        A tqdm progress bar on stderr (optional dependency ``mett[progress]``). None: a bar when
        stderr is a terminal and tqdm is installed, none in scripts, logs and notebooks' captured
        output; True insists (ValueError without tqdm); False never.
    checkpoint : path, optional
        JSON-lines file of finished points (a regular file); rerunning with the same arguments
        and the same mett version resumes. An existing file that is not this sweep's checkpoint
        is refused and left untouched; so is one written by another mett version. Its header
        records the backend that ran the points: a resume runs the rest on the same one, or is
        refused naming the ``backend`` option to give (a checkpoint from before the backend was
        recorded was written by the compiled DOP853, and resumes on it with a
        :class:`CheckpointWarning`).
    chunksize : int, optional
        Points per task sent to ``executor`` (default: about 1/32 of the grid), >= 1; without an
        executor, points run (and are checkpointed) this many at a time (default 1, and 64
        when the points run on the Taylor backend). On the Taylor backend (what the default
        ``backend="auto"`` runs wherever the model allows, :func:`mett.simulate`) the points of
        a task run side by side, four per SIMD batch (:func:`mett.dynamics.batch.run_ends`):
        the fastest way through a grid.
    friction : str or friction law, optional
        One friction law for the whole sweep: a name of :data:`mett.friction.LAW_NAMES`, whose
        coefficient is each point's ``mu`` (so ``mu`` may be a grid axis), or a law such as
        ``Coulomb(0.3)`` (then ``mu`` may not be an axis). Default: simulate's (viscous, ``mu``).
    contensou_radius : float, optional
        Contact-disc radius (m) of ``friction="coulomb"`` for the whole sweep.
    **simulate_kw
        Passed to :func:`mett.simulate` (``model``, ``rtol``, …); checked once, before the first
        run, by simulate's own checks at the first grid point simulate accepts.

    Returns
    -------
    pandas.DataFrame
        One row per grid point, in grid order: the grid values, ``t_invert`` (first θ = π/2, NaN
        if never), ``status``, ``theta_end``, ``omega3_end``, ``lam``, ``lam_ratio`` (λ/λ_thres),
        ``predicted`` (:func:`mett.asymptotic_state` kind; "n/a" with a ``message`` if λ <= 0),
        ``simulated`` (kind read off θ_end, or "not settled" if θ still moved over the last
        quarter of the run or it ended near an unstable spin), ``agree`` (for a "bistable"
        prediction: the run ended in one of its two stable states), and ``message``. A point that
        fails is a row too: status "invalid" (its parameters are refused), "error" (the
        simulation raised; ``message`` says what) or the run's own status ("failed",
        "contact_lost") with the partial run's end values; the sweep goes on.
        ``table.attrs["top"]`` holds the fields of ``top`` (a dict; grid axes override them per
        row), which :func:`mett.plotting.plot_phase_diagram` reads α from.

    Raises
    ------
    ValueError, TypeError
        Before any run or write: unknown grid names, bad values or options (``rtol``, ``model``,
        ``chunksize``, an option a grid axis overrides, …), a grid of more than
        :data:`MAX_POINTS` points, a checkpoint path in a missing directory or that is not a
        regular file, or an existing file that is not this sweep's checkpoint (left untouched) or
        has a damaged record (path and line named). ``TypeError`` if ``executor.submit`` does
        not return a ``concurrent.futures.Future``.
    OSError
        A checkpoint that cannot be written (a full disk): the error names the file; every point
        recorded before it is kept, and a rerun resumes there.
    """
    if not isinstance(top, TippeTop):
        raise TypeError(f"top must be a TippeTop; got {type(top).__name__}")
    t_end = _validate.positive_scalar("t_end", t_end)
    if executor is not None and not callable(getattr(executor, "submit", None)):
        raise TypeError(
            f"executor must be a concurrent.futures.Executor (with submit); got {type(executor).__name__}"
        )
    if chunksize is not None:
        chunksize = _validate.positive_int("chunksize", chunksize)
    if progress is not None:
        progress = _validate.boolean("progress", progress)
    ckpt_path = None if checkpoint is None else _checkpoint_path(checkpoint)
    grid_ = _grid(grid)
    names = grid_.names
    given = dict(theta0=theta0, thetadot=thetadot, phidot=phidot, omega3=omega3, nu_x=nu_x,
                 nu_y=nu_y)  # fmt: skip
    for name, value in given.items():
        if value is None:
            continue
        overridden = "lam_ratio" if name == "omega3" and "lam_ratio" in names else name
        if overridden in names:
            raise ValueError(
                f"{name}={value!r} is ignored when the grid varies {overridden!r} (it sets "
                f"{name} at every point); leave {name} out"
            )
    _check_mu_axis(names, simulate_kw.get("model"))
    start = {k: _STATE_DEFAULTS[k] if v is None else v for k, v in given.items()}
    base: dict[str, Any] = {
        "top": dataclasses.asdict(top),
        "t_end": t_end,
        "theta0": float(_validate.theta(start["theta0"], "theta0")),
        **{k: _validate.finite_scalar(k, start[k]) for k in _STATE_FIELDS if k != "theta0"},
        "simulate_kw": {
            **{k: _plain(v) for k, v in simulate_kw.items()},
            **_friction_option(friction, contensou_radius, names),
        },
    }
    backend = _probe_options(base, grid_)
    try:
        json.dumps(base["simulate_kw"])
    except (TypeError, ValueError):
        raise ValueError(
            "simulate options of a sweep must be plain values (numbers, strings, arrays): they "
            f"are recorded in the checkpoint; got {simulate_kw!r}"
        ) from None
    show_progress = _want_progress(progress)
    ckpt = None
    n = len(grid_)
    if ckpt_path is not None:
        summary = {"names": names, "n_points": n, "t_end": t_end}
        ckpt = _Checkpoint(ckpt_path, base, grid_, summary, backend)
        if ckpt.backend is not None:  # an older checkpoint: its backend runs the rest
            base["simulate_kw"]["backend"] = backend = ckpt.backend
    done = dict(ckpt.done) if ckpt else {}
    todo = ((i, p) for i, p in enumerate(grid_) if i not in done)
    bar = _progress_bar(n, len(done)) if show_progress else None
    results = dict(done)

    def finish(pairs: list[tuple[int, dict]]) -> None:
        for i, row in pairs:
            results[i] = row
            if ckpt:
                ckpt.write(i, row)
        if bar is not None:
            bar.update(len(pairs))

    try:
        if executor is None:
            # the Taylor backend runs a few points at a time, side by side in SIMD lanes; the
            # others one at a time (each checkpointed as soon as it is done)
            batched = backend == "taylor" or ":taylor" in backend  # (per law on a friction axis)
            size = chunksize or (_SERIAL_CHUNK if batched else 1)
            for chunk in iter(lambda: list(itertools.islice(todo, size)), []):
                finish(_run_chunk(base, chunk))
        else:
            size = chunksize or max(1, math.ceil((n - len(done)) / 32))
            futures: list[Future] = []
            for chunk in iter(lambda: list(itertools.islice(todo, size)), []):
                fut = executor.submit(_run_chunk, base, chunk)
                if not isinstance(fut, Future):
                    raise TypeError(
                        "executor.submit must return a concurrent.futures.Future; "
                        f"{type(executor).__name__}.submit returned {type(fut).__name__}"
                    )
                futures.append(fut)
            # A chunk whose task failed (a worker died, the executor shut down) is not recorded,
            # so a rerun redoes it; every other chunk is still collected and checkpointed first.
            failures: list[BaseException] = []
            try:
                for fut in as_completed(futures):
                    try:
                        pairs = fut.result()
                    except Exception as exc:
                        failures.append(exc)
                        continue
                    finish(pairs)
            except BaseException:  # an interrupt: the chunks not yet started are not run
                for fut in futures:
                    fut.cancel()
                raise
            if failures:
                raise failures[0]
    finally:
        if ckpt:
            ckpt.close()
        if bar is not None:
            bar.close()
    records = [results[i] for i in range(n)]
    results_first = ["t_invert", "status", "theta_end", "omega3_end", "lam", "lam_ratio",
                     "predicted", "simulated", "agree"]  # fmt: skip
    first = names + [c for c in results_first if c not in names]
    # the other columns in the order the rows first name them (built in that order directly:
    # reordering a finished table copies it)
    rest = list(dict.fromkeys(c for row in records for c in row if c not in first))
    table = SweepTable(records, columns=first + rest)
    table.attrs["top"] = dataclasses.asdict(top)  # the base top (its α for plot_phase_diagram)
    table.attrs["mett_sweep"] = _provenance(base, names, friction, backend)
    return table


def _check_mu_axis(names: list[str], model: Any) -> None:
    """Refuse a grid axis ``mu`` on a model that conserves the energy: no friction acts on it (the
    rolling top, the frictionless one), so every point along the axis would be the same run."""
    from .dynamics import MODELS

    if "mu" in names and isinstance(model, str) and model in MODELS:
        if "E" in MODELS[model].conserves:
            raise ValueError(
                f"the grid axis 'mu' has no effect on model={model!r}, which conserves the energy "
                "(no friction acts on it): every point would be the same run; leave the axis out"
            )


def _provenance(base: dict, names: list[str], friction: Any, backend: str) -> dict:
    """What a sweep ran, for its table's exports (``table.attrs["mett_sweep"]``)."""
    from . import __version__
    from .friction import describe

    kw = base["simulate_kw"]
    law = friction if friction is None or isinstance(friction, str) else describe(friction)
    if "friction" in names:
        law = "per point (grid axis 'friction', coefficient the top's mu)"
    return {
        "mett_version": __version__, "grid": list(names), "t_end": base["t_end"],
        "model": kw.get("model", "gliding"), "friction": law or "viscous (the top's mu)",
        "backend": backend, "rtol": kw.get("rtol", 1e-10), "atol": kw.get("atol"),
        "top": {k: float(v) for k, v in base["top"].items()},
        "initial_state": {k: float(base[k]) for k in _STATE_FIELDS},
    }  # fmt: skip


class SweepTable(pd.DataFrame):
    """The table of :func:`sweep`: a :class:`pandas.DataFrame` (one row per grid point) that also
    exports to xarray with the grid axes as dimensions. ``attrs["mett_sweep"]`` records what the
    sweep ran (grid axes, t_end, model, friction, backend, rtol, the base top and start, mett
    version)."""

    @property
    def _constructor(self) -> type:
        return SweepTable

    def to_xarray(self, dims: list[str] | None = None) -> Any:
        """The table as an :class:`xarray.Dataset` (optional extra ``mett[xarray]``).

        Parameters
        ----------
        dims : list of str, optional
            The grid axes, the dataset's dimensions (default: the sweep's own).

        Returns
        -------
        xarray.Dataset
            One variable per result column over the grid (points the table lacks are NaN), with
            ``units`` and ``long_name``; the sweep's settings (mett version, model, friction,
            backend, rtol, t_end, the base top ``top_<name>`` and start ``initial_<name>``, with
            ``<name>_units``) as attributes.

        Raises
        ------
        ValueError
            If ``dims`` are not columns, or the grid repeats a point.
        """
        from .dynamics._export import sweep_to_xarray

        return sweep_to_xarray(self, dims)

    def to_netcdf(self, path: str | os.PathLike) -> Path:
        """Write :meth:`to_xarray` to a NetCDF file (``.nc``, netCDF-3, scipy's writer)."""
        from .dynamics._export import check_nc_path, sweep_to_xarray, to_netcdf

        check_nc_path(path)
        return to_netcdf(sweep_to_xarray(self), path)
