"""The trajectory file format: :meth:`mett.Trajectory.save` and :meth:`mett.Trajectory.load`.

A file is numpy's ``.npz`` (a zip of ``.npy`` arrays; ``numpy.load`` reads it without mett and
without pickle) with one JSON metadata entry, ``mett_trajectory``. Format version 3 (this one):

* arrays: ``t``, ``states`` (the model's state vectors), every derived series (``theta``, ...,
  listed in the metadata's ``series``), ``psi`` (ψ, :attr:`mett.Trajectory.psi`), ``atol`` (one
  per state component), ``t_events_<k>`` per user event, the dense output as ``dense_*``
  (:func:`mett.dynamics.dense.to_arrays`), ``extra_<name>`` per per-sample series of
  :attr:`~mett.Trajectory.extras` and ``record_<name>`` for the array-valued
  :attr:`~mett.Trajectory.records`;
* metadata: ``format`` (``"mett.Trajectory"``), ``format_version``, ``mett_version``,
  ``model``, ``options``, ``params``, ``top`` (its class and all its fields),
  ``initial_state``, ``status``, ``message``, ``t_contact_lost``, ``nfev``, ``backend``,
  ``rtol``, ``t_end`` (the requested end time), ``series``, ``n_events``, ``dense`` (how the
  dense output is stored), ``extras`` (name: ``"f"`` for float64, ``"U"`` for text) and
  ``records`` (name: how it is stored: ``{"kind": "number", "value": x}``, ``{"kind":
  "array", "shape": [...]}``, ``{"kind": "array-tuples", "width": k, "shape": [...]}`` for a
  list of tuples of equal arrays, or ``{"kind": "records", "items": [...]}`` for a list of
  records: plain tuples of numbers and text, or one of mett's record classes by name).

The format names no model's series: a model's ``finish`` hook (:class:`mett.dynamics.Model`)
decides what a run carries, and a new model's results are saved without touching this module.

Versions 1 and 2 (mett before the record/extras split) still load: version 2 stored the hybrid
runs' ``switches`` in the metadata, ``jumps_before``/``jumps_after``, ``touchdowns``,
``stopping_band`` and the per-sample series ``extra_<name>`` of a fixed list; version 1 none of
these. Both lack ``rtol``, ``atol``, ``t_end`` (loaded as None) and ``psi`` (computed from the
dense output, :attr:`mett.Trajectory.psi`).
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import reprlib
import secrets
import stat
import typing
import warnings
import zipfile
import zlib
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .. import _validate
from ..state import State
from . import _params as ix
from ._status import Status
from .dense import ARRAYS, HermiteSolution, SegmentedSolution, from_arrays, to_arrays
from .registry import MODELS

if TYPE_CHECKING:
    from .trajectory import Trajectory

FORMAT_VERSION = 3
"""Version of the file layout written by :func:`save`; :func:`load` reads this and every older
version and refuses newer ones. Version 2 added what a run sets beyond its states (a hybrid
run's phases, contact series, switches and touchdowns) and the dense output of a hybrid run phase
by phase; version 3 stores those generically (extras and records), and rtol, atol, t_end and ψ."""

_FORMAT_NAME = "mett.Trajectory"
_META_KEY = "mett_trajectory"  # the JSON metadata entry of the .npz

_STATE_FIELDS = ("theta", "thetadot", "phidot", "omega3", "nu_x", "nu_y")

_BACKENDS = ("compiled", "scipy", "taylor")
"""The backends a saved run may name (those of :func:`mett.simulate`)."""

_MAX_RECORDS = 100_000
"""Most items of a record list (a hybrid run stops after 10⁵ phase switches, MAX_SWITCHES)."""

_MAX_NAMES = 64
"""Most extras and records of a run."""


# --- writing -----------------------------------------------------------------------------------
def save(traj: Trajectory, path: str | os.PathLike, series: Sequence[str]) -> Path:
    """Write ``traj`` to ``path`` (:meth:`mett.Trajectory.save`, which documents the
    arguments); ``series`` names its derived series."""
    given, target = _check_save_path(path)
    meta: dict[str, Any] = {
        "format": _FORMAT_NAME,
        "format_version": FORMAT_VERSION,
        "mett_version": _mett_version(),
        "model": traj.model,
        "options": {k: _encode_option(k, v) for k, v in traj.options.items()},
        "params": [_encode_param(i, v) for i, v in enumerate(traj.params)],
        "top": {"type": _class_name(type(traj.top), "top"), **dataclasses.asdict(traj.top)},
        "initial_state": (
            None
            if traj.initial_state is None
            else {k: float(getattr(traj.initial_state, k)) for k in _STATE_FIELDS}
        ),
        "status": str(traj.status),
        "message": traj.message,
        "t_contact_lost": None if traj.t_contact_lost is None else float(traj.t_contact_lost),
        "nfev": traj.nfev,
        "backend": traj.backend,
        "rtol": traj.rtol,
        "t_end": traj.t_end,
        "series": list(series),
        "n_events": len(traj.t_events),
    }
    arrays: dict[str, np.ndarray] = {"t": traj.t, "states": traj.states, "psi": traj.psi}
    arrays.update({name: getattr(traj, name) for name in series})
    if traj.atol is not None:
        arrays["atol"] = traj.atol
    arrays.update({f"t_events_{k}": np.asarray(te) for k, te in enumerate(traj.t_events)})
    meta["dense"], dense = to_arrays(traj._sol, _slopes(traj))
    arrays.update({f"dense_{k}": v for k, v in dense.items()})
    meta["extras"] = {}
    for name, values in traj.extras.items():
        values = np.asarray(values)
        if values.dtype.kind not in "fU":
            raise TypeError(f"extra series {name!r} must hold floats or text; got {values.dtype}")
        meta["extras"][name] = values.dtype.kind
        arrays[f"extra_{name}"] = values
    meta["records"] = {}
    for name, value in traj.records.items():
        meta["records"][name], array = _encode_record(name, value)
        if array is not None:
            arrays[f"record_{name}"] = array
    text = json.dumps(meta)
    entries = {_META_KEY: np.array(text), **arrays}
    # numpy's stub lets the keyword arrays reach allow_pickle (bool): a stub limitation
    _write_atomically(target, lambda fh: np.savez_compressed(fh, **entries))  # type: ignore[arg-type]
    return given


def _slopes(traj: Trajectory) -> Any:
    """The right-hand side of ``traj``'s model (phase by phase) at states, for a dense output
    stored as Hermite data."""
    mdl = traj._model
    table: dict[str | None, Callable[..., Any]] = {ph.name: ph.rhs for ph in mdl.phase_table()}

    def slopes(phase: str | None, ts: np.ndarray, Y: np.ndarray) -> np.ndarray:
        rhs = table.get(phase, mdl.rhs)
        return np.column_stack([np.asarray(rhs(t, Y[:, k], traj.params)) for k, t in enumerate(ts)])

    return slopes


def _is_float_array(v: Any) -> bool:
    return isinstance(v, np.ndarray) and v.dtype.kind == "f"


def _encode_record(name: str, v: Any) -> tuple[dict, np.ndarray | None]:
    """(description, array or None) of a record value (see the module docstring)."""
    if _is_number(v) or isinstance(v, (np.integer, np.floating)):
        return {"kind": "number", "value": float(v)}, None
    if _is_float_array(v):
        return {"kind": "array", "shape": list(v.shape)}, np.asarray(v, dtype=float)
    if isinstance(v, (list, tuple)):
        items = list(v)
        if items and all(
            isinstance(x, tuple) and not hasattr(x, "_fields") and len(x) == len(items[0])
            and all(_is_float_array(a) and a.shape == items[0][0].shape for a in x)
            for x in items
        ):  # fmt: skip
            stacked = np.array([[np.asarray(a, dtype=float) for a in x] for x in items])
            return {"kind": "array-tuples", "shape": list(stacked.shape)}, stacked
        return {"kind": "records", "items": [_encode_item(name, x) for x in items]}, None
    raise TypeError(
        f"record {name!r} of type {type(v).__name__} cannot be saved (a number, a float array, "
        "a list of tuples of float arrays, or a list of records)"
    )


def _encode_item(name: str, item: Any) -> dict:
    """One item of a record list: a mett record class by name, or a plain tuple."""
    if hasattr(item, "_asdict"):
        fields = {k: (v if isinstance(v, str) else float(v)) for k, v in item._asdict().items()}
        return {"type": _class_name(type(item), "record"), "fields": fields}
    if isinstance(item, tuple) and all(isinstance(v, str) or _is_number(v)
                                       or isinstance(v, np.floating) for v in item):  # fmt: skip
        return {"type": None, "values": [v if isinstance(v, str) else float(v) for v in item]}
    raise TypeError(f"an item of record {name!r} cannot be saved: {_short(item)}")


# --- reading -----------------------------------------------------------------------------------
def load(cls: type, path: str | os.PathLike, series: Sequence[str]) -> Any:
    """Read a file written by :func:`save` (:meth:`mett.Trajectory.load`, which documents the
    arguments and errors) as a ``cls``; ``series`` names the derived series it may hold."""
    p = Path(os.fspath(path))
    if not p.is_file():
        raise ValueError(f"path must be an existing trajectory file (.npz); got {str(p)!r}")
    try:
        with _Archive(p) as archive:
            meta = archive.meta()
            _check_meta(meta, p)
            return _from_saved(cls, meta, archive, tuple(series))
    except _Refused as exc:
        raise ValueError(f"{p} is a damaged mett trajectory file: {exc}") from None
    except _Named:
        raise
    except (OSError, EOFError, zipfile.BadZipFile, zlib.error, NotImplementedError) as exc:
        # (zipfile raises NotImplementedError for a damaged version or compression field)
        raise ValueError(f"{p} is not a readable mett trajectory file: {exc}") from None
    except (ValueError, TypeError, ArithmeticError, LookupError, AttributeError,
            RecursionError) as exc:  # fmt: skip
        # not expected after the checks; still an error about the file, never a raw one
        raise ValueError(f"{p} is a damaged mett trajectory file: {exc!r}") from None


def _from_saved(cls: type, meta: dict, archive: _Archive, all_series: tuple[str, ...]) -> Any:
    """The trajectory of a file's checked metadata ``meta`` and its entries. Every field and
    array is checked against the format and against each other before it is used (raising
    :class:`_Refused`): nothing unchecked reaches compiled code."""
    model = MODELS[meta["model"]]
    version = meta["format_version"]
    status = _choice(meta.get("status"), "status", tuple(s.value for s in Status))
    message = _text(meta.get("message"), "message")
    backend = _choice(meta.get("backend"), "backend", _BACKENDS)
    nfev = _integer(meta.get("nfev"), "nfev", 0, 2**62)
    if "mett_version" in meta:
        _text(meta["mett_version"], "mett_version", 100)
    t_lost = meta.get("t_contact_lost")
    t_lost = None if t_lost is None else _number(t_lost, "t_contact_lost")
    series = _names(meta.get("series", []), "series", all_series)
    n_events = _integer(meta.get("n_events"), "n_events", 0, 10_000)
    rtol = t_end = None
    extras_meta: dict[str, str] = {}
    records_meta: dict[str, Any] = {}
    if version >= 3:
        rtol, t_end = meta.get("rtol"), meta.get("t_end")
        rtol = None if rtol is None else _number(rtol, "rtol")
        t_end = None if t_end is None else _number(t_end, "t_end")
        if rtol is not None and not 0.0 < rtol < 1.0:
            raise _Refused(f"rtol must lie in (0, 1); got {rtol!r}")
        extras_meta = _kinds(meta.get("extras"))
        saved_records = meta.get("records")
        if not isinstance(saved_records, dict) or len(saved_records) > _MAX_NAMES:
            raise _Refused(f"records must be an object of at most {_MAX_NAMES} entries")
        records_meta = saved_records
        for name in records_meta:
            _public_name(name, "a record's name")
    else:
        legacy = _legacy_meta(meta)

    # the top, the options and the parameters: mett's own classes, validated as on creation,
    # and the parameters those of the top and options (to rounding)
    with warnings.catch_warnings():  # the top was accepted (and warned about) when it was made
        warnings.simplefilter("ignore", _validate.MettWarning)
        top = _decode_top(meta.get("top"))
        options = _decode_options(meta.get("options"))
        try:
            expected = tuple(model.parameters(top, **options))
        except (TypeError, ValueError, ArithmeticError) as exc:
            raise _Refused(f"the options do not fit model {model.name!r}: {exc}") from None
        params = _decode_params(meta.get("params"), expected, model.name)
        init = _decode_state(meta.get("initial_state"))
        try:
            n_state = int(np.asarray(model.initial(init, params), dtype=float).size)
        except (TypeError, ValueError, ArithmeticError) as exc:
            raise _Refused(f"initial_state does not fit model {model.name!r}: {exc}") from None

    # the entries: exactly those this metadata implies (others are refused unread)
    # and "flight": the free flights of a run that lost contact (mett.dynamics.flight)
    phase_names = (*(ph.name for ph in model.phase_table()), "flight")
    dense_meta = meta.get("dense")
    dense_entries = _dense_entries(dense_meta, phase_names, _MAX_RECORDS)
    required = {"t", "states", *series, *(f"t_events_{k}" for k in range(n_events))}
    required |= set(dense_entries)
    optional: set[str] = set()
    if version >= 3:
        required |= {"psi"} | {f"extra_{name}" for name in extras_meta}
        required |= {f"record_{n}" for n, d in records_meta.items()
                     if isinstance(d, dict) and d.get("kind") in ("array", "array-tuples")}  # fmt: skip
        (required if rtol is not None else optional).add("atol")
    else:
        required |= legacy.entries
        optional |= {"touchdowns"}
    archive.expect(required, optional=optional)

    # the samples: times first (their count fixes the other arrays' shapes)
    t = archive.array("t", (None,))
    if t.size == 0:
        raise _Refused("t must hold at least one sample")
    _check_times(t, "t", strict=True)
    states = archive.array("states", (n_state, t.size))
    saved_series = {name: archive.array(name, (t.size,)) for name in series}
    t_events = [archive.array(f"t_events_{k}", (None,)) for k in range(n_events)]
    t0, t1 = float(t[0]), float(t[-1])
    solution = _decode_dense(dense_meta, archive, n_state)
    if not (solution.t_min <= t0 and t1 <= solution.t_max):
        raise _Refused(
            f"the dense output covers [{solution.t_min!r}, {solution.t_max!r}] s, not the "
            f"samples' [{t0!r}, {t1!r}] s"
        )
    _check_dense_values(solution, t, states)
    if t_lost is not None and not t0 <= t_lost <= t1:
        raise _Refused(f"t_contact_lost = {t_lost!r} s lies outside the run")
    span = (solution.t_min, solution.t_max)
    atol = None
    if version >= 3:
        saved_series["psi"] = archive.array("psi", (t.size,))
        if rtol is not None:
            atol = archive.array("atol", (n_state,))
            if np.any(atol <= 0.0):
                raise _Refused("atol must be positive")
        if t_end is not None and not t1 <= t_end + 4 * np.finfo(float).eps * max(abs(t_end), 1):
            raise _Refused(f"t_end = {t_end!r} s lies before the last sample ({t1!r} s)")
        extras = {
            name: archive.array(f"extra_{name}", (t.size,), kind=kind)
            for name, kind in extras_meta.items()
        }
        records = {
            name: _decode_record(name, desc, archive, span) for name, desc in records_meta.items()
        }
    else:
        extras, records = _legacy_entries(legacy, archive, t.size, n_state, phase_names, span)

    return cls(
        t=t,
        states=states,
        model=model,
        top=top,
        params=params,
        solution=solution,
        status=status,
        message=message,
        t_contact_lost=t_lost,
        t_events=t_events,
        nfev=nfev,
        backend=backend,
        initial_state=init,
        options=options,
        extras=extras,
        records=records,
        rtol=rtol,
        atol=atol,
        t_end=t_end,
        # the series exactly as saved (a later mett may derive them in other rounding)
        series=saved_series,
        finish=False,
    )


def _kinds(v: Any) -> dict[str, str]:
    """The ``extras`` metadata: name -> "f" or "U"."""
    if not isinstance(v, dict) or len(v) > _MAX_NAMES:
        raise _Refused(f"extras must be an object of at most {_MAX_NAMES} entries")
    for name, kind in v.items():
        _public_name(name, "an extra series' name")
        _choice(kind, f"the kind of extra series {name!r}", ("f", "U"))
    return dict(v)


def _public_name(v: Any, what: str) -> str:
    """A name that can be an attribute (an identifier without a leading underscore)."""
    if not (isinstance(v, str) and v.isidentifier() and not v.startswith("_") and len(v) <= 64):
        raise _Refused(f"{what} must be a public name (an identifier of at most 64 characters, "
                       f"without a leading underscore); got {_short(v)}")  # fmt: skip
    return v


def _decode_record(name: str, desc: Any, archive: _Archive, span: tuple[float, float]) -> Any:
    """A record of format 3 (see :func:`_encode_record`), checked."""
    kind = desc.get("kind") if isinstance(desc, dict) else None
    if kind == "number" and set(desc) == {"kind", "value"}:
        return _number(desc["value"], f"record {name!r}", finite=False)
    if kind in ("array", "array-tuples") and set(desc) == {"kind", "shape"}:
        shape = desc["shape"]
        low = 3 if kind == "array-tuples" else 0
        if not (isinstance(shape, list) and low <= len(shape) <= 3):
            raise _Refused(f"record {name!r} must have a shape of at most 3 axes")
        dims = tuple(_integer(d, f"an axis of record {name!r}", 0, 2**40) for d in shape)
        arr = archive.array(f"record_{name}", dims)
        if kind == "array":
            return arr
        return [tuple(arr[i, j] for j in range(dims[1])) for i in range(dims[0])]
    if kind == "records" and set(desc) == {"kind", "items"}:
        items = desc["items"]
        if not isinstance(items, list) or len(items) > _MAX_RECORDS:
            raise _Refused(f"record {name!r} must be a list of at most {_MAX_RECORDS} items")
        out = [_decode_item(item, span) for item in items]
        times = [float(r.t) for r in out if hasattr(r, "_fields") and "t" in r._fields]
        if times != sorted(times):
            raise _Refused(f"the times of record {name!r} must be in order")
        return out
    raise _Refused(f"record {name!r} is not one the format defines: {_short(desc)}")


def _decode_item(item: Any, span: tuple[float, float]) -> Any:
    """One item of a record list: a plain tuple of numbers and text, or a mett record class
    (its time ``t``, if any, inside the run)."""
    if not isinstance(item, dict) or "type" not in item:
        raise _Refused(f"a record item must be an object with a type; got {_short(item)}")
    if item["type"] is None:
        values = item.get("values")
        if not isinstance(values, list) or len(values) > 64 or set(item) != {"type", "values"}:
            raise _Refused(f"a record item must be a list of values; got {_short(item)}")
        return tuple(
            _text(x, "a record item's text", 64) if isinstance(x, str)
            else _number(x, "a record item's number", finite=False)
            for x in values
        )  # fmt: skip
    cls = _saved_record(item["type"])
    fields = item.get("fields")
    if not isinstance(fields, dict) or set(fields) != set(cls._fields) or set(item) != {
        "type", "fields"
    }:  # fmt: skip
        raise _Refused(f"a record item must have the fields {cls._fields}; got {_short(item)}")
    record = _record_of(cls, fields, "record")
    t = getattr(record, "t", None)  # a number (_number): the fields' hints are str or float
    if isinstance(t, float) and not span[0] <= t <= span[1]:
        raise _Refused(f"a record at t = {t!r} s lies outside the run")
    return record


def _record_of(cls: Any, fields: dict, label: str) -> Any:
    """An instance of the record class ``cls`` from its checked field values: text where the
    field's hint is ``str`` (at most 64 characters), otherwise a number (a time ``t`` finite)."""
    hints = typing.get_type_hints(cls)
    kwargs = {
        k: _text(x, f"{label} field {k!r}", 64) if hints[k] is str
        else _number(x, f"{label} field {k!r}", finite=k == "t")
        for k, x in fields.items()
    }  # fmt: skip
    return cls(**kwargs)


# --- format versions 1 and 2 -------------------------------------------------------------------
class _Legacy(typing.NamedTuple):
    per_sample: list[str]
    switches: list | None
    n_jumps: int | None
    band: float | None
    entries: set[str]


_PER_SAMPLE = {
    "phase": ("U", ("sliding", "rolling", "ball", "stem")),
    "contact": ("U", ("ball", "stem")),
    "F_x": ("f", ()),
    "F_y": ("f", ()),
    "M_n": ("f", ()),
    "margin": ("f", ()),
}
"""The per-sample series a run of format 2 may hold beyond :data:`SERIES` (name: dtype kind,
allowed labels)."""


def _legacy_meta(meta: dict) -> _Legacy:
    """What the metadata of a file of format 1 or 2 declares beyond the samples."""
    per_sample = _names(meta.get("per_sample", []), "per_sample", tuple(_PER_SAMPLE))
    _names(meta.get("extra", []), "extra", (*per_sample, *_KNOWN_SERIES))
    switches = meta.get("switches")
    if switches is not None and (not isinstance(switches, list) or len(switches) > _MAX_RECORDS):
        raise _Refused(f"switches must be a list of at most {_MAX_RECORDS} records")
    n_jumps = None
    if "n_jumps" in meta:
        n_jumps = _integer(meta["n_jumps"], "n_jumps", 0, _MAX_RECORDS)
        if switches is not None and n_jumps != len(switches):
            raise _Refused(f"{n_jumps} jumps for {len(switches)} switches")
    band = None
    if "stopping_band" in meta:
        band = _number(meta["stopping_band"], "stopping_band")
        if band < 0.0:
            raise _Refused(f"stopping_band must be >= 0; got {band!r}")
    entries = {f"extra_{name}" for name in per_sample}
    if n_jumps is not None:
        entries |= {"jumps_before", "jumps_after"}
    return _Legacy(per_sample, switches, n_jumps, band, entries)


_KNOWN_SERIES = ("theta", "thetadot", "phidot", "psidot", "omega3", "nu_x", "nu_y", "gn", "x",
                 "y", "phi", "E", "E_mod", "D", "lam")  # fmt: skip
"""The derived series of format 2 (names ``extra`` may list)."""


def _legacy_entries(
    legacy: _Legacy, archive: _Archive, n: int, n_state: int, phases: tuple[str, ...],
    span: tuple[float, float],
) -> tuple[dict, dict]:  # fmt: skip
    """The extras and records of a file of format 1 or 2, checked as that format was."""
    extras = {
        name: archive.array(f"extra_{name}", (n,), kind=_PER_SAMPLE[name][0],
                            labels=_PER_SAMPLE[name][1])
        for name in legacy.per_sample
    }  # fmt: skip
    records: dict[str, Any] = {}
    switches = None
    if legacy.switches is not None:
        switches = [_decode_switch(item, phases, span) for item in legacy.switches]
        times = [float(sw[0]) for sw in switches]
        if times != sorted(times):
            raise _Refused("the switch times must be in order")
        records["switches"] = switches
    if legacy.n_jumps is not None:
        before = archive.array("jumps_before", (legacy.n_jumps, n_state))
        after = archive.array("jumps_after", (legacy.n_jumps, n_state))
        records["jumps"] = [(before[k], after[k]) for k in range(legacy.n_jumps)]
    if archive.has("touchdowns"):
        touchdowns = archive.array("touchdowns", (None,))
        # the times the stem touched down: those of the switches from ball to stem
        down = [sw[0] for sw in switches or () if sw[1][:4] == "ball" and sw[2][:4] == "stem"]
        if not np.array_equal(touchdowns, down):
            raise _Refused("the touchdowns are not the switches from ball to stem")
        records["touchdowns"] = touchdowns
    if legacy.band is not None:
        records["stopping_band"] = legacy.band
    return extras, records


# --- file helpers ----------------------------------------------------------------------------
def _mett_version() -> str:
    from .. import __version__

    return __version__


def _check_save_path(path: Any) -> tuple[Path, Path]:
    """The path as given and the file to write (a symbolic link resolved to the file it points
    to), checked before any work."""
    if not isinstance(path, (str, os.PathLike)) or isinstance(path, bytes):
        raise TypeError(f"path must be a str or path-like; got {type(path).__name__}")
    p = Path(os.fspath(path))
    if p.suffix != ".npz":
        raise ValueError(f"path must end in .npz; got {str(p)!r}")
    if p.is_dir():
        raise ValueError(f"path must be a file, not a directory; got {str(p)!r}")
    # a link is written through: the file it points to is replaced, the link stays a link
    real = Path(os.path.realpath(p)) if p.is_symlink() else p
    if real.is_dir():
        raise ValueError(f"path must be a file, not a directory; got {str(p)!r} -> {str(real)!r}")
    parent = real.parent if str(real.parent) else Path(".")
    if not parent.is_dir():
        raise ValueError(f"the directory of path must exist; got {str(p)!r}")
    if not os.access(parent, os.W_OK | os.X_OK) or (real.exists() and not os.access(real, os.W_OK)):
        raise ValueError(f"path must be writable; got {str(p)!r}")
    return p, real


def _write_atomically(target: Path, write: Any) -> None:
    """``write(file)`` into a fresh temporary file next to ``target``, then renamed over it.

    The temporary name is short (``.mett-<12 hex>.tmp``), so that any legal target name works.
    It is created exclusively with the permissions of the file it replaces (or those of a new
    file under the umask), never wider; it is removed on any error.
    """
    parent = target.parent if str(target.parent) else Path(".")
    try:
        mode = stat.S_IMODE(target.stat().st_mode) & 0o777
    except FileNotFoundError:
        mode = None
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_BINARY", 0)
    for _ in range(100):
        tmp = parent / f".mett-{secrets.token_hex(6)}.tmp"
        try:
            # created with the target's bits (or 0o666) under the umask: never wider than either
            fd = os.open(tmp, flags, 0o666 if mode is None else mode)
            break
        except FileExistsError:
            continue
    else:  # pragma: no cover - 100 collisions of 48 random bits
        raise FileExistsError(f"cannot create a temporary file in {str(parent)!r}")
    try:
        with os.fdopen(fd, "wb") as fh:
            if mode is not None and hasattr(os, "fchmod"):
                os.fchmod(fh.fileno(), mode)  # exactly the replaced file's bits (umask aside)
            write(fh)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, target)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def _encode_param(i: int, v: Any) -> float:
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, float, np.integer, np.floating)):
        raise TypeError(f"model parameter {i} must be a number to be saved; got {v!r}")
    return float(v)


