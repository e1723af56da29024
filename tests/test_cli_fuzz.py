"""Fuzzing the `mett` command: every subcommand with malformed and extreme arguments.

The only claim checked is the command line's contract: a run either succeeds (exit 0, something on
stdout), ends a simulation that did not complete (exit 1, its status on stdout: ``simulate`` only),
or fails cleanly (exit 2, exactly one ``mett: error: ...`` line on stderr, no traceback); never
another exit status (70 is an internal error) and never a hang. Simulated times are kept tiny
and grids small so that every example is quick; the default run draws a few dozen examples per
subcommand and the ``slow`` run many more.
"""

from __future__ import annotations

import contextlib
import io
import math

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mett import presets
from mett.dynamics import MODELS
from mett.sweeps import GRID_NAMES

# --- values --------------------------------------------------------------------------------------
_EXTREMES = ["nan", "inf", "-inf", "0", "-0", "-1", "1e300", "-1e300", "1e-300", "1e155", "-1e155",
             "5e-324", "1.8e308"]  # fmt: skip
_MALFORMED = ["abc", "", " ", "1,5", "0x10", "1e", "--", "True", "None", "[1]", "½"]


def numbers(lo: float = -1e6, hi: float = 1e6) -> st.SearchStrategy[str]:
    """Numeric option values: extremes, malformed text, and ordinary floats in [lo, hi].

    The ordinary floats are bounded so that a valid run stays quick (a spin of 1e12 rad/s is
    valid but needs ~1e6 steps per millisecond); the extremes cover the overflow range.
    """
    return st.one_of(
        st.sampled_from(_EXTREMES + _MALFORMED),
        st.floats(lo, hi, allow_nan=False).map(repr),
        st.integers(-1000, 1000).map(str),
    )


def values(lo: float, hi: float) -> st.SearchStrategy[str]:
    """A plausible value in [lo, hi] half of the time, else an extreme or malformed one."""
    return st.one_of(st.floats(lo, hi).map(repr), numbers())


T_END = st.one_of(
    st.sampled_from(["1e-4", "1e-3", "2e-3", "1e-300"]),
    st.sampled_from(["0", "-1", "nan", "inf", "abc", ""]),
)
PRESETS = st.sampled_from([*presets.names(), "nope", ""])
MODEL_NAMES = st.sampled_from([*sorted(MODELS), "magic"])
# The default run keeps to the models whose compiled code every test session loads anyway (each
# further model costs a cache load of seconds on a busy machine) and to plots that are refused
# (drawing one costs a second); the slow run draws from all.
FAST_MODELS = st.sampled_from(["gliding", "rolling", "magic", ""])
BAD_PLOTS = st.sampled_from(["x.xyz", "/nonexistent-mett-dir/theta.png", "", "/", "theta"])

TOP = {"preset": (None, PRESETS)} | {
    name: (None, values(lo, hi))
    for name, lo, hi in (("m", 1e-3, 1.0), ("R", 1e-3, 0.1), ("alpha", 0.0, 1.0),
                         ("I1", 1e-7, 1e-4), ("I3", 1e-7, 1e-4), ("mu", 0.0, 2.0),
                         ("g", 0.1, 30.0))
}  # fmt: skip
STATE = {
    "theta0": ("0.1", values(0.0, math.pi)),
    "omega3": ("155", values(-500.0, 500.0)),
    "thetadot": (None, values(-50.0, 50.0)),
    "phidot": (None, values(-50.0, 50.0)),
}


def paths(tmp: str, suffixes: list[str]) -> st.SearchStrategy[str]:
    """Output paths: good ones in a temporary directory, missing directories, directories,
    files in place of directories, wrong suffixes, empty."""
    good = [f"{tmp}/out{s}" for s in suffixes]
    bad = ["/nonexistent-mett-dir/x" + suffixes[0], tmp, f"{tmp}/afile/x{suffixes[0]}",
           f"{tmp}/x.xyz", "", "/", f"{tmp}/missing/deeper/x{suffixes[0]}"]  # fmt: skip
    return st.one_of(st.sampled_from(good), st.sampled_from(bad))


def option(name: str, value: str) -> list[str]:
    """``--name value`` or ``--name=value`` (the second survives values that start with -)."""
    return [f"--{name}={value}"] if value.startswith("-") else [f"--{name}", value]


@st.composite
def perturbed(draw, options: dict, flags: tuple[str, ...] = ()) -> list[str]:
    """An argv from ``{name: (valid default or None, strategy)}``: the defaults, with a few
    options set from their strategies (valid, extreme or malformed), now and then one dropped,
    and some of ``flags``."""
    chosen = draw(st.lists(st.sampled_from(list(options)), max_size=3, unique=True))
    dropped = draw(st.sampled_from([None, *options])) if draw(st.integers(0, 9)) == 0 else None
    argv: list[str] = []
    for name, (default, strategy) in options.items():
        if name == dropped:
            continue
        if name in chosen:
            argv += option(name, draw(strategy))
        elif default is not None:
            argv += option(name, default)
    for flag in flags:
        if draw(st.booleans()):
            argv.append(flag)
    return argv


