"""Ctrl-C (SIGINT) during runs and sweeps, observed in child processes, and the step budget.

A SIGINT during a compiled run used to crash the process (SIGSEGV) or surface as SystemError
after the whole run, and a serial sweep recorded it as an "error" row and went on
(docs/reliability.md#interrupts-and-step-budgets). Here a child process starts a long run; the
parent sends SIGINT only once the child reports that the integration is under way (a SIGALRM
handler, which the compiled loops run at their signal polls, finds the run integrating; in a
sweep, after a first row is in the checkpoint; with an executor, the checkpoint's first row
alone). The child must end with a KeyboardInterrupt, caught and reported, never with a signal (a
negative return code); an interrupted sweep, resumed from its checkpoint, must give the rows of an
uninterrupted run, bit for bit.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import mett
from mett.dynamics import _run

pytestmark = pytest.mark.skipif(not hasattr(signal, "setitimer"), reason="POSIX signals")

# A safety net against a child that hangs (the failure this file guards against), not a timing
# requirement: a passing child ends within seconds of the signal.
_HANG = 600.0

# The child's hook: a SIGALRM handler every 20 ms that prints RUNNING once it finds the run
# integrating (and ready() holds). The compiled loops run it at their signal polls; before the fix
# it ran only after the loop (in numba's call wrapper), so the child never printed RUNNING.
_HOOK = """
import os, signal, sys
import mett

# the Python frames that call the compiled loops (taylor/__init__.py holds solve and propagate)
COMPILED = {("dop853.py", "solve"), ("__init__.py", "solve"), ("__init__.py", "propagate")}
reported = False
ready = lambda: True

def where(frame):
    return os.path.basename(frame.f_code.co_filename), frame.f_code.co_name

def integrating(frame):
    # in a compiled loop, the innermost Python frame is the one that called it (inside numba's
    # call wrapper it is numba's own); on the scipy backend, solve_ivp is on the stack
    if where(frame) in COMPILED:
        return True
    while frame is not None:
        if where(frame) == ("ivp.py", "solve_ivp"):
            return True
        frame = frame.f_back
    return False

def tick(signum, frame):
    global reported
    if not reported and integrating(frame) and ready():
        reported = True
        print("RUNNING", flush=True)

def has_rows(path):  # a checkpoint with its header and a first row
    try:
        with open(path, "rb") as fh:
            return fh.read().count(b"\\n") >= 2
    except OSError:
        return False

def start_hook():
    signal.signal(signal.SIGALRM, tick)
    signal.setitimer(signal.ITIMER_REAL, 0.02, 0.02)

def stop_hook():  # before the interpreter exits: a SIGALRM without the handler would kill it
    signal.setitimer(signal.ITIMER_REAL, 0.0)
"""

# The child's single run: 3000 s of a fast top at rtol 1e-12, about a million steps (seconds to
# minutes on any backend), so it is still running when the signal comes.
_RUN_CHILD = (
    _HOOK
    + """
backend = sys.argv[1]
top = mett.presets.get("rutstam2013").replace(mu=0.01)
state = mett.State(theta=0.1, omega3=1e4)
mett.simulate(top, state, 1e-3, rtol=1e-12, backend=backend)  # loads the compiled code
start_hook()
try:
    traj = mett.simulate(top, state, 3000.0, rtol=1e-12, backend=backend)
    print("FINISHED", traj.status, flush=True)
except KeyboardInterrupt:
    stop_hook()
    print("INTERRUPTED", flush=True)
