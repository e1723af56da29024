"""Bad input that used to slip past the checks: models and friction laws, array states,
submodule bounds, end-state labels (docs/reliability.md, "Bad input: the remaining gaps").

Each test states what the user gets instead of a raw exception, a numpy warning or a wrong
label; the references are the documented rules (ValueError/TypeError naming the argument),
never mett's own earlier output.
"""

from __future__ import annotations

import math
import subprocess
import sys
import warnings

import numpy as np
import pytest

import mett
from mett.dynamics import MODELS
from mett.dynamics.simulation import check_run
from mett.friction import Coulomb, RegularisedCoulomb, Viscous

TOP = mett.presets.get("rutstam2013")
S = mett.State(theta=0.1, omega3=155.0)

LAWS = {
    "none": None,
    "viscous": Viscous(0.3),
    "coulomb": Coulomb(0.3),
    "contensou": Coulomb(0.3, contensou_radius=1e-3),
    "regularised": RegularisedCoulomb(0.3, eps=1e-3),
}


# --- F11: every model names the friction law it needs, before any work --------------------------


COULOMB = "friction=mett.friction.Coulomb(mu)"
VISCOUS = "friction=None (the top's mu) or mett.friction.Viscous(mu)"
STEM = "stem_radius and stem_distance"


@pytest.mark.parametrize(
    ("model", "law", "message"),
    [
        ("coulomb", None, f"model 'coulomb' needs {COULOMB}; got None"),
        ("coulomb", Viscous(0.3), f"model 'coulomb' needs {COULOMB}; got Viscous"),
        ("coulomb", RegularisedCoulomb(0.3, 1e-3), f"model 'coulomb' needs {COULOMB}; got Reg"),
        ("coulomb-contensou", RegularisedCoulomb(0.3, 1e-3), "model 'coulomb-contensou' needs"),
        ("coulomb-contensou", None, f"model 'coulomb-contensou' needs {COULOMB}; got None"),
        (
            "coulomb-regularised",
            Coulomb(0.3),
            "model 'coulomb-regularised' needs friction=mett.friction.RegularisedCoulomb(mu, eps)",
        ),
        ("stemmed-coulomb", None, f"model 'stemmed-coulomb' needs {COULOMB}; got None"),
        ("stemmed-coulomb", Viscous(), f"model 'stemmed-coulomb' needs {COULOMB}"),
        ("stemmed-coulomb", Coulomb(0.3), f"model 'stemmed-coulomb' needs {STEM}"),
        (
            "stemmed-coulomb-contensou",
            Coulomb(0.3),
            f"model 'stemmed-coulomb-contensou' needs {STEM}",
        ),
        ("rolling", Coulomb(0.3), f"model 'rolling' takes {VISCOUS}; got Coulomb"),
        ("gliding-hst", Coulomb(0.3), f"model 'gliding-hst' takes {VISCOUS}; got Coulomb"),
    ],
)
def test_a_model_without_its_friction_law_is_a_value_error_naming_both(model, law, message):
    with pytest.raises(ValueError) as info:
        mett.simulate(TOP, S, 0.01, model=model, friction=law)
    assert message in str(info.value)


@pytest.mark.parametrize("law", LAWS, ids=list(LAWS))
@pytest.mark.parametrize("model", list(MODELS))
def test_every_model_and_law_pair_runs_or_is_refused_with_value_or_type_error(model, law):
    """No AttributeError (or any other exception) for any pairing: the check is complete."""
    for top in (TOP, TOP.with_stem(0.004, 0.02)):
        try:
            check_run(top, S, 1e-3, model=model, friction=LAWS[law])
        except (ValueError, TypeError):
            pass


def test_a_stemmed_top_names_the_laws_it_takes():
    from mett.dynamics.resistance import RollingResistance

    with pytest.raises(ValueError, match=r"model 'stemmed' takes friction=None .*Viscous.*Coulomb"):
        mett.simulate(TOP.with_stem(0.004, 0.02), S, 0.01, friction=RollingResistance(1e-4))
    # the regularised law has its stemmed model
    tr = mett.simulate(TOP.with_stem(0.004, 0.02), S, 0.01, friction=LAWS["regularised"])
    assert tr.model == "stemmed-coulomb-regularised"