def _encode_option(name: str, v: Any) -> Any:
    if v is None or isinstance(v, (bool, str)):
        return v
    if isinstance(v, (int, float, np.integer, np.floating)):
        return v.item() if isinstance(v, np.generic) else v
    if isinstance(v, (list, tuple)):
        return [_encode_option(name, x) for x in v]
    if isinstance(v, Mapping):
        return {str(k): _encode_option(name, x) for k, x in v.items()}
    if type(v) in _saved_classes()["option"].values():
        fields = {f.name: _encode_option(name, getattr(v, f.name)) for f in dataclasses.fields(v)}
        return {"__dataclass__": _qualified_name(type(v)), "fields": fields}
    raise TypeError(
        f"option {name!r} must be a plain value (number, string, bool, None, list, dict or a "
        f"registered friction law) to be saved; got {type(v).__name__}"
    )


def _qualified_name(cls: type) -> str:
    return f"{cls.__module__}:{cls.__qualname__}"


def _saved_classes() -> dict[str, dict[str, type]]:
    """The only classes a trajectory file can name, by the name it uses: a file never chooses
    code to import or to call (no import by name, no attribute walk)."""
    from ..friction import registered
    from ..stem import StemContactTop
    from ..top import TippeTop
    from .stickslip import Switch

    def table(*classes: type) -> dict[str, type]:
        return {_qualified_name(c): c for c in classes}

    return {
        "top": table(TippeTop, StemContactTop),
        "option": table(*registered()),  # the registered friction laws
        "record": table(Switch),
    }


