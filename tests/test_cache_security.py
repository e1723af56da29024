"""The on-disk cache of compiled Taylor kernels: never code from a place another user can write,
never a crash from a damaged file (docs/reliability.md, "Caches and compiled code").

Every run that could load planted or damaged machine code runs in a subprocess, so a segfault or
an illegal instruction fails the test instead of killing pytest. The kernel is the harmonic
oscillator y'' = −ω² y, whose solution cos ωt is the independent reference: a planted kernel
computes cosh ωt instead, so loading it shows in the numbers.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import numba
import numpy as np
import pytest

from mett.dynamics import taylor
from mett.dynamics.taylor import _codegen, _llvm, _loop

ORDER = 12
OMEGA2 = 4.0  # ω² of the oscillator: y = cos 2t
T_END = 10.0

SCRIPT = (
    textwrap.dedent(
        """
    import json, math, sys, warnings
    import numpy as np
    from mett.dynamics import taylor
    from mett.dynamics.taylor import _llvm

    def osc(t, y, p, out):
        out[0] = y[1]
        out[1] = -p[0] * y[0]

    orders = [int(a) for a in sys.argv[1:]] or [ORDER]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        kernels = [taylor.kernel(osc, [], 2, 1, order, "cachetest") for order in orders]
    out = {"warnings": [[w.category.__name__, str(w.message)] for w in caught], "runs": []}
    for k in kernels:
        sol = taylor.solve(k, (0.0, T_END), [1.0, 0.0], [OMEGA2])[0]
        t, y = sol.dense.t, sol.dense.y
        err = float(np.max(np.abs(y[:, 0] - np.cos(math.sqrt(OMEGA2) * t))))
        out["runs"].append({"name": k.name, "source": _llvm._SOURCES[k.name],
                            "status": sol.status, "t": float(t[-1]), "err": err,
                            "order": k.order, "steps": sol.n_steps})
    print(json.dumps(out))
    """
    )
    .replace("ORDER", str(ORDER))
    .replace("T_END", str(T_END))
    .replace("OMEGA2", str(OMEGA2))
)


def _osc(t, y, p, out):  # the same oscillator as the script's (same graph, same kernel name)
    out[0] = y[1]
    out[1] = -p[0] * y[0]


def _anti(t, y, p, out):  # the planted kernel: y'' = +ω² y (cosh)
    out[0] = y[1]
    out[1] = p[0] * y[0]


def _env(cache: Path, tmpdir: Path | None = None) -> dict[str, str]:
    env = dict(os.environ, METT_CACHE_DIR=str(cache))
    if tmpdir is not None:
        env["TMPDIR"] = str(tmpdir)
    return env


def _run(env: dict[str, str], *orders: int) -> dict:
    """Run the script; a crash (signal) or an error fails the test with its output."""
    proc = subprocess.run(
        [sys.executable, "-c", SCRIPT, *map(str, orders)],
        env=env,
        capture_output=True,
        text=True,
        check=False,
    )
    assert proc.returncode == 0, f"rc {proc.returncode}\n{proc.stdout}\n{proc.stderr[-3000:]}"
    return json.loads(proc.stdout.strip().splitlines()[-1])


def _correct(run: dict) -> None:
    """The run reached T_END with the error of its order: each step's truncation error is
    ≈ ε |y| for ε = exp(−2 (p − 1)) (the tolerance whose order is p, Jorba & Zou 2005, §3.3) and
    |y| ≤ ω = 2 here, so over n steps at most 2 n ε, taken twice for the estimate, plus rounding.
    A planted cosh kernel is off by cosh(20) ≈ 2.4e8."""
    assert run["status"] == taylor.COMPLETED and run["t"] == T_END
    bound = 4.0 * run["steps"] * (math.exp(-2.0 * (run["order"] - 1)) + 1e-15)
    assert run["err"] < bound, run


def _victim_files(order: int = ORDER) -> tuple[str, str, Path, Path]:
    """Name, IR and cache paths (relative to the cache dir) of the script's kernel."""
    tr = taylor.trace(_osc, [], 2, 1)
    name, ir = _codegen._kernel_source(tr, order, "cachetest", 1, _codegen._norm_groups((), 2))
    obj, meta = _llvm._cache_paths(name, _llvm._build_id(ir, _llvm._target_machine()))
    return name, ir, Path(obj.name), Path(meta.name)