def test_a_sweep_of_a_dry_model_without_a_law_is_refused_before_any_run(tmp_path):
    ckpt = tmp_path / "sweep.jsonl"
    with pytest.raises(ValueError, match="model 'coulomb' needs friction="):
        mett.sweep(TOP, {"lam_ratio": [0.5, 1.0]}, t_end=0.01, model="coulomb", checkpoint=ckpt)
    assert not ckpt.exists()  # refused before the checkpoint was opened


def test_the_cli_refuses_a_dry_model_without_a_law_in_one_line():
    cmd = [sys.executable, "-m", "mett", "simulate", "--preset", "rutstam2013", "--model",
           "coulomb", "--theta0", "0.1", "--omega3", "155", "--t-end", "0.01"]  # fmt: skip
    res = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    assert res.returncode == 2
    assert "Traceback" not in res.stderr
    assert "model 'coulomb' needs friction=" in res.stderr


def test_a_required_option_is_checked_before_a_friction_law_it_does_not_concern():
    # the option's own message first, as for any other option
    with pytest.raises(ValueError, match="stopping_band"):
        mett.simulate(TOP, S, 0.01, model="coulomb", stopping_band=-1e-9)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        tr = mett.simulate(TOP, S, 0.01, model="coulomb", friction=Coulomb(0.3))
    assert tr.status == "completed"


# --- F8: Coulomb(0) is frictionless sliding, on every backend, also at a pole ----------------------

RTOL = 1e-10  # simulate's default
T_POLE = 0.2  # s


@pytest.mark.parametrize("backend", ["scipy", "compiled", "taylor"])
@pytest.mark.parametrize("theta0", [0.0, 5e-324, 1e-300, math.pi - 1e-15, math.pi, 0.5])
def test_coulomb_mu_zero_is_the_frictionless_gliding_top_on_every_backend(backend, theta0):
    """μ = 0 is a friction cone of radius 0: frictionless sliding throughout, no switch.

    The reference is the "gliding" model with μ = 0 (its own equations, with L_z in the state
    where the stick–slip model carries λ), integrated at rtol = 1e-12. Both conserve E exactly,
    so E may drift by the integration error only; the contact-point velocity ν and θ agree to the
    global error of two rtol-controlled runs, K rtol × scale with K = 100 for the accumulation of
    local errors over the run (scale: R|ω3| for ν, 1 rad for θ). At a pole every start used to
    stop the scipy backend (a 0/0 restart direction, a Brent sign error) and gave the Taylor
    backend spurious "reversal" switches of margin −inf.
    """
    nu_x = 0.01 if theta0 == 0.5 else 0.0  # one generic, slipping start besides the poles
    state = mett.State(theta=theta0, omega3=155.0, nu_x=nu_x)
    t_eval = np.linspace(0.0, T_POLE, 21)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no RuntimeWarning either
        run = mett.simulate(TOP, state, T_POLE, friction=Coulomb(0.0), backend=backend,
                            t_eval=t_eval)  # fmt: skip
        ref = mett.simulate(TOP, state, T_POLE, friction=Viscous(0.0), t_eval=t_eval, rtol=1e-12)
    assert run.status == "completed", run.message
    assert run.switches == [] and set(run.phase) == {"sliding"}
    assert np.all(run.margin <= 0.0)  # the sliding force on a zero cone: μ g_n − |F_t| = 0
    np.testing.assert_array_equal(run.F_x, 0.0)
    np.testing.assert_array_equal(run.F_y, 0.0)
    E0 = ref.E[0]
    assert np.max(np.abs(run.E - E0)) <= 100 * RTOL * E0
    v_scale = TOP.R * 155.0
    for name in ("nu_x", "nu_y"):
        np.testing.assert_allclose(getattr(run, name), getattr(ref, name), rtol=0,
                                   atol=100 * RTOL * v_scale, err_msg=name)  # fmt: skip
    np.testing.assert_allclose(run.theta, ref.theta, rtol=0, atol=100 * RTOL)


