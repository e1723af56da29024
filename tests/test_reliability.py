"""Regression tests of the fault-tolerance rules (docs/reliability.md): one test per finding.

Bad input is refused before any work or write with a ValueError/TypeError naming the argument;
numerical trouble is a clean error or a status, never a raw OverflowError/ZeroDivisionError/
LinAlgError; a sweep never loses a row or touches a file that is not its checkpoint; warnings are
MettWarning subclasses reported at the caller's line.
"""

from __future__ import annotations

import json
import math
import warnings

import numpy as np
import pandas as pd
import pytest

import mett
from mett import _validate, analysis
from mett.sweeps import NOT_SETTLED, sweep

TOP = mett.presets.get("rutstam2013")


# --- State ---------------------------------------------------------------------------------------
def test_state_does_not_alias_the_callers_arrays():
    th = np.array([0.1, 0.2, 0.3])
    w3 = np.array([100.0, 120.0, 140.0])
    s = mett.State(theta=th, omega3=w3)
    th[:] = np.nan
    w3[0] = -1.0
    assert np.all(np.isfinite(s.theta)) and s.theta[0] == 0.1
    assert s.omega3[0] == 100.0
    with pytest.raises(ValueError):  # and the State's own arrays are read-only
        s.theta[0] = 3.0


@pytest.mark.parametrize("bad", ["0.1", b"0.1", True, None, 1j, ["0.1", 0.2]])
def test_state_refuses_non_numbers_with_type_error(bad):
    with pytest.raises(TypeError, match="theta must be"):
        mett.State(theta=bad)


# --- TippeTop ------------------------------------------------------------------------------------
def test_huge_radius_is_a_value_error_with_the_valid_range():
    with pytest.raises(ValueError, match=r"R must lie in \[1e-50, 1e\+50\] m; got 1e\+300"):
        TOP.replace(R=1e300)
    with pytest.raises(ValueError, match=r"R must lie in \[1e-50, 1e\+50\]"):
        mett.TippeTop.rational(m=0.02, R=1e300, alpha=0.3, I3=1e-6)


@pytest.mark.parametrize(("field", "bad"), [("m", "0.02"), ("R", True), ("mu", False), ("g", None)])
def test_top_refuses_strings_and_booleans(field, bad):
    with pytest.raises(TypeError, match=f"{field} must be a real number"):
        TOP.replace(**{field: bad})


def test_huge_I1_warns_at_the_callers_line():
    with pytest.warns(mett.PhysicalityWarning, match="I1 = .* exceeds") as record:
        TOP.replace(I1=1e6 * TOP.I3)
    assert record[0].filename == __file__


def test_physical_tops_do_not_warn():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for name in ("rutstam2013", "rutstam2012", "cohen1977", "ueda2005"):
            mett.presets.get(name)
        # γ up to 1 + α (group III) is still a physical body
        TOP.replace(I1=1.3 * TOP.I3)


# --- presets -------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("kw", "message"),
    [
        ({"R": 0}, r"R must lie in \[1e-50, 1e\+50\] m; got 0.0"),
        ({"R": 0, "a": 0.006}, r"R must lie in"),
        ({"m": -1.0}, r"m must lie in"),
        ({"a": 0.5}, r"a = alpha\*R must lie in \(0, R\)"),
    ],
)
def test_preset_overrides_are_checked_before_use(kw, message):
    with pytest.raises(ValueError, match=message):
        mett.presets.get("rutstam2013", **kw)


def test_preset_physicality_warning_points_at_the_caller():
    with pytest.warns(mett.PhysicalityWarning, match="exceeds m R") as record:
        mett.presets.get("maple-tippe-top", alpha=0.3)
    assert record[0].filename == __file__


def test_warn_refuses_foreign_categories_and_attributes_to_the_caller():
    with pytest.raises(TypeError, match="MettWarning subclass"):
        _validate.warn("x", UserWarning)
    with pytest.warns(mett.MettWarning) as record:
        _validate.warn("from the test")
    assert record[0].filename == __file__
    assert issubclass(_validate.AccuracyWarning, mett.MettWarning)