def _class_name(cls: type, what: str) -> str:
    """The saved name of ``cls``, one of the classes a file may name as a ``what``."""
    name = _qualified_name(cls)
    if _saved_classes()[what].get(name) is not cls:
        raise TypeError(
            f"a {what} of type {cls.__name__} cannot be saved (not one of mett's types)"
        )
    return name


def _saved_class(name: Any, what: str) -> type:
    table = _saved_classes()[what]
    if not isinstance(name, str) or name not in table:
        raise _Refused(
            f"refusing to rebuild {_short(name)} as {'an' if what[0] in 'aeiou' else 'a'} {what}: not one of the types a trajectory "
            f"file may name ({', '.join(table)})"
        )
    return table[name]


def _saved_record(name: Any) -> Any:
    """The record class a file names (a :class:`typing.NamedTuple`: ``_fields``, keywords)."""
    return _saved_class(name, "record")


def _encode_switch(sw: Any) -> dict:
    """A switch of a hybrid run (a (t, before, after) tuple or a mett record) as JSON."""
    if hasattr(sw, "_asdict"):
        fields = {k: (v if isinstance(v, str) else float(v)) for k, v in sw._asdict().items()}
        return {"type": _class_name(type(sw), "record"), "fields": fields}
    return {"type": None, "values": [v if isinstance(v, str) else float(v) for v in sw]}


