"""Keeping results: Trajectory.save/load round trips, to_dataframe, and the empty dense query."""

from __future__ import annotations

import json
import math
import os
import stat
import zipfile
from pathlib import Path

import numpy as np
import pytest

import mett
from mett import State, Trajectory, analysis, presets
from mett.dynamics.trajectory import FORMAT_VERSION, SERIES

DATA = Path(__file__).parent / "data"


@pytest.fixture(scope="module")
def top():
    return presets.get("rutstam2013")


@pytest.fixture(scope="module")
def thesis(top):
    """The thesis run through its inversion (compiled DOP853), with a user event."""

    def horizontal(t, s):
        return s.theta - math.pi / 2

    return mett.simulate(
        top, State(theta=0.1, omega3=155.0), 7.0, events=[horizontal], backend="compiled"
    )


def _array_attrs(traj: Trajectory) -> dict[str, np.ndarray]:
    return {"t": traj.t, "states": traj.states, **{k: getattr(traj, k) for k in SERIES}}


def assert_same_run(a: Trajectory, b: Trajectory) -> None:
    """Everything saved is equal; arrays bit for bit (dtype, shape and values)."""
    for name, arr in _array_attrs(a).items():
        other = getattr(b, name)
        assert other.dtype == arr.dtype and other.shape == arr.shape, name
        assert np.array_equal(other, arr), name
    assert b.top == a.top
    assert b.initial_state == a.initial_state
    assert (b.model, b.options, b.params) == (a.model, a.options, a.params)
    assert (b.status, b.message, b.t_contact_lost) == (a.status, a.message, a.t_contact_lost)
    assert (b.nfev, b.backend) == (a.nfev, a.backend)
    assert (b.rtol, b.t_end) == (a.rtol, a.t_end) and np.array_equal(b.atol, a.atol)
    assert np.array_equal(b.psi, a.psi)
    assert len(b.t_events) == len(a.t_events)
    for ea, eb in zip(a.t_events, b.t_events, strict=True):
        assert np.array_equal(ea, eb)


def test_round_trip_is_exact_for_the_compiled_run(thesis, tmp_path):
    path = thesis.save(tmp_path / "thesis.npz")
    loaded = Trajectory.load(path)
    assert_same_run(thesis, loaded)
    assert loaded.initial_state == State(theta=0.1, omega3=155.0)
    assert thesis.t_events[0].size >= 1  # the event fired: its times are part of the round trip
    # the dense output is the solver's own: at(), crossings() equal bit for bit
    tt = np.linspace(0.0, thesis.t_final, 2001)
    assert np.array_equal(loaded.states_at(tt), thesis.states_at(tt))
    sa, sb = thesis.at(tt), loaded.at(tt)
    for k in ("theta", "thetadot", "phidot", "omega3", "nu_x", "nu_y"):
        assert np.array_equal(getattr(sa, k), getattr(sb, k)), k
    assert np.array_equal(loaded.crossings(math.pi / 2), thesis.crossings(math.pi / 2))
    assert loaded.crossings(math.pi / 2)[0] == pytest.approx(5.8797, abs=1e-4)
    # derived analyses run on the loaded trajectory and agree with the original's
    assert np.array_equal(analysis.mett_residual(loaded), analysis.mett_residual(thesis))
    tp_a, tp_b = analysis.theta_extrema(thesis), analysis.theta_extrema(loaded)
    assert tp_a.t.size > 2 and np.array_equal(tp_a.t, tp_b.t)


def test_round_trip_of_the_scipy_dop853_run_keeps_its_interpolant(top, tmp_path):
    traj = mett.simulate(top, State(theta=0.1, omega3=155.0), 3.0, backend="scipy")
    loaded = Trajectory.load(traj.save(tmp_path / "s.npz"))
    assert_same_run(traj, loaded)
    tt = np.linspace(0.0, 3.0, 3001)
    # scipy's DOP853 interpolant and the stored coefficients are the same polynomial
    assert np.array_equal(loaded.states_at(tt), traj.states_at(tt))


