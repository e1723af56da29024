"""Compiled twins of the model right-hand sides, for the compiled DOP853 (:mod:`.dop853`).

The physics is written once. Each model module keeps its equations in a private function of plain
float arithmetic (``gliding._core``, ``rolling._core``, ``reduced._cylinder_core``,
``euler._euler_core``, …) that numpy evaluates on floats or on arrays of samples, and adds two
plain-Python out-style functions on top of it: ``_rhs_into(t, y, p, out)`` and
``_events_into(t, y, p, out)`` (g_n/(m g), then the model's guards). This module compiles those
very functions with numba: :func:`_jit` makes a copy of the function whose module-level callees are
replaced by their compiled versions (recursively) and jits it with ``cache=True``. The reference
right-hand side ``Model.rhs`` and the compiled one therefore run the same source; the tests check
that they agree to rounding at random states.

Only :func:`mett.simulate` imports this module, when it runs the compiled backend: ``import mett``
does not import numba. Compiling from scratch takes a few seconds per model; later processes load
the machine code from numba's cache (``__pycache__`` next to the model modules). The cache of a
compiled function is keyed on the source file of that function, and every callee lives in the same
file, so editing a model module invalidates all of its kernels (numba does not track callees in
other files).

The kernels use numba's ``error_model="numpy"``: a division by zero gives inf/nan (which the
integrator rejects and reports as status "failed") instead of raising inside compiled code.
"""

from __future__ import annotations

import types
from collections.abc import Callable

import numba

from . import euler, gliding, reduced, rolling, routhian

__all__ = ["KERNELS", "get"]

_JITTED: dict[Callable, Callable] = {}


def _jit(fn: types.FunctionType) -> Callable:
    """``numba.njit(cache=True)`` of a plain-arithmetic function and of the functions it calls.

    Module-level functions of the same module that ``fn`` refers to are compiled first and bound in
    a copy of its globals, since compiled code can only call compiled code.
    """
    if fn in _JITTED:
        return _JITTED[fn]
    env = dict(fn.__globals__)
    for name in fn.__code__.co_names:
        callee = env.get(name)
        if isinstance(callee, types.FunctionType) and callee.__module__ == fn.__module__:
            env[name] = _jit(callee)
    clone = types.FunctionType(fn.__code__, env, fn.__name__, fn.__defaults__, fn.__closure__)
    clone.__qualname__, clone.__module__, clone.__doc__ = fn.__qualname__, fn.__module__, fn.__doc__
    _JITTED[fn] = out = numba.njit(cache=True, error_model="numpy")(clone)
    return out


KERNELS: dict[str, tuple[Callable, Callable]] = {
    "gliding": (_jit(gliding._rhs_into), _jit(gliding._events_into)),
    "rolling": (_jit(rolling._rhs_into), _jit(rolling._events_into)),
    "cylinder": (_jit(reduced._cylinder_rhs_into), _jit(reduced._cylinder_events_into)),
    "gliding-euler": (_jit(euler._rhs_into), _jit(euler._events_into)),
    "frictionless-routhian": (_jit(routhian._rhs_into), _jit(routhian._events_into)),
}
"""``Model.kernel`` → (rhs, events) numba dispatchers; compiled (or loaded from the cache) lazily,
at their first use."""


def get(name: str) -> tuple[Callable, Callable]:
    """The compiled (rhs, events) pair of a model's ``kernel`` name."""
    return KERNELS[name]