# --- integrals, asymptotics, stability ------------------------------------------------------------
def test_energy_at_huge_spin_is_a_value_error_not_overflow():
    s = mett.State(theta=0.1, omega3=1e155)
    for fn in (mett.energy, mett.modified_energy):
        with pytest.raises(ValueError, match=r"state: the .*energy overflows .*omega3 = 1e\+155"):
            fn(TOP, s)
    # λ and D are representable there, and exact: linear in ω3
    lam = float(mett.jellett(TOP, s))
    assert lam == pytest.approx(1e155 * float(mett.jellett(TOP, mett.State(theta=0.1, omega3=1))))
    assert math.isfinite(float(mett.routh(TOP, s)))


def test_integrals_refuse_wrong_argument_types():
    with pytest.raises(TypeError, match="state must be a State"):
        mett.energy(TOP, [0.1, 0, 0, 155, 0, 0])
    with pytest.raises(TypeError, match="top must be a TippeTop"):
        mett.jellett("rutstam2013", mett.State(theta=0.1))


def test_high_spin_at_tiny_spin_is_a_value_error():
    with pytest.raises(ValueError, match=r"omega3 = 1e-300 .* outside double precision"):
        mett.high_spin(TOP, math.pi / 2, 1e-300)
    # the scaling laws hold wherever the result is finite: width ∝ ω3⁻², frequency ∝ ω3
    a, b = mett.high_spin(TOP, 1.0, 1e3), mett.high_spin(TOP, 1.0, 1e9)
    assert b.width == pytest.approx(a.width * 1e-12, rel=1e-12)
    assert b.frequency == pytest.approx(a.frequency * 1e6, rel=1e-12)


def test_spin_eigenvalues_at_tiny_lambda_are_the_continuous_limit():
    for pole in ("inverted", "upright"):
        tiny = mett.spin_eigenvalues(TOP, 1e-300, pole)
        small = mett.spin_eigenvalues(TOP, 1e-13, pole)
        assert np.all(np.isfinite(tiny))
        np.testing.assert_allclose(np.sort_complex(tiny), np.sort_complex(small), atol=1e-4)
    # without spin the inverted top (CM above the contact) falls: a positive real eigenvalue
    assert mett.spin_eigenvalues(TOP, 1e-300, "inverted")[0].real > 1.0
    with pytest.raises(ValueError, match="lam = 1e\\+300 is too large"):
        mett.spin_eigenvalues(TOP, 1e300)


# --- period_comparison ----------------------------------------------------------------------------
@pytest.fixture(scope="module")
def short_runs():
    s = mett.State(theta=0.1, omega3=155.0)
    return (
        mett.simulate(TOP, s, t_end=1.0),
        mett.simulate(TOP, mett.State(theta=0.1, omega3=-155.0), t_end=1.0),
        mett.simulate(TOP, s, t_end=1.0, t_eval=[0.0, 1.0]),
    )


def test_period_comparison_of_the_mirror_image_top_equals_the_original(short_runs):
    plain, mirror, _ = short_runs
    assert float(mirror.lam[0]) < 0
    a, b = analysis.period_comparison(plain), analysis.period_comparison(mirror)
    assert a.t.size > 10 and a.t.size == b.t.size
    np.testing.assert_allclose(b.observed, a.observed, rtol=1e-7)
    np.testing.assert_allclose(b.rolling, a.rolling, rtol=1e-7)
    assert b.estimates == pytest.approx(a.estimates, rel=1e-9)


def test_period_comparison_on_a_two_sample_run_uses_the_dense_output(short_runs):
    plain, _, two = short_runs
    assert two.t.size == 2
    a, b = analysis.period_comparison(plain), analysis.period_comparison(two)
    np.testing.assert_allclose(b.observed, a.observed, rtol=1e-9)


