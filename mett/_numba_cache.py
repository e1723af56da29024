"""numba's on-disk cache of mett's own compiled functions: a damaged file is a cache miss; and
the one line mett prints on a terminal while it compiles machine code for its first use.

numba keeps the machine code of ``cache=True`` functions in pickles (an index ``*.nbi`` and data
files ``*.nbc``, in ``__pycache__`` beside the source or under ``NUMBA_CACHE_DIR``). It checks
neither: a truncated or overwritten file raised a raw ``UnpicklingError`` from every
:func:`mett.simulate` until the file was deleted, and a data file damaged inside its machine code
could be linked and run. :func:`install` makes numba treat the files of mett's own functions as
follows (the files of any other code are left to numba's own behaviour):

* the index and the data files are written with a sha256 of their contents in front and read
  only if it matches; anything else (damaged, truncated, written without the digest) is a miss,
  so the function is compiled again and its files are rewritten.

:func:`install` puts a subclass of numba's cache file class in its place (numba's own hooks,
overridden); it is called by every mett module that defines ``cache=True`` functions, after
importing numba and before decorating them.
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import os
import pickle
import sys
import threading
from collections.abc import Iterator
from functools import cache

_MAGIC = b"mett-nbc-sha256\n"
_HEAD = len(_MAGIC) + 32


@cache
def _mett_cache_dirs() -> tuple[frozenset[str], frozenset[str]]:
    """The ``__pycache__`` paths of mett's source directories, and the names numba gives their
    caches under ``NUMBA_CACHE_DIR`` or a user-wide cache (``<dir name>_<sha1 of its path>``)."""
    root = os.path.dirname(os.path.abspath(__file__))
    pycache, hashed = set(), set()
    for d, _, files in os.walk(root):
        if d.endswith("__pycache__") or not any(f.endswith(".py") for f in files):
            continue
        pycache.add(os.path.join(d, "__pycache__"))
        hashed.add(f"{os.path.basename(d)}_{hashlib.sha1(d.encode()).hexdigest()}")
    return frozenset(pycache), frozenset(hashed)


def _verified(raw: bytes) -> bytes | None:
    """The payload of a file written as magic + sha256 + payload, None if it does not match."""
    body = raw[_HEAD:]
    if raw[: len(_MAGIC)] != _MAGIC or hashlib.sha256(body).digest() != raw[len(_MAGIC) : _HEAD]:
        return None
    return body


def _is_mett_path(cache_path: str) -> bool:
    path = os.path.abspath(cache_path)
    pycache, hashed = _mett_cache_dirs()
    return path in pycache or os.path.basename(path) in hashed


def _checked_class(base: type) -> type:
    """numba's cache file class, with the checks of this module for mett's own files."""

    class CheckedCacheFile(base):
        mett_checked = True

        def _is_mett(self) -> bool:
            return _is_mett_path(self._cache_path)

        def _load_index(self):
            if not self._is_mett():
                return super()._load_index()
            try:
                with open(self._index_path, "rb") as f:
                    body = _verified(f.read())
                if body is None:  # damaged, or written without the digest: no entries
                    return {}
                stream = io.BytesIO(body)
                if pickle.load(stream) != self._version:  # numba's own rules from here on
                    return {}
                stamp, overloads = pickle.loads(stream.read())
            except Exception:  # missing or unreadable: no entries; the next save writes anew
                return {}
            ok = stamp == self._source_stamp and isinstance(overloads, dict)
            return overloads if ok else {}

        def _save_index(self, overloads):
            if not self._is_mett():
                return super()._save_index(overloads)
            body = pickle.dumps(self._version, protocol=-1)
            body += self._dump((self._source_stamp, overloads))
            with self._open_for_write(self._index_path) as f:
                f.write(_MAGIC + hashlib.sha256(body).digest() + body)

        def _load_data(self, name):
            if not self._is_mett():
                return super()._load_data(name)
            path = self._data_path(name)
            with open(path, "rb") as f:  # OSError: numba's load() treats it as a miss
                body = _verified(f.read())
            if body is None:
                raise OSError(f"damaged or unverified numba cache file {path}")
            try:
                return pickle.loads(body)
            except Exception as exc:  # a valid digest of a pickle this numba cannot read
                raise OSError(f"unreadable numba cache file {path}") from exc

        def _save_data(self, name, data):
            if not self._is_mett():
                return super()._save_data(name, data)
            body = self._dump(data)
            with self._open_for_write(self._data_path(name)) as f:
                f.write(_MAGIC + hashlib.sha256(body).digest() + body)

    return CheckedCacheFile


_HOOKS = ("_load_index", "_save_index", "_load_data", "_save_data", "_data_path", "_dump")


def install() -> None:
    """Make numba create its cache files with the checks of this module (idempotent).

    numba's ``Cache`` builds its file object from the module-level ``IndexDataCacheFile`` when a
    ``cache=True`` function is decorated, so this is called before mett's modules decorate
    theirs. It relies on numba's cache-file hooks (present in numba 0.5x-0.68); a numba without
    them keeps its own behaviour.
    """
    try:
        from numba.core import caching
    except ImportError:  # pragma: no cover - another numba layout: its own behaviour
        return
    base = getattr(caching, "IndexDataCacheFile", None)
    if base is None or getattr(base, "mett_checked", False):
        return
    if not all(hasattr(base, n) for n in (*_HOOKS, "_open_for_write")):  # pragma: no cover
        return
    # replaces numba's class on purpose (its subclass with the checks)
    caching.IndexDataCacheFile = _checked_class(base)  # type: ignore[misc, assignment]


# --- first use: a line on a terminal while machine code is built ------------------------------

_NOTICE_DELAY = 1.0
"""Seconds a first call may take before :func:`first_use` says it is compiling: loading cached
machine code takes well under that (about 0.3 s for the Taylor loop), compiling it far more."""

_NOTICED: list[bool] = [False]  # one line per process
_WARM: set[str] = set()  # what has run once in this process (no timer needed any more)


def _stderr_is_terminal() -> bool:
    try:
        return sys.stderr is not None and sys.stderr.isatty()
    except (AttributeError, ValueError):  # replaced or closed
        return False


def notice(what: str) -> None:
    """One line on stderr, if it is a terminal and none was printed in this process yet: mett is
    compiling ``what`` (once per installation; ``mett warmup`` does it ahead of time)."""
    if _NOTICED[0] or not _stderr_is_terminal():
        return
    _NOTICED[0] = True
    try:
        print(
            f"mett: compiling {what} for its first use (once per installation; "
            "`mett warmup` builds the default kernels ahead of time)...",
            file=sys.stderr,
            flush=True,
        )
    except (OSError, ValueError):  # stderr went away: the notice is not worth an error
        pass


@contextlib.contextmanager
def first_use(key: str, what: str) -> Iterator[None]:
    """Around the first call of ``key`` in a process (e.g. a backend's first run of a model):
    if it takes longer than :data:`_NOTICE_DELAY`, it is compiling machine code (numba cannot
    say beforehand whether its cache will load): :func:`notice` then, from a timer thread.
    Later calls of ``key`` cost a set lookup."""
    if key in _WARM or _NOTICED[0] or not _stderr_is_terminal():
        yield
        _WARM.add(key)
        return
    timer = threading.Timer(_NOTICE_DELAY, notice, args=(what,))
    timer.daemon = True
    timer.start()
    try:
        yield
    finally:
        timer.cancel()
    _WARM.add(key)
