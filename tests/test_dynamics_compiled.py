"""The compiled backend of simulate (numba DOP853 + compiled right-hand sides) against the scipy one.

Both backends run DOP853 with the same tableau, error norm and step-size controller, and the
compiled right-hand sides are compiled from the very functions the scipy backend calls
(mett.dynamics._kernels), so the two agree to rounding: the same number of steps (their times
differ by the rounding of the controller's error estimate, a difference of nearly equal sums), the
same event times, the same states at equal times. Measured when written, thesis run (8 s,
rtol 1e-10): first θ = π/2 crossing 3e-13 s apart, θ on the dense output 9e-12 apart, θ, ω3, E,
D, λ at the end 2e-14 apart (relative), 2630 steps each, step times up to 6e-10 s apart; contact
loss of the thrown top 1e-17 s apart; user event times 6e-14 s apart.
"""

from __future__ import annotations

import dataclasses
import math
import subprocess
import sys

import numba
import numpy as np
import pytest

import mett
from mett.dynamics import MODELS, _kernels, simulate

RTOL = 1e-10


@pytest.fixture(scope="module")
def top() -> mett.TippeTop:
    return mett.presets.get("rutstam2013")


def _random_model_state(name: str, rng: np.random.Generator) -> mett.State:
    theta = rng.uniform(0.05, math.pi - 0.05)
    if name == "cylinder":
        return mett.State(theta=theta, thetadot=rng.normal(0, 5), nu_x=rng.normal(0, 0.3))
    if name == "rolling":
        return mett.State(
            theta=theta,
            thetadot=rng.normal(0, 5),
            phidot=rng.normal(0, 20),
            omega3=rng.normal(0, 150),
        )
    return mett.State(
        theta=theta,
        thetadot=rng.normal(0, 5),
        phidot=rng.normal(0, 20),
        omega3=rng.normal(0, 150),
        nu_x=rng.normal(0, 0.3),
        nu_y=rng.normal(0, 0.3),
    )


# --- the compiled right-hand sides are the Python ones, compiled ------------------------------


# options a model cannot run without (the dry-friction models need their law)
_NEEDED = {
    "coulomb": {"friction": mett.friction.Coulomb(0.3)},
    "coulomb-contensou": {"friction": mett.friction.Coulomb(0.3, contensou_radius=3e-3)},
    "coulomb-regularised": {"friction": mett.friction.RegularisedCoulomb(0.3, eps=1e-3)},
    "rolling-resistance": {"friction": mett.dynamics.resistance.RollingResistance(1e-4)},
}


# the stemmed models need their stem options and have a phase per contact: their contract classes
# in test_model_contract.py check compiled == Python for each phase
@pytest.mark.parametrize("name", [n for n in MODELS if not n.startswith("stemmed")])
def test_compiled_rhs_and_events_equal_the_python_model(name, top):
    model = MODELS[name]
    rhs, events = _kernels.compiled(model)
    rng = np.random.default_rng(17)
    worst = 0.0
    for _ in range(50):
        p = model.parameters(top, **_NEEDED.get(name, {}))
        y = np.asarray(model.initial(_random_model_state(name, rng), p), dtype=float)
        # off the constraint manifold too: an unnormalised axis, a moved CM
        y = y * (1.0 + 1e-3 * rng.normal(size=y.size))
        ref = np.asarray(model.rhs(0.0, y, p), dtype=float)
        out = np.empty(y.size)
        rhs(0.0, y, np.array(p), out)
        worst = max(worst, float(np.max(np.abs(out - ref)) / np.max(np.abs(ref))))
        g = np.empty(len(model.events))
        events(0.0, y, np.array(p), g)
        assert model.events[0].action == "contact_lost"
        assert g[0] == pytest.approx(model.normal_force(y, p) / (top.m * top.g), rel=1e-15)
        for k, ev in enumerate(model.events):
            assert g[k] == pytest.approx(ev.fn(0.0, y, p), rel=1e-15, abs=1e-300)
    assert worst <= 1e-15  # measured 0: the same IEEE operations in the same order


