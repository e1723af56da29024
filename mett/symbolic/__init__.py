"""Symbolic derivations (sympy) behind the numeric core: equations of motion, integrals, METT.

Import explicitly (``import mett.symbolic``); ``import mett`` never imports sympy.

* :func:`gliding_euler_equations` — the Euler-angle equations of the rolling-and-gliding top,
  derived from Newton–Euler with the contact constraint (theory.md §2; Rutstam 2012 §2).
* :func:`integrals`, :func:`mett_potential`, :func:`mett_decomposition`, :func:`rational_potential`
  — λ, D, E, Ẽ and the Main Equation Ẽ = g(z) θ̇² + V(z, D, λ), general and rational
  (theory.md §3–§5).
* :mod:`mett.symbolic.seed000` — the Routhian model of the Maple/Poincaré paper (seed 000), its
  corrected equations, and its misprinted equations as erratum fixtures (docs/errata.md).

Every derivation is cached (``functools.cache``): the first call takes seconds, the next ones are
instant. Symbols are in :data:`S` (and :data:`seed000.SEED`); :data:`STATE` and :data:`PARAMS` give
the argument order of the numeric core (``y`` and ``params`` of :mod:`mett.dynamics.euler`).
"""

from . import seed000
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
    "mett_decomposition",
    "mett_potential",
    "newton_euler_residuals",
    "rational_potential",
    "resal_frame",
    "seed000",
    "trig_reduce",
]