def _check_meta(meta: Any, p: Path) -> None:
    if not isinstance(meta, dict) or meta.get("format") != _FORMAT_NAME:
        raise _Named(f"{p} is not a mett trajectory file")
    version = meta.get("format_version")
    if not isinstance(version, int) or isinstance(version, bool) or version < 1:
        raise _Named(f"{p} has an invalid format_version {_short(version)}")
    if version > FORMAT_VERSION:
        raise _Named(
            f"{p} was written in trajectory format version {version} (by mett "
            f"{_short(meta.get('mett_version', '?'))}); this mett reads versions up to "
            f"{FORMAT_VERSION}: upgrade mett to read it"
        )
    name = meta.get("model")
    if not isinstance(name, str) or name not in MODELS:
        raise _Named(
            f"{p} holds a run of model {_short(name)}, which this mett does not know "
            f"(known models: {', '.join(MODELS)})"
        )


# --- reading a file: every entry and field checked before use ----------------------------------
class _Refused(Exception):
    """Why a trajectory file is refused (:meth:`Trajectory.load` raises it as a ValueError
    naming the file)."""


class _Named(ValueError):
    """A ValueError whose message already names the file."""


_LOAD_FLOOR = 64 * 2**20
_LOAD_RATIO = 256
"""A file whose entries declare more than ``max(_LOAD_FLOOR, _LOAD_RATIO × its size)`` bytes
uncompressed is refused before anything is decompressed (a zip bomb). The arrays of a real run
compress by 1.1–3 (floats of a motion); the most compressible real file, a motionless run sampled
at integer ``t_eval``, by about 200. Deflate can reach 1032."""

