"""Compiled twins of the model right-hand sides and events, for the compiled DOP853 (:mod:`.dop853`).

The physics is written once. Each model module keeps its equations in private functions of plain
float arithmetic (``gliding.gliding_core``, ``rolling._core``, …) that numpy evaluates on floats or on
arrays of samples, and declares in its :class:`~mett.dynamics.registry.Model` an out-style
``rhs_into(t, y, p, out)`` and its events ``fn(t, y, p)``. This module compiles those very
functions with numba (:func:`compiled`): :func:`_jit` makes a copy of a function whose
module-level callees are replaced by their compiled versions (recursively) and jits it with
``cache=True``, and the events are gathered into one generated ``events_into(t, y, p, out)`` in
the order the model declares them. The reference right-hand side ``Model.rhs`` and the compiled
one therefore run the same source; the contract tests check that they agree to rounding.

Only :func:`mett.simulate` imports this module, when it runs the compiled backend: ``import mett``
does not import numba. Compiling from scratch takes a few seconds per model; later processes load
the machine code from numba's cache (``__pycache__`` next to the model modules). numba keys the
cache of a compiled function on that function's source file only; callees from other files of
mett are covered by a hash of those files in the cache name, so editing any module a kernel
inlines invalidates that kernel.

The kernels use numba's ``error_model="numpy"``: a division by zero gives inf/nan (which the
integrator rejects and reports as status "failed") instead of raising inside compiled code.
"""

from __future__ import annotations

import hashlib
import types
from collections.abc import Callable
from typing import Any, cast

import numba
from numba.core.dispatcher import Dispatcher

from .._numba_cache import install as _check_numba_cache
from .dop853 import FUNCTION_SIGNATURE
from .registry import MODELS, Model, Phase, lookup

_check_numba_cache()  # a damaged numba cache file of mett is a miss, not an error

__all__ = ["compiled", "get"]

_JITTED: dict[tuple[Callable, bool], Callable] = {}
# Part of the name of every kernel's cache files. numba 0.68 keys its on-disk cache on the function's
# bytecode and the hash of its source file, not on the compile options: change this tag whenever the
# options of _jit change, or processes keep loading machine code compiled with the old ones.
_CACHE_TAG = "inl1"


def _jit(fn: types.FunctionType, inline: bool = False) -> Callable:
    """``numba.njit(cache=True)`` of a plain-arithmetic function and of the functions it calls.

    Module-level functions that ``fn`` refers to by name, from its own module or from any module
    of mett (e.g. a friction model calling ``gliding_normal_force``), are compiled first and bound
    in a copy of its globals, since compiled code can only call compiled code. They are compiled
    with ``inline="always"``: numba then inlines them into the caller's IR. A real call boundary
    cost far more than the arithmetic: the gliding right-hand side took 115 ns per call when it
    called ``_core`` (passing the state and parameter arrays into a compiled call, and the 13-tuple
    back) and 29 ns with ``_core`` inlined (measured on the thesis run's machine, 1e6 calls).
    A large function that many events of a phase call (a dry contact force, marked with
    :func:`mett.dynamics.registry.kernel_call`) is compiled once, without the numba runtime, and
    called instead: inlined into every event it was compiled once per call site, tens of
    seconds of CPU per phase.

    numba's cache is stamped with the source file of ``fn`` only; the code inlined from other
    files, and the modules of mett whose constants it reads (``ix.MU``), are covered by a hash of
    those files in the cache name (:func:`_foreign_tag`).
    """
    key = (fn, inline)
    if key in _JITTED:
        return _JITTED[key]
    env = dict(fn.__globals__)
    deps: set[str] = set()
    for name in fn.__code__.co_names:
        callee = env.get(name)
        if isinstance(callee, types.FunctionType) and _inlinable(callee, fn):
            # marked by registry.kernel_call: compiled once and called, not inlined
            env[name] = _jit(callee, inline=not getattr(callee, "kernel_call", False))
            deps |= _DEPS[env[name]] | {callee.__code__.co_filename}
        elif isinstance(callee, types.ModuleType) and _own_module(callee):
            # a module of mett read for its constants (e.g. the parameter positions ``ix.MU``):
            # numba freezes them into the machine code, so its file is part of the cache name
            deps.add(str(callee.__file__))
    clone = types.FunctionType(fn.__code__, env, fn.__name__, fn.__defaults__, fn.__closure__)
    clone.__module__, clone.__doc__ = fn.__module__, fn.__doc__
    # the cache files are named after the qualname; the version tag keeps machine code compiled
    # with other options (numba's cache key ignores them) from being loaded
    called = getattr(fn, "kernel_call", False) and not inline
    # a kernel_call runs without the numba runtime (its own tag: other options, other code): with
    # it every call increfs and decrefs the state array atomically, ~5-10 % of a dry run's time
    tag = _CACHE_TAG + ("c" if called else "")
    clone.__qualname__ = f"{fn.__qualname__}__{tag}{_foreign_tag(deps, fn)}"
    options: dict[str, Any] = {"inline": "always"} if inline else {}
    if called:
        options["_nrt"] = False
    _JITTED[key] = out = numba.njit(cache=True, error_model="numpy", **options)(clone)
    _DEPS[out] = frozenset(deps)
    return out


_DEPS: dict[Callable, frozenset[str]] = {}
"""Source files whose code each compiled function inlines."""