@st.composite
def top_args(draw) -> list[str]:
    if draw(st.integers(0, 3)):
        fields = {k: (None, v[1]) for k, v in TOP.items()} | {"preset": ("rutstam2013", PRESETS)}
    else:  # a top given field by field
        given = {"m": "0.02", "R": "0.02", "alpha": "0.3", "I1": "3e-6", "I3": "3.2e-6"}
        fields = {k: (given.get(k), v[1]) for k, v in TOP.items() if k != "preset"}
    return draw(perturbed(fields))


# --- one argv per subcommand ---------------------------------------------------------------------
@st.composite
def info_argv(draw, tmp: str, thorough: bool) -> list[str]:
    opts = {"theta0": (None, values(0.0, math.pi))}
    return ["info", *draw(top_args()), *draw(perturbed(opts, ("--json",)))]


@st.composite
def simulate_argv(draw, tmp: str, thorough: bool) -> list[str]:
    opts = STATE | {
        "t-end": ("1e-3", T_END),
        "model": (None, MODEL_NAMES if thorough else FAST_MODELS),
        "rtol": (None, st.one_of(st.sampled_from(["1e-6", "0.5", "1", "5", "1e-300"]), numbers())),
        "out": (None, paths(tmp, [".csv", ".npz"])),
        "plot": (None, paths(tmp, [".png", ".svg"]) if thorough else BAD_PLOTS),
    }
    return ["simulate", *draw(top_args()), *draw(perturbed(opts, ("--cm-at-rest", "--json")))]


@st.composite
def period_argv(draw, tmp: str, thorough: bool) -> list[str]:
    if draw(st.booleans()):
        opts = {
            "E": ("0.047", values(0.0, 0.2)),
            "D": ("5.3e-4", values(0.0, 2e-3)),
            "lam": ("1.75e-6", values(0.0, 1e-5)),
        }
        flags: tuple[str, ...] = ("--json",)
    else:
        opts = STATE
        flags = ("--json", "--cm-at-rest")
    return ["period", *draw(top_args()), *draw(perturbed(opts, flags))]


@st.composite
def predict_argv(draw, tmp: str, thorough: bool) -> list[str]:
    flags = ("--json", "--cm-at-rest")
    return ["predict", *draw(top_args()), *draw(perturbed(STATE, flags))]


@st.composite
def grid_spec(draw) -> str:
    name = draw(st.sampled_from(["mu", "omega3", "theta0", "gamma", "lam_ratio"]))
    if draw(st.integers(0, 4)) == 0:
        name = draw(st.sampled_from([*GRID_NAMES, "nope", ""]))
    start, stop = draw(values(0.0, 1.0)), draw(values(0.0, 3.0))
    num = draw(st.sampled_from(["1", "2", "1", "2", "0", "-1", "x", "2.5", ""]))
    form = draw(st.sampled_from(["full"] * 6 + ["log", "list", "no-eq", "two-parts"]))
    if form == "log":  # geometric spacing
        return f"{name}=log:{start}:{stop}:{num}"
    if form == "list":  # explicit values
        return f"{name}={start},{stop}"
    if form == "no-eq":
        return f"{name}{start}:{stop}:{num}"
    if form == "two-parts":
        return f"{name}={start}:{stop}"
    return f"{name}={start}:{stop}:{num}"


@st.composite
def sweep_argv(draw, tmp: str, thorough: bool) -> list[str]:
    opts = {
        "grid": ("mu=0.1:0.3:2", grid_spec()),
        "t-end": ("1e-3", T_END),
        "theta0": (None, values(0.0, math.pi)),
        "omega3": (None, values(-500.0, 500.0)),
        "model": (None, MODEL_NAMES if thorough else FAST_MODELS),
        "rtol": (None, values(1e-12, 1e-3)),
        "out": (f"{tmp}/sweep.csv", paths(tmp, [".csv"])),  # never sweep.csv in the cwd
        "workers": (None, st.sampled_from(["-3", "0", "1", "abc", "1e3", "5000"])),
        "checkpoint": (None, paths(tmp, [".jsonl"])),
        "scheduler": (
            None,
            st.sampled_from(
                ["tcp://127.0.0.1:1", "tcp://127.0.0.1", "127.0.0.1:99999", "tcp://:", "nonsense"]
            ),
        ),
    }
    argv = ["sweep", *draw(top_args()), *draw(perturbed(opts, ("--progress", "--no-progress")))]
    if draw(st.integers(0, 3)) == 0:  # a second grid dimension
        argv += option("grid", draw(grid_spec()))
    return argv


@st.composite
def figures_argv(draw, tmp: str, thorough: bool) -> list[str]:
    out = st.sampled_from([f"{tmp}/figs", tmp, f"{tmp}/afile", f"{tmp}/afile/sub", "",
                           "/nonexistent-mett/x"])  # fmt: skip
    opts = {"out": (f"{tmp}/figs", out)}
    argv = ["figures", *draw(perturbed(opts, ("--no-animation", "--quiet")))]
    if draw(st.booleans()):
        argv += draw(top_args())
    return argv