"""
)


def _spawn(code: str, *args: str, **kw) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-c", textwrap.dedent(code), *args],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, **kw,
    )  # fmt: skip


def _wait_for_line(proc: subprocess.Popen, marker: str) -> None:
    for line in proc.stdout:
        if line.strip() == marker:
            return
        if line.startswith("FINISHED"):
            break
    out, err = _end(proc)
    pytest.fail(f"the child never reported {marker!r}; stdout {out!r}, stderr {err[-2000:]!r}")


def _end(proc: subprocess.Popen) -> tuple[str, str]:
    try:
        return proc.communicate(timeout=_HANG)
    except subprocess.TimeoutExpired:
        proc.kill()
        out, err = proc.communicate()
        pytest.fail(f"the child hung after SIGINT; stderr {err[-2000:]!r}")


def _assert_interrupted(proc: subprocess.Popen, out: str, err: str) -> None:
    assert proc.returncode >= 0, f"killed by signal {-proc.returncode}; stderr {err[-2000:]!r}"
    assert "SystemError" not in err and "Fatal Python error" not in err, err[-2000:]
    assert proc.returncode == 0 and "INTERRUPTED" in out, (proc.returncode, out, err[-2000:])


@pytest.mark.parametrize(
    "backend", ["compiled", "scipy", pytest.param("taylor", marks=pytest.mark.slow)]
)
def test_sigint_during_a_run_is_a_keyboard_interrupt(backend):
    proc = _spawn(_RUN_CHILD, backend)
    _wait_for_line(proc, "RUNNING")
    proc.send_signal(signal.SIGINT)
    out, err = _end(proc)
    _assert_interrupted(proc, out, err)


def test_a_signal_handlers_exception_leaves_a_compiled_run_unchanged():
    # A handler of another signal that raises: its own exception, raised at the next poll (not a
    # SystemError wrapping it, not a crash), and the process goes on normally afterwards.
    code = """
    import signal, mett
    top = mett.presets.get("rutstam2013").replace(mu=0.01)
    state = mett.State(theta=0.1, omega3=1e4)
    mett.simulate(top, state, 1e-3, rtol=1e-12)

    class Alarm(Exception):
        pass

    def alarm(signum, frame):
        raise Alarm

    signal.signal(signal.SIGALRM, alarm)
    signal.setitimer(signal.ITIMER_REAL, 0.2)
    try:
        mett.simulate(top, state, 3000.0, rtol=1e-12)
        print("FINISHED")
    except Alarm:
        print("ALARM")
    print(mett.simulate(top, state, 1e-3, rtol=1e-12).status)
    """
    proc = _spawn(code)
    out, err = _end(proc)
    assert proc.returncode == 0, err[-2000:]
    assert out.split() == ["ALARM", "completed"], (out, err[-2000:])


def test_cli_simulate_interrupted_exits_130():
    code = _HOOK + textwrap.dedent("""
    from mett.cli import main
    start_hook()
    try:
        status = main(["simulate", "--preset", "rutstam2013", "--mu", "0.01", "--theta0", "0.1",
                       "--omega3", "1e4", "--t-end", "3000", "--rtol", "1e-12"])
    finally:
        stop_hook()
    sys.exit(status)
    """)
    proc = _spawn(code)
    _wait_for_line(proc, "RUNNING")
    proc.send_signal(signal.SIGINT)
    out, err = _end(proc)
    assert proc.returncode == 130, (proc.returncode, err[-2000:])
    assert err.strip().splitlines()[-1] == "mett: interrupted", err[-2000:]


# --- sweeps ---------------------------------------------------------------------------------------

# 16 points of a few tenths of a second each: the signal, sent when the first row is in the
# checkpoint, comes long before the last point is done.
_GRID = {"lam_ratio": [float(x) for x in np.linspace(0.5, 2.5, 16)]}
# one point at a time on the compiled DOP853 (the default, backend="auto", runs a chunk of 64
# points side by side on Taylor lanes: checkpointed only when the chunk ends; the taylor mode)
_SWEEP_KW = dict(t_end=60.0, rtol=1e-12, progress=False, backend="compiled")
# the Taylor backend is faster: longer runs, two points per SIMD batch (one call of the loop)
_TAYLOR = dict(backend="taylor", chunksize=2, t_end=240.0)

# In a serial sweep the signal comes while a point after the first one is being integrated; with
# an executor, while the main thread waits for results (the workers cannot run the hook).
_SWEEP_CHILD = (
    _HOOK
    + f"""
mode, checkpoint = sys.argv[1], sys.argv[2]
top = mett.presets.get("rutstam2013")
grid, kw, taylor = {_GRID!r}, {_SWEEP_KW!r}, {_TAYLOR!r}
ready = lambda: has_rows(checkpoint)
try:
    if mode == "serial":
        start_hook()
        mett.sweep(top, grid, checkpoint=checkpoint, **kw)
    elif mode == "taylor":  # serial, four points at a time in SIMD lanes
        start_hook()
        mett.sweep(top, grid, checkpoint=checkpoint, **{{**kw, **taylor}})
    elif mode == "pool":
        from concurrent.futures import ProcessPoolExecutor

        pool = ProcessPoolExecutor(max_workers=2)
        try:
            mett.sweep(top, grid, checkpoint=checkpoint, executor=pool, chunksize=1, **kw)
        finally:
            pool.shutdown(wait=False, cancel_futures=True)
    elif mode == "dask":
        from distributed import Client, LocalCluster

        with LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                          dashboard_address=None) as cluster, Client(cluster) as client:
            mett.sweep(top, grid, checkpoint=checkpoint, executor=client.get_executor(),
                       chunksize=1, **kw)
    print("FINISHED", flush=True)
except KeyboardInterrupt:
    stop_hook()
    print("INTERRUPTED", flush=True)
