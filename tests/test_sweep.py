"""Parameter sweeps: executors, checkpoint/resume (incl. SIGKILL), end states, the CLI."""

from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
import textwrap
import time
import warnings
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import pandas as pd
import pytest
from test_cli import assert_one_line_error

import mett
from mett.sweeps import sweep

TOP = mett.presets.get("rutstam2013")
CHEAP = {"mu": [0.2, 0.4], "omega3": [120.0, 160.0]}  # 2 s runs: quick, still nontrivial


def _cheap(**kw):
    return sweep(TOP, CHEAP, t_end=2.0, **kw)


def test_serial_table_has_one_row_per_point_in_grid_order():
    table = _cheap()
    assert len(table) == 4
    assert list(table["mu"]) == [0.2, 0.2, 0.4, 0.4]
    assert list(table["omega3"]) == [120.0, 160.0, 120.0, 160.0]
    for col in ("t_invert", "status", "theta_end", "omega3_end", "lam", "lam_ratio", "predicted",
                "simulated", "agree"):  # fmt: skip
        assert col in table
    # each row is the simulation it claims to be
    row = table.iloc[3]
    traj = mett.simulate(TOP.replace(mu=0.4), mett.State(theta=0.1, omega3=160.0), t_end=2.0)
    assert row["theta_end"] == traj.theta[-1]
    assert row["lam"] == pytest.approx(float(traj.lam[0]), rel=1e-12)


def test_process_pool_gives_the_identical_table():
    serial = _cheap()
    with ProcessPoolExecutor(max_workers=2) as pool:
        parallel = _cheap(executor=pool, chunksize=1)
    pd.testing.assert_frame_equal(serial, parallel)


def test_dask_gives_the_identical_table():
    distributed = pytest.importorskip("distributed")
    serial = _cheap()
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None
    ) as cluster, distributed.Client(cluster) as client:  # fmt: skip
        dask_table = _cheap(executor=client.get_executor())
    pd.testing.assert_frame_equal(serial, dask_table)


def test_end_states_agree_with_prediction_across_all_three_kinds():
    # λ/λ_thres: below λ_0 (0.36 λ_thres), between λ_0 and λ_thres, above λ_thres
    table = sweep(TOP, {"lam_ratio": [0.288, 0.68, 2.0]}, t_end=25.0)
    assert list(table["predicted"]) == ["upright", "tumbling", "inverted"]
    assert table["agree"].all(), table[["lam_ratio", "theta_end", "simulated"]]


def test_checkpoint_resume_skips_finished_points(tmp_path):
    path = tmp_path / "ckpt.jsonl"
    first = _cheap(checkpoint=path)
    lines = path.read_text().splitlines()
    assert len(lines) == 5 and json.loads(lines[0])["mett_sweep"] == 3
    mtime = path.stat().st_mtime_ns
    again = _cheap(checkpoint=path)  # nothing left to run: read back, file untouched
    pd.testing.assert_frame_equal(first, again)
    assert path.stat().st_mtime_ns == mtime or len(path.read_text().splitlines()) == 5


def test_checkpoint_for_other_arguments_is_refused(tmp_path):
    path = tmp_path / "ckpt.jsonl"
    _cheap(checkpoint=path)
    with pytest.raises(ValueError, match="written for different sweep arguments"):
        sweep(TOP, CHEAP, t_end=3.0, checkpoint=path)
    with pytest.raises(ValueError, match="written for different sweep arguments"):
        sweep(TOP.replace(alpha=0.31), CHEAP, t_end=2.0, checkpoint=path)


def test_sweep_killed_with_sigkill_resumes_without_loss_or_duplicates(tmp_path):
    # the scipy backend keeps each point slow enough (~0.3 s) to be killed in the middle
    path = tmp_path / "ckpt.jsonl"
    grid = {"mu": [0.2, 0.3, 0.4], "omega3": [120.0, 160.0]}
    script = textwrap.dedent(
        f"""
        import mett
        from mett.sweeps import sweep
        top = mett.presets.get("rutstam2013")
        sweep(top, {grid!r}, t_end=2.0, checkpoint={str(path)!r}, backend="scipy")
        """
    )
    proc = subprocess.Popen([sys.executable, "-c", script])
    try:
        deadline = time.time() + 120
        while time.time() < deadline:  # wait for two finished points (plus the header)
            if path.exists() and len(path.read_bytes().split(b"\n")) >= 4:
                break
            time.sleep(0.05)
        else:
            pytest.fail("the sweep wrote no checkpoint lines")
        os.kill(proc.pid, signal.SIGKILL)
    finally:
        proc.wait(timeout=60)
    n_before = len([ln for ln in path.read_text().splitlines()[1:] if ln.strip()])
    assert 2 <= n_before < 6  # killed in the middle
    resumed = sweep(TOP, grid, t_end=2.0, checkpoint=path, backend="scipy")
    fresh = sweep(TOP, grid, t_end=2.0, backend="scipy")
    pd.testing.assert_frame_equal(resumed, fresh)
    records = [json.loads(ln) for ln in path.read_text().splitlines()[1:]]
    indices = [r["index"] for r in records]
    assert sorted(indices) == list(range(6))  # nothing lost, nothing duplicated