@st.composite
def any_argv(draw, tmp: str, thorough: bool) -> list[str]:
    """Wholly random word lists, to cover the parser itself."""
    words = st.one_of(
        st.sampled_from(["info", "simulate", "period", "sweep", "figures", "--json", "--help",
                         "--version", "--preset", "rutstam2013", "--t-end", "--grid", "-h", "--"]),
        numbers(),
        st.text(max_size=8),
    )  # fmt: skip
    return draw(st.lists(words, max_size=6))


COMMANDS = {
    "info": info_argv,
    "simulate": simulate_argv,
    "period": period_argv,
    "predict": predict_argv,
    "sweep": sweep_argv,
    "figures": figures_argv,
    "any": any_argv,
}


# --- the contract --------------------------------------------------------------------------------
def run(argv: list[str]) -> tuple[int, str, str]:
    from mett.cli import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = main(argv)
        except SystemExit as exc:  # argparse: usage errors, --help, --version
            code = exc.code
    return code, out.getvalue(), err.getvalue()


def check(argv: list[str]) -> None:
    code, out, err = run(argv)
    assert code in (0, 1, 2), f"mett {argv}: exit {code}\n{err}"
    if code == 1:  # only a simulation that ended failed or contact_lost, which it says
        assert argv[0] == "simulate", f"mett {argv}: exit 1\n{err}"
        assert ('"status": "failed"' in out or '"status": "contact_lost"' in out
                or out.startswith(("status                  failed",
                                   "status                  contact_lost"))), out  # fmt: skip
    assert "Traceback" not in err, f"mett {argv}:\n{err}"
    if "--progress" not in argv:  # asked for, a progress bar may animate; otherwise never
        assert "\r" not in out + err
    if code == 2:
        lines = err.strip().splitlines()
        assert len(lines) == 1, f"mett {argv}: {len(lines)} lines on stderr:\n{err}"
        assert lines[0].startswith("mett: error: "), f"mett {argv}: {err}"
    else:
        assert out.strip(), f"mett {argv}: exit {code} without output"
        if "--progress" not in argv:  # else a progress bar is on stderr too
            assert all(ln.startswith("mett: warning: ") for ln in err.strip().splitlines()), (
                f"mett {argv}: stray stderr:\n{err}"
            )


def _fake_generate(out_dir, *, top=None, animation=True, progress=False, **kw):
    """Stands in for the gallery (a minute per call): checks what the command passes."""
    from pathlib import Path

    from mett import TippeTop
    from mett.gallery import FIGURES

    assert top is None or isinstance(top, TippeTop)
    assert isinstance(animation, bool) and progress is False  # not a terminal: no progress bar
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"{next(iter(FIGURES))}.png"
    path.write_bytes(b"")
    return [path]


@pytest.fixture(scope="module")
def fuzz_dir(tmp_path_factory):
    d = tmp_path_factory.mktemp("cli_fuzz")
    (d / "afile").write_text("a file where a directory is expected")
    return str(d)


def _fuzz(command: str, tmp: str, n: int, *, thorough: bool) -> None:
    @settings(
        max_examples=n,
        deadline=None,
        derandomize=not thorough,
        suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
        database=None,
    )
    @given(argv=COMMANDS[command](tmp, thorough))
    def inner(argv: list[str]) -> None:
        check(argv)

    inner()


@pytest.fixture
def fake_gallery(monkeypatch, fuzz_dir):
    """The stand-in gallery, and the fuzz directory as the working directory (default outputs
    such as ./sweep.csv and ./figures land there)."""
    import mett.gallery

    monkeypatch.setattr(mett.gallery, "generate", _fake_generate)
    monkeypatch.chdir(fuzz_dir)


@pytest.mark.parametrize("command", list(COMMANDS))
def test_cli_fuzz(command, fuzz_dir, fake_gallery):
    # the same examples on every run (a CI failure reproduces); the slow run explores anew
    _fuzz(command, fuzz_dir, 30, thorough=False)


@pytest.mark.slow
@pytest.mark.parametrize("command", list(COMMANDS))
def test_cli_fuzz_many(command, fuzz_dir, fake_gallery):
    _fuzz(command, fuzz_dir, 400, thorough=True)


# --- cases found by fuzzing, kept as regressions --------------------------------------------------
@pytest.mark.parametrize(
    "argv",
    [
        ["period", "--preset", "rutstam2013", "--E", "1e300", "--D", "1e200", "--lam", "1"],
        ["simulate", "--preset", "rutstam2013", "--theta0", "0.1", "--omega3", "1e155",
         "--t-end", "0.01"],
        ["simulate", "--preset", "rutstam2013", "--theta0", "0.1", "--omega3", "155",
         "--t-end", "0.01", "--rtol", "1e-300"],
        ["simulate", "--preset", "rutstam2013", "--theta0", "0.1", "--omega3", "155",
         "--t-end", "0.01", "--R", "1e-300"],
        ["info", "--m", "0.02", "--R", "0.02", "--alpha", "0.3", "--I1", "3e-6", "--I3", "3.2e-6",
         "--g", "1e300", "--json"],
    ],
)  # fmt: skip
def test_extreme_inputs_end_cleanly(argv):
    check(argv)