def test_every_model_has_a_compiled_twin_and_import_mett_does_not_load_numba():
    assert all(m.rhs_into is not None for m in MODELS.values())
    code = (
        "import sys, mett, mett.dynamics; "
        "assert 'numba' not in sys.modules and 'mett.dynamics._kernels' not in sys.modules"
    )
    subprocess.run([sys.executable, "-c", code], check=True)


# --- the thesis run on both backends ----------------------------------------------------------


@pytest.fixture(scope="module")
def thesis_pair(top):
    s = mett.State(theta=0.1, omega3=155.0)
    comp = simulate(top, s, 8.0, rtol=RTOL, backend="compiled")
    ref = simulate(top, s, 8.0, rtol=RTOL, backend="scipy")
    return comp, ref


def test_the_pair_ran_compiled_and_scipy(thesis_pair):
    comp, ref = thesis_pair
    assert comp.backend == "compiled" and ref.backend == "scipy"


def test_thesis_run_agrees_between_backends(thesis_pair):
    comp, ref = thesis_pair
    assert comp.status == ref.status == "completed"
    assert comp.message == ref.message
    # the same steps and the same work; the step times agree to the rounding of the controller
    # (its error estimate is a difference of nearly equal sums: measured 6e-10 s)
    assert len(comp) == len(ref) and comp.nfev == ref.nfev
    assert np.max(np.abs(comp.t - ref.t)) < 1e-8
    t_comp, t_ref = comp.crossings(math.pi / 2), ref.crossings(math.pi / 2)
    assert t_comp.size == t_ref.size >= 1
    assert abs(t_comp[0] - t_ref[0]) < 1e-8  # measured 3e-13 s
    end_c, end_r = comp.states[:, -1], ref.states[:, -1]
    assert np.max(np.abs(end_c - end_r) / np.abs(end_r)) < 1e-9  # measured 8e-11
    for k in ("theta", "omega3", "E", "E_mod", "D", "lam"):
        assert getattr(comp, k)[-1] == pytest.approx(getattr(ref, k)[-1], rel=1e-9), k
    # dense output between the steps
    tt = np.linspace(0.0, 8.0, 1601)
    assert np.max(np.abs(comp.theta_at(tt) - ref.theta_at(tt))) < 1e-9


# --- status and events ------------------------------------------------------------------------


@pytest.mark.parametrize("model", ["gliding", "gliding-euler"])
def test_contact_loss_time_agrees_between_backends(top, model):
    # the thrown top of test_dynamics_models: g_n reaches 0 after ~0.0197 s
    s = mett.State(theta=0.5, thetadot=80.0)
    comp = simulate(top, s, 1.0, model=model, backend="compiled", stop_on_contact_loss=True)
    ref = simulate(top, s, 1.0, model=model, backend="scipy", stop_on_contact_loss=True)
    assert comp.backend == "compiled"
    assert comp.status == ref.status == "contact_lost"
    assert comp.t_contact_lost == pytest.approx(ref.t_contact_lost, abs=1e-12)
    assert comp.t[-1] == comp.t_contact_lost
    assert abs(comp.gn[-1]) < 1e-9 * top.m * top.g
    assert comp.message == ref.message


def test_pole_guard_of_the_euler_form_agrees_between_backends(top):
    s = mett.State(theta=1e-5, thetadot=-1.0, omega3=155.0)
    comp = simulate(top, s, 0.1, model="gliding-euler", backend="compiled")
    ref = simulate(top, s, 0.1, model="gliding-euler", backend="scipy")
    assert comp.status == ref.status == "failed"
    assert "singular at sin(theta) = 0" in comp.message
    assert comp.t[-1] == pytest.approx(ref.t[-1], abs=1e-12)


_GLIDING_RHS = _kernels.compiled(MODELS["gliding"])[0]


@numba.njit(cache=True, error_model="numpy")
def _rhs_blowing_up_after_0p1(t, y, p, out):
    _GLIDING_RHS(t, y, p, out)
    if t > 0.1:
        for i in range(out.size):
            out[i] = out[i] / (t - t)  # ±inf or nan; compiled code must not raise ZeroDivisionError