def _evil_object(name: str) -> bytes:
    """A valid object file with the victim kernel's symbols that integrates cosh instead."""
    tr = taylor.trace(_anti, [], 2, 1)
    ir = _codegen._IR(tr, ORDER, name, 1, _codegen._norm_groups((), 2)).text()
    return _llvm._compile(ir, _llvm._target_machine())


def _plant(d: Path, name: str, ir: str, obj_name: Path, meta_name: Path) -> bytes:
    """Plant the evil object under the victim's file name with a record that matches it (what
    an attacker who can write ``d`` can do), and under the name the old temp-dir cache used."""
    import llvmlite
    import llvmlite.binding as llvm

    d.mkdir(parents=True, exist_ok=True)
    evil = _evil_object(name)
    build = _llvm._build_id(ir, _llvm._target_machine())
    meta = {**build, "name": name, "sha256": hashlib.sha256(evil).hexdigest()}
    (d / obj_name).write_bytes(evil)
    (d / meta_name).write_text(json.dumps(meta, sort_keys=True))
    tm = _llvm._target_machine()
    old_key = hashlib.sha256(
        "\0".join([ir, llvm.get_host_cpu_name(), tm.triple, llvmlite.__version__]).encode()
    ).hexdigest()[:24]
    (d / f"{name}-{old_key}.o").write_bytes(evil)
    return evil


def _listing(d: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(d.iterdir())}


# --- where the cache is -------------------------------------------------------------------------


def test_no_shared_temp_dir_in_the_package():
    src = Path(taylor.__file__).resolve().parents[2]  # the mett package
    hits = [p for p in src.rglob("*.py") if "gettempdir" in p.read_text(encoding="utf-8")]
    assert hits == []


def test_cache_dir_is_the_users_own(monkeypatch, tmp_path):
    monkeypatch.setenv("METT_CACHE_DIR", str(tmp_path / "m"))
    assert taylor.cache_dir() == tmp_path / "m" / "taylor"
    monkeypatch.delenv("METT_CACHE_DIR")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "x"))
    assert taylor.cache_dir() == tmp_path / "x" / "mett" / "taylor"
    monkeypatch.setenv("XDG_CACHE_HOME", "relative/dir")  # the XDG spec: ignore a relative one
    monkeypatch.setenv("HOME", str(tmp_path / "h"))
    assert taylor.cache_dir() == tmp_path / "h" / ".cache" / "mett" / "taylor"


def test_a_new_cache_is_private_and_verified_on_the_next_run(tmp_path):
    cache = tmp_path / "cache"
    first = _run(_env(cache))["runs"][0]
    _correct(first)
    assert first["source"] == "written"
    d = cache / "taylor"
    for part in (cache, d):
        assert part.stat().st_mode & 0o777 == 0o700
    name, _, obj_name, meta_name = _victim_files()
    assert first["name"] == name
    files = sorted(p.name for p in d.iterdir())
    assert files == sorted([obj_name.name, meta_name.name])  # no temporary file left
    for f in files:
        assert (d / f).stat().st_mode & 0o777 == 0o600
    meta = json.loads((d / meta_name).read_text())
    obj = (d / obj_name).read_bytes()
    assert meta["sha256"] == hashlib.sha256(obj).hexdigest()
    import llvmlite.binding as llvm

    assert meta["features"] == llvm.get_host_cpu_features().flatten()
    second = _run(_env(cache))["runs"][0]
    _correct(second)
    assert second["source"] == "loaded"


# --- planted code is never loaded ---------------------------------------------------------------


def test_an_object_planted_in_the_old_temp_location_is_not_loaded(tmp_path):
    fake_tmp = tmp_path / "tmp"
    name, ir, obj_name, meta_name = _victim_files()
    planted = fake_tmp / "mett-cache" / "taylor"
    _plant(planted, name, ir, obj_name, meta_name)
    before = _listing(planted)
    out = _run(_env(tmp_path / "victim", fake_tmp))
    _correct(out["runs"][0])  # cos, not the planted cosh
    assert out["runs"][0]["source"] == "written" and out["warnings"] == []
    assert _listing(planted) == before
    assert sorted(p.name for p in fake_tmp.iterdir()) == ["mett-cache"]  # nothing else written
    assert (tmp_path / "victim" / "taylor" / obj_name).exists()