_META_MAX_CHARS = 2**24
"""Longest metadata text (characters): 10⁵ switch records (MAX_SWITCHES) of ~150 characters."""

_MAX_DEPTH = 16
"""Deepest nesting of an option value (a friction law in a dict in a list ...)."""

_MAX_TEXT = 100_000
"""Longest message or other text field (characters)."""

_MAX_TAYLOR_TERMS = 64
"""Most Taylor coefficients per component and step (the Taylor backend's order is at most ~20)."""


class _Archive:
    """The entries of a ``.npz`` file, read one by one with their sizes checked first.

    Only the entries the format defines are ever decompressed; each ``.npy`` header (dtype,
    shape) is checked against the shape the metadata and the other entries fix, and against
    the entry's declared size, before its data is read, and the data is read to exactly that
    size (a CRC error or a short entry is refused).
    """

    def __init__(self, path: Path) -> None:
        self.path = path
        self.zf = zipfile.ZipFile(path)
        try:
            infos = self.zf.infolist()
            names = [info.filename for info in infos]
            if len(set(names)) != len(names):
                raise _Refused("two entries have the same name")
            total = sum(info.file_size for info in infos)
            budget = max(_LOAD_FLOOR, _LOAD_RATIO * path.stat().st_size)
            if total > budget:
                raise _Refused(
                    f"its entries declare {total} bytes uncompressed, more than {budget} for a "
                    f"file of {path.stat().st_size} bytes (refused unread as a zip bomb)"
                )
            self.infos: dict[str, zipfile.ZipInfo] = {}
            for info in infos:
                name = info.filename
                if not name.endswith(".npy") or info.is_dir():
                    raise _Refused(f"entry {_short(name)} is not part of the format")
                if info.flag_bits & 0x1 or info.compress_type not in (
                    zipfile.ZIP_STORED,
                    zipfile.ZIP_DEFLATED,
                ):
                    raise _Refused(f"entry {_short(name)} is encrypted or compressed unusually")
                self.infos[name[: -len(".npy")]] = info
        except BaseException:
            self.zf.close()
            raise

    def __enter__(self) -> _Archive:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.zf.close()

    def has(self, key: str) -> bool:
        return key in self.infos

    def expect(self, required: set[str], optional: set[str]) -> None:
        """Refuse a file without one of ``required`` or with an entry not in either set."""
        keys = set(self.infos) - {_META_KEY}
        if missing := sorted(required - keys):
            raise _Refused(f"entry {missing[0]!r} is missing")
        if unknown := sorted(keys - required - optional):
            raise _Refused(f"entry {_short(unknown[0])} is not part of this file's format")

    def meta(self) -> Any:
        """The JSON metadata (a bounded text; deep nesting refused)."""
        if _META_KEY not in self.infos:
            raise _Named(f"{self.path} is not a mett trajectory file (no {_META_KEY!r} entry)")
        arr = self.array(_META_KEY, (), kind="U", max_chars=_META_MAX_CHARS)
        try:
            return json.loads(str(arr[()]))
        except RecursionError:
            raise _Refused("its metadata is nested too deeply") from None
        except ValueError as exc:  # json.JSONDecodeError; an integer of too many digits
            raise _Refused(f"its metadata is not JSON: {exc}") from None

    def array(
        self,
        key: str,
        shape: tuple[int | None, ...],
        *,
        kind: str = "f",
        labels: tuple[str, ...] = (),
        max_chars: int = 64,
    ) -> np.ndarray:
        """Entry ``key`` as a native array of ``shape`` (None: any length) and dtype ``kind``
        ("f": float64, finite; "U": text of at most ``max_chars`` characters, in ``labels`` if
        given)."""
        info = self.infos.get(key)
        if info is None:
            raise _Refused(f"entry {key!r} is missing")
        with self.zf.open(info) as fp:
            try:
                version = np.lib.format.read_magic(fp)
                if version == (1, 0):
                    found, fortran, dtype = np.lib.format.read_array_header_1_0(fp)
                elif version == (2, 0):
                    found, fortran, dtype = np.lib.format.read_array_header_2_0(fp)
                else:
                    raise _Refused(f"entry {key!r} has .npy version {version}")
            except _Refused:
                raise
            except Exception as exc:  # numpy parses the header's text: any failure is a bad one
                raise _Refused(f"entry {key!r} has no valid .npy header: {exc!r}") from None
            if not (isinstance(dtype, np.dtype) and dtype.names is None and dtype.shape == ()):
                raise _Refused(f"entry {key!r} has dtype {dtype}")
            if kind == "f" and not (dtype.kind == "f" and dtype.itemsize == 8):
                raise _Refused(f"entry {key!r} must hold float64; got {dtype}")
            if kind == "U" and not (dtype.kind == "U" and dtype.itemsize <= 4 * max_chars):
                raise _Refused(
                    f"entry {key!r} must hold text of <= {max_chars} characters; got {dtype}"
                )
            if (
                len(found) != len(shape)
                or any(d < 0 for d in found)
                or any(
                    want is not None and got != want for got, want in zip(found, shape, strict=True)
                )
            ):
                want_text = "(" + ", ".join("n" if s is None else str(s) for s in shape) + ")"
                raise _Refused(f"entry {key!r} has shape {found}, not {want_text}")
            count = math.prod(found)
            nbytes = count * dtype.itemsize
            if info.file_size != fp.tell() + nbytes:
                raise _Refused(
                    f"entry {key!r} declares {info.file_size} bytes for {nbytes} of data"
                )
            flat = np.empty(count, dtype=dtype)
            view = flat.view(np.uint8).data
            pos = 0
            while pos < nbytes:
                chunk = fp.read(min(2**20, nbytes - pos))
                if not chunk:
                    raise _Refused(f"entry {key!r} is truncated")
                view[pos : pos + len(chunk)] = chunk
                pos += len(chunk)
            if fp.read(1):  # (and at its end the entry's CRC is checked)
                raise _Refused(f"entry {key!r} is longer than its header says")
        arr = flat.reshape(found, order="F" if fortran else "C")
        arr = arr.astype(dtype.newbyteorder("="), order="C", copy=False)
        if kind == "f" and not np.all(np.isfinite(arr)):
            raise _Refused(f"entry {key!r} holds non-finite numbers")
        if labels and arr.size and not set(np.unique(arr).tolist()) <= set(labels):
            bad = sorted(set(np.unique(arr).tolist()) - set(labels))[0]
            raise _Refused(f"entry {key!r} holds {_short(bad)}, not one of {labels}")
        return arr