def test_period_comparison_without_two_maxima_is_empty():
    one = mett.simulate(TOP, mett.State(theta=0.1, omega3=155.0), t_end=1e-3)
    res = analysis.period_comparison(one)
    assert res.t.size == res.observed.size == res.rolling.size == 0
    assert res.estimates.T_D0 > 0
    with pytest.raises(TypeError, match=r"traj must be a mett\.Trajectory"):
        analysis.period_comparison(TOP)


# --- sweeps ---------------------------------------------------------------------------------------
def _tiny(**kw):
    return sweep(TOP, {"mu": [0.3]}, t_end=0.05, progress=False, **kw)


@pytest.mark.parametrize(
    "content",
    [b"my notes\nsecond line without newline", b"PK\x03\x04\x00binary npz\xff\xfe", b"[1, 2]\n"],
)
def test_checkpoint_never_modifies_a_file_that_is_not_one(tmp_path, content):
    path = tmp_path / "notes.txt"
    path.write_bytes(content)
    with pytest.raises(ValueError, match="is not a mett sweep checkpoint; it was left untouched"):
        _tiny(checkpoint=path)
    assert path.read_bytes() == content


def test_damaged_checkpoint_record_names_path_and_line(tmp_path):
    path = tmp_path / "ckpt.jsonl"
    sweep(TOP, {"mu": [0.2, 0.3, 0.4]}, t_end=0.05, progress=False, checkpoint=path)
    lines = path.read_text().splitlines()
    lines[2] = lines[2][:20] + "#" + lines[2][21:]
    damaged = "\n".join(lines) + "\n"
    path.write_text(damaged)
    with pytest.raises(ValueError, match=f"{path}, line 3: damaged checkpoint record"):
        sweep(TOP, {"mu": [0.2, 0.3, 0.4]}, t_end=0.05, progress=False, checkpoint=path)
    assert path.read_text() == damaged


@pytest.mark.parametrize(
    ("kw", "error", "message"),
    [
        ({"rtol": 2.0}, ValueError, r"rtol must lie in"),
        ({"model": "nope"}, ValueError, "unknown model 'nope'"),
        ({"bogus": 1}, TypeError, "bogus"),
        ({"chunksize": -1}, ValueError, "chunksize must be an integer >= 1"),
        ({"chunksize": 2.5}, TypeError, "chunksize must be an integer"),
        ({"progress": "yes"}, TypeError, "progress must be True or False"),
        ({"executor": "pool"}, TypeError, "executor must be a concurrent.futures.Executor"),
        ({"t_eval": [0.0, 5.0]}, ValueError, "t_eval must be"),
    ],
)
def test_bad_sweep_options_are_refused_before_any_write(tmp_path, kw, error, message):
    path = tmp_path / "ckpt.jsonl"
    with pytest.raises(error, match=message):
        sweep(TOP, {"mu": [0.2, 0.3]}, t_end=0.05, checkpoint=path, **{"progress": False, **kw})
    assert not path.exists()


def test_checkpoint_paths_are_checked_before_any_run(tmp_path, monkeypatch):
    calls = []
    monkeypatch.setattr(mett.dynamics, "simulate", lambda *a, **k: calls.append(a))
    with pytest.raises(ValueError, match=r"directory .* does not exist"):
        _tiny(checkpoint=tmp_path / "missing" / "c.jsonl")
    with pytest.raises(ValueError, match="must be a file, not a directory"):
        _tiny(checkpoint=tmp_path)
    assert calls == []


