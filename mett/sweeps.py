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
from typing import Any

import pandas as pd

from . import _validate
from .top import TippeTop

__all__ = ["GRID_NAMES", "classify_end", "sweep"]

_TOP_FIELDS = tuple(f.name for f in dataclasses.fields(TippeTop))
_STATE_FIELDS = ("theta0", "thetadot", "phidot", "omega3", "nu_x", "nu_y")
_DERIVED = ("gamma", "lam_ratio")
_FRICTION = ("friction", "contensou_radius")
GRID_NAMES = (*_TOP_FIELDS, *_STATE_FIELDS, *_DERIVED, *_FRICTION)
"""Names a grid may vary: TippeTop fields, initial conditions, two derived coordinates:
``gamma`` (sets I1 = γ I3) and ``lam_ratio`` (sets ω3 so that λ = lam_ratio · λ_thres), and the
friction law: ``friction`` (names of :data:`mett.friction.LAW_NAMES`; its coefficient is ``mu``)
and ``contensou_radius`` (m, Coulomb only)."""

_CHECKPOINT_VERSION = 1
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
    import numpy as np

    if end.window.size == 0 or not end.window[-1] > end.window[0]:
        return False
    lost = abs(end.E0 - end.E_window[-1])
    late = abs(end.E_window[0] - end.E_window[-1])
    # a conservative run (nothing lost, to rounding) is judged by θ alone
    share = late / lost if lost > 1e-9 * abs(end.E0) else 0.0
    return bool(np.ptp(end.theta_window) < _SETTLE_THETA and share < _SETTLE_ENERGY)


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


def _describe(exc: BaseException) -> str:
    return f"{type(exc).__name__}: {exc}"


def _start(base: dict, point: dict) -> tuple[dict, Any]:
    """The row of a grid point so far, and (top, state, simulate options, start values) to run,
    or None if the point's parameters are refused (the row then says why)."""
    from . import friction
    from .integrals import jellett
    from .state import State

    row: dict[str, Any] = dict(point)
    try:
        top, ic = _point_setup(base, point)
        state = State(
            theta=ic["theta0"], thetadot=ic["thetadot"], phidot=ic["phidot"],
            omega3=ic["omega3"], nu_x=ic["nu_x"], nu_y=ic["nu_y"],
        )  # fmt: skip
        lam = float(jellett(top, state))
        start = dict(
            omega3_start=float(ic["omega3"]), lam=lam, lam_ratio=lam / top.lambda_thres,
            gamma=top.gamma,
        )  # fmt: skip
    except (ValueError, TypeError, ArithmeticError) as exc:  # an inadmissible point
        result = dict(status="invalid", message=str(exc), simulated="invalid")
        return _finish(row, point, result), None
    kw: dict[str, Any] = {}
    law = point.get("friction", base["simulate_kw"].get("friction"))
    if law is not None:  # a law name: its coefficient is the point's mu
        r = point.get("contensou_radius", base["simulate_kw"].get("contensou_radius", 0.0))
        try:
            kw["friction"] = friction.from_name(law, top.mu, contensou_radius=r)
        except Exception as exc:  # as if the simulation had raised it
            result = dict(start, status="error", message=_describe(exc), simulated="error")
            return _finish(row, point, result), None
    return row, (top, state, kw, start)


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
    from .thresholds import asymptotic_state

    key = (*(getattr(top, f) for f in _PREDICTION_KEY), lam)
    found = _PREDICTED.get(key)
    if found is None:
        pred = asymptotic_state(top, lam)
        found = (pred.kind, tuple(c.kind for c in pred.candidates))
        if len(_PREDICTED) >= 4096:  # bounded: a long-lived process sweeps many grids
            _PREDICTED.clear()
        _PREDICTED[key] = found
    return found