_REPR = reprlib.Repr()
_REPR.maxlevel, _REPR.maxlist, _REPR.maxdict, _REPR.maxstring, _REPR.maxother = 3, 4, 4, 60, 60


def _short(value: Any) -> str:
    """``repr(value)`` of bounded length and cost (a crafted field may be huge or deep)."""
    text = _REPR.repr(value)
    return text if len(text) <= 100 else text[:97] + "..."


def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _number(v: Any, what: str, *, finite: bool = True) -> float:
    if not _is_number(v):
        raise _Refused(f"{what} must be a number; got {_short(v)}")
    try:
        x = float(v)
    except OverflowError:
        raise _Refused(f"{what} must be a float; got an integer of {len(str(v))} digits") from None
    if finite and not math.isfinite(x):
        raise _Refused(f"{what} must be finite; got {x!r}")
    return x


def _integer(v: Any, what: str, lo: int, hi: int) -> int:
    if not isinstance(v, int) or isinstance(v, bool) or not lo <= v <= hi:
        raise _Refused(f"{what} must be an integer in [{lo}, {hi}]; got {_short(v)}")
    return v


def _text(v: Any, what: str, max_len: int = _MAX_TEXT) -> str:
    if not isinstance(v, str) or len(v) > max_len:
        raise _Refused(f"{what} must be a str of at most {max_len} characters; got {_short(v)}")
    return v


def _choice(v: Any, what: str, allowed: tuple[str, ...]) -> str:
    if not isinstance(v, str) or v not in allowed:
        raise _Refused(f"{what} must be one of {allowed}; got {_short(v)}")
    return v