@pytest.mark.parametrize("backend", ["compiled", "taylor"])
def test_a_point_whose_simulation_raises_is_a_row_and_the_sweep_goes_on(monkeypatch, backend):
    import mett.dynamics.batch as batch

    real = batch.run_prepared

    def flaky(prep):
        if prep.run.top.mu == 0.4:
            raise RuntimeError("solver exploded")
        return real(prep)

    monkeypatch.setattr(batch, "run_prepared", flaky)
    # the Taylor backend runs several points at once: its failing point is one of the batch
    taylor = batch.REGISTRY["taylor"]
    real_batchable = taylor.batchable
    monkeypatch.setattr(taylor, "batchable", lambda p: p.run.top.mu != 0.4 and real_batchable(p))
    table = sweep(TOP, {"mu": [0.3, 0.4, 0.5]}, t_end=0.05, progress=False, backend=backend)
    assert list(table["status"]) == ["completed", "error", "completed"]
    assert table["message"].iloc[1] == "RuntimeError: solver exploded"
    assert table["simulated"].iloc[1] == "error" and math.isnan(table["theta_end"].iloc[1])
    assert table["lam"].iloc[1] == pytest.approx(table["lam"].iloc[0])  # start values kept


def test_a_failing_prediction_keeps_the_simulated_row(monkeypatch):
    import mett.classification

    def broken(top, lam):
        raise ValueError("no tumbling state here")

    monkeypatch.setattr(mett.classification, "asymptotic_state", broken)
    monkeypatch.setattr(mett.sweeps, "_PREDICTED", {})  # nothing remembered from other sweeps
    table = _tiny()
    row = table.iloc[0]
    assert row["status"] == "completed" and row["predicted"] == "error"
    assert "asymptotic_state: ValueError: no tumbling state here" in row["message"]
    assert math.isfinite(row["theta_end"])


def test_folded_tumbling_family_points_do_not_kill_the_sweep():
    # the docs example's γ = 0.75 column (α = 0.3), where the tumbling family folds: at λ = λ_thres
    # asymptotic_state raised, and the sweep with it
    table = sweep(TOP, {"lam_ratio": [0.2, 1.0], "gamma": [0.75]}, t_end=0.5, progress=False)
    assert len(table) == 2 and list(table["status"]) == ["completed", "completed"]
    assert set(table["simulated"]) <= {"upright", "tumbling", "inverted", NOT_SETTLED}
    # γ = 0.75 (class IIb): both the upright spin and a tumbling state are stable at λ_thres
    assert set(table["predicted"]) <= {"upright", "tumbling", "inverted", "bistable"}
    assert np.all(np.isfinite(table["theta_end"]))


def test_unsettled_run_is_labelled_not_settled():
    # λ = 2 λ_thres inverts in ~6 s; after 0.5 s the top is still near θ0 = 0.1
    table = sweep(TOP, {"lam_ratio": [2.0]}, t_end=0.5, progress=False)
    assert table["theta_end"].iloc[0] < 0.2
    assert table["simulated"].iloc[0] == NOT_SETTLED and not table["agree"].iloc[0]


def test_progress_defaults_to_off_when_stderr_is_not_a_terminal(capsys):
    pytest.importorskip("tqdm")
    sweep(TOP, {"mu": [0.3]}, t_end=0.05)
    assert "sweep" not in capsys.readouterr().err


# --- validators ----------------------------------------------------------------------------------
def test_validators():
    assert _validate.boolean("flag", np.True_) is True
    for bad in ("no", 0, None):
        with pytest.raises(TypeError, match="flag must be True or False"):
            _validate.boolean("flag", bad)
    assert _validate.positive_int("n", np.int64(3)) == 3
    with pytest.raises(TypeError):
        _validate.positive_int("n", True)
    with pytest.raises(ValueError, match="n must be an integer >= 1; got 0"):
        _validate.positive_int("n", 0)
    with pytest.raises(TypeError, match="x must be a real number"):
        _validate.finite_scalar("x", "1.0")
    with pytest.raises(TypeError, match="single real number"):
        _validate.finite_scalar("x", np.array([1.0, 2.0]))
    with pytest.raises(ValueError, match="rectangular"):
        _validate.as_finite_array("x", [[1.0], [1.0, 2.0]])
    with pytest.raises(ValueError, match="empty string"):
        _validate.output_path("out", "")
    with pytest.raises(TypeError, match="out must be a path"):
        _validate.output_path("out", 3)
    assert json.loads(json.dumps(_validate.finite_scalar("x", np.float32(0.5)))) == 0.5


