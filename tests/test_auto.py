"""``backend="auto"``, the default of simulate: the fastest backend that is exact for the run.

The choice follows what the model and its friction law declare (a law's ``analytic``, an event's
``grazing``, a right-hand side the Taylor tracer can represent), never their names: checked here
on every registered model without integrating, and on models and laws built by the test. The
accuracy claims are checked against independent runs: the thesis inversion time at a tenfold
tighter tolerance, and the compiled DOP853 (another method, another step rule), with a tolerance
from the error analysis of both (below).
"""

from __future__ import annotations

import dataclasses
import math
import os
import subprocess
import sys
import time
from pathlib import Path
from typing import ClassVar

import pytest

import mett
from mett import friction
from mett.dynamics import MODELS, backends, registry, simulation

TOP = mett.presets.get("rutstam2013")
THESIS = mett.State(theta=0.1, omega3=155.0)
# a Leine–Glocker-like body with a stem, just before touchdown (the stem tests' start)
STEMMED = mett.TippeTop(m=0.006, R=0.015, alpha=0.2, I1=8e-7, I3=7e-7, mu=0.3).with_stem(
    radius=0.005, distance=0.016
)
STEM_START = mett.State(theta=2.15, thetadot=2.0, phidot=110.0, omega3=-76.0, nu_y=0.16)
EPS = 2.220446049250313e-16


def _chosen(top, state=THESIS, **kw):
    """The backend ``simulate(top, state, 1.0, **kw)`` would run (prepared, not integrated)."""
    prep = simulation.prepare_run(top, state, 1.0, **{**simulation.SIMULATE_DEFAULTS, **kw})
    return prep.run.backend


@pytest.mark.parametrize(
    ("kw", "backend"),
    [
        ({}, "taylor"),  # the viscous gliding top
        ({"model": "rolling"}, "taylor"),
        ({"model": "gliding-hst"}, "taylor"),
        ({"model": "gliding-euler"}, "taylor"),
        ({"model": "frictionless-routhian"}, "taylor"),
        ({"friction": friction.RegularisedCoulomb(0.3, 1e-3)}, "taylor"),
        ({"friction": friction.Coulomb(0.3)}, "compiled"),  # slip direction at a switch
        ({"friction": friction.Coulomb(0.3, contensou_radius=1e-3)}, "compiled"),
        ({"method": "RK45"}, "scipy"),
        ({"method": "LSODA", "friction": friction.Coulomb(0.3)}, "scipy"),
    ],
)
def test_auto_picks_taylor_for_analytic_runs_and_dop853_where_taylor_is_not_exact(kw, backend):
    assert _chosen(TOP, **kw) == backend


def test_every_registered_model_gets_a_backend_by_its_declarations():
    # each model with the law it runs: the choice must follow the declarations alone
    laws = {"coulomb": friction.Coulomb(0.3), "coulomb-contensou": friction.Coulomb(0.3, 1e-3),
            "coulomb-regularised": friction.RegularisedCoulomb(0.3, 1e-3),
            "rolling-resistance": mett.dynamics.resistance.RollingResistance(1e-4)}  # fmt: skip
    starts = {"cylinder": mett.State(theta=0.5, thetadot=2.0, nu_x=0.01)}
    tay = backends.REGISTRY["taylor"]
    for name in MODELS:
        if name.startswith("stemmed"):
            continue  # a StemmedTop's models: below
        law = laws.get(name)
        kw = {"model": name} if law is None else {"friction": law}
        prep = simulation.prepare_run(TOP, starts.get(name, THESIS), 1.0,
                                      **{**simulation.SIMULATE_DEFAULTS, **kw})  # fmt: skip
        analytic = law is None or type(law).analytic
        grazing = any(ev.grazing for ph in prep.model.phase_table() for ev in ph.events)
        expected = "taylor" if analytic and not grazing else "compiled"
        assert prep.run.backend == expected, name
        why = tay.inexact(prep.model, prep.params, prep.run.options, prep.y0.size)
        assert (why is None) == (expected == "taylor"), (name, why)