def test_partial_last_line_is_discarded(tmp_path):
    path = tmp_path / "ckpt.jsonl"
    full = _cheap(checkpoint=path)
    text = path.read_text().splitlines()
    # simulate a kill in the middle of writing the last record
    path.write_text("\n".join(text[:-1]) + "\n" + text[-1][: len(text[-1]) // 2])
    resumed = _cheap(checkpoint=path)
    pd.testing.assert_frame_equal(full, resumed)
    assert len(path.read_text().splitlines()) == 5


def test_progress_bar_counts_points(capsys):
    pytest.importorskip("tqdm")
    _cheap(progress=True)
    err = capsys.readouterr().err
    assert "4/4" in err


@pytest.mark.parametrize(
    ("grid", "kw", "message"),
    [
        ({"spin": [1.0]}, {}, r"unknown grid name\(s\) \['spin'\]"),
        ({}, {}, "non-empty mapping"),
        ({"mu": [[0.1, 0.2]]}, {}, "non-empty 1-D array"),
        ({"mu": [np.nan]}, {}, "mu must be finite"),
        ({"gamma": [0.9], "I1": [3e-6]}, {}, "gamma or I1"),
        ({"mu": [0.1]}, {"t_end": -1.0}, r"t_end must lie in \(0, inf\)"),
    ],
)
def test_bad_sweeps_raise(grid, kw, message):
    with pytest.raises(ValueError, match=message):
        sweep(TOP, grid, **{"t_end": 1.0, **kw})


def test_inadmissible_points_are_recorded_not_raised():
    table = sweep(TOP, {"alpha": [0.3, 1.5]}, t_end=0.5)
    assert list(table["status"]) == ["completed", "invalid"]
    assert "alpha must lie in (0, 1)" in table["message"].iloc[1]


def test_cli_sweep_writes_csv(tmp_path):
    out = tmp_path / "s.csv"
    res = subprocess.run(
        [sys.executable, "-m", "mett", "sweep", "--preset", "rutstam2013", "--grid", "mu=0.2:0.4:2",
         "--t-end", "1", "--out", str(out)],
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert res.returncode == 0, res.stderr
    table = pd.read_csv(out, comment="#")  # the sweep's settings are # lines
    assert list(table["mu"]) == [0.2, 0.4] and "2 runs" in res.stdout


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["--grid", "mu=0.1:0.2"], "not one of the forms; give mu=START:STOP:NUM"),
        (["--grid", "mu=a:b:2"], "START and STOP must be numbers"),
        (["--grid", "spin=1:2:2"], "unknown grid name"),
    ],
)
def test_cli_sweep_bad_grid(args, needle):
    res = subprocess.run(
        [sys.executable, "-m", "mett", "sweep", "--preset", "rutstam2013", "--t-end", "1", *args],
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert_one_line_error(res, needle)


def test_cli_scheduler_without_dask_names_the_extra():
    # hide distributed as if `mett[dask]` were not installed
    code = (
        "import sys; sys.modules['distributed'] = None; from mett.cli import main; "
        "sys.exit(main(['sweep', '--preset', 'rutstam2013', '--grid', 'mu=0.1:0.2:2', "
        "'--t-end', '1', '--scheduler', 'tcp://127.0.0.1:1']))"
    )
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert_one_line_error(res, "pip install 'mett[dask]'")


def test_taylor_sweep_runs_points_side_by_side_with_the_results_of_one_at_a_time():
    # 7 points: one full SIMD batch of 4 and a padded one of 3, runs that lose contact, invert and
    # stay upright; the batched table equals the table of the same points run one per task
    grid = {"mu": [0.05, 0.3, 0.5], "omega3": [60.0, 155.0], "theta0": [0.1]}
    grid2 = {"mu": [0.3], "omega3": [155.0], "theta0": [3.0]}
    kw = dict(t_end=8.0, backend="taylor", rtol=1e-12, progress=False)
    batched = pd.concat([sweep(TOP, grid, **kw), sweep(TOP, grid2, **kw)], ignore_index=True)
    single = pd.concat(
        [sweep(TOP, grid, chunksize=1, **kw), sweep(TOP, grid2, chunksize=1, **kw)],
        ignore_index=True,
    )
    pd.testing.assert_frame_equal(batched, single)
    assert {"contact_lost", "completed"} <= set(batched["status"])
    assert len(set(batched["simulated"])) >= 3  # upright, tumbling, not settled, contact_lost
    # and each row is its own simulate call on the Taylor backend (one by one, dense output)
    for _, row in batched.iterrows():
        traj = mett.simulate(TOP.replace(mu=row["mu"]),
                             mett.State(theta=row["theta0"], omega3=row["omega3"]), 8.0,
                             backend="taylor", rtol=1e-12, stop_on_contact_loss=True)  # fmt: skip
        # the run's message, and the sweep's note on an unstable spin after it
        assert row["status"] == traj.status and row["message"].startswith(traj.message)
        assert row["theta_end"] == float(traj.theta[-1])
        assert row["omega3_end"] == float(traj.omega3[-1])
        cross = traj.crossings(np.pi / 2)
        if cross.size:
            assert abs(row["t_invert"] - cross[0]) < 1e-12
        else:
            assert np.isnan(row["t_invert"])


def test_the_default_sweep_table_is_that_of_each_point_simulated_alone():
    # the default sweep (no backend option: auto, the batched Taylor lanes, the options checked
    # once, the ends of a batch derived together) against mett.simulate of each point by itself
    # with the sweep's options: the same jet, step rule and event location, so the same end
    # values to the last bit (SIMD lanes round as a single run does); the label from θ_end and
    # the prediction from mett.asymptotic_state of the point's λ
    grid = {"mu": [0.02, 0.3], "omega3": [-40.0, 155.0], "theta0": [0.1, 2.9]}
    table = sweep(TOP, grid, t_end=3.0, rtol=1e-11, progress=False)
    assert table.attrs["mett_sweep"]["backend"] == "taylor"
    for _, row in table.iterrows():
        top = TOP.replace(mu=row["mu"])
        start = mett.State(theta=row["theta0"], omega3=row["omega3"])
        traj = mett.simulate(top, start, 3.0, rtol=1e-11, stop_on_contact_loss=True)
        assert traj.backend == "taylor"
        assert row["status"] == traj.status and row["message"].startswith(traj.message)
        assert row["theta_end"] == float(traj.theta[-1])
        assert row["omega3_end"] == float(traj.omega3[-1])
        cross = traj.crossings(np.pi / 2)
        # the crossing: a root of cos θ located on the step polynomial, to its tolerance
        assert (
            (abs(row["t_invert"] - cross[0]) < 1e-12) if cross.size else np.isnan(row["t_invert"])
        )
        lam = float(mett.jellett(top, start))
        assert row["lam"] == lam
        if lam > 0:
            assert row["predicted"] == mett.asymptotic_state(top, lam).kind
        if row["status"] == "completed" and row["simulated"] != "not settled":
            assert row["simulated"] == mett.sweeps.classify_end(row["theta_end"], "completed")


def test_run_ends_sends_what_cannot_be_batched_through_simulate():
    from mett.dynamics import batch
    from mett.friction import Coulomb

    state = mett.State(theta=0.1, omega3=155.0)
    jobs = [
        (TOP, state),  # batched
        (TOP, state, {"friction": Coulomb(0.3)}),  # a hybrid (stick-slip) model: one by one
        (TOP, state, {"backend": "compiled"}),  # another backend: one by one
        (TOP, state, {"rtol": 2.0}),  # bad input: the exception, returned
    ]
    ends = batch.run_ends(jobs, 0.5, backend="taylor")
    assert isinstance(ends[3], ValueError) and "rtol" in str(ends[3])
    ref = [
        batch.end_of(mett.simulate(TOP, state, 0.5, backend="taylor")),
        batch.end_of(mett.simulate(TOP, state, 0.5, backend="taylor", friction=Coulomb(0.3))),
        batch.end_of(mett.simulate(TOP, state, 0.5, backend="compiled")),
    ]
    for end, r in zip(ends[:3], ref, strict=True):
        assert (end.status, end.message) == (r.status, r.message)
        assert end.theta_end == r.theta_end and end.omega3_end == r.omega3_end
        np.testing.assert_allclose(end.theta_window, r.theta_window, rtol=0, atol=1e-14)
        np.testing.assert_allclose(end.E_window, r.E_window, rtol=1e-14)


@pytest.mark.parametrize(
    ("model", "top", "state"),
    [
        ("gliding", TOP.replace(mu=0.07), mett.State(theta=0.1, omega3=155.0)),
        ("rolling", TOP, mett.State(theta=0.4, phidot=3.0, omega3=80.0)),
        ("gliding-hst", TOP.replace(mu=0.2), mett.State(theta=1.0, omega3=-40.0, nu_x=0.01)),
        ("gliding", TOP, mett.State(theta=0.0, omega3=0.0)),  # a pole, no spin
        ("gliding", TOP, mett.State(theta=math.pi, omega3=0.0)),  # falls: contact lost at 0
    ],
)
def test_runs_prepared_from_one_plan_are_those_of_prepare_run(model, top, state):
    # run_ends checks the options once (plan_runs) and each (top, state) on its own
    # (prepare_planned): every field of the prepared run is prepare_run's, bit for bit
    from mett.dynamics import simulation

    kw = {**simulation.SIMULATE_DEFAULTS, "model": model, "rtol": 1e-11,
          "stop_on_contact_loss": True}  # fmt: skip
    plan = simulation.plan_runs(2.0, **kw)
    got = simulation.prepare_planned(plan, top, state)
    ref = simulation.prepare_run(top, state, 2.0, **kw)
    assert type(got) is type(ref)
    if isinstance(ref, mett.Trajectory):  # decided at t = 0
        assert (got.status, got.message) == (ref.status, ref.message)
        np.testing.assert_array_equal(got.y, ref.y)
        return
    assert got.run.backend == ref.run.backend and got.model is ref.model
    assert got.params == ref.params and got.phase == ref.phase and got.table == ref.table
    for a, b in ((got.y0, ref.y0), (got.atol_arr, ref.atol_arr)):
        np.testing.assert_array_equal(a, b)
    assert got[2:4] == ref[2:4] and got[6:] == ref[6:]  # t_end, rtol; max_step, method, events
    assert got.run.options == ref.run.options and got.run.options is not plan.model_options
    # a point the plan's checks would refuse: prepare_run's error
    with pytest.raises(TypeError, match=r"top must be a mett\.TippeTop"):
        simulation.prepare_planned(plan, "top", state)
    with pytest.raises(ValueError, match=r"state\.omega3"):
        simulation.prepare_planned(plan, top, mett.State(theta=0.1, omega3=1e40))
    with pytest.raises(ValueError, match="friction law"):
        simulation.plan_runs(2.0, friction=mett.friction.Viscous(0.1))


def test_a_sweep_over_friction_shares_each_start_and_still_builds_every_top():
    # Points that differ in mu alone share their top's checks, state, λ (mett.sweeps) and the
    # start and tolerance scales of their runs (prepare_planned); the other axes (I1 here) still
    # build and check a top of their own. Mixed valid and invalid points: a bad mu, a bad I1
    # (I3 > 2 I1), both (the full check names mu first). The table equals that of the same
    # points run one per chunk (nothing shared), and each row its own fresh top and simulate.
    bad_i1 = TOP.I3 / 2.5
    grid = {"I1": [TOP.I1, bad_i1, 1.1 * TOP.I1], "mu": [0.05, -0.2, 0.3, 0.45]}
    kw = dict(t_end=0.6, rtol=1e-11, progress=False)
    shared = sweep(TOP, grid, **kw)
    alone = sweep(TOP, grid, chunksize=1, **kw)
    pd.testing.assert_frame_equal(shared, alone, check_exact=True)
    for _, row in shared.iterrows():
        if row["mu"] < 0:
            assert row["status"] == "invalid" and row["message"].startswith("mu must lie")
            continue
        if row["I1"] == bad_i1:
            assert row["status"] == "invalid" and row["message"].startswith("I3 must lie")
            continue
        top = mett.TippeTop(m=TOP.m, R=TOP.R, alpha=TOP.alpha, I1=row["I1"], I3=TOP.I3,
                            mu=row["mu"], g=TOP.g)  # fmt: skip
        start = mett.State(theta=0.1, omega3=155.0)
        assert row["lam"] == float(mett.jellett(top, start))
        assert row["lam_ratio"] == row["lam"] / top.lambda_thres and row["gamma"] == top.gamma
        traj = mett.simulate(top, start, 0.6, rtol=1e-11, stop_on_contact_loss=True)
        assert row["status"] == traj.status and row["theta_end"] == float(traj.theta[-1])
        assert row["omega3_end"] == float(traj.omega3[-1])
    assert set(shared["status"]) == {"completed", "invalid"}


def test_runs_differing_in_mu_alone_share_their_start_bit_for_bit():
    # prepare_planned with a shared dict: a second run of the same state and another mu takes
    # the first run's start and scales (a copy of y0: each run owns its start), and every field
    # is prepare_run's; a model that does not declare a start free of mu shares nothing
    from mett.dynamics import simulation

    kw = {**simulation.SIMULATE_DEFAULTS, "rtol": 1e-11, "stop_on_contact_loss": True}
    state = mett.State(theta=0.3, thetadot=1.0, phidot=2.0, omega3=120.0, nu_x=0.01)
    for model, shares in (("gliding", True), ("gliding-euler", False)):
        plan = simulation.plan_runs(2.0, **{**kw, "model": model})
        starts: dict = {}
        preps = [simulation.prepare_planned(plan, TOP.replace(mu=mu), state, starts)
                 for mu in (0.05, 0.3, 0.0)]  # fmt: skip
        assert len(starts) == (1 if shares else 0)
        for mu, got in zip((0.05, 0.3, 0.0), preps, strict=True):
            ref = simulation.prepare_run(TOP.replace(mu=mu), state, 2.0, **{**kw, "model": model})
            assert got.params == ref.params and got.run.backend == ref.run.backend
            np.testing.assert_array_equal(got.y0, ref.y0)
            np.testing.assert_array_equal(got.atol_arr, ref.atol_arr)
        assert preps[0].y0 is not preps[1].y0
    # another state (even of equal values) is a start of its own
    starts = {}
    plan = simulation.plan_runs(2.0, **kw)
    simulation.prepare_planned(plan, TOP, state, starts)
    other = mett.State(theta=0.5, omega3=100.0)
    got = simulation.prepare_planned(plan, TOP.replace(mu=0.2), other, starts)
    ref = simulation.prepare_run(TOP.replace(mu=0.2), other, 2.0, **kw)
    np.testing.assert_array_equal(got.y0, ref.y0)
    np.testing.assert_array_equal(got.atol_arr, ref.atol_arr)


def test_a_model_declaring_a_start_free_of_mu_never_reads_mu_there():
    # Model.mu_free_start lets runs that differ in mu alone share initial and scales: for every
    # model that declares it, both must be the same, bit for bit, whatever mu (starts with slip,
    # at a pole, spinning either way, several tops)
    from mett.dynamics import MODELS
    from mett.dynamics import _params as ix

    declared = [mdl for mdl in MODELS.values() if mdl.mu_free_start]
    assert "gliding" in {mdl.name for mdl in declared}
    states = [mett.State(theta=0.1, omega3=155.0), mett.State(theta=0.0, omega3=-40.0),
              mett.State(theta=2.0, thetadot=-3.0, phidot=5.0, omega3=30.0, nu_x=0.02,
                         nu_y=-0.01)]  # fmt: skip
    tops = [TOP, TOP.replace(I3=1.9 * TOP.I1, alpha=0.45, R=0.03)]
    for mdl in declared:
        for top in tops:
            for state in states:
                p = tuple(mdl.params(top, {}))
                y0 = np.asarray(mdl.initial(state, p), dtype=float)
                sc = np.asarray(mdl.scales(y0, p), dtype=float)
                for mu in (0.0, 1e-3, 0.7, 40.0):
                    q = (*p[: ix.MU], mu, *p[ix.MU + 1 :])
                    y = np.asarray(mdl.initial(state, q), dtype=float)
                    np.testing.assert_array_equal(y, y0)
                    np.testing.assert_array_equal(np.asarray(mdl.scales(y, q), dtype=float), sc)


def test_the_gliding_normal_force_of_one_state_is_that_of_numpy_scalars():
    # the model's normal force (each run's check at t = 0) evaluates one state in float
    # arithmetic, not numpy scalars: the same IEEE operations (x ** 0.5 is pow(x, 0.5) in both),
    # so the same bits; a state whose axis is 0 gives numpy's non-finite value, not an exception
    from mett.dynamics.gliding import gliding_normal_force

    mdl = mett.dynamics.MODELS["gliding"]
    rng = np.random.default_rng(7)
    for _ in range(200):
        state = mett.State(theta=rng.uniform(0.0, np.pi), thetadot=rng.normal(0.0, 5.0),
                           phidot=rng.normal(0.0, 5.0), omega3=rng.normal(0.0, 100.0),
                           nu_x=rng.normal(0.0, 0.1), nu_y=rng.normal(0.0, 0.1))  # fmt: skip
        p = mdl.params(TOP.replace(mu=rng.uniform(0.0, 1.0)), {})
        y = np.asarray(mdl.initial(state, p)) * (1.0 + 1e-3 * rng.normal(size=10))
        one = mdl.normal_force(y, p)
        ref = gliding_normal_force(y, p)  # element by element of the array: numpy float64 scalars
        assert type(one) is float and type(ref) is np.float64
        assert one == ref and np.signbit(one) == np.signbit(ref)
    y[7:] = 0.0
    with np.errstate(all="ignore"):
        assert not np.isfinite(mdl.normal_force(y, p))


def test_the_predicted_end_state_does_not_depend_on_friction():
    # mett.sweep remembers predictions by the top without mu: asymptotic_state must not see mu
    # (for every class of top: the thesis body IIa, one with a fold, one that never inverts)
    tops = [TOP, TOP.replace(I3=1.9 * TOP.I1, alpha=0.45), TOP.replace(I3=0.5 * TOP.I1)]
    for top in tops:
        for lam in np.geomspace(0.2, 5.0, 7) * TOP.lambda_thres:
            want = repr(mett.asymptotic_state(top, lam))  # repr: NaN fields compare equal
            for mu in (0.0, 1e-3, 0.7, 40.0):
                assert repr(mett.asymptotic_state(top.replace(mu=mu), lam)) == want, (lam, mu)
    rows = sweep(TOP, {"mu": [0.01, 0.3, 3.0]}, t_end=0.01, progress=False)
    want = mett.asymptotic_state(TOP, float(rows["lam"][0])).kind
    assert list(rows["predicted"]) == [want] * 3


# --- end states near an unstable spin ------------------------------------------------------------
def test_a_top_slowly_leaving_its_unstable_upright_spin_is_not_labelled_upright():
    # the sweeps page's first example, point (λ = 0.5 λ_thres, γ = 0.9): λ > λ_0, so the upright
    # spin is unstable (a growing mode of the linearisation, independent of the simulation) and the
    # end state is a tumbling one (asymptotic_state); the top escapes on the time scale of
    # escape_time (~19 s) and is still within the pole band at 4 s
    top = TOP.replace(I1=0.9 * TOP.I3)
    short = sweep(TOP, {"lam_ratio": [0.5], "gamma": [0.9]}, t_end=4.0, progress=False).iloc[0]
    lam = float(short["lam"])
    assert lam > top.lambda_0
    assert mett.stability.spin_eigenvalues(top, lam, "upright").real.max() > 0
    pred = mett.asymptotic_state(top, lam)
    assert pred.kind == "tumbling"
    escape = mett.escape_time(top, mett.State(theta=0.1, omega3=float(short["omega3_start"])))
    assert 4.0 < escape.time < 100.0
    assert short["status"] == "completed" and short["theta_end"] < 0.05  # in the pole band
    assert short["simulated"] == "not settled" and "unstable" in short["message"]
    long = sweep(TOP, {"lam_ratio": [0.5], "gamma": [0.9]}, t_end=100.0, progress=False).iloc[0]
    assert long["simulated"] == "tumbling" and long["agree"]
    # settled at the predicted tumbling angle, within the settled test's band
    assert abs(long["theta_end"] - pred.theta) < 0.05


def test_a_stable_upright_spin_is_still_upright():
    # λ = 0.2 λ_thres < λ_0 ≈ 0.36 λ_thres: every eigenvalue of the upright spin decays
    table = sweep(TOP, {"lam_ratio": [0.2]}, t_end=4.0, progress=False)
    lam = float(table["lam"].iloc[0])
    assert lam < TOP.lambda_0
    assert mett.stability.spin_eigenvalues(TOP, lam, "upright").real.max() < 0
    assert list(table["simulated"]) == ["upright"] and table["agree"].all()


def test_a_top_near_its_unstable_inverted_spin_is_not_labelled_inverted():
    # started 0.01 rad from θ = π with λ = 0.98 λ_thres: the inverted spin is unstable (slowly:
    # σ ≈ 0.37/s), and after 3 s the top is still in the pole band, losing almost no energy
    table = sweep(TOP, {"lam_ratio": [0.98]}, theta0=np.pi - 0.01, t_end=3.0, progress=False)
    row = table.iloc[0]
    lam = float(row["lam"])
    assert 0 < lam < TOP.lambda_thres
    assert mett.stability.spin_eigenvalues(TOP, lam, "inverted").real.max() > 0
    assert mett.asymptotic_state(TOP, lam).kind == "tumbling"
    assert row["theta_end"] > np.pi - 0.05
    assert row["simulated"] == "not settled" and "inverted spin" in row["message"]


def test_no_prediction_for_a_negative_lambda_says_why():
    table = sweep(TOP, {"omega3": [-155.0]}, t_end=0.05, progress=False)
    row = table.iloc[0]
    assert row["lam"] < 0 and row["predicted"] == "n/a"
    assert "no predicted end state: lam" in row["message"] and "<= 0" in row["message"]


# --- options a grid axis makes meaningless; fixed friction ---------------------------------------
@pytest.mark.parametrize(
    ("grid", "kw", "needle"),
    [
        ({"lam_ratio": [1.0]}, {"omega3": 150.0}, "omega3=150.0 is ignored when the grid varies "
                                                  "'lam_ratio'"),
        ({"theta0": [0.1]}, {"theta0": 0.2}, "theta0=0.2 is ignored when the grid varies 'theta0'"),
        ({"friction": ["viscous"]}, {"friction": "coulomb"}, "friction= and a grid axis"),
        ({"mu": [0.3]}, {"friction": mett.friction.Coulomb(0.3)}, "would be ignored"),
        ({"contensou_radius": [0.0]}, {"contensou_radius": 0.001, "friction": "coulomb"},
         "contensou_radius= and a grid axis"),
        ({"mu": [0.3]}, {"friction": "dry"}, "friction must be one of"),
        ({"mu": [0.3]}, {"contensou_radius": 1e-3}, "contensou_radius= applies to the Coulomb"),
        ({"mu": [0.3]}, {"contensou_radius": 1e-3, "friction": "viscous"},
         "contensou_radius= applies to the Coulomb"),
        ({"omega3": [155.0]}, {"contensou_radius": 1e-3, "friction": mett.friction.Coulomb(0.3)},
         "carries its own contensou_radius"),
    ],
)  # fmt: skip
def test_options_the_grid_overrides_are_refused(grid, kw, needle):
    with pytest.raises(ValueError, match=needle):
        sweep(TOP, grid, t_end=0.05, progress=False, **kw)


def test_one_friction_law_for_the_whole_sweep():
    # a law by name (coefficient: each point's mu), a law whole, and a Contensou radius; each row
    # is the simulate call with that law
    from mett.friction import Coulomb

    st = mett.State(theta=0.1, omega3=155.0)
    cases = [
        ({"mu": [0.3, 0.1]}, {"friction": "coulomb"}, lambda mu: Coulomb(mu)),
        ({"omega3": [155.0]}, {"friction": Coulomb(0.2)}, lambda mu: Coulomb(0.2)),
        ({"mu": [0.3]}, {"friction": "coulomb", "contensou_radius": 1e-3},
         lambda mu: Coulomb(mu, contensou_radius=1e-3)),
    ]  # fmt: skip
    for grid, kw, law in cases:
        table = sweep(TOP, grid, t_end=0.2, progress=False, **kw)
        for _, row in table.iterrows():
            mu = row.get("mu", TOP.mu)
            ref = mett.simulate(TOP.replace(mu=mu), st, 0.2, friction=law(mu))
            assert row["status"] == ref.status and row["theta_end"] == ref.theta[-1], kw


def test_a_point_simulate_refuses_is_invalid_wherever_it_is_in_the_grid():
    # 1e300 λ_thres is a spin beyond simulate's range: first or last, the same "invalid" row
    a = sweep(TOP, {"lam_ratio": [1e300, 1.0]}, t_end=0.01, progress=False)
    b = sweep(TOP, {"lam_ratio": [1.0, 1e300]}, t_end=0.01, progress=False)
    assert list(a["status"]) == ["invalid", "completed"]
    assert list(b["status"]) == ["completed", "invalid"]
    assert a["message"].iloc[0] == b["message"].iloc[1]


def test_an_executor_whose_submit_returns_no_future_is_a_type_error():
    class Odd:
        def submit(self, fn, *args):
            return fn(*args)  # the result itself, not a Future

    with pytest.raises(TypeError, match=r"executor.submit must return a concurrent.futures.Future"):
        sweep(TOP, {"mu": [0.3]}, t_end=0.01, progress=False, executor=Odd())


# --- the grid's size -------------------------------------------------------------------------------
def test_a_grid_over_the_maximum_is_refused_before_any_point_is_built(monkeypatch):
    import itertools

    def no_product(*a, **k):  # the points must not be enumerated to find the size out
        raise AssertionError("points were built")

    monkeypatch.setattr(itertools, "product", no_product)
    n = int(np.sqrt(mett.sweeps.MAX_POINTS)) + 1
    axis = np.linspace(0.1, 0.5, n)
    with pytest.raises(ValueError, match=f"{n} x {n} = {n * n} points; at most MAX_POINTS"):
        sweep(TOP, {"mu": axis, "theta0": axis}, t_end=1.0)


def test_grid_points_come_in_product_order_without_being_listed():
    import itertools

    g = mett.sweeps._grid({"mu": [0.1, 0.2, 0.3], "friction": ["viscous", "coulomb"], "g": [9.8]})
    want = [dict(zip(g.names, c, strict=True)) for c in itertools.product(*g.axes)]
    assert list(g) == want and [g.point(i) for i in range(len(g))] == want


# --- checkpoint records: exactly what the sweep writes -------------------------------------------
GRID2 = {"mu": [0.2, 0.3]}


def _checkpoint(tmp_path, **kw):
    path = tmp_path / "c.jsonl"
    sweep(TOP, GRID2, t_end=0.05, progress=False, checkpoint=path, **kw)
    return path, path.read_text().splitlines()


def _edited(path, lines, line, edit):
    rec = json.loads(lines[line])
    edit(rec)
    lines = [*lines[:line], json.dumps(rec), *lines[line + 1 :]]
    path.write_text("\n".join(lines) + "\n")
    return path.read_bytes()


def _set(key, value):
    return lambda rec: rec["row"].__setitem__(key, value)


@pytest.mark.parametrize(
    ("edit", "needle"),
    [
        (lambda rec: rec.__setitem__("row", {}), "columns missing"),
        (_set("mu", 99.0), "mu = 99.0, but point 0 has 0.2"),
        (_set("mu", 0.2 + 1e-16), "but point 0 has 0.2"),  # exact after the JSON round trip
        (_set("status", 42), "status must be a str"),
        (_set("theta_end", "abc"), "theta_end must be a float"),
        (_set("theta_end", [1, 2, 3]), "theta_end must be a float"),
        (_set("agree", 1), "agree must be a bool"),
        (_set("extra", 1.0), r"unexpected \['extra'\]"),
        (lambda rec: rec.__setitem__("index", 1.9), "index must be an integer"),
        (lambda rec: rec.__setitem__("index", True), "index must be an integer"),
        (lambda rec: rec.__setitem__("index", "0"), "index must be an integer"),
        (lambda rec: rec.__setitem__("index", 7), "index must be an integer in"),
        (lambda rec: rec.__setitem__("more", 1), "not {"),
    ],
)
def test_a_wrong_record_is_refused_naming_file_and_line(tmp_path, edit, needle):
    path, lines = _checkpoint(tmp_path)
    before = _edited(path, lines, 1, edit)
    with pytest.raises(ValueError, match=f"{path}, line 2: damaged checkpoint record.*{needle}"):
        sweep(TOP, GRID2, t_end=0.05, progress=False, checkpoint=path)
    assert path.read_bytes() == before  # left as it was


def test_a_grid_value_of_a_lam_ratio_axis_is_checked(tmp_path):
    path = tmp_path / "c.jsonl"
    sweep(TOP, {"lam_ratio": [0.5]}, t_end=0.01, progress=False, checkpoint=path)
    lines = path.read_text().splitlines()
    _edited(path, lines, 1, _set("lam_ratio", 99.0))
    with pytest.raises(ValueError, match=r"lam_ratio = 99.0, but point 0 has 0.5"):
        sweep(TOP, {"lam_ratio": [0.5]}, t_end=0.01, progress=False, checkpoint=path)


def test_duplicate_records_conflicting_are_refused_identical_are_one(tmp_path):
    path, lines = _checkpoint(tmp_path)
    path.write_text("\n".join([*lines, lines[1]]) + "\n")  # the same record twice: harmless
    fresh = sweep(TOP, GRID2, t_end=0.05, progress=False)
    pd.testing.assert_frame_equal(
        sweep(TOP, GRID2, t_end=0.05, progress=False, checkpoint=path), fresh
    )
    rec = json.loads(lines[1])
    rec["row"]["theta_end"] = 0.5
    path.write_text("\n".join([*lines, json.dumps(rec)]) + "\n")
    with pytest.raises(
        ValueError, match=f"{path}, lines 2 and 4: two different records of point 0"
    ):
        sweep(TOP, GRID2, t_end=0.05, progress=False, checkpoint=path)


def test_a_deeply_nested_record_is_a_value_error_naming_file_and_line(tmp_path):
    path, lines = _checkpoint(tmp_path)
    path.write_text("\n".join([*lines, "[" * 100_000 + "]" * 100_000]) + "\n")
    with pytest.raises(ValueError, match=f"{path}, line 4: damaged checkpoint record"):
        sweep(TOP, GRID2, t_end=0.05, progress=False, checkpoint=path)


@pytest.mark.parametrize("version", [99, "x", True, 2.0, None])
def test_an_unknown_format_version_is_refused(tmp_path, version):
    path, lines = _checkpoint(tmp_path)
    before = _edited(path, lines, 0, lambda h: h.__setitem__("mett_sweep", version))
    with pytest.raises(ValueError, match=f"checkpoint {path} has format version"):
        sweep(TOP, GRID2, t_end=0.05, progress=False, checkpoint=path)
    assert path.read_bytes() == before


def test_a_checkpoint_of_another_mett_version_is_refused(tmp_path):
    path, lines = _checkpoint(tmp_path)
    _edited(path, lines, 0, lambda h: h.__setitem__("mett", "0.0.1"))
    with pytest.raises(ValueError, match=r"written by mett '0.0.1', this is mett"):
        sweep(TOP, GRID2, t_end=0.05, progress=False, checkpoint=path)


def test_a_version_1_checkpoint_still_resumes_with_a_warning(tmp_path):
    # written as mett did before format 2: the signature hashes the list of every point, with the
    # arguments as they were recorded then (spelled out here, not computed by mett)
    import dataclasses
    import hashlib

    base = {"top": dataclasses.asdict(TOP), "t_end": 0.05, "theta0": 0.1, "thetadot": 0.0,
            "phidot": 0.0, "omega3": 155.0, "nu_x": 0.0, "nu_y": 0.0, "simulate_kw": {}}  # fmt: skip
    points = [{"mu": 0.2}, {"mu": 0.3}]
    doc = json.dumps({"base": base, "names": ["mu"], "points": points}, sort_keys=True)
    header = {"mett_sweep": 1, "signature": hashlib.sha256(doc.encode()).hexdigest(),
              "args": {"names": ["mu"], "n_points": 2, "t_end": 0.05}}  # fmt: skip
    # its rows were computed by backend="auto" of then, the compiled DOP853
    _, lines = _checkpoint(tmp_path, backend="compiled")
    path = tmp_path / "v1.jsonl"
    path.write_text("\n".join([json.dumps(header), lines[1]]) + "\n")  # point 0 done
    with (
        pytest.warns(mett.sweeps.CheckpointWarning, match="before mett recorded the backend"),
        pytest.warns(mett.sweeps.CheckpointWarning, match="did not record its version"),
    ):
        resumed = sweep(TOP, GRID2, t_end=0.05, progress=False, checkpoint=path)
    expected = sweep(TOP, GRID2, t_end=0.05, progress=False, backend="compiled")
    pd.testing.assert_frame_equal(resumed, expected, check_exact=True, check_like=True)
    assert len(path.read_text().splitlines()) == 3  # point 1 appended


# --- the backend of a sweep and of its checkpoint -------------------------------------------------


def test_the_default_sweep_runs_side_by_side_on_taylor_lanes(tmp_path):
    path = tmp_path / "c.jsonl"
    default = sweep(TOP, GRID2, t_end=0.5, progress=False, checkpoint=path)
    assert default.attrs["mett_sweep"]["backend"] == "taylor"
    assert json.loads(path.read_text().splitlines()[0])["backend"] == "taylor"
    taylor = sweep(TOP, GRID2, t_end=0.5, progress=False, backend="taylor")
    pd.testing.assert_frame_equal(default, taylor, check_exact=True)
    # a dry-friction sweep is not analytic: one by one on the compiled DOP853
    dry = sweep(TOP, {"mu": [0.2]}, t_end=0.05, progress=False, friction="coulomb")
    assert dry.attrs["mett_sweep"]["backend"] == "compiled"
    mixed = sweep(TOP, {"friction": ["viscous", "coulomb"]}, t_end=0.05, progress=False)
    assert mixed.attrs["mett_sweep"]["backend"] == "coulomb:compiled+viscous:taylor"


def _version_2_checkpoint(tmp_path, simulate_kw):
    """A checkpoint written as mett wrote format 2 (before it recorded the backend; its
    backend="auto" ran the compiled DOP853): the signature hashes the arguments and the axes,
    spelled out here as that code did, and point 0 is done, with the compiled DOP853's row."""
    import dataclasses
    import hashlib

    base = {"top": dataclasses.asdict(TOP), "t_end": 0.05, "theta0": 0.1, "thetadot": 0.0,
            "phidot": 0.0, "omega3": 155.0, "nu_x": 0.0, "nu_y": 0.0,
            "simulate_kw": simulate_kw}  # fmt: skip
    doc = {"base": base, "names": ["mu"], "axes": [[0.2, 0.3]], "version": 2}
    header = {"mett_sweep": 2, "mett": mett.__version__,
              "signature": hashlib.sha256(json.dumps(doc, sort_keys=True).encode()).hexdigest(),
              "args": {"names": ["mu"], "n_points": 2, "t_end": 0.05}}  # fmt: skip
    _, lines = _checkpoint(tmp_path, backend="compiled")
    path = tmp_path / "v2.jsonl"
    path.write_text("\n".join([json.dumps(header), lines[1]]) + "\n")
    return path


def test_a_checkpoint_written_before_the_backend_was_recorded_resumes_on_dop853(tmp_path):
    compiled = sweep(TOP, GRID2, t_end=0.05, progress=False, backend="compiled")
    taylor = sweep(TOP, GRID2, t_end=0.05, progress=False, backend="taylor")
    assert not compiled.equals(taylor)  # the rows tell the backends apart: a mix would show
    path = _version_2_checkpoint(tmp_path, {})
    with pytest.warns(mett.sweeps.CheckpointWarning, match="backend='compiled'"):
        resumed = sweep(TOP, GRID2, t_end=0.05, progress=False, checkpoint=path)
    pd.testing.assert_frame_equal(resumed, compiled, check_exact=True, check_like=True)
    assert resumed.attrs["mett_sweep"]["backend"] == "compiled"
    assert len(path.read_text().splitlines()) == 3  # point 1 appended, by the same backend
    # asked for explicitly, the backend that wrote it resumes it too; another one is refused
    path = _version_2_checkpoint(tmp_path, {})
    again = sweep(TOP, GRID2, t_end=0.05, progress=False, checkpoint=path, backend="compiled")
    pd.testing.assert_frame_equal(again, compiled, check_exact=True, check_like=True)
    path = _version_2_checkpoint(tmp_path, {})
    before = path.read_bytes()
    with pytest.raises(ValueError, match=r"written by backend 'compiled'.*backend='compiled'"):
        sweep(TOP, GRID2, t_end=0.05, progress=False, checkpoint=path, backend="taylor")
    assert path.read_bytes() == before
    # a format-2 checkpoint of an explicit backend resumes on it, without a warning
    path = _version_2_checkpoint(tmp_path, {"backend": "compiled"})
    with warnings.catch_warnings():
        warnings.simplefilter("error", mett.sweeps.CheckpointWarning)
        again = sweep(TOP, GRID2, t_end=0.05, progress=False, checkpoint=path, backend="compiled")
    pd.testing.assert_frame_equal(again, compiled, check_exact=True, check_like=True)


def test_resuming_with_another_backend_is_refused_naming_the_option(tmp_path):
    path, _ = _checkpoint(tmp_path)  # the default: Taylor lanes
    before = path.read_bytes()
    with pytest.raises(ValueError, match=r"written by backend 'taylor'.*backend='taylor'"):
        sweep(TOP, GRID2, t_end=0.05, progress=False, checkpoint=path, backend="compiled")
    assert path.read_bytes() == before


# --- checkpoint paths and a full disk ------------------------------------------------------------
@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="FIFOs are a POSIX feature")
def test_a_fifo_or_a_device_is_refused_as_checkpoint_without_blocking(tmp_path):
    fifo = tmp_path / "f"
    os.mkfifo(fifo)
    with pytest.raises(ValueError, match=r"checkpoint must be a regular file; .* is a FIFO"):
        sweep(TOP, {"mu": [0.3]}, t_end=0.01, progress=False, checkpoint=fifo)
    for dev in ("/dev/stdout", "/dev/null"):
        with pytest.raises(ValueError, match="checkpoint must be a regular file"):
            sweep(TOP, {"mu": [0.3]}, t_end=0.01, progress=False, checkpoint=dev)