"""
)


_FRESH: dict[str, pd.DataFrame] = {}


def _fresh(**kw) -> pd.DataFrame:
    """The sweep run without interruption (and without a checkpoint), once per module."""
    key = repr(sorted(kw.items()))
    if key not in _FRESH:
        _FRESH[key] = mett.sweep(mett.presets.get("rutstam2013"), _GRID, **{**_SWEEP_KW, **kw})
    return _FRESH[key]


def _rows(path: Path) -> dict[int, dict]:
    lines = path.read_text(encoding="utf-8").splitlines()[1:]
    return {(rec := json.loads(line))["index"]: rec["row"] for line in lines if line.strip()}


def _wait_for_rows(proc: subprocess.Popen, path: Path) -> None:
    """Until the checkpoint holds a first complete row (or the child ended)."""
    import time

    while proc.poll() is None:
        if path.exists() and path.read_bytes().count(b"\n") >= 2:
            return
        time.sleep(0.005)
    out, err = _end(proc)
    pytest.fail(f"the child ended before writing a row; stdout {out!r}, stderr {err[-2000:]!r}")


def _interrupt_and_resume(tmp_path: Path, mode: str, *, group: bool = False, **kw) -> None:
    fresh = _fresh(**kw)
    ck = tmp_path / "sweep.ckpt"
    proc = _spawn(_SWEEP_CHILD, mode, str(ck), start_new_session=group)
    if mode in ("serial", "taylor"):
        _wait_for_line(proc, "RUNNING")
    else:
        _wait_for_rows(proc, ck)
    if group:  # Ctrl-C in a terminal: the whole process group (the workers too)
        os.killpg(proc.pid, signal.SIGINT)
    else:
        proc.send_signal(signal.SIGINT)
    out, err = _end(proc)
    _assert_interrupted(proc, out, err)
    done = _rows(ck)
    assert 1 <= len(done) < len(fresh), "the interrupt came after the last point"
    # what was recorded is what an uninterrupted run gives; the interrupted point is not there
    statuses = {row["status"] for row in done.values()}
    assert statuses <= {"completed", "contact_lost"}, statuses
    resumed = mett.sweep(
        mett.presets.get("rutstam2013"), _GRID, checkpoint=ck, **{**_SWEEP_KW, **kw}
    )
    pd.testing.assert_frame_equal(resumed, fresh, check_exact=True)


@pytest.mark.slow
@pytest.mark.ci
def test_sigint_during_a_serial_sweep_then_exact_resume(tmp_path):
    _interrupt_and_resume(tmp_path, "serial")


@pytest.mark.slow
def test_sigint_during_a_taylor_sweep_then_exact_resume(tmp_path):
    _interrupt_and_resume(tmp_path, "taylor", **_TAYLOR)


@pytest.mark.slow
def test_sigint_during_a_process_pool_sweep_then_exact_resume(tmp_path):
    _interrupt_and_resume(tmp_path, "pool", group=True)


@pytest.mark.slow
def test_sigint_during_a_dask_sweep_then_exact_resume(tmp_path):
    pytest.importorskip("distributed")
    _interrupt_and_resume(tmp_path, "dask")


@pytest.mark.slow
def test_cli_sweep_interrupted_exits_130_and_writes_no_table(tmp_path):
    ck, out_csv = tmp_path / "sweep.ckpt", tmp_path / "table.csv"
    grid = f"lam_ratio=0.5:2.5:{len(_GRID['lam_ratio'])}"
    code = _HOOK + textwrap.dedent(f"""
    from mett.cli import main
    ready = lambda: has_rows({str(ck)!r})
    start_hook()
    try:
        status = main(["sweep", "--preset", "rutstam2013", "--grid", {grid!r}, "--t-end", "60",
                       "--rtol", "1e-12", "--checkpoint", {str(ck)!r}, "--out", {str(out_csv)!r},
                       "--backend", "compiled"])
    finally:
        stop_hook()
    sys.exit(status)
    """)
    proc = _spawn(code)
    _wait_for_line(proc, "RUNNING")
    proc.send_signal(signal.SIGINT)
    out, err = _end(proc)
    assert proc.returncode == 130, (proc.returncode, err[-2000:])
    assert err.strip().splitlines()[-1] == "mett: interrupted", err[-2000:]
    assert not out_csv.exists()
    assert all(row["status"] != "error" for row in _rows(ck).values())


# --- the step budget ------------------------------------------------------------------------------


@pytest.mark.parametrize("method", ["DOP853", "RK45"])
def test_scipy_backend_stops_at_the_step_budget(monkeypatch, method):
    # μ = 1e9 makes the sliding stiff: explicit steps of ~1e-10 s, so 1 ms would take millions
    # of steps (the scipy backend used to run on for hours). With a budget of 200 steps the run
    # ends "failed" after exactly 200 accepted steps, its partial result kept.
    budget = 200
    monkeypatch.setattr(_run, "MAX_STEPS", budget)  # the backends read it at each run
    top = mett.presets.get("rutstam2013").replace(mu=1e9)
    traj = mett.simulate(top, mett.State(theta=0.1, omega3=155.0), 1e-3, backend="scipy",
                         method=method)  # fmt: skip
    assert traj.status == "failed"
    assert f"maximum number of steps ({budget}) reached" in traj.message
    assert traj.t.size == budget + 1  # the start and one sample per accepted step
    assert 0.0 < traj.t[-1] < 1e-3
    assert np.all(np.isfinite(traj.states))
    # the budget is the compiled backend's: with DOP853 both take the same steps and stop at
    # the same one
    if method == "DOP853":
        twin = mett.simulate(top, mett.State(theta=0.1, omega3=155.0), 1e-3, backend="compiled")
        assert twin.status == "failed" and twin.t.size == budget + 1
