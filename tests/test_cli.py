"""The `mett` command, run as a user would (subprocess)."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest

from mett.friction import Coulomb, RegularisedCoulomb, Viscous


def run(*args: str) -> subprocess.CompletedProcess:
    # the timeout guards against a hang only: a fresh clone compiles its kernels in the first
    # call (`mett figures` took over 120 s on a loaded two-core machine with NUMBA_OPT=0)
    return subprocess.run(
        [sys.executable, "-m", "mett", *args], capture_output=True, text=True, timeout=1800
    )


# --- in-process: mett.cli.main(argv) -------------------------------------------------------------
def assert_one_line_error(out: subprocess.CompletedProcess, needle: str) -> None:
    """Bad arguments (a subprocess): exit status 2, one line on stderr naming the problem."""
    assert out.returncode == 2
    assert "Traceback" not in out.stderr
    assert len(out.stderr.strip().splitlines()) == 1, out.stderr
    assert needle in out.stderr


def call(argv, capsys) -> tuple[int, str, str]:
    """Run ``mett argv`` in this process: (exit status, stdout, stderr)."""
    from mett.cli import main

    try:
        code = main([str(a) for a in argv])
    except SystemExit as exc:  # argparse: usage errors, --help, --version
        code = exc.code
    out = capsys.readouterr()
    return code, out.out, out.err


def assert_error(result, needle: str) -> None:
    code, _, err = result
    assert code == 2, err
    assert "Traceback" not in err
    assert len(err.strip().splitlines()) == 1, err
    assert needle in err


def test_info_prints_thesis_thresholds():
    out = run("info", "--preset", "rutstam2013")
    assert out.returncode == 0, out.stderr
    lines = dict(line.rsplit(None, 1) for line in out.stdout.strip().splitlines())
    assert float(lines["gamma = I1/I3"]) == pytest.approx(131 / 140, rel=1e-6)
    assert float(lines["sigma = m R^2/I3"]) == pytest.approx(2.5)
    assert float(lines["lambda_thres [kg m^3/s]"]) == pytest.approx(3.43888e-06, rel=1e-5)
    assert lines["rational METT"] == "True"
    assert lines["group"] == "II"
    assert float(lines["min omega3 to invert from theta0=0.1 [rad/s]"]) == pytest.approx(
        77.31, abs=0.01
    )


def test_info_with_explicit_parameters():
    out = run(
        "info", "--m", "0.02", "--R", "0.02", "--alpha", "0.3", "--I1", "3e-6", "--I3", "3.2e-6"
    )
    assert out.returncode == 0, out.stderr
    assert "group" in out.stdout


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["info", "--preset", "nope"], "unknown preset 'nope'"),
        (["info", "--preset", "rutstam2013", "--alpha", "1.5"], "alpha must lie in (0, 1)"),
        (["info", "--preset", "rutstam2013", "--m", "abc"], "invalid float value"),
        (["info", "--preset", "maple-tippe-top"], "pass alpha"),
        (["info", "--m", "0.02"], "without --preset"),
        (["frobnicate"], "invalid choice"),
        ([], "required"),
    ],
)
def test_bad_arguments_give_one_line_and_exit_2(args, needle, capsys):
    assert_error(call(args, capsys), needle)


def test_simulate_prints_inversion_time_and_writes_outputs(tmp_path):
    csv, png = tmp_path / "traj.csv", tmp_path / "theta.png"
    out = run(
        "simulate", "--preset", "rutstam2013", "--theta0", "0.1", "--omega3", "155",
        "--t-end", "7", "--out", str(csv), "--plot", str(png),
    )  # fmt: skip
    assert out.returncode == 0, out.stderr
    lines = dict(line.split(None, 1) for line in out.stdout.splitlines() if "  " in line)
    assert float(out.stdout.split("first theta = pi/2 [s]")[1].split()[0]) == pytest.approx(
        5.88, abs=0.01
    )
    assert "inverted" in lines["predicted"]

    data = pd.read_csv(csv, comment="#")  # the column names carry their units
    assert data["theta [rad]"].iloc[0] == pytest.approx(0.1) and data["t [s]"].iloc[-1] == 7.0
    assert png.stat().st_size > 10_000


def test_period_from_a_state_and_from_integrals(capsys):
    state = [
        "period",
        "--preset",
        "rutstam2013",
        "--theta0",
        "1",
        "--omega3",
        "100",
        "--phidot",
        "5",
    ]
    code, out, err = call(state, capsys)
    assert code == 0, err
    assert "0.05501395" in out  # the rolling top's nutation period (docs/theory)
    code, out, err = call([*state, "--json"], capsys)
    data = json.loads(out)
    assert data["nutation_period"] == pytest.approx(0.05501395, abs=5e-9)
    E, D, lam = (repr(data[k]) for k in ("E_mod", "D", "lam"))
    code, out, err = call(
        ["period", "--preset", "rutstam2013", "--E", E, "--D", D, "--lam", lam, "--json"], capsys
    )
    assert code == 0, err
    assert json.loads(out)["nutation_period"] == pytest.approx(data["nutation_period"], rel=1e-12)


def test_figures_command_writes_every_figure(tmp_path):
    from mett.gallery import FIGURES

    out = run("figures", "--out", str(tmp_path), "--no-animation", "--quiet")
    assert out.returncode == 0, out.stderr
    for name in FIGURES:
        assert (tmp_path / f"{name}.png").stat().st_size > 5_000
    assert "thesis fig. 4a" in (tmp_path / "mett-figures.md").read_text()


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["simulate", "--preset", "rutstam2013", "--theta0", "0.1", "--omega3", "155"], "--t-end"),
        (["simulate", "--preset", "rutstam2013", "--theta0", "4", "--omega3", "1", "--t-end", "1"],
         "argument --theta0: must lie in [0, pi]"),
        (["simulate", "--preset", "rutstam2013", "--theta0", "0.1", "--omega3", "1", "--t-end", "-1"],
         "--t-end"),
        (["simulate", "--preset", "rutstam2013", "--theta0", "0.1", "--omega3", "1", "--t-end", "1",
          "--model", "magic"], "invalid choice"),
        (["simulate", "--preset", "rutstam2013", "--theta0", "0.1", "--omega3", "1", "--t-end", "1",
          "--out", "x.txt"], "--out must end in one of .csv, .npz, .nc"),
        (["period", "--preset", "rutstam2013", "--E", "0.001", "--D", "1e-3", "--lam", "1e-6"],
         "no admissible motion"),
        (["period", "--preset", "rutstam2013", "--E", "0.01"], "give all of --E --D --lam"),
        (["period", "--preset", "rutstam2013"], "give --E --D --lam"),
    ],
)  # fmt: skip
def test_bad_arguments_of_the_other_commands(args, needle, capsys):
    assert_error(call(args, capsys), needle)


THESIS = ["--preset", "rutstam2013"]
SIM = ["simulate", *THESIS, "--theta0", "0.1", "--omega3", "155", "--t-end", "0.05"]
SWEEP = ["sweep", *THESIS, "--grid", "mu=0.1:0.3:2", "--t-end", "0.05"]
SWEEP_LR = ["sweep", *THESIS, "--grid", "lam_ratio=0.5:2:2", "--t-end", "0.05"]


def test_version(capsys):
    import mett

    code, out, _ = call(["--version"], capsys)
    assert code == 0 and out.strip() == f"mett {mett.__version__}"


def test_help_shows_defaults(capsys):
    code, out, _ = call(["simulate", "--help"], capsys)
    assert code == 0
    out = " ".join(out.split())  # undo the line wrapping
    assert "--thetadot THETADOT θ̇(0) [rad/s] (default: 0.0)" in out
    assert "(default: 1e-10)" in out and "(default: gliding, or stemmed with --stem)" in out
    assert "(default: None)" not in out and "(default: False)" not in out
    code, out, _ = call(["sweep", "--help"], capsys)
    out = " ".join(out.split())
    assert "(default: sweep.csv)" in out and "(default: 1)" in out


def test_info_json_matches_the_library(capsys):
    from mett import presets
    from mett.thresholds import lambda_E, lambda_roll

    top = presets.get("rutstam2013")
    code, out, err = call(["info", *THESIS, "--json"], capsys)
    assert code == 0, err
    data = json.loads(out)
    assert data["I1"] == top.I1 and data["gamma"] == top.gamma and data["group"] == top.group
    assert data["lambda_thres"] == top.lambda_thres and data["lambda_E"] == lambda_E(top)
    assert data["lambda_roll"] == lambda_roll(top) and data["rational"] is True
    assert data["min_omega3_to_invert"]["omega3"] == pytest.approx(77.31, abs=0.01)
    assert data["units"]["lambda"] == "kg m^3/s"


def test_text_output_is_aligned(capsys):
    for argv in (["info", *THESIS], ["period", *THESIS, "--theta0", "1", "--omega3", "100"]):
        code, out, _ = call(argv, capsys)
        assert code == 0
        lines = out.splitlines()
        # every value starts in one column: after the longest label and two spaces
        col = max(len(ln.split("  ")[0]) for ln in lines) + 2
        assert all(ln[col - 2 : col] == "  " and ln[col] != " " for ln in lines), out


def test_period_with_the_centre_of_mass_at_rest(capsys):
    """--cm-at-rest: the METT energy is Ẽ (not E), and θ̇(0) = 0 makes θ0 a turning point."""
    import math

    import mett

    top = mett.presets.get("rutstam2013")
    code, out, err = call(
        ["period", *THESIS, "--theta0", "0.3", "--omega3", "155", "--cm-at-rest", "--json"], capsys
    )
    assert code == 0, err
    data = json.loads(out)
    state = mett.State.with_cm_at_rest(top, theta=0.3, omega3=155.0)
    assert data["E_mod"] == float(mett.modified_energy(top, state))
    # E would be the wrong energy: it differs by far more than the tolerance below
    assert abs(data["E_mod"] - float(mett.energy(top, state))) > 1e-3
    # Ẽ = V(z0) at θ̇ = 0: z0 = cos θ0 is one of the turning points
    assert min(abs(data["z_low"] - math.cos(0.3)), abs(data["z_high"] - math.cos(0.3))) < 1e-9


@pytest.mark.parametrize(
    ("argv", "needle"),
    [
        ([*SIM, "--out", "/nonexistent-dir/x.csv"], "--out: the directory"),
        ([*SIM, "--plot", "/nonexistent-dir/theta.png"], "--plot: the directory"),
        ([*SIM, "--plot", "theta.xyz"], "--plot must end in one of"),
        ([*SIM, "--out", "x.txt"], "--out must end in one of .csv, .npz, .nc"),
        ([*SIM, "--rtol", "5"], "argument --rtol: must lie in [2.22e-14, 0.01]"),
        ([*SIM, "--rtol", "nan"], "argument --rtol: must be a finite number"),
        ([*SIM[:-1], "0"], "argument --t-end: must lie in (0, inf)"),
        ([*SIM, "--theta0", "4"], "argument --theta0: must lie in [0, pi]"),
        ([*SIM, "--m", "inf"], "argument --m: must be a finite number"),
        ([*SWEEP, "--out", "/nonexistent-dir/dir/s.csv"], "--out: the directory"),
        ([*SWEEP, "--rtol", "5"], "argument --rtol: must lie in [2.22e-14, 0.01]"),
        ([*SWEEP, "--workers", "-3"], "argument --workers: must lie in [1, 4096]"),
        ([*SWEEP, "--grid", "mu=0:nan:3"], "--grid mu=0:nan:3: START and STOP must be finite"),
        ([*SWEEP, "--grid", "mu=0:1:-3"], "--grid mu=0:1:-3: NUM must lie in"),
        ([*SWEEP, "--grid", "mu=0:1:3"], "--grid 'mu' is given twice"),
        ([*SWEEP, "--scheduler", "tcp://127.0.0.1:1"], "cannot reach the Dask scheduler"),
        ([*SWEEP, "--scheduler", "tcp://127.0.0.1"], "tcp://HOST:PORT"),
        (["period", *THESIS, "--E", "1e300", "--D", "1e200", "--lam", "1"], "error:"),
        (["period", *THESIS, "--theta0", "0.1"], "give --E --D --lam"),
        (["info", *THESIS, "--theta0", "-1"], "argument --theta0: must lie in [0, pi]"),
        # an option the grid overrides would be ignored
        ([*SWEEP_LR, "--omega3", "150"], "--omega3 is ignored when --grid varies lam_ratio"),
        ([*SWEEP, "--mu", "0.3"], "--mu is ignored when --grid varies mu"),
        ([*SWEEP_LR, "--grid", "gamma=0.9:1:2", "--I1", "3e-6"],
         "--I1 is ignored when --grid varies gamma"),
        ([*SWEEP, "--grid", "theta0=0.1:0.2:2", "--theta0", "0.1"], "--theta0 is ignored"),
        # numbers in ASCII only
        ([*SIM, "--omega3", "١٥٥"], "argument --omega3: invalid float value"),
        ([*SIM, "--t-end", "1_000"], "argument --t-end: invalid float value"),
        ([*SWEEP, "--workers", "٢"], "argument --workers: invalid int value"),
        ([*SWEEP, "--workers", "1_0"], "argument --workers: invalid int value"),
        ([*SWEEP_LR, "--grid", "mu=0:1:1_0"], "NUM an integer; give mu=START:STOP:NUM"),
        # a negative number in scientific notation is a value, not an option
        ([*SIM, "--omega3", "-1e20", "--rtol", "5"], "argument --rtol: must lie in [2.22e-14, 0.01]"),
    ],
)  # fmt: skip
def test_errors_are_one_line_and_exit_2_before_any_work(argv, needle, capsys, monkeypatch):
    import mett.dynamics
    import mett.sweeps

    def no_work(*args, **kwargs):
        raise AssertionError("the command started working before rejecting its arguments")

    monkeypatch.setattr(mett.dynamics, "simulate", no_work)
    monkeypatch.setattr(mett.sweeps, "sweep", no_work)
    assert_error(call(argv, capsys), needle)


def test_paths_are_checked_before_the_run(tmp_path, capsys, monkeypatch):
    import mett.sweeps

    monkeypatch.chdir(tmp_path)
    (tmp_path / "ckpt").mkdir()
    calls = []
    monkeypatch.setattr(mett.sweeps, "sweep", lambda *a, **k: calls.append(1))
    assert_error(call([*SWEEP, "--checkpoint", "ckpt"], capsys), "--checkpoint must be a file")
    assert_error(call([*SWEEP, "--out", "ckpt"], capsys), "--out must be a file")
    assert_error(
        call([*SWEEP, "--checkpoint", "s.csv", "--out", "s.csv"], capsys), "must be different"
    )
    (tmp_path / "afile").write_text("x")
    assert_error(call(["figures", "--out", "afile"], capsys), "--out must be a directory")
    assert_error(call(["figures", "--out", "afile/sub"], capsys), "is a file")
    assert calls == []
    assert sorted(p.name for p in tmp_path.iterdir()) == ["afile", "ckpt"]


def test_simulate_writes_a_trajectory_that_loads(tmp_path, capsys):
    from mett import State, Trajectory

    path = tmp_path / "t.npz"
    code, out, err = call([*SIM, "--cm-at-rest", "--model", "gliding", "--out", path], capsys)
    assert code == 0, err
    traj = Trajectory.load(path)
    assert traj.status == "completed" and traj.t[-1] == 0.05 and traj.model == "gliding"
    assert traj.initial_state.nu_y != 0.0  # the --cm-at-rest start
    assert traj.initial_state.theta == State(theta=0.1).theta
    assert f"wrote                   {path}" in out


def test_simulate_json_agrees_with_the_library(capsys):
    import math

    import mett

    code, out, err = call([*SIM[:-1], "7", "--json"], capsys)
    assert code == 0, err
    data = json.loads(out)
    top = mett.presets.get("rutstam2013")
    traj = mett.simulate(top, mett.State(theta=0.1, omega3=155.0), 7.0)
    assert data["status"] == traj.status == "completed"
    assert data["t_invert"] == float(traj.crossings(math.pi / 2)[0])
    assert data["theta_end"] == float(traj.theta[-1]) and data["t_end"] == 7.0
    assert data["predicted"]["kind"] == "inverted" and data["prediction_error"] is None
    assert data["lambda_ratio"] == pytest.approx(2.00485, abs=1e-5)


def test_simulate_reports_a_failed_prediction_but_keeps_the_run(tmp_path, capsys, monkeypatch):
    import mett.classification

    def broken(top, lam):
        raise ValueError("no tumbling state\nbetween lambda_0 and lambda_thres")

    monkeypatch.setattr(mett.classification, "asymptotic_state", broken)
    code, out, err = call([*SIM, "--out", tmp_path / "t.csv"], capsys)
    assert code == 0, err
    assert "unavailable (no tumbling state between lambda_0 and lambda_thres)" in out
    assert (tmp_path / "t.csv").stat().st_size > 1000


def test_figures_preset_passes_the_top_to_the_gallery(tmp_path, capsys, monkeypatch):
    import mett.gallery
    from mett import presets

    seen = {}

    def fake_generate(out_dir, **kw):
        seen.update(kw, out_dir=out_dir)
        out_dir.mkdir(parents=True, exist_ok=True)  # as the real one does
        path = out_dir / f"{next(iter(mett.gallery.FIGURES))}.png"
        path.write_bytes(b"png")
        return [path]

    monkeypatch.setattr(mett.gallery, "generate", fake_generate)
    code, out, err = call(["figures", "--preset", "ueda2005", "--out", tmp_path / "f"], capsys)
    assert code == 0, err
    assert seen["top"] == presets.get("ueda2005") and seen["progress"] is False
    assert (tmp_path / "f" / "mett-figures.md").exists()
    seen.clear()
    code, _, _ = call(["figures", "--out", tmp_path / "g", "--no-animation"], capsys)
    assert code == 0 and "top" not in seen and seen["animation"] is False  # the thesis top
    code, _, _ = call(
        ["figures", "--preset", "rutstam2013", "--mu", "0.1", "--out", tmp_path], capsys
    )
    assert seen["top"] == presets.get("rutstam2013", mu=0.1)


class _Terminal:
    """A stand-in stderr that says it is a terminal."""

    def __init__(self, stream):
        self._stream = stream

    def isatty(self) -> bool:
        return True

    def __getattr__(self, name):
        return getattr(self._stream, name)


def test_progress_only_on_a_terminal_unless_asked(tmp_path, capsys, monkeypatch):
    import sys

    import pandas as pd

    import mett.sweeps

    seen = []

    def fake_sweep(top, grid, **kw):
        seen.append(kw["progress"])
        return pd.DataFrame({"simulated": ["inverted"], "agree": [True]})

    monkeypatch.setattr(mett.sweeps, "sweep", fake_sweep)
    out = ["--out", tmp_path / "s.csv"]
    assert call([*SWEEP, *out], capsys)[0] == 0  # captured stderr: not a terminal
    assert call([*SWEEP, *out, "--progress"], capsys)[0] == 0
    monkeypatch.setattr(sys, "stderr", _Terminal(sys.stderr))
    assert call([*SWEEP, *out], capsys)[0] == 0
    assert call([*SWEEP, *out, "--no-progress"], capsys)[0] == 0
    assert seen == [False, True, True, False]


def test_no_carriage_returns_in_a_log(tmp_path, capsys):
    code, out, err = call([*SWEEP, "--out", tmp_path / "s.csv"], capsys)
    assert code == 0, err
    assert "\r" not in out + err


def test_warnings_are_one_line_each(capsys):
    code, out, err = call(["info", "--preset", "maple-tippe-top", "--alpha", "0.3"], capsys)
    assert code == 0
    lines = err.strip().splitlines()
    assert lines and all(ln.startswith("mett: warning: ") for ln in lines), err
    assert "I3" in err


def test_traceback_option_shows_the_exception(capsys):
    from mett.cli import main

    with pytest.raises(ValueError, match="without --preset"):
        main(["--traceback", "info", "--m", "0.02"])


def test_backend_option_of_simulate_and_sweep(tmp_path, capsys):
    import mett
    from mett.sweeps import sweep

    code, out, err = call([*SIM[:-1], "7", "--json", "--backend", "taylor"], capsys)
    assert code == 0, err
    top = mett.presets.get("rutstam2013")
    traj = mett.simulate(top, mett.State(theta=0.1, omega3=155.0), 7.0, backend="taylor")
    assert json.loads(out)["t_invert"] == float(traj.crossings(np.pi / 2)[0])
    # the sweep on the Taylor backend: the table of the library's sweep with the same arguments
    path = tmp_path / "s.csv"
    code, out, err = call([*SWEEP, "--backend", "taylor", "--out", path], capsys)
    assert code == 0, err
    want = sweep(top, {"mu": np.linspace(0.1, 0.3, 2)}, t_end=0.05, backend="taylor",
                 progress=False)  # fmt: skip
    got = pd.read_csv(path, comment="#")
    np.testing.assert_array_equal(got["theta_end"], want["theta_end"])
    assert_error(call([*SIM, "--backend", "nope"], capsys), "invalid choice: 'nope'")


# --- exit statuses, the output streams, odd files ---------------------------------------------------
def test_a_run_that_does_not_complete_exits_1_with_its_results(tmp_path, capsys):
    import mett

    # started with θ̇ = 100 rad/s at θ = 1.5 the ball leaves the table at once
    argv = ["simulate", *THESIS, "--theta0", "1.5", "--omega3", "0", "--thetadot", "100",
            "--t-end", "1", "--stop-on-contact-loss"]  # fmt: skip
    ref = mett.simulate(mett.presets.get("rutstam2013"),
                        mett.State(theta=1.5, omega3=0.0, thetadot=100.0), 1.0,
                        stop_on_contact_loss=True)  # fmt: skip
    assert ref.status == "contact_lost"
    code, out, err = call([*argv, "--out", tmp_path / "t.csv"], capsys)
    assert code == 1, err
    assert out.startswith("status                  contact_lost") and err == ""
    assert (tmp_path / "t.csv").stat().st_size > 100  # the partial run, written
    code, out, _ = call([*argv, "--json"], capsys)
    assert code == 1 and json.loads(out)["status"] == "contact_lost"


@pytest.mark.slow  # the run fails only after its step budget: half a minute
def test_the_issue_s_failed_run_exits_1():
    out = run("simulate", *THESIS, "--theta0", "0.1", "--omega3", "155", "--t-end", "1e9", "--json")
    assert out.returncode == 1, out.stderr
    assert json.loads(out.stdout)["status"] == "failed"


def test_exit_statuses_are_in_the_help(capsys):
    from mett.cli import EXIT_STATUS

    code, out, _ = call(["--help"], capsys)
    assert code == 0
    text = " ".join(out.split())
    for status, meaning in EXIT_STATUS.items():
        assert f"{status} {meaning}" in text


def test_no_prediction_for_lambda_not_positive_says_so(capsys):
    # ω3 < 0 (written in scientific notation: a value, not an option): λ < 0
    code, out, err = call([*SIM, "--omega3", "-1.55e2", "--json"], capsys)
    assert code == 0, err
    data = json.loads(out)
    assert data["lambda"] < 0 and data["predicted"] is None
    assert "lambda" in data["prediction_error"] and "<= 0" in data["prediction_error"]
    code, out, err = call([*SIM, "--omega3=-155"], capsys)
    assert "predicted end state     unavailable (lambda = " in out


@pytest.mark.skipif(sys.platform == "win32", reason="POSIX pipes and file descriptors")
def test_a_closed_pipe_is_a_quiet_exit_141():
    import os

    r, w = os.pipe()
    os.close(r)  # the reader is gone before mett writes (as `| head -1` after its line)
    try:
        out = subprocess.run([sys.executable, "-m", "mett", "info", *THESIS], stdout=w,
                             stderr=subprocess.PIPE, text=True, timeout=120)  # fmt: skip
    finally:
        os.close(w)
    assert out.returncode == 141 and out.stderr == ""


@pytest.mark.skipif(sys.platform == "win32", reason="POSIX shell")
def test_a_closed_stdout_is_an_error_not_a_silent_success():
    cmd = f"exec {sys.executable} -m mett info --preset rutstam2013 --json >&-"
    out = subprocess.run(["sh", "-c", cmd], capture_output=True, text=True, timeout=120)
    assert_one_line_error(out, "standard output is closed")


@pytest.mark.skipif(not hasattr(__import__("os"), "mkfifo"), reason="POSIX FIFOs")
def test_a_fifo_or_dev_stdout_checkpoint_is_refused(tmp_path, capsys, monkeypatch):
    import os

    monkeypatch.chdir(tmp_path)
    os.mkfifo("fifo")
    assert_error(call([*SWEEP, "--checkpoint", "fifo"], capsys), "must be a regular file")
    # (a /dev that is not writable may be named first: either way, one line and nothing run)
    assert_error(call([*SWEEP, "--checkpoint", "/dev/stdout"], capsys), "checkpoint")
    assert sorted(os.listdir()) == ["fifo"]  # nothing written


def test_figures_never_replace_a_file_of_the_user_s(tmp_path, capsys, monkeypatch):
    import mett.gallery

    def fake_generate(out_dir, **kw):
        out_dir.mkdir(parents=True, exist_ok=True)
        path = out_dir / "energies.png"
        path.write_bytes(b"png")
        return [path]

    monkeypatch.setattr(mett.gallery, "generate", fake_generate)
    monkeypatch.chdir(tmp_path)
    (tmp_path / "README.md").write_text("# my project readme\n")
    code, out, err = call(["figures", "--out", "."], capsys)
    assert code == 0, err
    assert (tmp_path / "README.md").read_text() == "# my project readme\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["README.md", "energies.png",
                                                          "mett-figures.md"]  # fmt: skip
    assert set(p.name for p in tmp_path.iterdir()) - {"README.md"} <= set(mett.gallery.file_names())


def test_the_repository_figure_index_is_the_one_mett_writes():
    # docs/figures (the gallery's reference images, regenerated on purpose with `mett figures
    # --out docs/figures`) holds the index under mett's name, as generated; the README's main job
    # writes figures/, which is not tracked, so a fresh clone stays clean after it
    from pathlib import Path

    from mett import gallery

    root = Path(__file__).resolve().parents[1] / "docs" / "figures"
    assert not (root / "README.md").exists()
    paths = [root / f"{n}.png" for n in gallery.FIGURES] + [root / "deforming_potential.gif"]
    assert (root / gallery.INDEX_NAME).read_text() == gallery.index_markdown(paths)
    assert all(p.exists() for p in paths)


def test_a_grid_product_over_the_maximum_is_one_line(tmp_path, capsys):
    # each axis within the per-axis cap, the product 10¹⁰ points: refused before any point
    argv = ["sweep", *THESIS, "--grid", "mu=0:1:100000", "--grid", "lam_ratio=0.5:2:100000",
            "--t-end", "1", "--out", tmp_path / "s.csv"]  # fmt: skip
    assert_error(call(argv, capsys), "100000 x 100000 = 10000000000 points; at most MAX_POINTS")
    assert list(tmp_path.iterdir()) == []


# --- every model and friction law from the command line ----------------------------------------------
LAW_FORMS = [
    ("viscous:0.3", Viscous(0.3)),
    ("coulomb:0.3", Coulomb(0.3)),
    ("coulomb-contensou:0.3,5e-4", Coulomb(0.3, contensou_radius=5e-4)),
    ("regularised:0.3,1e-3", RegularisedCoulomb(0.3, eps=1e-3)),
]


@pytest.mark.parametrize(("spec", "direct"), LAW_FORMS)
def test_each_friction_form_is_the_law_built_directly(spec, direct):
    from mett.cli import _build_parser

    args = _build_parser().parse_args([*SIM, "--friction", spec])
    assert args.friction == direct and type(args.friction) is type(direct)


def test_every_law_of_the_name_table_is_accepted_by_its_name(capsys):
    # the CLI has no list of its own: a law added to mett.friction.LAWS is a --friction form
    from mett.cli import _build_parser
    from mett.friction import LAWS

    for name, form in LAWS.items():
        spec = f"{name}:" + ",".join(["0.25"] * len(form.args))
        law = _build_parser().parse_args([*SIM, "--friction", spec]).friction
        assert law == form.law(*[0.25] * len(form.args))
    code, out, err = call(["simulate", "--help"], capsys)
    assert code == 0 and all(form.spelled(n) in " ".join(out.split()) for n, form in LAWS.items())


def _cli_and_library(tmp_path, capsys, extra, **kw):
    """The trajectory of ``mett simulate ... extra --out t.npz`` and of mett.simulate(**kw)."""
    import mett

    path = tmp_path / "t.npz"
    code, _, err = call([*SIM[:-1], "0.02", *extra, "--out", path], capsys)
    assert code == 0, err
    top = kw.pop("top", mett.presets.get("rutstam2013"))
    state = kw.pop("state", mett.State(theta=0.1, omega3=155.0))
    return mett.Trajectory.load(path), mett.simulate(top, state, 0.02, **kw)


@pytest.mark.parametrize(
    ("extra", "model", "law"),
    [
        ([], None, None),
        (["--friction", "viscous:0.3"], None, Viscous(0.3)),
        (["--friction", "coulomb:0.3"], None, Coulomb(0.3)),
        (["--model", "coulomb", "--friction", "coulomb:0.3"], "coulomb", Coulomb(0.3)),
        (["--model", "coulomb-contensou", "--friction", "coulomb-contensou:0.3,5e-4"],
         "coulomb-contensou", Coulomb(0.3, contensou_radius=5e-4)),
        (["--model", "coulomb-regularised", "--friction", "regularised:0.3,1e-3"],
         "coulomb-regularised", RegularisedCoulomb(0.3, eps=1e-3)),
        (["--model", "rolling"], "rolling", None),
        (["--model", "gliding-hst", "--friction", "viscous:0.2"], "gliding-hst", Viscous(0.2)),
        (["--model", "gliding-euler"], "gliding-euler", None),
        (["--model", "frictionless-routhian"], "frictionless-routhian", None),
    ],
)  # fmt: skip
def test_each_model_and_law_runs_as_the_library_does(tmp_path, capsys, extra, model, law):
    kw = {} if model is None else {"model": model}
    if law is not None:
        kw["friction"] = law
    got, want = _cli_and_library(tmp_path, capsys, extra, **kw)
    assert got.model == want.model and got.status == want.status == "completed"
    np.testing.assert_array_equal(got.t, want.t)
    np.testing.assert_array_equal(got.states, want.states)  # same process: bit for bit


def test_the_cylinder_runs_on_its_subspace(tmp_path, capsys):
    import mett

    path = tmp_path / "c.npz"
    argv = ["simulate", *THESIS, "--theta0", "0.5", "--omega3", "0", "--t-end", "0.02",
            "--model", "cylinder", "--out", path]  # fmt: skip
    code, _, err = call(argv, capsys)
    assert code == 0, err
    want = mett.simulate(mett.presets.get("rutstam2013"), mett.State(theta=0.5, omega3=0.0),
                         0.02, model="cylinder")  # fmt: skip
    np.testing.assert_array_equal(mett.Trajectory.load(path).states, want.states)


@pytest.mark.parametrize(
    ("extra", "model", "law"),
    [
        ([], "stemmed", None),
        (["--model", "stemmed", "--friction", "coulomb:0.3"], "stemmed", Coulomb(0.3)),
        (["--model", "stemmed-coulomb", "--friction", "coulomb:0.3"], "stemmed-coulomb",
         Coulomb(0.3)),
        (["--model", "stemmed-coulomb-contensou", "--friction", "coulomb-contensou:0.3,5e-4"],
         "stemmed-coulomb-contensou", Coulomb(0.3, contensou_radius=5e-4)),
    ],
)  # fmt: skip
def test_a_stemmed_run_with_stem(tmp_path, capsys, extra, model, law):
    import mett

    ball = mett.presets.get("rutstam2013")
    kw = {} if law is None else {"friction": law}
    if model == "stemmed":  # the library's way: a StemmedTop
        kw.update(top=ball.with_stem(0.005, 0.02))
    else:
        kw.update(model=model, stem_radius=0.005, stem_distance=0.02)
    got, want = _cli_and_library(tmp_path, capsys, ["--stem", "0.005,0.02", *extra], **kw)
    assert got.model == want.model and got.model.startswith("stemmed")
    np.testing.assert_array_equal(got.states, want.states)


@pytest.mark.parametrize(
    ("extra", "needle"),
    [
        (["--friction", "bogus:0.3"], "argument --friction: invalid value 'bogus:0.3'; give one of"),
        (["--friction", "coulomb:0.3,1"], "coulomb-contensou:MU,CONTENSOU_RADIUS [1, m]"),
        (["--friction", "regularised:0.3"], "regularised:MU,EPS [1, m/s]"),
        (["--friction", "viscous:abc"], "viscous:MU [s/m]"),
        (["--friction", "coulomb"], "invalid value 'coulomb'"),
        (["--friction", "coulomb:-0.3"], "argument --friction: mu must lie in [0, inf)"),
        (["--friction", "regularised:0.3,0"], "argument --friction: eps must lie in (0, inf)"),
        (["--model", "coulomb"], "--model coulomb takes --friction coulomb:MU or "
         "coulomb-contensou:MU,CONTENSOU_RADIUS: model 'coulomb' needs friction="
         "mett.friction.Coulomb(mu); got None"),
        (["--model", "coulomb-regularised", "--friction", "viscous:0.3"], "regularised:MU,EPS"),
        (["--model", "rolling", "--friction", "coulomb:0.3"],
         "--model rolling takes --friction viscous:MU (or no --friction)"),
        (["--model", "stemmed"], "--model stemmed needs --stem RADIUS,DISTANCE"),
        (["--model", "stemmed-coulomb", "--friction", "coulomb:0.3"], "needs --stem"),
        (["--model", "gliding", "--stem", "0.005,0.02"], "--stem applies to --model stemmed, "),
        (["--stem", "0.005"], "argument --stem: give RADIUS,DISTANCE"),
        (["--stem", "0.005,-1"], "argument --stem: RADIUS,DISTANCE (m): must lie in (0, inf)"),
        (["--stem", "0.005,0.001"], "distance must exceed |R - radius|"),
        (["--friction", "coulomb:0.3", "--mu", "0.2"], "--mu is ignored with --friction"),
    ],
)  # fmt: skip
def test_bad_friction_model_and_stem_forms_exit_2_with_one_line(extra, needle, capsys, monkeypatch):
    import mett.dynamics

    monkeypatch.setattr(mett.dynamics, "simulate", lambda *a, **k: pytest.fail("ran"))
    assert_error(call([*SIM, *extra], capsys), needle)


def test_every_registered_model_runs_or_is_refused_with_one_line(capsys, monkeypatch):
    # without --friction and --stem: each model either starts its run or says what it needs
    import mett.dynamics
    from mett.dynamics import MODELS

    ran = []
    monkeypatch.setattr(mett.dynamics, "simulate", lambda *a, **k: ran.append(k) or 1 / 0)
    for name in MODELS:
        code, _, err = call([*SIM, "--model", name], capsys)
        if ran and ran[-1].get("model") == name:
            continue  # it ran (and the stand-in failed)
        assert code == 2 and len(err.strip().splitlines()) == 1, (name, err)
        assert f"--model {name} " in err and ("--friction" in err or "--stem" in err), err


def test_sweep_with_a_fixed_law_is_the_library_s_sweep(tmp_path, capsys):
    import mett

    path = tmp_path / "s.csv"
    code, _, err = call(["sweep", *THESIS, "--grid", "theta0=0.1:0.2:2", "--t-end", "0.02",
                         "--friction", "coulomb:0.3", "--out", path], capsys)  # fmt: skip
    assert code == 0, err
    want = mett.sweep(mett.presets.get("rutstam2013"), {"theta0": np.linspace(0.1, 0.2, 2)},
                      t_end=0.02, friction=Coulomb(0.3), progress=False)  # fmt: skip
    np.testing.assert_array_equal(pd.read_csv(path, comment="#")["theta_end"], want["theta_end"])
    # a grid axis mu with a law that fixes mu: refused as the library refuses it
    with pytest.raises(ValueError, match="fixes mu") as lib:
        mett.sweep(mett.presets.get("rutstam2013"), {"mu": [0.1, 0.2]}, t_end=0.02,
                   friction=Coulomb(0.3))  # fmt: skip
    result = call([*SWEEP, "--friction", "coulomb:0.3", "--out", path], capsys)
    assert_error(result, str(lib.value))


def test_sweep_of_a_stemmed_top(tmp_path, capsys):
    import mett

    path = tmp_path / "s.csv"
    code, _, err = call(["sweep", *THESIS, "--grid", "theta0=0.1:0.2:2", "--t-end", "0.02",
                         "--stem", "0.005,0.02", "--out", path], capsys)  # fmt: skip
    assert code == 0, err
    want = mett.sweep(mett.presets.get("rutstam2013"), {"theta0": np.linspace(0.1, 0.2, 2)},
                      t_end=0.02, model="stemmed", stem_radius=0.005, stem_distance=0.02,
                      progress=False)  # fmt: skip
    np.testing.assert_array_equal(pd.read_csv(path, comment="#")["theta_end"], want["theta_end"])
    assert_error(call([*SWEEP, "--model", "stemmed", "--out", path], capsys), "needs --stem")


@pytest.mark.parametrize(
    ("extra", "law", "stemmed"),
    [
        ([], None, True),
        (["--friction", "coulomb-contensou:0.3,5e-4"], Coulomb(0.3, contensou_radius=5e-4), True),
        (["--model", "stemmed"], None, True),
        (["--model", "gliding"], None, False),
    ],
)  # fmt: skip
def test_a_preset_with_a_stem_simulates_with_it(tmp_path, capsys, extra, law, stemmed):
    """`mett simulate --preset friedl1997` runs the StemmedTop of mett.presets.stemmed (any
    --friction), as the library does; an explicit model without a stem runs the ball alone."""
    import mett

    path = tmp_path / "t.npz"
    argv = ["simulate", "--preset", "friedl1997", "--theta0", "0.1", "--omega3", "180",
            "--t-end", "0.02", *extra, "--out", path]  # fmt: skip
    code, _, err = call(argv, capsys)
    assert code == 0, err
    got = mett.Trajectory.load(path)
    top = mett.presets.stemmed("friedl1997") if stemmed else mett.presets.get("friedl1997")
    kw = {} if law is None else {"friction": law}
    want = mett.simulate(top, mett.State(theta=0.1, omega3=180.0), 0.02, **kw)
    assert got.model == want.model and got.model.startswith("stemmed") == stemmed
    np.testing.assert_array_equal(got.states, want.states)


# --- mett predict --method -----------------------------------------------------------------------
PREDICT = [
    "predict",
    "--preset",
    "rutstam2013",
    "--theta0",
    "0.1",
    "--omega3",
    "155",
    "--cm-at-rest",
]


def test_predict_method_selects_the_reduction(capsys):
    """`--method` is passed to mett.predict_inversion: gyroscopic (the default) gives the
    library's numbers bit for bit; averaged gives the averaged flow's own (a different
    reduction: its path has its own nodes), within 5 % of the balance flow's t_half on this start
    (docs/theory/inversion.md: both 5.074 s, simulated 5.067 s)."""
    import mett

    top = mett.presets.get("rutstam2013")
    state = mett.State.with_cm_at_rest(top, theta=0.1, omega3=155.0)
    want = mett.predict_inversion(top, state)
    code, out, err = call([*PREDICT, "--json"], capsys)
    assert code == 0, err
    default = json.loads(out)
    code, out, err = call([*PREDICT, "--method", "gyroscopic", "--json"], capsys)
    assert code == 0, err
    assert json.loads(out) == default
    assert default["method"] == "gyroscopic" and default["t_half"] == want.t_half
    code, out, err = call([*PREDICT, "--method", "averaged", "--json"], capsys)
    assert code == 0, err
    avg = json.loads(out)
    assert avg["method"] == "averaged" and avg["inverts"] is True
    assert avg["t_half"] == mett.predict_inversion(top, state, method="averaged").t_half
    assert avg["t_half"] != want.t_half
    assert avg["t_half"] == pytest.approx(want.t_half, rel=0.05)


@pytest.mark.parametrize("value", ["nope", "Averaged", ""])
def test_predict_unknown_method_is_one_line_exit_2(value, capsys):
    assert_error(call([*PREDICT, "--method", value], capsys), "--method")


def test_predict_with_a_stemmed_preset_says_it_predicts_the_ball_alone(capsys):
    """`mett simulate --preset friedl1997` runs the stemmed top; `mett predict` cannot (its
    reduction has one contact), so it predicts the ball and says so in its notes, naming the
    stem; a preset without a stem gets no such note."""
    import mett

    argv = ["predict", "--theta0", "0.1", "--omega3", "180", "--cm-at-rest", "--json"]
    code, out, err = call([*argv, "--preset", "friedl1997"], capsys)
    assert code == 0, err
    got = json.loads(out)
    ball = mett.presets.get("friedl1997")
    want = mett.predict_inversion(ball, mett.State.with_cm_at_rest(ball, theta=0.1, omega3=180.0))
    assert got["t_half"] == want.t_half
    assert any("has a stem" in n and "ball alone" in n for n in got["notes"])
    code, out, err = call([*argv, "--preset", "rutstam2013"], capsys)
    assert code == 0, err
    assert not any("has a stem" in n for n in json.loads(out)["notes"])
