"""The error bound of dry-friction stop times, shared by the backend comparisons.

A stop fires when the slip speed |v_A|, falling at the rate a (m/s², read off the run), is in the
stopping band [0, δ], δ = 10 rtol × the velocity scale (``traj.stopping_band``): up to δ/a early.
The error of v_A there is at most the local error allowed per step, rtol × the velocity scale =
δ/10, over the N steps of that slide: N δ/(10 a). Every later switch inherits the shift.
"""

from __future__ import annotations

import numpy as np


def stop_shift(traj, n: int | None = None, h: float = 1e-4) -> float:
    """Σ over the stops among the first ``n`` switches of ``traj`` (all by default) of
    (1 + N/10) δ/a (s); ``h`` (s) is short against the slip's deceleration time and long against
    δ/a (a is the slope of |v_A| over [t − 2h, t − h])."""
    shift, start = 0.0, 0.0
    for sw in traj.switches[:n]:
        if sw.reason == "stop":
            slip = traj.at(np.array([sw.t - 2.0 * h, sw.t - h]))
            speed = np.hypot(slip.nu_x, slip.nu_y)
            steps = np.count_nonzero((traj.t > start) & (traj.t <= sw.t))
            shift += (1.0 + steps / 10.0) * traj.stopping_band / ((speed[0] - speed[1]) / h)
        start = sw.t
    return shift
