"""The status codes of mett's compiled integrators, shared by :mod:`.dop853` and :mod:`.taylor`.

Plain ``int`` constants, so that numba kernels read them as compile-time constants; the
:class:`IntegratorCode` enumeration names the same values for Python code (``IntegratorCode(s)``
turns a code returned by a kernel into its name). A code ≥ 0 is a successful end, < 0 a failure.

The values are compiled into the cached machine code of :mod:`.dop853` and :mod:`.taylor`: they
are fixed (numba's disk cache is keyed on the source of the module that uses them, not on this
one), so a new code takes a new value and none is ever renumbered.
"""

from __future__ import annotations

from enum import IntEnum

__all__ = [
    "COMPLETED",
    "INTERRUPTED",
    "MAX_STEPS",
    "NON_FINITE",
    "POLL_EVERY",
    "STEP_TOO_SMALL",
    "TERMINAL_EVENT",
    "IntegratorCode",
]

COMPLETED = 0
"""Reached the end of the time span."""
TERMINAL_EVENT = 1
"""Stopped at a terminal event."""
STEP_TOO_SMALL = -1
"""Failed: the required step fell below the resolution of t (a singularity or a stiff stretch)."""
NON_FINITE = -2
"""Failed: the state, the right-hand side or the Taylor coefficients became non-finite."""
MAX_STEPS = -3
"""Failed: the budget of accepted steps was spent without reaching the end."""
INTERRUPTED = -4
"""A signal (Ctrl-C) stopped the loop: the Python caller raises KeyboardInterrupt; never a
result."""

POLL_EVERY = 32
"""Steps between two polls for signals (:mod:`._signals`): ~25 ns a poll, a step takes
microseconds."""


class IntegratorCode(IntEnum):
    """The codes above as an enumeration (same values)."""

    COMPLETED = COMPLETED
    TERMINAL_EVENT = TERMINAL_EVENT
    STEP_TOO_SMALL = STEP_TOO_SMALL
    NON_FINITE = NON_FINITE
    MAX_STEPS = MAX_STEPS
    INTERRUPTED = INTERRUPTED