def test_stemmed_coulomb_mu_zero_impacts_are_the_frictionless_ones():
    """Through five touchdowns and landings, Coulomb(0) on a stemmed top is the stemmed model
    with μ = 0 (frictionless Darboux–Keller impacts, its own impact code): the same impact times,
    no tangential impulse, and θ to the global error of the runs (1000 rtol: ten impacts, each
    located to the integration tolerance, with the error growth between them). Stops at 0.25 s,
    before a touchdown that grazes the stem by 1e-11 rad (a measure-zero tangency)."""
    ball = mett.TippeTop(m=0.006, R=0.015, alpha=0.2, I1=8e-7, I3=7e-7, mu=0.3)
    top = ball.with_stem(radius=0.005, distance=0.016)
    state = mett.State(theta=2.2, thetadot=8.0, phidot=110.0, omega3=-76.0, nu_y=0.16)
    t_eval = np.linspace(0.0, 0.25, 26)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        run = mett.simulate(top, state, 0.25, friction=Coulomb(0.0), t_eval=t_eval)
        ref = mett.simulate(top, state, 0.25, friction=Viscous(0.0), t_eval=t_eval, rtol=1e-12)
    assert run.status == "completed" and ref.touchdowns.size == 5
    np.testing.assert_allclose(run.touchdowns, ref.touchdowns, rtol=0, atol=1e-9)
    assert all(math.isnan(s.margin) for s in run.switches)  # no cone at μ = 0
    np.testing.assert_allclose(run.theta, ref.theta, rtol=0, atol=1000 * RTOL)


# --- F15: an array state obeys the type rules of State's fields ------------------------------------

_GOOD = [0.1, 0.0, 0.0, 155.0, 0.0, 0.0]


@pytest.mark.parametrize(
    ("value", "shown"),
    [
        (["0.1", "0", "0", "155", "0", "0"], "str"),
        ([b"0.1", b"0", b"0", b"155", b"0", b"0"], "S"),
        (np.array([True, False, False, True, False, False]), "bool"),
        ([0.1, True, 0.0, 155.0, 0.0, 0.0], "bool"),
        (np.array(_GOOD, dtype=complex), "complex"),
        ([0.1, 0.0, 0.0, 155.0 + 1e-3j, 0.0, 0.0], "complex"),
        ([0.1, None, 0.0, 155.0, 0.0, 0.0], "None"),
        (None, "None"),
    ],
)
def test_an_array_state_of_non_numbers_is_a_type_error_naming_the_argument(value, shown):
    """As ``State(thetadot=True)`` is: a string is not parsed, a boolean is not 1, an imaginary
    part is not dropped, None is not NaN."""
    with pytest.raises(TypeError, match=r"^y must be (a )?real numbers?; got .*" + shown):
        mett.State.from_array(value)
    with pytest.raises(TypeError, match=r"^state must be (a )?real numbers?; got .*" + shown):
        mett.simulate(TOP, value, 0.01)


def test_an_array_state_of_real_numbers_is_the_state():
    assert mett.State.from_array(_GOOD) == mett.State(theta=0.1, omega3=155.0)
    assert mett.State.from_array(np.array([0, 0, 0, 155, 0, 0])) == mett.State(0.0, omega3=155.0)
    with pytest.raises(
        ValueError, match="state must be a State or an array of leading dimension 6"
    ):
        mett.simulate(TOP, [0.1, 0.0, 155.0], 0.01)
    with pytest.raises(ValueError, match="thetadot must be finite; got nan"):
        mett.State.from_array([0.1, math.nan, 0.0, 155.0, 0.0, 0.0])


# --- F19: the submodules' bounds ------------------------------------------------------------------


