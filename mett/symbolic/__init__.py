"""Symbolic derivations (sympy) behind the numeric core: equations of motion, integrals, METT.

Import explicitly (``import mett.symbolic``); ``import mett`` never imports sympy.

* :func:`gliding_euler_equations` — the Euler-angle equations of the rolling-and-gliding top,
  derived from Newton–Euler with the contact constraint (docs/theory/equations.md#euler-form; Rutstam 2013, eqs (10)–(15)).
* :func:`integrals`, :func:`mett_potential`, :func:`mett_decomposition`, :func:`rational_potential`
  — λ, D, E, Ẽ and the Main Equation Ẽ = g(z) θ̇² + V(z, D, λ), general and rational
  (docs/theory/equations.md#integrals, docs/theory/mett.md#the-main-equation, docs/theory/mett.md#rational).
* :mod:`mett.symbolic.maple_tippe_top` — the Routhian model of the paper "Utilization of
  Maple-based Physics Computation in Determining the Dynamics of Tippe Top" (key
  ``maple-tippe-top``), its corrected equations, and its misprinted equations as erratum fixtures
  (docs/maple-tippe-top-errata.md).

Every derivation is cached (``functools.cache``): the first call takes seconds, the next ones are
instant. Symbols are in :data:`S` (and :data:`maple_tippe_top.MAPLE`); :data:`STATE` and :data:`PARAMS` give
the argument order of the numeric core (``y`` and ``params`` of :mod:`mett.dynamics.euler`).
"""

from . import maple_tippe_top
from ._frame import PARAMS, STATE, S, resal_frame, trig_reduce
from .euler import gliding_euler_equations, newton_euler_residuals
from .potential import d_expr, integrals, mett_decomposition, mett_potential, rational_potential

__all__ = [
    "PARAMS",
    "STATE",
    "S",
    "d_expr",
    "gliding_euler_equations",
    "integrals",
    "maple_tippe_top",
    "mett_decomposition",
    "mett_potential",
    "newton_euler_residuals",
    "rational_potential",
    "resal_frame",
    "trig_reduce",
]
