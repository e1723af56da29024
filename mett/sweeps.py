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
import itertools
import json
import math
import os
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


def classify_end(theta_end: float, status: str) -> str:
    """ "upright", "inverted" or "tumbling" from the final θ; the status if the run did not complete."""
    if status != "completed":
        return status
    if theta_end < _POLE_TOL:
        return "upright"
    if theta_end > math.pi - _POLE_TOL:
        return "inverted"
    return "tumbling"


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


def _run_point(base: dict, point: dict) -> dict:
    from . import friction
    from .dynamics import simulate
    from .integrals import jellett
    from .state import State
    from .thresholds import asymptotic_state

    row: dict[str, Any] = dict(point)
    try:
        top, ic = _point_setup(base, point)
        state = State(
            theta=ic["theta0"], thetadot=ic["thetadot"], phidot=ic["phidot"],
            omega3=ic["omega3"], nu_x=ic["nu_x"], nu_y=ic["nu_y"],
        )  # fmt: skip
        lam = float(jellett(top, state))
        kw = dict(base["simulate_kw"])
        law = point.get("friction", kw.get("friction"))
        if law is not None:  # a law name: its coefficient is the point's mu
            r = point.get("contensou_radius", kw.pop("contensou_radius", 0.0))
            kw["friction"] = friction.from_name(law, top.mu, contensou_radius=r)
        traj = simulate(top, state, base["t_end"], **kw)
        cross = traj.crossings(math.pi / 2)
        predicted = asymptotic_state(top, lam).kind if lam > 0 else "n/a"
        simulated = classify_end(float(traj.theta[-1]), traj.status)
        result = dict(
            t_invert=float(cross[0]) if cross.size else math.nan,
            status=traj.status,
            message=traj.message,
            theta_end=float(traj.theta[-1]),
            omega3_end=float(traj.omega3[-1]),
            omega3_start=float(ic["omega3"]),
            lam=lam,
            lam_ratio=lam / top.lambda_thres,
            gamma=top.gamma,
            predicted=predicted,
            simulated=simulated,
            agree=bool(predicted == simulated),
        )
        # the grid's own values stay exact (λ/λ_thres recomputed would differ in the last bit)
        row.update({k: v for k, v in result.items() if k not in point})
    except ValueError as exc:  # an inadmissible point: recorded, the sweep goes on
        row.update(
            t_invert=math.nan, status="invalid", message=str(exc), theta_end=math.nan,
            omega3_end=math.nan, omega3_start=math.nan, lam=math.nan, lam_ratio=math.nan,
            gamma=math.nan, predicted="n/a", simulated="invalid", agree=False,
        )  # fmt: skip
    return row


def _run_chunk(base: dict, chunk: list[tuple[int, dict]]) -> list[tuple[int, dict]]:
    return [(i, _run_point(base, p)) for i, p in chunk]


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
    """JSON-lines file: a header with the arguments' signature, then one finished point a line."""

    def __init__(self, path: Path, signature: str, summary: dict) -> None:
        self.path = path
        self.done: dict[int, dict] = {}
        if path.exists() and path.stat().st_size > 0:
            self._load(signature)
        else:
            header = {"mett_sweep": _CHECKPOINT_VERSION, "signature": signature, "args": summary}
            with open(path, "w", encoding="utf-8") as fh:
                fh.write(json.dumps(header) + "\n")
                fh.flush()
                os.fsync(fh.fileno())
        self._fh = open(path, "a", encoding="utf-8")

    def _load(self, signature: str) -> None:
        raw = self.path.read_bytes()
        lines = raw.split(b"\n")
        # A kill in the middle of a write leaves a partial last line: cut it off.
        complete, tail = lines[:-1], lines[-1]
        if tail:
            with open(self.path, "r+b") as fh:
                fh.truncate(len(raw) - len(tail))
        try:
            header = json.loads(complete[0])
        except (IndexError, json.JSONDecodeError):
            raise ValueError(f"{self.path} is not a mett sweep checkpoint") from None
        if header.get("signature") != signature:
            raise ValueError(
                f"checkpoint {self.path} was written for different sweep arguments "
                f"({header.get('args')}); use another path or delete it"
            )
        for line in complete[1:]:
            if line.strip():
                rec = json.loads(line)
                self.done[int(rec["index"])] = rec["row"]

    def write(self, index: int, row: dict) -> None:
        self._fh.write(json.dumps({"index": index, "row": row}) + "\n")
        self._fh.flush()
        os.fsync(self._fh.fileno())
        self.done[index] = row

    def close(self) -> None:
        self._fh.close()


def _progress_bar(total: int, initial: int, enabled: bool):
    if not enabled:
        return None
    try:
        from tqdm import tqdm
    except ImportError:
        raise ValueError("progress=True needs tqdm: pip install 'mett[progress]'") from None
    return tqdm(total=total, initial=initial, desc="sweep", unit="run")


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
    progress: bool = False,
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
    progress : bool, default False
        A tqdm progress bar (optional dependency ``mett[progress]``).
    checkpoint : path, optional
        JSON-lines file of finished points; rerunning with the same arguments resumes.
    **simulate_kw
        Passed to :func:`mett.simulate` (``model``, ``rtol``, …).

    Returns
    -------
    pandas.DataFrame
        One row per grid point, in grid order: the grid values, ``t_invert`` (first θ = π/2, NaN
        if never), ``status``, ``theta_end``, ``omega3_end``, ``lam``, ``lam_ratio`` (λ/λ_thres),
        ``predicted`` (:func:`mett.asymptotic_state` kind), ``simulated`` (kind read off θ_end),
        ``agree``, and ``message``.

    Raises
    ------
    ValueError
        Unknown grid names, bad values, or a checkpoint written for other arguments.
    """
    if not isinstance(top, TippeTop):
        raise TypeError(f"top must be a TippeTop; got {type(top).__name__}")
    t_end = _validate.positive_scalar("t_end", t_end)
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
        "simulate_kw": dict(simulate_kw),
    }
    try:
        json.dumps(base["simulate_kw"])
    except TypeError:
        raise ValueError(
            "simulate options of a sweep must be plain values (numbers, strings)"
        ) from None
    ckpt = None
    if checkpoint is not None:
        summary = {"names": names, "n_points": len(points), "t_end": t_end}
        ckpt = _Checkpoint(Path(checkpoint), _signature(base, names, points), summary)
    done = dict(ckpt.done) if ckpt else {}
    todo = [(i, p) for i, p in enumerate(points) if i not in done]
    bar = _progress_bar(len(points), len(done), progress)
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
            for item in todo:
                finish(_run_chunk(base, [item]))
        else:
            size = chunksize or max(1, math.ceil(len(todo) / 32))
            chunks = [todo[k : k + size] for k in range(0, len(todo), size)]
            futures: list[Future] = [executor.submit(_run_chunk, base, c) for c in chunks]
            for fut in as_completed(futures):
                finish(fut.result())
    finally:
        if ckpt:
            ckpt.close()
        if bar is not None:
            bar.close()
    table = pd.DataFrame([results[i] for i in range(len(points))])
    results_first = ["t_invert", "status", "theta_end", "omega3_end", "lam", "lam_ratio",
                     "predicted", "simulated", "agree"]  # fmt: skip
    first = names + [c for c in results_first if c not in names]
    rest = [c for c in table.columns if c not in first]
    return table[first + rest]
