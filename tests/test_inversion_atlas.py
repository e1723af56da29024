"""mett.inversion.atlas: the friction-law atlas, with Coulomb–Contensou.

References: mett.predict_inversion itself for the grid's bookkeeping (the atlas is that prediction
on a grid), and the full compiled Coulomb–Contensou simulation for atlas points, within the
reduction's declared accuracy (docs/theory/inversion.md#coulombcontensou).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import mett
from mett.friction import Coulomb
from mett.inversion import atlas, predict_inversion

LAWS = ("viscous", "regularised-coulomb", "coulomb", "coulomb-contensou")


@pytest.fixture(scope="module")
def thesis():
    return mett.presets.get("rutstam2013")


def test_atlas_covers_every_law_with_labelled_arrays(thesis):
    mus, spins = [0.1, 0.3], [155.0, 400.0, 1000.0]
    res = atlas(thesis, mus, spins, laws=LAWS, contensou_radius=3e-3)
    assert tuple(res) == LAWS
    for name, grid in res.items():
        assert set(grid) == {"t_half", "t_inv", "inverts", "outside", "lam_end"}, name
        for key, arr in grid.items():
            assert arr.shape == (2, 3), (name, key)
        assert set(np.unique(grid["inverts"])) <= {-1.0, 0.0, 1.0}
        assert np.all(grid["outside"][grid["inverts"] != 0] | (name == "viscous"))
        assert np.all(np.isinf(grid["t_inv"][grid["inverts"] != 1]))
    # λ is conserved by a force at the contact point; only the drilling torque lowers it
    for name in ("viscous", "regularised-coulomb"):
        np.testing.assert_array_equal(res[name]["lam_end"], 1.0)
    assert np.all(np.isnan(res["coulomb"]["lam_end"]))  # the slip stops: no slow path
    cc = res["coulomb-contensou"]
    assert np.all(cc["lam_end"] < 1.0)
    # each entry is the prediction for that (μ, ω3) with the stated disc (uniform pressure)
    state = mett.State.with_cm_at_rest(thesis, theta=0.1, omega3=400.0)
    p = predict_inversion(thesis, state, Coulomb(0.3, contensou_radius=3e-3))
    assert cc["t_half"][1, 1] == p.t_half
    assert cc["inverts"][1, 1] == (-1 if p.inverts is None else float(p.inverts))
    # a smaller disc: a smaller drilling torque, λ falls less on the way
    small = atlas(thesis, mus, spins, laws=("coulomb-contensou",), contensou_radius=5e-4)
    assert np.all(small["coulomb-contensou"]["lam_end"] > cc["lam_end"])


@pytest.mark.parametrize(("kwargs", "name"), [({"contensou_radius": 0.0}, "contensou_radius"),
                                              ({"contensou_radius": -1e-3}, "contensou_radius"),
                                              ({"eps": 0.0}, "eps")])  # fmt: skip
def test_atlas_refuses_a_bad_law_parameter(thesis, kwargs, name):
    with pytest.raises(ValueError, match=name):
        atlas(thesis, [0.3], [155.0], laws=LAWS, **kwargs)


# Atlas points on the table (no lift-off before π/2; the hopping points are early by 10–40 %,
# docs/theory/inversion.md#the-friction-law-atlas-which-law-inverts-which-top-and-when):
# (μ, ω3, r, θ0). One inverts, one falls back.
POINTS = [(0.3, 155.0, 5e-4, 0.03), (0.3, 155.0, 3e-3, 0.1)]


@pytest.mark.parametrize(("mu", "omega3", "r", "theta0"), POINTS)
def test_contensou_atlas_points_match_simulation(thesis, mu, omega3, r, theta0):
    # Reference: the full Coulomb–Contensou simulation (compiled DOP853, rtol 1e-8) from the
    # atlas's start (centre of mass at rest). Tolerance: the declared accuracy of t_half, 6 % +
    # one nutation period for θ0 <= 0.03 and 12 % + one period for θ0 <= 0.1; the outcome
    # (θ within tol of π or not) must be the atlas's.
    res = atlas(thesis, [mu], [omega3], laws=("coulomb-contensou",), theta0=theta0,
                contensou_radius=r)["coulomb-contensou"]  # fmt: skip
    t_half, t_inv, code = res["t_half"][0, 0], res["t_inv"][0, 0], res["inverts"][0, 0]
    assert code in (0.0, 1.0)
    state = mett.State.with_cm_at_rest(thesis, theta=theta0, omega3=omega3)
    traj = mett.simulate(thesis, state, 1.5 * (t_inv if code == 1 else 2 * t_half),
                         friction=Coulomb(mu, contensou_radius=r), rtol=1e-8,
                         stop_on_contact_loss=True)  # fmt: skip
    assert traj.status == "completed"
    t_sim = traj.crossings(0.5 * math.pi)[0]
    T_n = 2 * math.pi * thesis.I1 / (thesis.I3 * omega3)
    accuracy = 0.06 if theta0 <= 0.03 else 0.12
    assert abs(t_half - t_sim) <= accuracy * t_sim + T_n
    assert (float(np.max(traj.theta)) >= math.pi - 0.05) is bool(code == 1)