def test_escape_time_of_an_absurd_state_is_a_value_error_without_warnings():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(ValueError, match="not near the upright spin"):
            mett.escape_time(TOP, mett.State(theta=3.125, thetadot=1e300, omega3=-15.0))
        est = mett.escape_time(TOP, mett.State(theta=0.1, omega3=155.0))
    assert 0 < est.amplitude < 1 and est.time > 0


def test_progress_without_tqdm_is_refused_before_the_checkpoint_is_written(tmp_path, monkeypatch):
    import importlib.util

    real = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util, "find_spec", lambda name, *a: None if name == "tqdm" else real(name, *a)
    )
    path = tmp_path / "c.jsonl"
    with pytest.raises(ValueError, match=r"progress=True needs tqdm"):
        sweep(TOP, {"mu": [0.3]}, t_end=0.05, progress=True, checkpoint=path)
    assert not path.exists()


class _OneChunkFails:
    """An executor (serial) whose second task fails, as if its worker had died."""

    def __init__(self) -> None:
        self.n = 0

    def submit(self, fn, *args):
        from concurrent.futures import Future

        fut: Future = Future()
        self.n += 1
        if self.n == 2:
            fut.set_exception(RuntimeError("worker died"))
        else:
            fut.set_result(fn(*args))
        return fut


def test_a_failed_executor_task_keeps_every_other_row_in_the_checkpoint(tmp_path):
    path = tmp_path / "c.jsonl"
    grid = {"mu": [0.2, 0.3, 0.4]}
    with pytest.raises(RuntimeError, match="worker died"):
        sweep(TOP, grid, t_end=0.05, progress=False, checkpoint=path, executor=_OneChunkFails(),
              chunksize=1)  # fmt: skip
    records = [json.loads(line) for line in path.read_text().splitlines()[1:]]
    assert sorted(r["index"] for r in records) == [0, 2]  # the failed chunk is not recorded
    resumed = sweep(TOP, grid, t_end=0.05, progress=False, checkpoint=path)
    fresh = sweep(TOP, grid, t_end=0.05, progress=False)
    pd.testing.assert_frame_equal(resumed, fresh)


def test_sweep_accepts_numpy_option_values():
    atol = np.full(10, 1e-12)
    table = sweep(TOP, {"mu": [0.3]}, t_end=0.05, progress=False, atol=atol, rtol=np.float64(1e-9))
    assert list(table["status"]) == ["completed"]


# --- fuzz findings fixed at the source (tests/test_fuzz.py's known-failure list) -----------------
def _thesis_run() -> mett.Trajectory:
    return mett.simulate(TOP, mett.State(theta=0.1, omega3=155.0), 0.3)


@pytest.mark.parametrize(
    "call",
    [
        lambda t: mett.boundary_values(t, 1e-5),
        lambda t: mett.tumbling_state(t, 1e-5),
        lambda t: mett.asymptotic_state(t, 1e-5),
        lambda t: mett.min_spin_for_inversion(t, 0.1),
        lambda t: mett.period_estimates(t, 1e-5),
        lambda t: mett.potential_minimum(t, 1e-5, 1e-5),
        lambda t: mett.subgroup(t),
        lambda t: mett.tumbling_eigenvalues(t, 1.0),
        lambda t: mett.thresholds.pole_spins(t, 1e-5),
    ],
)
@pytest.mark.parametrize("not_a_top", [None, "rutstam2013", 1.0])
def test_a_top_that_is_not_a_tippe_top_is_a_type_error(call, not_a_top):
    with pytest.raises(TypeError, match="top must be a TippeTop"):
        call(not_a_top)


