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

_JITTED: dict[tuple[Callable, bool], Callable] = {}
# Part of the name of every kernel's cache files. numba 0.68 keys its on-disk cache on the function's
# bytecode and the hash of its source file, not on the compile options: change this tag whenever the
# options of _jit change, or processes keep loading machine code compiled with the old ones.
_CACHE_TAG = "inl1"


def _jit(fn: types.FunctionType, inline: bool = False) -> Callable:
    """``numba.njit(cache=True)`` of a plain-arithmetic function and of the functions it calls.

    Module-level functions of the same module that ``fn`` refers to are compiled first and bound in
    a copy of its globals, since compiled code can only call compiled code. They are compiled with
    ``inline="always"``: numba then inlines them into the caller's IR. A real call boundary cost
    far more than the arithmetic: the gliding right-hand side took 115 ns per call when it called
    ``_core`` (passing the state and parameter arrays into a compiled call, and the 13-tuple back)
    and 29 ns with ``_core`` inlined (measured on the thesis run's machine, 1e6 calls).
    """
    key = (fn, inline)
    if key in _JITTED:
        return _JITTED[key]
    env = dict(fn.__globals__)
    for name in fn.__code__.co_names:
        callee = env.get(name)
        if isinstance(callee, types.FunctionType) and callee.__module__ == fn.__module__:
            env[name] = _jit(callee, inline=True)
    clone = types.FunctionType(fn.__code__, env, fn.__name__, fn.__defaults__, fn.__closure__)
    clone.__module__, clone.__doc__ = fn.__module__, fn.__doc__
    # the cache files are named after the qualname; the version tag keeps machine code compiled
    # with other options (numba's cache key ignores them) from being loaded
    clone.__qualname__ = f"{fn.__qualname__}__{_CACHE_TAG}"
    options = {"inline": "always"} if inline else {}
    _JITTED[key] = out = numba.njit(cache=True, error_model="numpy", **options)(clone)
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