def test_non_finite_rhs_is_a_failed_status_on_both_backends(top):
    s = mett.State(theta=0.1, omega3=155.0)
    good = MODELS["gliding"]
    blowing_up = dataclasses.replace(good, rhs_into=_rhs_blowing_up_after_0p1)
    comp = simulate(top, s, 1.0, model=blowing_up)
    assert comp.backend == "compiled"
    assert comp.status == "failed"
    assert "integrator failed at t = 0.1" in comp.message
    assert comp.t[-1] == pytest.approx(0.1, abs=1e-3)
    assert np.all(np.isfinite(comp.theta))

    def broken(t, y, p):
        return good.rhs(t, y, p) / (t - t) if t > 0.1 else good.rhs(t, y, p)

    python_only = dataclasses.replace(good, rhs=broken, rhs_into=None)
    ref = simulate(top, s, 1.0, model=python_only)
    assert ref.backend == "scipy"  # no compiled twin: "auto" runs scipy
    assert ref.status == "failed" and "integrator failed at t = 0.1" in ref.message
    assert comp.t[-1] == pytest.approx(ref.t[-1], abs=1e-12)
    with pytest.raises(ValueError, match="no compiled right-hand side"):
        simulate(top, s, 1.0, model=python_only, backend="compiled")


def _events():
    def half_spin(t, state):
        return state.omega3 - 154.9

    def tilt_up(t, state):
        return state.theta - 0.0999

    tilt_up.direction = 1.0

    def tilt(t, state):
        return state.theta - 0.0999

    def stop_at_0p8(t, state):
        return t - 0.8

    stop_at_0p8.terminal = True
    return [half_spin, tilt_up, tilt, stop_at_0p8]


@pytest.mark.parametrize("t_eval", [None, np.linspace(0.0, 1.0, 11)])
def test_user_events_agree_between_backends(top, t_eval):
    # Evaluated after the compiled run on its steps and dense output; scipy during the run.
    s = mett.State(theta=0.1, omega3=155.0)
    comp = simulate(top, s, 1.0, t_eval=t_eval, events=_events(), backend="compiled")
    ref = simulate(top, s, 1.0, t_eval=t_eval, events=_events(), backend="scipy")
    assert comp.backend == "compiled"
    assert comp.status == ref.status == "completed"
    assert "terminal event 3" in comp.message and comp.message == ref.message
    assert comp.t[-1] == pytest.approx(0.8, abs=1e-12) and comp.t_final == ref.t_final
    assert comp.t.size == ref.t.size
    assert np.max(np.abs(comp.t - ref.t)) < 1e-8  # steps: same to rounding of the controller
    tt = np.linspace(0.0, 0.8, 801)
    assert np.max(np.abs(comp.states_at(tt) - ref.states_at(tt))) < 1e-12 * np.max(
        np.abs(ref.states)
    )
    assert len(comp.t_events) == 4
    for te_c, te_r in zip(comp.t_events, ref.t_events, strict=True):
        assert te_c.size == te_r.size
        assert np.max(np.abs(te_c - te_r), initial=0.0) < 1e-10
    up, both = comp.t_events[1], comp.t_events[2]
    assert 1 <= up.size < both.size and np.all(np.isin(up, both))
    assert np.all(comp.at(up).thetadot > 0)
    # the cut trajectory ends at the terminal event, and so does its dense output
    with pytest.raises(ValueError, match="simulated interval"):
        comp.at(0.9)
    assert comp.crossings(0.0999).max() < 0.8


# --- backend selection -------------------------------------------------------------------------


def test_backend_selection(top):
    s = mett.State(theta=0.1, omega3=155.0)
    assert simulate(top, s, 0.01).backend == "taylor"  # auto: tests/test_auto.py
    assert simulate(top, s, 0.01, method="RK45").backend == "scipy"  # auto: other methods on scipy
    assert simulate(top, s, 0.01, backend="scipy").backend == "scipy"
    with pytest.raises(ValueError, match="compiled backend implements method 'DOP853' only"):
        simulate(top, s, 0.01, method="RK45", backend="compiled")
    with pytest.raises(ValueError, match="unknown backend 'numba'; known backends: auto"):
        simulate(top, s, 0.01, backend="numba")


