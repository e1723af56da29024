"""Machine code for :mod:`mett.dynamics.taylor`: the IR compiled with llvmlite, and the on-disk cache
of the compiled objects with its security checks (:func:`cache_dir`, :func:`_native`).
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import stat
import tempfile
import threading
from pathlib import Path
from typing import Any

from ..._numba_cache import notice
from ..._validate import MettWarning, warn

# --- machine code -----------------------------------------------------------------------------

_LOCK = threading.Lock()
_ENGINES: list[Any] = []  # execution engines must outlive every pointer into their code
_ADDRESSES: dict[str, tuple[int, int]] = {}


class UnsafeCacheWarning(MettWarning):
    """The on-disk cache of compiled Taylor kernels is owned by another user or writable by
    others; mett did not use it (the kernel was compiled in memory) and wrote nothing there."""


# The cache holds machine code that is linked into the process and called, so it is read only
# from the user's own directory, only if that directory and the file belong to the user and
# nobody else can write them, and only after the object's sha256 and the build it was made for
# (IR, llvmlite, target, CPU and its features) match what this process would compile.
_CACHE_FORMAT = 1
_MAX_OBJECT_BYTES = 256 << 20  # far above any kernel (~0.1-2 MB); bounds what a bad file costs
_MAX_META_BYTES = 64 << 10
_UNSAFE_WARNED: set[str] = set()
_SOURCES: dict[str, str] = {}  # kernel name -> "loaded", "written" or "memory" (for tests)


def cache_dir() -> Path:
    """The directory of the on-disk cache of compiled Taylor kernels.

    Returns
    -------
    Path
        ``$METT_CACHE_DIR/taylor`` if ``METT_CACHE_DIR`` is set, else
        ``$XDG_CACHE_HOME/mett/taylor`` (an absolute ``XDG_CACHE_HOME`` only, as the XDG
        specification says), else ``~/.cache/mett/taylor``.

    Notes
    -----
    Never a shared directory: if this one cannot be created or written, kernels are compiled in
    memory for the process and not cached. mett creates it with mode 0700 and reads a kernel
    from it only if the directory and the file belong to the current user, nobody else can
    write them, and the file's sha256 and build record match (docs: reliability, "Caches and
    compiled code"); otherwise it compiles in memory and warns with
    :class:`UnsafeCacheWarning`.
    """
    base = os.environ.get("METT_CACHE_DIR")
    if base:
        return Path(base) / "taylor"
    xdg = os.environ.get("XDG_CACHE_HOME")
    root = Path(xdg) if xdg and os.path.isabs(xdg) else Path.home() / ".cache"
    return root / "mett" / "taylor"


def _unsafe(st: os.stat_result) -> str | None:
    """Why a cache entry with this ``stat`` may not be trusted, or None (POSIX owner and mode;
    on Windows, where neither means this, the user's profile directory is private by its ACL)."""
    if not hasattr(os, "geteuid"):  # pragma: no cover - Windows
        return None
    if st.st_uid != os.geteuid():
        return f"owned by uid {st.st_uid}, not by the current user ({os.geteuid()})"
    if st.st_mode & 0o022:
        return f"writable by group or others (mode {stat.S_IMODE(st.st_mode):04o})"
    return None


def _warn_unsafe(path: Path, why: str) -> None:
    if str(path) in _UNSAFE_WARNED:
        return
    _UNSAFE_WARNED.add(str(path))
    warn(
        f"not using the Taylor kernel cache {path}: it is {why}; compiling in memory instead "
        "(make the directory yours with mode 0700, or set METT_CACHE_DIR to a private one)",
        UnsafeCacheWarning,
    )


def _private_dir(d: Path) -> bool | None:
    """Create the cache directory ``d`` (and its parent ``mett`` directory) with mode 0700 if
    missing. True: ``d`` is safe to use; False: it exists but is unsafe (warned); None: it cannot
    be created (a read-only home: no cache, silently)."""
    try:
        d.parent.parent.mkdir(parents=True, exist_ok=True)
        for part in (d.parent, d):
            part.mkdir(mode=0o700, exist_ok=True)
        st = os.stat(d)
    except OSError:
        return None
    if not stat.S_ISDIR(st.st_mode):
        return None
    why = _unsafe(st)
    if why:
        _warn_unsafe(d, why)
        return False
    return True


def _read_private(path: Path, limit: int) -> bytes | None:
    """The bytes of ``path`` if it is a regular file of the current user that nobody else can
    write (checked on the open descriptor, so the file cannot be swapped between check and read)
    and at most ``limit`` bytes; None if it does not exist or cannot be read. Raises
    ``PermissionError`` with the reason if the file is not trustworthy."""
    try:
        # O_NOFOLLOW: a symbolic link fails (ELOOP); O_NONBLOCK: a FIFO cannot block the open
        flags = os.O_RDONLY | sum(
            getattr(os, f, 0) for f in ("O_NONBLOCK", "O_NOFOLLOW", "O_CLOEXEC")
        )
        fd = os.open(path, flags)
    except OSError:  # missing, a symbolic link (ELOOP), unreadable
        return None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            return None
        why = _unsafe(st)
        if why:
            raise PermissionError(why)
        if st.st_size > limit:
            return None
        with os.fdopen(fd, "rb", closefd=False) as f:
            return f.read(limit + 1)
    except PermissionError:
        raise
    except OSError:
        return None
    finally:
        os.close(fd)


def _write_atomic(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically: a new file of mode 0600 in the same directory
    (``O_EXCL``), fsynced, then renamed over ``path``; a reader sees the old file or the new
    one, never part of one. Raises ``OSError``; leaves no temporary file behind."""
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    with contextlib.suppress(OSError):  # make the rename itself durable (ext4: else an empty file)
        dfd = os.open(path.parent, os.O_RDONLY)
        try:
            os.fsync(dfd)
        finally:
            os.close(dfd)


def _build_id(ir: str, tm: Any) -> dict[str, Any]:
    """What the machine code of ``ir`` depends on besides the IR itself: recorded beside each
    cached object and compared before it is loaded (the CPU features too: virtual machines with
    the same CPU name can mask different instruction sets)."""
    import llvmlite
    import llvmlite.binding as llvm

    return {
        "format": _CACHE_FORMAT,
        "ir_sha256": hashlib.sha256(ir.encode()).hexdigest(),
        "llvmlite": llvmlite.__version__,
        "triple": tm.triple,
        "cpu": llvm.get_host_cpu_name(),
        "features": llvm.get_host_cpu_features().flatten(),
    }


def _cache_paths(name: str, build: dict[str, Any]) -> tuple[Path, Path]:
    """The object file of kernel ``name`` for ``build`` (:func:`_build_id`) and its record."""
    key = hashlib.sha256(json.dumps(build, sort_keys=True).encode()).hexdigest()[:24]
    obj = cache_dir() / f"{name}-{key}.o"
    return obj, obj.with_name(obj.name + ".json")


def _cached_object(obj_path: Path, meta_path: Path, build: dict[str, Any]) -> bytes | None:
    """The cached object if its record matches ``build`` and the object's sha256; None if it is
    missing, damaged or stale (to be rebuilt). Raises ``PermissionError`` if not trustworthy."""
    raw_meta = _read_private(meta_path, _MAX_META_BYTES)
    if raw_meta is None:
        return None
    try:
        meta = json.loads(raw_meta)
    except ValueError:
        return None
    if not isinstance(meta, dict) or any(meta.get(k) != v for k, v in build.items()):
        return None
    obj = _read_private(obj_path, _MAX_OBJECT_BYTES)
    if obj is None or hashlib.sha256(obj).hexdigest() != meta.get("sha256"):
        return None
    return obj


def _target_machine() -> Any:
    import llvmlite.binding as llvm

    llvm.initialize_native_target()
    llvm.initialize_native_asmprinter()
    target = llvm.Target.from_default_triple()
    return target.create_target_machine(
        opt=3,
        cpu=llvm.get_host_cpu_name(),
        features=llvm.get_host_cpu_features().flatten(),
        reloc="pic",
        codemodel="jitdefault",
    )


def _compile(ir: str, tm: Any) -> bytes:
    import llvmlite.binding as llvm

    mod = llvm.parse_assembly(ir)
    mod.verify()
    # llvmlite leaves the SLP vectorizer off; on: no faster here, and 10-100x the compile
    # time (80 s for the rolling top's jet)
    pb = llvm.create_pass_builder(tm, llvm.create_pipeline_tuning_options(speed_level=3))
    pb.getModulePassManager().run(mod, pb)
    return tm.emit_object(mod)


def _native(ir: str, name: str) -> tuple[int, int]:
    """Addresses of ``name`` and ``name_update`` compiled from ``ir`` (machine code cached in the
    user's :func:`cache_dir`, verified before it is loaded)."""
    import llvmlite.binding as llvm

    with _LOCK:
        if name in _ADDRESSES:
            return _ADDRESSES[name]
        tm = _target_machine()
        build = _build_id(ir, tm)
        obj_path, meta_path = _cache_paths(name, build)
        usable = _private_dir(obj_path.parent)
        obj = None
        if usable:
            try:
                obj = _cached_object(obj_path, meta_path, build)
            except PermissionError as exc:  # a planted or foreign file: neither used nor replaced
                _warn_unsafe(obj_path, str(exc))
                usable = False
        source = "loaded"
        if obj is None:
            notice(f"the Taylor kernel {name}")  # a terminal hears why the first call waits
            obj = _compile(ir, tm)
            source = "memory"
            if usable:  # a damaged or stale entry is replaced; a failed write costs nothing
                meta = {**build, "name": name, "sha256": hashlib.sha256(obj).hexdigest()}
                try:
                    _write_atomic(obj_path, obj)  # the object first: its record vouches for it
                    _write_atomic(meta_path, json.dumps(meta, sort_keys=True).encode())
                    source = "written"
                except OSError:
                    pass
        ee = llvm.create_mcjit_compiler(llvm.parse_assembly(""), tm)
        ee.add_object_file(llvm.ObjectFileRef.from_data(obj))
        ee.finalize_object()
        addr = (ee.get_function_address(name), ee.get_function_address(f"{name}_update"))
        if not all(addr):  # pragma: no cover - an object without the kernel's symbols
            raise RuntimeError(f"compiled Taylor kernel {name} has no entry point")
        _ENGINES.append(ee)
        _ADDRESSES[name] = addr
        _SOURCES[name] = source
        return addr