def _names(v: Any, what: str, allowed: tuple[str, ...]) -> list[str]:
    """A list of distinct names from ``allowed``."""
    if not isinstance(v, list) or len(v) > len(allowed):
        raise _Refused(f"{what} must be a list of names from {allowed}; got {_short(v)}")
    for name in v:
        _choice(name, f"an entry of {what}", allowed)
    if len(set(v)) != len(v):
        raise _Refused(f"{what} names a series twice: {_short(v)}")
    return list(v)


def _fields(v: Any, what: str, cls: type) -> dict[str, float]:
    """Keyword arguments of the dataclass ``cls`` from a JSON object of numbers."""
    names = {f.name for f in dataclasses.fields(cls) if f.init}
    if not isinstance(v, dict) or not set(v) <= names:
        raise _Refused(
            f"{what} must be an object with fields from {sorted(names)}; got {_short(v)}"
        )
    return {k: _number(x, f"{what} field {k!r}", finite=False) for k, x in v.items()}


def _build(cls: type, kwargs: dict, what: str) -> Any:
    try:
        return cls(**kwargs)
    except (TypeError, ValueError, ArithmeticError) as exc:
        raise _Refused(f"{what}: {exc}") from None


def _decode_top(v: Any) -> Any:
    if not isinstance(v, dict):
        raise _Refused(f"top must be an object; got {_short(v)}")
    fields = dict(v)
    cls = _saved_class(fields.pop("type", "mett.top:TippeTop"), "top")
    return _build(cls, _fields(fields, "top", cls), "top")


def _decode_options(v: Any) -> dict[str, Any]:
    if not isinstance(v, dict):
        raise _Refused(f"options must be an object; got {_short(v)}")
    return {k: _decode_option(x, f"option {k!r}", 0) for k, x in v.items()}


def _decode_option(v: Any, what: str, depth: int) -> Any:
    if depth > _MAX_DEPTH:
        raise _Refused(f"{what} is nested more than {_MAX_DEPTH} levels deep")
    if v is None or isinstance(v, (bool, int, float)):
        return v
    if isinstance(v, str):
        return _text(v, what)
    if isinstance(v, list):
        return [_decode_option(x, what, depth + 1) for x in v]
    if isinstance(v, dict):
        if "__dataclass__" in v:
            if set(v) != {"__dataclass__", "fields"}:
                raise _Refused(f"{what} must be {{'__dataclass__': name, 'fields': {{...}}}}")
            cls = _saved_class(v["__dataclass__"], "option")
            return _build(cls, _fields(v["fields"], what, cls), what)
        return {k: _decode_option(x, what, depth + 1) for k, x in v.items()}
    raise _Refused(f"{what} has a value of type {type(v).__name__}")  # pragma: no cover


def _decode_params(v: Any, expected: tuple, model: str = "") -> tuple:
    """The saved parameters, which must be those of the saved top and options (to rounding).

    A file written before the shared parameter order (g before mu in the dry models and rolling
    resistance, no mu in the Routhian) stored its tuple in the old order: it is mapped to
    today's (:func:`._params.from_legacy`) when it does not match as it stands.
    """
    if isinstance(v, list) and not _matches(v, expected):
        old = ix.from_legacy(model, tuple(v))
        if old is not None and _matches(list(old), expected):
            v = list(old)
    if not isinstance(v, list) or len(v) != len(expected):
        raise _Refused(f"params must be a list of {len(expected)} numbers; got {_short(v)}")
    params = tuple(_number(x, f"params[{i}]") for i, x in enumerate(v))
    for i, (got, want) in enumerate(zip(params, expected, strict=True)):
        want = float(want)
        if not abs(got - want) <= 1e-12 * abs(want):  # (a later mett may round differently)
            raise _Refused(f"params[{i}] = {got!r} is not that of the top and options ({want!r})")
    return params


def _matches(v: Any, expected: tuple) -> bool:
    """True if ``v`` is a list of numbers equal to ``expected`` to rounding (no exception)."""
    if not isinstance(v, list) or len(v) != len(expected):
        return False
    try:
        return all(
            abs(float(got) - float(want)) <= 1e-12 * abs(float(want))
            for got, want in zip(v, expected, strict=True)
        )
    except (TypeError, ValueError):
        return False


def _decode_state(v: Any) -> State:
    if not isinstance(v, dict) or set(v) != set(_STATE_FIELDS):
        raise _Refused(
            f"initial_state must be an object with fields {_STATE_FIELDS}; got {_short(v)}"
        )
    values = {k: _number(v[k], f"initial_state field {k!r}") for k in _STATE_FIELDS}
    return _build(State, values, "initial_state")


def _decode_switch(item: Any, phases: tuple[str, ...], span: tuple[float, float]) -> Any:
    """A switch record: a (t, before, after) tuple or a :class:`~mett.dynamics.stickslip.Switch`."""
    if not isinstance(item, dict) or "type" not in item:
        raise _Refused(f"a switch must be an object with a type; got {_short(item)}")
    if item["type"] is None:
        values = item.get("values")
        if not isinstance(values, list) or len(values) != 3 or set(item) != {"type", "values"}:
            raise _Refused(f"a switch must be [t, before, after]; got {_short(item)}")
        record: tuple = (_number(values[0], "a switch time"), values[1], values[2])
    else:
        cls = _saved_record(item["type"])
        fields = item.get("fields")
        if not isinstance(fields, dict) or set(fields) != set(cls._fields):
            raise _Refused(
                f"a switch record must have the fields {cls._fields}; got {_short(item)}"
            )
        record = _record_of(cls, fields, "switch")
    t, before, after = record[0], record[1], record[2]
    for name in (before, after):
        _choice(name, "a switch's phase", phases)
    if not span[0] <= t <= span[1]:
        raise _Refused(f"a switch at t = {t!r} s lies outside the run")
    return record


def _check_times(t: np.ndarray, what: str, *, strict: bool = False) -> None:
    """Finite (checked on reading) and in order, as the dense output's search needs."""
    steps = np.diff(t)
    if np.any(steps <= 0.0) if strict else np.any(steps < 0.0):
        raise _Refused(f"the times {what} must be {'increasing' if strict else 'in order'}")