def test_other_scipy_methods_interpolate_by_hermite_after_load(top, tmp_path):
    traj = mett.simulate(
        top, State(theta=0.5, omega3=155.0), 1.0, backend="scipy", method="RK45", rtol=1e-8
    )
    loaded = Trajectory.load(traj.save(tmp_path / "rk45.npz"))
    assert_same_run(traj, loaded)
    steps = np.asarray(traj._sol.ts)
    # through the step states (to rounding), close (interpolation error) between them
    a, b = loaded.states_at(steps), traj.states_at(steps)
    assert np.max(np.abs(a - b)) <= 1e-14 * np.max(np.abs(b))
    mids = 0.5 * (steps[1:] + steps[:-1])
    err = np.max(np.abs(loaded.theta_at(mids) - traj.theta_at(mids)))
    assert 0.0 < err < 1e-6
    level = float(np.median(traj.theta))
    th_a = traj.crossings(level)
    assert th_a.size > 10
    assert np.allclose(loaded.crossings(level), th_a, atol=1e-6, rtol=0)


@pytest.mark.parametrize(
    ("model", "kw", "state"),
    [
        ("gliding-hst", {"l": 0.005}, State(theta=0.3, omega3=100.0)),
        ("frictionless-routhian", {"vertical_cm": False}, State(theta=0.5, omega3=100.0)),
        ("rolling", {}, State(theta=1.0, omega3=100.0, phidot=5.0)),
    ],
)
def test_model_options_round_trip(top, tmp_path, model, kw, state):
    traj = mett.simulate(top, state, 0.2, model=model, **kw)
    assert traj.options == kw
    loaded = Trajectory.load(traj.save(tmp_path / "m.npz"))
    assert_same_run(traj, loaded)
    assert loaded.options == kw


def test_contact_lost_and_failed_runs_round_trip(top, tmp_path):
    # a failure before the first step: the constant dense output of the start
    failed = mett.simulate(top, State(theta=0.0, omega3=10.0), 1.0, model="gliding-euler")
    assert failed.status == "failed" and failed.t.size == 1
    loaded = Trajectory.load(failed.save(tmp_path / "f.npz"))
    assert_same_run(failed, loaded)
    assert loaded.at(0.0) == failed.at(0.0)
    # contact lost at t = 0 (a top dropped with a large downward θ̇ at θ = π/2)
    lost = mett.simulate(top, State(theta=1.5, thetadot=-400.0, omega3=0.0), 1.0,
                        stop_on_contact_loss=True)  # fmt: skip
    assert lost.status == "contact_lost"
    loaded = Trajectory.load(lost.save(tmp_path / "c.npz"))
    assert_same_run(lost, loaded)
    assert loaded.t_contact_lost == lost.t_contact_lost


def test_t_eval_run_keeps_its_start_state(top, tmp_path):
    state = State.with_cm_at_rest(top, theta=0.2, omega3=150.0)
    traj = mett.simulate(top, state, 1.0, t_eval=np.linspace(0.5, 1.0, 11))
    assert traj.t[0] == 0.5 and traj.initial_state == state
    loaded = Trajectory.load(traj.save(tmp_path / "te.npz"))
    assert_same_run(traj, loaded)


def test_the_file_is_a_plain_npz_readable_without_mett(thesis, tmp_path):
    path = thesis.save(tmp_path / "plain.npz")
    with np.load(path, allow_pickle=False) as data:
        assert np.array_equal(data["theta"], thesis.theta)
        meta = json.loads(str(data["mett_trajectory"]))
    assert meta["format"] == "mett.Trajectory" and meta["format_version"] == FORMAT_VERSION
    assert meta["top"]["type"] == "mett.top:TippeTop"
    assert meta["top"]["I1"] == thesis.top.I1 and meta["status"] == "completed"
    assert meta["initial_state"]["omega3"] == 155.0 and meta["model"] == "gliding"


def _read_meta(path) -> dict:
    with np.load(path, allow_pickle=False) as data:
        return json.loads(str(data["mett_trajectory"]))


