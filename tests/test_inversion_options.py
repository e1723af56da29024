"""predict_inversion's accuracy/speed options: ``start`` and ``hops`` (docs/theory/inversion.md#speed).

``start="linear"`` is checked against the linear split computed here directly (LAPACK's
eigen-decomposition of the upright spin's Jacobian, not the compiled QR iteration the library
uses); ``start="linear", hops=False`` is checked to run no simulation of the full model (the part
of a prediction whose cost grows with ω3 and with the number of nutations).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import mett
from mett.inversion import STARTS, _hops, _nutation, atlas, predict_inversion
from mett.stability import spin_jacobian

HORIZONTAL = [2, 3, 4, 5, 7, 8]  # ẋ, ẏ, L_x, L_y, 3̂_x, 3̂_y in the gliding model's state


@pytest.fixture(scope="module")
def fast_spin():
    # Thesis top, μ = 0.05 s/m, ω3 = 620 rad/s, θ0 = 0.1 with the centre of mass at rest: a large
    # tilt whose resolved growing part is 8× below the linear split's
    # (docs/theory/inversion.md#speed): the two options must give different starts.
    top = mett.presets.get("rutstam2013", mu=0.05)
    return top, mett.State.with_cm_at_rest(top, theta=0.1, omega3=620.0)


def _linear_split(top, state) -> tuple[float, float]:
    """The growing pair's amplitude (rad) in the start, and the bound of its rounding error.

    The start's horizontal deviation from the upright spin with the same λ (zero there) in the
    eigenvectors of the horizontal block of the Jacobian (numpy's eig); the size of the growing
    pair's 3̂_x, 3̂_y rows. The projection onto the growing pair does not depend on the basis, so
    two eigen-solvers agree to rounding times the eigenbasis's condition number.
    """
    lam = float(mett.jellett(top, state))
    J = spin_jacobian(top, lam, "upright")[np.ix_(HORIZONTAL, HORIZONTAL)]
    ev, V = np.linalg.eig(J)
    y = mett.simulate(top, state, 1e-6).states_at([0.0])[HORIZONTAL, 0]
    c = np.linalg.solve(V, y)
    grow = np.argsort(-ev.real, kind="stable")[:2]
    assert ev[grow[0]].real > 0.0 and ev[grow[0]] == pytest.approx(ev[grow[1]].conjugate())
    amp = float(np.linalg.norm(V[4:6][:, grow] * c[grow]))
    return amp, 1e3 * np.finfo(float).eps * np.linalg.cond(V)


def test_linear_start_is_the_linear_split(fast_spin):
    # The slow path starts on the growing mode's amplitude: with start="linear" the linear split's,
    # with "auto" the resolved start's (a run of the full model past the slip's transient),
    # which differs from it by far more than the split's rounding.
    top, state = fast_spin
    amp, err = _linear_split(top, state)
    linear = predict_inversion(top, state, start="linear", hops=False)
    auto = predict_inversion(top, state, hops=False)
    assert linear.theta[0] == pytest.approx(amp, rel=err)
    assert abs(auto.theta[0] / amp - 1.0) > 0.3
    # a later start: the linear split overestimates the growing part here
    assert auto.t_half > linear.t_half
    assert linear.inverts is True and auto.inverts is True


def test_small_tilt_gives_the_same_prediction_either_way():
    # θ0 <= SMALL_TILT: "auto" keeps the linear split, so both options are the same computation.
    top = mett.presets.get("rutstam2013", mu=0.05)
    state = mett.State.with_cm_at_rest(top, theta=0.02, omega3=310.0)
    a = predict_inversion(top, state, hops=False)
    b = predict_inversion(top, state, start="linear", hops=False)
    assert (a.t_start, a.t_half, a.t_inv, a.t_lift) == (b.t_start, b.t_half, b.t_inv, b.t_lift)
    assert a.theta[0] == pytest.approx(_linear_split(top, state)[0], rel=1e-6)


def test_fast_options_run_no_simulation(fast_spin, monkeypatch):
    # The resolved start and the hop windows are runs of the full model, whose cost grows with
    # ω3 and with the nutations resolved; with start="linear", hops=False neither may run, even
    # where the top is predicted to hop before π/2 (t_lift < t_half at this spin).
    def boom(*args, **kwargs):
        raise AssertionError("a simulation ran")

    top, state = fast_spin
    monkeypatch.setattr(mett.dynamics.simulation, "simulate", boom)
    monkeypatch.setattr(mett.dynamics, "simulate", boom)
    monkeypatch.setattr(_hops, "hopping_times", boom)
    monkeypatch.setattr(_nutation, "resolved_start", boom)
    p = predict_inversion(top, state, start="linear", hops=False)
    assert p.t_lift < p.t_half  # the hopping branch is reached, and skipped
    assert any("predicted to hop" in n for n in p.validity.notes)
    with pytest.raises(AssertionError, match="a simulation ran"):
        predict_inversion(top, state, start="auto", hops=False)
    with pytest.raises(AssertionError, match="a simulation ran"):
        predict_inversion(top, state, start="linear", hops=True)


@pytest.mark.parametrize("bad", ["Linear", "resolved", "", "auto "])
def test_unknown_start_is_a_value_error(fast_spin, bad):
    top, state = fast_spin
    with pytest.raises(ValueError, match=r"start must be one of \('auto', 'linear'\)"):
        predict_inversion(top, state, start=bad)
    with pytest.raises(ValueError, match="start must be one of"):
        atlas(top, [0.05], [155.0], start=bad)


@pytest.mark.parametrize("bad", [None, 1, b"linear", ("linear",)])
def test_start_of_another_type_is_a_type_error(fast_spin, bad):
    top, state = fast_spin
    with pytest.raises(TypeError, match="start must be a str"):
        predict_inversion(top, state, start=bad)
    with pytest.raises(TypeError, match="start must be a str"):
        atlas(top, [0.05], [155.0], start=bad)


@pytest.mark.parametrize("bad", [None, 1, "False", np.bool_(True)])
def test_hops_must_be_a_bool(fast_spin, bad):
    top, state = fast_spin
    with pytest.raises(TypeError, match="hops must be a bool"):
        predict_inversion(top, state, hops=bad)
    with pytest.raises(TypeError, match="hops must be a bool"):
        atlas(top, [0.05], [155.0], hops=bad)


def test_atlas_passes_the_options_through():
    top = mett.presets.get("rutstam2013", mu=0.05)
    res = atlas(top, [0.05], [155.0, 620.0], start="linear", hops=False)["viscous"]
    for j, w in enumerate((155.0, 620.0)):
        state = mett.State.with_cm_at_rest(top, theta=0.1, omega3=w)
        want = predict_inversion(top, state, mett.friction.Viscous(0.05), start="linear",
                                 hops=False)  # fmt: skip
        assert res["t_half"][0, j] == want.t_half


# --- mett predict --start / --hops ----------------------------------------------------------------
PREDICT = ["predict", "--preset", "rutstam2013", "--mu", "0.05", "--theta0", "0.1", "--omega3",
           "620", "--cm-at-rest", "--json"]  # fmt: skip


def _call(argv, capsys):
    from mett.cli import main

    try:
        code = main(argv)
    except SystemExit as exc:  # argparse's usage errors
        code = exc.code
    out = capsys.readouterr()
    return code, out.out, out.err


def test_cli_start_and_hops_reach_the_prediction(fast_spin, capsys):
    top, state = fast_spin
    code, out, err = _call([*PREDICT, "--start", "linear", "--no-hops"], capsys)
    assert code == 0, err
    got = json.loads(out)
    want = predict_inversion(top, state, start="linear", hops=False)
    assert got["t_half"] == want.t_half and got["t_lift"] == want.t_lift
    code, out, err = _call([*PREDICT, "--start", "auto", "--no-hops"], capsys)
    assert code == 0, err
    assert (
        json.loads(out)["t_half"] == predict_inversion(top, state, hops=False).t_half != want.t_half
    )


def test_cli_hops_flag_default_is_on(capsys):
    # --hops is the default: the parsed namespace passes True, --no-hops False
    from mett.cli import _build_parser

    parser = _build_parser()
    assert parser.parse_args(PREDICT).hops is True
    assert parser.parse_args([*PREDICT, "--no-hops"]).hops is False
    assert parser.parse_args([*PREDICT, "--hops"]).hops is True
    assert parser.parse_args(PREDICT).start == "auto" and STARTS == ("auto", "linear")


@pytest.mark.parametrize("value", ["nope", "Linear", ""])
def test_cli_unknown_start_is_one_line_exit_2(value, capsys):
    code, _, err = _call([*PREDICT, "--start", value], capsys)
    assert code == 2, err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1, err
    assert "--start" in err


def test_start_leaves_a_non_viscous_law_alone():
    # The resolved start is the viscous law's (gyroscopic method); the regularised Coulomb law's
    # prediction is the linear split's either way.
    top = mett.presets.get("rutstam2013")
    state = mett.State.with_cm_at_rest(top, theta=0.1, omega3=155.0)
    law = mett.friction.RegularisedCoulomb(0.3, 0.01)
    a = predict_inversion(top, state, law, hops=False)
    b = predict_inversion(top, state, law, start="linear", hops=False)
    assert a.t_half == b.t_half and math.isfinite(a.t_half)