def _dense_entries(desc: Any, phases: tuple[str, ...], max_parts: int) -> list[str]:
    """The entry names of a dense-output description (checked: known kinds, one level of
    segments, their phases those of the model)."""
    if not isinstance(desc, dict):
        raise _Refused(f"dense must be an object; got {_short(desc)}")
    kind = desc.get("kind")
    if kind == "segments":
        parts, names = desc.get("parts"), desc.get("phases")
        if not (isinstance(parts, list) and isinstance(names, list)
                and 1 <= len(parts) == len(names) <= max_parts + 1):  # fmt: skip
            raise _Refused("dense segments must be lists of parts and phases of one length")
        for name in names:
            _choice(name, "a dense segment's phase", phases)
        out = []
        for k, part in enumerate(parts):
            if not isinstance(part, dict) or part.get("kind") not in ARRAYS:
                raise _Refused(f"dense segment {k} must be one of {tuple(ARRAYS)}")
            out += [f"dense_s{k}_{a}" for a in ARRAYS[part["kind"]]]
        return out
    if kind not in ARRAYS:
        raise _Refused(f"dense kind must be one of {(*ARRAYS, 'segments')}; got {_short(kind)}")
    return [f"dense_{a}" for a in ARRAYS[kind]]


def _decode_dense(desc: Any, archive: _Archive, n: int) -> Any:
    """The dense output (checked by :func:`_dense_entries`) with every array's shape fixed by
    its times and the state size ``n``, its times in order and its steps positive."""
    if desc["kind"] != "segments":
        return _decode_part(desc["kind"], archive, "dense_", n)
    parts = [
        _decode_part(d["kind"], archive, f"dense_s{k}_", n) for k, d in enumerate(desc["parts"])
    ]
    for k in range(1, len(parts)):
        if parts[k].t_min != parts[k - 1].t_max:
            raise _Refused(f"dense segment {k} does not start where segment {k - 1} ends")
    return SegmentedSolution(parts, list(desc["phases"]))


def _decode_part(kind: str, archive: _Archive, prefix: str, n: int) -> Any:
    """One dense output of ``kind`` (not segments), its arrays' shapes fixed by its times and
    ``n``, its times in order and (DOP853) its step sizes those of its times."""
    if kind == "constant":
        t = archive.array(prefix + "t", (1,))
        return from_arrays({"kind": kind}, {"t": t, "y": archive.array(prefix + "y", (n,))})
    t = archive.array(prefix + "t", (None,))
    if t.size == 0:
        raise _Refused(f"entry {prefix + 't'!r} is empty")
    m = t.size - 1
    arrays = {"t": t, "y": archive.array(prefix + "y", (m + 1, n))}
    if kind == "hermite":
        _check_times(t, prefix + "t", strict=True)
        arrays["dy"] = archive.array(prefix + "dy", (m + 1, n))
        return from_arrays({"kind": kind}, arrays)
    _check_times(t, prefix + "t")
    if kind == "taylor":
        C = archive.array(prefix + "C", (m, n, None))
        if not 1 <= C.shape[2] <= _MAX_TAYLOR_TERMS:
            raise _Refused(f"entry {prefix + 'C'!r} has {C.shape[2]} Taylor coefficients")
        return from_arrays({"kind": kind}, {**arrays, "C": C})
    h = archive.array(prefix + "h", (m,))
    F = archive.array(prefix + "F", (m, 7, n))
    # each step's interpolant spans its segment: t[i+1] = t[i] + h[i] to rounding, the last
    # step possibly cut short by a terminal event
    steps = np.diff(t)
    slack = 4.0 * np.finfo(float).eps * np.maximum(np.abs(t[:-1]), np.abs(t[1:]))
    if np.any(h <= 0.0) or np.any(steps > h + slack) or np.any(np.abs(steps - h)[:-1] > slack[:-1]):
        raise _Refused(f"the step sizes {prefix + 'h'!r} do not match the times {prefix + 't'!r}")
    return from_arrays({"kind": kind}, {**arrays, "h": h, "F": F})


_EXACT = 16 * np.finfo(float).eps
"""Agreement (relative to each component's magnitude) of the states a dense output stores at
its steps with the samples there and with its own polynomials at the step ends: a run stores
the very numbers (measured: 0 for DOP853 and constants, 1 ulp for Hermite data, 6 ulps for the
Taylor polynomials summed at a step's end)."""

_BOUNDED = 1e6
"""Largest sum of a step's polynomial terms over the component's magnitude (+ 1): a run's are
below ~1 (its dense output moves a component by at most its range within a step); far larger
ones could overflow what :meth:`Trajectory.at` derives from them."""


def _check_dense_values(solution: Any, t: np.ndarray, states: np.ndarray) -> None:
    """The dense output's polynomials join at their steps with bounded terms, and pass through
    the stored samples: what :meth:`Trajectory.at` gives agrees with the samples and stays
    finite."""
    from .dop853 import DenseOutput
    from .taylor import TaylorDense

    parts = solution.sols if isinstance(solution, SegmentedSolution) else [solution]
    ys = [np.atleast_2d(p.y) for p in parts]
    scale = np.max(np.abs(np.vstack([states.T, *ys])), axis=0)
    tol = _EXACT * scale
    with np.errstate(over="ignore", invalid="ignore"):  # (what overflows is refused)
        for k, part in enumerate(parts):
            if isinstance(part, DenseOutput):  # each step ends where the next starts
                inner = np.abs(part.y[:-2] + part.F[:-1, 0] - part.y[1:-1]) > tol
                terms = np.abs(part.F).sum(axis=1)
            elif isinstance(part, TaylorDense):  # (the sum at a step's end: a few ulps)
                powers = np.diff(part.t)[:, None] ** np.arange(part.C.shape[2])
                ends = np.einsum("ick,ik->ic", part.C, powers)
                inner = np.vstack(
                    [np.abs(part.C[:, :, 0] - part.y[:-1]) > tol,
                     np.abs(ends[:-1] - part.y[1:-1]) > 4 * tol]
                )  # fmt: skip
                terms = np.einsum("ick,ik->ic", np.abs(part.C[:, :, 1:]), powers[:, 1:])
            elif isinstance(part, HermiteSolution):
                inner = np.zeros(0, dtype=bool)
                terms = np.abs(part.dy[:-1]) * np.diff(part.ts)[:, None]
            else:
                continue
            if np.any(inner):
                raise _Refused(f"the dense output (part {k}) does not join at its steps")
            if np.any(~np.isfinite(terms) | (terms > _BOUNDED * (scale + 1.0))):
                raise _Refused(f"the dense output (part {k}) has coefficients out of scale")
        Y = np.asarray(solution(t), dtype=float).reshape(states.shape)
        off = np.any(~(np.abs(Y - states).T <= tol), axis=1)
    # Hermite data (other scipy methods) interpolate between their steps: compared there only
    for part in parts:
        if isinstance(part, HermiteSolution):
            off &= ~((t >= part.t_min) & (t <= part.t_max) & ~np.isin(t, part.ts))
    if off.any():
        k = int(np.flatnonzero(off)[0])
        raise _Refused(f"the dense output does not pass through sample {k} (t = {t[k]!r} s)")