@pytest.mark.parametrize(
    "call",
    [
        analysis.mett_residual,
        lambda tr: analysis.deforming_potential(tr, [0.1]),
        analysis.minimum_track,
        analysis.theta_extrema,
        analysis.period_comparison,
    ],
)
def test_a_traj_that_is_not_a_trajectory_is_a_type_error(call):
    with pytest.raises(TypeError, match="traj must be a"):
        call(None)


def test_boundary_values_refuse_a_lambda_whose_energy_overflows():
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # and no numpy RuntimeWarning on the way
        with pytest.raises(ValueError, match=r"\|lam\| must be at most 2.37e\+149 .* got 1e\+155"):
            mett.boundary_values(TOP, 1e155)
        with pytest.raises(ValueError, match="got -1e\\+300"):
            mett.boundary_values(TOP, [1e-5, -1e300])
        # just inside the stated bound every value is finite, and E0 = λ²/(2 I3 R² (1 − α)²) + …
        lam = 2.3e149
        bv = mett.boundary_values(TOP, lam)
    assert all(np.isfinite(v) for v in bv)
    a = TOP.alpha
    expected = lam**2 / (2 * TOP.I3 * TOP.R**2 * (1 - a) ** 2) + TOP.m * TOP.g * TOP.R * (1 - a)
    assert float(bv.E0) == pytest.approx(expected, rel=1e-14)


def test_tumbling_state_and_asymptotic_state_at_huge_lambda():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        # above λ_thres the thesis top has no tumbling state, however large λ is
        assert mett.tumbling_state(TOP, 1e155) is None
        assert mett.tumbling_state(TOP, 1e300) is None
        # ω3 = −λ/(R I3 (1 + α)) is finite at 1e300 for the thesis top: a correct answer ...
        st = mett.asymptotic_state(TOP, 1e300)
        assert st.kind == "inverted"
        assert st.omega3 == pytest.approx(-1e300 / (TOP.R * TOP.I3 * (1 + TOP.alpha)), rel=1e-15)
        # ... and refused where it would overflow (a small top)
        small = mett.TippeTop(0.015625, 0.005859375, 0.5, 5.364418029785156e-07, 5.36e-07)
        with pytest.raises(ValueError, match=r"lam must be at most .* omega3 overflows"):
            mett.asymptotic_state(small, 1e300)


def test_period_estimates_are_one_over_lambda_down_to_the_float_range():
    ref = mett.period_estimates(TOP, 6.8944e-6)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for lam in (1e-300, 1e300):
            est = mett.period_estimates(TOP, lam)
            assert est.T_D0 == pytest.approx(ref.T_D0 * 6.8944e-6 / lam, rel=1e-13)
            assert est.T_D1 == pytest.approx(ref.T_D1 * 6.8944e-6 / lam, rel=1e-13)
        with pytest.raises(ValueError, match=r"lam must be at least .* got 5e-324"):
            mett.period_estimates(TOP, 5e-324)


@pytest.mark.parametrize("sub", [0, -1, 10_001, 10**9])
def test_theta_extrema_subdivision_is_bounded(sub):
    tr = _thesis_run()
    with pytest.raises(ValueError, match=r"subdivision must be an integer (in \[1, 10000\]|>= 1)"):
        analysis.theta_extrema(tr, subdivision=sub)
    with pytest.raises(TypeError, match="subdivision must be an integer"):
        analysis.theta_extrema(tr, subdivision=1e300)


def test_theta_extrema_in_blocks_equals_one_evaluation(monkeypatch):
    """Blocks of the dense output (the memory bound) find the same extrema as one grid."""
    tr = _thesis_run()
    whole = analysis.theta_extrema(tr, subdivision=16)
    monkeypatch.setattr(analysis, "_BLOCK_POINTS", 37)  # many blocks, boundaries everywhere
    blocked = analysis.theta_extrema(tr, subdivision=16)
    assert whole.t.size > 4
    np.testing.assert_array_equal(blocked.kind, whole.kind)
    np.testing.assert_allclose(blocked.t, whole.t, rtol=0, atol=1e-12)
    # θ̇ vanishes at each one (independent check on the dense output)
    assert np.max(np.abs(tr.at(blocked.t).thetadot)) < 1e-8


