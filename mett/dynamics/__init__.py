"""Dynamics of the tippe top: models (right-hand sides), the integrator and the Trajectory.

Models (theory.md §2, §3, §10; Rutstam 2012; thesis eqs (10)–(15)):

* ``"gliding"`` — rolling-and-gliding eccentric sphere, F = g_n ẑ − μ g_n v_A, vector form
  (:mod:`.gliding`);
* ``"rolling"`` — the integrable rolling ball, v_A ≡ 0 (:mod:`.rolling`);
* ``"gliding-hst"`` — gliding heavy symmetric top, R → 0 with Rα = l (:mod:`.reduced`);
* ``"cylinder"`` — gliding eccentric cylinder, the subspace φ̇ = ω3 = ν_y = 0 (:mod:`.reduced`);
* ``"gliding-euler"`` — the Euler-angle form of "gliding", a cross-check (:mod:`.euler`).

Every right-hand side is a pure function ``rhs(t, y, params)`` of a flat float array and a tuple of
floats, written as plain float arithmetic. :func:`simulate` runs it either through scipy
(``backend="scipy"``, the reference) or, by default, compiled: :mod:`._kernels` compiles the same
source with numba for the compiled DOP853 of :mod:`.dop853` (``backend="compiled"``), loaded on the
first compiled run so that ``import mett`` does not import numba.
"""

from .euler import euler_normal_force, euler_rhs
from .gliding import gliding_normal_force, gliding_rhs
from .reduced import cylinder_rhs, hst_euler_rhs
from .rolling import rolling_rhs
from .simulation import MODELS, simulate
from .trajectory import Trajectory

__all__ = [
    "MODELS",
    "Trajectory",
    "cylinder_rhs",
    "euler_normal_force",
    "euler_rhs",
    "gliding_normal_force",
    "gliding_rhs",
    "hst_euler_rhs",
    "rolling_rhs",
    "simulate",
]