def test_a_group_writable_cache_dir_is_not_used(tmp_path):
    cache = tmp_path / "shared"
    d = cache / "taylor"
    name, ir, obj_name, meta_name = _victim_files()
    _plant(d, name, ir, obj_name, meta_name)
    os.chmod(d, 0o777)
    before = _listing(d)
    out = _run(_env(cache), ORDER, ORDER + 2)  # two kernels, one warning
    for run in out["runs"]:
        _correct(run)
        assert run["source"] == "memory"
    assert [w[0] for w in out["warnings"]] == ["UnsafeCacheWarning"]
    assert "writable by group or others" in out["warnings"][0][1]
    assert _listing(d) == before  # nothing written into it


@pytest.mark.skipif(os.geteuid() != 0, reason="needs root to give a directory to another user")
def test_a_cache_dir_owned_by_another_user_is_not_used(tmp_path):
    cache = tmp_path / "foreign"
    d = cache / "taylor"
    name, ir, obj_name, meta_name = _victim_files()
    _plant(d, name, ir, obj_name, meta_name)
    os.chmod(d, 0o700)
    os.chown(d, 65534, 65534)
    before = _listing(d)
    out = _run(_env(cache))
    _correct(out["runs"][0])
    assert out["runs"][0]["source"] == "memory"
    assert [w[0] for w in out["warnings"]] == ["UnsafeCacheWarning"]
    assert "owned by uid 65534" in out["warnings"][0][1]
    assert _listing(d) == before


@pytest.mark.parametrize("how", ["group-writable", "other-owner", "symlink"])
def test_a_planted_file_in_the_own_cache_dir_is_not_loaded(tmp_path, how):
    if how == "other-owner" and os.geteuid() != 0:
        pytest.skip("needs root to give a file to another user")
    cache = tmp_path / "cache"
    d = cache / "taylor"
    d.mkdir(parents=True, mode=0o700)
    name, ir, obj_name, meta_name = _victim_files()
    elsewhere = tmp_path / "elsewhere"
    _plant(elsewhere if how == "symlink" else d, name, ir, obj_name, meta_name)
    if how == "symlink":  # links to files another user controls: O_NOFOLLOW refuses them
        (d / obj_name).symlink_to(elsewhere / obj_name)
        (d / meta_name).symlink_to(elsewhere / meta_name)
    elif how == "group-writable":
        os.chmod(d / obj_name, 0o666)
    else:
        os.chown(d / obj_name, 65534, 65534)
        os.chmod(d / obj_name, 0o644)
    out = _run(_env(cache))
    run = out["runs"][0]
    _correct(run)
    if how == "symlink":  # treated as missing: compiled and written over the links
        assert run["source"] == "written" and out["warnings"] == []
        assert not (d / obj_name).is_symlink() and not (d / meta_name).is_symlink()
        assert (elsewhere / obj_name).read_bytes() == _evil_object(name)  # the target untouched
    else:
        assert run["source"] == "memory"
        assert [w[0] for w in out["warnings"]] == ["UnsafeCacheWarning"]


