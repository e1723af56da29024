"""Compiled twins of the model right-hand sides and events, for the compiled DOP853 (:mod:`.dop853`).

The physics is written once. Each model module keeps its equations in private functions of plain
float arithmetic (``gliding._core``, ``rolling._core``, …) that numpy evaluates on floats or on
arrays of samples, and declares in its :class:`~mett.dynamics.registry.Model` an out-style
``rhs_into(t, y, p, out)`` and its events ``fn(t, y, p)``. This module compiles those very
functions with numba (:func:`compiled`): :func:`_jit` makes a copy of a function whose
module-level callees are replaced by their compiled versions (recursively) and jits it with
``cache=True``, and the events are gathered into one generated ``events_into(t, y, p, out)`` in
the order the model declares them. The reference right-hand side ``Model.rhs`` and the compiled
one therefore run the same source; the contract tests check that they agree to rounding.

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
from numba.core.dispatcher import Dispatcher

from .registry import Model, lookup

__all__ = ["compiled", "get"]

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


def _events_kernel(model_name: str, events: tuple) -> Callable:
    """One compiled ``events_into(t, y, p, out)`` writing ``out[k] = events[k].fn(t, y, p)``.

    Generated from the model's declared events (no hand-ordered list): the source is compiled
    with the file name of the events' module, so numba caches it next to that module and an
    edit of that module invalidates it (see the module docstring); the event functions are
    inlined as the callees of :func:`_jit` are.
    """
    fns = [ev.fn for ev in events]
    home = fns[0]
    if any(fn.__module__ != home.__module__ for fn in fns):
        raise ValueError(
            f"model {model_name!r}: its compiled events must live in one module (numba's cache "
            "tracks one source file); got " + ", ".join(fn.__module__ for fn in fns)
        )
    env = dict(home.__globals__)
    lines = ["def events_into(t, y, p, out):"]
    for k, fn in enumerate(fns):
        env[f"_event_{k}"] = _jit(fn, inline=True)
        lines.append(f"    out[{k}] = _event_{k}(t, y, p)")
    code = compile("\n".join(lines) + "\n", home.__code__.co_filename, "exec")
    scope: dict = {}
    exec(code, env, scope)  # our own generated source, from the declared events
    fn = types.FunctionType(scope["events_into"].__code__, env, "events_into")
    fn.__module__ = home.__module__
    tag = "_".join(f.__name__.strip("_") for f in fns)
    fn.__qualname__ = f"events_into__{model_name.replace('-', '_')}__{tag}__{_CACHE_TAG}"
    return numba.njit(cache=True, error_model="numpy")(fn)


_COMPILED: dict[tuple, tuple[Callable, Callable]] = {}


def compiled(model: Model, phase: str | None = None) -> tuple[Callable, Callable]:
    """The compiled (rhs, events) pair of a model (of one of its phases; default the first).

    ``rhs`` is ``rhs_into`` compiled (or used as given if it already is a numba dispatcher),
    ``events`` evaluates the phase's declared events in their declared order. Compiled (or loaded
    from numba's cache) at the first call, then kept for the process.
    """
    table = model.phase_table()
    ph = table[0] if phase is None else next(p for p in table if p.name == phase)
    if ph.rhs_into is None:
        raise ValueError(
            f"model {model.name!r} has no compiled right-hand side; use backend='scipy'"
        )
    key = (ph.rhs_into, tuple(ev.fn for ev in ph.events))
    if key not in _COMPILED:
        rhs = ph.rhs_into
        if not isinstance(rhs, Dispatcher):
            rhs = _jit(rhs)
        name = model.name if not ph.name else f"{model.name}_{ph.name}"
        _COMPILED[key] = (rhs, _events_kernel(name, ph.events))
    return _COMPILED[key]


def get(model: str | Model) -> tuple[Callable, Callable]:
    """The compiled (rhs, events) pair of a registered model's name (or of a Model)."""
    return compiled(lookup(model))