def test_a_stem_contact_top_has_the_bounds_of_a_top():
    from mett.stem import StemContactTop

    big = dict(m=1e300, R=1e300, alpha=1e300, I1=1e300, I3=1e300)
    with pytest.raises(ValueError, match=r"^m must lie in \[1e-50, 1e\+50\] kg; got 1e\+300"):
        StemContactTop(**big)
    ok = dict(m=0.02, R=0.005, I1=3e-6, I3=3.2e-6)
    with pytest.raises(ValueError, match=r"^alpha must lie in \(0, 1e\+50\]"):
        StemContactTop(alpha=1e60, **ok)  # α at most 1e50
    with pytest.raises(ValueError, match=r"^alpha must lie in \(0, 1e\+40\]"):
        StemContactTop(alpha=1e45, **{**ok, "R": 1e10})  # α R = 1e55 m: beyond 1e50 m
    with pytest.raises(ValueError, match=r"^g must lie in \[1e-50, 1e\+50\]"):
        StemContactTop(alpha=5.0, g=1e60, **ok)
    # the extreme corner that is allowed computes without overflow
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        corner = StemContactTop(m=1e50, R=1e-50, alpha=1e50, I1=1e50, I3=1e50, g=1e50)
        assert math.isfinite(corner.lambda_0) and corner.lambda_thres > 0.0
        assert corner.subgroup in mett.classification.SUBGROUPS


@pytest.mark.parametrize(
    ("radius", "distance", "message"),
    [
        (1e300, 3e300, r"^radius must lie in \[1e-50, 1e\+50\] m; got 1e\+300"),
        (5e-324, 0.021, r"^radius must lie in \[1e-50, 1e\+50\] m; got 5e-324"),
        (0.005, 1e60, r"^distance must lie in \[1e-50, 1e\+50\] m; got 1e\+60"),
        (1e-50, 1e50, r"^radius and distance must keep the top on its stem within mett's range"),
    ],
)
def test_with_stem_names_the_arguments_the_user_passed(radius, distance, message):
    """Never 'alpha must be finite' about the stem top's α the user never gave."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no overflow RuntimeWarning on the way
        with pytest.raises(ValueError, match=message):
            TOP.with_stem(radius, distance)


def test_classify_bounds_alpha_and_gamma_instead_of_overflowing():
    from mett.classification import classify

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(ValueError, match=r"^alpha must lie in \(0, 1e\+100\]; got 1e\+300"):
            classify(1e300, 0.9)
        with pytest.raises(ValueError, match=r"^gamma must lie in \(0, 1e\+100\]; got 1e\+300"):
            classify(0.3, 1e300)
        # at the bounds: γ ≥ 1 + α is group III (module table), computed without overflow
        assert str(classify(1e99, 1e100)) == "III"
        assert str(classify(0.3, 1e100)) == "III"


def test_classify_end_refuses_a_nan_end_angle_of_a_completed_run():
    from decimal import Decimal

    from mett.sweeps import classify_end

    for bad in (math.nan, Decimal("NaN"), math.inf):
        with pytest.raises(ValueError, match="theta_end must be finite"):
            classify_end(bad, "completed")
    with pytest.raises(ValueError, match=r"theta_end must lie in \[0, pi\]"):
        classify_end(4.0, "completed")
    with pytest.raises(TypeError, match="status must be a str"):
        classify_end(0.0, None)
    # a run that did not complete is labelled by its status, whatever its θ (NaN at a failure)
    assert classify_end(math.nan, "failed") == "failed"
    assert classify_end(Decimal("3.14159"), "completed") == "inverted"
    assert classify_end(0.0, "completed") == "upright"


def test_rtol_beyond_a_percent_is_refused_before_any_work():
    with pytest.raises(ValueError, match=r"^rtol must lie in \[2\.22e-14, 0\.01\]"):
        mett.simulate(TOP, S, 1.0, rtol=0.9999)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no numpy RuntimeWarning at the loosest rtol accepted
        for backend in ("compiled", "scipy"):
            run = mett.simulate(TOP, S, 0.5, rtol=1e-2, backend=backend)
            assert run.status == "completed"
