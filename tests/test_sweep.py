"""Parameter sweeps: executors, checkpoint/resume (incl. SIGKILL), end states, the CLI."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time
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
    assert len(lines) == 5 and json.loads(lines[0])["mett_sweep"] == 1
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
    table = pd.read_csv(out)
    assert list(table["mu"]) == [0.2, 0.4] and "2 runs" in res.stdout


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["--grid", "mu=0.1:0.2"], "name=start:stop:num"),
        (["--grid", "mu=a:b:2"], "with numbers"),
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
                             backend="taylor", rtol=1e-12)  # fmt: skip
        assert row["status"] == traj.status and row["message"] == traj.message
        assert row["theta_end"] == float(traj.theta[-1])
        assert row["omega3_end"] == float(traj.omega3[-1])
        cross = traj.crossings(np.pi / 2)
        if cross.size:
            assert abs(row["t_invert"] - cross[0]) < 1e-12
        else:
            assert np.isnan(row["t_invert"])


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
