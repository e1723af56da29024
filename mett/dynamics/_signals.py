"""Signals (Ctrl-C) during compiled runs: a clean ``KeyboardInterrupt`` at a step boundary.

CPython's C-level signal handler only notes the signal; the Python handler (for SIGINT
:func:`signal.default_int_handler`, which raises ``KeyboardInterrupt``) runs later, at the next
Python-level check. A compiled loop never makes such a check, so the handler used to run inside
the Python calls numba's call wrapper makes around the loop (unpickling the return types while
boxing the result, resolving the first-class function arguments): an exception raised there is not
checked by the generated code, which then gave ``SystemError: CPUDispatcher(...) returned a result
with an exception set`` or dereferenced a NULL object (a segfault), and only after the whole run.

Two parts make an interrupt clean and prompt:

* the compiled loops call :func:`poll` every few steps. It calls ``PyErr_CheckSignals`` (the loops
  hold the GIL; in a thread other than the main one it returns at once), which runs pending Python
  handlers there. A handler that raises has its exception taken out of the interpreter
  (``PyErr_Fetch``, so no Python code runs with an exception set) and kept in ``stop[1:4]``; the
  loop then returns normally and :func:`raise_pending` raises it again in Python.
* around the compiled call, :func:`deferred_sigint` replaces Python's default SIGINT handler (main
  thread only) with one that only sets ``stop[0]``; the loop stops at its next poll, and a SIGINT
  that arrives while numba's wrapper runs Python code is harmless. :func:`raise_pending` then
  raises ``KeyboardInterrupt``. A SIGINT handler of the user's own is left in place (it runs at
  the poll; if it raises, its exception is raised as above). Such a handler, or one of another
  signal, that raises during the few microseconds numba's wrapper runs Python code can still
  meet numba's unchecked path; Python's default SIGINT handler never does.

A poll costs about 25 ns when no signal is pending (``PyErr_CheckSignals`` reads one flag), and
the loops poll every 32 steps (``_POLL_EVERY`` in :mod:`.dop853` and :mod:`.taylor`): on the thesis
run, 2 630 steps of ~4 µs, that is 83 polls, about 2 µs of 11 ms.
"""

from __future__ import annotations

import ctypes
import signal
import threading
from typing import Any

import numba
import numpy as np
from numba import types

from .._numba_cache import install as _check_numba_cache

# before this module decorates its cache=True function: whichever mett module numba meets first,
# every cache file of mett is written and read with the checks (a file written with them cannot be
# read by numba's own class, nor the other way round)
_check_numba_cache()

try:  # the C functions behind signal.getsignal/signal: those convert to enums, 12 µs a call
    import _signal as _sig
except ImportError:  # pragma: no cover (another Python implementation)
    _sig = signal

__all__ = ["deferred_sigint", "new_stop", "poll", "raise_pending"]

# Python C-API functions, called from compiled code by name (resolved in the running interpreter,
# so the cached machine code holds no process-specific address)
_check_signals = types.ExternalFunction("PyErr_CheckSignals", types.intc())
_fetch = types.ExternalFunction(
    "PyErr_Fetch", types.void(types.voidptr, types.voidptr, types.voidptr)
)


@numba.njit(cache=True, _nrt=False)  # type: ignore[call-overload]  # numba's stub omits _nrt
def poll(stop):
    """True if the run must stop: a SIGINT was noted (``stop[0]`` set by the deferred handler) or
    a Python signal handler raised (its exception is then held in ``stop[1:4]``)."""
    if _check_signals() != 0:
        _fetch(stop[1:].ctypes, stop[2:].ctypes, stop[3:].ctypes)
        stop[0] = 2
    return stop[0] != 0


def new_stop() -> np.ndarray:
    """The flag array that :func:`poll`, :func:`deferred_sigint` and :func:`raise_pending` share:
    ``[flag, exception type, value, traceback]`` (the last three PyObject pointers or 0)."""
    return np.zeros(4, dtype=np.int64)


class _NoteSigint:
    """A SIGINT handler that notes the signal in ``stop[0]`` instead of raising."""

    def __init__(self, stop: np.ndarray, outer: object) -> None:
        self.stop, self.outer = stop, outer

    def __call__(self, signum: int, frame: object) -> None:
        self.stop[0] = 1
        if isinstance(self.outer, _NoteSigint):  # a compiled run nested in another one
            self.outer(signum, frame)


class deferred_sigint:
    """While the block runs, a SIGINT sets ``stop[0]`` instead of raising (main thread, and only
    if Python's default handler, or the one of an enclosing block, is installed). A few µs (two
    sigaction calls), against ~0.1 ms for numba to convert the arguments of a compiled call."""

    __slots__ = ("mine", "outer", "stop")

    def __init__(self, stop: np.ndarray) -> None:
        self.stop = stop
        self.outer: Any = None  # the handler replaced (a callable, SIG_DFL/SIG_IGN or None)
        self.mine: _NoteSigint | None = None

    def __enter__(self) -> None:
        if threading.get_ident() != threading.main_thread().ident:
            return
        outer = _sig.getsignal(signal.SIGINT)
        if outer is not signal.default_int_handler and not isinstance(outer, _NoteSigint):
            return  # SIG_IGN, SIG_DFL or the user's own handler: left as it is
        mine = _NoteSigint(self.stop, outer)
        try:
            _sig.signal(signal.SIGINT, mine)
        except ValueError:  # not the main interpreter
            return
        self.outer, self.mine = outer, mine

    def __exit__(self, *exc: Any) -> None:
        mine, self.mine = self.mine, None
        if mine is not None and _sig.getsignal(signal.SIGINT) is mine:  # unless replaced meanwhile
            _sig.signal(signal.SIGINT, self.outer)


_restore = ctypes.PYFUNCTYPE(None, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p)(
    ("PyErr_Restore", ctypes.pythonapi)
)


def raise_pending(stop: np.ndarray) -> None:
    """Raise what stopped a compiled run, if anything: a signal handler's exception held by
    :func:`poll`, else ``KeyboardInterrupt`` for a noted SIGINT."""
    if stop[1] != 0:
        ptype, value, tb = (int(x) for x in stop[1:4])
        stop[:] = 0
        # PyErr_Restore takes over the references PyErr_Fetch gave; ctypes then raises the
        # exception it set (a PYFUNCTYPE function checks for one after the call)
        _restore(ptype, value or None, tb or None)
    if stop[0] != 0:
        stop[:] = 0
        raise KeyboardInterrupt