def test_an_unwritable_cache_dir_compiles_in_memory_and_writes_nowhere(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("not a directory")
    fake_tmp = tmp_path / "tmp"
    fake_tmp.mkdir()
    out = _run(_env(blocker / "cache", fake_tmp))
    run = out["runs"][0]
    _correct(run)
    assert run["source"] == "memory" and out["warnings"] == []
    assert list(fake_tmp.iterdir()) == []


# --- damaged files are rebuilt, never loaded --------------------------------------------------


def _damage(path: Path, mode: str) -> None:
    data = path.read_bytes()
    if mode == "truncated":
        path.write_bytes(data[:1000])
    elif mode == "half":
        path.write_bytes(data[: len(data) // 2])
    elif mode == "empty":
        path.write_bytes(b"")
    elif mode == "random":
        path.write_bytes(os.urandom(len(data)))
    elif mode == "bitflip":  # 64 bytes inverted in the middle: the size stays right
        mid = len(data) // 2
        path.write_bytes(
            data[:mid] + bytes(b ^ 0xFF for b in data[mid : mid + 64]) + data[mid + 64 :]
        )
    elif mode == "record-empty":
        path.with_name(path.name + ".json").write_bytes(b"")
    elif mode == "record-other-cpu":  # a home shared with a node whose CPU masks features
        meta_path = path.with_name(path.name + ".json")
        meta = json.loads(meta_path.read_text())
        meta["features"] = meta["features"].replace("+", "-")
        meta_path.write_text(json.dumps(meta))
    else:  # pragma: no cover
        raise AssertionError(mode)


DAMAGE = ["truncated", "half", "empty", "random", "bitflip", "record-empty", "record-other-cpu"]


def test_every_kind_of_damaged_cache_entry_is_rebuilt(tmp_path):
    # one kernel (order) per kind of damage, so that three processes test them all
    cache = tmp_path / "cache"
    orders = list(range(8, 8 + len(DAMAGE)))
    for run in _run(_env(cache), *orders)["runs"]:
        _correct(run)
    good = {}
    for order, mode in zip(orders, DAMAGE, strict=True):
        obj = cache / "taylor" / _victim_files(order)[2]
        record = obj.with_name(obj.name + ".json")
        good[order], before = obj.read_bytes(), record.read_bytes()
        _damage(obj, mode)
        assert (obj.read_bytes(), record.read_bytes()) != (good[order], before), mode
    rebuilt = _run(_env(cache), *orders)["runs"]
    for order, mode, run in zip(orders, DAMAGE, rebuilt, strict=True):
        _correct(run)
        assert run["source"] == "written", mode
        _, _, obj_name, meta_name = _victim_files(order)
        data = (cache / "taylor" / obj_name).read_bytes()
        meta = json.loads((cache / "taylor" / meta_name).read_text())
        assert meta["sha256"] == hashlib.sha256(data).hexdigest(), mode
        assert len(data) == len(good[order]), mode
    for run in _run(_env(cache), *orders)["runs"]:  # the rebuilt entries are used from then on
        _correct(run)
        assert run["source"] == "loaded"


def test_two_processes_building_one_kernel_at_once(tmp_path):
    # both compile (fresh cache) and rename their files into place; neither may read a half-written
    # file of the other: each loads complete, verified code or compiles its own
    cache = tmp_path / "cache"
    orders = [str(o) for o in range(8, 16)]
    procs = [
        subprocess.Popen(
            [sys.executable, "-c", SCRIPT, *orders],
            env=_env(cache),
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        for _ in range(2)
    ]
    for p in procs:
        stdout, stderr = p.communicate()
        assert p.returncode == 0, f"rc {p.returncode}\n{stderr[-3000:]}"
        for run in json.loads(stdout.strip().splitlines()[-1])["runs"]:
            _correct(run)
    d = cache / "taylor"
    assert not [p.name for p in d.iterdir() if p.name.endswith(".tmp")]
    assert len(list(d.glob("*.o"))) == len(orders)
    third = _run(_env(cache), *map(int, orders))
    for run in third["runs"]:
        _correct(run)
        assert run["source"] == "loaded"


# --- numba's own cache of mett's functions --------------------------------------------------------


def _numba_file(tmp: Path, monkeypatch, mett_owned: bool):
    from numba.core.caching import IndexDataCacheFile

    from mett import _numba_cache

    _loop._check_numba_cache()  # installed by every module with cache=True functions
    d = tmp / "__pycache__"
    d.mkdir()
    monkeypatch.setattr(_numba_cache, "_is_mett_path", lambda path: mett_owned and Path(path) == d)
    return IndexDataCacheFile(cache_path=str(d), filename_base="f-1.py311", source_stamp=(1.0, 2))


def test_the_cache_files_of_mett_functions_are_recognised():
    _loop._dense_many(np.zeros(2), np.zeros((1, 1, 2)), 1, np.zeros(1), np.empty((1, 1)))
    own = _loop._dense_many._cache._cache_file
    assert type(own).mett_checked and own._is_mett()
    outside = numba.njit(cache=True)(_osc)  # a function of other code: numba's own rules
    assert not outside._cache._cache_file._is_mett()


def _cached_functions_and_install_calls(path: Path) -> tuple[list[int], list[int]]:
    import ast

    tree = ast.parse(path.read_text(encoding="utf-8"))
    decorated, installs = [], []
    for node in tree.body:  # module level: what runs at import, in order
        if isinstance(node, ast.FunctionDef):
            for dec in node.decorator_list:
                if any(
                    isinstance(k, ast.keyword) and k.arg == "cache" and getattr(k.value, "value", 0)
                    for k in getattr(dec, "keywords", [])
                ):
                    decorated.append(node.lineno)
        elif isinstance(node, ast.Expr) and isinstance(node.value, ast.Call):
            if getattr(node.value.func, "id", None) == "_check_numba_cache":
                installs.append(node.lineno)
    return decorated, installs


def test_every_module_with_cached_kernels_installs_the_checks_before_decorating():
    # numba picks its cache-file class when a cache=True function is decorated; a module that
    # decorates one before the checks are installed reads and writes mett's files with numba's own
    # class (no digest), and fails on files the checked class wrote ("invalid load key")
    root = Path(__file__).resolve().parents[1] / "mett"
    seen = 0
    for path in sorted(root.rglob("*.py")):
        if path.name == "_numba_cache.py":
            continue
        decorated, installs = _cached_functions_and_install_calls(path)
        if decorated:
            seen += 1
            assert installs and installs[0] < decorated[0], path.relative_to(root)
    assert seen >= 3  # _signals, dop853, taylor._loop (_kernels decorates at call time, after it)


@pytest.mark.parametrize("which", ["index", "data"])
@pytest.mark.parametrize("mode", ["truncated", "empty", "random", "bitflip"])
def test_a_damaged_numba_cache_file_of_mett_is_a_miss(tmp_path, monkeypatch, which, mode):
    f = _numba_file(tmp_path, monkeypatch, mett_owned=True)
    payload = ("machine code", bytes(range(256)) * 64)
    f.save("key", payload)
    assert f.load("key") == payload
    path = Path(f._index_path) if which == "index" else next(tmp_path.rglob("*.nbc"))
    data = path.read_bytes()
    mid = len(data) // 2
    damaged = {
        "truncated": data[: len(data) // 2],
        "empty": b"",
        "random": os.urandom(len(data)),
        "bitflip": data[:mid] + bytes(b ^ 0x10 for b in data[mid : mid + 8]) + data[mid + 8 :],
    }[mode]
    path.write_bytes(damaged)
    assert f.load("key") is None  # a miss: numba compiles the function again ...
    f.save("key", payload)  # ... and rewrites its files
    assert f.load("key") == payload


def test_numba_cache_files_of_other_code_keep_numba_behaviour(tmp_path, monkeypatch):
    import pickle

    f = _numba_file(tmp_path, monkeypatch, mett_owned=False)
    f.save("key", ("x", 1))
    next(tmp_path.rglob("*.nbc")).write_bytes(b"garbage")
    with pytest.raises(pickle.UnpicklingError):
        f.load("key")


@pytest.mark.parametrize(
    "mode",
    [  # a subprocess each: one in the default run, every mode with -m slow
        pytest.param("index-random", marks=pytest.mark.slow),
        "data-bitflip",
        pytest.param("data-truncated", marks=pytest.mark.slow),
    ],
)
def test_mett_runs_with_a_damaged_numba_cache(tmp_path, mode):
    # a copy of the package with its warm cache; one compiled function's files damaged, then used
    import mett

    _loop._dense_many(np.zeros(2), np.zeros((1, 1, 2)), 1, np.zeros(1), np.empty((1, 1)))
    src = Path(mett.__file__).parent
    index = Path(_loop._dense_many._cache._cache_file._index_path)
    if src not in index.parents:
        pytest.skip("numba caches outside the package here (NUMBA_CACHE_DIR)")
    shutil.copytree(src, tmp_path / "mett")  # copy2: the sources' times, so the cache stays valid
    index = tmp_path / "mett" / index.relative_to(src)
    datas = sorted(index.parent.glob(index.name[: -len(".nbi")] + ".*.nbc"))
    assert datas
    if mode == "index-random":
        index.write_bytes(os.urandom(index.stat().st_size))
    for p in datas if mode.startswith("data") else []:
        data = p.read_bytes()
        if mode == "data-truncated":
            p.write_bytes(data[:1000])
        else:  # inside the object code, the size unchanged
            mid = len(data) // 2
            p.write_bytes(
                data[:mid] + bytes(b ^ 0xFF for b in data[mid : mid + 64]) + data[mid + 64 :]
            )
    script = textwrap.dedent(
        """
        import numpy as np
        from mett.dynamics import taylor
        C = np.array([[[1.0, 2.0, 3.0]]])  # 1 + 2x + 3x²
        d = taylor.TaylorDense(np.array([0.0, 1.0]), np.zeros((2, 1)), C)
        print(taylor.__file__, float(d(0.5)[0]))
        """
    )
    env = dict(os.environ, PYTHONPATH=str(tmp_path))
    proc = subprocess.run(
        [sys.executable, "-c", script],
        env=env,
        cwd=tmp_path,
        capture_output=True,
        text=True,
        check=False,
    )
    assert proc.returncode == 0, f"rc {proc.returncode}\n{proc.stderr[-3000:]}"
    where, value = proc.stdout.split()
    # the copy ran: its mett/dynamics/taylor/__init__.py
    assert Path(where).parents[2] == tmp_path / "mett"
    assert float(value) == 2.75