@pytest.mark.parametrize("room", [0, 2])  # the disk fills at the header, or after one record
def test_a_full_disk_is_one_error_naming_the_checkpoint_and_resumes(tmp_path, monkeypatch, room):
    import errno

    path = tmp_path / "c.jsonl"
    grid = {"mu": [0.2, 0.3, 0.4]}
    real = os.fsync
    calls = []

    def fsync(fd):  # `room` writes fit; then the disk is full
        calls.append(fd)
        if len(calls) > room:
            raise OSError(errno.ENOSPC, "No space left on device")
        real(fd)

    monkeypatch.setattr(mett.sweeps.os, "fsync", fsync)
    with pytest.raises(OSError) as info:
        sweep(TOP, grid, t_end=0.01, progress=False, checkpoint=path)
    assert info.value.errno == errno.ENOSPC and info.value.filename == str(path)
    assert "cannot write the checkpoint" in str(info.value)
    monkeypatch.setattr(mett.sweeps.os, "fsync", real)  # space freed
    resumed = sweep(TOP, grid, t_end=0.01, progress=False, checkpoint=path)
    pd.testing.assert_frame_equal(resumed, sweep(TOP, grid, t_end=0.01, progress=False))


def test_the_spin_stability_a_sweep_remembers_does_not_depend_on_friction():
    # mett.sweep remembers whether a spin is unstable by the top without mu (and mu > 0): the sign
    # of the eigenvalues' largest real part must not depend on mu, on either side of λ_0 and λ_thres
    from mett.stability import spin_eigenvalues

    for top in (TOP, TOP.replace(I1=0.9 * TOP.I3), TOP.replace(I1=1.1 * TOP.I3)):
        for lam in np.geomspace(0.05, 20.0, 24) * top.lambda_thres:  # not at a threshold
            for pole, threshold in (("upright", top.lambda_0), ("inverted", top.lambda_thres)):
                want = (lam > threshold) if pole == "upright" else (lam < threshold)
                for mu in (1e-4, 0.3, 40.0):
                    sigma = spin_eigenvalues(top.replace(mu=mu), lam, pole).real.max()
                    assert (sigma > 0) == want, (lam / top.lambda_thres, pole, mu)