def test_the_stemmed_top_runs_taylor_between_impacts_and_dop853_under_dry_friction():
    viscous = mett.simulate(STEMMED, STEM_START, 0.01)
    dry = mett.simulate(STEMMED, STEM_START, 0.01, friction=friction.Coulomb(0.3))
    assert (viscous.model, viscous.backend) == ("stemmed", "taylor")
    assert (dry.model, dry.backend) == ("stemmed-coulomb", "compiled")


@dataclasses.dataclass(frozen=True)
class _UndeclaredViscous(friction.Viscous):
    """A law that says nothing about analyticity: auto must not assume it."""

    analytic: ClassVar[bool] = False


def test_a_law_or_event_or_rhs_taylor_cannot_represent_sends_auto_to_dop853():
    gliding = MODELS["gliding"]
    tay = backends.REGISTRY["taylor"]
    p = gliding.params(TOP, {})
    assert tay.inexact(gliding, p, {}, 10) is None
    assert "not analytic" in tay.inexact(gliding, p, {"friction": _UndeclaredViscous(0.3)}, 10)
    # a grazing event: located only by the compiled DOP853 inside a step
    ev = gliding.events[0]
    grazing = dataclasses.replace(
        gliding, name="grazing-test", events=(dataclasses.replace(ev, grazing=True),)
    )
    assert "grazing" in tay.inexact(grazing, p, {}, 10)
    assert mett.simulate(TOP, THESIS, 0.01, model=grazing).backend == "compiled"

    # a right-hand side that branches on the state: numba compiles it, the tracer cannot
    def branchy_into(t, y, q, out):
        gliding.rhs_into(t, y, q, out)
        if y[9] > 2.0:  # never true (3̂_z ≤ 1): the same equations, but a branch on the state
            out[0] = 0.0

    branchy = dataclasses.replace(gliding, name="branchy-test", rhs_into=branchy_into)
    assert "cannot be traced" in tay.inexact(branchy, p, {}, 10)
    assert backends.choose(branchy, "DOP853", p, {}, 10) == "compiled"


def _first_principles_choice(model, method, params, options, n_state, user_events=False):
    """backend="auto" by its definition: the first backend of AUTO that accepts the run and is
    exact for it (asked afresh, nothing remembered)."""
    for name in backends.AUTO:
        if user_events and name == "taylor":
            continue
        b = backends.REGISTRY[name]
        if b.accepts(model, method) and b.inexact(model, params, options, n_state) is None:
            return name
    return "scipy"


def test_the_remembered_choice_is_the_choice_asked_afresh_for_every_model_law_and_method():
    # choose remembers what does not depend on the parameters (per model, method, kind of law);
    # the tracer's verdict, which may, is asked per call: a model whose right-hand side branches
    # on the state only for some parameters runs Taylor until such parameters come
    gliding = MODELS["gliding"]

    def sometimes_branchy_into(t, y, q, out):
        gliding.rhs_into(t, y, q, out)
        if q[5] > 1.0 and y[9] > 2.0:  # a branch on the state, reached only when mu > 1
            out[0] = 0.0

    picky = dataclasses.replace(gliding, name="picky-test", rhs_into=sometimes_branchy_into)
    # Taylor while the parameters keep it off the state's branch; once it is reached, the
    # tracer's "no" holds for every parameter set (backends._TRACED)
    assert backends.choose(picky, "DOP853", gliding.params(TOP, {}), {}, 10) == "taylor"
    p2 = gliding.params(TOP.replace(mu=2.0), {})
    assert backends.choose(picky, "DOP853", p2, {}, 10) == "compiled"
    laws = [None, friction.Viscous(0.2), friction.Coulomb(0.3), _UndeclaredViscous(0.3)]
    models = [*MODELS.values(), picky]
    checked = set()
    for mu in (0.3, 2.0, 0.3):
        top = TOP.replace(mu=mu)
        for model in models:
            try:  # the model's own parameters and state size (with its default options)
                p = model.params(top, registry.validate_options(model, {}))
                n = len(model.initial(THESIS, p))
            except (ValueError, TypeError, KeyError):
                continue  # a model that needs options or another top: its own tests
            for method in ("DOP853", "Radau"):
                for law in laws:
                    for user in (False, True):
                        opts = {} if law is None else {"friction": law}
                        args = (model, method, p, opts, n, user)
                        assert backends.choose(*args) == _first_principles_choice(*args), (
                            model.name,
                            mu,
                            method,
                            law,
                            user,
                        )
            checked.add(model.name)
    assert {"gliding", "rolling", "picky-test"} <= checked


