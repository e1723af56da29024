"""The record of one run, shared by :func:`~mett.simulate`, the backends and the hybrid driver.

The floor under :mod:`.simulation`, :mod:`.backends` and :mod:`.hybrid`: the run (:class:`Run`:
model, parameters, start, phase, and how its :class:`~mett.Trajectory` is built), the piece of
a run one backend call returns (:class:`Piece`), a validated run (:class:`PreparedRun`), the
step budget and the messages of the ends of a run. It imports nothing of the three modules above
it, so they import it without a cycle.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, NamedTuple

import numpy as np

from ..state import State
from ..top import TippeTop
from . import _codes
from .dense import ConstantSolution
from .registry import Model, Phase
from .trajectory import Trajectory

__all__ = [
    "MAX_STEPS",
    "Piece",
    "PreparedRun",
    "Run",
    "completed_message",
    "event_end",
    "integrator_failure",
]

MAX_STEPS = 1_000_000
"""Every backend stops with status "failed" after this many accepted steps (per phase of a hybrid
run), the steps taken kept. The compiled backend keeps every step in memory: 8 (12 + 8n) bytes per step for an n-component state, 656 MB for the gliding model (n = 10),
plus the Trajectory's series, about 140 MB more. Measured on the thesis top (rtol = 1e-10; 1e6
steps reach t = 74 000 s once the top has settled, about 3000 s while it still nutates fast): the
process peaks at 0.96 GB RSS, of which 0.19 GB is the interpreter with numpy, scipy and numba.
The backends read it when a run starts (``_run.MAX_STEPS``), so a test may lower it."""


def completed_message(t_end: float) -> str:
    """The message of a run that reached ``t_end``."""
    return f"reached t_end = {t_end:g} s"


def event_end(action: str, message: str, t_ev: float) -> tuple[str, str]:
    """Status and message of a run stopped at ``t_ev`` by a model event (not a switch) with this
    ``action`` and ``message``."""
    if action == "contact_lost":
        return "contact_lost", f"contact lost: the normal force g_n reached 0 at t = {t_ev:.9g} s"
    return "failed", f"{message} (t = {t_ev:.9g} s)"


def integrator_failure(messages: Mapping[int, str], status: int, t_stop: float) -> str:
    """The message of a compiled integrator's failure ``status`` (< 0, :mod:`._codes`) at
    ``t_stop``, with that integrator's ``messages`` per code (the step budget worded alike for
    every backend)."""
    base = messages[status]
    if status == _codes.MAX_STEPS:
        base = f"maximum number of steps ({MAX_STEPS}) reached"
    return f"integrator failed at t = {t_stop:.9g} s: {base}"


class Piece(NamedTuple):
    """One backend call's run (one phase of a hybrid run): samples, dense output, status."""

    t: Any
    Y: Any
    sol: Any
    status: str
    message: str
    kw: dict


class Run:
    """What every backend shares: the model, its parameters, and how to build the Trajectory."""

    def __init__(
        self,
        mdl: Model,
        top: TippeTop,
        params: tuple,
        y0: np.ndarray,
        backend: str,
        phase: Phase,
        t0: float = 0.0,
        *,
        state: State | None = None,
        options: dict | None = None,
    ) -> None:
        self.mdl, self.top, self.params, self.y0, self.backend = mdl, top, params, y0, backend
        self.phase, self.t0 = phase, t0
        self.state, self.options = state, options  # kept on the Trajectory (saved with it)
        self.collect = False  # True: result() returns the pieces (a backend's solve)
        self.tolerances: dict[str, Any] = {}  # rtol, atol, t_end: kept on the Trajectory
        self.switch: tuple[int, float] | None = None  # (event index, time) of a "switch" stop

    def result(self, t, Y, sol, status: str, message: str, **kw: Any) -> Any:
        if self.collect:
            return Piece(t, Y, sol, status, message, kw)
        if self.mdl.hybrid and "records" not in kw:  # one phase throughout
            kw.update(extras={"phase": np.full(np.shape(t), self.phase.name)},
                      records={"switches": [], "jumps": []})  # fmt: skip
        return Trajectory(
            t=t,
            states=Y,
            model=self.mdl,
            top=self.top,
            params=self.params,
            solution=sol,
            status=status,
            message=message,
            backend=self.backend,
            initial_state=self.state,
            options=self.options,
            **self.tolerances,
            **kw,
        )

    def trajectory(self, piece: Piece) -> Trajectory:
        """The Trajectory of a single-phase run from the piece its backend returned."""
        self.collect = False
        return self.result(piece.t, piece.Y, piece.sol, piece.status, piece.message, **piece.kw)

    def at_start(self, status: str, message: str, **kw: Any) -> Any:
        """A run that ends at t = 0 (contact lost or failure before the first step)."""
        sol = ConstantSolution(self.t0, self.y0)
        return self.result([self.t0], self.y0, sol, status, message, **kw)

    def contact_lost(self, t_out, Y, sol, t_ev: float, **kw: Any) -> Any:
        msg = event_end("contact_lost", "", t_ev)[1]
        return self.result(t_out, Y, sol, "contact_lost", msg, t_contact_lost=float(t_ev), **kw)

    def stopped(self, t_out, Y, sol, index: int, t_ev: float, **kw: Any) -> Any:
        """The run stopped at the model's event ``index``, located at ``t_ev``."""
        ev = self.phase.events[index]
        if ev.action == "contact_lost":
            return self.contact_lost(t_out, Y, sol, t_ev, **kw)
        if ev.action == "switch":
            self.switch = (index, float(t_ev))
            msg = f"switch to phase {ev.target!r} at t = {t_ev:.9g} s"
            return self.result(t_out, Y, sol, "completed", msg, **kw)
        return self.result(t_out, Y, sol, *event_end(ev.action, ev.message, t_ev), **kw)


class PreparedRun(NamedTuple):
    """A validated run, ready for its backend (:func:`mett.dynamics.simulation.prepare_run`)."""

    run: Run
    table: dict[str, Phase]
    t_end: float
    rtol: float
    atol_arr: np.ndarray
    t_eval_arr: np.ndarray | None
    max_step: float
    method: str
    user: list

    @property
    def model(self) -> Model:
        """The model that runs (after the friction law and the options chose it)."""
        return self.run.mdl

    @property
    def params(self) -> tuple:
        """The model's parameter tuple."""
        return self.run.params

    @property
    def y0(self) -> np.ndarray:
        """The start, in the model's state."""
        return self.run.y0

    @property
    def backend(self) -> str:
        """The name of the backend that runs it ("auto" resolved)."""
        return self.run.backend

    @property
    def phase(self) -> Phase:
        """The phase the run starts in."""
        return self.run.phase

    @property
    def scales(self) -> np.ndarray:
        """Typical magnitude per component, atol / rtol (the Taylor step-size norm's σ)."""
        return self.atol_arr / self.rtol