def _row(row: dict, point: dict, job: tuple, end: Any) -> dict:
    """The row of a point from how its run ended (a RunEnd, or the exception it raised)."""
    top, _, _, start = job
    if isinstance(end, BaseException):  # a sweep records a failing point and goes on
        return _finish(row, point, dict(start, status="error", message=_describe(end),
                                        simulated="error"))  # fmt: skip
    message = end.message
    candidates: tuple[str, ...] = ()
    try:
        lam = start["lam"]
        predicted, candidates = _prediction(top, lam) if lam > 0 else ("n/a", ())
    except Exception as exc:  # the simulated result is kept
        predicted = "error"
        message = "; ".join(filter(None, [message, f"asymptotic_state: {_describe(exc)}"]))
    settled = end.status != "completed" or _settled(end)
    simulated = classify_end(end.theta_end, end.status, settled=settled)
    return _finish(
        row,
        point,
        dict(
            start,
            t_invert=end.t_cross,
            status=end.status,
            message=message,
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
    the top or the state), "error" (the simulation raised), or the simulation's own status; an
    exception of the prediction only sets ``predicted`` = "error" and keeps the simulated result.
    """
    return _run_chunk(base, [(0, point)])[0][1]


def _run_chunk(base: dict, chunk: list[tuple[int, dict]]) -> list[tuple[int, dict]]:
    """The rows of a chunk of points; runs on the Taylor backend go several at a time
    (:func:`mett.dynamics.batch.run_ends`)."""
    from .dynamics.batch import run_ends

    kw = {k: v for k, v in base["simulate_kw"].items() if k != "contensou_radius"}
    started = [(i, p, *_start(base, p)) for i, p in chunk]
    todo = [(i, p, row, job) for i, p, row, job in started if job is not None]
    jobs = [(job[0], job[1], job[2]) for *_, job in todo]
    ends = run_ends(jobs, base["t_end"], window=_SETTLE_WINDOW, **kw)
    rows = {i: row for i, _, row, job in started if job is None}
    for (i, p, row, job), end in zip(todo, ends, strict=True):
        rows[i] = _row(row, p, job, end)
    return [(i, rows[i]) for i, _ in chunk]


def _grid_points(grid: Mapping[str, Any]) -> tuple[list[str], list[dict]]:
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
            bad = [v for v in laws if v not in LAW_NAMES]
            if bad or not laws:
                raise ValueError(f"grid['friction'] must name laws of {LAW_NAMES}; got {bad!r}")
            axes.append(laws)
            continue
        arr = _validate.as_finite_array(n, grid[n])
        if arr.ndim != 1 or arr.size == 0:
            raise ValueError(f"grid[{n!r}] must be a non-empty 1-D array; got shape {arr.shape}")
        axes.append([float(v) for v in arr])
    return names, [dict(zip(names, combo, strict=True)) for combo in itertools.product(*axes)]


def _signature(base: dict, names: list[str], points: list[dict]) -> str:
    payload = json.dumps({"base": base, "names": names, "points": points}, sort_keys=True)
    return hashlib.sha256(payload.encode()).hexdigest()


class _Checkpoint:
    """JSON-lines file: a header with the arguments' signature, then one finished point a line.

    An existing file is read and checked (header, signature, every record) before anything is
    written to it, so a file that is not this sweep's checkpoint is never modified.
    """

    def __init__(self, path: Path, signature: str, summary: dict, n_points: int) -> None:
        self.path = path
        self.done: dict[int, dict] = {}
        if path.exists() and path.stat().st_size > 0:
            self._load(signature, n_points)
        else:
            header = {"mett_sweep": _CHECKPOINT_VERSION, "signature": signature, "args": summary}
            with open(path, "w", encoding="utf-8") as fh:
                fh.write(json.dumps(header) + "\n")
                fh.flush()
                os.fsync(fh.fileno())
        self._fh = open(path, "a", encoding="utf-8")

    def _load(self, signature: str, n_points: int) -> None:
        raw = self.path.read_bytes()
        lines = raw.split(b"\n")
        complete, tail = lines[:-1], lines[-1]
        not_ours = (
            f"{self.path} exists and is not a mett sweep checkpoint; it was left untouched "
            "(choose another checkpoint path)"
        )
        try:
            header = json.loads(complete[0])
        except (IndexError, UnicodeDecodeError, json.JSONDecodeError):
            raise ValueError(not_ours) from None
        if not isinstance(header, dict) or "mett_sweep" not in header:
            raise ValueError(not_ours)
        if header.get("signature") != signature:
            raise ValueError(
                f"checkpoint {self.path} was written for different sweep arguments "
                f"({header.get('args')}); use another path or delete it"
            )
        done = {}
        for lineno, line in enumerate(complete[1:], start=2):
            if not line.strip():
                continue
            try:
                rec = json.loads(line)
                index, row = int(rec["index"]), rec["row"]
                if not (0 <= index < n_points and isinstance(row, dict)):
                    raise ValueError
            except (UnicodeDecodeError, ValueError, KeyError, TypeError):
                raise ValueError(
                    f"{self.path}, line {lineno}: damaged checkpoint record {line[:80]!r}; "
                    "delete that line (the point will be rerun) or the file"
                ) from None
            done[index] = row
        # Only now, with the file known to be ours: a kill in the middle of a write leaves a
        # partial last line; cut it off (its point is rerun).
        if tail:
            with open(self.path, "r+b") as fh:
                fh.truncate(len(raw) - len(tail))
        self.done = done

    def write(self, index: int, row: dict) -> None:
        self._fh.write(json.dumps({"index": index, "row": row}) + "\n")
        self._fh.flush()
        os.fsync(self._fh.fileno())
        self.done[index] = row

    def close(self) -> None:
        self._fh.close()


def _want_progress(progress: bool | None) -> bool:
    """Resolve ``progress`` before any work: None means "if stderr is a terminal and tqdm exists"."""
    has_tqdm = importlib.util.find_spec("tqdm") is not None
    if progress is None:
        try:
            interactive = sys.stderr is not None and sys.stderr.isatty()
        except (AttributeError, ValueError):  # a closed or replaced stderr
            interactive = False
        return interactive and has_tqdm
    if progress and not has_tqdm:
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


def _probe_options(base: dict, points: list[dict]) -> None:
    """Let :func:`mett.simulate` check the options (model, rtol, atol, backend, …) before any run.

    Makes simulate's own checks, without integrating (:func:`mett.dynamics.simulation.check_run`),
    at the first grid point whose top and state are valid, so ``rtol=2.0`` or ``model="nope"``
    is refused once, with simulate's own message, instead of making every row "invalid".
    ``t_eval`` (which must fit the full ``t_end``) is checked here.
    """
    import numpy as np

    from .dynamics.simulation import check_run
    from .state import State

    kw = dict(base["simulate_kw"])
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
    for point in points:
        try:
            top, ic = _point_setup(base, point)
            state = State(
                theta=ic["theta0"], thetadot=ic["thetadot"], phidot=ic["phidot"],
                omega3=ic["omega3"], nu_x=ic["nu_x"], nu_y=ic["nu_y"],
            )  # fmt: skip
        except (ValueError, TypeError, ArithmeticError):
            continue  # an invalid point: it becomes an "invalid" row; probe the next one
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # each run reports its own warnings
            try:  # what simulate checks before its first step, without integrating
                check_run(top, state, min(base["t_end"], _PROBE_T_END), **kw)
            except (ValueError, TypeError) as exc:
                raise type(exc)(f"invalid simulate option for the sweep: {exc}") from None
            except Exception:  # a run-time failure is the rows' business
                pass
        return


_PROBE_T_END = 1e-6  # s: short, since friction=Viscous(...) checks by running simulate itself


def sweep(
    top: TippeTop,
    grid: Mapping[str, Iterable[float]],
    *,
    t_end: float,
    theta0: float = 0.1,
    thetadot: float = 0.0,
    phidot: float = 0.0,
    omega3: float = 155.0,
    nu_x: float = 0.0,
    nu_y: float = 0.0,
    executor: Executor | None = None,
    progress: bool | None = None,
    checkpoint: str | os.PathLike | None = None,
    chunksize: int | None = None,
    **simulate_kw: Any,
) -> pd.DataFrame:
    """Simulate every point of a Cartesian grid of parameters and initial conditions.

    Parameters
    ----------
    top : TippeTop
        The base top; grid entries override its fields.
    grid : mapping of str to 1-D array
        Names from :data:`GRID_NAMES` (TippeTop fields, initial conditions, ``gamma``,
        ``lam_ratio``) to the values to run; the Cartesian product is swept.
    t_end : float
        Simulated time of every run (s).
    theta0, thetadot, phidot, omega3, nu_x, nu_y : float
        Initial conditions where the grid does not set them (default: the thesis start).
    executor : concurrent.futures.Executor, optional
        Where to run: a ``ProcessPoolExecutor``, a Dask ``Client.get_executor()``, …; serial when
        None. Only ``submit`` is used; points travel in chunks of ``chunksize``.
    progress : bool or None, default None
        A tqdm progress bar on stderr (optional dependency ``mett[progress]``). None: a bar when
        stderr is a terminal and tqdm is installed, none in scripts, logs and notebooks' captured
        output; True insists (ValueError without tqdm); False never.
    checkpoint : path, optional
        JSON-lines file of finished points; rerunning with the same arguments resumes. An existing
        file that is not this sweep's checkpoint is refused and left untouched.
    chunksize : int, optional
        Points per task sent to ``executor`` (default: about 1/32 of the grid), >= 1; without an
        executor, points run (and are checkpointed) this many at a time (default 1, and 64 with
        ``backend="taylor"``). On the Taylor backend the points of a task run side by side, four
        per SIMD batch (:func:`mett.dynamics.batch.run_ends`): the fastest way through a grid.
    **simulate_kw
        Passed to :func:`mett.simulate` (``model``, ``rtol``, …); checked once, before the first
        run, by simulate's own checks at the first valid grid point.

    Returns
    -------
    pandas.DataFrame
        One row per grid point, in grid order: the grid values, ``t_invert`` (first θ = π/2, NaN
        if never), ``status``, ``theta_end``, ``omega3_end``, ``lam``, ``lam_ratio`` (λ/λ_thres),
        ``predicted`` (:func:`mett.asymptotic_state` kind), ``simulated`` (kind read off θ_end, or
        "not settled" if θ still moved over the last quarter of the run), ``agree`` (for a
        "bistable" prediction: the run ended in one of its two stable states), and
        ``message``. A point that fails is a row too: status "invalid" (its parameters are
        refused), "error" (the simulation raised; ``message`` says what) or the run's own status
        ("failed", "contact_lost") with the partial run's end values; the sweep goes on.

    Raises
    ------
    ValueError, TypeError
        Before any run or write: unknown grid names, bad values or options (``rtol``, ``model``,
        ``chunksize``, …), a checkpoint path in a missing directory, or an existing file that is
        not this sweep's checkpoint (left untouched) or has a damaged record (path and line named).
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
    ckpt_path = None if checkpoint is None else _validate.output_path("checkpoint", checkpoint)
    names, points = _grid_points(grid)
    base = {
        "top": dataclasses.asdict(top),
        "t_end": t_end,
        "theta0": float(_validate.theta(theta0, "theta0")),
        "thetadot": _validate.finite_scalar("thetadot", thetadot),
        "phidot": _validate.finite_scalar("phidot", phidot),
        "omega3": _validate.finite_scalar("omega3", omega3),
        "nu_x": _validate.finite_scalar("nu_x", nu_x),
        "nu_y": _validate.finite_scalar("nu_y", nu_y),
        "simulate_kw": {k: _plain(v) for k, v in simulate_kw.items()},
    }
    _probe_options(base, points)
    try:
        json.dumps(base["simulate_kw"])
    except (TypeError, ValueError):
        raise ValueError(
            "simulate options of a sweep must be plain values (numbers, strings, arrays): they "
            f"are recorded in the checkpoint; got {simulate_kw!r}"
        ) from None
    signature = _signature(base, names, points)
    show_progress = _want_progress(progress)
    ckpt = None
    if ckpt_path is not None:
        summary = {"names": names, "n_points": len(points), "t_end": t_end}
        ckpt = _Checkpoint(ckpt_path, signature, summary, len(points))
    done = dict(ckpt.done) if ckpt else {}
    todo = [(i, p) for i, p in enumerate(points) if i not in done]
    bar = _progress_bar(len(points), len(done)) if show_progress else None
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
            batched = simulate_kw.get("backend") == "taylor"
            size = chunksize or (_SERIAL_CHUNK if batched else 1)
            for k in range(0, len(todo), size):
                finish(_run_chunk(base, todo[k : k + size]))
        else:
            size = chunksize or max(1, math.ceil(len(todo) / 32))
            chunks = [todo[k : k + size] for k in range(0, len(todo), size)]
            futures: list[Future] = [executor.submit(_run_chunk, base, c) for c in chunks]
            # A chunk whose task failed (a worker died, the executor shut down) is not recorded,
            # so a rerun redoes it; every other chunk is still collected and checkpointed first.
            failures: list[BaseException] = []
            for fut in as_completed(futures):
                try:
                    pairs = fut.result()
                except Exception as exc:
                    failures.append(exc)
                    continue
                finish(pairs)
            if failures:
                raise failures[0]
    finally:
        if ckpt:
            ckpt.close()
        if bar is not None:
            bar.close()
    records = [results[i] for i in range(len(points))]
    results_first = ["t_invert", "status", "theta_end", "omega3_end", "lam", "lam_ratio",
                     "predicted", "simulated", "agree"]  # fmt: skip
    first = names + [c for c in results_first if c not in names]
    # the other columns in the order the rows first name them (built in that order directly:
    # reordering a finished table copies it)
    rest = list(dict.fromkeys(c for row in records for c in row if c not in first))
    return pd.DataFrame(records, columns=first + rest)