def _first_half(traj):
    return float(traj.crossings(math.pi / 2)[0])


def test_the_default_run_is_converged_and_agrees_with_dop853():
    """At the default rtol the thesis run's first θ = π/2 moves < 1e-4 s when rtol is tightened
    tenfold (the claim of simulate's docstring), and agrees with the compiled DOP853 at the same
    rtol to the error both may make.

    The bound: each step keeps its local error below rtol times the state's scale; over n steps
    the errors add up at most linearly (the run is not chaotic over 6 s: its nutation is
    damped), so the state is known to n · rtol relative, and the crossing time, reached at a rate
    ~1/t_cross of the state's scale, to n · rtol · t_cross. Each run contributes its own n; the
    event location adds its 4 ulps. A sign error in either integrator, or a Taylor order too low
    for rtol, moves the crossing by far more (milliseconds)."""
    default = mett.simulate(TOP, THESIS, t_end=7.0)
    tight = mett.simulate(TOP, THESIS, t_end=7.0, rtol=1e-11)
    assert default.backend == tight.backend == "taylor"
    t_def, t_tight = _first_half(default), _first_half(tight)
    assert abs(t_def - t_tight) < 1e-4

    rtol = simulation.SIMULATE_DEFAULTS["rtol"]
    dop = mett.simulate(TOP, THESIS, t_end=7.0, backend="compiled")
    t_dop = _first_half(dop)
    bound = (default.t.size + dop.t.size) * rtol * t_dop + 8 * EPS * t_dop
    assert abs(t_def - t_dop) < bound, (t_def - t_dop, bound)
    # the tighter Taylor run is nearer the DOP853 one than the bound of the default run
    assert abs(t_tight - t_dop) < bound


# --- first use: the kernels are built once, safely, with a notice; `mett warmup` --------------


def test_warmup_builds_what_the_first_runs_use_and_reports_each_task():
    from mett.dynamics.warmup import WARMUP_MODELS, warmup

    lines: list[str] = []
    done = warmup(("gliding",), progress=lines.append)
    assert [(label, backend) for label, backend, _ in done] == [
        ("gliding top, simulate", "taylor"),
        ("gliding top, sweep lanes", "taylor (SIMD lanes)"),
        ("flight and landing kernels", "numba"),
    ]
    assert all(seconds >= 0.0 for *_, seconds in done)
    assert lines[0] == "[1/3] gliding top, simulate ..." and lines[-1].startswith("[3/3] flight")
    with pytest.raises(ValueError, match="models must be names of"):
        warmup(("nope",))
    assert "coulomb" in WARMUP_MODELS


