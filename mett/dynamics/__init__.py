"""Dynamics of the tippe top: models (right-hand sides), the integrator and the Trajectory.

Models (docs/theory/equations.md#equations-of-motion, docs/theory/equations.md#integrals, docs/theory/reduced.md#reduced-systems; Rutstam 2012; thesis eqs (10)–(15)):

* ``"gliding"`` — rolling-and-gliding eccentric sphere, F = g_n ẑ − μ g_n v_A, vector form
  (:mod:`.gliding`);
* ``"rolling"`` — the integrable rolling ball, v_A ≡ 0 (:mod:`.rolling`);
* ``"gliding-hst"`` — gliding heavy symmetric top, R → 0 with Rα = l (:mod:`.reduced`);
* ``"cylinder"`` — gliding eccentric cylinder, the subspace φ̇ = ω3 = ν_y = 0 (:mod:`.reduced`);
* ``"gliding-euler"`` — the Euler-angle form of "gliding", a cross-check (:mod:`.euler`);
* ``"coulomb"``, ``"coulomb-contensou"``, ``"coulomb-regularised"`` — dry friction (exact
  stick–slip, a hybrid of sliding and rolling phases; the regularised law), chosen by
  ``simulate(..., friction=...)`` (:mod:`.stickslip`);
* ``"stemmed"`` — the top with a stem, ball and stem contacts with impacts (:mod:`.stem`), and
  ``"stemmed-coulomb"``, ``"stemmed-coulomb-contensou"`` — the same under dry friction
  (:mod:`.stemslip`), chosen by ``simulate(top.with_stem(...), ..., friction=Coulomb(...))``,
  and ``"stemmed-coulomb-regularised"`` under ``RegularisedCoulomb(...)`` (:mod:`.stemreg`);
* ``"rolling-resistance"`` — viscous sliding with a rolling-resistance couple, chosen by
  ``simulate(..., friction=RollingResistance(mu_r))`` (:mod:`.resistance`).

Every model declares itself once, in its own module, with :func:`~.registry.register` (see
:mod:`.registry` for the design): right-hand side, events, options, conserved quantities. Adding a
model is one module plus one name in the import line below.

Every right-hand side is a pure function ``rhs(t, y, params)`` of a flat float array and a tuple of
floats, written as plain float arithmetic. :func:`simulate` runs it either through scipy
(``backend="scipy"``, the reference) or, by default, compiled: :mod:`._kernels` compiles the same
source with numba for the compiled DOP853 of :mod:`.dop853` (``backend="compiled"``), loaded on the
first compiled run so that ``import mett`` does not import numba.
"""

# the registry first, then the built-in models, which register themselves in MODELS in this order
from . import registry  # noqa: F401, I001
from . import gliding, rolling, reduced, euler, routhian, stickslip  # noqa: F401
from . import stem, stemslip, stemreg, resistance  # noqa: F401
from .euler import euler_normal_force, euler_rhs
from .gliding import gliding_normal_force, gliding_rhs
from .reduced import cylinder_rhs, hst_euler_rhs
from .registry import MODELS, Event, Model, Option, Phase, register
from .rolling import rolling_rhs
from .simulation import simulate
from ._status import Status
from .trajectory import Trajectory

__all__ = [
    "MODELS",
    "Event",
    "Model",
    "Option",
    "Phase",
    "Status",
    "Trajectory",
    "cylinder_rhs",
    "euler_normal_force",
    "euler_rhs",
    "gliding_normal_force",
    "gliding_rhs",
    "hst_euler_rhs",
    "register",
    "rolling_rhs",
    "simulate",
]
