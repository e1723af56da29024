"""numba's on-disk cache of mett's own compiled functions: a damaged file is a cache miss.

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

import hashlib
import io
import os
import pickle
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