def test_mett_warmup_prints_its_progress(capsys):
    from mett.cli import main

    assert main(["warmup", "--model", "gliding"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("mett warmup: building gliding at rtol 1e-10")
    assert out[-1].startswith("mett warmup: done, 3 tasks in")


_FIRST_RUN = """
import sys, time
from pathlib import Path
import mett
from mett.dynamics.taylor import _llvm
go = Path(sys.argv[1])
while not go.exists():  # both processes start compiling together
    time.sleep(0.001)
traj = mett.simulate(mett.presets.get("rutstam2013"), mett.State(theta=0.1, omega3=155.0), 0.5,
                     rtol=1e-9)
print(traj.backend, repr(float(traj.theta[-1])), sorted(set(_llvm._SOURCES.values())))
"""


def _env(cache: Path) -> dict:
    return {**os.environ, "METT_CACHE_DIR": str(cache), "PYTHONPATH": os.pathsep.join(sys.path)}


def test_two_processes_building_the_same_kernel_at_once_neither_corrupt_nor_half_read(tmp_path):
    # a fresh kernel cache: both processes compile the same Taylor jet and write it at once
    # (atomic write + rename, the object before its record; a reader checks the sha256); a third
    # process then loads it. All three must get the same run, bit for bit.
    cache, go = tmp_path / "cache", tmp_path / "go"
    cmd = [sys.executable, "-c", _FIRST_RUN, str(go)]
    pipes = {"stdout": subprocess.PIPE, "stderr": subprocess.PIPE, "text": True}
    procs = [subprocess.Popen(cmd, env=_env(cache), **pipes) for _ in range(2)]
    time.sleep(0.5)
    go.touch()
    outs = [p.communicate(timeout=600) for p in procs]
    for p, (_, err) in zip(procs, outs, strict=True):
        assert p.returncode == 0, err
        assert "mett: compiling" not in err  # stderr is a pipe: no notice
    runs = [out.split(" ", 2)[:2] for out, _ in outs]
    assert runs[0] == runs[1] and runs[0][0] == "taylor"
    assert all("'loaded'" in out or "'written'" in out for out, _ in outs)
    third = subprocess.run([sys.executable, "-c", _FIRST_RUN, str(go)], env=_env(cache),
                           capture_output=True, text=True, timeout=600, check=True)  # fmt: skip
    assert third.stdout.split(" ", 2)[:2] == runs[0]
    assert "['loaded']" in third.stdout  # read back whole and verified, not rebuilt
    files = sorted(f.name for f in (cache / "taylor").iterdir())
    assert not [f for f in files if f.endswith(".tmp")]  # no temporary left behind
    assert len(files) == 2 and files[1] == files[0] + ".json"


@pytest.mark.skipif(not hasattr(os, "openpty"), reason="needs a pseudo-terminal")
def test_a_terminal_hears_one_line_while_a_kernel_compiles(tmp_path):
    # (a pipe hears nothing: the racing processes above)
    master, slave = os.openpty()
    go = tmp_path / "go"
    go.touch()
    try:
        run = subprocess.run([sys.executable, "-c", _FIRST_RUN, str(go)],
                             env=_env(tmp_path / "a"), stdout=subprocess.PIPE, stderr=slave,
                             text=True, timeout=600, check=True)  # fmt: skip
        os.close(slave)
        heard = b""
        while True:
            try:
                chunk = os.read(master, 4096)
            except OSError:  # the terminal's other end is closed: all read
                break
            if not chunk:
                break
            heard += chunk
    finally:
        os.close(master)
    assert "'written'" in run.stdout
    notice = [ln for ln in heard.decode().splitlines() if ln.startswith("mett: compiling")]
    assert len(notice) == 1 and "the Taylor kernel" in notice[0] and "mett warmup" in notice[0]


def test_a_run_with_user_events_does_not_go_to_taylor():
    # Next to the pole θ̇ changes sign twice per nutation period and Taylor's long steps (looked at
    # in a few points each) can hold both zeros: the rolling top at θ0 = 1e-8 (the separation
    # tests' check) has 5+ zeros of θ̇ in 1.2 s that a Taylor run misses some of
    assert _chosen(TOP, model="rolling") == "taylor"
    assert _chosen(TOP, model="rolling", events=[lambda t, s: s.thetadot]) == "compiled"
