"""Bad input that used to slip past the checks: models and friction laws, array states,
submodule bounds, end-state labels (docs/reliability.md, "Bad input: the remaining gaps").

Each test states what the user gets instead of a raw exception, a numpy warning or a wrong
label; the references are the documented rules (ValueError/TypeError naming the argument),
never mett's own earlier output.
"""

from __future__ import annotations

import subprocess
import sys
import warnings

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
    with pytest.raises(ValueError, match=r"model 'stemmed' takes friction=None .*Viscous.*Coulomb"):
        mett.simulate(TOP.with_stem(0.004, 0.02), S, 0.01, friction=LAWS["regularised"])


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
