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

The methods are wrapped in place, so functions decorated before :func:`install` are covered too;
it is called by every mett module that defines ``cache=True`` functions, after importing numba.
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


def _is_mett(cache_file: object) -> bool:
    path = os.path.abspath(getattr(cache_file, "_cache_path", ""))
    pycache, hashed = _mett_cache_dirs()
    return path in pycache or os.path.basename(path) in hashed


def install() -> None:
    """Wrap numba's cache file methods for mett's functions (idempotent; a numba without these
    methods is left as it is)."""
    try:
        from numba.core.caching import IndexDataCacheFile as F
    except ImportError:  # pragma: no cover - another numba layout: its own behaviour
        return
    if getattr(F, "_mett_checked", False):
        return
    names = (
        "_load_index",
        "_save_index",
        "_load_data",
        "_save_data",
        "_data_path",
        "_dump",
        "_open_for_write",
    )
    if not all(hasattr(F, n) for n in names):  # pragma: no cover - another numba
        return
    load_index, save_index = F._load_index, F._save_index
    load_data, save_data = F._load_data, F._save_data

    def _load_index(self):
        if not _is_mett(self):
            return load_index(self)
        try:
            with open(self._index_path, "rb") as f:
                body = _verified(f.read())
            if body is None:  # damaged, or written without the digest: no entries
                return {}
            stream = io.BytesIO(body)
            if pickle.load(stream) != self._version:  # numba's own rules from here on
                return {}
            stamp, overloads = pickle.loads(stream.read())
        except Exception:  # missing or unreadable: no entries; the next save writes a new one
            return {}
        return overloads if stamp == self._source_stamp and isinstance(overloads, dict) else {}

    def _save_index(self, overloads):
        if not _is_mett(self):
            return save_index(self, overloads)
        body = pickle.dumps(self._version, protocol=-1)
        body += self._dump((self._source_stamp, overloads))
        with self._open_for_write(self._index_path) as f:
            f.write(_MAGIC + hashlib.sha256(body).digest() + body)

    def _load_data(self, name):
        if not _is_mett(self):
            return load_data(self, name)
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
        if not _is_mett(self):
            return save_data(self, name, data)
        body = self._dump(data)
        with self._open_for_write(self._data_path(name)) as f:
            f.write(_MAGIC + hashlib.sha256(body).digest() + body)

    F._load_index, F._save_index = _load_index, _save_index
    F._load_data, F._save_data = _load_data, _save_data
    F._mett_checked = True
