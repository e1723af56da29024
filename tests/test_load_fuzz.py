"""Trajectory.load over crafted and damaged files (docs/reliability.md#saved-files).

Legitimate files of short runs (viscous gliding with a user event, a stemmed top under Coulomb
friction with its switch records, a Taylor run, an RK45 run stored as Hermite data, a run that
failed at t = 0) are mutated entry by entry and field by field: arrays of the wrong length, shape
or dtype, NaN and inf, times out of order, zero steps, missing entries; metadata fields of the
wrong type, missing or nested deeply; class names pointing at other code; huge compressed entries;
truncated zips; random bytes and random JSON values (hypothesis, a bounded number of examples).

Every case must either load a self-consistent Trajectory (finite samples, its dense output
through its states, ``at`` and ``crossings`` working) or raise a ValueError naming the file. The
array mutations are loaded and evaluated in a subprocess: before the fix some of them made the
compiled dense output read out of bounds (a segfault), which then fails the test instead of
ending the test run.
"""

from __future__ import annotations

import functools
import io
import json
import math
import os
import struct
import subprocess
import sys
import tempfile
import textwrap
import tracemalloc
import zipfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import mett
from mett import State, Trajectory, presets
from mett.friction import Coulomb

FUZZ = settings(
    max_examples=30,
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
META = "mett_trajectory"


_STEMMED = mett.TippeTop(m=0.006, R=0.015, alpha=0.2, I1=8e-7, I3=7e-7, mu=0.3).with_stem(
    radius=0.005, distance=0.016
)
_NEAR_TOUCHDOWN = State(theta=2.15, thetadot=2.0, phidot=110.0, omega3=-76.0, nu_y=0.16)


def _tick(t, s):  # a user event that fires once, at t = 0.1 s
    return t - 0.1


@functools.cache
def _legit() -> dict:
    """name -> (meta, {entry: array}) of legitimate files written by Trajectory.save."""
    top = presets.get("rutstam2013")
    start = State(theta=0.1, omega3=155.0)
    runs = {
        "gliding": mett.simulate(top, start, 0.3, events=[_tick], backend="compiled"),
        # a stemmed top under Coulomb friction: ball and stem contacts, sliding and rolling
        "coulomb": mett.simulate(_STEMMED, _NEAR_TOUCHDOWN, 0.07, friction=Coulomb(0.3)),
        "taylor": mett.simulate(top, start, 0.2, backend="taylor"),
        "rk45": mett.simulate(top, start, 0.05, backend="scipy", method="RK45"),
        "failed": mett.simulate(top, State(theta=0.0, omega3=10.0), 1.0, model="gliding-euler"),
    }
    assert len(runs["coulomb"].switches) >= 3 and runs["gliding"].t_events[0].size == 1
    assert runs["failed"].status == "failed"
    out = {}
    with tempfile.TemporaryDirectory() as base:
        for name, traj in runs.items():
            path = traj.save(Path(base) / f"{name}.npz")
            with np.load(path, allow_pickle=False) as data:
                entries = {k: np.array(data[k]) for k in data.files}
            out[name] = (json.loads(str(entries.pop(META))), entries)
    return out


@functools.cache
def _blobs(name: str) -> dict[str, bytes]:
    """The .npy bytes of each entry of a legitimate file (encoded once)."""
    return {k: _npy(v) for k, v in _legit()[name][1].items()}


@pytest.fixture(scope="module")
def files():
    return _legit()


def _npy(arr: np.ndarray) -> bytes:
    buf = io.BytesIO()
    np.lib.format.write_array(buf, np.asanyarray(arr), allow_pickle=True)
    return buf.getvalue()


def _write(path, meta, entries, *, text: str | None = None) -> None:
    """A .npz like numpy's (stored .npy entries), with the metadata as JSON ``text`` if given."""
    body = json.dumps(meta) if text is None else text
    with zipfile.ZipFile(path, "w", zipfile.ZIP_STORED) as zf:
        zf.writestr(META + ".npy", _npy(np.array(body)))
        for key, value in entries.items():
            zf.writestr(key + ".npy", value if isinstance(value, bytes) else _npy(value))


def _consistent(traj: Trajectory) -> None:
    """A loaded trajectory is usable and agrees with itself."""
    t = traj.t
    assert t.ndim == 1 and t.size >= 1 and np.all(np.isfinite(t)) and np.all(np.diff(t) >= 0)
    assert traj.states.shape[1] == t.size and np.all(np.isfinite(traj.states))
    grid = np.linspace(t[0], t[-1], 101)
    s = traj.at(grid)
    for name in ("theta", "thetadot", "phidot", "omega3", "nu_x", "nu_y"):
        assert np.all(np.isfinite(getattr(s, name))), name
    # the dense output passes through the stored states (at the solver's steps: to rounding)
    Y = traj.states_at(t)
    scale = np.max(np.abs(traj.states), axis=1, keepdims=True) + 1e-300
    assert np.all(np.abs(Y - traj.states) <= 1e-9 * scale)
    crossings = traj.crossings(float(np.median(traj.theta_at(grid))))
    assert np.all((crossings >= t[0]) & (crossings <= t[-1]))


def _outcome(path) -> str:
    """ "refused" (a ValueError naming the file) or "loaded" (and consistent); anything else
    (another exception, a message without the file) fails the test."""
    try:
        traj = Trajectory.load(path)
    except ValueError as exc:
        assert str(path) in str(exc), exc
        return "refused"
    _consistent(traj)
    return "loaded"


# --- array entries: every one of wrong length, shape, dtype, or with NaN (in a subprocess) -------
def _array_mutations(arr: np.ndarray) -> dict[str, np.ndarray | None]:
    out: dict[str, np.ndarray | None] = {"missing": None}
    if arr.ndim >= 1 and arr.shape[0] >= 1:
        out["short"] = arr[:-1]
        out["long"] = np.concatenate([arr, arr[-1:]])
        out["empty"] = arr[:0]
        out["reversed"] = arr[::-1].copy()
    if arr.ndim >= 2:
        out["narrow"] = arr[..., :-1]
        out["wide"] = np.concatenate([arr, arr[..., -1:]], axis=-1)
        out["flat"] = arr.ravel()
    out["extra_axis"] = arr[None]
    if arr.dtype.kind == "f":
        for dtype in ("float32", "int64", "U8"):
            out[dtype] = arr.astype(dtype)
        out["object"] = arr.astype(object)
        out["big_endian"] = arr.astype(">f8")  # the same numbers: may load
        out["fortran"] = np.asfortranarray(arr)  # the same numbers: may load
        if arr.size:
            for label, value in (("nan", math.nan), ("inf", math.inf)):
                bad = arr.copy()
                bad.reshape(-1)[bad.size // 2] = value
                out[label] = bad
            out["zeros"] = np.zeros_like(arr)
            with np.errstate(over="ignore"):
                out["huge"] = np.clip(arr * 1e300, -1e307, 1e307)  # finite, out of scale
    else:
        out["float"] = np.zeros(arr.shape)
        out["label"] = np.full(arr.shape, "evil")
        out["long_text"] = np.full(arr.shape, "x" * 1000)
    return out


def _selected(entries: dict, full: bool) -> list[str]:
    """Every entry; by default one of the 15 series (they are read alike) and of a phase-by-phase
    dense output the first and last phases."""
    if full:
        return list(entries)
    names = [k for k in entries if k not in mett.dynamics.trajectory.SERIES or k == "theta"]
    segments = sorted({k.split("_")[1] for k in names if k.startswith("dense_s")})
    keep = {segments[0], segments[-1]} if segments else set()
    return [k for k in names if not k.startswith("dense_s") or k.split("_")[1] in keep]


_CHILD = textwrap.dedent(
    """
    import json, pathlib, sys
    folder = pathlib.Path(sys.argv[1])
    # an import of mett.__main__ would run the mett CLI on these arguments and exit at once
    sys.argv = ["victim.py", "info"]
    import test_load_fuzz as fuzz

    results = {}
    for path in sorted(folder.glob("*.npz")):
        try:
            results[path.name] = fuzz._outcome(path)
        except BaseException as exc:  # reported, so the parent names the case
            results[path.name] = f"{type(exc).__name__}: {exc}"[:300]
    print(json.dumps({"results": results, "main": "mett.__main__" in sys.modules}))
    """
)


def _run_child(folder) -> dict:
    """Load every file of ``folder`` in a fresh interpreter; a crash (segfault) fails here."""
    script = folder.parent / "child.py"
    script.write_text(_CHILD)
    # the child imports this module (its checks) from the tests' directory, mett as we do
    paths = [str(Path(__file__).parent), *sys.path]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(paths)}
    proc = subprocess.run(
        [sys.executable, str(script), str(folder)], capture_output=True, text=True, env=env
    )
    assert proc.returncode == 0, (proc.returncode, proc.stderr[-3000:])  # -11: a segfault
    report = json.loads(proc.stdout.strip().splitlines()[-1])
    assert report["main"] is False  # no file made load import (and run) mett.__main__
    return report["results"]


# the default run: a wrong length, shape and dtype, a NaN and a missing entry of each; the slow
# run adds the other mutations
_CORE = ("missing", "short", "narrow", "extra_axis", "int64", "nan", "label")


def _array_cases(folder, full: bool) -> set[str]:
    """Write the array mutations into ``folder`` (names ``a__*``); the cases that must be refused."""
    expected_refused = set()
    for name, (meta, entries) in _legit().items():
        blobs = _blobs(name)
        _write(folder / f"a__{name}__original.npz", meta, blobs)
        for key in _selected(entries, full):
            for label, value in _array_mutations(entries[key]).items():
                if not full and label not in _CORE:
                    continue
                changed = {k: v for k, v in blobs.items() if k != key}
                if value is not None:
                    changed[key] = value
                case = f"a__{name}__{key}__{label}.npz"
                _write(folder / case, meta, changed)
                # (touchdowns: optional, as a stemmed model run without its top has none)
                if label in ("missing", "nan", "inf", "float32", "int64", "object", "U8") and (
                    (key, label) != ("touchdowns", "missing")
                ):
                    expected_refused.add(case)
    # the cases of the finding: dense times and steps of a million steps with one row of
    # coefficients (an out-of-bounds read of gigabytes), and Taylor coefficients too few
    meta, entries = _legit()["gliding"]
    t = np.linspace(0.0, entries["dense_t"][-1], 10**6)
    oob = {**entries, "dense_t": t, "dense_h": np.diff(t), "dense_F": entries["dense_F"][:1]}
    _write(folder / "a__oob_dense_F_one_row.npz", meta, oob)
    meta, entries = _legit()["taylor"]
    _write(
        folder / "a__oob_taylor_C_short.npz", meta, {**entries, "dense_C": entries["dense_C"][:2]}
    )
    return expected_refused | {"a__oob_dense_F_one_row.npz", "a__oob_taylor_C_short.npz"}


_FOREIGN = [
    "mett.__main__:TippeTop", "mett.__main__:main", "mett.sweeps:pd.NamedAgg", "os:system",
    "builtins:eval", "mett.top:TippeTop.__class__", "mett.dynamics.simulation:PreparedRun",
    "mett.stability:EscapeEstimate", "mett.top:TippeTop ", 7, ["mett.top:TippeTop"],
]  # fmt: skip


def _name_cases(folder) -> None:
    """Files naming other code as the top, a friction law, a switch record (names ``n__*``)."""
    g_meta, c_meta = _legit()["gliding"][0], _legit()["coulomb"][0]
    for k, name in enumerate(_FOREIGN):
        top = {**g_meta["top"], "type": name}
        _write(folder / f"n__top_{k}.npz", {**g_meta, "top": top}, _blobs("gliding"))
        friction = {"__dataclass__": name, "fields": {"mu": 0.02, "contensou_radius": 0.0}}
        options = {**c_meta["options"], "friction": friction}
        _write(folder / f"n__option_{k}.npz", {**c_meta, "options": options}, _blobs("coulomb"))
        items = [{**sw, "type": name} for sw in c_meta["records"]["switches"]["items"]]
        records = {**c_meta["records"], "switches": {"kind": "records", "items": items}}
        _write(folder / f"n__record_{k}.npz", {**c_meta, "records": records}, _blobs("coulomb"))


@pytest.fixture(scope="module")
def child(tmp_path_factory):
    """The array and class-name cases, loaded in one fresh interpreter (started with the CLI's
    arguments: an import of mett.__main__ would run it and exit); name -> outcome, and the
    array cases that must be refused."""
    folder = tmp_path_factory.mktemp("child") / "cases"
    folder.mkdir()
    refused = _array_cases(folder, full=False)
    _name_cases(folder)
    return _run_child(folder), refused


def _check_array_results(results: dict, expected_refused: set, minimum: int) -> None:
    results = {case: r for case, r in results.items() if case.startswith("a__")}
    bad = {case: r for case, r in results.items() if r not in ("refused", "loaded")}
    assert not bad, dict(list(bad.items())[:10])
    assert all(results[f"a__{name}__original.npz"] == "loaded" for name in _legit())
    assert [c for c in sorted(expected_refused) if results[c] != "refused"] == []
    assert len(results) > minimum  # the cases were made


def test_every_array_entry_mutated_loads_consistently_or_is_refused(child):
    _check_array_results(*child, minimum=200)


@pytest.mark.slow
def test_every_array_entry_mutated_in_every_way(tmp_path):
    folder = tmp_path / "cases"
    folder.mkdir()
    refused = _array_cases(folder, full=True)
    _check_array_results(_run_child(folder), refused, minimum=800)


def test_class_names_in_a_file_import_and_call_nothing(child):
    results = {case: r for case, r in child[0].items() if case.startswith("n__")}
    assert len(results) == 3 * len(_FOREIGN)
    assert set(results.values()) == {"refused"}, results


# --- metadata fields: wrong types, missing, nested --------------------------------------------
_DEEP = 200_000
_VALUES = [None, True, 0, -1, 2.5, math.nan, math.inf, "x", "", [], {}, [1, 2], {"a": 1}, 10**40]


def _paths(node, prefix=(), depth=0):
    """Paths to every field of the metadata (of a list: the first and last items)."""
    if depth > 4:
        return
    if isinstance(node, dict):
        keys = list(node)
    elif isinstance(node, list):
        keys = sorted({0, len(node) - 1} & set(range(len(node))))
    else:
        return
    for key in keys:
        yield (*prefix, key)
        yield from _paths(node[key], (*prefix, key), depth + 1)


def _set(meta, path, value, *, delete=False):
    out = json.loads(json.dumps(meta))
    node = out
    for key in path[:-1]:
        node = node[key]
    if delete:
        del node[path[-1]]
    else:
        node[path[-1]] = value
    return out


_COMMON = ("format", "format_version", "mett_version", "model", "top", "initial_state", "params",
           "status", "message", "t_contact_lost", "nfev", "backend", "series", "n_events")  # fmt: skip


@pytest.mark.parametrize("full", [False, pytest.param(True, marks=pytest.mark.slow)])
@pytest.mark.parametrize("name", ["gliding", "coulomb", "taylor", "rk45"])
def test_every_metadata_field_mutated_loads_consistently_or_is_refused(files, tmp_path, name, full):
    # every field missing, of another type (text, a list) and NaN; the slow run: all _VALUES
    meta = files[name][0]
    blobs = _blobs(name)
    paths = [p for p in _paths(meta) if name == "gliding" or p[0] not in _COMMON]
    assert len(paths) > 5
    outcomes = {"refused": 0, "loaded": 0}
    path = tmp_path / "m.npz"
    for p in paths:
        for k, value in enumerate([None, *(_VALUES if full else ("x", [1, 2], math.nan))]):
            _write(path, _set(meta, p, value, delete=k == 0), blobs)
            outcomes[_outcome(path)] += 1
    assert outcomes["refused"] > outcomes["loaded"] > 0


def test_metadata_nested_deeply_is_refused(files, tmp_path):
    meta, entries = files["gliding"]
    text = json.dumps(meta)
    path = tmp_path / "deep.npz"
    for field in ("message", "top", "options", "params"):
        nested = "[" * _DEEP + "]" * _DEEP
        _write(
            path, meta, entries, text=text.replace(f'"{field}": ', f'"{field}": {nested}, "_": ', 1)
        )
        with pytest.raises(ValueError, match="nested too deeply"):
            Trajectory.load(path)
    # nesting that JSON parses but no field of the format has
    deep_option = {"friction": None}
    for _ in range(100):
        deep_option = {"x": deep_option}
    _write(path, {**meta, "options": {"l": deep_option}}, entries)
    with pytest.raises(ValueError, match="nested more than"):
        Trajectory.load(path)


@pytest.mark.parametrize(
    ("change", "match"),
    [
        ({"top": []}, "top must be an object"),
        ({"options": []}, "options must be an object"),
        ({"model": ["gliding"]}, "model"),
        ({"message": 12345}, "message must be a str"),
        ({"backend": ["x"]}, "backend must be one of"),
        ({"backend": "auto"}, "backend must be one of"),
        ({"params": [math.nan] * 7}, r"params\[0\] must be finite"),
        ({"params": [0.02] * 7}, r"params\[.\] = 0.02 is not that of the top"),
        ({"status": "done"}, "status must be one of"),
        ({"nfev": 1.5}, "nfev must be an integer"),
        ({"nfev": True}, "nfev must be an integer"),
        ({"n_events": 2}, "entry 't_events_1' is missing"),
        ({"series": ["theta", "__class__"]}, "an entry of series must be one of"),
        ({"extras": {"_sol": "f"}}, "an extra series' name must be a public name"),
        ({"extras": {"phase": "pickle"}}, "the kind of extra series 'phase' must be one of"),
        ({"records": {"__init__": {"kind": "number", "value": 1}}}, "a record's name must be"),
        ({"records": {"states": {"kind": "number", "value": 1}}}, "would hide an attribute"),
        ({"records": {"x": {"kind": "pickle"}}}, "record 'x' is not one the format defines"),
        ({"rtol": 2.0}, r"rtol must lie in \(0, 1\)"),
        ({"t_end": 0.001}, "t_end = 0.001 s lies before the last sample"),
        ({"initial_state": {"theta": "0.1"}}, "initial_state must be an object with fields"),
        ({"t_contact_lost": 99.0}, "t_contact_lost = 99.0 s lies outside the run"),
        ({"dense": {"kind": "segments", "phases": [""], "parts": [{"kind": "segments"}]}},
         "dense segment 0 must be one of"),
        ({"dense": {"kind": "pickle"}}, "dense kind must be one of"),
    ],
)  # fmt: skip
def test_the_reported_metadata_cases_are_value_errors_naming_the_file(
    files, tmp_path, change, match
):
    meta, entries = files["gliding"]
    path = tmp_path / "case.npz"
    _write(path, {**meta, **change}, entries)
    with pytest.raises(ValueError, match=match) as info:
        Trajectory.load(path)
    assert str(path) in str(info.value)


def test_a_zip_version_this_python_cannot_read_is_a_value_error(files, tmp_path):
    # zipfile raises NotImplementedError for an entry that needs a newer zip version (a byte
    # flipped in the central directory's "version needed" field): the file is refused as such
    meta, entries = files["gliding"]
    path = tmp_path / "case.npz"
    _write(path, meta, entries)
    raw = bytearray(path.read_bytes())
    at = raw.index(b"PK\x01\x02")  # the first central-directory header
    raw[at + 6 : at + 8] = (64).to_bytes(2, "little")  # version needed to extract: 6.4
    path.write_bytes(bytes(raw))
    with pytest.raises(ValueError, match="not a readable mett trajectory file"):
        mett.load(path)


def test_the_reported_array_cases_are_value_errors(files, tmp_path):
    meta, entries = files["gliding"]
    path = tmp_path / "case.npz"
    for key, value, match in [
        ("dense_h", np.zeros_like(entries["dense_h"]), "step sizes 'dense_h' do not match"),
        ("dense_y", entries["dense_y"][:, :1], r"entry 'dense_y' has shape \(\d+, 1\)"),
        ("dense_h", np.concatenate([entries["dense_h"]] * 2), "entry 'dense_h' has shape"),
        ("dense_F", entries["dense_F"][:, :, :-1], "entry 'dense_F' has shape"),
        ("dense_t", entries["dense_t"][::-1].copy(), "must be in order"),
        ("states", entries["states"][:1], "entry 'states' has shape"),
    ]:
        _write(path, meta, {**entries, key: value})
        with pytest.raises(ValueError, match=match):
            Trajectory.load(path)


# --- size: entries are checked before they are decompressed ----------------------------------
def _peak_of_load(path) -> tuple[str, int]:
    tracemalloc.start()
    try:
        outcome = _outcome(path)
        return outcome, tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def _zeros_entry(zf: zipfile.ZipFile, name: str, nbytes: int) -> None:
    """A .npy entry of ``nbytes`` of float zeros, deflated as it is written (never in memory)."""
    n = nbytes // 8
    header = io.BytesIO()
    np.lib.format.write_array_header_1_0(
        header, {"descr": "<f8", "fortran_order": False, "shape": (n,)}
    )
    with zf.open(name, "w", force_zip64=True) as fh:
        fh.write(header.getvalue())
        chunk = bytes(2**20)
        for _ in range(n * 8 // len(chunk)):
            fh.write(chunk)


@pytest.mark.parametrize(
    ("entry", "size", "why"),
    [
        ("junk.npy", 48 * 2**20, "is not part of this file's format"),  # under the budget
        ("junk.npy", 80 * 2**20, "refused unread as a zip bomb"),  # over it
        ("theta.npy", 48 * 2**20, "entry 'theta' has shape"),  # a known entry, of the wrong size
    ],
)
def test_huge_compressed_entries_are_refused_without_decompressing(
    files, tmp_path, entry, size, why
):
    meta, entries = files["gliding"]
    path = tmp_path / "bomb.npz"
    _write(path, meta, {k: v for k, v in entries.items() if k + ".npy" != entry})
    with zipfile.ZipFile(path, "a", zipfile.ZIP_DEFLATED, compresslevel=9) as zf:
        _zeros_entry(zf, entry, size)
    assert path.stat().st_size < size / 100  # a bomb: small on disk
    with pytest.raises(ValueError, match=why):
        Trajectory.load(path)
    outcome, peak = _peak_of_load(path)
    # far less than the entry (the legitimate arrays of this run take ~0.1 MB; decompressing
    # the entry would take its size)
    assert outcome == "refused" and peak < size / 16, peak


def test_an_entry_declaring_a_false_size_is_refused(files, tmp_path):
    """The central directory declares 4 GB for an entry: refused by the budget, unread; declaring
    less than the data is refused by the .npy header's size (or the zip's CRC)."""
    meta, entries = files["gliding"]
    path = tmp_path / "lie.npz"
    _write(path, meta, entries)
    raw = bytearray(path.read_bytes())
    with zipfile.ZipFile(path) as zf:
        short = zf.getinfo("theta.npy").file_size - 8  # the header, and all but one number
    for declared, match in ((0xFFFFFFF0, "zip bomb"), (short, f"declares {short} bytes|Bad CRC")):
        data = bytearray(raw)
        at = data.find(b"PK\x01\x02")
        while at >= 0:  # every central directory record of "theta.npy"
            name_len = struct.unpack_from("<H", data, at + 28)[0]
            if data[at + 46 : at + 46 + name_len] == b"theta.npy":
                struct.pack_into("<I", data, at + 24, declared)
            at = data.find(b"PK\x01\x02", at + 4)
        path.write_bytes(bytes(data))
        with pytest.raises(ValueError, match=match):
            Trajectory.load(path)


def test_truncated_and_damaged_zips_are_refused(files, tmp_path):
    meta, entries = files["gliding"]
    good = tmp_path / "good.npz"
    _write(good, meta, entries)
    raw = good.read_bytes()
    path = tmp_path / "cut.npz"
    for k in range(1, 40):
        path.write_bytes(raw[: len(raw) * k // 40])
        assert _outcome(path) == "refused"
    path.write_bytes(b"")
    assert _outcome(path) == "refused"


# --- random mutation ---------------------------------------------------------------------------
# (the legitimate files come from the cached _legit(), not from fixtures: hypothesis would
# print them with every example)
_NAMES = st.sampled_from(["gliding", "taylor", "coulomb"])


@FUZZ
@given(name=_NAMES, data=st.data())
def test_random_bytes_of_a_file(name, data):
    """Random bytes of the zip replaced (its structure, headers and data)."""
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "b.npz"
        _write(path, _legit()[name][0], _blobs(name))
        raw = bytearray(path.read_bytes())
        for _ in range(data.draw(st.integers(1, 8), label="changes")):
            raw[data.draw(st.integers(0, len(raw) - 1))] = data.draw(st.integers(0, 255))
        path.write_bytes(bytes(raw))
        _outcome(path)


@FUZZ
@given(name=_NAMES, data=st.data())
def test_random_bytes_of_an_entry(name, data):
    """Random bytes of one .npy entry (its header or its numbers) replaced, the zip intact: what
    a crafted file can do past the CRC."""
    blobs = _blobs(name)
    key = data.draw(st.sampled_from(sorted(blobs)), label="entry")
    blob = bytearray(blobs[key])
    header = blob.index(b"\n") + 1
    for _ in range(data.draw(st.integers(1, 6), label="changes")):
        in_header = data.draw(st.booleans())
        at = data.draw(st.integers(0, (header if in_header else len(blob)) - 1))
        blob[at] = data.draw(st.integers(0, 255))
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "e.npz"
        _write(path, _legit()[name][0], {**blobs, key: bytes(blob)})
        _outcome(path)


_JSON = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=8),
    lambda inner: (
        st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=6), inner, max_size=3)
    ),
    max_leaves=8,
)


@FUZZ
@given(name=st.sampled_from(["gliding", "coulomb"]), data=st.data())
def test_random_values_in_the_metadata(name, data):
    meta = _legit()[name][0]
    paths = list(_paths(meta))
    for _ in range(data.draw(st.integers(1, 3), label="changes")):
        where = data.draw(st.sampled_from(paths), label="field")
        try:
            meta = _set(meta, where, data.draw(_JSON), delete=data.draw(st.booleans()))
        except (KeyError, IndexError, TypeError):  # the field went away with an earlier change
            continue
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "m.npz"
        _write(path, meta, _blobs(name))
        _outcome(path)