def test_deforming_potential_accepts_a_scalar_z():
    tr = _thesis_run()
    z, V, theta = analysis.deforming_potential(tr, 0.1, 0.5)
    assert z.shape == (1,) and V.shape == (1, 1) and theta.shape == (1,)
    z2, V2, _ = analysis.deforming_potential(tr, [0.1], [0.5, 0.5])
    assert V[0, 0] == V2[0, 0] == V2[0, 1]
    with pytest.raises(ValueError, match=r"z = cos\(theta\) must lie in \[-1, 1\]"):
        analysis.deforming_potential(tr, 0.1, 2.0)
    with pytest.raises(ValueError, match="z must be a scalar or 1-D array"):
        analysis.deforming_potential(tr, 0.1, np.zeros((2, 2)))


@pytest.mark.parametrize("field", ["omega3", "thetadot", "phidot", "nu_x", "nu_y"])
@pytest.mark.parametrize("value", [1e155, -1e300])
def test_simulate_refuses_absurd_state_rates_naming_the_field(field, value):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(ValueError, match=f"state.{field} must lie in"):
            mett.simulate(TOP, mett.State(theta=0.1, **{field: value}), 0.01)


def test_simulate_rate_bound_is_relative_to_the_tops_natural_rate():
    rate = math.sqrt(TOP.g / TOP.R)
    bound = mett.dynamics.simulation.RATE_MAX * rate
    with pytest.raises(ValueError, match=r"state\.omega3"):
        mett.simulate(TOP, mett.State(theta=0.1, omega3=1.01 * bound), 1e-6)
    # just inside: a clean run (the normal force at this spin is negative: contact lost at once)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        tr = mett.simulate(TOP, mett.State(theta=0.1, omega3=0.99 * bound), 1e-6)
    assert tr.status in ("completed", "contact_lost", "failed") and tr.message


def test_simulate_refuses_a_max_step_beyond_the_step_budget_before_any_work():
    s = mett.State(theta=0.1, omega3=155.0)
    t_end = 0.01
    limit = t_end / mett.dynamics.simulation.MAX_STEPS
    for backend in ("compiled", "scipy"):
        with pytest.raises(ValueError, match="max_step must be at least t_end / MAX_STEPS"):
            mett.simulate(TOP, s, t_end, max_step=0.5 * limit, backend=backend)
    with pytest.raises(TypeError, match="max_step must be a real number"):
        mett.simulate(TOP, s, t_end, max_step="1e-3")
    tr = mett.simulate(TOP, s, t_end, max_step=1e-4)  # ordinary values still run
    assert tr.status == "completed" and np.max(np.diff(tr.t)) <= 1e-4 * (1 + 1e-12)


_POTENTIAL_CALLS = {
    "d": lambda t: mett.d(t, 0.3),
    "g": lambda t: mett.g(t, 0.3),
    "V": lambda t: mett.V(t, 0.3, 1e-4, 1e-5),
    "V_rational": lambda t: mett.V_rational(t, 0.3, 1e-4, 1e-5),
    "dV_dz": lambda t: mett.dV_dz(t, 0.3, 1e-4, 1e-5),
    "d2V_dz2": lambda t: mett.d2V_dz2(t, 0.3, 1e-4, 1e-5),
    "f": lambda t: mett.f(t, 0.3, 0.01, 1e-4, 1e-5),
    "band": lambda t: mett.band(t, 0.01, 1e-4, 1e-5),
    "turning_points": lambda t: mett.turning_points(t, 0.01, 1e-4, 1e-5),
    "nutation_period": lambda t: mett.nutation_period(t, 0.01, 1e-4, 1e-5),
    "mean_precession": lambda t: mett.mean_precession(t, 0.01, 1e-4, 1e-5),
    "classify_motion": lambda t: mett.classify_motion(t, 0.01, 1e-4, 1e-5),
}


