"""The models' parameter tuples share one prefix order (m, R, l | α, I1, I3, μ, g).

Every registered model must have an entry in ``CASES``; its tuple, built from a top whose fields
all have distinct values, must hold each field at its named position of
:mod:`mett.dynamics._params`. A model that put g where μ belongs (as the dry models once did)
fails here, since g ≠ μ.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

import mett
from mett import State, Trajectory
from mett.dynamics import _params as ix
from mett.dynamics.contact import LAW_COULOMB, LAW_REGULARISED
from mett.dynamics.registry import MODELS
from mett.dynamics.resistance import RollingResistance
from mett.friction import Coulomb, RegularisedCoulomb

# every field distinct (and distinct from the law's μ), so that a swap of any two shows
TOP = mett.TippeTop(m=0.0151, R=0.0152, alpha=0.31, I1=1.41e-6, I3=1.32e-6, mu=0.27, g=9.79)
MU_DRY = 0.43  # the dry law's μ (dimensionless), ≠ TOP.mu
R_S, L_S = 0.0051, 0.0163  # stem sphere radius and distance (m)
STEM = {"stem_radius": R_S, "stem_distance": L_S}
BAND = 3.3e-7  # stopping band (m/s)
COULOMB = Coulomb(MU_DRY)
CONTENSOU = Coulomb(MU_DRY, contensou_radius=0.0009)
REGULARISED = RegularisedCoulomb(MU_DRY, eps=2.1e-4)
ROLLING = RollingResistance(1.7e-4, omega_eps=0.23)

# name: (options, μ expected at MU, True if slot 2 holds α (Euler forms) instead of l = R α)
CASES = {
    "gliding": ({}, TOP.mu, False),
    "rolling": ({}, TOP.mu, False),
    "gliding-hst": ({}, TOP.mu, False),
    "cylinder": ({}, TOP.mu, True),
    "gliding-euler": ({}, TOP.mu, True),
    "frictionless-routhian": ({"vertical_cm": False}, 0.0, True),
    "coulomb": ({"friction": COULOMB, "stopping_band": BAND}, MU_DRY, False),
    "coulomb-contensou": ({"friction": CONTENSOU, "stopping_band": BAND}, MU_DRY, False),
    "coulomb-regularised": ({"friction": REGULARISED}, MU_DRY, False),
    "stemmed": (STEM, TOP.mu, False),
    "stemmed-coulomb": ({"friction": COULOMB, "stopping_band": BAND, **STEM}, MU_DRY, False),
    "stemmed-coulomb-contensou": (
        {"friction": CONTENSOU, "stopping_band": BAND, **STEM},
        MU_DRY,
        False,
    ),
    "stemmed-coulomb-regularised": ({"friction": REGULARISED, **STEM}, MU_DRY, False),
    "rolling-resistance": ({"friction": ROLLING}, TOP.mu, False),
}


def test_every_registered_model_has_a_case():
    assert set(CASES) == set(MODELS)


@pytest.mark.parametrize("name", sorted(CASES))
def test_the_shared_prefix_holds_the_top_fields_by_name(name):
    options, mu, euler = CASES[name]
    p = MODELS[name].parameters(TOP, **options)
    assert p[ix.M] == TOP.m
    assert p[ix.R] == (0.0 if name == "gliding-hst" else TOP.R)  # the heavy top: R = 0
    if euler:
        assert p[ix.ALPHA] == TOP.alpha
    else:
        assert p[ix.L] == TOP.R * TOP.alpha
    assert p[ix.I1] == TOP.I1
    assert p[ix.I3] == TOP.I3
    assert p[ix.MU] == mu
    assert p[ix.G] == TOP.g
    assert ix.prefix(p) == tuple(p[: ix.PREFIX])


def test_the_dry_tail_by_name():
    p = MODELS["coulomb-contensou"].parameters(TOP, friction=CONTENSOU, stopping_band=BAND)
    assert (p[ix.RSTAR], p[ix.EPS], p[ix.LAW], p[ix.BAND]) == (
        CONTENSOU.r_star,
        0.0,
        LAW_COULOMB,
        BAND,
    )
    assert len(p) == ix.BAND + 1
    p = MODELS["coulomb-regularised"].parameters(TOP, friction=REGULARISED)
    assert (p[ix.RSTAR], p[ix.EPS], p[ix.LAW]) == (0.0, REGULARISED.eps, LAW_REGULARISED)
    # without an rtol the band is 1e-9 of √(g R)
    assert p[ix.BAND] == 1e-9 * math.sqrt(TOP.g * TOP.R)


def test_the_stem_tails_by_name():
    p = MODELS["stemmed"].parameters(TOP, **STEM)
    assert (p[ix.R_S], p[ix.L_S]) == (R_S, L_S) and len(p) == ix.L_S + 1
    p = MODELS["stemmed-coulomb"].parameters(TOP, friction=COULOMB, stopping_band=BAND, **STEM)
    assert (p[ix.DRY_R_S], p[ix.DRY_L_S]) == (R_S, L_S) and len(p) == ix.DRY_L_S + 1
    assert p[ix.BAND] == BAND
    p = MODELS["stemmed-coulomb-regularised"].parameters(TOP, friction=REGULARISED, **STEM)
    assert (p[ix.R_S], p[ix.L_S], p[ix.STEM_EPS]) == (R_S, L_S, REGULARISED.eps)
    assert len(p) == ix.STEM_EPS + 1


def test_the_rolling_resistance_and_routhian_tails_by_name():
    p = MODELS["rolling-resistance"].parameters(TOP, friction=ROLLING)
    assert (p[ix.MU_R], p[ix.W_EPS]) == (ROLLING.mu_r, ROLLING.omega_eps)
    assert len(p) == ix.W_EPS + 1
    for vertical, flag in ((True, 1.0), (False, 0.0)):
        p = MODELS["frictionless-routhian"].parameters(TOP, vertical_cm=vertical)
        assert p[ix.VERTICAL] == flag and len(p) == ix.VERTICAL + 1


@pytest.mark.parametrize(
    ("name", "options"),
    [
        ("coulomb", {"friction": COULOMB, "stopping_band": BAND}),
        ("stemmed-coulomb", {"friction": COULOMB, "stopping_band": BAND, **STEM}),
        ("rolling-resistance", {"friction": ROLLING}),
        ("frictionless-routhian", {"vertical_cm": True}),
    ],
)
def test_a_tuple_in_the_order_before_the_shared_prefix_is_mapped(name, options):
    """Files written before stored (…, I3, g, μ, …), and the Routhian (…, I3, g, vertical)."""
    p = MODELS[name].parameters(TOP, **options)
    if name == "frictionless-routhian":
        old = (*p[:5], p[ix.G], p[ix.VERTICAL])
    else:
        old = (*p[:5], p[ix.G], p[ix.MU], *p[ix.PREFIX :])
    assert old != p
    assert ix.from_legacy(name, old) == p


def test_no_legacy_order_for_models_that_always_had_the_shared_one():
    p = MODELS["gliding"].parameters(TOP)
    assert ix.from_legacy("gliding", p) is None
    assert ix.from_legacy("frictionless-routhian", (1.0,) * 8) is None  # today's length


DATA = Path(__file__).parent / "data"


def test_a_file_saved_in_the_order_before_loads_with_the_shared_order():
    # written by an older mett (tests/data/README.md): its params have g (9.82) before μ (0.3)
    path = DATA / "format2_stemmed_coulomb.npz"
    with np.load(path, allow_pickle=False) as data:
        saved = json.loads(str(data["mett_trajectory"]))["params"]
    assert (saved[5], saved[6]) == (9.82, 0.3)
    loaded = Trajectory.load(path)
    assert (loaded.params[ix.MU], loaded.params[ix.G]) == (0.3, 9.82)
    assert loaded.params == MODELS["stemmed-coulomb"].parameters(loaded.top, **loaded.options)


def test_a_routhian_file_of_the_order_before_loads(tmp_path):
    # the Routhian's tuple had no μ: (m, R, α, I1, I3, g, vertical)
    traj = mett.simulate(
        TOP, State(theta=0.5, omega3=100.0), 1e-3, model="frictionless-routhian", backend="scipy"
    )
    path = traj.save(tmp_path / "routhian.npz")
    with np.load(path, allow_pickle=False) as data:
        files = {k: np.array(data[k]) for k in data.files}
    meta = json.loads(str(files["mett_trajectory"]))
    p = meta["params"]
    meta["params"] = [*p[:5], p[ix.G], p[ix.VERTICAL]]
    files["mett_trajectory"] = np.array(json.dumps(meta))
    np.savez(path, **files)
    loaded = Trajectory.load(path)
    assert loaded.params == traj.params and len(loaded.params) == ix.VERTICAL + 1
    assert np.array_equal(loaded.states, traj.states)
    # a tuple in neither order is still refused
    meta["params"] = [*p[:5], p[ix.G] * 2.0, p[ix.VERTICAL]]
    files["mett_trajectory"] = np.array(json.dumps(meta))
    np.savez(path, **files)
    with pytest.raises(ValueError, match="params"):
        Trajectory.load(path)