@pytest.mark.parametrize(
    ("model", "state", "kw"),
    [
        ("rolling", mett.State(theta=1.0, omega3=100.0, phidot=5.0), {}),
        ("cylinder", mett.State(theta=0.5, nu_x=0.05), {}),
        (
            "gliding-hst",
            mett.State(theta=2.6, thetadot=0.5, phidot=2.0, omega3=250.0, nu_x=0.02, nu_y=-0.01),
            {"l": 0.01},
        ),
        ("gliding-euler", mett.State(theta=1.0, omega3=100.0, phidot=5.0, nu_x=0.01), {}),
    ],
)
def test_every_model_agrees_between_backends(top, model, state, kw):
    comp = simulate(top, state, 0.5, model=model, backend="compiled", **kw)
    ref = simulate(top, state, 0.5, model=model, backend="scipy", **kw)
    assert comp.backend == "compiled"
    assert comp.status == ref.status == "completed"
    assert comp.nfev == ref.nfev and len(comp) == len(ref)
    # compared at equal times: the step times themselves agree only to the rounding of the
    # step-size controller (its error estimate is a difference of nearly equal sums)
    tt = np.linspace(0.0, 0.5, 501)
    scale = np.max(np.abs(ref.states), axis=1, keepdims=True)
    assert np.max(np.abs(comp.states_at(tt) - ref.states_at(tt)) / scale) < 1e-11


def test_a_kernel_reading_the_parameter_positions_names_their_file_in_its_cache():
    # numba freezes module constants (ix.MU, ...) into the machine code and stamps its cache with
    # the kernel's own file only: the file of the positions must be part of the cache name, or an
    # edit of it would leave kernels compiled with the old positions in the cache
    from mett.dynamics import _params, gliding

    fn = next(f for f in vars(gliding).values() if callable(f) and "ix" in getattr(
        getattr(f, "__code__", None), "co_names", ()))  # fmt: skip
    compiled = _kernels._jit(fn)
    assert _params.__file__ in _kernels._DEPS[compiled]
    assert compiled.py_func.__qualname__.split("__")[-1] != _kernels._CACHE_TAG  # a hash follows


def test_a_kernel_call_is_compiled_once_and_called_not_inlined():
    # registry.kernel_call: the dry contact force is one compiled function that every event of a
    # phase calls (inlined, it was compiled once per event: tens of seconds of CPU per phase);
    # the caller's cache name still covers the callee's file, whose code it links in
    from mett.dynamics import contact, stemslip

    assert getattr(contact.stick, "kernel_call", False)
    caller = _kernels._jit(stemslip._ball_rolling_into)
    env = caller.py_func.__globals__
    assert isinstance(env["stick"], numba.core.dispatcher.Dispatcher)
    assert env["stick"].targetoptions.get("inline", "never") == "never"
    assert env["stick"].targetoptions.get("_nrt") is False  # no atomic refcounts per call
    assert env["_write"].targetoptions.get("inline") == "always"  # unmarked: inlined
    assert contact.__file__ in _kernels._DEPS[caller]
    inner = env["stick"].py_func.__globals__
    assert inner["kinematics"].targetoptions.get("inline") == "always"


@pytest.mark.parametrize(
    ("name", "owner"),
    [("coulomb-contensou", "coulomb"), ("stemmed-coulomb-contensou", "stemmed-coulomb")],
)
def test_models_that_differ_in_parameters_alone_share_their_event_kernels(name, owner):
    # the same phase functions: one events kernel on disk, named the same whichever model a
    # process compiles first (else each was compiled again in every process that ran the other)
    for model in (MODELS[name], MODELS[owner]):
        for ph in model.phase_table():
            if ph.events:
                assert _kernels._kernel_owner(model, ph, _kernels._phase_key(ph)) == owner
    assert _kernels._kernel_owner(MODELS["gliding"], MODELS["gliding"].phase_table()[0],
                                  _kernels._phase_key(MODELS["gliding"].phase_table()[0])) == "gliding"  # fmt: skip