@pytest.mark.parametrize("name", list(_POTENTIAL_CALLS))
def test_potential_and_separation_refuse_a_top_that_is_not_a_tippe_top(name):
    with pytest.raises(TypeError, match="top must be a TippeTop; got NoneType"):
        _POTENTIAL_CALLS[name](None)


def test_integral_bounds_are_the_top_natural_scales():
    rate = math.sqrt(TOP.g / TOP.R)
    big = mett.potential.INTEGRAL_MAX
    D_max, lam_max = big * TOP.I3 * rate, big * TOP.R * TOP.I3 * rate
    E_max = big**2 * max(TOP.m * TOP.g * TOP.R, TOP.I3 * TOP.g / TOP.R)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no numpy RuntimeWarning either
        for fn in (mett.V, mett.dV_dz, mett.V_rational):
            with pytest.raises(ValueError, match=r"D must lie in \[-.*\] kg m\^2/s .* got 1e\+155"):
                fn(TOP, 0.3, 1e155, 1e-5)
            with pytest.raises(ValueError, match=r"lam must lie in .* kg m\^3/s .* got -1e\+300"):
                fn(TOP, 0.3, 1e-4, [1e-5, -1e300])
        for fn in (mett.band, mett.nutation_period, mett.turning_points, mett.classify_motion):
            with pytest.raises(ValueError, match=r"E must lie in .* J .* got 1e\+300"):
                fn(TOP, 1e300, 1e-4, 1e-5)
        with pytest.raises(ValueError, match="E must lie in"):
            mett.f(TOP, 0.3, -1e300, 1e-4, 1e-5)
        with pytest.raises(ValueError, match="lam must lie in"):
            mett.potential_minimum(TOP, 1e-4, 1e155)
        # at the bounds themselves V is finite and equals its closed form (interior z)
        z = 0.3
        v = float(mett.V(TOP, z, D_max, lam_max))
        n = lam_max * math.sqrt(float(mett.d(TOP, z))) + TOP.R * D_max * (TOP.alpha - z)
        expected = (
            TOP.m * TOP.g * TOP.R * (1 - TOP.alpha * z)
            + TOP.I3 / (2 * TOP.I1**2 * TOP.R**2) * n * n / (1 - z * z)
            + D_max**2 / (2 * TOP.I1)
            - TOP.m * lam_max**2 / (2 * TOP.I1 * TOP.I3)
        )
        assert math.isfinite(v) and v == pytest.approx(expected, rel=1e-12)
        assert np.all(np.isfinite(mett.f(TOP, [0.0, 0.3], E_max, D_max, lam_max)))


def test_tiny_integrals_give_finite_answers_without_warnings():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for tiny in (5e-324, -1e-300):
            assert np.all(np.isfinite(mett.V(TOP, [-0.5, 0.0, 0.5], tiny, tiny)))
            assert np.all(np.isfinite(mett.dV_dz(TOP, [-0.5, 0.0, 0.5], tiny, tiny)))
            assert mett.classify_motion(TOP, 0.01, tiny, tiny) in ("nutation", "steady", "none")


def test_dV_dz_on_a_grid_through_z_zero_has_no_warning():
    z = np.linspace(-0.9, 0.9, 7)  # contains 0 exactly
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        dv = mett.dV_dz(TOP, z, 1e-4, 1e-5)
    # against a central difference of V
    h = 1e-6
    fd = (mett.V(TOP, z + h, 1e-4, 1e-5) - mett.V(TOP, z - h, 1e-4, 1e-5)) / (2 * h)
    np.testing.assert_allclose(dv, fd, rtol=1e-6, atol=1e-9)