def _rewrite_meta(path, **changes) -> None:
    with np.load(path, allow_pickle=False) as data:
        files = {k: np.array(data[k]) for k in data.files}
    meta = json.loads(str(files["mett_trajectory"]))
    meta.update(changes)
    files["mett_trajectory"] = np.array(json.dumps(meta))
    np.savez(path, **files)


def test_load_refuses_a_newer_format_version(thesis, tmp_path):
    path = thesis.save(tmp_path / "new.npz")
    _rewrite_meta(path, format_version=FORMAT_VERSION + 1)
    with pytest.raises(ValueError, match=rf"format version {FORMAT_VERSION + 1}.*upgrade mett"):
        Trajectory.load(path)
    _rewrite_meta(path, format_version="1")
    with pytest.raises(ValueError, match="invalid format_version"):
        Trajectory.load(path)


def test_load_refuses_what_is_not_a_trajectory(thesis, tmp_path):
    other = tmp_path / "other.npz"
    np.savez(other, theta=np.zeros(3))
    with pytest.raises(ValueError, match="not a mett trajectory"):
        Trajectory.load(other)
    garbage = tmp_path / "garbage.npz"
    garbage.write_bytes(b"not a zip file at all")
    with pytest.raises(ValueError, match="not a readable mett trajectory"):
        Trajectory.load(garbage)
    with pytest.raises(ValueError, match="existing trajectory file"):
        Trajectory.load(tmp_path / "missing.npz")
    truncated = tmp_path / "truncated.npz"
    raw = thesis.save(tmp_path / "full.npz").read_bytes()
    truncated.write_bytes(raw[: len(raw) // 2])
    with pytest.raises(ValueError, match="not a readable mett trajectory"):
        Trajectory.load(truncated)
    damaged = thesis.save(tmp_path / "damaged.npz")
    with np.load(damaged, allow_pickle=False) as data:
        files = {k: np.array(data[k]) for k in data.files}
    files["theta"] = files["theta"][:-1]  # one sample short
    np.savez(damaged, **files)
    with pytest.raises(ValueError, match="damaged mett trajectory file"):
        Trajectory.load(damaged)
    unknown = thesis.save(tmp_path / "unknown_model.npz")
    _rewrite_meta(unknown, model="magic")
    with pytest.raises(ValueError, match="model 'magic'"):
        Trajectory.load(unknown)


def test_friction_law_options_round_trip_and_foreign_classes_are_refused(top, tmp_path):
    # a model option that is a friction law is stored by its name in a fixed table of mett's types
    from mett.friction import RegularisedCoulomb

    law = RegularisedCoulomb(0.3, 1e-3)
    traj = mett.simulate(top, State(theta=0.5, omega3=120.0), 0.02, friction=law)
    path = traj.save(tmp_path / "opt.npz")
    loaded = Trajectory.load(path)
    assert loaded.options == {"friction": law} and type(loaded.options["friction"]) is type(law)
    assert_same_run(traj, loaded)
    # a file can only name types of that table: nothing else is imported, walked or called
    good = json.loads(json.dumps(_read_meta(path)))
    for name in (
        "os:system",
        "mett.top:NoSuchTop",
        "mett.__main__:TippeTop",
        "mett.sweeps:pd.NamedAgg",
    ):
        _rewrite_meta(path, top={**good["top"], "type": name})
        with pytest.raises(ValueError, match=f"refusing to rebuild '{name}' as a top"):
            Trajectory.load(path)
        friction = {"__dataclass__": name, "fields": {"mu": 0.3}}
        _rewrite_meta(path, top=good["top"], options={"friction": friction})
        with pytest.raises(ValueError, match=f"refusing to rebuild '{name}' as an option"):
            Trajectory.load(path)
    # and only those types are saved (a file that load would refuse is never written)
    traj.options = {"friction": State(theta=0.2, omega3=3.0)}
    with pytest.raises(TypeError, match="option 'friction' must be a plain value"):
        traj.save(tmp_path / "state.npz")
    assert not (tmp_path / "state.npz").exists()


def test_save_validates_the_path_before_writing(thesis, tmp_path):
    with pytest.raises(ValueError, match="directory of path must exist"):
        thesis.save(tmp_path / "missing" / "x.npz")
    assert not (tmp_path / "missing").exists()
    with pytest.raises(ValueError, match=r"must end in \.npz"):
        thesis.save(tmp_path / "x.csv")
    (tmp_path / "d.npz").mkdir()
    with pytest.raises(ValueError, match="not a directory"):
        thesis.save(tmp_path / "d.npz")
    with pytest.raises(TypeError, match="path must be a str"):
        thesis.save(3)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d.npz"]


def test_a_failed_save_leaves_the_existing_file_intact(thesis, tmp_path):
    path = thesis.save(tmp_path / "keep.npz")
    before = path.read_bytes()
    thesis.options = {"friction": object()}  # not storable: refused before anything is written
    try:
        with pytest.raises(TypeError, match="option 'friction' must be a plain value"):
            thesis.save(path)
    finally:
        thesis.options = {}
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["keep.npz"]  # no temporary left behind


def test_to_dataframe(thesis):
    df = thesis.to_dataframe()
    assert list(df.columns) == ["t", *SERIES]
    assert len(df) == len(thesis)
    for name, arr in thesis.as_dict().items():
        assert np.array_equal(df[name].to_numpy(), arr)
    assert df.attrs == {"model": "gliding", "status": "completed", "message": thesis.message}
    first = thesis.theta[0]
    df.loc[0, "theta"] = 99.0  # a copy: the trajectory is unchanged
    assert thesis.theta[0] == first


def test_dense_queries_with_no_times_return_empty_results(thesis):
    s = thesis.at([])
    assert isinstance(s, State) and s.shape == (0,)
    assert s.theta.dtype == float and s.nu_y.shape == (0,)
    assert thesis.at(np.empty((0, 3))).shape == (0, 3)
    assert thesis.theta_at([]).shape == (0,)
    assert thesis.states_at([]).shape == (thesis.states.shape[0], 0)
    # scalars and arrays still work as before
    assert float(thesis.at(0.0).theta) == pytest.approx(0.1, abs=1e-15)
    with pytest.raises(ValueError, match="simulated interval"):
        thesis.at([0.0, 100.0])


def test_initial_state_of_a_trajectory_built_without_it(top):
    traj = mett.simulate(top, State(theta=0.4, omega3=120.0, phidot=3.0), 0.1, backend="scipy")
    rebuilt = Trajectory(
        t=traj.t,
        states=traj.states,
        model=mett.dynamics.MODELS["gliding"],
        top=top,
        params=traj.params,
        solution=traj._sol,
        status="completed",
        message="",
    )
    s = rebuilt.initial_state
    assert s.theta == pytest.approx(0.4, abs=1e-15) and s.omega3 == pytest.approx(120.0, rel=1e-15)
    assert s.phidot == pytest.approx(3.0, rel=1e-14) and rebuilt.options == {}


def test_loading_does_not_import_pickle_payloads(thesis, tmp_path):
    """A file with an object array is refused unread (not an entry of the format), not executed."""
    path = thesis.save(tmp_path / "p.npz")
    with zipfile.ZipFile(path, "a") as zf:
        import io

        buf = io.BytesIO()
        np.save(buf, np.array([{"a": 1}], dtype=object), allow_pickle=True)
        zf.writestr("evil.npy", buf.getvalue())
    with pytest.raises(ValueError, match="damaged mett trajectory file: entry 'evil' is not part"):
        Trajectory.load(path)
    # and an object array in place of an entry of the format is refused by its dtype
    with np.load(thesis.save(tmp_path / "q.npz"), allow_pickle=False) as data:
        files = {k: np.array(data[k]) for k in data.files}
    files["theta"] = np.array([{"a": 1}] * thesis.t.size, dtype=object)
    np.savez(tmp_path / "q.npz", **files)
    with pytest.raises(ValueError, match="entry 'theta' must hold float64; got object"):
        Trajectory.load(tmp_path / "q.npz")


# --- runs of hybrid models: phases, contact series, switches ----------------------------------

_BALL = mett.TippeTop(m=0.006, R=0.015, alpha=0.2, I1=8e-7, I3=7e-7, mu=0.3)
_NEAR_TOUCHDOWN = State(theta=2.15, thetadot=2.0, phidot=110.0, omega3=-76.0, nu_y=0.16)


def _hybrid_runs():
    from mett.friction import Coulomb

    top = presets.get("rutstam2013")
    stick_slip = State.with_cm_at_rest(top, 0.1, 155.0)  # slides, sticks twice, slides on
    stemmed = _BALL.with_stem(radius=0.005, distance=0.016)
    return {
        "coulomb": (top, stick_slip, 0.8, {"friction": Coulomb(0.02)}),
        "coulomb, Taylor": (top, stick_slip, 0.8, {"friction": Coulomb(0.02), "backend": "taylor"}),
        "coulomb, scipy RK45": (top, stick_slip, 0.8, {"friction": Coulomb(0.02), "rtol": 1e-8,
                                                       "backend": "scipy", "method": "RK45"}),
        "stemmed": (stemmed, _NEAR_TOUCHDOWN, 1.0, {}),
        "stemmed, Coulomb": (stemmed, _NEAR_TOUCHDOWN, 1.0, {"friction": Coulomb(0.3)}),
    }  # fmt: skip


@pytest.mark.parametrize("case", list(_hybrid_runs()))
def test_a_hybrid_run_round_trips_with_its_phases_switches_and_contact_series(case, tmp_path):
    # these runs could not be saved before format 2 (the sliding equations were evaluated at the
    # rolling steps), or lost their phases, switches and touchdowns
    top, state, t_end, kw = _hybrid_runs()[case]
    traj = mett.simulate(top, state, t_end, **kw)
    assert traj.status == "completed" and len(traj.switches) >= 3, traj.switches
    loaded = Trajectory.load(traj.save(tmp_path / "h.npz"))
    assert_same_run(traj, loaded)
    assert loaded.extra == traj.extra and "phase" in traj.extra
    for name in traj.extra:
        want, got = np.asarray(getattr(traj, name)), np.asarray(getattr(loaded, name))
        nan = want.dtype.kind == "f"  # equal_nan works on numbers only (phase is text)
        assert got.dtype == want.dtype and np.array_equal(got, want, equal_nan=nan), name
    assert list(loaded.records) == list(traj.records)
    assert repr(loaded.switches) == repr(traj.switches)  # records (NaN margins compare by repr)
    assert [type(s) for s in loaded.switches] == [type(s) for s in traj.switches]
    assert len(loaded.jumps) == len(traj.jumps)
    for (a0, a1), (b0, b1) in zip(traj.jumps, loaded.jumps, strict=True):
        assert np.array_equal(a0, b0) and np.array_equal(a1, b1)
    if "touchdowns" in traj.records:
        assert np.array_equal(loaded.touchdowns, traj.touchdowns) and traj.touchdowns.size
    # the dense output phase by phase: equal bit for bit, or (RK45: Hermite) at the steps
    tt = np.linspace(0.0, t_end, 1001)
    if kw.get("method", "DOP853") == "DOP853":
        assert np.array_equal(loaded.states_at(tt), traj.states_at(tt))
        assert np.array_equal(loaded.crossings(1.0), traj.crossings(1.0))
    else:
        ts = np.asarray(traj._sol.ts)
        np.testing.assert_allclose(loaded.states_at(ts), traj.states_at(ts), rtol=0, atol=1e-13)
    # and saving the loaded run writes the same file content
    again = Trajectory.load(loaded.save(tmp_path / "h2.npz"))
    assert np.array_equal(again.states_at(tt), loaded.states_at(tt))
    assert repr(again.switches) == repr(loaded.switches)


def test_a_format_1_file_still_loads(tmp_path):
    # format 1 is format 2 without what a run sets beyond its states: made from the file of
    # format 2 that an older mett wrote (tests/data)
    with np.load(DATA / "format2_gliding.npz", allow_pickle=False) as data:
        files = {k: np.array(data[k]) for k in data.files if not k.startswith("extra_")}
    meta = json.loads(str(files["mett_trajectory"]))
    for key in ("extra", "per_sample"):
        meta.pop(key)
    meta["format_version"] = 1
    files["mett_trajectory"] = np.array(json.dumps(meta))
    path = tmp_path / "v1.npz"
    np.savez(path, **files)
    loaded = Trajectory.load(path)
    assert np.array_equal(loaded.states, files["states"]) and np.array_equal(loaded.t, files["t"])
    assert set(loaded.phase) == {"sliding"} and loaded.extra == ("phase",)
    assert loaded.records == {} and (loaded.rtol, loaded.atol, loaded.t_end) == (None, None, None)


# --- where and how a file is written -----------------------------------------------------------


def test_save_takes_the_longest_legal_file_name(thesis, tmp_path):
    # the temporary name is short, so a target name of the file system's limit works
    limit = os.pathconf(tmp_path, "PC_NAME_MAX")
    path = tmp_path / ("a" * (limit - len(".npz")) + ".npz")
    assert len(path.name.encode()) == limit
    assert thesis.save(path) == path
    assert_same_run(thesis, Trajectory.load(path))
    assert [p.name for p in tmp_path.iterdir()] == [path.name]  # no temporary left behind


@pytest.mark.parametrize("mode", [0o600, 0o640, 0o444 | 0o200])
def test_a_replaced_file_keeps_its_permission_bits(thesis, tmp_path, mode):
    path = thesis.save(tmp_path / "private.npz")
    path.chmod(mode)
    thesis.save(path)
    assert stat.S_IMODE(path.stat().st_mode) == mode
    # a new file gets the ordinary bits of a new file (0o666 under the umask)
    umask = os.umask(0)
    os.umask(umask)
    fresh = thesis.save(tmp_path / "fresh.npz")
    assert stat.S_IMODE(fresh.stat().st_mode) == 0o666 & ~umask


def test_save_through_a_symbolic_link_replaces_the_file_it_points_to(thesis, top, tmp_path):
    (tmp_path / "data").mkdir()
    real = thesis.save(tmp_path / "data" / "run.npz")
    link = tmp_path / "latest.npz"
    link.symlink_to(real)
    other = mett.simulate(top, State(theta=0.3, omega3=140.0), 0.1)
    assert other.save(link) == link
    assert link.is_symlink() and os.readlink(link) == str(real)  # still the same link
    assert_same_run(other, Trajectory.load(real))  # the file it points to was written
    assert sorted(p.name for p in (tmp_path / "data").iterdir()) == ["run.npz"]
    # a dangling link: the file is created where it points
    (tmp_path / "later.npz").symlink_to(tmp_path / "data" / "new.npz")
    other.save(tmp_path / "later.npz")
    assert_same_run(other, Trajectory.load(tmp_path / "data" / "new.npz"))


@pytest.mark.parametrize("where", ["writing", "renaming"])
def test_a_save_failing_midway_removes_its_temporary_file(thesis, tmp_path, monkeypatch, where):
    path = thesis.save(tmp_path / "keep.npz")
    before = path.read_bytes()

    def fail(*args, **kwargs):
        if where == "writing":
            args[0].write(b"PK partial")  # some bytes are on disk when it fails
        raise OSError(28, "No space left on device")

    if where == "writing":
        monkeypatch.setattr(np, "savez_compressed", fail)
    else:
        monkeypatch.setattr(os, "replace", fail)
    with pytest.raises(OSError, match="No space left"):
        thesis.save(path)
    monkeypatch.undo()
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["keep.npz"]


@pytest.mark.skipif(os.name != "posix" or os.geteuid() == 0, reason="needs a non-root POSIX user")
def test_save_refuses_a_read_only_directory_before_any_work(thesis, tmp_path):
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o500)
    try:
        with pytest.raises(ValueError, match="must be writable"):
            thesis.save(locked / "x.npz")
    finally:
        locked.chmod(0o700)
    assert list(locked.iterdir()) == []