def _inlinable(callee: types.FunctionType, fn: types.FunctionType) -> bool:
    """A callee :func:`_jit` compiles along with ``fn``: same module, or a module of mett."""
    mod = callee.__module__ or ""
    return mod == fn.__module__ or mod == "mett" or mod.startswith("mett.")


def _own_module(module: types.ModuleType) -> bool:
    name = module.__name__
    return (name == "mett" or name.startswith("mett.")) and bool(getattr(module, "__file__", None))


def _foreign_tag(files: set[str], fn: types.FunctionType) -> str:
    """``""``, or ``"_"`` + a hash of the files other than ``fn``'s own that ``fn`` inlines."""
    foreign = sorted(f for f in files if f != fn.__code__.co_filename)
    if not foreign:
        return ""
    h = hashlib.sha1(usedforsecurity=False)
    for path in foreign:
        with open(path, "rb") as fh:
            h.update(fh.read())
    return "_" + h.hexdigest()[:10]


def _events_kernel(model_name: str, events: tuple) -> Callable:
    """One compiled ``events_into(t, y, p, out)`` writing ``out[k] = events[k].fn(t, y, p)``.

    Generated from the model's declared events (no hand-ordered list): the source is compiled
    with the file name of the first event's module, so numba caches it next to that module and
    an edit of that module invalidates it; the code of other files it inlines (other events'
    modules, their callees) is covered by a hash in its cache name, as in :func:`_jit`.
    """
    fns = [ev.fn for ev in events]
    home = fns[0]
    env = dict(home.__globals__)
    lines = ["def events_into(t, y, p, out):"]
    deps: set[str] = set()
    for k, fn in enumerate(fns):
        env[f"_event_{k}"] = jitted = _jit(fn, inline=True)
        deps |= _DEPS[jitted] | {fn.__code__.co_filename}
        lines.append(f"    out[{k}] = _event_{k}(t, y, p)")
    code = compile("\n".join(lines) + "\n", home.__code__.co_filename, "exec")
    scope: dict = {}
    exec(code, env, scope)  # our own generated source, from the declared events
    fn = types.FunctionType(scope["events_into"].__code__, env, "events_into")
    fn.__module__ = home.__module__
    tag = "_".join(f.__name__.strip("_") for f in fns)
    fn.__qualname__ = (
        f"events_into__{model_name.replace('-', '_')}__{tag}__{_CACHE_TAG}{_foreign_tag(deps, fn)}"
    )
    return numba.njit(cache=True, error_model="numpy")(fn)


_COMPILED: dict[tuple, tuple[Callable, Callable]] = {}


def _phase_key(ph: Phase) -> tuple:
    return (ph.rhs_into, tuple(ev.fn for ev in ph.events))


def _kernel_owner(model: Model, ph: Phase, key: tuple) -> str:
    """The model name in the cache name of a phase's events kernel: the first, alphabetically, of
    the registered models with the same phase (same functions). Models that differ in their
    parameters alone ("coulomb" and "coulomb-contensou", "stemmed-coulomb" and
    "stemmed-coulomb-contensou") then share one kernel on disk, whichever a process runs first;
    named after the model that compiled it first, each was compiled again (tens of seconds of
    CPU per phase of the dry laws) in every process that ran the other first."""
    names = [model.name]
    for other in MODELS.values():
        for q in other.phase_table():
            if q.name == ph.name and q.events and _phase_key(q) == key:
                names.append(other.name)
    return min(names)


def compiled(model: Model, phase: str | None = None) -> tuple[Callable, Callable]:
    """The compiled (rhs, events) pair of a model (of one of its phases; default the first).

    ``rhs`` is ``rhs_into`` compiled (or used as given if it already is a numba dispatcher),
    ``events`` evaluates the phase's declared events in their declared order. Compiled (or loaded
    from numba's cache) at the first call, then kept for the process.
    """
    table = model.phase_table()
    ph = table[0] if phase is None else next(p for p in table if p.name == phase)
    if not ph.events:
        raise ValueError(f"model {model.name!r}, phase {ph.name!r}: no events to compile")
    if ph.rhs_into is None:
        raise ValueError(
            f"model {model.name!r} has no compiled right-hand side; use backend='scipy'"
        )
    key = _phase_key(ph)
    if key not in _COMPILED:
        rhs = ph.rhs_into
        if not isinstance(rhs, Dispatcher):
            if not isinstance(rhs, types.FunctionType):
                raise TypeError(
                    f"rhs_into of model {model.name!r} must be a Python function or a numba "
                    f"function; got {type(rhs).__name__}"
                )
            rhs = _jit(rhs)
        base = _kernel_owner(model, ph, key)
        name = base if not ph.name else f"{base}_{ph.name}"
        events = _events_kernel(name, ph.events)
        # Compiled (or loaded) here under the driver's signature, the key of numba's disk cache.
        # The driver passes the kernels as first-class functions of FUNCTION_SIGNATURE, a call
        # from Python compiles for the argument types alone: two cache keys, so a fresh process
        # that called a kernel from Python first compiled it a second time (the largest event
        # kernels twice on every cold machine). A Python call now finds this overload.
        for kernel in (rhs, events):
            cast(Dispatcher, kernel).compile(FUNCTION_SIGNATURE)
        _COMPILED[key] = (rhs, events)
    return _COMPILED[key]


def get(model: str | Model) -> tuple[Callable, Callable]:
    """The compiled (rhs, events) pair of a registered model's name (or of a Model)."""
    return compiled(lookup(model))
