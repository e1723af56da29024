"""``mett warmup``: build the machine code of the default models ahead of their first use.

The first run of a model on a machine compiles its kernels: the Taylor jets with LLVM (a few
seconds per model and order, cached in the user's :func:`mett.dynamics.taylor.cache_dir`) and the
numba integrators and right-hand sides (numba's cache). :func:`warmup` makes those first runs,
short ones, so that a user's first call loads what is cached; ``mett warmup`` is its command.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from .. import presets
from ..friction import Coulomb
from ..state import State
from ..top import TippeTop
from . import flight
from .batch import LANES, run_ends
from .simulation import simulate

__all__ = ["WARMUP_DEFAULT", "WARMUP_MODELS", "warmup"]


def _backend(traj: Any) -> str:
    return str(traj.backend)


WARMUP_MODELS = ("gliding", "rolling", "gliding-hst", "stemmed", "coulomb")
"""What :func:`warmup` can build: the viscous gliding top (a single run and a sweep's SIMD
lanes), the rolling top, the gliding HST, the viscous stemmed top (Taylor) and the dry Coulomb
top (the compiled DOP853)."""

WARMUP_DEFAULT = ("gliding", "coulomb")
"""What ``mett warmup`` builds by default: what the README's examples and a default sweep run."""


def _warmup_tasks(models: Any, rtol: float) -> list[tuple[str, Callable[[], str]]]:
    """(label, build) per task of :func:`warmup`; ``build()`` runs a short run and returns the
    backend it ran on."""
    top = presets.get("rutstam2013")
    thesis = State(theta=0.1, omega3=155.0)
    short = 1e-3  # s: enough for the first step of every kernel

    def run(**kw: Any) -> str:
        return _backend(simulate(top, thesis, short, rtol=rtol, **kw))

    def stemmed() -> str:
        body = TippeTop(m=0.006, R=0.015, alpha=0.2, I1=8e-7, I3=7e-7, mu=0.3)
        start = State(theta=2.15, thetadot=2.0, phidot=110.0, omega3=-76.0, nu_y=0.16)
        traj = simulate(body.with_stem(radius=0.005, distance=0.016), start, short, rtol=rtol)
        return _backend(traj)

    def lanes() -> str:
        ends = run_ends([(top.replace(mu=0.1 * (k + 1)), thesis) for k in range(LANES)], short,
                        rtol=rtol)  # fmt: skip
        bad = [e for e in ends if isinstance(e, BaseException)]
        if bad:
            raise bad[0]
        return "taylor (SIMD lanes)"

    table: dict[str, list[tuple[str, Callable[[], str]]]] = {
        "gliding": [
            ("gliding top, simulate", run),
            ("gliding top, sweep lanes", lanes),
            ("flight and landing kernels", flight.warm_kernels),
        ],
        "rolling": [("rolling top, simulate", lambda: run(model="rolling"))],
        "gliding-hst": [("gliding HST, simulate", lambda: run(model="gliding-hst"))],
        "stemmed": [("stemmed top, simulate", stemmed)],
        "coulomb": [("Coulomb top, simulate", lambda: run(friction=Coulomb(0.3)))],
    }
    return [task for name in models for task in table[name]]


def warmup(
    models: Any = WARMUP_DEFAULT,
    *,
    rtol: float = 1e-10,
    progress: Callable[[str], None] | None = None,
) -> list[tuple[str, str, float]]:
    """Build the machine code of ``models`` ahead of their first use: the Taylor kernels (LLVM,
    cached in :func:`mett.dynamics.taylor.cache_dir`) and the numba-compiled integrators and
    right-hand sides (numba's cache), as a first run at ``rtol`` would; later processes load them.

    Parameters
    ----------
    models : sequence of str, default ("gliding", "coulomb")
        Names of :data:`WARMUP_MODELS`.
    rtol : float, default 1e-10
        The tolerance whose Taylor order is built (:func:`mett.dynamics.taylor.order_for`): the
        kernels are per order, so a run at another tolerance may build its own.
    progress : callable, optional
        Called with one line per task as it starts and as it ends (``mett warmup`` prints
        them).

    Returns
    -------
    list of (str, str, float)
        Per task: what it built, the backend it ran on, and the seconds it took (compiling, or
        loading what is already cached).

    Raises
    ------
    ValueError
        For a name that is not in :data:`WARMUP_MODELS`, or an rtol :func:`mett.simulate` refuses.
    """
    if isinstance(models, str):
        models = (models,)
    models = tuple(models)
    bad = [m for m in models if m not in WARMUP_MODELS]
    if bad or not models:
        raise ValueError(f"models must be names of {WARMUP_MODELS}; got {list(models)!r}")
    tasks = _warmup_tasks(models, rtol)
    done = []
    for k, (label, build) in enumerate(tasks, start=1):
        if progress is not None:
            progress(f"[{k}/{len(tasks)}] {label} ...")
        t0 = time.perf_counter()
        backend = build()
        seconds = time.perf_counter() - t0
        done.append((label, backend, seconds))
        if progress is not None:
            progress(f"[{k}/{len(tasks)}] {label}: {backend}, {seconds:.1f} s")
    return done
