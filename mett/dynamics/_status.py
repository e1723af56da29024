"""How a run of :func:`mett.simulate` ended: one enumeration for every backend and model.

A :class:`Status` is a ``str`` (``Status.COMPLETED == "completed"``), so the comparisons with
plain strings that user code, the CLI and the sweeps make keep working, and it is saved in a
trajectory file as its plain value.
"""

from __future__ import annotations

import enum

__all__ = ["SUCCESSFUL", "Status"]


class Status(str, enum.Enum):
    """The end of a run (:attr:`mett.Trajectory.status`).

    Numerical trouble never raises (docs/reliability.md): the run stops, keeps what it computed,
    and says why in ``Trajectory.message``.
    """

    COMPLETED = "completed"
    """The run reached the requested ``t_end``, or stopped at a terminal user event."""
    CONTACT_LOST = "contact_lost"
    """The normal force g_n reached 0 (the top leaves the floor): the model's equations, which
    assume contact, end there (``Trajectory.t_contact_lost``)."""
    FAILED = "failed"
    """The integrator or a model guard stopped the run (step budget, step size underflow, a
    pole of the Euler-angle equations, a failed impact, too many phase switches)."""

    # printed as the plain value it replaces ('completed'), so printed output stays the same
    def __str__(self) -> str:
        return self.value

    def __repr__(self) -> str:
        return repr(self.value)


SUCCESSFUL = frozenset({Status.COMPLETED})
"""The statuses :attr:`mett.Trajectory.success` counts as a success: only "completed". A run
that lost contact stopped before the requested end for a physical reason, which is an answer but
not the run that was asked for (as ``mett simulate`` exits non-zero for it)."""
